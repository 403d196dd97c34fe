/*
 * tracer.h -- the one interface every tracing algorithm implements (prefix
 * rt_tracer_).
 *
 * A tracer is given a scene, the acceleration structure it runs on
 * (accel.h; built by the job, the one its traits ask for) and render
 * options. It may first compute a plan that depends only on those (the
 * dynamic scheduler's queue points), then declares the modeled memory regions it will touch (layout),
 * then renders (run): it produces an image (RGB, cost channels, depth) and,
 * when a recorder is attached, reports every memory access in program
 * order. With the same inputs every tracer must find the same closest hit
 * per pixel and the same shadow visibility per pixel and light, so RGB
 * images are bit-identical across tracers; only cost channels and traces
 * differ.
 *
 * Adding a tracer:
 *   1. write tracegen/NAME.c defining `const rt_tracer rt_tracer_NAME` with
 *      designated initialisers: its traits (.modes, .accels and
 *      .accel_default, .opts, .traits, .figures) and, if it has knobs of
 *      its own, .check_opts and .params; keep everything else static;
 *   2. layout(): call rt_reg_geometry first (regions.h: the tree and
 *      triangles keep their addresses across tracers), then add your own
 *      regions with rt_mm_add, in a fixed order;
 *   3. run(): trace the pixels rt_pixel_order (pixels.h) returns, rays from
 *      rt_cam_ray (camera.h), shadow rays from rt_shade_ray, pixels written
 *      with rt_shade_pixel (shade.h); in the whitted and path modes every
 *      ray goes through rt_shade_step and pixels are summed in an rt_acc
 *      (shade.h), so the order rays are traced in does not matter; record every access with RT_REC
 *      (memmodel.h) into a region of your layout; count node visits and
 *      triangle tests in an rt_trav set up by rt_reg_trav and finish the
 *      statistics with rt_stats_finish (stats.h); put tracer-specific
 *      numbers in st->extra as "k=v k=v" (unique keys, one-word values:
 *      the form stats.h states; meanings go in docs/tracers.md);
 *   4. plan()/plan_free() only if something costly depends on the tree and
 *      options alone: the job computes it once and hands it to layout and
 *      run as ctx->plan;
 *   5. list it in rt_tracer_all (tracer.c) and tracegen/local.am, run
 *      `RT_REDO_GOLDEN=1 make check TESTS=tests/test_conform` once for its
 *      record-stream golden hashes (the conformance test covers every
 *      registered tracer, mode and structure by itself), and describe it
 *      in docs/tracers.md.
 * Nothing outside this file and tracegen/NAME.c compares a tracer's name:
 * what a tracer is, the rest of the toolkit learns from its traits.
 * Library rule: return -1 with rt_errf(e, ...) on failure; never print.
 */
#ifndef RT_TRACER_H
#define RT_TRACER_H

#include "camera.h" /* rt_dtan for the front end's tests */
#include "image.h"
#include "accel.h"
#include "kdtrav.h"
#include "memmodel.h"
#include "mesh.h"
#include "options.h"
#include "pixels.h"
#include "scene.h"

typedef struct rt_run_stats {
    uint64_t rays_primary;   /* primary rays traced */
    uint64_t rays_shadow;    /* shadow rays traced */
    uint64_t nodes;          /* node visits, all rays */
    uint64_t tests;          /* triangle tests, all rays */
    uint64_t pv_primary;     /* distinct triangles tested by primary rays */
    uint64_t pv_all;         /* distinct triangles tested by any ray */
    uint64_t accesses;       /* memory accesses recorded (0 if not recording) */
    double seconds;          /* wall time of run() */
    uint8_t *mark_keep;      /* set by the job for one host thread's share: rt_stats_finish copies the
                              * run's triangle marks there (ntri bytes), so the job can count the
                              * potentially visible sets of the whole image; NULL otherwise */
    char extra[512];         /* tracer-specific statistics, "k=v k=v" */
} rt_run_stats;

typedef struct rt_tracer_ctx {
    const rt_scene *sc;
    const rt_accel *acc; /* the structure the run traces through (accel.h) */
    const rt_kdtree *kd; /* acc's k-d tree when it is one, else NULL */
    const rt_render_opts *opt;
    rt_layout *L;      /* filled by layout(), read by run() */
    rt_rec *rec;       /* NULL: not recording */
    const void *plan;  /* the tracer's plan (NULL before plan() or without one) */
    int check;         /* test mode: verify the tracer's invariants as it runs */
    const rt_mesh *mesh; /* vertex index of the mesh layout (NULL in the compact one) */
    /* The work share this run traces: part `part` of `nparts` (0 or 1 parts:
     * all the work, today's order). Only tracers with the RT_OPTG_THREADS
     * group read it, through rt_pixel_order_part (recursive, treelet) or
     * rt_pixel_packet_part (packet); see "Work shares" in pixels.h. */
    int part, nparts;
    /* Tracers with RT_TR_CORES on opt->cores > 1 simulated cores, traced:
     * the core sink their cores' references go to, interleaved by the
     * tracer in the modeled clock's ticks (run.h); rec is NULL then. NULL
     * otherwise. */
    rt_csink *cs;
    /* Simulated cores of a tracer that splits its own work (RT_TR_CORE_PHASES;
     * cores.h): set by the job when it runs on rt_job_run_cores, or
     * untraced with --cores N > 1; the tracer then records core k's work
     * into rt_cores_rec(cores, k) and ends each phase with a barrier.
     * NULL: one core, rec as above (today's run). */
    struct rt_cores *cores;
} rt_tracer_ctx;

/* Traits (rt_tracer.traits). */
enum {
    RT_TR_SCHEDULED = 1u << 0, /* scheduled for a cache size (sched_size): a sweep runs it once per size */
    RT_TR_TEXCACHE = 1u << 1,  /* its jobs also simulate Purcell et al.'s texture cache */
    RT_TR_QUEUES = 1u << 2,    /* keeps ray queues in memory (--queue-stores applies) */
    RT_TR_REFERENCE = 1u << 3, /* the reference tracer other tracers' images are compared with */
    RT_TR_MULTIPASS = 1u << 4, /* Purcell et al.'s multipass architecture (stencil passes) */
    RT_TR_LIGHTS = 1u << 5,    /* traces the authored lights' samples (--light-samples; shade.h) */
    RT_TR_CORES = 1u << 6,     /* splits its own work over simulated cores in one run (ctx->cs,
                                * opt->cores; the dynamic scheduler's queues: run.h) */
    RT_TR_CORE_PHASES = 1u << 7 /* splits its own work over --cores N simulated cores in one run,
                                 * phase by phase through the shared stepping (ctx->cores, cores.h) */
};
/* Report figures a tracer appears in (rt_tracer.figures), in registry order. */
enum {
    RT_FIG_NAVRATIL = 1u << 0, /* the paper's Figures 4-9: baseline, packet and scheduled columns */
    RT_FIG_PURCELL = 1u << 1,  /* report --figure purcell */
    RT_FIG_FEEDBACK = 1u << 2, /* report --figure feedback: the designs compared */
    RT_FIG_TREELET = 1u << 3   /* report --figure treelet: the treelet schedulers */
};

typedef struct rt_tracer {
    const char *name;  /* "recursive", "packet", "dynamic", ... */
    const char *desc;  /* one line */
    unsigned modes;    /* bit m set: can run rt_mode m (RT_TRACER_ALL_MODES) */
    unsigned accels;   /* bit k set: runs on rt_accel_kind k (RT_ACCEL_BIT) */
    int accel_default; /* the structure it runs on without --accel */
    unsigned opts;     /* option groups it reads (RT_OPTG_*); others are refused */
    unsigned traits;   /* RT_TR_* */
    unsigned figures;  /* RT_FIG_* */
    /* Optional: refuses option values this tracer cannot run (beyond the
     * common checks). 0, or -1 naming the option in e. */
    int (*check_opts)(const rt_render_opts *o, rt_err *e);
    /* Optional: its part of the run key, only the parameters that shaped
     * the run ("packet=8", "qorder=fullest threads=4"); buf is "" on entry. */
    void (*params)(const rt_render_opts *o, char *buf, size_t n);
    /* Declares the regions this run touches (in a fixed order). 0 or -1. */
    int (*layout)(const rt_tracer_ctx *ctx, rt_layout *L, rt_err *e);
    /* Renders into img (allocated by the caller at opt->W x opt->H). 0 or -1. */
    int (*run)(const rt_tracer_ctx *ctx, rt_image *img, rt_run_stats *st, rt_err *e);
    /* Optional (NULL): computes *plan from the scene, tree and options
     * (ctx->plan is NULL then). 0, or -1 with *plan NULL. */
    int (*plan)(const rt_tracer_ctx *ctx, void **plan, rt_err *e);
    /* Frees a plan; accepts NULL. Required when plan is set. */
    void (*plan_free)(void *plan);
} rt_tracer;

#define RT_TRACER_ALL_MODES                                                                  \
    ((1u << RT_MODE_RAYCAST) | (1u << RT_MODE_SHADOW) | (1u << RT_MODE_WHITTED) | (1u << RT_MODE_PATH))
#define RT_TRACER_PRIMARY_MODES ((1u << RT_MODE_RAYCAST) | (1u << RT_MODE_SHADOW))

/* Registered tracers, NULL-terminated, and lookup by name (NULL if none). */
extern const rt_tracer *const rt_tracer_all[];
const rt_tracer *rt_tracer_find(const char *name);
/* The registered names, comma separated, for messages. */
const char *rt_tracer_names(void);
/* The reference tracer (RT_TR_REFERENCE). */
const rt_tracer *rt_tracer_reference(void);
/* 1 when tr has every trait in mask; a NULL tr has none. */
static inline int rt_tracer_is(const rt_tracer *tr, unsigned mask) { return tr && (tr->traits & mask) == mask; }
/* 1 when --cores N > 1 gives tr's work N simulated cores (a version-4
 * trace): the work-share tracers (RT_OPTG_THREADS) and those that split
 * their own work (RT_TR_CORE_PHASES). The dynamic tracer's --cores is its
 * modeled threads, one stream. */
static inline int rt_tracer_simulates_cores(const rt_tracer *tr)
{
    return tr && ((tr->opts & RT_OPTG_THREADS) || (tr->traits & RT_TR_CORE_PHASES));
}
/* The structure tr runs on under o (o->accel, or tr's default). */
static inline int rt_tracer_accel(const rt_tracer *tr, const rt_render_opts *o)
{
    return o->accel != RT_ACCEL_DEFAULT ? o->accel : tr->accel_default;
}
/* The options given (o->given) that tr does not read, and a structure it
 * cannot run on: -1 with "--X does not apply to the T tracer" in e. 0
 * when all apply. */
int rt_tracer_check_given(const rt_tracer *tr, const rt_render_opts *o, rt_err *e);
/* The option values tr can run: the subsampling check (pixels.h), the
 * structure (one of tr->accels) and tr->check_opts. 0, or -1 with e. */
int rt_tracer_check_opts(const rt_tracer *tr, const rt_render_opts *o, rt_err *e);
/* The same over a set of tracers (a sweep): an option applies when one of
 * them reads it. ntr > 0. */
int rt_tracer_check_given_any(const rt_tracer *const *trs, int ntr, const rt_render_opts *o, rt_err *e);

#endif
