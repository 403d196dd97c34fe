/*
 * test_sim.c -- cache simulators against obviously-correct references.
 *
 * The reference is a plain array kept in recency order (move-to-front by
 * linear scan), one independent cache per size and, for set-associative
 * caches, one such array per set. It is run separately for every size and
 * compared counter by counter (per class and per ray generation: accesses,
 * read/write misses, write-backs charged to the last writer's class and
 * generation, write-through bytes, traffic) with both engines, whose
 * invariant checkers also run every few thousand references. Random
 * streams carry random generations 0..9, so the pooling of generations >=
 * RT_MAXGEN-1 is exercised too; traces of both format versions are
 * replayed and must give what the stream gives in-process.
 */
#include "check.h"
#include "bench.h"
#include "approx.h"
#include "msim.h"
#include "setassoc.h"
#include "sim.h"
#include "trace.h"

#include <ctype.h>
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

/* ---- naive reference: one cache, sets of recency-ordered arrays -------- */

typedef struct naive {
    uint64_t line, nsets, ways;
    int wt, nwa;
    int fullline;     /* an allocating write miss covering its line fetches nothing */
    uint64_t *tag;    /* nsets * ways, MRU first */
    uint8_t *dirty, *wcls, *wgen; /* per line: modified, last writer's class and generation */
    uint64_t *used;   /* per set */
    rt_sim_counts c[RT_NCLASS][RT_MAXGEN]; /* per class and generation bucket */
} naive;

static naive *naive_new(uint64_t size, uint64_t line, uint64_t assoc, int wt, int nwa)
{
    naive *n = calloc(1, sizeof *n);
    uint64_t lines = size / line;
    n->line = line;
    n->ways = assoc ? assoc : lines;
    n->nsets = lines / n->ways;
    n->wt = wt;
    n->nwa = nwa;
    n->tag = calloc(lines, sizeof *n->tag);
    n->dirty = calloc(lines, 1);
    n->wcls = calloc(lines, 1);
    n->wgen = calloc(lines, 1);
    n->used = calloc(n->nsets, sizeof *n->used);
    return n;
}

static void naive_free(naive *n)
{
    free(n->tag);
    free(n->dirty);
    free(n->wcls);
    free(n->wgen);
    free(n->used);
    free(n);
}

/* g: the generation bucket */
static void naive_touch(naive *n, uint64_t L, int w, int cls, int g, uint64_t bytes)
{
    uint64_t s = L % n->nsets;
    uint64_t *t = n->tag + s * n->ways;
    uint8_t *d = n->dirty + s * n->ways, *wc = n->wcls + s * n->ways, *wg = n->wgen + s * n->ways;
    rt_sim_counts *c = &n->c[cls][g];
    c->accesses++;
    uint64_t i;
    for (i = 0; i < n->used[s]; i++)
        if (t[i] == L) break;
    uint8_t dd, ww, gg;
    if (i < n->used[s]) { /* hit: rotate to front */
        dd = d[i];
        ww = wc[i];
        gg = wg[i];
        memmove(t + 1, t, i * sizeof *t);
        memmove(d + 1, d, i);
        memmove(wc + 1, wc, i);
        memmove(wg + 1, wg, i);
    } else {
        if (w) c->write_misses++;
        else c->read_misses++;
        if (w && n->nwa) {
            c->wt_bytes += bytes;
            return;
        }
        /* a streaming store never fetches; an ordinary write only when it
         * covers the line and full-line writes are on */
        if (w == RT_WRITE_STREAM || (w && n->fullline && bytes == n->line)) c->nofetch++;
        if (n->used[s] == n->ways) { /* evict the last */
            uint64_t l = n->ways - 1;
            if (d[l]) n->c[wc[l]][wg[l]].writebacks++;
            n->used[s]--;
        }
        uint64_t u = n->used[s]++;
        memmove(t + 1, t, u * sizeof *t);
        memmove(d + 1, d, u);
        memmove(wc + 1, wc, u);
        memmove(wg + 1, wg, u);
        dd = 0;
        ww = 0;
        gg = 0;
    }
    t[0] = L;
    d[0] = dd;
    wc[0] = ww;
    wg[0] = gg;
    if (w) {
        if (n->wt) c->wt_bytes += bytes;
        else d[0] = 1, wc[0] = (uint8_t)cls, wg[0] = (uint8_t)g;
    }
}

static void naive_put(naive *n, const rt_access *a, size_t cnt)
{
    for (size_t i = 0; i < cnt; i++) {
        uint64_t sz = a[i].size ? a[i].size : 1;
        uint64_t end = a[i].addr + sz;
        for (uint64_t L = a[i].addr / n->line; L * n->line < end; L++) {
            uint64_t lo = L * n->line > a[i].addr ? L * n->line : a[i].addr;
            uint64_t hi = (L + 1) * n->line < end ? (L + 1) * n->line : end;
            int g = a[i].gen < RT_MAXGEN - 1 ? a[i].gen : RT_MAXGEN - 1;
            naive_touch(n, L, a[i].write, a[i].cls, g, hi - lo);
        }
    }
}

/* The end-of-run flush: every dirty line is written back, charged to its
 * last writer. */
static void naive_flush(naive *n)
{
    for (uint64_t s = 0; s < n->nsets; s++)
        for (uint64_t i = 0; i < n->used[s]; i++) {
            uint64_t k = s * n->ways + i;
            if (n->dirty[k]) n->c[n->wcls[k]][n->wgen[k]].writebacks++;
            n->dirty[k] = 0;
        }
}

/* Counters of class cls, generation bucket gen (-1: all of them). */
static void naive_get(const naive *n, int cls, int gen, rt_sim_counts *o)
{
    memset(o, 0, sizeof *o);
    for (int g = 0; g < RT_MAXGEN; g++) {
        if (gen >= 0 && g != gen) continue;
        const rt_sim_counts *c = &n->c[cls][g];
        o->accesses += c->accesses;
        o->read_misses += c->read_misses;
        o->write_misses += c->write_misses;
        o->writebacks += c->writebacks;
        o->wt_bytes += c->wt_bytes;
        o->nofetch += c->nofetch;
    }
    uint64_t fetch = o->read_misses + (n->nwa ? 0 : o->write_misses - o->nofetch);
    o->traffic_bytes = (fetch + o->writebacks) * n->line + o->wt_bytes;
}

/* ---- trace generators --------------------------------------------------- */

static uint64_t rs = 88172645463325252ULL;
static uint64_t rnd(void)
{
    rs ^= rs << 13;
    rs ^= rs >> 7;
    rs ^= rs << 17;
    return rs;
}

enum { GEN_RANDOM, GEN_ZIPF, GEN_CYCLIC };

static const uint32_t sizes_pool[] = {1, 4, 8, 8, 8, 32, 36, 36, 64, 100};

/* 1: gen() makes about a third of its writes streaming stores (write = 2) */
static int gen_stream;

/* footprint in 64-byte units; addresses get a random offset and size */
static void gen(rt_access *a, size_t n, int kind, uint64_t footprint)
{
    uint64_t cyc = 0;
    for (size_t i = 0; i < n; i++) {
        uint64_t r = rnd(), unit;
        if (kind == GEN_RANDOM) {
            unit = r % footprint;
        } else if (kind == GEN_ZIPF) {
            double u = (double)(r >> 11) / 9007199254740992.0;
            unit = (uint64_t)(footprint * u * u * u * u);
        } else {
            unit = (r & 15) == 0 ? (r >> 8) % (footprint * 2) : cyc++ % footprint;
        }
        a[i].addr = 0x10000000ULL + unit * 64 + ((r >> 40) & 63);
        a[i].size = sizes_pool[(r >> 48) % 10];
        a[i].write = ((r >> 52) & 7) < 3;
        if (gen_stream && a[i].write && (r >> 4) % 3 == 0) a[i].write = RT_WRITE_STREAM;
        a[i].cls = (uint8_t)((r >> 56) % RT_NCLASS);
        a[i].gen = (uint8_t)((r >> 20) % 10); /* 0..9: 7, 8, 9 share the last bucket */
    }
}

static int same(const rt_sim_counts *x, const rt_sim_counts *y)
{
    return x->accesses == y->accesses && x->read_misses == y->read_misses && x->write_misses == y->write_misses &&
           x->writebacks == y->writebacks && x->wt_bytes == y->wt_bytes && x->traffic_bytes == y->traffic_bytes &&
           x->nofetch == y->nofetch;
}

static void show(const char *what, const rt_sim_counts *c)
{
    fprintf(stderr, "  %s acc %llu rm %llu wm %llu wb %llu wt %llu traffic %llu nofetch %llu\n", what,
            (unsigned long long)c->accesses, (unsigned long long)c->read_misses, (unsigned long long)c->write_misses,
            (unsigned long long)c->writebacks, (unsigned long long)c->wt_bytes, (unsigned long long)c->traffic_bytes,
            (unsigned long long)c->nofetch);
}

/* Runs a through a simulator with config c and through one naive cache per
 * size; compares everything. */
static void compare(const char *name, const rt_sim_config *c, const rt_access *a, size_t n)
{
    rt_err e = {0};
    rt_sim *s = rt_sim_new(c, &e);
    CHECK(s, "%s: rt_sim_new: %s", name, e.msg);
    if (!s) return;
    for (size_t i = 0; i < n; i += 4096) {
        rt_sim_put(s, a + i, n - i < 4096 ? n - i : 4096);
        if ((i / 4096) % 16 == 0) CHECK(rt_sim_check(s, &e) == 0, "%s: invariant: %s", name, e.msg);
    }
    CHECK(rt_sim_check(s, &e) == 0, "%s: invariant: %s", name, e.msg);
    CHECK(rt_sim_finish(s) == 0, "%s: finish", name);
    CHECK(rt_sim_check(s, &e) == 0, "%s: invariant after finish: %s", name, e.msg);
    CHECK(rt_sim_refs(s) == n, "%s: refs", name);
    uint64_t wbgen = 0; /* write-backs outside generation 0: the test must see some */
    uint64_t nofetch = 0, flushed = 0; /* write misses without a fetch; flush write-backs */
    int streams = 0;                   /* the stream has streaming stores */
    for (size_t i = 0; i < n && !streams; i++) streams = a[i].write == RT_WRITE_STREAM;
    for (int i = 0; i < c->nsizes; i++) {
        naive *nv = naive_new(c->sizes[i], c->line, c->assoc, c->write_through, c->no_write_allocate);
        nv->fullline = c->write_miss_fullline;
        naive_put(nv, a, n);
        if (c->flush) {
            rt_sim_counts before, t;
            memset(&before, 0, sizeof before);
            for (int k = 0; k < RT_NCLASS; k++) {
                naive_get(nv, k, -1, &t);
                before.writebacks += t.writebacks;
            }
            naive_flush(nv);
            for (int k = 0; k < RT_NCLASS; k++) {
                naive_get(nv, k, -1, &t);
                flushed += t.writebacks;
            }
            flushed -= before.writebacks;
        }
        for (int k = 0; k < RT_NCLASS; k++)
            for (int g = -1; g < RT_MAXGEN; g++) {
                rt_sim_counts x, y;
                if (g < 0) rt_sim_get(s, i, k, &x);
                else rt_sim_get_gen(s, i, k, g, &x);
                naive_get(nv, k, g, &y);
                if (g > 0) wbgen += x.writebacks;
                if (g < 0) nofetch += x.nofetch;
                if (!same(&x, &y)) {
                    CHECK(0, "%s: size %llu class %s generation %d differs (engine %s)", name,
                          (unsigned long long)c->sizes[i], rt_class_name(k), g, rt_sim_engine(s));
                    show("sim  ", &x);
                    show("naive", &y);
                }
            }
        naive_free(nv);
    }
    CHECK(wbgen > 0 || c->write_through, "%s: no write-back of a later generation", name);
    /* the options must have had something to do, or the comparison proves nothing */
    CHECK(!(c->write_miss_fullline || streams) || c->no_write_allocate || nofetch > 0, "%s: no write miss without a fetch",
          name);
    CHECK(!c->flush || c->write_through || c->no_write_allocate || flushed > 0, "%s: the flush wrote nothing back", name);
    rt_sim_free(s);
}

/* ---- hand-computed cases ------------------------------------------------ */

static void test_cycles(void)
{
    /* 16-line cache (1 KB, 64 B lines) inside a 3-size simulation */
    rt_sim_config c;
    rt_sim_config_default(&c);
    c.nsizes = 3;
    c.sizes[0] = 512, c.sizes[1] = 1024, c.sizes[2] = 2048;
    rt_sim *s = rt_sim_new(&c, NULL);
    rt_access a;
    /* 17 lines cycled 10 times: every reference misses in 16 lines and
     * below; in 32 lines only the first pass misses */
    for (int pass = 0; pass < 10; pass++)
        for (int l = 0; l < 17; l++) {
            a = (rt_access){0x1000 + (uint64_t)l * 64, 8, 0, RT_CLS_TRI, 0};
            rt_sim_put(s, &a, 1);
        }
    rt_sim_counts r;
    rt_sim_get(s, 1, RT_CLS_TRI, &r);
    CHECK(r.accesses == 170 && r.read_misses == 170, "cycle N+1 through N: %llu misses", (unsigned long long)r.read_misses);
    rt_sim_get(s, 0, RT_CLS_TRI, &r);
    CHECK(r.read_misses == 170, "cycle through 8 lines");
    rt_sim_get(s, 2, RT_CLS_TRI, &r);
    CHECK(r.read_misses == 17, "cycle fits 32 lines: %llu", (unsigned long long)r.read_misses);
    CHECK(r.traffic_bytes == 17 * 64, "traffic");
    rt_sim_free(s);

    /* N lines in an N-line cache: all hit after the first pass */
    s = rt_sim_new(&c, NULL);
    for (int pass = 0; pass < 5; pass++)
        for (int l = 0; l < 16; l++) {
            a = (rt_access){0x1000 + (uint64_t)l * 64, 64, pass & 1, RT_CLS_NODE, 0};
            rt_sim_put(s, &a, 1);
        }
    rt_sim_get(s, 1, RT_CLS_NODE, &r);
    CHECK(r.read_misses == 16 && r.write_misses == 0 && r.writebacks == 0, "N lines in N-line cache");
    rt_sim_get(s, 0, RT_CLS_NODE, &r);
    CHECK(r.read_misses + r.write_misses == 80, "16 lines in 8-line cache always miss");
    /* 8-line cache: passes 1 and 3 write every line, each written line is
     * evicted dirty by the next pass: 32 write-backs */
    CHECK(r.writebacks == 32, "write-backs in 8-line cache: %llu", (unsigned long long)r.writebacks);
    rt_sim_free(s);
}

/* The end-of-run flush and full-line writes by hand, both engines. */
static void test_flush_fullline_by_hand(void)
{
    /* 2-line cache: W a(node), W b(ray), W c(tri) -- c evicts a (1
     * write-back, node), the flush writes back b and c (ray, tri) */
    const rt_access seq[3] = {{0x000, 4, 1, RT_CLS_NODE, 0}, {0x040, 4, 1, RT_CLS_RAY, 1}, {0x080, 4, 1, RT_CLS_TRI, 2}};
    for (int engine = 0; engine < 2; engine++) {
        rt_sim_config c;
        rt_sim_config_default(&c);
        c.nsizes = 1;
        c.sizes[0] = 128;
        c.assoc = engine ? 2 : 0; /* 2 ways, one set: the per-size engine */
        c.flush = 1;
        rt_sim *s = rt_sim_new(&c, NULL);
        CHECK(!strcmp(rt_sim_engine(s), engine ? "exact-persize" : "exact-stack"), "flush: engine");
        rt_sim_put(s, seq, 3);
        rt_sim_counts n, r, t;
        rt_sim_get(s, 0, RT_CLS_NODE, &n);
        rt_sim_get(s, 0, RT_CLS_TRI, &t);
        CHECK(n.writebacks == 1 && t.writebacks == 0, "before the flush: %llu node, %llu tri write-backs",
              (unsigned long long)n.writebacks, (unsigned long long)t.writebacks);
        rt_sim_finish(s);
        rt_sim_finish(s); /* a second finish finds nothing dirty */
        rt_err e = {0};
        CHECK(rt_sim_check(s, &e) == 0, "flush: invariant: %s", e.msg);
        rt_sim_get(s, 0, RT_CLS_NODE, &n);
        rt_sim_get(s, 0, RT_CLS_RAY, &r);
        rt_sim_get(s, 0, RT_CLS_TRI, &t);
        CHECK(n.writebacks == 1 && r.writebacks == 1 && t.writebacks == 1, "flush: 1 eviction + 2 flush write-backs");
        CHECK(t.traffic_bytes == 2 * 64, "flush: tri traffic %llu", (unsigned long long)t.traffic_bytes);
        rt_sim_get_gen(s, 0, RT_CLS_RAY, 1, &r);
        CHECK(r.writebacks == 1, "flush: charged to the writer's generation");
        rt_sim_get_gen(s, 0, RT_CLS_TRI, 1, &t);
        CHECK(t.writebacks == 0, "flush: not charged to another generation");
        rt_sim_free(s);
    }
    /* the two-size stack: a line evicted from the 1-line cache but still
     * dirty in the 2-line one is flushed there only */
    {
        rt_sim_config c;
        rt_sim_config_default(&c);
        c.nsizes = 2;
        c.sizes[0] = 64, c.sizes[1] = 128;
        c.flush = 1;
        rt_sim *s = rt_sim_new(&c, NULL);
        rt_sim_put(s, seq, 2); /* W a, W b: a evicted dirty from 1 line, both dirty in 2 lines */
        rt_sim_finish(s);
        rt_sim_counts n, r;
        rt_sim_get(s, 0, RT_CLS_NODE, &n);
        rt_sim_get(s, 0, RT_CLS_RAY, &r);
        CHECK(n.writebacks == 1 && r.writebacks == 1, "1 line: a evicted, b flushed");
        rt_sim_get(s, 1, RT_CLS_NODE, &n);
        rt_sim_get(s, 1, RT_CLS_RAY, &r);
        CHECK(n.writebacks == 1 && r.writebacks == 1, "2 lines: a and b flushed");
        rt_sim_free(s);
    }
    /* full-line writes: a 64-byte aligned write misses without a fetch, a
     * 100-byte write at 0x1030 covers line 0x41 only, a 4-byte write fetches */
    const rt_access w[3] = {{0x2000, 64, 1, RT_CLS_RAY, 0}, {0x1030, 100, 1, RT_CLS_RAY, 0}, {0x3000, 4, 1, RT_CLS_RAY, 0}};
    for (int engine = 0; engine < 2; engine++) {
        rt_sim_config c;
        rt_sim_config_default(&c);
        c.nsizes = 1;
        c.sizes[0] = 4096;
        c.assoc = engine ? 4 : 0;
        c.write_miss_fullline = 1;
        CHECK(!strcmp(rt_sim_policy_name(&c), "wb-wa+fullline"), "label %s", rt_sim_policy_name(&c));
        rt_sim *s = rt_sim_new(&c, NULL);
        rt_sim_put(s, w, 3);
        rt_sim_counts r;
        rt_sim_get(s, 0, RT_CLS_RAY, &r);
        CHECK(r.write_misses == 5 && r.nofetch == 2, "full-line: %llu write misses, %llu without fetch",
              (unsigned long long)r.write_misses, (unsigned long long)r.nofetch);
        CHECK(r.traffic_bytes == 3 * 64, "full-line: traffic %llu", (unsigned long long)r.traffic_bytes);
        rt_sim_free(s);
    }
    rt_sim_config c;
    rt_sim_config_default(&c);
    CHECK(!strcmp(rt_sim_policy_name(&c), "wb-wa"), "default label");
    c.flush = 1;
    CHECK(!strcmp(rt_sim_policy_name(&c), "wb-wa+flush"), "flush label");
    c.write_miss_fullline = 1, c.no_write_allocate = 1;
    CHECK(!strcmp(rt_sim_policy_name(&c), "wb-nwa+flush+fullline"), "both labels");
}

/* Streaming stores, by hand, in both exact engines: one 2-line cache,
 * queue class throughout.
 *   1. S line 0 (32 B)      miss, no fetch, dirty            wm 1 nf 1
 *   2. R line 0             hit
 *   3. S lines 1, 2 (128 B) two misses, no fetch; line 2 evicts dirty
 *                           line 0                           wm 3 nf 3 wb 1
 *   4. W line 3 (8 B)       miss, fetched; evicts dirty 1    wm 4 nf 3 wb 2
 *   5. S line 2             hit: an ordinary write, no miss
 *   6. R line 0             miss; evicts dirty line 3         rm 1 wb 3
 * accesses 7, traffic (rm 1 + wm 4 - nf 3 + wb 3) x 64 = 320 B; the flush
 * then writes back line 2 (dirty): wb 4, 384 B. With no-write-allocate
 * every write misses and writes around (1: 32 B, 3: 2 x 64 B, 4: 8 B, 5:
 * 8 B; wm 5, 176 B), line 0 is read into the cache at 2 (miss) and hits
 * at 6: traffic 64 + 176 B, no write-back, nothing without a fetch. */
static void test_stream_by_hand(void)
{
    const rt_access seq[6] = {{0x000, 32, RT_WRITE_STREAM, RT_CLS_QUEUE, 0}, {0x020, 4, 0, RT_CLS_QUEUE, 0},
                              {0x040, 128, RT_WRITE_STREAM, RT_CLS_QUEUE, 0}, {0x0c0, 8, 1, RT_CLS_QUEUE, 0},
                              {0x080, 8, RT_WRITE_STREAM, RT_CLS_QUEUE, 0}, {0x000, 4, 0, RT_CLS_QUEUE, 0}};
    for (int engine = 0; engine < 3; engine++) {
        rt_sim_config c;
        rt_sim_config_default(&c);
        c.nsizes = 1;
        c.sizes[0] = 128;
        c.assoc = engine ? 2 : 0; /* 2 ways, one set: the per-size engine */
        c.no_write_allocate = engine == 2;
        c.flush = 1;
        rt_sim *s = rt_sim_new(&c, NULL);
        CHECK(!strcmp(rt_sim_engine(s), engine ? "exact-persize" : "exact-stack"), "stream: engine");
        rt_sim_put(s, seq, 6);
        rt_err e = {0};
        CHECK(rt_sim_check(s, &e) == 0, "stream: invariant: %s", e.msg);
        rt_sim_counts q;
        rt_sim_get(s, 0, RT_CLS_QUEUE, &q);
        if (engine < 2) {
            CHECK(q.accesses == 7 && q.read_misses == 1 && q.write_misses == 4 && q.nofetch == 3 && q.writebacks == 3 &&
                      q.traffic_bytes == 320,
                  "stream (engine %d): acc %llu rm %llu wm %llu nf %llu wb %llu traffic %llu", engine,
                  (unsigned long long)q.accesses, (unsigned long long)q.read_misses, (unsigned long long)q.write_misses,
                  (unsigned long long)q.nofetch, (unsigned long long)q.writebacks, (unsigned long long)q.traffic_bytes);
            rt_sim_finish(s);
            rt_sim_get(s, 0, RT_CLS_QUEUE, &q);
            CHECK(q.writebacks == 4 && q.traffic_bytes == 384, "stream (engine %d) flushed: wb %llu traffic %llu",
                  engine, (unsigned long long)q.writebacks, (unsigned long long)q.traffic_bytes);
        } else {
            CHECK(q.accesses == 7 && q.read_misses == 1 && q.write_misses == 5 && q.nofetch == 0 && q.writebacks == 0 &&
                      q.wt_bytes == 32 + 128 + 8 + 8 && q.traffic_bytes == 64 + 176,
                  "stream, no-write-allocate: acc %llu rm %llu wm %llu nf %llu wb %llu wt %llu", (unsigned long long)q.accesses,
                  (unsigned long long)q.read_misses, (unsigned long long)q.write_misses, (unsigned long long)q.nofetch,
                  (unsigned long long)q.writebacks, (unsigned long long)q.wt_bytes);
        }
        CHECK(rt_sim_check(s, &e) == 0, "stream: invariant after finish: %s", e.msg);
        rt_sim_free(s);
    }
}

static void test_writebacks_by_hand(void)
{
    /* sizes 1 and 2 lines of 64 B: W a(node) R b(ray) R a(node) W c(tri) R b(ray) */
    rt_sim_config c;
    rt_sim_config_default(&c);
    c.nsizes = 2;
    c.sizes[0] = 64, c.sizes[1] = 128;
    const rt_access seq[5] = {
        {0x000, 4, 1, RT_CLS_NODE, 0}, {0x040, 4, 0, RT_CLS_RAY, 0}, {0x000, 4, 0, RT_CLS_NODE, 0},
        {0x080, 4, 1, RT_CLS_TRI, 0}, {0x040, 4, 0, RT_CLS_RAY, 0},
    };
    for (int engine = 0; engine < 2; engine++) {
        c.assoc = engine ? 1 : 0; /* 1 way: direct-mapped 1 set = same as full for 1 line */
        if (engine) c.nsizes = 1;
        rt_sim *s = rt_sim_new(&c, NULL);
        rt_sim_put(s, seq, 5);
        rt_sim_counts n, r, t;
        rt_sim_get(s, 0, RT_CLS_NODE, &n);
        rt_sim_get(s, 0, RT_CLS_RAY, &r);
        rt_sim_get(s, 0, RT_CLS_TRI, &t);
        CHECK(n.write_misses == 1 && n.read_misses == 1 && n.writebacks == 1, "1 line: node");
        CHECK(r.read_misses == 2 && r.writebacks == 0, "1 line: ray");
        CHECK(t.write_misses == 1 && t.writebacks == 1, "1 line: tri");
        CHECK(n.traffic_bytes == 3 * 64 && t.traffic_bytes == 2 * 64, "1 line: traffic");
        if (!engine) {
            rt_sim_get(s, 1, RT_CLS_NODE, &n);
            rt_sim_get(s, 1, RT_CLS_RAY, &r);
            rt_sim_get(s, 1, RT_CLS_TRI, &t);
            CHECK(n.write_misses == 1 && n.read_misses == 0 && n.writebacks == 1, "2 lines: node");
            CHECK(r.read_misses == 2 && r.writebacks == 0, "2 lines: ray");
            CHECK(t.write_misses == 1 && t.writebacks == 0, "2 lines: tri");
        }
        rt_sim_free(s);
    }
    /* a reference spanning three lines touches three lines */
    rt_sim_config_default(&c);
    rt_sim *s = rt_sim_new(&c, NULL);
    rt_access big = {0x1030, 100, 0, RT_CLS_TRI, 0}; /* 0x1030..0x1093: lines 0x40, 0x41, 0x42 */
    rt_sim_put(s, &big, 1);
    rt_sim_counts t;
    rt_sim_get(s, 0, RT_CLS_TRI, &t);
    CHECK(t.accesses == 3 && t.read_misses == 3, "spanning reference: %llu touches", (unsigned long long)t.accesses);
    rt_sim_free(s);
}

/* Per-generation accounting by hand: a one-line cache (both engines) and,
 * for the one-pass engine, a two-line cache beside it. */
static void test_generations_by_hand(void)
{
    const rt_access seq[6] = {
        {0x000, 4, 1, RT_CLS_NODE, 2}, /* W x: write miss of generation 2 */
        {0x008, 4, 1, RT_CLS_NODE, 0}, /* W x: hit; generation 0 wrote x last */
        {0x040, 4, 0, RT_CLS_RAY, 1},  /* R y: miss; x written back, charged to (node, 0) */
        {0x044, 4, 1, RT_CLS_RAY, 3},  /* W y: hit, by generation 3 */
        {0x010, 4, 0, RT_CLS_NODE, 1}, /* R x: miss; y written back, charged to (ray, 3) */
        {0x080, 4, 0, RT_CLS_TRI, 200}, /* R z: miss, counted in the last bucket */
    };
    rt_sim_config c;
    rt_sim_config_default(&c);
    for (int engine = 0; engine < 2; engine++) {
        c.nsizes = engine ? 1 : 2;
        c.sizes[0] = 64, c.sizes[1] = 128;
        c.assoc = engine ? 1 : 0;
        rt_sim *s = rt_sim_new(&c, NULL);
        rt_sim_put(s, seq, 6);
        rt_err e = {0};
        CHECK(rt_sim_check(s, &e) == 0, "by hand: %s", e.msg);
        rt_sim_counts n0, n1, n2, r1, r3, t7, all;
        rt_sim_get_gen(s, 0, RT_CLS_NODE, 0, &n0);
        rt_sim_get_gen(s, 0, RT_CLS_NODE, 1, &n1);
        rt_sim_get_gen(s, 0, RT_CLS_NODE, 2, &n2);
        rt_sim_get_gen(s, 0, RT_CLS_RAY, 1, &r1);
        rt_sim_get_gen(s, 0, RT_CLS_RAY, 3, &r3);
        rt_sim_get_gen(s, 0, RT_CLS_TRI, RT_MAXGEN - 1, &t7);
        const char *en = rt_sim_engine(s);
        CHECK(n2.accesses == 1 && n2.write_misses == 1 && n2.read_misses == 0 && n2.writebacks == 0, "%s: node gen 2", en);
        CHECK(n0.accesses == 1 && n0.write_misses + n0.read_misses == 0 && n0.writebacks == 1 &&
                  n0.traffic_bytes == 64, "%s: node gen 0: write-back of its last write", en);
        CHECK(n1.accesses == 1 && n1.read_misses == 1 && n1.writebacks == 0, "%s: node gen 1", en);
        CHECK(r1.accesses == 1 && r1.read_misses == 1 && r1.writebacks == 0, "%s: ray gen 1", en);
        CHECK(r3.accesses == 1 && r3.read_misses + r3.write_misses == 0 && r3.writebacks == 1, "%s: ray gen 3", en);
        CHECK(t7.accesses == 1 && t7.read_misses == 1, "%s: generation 200 in the last bucket", en);
        rt_sim_get(s, 0, RT_CLS_NODE, &all);
        CHECK(all.accesses == 3 && all.read_misses == 1 && all.write_misses == 1 && all.writebacks == 1 &&
                  all.traffic_bytes == 3 * 64, "%s: node over all generations", en);
        rt_sim_get_group_gen(s, 0, RT_GROUP_RAY, 3, &all);
        CHECK(all.accesses == 1 && all.writebacks == 1, "%s: ray group, gen 3", en);
        rt_sim_get_group_gen(s, 0, RT_GROUP_GEOMETRY, 1, &all);
        CHECK(all.accesses == 1 && all.read_misses == 1, "%s: geometry group, gen 1", en);
        rt_sim_get_gen(s, 0, RT_CLS_NODE, RT_MAXGEN, &all);
        CHECK(all.accesses == 0, "%s: generation out of range", en);
        rt_sim_get_gen(s, 0, RT_CLS_NODE, -1, &all);
        CHECK(all.accesses == 0, "%s: negative generation", en);
        if (!engine) { /* two lines: x stays; z evicts y, dirty from (ray, 3) */
            rt_sim_get_gen(s, 1, RT_CLS_NODE, 0, &n0);
            rt_sim_get_gen(s, 1, RT_CLS_NODE, 1, &n1);
            rt_sim_get_gen(s, 1, RT_CLS_RAY, 3, &r3);
            CHECK(n0.writebacks == 0 && n1.read_misses == 0 && r3.writebacks == 1, "2 lines by generation");
        }
        rt_sim_free(s);
    }
}

/* Writes a to a trace whose header declares `generations`, replays it, and
 * compares every counter with the stream simulated in-process. */
static void replay_compare(const char *name, const rt_access *a, size_t n, unsigned generations)
{
    rt_tr_meta m;
    memset(&m, 0, sizeof m);
    snprintf(m.tracer, sizeof m.tracer, "test");
    rt_mm_init(&m.layout);
    m.generations = generations;
    rt_err e = {0};
    const char *p = check_path("gen.rtt");
    rt_tr_writer *w = rt_tr_create(p, &m, &e);
    CHECK(w, "%s: %s", name, e.msg);
    if (!w) return;
    rt_sink *sk = rt_tr_sink(w);
    CHECK(sk->put(sk, a, n) == 0 && rt_tr_finish(w, &e) == 0, "%s: write: %s %s", name, rt_tr_writer_error(w), e.msg);
    rt_tr_reader *r = rt_tr_open(p, &e);
    CHECK(r && rt_tr_get_version(r) == (generations ? 2u : 1u), "%s: version", name);
    rt_tr_close(r);
    rt_sim_config c;
    rt_sim_config_default(&c);
    rt_sim *direct = rt_sim_new(&c, NULL), *replayed = rt_sim_new(&c, NULL);
    rt_sim_put(direct, a, n);
    rt_tr_meta got;
    rt_sim_input in;
    CHECK(rt_sim_replay(replayed, p, RT_SIM_IN_AUTO, 0, &got, &in, &e) == 0, "%s: replay: %s", name, e.msg);
    CHECK(in.refs == n && got.generations == generations, "%s: %llu refs, %u generations", name,
          (unsigned long long)in.refs, got.generations);
    CHECK(rt_sim_check(replayed, &e) == 0, "%s: %s", name, e.msg);
    uint64_t later = 0;
    for (int i = 0; i < c.nsizes; i++)
        for (int k = 0; k < RT_NCLASS; k++)
            for (int g = -1; g < RT_MAXGEN; g++) {
                rt_sim_counts x, y;
                if (g < 0) rt_sim_get(direct, i, k, &x), rt_sim_get(replayed, i, k, &y);
                else rt_sim_get_gen(direct, i, k, g, &x), rt_sim_get_gen(replayed, i, k, g, &y);
                CHECK(same(&x, &y), "%s: size %d class %d generation %d differs after replay", name, i, k, g);
                if (g > 0) later += y.accesses;
            }
    CHECK(generations ? later > 0 : later == 0, "%s: %llu touches of later generations", name,
          (unsigned long long)later);
    rt_sim_free(direct);
    rt_sim_free(replayed);
}

static void test_replay_generations(void)
{
    enum { N = 60000 };
    rt_access *a = malloc(N * sizeof *a);
    gen(a, N, GEN_ZIPF, 4000); /* generations 0..9 */
    replay_compare("version 2", a, N, 9);
    for (size_t i = 0; i < N; i++) a[i].gen = 0;
    replay_compare("version 1", a, N, 0);
    free(a);
}

static void test_counters_64bit(void)
{
    _Static_assert(sizeof(((rt_sim_counts *)0)->accesses) == 8, "64-bit counters");
    uint64_t sz[2] = {1024, 2048};
    rt_msim *m = rt_msim_new(sz, 2, 64, NULL);
    uint64_t big = (1ULL << 32) + 12345;
    rt_msim_test_add(m, RT_CLS_RAY, 0, 2, big); /* misses everywhere */
    rt_msim_test_add(m, RT_CLS_RAY, 1, 1, big); /* misses in size 0 only */
    rt_sim_counts c;
    rt_msim_get(m, 0, RT_CLS_RAY, &c);
    CHECK(c.accesses == 2 * big && c.read_misses == big && c.write_misses == big, "64-bit sums");
    CHECK(c.traffic_bytes == 2 * big * 64, "64-bit traffic");
    rt_msim_get(m, 1, RT_CLS_RAY, &c);
    CHECK(c.read_misses == big && c.write_misses == 0, "64-bit sums, size 1");
    rt_msim_free(m);
    /* real traffic beyond 2^32 bytes: 1 GiB lines */
    rt_sim_config cf;
    rt_sim_config_default(&cf);
    cf.nsizes = 1;
    cf.sizes[0] = 1ULL << 30;
    cf.line = 1u << 30;
    rt_sim *s = rt_sim_new(&cf, NULL);
    for (int i = 0; i < 6; i++) {
        rt_access a = {(uint64_t)i << 30, 8, 1, RT_CLS_HIT, 0};
        rt_sim_put(s, &a, 1);
    }
    rt_sim_get(s, 0, RT_CLS_HIT, &c);
    CHECK(c.write_misses == 6 && c.writebacks == 5 && c.traffic_bytes == 11ULL << 30, "traffic > 2^32");
    rt_sim_free(s);
}

/* The plain and the pipelined walk of a batch, and the automatic choice
 * between them batch by batch, give the same counters (every size, class,
 * generation) and keep the invariants; the automatic choice must have used
 * both on a stream that alternates a small and a large working set. */
static void test_msim_engines(void)
{
    enum { N = 120000 };
    rt_access *a = malloc(N * sizeof *a);
    uint64_t sz[6] = {1024, 4096, 16384, 65536, 262144, 1048576};
    for (int kind = 0; kind < 4; kind++) {
        gen_stream = kind >= 2; /* streaming stores in the last two */
        if (kind < 3) {
            gen(a, N, kind, kind == 1 ? 20000 : 3000);
        } else { /* phases of 8192: a 20-line loop, then random over 30000 lines */
            for (size_t i = 0; i < N; i += 8192) {
                size_t m = N - i < 8192 ? N - i : 8192;
                gen(a + i, m, (i / 8192) % 2 ? GEN_RANDOM : GEN_CYCLIC, (i / 8192) % 2 ? 30000 : 20);
            }
        }
        rt_msim *m[3];
        for (int v = 0; v < 3; v++) {
            m[v] = rt_msim_new(sz, 6, 64, NULL);
            rt_msim_set_engine(m[v], v);
        }
        uint64_t rs0 = rs;
        for (int v = 0; v < 3; v++) {
            rs = rs0; /* the same batch sizes for all three */
            for (size_t i = 0; i < N;) {
                size_t b = 1 + rnd() % 4096;
                if (b > N - i) b = N - i;
                rt_msim_put(m[v], a + i, b);
                i += b;
            }
            rt_err e = {0};
            CHECK(rt_msim_check(m[v], &e) == 0, "engines: kind %d engine %d: %s", kind, v, e.msg);
            rt_msim_flush(m[v]);
        }
        int diff = 0;
        for (int i = 0; i < 6; i++)
            for (int k = 0; k < RT_NCLASS; k++)
                for (int g = 0; g < RT_MAXGEN; g++) {
                    rt_sim_counts x[3];
                    for (int v = 0; v < 3; v++) rt_msim_get_gen(m[v], i, k, g, &x[v]);
                    diff += !same(&x[0], &x[1]) || !same(&x[1], &x[2]);
                }
        CHECK(diff == 0, "engines: kind %d: %d counter sets differ between the plain and the pipelined walk", kind,
              diff);
        uint64_t nb[3][2];
        for (int v = 0; v < 3; v++) rt_msim_engine_batches(m[v], nb[v]);
        CHECK(nb[1][1] == 0 && nb[2][0] == 0, "engines: forced engines were not used");
        if (kind == 3)
            CHECK(nb[0][0] > 0 && nb[0][1] > 0, "engines: the automatic choice used only one walk (%llu plain, %llu "
                  "pipelined)", (unsigned long long)nb[0][0], (unsigned long long)nb[0][1]);
        for (int v = 0; v < 3; v++) rt_msim_free(m[v]);
    }
    gen_stream = 0;
    free(a);
}

/* ---- din reader --------------------------------------------------------- */

static void test_din(void)
{
    char path[] = "/tmp/rt_test_din_XXXXXX";
    int fd = mkstemp(path);
    CHECK(fd >= 0, "mkstemp");
    FILE *f = fdopen(fd, "w");
    enum { N = 20000 };
    rt_access *a = malloc(N * sizeof *a);
    for (int i = 0; i < N; i++) {
        uint64_t r = rnd();
        int label = (int)(r % 3);
        a[i] = (rt_access){(r >> 8) % 200000, 1, label == 1, RT_CLS_FB, 0};
        fprintf(f, i % 2 ? "%d %llx\n" : "%d 0x%llx trailing\n", label, (unsigned long long)a[i].addr);
        if (i == 5) fprintf(f, "\n");
    }
    fclose(f);
    rt_sim_config c;
    rt_sim_config_default(&c);
    rt_sim *s1 = rt_sim_new(&c, NULL), *s2 = rt_sim_new(&c, NULL);
    rt_sim_put(s1, a, N);
    rt_err e = {0};
    rt_din *d = rt_din_open(path, RT_CLS_FB, &e);
    CHECK(d, "din open: %s", e.msg);
    rt_access buf[1000];
    memset(buf, 0, sizeof buf); /* the din reader leaves gen as it finds it */
    long n, total = 0;
    while ((n = rt_din_read(d, buf, 1000, &e)) > 0) {
        rt_sim_put(s2, buf, (size_t)n);
        total += n;
    }
    CHECK(n == 0 && total == N, "din read: %ld records, %s", total, e.msg);
    rt_din_close(d);
    for (int i = 0; i < c.nsizes; i++) {
        rt_sim_counts x, y;
        rt_sim_get(s1, i, RT_CLS_FB, &x);
        rt_sim_get(s2, i, RT_CLS_FB, &y);
        CHECK(same(&x, &y), "din result differs from the access stream at size %d", i);
    }
    CHECK(rt_sim_sniff(path, &e) == RT_SIM_IN_DIN, "sniff din: %s", e.msg);
    rt_sim_free(s1);
    rt_sim_free(s2);
    /* a bad label is an error naming file:line */
    f = fopen(path, "w");
    fprintf(f, "0 100\n1 200\n7 300\n");
    fclose(f);
    d = rt_din_open(path, RT_CLS_FB, &e);
    n = rt_din_read(d, buf, 1000, &e);
    char want[300];
    snprintf(want, sizeof want, "%s:3:", path);
    CHECK(n < 0 && strstr(e.msg, want), "bad label message: '%s'", e.msg);
    rt_din_close(d);
    f = fopen(path, "w");
    fprintf(f, "0 zzz\n");
    fclose(f);
    d = rt_din_open(path, RT_CLS_FB, &e);
    CHECK(rt_din_read(d, buf, 1000, &e) < 0 && strstr(e.msg, ":1:"), "bad address message: '%s'", e.msg);
    rt_din_close(d);
    unlink(path);
    free(a);
}

static void test_parse(void)
{
    rt_sim_config c;
    rt_sim_config_default(&c);
    CHECK(rt_sim_parse_sizes("1K-4M", &c, NULL) == 0 && c.nsizes == 13 && c.sizes[12] == 4u << 20, "1K-4M");
    CHECK(rt_sim_parse_sizes("64K,1K,2K", &c, NULL) == 0 && c.nsizes == 3 && c.sizes[0] == 1024 &&
              c.sizes[2] == 65536, "list");
    CHECK(rt_sim_parse_sizes("1K,1K", &c, NULL) < 0, "duplicate");
    CHECK(rt_sim_parse_sizes("abc", &c, NULL) < 0, "garbage");
    rt_sim_config_default(&c);
    c.line = 48;
    c.assoc = 1;
    c.nsizes = 1;
    c.sizes[0] = 65536; /* not a multiple of 48 */
    CHECK(rt_sim_config_check(&c, NULL) < 0, "64K / 48-byte lines rejected");
}

/* ---- din reader against the getline + strtoull reader it replaced ------- */

/* The previous reader, kept as the reference: one line at a time. Returns
 * records, 0 at the end, -1 with "path:line: message". */
typedef struct ref_din {
    FILE *f;
    const char *path;
    uint64_t lineno, hash, bytes;
    char *buf;
    size_t cap;
} ref_din;

static long ref_din_read(ref_din *d, rt_access *buf, size_t cap, rt_err *e)
{
    size_t n = 0;
    while (n < cap) {
        ssize_t len = getline(&d->buf, &d->cap, d->f);
        if (len < 0) break;
        d->lineno++;
        d->bytes += (uint64_t)len;
        d->hash = rt_fnv1a(d->hash, d->buf, (size_t)len);
        unsigned long long ln = (unsigned long long)d->lineno;
        if (memchr(d->buf, 0, (size_t)len)) return rt_errf(e, "%s:%llu: NUL byte in line", d->path, ln);
        const char *p = d->buf;
        while (*p == ' ' || *p == '\t') p++;
        if (*p == '\n' || *p == '\r' || *p == 0) continue;
        if (!isdigit((unsigned char)*p)) return rt_errf(e, "%s:%llu: expected 'label address'", d->path, ln);
        char *end;
        unsigned long label = strtoul(p, &end, 10);
        if (end == p || (*end != ' ' && *end != '\t'))
            return rt_errf(e, "%s:%llu: expected 'label address'", d->path, ln);
        if (label > 2)
            return rt_errf(e, "%s:%llu: unsupported din label %lu (0 read, 1 write, 2 fetch)", d->path, ln, label);
        p = end;
        while (*p == ' ' || *p == '\t') p++;
        if (!isxdigit((unsigned char)*p)) return rt_errf(e, "%s:%llu: missing hexadecimal address", d->path, ln);
        errno = 0;
        unsigned long long addr = strtoull(p, &end, 16);
        if (errno || (*end && !isspace((unsigned char)*end)))
            return rt_errf(e, "%s:%llu: bad hexadecimal address", d->path, ln);
        buf[n++] = (rt_access){addr, 1, label == 1, RT_CLS_FB, 0};
    }
    return (long)n;
}

/* Reads path with both readers in batches of cap records and compares the
 * records, the outcome, the message and, at the end, bytes and hash. */
static void din_compare(const char *name, const char *path, size_t cap)
{
    rt_err e1 = {0}, e2 = {0};
    ref_din r = {fopen(path, "rb"), path, 0, RT_FNV_INIT, 0, NULL, 0};
    rt_din *d = rt_din_open(path, RT_CLS_FB, &e2);
    CHECK(r.f && d, "%s: open: %s", name, e2.msg);
    if (!r.f || !d) return;
    rt_access *b1 = calloc(cap, sizeof *b1), *b2 = calloc(cap, sizeof *b2);
    long n1, n2;
    uint64_t recs = 0;
    int bad = 0;
    do {
        n1 = ref_din_read(&r, b1, cap, &e1);
        n2 = rt_din_read(d, b2, cap, &e2);
        if (n1 != n2) {
            CHECK(0, "%s: after %llu records: %ld records, reference %ld ('%s' / '%s')", name,
                  (unsigned long long)recs, n2, n1, e2.msg, e1.msg);
            bad = 1;
            break;
        }
        for (long i = 0; i < n1 && !bad; i++)
            if (b1[i].addr != b2[i].addr || b1[i].write != b2[i].write || b2[i].size != 1 || b2[i].cls != RT_CLS_FB) {
                CHECK(0, "%s: record %llu: %llx/%u, reference %llx/%u", name, (unsigned long long)recs + (size_t)i,
                      (unsigned long long)b2[i].addr, b2[i].write, (unsigned long long)b1[i].addr, b1[i].write);
                bad = 1;
            }
        if (n1 > 0) recs += (uint64_t)n1;
    } while (n1 > 0 && !bad);
    if (!bad && n1 < 0) CHECK(!strcmp(e1.msg, e2.msg), "%s: message '%s', reference '%s'", name, e2.msg, e1.msg);
    if (!bad && n1 == 0) {
        CHECK(rt_din_file_bytes(d) == r.bytes && rt_din_file_hash(d) == r.hash, "%s: %llu bytes, reference %llu",
              name, (unsigned long long)rt_din_file_bytes(d), (unsigned long long)r.bytes);
        CHECK(rt_din_read(d, b2, cap, &e2) == 0, "%s: read after the end", name);
    }
    free(b1);
    free(b2);
    free(r.buf);
    fclose(r.f);
    rt_din_close(d);
}

static void test_din_reference(void)
{
    static const char *const forms[] = {
        "0 %llx\n", "1 0x%llx\n", "2 0X%llX\n", "\t 1\t%llx  trailing words\n", "0 %llx\r\n", "\n", "   \r junk\n",
        " \t \n", "00 %llx\f\n", "1 %llx\v\n", "0 0000000000000000000000%llx\n",
    };
    static const char *const bad[] = {
        "3 100\n", "99999999999999999999999 1\n", "1x 5\n", "0 \n", "0 0x\n", "0 0xg\n", "0 1ffffffffffffffff\n",
        "0 12z\n", "x 1\n", "0 1\0 2\n", "\0\n", "0 ffffffffffffffff 1\0\n", "0 -1\n", "+1 2\n", "0 0x0x1\n",
    };
    const char *path = check_path("ref.din");
    for (int t = 0; t < 400; t++) {
        FILE *f = fopen(path, "wb");
        int lines = 1 + (int)(rnd() % 60), broken = t % 3 == 0;
        int at = broken ? (int)(rnd() % (unsigned)lines) : -1;
        for (int i = 0; i < lines; i++) {
            if (i == at) {
                const char *b = bad[rnd() % (sizeof bad / sizeof bad[0])];
                size_t len = strlen(b);
                if (len == 0 || b[len - 1] != '\n') len += strlen(b + len + 1) + 1; /* lines holding a NUL */
                fwrite(b, 1, len, f);
                continue;
            }
            unsigned long long a = rnd() >> (rnd() % 64);
            fprintf(f, forms[rnd() % (sizeof forms / sizeof forms[0])], a);
        }
        if (t % 7 == 1) fprintf(f, "1 %llx", (unsigned long long)rnd()); /* no final newline */
        if (t % 11 == 2) fprintf(f, "   ");
        fclose(f);
        char name[64];
        snprintf(name, sizeof name, "din file %d", t);
        din_compare(name, path, 1 + rnd() % 40);
    }
    /* lines across block boundaries, a line longer than the first block,
     * a bad line near the end */
    for (int v = 0; v < 3; v++) {
        FILE *f = fopen(path, "wb");
        for (int i = 0; i < 120000; i++) {
            if (i == 70000 && v >= 1) {
                fputs("0 10 ", f);
                for (int k = 0; k < 300000; k++) fputc('a' + k % 26, f);
                fputc('\n', f);
            }
            if (i == 119990 && v == 2) fputs("0 0xq\n", f);
            fprintf(f, i % 5 ? "%d %llx\n" : "%d 0x%llx\n", (int)(rnd() % 3), (unsigned long long)(rnd() >> 20));
        }
        fclose(f);
        char name[64];
        snprintf(name, sizeof name, "large din %d", v);
        din_compare(name, path, 4096);
    }
}

/* ---- two-thread replay ---------------------------------------------------- */

/* A sink that refuses its third batch. */
static int refuse_put(rt_sink *s, const rt_access *a, size_t n)
{
    int *calls = s->ctx;
    return ++*calls >= 3 ? -1 : 0;
}

/* Replays path on 1 and 2 threads; everything must match: status,
 * message, references, input facts and every counter. */
static void threads_compare(const char *name, const char *path, int want_ok)
{
    rt_sim_config c;
    rt_sim_config_default(&c);
    rt_sim *s[2];
    rt_sim_input in[2];
    rt_err e[2] = {{{0}, 0}, {{0}, 0}};
    int rc[2];
    rt_tr_meta *m = calloc(2, sizeof *m);
    for (int t = 0; t < 2; t++) {
        s[t] = rt_sim_new(&c, NULL);
        rc[t] = rt_sim_replay_threads(rt_sim_sink(s[t]), path, RT_SIM_IN_AUTO, RT_CLS_FB, t + 1, &m[t], &in[t], &e[t]);
    }
    CHECK(rc[0] == rc[1] && rc[0] == (want_ok ? 0 : -1), "%s: status %d / %d ('%s')", name, rc[0], rc[1], e[0].msg);
    CHECK(rc[0] == 0 || !strcmp(e[0].msg, e[1].msg), "%s: messages '%s' / '%s'", name, e[0].msg, e[1].msg);
    CHECK(in[0].refs == in[1].refs && in[0].format == in[1].format && in[0].has_meta == in[1].has_meta &&
              in[0].file_bytes == in[1].file_bytes && in[0].file_hash == in[1].file_hash,
          "%s: input %llu / %llu refs", name, (unsigned long long)in[0].refs, (unsigned long long)in[1].refs);
    CHECK(!in[0].has_meta || !memcmp(&m[0], &m[1], sizeof m[0]), "%s: headers differ", name);
    CHECK(rt_sim_refs(s[0]) == in[0].refs && rt_sim_refs(s[1]) == in[1].refs, "%s: simulated refs", name);
    for (int i = 0; i < c.nsizes; i++)
        for (int k = 0; k < RT_NCLASS; k++)
            for (int g = 0; g < RT_MAXGEN; g++) {
                rt_sim_counts x, y;
                rt_sim_get_gen(s[0], i, k, g, &x);
                rt_sim_get_gen(s[1], i, k, g, &y);
                CHECK(same(&x, &y), "%s: size %d class %d generation %d differs between 1 and 2 threads", name, i, k, g);
            }
    rt_sim_free(s[0]);
    rt_sim_free(s[1]);
    free(m);
}

/* Writes a[0..n) as a trace with generations up to 9 (version 2); 0, or
 * -1 after a failed CHECK. */
static int write_test_trace(const char *p, const rt_access *a, size_t n)
{
    rt_tr_meta m;
    memset(&m, 0, sizeof m);
    snprintf(m.tracer, sizeof m.tracer, "test");
    rt_mm_init(&m.layout);
    m.generations = 9;
    rt_err e = {0};
    rt_tr_writer *w = rt_tr_create(p, &m, &e);
    CHECK(w, "%s: %s", p, e.msg);
    if (!w) return -1;
    rt_sink *sk = rt_tr_sink(w);
    int ok = sk->put(sk, a, n) == 0 && rt_tr_finish(w, &e) == 0;
    CHECK(ok, "%s: write: %s", p, e.msg);
    return ok ? 0 : -1;
}

static void test_replay_threads(void)
{
    enum { N = 300000 }; /* several trace chunks, many more ring slots */
    rt_access *a = malloc(N * sizeof *a);
    gen(a, N, GEN_ZIPF, 20000);
    rt_err e = {0};
    const char *p = check_path("thr.rtt");
    if (write_test_trace(p, a, N) < 0) return;
    threads_compare("rtt", p, 1);
    /* the two-thread replay equals the stream simulated in-process */
    {
        rt_sim_config c;
        rt_sim_config_default(&c);
        rt_sim *direct = rt_sim_new(&c, NULL), *two = rt_sim_new(&c, NULL);
        rt_sim_put(direct, a, N);
        rt_sim_input in;
        CHECK(rt_sim_replay_threads(rt_sim_sink(two), p, RT_SIM_IN_RTT, 0, 2, NULL, &in, &e) == 0 && in.refs == N,
              "threads: replay: %s", e.msg);
        for (int i = 0; i < c.nsizes; i++)
            for (int k = 0; k < RT_NCLASS; k++) {
                rt_sim_counts x, y;
                rt_sim_get(direct, i, k, &x);
                rt_sim_get(two, i, k, &y);
                CHECK(same(&x, &y), "threads: size %d class %d differs from the stream", i, k);
            }
        rt_sim_free(direct);
        rt_sim_free(two);
    }
    /* truncated and bit-flipped copies: same error, same partial counters */
    FILE *f = fopen(p, "rb");
    fseek(f, 0, SEEK_END);
    long size = ftell(f);
    rewind(f);
    unsigned char *bytes = malloc((size_t)size);
    CHECK(fread(bytes, 1, (size_t)size, f) == (size_t)size, "threads: read back");
    fclose(f);
    const char *q = check_path("thr-bad.rtt");
    for (int v = 0; v < 12; v++) {
        long cut = v < 6 ? size * (v + 1) / 7 : size;
        f = fopen(q, "wb");
        if (v >= 6) bytes[size * (v - 5) / 7] ^= (unsigned char)(1u << v % 8);
        fwrite(bytes, 1, (size_t)cut, f);
        if (v >= 6) bytes[size * (v - 5) / 7] ^= (unsigned char)(1u << v % 8);
        fclose(f);
        char name[64];
        snprintf(name, sizeof name, v < 6 ? "rtt cut at %ld" : "rtt bit flip %ld", v < 6 ? cut : size * (v - 5) / 7);
        threads_compare(name, q, 0);
    }
    free(bytes);
    /* din: whole, and with a bad line near the end */
    const char *dp = check_path("thr.din");
    for (int v = 0; v < 2; v++) {
        f = fopen(dp, "w");
        for (int i = 0; i < N; i++) {
            if (v && i == N - 100) fputs("1 0xfoo\n", f);
            fprintf(f, "%d %llx\n", (int)(a[i].addr % 3), (unsigned long long)a[i].addr);
        }
        fclose(f);
        threads_compare(v ? "din with a bad line" : "din", dp, !v);
    }
    /* a sink that fails: both stop with the same message, no hang */
    for (int t = 1; t <= 2; t++) {
        int calls = 0;
        rt_sink bad = {refuse_put, &calls};
        rt_sim_input in;
        CHECK(rt_sim_replay_threads(&bad, p, RT_SIM_IN_AUTO, 0, t, NULL, &in, &e) < 0 &&
                  !strcmp(e.msg, "the simulator rejected references") && in.refs == 2 * 4096,
              "threads %d: refusing sink: '%s', %llu refs", t, e.msg, (unsigned long long)in.refs);
    }
    int calls = -100;
    rt_sink none = {refuse_put, &calls};
    CHECK(rt_sim_replay_threads(&none, p, 0, 0, 0, NULL, NULL, &e) < 0 && strstr(e.msg, "threads") && calls == -100,
          "0 threads");
    CHECK(rt_sim_replay_threads(&none, p, 0, 0, 3, NULL, NULL, &e) < 0 && calls == -100, "3 threads");
    free(a);
}

/* The repeat filter of two-thread replays (sim.h, rt_repeats): on a stream
 * where a third of the references re-read the line the previous one ended
 * on, every counter of the filtered two-thread replay equals the plain
 * one-thread replay's, for several line sizes, size lists and write
 * rules; the filter did drop references; engines that may not use it offer
 * none. */
static void test_repeat_filter(void)
{
    enum { N = 200000 };
    rt_access *a = malloc(N * sizeof *a);
    gen_stream = 1;
    gen(a, N, GEN_ZIPF, 30000);
    gen_stream = 0;
    for (size_t i = 1; i < N; i++) {
        uint64_t r = rnd();
        if (r % 3) continue;
        /* a one-line reference within the line the previous one ended on
         * (at 64-byte lines; at 48 bytes some straddle, which the filter
         * must leave alone); mostly reads, some writes */
        uint64_t end = a[i - 1].addr + a[i - 1].size - 1;
        a[i].addr = (end & ~63ULL) + (r >> 8) % 60;
        a[i].size = 1 + (uint32_t)((r >> 16) % 4);
        a[i].write = (r >> 24) % 8 == 0;
    }
    rt_err e = {0};
    const char *p = check_path("rep.rtt");
    if (write_test_trace(p, a, N) < 0) return;
    for (int v = 0; v < 5; v++) {
        rt_sim_config c;
        rt_sim_config_default(&c);
        if (v == 1) c.line = 48, rt_sim_parse_sizes("1536,3072,6144,49152,393216", &c, NULL);
        if (v == 2) rt_sim_parse_sizes("16K", &c, NULL);
        if (v == 3) c.flush = 1, c.write_miss_fullline = 1;
        if (v == 4) c.line = 32;
        rt_sim *s1 = rt_sim_new(&c, &e), *s2 = rt_sim_new(&c, &e);
        CHECK(s1 && s2, "repeats %d: %s", v, e.msg);
        rt_repeats rp;
        rt_sim_repeats(s2, &rp);
        CHECK(rp.line == c.line && rp.add, "repeats %d: the stack engine offers no filter", v);
        rt_sim_input in1, in2;
        CHECK(rt_sim_replay_threads(rt_sim_sink(s1), p, RT_SIM_IN_AUTO, 0, 1, NULL, &in1, &e) == 0, "repeats %d: %s", v,
              e.msg);
        CHECK(rt_sim_replay_filtered(rt_sim_sink(s2), &rp, p, RT_SIM_IN_AUTO, 0, 2, NULL, &in2, &e) == 0,
              "repeats %d: filtered: %s", v, e.msg);
        CHECK(in1.refs == N && in2.refs == N && in1.repeats == 0, "repeats %d: refs", v);
        CHECK(in2.repeats > N / 10 && in2.repeats < N / 2, "repeats %d: %llu references dropped", v,
              (unsigned long long)in2.repeats);
        CHECK(rt_sim_refs(s1) == N && rt_sim_refs(s2) == N, "repeats %d: simulated refs", v);
        rt_sim_finish(s1);
        rt_sim_finish(s2);
        int diff = 0;
        for (int i = 0; i < c.nsizes; i++)
            for (int k = 0; k < RT_NCLASS; k++)
                for (int g = 0; g < RT_MAXGEN; g++) {
                    rt_sim_counts x, y;
                    rt_sim_get_gen(s1, i, k, g, &x);
                    rt_sim_get_gen(s2, i, k, g, &y);
                    diff += !same(&x, &y);
                }
        CHECK(diff == 0, "repeats %d: %d counter sets differ from the unfiltered replay", v, diff);
        CHECK(rt_sim_check(s2, &e) == 0, "repeats %d: invariant: %s", v, e.msg);
        rt_sim_free(s1);
        rt_sim_free(s2);
    }
    /* engines that may not drop them: set-associative, no-write-allocate */
    for (int v = 0; v < 2; v++) {
        rt_sim_config c;
        rt_sim_config_default(&c);
        if (v == 0) c.assoc = 4;
        else c.no_write_allocate = 1, c.write_through = 1;
        rt_sim *s = rt_sim_new(&c, &e);
        rt_repeats rp;
        rt_sim_repeats(s, &rp);
        CHECK(rp.line == 0, "repeats: per-size engine %d offers a filter", v);
        rt_sim_free(s);
    }
    /* through rt_approx: the exact method forwards the filter, sampled ones offer none */
    rt_sim_config c;
    rt_sim_config_default(&c);
    for (int meth = 0; meth < 2; meth++) {
        rt_approx_config ac;
        rt_approx_config_default(&ac);
        ac.method = meth ? RT_APPROX_HYBRID : RT_APPROX_EXACT;
        rt_approx *ap = rt_approx_new(&c, &ac, &e);
        CHECK(ap, "repeats: approx: %s", e.msg);
        rt_repeats rp;
        rt_approx_repeats(ap, &rp);
        CHECK(meth ? rp.line == 0 : rp.line == 64, "repeats: approx method %d filter line %u", meth, rp.line);
        rt_approx_free(ap);
    }
    free(a);
}

int main(void)
{
    enum { N = 150000 };
    rt_access *a = malloc(N * sizeof *a);
    if (!check_tmpdir("test_sim")) return perror("mkdtemp"), 1;
    test_parse();
    test_cycles();
    test_writebacks_by_hand();
    test_flush_fullline_by_hand();
    test_stream_by_hand();
    test_generations_by_hand();
    test_replay_generations();
    test_counters_64bit();
    test_msim_engines();
    test_repeat_filter();
    test_din();

    /* one-pass fully associative vs naive, sizes 1K..64K */
    rt_sim_config c;
    rt_sim_config_default(&c);
    CHECK(rt_sim_parse_sizes("1K-64K", &c, NULL) == 0, "sizes");
    const char *kinds[3] = {"random", "zipf", "cyclic"};
    const uint64_t fp[3] = {1500, 6000, 700};
    for (int k = 0; k < 3; k++) {
        gen(a, N, k, fp[k]);
        char name[64];
        snprintf(name, sizeof name, "full/%s", kinds[k]);
        compare(name, &c, a, N);
    }
    /* Dinero accounting: end-of-run flush, full-line writes, and both */
    for (int v = 1; v <= 3; v++) {
        rt_sim_config d = c;
        d.flush = v & 1;
        d.write_miss_fullline = v >> 1 & 1;
        gen(a, N / 3, GEN_ZIPF, 3000);
        char name[64];
        snprintf(name, sizeof name, "full/%s", rt_sim_policy_name(&d));
        compare(name, &d, a, N / 3);
    }
    /* streaming stores mixed with reads and writes: plain, with the flush,
     * with full-line writes, and both */
    gen_stream = 1;
    for (int v = 0; v <= 3; v++) {
        rt_sim_config d = c;
        d.flush = v & 1;
        d.write_miss_fullline = v >> 1 & 1;
        gen(a, N / 3, v == 2 ? GEN_CYCLIC : GEN_ZIPF, 3000);
        char name[64];
        snprintf(name, sizeof name, "full/stream/%s", rt_sim_policy_name(&d));
        compare(name, &d, a, N / 3);
    }
    gen_stream = 0;
    /* the stack simulator's state grows with the lines seen (4096 nodes at
     * first): 1K-1M (16384 lines) over 6000 distinct lines grows it and its
     * hash table twice, mid-stream; still equal to naive */
    {
        rt_sim_config g = c;
        CHECK(rt_sim_parse_sizes("1K-1M", &g, NULL) == 0, "sizes");
        gen(a, N / 3, GEN_RANDOM, 6000);
        compare("full/growing", &g, a, N / 3);
    }
    /* odd sizes and line size (non-power-of-two path) */
    rt_sim_config odd = c;
    odd.line = 48;
    odd.nsizes = 4;
    odd.sizes[0] = 48, odd.sizes[1] = 480, odd.sizes[2] = 4800, odd.sizes[3] = 48000;
    gen(a, N / 2, GEN_ZIPF, 3000);
    compare("full/48-byte lines", &odd, a, N / 2);

    /* the paper's 13 sizes: one-pass vs the independent per-size engine,
     * which itself is checked against naive below */
    rt_sim_config_default(&c);
    enum { NB = 400000 };
    rt_access *b = malloc(NB * sizeof *b);
    gen(b, NB, GEN_ZIPF, 150000);
    {
        rt_sim_config pc = c;
        pc.no_write_allocate = 0;
        rt_sim *one = rt_sim_new(&c, NULL);
        /* per-size engine with the same policy: force by a 1-set "assoc" */
        rt_sim *per[RT_SIM_PAPER_NSIZES];
        rt_sim_put(one, b, NB);
        rt_err e = {0};
        CHECK(rt_sim_check(one, &e) == 0, "13 sizes invariant: %s", e.msg);
        for (int i = 0; i < c.nsizes; i++) {
            pc.nsizes = 1;
            pc.sizes[0] = c.sizes[i];
            pc.assoc = (uint32_t)(c.sizes[i] / 64); /* one set = fully associative */
            per[i] = rt_sim_new(&pc, NULL);
            rt_sim_put(per[i], b, NB);
            for (int k = 0; k < RT_NCLASS; k++)
                for (int g = 0; g < RT_MAXGEN; g++) {
                    rt_sim_counts x, y;
                    rt_sim_get_gen(one, i, k, g, &x);
                    rt_sim_get_gen(per[i], 0, k, g, &y);
                    CHECK(same(&x, &y), "13 sizes: size %llu class %d generation %d differs",
                          (unsigned long long)c.sizes[i], k, g);
                }
            rt_sim_free(per[i]);
        }
        rt_sim_free(one);
    }
    free(b);

    /* set-associative, direct-mapped, write policies, any line size */
    struct {
        const char *name;
        uint32_t line, assoc;
        int wt, nwa;
        const char *sizes;
        int flush, fullline;
    } sa[] = {
        {"direct-mapped 64", 64, 1, 0, 0, "1K,4K,16K", 0, 0},
        {"2-way 64", 64, 2, 0, 0, "1K,8K", 0, 0},
        {"4-way 32 wt", 32, 4, 1, 0, "2K,8K", 0, 0},
        {"8-way 64 nwa", 64, 8, 0, 1, "4K,32K", 0, 0},
        {"4-way 64 wt nwa", 64, 4, 1, 1, "4K", 0, 0},
        {"full wt", 64, 0, 1, 0, "1K,4K", 0, 0},
        {"direct-mapped 48 (Purcell)", 48, 1, 0, 0, "48K,96K", 0, 0},
        {"texture 64K direct 48B", 48, 1, 0, 0, "64K", 0, 0},
        {"2-way 64 flush fullline", 64, 2, 0, 0, "1K,8K", 1, 1},
        {"direct-mapped 32 flush", 32, 1, 0, 0, "2K", 1, 0},
        {"4-way 64 wt fullline", 64, 4, 1, 0, "4K", 0, 1},
        {"8-way 64 nwa flush fullline", 64, 8, 0, 1, "4K", 1, 1},
        {"full wt flush", 64, 0, 1, 0, "1K,4K", 1, 0},
    };
    for (size_t t = 0; t < sizeof sa / sizeof sa[0]; t++) {
        rt_sim_config_default(&c);
        if (rt_sim_parse_sizes(sa[t].sizes, &c, NULL)) CHECK(0, "sizes %s", sa[t].sizes);
        c.line = sa[t].line;
        c.assoc = sa[t].assoc;
        c.write_through = sa[t].wt;
        c.no_write_allocate = sa[t].nwa;
        c.flush = sa[t].flush;
        c.write_miss_fullline = sa[t].fullline;
        if (c.sizes[0] == 65536 && c.line == 48) {
            /* 64 KB is not a multiple of 48: the texture cache holds
             * floor(65536 / 48) = 1365 lines; model it as 1365 * 48 bytes */
            c.sizes[0] = 1365 * 48;
        }
        for (int k = 0; k < 3; k++) {
            gen(a, N / 3, k, fp[k] * 2);
            char name[96];
            snprintf(name, sizeof name, "%s/%s", sa[t].name, kinds[k]);
            compare(name, &c, a, N / 3);
        }
        /* and with streaming stores among the writes */
        gen_stream = 1;
        gen(a, N / 4, GEN_ZIPF, fp[1] * 2);
        char name[96];
        snprintf(name, sizeof name, "%s/stream", sa[t].name);
        compare(name, &c, a, N / 4);
        gen_stream = 0;
    }
    free(a);

    /* benchmark entry point runs (short) */
    FILE *devnull = fopen("/dev/null", "w");
    CHECK(rt_sim_bench_n(devnull, 100000) == 0, "bench");
    fclose(devnull);

    test_din_reference();
    test_replay_threads();

    check_rmdir();
    if (failures) fprintf(stderr, "test_sim: %d failures\n", failures);
    else printf("test_sim: ok\n");
    return failures ? 1 : 0;
}
