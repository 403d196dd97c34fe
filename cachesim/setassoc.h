/*
 * setassoc.h -- one set-associative cache of one size, LRU or a
 * replacement policy's hooks (private to cachesim/; see setassoc.c).
 */
#ifndef RT_SETASSOC_H
#define RT_SETASSOC_H

#include "sim.h"

struct rt_repl_ops;

typedef struct rt_sa rt_sa;

/* size and line in bytes (any line size >= 1); assoc ways per set, 0 =
 * fully associative (one set). size must be a multiple of line*assoc.
 * ops: the replacement policy (engine.h), NULL = LRU; seed for its random
 * choices. */
rt_sa *rt_sa_new(uint64_t size, uint32_t line, uint32_t assoc, int write_through, int no_write_allocate,
                 const struct rt_repl_ops *ops, uint64_t seed, rt_err *e);
void rt_sa_free(rt_sa *c);
/* Bytes of state rt_sa_new allocates for that cache (slots, sets, table):
 * it is all allocated up front, so it is checked before (rt_sim_config_check). */
uint64_t rt_sa_state_bytes(uint64_t size, uint32_t line, uint32_t assoc, int policy);
void rt_sa_put(rt_sa *c, const rt_access *a, size_t n);
/* Counters of class cls summed over the generations; _gen: of generation
 * bucket gen (0..RT_MAXGEN-1), gen < 0 sums them. */
void rt_sa_get(const rt_sa *c, int cls, rt_sim_counts *out);
void rt_sa_get_gen(const rt_sa *c, int cls, int gen, rt_sim_counts *out);
int rt_sa_check(const rt_sa *c, rt_err *e);
/* on: an allocating write miss covering its whole line fetches nothing
 * (rt_sim_config.write_miss_fullline); set before the first reference. */
void rt_sa_set_fullline(rt_sa *c, int on);
/* Writes back every dirty line (charged to its last writer), leaving it
 * clean and resident. */
void rt_sa_flush(rt_sa *c);

/* Makes c a level of a hierarchy: every line it fetches (a read of the
 * line), writes back (a write of the line) or writes through / around (a
 * write of those bytes) becomes a reference to below, in order, with the
 * class and generation of the reference that caused it (a write-back: of
 * the line's last writer); they are sent when a batch of rt_sa_put or a
 * flush ends. NULL: none. 0, or -1 out of memory. */
int rt_sa_set_below(rt_sa *c, rt_sink *below, rt_err *e);
/* Counts cnt[cg] reads that hit the most recent line of their set (the
 * repeat filter, sim.h; LRU with write-allocate only). */
void rt_sa_add_repeats(rt_sa *c, const uint64_t *cnt);
/* ---- one line at a time, for the multi-core model (cachesim/mcore.c) ---- */
/* One touch of line (bytes of the reference inside it, from address lo),
 * as rt_sa_put makes them; what it sends below stays buffered until
 * rt_sa_send_below. 1 on a hit, 0 on a miss. */
int rt_sa_touch(rt_sa *c, uint64_t line, int write, unsigned cg, uint32_t bytes, uint64_t lo);
void rt_sa_send_below(rt_sa *c);
/* Removes line (a coherence invalidation; nothing is counted or sent): 0
 * if absent, 1 if it was clean, 2 if dirty (*wcg = its last writer's
 * (class, generation) index). The way becomes a hole, filled first. */
int rt_sa_drop(rt_sa *c, uint64_t line, unsigned *wcg);
/* Marks line clean (a downgrade): 1 if it was dirty (*wcg as above), else 0. */
int rt_sa_clean(rt_sa *c, uint64_t line, unsigned *wcg);
/* 0 absent, 1 resident clean, 2 resident dirty. */
int rt_sa_holds(const rt_sa *c, uint64_t line);
/* Calls fn for every resident line (tests' checkers); stops at the first
 * non-zero return (then -1). */
int rt_sa_foreach(const rt_sa *c, int (*fn)(void *ctx, uint64_t line, int dirty), void *ctx);
/* 1 once the level below refused a batch. */
int rt_sa_below_failed(const rt_sa *c);

#endif
