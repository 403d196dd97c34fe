/*
 * test_mcore.c -- the multi-core hierarchy (cachesim/mcore.h) against a
 * naive reference written from the rules of mcore.h alone: per core one
 * naive cache (tests/naive_cache.h, shared with test_repl.c) per private
 * level, per shared level one naive cache (the last level: one per size),
 * a list of the lines each core's level lost to another core's write,
 * replaying the interleaved stream reference by reference, line touch by
 * line touch, invalidating and downgrading by linear scans.
 *
 *   - random multi-core streams (a small address range, so lines are
 *     shared and written by several cores; reads, writes and streaming
 *     stores; several classes and generations), 1, 2, 3, 8 and 70 cores, on
 *     hierarchies of one to three levels with every replacement policy at
 *     the private levels (lru fifo random plru srrip brrip) and at the
 *     shared ones (those, set-associative, and OPT at the last), a fully
 *     associative LRU last level at several sizes in one pass, the flush
 *     and full-line accounting: every core's counters per level, class and
 *     generation (coherence misses, coherence write-backs, invalidations
 *     included) and every shared level's per size, class and generation
 *     equal the reference's, and rt_mc_check passes;
 *   - one core is the one-core hierarchy (hier.h) to the byte: the traffic
 *     and per-level rows of rt_mc equal rt_hier's on the same stream
 *     (private levels' rows but for their core 0);
 *   - coherence counts on a hand-made two-core stream, by hand;
 *   - the hierarchy spec: the form, default scopes, the CPU
 *     preset, canonical spelling round-trips, bad specs refused naming the
 *     part.
 */
#include "check.h"
#include "engine.h"
#include "mcore.h"
#include "mcore_rows.h"
#include "rows.h"

#include <inttypes.h>

#include "naive_cache.h"

/* ---- the naive machine ---------------------------------------------------- */

enum { NMAXC = 72 }; /* cores of the naive machine: past 63, the model's sharer filter shares bits */

typedef struct lostset {
    uint64_t *l;
    size_t n, cap;
} lostset;

typedef struct nmachine {
    int ncores, np, ns;
    uint32_t line;
    naive *priv[NMAXC][RT_HIER_MAXLEVELS];
    lostset lost[NMAXC][RT_HIER_MAXLEVELS];
    uint64_t coh[NMAXC][RT_HIER_MAXLEVELS][RT_NCLASS][RT_MAXGEN];
    uint64_t inv[NMAXC][RT_HIER_MAXLEVELS][RT_NCLASS][RT_MAXGEN];
    uint64_t cwb[NMAXC][RT_NCLASS][RT_MAXGEN];
    rt_access *sh; /* the stream the shared levels see */
    size_t nsh, capsh;
    naive *shared[RT_HIER_MAXLEVELS][RT_SIM_MAXSIZES]; /* shared level s, size i */
    int nsz[RT_HIER_MAXLEVELS];
} nmachine;

static int pol_of(int repl)
{
    static const char *const names[] = {"lru", "fifo", "random", "plru", "srrip", "brrip", "opt"};
    for (int i = 0; i < 7; i++)
        if (!strcmp(rt_sim_repl_name(repl), names[i])) return i;
    return -1;
}

static void lost_add(lostset *s, uint64_t L)
{
    for (size_t i = 0; i < s->n; i++)
        if (s->l[i] == L) return;
    if (s->n == s->cap) s->l = realloc(s->l, (s->cap = s->cap ? 2 * s->cap : 64) * sizeof *s->l);
    s->l[s->n++] = L;
}

static int lost_take(lostset *s, uint64_t L)
{
    for (size_t i = 0; i < s->n; i++)
        if (s->l[i] == L) {
            s->l[i] = s->l[--s->n];
            return 1;
        }
    return 0;
}

static void sh_emit(nmachine *M, const rt_access *a)
{
    if (M->nsh == M->capsh) M->sh = realloc(M->sh, (M->capsh = M->capsh ? 2 * M->capsh : 4096) * sizeof *M->sh);
    M->sh[M->nsh++] = *a;
}

static void coh_wb(nmachine *M, int k, uint64_t L, int cls, int g)
{
    M->cwb[k][cls][g]++;
    rt_access a = {L * M->line, M->line, 1, (uint8_t)cls, (uint8_t)g};
    sh_emit(M, &a);
}

static void n_downgrade(nmachine *M, int self, uint64_t L)
{
    for (int k = 0; k < M->ncores; k++) {
        if (k == self) continue;
        int dirty = 0, dc = 0, dg = 0;
        for (int p = 0; p < M->np; p++) {
            int c, g;
            if (naive_clean(M->priv[k][p], L, &c, &g) && !dirty) dirty = 1, dc = c, dg = g;
        }
        if (dirty) {
            coh_wb(M, k, L, dc, dg);
            return;
        }
    }
}

static void n_ptouch(nmachine *M, int k, int p, uint64_t L, int w, int cls, int g, uint64_t bytes, uint64_t lo)
{
    naive *n = M->priv[k][p];
    const uint64_t before = n->c[cls][g].read_misses + n->c[cls][g].write_misses;
    naive_touch(n, L, w, cls, g, bytes, lo);
    if (n->c[cls][g].read_misses + n->c[cls][g].write_misses != before) {
        if (lost_take(&M->lost[k][p], L)) M->coh[k][p][cls][g]++;
        if (p == 0 && !w && M->ncores > 1) n_downgrade(M, k, L);
    }
    size_t no = n->nout;
    rt_access out[4];
    if (no) memcpy(out, n->out, no * sizeof *out); /* n->out is NULL before the first output */
    n->nout = 0;
    for (size_t i = 0; i < no; i++) {
        if (p + 1 == M->np) sh_emit(M, &out[i]);
        else n_ptouch(M, k, p + 1, out[i].addr / M->line, out[i].write, out[i].cls, out[i].gen, out[i].size, out[i].addr);
    }
}

static void n_put(nmachine *M, int k, const rt_access *a)
{
    if (!M->np) {
        sh_emit(M, a);
        return;
    }
    uint64_t sz = a->size ? a->size : 1, end = a->addr + sz;
    int cls = a->cls < RT_NCLASS ? a->cls : RT_CLS_FB, g = a->gen < RT_MAXGEN - 1 ? a->gen : RT_MAXGEN - 1;
    for (uint64_t L = a->addr / M->line; L * M->line < end; L++) {
        uint64_t lo = L * M->line > a->addr ? L * M->line : a->addr;
        uint64_t hi = (L + 1) * M->line < end ? (L + 1) * M->line : end;
        if (a->write && M->ncores > 1)
            for (int j = 0; j < M->ncores; j++) {
                if (j == k) continue;
                int dirty = 0, dc = 0, dg = 0;
                for (int p = 0; p < M->np; p++) {
                    int c = 0, gg = 0, r = naive_drop(M->priv[j][p], L, &c, &gg);
                    if (!r) continue;
                    M->inv[j][p][cls][g]++;
                    lost_add(&M->lost[j][p], L);
                    if (r == 2 && !dirty) dirty = 1, dc = c, dg = gg;
                }
                if (dirty) coh_wb(M, j, L, dc, dg);
            }
        n_ptouch(M, k, 0, L, a->write, cls, g, hi - lo, lo);
    }
}

static void n_init(nmachine *M, const rt_mc_config *c)
{
    memset(M, 0, sizeof *M);
    M->ncores = c->ncores;
    M->np = c->nprivate;
    M->ns = c->h.nlevels - c->nprivate;
    M->line = c->h.level[0].line;
    for (int k = 0; k < c->ncores; k++)
        for (int p = 0; p < M->np; p++) {
            M->priv[k][p] = naive_new(pol_of(c->h.level[p].repl), &c->h.level[p], c->h.level[p].sizes[0]);
            M->priv[k][p]->below = 1;
        }
    for (int s = 0; s < M->ns; s++) {
        const rt_sim_config *l = &c->h.level[c->nprivate + s];
        M->nsz[s] = l->nsizes;
        for (int i = 0; i < l->nsizes; i++) {
            M->shared[s][i] = naive_new(pol_of(l->repl), l, l->sizes[i]);
            M->shared[s][i]->below = s + 1 < M->ns;
        }
    }
}

/* The end: the private flushes (core by core, level by level), then the
 * shared levels on their whole stream, each level's flush reaching the next. */
static void n_finish(nmachine *M, int flush)
{
    for (int k = 0; flush && k < M->ncores; k++)
        for (int p = 0; p < M->np; p++) {
            naive *n = M->priv[k][p];
            naive_flush(n);
            size_t no = n->nout;
            rt_access *out = malloc((no + 1) * sizeof *out);
            memcpy(out, n->out, no * sizeof *out);
            n->nout = 0;
            for (size_t i = 0; i < no; i++) {
                if (p + 1 == M->np) sh_emit(M, &out[i]);
                else n_ptouch(M, k, p + 1, out[i].addr / M->line, out[i].write, out[i].cls, out[i].gen, out[i].size, out[i].addr);
            }
            free(out);
        }
    rt_access *in = M->sh;
    size_t nin = M->nsh;
    for (int s = 0; s < M->ns; s++)
        for (int i = 0; i < M->nsz[s]; i++) {
            naive *n = M->shared[s][i];
            naive_put(n, in, nin);
            if (flush && n->pol != P_OPT) naive_flush(n);
            if (s + 1 < M->ns) in = n->out, nin = n->nout;
        }
}

static void n_free(nmachine *M)
{
    for (int k = 0; k < M->ncores; k++)
        for (int p = 0; p < M->np; p++) {
            naive_free(M->priv[k][p]);
            free(M->lost[k][p].l);
        }
    for (int s = 0; s < M->ns; s++)
        for (int i = 0; i < M->nsz[s]; i++) naive_free(M->shared[s][i]);
    free(M->sh);
}

/* ---- streams ------------------------------------------------------------ */

static uint64_t rs = 0x9E3779B97F4A7C15ULL;
static uint64_t rnd(void)
{
    rs ^= rs << 13;
    rs ^= rs >> 7;
    rs ^= rs << 17;
    return rs;
}

/* n references in [base, base + span): reads, writes, streaming stores,
 * four classes, three generations, sizes 1..2 lines; cores in runs. */
static void gen_stream(rt_access *a, uint8_t *core, size_t n, int ncores, uint64_t span, uint32_t line)
{
    unsigned k = 0;
    for (size_t i = 0; i < n; i++) {
        if (rnd() % 16 == 0) k = (unsigned)(rnd() % (uint64_t)ncores);
        memset(&a[i], 0, sizeof a[i]);
        a[i].addr = RT_MM_BASE + rnd() % span;
        a[i].size = (uint32_t)(1 + rnd() % (2 * line));
        uint64_t r = rnd() % 10;
        a[i].write = r < 3 ? 1 : r == 3 ? RT_WRITE_STREAM : 0;
        a[i].cls = (uint8_t)(rnd() % 4);
        a[i].gen = (uint8_t)(rnd() % 3);
        core[i] = (uint8_t)k;
    }
}

/* ---- comparisons ---------------------------------------------------------- */

static int same(const rt_sim_counts *x, const rt_sim_counts *y) { return !memcmp(x, y, sizeof *x); }

static void compare(const char *spec, int ncores, int flush, int fullline, size_t nrefs, uint64_t span)
{
    rt_sim_config base;
    rt_sim_config_default(&base);
    base.flush = flush;
    base.write_miss_fullline = fullline;
    base.seed = 7;
    rt_mc_config c;
    rt_err e = {0};
    CHECK(rt_mc_parse_base(spec, &base, &c, &e) == 0, "%s: %s", spec, e.msg);
    if (failures) return;
    c.ncores = ncores;
    rt_mc *m = rt_mc_new(&c, &e);
    CHECK(m != NULL, "%s: %s", spec, e.msg);
    if (!m) return;
    nmachine *M = calloc(1, sizeof *M);
    n_init(M, &c);
    rt_access *a = calloc(nrefs, sizeof *a);
    uint8_t *core = calloc(nrefs, 1);
    gen_stream(a, core, nrefs, ncores, span, c.h.level[0].line);
    for (size_t i = 0; i < nrefs;) {
        size_t j = i + 1;
        while (j < nrefs && core[j] == core[i]) j++;
        CHECK(rt_mc_put(m, core[i], a + i, j - i) == 0, "%s", rt_mc_error(m));
        for (size_t x = i; x < j; x++) n_put(M, core[i], &a[x]);
        if (i < 3000 && j >= 3000) CHECK(rt_mc_check(m, &e) == 0, "%s mid-stream: %s", spec, e.msg);
        i = j;
    }
    CHECK(rt_mc_finish(m) == 0, "finish");
    n_finish(M, flush);
    CHECK(rt_mc_check(m, &e) == 0, "%s, %d cores: check: %s", spec, ncores, e.msg);
    int bad = 0;
    for (int k = 0; k < ncores && !bad; k++)
        for (int p = 0; p < c.nprivate && !bad; p++)
            for (int cl = 0; cl < RT_NCLASS && !bad; cl++)
                for (int g = 0; g < RT_MAXGEN && !bad; g++) {
                    rt_mc_counts got;
                    rt_mc_get_level(m, p, k, cl, g, &got);
                    rt_sim_counts w;
                    naive_get(M->priv[k][p], cl, g, &w);
                    const uint64_t cwb = p + 1 == c.nprivate ? M->cwb[k][cl][g] : 0;
                    if (got.accesses != w.accesses || got.misses != w.read_misses + w.write_misses ||
                        got.nofetch != w.nofetch || got.writebacks != w.writebacks + cwb || got.coh_writebacks != cwb ||
                        got.coherence_misses != M->coh[k][p][cl][g] || got.invalidations != M->inv[k][p][cl][g] ||
                        got.traffic_bytes != w.traffic_bytes + cwb * c.h.level[p].line) {
                        CHECK(0, "%s, %d cores, core %d level %d class %d gen %d: acc %" PRIu64 "/%" PRIu64 " miss %" PRIu64
                                 "/%" PRIu64 " wb %" PRIu64 "/%" PRIu64 "+%" PRIu64 " coh %" PRIu64 "/%" PRIu64
                                 " inv %" PRIu64 "/%" PRIu64,
                              spec, ncores, k, p, cl, g, got.accesses, w.accesses, got.misses, w.read_misses + w.write_misses,
                              got.writebacks, w.writebacks, cwb, got.coherence_misses, M->coh[k][p][cl][g],
                              got.invalidations, M->inv[k][p][cl][g]);
                        bad = 1;
                    }
                }
    uint64_t coh = 0;
    for (int k = 0; k < ncores; k++)
        for (int cl = 0; cl < RT_NCLASS; cl++)
            for (int g = 0; g < RT_MAXGEN; g++) coh += M->cwb[k][cl][g] + (c.nprivate ? M->coh[k][0][cl][g] : 0);
    if (ncores > 1 && c.nprivate) CHECK(coh > 0, "%s, %d cores: the stream made no coherence traffic", spec, ncores);
    for (int s = 0; s < M->ns && !bad; s++)
        for (int i = 0; i < M->nsz[s] && !bad; i++)
            for (int cl = 0; cl < RT_NCLASS && !bad; cl++)
                for (int g = 0; g < RT_MAXGEN && !bad; g++) {
                    rt_sim_counts got, w;
                    rt_sim_get_gen(rt_hier_level(rt_mc_shared_hier(m), s), i, cl, g, &got);
                    naive_get(M->shared[s][i], cl, g, &w);
                    if (!same(&got, &w)) {
                        CHECK(0, "%s, %d cores, shared level %d size %d class %d gen %d: acc %" PRIu64 "/%" PRIu64
                                 " rm %" PRIu64 "/%" PRIu64 " wm %" PRIu64 "/%" PRIu64 " wb %" PRIu64 "/%" PRIu64,
                              spec, ncores, s, i, cl, g, got.accesses, w.accesses, got.read_misses, w.read_misses,
                              got.write_misses, w.write_misses, got.writebacks, w.writebacks);
                        bad = 1;
                    }
                }
    n_free(M);
    free(M);
    free(a);
    free(core);
    rt_mc_free(m);
}

/* One core against the one-core hierarchy: the same rows, to the byte. */
static void one_core(const char *spec, int flush, size_t nrefs, uint64_t span)
{
    rt_sim_config base;
    rt_sim_config_default(&base);
    base.flush = flush;
    base.seed = 3;
    rt_mc_config c;
    rt_err e = {0};
    CHECK(rt_mc_parse_base(spec, &base, &c, &e) == 0, "%s: %s", spec, e.msg);
    if (failures) return;
    rt_mc *m = rt_mc_new(&c, &e);
    rt_hier *h = rt_hier_new(&c.h, &e);
    CHECK(m && h, "%s: %s", spec, e.msg);
    if (!m || !h) return;
    rt_access *a = calloc(nrefs, sizeof *a);
    uint8_t *core = calloc(nrefs, 1);
    gen_stream(a, core, nrefs, 1, span, c.h.level[0].line);
    for (size_t i = 0; i < nrefs; i += 1000) {
        size_t n = nrefs - i < 1000 ? nrefs - i : 1000;
        rt_mc_put(m, 0, a + i, n);
        rt_hier_put(h, a + i, n);
    }
    rt_mc_finish(m);
    rt_hier_finish(h);
    rt_db_traffic t1[RT_SIM_MAXSIZES * RT_NCLASS], t2[RT_SIM_MAXSIZES * RT_NCLASS];
    const rt_sim *last = rt_hier_level(h, c.h.nlevels - 1);
    size_t n1 = rt_mc_db_traffic_rows(m, t1), n2 = rt_sim_db_rows(last, t2);
    CHECK(n1 == n2 && n1 > 0, "%s: %zu and %zu traffic rows", spec, n1, n2);
    for (size_t i = 0; i < n1 && i < n2; i++)
        CHECK(t1[i].size == t2[i].size && t1[i].cls == t2[i].cls && t1[i].accesses == t2[i].accesses &&
                  t1[i].read_misses == t2[i].read_misses && t1[i].write_misses == t2[i].write_misses &&
                  t1[i].writebacks == t2[i].writebacks && t1[i].traffic_bytes == t2[i].traffic_bytes &&
                  !strcmp(t1[i].policy, t2[i].policy),
              "%s: traffic row %zu differs", spec, i);
    rt_db_level *l1 = calloc(rt_mc_db_level_cap(m), sizeof *l1), *l2 = calloc(rt_hier_db_level_max(h), sizeof *l2);
    n1 = rt_mc_db_level_rows_gen(m, 1, l1);
    n2 = rt_hier_db_level_rows(h, 1, l2);
    CHECK(n1 == n2 && n1 > 0, "%s: %zu and %zu level rows", spec, n1, n2);
    for (size_t i = 0; i < n1 && i < n2; i++) {
        CHECK(l1[i].core == (l1[i].level <= c.nprivate ? 0 : -1), "%s: level row %zu core %d", spec, i, l1[i].core);
        l1[i].core = -1;
        CHECK(l1[i].level == l2[i].level && !strcmp(l1[i].level_name, l2[i].level_name) && l1[i].size == l2[i].size &&
                  l1[i].line == l2[i].line && l1[i].assoc == l2[i].assoc && !strcmp(l1[i].policy, l2[i].policy) &&
                  !strcmp(l1[i].repl, l2[i].repl) && l1[i].cls == l2[i].cls && l1[i].gen == l2[i].gen &&
                  l1[i].accesses == l2[i].accesses && l1[i].misses == l2[i].misses &&
                  l1[i].writebacks == l2[i].writebacks && l1[i].traffic_bytes == l2[i].traffic_bytes,
              "%s: level row %zu (level %d class %d gen %d): %" PRIu64 "/%" PRIu64 " acc, %" PRIu64 "/%" PRIu64 " miss",
              spec, i, l1[i].level, l1[i].cls, l1[i].gen, l1[i].accesses, l2[i].accesses, l1[i].misses, l2[i].misses);
    }
    CHECK(rt_mc_check(m, &e) == 0, "%s: %s", spec, e.msg);
    free(l1);
    free(l2);
    free(a);
    free(core);
    rt_mc_free(m);
    rt_hier_free(h);
}

static void test_handmade(void)
{
    rt_mc_config c;
    rt_err e = {0};
    CHECK(rt_mc_parse("L1=1K/2/64/lru/private,LLC=256+512+1K/full/64/lru/shared", &c, &e) == 0, "%s", e.msg);
    c.ncores = 2;
    rt_mc *m = rt_mc_new(&c, &e);
    CHECK(m != NULL, "%s", e.msg);
    if (!m) return;
    rt_access r = {RT_MM_BASE, 8, 0, RT_CLS_RAY, 0}, w = {RT_MM_BASE, 8, 1, RT_CLS_RAY, 0},
              g = {RT_MM_BASE + 4096, 8, 0, RT_CLS_TRI, 0};
    /* both read A and geometry G: clean copies in both */
    rt_mc_put(m, 0, &r, 1);
    rt_mc_put(m, 1, &r, 1);
    rt_mc_put(m, 0, &g, 1);
    rt_mc_put(m, 1, &g, 1);
    rt_mc_put(m, 1, &w, 1); /* core 1 writes A: core 0's clean copy invalidated, no write-back */
    rt_mc_put(m, 0, &r, 1); /* core 0 misses on A: a coherence miss; core 1 writes A back, keeps it clean */
    rt_mc_put(m, 0, &w, 1); /* core 0 writes A: core 1's clean copy invalidated */
    rt_mc_put(m, 1, &r, 1); /* core 1: a coherence miss; core 0 writes A back, keeps it clean */
    rt_mc_put(m, 0, &g, 1); /* geometry: hits in both, never invalidated */
    rt_mc_put(m, 1, &g, 1);
    rt_mc_finish(m);
    rt_mc_counts a0, a1, g0, g1;
    rt_mc_get(m, 0, RT_CLS_RAY, &a0);
    rt_mc_get(m, 1, RT_CLS_RAY, &a1);
    rt_mc_get(m, 0, RT_CLS_TRI, &g0);
    rt_mc_get(m, 1, RT_CLS_TRI, &g1);
    CHECK(a0.accesses == 3 && a0.misses == 2 && a0.coherence_misses == 1 && a0.invalidations == 1 && a0.writebacks == 1 &&
              a0.coh_writebacks == 1,
          "core 0 rays: %" PRIu64 " acc %" PRIu64 " miss %" PRIu64 " coh %" PRIu64 " inv %" PRIu64 " wb", a0.accesses,
          a0.misses, a0.coherence_misses, a0.invalidations, a0.writebacks);
    CHECK(a1.accesses == 3 && a1.misses == 2 && a1.coherence_misses == 1 && a1.invalidations == 1 && a1.writebacks == 1,
          "core 1 rays: %" PRIu64 " acc %" PRIu64 " miss %" PRIu64 " coh %" PRIu64 " inv %" PRIu64 " wb", a1.accesses,
          a1.misses, a1.coherence_misses, a1.invalidations, a1.writebacks);
    CHECK(g0.accesses == 2 && g0.misses == 1 && !g0.invalidations && g1.accesses == 2 && g1.misses == 1 && !g1.invalidations,
          "geometry: %" PRIu64 "/%" PRIu64 " and %" PRIu64 "/%" PRIu64, g0.misses, g0.accesses, g1.misses, g1.accesses);
    /* the shared level saw: A fetched 4 times (2 + 2 misses) and written back twice, G fetched twice */
    rt_sim_counts ray, tri;
    rt_sim_get(rt_mc_shared(m), 2, RT_CLS_RAY, &ray);
    rt_sim_get(rt_mc_shared(m), 2, RT_CLS_TRI, &tri);
    CHECK(ray.accesses == 6 && ray.read_misses == 1 && ray.write_misses == 0 && ray.writebacks == 0 && tri.accesses == 2 &&
              tri.read_misses == 1,
          "shared: rays %" PRIu64 " acc %" PRIu64 " rm, tri %" PRIu64 " acc %" PRIu64 " rm", ray.accesses, ray.read_misses,
          tri.accesses, tri.read_misses);
    CHECK(rt_mc_check(m, &e) == 0, "%s", e.msg);
    rt_mc_free(m);

    /* two private levels: core 0 writes A, its L1 evicts it dirty into its L2
     * (a 1-line L1); core 1 then reads A: core 0's L2 copy is the dirty one,
     * written back (charged to L2) and kept clean */
    CHECK(rt_mc_parse("L1=64/1/64/lru,L2=1K/full/64/lru,LLC=4K/full/64/lru", &c, &e) == 0 && c.nprivate == 2, "%s", e.msg);
    c.ncores = 2;
    m = rt_mc_new(&c, &e);
    rt_access b = {RT_MM_BASE + 64, 8, 0, RT_CLS_RAY, 0};
    rt_mc_put(m, 0, &w, 1); /* L1 write miss: fetch through L2 and LLC */
    rt_mc_put(m, 0, &b, 1); /* evicts A dirty from L1 into L2 */
    rt_mc_put(m, 1, &r, 1); /* core 1 read miss: downgrade core 0's L2 copy */
    rt_mc_put(m, 1, &w, 1); /* core 1 writes A: core 0's L2 copy (now clean) invalidated */
    rt_mc_finish(m);
    rt_mc_counts l1, l2, c1;
    rt_mc_get_level(m, 0, 0, -1, -1, &l1);
    rt_mc_get_level(m, 1, 0, -1, -1, &l2);
    rt_mc_get_level(m, 0, 1, -1, -1, &c1);
    CHECK(l1.accesses == 2 && l1.misses == 2 && l1.writebacks == 1 && !l1.coh_writebacks && !l1.invalidations,
          "core 0 L1: %" PRIu64 " acc %" PRIu64 " miss %" PRIu64 " wb", l1.accesses, l1.misses, l1.writebacks);
    CHECK(l2.accesses == 3 && l2.misses == 2 && l2.writebacks == 1 && l2.coh_writebacks == 1 && l2.invalidations == 1,
          "core 0 L2: %" PRIu64 " acc %" PRIu64 " miss %" PRIu64 " wb %" PRIu64 " coh wb %" PRIu64 " inv", l2.accesses,
          l2.misses, l2.writebacks, l2.coh_writebacks, l2.invalidations);
    CHECK(c1.accesses == 2 && c1.misses == 1 && !c1.coherence_misses, "core 1 L1: %" PRIu64 " acc %" PRIu64 " miss",
          c1.accesses, c1.misses);
    CHECK(rt_mc_check(m, &e) == 0, "%s", e.msg);
    rt_mc_free(m);
}

static void test_spec(void)
{
    rt_mc_config c;
    rt_err e = {0};
    char spec[400];
    CHECK(rt_mc_parse("L1=32K/8/64/lru/private,LLC=1K-4M/full/64/lru/shared", &c, &e) == 0, "%s", e.msg);
    CHECK(c.nprivate == 1 && c.h.nlevels == 2 && c.h.level[0].sizes[0] == 32768 && c.h.level[0].assoc == 8 &&
              c.h.level[1].nsizes == 13 && c.h.level[1].sizes[0] == 1024 && c.h.level[1].sizes[12] == 4u << 20 &&
              !strcmp(c.h.name[0], "L1") && !strcmp(c.h.name[1], "LLC"),
          "parsed %d private of %d", c.nprivate, c.h.nlevels);
    rt_mc_spec(&c, spec, sizeof spec);
    CHECK(!strcmp(spec, "L1=32K/8/64/lru/private,LLC=1K-4M/full/64/lru/shared"), "canonical '%s'", spec);
    /* the CPU preset: L1 and L2 private, LLC shared */
    CHECK(rt_mc_parse("L1=32K/8/64/lru,L2=1M/16/64/lru,LLC=1K-4M/full/64/lru", &c, &e) == 0 && c.nprivate == 2, "cpu: %s",
          e.msg);
    rt_mc_spec(&c, spec, sizeof spec);
    CHECK(!strcmp(spec, "L1=32K/8/64/lru/private,L2=1M/16/64/lru/private,LLC=1K-4M/full/64/lru/shared"), "cpu '%s'", spec);
    CHECK(rt_mc_parse("L1=32K/8/64/plru,L2=1M/16/64/srrip/shared,LLC=4M+8M/16/64/opt", &c, &e) == 0 && c.nprivate == 1,
          "mixed: %s", e.msg);
    rt_mc_spec(&c, spec, sizeof spec);
    CHECK(!strcmp(spec, "L1=32K/8/64/plru/private,L2=1M/16/64/srrip/shared,LLC=4M+8M/16/64/opt/shared"), "mixed '%s'", spec);
    rt_mc_config c2;
    CHECK(rt_mc_parse(spec, &c2, &e) == 0 && !memcmp(&c.h, &c2.h, sizeof c.h) && c2.nprivate == 1, "round trip: %s", e.msg);
    CHECK(rt_mc_parse("LLC=1K-4M/full/64/lru", &c, &e) == 0 && c.nprivate == 0, "one level: %s", e.msg);
    const char *bad[][2] = {
        {"L1=32K/8/64/lru/private", "is shared"},
        {"L1=32K/8/64/lru/shared,LLC=1M/full/64/lru/private", "is shared"},
        {"L1=32K/8/64/lru/shared,L2=1M/16/64/lru/private,LLC=4M/full/64/lru", "private below the shared"},
        {"L1=32K/8/64/lru,L2=1M/16/128/lru/private,LLC=4M/full/128/lru", "one line size"},
        {"L1=32K/8/64/lru/wt,LLC=1M/full/64/lru", "write-back write-allocate"},
        {"L1=32K/8/64/lru,LLC=1M/full/64/lru,inclusive", "non-inclusive"},
        {"L1=32K/x/64/lru,LLC=1M/full/64/lru", "ways 'x'"},
        {"L1=32K/8/64/opt,LLC=1M/full/64/lru", "--hierarchy: "},
        {"L1=32K/8/64/lru/private/shared,LLC=1M/full/64/lru", "--hierarchy: "},
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        memset(&e, 0, sizeof e);
        CHECK(rt_mc_parse(bad[i][0], &c, &e) < 0 && strstr(e.msg, bad[i][1]), "'%s': '%s'", bad[i][0], e.msg);
    }
}

int main(void)
{
    static const char *const pols[] = {"lru", "fifo", "random", "plru", "srrip", "brrip"};
    const int cores[] = {1, 2, 3, 8};
    char spec[300];
    for (int ci = 0; ci < 4; ci++) {
        const int n = cores[ci];
        for (int p = 0; p < 6; p++) {
            const char *q = pols[(p + 1) % 6];
            /* a private L1 of policy p, a shared set-associative last level of another, 3 sizes */
            snprintf(spec, sizeof spec, "L1=512/4/32/%s,LLC=1K+2K+4K/4/32/%s", pols[p], q);
            compare(spec, n, 0, 0, 6000, 32 * 400);
            /* two private levels, a fully associative LRU last level at 4 sizes in one pass */
            snprintf(spec, sizeof spec, "L1=256/2/32/%s,L2=1K/4/32/%s/private,LLC=1K-8K/full/32/lru", pols[p], q);
            compare(spec, n, p == 0, p == 0, 6000, 32 * 400);
        }
        /* a shared middle level and OPT at the last */
        compare("L1=512/4/64/lru,L2=2K/8/64/srrip/shared,LLC=2K+4K/full/64/opt", n, 0, 0, 4000, 64 * 300);
        /* direct-mapped private, fully associative private */
        compare("L1=512/1/32/lru,LLC=1K+4K/full/32/lru", n, 1, 0, 6000, 32 * 200);
        compare("L1=256/full/64/fifo,LLC=1K-4K/full/64/lru", n, 0, 1, 6000, 64 * 60);
        /* every level shared */
        compare("LLC=1K-4K/full/64/lru", n, 0, 0, 3000, 64 * 200);
    }
    /* 70 cores: the sharer filter's bits stand for several cores */
    compare("L1=256/2/32/plru,L2=1K/4/32/lru,LLC=2K+8K/full/32/lru", 70, 0, 0, 8000, 32 * 300);
    one_core("L1=512/4/32/lru,L2=2K/8/32/plru,LLC=1K-16K/full/32/lru", 0, 20000, 32 * 800);
    one_core("L1=512/4/32/brrip,L2=2K/8/32/fifo,LLC=1K-16K/full/32/lru", 1, 20000, 32 * 800);
    one_core("L1=1K/8/64/random,LLC=4K+8K/8/64/srrip", 0, 20000, 64 * 400);
    one_core("L1=1K/8/64/lru,LLC=2K+8K/full/64/opt", 0, 10000, 64 * 400);
    test_handmade();
    test_spec();
    return failures ? 1 : 0;
}
