/*
 * sample.h -- the sampling rules every sampled simulator and the trace's
 * sample index share (prefix rt_sample_), so they are written once:
 *
 *   - golden-ratio (stratified) line sampling: line L is sampled iff
 *     L * GOLD + off < T64 (mod 2^64), off = mix(seed ^ GOLD), T64 = R 2^64
 *     for a rate R (T64 = 0: every line); a sequence whose fractional parts
 *     L / phi + c fill [0, 1) evenly, so a rate-R sample of any range of
 *     lines holds R of them to within one line;
 *   - window placement: window j measures records [s_j, s_j + M) with
 *     s_j = (j + 1) P - M - o and o = (seed - 1) GOLD mod (P - M), so seed 1
 *     (the default) places every window at the end of its period.
 *
 * Users: cachesim/window.c (the hybrid method), cachesim/shards.c (golden
 * SHARDS), cachesim/sindex.c (the version-3 trace's sample index, which
 * must give the hybrid method's windows and samples bit for bit).
 */
#ifndef RT_SAMPLE_H
#define RT_SAMPLE_H

#include "rt_math.h"

#include <stdint.h>

#define RT_SAMPLE_GOLD 0x9e3779b97f4a7c15ULL /* 2^64 / phi */

/* off of the golden rule for a seed. */
static inline uint64_t rt_sample_golden_offset(uint64_t seed) { return rt_mix64(seed ^ RT_SAMPLE_GOLD); }

/* 1 when line L is in the golden sample (T64 = 0: every line). */
static inline int rt_sample_golden(uint64_t L, uint64_t off, uint64_t T64)
{
    return !T64 || L * RT_SAMPLE_GOLD + off < T64;
}

/* Start of the first window, s_0 = P - M - o (period > window >= 1). */
static inline uint64_t rt_sample_first_window(uint64_t period, uint64_t window, uint64_t seed)
{
    uint64_t pm = period - window;
    return pm - ((seed - 1) * RT_SAMPLE_GOLD) % pm;
}

#endif
