/*
 * engine.h -- the cache engine table (module prefix rt_cache_engine /
 * rt_repl_): how rt_sim (sim.h) reaches the simulators that do the work.
 *
 * An ENGINE simulates every size of one rt_sim_config (all of them in one
 * pass, or one cache per size) and answers counters per (size, class,
 * generation). rt_sim_new walks the table (rt_cache_engines) in order and
 * takes the first entry whose replacement policy is the configuration's
 * (rt_sim_config.repl) and whose capabilities cover it; every later call of
 * sim.c goes through the entry's function pointers, so sim.c knows no
 * engine by name.
 *
 * A REPLACEMENT POLICY other than the set-associative LRU lists is a small
 * rt_repl_ops (hit / fill / victim hooks over one set's words of state)
 * run by the per-size engine of setassoc.c, which keeps the tags, the
 * write policies and the counters. Adding a policy is one file defining an
 * rt_repl_ops and one line in the table of engine.c (plus the file in
 * cachesim/local.am), with its naive reference in tests/test_repl.c.
 *
 * A level of a hierarchy is meant to be an engine of one size whose misses
 * and write-backs are the references of the level below; the table keeps
 * that shape (create from a configuration, access, finish, counts), so a
 * hierarchy is engines chained.
 *
 * Ownership: the table and the ops are static constants; an engine's state
 * (create's result) belongs to the rt_sim that created it and is released
 * by destroy. Errors are reported through rt_err; nothing here prints.
 */
#ifndef RT_ENGINE_H
#define RT_ENGINE_H

#include "sim.h"

/* What an engine supports (rt_cache_engine.caps). */
enum {
    RT_ENG_FULLASSOC = 1u << 0, /* assoc == 0 (one set) */
    RT_ENG_SETASSOC = 1u << 1,  /* assoc >= 1 (direct-mapped included) */
    RT_ENG_WT = 1u << 2,        /* write-through */
    RT_ENG_NWA = 1u << 3,       /* no-write-allocate */
    RT_ENG_ONEPASS = 1u << 4,   /* every size in one pass (a stack algorithm) */
    RT_ENG_REPEATS = 1u << 5,   /* offers the repeat filter (rt_repeats) */
};

typedef struct rt_cache_engine {
    const char *name; /* engine label printed by `sim` and stored ("exact-stack") */
    const char *repl; /* the replacement policy it implements ("lru"), or NULL: every
                         policy of rt_repl_policies (the per-size engine's hooks) */
    unsigned caps;    /* RT_ENG_* */
    /* Bytes allocated up front for configuration c (checked against the
     * memory limit before create); 0 when the state grows with the lines
     * seen. */
    uint64_t (*state_bytes)(const rt_sim_config *c);
    /* Cold caches for every size of c (already checked by
     * rt_sim_config_check); NULL with a message. */
    void *(*create)(const rt_sim_config *c, rt_err *e);
    void (*destroy)(void *st);
    /* Simulates n references: 0, or -1 when the state could not grow (then
     * the counters stop at the batch before). */
    int (*access)(void *st, const rt_access *a, size_t n);
    /* The end of a run (rt_sim_finish): with flush (cfg.flush) every dirty
     * line is written back; an offline engine (OPT) simulates here. */
    void (*finish)(void *st, int flush);
    /* Counters of size index i, class cls, generation bucket gen (gen < 0:
     * summed over them), traffic_bytes filled in. */
    void (*counts)(const void *st, int i, int cls, int gen, rt_sim_counts *out);
    /* The engine's invariants: 0, or -1 with a message. */
    int (*check)(const void *st, rt_err *e);
    /* RT_ENG_REPEATS only: counts cnt[cg] reads that hit the top of the
     * recency stack in every size (rt_repeats). */
    void (*repeats)(void *st, const uint64_t *cnt);
    /* A level of a hierarchy (NULL: this engine cannot feed another): its
     * fetches, write-backs and written-through bytes become references to
     * below, in order (rt_sa_set_below). 0, or -1 with a message. */
    int (*set_below)(void *st, rt_sink *below, rt_err *e);
    /* An offline engine's phases in its last finish, in seconds (NULL:
     * none): out[0] the backward next-use pass, out[1] the forward
     * simulation of every size. */
    void (*phases)(const void *st, double *out);
} rt_cache_engine;

/* The table, in the order rt_sim_new tries it, ended by NULL. */
extern const rt_cache_engine *const rt_cache_engines[];
/* Its entries: the one-pass LRU stack simulator (msim.c), the per-size
 * set-associative engine (setassoc.c: LRU lists, or a policy's hooks) and
 * Belady's MIN (opt.c, offline: it simulates in finish). */
extern const rt_cache_engine rt_engine_stack, rt_engine_persize, rt_engine_opt;

/* The first entry that simulates c (its policy, associativity and write
 * policy), or NULL. */
const rt_cache_engine *rt_cache_engine_for(const rt_sim_config *c);
/* Whether engine g can simulate c. */
int rt_cache_engine_fits(const rt_cache_engine *g, const rt_sim_config *c);

/* ---- replacement policies run by the per-size engine ------------------ */

/* One set as a policy sees it. Ways are filled in order 0, 1, ... while the
 * set has room (fill is told each), so victim is asked only of a full set. */
typedef struct rt_repl_set {
    uint32_t ways;  /* ways of the set (every line of a fully associative cache) */
    uint32_t *way;  /* ways words, one per way, zero when the cache is cold */
    uint32_t *set;  /* ways words for the set as a whole (a PLRU tree, a FIFO hand), zero at first */
    uint64_t *rng;  /* the cache's random state, seeded from rt_sim_config.seed */
} rt_repl_set;

typedef struct rt_repl_ops {
    const char *name; /* as given to --repl and stored in the repl column ("fifo") */
    int pow2_ways;    /* 1: needs a power-of-two number of ways (tree PLRU) */
    int random;       /* 1: draws from rng (rt_sim_config.seed matters) */
    void (*hit)(rt_repl_set *s, uint32_t w);  /* a touch found the line in way w */
    void (*fill)(rt_repl_set *s, uint32_t w); /* a missing line was placed in way w */
    uint32_t (*victim)(rt_repl_set *s);       /* a full set must lose a way: which */
    /* The policy's invariants on one set of `used` filled ways (NULL: none). */
    int (*check)(const rt_repl_set *s, uint32_t used, rt_err *e);
} rt_repl_ops;

/* The policies of the per-size engine, ended by NULL; rt_sim_config.repl =
 * k in 1..P names rt_repl_policies[k - 1] (0 is LRU, the engines' own
 * lists; values above P name the engines of their own policy, "opt"). */
extern const rt_repl_ops *const rt_repl_policies[];
/* The ops of configuration value repl (NULL for 0 = LRU or out of range). */
const rt_repl_ops *rt_repl_ops_for(int repl);

/* The random stream every policy draws from (xorshift64*): a value in
 * 0..n-1, n >= 1. Deterministic for a seed. */
static inline uint32_t rt_repl_rand(uint64_t *st, uint32_t n)
{
    uint64_t x = *st;
    x ^= x >> 12;
    x ^= x << 25;
    x ^= x >> 27;
    *st = x;
    return (uint32_t)(((x * 0x2545F4914F6CDD1DULL) >> 32) % n);
}

#endif
