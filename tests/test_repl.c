/*
 * test_repl.c -- replacement policies against naive references.
 *
 * The reference (tests/naive_cache.h, shared with test_mcore.c) is one cache
 * per size kept as plain arrays: for every set,
 * `ways` entries (tag, valid, dirty, last writer's class and generation)
 * and, per policy, the obvious state: FIFO the round-robin hand (the way
 * filled longest ago, since ways fill in order). Lookups are linear scans; nothing is
 * shared with the engine but the accounting rules of docs/cachesim.md (a
 * reference touches each line it covers; misses, write-backs charged to
 * the last writer, write-through bytes, no-write-allocate, full-line and
 * streaming stores). Each policy is compared counter by counter (per size,
 * class and generation) on random streams of three kinds and on the
 * reference streams of ray tracers, fully associative and set-associative,
 * with the engine's invariant checker running along; hand-computed cases
 * pin the policies' choices on short sequences.
 */
#include "check.h"
#include "engine.h"
#include "hier.h"
#include "run.h"
#include "sim.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "naive_cache.h"

/* ---- streams ------------------------------------------------------------ */

static uint64_t rs = 0x243F6A8885A308D3ULL;
static uint64_t rnd(void)
{
    rs ^= rs << 13;
    rs ^= rs >> 7;
    rs ^= rs << 17;
    return rs;
}

enum { GEN_RANDOM, GEN_ZIPF, GEN_CYCLIC };

static void gen(rt_access *a, size_t n, int kind, uint64_t footprint)
{
    static const uint32_t sizes[] = {1, 4, 8, 8, 32, 36, 64, 100};
    uint64_t cyc = 0;
    for (size_t i = 0; i < n; i++) {
        uint64_t r = rnd(), unit;
        if (kind == GEN_RANDOM) unit = r % footprint;
        else if (kind == GEN_ZIPF) {
            double u = (double)(r >> 11) / 9007199254740992.0;
            unit = (uint64_t)(footprint * u * u * u);
        } else unit = (r & 15) == 0 ? (r >> 8) % (footprint * 2) : cyc++ % footprint;
        a[i].addr = 0x4000000ULL + unit * 64 + ((r >> 40) & 63);
        a[i].size = sizes[(r >> 48) % 8];
        a[i].write = ((r >> 52) & 7) < 3;
        if (a[i].write && (r >> 4) % 5 == 0) a[i].write = RT_WRITE_STREAM;
        a[i].cls = (uint8_t)((r >> 56) % RT_NCLASS);
        a[i].gen = (uint8_t)((r >> 20) % 9);
    }
}

typedef struct capture {
    rt_access *a;
    size_t n, cap;
} capture;

static int cap_put(rt_sink *s, const rt_access *a, size_t n)
{
    capture *c = s->ctx;
    if (c->n + n > c->cap) {
        size_t nc = (c->n + n) * 2;
        rt_access *na = realloc(c->a, nc * sizeof *na);
        if (!na) return -1;
        c->a = na;
        c->cap = nc;
    }
    memcpy(c->a + c->n, a, n * sizeof *a);
    c->n += n;
    return 0;
}

/* The reference stream of tracer on scene spec at W x H, whitted. */
static capture trace_stream(const char *spec, const char *tracer, int W, int H)
{
    capture cap = {0};
    rt_render_opts o;
    rt_run_stats st;
    rt_err e = {0};
    rt_job j;
    rt_render_default_opts(&o);
    o.W = W, o.H = H;
    o.mode = RT_MODE_WHITTED;
    o.lights = 7;
    rt_sink sink = {cap_put, &cap};
    if (rt_job_setup(&j, spec, tracer, &o, &e) < 0) {
        CHECK(0, "%s %s: %s", spec, tracer, e.msg);
        return cap;
    }
    rt_image *im = rt_image_new(W, H, &e);
    CHECK(im && rt_job_run(&j, &sink, im, &st, &e) == 0, "trace %s %s: %s", spec, tracer, e.msg);
    rt_image_free(im);
    rt_job_free(&j);
    return cap;
}

/* ---- comparison --------------------------------------------------------- */

static int same(const rt_sim_counts *x, const rt_sim_counts *y) { return !memcmp(x, y, sizeof *x); }

/* Runs a[0..n) through the engine of c and through naive caches of policy
 * pol, one per size; compares every counter. Returns the total traffic of
 * the largest size (so callers can compare policies). */
static uint64_t compare(const char *name, int pol, const rt_sim_config *c, const rt_access *a, size_t n)
{
    rt_err e = {0};
    rt_sim *s = rt_sim_new(c, &e);
    CHECK(s, "%s: rt_sim_new: %s", name, e.msg);
    if (!s) return 0;
    for (size_t i = 0; i < n; i += 2048) {
        rt_sim_put(s, a + i, n - i < 2048 ? n - i : 2048);
        if ((i / 2048) % 16 == 0) CHECK(rt_sim_check(s, &e) == 0, "%s: invariant: %s", name, e.msg);
    }
    rt_sim_finish(s);
    CHECK(rt_sim_check(s, &e) == 0, "%s: invariant after finish: %s", name, e.msg);
    uint64_t misses = 0, last = 0;
    for (int i = 0; i < c->nsizes; i++) {
        naive *nv = naive_new(pol, c, c->sizes[i]);
        naive_put(nv, a, n);
        if (c->flush) naive_flush(nv);
        for (int k = 0; k < RT_NCLASS; k++)
            for (int g = -1; g < RT_MAXGEN; g++) {
                rt_sim_counts x, y;
                if (g < 0) rt_sim_get(s, i, k, &x);
                else rt_sim_get_gen(s, i, k, g, &x);
                naive_get(nv, k, g, &y);
                if (g < 0) misses += x.read_misses + x.write_misses;
                if (g < 0 && i == c->nsizes - 1) last += x.traffic_bytes;
                CHECK(same(&x, &y),
                      "%s: size %llu class %s gen %d: engine rm %llu wm %llu wb %llu wt %llu, naive rm %llu wm %llu "
                      "wb %llu wt %llu",
                      name, (unsigned long long)c->sizes[i], rt_class_name(k), g, (unsigned long long)x.read_misses,
                      (unsigned long long)x.write_misses, (unsigned long long)x.writebacks,
                      (unsigned long long)x.wt_bytes, (unsigned long long)y.read_misses,
                      (unsigned long long)y.write_misses, (unsigned long long)y.writebacks,
                      (unsigned long long)y.wt_bytes);
            }
        naive_free(nv);
    }
    CHECK(misses > 0, "%s: no misses at all: the comparison proves nothing", name);
    rt_sim_free(s);
    return last;
}

static int repl_of(const char *name)
{
    int r = -1;
    rt_err e = {0};
    CHECK(rt_sim_repl_parse(name, &r, &e) == 0, "parse %s: %s", name, e.msg);
    return r;
}

/* Every policy on random streams and tracer streams, fully associative and
 * 4-way, with the write policies mixed in. */
static void test_against_naive_n(const char *pname, int pol, const capture *tr, size_t ntr, size_t N)
{
    rt_access *a = malloc(N * sizeof *a);
    static const char *const kinds[3] = {"random", "zipf", "cyclic"};
    static const uint64_t fp[3] = {400, 1500, 200};
    for (int v = 0; v < 4; v++) {
        rt_sim_config c;
        rt_sim_config_default(&c);
        CHECK(rt_sim_parse_sizes(v < 2 ? "1K-16K" : "2K,4K,16K", &c, NULL) == 0, "sizes");
        c.repl = repl_of(pname);
        c.seed = 7;
        c.assoc = v & 1 ? 4 : 0;
        c.flush = v == 1;
        c.write_through = v == 2;
        c.no_write_allocate = v == 3;
        c.write_miss_fullline = v == 0;
        for (int k = 0; k < 3; k++) {
            gen(a, N, k, fp[k]);
            char name[96];
            snprintf(name, sizeof name, "%s/%s/assoc%u/v%d", pname, kinds[k], c.assoc, v);
            compare(name, pol, &c, a, N);
        }
        for (size_t t = 0; t < ntr; t++) {
            char name[96];
            snprintf(name, sizeof name, "%s/tracer%zu/assoc%u/v%d", pname, t, c.assoc, v);
            compare(name, pol, &c, tr[t].a, tr[t].n);
        }
    }
    free(a);
}

static void test_against_naive(const char *pname, int pol, const capture *tr, size_t ntr)
{
    test_against_naive_n(pname, pol, tr, ntr, 25000);
}

/* ---- hand-computed cases ------------------------------------------------ */

/* Misses of a fully associative cache of `lines` 64-byte lines on the
 * lines named by the letters of seq. */
static uint64_t misses_n(const char *pname, uint64_t lines, const char *seq)
{
    rt_sim_config c;
    rt_sim_config_default(&c);
    c.nsizes = 1;
    c.sizes[0] = 64 * lines;
    c.repl = repl_of(pname);
    rt_sim *s = rt_sim_new(&c, NULL);
    for (const char *p = seq; *p; p++) {
        rt_access a = {0};
        a.addr = (uint64_t)(*p - 'A') * 64;
        a.size = 4;
        rt_sim_put(s, &a, 1);
    }
    rt_sim_counts t;
    rt_sim_get(s, 0, 0, &t);
    rt_sim_free(s);
    return t.read_misses;
}

static uint64_t misses2(const char *pname, const char *seq) { return misses_n(pname, 2, seq); }

static void test_by_hand(void)
{
    /* SRRIP: A B hit (RRPV 0), C D fill at 2; E finds no 3, ages all by 1
     * (A B 1, C D 3), evicts C; F evicts D; A B still hit: 6 misses. LRU
     * loses A and B to the scan: 8. PLRU (nodes: root, left pair, right
     * pair; a bit points at the half to evict): A B C D fill ways 0-3, the
     * root then points left, the left pair at A: E evicts A (root now
     * right, the right pair at C): F evicts C (root left, left pair at
     * B): A evicts B, B evicts D: 8 as well, by another path. */
    CHECK(misses_n("lru", 4, "ABABCDEFAB") == 8, "lru scan: %llu", (unsigned long long)misses_n("lru", 4, "ABABCDEFAB"));
    CHECK(misses_n("srrip", 4, "ABABCDEFAB") == 6, "srrip scan: %llu",
          (unsigned long long)misses_n("srrip", 4, "ABABCDEFAB"));
    CHECK(misses_n("plru", 4, "ABABCDEFAB") == 8, "plru scan: %llu",
          (unsigned long long)misses_n("plru", 4, "ABABCDEFAB"));
    /* with two ways PLRU is LRU */
    CHECK(misses2("plru", "ABACA") == 3, "plru ABACA");
    CHECK(misses2("srrip", "ABACA") == 3, "srrip ABACA");
    /* PLRU differs from LRU with 4 ways: after A B C D and the hit on A,
     * LRU's E evicts B, then B evicts C and C evicts D: 7 misses; PLRU's
     * root points right and the right pair at C, so E evicts C, B hits and
     * C evicts D: 6 */
    CHECK(misses_n("lru", 4, "ABCDAEBC") == 7, "lru ABCDAEBC: %llu", (unsigned long long)misses_n("lru", 4, "ABCDAEBC"));
    CHECK(misses_n("plru", 4, "ABCDAEBC") == 6, "plru ABCDAEBC: %llu",
          (unsigned long long)misses_n("plru", 4, "ABCDAEBC"));
    /* A B A C A: LRU keeps A (C evicts B): 3 misses; FIFO evicts A, the
     * oldest, for C, so the last A misses: 4 */
    CHECK(misses2("lru", "ABACA") == 3, "lru ABACA: %llu", (unsigned long long)misses2("lru", "ABACA"));
    CHECK(misses2("fifo", "ABACA") == 4, "fifo ABACA: %llu", (unsigned long long)misses2("fifo", "ABACA"));
    /* FIFO's hand wraps: A B C(evicts A) D(evicts B) C hits, A misses (evicts C) */
    CHECK(misses2("fifo", "ABCDCA") == 5, "fifo ABCDCA: %llu", (unsigned long long)misses2("fifo", "ABCDCA"));
}

/* ---- OPT: brute force and the floor ------------------------------------ */

/* The fewest misses any replacement can have on lines seq[from..n) of a
 * fully associative cache of cap lines holding res[0..nres): tries every
 * victim. */
static int brute_min(const int *seq, int from, int n, int *res, int nres, int cap)
{
    if (from == n) return 0;
    int L = seq[from];
    for (int i = 0; i < nres; i++)
        if (res[i] == L) return brute_min(seq, from + 1, n, res, nres, cap);
    if (nres < cap) {
        res[nres] = L;
        int m = 1 + brute_min(seq, from + 1, n, res, nres + 1, cap);
        return m;
    }
    int best = n + 1;
    for (int i = 0; i < nres; i++) {
        int old = res[i];
        res[i] = L;
        int m = 1 + brute_min(seq, from + 1, n, res, nres, cap);
        res[i] = old;
        if (m < best) best = m;
    }
    return best;
}

static void test_opt_brute(void)
{
    rt_access a[14];
    int seq[14], res[8];
    for (int trial = 0; trial < 200; trial++) {
        int n = 8 + (int)(rnd() % 7), lines = 3 + (int)(rnd() % 4), cap = 2 + (int)(rnd() % 2);
        memset(a, 0, sizeof a);
        for (int i = 0; i < n; i++) {
            seq[i] = (int)(rnd() % (uint64_t)lines);
            a[i].addr = (uint64_t)seq[i] * 64;
            a[i].size = 8;
        }
        rt_sim_config c;
        rt_sim_config_default(&c);
        c.nsizes = 1;
        c.sizes[0] = 64 * (uint64_t)cap;
        c.repl = repl_of("opt");
        rt_sim *s = rt_sim_new(&c, NULL);
        rt_sim_put(s, a, (size_t)n);
        rt_sim_finish(s);
        rt_sim_counts t;
        rt_sim_get(s, 0, 0, &t);
        int want = brute_min(seq, 0, n, res, 0, cap);
        CHECK(t.read_misses == (uint64_t)want, "opt trial %d: %llu misses, brute force %d", trial,
              (unsigned long long)t.read_misses, want);
        rt_sim_free(s);
    }
}

/* Misses (read + write) of size i summed over the classes. */
static uint64_t all_misses(rt_sim *s, int i)
{
    uint64_t m = 0;
    for (int k = 0; k < RT_NCLASS; k++) {
        rt_sim_counts t;
        rt_sim_get(s, i, k, &t);
        m += t.read_misses + t.write_misses;
    }
    return m;
}

/* OPT has no more misses than any policy, at any size, fully and 4-way. */
static void test_opt_floor(const capture *tr, size_t ntr)
{
    enum { N = 6000 };
    rt_access *a = malloc(N * sizeof *a);
    static const char *const pols[] = {"lru", "fifo", "random", "plru", "srrip", "brrip"};
    int streams = 0, strict = 0;
    for (int trial = 0; trial < 24 + (int)ntr; trial++) {
        const rt_access *x = a;
        size_t n = N;
        if (trial < 24) gen(a, N, trial % 3, 50 + rnd() % 600);
        else x = tr[trial - 24].a, n = tr[trial - 24].n;
        for (int assoc = 0; assoc <= 4; assoc += 4) {
            rt_sim_config c;
            rt_sim_config_default(&c);
            CHECK(rt_sim_parse_sizes("1K-16K", &c, NULL) == 0, "sizes");
            c.assoc = (uint32_t)assoc;
            c.seed = (uint64_t)trial;
            c.repl = repl_of("opt");
            rt_sim *o = rt_sim_new(&c, NULL);
            rt_sim_put(o, x, n);
            rt_sim_finish(o);
            rt_err e = {0};
            CHECK(rt_sim_check(o, &e) == 0, "opt invariant: %s", e.msg);
            for (size_t p = 0; p < sizeof pols / sizeof pols[0]; p++) {
                c.repl = repl_of(pols[p]);
                rt_sim *s = rt_sim_new(&c, NULL);
                rt_sim_put(s, x, n);
                rt_sim_finish(s);
                for (int i = 0; i < c.nsizes; i++) {
                    uint64_t mo = all_misses(o, i), mp = all_misses(s, i);
                    CHECK(mo <= mp, "trial %d assoc %d size %llu: opt %llu misses > %s %llu", trial, assoc,
                          (unsigned long long)c.sizes[i], (unsigned long long)mo, pols[p], (unsigned long long)mp);
                    strict += mo < mp;
                }
                rt_sim_free(s);
            }
            rt_sim_free(o);
            streams++;
        }
    }
    CHECK(strict > 0, "opt never beat any policy: the property proves nothing");
    CHECK(streams == 2 * (24 + (int)ntr), "streams compared: %d", streams);
    free(a);
}

/* ---- hierarchies -------------------------------------------------------- */

/* Runs a through hierarchy spec and through a chain of naive caches (each
 * level's recorded output is the next one's input; the last level one
 * naive cache per size); compares every level, size, class, generation. */
static void compare_hier(const char *spec, int flush, const rt_access *a, size_t n)
{
    static const int pol_of[] = {P_LRU, P_FIFO, P_RANDOM, P_PLRU, P_SRRIP, P_BRRIP, P_OPT};
    rt_sim_config base;
    rt_sim_config_default(&base);
    base.flush = flush;
    rt_hier_config hc;
    rt_err e = {0};
    CHECK(rt_hier_parse(spec, &base, &hc, &e) == 0, "parse %s: %s", spec, e.msg);
    rt_hier *h = rt_hier_new(&hc, &e);
    CHECK(h, "%s: %s", spec, e.msg);
    if (!h) return;
    for (size_t i = 0; i < n; i += 3000) {
        rt_hier_put(h, a + i, n - i < 3000 ? n - i : 3000);
        if ((i / 3000) % 8 == 0) CHECK(rt_hier_check(h, &e) == 0, "%s: %s", spec, e.msg);
    }
    rt_hier_finish(h);
    CHECK(rt_hier_check(h, &e) == 0, "%s after finish: %s", spec, e.msg);
    const rt_access *in = a;
    size_t nin = n;
    rt_access *keep = NULL;
    uint64_t last_traffic = 0;
    for (int k = 0; k < hc.nlevels; k++) {
        const rt_sim_config *c = &hc.level[k];
        const rt_sim *s = rt_hier_level(h, k);
        naive *down = NULL;
        for (int i = 0; i < c->nsizes; i++) {
            naive *nv = naive_new(P_LRU, c, c->sizes[i]);
            /* the policy: by name, the naive enum follows the table's order */
            const char *pn = rt_sim_repl_name(c->repl);
            static const char *const names[] = {"lru", "fifo", "random", "plru", "srrip", "brrip", "opt"};
            for (int p = 0; p < 7; p++)
                if (!strcmp(pn, names[p])) nv->pol = pol_of[p];
            nv->below = k + 1 < hc.nlevels;
            naive_put(nv, in, nin);
            if (flush) naive_flush(nv);
            for (int cls = 0; cls < RT_NCLASS; cls++)
                for (int g = -1; g < RT_MAXGEN; g++) {
                    rt_sim_counts x, y;
                    if (g < 0) rt_sim_get(s, i, cls, &x);
                    else rt_sim_get_gen(s, i, cls, g, &x);
                    naive_get(nv, cls, g, &y);
                    if (g < 0 && k == hc.nlevels - 1 && i == c->nsizes - 1) last_traffic += x.traffic_bytes;
                    CHECK(same(&x, &y), "%s: level %s size %llu class %s gen %d: engine acc %llu rm %llu wm %llu wb %llu, "
                          "naive acc %llu rm %llu wm %llu wb %llu", spec, hc.name[k], (unsigned long long)c->sizes[i],
                          rt_class_name(cls), g, (unsigned long long)x.accesses, (unsigned long long)x.read_misses,
                          (unsigned long long)x.write_misses, (unsigned long long)x.writebacks,
                          (unsigned long long)y.accesses, (unsigned long long)y.read_misses,
                          (unsigned long long)y.write_misses, (unsigned long long)y.writebacks);
                }
            if (nv->below) down = nv;
            else naive_free(nv);
        }
        if (down) { /* the next level's input */
            free(keep);
            keep = down->out;
            down->out = NULL;
            in = keep;
            nin = down->nout;
            CHECK(nin > 0, "%s: level %s sent nothing down", spec, hc.name[k]);
            naive_free(down);
        }
    }
    CHECK(last_traffic > 0, "%s: no DRAM traffic", spec);
    free(keep);
    rt_hier_free(h);
}

static void test_hier(const capture *tr, size_t ntr)
{
    enum { N = 20000 };
    rt_access *a = malloc(N * sizeof *a);
    static const char *const specs[] = {
        "L1=2K/2/64/lru,LLC=1K-64K/full/64/lru",
        "L1=1K/full/64/lru,L2=4K/4/64/srrip,LLC=4K-32K/full/64/lru",
        "L1=1K/4/32/fifo,L2=8K/8/64/plru,L3=16K/16/128/brrip,MEM=32K+64K/4/128/random",
        "L1=2K/2/64/lru/wt,L2=8K/4/64/lru/nwa,LLC=16K/full/64/lru",
        "L1=2K/4/64/lru,LLC=4K-16K/4/64/opt",
        "L1=2K/4/64/lru,LLC=4K-32K/full/64/opt",
        "LLC=1K-8K/full/64/lru",
    };
    for (size_t sp = 0; sp < sizeof specs / sizeof specs[0]; sp++)
        for (int flush = 0; flush < 2; flush++) {
            gen(a, N, (int)(sp + flush) % 3, 800);
            compare_hier(specs[sp], flush, a, N);
            compare_hier(specs[sp], flush, tr[flush % ntr].a, tr[flush % ntr].n < 15000 ? tr[flush % ntr].n : 15000);
        }
    free(a);
    /* a one-level hierarchy is the plain simulator */
    rt_sim_config base;
    rt_sim_config_default(&base);
    rt_hier_config hc;
    CHECK(rt_hier_parse("LLC=1K-4M/full/64/lru", &base, &hc, NULL) == 0, "one level");
    CHECK(hc.nlevels == 1 && hc.level[0].nsizes == 13 && !memcmp(hc.level[0].sizes, base.sizes, sizeof base.sizes),
          "one level = the paper's sizes");
    rt_hier *h = rt_hier_new(&hc, NULL);
    CHECK(h && !strcmp(rt_sim_engine(rt_hier_level(h, 0)), "exact-stack"), "one-level LRU is the stack engine");
    rt_hier_free(h);
    /* the brief's spec as written */
    char buf[512];
    rt_err e = {0};
    CHECK(rt_hier_parse("L1=32K/8/64/lru,L2=1M/16/64/srrip,LLC=1K-4M/full/64/lru", &base, &hc, &e) == 0, "spec: %s", e.msg);
    CHECK(!strcmp(rt_hier_spec(&hc, buf, sizeof buf), "L1=32K/8/64/lru,L2=1M/16/64/srrip,LLC=1K-4M/full/64/lru"),
          "spec round trip: %s", buf);
    CHECK(hc.nlevels == 3 && hc.level[0].assoc == 8 && hc.level[1].sizes[0] == 1u << 20 && hc.level[2].nsizes == 13,
          "spec fields");
    /* errors name the level and the field */
    static const char *const bad[][2] = {
        {"L1=32K/8/64", "fields"},          {"L1=1K-4K/full/64/lru,L2=1M/16/64/lru", "only the last level"},
        {"L1=32K/x/64/lru", "ways"},        {"L1=32K/8/64/belady", "unknown replacement policy"},
        {"L1=32K/8/64/lru,L1=1M/full/64/lru", "repeats"}, {"L1=32K/8/64/lru/zz", "unknown flag"},
        {"A=1K/1/64/lru,B=1K/1/64/lru,C=1K/1/64/lru,D=1K/1/64/lru,E=1K/1/64/lru", "more than 4"},
        {"L1=48K/full/64/plru,L2=1M/full/64/lru", "power-of-two"}, {"=1K/1/64/lru", "NAME="},
        {"L1=32K/8/64/opt,L2=1M/full/64/lru", "cannot feed"},
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        memset(&e, 0, sizeof e);
        int rc = rt_hier_parse(bad[i][0], &base, &hc, &e);
        if (rc == 0) {
            rt_hier *x = rt_hier_new(&hc, &e);
            rc = x ? 0 : -1;
            rt_hier_free(x);
        }
        CHECK(rc < 0 && strstr(e.msg, bad[i][1]), "bad spec %s: '%s' (want %s)", bad[i][0], e.msg, bad[i][1]);
    }
}

/* OPT's one-pass run (fully associative, every size at once) against its
 * per-size run (a one-set cache of the same size with ways = lines), all
 * counters, with and without the flush and full-line writes. */
static void test_opt_onepass(const capture *tr)
{
    enum { N = 30000 };
    rt_access *a = malloc(N * sizeof *a);
    for (int v = 0; v < 4; v++) {
        const rt_access *x = a;
        size_t n = N;
        if (v < 3) gen(a, N, v, 400 + 300 * (uint64_t)v);
        else x = tr->a, n = tr->n;
        rt_sim_config c;
        rt_sim_config_default(&c);
        CHECK(rt_sim_parse_sizes("1K-32K", &c, NULL) == 0, "sizes");
        c.repl = repl_of("opt");
        c.flush = v & 1;
        c.write_miss_fullline = v >> 1 & 1;
        rt_sim *all = rt_sim_new(&c, NULL);
        rt_sim_put(all, x, n);
        rt_sim_finish(all);
        for (int i = 0; i < c.nsizes; i++) {
            rt_sim_config d = c;
            d.nsizes = 1;
            d.sizes[0] = c.sizes[i];
            d.assoc = (uint32_t)(c.sizes[i] / c.line); /* one set: the per-size pass */
            rt_sim *one = rt_sim_new(&d, NULL);
            rt_sim_put(one, x, n);
            rt_sim_finish(one);
            for (int k = 0; k < RT_NCLASS; k++)
                for (int g = -1; g < RT_MAXGEN; g++) {
                    rt_sim_counts p, q;
                    if (g < 0) rt_sim_get(all, i, k, &p), rt_sim_get(one, 0, k, &q);
                    else rt_sim_get_gen(all, i, k, g, &p), rt_sim_get_gen(one, 0, k, g, &q);
                    CHECK(same(&p, &q), "opt one-pass v%d size %llu class %s gen %d: rm %llu/%llu wm %llu/%llu wb %llu/%llu",
                          v, (unsigned long long)c.sizes[i], rt_class_name(k), g, (unsigned long long)p.read_misses,
                          (unsigned long long)q.read_misses, (unsigned long long)p.write_misses,
                          (unsigned long long)q.write_misses, (unsigned long long)p.writebacks,
                          (unsigned long long)q.writebacks);
                }
            rt_sim_free(one);
        }
        rt_sim_free(all);
    }
    free(a);
}

/* Each policy's checker passes on the state its hooks make and fails on
 * corrupted state. */
/* the policies' ops (defined in their files, listed in engine.c) */
extern const rt_repl_ops rt_repl_fifo, rt_repl_plru, rt_repl_srrip;

static void test_checkers(void)
{
    uint32_t wv[8], sv[8];
    uint64_t rng = 1;
    rt_repl_set st = {8, wv, sv, &rng};
    rt_err e = {0};
    for (int k = 0; rt_repl_policies[k]; k++) {
        const rt_repl_ops *o = rt_repl_policies[k];
        memset(wv, 0, sizeof wv);
        memset(sv, 0, sizeof sv);
        for (uint32_t w = 0; w < 8; w++) o->fill(&st, w);
        for (int i = 0; i < 50; i++) {
            uint32_t v = o->victim(&st);
            CHECK(v < 8, "%s: victim %u of 8 ways", o->name, v);
            o->fill(&st, v);
            o->hit(&st, (uint32_t)i % 8);
        }
        CHECK(!o->check || o->check(&st, 8, &e) == 0, "%s: check of a sound set: %s", o->name, e.msg);
    }
    /* corruptions each checker must see */
    memset(sv, 0, sizeof sv);
    sv[0] = 8; /* the hand past the last way */
    CHECK(rt_repl_fifo.check(&st, 8, &e) < 0 && strstr(e.msg, "fifo"), "fifo hand not caught");
    sv[0] = 3; /* a hand moved in a set not yet full */
    CHECK(rt_repl_fifo.check(&st, 5, &e) < 0, "fifo hand in a filling set not caught");
    memset(sv, 0, sizeof sv);
    sv[3] = 2; /* a node bit that is not a bit */
    CHECK(rt_repl_plru.check(&st, 8, &e) < 0 && strstr(e.msg, "plru"), "plru node not caught");
    rt_repl_set odd = {6, wv, sv, &rng};
    memset(sv, 0, sizeof sv);
    CHECK(rt_repl_plru.check(&odd, 6, &e) < 0, "plru with 6 ways not caught");
    memset(wv, 0, sizeof wv);
    wv[5] = 4; /* an RRPV beyond 2 bits */
    CHECK(rt_repl_srrip.check(&st, 8, &e) < 0 && strstr(e.msg, "rrip"), "rrip value not caught");
    CHECK(rt_repl_srrip.check(&st, 5, &e) == 0, "rrip: an unfilled way is not checked");
}

static void test_names(void)
{
    int r = 99;
    rt_err e = {0};
    CHECK(rt_sim_repl_parse("lru", &r, &e) == 0 && r == 0, "lru is 0");
    CHECK(rt_sim_repl_parse("nonsense", &r, &e) < 0 && strstr(e.msg, "lru"), "unknown policy: %s", e.msg);
    CHECK(!strcmp(rt_sim_repl_name(0), "lru"), "name of 0");
    CHECK(!strcmp(rt_sim_repl_name(1000), "?"), "name out of range");
    /* every listed name parses back to itself */
    char list[256];
    snprintf(list, sizeof list, "%s", rt_sim_repl_list());
    int count = 0;
    for (char *t = strtok(list, ","); t; t = strtok(NULL, ","), count++)
        CHECK(rt_sim_repl_parse(t, &r, &e) == 0 && !strcmp(rt_sim_repl_name(r), t), "round trip %s", t);
    CHECK(count >= 2, "policies listed: %d", count);
    /* LRU stays on the one-pass engine, other policies on the per-size one */
    rt_sim_config c;
    rt_sim_config_default(&c);
    rt_sim *s = rt_sim_new(&c, NULL);
    CHECK(s && !strcmp(rt_sim_engine(s), "exact-stack"), "lru engine");
    rt_sim_free(s);
    c.repl = repl_of("fifo");
    s = rt_sim_new(&c, NULL);
    CHECK(s && !strcmp(rt_sim_engine(s), "exact-persize"), "fifo engine");
    rt_sim_free(s);
    c.repl = repl_of("opt");
    s = rt_sim_new(&c, NULL);
    CHECK(s && !strcmp(rt_sim_engine(s), "exact-opt"), "opt engine");
    rt_sim_free(s);
    c.repl = -1;
    CHECK(rt_sim_new(&c, &e) == NULL && strstr(e.msg, "replacement"), "bad repl refused: %s", e.msg);
}

int main(void)
{
    test_names();
    test_checkers();
    test_by_hand();
    /* tracer streams: two orders of the same work */
    capture tr[2];
    tr[0] = trace_stream("cornell", "recursive", 12, 10);
    tr[1] = trace_stream("cornell", "dynamic", 12, 10);
    CHECK(tr[0].n > 10000 && tr[1].n > 10000, "tracer streams: %zu, %zu references", tr[0].n, tr[1].n);
    test_against_naive("lru", P_LRU, tr, 2);
    test_against_naive("fifo", P_FIFO, tr, 2);
    test_against_naive("random", P_RANDOM, tr, 2);
    test_against_naive("plru", P_PLRU, tr, 2);
    test_against_naive("srrip", P_SRRIP, tr, 2);
    test_against_naive("brrip", P_BRRIP, tr, 2);
    test_hier(tr, 2);
    test_opt_brute();
    test_opt_onepass(&tr[1]);
    test_opt_floor(tr, 2);
    /* OPT against its naive reference (a forward scan for each next use):
     * short streams, the scan is quadratic */
    {
        capture sh[2];
        for (int t = 0; t < 2; t++) {
            sh[t] = tr[t];
            if (sh[t].n > 6000) sh[t].n = 6000;
        }
        test_against_naive_n("opt", P_OPT, sh, 2, 5000);
    }
    for (int t = 0; t < 2; t++) free(tr[t].a);
    return failures ? 1 : 0;
}
