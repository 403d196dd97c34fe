/*
 * window.c -- time-sampled exact simulation of small caches: short windows
 * of the stream simulated exactly, each warmed from the references just
 * before it (the small-size half of the hybrid method, approx.h).
 *
 * WHY. Spatial sampling cannot see a 1 KB cache (16 lines): at rate R it
 * holds 16 R sampled lines, and the handful of very hot lines (the tree
 * top) that carry its hits are in or out of the sample by luck. But a small
 * cache forgets fast: its contents at any moment are fixed by the last few
 * hundred references. So small caches are simulated exactly, on windows.
 *
 * WINDOWS. Window j measures the M references [s_j, s_j + M) with s_j =
 * (j + 1) P - M - o (P = period, M = window, o in [0, P - M) from the seed,
 * 0 for seed 1): the windows are evenly spaced, at positions fixed in
 * advance, independent of what the stream does.
 * That matters: starting a window when the warm-up "looks done" (say, at
 * the miss that fills the stack) starts it inside a burst of misses and
 * biases the miss ratio up (measured: +0.02 at 4 KB on sphereflake).
 *
 * EXACT WARM-UP. LRU's top C entries at time s_j are the C most recently
 * touched distinct lines before s_j, whatever happened earlier. We keep the
 * H = min(P - M, 128 C_max) references before s_j, scan them backward
 * until C_max distinct lines have been seen (C_max = the largest windowed
 * cache, in lines), and give those lines, least recent first, one touch
 * each to a fresh exact simulator (rt_msim): at s_j its stack holds exactly
 * the true top C_max lines in the true order, so every touch of the window
 * hits or misses exactly as in the full simulation, at every windowed size,
 * for C_max touches of warm-up instead of the thousands of references the
 * history spans. If the kept history holds fewer than C_max distinct lines
 * the warm-up is exact only when it reaches back to the start of the trace;
 * otherwise the window is counted as short (stats) and its few unknown
 * lines count as misses.
 *
 * DIRTY STATE is approximate: a line the scan saw written starts dirty in
 * every windowed size (even if a small cache evicted and refetched it since
 * the write), a line written before the scanned history starts clean.
 * Misses are exact per window; write-backs of the windowed sizes are not.
 * A streaming store (RT_WRITE_STREAM) reaches the window's msim as it is,
 * but the estimate takes its write misses and charges a fetch for each
 * (approx.c adds no no-fetch term): like every approximate method it is
 * counted as an ordinary write.
 *
 * ESTIMATE. Per class, measured misses and write-backs are scaled by
 * (exact touches of the class in the whole trace) / (its touches inside the
 * windows): a ratio estimator, so a class that is rare in the windows is
 * scaled by its own frequency. A class with accesses but none inside any
 * window is scaled by the overall touch ratio (its measured misses are
 * then 0). Fewer than RT_APPROX_MIN_SAMPLES windows: no estimate.
 *
 * ERROR. Each window j gives, per size and group of classes (and for all
 * classes), d_j = its misses + write-backs and n_j = its touches; the
 * estimate is a ratio T sum(d) / sum(n). Treating the windows as a sample,
 * its standard error is T sqrt(sum (d_j - r n_j)^2 / (J (J - 1))) / mean(n)
 * with r = sum(d) / sum(n) (the linearised ratio estimator; Cochran,
 * Sampling Techniques, 6.3). Evenly spaced windows usually vary less than
 * a random sample of windows would, so this tends to overstate the error;
 * the per-class scaling of the estimate itself is not modelled in it.
 *
 * FROM A TRACE. A version-3 trace's writer runs the same placement and
 * backward scan and stores each window's warm-up lines and records
 * (trace.h); rt_window_put_warm replays one such window: same warm-up,
 * same counters, same statistics, without the history.
 *
 * INVARIANTS: pos = references seen; next = s_j of the window in progress
 * or to come; nhist = references of [max(next - H, 0), next) kept so far
 * (hist holds them in order); cur != NULL iff next <= pos < next + M.
 */
#include "sample.h"
#include "approx_int.h"
#include "msim.h"
#include "sim_int.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* History kept per line of the largest windowed cache: the backward scan
 * needs ~40 references per line on sphereflake at 1024^2 (median 9.5K, p99
 * 29K references for 256 lines; grove: 14K, 33K); more is copied for
 * nothing, less makes more short warm-ups. */
#define RT_TWIN_HIST_PER_LINE 128

struct rt_window {
    int k;                          /* windowed sizes */
    uint64_t sizes[RT_SIM_MAXSIZES]; /* bytes */
    uint32_t line;
    rt_approx_lines ln;
    uint64_t cmax;                  /* lines of the largest windowed size */
    uint64_t P, M, H;               /* period, window, history kept */
    uint64_t pos;                   /* references seen */
    uint64_t next;                  /* start of the current / next window */
    rt_access *hist;                /* the H references before next */
    uint64_t nhist;                 /* of which kept so far */
    uint64_t *set;                  /* distinct-line set for the backward scan */
    uint32_t *setidx;               /* index in stk of each set entry */
    uint64_t setmask;
    int setshift;                   /* 64 - log2(set size): Fibonacci hashing takes the top bits */
    rt_access *stk;                 /* the lines found, most recent first */
    rt_msim *cur;                   /* simulator of the window in progress */
    rt_sim_counts base[RT_SIM_MAXSIZES][RT_NCLASS]; /* its counters at the window start */
    double rm[RT_SIM_MAXSIZES][RT_NCLASS], wm[RT_SIM_MAXSIZES][RT_NCLASS], wb[RT_SIM_MAXSIZES][RT_NCLASS];
    uint64_t macc[RT_NCLASS];       /* touches inside windows, by class */
    /* per-window sums for the error (ERROR above), group RT_NGROUP = all:
     * d = misses + write-backs of the window, n = its touches */
    double sd[RT_SIM_MAXSIZES][RT_NGROUP + 1], sdd[RT_SIM_MAXSIZES][RT_NGROUP + 1],
        sdn[RT_SIM_MAXSIZES][RT_NGROUP + 1];
    double sn[RT_NGROUP + 1], snn[RT_NGROUP + 1];
    uint64_t nwin, nshort, fed;     /* windows done, with short warm-up, references scanned or simulated */
    int oom;
};

rt_window *rt_window_new(const uint64_t *sizes, int k, uint32_t line, uint64_t period, uint64_t window, uint64_t seed,
                     rt_err *e)
{
    if (k < 1 || k > RT_SIM_MAXSIZES) return rt_errf(e, "windows: %d sizes", k), NULL;
    if (window < 1 || period <= window) /* the seed's offset is taken mod period - window */
        return rt_errf(e, "windows: window %llu must be 1..period - 1 (%llu)", (unsigned long long)window,
                       (unsigned long long)period),
               NULL;
    rt_window *t = rt_calloc(1, sizeof *t, e);
    if (!t) return NULL;
    t->k = k;
    memcpy(t->sizes, sizes, (size_t)k * sizeof *sizes);
    t->line = line;
    rt_approx_lines_init(&t->ln, line);
    t->cmax = sizes[k - 1] / line;
    t->P = period;
    t->M = window;
    uint64_t hmax = RT_TWIN_HIST_PER_LINE * t->cmax;
    t->H = period - window < hmax ? period - window : hmax;
    /* the seed shifts every window by the same offset in [0, P - M): seed 1
     * (the default) by none, other seeds give other, independent placements */
    t->next = rt_sample_first_window(period, window, seed);
    uint64_t ss = 16;
    while (ss < 4 * t->cmax) ss <<= 1;
    t->setmask = ss - 1;
    t->setshift = 64;
    for (uint64_t q = ss; q > 1; q >>= 1) t->setshift--;
    t->set = rt_calloc(ss, sizeof *t->set, e);
    t->setidx = rt_calloc(ss, sizeof *t->setidx, e);
    t->stk = rt_calloc(t->cmax, sizeof *t->stk, e);
    t->hist = t->H ? rt_calloc(t->H, sizeof *t->hist, e) : NULL;
    if (!t->set || !t->setidx || !t->stk || (t->H && !t->hist)) {
        rt_window_free(t);
        return NULL;
    }
    return t;
}

void rt_window_free(rt_window *t)
{
    if (!t) return;
    rt_msim_free(t->cur);
    free(t->hist);
    free(t->set);
    free(t->setidx);
    free(t->stk);
    free(t);
}

/* The warm-up is done: the window's counters start here. */
static void window_mark(rt_window *t)
{
    for (int i = 0; i < t->k; i++)
        for (int c = 0; c < RT_NCLASS; c++) rt_msim_get(t->cur, i, c, &t->base[i][c]);
}

/* Window start: rebuilds the top of the LRU stack from the history. The
 * backward scan meets lines in recency order, so the first C_max distinct
 * lines it meets, replayed least recent first as one touch each, leave the
 * simulator's stack exactly as the full simulation's top C_max; a line is
 * replayed as a write (dirty in every size, charged to the writer's class)
 * if the scan saw it written. */
static void window_begin(rt_window *t)
{
    rt_err e;
    t->cur = rt_msim_new(t->sizes, t->k, t->line, &e);
    if (!t->cur) {
        t->oom = 1;
        return;
    }
    memset(t->set, 0, (t->setmask + 1) * sizeof *t->set);
    /* locals: the stores into stk must not make the compiler reload the
     * table pointers on every reference (they alias nothing here) */
    uint64_t *restrict set = t->set;
    uint32_t *restrict setidx = t->setidx;
    rt_access *restrict stk = t->stk;
    const rt_access *restrict hist = t->hist;
    const uint64_t mask = t->setmask, cmax = t->cmax, line = t->line;
    const int shift = t->setshift;
    const rt_approx_lines ln = t->ln;
    uint32_t seen = 0;
    uint64_t s = t->nhist, prev = UINT64_MAX;
    while (s > 0 && seen < cmax) {
        rt_approx_touch tc = rt_approx_touch_of(&ln, &hist[--s]);
        uint64_t f = tc.first, l = tc.last;
        if (f == l && f == prev && !tc.w) continue; /* a read of the line just met: nothing new */
        prev = f;
        for (uint64_t L = l + 1; L-- > f && seen < cmax;) {
            /* the scan set: slots hold L + 1 (0 = empty), setidx the line's index in stk */
            uint64_t i = (L * 0x9e3779b97f4a7c15ULL) >> shift;
            while (set[i] && set[i] != L + 1) i = (i + 1) & mask;
            if (!set[i]) { /* new: this is its most recent touch */
                set[i] = L + 1;
                setidx[i] = seen;
                stk[seen++] = (rt_access){L * line, 1, (uint8_t)tc.w, (uint8_t)tc.cls, 0};
            } else if (tc.w && !stk[setidx[i]].write) { /* its latest write */
                stk[setidx[i]].write = 1;
                stk[setidx[i]].cls = (uint8_t)tc.cls;
            }
        }
    }
    /* the history reaches back to the trace start iff next - nhist == 0 */
    if (seen < t->cmax && t->next - t->nhist > 0) t->nshort++;
    for (uint32_t i = seen; i-- > 0;) rt_msim_put(t->cur, &t->stk[i], 1);
    t->fed += t->nhist - s;
    window_mark(t);
}

static void window_end(rt_window *t)
{
    double d[RT_SIM_MAXSIZES][RT_NGROUP + 1] = {{0}}, nt[RT_NGROUP + 1] = {0};
    for (int c = 0; c < RT_NCLASS; c++) {
        rt_sim_counts x;
        int g = (int)rt_class_group(c);
        for (int i = 0; i < t->k; i++) {
            rt_msim_get(t->cur, i, c, &x);
            const rt_sim_counts *b = &t->base[i][c];
            double rm = (double)(x.read_misses - b->read_misses), wm = (double)(x.write_misses - b->write_misses),
                   wb = (double)(x.writebacks - b->writebacks);
            t->rm[i][c] += rm;
            t->wm[i][c] += wm;
            t->wb[i][c] += wb;
            d[i][g] += rm + wm + wb;
            d[i][RT_NGROUP] += rm + wm + wb;
            if (i == 0) {
                t->macc[c] += x.accesses - b->accesses;
                nt[g] += (double)(x.accesses - b->accesses);
                nt[RT_NGROUP] += (double)(x.accesses - b->accesses);
            }
        }
    }
    for (int g = 0; g <= RT_NGROUP; g++) {
        t->sn[g] += nt[g];
        t->snn[g] += nt[g] * nt[g];
        for (int i = 0; i < t->k; i++) {
            t->sd[i][g] += d[i][g];
            t->sdd[i][g] += d[i][g] * d[i][g];
            t->sdn[i][g] += d[i][g] * nt[g];
        }
    }
    rt_msim_free(t->cur);
    t->cur = NULL;
    t->nwin++;
    t->nhist = 0;
    t->next += t->P;
}

void rt_window_put(rt_window *t, const rt_access *a, size_t n)
{
    if (t->oom) return;
    uint64_t end = t->pos + n;
    while (t->pos < end) {
        uint64_t p = t->pos;
        if (p < t->next) { /* before the window: keep the last H references */
            uint64_t stop = end < t->next ? end : t->next, from = p;
            uint64_t hstart = t->next > t->H ? t->next - t->H : 0; /* the first window may start early */
            if (t->H && stop > hstart) {
                if (from < hstart) from = hstart;
                memcpy(t->hist + t->nhist, a + (from - (end - n)), (size_t)(stop - from) * sizeof *a);
                t->nhist += stop - from;
            }
            t->pos = stop;
            continue;
        }
        if (!t->cur) {
            window_begin(t);
            if (t->oom) return;
        }
        uint64_t stop = end < t->next + t->M ? end : t->next + t->M;
        rt_msim_put(t->cur, a + (p - (end - n)), (size_t)(stop - p));
        t->fed += stop - p;
        t->pos = stop;
        if (stop == t->next + t->M) window_end(t);
    }
}

void rt_window_put_warm(rt_window *t, const rt_access *warm, size_t nwarm, uint64_t scanned, int short_warmup,
                        const rt_access *recs, size_t nrecs)
{
    if (t->oom) return;
    rt_msim_free(t->cur); /* a partial window can only be the last one */
    rt_err e;
    if (!(t->cur = rt_msim_new(t->sizes, t->k, t->line, &e))) {
        t->oom = 1;
        return;
    }
    rt_msim_put(t->cur, warm, nwarm);
    t->nshort += short_warmup != 0;
    t->fed += scanned;
    window_mark(t);
    if (nrecs > t->M) nrecs = (size_t)t->M;
    rt_msim_put(t->cur, recs, nrecs);
    t->fed += nrecs;
    t->pos += nrecs;
    if (nrecs == t->M) window_end(t);
}

uint64_t rt_window_hist(const rt_window *t) { return t->H; }

int rt_window_estimate(const rt_window *t, const uint64_t acc[RT_NCLASS][2], rt_approx_est *est, int off, rt_err *e)
{
    if (t->oom) return rt_errf(e, "windows: out of memory");
    uint64_t tall = 0, mall = 0;
    for (int c = 0; c < RT_NCLASS; c++) {
        tall += acc[c][0] + acc[c][1];
        mall += t->macc[c];
    }
    double g = mall ? (double)tall / (double)mall : 0;
    for (int c = 0; c < RT_NCLASS; c++) {
        uint64_t tc = acc[c][0] + acc[c][1];
        double f = t->macc[c] ? (double)tc / (double)t->macc[c] : g;
        for (int i = 0; i < t->k; i++) {
            est->rm[off + i][c] = t->rm[i][c] * f;
            est->wm[off + i][c] = t->wm[i][c] * f;
            est->wb[off + i][c] = t->wb[i][c] * f;
        }
    }
    /* the standard errors (ERROR above) */
    double J = (double)t->nwin;
    for (int gr = 0; gr <= RT_NGROUP; gr++) {
        double T = 0;
        for (int c = 0; c < RT_NCLASS; c++)
            if (gr == RT_NGROUP || (int)rt_class_group(c) == gr) T += (double)(acc[c][0] + acc[c][1]);
        for (int i = 0; i < t->k; i++) {
            double *se = &est->se[off + i][gr];
            if (T == 0) *se = 0; /* nothing of this group anywhere: exactly none */
            else if (t->nwin < 2 || t->sn[gr] <= 0) *se = -1;
            else {
                double r = t->sd[i][gr] / t->sn[gr];
                double ss = t->sdd[i][gr] - 2 * r * t->sdn[i][gr] + r * r * t->snn[gr];
                if (ss < 0) ss = 0; /* rounding */
                *se = T * sqrt(ss / (J * (J - 1))) / (t->sn[gr] / J);
            }
        }
    }
    return 0;
}

void rt_window_stats(const rt_window *t, uint64_t *windows, uint64_t *short_warmups, uint64_t *fed)
{
    *windows = t->nwin;
    *short_warmups = t->nshort;
    *fed = t->fed;
}
