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
 * the tree traversal and the brute-force reference, and the walk returns
 * brute force's hit bit for bit on every ray but one that starts exactly
 * on a triangle lying flat in a split plane (docs/kdtree.md, "Agreement
 * with brute force"; rt_kd_step below).
 *
 * What is modeled and what runs are separate: the accesses above describe
 * the modeled walk, while the host walks the tree's host-side copy
 * (kdtree.h: the same nodes, leaf triangles four to a quad) and tests a
 * leaf's triangles four per SSE2 computation, each lane the scalar test's
 * arithmetic. Hits (t, u, v, triangle), node and test counts, marks and the
 * recorded stream are those of the plain scalar walk, which stays
 * (rt_kd_plain_sub) as the reference the tests compare against and as the
 * walk of trees without the copy.
 */
#ifndef RT_KDTRAV_H
#define RT_KDTRAV_H

#include "hit.h"
#include "isect.h"
#include "kdtree.h"
#include "memmodel.h"

#define RT_KD_STACK 64

/*
 * Early exit of closest-hit traversal: stop before a node whose entry
 * distance tmin lies beyond the best hit so far. pbrt stops at best < tmin;
 * here the test is widened by 2^-16 relative, because a hit lying in a split
 * plane is computed (by the triangle test) with a rounding different from
 * the plane distance, and a triangle in the next cell at the same t (a tie
 * the lower index must win) or a hair closer must still be found.
 * Schedulers that walk the tree themselves should use the same test.
 */
static inline int rt_kd_past(float best, float tmin) { return best < tmin * (1.0f - 1.0f / 65536.0f); }

/*
 * The front-to-back rule at an interior node, shared by every walk of the
 * tree (the single-ray walks here, the packet and dynamic tracers, the
 * tests' cut walk). tPlane = (split - o) * inv_d on the node's axis, the
 * node's interval is [tMin, tMax], and the near child is the side holding
 * the origin (on the plane: the side the direction points to). Returns
 * RT_KD_NEAR (the near child only, over [tMin, tMax]), RT_KD_FAR (the far
 * child only, over [tMin, tMax]) or a value with both bits (RT_KD_BOTH):
 * the near child over [tMin, *near_end], then the far child over
 * [*far_start, tMax].
 *
 * pbrt's rule, with two additions:
 *   - tPlane NaN (the ray lies in the split plane): both children over the
 *     whole interval, returned as RT_KD_BOTH | RT_KD_INPLANE. Only this
 *     case pushes a far child that begins before the entries pushed after
 *     it; without it a stack walk's entries begin later the deeper they
 *     lie, and a walk may stop at the first one past its best hit;
 *   - a crossing within RT_KD_TOUCH relative beyond the interval's end (or
 *     before its start) counts as inside it: the ray leaves the cell
 *     through (or enters it at) an edge or corner where the split meets
 *     another plane, and the computed distances of the two planes differ
 *     by a few roundings, so the cell on the other side is visited too,
 *     over the single point [tMax, tMax] (or [tMin, tMin] for the near
 *     child). A triangle whose vertex or edge lies on that edge of the
 *     cells -- one the watertight test hits -- may be listed only there
 *     (kdtree.h: a box touching a split plane from one side goes to that
 *     side).
 * A plane at or behind the origin (tPlane <= 0, not NaN) is never crossed:
 * the near child only, even for a ray starting on the plane.
 *
 * rt_kd_step_w is the same rule with the widened bounds tMinW =
 * rt_kd_wlo(tMin) and tMaxW = rt_kd_whi(tMax) passed in, for walks that
 * keep them next to their interval (one multiplication when the interval
 * changes, none per node); the decisions are the same.
 */
enum { RT_KD_NEAR = 1, RT_KD_FAR = 2, RT_KD_BOTH = 3, RT_KD_INPLANE = 4 };

/* 2^-22 relative, four units in the last place. Each plane distance is
 * three roundings (1/d, split - o, the product), so the distances of two
 * planes through one point can differ by up to about six. On rays through
 * vertices and along edges of the test scenes a band of 2^-23 still left 5
 * hits hidden in 200,000 per scene, 2^-22 none in 1 million. The band is kept
 * that narrow because a ray that passes this close to a cell edge visits
 * one more cell: at 2^-22 one to three primary or secondary rays in
 * 10,000, and a few of cornell's primary rays, which its symmetric camera
 * (eye at x = z = 0.5) sends within two ulps of the edge where the planes
 * x = 0.6 and z = 0.6 meet. 0 restores pbrt's rule exactly. */
#define RT_KD_TOUCH (1.0f / 4194304.0f)

static inline float rt_kd_wlo(float tMin) { return tMin * (1.0f - RT_KD_TOUCH); }
static inline float rt_kd_whi(float tMax) { return tMax * (1.0f + RT_KD_TOUCH); }

static inline int rt_kd_step_w(float tPlane, float tMin, float tMax, float tMinW, float tMaxW, float *near_end,
                               float *far_start)
{
    if (tPlane > tMaxW || tPlane <= 0.0f) return RT_KD_NEAR;
    if (tPlane < tMinW) return RT_KD_FAR;
    if (tPlane <= tMax && tPlane >= tMin) { /* crosses inside the interval (pbrt) */
        *near_end = *far_start = tPlane;
        return RT_KD_BOTH;
    }
    if (tPlane > tMax) { /* leaves through an edge: the far cell at that point */
        *near_end = *far_start = tMax;
        return RT_KD_BOTH;
    }
    if (tPlane < tMin) { /* entered through an edge: the near cell at that point */
        *near_end = *far_start = tMin;
        return RT_KD_BOTH;
    }
    *near_end = tMax; /* NaN: the ray lies in the split plane */
    *far_start = tMin;
    return RT_KD_BOTH | RT_KD_INPLANE;
}

static inline int rt_kd_step(float tPlane, float tMin, float tMax, float *near_end, float *far_start)
{
    return rt_kd_step_w(tPlane, tMin, tMax, rt_kd_wlo(tMin), rt_kd_whi(tMax), near_end, far_start);
}

/* Clips r to the tree bounds; returns 0 when the ray misses them. */
int rt_kd_clip(const rt_kdtree *kd, const rt_ray *r, float *t0, float *t1);

/* Closest hit in (r->tmin, r->tmax). Returns 1 and fills *h on a hit; on a
 * miss returns 0 with h->tri = RT_NO_HIT and h->t = +inf. */
int rt_kd_closest(rt_trav *tv, const rt_ray *r, rt_hit *h);
/* Any hit in (r->tmin, r->tmax) (shadow rays). Returns 1 if occluded. */
int rt_kd_occluded(rt_trav *tv, const rt_ray *r);

/*
 * Subtree-restricted traversal (for ray schedulers that resume a ray at a
 * queue point): traverses only the subtree rooted at `node` over the
 * parametric interval [t0, t1] (the ray's extent inside that node's cell;
 * the ray's own (tmin, tmax) still bounds accepted hits). Records and counts
 * exactly as the full traversal does from that node on.
 * rt_kd_closest_sub: *h is in/out; set h->tri = RT_NO_HIT (rt_hit_none) before
 * the first call. A hit already in *h is replaced only by a closer one (equal
 * t: lower triangle index), and the walk stops early once h->t lies before
 * the next node's entry. Returns 1 when *h holds a hit afterwards.
 * rt_kd_occluded_sub: returns 1 on any hit in (r->tmin, r->tmax).
 */
int rt_kd_closest_sub(rt_trav *tv, const rt_ray *r, uint32_t node, float t0, float t1, rt_hit *h);
int rt_kd_occluded_sub(rt_trav *tv, const rt_ray *r, uint32_t node, float t0, float t1);

/*
 * One leaf's tests, for tracers that walk the tree themselves (the dynamic
 * scheduler): the entries of leaf `node` against r in list order, as that
 * leaf's part of the traversal does -- the index-list read and one
 * triangle read per entry recorded on tv->rec, tv->tests counted, tv->mark
 * set -- accepting a hit whose t lies in (r->tmin, r->tmax) and beats *h
 * (any hit when h->tri == RT_NO_HIT; equal t: the lower triangle index).
 * any = 1 (h unused): returns 1 at the first such hit, the entries after
 * it untested, uncounted and unrecorded. any = 0: returns 1 when *h was
 * replaced. Uses the host copy's quads when the tree has them.
 */
int rt_kd_leaf(rt_trav *tv, const rt_ray *r, uint32_t node, rt_hit *h, int any);

/*
 * rt_kd_leaf's tests alone, for tracers that read, count and mark a leaf's
 * triangles in their own order (the packet tracer): nothing is recorded,
 * counted or marked here. Sets *ntested to the entries tested: all of them
 * for any = 0, for any = 1 those up to and including the first hit (or
 * all); the hit rule and return value are rt_kd_leaf's.
 */
int rt_kd_leaf_scan(const rt_trav *tv, const rt_ray *r, uint32_t node, rt_hit *h, int any, uint32_t *ntested);

/*
 * The plain walk: the subtree-restricted traversal above (any = 0: closest,
 * *h in/out; any = 1: occlusion, h unused) on the modeled nodes only,
 * one scalar test per entry. The entry points above take the same walk on
 * the tree's host-side copy when it has one (kdtree.h), four triangles per
 * test, with identical results, counts, marks and recorded accesses; this
 * one is kept as their reference (tests) and for trees without the copy.
 */
int rt_kd_plain_sub(rt_trav *tv, const rt_ray *r, uint32_t node, float t0, float t1, rt_hit *h, int any);

#endif
