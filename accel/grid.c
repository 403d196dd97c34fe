/*
 * grid.c -- building, checking and walking the uniform grid.
 *
 * Representation. Purcell et al. (2002, Figure 4) keep a uniform grid in
 * textures: a grid texture with one word per cell pointing into a
 * triangle-list texture (null for an empty cell), lists of triangle indices
 * ("pointers to vertex data") each ended by a null word, and the vertex
 * positions as RGB float texels. Here the words are 4 bytes, null is
 * RT_GRID_NULL (0xffffffff), cell id (iz * ny + iy) * nx + ix indexes the
 * grid texture, lists are laid out in cell-id order with ascending triangle
 * indices, and the vertex and shading data are the scene's own arrays, so a
 * tracer declares four regions: grid, list, vertices (36 B per triangle),
 * shading (16 B per triangle).
 *
 * Resolution (the paper's rule). Voxels are cubes of edge v chosen so the
 * smallest non-flat axis of the scene bounds gets grid_min cells (v =
 * extent / grid_min, rounded up by ULPs until the grid_min-th plane covers
 * the bounds); every other axis gets the fewest cells n with plane n >= the
 * bounds' upper face, i.e. ceil(extent / v). A flat axis (extent 0) gets one
 * cell of edge v; a scene flat on all axes gets v = max(1, |coord| / 1024);
 * an empty scene a 1x1x1 grid at the origin with v = 1. (The density rule,
 * rt_grid_density_min, only picks the grid_min this rule then uses.) Planes are
 * lo + i * v in float, one expression for boxes, clipping and crossings, so
 * the cells tile the grid bounds exactly. Errors: grid_min < 1, more than
 * RT_GRID_MAX_CELLS (2^27) cells, more than 2^32 - 2 list words, or a voxel
 * below 8 ULPs of the largest coordinate (planes would collapse).
 *
 * Listing. A triangle is listed in a cell when Akenine-Möller's separating
 * axis test (box axes, the 9 edge x axis cross products, the triangle's
 * plane), evaluated in double, finds no separating axis against the cell's
 * box enlarged by eps on every side. eps = max(v / 1024, S / 65536) capped
 * at v / 4, S the largest |coordinate| or extent of the bounds: far above
 * the rounding of the triangle test and of the DDA's plane distances (a few
 * float ULPs of S), far below a voxel. The enlargement makes the test
 * conservative: every cell within eps of a triangle lists it, which is what
 * lets the traversal accept a hit only near the current cell (below).
 *
 * Invariants (verified by rt_grid_check):
 *   G1  resolution: n, lo, v and eps are what the rule above gives for the
 *       triangles' bounds and grid_min; ncells = nx ny nz <= 2^27;
 *   G2  tiling: on each axis plane(0) = bounds lo, planes strictly increase,
 *       plane(n) >= bounds hi and plane(n - 1) < bounds hi (n minimal), so
 *       the closed cell boxes tile the grid bounds, which hold the scene;
 *   G3  grid words: each is null or the offset of a list; non-empty lists
 *       follow each other in cell-id order from offset 0 with no gaps and
 *       end exactly at nlist; empty cells are null;
 *   G4  lists: non-empty, strictly ascending triangle indices < ntri, each
 *       ended by a null inside the list texture; nonempty and maxlist match;
 *   G5  exact listing: triangle t is in cell c iff rt_grid_tri_in_cell(t, c)
 *       (recomputed for every cell near each triangle, and the number of
 *       accepted pairs equals the number of list entries).
 *
 * Traversal. Amanatides and Woo's 3D-DDA: clip the ray to [tmin, tmax] and
 * the closed grid bounds, find the start cell, then repeatedly report the
 * cell with [entry, exit] and step the axis whose next plane crossing comes
 * first. Crossings are computed afresh per step as (plane - o) / d (no
 * accumulated increments, so no drift, and exact when the true value is a
 * float). Edge cases:
 *   - a zero direction component never steps; its cell is the half-open
 *     [plane(i), plane(i+1)) holding the origin (the last cell closed), so a
 *     ray lying in a cell face walks the cells on the face's upper side; a
 *     ray outside the slab misses the grid;
 *   - the start cell is the one the segment occupies just after the clipped
 *     entry: a start on a plane moving up is the upper cell, moving down the
 *     lower one; a first guess from the entry point is corrected by
 *     comparing the same plane crossings the walk uses, so it never
 *     disagrees with them;
 *   - crossings equal on several axes (the ray passes through an edge or a
 *     corner) step all those axes at once: cells the segment only touches
 *     in a point or line are not visited, no cell is visited twice;
 *   - the walk ends when the next crossing is at or beyond the clipped end;
 *     a segment touching the grid in one point visits one cell, [t, t].
 * So every cell the segment crosses with positive length (half-open on
 * zero-direction axes) is visited once, in order, and each exit equals the
 * next entry exactly.
 *
 * Closest hit. Each listed triangle is tested with the shared watertight
 * test (rt_isect_core) against the ray's own interval (tmin, tmax); a hit is
 * accepted only when its t lies in the current cell's [entry, exit] widened
 * by tol = eps / 2 / max|d| (the paper's rule: a triangle spanning cells is
 * taken where its hit lies; the widening absorbs rounding at cell faces and
 * at the grid boundary, and is covered by the listing's eps). The walk stops
 * after a cell when the best hit is < exit - tol: no later cell can accept
 * anything closer. Ties follow kdtrav.h: among equal t the lower triangle
 * index wins (a tie exactly on a cell face is seen, since the walk goes on
 * into the next cell while best >= exit - tol). Any-hit queries accept any
 * hit in (tmin, tmax).
 */
#include "config.h"
#include "grid.h"
#include "accel.h"

#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <stdio.h>
#include <string.h>

/* ---- resolution ----------------------------------------------------------- */

typedef struct res {
    uint32_t n[3];
    float lo[3], voxel, eps;
} res;

static int bounds_empty(const rt_bounds *b) { return !(b->lo.x <= b->hi.x && b->lo.y <= b->hi.y && b->lo.z <= b->hi.z); }

static float plane_of(const float lo[3], float v, int k, uint32_t i) { return lo[k] + (float)i * v; }

/* The resolution rule of the essay; 0 or -1 with a message. */
static int resolve(const rt_bounds *b, uint32_t grid_min, res *R, rt_err *e)
{
    if (grid_min < 1) return rt_errf(e, "grid: grid_min must be at least 1");
    if (grid_min > RT_GRID_MAX_CELLS)
        return rt_errf(e, "grid: grid_min %u exceeds the cell limit %u", grid_min, RT_GRID_MAX_CELLS);
    if (bounds_empty(b)) {
        for (int k = 0; k < 3; k++) {
            R->n[k] = 1;
            R->lo[k] = 0.0f;
        }
        R->voxel = 1.0f;
        R->eps = 1.0f / 1024.0f;
        return 0;
    }
    const float bl[3] = {b->lo.x, b->lo.y, b->lo.z}, bh[3] = {b->hi.x, b->hi.y, b->hi.z};
    float M = 0.0f, emax = 0.0f;
    int kmin = -1;
    for (int k = 0; k < 3; k++) {
        if (!isfinite(bl[k]) || !isfinite(bh[k])) return rt_errf(e, "grid: scene bounds are not finite");
        R->lo[k] = bl[k];
        M = fmaxf(M, fmaxf(fabsf(bl[k]), fabsf(bh[k])));
        float ext = bh[k] - bl[k];
        emax = fmaxf(emax, ext);
        if (ext > 0.0f && (kmin < 0 || ext < bh[kmin] - bl[kmin])) kmin = k;
    }
    float v;
    if (kmin < 0) {
        v = fmaxf(1.0f, M / 1024.0f);
    } else {
        v = (float)((double)(bh[kmin] - bl[kmin]) / grid_min);
        if (!(v > 0.0f)) return rt_errf(e, "grid: voxel size underflows");
        while (plane_of(R->lo, v, kmin, grid_min) < bh[kmin]) v = nextafterf(v, INFINITY);
    }
    float ulp = nextafterf(M, INFINITY) - M;
    if (!(v >= 8.0f * ulp))
        return rt_errf(e, "grid: voxel %g is below the float resolution of coordinates near %g (lower grid_min)",
                       (double)v, (double)M);
    uint64_t total = 1;
    for (int k = 0; k < 3; k++) {
        uint32_t n = 1;
        if (bh[k] > bl[k]) {
            double c = ceil((double)(bh[k] - bl[k]) / v);
            if (c > RT_GRID_MAX_CELLS) c = (double)RT_GRID_MAX_CELLS + 1;
            n = c < 1 ? 1 : (uint32_t)c;
            while (n > 1 && plane_of(R->lo, v, k, n - 1) >= bh[k]) n--;
            while (n <= RT_GRID_MAX_CELLS && plane_of(R->lo, v, k, n) < bh[k]) n++;
        }
        R->n[k] = n;
        total *= n;
        if (total > RT_GRID_MAX_CELLS) break;
    }
    if (total > RT_GRID_MAX_CELLS) {
        double want = 1;
        for (int k = 0; k < 3; k++)
            want *= bh[k] > bl[k] ? ceil((double)(bh[k] - bl[k]) / v) : 1.0;
        return rt_errf(e, "grid: grid_min %u needs %.0f cells, above the limit of 2^27 (lower grid_min)", grid_min,
                       want);
    }
    float S = fmaxf(M, emax);
    float eps = fmaxf(v / 1024.0f, S / 65536.0f);
    R->eps = fminf(eps, v / 4.0f);
    R->voxel = v;
    return 0;
}

static rt_bounds tri_bounds(const rt_scene *s)
{
    rt_bounds b = rt_bounds_empty();
    for (uint32_t i = 0; i < s->ntri; i++)
        for (int j = 0; j < 3; j++) rt_bounds_grow(&b, s->tri[i].p[j]);
    return b;
}

/* ---- overlap ------------------------------------------------------------- */

static inline double min3(double a, double b, double c) { return fmin(a, fmin(b, c)); }
static inline double max3(double a, double b, double c) { return fmax(a, fmax(b, c)); }

int rt_grid_tri_box(const rt_tri *tri, const double lo[3], const double hi[3])
{
    double c[3], h[3], v[3][3], ed[3][3];
    for (int k = 0; k < 3; k++) {
        c[k] = 0.5 * (lo[k] + hi[k]);
        h[k] = 0.5 * (hi[k] - lo[k]);
    }
    for (int i = 0; i < 3; i++) {
        const float *p = (const float *)(const void *)&tri->p[i];
        for (int k = 0; k < 3; k++) v[i][k] = (double)p[k] - c[k];
    }
    /* Box face normals: the triangle's bounds against the box. */
    for (int k = 0; k < 3; k++)
        if (min3(v[0][k], v[1][k], v[2][k]) > h[k] || max3(v[0][k], v[1][k], v[2][k]) < -h[k]) return 0;
    for (int k = 0; k < 3; k++) {
        ed[0][k] = v[1][k] - v[0][k];
        ed[1][k] = v[2][k] - v[1][k];
        ed[2][k] = v[0][k] - v[2][k];
    }
    /* Edge x unit axis: a = e x u_k. A zero axis (degenerate edge) gives
     * p = r = 0 and separates nothing. */
    for (int j = 0; j < 3; j++) {
        const double *E = ed[j];
        for (int k = 0; k < 3; k++) {
            double a[3];
            if (k == 0) { a[0] = 0; a[1] = E[2]; a[2] = -E[1]; }
            else if (k == 1) { a[0] = -E[2]; a[1] = 0; a[2] = E[0]; }
            else { a[0] = E[1]; a[1] = -E[0]; a[2] = 0; }
            double p0 = a[0] * v[0][0] + a[1] * v[0][1] + a[2] * v[0][2];
            double p1 = a[0] * v[1][0] + a[1] * v[1][1] + a[2] * v[1][2];
            double p2 = a[0] * v[2][0] + a[1] * v[2][1] + a[2] * v[2][2];
            double r = h[0] * fabs(a[0]) + h[1] * fabs(a[1]) + h[2] * fabs(a[2]);
            if (min3(p0, p1, p2) > r || max3(p0, p1, p2) < -r) return 0;
        }
    }
    /* The triangle's plane against the box. */
    double n[3] = {ed[0][1] * ed[1][2] - ed[0][2] * ed[1][1], ed[0][2] * ed[1][0] - ed[0][0] * ed[1][2],
                   ed[0][0] * ed[1][1] - ed[0][1] * ed[1][0]};
    double d = n[0] * v[0][0] + n[1] * v[0][1] + n[2] * v[0][2];
    double r = h[0] * fabs(n[0]) + h[1] * fabs(n[1]) + h[2] * fabs(n[2]);
    return !(fabs(d) > r);
}

void rt_grid_cell_box(const rt_grid *g, uint32_t ix, uint32_t iy, uint32_t iz, double lo[3], double hi[3])
{
    const uint32_t i[3] = {ix, iy, iz};
    for (int k = 0; k < 3; k++) {
        lo[k] = rt_grid_plane(g, k, i[k]);
        hi[k] = rt_grid_plane(g, k, i[k] + 1);
    }
}

int rt_grid_tri_in_cell(const rt_grid *g, const rt_tri *tri, uint32_t ix, uint32_t iy, uint32_t iz)
{
    double lo[3], hi[3];
    rt_grid_cell_box(g, ix, iy, iz, lo, hi);
    for (int k = 0; k < 3; k++) {
        lo[k] -= g->eps;
        hi[k] += g->eps;
    }
    return rt_grid_tri_box(tri, lo, hi);
}

/* Cells [*a, *b] along axis k that can meet [bmin, bmax] enlarged by eps,
 * widened by one cell each way (the overlap test decides; beyond that the
 * gap is >= v - 2 eps > 0). */
static void cell_range(const rt_grid *g, int k, float bmin, float bmax, uint32_t *a, uint32_t *b)
{
    double v = g->voxel, lo = g->lo[k], last = (double)g->n[k] - 1;
    double fa = floor(((double)bmin - g->eps - lo) / v) - 1, fb = floor(((double)bmax + g->eps - lo) / v) + 1;
    fa = fa < 0 ? 0 : (fa > last ? last : fa);
    fb = fb < 0 ? 0 : (fb > last ? last : fb);
    *a = (uint32_t)fa;
    *b = (uint32_t)fb;
}

static void tri_range(const rt_grid *g, const rt_tri *t, uint32_t a[3], uint32_t b[3])
{
    for (int k = 0; k < 3; k++) {
        float p0 = rt_axis(t->p[0], k), p1 = rt_axis(t->p[1], k), p2 = rt_axis(t->p[2], k);
        cell_range(g, k, fminf(p0, fminf(p1, p2)), fmaxf(p0, fmaxf(p1, p2)), &a[k], &b[k]);
    }
}

/* ---- build --------------------------------------------------------------- */

rt_grid *rt_grid_build(const rt_scene *s, uint32_t grid_min, rt_err *e)
{
    double t0 = rt_now();
    rt_bounds b = tri_bounds(s);
    res R;
    if (resolve(&b, grid_min, &R, e) < 0) return NULL;
    rt_grid *g = rt_calloc(1, sizeof *g, e);
    if (!g) return NULL;
    memcpy(g->n, R.n, sizeof g->n);
    memcpy(g->lo, R.lo, sizeof g->lo);
    g->voxel = R.voxel;
    g->eps = R.eps;
    g->grid_min = grid_min;
    g->ncells = R.n[0] * R.n[1] * R.n[2];
    g->ntri = s->ntri;
    g->bounds = b;
    uint32_t *refs = NULL, *tstart = NULL;
    size_t nrefs = 0, cap = 0;
    g->cells = rt_calloc(g->ncells, sizeof *g->cells, e); /* counts first */
    tstart = rt_calloc((size_t)s->ntri + 1, sizeof *tstart, e);
    if (!g->cells || !tstart) goto fail;
    /* Pass 1: the cells of each triangle, in triangle order. */
    for (uint32_t t = 0; t < s->ntri; t++) {
        tstart[t] = (uint32_t)nrefs;
        uint32_t a[3], c[3];
        tri_range(g, &s->tri[t], a, c);
        for (uint32_t iz = a[2]; iz <= c[2]; iz++)
            for (uint32_t iy = a[1]; iy <= c[1]; iy++)
                for (uint32_t ix = a[0]; ix <= c[0]; ix++) {
                    if (!rt_grid_tri_in_cell(g, &s->tri[t], ix, iy, iz)) continue;
                    if (nrefs == cap) {
                        size_t nc = cap ? cap * 2 : 4096;
                        uint32_t *p = rt_reallocarray(refs, nc, sizeof *p, e);
                        if (!p) goto fail;
                        refs = p;
                        cap = nc;
                    }
                    uint32_t id = rt_grid_cell_id(g, ix, iy, iz);
                    refs[nrefs++] = id;
                    g->cells[id]++;
                    if (nrefs >= UINT32_MAX - g->ncells) {
                        rt_errf(e, "grid: more than 2^32 - 2 list words (lower grid_min)");
                        goto fail;
                    }
                }
    }
    tstart[s->ntri] = (uint32_t)nrefs;
    /* Offsets: each non-empty list is its entries and a null. The word is
     * set to the list's end for the backward fill below. */
    uint64_t off = 0;
    for (uint32_t id = 0; id < g->ncells; id++) {
        uint32_t n = g->cells[id];
        if (n == 0) {
            g->cells[id] = RT_GRID_NULL;
            continue;
        }
        g->nonempty++;
        if (n > g->maxlist) g->maxlist = n;
        g->cells[id] = (uint32_t)(off + n);
        off += (uint64_t)n + 1;
    }
    g->nlist = (uint32_t)off;
    if (off) {
        g->list = rt_calloc(off, sizeof *g->list, e);
        if (!g->list) goto fail;
    }
    for (uint32_t id = 0; id < g->ncells; id++)
        if (g->cells[id] != RT_GRID_NULL) g->list[g->cells[id]] = RT_GRID_NULL;
    /* Fill backwards in triangle order, so lists come out ascending and
     * each word ends at its list's start. */
    for (uint32_t t = s->ntri; t-- > 0;)
        for (uint32_t r = tstart[t + 1]; r-- > tstart[t];) g->list[--g->cells[refs[r]]] = t;
    free(refs);
    free(tstart);
    g->build_sec = rt_now() - t0;
    return g;
fail:
    free(refs);
    free(tstart);
    rt_grid_free(g);
    return NULL;
}

void rt_grid_free(rt_grid *g)
{
    if (!g) return;
    free(g->cells);
    free(g->list);
    free(g);
}

void rt_grid_get_sizes(const rt_grid *g, rt_grid_sizes *z)
{
    z->grid_words = g->ncells;
    z->list_words = g->nlist;
    z->grid_bytes = (uint64_t)RT_GRID_WORD * g->ncells;
    z->list_bytes = (uint64_t)RT_GRID_WORD * g->nlist;
    z->vert_bytes = (uint64_t)RT_GRID_VERT_BYTES * g->ntri;
    z->shade_bytes = (uint64_t)sizeof(rt_shade) * g->ntri;
    z->total_bytes = z->grid_bytes + z->list_bytes + z->vert_bytes + z->shade_bytes;
}

double rt_grid_mean_list(const rt_grid *g)
{
    return g->nonempty ? (double)(g->nlist - g->nonempty) / g->nonempty : 0.0;
}

/* ---- check --------------------------------------------------------------- */

static int in_list(const rt_grid *g, uint32_t id, uint32_t t)
{
    uint32_t w = g->cells[id];
    if (w == RT_GRID_NULL) return 0;
    for (const uint32_t *p = g->list + w; *p != RT_GRID_NULL && *p <= t; p++)
        if (*p == t) return 1;
    return 0;
}

int rt_grid_check(const rt_grid *g, const rt_scene *s, rt_err *e)
{
    if (!g || !g->cells) return rt_errf(e, "grid: no grid texture");
    /* G1 */
    rt_bounds b = tri_bounds(s);
    res R;
    if (resolve(&b, g->grid_min, &R, e) < 0) return -1;
    if (g->ntri != s->ntri) return rt_errf(e, "grid: built over %u triangles, scene has %u", g->ntri, s->ntri);
    for (int k = 0; k < 3; k++)
        if (g->n[k] != R.n[k] || g->lo[k] != R.lo[k])
            return rt_errf(e, "G1: axis %d has %u cells from %g, the rule gives %u from %g", k, g->n[k],
                           (double)g->lo[k], R.n[k], (double)R.lo[k]);
    if (g->voxel != R.voxel || g->eps != R.eps)
        return rt_errf(e, "G1: voxel %g eps %g, the rule gives %g, %g", (double)g->voxel, (double)g->eps,
                       (double)R.voxel, (double)R.eps);
    if ((uint64_t)g->n[0] * g->n[1] * g->n[2] != g->ncells || g->ncells > RT_GRID_MAX_CELLS)
        return rt_errf(e, "G1: ncells %u is not %u x %u x %u within the limit", g->ncells, g->n[0], g->n[1], g->n[2]);
    /* G2 */
    if (!bounds_empty(&b)) {
        const float bl[3] = {b.lo.x, b.lo.y, b.lo.z}, bh[3] = {b.hi.x, b.hi.y, b.hi.z};
        for (int k = 0; k < 3; k++) {
            if (rt_grid_plane(g, k, 0) != bl[k]) return rt_errf(e, "G2: axis %d starts off the bounds", k);
            for (uint32_t i = 0; i < g->n[k]; i++)
                if (!(rt_grid_plane(g, k, i) < rt_grid_plane(g, k, i + 1)))
                    return rt_errf(e, "G2: axis %d planes %u and %u do not increase", k, i, i + 1);
            if (!(rt_grid_plane(g, k, g->n[k]) >= bh[k])) return rt_errf(e, "G2: axis %d ends inside the bounds", k);
            if (g->n[k] > 1 && !(rt_grid_plane(g, k, g->n[k] - 1) < bh[k]))
                return rt_errf(e, "G2: axis %d has a cell beyond the bounds", k);
        }
    }
    /* G3, G4 */
    uint64_t pos = 0;
    uint32_t nonempty = 0, maxlist = 0;
    for (uint32_t id = 0; id < g->ncells; id++) {
        uint32_t w = g->cells[id];
        if (w == RT_GRID_NULL) continue;
        if (w != pos) return rt_errf(e, "G3: cell %u list at %u, expected %llu", id, w, (unsigned long long)pos);
        uint32_t n = 0;
        for (;;) {
            if (pos >= g->nlist) return rt_errf(e, "G4: cell %u list runs off the list texture", id);
            uint32_t t = g->list[pos++];
            if (t == RT_GRID_NULL) break;
            if (t >= s->ntri) return rt_errf(e, "G4: cell %u lists triangle %u of %u", id, t, s->ntri);
            if (n > 0 && !(g->list[pos - 2] < t)) return rt_errf(e, "G4: cell %u list not ascending", id);
            n++;
        }
        if (n == 0) return rt_errf(e, "G4: cell %u has an empty list (must be null)", id);
        nonempty++;
        if (n > maxlist) maxlist = n;
    }
    if (pos != g->nlist) return rt_errf(e, "G3: lists end at %llu, texture has %u words", (unsigned long long)pos, g->nlist);
    if (nonempty != g->nonempty || maxlist != g->maxlist)
        return rt_errf(e, "G4: statistics nonempty %u maxlist %u, counted %u %u", g->nonempty, g->maxlist, nonempty,
                       maxlist);
    /* G5 */
    uint64_t accepted = 0;
    for (uint32_t t = 0; t < s->ntri; t++) {
        uint32_t a[3], c[3];
        tri_range(g, &s->tri[t], a, c);
        for (uint32_t iz = a[2]; iz <= c[2]; iz++)
            for (uint32_t iy = a[1]; iy <= c[1]; iy++)
                for (uint32_t ix = a[0]; ix <= c[0]; ix++) {
                    int want = rt_grid_tri_in_cell(g, &s->tri[t], ix, iy, iz);
                    int have = in_list(g, rt_grid_cell_id(g, ix, iy, iz), t);
                    if (want != have)
                        return rt_errf(e, "G5: triangle %u %s cell (%u,%u,%u) but the overlap test says %d", t,
                                       have ? "listed in" : "missing from", ix, iy, iz, want);
                    accepted += (uint64_t)want;
                }
    }
    if (accepted != (uint64_t)g->nlist - g->nonempty)
        return rt_errf(e, "G5: %llu accepted pairs but %u list entries", (unsigned long long)accepted,
                       g->nlist - g->nonempty);
    return 0;
}

/* ---- 3D-DDA --------------------------------------------------------------- */

static inline float cross_t(const rt_grid *g, int k, uint32_t i, float o, float d)
{
    return (rt_grid_plane(g, k, i) - o) / d;
}

int rt_grid_iter_init(rt_grid_iter *it, const rt_grid *g, const rt_ray *r, float tmin, float tmax)
{
    memset(it, 0, sizeof *it);
    it->g = g;
    const float o[3] = {r->o.x, r->o.y, r->o.z}, d[3] = {r->d.x, r->d.y, r->d.z};
    if (tmin != tmin || tmax != tmax) return 0;
    float t0 = tmin, t1 = tmax;
    for (int k = 0; k < 3; k++) {
        if (o[k] != o[k] || d[k] != d[k]) return 0;
        it->o[k] = o[k];
        it->d[k] = d[k];
        float a = rt_grid_plane(g, k, 0), b = rt_grid_plane(g, k, g->n[k]);
        if (d[k] == 0.0f) {
            if (o[k] < a || o[k] > b) return 0;
            continue;
        }
        float ta = (a - o[k]) / d[k], tb = (b - o[k]) / d[k];
        if (ta > tb) {
            float x = ta;
            ta = tb;
            tb = x;
        }
        if (ta > t0) t0 = ta;
        if (tb < t1) t1 = tb;
    }
    if (!(t0 <= t1)) return 0;
    for (int k = 0; k < 3; k++) {
        const uint32_t last = g->n[k] - 1;
        const float ok = o[k], dk = d[k];
        /* First guess from the entry point; corrected below with the very
         * comparisons the walk makes. */
        double p = dk == 0.0f ? (double)ok : (double)ok + (double)t0 * dk;
        double q = floor((p - g->lo[k]) / g->voxel);
        uint32_t i = !(q > 0) ? 0 : (q > last ? last : (uint32_t)q);
        if (dk == 0.0f) {
            while (i > 0 && ok < rt_grid_plane(g, k, i)) i--;
            while (i < last && ok >= rt_grid_plane(g, k, i + 1)) i++;
            it->step[k] = 0;
            it->tnext[k] = INFINITY;
        } else if (dk > 0.0f) {
            while (i < last && cross_t(g, k, i + 1, ok, dk) <= t0) i++;
            while (i > 0 && cross_t(g, k, i, ok, dk) > t0) i--;
            it->step[k] = 1;
            it->tnext[k] = cross_t(g, k, i + 1, ok, dk);
        } else {
            while (i > 0 && cross_t(g, k, i, ok, dk) <= t0) i--;
            while (i < last && cross_t(g, k, i + 1, ok, dk) > t0) i++;
            it->step[k] = -1;
            it->tnext[k] = cross_t(g, k, i, ok, dk);
        }
        it->i[k] = i;
    }
    it->t = t0;
    it->tend = t1;
    it->live = 1;
    return 1;
}

/* fminf(a, b) without the library call: the same value for every pair
 * with at most one NaN (the other operand), including which zero of an
 * equal pair of zeros (b, as glibc's minss-based fminf returns); two NaNs
 * give a NaN, as fminf does. The walk only compares the minimum, so even a
 * NaN's payload cannot show. */
static inline float min_num(float a, float b) { return (a < b || b != b) ? a : b; }

int rt_grid_iter_next(rt_grid_iter *it, rt_grid_cell *c)
{
    if (!it->live) return 0;
    const rt_grid *g = it->g;
    c->ix = it->i[0];
    c->iy = it->i[1];
    c->iz = it->i[2];
    c->id = rt_grid_cell_id(g, it->i[0], it->i[1], it->i[2]);
    c->t0 = it->t;
    float tx = min_num(it->tnext[0], min_num(it->tnext[1], it->tnext[2]));
    if (!(tx < it->tend)) { /* the segment ends in this cell */
        c->t1 = it->tend;
        it->live = 0;
        return 1;
    }
    float exit = tx < it->t ? it->t : tx; /* rounding: never before the entry */
    c->t1 = exit;
    for (int k = 0; k < 3; k++) {
        if (it->tnext[k] != tx) continue;
        if (it->step[k] > 0) {
            if (it->i[k] + 1 >= g->n[k]) { /* cannot happen: the clip ends first */
                it->live = 0;
                break;
            }
            it->i[k]++;
            it->tnext[k] = cross_t(g, k, it->i[k] + 1, it->o[k], it->d[k]);
        } else {
            if (it->i[k] == 0) {
                it->live = 0;
                break;
            }
            it->i[k]--;
            it->tnext[k] = cross_t(g, k, it->i[k], it->o[k], it->d[k]);
        }
    }
    it->t = exit;
    return 1;
}

uint64_t rt_grid_walk(const rt_grid *g, const rt_ray *r, float tmin, float tmax, rt_grid_visitor visit, void *ctx)
{
    rt_grid_iter it;
    rt_grid_cell c;
    uint64_t n = 0;
    if (!rt_grid_iter_init(&it, g, r, tmin, tmax)) return 0;
    while (rt_grid_iter_next(&it, &c)) {
        n++;
        if (visit(ctx, &c)) break;
    }
    return n;
}

float rt_grid_ttol(const rt_grid *g, const rt_ray *r)
{
    float m = fmaxf(fabsf(r->d.x), fmaxf(fabsf(r->d.y), fabsf(r->d.z)));
    return m > 0.0f ? 0.5f * g->eps / m : 0.0f;
}

int rt_grid_cell_closest(const rt_grid *g, const rt_scene *s, const rt_ray *r, const rt_grid_cell *c, float tol,
                         rt_hit *h, uint64_t *tests)
{
    return rt_grid_cell_closest_at(g, s, r, c, tol, h, tests, NULL, NULL);
}

int rt_grid_cell_closest_at(const rt_grid *g, const rt_scene *s, const rt_ray *r, const rt_grid_cell *c, float tol,
                            rt_hit *h, uint64_t *tests, const rt_alpha_at *at, rt_rec *rec)
{
    const uint32_t w = g->cells[c->id];
    if (w == RT_GRID_NULL) return h->tri != RT_NO_HIT;
    const float lo = c->t0 - tol, hi = c->t1 + tol, rtmin = r->tmin, rtmax = r->tmax;
    const rt_tri *tris = s->tri;
    int found = h->tri != RT_NO_HIT;
    float best = found ? h->t : rtmax, bu = h->u, bv = h->v;
    uint32_t besttri = found ? h->tri : 0, n = 0;
    for (const uint32_t *p = g->list + w; *p != RT_GRID_NULL; p++) {
        const uint32_t tri = *p;
        float t, u, v;
        n++;
        if (!rt_isect_core(r, &tris[tri], &t, &u, &v)) continue;
        if (!(t > rtmin && t < rtmax && t >= lo && t <= hi)) continue;
        if ((t < best || (t == best && tri < besttri)) && !rt_alpha_cut(s->alpha, at, rec, r, tri, u, v)) {
            found = 1;
            best = t;
            besttri = tri;
            bu = u;
            bv = v;
        }
    }
    if (tests) *tests += n;
    if (found) {
        h->t = best;
        h->tri = besttri;
        h->u = bu;
        h->v = bv;
    }
    return found;
}

int rt_grid_closest(const rt_grid *g, const rt_scene *s, const rt_ray *rp, rt_hit *h, rt_grid_count *cnt)
{
    const rt_ray ray = *rp, *r = &ray;
    rt_hit_none(h);
    rt_grid_iter it;
    if (!rt_grid_iter_init(&it, g, r, r->tmin, r->tmax)) return 0;
    const float tol = rt_grid_ttol(g, r);
    uint64_t ncell = 0, ntest = 0;
    int found = 0;
    rt_grid_cell c;
    while (rt_grid_iter_next(&it, &c)) {
        ncell++;
        found = rt_grid_cell_closest(g, s, r, &c, tol, h, &ntest);
        if (found && h->t < c.t1 - tol) break;
    }
    if (cnt) {
        cnt->cells += ncell;
        cnt->tests += ntest;
    }
    return found;
}

int rt_grid_any(const rt_grid *g, const rt_scene *s, const rt_ray *rp, rt_grid_count *cnt)
{
    const rt_ray ray = *rp, *r = &ray;
    rt_grid_iter it;
    if (!rt_grid_iter_init(&it, g, r, r->tmin, r->tmax)) return 0;
    const rt_tri *tris = s->tri;
    uint64_t ncell = 0, ntest = 0;
    int hit = 0;
    rt_grid_cell c;
    while (!hit && rt_grid_iter_next(&it, &c)) {
        ncell++;
        const uint32_t w = g->cells[c.id];
        if (w == RT_GRID_NULL) continue;
        for (const uint32_t *p = g->list + w; *p != RT_GRID_NULL; p++) {
            float t, u, v;
            ntest++;
            if (rt_isect_core(r, &tris[*p], &t, &u, &v) && t > r->tmin && t < r->tmax &&
                !rt_alpha_cut(s->alpha, NULL, NULL, r, *p, u, v)) {
                hit = 1;
                break;
            }
        }
    }
    if (cnt) {
        cnt->cells += ncell;
        cnt->tests += ntest;
    }
    return hit;
}

/* ---- the grid as a member of the acceleration layer (accel.h) ------------ */

uint32_t rt_grid_density_min(const rt_scene *s, double density)
{
    rt_bounds b = tri_bounds(s);
    if (bounds_empty(&b) || !s->ntri || !(density > 0)) return 1;
    const double ext[3] = {(double)b.hi.x - b.lo.x, (double)b.hi.y - b.lo.y, (double)b.hi.z - b.lo.z};
    double vol = 1, emin = 0;
    int d = 0;
    for (int k = 0; k < 3; k++)
        if (ext[k] > 0) {
            vol *= ext[k];
            emin = d++ ? fmin(emin, ext[k]) : ext[k];
        }
    if (!d) return 1;
    double edge = pow(vol / (density * (double)s->ntri), 1.0 / d), m = floor(emin / edge + 0.5);
    return m < 1 ? 1 : m > RT_GRID_MAX_CELLS ? RT_GRID_MAX_CELLS : (uint32_t)m;
}

/* An explicit grid_min is used as given (an oversized grid is an error
 * naming the limit); so is the grid_min of the density rule; 0 means 64
 * (the paper's bunny), halved while the grid would exceed RT_GRID_MAX_CELLS
 * (grove: 32). */
static void *grid_build(const rt_scene *sc, const rt_accel_params *p, rt_err *e)
{
    rt_grid *g = NULL;
    if (p->grid_density > 0) {
        const uint32_t m = rt_grid_density_min(sc, p->grid_density);
        if (!(g = rt_grid_build(sc, m, e))) {
            char msg[sizeof e->msg];
            snprintf(msg, sizeof msg, "%s", e->msg);
            if (strstr(msg, "above the limit of 2^27"))
                rt_errf_usage(e, "--grid-density %g: %s (at most %u cells)", p->grid_density, msg,
                              (unsigned)RT_GRID_MAX_CELLS);
            else
                rt_errf(e, "--grid-density %g: %s", p->grid_density, msg);
        }
        return g;
    }
    if (p->grid_min) {
        if (!(g = rt_grid_build(sc, p->grid_min, e))) {
            char msg[sizeof e->msg];
            snprintf(msg, sizeof msg, "%s", e->msg);
            /* a grid over the cell limit asks too much of the option */
            if (strstr(msg, "above the limit of 2^27"))
                rt_errf_usage(e, "--grid-min %u: %s (at most %u cells)", (unsigned)p->grid_min, msg,
                              (unsigned)RT_GRID_MAX_CELLS);
            else
                rt_errf(e, "--grid-min %u: %s", (unsigned)p->grid_min, msg);
        }
        return g;
    }
    for (uint32_t m = RT_GRID_MIN_DEFAULT; m >= 1 && !g; m /= 2) {
        rt_err e2 = {0};
        g = rt_grid_build(sc, m, &e2);
        if (!g && (m == 1 || !strstr(e2.msg, "cells"))) {
            rt_errf(e, "%s", e2.msg);
            break;
        }
    }
    return g;
}

static void grid_free(void *as) { rt_grid_free(as); }

/* grid.cells and grid.lists, one 4-byte texel each (Purcell et al.'s grid
 * and list textures). */
static int grid_regions(const void *as, const rt_scene *sc, rt_layout *L, rt_err *e)
{
    const rt_grid *g = as;
    (void)sc;
    if (rt_mm_add(L, "grid.cells", RT_CLS_NODE, RT_GRID_WORD, g->ncells, e) < 0) return -1;
    return rt_mm_add(L, "grid.lists", RT_CLS_INDEX, RT_GRID_WORD, g->nlist ? g->nlist : 1, e) < 0 ? -1 : 0;
}

static void grid_trav_init(rt_trav *tv, const void *as, const rt_layout *L)
{
    tv->as = as;
    tv->reg_node = rt_mm_find(L, "grid.cells");
    tv->reg_idx = rt_mm_find(L, "grid.lists");
}

/* The single-ray walk counts cells as node visits and triangle tests; the
 * grid tracers record their kernels' texel reads themselves (stream.c,
 * feedback.c), so this walk records nothing. */
static int grid_closest(rt_trav *tv, const rt_ray *r, rt_hit *h)
{
    rt_grid_count c = {0, 0};
    int hit = rt_grid_closest(tv->as, tv->sc, r, h, &c);
    tv->nodes += c.cells;
    tv->tests += c.tests;
    return hit;
}

static int grid_occluded(rt_trav *tv, const rt_ray *r)
{
    rt_grid_count c = {0, 0};
    int hit = rt_grid_any(tv->as, tv->sc, r, &c);
    tv->nodes += c.cells;
    tv->tests += c.tests;
    return hit;
}

static int grid_check(const void *as, const rt_scene *sc, rt_err *e) { return rt_grid_check(as, sc, e); }

static void grid_info(const void *as, rt_accel_info *inf)
{
    const rt_grid *g = as;
    inf->nodes = g->ncells;
    inf->bytes = (uint64_t)RT_GRID_WORD * ((uint64_t)g->ncells + g->nlist);
}

const rt_accel_ops rt_accel_grid = {
    .name = "grid",
    .desc = "uniform grid, 3D-DDA (Purcell et al. 2002)",
    .build = grid_build,
    .free = grid_free,
    .regions = grid_regions,
    .trav_init = grid_trav_init,
    .closest = grid_closest,
    .occluded = grid_occluded,
    .check = grid_check,
    .info = grid_info,
};
