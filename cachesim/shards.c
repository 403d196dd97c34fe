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
 * A streaming store (RT_WRITE_STREAM) is an ordinary write here: its
 * misses are charged a fetch, as in every approximate method (the exact
 * engines do not).
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
 * GOLDEN (STRATIFIED) SAMPLING. With golden = 1 the decision is instead
 * L * G + c < T64 (mod 2^64), G = 2^64 / phi (the golden ratio), c =
 * mix(seed), T64 = R 2^64: a line is sampled iff frac(L / phi + c') < R.
 * Over a uniform offset each line is sampled with probability exactly R,
 * so every expectation above still holds, but the multiples of 1/phi are
 * the most evenly spread sequence mod 1 (three-gap theorem): any run of N
 * consecutive lines holds N R + O(log N) sampled lines instead of N R +-
 * sqrt(N R). Ray tracers touch lines in long contiguous runs (ray buffers,
 * the visible part of a triangle array), so the count of sampled lines per
 * class -- the main source of SHARDS' error at large caches -- is nearly
 * exact, and the test is one multiply and one compare per touch (the
 * seeded mixer is computed only for sampled lines, for the hash table).
 * Golden sampling is rate-only (no fixed size); put_golden is the
 * filter, with an AVX-512 version chosen at run time that gives the same
 * touches in the same order.
 *
 * REPLICATES (the error estimate). rt_shards_split(s, K) divides a
 * golden sample into K random replicates: a sampled line goes to part
 * floor(K h / 2^32), h the high 32 bits of its hash, so each part is a
 * random 1/K of the sample (rate R / K in expectation) and runs its own
 * SHARDS on its own lines, fed by sample() as the touches pass: one more
 * sample() per sampled touch and no second pass over the stream, and a
 * trace's sample index (which holds the rate-R sample) feeds them as well
 * as the records do. Their K estimates, each with about K times the full
 * sample's variance, give the standard error of the full estimate as
 * sqrt(var(part estimates) / K) (approx.c). Contiguous slices of the
 * golden interval would be golden samples themselves, but they are
 * stratified alike and vary too little (docs/approx.md). What the parts
 * cannot see is a bias shared by all of them (the resolution of the
 * smallest sizes).
 *
 * WEAK CASES: a few very hot lines (the top of a k-d tree) carry much of the
 * traffic; whether they fall in the sample changes the estimate of small
 * caches by a lot, so small sizes need large R or exact simulation
 * (exact_below). Caches of fewer than 1 / R lines cannot be estimated at
 * all (t < 1 sampled line); the glue reports them as unavailable.
 */
#include "sample.h"
#include "approx_int.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#if defined(__x86_64__) && defined(__GNUC__) && !defined(RT_NO_AVX512)
#define RT_SHARDS_HAVE_AVX512 1
#else
#define RT_SHARDS_HAVE_AVX512 0
#endif

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
    int golden;                                     /* golden-ratio sampling (rate only) */
    uint64_t T64, goff;                             /* golden: sample iff L * G + goff < T64; T64 0 = all */
    int simd;                                       /* golden: the AVX-512 filter may be used */
    double m[2][RT_NCLASS][RT_SIM_MAXSIZES];        /* miss weight / R by write, class, size */
    double wb[RT_NCLASS][RT_SIM_MAXSIZES];          /* write-back weight / R */
    uint64_t sampled_touches;                       /* touches of sampled lines */
    int oom;                                        /* a table failed to grow */
    struct rt_shards *part[RT_SHARDS_MAXPARTS];     /* replicates (rt_shards_split), or none */
    int nparts;
};

static void set_rate(rt_shards *s, uint64_t T)
{
    s->T = T;
    s->R = (double)T / TWO32;
    s->invR = TWO32 / (double)T;
    for (int i = 0; i < s->k; i++) s->t[i] = s->R * s->cm1[i];
}

/* Golden rate T64 / 2^64 (T64 0: every line, rate 1) and the thresholds. */
static void set_golden(rt_shards *s, uint64_t T64)
{
    s->T64 = T64;
    s->R = T64 ? (double)T64 * 0x1p-64 : 1;
    s->invR = 1 / s->R;
    for (int i = 0; i < s->k; i++) s->t[i] = s->R * s->cm1[i];
}

static inline uint64_t hash_of(const rt_shards *s, uint64_t L) { return rt_mix64(L ^ s->seedmix); }

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
                         int golden, rt_err *e)
{
    if (golden && smax) return rt_errf(e, "shards: golden sampling has a fixed rate, not a fixed size"), NULL;
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
    s->seedmix = rt_mix64(seed ^ 0x5851f42d4c957f2dULL);
    if (golden) {
        /* T64 = R 2^64 exactly representable for rates 2^-k; the rate is
         * then T64 / 2^64 (rate 1: T64 = 0 means every line). */
        s->golden = 1;
        s->goff = rt_sample_golden_offset(seed);
        double T = floor(rate * 0x1p64 + 0.5);
        if (T < 1) T = 1;
        set_golden(s, T >= 0x1p64 ? 0 : (uint64_t)T);
        s->simd = rt_shards_simd_available() && !getenv("RT_NO_SIMD");
    }
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
    for (int p = 0; p < s->nparts; p++) rt_shards_free(s->part[p]);
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

static void put_golden(rt_shards *restrict s, const rt_access *a, size_t n, uint64_t acc[RT_NCLASS][2]);

void rt_shards_put(rt_shards *restrict s, const rt_access *a, size_t n, uint64_t acc[RT_NCLASS][2])
{
    if (s->golden) {
        put_golden(s, a, n, acc);
        return;
    }
    for (size_t r = 0; r < n; r++) {
        rt_approx_touch t = rt_approx_touch_of(&s->ln, &a[r]);
        acc[t.cls][t.w] += t.last - t.first + 1;
        for (uint64_t L = t.first; L <= t.last; L++) {
            uint64_t hv = rt_mix64(L ^ s->seedmix);
            if ((hv & 0xffffffffULL) < s->T) sample(s, L, hv, t.w, t.cls); /* s->T falls as the sample fills */
        }
    }
}

/* ---- golden-ratio filter ---- */

#define GOLD RT_SAMPLE_GOLD

/* One reference, generic: any size, any line. */
static inline void golden_ref(rt_shards *restrict s, const rt_access *r, uint64_t acc[RT_NCLASS][2])
{
    rt_approx_touch t = rt_approx_touch_of(&s->ln, r);
    acc[t.cls][t.w] += t.last - t.first + 1;
    for (uint64_t L = t.first; L <= t.last; L++) {
        uint64_t x = L * GOLD + s->goff;
        if (s->T64 && x >= s->T64) continue;
        uint64_t hv = hash_of(s, L);
        sample(s, L, hv, t.w, t.cls);
        if (s->nparts) sample(s->part[((hv >> 32) * (uint64_t)s->nparts) >> 32], L, hv, t.w, t.cls);
    }
}

/* Scalar filter for 64-byte-style power-of-two lines: the common reference
 * covers one or two lines; anything else takes golden_ref. Counts go to two
 * interleaved tables so consecutive references of one class do not wait on
 * each other's store. */
static void put_golden_scalar(rt_shards *restrict s, const rt_access *a, size_t n, uint64_t acc[RT_NCLASS][2])
{
    if (s->ln.shift < 0 || !s->T64) {
        for (size_t i = 0; i < n; i++) golden_ref(s, &a[i], acc);
        return;
    }
    const int sh = s->ln.shift;
    const uint64_t T = s->T64, off = s->goff, maxsz = s->ln.line;
    uint64_t c[2][RT_NCLASS][2];
    memset(c, 0, sizeof c);
    for (size_t i = 0; i < n; i++) {
        const rt_access *r = &a[i];
        uint64_t f = r->addr >> sh, l = (r->addr + (r->size ? r->size : 1) - 1) >> sh;
        int odd = (r->size > maxsz) | (r->cls >= RT_NCLASS) | ((f * GOLD + off) < T) | ((l * GOLD + off) < T);
        if (__builtin_expect(odd, 0)) {
            golden_ref(s, r, acc);
            continue;
        }
        c[i & 1][r->cls][r->write ? 1 : 0] += 1 + (l - f);
    }
    for (int k = 0; k < RT_NCLASS; k++)
        for (int w = 0; w < 2; w++) acc[k][w] += c[0][k][w] + c[1][k][w];
}

#if RT_SHARDS_HAVE_AVX512
#include <immintrin.h>

/* AVX-512 filter: eight references per step. Lanes that need care (a
 * sampled line, a reference longer than a line) are handled by golden_ref
 * in lane order, so sampled touches reach sample() in stream order; the
 * others are counted in packed 8-bit fields (key = class * 2 +
 * write, four accumulators of eight fields, flushed before a field can
 * reach 255). Same counts and same sampled touches as the scalar filter. */
__attribute__((target("avx512f,avx512dq"))) static void put_golden_avx512(rt_shards *restrict s, const rt_access *a,
                                                                           size_t n, uint64_t acc[RT_NCLASS][2])
{
    _Static_assert(sizeof(rt_access) == 16, "rt_access is 16 bytes");
    _Static_assert(2 * RT_NCLASS <= 32, "keys class * 2 + write fit four accumulators of eight fields");
    const int sh = s->ln.shift;
    const __m512i vT = _mm512_set1_epi64((long long)s->T64), voff = _mm512_set1_epi64((long long)s->goff),
                  vG = _mm512_set1_epi64((long long)GOLD), one = _mm512_set1_epi64(1),
                  lo32 = _mm512_set1_epi64(0xffffffffLL), b8 = _mm512_set1_epi64(0xff),
                  vmax = _mm512_set1_epi64((long long)s->ln.line), vfb = _mm512_set1_epi64(RT_CLS_FB), vnc = _mm512_set1_epi64(RT_NCLASS),
                  seven = _mm512_set1_epi64(7), ieven = _mm512_setr_epi64(0, 2, 4, 6, 8, 10, 12, 14),
                  iodd = _mm512_setr_epi64(1, 3, 5, 7, 9, 11, 13, 15);
    const __m128i vsh = _mm_set_epi64x(0, sh);
    uint64_t cnt[32] = {0};
    size_t i = 0;
    while (i + 8 <= n) {
        __m512i p0 = _mm512_setzero_si512(), p1 = p0, p2 = p0, p3 = p0;
        uint8_t oddm[120];
        size_t blk = i, stop = i + 8 * 120; /* at most 2 per step per field: 240 < 256 */
        if (stop > n) stop = n;
        for (; i + 8 <= stop; i += 8) {
            __m512i z0 = _mm512_loadu_si512((const void *)(a + i)), z1 = _mm512_loadu_si512((const void *)(a + i + 4));
            __m512i addr = _mm512_permutex2var_epi64(z0, ieven, z1), meta = _mm512_permutex2var_epi64(z0, iodd, z1);
            __m512i size = _mm512_max_epu64(_mm512_and_si512(meta, lo32), one);
            __m512i f = _mm512_srl_epi64(addr, vsh);
            __m512i l = _mm512_srl_epi64(_mm512_sub_epi64(_mm512_add_epi64(addr, size), one), vsh);
            __m512i wr = _mm512_and_si512(_mm512_srli_epi64(meta, 32), b8);
            /* classes out of range count as the framebuffer */
            __m512i cls = _mm512_and_si512(_mm512_srli_epi64(meta, 40), b8);
            cls = _mm512_mask_mov_epi64(cls, _mm512_cmpge_epu64_mask(cls, vnc), vfb);
            /* a reference of at most one line covers f or f, f + 1: the hash
             * of l is that of f plus G when it crosses (wider ones are odd) */
            __m512i d = _mm512_sub_epi64(l, f);
            __m512i hf = _mm512_add_epi64(_mm512_mullo_epi64(f, vG), voff);
            __m512i hl = _mm512_mask_add_epi64(hf, _mm512_test_epi64_mask(d, d), hf, vG);
            __mmask8 odd = _mm512_cmpgt_epu64_mask(size, vmax) | _mm512_cmplt_epu64_mask(hf, vT) |
                           _mm512_cmplt_epu64_mask(hl, vT);
            /* key = cls * 2 + (write != 0); field (key & 7) of accumulator key >> 3 */
            __m512i key = _mm512_add_epi64(_mm512_add_epi64(cls, cls),
                                           _mm512_min_epu64(wr, one));
            __m512i nt = _mm512_maskz_add_epi64((__mmask8)~odd, d, one);
            __m512i v = _mm512_sllv_epi64(nt, _mm512_slli_epi64(_mm512_and_si512(key, seven), 3));
            __m512i hi = _mm512_srli_epi64(key, 3);
            p0 = _mm512_mask_add_epi64(p0, _mm512_cmpeq_epi64_mask(hi, _mm512_setzero_si512()), p0, v);
            p1 = _mm512_mask_add_epi64(p1, _mm512_cmpeq_epi64_mask(hi, one), p1, v);
            p2 = _mm512_mask_add_epi64(p2, _mm512_cmpeq_epi64_mask(hi, _mm512_add_epi64(one, one)), p2, v);
            p3 = _mm512_mask_add_epi64(p3, _mm512_cmpeq_epi64_mask(hi, _mm512_set1_epi64(3)), p3, v);
            oddm[(i - blk) / 8] = odd;
        }
        /* second pass, out of the vector loop (no calls inside it): the
         * lanes that need care, in stream order */
        for (size_t g = 0; g < (i - blk) / 8; g++)
            for (unsigned odd = oddm[g]; odd; odd &= odd - 1)
                golden_ref(s, &a[blk + 8 * g + (size_t)__builtin_ctz(odd)], acc);
        for (int fld = 0; fld < 8; fld++) {
            __m512i m8 = _mm512_set1_epi64(0xff);
            cnt[fld] += (uint64_t)_mm512_reduce_add_epi64(_mm512_and_si512(_mm512_srli_epi64(p0, 8 * (unsigned)fld), m8));
            cnt[8 + fld] +=
                (uint64_t)_mm512_reduce_add_epi64(_mm512_and_si512(_mm512_srli_epi64(p1, 8 * (unsigned)fld), m8));
            cnt[16 + fld] +=
                (uint64_t)_mm512_reduce_add_epi64(_mm512_and_si512(_mm512_srli_epi64(p2, 8 * (unsigned)fld), m8));
            cnt[24 + fld] +=
                (uint64_t)_mm512_reduce_add_epi64(_mm512_and_si512(_mm512_srli_epi64(p3, 8 * (unsigned)fld), m8));
        }
    }
    for (int k = 0; k < RT_NCLASS; k++)
        for (int w = 0; w < 2; w++) acc[k][w] += cnt[2 * k + w];
    if (i < n) put_golden_scalar(s, a + i, n - i, acc);
}
#endif

int rt_shards_simd_available(void)
{
#if RT_SHARDS_HAVE_AVX512
    __builtin_cpu_init();
    return __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512dq");
#else
    return 0;
#endif
}

static void put_golden(rt_shards *restrict s, const rt_access *a, size_t n, uint64_t acc[RT_NCLASS][2])
{
#if RT_SHARDS_HAVE_AVX512
    if (s->simd && s->ln.shift >= 0 && s->T64) {
        put_golden_avx512(s, a, n, acc);
        return;
    }
#endif
    put_golden_scalar(s, a, n, acc);
}

int rt_shards_split(rt_shards *s, const uint64_t *lines, int nparts, rt_err *e)
{
    if (!s->golden || !s->T64 || s->now || s->nparts || nparts < 2 || nparts > RT_SHARDS_MAXPARTS || s->T64 / (uint64_t)nparts == 0)
        return rt_errf(e, "shards: only a fresh golden sample below rate 1 splits into 2..%d parts", RT_SHARDS_MAXPARTS);
    uint64_t pw = s->T64 / (uint64_t)nparts;
    for (int p = 0; p < nparts; p++) {
        rt_shards *q = rt_shards_new(lines, s->k, s->ln.line, 0.5, 0, 1, 1, e);
        if (!q) return -1;
        q->seedmix = s->seedmix;
        q->simd = 0;
        set_golden(q, pw); /* fed by sample(), never filtered: T64 only sets the rate */
        s->part[s->nparts++] = q;
    }
    return 0;
}

int rt_shards_nparts(const rt_shards *s) { return s->nparts; }

int rt_shards_estimate_part(const rt_shards *s, int p, rt_approx_est *est, int off, rt_err *e)
{
    if (p < 0 || p >= s->nparts) return rt_errf(e, "shards: no part %d", p);
    return rt_shards_estimate(s->part[p], est, off, e);
}

int rt_shards_estimate(const rt_shards *s, rt_approx_est *est, int off, rt_err *e)
{
    if (s->oom) return rt_errf(e, "shards: out of memory while growing the sample");
    for (int p = 0; p < s->nparts; p++)
        if (s->part[p]->oom) return rt_errf(e, "shards: out of memory while growing the sample");
    for (int i = 0; i < s->k; i++)
        for (int c = 0; c < RT_NCLASS; c++) {
            est->rm[off + i][c] = s->m[0][c][i];
            est->wm[off + i][c] = s->m[1][c][i];
            est->wb[off + i][c] = s->wb[c][i];
        }
    /* dirty lines that have fallen out of a cache since their last touch */
    for (uint32_t x = 0; x < s->nsl; x++) {
        const shline *p = &s->sl[x];
        if (!p->ts || p->wmax == INFINITY) continue;
        double y = (double)(s->live - fw_prefix(s->fw, p->ts)), rwm = s->R * p->wmax;
        for (int i = 0; i < s->k; i++) {
            double b = rt_approx_missw(y, s->t[i]) - rt_approx_missw(rwm, s->t[i]);
            if (b > 0) est->wb[off + i][p->wcls] += b * s->invR;
        }
    }
    est->sampled_touches = s->sampled_touches;
    est->sampled_lines = s->live;
    est->rate = s->R;
    return 0;
}
