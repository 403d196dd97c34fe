/*
 * cmd_db.c -- `raytraffic db`: database maintenance.
 *
 *   raytraffic db merge OUT.db IN.db...
 *
 * Copies every run of every input (with its scene, provenance, statistics
 * and traffic rows) into OUT through the same store path a sweep uses, so a
 * run whose key is already in OUT replaces it and nothing is duplicated;
 * each run is copied in its own transaction. This joins the per-job
 * databases of a sweep spread over GNU parallel or a Slurm array.
 */
#include "cmd.h"
#include "db.h"

#include <errno.h>
#include <inttypes.h>
#include <sqlite3.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

static void usage(FILE *f)
{
    fprintf(f,
            "Usage: raytraffic db merge OUT.db IN.db...\n\n"
            "Merges result databases (e.g. the shards of `sweep --list-jobs`) into OUT.db.\n"
            "A run already in OUT.db (same scene, tracer, size, lights, schedule, parameters\n"
            "and simulation method) is replaced, never duplicated.\n");
}

static const char *txt(sqlite3_stmt *st, int i)
{
    const unsigned char *t = sqlite3_column_text(st, i);
    return t ? (const char *)t : "";
}

static int merge_one(rt_db *out, const char *inpath, long *nruns, rt_err *e)
{
    sqlite3 *in = NULL;
    struct stat sb;
    if (stat(inpath, &sb) < 0) return rt_errf(e, "%s: %s", inpath, strerror(errno));
    if (sqlite3_open_v2(inpath, &in, SQLITE_OPEN_READONLY, NULL) != SQLITE_OK) {
        rt_errf(e, "%s: cannot open database: %s", inpath, in ? sqlite3_errmsg(in) : "out of memory");
        sqlite3_close(in);
        return -1;
    }
    sqlite3_busy_timeout(in, 60000);
    static const char *runs_sql =
        "SELECT r.id, s.name, s.params, s.hash, s.triangles, r.tracer, r.W, r.H, r.lights, r.sched_cache_size, r.gmax,"
        " r.params, r.sim_method, r.sim_params, r.trace_hash, r.refs, r.tool_version, r.git_rev, r.command,"
        " r.wall_time, r.stats FROM runs r JOIN scenes s ON s.id = r.scene_id ORDER BY r.id";
    static const char *rows_sql =
        "SELECT c.size, c.line, c.assoc, c.policy, t.class, t.accesses, t.read_misses, t.write_misses, t.writebacks,"
        " t.wt_bytes, t.traffic_bytes FROM traffic t JOIN cache_configs c ON c.id = t.config_id WHERE t.run_id = ?1"
        " ORDER BY c.size, t.class";
    sqlite3_stmt *rs = NULL, *ts = NULL;
    int rc = -1;
    if (sqlite3_prepare_v2(in, runs_sql, -1, &rs, NULL) != SQLITE_OK ||
        sqlite3_prepare_v2(in, rows_sql, -1, &ts, NULL) != SQLITE_OK) {
        rt_errf(e, "%s: not a raytraffic database: %s", inpath, sqlite3_errmsg(in));
        goto done;
    }
    rt_db_traffic *rows = NULL;
    size_t cap = 0;
    int step;
    while ((step = sqlite3_step(rs)) == SQLITE_ROW) {
        rt_db_run run;
        memset(&run, 0, sizeof run);
        int64_t id = sqlite3_column_int64(rs, 0);
        run.scene = txt(rs, 1);
        run.scene_params = txt(rs, 2);
        run.scene_hash = strtoull(txt(rs, 3), NULL, 16);
        run.ntri = (uint32_t)sqlite3_column_int64(rs, 4);
        run.tracer = txt(rs, 5);
        run.W = sqlite3_column_int(rs, 6);
        run.H = sqlite3_column_int(rs, 7);
        run.lights = (uint32_t)sqlite3_column_int64(rs, 8);
        run.cache_size = (uint64_t)sqlite3_column_int64(rs, 9);
        run.gmax = (uint64_t)sqlite3_column_int64(rs, 10);
        run.params = txt(rs, 11);
        run.sim_method = txt(rs, 12);
        run.sim_params = txt(rs, 13);
        run.trace_hash = strtoull(txt(rs, 14), NULL, 16);
        run.refs = (uint64_t)sqlite3_column_int64(rs, 15);
        run.tool_version = txt(rs, 16);
        run.git_rev = txt(rs, 17);
        run.command = txt(rs, 18);
        run.wall_time = sqlite3_column_double(rs, 19);
        run.stats = txt(rs, 20);
        size_t n = 0;
        sqlite3_reset(ts);
        sqlite3_bind_int64(ts, 1, id);
        while ((step = sqlite3_step(ts)) == SQLITE_ROW) {
            if (n == cap) {
                size_t nc = cap ? 2 * cap : 256;
                rt_db_traffic *r2 = rt_reallocarray(rows, nc, sizeof *rows, e);
                if (!r2) goto fail_rows;
                rows = r2;
                cap = nc;
            }
            rt_db_traffic *r = &rows[n++];
            r->size = (uint64_t)sqlite3_column_int64(ts, 0);
            r->line = (uint32_t)sqlite3_column_int64(ts, 1);
            r->assoc = (uint32_t)sqlite3_column_int64(ts, 2);
            r->policy = strdup(txt(ts, 3));
            r->cls = rt_class_from_name(txt(ts, 4));
            r->accesses = (uint64_t)sqlite3_column_int64(ts, 5);
            r->read_misses = (uint64_t)sqlite3_column_int64(ts, 6);
            r->write_misses = (uint64_t)sqlite3_column_int64(ts, 7);
            r->writebacks = (uint64_t)sqlite3_column_int64(ts, 8);
            r->wt_bytes = (uint64_t)sqlite3_column_int64(ts, 9);
            r->traffic_bytes = (uint64_t)sqlite3_column_int64(ts, 10);
            if (r->cls < 0 || !r->policy) {
                rt_errf(e, "%s: run %" PRId64 ": bad class '%s'", inpath, id, txt(ts, 4));
                goto fail_rows;
            }
        }
        if (step != SQLITE_DONE) {
            rt_errf(e, "%s: %s", inpath, sqlite3_errmsg(in));
            goto fail_rows;
        }
        int st = rt_db_store_run(out, &run, rows, n, NULL, e);
        for (size_t k = 0; k < n; k++) free((char *)rows[k].policy);
        if (st < 0) goto fail_free;
        (*nruns)++;
        continue;
    fail_rows:
        for (size_t k = 0; k < n; k++) free((char *)rows[k].policy);
    fail_free:
        free(rows);
        goto done;
    }
    free(rows);
    if (step != SQLITE_DONE) {
        rt_errf(e, "%s: %s", inpath, sqlite3_errmsg(in));
        goto done;
    }
    rc = 0;
done:
    sqlite3_finalize(rs);
    sqlite3_finalize(ts);
    sqlite3_close(in);
    return rc;
}

int main_db(int argc, char **argv)
{
    if (argc < 2 || rt_cmd_wants_help(argc, argv)) {
        usage(argc < 2 ? stderr : stdout);
        return argc < 2 ? RT_EXIT_USAGE : RT_EXIT_OK;
    }
    if (strcmp(argv[1], "merge")) {
        rt_cmd_error("db", "unknown subcommand '%s' (merge)", argv[1]);
        return RT_EXIT_USAGE;
    }
    if (argc < 4) {
        rt_cmd_error("db", "merge needs OUT.db and at least one IN.db");
        return RT_EXIT_USAGE;
    }
    rt_err e = {""};
    rt_db *out = rt_db_open(argv[2], &e);
    if (!out) {
        rt_cmd_error("db", "%s", e.msg);
        return RT_EXIT_FAIL;
    }
    long total = 0;
    for (int i = 3; i < argc; i++) {
        long n = 0;
        if (merge_one(out, argv[i], &n, &e) < 0) {
            rt_cmd_error("db", "%s", e.msg);
            rt_db_close(out);
            return RT_EXIT_FAIL;
        }
        total += n;
        fprintf(stderr, "merged %ld run(s) from %s\n", n, argv[i]);
    }
    rt_db_close(out);
    fprintf(stderr, "%s: %ld run(s) merged from %d database(s)\n", argv[2], total, argc - 3);
    return RT_EXIT_OK;
}
