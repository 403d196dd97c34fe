/*
 * db.c -- the SQLite results database (see db.h and docs/database.md).
 *
 * The schema lives in one string below (documented column by column in
 * docs/database.md). Version 7; older files are upgraded in place when
 * opened, one step after the other in one transaction (the views dropped
 * first and created again last; migrate_v1: the sched_size rename;
 * migrate_v2: where a mesh scene was found; 3 -> 4: the per-generation
 * table traffic_gen and its view v_gen; 4 -> 5: the standard errors of
 * approximate runs, table traffic_se and view v_traffic_se; migrate_v5:
 * the run's new dimensions repl, hierarchy, cores, light_model and
 * instances in its key, the per-level table level_traffic and its view
 * v_level; migrate_v6: runs.stats_json, the statistics as a JSON object,
 * parsed from the old stats text where it parses, NULL where not;
 * migrate_v7: level_traffic gains last_size, backinvals and
 * bi_writebacks, the chain's last-level size part of its UNIQUE key). Unsigned 64-bit hashes are stored as 16 lowercase hex
 * digits, counters as INTEGER (they stay far below 2^63), standard errors
 * as REAL (bytes, NULL = none).
 *
 * Standard errors: an approximate run that estimated its own error (the
 * hybrid method with errors on; "errors=1" in its sim_params, so it never
 * shares a key with one that did not) has one traffic_se row per cache
 * configuration it has traffic rows for, holding the standard error of
 * the traffic summed over each class group and over all classes. A
 * standard error does not sum over groups (the groups' estimates are
 * correlated), hence a column per group and one for the whole. Every other
 * run (exact, other methods, --no-error) has no traffic_se rows; the view
 * v_traffic_se shows NULL for them. Invariant: a traffic_se row's (run,
 * configuration) has traffic rows (a store replaces both together).
 *
 * Names: sched_size is the cache size a dynamic trace was *scheduled* for
 * (a property of the run); cache_size (views) and cache_configs.size are
 * the *simulated* size. Version 1 called the former sched_cache_size; that
 * name survives only as a read-only alias (a generated column of runs and
 * a column of v_paper) so queries written against version 1 keep working.
 *
 * Opening is race-free for processes starting together on a file that does
 * not exist yet: the busy timeout is set first, the switch to WAL (which
 * needs the file to itself and may answer SQLITE_BUSY without waiting) and
 * the schema transaction (BEGIN IMMEDIATE, version re-read under the lock)
 * are retried on SQLITE_BUSY with a bounded exponential backoff.
 */
#include "db.h"
#include "memmodel.h"
#include "outfile.h"
#include "stats.h"

#include <ctype.h>
#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <sqlite3.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

long rt_db_fail_row_after = 0;

_Static_assert(RT_DB_SE_N == RT_NGROUP + 1, "rt_db_se holds one error per group and one for all classes");

/* Room for a run's stats as JSON (the text is at most ~900 bytes, each
 * token grows by at most 8). */
#define RT_DB_STATS_JSON_MAX 4096

/* Version 1's name of sched_size, kept as a generated read-only alias
 * (last column of runs but stats_json, which version 7 appended, so fresh
 * and upgraded files have the same layout). */
#define SCHED_ALIAS "sched_cache_size INTEGER GENERATED ALWAYS AS (sched_size) VIRTUAL"

/* The runs table, as created fresh and as the version 5 -> 6 upgrade
 * rebuilds it (its UNIQUE key gains the new dimensions, which SQLite
 * cannot add to an existing table); NAME is "runs" or the rebuild's
 * temporary name. */
#define RUNS_TABLE(NAME) \
    "CREATE TABLE IF NOT EXISTS " NAME "(\n" \
    "  id INTEGER PRIMARY KEY,\n" \
    "  scene_id INTEGER NOT NULL REFERENCES scenes(id),\n" \
    "  tracer TEXT NOT NULL,\n" \
    "  W INTEGER NOT NULL,\n" \
    "  H INTEGER NOT NULL,\n" \
    "  lights INTEGER NOT NULL,            -- enabled-light mask (bit i = light i; 0 = none)\n" \
    "  sched_size INTEGER NOT NULL DEFAULT 0, -- cache size the trace was scheduled for (0 = n/a)\n" \
    "  gmax INTEGER NOT NULL DEFAULT 0,    -- geometry budget (0 = n/a)\n" \
    "  params TEXT NOT NULL DEFAULT '',    -- other tracer parameters\n" \
    "  sim_method TEXT NOT NULL DEFAULT 'exact',\n" \
    "  sim_params TEXT NOT NULL DEFAULT '',\n" \
    "  trace_hash TEXT NOT NULL DEFAULT '', -- 16 hex digits; '' for in-process streams\n" \
    "  refs INTEGER NOT NULL DEFAULT 0,    -- references simulated\n" \
    "  tool_version TEXT NOT NULL DEFAULT '',\n" \
    "  git_rev TEXT NOT NULL DEFAULT '',\n" \
    "  command TEXT NOT NULL DEFAULT '',\n" \
    "  wall_time REAL NOT NULL DEFAULT 0,  -- seconds\n" \
    "  stats TEXT NOT NULL DEFAULT '',     -- tracer statistics, k=v k=v\n" \
    "  created TEXT NOT NULL DEFAULT (strftime('%Y-%m-%dT%H:%M:%SZ','now')),\n" \
    "  repl TEXT NOT NULL DEFAULT 'lru',   -- replacement policy (the write policy is cache_configs.policy)\n" \
    "  hierarchy TEXT NOT NULL DEFAULT '', -- canonical hierarchy spec ('' = one level)\n" \
    "  cores INTEGER NOT NULL DEFAULT 1,   -- cores sharing the hierarchy's last level\n" \
    "  light_model TEXT NOT NULL DEFAULT 'point', -- how lights are sampled\n" \
    "  instances TEXT NOT NULL DEFAULT 'flatten', -- how object instances are traced\n" \
    "  " SCHED_ALIAS ",\n" \
    "  stats_json TEXT,                   -- stats as a JSON object (NULL: old text that does not parse)\n" \
    "  UNIQUE(scene_id, tracer, W, H, lights, sched_size, gmax, params, sim_method, sim_params, repl, hierarchy,\n" \
    "         cores, light_model, instances));\n"

/* The structure a run was traced on, from its key: the word after
 * "accel=" ('' = the tracer's default, the k-d tree for the paper's
 * tracers). */
#define ACCEL_EXPR                                                                                                   \
    "CASE WHEN instr(r.params, 'accel=') > 0 THEN substr(substr(r.params, instr(r.params, 'accel=') + 6), 1,"        \
    " instr(substr(r.params, instr(r.params, 'accel=') + 6) || ' ', ' ') - 1) ELSE '' END"

/* A light mask as names: bit i is light i, "0+2" for lights 0 and 2
 * (lights 0..7; 0 = "none"). */
/* the inclusion of a run's hierarchy: '' (no hierarchy), nine, inclusive, exclusive */
#define INCLUSION_EXPR                                                                                               \
    "CASE WHEN r.hierarchy = '' THEN '' WHEN r.hierarchy LIKE '%,inclusive' THEN 'inclusive'"                        \
    " WHEN r.hierarchy LIKE '%,exclusive' THEN 'exclusive' ELSE 'nine' END"
#define LIGHT_BITS "CASE WHEN r.lights & 1 THEN '+0' ELSE '' END || CASE WHEN r.lights & 2 THEN '+1' ELSE '' END || CASE WHEN r.lights & 4 THEN '+2' ELSE '' END || CASE WHEN r.lights & 8 THEN '+3' ELSE '' END || CASE WHEN r.lights & 16 THEN '+4' ELSE '' END || CASE WHEN r.lights & 32 THEN '+5' ELSE '' END || CASE WHEN r.lights & 64 THEN '+6' ELSE '' END || CASE WHEN r.lights & 128 THEN '+7' ELSE '' END"

static const char schema_sql[] =
    "CREATE TABLE IF NOT EXISTS scenes(\n"
    "  id INTEGER PRIMARY KEY,\n"
    "  name TEXT NOT NULL,                 -- scene spec (built-in name or file)\n"
    "  params TEXT NOT NULL DEFAULT '',    -- canonical scene parameters\n"
    "  hash TEXT NOT NULL,                 -- rt_scene_hash, 16 hex digits\n"
    "  triangles INTEGER NOT NULL DEFAULT 0,\n"
    "  path TEXT NOT NULL DEFAULT '',      -- mesh file as given on the command line ('' built-in)\n"
    "  abspath TEXT NOT NULL DEFAULT '',   -- that file's absolute path, where it was last seen\n"
    "  UNIQUE(name, params, hash));\n"
    RUNS_TABLE("runs")
    "CREATE TABLE IF NOT EXISTS cache_configs(\n"
    "  id INTEGER PRIMARY KEY,\n"
    "  size INTEGER NOT NULL,              -- bytes\n"
    "  line INTEGER NOT NULL,              -- bytes\n"
    "  assoc INTEGER NOT NULL,             -- ways; 0 = fully associative\n"
    "  policy TEXT NOT NULL,               -- wb-wa | wb-nwa | wt-wa | wt-nwa\n"
    "  UNIQUE(size, line, assoc, policy));\n"
    "CREATE TABLE IF NOT EXISTS classes(\n"
    "  name TEXT PRIMARY KEY,              -- memory-model class\n"
    "  grp TEXT NOT NULL);                 -- geometry | ray | other\n"
    "CREATE TABLE IF NOT EXISTS traffic(\n"
    "  run_id INTEGER NOT NULL REFERENCES runs(id) ON DELETE CASCADE,\n"
    "  config_id INTEGER NOT NULL REFERENCES cache_configs(id),\n"
    "  class TEXT NOT NULL REFERENCES classes(name),\n"
    "  accesses INTEGER NOT NULL,          -- line touches\n"
    "  read_misses INTEGER NOT NULL,\n"
    "  write_misses INTEGER NOT NULL,\n"
    "  writebacks INTEGER NOT NULL,\n"
    "  wt_bytes INTEGER NOT NULL DEFAULT 0, -- write-through / write-around bytes\n"
    "  traffic_bytes INTEGER NOT NULL,     -- (fetches + writebacks) * line + wt_bytes\n"
    "  UNIQUE(run_id, config_id, class));\n"
    "CREATE INDEX IF NOT EXISTS traffic_config ON traffic(config_id);\n"
    "CREATE VIEW IF NOT EXISTS v_traffic_group AS\n"
    "  SELECT t.run_id, t.config_id, c.size AS cache_size, c.line, c.assoc, c.policy,\n"
    "    SUM(CASE WHEN k.grp = 'geometry' THEN t.traffic_bytes ELSE 0 END) / 1048576.0 AS geometry_mb,\n"
    "    SUM(CASE WHEN k.grp = 'ray' THEN t.traffic_bytes ELSE 0 END) / 1048576.0 AS ray_mb,\n"
    "    SUM(CASE WHEN k.grp = 'other' THEN t.traffic_bytes ELSE 0 END) / 1048576.0 AS other_mb,\n"
    "    SUM(t.traffic_bytes) / 1048576.0 AS total_mb\n"
    "  FROM traffic t JOIN cache_configs c ON c.id = t.config_id JOIN classes k ON k.name = t.class\n"
    "  GROUP BY t.run_id, t.config_id;\n"
    "CREATE VIEW IF NOT EXISTS v_paper AS\n"
    "  SELECT s.name AS scene, r.tracer, r.lights, r.W, r.H, r.sched_size, g.cache_size,\n"
    "    g.geometry_mb, g.ray_mb, r.sched_size AS sched_cache_size,\n"
    "    s.params AS scene_params, " ACCEL_EXPR " AS accel, r.sim_params, r.params, r.id AS run_id\n"
    "  FROM v_traffic_group g JOIN runs r ON r.id = g.run_id JOIN scenes s ON s.id = r.scene_id\n"
    "  WHERE g.line = 64 AND g.assoc = 0 AND g.policy = 'wb-wa' AND r.sim_method = 'exact'\n"
    "    AND r.params NOT LIKE '%subsample=%';\n"
    "CREATE TABLE IF NOT EXISTS traffic_gen(\n"
    "  run_id INTEGER NOT NULL REFERENCES runs(id) ON DELETE CASCADE,\n"
    "  config_id INTEGER NOT NULL REFERENCES cache_configs(id),\n"
    "  class TEXT NOT NULL REFERENCES classes(name),\n"
    "  gen INTEGER NOT NULL,               -- ray generation 0..7 (7: 7 and later)\n"
    "  accesses INTEGER NOT NULL,          -- line touches of this generation's references\n"
    "  read_misses INTEGER NOT NULL,\n"
    "  write_misses INTEGER NOT NULL,\n"
    "  writebacks INTEGER NOT NULL,        -- of lines this generation wrote last\n"
    "  traffic_bytes INTEGER NOT NULL,\n"
    "  UNIQUE(run_id, config_id, class, gen));\n"
    "CREATE VIEW IF NOT EXISTS v_gen AS\n"
    "  SELECT r.id AS run_id, s.name AS scene, r.tracer, r.lights, r.W, r.H,\n"
    "    CASE WHEN r.params LIKE '%mode=whitted%' THEN 'whitted' WHEN r.params LIKE '%mode=path%' THEN 'path'\n"
    "      WHEN r.params LIKE '%mode=raycast%' OR (r.lights = 0 AND r.params NOT LIKE '%mode=%') THEN 'raycast'\n"
    "      ELSE 'shadow' END AS mode,\n"
    "    r.params, r.sched_size, c.size AS cache_size, t.gen,\n"
    "    SUM(CASE WHEN k.grp = 'geometry' THEN t.traffic_bytes ELSE 0 END) / 1048576.0 AS geometry_mb,\n"
    "    SUM(CASE WHEN k.grp = 'ray' THEN t.traffic_bytes ELSE 0 END) / 1048576.0 AS ray_mb,\n"
    "    SUM(CASE WHEN k.grp = 'other' THEN t.traffic_bytes ELSE 0 END) / 1048576.0 AS other_mb,\n"
    "    SUM(t.traffic_bytes) / 1048576.0 AS total_mb\n"
    "  FROM traffic_gen t JOIN cache_configs c ON c.id = t.config_id JOIN classes k ON k.name = t.class\n"
    "    JOIN runs r ON r.id = t.run_id JOIN scenes s ON s.id = r.scene_id\n"
    "  WHERE c.line = 64 AND c.assoc = 0 AND c.policy = 'wb-wa' AND r.sim_method = 'exact'\n"
    "    AND r.params NOT LIKE '%subsample=%'\n"
    "  GROUP BY t.run_id, t.config_id, t.gen;\n"
    "CREATE TABLE IF NOT EXISTS traffic_se(\n"
    "  run_id INTEGER NOT NULL REFERENCES runs(id) ON DELETE CASCADE,\n"
    "  config_id INTEGER NOT NULL REFERENCES cache_configs(id),\n"
    "  geometry_se REAL,                   -- bytes: standard error of the geometry classes' traffic estimate\n"
    "  ray_se REAL,                        -- bytes: of the ray classes' (NULL: the estimator has none)\n"
    "  other_se REAL,                      -- bytes: of the other classes'\n"
    "  total_se REAL,                      -- bytes: of all classes' traffic (not a sum of the three)\n"
    "  UNIQUE(run_id, config_id));\n"
    "CREATE VIEW IF NOT EXISTS v_traffic_se AS\n"
    "  SELECT g.run_id, g.config_id, r.sim_method, g.cache_size, g.line, g.assoc, g.policy,\n"
    "    g.geometry_mb, e.geometry_se / 1048576.0 AS geometry_se_mb, g.ray_mb, e.ray_se / 1048576.0 AS ray_se_mb,\n"
    "    g.other_mb, e.other_se / 1048576.0 AS other_se_mb, g.total_mb, e.total_se / 1048576.0 AS total_se_mb\n"
    "  FROM v_traffic_group g JOIN runs r ON r.id = g.run_id\n"
    "    LEFT JOIN traffic_se e ON e.run_id = g.run_id AND e.config_id = g.config_id;\n"
    "CREATE VIEW IF NOT EXISTS v_runs AS\n"
    "  SELECT r.id AS run_id, s.name AS scene, s.params AS scene_params, s.hash AS scene_hash, r.tracer,\n"
    "    " ACCEL_EXPR " AS accel, r.W, r.H, r.lights,\n"
    "    CASE WHEN r.lights = 0 THEN 'none' ELSE ltrim(" LIGHT_BITS ", '+') END AS light_names,\n"
    "    CASE WHEN r.params LIKE '%mode=whitted%' THEN 'whitted' WHEN r.params LIKE '%mode=path%' THEN 'path'\n"
    "      WHEN r.params LIKE '%mode=raycast%' OR (r.lights = 0 AND r.params NOT LIKE '%mode=%') THEN 'raycast'\n"
    "      ELSE 'shadow' END AS mode,\n"
    "    CASE WHEN r.params LIKE '%subsample=%' THEN 'subsample' ELSE 'full' END AS proxy,\n"
    "    CASE WHEN r.sim_params LIKE 'model=%' THEN substr(r.sim_params, 7, instr(r.sim_params || ' ', ' ') - 7)\n"
    "      WHEN r.sim_method = 'exact' THEN 'lean' ELSE '' END AS model,\n"
    "    r.sim_method, r.sim_params, r.sched_size, r.gmax, r.repl, r.hierarchy, r.cores, r.light_model,\n"
    "    r.instances, r.params, r.refs, r.git_rev, r.created, r.command, r.stats_json\n"
    "  FROM runs r JOIN scenes s ON s.id = r.scene_id;\n"
    "CREATE TABLE IF NOT EXISTS level_traffic(\n"
    "  run_id INTEGER NOT NULL REFERENCES runs(id) ON DELETE CASCADE,\n"
    "  level INTEGER NOT NULL,             -- 1 = nearest the core, 2, ... (memory side last)\n"
    "  level_name TEXT NOT NULL DEFAULT '', -- e.g. L1, L2\n"
    "  core INTEGER NOT NULL DEFAULT -1,   -- core of a private cache; -1 = shared / all cores\n"
    "  cache_size INTEGER NOT NULL,        -- bytes\n"
    "  line INTEGER NOT NULL,              -- bytes\n"
    "  assoc INTEGER NOT NULL,             -- ways; 0 = fully associative\n"
    "  policy TEXT NOT NULL DEFAULT 'wb-wa', -- write policy of this level\n"
    "  repl TEXT NOT NULL DEFAULT 'lru',   -- replacement policy of this level\n"
    "  class TEXT NOT NULL REFERENCES classes(name),\n"
    "  gen INTEGER NOT NULL DEFAULT -1,    -- ray generation 0..7; -1 = all generations\n"
    "  accesses INTEGER NOT NULL,          -- line touches reaching this level\n"
    "  misses INTEGER NOT NULL,            -- of them, misses (read and write)\n"
    "  writebacks INTEGER NOT NULL,        -- dirty evictions out of this level\n"
    "  traffic_bytes INTEGER NOT NULL,     -- bytes this level moves to the level below it\n"
    "  last_size INTEGER NOT NULL DEFAULT 0, -- inclusive/exclusive: the chain's last-level size; 0 = none\n"
    "  backinvals INTEGER NOT NULL DEFAULT 0, -- lines lost to back-invalidation (inclusive)\n"
    "  bi_writebacks INTEGER NOT NULL DEFAULT 0, -- of them, dirty ones written down first\n"
    "  UNIQUE(run_id, level, core, cache_size, line, assoc, policy, repl, class, gen, last_size));\n"
    "CREATE VIEW IF NOT EXISTS v_level AS\n"
    "  SELECT l.run_id, s.name AS scene, s.params AS scene_params, r.tracer, r.W, r.H, r.lights, r.hierarchy,\n"
    "    r.cores, r.light_model, r.instances, r.sim_method, l.level, l.level_name, l.core, l.cache_size, l.line,\n"
    "    l.assoc, l.policy, l.repl, l.gen,\n"
    "    " INCLUSION_EXPR " AS inclusion, l.last_size,\n"
    "    SUM(CASE WHEN k.grp = 'geometry' THEN l.traffic_bytes ELSE 0 END) AS geometry_bytes,\n"
    "    SUM(CASE WHEN k.grp = 'ray' THEN l.traffic_bytes ELSE 0 END) AS ray_bytes,\n"
    "    SUM(CASE WHEN k.grp = 'other' THEN l.traffic_bytes ELSE 0 END) AS other_bytes,\n"
    "    SUM(l.traffic_bytes) AS total_bytes, SUM(l.accesses) AS accesses, SUM(l.misses) AS misses,\n"
    "    SUM(l.writebacks) AS writebacks, SUM(l.backinvals) AS backinvals, SUM(l.bi_writebacks) AS bi_writebacks\n"
    "  FROM level_traffic l JOIN classes k ON k.name = l.class JOIN runs r ON r.id = l.run_id\n"
    "    JOIN scenes s ON s.id = r.scene_id\n"
    "  GROUP BY l.run_id, l.level, l.core, l.cache_size, l.line, l.assoc, l.policy, l.repl, l.gen, l.last_size;\n";

struct rt_db {
    sqlite3 *h;        /* connection */
    char *path;        /* for messages */
    sqlite3_stmt *st[20]; /* prepared statements, see enum (S_NSTMT of them) */
    int busy;          /* the last failure was SQLITE_BUSY / SQLITE_LOCKED (open retries it) */
};

enum {
    S_SCENE_INS, S_SCENE_GET, S_SCENE_TRI, S_RUN_GET, S_RUN_INS, S_RUN_UPD, S_CFG_INS, S_CFG_GET, S_TR_DEL,
    S_TR_INS, S_GEN_DEL, S_GEN_INS, S_SE_DEL, S_SE_INS, S_TR_HAS, S_LV_DEL, S_LV_INS, S_NSTMT
};
_Static_assert(S_NSTMT <= 20, "struct rt_db holds 20 statements");

static const char *const stmt_sql[S_NSTMT] = {
    "INSERT OR IGNORE INTO scenes(name, params, hash, triangles) VALUES(?1, ?2, ?3, ?4)",
    "SELECT id FROM scenes WHERE name = ?1 AND params = ?2 AND hash = ?3",
    "UPDATE scenes SET triangles = CASE WHEN ?2 > 0 THEN ?2 ELSE triangles END,"
    " path = CASE WHEN ?4 <> '' THEN ?3 ELSE path END, abspath = CASE WHEN ?4 <> '' THEN ?4 ELSE abspath END"
    " WHERE id = ?1",
    "SELECT r.id FROM runs r JOIN scenes s ON s.id = r.scene_id WHERE s.name = ?1 AND s.params = ?2 AND s.hash = ?3"
    " AND r.tracer = ?4 AND r.W = ?5 AND r.H = ?6 AND r.lights = ?7 AND r.sched_size = ?8 AND r.gmax = ?9"
    " AND r.params = ?10 AND r.sim_method = ?11 AND r.sim_params = ?12 AND r.repl = ?13 AND r.hierarchy = ?14"
    " AND r.cores = ?15 AND r.light_model = ?16 AND r.instances = ?17",
    "INSERT INTO runs(scene_id, tracer, W, H, lights, sched_size, gmax, params, sim_method, sim_params,"
    " repl, hierarchy, cores, light_model, instances,"
    " trace_hash, refs, tool_version, git_rev, command, wall_time, stats, stats_json)"
    " VALUES(?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11, ?12, ?13, ?14, ?15, ?16, ?17, ?18, ?19, ?20, ?21,"
    " ?22, ?23)",
    "UPDATE runs SET trace_hash = ?2, refs = ?3, tool_version = ?4, git_rev = ?5, command = ?6, wall_time = ?7,"
    " stats = ?8, stats_json = ?9, created = strftime('%Y-%m-%dT%H:%M:%SZ','now') WHERE id = ?1",
    "INSERT OR IGNORE INTO cache_configs(size, line, assoc, policy) VALUES(?1, ?2, ?3, ?4)",
    "SELECT id FROM cache_configs WHERE size = ?1 AND line = ?2 AND assoc = ?3 AND policy = ?4",
    "DELETE FROM traffic WHERE run_id = ?1 AND config_id = ?2",
    "INSERT INTO traffic(run_id, config_id, class, accesses, read_misses, write_misses, writebacks, wt_bytes,"
    " traffic_bytes) VALUES(?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9)",
    "DELETE FROM traffic_gen WHERE run_id = ?1 AND config_id = ?2",
    "INSERT INTO traffic_gen(run_id, config_id, class, accesses, read_misses, write_misses, writebacks, gen,"
    " traffic_bytes) VALUES(?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9)",
    "DELETE FROM traffic_se WHERE run_id = ?1 AND config_id = ?2",
    "INSERT INTO traffic_se(run_id, config_id, geometry_se, ray_se, other_se, total_se) VALUES(?1, ?2, ?3, ?4, ?5, ?6)",
    "SELECT 1 FROM traffic WHERE run_id = ?1 AND config_id = ?2 LIMIT 1",
    "DELETE FROM level_traffic WHERE run_id = ?1 AND level = ?2 AND core = ?3 AND cache_size = ?4 AND line = ?5"
    " AND assoc = ?6 AND policy = ?7 AND repl = ?8 AND last_size = ?9",
    "INSERT INTO level_traffic(run_id, level, level_name, core, cache_size, line, assoc, policy, repl, class, gen,"
    " accesses, misses, writebacks, traffic_bytes, last_size, backinvals, bi_writebacks)"
    " VALUES(?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11, ?12, ?13, ?14, ?15, ?16, ?17, ?18)",
};

const char *rt_db_schema_sql(void) { return schema_sql; }
void *rt_db_handle(rt_db *db) { return db->h; }

/* The connection's last error was a lock conflict (worth retrying). */
static int is_busy(rt_db *db)
{
    int c = sqlite3_errcode(db->h) & 0xff;
    return c == SQLITE_BUSY || c == SQLITE_LOCKED;
}

static int dberr(rt_db *db, rt_err *e, const char *what)
{
    db->busy = is_busy(db);
    return rt_errf(e, "%s: %s%s%s", db->path, what ? what : "", what ? ": " : "", sqlite3_errmsg(db->h));
}

static int exec(rt_db *db, const char *sql, rt_err *e)
{
    char *msg = NULL;
    if (sqlite3_exec(db->h, sql, NULL, NULL, &msg) != SQLITE_OK) {
        db->busy = is_busy(db);
        rt_errf(e, "%s: %s", db->path, msg ? msg : sqlite3_errmsg(db->h));
        sqlite3_free(msg);
        return -1;
    }
    return 0;
}

static int get_int(rt_db *db, const char *sql, int64_t *out, rt_err *e)
{
    sqlite3_stmt *st;
    if (sqlite3_prepare_v2(db->h, sql, -1, &st, NULL) != SQLITE_OK) return dberr(db, e, NULL);
    int rc = sqlite3_step(st);
    if (rc == SQLITE_ROW) *out = sqlite3_column_int64(st, 0);
    sqlite3_finalize(st);
    if (rc != SQLITE_ROW && rc != SQLITE_DONE) return dberr(db, e, NULL);
    return 0;
}

void rt_db_close(rt_db *db)
{
    if (!db) return;
    for (int i = 0; i < S_NSTMT; i++) sqlite3_finalize(db->st[i]);
    sqlite3_close(db->h);
    free(db->path);
    free(db);
}

/* The class rows: every class this raytraffic knows (a file made before
 * classes tlas, inst and alpha existed gets them on its next open for
 * writing; rows already there are kept). */
static int add_classes(rt_db *db, rt_err *e)
{
    char sql[128];
    for (int c = 0; c < RT_NCLASS; c++) {
        snprintf(sql, sizeof sql, "INSERT OR IGNORE INTO classes(name, grp) VALUES('%s', '%s')", rt_class_name(c),
                 rt_group_name(rt_class_group(c)));
        if (exec(db, sql, e)) return -1;
    }
    return 0;
}

/* Creates the tables, views and class rows of an empty database. */
static int create_tables(rt_db *db, rt_err *e)
{
    if (exec(db, schema_sql, e)) return -1;
    return add_classes(db, e);
}

/* Every view, dropped before an upgrade changes a table under it and
 * created again (as the current schema has it) when the upgrade is done. */
static const char drop_views_sql[] = "DROP VIEW IF EXISTS v_paper;\n"
                                     "DROP VIEW IF EXISTS v_traffic_se;\n"
                                     "DROP VIEW IF EXISTS v_gen;\n"
                                     "DROP VIEW IF EXISTS v_traffic_group;\n"
                                     "DROP VIEW IF EXISTS v_level;\n"
                                     "DROP VIEW IF EXISTS v_runs;\n";

/* Version 1 -> 2: runs.sched_cache_size becomes sched_size (the UNIQUE
 * key follows the rename), the old name an alias. Runs inside the
 * caller's transaction, the views already dropped. */
static int migrate_v1(rt_db *db, rt_err *e)
{
    return exec(db,
                "ALTER TABLE runs RENAME COLUMN sched_cache_size TO sched_size;\n"
                "ALTER TABLE runs ADD COLUMN " SCHED_ALIAS ";\n",
                e);
}

/* Version 2 -> 3: scenes learn where a mesh file was (path as given,
 * absolute path); existing scenes get ''. */
static int migrate_v2(rt_db *db, rt_err *e)
{
    return exec(db,
                "ALTER TABLE scenes ADD COLUMN path TEXT NOT NULL DEFAULT '';\n"
                "ALTER TABLE scenes ADD COLUMN abspath TEXT NOT NULL DEFAULT '';\n",
                e);
}

/* Version 3 -> 4 (the per-generation table traffic_gen and the view
 * v_gen) and 4 -> 5 (the standard errors of approximate runs, table
 * traffic_se and view v_traffic_se) only add tables and views, which the
 * schema creates: runs stored before simply have no such rows. */

/* Version 5 -> 6: the run gains the dimensions repl, hierarchy, cores,
 * light_model and instances, all part of its key, with defaults under
 * which every stored run reads as it did (LRU, one level, one core, point
 * lights, flattened instances); the per-level table level_traffic and the
 * views v_level and v_runs are new. A UNIQUE key cannot be altered in
 * place, so runs is rebuilt: a copy with the current definition is
 * filled with every row (ids kept, so the rows referring to them stay
 * valid), the old table dropped and the copy renamed. The caller has
 * turned foreign keys off (the drop must not cascade into the traffic
 * rows) and dropped the views. */
static int migrate_v5(rt_db *db, rt_err *e)
{
    return exec(db,
                "DROP TABLE IF EXISTS runs_v6;\n" RUNS_TABLE("runs_v6")
                "INSERT INTO runs_v6(id, scene_id, tracer, W, H, lights, sched_size, gmax, params, sim_method,"
                " sim_params, trace_hash, refs, tool_version, git_rev, command, wall_time, stats, created)\n"
                "  SELECT id, scene_id, tracer, W, H, lights, sched_size, gmax, params, sim_method, sim_params,"
                " trace_hash, refs, tool_version, git_rev, command, wall_time, stats, created FROM runs;\n"
                "DROP TABLE runs;\n"
                "ALTER TABLE runs_v6 RENAME TO runs;\n",
                e);
}

/* Binds stats_json: the statistics as a JSON object, NULL when the text
 * is not k=v with unique keys and one-word values (stats.h). Older packet
 * runs wrote descriptive words into their statistics ("nodes=packet node
 * visits tests=ray-triangle tests", repeating the keys nodes and tests):
 * those words are left out of the object, so such a run parses whether it
 * comes by the upgrade or from an old shard through db merge. */
static void bind_stats_json(sqlite3_stmt *st, int col, const char *stats)
{
    static const char legacy[] = " nodes=packet node visits tests=ray-triangle tests";
    char txt[RT_DB_STATS_JSON_MAX], obj[RT_DB_STATS_JSON_MAX];
    rt_err ignored;
    int n = snprintf(txt, sizeof txt, "%s", stats ? stats : "");
    char *w = strstr(txt, legacy);
    if (w) memmove(w, w + sizeof legacy - 1, strlen(w + sizeof legacy - 1) + 1);
    if (n >= 0 && (size_t)n < sizeof txt && rt_stats_json(txt, obj, sizeof obj, &ignored) == 0)
        sqlite3_bind_text(st, col, obj, -1, SQLITE_TRANSIENT);
    else sqlite3_bind_null(st, col);
}

/* Version 6 -> 7: stats_json from every run's stats (the column itself is
 * new in RUNS_TABLE, so a file coming from version 5 or older has it
 * already; a version-6 file gets it appended), parsed as a store does
 * (bind_stats_json: the old packet words left out); text that does not
 * parse keeps NULL. */
static int migrate_v6(rt_db *db, int64_t ver, rt_err *e)
{
    if (ver == 6 && exec(db, "ALTER TABLE runs ADD COLUMN stats_json TEXT", e)) return -1;
    sqlite3_stmt *sel = NULL, *upd = NULL;
    if (sqlite3_prepare_v2(db->h, "SELECT id, stats FROM runs ORDER BY id", -1, &sel, NULL) != SQLITE_OK ||
        sqlite3_prepare_v2(db->h, "UPDATE runs SET stats_json = ?2 WHERE id = ?1", -1, &upd, NULL) != SQLITE_OK) {
        sqlite3_finalize(sel);
        return dberr(db, e, NULL);
    }
    int rc;
    while ((rc = sqlite3_step(sel)) == SQLITE_ROW) {
        sqlite3_reset(upd);
        sqlite3_bind_int64(upd, 1, sqlite3_column_int64(sel, 0));
        bind_stats_json(upd, 2, (const char *)sqlite3_column_text(sel, 1));
        if (sqlite3_step(upd) != SQLITE_DONE) {
            rc = SQLITE_ERROR;
            break;
        }
    }
    sqlite3_finalize(sel);
    sqlite3_finalize(upd);
    if (rc != SQLITE_DONE) return dberr(db, e, NULL);
    return 0;
}

/* Version 7 -> 8: level_traffic gains the chain's last-level size (part
 * of its UNIQUE key, so the table is rebuilt as runs was by migrate_v5:
 * a copy with the current definition filled with every row, the old table
 * dropped, the copy renamed), back-invalidations and their write-backs;
 * the rows stored before are non-inclusive: 0 in all three. Before version
 * 6 there was no level_traffic: the schema creates it. */
static int migrate_v7(rt_db *db, rt_err *e)
{
    static const char head[] = "CREATE TABLE IF NOT EXISTS level_traffic(";
    char sql[4096];
    const char *def = strstr(schema_sql, head);
    const char *end = def ? strstr(def, ");\n") : NULL; /* the table's closing parenthesis */
    if (!end) return rt_errf(e, "%s: level_traffic definition not found", db->path);
    int n = snprintf(sql, sizeof sql, "DROP TABLE IF EXISTS level_traffic_v8;\nCREATE TABLE level_traffic_v8(%.*s);\n",
                     (int)(end - def - (sizeof head - 1)), def + sizeof head - 1);
    if (n < 0 || (size_t)n >= sizeof sql) return rt_errf(e, "%s: level_traffic definition too long", db->path);
    if (exec(db, sql, e)) return -1;
    return exec(db,
                "INSERT INTO level_traffic_v8(run_id, level, level_name, core, cache_size, line, assoc, policy, repl,"
                " class, gen, accesses, misses, writebacks, traffic_bytes)\n"
                "  SELECT run_id, level, level_name, core, cache_size, line, assoc, policy, repl, class, gen, accesses,"
                " misses, writebacks, traffic_bytes FROM level_traffic;\n"
                "DROP TABLE level_traffic;\n"
                "ALTER TABLE level_traffic_v8 RENAME TO level_traffic;\n",
                e);
}

/* The name of a table that is not raytraffic's, or "" (none); for refusing
 * to add tables to an unrelated file. */
static int foreign_table(rt_db *db, char *name, size_t n, rt_err *e)
{
    sqlite3_stmt *st;
    name[0] = 0;
    if (sqlite3_prepare_v2(db->h,
                           "SELECT name FROM sqlite_master WHERE name NOT LIKE 'sqlite_%' AND name NOT IN "
                           "('scenes', 'runs', 'cache_configs', 'classes', 'traffic', 'traffic_config', "
                           "'v_traffic_group', 'v_paper', 'traffic_gen', 'v_gen', 'traffic_se', 'v_traffic_se', "
                           "'level_traffic', 'v_level', 'v_runs') "
                           "ORDER BY name LIMIT 1",
                           -1, &st, NULL) != SQLITE_OK)
        return dberr(db, e, NULL);
    int rc = sqlite3_step(st);
    if (rc == SQLITE_ROW) snprintf(name, n, "%s", (const char *)sqlite3_column_text(st, 0));
    sqlite3_finalize(st);
    if (rc != SQLITE_ROW && rc != SQLITE_DONE) return dberr(db, e, NULL);
    return 0;
}

/* Refuses, before anything is written, a file with a newer schema or an
 * unrelated SQLite file (user_version 0 but tables of its own). */
static int check_foreign(rt_db *db, rt_err *e)
{
    int64_t ver = 0;
    char other[128];
    if (get_int(db, "PRAGMA user_version", &ver, e)) return -1;
    if (ver > RT_DB_SCHEMA_VERSION)
        return rt_errf(e, "%s: database schema version %lld is newer than this raytraffic supports (%d)", db->path,
                       (long long)ver, RT_DB_SCHEMA_VERSION);
    if (ver < 0) return rt_errf(e, "%s: not a raytraffic database (user_version %lld)", db->path, (long long)ver);
    if (ver == 0) {
        if (foreign_table(db, other, sizeof other, e)) return -1;
        if (other[0])
            return rt_errf(e, "%s: not a raytraffic database (it has a table or view '%s'); refusing to add tables "
                              "to it", db->path, other);
        return 0;
    }
    /* A version we know: the file must hold our tables (an unrelated file
     * may use user_version too), and at the current version every
     * statement must compile against them; checked before WAL or any
     * upgrade, so a refused file is left exactly as it was. */
    int64_t ntab = 0;
    if (get_int(db,
                "SELECT COUNT(*) FROM sqlite_master WHERE type = 'table' AND name IN ('scenes', 'runs', "
                "'cache_configs', 'classes', 'traffic')",
                &ntab, e))
        return -1;
    if (ntab != 5)
        return rt_errf(e, "%s: not a raytraffic database (user_version %lld but not its tables); refusing to "
                          "change it", db->path, (long long)ver);
    if (ver == RT_DB_SCHEMA_VERSION)
        for (int i = 0; i < S_NSTMT; i++) {
            sqlite3_stmt *st = NULL;
            int rc = sqlite3_prepare_v2(db->h, stmt_sql[i], -1, &st, NULL);
            sqlite3_finalize(st);
            if (rc != SQLITE_OK) {
                db->busy = is_busy(db);
                if (db->busy) return dberr(db, e, NULL);
                return rt_errf(e, "%s: not a raytraffic database (schema mismatch: %s); refusing to change it",
                               db->path, sqlite3_errmsg(db->h));
            }
        }
    return 0;
}

/* After an upgrade: every row still refers to rows that exist (the
 * rebuild of runs ran with foreign keys off). */
static int foreign_key_check(rt_db *db, rt_err *e)
{
    sqlite3_stmt *st;
    if (sqlite3_prepare_v2(db->h, "PRAGMA foreign_key_check", -1, &st, NULL) != SQLITE_OK) return dberr(db, e, NULL);
    int rc = sqlite3_step(st);
    char tab[64] = "";
    if (rc == SQLITE_ROW) snprintf(tab, sizeof tab, "%s", (const char *)sqlite3_column_text(st, 0));
    sqlite3_finalize(st);
    if (rc == SQLITE_ROW) return rt_errf(e, "%s: upgrade left a row of %s without its referent", db->path, tab);
    if (rc != SQLITE_DONE) return dberr(db, e, NULL);
    return 0;
}

/* Brings the file to RT_DB_SCHEMA_VERSION in one transaction: creates the
 * schema of an empty file, upgrades an older one step by step. */
static int create_schema(rt_db *db, rt_err *e)
{
    int64_t ver = 0, ncls = 0;
    if (get_int(db, "PRAGMA user_version", &ver, e)) return -1;
    if (ver == RT_DB_SCHEMA_VERSION) {
        if (get_int(db, "SELECT COUNT(*) FROM classes", &ncls, e)) return -1;
        if (ncls >= RT_NCLASS) return 0;
    }
    if (exec(db, "BEGIN IMMEDIATE", e)) return -1;
    if (get_int(db, "PRAGMA user_version", &ver, e)) goto fail;
    /* re-read under the lock: another process may have done it meanwhile */
    if (ver == 0) {
        if (create_tables(db, e)) goto fail;
    } else if (ver == RT_DB_SCHEMA_VERSION) {
        if (add_classes(db, e)) goto fail;
    } else {
        if (exec(db, drop_views_sql, e)) goto fail;
        if (ver == 1 && migrate_v1(db, e)) goto fail;
        if (ver <= 2 && migrate_v2(db, e)) goto fail;
        if (ver <= 5 && migrate_v5(db, e)) goto fail;
        if (ver <= 6 && migrate_v6(db, ver, e)) goto fail;
        if (ver >= 6 && ver <= 7 && migrate_v7(db, e)) goto fail;
        if (exec(db, schema_sql, e)) goto fail;
        if (add_classes(db, e)) goto fail;
        if (foreign_key_check(db, e)) goto fail;
    }
    if (ver < RT_DB_SCHEMA_VERSION) {
        char sql[64];
        snprintf(sql, sizeof sql, "PRAGMA user_version = %d", RT_DB_SCHEMA_VERSION);
        if (exec(db, sql, e)) goto fail;
    }
    if (exec(db, "COMMIT", e)) goto fail;
    return 0;
fail:
    sqlite3_exec(db->h, "ROLLBACK", NULL, NULL, NULL);
    return -1;
}

/* journal_mode = WAL (it returns a row; a non-database file fails here). */
static int set_wal(rt_db *db, rt_err *e)
{
    sqlite3_stmt *st;
    if (sqlite3_prepare_v2(db->h, "PRAGMA journal_mode = WAL", -1, &st, NULL) != SQLITE_OK) return dberr(db, e, NULL);
    int rc = sqlite3_step(st);
    sqlite3_finalize(st);
    if (rc != SQLITE_ROW && rc != SQLITE_DONE) return dberr(db, e, NULL);
    return 0;
}

/* Runs step until it succeeds or fails for another reason than a lock
 * held by another process; lock conflicts are retried after 1, 2, 4 ... ms
 * (at most 250 ms apart, a little jitter so that processes started together
 * do not collide again), for at most 120 s in all. */
static int retry_busy(rt_db *db, int (*step)(rt_db *, rt_err *), rt_err *e)
{
    long wait_us = 1000, total_us = 0;
    unsigned jitter = (unsigned)getpid() * 2654435761u;
    for (;;) {
        db->busy = 0;
        if (step(db, e) == 0) return 0;
        if (!db->busy || total_us > 120L * 1000000) return -1;
        jitter = jitter * 1103515245u + 12345u;
        long us = wait_us + (long)(jitter % (unsigned)(wait_us / 2 + 1));
        struct timespec ts = {us / 1000000, (us % 1000000) * 1000};
        nanosleep(&ts, NULL);
        total_us += us;
        if (wait_us < 250000) wait_us *= 2;
    }
}

/* The name to hand sqlite3_open_v2 for the file path: SQLite may be built
 * to read any name starting with "file:" as a URI (SQLITE_USE_URI), and
 * then "file:x.db?mode=memory" would be no file at all and "file:other.db"
 * another one; such a relative name gets "./" in front, which SQLite takes
 * literally. Others are returned unchanged. Malloc'd; NULL when out of
 * memory. */
static char *fs_name(const char *path)
{
    size_t n = strlen(path);
    int pre = strncmp(path, "file:", 5) == 0;
    char *s = malloc(n + 3);
    if (!s) return NULL;
    snprintf(s, n + 3, "%s%s", pre ? "./" : "", path);
    return s;
}

rt_db *rt_db_open(const char *path, rt_err *e)
{
    /* a file name of a regular file or of none: never a FIFO (SQLite's
     * read would block for ever), a device (its -journal beside it), or
     * memory (results stored nowhere) */
    if (rt_open_target(path, RT_TARGET_DB, e) < 0) return NULL;
    rt_db *db = rt_calloc(1, sizeof *db, e);
    if (!db) return NULL;
    db->path = strdup(path);
    if (!db->path) {
        free(db);
        rt_errf(e, "%s: out of memory", path);
        return NULL;
    }
    char *name = fs_name(path);
    int orc = name ? sqlite3_open_v2(name, &db->h, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE, NULL) : SQLITE_NOMEM;
    free(name);
    if (orc != SQLITE_OK) {
        if (db->h) dberr(db, e, "cannot open database");
        else rt_errf(e, "%s: cannot open database", path);
        goto fail;
    }
    sqlite3_busy_timeout(db->h, 60000);
    if (sqlite3_db_readonly(db->h, "main") == 1) {
        rt_errf(e, "%s: database is not writable", path);
        goto fail;
    }
    if (retry_busy(db, check_foreign, e)) goto fail;
    /* foreign keys on only after the schema is current: the upgrade to 6
     * rebuilds runs, whose drop must not cascade */
    if (exec(db, "PRAGMA foreign_keys = OFF", e)) goto fail;
    if (retry_busy(db, set_wal, e) || retry_busy(db, create_schema, e)) goto fail;
    if (exec(db, "PRAGMA foreign_keys = ON", e)) goto fail;
    for (int i = 0; i < S_NSTMT; i++)
        if (sqlite3_prepare_v2(db->h, stmt_sql[i], -1, &db->st[i], NULL) != SQLITE_OK) {
            dberr(db, e, "schema mismatch");
            goto fail;
        }
    return db;
fail:
    rt_db_close(db);
    return NULL;
}

static const char *nz(const char *s) { return s ? s : ""; }

static void hex64(char out[17], uint64_t v) { snprintf(out, 17, "%016llx", (unsigned long long)v); }

/* Binds the run's own identity columns (tracer, W, H, lights, sched_size,
 * gmax, params, sim_method, sim_params, repl, hierarchy, cores,
 * light_model, instances) to parameters first..first+13: the same columns,
 * in the same order, in S_RUN_GET and S_RUN_INS. Unset new dimensions
 * (NULL, cores 0) bind their defaults, so every earlier caller's run reads
 * as it always did. */
static void bind_run_cols(sqlite3_stmt *st, int first, const rt_db_run *r)
{
    sqlite3_bind_text(st, first, nz(r->tracer), -1, SQLITE_TRANSIENT);
    sqlite3_bind_int(st, first + 1, r->W);
    sqlite3_bind_int(st, first + 2, r->H);
    sqlite3_bind_int64(st, first + 3, r->lights);
    sqlite3_bind_int64(st, first + 4, (sqlite3_int64)r->sched_size);
    sqlite3_bind_int64(st, first + 5, (sqlite3_int64)r->gmax);
    sqlite3_bind_text(st, first + 6, nz(r->params), -1, SQLITE_TRANSIENT);
    sqlite3_bind_text(st, first + 7, r->sim_method ? r->sim_method : "exact", -1, SQLITE_TRANSIENT);
    sqlite3_bind_text(st, first + 8, nz(r->sim_params), -1, SQLITE_TRANSIENT);
    sqlite3_bind_text(st, first + 9, r->repl && r->repl[0] ? r->repl : "lru", -1, SQLITE_TRANSIENT);
    sqlite3_bind_text(st, first + 10, nz(r->hierarchy), -1, SQLITE_TRANSIENT);
    sqlite3_bind_int(st, first + 11, r->cores > 0 ? r->cores : 1);
    sqlite3_bind_text(st, first + 12, r->light_model && r->light_model[0] ? r->light_model : "point", -1,
                      SQLITE_TRANSIENT);
    sqlite3_bind_text(st, first + 13, r->instances && r->instances[0] ? r->instances : "flatten", -1,
                      SQLITE_TRANSIENT);
}

/* Binds the 17 identity parameters of S_RUN_GET. */
static void bind_key(sqlite3_stmt *st, const rt_db_run *r, char *hash)
{
    hex64(hash, r->scene_hash);
    sqlite3_bind_text(st, 1, nz(r->scene), -1, SQLITE_TRANSIENT);
    sqlite3_bind_text(st, 2, nz(r->scene_params), -1, SQLITE_TRANSIENT);
    sqlite3_bind_text(st, 3, hash, -1, SQLITE_TRANSIENT);
    bind_run_cols(st, 4, r);
}

/* Runs a statement expecting at most one integer row. 1 = row, 0 = none, -1 = error. */
static int step_id(rt_db *db, sqlite3_stmt *st, int64_t *id, rt_err *e)
{
    int rc = sqlite3_step(st);
    int ret = 0;
    if (rc == SQLITE_ROW) {
        if (id) *id = sqlite3_column_int64(st, 0);
        ret = 1;
    } else if (rc != SQLITE_DONE) {
        ret = dberr(db, e, NULL);
    }
    sqlite3_reset(st);
    sqlite3_clear_bindings(st);
    return ret;
}

int rt_db_has_run(rt_db *db, const rt_db_run *key, rt_err *e)
{
    char hash[17];
    bind_key(db->st[S_RUN_GET], key, hash);
    return step_id(db, db->st[S_RUN_GET], NULL, e);
}

int rt_db_missing_sizes(rt_db *db, const rt_db_run *key, const uint64_t *sizes, int n, uint32_t line, uint32_t assoc,
                        const char *policy, int *have, rt_err *e)
{
    char hash[17];
    int64_t rid = 0;
    bind_key(db->st[S_RUN_GET], key, hash);
    int r = step_id(db, db->st[S_RUN_GET], &rid, e);
    if (r < 0) return -1;
    for (int i = 0; i < n; i++) have[i] = 0;
    if (r == 0) return n;
    sqlite3_stmt *st;
    if (sqlite3_prepare_v2(db->h,
                           "SELECT 1 FROM traffic t JOIN cache_configs c ON c.id = t.config_id WHERE t.run_id = ?1"
                           " AND c.size = ?2 AND c.line = ?3 AND c.assoc = ?4 AND c.policy = ?5 LIMIT 1",
                           -1, &st, NULL) != SQLITE_OK)
        return dberr(db, e, NULL);
    int missing = 0;
    for (int i = 0; i < n; i++) {
        sqlite3_bind_int64(st, 1, rid);
        sqlite3_bind_int64(st, 2, (sqlite3_int64)sizes[i]);
        sqlite3_bind_int64(st, 3, line);
        sqlite3_bind_int64(st, 4, assoc);
        sqlite3_bind_text(st, 5, policy, -1, SQLITE_TRANSIENT);
        int rc = sqlite3_step(st);
        if (rc != SQLITE_ROW && rc != SQLITE_DONE) {
            dberr(db, e, NULL);
            sqlite3_finalize(st);
            return -1;
        }
        have[i] = rc == SQLITE_ROW;
        missing += !have[i];
        sqlite3_reset(st);
    }
    sqlite3_finalize(st);
    return missing;
}

/* Inserts the run's scene if new (or fills in its triangle count and,
 * when the run knows it, where the mesh file is now); its id. */
static int store_scene(rt_db *db, const rt_db_run *r, int64_t *scene_id, rt_err *e)
{
    char hash[17];
    sqlite3_stmt **st = db->st;
    hex64(hash, r->scene_hash);
    sqlite3_bind_text(st[S_SCENE_INS], 1, nz(r->scene), -1, SQLITE_TRANSIENT);
    sqlite3_bind_text(st[S_SCENE_INS], 2, nz(r->scene_params), -1, SQLITE_TRANSIENT);
    sqlite3_bind_text(st[S_SCENE_INS], 3, hash, -1, SQLITE_TRANSIENT);
    sqlite3_bind_int64(st[S_SCENE_INS], 4, r->ntri);
    if (step_id(db, st[S_SCENE_INS], NULL, e) < 0) return -1;
    sqlite3_bind_text(st[S_SCENE_GET], 1, nz(r->scene), -1, SQLITE_TRANSIENT);
    sqlite3_bind_text(st[S_SCENE_GET], 2, nz(r->scene_params), -1, SQLITE_TRANSIENT);
    sqlite3_bind_text(st[S_SCENE_GET], 3, hash, -1, SQLITE_TRANSIENT);
    if (step_id(db, st[S_SCENE_GET], scene_id, e) != 1) return rt_errf(e, "%s: scene row vanished", db->path);
    sqlite3_bind_int64(st[S_SCENE_TRI], 1, *scene_id);
    sqlite3_bind_int64(st[S_SCENE_TRI], 2, r->ntri);
    sqlite3_bind_text(st[S_SCENE_TRI], 3, nz(r->scene_path), -1, SQLITE_TRANSIENT);
    sqlite3_bind_text(st[S_SCENE_TRI], 4, nz(r->scene_abspath), -1, SQLITE_TRANSIENT);
    return step_id(db, st[S_SCENE_TRI], NULL, e) < 0 ? -1 : 0;
}

/* Binds a configuration to S_CFG_INS / S_CFG_GET and gets its id. */
static int config_id(rt_db *db, uint64_t size, uint32_t line, uint32_t assoc, const char *policy, int64_t *cfg_id,
                     rt_err *e)
{
    sqlite3_stmt **st = db->st;
    for (int k = S_CFG_INS; k <= S_CFG_GET; k++) {
        sqlite3_bind_int64(st[k], 1, (sqlite3_int64)size);
        sqlite3_bind_int64(st[k], 2, line);
        sqlite3_bind_int64(st[k], 3, assoc);
        sqlite3_bind_text(st[k], 4, policy ? policy : "wb-wa", -1, SQLITE_TRANSIENT);
    }
    if (step_id(db, st[S_CFG_INS], NULL, e) < 0) return -1;
    if (step_id(db, st[S_CFG_GET], cfg_id, e) != 1) return rt_errf(e, "%s: config row vanished", db->path);
    return 0;
}

static int del_rows(rt_db *db, int s, int64_t rid, int64_t cfg_id, rt_err *e)
{
    sqlite3_bind_int64(db->st[s], 1, rid);
    sqlite3_bind_int64(db->st[s], 2, cfg_id);
    return step_id(db, db->st[s], NULL, e) < 0 ? -1 : 0;
}

/* One pass over one table's rows of run rid: pass 0 deletes the run's old
 * rows of each configuration met (traffic rows: in all three tables, so no
 * stale generation or standard-error row outlives a re-store; generation
 * rows: in traffic_gen), pass 1 inserts. tab 0: rt_db_traffic rows; 1:
 * rt_db_gen rows (stride bytes apart, the counters first in each). */
static int store_rows(rt_db *db, int64_t rid, int pass, int tab, const void *base, size_t n, size_t stride, rt_err *e)
{
    int64_t cfg_id = -1;
    const rt_db_traffic *prev = NULL;
    for (size_t i = 0; i < n; i++) {
        const rt_db_traffic *t = (const rt_db_traffic *)((const char *)base + i * stride);
        const char *cname = rt_class_name(t->cls);
        if (!cname) return rt_errf(e, "%s: %s row %zu has bad class %d", db->path, tab ? "generation" : "traffic", i, t->cls);
        int gen = tab ? ((const rt_db_gen *)t)->gen : 0;
        if (gen < 0 || gen >= RT_MAXGEN)
            return rt_errf(e, "%s: generation row %zu has generation %d (0..%d)", db->path, i, gen, RT_MAXGEN - 1);
        if (!prev || prev->size != t->size || prev->line != t->line || prev->assoc != t->assoc ||
            strcmp(nz(prev->policy), nz(t->policy))) {
            if (config_id(db, t->size, t->line, t->assoc, t->policy, &cfg_id, e) < 0) return -1;
            if (pass == 0 && (del_rows(db, S_GEN_DEL, rid, cfg_id, e) < 0 ||
                              (tab == 0 && (del_rows(db, S_TR_DEL, rid, cfg_id, e) < 0 ||
                                            del_rows(db, S_SE_DEL, rid, cfg_id, e) < 0))))
                return -1;
            prev = t;
        }
        if (pass == 0) continue;
        if (tab == 0 && rt_db_fail_row_after > 0 && --rt_db_fail_row_after == 0)
            return rt_errf(e, "%s: injected failure at traffic row %zu", db->path, i);
        sqlite3_stmt *in = db->st[tab ? S_GEN_INS : S_TR_INS];
        sqlite3_bind_int64(in, 1, rid);
        sqlite3_bind_int64(in, 2, cfg_id);
        sqlite3_bind_text(in, 3, cname, -1, SQLITE_STATIC);
        sqlite3_bind_int64(in, 4, (sqlite3_int64)t->accesses);
        sqlite3_bind_int64(in, 5, (sqlite3_int64)t->read_misses);
        sqlite3_bind_int64(in, 6, (sqlite3_int64)t->write_misses);
        sqlite3_bind_int64(in, 7, (sqlite3_int64)t->writebacks);
        sqlite3_bind_int64(in, 8, tab ? (sqlite3_int64)gen : (sqlite3_int64)t->wt_bytes);
        sqlite3_bind_int64(in, 9, (sqlite3_int64)t->traffic_bytes);
        if (step_id(db, in, NULL, e) < 0) return -1;
    }
    return 0;
}

/* One pass over the standard-error rows of run rid: pass 0 checks each
 * value and deletes the run's old row of each configuration, pass 1
 * (after the traffic rows) inserts, a negative error as NULL, refusing a
 * configuration without traffic rows (the invariant of the file comment). */
static int store_se(rt_db *db, int64_t rid, int pass, const rt_db_se *se, size_t n, rt_err *e)
{
    for (size_t i = 0; i < n; i++) {
        const rt_db_se *x = &se[i];
        int64_t cfg_id = -1;
        if (pass == 0)
            for (int g = 0; g < RT_DB_SE_N; g++)
                if (!isfinite(x->se[g]))
                    return rt_errf(e, "%s: standard-error row %zu (size %llu) is not a number", db->path, i,
                                   (unsigned long long)x->size);
        if (config_id(db, x->size, x->line, x->assoc, x->policy, &cfg_id, e) < 0) return -1;
        if (pass == 0) {
            if (del_rows(db, S_SE_DEL, rid, cfg_id, e) < 0) return -1;
            continue;
        }
        sqlite3_bind_int64(db->st[S_TR_HAS], 1, rid);
        sqlite3_bind_int64(db->st[S_TR_HAS], 2, cfg_id);
        int has = step_id(db, db->st[S_TR_HAS], NULL, e);
        if (has < 0) return -1;
        if (!has)
            return rt_errf(e, "%s: standard-error row %zu (size %llu) has no traffic row", db->path, i,
                           (unsigned long long)x->size);
        sqlite3_stmt *in = db->st[S_SE_INS];
        sqlite3_bind_int64(in, 1, rid);
        sqlite3_bind_int64(in, 2, cfg_id);
        for (int g = 0; g < RT_DB_SE_N; g++) {
            if (x->se[g] >= 0) sqlite3_bind_double(in, 3 + g, x->se[g]);
            else sqlite3_bind_null(in, 3 + g);
        }
        if (step_id(db, in, NULL, e) < 0) return -1;
    }
    return 0;
}

/* One pass over the per-level rows of run rid: pass 0 checks each row and
 * deletes the run's old rows of its level configuration (level, core,
 * size, line, assoc, write policy, replacement policy), pass 1 inserts. */
static int store_levels(rt_db *db, int64_t rid, int pass, const rt_db_level *lv, size_t n, rt_err *e)
{
    for (size_t i = 0; i < n; i++) {
        const rt_db_level *x = &lv[i];
        const char *cname = rt_class_name(x->cls);
        const char *pol = x->policy && x->policy[0] ? x->policy : "wb-wa";
        const char *repl = x->repl && x->repl[0] ? x->repl : "lru";
        int first = pass == 0 ? 0 : 1;
        if (pass == 0) {
            if (!cname) return rt_errf(e, "%s: level row %zu has bad class %d", db->path, i, x->cls);
            if (x->level < 1) return rt_errf(e, "%s: level row %zu has level %d (1 or more)", db->path, i, x->level);
            if (x->core < -1) return rt_errf(e, "%s: level row %zu has core %d (-1 or more)", db->path, i, x->core);
            if (x->gen < -1 || x->gen >= RT_MAXGEN)
                return rt_errf(e, "%s: level row %zu has generation %d (-1..%d)", db->path, i, x->gen, RT_MAXGEN - 1);
            if (x->line == 0 || x->misses > x->accesses)
                return rt_errf(e, "%s: level row %zu has line 0 or more misses than accesses", db->path, i);
            if (x->bi_writebacks > x->backinvals)
                return rt_errf(e, "%s: level row %zu has more back-invalidation write-backs than back-invalidations",
                               db->path, i);
        }
        sqlite3_stmt *st = db->st[pass == 0 ? S_LV_DEL : S_LV_INS];
        sqlite3_bind_int64(st, 1, rid);
        sqlite3_bind_int(st, 2, x->level);
        if (pass) sqlite3_bind_text(st, 3, x->level_name ? x->level_name : "", -1, SQLITE_TRANSIENT);
        sqlite3_bind_int(st, 3 + first, x->core);
        sqlite3_bind_int64(st, 4 + first, (sqlite3_int64)x->size);
        sqlite3_bind_int64(st, 5 + first, x->line);
        sqlite3_bind_int64(st, 6 + first, x->assoc);
        sqlite3_bind_text(st, 7 + first, pol, -1, SQLITE_TRANSIENT);
        sqlite3_bind_text(st, 8 + first, repl, -1, SQLITE_TRANSIENT);
        if (!pass) sqlite3_bind_int64(st, 9, (sqlite3_int64)x->last_size);
        if (pass) {
            sqlite3_bind_int64(st, 16, (sqlite3_int64)x->last_size);
            sqlite3_bind_int64(st, 17, (sqlite3_int64)x->backinvals);
            sqlite3_bind_int64(st, 18, (sqlite3_int64)x->bi_writebacks);
            sqlite3_bind_text(st, 10, cname, -1, SQLITE_STATIC);
            sqlite3_bind_int(st, 11, x->gen);
            sqlite3_bind_int64(st, 12, (sqlite3_int64)x->accesses);
            sqlite3_bind_int64(st, 13, (sqlite3_int64)x->misses);
            sqlite3_bind_int64(st, 14, (sqlite3_int64)x->writebacks);
            sqlite3_bind_int64(st, 15, (sqlite3_int64)x->traffic_bytes);
        }
        if (step_id(db, st, NULL, e) < 0) return -1;
    }
    return 0;
}

static int store(rt_db *db, const rt_db_run *r, const rt_db_rows *R, int64_t *run_id, rt_err *e)
{
    char hash[17], thash[17];
    sqlite3_stmt **st = db->st;
    int64_t scene_id = 0;
    if (store_scene(db, r, &scene_id, e) < 0) return -1;
    /* run: update in place if the key exists, else insert */
    int64_t rid = 0;
    bind_key(st[S_RUN_GET], r, hash);
    int have = step_id(db, st[S_RUN_GET], &rid, e);
    if (have < 0) return -1;
    if (r->trace_hash) hex64(thash, r->trace_hash);
    else thash[0] = 0;
    const char *ver = r->tool_version ? r->tool_version : rt_version();
    const char *rev = r->git_rev ? r->git_rev : rt_git_rev();
    if (have) {
        sqlite3_stmt *u = st[S_RUN_UPD];
        sqlite3_bind_int64(u, 1, rid);
        sqlite3_bind_text(u, 2, thash, -1, SQLITE_TRANSIENT);
        sqlite3_bind_int64(u, 3, (sqlite3_int64)r->refs);
        sqlite3_bind_text(u, 4, ver, -1, SQLITE_TRANSIENT);
        sqlite3_bind_text(u, 5, rev, -1, SQLITE_TRANSIENT);
        sqlite3_bind_text(u, 6, nz(r->command), -1, SQLITE_TRANSIENT);
        sqlite3_bind_double(u, 7, r->wall_time);
        sqlite3_bind_text(u, 8, nz(r->stats), -1, SQLITE_TRANSIENT);
        bind_stats_json(u, 9, r->stats);
        if (step_id(db, u, NULL, e) < 0) return -1;
    } else {
        sqlite3_stmt *in = st[S_RUN_INS];
        sqlite3_bind_int64(in, 1, scene_id);
        bind_run_cols(in, 2, r);
        sqlite3_bind_text(in, 16, thash, -1, SQLITE_TRANSIENT);
        sqlite3_bind_int64(in, 17, (sqlite3_int64)r->refs);
        sqlite3_bind_text(in, 18, ver, -1, SQLITE_TRANSIENT);
        sqlite3_bind_text(in, 19, rev, -1, SQLITE_TRANSIENT);
        sqlite3_bind_text(in, 20, nz(r->command), -1, SQLITE_TRANSIENT);
        sqlite3_bind_double(in, 21, r->wall_time);
        sqlite3_bind_text(in, 22, nz(r->stats), -1, SQLITE_TRANSIENT);
        bind_stats_json(in, 23, r->stats);
        if (step_id(db, in, NULL, e) < 0) return -1;
        rid = sqlite3_last_insert_rowid(db->h);
    }
    /* configurations: first drop this run's old rows of every configuration
     * being stored (traffic rows: all three tables; generation rows:
     * traffic_gen; standard-error rows: traffic_se), then insert (rows of
     * one configuration are adjacent) */
    for (int pass = 0; pass < 2; pass++) {
        for (int tab = 0; tab < 2; tab++)
            if (store_rows(db, rid, pass, tab, tab ? (const void *)R->gen : R->traffic, tab ? R->ngen : R->ntraffic,
                           tab ? sizeof *R->gen : sizeof *R->traffic, e) < 0)
                return -1;
        if (store_se(db, rid, pass, R->se, R->nse, e) < 0) return -1;
        if (store_levels(db, rid, pass, R->level, R->nlevel, e) < 0) return -1;
    }
    if (run_id) *run_id = rid;
    return 0;
}

int rt_db_store_run(rt_db *db, const rt_db_run *run, const rt_db_traffic *rows, size_t n, int64_t *run_id, rt_err *e)
{
    return rt_db_store_run_gen(db, run, rows, n, NULL, 0, run_id, e);
}

int rt_db_store_run_gen(rt_db *db, const rt_db_run *run, const rt_db_traffic *rows, size_t n, const rt_db_gen *grows,
                        size_t ng, int64_t *run_id, rt_err *e)
{
    rt_db_rows R = {.traffic = rows, .ntraffic = n, .gen = grows, .ngen = ng};
    return rt_db_store(db, run, &R, run_id, e);
}

int rt_db_store(rt_db *db, const rt_db_run *run, const rt_db_rows *rows, int64_t *run_id, rt_err *e)
{
    if (exec(db, "BEGIN IMMEDIATE", e)) return -1;
    if (store(db, run, rows, run_id, e) < 0) {
        for (int i = 0; i < S_NSTMT; i++) {
            sqlite3_reset(db->st[i]);
            sqlite3_clear_bindings(db->st[i]);
        }
        sqlite3_exec(db->h, "ROLLBACK", NULL, NULL, NULL);
        return -1;
    }
    if (exec(db, "COMMIT", e)) {
        sqlite3_exec(db->h, "ROLLBACK", NULL, NULL, NULL);
        return -1;
    }
    return 0;
}

/* ---- reading a database whole ------------------------------------------ */

const char *rt_db_read_error_kind(int rc)
{
    switch (rc & 0xff) {
    case SQLITE_CORRUPT: return "malformed database";
    case SQLITE_NOTADB: return "not an SQLite database";
    default: return "cannot read database";
    }
}

/* A URI for path with every byte outside the unreserved set escaped (so a
 * '?' or '#' in the name stays part of it) and the query q. Malloc'd. */
static char *read_uri(const char *path, const char *q, rt_err *e)
{
    size_t n = strlen(path);
    char *uri = rt_calloc(3 * n + strlen(q) + 16, 1, e);
    if (!uri) return NULL;
    size_t k = (size_t)sprintf(uri, "file:");
    for (const unsigned char *p = (const unsigned char *)path; *p; p++)
        k += (size_t)(isalnum(*p) || strchr("-._~/", *p) ? sprintf(uri + k, "%c", *p) : sprintf(uri + k, "%%%02X", *p));
    strcpy(uri + k, q);
    return uri;
}

/* What the first 100 bytes of the file at fd say: 0 when they are an
 * SQLite header consistent with the file's size, else -1 with the reason
 * ("malformed" for a truncated file, "not a raytraffic database" for
 * something else). check_size: the main file is complete only without a
 * write-ahead log beside it. */
static int check_header(int fd, const char *path, int check_size, rt_err *e)
{
    unsigned char h[100];
    struct stat st;
    if (fstat(fd, &st) != 0) return rt_errf(e, "%s: unreadable: %s", path, strerror(errno));
    ssize_t n = pread(fd, h, sizeof h, 0);
    if (n < 0) return rt_errf(e, "%s: unreadable: %s", path, strerror(errno));
    if (n == 0) return rt_errf(e, "%s: not a raytraffic database (an empty file)", path);
    if ((size_t)n < 16 || memcmp(h, "SQLite format 3", 16) != 0)
        return rt_errf(e, "%s: not a raytraffic database (not an SQLite file)", path);
    if ((size_t)n < sizeof h)
        return rt_errf(e, "%s: malformed database: truncated (%lld bytes, shorter than SQLite's 100-byte header)", path,
                       (long long)n);
    uint64_t page = (uint64_t)h[16] << 8 | h[17];
    if (page == 1) page = 65536;
    uint32_t count = (uint32_t)h[28] << 24 | (uint32_t)h[29] << 16 | (uint32_t)h[30] << 8 | h[31];
    /* the page count is valid when the change counter (24) equals its
     * version-valid-for copy (92) */
    if (check_size && memcmp(h + 24, h + 92, 4) == 0 && count && (uint64_t)st.st_size < page * count)
        return rt_errf(e, "%s: malformed database: truncated (%lld bytes; its header says %u pages of %llu bytes)",
                       path, (long long)st.st_size, (unsigned)count, (unsigned long long)page);
    return 0;
}

/* 1 if path's folder cannot be written (read-only file system, no
 * permission). */
static int folder_read_only(const char *path)
{
    const char *s = strrchr(path, '/');
    char dir[4096];
    if (!s) snprintf(dir, sizeof dir, ".");
    else snprintf(dir, sizeof dir, "%.*s", (int)(s - path) + 1, path);
    return access(dir, W_OK) != 0;
}

void rt_db_close_read(void *h) { sqlite3_close(h); }

int rt_db_open_read(const char *path, void **ph, int *ver, rt_err *e)
{
    *ph = NULL;
    *ver = 0;
    if (rt_open_target(path, RT_TARGET_DB_READ, e) < 0) {
        if (!e || e->usage) return -1;
        char m[RT_ERR_LEN];
        snprintf(m, sizeof m, "%s", e->msg);
        size_t pl = strlen(path);
        /* "PATH: reason" -> "PATH: unreadable: reason" */
        return rt_errf(e, "%s: unreadable: %s", path, strncmp(m, path, pl) == 0 && m[pl] == ':' ? m + pl + 2 : m);
    }
    size_t n = strlen(path);
    char *wal = rt_calloc(n + 12, 1, e);
    if (!wal) return -1;
    snprintf(wal, n + 8, "%s-wal", path);
    struct stat ws;
    int has_wal = stat(wal, &ws) == 0;
    /* a rollback journal left by a writer that died: not immutable, so
     * SQLite sees it (and, read-only, refuses rather than read a torn file) */
    snprintf(wal, n + 12, "%s-journal", path);
    int has_journal = stat(wal, &ws) == 0;
    free(wal);
    int fd = open(path, O_RDONLY | O_NONBLOCK | O_CLOEXEC);
    if (fd < 0) return rt_errf(e, "%s: unreadable: %s", path, strerror(errno));
    int hr = check_header(fd, path, !has_wal && !has_journal, e);
    close(fd);
    if (hr < 0) return -1;
    /* immutable: no -shm or -wal made beside it, fine on a read-only
     * file system; with a log it must be read through the log */
    char *uri = read_uri(path, has_wal || has_journal ? "?mode=ro" : "?immutable=1", e);
    if (!uri) return -1;
    sqlite3 *h = NULL;
    int orc = sqlite3_open_v2(uri, &h, SQLITE_OPEN_READONLY | SQLITE_OPEN_URI, NULL);
    free(uri);
    sqlite3_stmt *st = NULL;
    if (orc == SQLITE_OK) {
        sqlite3_busy_timeout(h, 60000);
        orc = sqlite3_prepare_v2(h, "PRAGMA user_version", -1, &st, NULL);
        if (orc == SQLITE_OK && (orc = sqlite3_step(st)) == SQLITE_ROW) {
            *ver = sqlite3_column_int(st, 0);
            orc = SQLITE_OK;
        }
        if (orc == SQLITE_OK) {
            /* the catalogue holds every table's root: reading it touches
             * the file beyond the header */
            sqlite3_finalize(st);
            orc = sqlite3_prepare_v2(h,
                                     "SELECT COUNT(*) FROM sqlite_master WHERE type = 'table' AND name IN ('runs', "
                                     "'scenes')",
                                     -1, &st, NULL);
            if (orc == SQLITE_OK && (orc = sqlite3_step(st)) == SQLITE_ROW) {
                if (sqlite3_column_int(st, 0) != 2 && *ver <= RT_DB_SCHEMA_VERSION) *ver = 0;
                orc = SQLITE_OK;
            }
        }
    }
    sqlite3_finalize(st);
    if (orc != SQLITE_OK) {
        int code = orc & 0xff;
        if (has_journal && code == SQLITE_READONLY)
            rt_errf(e, "%s: read-only: its rollback journal %s-journal (a writer died mid-transaction) must be rolled "
                       "back, which a reader does not do; open it once for writing, e.g. sqlite3 %s 'PRAGMA "
                       "quick_check'", path, path, path);
        else if (has_wal && code != SQLITE_CORRUPT && code != SQLITE_NOTADB && folder_read_only(path))
            rt_errf(e, "%s: read-only: its write-ahead log %s-wal must be replayed, which needs a writable folder; copy "
                       "both files to one, or rerun where it was written", path, path);
        else
            rt_errf(e, "%s: %s: %s", path, rt_db_read_error_kind(orc), h ? sqlite3_errmsg(h) : "out of memory");
        sqlite3_close(h);
        return -1;
    }
    if (*ver > RT_DB_SCHEMA_VERSION) {
        rt_errf(e, "%s: database schema version %d is newer than this raytraffic supports (%d); use a newer raytraffic",
                path, *ver, RT_DB_SCHEMA_VERSION);
        sqlite3_close(h);
        return -1;
    }
    if (*ver < 1) {
        rt_errf(e, "%s: not a raytraffic database (an SQLite file without raytraffic's tables)", path);
        sqlite3_close(h);
        return -1;
    }
    *ph = h;
    return 0;
}

/* ---- merge ------------------------------------------------------------- */

/* A shard being merged: its connection and the reading statements. */
typedef struct shard {
    const char *path; /* for messages */
    sqlite3 *h;
    sqlite3_stmt *runs, *rows;
    sqlite3_stmt *gens; /* generation rows (version 4), or NULL */
    sqlite3_stmt *ses;  /* standard-error rows (version 5), or NULL */
    sqlite3_stmt *lvs;  /* per-level rows (version 6), or NULL */
} shard;

static const char *txt(sqlite3_stmt *st, int i)
{
    const unsigned char *t = sqlite3_column_text(st, i);
    return t ? (const char *)t : "";
}

/* Column i of st as a count (an INTEGER >= 0), else -1 with a message
 * naming the shard, the row and the column. */
static int count_col(const shard *sh, sqlite3_stmt *st, int i, const char *row, uint64_t *out, rt_err *e)
{
    if (sqlite3_column_type(st, i) != SQLITE_INTEGER)
        return rt_errf(e, "%s: %s: %s is '%s', not an integer", sh->path, row, sqlite3_column_name(st, i),
                       txt(st, i));
    sqlite3_int64 v = sqlite3_column_int64(st, i);
    if (v < 0) return rt_errf(e, "%s: %s: %s is negative (%lld)", sh->path, row, sqlite3_column_name(st, i), (long long)v);
    *out = (uint64_t)v;
    return 0;
}

/* A statement of a shard did not compile: a damaged file, or tables that
 * are not raytraffic's. */
static int shard_error(const shard *sh, rt_err *e)
{
    int c = sqlite3_errcode(sh->h) & 0xff;
    if (c == SQLITE_CORRUPT || c == SQLITE_NOTADB)
        return rt_errf(e, "%s: %s: %s", sh->path, rt_db_read_error_kind(c), sqlite3_errmsg(sh->h));
    return rt_errf(e, "%s: not a raytraffic database (%s)", sh->path, sqlite3_errmsg(sh->h));
}

/* Opens a shard read-only and checks it is a raytraffic database of a
 * version this build reads (1 to 7, through rt_db_open_read; older column
 * name for 1, no scene paths before 3, no generation rows before 4, no
 * standard errors before 5, no new dimensions (their defaults) and no
 * level rows before 6). */
static int shard_open(shard *sh, const char *path, rt_err *e)
{
    memset(sh, 0, sizeof *sh);
    sh->path = path;
    int ver = 0;
    void *h = NULL;
    if (rt_db_open_read(path, &h, &ver, e) < 0) return -1;
    sh->h = h;
    char runs_sql[900];
    snprintf(runs_sql, sizeof runs_sql,
             "SELECT r.id, s.name, s.params, s.hash, s.triangles, r.tracer, r.W, r.H, r.lights, r.%s, r.gmax,"
             " r.params, r.sim_method, r.sim_params, r.trace_hash, r.refs, r.tool_version, r.git_rev, r.command,"
             " r.wall_time, r.stats, %s, %s FROM runs r JOIN scenes s ON s.id = r.scene_id ORDER BY r.id",
             ver == 1 ? "sched_cache_size" : "sched_size", ver >= 3 ? "s.path, s.abspath" : "'', ''",
             ver >= 6 ? "r.repl, r.hierarchy, r.cores, r.light_model, r.instances"
                      : "'lru', '', 1, 'point', 'flatten'");
    static const char rows_sql[] =
        "SELECT c.size, c.line, c.assoc, c.policy, t.class, t.accesses, t.read_misses, t.write_misses, t.writebacks,"
        " t.wt_bytes, t.traffic_bytes FROM traffic t JOIN cache_configs c ON c.id = t.config_id WHERE t.run_id = ?1"
        " ORDER BY c.size, t.class";
    if (sqlite3_prepare_v2(sh->h, runs_sql, -1, &sh->runs, NULL) != SQLITE_OK ||
        sqlite3_prepare_v2(sh->h, rows_sql, -1, &sh->rows, NULL) != SQLITE_OK)
        return shard_error(sh, e);
    static const char gens_sql[] =
        "SELECT c.size, c.line, c.assoc, c.policy, t.class, t.accesses, t.read_misses, t.write_misses, t.writebacks,"
        " t.gen, t.traffic_bytes FROM traffic_gen t JOIN cache_configs c ON c.id = t.config_id WHERE t.run_id = ?1"
        " ORDER BY c.size, c.line, c.assoc, c.policy, t.class, t.gen";
    if (ver >= 4 && sqlite3_prepare_v2(sh->h, gens_sql, -1, &sh->gens, NULL) != SQLITE_OK)
        return shard_error(sh, e);
    static const char ses_sql[] =
        "SELECT c.size, c.line, c.assoc, c.policy, e.geometry_se, e.ray_se, e.other_se, e.total_se FROM traffic_se e"
        " JOIN cache_configs c ON c.id = e.config_id WHERE e.run_id = ?1 ORDER BY c.size, c.line, c.assoc, c.policy";
    if (ver >= 5 && sqlite3_prepare_v2(sh->h, ses_sql, -1, &sh->ses, NULL) != SQLITE_OK)
        return shard_error(sh, e);
    /* version 8 added the inclusion's columns: 0 (non-inclusive) before */
    char lvs_sql[512];
    snprintf(lvs_sql, sizeof lvs_sql,
             "SELECT level, level_name, core, cache_size, line, assoc, policy, repl, class, gen, accesses, misses,"
             " writebacks, traffic_bytes, %s FROM level_traffic WHERE run_id = ?1"
             " ORDER BY level, core, cache_size, line, assoc, policy, repl, class, gen%s",
             ver >= 8 ? "last_size, backinvals, bi_writebacks" : "0, 0, 0", ver >= 8 ? ", last_size" : "");
    if (ver >= 6 && sqlite3_prepare_v2(sh->h, lvs_sql, -1, &sh->lvs, NULL) != SQLITE_OK)
        return shard_error(sh, e);
    return 0;
}

static void shard_close(shard *sh)
{
    sqlite3_finalize(sh->runs);
    sqlite3_finalize(sh->rows);
    sqlite3_finalize(sh->gens);
    sqlite3_finalize(sh->ses);
    sqlite3_finalize(sh->lvs);
    sqlite3_close(sh->h);
}

/* The current row of sh->runs as a run (strings point into the statement,
 * valid until its next step). */
static int read_run(const shard *sh, rt_db_run *r, int64_t *id, rt_err *e)
{
    sqlite3_stmt *st = sh->runs;
    char row[64];
    uint64_t v[6];
    *id = sqlite3_column_int64(st, 0);
    snprintf(row, sizeof row, "run %lld", (long long)*id);
    static const int cols[6] = {4, 6, 7, 8, 9, 10};
    for (int k = 0; k < 6; k++)
        if (count_col(sh, st, cols[k], row, &v[k], e)) return -1;
    if (count_col(sh, st, 15, row, &r->refs, e)) return -1;
    int wt = sqlite3_column_type(st, 19);
    if ((wt != SQLITE_INTEGER && wt != SQLITE_FLOAT) || sqlite3_column_double(st, 19) < 0)
        return rt_errf(e, "%s: %s: wall_time is '%s', not a number of seconds", sh->path, row, txt(st, 19));
    if (v[1] > 65536 || v[2] > 65536 || v[3] > UINT32_MAX || v[0] > UINT32_MAX)
        return rt_errf(e, "%s: %s: image size, lights or triangles out of range", sh->path, row);
    r->scene = txt(st, 1);
    r->scene_params = txt(st, 2);
    r->scene_hash = strtoull(txt(st, 3), NULL, 16);
    r->ntri = (uint32_t)v[0];
    r->tracer = txt(st, 5);
    r->W = (int)v[1];
    r->H = (int)v[2];
    r->lights = (uint32_t)v[3];
    r->sched_size = v[4];
    r->gmax = v[5];
    r->params = txt(st, 11);
    r->sim_method = txt(st, 12);
    r->sim_params = txt(st, 13);
    r->trace_hash = strtoull(txt(st, 14), NULL, 16);
    r->tool_version = txt(st, 16);
    r->git_rev = txt(st, 17);
    r->command = txt(st, 18);
    r->wall_time = sqlite3_column_double(st, 19);
    r->stats = txt(st, 20);
    r->scene_path = txt(st, 21);
    r->scene_abspath = txt(st, 22);
    uint64_t cores;
    if (count_col(sh, st, 25, row, &cores, e)) return -1;
    if (cores < 1 || cores > 65536) return rt_errf(e, "%s: %s: cores out of range (1..65536)", sh->path, row);
    r->repl = txt(st, 23);
    r->hierarchy = txt(st, 24);
    r->cores = (int)cores;
    r->light_model = txt(st, 26);
    r->instances = txt(st, 27);
    return 0;
}

/* The current row of st (sh->rows, or sh->gens when gen is non-NULL:
 * column 9 is the generation, no wt_bytes) as a traffic row (policy
 * strdup'd). */
static int read_row(const shard *sh, sqlite3_stmt *st, int64_t id, rt_db_traffic *t, int *gen, rt_err *e)
{
    char row[160];
    uint64_t v[9];
    if (gen)
        snprintf(row, sizeof row, "run %lld, generation row (size %s, class %s, gen %s)", (long long)id, txt(st, 0),
                 txt(st, 4), txt(st, 9));
    else
        snprintf(row, sizeof row, "run %lld, traffic row (size %s, class %s)", (long long)id, txt(st, 0), txt(st, 4));
    static const int cols[9] = {0, 1, 2, 5, 6, 7, 8, 9, 10};
    for (int k = 0; k < 9; k++)
        if (count_col(sh, st, cols[k], row, &v[k], e)) return -1;
    t->cls = rt_class_from_name(txt(st, 4));
    if (t->cls < 0) return rt_errf(e, "%s: %s: unknown class", sh->path, row);
    if (v[1] == 0 || v[1] > UINT32_MAX || v[2] > UINT32_MAX)
        return rt_errf(e, "%s: %s: line or assoc out of range", sh->path, row);
    t->size = v[0];
    t->line = (uint32_t)v[1];
    t->assoc = (uint32_t)v[2];
    t->accesses = v[3];
    t->read_misses = v[4];
    t->write_misses = v[5];
    t->writebacks = v[6];
    t->wt_bytes = gen ? 0 : v[7];
    t->traffic_bytes = v[8];
    if (gen) {
        if (v[7] >= RT_MAXGEN) return rt_errf(e, "%s: %s: generation out of range (0..%d)", sh->path, row, RT_MAXGEN - 1);
        *gen = (int)v[7];
    }
    if (!(t->policy = strdup(txt(st, 3)))) return rt_errf(e, "%s: out of memory", sh->path);
    return 0;
}

/* Reads run id's rows of st (sh->rows: rt_db_traffic, or sh->gens:
 * rt_db_gen, elements of size elem) into *rows (grown as needed); the row
 * count, or -1. */
static long read_rows(const shard *sh, sqlite3_stmt *st, int64_t id, void **rows, size_t *cap, size_t elem, rt_err *e)
{
    size_t n = 0;
    int step;
    sqlite3_reset(st);
    sqlite3_bind_int64(st, 1, id);
    while ((step = sqlite3_step(st)) == SQLITE_ROW) {
        if (n == *cap) {
            size_t nc = *cap ? 2 * *cap : 256;
            void *r2 = rt_reallocarray(*rows, nc, elem, e);
            if (!r2) goto fail;
            *rows = r2;
            *cap = nc;
        }
        rt_db_traffic *t = (rt_db_traffic *)((char *)*rows + n * elem);
        t->policy = NULL;
        if (read_row(sh, st, id, t, st == sh->gens ? &((rt_db_gen *)t)->gen : NULL, e)) goto fail;
        n++;
    }
    if (step == SQLITE_DONE) return (long)n;
    rt_errf(e, "%s: %s: %s", sh->path, rt_db_read_error_kind(step), sqlite3_errmsg(sh->h));
fail:
    for (size_t k = 0; k < n; k++) free((char *)((rt_db_traffic *)((char *)*rows + k * elem))->policy);
    return -1;
}

/* Reads run id's standard-error rows (sh->ses) into *ses (grown as needed;
 * policies strdup'd): each error NULL (stored back as none) or a
 * non-negative number. The row count, or -1. */
static long read_ses(const shard *sh, int64_t id, rt_db_se **ses, size_t *cap, rt_err *e)
{
    size_t n = 0;
    int step;
    sqlite3_stmt *st = sh->ses;
    sqlite3_reset(st);
    sqlite3_bind_int64(st, 1, id);
    while ((step = sqlite3_step(st)) == SQLITE_ROW) {
        if (n == *cap) {
            size_t nc = *cap ? 2 * *cap : 64;
            rt_db_se *r2 = rt_reallocarray(*ses, nc, sizeof *r2, e);
            if (!r2) goto fail;
            *ses = r2;
            *cap = nc;
        }
        rt_db_se *x = &(*ses)[n];
        char row[96];
        uint64_t v[3];
        snprintf(row, sizeof row, "run %lld, standard-error row (size %s)", (long long)id, txt(st, 0));
        for (int k = 0; k < 3; k++)
            if (count_col(sh, st, k, row, &v[k], e)) goto fail;
        if (v[1] == 0 || v[1] > UINT32_MAX || v[2] > UINT32_MAX) {
            rt_errf(e, "%s: %s: line or assoc out of range", sh->path, row);
            goto fail;
        }
        for (int g = 0; g < RT_DB_SE_N; g++) {
            int t = sqlite3_column_type(st, 4 + g);
            double d = sqlite3_column_double(st, 4 + g);
            if (t == SQLITE_NULL) d = -1;
            else if ((t != SQLITE_FLOAT && t != SQLITE_INTEGER) || !(d >= 0) || !isfinite(d)) {
                rt_errf(e, "%s: %s: %s is '%s', not a standard error in bytes", sh->path, row,
                        sqlite3_column_name(st, 4 + g), txt(st, 4 + g));
                goto fail;
            }
            x->se[g] = d;
        }
        x->size = v[0];
        x->line = (uint32_t)v[1];
        x->assoc = (uint32_t)v[2];
        if (!(x->policy = strdup(txt(st, 3)))) {
            rt_errf(e, "%s: out of memory", sh->path);
            goto fail;
        }
        n++;
    }
    if (step == SQLITE_DONE) return (long)n;
    rt_errf(e, "%s: %s: %s", sh->path, rt_db_read_error_kind(step), sqlite3_errmsg(sh->h));
fail:
    for (size_t k = 0; k < n; k++) free((char *)(*ses)[k].policy);
    return -1;
}

/* Frees the strings read_levels strdup'd in lv[0..n). */
static void free_levels(rt_db_level *lv, long n)
{
    for (long k = 0; k < n; k++) {
        free((char *)lv[k].level_name);
        free((char *)lv[k].policy);
        free((char *)lv[k].repl);
    }
}

/* Reads run id's per-level rows (sh->lvs) into *lv (grown as needed;
 * strings strdup'd): counts non-negative integers, level >= 1, core >= -1,
 * generation -1..RT_MAXGEN-1. The row count, or -1. */
static long read_levels(const shard *sh, int64_t id, rt_db_level **lv, size_t *cap, rt_err *e)
{
    size_t n = 0;
    int step;
    sqlite3_stmt *st = sh->lvs;
    sqlite3_reset(st);
    sqlite3_bind_int64(st, 1, id);
    while ((step = sqlite3_step(st)) == SQLITE_ROW) {
        if (n == *cap) {
            size_t nc = *cap ? 2 * *cap : 64;
            rt_db_level *r2 = rt_reallocarray(*lv, nc, sizeof *r2, e);
            if (!r2) goto fail;
            *lv = r2;
            *cap = nc;
        }
        rt_db_level *x = &(*lv)[n];
        memset(x, 0, sizeof *x);
        char row[128];
        snprintf(row, sizeof row, "run %lld, level row (level %s, size %s, class %s)", (long long)id, txt(st, 0),
                 txt(st, 3), txt(st, 8));
        static const int cols[11] = {0, 3, 4, 5, 10, 11, 12, 13, 14, 15, 16};
        uint64_t v[11];
        for (int k = 0; k < 11; k++)
            if (count_col(sh, st, cols[k], row, &v[k], e)) goto fail;
        sqlite3_int64 core = sqlite3_column_int64(st, 2), gen = sqlite3_column_int64(st, 9);
        if (sqlite3_column_type(st, 2) != SQLITE_INTEGER || sqlite3_column_type(st, 9) != SQLITE_INTEGER ||
            core < -1 || core > 65535 || gen < -1 || gen >= RT_MAXGEN || v[0] < 1 || v[0] > 64 || v[2] == 0 ||
            v[2] > UINT32_MAX || v[3] > UINT32_MAX) {
            rt_errf(e, "%s: %s: level, core, generation, line or assoc out of range", sh->path, row);
            goto fail;
        }
        x->cls = rt_class_from_name(txt(st, 8));
        if (x->cls < 0) {
            rt_errf(e, "%s: %s: unknown class", sh->path, row);
            goto fail;
        }
        x->level = (int)v[0];
        x->core = (int)core;
        x->gen = (int)gen;
        x->size = v[1];
        x->line = (uint32_t)v[2];
        x->assoc = (uint32_t)v[3];
        x->accesses = v[4];
        x->misses = v[5];
        x->writebacks = v[6];
        x->traffic_bytes = v[7];
        x->last_size = v[8];
        x->backinvals = v[9];
        x->bi_writebacks = v[10];
        n++;
        if (!(x->level_name = strdup(txt(st, 1))) || !(x->policy = strdup(txt(st, 6))) ||
            !(x->repl = strdup(txt(st, 7)))) {
            rt_errf(e, "%s: out of memory", sh->path);
            goto fail;
        }
    }
    if (step == SQLITE_DONE) return (long)n;
    rt_errf(e, "%s: %s", sh->path, sqlite3_errmsg(sh->h));
fail:
    free_levels(*lv, (long)n);
    return -1;
}

int rt_db_merge(rt_db *out, const char *inpath, long *nruns, rt_err *e)
{
    shard sh;
    rt_db_traffic *rows = NULL;
    rt_db_gen *gens = NULL;
    rt_db_se *ses = NULL;
    rt_db_level *lvs = NULL;
    size_t cap = 0, gcap = 0, scap = 0, lcap = 0;
    int rc = -1, step;
    *nruns = 0;
    if (shard_open(&sh, inpath, e)) goto done;
    while ((step = sqlite3_step(sh.runs)) == SQLITE_ROW) {
        rt_db_run run;
        int64_t id;
        memset(&run, 0, sizeof run);
        if (read_run(&sh, &run, &id, e)) goto done;
        long n = read_rows(&sh, sh.rows, id, (void **)&rows, &cap, sizeof *rows, e), ng = 0, ns = 0, nl = 0;
        if (n < 0) goto done;
        if (sh.gens && (ng = read_rows(&sh, sh.gens, id, (void **)&gens, &gcap, sizeof *gens, e)) < 0) ng = -1;
        else if (sh.ses && (ns = read_ses(&sh, id, &ses, &scap, e)) < 0) ns = -1;
        else if (sh.lvs && (nl = read_levels(&sh, id, &lvs, &lcap, e)) < 0) nl = -1;
        int st = -1;
        if (ng >= 0 && ns >= 0 && nl >= 0) {
            rt_db_rows R = {.traffic = rows, .ntraffic = (size_t)n, .gen = gens, .ngen = (size_t)ng, .se = ses,
                            .nse = (size_t)ns, .level = lvs, .nlevel = (size_t)nl};
            st = rt_db_store(out, &run, &R, NULL, e);
        }
        for (long k = 0; k < n; k++) free((char *)rows[k].policy);
        for (long k = 0; k < ng; k++) free((char *)gens[k].t.policy);
        for (long k = 0; k < ns; k++) free((char *)ses[k].policy);
        if (nl > 0) free_levels(lvs, nl);
        if (st < 0) goto done;
        (*nruns)++;
    }
    if (step != SQLITE_DONE) {
        rt_errf(e, "%s: %s: %s", inpath, rt_db_read_error_kind(step), sqlite3_errmsg(sh.h));
        goto done;
    }
    rc = 0;
done:
    free(rows);
    free(gens);
    free(ses);
    free(lvs);
    shard_close(&sh);
    return rc;
}
