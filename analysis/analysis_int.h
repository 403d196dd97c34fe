/*
 * analysis_int.h -- helpers shared by the files of analysis/ (not public).
 */
#ifndef RT_ANALYSIS_INT_H
#define RT_ANALYSIS_INT_H

#include "analysis.h"
#include "tracer.h"

/* Prepares sql on h and binds its parameters ?1, ?2, ... from the
 * variable arguments, one per character of types: 's' const char *,
 * 'i' int, 'I' int64_t. NULL with "context: sqlite message" on failure. */
sqlite3_stmt *rt_report_stmt(sqlite3 *h, const char *sql, const char *context, rt_err *e, const char *types, ...);

/* Finalizes st after the last sqlite3_step returned rc: 0 when rc is
 * SQLITE_ROW or SQLITE_DONE, else -1 with "context: sqlite message". */
int rt_report_done(sqlite3_stmt *st, int rc, const char *context, rt_err *e);

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
