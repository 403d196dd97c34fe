/*
 * test_experiment.c -- one job run in-process (rt_exp_run_job, what sweep
 * runs) against the slow, obviously-correct route: write the trace, replay
 * it through rt_sim_replay and turn the counters into rows. The stored rows
 * must equal the replayed ones, the key built from the trace header must
 * find the stored run (one identity formatter), a rerun must skip, and a
 * store that fails must leave nothing. Also the fan-out sink on its own.
 */
#include "experiment.h"
#include "rows.h"
#include "check.h"

#include <dirent.h>
#include <sqlite3.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
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

/* ---- fan-out ----------------------------------------------------------- */

typedef struct counter {
    rt_sink s;
    uint64_t n, sum; /* references, sum of addresses */
    int fail;        /* put returns -1 */
} counter;

static int counter_put(rt_sink *s, const rt_access *a, size_t n)
{
    counter *c = s->ctx;
    for (size_t i = 0; i < n; i++) c->sum += a[i].addr;
    c->n += n;
    return c->fail ? -1 : 0;
}

static void test_fan(void)
{
    counter c[3] = {{{counter_put, &c[0]}, 0, 0, 0}, {{counter_put, &c[1]}, 0, 0, 1}, {{counter_put, &c[2]}, 0, 0, 0}};
    rt_exp_fan f;
    rt_err e = {""};
    rt_exp_fan_init(&f);
    for (int i = 0; i < 3; i++) CHECK(rt_exp_fan_add(&f, &c[i].s, &e) == i, "fan index");
    rt_access a[3] = {{.addr = 10}, {.addr = 20}, {.addr = 30}};
    rt_sink *s = rt_exp_fan_sink(&f);
    CHECK(s->put(s, a, 3) == -1, "a failing target fails the fan");
    for (int i = 0; i < 3; i++) CHECK(c[i].n == 3 && c[i].sum == 60, "target %d got %llu refs, sum %llu", i,
                                      (unsigned long long)c[i].n, (unsigned long long)c[i].sum);
    for (int i = 3; i < RT_EXP_MAXFAN; i++) rt_exp_fan_add(&f, &c[0].s, &e);
    CHECK(rt_exp_fan_add(&f, &c[0].s, &e) == -1, "fan accepts more than %d targets", RT_EXP_MAXFAN);
}

/* ---- run_job against trace + replay ------------------------------------ */

static char *tracers[] = {"recursive", "packet", "dynamic"};

static void config(rt_exp_config *c, const char *keep)
{
    static char knot[] = "knot";
    memset(c, 0, sizeof *c);
    c->scenes[0] = knot;
    c->nscenes = 1;
    for (int i = 0; i < 3; i++) c->tracers[i] = tracers[i];
    c->ntracers = 3;
    c->lightings[0] = (rt_exp_lighting){"all", 7};
    c->nlightings = 1;
    rt_sim_config_default(&c->sim);
    rt_err e = {""};
    rt_sim_parse_sizes("1K,4K,64K", &c->sim, &e);
    rt_render_default_opts(&c->ro);
    c->ro.W = 32;
    c->ro.H = 32;
    c->keep = keep;
    c->command = "test_experiment";
}

/* The stored exact run matching the trace header's key: its rows must be
 * those of replaying the trace. */
static void compare_with_replay(rt_db *db, const rt_exp_config *c, const rt_exp_job *jb, const char *trace)
{
    rt_err e = {""};
    rt_sim_config sc = c->sim;
    if (jb->sched) {
        sc.nsizes = 1;
        sc.sizes[0] = jb->sched;
    }
    rt_sim *s = rt_sim_new(&sc, &e);
    rt_tr_meta m;
    rt_sim_input in;
    CHECK(s && rt_sim_replay(s, trace, RT_SIM_IN_AUTO, 0, &m, &in, &e) == 0, "replay %s: %s", trace, e.msg);
    rt_db_traffic rows[RT_SIM_MAXSIZES * RT_NCLASS];
    size_t n = rt_sim_db_rows(s, rows);
    rt_db_run key;
    rt_exp_run_from_meta(&m, &key);
    CHECK(rt_db_has_run(db, &key, &e) == 1, "%s: the trace header's key (params '%s') finds no stored run", trace,
          m.params);
    sqlite3 *h = rt_db_handle(db);
    sqlite3_stmt *st;
    char sql[256];
    snprintf(sql, sizeof sql, "SELECT r.refs, COUNT(*) FROM runs r JOIN traffic t ON t.run_id = r.id WHERE "
                              "r.tracer = '%s' AND r.sched_size = %llu AND r.sim_method = 'exact'",
             jb->tracer, (unsigned long long)jb->sched);
    CHECK(sqlite3_prepare_v2(h, sql, -1, &st, NULL) == SQLITE_OK && sqlite3_step(st) == SQLITE_ROW, "%s", sql);
    CHECK((uint64_t)sqlite3_column_int64(st, 0) == in.refs, "%s: stored refs %lld, trace has %llu", trace,
          (long long)sqlite3_column_int64(st, 0), (unsigned long long)in.refs);
    CHECK((size_t)sqlite3_column_int64(st, 1) == n, "%s: %lld stored rows, replay gives %zu", trace,
          (long long)sqlite3_column_int64(st, 1), n);
    sqlite3_finalize(st);
    sqlite3_prepare_v2(h,
                       "SELECT t.accesses, t.read_misses, t.write_misses, t.writebacks, t.wt_bytes, t.traffic_bytes "
                       "FROM traffic t JOIN runs r ON r.id = t.run_id JOIN cache_configs c ON c.id = t.config_id "
                       "WHERE r.tracer = ?1 AND r.sched_size = ?2 AND r.sim_method = 'exact' AND c.size = ?3 "
                       "AND c.line = ?4 AND c.assoc = ?5 AND c.policy = ?6 AND t.class = ?7",
                       -1, &st, NULL);
    for (size_t i = 0; i < n; i++) {
        const rt_db_traffic *r = &rows[i];
        sqlite3_reset(st);
        sqlite3_bind_text(st, 1, jb->tracer, -1, SQLITE_STATIC);
        sqlite3_bind_int64(st, 2, (sqlite3_int64)jb->sched);
        sqlite3_bind_int64(st, 3, (sqlite3_int64)r->size);
        sqlite3_bind_int64(st, 4, r->line);
        sqlite3_bind_int64(st, 5, r->assoc);
        sqlite3_bind_text(st, 6, r->policy, -1, SQLITE_STATIC);
        sqlite3_bind_text(st, 7, rt_class_name(r->cls), -1, SQLITE_STATIC);
        int found = sqlite3_step(st) == SQLITE_ROW;
        CHECK(found, "%s: no stored row for size %llu class %s", trace, (unsigned long long)r->size,
              rt_class_name(r->cls));
        if (!found) continue;
        uint64_t want[6] = {r->accesses, r->read_misses, r->write_misses, r->writebacks, r->wt_bytes, r->traffic_bytes};
        for (int k = 0; k < 6; k++)
            CHECK((uint64_t)sqlite3_column_int64(st, k) == want[k], "%s: size %llu class %s column %d: stored %lld, "
                  "replayed %llu", trace, (unsigned long long)r->size, rt_class_name(r->cls), k,
                  (long long)sqlite3_column_int64(st, k), (unsigned long long)want[k]);
    }
    sqlite3_finalize(st);
    rt_sim_free(s);
}

static int by_name(const void *a, const void *b) { return strcmp(*(char *const *)a, *(char *const *)b); }

static void test_run_job(const char *dir)
{
    char keep[512], path[600];
    snprintf(keep, sizeof keep, "%s/traces", dir);
    snprintf(path, sizeof path, "%s/e.db", dir);
    CHECK(mkdir(keep, 0777) == 0, "mkdir %s", keep);
    rt_exp_config c;
    config(&c, keep);
    rt_err e = {""};
    rt_exp_job *J = NULL;
    long nj = rt_exp_matrix(&c, &J, &e);
    CHECK(nj == 5, "matrix of recursive, packet and dynamic at 3 sizes has %ld jobs, want 5", nj);
    rt_db *db = rt_db_open(path, &e);
    rt_exp_worker *w = db ? rt_exp_worker_new(&c, db, &e) : NULL;
    CHECK(w != NULL, "worker: %s", e.msg);
    if (!w || nj != 5) return;
    for (long i = 0; i < nj; i++) CHECK(rt_exp_run_job(w, &J[i], i, &e) == 1, "job %ld: %s", i, e.msg);
    CHECK(count(db, "SELECT COUNT(*) FROM runs") == 5, "5 runs stored");
    /* the kept traces, in job order (job%04ld prefix) */
    char *names[8];
    int nt = 0;
    DIR *d = opendir(keep);
    for (struct dirent *de; d && (de = readdir(d));)
        if (strstr(de->d_name, ".rtt") && nt < 8) names[nt++] = strdup(de->d_name);
    if (d) closedir(d);
    qsort(names, (size_t)nt, sizeof *names, by_name);
    CHECK(nt == 5, "%d traces kept, want 5", nt);
    for (int i = 0; i < nt && i < nj; i++) {
        char tp[1200];
        snprintf(tp, sizeof tp, "%s/%s", keep, names[i]);
        compare_with_replay(db, &c, &J[i], tp);
        free(names[i]);
    }
    /* resume: a stored job is skipped and changes nothing */
    long long runs = count(db, "SELECT COUNT(*) FROM runs"), rows = count(db, "SELECT COUNT(*) FROM traffic");
    CHECK(rt_exp_run_job(w, &J[0], 0, &e) == 0, "a stored job was not skipped");
    CHECK(count(db, "SELECT COUNT(*) FROM runs") == runs && count(db, "SELECT COUNT(*) FROM traffic") == rows,
          "a skipped job changed the database");
    rt_exp_worker_free(w);
    rt_db_close(db);
    free(J);
}

static void test_failing_store(const char *dir)
{
    char path[600];
    snprintf(path, sizeof path, "%s/f.db", dir);
    rt_exp_config c;
    config(&c, NULL);
    c.ntracers = 1;
    rt_err e = {""};
    rt_exp_job *J = NULL;
    long nj = rt_exp_matrix(&c, &J, &e);
    rt_db *db = rt_db_open(path, &e);
    rt_exp_worker *w = db ? rt_exp_worker_new(&c, db, &e) : NULL;
    CHECK(w && nj == 1, "setup: %s", e.msg);
    if (!w || nj != 1) return;
    rt_db_fail_row_after = 3;
    CHECK(rt_exp_run_job(w, &J[0], 0, &e) == -1, "injected failure not reported");
    CHECK(strstr(e.msg, "injected failure") != NULL, "message: %s", e.msg);
    rt_db_fail_row_after = 0;
    CHECK(count(db, "SELECT COUNT(*) FROM runs") == 0 && count(db, "SELECT COUNT(*) FROM traffic") == 0 &&
              count(db, "SELECT COUNT(*) FROM scenes") == 0,
          "a failed store left rows behind");
    /* and the job runs normally afterwards */
    CHECK(rt_exp_run_job(w, &J[0], 0, &e) == 1, "rerun after failure: %s", e.msg);
    CHECK(count(db, "SELECT COUNT(*) FROM runs") == 1, "rerun stored one run");
    rt_exp_worker_free(w);
    rt_db_close(db);
    free(J);
}

int main(void)
{
    char dir[] = "/tmp/rt-exp-XXXXXX";
    if (!mkdtemp(dir)) return 1;
    test_fan();
    test_run_job(dir);
    test_failing_store(dir);
    char cmd[64];
    snprintf(cmd, sizeof cmd, "rm -rf %s", dir);
    if (system(cmd) != 0) fprintf(stderr, "cannot remove %s\n", dir);
    if (failures) fprintf(stderr, "%d failure(s)\n", failures);
    else printf("experiment tests passed\n");
    return failures ? 1 : 0;
}
