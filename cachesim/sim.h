/*
 * sim.h -- cache simulators: the public API (module prefix rt_sim_).
 *
 * One rt_sim simulates a set of cache configurations that share a line size,
 * an associativity and a write policy, and differ only in total size. It
 * consumes memory references (rt_access) through an rt_sink, so a tracer can
 * stream into it in-process, or replays a trace file (.rtt) or a Dinero IV
 * din text file. Results are 64-bit counters per (size, class, ray
 * generation); per-class figures are sums over the generations.
 *
 * Engines: rt_sim_new takes the first entry of the engine table (engine.h,
 * docs/cachesim.md) that fits the configuration; sim.c reaches it only
 * through the table:
 *   - exact-stack: fully associative LRU, write-back, write-allocate (the
 *     paper's setting): the one-pass multi-size stack simulator (msim.c),
 *     exact for every size at O(#sizes) per reference;
 *   - exact-persize: anything else but OPT (set-associative,
 *     direct-mapped, write-through, no-write-allocate, a replacement
 *     policy other than LRU): one cache per size (setassoc.c), any line
 *     size;
 *   - exact-opt: Belady's MIN (opt.c), offline: counters after
 *     rt_sim_finish.
 * The replacement policy (rt_sim_config.repl) is separate from the write
 * policy; a hierarchy of caches (hier.h) chains simulators.
 *
 * Ownership and errors: an rt_sim owns its state and its sink; every
 * function that can fail returns -1 or NULL with a message in the rt_err
 * (which may be NULL); nothing here prints. The configuration is copied.
 *
 * Accounting (Dinero IV defaults, documented in docs/cachesim.md):
 *   - a reference touches every line in [addr, addr+size-1]; each touch is
 *     one access; a read touch that misses is a read miss, a write touch
 *     that misses is a write miss;
 *   - with write-allocate every miss fetches the line (one line of traffic),
 *     also a write miss; with no-write-allocate a write miss does not
 *     allocate and its bytes go to memory;
 *   - write-back: an evicted dirty line costs one line of traffic, charged
 *     to the class and generation of the reference that last wrote the
 *     line. Lines still dirty at the end are written back only with
 *     cfg.flush, by rt_sim_finish (Dinero IV's command-line simulator
 *     flushes at the end and counts them; the default keeps the earlier
 *     figures);
 *   - with cfg.write_miss_fullline, an allocating write miss whose
 *     reference covers the whole line fetches nothing (Dinero IV's rule); it
 *     is still a write miss, counted in nofetch too;
 *   - a streaming store (rt_access.write == RT_WRITE_STREAM) that misses
 *     allocates the line, dirty, without a fetch on every line it touches,
 *     whatever write_miss_fullline says (the same no-fetch path, counted in
 *     nofetch); a hit is an ordinary write; with no-write-allocate it writes
 *     around like any write. The approximate simulators count it as an
 *     ordinary write;
 *   - generations: every touch counts for its reference's generation
 *     (rt_access.gen, generations >= RT_MAXGEN-1 pooled in the last
 *     bucket); only these exact engines keep them, the approximate
 *     simulators (approx.h) accept the field and ignore it;
 *   - write-through: every write touch sends its bytes (the part of the
 *     reference inside that line) to memory; lines are never dirty;
 *   - traffic_bytes = (fetches + write-backs) x line + write-through bytes,
 *     fetches = read misses + allocating write misses - nofetch.
 */
#ifndef RT_SIM_H
#define RT_SIM_H

#include "memmodel.h"
#include "rt.h"
#include "din.h"
#include "trace.h"

#include <stdint.h>
#include <stdio.h>

#define RT_SIM_MAXSIZES 32

/* The paper's 13 sizes: 1 KiB, 2 KiB, ..., 4 MiB. */
#define RT_SIM_PAPER_NSIZES 13

typedef struct rt_sim_config {
    int nsizes;                      /* 1..RT_SIM_MAXSIZES, strictly increasing */
    uint64_t sizes[RT_SIM_MAXSIZES]; /* cache sizes in bytes */
    uint32_t line;                   /* line size in bytes (any value >= 1) */
    uint32_t assoc;                  /* ways per set; 0 = fully associative */
    int write_through;               /* 1: write-through, 0: write-back */
    int no_write_allocate;           /* 1: write misses do not allocate */
    int flush;                       /* 1: rt_sim_finish writes back every dirty line */
    int write_miss_fullline;         /* 1: a write miss covering its whole line fetches nothing */
    int repl;                        /* replacement policy: 0 = LRU, else rt_sim_repl_parse's value */
    uint64_t seed;                   /* seed of the random choices of a policy (random, BRRIP) */
    int feeds_below;                 /* 1: a level of a hierarchy above another (rt_sim_set_below) */
} rt_sim_config;

/* One size's counters for one class (64-bit). */
typedef struct rt_sim_counts {
    uint64_t accesses;     /* line touches */
    uint64_t read_misses;  /* read touches that missed */
    uint64_t write_misses; /* write touches that missed */
    uint64_t writebacks;   /* dirty lines evicted (charged to the last writer's class) */
    uint64_t wt_bytes;     /* bytes written through / around the cache to memory */
    uint64_t traffic_bytes;/* (fetches + writebacks) * line + wt_bytes */
    uint64_t nofetch;      /* write misses that fetched nothing (write_miss_fullline) */
} rt_sim_counts;

/* Fills c with the paper's configuration: 13 sizes 1K..4M, 64-byte lines,
 * fully associative, write-back, write-allocate. */
void rt_sim_config_default(rt_sim_config *c);

/* Parses a size list: "1K-4M" (powers of two from..to), "1K,2K,64K", or a
 * single size. Returns 0, or -1 with a message. */
int rt_sim_parse_sizes(const char *s, rt_sim_config *c, rt_err *e);

/* Policy label used in the database: "wb-wa", "wb-nwa", "wt-wa", "wt-nwa",
 * followed by "+flush" (cfg.flush) and "+fullline" (write_miss_fullline)
 * when set, e.g. "wb-wa+flush+fullline"; the defaults keep the bare
 * labels, so rows of different accounting never share a label. */
const char *rt_sim_policy_name(const rt_sim_config *c);

/* Replacement policies (rt_sim_config.repl): "lru" (0, the default), and
 * the per-size engine's policies (engine.h): "fifo", ... rt_sim_repl_parse
 * sets *repl from a name: 0, or -1 with a message listing the names;
 * rt_sim_repl_name gives the name ("?" out of range). The replacement
 * policy is its own dimension, separate from the write policy label of
 * rt_sim_policy_name. */
int rt_sim_repl_parse(const char *name, int *repl, rt_err *e);
const char *rt_sim_repl_name(int repl);
/* 1 if policy repl makes random choices (so rt_sim_config.seed matters). */
int rt_sim_repl_random(int repl);
/* The names accepted, comma-separated ("lru,fifo,..."), for usage texts. */
const char *rt_sim_repl_list(void);

/* Checks a configuration: sizes increasing, each a multiple of
 * line * assoc (fully associative: of line), at least one set. 0 or -1. */
int rt_sim_config_check(const rt_sim_config *c, rt_err *e);

typedef struct rt_sim rt_sim;

/* Creates a simulator (cold caches). NULL on a bad configuration or out of
 * memory, with a message. Memory: about 48 bytes per line of the largest
 * cache (exact-stack) or per line of every size (exact-persize, 8 more
 * with a policy), or 12 bytes per line touch buffered (exact-opt). The
 * caller owns the result; rt_sim_free(NULL) is a no-op. */
rt_sim *rt_sim_new(const rt_sim_config *c, rt_err *e);
void rt_sim_free(rt_sim *s);

/* The configuration s was created with. */
const rt_sim_config *rt_sim_get_config(const rt_sim *s);
/* The engine's name (engine.h): "exact-stack" (one-pass msim) or
 * "exact-persize" (setassoc per size, any replacement policy). */
const char *rt_sim_engine(const rt_sim *s);
/* The seconds of an offline engine's phases in the last rt_sim_finish
 * (OPT: out[0] the backward next-use pass, out[1] the forward simulation);
 * 0, or -1 (out zero) for an engine without phases. For bench. */
int rt_sim_phases(const rt_sim *s, double out[2]);

/* Simulates n references. Never fails (returns 0); references with size 0
 * are treated as size 1. Class values >= RT_NCLASS are counted as RT_CLS_FB
 * ("other"), generations >= RT_MAXGEN-1 as RT_MAXGEN-1. */
int rt_sim_put(rt_sim *s, const rt_access *a, size_t n);

/* An rt_sink feeding s; owned by s, valid until rt_sim_free. */
rt_sink *rt_sim_sink(rt_sim *s);

/* Ends a simulation: with cfg.flush, every line still dirty in any size is
 * written back (counted in writebacks and traffic, charged to its last
 * writer's class and generation) and left clean and resident; without it
 * nothing happens for the online engines; OPT simulates here (its counters
 * are zero before). Call it after the last reference and before reading
 * results; more references may follow, and a second call writes back only
 * what they dirtied (OPT: simulates everything again from cold). Returns 0. */
int rt_sim_finish(rt_sim *s);

/* Makes s one level of a hierarchy (hier.h): every line it fetches, every
 * write-back and every byte written through or around becomes a reference
 * to below, in order, with the class and generation of its cause. Only a
 * one-size configuration of the per-size engine can (any replacement but
 * OPT); -1 with a message otherwise. below is borrowed. */
int rt_sim_set_below(rt_sim *s, rt_sink *below, rt_err *e);

/* References (rt_access records, not line touches) seen so far. */
uint64_t rt_sim_refs(const rt_sim *s);

/* Counters of size index i (0..nsizes-1) for class cls (0..RT_NCLASS-1),
 * summed over all generations, with traffic_bytes computed. Out-of-range
 * arguments give zeros. */
void rt_sim_get(const rt_sim *s, int i, int cls, rt_sim_counts *out);
/* Sum over the classes of a group (rt_group). */
void rt_sim_get_group(const rt_sim *s, int i, int group, rt_sim_counts *out);
/* The same restricted to generation gen (0..RT_MAXGEN-1; RT_MAXGEN-1 holds
 * every later generation too): misses of the generation's references and
 * the write-backs of lines it wrote last. Summed over gen they equal
 * rt_sim_get / rt_sim_get_group. gen out of range gives zeros. */
void rt_sim_get_gen(const rt_sim *s, int i, int cls, int gen, rt_sim_counts *out);
void rt_sim_get_group_gen(const rt_sim *s, int i, int group, int gen, rt_sim_counts *out);

/* Checks the simulator's internal invariants (stack markers, group sizes,
 * hash table, dirty bits, write-backs per (class, generation) bounded by
 * that pair's writes) and that, for every size and class, the
 * per-generation counters sum to the class counters. 0 if consistent, -1
 * with a message. Slow; for tests. */
int rt_sim_check(const rt_sim *s, rt_err *e);

/* ---- input files ------------------------------------------------------ */

enum { RT_SIM_IN_AUTO = 0, RT_SIM_IN_RTT = 1, RT_SIM_IN_DIN = 2 };

/* Guesses the format of a file from its first bytes: RT_SIM_IN_RTT,
 * RT_SIM_IN_DIN, or -1 (unreadable / unknown, with a message). */
int rt_sim_sniff(const char *path, rt_err *e);

/* What a replay learned about its input. */
typedef struct rt_sim_input {
    int format;          /* RT_SIM_IN_RTT or RT_SIM_IN_DIN */
    int has_meta;        /* 1 for .rtt (meta valid) */
    uint64_t refs;       /* references replayed */
    uint64_t file_bytes; /* size of the input */
    uint64_t file_hash;  /* 64-bit content hash (rt_tr_file_hash for .rtt,
                            FNV-1a of the bytes for din) */
    uint64_t repeats;    /* of refs, how many a repeat filter counted on the
                            reader thread instead of the sink (rt_sim_repeats) */
} rt_sim_input;

/* Replays a whole file through s. fmt is RT_SIM_IN_AUTO/RTT/DIN; din_class
 * is the class given to din records (RT_CLS_FB = "other" by default;
 * label 2, instruction fetch, is a read). If meta is non-NULL and the input
 * is .rtt, the header is copied there. Returns 0, or -1 with the reader's
 * message (file and position). On failure s holds a partial simulation. */
int rt_sim_replay(rt_sim *s, const char *path, int fmt, int din_class, rt_tr_meta *meta,
                  rt_sim_input *info, rt_err *e);
/* The same replay into any sink (rt_sim_sink, rt_approx_sink, a fan-out):
 * the one replay loop. A put that fails ends it with -1. */
int rt_sim_replay_sink(rt_sink *sink, const char *path, int fmt, int din_class, rt_tr_meta *meta,
                       rt_sim_input *info, rt_err *e);

/* Most threads rt_sim_replay_threads uses: one decodes, one simulates. */
#define RT_SIM_MAXTHREADS 2

/* rt_sim_replay_sink on nthreads threads (1..RT_SIM_MAXTHREADS; anything
 * else is an error). With 2, the file is decoded on a second thread while
 * the calling thread runs the sink, so the sink needs no locking; the
 * results, info, meta and messages are those of the one-thread replay,
 * the reader's error included (after the references decoded before it).
 * If the thread cannot be started, the replay runs on one thread. */
int rt_sim_replay_threads(rt_sink *sink, const char *path, int fmt, int din_class, int nthreads, rt_tr_meta *meta,
                          rt_sim_input *info, rt_err *e);

/*
 * Repeat filter. In a fully associative LRU cache with write-allocate, a
 * read that touches exactly one line, the line the previous reference
 * ended on, is a hit at the top of the recency stack in every cache size:
 * it changes no state, only the read-hit counts (about 30% of a k-d
 * tracer's references: neighbouring nodes share a line). A sink that
 * simulates only such caches may offer a filter; a two-thread replay then
 * drops those reads on the reader thread and hands the sink, with each
 * batch, their counts per (generation bucket, class), so the simulating
 * thread, the slower one, does less. Results are identical (tested).
 */
typedef struct rt_repeats {
    uint32_t line; /* the sink's line size in bytes; 0 = no filter */
    /* cnt[rt_gen_bucket(gen) * RT_NCLASS + class]: reads dropped */
    void (*add)(void *ctx, const uint64_t *cnt);
    void *ctx;
} rt_repeats;
/* s's filter: line 0 unless s is the one-pass fully associative
 * write-back write-allocate engine. */
void rt_sim_repeats(rt_sim *s, rt_repeats *out);
/* rt_sim_replay_threads with a repeat filter rp for sink (NULL, or line 0:
 * none; used only with two threads). */
int rt_sim_replay_filtered(rt_sink *sink, const rt_repeats *rp, const char *path, int fmt, int din_class,
                           int nthreads, rt_tr_meta *meta, rt_sim_input *info, rt_err *e);

#endif
