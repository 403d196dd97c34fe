/*
 * analysis_int.h -- helpers shared by the files of analysis/ (not public).
 */
#ifndef RT_ANALYSIS_INT_H
#define RT_ANALYSIS_INT_H

#include "analysis.h"
#include "outfile.h"
#include "tracer.h"

/* Prepares sql on h and binds its parameters ?1, ?2, ... from the
 * variable arguments, one per character of types: 's' const char *,
 * 'i' int, 'I' int64_t. NULL with "context: sqlite message" on failure.
 * Before preparing, the tokens @BASE@, @PACKET@, @SCHED@ (the figures'
 * tracers as SQL strings, from the traits: RT_FIG_NAVRATIL), @NAVRATIL@
 * (the three as an IN list) and @DIMS@ (the schema-6 dimensions at the
 * values the figures are drawn for, aliased r; "1" on older files) are
 * replaced, so no query names a tracer or a default itself. */
sqlite3_stmt *rt_report_stmt(sqlite3 *h, const char *sql, const char *context, rt_err *e, const char *types, ...);

/* Finalizes st after the last sqlite3_step returned rc: 0 when rc is
 * SQLITE_ROW or SQLITE_DONE, else -1 with "context: sqlite message". */
int rt_report_done(sqlite3_stmt *st, int rc, const char *context, rt_err *e);

/* Merges the ascending sizes add[0..nadd) into the ascending union
 * sz[0..ns) (each size once, at most max kept); returns the new count. */
int rt_report_size_union(uint64_t *sz, int ns, int max, const uint64_t *add, int nadd);

/* What groups the runs of a figure that compares structures (accel.c,
 * instances.c): one scene, resolution, lighting, tracer, run key without
 * the structure, and simulator parameters. */
typedef struct rt_report_group {
    char scene[128], hash[17], tracer[64], key[256], sim_params[160];
    int W, H, lights;
} rt_report_group;

/* Orders groups by scene, hash, W, H, lights, tracer, key, sim_params;
 * 0 when they are the same group. */
int rt_report_group_cmp(const rt_report_group *a, const rt_report_group *b);

/* A group's label "SCENE WxH lights L: TRACER[ KEY][ SIM_PARAMS]" (the
 * figures' headings) into b (n bytes). */
void rt_report_run_label(char *b, size_t n, const rt_report_group *g);

/* 0 if everything written to out so far reached it (fflush), else -1
 * with "write error: reason". */
int rt_report_flush(FILE *out, rt_err *e);

/* Index in R->scenes of a scene label, or of the first scene named so
 * when label is a bare name; -1 if none. */
int rt_report_scene_index(const rt_report *R, const char *label);

/* sql with every "@LABEL@" replaced by the SQL expression of a scene's
 * report label (scenes aliased s; see rt_report.scenes), for databases
 * with or without the scene paths of schema 3. malloc'd; NULL on error. */
char *rt_report_label_sql(sqlite3 *h, const char *sql, rt_err *e);

/* ---- plot outputs (plot.c) ---- */

/* The path DIR/PREFIX NAME SUFFIX of a plot file, into buf (n bytes): '/'
 * in NAME becomes '_' (a mesh given by its path still makes one file in
 * DIR), and a NAME longer than RT_PLOT_NAME_MAX bytes is cut and ended
 * with "~" and its hash (rt_name_fit), so two long names that differ only
 * at the end give two files, and the file name stays under NAME_MAX. */
#define RT_PLOT_NAME_MAX 160
void rt_plot_path(char *buf, size_t n, const char *dir, const char *prefix, const char *name, const char *suffix);

/* Opens a data or script file through src/outfile.c (unique temporary,
 * renamed by rt_plot_commit): the stream, with *o its handle; NULL with
 * "PATH: reason". */
FILE *rt_plot_open(const char *path, struct rt_out **o, rt_err *e);
/* Commits what rt_plot_open opened: 0, or -1 with "PATH: reason" and
 * nothing left (rt_out_commit). */
int rt_plot_commit(struct rt_out *o, rt_err *e);

/* Runs script with p->gnuplot (nothing without one), then checks that
 * every path of outs (NULL-terminated) is a non-empty regular file, so a
 * picture gnuplot did not write is an error, never a "wrote" line; then
 * logs "wrote WHAT" to p->log. 0 or -1. */
int rt_plot_draw(const rt_plot_opts *p, const char *script, const char *const *outs, const char *what, rt_err *e);
/* The run-key part that selects a layout's runs: "" for compact (no
 * layout= in the key), else "layout=NAME " (matched against the key with a
 * space appended, so pbrt does not match pbrt64). Returns buf. */
const char *rt_report_layout_key(int geom, char *buf, size_t n);

/* Creates dir unless it exists. */
int rt_plot_mkdir(const char *dir, rt_err *e);

/* Writes DIR/speed-error.gp for the data file datpath whose last column
 * is a series index into labels[0..n-1], and runs it when p->gnuplot is
 * set. */
int rt_plot_speed_error(const rt_plot_opts *p, const char *datpath, const char (*labels)[128], int n, rt_err *e);

/* The registered tracers that appear in figure fig (RT_FIG_*), in registry
 * order, up to max; returns how many. The paper's Figures 4-9 take three:
 * baseline, packet, scheduled. */
int rt_report_fig_tracers(unsigned fig, const rt_tracer **out, int max);

#endif
