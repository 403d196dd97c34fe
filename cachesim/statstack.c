/*
 * statstack.c -- temporally sampled LRU miss-ratio estimation in the manner
 * of StatStack (Eklov and Hagersten, ISPASS 2010): sample line touches,
 * measure their reuse times, and turn the reuse-time distribution into
 * expected stack distances, per class, for every size of a fully
 * associative write-back write-allocate LRU cache.
 *
 * SAMPLING. Time is the index of a line touch (a reference spanning two
 * lines is two touches). The gaps between sampled touches are geometric
 * with mean 1/R, drawn from a seeded splitmix64 PRNG (gap = 1 +
 * floor(ln U / ln(1 - R)), U uniform in (0, 1]; every touch at R = 1), so
 * each touch is sampled independently with probability R. A sampled touch
 * at time i of line L puts a *watch* on L; the next touch of L, at time j,
 * ends the watch and yields the reuse time r = j - i >= 1. A watch still
 * open at the end is *dangling* (r = infinity): the sampled touch was the
 * line's last. At most one watch per line is open (a new sample of L at
 * time j starts after the old watch ended at j). Every touch checks a
 * 2^16-entry counting filter of watched lines (Fibonacci hash) and probes
 * the watch table only on a filter hit.
 *
 * FROM REUSE TIME TO STACK DISTANCE. Touch j misses in a cache of C lines
 * iff y >= C, where y is the number of distinct other lines touched in
 * (i, j). The touch at i + k (0 < k < r) is the last touch of its line
 * before j iff its own forward reuse time exceeds r - k, so, assuming the
 * reuse-time distribution is the same everywhere,
 *        E[y | r] = sum_{k=1}^{r-1} P(RT > k)
 *                 = (1/n) sum_s (min(RT_s, r) - 1)          (StatStack)
 * over all n samples s, dangling ones counting as RT = infinity. Reuse
 * times are kept in a histogram with exact bins below 128 and 64 bins per
 * octave above (0.8-1.6% wide), each bin holding the count and the exact
 * sum of its reuse times, so the sum over samples below the query's bin is
 * exact and the query bin is approximated by its mean. A reuse then
 * counts as a miss of size C with weight clamp(E[y|r] - (C - 1), 0, 1)
 * (the same interpolation as shards.c), attributed to the class and
 * read/write type of the reusing touch j: the touch that misses. Each
 * non-first touch has exactly one predecessor, so sampling i at rate R
 * samples reuses j at rate R.
 *
 * COLD MISSES. The number of dangling samples estimates the number of last
 * touches, which equals the number of distinct lines, which equals the
 * number of first touches: the cold misses (a miss in every size). A
 * dangling sample gives the class (lines keep their class), but not whether
 * the line's *first* touch was a read or a write; cold misses are split
 * between read and write misses in the class's exact read/write touch
 * proportion. Totals and traffic are unaffected; the read/write split of
 * cold misses is approximate (ray records are read first and written last,
 * so their cold misses show up half as write misses).
 *
 * WRITE-BACKS. A reuse (i, j) that misses in C means the line was evicted
 * from C between i and j, and i was its last touch before the eviction. If
 * i was a write, the evicted line was dirty: one write-back, charged to the
 * class of i (the last writer, as in the exact simulator). A dangling
 * write sample is written back from every cache it has fallen out of by
 * the end (expected depth from the same formula with r = end - i). If i was
 * a read the line may still have been dirty from an earlier write in the
 * same residency; those write-backs are not seen, so the estimate is a
 * lower bound, exact for lines that are only read, or written on their
 * last touch before each eviction (ray records: read, then the hit written
 * back), and low for read-modify-read patterns. A streaming store
 * (RT_WRITE_STREAM) is an ordinary write here: its misses are charged a
 * fetch, as in every approximate method (the exact engines do not).
 *
 * SCALING. All counts are multiplied by touches / samples (the realized
 * inverse rate). Counters are 64-bit, scaling in double; a sample count
 * below RT_APPROX_MIN_SAMPLES is reported as too short by the glue.
 */
#include "approx_int.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#define NBIN (128 + 57 * 64)
#define FBITS 16
#define FIB 0x9E3779B97F4A7C15ULL

typedef struct watch {
    uint64_t line; /* watched line */
    uint64_t t0;   /* time of the sampled touch */
    uint8_t cls;   /* its class */
    uint8_t w;     /* 1 if it was a write */
    uint8_t used;  /* slot in use */
} watch;

struct rt_sstack {
    int k;                                 /* sizes */
    rt_approx_lines ln;                    /* line splitting */
    double cm1[RT_SIM_MAXSIZES];           /* C_i - 1, lines */
    double rate;                           /* R */
    double lnq;                            /* ln(1 - R) (R < 1) */
    uint64_t rng;                          /* splitmix64 state */
    uint64_t now;                          /* touches so far */
    uint64_t next;                         /* time of the next sampled touch */
    uint16_t filt[1u << FBITS];            /* watches per filter bucket (65535 = sticky) */
    watch *wt;                             /* watch table (open addressing) */
    uint64_t wmask;                        /* table size - 1 */
    int wshift;                            /* 64 - log2(table size) */
    uint64_t nwatch;                       /* open watches */
    uint64_t nsamples;                     /* sampled touches */
    uint64_t rtc[NBIN];                    /* finished reuses per bin */
    double rts[NBIN];                      /* sum of their reuse times */
    uint64_t hj[RT_NCLASS][2][NBIN];       /* reuses by class, write of the reusing touch */
    uint64_t hwb[RT_NCLASS][NBIN];         /* reuses whose sampled touch was a write, by its class */
    int oom;                               /* the watch table failed to grow */
};

static inline int rbin(uint64_t r)
{
    if (r < 128) return (int)r;
    int e = 63 - __builtin_clzll(r);
    return 128 + (e - 7) * 64 + (int)((r >> (e - 6)) & 63);
}

static uint64_t gap(rt_sstack *s)
{
    if (s->rate >= 1) return 1;
    s->rng += 0x9E3779B97F4A7C15ULL;
    uint64_t x = rt_mix64(s->rng);
    double u = (double)((x >> 11) + 1) * (1.0 / 9007199254740992.0); /* (0, 1] */
    double g = floor(log(u) / s->lnq);
    return g >= 4e18 ? (uint64_t)4e18 : 1 + (uint64_t)g;
}

static int wt_resize(rt_sstack *s, int bits)
{
    uint64_t size = 1ULL << bits;
    watch *nt = calloc(size, sizeof *nt);
    if (!nt) return -1;
    watch *old = s->wt;
    uint64_t osize = old ? s->wmask + 1 : 0;
    s->wt = nt;
    s->wmask = size - 1;
    s->wshift = 64 - bits;
    for (uint64_t i = 0; i < osize; i++)
        if (old[i].used) {
            uint64_t j = (old[i].line * FIB) >> s->wshift;
            while (s->wt[j].used) j = (j + 1) & s->wmask;
            s->wt[j] = old[i];
        }
    free(old);
    return 0;
}

static void wt_delete(rt_sstack *s, uint64_t i)
{
    uint64_t j = i;
    for (;;) {
        j = (j + 1) & s->wmask;
        if (!s->wt[j].used) break;
        uint64_t h = (s->wt[j].line * FIB) >> s->wshift;
        if (i <= j ? (i < h && h <= j) : (i < h || h <= j)) continue;
        s->wt[i] = s->wt[j];
        i = j;
    }
    s->wt[i].used = 0;
}

rt_sstack *rt_sstack_new(const uint64_t *lines, int k, uint32_t line, double rate, uint64_t seed, rt_err *e)
{
    rt_sstack *s = rt_calloc(1, sizeof *s, e);
    if (!s) return NULL;
    s->k = k;
    rt_approx_lines_init(&s->ln, line);
    for (int i = 0; i < k; i++) s->cm1[i] = (double)lines[i] - 1;
    s->rate = rate;
    s->lnq = rate < 1 ? log1p(-rate) : 0;
    s->rng = seed * 0x2545F4914F6CDD1DULL + 0x632BE59BD9B4E019ULL;
    s->next = gap(s) - 1;
    if (wt_resize(s, 10)) {
        rt_errf(e, "out of memory");
        rt_sstack_free(s);
        return NULL;
    }
    return s;
}

void rt_sstack_free(rt_sstack *s)
{
    if (!s) return;
    free(s->wt);
    free(s);
}

/* A touch of a line whose filter bucket is non-empty: end its watch. */
static void reuse(rt_sstack *s, uint64_t L, uint64_t t, unsigned w, unsigned cls, uint32_t fi)
{
    uint64_t i = (L * FIB) >> s->wshift;
    for (;; i = (i + 1) & s->wmask) {
        if (!s->wt[i].used) return;
        if (s->wt[i].line == L) break;
    }
    uint64_t r = t - s->wt[i].t0;
    int b = rbin(r);
    s->rtc[b]++;
    s->rts[b] += (double)r;
    s->hj[cls][w][b]++;
    if (s->wt[i].w) s->hwb[s->wt[i].cls][b]++;
    wt_delete(s, i);
    s->nwatch--;
    if (s->filt[fi] != UINT16_MAX) s->filt[fi]--;
}

static void start(rt_sstack *s, uint64_t L, uint64_t t, unsigned w, unsigned cls, uint32_t fi)
{
    s->nsamples++;
    s->next = t + gap(s);
    if (2 * (s->nwatch + 1) > s->wmask + 1 && wt_resize(s, 64 - s->wshift + 1)) {
        s->oom = 1;
        return;
    }
    uint64_t i = (L * FIB) >> s->wshift;
    while (s->wt[i].used) i = (i + 1) & s->wmask;
    s->wt[i] = (watch){L, t, (uint8_t)cls, (uint8_t)w, 1};
    s->nwatch++;
    if (s->filt[fi] != UINT16_MAX) s->filt[fi]++;
}

void rt_sstack_put(rt_sstack *restrict s, const rt_access *a, size_t n, uint64_t acc[RT_NCLASS][2])
{
    for (size_t r = 0; r < n; r++) {
        rt_approx_touch tc = rt_approx_touch_of(&s->ln, &a[r]);
        unsigned cls = tc.cls, w = tc.w;
        acc[cls][w] += tc.last - tc.first + 1;
        for (uint64_t L = tc.first; L <= tc.last; L++) {
            uint64_t t = s->now++;
            uint32_t fi = (uint32_t)((L * FIB) >> (64 - FBITS));
            if (s->filt[fi]) reuse(s, L, t, w, cls, fi);
            if (t == s->next) start(s, L, t, w, cls, fi);
        }
    }
}

/* Expected distinct other lines in the r - 1 touches after a touch. */
typedef struct sdtab {
    const rt_sstack *s;
    double n;                /* samples, dangling included */
    uint64_t pc[NBIN + 1];   /* finished samples in bins < b */
    double ps[NBIN + 1];     /* sum of (RT - 1) over bins < b */
} sdtab;

static double sd_of(const sdtab *T, double r)
{
    const rt_sstack *s = T->s;
    uint64_t ri = r >= 9.2e18 ? (uint64_t)9.2e18 : (uint64_t)r;
    int b = rbin(ri < 1 ? 1 : ri);
    double sum = T->ps[b];
    if (s->rtc[b]) {
        double mean = b < 128 ? (double)b : s->rts[b] / (double)s->rtc[b];
        sum += (double)s->rtc[b] * ((mean < r ? mean : r) - 1);
    }
    sum += (T->n - (double)T->pc[b + 1]) * (r - 1);
    return sum / T->n;
}

int rt_sstack_estimate(const rt_sstack *s, const uint64_t acc[RT_NCLASS][2], rt_approx_est *est, rt_err *e)
{
    if (s->oom) return rt_errf(e, "statstack: out of memory while growing the watch table");
    memset(est, 0, sizeof *est);
    est->sampled_touches = s->nsamples;
    est->sampled_lines = s->nsamples;
    est->rate = s->now ? (double)s->nsamples / (double)s->now : s->rate;
    if (!s->nsamples) return 0;
    sdtab *T = malloc(sizeof *T);
    if (!T) return rt_errf(e, "out of memory");
    T->s = s;
    T->n = (double)s->nsamples;
    T->pc[0] = 0;
    T->ps[0] = 0;
    for (int b = 0; b < NBIN; b++) {
        T->pc[b + 1] = T->pc[b] + s->rtc[b];
        T->ps[b + 1] = T->ps[b] + s->rts[b] - (double)s->rtc[b];
    }
    double scale = (double)s->now / (double)s->nsamples;
    for (int b = 1; b < NBIN; b++) {
        if (!s->rtc[b]) continue;
        double y = sd_of(T, b < 128 ? (double)b : s->rts[b] / (double)s->rtc[b]);
        for (int i = 0; i < s->k; i++) {
            double mw = rt_approx_missw(y, s->cm1[i]);
            if (mw <= 0) break;
            mw *= scale;
            for (int c = 0; c < RT_NCLASS; c++) {
                est->rm[i][c] += mw * (double)s->hj[c][0][b];
                est->wm[i][c] += mw * (double)s->hj[c][1][b];
                est->wb[i][c] += mw * (double)s->hwb[c][b];
            }
        }
    }
    double cold[RT_NCLASS] = {0};
    for (uint64_t x = 0; x <= s->wmask; x++) {
        const watch *wa = &s->wt[x];
        if (!wa->used) continue;
        cold[wa->cls] += scale;
        if (!wa->w) continue;
        double y = sd_of(T, (double)(s->now - wa->t0));
        for (int i = 0; i < s->k; i++) {
            double mw = rt_approx_missw(y, s->cm1[i]);
            if (mw <= 0) break;
            est->wb[i][wa->cls] += mw * scale;
        }
    }
    for (int c = 0; c < RT_NCLASS; c++) {
        double tot = (double)acc[c][0] + (double)acc[c][1];
        if (!cold[c] || tot <= 0) continue;
        double fr = (double)acc[c][0] / tot;
        for (int i = 0; i < s->k; i++) {
            est->rm[i][c] += cold[c] * fr;
            est->wm[i][c] += cold[c] * (1 - fr);
        }
    }
    free(T);
    return 0;
}
