/*
 * tracer.h -- the one interface every tracing algorithm implements.
 *
 * A tracer is given a scene, its k-d tree and render options. It first
 * declares the modeled memory regions it will touch (layout), then renders
 * (run): it produces an image (RGB, cost channels, depth) and, when a
 * recorder is attached, reports every memory access in program order.
 * With the same inputs every tracer must find the same closest hit per
 * pixel and the same shadow visibility per pixel and light, so RGB images
 * are bit-identical across tracers; only cost channels and traces differ.
 *
 * Shading (shared by all tracers, in this exact operation order so results
 * are bit-identical): c = albedo * ambient; for each enabled light i in
 * increasing order, if visible: c += albedo * (max(0, n.l) * light_power);
 * n is the geometric normal facing the eye ray, l the unit vector to the
 * light. With no light enabled (primary rays only) a headlight stands in
 * so the image still shows shape: c = albedo * (ambient + |n.d| *
 * light_power), d the unit eye direction. Rays that miss get the scene
 * background.
 */
#ifndef RT_TRACER_H
#define RT_TRACER_H

#include "image.h"
#include "kdtrav.h"
#include "memmodel.h"
#include "scene.h"

typedef enum rt_qorder {
    RT_QORDER_FULLEST = 0, /* dynamic: process the fullest queue next */
    RT_QORDER_TREE = 1     /* dynamic: queue points in tree (depth-first) order */
} rt_qorder;

typedef struct rt_render_opts {
    int W, H;            /* image size */
    unsigned lights;     /* bit i set: light i enabled */
    int packet;          /* packet edge in pixels (packet tracer), 8 */
    uint64_t cache_size; /* dynamic: cache size the schedule targets (bytes) */
    uint64_t gmax;       /* dynamic: explicit geometry budget, 0 = derive */
    int qorder;          /* dynamic: rt_qorder */
    int threads;         /* dynamic: modeled threads (ray buffer = 2 rays each) */
    uint32_t subsample;  /* reduced experiment: trace 1 in K tiles (1 = all) */
    int subtile;         /* subsampling tile edge in pixels (default 8) */
} rt_render_opts;

void rt_render_default_opts(rt_render_opts *o);

/*
 * Pixel subsampling, a reduced experiment: the image is cut into square
 * tiles of o->subtile pixels and a tile is traced iff a fixed hash of its
 * coordinates is 0 mod o->subsample, so about 1/K of the tiles are traced,
 * the same ones on every machine and for every tracer. Tiles keep the
 * locality of neighbouring rays (a tile of 8 is one packet, and two rays
 * per ray-record line); tile 1 samples single pixels. Untraced pixels
 * keep the image's initial zeros and are never referenced, so their ray
 * records and framebuffer lines never enter the cache. Traffic of the
 * full image is estimated as traffic x (pixels / traced pixels).
 */
int rt_pixel_kept(const rt_render_opts *o, int x, int y);
/* Writes the traced pixels (y * W + x) in Hilbert-curve order to order[]
 * (room for W * H) and returns how many there are. */
size_t rt_pixel_order(const rt_render_opts *o, uint32_t *order);
/* Checks subsample/subtile against the tracer (packet tiles must hold
 * whole packets). */
/* Appends " subsample=K tile=T" (nothing when K = 1) for run parameters. */
void rt_subsample_params(const rt_render_opts *o, char *buf, size_t n);
int rt_check_subsample(const rt_render_opts *o, const char *tracer, rt_err *e);



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
    rt_layout *L;   /* filled by layout(), read by run() */
    rt_rec *rec;    /* NULL: not recording */
} rt_tracer_ctx;

typedef struct rt_tracer {
    const char *name;  /* "recursive", "packet", "dynamic" */
    const char *desc;  /* one line */
    /* Declares the regions this run touches (in a fixed order). 0 or -1. */
    int (*layout)(const rt_tracer_ctx *ctx, rt_layout *L, rt_err *e);
    /* Renders into img (allocated by the caller at opt->W x opt->H). */
    int (*run)(const rt_tracer_ctx *ctx, rt_image *img, rt_run_stats *st, rt_err *e);
} rt_tracer;

/* Registered tracers, NULL-terminated, and lookup by name (NULL if none). */
extern const rt_tracer *const rt_tracers[];
const rt_tracer *rt_tracer_find(const char *name);

/* Parses "all", "none", or a comma list of light indices "0,2". */
int rt_parse_lights(const char *s, unsigned *mask);

/* Adds the geometry regions, in this order: kd.nodes (8 B x nodes),
 * kd.index (4 B x entries), tri.verts (36 B x triangles) and, when
 * want_shade, tri.shade (16 B x triangles). Look them up with rt_mm_find. */
int rt_layout_geometry(const rt_tracer_ctx *ctx, rt_layout *L, int want_shade, rt_err *e);

/* Shades one primary hit exactly as documented above. vis[i] != 0 when light
 * i is enabled and visible. Writes rgb[3]. */
void rt_shade_hit(const rt_scene *sc, const rt_ray *eye, const rt_hit *h, const int vis[RT_NLIGHTS],
                  unsigned lights, float rgb[3]);

/* Pinhole camera basis, computed once per render (deterministic: no libm
 * trigonometry). */
typedef struct rt_cam_frame {
    rt_vec3 eye, dir, right, up; /* dir/right/up scaled to the image plane */
    int W, H;
} rt_cam_frame;
void rt_cam_setup(rt_cam_frame *f, const rt_scene *sc, int W, int H);
/* Primary ray through the centre of pixel (x, y), y down. */
void rt_camera_ray(const rt_cam_frame *f, int x, int y, rt_ray *r);

/* Initialises a traversal context for ctx (region indices looked up in
 * ctx->L when recording). */
void rt_trav_init(rt_trav *tv, const rt_tracer_ctx *ctx);

/* Deterministic double-precision tangent for |x| < pi/2 (series; no libm). */
double rt_dtan(double x);

/* Shadow ray from a primary hit toward light i: origin offset off the
 * surface toward the eye side, direction = light - origin, interval
 * (0, 1). Returns 0 when the light is behind the surface (no ray needed:
 * not lit), else 1. */
int rt_shadow_ray(const rt_scene *sc, const rt_ray *eye, const rt_hit *h, int light, rt_ray *sr);

#endif
