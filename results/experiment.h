/*
 * experiment.h -- the experiment: jobs rendered in-process, their access
 * stream fanned out to simulators, their runs stored (module prefix
 * rt_exp_).
 *
 * A reference travels tracer -> recorder -> fan-out sink (this module) ->
 * the exact simulator, any approximate simulators and an optional trace
 * writer; the counters become rows (rows.h) and runs (db.h). `sweep` builds
 * the matrix of jobs and hands each job to rt_exp_run_job; the front end only
 * parses options, forks workers and prints. The tests call the same
 * function, so what is tested is what the sweep runs.
 *
 * Run identity: every rt_db_run key is built here, by rt_exp_job_key (an
 * in-process job), rt_exp_run_from_meta (a trace header) or
 * rt_exp_run_from_din (a din file); the tracer parameter string ("qorder=..
 * threads=..", "packet=N", "subsample=..") is formatted in one place,
 * rt_exp_tracer_params, and matches the string the trace writer records, so
 * `sim --db` of a kept trace finds the run the sweep stored.
 *
 * Return conventions as in rt.h: 0 / non-NULL on success, -1 / NULL with
 * one line in e; nothing here prints or exits.
 */
#ifndef RT_EXPERIMENT_H
#define RT_EXPERIMENT_H

#include "approx.h"
#include "db.h"
#include "hier.h"
#include "sim.h"
#include "trace.h"
#include "tracer.h"

#include <stddef.h>
#include <stdint.h>

/* ---- fan-out sink ------------------------------------------------------ */

#define RT_EXP_MAXFAN 10

/* One rt_sink feeding up to RT_EXP_MAXFAN sinks in the order added, timing
 * each, so every simulator's speed on the same stream is measured without
 * the tracer's time. Embed it (no allocation); the targets stay owned by
 * the caller and must outlive the fan. */
typedef struct rt_exp_fan {
    rt_sink self;               /* hand this to the recorder (rt_exp_fan_sink) */
    int n;                      /* targets */
    rt_sink *to[RT_EXP_MAXFAN]; /* targets, in the order added */
    double sec[RT_EXP_MAXFAN];  /* seconds spent in each target's put */
} rt_exp_fan;

/* Empties f (no targets, zero times). */
void rt_exp_fan_init(rt_exp_fan *f);
/* Adds a target; returns its index (into f->sec), or -1 when full. */
int rt_exp_fan_add(rt_exp_fan *f, rt_sink *to, rt_err *e);
/* The sink feeding every target; its put fails (-1) if any target's did,
 * after still feeding the others. Valid as long as f. */
rt_sink *rt_exp_fan_sink(rt_exp_fan *f);

/* ---- named models ------------------------------------------------------ */

/* A model names one set of modeling choices (docs/results.md, "Models"):
 * the geometry layout and queue stores the tracers record, and the
 * simulator's accounting. It sets the defaults of those options; options
 * given explicitly override them. `lean` is the toolkit's default
 * (compact layout, write-allocate queue stores, no flush, no full-line
 * rule: every earlier run is a lean run); `paper` is what the paper's text
 * supports (Dinero IV's defaults as printed: the end-of-run flush and
 * full-line writes without a fetch; compact layout and write-allocate
 * queue stores, for the reasons given in docs/results.md). */
typedef struct rt_exp_model {
    const char *name; /* "lean", "paper" */
    int geom;         /* rt_geom_layout */
    int qstores;      /* rt_qstores (dynamic tracer) */
    int flush;        /* rt_sim_config.flush */
    int fullline;     /* rt_sim_config.write_miss_fullline */
} rt_exp_model;

#define RT_EXP_NMODELS 2
enum { RT_EXP_MODEL_LEAN = 0, RT_EXP_MODEL_PAPER = 1 };

/* Model i (0..RT_EXP_NMODELS-1), or NULL. */
const rt_exp_model *rt_exp_model_get(int i);
/* The index of the model called name, or -1. */
int rt_exp_model_find(const char *name);
/* Sets ro's layout and queue stores and sc's flush and full-line rule to
 * model m's (the caller then applies explicit options on top). */
void rt_exp_model_apply(const rt_exp_model *m, rt_render_opts *ro, rt_sim_config *sc);

/* The sim_params of an exact run: "" for the lean model with the default
 * accounting (so earlier keys are unchanged), else "model=NAME" (model
 * other than lean) followed by " policy=LABEL" when the accounting is not
 * the default ("policy=wb-wa+flush+fullline"). Runs of different models,
 * or of different accounting, therefore never share a key, even where
 * the tracer parameters agree. Writes at most n bytes; returns buf. */
const char *rt_exp_sim_params(int model, const rt_sim_config *sc, char *buf, size_t n);

/* ---- the experiment's settings and its matrix of jobs ------------------ */

#define RT_EXP_MAXLIST 32
#define RT_EXP_MAXAPPROX 8
#define RT_EXP_MAXPROXY 8
#define RT_EXP_MAXMODES 4

typedef struct rt_exp_lighting {
    const char *label; /* "primary", "0", "1", "2", "all" */
    unsigned mask;     /* enabled-light mask */
} rt_exp_lighting;

/* A reduced experiment run beside each job: a lower resolution (W pixels
 * wide, same aspect) or pixel subsampling (1 in subsample tiles). */
typedef struct rt_exp_proxy {
    int W;              /* res: image width; 0 = unchanged */
    uint32_t subsample; /* sub: 1 in K tiles (1 = none) */
    int subtile;        /* sub: tile edge in pixels */
} rt_exp_proxy;

/* Everything jobs share. Strings are borrowed: they must outlive every use
 * of the configuration. */
typedef struct rt_exp_config {
    char *scenes[RT_EXP_MAXLIST];               /* scene specs */
    int nscenes;
    char *tracers[RT_EXP_MAXLIST];              /* tracer names */
    int ntracers;
    rt_exp_lighting lightings[RT_EXP_MAXLIST];
    int nlightings;
    rt_sim_config sim;                          /* cache sizes, line, policy */
    rt_render_opts ro;                          /* image size, dynamic options, depth, spp, bounces, ... */
    int modes[RT_EXP_MAXMODES];                 /* render modes swept (rt_mode), see rt_exp_matrix */
    int nmodes;                                 /* 0: one mode, RT_MODE_DEFAULT */
    int accels[RT_ACCEL_NKINDS];                /* structures swept (rt_accel_kind), see rt_exp_matrix */
    int naccels;                                /* 0: one structure, ro.accel */
    int dyn_all;                                /* simulate each dynamic schedule at every size */
    rt_approx_config approx[RT_EXP_MAXAPPROX];  /* estimators run beside the exact simulator (a hybrid one
                                                   with errors set also stores its standard errors) */
    int napprox;
    rt_exp_proxy proxies[RT_EXP_MAXPROXY];      /* reduced experiments of every job */
    int nproxies;
    int model;                                  /* RT_EXP_MODEL_*: recorded in exact runs' sim_params */
    const char *keep;                           /* directory for every job's trace, or NULL */
    const char *command;                        /* command line recorded as provenance */
    /* Called once per job that is run, right after its exact run is
     * committed, with SIGTERM, SIGINT and SIGHUP blocked in the calling
     * thread from before the COMMIT until it returns: a counter it bumps
     * agrees with the database even when one of those signals ends the
     * process at that moment (the signal is delivered right after). NULL =
     * none. */
    void (*on_stored)(void *arg);
    void *on_stored_arg;                        /* its argument */
    /* A cache hierarchy every job is simulated through instead of one level
     * (NULL: one level, sim). Its last level's sizes are sim's (sim is set
     * to that level's configuration); the run key carries the canonical
     * spec, the traffic rows are the last level's, level_traffic rows the
     * levels'. No approximate runs with it. */
    const rt_hier_config *hier;
    /* The multi-core machine (cachesim/mcore.h) every job is simulated on
     * instead (NULL: none; then hier or sim): each job's simulated cores
     * (rt_job_run_cores) each with the private levels, above the shared
     * ones. Its last level's sizes are sim's; the run key carries the
     * canonical spec (every level's scope written) and the cores, the
     * traffic rows are the last level's, level_traffic rows per core for
     * the private levels. No approximate runs with it. */
    const struct rt_mc_config *mc;
    /* Simulated core counts swept (sweep --cores LIST): every job once per
     * count, in this order (rt_exp_job.cores); ncores 0: ro.cores alone. */
    int cores[RT_EXP_MAXLIST];
    int ncores;
} rt_exp_config;

/* One job of the matrix: scene x mode x lighting x tracer (x scheduled
 * size for the dynamic tracer) (x core count) (x proxy). */
typedef struct rt_exp_job {
    int scene;          /* index into config scenes */
    int lighting;       /* index into config lightings; -1 = no light (a raycast job) */
    const char *tracer; /* borrowed from the config */
    uint64_t sched_size; /* scheduled tracers: the cache size the run is scheduled for; 0 otherwise */
    int proxy;          /* index into config proxies, -1 = the full experiment */
    int mode;           /* rt_mode: RT_MODE_DEFAULT (the lighting decides), RAYCAST, WHITTED, PATH */
    int accel;          /* rt_accel_kind the job runs on; RT_ACCEL_DEFAULT: the config's ro.accel */
    int cores;          /* simulated cores (ro.cores) of a core-count sweep; 0: the config's ro.cores */
} rt_exp_job;

/* The matrix in run order: every full job, then each proxy's copies (so a
 * partial sweep has the references first). Returns the number of jobs and
 * a malloc'd array in *out (caller frees), or -1.
 *
 * Modes and lightings: per scene, per mode of c->modes (in order), per
 * lighting, per tracer:
 *   - RT_MODE_DEFAULT or RT_MODE_SHADOW: every lighting as it always was
 *     (`primary` is a raycast run, the others shadow runs; job mode
 *     RT_MODE_DEFAULT, so run keys are unchanged);
 *   - RT_MODE_RAYCAST: one job per scene and tracer, without lights
 *     (lighting -1; the same run as the `primary` lighting, so it is left
 *     out when a shadow mode with a `primary` lighting is swept too);
 *   - RT_MODE_WHITTED, RT_MODE_PATH: each lighting with lights (`primary`
 *     is skipped), with c->ro's depth, spp and bounces.
 * A tracer that cannot run a mode gets no job of it. */
long rt_exp_matrix(const rt_exp_config *c, rt_exp_job **out, rt_err *e);

/* The render options of a job: the config's, with its lighting, scheduled
 * size and proxy applied. */
rt_render_opts rt_exp_job_opts(const rt_exp_config *c, const rt_exp_job *jb);

/* ---- lights -------------------------------------------------------------- */

/* The one way a set of lights is printed, on every command, table,
 * heading and progress line: the enabled-light mask (bit i = light i, as
 * the database's lights column stores it) as names: "none" (mask 0, only
 * primary rays), "all" (every light, RT_NLIGHTS of them), else the
 * indices joined by '+', "0", "0+2". --lights reads these names (and the
 * older "0,2"). Writes at most n bytes; returns buf. */
const char *rt_exp_lights_name(unsigned mask, char *buf, size_t n);

/* ---- run identity ------------------------------------------------------ */

#define RT_EXP_PARAMS 512 /* = sizeof(rt_tr_meta.params) */

/* The tracer parameter string of a run: "qorder=Q threads=N" (dynamic,
 * then " sim=all-sizes" if all_sizes), "packet=N" (packet), "" (others),
 * then " subsample=K tile=T" when subsampled. The one formatter of that
 * string for database keys (the trace header's copy, rt_job_meta, writes
 * the same for all_sizes = 0; the tests compare them). Writes at most n
 * bytes (NUL included) and returns buf. */
const char *rt_exp_tracer_params(const char *tracer, const rt_render_opts *ro, int all_sizes, char *buf, size_t n);

/* A run key with the storage its strings point into. */
typedef struct rt_exp_key {
    rt_db_run run;             /* identity (provenance fields zero) */
    char params[RT_EXP_PARAMS]; /* run.params points here */
    char sim_params[160];      /* run.sim_params points here */
    char exact_sim_params[160]; /* the exact run's sim_params (kept when the key switches method) */
    char scene[300];           /* run.scene points here (din keys) */
    char abspath[4096];        /* run.scene_abspath points here (mesh and din files) */
    char hierarchy[1024];      /* run.hierarchy points here (the canonical spec) */
} rt_exp_key;

/* The key of an in-process job of scene sc (whose rt_scene_hash is
 * scene_hash), exact method; sim_params from rt_exp_sim_params (the
 * model and a non-default accounting). A mesh scene (a .obj/.ply spec) also records
 * its path as given and its absolute path (realpath; '' if it fails). A dynamic job simulated at every size carries
 * " sim=all-sizes" in its params. */
void rt_exp_job_key(const rt_exp_config *c, const rt_exp_job *jb, const rt_scene *sc, uint64_t scene_hash,
                    rt_exp_key *k);
/* Switches k to an approximate method (ac->method != RT_APPROX_EXACT for
 * an approximate run; RT_APPROX_EXACT gives the exact key back). sim_params
 * is rt_approx_params, then " errors=1" when the run stores standard
 * errors (rt_approx_db_has_se: hybrid with ac->errors), so a run with
 * errors and one without (or one stored before errors were stored) never
 * share a key. */
void rt_exp_key_method(rt_exp_key *k, const rt_approx_config *ac);
/* The key of a replayed .rtt trace, from its header; strings point into m,
 * which must outlive r. Exact method. */
void rt_exp_run_from_meta(const rt_tr_meta *m, rt_db_run *r);
/* The key of a replayed din file: scene "din:BASENAME", tracer "din",
 * params "din_class=CLASS", scene hash = the file's content hash; the
 * file's path as given and absolute path recorded with the scene. */
void rt_exp_run_from_din(const char *path, int din_class, uint64_t file_hash, rt_exp_key *k);

/* ---- running jobs ------------------------------------------------------ */

/* The texture cache of Purcell et al. 2002 that every job of the stream
 * and feedback tracers also simulates: 1365 direct-mapped lines of 48
 * bytes (64 KB). */
#define RT_EXP_TEXCACHE_LINE 48
#define RT_EXP_TEXCACHE_SIZE (1365 * RT_EXP_TEXCACHE_LINE)

/* A worker runs jobs one after the other into one database, keeping the
 * current scene and its k-d tree between jobs of the same scene. */
typedef struct rt_exp_worker rt_exp_worker;

/* c and db are borrowed and must outlive the worker. NULL on out of memory. */
rt_exp_worker *rt_exp_worker_new(const rt_exp_config *c, rt_db *db, rt_err *e);
void rt_exp_worker_free(rt_exp_worker *w); /* NULL is fine; frees scene and tree, not db */
/* Before a pool forks: when every job of J[0..nj) is of one scene, loads
 * it into w (a worker made with db NULL) and, when a job runs on the k-d
 * tree, builds the tree, so that forked workers share both (pages nobody
 * writes stay shared) instead of each building its own. 1 preloaded, 0
 * nothing to share (several scenes), -1 with e. */
int rt_exp_worker_preload(rt_exp_worker *w, const rt_exp_job *J, long nj, rt_err *e);
/* Gives a worker made before a fork its database connection. */
void rt_exp_worker_set_db(rt_exp_worker *w, rt_db *db);

/* Where a worker's time went, summed over the jobs it ran (skipped jobs
 * count their database lookups only). */
typedef struct rt_exp_stages {
    double scene;      /* scene load and k-d tree build */
    double tracing;    /* rendering, less the time inside the simulators (a kept trace's writing counts here) */
    double simulation; /* exact and approximate simulators, their flush and finish */
    double database;   /* lookups of stored runs and the stores */
} rt_exp_stages;

/* The worker's stage times so far. */
void rt_exp_worker_stages(const rt_exp_worker *w, rt_exp_stages *out);

/* Runs job jb (index is its place in the matrix, used to name a kept
 * trace): skips it if its exact run and every approximate run are already
 * stored; otherwise renders it in-process streaming into the exact
 * simulator (at every size, or at the scheduled size alone for a dynamic
 * job without dyn_all), for the stream and feedback tracers also the
 * texture cache (RT_EXP_TEXCACHE_*; its rows are stored with the exact
 * run's), the approximate simulators (only for jobs simulated
 * at every size, never for proxies) and, with c->keep, a trace file
 * KEEP/jobNNNN-SCENE-LIGHT-TRACER[-SIZE][-proxy].rtt (SCENE longer than 160
 * bytes cut and ended by ~HASH, rt_name_fit), then stores the exact
 * run and each approximate run (with its standard errors when it
 * estimated them, rt_approx_db_se_rows; its wall_time is the seconds
 * spent in its estimator, puts and rt_approx_finish, which include the
 * cost of the errors), each in its own transaction; the exact
 * simulator is finished first (rt_sim_finish: with cfg.flush the dirty
 * lines are written back and counted). Returns 1 if
 * run and stored, 0 if skipped, -1 on error (a failed store leaves no row
 * of that run; runs stored before it stay). */
int rt_exp_run_job(rt_exp_worker *w, const rt_exp_job *jb, long index, rt_err *e);

#endif
