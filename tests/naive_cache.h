/*
 * naive_cache.h -- the naive reference cache of the tests (test_repl.c,
 * test_mcore.c): one cache of one size as plain arrays, for every set
 * `ways` entries (tag, valid, dirty, last writer's class and generation)
 * and, per policy, the obvious state: LRU the time of the last touch, FIFO
 * the round-robin hand of hardware (the way filled longest ago while ways
 * fill in order, as they do without invalidations), PLRU a bit tree,
 * SRRIP/BRRIP the RRPVs, random and BRRIP the xorshift64* stream, OPT the
 * whole future. Lookups are linear scans; nothing is shared with the
 * engines but the accounting rules of docs/cachesim.md. For the multi-core
 * reference, naive_drop and naive_clean take a line away or clean it (an
 * invalidated way is simply invalid: a miss fills the lowest invalid way
 * first). Header-only (static functions): include it in one test file.
 */
#ifndef RT_TEST_NAIVE_CACHE_H
#define RT_TEST_NAIVE_CACHE_H

#include "sim.h"

#include <stdlib.h>
#include <string.h>


enum { P_LRU, P_FIFO, P_RANDOM, P_PLRU, P_SRRIP, P_BRRIP, P_OPT };

/* OPT's reference needs the future: the line touches of the whole stream */
typedef struct ltouch {
    uint64_t line;
    int w, cls, g;
    uint64_t bytes, lo;
} ltouch;

typedef struct way {
    uint64_t tag;
    int valid, dirty;
    uint8_t wcls, wgen;
    uint64_t filled; /* time of the fill (FIFO) */
    uint64_t used;   /* time of the last touch (LRU) */
    unsigned rrpv;   /* re-reference prediction value (SRRIP, BRRIP) */
} way;

typedef struct naive {
    int pol;
    uint64_t line, nsets, ways;
    int wt, nwa, fullline;
    way *w; /* nsets * ways */
    uint8_t *bit; /* PLRU: per set, ways bits; bit[k] for inner node k of the tree in heap order */
    uint64_t rng; /* random and BRRIP: xorshift64* seeded as docs/cachesim.md says */
    rt_access *out;    /* a level above another: what it sends down, in order (NULL: nothing) */
    size_t nout, capout;
    int below;         /* 1: record what it sends down */
    const ltouch *fut; /* OPT: every touch, and how many */
    uint64_t nfut;
    uint64_t now;
    uint64_t *hand; /* FIFO: per set, the way the next eviction takes */
    rt_sim_counts c[RT_NCLASS][RT_MAXGEN];
} naive;

static naive *naive_new(int pol, const rt_sim_config *cf, uint64_t size)
{
    naive *n = calloc(1, sizeof *n);
    uint64_t lines = size / cf->line;
    n->pol = pol;
    n->line = cf->line;
    n->ways = cf->assoc ? cf->assoc : lines;
    n->nsets = lines / n->ways;
    n->wt = cf->write_through;
    n->nwa = cf->no_write_allocate;
    n->fullline = cf->write_miss_fullline;
    n->w = calloc(lines, sizeof *n->w);
    n->bit = calloc(lines, 1);
    n->hand = calloc(n->nsets, sizeof *n->hand);
    n->rng = cf->seed * 0x9E3779B97F4A7C15ULL + 0x2545F4914F6CDD1DULL;
    if (!n->rng) n->rng = 1;
    return n;
}

/* A reference sent to the level below. */
static void naive_emit(naive *n, uint64_t addr, uint64_t size, int w, int cls, int g)
{
    if (!n->below) return;
    if (n->nout == n->capout) n->out = realloc(n->out, (n->capout = n->capout ? 2 * n->capout : 4096) * sizeof *n->out);
    rt_access *o = &n->out[n->nout++];
    memset(o, 0, sizeof *o);
    o->addr = addr;
    o->size = (uint32_t)size;
    o->write = (uint8_t)w;
    o->cls = (uint8_t)cls;
    o->gen = (uint8_t)g;
}

static void naive_free(naive *n)
{
    free(n->out);
    free(n->w);
    free(n->bit);
    free(n->hand);
    free(n);
}

/* xorshift64*, a value in 0..m-1 */
static uint64_t naive_rand(naive *n, uint64_t m)
{
    uint64_t x = n->rng;
    x ^= x >> 12;
    x ^= x << 25;
    x ^= x >> 27;
    n->rng = x;
    return ((x * 0x2545F4914F6CDD1DULL) >> 32) % m;
}

/* PLRU: points the nodes above way i away from it. The tree over ways
 * [lo, hi) at node k: the left half [lo, mid) under 2k, the right under
 * 2k+1; bit 1 = the victim is on the right. */
static void plru_use(naive *n, uint8_t *bit, uint64_t i)
{
    uint64_t lo = 0, hi = n->ways, k = 1;
    while (hi - lo > 1) {
        uint64_t mid = (lo + hi) / 2;
        if (i < mid) bit[k] = 1, hi = mid, k = 2 * k;
        else bit[k] = 0, lo = mid, k = 2 * k + 1;
    }
}

static uint64_t plru_find(naive *n, const uint8_t *bit)
{
    uint64_t lo = 0, hi = n->ways, k = 1;
    while (hi - lo > 1) {
        uint64_t mid = (lo + hi) / 2;
        if (bit[k]) lo = mid, k = 2 * k + 1;
        else hi = mid, k = 2 * k;
    }
    return lo;
}

/* The way a full set gives up. */
static uint64_t naive_victim(naive *n, way *s, uint8_t *bit)
{
    if (n->pol == P_RANDOM) return naive_rand(n, n->ways);
    if (n->pol == P_PLRU) return plru_find(n, bit);
    if (n->pol == P_OPT) { /* the line used again last; among those never used again, the one seen first */
        uint64_t best = 0, bestd = 0, bestfirst = UINT64_MAX;
        for (uint64_t i = 0; i < n->ways; i++) {
            uint64_t d = n->now; /* touches are numbered from 1: fut[now - 1] is the current one */
            while (d < n->nfut && n->fut[d].line != s[i].tag) d++;
            if (d == n->nfut) {
                uint64_t first = 0;
                while (n->fut[first].line != s[i].tag) first++;
                if (bestd != n->nfut || first < bestfirst) best = i, bestfirst = first;
                bestd = n->nfut;
            } else if (d > bestd) best = i, bestd = d;
        }
        return best;
    }
    if (n->pol == P_SRRIP || n->pol == P_BRRIP)
        for (;;) { /* the paper's loop: the first distant way, else age them all */
            for (uint64_t i = 0; i < n->ways; i++)
                if (s[i].rrpv == 3) return i;
            for (uint64_t i = 0; i < n->ways; i++) s[i].rrpv++;
        }
    if (n->pol == P_FIFO) { /* the hand, then the next way */
        uint64_t *h = n->hand + (uint64_t)(s - n->w) / n->ways, v = *h;
        *h = (v + 1) % n->ways;
        return v;
    }
    uint64_t best = 0;
    for (uint64_t i = 1; i < n->ways; i++)
        if (s[i].used < s[best].used) best = i;
    return best;
}

static void naive_touch(naive *n, uint64_t L, int wr, int cls, int g, uint64_t bytes, uint64_t lo)
{
    way *s = n->w + (L % n->nsets) * n->ways;
    uint8_t *bit = n->bit + (L % n->nsets) * n->ways;
    rt_sim_counts *c = &n->c[cls][g];
    n->now++;
    c->accesses++;
    uint64_t i;
    way wb;
    int haswb = 0;
    for (i = 0; i < n->ways; i++)
        if (s[i].valid && s[i].tag == L) break;
    if (i == n->ways) { /* miss */
        if (wr) c->write_misses++;
        else c->read_misses++;
        if (wr && n->nwa) {
            c->wt_bytes += bytes;
            naive_emit(n, lo, bytes, 1, cls, g);
            return;
        }
        int nofetch = wr == RT_WRITE_STREAM || (wr && n->fullline && bytes == n->line);
        if (nofetch) c->nofetch++;
        for (i = 0; i < n->ways; i++)
            if (!s[i].valid) break;
        if (i == n->ways) {
            i = naive_victim(n, s, bit);
            if (s[i].dirty) {
                n->c[s[i].wcls][s[i].wgen].writebacks++;
                wb = s[i]; /* goes down after the fetch and the written-through bytes (Dinero IV's order) */
                haswb = 1;
            }
        }
        if (!nofetch) naive_emit(n, L * n->line, n->line, 0, cls, g);
        s[i].valid = 1;
        s[i].tag = L;
        s[i].dirty = 0;
        s[i].filled = n->now;
        if (n->pol == P_SRRIP) s[i].rrpv = 2;
        if (n->pol == P_BRRIP) s[i].rrpv = naive_rand(n, 32) == 0 ? 2 : 3;
    } else {
        s[i].rrpv = 0;
    }
    s[i].used = n->now;
    if (n->pol == P_PLRU) plru_use(n, bit, i);
    if (wr) {
        if (n->wt) c->wt_bytes += bytes, naive_emit(n, lo, bytes, 1, cls, g);
        else s[i].dirty = 1, s[i].wcls = (uint8_t)cls, s[i].wgen = (uint8_t)g;
    }
    if (haswb) naive_emit(n, wb.tag * n->line, n->line, 1, wb.wcls, wb.wgen);
}

static void naive_put(naive *n, const rt_access *a, size_t cnt)
{
    if (n->pol == P_OPT) { /* collect the touches first, then replay them knowing the future */
        ltouch *t = NULL;
        uint64_t nt = 0, cap = 0;
        for (size_t i = 0; i < cnt; i++) {
            uint64_t sz = a[i].size ? a[i].size : 1, end = a[i].addr + sz;
            for (uint64_t L = a[i].addr / n->line; L * n->line < end; L++) {
                if (nt == cap) t = realloc(t, (cap = cap ? 2 * cap : 1024) * sizeof *t);
                uint64_t lo = L * n->line > a[i].addr ? L * n->line : a[i].addr;
                uint64_t hi = (L + 1) * n->line < end ? (L + 1) * n->line : end;
                t[nt].line = L;
                t[nt].w = a[i].write;
                t[nt].cls = a[i].cls < RT_NCLASS ? a[i].cls : RT_CLS_FB;
                t[nt].g = a[i].gen < RT_MAXGEN - 1 ? a[i].gen : RT_MAXGEN - 1;
                t[nt].lo = lo;
                t[nt++].bytes = hi - lo;
            }
        }
        n->fut = t;
        n->nfut = nt;
        for (uint64_t i = 0; i < nt; i++) naive_touch(n, t[i].line, t[i].w, t[i].cls, t[i].g, t[i].bytes, t[i].lo);
        free(t);
        n->fut = NULL;
        return;
    }
    for (size_t i = 0; i < cnt; i++) {
        uint64_t sz = a[i].size ? a[i].size : 1;
        uint64_t end = a[i].addr + sz;
        for (uint64_t L = a[i].addr / n->line; L * n->line < end; L++) {
            uint64_t lo = L * n->line > a[i].addr ? L * n->line : a[i].addr;
            uint64_t hi = (L + 1) * n->line < end ? (L + 1) * n->line : end;
            int g = a[i].gen < RT_MAXGEN - 1 ? a[i].gen : RT_MAXGEN - 1;
            int cls = a[i].cls < RT_NCLASS ? a[i].cls : RT_CLS_FB;
            naive_touch(n, L, a[i].write, cls, g, hi - lo, lo);
        }
    }
}

/* The end-of-run flush in Dinero IV's order: sets from the last; within a
 * set LRU goes from the least recently used line up, the other policies
 * from the last way down (the order a level below sees the write-backs in). */
static void naive_flush(naive *n)
{
    for (uint64_t st = n->nsets; st-- > 0;) {
        way *s = n->w + st * n->ways;
        for (uint64_t done = 0; done < n->ways; done++) {
            uint64_t k = n->ways - 1 - done;
            if (n->pol == P_LRU) { /* the done-th least recent valid way */
                k = n->ways;
                for (uint64_t i = 0; i < n->ways; i++) {
                    if (!s[i].valid) continue;
                    uint64_t older = 0;
                    for (uint64_t j = 0; j < n->ways; j++) older += s[j].valid && s[j].used < s[i].used;
                    if (older == done) k = i;
                }
                if (k == n->ways) break;
            }
            if (s[k].valid && s[k].dirty) {
                n->c[s[k].wcls][s[k].wgen].writebacks++;
                naive_emit(n, s[k].tag * n->line, n->line, 1, s[k].wcls, s[k].wgen);
                s[k].dirty = 0;
            }
        }
    }
}

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

/* ---- coherence (the multi-core reference) ---- */

/* Takes line away: 0 absent, 1 clean, 2 dirty (*cls, *gen of its last write). */
static inline int naive_drop(naive *n, uint64_t L, int *cls, int *gen)
{
    way *s = n->w + (L % n->nsets) * n->ways;
    for (uint64_t i = 0; i < n->ways; i++)
        if (s[i].valid && s[i].tag == L) {
            int d = s[i].dirty;
            if (d) *cls = s[i].wcls, *gen = s[i].wgen;
            s[i].valid = s[i].dirty = 0;
            return 1 + d;
        }
    return 0;
}

/* Cleans line: 1 if it was dirty (*cls, *gen as above). */
static inline int naive_clean(naive *n, uint64_t L, int *cls, int *gen)
{
    way *s = n->w + (L % n->nsets) * n->ways;
    for (uint64_t i = 0; i < n->ways; i++)
        if (s[i].valid && s[i].tag == L && s[i].dirty) {
            *cls = s[i].wcls, *gen = s[i].wgen;
            s[i].dirty = 0;
            return 1;
        }
    return 0;
}

#endif
