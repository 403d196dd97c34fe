/* main.c -- the raytraffic front end: a thin dispatcher over subcommands.
 * It also owns what every command shares at exit: a failed write to
 * standard output is an error (as coreutils' close_stdout), and a fatal
 * signal removes the temporaries of unfinished output files. It calls the
 * commands (cmd_*.c) and cmd_base.c; nothing calls back into it. */
#include "config.h"
#include "cmd.h"
#include "outfile.h"
#include "rt.h"

#include <errno.h>
#include <limits.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef struct command {
    const char *name;
    int (*fn)(int, char **);
    const char *help;
} command;

static const command commands[] = {
    {"scene", main_scene, "list, describe and export scenes"},
    {"render", main_render, "render a scene to an OpenEXR image"},
    {"trace", main_trace, "render and record every memory access to a trace file"},
    {"trace-info", main_trace_info, "describe a trace file"},
    {"trace-dump", main_trace_dump, "print a trace's records (text or Dinero IV din)"},
    {"sim", main_sim, "replay traces through cache models, optionally into SQLite"},
    {"sweep", main_sweep, "run the paper's experiment matrix into a database"},
    {"report", main_report, "print the paper's tables and plots from a database"},
    {"db", main_db, "database maintenance (merge shards)"},
    {"bench", main_bench, "measure throughput of tracers, tree build and simulator"},
    {NULL, NULL, NULL},
};

static void usage(FILE *f)
{
    fprintf(f,
            "raytraffic %s -- memory traffic of ray-tracing algorithms\n\n"
            "Usage: raytraffic COMMAND [options]\n\nCommands:\n",
            rt_version());
    for (const command *c = commands; c->name; c++) fprintf(f, "  %-11s %s\n", c->name, c->help);
    fprintf(f,
            "  help CMD    same as CMD --help\n"
            "  version     version and build configuration\n\n"
            "Run 'raytraffic COMMAND --help' for a command's options.\n");
}

static void version(void)
{
    printf("raytraffic %s\n", rt_version());
    printf("git revision: %s\n", rt_git_rev());
    printf("compiler: %s\n", RT_BUILD_CC);
    printf("cflags: %s\n", RT_BUILD_CFLAGS);
    printf("sanitizers: %s\n", RT_SANITIZERS);
    printf("gnuplot: %s\n", GNUPLOT_PATH[0] ? GNUPLOT_PATH : "(not found at configure time)");
}

static int dispatch(int argc, char **argv)
{
    if (argc < 2) { /* no command: a usage error, the usage on stderr */
        usage(stderr);
        return RT_EXIT_USAGE;
    }
    const char *name = argv[1];
    if (!strcmp(name, "--version") || !strcmp(name, "version")) {
        version();
        return RT_EXIT_OK;
    }
    if (!strcmp(name, "--help") || !strcmp(name, "-h")) {
        usage(stdout);
        return RT_EXIT_OK;
    }
    if (!strcmp(name, "help")) {
        if (argc < 3) {
            usage(stdout);
            return RT_EXIT_OK;
        }
        for (const command *c = commands; c->name; c++)
            if (!strcmp(c->name, argv[2])) {
                char *hv[] = {argv[2], "--help", NULL};
                return c->fn(2, hv);
            }
        rt_cmd_error("help", "unknown command '%s'", argv[2]);
        return RT_EXIT_USAGE;
    }
    for (const command *c = commands; c->name; c++)
        if (!strcmp(c->name, name)) return c->fn(argc - 1, argv + 1);
    fprintf(stderr, "raytraffic: unknown command '%s' (see 'raytraffic --help')\n", name);
    return RT_EXIT_USAGE;
}

/* An interrupted run must not leave temporaries behind: unlink is
 * async-signal-safe, and the default action then ends the process. */
static void on_signal(int sig)
{
    rt_out_remove_temporaries();
    signal(sig, SIG_DFL);
    raise(sig);
}

/* Output that could not be written (a full disk, /dev/full, a closed pipe's
 * EIO) must not end in exit 0: check stdout's error flag and its final
 * flush, as coreutils' close_stdout does. */
static int close_stdout(int rc)
{
    int prev = ferror(stdout);
    errno = 0;
    int fail = fclose(stdout) != 0;
    if (!prev && !fail) return rc;
    if (!fail) errno = 0; /* the failed write's errno is long gone */
    if (errno) fprintf(stderr, "raytraffic: write error: %s\n", strerror(errno));
    else fprintf(stderr, "raytraffic: write error\n");
    return rc != RT_EXIT_OK ? rc : RT_EXIT_FAIL;
}

int main(int argc, char **argv)
{
    rt_cmd_set_line(argc, argv);
    static const int sigs[] = {SIGINT, SIGTERM, SIGHUP};
    for (size_t i = 0; i < sizeof sigs / sizeof sigs[0]; i++)
        if (signal(sigs[i], on_signal) == SIG_IGN) signal(sigs[i], SIG_IGN); /* keep nohup's choice */
    /* The largest scene file the loaders read (docs/scenes.md). */
    const char *sm = getenv("RT_SCENE_MAX_BYTES");
    if (sm && *sm) {
        uint64_t v;
        if (rt_parse_size(sm, &v) < 0 || v == 0) {
            fprintf(stderr, "raytraffic: RT_SCENE_MAX_BYTES: '%s' is not a size like 512M\n", sm);
            return RT_EXIT_USAGE;
        }
        rt_scene_max_bytes = v;
    }
    /* Test hook: every output file fails with ENOSPC after N bytes. */
    const char *fa = getenv("RT_OUT_FAIL_AFTER");
    if (fa && *fa) {
        long v;
        if (rt_cmd_parse_long(fa, 0, LONG_MAX, &v) < 0) {
            fprintf(stderr, "raytraffic: RT_OUT_FAIL_AFTER: '%s' is not a byte count\n", fa);
            return RT_EXIT_USAGE;
        }
        rt_out_fail_after = v;
    }
    return close_stdout(dispatch(argc, argv));
}
