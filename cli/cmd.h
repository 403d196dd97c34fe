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

#include "tracer.h"

#include <getopt.h>
#include <stdint.h>
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

/* True when a --hierarchy argument (--hierarchy SPEC or --hierarchy=SPEC)
 * marks levels /private or /shared: the multi-core model's command line
 * (sim and sweep hand such a command to their *_cores.c variant). */
int rt_cmd_wants_cores(int argc, char **argv);

/* A sampling rate: a number in (0, 1] or 1/N ("1/64"). 0 or -1. */
int rt_cmd_parse_rate(const char *s, double *out);

/* A decimal integer in lo..hi: a digit first (or '-' and a digit), nothing
 * after it; no white space, no '+'. 0 or -1 (no message). */
int rt_cmd_parse_long(const char *s, long lo, long hi, long *out);

/* A finite decimal number [-]D[.D][e[+-]D] (or [-].D...): no white space,
 * no '+' in front, no hex, nan or inf, no overflow. 0 or -1 (no message).
 * The one parser of non-integer option values. */
int rt_cmd_parse_double(const char *s, double *out);

/* Refuses a word that will be a scene name or a file name and contains a
 * control character (bytes 0x01-0x1f, 0x7f): a newline there would end a
 * line of `sweep --list-jobs` early and run the rest as a command.
 * 0, or -1 with "OPT: 'ARG' contains a control character" printed for cmd. */
int rt_cmd_check_text(const char *cmd, const char *opt, const char *arg);

/* --line: a line size in bytes, 1..1M, as a number or with a K/M suffix
 * ("64", "4K"). 0, or -1 with the message printed for cmd. The one parser
 * of --line (sim, sweep, trace-dump). */
int rt_cmd_parse_line(const char *cmd, const char *arg, uint32_t *line);

/* Writes s to f as a JSON string literal (quotes, backslashes and control
 * bytes escaped). */
void rt_cmd_json_str(FILE *f, const char *s);

/* A scene's load warnings (rt_scene.warn), every kind on its own stderr
 * line "raytraffic CMD: warning: FILE:LINE: what (N times)". */
void rt_cmd_print_warnings(const char *cmd, const rt_scene *s);
/* The same as a JSON member `"warnings": [{"kind": ..., "count": N,
 * "first": "FILE:LINE", "message": ...}, ...]` (no comma around it). */
void rt_cmd_json_warnings(FILE *f, const rt_scene *s);
/* --strict: a scene with warnings is refused, its first warning named and
 * the count of kinds given (printed for cmd). 0, or -1. */
int rt_cmd_strict(const char *cmd, const rt_scene *s);

/* ---- render options shared by render, trace, bench and sweep ---------- */

/* The options come from one table, rt_render_optdefs (tracegen/options.h):
 * an entry names the commands (RT_OC_*) that take it, and these helpers
 * derive the getopt tables, the parsing and the --help text from it. An
 * entry's getopt code is RT_OPT_CODE_BASE + its index (or its short name). */

/* The command's own NULL-terminated long options followed by the table's
 * entries for cmd (RT_OC_RENDER, ...); a malloc'd table (caller frees) or
 * NULL. */
struct option *rt_cmd_longopts(unsigned cmd, const struct option *own);
/* own short options followed by the table's for cmd ("o:h" + "t:W:H:")
 * into buf. */
const char *rt_cmd_shortopts(unsigned cmd, const char *own, char *buf, size_t n);
/* The table index behind a getopt code, or -1. */
int rt_cmd_opt_index(int c);

/* Handles one table option. Returns 1 if handled, 0 if c is not a table
 * option, -1 on a bad value (message printed for cmd). Records the option
 * in o->given, so the tracer can refuse it. */
int rt_cmd_render_opt(const char *cmd, int c, const char *arg, rt_render_opts *o, const char **tracer);
/* The same for the option named "--NAME" (scene's --look-at, --fov, --light). */
int rt_cmd_render_opt_named(const char *cmd, const char *name, const char *arg, rt_render_opts *o);

/* --help lines of the table's entries for cmd, in table order. */
void rt_cmd_render_help(FILE *f, unsigned cmd);
/* sweep --help: the line of the entry "--NAME" (its .sweep_help), and then
 * every entry of cmd without one (as render lists it). */
void rt_cmd_render_help_line(FILE *f, const char *name);
void rt_cmd_render_help_rest(FILE *f, unsigned cmd);

/* Refuses, as a usage error printed for cmd, the options given in o that
 * the tracer does not read, a structure it cannot run on, and values it
 * cannot run (subsampling that traces nothing, partial packets). 0 or -1. */
int rt_cmd_check_tracer_opts(const char *cmd, const char *tracer, const rt_render_opts *o);

/* `sim --hierarchy SPEC ...` with private/shared levels: the multi-core
 * hierarchy (cmd_sim_cores.c). */
int rt_cmd_sim_cores(int argc, char **argv);
/* trace --sim: the simulator's options checked as `sim` parses them, before
 * anything is traced (argv: "sim", the options, the trace to be written).
 * 0, or -1 with the message printed (a usage error). The multi-core form
 * (rt_cmd_wants_cores) is checked when it runs. */
int rt_cmd_sim_check_args(int argc, char **argv);

/* --material NAME for render and trace: checks NAME against the scene
 * library's presets and returns SPEC with ":material=NAME" (or
 * ",material=NAME" after existing parameters) in buf; SPEC itself when
 * name is NULL; NULL (message printed for cmd) for an unknown preset or a
 * spec too long. */
const char *rt_cmd_scene_material(const char *cmd, const char *spec, const char *name, char *buf, size_t n);

#endif
