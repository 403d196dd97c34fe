/*
 * isect.c -- watertight ray/triangle intersection and robust ray offsets.
 *
 * Every tracer and the brute-force reference call rt_isect_tri through the
 * same inline core (rt_isect_core, defined in isect.h), so
 * a hit found by the k-d tree and by brute force has bit-identical t, u, v.
 * The intersection is Woop, Benthin and Wald, "Watertight Ray/Triangle
 * Intersection" (JCGT 2(1), 2013): the ray is permuted so its dominant
 * direction axis becomes z, sheared so the direction becomes +z, and the
 * three 2D edge functions of the transformed triangle are evaluated at the
 * origin. Because the shear depends only on the ray, a shared edge of two
 * triangles yields the same edge function (negated) in both, so a ray
 * through the edge hits at least one of them; edge functions that come out
 * exactly 0 in single precision are recomputed in double precision, which
 * is exact for the products involved and settles the sign. Both windings are
 * accepted. A triangle whose projected determinant is 0 never hits, and an
 * accepted hit is additionally rejected when the triangle's 3D area is zero
 * to rounding (collinear or repeated vertices), so degenerate triangles
 * never hit and never produce NaN.
 *
 * rt_offset_origin is Wächter and Binder, "A Fast and Robust Method for
 * Avoiding Self-Intersection" (Ray Tracing Gems, ch. 6): the point moves
 * along the unit normal by up to 256 ULPs in integer space, so the offset
 * scales with the point's magnitude; components within 1/32 of zero, where
 * ULPs become tiny, move by a fixed 1/65536 of the normal instead. In a
 * scene smaller than the unit cube both constants shrink with its diagonal
 * (rt_offset_origin_scaled, rt_scene_offset_scale), so tiny scenes keep
 * their shadow rays on their own surfaces.
 */
#include "config.h"
#include "isect.h"

#include <math.h>
#include <string.h>

void rt_ray_init(rt_ray *r, rt_vec3 o, rt_vec3 d)
{
    /* every field is assigned below (no memset: this runs once per ray) */
    r->o = o;
    r->d = d;
    r->tmin = 0.0f;
    r->tmax = INFINITY;
    float ad[3] = {fabsf(d.x), fabsf(d.y), fabsf(d.z)};
    float dv[3] = {d.x, d.y, d.z};
    int kz = 0;
    if (ad[1] > ad[kz]) kz = 1;
    if (ad[2] > ad[kz]) kz = 2;
    int kx = kz + 1 == 3 ? 0 : kz + 1;
    int ky = kx + 1 == 3 ? 0 : kx + 1;
    /* Swap kx and ky to preserve the triangle's winding when the dominant
     * direction is negative (only matters for one-sided tests; harmless
     * here and kept for fidelity with the paper). */
    if (dv[kz] < 0.0f) {
        int tmp = kx;
        kx = ky;
        ky = tmp;
    }
    r->kx = kx;
    r->ky = ky;
    r->kz = kz;
    if (dv[kz] != 0.0f) {
        r->Sx = dv[kx] / dv[kz];
        r->Sy = dv[ky] / dv[kz];
        r->Sz = 1.0f / dv[kz];
    } else {
        /* Zero direction: every candidate has t = 0, which lies outside the
         * open interval, so the ray hits nothing. */
        r->Sx = r->Sy = r->Sz = 0.0f;
    }
    /* 1/(+-0) must be +-inf with the sign of the zero for slab clipping;
     * computed explicitly so no floating division by zero happens. */
    r->inv_d.x = d.x != 0.0f ? 1.0f / d.x : copysignf(INFINITY, d.x);
    r->inv_d.y = d.y != 0.0f ? 1.0f / d.y : copysignf(INFINITY, d.y);
    r->inv_d.z = d.z != 0.0f ? 1.0f / d.z : copysignf(INFINITY, d.z);
}

int rt_isect_tri(const rt_ray *r, const rt_tri *tri, float *t_out, float *u, float *v)
{
    float t, b1, b2;
    if (!rt_isect_core(r, tri, &t, &b1, &b2)) return 0;
    if (!(t > r->tmin && t < r->tmax)) return 0;
    if (t_out) *t_out = t;
    if (u) *u = b1;
    if (v) *v = b2;
    return 1;
}

int rt_isect_degenerate(const rt_tri *tri)
{
    /* Double precision: float differences and their products are (nearly)
     * exact, so an exactly collinear triangle gives a cross product that is
     * zero up to a tiny relative error. */
    double e1[3] = {(double)tri->p[1].x - tri->p[0].x, (double)tri->p[1].y - tri->p[0].y,
                    (double)tri->p[1].z - tri->p[0].z};
    double e2[3] = {(double)tri->p[2].x - tri->p[0].x, (double)tri->p[2].y - tri->p[0].y,
                    (double)tri->p[2].z - tri->p[0].z};
    double c0 = e1[1] * e2[2] - e1[2] * e2[1];
    double c1 = e1[2] * e2[0] - e1[0] * e2[2];
    double c2 = e1[0] * e2[1] - e1[1] * e2[0];
    double cc = c0 * c0 + c1 * c1 + c2 * c2;
    double l1 = e1[0] * e1[0] + e1[1] * e1[1] + e1[2] * e1[2];
    double l2 = e2[0] * e2[0] + e2[1] * e2[1] + e2[2] * e2[2];
    /* |e1 x e2| <= 1e-12 |e1| |e2|: sine of the corner angle below 1e-12. */
    return !(cc > 1e-24 * l1 * l2);
}

int rt_isect_core_nd_out(const rt_ray *r, const rt_tri *tri, float *t_out, float *u, float *v)
{
    return rt_isect_core_nd(r, tri, t_out, u, v);
}

rt_vec3 rt_tri_normal(const rt_tri *tri)
{
    return rt_cross(rt_sub(tri->p[1], tri->p[0]), rt_sub(tri->p[2], tri->p[0]));
}

rt_vec3 rt_tri_point(const rt_tri *tri, float u, float v)
{
    rt_vec3 e1 = rt_sub(tri->p[1], tri->p[0]), e2 = rt_sub(tri->p[2], tri->p[0]);
    return rt_add(tri->p[0], rt_add(rt_mul(e1, u), rt_mul(e2, v)));
}

static float offset_comp(float p, float n, float scale)
{
    const float origin = scale * (1.0f / 32.0f);
    const float float_scale = scale * (1.0f / 65536.0f);
    const float int_scale = 256.0f;
    if (fabsf(p) < origin) return p + float_scale * n;
    int32_t of = (int32_t)(int_scale * n); /* |n| <= 1: at most 256 ULPs */
    uint32_t bits;
    memcpy(&bits, &p, sizeof bits);
    /* Moving away from zero grows the magnitude bits; for negative p the
     * same move in value space is the opposite move in magnitude. */
    if (p < 0.0f) of = -of;
    bits = (uint32_t)((int64_t)bits + of);
    float q;
    memcpy(&q, &bits, sizeof q);
    return q;
}

rt_vec3 rt_offset_origin_scaled(rt_vec3 p, rt_vec3 n, float scale)
{
    float l = rt_len(n);
    if (!(l > 0.0f) || !isfinite(l)) {
        /* the normal of a tiny triangle (edges below ~1e-10: its squared
         * length underflows) or a huge one: rescale by its largest
         * component first (only here, so other normals keep their bits) */
        float m = fmaxf(fabsf(n.x), fmaxf(fabsf(n.y), fabsf(n.z)));
        if (!(m > 0.0f) || !isfinite(m)) return p;
        n = rt_mul(n, 1.0f / m);
        l = rt_len(n);
        if (!(l > 0.0f) || !isfinite(l)) return p;
    }
    if (!(scale > 0.0f && scale <= 1.0f)) scale = 1.0f;
    n = rt_mul(n, 1.0f / l);
    return rt_v3(offset_comp(p.x, n.x, scale), offset_comp(p.y, n.y, scale), offset_comp(p.z, n.z, scale));
}

rt_vec3 rt_offset_origin(rt_vec3 p, rt_vec3 n) { return rt_offset_origin_scaled(p, n, 1.0f); }

float rt_offset_reach(rt_vec3 p, float scale)
{
    if (!(scale > 0.0f && scale <= 1.0f)) scale = 1.0f;
    float m = fmaxf(fabsf(p.x), fmaxf(fabsf(p.y), fabsf(p.z)));
    /* 256 ULPs of m is at most m * 2^-15; a ULP below 1/32 is smaller */
    return 2.0f * fmaxf(m * 0x1p-15f, scale * (1.0f / 65536.0f));
}
