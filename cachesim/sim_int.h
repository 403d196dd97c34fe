/*
 * sim_int.h -- what the exact engines share, private to cachesim/: the
 * counter index of a (class, generation) pair.
 *
 * The exact engines count every touch and every write-back per class *and*
 * ray generation. Folding the two into one small index (cg = bucket *
 * RT_NCLASS + class, < RT_SIM_NCG = 80) keeps their hot paths as they were
 * with classes alone: one index computed per reference, one byte per line
 * for the last writer, one counter row per index. Per-class figures are
 * sums over the generations, made when results are read.
 */
#ifndef RT_SIM_INT_H
#define RT_SIM_INT_H

#include "memmodel.h"

#define RT_SIM_NCG (RT_NCLASS * RT_MAXGEN) /* (class, generation) indices */

_Static_assert(RT_SIM_NCG <= 256, "a (class, generation) index must fit a byte");

/* The counter index of a reference: classes >= RT_NCLASS count as
 * RT_CLS_FB ("other"), generations >= RT_MAXGEN-1 in the last bucket. */
static inline unsigned rt_sim_cg(const rt_access *a)
{
    unsigned cls = a->cls < RT_NCLASS ? a->cls : RT_CLS_FB;
    return rt_gen_bucket(a->gen) * RT_NCLASS + cls;
}

/* ---- the hybrid's windows fed from a trace's sample index (window.c,
 * approx.c) ---- */
struct rt_window;
/* One window whose warm-up was computed by the trace writer: the warm-up
 * touches (least recent first), the records its backward scan read and
 * whether it was short (for the statistics), then its records; fewer than
 * the window length: the trace ended inside it (no counters, as when the
 * stream ends inside a window). Same counters as rt_window_put on the
 * records around it. Not to be mixed with rt_window_put. */
void rt_window_put_warm(struct rt_window *t, const rt_access *warm, size_t nwarm, uint64_t scanned, int short_warmup,
                        const rt_access *recs, size_t nrecs);
/* History records kept before a window (its warm-up scans at most these). */
uint64_t rt_window_hist(const struct rt_window *t);

#endif
