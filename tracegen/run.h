/*
 * run.h -- one rendering job: scene + tree + tracer + options, traced or not.
 *
 * Used by `render`, `trace`, `bench` and `sweep` so that they all set up a
 * run the same way: load the scene from its spec, build the acceleration
 * structure the tracer runs on (only that one: accel.h), check
 * the options (a run that would trace no pixel is refused), let the tracer
 * compute its plan (once per job: the dynamic scheduler's queue points for
 * this tree and budget) and declare its regions, then run with or without a
 * sink.
 */
#ifndef RT_RUN_H
#define RT_RUN_H

#include "kdtree.h"
#include "scene.h"
#include "trace.h"
#include "tracer.h"

typedef struct rt_job {
    rt_scene *sc;          /* owned unless borrowed */
    rt_accel acc;          /* the structure the tracer runs on (owned unless acc_borrowed) */
    const rt_tracer *tr;   /* static */
    rt_render_opts opt;    /* copy of the options, opt.accel resolved to acc.kind */
    rt_layout L;           /* regions declared by the tracer */
    int borrowed;          /* the scene belongs to the caller */
    int acc_borrowed;      /* acc wraps the caller's k-d tree */
    void *plan;            /* the tracer's plan for this tree and options (owned), or NULL */
    int check;             /* test mode: set before rt_job_run to have the tracer verify its
                            * invariants at every step (slow; an error names the one broken) */
    rt_mesh *mesh;         /* vertex index for the mesh layout (owned), NULL in the compact one */
} rt_job;

/* Loads the scene, builds the tree and the layout. 0 or -1 (job freed). */
int rt_job_setup(rt_job *j, const char *scene_spec, const char *tracer, const rt_render_opts *o, rt_err *e);
/* Reuses an already loaded scene (with the options' view already applied:
 * rt_render_apply_view) and, when the tracer runs on a k-d tree,
 * the caller's tree kd (NULL: built here). Ownership of sc and kd stays
 * with the caller; any other structure is built and owned by the job. */
int rt_job_setup_borrowed(rt_job *j, rt_scene *sc, rt_kdtree *kd, const char *tracer, const rt_render_opts *o,
                          rt_err *e);
/* Renders into img (W x H); sink NULL = untraced. Fills st. 0 or -1.
 * opt.host_threads > 1 (untraced only): the work shares on that many host
 * threads, images and statistics those of one thread. opt.cores > 1 with a
 * sink: the simulated cores' references interleaved as rt_job_run_cores
 * orders them, without their core ids. */
int rt_job_run(rt_job *j, rt_sink *sink, rt_image *img, rt_run_stats *st, rt_err *e);
/*
 * Simulated cores (opt.cores = N > 1, tracers of RT_OPTG_THREADS): core k
 * runs work share k of N (pixels.h: Hilbert share tiles or packets dealt
 * round-robin), recording on its own host thread into a bounded queue,
 * and the calling thread hands the references to cs in the order of the
 * modeled clock:
 *
 *   A TICK is RT_CORE_TICK references of every core that has work left:
 *   in each tick core 0 issues its next RT_CORE_TICK references (fewer at
 *   its end), then core 1, ..., then core N-1. A finished core drops out.
 *
 * Each core has its own copy of the run's scratch regions -- every region
 * but the geometry group's and the per-pixel "rays.primary" and "fb"
 * (queues, stacks, ray-window slots, packet hits: what one core's tracer
 * keeps for itself): core k's references into them are moved up by k
 * times the layout's span (rt_layout.next - RT_MM_BASE, rounded to 4 KiB),
 * so two cores never share a scratch line; geometry is shared read-only
 * and a pixel's records are its core's (lines at share-tile edges are
 * really shared). rt_job_run_part moves them the same way.
 *
 * The order depends only on each core's own reference stream, never on
 * host timing, so it is the same on every machine; N = 1 is the one-core
 * run (rt_job_run). A trace of it costs one 2-byte core switch per
 * RT_CORE_TICK references (0.125 B/reference before compression).
 * Statistics are summed as for host threads. A tracer with RT_TR_CORES
 * (the dynamic scheduler: its queues dealt to the cores in rounds,
 * dynamic.c) is instead run once on the calling thread with cs in its
 * context and interleaves its cores by the same tick itself. A tracer
 * with RT_TR_CORE_PHASES (treelet, the stream tracers, feedback) is run
 * once on the calling thread with ctx.cores (cores.h): a recorder per core
 * (the mesh layout's translator in front), the same tick applied phase by
 * phase between the tracer's barriers; for it N = 1 runs that way too and
 * is the one-core run reference for reference, and rt_job_run untraced
 * with N > 1 runs its N-core algorithm without recording. 0 or -1.
 */
#define RT_CORE_TICK 16
int rt_job_run_cores(rt_job *j, rt_csink *cs, rt_image *img, rt_run_stats *st, rt_err *e);
/* Work share part of nparts alone, on the calling thread, into sink (NULL:
 * untraced): one core's references as rt_job_run_cores sees them (the
 * tests' reference for the interleave). 0 or -1. */
int rt_job_run_part(rt_job *j, rt_sink *sink, int part, int nparts, rt_image *img, rt_run_stats *st, rt_err *e);
/* The tracer-parameter string that identifies a run ("qorder=fullest
 * threads=4", "packet=8", "" ...; then the subsampling parameters), the
 * one formatter for trace headers and database keys. extra, if non-empty,
 * is inserted before the subsampling parameters (sweep: "sim=all-sizes").
 * Returns buf. */
const char *rt_job_params(const char *tracer, const rt_render_opts *o, const char *extra, char *buf, size_t n);
/* Fills trace metadata from the job (command line from rt_cmd_line()). */
void rt_job_meta(const rt_job *j, const char *command, rt_tr_meta *m);
/* The highest ray generation the job can stamp on a reference (0: primary
 * and shadow rays only); rt_job_meta's generations, without hashing the scene. */
uint32_t rt_job_generations(const rt_job *j);
/* Frees what the job owns (not a borrowed scene and tree); accepts NULL. */
void rt_job_free(rt_job *j);
/* The job's k-d tree, or NULL when it runs on another structure. */
static inline rt_kdtree *rt_job_kd(const rt_job *j) { return j->acc.kind == RT_ACCEL_KD ? (rt_kdtree *)j->acc.as : NULL; }

#endif
