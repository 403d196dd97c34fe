/*
 * mcore.h -- many cores sharing a cache hierarchy (prefix rt_mc_): N
 * simulated cores, each with a private cache, above one shared last level,
 * fed the interleaved references of a multi-core run (tracegen/run.h
 * rt_job_run_cores, or a version-4 trace).
 *
 * THE MACHINE. References arrive in the order of the modeled clock (a tick
 * is 16 references of every running core, cores in order: run.h); the
 * model handles them one at a time in that order, so its counts are the
 * same on every machine. Each reference touches every line of
 * [addr, addr + size - 1] (line = the hierarchy's one line size); each touch
 * goes to the core's private cache first:
 *
 *   - private level: set-associative (or fully associative) LRU,
 *     write-back, write-allocate. A hit refreshes the line (a write marks
 *     it dirty). A miss fetches the line from the shared level (one read
 *     of the line there, of the touch's class and generation) -- except a
 *     streaming store (RT_WRITE_STREAM), which allocates the line dirty
 *     without a fetch -- and evicts the set's least recently used line,
 *     which, dirty, is written back: one whole-line store to the shared
 *     level (RT_WRITE_STREAM: it allocates there without a fetch), charged
 *     to the class and generation of the line's last write;
 *   - coherence, write-invalidate: a write touch (hit or miss) removes the
 *     line from every other core's private cache; a dirty copy there is
 *     written back first (to the shared level, charged to that core). The
 *     core that lost the line remembers it, and its next miss on that line
 *     is a COHERENCE miss (counted in misses and, separately, in
 *     coherence_misses). A read miss on a line another core holds dirty
 *     makes that core write it back first (charged to it) and keep it
 *     clean (MSI's downgrade): the reader's fetch then gets the written
 *     data from the shared level. A miss sends the shared level, in this
 *     order, the other cores' write-backs, the victim's, then the fetch.
 *     Read-only data (geometry) is never
 *     invalidated: any number of cores hold clean copies;
 *   - shared level: the one-pass simulator of cachesim/sim.h at all its
 *     sizes at once (fully associative LRU write-back write-allocate: the
 *     13 sizes 1K..4M in the paper's setting), whose traffic is the DRAM
 *     traffic. At the end nothing is flushed (as the one-level simulator
 *     without cfg.flush): lines still dirty in a private cache stay there.
 *
 * Ray state that moves between cores is counted where it moves: a line one
 * core wrote and another reads is a miss of the reader that the writer's
 * write-back (on invalidation or eviction) and the reader's fetch carry
 * through the shared level. In the static decompositions of the recursive,
 * packet and treelet tracers no ray moves (each core owns its pixels'
 * rays), so coherence misses count only lines two cores' records share
 * (false sharing of ray and framebuffer lines at share-tile edges).
 *
 * INVARIANTS (rt_mc_check):
 *   1. every valid private line is in the set its line number maps to, at
 *      most once per cache, and a set holds at most assoc lines;
 *   2. per core and class: misses <= accesses, coherence_misses <= misses;
 *      per core, summed over classes: fetches + nofetch = misses;
 *   3. a line dirty in one core's cache is held by no other core (a write
 *      invalidated every other copy);
 *   4. the shared level saw exactly the fetches and write-backs of all
 *      private caches (its references = their sum), and itself passes
 *      rt_sim_check.
 * Library rule: errors through rt_err, never printed.
 */
#ifndef RT_MCORE_H
#define RT_MCORE_H

#include "sim.h"

#define RT_MC_MAXCORES 256

typedef struct rt_mc_config {
    int ncores;           /* 1..RT_MC_MAXCORES */
    char priv_name[16];   /* the private level's name ("L1") */
    char shared_name[16]; /* the shared level's name ("LLC") */
    uint64_t priv_size;   /* private cache bytes per core */
    uint32_t priv_assoc;  /* its ways; 0 = fully associative */
    uint32_t line;        /* line bytes (a power of two), both levels */
    rt_sim_config shared; /* the shared level: sizes, line (= line), LRU write-back write-allocate */
} rt_mc_config;

/* One core's private-level counters for one class (or all classes). */
typedef struct rt_mc_counts {
    uint64_t accesses;         /* line touches */
    uint64_t misses;           /* touches that missed (coherence misses included) */
    uint64_t coherence_misses; /* misses on a line another core's write took away */
    uint64_t nofetch;          /* misses that fetched nothing (streaming stores) */
    uint64_t writebacks;       /* dirty lines sent down (evictions and invalidations) */
    uint64_t invalidations;    /* lines of this core another core's write removed */
    uint64_t traffic_bytes;    /* (fetches + write-backs) x line: what goes to the shared level */
} rt_mc_counts;

/* Parses a hierarchy: two comma-separated levels NAME=SIZE/WAYS/LINE/REPL[/SCOPE],
 * SIZE a size (32K) or, for the shared level, a range of powers of two
 * (1K-4M: 1K, 2K, ..., 4M), WAYS a number or "full", REPL "lru" (the one
 * policy this model has), SCOPE "private" or "shared" (without it: the
 * first level private, the last shared); one private level above one
 * shared one, one line size. E.g. "L1=32K/8/64/lru/private,LLC=1K-4M/full/64/lru/shared".
 * Fills c (ncores 1). 0, or -1 naming the part in e. */
int rt_mc_parse(const char *spec, rt_mc_config *c, rt_err *e);
/* The canonical spelling of c's hierarchy into buf (the run key's). */
void rt_mc_spec(const rt_mc_config *c, char *buf, size_t n);

typedef struct rt_mc rt_mc;
rt_mc *rt_mc_new(const rt_mc_config *c, rt_err *e);
void rt_mc_free(rt_mc *m);
/* n references of core `core` (< ncores), in clock order. 0, or -1 (out
 * of memory, core out of range: rt_mc_error). */
int rt_mc_put(rt_mc *m, unsigned core, const rt_access *a, size_t n);
/* The model as a core sink (rt_mc_put). */
rt_csink *rt_mc_csink(rt_mc *m);
/* The model as a one-core sink (core 0): a trace of versions 1-3. */
rt_sink *rt_mc_sink(rt_mc *m);
/* Ends the stream (the shared level's rt_sim_finish). 0 or -1. */
int rt_mc_finish(rt_mc *m);
const char *rt_mc_error(const rt_mc *m);
const rt_mc_config *rt_mc_get_config(const rt_mc *m);
/* Core's private counters for class cls (0..RT_NCLASS-1), or all classes (cls -1). */
void rt_mc_get(const rt_mc *m, int core, int cls, rt_mc_counts *out);
/* The shared level (read its counters with rt_sim_get). */
const rt_sim *rt_mc_shared(const rt_mc *m);
/* References handed to the model. */
uint64_t rt_mc_refs(const rt_mc *m);
/* The invariants above. 0, or -1 naming the one broken. Slow; for tests. */
int rt_mc_check(const rt_mc *m, rt_err *e);

#endif
