/*
 * feedback.h -- the feedback tracer of Ralovich and Magdics (2009):
 * rays as point primitives in two ping-pong vertex buffers, one ray
 * generation per pass, colour composited by blending (prefix rt_fb_).
 *
 * A ray lives in the vertex buffer as the paper's 64-byte PackedHit
 * (Listing 2): four 4-float vectors. Lanes holding integers carry their
 * bits (GLSL floatBitsToUint), not a converted value:
 *
 *   pos.x       pixel index y*W + x (bits): rasterisation puts the point
 *               at that pixel's centre, so the position needs no more
 *   pos.yzw     eye/reflected/refracted rays: the throughput w (RGB, the
 *               paper's premultiplied rho); shadow rays: the RGB the
 *               fragment stage blends when the ray's outcome calls for it
 *   orig_t      ray origin xyz; w: tmax before the vertex stage (INF, or 1
 *               for shadow rays), the hit's t after it
 *   dir_idx     direction xyz (not normalised); w: hit triangle (bits),
 *               RT_NO_HIT when none (yet)
 *   uv_state    x, y: barycentrics of the hit (shadow rays: x = the light
 *               index, bits); z: state word (bits 0-1 state, 2-3 type,
 *               4-10 generation, 11-13 dielectrics the ray is inside);
 *               w: those dielectrics' materials, 8 bits each, innermost in
 *               the highest used byte
 *
 * tmin is 0 for every ray and the sample is 0 (whitted mode), so a record
 * holds every input of the shared shading step (rt_shade_step) except the
 * triangle the ray left, which only the self-hit diagnostic needs. A
 * refracting scene with more than 256 materials cannot be packed and is
 * refused.
 */
#ifndef RT_FEEDBACK_H
#define RT_FEEDBACK_H

#include "tracer.h"

#include <stdint.h>

#define RT_FB_REC_SIZE 64
#define RT_FB_VB_DEFAULT (2ull << 30) /* default limit of one vertex buffer: 2 GiB */

typedef struct rt_fb_rec {
    float pos[4], orig_t[4], dir_idx[4], uv_state[4];
} rt_fb_rec;
_Static_assert(sizeof(rt_fb_rec) == RT_FB_REC_SIZE, "a PackedHit is 64 bytes");

enum { RT_FB_TRACE = 0, RT_FB_SHADE = 1, RT_FB_WRITTEN = 2 };              /* state */
enum { RT_FB_EYE = 0, RT_FB_SHADOW = 1, RT_FB_REFL = 2, RT_FB_REFR = 3 }; /* type */

/* A record unpacked. */
typedef struct rt_fb_ray {
    uint32_t pix;     /* pixel y*W + x */
    float w[3];       /* throughput, or a shadow ray's blend colour */
    rt_vec3 o, d;     /* origin, direction */
    float t;          /* tmax before intersection, hit t after */
    uint32_t tri;     /* hit triangle or RT_NO_HIT */
    float u, v;       /* barycentrics (eye and secondary rays) */
    uint32_t light;   /* shadow rays: the light */
    uint8_t state;    /* RT_FB_TRACE, _SHADE, _WRITTEN */
    uint8_t type;     /* RT_FB_EYE, _SHADOW, _REFL, _REFR */
    uint8_t gen;      /* generation: 0 eye rays (and their shadow rays) */
    uint8_t nmed;     /* entries of med in use (0..4) */
    uint8_t med[4];   /* dielectrics the ray is inside, innermost last */
} rt_fb_ray;

/* Packs r into the 64-byte record (layout above). */
void rt_fb_pack(const rt_fb_ray *r, rt_fb_rec *out);
/* Unpacks a record; rt_fb_unpack(rt_fb_pack(r)) == r field by field. */
void rt_fb_unpack(const rt_fb_rec *in, rt_fb_ray *r);

/*
 * Buffer size, the paper's S_VB = w x h x (G + G') x 64. E[k] is the
 * worst-case number of records emitted per pixel at recursion depth k:
 * E[0] = 1 eye ray; for 1 <= k < D, E[k] = L b^(k-1) + b^k (shadow rays of
 * the hits of generation k-1, secondary rays of generation k); E[D] = L
 * b^(D-1) (the last generation's shadow rays), where L is the number of
 * enabled lights, D the generations (1 in raycast and shadow modes,
 * --depth in whitted mode) and b the branching: 0 in raycast/shadow
 * modes, else 1 per kind of secondary ray the scene's materials spawn
 * (mirror, refraction). The output buffer of the pass that traces depth
 * k-1 holds those rays again (streamed through after shading, dropped in
 * the next pass) and the E[k] new ones, so E[k-1] + E[k] <= G + G' where
 * G and G' are the largest and second-largest E. Passes: one per depth
 * with rays to trace, depths 0..D-1 and D when lights are on.
 */
typedef struct rt_fb_sizes {
    int ndepth;                     /* depths with emitted rays: E[0..ndepth) */
    double E[RT_DEPTH_MAX + 1];     /* records per pixel emitted at each depth */
    double G, G2;                   /* largest and second-largest E */
    double svb;                     /* bytes per vertex buffer (double: may exceed 2^64) */
    uint64_t limit;                 /* the --vb-size limit in force (bytes) */
    int branching;                  /* b */
    int passes;                     /* passes the recursion needs */
} rt_fb_sizes;

/* Fills z for a run of options o on scene sc (its materials give the
 * branching). Returns 0, or -1 when S_VB exceeds the limit (o->vb_size,
 * or RT_FB_VB_DEFAULT when 0), with a message giving the size needed that
 * rt_fb_refused recognises. */
int rt_fb_size(const rt_scene *sc, const rt_render_opts *o, rt_fb_sizes *z, rt_err *e);
/* 1 when e holds the refusal of rt_fb_size: a usage error (the options
 * ask for more than the buffers may hold), not a failure of the run. */
int rt_fb_refused(const rt_err *e);

/* Heat map of the intersection cost (the paper's Figure 1d): per pixel,
 * log(1 + tests) / log(1 + 4 ntri) through a blue-green-yellow-red ramp,
 * so grid and naive runs of one scene share the scale. rgb has 3 W H
 * bytes. */
void rt_fb_heatmap(const rt_image *img, uint32_t ntri, unsigned char *rgb);

#endif
