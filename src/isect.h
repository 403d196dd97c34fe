/*
 * isect.h -- watertight ray/triangle intersection and robust ray offsets.
 *
 * rt_isect_tri implements Woop, Benthin and Wald (JCGT 2013): the ray is
 * transformed so its direction is +z (dominant axis kz, with kx/ky swapped
 * when d[kz] < 0 to keep winding), edge functions are evaluated in that
 * space and re-evaluated in double precision when any is exactly zero, so
 * a ray through a shared edge or vertex of a closed mesh hits at least one
 * of the triangles. Both windings are accepted (two-sided geometry).
 *
 * rt_offset_origin moves a hit point off its surface along the geometric
 * normal by a few ULPs in integer space (Wächter and Binder, Ray Tracing
 * Gems ch. 6), so shadow and secondary rays never re-hit their own surface
 * at any scene scale.
 */
#ifndef RT_ISECT_H
#define RT_ISECT_H

#include "rt_math.h"
#include "scene.h"

#include <stdint.h>

/* A ray with its watertight precomputation. */
typedef struct rt_ray {
    rt_vec3 o, d;       /* origin, direction (need not be unit length) */
    float tmin, tmax;   /* valid parametric interval (exclusive ends) */
    int kx, ky, kz;     /* permutation: kz = dominant axis of d */
    float Sx, Sy, Sz;   /* shear constants */
    rt_vec3 inv_d;      /* 1/d per axis (+-inf for zero components) */
} rt_ray;

/* Fills the precomputed fields from o and d; sets tmin=0, tmax=INFINITY. */
void rt_ray_init(rt_ray *r, rt_vec3 o, rt_vec3 d);

/* Intersects r with t. Returns 1 and sets *t_out, *u, *v (barycentrics of
 * p[1], p[2]) when the hit's t lies in (r->tmin, r->tmax); 0 otherwise.
 * Degenerate (zero-area) triangles never hit. */
int rt_isect_tri(const rt_ray *r, const rt_tri *tri, float *t_out, float *u, float *v);

/* Geometric normal (unnormalised cross product of the edges). */
rt_vec3 rt_tri_normal(const rt_tri *tri);

/* Offsets p along n (pointing to the side the new ray leaves on). */
rt_vec3 rt_offset_origin(rt_vec3 p, rt_vec3 n);

#endif
