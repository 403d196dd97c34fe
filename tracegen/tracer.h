/*
 * tracer.h -- the one interface every tracing algorithm implements (prefix
 * rt_tracer_).
 *
 * A tracer is given a scene, its k-d tree and render options. It may first
 * compute a plan that depends only on those (the dynamic scheduler's queue
 * points), then declares the modeled memory regions it will touch (layout),
 * then renders (run): it produces an image (RGB, cost channels, depth) and,
 * when a recorder is attached, reports every memory access in program
 * order. With the same inputs every tracer must find the same closest hit
 * per pixel and the same shadow visibility per pixel and light, so RGB
 * images are bit-identical across tracers; only cost channels and traces
 * differ.
 *
 * Adding a tracer:
 *   1. write tracegen/NAME.c defining `const rt_tracer rt_tracer_NAME` with
 *      designated initialisers (.modes lists the rt_mode values it runs);
 *      keep everything else in the file static;
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
 *      numbers in st->extra as "k=v k=v";
 *   4. plan()/plan_free() only if something costly depends on the tree and
 *      options alone: the job computes it once and hands it to layout and
 *      run as ctx->plan;
 *   5. list it in rt_tracer_all (tracer.c), add it to tracegen/local.am and
 *      to tests/test_tracers.c (same images, traffic counts, golden file),
 *      and describe it in docs/tracers.md.
 * Library rule: return -1 with rt_errf(e, ...) on failure; never print.
 */
#ifndef RT_TRACER_H
#define RT_TRACER_H

#include "camera.h" /* rt_dtan for the front end's tests */
#include "image.h"
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
    char extra[512];         /* tracer-specific statistics, "k=v k=v" */
} rt_run_stats;

typedef struct rt_tracer_ctx {
    const rt_scene *sc;
    const rt_kdtree *kd;
    const rt_render_opts *opt;
    rt_layout *L;      /* filled by layout(), read by run() */
    rt_rec *rec;       /* NULL: not recording */
    const void *plan;  /* the tracer's plan (NULL before plan() or without one) */
    int check;         /* test mode: verify the tracer's invariants as it runs */
    const rt_mesh *mesh; /* vertex index of the mesh layout (NULL in the compact one) */
} rt_tracer_ctx;

typedef struct rt_tracer {
    const char *name;  /* "recursive", "packet", "dynamic" */
    const char *desc;  /* one line */
    unsigned modes;    /* bit m set: can run rt_mode m (RT_TRACER_ALL_MODES) */
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

#endif
