/*
 * test_grid.c -- the uniform grid against hand-computed values and brute force.
 *
 * Resolution on boxes whose answer is known (including flat, point and
 * empty scenes and the grid_min and cell limits); the separating-axis test
 * against polygon clipping on random triangles and boxes; rt_grid_check on
 * random soups, a sphere and reduced built-in scenes, and on corrupted grids
 * (it must fail); the 3D-DDA against a per-cell slab computation in double
 * on random rays (inside, outside, axis-parallel with signed zeros, segments)
 * and, exactly, on rays with integer origins and directions through the
 * faces, edges and corners of a unit-voxel grid; closest hits against
 * rt_brute_closest and rt_kd_closest, any-hit against rt_brute_occluded;
 * hand-counted cells and tests for the in-cell acceptance rule; ties.
 * The quick tier uses small grids; the long tier (RT_TEST_LONG=1) larger
 * grids and more rays.
 *
 * `test_grid stats GRIDMIN` prints build statistics of the full built-in
 * scenes (docs/grid.md) instead of testing.
 */
#include "config.h"
#include "check.h"
#include "check_scene.h"
#include "grid.h"
#include "kdtrav.h"
#include "kdtree.h"
#include "scene.h"
#include "scene_load.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>


static rt_scene *new_scene(uint32_t n)
{
    rt_scene *s = rt_scene_new(n, NULL);
    if (!s) exit(1);
    return s;
}

static rt_grid *build_ok(const char *name, const rt_scene *s, uint32_t gm)
{
    rt_err e = {0};
    rt_grid *g = rt_grid_build(s, gm, &e);
    CHECK(g != NULL, "%s: build at %u: %s", name, gm, e.msg);
    if (!g) exit(1);
    CHECK(rt_grid_check(g, s, &e) == 0, "%s: check at %u: %s", name, gm, e.msg);
    return g;
}

/* ---- resolution ----------------------------------------------------------- */

static void test_resolution(void)
{
    rt_err e = {0};
    /* Box [0,2] x [0,1] x [0,4]: v = 1/4 on y, so 8 x 4 x 16. */
    rt_scene *s = new_scene(2);
    add(s, rt_v3(0, 0, 0), rt_v3(2, 1, 0), rt_v3(0, 0, 4));
    add(s, rt_v3(2, 1, 4), rt_v3(1, 0, 4), rt_v3(2, 0.5f, 0));
    finish(s);
    rt_grid *g = build_ok("box", s, 4);
    CHECK(g->n[0] == 8 && g->n[1] == 4 && g->n[2] == 16 && g->ncells == 512 && g->voxel == 0.25f,
          "box: %u x %u x %u voxel %g", g->n[0], g->n[1], g->n[2], (double)g->voxel);
    CHECK(rt_grid_cells(g) == 512, "box: cells");
    rt_grid_sizes z;
    rt_grid_get_sizes(g, &z);
    CHECK(z.grid_bytes == 2048 && z.list_words == g->nlist && z.list_bytes == 4ull * g->nlist && z.vert_bytes == 72 &&
              z.shade_bytes == 32 && z.total_bytes == 2048 + 4ull * g->nlist + 72 + 32,
          "box: sizes");
    rt_grid_free(g);
    /* grid_min 3 on y: v = 1/3 rounded up until 3 v covers 1; x needs 6. */
    g = build_ok("box3", s, 3);
    CHECK(g->n[1] == 3 && g->n[0] == 6 && g->n[2] == 12, "box3: %u x %u x %u", g->n[0], g->n[1], g->n[2]);
    CHECK(rt_grid_plane(g, 1, 3) >= 1.0f && rt_grid_plane(g, 1, 2) < 1.0f, "box3: planes");
    rt_grid_free(g);
    /* Limits: grid_min 0, and too many cells (512^2 * 2048 = 2^29). */
    CHECK(rt_grid_build(s, 0, &e) == NULL && strstr(e.msg, "grid_min"), "grid_min 0: %s", e.msg);
    e.msg[0] = 0;
    CHECK(rt_grid_build(s, 512, &e) == NULL && strstr(e.msg, "2^27"), "cell limit: %s", e.msg);
    g = rt_grid_build(s, 32, &e);
    CHECK(g && g->n[0] == 64 && g->n[1] == 32 && g->n[2] == 128 && g->ncells == (1u << 18), "2^18 cells: %s", e.msg);
    rt_grid_free(g);
    rt_scene_free(s);

    /* Flat scene (z = 3): z gets one cell of the same voxel. */
    s = new_scene(1);
    add(s, rt_v3(0, 0, 3), rt_v3(1, 0, 3), rt_v3(0, 2, 3));
    finish(s);
    g = build_ok("flat", s, 8);
    CHECK(g->n[0] == 8 && g->n[1] == 16 && g->n[2] == 1 && g->voxel == 0.125f && g->lo[2] == 3.0f,
          "flat: %u x %u x %u voxel %g", g->n[0], g->n[1], g->n[2], (double)g->voxel);
    /* Cells (i, j) whose corner (i/8, j/8) lies in x + y/2 <= 1, i.e.
     * 2i + j <= 16: 16 + 15 + 13 + 11 + 9 + 7 + 5 + 3 = 79, one triangle each. */
    CHECK(g->nonempty == 79 && g->nlist == 158 && g->maxlist == 1, "flat: %u non-empty cells", g->nonempty);
    CHECK(rt_grid_mean_list(g) == 1.0, "flat: mean");
    /* A ray straight down hits it. */
    rt_ray r;
    rt_hit h;
    rt_ray_init(&r, rt_v3(0.3f, 0.4f, 10), rt_v3(0, 0, -1));
    int hit = rt_grid_closest(g, s, &r, &h, NULL);
    CHECK(hit == 1 && h.tri == 0 && check_near(h.t, 7.0, 1e-6, 0), "flat: hit %d tri %u t %.9g", hit, h.tri, (double)h.t);
    rt_grid_free(g);
    rt_scene_free(s);

    /* A scene flat on every axis (a point): 1 x 1 x 1, voxel 1. */
    s = new_scene(1);
    add(s, rt_v3(5, 5, 5), rt_v3(5, 5, 5), rt_v3(5, 5, 5));
    finish(s);
    g = build_ok("point", s, 64);
    CHECK(g->ncells == 1 && g->voxel == 1.0f && g->nonempty == 1 && g->nlist == 2 && g->list[0] == 0 &&
              g->list[1] == RT_GRID_NULL,
          "point: %u cells, nlist %u", g->ncells, g->nlist);
    rt_grid_free(g);
    rt_scene_free(s);

    /* Empty scene (not finished: finish rejects it): a valid 1x1x1 grid. */
    s = new_scene(0);
    g = build_ok("empty", s, 64);
    CHECK(g->ncells == 1 && g->cells[0] == RT_GRID_NULL && g->nlist == 0 && g->nonempty == 0, "empty grid");
    rt_ray_init(&r, rt_v3(0.5f, 0.5f, -1), rt_v3(0, 0, 1));
    CHECK(!rt_grid_closest(g, s, &r, &h, NULL) && h.tri == RT_NO_HIT && !rt_grid_any(g, s, &r, NULL), "empty hit");
    rt_grid_free(g);
    rt_grid_free(NULL);
    rt_scene_free(s);

    /* Out-of-memory: every allocation of the build fails in turn. */
    s = make_soup(100);
    for (long k = 1; k < 20; k++) {
        rt_fail_alloc_after = k;
        g = rt_grid_build(s, 8, &e);
        int failed = g == NULL;
        rt_fail_alloc_after = 0;
        if (g) CHECK(rt_grid_check(g, s, &e) == 0, "oom %ld: %s", k, e.msg);
        else CHECK(e.msg[0] != 0, "oom %ld: no message", k);
        rt_grid_free(g);
        if (!failed) break;
    }
    rt_scene_free(s);
}

/* ---- overlap: SAT against polygon clipping --------------------------------- */

/* Clips the triangle to the box (Sutherland-Hodgman in double); 1 when
 * anything is left. */
static int clip_nonempty(const rt_tri *t, const double lo[3], const double hi[3])
{
    double P[16][3], Q[16][3];
    int n = 3;
    for (int i = 0; i < 3; i++)
        for (int k = 0; k < 3; k++) P[i][k] = rt_axis(t->p[i], k);
    for (int pl = 0; pl < 6 && n > 0; pl++) {
        int k = pl >> 1, up = pl & 1;
        double b = up ? hi[k] : lo[k];
        int m = 0;
        for (int i = 0; i < n; i++) {
            const double *a = P[i], *c = P[(i + 1) % n];
            int ina = up ? a[k] <= b : a[k] >= b, inc = up ? c[k] <= b : c[k] >= b;
            if (ina) memcpy(Q[m++], a, sizeof Q[0]);
            if (ina != inc) {
                double s = (b - a[k]) / (c[k] - a[k]);
                for (int j = 0; j < 3; j++) Q[m][j] = a[j] + s * (c[j] - a[j]);
                Q[m][k] = b;
                m++;
            }
        }
        n = m;
        memcpy(P, Q, sizeof(double) * 3 * (size_t)n);
    }
    return n > 0;
}

static void test_overlap(long n)
{
    long agree_in = 0, agree_out = 0;
    for (int i = 0; i < n; i++) {
        rt_tri t;
        int kind = i % 4;
        for (int j = 0; j < 3; j++) t.p[j] = rt_v3(uf(-1, 2), uf(-1, 2), uf(-1, 2));
        if (kind == 1) { /* small */
            rt_vec3 c = rt_v3(uf(-0.2f, 1.2f), uf(-0.2f, 1.2f), uf(-0.2f, 1.2f));
            for (int j = 0; j < 3; j++) t.p[j] = rt_add(c, rt_mul(rand_dir(), 0.2f));
        } else if (kind == 2) { /* axis-aligned flat */
            int ax = (int)(rnd64() % 3);
            float g = uf(-0.2f, 1.2f);
            for (int j = 0; j < 3; j++) rt_set_axis(&t.p[j], ax, g);
        } else if (kind == 3) { /* degenerate: a segment */
            t.p[2] = rt_add(t.p[0], rt_mul(rt_sub(t.p[1], t.p[0]), 0.5f));
        }
        double lo[3], hi[3], lo2[3], hi2[3], lo3[3], hi3[3];
        for (int k = 0; k < 3; k++) {
            lo[k] = uf(0, 0.5f);
            hi[k] = lo[k] + uf(0.05f, 0.5f);
            lo2[k] = lo[k] + 1e-9;
            hi2[k] = hi[k] - 1e-9;
            lo3[k] = lo[k] - 1e-9;
            hi3[k] = hi[k] + 1e-9;
        }
        int sat = rt_grid_tri_box(&t, lo, hi);
        if (clip_nonempty(&t, lo2, hi2)) {
            CHECK(sat == 1, "overlap %d: SAT misses an overlap (kind %d)", i, kind);
            agree_in++;
        }
        if (!clip_nonempty(&t, lo3, hi3)) {
            CHECK(sat == 0, "overlap %d: SAT accepts a separated triangle (kind %d)", i, kind);
            agree_out++;
        }
    }
    CHECK(agree_in > n / 40 && agree_out > n / 40, "overlap: too few cases (%ld in, %ld out)", agree_in, agree_out);
    /* Hand cases: a triangle touching a box corner, one missing it by 1e-6
     * across a diagonal, one whose bounds overlap but plane does not. */
    double lo[3] = {0, 0, 0}, hi[3] = {1, 1, 1};
    rt_tri t = {{rt_v3(1, 1, 1), rt_v3(2, 1, 1), rt_v3(1, 2, 1)}};
    CHECK(rt_grid_tri_box(&t, lo, hi) == 1, "corner touch");
    rt_tri u = {{rt_v3(2.000002f, 0, 0.5f), rt_v3(0, 2.000002f, 0.5f), rt_v3(2.000002f, 0, 0.6f)}};
    CHECK(rt_grid_tri_box(&u, lo, hi) == 0, "diagonal miss");
    rt_tri w = {{rt_v3(1.9f, 0, 0), rt_v3(0, 1.9f, 0), rt_v3(0, 0, 1.9f)}}; /* x+y+z = 1.9 meets the cube */
    CHECK(rt_grid_tri_box(&w, lo, hi) == 1, "plane through cube");
    rt_tri w2 = {{rt_v3(3.1f, 0, 0), rt_v3(0, 3.1f, 0), rt_v3(0, 0, 3.1f)}}; /* x+y+z = 3.1 misses it */
    CHECK(rt_grid_tri_box(&w2, lo, hi) == 0, "plane beyond cube");
}

/* ---- the checker must catch corruption --------------------------------------- */

static void test_check_catches(void)
{
    rt_err e = {0};
    rt_scene *s = make_soup(300);
    rt_grid *g = build_ok("soup-300", s, 8);
    /* A cell with at least two entries. */
    uint32_t id = 0;
    while (id < g->ncells && (g->cells[id] == RT_GRID_NULL || g->list[g->cells[id] + 1] == RT_GRID_NULL)) id++;
    CHECK(id < g->ncells, "no cell with two triangles");
    if (id < g->ncells) {
        uint32_t w = g->cells[id], a = g->list[w], b = g->list[w + 1];
        /* Not ascending (G4). */
        g->list[w + 1] = a;
        CHECK(rt_grid_check(g, s, &e) < 0 && strstr(e.msg, "G4"), "duplicate entry not caught: %s", e.msg);
        /* A different, still ascending triangle (G5). */
        uint32_t nb = b + 1;
        while (nb < s->ntri && rt_grid_tri_in_cell(g, &s->tri[nb], id % g->n[0], id / g->n[0] % g->n[1],
                                                   id / g->n[0] / g->n[1]))
            nb++;
        if (g->list[w + 2] != RT_GRID_NULL && nb >= g->list[w + 2]) nb = s->ntri;
        if (nb < s->ntri) {
            g->list[w + 1] = nb;
            CHECK(rt_grid_check(g, s, &e) < 0 && strstr(e.msg, "G5"), "wrong triangle not caught: %s", e.msg);
        }
        g->list[w + 1] = b;
        CHECK(rt_grid_check(g, s, &e) == 0, "restored: %s", e.msg);
        /* A non-empty cell marked empty (G3). */
        g->cells[id] = RT_GRID_NULL;
        CHECK(rt_grid_check(g, s, &e) < 0 && strstr(e.msg, "G3"), "null word not caught: %s", e.msg);
        g->cells[id] = w;
        /* A list without its terminator at the end of the texture (G4). */
        uint32_t lastw = g->list[g->nlist - 1];
        g->list[g->nlist - 1] = 0;
        CHECK(rt_grid_check(g, s, &e) < 0 && strstr(e.msg, "G4"), "missing null not caught: %s", e.msg);
        g->list[g->nlist - 1] = lastw;
        /* A different epsilon or resolution (G1). */
        g->eps *= 2;
        CHECK(rt_grid_check(g, s, &e) < 0 && strstr(e.msg, "G1"), "eps not caught: %s", e.msg);
        g->eps /= 2;
        g->grid_min = 9;
        CHECK(rt_grid_check(g, s, &e) < 0 && strstr(e.msg, "G1"), "grid_min not caught: %s", e.msg);
        g->grid_min = 8;
        CHECK(rt_grid_check(g, s, &e) == 0, "restored: %s", e.msg);
    }
    /* Exact listing, by the definition: every cell against every triangle. */
    uint64_t pairs = 0;
    for (uint32_t t = 0; t < s->ntri; t++)
        for (uint32_t iz = 0; iz < g->n[2]; iz++)
            for (uint32_t iy = 0; iy < g->n[1]; iy++)
                for (uint32_t ix = 0; ix < g->n[0]; ix++) {
                    int want = rt_grid_tri_in_cell(g, &s->tri[t], ix, iy, iz);
                    uint32_t w = g->cells[rt_grid_cell_id(g, ix, iy, iz)];
                    int have = 0;
                    if (w != RT_GRID_NULL)
                        for (const uint32_t *p = g->list + w; *p != RT_GRID_NULL; p++) have |= *p == t;
                    pairs += (uint64_t)want;
                    if (want != have) {
                        CHECK(want == have, "tri %u cell (%u,%u,%u): listed %d, overlap %d", t, ix, iy, iz, have, want);
                        t = s->ntri - 1;
                    }
                }
    CHECK(pairs == (uint64_t)g->nlist - g->nonempty, "pairs %llu vs entries %u", (unsigned long long)pairs,
          g->nlist - g->nonempty);
    rt_grid_free(g);
    rt_scene_free(s);
}

/* ---- 3D-DDA against per-cell slabs --------------------------------------------- */

typedef struct walkrec {
    rt_grid_cell c[4096];
    int n;
} walkrec;

static int rec_visit(void *ctx, const rt_grid_cell *c)
{
    walkrec *w = ctx;
    if (w->n < 4096) w->c[w->n++] = *c;
    return 0;
}

/* The exact parametric overlap of the segment [tmin, tmax] with each cell
 * (double; zero-direction axes use the half-open cell), as len = t1 - t0
 * (negative: no overlap; -inf: outside a zero-direction slab). */
static void ref_interval(const rt_grid *g, const rt_ray *r, double tmin, double tmax, uint32_t ix, uint32_t iy,
                         uint32_t iz, double *t0, double *t1)
{
    const uint32_t i[3] = {ix, iy, iz};
    double a = tmin, b = tmax;
    for (int k = 0; k < 3; k++) {
        double o = rt_axis(r->o, k), d = rt_axis(r->d, k);
        double p0 = rt_grid_plane(g, k, i[k]), p1 = rt_grid_plane(g, k, i[k] + 1);
        if (d == 0) {
            int in = o >= p0 && (o < p1 || (i[k] == g->n[k] - 1 && o <= p1));
            if (!in) {
                *t0 = 1;
                *t1 = -INFINITY;
                return;
            }
            continue;
        }
        double u = (p0 - o) / d, v = (p1 - o) / d;
        if (u > v) {
            double x = u;
            u = v;
            v = x;
        }
        if (u > a) a = u;
        if (v < b) b = v;
    }
    *t0 = a;
    *t1 = b;
}

/* Compares one walk with the reference; tol 0 demands exact agreement. */
static void check_walk(const char *name, long i, const rt_grid *g, const rt_ray *r, float tmin, float tmax, double tol)
{
    walkrec *w = malloc(sizeof *w);
    w->n = 0;
    uint64_t n = rt_grid_walk(g, r, tmin, tmax, rec_visit, w);
    CHECK(n == (uint64_t)w->n, "%s ray %ld: walk count", name, i);
    /* Visited cells: near the segment, in order, contiguous, no repeats. */
    uint8_t *seen = calloc(g->ncells, 1);
    for (int j = 0; j < w->n; j++) {
        const rt_grid_cell *c = &w->c[j];
        CHECK(c->id == rt_grid_cell_id(g, c->ix, c->iy, c->iz) && c->ix < g->n[0] && c->iy < g->n[1] && c->iz < g->n[2],
              "%s ray %ld: bad cell", name, i);
        CHECK(!seen[c->id], "%s ray %ld: cell %u visited twice", name, i, c->id);
        seen[c->id] = 1;
        CHECK(c->t0 <= c->t1, "%s ray %ld: cell %d entry %g > exit %g", name, i, j, (double)c->t0, (double)c->t1);
        if (j > 0) {
            CHECK(c->t0 == w->c[j - 1].t1, "%s ray %ld: gap between cells %d and %d", name, i, j - 1, j);
            int dx = abs((int)c->ix - (int)w->c[j - 1].ix), dy = abs((int)c->iy - (int)w->c[j - 1].iy),
                dz = abs((int)c->iz - (int)w->c[j - 1].iz);
            CHECK(dx <= 1 && dy <= 1 && dz <= 1 && dx + dy + dz > 0, "%s ray %ld: jump between cells", name, i);
        }
        double a, b;
        ref_interval(g, r, tmin, tmax, c->ix, c->iy, c->iz, &a, &b);
        CHECK(b - a >= -tol, "%s ray %ld: visited cell (%u,%u,%u) is %g away from the segment", name, i, c->ix, c->iy,
              c->iz, a - b);
        /* Exact rays: edges and corners step several axes at once, so no
         * cell is visited that the segment only touches in a line or point. */
        if (tol == 0 && w->c[w->n - 1].t1 > w->c[0].t0)
            CHECK(b > a, "%s ray %ld: cell (%u,%u,%u) only touched, yet visited", name, i, c->ix, c->iy, c->iz);
        if (b - a > 2 * tol) {
            CHECK(fabs(c->t0 - a) <= tol && fabs(c->t1 - b) <= tol,
                  "%s ray %ld: cell (%u,%u,%u) [%.9g, %.9g], exact [%.9g, %.9g]", name, i, c->ix, c->iy, c->iz,
                  (double)c->t0, (double)c->t1, a, b);
        }
    }
    /* Every cell crossed with positive length (beyond tol) was visited. */
    double first = INFINITY, last = -INFINITY;
    for (uint32_t iz = 0; iz < g->n[2]; iz++)
        for (uint32_t iy = 0; iy < g->n[1]; iy++)
            for (uint32_t ix = 0; ix < g->n[0]; ix++) {
                double a, b;
                ref_interval(g, r, tmin, tmax, ix, iy, iz, &a, &b);
                if (b - a > 2 * tol || (tol == 0 && b > a)) {
                    CHECK(seen[rt_grid_cell_id(g, ix, iy, iz)], "%s ray %ld: cell (%u,%u,%u) [%.9g, %.9g] skipped",
                          name, i, ix, iy, iz, a, b);
                }
                if (b >= a) {
                    if (a < first) first = a;
                    if (b > last) last = b;
                }
            }
    if (w->n > 0 && first <= last) {
        CHECK(fabs(w->c[0].t0 - first) <= tol && fabs(w->c[w->n - 1].t1 - last) <= tol,
              "%s ray %ld: walk [%.9g, %.9g], segment in grid [%.9g, %.9g]", name, i, (double)w->c[0].t0,
              (double)w->c[w->n - 1].t1, first, last);
    }
    if (w->n == 0) CHECK(!(last - first > 2 * tol), "%s ray %ld: no cells but the segment crosses the grid", name, i);
    free(seen);
    free(w);
}

static void test_dda_random(const char *name, const rt_scene *s, uint32_t gm, long nrays)
{
    rt_grid *g = build_ok(name, s, gm);
    rt_bounds b = s->bounds;
    rt_vec3 ext = rt_sub(b.hi, b.lo);
    for (long i = 0; i < nrays; i++) {
        int kind = (int)(i % 6);
        rt_vec3 o = rt_v3(uf(b.lo.x - 0.5f * ext.x, b.hi.x + 0.5f * ext.x), uf(b.lo.y - 0.5f * ext.y, b.hi.y + 0.5f * ext.y),
                          uf(b.lo.z - 0.5f * ext.z, b.hi.z + 0.5f * ext.z));
        rt_vec3 d = rand_dir();
        if (kind == 1) { /* axis-parallel, signed zeros */
            d = rt_v3((rnd64() & 1) ? -0.0f : 0.0f, (rnd64() & 1) ? -0.0f : 0.0f, (rnd64() & 1) ? -0.0f : 0.0f);
            rt_set_axis(&d, (int)(rnd64() % 3), (rnd64() & 1) ? -1.0f : 1.0f);
        } else if (kind == 2) { /* one zero component */
            rt_set_axis(&d, (int)(rnd64() % 3), (rnd64() & 1) ? -0.0f : 0.0f);
        } else if (kind == 3) { /* origin on a cell plane */
            int ax = (int)(rnd64() % 3);
            rt_set_axis(&o, ax, rt_grid_plane(g, ax, (uint32_t)(rnd64() % (g->n[ax] + 1))));
            if (rnd64() & 1) rt_set_axis(&d, ax, 0.0f);
        }
        rt_ray r;
        rt_ray_init(&r, o, d);
        float tmin = 0, tmax = INFINITY;
        if (kind == 4) {
            tmin = uf(0, rt_len(ext));
            tmax = tmin + uf(0, rt_len(ext));
        }
        double tol = 1e-4 * g->voxel / fmax(fabs(d.x), fmax(fabs(d.y), fabs(d.z))) + 1e-5 * (rt_len(o) + rt_len(ext));
        check_walk(name, i, g, &r, tmin, tmax, tol);
    }
    rt_grid_free(g);
}

/* Integer origins and directions on a unit-voxel 8^3 grid: crossings are
 * exact floats, so faces, edges and corners are hit exactly and the walk
 * must equal the exact cell set (no tolerance). */
static void test_dda_exact(long nrays)
{
    rt_scene *s = new_scene(1);
    add(s, rt_v3(0, 0, 0), rt_v3(8, 0, 0), rt_v3(0, 8, 8));
    finish(s);
    rt_grid *g = build_ok("cube8", s, 8);
    CHECK(g->n[0] == 8 && g->n[1] == 8 && g->n[2] == 8 && g->voxel == 1.0f, "cube8 resolution");
    long corners = 0;
    for (long i = 0; i < nrays; i++) {
        rt_vec3 o, d;
        do {
            o = rt_v3((float)((int)(rnd64() % 25) - 8) * 0.5f, (float)((int)(rnd64() % 25) - 8) * 0.5f,
                      (float)((int)(rnd64() % 25) - 8) * 0.5f);
            static const float dv[] = {-2, -1, -0.0f, 0, 1, 2};
            d = rt_v3(dv[rnd64() % 6], dv[rnd64() % 6], dv[rnd64() % 6]);
        } while (d.x == 0 && d.y == 0 && d.z == 0);
        if (i % 3 == 0) o = rt_v3(floorf(o.x), floorf(o.y), floorf(o.z)); /* on planes */
        rt_ray r;
        rt_ray_init(&r, o, d);
        float tmin = 0, tmax = INFINITY;
        if (i % 5 == 0) {
            tmin = (float)(rnd64() % 8) * 0.5f;
            tmax = tmin + (float)(rnd64() % 12) * 0.5f;
        }
        int nz = (d.x != 0) + (d.y != 0) + (d.z != 0);
        corners += nz >= 2;
        check_walk("cube8", i, g, &r, tmin, tmax, 0.0);
    }
    CHECK(corners > nrays / 2, "cube8: too few diagonal rays");
    /* Hand cases. The main diagonal from the corner: 8 cells, [k, k+1]. */
    rt_ray r;
    walkrec *w = malloc(sizeof *w);
    rt_ray_init(&r, rt_v3(0, 0, 0), rt_v3(1, 1, 1));
    w->n = 0;
    rt_grid_walk(g, &r, 0, INFINITY, rec_visit, w);
    CHECK(w->n == 8, "diagonal: %d cells", w->n);
    for (int j = 0; j < w->n && j < 8; j++)
        CHECK(w->c[j].ix == (uint32_t)j && w->c[j].iy == (uint32_t)j && w->c[j].iz == (uint32_t)j &&
                  w->c[j].t0 == (float)j && w->c[j].t1 == (float)(j + 1),
              "diagonal cell %d", j);
    /* Along the edge x = 3, y = 5 going down z: cells (3, 5, 7..0). */
    rt_ray_init(&r, rt_v3(3, 5, 10), rt_v3(0, -0.0f, -1));
    w->n = 0;
    rt_grid_walk(g, &r, 0, INFINITY, rec_visit, w);
    CHECK(w->n == 8 && w->c[0].ix == 3 && w->c[0].iy == 5 && w->c[0].iz == 7 && w->c[0].t0 == 2.0f &&
              w->c[7].iz == 0 && w->c[7].t1 == 10.0f,
          "edge walk: %d cells", w->n);
    /* On the top face x = 8 (closed): cells (7, *, 2). */
    rt_ray_init(&r, rt_v3(8, -1, 2.5f), rt_v3(0, 1, 0));
    w->n = 0;
    rt_grid_walk(g, &r, 0, INFINITY, rec_visit, w);
    CHECK(w->n == 8 && w->c[0].ix == 7 && w->c[0].iz == 2, "top face: %d cells", w->n);
    /* Starting on a plane going down: the lower cell first. */
    rt_ray_init(&r, rt_v3(4, 0.5f, 0.5f), rt_v3(-1, 0, 0));
    w->n = 0;
    rt_grid_walk(g, &r, 0, INFINITY, rec_visit, w);
    CHECK(w->n == 4 && w->c[0].ix == 3 && w->c[0].t0 == 0.0f && w->c[3].ix == 0, "start on plane: %d", w->n);
    /* Touching the grid in its corner only: one cell, [1, 1]. */
    rt_ray_init(&r, rt_v3(-1, -1, 1), rt_v3(1, 1, -1));
    w->n = 0;
    rt_grid_walk(g, &r, 0, INFINITY, rec_visit, w);
    CHECK(w->n == 1 && w->c[0].id == 0 && w->c[0].t0 == 1.0f && w->c[0].t1 == 1.0f, "corner touch: %d", w->n);
    /* Missing it, and a stop requested by the visitor. */
    rt_ray_init(&r, rt_v3(-1, -1, 9), rt_v3(1, 1, 0));
    CHECK(rt_grid_walk(g, &r, 0, INFINITY, rec_visit, w) == 0, "miss above");
    free(w);
    rt_grid_free(g);
    rt_scene_free(s);
}

/* ---- closest hit: hand counts, ties, brute force, k-d tree ---------------------- */

static void test_hand_counts(void)
{
    /* T0 = the y = 0 face (x + z <= 8), T1 slanted x = 2 + 3y, T2 the plane
     * x = 5.5; bounds [0,8]^3, voxel 1. The ray y = z = 0.5 along +x meets
     * T1 at x = 3.5 (t = 3): T1 is listed in cells 1 (it touches its face
     * x = 2), 2, 3, 4 of that row; its hit is rejected in cells 1 and 2
     * (t outside [0.5, 1.5], [1.5, 2.5]) and taken in cell 3, where the
     * walk stops: 4 cells, 4 tests of T0 + 3 of T1. */
    rt_scene *s = new_scene(3);
    add(s, rt_v3(0, 0, 0), rt_v3(8, 0, 0), rt_v3(0, 0, 8));
    add(s, rt_v3(2, 0, 0), rt_v3(5, 1, 0), rt_v3(2, 0, 8));
    add(s, rt_v3(5.5f, 0, 0), rt_v3(5.5f, 8, 0), rt_v3(5.5f, 0, 8));
    finish(s);
    rt_grid *g = build_ok("hand", s, 8);
    rt_ray r;
    rt_ray_init(&r, rt_v3(0.5f, 0.5f, 0.5f), rt_v3(1, 0, 0));
    rt_hit h;
    rt_grid_count cnt = {0, 0};
    CHECK(rt_grid_closest(g, s, &r, &h, &cnt) == 1 && h.tri == 1 && h.t == 3.0f, "hand: tri %u t %g", h.tri,
          (double)h.t);
    CHECK(cnt.cells == 4 && cnt.tests == 7, "hand: %llu cells %llu tests", (unsigned long long)cnt.cells,
          (unsigned long long)cnt.tests);
    /* The same, cell by cell: the hit is rejected in cells 1 and 2, where
     * T1 is listed but its t lies outside the cell, and taken in cell 3. */
    rt_grid_iter it;
    rt_grid_cell gc;
    rt_hit hc;
    rt_hit_none(&hc);
    uint64_t ntest = 0;
    float tol = rt_grid_ttol(g, &r);
    CHECK(tol > 0 && tol < 1e-3f, "hand: tol %g", (double)tol);
    CHECK(rt_grid_iter_init(&it, g, &r, r.tmin, r.tmax), "hand: iter");
    for (int j = 0; j < 4; j++) {
        CHECK(rt_grid_iter_next(&it, &gc) && gc.ix == (uint32_t)j && gc.t0 == (j ? j - 0.5f : 0.0f) &&
                  gc.t1 == j + 0.5f,
              "hand: cell %d", j);
        int got = rt_grid_cell_closest(g, s, &r, &gc, tol, &hc, &ntest);
        CHECK(got == (j == 3) && (j < 3 || (hc.tri == 1 && hc.t == 3.0f)), "hand: cell %d found %d", j, got);
    }
    CHECK(ntest == 7, "hand: %llu tests", (unsigned long long)ntest);
    /* Above T1's top (y = 1.5: T1 ends at y = 1): T2 at t = 5 in cell 5. */
    rt_ray_init(&r, rt_v3(0.5f, 1.5f, 0.5f), rt_v3(1, 0, 0));
    cnt.cells = cnt.tests = 0;
    CHECK(rt_grid_closest(g, s, &r, &h, &cnt) == 1 && h.tri == 2 && h.t == 5.0f && cnt.cells == 6, "hand 2");
    /* Shadow ray stopping short of T2: clear; past it: occluded. */
    r.tmax = 4.9f;
    CHECK(!rt_grid_any(g, s, &r, NULL), "hand: short shadow ray occluded");
    r.tmax = 5.1f;
    CHECK(rt_grid_any(g, s, &r, NULL), "hand: shadow ray not occluded");
    rt_grid_free(g);
    rt_scene_free(s);

    /* Ties: eight identical triangles, and two coincident ones lying in the
     * cell face x = 0.5 (listed in the cells on both sides): the lower
     * index wins, from either direction. */
    s = new_scene(10);
    for (int i = 0; i < 8; i++) add(s, rt_v3(0, 0, 0), rt_v3(1, 0, 0), rt_v3(0, 1, 0));
    add(s, rt_v3(0.5f, 0, 0), rt_v3(0.5f, 1, 0), rt_v3(0.5f, 0, 1));
    add(s, rt_v3(0.5f, 0, 0), rt_v3(0.5f, 1, 0), rt_v3(0.5f, 0, 1));
    finish(s);
    g = build_ok("ties", s, 8);
    rt_ray_init(&r, rt_v3(0.25f, 0.25f, 1), rt_v3(0, 0, -1));
    CHECK(rt_grid_closest(g, s, &r, &h, NULL) && h.tri == 0 && h.t == 1.0f, "tie: tri %u", h.tri);
    rt_ray_init(&r, rt_v3(0, 0.3f, 0.3f), rt_v3(1, 0, 0));
    CHECK(rt_grid_closest(g, s, &r, &h, NULL) && h.tri == 8 && h.t == 0.5f, "face tie: tri %u t %g", h.tri, (double)h.t);
    rt_ray_init(&r, rt_v3(1, 0.3f, 0.3f), rt_v3(-1, 0, 0));
    CHECK(rt_grid_closest(g, s, &r, &h, NULL) && h.tri == 8 && h.t == 0.5f, "face tie back: tri %u", h.tri);
    rt_grid_free(g);
    rt_scene_free(s);
}

typedef struct cam {
    rt_vec3 eye, dir, right, up;
} cam;

static void gen_ray(const rt_scene *s, const cam *c, rt_ray *r, int k)
{
    rt_bounds b = s->bounds;
    rt_vec3 ext = rt_sub(b.hi, b.lo);
    rt_vec3 o = rt_v3(uf(b.lo.x - 0.05f * ext.x, b.hi.x + 0.05f * ext.x), uf(b.lo.y - 0.05f * ext.y, b.hi.y + 0.05f * ext.y),
                      uf(b.lo.z - 0.05f * ext.z, b.hi.z + 0.05f * ext.z));
    rt_vec3 d;
    if (k == 7) {
        o = c->eye;
        d = rt_add(c->dir, rt_add(rt_mul(c->right, uf(-1, 1)), rt_mul(c->up, uf(-1, 1))));
    } else if (k == 6) {
        d = rt_v3((rnd64() & 1) ? -0.0f : 0.0f, (rnd64() & 1) ? -0.0f : 0.0f, (rnd64() & 1) ? -0.0f : 0.0f);
        rt_set_axis(&d, (int)(rnd64() % 3), (rnd64() & 1) ? -1.0f : 1.0f);
    } else {
        d = rand_dir();
    }
    rt_ray_init(r, o, d);
    if (k == 5) {
        float len = rt_len(ext);
        r->tmin = uf(0, 0.1f * len);
        r->tmax = r->tmin + uf(0, len);
    }
}

static void compare_rays(const char *name, const rt_scene *s, uint32_t gm, long nrays, long nbrute)
{
    rt_err e = {0};
    double t0 = rt_now();
    rt_grid *g = build_ok(name, s, gm);
    double t1 = rt_now();
    rt_kdtree *kd = rt_kd_build(s, NULL, &e);
    CHECK(kd != NULL, "%s: kd: %s", name, e.msg);
    if (!kd) exit(1);
    rt_trav tv;
    memset(&tv, 0, sizeof tv);
    tv.kd = kd;
    tv.sc = s;
    cam c;
    c.eye = s->cam.eye;
    c.dir = rt_norm(rt_sub(s->cam.at, s->cam.eye));
    c.right = rt_norm(rt_cross(c.dir, s->cam.up));
    c.up = rt_cross(c.right, c.dir);
    float th = tanf(s->cam.fovy_deg * 0.5f * 3.14159265f / 180.0f);
    c.right = rt_mul(c.right, th);
    c.up = rt_mul(c.up, th);
    long hits = 0;
    rt_grid_count cnt = {0, 0};
    for (long i = 0; i < nrays; i++) {
        rt_ray r;
        gen_ray(s, &c, &r, (int)(i % 8));
        rt_hit hg, hk, hb;
        int a = rt_grid_closest(g, s, &r, &hg, &cnt);
        int k = rt_kd_closest(&tv, &r, &hk);
        hits += a;
        CHECK(a == k && hg.tri == hk.tri && (!a || hg.t == hk.t), "%s ray %ld: grid tri %u t %.9g, kd tri %u t %.9g",
              name, i, hg.tri, (double)hg.t, hk.tri, (double)hk.t);
        int any = rt_grid_any(g, s, &r, NULL);
        CHECK(any == k, "%s ray %ld: grid any %d, kd closest %d", name, i, any, k);
        if (i < nbrute) {
            int b = rt_brute_closest(s, &r, &hb);
            CHECK(a == b && hg.tri == hb.tri && (!a || (hg.t == hb.t && hg.u == hb.u && hg.v == hb.v)),
                  "%s ray %ld: grid tri %u t %.9g, brute tri %u t %.9g", name, i, hg.tri, (double)hg.t, hb.tri,
                  (double)hb.t);
            if (a && (i & 1)) { /* the segment up to the hit is clear */
                rt_ray sr = r;
                sr.tmax = hb.t;
                CHECK(rt_grid_any(g, s, &sr, NULL) == rt_brute_occluded(s, &sr), "%s ray %ld: short shadow", name, i);
            }
        }
    }
    printf("%-34s tris %7u grid %4ux%4ux%4u nonempty %8u words %9u mean %6.2f max %5u | build %.3fs rays %ld (%ld hit) "
           "cells/ray %.1f tests/ray %.1f\n",
           name, s->ntri, g->n[0], g->n[1], g->n[2], g->nonempty, g->nlist, rt_grid_mean_list(g), g->maxlist, t1 - t0,
           nrays, hits, (double)cnt.cells / nrays, (double)cnt.tests / nrays);
    rt_kd_free(kd);
    rt_grid_free(g);
}

/* ---- statistics for docs/grid.md --------------------------------------------- */

static int stats(uint32_t gm)
{
    printf("| scene | triangles | grid | cells | non-empty | list words | mean tris/non-empty | max | build s |\n");
    printf("|---|---:|---|---:|---:|---:|---:|---:|---:|\n");
    for (int i = 0; rt_scene_builtin_names[i]; i++) {
        rt_err e = {0};
        rt_scene *s = rt_scene_builtin(rt_scene_builtin_names[i], NULL, &e);
        if (!s) {
            fprintf(stderr, "%s: %s\n", rt_scene_builtin_names[i], e.msg);
            return 1;
        }
        rt_grid *g = rt_grid_build(s, gm, &e);
        if (!g) {
            printf("| %s | %u | %s | | | | | | |\n", rt_scene_builtin_names[i], s->ntri, e.msg);
        } else {
            printf("| %s | %u | %ux%ux%u | %u | %u | %u | %.2f | %u | %.2f |\n", rt_scene_builtin_names[i], s->ntri,
                   g->n[0], g->n[1], g->n[2], g->ncells, g->nonempty, g->nlist, rt_grid_mean_list(g), g->maxlist,
                   g->build_sec);
        }
        rt_grid_free(g);
        rt_scene_free(s);
    }
    return 0;
}

int main(int argc, char **argv)
{
    if (argc > 2 && !strcmp(argv[1], "stats")) return stats((uint32_t)atoi(argv[2]));
    rnd_seed(0x5eed6121d0c0ffeeULL);
    int full = check_long();
    test_resolution();
    test_overlap(full ? 400000 : 100000);
    test_check_catches();
    test_hand_counts();
    test_dda_exact(full ? 200000 : 10000);

    rt_scene *s = make_soup(300);
    test_dda_random("soup-300", s, 6, full ? 100000 : 10000);
    compare_rays("soup-300", s, 8, full ? 100000 : 20000, 20000);
    rt_scene_free(s);
    s = make_soup(2000);
    compare_rays("soup-2000", s, full ? 32 : 16, full ? 100000 : 20000, 5000);
    rt_scene_free(s);
    s = make_sphere(8);
    test_dda_random("sphere-r8", s, 5, full ? 50000 : 5000);
    compare_rays("sphere-r8", s, 12, full ? 100000 : 20000, 5000);
    rt_scene_free(s);

    static const struct {
        const char *name, *params;
        uint32_t gm_quick, gm_long;
        long quick, brute;
    } bi[] = {
        {"cornell", NULL, 16, 64, 20000, 5000},
        {"knot", NULL, 16, 64, 20000, 3000},
        {"sphereflake", "level=2,tess=2", 8, 32, 10000, 1000},
        {"grove", "trees=1,depth=4,tess=2", 4, 16, 10000, 1000},
        {"room", NULL, 8, 32, 5000, 300},
    };
    for (size_t i = 0; i < sizeof bi / sizeof bi[0]; i++) {
        rt_err e = {0};
        s = rt_scene_builtin(bi[i].name, bi[i].params, &e);
        CHECK(s != NULL, "builtin %s: %s", bi[i].name, e.msg);
        if (!s) continue;
        char label[80];
        uint32_t gm = full ? bi[i].gm_long : bi[i].gm_quick;
        snprintf(label, sizeof label, "%s%s%s@%u", bi[i].name, bi[i].params ? ":" : "", bi[i].params ? bi[i].params : "",
                 gm);
        compare_rays(label, s, gm, full ? 100000 : bi[i].quick, full ? 10 * bi[i].brute : bi[i].brute);
        rt_scene_free(s);
    }
    if (failures) fprintf(stderr, "%d failures\n", failures);
    return failures ? 1 : 0;
}
