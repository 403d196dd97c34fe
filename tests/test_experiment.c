/*
 * test_experiment.c -- one job run in-process (rt_exp_run_job, what sweep
 * runs) against the slow, obviously-correct route: write the trace, replay
 * it through rt_sim_replay and turn the counters into rows. The stored rows
 * must equal the replayed ones, the key built from the trace header must
 * find the stored run (one identity formatter), a rerun must skip, and a
 * store that fails must leave nothing. Also the fan-out sink on its own,
 * and the render modes: the matrix of --modes, and per-generation rows of
 * whitted and path jobs (they sum to the traffic rows; their accesses equal
 * a plain per-generation count of the job's line touches; a kept trace
 * replayed gives the same rows; shadow jobs have none); the hybrid's
 * standard errors stored bit for bit as its kept trace replayed gives them.
 */
#include "experiment.h"
#include "rows.h"
#include "run.h"
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
    rt_err e = {0};
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
    rt_err e = {0};
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
    rt_err e = {0};
    rt_sim_config sc = c->sim;
    if (jb->sched_size) {
        sc.nsizes = 1;
        sc.sizes[0] = jb->sched_size;
    }
    rt_sim *s = rt_sim_new(&sc, &e);
    rt_tr_meta m;
    rt_sim_input in;
    CHECK(s && rt_sim_replay(s, trace, RT_SIM_IN_AUTO, 0, &m, &in, &e) == 0, "replay %s: %s", trace, e.msg);
    rt_sim_finish(s); /* the flush, when the model's accounting has one */
    rt_db_traffic rows[RT_SIM_MAXSIZES * RT_NCLASS];
    size_t n = rt_sim_db_rows(s, rows);
    rt_db_run key;
    char sp[160];
    rt_exp_run_from_meta(&m, &key);
    key.sim_params = rt_exp_sim_params(c->model, &c->sim, sp, sizeof sp); /* not in the trace header */
    CHECK(rt_db_has_run(db, &key, &e) == 1, "%s: the trace header's key (params '%s') finds no stored run", trace,
          m.params);
    sqlite3 *h = rt_db_handle(db);
    sqlite3_stmt *st;
    char sql[256];
    snprintf(sql, sizeof sql, "SELECT r.refs, COUNT(*) FROM runs r JOIN traffic t ON t.run_id = r.id WHERE "
                              "r.tracer = '%s' AND r.sched_size = %llu AND r.sim_method = 'exact'",
             jb->tracer, (unsigned long long)jb->sched_size);
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
        sqlite3_bind_int64(st, 2, (sqlite3_int64)jb->sched_size);
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
    rt_err e = {0};
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

/* Standard errors: a job with two hybrid estimators, one with errors and
 * one without, stores the first's errors per size exactly as an rt_approx
 * fed the kept trace computes them (the same doubles, bit for bit), and
 * none for the second; errors=1 ends the first's key only (not a shards
 * run's, which has no errors to store). */
static void test_errors(const char *dir)
{
    char keep[512], path[600];
    snprintf(keep, sizeof keep, "%s/se-traces", dir);
    snprintf(path, sizeof path, "%s/se.db", dir);
    CHECK(mkdir(keep, 0777) == 0, "mkdir %s", keep);
    rt_exp_config c;
    config(&c, keep);
    c.ntracers = 1; /* recursive */
    for (int a = 0; a < 2; a++) {
        rt_approx_config *ac = &c.approx[a];
        rt_approx_config_default(ac);
        ac->method = RT_APPROX_HYBRID;
        ac->rate = 0.25;
        ac->window_below = 4096;
        ac->period = 256;
        ac->window = 64;
        ac->errors = a == 0;
    }
    c.napprox = 2;
    rt_err e = {0};
    rt_exp_job *J = NULL;
    long nj = rt_exp_matrix(&c, &J, &e);
    rt_db *db = rt_db_open(path, &e);
    rt_exp_worker *w = db ? rt_exp_worker_new(&c, db, &e) : NULL;
    CHECK(nj == 1 && w, "one job, a worker: %s", e.msg);
    if (nj != 1 || !w) {
        rt_exp_worker_free(w);
        rt_db_close(db);
        free(J);
        return;
    }
    CHECK(rt_exp_run_job(w, &J[0], 0, &e) == 1, "job: %s", e.msg);
    CHECK(count(db, "SELECT COUNT(*) FROM runs WHERE sim_method = 'hybrid' AND sim_params LIKE '% errors=1'") == 1 &&
              count(db, "SELECT COUNT(*) FROM runs WHERE sim_method = 'hybrid' AND sim_params NOT LIKE '%errors%'") ==
                  1,
          "one hybrid run with errors=1, one without");
    CHECK(count(db, "SELECT COUNT(*) FROM traffic_se e JOIN runs r ON r.id = e.run_id WHERE r.sim_params NOT LIKE "
                    "'%errors=1'") == 0,
          "the run without errors has error rows");
    /* the kept trace through an rt_approx of the same settings */
    char tp[1200] = "";
    DIR *d = opendir(keep);
    for (struct dirent *de; d && (de = readdir(d));)
        if (strstr(de->d_name, ".rtt")) snprintf(tp, sizeof tp, "%s/%s", keep, de->d_name);
    if (d) closedir(d);
    rt_approx *ap = rt_approx_new(&c.sim, &c.approx[0], &e);
    rt_tr_meta m;
    rt_sim_input in;
    CHECK(ap && tp[0] && rt_approx_replay(ap, tp, RT_SIM_IN_AUTO, 0, &m, &in, &e) == 0 && rt_approx_finish(ap, &e) == 0,
          "replay %s: %s", tp, e.msg);
    rt_db_se se[RT_SIM_MAXSIZES];
    size_t n = ap ? rt_approx_db_se_rows(ap, se) : 0;
    CHECK(n == 3, "errors of %zu sizes, want 3 (1K, 4K, 64K)", n);
    CHECK(count(db, "SELECT COUNT(*) FROM traffic_se") == (long long)n, "stored error rows");
    sqlite3_stmt *st;
    sqlite3_prepare_v2(rt_db_handle(db),
                       "SELECT e.geometry_se, e.ray_se, e.other_se, e.total_se FROM traffic_se e JOIN cache_configs c "
                       "ON c.id = e.config_id WHERE c.size = ?1",
                       -1, &st, NULL);
    int nonzero = 0;
    for (size_t i = 0; i < n; i++) {
        sqlite3_reset(st);
        sqlite3_bind_int64(st, 1, (sqlite3_int64)se[i].size);
        CHECK(sqlite3_step(st) == SQLITE_ROW, "no error row of size %llu", (unsigned long long)se[i].size);
        for (int g = 0; g < RT_DB_SE_N; g++) {
            int null = sqlite3_column_type(st, g) == SQLITE_NULL;
            double v = sqlite3_column_double(st, g);
            CHECK(se[i].se[g] < 0 ? null : !null && v == se[i].se[g], "size %llu group %d: stored %s%.17g, replay %.17g",
                  (unsigned long long)se[i].size, g, null ? "NULL " : "", v, se[i].se[g]);
            nonzero += se[i].se[g] > 0;
        }
    }
    CHECK(nonzero >= 6, "only %d errors above 0: the test compares little", nonzero);
    sqlite3_finalize(st);
    rt_approx_free(ap);
    /* the key: errors=1 for the hybrid with errors only */
    rt_exp_key k;
    memset(&k, 0, sizeof k);
    rt_approx_config sh = c.approx[0];
    sh.method = RT_APPROX_SHARDS_RATE;
    rt_exp_key_method(&k, &sh);
    CHECK(!strstr(k.run.sim_params, "errors"), "shards key: %s", k.run.sim_params);
    rt_exp_key_method(&k, &c.approx[0]);
    size_t kl = strlen(k.run.sim_params);
    CHECK(kl > 9 && !strcmp(k.run.sim_params + kl - 9, " errors=1"), "hybrid key: %s", k.run.sim_params);
    rt_exp_worker_free(w);
    rt_db_close(db);
    free(J);
}

/* Models: a paper-model run is the lean job's stream simulated with the
 * flush and full-line writes (replayed from its kept trace, finished, row
 * for row), under its own key; lean and paper runs of the same jobs share
 * no key, so both are stored in one database and neither skips the other. */
static void test_models(const char *dir)
{
    char keep[512], path[600];
    snprintf(keep, sizeof keep, "%s/model-traces", dir);
    snprintf(path, sizeof path, "%s/models.db", dir);
    CHECK(mkdir(keep, 0777) == 0, "mkdir %s", keep);
    CHECK(rt_exp_model_find("paper") == RT_EXP_MODEL_PAPER && rt_exp_model_find("lean") == RT_EXP_MODEL_LEAN &&
              rt_exp_model_find("other") < 0,
          "model names");
    rt_err e = {0};
    rt_db *db = rt_db_open(path, &e);
    CHECK(db != NULL, "%s", e.msg);
    if (!db) return;
    long nj = 0;
    for (int model = RT_EXP_MODEL_PAPER; model >= RT_EXP_MODEL_LEAN; model--) {
        rt_exp_config c;
        config(&c, model == RT_EXP_MODEL_PAPER ? keep : NULL);
        c.model = model;
        rt_exp_model_apply(rt_exp_model_get(model), &c.ro, &c.sim);
        CHECK(c.sim.flush == (model == RT_EXP_MODEL_PAPER) && c.sim.write_miss_fullline == c.sim.flush &&
                  c.ro.geom == (model == RT_EXP_MODEL_PAPER ? RT_GEOM_PBRT : RT_GEOM_COMPACT) &&
                  c.ro.qstores == RT_QSTORES_WRITE_ALLOCATE,
              "model %d settings", model);
        rt_exp_job *J = NULL;
        nj = rt_exp_matrix(&c, &J, &e);
        rt_exp_worker *w = rt_exp_worker_new(&c, db, &e);
        for (long i = 0; i < nj && w; i++) CHECK(rt_exp_run_job(w, &J[i], i, &e) == 1, "model %d job %ld: %s", model, i, e.msg);
        rt_exp_worker_free(w);
        if (model == RT_EXP_MODEL_PAPER) {
            CHECK(count(db, "SELECT COUNT(*) FROM runs WHERE sim_params = 'model=paper policy=wb-wa+flush+fullline'") == nj,
                  "paper runs carry the model and the accounting");
            char *names[8];
            int nt = 0;
            DIR *d = opendir(keep);
            for (struct dirent *de; d && (de = readdir(d));)
                if (strstr(de->d_name, ".rtt") && nt < 8) names[nt++] = strdup(de->d_name);
            if (d) closedir(d);
            qsort(names, (size_t)nt, sizeof *names, by_name);
            CHECK(nt == nj, "%d traces kept, want %ld", nt, nj);
            for (int i = 0; i < nt && i < nj; i++) {
                char tp[1200];
                snprintf(tp, sizeof tp, "%s/%s", keep, names[i]);
                compare_with_replay(db, &c, &J[i], tp); /* the only runs so far: the query finds them */
                free(names[i]);
            }
        }
        free(J);
    }
    CHECK(count(db, "SELECT COUNT(*) FROM runs") == 2 * nj, "lean and paper runs both stored (%ld jobs each)", nj);
    CHECK(count(db, "SELECT COUNT(*) FROM runs WHERE sim_params = ''") == nj, "lean runs keep the old key");
    /* the flush wrote back something: more write-backs under the paper model */
    CHECK(count(db, "SELECT (SELECT SUM(t.writebacks) FROM traffic t JOIN cache_configs c ON c.id = t.config_id WHERE "
                    "c.policy = 'wb-wa+flush+fullline') > (SELECT SUM(t.writebacks) FROM traffic t JOIN cache_configs c "
                    "ON c.id = t.config_id WHERE c.policy = 'wb-wa')") == 1,
          "paper model: flushed write-backs");
    rt_db_close(db);
}

static void test_failing_store(const char *dir)
{
    char path[600];
    snprintf(path, sizeof path, "%s/f.db", dir);
    rt_exp_config c;
    config(&c, NULL);
    c.ntracers = 1;
    rt_err e = {0};
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

/* Line touches (64-byte lines) per generation bucket, the plain way. */
typedef struct gencount {
    rt_sink s;
    uint64_t touches[RT_MAXGEN];
    unsigned maxgen;
} gencount;

static int gencount_put(rt_sink *s, const rt_access *a, size_t n)
{
    gencount *g = s->ctx;
    for (size_t i = 0; i < n; i++) {
        uint32_t sz = a[i].size ? a[i].size : 1;
        g->touches[rt_gen_bucket(a[i].gen)] += (a[i].addr + sz - 1) / 64 - a[i].addr / 64 + 1;
        if (a[i].gen > g->maxgen) g->maxgen = a[i].gen;
    }
    return 0;
}

static void test_modes(const char *dir)
{
    char keep[512], path[600];
    snprintf(keep, sizeof keep, "%s/mtraces", dir);
    snprintf(path, sizeof path, "%s/m.db", dir);
    CHECK(mkdir(keep, 0777) == 0, "mkdir %s", keep);
    rt_exp_config c;
    config(&c, keep);
    c.tracers[1] = tracers[2]; /* recursive, dynamic */
    c.ntracers = 2;
    c.lightings[0] = (rt_exp_lighting){"primary", 0};
    c.lightings[1] = (rt_exp_lighting){"all", 7};
    c.nlightings = 2;
    c.ro.depth = 3;
    c.ro.bounces = 2;
    rt_sim_parse_sizes("1K,64K", &c.sim, NULL);
    rt_err e = {0};
    rt_exp_job *J = NULL;
    /* raycast alone: one lightless job per tracer (1 + 2 sizes) */
    c.modes[0] = RT_MODE_RAYCAST;
    c.nmodes = 1;
    long nj = rt_exp_matrix(&c, &J, &e);
    CHECK(nj == 3 && J[0].lighting == -1 && rt_exp_job_opts(&c, &J[0]).lights == 0 &&
              rt_exp_job_opts(&c, &J[0]).mode == RT_MODE_DEFAULT, "raycast matrix: %ld jobs", nj);
    free(J);
    /* shadow (both lightings, primary holds the raycast runs), whitted and
     * path (the lit lighting only), raycast (already swept: no job) */
    int modes[4] = {RT_MODE_SHADOW, RT_MODE_WHITTED, RT_MODE_PATH, RT_MODE_RAYCAST};
    memcpy(c.modes, modes, sizeof modes);
    c.nmodes = 4;
    nj = rt_exp_matrix(&c, &J, &e);
    CHECK(nj == 2 * 3 + 3 + 3, "modes matrix has %ld jobs, want 12", nj);
    if (nj != 12) return;
    CHECK(J[0].mode == RT_MODE_DEFAULT && J[6].mode == RT_MODE_WHITTED && J[6].lighting == 1 &&
              J[9].mode == RT_MODE_PATH, "job modes in order");
    rt_db *db = rt_db_open(path, &e);
    rt_exp_worker *w = db ? rt_exp_worker_new(&c, db, &e) : NULL;
    CHECK(w != NULL, "worker: %s", e.msg);
    if (!w) return;
    for (long i = 0; i < nj; i++) CHECK(rt_exp_run_job(w, &J[i], i, &e) == 1, "job %ld: %s", i, e.msg);
    CHECK(count(db, "SELECT COUNT(*) FROM runs") == 12, "12 runs stored");
    CHECK(count(db, "SELECT COUNT(*) FROM traffic_gen t JOIN runs r ON r.id = t.run_id WHERE r.params NOT LIKE "
                    "'%mode=%'") == 0, "shadow and raycast runs have no generation rows");
    CHECK(count(db, "SELECT COUNT(DISTINCT run_id) FROM traffic_gen") == 6, "every whitted and path run has them");
    CHECK(count(db, "SELECT COUNT(*) FROM runs WHERE params LIKE '%mode=whitted depth=3%'") == 3 &&
              count(db, "SELECT COUNT(*) FROM runs WHERE params LIKE '%mode=path spp=1 bounces=2%'") == 3,
          "mode parameters in the run keys");
    static const char sum_sql[] =
        "SELECT count(*) FROM traffic t JOIN (SELECT run_id, config_id, class, sum(accesses) a, sum(read_misses) rm,"
        " sum(write_misses) wm, sum(writebacks) wb, sum(traffic_bytes) tb FROM traffic_gen GROUP BY 1, 2, 3) g"
        " USING (run_id, config_id, class) WHERE g.a = t.accesses AND g.rm = t.read_misses AND"
        " g.wm = t.write_misses AND g.wb = t.writebacks AND g.tb = t.traffic_bytes";
    CHECK(count(db, sum_sql) == count(db, "SELECT count(*) FROM traffic WHERE run_id IN (SELECT run_id FROM traffic_gen)"),
          "generation rows sum to the traffic rows of their runs");
    CHECK(count(db, "SELECT max(gen) FROM traffic_gen") == 2, "highest generation = depth - 1 = bounces = 2");
    /* each secondary job: per-generation accesses = a plain count of its stream */
    for (long i = 6; i < nj; i++) {
        rt_render_opts ro = rt_exp_job_opts(&c, &J[i]);
        rt_job j;
        gencount g;
        memset(&g, 0, sizeof g);
        g.s.put = gencount_put;
        g.s.ctx = &g;
        rt_run_stats st;
        rt_image *img = rt_image_new(ro.W, ro.H, &e);
        CHECK(img && rt_job_setup(&j, "knot", J[i].tracer, &ro, &e) == 0, "setup: %s", e.msg);
        CHECK(rt_job_run(&j, &g.s, img, &st, &e) == 0, "run: %s", e.msg);
        rt_tr_meta *m = calloc(1, sizeof *m);
        rt_job_meta(&j, NULL, m);
        CHECK(m->generations == 2 && g.maxgen == 2, "job %ld: meta generations %u, stream reaches %u", i,
              m->generations, g.maxgen);
        free(m);
        for (int gen = 0; gen < RT_MAXGEN; gen++) {
            char sql[400];
            snprintf(sql, sizeof sql,
                     "SELECT coalesce(sum(t.accesses), 0) FROM traffic_gen t JOIN runs r ON r.id = t.run_id JOIN "
                     "cache_configs c ON c.id = t.config_id WHERE r.tracer = '%s' AND r.sched_size = %llu AND "
                     "r.params LIKE '%%mode=%s%%' AND c.size = %llu AND t.gen = %d",
                     J[i].tracer, (unsigned long long)J[i].sched_size, i < 9 ? "whitted" : "path",
                     (unsigned long long)(J[i].sched_size ? J[i].sched_size : 1024), gen);
            CHECK((uint64_t)count(db, sql) == g.touches[gen], "job %ld gen %d: stored %lld accesses, counted %llu", i,
                  gen, count(db, sql), (unsigned long long)g.touches[gen]);
        }
        rt_job_free(&j);
        rt_image_free(img);
    }
    /* a kept trace (version 2) replayed gives the stored generation rows */
    char tp[1200] = "";
    DIR *d = opendir(keep);
    for (struct dirent *de; d && (de = readdir(d));)
        if (strstr(de->d_name, "job0006")) snprintf(tp, sizeof tp, "%s/%s", keep, de->d_name);
    if (d) closedir(d);
    rt_sim *s = rt_sim_new(&c.sim, &e);
    rt_tr_meta *m = calloc(1, sizeof *m);
    rt_sim_input in;
    CHECK(tp[0] && strstr(tp, "-whitted-") && s && rt_sim_replay(s, tp, RT_SIM_IN_AUTO, 0, m, &in, &e) == 0,
          "replay %s: %s", tp, e.msg);
    CHECK(m->generations == 2, "trace header: generations %u", m->generations);
    rt_db_gen *gr = calloc((size_t)c.sim.nsizes * RT_NCLASS * RT_MAXGEN, sizeof *gr);
    size_t ng = rt_sim_db_gen_rows(s, gr);
    long long stored = count(db, "SELECT count(*) FROM traffic_gen t JOIN runs r ON r.id = t.run_id WHERE "
                                 "r.tracer = 'recursive' AND r.params LIKE '%mode=whitted%'");
    CHECK(ng > 0 && (long long)ng == stored, "replayed %zu generation rows, stored %lld", ng, stored);
    uint64_t tb = 0;
    for (size_t k = 0; k < ng; k++) tb += gr[k].t.traffic_bytes * (uint64_t)(gr[k].gen + 1);
    CHECK((long long)tb == count(db, "SELECT sum(t.traffic_bytes * (t.gen + 1)) FROM traffic_gen t JOIN runs r ON "
                                     "r.id = t.run_id WHERE r.tracer = 'recursive' AND r.params LIKE '%mode=whitted%'"),
          "replayed generation rows match the stored ones");
    free(gr);
    free(m);
    rt_sim_free(s);
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
    test_modes(dir);
    test_models(dir);
    test_errors(dir);
    if (check_rm_tree(dir) != 0) fprintf(stderr, "cannot remove %s\n", dir);
    if (failures) fprintf(stderr, "%d failure(s)\n", failures);
    else printf("experiment tests passed\n");
    return failures ? 1 : 0;
}
