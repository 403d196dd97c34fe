/*
 * db.c -- the SQLite results database (see db.h and docs/database.md).
 *
 * The schema lives in one string below (also shipped as
 * analysis/views.sql-style documentation in docs/database.md). Version 1.
 * Unsigned 64-bit hashes are stored as 16 lowercase hex digits, counters as
 * INTEGER (they stay far below 2^63).
 */
#include "db.h"
#include "memmodel.h"

#include <sqlite3.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

long rt_db_fail_row_after = 0;

static const char schema_sql[] =
    "CREATE TABLE IF NOT EXISTS scenes(\n"
    "  id INTEGER PRIMARY KEY,\n"
    "  name TEXT NOT NULL,                 -- scene spec (built-in name or file)\n"
    "  params TEXT NOT NULL DEFAULT '',    -- canonical scene parameters\n"
    "  hash TEXT NOT NULL,                 -- rt_scene_hash, 16 hex digits\n"
    "  triangles INTEGER NOT NULL DEFAULT 0,\n"
    "  UNIQUE(name, params, hash));\n"
    "CREATE TABLE IF NOT EXISTS runs(\n"
    "  id INTEGER PRIMARY KEY,\n"
    "  scene_id INTEGER NOT NULL REFERENCES scenes(id),\n"
    "  tracer TEXT NOT NULL,\n"
    "  W INTEGER NOT NULL,\n"
    "  H INTEGER NOT NULL,\n"
    "  lights INTEGER NOT NULL,            -- enabled-light mask\n"
    "  sched_cache_size INTEGER NOT NULL DEFAULT 0, -- cache size the trace was scheduled for (0 = n/a)\n"
    "  gmax INTEGER NOT NULL DEFAULT 0,    -- geometry budget (0 = n/a)\n"
    "  params TEXT NOT NULL DEFAULT '',    -- other tracer parameters\n"
    "  sim_method TEXT NOT NULL DEFAULT 'exact',\n"
    "  sim_params TEXT NOT NULL DEFAULT '',\n"
    "  trace_hash TEXT NOT NULL DEFAULT '', -- 16 hex digits; '' for in-process streams\n"
    "  refs INTEGER NOT NULL DEFAULT 0,    -- references simulated\n"
    "  tool_version TEXT NOT NULL DEFAULT '',\n"
    "  git_rev TEXT NOT NULL DEFAULT '',\n"
    "  command TEXT NOT NULL DEFAULT '',\n"
    "  wall_time REAL NOT NULL DEFAULT 0,  -- seconds\n"
    "  stats TEXT NOT NULL DEFAULT '',     -- tracer statistics, k=v k=v\n"
    "  created TEXT NOT NULL DEFAULT (strftime('%Y-%m-%dT%H:%M:%SZ','now')),\n"
    "  UNIQUE(scene_id, tracer, W, H, lights, sched_cache_size, gmax, params, sim_method, sim_params));\n"
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
    "  SELECT s.name AS scene, r.tracer, r.lights, r.W, r.H, r.sched_cache_size, g.cache_size,\n"
    "    g.geometry_mb, g.ray_mb\n"
    "  FROM v_traffic_group g JOIN runs r ON r.id = g.run_id JOIN scenes s ON s.id = r.scene_id\n"
    "  WHERE g.line = 64 AND g.assoc = 0 AND g.policy = 'wb-wa' AND r.sim_method = 'exact'\n"
    "    AND r.params NOT LIKE '%subsample=%';\n";

struct rt_db {
    sqlite3 *h;        /* connection */
    char *path;        /* for messages */
    sqlite3_stmt *st[16]; /* prepared statements, see enum */
};

enum {
    S_SCENE_INS, S_SCENE_GET, S_SCENE_TRI, S_RUN_GET, S_RUN_INS, S_RUN_UPD, S_CFG_INS, S_CFG_GET, S_TR_DEL,
    S_TR_INS, S_NSTMT
};

static const char *const stmt_sql[S_NSTMT] = {
    "INSERT OR IGNORE INTO scenes(name, params, hash, triangles) VALUES(?1, ?2, ?3, ?4)",
    "SELECT id FROM scenes WHERE name = ?1 AND params = ?2 AND hash = ?3",
    "UPDATE scenes SET triangles = ?2 WHERE id = ?1 AND ?2 > 0",
    "SELECT r.id FROM runs r JOIN scenes s ON s.id = r.scene_id WHERE s.name = ?1 AND s.params = ?2 AND s.hash = ?3"
    " AND r.tracer = ?4 AND r.W = ?5 AND r.H = ?6 AND r.lights = ?7 AND r.sched_cache_size = ?8 AND r.gmax = ?9"
    " AND r.params = ?10 AND r.sim_method = ?11 AND r.sim_params = ?12",
    "INSERT INTO runs(scene_id, tracer, W, H, lights, sched_cache_size, gmax, params, sim_method, sim_params,"
    " trace_hash, refs, tool_version, git_rev, command, wall_time, stats)"
    " VALUES(?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11, ?12, ?13, ?14, ?15, ?16, ?17)",
    "UPDATE runs SET trace_hash = ?2, refs = ?3, tool_version = ?4, git_rev = ?5, command = ?6, wall_time = ?7,"
    " stats = ?8, created = strftime('%Y-%m-%dT%H:%M:%SZ','now') WHERE id = ?1",
    "INSERT OR IGNORE INTO cache_configs(size, line, assoc, policy) VALUES(?1, ?2, ?3, ?4)",
    "SELECT id FROM cache_configs WHERE size = ?1 AND line = ?2 AND assoc = ?3 AND policy = ?4",
    "DELETE FROM traffic WHERE run_id = ?1 AND config_id = ?2",
    "INSERT INTO traffic(run_id, config_id, class, accesses, read_misses, write_misses, writebacks, wt_bytes,"
    " traffic_bytes) VALUES(?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9)",
};

const char *rt_db_schema_sql(void) { return schema_sql; }
void *rt_db_handle(rt_db *db) { return db->h; }

static int dberr(rt_db *db, rt_err *e, const char *what)
{
    return rt_errf(e, "%s: %s%s%s", db->path, what ? what : "", what ? ": " : "", sqlite3_errmsg(db->h));
}

static int exec(rt_db *db, const char *sql, rt_err *e)
{
    char *msg = NULL;
    if (sqlite3_exec(db->h, sql, NULL, NULL, &msg) != SQLITE_OK) {
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

static int create_schema(rt_db *db, rt_err *e)
{
    int64_t ver = 0;
    if (get_int(db, "PRAGMA user_version", &ver, e)) return -1;
    if (ver == RT_DB_SCHEMA_VERSION) return 0;
    if (ver > RT_DB_SCHEMA_VERSION)
        return rt_errf(e, "%s: database schema version %lld is newer than this raytraffic supports (%d)", db->path,
                       (long long)ver, RT_DB_SCHEMA_VERSION);
    if (exec(db, "BEGIN IMMEDIATE", e)) return -1;
    if (get_int(db, "PRAGMA user_version", &ver, e)) goto fail;
    if (ver == 0) { /* still empty: nobody created it in between */
        if (exec(db, schema_sql, e)) goto fail;
        char sql[128];
        for (int c = 0; c < RT_NCLASS; c++) {
            snprintf(sql, sizeof sql, "INSERT OR REPLACE INTO classes(name, grp) VALUES('%s', '%s')", rt_class_name(c),
                     rt_group_name(rt_class_group(c)));
            if (exec(db, sql, e)) goto fail;
        }
        snprintf(sql, sizeof sql, "PRAGMA user_version = %d", RT_DB_SCHEMA_VERSION);
        if (exec(db, sql, e)) goto fail;
    }
    if (exec(db, "COMMIT", e)) goto fail;
    return 0;
fail:
    sqlite3_exec(db->h, "ROLLBACK", NULL, NULL, NULL);
    return -1;
}

rt_db *rt_db_open(const char *path, rt_err *e)
{
    rt_db *db = rt_calloc(1, sizeof *db, e);
    if (!db) return NULL;
    db->path = strdup(path);
    if (!db->path) {
        free(db);
        rt_errf(e, "%s: out of memory", path);
        return NULL;
    }
    if (sqlite3_open_v2(path, &db->h, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE, NULL) != SQLITE_OK) {
        if (db->h) dberr(db, e, "cannot open database");
        else rt_errf(e, "%s: cannot open database", path);
        goto fail;
    }
    sqlite3_busy_timeout(db->h, 60000);
    if (sqlite3_db_readonly(db->h, "main") == 1) {
        rt_errf(e, "%s: database is not writable", path);
        goto fail;
    }
    if (exec(db, "PRAGMA foreign_keys = ON", e)) goto fail;
    /* journal_mode returns a row; a non-database file fails here */
    {
        sqlite3_stmt *st;
        if (sqlite3_prepare_v2(db->h, "PRAGMA journal_mode = WAL", -1, &st, NULL) != SQLITE_OK) {
            dberr(db, e, NULL);
            goto fail;
        }
        int rc = sqlite3_step(st);
        sqlite3_finalize(st);
        if (rc != SQLITE_ROW && rc != SQLITE_DONE) {
            dberr(db, e, NULL);
            goto fail;
        }
    }
    if (create_schema(db, e)) goto fail;
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

/* Binds the 12 identity parameters of S_RUN_GET. */
static void bind_key(sqlite3_stmt *st, const rt_db_run *r, char *hash)
{
    hex64(hash, r->scene_hash);
    sqlite3_bind_text(st, 1, nz(r->scene), -1, SQLITE_TRANSIENT);
    sqlite3_bind_text(st, 2, nz(r->scene_params), -1, SQLITE_TRANSIENT);
    sqlite3_bind_text(st, 3, hash, -1, SQLITE_TRANSIENT);
    sqlite3_bind_text(st, 4, nz(r->tracer), -1, SQLITE_TRANSIENT);
    sqlite3_bind_int(st, 5, r->W);
    sqlite3_bind_int(st, 6, r->H);
    sqlite3_bind_int64(st, 7, r->lights);
    sqlite3_bind_int64(st, 8, (sqlite3_int64)r->cache_size);
    sqlite3_bind_int64(st, 9, (sqlite3_int64)r->gmax);
    sqlite3_bind_text(st, 10, nz(r->params), -1, SQLITE_TRANSIENT);
    sqlite3_bind_text(st, 11, r->sim_method ? r->sim_method : "exact", -1, SQLITE_TRANSIENT);
    sqlite3_bind_text(st, 12, nz(r->sim_params), -1, SQLITE_TRANSIENT);
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

static int store(rt_db *db, const rt_db_run *r, const rt_db_traffic *rows, size_t n, int64_t *run_id, rt_err *e)
{
    char hash[17], thash[17];
    sqlite3_stmt **st = db->st;
    /* scene */
    hex64(hash, r->scene_hash);
    sqlite3_bind_text(st[S_SCENE_INS], 1, nz(r->scene), -1, SQLITE_TRANSIENT);
    sqlite3_bind_text(st[S_SCENE_INS], 2, nz(r->scene_params), -1, SQLITE_TRANSIENT);
    sqlite3_bind_text(st[S_SCENE_INS], 3, hash, -1, SQLITE_TRANSIENT);
    sqlite3_bind_int64(st[S_SCENE_INS], 4, r->ntri);
    if (step_id(db, st[S_SCENE_INS], NULL, e) < 0) return -1;
    int64_t scene_id = 0;
    sqlite3_bind_text(st[S_SCENE_GET], 1, nz(r->scene), -1, SQLITE_TRANSIENT);
    sqlite3_bind_text(st[S_SCENE_GET], 2, nz(r->scene_params), -1, SQLITE_TRANSIENT);
    sqlite3_bind_text(st[S_SCENE_GET], 3, hash, -1, SQLITE_TRANSIENT);
    if (step_id(db, st[S_SCENE_GET], &scene_id, e) != 1) return rt_errf(e, "%s: scene row vanished", db->path);
    sqlite3_bind_int64(st[S_SCENE_TRI], 1, scene_id);
    sqlite3_bind_int64(st[S_SCENE_TRI], 2, r->ntri);
    if (step_id(db, st[S_SCENE_TRI], NULL, e) < 0) return -1;
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
        if (step_id(db, u, NULL, e) < 0) return -1;
    } else {
        sqlite3_stmt *in = st[S_RUN_INS];
        sqlite3_bind_int64(in, 1, scene_id);
        sqlite3_bind_text(in, 2, nz(r->tracer), -1, SQLITE_TRANSIENT);
        sqlite3_bind_int(in, 3, r->W);
        sqlite3_bind_int(in, 4, r->H);
        sqlite3_bind_int64(in, 5, r->lights);
        sqlite3_bind_int64(in, 6, (sqlite3_int64)r->cache_size);
        sqlite3_bind_int64(in, 7, (sqlite3_int64)r->gmax);
        sqlite3_bind_text(in, 8, nz(r->params), -1, SQLITE_TRANSIENT);
        sqlite3_bind_text(in, 9, r->sim_method ? r->sim_method : "exact", -1, SQLITE_TRANSIENT);
        sqlite3_bind_text(in, 10, nz(r->sim_params), -1, SQLITE_TRANSIENT);
        sqlite3_bind_text(in, 11, thash, -1, SQLITE_TRANSIENT);
        sqlite3_bind_int64(in, 12, (sqlite3_int64)r->refs);
        sqlite3_bind_text(in, 13, ver, -1, SQLITE_TRANSIENT);
        sqlite3_bind_text(in, 14, rev, -1, SQLITE_TRANSIENT);
        sqlite3_bind_text(in, 15, nz(r->command), -1, SQLITE_TRANSIENT);
        sqlite3_bind_double(in, 16, r->wall_time);
        sqlite3_bind_text(in, 17, nz(r->stats), -1, SQLITE_TRANSIENT);
        if (step_id(db, in, NULL, e) < 0) return -1;
        rid = sqlite3_last_insert_rowid(db->h);
    }
    /* configurations: first drop this run's old rows of every configuration
     * being stored, then insert (rows of one configuration are adjacent) */
    for (int pass = 0; pass < 2; pass++) {
        int64_t cfg_id = -1;
        const rt_db_traffic *prev = NULL;
        for (size_t i = 0; i < n; i++) {
            const rt_db_traffic *t = &rows[i];
            const char *cname = rt_class_name(t->cls);
            if (!cname) return rt_errf(e, "%s: traffic row %zu has bad class %d", db->path, i, t->cls);
            if (!prev || prev->size != t->size || prev->line != t->line || prev->assoc != t->assoc ||
                strcmp(nz(prev->policy), nz(t->policy))) {
                for (int k = S_CFG_INS; k <= S_CFG_GET; k++) {
                    sqlite3_bind_int64(st[k], 1, (sqlite3_int64)t->size);
                    sqlite3_bind_int64(st[k], 2, t->line);
                    sqlite3_bind_int64(st[k], 3, t->assoc);
                    sqlite3_bind_text(st[k], 4, t->policy ? t->policy : "wb-wa", -1, SQLITE_TRANSIENT);
                }
                if (step_id(db, st[S_CFG_INS], NULL, e) < 0) return -1;
                if (step_id(db, st[S_CFG_GET], &cfg_id, e) != 1)
                    return rt_errf(e, "%s: config row vanished", db->path);
                if (pass == 0) {
                    sqlite3_bind_int64(st[S_TR_DEL], 1, rid);
                    sqlite3_bind_int64(st[S_TR_DEL], 2, cfg_id);
                    if (step_id(db, st[S_TR_DEL], NULL, e) < 0) return -1;
                }
                prev = t;
            }
            if (pass == 0) continue;
            if (rt_db_fail_row_after > 0 && --rt_db_fail_row_after == 0)
                return rt_errf(e, "%s: injected failure at traffic row %zu", db->path, i);
            sqlite3_stmt *in = st[S_TR_INS];
            sqlite3_bind_int64(in, 1, rid);
            sqlite3_bind_int64(in, 2, cfg_id);
            sqlite3_bind_text(in, 3, cname, -1, SQLITE_STATIC);
            sqlite3_bind_int64(in, 4, (sqlite3_int64)t->accesses);
            sqlite3_bind_int64(in, 5, (sqlite3_int64)t->read_misses);
            sqlite3_bind_int64(in, 6, (sqlite3_int64)t->write_misses);
            sqlite3_bind_int64(in, 7, (sqlite3_int64)t->writebacks);
            sqlite3_bind_int64(in, 8, (sqlite3_int64)t->wt_bytes);
            sqlite3_bind_int64(in, 9, (sqlite3_int64)t->traffic_bytes);
            if (step_id(db, in, NULL, e) < 0) return -1;
        }
    }
    if (run_id) *run_id = rid;
    return 0;
}

int rt_db_store_run(rt_db *db, const rt_db_run *run, const rt_db_traffic *rows, size_t n, int64_t *run_id, rt_err *e)
{
    if (exec(db, "BEGIN IMMEDIATE", e)) return -1;
    if (store(db, run, rows, n, run_id, e) < 0) {
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
