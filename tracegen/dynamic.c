/*
 * dynamic.c -- dynamically scheduled rays (Navrátil et al. 2007, section 2).
 *
 * Rays are traced from the root of the k-d tree down to the first queue
 * point on their path (the "tree top", assumed resident) and appended to
 * that queue point's ray queue in main memory. Queues are then processed
 * one at a time: every ray in the queue traverses the queue point's subtree
 * (whose geometry was chosen to fit in the cache) until it finds its hit or
 * leaves the subtree, in which case it continues through the tree top to
 * its next queue point, or leaves the scene. Rays are processed in
 * generations: all primary rays; then, per point light, shadow rays traced
 * from the light toward the hit points; then newly spawned non-shadow rays
 * (none with the diffuse shading used here).
 *
 * Choices the paper leaves open (docs/tracers.md):
 *   - queue order: fullest queue first (default) or depth-first tree order,
 *     repeated until all queues are empty (--qorder fullest|tree);
 *   - a ray's position is kept as its entry distance t into the next queue
 *     point (the 32-byte record holds origin, direction, pixel id, t); the
 *     exit distance is recomputed from the queue point's cell box, read once
 *     per queue processing (region dyn.qpbox, 24 B per queue point);
 *   - a closest-hit candidate found beyond the subtree's exit (a triangle
 *     reaching into later cells) is kept in the pixel's hit record, flagged
 *     in the ray's pixel id, and settled in a later queue point, so the hit
 *     is exactly the one a single-ray traversal finds;
 *   - queues are chains of 64-ray blocks (2 KB) from a pool with a LIFO
 *     free list; the queue table entry (8 B) is read and written on every
 *     enqueue and when a queue is processed;
 *   - rays popped from a queue pass through a ray buffer of two rays per
 *     modeled thread (region dyn.raybuf), written on load and read when the
 *     ray moves on to another queue;
 *   - when the root is the only queue point (everything fits), rays are
 *     traced straight away without queueing: recursive order.
 *
 * Images are bit-identical to the recursive tracer's: the same camera rays,
 * the same closest hit (ties to the lower triangle index), the same shadow
 * test (the shadow segment is intersected as the ray from the offset hit
 * point toward the light, whichever way it is traversed) and the same
 * shading rule applied to the per-light visibility.
 */
#include "dynamic.h"
#include "hilbert.h"
#include "tracer.h"

#include <inttypes.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define QBLK 64          /* rays per queue block */
#define CAND_FLAG 0x80000000u

/* ---- queue-point selection ---------------------------------------------- */

int rt_dyn_subtree_geometry(const rt_kdtree *kd, uint32_t ntri, uint64_t *g, rt_err *e)
{
    /* The distinct-triangle sizes cost O(references x depth); a sweep
     * schedules the same tree for many cache sizes, so the last result is
     * kept (keyed by the tree's identity and shape). */
    static const rt_kdtree *last_kd;
    static uint32_t last_nnodes, last_nidx;
    static double last_build;
    static uint64_t *last_g;
    if (last_g && last_kd == kd && last_nnodes == kd->nnodes && last_nidx == kd->nidx && last_build == kd->build_sec) {
        memcpy(g, last_g, sizeof *g * kd->nnodes);
        return 0;
    }
    rt_kd_subsize *z = rt_calloc(kd->nnodes, sizeof *z, e);
    if (!z || rt_kd_subtree_sizes(kd, ntri, z, e) < 0) {
        free(z);
        return -1;
    }
    for (uint32_t i = 0; i < kd->nnodes; i++) g[i] = rt_kd_subsize_bytes(&z[i]);
    free(z);
    uint64_t *copy = malloc(sizeof *copy * (kd->nnodes ? kd->nnodes : 1));
    if (copy) {
        memcpy(copy, g, sizeof *g * kd->nnodes);
        free(last_g);
        last_g = copy;
        last_kd = kd;
        last_nnodes = kd->nnodes;
        last_nidx = kd->nidx;
        last_build = kd->build_sec;
    }
    return 0;
}

uint32_t rt_dyn_select(const rt_kdtree *kd, const uint64_t *g, uint64_t gmax, int32_t *qp, uint32_t *ntop)
{
    uint32_t nq = 0, top = 0;
    /* qp doubles as scratch: -2 where the subtree holds triangles, -3 where
     * it is empty (children have larger indices: one backward pass); the
     * walk below overwrites what it visits and the rest becomes -1. */
    for (uint32_t i = kd->nnodes; i-- > 0;) {
        const rt_kdnode *n = &kd->nodes[i];
        int any = rt_kd_is_leaf(n) ? rt_kd_ntri(n) > 0 : (qp[i + 1] == -2 || qp[rt_kd_above(n)] == -2);
        qp[i] = any ? -2 : -3;
    }
    uint32_t stack[RT_KD_STACK * 2 + 8];
    int sp = 0;
    stack[sp++] = 0;
    while (sp) {
        uint32_t i = stack[--sp];
        const rt_kdnode *nd = &kd->nodes[i];
        int has_tris = qp[i] == -2;
        qp[i] = -1;
        if (!has_tris) continue; /* empty subtrees: crossed in the top */
        if (g[i] <= gmax || rt_kd_is_leaf(nd)) {
            qp[i] = (int32_t)nq++;
            continue;
        }
        top++;
        stack[sp++] = rt_kd_above(nd); /* below first: depth-first order */
        stack[sp++] = i + 1;
    }
    for (uint32_t i = 0; i < kd->nnodes; i++)
        if (qp[i] < -1) qp[i] = -1;
    if (ntop) *ntop = top;
    return nq;
}

uint64_t rt_dyn_derive_gmax(const rt_kdtree *kd, const uint64_t *g, uint64_t cache_bytes, uint64_t raybuf_bytes,
                            int *fallback)
{
    if (fallback) *fallback = 0;
    if (cache_bytes <= raybuf_bytes) return 0;
    int32_t *qp = malloc(sizeof *qp * (kd->nnodes ? kd->nnodes : 1));
    if (!qp) return 0;
    uint64_t gm = cache_bytes - raybuf_bytes;
    for (int it = 0; it < 64; it++) {
        uint32_t ntop = 0, nq = rt_dyn_select(kd, g, gm, qp, &ntop);
        uint64_t resident = raybuf_bytes + 8ull * ntop + 8ull * nq;
        uint64_t next = cache_bytes > resident ? cache_bytes - resident : 0;
        if (next >= gm) break; /* the selection for gm fits */
        gm = next;
        if (gm == 0) break;
    }
    if (gm == 0) {
        /* The tree top and queue table cannot be resident beside any
         * geometry. Keep the routing structure resident instead (every ray
         * passes through it): the smallest g_max whose top and table fit in
         * half the cache left by the ray buffer; subtree geometry then
         * streams through the other half (docs/tracers.md). g is monotone:
         * a larger g_max never selects more queue points. */
        uint64_t budget = (cache_bytes - raybuf_bytes) / 2, lo = 1, hi = g[0];
        while (lo < hi) {
            uint64_t mid = lo + (hi - lo) / 2;
            uint32_t ntop = 0, nq = rt_dyn_select(kd, g, mid, qp, &ntop);
            if (8ull * ntop + 8ull * nq <= budget) hi = mid;
            else lo = mid + 1;
        }
        gm = lo;
        if (fallback) *fallback = 1;
    }
    free(qp);
    return gm;
}

/* ---- scheduler state ------------------------------------------------------ */

typedef struct qent {
    uint32_t pix;  /* pixel id; CAND_FLAG: a candidate hit is pending */
    float t0, t1;  /* interval within the queue point's cell */
} qent;

typedef struct dyn {
    const rt_tracer_ctx *ctx;
    const rt_scene *sc;
    const rt_kdtree *kd;
    const rt_layout *L;
    rt_rec *rec;
    rt_trav tv;
    int reg_shade, reg_ray, reg_fb, reg_hits, reg_qt, reg_q, reg_box, reg_rb, reg_top;
    int32_t *topid;      /* entry of a node in the packed tree top, or -1 */
    uint8_t *hastris;    /* subtree holds triangles */
    uint64_t gmax;
    int32_t *qp;         /* queue point of node, or -1 */
    uint32_t *qnode;     /* node of queue point */
    uint32_t nq, ntop;
    uint32_t oversized;  /* leaf queue points whose geometry exceeds gmax */
    /* queues: chains of blocks */
    qent *blk;           /* nblk * QBLK entries */
    int32_t *bnext;      /* next block in chain / free list */
    uint32_t nblk;
    int32_t freelist;
    int32_t *qhead, *qtail; /* first/last block per queue */
    uint32_t *qheadpos;  /* read position in head block */
    uint32_t *qcount;    /* rays queued */
    uint64_t queued, peak_queued;
    /* fullest-first buckets */
    int32_t *bk_head, *bk_next, *bk_prev;
    uint32_t bk_max, bk_cap;
    /* per-pixel state */
    rt_cam_frame cam;
    float *hit_t;
    uint32_t *hit_tri;
    float *hit_u, *hit_v; /* barycentrics of the final hit */
    uint8_t *vis;        /* bit i: light i visible */
    uint8_t *resolved;   /* rays of this generation resolved per pixel */
    int shadow;          /* current generation: 0 primary, 1 shadow */
    int light;           /* light of the shadow generation */
    uint32_t rbslot, rbslots;
    /* statistics */
    uint64_t events, ev_rays, ev_max, enq, created, done;
    uint32_t *qtimes;    /* times each queue was processed */
    uint8_t *mark;
    rt_image *img;
    rt_run_stats *st;
    int err;
} dyn;

/* Rays of the current generation are made from the pixel id alone, so the
 * queues need not hold their 32-byte contents in host memory (they are
 * modeled in dyn.queues). */
static void make_rays(dyn *D, uint32_t pix, rt_ray *trav, rt_ray *test)
{
    int x = (int)(pix % (uint32_t)D->cam.W), y = (int)(pix / (uint32_t)D->cam.W);
    rt_ray eye;
    rt_camera_ray(&D->cam, x, y, &eye);
    if (!D->shadow) {
        *trav = eye;
        *test = eye;
        return;
    }
    rt_hit h = {D->hit_t[pix], D->hit_tri[pix], D->hit_u[pix], D->hit_v[pix]};
    rt_shadow_ray(D->sc, &eye, &h, D->light, test);
    rt_ray_init(trav, D->sc->light[D->light], rt_sub(test->o, D->sc->light[D->light]));
    trav->tmin = 0.0f;
    trav->tmax = 1.0f;
}

/* ---- queues ---------------------------------------------------------------- */

static void bk_unlink(dyn *D, uint32_t q)
{
    uint32_t c = D->qcount[q];
    if (D->bk_prev[q] >= 0) D->bk_next[D->bk_prev[q]] = D->bk_next[q];
    else D->bk_head[c] = D->bk_next[q];
    if (D->bk_next[q] >= 0) D->bk_prev[D->bk_next[q]] = D->bk_prev[q];
}

static void bk_link(dyn *D, uint32_t q)
{
    uint32_t c = D->qcount[q];
    D->bk_prev[q] = -1;
    D->bk_next[q] = D->bk_head[c];
    if (D->bk_head[c] >= 0) D->bk_prev[D->bk_head[c]] = (int32_t)q;
    D->bk_head[c] = (int32_t)q;
    if (c > D->bk_max) D->bk_max = c;
}

static int32_t alloc_block(dyn *D)
{
    int32_t b = D->freelist;
    if (b >= 0) {
        D->freelist = D->bnext[b];
        D->bnext[b] = -1;
    }
    return b;
}

static uint64_t qaddr(const dyn *D, int32_t b, uint32_t pos)
{
    return rt_mm_addr(D->L, D->reg_q, (uint64_t)b * QBLK + pos);
}

static void enqueue(dyn *D, uint32_t q, uint32_t pix, float t0, float t1)
{
    RT_REC(D->rec, rt_mm_addr(D->L, D->reg_qt, q), 8, 0, RT_CLS_QTABLE);
    int32_t tb = D->qtail[q];
    uint32_t pos = D->qcount[q] + D->qheadpos[q];
    /* position within the tail block */
    uint32_t inblk = tb >= 0 ? pos % QBLK : 0;
    if (tb < 0 || (inblk == 0 && pos > 0)) {
        int32_t nb = alloc_block(D);
        if (nb < 0) {
            D->err = 1;
            return;
        }
        if (tb < 0) {
            D->qhead[q] = nb;
            D->qheadpos[q] = 0;
            inblk = 0;
        } else {
            D->bnext[tb] = nb;
        }
        D->qtail[q] = tb = nb;
        inblk = 0;
    }
    qent *e = &D->blk[(size_t)tb * QBLK + inblk];
    e->pix = pix;
    e->t0 = t0;
    e->t1 = t1;
    RT_REC(D->rec, qaddr(D, tb, inblk), 32, 1, RT_CLS_QUEUE);
    RT_REC(D->rec, rt_mm_addr(D->L, D->reg_qt, q), 8, 1, RT_CLS_QTABLE);
    if (D->ctx->opt->qorder == RT_QORDER_FULLEST) bk_unlink(D, q);
    D->qcount[q]++;
    if (D->ctx->opt->qorder == RT_QORDER_FULLEST) bk_link(D, q);
    D->queued++;
    D->enq++;
    if (D->queued > D->peak_queued) D->peak_queued = D->queued;
}

/* ---- traversal ------------------------------------------------------------- */

typedef struct tstack {
    uint32_t node;
    float t0, t1;
} tstack;

/* One front-to-back step at an interior node (pbrt's rules, as in
 * kdtrav.c): returns the child to visit next, narrowing *tmax and pushing
 * the far child when the ray crosses the split inside [tmin, *tmax]. */
static inline uint32_t interior_step(const rt_kdnode *nd, uint32_t node, const rt_ray *r, float tmin, float *tmax,
                                     tstack *stack, int *sp)
{
    int axis = rt_kd_axis(nd);
    float split = rt_kd_split(nd);
    float o = rt_axis(r->o, axis), d = rt_axis(r->d, axis);
    float tp = (split - o) * rt_axis(r->inv_d, axis);
    int below_first = o < split || (o == split && d <= 0);
    uint32_t nearc = below_first ? node + 1 : rt_kd_above(nd);
    uint32_t farc = below_first ? rt_kd_above(nd) : node + 1;
    if (tp > *tmax || tp <= 0) return nearc;
    if (tp < tmin) return farc;
    if (*sp < RT_KD_STACK) {
        stack[*sp].node = farc;
        stack[*sp].t0 = tp;
        stack[*sp].t1 = *tmax;
        (*sp)++;
    }
    *tmax = tp;
    return nearc;
}

/* Descends the tree top from the root over [t0, t1] of r and returns the
 * first queue point (other than skip) the ray enters with a non-empty
 * interval, or -1 when it leaves the scene first. */
static int32_t to_queue_point(dyn *D, const rt_ray *r, float t0, float t1, int32_t skip, float *qa, float *qb)
{
    const rt_kdtree *kd = D->kd;
    tstack stack[RT_KD_STACK];
    int sp = 0;
    uint32_t node = 0;
    float tmin = t0, tmax = t1;
    for (;;) {
        const rt_kdnode *nd = &kd->nodes[node];
        RT_REC(D->rec, rt_mm_addr(D->L, D->reg_top, (uint64_t)D->topid[node]), 8, 0, RT_CLS_NODE);
        D->tv.nodes++;
        int32_t q = D->qp[node];
        if (q >= 0) {
            if (q != skip && tmax > tmin) {
                *qa = tmin;
                *qb = tmax;
                return q;
            }
        } else if (D->hastris[node] && !rt_kd_is_leaf(nd)) {
            node = interior_step(nd, node, r, tmin, &tmax, stack, &sp);
            continue;
        }
        if (!sp) return -1;
        sp--;
        node = stack[sp].node;
        tmin = stack[sp].t0;
        tmax = stack[sp].t1;
    }
}

/* Tests the triangles of a leaf against one ray. Returns 1 when a shadow
 * ray is occluded. */
static int leaf_test(dyn *D, const rt_kdnode *nd, const rt_ray *test, float *best_t, uint32_t *best_tri)
{
    uint32_t n = rt_kd_ntri(nd), first = rt_kd_first(nd);
    if (!n) return 0;
    RT_REC(D->rec, rt_mm_addr(D->L, D->tv.reg_idx, first), 4 * n, 0, RT_CLS_INDEX);
    for (uint32_t k = 0; k < n; k++) {
        uint32_t tri = D->kd->idx[first + k];
        float t, u, v;
        RT_REC(D->rec, rt_mm_addr(D->L, D->tv.reg_tri, tri), 36, 0, RT_CLS_TRI);
        D->tv.tests++;
        if (D->mark) D->mark[tri] |= D->tv.mark_bit;
        if (!rt_isect_tri(test, &D->sc->tri[tri], &t, &u, &v)) continue;
        if (D->shadow) return 1;
        if (*best_tri == RT_NO_HIT || t < *best_t || (t == *best_t && tri < *best_tri)) {
            *best_t = t;
            *best_tri = tri;
        }
    }
    return 0;
}

/* Traverses the subtree at node over [a, b] (front to back, pbrt rules).
 * Returns 1 when a shadow ray is occluded. */
static int subtree(dyn *D, uint32_t root, const rt_ray *trav, const rt_ray *test, float a, float b, float *best_t,
                   uint32_t *best_tri)
{
    const rt_kdtree *kd = D->kd;
    tstack stack[RT_KD_STACK];
    int sp = 0;
    uint32_t node = root;
    float tmin = a, tmax = b;
    for (;;) {
        if (!D->shadow && *best_tri != RT_NO_HIT && rt_kd_past(*best_t, tmin)) return 0;
        const rt_kdnode *nd = &kd->nodes[node];
        RT_REC(D->rec, rt_mm_addr(D->L, D->tv.reg_node, node), 8, 0, RT_CLS_NODE);
        D->tv.nodes++;
        if (rt_kd_is_leaf(nd)) {
            if (leaf_test(D, nd, test, best_t, best_tri)) return 1;
        } else {
            node = interior_step(nd, node, trav, tmin, &tmax, stack, &sp);
            continue;
        }
        if (!sp) return 0;
        sp--;
        node = stack[sp].node;
        tmin = stack[sp].t0;
        tmax = stack[sp].t1;
    }
}

/* ---- resolution ------------------------------------------------------------ */

static void resolve_primary(dyn *D, uint32_t pix, float t, uint32_t tri, int tri_cached)
{
    D->resolved[pix]++;
    D->done++;
    D->hit_t[pix] = t;
    D->hit_tri[pix] = tri;
    if (tri != RT_NO_HIT) {
        /* barycentrics of the final hit: the same test on the same ray
         * gives the same t, u, v as during traversal */
        rt_ray eye;
        float tt;
        rt_camera_ray(&D->cam, (int)(pix % (uint32_t)D->cam.W), (int)(pix / (uint32_t)D->cam.W), &eye);
        rt_isect_tri(&eye, &D->sc->tri[tri], &tt, &D->hit_u[pix], &D->hit_v[pix]);
    }
    if (tri == RT_NO_HIT) {
        RT_REC(D->rec, rt_mm_addr(D->L, D->reg_hits, pix), 4, 1, RT_CLS_HIT);
        RT_REC(D->rec, rt_mm_addr(D->L, D->reg_fb, pix), 12, 1, RT_CLS_FB);
        return;
    }
    /* The hit record keeps t, triangle, offset origin and facing mask for
     * the shadow generations; computing them needs the triangle's vertices
     * (in cache when the hit was found in this subtree). */
    if (!tri_cached) RT_REC(D->rec, rt_mm_addr(D->L, D->tv.reg_tri, tri), 36, 0, RT_CLS_TRI);
    RT_REC(D->rec, rt_mm_addr(D->L, D->reg_shade, tri), 16, 0, RT_CLS_SHADE);
    RT_REC(D->rec, rt_mm_addr(D->L, D->reg_hits, pix), 24, 1, RT_CLS_HIT);
    RT_REC(D->rec, rt_mm_addr(D->L, D->reg_fb, pix), 12, 1, RT_CLS_FB);
}

static void resolve_shadow(dyn *D, uint32_t pix, int visible)
{
    D->resolved[pix]++;
    D->done++;
    if (!visible) return;
    D->vis[pix] |= (uint8_t)(1u << D->light);
    RT_REC(D->rec, rt_mm_addr(D->L, D->reg_fb, pix), 12, 0, RT_CLS_FB);
    RT_REC(D->rec, rt_mm_addr(D->L, D->reg_fb, pix), 12, 1, RT_CLS_FB);
}

/* Moves a ray on from tmin: to its next queue point, or resolves it. */
static void advance(dyn *D, uint32_t pixf, const rt_ray *trav, float tmin, float tmax, int32_t skip, float best_t,
                    uint32_t best_tri, int from_buffer)
{
    uint32_t pix = pixf & ~CAND_FLAG;
    float qa, qb;
    uint64_t n0 = D->tv.nodes;
    /* With a candidate hit only cells the single-ray traversal would still
     * enter (rt_kd_past: entered before the hit, with its margin) can hold a
     * closer or equal-t, lower-index hit: stop the search there. */
    if (!D->shadow && best_tri != RT_NO_HIT) {
        float lim = nextafterf(best_t / (1.0f - 1.0f / 65536.0f), INFINITY);
        if (lim < tmax) tmax = lim;
    }
    int32_t q = tmax > tmin ? to_queue_point(D, trav, tmin, tmax, skip, &qa, &qb) : -1;
    D->img->nodes[pix] += (float)(D->tv.nodes - n0);
    if (q >= 0) {
        if (from_buffer) RT_REC(D->rec, rt_mm_addr(D->L, D->reg_rb, D->rbslot % D->rbslots), 32, 0, RT_CLS_RAY);
        enqueue(D, (uint32_t)q, pixf, qa, qb);
        return;
    }
    if (D->shadow) resolve_shadow(D, pix, 1);
    else resolve_primary(D, pix, best_t, best_tri, 0);
}

/* Processes one ray popped from queue q. */
static void process(dyn *D, uint32_t q, const qent *e)
{
    uint32_t pix = e->pix & ~CAND_FLAG;
    rt_ray trav, test;
    make_rays(D, pix, &trav, &test);
    float best_t = INFINITY;
    uint32_t best_tri = RT_NO_HIT;
    if (e->pix & CAND_FLAG) {
        RT_REC(D->rec, rt_mm_addr(D->L, D->reg_hits, pix), 8, 0, RT_CLS_HIT);
        best_t = D->hit_t[pix];
        best_tri = D->hit_tri[pix];
    }
    uint32_t root = D->qnode[q];
    uint64_t n0 = D->tv.nodes, k0 = D->tv.tests;
    int occluded = subtree(D, root, &trav, &test, e->t0, e->t1, &best_t, &best_tri);
    D->img->nodes[pix] += (float)(D->tv.nodes - n0);
    D->img->tests[pix] += (float)(D->tv.tests - k0);
    if (D->shadow) {
        if (occluded) {
            resolve_shadow(D, pix, 0);
            return;
        }
    } else if (best_tri != RT_NO_HIT && rt_kd_past(best_t, e->t1)) {
        resolve_primary(D, pix, best_t, best_tri, 1);
        return;
    }
    uint32_t pixf = pix;
    if (!D->shadow && best_tri != RT_NO_HIT) {
        /* candidate beyond this subtree: park it in the hit record */
        if (!(e->pix & CAND_FLAG) || D->hit_tri[pix] != best_tri || D->hit_t[pix] != best_t)
            RT_REC(D->rec, rt_mm_addr(D->L, D->reg_hits, pix), 8, 1, RT_CLS_HIT);
        D->hit_t[pix] = best_t;
        D->hit_tri[pix] = best_tri;
        pixf |= CAND_FLAG;
    }
    float t0, t1;
    rt_kd_clip(D->kd, &trav, &t0, &t1);
    advance(D, pixf, &trav, e->t1, t1, (int32_t)q, best_t, best_tri, 1);
}

/* Oversized leaf queue point: blocks of rays against blocks of geometry. */
static void process_oversized(dyn *D, uint32_t q, const qent *es, uint32_t n)
{
    const rt_kdnode *nd = &D->kd->nodes[D->qnode[q]];
    uint32_t ntri = rt_kd_ntri(nd), first = rt_kd_first(nd);
    uint32_t gblk = (uint32_t)(D->gmax / 40);
    if (gblk < 1) gblk = 1;
    rt_ray trav[256], test[256];
    float bt[256];
    uint32_t btri[256];
    uint8_t occl[256];
    RT_REC(D->rec, rt_mm_addr(D->L, D->tv.reg_node, D->qnode[q]), 8, 0, RT_CLS_NODE);
    for (uint32_t i = 0; i < n; i++) {
        uint32_t pix = es[i].pix & ~CAND_FLAG;
        make_rays(D, pix, &trav[i], &test[i]);
        bt[i] = INFINITY;
        btri[i] = RT_NO_HIT;
        occl[i] = 0;
        D->tv.nodes++;
        if (es[i].pix & CAND_FLAG) {
            RT_REC(D->rec, rt_mm_addr(D->L, D->reg_hits, pix), 8, 0, RT_CLS_HIT);
            bt[i] = D->hit_t[pix];
            btri[i] = D->hit_tri[pix];
        }
    }
    for (uint32_t g0 = 0; g0 < ntri; g0 += gblk) {
        uint32_t g1 = g0 + gblk < ntri ? g0 + gblk : ntri;
        RT_REC(D->rec, rt_mm_addr(D->L, D->tv.reg_idx, first + g0), 4 * (g1 - g0), 0, RT_CLS_INDEX);
        for (uint32_t k = g0; k < g1; k++) {
            uint32_t tri = D->kd->idx[first + k];
            int read = 0;
            for (uint32_t i = 0; i < n; i++) {
                if (occl[i]) continue;
                if (!read) {
                    RT_REC(D->rec, rt_mm_addr(D->L, D->tv.reg_tri, tri), 36, 0, RT_CLS_TRI);
                    if (D->mark) D->mark[tri] |= D->tv.mark_bit;
                    read = 1;
                }
                float t, u, v;
                D->tv.tests++;
                D->img->tests[es[i].pix & ~CAND_FLAG] += 1;
                if (!rt_isect_tri(&test[i], &D->sc->tri[tri], &t, &u, &v)) continue;
                if (D->shadow) occl[i] = 1;
                else if (btri[i] == RT_NO_HIT || t < bt[i] || (t == bt[i] && tri < btri[i])) {
                    bt[i] = t;
                    btri[i] = tri;
                }
            }
        }
    }
    for (uint32_t i = 0; i < n; i++) {
        uint32_t pix = es[i].pix & ~CAND_FLAG;
        if (D->shadow && occl[i]) {
            resolve_shadow(D, pix, 0);
            continue;
        }
        if (!D->shadow && btri[i] != RT_NO_HIT && rt_kd_past(bt[i], es[i].t1)) {
            resolve_primary(D, pix, bt[i], btri[i], 0);
            continue;
        }
        uint32_t pixf = pix;
        if (!D->shadow && btri[i] != RT_NO_HIT) {
            RT_REC(D->rec, rt_mm_addr(D->L, D->reg_hits, pix), 8, 1, RT_CLS_HIT);
            D->hit_t[pix] = bt[i];
            D->hit_tri[pix] = btri[i];
            pixf |= CAND_FLAG;
        }
        float t0, t1;
        rt_kd_clip(D->kd, &trav[i], &t0, &t1);
        advance(D, pixf, &trav[i], es[i].t1, t1, (int32_t)q, bt[i], btri[i], 1);
    }
}

/* Pops every ray of queue q (rays never re-enter q: cells are convex). */
static void drain(dyn *D, uint32_t q)
{
    uint32_t n = D->qcount[q];
    if (!n) return;
    D->events++;
    D->ev_rays += n;
    if (n > D->ev_max) D->ev_max = n;
    D->qtimes[q]++;
    RT_REC(D->rec, rt_mm_addr(D->L, D->reg_qt, q), 8, 0, RT_CLS_QTABLE);
    RT_REC(D->rec, rt_mm_addr(D->L, D->reg_box, q), 24, 0, RT_CLS_QTABLE);
    if (D->ctx->opt->qorder == RT_QORDER_FULLEST) bk_unlink(D, q);
    int32_t b = D->qhead[q];
    uint32_t pos = D->qheadpos[q];
    D->qhead[q] = D->qtail[q] = -1;
    D->qcount[q] = 0;
    D->qheadpos[q] = 0;
    D->queued -= n;
    if (D->ctx->opt->qorder == RT_QORDER_FULLEST) bk_link(D, q);
    const rt_kdnode *nd = &D->kd->nodes[D->qnode[q]];
    int oversized = rt_kd_is_leaf(nd) && 40ull * rt_kd_ntri(nd) > D->gmax;
    qent batch[256];
    uint32_t nb = 0, bsz = D->rbslots < 256 ? D->rbslots : 256;
    while (n) {
        qent e = D->blk[(size_t)b * QBLK + pos];
        RT_REC(D->rec, qaddr(D, b, pos), 32, 0, RT_CLS_QUEUE);
        D->rbslot++;
        RT_REC(D->rec, rt_mm_addr(D->L, D->reg_rb, D->rbslot % D->rbslots), 32, 1, RT_CLS_RAY);
        n--;
        if (++pos == QBLK || n == 0) {
            int32_t nx = D->bnext[b];
            D->bnext[b] = D->freelist;
            D->freelist = b;
            b = nx;
            pos = 0;
        }
        if (oversized) {
            batch[nb++] = e;
            if (nb == bsz || n == 0) {
                process_oversized(D, q, batch, nb);
                nb = 0;
            }
        } else {
            process(D, q, &e);
        }
    }
}

static void run_queues(dyn *D)
{
    if (D->ctx->opt->qorder == RT_QORDER_FULLEST) {
        while (D->queued && !D->err) {
            while (D->bk_max > 0 && D->bk_head[D->bk_max] < 0) D->bk_max--;
            if (!D->bk_max) break;
            drain(D, (uint32_t)D->bk_head[D->bk_max]);
        }
    } else {
        while (D->queued && !D->err)
            for (uint32_t q = 0; q < D->nq && !D->err; q++) drain(D, q);
    }
}

/* Starts a ray of the current generation from the root. */
static void start(dyn *D, uint32_t pix)
{
    rt_ray trav, test;
    make_rays(D, pix, &trav, &test);
    D->created++;
    float t0, t1;
    if (!rt_kd_clip(D->kd, &trav, &t0, &t1)) {
        if (D->shadow) resolve_shadow(D, pix, 1);
        else resolve_primary(D, pix, INFINITY, RT_NO_HIT, 0);
        return;
    }
    if (D->nq == 1 && D->qnode[0] == 0) {
        /* Everything fits: no queues, recursive order. */
        uint64_t n0 = D->tv.nodes, k0 = D->tv.tests;
        if (!D->shadow) {
            rt_hit h;
            if (rt_kd_closest(&D->tv, &trav, &h)) resolve_primary(D, pix, h.t, h.tri, 1);
            else resolve_primary(D, pix, INFINITY, RT_NO_HIT, 0);
        } else {
            float bt = INFINITY;
            uint32_t btri = RT_NO_HIT;
            resolve_shadow(D, pix, !subtree(D, 0, &trav, &test, t0, t1, &bt, &btri));
        }
        D->img->nodes[pix] += (float)(D->tv.nodes - n0);
        D->img->tests[pix] += (float)(D->tv.tests - k0);
        return;
    }
    advance(D, pix, &trav, t0, t1, -1, INFINITY, RT_NO_HIT, 0);
}

static int check_generation(dyn *D, const uint8_t *want, size_t npix, rt_err *e)
{
    if (D->err) return rt_errf(e, "dynamic: queue block pool exhausted (internal error)");
    if (D->queued) return rt_errf(e, "dynamic: %" PRIu64 " rays left in queues (internal error)", D->queued);
    for (size_t p = 0; p < npix; p++)
        if (D->resolved[p] != want[p])
            return rt_errf(e, "dynamic: pixel %zu resolved %u times, expected %u (internal error)", p, D->resolved[p],
                           want[p]);
    return 0;
}

/* ---- tracer interface --------------------------------------------------------- */

static uint64_t raybuf_bytes(const rt_render_opts *o) { return 2ull * (uint64_t)o->threads * 32; }

typedef struct sched {
    uint64_t gmax;
    int fallback; /* top could not be resident: half-cache rule used */
    uint32_t nq, ntop;
    int32_t *qp;
    int32_t *topid;    /* packed tree-top entry per node, -1 below queue points */
    uint8_t *hastris;  /* subtree holds triangles */
    uint32_t ntopent;  /* entries of the packed top */
} sched;

static void sched_free(sched *s)
{
    free(s->qp);
    free(s->topid);
    free(s->hastris);
}

static int schedule(const rt_tracer_ctx *ctx, sched *s, rt_err *e)
{
    const rt_kdtree *kd = ctx->kd;
    uint64_t *g = rt_calloc(kd->nnodes, sizeof *g, e);
    s->qp = g ? rt_calloc(kd->nnodes, sizeof *s->qp, e) : NULL;
    if (!s->qp) {
        free(g);
        return -1;
    }
    if (rt_dyn_subtree_geometry(kd, ctx->sc->ntri, g, e) < 0) {
        free(g);
        free(s->qp);
        s->qp = NULL;
        return -1;
    }
    s->fallback = 0;
    s->gmax = ctx->opt->gmax ? ctx->opt->gmax
                             : rt_dyn_derive_gmax(kd, g, ctx->opt->cache_size, raybuf_bytes(ctx->opt), &s->fallback);
    s->nq = rt_dyn_select(kd, g, s->gmax, s->qp, &s->ntop);
    free(g);
    /* The tree top (interior nodes above the queue points, the queue points
     * and the roots of empty subtrees) is packed depth first into its own
     * region, dyn.top: it is the structure that routes rays to queues and is
     * kept apart from the subtrees so it can stay in cache. */
    s->topid = rt_calloc(kd->nnodes, sizeof *s->topid, e);
    s->hastris = s->topid ? rt_calloc(kd->nnodes, 1, e) : NULL;
    if (!s->hastris) {
        sched_free(s);
        return -1;
    }
    for (uint32_t i = kd->nnodes; i-- > 0;) {
        const rt_kdnode *n = &kd->nodes[i];
        s->topid[i] = -1;
        s->hastris[i] = rt_kd_is_leaf(n) ? rt_kd_ntri(n) > 0 : (s->hastris[i + 1] || s->hastris[rt_kd_above(n)]);
    }
    uint32_t stack[RT_KD_STACK * 2 + 8], id = 0;
    int sp = 0;
    stack[sp++] = 0;
    while (sp) {
        uint32_t i = stack[--sp];
        s->topid[i] = (int32_t)id++;
        const rt_kdnode *n = &kd->nodes[i];
        if (s->qp[i] >= 0 || !s->hastris[i] || rt_kd_is_leaf(n)) continue;
        stack[sp++] = rt_kd_above(n);
        stack[sp++] = i + 1;
    }
    s->ntopent = id;
    return 0;
}

static int dyn_layout(const rt_tracer_ctx *ctx, rt_layout *L, rt_err *e)
{
    size_t npix = (size_t)ctx->opt->W * (size_t)ctx->opt->H;
    sched s;
    if (schedule(ctx, &s, e) < 0) return -1;
    uint64_t nq = s.nq ? s.nq : 1, ntop = s.ntopent;
    sched_free(&s);
    if (rt_layout_geometry(ctx, L, 1, e) < 0) return -1;
    if (rt_mm_add(L, "rays.primary", RT_CLS_RAY, 32, npix, e) < 0) return -1;
    if (rt_mm_add(L, "dyn.raybuf", RT_CLS_RAY, 32, 2ull * (uint64_t)ctx->opt->threads, e) < 0) return -1;
    if (rt_mm_add(L, "dyn.qtable", RT_CLS_QTABLE, 8, nq, e) < 0) return -1;
    if (rt_mm_add(L, "dyn.qpbox", RT_CLS_QTABLE, 24, nq, e) < 0) return -1;
    if (rt_mm_add(L, "dyn.top", RT_CLS_NODE, 8, ntop, e) < 0) return -1;
    if (rt_mm_add(L, "dyn.hits", RT_CLS_HIT, 24, npix, e) < 0) return -1;
    if (rt_mm_add(L, "fb", RT_CLS_FB, 12, npix, e) < 0) return -1;
    if (rt_mm_add(L, "dyn.queues", RT_CLS_QUEUE, 32, ((uint64_t)npix / QBLK + nq + 2) * QBLK, e) < 0) return -1;
    return 0;
}

static int dyn_run(const rt_tracer_ctx *ctx, rt_image *img, rt_run_stats *st, rt_err *e)
{
    const rt_scene *sc = ctx->sc;
    const rt_render_opts *o = ctx->opt;
    const size_t npix = (size_t)o->W * (size_t)o->H;
    dyn D;
    memset(&D, 0, sizeof D);
    D.ctx = ctx;
    D.sc = sc;
    D.kd = ctx->kd;
    D.L = ctx->L;
    D.rec = ctx->rec;
    D.img = img;
    D.st = st;
    rt_trav_init(&D.tv, ctx);
    const rt_layout *L = ctx->L;
    D.reg_shade = rt_mm_find(L, "tri.shade");
    D.reg_ray = rt_mm_find(L, "rays.primary");
    D.reg_fb = rt_mm_find(L, "fb");
    D.reg_hits = rt_mm_find(L, "dyn.hits");
    D.reg_qt = rt_mm_find(L, "dyn.qtable");
    D.reg_q = rt_mm_find(L, "dyn.queues");
    D.reg_box = rt_mm_find(L, "dyn.qpbox");
    D.reg_rb = rt_mm_find(L, "dyn.raybuf");
    D.rbslots = (uint32_t)(2 * o->threads);
    rt_cam_setup(&D.cam, sc, o->W, o->H);
    int rc = -1;
    sched s = {0, 0, 0, 0, NULL, NULL, NULL, 0};
    uint32_t *order = NULL;
    uint8_t *want = NULL;
    if (schedule(ctx, &s, e) < 0) return -1;
    D.qp = s.qp;
    D.topid = s.topid;
    D.hastris = s.hastris;
    D.reg_top = rt_mm_find(L, "dyn.top");
    D.gmax = s.gmax;
    D.nq = s.nq;
    D.ntop = s.ntop;
    uint32_t nq = D.nq ? D.nq : 1;
    D.nblk = (uint32_t)(npix / QBLK + nq + 2);
    if (!(D.qnode = rt_calloc(nq, sizeof *D.qnode, e)) || !(D.blk = rt_calloc((size_t)D.nblk * QBLK, sizeof *D.blk, e)) ||
        !(D.bnext = rt_calloc(D.nblk, sizeof *D.bnext, e)) || !(D.qhead = rt_calloc(nq, sizeof *D.qhead, e)) ||
        !(D.qtail = rt_calloc(nq, sizeof *D.qtail, e)) || !(D.qheadpos = rt_calloc(nq, sizeof *D.qheadpos, e)) ||
        !(D.qcount = rt_calloc(nq, sizeof *D.qcount, e)) || !(D.qtimes = rt_calloc(nq, sizeof *D.qtimes, e)) ||
        !(D.bk_head = rt_calloc(npix + 2, sizeof *D.bk_head, e)) || !(D.bk_next = rt_calloc(nq, sizeof *D.bk_next, e)) ||
        !(D.bk_prev = rt_calloc(nq, sizeof *D.bk_prev, e)) || !(D.hit_t = rt_calloc(npix, sizeof *D.hit_t, e)) ||
        !(D.hit_tri = rt_calloc(npix, sizeof *D.hit_tri, e)) ||
        !(D.hit_u = rt_calloc(npix, sizeof *D.hit_u, e)) || !(D.hit_v = rt_calloc(npix, sizeof *D.hit_v, e)) || !(D.vis = rt_calloc(npix, 1, e)) ||
        !(D.resolved = rt_calloc(npix, 1, e)) || !(D.mark = rt_calloc(sc->ntri ? sc->ntri : 1, 1, e)) ||
        !(order = rt_calloc(npix, sizeof *order, e)) || !(want = rt_calloc(npix, 1, e)))
        goto done;
    for (uint32_t i = 0; i < D.nblk; i++) D.bnext[i] = i + 1 < D.nblk ? (int32_t)(i + 1) : -1;
    D.freelist = 0;
    for (uint32_t q = 0; q < nq; q++) D.qhead[q] = D.qtail[q] = -1;
    for (size_t c = 0; c < npix + 2; c++) D.bk_head[c] = -1;
    D.bk_cap = (uint32_t)(npix + 1);
    for (uint32_t n = 0; n < D.kd->nnodes; n++)
        if (D.qp[n] >= 0) D.qnode[D.qp[n]] = n;
    for (uint32_t q = 0; q < D.nq; q++) bk_link(&D, q);
    D.tv.mark = D.mark;
    const size_t ntr = rt_pixel_order(o, order); /* traced pixels (all unless subsampling) */

    /* generation 0: primary rays */
    D.shadow = 0;
    D.tv.mark_bit = 1;
    for (size_t k = 0; k < ntr; k++) {
        RT_REC(D.rec, rt_mm_addr(L, D.reg_ray, order[k]), 32, 0, RT_CLS_RAY);
        start(&D, order[k]);
    }
    st->rays_primary = ntr;
    run_queues(&D);
    for (size_t k = 0; k < ntr; k++) want[order[k]] = 1;
    if (check_generation(&D, want, npix, e) < 0) goto done;

    /* shadow generations, one per light, from the light toward the hits */
    D.shadow = 1;
    D.tv.mark_bit = 2;
    for (int li = 0; li < RT_NLIGHTS; li++) {
        if (!(o->lights & (1u << li))) continue;
        D.light = li;
        memset(D.resolved, 0, npix);
        for (size_t k = 0; k < ntr; k++) {
            uint32_t pix = order[k];
            want[pix] = 0;
            RT_REC(D.rec, rt_mm_addr(L, D.reg_hits, pix), 24, 0, RT_CLS_HIT);
            if (D.hit_tri[pix] == RT_NO_HIT) continue;
            rt_ray eye, sr;
            rt_camera_ray(&D.cam, (int)(pix % (uint32_t)o->W), (int)(pix / (uint32_t)o->W), &eye);
            rt_hit h = {D.hit_t[pix], D.hit_tri[pix], D.hit_u[pix], D.hit_v[pix]};
            if (!rt_shadow_ray(sc, &eye, &h, li, &sr)) continue;
            want[pix] = 1;
            st->rays_shadow++;
            start(&D, pix);
        }
        run_queues(&D);
        if (check_generation(&D, want, npix, e) < 0) goto done;
    }

    /* final image: the shared shading rule on the per-light visibility */
    for (size_t p = 0; p < npix; p++) {
        float rgb[3];
        rt_ray eye;
        if (!rt_pixel_kept(o, (int)(p % (size_t)o->W), (int)(p / (size_t)o->W))) continue; /* not traced */
        rt_camera_ray(&D.cam, (int)(p % (size_t)o->W), (int)(p / (size_t)o->W), &eye);
        if (D.hit_tri[p] != RT_NO_HIT) {
            rt_hit h = {D.hit_t[p], D.hit_tri[p], D.hit_u[p], D.hit_v[p]};
            int vis[RT_NLIGHTS];
            for (int i = 0; i < RT_NLIGHTS; i++) vis[i] = (D.vis[p] >> i) & 1;
            rt_shade_hit(sc, &eye, &h, vis, o->lights, rgb);
            img->depth[p] = h.t * rt_len(eye.d);
        } else {
            rgb[0] = sc->background.x;
            rgb[1] = sc->background.y;
            rgb[2] = sc->background.z;
            img->depth[p] = INFINITY;
        }
        img->rgb[3 * p] = rgb[0];
        img->rgb[3 * p + 1] = rgb[1];
        img->rgb[3 * p + 2] = rgb[2];
    }
    st->nodes = D.tv.nodes;
    st->tests = D.tv.tests;
    for (uint32_t i = 0; i < sc->ntri; i++) {
        st->pv_primary += D.mark[i] & 1;
        st->pv_all += D.mark[i] != 0;
    }
    uint32_t qmax = 0, oversized = 0;
    for (uint32_t q = 0; q < D.nq; q++) {
        if (D.qtimes[q] > qmax) qmax = D.qtimes[q];
        const rt_kdnode *nd = &D.kd->nodes[D.qnode[q]];
        oversized += rt_kd_is_leaf(nd) && 40ull * rt_kd_ntri(nd) > D.gmax;
    }
    snprintf(st->extra, sizeof st->extra,
             "gmax=%" PRIu64 " gmax_rule=%s queue_points=%u top_nodes=%u oversized_leaves=%u enqueues=%" PRIu64
             " queue_events=%" PRIu64 " rays_per_event_mean=%.1f rays_per_event_max=%" PRIu64
             " peak_queued_bytes=%" PRIu64 " events_per_queue_mean=%.2f events_per_queue_max=%u rays=%" PRIu64
             " resolved=%" PRIu64,
             D.gmax, o->gmax ? "given" : (s.fallback ? "top-first" : "resident-top"), D.nq, D.ntop, oversized, D.enq, D.events, D.events ? (double)D.ev_rays / (double)D.events : 0.0,
             D.ev_max, D.peak_queued * 32, D.nq ? (double)D.events / D.nq : 0.0, qmax, D.created, D.done);
    rc = 0;
done:
    sched_free(&s);
    free(D.qnode);
    free(D.blk);
    free(D.bnext);
    free(D.qhead);
    free(D.qtail);
    free(D.qheadpos);
    free(D.qcount);
    free(D.qtimes);
    free(D.bk_head);
    free(D.bk_next);
    free(D.bk_prev);
    free(D.hit_t);
    free(D.hit_tri);
    free(D.hit_u);
    free(D.hit_v);
    free(D.vis);
    free(D.resolved);
    free(D.mark);
    free(order);
    free(want);
    return rc;
}

const rt_tracer rt_tracer_dynamic = {
    "dynamic",
    "dynamically scheduled rays queued at cache-sized subtrees (Navratil et al. 2007)",
    dyn_layout,
    dyn_run,
};
