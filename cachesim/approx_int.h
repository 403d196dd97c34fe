/*
 * approx_int.h -- the interface between the approximate-simulation glue
 * (approx.c) and its estimators (shards.c, statstack.c). Private to
 * cachesim/; the public API is approx.h.
 *
 * An estimator sees every reference, splits it into line touches, counts
 * the touches per class exactly (acc), samples some of them, and on request
 * writes its estimates for k sampled sizes (in lines) into an rt_approx_est,
 * in full-trace units (already scaled by the inverse sampling rate).
 */
#ifndef RT_APPROX_INT_H
#define RT_APPROX_INT_H

#include "approx.h"
#include "rt_math.h"

typedef struct rt_approx_est {
    double rm[RT_SIM_MAXSIZES][RT_NCLASS]; /* estimated read misses */
    double wm[RT_SIM_MAXSIZES][RT_NCLASS]; /* estimated write misses */
    double wb[RT_SIM_MAXSIZES][RT_NCLASS]; /* estimated write-backs (class of the last writer) */
    uint64_t sampled_touches;              /* touches the estimator simulated */
    uint64_t sampled_lines;                /* SHARDS: lines in the sample; StatStack: sampled references */
    double rate;                           /* effective sampling rate at the end */
    /* standard error of the traffic estimate (lines: misses + write-backs)
     * per group, [RT_NGROUP] = all classes; < 0 where there is none */
    double se[RT_SIM_MAXSIZES][RT_NGROUP + 1];
} rt_approx_est;

/* Splits references into line touches: line size as shift (power of two)
 * or divisor. */
typedef struct rt_approx_lines {
    uint32_t line; /* bytes */
    int shift;     /* log2(line), or -1 */
} rt_approx_lines;

static inline void rt_approx_lines_init(rt_approx_lines *l, uint32_t line)
{
    l->line = line;
    l->shift = -1;
    if ((line & (line - 1)) == 0) {
        l->shift = 0;
        while ((1u << l->shift) != line) l->shift++;
    }
}

static inline uint64_t rt_approx_line_of(const rt_approx_lines *l, uint64_t addr)
{
    return l->shift >= 0 ? addr >> l->shift : addr / l->line;
}

/* What every estimator reads of a reference: the lines it covers (size 0
 * counts as 1 byte), its class (out of range: the framebuffer, as in
 * rt_sim_put) and whether it writes. */
typedef struct rt_approx_touch {
    uint64_t first, last; /* lines first..last */
    unsigned cls, w;
} rt_approx_touch;

static inline rt_approx_touch rt_approx_touch_of(const rt_approx_lines *l, const rt_access *r)
{
    rt_approx_touch t;
    t.first = rt_approx_line_of(l, r->addr);
    t.last = rt_approx_line_of(l, r->addr + (r->size ? r->size : 1) - 1);
    t.cls = r->cls < RT_NCLASS ? r->cls : RT_CLS_FB;
    t.w = r->write ? 1 : 0;
    return t;
}


/* Miss weight of a reuse with (estimated) y other distinct lines since the
 * previous touch, in a cache whose hit threshold is t (see shards.c). */
static inline double rt_approx_missw(double y, double t)
{
    double d = y - t;
    return d <= 0 ? 0 : d >= 1 ? 1 : d;
}

/* ---- SHARDS (shards.c) ---- */
typedef struct rt_shards rt_shards;
/* lines[0..k-1]: sampled sizes in lines, increasing. smax 0 = fixed rate. */
rt_shards *rt_shards_new(const uint64_t *lines, int k, uint32_t line, double rate, uint64_t smax, uint64_t seed,
                         int golden, rt_err *e);
/* 1 if this CPU runs the AVX-512 golden filter (RT_NO_SIMD in the
 * environment turns it off; both give identical results). */
int rt_shards_simd_available(void);
void rt_shards_free(rt_shards *s);
void rt_shards_put(rt_shards *s, const rt_access *a, size_t n, uint64_t acc[RT_NCLASS][2]);
/* Writes sizes off..off+k-1 (and the sampling statistics) of est, which the
 * caller has zeroed. -1 if a table could not grow (out of memory) during put. */
int rt_shards_estimate(const rt_shards *s, rt_approx_est *est, int off, rt_err *e);
/* Splits a fresh golden sample (rate < 1, nothing fed yet) into nparts
 * random replicates at rate R / nparts, each estimated on its own (the
 * error estimate; shards.c, REPLICATES). lines as given to
 * rt_shards_new. 0, or -1 (out of memory, or not a fresh golden sample). */
#define RT_SHARDS_MAXPARTS 8
int rt_shards_split(rt_shards *s, const uint64_t *lines, int nparts, rt_err *e);
int rt_shards_nparts(const rt_shards *s);
/* rt_shards_estimate of part p. */
int rt_shards_estimate_part(const rt_shards *s, int p, rt_approx_est *est, int off, rt_err *e);

/* ---- time-sampled exact windows (window.c) ---- */
typedef struct rt_window rt_window;
/* sizes[0..k-1] in bytes, increasing; a window of `window` references
 * every `period` (period > window >= 1), placed by seed. */
rt_window *rt_window_new(const uint64_t *sizes, int k, uint32_t line, uint64_t period, uint64_t window, uint64_t seed,
                     rt_err *e);
void rt_window_free(rt_window *t);
void rt_window_put(rt_window *t, const rt_access *a, size_t n);
/* Writes sizes off..off+k-1 of est, scaled per class by acc (exact touches),
 * with their standard errors (se). */
int rt_window_estimate(const rt_window *t, const uint64_t acc[RT_NCLASS][2], rt_approx_est *est, int off, rt_err *e);
void rt_window_stats(const rt_window *t, uint64_t *windows, uint64_t *short_warmups, uint64_t *fed);

/* ---- StatStack (statstack.c) ---- */
typedef struct rt_sstack rt_sstack;
rt_sstack *rt_sstack_new(const uint64_t *lines, int k, uint32_t line, double rate, uint64_t seed, rt_err *e);
void rt_sstack_free(rt_sstack *s);
void rt_sstack_put(rt_sstack *s, const rt_access *a, size_t n, uint64_t acc[RT_NCLASS][2]);
/* acc: the exact touch counts (for splitting cold misses into reads and
 * writes). */
int rt_sstack_estimate(const rt_sstack *s, const uint64_t acc[RT_NCLASS][2], rt_approx_est *est, rt_err *e);

#endif
