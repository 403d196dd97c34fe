/*
 * shards.c -- spatially sampled LRU miss-ratio estimation in the manner of
 * SHARDS (Waldspurger, Park, Garthwaite and Ahmad, FAST 2015), fixed-rate
 * and fixed-size, with per-class misses and write-backs for every size of
 * a fully associative write-back write-allocate LRU cache.
 *
 * SAMPLING. Each line number L is hashed with a seeded 64-bit mixer,
 * h = mix(L ^ mix(seed)); the low 32 bits decide sampling: L is in the
 * sample iff (h mod 2^32) < T, so the rate is R = T / 2^32 (T = round(rate
 * x 2^32), at least 1; rate 1 gives T = 2^32 and every line). Because the
 * decision depends only on the line, a sampled line is seen on every touch:
 * the sampled stream is the full stream restricted to about R of the lines,
 * and its LRU behaviour is that of a cache R times smaller.
 *
 * DISTANCES. For a touch of a sampled line we need y = the number of other
 * distinct sampled lines touched since this line's previous touch (its LRU
 * stack depth minus one in the sampled stream). Every sampled line keeps the
 * timestamp of its last touch (a counter over sampled touches); a Fenwick
 * tree over timestamps holds a 1 at each live line's timestamp, so
 * y = live - prefix(ts) in O(log n). When the timestamp counter reaches the
 * tree's capacity the live lines are renumbered 1..live in timestamp order
 * (a bucket pass, no sort) and the tree is rebuilt with capacity >= 2 live,
 * so renumbering costs O(1) amortized per touch.
 *
 * FROM SAMPLED DEPTH TO MISSES. In the full stream a touch whose previous
 * touch was D - 1 distinct lines ago hits in a cache of C lines iff D <= C,
 * i.e. iff Y = D - 1 <= C - 1. The sampled y is the line itself plus a
 * Binomial(Y, R) count, so E[y] = R Y, and the unbiased test is y vs
 * t = R (C - 1) (not R C: scaling the cache size alone, as a simulator of a
 * round(R C)-line cache would, is biased by about 1/R lines). Since t is
 * fractional and y an integer, a touch counts as
 *        miss weight  w(y, t) = clamp(y - t, 0, 1),
 * the linear interpolation between the caches of floor(t)+1 and ceil(t)+1
 * sampled lines. A touch of a line not in the sample yet (a cold miss of
 * the sampled stream) has weight 1 everywhere. Estimated full-trace misses
 * are sum(weight) / R per (size, class of the touch, read|write), i.e. the
 * Horvitz-Thompson scaling; this equals SHARDS_adj's correction of the
 * reference count to the expected N R. At R = 1, t = C - 1 and y are
 * integers, the weights are 0 or 1, and every counter equals the exact
 * simulator's.
 *
 * WRITE-BACKS. With write-allocate a write puts the line, modified, in every
 * cache. The line stays dirty in cache C until it is evicted from C, which
 * happens before a later touch iff that touch misses in C. So a line is
 * dirty in C iff it has been written and every reuse since the last write
 * hit in C, i.e. iff wmax <= C - 1, where wmax is the largest (estimated
 * full-trace) distance Y of the reuses since the last write (-1 right after
 * a write, +inf if never written). On a touch with distance y the line was
 * evicted, dirty, from every cache with w(R wmax, t) = 0 < w(y, t) = 1;
 * with fractional weights the write-back weight is max(0, w(y, t) -
 * w(R wmax, t)), charged to the class of the last write (as the exact
 * simulator does). Then wmax = max(wmax, y / R) on a read, -1 on a write.
 * Lines still resident at the end are not written back (Dinero IV and
 * rt_sim do not flush), but a dirty line that has since fallen out of a
 * cache has been; rt_shards_estimate adds these with y = the line's final
 * depth - 1.
 *
 * FIXED SIZE. With smax > 0 at most smax lines are kept: when a new line
 * makes the sample larger, the lines with the largest hash are dropped (a
 * max-heap of the sample's hashes) and T is lowered to that hash, so the
 * sample is again exactly the lines with h < T. Every event is weighted
 * 1 / R with the rate in force when it happened, and thresholds t are
 * recomputed from the new R; wmax is kept in full-trace units so it
 * survives a rate change.
 *
 * INVARIANTS: live = lines in the sample = Fenwick total = hash entries =
 * (fixed size) heap entries <= smax; every live line has h < T and a unique
 * timestamp in 1..now <= fcap; the MRU line (last) is live with ts = now.
 *
 * WEAK CASES: a few very hot lines (the top of a k-d tree) carry much of the
 * traffic; whether they fall in the sample changes the estimate of small
 * caches by a lot, so small sizes need large R or exact simulation
 * (exact_below). Caches of fewer than 1 / R lines cannot be estimated at
 * all (t < 1 sampled line); the glue reports them as unavailable.
 */
#include "approx_int.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#define NIL UINT32_MAX
#define TWO32 4294967296.0

typedef struct shline {
    uint64_t line; /* line number; next free slot when ts == 0 */
    uint64_t ts;   /* timestamp of the last touch, 1..now; 0 = free slot */
    double wmax;   /* dirty state: -1 dirty everywhere, +inf clean, else max Y since the last write */
    uint32_t h;    /* low 32 bits of the line's hash */
    uint8_t wcls;  /* class of the last write */
} shline;

typedef struct heapent {
    uint32_t h;    /* hash of the line */
    uint32_t slot; /* its slot */
} heapent;

struct rt_shards {
    int k;                                          /* sizes */
    rt_approx_lines ln;                             /* line splitting */
    double cm1[RT_SIM_MAXSIZES];                    /* C_i - 1, lines */
    double t[RT_SIM_MAXSIZES];                      /* thresholds R (C_i - 1) */
    uint64_t T;                                     /* sample iff h < T (<= 2^32) */
    double R, invR;                                 /* T / 2^32 and its inverse */
    uint64_t smax;                                  /* most lines kept; 0 = fixed rate */
    uint64_t seedmix;                               /* mix(seed) */
    shline *sl;                                     /* slots */
    uint32_t nsl, slcap;                            /* slots used (incl. free ones), allocated */
    uint32_t freeslot;                              /* head of the free-slot list, NIL if none */
    uint32_t *ht;                                   /* open addressing: slot index or NIL */
    uint64_t hmask;                                 /* table size - 1 */
    int hshift;                                     /* 64 - log2(table size) */
    uint32_t *fw;                                   /* Fenwick tree, 1..fcap */
    uint64_t fcap;                                  /* its capacity (power of two) */
    uint64_t now;                                   /* last timestamp handed out */
    uint32_t live;                                  /* lines in the sample */
    heapent *heap;                                  /* fixed size: max-heap on h */
    uint32_t nheap, heapcap;                        /* entries, allocated */
    uint32_t last;                                  /* slot of the MRU sampled line, or NIL */
    uint64_t last_line;                             /* its line */
    double m[2][RT_NCLASS][RT_SIM_MAXSIZES];        /* miss weight / R by write, class, size */
    double wb[RT_NCLASS][RT_SIM_MAXSIZES];          /* write-back weight / R */
    uint64_t sampled_touches;                       /* touches of sampled lines */
    int oom;                                        /* a table failed to grow */
};

static void set_rate(rt_shards *s, uint64_t T)
{
    s->T = T;
    s->R = (double)T / TWO32;
    s->invR = TWO32 / (double)T;
    for (int i = 0; i < s->k; i++) s->t[i] = s->R * s->cm1[i];
}

static inline uint64_t hash_of(const rt_shards *s, uint64_t L) { return rt_approx_mix(L ^ s->seedmix); }

/* ---- Fenwick tree over timestamps ---- */

static inline void fw_add(uint32_t *fw, uint64_t cap, uint64_t i, int32_t d)
{
    for (; i <= cap; i += i & (~i + 1)) fw[i] += (uint32_t)d;
}

static inline uint64_t fw_prefix(const uint32_t *fw, uint64_t i)
{
    uint64_t sum = 0;
    for (; i; i &= i - 1) sum += fw[i];
    return sum;
}

/* Renumbers live lines 1..live in timestamp order and rebuilds the tree with
 * capacity >= 2 live (at least 4096). */
static int compact(rt_shards *s)
{
    uint64_t cap = 4096;
    while (cap < 2 * (uint64_t)s->live + 2) cap <<= 1;
    uint32_t *byts = malloc((s->fcap + 1) * sizeof *byts);
    uint32_t *nfw = calloc(cap + 1, sizeof *nfw);
    if (!byts || !nfw) {
        free(byts);
        free(nfw);
        return -1;
    }
    for (uint64_t i = 0; i <= s->fcap; i++) byts[i] = NIL;
    for (uint32_t x = 0; x < s->nsl; x++)
        if (s->sl[x].ts) byts[s->sl[x].ts] = x;
    uint64_t n = 0;
    for (uint64_t i = 1; i <= s->fcap; i++)
        if (byts[i] != NIL) s->sl[byts[i]].ts = ++n;
    for (uint64_t i = 1; i <= cap; i++) { /* linear build: push each partial sum to its parent */
        if (i <= n) nfw[i] += 1;
        uint64_t j = i + (i & (~i + 1));
        if (j <= cap) nfw[j] += nfw[i];
    }
    free(byts);
    free(s->fw);
    s->fw = nfw;
    s->fcap = cap;
    s->now = n;
    return 0;
}

/* ---- hash table: line -> slot ---- */

static inline uint32_t ht_find(const rt_shards *s, uint64_t L, uint64_t hv)
{
    uint64_t i = hv >> s->hshift;
    for (;;) {
        uint32_t x = s->ht[i];
        if (x == NIL || s->sl[x].line == L) return x;
        i = (i + 1) & s->hmask;
    }
}

static void ht_insert(rt_shards *s, uint32_t x)
{
    uint64_t i = hash_of(s, s->sl[x].line) >> s->hshift;
    while (s->ht[i] != NIL) i = (i + 1) & s->hmask;
    s->ht[i] = x;
}

static void ht_delete(rt_shards *s, uint32_t x)
{
    uint64_t i = hash_of(s, s->sl[x].line) >> s->hshift;
    while (s->ht[i] != x) i = (i + 1) & s->hmask;
    uint64_t j = i; /* backward-shift deletion */
    for (;;) {
        j = (j + 1) & s->hmask;
        if (s->ht[j] == NIL) break;
        uint64_t h = hash_of(s, s->sl[s->ht[j]].line) >> s->hshift;
        if (i <= j ? (i < h && h <= j) : (i < h || h <= j)) continue;
        s->ht[i] = s->ht[j];
        i = j;
    }
    s->ht[i] = NIL;
}

static int ht_resize(rt_shards *s, int bits)
{
    uint64_t size = 1ULL << bits;
    uint32_t *nt = malloc(size * sizeof *nt);
    if (!nt) return -1;
    for (uint64_t i = 0; i < size; i++) nt[i] = NIL;
    free(s->ht);
    s->ht = nt;
    s->hmask = size - 1;
    s->hshift = 64 - bits;
    for (uint32_t x = 0; x < s->nsl; x++)
        if (s->sl[x].ts) ht_insert(s, x);
    return 0;
}

/* ---- max-heap of hashes (fixed size) ---- */

static int heap_push(rt_shards *s, uint32_t h, uint32_t slot)
{
    if (s->nheap == s->heapcap) {
        uint32_t nc = s->heapcap ? 2 * s->heapcap : 1024;
        heapent *nh = realloc(s->heap, nc * sizeof *nh);
        if (!nh) return -1;
        s->heap = nh;
        s->heapcap = nc;
    }
    uint32_t i = s->nheap++;
    while (i && s->heap[(i - 1) / 2].h < h) {
        s->heap[i] = s->heap[(i - 1) / 2];
        i = (i - 1) / 2;
    }
    s->heap[i] = (heapent){h, slot};
    return 0;
}

static heapent heap_pop(rt_shards *s)
{
    heapent top = s->heap[0], x = s->heap[--s->nheap];
    uint32_t i = 0, n = s->nheap;
    for (;;) {
        uint32_t c = 2 * i + 1;
        if (c >= n) break;
        if (c + 1 < n && s->heap[c + 1].h > s->heap[c].h) c++;
        if (s->heap[c].h <= x.h) break;
        s->heap[i] = s->heap[c];
        i = c;
    }
    if (n) s->heap[i] = x;
    return top;
}

/* ---- slots ---- */

static uint32_t slot_alloc(rt_shards *s)
{
    if (s->freeslot != NIL) {
        uint32_t x = s->freeslot;
        s->freeslot = (uint32_t)s->sl[x].line;
        return x;
    }
    if (s->nsl == s->slcap) {
        if (s->slcap >= UINT32_MAX / 2) return NIL;
        uint32_t nc = s->slcap ? 2 * s->slcap : 1024;
        shline *n = realloc(s->sl, (size_t)nc * sizeof *n);
        if (!n) return NIL;
        s->sl = n;
        s->slcap = nc;
    }
    return s->nsl++;
}

static void drop_line(rt_shards *s, uint32_t x)
{
    fw_add(s->fw, s->fcap, s->sl[x].ts, -1);
    s->live--;
    ht_delete(s, x);
    s->sl[x].ts = 0;
    s->sl[x].line = s->freeslot;
    s->freeslot = x;
    if (x == s->last) s->last = NIL;
}

/* Fixed size: drops the largest-hash lines until live <= smax. */
static void shrink(rt_shards *s)
{
    while (s->live > s->smax && s->nheap && s->heap[0].h > 0) {
        uint32_t hmax = s->heap[0].h;
        while (s->nheap && s->heap[0].h == hmax) drop_line(s, heap_pop(s).slot);
        set_rate(s, hmax);
    }
}

rt_shards *rt_shards_new(const uint64_t *lines, int k, uint32_t line, double rate, uint64_t smax, uint64_t seed,
                         rt_err *e)
{
    rt_shards *s = rt_calloc(1, sizeof *s, e);
    if (!s) return NULL;
    s->k = k;
    rt_approx_lines_init(&s->ln, line);
    for (int i = 0; i < k; i++) s->cm1[i] = (double)lines[i] - 1;
    double Td = smax ? TWO32 : floor(rate * TWO32 + 0.5);
    if (Td < 1) Td = 1;
    if (Td > TWO32) Td = TWO32;
    set_rate(s, (uint64_t)Td);
    s->smax = smax;
    s->seedmix = rt_approx_mix(seed ^ 0x5851f42d4c957f2dULL);
    s->freeslot = NIL;
    s->last = NIL;
    s->fcap = 4096;
    s->fw = rt_calloc(s->fcap + 1, sizeof *s->fw, e);
    if (!s->fw || ht_resize(s, 12)) {
        if (s->fw) rt_errf(e, "out of memory");
        rt_shards_free(s);
        return NULL;
    }
    return s;
}

void rt_shards_free(rt_shards *s)
{
    if (!s) return;
    free(s->sl);
    free(s->ht);
    free(s->fw);
    free(s->heap);
    free(s);
}

/* One touch of a sampled line. */
static void sample(rt_shards *restrict s, uint64_t L, uint64_t hv, unsigned w, unsigned cls)
{
    s->sampled_touches++;
    if (s->last != NIL && L == s->last_line) { /* y = 0: a hit everywhere */
        if (w) {
            s->sl[s->last].wmax = -1;
            s->sl[s->last].wcls = (uint8_t)cls;
        }
        return;
    }
    if (s->now == s->fcap && compact(s)) {
        s->oom = 1;
        return;
    }
    uint32_t x = ht_find(s, L, hv);
    if (x == NIL) { /* cold in the sample: a miss in every size */
        for (int i = 0; i < s->k; i++) s->m[w][cls][i] += s->invR;
        if (2 * ((uint64_t)s->live + 1) > s->hmask + 1 && ht_resize(s, 64 - s->hshift + 1)) {
            s->oom = 1;
            return;
        }
        x = slot_alloc(s);
        if (x == NIL) {
            s->oom = 1;
            return;
        }
        shline *p = &s->sl[x];
        p->line = L;
        p->ts = ++s->now;
        p->wmax = w ? -1 : INFINITY;
        p->h = (uint32_t)hv;
        p->wcls = (uint8_t)cls;
        fw_add(s->fw, s->fcap, p->ts, 1);
        s->live++;
        ht_insert(s, x);
        s->last = x;
        s->last_line = L;
        if (s->smax) {
            if (heap_push(s, p->h, x)) {
                s->oom = 1;
                return;
            }
            if (s->live > s->smax) shrink(s);
        }
        return;
    }
    shline *p = &s->sl[x];
    double y = (double)(s->live - fw_prefix(s->fw, p->ts));
    double wm = p->wmax, rwm = s->R * wm, invR = s->invR;
    for (int i = 0; i < s->k; i++) {
        double mw = rt_approx_missw(y, s->t[i]);
        if (mw <= 0) break; /* thresholds increase: no miss in larger sizes */
        s->m[w][cls][i] += mw * invR;
        double b = mw - rt_approx_missw(rwm, s->t[i]);
        if (b > 0) s->wb[p->wcls][i] += b * invR;
    }
    if (w) {
        p->wmax = -1;
        p->wcls = (uint8_t)cls;
    } else if (y * invR > wm) {
        p->wmax = y * invR;
    }
    fw_add(s->fw, s->fcap, p->ts, -1);
    p->ts = ++s->now;
    fw_add(s->fw, s->fcap, p->ts, 1);
    s->last = x;
    s->last_line = L;
}

void rt_shards_put(rt_shards *restrict s, const rt_access *a, size_t n, uint64_t acc[RT_NCLASS][2])
{
    for (size_t r = 0; r < n; r++) {
        uint32_t sz = a[r].size ? a[r].size : 1;
        unsigned cls = a[r].cls < RT_NCLASS ? a[r].cls : RT_CLS_FB;
        unsigned w = a[r].write ? 1 : 0;
        uint64_t first = rt_approx_line_of(&s->ln, a[r].addr);
        uint64_t last = rt_approx_line_of(&s->ln, a[r].addr + sz - 1);
        acc[cls][w] += last - first + 1;
        for (uint64_t L = first; L <= last; L++) {
            uint64_t hv = rt_approx_mix(L ^ s->seedmix);
            if ((hv & 0xffffffffULL) < s->T) sample(s, L, hv, w, cls); /* s->T falls as the sample fills */
        }
    }
}

int rt_shards_estimate(const rt_shards *s, rt_approx_est *est, rt_err *e)
{
    if (s->oom) return rt_errf(e, "shards: out of memory while growing the sample");
    memset(est, 0, sizeof *est);
    for (int i = 0; i < s->k; i++)
        for (int c = 0; c < RT_NCLASS; c++) {
            est->rm[i][c] = s->m[0][c][i];
            est->wm[i][c] = s->m[1][c][i];
            est->wb[i][c] = s->wb[c][i];
        }
    /* dirty lines that have fallen out of a cache since their last touch */
    for (uint32_t x = 0; x < s->nsl; x++) {
        const shline *p = &s->sl[x];
        if (!p->ts || p->wmax == INFINITY) continue;
        double y = (double)(s->live - fw_prefix(s->fw, p->ts)), rwm = s->R * p->wmax;
        for (int i = 0; i < s->k; i++) {
            double b = rt_approx_missw(y, s->t[i]) - rt_approx_missw(rwm, s->t[i]);
            if (b > 0) est->wb[i][p->wcls] += b * s->invR;
        }
    }
    est->sampled_touches = s->sampled_touches;
    est->sampled_lines = s->live;
    est->rate = s->R;
    return 0;
}
