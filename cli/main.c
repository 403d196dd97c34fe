/* main.c -- the raytraffic front end: a thin dispatcher over subcommands. */
#include "config.h"
#include "cmd.h"
#include "rt.h"

#include <stdarg.h>
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

static char cmdline[4096];

void rt_cmd_set_line(int argc, char **argv)
{
    size_t k = 0;
    cmdline[0] = 0;
    for (int i = 0; i < argc && k + 1 < sizeof cmdline; i++) {
        int n = snprintf(cmdline + k, sizeof cmdline - k, "%s%s", i ? " " : "", argv[i]);
        if (n < 0) break;
        k += (size_t)n;
    }
}

const char *rt_cmd_line(void) { return cmdline; }

void rt_cmd_error(const char *cmd, const char *fmt, ...)
{
    va_list ap;
    fprintf(stderr, "raytraffic %s: ", cmd);
    va_start(ap, fmt);
    vfprintf(stderr, fmt, ap);
    va_end(ap);
    fputc('\n', stderr);
}

int rt_cmd_wants_help(int argc, char **argv)
{
    for (int i = 1; i < argc; i++) {
        if (strcmp(argv[i], "--") == 0) break;
        if (strcmp(argv[i], "-h") == 0 || strcmp(argv[i], "--help") == 0) return 1;
    }
    return 0;
}

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

int main(int argc, char **argv)
{
    rt_cmd_set_line(argc, argv);
    if (argc < 2) {
        usage(stdout);
        return RT_EXIT_OK;
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
