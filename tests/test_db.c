/*
 * test_db.c -- the results database: schema, idempotent stores, rollback of
 * a failed store, concurrent writers (fork), views, error messages.
 */
#include "check.h"
#include "rows.h"
#include "memmodel.h"
#include "sim.h"

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
    r->cache_size = cache;
    r->refs = 123456789;
    r->trace_hash = 0x8000000000000001ULL;
    r->command = "test_db";
}

int main(void)
{
    char dir[] = "/tmp/rt_test_db_XXXXXX";
    if (!mkdtemp(dir)) return 1;
    char path[256], bad[300];
    snprintf(path, sizeof path, "%s/r.db", dir);
    rt_err e = {{0}};
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
            rt_access a = {0x20000000ULL + i * 32, 32, 0, RT_CLS_RAY};
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

    char cmd[400];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", dir);
    if (system(cmd) != 0) fprintf(stderr, "warning: could not remove %s\n", dir);
    if (failures) fprintf(stderr, "test_db: %d failures\n", failures);
    else printf("test_db: ok\n");
    return failures ? 1 : 0;
}
