/*
 * test_db.c -- the results database: schema, idempotent stores, rollback of
 * a failed store, concurrent writers (fork), views, error messages, the
 * upgrade of a version-1 file, refusal of foreign files, merge checks,
 * per-generation rows (they sum to the traffic rows; the v3 -> v4 upgrade;
 * merge copies and checks them), standard-error rows (the v4 -> v5 upgrade
 * from version 4's own schema; stored, replaced, rolled back, refused when
 * not a number, merged).
 */
#include "check.h"
#include "rows.h"
#include "memmodel.h"
#include "sim.h"
#include "stats.h"

#include <math.h>
#include <sqlite3.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

static long long count(rt_db *db, const char *sql)
{
    sqlite3_stmt *st;
    long long v = -1;
    if (sqlite3_prepare_v2(rt_db_handle(db), sql, -1, &st, NULL) == SQLITE_OK && sqlite3_step(st) == SQLITE_ROW)
        v = sqlite3_column_int64(st, 0);
    sqlite3_finalize(st);
    return v;
}

static double getd(rt_db *db, const char *sql)
{
    sqlite3_stmt *st;
    double v = -1;
    if (sqlite3_prepare_v2(rt_db_handle(db), sql, -1, &st, NULL) == SQLITE_OK && sqlite3_step(st) == SQLITE_ROW)
        v = sqlite3_column_double(st, 0);
    sqlite3_finalize(st);
    return v;
}

/* 13 sizes x 3 classes: 1M rays x 32 B of ray traffic, 2M tri line fetches */
static size_t make_rows(rt_db_traffic *rows)
{
    size_t n = 0;
    for (int i = 0; i < 13; i++) {
        const int cls[3] = {RT_CLS_NODE, RT_CLS_TRI, RT_CLS_RAY};
        for (int k = 0; k < 3; k++) {
            rt_db_traffic *t = &rows[n++];
            memset(t, 0, sizeof *t);
            t->size = 1024ULL << i;
            t->line = 64;
            t->assoc = 0;
            t->policy = "wb-wa";
            t->cls = cls[k];
            t->accesses = 5000000;
            if (cls[k] == RT_CLS_RAY) t->traffic_bytes = 1048576ULL * 32; /* 32.00 MB */
            else if (cls[k] == RT_CLS_TRI) t->traffic_bytes = 64ULL * 100000;
            else t->traffic_bytes = 64ULL * 1000;
            t->read_misses = t->traffic_bytes / 64;
        }
    }
    return n;
}

static void run_key(rt_db_run *r, const char *tracer, uint32_t lights, uint64_t cache)
{
    memset(r, 0, sizeof *r);
    r->scene = "room";
    r->scene_params = "";
    r->scene_hash = 0xfedcba9876543210ULL;
    r->ntri = 47000;
    r->tracer = tracer;
    r->W = 1024;
    r->H = 1024;
    r->lights = lights;
    r->sched_size = cache;
    r->refs = 123456789;
    r->trace_hash = 0x8000000000000001ULL;
    r->command = "test_db";
}


/* Version 1's schema, as raytraffic 1 created it (the runs column was
 * sched_cache_size), with one dynamic run: the input of the upgrade test. */
static const char v1_schema_sql[] =
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
    "    AND r.params NOT LIKE '%subsample=%';\n"
    "INSERT INTO classes(name, grp) VALUES('tri', 'geometry'), ('ray', 'ray');\n"
    "INSERT INTO scenes(name, params, hash, triangles) VALUES('room', '', 'fedcba9876543210', 47000);\n"
    "INSERT INTO runs(scene_id, tracer, W, H, lights, sched_cache_size, params) VALUES(1, 'dynamic', 64, 64, 7, 65536,"
    " 'qorder=fullest threads=4');\n"
    "INSERT INTO cache_configs(size, line, assoc, policy) VALUES(4096, 64, 0, 'wb-wa');\n"
    "INSERT INTO traffic VALUES(1, 1, 'tri', 100, 10, 0, 0, 0, 640), (1, 1, 'ray', 50, 5, 5, 2, 0, 768);\n"
    "PRAGMA user_version = 1;\n";

/* Runs sql on a new SQLite file at path (not through rt_db). */
static int make_file(const char *path, const char *sql)
{
    sqlite3 *h;
    int rc = sqlite3_open(path, &h) == SQLITE_OK && sqlite3_exec(h, sql, NULL, NULL, NULL) == SQLITE_OK ? 0 : -1;
    sqlite3_close(h);
    return rc;
}

/* A version-1 file is upgraded in place: column renamed, key and views
 * follow, the old name still reads, and the run is found by its key. */
/* Version 2's schema and one run, as raytraffic 2 wrote them (sqlite3
 * .dump of `sim --db` on a din file): the input of the v2 -> v3 upgrade. */
static const char v2_file_sql[] =
    "CREATE TABLE scenes(\n"
    "  id INTEGER PRIMARY KEY,\n"
    "  name TEXT NOT NULL,                 -- scene spec (built-in name or file)\n"
    "  params TEXT NOT NULL DEFAULT '',    -- canonical scene parameters\n"
    "  hash TEXT NOT NULL,                 -- rt_scene_hash, 16 hex digits\n"
    "  triangles INTEGER NOT NULL DEFAULT 0,\n"
    "  UNIQUE(name, params, hash));\n"
    "INSERT INTO scenes VALUES(1,'din:w1.din','','8919f9225eb6d004',0);\n"
    "CREATE TABLE runs(\n"
    "  id INTEGER PRIMARY KEY,\n"
    "  scene_id INTEGER NOT NULL REFERENCES scenes(id),\n"
    "  tracer TEXT NOT NULL,\n"
    "  W INTEGER NOT NULL,\n"
    "  H INTEGER NOT NULL,\n"
    "  lights INTEGER NOT NULL,            -- enabled-light mask\n"
    "  sched_size INTEGER NOT NULL DEFAULT 0, -- cache size the trace was scheduled for (0 = n/a)\n"
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
    "  sched_cache_size INTEGER GENERATED ALWAYS AS (sched_size) VIRTUAL,\n"
    "  UNIQUE(scene_id, tracer, W, H, lights, sched_size, gmax, params, sim_method, sim_params));\n"
    "INSERT INTO runs VALUES(1,1,'din',0,0,0,0,0,'din_class=fb','exact','','8919f9225eb6d004',1704,'0.1.0','b91ca29ca6b7','/tmp/build-jobs/raytraffic sim --db v2.db w1.din',0.00015235199953167466446,'','2026-12-01T18:39:24Z');\n"
    "CREATE TABLE cache_configs(\n"
    "  id INTEGER PRIMARY KEY,\n"
    "  size INTEGER NOT NULL,              -- bytes\n"
    "  line INTEGER NOT NULL,              -- bytes\n"
    "  assoc INTEGER NOT NULL,             -- ways; 0 = fully associative\n"
    "  policy TEXT NOT NULL,               -- wb-wa | wb-nwa | wt-wa | wt-nwa\n"
    "  UNIQUE(size, line, assoc, policy));\n"
    "INSERT INTO cache_configs VALUES(1,1024,64,0,'wb-wa');\n"
    "INSERT INTO cache_configs VALUES(2,2048,64,0,'wb-wa');\n"
    "INSERT INTO cache_configs VALUES(3,4096,64,0,'wb-wa');\n"
    "INSERT INTO cache_configs VALUES(4,8192,64,0,'wb-wa');\n"
    "INSERT INTO cache_configs VALUES(5,16384,64,0,'wb-wa');\n"
    "INSERT INTO cache_configs VALUES(6,32768,64,0,'wb-wa');\n"
    "INSERT INTO cache_configs VALUES(7,65536,64,0,'wb-wa');\n"
    "INSERT INTO cache_configs VALUES(8,131072,64,0,'wb-wa');\n"
    "INSERT INTO cache_configs VALUES(9,262144,64,0,'wb-wa');\n"
    "INSERT INTO cache_configs VALUES(10,524288,64,0,'wb-wa');\n"
    "INSERT INTO cache_configs VALUES(11,1048576,64,0,'wb-wa');\n"
    "INSERT INTO cache_configs VALUES(12,2097152,64,0,'wb-wa');\n"
    "INSERT INTO cache_configs VALUES(13,4194304,64,0,'wb-wa');\n"
    "CREATE TABLE classes(\n"
    "  name TEXT PRIMARY KEY,              -- memory-model class\n"
    "  grp TEXT NOT NULL);\n"
    "INSERT INTO classes VALUES('node','geometry');\n"
    "INSERT INTO classes VALUES('index','geometry');\n"
    "INSERT INTO classes VALUES('tri','geometry');\n"
    "INSERT INTO classes VALUES('shade','geometry');\n"
    "INSERT INTO classes VALUES('ray','ray');\n"
    "INSERT INTO classes VALUES('queue','ray');\n"
    "INSERT INTO classes VALUES('qtable','ray');\n"
    "INSERT INTO classes VALUES('hit','ray');\n"
    "INSERT INTO classes VALUES('stream','ray');\n"
    "INSERT INTO classes VALUES('fb','other');\n"
    "CREATE TABLE traffic(\n"
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
    "INSERT INTO traffic VALUES(1,1,'fb',1704,249,45,43,0,21568);\n"
    "INSERT INTO traffic VALUES(1,2,'fb',1704,100,26,19,0,9280);\n"
    "INSERT INTO traffic VALUES(1,3,'fb',1704,79,18,6,0,6592);\n"
    "INSERT INTO traffic VALUES(1,4,'fb',1704,76,12,0,0,5632);\n"
    "INSERT INTO traffic VALUES(1,5,'fb',1704,76,12,0,0,5632);\n"
    "INSERT INTO traffic VALUES(1,6,'fb',1704,76,12,0,0,5632);\n"
    "INSERT INTO traffic VALUES(1,7,'fb',1704,76,12,0,0,5632);\n"
    "INSERT INTO traffic VALUES(1,8,'fb',1704,76,12,0,0,5632);\n"
    "INSERT INTO traffic VALUES(1,9,'fb',1704,76,12,0,0,5632);\n"
    "INSERT INTO traffic VALUES(1,10,'fb',1704,76,12,0,0,5632);\n"
    "INSERT INTO traffic VALUES(1,11,'fb',1704,76,12,0,0,5632);\n"
    "INSERT INTO traffic VALUES(1,12,'fb',1704,76,12,0,0,5632);\n"
    "INSERT INTO traffic VALUES(1,13,'fb',1704,76,12,0,0,5632);\n"
    "CREATE INDEX traffic_config ON traffic(config_id);\n"
    "CREATE VIEW v_traffic_group AS\n"
    "  SELECT t.run_id, t.config_id, c.size AS cache_size, c.line, c.assoc, c.policy,\n"
    "    SUM(CASE WHEN k.grp = 'geometry' THEN t.traffic_bytes ELSE 0 END) / 1048576.0 AS geometry_mb,\n"
    "    SUM(CASE WHEN k.grp = 'ray' THEN t.traffic_bytes ELSE 0 END) / 1048576.0 AS ray_mb,\n"
    "    SUM(CASE WHEN k.grp = 'other' THEN t.traffic_bytes ELSE 0 END) / 1048576.0 AS other_mb,\n"
    "    SUM(t.traffic_bytes) / 1048576.0 AS total_mb\n"
    "  FROM traffic t JOIN cache_configs c ON c.id = t.config_id JOIN classes k ON k.name = t.class\n"
    "  GROUP BY t.run_id, t.config_id;\n"
    "CREATE VIEW v_paper AS\n"
    "  SELECT s.name AS scene, r.tracer, r.lights, r.W, r.H, r.sched_size, g.cache_size,\n"
    "    g.geometry_mb, g.ray_mb, r.sched_size AS sched_cache_size\n"
    "  FROM v_traffic_group g JOIN runs r ON r.id = g.run_id JOIN scenes s ON s.id = r.scene_id\n"
    "  WHERE g.line = 64 AND g.assoc = 0 AND g.policy = 'wb-wa' AND r.sim_method = 'exact'\n"
    "    AND r.params NOT LIKE '%subsample=%';\n"
    "PRAGMA user_version = 2;\n";

/* Column names of a table, comma-separated, in order. */
static void columns(rt_db *db, const char *table, char *buf, size_t n)
{
    char sql[160];
    sqlite3_stmt *st;
    snprintf(sql, sizeof sql, "SELECT group_concat(name) FROM pragma_table_info('%s')", table);
    buf[0] = 0;
    if (sqlite3_prepare_v2(rt_db_handle(db), sql, -1, &st, NULL) == SQLITE_OK && sqlite3_step(st) == SQLITE_ROW)
        snprintf(buf, n, "%s", (const char *)sqlite3_column_text(st, 0));
    sqlite3_finalize(st);
}

/* A version-2 file is upgraded in place: its run kept, scenes gain path
 * and abspath ('' for old rows) in the layout of a fresh file; storing a
 * run with a mesh path fills them in without making a new scene or run. */
static void test_upgrade_v2(const char *dir)
{
    char path[300], fresh[300], a[512], b[512];
    rt_err e = {0};
    snprintf(path, sizeof path, "%s/v2.db", dir);
    snprintf(fresh, sizeof fresh, "%s/v3fresh.db", dir);
    CHECK(make_file(path, v2_file_sql) == 0, "create v2 file");
    rt_db *db = rt_db_open(path, &e), *f = rt_db_open(fresh, &e);
    CHECK(db && f, "open v2: %s", e.msg);
    if (!db || !f) return;
    CHECK(count(db, "PRAGMA user_version") == RT_DB_SCHEMA_VERSION, "v2 upgraded to the current version");
    CHECK(count(db, "SELECT count(*) FROM runs") == 1 && count(db, "SELECT count(*) FROM traffic") == 13,
          "v2 run kept (13 sizes x class fb)");
    CHECK(count(db, "SELECT count(*) FROM scenes WHERE path = '' AND abspath = ''") == 1, "old scene has no path");
    const char *tables[] = {"scenes", "runs", "traffic", "v_paper", "v_traffic_group"};
    for (int i = 0; i < 5; i++) {
        columns(db, tables[i], a, sizeof a);
        columns(f, tables[i], b, sizeof b);
        CHECK(!strcmp(a, b), "%s: upgraded columns %s, fresh %s", tables[i], a, b);
    }
    /* the v2 run again, now with the place of its (din) file */
    sqlite3_stmt *st;
    sqlite3_prepare_v2(rt_db_handle(db),
                       "SELECT s.name, s.hash, r.params FROM runs r JOIN scenes s ON s.id = r.scene_id", -1, &st,
                       NULL);
    CHECK(sqlite3_step(st) == SQLITE_ROW, "v2 run row");
    rt_db_run r;
    memset(&r, 0, sizeof r);
    /* copies: the column texts die with the statement, finalized below */
    char *scene = strdup((const char *)sqlite3_column_text(st, 0));
    char *params = strdup((const char *)sqlite3_column_text(st, 2));
    r.scene = scene;
    r.scene_hash = strtoull((const char *)sqlite3_column_text(st, 1), NULL, 16);
    r.tracer = "din";
    r.params = params;
    r.scene_path = "x/w1.din";
    r.scene_abspath = "/data/x/w1.din";
    rt_db_traffic t = {1024, 64, 0, "wb-wa", RT_CLS_FB, 10, 1, 0, 0, 0, 64};
    CHECK(rt_db_has_run(db, &r, &e) == 1, "v2 run found by its key");
    CHECK(rt_db_store_run(db, &r, &t, 1, NULL, &e) == 0, "store into upgraded: %s", e.msg);
    sqlite3_finalize(st);
    CHECK(count(db, "SELECT count(*) FROM runs") == 1 && count(db, "SELECT count(*) FROM scenes") == 1,
          "paths are not identity: still one scene and one run");
    CHECK(count(db, "SELECT count(*) FROM scenes WHERE path = 'x/w1.din' AND abspath = '/data/x/w1.din'") == 1,
          "path and abspath stored");
    r.scene_path = r.scene_abspath = NULL; /* a replayed trace does not know: the place stays */
    CHECK(rt_db_store_run(db, &r, &t, 1, NULL, &e) == 0, "store without path");
    CHECK(count(db, "SELECT count(*) FROM scenes WHERE abspath = '/data/x/w1.din'") == 1, "abspath kept");
    free(scene);
    free(params);
    rt_db_close(db);
    rt_db_close(f);
}

static void test_upgrade_v1(const char *dir)
{
    char path[300];
    rt_err e = {0};
    snprintf(path, sizeof path, "%s/v1.db", dir);
    CHECK(make_file(path, v1_schema_sql) == 0, "create v1 file");
    rt_db *db = rt_db_open(path, &e);
    CHECK(db, "open v1: %s", e.msg);
    if (!db) return;
    CHECK(count(db, "PRAGMA user_version") == RT_DB_SCHEMA_VERSION, "upgraded to the current version");
    CHECK(count(db, "SELECT sched_size FROM runs") == 65536, "sched_size carries the old value");
    CHECK(count(db, "SELECT sched_cache_size FROM runs") == 65536, "old name reads as an alias");
    CHECK(count(db, "SELECT sched_size FROM v_paper WHERE cache_size = 4096") == 65536, "v_paper has sched_size");
    CHECK(getd(db, "SELECT ray_mb FROM v_paper") == 768 / 1048576.0, "v_paper ray_mb after upgrade");
    rt_db_run r;
    memset(&r, 0, sizeof r);
    r.scene = "room";
    r.scene_hash = 0xfedcba9876543210ULL;
    r.tracer = "dynamic";
    r.W = r.H = 64;
    r.lights = 7;
    r.sched_size = 65536;
    r.params = "qorder=fullest threads=4";
    CHECK(rt_db_has_run(db, &r, &e) == 1, "upgraded run found by its key: %s", e.msg);
    rt_db_traffic t = {4096, 64, 0, "wb-wa", RT_CLS_RAY, 60, 6, 6, 3, 0, 960};
    CHECK(rt_db_store_run(db, &r, &t, 1, NULL, &e) == 0, "store into upgraded: %s", e.msg);
    CHECK(count(db, "SELECT count(*) FROM runs") == 1, "the unique key still holds after the rename");
    CHECK(count(db, "SELECT traffic_bytes FROM traffic WHERE class = 'ray'") == 960, "row replaced");
    /* same layout as a fresh file: column names in order */
    sqlite3_stmt *st;
    sqlite3_prepare_v2(rt_db_handle(db), "SELECT group_concat(name, ' ') FROM pragma_table_xinfo('runs')", -1, &st,
                       NULL);
    sqlite3_step(st);
    const char *cols = (const char *)sqlite3_column_text(st, 0);
    CHECK(cols && !strcmp(cols, "id scene_id tracer W H lights sched_size gmax params sim_method sim_params trace_hash "
                                "refs tool_version git_rev command wall_time stats created repl hierarchy cores light_model "
                                "instances sched_cache_size stats_json"),
          "upgraded runs columns: %s", cols ? cols : "(none)");
    sqlite3_finalize(st);
    rt_db_close(db);
}

/* An unrelated SQLite file is refused and left as it was. */
static void test_foreign(const char *dir)
{
    char path[300];
    rt_err e = {0};
    snprintf(path, sizeof path, "%s/other.db", dir);
    CHECK(make_file(path, "CREATE TABLE notes(x TEXT); INSERT INTO notes VALUES('keep me');") == 0, "create foreign");
    struct stat a, b;
    stat(path, &a);
    CHECK(!rt_db_open(path, &e), "a foreign file was opened");
    CHECK(strstr(e.msg, path) && strstr(e.msg, "notes"), "message names the file and its table: %s", e.msg);
    stat(path, &b);
    CHECK(a.st_size == b.st_size && a.st_mtime == b.st_mtime, "foreign file touched");
    sqlite3 *h;
    sqlite3_open(path, &h);
    sqlite3_stmt *st;
    sqlite3_prepare_v2(h, "SELECT count(*) FROM sqlite_master", -1, &st, NULL);
    sqlite3_step(st);
    CHECK(sqlite3_column_int(st, 0) == 1, "tables were added to a foreign file");
    sqlite3_finalize(st);
    sqlite3_close(h);
    /* a newer schema version is refused too */
    snprintf(path, sizeof path, "%s/newer.db", dir);
    char newer[64];
    snprintf(newer, sizeof newer, "PRAGMA user_version = %d;", RT_DB_SCHEMA_VERSION + 1);
    CHECK(make_file(path, newer) == 0, "create newer");
    CHECK(!rt_db_open(path, &e) && strstr(e.msg, "newer"), "newer schema: %s", e.msg);
}

/* A simulator fed a random stream of several generations: its generation
 * rows sum to its traffic rows in every field, once stored (SQL sums) and
 * per generation the accesses equal a plain count of the line touches. */
static void test_gen_rows(const char *dir)
{
    char path[300];
    rt_err e = {0};
    snprintf(path, sizeof path, "%s/gen.db", dir);
    rt_sim_config c;
    rt_sim_config_default(&c);
    rt_sim *s = rt_sim_new(&c, NULL);
    uint64_t touches[RT_MAXGEN] = {0};
    rnd_seed(7);
    for (int i = 0; i < 200000; i++) {
        /* 1 MiB of addresses: misses at small sizes, hits at large */
        int gen = (int)(rnd64() % 10), cls = (int)(rnd64() % RT_NCLASS);
        uint32_t size = 1 + (uint32_t)(rnd64() % 100);
        uint64_t addr = 0x10000000ULL + rnd64() % (1u << 20);
        rt_access a = {addr, size, (uint8_t)(rnd64() % 3 == 0), (uint8_t)cls, (uint8_t)gen};
        touches[rt_gen_bucket((unsigned)gen)] += (addr + size - 1) / 64 - addr / 64 + 1;
        rt_sim_put(s, &a, 1);
    }
    rt_db_traffic *tr = calloc((size_t)c.nsizes * RT_NCLASS, sizeof *tr);
    rt_db_gen *gr = calloc((size_t)c.nsizes * RT_NCLASS * RT_MAXGEN, sizeof *gr);
    size_t n = rt_sim_db_rows(s, tr), ng = rt_sim_db_gen_rows(s, gr);
    CHECK(n == (size_t)c.nsizes * RT_NCLASS, "traffic rows %zu", n);
    CHECK(ng == (size_t)c.nsizes * RT_NCLASS * RT_MAXGEN, "generation rows %zu (every bucket used)", ng);
    uint64_t got[RT_MAXGEN] = {0};
    for (size_t k = 0; k < ng; k++)
        if (gr[k].t.size == c.sizes[0]) got[gr[k].gen] += gr[k].t.accesses;
    for (int g = 0; g < RT_MAXGEN; g++) CHECK(got[g] == touches[g], "gen %d: %llu accesses, counted %llu", g,
                                              (unsigned long long)got[g], (unsigned long long)touches[g]);
    rt_db *db = rt_db_open(path, &e);
    rt_db_run r;
    run_key(&r, "stream", 7, 0);
    CHECK(db && rt_db_store_run_gen(db, &r, tr, n, gr, ng, NULL, &e) == 0, "store gen rows: %s", e.msg);
    CHECK(count(db, "SELECT count(*) FROM traffic_gen") == (long long)ng, "all generation rows stored");
    static const char sum_sql[] =
        "SELECT count(*) FROM traffic t JOIN (SELECT run_id, config_id, class, sum(accesses) a, sum(read_misses) rm,"
        " sum(write_misses) wm, sum(writebacks) wb, sum(traffic_bytes) tb FROM traffic_gen GROUP BY 1, 2, 3) g"
        " USING (run_id, config_id, class) WHERE g.a = t.accesses AND g.rm = t.read_misses AND"
        " g.wm = t.write_misses AND g.wb = t.writebacks AND g.tb = t.traffic_bytes";
    CHECK(count(db, sum_sql) == (long long)n, "generation rows sum to every traffic row (%lld of %zu)",
          count(db, sum_sql), n);
    CHECK(count(db, "SELECT count(*) FROM traffic_gen WHERE writebacks > 0 AND gen = 7") > 0, "pooled bucket has data");
    /* v_gen: per generation, its group sums */
    CHECK(getd(db, "SELECT sum(total_mb) FROM v_gen WHERE cache_size = 1024") * 1048576.0 ==
              (double)count(db, "SELECT sum(traffic_bytes) FROM traffic t JOIN cache_configs c ON c.id = t.config_id"
                                " WHERE c.size = 1024"),
          "v_gen totals");
    CHECK(count(db, "SELECT count(*) FROM v_gen WHERE mode = 'shadow'") == (long long)c.nsizes * RT_MAXGEN,
          "v_gen: one row per size and generation, mode shadow");
    /* storing again without generations leaves no stale generation rows */
    CHECK(rt_db_store_run(db, &r, tr, n, NULL, &e) == 0, "store again without generations");
    CHECK(count(db, "SELECT count(*) FROM traffic_gen") == 0, "stale generation rows removed");
    CHECK(rt_db_store_run_gen(db, &r, tr, n, gr, ng, NULL, &e) == 0, "store with generations again");
    /* a bad generation is refused and rolled back */
    gr[3].gen = RT_MAXGEN;
    run_key(&r, "stream", 3, 0);
    CHECK(rt_db_store_run_gen(db, &r, tr, n, gr, ng, NULL, &e) < 0 && strstr(e.msg, "generation"), "bad gen: %s",
          e.msg);
    CHECK(count(db, "SELECT count(*) FROM runs WHERE lights = 3") == 0, "bad gen run rolled back");
    gr[3].gen = 0;
    rt_db_close(db);

    /* merge copies the generation rows; a shard's bad generation is refused */
    char out[300];
    long nr = 0;
    snprintf(out, sizeof out, "%s/genm.db", dir);
    rt_db *m = rt_db_open(out, &e);
    CHECK(m && rt_db_merge(m, path, &nr, &e) == 0 && nr == 1, "merge gen shard: %s", e.msg);
    CHECK(count(m, "SELECT count(*) FROM traffic_gen") == (long long)ng, "merged generation rows");
    CHECK(count(m, sum_sql) == (long long)n, "merged generation rows still sum");
    sqlite3 *h;
    sqlite3_open(path, &h);
    sqlite3_exec(h, "UPDATE traffic_gen SET gen = 9 WHERE rowid = 2", NULL, NULL, NULL);
    sqlite3_close(h);
    sqlite3_exec(rt_db_handle(m), "DELETE FROM runs", NULL, NULL, NULL);
    CHECK(rt_db_merge(m, path, &nr, &e) < 0 && strstr(e.msg, path) && strstr(e.msg, "generation row") &&
              strstr(e.msg, "out of range"), "bad shard generation: %s", e.msg);
    CHECK(count(m, "SELECT count(*) FROM runs") == 0, "nothing of the bad run stored");
    sqlite3_open(path, &h);
    sqlite3_exec(h, "UPDATE traffic_gen SET gen = 1, accesses = -1 WHERE rowid = 2", NULL, NULL, NULL);
    sqlite3_close(h);
    CHECK(rt_db_merge(m, path, &nr, &e) < 0 && strstr(e.msg, "accesses is negative"), "negative gen count: %s",
          e.msg);
    rt_db_close(m);
    free(tr);
    free(gr);
    rt_sim_free(s);
}

/* A version-3 file (today's schema without traffic_gen and v_gen, which is
 * all version 4 adds) is upgraded in place: its run and rows kept, the new
 * table and view in the layout of a fresh file, generation rows storable. */
static void test_upgrade_v3(const char *dir, const rt_db_traffic *rows, size_t n)
{
    char path[300], fresh[300], a[1024], b[1024];
    rt_err e = {0};
    snprintf(path, sizeof path, "%s/v3.db", dir);
    snprintf(fresh, sizeof fresh, "%s/v4fresh.db", dir);
    rt_db *db = rt_db_open(path, &e);
    rt_db_run r;
    run_key(&r, "recursive", 1, 0);
    CHECK(db && rt_db_store_run(db, &r, rows, n, NULL, &e) == 0, "v3 run: %s", e.msg);
    rt_db_close(db);
    sqlite3 *h;
    sqlite3_open(path, &h);
    CHECK(sqlite3_exec(h, "DROP VIEW v_gen; DROP TABLE traffic_gen; PRAGMA user_version = 3", NULL, NULL, NULL) ==
              SQLITE_OK, "make a v3 file");
    sqlite3_close(h);
    db = rt_db_open(path, &e);
    rt_db *f = rt_db_open(fresh, &e);
    CHECK(db && f, "open v3: %s", e.msg);
    if (!db || !f) return;
    CHECK(count(db, "PRAGMA user_version") == RT_DB_SCHEMA_VERSION, "v3 upgraded to the current version");
    CHECK(count(db, "SELECT count(*) FROM runs") == 1 && count(db, "SELECT count(*) FROM traffic") == (long long)n,
          "v3 run kept");
    const char *tables[] = {"traffic_gen", "v_gen", "runs", "traffic", "v_paper"};
    for (int i = 0; i < 5; i++) {
        columns(db, tables[i], a, sizeof a);
        columns(f, tables[i], b, sizeof b);
        CHECK(a[0] && !strcmp(a, b), "%s: upgraded columns %s, fresh %s", tables[i], a, b);
    }
    rt_db_gen g[2];
    memset(g, 0, sizeof g);
    for (int k = 0; k < 2; k++) {
        g[k].t = rows[0];
        g[k].t.accesses = rows[0].accesses / 2;
        g[k].gen = k;
    }
    CHECK(rt_db_store_run_gen(db, &r, rows, n, g, 2, NULL, &e) == 0, "store generation rows after upgrade: %s", e.msg);
    CHECK(count(db, "SELECT sum(accesses) FROM traffic_gen") == (long long)rows[0].accesses, "generation rows stored");
    CHECK(count(db, "SELECT count(*) FROM runs") == 1, "same run");
    rt_db_close(db);
    rt_db_close(f);
}

/* Version 4's schema as raytraffic 4 created it (the string of db.c, kept
 * here verbatim) and two runs of one job, exact and hybrid (a hybrid run
 * of version 4 stored no errors): the input of the v4 -> v5 upgrade. */
static const char v4_file_sql[] =
    "CREATE TABLE IF NOT EXISTS scenes(\n"
    "  id INTEGER PRIMARY KEY,\n"
    "  name TEXT NOT NULL,                 -- scene spec (built-in name or file)\n"
    "  params TEXT NOT NULL DEFAULT '',    -- canonical scene parameters\n"
    "  hash TEXT NOT NULL,                 -- rt_scene_hash, 16 hex digits\n"
    "  triangles INTEGER NOT NULL DEFAULT 0,\n"
    "  path TEXT NOT NULL DEFAULT '',      -- mesh file as given on the command line ('' built-in)\n"
    "  abspath TEXT NOT NULL DEFAULT '',   -- that file's absolute path, where it was last seen\n"
    "  UNIQUE(name, params, hash));\n"
    "CREATE TABLE IF NOT EXISTS runs(\n"
    "  id INTEGER PRIMARY KEY,\n"
    "  scene_id INTEGER NOT NULL REFERENCES scenes(id),\n"
    "  tracer TEXT NOT NULL,\n"
    "  W INTEGER NOT NULL,\n"
    "  H INTEGER NOT NULL,\n"
    "  lights INTEGER NOT NULL,            -- enabled-light mask\n"
    "  sched_size INTEGER NOT NULL DEFAULT 0, -- cache size the trace was scheduled for (0 = n/a)\n"
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
    "  sched_cache_size INTEGER GENERATED ALWAYS AS (sched_size) VIRTUAL,\n"
    "  UNIQUE(scene_id, tracer, W, H, lights, sched_size, gmax, params, sim_method, sim_params));\n"
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
    "    g.geometry_mb, g.ray_mb, r.sched_size AS sched_cache_size\n"
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
    "INSERT INTO classes VALUES('node', 'geometry'), ('tri', 'geometry'), ('ray', 'ray'), ('fb', 'other');\n"
    "INSERT INTO scenes(id, name, hash, triangles) VALUES(1, 'cornell', '00000000000000aa', 32);\n"
    "INSERT INTO runs(id, scene_id, tracer, W, H, lights, sim_method, sim_params, refs, wall_time) VALUES\n"
    "  (1, 1, 'recursive', 64, 64, 0, 'exact', '', 90000, 0.5),\n"
    "  (2, 1, 'recursive', 64, 64, 0, 'hybrid',\n"
    "   'rate=0.25 seed=1 window_below=4096 period=2048 window=1024 exact_below=0', 90000, 0.125);\n"
    "INSERT INTO cache_configs(id, size, line, assoc, policy) VALUES(1, 4096, 64, 0, 'wb-wa'), (2, 65536, 64, 0, 'wb-wa');\n"
    "INSERT INTO traffic(run_id, config_id, class, accesses, read_misses, write_misses, writebacks, wt_bytes,\n"
    "  traffic_bytes) VALUES\n"
    "  (1, 1, 'tri', 1000, 100, 0, 0, 0, 6400), (1, 1, 'ray', 500, 50, 0, 10, 0, 3840),\n"
    "  (1, 2, 'tri', 1000, 20, 0, 0, 0, 1280), (1, 2, 'ray', 500, 50, 0, 0, 0, 3200),\n"
    "  (2, 1, 'tri', 1000, 104, 0, 0, 0, 6656), (2, 1, 'ray', 500, 50, 0, 12, 0, 3968),\n"
    "  (2, 2, 'tri', 1000, 16, 0, 0, 0, 1024), (2, 2, 'ray', 500, 50, 0, 0, 0, 3200);\n"
    "PRAGMA user_version = 4;\n";

/* A version-4 file is upgraded in place: its runs and rows kept, the table
 * traffic_se (empty) and the view v_traffic_se (NULL errors for the old
 * runs) in the layout of a fresh file; the old hybrid run keeps its key
 * (it has no errors), a run with errors is another key and its errors
 * show in the view. */
static void test_upgrade_v4(const char *dir)
{
    char path[300], fresh[300], a[1024], b[1024];
    rt_err e = {0};
    snprintf(path, sizeof path, "%s/v4.db", dir);
    snprintf(fresh, sizeof fresh, "%s/v5fresh.db", dir);
    CHECK(make_file(path, v4_file_sql) == 0, "create v4 file");
    rt_db *db = rt_db_open(path, &e), *f = rt_db_open(fresh, &e);
    CHECK(db && f, "open v4: %s", e.msg);
    if (!db || !f) {
        rt_db_close(db);
        rt_db_close(f);
        return;
    }
    CHECK(count(db, "PRAGMA user_version") == RT_DB_SCHEMA_VERSION && RT_DB_SCHEMA_VERSION == 8, "v4 upgraded to 8");
    CHECK(count(db, "SELECT count(*) FROM runs") == 2 && count(db, "SELECT count(*) FROM traffic") == 8 &&
              count(db, "SELECT sum(traffic_bytes) FROM traffic WHERE run_id = 2") == 6656 + 3968 + 1024 + 3200,
          "v4 runs and rows kept");
    CHECK(count(db, "SELECT count(*) FROM traffic_se") == 0, "no errors for old runs");
    CHECK(count(db, "SELECT count(*) FROM v_traffic_se") == 4 &&
              count(db, "SELECT count(*) FROM v_traffic_se WHERE geometry_se_mb IS NULL AND ray_se_mb IS NULL AND "
                        "other_se_mb IS NULL AND total_se_mb IS NULL") == 4,
          "v_traffic_se: every old run's size, errors NULL");
    CHECK(getd(db, "SELECT total_mb FROM v_traffic_se WHERE run_id = 2 AND cache_size = 4096") ==
              (6656 + 3968) / 1048576.0,
          "v_traffic_se: the estimate");
    const char *tables[] = {"traffic_se", "v_traffic_se", "v_traffic_group", "runs", "traffic", "v_gen"};
    for (int i = 0; i < 6; i++) {
        columns(db, tables[i], a, sizeof a);
        columns(f, tables[i], b, sizeof b);
        CHECK(a[0] && !strcmp(a, b), "%s: upgraded columns %s, fresh %s", tables[i], a, b);
    }
    /* the old hybrid run is found by its key, and a run with errors is another one */
    rt_db_run r;
    memset(&r, 0, sizeof r);
    r.scene = "cornell";
    r.scene_hash = 0xaa;
    r.tracer = "recursive";
    r.W = r.H = 64;
    r.sim_method = "hybrid";
    r.sim_params = "rate=0.25 seed=1 window_below=4096 period=2048 window=1024 exact_below=0";
    CHECK(rt_db_has_run(db, &r, &e) == 1, "old hybrid run found by its key: %s", e.msg);
    r.sim_params = "rate=0.25 seed=1 window_below=4096 period=2048 window=1024 exact_below=0 errors=1";
    CHECK(rt_db_has_run(db, &r, &e) == 0, "a run with errors is not the old run");
    rt_db_traffic t[2] = {{4096, 64, 0, "wb-wa", RT_CLS_TRI, 1000, 104, 0, 0, 0, 6656},
                          {65536, 64, 0, "wb-wa", RT_CLS_TRI, 1000, 16, 0, 0, 0, 1024}};
    rt_db_se se[2] = {{4096, 64, 0, "wb-wa", {512.25, 300, -1, 640.5}}, {65536, 64, 0, "wb-wa", {0, 0, 0, 0}}};
    rt_db_rows R = {.traffic = t, .ntraffic = 2, .se = se, .nse = 2};
    CHECK(rt_db_store(db, &r, &R, NULL, &e) == 0, "store with errors after the upgrade: %s", e.msg);
    CHECK(count(db, "SELECT count(*) FROM runs") == 3 && count(db, "SELECT count(*) FROM traffic_se") == 2,
          "a third run with two error rows");
    CHECK(getd(db, "SELECT geometry_se_mb * 1048576 FROM v_traffic_se v JOIN runs r ON r.id = v.run_id WHERE "
                   "r.sim_params LIKE '%errors=1' AND cache_size = 4096") == 512.25,
          "geometry error in the view");
    CHECK(count(db, "SELECT count(*) FROM traffic_se WHERE other_se IS NULL") == 1, "a missing error is NULL");
    CHECK(getd(db, "SELECT total_se FROM traffic_se t JOIN cache_configs c ON c.id = t.config_id WHERE c.size = 65536") ==
              0,
          "an exact size's error is 0");
    rt_db_close(db);
    rt_db_close(f);
}

/* Standard-error rows: stored with the run, replaced with its traffic rows
 * (a re-store without errors keeps none for those sizes), rolled back
 * with a failed store, refused when not a number, and copied by merge. */
/* Version 5 additions over version 4 (its own text): the standard-error
 * table and view; with one error row and one generation row, so the
 * rebuild of runs can be seen to keep every row that refers to a run. */
static const char v5_extra_sql[] =
    "CREATE TABLE IF NOT EXISTS traffic_se(\n"
    "  run_id INTEGER NOT NULL REFERENCES runs(id) ON DELETE CASCADE,\n"
    "  config_id INTEGER NOT NULL REFERENCES cache_configs(id),\n"
    "  geometry_se REAL, ray_se REAL, other_se REAL, total_se REAL,\n"
    "  UNIQUE(run_id, config_id));\n"
    "CREATE VIEW IF NOT EXISTS v_traffic_se AS\n"
    "  SELECT g.run_id, g.config_id, r.sim_method, g.cache_size, g.line, g.assoc, g.policy,\n"
    "    g.geometry_mb, e.geometry_se / 1048576.0 AS geometry_se_mb, g.ray_mb, e.ray_se / 1048576.0 AS ray_se_mb,\n"
    "    g.other_mb, e.other_se / 1048576.0 AS other_se_mb, g.total_mb, e.total_se / 1048576.0 AS total_se_mb\n"
    "  FROM v_traffic_group g JOIN runs r ON r.id = g.run_id\n"
    "    LEFT JOIN traffic_se e ON e.run_id = g.run_id AND e.config_id = g.config_id;\n"
    "INSERT INTO traffic_se VALUES(2, 1, 10.5, 20.25, NULL, 30);\n"
    "INSERT INTO traffic_gen VALUES(1, 1, 'tri', 0, 1000, 100, 0, 0, 6400);\n"
    "PRAGMA user_version = 5;\n";

/* A version-5 file is upgraded to 6 in place: runs rebuilt with the new
 * dimensions at their defaults (ids, provenance, traffic, generation and
 * error rows all kept: the rebuild must not cascade), the layout of a
 * fresh file; old keys still found; the new dimensions are part of the
 * key; level rows are stored, replaced per level configuration, refused
 * when wrong, shown by v_level and copied by merge. */
static void test_upgrade_v5(const char *dir)
{
    char path[300], fresh[300], a[2048], b[2048], out[300];
    rt_err e = {0};
    snprintf(path, sizeof path, "%s/v5.db", dir);
    snprintf(fresh, sizeof fresh, "%s/v6fresh.db", dir);
    snprintf(out, sizeof out, "%s/v6merged.db", dir);
    CHECK(make_file(path, v4_file_sql) == 0 && make_file(path, v5_extra_sql) == 0, "create v5 file");
    sqlite3 *h;
    sqlite3_open(path, &h);
    sqlite3_exec(h, "UPDATE runs SET git_rev = 'abc123', command = 'sweep x', created = '2026-01-02T03:04:05Z'",
                 NULL, NULL, NULL);
    sqlite3_close(h);
    rt_db *db = rt_db_open(path, &e), *f = rt_db_open(fresh, &e);
    CHECK(db && f, "open v5: %s", e.msg);
    if (!db || !f) {
        rt_db_close(db);
        rt_db_close(f);
        return;
    }
    CHECK(count(db, "PRAGMA user_version") == 8, "v5 upgraded to 8");
    CHECK(count(db, "SELECT count(*) FROM runs") == 2 && count(db, "SELECT count(*) FROM traffic") == 8 &&
              count(db, "SELECT count(*) FROM traffic_se") == 1 && count(db, "SELECT count(*) FROM traffic_gen") == 1 &&
              count(db, "SELECT sum(traffic_bytes) FROM traffic WHERE run_id = 2") == 6656 + 3968 + 1024 + 3200,
          "v5 runs, traffic, error and generation rows kept");
    CHECK(count(db, "SELECT count(*) FROM runs WHERE repl = 'lru' AND hierarchy = '' AND cores = 1 AND "
                    "light_model = 'point' AND instances = 'flatten' AND git_rev = 'abc123' AND command = 'sweep x' "
                    "AND created = '2026-01-02T03:04:05Z' AND sched_cache_size = 0") == 2,
          "defaults of the new dimensions, provenance kept");
    CHECK(getd(db, "SELECT total_se_mb FROM v_traffic_se WHERE run_id = 2 AND cache_size = 4096") == 30 / 1048576.0,
          "the error row still joins its run");
    CHECK(count(db, "PRAGMA foreign_key_check") == -1, "no dangling rows");
    const char *tables[] = {"runs", "level_traffic", "v_level", "v_paper", "v_gen", "v_traffic_se"};
    for (int i = 0; i < 6; i++) {
        columns(db, tables[i], a, sizeof a);
        columns(f, tables[i], b, sizeof b);
        CHECK(a[0] && !strcmp(a, b), "%s: upgraded columns %s, fresh %s", tables[i], a, b);
    }
    rt_db_run r;
    memset(&r, 0, sizeof r);
    r.scene = "cornell";
    r.scene_hash = 0xaa;
    r.tracer = "recursive";
    r.W = r.H = 64;
    CHECK(rt_db_has_run(db, &r, &e) == 1, "old exact run found by its key: %s", e.msg);
    r.repl = "lru";
    r.cores = 1;
    r.light_model = "point";
    r.instances = "flatten";
    r.hierarchy = "";
    CHECK(rt_db_has_run(db, &r, &e) == 1, "explicit defaults are the same key");
    r.repl = "fifo";
    CHECK(rt_db_has_run(db, &r, &e) == 0, "another replacement policy is another run");
    r.repl = NULL;
    r.cores = 4;
    CHECK(rt_db_has_run(db, &r, &e) == 0, "another core count is another run");
    /* a hierarchy run with level rows */
    r.cores = 2;
    r.hierarchy = "L1:4K:64:2,L2:64K:64:8";
    rt_db_traffic t[1] = {{65536, 64, 8, "wb-wa", RT_CLS_TRI, 50, 5, 0, 0, 0, 320}};
    rt_db_level lv[3] = {
        {1, "L1", 0, 4096, 64, 2, NULL, NULL, RT_CLS_TRI, -1, 1000, 50, 0, 3200, 0, 0, 0},
        {1, "L1", 1, 4096, 64, 2, NULL, NULL, RT_CLS_TRI, -1, 900, 40, 0, 2560, 0, 0, 0},
        {2, "L2", -1, 65536, 64, 8, "wb-wa", "lru", RT_CLS_TRI, -1, 90, 5, 0, 320, 0, 0, 0},
    };
    rt_db_rows R = {.traffic = t, .ntraffic = 1, .level = lv, .nlevel = 3};
    int64_t rid = 0;
    CHECK(rt_db_store(db, &r, &R, &rid, &e) == 0, "store level rows: %s", e.msg);
    CHECK(count(db, "SELECT count(*) FROM level_traffic") == 3 &&
              count(db, "SELECT sum(traffic_bytes) FROM level_traffic WHERE level = 1") == 3200 + 2560,
          "level rows stored");
    CHECK(count(db, "SELECT total_bytes FROM v_level WHERE level = 2 AND core = -1 AND hierarchy = "
                    "'L1:4K:64:2,L2:64K:64:8' AND cores = 2") == 320 &&
              count(db, "SELECT geometry_bytes FROM v_level WHERE level = 1 AND core = 1") == 2560 &&
              count(db, "SELECT misses FROM v_level WHERE level = 1 AND core = 0") == 50,
          "v_level");
    lv[0].traffic_bytes = 6400;
    R.nlevel = 1;
    CHECK(rt_db_store(db, &r, &R, NULL, &e) == 0, "store again: %s", e.msg);
    CHECK(count(db, "SELECT count(*) FROM level_traffic") == 3 &&
              count(db, "SELECT traffic_bytes FROM level_traffic WHERE level = 1 AND core = 0") == 6400,
          "a re-store replaces that level configuration only");
    rt_db_level badl = lv[1];
    badl.misses = badl.accesses + 1;
    R.level = &badl;
    CHECK(rt_db_store(db, &r, &R, NULL, &e) < 0 && strstr(e.msg, "more misses"), "misses > accesses: %s", e.msg);
    badl = lv[1];
    badl.level = 0;
    CHECK(rt_db_store(db, &r, &R, NULL, &e) < 0 && strstr(e.msg, "level 0"), "level 0: %s", e.msg);
    CHECK(count(db, "SELECT count(*) FROM level_traffic") == 3 &&
              count(db, "SELECT traffic_bytes FROM level_traffic WHERE level = 1 AND core = 0") == 6400,
          "refused stores left nothing");
    /* merge copies dimensions and level rows */
    long nr = -1;
    rt_db *m = rt_db_open(out, &e);
    CHECK(m && rt_db_merge(m, path, &nr, &e) == 0 && nr == 3, "merge v6: %ld %s", nr, e.msg);
    CHECK(count(m, "SELECT count(*) FROM level_traffic") == 3 &&
              count(m, "SELECT sum(traffic_bytes) FROM level_traffic") == 6400 + 2560 + 320 &&
              count(m, "SELECT cores FROM runs WHERE hierarchy = 'L1:4K:64:2,L2:64K:64:8'") == 2 &&
              count(m, "SELECT count(*) FROM runs WHERE repl = 'lru' AND light_model = 'point'") == 3,
          "merged dimensions and level rows");
    CHECK(rt_db_merge(m, path, &nr, &e) == 0 && count(m, "SELECT count(*) FROM level_traffic") == 3 &&
              count(m, "SELECT count(*) FROM runs") == 3,
          "merging twice duplicates nothing");
    rt_db_close(m);
    sqlite3_open(path, &h);
    sqlite3_exec(h, "UPDATE level_traffic SET gen = 9 WHERE level = 2", NULL, NULL, NULL);
    sqlite3_close(h);
    m = rt_db_open(out, &e);
    CHECK(m && rt_db_merge(m, path, &nr, &e) < 0 && strstr(e.msg, "level row") && strstr(e.msg, path),
          "bad level row refused: %s", e.msg);
    rt_db_close(m);
    rt_db_close(db);
    rt_db_close(f);
}

static void test_se_rows(const char *dir)
{
    char path[300], mpath[300];
    rt_err e = {0};
    snprintf(path, sizeof path, "%s/se.db", dir);
    snprintf(mpath, sizeof mpath, "%s/se_merged.db", dir);
    rt_db *db = rt_db_open(path, &e);
    CHECK(db, "open: %s", e.msg);
    if (!db) return;
    rt_db_run r;
    run_key(&r, "recursive", 0, 0);
    r.sim_method = "hybrid";
    r.sim_params = "rate=0.015625 seed=1 window_below=32768 period=65536 window=1024 exact_below=0 errors=1";
    rt_db_traffic t[3] = {{1024, 64, 0, "wb-wa", RT_CLS_TRI, 10, 5, 0, 0, 0, 320},
                          {2048, 64, 0, "wb-wa", RT_CLS_TRI, 10, 4, 0, 0, 0, 256},
                          {2048, 64, 0, "wb-wa", RT_CLS_RAY, 10, 1, 0, 0, 0, 64}};
    rt_db_se se[2] = {{1024, 64, 0, "wb-wa", {10.5, -1, 0, 10.5}}, {2048, 64, 0, "wb-wa", {8, 3.25, 0, 9.125}}};
    rt_db_rows R = {.traffic = t, .ntraffic = 3, .se = se, .nse = 2};
    CHECK(rt_db_store(db, &r, &R, NULL, &e) == 0, "store: %s", e.msg);
    CHECK(count(db, "SELECT count(*) FROM traffic_se") == 2, "two error rows");
    CHECK(getd(db, "SELECT ray_se_mb * 1048576 FROM v_traffic_se WHERE cache_size = 2048") == 3.25 &&
              getd(db, "SELECT total_se FROM traffic_se e JOIN cache_configs c ON c.id = e.config_id WHERE c.size = 2048") ==
                  9.125,
          "values kept exactly");
    /* not a number: refused, nothing of the store left */
    rt_db_se bad = se[0];
    bad.se[2] = NAN;
    rt_db_rows RB = {.traffic = t, .ntraffic = 1, .se = &bad, .nse = 1};
    r.tracer = "packet";
    CHECK(rt_db_store(db, &r, &RB, NULL, &e) < 0 && strstr(e.msg, path) && strstr(e.msg, "not a number"),
          "NaN refused: %s", e.msg);
    CHECK(count(db, "SELECT count(*) FROM runs") == 1, "refused store left a run");
    /* an error row of a size without traffic rows: refused */
    rt_db_se lone = se[0];
    lone.size = 4096;
    rt_db_rows RL = {.traffic = t, .ntraffic = 3, .se = &lone, .nse = 1};
    CHECK(rt_db_store(db, &r, &RL, NULL, &e) < 0 && strstr(e.msg, "has no traffic row"), "lone error row: %s", e.msg);
    CHECK(count(db, "SELECT count(*) FROM runs") == 1, "refused store left a run");
    /* a store failing at its second error row (the same configuration
     * twice) leaves nothing: not the run, not its first error row */
    rt_db_se twice[2] = {se[0], se[0]};
    rt_db_rows RT = {.traffic = t, .ntraffic = 1, .se = twice, .nse = 2};
    CHECK(rt_db_store(db, &r, &RT, NULL, &e) < 0 && strstr(e.msg, "UNIQUE"), "duplicate error row: %s", e.msg);
    CHECK(count(db, "SELECT count(*) FROM runs") == 1 && count(db, "SELECT count(*) FROM traffic_se") == 2 &&
              count(db, "SELECT count(*) FROM traffic") == 3,
          "rolled back");
    /* merge copies the errors (NULL stays NULL) */
    rt_db *m = rt_db_open(mpath, &e);
    long nr = 0;
    CHECK(m && rt_db_merge(m, path, &nr, &e) == 0 && nr == 1, "merge: %s", e.msg);
    CHECK(m && count(m, "SELECT count(*) FROM traffic_se") == 2 &&
              count(m, "SELECT count(*) FROM traffic_se WHERE geometry_se IS NULL OR ray_se IS NULL") == 1 &&
              getd(m, "SELECT sum(total_se) FROM traffic_se") == 10.5 + 9.125,
          "merged errors");
    /* re-storing sizes without errors drops their error rows only */
    r.tracer = "recursive";
    rt_db_rows R2 = {.traffic = t, .ntraffic = 1};
    CHECK(rt_db_store(db, &r, &R2, NULL, &e) == 0, "re-store 1K: %s", e.msg);
    CHECK(count(db, "SELECT count(*) FROM traffic_se") == 1 && count(db, "SELECT count(*) FROM traffic") == 3,
          "1K's error row replaced by none, 2K's kept");
    /* the invariant: every error row's (run, configuration) has traffic rows */
    CHECK(count(db, "SELECT count(*) FROM traffic_se e WHERE NOT EXISTS (SELECT 1 FROM traffic t WHERE "
                    "t.run_id = e.run_id AND t.config_id = e.config_id)") == 0,
          "an error row without traffic rows");
    /* a shard with an error that is not a number is refused, naming it */
    sqlite3_exec(rt_db_handle(db), "UPDATE traffic_se SET ray_se = 'big'", NULL, NULL, NULL);
    rt_db_close(db);
    CHECK(m && rt_db_merge(m, path, &nr, &e) < 0 && strstr(e.msg, path) && strstr(e.msg, "ray_se is 'big'") &&
              strstr(e.msg, "standard-error row"),
          "bad shard error: %s", e.msg);
    rt_db_close(m);
}

/* Merge copies runs, refuses newer shards and bad values with the shard
 * path and the offending row, and stores nothing of a bad run. */
static void test_merge(const char *dir, const rt_db_traffic *rows, size_t n)
{
    char out[300], in[300], v1[300];
    rt_err e = {0};
    long nr = -1;
    snprintf(out, sizeof out, "%s/m.db", dir);
    snprintf(in, sizeof in, "%s/shard.db", dir);
    snprintf(v1, sizeof v1, "%s/v1.db", dir); /* upgraded by test_upgrade_v1: 1 run */
    rt_db *s = rt_db_open(in, &e);
    rt_db_run r;
    run_key(&r, "recursive", 0, 0);
    CHECK(s && rt_db_store_run(s, &r, rows, n, NULL, &e) == 0, "shard: %s", e.msg);
    run_key(&r, "dynamic", 1, 4096);
    CHECK(rt_db_store_run(s, &r, rows, n, NULL, &e) == 0, "shard 2: %s", e.msg);
    rt_db_close(s);
    rt_db *db = rt_db_open(out, &e);
    CHECK(db && rt_db_merge(db, in, &nr, &e) == 0 && nr == 2, "merge: %ld runs, %s", nr, e.msg);
    CHECK(rt_db_merge(db, in, &nr, &e) == 0 && nr == 2, "merge twice");
    /* the shard is only read: no -wal or -shm left beside it */
    char side[320];
    snprintf(side, sizeof side, "%s-wal", in);
    CHECK(access(side, F_OK) != 0, "merge left %s", side);
    snprintf(side, sizeof side, "%s-shm", in);
    CHECK(access(side, F_OK) != 0, "merge left %s", side);
    CHECK(count(db, "SELECT count(*) FROM runs") == 2 && count(db, "SELECT count(*) FROM traffic") == 2 * (long long)n,
          "merging twice duplicated nothing");
    CHECK(count(db, "SELECT sched_size FROM runs WHERE tracer = 'dynamic'") == 4096, "sched_size merged");
    CHECK(rt_db_merge(db, v1, &nr, &e) == 0 && nr == 1, "merge an upgraded v1 file: %s", e.msg);
    /* bad values: a negative count, then text where a number belongs */
    static const char *const bad[] = {"UPDATE traffic SET writebacks = -3 WHERE rowid = 5",
                                      "UPDATE runs SET W = 'wide' WHERE tracer = 'recursive'"};
    static const char *const want[] = {"writebacks is negative", "W is 'wide'"};
    for (int k = 0; k < 2; k++) {
        sqlite3 *h;
        sqlite3_open(in, &h);
        sqlite3_exec(h, bad[k], NULL, NULL, NULL);
        sqlite3_close(h);
        long long before = count(db, "SELECT count(*) FROM traffic");
        sqlite3_exec(rt_db_handle(db), "DELETE FROM traffic; DELETE FROM runs", NULL, NULL, NULL);
        CHECK(rt_db_merge(db, in, &nr, &e) < 0, "bad value %d merged", k);
        CHECK(strstr(e.msg, in) && strstr(e.msg, want[k]) && strstr(e.msg, "run "), "message: %s", e.msg);
        CHECK(count(db, "SELECT count(*) FROM runs WHERE tracer = 'recursive'") == 0, "bad run stored");
        (void)before;
    }
    /* a newer shard is refused without reading it */
    sqlite3 *h;
    sqlite3_open(in, &h);
    char newer[64];
    snprintf(newer, sizeof newer, "PRAGMA user_version = %d", RT_DB_SCHEMA_VERSION + 1);
    sqlite3_exec(h, newer, NULL, NULL, NULL);
    sqlite3_close(h);
    CHECK(rt_db_merge(db, in, &nr, &e) < 0 && strstr(e.msg, in) && strstr(e.msg, "newer"), "newer shard: %s", e.msg);
    rt_db_close(db);
}


/* W processes open a database that does not exist yet at the same instant
 * (released together through a pipe) and each stores one run, R rounds on
 * a fresh file each: creating the schema and switching to WAL must not
 * fail with "database is locked", and no run may be lost or duplicated. */
static void test_fresh_concurrent(const char *dir, int W, int R, const rt_db_traffic *rows, size_t n)
{
    int bad = 0;
    for (int round = 0; round < R; round++) {
        char path[300];
        snprintf(path, sizeof path, "%s/fresh%d.db", dir, round);
        int go[2];
        if (pipe(go) < 0) return;
        pid_t kids[16];
        for (int c = 0; c < W; c++) {
            kids[c] = fork();
            if (kids[c] == 0) {
                char b;
                close(go[1]);
                if (read(go[0], &b, 1) < 0) _exit(4); /* EOF when the parent closes: all start together */
                rt_err e = {0};
                rt_db *d = rt_db_open(path, &e);
                rt_db_run k;
                run_key(&k, "recursive", 0, 0);
                k.lights = (uint32_t)c;
                if (!d || rt_db_store_run(d, &k, rows, n, NULL, &e)) {
                    fprintf(stderr, "round %d writer %d: %s\n", round, c, e.msg);
                    _exit(3);
                }
                rt_db_close(d);
                _exit(0);
            }
        }
        close(go[0]);
        close(go[1]);
        for (int c = 0; c < W; c++) {
            int status = 0;
            waitpid(kids[c], &status, 0);
            if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) bad++;
        }
        rt_err e = {0};
        rt_db *db = rt_db_open(path, &e);
        CHECK(db, "reopen fresh: %s", e.msg);
        if (!db) return;
        CHECK(count(db, "SELECT count(*) FROM runs") == W, "round %d: %lld runs of %d", round,
              count(db, "SELECT count(*) FROM runs"), W);
        CHECK(count(db, "SELECT count(*) FROM traffic") == W * (long long)n, "round %d: traffic rows", round);
        CHECK(count(db, "SELECT count(*) FROM scenes") == 1, "round %d: one scene", round);
        rt_db_close(db);
    }
    CHECK(bad == 0, "%d of %d writers failed on a fresh database", bad, W * R);
}

/* A version-6 file (stats_json removed from a fresh one: the column was
 * new in 7) is upgraded: stats_json is parsed from every run's stats, the
 * old packet tracer's descriptive words left out, NULL where the text does
 * not parse; json_extract reads it; a new store fills it. */
static void test_upgrade_v6(const char *dir, const rt_db_traffic *rows, size_t n)
{
    char path[300];
    rt_err e = {0};
    snprintf(path, sizeof path, "%s/v6.db", dir);
    rt_db *db = rt_db_open(path, &e);
    CHECK(db, "open v6: %s", e.msg);
    if (!db) return;
    rt_db_run r;
    run_key(&r, "packet", 0, 0);
    r.stats = "rays_primary=10 nodes=4 tests=5 render_seconds=0.125 packet=8";
    CHECK(rt_db_store_run(db, &r, rows, n, NULL, &e) == 0, "store packet: %s", e.msg);
    CHECK(count(db, "SELECT count(*) FROM runs WHERE stats_json = "
                    "'{\"rays_primary\": 10, \"nodes\": 4, \"tests\": 5, \"render_seconds\": 0.125, \"packet\": 8}'") == 1,
          "a new run's stats_json");
    run_key(&r, "dynamic", 0, 4096);
    r.stats = "gmax=100 gmax_rule=given";
    CHECK(rt_db_store_run(db, &r, rows, n, NULL, &e) == 0, "store dynamic: %s", e.msg);
    run_key(&r, "recursive", 0, 0);
    r.stats = "";
    CHECK(rt_db_store_run(db, &r, rows, n, NULL, &e) == 0, "store recursive: %s", e.msg);
    rt_db_close(db);
    sqlite3 *h;
    sqlite3_open(path, &h);
    CHECK(sqlite3_exec(h,
                       "DROP VIEW v_runs; ALTER TABLE runs DROP COLUMN stats_json;"
                       "UPDATE runs SET stats = 'nodes=4 tests=5 packet=8 nodes=packet node visits tests=ray-triangle "
                       "tests' WHERE tracer = 'packet';"
                       "UPDATE runs SET stats = 'gmax=1 gmax=2' WHERE tracer = 'recursive';"
                       "PRAGMA user_version = 6",
                       NULL, NULL, NULL) == SQLITE_OK,
          "make the v6 file: %s", sqlite3_errmsg(h));
    sqlite3_close(h);
    db = rt_db_open(path, &e);
    CHECK(db, "reopen v6: %s", e.msg);
    if (!db) return;
    CHECK(count(db, "PRAGMA user_version") == 8, "v6 upgraded to 8");
    CHECK(count(db, "SELECT count(*) FROM runs WHERE tracer = 'packet' AND stats_json = "
                    "'{\"nodes\": 4, \"tests\": 5, \"packet\": 8}'") == 1,
          "the old packet text parsed without its descriptive words");
    CHECK(count(db, "SELECT json_extract(stats_json, '$.gmax') FROM runs WHERE tracer = 'dynamic'") == 100 &&
              count(db, "SELECT count(*) FROM runs WHERE json_extract(stats_json, '$.gmax_rule') = 'given'") == 1,
          "json_extract reads the migrated object");
    CHECK(count(db, "SELECT count(*) FROM runs WHERE tracer = 'recursive' AND stats_json IS NULL") == 1,
          "a repeated key leaves NULL");
    CHECK(count(db, "SELECT count(*) FROM v_runs WHERE stats_json IS NOT NULL") == 2, "v_runs shows stats_json");
    CHECK(count(db, "PRAGMA foreign_key_check") == -1, "no dangling rows after the v6 upgrade");
    /* an old shard's packet run stored as db merge does: the same object */
    run_key(&r, "packet", 1, 0);
    r.stats = "nodes=7 packet=8 nodes=packet node visits tests=ray-triangle tests";
    CHECK(rt_db_store_run(db, &r, rows, n, NULL, &e) == 0, "store old packet text: %s", e.msg);
    CHECK(count(db, "SELECT count(*) FROM runs WHERE lights = 1 AND stats_json = '{\"nodes\": 7, \"packet\": 8}'") == 1,
          "a store of the old packet text leaves its words out");
    rt_db_close(db);
}

/* Version 7's level_traffic (before the inclusion's columns), for making a
 * version-7 file out of a fresh one. */
static const char v7_level_sql[] =
    "DROP VIEW v_level;\n"
    "CREATE TABLE lt7(run_id INTEGER NOT NULL REFERENCES runs(id) ON DELETE CASCADE, level INTEGER NOT NULL,"
    " level_name TEXT NOT NULL DEFAULT '', core INTEGER NOT NULL DEFAULT -1, cache_size INTEGER NOT NULL,"
    " line INTEGER NOT NULL, assoc INTEGER NOT NULL, policy TEXT NOT NULL DEFAULT 'wb-wa',"
    " repl TEXT NOT NULL DEFAULT 'lru', class TEXT NOT NULL REFERENCES classes(name),"
    " gen INTEGER NOT NULL DEFAULT -1, accesses INTEGER NOT NULL, misses INTEGER NOT NULL,"
    " writebacks INTEGER NOT NULL, traffic_bytes INTEGER NOT NULL,"
    " UNIQUE(run_id, level, core, cache_size, line, assoc, policy, repl, class, gen));\n"
    "INSERT INTO lt7 SELECT run_id, level, level_name, core, cache_size, line, assoc, policy, repl, class, gen,"
    " accesses, misses, writebacks, traffic_bytes FROM level_traffic;\n"
    "DROP TABLE level_traffic;\n"
    "ALTER TABLE lt7 RENAME TO level_traffic;\n"
    "PRAGMA user_version = 7;\n";

/* A version-7 file (level_traffic without last_size, backinvals,
 * bi_writebacks) is upgraded: its level rows kept with 0 in the new
 * columns, the table's columns those of a fresh file; an inclusive run's
 * two chains (the same L1 configuration, two last-level sizes) are stored
 * side by side and v_level names the inclusion; a version-7 shard merges
 * (its rows non-inclusive); bi_writebacks > backinvals is refused. */
static void test_upgrade_v7(const char *dir)
{
    char path[300], fresh[300], out[300], a[512], b[512];
    rt_err e = {0};
    snprintf(path, sizeof path, "%s/v7.db", dir);
    snprintf(fresh, sizeof fresh, "%s/v7fresh.db", dir);
    snprintf(out, sizeof out, "%s/v7merged.db", dir);
    rt_db *db = rt_db_open(path, &e);
    CHECK(db, "open v7: %s", e.msg);
    if (!db) return;
    rt_db_run r;
    run_key(&r, "recursive", 0, 0);
    r.hierarchy = "L1=4K/2/64/lru,L2=64K/8/64/lru";
    rt_db_traffic t[1] = {{65536, 64, 8, "wb-wa", RT_CLS_TRI, 50, 5, 0, 0, 0, 320}};
    rt_db_level lv[2] = {
        {1, "L1", -1, 4096, 64, 2, NULL, NULL, RT_CLS_TRI, -1, 1000, 50, 0, 3200, 0, 0, 0},
        {2, "L2", -1, 65536, 64, 8, NULL, NULL, RT_CLS_TRI, -1, 50, 5, 0, 320, 0, 0, 0},
    };
    rt_db_rows R = {.traffic = t, .ntraffic = 1, .level = lv, .nlevel = 2};
    CHECK(rt_db_store(db, &r, &R, NULL, &e) == 0, "store: %s", e.msg);
    rt_db_close(db);
    sqlite3 *h;
    sqlite3_open(path, &h);
    CHECK(sqlite3_exec(h, v7_level_sql, NULL, NULL, NULL) == SQLITE_OK, "make the v7 file: %s", sqlite3_errmsg(h));
    sqlite3_close(h);
    /* a copy of the version-7 file, merged below as an old shard */
    char shard[300], cmd[700];
    snprintf(shard, sizeof shard, "%s/v7shard.db", dir);
    snprintf(cmd, sizeof cmd, "cp '%s' '%s'", path, shard);
    CHECK(system(cmd) == 0, "copy the v7 file");
    db = rt_db_open(path, &e);
    rt_db *f = rt_db_open(fresh, &e);
    CHECK(db && f, "reopen v7: %s", e.msg);
    if (!db || !f) return;
    CHECK(count(db, "PRAGMA user_version") == 8, "v7 upgraded to 8");
    columns(db, "level_traffic", a, sizeof a);
    columns(f, "level_traffic", b, sizeof b);
    CHECK(a[0] && !strcmp(a, b), "level_traffic: upgraded columns %s, fresh %s", a, b);
    columns(db, "v_level", a, sizeof a);
    columns(f, "v_level", b, sizeof b);
    CHECK(a[0] && !strcmp(a, b), "v_level: upgraded columns %s, fresh %s", a, b);
    CHECK(count(db, "SELECT count(*) FROM level_traffic WHERE last_size = 0 AND backinvals = 0 AND bi_writebacks = 0") ==
                  2 &&
              count(db, "SELECT sum(traffic_bytes) FROM level_traffic") == 3520,
          "v7 level rows kept, non-inclusive");
    CHECK(count(db, "SELECT count(*) FROM v_level WHERE inclusion = 'nine'") == 2, "v_level: a v7 hierarchy is nine");
    /* an inclusive run: L1 once per last-level size */
    run_key(&r, "recursive", 1, 0);
    r.hierarchy = "L1=4K/2/64/lru,L2=8K+16K/8/64/lru,inclusive";
    rt_db_traffic t2[2] = {{8192, 64, 8, "wb-wa", RT_CLS_TRI, 60, 30, 0, 0, 0, 1920},
                           {16384, 64, 8, "wb-wa", RT_CLS_TRI, 55, 20, 0, 0, 0, 1280}};
    rt_db_level il[4] = {
        {1, "L1", -1, 4096, 64, 2, NULL, "lru", RT_CLS_TRI, -1, 1000, 60, 0, 3840, 8192, 12, 3},
        {2, "L2", -1, 8192, 64, 8, NULL, "lru", RT_CLS_TRI, -1, 60, 30, 0, 1920, 8192, 0, 0},
        {1, "L1", -1, 4096, 64, 2, NULL, "lru", RT_CLS_TRI, -1, 1000, 55, 0, 3520, 16384, 4, 1},
        {2, "L2", -1, 16384, 64, 8, NULL, "lru", RT_CLS_TRI, -1, 55, 20, 0, 1280, 16384, 0, 0},
    };
    rt_db_rows R2 = {.traffic = t2, .ntraffic = 2, .level = il, .nlevel = 4};
    CHECK(rt_db_store(db, &r, &R2, NULL, &e) == 0, "store inclusive: %s", e.msg);
    CHECK(count(db, "SELECT count(*) FROM level_traffic WHERE level = 1 AND last_size > 0") == 2 &&
              count(db, "SELECT sum(backinvals) FROM level_traffic WHERE level = 1") == 16 &&
              count(db, "SELECT bi_writebacks FROM level_traffic WHERE level = 1 AND last_size = 8192") == 3,
          "both chains stored");
    CHECK(count(db, "SELECT backinvals FROM v_level WHERE inclusion = 'inclusive' AND level = 1 AND last_size = 16384") ==
              4,
          "v_level: the inclusion and the chain");
    CHECK(rt_db_store(db, &r, &R2, NULL, &e) == 0 && count(db, "SELECT count(*) FROM level_traffic") == 6,
          "a re-store replaces the chains' rows: %s", e.msg);
    il[0].bi_writebacks = il[0].backinvals + 1;
    CHECK(rt_db_store(db, &r, &R2, NULL, &e) < 0 && strstr(e.msg, "back-invalidation"), "biwb > bi refused: %s", e.msg);
    rt_db_close(db);
    rt_db_close(f);
    long nr = -1;
    rt_db *m = rt_db_open(out, &e);
    CHECK(m && rt_db_merge(m, shard, &nr, &e) == 0 && nr == 1, "merge a v7 shard: %ld %s", nr, e.msg);
    CHECK(m && count(m, "SELECT count(*) FROM level_traffic WHERE last_size = 0 AND backinvals = 0") == 2,
          "the v7 shard's level rows merged");
    CHECK(m && rt_db_merge(m, path, &nr, &e) == 0 && nr == 2 &&
              count(m, "SELECT count(*) FROM level_traffic WHERE last_size = 16384 AND backinvals = 4") == 1,
          "a v8 file's inclusive rows merged: %s", e.msg);
    rt_db_close(m);
}

/* The statistics parser on hand cases: numbers in JSON's grammar become
 * numbers, other one-word values strings; a repeated key, a token without
 * '=', an empty key or value, a quote, a double or trailing space fail. */
static void test_stats_json(void)
{
    char out[256];
    rt_err e = {0};
    static const struct {
        const char *in, *want;
    } ok[] = {
        {"", "{}"},
        {"a=1", "{\"a\": 1}"},
        {"a=-1.5e3 b=0.000 c=4x4x4 d=1,2,3 e=007 f=inf g=1. h=-0", "{\"a\": -1.5e3, \"b\": 0.000, \"c\": \"4x4x4\", "
         "\"d\": \"1,2,3\", \"e\": \"007\", \"f\": \"inf\", \"g\": \"1.\", \"h\": -0}"},
        {"gmax_rule=top-first q_1=2E+5", "{\"gmax_rule\": \"top-first\", \"q_1\": 2E+5}"},
    };
    for (size_t i = 0; i < sizeof ok / sizeof ok[0]; i++) {
        int rc = rt_stats_json(ok[i].in, out, sizeof out, &e);
        CHECK(rc == 0 && !strcmp(out, ok[i].want), "stats json '%s': %d '%s' (%s)", ok[i].in, rc, out, e.msg);
    }
    static const char *bad[] = {"a=1 a=2", "ab=1 b=2 ab=3", "a=1 nodes=packet node visits", "a=1 ", "a=1  b=2", " a=1",
                                "=1", "a=", "a", "a=\"x\"", "a=x\\y", "a-b=1", "a=1\tb=2"};
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        int rc = rt_stats_json(bad[i], out, sizeof out, &e);
        CHECK(rc == -1 && !strcmp(out, "{}") && e.msg[0], "stats json '%s' accepted: %s", bad[i], out);
    }
    CHECK(rt_stats_json("key=12345678901234567890", out, 16, &e) == -1, "a too small buffer is refused");
}

int main(void)
{
    char dir[] = "/tmp/rt_test_db_XXXXXX";
    if (!mkdtemp(dir)) return 1;
    char path[256], bad[300];
    snprintf(path, sizeof path, "%s/r.db", dir);
    rt_err e = {0};
    rt_db *db = rt_db_open(path, &e);
    CHECK(db, "open: %s", e.msg);
    if (!db) return 1;
    CHECK(count(db, "PRAGMA user_version") == RT_DB_SCHEMA_VERSION, "user_version");
    CHECK(count(db, "SELECT count(*) FROM classes") == RT_NCLASS, "classes");
    sqlite3_stmt *st;
    sqlite3_prepare_v2(rt_db_handle(db), "PRAGMA journal_mode", -1, &st, NULL);
    sqlite3_step(st);
    CHECK(!strcmp((const char *)sqlite3_column_text(st, 0), "wal"), "WAL mode");
    sqlite3_finalize(st);

    rt_db_traffic rows[64];
    size_t n = make_rows(rows);
    rt_db_run r;
    run_key(&r, "recursive", 0, 0);
    CHECK(rt_db_has_run(db, &r, &e) == 0, "has_run before");
    int64_t id1 = 0, id2 = 0;
    CHECK(rt_db_store_run(db, &r, rows, n, &id1, &e) == 0, "store: %s", e.msg);
    CHECK(rt_db_has_run(db, &r, &e) == 1, "has_run after");
    r.wall_time = 5;
    CHECK(rt_db_store_run(db, &r, rows, n, &id2, &e) == 0, "store again: %s", e.msg);
    CHECK(id1 == id2, "same run id");
    CHECK(count(db, "SELECT count(*) FROM runs") == 1, "one run after storing twice");
    CHECK(count(db, "SELECT count(*) FROM scenes") == 1, "one scene");
    CHECK(count(db, "SELECT count(*) FROM traffic") == (long long)n, "traffic rows not duplicated");
    CHECK(count(db, "SELECT count(*) FROM cache_configs") == 13, "13 configs");
    CHECK(getd(db, "SELECT wall_time FROM runs") == 5, "provenance updated");
    /* views: MB = 2^20 */
    CHECK(getd(db, "SELECT ray_mb FROM v_paper WHERE cache_size = 2048") == 32.0, "ray_mb = 32.00");
    CHECK(getd(db, "SELECT geometry_mb FROM v_paper WHERE cache_size = 1024") == (6400000.0 + 64000.0) / 1048576.0,
          "geometry_mb");
    CHECK(count(db, "SELECT count(*) FROM v_paper") == 13, "v_paper rows");
    CHECK(count(db, "SELECT count(*) FROM v_traffic_group WHERE other_mb = 0") == 13, "v_traffic_group");

    /* a different key (scheduled cache size) is a different run */
    run_key(&r, "dynamic", 1, 65536);
    CHECK(rt_db_store_run(db, &r, rows, n, NULL, &e) == 0, "store dynamic");
    CHECK(count(db, "SELECT count(*) FROM runs") == 2, "two runs");

    /* failure in the middle of a store leaves nothing */
    run_key(&r, "packet", 0, 0);
    r.scene = "grove"; /* new scene row must be rolled back too */
    rt_db_fail_row_after = 7;
    CHECK(rt_db_store_run(db, &r, rows, n, NULL, &e) < 0, "injected failure");
    CHECK(strstr(e.msg, path) != NULL, "failure message names the db: %s", e.msg);
    CHECK(count(db, "SELECT count(*) FROM runs") == 2, "no run row after failure");
    CHECK(count(db, "SELECT count(*) FROM scenes") == 1, "no scene row after failure");
    CHECK(count(db, "SELECT count(*) FROM traffic") == 2 * (long long)n, "no traffic rows after failure");
    int saved = rows[20].cls;
    rows[20].cls = 99; /* bad class mid-way: also rolled back */
    CHECK(rt_db_store_run(db, &r, rows, n, NULL, &e) < 0, "bad class fails");
    CHECK(count(db, "SELECT count(*) FROM traffic") == 2 * (long long)n, "no rows after bad class");
    rows[20].cls = saved;
    CHECK(rt_db_store_run(db, &r, rows, n, NULL, &e) == 0, "store after failures: %s", e.msg);
    rt_db_close(db);

    /* two processes writing different runs concurrently lose nothing */
    enum { PER_CHILD = 25 };
    pid_t kids[2];
    for (int c = 0; c < 2; c++) {
        kids[c] = fork();
        if (kids[c] == 0) {
            rt_db *d = rt_db_open(path, &e);
            if (!d) _exit(2);
            for (int i = 0; i < PER_CHILD; i++) {
                rt_db_run k;
                run_key(&k, c ? "dynamic" : "recursive", 7, (uint64_t)(i + 1) * 1024 + (uint64_t)c);
                if (rt_db_store_run(d, &k, rows, n, NULL, &e)) {
                    fprintf(stderr, "child %d: %s\n", c, e.msg);
                    _exit(3);
                }
            }
            rt_db_close(d);
            _exit(0);
        }
    }
    for (int c = 0; c < 2; c++) {
        int status = 0;
        waitpid(kids[c], &status, 0);
        CHECK(WIFEXITED(status) && WEXITSTATUS(status) == 0, "child %d failed (%d)", c, status);
    }
    db = rt_db_open(path, &e);
    CHECK(db, "reopen: %s", e.msg);
    CHECK(count(db, "SELECT count(*) FROM runs WHERE lights = 7") == 2 * PER_CHILD, "concurrent runs all stored");
    CHECK(count(db, "SELECT count(*) FROM traffic t JOIN runs r ON r.id = t.run_id WHERE r.lights = 7") ==
              2 * PER_CHILD * (long long)n, "concurrent traffic rows all stored");
    rt_db_close(db);

    /* storing a simulator's results */
    {
        rt_sim_config c;
        rt_sim_config_default(&c);
        rt_sim *s = rt_sim_new(&c, NULL);
        for (uint64_t i = 0; i < (1u << 20); i++) {
            rt_access a = {0x20000000ULL + i * 32, 32, 0, RT_CLS_RAY, 0};
            rt_sim_put(s, &a, 1);
        }
        rt_db_traffic *sr = calloc((size_t)c.nsizes * RT_NCLASS, sizeof *sr);
        size_t sn = rt_sim_db_rows(s, sr);
        CHECK(sn == 13, "one class x 13 sizes: %zu rows", sn);
        db = rt_db_open(path, &e);
        run_key(&r, "stream", 0, 0);
        CHECK(rt_db_store_run(db, &r, sr, sn, NULL, &e) == 0, "store sim rows: %s", e.msg);
        /* 1M rays x 32 B read once: 32.00 MB at every size */
        CHECK(getd(db, "SELECT ray_mb FROM v_paper WHERE tracer = 'stream' AND cache_size = 4194304") == 32.0,
              "1M x 32 B rays = 32.00 MB");
        rt_db_close(db);
        free(sr);
        rt_sim_free(s);
    }

    /* errors name the path */
    snprintf(bad, sizeof bad, "%s/no/such/dir/x.db", dir);
    CHECK(!rt_db_open(bad, &e) && strstr(e.msg, bad), "unopenable: %s", e.msg);
    snprintf(bad, sizeof bad, "%s/corrupt.db", dir);
    FILE *f = fopen(bad, "w");
    for (int i = 0; i < 200; i++) fputs("this is not a database at all ", f);
    fclose(f);
    CHECK(!rt_db_open(bad, &e) && strstr(e.msg, bad), "corrupt: %s", e.msg);
    if (getuid() != 0) { /* root can write anything */
        snprintf(bad, sizeof bad, "%s/ro.db", dir);
        db = rt_db_open(bad, &e);
        rt_db_close(db);
        chmod(bad, 0444);
        CHECK(!rt_db_open(bad, &e) && strstr(e.msg, bad), "read-only: %s", e.msg);
    }

    if (check_long()) test_fresh_concurrent(dir, 8, 5, rows, n);
    else test_fresh_concurrent(dir, 4, 2, rows, n);
    if (getenv("RT_DB_STRESS")) test_fresh_concurrent(dir, 8, atoi(getenv("RT_DB_STRESS")), rows, n);
    test_upgrade_v1(dir);
    test_upgrade_v2(dir);
    test_foreign(dir);
    test_merge(dir, rows, n);
    test_gen_rows(dir);
    test_upgrade_v3(dir, rows, n);
    test_upgrade_v4(dir);
    test_upgrade_v5(dir);
    test_upgrade_v6(dir, rows, n);
    test_upgrade_v7(dir);
    test_stats_json();
    test_se_rows(dir);

    if (check_rm_tree(dir) != 0) fprintf(stderr, "warning: could not remove %s\n", dir);
    if (failures) fprintf(stderr, "test_db: %d failures\n", failures);
    else printf("test_db: ok\n");
    return failures ? 1 : 0;
}
