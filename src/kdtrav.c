/*
 * kdtrav.c -- single-ray k-d tree traversal (closest hit and any hit) with
 * memory-access recording, and the brute-force reference.
 *
 * The traversal is pbrt's KdTreeAccel::Intersect: clip the ray to the tree
 * bounds, then walk front to back; at an interior node the near child (the
 * side holding the origin, or the side the direction points to when the
 * origin lies on the plane) is visited first and the far one pushed with its
 * parametric interval when the plane crossing falls inside the current
 * interval. Leaves test every listed triangle against the ray's own interval
 * (never the leaf's), so rounding in the plane distances cannot lose a hit;
 * closest-hit traversal stops as soon as the best hit lies before the next
 * node's entry distance (by a margin of 2^-16 relative, rt_kd_past, so that
 * hits in a split plane and exact ties are resolved as brute force does). A plane distance that is NaN (the ray lies in the
 * split plane) visits both children.
 *
 * What is recorded (when tv->rec != NULL), in program order: one 8-byte read
 * of kd.nodes per node visited; at a leaf with n > 0 triangles one read of
 * 4n bytes of kd.index at its first entry; one 36-byte read of tri.verts per
 * triangle tested. No mailboxing. tv->nodes and tv->tests count the same
 * events whether or not recording is on.
 */
#include "config.h"
#include "kdtrav.h"

#include <float.h>
#include <math.h>

/* pbrt's gamma(3): relative bound on three roundings. */
#define GAMMA3 ((3.0f * FLT_EPSILON * 0.5f) / (1.0f - 3.0f * FLT_EPSILON * 0.5f))

int rt_kd_clip(const rt_kdtree *kd, const rt_ray *r, float *t0, float *t1)
{
    const rt_bounds *b = &kd->bounds;
    if (kd->nidx == 0 || !(b->lo.x <= b->hi.x && b->lo.y <= b->hi.y && b->lo.z <= b->hi.z)) return 0;
    const float *lo = (const float *)(const void *)&b->lo;
    const float *hi = (const float *)(const void *)&b->hi;
    const float *o = (const float *)(const void *)&r->o;
    const float *inv = (const float *)(const void *)&r->inv_d;
    float a = r->tmin, c = r->tmax;
    for (int k = 0; k < 3; k++) {
        float tn = (lo[k] - o[k]) * inv[k];
        float tf = (hi[k] - o[k]) * inv[k];
        if (tn > tf) {
            float x = tn;
            tn = tf;
            tf = x;
        }
        tf *= 1.0f + 2.0f * GAMMA3;
        /* NaN (origin on a slab face, direction 0 on that axis) constrains
         * nothing: the comparisons below are false. */
        if (tn > a) a = tn;
        if (tf < c) c = tf;
        if (a > c) return 0;
    }
    *t0 = a;
    *t1 = c;
    return 1;
}

typedef struct todo {
    uint32_t node; /* node to visit */
    float tmin;    /* its parametric interval */
    float tmax;
} todo;

/*
 * The traversal, shared by all four entry points. `any` is a constant at
 * every call site, so the compiler emits a closest-hit and an any-hit
 * loop. For closest hit, *h is in/out: a hit already in it is only replaced
 * by a closer one (equal t: lower triangle index). Returns 1 when *h holds
 * a hit (closest) or the ray is occluded (any).
 */
static RT_ALWAYS_INLINE int traverse(rt_trav *tv, const rt_ray *rp, uint32_t node, float tMin, float tMax, rt_hit *h,
                           const int any)
{
    /* A local copy: stores through mark[] (a char pointer) and into the
     * recorder could alias *rp and force reloads in the inner loop. */
    const rt_ray ray = *rp, *r = &ray;
    const rt_kdnode *nodes = tv->kd->nodes;
    const uint32_t *idx = tv->kd->idx;
    const rt_tri *tris = tv->sc->tri;
    rt_rec *rec = tv->rec;
    const rt_layout *L = tv->L;
    uint8_t *mark = tv->mark;
    const uint8_t mbit = tv->mark_bit;
    const float *o = (const float *)(const void *)&r->o;
    const float *d = (const float *)(const void *)&r->d;
    const float *inv = (const float *)(const void *)&r->inv_d;
    const float rtmin = r->tmin, rtmax = r->tmax;

    int found = 0;
    float best = rtmax, bu = 0.0f, bv = 0.0f;
    uint32_t besttri = 0; /* 0 while no hit: an equal t never wins */
    if (!any && h->tri != RT_NO_HIT) {
        found = 1;
        best = h->t;
        besttri = h->tri;
        bu = h->u;
        bv = h->v;
    }
    todo stack[RT_KD_STACK];
    int sp = 0;
    uint64_t nvisit = 0, ntest = 0;
    int occluded = 0;

    for (;;) {
        if (!any && rt_kd_past(best, tMin)) break;
        const rt_kdnode *nd = &nodes[node];
        nvisit++;
        RT_REC(rec, rt_mm_addr(L, tv->reg_node, node), 8, 0, RT_CLS_NODE);
        const uint32_t w1 = nd->w1;
        if ((w1 & 3u) != 3u) {
            const int axis = (int)(w1 & 3u);
            const float split = rt_kd_split(nd);
            const float tPlane = (split - o[axis]) * inv[axis];
            const int belowFirst = o[axis] < split || (o[axis] == split && d[axis] <= 0.0f);
            const uint32_t above = w1 >> 2;
            const uint32_t first = belowFirst ? node + 1 : above;
            const uint32_t second = belowFirst ? above : node + 1;
            if (tPlane > tMax || tPlane <= 0.0f) {
                node = first;
            } else if (tPlane < tMin) {
                node = second;
            } else if (tPlane == tPlane) {
                stack[sp].node = second;
                stack[sp].tmin = tPlane;
                stack[sp].tmax = tMax;
                sp++;
                node = first;
                tMax = tPlane;
            } else { /* NaN: the ray lies in the split plane */
                stack[sp].node = second;
                stack[sp].tmin = tMin;
                stack[sp].tmax = tMax;
                sp++;
                node = first;
            }
            continue;
        }
        const uint32_t n = w1 >> 2;
        if (n > 0) {
            const uint32_t firstidx = nd->w0;
            RT_REC(rec, rt_mm_addr(L, tv->reg_idx, firstidx), 4u * n, 0, RT_CLS_INDEX);
            const uint32_t *list = idx + firstidx;
            for (uint32_t k = 0; k < n; k++) {
                const uint32_t tri = list[k];
                ntest++;
                if (mark) mark[tri] |= mbit;
                RT_REC(rec, rt_mm_addr(L, tv->reg_tri, tri), 36, 0, RT_CLS_TRI);
                float t, u, v;
                if (!rt_isect_core(r, &tris[tri], &t, &u, &v)) continue;
                if (any) {
                    if (t > rtmin && t < rtmax) {
                        occluded = 1;
                        goto done;
                    }
                } else if (t > rtmin && (t < best || (t == best && tri < besttri))) {
                    found = 1;
                    best = t;
                    besttri = tri;
                    bu = u;
                    bv = v;
                }
            }
        }
        if (sp == 0) break;
        --sp;
        node = stack[sp].node;
        tMin = stack[sp].tmin;
        tMax = stack[sp].tmax;
    }
done:
    tv->nodes += nvisit;
    tv->tests += ntest;
    if (any) return occluded;
    if (found) {
        h->t = best;
        h->tri = besttri;
        h->u = bu;
        h->v = bv;
    }
    return found;
}

int rt_kd_closest(rt_trav *tv, const rt_ray *r, rt_hit *h)
{
    rt_hit_none(h);
    float t0, t1;
    if (!rt_kd_clip(tv->kd, r, &t0, &t1)) return 0;
    return traverse(tv, r, 0, t0, t1, h, 0);
}

int rt_kd_occluded(rt_trav *tv, const rt_ray *r)
{
    float t0, t1;
    if (!rt_kd_clip(tv->kd, r, &t0, &t1)) return 0;
    return traverse(tv, r, 0, t0, t1, NULL, 1);
}

int rt_kd_closest_sub(rt_trav *tv, const rt_ray *r, uint32_t node, float t0, float t1, rt_hit *h)
{
    return traverse(tv, r, node, t0, t1, h, 0);
}

int rt_kd_occluded_sub(rt_trav *tv, const rt_ray *r, uint32_t node, float t0, float t1)
{
    return traverse(tv, r, node, t0, t1, NULL, 1);
}

int rt_brute_closest(const rt_scene *sc, const rt_ray *rp, rt_hit *h)
{
    const rt_ray ray = *rp, *r = &ray;
    const rt_tri *tris = sc->tri;
    const uint32_t n = sc->ntri;
    rt_hit best;
    rt_hit_none(&best);
    best.t = r->tmax;
    for (uint32_t i = 0; i < n; i++) {
        float t, u, v;
        if (!rt_isect_core(r, &tris[i], &t, &u, &v)) continue;
        /* Ascending i: an equal t never beats the earlier, lower index. */
        if (t > r->tmin && t < best.t) {
            best.t = t;
            best.tri = i;
            best.u = u;
            best.v = v;
        }
    }
    if (best.tri == RT_NO_HIT) {
        rt_hit_none(h);
        return 0;
    }
    *h = best;
    return 1;
}

int rt_brute_occluded(const rt_scene *sc, const rt_ray *rp)
{
    const rt_ray ray = *rp, *r = &ray;
    const rt_tri *tris = sc->tri;
    const uint32_t n = sc->ntri;
    for (uint32_t i = 0; i < n; i++) {
        float t, u, v;
        if (rt_isect_core(r, &tris[i], &t, &u, &v) && t > r->tmin && t < r->tmax) return 1;
    }
    return 0;
}
