/*
 * hit.h -- what every acceleration structure's walk returns and counts
 * (prefix rt_hit_, rt_trav, rt_brute_), independent of the structure.
 *
 * The hit rule, shared by every structure and by the brute-force reference
 * so that images are bit-identical whatever the structure: a triangle is
 * hit when the watertight test (isect.h) finds t in (r->tmin, r->tmax); of
 * all hits the smallest t wins, and among hits at the same t the lowest
 * triangle index (the scene's original index, whatever order a structure
 * stores triangles in) wins. A hit that the scene's alpha texture cuts
 * away (rt_alpha_cut, src/alpha.h) is no hit: every walk asks the filter
 * of each hit it would accept and goes on past the cut ones, so the rule
 * holds among the hits not cut.
 */
#ifndef RT_HIT_H
#define RT_HIT_H

#include "alpha.h"
#include "isect.h"
#include "memmodel.h"
#include "scene.h"

#include <math.h>
#include <stdint.h>

typedef struct rt_hit {
    float t;       /* parametric distance along the ray */
    uint32_t tri;  /* triangle index, RT_NO_HIT when none */
    float u, v;    /* barycentrics */
} rt_hit;

#define RT_NO_HIT UINT32_MAX

static inline void rt_hit_none(rt_hit *h)
{
    h->t = INFINITY;
    h->tri = RT_NO_HIT;
    h->u = h->v = 0.0f;
}

/* 1 when a hit at (t, tri) beats *h under the hit rule above. */
static inline int rt_hit_better(const rt_hit *h, float t, uint32_t tri)
{
    return t < h->t || (t == h->t && tri < h->tri);
}

struct rt_kdtree;
struct rt_bvh;

/* The state of walking one structure of one scene: what a walk records into
 * and the running counts every structure keeps the same way. */
typedef struct rt_trav {
    union {                          /* the structure walked (rt_accel.as) */
        const struct rt_kdtree *kd;  /* RT_ACCEL_KD */
        const struct rt_bvh *bvh;    /* RT_ACCEL_BVH2/4/8 */
        const void *as;
    };
    const rt_scene *sc;
    rt_rec *rec;         /* NULL: not recording */
    const rt_layout *L;  /* modeled layout (needed only when rec != NULL) */
    int reg_node, reg_idx, reg_tri; /* region indices in L (-1: the structure has none) */
    uint64_t nodes;      /* nodes visited (running count) */
    uint64_t tests;      /* ray/triangle tests (running count) */
    uint8_t *mark;       /* optional per-triangle flags: mark[tri] |= mark_bit
                            on every test ("potentially visible" statistics) */
    uint8_t mark_bit;
    int width;           /* BVH branching factor (2, 4, 8); 0 for other structures */
    int reg_top, reg_inst; /* inst: the top-level nodes' and instance records' regions (-1: none) */
    uint64_t xforms;     /* inst: rays transformed into an object's space (running count) */
    rt_alpha_at alpha;   /* where the alpha filter's reads are recorded (rt_alpha_at_init) */
} rt_trav;

/* Brute force over all triangles: the obviously-correct reference (the
 * alpha filter applied to every hit, nothing recorded). */
int rt_brute_closest(const rt_scene *sc, const rt_ray *r, rt_hit *h);
int rt_brute_occluded(const rt_scene *sc, const rt_ray *r);

#endif
