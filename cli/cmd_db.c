/*
 * cmd_db.c -- `raytraffic db`: database maintenance.
 *
 *   raytraffic db merge OUT.db IN.db...
 *
 * Copies every run of every input into OUT (rt_db_merge in results/db.c:
 * a run whose key is already in OUT replaces it, nothing is duplicated,
 * bad shards are refused). This joins the per-job databases of a sweep
 * spread over GNU parallel or a Slurm array.
 */
#include "cmd.h"
#include "db.h"
#include "outfile.h"

#include <stdio.h>
#include <string.h>

static void usage(FILE *f)
{
    fprintf(f,
            "Usage: raytraffic db merge OUT.db IN.db...\n\n"
            "Merges result databases (e.g. the shards of `sweep --list-jobs`) into OUT.db.\n"
            "A run already in OUT.db (same scene, tracer, size, lights, schedule, parameters\n"
            "and simulation method) is replaced, never duplicated.\n");
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
    rt_err e = {0};
    /* every name first: a shard named ":memory:" is a usage error before
     * anything is merged */
    for (int i = 2; i < argc; i++)
        if (rt_open_target(argv[i], RT_TARGET_DB, &e) < 0 && e.usage) {
            rt_cmd_error("db", "%s", e.msg);
            return RT_EXIT_USAGE;
        }
    /* and every shard's kind (a FIFO, a folder, a missing file) before OUT
     * is created; what is inside each is checked as it is merged */
    for (int i = 3; i < argc; i++) {
        void *h = NULL;
        int ver;
        if (rt_db_open_read(argv[i], &h, &ver, &e) < 0) {
            rt_cmd_error("db", "%s", e.msg);
            return RT_EXIT_FAIL;
        }
        rt_db_close_read(h);
    }
    rt_db *out = rt_db_open(argv[2], &e);
    if (!out) {
        rt_cmd_error("db", "%s", e.msg);
        return e.usage ? RT_EXIT_USAGE : RT_EXIT_FAIL;
    }
    long total = 0;
    for (int i = 3; i < argc; i++) {
        long n = 0;
        if (rt_db_merge(out, argv[i], &n, &e) < 0) {
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
