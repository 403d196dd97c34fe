/*
 * db.h -- the SQLite results database (module prefix rt_db_).
 *
 * One file (default raytraffic.db) holds scenes, runs (one per simulated
 * trace or in-process stream), cache configurations, per-class traffic
 * rows, for runs whose access stream carried ray generations (exact
 * simulation only) per-(class, generation) rows, and for approximate runs
 * that estimated their error (the hybrid method with errors on) the
 * standard errors per cache size; views give the paper's geometry / ray
 * traffic in MB (2^20 bytes), in all and per generation, and every run's
 * traffic per group beside its standard error (NULL where there is none).
 * The schema is documented in docs/database.md and created on first open
 * (PRAGMA user_version = RT_DB_SCHEMA_VERSION).
 *
 * Concurrency: WAL journal, 60 s busy timeout, every run stored in one
 * BEGIN IMMEDIATE ... COMMIT transaction, so several processes (a parallel
 * sweep) may write to the same file; a failed store leaves nothing behind.
 *
 * Identity: a run is identified by (scene name, scene params, scene hash,
 * tracer, W, H, lights, scheduled cache size, gmax, tracer params,
 * sim method, sim params, replacement policy, hierarchy, cores, light
 * model, instances). The last five (schema version 6) default to LRU, ''
 * (one level), 1, "point" and "flatten": a caller that leaves them unset
 * (NULL / 0) stores and finds the run every earlier version did. Storing a run whose key exists updates the run's
 * provenance and replaces its traffic rows for the cache configurations
 * being stored (rows of other configurations are kept); nothing is ever
 * duplicated.
 *
 * All functions return 0 (or a documented non-negative value) on success,
 * -1 on failure with one line in e naming the database path.
 */
#ifndef RT_DB_H
#define RT_DB_H

#include "rt.h"

#include <stdint.h>

#define RT_DB_SCHEMA_VERSION 8

typedef struct rt_db rt_db;

/* The identifying columns and provenance of one run. NULL strings are
 * stored as ''. */
typedef struct rt_db_run {
    /* identity (the runs table's UNIQUE key, through the scene) */
    const char *scene;        /* scene spec, e.g. "room" */
    const char *scene_params; /* canonical scene parameters */
    uint64_t scene_hash;      /* rt_scene_hash (stored as 16 hex digits) */
    const char *tracer;       /* "recursive", "packet", "dynamic", ..., "din" */
    int W, H;                 /* image size */
    uint32_t lights;          /* enabled-light mask */
    uint64_t sched_size;      /* cache size the trace was scheduled for (0 = n/a) */
    uint64_t gmax;            /* geometry budget (0 = n/a) */
    const char *params;       /* other tracer parameters "k=v k=v" */
    const char *sim_method;   /* "exact" (NULL = "exact"); later "sampled" ... */
    const char *sim_params;   /* parameters of the sim method ('' for exact) */
    const char *repl;         /* replacement policy (NULL = "lru"); the write policy is per configuration */
    const char *hierarchy;    /* canonical hierarchy spec (NULL = '': one level, the traffic rows) */
    int cores;                /* cores (0 = 1) */
    const char *light_model;  /* how lights are sampled (NULL = "point") */
    const char *instances;    /* how object instances are traced (NULL = "flatten") */
    /* provenance */
    uint32_t ntri;            /* scene triangles */
    uint64_t trace_hash;      /* content hash of the trace (0 = in-process stream) */
    uint64_t refs;            /* references simulated */
    const char *tool_version; /* NULL = rt_version() */
    const char *git_rev;      /* NULL = rt_git_rev() */
    const char *command;      /* command line */
    double wall_time;         /* seconds spent producing the results */
    const char *stats;        /* tracer statistics "k=v k=v" (rays, nodes, tests, ...) */
    /* where the scene's mesh file is (not identity: the content hash is;
     * '' = unknown or built-in, and '' never overwrites a known place) */
    const char *scene_path;    /* as given on the command line, e.g. "a/mesh.obj" */
    const char *scene_abspath; /* resolved absolute path, used to re-render it */
} rt_db_run;

/* One traffic row: counters of one class in one cache configuration. */
typedef struct rt_db_traffic {
    uint64_t size;          /* cache size, bytes */
    uint32_t line;          /* line size, bytes */
    uint32_t assoc;         /* ways, 0 = fully associative */
    const char *policy;     /* "wb-wa", "wb-nwa", "wt-wa", "wt-nwa" */
    int cls;                /* rt_class */
    uint64_t accesses;      /* line touches */
    uint64_t read_misses;   /* read touches that missed */
    uint64_t write_misses;  /* write touches that missed */
    uint64_t writebacks;    /* dirty evictions charged to this class */
    uint64_t wt_bytes;      /* write-through / write-around bytes */
    uint64_t traffic_bytes; /* (fetches + writebacks) * line + wt_bytes */
} rt_db_traffic;

/* One per-generation row: the counters of class t.cls in configuration
 * (t.size, t.line, t.assoc, t.policy) restricted to the references of ray
 * generation gen (rt_sim_get_gen). t.wt_bytes is not stored (it is part of
 * t.traffic_bytes). Summed over gen they equal the run's traffic row. */
typedef struct rt_db_gen {
    rt_db_traffic t; /* configuration, class and counters */
    int gen;         /* generation bucket 0..RT_MAXGEN-1 (the last one pools later generations) */
} rt_db_gen;

/* One standard-error row of an approximate run (table traffic_se): the
 * estimated standard errors, in bytes, of the traffic estimate of one
 * cache configuration summed over the classes of each group (se[g], g in
 * rt_group order: geometry, ray, other) and over all classes (se[3]; not
 * a sum of the others), as rt_approx_traffic_se gives them. A negative
 * value means the estimator has none for that sum: stored as NULL. */
#define RT_DB_SE_N 4
typedef struct rt_db_se {
    uint64_t size;         /* cache size, bytes */
    uint32_t line;         /* line size, bytes */
    uint32_t assoc;        /* ways, 0 = fully associative */
    const char *policy;    /* "wb-wa", ... (NULL = "wb-wa") */
    double se[RT_DB_SE_N]; /* geometry, ray, other, all classes; bytes, < 0 = none */
} rt_db_se;

/* One per-level row (table level_traffic) of a run simulated through a
 * cache hierarchy: the counters of class cls at one level (of one core's
 * private cache, or of a shared level) restricted to generation gen (-1:
 * all generations). The level's configuration is (level, core, size,
 * line, assoc, policy, repl, last_size); a store replaces the run's old
 * rows of every level configuration it stores. An inclusive or exclusive
 * hierarchy runs one chain of levels per last-level size (cachesim/incl.h):
 * its rows carry the chain's last-level size (last_size) and the level's
 * back-invalidations and their write-backs; a non-inclusive one has
 * last_size 0 (its upper levels do not depend on the last level) and
 * zeros there (schema version 8; older files read so). traffic_bytes is what the level moves to
 * the level below it (fetches and write-backs, in bytes); the traffic
 * table keeps holding what reaches memory. */
typedef struct rt_db_level {
    int level;              /* 1 = nearest the core, 2, ... */
    const char *level_name; /* "L1", "L2", ... (NULL = '') */
    int core;               /* core of a private cache; -1 = shared / all cores */
    uint64_t size;          /* cache size, bytes */
    uint32_t line;          /* line size, bytes (> 0) */
    uint32_t assoc;         /* ways, 0 = fully associative */
    const char *policy;     /* write policy (NULL = "wb-wa") */
    const char *repl;       /* replacement policy (NULL = "lru") */
    int cls;                /* rt_class */
    int gen;                /* generation 0..RT_MAXGEN-1, -1 = all */
    uint64_t accesses;      /* line touches reaching this level */
    uint64_t misses;        /* of them, misses (<= accesses) */
    uint64_t writebacks;    /* dirty evictions out of this level */
    uint64_t traffic_bytes; /* bytes moved to the level below */
    uint64_t last_size;     /* inclusive/exclusive: the last level's size of this row's chain; 0 = none */
    uint64_t backinvals;    /* lines this level lost to a back-invalidation (inclusive) */
    uint64_t bi_writebacks; /* of them, dirty ones written down first */
} rt_db_level;

/* Everything stored with one run: its traffic rows, its per-generation
 * rows (exact runs whose stream carried generations) and its
 * standard-error rows (approximate runs with errors). Rows of one
 * configuration are adjacent in each array; any array may be empty. */
typedef struct rt_db_rows {
    const rt_db_traffic *traffic; /* per (configuration, class) */
    size_t ntraffic;
    const rt_db_gen *gen;         /* per (configuration, class, generation) */
    size_t ngen;
    const rt_db_se *se;           /* per configuration */
    size_t nse;
    const rt_db_level *level;     /* per (level configuration, class, generation); schema version 6 */
    size_t nlevel;
} rt_db_rows;

/* Opens (creating if needed) the database at path and ensures the schema.
 * A version-1 to -6 file is upgraded to RT_DB_SCHEMA_VERSION in place, in
 * one transaction. Safe for many processes opening a new file at once
 * (lock conflicts while creating it are waited out, up to 2 minutes). Fails with "PATH: message", leaving the file untouched, if
 * it cannot be created or written, is not a SQLite database, has a newer
 * schema version, or is an unrelated SQLite file (schema version 0 with
 * tables of its own, or a known version without raytraffic's tables or
 * with tables the statements do not compile against): all checked before
 * anything is written (no WAL switch, no upgrade). An older raytraffic
 * refuses a file of this version (newer than it supports). path is a file name,
 * never an SQLite URI ("file:x.db?mode=memory" is a file of that name).
 * Before SQLite sees it, path goes through rt_open_target's database rule
 * (src/outfile.h): ":memory:", "" and names beginning with ':' are refused
 * with e->usage set, and so is (without usage) anything but a regular file
 * or an absent one in an existing folder: a FIFO, a device, a folder. */
rt_db *rt_db_open(const char *path, rt_err *e);

/* Opens the database at path read-only, for reading it whole (db merge,
 * report), and returns the handle (*ph, an sqlite3 *; sqlite3_close it)
 * and its schema version (*ver). The file is never changed and nothing is
 * created beside it: without a "-wal" or "-journal" file beside it, it is
 * opened as immutable (SQLite creates no "-shm" or "-wal", and a read-only
 * folder or file system is fine); with one, read-only with the log
 * applied (a hot rollback journal is then refused, not ignored). It must
 * not be written while read. Each refusal says which it is:
 *   usage (e->usage):  ":memory:", "", names beginning with ':';
 *   "unreadable":      absent, not a regular file (FIFO, device, folder),
 *                      or no read permission;
 *   "read-only":       an unfinished write-ahead log that cannot be
 *                      replayed because the folder is not writable;
 *   "malformed":       an SQLite file that is truncated (shorter than its
 *                      header's page count) or damaged;
 *   "not a raytraffic database": not an SQLite file, or one without the
 *                      runs and scenes tables (schema version < 1);
 *   "newer":           a schema version above RT_DB_SCHEMA_VERSION.
 * 0, or -1 with "PATH: ..." in e. */
int rt_db_open_read(const char *path, void **ph, int *ver, rt_err *e);
void rt_db_close_read(void *h); /* sqlite3_close; NULL is fine */

/* The message class of an SQLite error code met while reading a database
 * (rt_db_open_read's words): "malformed database" for SQLITE_CORRUPT, "not
 * an SQLite database" for SQLITE_NOTADB, else "cannot read database". */
const char *rt_db_read_error_kind(int sqlite_rc);
void rt_db_close(rt_db *db); /* NULL is fine */

/* 1 if a run with this key has been stored, 0 if not, -1 on error. Only
 * the identity fields of key are used. */
int rt_db_has_run(rt_db *db, const rt_db_run *key, rt_err *e);

/* Which of the n cache sizes the run with this key has traffic rows for,
 * in the configuration (size, line, assoc, policy): have[i] = 1 or 0. A
 * missing run has none. Returns the number of sizes missing (0..n), or -1.
 * For a rerun of a sweep with other --sizes or --line: what is missing is
 * simulated and stored into the same run. */
int rt_db_missing_sizes(rt_db *db, const rt_db_run *key, const uint64_t *sizes, int n, uint32_t line, uint32_t assoc,
                        const char *policy, int *have, rt_err *e);

/* Stores run and its n traffic rows in one transaction. On success returns
 * 0 and, if run_id is non-NULL, the run's id. On failure nothing of this
 * store is left in the database. */
int rt_db_store_run(rt_db *db, const rt_db_run *run, const rt_db_traffic *rows, size_t n, int64_t *run_id,
                    rt_err *e);
/* The same with ng per-generation rows (table traffic_gen). For every
 * configuration in rows the run's old traffic and generation rows are
 * replaced (a run stored again without generations keeps none); for every
 * configuration in grows its old generation rows are. rt_db_store_run is
 * this with ng = 0. */
int rt_db_store_run_gen(rt_db *db, const rt_db_run *run, const rt_db_traffic *rows, size_t n, const rt_db_gen *grows,
                        size_t ng, int64_t *run_id, rt_err *e);
/* The general store, of which the two above are cases: for every
 * configuration in rows->traffic the run's old traffic, generation and
 * standard-error rows are replaced (a run stored again without errors
 * keeps none for those configurations); for every configuration in
 * rows->gen its old generation rows are, in rows->se its old
 * standard-error rows, and for every level configuration in rows->level
 * its old level rows are (a level row with a bad class, level < 1,
 * core < -1, generation out of range, line 0 or more misses than
 * accesses is refused). A standard error that is not a finite number is
 * refused, and so is one of a configuration the run has no traffic rows
 * for (nothing stored). Same returns. */
int rt_db_store(rt_db *db, const rt_db_run *run, const rt_db_rows *rows, int64_t *run_id, rt_err *e);

/* Copies every run of the database at inpath (with its scene, provenance,
 * statistics, traffic rows, generation rows and standard-error rows) into
 * out through rt_db_store: a run whose key is already in out is replaced,
 * never duplicated; each run in its own transaction. inpath is opened
 * read-only and never written. It must be a raytraffic database of schema version 1
 * to 6 (level rows copied too); a newer version, a foreign file, or a value that is not a
 * non-negative integer where a count belongs (negative counts, text; a
 * generation outside 0..RT_MAXGEN-1), or a standard error that is neither
 * NULL nor a non-negative number, is refused with a message naming inpath and the
 * offending run / traffic row / generation row / standard-error row, and nothing of that run is
 * stored (runs copied before it stay). Returns 0 and the runs copied in
 * *nruns, or -1. */
int rt_db_merge(rt_db *out, const char *inpath, long *nruns, rt_err *e);

/* The schema (tables, views) as SQL, for docs and tests. */
const char *rt_db_schema_sql(void);

/* The underlying sqlite3 handle (for reports and tests; type-erased). */
void *rt_db_handle(rt_db *db);

/* Test hook: when > 0, the n-th traffic row insert of a store fails
 * (counts down; 0 disables), exercising the rollback path. */
extern long rt_db_fail_row_after;

#endif
