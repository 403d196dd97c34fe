/*
 * dynamic.h -- dynamic ray scheduling (Navrátil, Fussell, Lin 2007, sec. 2):
 * queue-point selection, exposed for tests and reports, and the scheduler's
 * invariant checker (prefix rt_dyn_).
 *
 * Subtree geometry g(n) is the geometry, in bytes, that processing the
 * subtree rooted at n can bring into the cache: 8 bytes per node of the
 * subtree, 4 bytes per entry of its leaves' index lists, and 36 bytes per
 * distinct triangle its leaves reference (a triangle shared by several
 * leaves is loaded once).
 *
 * Queue points are the first nodes on each branch, from the root down,
 * with 0 < g(n) <= g_max; a leaf with triangles is a queue point even when
 * its geometry exceeds g_max (it is then processed in cache-sized blocks).
 * Subtrees holding no triangles are never queue points: rays cross them in
 * the tree top without stopping. The root alone is the queue point when
 * everything fits, and the scheduler degenerates to recursive order.
 */
#ifndef RT_DYNAMIC_H
#define RT_DYNAMIC_H

#include "kdtree.h"

#include <stdint.h>

/* Fills g[0..nnodes) with subtree geometry bytes (see above); ntri is the
 * scene's triangle count. 0 or -1 (out of memory). */
int rt_dyn_subtree_geometry(const rt_kdtree *kd, uint32_t ntri, uint64_t *g, rt_err *e);

/* Marks queue points: qp[n] = queue-point number (0.. in depth-first order)
 * or -1. Returns the number of queue points; *ntop receives the number of
 * tree-top nodes (non-queue-point nodes above the queue points). */
uint32_t rt_dyn_select(const rt_kdtree *kd, const uint64_t *g, uint64_t gmax, int32_t *qp, uint32_t *ntop);

/* Derives g_max for a cache of sched_size: the geometry that fits after the
 * resident tree top (8 B per node), the queue table (8 B per queue point)
 * and the ray buffer (raybuf_bytes), iterated to a fixed point. When no
 * fixed point above 0 exists (the top needed to make subtrees fit is itself
 * larger than the cache), the top is kept resident instead: the smallest
 * g_max whose top and table fit in half the cache after the ray buffer;
 * *fallback is then set. */
uint64_t rt_dyn_derive_gmax(const rt_kdtree *kd, const uint64_t *g, uint64_t sched_size, uint64_t raybuf_bytes,
                            int *fallback);

/* The scheduler's state during a run (dynamic.c). */
typedef struct rt_dyn rt_dyn;

/* Verifies the invariants I1-I6 documented at the top of dynamic.c. The
 * tracer calls it at every step boundary when its job is in test mode
 * (rt_job.check). 0, or -1 naming the broken invariant in e. */
int rt_dyn_check(const rt_dyn *D, rt_err *e);

#endif
