/*
 * analysis.h -- reports and plots from a results database (prefixes
 * rt_report_, rt_plot_). This header is the manual of analysis/.
 *
 * The paper's tables (Figures 3-9), the comparison with the paper's
 * published values, the speed-against-error tables of approximate and
 * reduced experiments, and the gnuplot plots are all computed here from
 * the SQLite database that results/ writes. The front end (cli/cmd_report.c)
 * parses options, calls these functions and prints their error messages.
 *
 * Conventions, for every function below unless it says otherwise:
 * - tables go to the FILE *out given; nothing is ever written to stdout or
 *   stderr directly, and nothing exits;
 * - the return value is 0 on success and -1 on failure, with one line in
 *   e (which may be NULL); a database error, a file that cannot be written,
 *   a failed write on out (checked with fflush/ferror before returning) and
 *   a plot that gnuplot fails to draw are all failures;
 * - the database is only read: open it with rt_report_db_open (read-only)
 *   or pass any sqlite3 handle, e.g. rt_db_handle() of an rt_db.
 *
 * Plots never go through a shell: gnuplot runs with fork/execvp on a script
 * file, and every string that enters a script (scene names, paths) is
 * written by rt_plot_quote, so a scene named x'$(touch PWNED)'.obj is just a
 * title.
 */
#ifndef RT_ANALYSIS_H
#define RT_ANALYSIS_H

#include "rt.h"

#include <sqlite3.h>
#include <stdint.h>
#include <stdio.h>

#define RT_REPORT_MAXSIZES 32  /* cache sizes reported */

/* What a report shows. Zero-initialised means: Markdown, geometry
 * reductions in figures 7-9, the largest resolution present, all scenes. */
typedef struct rt_report_opts {
    int csv;           /* CSV instead of Markdown */
    int total;         /* figures 7-9 (and their comparison) on total instead of geometry traffic */
    int W, H;          /* resolution to report; 0 = the largest exact run's */
    const char *scene; /* only this scene; NULL = every scene at that resolution */
    const char *model; /* only runs of this model ("lean", "paper"); NULL = as before: wb-wa runs, any model */
    const char *layout; /* with model: that model's runs in this layout ("compact", "mesh", "pbrt",
                         * "pbrt64") instead of the model's own; NULL = the model's */
} rt_report_opts;

/* A report's axes, read from the database by rt_report_init. */
typedef struct rt_report {
    sqlite3 *h;                       /* borrowed handle; never closed here */
    const char *dbpath;               /* named in the Markdown header (borrowed) */
    int csv, total;                   /* from rt_report_opts */
    int W, H;                         /* resolution reported (0x0 when the database has no exact runs) */
    int nsizes;                       /* cache sizes with fully associative 64-byte wb-wa traffic */
    uint64_t sizes[RT_REPORT_MAXSIZES]; /* ascending, bytes */
    int nscenes;                      /* scenes with runs at W x H (0: nothing to report); no limit */
    char **scenes;                    /* nscenes labels: room, grove, sphereflake first, then by label */
    /* Scenes are told apart by (name, content hash): two meshes both named
     * mesh.obj are two scenes, labelled "mesh.obj (a/mesh.obj)" and
     * "mesh.obj (b/mesh.obj)" (path as given; else parameters or hash).
     * Labels and names are whole (never cut), so they are as distinct as
     * the scenes. */
    char **scene_name;                /* scenes.name of each label */
    char (*scene_hash)[17];           /* scenes.hash of each label */
    char **scene_abspath;             /* mesh file to re-render, '' = built-in or unknown */
    int packet;                       /* packet edge of the packet runs (default 8) */
    /* The model the values are read for (rt_report_set_model): -1 = none,
     * every exact wb-wa run (the lowest geometry when several match);
     * else only that model's runs: its policy label, its sim_params, and
     * tracer parameters with (or without) its layout and queue stores. */
    int model;                        /* RT_EXP_MODEL_* or -1 */
    char policy[64];                  /* cache_configs.policy read ("wb-wa" with no model) */
    char sim_params[160];             /* the model's exact sim_params (rt_exp_sim_params) */
    int geom;                         /* the layout read (rt_geom_layout): the model's, or set after
                                       * rt_report_set_model to read another layout's runs */
    int stream;                       /* the model's queue stores are stream */
} rt_report;

/* Opens the results database at path read-only (no file is ever created
 * or written, so it works on a read-only file in a read-only folder).
 * Fails with "PATH: reason" when the file is missing, is not a SQLite
 * database, is not a raytraffic database, or has a schema version newer
 * than RT_DB_SCHEMA_VERSION. On success *ph is the handle; the caller
 * closes it with sqlite3_close. */
int rt_report_db_open(const char *path, sqlite3 **ph, rt_err *e);

/* Reads the report's axes (resolution, cache sizes, scenes, packet edge)
 * from h. dbpath is only used in texts. nscenes == 0 is not an error:
 * the caller decides whether an empty report is one. Every scene is kept,
 * however many. R owns its scene arrays: release them with rt_report_free
 * (also after a failed init). */
int rt_report_init(rt_report *R, sqlite3 *h, const char *dbpath, const rt_report_opts *o, rt_err *e);

/* Frees what rt_report_init allocated in R (not the handle); R may be
 * zeroed or freed already. */
void rt_report_free(rt_report *R);

/* Restricts R's values to model (RT_EXP_MODEL_*, or -1 for no model, as
 * rt_report_init leaves it) and re-reads the cache sizes of that model's
 * policy. 0, or -1 with a message (unknown model, database error). */
int rt_report_set_model(rt_report *R, int model, rt_err *e);

/* Geometry and ray traffic (MB) of tracer on scene (a label of R->scenes,
 * or a bare scene name: then any scene of that name) at cache size `size`
 * with light mask `lights`; the dynamic tracer's run is the one scheduled
 * for that size. Returns 1 and sets *geom, *ray when the run exists, 0
 * when it does not, -1 on a database error. */
int rt_report_value(const rt_report *R, const char *scene, const char *tracer, unsigned lights, uint64_t size,
                    double *geom, double *ray, rt_err *e);

/* The agreement of one scene's values with the paper's, for R's model
 * (rt_report_compare_paper prints it per scene and model). */
typedef struct rt_report_agree {
    int cells[2], within[2]; /* Figures 4-6 (0) and 7-9 (1): cells compared, of them within 2x of the paper's */
    int nsizes, dyn_less;    /* sizes compared (primary rays), where dynamic moves less geometry than recursive */
    int ray_more, paper_ray_more; /* sizes where dynamic moves more ray data than recursive: ours, the paper's */
    int ray_both;            /* of the paper's sizes, those where ours does too */
    int turn_kb, paper_turn_kb; /* size (KB) from which the total traffic reduction vs recursive is negative and
                                 * never again positive; 0 = none */
} rt_report_agree;

/* Within 2x: same sign (or both zero) and the larger magnitude at most
 * twice the smaller. */
int rt_report_within2(double ours, double paper);

/* Computes a's fields for scene sc from the paper's tables
 * (data/paper_*.csv). 0, or -1 with a message. */
int rt_report_agreement(const rt_report *R, const char *sc, rt_report_agree *a, rt_err *e);

/* The reduction, the paper's formula and the only one in every report,
 * plot and CSV: 100 (base / dyn - 1) percent (0: the same; 100: half the
 * traffic; negative: dynamic moves more, down to -100); NAN unless both
 * are positive. */
double rt_report_reduction(double base, double dyn);
/* A reduction as the paper prints it (losses as -100 (dyn / base - 1),
 * e.g. -625.1 for 7.251 times more) in rt_report_reduction's terms. */
double rt_report_paper_reduction(double printed);
/* A reduction for reading: "521.5%" for a gain, "7.25× more" (dyn / base)
 * for a loss, "—" for none; csv: the number itself, full precision, ""
 * for none. Returns buf. */
const char *rt_report_fmt_reduction(double red, int csv, char *buf, size_t n);

/* One size of a scene's primary-ray table as the findings read it:
 * geometry and ray traffic of the baseline ([0], recursive) and of the
 * scheduled tracer ([1], dynamic), in any one unit; NAN = no run. */
typedef struct rt_report_point {
    uint64_t size;     /* cache size (bytes, or KB for the paper's rows) */
    double geom[2], ray[2];
} rt_report_point;

/* The findings of one such table (sizes ascending), computed by
 * rt_report_find for our runs and for the paper's rows alike. */
typedef struct rt_report_findings {
    int nsizes;          /* sizes with both tracers */
    int dyn_less;        /* of them, where dynamic moves less geometry */
    int ray_more;        /* where dynamic moves more ray data */
    uint64_t best_size;  /* the largest geometry reduction's size (0 = none) */
    double best_red;     /* and that reduction (NAN = none) */
    uint64_t turn_size;  /* the crossover: the first size from which the total reduction is negative and never
                          * again positive (0 = none: it ends positive, or never turns) */
    double turn_red;     /* total reduction at the crossover (NAN = none) */
    uint64_t last_size;  /* the largest size compared */
    double last_total;   /* its total reduction */
} rt_report_findings;

/* Computes f from the n points p (ascending sizes). */
void rt_report_find(const rt_report_point *p, int n, rt_report_findings *f);
/* The findings as Markdown list items (sizes in KB), with the paper's in
 * brackets when paper is non-NULL. sc names the scene (unused in the
 * sentences, which follow a heading naming it). */
void rt_report_write_findings(FILE *out, const char *sc, const rt_report_findings *f, const rt_report_findings *paper);

/* The report's tables: figure is "all" (header, scene table, Figures 4-6
 * then 7-9 for every scene), "scenes" (the scene table) or "4".."9" (that
 * figure's table for the paper scene it belongs to: 4/7 room, 5/8 grove,
 * 6/9 sphereflake). The Markdown header is printed for every figure. An
 * unknown figure is an error. */
int rt_report_tables(const rt_report *R, const char *figure, FILE *out, rt_err *e);

/* The summary that opens the full report (rt_report_tables "all", in
 * Markdown): what was run (runs, resolution, scenes, cache sizes, the
 * setup), the revision, date, command and preset recorded with the
 * figures' runs, then per scene its findings (rt_report_find over every
 * size) in a few sentences with the numbers, and the paper's for a scene
 * at the paper's setup. */
int rt_report_summary(const rt_report *R, FILE *out, rt_err *e);

/* The single tables behind rt_report_tables: the scene table (the paper's
 * Figure 3 statistics), one scene's primary-ray traffic (Figures 4-6), one
 * scene's shadow-ray reductions (Figures 7-9). */
int rt_report_scenes(const rt_report *R, FILE *out, rt_err *e);
int rt_report_primary(const rt_report *R, const char *scene, FILE *out, rt_err *e);
int rt_report_shadows(const rt_report *R, const char *scene, FILE *out, rt_err *e);

/* Figures 4-9 as tidy tables, one per figure (figure "all" or "4".."9"),
 * for loading elsewhere: one row per run x cache size x class of the runs
 * the figure shows, with every configuration column (scene, parameters,
 * hash, run, tracer, resolution, light mask, schedule, tracer and
 * simulator parameters, the schema-6 dimensions, cache configuration,
 * class and group) and the counters in bytes and line touches, full
 * precision. CSV (a header line) or JSON ({"figure", "scene", "caption",
 * "columns", "rows"}; on out, all of them inside {"database", "figures"}).
 * With dir, one file per figure, DIR/figureN-SCENE.csv or .json, each
 * logged as "wrote PATH (N rows)" to log (may be NULL); without, out (CSV
 * only for one figure: tables of different figures never share a
 * stream). Nothing to show is an error. */
int rt_report_tidy(const rt_report *R, const char *figure, int json, const char *dir, FILE *log, FILE *out, rt_err *e);

/* Splits a CSV report of several tables (each after a "# title" line, as
 * --figure purcell, feedback and --speed-error write them) into one file
 * per table, DIR/PREFIX-N-TITLE.csv, each logged as "wrote PATH" to log
 * (may be NULL). 0, or -1 (no table at all is an error). */
int rt_report_csv_split(FILE *in, const char *dir, const char *prefix, FILE *log, rt_err *e);

/* Our values beside the paper's (data/paper_primary.csv,
 * data/paper_shadows.csv, found in the source tree or the installed data
 * folder) for the paper scenes present, with ratios and, in Markdown, the
 * qualitative findings. An unreadable paper table is an error. */
int rt_report_compare_paper(const rt_report *R, FILE *out, rt_err *e);

/* The paper's values at cache size kb (KB) for scene label, when the
 * scene is at the paper's setup: geometry and ray MB of recursive, packet,
 * dynamic (NAN where the paper has none) and the geometry reductions vs
 * recursive with light 0, 1, 2 and all three (rt_report_reduction's
 * terms). 1 when the paper has a row at that size, 0 when not (or not the
 * paper's setup), -1 on error. */
int rt_report_paper_point(const rt_report *R, const char *label, uint64_t kb, double geom[3], double ray[3],
                          double shadow[4], rt_err *e);

/* ---- plots ---------------------------------------------------------------- */

/* Where and how plots are drawn. */
typedef struct rt_plot_opts {
    const char *dir;     /* output folder, created if missing */
    const char *gnuplot; /* gnuplot executable (rt_plot_find_gnuplot); NULL = data files and scripts only */
    FILE *log;           /* one "wrote PATH" line per picture; NULL = quiet */
} rt_plot_opts;

/* Finds gnuplot: $RT_GNUPLOT if set and non-empty (not checked: a wrong
 * value fails when plotting), else the configure-time GNUPLOT_PATH if
 * executable, else "gnuplot" on PATH. Writes the path into buf (n bytes)
 * and returns 0, or returns -1 when there is none. */
int rt_plot_find_gnuplot(char *buf, size_t n);

/* Runs `gnuplot script` with fork/execvp (no shell), its output discarded.
 * Fails with "script: gnuplot ...: first line of its messages" unless
 * gnuplot exits with status 0. */
int rt_plot_run(const char *gnuplot, const char *script, rt_err *e);

/* Writes s to f as one gnuplot double-quoted string: quotes, backslashes,
 * control bytes, and the characters gnuplot substitutes inside double
 * quotes (` for commands, @ and $) become octal escapes; bytes >= 0x80
 * pass through (UTF-8 names stay readable). rt_plot_quote_path does the
 * same for a file name and prefixes "./" to a relative one, so that a
 * name starting with '<' or '|' is never read as a pipe. Return fputs's
 * convention: non-negative, or EOF on a write error. */
int rt_plot_quote(FILE *f, const char *s);
int rt_plot_quote_path(FILE *f, const char *path);

/* Per scene: DIR/NAME-traffic.dat (geometry and ray MB against cache size,
 * primary rays), DIR/NAME-traffic.gp and, with gnuplot, .png and .svg;
 * NAME is the scene name with '/' replaced by '_'. */
int rt_plot_traffic(const rt_report *R, const rt_plot_opts *p, rt_err *e);

/* DIR/scenes.png: every scene rendered at 256x256 (recursive tracer, all
 * lights), side by side; a mesh is re-read from the absolute path the
 * database recorded, so this works from any folder. A scene that cannot be
 * rebuilt (e.g. a mesh file no longer where the database says) is an error
 * naming it; nothing is written then. */
int rt_plot_scenes(const rt_report *R, const rt_plot_opts *p, rt_err *e);

/* ---- approximate and reduced experiments ------------------------------------- */

/* Speed against error: every approximate run against the exact run of the
 * same identity, every reduced experiment against its full exact run
 * (tables and summary in analysis/speed_error.c), and for the runs that
 * stored standard errors (schema 5) how many estimates lie within 1, 2, 3
 * of them and every size's estimate beside its error (Markdown; CSV: four
 * more columns per pair, empty without errors). csv selects CSV. With
 * plot non-NULL also writes DIR/speed-error.dat and .gp and, with
 * gnuplot, DIR/speed-error.png (mean miss-ratio error against speedup).
 * A database with no such pair is an error ("nothing to show"). */
int rt_report_speed_error(sqlite3 *h, int csv, const rt_plot_opts *plot, FILE *out, rt_err *e);

/* Acceleration structures (analysis/accel.c): per group of runs of one
 * tracer that differ only in their structure (scene, resolution, lights,
 * run key without accel=, simulator parameters; exact, full-frame,
 * unscheduled), one row per structure: footprint (the stats' accel_nodes,
 * accel_bytes), node visits and triangle tests per ray traced, geometry
 * traffic at every 64-byte fully associative cache size; Markdown adds the
 * structure with the least geometry at the smallest and largest size.
 * scene NULL: every scene. With plot, DIR/accel-LABEL.{dat,gp,png}. No
 * group of two structures or more is an error naming the sweep to run. */
int rt_report_accel(sqlite3 *h, const char *scene, int csv, const rt_plot_opts *plot, FILE *out, rt_err *e);

/* `report --figure instances` (instances.c): groups of runs of one tracer
 * that differ only in their structure, holding an `--instances bvh` run
 * and a flattened one; per run and 64-byte fully associative cache size
 * the geometry traffic by level: two-level tlas, inst, blas (node, index,
 * tri), shade; flattened nodes (node, index), tri, shade; both the whole
 * geometry group. Markdown adds the two-level geometry over each
 * flattened run's at the smallest and largest size; csv one row per
 * (group, structure, level, size). scene NULL: every scene. No such group
 * is an error naming the sweeps to run. */
int rt_report_instances(sqlite3 *h, const char *scene, int csv, FILE *out, rt_err *e);

/* Secondary rays (analysis/secondary.c): per scene, mode (with its
 * parameters), lighting, resolution and cache size, the reduction of
 * dynamic against recursive (rt_report_reduction) in geometry and in total
 * traffic per ray generation (view v_gen; the dynamic run scheduled for the
 * size), then, in Markdown, one sentence per scene: at how many points
 * dynamic moves less geometry / total traffic over generations >= 1. With
 * plot, DIR/secondary-SCENE-MODE-lLIGHTS-WxH.{dat,gp,png}. A database
 * without such pairs is an error naming the sweep that makes them. */
int rt_report_secondary(sqlite3 *h, const char *dbpath, int csv, const rt_plot_opts *plot, FILE *out, rt_err *e);

/* Purcell et al. 2002 (analysis/purcell.c): the runs of stream-branching
 * and stream-multipass (of scene, or all when NULL) beside the paper's
 * bunny values (data/purcell_bunny.csv): Figure 6 (v, t, s), Table 2
 * (passes, per-ray maxima, SIMD efficiency), Figure 7 (instructions and
 * bandwidth per kernel), Figure 8 (bandwidth by data type), Figure 9
 * (traffic with the texture cache the sweep simulates beside these runs,
 * 1365 direct-mapped 48-byte lines, or else the simulated cache nearest 64
 * KB, over the bytes referenced, by data type, and the triangle reads' hit
 * rate). Markdown, or CSV. With plot non-NULL also writes stacked-bar
 * charts in the paper's form, DIR/purcell-{fig7-instructions,
 * fig7-bandwidth,fig8,fig9}.{dat,gp} and, with gnuplot, .png (fig9 only
 * when some run has a cache). With compare (--compare-paper), each value
 * the paper gives (Figure 6, Table 2, Figure 9's triangle hit rate) is
 * printed as ours / paper (ratio) for the runs of the paper's case (the
 * bunny, ray cast; CSV: an extra _paper column), and every figure ends with
 * an agreement line. 0, or -1 when there are no such runs, the
 * paper's file is missing or a plot cannot be written. */
int rt_report_purcell(sqlite3 *h, const char *scene, int csv, int compare, const rt_plot_opts *plot, FILE *out,
                      rt_err *e);

/* The feedback tracer (analysis/feedback.c): per feedback run (of scene,
 * or all when NULL; exact, not subsampled) and cache configuration, the
 * traffic per class (stream = the vertex buffers, node = grid, index =
 * lists, tri, shade, fb), then the ray-state bytes per traced ray and per
 * ray generation of three designs on the same scene, resolution, lights
 * and mode: the dynamic run scheduled for the size (classes ray, queue,
 * qtable, hit), a stream-multipass run (class stream; the one with the
 * feedback run's grid_min if several) and the feedback run (class
 * stream), each over its own rays traced (rays_primary + rays_shadow +
 * rays_secondary) and the mode's generations (whitted depth D: D; path
 * B bounces: B + 1; else 1); a missing design is a dash. Markdown with a
 * finding per run at its largest configuration, or CSV (bytes). With plot,
 * DIR/feedback-LABEL.{dat,gp,png}. -1 when there is no feedback run. */
int rt_report_feedback(sqlite3 *h, const char *scene, int csv, const rt_plot_opts *plot, FILE *out, rt_err *e);

/* Treelets (analysis/treelet.c): per scene (or only scene when non-NULL),
 * mode, lighting, resolution, treelet variant and cache size, total DRAM
 * traffic (fully associative 64-byte lines, wb-wa, exact runs) split into
 * geometry, ray, stack and queue of the reference tracer on the BVH, the
 * treelet run scheduled for that size, the reference tracer on the k-d
 * tree and the dynamic run scheduled for that size, and each scheduler's
 * saving against its baseline (rt_report_reduction). Roles come
 * from the traits (reference, RT_FIG_TREELET, the scheduled tracer of
 * RT_FIG_NAVRATIL). Markdown (with the largest saving) or CSV. With plot,
 * DIR/treelet-SCENE-MODE-lLIGHTS-WxH-ACCEL[-VARIANT].{dat,gp,png}. 0, or
 * -1 when there is no treelet run or a plot cannot be written. */
/* report --figure cores (cores.c): DRAM traffic and the shared level's
 * miss rate of the multi-core runs (a hierarchy with a private level)
 * against their core count, per scene, tracer and shared size (256K, 4M),
 * with each tracer's reduction against the recursive tracer; a plot per
 * scene with plot. 0, or -1 with e (no such runs: the message says how to
 * make them). */
int rt_report_cores(sqlite3 *h, const char *dbpath, const char *scene, int csv, const rt_plot_opts *plot, FILE *out,
                    rt_err *e);
int rt_report_treelet(sqlite3 *h, const char *dbpath, const char *scene, int csv, const rt_plot_opts *plot, FILE *out,
                      rt_err *e);

/* `report --figure hierarchy` (analysis/hierarchy.c): per hierarchy run
 * the traffic of every level and size per class group, then for runs that
 * differ only in their replacement policy and include OPT, total traffic
 * per policy and size with LRU's gap to OPT. Markdown. scene NULL = all.
 * 0, or -1 when there is nothing to show. */
int rt_report_hierarchy(sqlite3 *h, const char *scene, FILE *out, rt_err *e);

#endif
