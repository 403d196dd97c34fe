/*
 * incl.h -- inclusive and exclusive cache hierarchies (module prefix
 * rt_incl_; private to cachesim/, reached through hier.h).
 *
 * A non-inclusive non-exclusive hierarchy is engines chained (hier.c):
 * the stream a level sends down does not depend on the levels below it,
 * so the last level runs all its sizes on one filtered stream. With
 * inclusion that no longer holds: an inclusive last level that evicts a
 * line back-invalidates it above, and an exclusive last level takes the
 * victims of the level above and gives lines back up, so the upper levels'
 * contents depend on the last level's size. Here every size of the last
 * level runs its own chain of levels (one chain per size; the upper levels
 * are simulated once per size).
 *
 * The model (every level write-back, write-allocate, one line size for all
 * levels; a reference is cut into touches of that line). Each level has
 * its own replacement policy, any of the per-size engine's (lru, fifo,
 * random, plru, srrip, brrip; not opt, which needs the whole stream of a
 * level before it simulates): "evicts its victim" below is that policy's
 * choice in a full set; a line that leaves a level otherwise (back-
 * invalidated, or taken out by an exclusive lookup) frees its way, which
 * the set's next fill takes first (the lowest free way), the policy not
 * told of the removal (incl.c):
 *
 * INCLUSIVE. A touch that hits level 0 is done. A miss at level k fetches
 * the line from level k+1 (an access there, read, of the touch's class;
 * recursively; the last level fetches from memory), then, when its set is
 * full, evicts its victim; a dirty victim is written back to level k+1,
 * a write access there that always hits (inclusion) -- the same order as
 * the non-inclusive chain, fetch first, then the write-back. When a level
 * j >= 1 evicts a line, every level above that holds it loses it: a
 * BACK-INVALIDATION, counted at the level that loses the line, charged to
 * the class of the touch that last brought or touched it there; a dirty
 * copy is written down into the evicted line first (a BACK-INVALIDATION
 * WRITE-BACK of that level, charged to its last writer's class; the line
 * evicted from j is then dirty and written back by j as usual).
 *
 * EXCLUSIVE. A line is in at most one level. A touch that misses level 0
 * looks in levels 1, 2, ... in order (an access at each, a miss where it is
 * absent); where it is found it is taken out (with its dirty bit and last
 * writer) and moved into level 0; found nowhere, it comes from memory (a
 * miss at every level). Level 0's victim, clean or dirty, moves into
 * level 1 (a fill there: the most recent position of an LRU level), level
 * 1's victim into level 2, and
 * so on; the last level's dirty victims are written back to memory, its
 * clean ones dropped. Moves into a level are not accesses of it.
 *
 * Counters per level, last-level size and class (generations are pooled):
 * accesses, read/write misses, writebacks (dirty lines sent down: written
 * back, or moved down by exclusion), back-invalidations and their
 * write-backs; traffic_bytes of a level = line bytes x (misses + lines it
 * sent down: its writebacks, back-invalidation write-backs and, exclusive,
 * its clean victims moved down). DRAM traffic is the last level's.
 *
 * Not modeled here (rejected by rt_hier_parse): opt,
 * write-through, no-write-allocate, flush at the end, full-line write
 * misses, differing line sizes. A streaming store is a write.
 *
 * Ownership: an rt_incl owns its chains. Errors through rt_err.
 */
#ifndef RT_INCL_H
#define RT_INCL_H

#include "hier.h"

typedef struct rt_incl rt_incl;

/* Cold chains for every last-level size of h (inclusion inclusive or
 * exclusive, levels as above); NULL with a message. */
rt_incl *rt_incl_new(const rt_hier_config *h, rt_err *e);
void rt_incl_free(rt_incl *x);
/* n references into the first level of every chain. 0. */
int rt_incl_put(rt_incl *x, const rt_access *a, size_t n);
/* Level k's counters in the chain of last-level size index i, class cls. */
void rt_incl_get(const rt_incl *x, int k, int i, int cls, rt_hier_counts *out);
/* References put so far. */
uint64_t rt_incl_refs(const rt_incl *x);
/* The invariants (incl.c): 0 or -1 with a message. */
int rt_incl_check(const rt_incl *x, rt_err *e);

#endif
