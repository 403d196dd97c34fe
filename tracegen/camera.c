/* camera.c -- the shared pinhole camera (see camera.h). */
#include "camera.h"

#include <math.h>
#include <stdlib.h>

double rt_cam_tan(double x)
{
    double s, c;
    rt_dsincos_deg(x * (180.0 / 3.14159265358979323846), &s, &c);
    return s / c;
}

double rt_cam_tan_deg(double deg)
{
    double s, c;
    rt_dsincos_deg(deg, &s, &c);
    return s / c;
}

/* Squared distance from p to triangle t (Ericson, Real-Time Collision
 * Detection 5.1.5: the closest point by Voronoi regions), in double. */
static double dist2_tri(const double p[3], const rt_tri *t)
{
    double a[3] = {t->p[0].x, t->p[0].y, t->p[0].z}, b[3] = {t->p[1].x, t->p[1].y, t->p[1].z},
           c[3] = {t->p[2].x, t->p[2].y, t->p[2].z};
    double ab[3], ac[3], ap[3], q[3];
    for (int k = 0; k < 3; k++) ab[k] = b[k] - a[k], ac[k] = c[k] - a[k], ap[k] = p[k] - a[k];
#define DOT(u, v) ((u)[0] * (v)[0] + (u)[1] * (v)[1] + (u)[2] * (v)[2])
    double d1 = DOT(ab, ap), d2 = DOT(ac, ap), v, w;
    if (d1 <= 0 && d2 <= 0) {
        v = w = 0;
    } else {
        double bp[3], cp[3];
        for (int k = 0; k < 3; k++) bp[k] = p[k] - b[k], cp[k] = p[k] - c[k];
        double d3 = DOT(ab, bp), d4 = DOT(ac, bp), d5 = DOT(ab, cp), d6 = DOT(ac, cp);
        double vc = d1 * d4 - d3 * d2, vb = d5 * d2 - d1 * d6, va = d3 * d6 - d5 * d4;
        if (d3 >= 0 && d4 <= d3) v = 1, w = 0;
        else if (d6 >= 0 && d5 <= d6) v = 0, w = 1;
        else if (vc <= 0 && d1 >= 0 && d3 <= 0) v = d1 / (d1 - d3), w = 0;
        else if (vb <= 0 && d2 >= 0 && d6 <= 0) v = 0, w = d2 / (d2 - d6);
        else if (va <= 0 && d4 - d3 >= 0 && d5 - d6 >= 0) w = (d4 - d3) / ((d4 - d3) + (d5 - d6)), v = 1 - w;
        else {
            double den = va + vb + vc;
            if (!(den != 0)) return DOT(ap, ap); /* degenerate: its first vertex */
            v = vb / den, w = vc / den;
        }
    }
    for (int k = 0; k < 3; k++) q[k] = a[k] + ab[k] * v + ac[k] * w - p[k];
    return DOT(q, q);
#undef DOT
}

/* The near distance of rt_cam_setup: rt_offset_reach when the eye is that
 * close to a triangle, else 0. */
static float eye_near(const rt_scene *sc, rt_vec3 eye)
{
    float reach = rt_offset_reach(eye, rt_scene_offset_scale(sc));
    rt_bounds b = sc->bounds;
    if (!(eye.x >= b.lo.x - reach && eye.x <= b.hi.x + reach && eye.y >= b.lo.y - reach && eye.y <= b.hi.y + reach &&
          eye.z >= b.lo.z - reach && eye.z <= b.hi.z + reach))
        return 0.0f;
    const double p[3] = {eye.x, eye.y, eye.z}, r2 = (double)reach * reach;
    for (uint32_t i = 0; i < sc->ntri; i++)
        if (dist2_tri(p, &sc->tri[i]) <= r2) return reach;
    /* kept instances: each object's triangles as the flattened copy has
     * them, for the instances whose box (their object's box with its
     * corners transformed, widened) is within reach */
    double(*ob)[2][3] = sc->kept && sc->nobj ? calloc(sc->nobj, sizeof *ob) : NULL;
    /* (out of memory: no boxes, every instanced triangle is tested) */
    for (uint32_t k = 0; ob && k < sc->nobj; k++) {
        const rt_scene_obj *o = &sc->obj[k];
        for (int a = 0; a < 3; a++) ob[k][0][a] = INFINITY, ob[k][1][a] = -INFINITY;
        for (uint32_t j = 0; j < o->count; j++)
            for (int c = 0; c < 3; c++)
                for (int a = 0; a < 3; a++) {
                    const double x = (&sc->otri[o->start + j].p[c].x)[a];
                    if (x < ob[k][0][a]) ob[k][0][a] = x;
                    if (x > ob[k][1][a]) ob[k][1][a] = x;
                }
    }
    for (uint32_t k = 0; sc->kept && k < sc->nirec; k++) {
        const rt_scene_inst *q = &sc->irec[k];
        const rt_scene_obj *o = &sc->obj[q->obj];
        double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
        for (int c = 0; ob && c < 8; c++) {
            const double v[3] = {ob[q->obj][c & 1][0], ob[q->obj][(c >> 1) & 1][1], ob[q->obj][(c >> 2) & 1][2]};
            for (int a = 0; a < 3; a++) {
                const double x = q->m[a][0] * v[0] + q->m[a][1] * v[1] + q->m[a][2] * v[2] + q->m[a][3];
                if (x < lo[a]) lo[a] = x;
                if (x > hi[a]) hi[a] = x;
            }
        }
        int near = 1;
        for (int a = 0; ob && a < 3; a++) {
            const double m = 1e-6 * (fabs(lo[a]) + fabs(hi[a])) + reach;
            if (p[a] < lo[a] - m || p[a] > hi[a] + m) near = 0;
        }
        for (uint32_t j = 0; near && j < o->count; j++) {
            rt_tri w;
            rt_scene_inst_tri(q->m, &sc->otri[o->start + j], &w);
            if (dist2_tri(p, &w) <= r2) {
                free(ob);
                return reach;
            }
        }
    }
    free(ob);
    return 0.0f;
}

void rt_cam_setup(rt_cam_frame *f, const rt_scene *sc, int W, int H)
{
    const rt_camera *c = &sc->cam;
    rt_vec3 dir = rt_norm(rt_sub(c->at, c->eye));
    rt_vec3 right = rt_norm(rt_cross(dir, c->up));
    rt_vec3 up = rt_cross(right, dir);
    if (c->mirror) right = rt_mul(right, -1.0f); /* pbrt's left-handed screen */
    double half_h = rt_cam_tan_deg(0.5 * (double)c->fovy_deg);
    double half_w = half_h * (double)W / (double)H;
    f->eye = c->eye;
    f->dir = dir;
    f->right = rt_mul(right, (float)half_w);
    f->up = rt_mul(up, (float)half_h);
    f->W = W;
    f->H = H;
    f->near = eye_near(sc, c->eye);
}

void rt_cam_ray(const rt_cam_frame *f, int x, int y, rt_ray *r)
{
    float sx = (float)(2.0 * ((double)x + 0.5) / f->W - 1.0);
    float sy = (float)(1.0 - 2.0 * ((double)y + 0.5) / f->H);
    rt_vec3 d = rt_add(f->dir, rt_add(rt_mul(f->right, sx), rt_mul(f->up, sy)));
    if (f->near > 0) {
        /* an eye on a surface: start past it (rt_cam_setup) */
        rt_ray_init(r, rt_add(f->eye, rt_mul(d, f->near / rt_len(d))), d);
        return;
    }
    rt_ray_init(r, f->eye, d);
}
