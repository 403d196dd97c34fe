/*
 * cmd.h -- the front end's subcommands and the helpers they share.
 *
 * Each subcommand lives in its own cmd_*.c as `int main_NAME(int argc,
 * char **argv)` with argv[0] the subcommand name. Exit status: 0 ok,
 * 1 failure, 2 usage error. Messages go to stderr as one line:
 * "raytraffic NAME: message".
 */
#ifndef RT_CMD_H
#define RT_CMD_H

#include <stdio.h>

#define RT_EXIT_OK 0
#define RT_EXIT_FAIL 1
#define RT_EXIT_USAGE 2

int main_scene(int argc, char **argv);
int main_render(int argc, char **argv);
int main_trace(int argc, char **argv);
int main_trace_info(int argc, char **argv);
int main_trace_dump(int argc, char **argv);
int main_sim(int argc, char **argv);
int main_sweep(int argc, char **argv);
int main_report(int argc, char **argv);
int main_db(int argc, char **argv);
int main_bench(int argc, char **argv);

/* Prints "raytraffic CMD: msg" to stderr. */
void rt_cmd_error(const char *cmd, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 2, 3)))
#endif
    ;

/* The full command line as one string (for provenance); static storage. */
const char *rt_cmd_line(void);
void rt_cmd_set_line(int argc, char **argv);

/* True when argv holds -h or --help anywhere before "--". */
int rt_cmd_wants_help(int argc, char **argv);

#endif
