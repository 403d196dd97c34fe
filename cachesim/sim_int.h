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

#endif
