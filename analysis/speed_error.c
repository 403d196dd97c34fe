/*
 * speed_error.c -- `raytraffic report --speed-error`: approximate methods
 * against the exact simulation, measured on the database's own runs.
 *
 * For every run whose sim_method is not 'exact', the exact run with the same
 * identity (scene, tracer, size, lights, schedule, tracer parameters) is the
 * reference. Per cache size and group (geometry, ray) it compares the miss
 * ratio (fetch misses / accesses) and the traffic; the table gives, per
 * method and parameters, the wall time of both runs, the speedup, and the
 * mean and maximum over the sizes of the absolute miss-ratio error and of
 * the relative traffic error (%), naming the exact run compared against.
 * Times are simulation times on the same access stream when the sweep
 * measured them (sweep --approx), else the runs' wall times.
 *
 * Reduced experiments (sweep --proxy) are exact simulations of a smaller
 * problem: a lower resolution or a subsample of the pixels. Their
 * reference is the exact full run of the same configuration with the most
 * pixels; miss ratios are compared as they are and traffic is scaled by
 * (reference primary rays / proxy primary rays). Speedups are whole-run
 * wall times (tracer + exact simulation; the reference's approximate
 * simulators, if any ran beside it, are subtracted). For the dynamic
 * scheduler a second table gives the rays per queue event, which is what a
 * reduced experiment changes: fewer rays per pixel of geometry means each
 * queue holds fewer rays when it is processed.
 *
 * Standard errors (schema 5): an approximate run that estimated its error
 * (hybrid with errors, "errors=1" in its sim_params) has one per cache
 * size and group (traffic_se). A section after the table lists, per such
 * run, how many of its estimates lie within 1, 2 and 3 standard errors of
 * the exact run's traffic (geometry, ray, all classes), then every size's
 * estimate beside its standard error and the exact value; the CSV pairs
 * carry the whole traffic's counts as four more columns (empty for runs
 * without errors). A database older than version 5 has none.
 *
 * The plot data (DIR/speed-error.dat) has one point per compared pair:
 * speedup, geometry and ray mean miss-ratio error, and a series index (one
 * series per method and parameter set, one per kind of reduced
 * experiment) whose labels the plot script names (rt_plot_speed_error).
 */
#include "analysis_int.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

/* Pairs (approximate run, exact run) with per-size group figures. */
static const char *pairs_sql =
    "WITH g AS ("
    "  SELECT t.run_id, c.size, k.grp,"
    "    SUM(t.accesses) AS acc, SUM(t.read_misses + t.write_misses) AS miss, SUM(t.traffic_bytes) AS bytes"
    "  FROM traffic t JOIN cache_configs c ON c.id = t.config_id JOIN classes k ON k.name = t.class"
    "  WHERE c.line = 64 AND c.assoc = 0 AND k.grp IN ('geometry', 'ray')"
    "  GROUP BY t.run_id, c.size, k.grp)"
    " SELECT @LABEL@, a.tracer, a.W, a.H, a.lights, a.sched_size, a.sim_method, a.sim_params, a.id, x.id,"
    "   a.wall_time, x.wall_time, ga.grp, ga.size,"
    "   CASE WHEN ga.acc > 0 THEN 1.0 * ga.miss / ga.acc ELSE 0 END,"
    "   CASE WHEN gx.acc > 0 THEN 1.0 * gx.miss / gx.acc ELSE 0 END,"
    "   ga.bytes, gx.bytes, x.stats"
    " FROM runs a JOIN runs x ON x.scene_id = a.scene_id AND x.tracer = a.tracer AND x.W = a.W AND x.H = a.H"
    "   AND x.lights = a.lights AND x.sched_size = a.sched_size AND x.gmax = a.gmax"
    "   AND x.params = a.params AND x.sim_method = 'exact'"
    " JOIN scenes s ON s.id = a.scene_id"
    " JOIN g ga ON ga.run_id = a.id JOIN g gx ON gx.run_id = x.id AND gx.size = ga.size AND gx.grp = ga.grp"
    " WHERE a.sim_method <> 'exact'"
    " ORDER BY s.name, s.hash, a.tracer, a.lights, a.sched_size, a.sim_method, a.sim_params, a.id, ga.grp, ga.size";

/* Pairs (reduced run, full exact run) with per-size group figures. */
static const char *proxy_sql =
    "WITH g AS ("
    "  SELECT t.run_id, c.size, k.grp,"
    "    SUM(t.accesses) AS acc, SUM(t.read_misses + t.write_misses) AS miss, SUM(t.traffic_bytes) AS bytes"
    "  FROM traffic t JOIN cache_configs c ON c.id = t.config_id JOIN classes k ON k.name = t.class"
    "  WHERE c.line = 64 AND c.assoc = 0 AND k.grp IN ('geometry', 'ray')"
    "  GROUP BY t.run_id, c.size, k.grp),"
    " full AS (SELECT r.* FROM runs r WHERE r.sim_method = 'exact' AND r.params NOT LIKE '%subsample=%'"
    "   AND r.W * r.H = (SELECT MAX(q.W * q.H) FROM runs q WHERE q.scene_id = r.scene_id AND q.tracer = r.tracer"
    "     AND q.lights = r.lights AND q.sched_size = r.sched_size AND q.gmax = r.gmax"
    "     AND q.params = r.params AND q.sim_method = 'exact'))"
    " SELECT @LABEL@, a.tracer, a.W, a.H, a.lights, a.sched_size, a.params, a.id, x.id, x.W, x.H,"
    "   a.wall_time, x.wall_time - COALESCE((SELECT SUM(y.wall_time) FROM runs y WHERE y.scene_id = x.scene_id"
    "     AND y.tracer = x.tracer AND y.W = x.W AND y.H = x.H AND y.lights = x.lights"
    "     AND y.sched_size = x.sched_size AND y.gmax = x.gmax AND y.params = x.params"
    "     AND y.sim_method <> 'exact'), 0),"
    "   a.stats, x.stats, ga.grp, ga.size,"
    "   CASE WHEN ga.acc > 0 THEN 1.0 * ga.miss / ga.acc ELSE 0 END,"
    "   CASE WHEN gx.acc > 0 THEN 1.0 * gx.miss / gx.acc ELSE 0 END,"
    "   ga.bytes, gx.bytes"
    " FROM runs a JOIN full x ON x.scene_id = a.scene_id AND x.tracer = a.tracer AND x.lights = a.lights"
    "   AND x.sched_size = a.sched_size AND x.gmax = a.gmax AND x.id <> a.id"
    "   AND (a.params = x.params OR a.params LIKE x.params || ' subsample=%')"
    " JOIN scenes s ON s.id = a.scene_id"
    " JOIN g ga ON ga.run_id = a.id JOIN g gx ON gx.run_id = x.id AND gx.size = ga.size AND gx.grp = ga.grp"
    " WHERE a.sim_method = 'exact' AND (a.W * a.H < x.W * x.H OR a.params LIKE '%subsample=%')"
    " ORDER BY s.name, s.hash, a.tracer, a.lights, a.sched_size, a.W * a.H DESC, a.params, a.id, ga.grp, ga.size";

/* Per size of every run with standard errors (line 64, fully associative,
 * as above): its group estimates and their errors (MB, exact multiples of
 * 2^-20 bytes, so comparisons are those of the bytes), the exact run of
 * the same identity and accounting (sim_params '', at most one by the
 * runs' UNIQUE key) and its traffic in the same configuration, or NULL. */
static const char *se_sql =
    "SELECT @LABEL@, a.tracer, a.lights, a.sched_size, a.sim_method, a.sim_params, a.id, x.id, v.cache_size,"
    "   v.geometry_mb, v.geometry_se_mb, v.ray_mb, v.ray_se_mb, v.total_mb, v.total_se_mb,"
    "   gx.geometry_mb, gx.ray_mb, gx.total_mb"
    " FROM runs a JOIN scenes s ON s.id = a.scene_id JOIN v_traffic_se v ON v.run_id = a.id"
    " LEFT JOIN runs x ON x.scene_id = a.scene_id AND x.tracer = a.tracer AND x.W = a.W AND x.H = a.H"
    "   AND x.lights = a.lights AND x.sched_size = a.sched_size AND x.gmax = a.gmax AND x.params = a.params"
    "   AND x.sim_method = 'exact' AND x.sim_params = ''"
    " LEFT JOIN v_traffic_group gx ON gx.run_id = x.id AND gx.config_id = v.config_id"
    " WHERE v.line = 64 AND v.assoc = 0 AND a.id IN (SELECT run_id FROM traffic_se)"
    " ORDER BY s.name, s.hash, a.tracer, a.lights, a.sched_size, a.sim_method, a.sim_params, a.id, v.cache_size";

/* A "key=" number from a stats string, or NAN. */
static double stat_num(const char *stats, const char *key)
{
    size_t kl = strlen(key);
    for (const char *q = stats; q && (q = strstr(q, key)); q += kl)
        if ((q == stats || q[-1] == ' ') && q[kl] == '=') return strtod(q + kl + 1, NULL);
    return NAN;
}

/* Errors of one compared pair in one group, over the cache sizes. */
typedef struct acc {
    int n;                                 /* sizes compared */
    double mr_sum, mr_max, rel_sum, rel_max; /* absolute miss-ratio error; relative traffic error, % */
} acc;

/* Adds one size: miss ratios (approximate, exact) and traffic bytes. */
static void acc_add(acc *a, double mra, double mrx, double ba, double bx)
{
    double emr = fabs(mra - mrx), rel = bx > 0 ? 100.0 * fabs(ba - bx) / bx : (ba > 0 ? 100.0 : 0.0);
    a->n++;
    a->mr_sum += emr;
    a->rel_sum += rel;
    if (emr > a->mr_max) a->mr_max = emr;
    if (rel > a->rel_max) a->rel_max = rel;
}

#define MAX_SERIES 24
#define MAX_SUMM 256

/* Summary per scene and method/parameters over the runs (tracers, lights). */
typedef struct summ {
    char scene[192], method[32], params[192];
    int n, minsizes;          /* runs; fewest sizes compared in one of them */
    double secs, xsecs;       /* summed over the runs */
    double mr_mean[2], mr_max[2], rel_mean[2], rel_max[2]; /* geometry, ray: mean of the runs' means, max of maxima */
} summ;

/* The standard errors of one approximate run, over its sizes. */
#define SE_GROUPS 3 /* geometry, ray, all classes */
typedef struct serun {
    long id, xid;                /* the run; its exact run, 0 if none */
    char hdr[512];               /* "| scene | tracer | lights | sched | method | params" */
    int n[SE_GROUPS];            /* sizes with an error and an exact value */
    int within[SE_GROUPS][3];    /* of which within 1, 2, 3 standard errors */
} serun;

/* One report's state. */
typedef struct se_ctx {
    sqlite3 *h;
    int csv;
    FILE *out;                        /* the tables */
    FILE *dat;                        /* plot points, or NULL (the stream of dato) */
    rt_out *dato;                     /* its output file (src/outfile.c) */
    char series[MAX_SERIES][128];     /* plot series labels; a point's series is the dat file's last column */
    int nseries;
    summ summs[MAX_SUMM];
    int nsumm;
    serun *ser;                       /* runs with standard errors (se_collect), in report order */
    int nser;
    char *sizes_md;                   /* their per-size table rows (Markdown), or NULL */
    size_t sizes_len;
    int shown;                        /* approximate and reduced pairs reported */
} se_ctx;

static int series_id(se_ctx *C, const char *label)
{
    for (int i = 0; i < C->nseries; i++)
        if (!strcmp(C->series[i], label)) return i;
    if (C->nseries == MAX_SERIES) return MAX_SERIES - 1; /* the last one takes the rest */
    snprintf(C->series[C->nseries], sizeof C->series[0], "%s", label);
    return C->nseries++;
}

/* "hybrid rate=0.015625 window_below=8192": the parameters without the
 * defaults every run shares. */
static int approx_series(se_ctx *C, const char *method, const char *params)
{
    static const char *const skip[] = {"seed=1", "exact_below=0", "period=65536", "window=1024"};
    char lab[128];
    size_t n = (size_t)snprintf(lab, sizeof lab, "%s", method);
    const char *q = params ? params : "";
    while (*q && n + 2 < sizeof lab) {
        size_t len = strcspn(q, " ");
        int keep = 1;
        for (size_t k = 0; k < sizeof skip / sizeof skip[0]; k++)
            if (len == strlen(skip[k]) && !strncmp(q, skip[k], len)) keep = 0;
        if (keep && len) n += (size_t)snprintf(lab + n, sizeof lab - n, " %.*s", (int)len, q);
        q += len;
        while (*q == ' ') q++;
    }
    return series_id(C, lab);
}

static void summ_add(se_ctx *C, const char *scene, const char *method, const char *params, double secs, double xsecs,
                     const acc *A)
{
    summ *u = NULL;
    for (int i = 0; i < C->nsumm && !u; i++)
        if (!strcmp(C->summs[i].scene, scene) && !strcmp(C->summs[i].method, method) &&
            !strcmp(C->summs[i].params, params))
            u = &C->summs[i];
    if (!u) {
        if (C->nsumm == MAX_SUMM) return;
        u = &C->summs[C->nsumm++];
        memset(u, 0, sizeof *u);
        snprintf(u->scene, sizeof u->scene, "%s", scene);
        snprintf(u->method, sizeof u->method, "%s", method);
        snprintf(u->params, sizeof u->params, "%s", params);
    }
    if (!u->n || A[0].n < u->minsizes) u->minsizes = A[0].n;
    u->n++;
    u->secs += secs;
    u->xsecs += xsecs;
    for (int g = 0; g < 2; g++) {
        if (!A[g].n) continue;
        u->mr_mean[g] += A[g].mr_sum / A[g].n;
        u->rel_mean[g] += A[g].rel_sum / A[g].n;
        if (A[g].mr_max > u->mr_max[g]) u->mr_max[g] = A[g].mr_max;
        if (A[g].rel_max > u->rel_max[g]) u->rel_max[g] = A[g].rel_max;
    }
}

static void summ_print(const se_ctx *C)
{
    if (!C->nsumm) return;
    fprintf(C->out,
            "\n## Summary per scene and method\n\nOver the runs of each scene (tracers, lights): total simulation time "
            "and speedup (ratio of the totals); errors as above, the mean of the runs' means and the largest "
            "maximum; sizes = the fewest sizes compared in one run.\n\n| scene | method | params | runs | s (exact s) | "
            "speedup | sizes | geometry MR err mean / max | geometry traffic err %% mean / max | ray MR err mean / max | "
            "ray traffic err %% mean / max |\n|---|---|---|---|---|---|---|---|---|---|---|\n");
    for (int i = 0; i < C->nsumm; i++) {
        const summ *u = &C->summs[i];
        fprintf(C->out,
                "| %s | %s | %s | %d | %.2f (%.2f) | %.1fx | %d | %.4f / %.4f | %.2f / %.2f | %.4f / %.4f | %.2f / "
                "%.2f |\n",
                u->scene, u->method, u->params, u->n, u->secs, u->xsecs, u->secs > 0 ? u->xsecs / u->secs : NAN,
                u->minsizes, u->mr_mean[0] / u->n, u->mr_max[0], u->rel_mean[0] / u->n, u->rel_max[0],
                u->mr_mean[1] / u->n, u->mr_max[1], u->rel_mean[1] / u->n, u->rel_max[1]);
    }
}

/* 1 if the database has the standard-error table (schema 5). */
static int has_se_table(sqlite3 *h)
{
    sqlite3_stmt *st;
    int r = 0;
    if (sqlite3_prepare_v2(h, "SELECT 1 FROM sqlite_master WHERE type = 'table' AND name = 'traffic_se'", -1, &st,
                           NULL) == SQLITE_OK)
        r = sqlite3_step(st) == SQLITE_ROW;
    sqlite3_finalize(st);
    return r;
}

/* "0.0688 ± 0.0055" (MB), or the estimate alone with "± -" when it has no
 * error. */
static void fmt_est(char *buf, size_t n, sqlite3_stmt *st, int col)
{
    if (sqlite3_column_type(st, col + 1) == SQLITE_NULL)
        snprintf(buf, n, "%.4f ± -", sqlite3_column_double(st, col));
    else
        snprintf(buf, n, "%.4f ± %.4f", sqlite3_column_double(st, col), sqlite3_column_double(st, col + 1));
}

/* Reads every run with standard errors (se_sql) into C->ser, counting per
 * group how many estimates lie within 1, 2, 3 errors of the exact value,
 * and writes the per-size Markdown rows into C->sizes_md. A database
 * without the table has none (0). */
static int se_collect(se_ctx *C, rt_err *e)
{
    if (!has_se_table(C->h)) return 0;
    char *sql = rt_report_label_sql(C->h, se_sql, e);
    if (!sql) return -1;
    sqlite3_stmt *st = rt_report_stmt(C->h, sql, "standard-error query", e, "");
    free(sql);
    if (!st) return -1;
    FILE *md = open_memstream(&C->sizes_md, &C->sizes_len);
    if (!md) {
        sqlite3_finalize(st);
        return rt_errf(e, "standard-error table: out of memory");
    }
    int rc, cap = 0;
    while ((rc = sqlite3_step(st)) == SQLITE_ROW) {
        long id = sqlite3_column_int64(st, 6);
        if (!C->nser || C->ser[C->nser - 1].id != id) {
            if (C->nser == cap) {
                serun *t = rt_reallocarray(C->ser, (size_t)(cap = cap ? 2 * cap : 16), sizeof *t, e);
                if (!t) break;
                C->ser = t;
            }
            serun *u = &C->ser[C->nser++];
            memset(u, 0, sizeof *u);
            u->id = id;
            u->xid = sqlite3_column_int64(st, 7);
            const char *p = (const char *)sqlite3_column_text(st, 5);
            snprintf(u->hdr, sizeof u->hdr, "| %s | %s | %d | %lld | %s | %s", sqlite3_column_text(st, 0),
                     sqlite3_column_text(st, 1), sqlite3_column_int(st, 2), (long long)sqlite3_column_int64(st, 3),
                     sqlite3_column_text(st, 4), p ? p : "");
        }
        serun *u = &C->ser[C->nser - 1];
        /* groups: estimate, error, exact columns */
        static const int est[SE_GROUPS] = {9, 11, 13}, exa[SE_GROUPS] = {15, 16, 17};
        char cell[SE_GROUPS][64], xcell[SE_GROUPS][32], dev[32] = "-";
        for (int g = 0; g < SE_GROUPS; g++) {
            fmt_est(cell[g], sizeof cell[g], st, est[g]);
            int has_x = sqlite3_column_type(st, exa[g]) != SQLITE_NULL;
            int has_se = sqlite3_column_type(st, est[g] + 1) != SQLITE_NULL;
            snprintf(xcell[g], sizeof xcell[g], has_x ? "%.4f" : "-", sqlite3_column_double(st, exa[g]));
            if (!has_x || !has_se) continue;
            double d = sqlite3_column_double(st, est[g]) - sqlite3_column_double(st, exa[g]);
            double se = sqlite3_column_double(st, est[g] + 1);
            u->n[g]++;
            for (int k = 0; k < 3; k++) u->within[g][k] += fabs(d) <= (k + 1) * se;
            if (g == SE_GROUPS - 1 && se > 0) snprintf(dev, sizeof dev, "%+.2f", d / se);
        }
        char run[48];
        snprintf(run, sizeof run, u->xid ? "%ld (%ld)" : "%ld (-)", u->id, u->xid);
        fprintf(md, "| %s | %lld | %s | %s | %s | %s | %s | %s | %s |\n", run, (long long)sqlite3_column_int64(st, 8),
                cell[0], xcell[0], cell[1], xcell[1], cell[2], xcell[2], dev);
    }
    int bad = fclose(md) != 0;
    if (rc == SQLITE_ROW) { /* out of memory above */
        sqlite3_finalize(st);
        return -1;
    }
    if (rt_report_done(st, rc, "standard-error query", e) < 0) return -1;
    return bad ? rt_errf(e, "standard-error table: out of memory") : 0;
}

/* The run's standard-error record, or NULL. */
static const serun *se_find(const se_ctx *C, long id)
{
    for (int i = 0; i < C->nser; i++)
        if (C->ser[i].id == id) return &C->ser[i];
    return NULL;
}

/* "a / b / c of n" for group g of u, or "-" when no size compares. */
static void fmt_within(char *buf, size_t n, const serun *u, int g)
{
    if (u->n[g]) snprintf(buf, n, "%d / %d / %d of %d", u->within[g][0], u->within[g][1], u->within[g][2], u->n[g]);
    else snprintf(buf, n, "-");
}

/* The Markdown section of the runs with standard errors. */
static void se_print(const se_ctx *C)
{
    if (!C->nser) return;
    FILE *out = C->out;
    fprintf(out,
            "\n## Standard errors\n\nApproximate runs that estimated their own error (hybrid with errors: errors=1 "
            "in params) store a standard error per cache size and group (table traffic_se, view v_traffic_se). Per "
            "run: of the sizes with an error and an exact value (the exact run in parentheses), how many estimates lie within "
            "1, 2 and 3 standard errors of the exact traffic; an error of normal shape would put about 68%%, 95%% and "
            "99.7%% of them there. The error is statistical: it does not see a bias the whole sample shares "
            "(docs/approx.md).\n\n"
            "| scene | tracer | lights | sched | method | params | run (exact run) | geometry within 1 / 2 / 3 SE | "
            "ray within 1 / 2 / 3 SE | total within 1 / 2 / 3 SE |\n|---|---|---|---|---|---|---|---|---|---|\n");
    int n[SE_GROUPS] = {0}, w[SE_GROUPS][3] = {{0}};
    for (int i = 0; i < C->nser; i++) {
        const serun *u = &C->ser[i];
        char cell[SE_GROUPS][48], run[48];
        for (int g = 0; g < SE_GROUPS; g++) {
            fmt_within(cell[g], sizeof cell[g], u, g);
            n[g] += u->n[g];
            for (int k = 0; k < 3; k++) w[g][k] += u->within[g][k];
        }
        snprintf(run, sizeof run, u->xid ? "%ld (%ld)" : "%ld (-)", u->id, u->xid);
        fprintf(out, "%s | %s | %s | %s | %s |\n", u->hdr, run, cell[0], cell[1], cell[2]);
    }
    static const char *const gname[SE_GROUPS] = {"geometry", "ray", "total"};
    fprintf(out, "\nOver all runs:");
    for (int g = 0; g < SE_GROUPS; g++) {
        if (n[g])
            fprintf(out, "%s %s %d / %d / %d of %d (%.0f%% / %.0f%% / %.0f%%)", g ? ";" : "", gname[g], w[g][0],
                    w[g][1], w[g][2], n[g], 100.0 * w[g][0] / n[g], 100.0 * w[g][1] / n[g], 100.0 * w[g][2] / n[g]);
        else
            fprintf(out, "%s %s no exact value to compare", g ? ";" : "", gname[g]);
    }
    fprintf(out, ".\n\nPer size: estimate ± standard error beside the exact value (MB = 2^20 bytes; - where there is "
                 "none); the last column is (estimate - exact) / standard error of the total.\n\n"
                 "| run (exact run) | cache size | geometry MB | exact | ray MB | exact | total MB | exact | "
                 "total error / SE |\n|---|---|---|---|---|---|---|---|---|\n");
    if (C->sizes_len) fwrite(C->sizes_md, 1, C->sizes_len, out);
}

/* One compared pair, as a table row (Markdown or CSV) and a plot point:
 * the run, its reference, both times, the speedup, how many sizes were
 * compared, and the geometry and ray errors. The point's label is the
 * row's description with quotes and control bytes replaced, so that it
 * stays one column of the data file. */
static void pair_row(se_ctx *C, const char *hdr, long id, long xid, double secs, double xsecs, const acc *A,
                     const char *label, int sid)
{
    double sp = secs > 0 ? xsecs / secs : NAN;
    const acc *G = &A[0], *Y = &A[1];
    double gm = G->n ? G->mr_sum / G->n : NAN, gr = G->n ? G->rel_sum / G->n : NAN;
    double ym = Y->n ? Y->mr_sum / Y->n : NAN, yr = Y->n ? Y->rel_sum / Y->n : NAN;
    if (C->csv) {
        /* the whole traffic's standard-error counts, when the run has errors */
        const serun *u = se_find(C, id);
        char sec[64] = ",,,";
        if (u && u->n[SE_GROUPS - 1])
            snprintf(sec, sizeof sec, "%d,%d,%d,%d", u->n[SE_GROUPS - 1], u->within[SE_GROUPS - 1][0],
                     u->within[SE_GROUPS - 1][1], u->within[SE_GROUPS - 1][2]);
        fprintf(C->out, "%s,%ld,%ld,%.3f,%.3f,%.2f,%.5f,%.5f,%.3f,%.3f,%.5f,%.5f,%.3f,%.3f,%d,%s\n", hdr, id, xid,
                secs, xsecs, sp, gm, G->mr_max, gr, G->rel_max, ym, Y->mr_max, yr, Y->rel_max, G->n, sec);
    } else
        fprintf(C->out, "%s | %ld (%ld) | %.2f (%.2f) | %.1fx | %d | %.4f / %.4f | %.2f / %.2f | %.4f / %.4f | %.2f / %.2f |\n",
                hdr, id, xid, secs, xsecs, sp, G->n, gm, G->mr_max, gr, G->rel_max, ym, Y->mr_max, yr, Y->rel_max);
    if (C->dat) {
        fputc('"', C->dat);
        for (const unsigned char *p = (const unsigned char *)label; *p; p++)
            fputc(*p < 0x20 || *p == '"' || *p == 0x7f ? '_' : *p, C->dat);
        fprintf(C->dat, "\" %.4f %.6f %.6f %d\n", sp, gm, ym, sid);
    }
}

static int report_approx(se_ctx *C, rt_err *e)
{
    char *sql = rt_report_label_sql(C->h, pairs_sql, e);
    if (!sql) return -1;
    sqlite3_stmt *st = rt_report_stmt(C->h, sql, "speed-error query", e, "");
    free(sql);
    if (!st) return -1;
    FILE *out = C->out;
    if (C->csv)
        fprintf(out, "scene,tracer,W,H,lights,sched,method,params,run,exact_run,seconds,exact_seconds,speedup,"
                     "geom_mr_mean,geom_mr_max,geom_rel_mean_pct,geom_rel_max_pct,ray_mr_mean,ray_mr_max,"
                     "ray_rel_mean_pct,ray_rel_max_pct,sizes,se_sizes,within_1se,within_2se,within_3se\n");
    else
        fprintf(out, "# Speed against error (approximate vs exact simulation)\n\n"
                     "Miss ratio = fetch misses / line accesses per group; errors are absolute (miss ratio) and relative "
                     "(traffic, %%), mean and max over the cache sizes that have an estimate (sizes: how many of them; "
                     "a sampled method leaves out the sizes it cannot estimate, e.g. hybrid's windowed sizes on a "
                     "trace shorter than 32 windows).\n\n"
                     "| scene | tracer | lights | sched | method | params | run (exact run) | s (exact s) | speedup | "
                     "sizes | geometry MR err mean / max | geometry traffic err %% mean / max | ray MR err mean / max | "
                     "ray traffic err %% mean / max |\n|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
    int rows = 0, series_cur = 0, rc;
    long cur = -1, xid = 0;
    char hdr[1024] = "", cur_scene[192] = "", cur_method[32] = "", cur_params[192] = "";
    double secs = 0, xsecs = 0;
    acc A[2];
    memset(A, 0, sizeof A);
    for (;;) {
        rc = sqlite3_step(st);
        long id = rc == SQLITE_ROW ? sqlite3_column_int64(st, 8) : -2;
        if (id != cur && cur != -1) {
            pair_row(C, hdr, cur, xid, secs, xsecs, A, hdr, series_cur);
            if (!C->csv) summ_add(C, cur_scene, cur_method, cur_params, secs, xsecs, A);
            rows++;
            C->shown++;
            memset(A, 0, sizeof A);
        }
        if (rc != SQLITE_ROW) break;
        if (id != cur) {
            cur = id;
            xid = sqlite3_column_int64(st, 9);
            secs = sqlite3_column_double(st, 10);
            xsecs = sqlite3_column_double(st, 11);
            /* the exact run's own simulation time when the sweep measured it
             * (its wall time includes the tracer) */
            const char *xs = (const char *)sqlite3_column_text(st, 18), *q = xs ? strstr(xs, "sim_seconds=") : NULL;
            if (q && (q == xs || q[-1] == ' ')) xsecs = strtod(q + 12, NULL);
            const char *m = (const char *)sqlite3_column_text(st, 6), *p = (const char *)sqlite3_column_text(st, 7);
            if (C->dat) series_cur = approx_series(C, m, p);
            snprintf(cur_scene, sizeof cur_scene, "%s", (const char *)sqlite3_column_text(st, 0));
            snprintf(cur_method, sizeof cur_method, "%s", m ? m : "");
            snprintf(cur_params, sizeof cur_params, "%s", p ? p : "");
            if (C->csv)
                snprintf(hdr, sizeof hdr, "%s,%s,%d,%d,%d,%lld,%s,\"%s\"", sqlite3_column_text(st, 0),
                         sqlite3_column_text(st, 1), sqlite3_column_int(st, 2), sqlite3_column_int(st, 3),
                         sqlite3_column_int(st, 4), (long long)sqlite3_column_int64(st, 5), m, p ? p : "");
            else
                snprintf(hdr, sizeof hdr, "| %s | %s | %d | %lld | %s | %s", sqlite3_column_text(st, 0),
                         sqlite3_column_text(st, 1), sqlite3_column_int(st, 4), (long long)sqlite3_column_int64(st, 5),
                         m, p ? p : "");
        }
        int gi = strcmp((const char *)sqlite3_column_text(st, 12), "geometry") == 0 ? 0 : 1;
        acc_add(&A[gi], sqlite3_column_double(st, 14), sqlite3_column_double(st, 15), sqlite3_column_double(st, 16),
                sqlite3_column_double(st, 17));
    }
    if (rt_report_done(st, rc, "speed-error query", e) < 0) return -1;
    if (!rows && !C->csv)
        fprintf(out, "(no approximate runs in the database: run `raytraffic sim --method ...` or the sweep with "
                     "--approx)\n");
    if (!C->csv) summ_print(C);
    if (!C->csv) se_print(C);
    return 0;
}

/* One finished (proxy, reference) pair. */
typedef struct ppair {
    char hdr[512], desc[128];
    int series; /* plot series: "reduced sub:K" or "reduced WxH" */
    long id, xid;
    double secs, xsecs, scale, dens, xdens;
    acc A[2];
} ppair;

static void proxies_dynamic(const se_ctx *C, const ppair *dyn, size_t ndyn)
{
    fprintf(C->out,
            "\n### Dynamic scheduler: rays per queue event in reduced experiments\n\n"
            "A queue is processed when it is the fullest (or in tree order); the rays it holds then are what "
            "amortise loading its subtree. Fewer traced pixels leave fewer rays per queue, so reduced "
            "experiments overstate the dynamic scheduler's geometry traffic per ray.\n\n"
            "| scene | lights | sched | reduced run | pixel fraction | rays/event full | rays/event reduced | ratio |\n"
            "|---|---|---|---|---|---|---|---|\n");
    for (size_t i = 0; i < ndyn; i++) {
        const ppair *p = &dyn[i];
        /* hdr is "| scene | tracer | lights | sched | method | desc"; a
         * scene label may hold spaces ("mesh.obj (a/mesh.obj)") */
        char f[4][192] = {"", "", "", ""}, *scene = f[0], *lights = f[2], *sched = f[3];
        const char *q = p->hdr + (strncmp(p->hdr, "| ", 2) ? 0 : 2);
        for (int k = 0; k < 4 && *q; k++) {
            const char *end = strstr(q, " | ");
            size_t len = end ? (size_t)(end - q) : strlen(q);
            snprintf(f[k], sizeof f[k], "%.*s", (int)(len < sizeof f[k] ? len : sizeof f[k] - 1), q);
            q = end ? end + 3 : q + len;
        }
        fprintf(C->out, "| %s | %s | %s | %s | %.4f | %.1f | %.1f | %.3f |\n", scene, lights, sched, p->desc,
                p->scale > 0 ? 1.0 / p->scale : NAN, p->xdens, p->dens, p->xdens > 0 ? p->dens / p->xdens : NAN);
    }
}

static int report_proxies(se_ctx *C, rt_err *e)
{
    char *sql = rt_report_label_sql(C->h, proxy_sql, e);
    if (!sql) return -1;
    sqlite3_stmt *st = rt_report_stmt(C->h, sql, "reduced-experiment query", e, "");
    free(sql);
    if (!st) return -1;
    ppair cur, *dyn = NULL;
    size_t ndyn = 0, capdyn = 0;
    int rows = 0, rc, have = 0;
    memset(&cur, 0, sizeof cur);
    for (;;) {
        rc = sqlite3_step(st);
        long id = rc == SQLITE_ROW ? sqlite3_column_int64(st, 7) : -2;
        if (have && id != cur.id) {
            if (!rows && !C->csv)
                fprintf(C->out,
                        "\n## Reduced experiments (exact simulation of a smaller problem)\n\n"
                        "Lower resolution or pixel subsampling, compared with the exact full run of the same "
                        "configuration (the run in parentheses). Traffic is scaled by the ratio of primary rays (x "
                        "factor in params); miss ratios are compared unscaled. Times are whole runs (tracer + "
                        "simulation).\n\n"
                        "| scene | tracer | lights | sched | method | params | run (full run) | s (full s) | speedup "
                        "| sizes | geometry MR err mean / max | geometry traffic err %% mean / max | ray MR err mean / "
                        "max | ray traffic err %% mean / max |\n|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
            pair_row(C, cur.hdr, cur.id, cur.xid, cur.secs, cur.xsecs, cur.A, cur.desc, cur.series);
            rows++;
            C->shown++;
            if (!isnan(cur.dens) && !isnan(cur.xdens)) {
                if (ndyn == capdyn) {
                    ppair *t = rt_reallocarray(dyn, capdyn = capdyn ? 2 * capdyn : 16, sizeof *t, e);
                    if (!t) {
                        sqlite3_finalize(st);
                        free(dyn);
                        return -1;
                    }
                    dyn = t;
                }
                dyn[ndyn++] = cur;
            }
            have = 0;
        }
        if (rc != SQLITE_ROW) break;
        if (!have) {
            memset(&cur, 0, sizeof cur);
            have = 1;
            cur.id = id;
            cur.xid = sqlite3_column_int64(st, 8);
            cur.secs = sqlite3_column_double(st, 11);
            cur.xsecs = sqlite3_column_double(st, 12);
            const char *as = (const char *)sqlite3_column_text(st, 13), *xs = (const char *)sqlite3_column_text(st, 14);
            double ra = stat_num(as, "rays_primary"), rx = stat_num(xs, "rays_primary");
            cur.scale = ra > 0 && rx > 0 ? rx / ra : NAN;
            cur.dens = stat_num(as, "rays_per_event_mean");
            cur.xdens = stat_num(xs, "rays_per_event_mean");
            int W = sqlite3_column_int(st, 2), H = sqlite3_column_int(st, 3);
            const char *params = (const char *)sqlite3_column_text(st, 6), *sub = params ? strstr(params, "subsample=") : NULL;
            const char *method = sub ? "subsample" : "resolution";
            char lab[64];
            if (sub) {
                snprintf(cur.desc, sizeof cur.desc, "%dx%d %s (x%.2f)", W, H, sub, cur.scale);
                snprintf(lab, sizeof lab, "reduced sub:%ld", strtol(sub + 10, NULL, 10));
            } else {
                snprintf(cur.desc, sizeof cur.desc, "%dx%d (x%.2f)", W, H, cur.scale);
                snprintf(lab, sizeof lab, "reduced resolution (1/%.0f of the pixels)", cur.scale);
            }
            cur.series = series_id(C, lab);
            if (C->csv)
                snprintf(cur.hdr, sizeof cur.hdr, "%s,%s,%d,%d,%d,%lld,%s,\"%s\"", sqlite3_column_text(st, 0),
                         sqlite3_column_text(st, 1), W, H, sqlite3_column_int(st, 4),
                         (long long)sqlite3_column_int64(st, 5), method, cur.desc);
            else
                snprintf(cur.hdr, sizeof cur.hdr, "| %s | %s | %d | %lld | %s | %s", sqlite3_column_text(st, 0),
                         sqlite3_column_text(st, 1), sqlite3_column_int(st, 4), (long long)sqlite3_column_int64(st, 5),
                         method, cur.desc);
        }
        int gi = strcmp((const char *)sqlite3_column_text(st, 15), "geometry") == 0 ? 0 : 1;
        /* traffic of the reduced run scaled up to the full problem */
        acc_add(&cur.A[gi], sqlite3_column_double(st, 17), sqlite3_column_double(st, 18),
                sqlite3_column_double(st, 19) * (isnan(cur.scale) ? 1.0 : cur.scale), sqlite3_column_double(st, 20));
    }
    if (rt_report_done(st, rc, "reduced-experiment query", e) < 0) {
        free(dyn);
        return -1;
    }
    if (ndyn && !C->csv) proxies_dynamic(C, dyn, ndyn);
    free(dyn);
    return 0;
}

int rt_report_speed_error(sqlite3 *h, int csv, const rt_plot_opts *plot, FILE *out, rt_err *e)
{
    se_ctx *C = rt_calloc(1, sizeof *C, e);
    if (!C) return -1;
    C->h = h;
    C->csv = csv;
    C->out = out;
    char datpath[4096] = "";
    int rc = -1;
    if (plot) {
        if (rt_plot_mkdir(plot->dir, e) < 0) goto done;
        snprintf(datpath, sizeof datpath, "%s/speed-error.dat", plot->dir);
        if (!(C->dat = rt_plot_open(datpath, &C->dato, e))) goto done;
        fprintf(C->dat, "# run speedup geom_mean_abs_mr_err ray_mean_abs_mr_err series\n");
    }
    if (se_collect(C, e) < 0 || report_approx(C, e) < 0 || report_proxies(C, e) < 0 || rt_report_flush(out, e) < 0)
        goto done;
    if (!C->shown) {
        rt_errf(e, "nothing to show: no approximate run beside its exact run and no reduced experiment beside its full "
                   "run (run the sweep with --approx or --proxy, or `sim --method ... --db`)");
        goto done;
    }
    if (C->dat) {
        C->dat = NULL;
        rt_out *o = C->dato;
        C->dato = NULL;
        if (rt_plot_commit(o, e) < 0) goto done;
        if (rt_plot_speed_error(plot, datpath, (const char(*)[128])C->series, C->nseries, e) < 0) goto done;
    }
    rc = 0;
done:
    rt_out_abort(C->dato);
    free(C->ser);
    free(C->sizes_md);
    free(C);
    return rc;
}
