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

/* The point at barycentrics (u, v) of p[1], p[2]: p0 + u (p1-p0) + v (p2-p0).
 * Use this, not o + t d, as the origin of secondary rays: its error is a few
 * ULPs of the vertex coordinates, which rt_offset_origin is sized for. */
rt_vec3 rt_tri_point(const rt_tri *tri, float u, float v);

/* Offsets p along n (pointing to the side the new ray leaves on; need not
 * be unit length: it is normalised here). Every component moves by up to
 * 256 ULPs of itself (components below 1/32 in magnitude by n/65536). */
rt_vec3 rt_offset_origin(rt_vec3 p, rt_vec3 n);
/* The same in a scene of length scale `scale` (rt_scene_offset_scale, in
 * (0, 1]): components below scale/32 move by scale * n/65536, so the
 * offset stays a fixed fraction of a scene smaller than the unit cube
 * instead of leaving it (a cube of edge 1e-9 would otherwise start its
 * shadow rays 1.5e-5 away). scale = 1 is rt_offset_origin bit for bit. */
rt_vec3 rt_offset_origin_scaled(rt_vec3 p, rt_vec3 n, float scale);
/* How far from p a surface counts as p's own under that rule: the
 * largest move rt_offset_origin_scaled makes (256 ULPs of the largest
 * component, at least scale/65536), doubled. Camera rays from an eye this
 * close to a triangle start this far along (camera.h). */
float rt_offset_reach(rt_vec3 p, float scale);

/* rt_isect_core_nd (below) out of line: the vector core's rare fallback,
 * kept out of the walks it is inlined into. */
int rt_isect_core_nd_out(const rt_ray *r, const rt_tri *tri, float *t_out, float *u, float *v);

/* 1 when the triangle has zero area to rounding (collinear or repeated
 * vertices); such triangles never hit. */
int rt_isect_degenerate(const rt_tri *tri);

/*
 * The shared intersection core, inline so the k-d tree traversal's inner
 * loop and the brute-force reference compute bit-identical results.
 * Returns 1 when the ray's line hits the triangle at a t that is not
 * checked against any interval (callers compare t themselves: rt_isect_tri
 * against (tmin, tmax), the traversal also breaks ties by triangle index).
 * Never returns 1 with a NaN or infinite t.
 */
#if defined(__GNUC__)
#define RT_ALWAYS_INLINE inline __attribute__((always_inline))
#define RT_NOINLINE __attribute__((noinline))
#else
#define RT_ALWAYS_INLINE inline
#define RT_NOINLINE
#endif
static RT_ALWAYS_INLINE int rt_isect_core_nd(const rt_ray *r, const rt_tri *tri, float *t_out, float *u, float *v);

static RT_ALWAYS_INLINE int rt_isect_core(const rt_ray *r, const rt_tri *tri, float *t_out, float *u, float *v)
{
    float t, b1, b2;
    if (!rt_isect_core_nd(r, tri, &t, &b1, &b2)) return 0;
    if (rt_isect_degenerate(tri)) return 0; /* rare: only on a hit */
    *t_out = t;
    *u = b1;
    *v = b2;
    return 1;
}

/* rt_isect_core without its last step, the degenerate-triangle rejection:
 * for callers that know the triangle's area is not zero (a flag computed
 * once per triangle, as in the k-d tree's host copy, kdtree.h). */
static RT_ALWAYS_INLINE int rt_isect_core_nd(const rt_ray *r, const rt_tri *tri, float *t_out, float *u, float *v)
{
    const float *p = (const float *)(const void *)tri; /* 9 floats */
    const float *o = (const float *)(const void *)&r->o;
    const int kx = r->kx, ky = r->ky, kz = r->kz;
    const float Ax0 = p[kx] - o[kx], Ay0 = p[ky] - o[ky], Az0 = p[kz] - o[kz];
    const float Bx0 = p[3 + kx] - o[kx], By0 = p[3 + ky] - o[ky], Bz0 = p[3 + kz] - o[kz];
    const float Cx0 = p[6 + kx] - o[kx], Cy0 = p[6 + ky] - o[ky], Cz0 = p[6 + kz] - o[kz];
    const float Ax = Ax0 - r->Sx * Az0, Ay = Ay0 - r->Sy * Az0;
    const float Bx = Bx0 - r->Sx * Bz0, By = By0 - r->Sy * Bz0;
    const float Cx = Cx0 - r->Sx * Cz0, Cy = Cy0 - r->Sy * Cz0;
    const float U = Cx * By - Cy * Bx;
    const float V = Ax * Cy - Ay * Cx;
    const float W = Bx * Ay - By * Ax;
    float t, b1, b2;
    if (U != 0.0f && V != 0.0f && W != 0.0f) {
        if ((U < 0.0f || V < 0.0f || W < 0.0f) && (U > 0.0f || V > 0.0f || W > 0.0f)) return 0;
        const float det = U + V + W;
        if (det == 0.0f) return 0;
        const float T = U * (r->Sz * Az0) + V * (r->Sz * Bz0) + W * (r->Sz * Cz0);
        const float inv = 1.0f / det;
        t = T * inv;
        b1 = V * inv;
        b2 = W * inv;
    } else {
        /* An edge function is exactly 0: redo all three in double, where
         * the products of two floats are exact, so the sign is right. */
        const double Ud = (double)Cx * By - (double)Cy * Bx;
        const double Vd = (double)Ax * Cy - (double)Ay * Cx;
        const double Wd = (double)Bx * Ay - (double)By * Ax;
        if ((Ud < 0.0 || Vd < 0.0 || Wd < 0.0) && (Ud > 0.0 || Vd > 0.0 || Wd > 0.0)) return 0;
        const double det = Ud + Vd + Wd;
        if (det == 0.0) return 0;
        const double T = Ud * ((double)r->Sz * Az0) + Vd * ((double)r->Sz * Bz0) + Wd * ((double)r->Sz * Cz0);
        t = (float)(T / det);
        b1 = (float)(Vd / det);
        b2 = (float)(Wd / det);
    }
    if (!(t > -INFINITY && t < INFINITY)) return 0; /* NaN or overflow */
    *t_out = t;
    *u = b1;
    *v = b2;
    return 1;
}


#if defined(__SSE2__)
#include <emmintrin.h>

/*
 * rt_isect_core_nd with the three vertices in the lanes of one vector:
 * the same operations on the same operands in the same order, so the same
 * bits (IEEE single precision, no contraction), in about half the
 * instructions. Lane 0, 1, 2 hold vertex A, B, C; lane 3 is never read.
 * The rare case of an edge function exactly zero goes to the scalar core.
 */
typedef struct rt_isect_sse {
    __m128 o[3];   /* o[kx], o[ky], o[kz], broadcast */
    __m128 s[3];   /* Sx, Sy, Sz, broadcast */
    int k[3];      /* kx, ky, kz */
} rt_isect_sse;

static RT_ALWAYS_INLINE void rt_isect_sse_init(rt_isect_sse *q, const rt_ray *r)
{
    const float *o = (const float *)(const void *)&r->o;
    q->k[0] = r->kx;
    q->k[1] = r->ky;
    q->k[2] = r->kz;
    q->o[0] = _mm_set1_ps(o[r->kx]);
    q->o[1] = _mm_set1_ps(o[r->ky]);
    q->o[2] = _mm_set1_ps(o[r->kz]);
    q->s[0] = _mm_set1_ps(r->Sx);
    q->s[1] = _mm_set1_ps(r->Sy);
    q->s[2] = _mm_set1_ps(r->Sz);
}

static RT_ALWAYS_INLINE int rt_isect_core_nd_sse(const rt_isect_sse *q, const rt_ray *r, const rt_tri *tri,
                                                 float *t_out, float *u, float *v)
{
    const float *p = (const float *)(const void *)tri;
    const __m128 a = _mm_loadu_ps(p), b = _mm_loadu_ps(p + 4), c = _mm_load_ss(p + 8);
    __m128 xyz[3];
    xyz[0] = _mm_shuffle_ps(a, b, _MM_SHUFFLE(3, 2, 3, 0)); /* x0 x1 x2 */
    const __m128 y = _mm_shuffle_ps(a, b, _MM_SHUFFLE(3, 0, 1, 1));
    xyz[1] = _mm_shuffle_ps(y, y, _MM_SHUFFLE(3, 3, 2, 0)); /* y0 y1 y2 */
    const __m128 z = _mm_shuffle_ps(a, b, _MM_SHUFFLE(1, 1, 2, 2));
    xyz[2] = _mm_shuffle_ps(z, c, _MM_SHUFFLE(0, 0, 2, 0)); /* z0 z1 z2 */
    const __m128 dx = _mm_sub_ps(xyz[q->k[0]], q->o[0]); /* Ax0 Bx0 Cx0 */
    const __m128 dy = _mm_sub_ps(xyz[q->k[1]], q->o[1]);
    const __m128 dz = _mm_sub_ps(xyz[q->k[2]], q->o[2]);
    const __m128 X = _mm_sub_ps(dx, _mm_mul_ps(q->s[0], dz)); /* Ax Bx Cx */
    const __m128 Y = _mm_sub_ps(dy, _mm_mul_ps(q->s[1], dz));
    /* lanes (U, V, W) = (Cx By - Cy Bx, Ax Cy - Ay Cx, Bx Ay - By Ax) */
    const __m128 X1 = _mm_shuffle_ps(X, X, _MM_SHUFFLE(3, 0, 2, 1)), X2 = _mm_shuffle_ps(X, X, _MM_SHUFFLE(3, 1, 0, 2));
    const __m128 Y1 = _mm_shuffle_ps(Y, Y, _MM_SHUFFLE(3, 0, 2, 1)), Y2 = _mm_shuffle_ps(Y, Y, _MM_SHUFFLE(3, 1, 0, 2));
    const __m128 E = _mm_sub_ps(_mm_mul_ps(X2, Y1), _mm_mul_ps(Y2, X1));
    const __m128 zero = _mm_setzero_ps();
    if (_mm_movemask_ps(_mm_cmpeq_ps(E, zero)) & 7) return rt_isect_core_nd_out(r, tri, t_out, u, v);
    if ((_mm_movemask_ps(_mm_cmplt_ps(E, zero)) & 7) && (_mm_movemask_ps(_mm_cmpgt_ps(E, zero)) & 7)) return 0;
    const float U = _mm_cvtss_f32(E), V = _mm_cvtss_f32(_mm_shuffle_ps(E, E, 1)),
                W = _mm_cvtss_f32(_mm_shuffle_ps(E, E, 2));
    const float det = U + V + W;
    if (det == 0.0f) return 0;
    const __m128 P = _mm_mul_ps(E, _mm_mul_ps(q->s[2], dz)); /* U (Sz Az0), V (Sz Bz0), W (Sz Cz0) */
    const float T = _mm_cvtss_f32(P) + _mm_cvtss_f32(_mm_shuffle_ps(P, P, 1)) + _mm_cvtss_f32(_mm_shuffle_ps(P, P, 2));
    const float inv = 1.0f / det;
    const float t = T * inv;
    if (!(t > -INFINITY && t < INFINITY)) return 0;
    *t_out = t;
    *u = V * inv;
    *v = W * inv;
    return 1;
}
#endif

#endif
