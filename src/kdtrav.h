/*
 * kdtrav.h -- single-ray k-d tree traversal with memory-access recording.
 *
 * Front-to-back traversal with a fixed stack (pbrt's algorithm). Every node
 * visited is one 8-byte read of the node region; at a leaf, its index-list
 * entries are read as one access of 4 * ntri bytes, then each triangle
 * tested is one 36-byte read of the triangle region. No mailboxing: a
 * triangle referenced by several leaves is re-read and re-tested, as in the
 * tracers the paper measured. The recorder may be NULL (no recording).
 * Ties: among hits at the same t the lower triangle index wins, in both
 * the tree traversal and the brute-force reference, so they agree exactly.
 */
#ifndef RT_KDTRAV_H
#define RT_KDTRAV_H

#include "isect.h"
#include "kdtree.h"
#include "memmodel.h"

typedef struct rt_hit {
    float t;       /* parametric distance along the ray */
    uint32_t tri;  /* triangle index, RT_NO_HIT when none */
    float u, v;    /* barycentrics */
} rt_hit;

#define RT_NO_HIT UINT32_MAX
#define RT_KD_STACK 64

/* Shared state for traversing one tree of one scene. */
typedef struct rt_trav {
    const rt_kdtree *kd;
    const rt_scene *sc;
    rt_rec *rec;         /* NULL: not recording */
    const rt_layout *L;  /* modeled layout (needed only when rec != NULL) */
    int reg_node, reg_idx, reg_tri; /* region indices in L */
    uint64_t nodes;      /* nodes visited (running count) */
    uint64_t tests;      /* ray/triangle tests (running count) */
    uint8_t *mark;       /* optional per-triangle flags: mark[tri] |= mark_bit
                            on every test ("potentially visible" statistics) */
    uint8_t mark_bit;
} rt_trav;

/* Clips r to the tree bounds; returns 0 when the ray misses them. */
int rt_kd_clip(const rt_kdtree *kd, const rt_ray *r, float *t0, float *t1);

/* Closest hit in (r->tmin, r->tmax). Returns 1 and fills *h on a hit. */
int rt_kd_closest(rt_trav *tv, const rt_ray *r, rt_hit *h);
/* Any hit in (r->tmin, r->tmax) (shadow rays). Returns 1 if occluded. */
int rt_kd_occluded(rt_trav *tv, const rt_ray *r);

/* Brute force over all triangles: the obviously-correct reference. */
int rt_brute_closest(const rt_scene *sc, const rt_ray *r, rt_hit *h);
int rt_brute_occluded(const rt_scene *sc, const rt_ray *r);

#endif
