/*
 * scene_builtin.c -- the deterministic built-in scenes: sphereflake (Haines'
 * SPD `balls`), grove (SPD `tree`-style recursive trees), room (a furnished
 * multi-room interior), cornell (a Cornell box) and knot (a torus-knot tube).
 * Materials follow the sources: sphereflake's balls and the knot are grey
 * mirrors, cornell has a glass sphere (glass=0 gives the plain box); grove
 * and room are plain diffuse. Diffuse colours do not depend on materials, so
 * images of primary and shadow rays are the same with or without them.
 *
 * Determinism is the point of this file: the same spec must give
 * bit-identical triangles on every machine, because the scene hash is
 * recorded in every trace and result row. So geometry is computed in double
 * precision using only + - * / and sqrt (all correctly rounded by IEEE 754),
 * never libm's sin/cos/acos whose last bit differs between libm versions;
 * the trigonometry is rt_dsincos_deg (rt.c: exact reduction in degrees,
 * then a Taylor polynomial), the pseudo-random numbers are a 32-bit integer hash,
 * and the build disables FMA contraction. Results are rounded to float only
 * when a triangle is stored.
 *
 * Specs are "name" or "name:k=v,k=v"; every scene takes integer parameters
 * from a fixed table, rejects unknown keys, and records the complete
 * canonical parameter string (every key, in table order) in s->params.
 */
#include "config.h"
#include "scene.h"
#include "scene_load.h"
#include "ply_read.h"

#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ------------------------------------------------------------------------ */
/* Small double-precision vectors and emission                               */

typedef struct dv3 {
    double x, y, z;
} dv3;

static dv3 d3(double x, double y, double z) { dv3 v = {x, y, z}; return v; }
static dv3 dadd(dv3 a, dv3 b) { return d3(a.x + b.x, a.y + b.y, a.z + b.z); }
static dv3 dsub(dv3 a, dv3 b) { return d3(a.x - b.x, a.y - b.y, a.z - b.z); }
static dv3 dmul(dv3 a, double s) { return d3(a.x * s, a.y * s, a.z * s); }
static double ddot(dv3 a, dv3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
static dv3 dcross(dv3 a, dv3 b) { return d3(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x); }
static dv3 dnorm(dv3 a)
{
    double l = sqrt(ddot(a, a));
    return l > 0 ? d3(a.x / l, a.y / l, a.z / l) : a;
}
static rt_vec3 tof(dv3 a) { return rt_v3((float)a.x, (float)a.y, (float)a.z); }

/* Emission context: the scene, the current colour, the first error, the
 * current material. */
typedef struct gen {
    rt_scene *s;
    float col[3];
    int failed;
    rt_err *e;
    uint32_t mat; /* index into s->mat for the triangles emitted next */
} gen;

/* A built-in scene's view: z-up camera, three point lights, shading. */
typedef struct view {
    rt_vec3 eye, at;               /* camera */
    float fovy_deg;                /* vertical field of view */
    rt_vec3 light[RT_NLIGHTS];     /* point lights */
    float light_power, ambient;    /* shading */
    rt_vec3 background;            /* colour of escaping rays */
} view;

/* Sets the view; ends every generator, so it returns its status. */
static int set_view(gen *g, const view *v)
{
    rt_scene *s = g->s;
    s->cam.eye = v->eye;
    s->cam.at = v->at;
    s->cam.up = rt_v3(0, 0, 1);
    s->cam.fovy_deg = v->fovy_deg;
    for (int i = 0; i < RT_NLIGHTS; i++) s->light[i] = v->light[i];
    s->light_power = v->light_power;
    s->ambient = v->ambient;
    s->background = v->background;
    return g->failed ? -1 : 0;
}

static void colour(gen *g, double r, double gg, double b)
{
    g->col[0] = (float)r;
    g->col[1] = (float)gg;
    g->col[2] = (float)b;
}

static void tri(gen *g, dv3 a, dv3 b, dv3 c)
{
    if (g->failed) return;
    if (rt_scene_add_tri_mat(g->s, tof(a), tof(b), tof(c), g->col, g->mat, g->e) < 0) g->failed = 1;
}

/* Adds a material (grey mirror reflectance ks, grey transmittance kt,
 * ior) and makes it current; 0 or -1. Material 0, the plain one, is
 * current until this is called. */
static int material(gen *g, const char *name, double ks, double kt, double ior)
{
    rt_material m;
    memset(&m, 0, sizeof m);
    snprintf(m.name, sizeof m.name, "%s", name);
    m.ks[0] = m.ks[1] = m.ks[2] = (float)ks;
    m.kt[0] = m.kt[1] = m.kt[2] = (float)kt;
    m.ior = (float)ior;
    int r = rt_scene_add_material(g->s, &m, g->e);
    if (r < 0) return -1;
    g->mat = (uint32_t)r;
    return 0;
}

/* Quad a b c d (counter-clockwise seen from outside) as two triangles. */
static void quad(gen *g, dv3 a, dv3 b, dv3 c, dv3 d)
{
    tri(g, a, b, c);
    tri(g, a, c, d);
}

/* Rigid placement in the xy plane: rotate about z by an angle, translate. */
typedef struct xform {
    double c, s;    /* cos, sin of the rotation */
    dv3 t;          /* translation */
    double scale;   /* uniform scale applied before rotation */
} xform;

static xform xf(double x, double y, double z, double deg)
{
    xform f;
    rt_dsincos_deg(deg, &f.s, &f.c);
    f.t = d3(x, y, z);
    f.scale = 1.0;
    return f;
}

static dv3 xapply(const xform *f, dv3 p)
{
    p = dmul(p, f->scale);
    return d3(f->c * p.x - f->s * p.y + f->t.x, f->s * p.x + f->c * p.y + f->t.y, p.z + f->t.z);
}

static void xtri(gen *g, const xform *f, dv3 a, dv3 b, dv3 c) { tri(g, xapply(f, a), xapply(f, b), xapply(f, c)); }
static void xquad(gen *g, const xform *f, dv3 a, dv3 b, dv3 c, dv3 d)
{
    xtri(g, f, a, b, c);
    xtri(g, f, a, c, d);
}

/* Axis-aligned box in local coordinates: 12 triangles, outward winding. */
static void box(gen *g, const xform *f, double x0, double y0, double z0, double x1, double y1, double z1)
{
    dv3 p[8];
    for (int i = 0; i < 8; i++) p[i] = d3(i & 1 ? x1 : x0, i & 2 ? y1 : y0, i & 4 ? z1 : z0);
    xquad(g, f, p[0], p[2], p[3], p[1]); /* -z */
    xquad(g, f, p[4], p[5], p[7], p[6]); /* +z */
    xquad(g, f, p[0], p[1], p[5], p[4]); /* -y */
    xquad(g, f, p[2], p[6], p[7], p[3]); /* +y */
    xquad(g, f, p[0], p[4], p[6], p[2]); /* -x */
    xquad(g, f, p[1], p[3], p[7], p[5]); /* +x */
}

/* Frustum along +z in local coordinates: radius r0 at z0, r1 at z1, n
 * sides (2n triangles); caps add a fan of n-2 triangles each when asked. */
static void frustum(gen *g, const xform *f, double cx, double cy, double z0, double z1, double r0, double r1,
                    int n, int cap0, int cap1)
{
    for (int i = 0; i < n; i++) {
        double s0, c0, s1, c1;
        rt_dsincos_deg(360.0 * i / n, &s0, &c0);
        rt_dsincos_deg(360.0 * (i + 1) / n, &s1, &c1);
        dv3 a = d3(cx + r0 * c0, cy + r0 * s0, z0), b = d3(cx + r0 * c1, cy + r0 * s1, z0);
        dv3 c = d3(cx + r1 * c1, cy + r1 * s1, z1), d = d3(cx + r1 * c0, cy + r1 * s0, z1);
        if (r1 > 0)
            xquad(g, f, a, b, c, d);
        else
            xtri(g, f, a, b, d);
    }
    double sa, ca;
    rt_dsincos_deg(0, &sa, &ca);
    for (int i = 1; i + 1 < n; i++) {
        double s1, c1, s2, c2;
        rt_dsincos_deg(360.0 * i / n, &s1, &c1);
        rt_dsincos_deg(360.0 * (i + 1) / n, &s2, &c2);
        if (cap0)
            xtri(g, f, d3(cx + r0 * ca, cy + r0 * sa, z0), d3(cx + r0 * c2, cy + r0 * s2, z0),
                 d3(cx + r0 * c1, cy + r0 * s1, z0));
        if (cap1)
            xtri(g, f, d3(cx + r1 * ca, cy + r1 * sa, z1), d3(cx + r1 * c1, cy + r1 * s1, z1),
                 d3(cx + r1 * c2, cy + r1 * s2, z1));
    }
}

/* Cube-sphere template: 6 faces x t x t cells x 2 triangles of unit
 * vectors (12 t^2 triangles, 36 t^2 vectors), outward winding. Vectors on
 * shared cube edges are computed from identical inputs, so the mesh is
 * watertight. Caller frees. */
static dv3 *sphere_template(int t, rt_err *e)
{
    dv3 *v = rt_calloc((size_t)36 * t * t, sizeof *v, e);
    if (!v) return NULL;
    /* Grid coordinates symmetric about 0 so that negating one (the
     * negative faces) lands exactly on another. */
    double grid[65];
    for (int k = 0; k <= t; k++) grid[k] = 2 * k <= t ? -1.0 + 2.0 * k / t : 1.0 - 2.0 * (t - k) / t;
    size_t k = 0;
    for (int face = 0; face < 6; face++) {
        int ax = face >> 1;               /* axis the face is normal to */
        double sg = (face & 1) ? -1.0 : 1.0;
        int a1 = (ax + 1) % 3, a2 = (ax + 2) % 3;
        for (int i = 0; i < t; i++)
            for (int j = 0; j < t; j++) {
                dv3 q[4];
                for (int c = 0; c < 4; c++) {
                    int ii = i + (c == 1 || c == 2), jj = j + (c >= 2);
                    double u = grid[ii], w = grid[jj];
                    double p[3];
                    p[ax] = sg;
                    p[a1] = u;
                    p[a2] = w * sg; /* flip to keep outward winding on the negative face */
                    q[c] = dnorm(d3(p[0], p[1], p[2]));
                }
                v[k++] = q[0], v[k++] = q[1], v[k++] = q[2];
                v[k++] = q[0], v[k++] = q[2], v[k++] = q[3];
            }
    }
    return v;
}

static void sphere_from(gen *g, const dv3 *tmpl, int t, dv3 c, double r)
{
    size_t n = (size_t)36 * t * t;
    for (size_t k = 0; k < n; k += 3)
        tri(g, dadd(c, dmul(tmpl[k], r)), dadd(c, dmul(tmpl[k + 1], r)), dadd(c, dmul(tmpl[k + 2], r)));
}

/* Integer hash (lowbias32) for deterministic "random" choices. */
static uint32_t hash32(uint32_t x)
{
    x ^= x >> 16;
    x *= 0x7feb352dU;
    x ^= x >> 15;
    x *= 0x846ca68bU;
    x ^= x >> 16;
    return x;
}
/* Uniform in [0, 1), exact: 24 random bits scaled by 2^-24. */
static double urand(uint32_t *st)
{
    *st = hash32(*st + 0x9e3779b9U);
    return (double)(*st >> 8) / 16777216.0;
}

/* ------------------------------------------------------------------------ */
/* Parameters                                                                */

typedef struct param {
    const char *key;
    int def, min, max;
    const char *help;
} param;

#define MAXP 6
#define BUNNY_FOVY 17.8f /* vertical field of view of the bunny camera (see gen_bunny) */

/* Parses "k=v,k=v" against the table into vals (defaults first) and writes
 * the canonical string. 0 or -1 with a message. */
static int parse_params(const char *scene, const param *tab, const char *spec, int *vals, char *canon,
                        size_t ncanon, rt_err *e)
{
    int np = 0;
    while (tab[np].key) {
        vals[np] = tab[np].def;
        np++;
    }
    int seen[MAXP] = {0};
    const char *p = spec ? spec : "";
    while (*p) {
        const char *end = strchr(p, ',');
        size_t len = end ? (size_t)(end - p) : strlen(p);
        const char *eq = memchr(p, '=', len);
        if (len == 0) return rt_errf(e, "%s: empty parameter in '%s'", scene, spec);
        if (!eq) return rt_errf(e, "%s: parameter '%.*s' is not key=value", scene, (int)len, p);
        size_t klen = (size_t)(eq - p);
        int k = -1;
        for (int i = 0; i < np; i++)
            if (strlen(tab[i].key) == klen && !memcmp(tab[i].key, p, klen)) k = i;
        if (k < 0) {
            char known[160] = "";
            for (int i = 0; i < np; i++) {
                size_t kl = strlen(known);
                snprintf(known + kl, sizeof known - kl, "%s%s", i ? ", " : "", tab[i].key);
            }
            return rt_errf(e, "%s: unknown parameter '%.*s' (known: %s)", scene, (int)klen, p,
                           np ? known : "none");
        }
        if (seen[k]) return rt_errf(e, "%s: parameter '%s' given twice", scene, tab[k].key);
        seen[k] = 1;
        const char *v = eq + 1;
        size_t vlen = len - klen - 1;
        char buf[32];
        if (vlen == 0 || vlen >= sizeof buf)
            return rt_errf(e, "%s: %s=%.*s: not an integer", scene, tab[k].key, (int)vlen, v);
        memcpy(buf, v, vlen);
        buf[vlen] = 0;
        char *q;
        long x = strtol(buf, &q, 10);
        if (*q || q == buf || buf[0] == ' ')
            return rt_errf(e, "%s: %s=%s: not an integer", scene, tab[k].key, buf);
        if (x < tab[k].min || x > tab[k].max)
            return rt_errf(e, "%s: %s=%s out of range %d..%d", scene, tab[k].key, buf, tab[k].min, tab[k].max);
        vals[k] = (int)x;
        p = end ? end + 1 : p + len;
        if (end && !*p) return rt_errf(e, "%s: empty parameter in '%s'", scene, spec);
    }
    size_t n = 0;
    canon[0] = 0;
    for (int i = 0; i < np && n < ncanon; i++) {
        int w = snprintf(canon + n, ncanon - n, "%s%s=%d", i ? "," : "", tab[i].key, vals[i]);
        if (w < 0) break;
        n += (size_t)w;
    }
    return 0;
}

/* ------------------------------------------------------------------------ */
/* sphereflake (SPD balls)                                                   */

/* 3x3 matrix applied to column vectors. */
typedef struct m3 {
    double m[3][3];
} m3;

static dv3 mapply(const m3 *M, dv3 v)
{
    return d3(M->m[0][0] * v.x + M->m[0][1] * v.y + M->m[0][2] * v.z,
              M->m[1][0] * v.x + M->m[1][1] * v.y + M->m[1][2] * v.z,
              M->m[2][0] * v.x + M->m[2][1] * v.y + M->m[2][2] * v.z);
}

/* Rotation taking +Z onto unit d (Rodrigues, with cos = d.z and
 * sin = |Z x d| computed directly, so no acos is needed). */
static m3 rot_z_to(dv3 d)
{
    m3 M;
    memset(&M, 0, sizeof M);
    if (d.z >= 0.9999) {
        M.m[0][0] = M.m[1][1] = M.m[2][2] = 1;
    } else if (d.z <= -0.9999) { /* pi about Y */
        M.m[0][0] = -1, M.m[1][1] = 1, M.m[2][2] = -1;
    } else {
        double sn = sqrt(d.x * d.x + d.y * d.y), cs = d.z;
        double kx = -d.y / sn, ky = d.x / sn; /* axis normalize(Z x d), kz = 0 */
        double oc = 1.0 - cs;
        M.m[0][0] = cs + kx * kx * oc;
        M.m[0][1] = kx * ky * oc;
        M.m[0][2] = ky * sn;
        M.m[1][0] = ky * kx * oc;
        M.m[1][1] = cs + ky * ky * oc;
        M.m[1][2] = -kx * sn;
        M.m[2][0] = -ky * sn;
        M.m[2][1] = kx * sn;
        M.m[2][2] = cs;
    }
    return M;
}

typedef struct flake {
    gen *g;
    const dv3 *tmpl;
    int tess;
    dv3 dirs[9];
} flake;

static const double flake_colours[][3] = {
    {0.80, 0.62, 0.25}, {0.72, 0.30, 0.25}, {0.30, 0.55, 0.75}, {0.40, 0.70, 0.35},
    {0.75, 0.70, 0.65}, {0.60, 0.40, 0.70}, {0.70, 0.70, 0.30}, {0.50, 0.50, 0.50},
};

static void flake_rec(flake *F, dv3 c, double r, dv3 dir, int level, int depth)
{
    const double *col = flake_colours[depth % 8];
    colour(F->g, col[0], col[1], col[2]);
    sphere_from(F->g, F->tmpl, F->tess, c, r);
    if (level == 0) return;
    m3 M = rot_z_to(dir);
    for (int i = 0; i < 9; i++) {
        dv3 off = mapply(&M, F->dirs[i]);
        flake_rec(F, dadd(c, dmul(off, r * (1.0 + 1.0 / 3.0))), r / 3.0, off, level - 1, depth + 1);
    }
}

static const param sphereflake_params[] = {
    {"level", 4, 0, 6, "recursion levels below the root sphere"},
    {"tess", 3, 1, 32, "cube-sphere cells per face edge (12*tess^2 triangles per sphere)"},
    {NULL, 0, 0, 0, NULL},
};

static int gen_sphereflake(gen *g, const int *pv)
{
    int level = pv[0], tess = pv[1];
    uint64_t nsph = 0, p9 = 1;
    for (int i = 0; i <= level; i++, p9 *= 9) nsph += p9;
    uint64_t ntri = nsph * 12u * (uint64_t)tess * (uint64_t)tess + 2;
    if (ntri > 0x7fffffffu)
        return rt_errf(g->e, "sphereflake: level=%d,tess=%d gives %llu triangles (too many)", level, tess,
                       (unsigned long long)ntri);
    if (rt_scene_reserve(g->s, (uint32_t)ntri, g->e) < 0) return -1;
    flake F;
    F.g = g;
    F.tess = tess;
    /* 6 equatorial directions at azimuths 15 + 60k degrees, 3 at elevation
     * asin(sqrt(2/3)) (z = sqrt(2/3), horizontal radius sqrt(1/3)) at
     * azimuths 45 + 120k degrees. */
    for (int k = 0; k < 6; k++) {
        double sn, cs;
        rt_dsincos_deg(15.0 + 60.0 * k, &sn, &cs);
        F.dirs[k] = d3(cs, sn, 0);
    }
    double zr = sqrt(2.0 / 3.0), hr = sqrt(1.0 / 3.0);
    for (int k = 0; k < 3; k++) {
        double sn, cs;
        rt_dsincos_deg(45.0 + 120.0 * k, &sn, &cs);
        F.dirs[6 + k] = d3(hr * cs, hr * sn, zr);
    }
    /* SPD balls.c: the spheres "shiny", lib_output_color(..., ka 0, kd 0.5,
     * ks 0.5, shine 0.5, phong 37, kt 0, ior 1): a grey mirror of 0.5; the
     * floor (ks 0) stays plain diffuse. */
    if (material(g, "balls", 0.5, 0, 1) < 0) return -1;
    dv3 *tmpl = sphere_template(tess, g->e);
    if (!tmpl) return -1;
    F.tmpl = tmpl;
    flake_rec(&F, d3(0, 0, 0), 0.5, d3(0, 0, 1), level, 0);
    free(tmpl);
    g->mat = 0;
    colour(g, 0.55, 0.55, 0.50);
    quad(g, d3(-12, -12, -0.5), d3(12, -12, -0.5), d3(12, 12, -0.5), d3(-12, 12, -0.5));
    view v = {rt_v3(2.1f, 1.3f, 1.7f), rt_v3(0, 0, 0), 45.0f,
              {rt_v3(4, 3, 2), rt_v3(1, -4, 4), rt_v3(-3, 1, 5)},
              0.45f, 0.12f, rt_v3(0.08f, 0.10f, 0.16f)};
    return set_view(g, &v);
}

/* ------------------------------------------------------------------------ */
/* grove (SPD tree, Aono & Kunii)                                            */

/* Affine map in SPD's row-vector convention: world = p . L + t. */
typedef struct aff {
    double L[3][3];
    dv3 t;
} aff;

static dv3 aapply(const aff *A, dv3 p)
{
    return d3(p.x * A->L[0][0] + p.y * A->L[1][0] + p.z * A->L[2][0] + A->t.x,
              p.x * A->L[0][1] + p.y * A->L[1][1] + p.z * A->L[2][1] + A->t.y,
              p.x * A->L[0][2] + p.y * A->L[1][2] + p.z * A->L[2][2] + A->t.z);
}

static dv3 alinear(const aff *A, dv3 p)
{
    return d3(p.x * A->L[0][0] + p.y * A->L[1][0] + p.z * A->L[2][0],
              p.x * A->L[0][1] + p.y * A->L[1][1] + p.z * A->L[2][1],
              p.x * A->L[0][2] + p.y * A->L[1][2] + p.z * A->L[2][2]);
}

/* A . B (first A, then B). */
static aff acompose(const aff *A, const aff *B)
{
    aff C;
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) C.L[i][j] = A->L[i][0] * B->L[0][j] + A->L[i][1] * B->L[1][j] + A->L[i][2] * B->L[2][j];
    C.t = aapply(B, A->t);
    return C;
}

typedef struct tree {
    gen *g;
    const dv3 *tmpl;
    int tess;
    int nside;          /* 4 * tess sides per cone: 8 * tess triangles */
    double cs[64], sn[64]; /* unit circle samples for the cone sides */
    aff child[2];       /* RotX(a) . RotZ(div) . S(c) with translation (0,0,1) */
    int version;        /* 1: apex spheres; 2: leaf clusters at the tips */
    int leaves;         /* version 2: leaf triangles per branch tip */
    uint32_t rng;       /* version 2: leaf placement state */
} tree;

/* A uniform point in the unit ball (rejection from the cube). */
static dv3 ball_point(uint32_t *st)
{
    for (;;) {
        dv3 p = d3(2 * urand(st) - 1, 2 * urand(st) - 1, 2 * urand(st) - 1);
        if (ddot(p, p) <= 1.0 && ddot(p, p) > 1e-6) return p;
    }
}

/* Version 2's foliage: a loose cluster of single-triangle leaves around a
 * branch tip, each a narrow triangle of random orientation. The cluster is
 * sparse enough that rays see through it, as through real foliage, which
 * is what makes most of the paper's grove potentially visible. */
static void leaf_cluster(tree *T, dv3 apex, double s)
{
    gen *g = T->g;
    double rc = 1.6 * s, len = 0.40 * s, wid = 0.14 * s;
    for (int i = 0; i < T->leaves; i++) {
        dv3 q = dadd(apex, dmul(ball_point(&T->rng), rc));
        dv3 d = dnorm(ball_point(&T->rng)), r = ball_point(&T->rng);
        dv3 side = dcross(d, r);
        if (ddot(side, side) < 1e-6) side = dcross(d, d3(0.36, 0.48, 0.8));
        side = dmul(dnorm(side), wid);
        dv3 m = dadd(q, dmul(d, len));
        colour(g, 0.18 + 0.12 * urand(&T->rng), 0.42 + 0.20 * urand(&T->rng), 0.14);
        tri(g, q, dadd(m, side), dsub(m, side));
    }
}

static void tree_rec(tree *T, const aff *A, double s, int depth, int n)
{
    gen *g = T->g;
    double rb = 0.15 * s, ra = 0.67 * rb;
    dv3 base = aapply(A, d3(0, 0, 0)), apex = aapply(A, d3(0, 0, 1));
    dv3 U = dnorm(alinear(A, d3(1, 0, 0))), V = dnorm(alinear(A, d3(0, 1, 0)));
    /* Bark darkens towards the trunk; the apex spheres are foliage-green on
     * the outer levels and bark-coloured near the trunk. */
    colour(g, 0.42 + 0.02 * depth, 0.28 + 0.015 * depth, 0.16);
    for (int i = 0; i < T->nside; i++) {
        int j = i + 1 == T->nside ? 0 : i + 1;
        dv3 ui = dadd(dmul(U, T->cs[i]), dmul(V, T->sn[i])), uj = dadd(dmul(U, T->cs[j]), dmul(V, T->sn[j]));
        quad(g, dadd(base, dmul(ui, rb)), dadd(base, dmul(uj, rb)), dadd(apex, dmul(uj, ra)), dadd(apex, dmul(ui, ra)));
    }
    if (T->version == 1) {
        if (n - depth <= 2)
            colour(g, 0.22 + 0.03 * (depth & 3), 0.50 + 0.04 * (depth & 1), 0.18);
        /* The outermost apex spheres stand for foliage clusters: 12x the
         * apex radius, so the canopy hides the inner branches as leaves
         * would. */
        sphere_from(g, T->tmpl, T->tess, apex, depth == n ? 12.0 * ra : ra);
    } else if (depth == n) {
        leaf_cluster(T, apex, s);
    }
    if (depth == n) return;
    for (int i = 0; i < 2; i++) {
        aff C = acompose(&T->child[i], A);
        tree_rec(T, &C, s * 0.67, depth + 1, n);
    }
}

static aff rotx(double deg)
{
    aff A;
    memset(&A, 0, sizeof A);
    double s, c;
    rt_dsincos_deg(deg, &s, &c);
    A.L[0][0] = 1;
    A.L[1][1] = c, A.L[1][2] = s;
    A.L[2][1] = -s, A.L[2][2] = c;
    return A;
}

static aff rotz(double deg)
{
    aff A;
    memset(&A, 0, sizeof A);
    double s, c;
    rt_dsincos_deg(deg, &s, &c);
    A.L[0][0] = c, A.L[0][1] = s;
    A.L[1][0] = -s, A.L[1][1] = c;
    A.L[2][2] = 1;
    return A;
}

static aff scale_tr(double k, dv3 t)
{
    aff A;
    memset(&A, 0, sizeof A);
    A.L[0][0] = A.L[1][1] = A.L[2][2] = k;
    A.t = t;
    return A;
}

static const param grove_params[] = {
    {"v", 2, 1, 2, "version: 1 = apex-sphere canopies (the scene before 2), 2 = leaf clusters matched to the paper"},
    {"trees", 5, 1, 64, "number of trees"},
    {"depth", 7, 0, 14, "branching depth n: 2^(n+1)-1 branches per tree"},
    {"tess", 3, 1, 16, "cone sides 4*tess (8*tess triangles); v=1: apex spheres 12*tess^2"},
    {"leaves", 208, 1, 4096, "v=2: leaf triangles per branch tip (2^n tips per tree)"},
    {NULL, 0, 0, 0, NULL},
};

static int gen_grove(gen *g, const int *pv)
{
    int version = pv[0], ntrees = pv[1], depth = pv[2], tess = pv[3], leaves = pv[4];
    uint64_t per = ((uint64_t)1 << (depth + 1)) - 1, tips = (uint64_t)1 << depth;
    uint64_t ntri = version == 1 ? (uint64_t)ntrees * per * (8u * (uint64_t)tess + 12u * (uint64_t)tess * tess) + 2
                                 : (uint64_t)ntrees * (per * 8u * (uint64_t)tess + tips * (uint64_t)leaves) + 2;
    if (ntri > 0x7fffffffu)
        return rt_errf(g->e, "grove: %llu triangles (too many)", (unsigned long long)ntri);
    if (rt_scene_reserve(g->s, (uint32_t)ntri, g->e) < 0) return -1;
    tree T;
    T.g = g;
    T.tess = tess;
    T.nside = 4 * tess;
    T.version = version;
    T.leaves = leaves;
    T.rng = 0x6b43a9b5U;
    for (int i = 0; i < T.nside; i++) rt_dsincos_deg(360.0 * i / T.nside, &T.sn[i], &T.cs[i]);
    aff r1 = rotx(40), r2 = rotz(90), s1 = scale_tr(0.65, d3(0, 0, 1));
    aff t1 = acompose(&r1, &r2);
    T.child[0] = acompose(&t1, &s1);
    aff q1 = rotx(25), q2 = rotz(230), s2 = scale_tr(0.70, d3(0, 0, 1));
    aff t2 = acompose(&q1, &q2);
    T.child[1] = acompose(&t2, &s2);
    dv3 *tmpl = sphere_template(tess, g->e);
    if (!tmpl) return -1;
    T.tmpl = tmpl;
    /* Trees on a sunflower spiral (golden angle), each turned and scaled a
     * little differently; tree 0 stands at the origin. */
    double maxr = 0;
    for (int i = 0; i < ntrees; i++) {
        double ang = 137.5 * i, rr = 1.9 * sqrt((double)i);
        double sn, cs;
        rt_dsincos_deg(ang, &sn, &cs);
        double k = 1.0 - 0.06 * (i % 4);
        aff rz = rotz(71.0 * i), sc = scale_tr(k, d3(rr * cs, rr * sn, 0));
        aff A = acompose(&rz, &sc);
        tree_rec(&T, &A, k, 0, depth);
        if (rr > maxr) maxr = rr;
    }
    free(tmpl);
    colour(g, 0.42, 0.50, 0.30);
    quad(g, d3(-50, -50, 0), d3(50, -50, 0), d3(50, 50, 0), d3(-50, 50, 0));
    /* Camera: SPD tree's view direction, (4.5,0.4,0.5) from the target,
     * pulled back so the spiral (radius maxr + 1) fills the view width. */
    double dist = 0.8 * (maxr + 1.0) / 0.41421356237309503; /* tan(22.5 deg) */
    dv3 dir = dnorm(d3(4.5, 0.4, 0.5));
    dv3 at = d3(0, 0, 1.5);
    if (ntrees > 1) at = d3(0, 0, 1.7);
    dv3 eye = dadd(at, dmul(dir, ntrees > 1 ? dist : 4.54)); /* 1 tree: exactly SPD's view */
    /* Light 0 at the camera (the paper's setting), light 1 high to the
     * left, light 2 low from behind the grove. */
    view v = {tof(eye), tof(at), 45.0f,
              {tof(eye), tof(d3(0.3 * dist, 0.8 * dist, 0.9 * dist)), tof(d3(-0.6 * dist, -0.7 * dist, 0.4 * dist))},
              0.42f, 0.15f, rt_v3(0.55f, 0.65f, 0.85f)};
    return set_view(g, &v);
}

/* ------------------------------------------------------------------------ */
/* room: a furnished flat of 3 x 2 rooms                                     */

#define RX 5.0    /* room size along x (m) */
#define RY 4.0    /* room size along y */
#define RH 2.6    /* ceiling height */
#define WT 0.12   /* wall thickness */
#define DW 0.9    /* door width */
#define DH 2.1    /* door height */

static const xform ident = {1, 0, {0, 0, 0}, 1};

/* A wall along x (axis 0) or y (axis 1) from a to b at coordinate c, with
 * an optional door centred at d (d < 0: none). 12 or 36 triangles. */
static void wall(gen *g, int axis, double c, double a, double b, double d)
{
    colour(g, 0.80, 0.77, 0.68);
    double h = WT / 2;
    double segs[2][2] = {{a, b}, {0, 0}};
    int ns = 1;
    if (d >= 0) {
        segs[0][1] = d - DW / 2;
        segs[1][0] = d + DW / 2, segs[1][1] = b;
        ns = 2;
    }
    for (int i = 0; i < ns; i++) {
        if (axis == 0) box(g, &ident, segs[i][0], c - h, 0, segs[i][1], c + h, RH);
        else box(g, &ident, c - h, segs[i][0], 0, c + h, segs[i][1], RH);
    }
    if (d >= 0) { /* lintel */
        if (axis == 0) box(g, &ident, d - DW / 2, c - h, DH, d + DW / 2, c + h, RH);
        else box(g, &ident, c - h, d - DW / 2, DH, c + h, d + DW / 2, RH);
    }
}

/* Parquet floor of one room: 0.5 m tiles in two shades; plain ceiling. */
static void floor_ceiling(gen *g, double x0, double y0)
{
    int nx = (int)(RX / 0.5), ny = (int)(RY / 0.5);
    for (int i = 0; i < nx; i++)
        for (int j = 0; j < ny; j++) {
            if ((i + j) & 1) colour(g, 0.55, 0.36, 0.20);
            else colour(g, 0.48, 0.30, 0.17);
            double xa = x0 + 0.5 * i, ya = y0 + 0.5 * j;
            quad(g, d3(xa, ya, 0), d3(xa + 0.5, ya, 0), d3(xa + 0.5, ya + 0.5, 0), d3(xa, ya + 0.5, 0));
        }
    colour(g, 0.88, 0.88, 0.86);
    quad(g, d3(x0, y0, RH), d3(x0, y0 + RY, RH), d3(x0 + RX, y0 + RY, RH), d3(x0 + RX, y0, RH));
}

/* Table with turned legs: top 1.6 x 0.9 (local origin at the centre). */
static void table(gen *g, const xform *f, double w, double dpt)
{
    colour(g, 0.50, 0.32, 0.18);
    box(g, f, -w / 2, -dpt / 2, 0.72, w / 2, dpt / 2, 0.76);
    for (int i = 0; i < 4; i++) {
        double x = (i & 1 ? 1 : -1) * (w / 2 - 0.08), y = (i & 2 ? 1 : -1) * (dpt / 2 - 0.08);
        frustum(g, f, x, y, 0.0, 0.30, 0.025, 0.035, 16, 1, 0);
        frustum(g, f, x, y, 0.30, 0.36, 0.035, 0.045, 16, 0, 0);
        frustum(g, f, x, y, 0.36, 0.72, 0.045, 0.03, 16, 0, 1);
    }
}

/* Chair facing -y in local coordinates (seat centred on the origin). */
static void chair(gen *g, const xform *f)
{
    colour(g, 0.45, 0.28, 0.15);
    box(g, f, -0.22, -0.22, 0.44, 0.22, 0.22, 0.48);
    for (int i = 0; i < 4; i++) {
        double x = (i & 1 ? 0.19 : -0.19), y = (i & 2 ? 0.19 : -0.19);
        double top = (i & 2) ? 0.95 : 0.44;
        frustum(g, f, x, y, 0, top, 0.018, 0.016, 12, 1, 1);
    }
    colour(g, 0.55, 0.36, 0.20);
    for (int k = 0; k < 3; k++) box(g, f, -0.18, 0.18, 0.58 + 0.12 * k, 0.18, 0.2, 0.64 + 0.12 * k);
}

/* Bookcase against a wall: back at local y = +0.3, open towards -y. */
static void bookcase(gen *g, const xform *f, double w, int shelves, uint32_t seed)
{
    double ht = 0.35 * shelves + 0.1;
    colour(g, 0.40, 0.26, 0.15);
    box(g, f, -w / 2, -0.0, 0, -w / 2 + 0.03, 0.3, ht);
    box(g, f, w / 2 - 0.03, -0.0, 0, w / 2, 0.3, ht);
    box(g, f, -w / 2, 0.28, 0, w / 2, 0.3, ht);
    for (int k = 0; k <= shelves; k++) box(g, f, -w / 2 + 0.03, 0, 0.35 * k + 0.05, w / 2 - 0.03, 0.28, 0.35 * k + 0.08);
    uint32_t st = seed;
    static const double pal[][3] = {{0.60, 0.12, 0.10}, {0.12, 0.25, 0.50}, {0.15, 0.40, 0.20}, {0.70, 0.60, 0.30},
                                    {0.35, 0.20, 0.35}, {0.80, 0.78, 0.70}, {0.20, 0.20, 0.22}, {0.55, 0.35, 0.15}};
    for (int k = 0; k < shelves; k++) {
        double x = -w / 2 + 0.04, z0 = 0.35 * k + 0.08;
        for (;;) {
            double bw = 0.018 + 0.03 * urand(&st), bh = 0.18 + 0.10 * urand(&st), bd = 0.16 + 0.08 * urand(&st);
            if (x + bw > w / 2 - 0.04) break;
            int c = (int)(8 * urand(&st));
            colour(g, pal[c][0], pal[c][1], pal[c][2]);
            box(g, f, x, 0.27 - bd, z0, x + bw, 0.27, z0 + bh);
            x += bw + 0.002;
        }
    }
}

/* Floor lamp: round base, stem, open shade and a bulb. */
static void lamp(gen *g, const xform *f, const dv3 *tmpl, int tess)
{
    colour(g, 0.25, 0.25, 0.27);
    frustum(g, f, 0, 0, 0, 0.03, 0.16, 0.15, 32, 1, 1);
    frustum(g, f, 0, 0, 0.03, 1.45, 0.012, 0.012, 12, 0, 1);
    colour(g, 0.92, 0.86, 0.70);
    frustum(g, f, 0, 0, 1.35, 1.60, 0.25, 0.14, 48, 0, 0);
    colour(g, 1.0, 0.97, 0.85);
    sphere_from(g, tmpl, tess, xapply(f, d3(0, 0, 1.47)), 0.05);
}

/* Sofa along local x, back towards +y. */
static void sofa(gen *g, const xform *f, double w)
{
    colour(g, 0.30, 0.35, 0.50);
    box(g, f, -w / 2, -0.45, 0.10, w / 2, 0.45, 0.42);
    box(g, f, -w / 2, 0.25, 0.42, w / 2, 0.45, 0.85);
    box(g, f, -w / 2, -0.45, 0.42, -w / 2 + 0.18, 0.25, 0.62);
    box(g, f, w / 2 - 0.18, -0.45, 0.42, w / 2, 0.25, 0.62);
    for (int k = 0; k < 3; k++) {
        double x0 = -w / 2 + 0.18 + k * (w - 0.36) / 3;
        box(g, f, x0 + 0.01, -0.42, 0.42, x0 + (w - 0.36) / 3 - 0.01, 0.24, 0.52);
    }
    colour(g, 0.2, 0.15, 0.1);
    for (int i = 0; i < 4; i++)
        frustum(g, f, (i & 1 ? 1 : -1) * (w / 2 - 0.06), (i & 2 ? 1 : -1) * 0.39, 0, 0.10, 0.025, 0.025, 12, 1, 0);
}

/* Potted plant: pot and a fan of long leaves (2 triangles each). */
static void plant(gen *g, const xform *f, int nleaf, uint32_t seed)
{
    colour(g, 0.60, 0.35, 0.25);
    frustum(g, f, 0, 0, 0, 0.35, 0.13, 0.18, 24, 1, 0);
    uint32_t st = seed;
    for (int i = 0; i < nleaf; i++) {
        double az = 360.0 * urand(&st), el = 0.35 + 0.5 * urand(&st), len = 0.30 + 0.25 * urand(&st);
        double sa, ca;
        rt_dsincos_deg(az, &sa, &ca);
        dv3 base = d3(0.04 * ca, 0.04 * sa, 0.33);
        dv3 dir = dnorm(d3(ca, sa, el * 2.0));
        dv3 side = d3(-sa * 0.03, ca * 0.03, 0);
        dv3 mid = dadd(base, dmul(dir, len * 0.5));
        dv3 tip = dadd(dadd(base, dmul(dir, len)), d3(0, 0, -0.08 * len));
        colour(g, 0.15 + 0.1 * urand(&st), 0.40 + 0.2 * urand(&st), 0.15);
        xtri(g, f, base, dadd(mid, side), dsub(mid, side));
        xtri(g, f, dsub(mid, side), dadd(mid, side), tip);
    }
}

/* Bed along local y, head at +y. */
static void bed(gen *g, const xform *f)
{
    colour(g, 0.45, 0.30, 0.18);
    box(g, f, -0.8, -1.0, 0.15, 0.8, 1.0, 0.35);
    box(g, f, -0.8, 0.95, 0, 0.8, 1.05, 0.95);
    colour(g, 0.85, 0.85, 0.90);
    box(g, f, -0.78, -0.98, 0.35, 0.78, 0.98, 0.52);
    colour(g, 0.95, 0.95, 0.95);
    box(g, f, -0.7, 0.55, 0.52, -0.05, 0.9, 0.62);
    box(g, f, 0.05, 0.55, 0.52, 0.7, 0.9, 0.62);
    colour(g, 0.2, 0.15, 0.1);
    for (int i = 0; i < 4; i++)
        frustum(g, f, (i & 1 ? 1 : -1) * 0.74, (i & 2 ? 1 : -1) * 0.94, 0, 0.15, 0.03, 0.03, 12, 1, 0);
}

static const param room_params[] = {
    {"v", 2, 1, 2, "version: 1 = the scene before 2, 2 = camera and lights matched to the paper"},
    {NULL, 0, 0, 0, NULL},
};

static int gen_room(gen *g, const int *pv)
{
    int version = pv[0];
    if (rt_scene_reserve(g->s, 49152, g->e) < 0) return -1;
    dv3 *tmpl = sphere_template(4, g->e);
    if (!tmpl) return -1;
    /* Rooms (i, j), i = 0..2 along x, j = 0..1 along y. */
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 2; j++) floor_ceiling(g, RX * i, RY * j);
    /* Outer walls. */
    wall(g, 0, 0, 0, 3 * RX, -1);
    wall(g, 0, 2 * RY, 0, 3 * RX, -1);
    wall(g, 1, 0, 0, 2 * RY, -1);
    wall(g, 1, 3 * RX, 0, 2 * RY, -1);
    /* Inner walls with doors: x = 5 and x = 10 (one door per room row),
     * y = 4 (one door per room column). */
    for (int i = 1; i <= 2; i++)
        for (int j = 0; j < 2; j++) wall(g, 1, RX * i, RY * j, RY * (j + 1), RY * j + (j ? 1.2 : 2.0));
    for (int i = 0; i < 3; i++) wall(g, 0, RY, RX * i, RX * (i + 1), RX * i + (i == 1 ? 3.6 : 2.5));
    /* Room (0,0), the living room the camera stands in. */
    xform f = xf(2.9, 1.5, 0, 0);
    table(g, &f, 1.6, 0.9);
    for (int k = 0; k < 4; k++) {
        xform c = xf(2.9 + (k & 1 ? 0.45 : -0.45), 1.5 + (k & 2 ? 0.65 : -0.65), 0, k & 2 ? 0 : 180);
        chair(g, &c);
    }
    f = xf(1.6, RY - WT / 2 - 0.31, 0, 0);
    bookcase(g, &f, 1.8, 6, 11);
    f = xf(3.7, RY - WT / 2 - 0.31, 0, 0);
    bookcase(g, &f, 1.2, 6, 12);
    f = xf(4.5, 0.5, 0, 0);
    lamp(g, &f, tmpl, 4);
    f = xf(0.65, 2.4, 0, 90);
    plant(g, &f, 120, 13);
    /* Room (1,0): library. */
    for (int k = 0; k < 4; k++) {
        f = xf(RX + 0.75 + 1.15 * k, WT / 2 + 0.31, 0, 180);
        bookcase(g, &f, 1.1, 6, 20 + k);
    }
    f = xf(RX + 2.5, 2.4, 0, 90);
    table(g, &f, 1.4, 0.8);
    for (int k = 0; k < 2; k++) {
        xform c = xf(RX + 2.5 + (k ? 0.6 : -0.6), 2.4, 0, k ? 270 : 90);
        chair(g, &c);
    }
    f = xf(2 * RX - 0.5, RY - 0.5, 0, 0);
    lamp(g, &f, tmpl, 4);
    /* Room (2,0): dining. */
    f = xf(2 * RX + 2.5, 2.0, 0, 0);
    table(g, &f, 2.2, 1.0);
    for (int k = 0; k < 6; k++) {
        xform c = xf(2 * RX + 1.8 + 0.7 * (k % 3), 2.0 + (k < 3 ? -0.7 : 0.7), 0, k < 3 ? 180 : 0);
        chair(g, &c);
    }
    f = xf(3 * RX - WT / 2 - 0.31, 2.0, 0, 270);
    bookcase(g, &f, 1.6, 6, 31);
    f = xf(2 * RX + 0.65, 0.65, 0, 0);
    plant(g, &f, 100, 32);
    /* A bowl of fruit on the dining table. */
    f = xf(2 * RX + 2.5, 2.0, 0.76, 0);
    colour(g, 0.85, 0.85, 0.80);
    frustum(g, &f, 0, 0, 0, 0.08, 0.08, 0.16, 32, 1, 0);
    for (int k = 0; k < 12; k++) {
        double sa, ca;
        rt_dsincos_deg(30.0 * k, &sa, &ca);
        double rr = k < 8 ? 0.09 : 0.04;
        colour(g, k & 1 ? 0.85 : 0.75, k & 2 ? 0.55 : 0.20, 0.10);
        sphere_from(g, tmpl, 4, d3(2 * RX + 2.5 + rr * ca, 2.0 + rr * sa, 0.76 + (k < 8 ? 0.1 : 0.17)), 0.04);
    }
    /* Room (0,1): bedroom. */
    f = xf(2.5, 2 * RY - WT / 2 - 1.05, 0, 0);
    bed(g, &f);
    f = xf(0.8, RY + 0.6, 0, 0);
    lamp(g, &f, tmpl, 4);
    f = xf(WT / 2 + 0.31, RY + 2.0, 0, 90);
    bookcase(g, &f, 1.0, 5, 41);
    f = xf(WT / 2 + 0.31, RY + 3.2, 0, 90);
    bookcase(g, &f, 1.2, 5, 42);
    /* Room (1,1): study. */
    f = xf(RX + 2.5, RY + 2.5, 0, 0);
    table(g, &f, 1.5, 0.75);
    {
        xform c = xf(RX + 2.5, RY + 1.9, 0, 180);
        chair(g, &c);
    }
    for (int k = 0; k < 3; k++) {
        f = xf(RX + 0.9 + 1.6 * k, 2 * RY - WT / 2 - 0.31, 0, 0);
        bookcase(g, &f, 1.5, 6, 50 + k);
    }
    f = xf(2 * RX - 0.5, RY + 0.5, 0, 0);
    lamp(g, &f, tmpl, 4);
    f = xf(RX + 0.65, RY + 0.65, 0, 0);
    plant(g, &f, 100, 54);
    /* Room (2,1): lounge. */
    f = xf(2 * RX + 2.5, 2 * RY - WT / 2 - 0.5, 0, 0);
    sofa(g, &f, 2.2);
    f = xf(2 * RX + 2.5, RY + 1.6, 0, 0);
    table(g, &f, 1.0, 0.6);
    f = xf(3 * RX - 0.5, 2 * RY - 0.5, 0, 0);
    lamp(g, &f, tmpl, 4);
    f = xf(3 * RX - WT / 2 - 0.31, RY + 1.6, 0, 270);
    bookcase(g, &f, 1.6, 6, 61);
    f = xf(2 * RX + 0.65, RY + 0.65, 0, 0);
    plant(g, &f, 120, 62);
    free(tmpl);
    /* Camera in a corner of the living room, looking through the door
     * into the library; light 0 at the camera, lights 1 and 2 near the
     * living-room ceiling. */
    view v = {rt_v3(0.5f, 0.45f, 1.65f), rt_v3(5.0f, 2.3f, 1.0f), 50.0f,
              {rt_v3(0.5f, 0.45f, 1.65f), rt_v3(2.9f, 1.5f, 2.35f), rt_v3(4.3f, 3.2f, 2.2f)},
              0.40f, 0.15f, rt_v3(0, 0, 0)};
    if (version >= 2) {
        /* Version 2 (docs/scenes.md): from the living room's door corner
         * towards its bookcases and the bedroom door, so the primary rays
         * test about as many triangles as the paper's room; lights 1 and 2
         * low (under the table, by the plant), so shadow rays pass under
         * the furniture and test ~5% more. */
        view v2 = {rt_v3(4.8f, 1.0f, 1.75f), rt_v3(1.6f, 3.6f, 1.0f), 50.0f,
                   {rt_v3(4.8f, 1.0f, 1.75f), rt_v3(2.9f, 1.5f, 0.3f), rt_v3(1.0f, 1.0f, 0.3f)},
                   0.40f, 0.15f, rt_v3(0, 0, 0)};
        v = v2;
    }
    return set_view(g, &v);
}

/* ------------------------------------------------------------------------ */
/* cornell                                                                   */

static const param cornell_params[] = {
    {"glass", 1, 0, 1, "a glass sphere in the front left (0: the plain 36-triangle box)"},
    {NULL, 0, 0, 0, NULL},
};

/* A box of size (w, d, h) standing on the floor at (x, y), turned. */
static void cbox(gen *g, double x, double y, double w, double d, double h, double deg)
{
    xform f = xf(x, y, 0, deg);
    box(g, &f, -w / 2, -d / 2, 0, w / 2, d / 2, h);
}

static int gen_cornell(gen *g, const int *pv)
{
    int glass = pv[0];
    /* Unit box x, y, z in [0, 1], open at y = 0 (front), z up. */
    colour(g, 0.73, 0.73, 0.73);
    quad(g, d3(0, 0, 0), d3(1, 0, 0), d3(1, 1, 0), d3(0, 1, 0)); /* floor */
    quad(g, d3(0, 0, 1), d3(0, 1, 1), d3(1, 1, 1), d3(1, 0, 1)); /* ceiling */
    quad(g, d3(0, 1, 0), d3(1, 1, 0), d3(1, 1, 1), d3(0, 1, 1)); /* back */
    colour(g, 0.63, 0.065, 0.05);
    quad(g, d3(0, 0, 0), d3(0, 1, 0), d3(0, 1, 1), d3(0, 0, 1)); /* left, red */
    colour(g, 0.14, 0.45, 0.09);
    quad(g, d3(1, 0, 0), d3(1, 0, 1), d3(1, 1, 1), d3(1, 1, 0)); /* right, green */
    colour(g, 0.95, 0.95, 0.90);
    quad(g, d3(0.4, 0.4, 0.999), d3(0.4, 0.6, 0.999), d3(0.6, 0.6, 0.999), d3(0.6, 0.4, 0.999)); /* lamp */
    colour(g, 0.73, 0.73, 0.73);
    cbox(g, 0.33, 0.62, 0.30, 0.30, 0.60, 17);  /* tall box */
    cbox(g, 0.66, 0.32, 0.30, 0.30, 0.30, -17); /* short box */
    if (glass) {
        /* Glass sphere (ior 1.5, clear; Fresnel reflection is the tracer's)
         * on the floor between the tall block and the open side, clear of
         * both blocks; its colour is what diffuse-only modes show. */
        if (material(g, "glass", 0, 1, 1.5) < 0) return -1;
        dv3 *tmpl = sphere_template(4, g->e);
        if (!tmpl) return -1;
        colour(g, 0.85, 0.90, 0.95);
        sphere_from(g, tmpl, 4, d3(0.25, 0.22, 0.12), 0.12);
        free(tmpl);
        g->mat = 0;
    }
    view v = {rt_v3(0.5f, -1.35f, 0.5f), rt_v3(0.5f, 0.5f, 0.5f), 40.0f,
              {rt_v3(0.5f, -0.9f, 0.55f) /* near the camera */, rt_v3(0.5f, 0.5f, 0.95f) /* under the lamp */,
               rt_v3(0.85f, 0.15f, 0.80f)},
              0.45f, 0.12f, rt_v3(0, 0, 0)};
    return set_view(g, &v);
}

/* ------------------------------------------------------------------------ */
/* knot: a (p, q) torus knot tube                                            */

static const param knot_params[] = {
    {"p", 2, 1, 64, "turns around the torus axis"},
    {"q", 3, 1, 64, "turns through the torus hole"},
    {"segs", 64, 3, 65536, "segments along the curve"},
    {"sides", 8, 3, 256, "sides around the tube (2*segs*sides triangles)"},
    {NULL, 0, 0, 0, NULL},
};

static int gen_knot(gen *g, const int *pv)
{
    int P = pv[0], Q = pv[1], segs = pv[2], sides = pv[3];
    const double R = 1.0, r = 0.4, tube = 0.12;
    if (rt_scene_reserve(g->s, (uint32_t)(2u * segs * sides), g->e) < 0) return -1;
    dv3 *ring = rt_calloc((size_t)(segs + 1) * sides, sizeof *ring, g->e);
    if (!ring) return -1;
    double *cs = rt_calloc((size_t)sides * 2, sizeof *cs, g->e);
    if (!cs) {
        free(ring);
        return -1;
    }
    for (int j = 0; j < sides; j++) rt_dsincos_deg(360.0 * j / sides, &cs[2 * j + 1], &cs[2 * j]);
    for (int i = 0; i < segs; i++) {
        /* Angles in degrees reduced exactly with integer arithmetic. */
        double sp, cp, sq, cq;
        rt_dsincos_deg(360.0 * (double)(((long long)P * i) % segs) / segs, &sp, &cp);
        rt_dsincos_deg(360.0 * (double)(((long long)Q * i) % segs) / segs, &sq, &cq);
        double rr = R + r * cq;
        dv3 C = d3(rr * cp, rr * sp, r * sq);
        dv3 T = dnorm(d3(-Q * r * sq * cp - P * rr * sp, -Q * r * sq * sp + P * rr * cp, Q * r * cq));
        dv3 D = d3(r * cq * cp, r * cq * sp, r * sq);
        dv3 N = dnorm(dsub(D, dmul(T, ddot(D, T))));
        dv3 B = dcross(T, N);
        for (int j = 0; j < sides; j++)
            ring[(size_t)i * sides + j] = dadd(C, dmul(dadd(dmul(N, cs[2 * j]), dmul(B, cs[2 * j + 1])), tube));
    }
    /* Ralovich & Magdics, Fig. 1c: the "Torus Knot" scene "with reflections
     * and shadows from a single light source"; the paper gives no
     * reflectivity (rho in its Eq. 1), so the knot is a grey mirror of 0.5,
     * the sphereflake's SPD value. */
    if (material(g, "knot", 0.5, 0, 1) < 0) {
        free(ring);
        free(cs);
        return -1;
    }
    for (int i = 0; i < segs; i++) {
        int i2 = (i + 1) % segs;
        /* Colour runs once around the spectrum along the curve. */
        double t = (double)i / segs;
        double cr = t < 0.5 ? 0.85 - 1.2 * t : 0.25 + 1.2 * (t - 0.5);
        colour(g, cr, 0.35 + 0.3 * t, 0.85 - 0.5 * t);
        for (int j = 0; j < sides; j++) {
            int j2 = (j + 1) % sides;
            quad(g, ring[(size_t)i * sides + j], ring[(size_t)i2 * sides + j], ring[(size_t)i2 * sides + j2],
                 ring[(size_t)i * sides + j2]);
        }
    }
    free(ring);
    free(cs);
    view v = {rt_v3(0.0f, -3.4f, 2.4f), rt_v3(0, 0, 0), 45.0f,
              {rt_v3(0.3f, -3.0f, 2.6f), rt_v3(3.0f, 2.0f, 4.0f), rt_v3(-3.0f, 1.0f, 3.0f)},
              0.45f, 0.12f, rt_v3(0.1f, 0.1f, 0.12f)};
    return set_view(g, &v);
}

/* ------------------------------------------------------------------------ */
/* Bunny: the Stanford bunny of Purcell et al. 2002, from data/bunny         */

static const param bunny_params[] = {
    {NULL, 0, 0, 0, NULL},
};

/* Loads the shipped PLY (the source tree's data first, then the installed
 * copy), turns it z-up ((x, y, z) -> (x, -z, y)) and frames it from the
 * front so that about 82% of the primary rays hit it: the paper's s = 0.82
 * (Figure 6) for a camera it does not give. */
static int gen_bunny(gen *g, const int *pv)
{
    (void)pv;
    static const char *const dirs[] = {RT_SRCDATADIR, RT_DATADIR};
    char path[1024];
    rt_ply_mesh b;
    int found = 0;
    rt_err e2 = {0};
    for (int i = 0; i < 2 && !found; i++) {
        snprintf(path, sizeof path, "%s/bunny/bun_zipper.ply", dirs[i]);
        FILE *f = fopen(path, "rb");
        if (!f) continue;
        fclose(f);
        if (rt_ply_read_file(path, &b, &e2) < 0) return rt_errf(g->e, "bunny: %s", e2.msg); /* the shared reader */
        found = 1;
    }
    if (!found) return rt_errf(g->e, "bunny: bunny/bun_zipper.ply found neither in %s nor in %s", RT_SRCDATADIR, RT_DATADIR);
    int huge = b.nidx / 3 > UINT32_MAX / 2;
    if (huge || rt_scene_reserve(g->s, (uint32_t)(b.nidx / 3), g->e) < 0) {
        rt_ply_mesh_free(&b);
        return huge ? rt_errf(g->e, "bunny: too many triangles") : -1;
    }
    colour(g, 0.85, 0.78, 0.66);
    for (size_t t = 0; t < b.nidx && !g->failed; t += 3) {
        dv3 v[3];
        for (int k = 0; k < 3; k++) {
            const rt_vec3 p = b.v[b.idx[t + (size_t)k]];
            v[k] = d3(p.x, -(double)p.z, p.y);
        }
        tri(g, v[0], v[1], v[2]);
    }
    rt_ply_mesh_free(&b);
    /* bounds after the turn: x -0.095..0.061, y -0.059..0.062, z 0.033..0.187 */
    view v = {rt_v3(-0.012f, -0.36f, 0.1f), rt_v3(-0.012f, 0.0f, 0.095f), BUNNY_FOVY,
              {rt_v3(-0.25f, -0.35f, 0.45f), rt_v3(0.3f, -0.3f, 0.35f), rt_v3(0.0f, 0.2f, 0.6f)},
              0.6f, 0.15f, rt_v3(0.05f, 0.05f, 0.08f)};
    return set_view(g, &v);
}

/* ------------------------------------------------------------------------ */
/* Registry                                                                  */

typedef struct builtin {
    const char *name;
    const char *desc;
    const param *params;
    int (*fn)(gen *g, const int *pv);
} builtin;

static const builtin builtins[] = {
    {"sphereflake", "Haines' SPD sphereflake (balls): 7,381 mirror spheres, 797,150 triangles at level 4",
     sphereflake_params, gen_sphereflake},
    {"grove", "five SPD-style recursive trees with leaf clusters, 163,722 triangles (v=1: apex spheres, 168,302)",
     grove_params, gen_grove},
    {"room", "furnished flat of six rooms with doorways, bookcases and lamps, 46,588 triangles", room_params,
     gen_room},
    {"cornell", "Cornell box with two blocks and a glass sphere, 228 triangles (glass=0: 36)", cornell_params,
     gen_cornell},
    {"knot", "(2,3) torus-knot tube, mirror 0.5, 1,024 triangles", knot_params, gen_knot},
    {"bunny", "the Stanford bunny (data/bunny/bun_zipper.ply), 69,451 triangles, framed for Purcell et al. 2002",
     bunny_params, gen_bunny},
};

#define NBUILTIN (sizeof builtins / sizeof builtins[0])

const char *const rt_scene_builtin_names[] = {"sphereflake", "grove", "room", "cornell", "knot", "bunny", NULL};

const char *rt_scene_describe(const char *name)
{
    for (size_t i = 0; i < NBUILTIN; i++)
        if (!strcmp(builtins[i].name, name)) return builtins[i].desc;
    return NULL;
}

int rt_scene_builtin_params(const char *name, char *buf, size_t n)
{
    for (size_t i = 0; i < NBUILTIN; i++)
        if (!strcmp(builtins[i].name, name)) {
            size_t k = 0;
            buf[0] = 0;
            for (const param *p = builtins[i].params; p->key && k < n; p++) {
                int w = snprintf(buf + k, n - k, "%s%s=%d (%d..%d): %s", k ? "; " : "", p->key, p->def, p->min,
                                 p->max, p->help);
                if (w < 0) break;
                k += (size_t)w;
            }
            return 0;
        }
    return -1;
}

rt_scene *rt_scene_builtin(const char *name, const char *params, rt_err *e)
{
    const builtin *b = NULL;
    for (size_t i = 0; i < NBUILTIN; i++)
        if (!strcmp(builtins[i].name, name)) b = &builtins[i];
    if (!b) {
        rt_errf(e, "unknown scene '%s' (not .obj/.ply/.pbrt, not a built-in; see 'raytraffic scene list')", name);
        return NULL;
    }
    int vals[MAXP];
    char canon[128];
    if (parse_params(name, b->params, params, vals, canon, sizeof canon, e) < 0) return NULL;
    rt_scene *s = rt_scene_new(0, e);
    if (!s) return NULL;
    snprintf(s->name, sizeof s->name, "%s", name);
    snprintf(s->params, sizeof s->params, "%s", canon);
    gen g = {s, {0.7f, 0.7f, 0.7f}, 0, e, 0};
    if (b->fn(&g, vals) < 0 || g.failed || rt_scene_finish(s, e) < 0) {
        rt_scene_free(s);
        return NULL;
    }
    return s;
}
