/*
 * approx.h -- approximate (sampled) cache simulation with measured error
 * (module prefix rt_approx_).
 *
 * An rt_approx estimates, for the cache configurations of an rt_sim_config
 * (fully associative LRU, write-back, write-allocate: the paper's setting),
 * the same per-size, per-class counters the exact simulator produces
 * (rt_sim_counts), from a sample of the reference stream, at a fraction of
 * the cost. Methods (docs/approx.md has the formulas and measured errors):
 *
 *   RT_APPROX_EXACT         no sampling: the exact simulator for every size
 *                           (lets a front end use one code path);
 *   RT_APPROX_SHARDS_RATE   spatial sampling, fixed rate (SHARDS, Waldspurger
 *                           et al., FAST 2015): lines whose hash falls under
 *                           a threshold are simulated, distances scaled;
 *   RT_APPROX_SHARDS_FIXED  spatial sampling with at most smax sampled lines
 *                           (SHARDS fixed-size): the threshold is lowered as
 *                           lines arrive, so memory is bounded;
 *   RT_APPROX_STATSTACK     temporal sampling of reuse times (StatStack,
 *                           Eklov and Hagersten, ISPASS 2010), converted to
 *                           expected stack distances;
 *   RT_APPROX_HYBRID        sizes below window_below simulated exactly on
 *                           evenly spaced windows of the stream, each warmed
 *                           exactly from the references before it; larger
 *                           sizes by SHARDS with golden-ratio (stratified)
 *                           line sampling at a fixed rate.
 *
 * Sizes strictly below ac->exact_below bytes are simulated exactly (the real
 * rt_sim, on every reference, but only for those small sizes). A sampled
 * size whose scaled capacity is below one sampled line (SHARDS: rate x lines
 * < 1) has no estimate: rt_approx_get fails for it with a message naming
 * the remedy (exact_below). Accesses are always counted exactly; misses and
 * write-backs are estimates scaled back to full-trace units.
 *
 * Ray generations (rt_access.gen) are accepted and ignored: every estimate
 * is summed over the generations. Per-generation figures are exact-only
 * (rt_sim_get_gen).
 *
 * Usage: rt_approx_new, feed references through rt_approx_sink /
 * rt_approx_put, rt_approx_replay or rt_approx_replay_file (which reads a
 * version-3 trace's sample index instead of its records when it can),
 * call rt_approx_finish, then rt_approx_get. Return conventions as in rt.h: 0 / non-NULL on success,
 * -1 / NULL with one line in e.
 */
#ifndef RT_APPROX_H
#define RT_APPROX_H

#include "memmodel.h"
#include "rt.h"
#include "sim.h"
#include "sindex.h"
#include "trace.h"

#include <stdint.h>
#include <stdio.h>

enum {
    RT_APPROX_EXACT = 0,
    RT_APPROX_SHARDS_RATE = 1,
    RT_APPROX_SHARDS_FIXED = 2,
    RT_APPROX_STATSTACK = 3,
    RT_APPROX_HYBRID = 4,
    RT_APPROX_NMETHODS = 5
};

/* Fewest sampled lines (SHARDS) or sampled references (StatStack) that give
 * an estimate; below it rt_approx_get fails ("trace too short"). */
#define RT_APPROX_MIN_SAMPLES 32

typedef struct rt_approx_config {
    int method;           /* RT_APPROX_* */
    double rate;          /* SHARDS_RATE, STATSTACK: sampling rate, 2^-32 .. 1 */
    uint64_t smax;        /* SHARDS_FIXED: most sampled lines kept (>= RT_APPROX_MIN_SAMPLES) */
    uint64_t seed;        /* hash / PRNG seed; equal seeds give bit-identical estimates */
    uint64_t exact_below; /* sizes (bytes) strictly below this are simulated exactly; 0 = none */
    uint64_t window_below; /* HYBRID: sizes (bytes) below this (and >= exact_below) on windows */
    uint64_t period;       /* HYBRID: one window every period references */
    uint64_t window;       /* HYBRID: references measured per window (1..period) */
    int errors;            /* HYBRID: also estimate standard errors (rt_approx_traffic_se); the
                              estimates are the same either way, the sampled part costs about
                              twice as much; default 0 */
} rt_approx_config;

/* Defaults of the hybrid method (docs/approx.md has the measurements). */
#define RT_APPROX_HYBRID_RATE (1.0 / 64)
#define RT_APPROX_HYBRID_WINDOW_BELOW 32768
#define RT_APPROX_HYBRID_PERIOD 65536
#define RT_APPROX_HYBRID_WINDOW 1024

/* SHARDS_RATE, rate 0.01, smax 8192, seed 1, exact_below 0; the hybrid
 * fields at their defaults (used only by RT_APPROX_HYBRID). */
void rt_approx_config_default(rt_approx_config *ac);
/* The rate a method uses when none is given: RT_APPROX_HYBRID_RATE for
 * hybrid, 0.01 for the others. */
double rt_approx_default_rate(int method);

/* "exact", "shards", "shards-fixed", "statstack", "hybrid"; NULL if out of
 * range. */
const char *rt_approx_method_name(int method);
/* Method from its name, or -1. */
int rt_approx_method_from_name(const char *name);

/* Canonical parameter string for the database's sim_params, e.g.
 * "rate=0.01 seed=1 exact_below=16384" (shards, statstack),
 * "rate=0.015625 seed=1 window_below=32768 period=65536 window=1024
 * exact_below=0" (hybrid),
 * "smax=8192 seed=1 exact_below=0" (shards-fixed), "" (exact). Writes at
 * most n bytes (NUL included) into buf and returns buf. */
const char *rt_approx_params(const rt_approx_config *ac, char *buf, size_t n);

/* Checks ac against c: a known method, rate in [2^-32, 1], smax >= the
 * minimum, and a fully associative write-back write-allocate c. 0 or -1. */
int rt_approx_config_check(const rt_sim_config *c, const rt_approx_config *ac, rt_err *e);

typedef struct rt_approx rt_approx;

/* Creates an estimator for the sizes of c (copied). NULL on a bad
 * configuration or out of memory. Memory: the exact simulator of the
 * sizes below exact_below, plus about 64 bytes per sampled line (SHARDS)
 * or per outstanding sampled reference (StatStack). */
rt_approx *rt_approx_new(const rt_sim_config *c, const rt_approx_config *ac, rt_err *e);
void rt_approx_free(rt_approx *a); /* NULL is fine */

const rt_sim_config *rt_approx_get_config(const rt_approx *a);
const rt_approx_config *rt_approx_get_approx_config(const rt_approx *a);

/* Consumes n references. Returns 0 (never fails; out-of-memory while
 * growing a table is remembered and reported by rt_approx_finish). Class
 * values >= RT_NCLASS count as RT_CLS_FB, size 0 as 1, as in rt_sim_put. */
int rt_approx_put(rt_approx *a, const rt_access *acc, size_t n);
/* An rt_sink feeding a; owned by a, valid until rt_approx_free. */
rt_sink *rt_approx_sink(rt_approx *a);
/* The repeat filter of a's sink for two-thread replays (sim.h,
 * rt_repeats): that of the exact simulator for the exact method, none
 * (line 0) for the sampled ones. */
void rt_approx_repeats(rt_approx *a, rt_repeats *out);
/* References seen so far. */
uint64_t rt_approx_refs(const rt_approx *a);
/* The engine: for RT_APPROX_EXACT the exact simulator's (rt_sim_engine:
 * "exact-stack" or "exact-persize"), else the method name. Static string. */
const char *rt_approx_engine(const rt_approx *a);

/* Replays a whole .rtt or din file into a; arguments and return as
 * rt_sim_replay (sim.h). Does not call rt_approx_finish. */
int rt_approx_replay(rt_approx *a, const char *path, int fmt, int din_class, rt_tr_meta *meta,
                     rt_sim_input *info, rt_err *e);

/* Whether a trace's sample index (trace.h) can stand in for its records:
 * 1 if feeding a the stream's side chunks (rt_approx_put_side) gives the
 * estimates the records would, 0 with the reason in why (n bytes) if not.
 * It can for the hybrid method with no exact sizes, the stream's line size
 * and seed, a rate at most the stream's (golden samples at a lower rate
 * are subsets), and windows of the stream's period, length, warm-up depth
 * (largest windowed size) and history; a has seen no references. */
int rt_approx_sample_fits(const rt_approx *a, const rt_tr_sample_params *sp, char *why, size_t n);
/* Consumes the sample index of one data chunk (rt_si_read). Only
 * after rt_approx_sample_fits said yes, and not mixed with rt_approx_put. */
int rt_approx_put_side(rt_approx *a, const rt_si_side *s);

/* Replays one file into a, from its sample index when it has one that
 * fits (rt_approx_sample_fits: only the side chunks are decoded), else
 * every record through rt_sim_replay_threads (same arguments). For the
 * hybrid method on an .rtt without a fitting sample index, note (n bytes)
 * gets one line saying why every record is decoded; otherwise it is "".
 * Results, meta and info (refs, file size, file hash) are the same either
 * way. 0, or -1 with the reader's message. Does not call rt_approx_finish. */
int rt_approx_replay_file(rt_approx *a, const char *path, int fmt, int din_class, int nthreads, rt_tr_meta *meta,
                          rt_sim_input *info, char *note, size_t n, rt_err *e);

/* Computes the estimates from the references seen so far (a snapshot:
 * more references may follow, and finish again). -1 only if an earlier
 * put ran out of memory. */
int rt_approx_finish(rt_approx *a, rt_err *e);

/* 1 if size index i has a number after rt_approx_finish, 0 if not (with
 * the reason in e: trace too short for the rate, size below the sampling
 * resolution, or finish not called). */
int rt_approx_available(const rt_approx *a, int i, rt_err *e);

/* Estimated standard error, in bytes, of the traffic estimate of size
 * index i summed over the classes of a group (rt_group; RT_NGROUP: all
 * classes), after rt_approx_finish. 0 for a size simulated exactly. The
 * hybrid method estimates it: windowed sizes from the spread of the
 * windows (window.c, ERROR), larger sizes from RT_APPROX_SE_PARTS
 * random replicates of the golden sample (shards.c, REPLICATES); it is a statistical error and does not see a bias shared
 * by the whole sample (docs/approx.md has measured coverage). Other
 * sampled methods have none: -1 with a message, as for an unavailable
 * size, or when ac->errors was 0. */
#define RT_APPROX_SE_PARTS 8
int rt_approx_traffic_se(const rt_approx *a, int i, int group, double *se, rt_err *e);

/* Estimated counters of size index i for class cls, in full-trace units,
 * rounded to integers, with traffic_bytes = (read_misses + write_misses +
 * writebacks) * line and wt_bytes 0. Exact for sizes below exact_below.
 * Returns 0, or -1 with a message ("trace too short for rate 0.0001: 3
 * sampled lines", "size 1K is below the sampling resolution ...") when
 * the size has no estimate. */
int rt_approx_get(const rt_approx *a, int i, int cls, rt_sim_counts *out, rt_err *e);
/* Sum over the classes of a group (rt_group). Same returns. */
int rt_approx_get_group(const rt_approx *a, int i, int group, rt_sim_counts *out, rt_err *e);
/* Counters of size index i, class cls, generation gen (as rt_sim_get_gen)
 * for a size simulated exactly (every size of RT_APPROX_EXACT, sizes below
 * exact_below otherwise). -1 with a message for an estimated size: the
 * estimators keep no generations. */
int rt_approx_get_gen(const rt_approx *a, int i, int cls, int gen, rt_sim_counts *out, rt_err *e);

/* Sampling statistics of the last rt_approx_finish. */
typedef struct rt_approx_stats {
    uint64_t refs;            /* references seen */
    uint64_t touches;         /* line touches seen (all sizes' accesses) */
    uint64_t sampled_touches; /* touches that went to the estimator */
    uint64_t sampled_lines;   /* SHARDS: distinct lines in the sample now; StatStack: sampled references */
    double rate;              /* effective rate (SHARDS_FIXED: the final one) */
    uint64_t windows;         /* HYBRID: windows measured */
    uint64_t short_warmups;   /* HYBRID: of which warmed from fewer lines than the largest windowed cache */
    uint64_t window_refs;     /* HYBRID: references scanned (history) or simulated for the windows */
} rt_approx_stats;
void rt_approx_get_stats(const rt_approx *a, rt_approx_stats *st);

#endif
