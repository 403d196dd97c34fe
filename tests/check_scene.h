/*
 * check_scene.h -- building small scenes by hand in the tests: a grey
 * triangle appended, a scene finished, each exiting with the library's
 * message on failure (a test that cannot build its input cannot check
 * anything), materials and quads for hand-made mirror and glass scenes,
 * and the random triangle soup and the SPD-style sphere the
 * k-d tree and grid tests compare against brute force. Static inline, like
 * check.h.
 */
#ifndef RT_CHECK_SCENE_H
#define RT_CHECK_SCENE_H

#include "check.h"
#include "scene.h"

#include <stdio.h>
#include <stdlib.h>

static const float check_grey[3] = {0.5f, 0.5f, 0.5f};

/* Appends the grey triangle abc to s. */
static inline void add(rt_scene *s, rt_vec3 a, rt_vec3 b, rt_vec3 c)
{
    rt_err e = {0};
    if (rt_scene_add_tri(s, a, b, c, check_grey, &e) < 0) {
        fprintf(stderr, "add_tri: %s\n", e.msg);
        exit(1);
    }
}

/* Computes s's bounds (rt_scene_finish). */
static inline void finish(rt_scene *s)
{
    rt_err e = {0};
    if (rt_scene_finish(s, &e) < 0) {
        fprintf(stderr, "finish: %s\n", e.msg);
        exit(1);
    }
}

/* Appends a material with mirror reflectance ks and transmittance kt
 * (grey) and index of refraction ior; its index. */
static inline int add_mat(rt_scene *sc, float ks, float kt, float ior)
{
    rt_err e = {0};
    rt_material m;
    memset(&m, 0, sizeof m);
    for (int k = 0; k < 3; k++) m.ks[k] = ks, m.kt[k] = kt;
    m.ior = ior;
    int id = rt_scene_add_material(sc, &m, &e);
    CHECK(id > 0, "material: %s", e.msg);
    return id;
}

/* Appends the quad abcd (triangles abc, acd) with colour rgb and material
 * mat; 0, or -1 (a failed check). */
static inline int add_quad(rt_scene *sc, rt_vec3 a, rt_vec3 b, rt_vec3 c, rt_vec3 d, const float rgb[3], int mat)
{
    rt_err e = {0};
    int r = rt_scene_add_tri_mat(sc, a, b, c, rgb, (uint32_t)mat, &e);
    r |= rt_scene_add_tri_mat(sc, a, c, d, rgb, (uint32_t)mat, &e);
    CHECK(r == 0, "add quad: %s", e.msg);
    return r;
}

/* A soup of n triangles in [0,1]^3 with awkward members mixed in. */
static inline rt_scene *make_soup(uint32_t n)
{
    rt_scene *s = rt_scene_new(n, NULL);
    if (!s) exit(1);
    for (uint32_t i = 0; i < n; i++) {
        int kind = (int)(rnd64() % 16);
        rt_vec3 c = rt_v3(uf(0, 1), uf(0, 1), uf(0, 1));
        float sz = kind == 0 ? 0.5f : (kind < 4 ? 0.002f : 0.05f);
        if (kind == 4 || kind == 5) {
            /* Axis-aligned flat triangle on a coarse grid: split planes
             * coincide with it and with neighbours. */
            int ax = (int)(rnd64() % 3);
            float g = (float)(rnd64() % 9) / 8.0f;
            rt_vec3 p[3];
            for (int k = 0; k < 3; k++) {
                p[k] = rt_v3((float)(rnd64() % 9) / 8.0f, (float)(rnd64() % 9) / 8.0f,
                             (float)(rnd64() % 9) / 8.0f);
                rt_set_axis(&p[k], ax, g);
            }
            add(s, p[0], p[1], p[2]);
        } else if (kind == 6) {
            /* Degenerate: repeated vertex or exactly collinear. */
            rt_vec3 a = c, b = rt_add(c, rt_v3(0.125f, 0.25f, 0.0625f));
            if (rnd64() & 1) add(s, a, b, b);
            else add(s, a, b, rt_add(c, rt_v3(0.25f, 0.5f, 0.125f)));
        } else {
            add(s, rt_add(c, rt_mul(rand_dir(), sz)), rt_add(c, rt_mul(rand_dir(), sz)),
                rt_add(c, rt_mul(rand_dir(), sz)));
        }
    }
    finish(s);
    return s;
}

/* SPD-style sphere: 6 cube faces, r x r cells, 2 triangles each; shared
 * vertices computed from the same integer grid point, so bit-identical. */
static inline rt_vec3 cube_pt(int face, int i, int j, int r)
{
    double a = -1.0 + 2.0 * i / r, b = -1.0 + 2.0 * j / r, p[3];
    int ax = face % 3;
    double sgn = face < 3 ? 1.0 : -1.0;
    p[ax] = sgn;
    p[(ax + 1) % 3] = a;
    p[(ax + 2) % 3] = b;
    double l = sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]);
    return rt_v3((float)(p[0] / l), (float)(p[1] / l), (float)(p[2] / l));
}

static inline rt_scene *make_sphere(int r)
{
    rt_scene *s = rt_scene_new((uint32_t)(12 * r * r), NULL);
    if (!s) exit(1);
    for (int f = 0; f < 6; f++)
        for (int i = 0; i < r; i++)
            for (int j = 0; j < r; j++) {
                rt_vec3 a = cube_pt(f, i, j, r), b = cube_pt(f, i + 1, j, r), c = cube_pt(f, i + 1, j + 1, r),
                        d = cube_pt(f, i, j + 1, r);
                add(s, a, b, c);
                add(s, a, c, d);
            }
    finish(s);
    return s;
}

#endif
