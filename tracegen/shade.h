/*
 * shade.h -- the shading rule and shadow rays every tracer shares (prefix
 * rt_shade_).
 *
 * Shading, in this exact operation order so results are bit-identical:
 * c = albedo * ambient; for each enabled light i in increasing order, if
 * visible: c += albedo * (max(0, n.l) * light_power); n is the geometric
 * normal facing the eye ray, l the unit vector to the light. With no light
 * enabled (primary rays only) a headlight stands in so the image still
 * shows shape: c = albedo * (ambient + |n.d| * light_power), d the unit eye
 * direction. Rays that miss get the scene background.
 *
 * Tracers differ only in the order they trace rays: each finds a pixel's
 * closest hit and per-light visibility and hands them to rt_shade_pixel.
 *
 * Secondary modes (whitted, path; docs/tracers.md "Modes"). Every ray of a
 * Whitted tree or a path is an rt_path: the ray, its throughput, pixel,
 * sample and generation, and the stack of dielectric media it travels in.
 * rt_shade_step turns one such ray and its closest hit (or miss) into an
 * rt_shade_out: a contribution that needs no visibility (ambient, emission,
 * background), one shadow ray per enabled light with the contribution it
 * adds when unoccluded, and zero to two children for the next generation.
 * The step is a pure function of (scene, options, ray, hit), and random
 * numbers come from a hash of (pixel, sample, bounce, dimension), so a
 * tracer may trace the rays in any order. Contributions are summed in
 * 32.32 fixed point (rt_acc): integer addition is associative, so the sum
 * and hence the image is bit-identical whatever order a tracer adds them.
 */
#ifndef RT_SHADE_H
#define RT_SHADE_H

#include "image.h"
#include "kdtrav.h"
#include "options.h"
#include "scene.h"

/* Shades one primary hit exactly as documented above. vis[i] != 0 when light
 * i is enabled and visible. Writes rgb[3]. */
void rt_shade_hit(const rt_scene *sc, const rt_ray *eye, const rt_hit *h, const int vis[RT_NLIGHTS],
                  unsigned lights, float rgb[3]);

/* Writes pixel pix of img (RGB and depth; not the cost channels): the
 * shaded hit h of the eye ray, or the background when h is NULL. */
void rt_shade_pixel(const rt_scene *sc, const rt_ray *eye, const rt_hit *h, const int vis[RT_NLIGHTS],
                    unsigned lights, rt_image *img, size_t pix);

/* Shadow ray from a primary hit toward light i: origin offset off the
 * surface toward the eye side, direction = light - origin, interval
 * (0, 1). Returns 0 when the light is behind the surface (no ray needed:
 * not lit), else 1. */
int rt_shade_ray(const rt_scene *sc, const rt_ray *eye, const rt_hit *h, int light, rt_ray *sr);

/* ---- lights as authored (--light-samples N; docs/scenes.md "Lights") ------
 *
 * With o->light_samples = N > 0 and a scene that has authored lights
 * (rt_shade_authored), the lights are the scene's lights[] and a hit casts,
 * per enabled light i, rt_shade_light_nsamples shadow rays: 1 to a point
 * light (the ray of rt_shade_ray), 1 along a distant light's direction, and
 * N to an area light (to points sampled on the emitter: a mesh triangle
 * picked by area, then a uniform point on it; a uniform point on the
 * visible cap of a sphere; a uniform point on a disk) or to the sky of an
 * infinite light (cosine-distributed directions about the normal). Sample
 * k of light i at a hit is a pure function of (hit triangle, barycentrics,
 * i, k): a hash, not a counter, so every tracer draws the same points in
 * any order and the images agree bit for bit. A sample adds its weight
 * w = max(0, n.l) (1 for the sky) when unoccluded, and the hit is shaded
 * c = albedo * ambient + sum over lights in order of
 *     albedo * ((W_i / n_i) * (light_power * scale_i)),
 * W_i the sum of the weights of light i's unoccluded samples, n_i its
 * sample count: with point lights alone this is the rule above. Emitters
 * are two-sided (no cosine at the emitter) and every light has the power
 * of a point light; the study counts rays, the shading only shows them. */

/* 1 when the run uses the authored lights (o->light_samples > 0 and the
 * scene has authored lights). */
int rt_shade_authored(const rt_scene *sc, const rt_render_opts *o);
/* Shadow rays per hit to authored light i (1 or o->light_samples). */
uint32_t rt_shade_light_nsamples(const rt_scene *sc, const rt_render_opts *o, uint32_t i);
/* Sample k of authored light i at the primary hit h of eye: the shadow
 * ray (origin offset as rt_shade_ray's; to a point: interval (0, 1) to
 * it, or (0, 0.999) when the point lies on an emitter, so the emitter does
 * not shadow itself; to the sky or a distant light: a segment reaching
 * past the scene's bounds), its weight *w, and *tri the emitter triangle
 * sampled (mesh lights; else RT_NO_HIT). 0 when no ray is needed (the
 * sample lies behind the surface, or the hit is inside a sphere light). */
int rt_shade_sample_ray(const rt_scene *sc, const rt_render_opts *o, const rt_ray *eye, const rt_hit *h, uint32_t i,
                        uint32_t k, rt_ray *sr, float *w, uint32_t *tri);
/* Shades and writes pixel pix from lw[i], the summed weights of light i's
 * unoccluded samples (lights not enabled: ignored); h NULL for a miss. */
void rt_shade_pixel_lw(const rt_scene *sc, const rt_render_opts *o, const rt_ray *eye, const rt_hit *h,
                       const float *lw, rt_image *img, size_t pix);

/* ---- secondary modes ------------------------------------------------------ */

#define RT_PATH_MEDIA 4 /* nesting depth of dielectrics a ray remembers */

/* One ray of a Whitted tree or a path. Modeled as the 64-byte record of
 * docs/memory-model.md ("secondary ray records"). */
typedef struct rt_path {
    rt_vec3 o, d;       /* origin (offset off the surface) and direction */
    float w[3];         /* throughput: weight of everything this ray brings back */
    uint32_t pix;       /* pixel */
    uint32_t sample;    /* path sample (0 in whitted mode) */
    uint16_t depth;     /* generation: 0 for the primary ray */
    uint8_t nmed;       /* entries of med[] in use (the innermost last) */
    uint8_t kind;       /* RT_PATH_REFRACT for a refracted ray, else 0 */
    uint16_t med[RT_PATH_MEDIA]; /* materials of the dielectrics the ray is inside */
    uint32_t from_tri;  /* triangle it left (RT_NO_HIT for primary rays) */
} rt_path;

#define RT_PATH_REFRACT 1
/* Bytes of a secondary ray record in the modeled memory (docs/memory-model.md). */
#define RT_SREC_SIZE 64

/* What one ray's hit or miss produces. */
typedef struct rt_shade_out {
    float c[3];                      /* contribution needing no visibility */
    uint8_t want[RT_NLIGHTS];        /* shadow ray i to trace */
    rt_ray sray[RT_NLIGHTS];         /* shadow rays, interval (0, 1) */
    float lc[RT_NLIGHTS][3];         /* added when shadow ray i is unoccluded */
    int nchild;                      /* children in child[] (0..2: reflection first) */
    rt_path child[2];
    int self_hit;                    /* the ray hit the triangle it left (never expected) */
} rt_shade_out;

/* The primary ray of pixel pix, sample s: throughput 1, generation 0. */
void rt_shade_path_start(rt_path *p, const rt_ray *eye, uint32_t pix, uint32_t sample);
/* The traceable ray of p (rt_ray_init of its origin and direction). */
void rt_shade_path_ray(const rt_path *p, rt_ray *r);
/* The step documented above for mode o->mode (RT_MODE_WHITTED or
 * RT_MODE_PATH); h NULL or h->tri == RT_NO_HIT for a miss. */
void rt_shade_step(const rt_scene *sc, const rt_render_opts *o, const rt_path *p, const rt_ray *r, const rt_hit *h,
                   rt_shade_out *out);
/* The path sampler: uniform float in [0, 1) from a hash of the counters. */
float rt_shade_rand(uint32_t pix, uint32_t sample, uint32_t bounce, uint32_t dim);

/* Order-independent pixel accumulator: 32.32 fixed point per channel
 * (resolution 2^-32, saturating at +-2^30; NaN adds 0). */
typedef struct rt_acc {
    int64_t v[3];
} rt_acc;
void rt_acc_add(rt_acc *a, const float c[3]);
/* Writes acc / spp as the pixel's RGB and depth (the primary hit's distance
 * along eye, INFINITY when h is NULL). */
void rt_acc_pixel(const rt_acc *a, int spp, const rt_ray *eye, const rt_hit *h, rt_image *img, size_t pix);

/* pbrt-v3's robust origin (Pharr, Jakob, Humphreys, 3rd ed., 3.9): the
 * point at barycentrics (u, v) of tri, with its rounding-error bound
 * pbrt-style, offset along n (unit) by |n|.err and rounded one more ULP away
 * from the surface, to the side of n when side > 0, else the other side. */
rt_vec3 rt_shade_offset(const rt_tri *tri, float u, float v, rt_vec3 n, int side);

#endif
