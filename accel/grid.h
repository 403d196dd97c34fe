/*
 * grid.h -- the uniform grid of Purcell et al. (2002) and its 3D-DDA walk.
 *
 * The grid is stored as the paper's Figure 4 textures, the records a grid
 * tracer reads and the memory model charges for (word size 4 bytes):
 *   grid texture   one word per cell, cell id = (iz * ny + iy) * nx + ix:
 *                  the offset of the cell's list in the list texture, or
 *                  RT_GRID_NULL for an empty cell;
 *   list texture   per non-empty cell, its triangle indices ("pointers to
 *                  vertex data") in ascending order, then RT_GRID_NULL;
 *                  lists are laid out in cell-id order;
 *   vertex data    the scene's triangles, three RGB float texels = 36 bytes
 *                  per triangle (rt_scene.tri);
 *   shading data   the scene's per-triangle rt_shade records (16 bytes).
 * Cells are near-cubic with edge `voxel`; the cell boundary planes of axis
 * k are rt_grid_plane(g, k, i) = lo[k] + i * voxel (float arithmetic), for
 * i = 0..n[k]. The essay at the top of grid.c gives the resolution rule,
 * the overlap test, the DDA's edge cases and the invariants rt_grid_check
 * verifies.
 */
#ifndef RT_GRID_H
#define RT_GRID_H

#include "isect.h"
#include "hit.h"
#include "rt.h"
#include "rt_math.h"
#include "scene.h"

#include <stdint.h>

#define RT_GRID_NULL 0xffffffffu      /* empty cell / end of a triangle list */
#define RT_GRID_WORD 4u               /* bytes per grid and list texel */
#define RT_GRID_VERT_BYTES 36u        /* vertex data per triangle */
#define RT_GRID_MAX_CELLS (1u << 27)  /* 512 MiB of grid texture */
#define RT_GRID_MIN_DEFAULT 64        /* the paper's bunny; 128 for its large scenes */
#define RT_GRID_DENSITY_MAX 1024      /* largest --grid-density (cells per triangle) */

typedef struct rt_grid {
    uint32_t n[3];      /* cells along x, y, z (each >= 1) */
    uint32_t ncells;    /* n[0] * n[1] * n[2] <= RT_GRID_MAX_CELLS */
    float lo[3];        /* grid origin = lower corner of the scene bounds */
    float voxel;        /* cell edge length (> 0) */
    float eps;          /* overlap epsilon: cells are enlarged by it when listing */
    uint32_t grid_min;  /* cells along the smallest non-flat axis (as requested) */
    uint32_t *cells;    /* grid texture, ncells words */
    uint32_t *list;     /* list texture, nlist words (NULL when nlist = 0) */
    uint32_t nlist;     /* list words, terminators included */
    uint32_t ntri;      /* triangles of the scene it was built over */
    rt_bounds bounds;   /* bounds of the triangles' vertices (lo > hi: empty) */
    /* statistics */
    uint32_t nonempty;  /* cells with a list */
    uint32_t maxlist;   /* most triangles in one cell */
    double build_sec;   /* wall time of rt_grid_build */
} rt_grid;

/* Builds the grid over all triangles of s with grid_min cells along the
 * smallest non-flat axis of the bounds. Returns NULL with a message when
 * grid_min < 1, when the grid would exceed RT_GRID_MAX_CELLS cells or 2^32-1
 * list words, when the voxel falls below the float resolution of the
 * coordinates, or on out-of-memory. Free with rt_grid_free. */
rt_grid *rt_grid_build(const rt_scene *s, uint32_t grid_min, rt_err *e);

/* The density rule (--grid-density): the grid_min whose cubic voxels give
 * about density x ntri cells over the triangles' bounds (the usual rule for
 * uniform grids: the voxel edge is (product of the non-flat extents /
 * (density ntri))^(1/d) over the d non-flat axes, and the smallest non-flat
 * axis gets extent / edge cells, rounded, at least 1). 1 for an empty scene
 * or one flat on every axis. density > 0. */
uint32_t rt_grid_density_min(const rt_scene *s, double density);
void rt_grid_free(rt_grid *g);

/* Verifies the invariants G1-G5 of grid.c against the scene it was built
 * over; 0 if all hold, else -1 with the first violation. For tests: it
 * re-runs the overlap test for every triangle near every cell it touches. */
int rt_grid_check(const rt_grid *g, const rt_scene *s, rt_err *e);

/* Boundary plane i (0..n[k]) of axis k. Every box, clip and crossing uses
 * this one expression, so cells tile the grid bounds exactly. */
static inline float rt_grid_plane(const rt_grid *g, int k, uint32_t i) { return g->lo[k] + (float)i * g->voxel; }

static inline uint64_t rt_grid_cells(const rt_grid *g) { return g->ncells; }
static inline uint32_t rt_grid_cell_id(const rt_grid *g, uint32_t ix, uint32_t iy, uint32_t iz)
{
    return (iz * g->n[1] + iy) * g->n[0] + ix;
}

/* Sizes of the four textures in the modeled memory. */
typedef struct rt_grid_sizes {
    uint64_t grid_words;  /* = ncells */
    uint64_t list_words;  /* = nlist (triangle references + one null per non-empty cell) */
    uint64_t grid_bytes;  /* 4 per cell */
    uint64_t list_bytes;  /* 4 per list word */
    uint64_t vert_bytes;  /* 36 per triangle */
    uint64_t shade_bytes; /* sizeof(rt_shade) = 16 per triangle */
    uint64_t total_bytes; /* sum of the four */
} rt_grid_sizes;
void rt_grid_get_sizes(const rt_grid *g, rt_grid_sizes *z);
/* Mean triangles per non-empty cell (0 when all are empty). */
double rt_grid_mean_list(const rt_grid *g);

/* The closed box of cell (ix, iy, iz), not enlarged, as doubles. */
void rt_grid_cell_box(const rt_grid *g, uint32_t ix, uint32_t iy, uint32_t iz, double lo[3], double hi[3]);
/* Akenine-Möller's separating-axis triangle/box test in double precision:
 * 1 when the triangle meets the closed box [lo, hi] (up to double rounding,
 * far below the grid's eps); also correct for degenerate triangles. */
int rt_grid_tri_box(const rt_tri *tri, const double lo[3], const double hi[3]);
/* The listing rule: 1 when tri meets the cell's box enlarged by g->eps.
 * The build lists a triangle in exactly the cells where this returns 1. */
int rt_grid_tri_in_cell(const rt_grid *g, const rt_tri *tri, uint32_t ix, uint32_t iy, uint32_t iz);

/* ---- 3D-DDA (Amanatides and Woo) ---------------------------------------- */

typedef struct rt_grid_cell {
    uint32_t ix, iy, iz; /* cell coordinates */
    uint32_t id;         /* grid-texture index */
    float t0, t1;        /* parametric entry and exit (t0 <= t1) */
} rt_grid_cell;

/* Walk state; plain data, so a tracer may keep one per ray between steps. */
typedef struct rt_grid_iter {
    const rt_grid *g;
    float o[3], d[3];    /* the ray */
    uint32_t i[3];       /* current cell */
    int step[3];         /* +1, -1, or 0 on an axis the ray does not move along */
    float tnext[3];      /* t of the next plane crossing per axis (+inf if none) */
    float t, tend;       /* entry of the current cell, end of the clipped segment */
    int live;            /* 1 while a cell remains to report */
} rt_grid_iter;

/* Clips the ray to [tmin, tmax] and the grid bounds (closed). Returns 1 when
 * at least one cell is to be visited, 0 when the segment misses the grid
 * (or the ray has a NaN). */
int rt_grid_iter_init(rt_grid_iter *it, const rt_grid *g, const rt_ray *r, float tmin, float tmax);
/* Reports the next cell in order along the ray: 1 and *c filled, or 0 at
 * the end. Consecutive cells share their boundary t exactly (exit of one =
 * entry of the next); the first entry is the clipped start, the last exit
 * the clipped end; no cell is reported twice. */
int rt_grid_iter_next(rt_grid_iter *it, rt_grid_cell *c);

/* Calls visit(ctx, cell) for each cell in order until it returns non-zero.
 * Returns the number of cells visited. */
typedef int (*rt_grid_visitor)(void *ctx, const rt_grid_cell *c);
uint64_t rt_grid_walk(const rt_grid *g, const rt_ray *r, float tmin, float tmax, rt_grid_visitor visit, void *ctx);

/* Running counters of the two queries (may be NULL). */
typedef struct rt_grid_count {
    uint64_t cells; /* cells stepped through (grid-texture reads) */
    uint64_t tests; /* ray/triangle tests (list and vertex reads) */
} rt_grid_count;

/* Half-width in t of the acceptance window around a cell's [t0, t1]
 * (eps / 2 along the ray's fastest axis); 0 for a zero direction. */
float rt_grid_ttol(const rt_grid *g, const rt_ray *r);

/* Closest hit in (r->tmin, r->tmax) over scene s (the one g was built
 * over): walks the cells front to back, tests each listed triangle and
 * accepts a hit only when its t lies in the current cell's [t0, t1]
 * widened by rt_grid_ttol; stops after the first cell whose exit (less the
 * tolerance) lies beyond the best hit. Equal t: the lower triangle index
 * wins, as in kdtrav.h, so the result equals rt_kd_closest and
 * rt_brute_closest. Returns 1 and fills *h, or 0 with rt_hit_none(h). */
int rt_grid_closest(const rt_grid *g, const rt_scene *s, const rt_ray *r, rt_hit *h, rt_grid_count *cnt);
/* One step of it (the paper's intersection kernel for one ray-voxel pair):
 * tests the triangles listed in cell c, accepting hits in (r->tmin,
 * r->tmax) that lie in [c->t0 - tol, c->t1 + tol]. *h is in/out: set
 * rt_hit_none(h) before the first cell; a hit already in it is replaced
 * only by a closer one (equal t: lower triangle index). Adds the tests made
 * to *tests (may be NULL). Returns 1 when *h holds a hit afterwards. */
int rt_grid_cell_closest(const rt_grid *g, const rt_scene *s, const rt_ray *r, const rt_grid_cell *c, float tol,
                         rt_hit *h, uint64_t *tests);
/* The same, recording the alpha filter's reads into rec at the addresses
 * of at (either may be NULL).
 * Every grid walk applies the filter (rt_alpha_cut) to the hits it would
 * accept; the others record nothing. */
int rt_grid_cell_closest_at(const rt_grid *g, const rt_scene *s, const rt_ray *r, const rt_grid_cell *c, float tol,
                            rt_hit *h, uint64_t *tests, const rt_alpha_at *at, rt_rec *rec);
/* Any hit in (r->tmin, r->tmax) (shadow rays); the cell window does not
 * apply. Returns 1 if occluded. */
int rt_grid_any(const rt_grid *g, const rt_scene *s, const rt_ray *r, rt_grid_count *cnt);

#endif
