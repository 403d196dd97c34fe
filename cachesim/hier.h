/*
 * hier.h -- cache hierarchies: 1..4 levels of caches chained (module
 * prefix rt_hier_).
 *
 * A hierarchy is engines chained (engine.h): each level but the last is an
 * rt_sim of one size whose fetches, write-backs and written-through bytes
 * are the references of the level below (rt_sim_set_below); the last level
 * is an ordinary rt_sim and may have many sizes. DRAM traffic is the last
 * level's traffic_bytes.
 *
 * Inclusion: non-inclusive non-exclusive (NINE, the default, as in Dinero
 * IV): a level knows nothing of the others; a line evicted below stays
 * where it is above. Because the stream a level sends down does not depend
 * on the levels below it, the last level's sizes all run on the same
 * filtered stream: with an LRU last level (fully associative, write-back,
 * write-allocate) that is the one-pass stack simulator, every size in one
 * pass; OPT runs its backward pass once. INCLUSIVE (back-invalidation
 * counted) and EXCLUSIVE hierarchies are incl.h's: there the upper levels
 * depend on the last level's size, so every size runs its own chain.
 *
 * Spec (rt_hier_parse): levels from the core outward, comma-separated,
 *     NAME=SIZE[S]/WAYS|full/LINE/POLICY[/wt][/nwa]
 * e.g. L1=32K/8/64/lru,L2=1M/16/64/srrip,LLC=1K-4M/full/64/lru. SIZE is a
 * size (32K, 1M); only the last level may give several: a range A-B of
 * powers of two, or a list joined by '+' (256K+1M+4M). WAYS is a number
 * (1 = direct-mapped) or full; LINE bytes; POLICY one of rt_sim_repl_list()
 * (opt only at the last level: it sees its whole stream before it
 * simulates). /wt and /nwa make the level write-through, no-write-allocate.
 * Write-backs of a level reach the next as whole-line writes.
 * An optional last item names the inclusion: nine (the default, never
 * written back by rt_hier_spec), inclusive or exclusive, e.g.
 * L1=32K/8/64/lru,LLC=1K-4M/full/64/lru,inclusive; those two need every
 * level write-back, write-allocate with a policy of the per-size engine
 * (any but opt), one line size, and no flush or full-line write
 * accounting (incl.h).
 *
 * Ownership: an rt_hier owns its levels; rt_hier_sink is valid until
 * rt_hier_free. Errors are returned through rt_err; nothing here prints.
 */
#ifndef RT_HIER_H
#define RT_HIER_H

#include "sim.h"

#define RT_HIER_MAXLEVELS 4

enum { RT_INCL_NINE = 0, RT_INCL_INCLUSIVE = 1, RT_INCL_EXCLUSIVE = 2 };

/* "nine", "inclusive", "exclusive". */
const char *rt_hier_inclusion_name(int inclusion);

/* A level's counters with the inclusion's: back-invalidations (lines the
 * level lost because a level below evicted them) and the write-backs of
 * the dirty ones, per class; zero for a non-inclusive hierarchy. */
typedef struct rt_hier_counts {
    rt_sim_counts c;
    uint64_t backinvals;
    uint64_t bi_writebacks;
} rt_hier_counts;

typedef struct rt_hier_config {
    int nlevels;                             /* 1..RT_HIER_MAXLEVELS */
    char name[RT_HIER_MAXLEVELS][16];        /* as written in the spec ("L1") */
    rt_sim_config level[RT_HIER_MAXLEVELS];  /* level 0 is next to the core */
    int inclusion;                           /* RT_INCL_* */
} rt_hier_config;

/* Parses a spec (above) into h; flush and write_miss_fullline of every
 * level are taken from base (the run's accounting). 0, or -1 with a message
 * naming the level and the field. */
int rt_hier_parse(const char *spec, const rt_sim_config *base, rt_hier_config *h, rt_err *e);

/* The spec of h written back in the form above (canonical: sizes in K/M
 * when exact), into buf of n bytes; returns buf. */
const char *rt_hier_spec(const rt_hier_config *h, char *buf, size_t n);

typedef struct rt_hier rt_hier;

/* Cold caches; NULL with a message (a level's configuration, memory). */
rt_hier *rt_hier_new(const rt_hier_config *h, rt_err *e);
void rt_hier_free(rt_hier *h);
const rt_hier_config *rt_hier_get_config(const rt_hier *h);

/* n references into the first level. 0, or -1 when a level's state could
 * not grow. */
int rt_hier_put(rt_hier *h, const rt_access *a, size_t n);
/* An rt_sink feeding rt_hier_put; owned by h. */
rt_sink *rt_hier_sink(rt_hier *h);
/* Ends the run, level by level from the core outward (each level's flush,
 * when configured, reaches the level below before that one ends). 0. */
int rt_hier_finish(rt_hier *h);

/* The repeat filter of the first level (rt_repeats, sim.h): on when it is
 * LRU with write-allocate (a read of the line the previous reference
 * ended on is a hit at the top of its set and changes nothing). */
void rt_hier_repeats(rt_hier *h, rt_repeats *out);

/* Level k (0..nlevels-1) as a simulator: its counters with rt_sim_get and
 * the rest of sim.h (size index 0 for every level but the last). NULL for
 * an inclusive or exclusive hierarchy (use rt_hier_get). */
const rt_sim *rt_hier_level(const rt_hier *h, int k);
/* Level k's counters for last-level size index i (the chain of that size
 * when inclusive or exclusive) and class cls. */
void rt_hier_get(const rt_hier *h, int k, int i, int cls, rt_hier_counts *out);
/* References put into the first level. */
uint64_t rt_hier_refs(const rt_hier *h);

/* The invariants of every level (rt_sim_check) and of the chain: each
 * level's references are the fetches, write-backs and written-through
 * bytes of the one above (counted as they pass). 0 or -1 with a message. */
int rt_hier_check(const rt_hier *h, rt_err *e);

#endif
