/*
 * opt.c -- Belady's MIN (OPT), the offline optimal replacement, as an
 * entry of the engine table (engine.h, repl "opt").
 *
 * WHAT IT IS. On a miss in a full set, MIN evicts the resident line whose
 * next use lies farthest in the future (never used again counts as
 * infinitely far; ties go to the lowest slot). It gives the fewest misses
 * of any replacement policy for each set and size (Belady 1966; Mattson et
 * al. 1970), so it is the floor every policy and every ray order is
 * measured against. It minimizes misses, not write-backs: a policy may
 * write back less by keeping dirty lines.
 *
 * HOW. MIN needs each touch's next use, so the engine buffers the stream
 * and simulates when the run ends (finish):
 *   1. access() splits every reference into line touches (the accounting of
 *      docs/cachesim.md) and appends them: a dense id per distinct line (an
 *      open-addressing table line -> id, 16-byte slots), the write kind, the (class,
 *      generation) index and the bytes inside the line: 12 bytes a touch,
 *      plus 8 (ids) and 32 to 64 (table slots) per distinct line.
 *   2. finish() makes one backward pass over the touches, giving each the
 *      index of the next touch of its line (one array of the last index
 *      seen per line id): O(touches) time, 4 bytes a touch.
 *   3. then, per size, one forward pass: per set an indexed 4-ary max-heap
 *      of the resident slots keyed by next use, a slot per line id (no
 *      hash), so a touch costs O(log ways).
 * Counters are read after finish (before it they are zero); a later finish
 * simulates everything buffered from cold again (with cfg.flush the dirty
 * lines are written back at the end of each such simulation).
 * Memory: 12 bytes a touch (a trace of 10^8 line touches needs 1.2 GB,
 * checked against the memory limit as the buffer grows) and 40 to 72 bytes
 * per distinct line (ids, table, next-use scratch), plus 22 bytes per line of the size being simulated
 * (per size) or 20 bytes per distinct line and 8 per line of the largest size (one pass).
 * Lines up to 65535 bytes (the bytes of a touch are 16 bits).
 *
 * INVARIANTS (rt_sim_check -> opt_check):
 *   O1 every touch's line id is below the number of ids, and ids[] maps
 *      each id back to a line whose table entry names it;
 *   O2 after finish, next[i] is NONE or > i, and touch next[i] has the same
 *      line id as touch i, with no touch of that id in between;
 *   O3 per size and (class, generation): misses <= accesses, write-backs
 *      <= write touches, no-fetch misses <= write misses.
 */
#include "engine.h"
#include "sim_int.h"

#include <stdlib.h>
#include <string.h>

#define NONE UINT32_MAX
/* heap arity (the one-pass groups and the per-size sets; see o_down) */
#define OARY 4
/* touches ahead whose line record is prefetched in the one-pass run */
#define OPT_AHEAD 16

typedef struct otouch {
    uint32_t id;    /* dense line id */
    uint8_t w;      /* 0 read, 1 write, RT_WRITE_STREAM */
    uint8_t cg;     /* (class, generation) index */
    uint16_t bytes; /* bytes of the reference inside the line (<= 65535: lines up to 64 KB) */
    uint32_t next;  /* next touch of the same line (after finish), NONE = never */
} otouch;

typedef struct oslot {
    uint64_t key; /* the line */
    uint32_t val; /* its id, NONE = empty */
    uint32_t pad;
} oslot;

typedef struct ocount {
    uint64_t acc[RT_SIM_NCG], rm[RT_SIM_NCG], wm[RT_SIM_NCG], wb[RT_SIM_NCG], wtb[RT_SIM_NCG], nf[RT_SIM_NCG];
    uint64_t wr[RT_SIM_NCG];
} ocount;

typedef struct opt {
    rt_sim_config cfg;
    otouch *t;          /* touches */
    uint64_t nt, capt;  /* used, allocated */
    uint64_t *ids;      /* id -> line */
    uint32_t nid, capid;
    oslot *ht;          /* table line -> id (one 16-byte slot: a probe reads one cache line) */
    uint64_t hcap;      /* power of two, >= 2 * capid */
    uint64_t memo_line; /* the line of the latest touch, and its id (NONE: none yet) */
    uint32_t memo_id;
    int done;           /* finish ran on the current touches */
    int oom;            /* growth failed: later batches are refused */
    ocount *cnt;        /* per size */
    uint64_t rep[RT_SIM_NCG]; /* reads counted by the repeat filter: hits in every size */
    double sec[2];            /* the last finish: backward pass, forward simulation (s) */
} opt;

static inline uint64_t hsl(uint64_t line, uint64_t cap) { return (line * 0x9E3779B97F4A7C15ULL) & (cap - 1); }

static int grow_table(opt *o, rt_err *e)
{
    uint64_t cap = o->hcap ? o->hcap * 2 : 1024;
    oslot *t = rt_calloc_aligned(cap, sizeof *t, 64, e);
    if (!t) return -1;
    for (uint64_t i = 0; i < cap; i++) t[i].val = NONE;
    for (uint32_t id = 0; id < o->nid; id++) {
        uint64_t h = hsl(o->ids[id], cap);
        while (t[h].val != NONE) h = (h + 1) & (cap - 1);
        t[h].key = o->ids[id];
        t[h].val = id;
    }
    free(o->ht);
    o->ht = t;
    o->hcap = cap;
    return 0;
}

static uint32_t line_id(opt *o, uint64_t line, rt_err *e)
{
    uint64_t h = hsl(line, o->hcap);
    for (; o->ht[h].val != NONE; h = (h + 1) & (o->hcap - 1))
        if (o->ht[h].key == line) return o->ht[h].val;
    if (o->nid == o->capid) {
        if (o->capid >= (1u << 31)) return rt_errf(e, "opt: more than 2^31 distinct lines"), NONE;
        uint32_t nc = o->capid ? o->capid * 2 : 1024;
        uint64_t *ni = rt_reallocarray(o->ids, nc, sizeof *ni, e);
        if (!ni) return NONE;
        o->ids = ni;
        o->capid = nc;
    }
    if (2 * (uint64_t)(o->nid + 1) > o->hcap) {
        if (grow_table(o, e)) return NONE;
        h = hsl(line, o->hcap);
        while (o->ht[h].val != NONE) h = (h + 1) & (o->hcap - 1);
    }
    o->ht[h].key = line;
    o->ht[h].val = o->nid;
    o->ids[o->nid] = line;
    return o->nid++;
}

/* Whether every size runs in one pass (run_onepass): fully associative,
 * write-back, write-allocate, at most 255 sizes of group index. */
static int opt_onepass(const rt_sim_config *c) { return c->assoc == 0 && !c->write_through && !c->no_write_allocate; }

static uint64_t opt_state_bytes(const rt_sim_config *c)
{
    (void)c;
    return 0; /* grows with the touches */
}

static void opt_destroy(void *st)
{
    opt *o = st;
    if (!o) return;
    free(o->t);
    free(o->ids);
    free(o->ht);
    free(o->cnt);
    free(o);
}

static void *opt_create(const rt_sim_config *c, rt_err *e)
{
    if (c->line > 65535) return rt_errf(e, "opt: lines of %u bytes (at most 65535)", c->line), NULL;
    opt *o = rt_calloc(1, sizeof *o, e);
    if (!o) return NULL;
    o->cfg = *c;
    o->memo_id = NONE;
    o->cnt = rt_calloc((size_t)c->nsizes, sizeof *o->cnt, e);
    if (!o->cnt || grow_table(o, e)) {
        opt_destroy(o);
        return NULL;
    }
    return o;
}

static int push(opt *o, uint64_t line, unsigned w, unsigned cg, uint32_t bytes, rt_err *e)
{
    if (o->nt == o->capt) {
        if (o->capt >= NONE - 1) return rt_errf(e, "opt: more than 2^32 line touches");
        uint64_t nc = o->capt ? o->capt * 2 : 65536;
        if (nc >= NONE) nc = NONE - 1;
        char what[96];
        snprintf(what, sizeof what, "buffering %llu line touches for OPT", (unsigned long long)nc);
        if (rt_mem_fits(nc * sizeof(otouch), what, e) < 0) return -1;
        otouch *nt = rt_reallocarray(o->t, nc, sizeof *nt, e);
        if (!nt) return -1;
        o->t = nt;
        o->capt = nc;
    }
    uint32_t id = o->memo_id != NONE && o->memo_line == line ? o->memo_id : line_id(o, line, e);
    if (id == NONE) return -1;
    o->memo_line = line;
    o->memo_id = id;
    otouch *t = &o->t[o->nt++];
    t->id = id;
    t->w = (uint8_t)w;
    t->cg = (uint8_t)cg;
    t->bytes = (uint16_t)bytes;
    t->next = NONE;
    return 0;
}

static int opt_access(void *st, const rt_access *a, size_t n)
{
    opt *o = st;
    if (o->oom) return -1;
    const uint64_t ls = o->cfg.line;
    /* a power-of-two line (the usual case): shifts instead of the three
     * 64-bit divisions a reference costs otherwise */
    const int sh = (ls & (ls - 1)) == 0 ? __builtin_ctzll(ls) : -1;
    rt_err e = {0};
    o->done = 0;
    for (size_t i = 0; i < n; i++) {
        uint64_t addr = a[i].addr;
        uint32_t sz = a[i].size ? a[i].size : 1;
        unsigned cg = rt_sim_cg(&a[i]);
        unsigned w = a[i].write == RT_WRITE_STREAM ? RT_WRITE_STREAM : a[i].write != 0;
        if (i + OPT_AHEAD < n) { /* the table slots of a reference ahead */
            uint64_t ahead = a[i + OPT_AHEAD].addr;
            uint64_t h = hsl(sh >= 0 ? ahead >> sh : ahead / ls, o->hcap);
            __builtin_prefetch(&o->ht[h]);
        }
        uint64_t end = addr + sz, first = sh >= 0 ? addr >> sh : addr / ls, last = sh >= 0 ? (end - 1) >> sh : (end - 1) / ls;
        if (first == last) { /* one line: the whole reference is inside it */
            if (push(o, first, w, cg, sz, &e)) {
                o->oom = 1;
                return -1;
            }
            continue;
        }
        for (uint64_t L = first; L <= last; L++) {
            uint64_t lo = L == first ? addr : L * ls, hi = L == last ? end : (L + 1) * ls;
            if (push(o, L, w, cg, (uint32_t)(hi - lo), &e)) {
                o->oom = 1;
                return -1;
            }
        }
    }
    return 0;
}

/* ---- the forward pass of one size ---- */

typedef struct fwd {
    uint32_t ways;
    uint64_t nsets;
    uint32_t *heap;  /* per set, ways slots: a max-heap by key */
    uint32_t *used;  /* per set */
    uint32_t *pos;   /* slot -> heap position within its set */
    uint32_t *key;   /* slot -> next use (NONE = never: the largest) */
    uint32_t *line;  /* slot -> line id */
    uint8_t *dirty, *wcg;
    uint32_t *slot;  /* line id -> slot, NONE = not resident */
} fwd;

/* key order; ties (lines never used again) go to the lower line id, the
 * line seen first: a priority that does not depend on the size, so MIN
 * stays a stack algorithm and the one-pass run gives the same numbers */
static inline int above(const fwd *f, uint32_t a, uint32_t b)
{
    return f->key[a] > f->key[b] || (f->key[a] == f->key[b] && f->line[a] < f->line[b]);
}

static void sift_up(fwd *f, uint32_t *h, uint32_t i)
{
    uint32_t x = h[i];
    while (i > 0) {
        uint32_t p = (i - 1) / OARY;
        if (!above(f, x, h[p])) break;
        h[i] = h[p];
        f->pos[h[i]] = i;
        i = p;
    }
    h[i] = x;
    f->pos[x] = i;
}

static void sift_down(fwd *f, uint32_t *h, uint32_t n, uint32_t i)
{
    uint32_t x = h[i];
    for (;;) {
        uint32_t c = OARY * i + 1;
        if (c >= n) break;
        uint32_t e = c + OARY < n ? c + OARY : n;
        for (uint32_t q = c + 1; q < e; q++)
            if (above(f, h[q], h[c])) c = q;
        if (!above(f, h[c], x)) break;
        h[i] = h[c];
        f->pos[h[i]] = i;
        i = c;
    }
    h[i] = x;
    f->pos[x] = i;
}

static void fwd_free(fwd *f)
{
    free(f->heap);
    free(f->used);
    free(f->pos);
    free(f->key);
    free(f->line);
    free(f->dirty);
    free(f->wcg);
    free(f->slot);
}

static int run_size(opt *o, int si, rt_err *e)
{
    const rt_sim_config *c = &o->cfg;
    uint64_t nlines = c->sizes[si] / c->line;
    fwd f = {0};
    f.ways = c->assoc ? c->assoc : (uint32_t)nlines;
    f.nsets = nlines / f.ways;
    f.heap = rt_calloc(nlines, sizeof *f.heap, e);
    f.used = rt_calloc(f.nsets, sizeof *f.used, e);
    f.pos = rt_calloc(nlines, sizeof *f.pos, e);
    f.key = rt_calloc(nlines, sizeof *f.key, e);
    f.line = rt_calloc(nlines, sizeof *f.line, e);
    f.dirty = rt_calloc(nlines, 1, e);
    f.wcg = rt_calloc(nlines, 1, e);
    f.slot = rt_calloc(o->nid ? o->nid : 1, sizeof *f.slot, e);
    if (!f.heap || !f.used || !f.pos || !f.key || !f.line || !f.dirty || !f.wcg || !f.slot) {
        fwd_free(&f);
        return -1;
    }
    for (uint32_t i = 0; i < o->nid; i++) f.slot[i] = NONE;
    ocount *k = &o->cnt[si];
    memset(k, 0, sizeof *k);
    const int wt = c->write_through, nwa = c->no_write_allocate, fl = c->write_miss_fullline;
    const uint64_t smask = (f.nsets & (f.nsets - 1)) == 0 ? f.nsets - 1 : 0; /* a power of two: no division */
    for (uint64_t i = 0; i < o->nt; i++) {
        const otouch *t = &o->t[i];
        unsigned cg = t->cg, w = t->w;
        k->acc[cg]++;
        k->wr[cg] += w != 0;
        uint64_t set = smask || f.nsets == 1 ? o->ids[t->id] & smask : o->ids[t->id] % f.nsets;
        uint32_t *h = f.heap + set * f.ways;
        uint32_t x = f.slot[t->id];
        if (x != NONE) {
            f.key[x] = t->next;
            sift_up(&f, h, f.pos[x]);
            sift_down(&f, h, f.used[set], f.pos[x]);
        } else {
            if (w) k->wm[cg]++;
            else k->rm[cg]++;
            if (w && nwa) {
                k->wtb[cg] += t->bytes;
                continue;
            }
            if (w == RT_WRITE_STREAM || (w && fl && t->bytes == c->line)) k->nf[cg]++;
            if (f.used[set] < f.ways) {
                x = (uint32_t)(set * f.ways + f.used[set]);
                h[f.used[set]] = x;
                f.pos[x] = f.used[set]++;
            } else {
                x = h[0]; /* farthest next use */
                if (f.dirty[x]) k->wb[f.wcg[x]]++;
                f.slot[f.line[x]] = NONE;
            }
            f.line[x] = t->id;
            f.dirty[x] = 0;
            f.slot[t->id] = x;
            f.key[x] = t->next;
            sift_up(&f, h, f.pos[x]);
            sift_down(&f, h, f.used[set], f.pos[x]);
        }
        if (w) {
            if (wt) k->wtb[cg] += t->bytes;
            else {
                f.dirty[x] = 1;
                f.wcg[x] = (uint8_t)cg;
            }
        }
    }
    if (c->flush)
        for (uint64_t x = 0; x < nlines; x++)
            if (f.slot[f.line[x]] == x && f.dirty[x]) k->wb[f.wcg[x]]++;
    fwd_free(&f);
    return 0;
}

/* ---- every size in one pass (fully associative, write-back, write-allocate) ----
 *
 * MIN with a size-independent priority (next use, then line id) is a stack
 * algorithm (Mattson et al. 1970): the cache of size C_j holds a subset of
 * the one of size C_{j+1}. So, as msim does for LRU, the lines are kept in
 * groups G_0 .. G_{k-1} (S_j = G_0 u .. u G_j is cache j's content), each a
 * max-heap by priority. A touch of a line x in group i (i = k: in no
 * cache) hits in sizes >= i and misses below; x moves to G_0; S_0's victim
 * is the top of G_0, and going up, the victim of S_j is the farther of the
 * victim carried from S_{j-1} and the top of G_j (which then swap: the
 * top leaves S_j, the carried line stays in it); the last victim lands in
 * G_i, or leaves every cache when i = k. A level not yet full takes the
 * carried line and no eviction happens above it. O(i log) a touch.
 * Dirty bits per line and size (bit j: dirty in cache j), as in msim:
 * leaving S_j with bit j set is a write-back of size j.
 */
/* A line's state, in one 16-byte record so a touch reads one cache line. */
typedef struct oline {
    uint32_t key;   /* next use (NONE = never) */
    uint32_t pad2;
    uint32_t dirty; /* bit j: dirty in cache j */
    uint8_t grp;    /* group, k = in no cache */
    uint8_t wcg;    /* (class, generation) index of the last write */
    uint16_t pad;
} oline;

typedef struct one {
    oline *l;
    /* line id -> position in its group's heap, apart from the records: a
     * sift writes the positions of the entries it moves, and 4 bytes a line
     * keep four times as many of them in the cache as 16-byte records */
    uint32_t *pos;
    /* per group a max-heap of entries (next use << 32 | ~line id): the
     * priority order (farther next use first, then the lower id) is the
     * integer order, and sifting reads no line record */
    uint64_t *heap[RT_SIM_MAXSIZES];
    uint32_t n[RT_SIM_MAXSIZES], cap[RT_SIM_MAXSIZES];
} one;

static inline uint64_t oent(const one *g, uint32_t x) { return (uint64_t)g->l[x].key << 32 | (uint32_t)~x; }
static inline uint32_t oid(uint64_t v) { return ~(uint32_t)v; }

/* The heaps are 4-ary (children of i: 4i+1..4i+4, one 32-byte run): half
 * the depth of a binary heap, so a sift moves half as many entries and
 * writes half as many heap positions (g->pos), the cost that dominates;
 * the order is total (entries are unique), so the top, and every result,
 * is the binary heap's. */
static void o_up(one *g, int j, uint32_t i)
{
    uint64_t *h = g->heap[j], v = h[i];
    while (i > 0) {
        uint32_t p = (i - 1) / OARY;
        if (v <= h[p]) break;
        h[i] = h[p];
        g->pos[oid(h[i])] = i;
        i = p;
    }
    h[i] = v;
    g->pos[oid(v)] = i;
}

static void o_down(one *g, int j, uint32_t i)
{
    uint64_t *h = g->heap[j], v = h[i];
    uint32_t n = g->n[j];
    for (;;) {
        uint32_t c = OARY * i + 1, b;
        if (c + 3 < n) { /* four children: the larger of two pairs, without branches */
            uint32_t b0 = c + (h[c + 1] > h[c]), b1 = c + 2 + (h[c + 3] > h[c + 2]);
            b = h[b1] > h[b0] ? b1 : b0;
        } else {
            if (c >= n) break;
            b = c;
            for (uint32_t q = c + 1; q < n; q++)
                if (h[q] > h[b]) b = q;
        }
        if (h[b] <= v) break;
        h[i] = h[b];
        g->pos[oid(h[i])] = i;
        i = b;
    }
    h[i] = v;
    g->pos[oid(v)] = i;
}

static void o_push(one *g, int j, uint32_t x)
{
    g->heap[j][g->n[j]] = oent(g, x);
    g->l[x].grp = (uint8_t)j;
    o_up(g, j, g->n[j]++);
}

/* y takes heap position p of group j (whatever held it leaves the heap). */
static void o_replace(one *g, int j, uint32_t p, uint32_t y)
{
    g->heap[j][p] = oent(g, y);
    g->l[y].grp = (uint8_t)j;
    g->pos[y] = p;
    if (p) o_up(g, j, p);
    o_down(g, j, g->pos[y]);
}

static void o_remove(one *g, int j, uint32_t x)
{
    uint32_t i = g->pos[x];
    uint64_t last = g->heap[j][--g->n[j]];
    if (i == g->n[j]) return;
    g->heap[j][i] = last;
    g->pos[oid(last)] = i;
    o_up(g, j, i);
    o_down(g, j, g->pos[oid(last)]);
}

static int run_onepass(opt *o, rt_err *e)
{
    const rt_sim_config *c = &o->cfg;
    const int k = c->nsizes;
    one g = {0};
    uint32_t nid = o->nid ? o->nid : 1;
    g.l = rt_calloc(nid, sizeof *g.l, e);
    g.pos = g.l ? rt_calloc(nid, sizeof *g.pos, e) : NULL;
    int ok = g.pos != NULL;
    for (int j = 0; j < k && ok; j++) {
        g.cap[j] = (uint32_t)((c->sizes[j] - (j ? c->sizes[j - 1] : 0)) / c->line);
        /* 3 entries before a 64-byte boundary: the 4 children of i (4i+1..4i+4)
         * then share one cache line */
        uint64_t *b = rt_calloc_aligned((size_t)g.cap[j] + 3, sizeof *b, 64, e);
        ok = b != NULL;
        g.heap[j] = b ? b + 3 : NULL;
    }
    /* misses by group: hist[cg][kind][g], kind 0 read, 1 write that fetches, 2 write without a fetch */
    uint64_t(*hist)[3][RT_SIM_MAXSIZES + 1] = ok ? rt_calloc(RT_SIM_NCG, sizeof *hist, e) : NULL;
    uint64_t(*wb)[RT_SIM_NCG] = ok ? rt_calloc((size_t)k, sizeof *wb, e) : NULL;
    uint64_t acc[RT_SIM_NCG] = {0}, wr[RT_SIM_NCG] = {0};
    int rc = -1;
    if (!hist || !wb) goto out;
    for (uint32_t x = 0; x < nid; x++) g.l[x].grp = (uint8_t)k;
    const uint32_t all = k == 32 ? UINT32_MAX : (1u << k) - 1;
    const int fl = c->write_miss_fullline;
    for (uint64_t t = 0; t < o->nt; t++) {
        const otouch *tc = &o->t[t];
        uint32_t x = tc->id;
        unsigned cg = tc->cg, w = tc->w;
        if (t + OPT_AHEAD < o->nt) { /* a random record and position, ahead */
            __builtin_prefetch(&g.l[o->t[t + OPT_AHEAD].id]);
            __builtin_prefetch(&g.pos[o->t[t + OPT_AHEAD].id]);
        }
        int i = g.l[x].grp;
        acc[cg]++;
        wr[cg] += w != 0;
        hist[cg][w == 0 ? 0 : (w == RT_WRITE_STREAM || (fl && tc->bytes == c->line)) ? 2 : 1][i]++;
        if (i == 0) { /* a hit in every size: only x's priority grows (its key was now, the least) */
            g.l[x].key = tc->next;
            g.heap[0][g.pos[x]] = oent(&g, x);
            o_up(&g, 0, g.pos[x]);
            if (w) {
                g.l[x].dirty = all;
                g.l[x].wcg = (uint8_t)cg;
            }
            continue;
        }
        /* x's old key was this touch, the least of all: x is a leaf of G_i,
         * where the last victim will take its place */
        uint32_t px = i < k ? g.pos[x] : 0;
        g.l[x].key = tc->next;
        uint32_t carry = NONE;
        for (int j = 0; j < i; j++) {
            uint32_t full = g.n[j] == g.cap[j];
            if (j == 0) {
                if (!full) { /* a cold cache: every size has room, nothing is evicted */
                    o_push(&g, 0, x);
                    break;
                }
                carry = oid(g.heap[0][0]); /* the farthest next use leaves cache 0; x takes its place */
                o_replace(&g, 0, 0, x);
            } else {
                if (!full) { /* room: the carried line stays in S_j, nothing above is evicted */
                    o_push(&g, j, carry);
                    carry = NONE;
                    break;
                }
                if (g.heap[j][0] > oent(&g, carry)) { /* G_j's top leaves cache j instead */
                    uint32_t top = oid(g.heap[j][0]);
                    o_replace(&g, j, 0, carry);
                    carry = top;
                }
            }
            if (g.l[carry].dirty >> j & 1) { /* carry leaves cache j */
                wb[j][g.l[carry].wcg]++;
                g.l[carry].dirty &= ~(1u << j);
            }
        }
        if (i < k) {
            if (carry != NONE) o_replace(&g, i, px, carry);
            else o_remove(&g, i, x); /* (not reached: a cache with room holds every line) */
        } else if (carry != NONE)
            g.l[carry].grp = (uint8_t)k;
        if (w) {
            g.l[x].dirty = all;
            g.l[x].wcg = (uint8_t)cg;
        }
    }
    if (c->flush)
        for (uint32_t x = 0; x < o->nid; x++)
            for (int j = g.l[x].grp; j < k; j++)
                if (g.l[x].dirty >> j & 1) wb[j][g.l[x].wcg]++;
    for (int j = 0; j < k; j++) {
        ocount *q = &o->cnt[j];
        memset(q, 0, sizeof *q);
        for (int cg = 0; cg < RT_SIM_NCG; cg++) {
            q->acc[cg] = acc[cg];
            q->wr[cg] = wr[cg];
            q->wb[cg] = wb[j][cg];
            for (int gi = j + 1; gi <= k; gi++) {
                q->rm[cg] += hist[cg][0][gi];
                q->wm[cg] += hist[cg][1][gi] + hist[cg][2][gi];
                q->nf[cg] += hist[cg][2][gi];
            }
        }
    }
    rc = 0;
out:
    free(hist);
    free(wb);
    for (int j = 0; j < k; j++) free(g.heap[j] ? g.heap[j] - 3 : NULL);
    free(g.l);
    free(g.pos);
    return rc;
}

static void opt_finish(void *st, int flush)
{
    (void)flush; /* cfg.flush, applied inside each size's pass */
    opt *o = st;
    if (o->oom) return;
    rt_err e = {0};
    double t0 = rt_now();
    /* the backward pass: next use of every touch */
    uint32_t *last = rt_calloc(o->nid ? o->nid : 1, sizeof *last, &e);
    if (!last) {
        o->oom = 1;
        return;
    }
    for (uint32_t i = 0; i < o->nid; i++) last[i] = NONE;
    for (uint64_t i = o->nt; i-- > 0;) {
        if (i >= OPT_AHEAD) __builtin_prefetch(&last[o->t[i - OPT_AHEAD].id], 1);
        o->t[i].next = last[o->t[i].id];
        last[o->t[i].id] = (uint32_t)i;
    }
    free(last);
    double t1 = rt_now();
    o->sec[0] = t1 - t0;
    if (opt_onepass(&o->cfg)) {
        if (run_onepass(o, &e)) o->oom = 1;
    } else {
        for (int s = 0; s < o->cfg.nsizes; s++)
            if (run_size(o, s, &e)) {
                o->oom = 1;
                return;
            }
    }
    o->sec[1] = rt_now() - t1;
    o->done = !o->oom;
}

static void opt_counts(const void *st, int i, int cls, int gen, rt_sim_counts *out)
{
    const opt *o = st;
    memset(out, 0, sizeof *out);
    if (cls < 0 || cls >= RT_NCLASS || gen >= RT_MAXGEN) return;
    const ocount *k = &o->cnt[i];
    for (int b = gen < 0 ? 0 : gen; b < (gen < 0 ? RT_MAXGEN : gen + 1); b++) {
        int cg = b * RT_NCLASS + cls;
        out->accesses += k->acc[cg] + o->rep[cg];
        out->read_misses += k->rm[cg];
        out->write_misses += k->wm[cg];
        out->writebacks += k->wb[cg];
        out->wt_bytes += k->wtb[cg];
        out->nofetch += k->nf[cg];
    }
    uint64_t fetches = out->read_misses + (o->cfg.no_write_allocate ? 0 : out->write_misses - out->nofetch);
    out->traffic_bytes = (fetches + out->writebacks) * o->cfg.line + out->wt_bytes;
}

static int opt_check(const void *st, rt_err *e)
{
    const opt *o = st;
    if (o->oom) return rt_errf(e, "opt: out of memory earlier; results incomplete");
    for (uint32_t id = 0; id < o->nid; id++) { /* O1 */
        uint64_t h = hsl(o->ids[id], o->hcap);
        while (o->ht[h].val != NONE && o->ht[h].key != o->ids[id]) h = (h + 1) & (o->hcap - 1);
        if (o->ht[h].val != id) return rt_errf(e, "opt: line id %u not in the table", id);
    }
    for (uint64_t i = 0; i < o->nt; i++) {
        const otouch *t = &o->t[i];
        if (t->id >= o->nid) return rt_errf(e, "opt: touch %llu has line id %u of %u", (unsigned long long)i, t->id, o->nid);
        if (!o->done) continue;
        if (t->next != NONE && (t->next <= i || t->next >= o->nt || o->t[t->next].id != t->id))
            return rt_errf(e, "opt: next use of touch %llu is wrong", (unsigned long long)i); /* O2 */
    }
    if (o->done) { /* O2: no touch of the line between i and next[i] (every id's chain is all its touches) */
        uint64_t chained = 0;
        for (uint64_t i = 0; i < o->nt; i++) chained += o->t[i].next != NONE;
        if (chained != o->nt - o->nid) return rt_errf(e, "opt: next-use chains skip touches");
    }
    for (int s = 0; s < o->cfg.nsizes; s++) /* O3 */
        for (int cg = 0; cg < RT_SIM_NCG; cg++) {
            const ocount *k = &o->cnt[s];
            if (k->rm[cg] + k->wm[cg] > k->acc[cg] || k->wb[cg] > k->wr[cg] || k->nf[cg] > k->wm[cg] ||
                k->wm[cg] > k->wr[cg])
                return rt_errf(e, "opt: counters of size %llu class %s generation %d inconsistent",
                               (unsigned long long)o->cfg.sizes[s], rt_class_name(cg % RT_NCLASS), cg / RT_NCLASS);
        }
    return 0;
}

/* A read of the line the previous touch ended on is a hit in every size
 * (write-allocate: that touch left the line resident, and MIN's choices
 * are the same with the repeat left out, no eviction falling between the
 * two touches); the filter drops it and it is counted here. */
static void opt_repeats(void *st, const uint64_t *cnt)
{
    opt *o = st;
    for (int cg = 0; cg < RT_SIM_NCG; cg++) o->rep[cg] += cnt[cg];
}

static void opt_phases(const void *st, double *out)
{
    const opt *o = st;
    out[0] = o->sec[0];
    out[1] = o->sec[1];
}

const rt_cache_engine rt_engine_opt = {
    .name = "exact-opt",
    .repl = "opt",
    .caps = RT_ENG_FULLASSOC | RT_ENG_SETASSOC | RT_ENG_WT | RT_ENG_NWA | RT_ENG_REPEATS,
    .state_bytes = opt_state_bytes,
    .create = opt_create,
    .destroy = opt_destroy,
    .access = opt_access,
    .finish = opt_finish,
    .counts = opt_counts,
    .check = opt_check,
    .repeats = opt_repeats,
    .phases = opt_phases,
};
