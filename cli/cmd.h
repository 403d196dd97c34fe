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

/* ---- render options shared by render, trace, bench and sweep ---------- */

/* getopt_long codes for the shared render options. */
enum {
    RT_OPT_LIGHTS = 1000,
    RT_OPT_CACHE_SIZE,
    RT_OPT_GMAX,
    RT_OPT_PACKET,
    RT_OPT_QORDER,
    RT_OPT_HIT_RULE,
    RT_OPT_QP_MEASURE,
    RT_OPT_THREADS,
    RT_OPT_SUBSAMPLE,
    RT_OPT_MODE,
    RT_OPT_DEPTH,
    RT_OPT_SPP,
    RT_OPT_BOUNCES,
    RT_OPT_LAYOUT,
    RT_OPT_QUEUE_STORES,
    RT_OPT_ACCEL,
    RT_OPT_GRID_MIN,
    RT_OPT_VB_SIZE,
    RT_OPT_ORACLE,
    RT_OPT_ORACLE_FRACTION,
    RT_OPT_UNROLL,
    RT_OPT_UNROLL_SUPPRESS,
    RT_OPT_LOOK_AT,
    RT_OPT_FOV,
    RT_OPT_LIGHT,
    RT_OPT_GRID_DENSITY,
    RT_OPT_RECORD_STORES,
    RT_OPT_TREELET_TRIS,
    RT_OPT_RAY_WINDOW,
    RT_OPT_LIGHT_SAMPLES
};

/* The shared long options ({"lights",...}, {"cache-size",...}, ...);
 * terminated by a zero entry. Copy them into a command's own table with
 * rt_cmd_merge_opts. */
extern const struct option rt_render_longopts[];
#define RT_RENDER_SHORTOPTS "t:W:H:"
#define RT_RENDER_OPTS_HELP                                                                  \
    "  -t TRACER          recursive | packet | dynamic | stream-branching |\n"               \
    "                     stream-multipass | feedback | treelet (default recursive)\n"                \
    "  -W N, -H N         image size in pixels (a .pbrt scene: its Film's by default;\n"   \
    "                     one of them alone keeps the Film's aspect ratio)\n"                \
    "  --lights L         all | none | comma list of lights 0,1,2 (default none; with\n"   \
    "                     --light-samples, indices 0..31 of the file's lights, all = every one)\n" \
    "  --light-samples N  the scene file's own lights: N shadow rays per hit to each area\n" \
    "                     or infinite light, 1 to point and distant ones (default 0: the\n" \
    "                     three point lights)\n"                                             \
    "  --look-at EX,EY,EZ,AX,AY,AZ[,UX,UY,UZ]  camera at E looking at A (up: the scene's)\n" \
    "  --fov DEGREES      vertical field of view (default: the scene's)\n"                 \
    "  --light X,Y,Z[,POWER]  a point light (repeat up to 3 times: lights 0, 1, 2 replace\n" \
    "                     the scene's; POWER default: the scene's light power)\n"          \
    "  --packet N         packet edge in pixels for -t packet (default 8)\n"                 \
    "  --cache-size S     dynamic, treelet: cache size to schedule for, e.g. 64K (default 64K)\n" \
    "  --gmax B           dynamic: explicit geometry budget in bytes (overrides derivation);\n" \
    "                     treelet: the treelet byte budget (default half the cache size)\n" \
    "  --subsample K[:T]  reduced experiment: trace 1 in K tiles of TxT pixels (T default 8;\n" \
    "                     1 = single pixels; packet tracer: T a multiple of the packet)\n" \
    "  --qorder O         dynamic, treelet: queue order, fullest | tree (default fullest)\n" \
    "  --hit-rule R       dynamic: a hit beyond the subtree's exit, exact (settled in\n"    \
    "                     later queue points) | first (taken; images may differ)\n"        \
    "  --qp-measure M     dynamic: subtree size for queue points, all (nodes, lists,\n"    \
    "                     triangles) | triangles (default all)\n"                          \
    "  --threads N        dynamic: modeled threads, 2 rays buffered each (default 4)\n"      \
    "  --mode M           raycast | shadow | whitted | path (default shadow with lights,\n" \
    "                     else raycast)\n"                                                    \
    "  --depth N          whitted: ray generations per path, primary included (1..64, 5)\n" \
    "  --spp N            path: samples per pixel (default 1)\n"                             \
    "  --bounces B        path: bounces after the primary hit (0..1000, default 4)\n"        \
    "  --layout L         geometry layout, compact | mesh (pbrt-style shared vertices)\n" \
    "                     | pbrt | pbrt64 (pbrt-v1's k-d tree objects and mailboxes,\n"    \
    "                     4- or 8-byte pointers) (default compact)\n"                      \
    "  --queue-stores S   dynamic: queue writes, write-allocate | stream (default\n"        \
    "                     write-allocate)\n"                                               \
    "  --accel A          acceleration structure: kd | bvh2 | bvh4 | bvh8 (recursive,\n"  \
    "                     packet; default kd), grid | naive (feedback; default grid)\n"  \
    "  --vb-size S        feedback: limit of one vertex buffer, e.g. 512M (default 2G)\n" \
    "  --grid-min N       grid tracers: grid cells along the smallest axis (default 64,\n" \
    "                     halved until the grid fits the cell limit)\n"                     \
    "  --grid-density L   grid tracers: about L cells per triangle instead (0 < L <= 1024)\n" \
    "  --record-stores S  feedback, stream tracers: non-temporal (whole records, lines not\n" \
    "                     fetched; default) | write-allocate\n"                               \
    "  --oracle O         stream-multipass: naive | threshold (default threshold)\n"        \
    "  --oracle-fraction F  stream-multipass: intersect once F of the active rays need it\n" \
    "                     (0 < F <= 1, default 0.2)\n"                                      \
    "  --unroll T,I       stream-multipass: traversal steps, intersection tests per pass (1,1)\n" \
    "  --unroll-suppress  stream-multipass: no texel reads for rays done mid-pass\n"        \
    "  --treelet-tris     treelet: leaves' triangles count against the treelet budget\n"   \
    "  --ray-window N     treelet: rays in flight per generation, e.g. 64K (default all)\n"

/* Appends the shared options to a command's own NULL-terminated table;
 * returns a malloc'd table (caller frees) or NULL. */
struct option *rt_cmd_merge_opts(const struct option *own);

/* Handles one shared option. Returns 1 if handled, 0 if c is not a shared
 * option, -1 on a bad value (message printed for cmd). */
int rt_cmd_render_opt(const char *cmd, int c, const char *arg, rt_render_opts *o, const char **tracer);
/* Refuses, as a usage error printed for cmd, the options given in o that
 * the tracer does not read, a structure it cannot run on, and values it
 * cannot run (subsampling that traces nothing, partial packets). 0 or -1. */
int rt_cmd_check_tracer_opts(const char *cmd, const char *tracer, const rt_render_opts *o);

/* --material NAME for render and trace: checks NAME against the scene
 * library's presets and returns SPEC with ":material=NAME" (or
 * ",material=NAME" after existing parameters) in buf; SPEC itself when
 * name is NULL; NULL (message printed for cmd) for an unknown preset or a
 * spec too long. */
const char *rt_cmd_scene_material(const char *cmd, const char *spec, const char *name, char *buf, size_t n);

#endif
