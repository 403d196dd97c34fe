/* cmd_base.c -- what the dispatcher (main.c) and every command share: the
 * one-line error message, the command line kept for provenance, and --help
 * detection. It calls nothing of the front end, so main.c, the commands and
 * cmd_common.c all depend on it and it on none of them (docs/architecture.md,
 * "cli/"). The fuzz harness of cmd_common.c (tests/fuzz/fuzz_cli.c) links
 * its own rt_cmd_error in its place. */
#include "cmd.h"

#include <stdarg.h>
#include <stdio.h>
#include <string.h>

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

int rt_cmd_wants_cores(int argc, char **argv)
{
    for (int a = 1; a < argc; a++) {
        const char *spec = !strncmp(argv[a], "--hierarchy=", 12) ? argv[a] + 12
                           : !strcmp(argv[a], "--hierarchy") && a + 1 < argc ? argv[a + 1] : NULL;
        if (spec && (strstr(spec, "/private") || strstr(spec, "/shared"))) return 1;
    }
    return 0;
}
