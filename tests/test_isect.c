/*
 * test_isect.c -- robustness of the ray/triangle test and of ray offsets.
 *
 * Closed meshes (an SPD-style tessellated sphere and a 12-triangle cube)
 * must not let rays slip through shared edges or vertices: thousands of rays
 * aimed exactly at edge midpoints and vertices from many directions, rays
 * from inside in random and axis-parallel (signed-zero) directions, all at
 * several scales and far from the origin. Degenerate triangles never hit
 * and never yield NaN. Grazing rays never produce NaN or absurd t. A shadow
 * ray leaving an offset hit point (rt_offset_origin) never re-hits its own
 * triangle. rt_ray_init gets the sign of 1/(+-0) right.
 * Exit 0 on success; failures are printed and exit 1.
 */
#include "config.h"
#include "check.h"
#include "isect.h"
#include "kdtrav.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>


/* A mesh as a plain triangle array plus its points of interest. */
typedef struct mesh {
    rt_tri *t;    /* triangles */
    int n;        /* count */
    rt_vec3 *poi; /* vertices and edge midpoints (in double, rounded) */
    int npoi;
    rt_vec3 centre; /* an interior point */
} mesh;

static void mesh_free(mesh *m)
{
    free(m->t);
    free(m->poi);
}

/* Maps unit-scale coordinates to scale * p + shift, in double, rounded once:
 * shared vertices stay bit-identical. */
static rt_vec3 place(double x, double y, double z, double scale, double shift)
{
    return rt_v3((float)(x * scale + shift), (float)(y * scale + shift), (float)(z * scale + shift));
}

static void cube_pt(int face, int i, int j, int r, double out[3])
{
    double a = -1.0 + 2.0 * i / r, b = -1.0 + 2.0 * j / r;
    int ax = face % 3;
    out[ax] = face < 3 ? 1.0 : -1.0;
    out[(ax + 1) % 3] = a;
    out[(ax + 2) % 3] = b;
}

/* Tessellated sphere (sphere=1) or cube (sphere=0, r=1): 12 r^2 triangles. */
static mesh make_mesh(int r, int sphere, double scale, double shift)
{
    mesh m;
    m.n = 12 * r * r;
    m.t = calloc((size_t)m.n, sizeof *m.t);
    m.poi = calloc((size_t)m.n * 6, sizeof *m.poi);
    m.npoi = 0;
    m.centre = place(0, 0, 0, scale, shift);
    int k = 0;
    for (int f = 0; f < 6; f++)
        for (int i = 0; i < r; i++)
            for (int j = 0; j < r; j++) {
                double q[4][3];
                cube_pt(f, i, j, r, q[0]);
                cube_pt(f, i + 1, j, r, q[1]);
                cube_pt(f, i + 1, j + 1, r, q[2]);
                cube_pt(f, i, j + 1, r, q[3]);
                rt_vec3 v[4];
                for (int c = 0; c < 4; c++) {
                    double l = sphere ? sqrt(q[c][0] * q[c][0] + q[c][1] * q[c][1] + q[c][2] * q[c][2]) : 1.0;
                    v[c] = place(q[c][0] / l, q[c][1] / l, q[c][2] / l, scale, shift);
                }
                m.t[k].p[0] = v[0];
                m.t[k].p[1] = v[1];
                m.t[k].p[2] = v[2];
                k++;
                m.t[k].p[0] = v[0];
                m.t[k].p[1] = v[2];
                m.t[k].p[2] = v[3];
                k++;
                /* Vertex, two cell edges' midpoints and the diagonal's. */
                m.poi[m.npoi++] = v[0];
                m.poi[m.npoi++] = rt_mul(rt_add(v[0], v[1]), 0.5f);
                m.poi[m.npoi++] = rt_mul(rt_add(v[0], v[3]), 0.5f);
                m.poi[m.npoi++] = rt_mul(rt_add(v[0], v[2]), 0.5f);
            }
    return m;
}

/* Closest hit over the array (brute force, same core as the tree). */
/* The vector core (isect.h, SSE2) against the scalar one: the same
 * answer and the same bits of t, u, v on every pair it is given. */
static long core_pairs, core_differ;
static void core_agree(const rt_ray *r, const rt_tri *tri)
{
#if defined(__SSE2__)
    rt_isect_sse q;
    rt_isect_sse_init(&q, r);
    float t0 = 0, u0 = 0, v0 = 0, t1 = 0, u1 = 0, v1 = 0;
    const int a = rt_isect_core_nd(r, tri, &t0, &u0, &v0), b = rt_isect_core_nd_sse(&q, r, tri, &t1, &u1, &v1);
    core_pairs++;
    if (a != b || (a && (memcmp(&t0, &t1, sizeof t0) || memcmp(&u0, &u1, sizeof u0) || memcmp(&v0, &v1, sizeof v0)))) {
        if (core_differ++ < 8)
            fprintf(stderr, "vector core differs: hit %d/%d t %.9g/%.9g u %.9g/%.9g v %.9g/%.9g\n", a, b, (double)t0,
                    (double)t1, (double)u0, (double)u1, (double)v0, (double)v1);
    }
#else
    (void)r;
    (void)tri;
#endif
}

static int closest(const mesh *m, const rt_ray *r, float *t, int *which)
{
    int hit = 0;
    float best = r->tmax;
    for (int i = 0; i < m->n; i++) {
        float tt, u, v;
        core_agree(r, &m->t[i]);
        if (rt_isect_tri(r, &m->t[i], &tt, &u, &v)) {
            CHECK(isfinite(tt) && isfinite(u) && isfinite(v), "non-finite hit");
            if (tt < best) {
                best = tt;
                *which = i;
                hit = 1;
            }
        }
    }
    *t = best;
    return hit;
}

/* Rays at the mesh's vertices and edge midpoints. */
static long nreport;
static void report_slip(const char *name, const char *kind, const rt_ray *r)
{
    if (nreport++ < 8)
        fprintf(stderr, "%s: %s ray slipped: o (%.9g %.9g %.9g) d (%.9g %.9g %.9g)\n", name, kind, (double)r->o.x,
                (double)r->o.y, (double)r->o.z, (double)r->d.x, (double)r->d.y, (double)r->d.z);
}

static void test_watertight(const char *name, const mesh *m, double scale, double shift, int per_point)
{
    long rays = 0, slips = 0, badt = 0;
    /* t is 1 at P up to the rounding of P, o and d: a few ULPs of the
     * coordinates' magnitude relative to the ray length. */
    const float tol = (float)(1e-3 + 8.0 * (fabs(shift) + scale) * 1.2e-7 / scale);
    for (int p = 0; p < m->npoi; p++) {
        rt_vec3 P = m->poi[p];
        for (int k = 0; k < per_point; k++) {
            /* From outside, on the line through P and a random interior
             * point Q: by convexity the first hit is at P. */
            rt_vec3 Q = rt_add(m->centre, rt_mul(rand_dir(), (float)(0.8 * scale * unif())));
            rt_vec3 dir = rt_norm(rt_sub(P, Q));
            rt_vec3 o = rt_add(P, rt_mul(dir, (float)(3.0 * scale)));
            rt_ray r;
            rt_ray_init(&r, o, rt_sub(P, o));
            float t;
            int w;
            rays++;
            if (!closest(m, &r, &t, &w)) {
                slips++;
                report_slip(name, "outside", &r);
            } else if (fabsf(t - 1.0f) > tol) badt++;
            /* From the interior point through P: exactly one exit. */
            rt_ray_init(&r, m->centre, rt_sub(P, m->centre));
            rays++;
            if (!closest(m, &r, &t, &w)) {
                slips++;
                report_slip(name, "centre", &r);
            } else if (fabsf(t - 1.0f) > tol) badt++;
        }
    }
    /* From random interior points in random and axis-parallel directions. */
    for (int k = 0; k < 4000; k++) {
        rt_vec3 o = rt_add(m->centre, rt_mul(rand_dir(), (float)(0.5 * scale * unif())));
        rt_vec3 d;
        if (k & 1) {
            d = rt_v3((rnd64() & 1) ? -0.0f : 0.0f, (rnd64() & 1) ? -0.0f : 0.0f, (rnd64() & 1) ? -0.0f : 0.0f);
            rt_set_axis(&d, (int)(rnd64() % 3), (rnd64() & 1) ? -1.0f : 1.0f);
        } else {
            d = rand_dir();
        }
        rt_ray r;
        rt_ray_init(&r, o, d);
        float t;
        int w;
        rays++;
        if (!closest(m, &r, &t, &w)) {
            slips++;
            report_slip(name, "interior", &r);
        }
    }
    CHECK(slips == 0, "%s: %ld of %ld rays slipped through the closed mesh", name, slips, rays);
    CHECK(badt == 0, "%s: %ld rays hit at an inconsistent t", name, badt);
}

/* Rays from outside pointing away from the mesh must miss. */
static void test_misses(const char *name, const mesh *m, double scale)
{
    long wrong = 0;
    for (int k = 0; k < 2000; k++) {
        rt_vec3 dir = rand_dir();
        rt_vec3 o = rt_add(m->centre, rt_mul(dir, (float)(3.0 * scale)));
        rt_ray r;
        rt_ray_init(&r, o, dir);
        float t;
        int w;
        wrong += closest(m, &r, &t, &w);
    }
    CHECK(wrong == 0, "%s: %ld rays pointing away hit", name, wrong);
}

static void test_signed_zero(void)
{
    rt_ray r;
    rt_ray_init(&r, rt_v3(0, 0, 0), rt_v3(-0.0f, 0.0f, 1.0f));
    CHECK(r.inv_d.x == -INFINITY && r.inv_d.y == INFINITY && r.inv_d.z == 1.0f, "inv_d %g %g %g", (double)r.inv_d.x,
          (double)r.inv_d.y, (double)r.inv_d.z);
    CHECK(r.kz == 2 && r.tmin == 0.0f && r.tmax == INFINITY, "ray init fields");
    rt_ray_init(&r, rt_v3(0, 0, 0), rt_v3(0.0f, -1.0f, -0.0f));
    CHECK(r.inv_d.x == INFINITY && r.inv_d.z == -INFINITY && r.kz == 1, "inv_d 2");
    /* A unit square in z = 0 hit straight down along its edge x = 0 and its
     * corner, with every combination of signed zeros. */
    rt_tri a = {{{0, 0, 0}, {1, 0, 0}, {1, 1, 0}}}, b = {{{0, 0, 0}, {1, 1, 0}, {0, 1, 0}}},
           c = {{{-1, 0, 0}, {0, 0, 0}, {0, 1, 0}}};
    for (int s = 0; s < 8; s++) {
        rt_vec3 d = rt_v3((s & 1) ? -0.0f : 0.0f, (s & 2) ? -0.0f : 0.0f, (s & 4) ? 1.0f : -1.0f);
        rt_vec3 pts[3] = {rt_v3(0, 0.5f, 0), rt_v3(0, 0, 0), rt_v3(0.5f, 0.5f, 0)};
        for (int q = 0; q < 3; q++) {
            rt_vec3 o = rt_sub(pts[q], rt_mul(d, 2.0f));
            rt_ray_init(&r, o, d);
            float t, u, v;
            int n = rt_isect_tri(&r, &a, &t, &u, &v) + rt_isect_tri(&r, &b, &t, &u, &v) + rt_isect_tri(&r, &c, &t, &u, &v);
            CHECK(n >= 1, "axis ray %d at point %d slipped", s, q);
            if (n) CHECK(t == 2.0f, "axis ray t %g", (double)t);
        }
    }
}

static void test_degenerate(void)
{
    rt_tri deg[6] = {
        {{{0, 0, 0}, {0, 0, 0}, {0, 0, 0}}},              /* a point */
        {{{0, 0, 0}, {1, 1, 0}, {1, 1, 0}}},              /* repeated vertex */
        {{{0, 0, 0}, {1, 1, 0}, {0, 0, 0}}},              /* repeated vertex */
        {{{0, 0, 0}, {0.5f, 0.25f, 1}, {1, 0.5f, 2}}},    /* collinear */
        {{{-1, -1, -1}, {1, 1, 1}, {0.25f, 0.25f, 0.25f}}}, /* collinear */
        {{{1e5f, 1e5f, 1e5f}, {1e5f + 2, 1e5f + 4, 1e5f}, {1e5f + 1, 1e5f + 2, 1e5f}}}, /* collinear, far */
    };
    long hits = 0, nans = 0;
    for (int k = 0; k < 60000; k++) {
        const rt_tri *t = &deg[k % 6];
        /* Aim at a point on the degenerate triangle (a vertex or between
         * two), from random directions, and random rays nearby. */
        float w = uf(0, 1);
        rt_vec3 P = rt_add(rt_mul(t->p[0], 1 - w), rt_mul(t->p[1], w));
        if (k % 3 == 0) P = t->p[(k / 3) % 3];
        rt_vec3 o = rt_add(P, rt_mul(rand_dir(), uf(0.5f, 4)));
        rt_ray r;
        rt_ray_init(&r, o, (k % 5 == 0) ? rand_dir() : rt_sub(P, o));
        float tt = NAN, u = NAN, v = NAN;
        int h = rt_isect_tri(&r, t, &tt, &u, &v);
        hits += h;
        if (h && (isnan(tt) || isnan(u) || isnan(v))) nans++;
        CHECK(rt_isect_degenerate(t), "triangle %d not flagged degenerate", k % 6);
    }
    CHECK(hits == 0, "%ld hits on degenerate triangles", hits);
    CHECK(nans == 0, "%ld NaN results", nans);
    /* A zero direction never hits. */
    rt_ray r;
    rt_ray_init(&r, rt_v3(0.25f, 0.25f, 0), rt_v3(0, 0, 0));
    rt_tri ok = {{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}};
    float t, u, v;
    CHECK(!rt_isect_tri(&r, &ok, &t, &u, &v), "zero direction hit");
    CHECK(!rt_isect_degenerate(&ok), "good triangle flagged degenerate");
}

/* Rays in the plane of a triangle or nearly so: never NaN, never far off. */
static void test_grazing(void)
{
    rt_tri tri = {{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}};
    long bad = 0, inplane_hits = 0;
    for (int k = 0; k < 20000; k++) {
        rt_vec3 o = rt_v3(uf(-2, 2), uf(-2, 2), 0);
        rt_vec3 d = rt_v3(uf(-1, 1), uf(-1, 1), (k & 1) ? 0.0f : uf(-1e-6f, 1e-6f));
        if (k % 7 == 0) o.z = uf(-1e-6f, 1e-6f);
        rt_ray r;
        rt_ray_init(&r, o, d);
        float t, u, v;
        if (rt_isect_tri(&r, &tri, &t, &u, &v)) {
            if (!isfinite(t) || !isfinite(u) || !isfinite(v) || t <= 0) bad++;
            if (o.z == 0 && d.z == 0) inplane_hits++;
        }
    }
    CHECK(bad == 0, "%ld grazing hits with bad values", bad);
    CHECK(inplane_hits == 0, "%ld rays lying in the triangle's plane hit it", inplane_hits);
}

/* Shadow rays from offset hit points never hit their own triangle.
 * oscale: the scene length scale handed to rt_offset_origin_scaled (1:
 * rt_offset_origin). */
static void test_offset(double scale, double shift, float oscale)
{
    long self = 0, tried = 0;
    for (int k = 0; k < 20000; k++) {
        rt_tri tri;
        rt_vec3 c = rt_v3((float)(shift + scale * uf(-1, 1)), (float)(shift + scale * uf(-1, 1)),
                          (float)(shift + scale * uf(-1, 1)));
        float sz = (float)(scale * (k & 1 ? 1.0 : 1e-2));
        for (int i = 0; i < 3; i++) tri.p[i] = rt_add(c, rt_mul(rand_dir(), sz));
        if (rt_isect_degenerate(&tri)) continue;
        /* A random point on it, hit from a random eye. */
        float a = uf(0, 1), b = uf(0, 1);
        if (a + b > 1) {
            a = 1 - a;
            b = 1 - b;
        }
        rt_vec3 P = rt_add(tri.p[0], rt_add(rt_mul(rt_sub(tri.p[1], tri.p[0]), a), rt_mul(rt_sub(tri.p[2], tri.p[0]), b)));
        rt_vec3 eye = rt_add(P, rt_mul(rand_dir(), (float)(scale * uf(0.1f, 10))));
        rt_ray r;
        rt_ray_init(&r, eye, rt_sub(P, eye));
        float t, u, v;
        if (!rt_isect_tri(&r, &tri, &t, &u, &v)) continue;
        /* The hit point from the barycentrics (as Wächter and Binder
         * require), not o + t d, whose error grows with the eye distance. */
        rt_vec3 hitp = rt_tri_point(&tri, u, v);
        rt_vec3 n = rt_tri_normal(&tri);
        if (rt_dot(n, r.d) > 0) n = rt_mul(n, -1.0f);
        rt_vec3 o2 = rt_offset_origin_scaled(hitp, n, oscale);
        /* Lights on the eye's side, near and far, grazing and steep. */
        for (int j = 0; j < 4; j++) {
            rt_vec3 ld = rand_dir();
            if (rt_dot(ld, n) < 0) ld = rt_mul(ld, -1.0f);
            rt_vec3 light = rt_add(hitp, rt_mul(ld, (float)(scale * (j + 1) * (j + 1))));
            rt_ray sr;
            rt_ray_init(&sr, o2, rt_sub(light, o2));
            sr.tmax = 1.0f;
            if (rt_dot(sr.d, n) <= 0) continue; /* light below the offset point's plane */
            tried++;
            if (rt_isect_tri(&sr, &tri, &t, &u, &v)) self++;
        }
    }
    CHECK(tried > 5000, "offset: only %ld shadow rays tried", tried);
    CHECK(self == 0, "offset at scale %g shift %g: %ld of %ld shadow rays hit their own triangle", scale, shift, self,
          tried);
}

/* In a scene smaller than the unit cube the offset shrinks with it: a
 * floor point under a plate 5% of the scene above it, lit from 10% above,
 * is in shadow. The unit-cube offset (2^-16 = 1.5e-5) put the shadow ray's
 * origin above the light in a scene of 1e-7, and the plate was never
 * crossed. Scale 1 gives rt_offset_origin bit for bit. */
static void test_offset_small_scene(void)
{
    for (int k = 0; k < 4; k++) {
        const float s = k == 0 ? 1.0f : k == 1 ? 1e-4f : k == 2 ? 1e-7f : 1e-9f;
        rt_tri floor_t = {{rt_v3(-s, -s, 0), rt_v3(s, -s, 0), rt_v3(0, s, 0)}};
        rt_tri plate = {{rt_v3(-s, -s, 0.05f * s), rt_v3(s, -s, 0.05f * s), rt_v3(0, s, 0.05f * s)}};
        rt_vec3 light = rt_v3(0.01f * s, 0.01f * s, 0.1f * s);
        float diag = 2.0f * s * 1.5f; /* about the scene's diagonal */
        float sc = diag < 1 ? diag : 1;
        rt_vec3 p = rt_v3(0.02f * s, -0.01f * s, 0), n = rt_v3(0, 0, 1);
        rt_vec3 o = rt_offset_origin_scaled(p, n, sc);
        rt_ray sr;
        rt_ray_init(&sr, o, rt_sub(light, o));
        sr.tmax = 1.0f;
        float t, u, v;
        CHECK(o.z > 0 && o.z < 0.01f * s, "scale %g: offset origin z %g not just above the floor", (double)s, (double)o.z);
        CHECK(rt_isect_tri(&sr, &plate, &t, &u, &v), "scale %g: the plate does not shadow the floor point", (double)s);
        CHECK(!rt_isect_tri(&sr, &floor_t, &t, &u, &v), "scale %g: the shadow ray hits its own floor", (double)s);
        rt_vec3 a = rt_offset_origin(p, n), b = rt_offset_origin_scaled(p, n, 1.0f);
        CHECK(memcmp(&a, &b, sizeof a) == 0, "scale 1 differs from rt_offset_origin");
        CHECK(rt_offset_reach(p, sc) >= fabsf(o.z - p.z), "scale %g: reach %g below the offset %g", (double)s,
              (double)rt_offset_reach(p, sc), (double)(o.z - p.z));
    }
}

/* Random and hostile pairs for core_agree: triangles with shared and
 * repeated vertices, collinear and tiny ones, coordinates from 1e-30 to
 * 1e30; rays through vertices and edge points (edge functions exactly 0),
 * axis-parallel and signed-zero directions, origins on the triangle. */
static void test_vector_core(void)
{
    static const float mag[] = {1e-30f, 1e-6f, 1.0f, 3.0f, 1e6f, 1e30f};
    for (int k = 0; k < 200000; k++) {
        const float m = mag[rnd64() % 6];
        rt_tri tri;
        for (int i = 0; i < 3; i++) {
            tri.p[i] = rt_mul(rt_v3((float)(unif() * 2 - 1), (float)(unif() * 2 - 1), (float)(unif() * 2 - 1)), m);
            if (k % 7 == 0) tri.p[i] = rt_v3(floorf(tri.p[i].x), floorf(tri.p[i].y), 0.0f); /* on a grid, coplanar */
        }
        if (k % 11 == 0) tri.p[2] = tri.p[(int)(rnd64() % 2)];                          /* repeated vertex */
        if (k % 13 == 0) tri.p[2] = rt_add(tri.p[0], rt_mul(rt_sub(tri.p[1], tri.p[0]), 2.0f)); /* collinear */
        rt_vec3 target;
        switch (k % 4) {
        case 0: target = tri.p[rnd64() % 3]; break;                                         /* a vertex */
        case 1: target = rt_mul(rt_add(tri.p[0], tri.p[1]), 0.5f); break;                   /* an edge */
        default: {
            const float a = (float)unif(), b = (float)unif() * (1 - a);
            target = rt_add(tri.p[0], rt_add(rt_mul(rt_sub(tri.p[1], tri.p[0]), a), rt_mul(rt_sub(tri.p[2], tri.p[0]), b)));
        }
        }
        rt_vec3 d = rand_dir();
        if (k % 5 == 0) {
            d = rt_v3((rnd64() & 1) ? -0.0f : 0.0f, (rnd64() & 1) ? -0.0f : 0.0f, (rnd64() & 1) ? -0.0f : 0.0f);
            rt_set_axis(&d, (int)(rnd64() % 3), (rnd64() & 1) ? -1.0f : 1.0f);
        }
        const rt_vec3 o = k % 9 == 0 ? target : rt_sub(target, rt_mul(d, m * (float)(0.5 + unif())));
        rt_ray r;
        rt_ray_init(&r, o, d);
        core_agree(&r, &tri);
    }
}

int main(void)
{
    rnd_seed(0x243f6a8885a308d3ULL);
    test_vector_core();
    test_signed_zero();
    test_degenerate();
    test_grazing();
    static const struct {
        double scale, shift;
    } sc[] = {{1, 0}, {1e-4, 0}, {1e5, 0}, {1, 1e5}, {1e-4, 1}};
    for (size_t i = 0; i < sizeof sc / sizeof sc[0]; i++) {
        char name[96];
        mesh m = make_mesh(6, 1, sc[i].scale, sc[i].shift);
        snprintf(name, sizeof name, "sphere(scale %g, shift %g)", sc[i].scale, sc[i].shift);
        test_watertight(name, &m, sc[i].scale, sc[i].shift, 2);
        test_misses(name, &m, sc[i].scale);
        mesh_free(&m);
        m = make_mesh(1, 0, sc[i].scale, sc[i].shift);
        snprintf(name, sizeof name, "cube(scale %g, shift %g)", sc[i].scale, sc[i].shift);
        test_watertight(name, &m, sc[i].scale, sc[i].shift, 60);
        test_misses(name, &m, sc[i].scale);
        mesh_free(&m);
        test_offset(sc[i].scale, sc[i].shift, 1.0f);
    }
    /* scenes smaller than the unit cube, with the scaled offsets */
    test_offset(1e-7, 0, 3.5e-7f);
    test_offset(1e-9, 0, 3.5e-9f);
    test_offset(1e-7, 1e-6, 3.5e-7f);
    test_offset_small_scene();
    CHECK(core_differ == 0, "vector core differs from the scalar core on %ld of %ld pairs", core_differ, core_pairs);
#if defined(__SSE2__)
    CHECK(core_pairs > 1000000, "vector core compared on only %ld pairs", core_pairs);
#endif
    if (failures) {
        fprintf(stderr, "%d failures\n", failures);
        return 1;
    }
    printf("test_isect: ok\n");
    return 0;
}
