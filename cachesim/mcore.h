/*
 * mcore.h -- many cores sharing a cache hierarchy (prefix rt_mc_): N
 * simulated cores, each with its private levels of a hierarchy (hier.h),
 * above the shared levels, fed the interleaved references of a multi-core
 * run (tracegen/run.h rt_job_run_cores, or a version-4 trace).
 *
 * THE HIERARCHY is an rt_hier_config (1..RT_HIER_MAXLEVELS levels, from
 * the core outward) whose first nprivate levels are private (one copy per
 * core) and the rest shared (one copy for all cores). Each level is any
 * level hier.h allows -- set-associative or fully associative, any
 * replacement policy of engine.h -- with these limits, each for a reason:
 *   - private levels are write-back write-allocate (the coherence protocol
 *     below is a write-back one) and have one line size between them (the
 *     coherence granule); they cannot be OPT (hier.h allows OPT only at
 *     the last level, which here is shared: OPT works there, it sees the
 *     shared stream, which no later choice changes);
 *   - the last level is shared (its traffic is the DRAM traffic), and
 *     private levels come before shared ones;
 *   - the hierarchy is non-inclusive (NINE, hier.h's default): inclusive
 *     and exclusive chains (incl.h) depend on the last level's size, which
 *     would need every size's private caches run apart.
 * Because of NINE, the stream the private levels send to the shared ones
 * does not depend on the shared levels; the shared levels are one rt_hier
 * (hier.h), so the last level runs all its sizes in one pass when it is
 * fully associative LRU (the stack property), else one cache per size on
 * the same stream.
 *
 * THE MACHINE. References arrive in the order of the modeled clock (a tick
 * is 16 references of every running core, cores in order: run.h); the
 * model handles them one at a time in that order, so its counts are the
 * same on every machine. Each reference touches every line it covers, as
 * sim.h says; each touch goes to the core's first private level, whose
 * fetches and write-backs go to its next private level and, from the last
 * private level, to the first shared level, exactly as hier.h chains
 * levels (a fetch is a read of the line, a write-back a whole-line write;
 * write-backs after the fetch, as Dinero IV). Coherence, write-invalidate
 * (MSI):
 *   - a write touch (hit or miss, a streaming store too) first removes the
 *     line from every private level of every other core. If one of those
 *     copies was dirty, one whole-line write of it goes to the first shared
 *     level (charged to that core's last private level, with the class and
 *     generation of the innermost dirty copy's last write). The removed way
 *     becomes a hole, refilled before any victim is taken (setassoc.c).
 *     The core that lost the line remembers it per level, and its next
 *     miss on that line at that level is a COHERENCE miss (counted in
 *     misses and, separately, in coherence_misses);
 *   - a read touch that misses the first private level first makes the
 *     other core holding the line dirty (at most one does) write it back
 *     (as above) and keep it clean (MSI's downgrade): the reader's fetch
 *     then gets the written data from the shared level;
 *   - read-only data (geometry) is never invalidated: any number of cores
 *     hold clean copies.
 * So the first shared level sees, in order: the other cores' write-backs,
 * then the core's own fetch and its levels' victims. At the end, with the
 * accounting's flush (rt_sim_config.flush), each core's private levels are
 * flushed in order (core 0 first, each level into the next), then the
 * shared levels (rt_hier_finish); without it nothing is flushed. With one
 * core nothing of the coherence happens and the counts are those of the
 * one-core hierarchy of the same levels, to the byte (tests/test_mcore.c).
 *
 * Ray state that moves between cores is counted where it moves: a line one
 * core wrote and another reads is a miss of the reader that the writer's
 * write-back (on invalidation, downgrade or eviction) and the reader's
 * fetch carry through the shared level.
 *
 * INVARIANTS (rt_mc_check):
 *   1. every private cache passes its own check (setassoc.c: sets, holes,
 *      table, counters), and per (core, level, class, generation)
 *      coherence_misses <= misses;
 *   2. a line dirty in any private level of one core is held in no private
 *      level of any other core (a write invalidated every other copy);
 *   3. each private level below the first saw exactly the fetches and
 *      write-backs of the one above (its own, not the coherence ones);
 *   4. the shared levels saw exactly what the cores' last private levels
 *      sent (fetches, write-backs, coherence write-backs; without private
 *      levels: the references), and pass rt_hier_check.
 * Library rule: errors through rt_err, never printed.
 */
#ifndef RT_MCORE_H
#define RT_MCORE_H

#include "hier.h"
#include "sim.h"

#define RT_MC_MAXCORES 256

typedef struct rt_mc_config {
    int ncores;        /* 1..RT_MC_MAXCORES */
    int nprivate;      /* levels 0..nprivate-1 are private (0..h.nlevels-1) */
    rt_hier_config h;  /* every level from the core outward (hier.h); non-inclusive */
} rt_mc_config;

/* One core's counters at one private level for one class (or all). */
typedef struct rt_mc_counts {
    uint64_t accesses;         /* line touches */
    uint64_t misses;           /* touches that missed (coherence misses included) */
    uint64_t coherence_misses; /* misses on a line another core's write took away */
    uint64_t nofetch;          /* misses that fetched nothing (streaming stores, full-line writes) */
    uint64_t writebacks;       /* dirty lines sent down (evictions, flush, invalidations, downgrades) */
    uint64_t coh_writebacks;   /* of them, sent because another core wrote or read the line */
    uint64_t invalidations;    /* lines of this level another core's write removed (by that write's class) */
    uint64_t traffic_bytes;    /* (fetches + write-backs) x line: what goes to the level below */
} rt_mc_counts;

/* Parses a hierarchy: hier.h's spec, each level optionally ending in
 * /private or /shared, e.g. "L1=32K/8/64/lru/private,LLC=1K-4M/full/64/lru/shared"
 * or "L1=32K/8/64/lru,L2=1M/16/64/srrip,LLC=1K-4M/full/64/lru". A level
 * without the suffix: the last one shared, the first private (a one-level
 * hierarchy: shared), a middle one as the level above it. flush and
 * full-line accounting from base (NULL: the defaults, rt_sim_config_default).
 * Fills c (ncores 1). 0, or -1 with a message starting "--hierarchy: ". */
int rt_mc_parse(const char *spec, rt_mc_config *c, rt_err *e);
int rt_mc_parse_base(const char *spec, const rt_sim_config *base, rt_mc_config *c, rt_err *e);
/* A one-core hierarchy (hier.h) as a multi-core one with the default
 * scopes above (levels before the last private). 0, or -1 naming the
 * level that cannot be private. */
int rt_mc_from_hier(const rt_hier_config *h, rt_mc_config *c, rt_err *e);
/* The canonical spelling (rt_hier_spec with every level's scope) into buf. */
void rt_mc_spec(const rt_mc_config *c, char *buf, size_t n);
/* The shared levels as a hierarchy of their own (what rt_mc_new builds). */
void rt_mc_shared_config(const rt_mc_config *c, rt_hier_config *out);

typedef struct rt_mc rt_mc;
rt_mc *rt_mc_new(const rt_mc_config *c, rt_err *e);
void rt_mc_free(rt_mc *m);
/* n references of core `core` (< ncores), in clock order. 0, or -1 (core
 * out of range, a level's state could not grow: rt_mc_error). */
int rt_mc_put(rt_mc *m, unsigned core, const rt_access *a, size_t n);
/* The model as a core sink (rt_mc_put). */
rt_csink *rt_mc_csink(rt_mc *m);
/* The model as a one-core sink (core 0): a trace of versions 1-3. */
rt_sink *rt_mc_sink(rt_mc *m);
/* Ends the stream (the flush, when the accounting has it, and the shared
 * levels' end: OPT simulates here). 0 or -1. */
int rt_mc_finish(rt_mc *m);
const char *rt_mc_error(const rt_mc *m);
const rt_mc_config *rt_mc_get_config(const rt_mc *m);
/* Core's counters at private level p (0..nprivate-1) for class cls
 * (0..RT_NCLASS-1, or -1: all) and generation bucket gen (-1: all). */
void rt_mc_get_level(const rt_mc *m, int p, int core, int cls, int gen, rt_mc_counts *out);
/* The same at the first private level (zeros without private levels). */
void rt_mc_get(const rt_mc *m, int core, int cls, rt_mc_counts *out);
/* The shared levels (level k of it is level nprivate + k of the machine). */
const rt_hier *rt_mc_shared_hier(const rt_mc *m);
/* The last level (DRAM traffic: its rt_sim_get traffic_bytes). */
const rt_sim *rt_mc_shared(const rt_mc *m);
/* References handed to the model. */
uint64_t rt_mc_refs(const rt_mc *m);
/* The invariants above. 0, or -1 naming the one broken. Slow; for tests. */
int rt_mc_check(const rt_mc *m, rt_err *e);

#endif
