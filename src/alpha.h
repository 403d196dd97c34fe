/*
 * alpha.h -- alpha textures and the any-hit cutout (prefix rt_alpha_).
 *
 * A pbrt shape may name a float image texture as its alpha ("texture
 * alpha" "leafmask"): where the texture is 0 the surface is not there, so
 * rays pass through the holes of leaf cards and fences. The scene keeps
 * the textures it loaded (rt_scene_alpha, one per scene, NULL when no
 * shape has an alpha texture) and every tracer asks one function,
 * rt_alpha_cut, of each candidate hit before it accepts it: a hit that is
 * cut is skipped and the walk goes on, as an any-hit program would. The
 * closest-hit rule (accel/hit.h) then holds among the hits not cut, and
 * shadow rays see the holes too.
 *
 * THE TEXTURE. Texels are floats, row 0 the top row of the image, the
 * values after pbrt's "scale" and "invert" (v' = invert ? max(0, 1 - s v)
 * : s v). The lookup is NEAREST texel with pbrt's (s, t) convention and
 * its default wrap "repeat": x = floor(u w) mod w, y = floor((1 - v) h)
 * mod h (pbrt flips t so that v = 1 is the top of the image). pbrt filters
 * bilinearly; one texel is one modeled read (the loader warns).
 *
 * THE RULE. pbrt-v4's (GeometricPrimitive::Intersect): a hit with alpha
 * a >= 1 counts; a <= 0 is cut; 0 < a < 1 is cut when HashFloat(o, d) > a,
 * HashFloat the MurmurHash64A of the ray's origin and direction (24 bytes,
 * seed 0) scaled to [0, 1) from its low 32 bits, as pbrt's HashFloat. The
 * test is deterministic per ray (the same ray, the same answer, whatever
 * the tracer or the order of the tests), so every tracer finds the same
 * hits and a mask of 0 and 1 is cut exactly where it is 0.
 *
 * THE MEMORY MODEL. Two regions of class alpha (docs/memory-model.md):
 * alpha.tri, one 28-byte record per triangle (u32 texture + 1, 0 for an
 * opaque triangle, then the three vertices' uv), and alpha.texel, 4 bytes
 * per texel of all textures in order. In a scene with alpha textures
 * every candidate hit reads the record's first 4 bytes; a triangle with a
 * texture reads the whole 28-byte record and one texel. A scene without
 * them reads nothing and its traces are what they were.
 *
 * INVARIANTS (rt_alpha_check): nmap >= 1; every map has w, h >= 1 and its
 * texels lie in [0, ntexel), maps in order without overlap; 1 <= nrec <=
 * ntri; tmap has nrec entries each <= nmap, at least one non-zero; every
 * texel and uv is finite and every texel >= 0. alpha.tri models a record
 * for every triangle (ntri of them), whatever nrec.
 */
#ifndef RT_ALPHA_H
#define RT_ALPHA_H

#include "memmodel.h"
#include "rt.h"

#include <stdint.h>

struct rt_ray;

typedef struct rt_alpha_map {
    uint32_t w, h;   /* texels */
    uint64_t off;    /* its first texel in rt_scene_alpha.texel */
    char name[64];   /* the pbrt texture's name, for messages */
} rt_alpha_map;

typedef struct rt_scene_alpha {
    uint32_t nmap;       /* textures */
    rt_alpha_map *map;   /* nmap records */
    uint64_t ntexel;     /* texels of all textures */
    float *texel;        /* ntexel values, map after map */
    uint32_t ntri;       /* the scene's triangles in the flattened order (rt_scene_nflat: the indices hits carry) */
    uint32_t nrec;       /* triangles the arrays hold, 0 .. nrec - 1 (<= ntri: one past the last with a
                          * texture, so a kept scene's instanced triangles after it cost no memory) */
    uint32_t *tmap;      /* per triangle < nrec: texture index + 1, 0 = opaque; triangles >= nrec are opaque */
    float *uv;           /* per triangle < nrec: u0 v0 u1 v1 u2 v2 */
} rt_scene_alpha;

#define RT_ALPHA_TRI_RECSIZE 28u
#define RT_ALPHA_TEXEL_RECSIZE 4u

/* Where the alpha reads of one run go in the modeled memory: the bases
 * of alpha.tri and alpha.texel (on = 0: the layout has no such regions,
 * nothing is recorded). The recorder is the caller's, passed with each
 * test: the one its walk records its other reads into (a run on
 * simulated cores switches it per core). */
typedef struct rt_alpha_at {
    int on;
    uint64_t tri_base, tex_base;
} rt_alpha_at;

/* The alpha value at barycentrics (u, v) of triangle tri (1 for an opaque
 * triangle), recording the reads into rec at the addresses of at (either
 * may be NULL: nothing recorded). */
float rt_alpha_value(const rt_scene_alpha *A, const rt_alpha_at *at, rt_rec *rec, uint32_t tri, float u, float v);
/* pbrt's HashFloat(o, d) of the ray, in [0, 1). */
float rt_alpha_hash(const struct rt_ray *r);
/* rt_alpha_cut's work when A is non-NULL. */
int rt_alpha_cut_slow(const rt_scene_alpha *A, const rt_alpha_at *at, rt_rec *rec, const struct rt_ray *r,
                      uint32_t tri, float u, float v);

/* 1 when the hit of r on triangle tri (scene index) at barycentrics (u, v)
 * of p[1], p[2] is cut away by its alpha texture: the one filter every
 * tracer's triangle loop calls on a hit it would otherwise accept. A
 * NULL A (no alpha textures) costs one predictable branch. The reads
 * go to rec (NULL: not recording) at the addresses of at. */
static inline int rt_alpha_cut(const rt_scene_alpha *A, const rt_alpha_at *at, rt_rec *rec, const struct rt_ray *r,
                               uint32_t tri, float u, float v)
{
    if (__builtin_expect(A == NULL, 1)) return 0;
    return rt_alpha_cut_slow(A, at, rec, r, tri, u, v);
}

/* Adds the regions alpha.tri (RT_ALPHA_TRI_RECSIZE x triangles) and
 * alpha.texel (RT_ALPHA_TEXEL_RECSIZE x texels), class alpha, when A is
 * non-NULL; nothing otherwise (a scene without alpha textures keeps its
 * layout). Every tracer's layout calls it after its geometry regions. 0
 * or -1. */
int rt_alpha_regions(rt_layout *L, const rt_scene_alpha *A, rt_err *e);

/* Fills at from a layout (may be NULL) holding the regions alpha.tri and
 * alpha.texel (absent: on = 0, nothing recorded). */
void rt_alpha_at_init(rt_alpha_at *at, const rt_layout *L);

/* Checks the invariants above: 0, or -1 naming the first violation. */
int rt_alpha_check(const rt_scene_alpha *A, rt_err *e);
void rt_alpha_free(rt_scene_alpha *A);

/* Decoders of the image files an alpha texture names, from the file's
 * bytes (the loader reads the file): the first channel of the image, as
 * pbrt-v4's float image textures read it (gray: its value; RGB, RGBA: R;
 * OpenEXR: the channel R, else Y, else A, else the first), as floats,
 * row 0 at the top. PNG 8- and 16-bit values become v / (2^bits - 1),
 * decoded from sRGB when srgb is set (pbrt's default encoding for PNG).
 * *px is malloc'd (w * h floats). 0, or -1 with "NAME: what" (name is the
 * file as the message should show it). */
int rt_alpha_decode_png(const unsigned char *buf, size_t n, const char *name, int srgb, float **px, uint32_t *w,
                        uint32_t *h, rt_err *e);
int rt_alpha_decode_exr(const unsigned char *buf, size_t n, const char *name, float **px, uint32_t *w, uint32_t *h,
                        rt_err *e);

/* The largest image an alpha texture may have (texels), checked on the
 * header before any pixel is decoded. */
#define RT_ALPHA_MAX_TEXELS ((uint64_t)1 << 28)

#endif
