/*
 * packet.c -- ray packets: P x P pixels (default 8 x 8) traced together.
 *
 * Packets tile the image in row-major order. A packet descends the k-d tree
 * front to back (front as seen by its first active ray) and visits a child
 * when any of its active rays' parametric intervals reaches it; each ray
 * keeps its own interval and closest hit, and a ray leaves the packet's
 * traversal once its best hit lies before the interval of the node about
 * to be visited, so every ray finds exactly the hit a single-ray traversal
 * (and brute force) finds. Shadow rays are traced as one packet per light
 * from the packet's hit points (any hit ends a ray).
 *
 * Memory accesses: each node is read once per packet visit (8 B), a leaf's
 * index list once per visit, each triangle once per packet test (36 B),
 * each primary ray record once (32 B); per-ray hit records (t, triangle:
 * 8 B) live in a P*P-entry packet buffer that is rewritten for every packet
 * and read back for shading and shadow-ray setup.
 *
 * Secondary modes (whitted, path): per packet and sample, rays travel in
 * chunks of at most P*P rays. The primary chunk is the packet's camera
 * rays; a chunk is traced as one packet, its hits are shaded, its shadow
 * rays go out as one packet per light, and its surviving rays' children
 * form new chunks: the reflected rays one chunk, the refracted rays another
 * (a path's single continuation one chunk), so each new packet is formed
 * from one packet's hits and holds only rays that are still alive (the
 * active mask shrinks as rays terminate). Chunks wait on a stack (depth
 * first: at most depth + 1 of them), and their rays are stored as 64-byte
 * records (docs/memory-model.md) in packet.rays, one P*P slot per stack
 * level: written when spawned, read when the chunk is traced. Statistics:
 * secondary packets traced and their mean fill (rays / (P*P)).
 *
 * Representation. A packet is NP = P*P rays (ray[], and per ray its hit,
 * its shadow flag done[] and its cost channels pnodes/ptests), indexed by
 * their slot in the packet. The rays still walking form an active list: on
 * the k-d tree a plist per depth and side (store[2 d], store[2 d + 1]: the
 * packet's first and second child) of slots with their intervals in the
 * node's cell; on a BVH a bvlevel per depth of slots with their entry
 * distances and, for wide nodes, the children each ray's box test hit.
 *
 * Invariants (RT_ASSERT where the walk relies on one):
 *   P1  lists: an active list at depth d holds at most NP distinct slots,
 *       each < NP; d stays within the lists allocated for the structure's
 *       depth (k-d: d <= maxdepth; BVH: d + 1 <= maxdepth);
 *   P2  pruning: a slot in the list of a node being visited is needed
 *       there -- not an occluded shadow ray, and (closest hits) its best
 *       hit does not lie strictly before the node's interval (k-d) or
 *       beyond the visit bound of its best hit (BVH cull);
 *   P3  results: each ray's hit is the hit rule's best (accel/hit.h,
 *       rt_hit_better: least t, then least triangle) among the triangles
 *       tested against it, and by P2 no triangle that could beat it was
 *       skipped, so it is the single-ray walk's; a shadow ray is done
 *       exactly when a triangle hit it inside its interval;
 *   P4  accounting: a node is read once per packet visit, a leaf's index
 *       list once per visit, a triangle once per packet test; a ray's
 *       cost channels count the nodes it was present at and the tests
 *       made against it;
 *   P5  chunk stack (secondary modes): height <= pk_levels levels, each
 *       level a chunk of 1..NP rays of one generation; a chunk's children
 *       go refracted first onto the level it freed, the others above.
 */
#include "bvh.h"
#include "camera.h"
#include "inst.h"
#include "regions.h"
#include "rt_assert.h"
#include "shade.h"
#include "stats.h"
#include "tracer.h"

#include <float.h>
#include <inttypes.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef struct plist {
    int n;          /* active rays */
    uint16_t *idx;  /* ray index within the packet */
    float *t0, *t1; /* per-ray interval in the current node */
} plist;

typedef struct pstate {
    rt_trav *tv;
    const rt_kdtree *kd;
    const rt_scene *sc;
    rt_rec *rec;
    const rt_layout *L;
    int reg_node, reg_idx, reg_tri;
    rt_ray *ray;     /* P*P rays */
    rt_hit *hit;     /* closest hits (primary) */
    uint8_t *done;   /* shadow: occluded */
    int shadow;      /* any-hit mode */
    float *pnodes;   /* per-ray node visits (cost channel) */
    float *ptests;   /* per-ray triangle tests */
    plist *store;    /* 2 lists per depth */
    int maxdepth;
    /* BVH packets (NULL bvh: the k-d tree) */
    const rt_bvh *bvh;
    struct bvlevel *lv; /* per depth: the rays entering a node */
    float *cull;     /* per ray: visit bound of its best hit so far */
    int np;          /* P * P */
    rt_inst_pk *ipk; /* the two-level structure (--instances bvh): its packet walker, else NULL */
} pstate;

/* Drops rays that no longer need this node: occluded shadow rays, or rays
 * whose best hit lies strictly before the node's interval. */
static void prune(const pstate *ps, plist *l)
{
    int k = 0;
    for (int j = 0; j < l->n; j++) {
        int i = l->idx[j];
        if (ps->shadow ? ps->done[i] : (ps->hit[i].tri != RT_NO_HIT && rt_kd_past(ps->hit[i].t, l->t0[j]))) continue;
        l->idx[k] = l->idx[j];
        l->t0[k] = l->t0[j];
        l->t1[k] = l->t1[j];
        k++;
    }
    l->n = k;
}

/*
 * The leaf's triangles against the active rays. The model is triangle by
 * triangle: read triangle k (recorded, marked), test it against every ray
 * still active, and in shadow mode drop the rays it occludes, stopping
 * once none is left. The host runs it ray by ray instead (rt_kd_leaf_scan,
 * four triangles per test on the tree's host copy) and then replays what
 * the model observes, which does not depend on the order: a closest hit is
 * the least (t, triangle) whatever the order; in shadow mode a ray is
 * tested up to its first hit, so triangle k is read while some ray's first
 * hit (or none) lies at or past k, and the surviving rays are the same.
 */
static void leaf(pstate *ps, const rt_kdnode *nd, plist *l)
{
    uint32_t n = rt_kd_ntri(nd), first = rt_kd_first(nd);
    if (n == 0) return;
    RT_REC(ps->rec, rt_mm_addr(ps->L, ps->reg_idx, first), 4 * n, 0, RT_CLS_INDEX);
    if (ps->kd->hnodes) {
        if (l->n == 0) return;
        const uint32_t node = (uint32_t)(nd - ps->kd->nodes);
        uint32_t reads = ps->shadow ? 0 : n;
        for (int j = 0; j < l->n; j++) {
            const int i = l->idx[j];
            uint32_t cnt;
            if (ps->shadow) {
                if (rt_kd_leaf_scan(ps->tv, &ps->ray[i], node, NULL, 1, &cnt)) ps->done[i] = 1;
                if (cnt > reads) reads = cnt;
            } else {
                rt_kd_leaf_scan(ps->tv, &ps->ray[i], node, &ps->hit[i], 0, &cnt);
            }
            ps->tv->tests += cnt;
            ps->ptests[i] += (float)cnt; /* exact: small integers */
        }
        for (uint32_t k = 0; k < reads; k++) {
            const uint32_t tri = ps->kd->idx[first + k];
            RT_REC(ps->rec, rt_mm_addr(ps->L, ps->reg_tri, tri), 36, 0, RT_CLS_TRI);
            if (ps->tv->mark) ps->tv->mark[tri] |= ps->tv->mark_bit;
        }
        if (ps->shadow) prune(ps, l);
        return;
    }
    for (uint32_t k = 0; k < n && l->n > 0; k++) {
        uint32_t tri = ps->kd->idx[first + k];
        const rt_tri *T = &ps->sc->tri[tri];
        RT_REC(ps->rec, rt_mm_addr(ps->L, ps->reg_tri, tri), 36, 0, RT_CLS_TRI);
        if (ps->tv->mark) ps->tv->mark[tri] |= ps->tv->mark_bit;
        for (int j = 0; j < l->n; j++) {
            int i = l->idx[j];
            const rt_ray *r = &ps->ray[i];
            float t, u, v;
            ps->tv->tests++;
            ps->ptests[i] += 1;
            if (!rt_isect_core(r, T, &t, &u, &v) || !(t > r->tmin && t < r->tmax)) continue;
            if (ps->shadow) {
                if (!rt_alpha_cut(ps->sc->alpha, &ps->tv->alpha, ps->rec, r, tri, u, v)) ps->done[i] = 1;
            } else {
                rt_hit *h = &ps->hit[i];
                if ((h->tri == RT_NO_HIT || t < h->t || (t == h->t && tri < h->tri)) &&
                    !rt_alpha_cut(ps->sc->alpha, &ps->tv->alpha, ps->rec, r, tri, u, v)) {
                    h->t = t;
                    h->tri = tri;
                    h->u = u;
                    h->v = v;
                }
            }
        }
        if (ps->shadow) prune(ps, l);
    }
}

static void visit(pstate *ps, uint32_t node, plist *l, int depth)
{
    RT_ASSERT(depth <= ps->maxdepth && l->n <= ps->np); /* P1 */
    /* prune() and the per-ray visit count in one pass over the rays */
    int kept = 0;
    for (int j = 0; j < l->n; j++) {
        int i = l->idx[j];
        if (ps->shadow ? ps->done[i] : (ps->hit[i].tri != RT_NO_HIT && rt_kd_past(ps->hit[i].t, l->t0[j]))) continue;
        l->idx[kept] = l->idx[j];
        l->t0[kept] = l->t0[j];
        l->t1[kept] = l->t1[j];
        kept++;
        ps->pnodes[i] += 1;
    }
    l->n = kept;
    if (l->n == 0) return;
    const rt_kdnode *nd = &ps->kd->nodes[node];
    RT_REC(ps->rec, rt_mm_addr(ps->L, ps->reg_node, node), 8, 0, RT_CLS_NODE);
    ps->tv->nodes++;
    if (rt_kd_is_leaf(nd)) {
        leaf(ps, nd, l);
        return;
    }
    int axis = rt_kd_axis(nd);
    float split = rt_kd_split(nd);
    plist *first = &ps->store[2 * depth], *second = &ps->store[2 * depth + 1];
    /* The packet's order: the first active ray's near child goes first. */
    const rt_ray *r0 = &ps->ray[l->idx[0]];
    float o0 = rt_axis(r0->o, axis), d0 = rt_axis(r0->d, axis);
    int below_first_pkt = o0 < split || (o0 == split && d0 <= 0);
    uint32_t child_first = below_first_pkt ? node + 1 : rt_kd_above(nd);
    uint32_t child_second = below_first_pkt ? rt_kd_above(nd) : node + 1;
    first->n = second->n = 0;
    for (int j = 0; j < l->n; j++) {
        int i = l->idx[j];
        const rt_ray *r = &ps->ray[i];
        /* the axis-th component by index, not rt_axis's branches */
        const float o = ((const float *)(const void *)&r->o)[axis], d = ((const float *)(const void *)&r->d)[axis];
        const float inv = ((const float *)(const void *)&r->inv_d)[axis];
        float tp = (split - o) * inv;
        int below_first = o < split || (o == split && d <= 0);
        float t0 = l->t0[j], t1 = l->t1[j];
        /* near/far as in single-ray traversal; then mapped to packet order */
        int near_is_first = below_first == below_first_pkt;
        plist *nearl = near_is_first ? first : second, *farl = near_is_first ? second : first;
        float near_end = t1, far_start = t0;
        const int step = rt_kd_step(tp, t0, t1, &near_end, &far_start);
        if (step & RT_KD_NEAR) nearl->idx[nearl->n] = (uint16_t)i, nearl->t0[nearl->n] = t0, nearl->t1[nearl->n++] = near_end;
        if (step & RT_KD_FAR) farl->idx[farl->n] = (uint16_t)i, farl->t0[farl->n] = far_start, farl->t1[farl->n++] = t1;
    }
    if (first->n) visit(ps, child_first, first, depth + 1);
    if (second->n) visit(ps, child_second, second, depth + 1);
}

/* ---- BVH packets ---------------------------------------------------------
 *
 * The same packet discipline on a bounding volume hierarchy (bvh.h). A
 * packet visits a node when one of its rays still needs it; the node
 * record is read once per packet visit (32, 128 or 80 bytes) and counted
 * once in tv->nodes, and every ray present is counted in its cost channel.
 * Each ray then tests the node's box (bvh2) or its children's boxes (bvh4,
 * bvh8) by itself, with the single-ray walk's slab test and visit bound
 * (bvh.c: cull_bound of the ray's best hit), so a ray is pruned exactly
 * where its own walk would stop descending. bvh2 visits the children in
 * the order the packet's first active ray would (its direction's sign on
 * the split axis, pbrt); a wide node's hit children go nearest first by the
 * least entry distance among the packet's rays (ties: lower slot), and a
 * child is entered by the rays whose box test hit it and whose entry still
 * lies within their bound. A leaf (bvh2 leaf node, or a wide node's leaf
 * child) is tested triangle by triangle: each of its 36-byte bvh.tri
 * records is read once per packet visit and tested against every active
 * ray; in shadow mode an occluded ray leaves, and reading stops once no
 * ray is left -- the k-d packets' accounting. Each ray finds the hit the
 * hit rule (hit.h) defines: nothing that could beat its best hit is
 * skipped, and the order of tests does not change the least (t, index).
 */
typedef struct bvlevel {
    int n;          /* rays entering the node */
    uint16_t *idx;  /* their indices within the packet */
    float *tin;     /* their entry distances (wide: the parent's box test) */
    float *tn;      /* wide: tn[slot * NP + j], ray j's entry into slot */
    uint8_t *mask;  /* wide: mask[j], the slots ray j hits */
} bvlevel;

/* bvh.c's slab test of one box (box_lane), for ray r. */
#define PB_GAMMA3 ((3.0f * FLT_EPSILON * 0.5f) / (1.0f - 3.0f * FLT_EPSILON * 0.5f))
static inline int pb_box(const rt_ray *r, const float lo[3], const float hi[3], float cull, float *tnear)
{
    const float o[3] = {r->o.x, r->o.y, r->o.z}, inv[3] = {r->inv_d.x, r->inv_d.y, r->inv_d.z};
    float tn = r->tmin, tf = INFINITY;
    for (int a = 0; a < 3; a++) {
        const int neg = signbit(inv[a]) != 0;
        const float np = neg ? hi[a] : lo[a], fp = neg ? lo[a] : hi[a];
        const float n = (np - o[a]) * inv[a];
        const float f = (fp - o[a]) * inv[a];
        tn = n > tn ? n : tn;
        tf = f < tf ? f : tf;
    }
    tf = tf * (1.0f + 2.0f * PB_GAMMA3);
    tf = tf < cull ? tf : cull;
    *tnear = tn;
    return tn <= tf;
}

/* Drops the shadow rays already occluded. */
static void pb_drop_done(const pstate *ps, bvlevel *l)
{
    int k = 0;
    for (int j = 0; j < l->n; j++)
        if (!ps->done[l->idx[j]]) l->idx[k] = l->idx[j], l->tin[k++] = l->tin[j];
    l->n = k;
}

/* Leaf records [first, first + n) against the rays of l. */
static void pb_leaf(pstate *ps, uint32_t first, uint32_t n, bvlevel *l)
{
    const rt_bvh *b = ps->bvh;
    for (uint32_t k = first; k < first + n && l->n > 0; k++) {
        const uint32_t o = b->orig[k];
        RT_REC(ps->rec, rt_mm_addr(ps->L, ps->reg_tri, k), 36, 0, RT_CLS_TRI);
        if (ps->tv->mark) ps->tv->mark[o] |= ps->tv->mark_bit;
        for (int j = 0; j < l->n; j++) {
            const int i = l->idx[j];
            const rt_ray *r = &ps->ray[i];
            float t, u, v;
            ps->tv->tests++;
            ps->ptests[i] += 1;
            if (!rt_isect_core(r, rt_bvh_tri(b, k), &t, &u, &v) || !(t > r->tmin && t < r->tmax)) continue;
            if (ps->shadow) {
                if (!rt_alpha_cut(ps->sc->alpha, &ps->tv->alpha, ps->rec, r, o, u, v)) ps->done[i] = 1;
            } else if (rt_hit_better(&ps->hit[i], t, o) && !rt_alpha_cut(ps->sc->alpha, &ps->tv->alpha, ps->rec, r, o, u, v)) {
                rt_hit *h = &ps->hit[i];
                h->t = t;
                h->tri = o;
                h->u = u;
                h->v = v;
                ps->cull[i] = rt_bvh_cull_bound(t);
            }
        }
        if (ps->shadow) pb_drop_done(ps, l);
    }
}

/* Counts and records a packet visit of node (every ray of l present). */
static void pb_read(pstate *ps, uint32_t node, const bvlevel *l)
{
    RT_REC(ps->rec, rt_mm_addr(ps->L, ps->reg_node, node), rt_bvh_node_size(ps->bvh->width), 0, RT_CLS_NODE);
    ps->tv->nodes++;
    for (int j = 0; j < l->n; j++) ps->pnodes[l->idx[j]] += 1;
}

/* bvh2: node with the rays of ps->lv[d]. */
static void pb_visit2(pstate *ps, uint32_t node, int d)
{
    RT_ASSERT(d + 1 <= ps->maxdepth && ps->lv[d].n <= ps->np); /* P1 */
    bvlevel *l = &ps->lv[d];
    if (ps->shadow) pb_drop_done(ps, l);
    if (l->n == 0) return;
    const rt_bvh2_node *nd = &ps->bvh->n2[node];
    pb_read(ps, node, l);
    int k = 0;
    for (int j = 0; j < l->n; j++) {
        const int i = l->idx[j];
        float tn;
        if (pb_box(&ps->ray[i], nd->lo, nd->hi, ps->cull[i], &tn)) l->idx[k] = (uint16_t)i, l->tin[k++] = tn;
    }
    l->n = k;
    if (k == 0) return;
    if (nd->ntri) {
        pb_leaf(ps, nd->offset, nd->ntri, l);
        return;
    }
    const rt_ray *r0 = &ps->ray[l->idx[0]];
    const int neg = signbit(((const float *)(const void *)&r0->inv_d)[nd->axis]) != 0;
    const uint32_t c[2] = {neg ? nd->offset : node + 1, neg ? node + 1 : nd->offset};
    bvlevel *nx = &ps->lv[d + 1];
    for (int ci = 0; ci < 2; ci++) {
        nx->n = l->n;
        memcpy(nx->idx, l->idx, sizeof *l->idx * (size_t)l->n);
        memcpy(nx->tin, l->tin, sizeof *l->tin * (size_t)l->n);
        pb_visit2(ps, c[ci], d + 1);
    }
}

/* bvh4, bvh8: node with the rays of ps->lv[d]. */
static void pb_visitw(pstate *ps, uint32_t node, int d)
{
    const rt_bvh *b = ps->bvh;
    const int W = b->width, NP = ps->np;
    RT_ASSERT(d + 1 <= ps->maxdepth && ps->lv[d].n <= NP); /* P1 */
    bvlevel *l = &ps->lv[d];
    int k = 0;
    for (int j = 0; j < l->n; j++) {
        const int i = l->idx[j];
        if (ps->shadow ? ps->done[i] : l->tin[j] > ps->cull[i]) continue;
        l->idx[k] = (uint16_t)i, l->tin[k++] = l->tin[j];
    }
    l->n = k;
    if (k == 0) return;
    pb_read(ps, node, l);
    const float *base = W == 4 ? &b->n4[node].lo[0][0] : &b->h8[node].lo[0][0];
    float key[8];
    unsigned any = 0;
    for (int s = 0; s < W; s++) key[s] = INFINITY;
    for (int j = 0; j < l->n; j++) {
        const int i = l->idx[j];
        unsigned m = 0;
        for (int s = 0; s < W; s++) {
            const float lo[3] = {base[s], base[W + s], base[2 * W + s]};
            const float hi[3] = {base[3 * W + s], base[4 * W + s], base[5 * W + s]};
            float tn;
            if (!pb_box(&ps->ray[i], lo, hi, ps->cull[i], &tn)) continue;
            m |= 1u << s;
            l->tn[s * NP + j] = tn;
            if (tn < key[s]) key[s] = tn;
        }
        l->mask[j] = (uint8_t)m;
        any |= m;
    }
    /* hit children by (least entry, slot) */
    int ord[8], no = rt_bvh_order_slots(any, key, ord);
    bvlevel *nx = &ps->lv[d + 1];
    for (int oi = 0; oi < no; oi++) {
        const int s = ord[oi];
        uint32_t ra, rn;
        if (!rt_bvh_wide_child(W, b->n4, b->h8, node, s, &ra, &rn)) continue;
        nx->n = 0;
        for (int j = 0; j < l->n; j++) {
            const int i = l->idx[j];
            if (!(l->mask[j] >> s & 1u)) continue;
            const float tn = l->tn[s * NP + j];
            if (ps->shadow ? ps->done[i] : tn > ps->cull[i]) continue;
            nx->idx[nx->n] = (uint16_t)i, nx->tin[nx->n++] = tn;
        }
        if (!nx->n) continue;
        if (rn) pb_leaf(ps, ra, rn, nx);
        else pb_visitw(ps, ra, d + 1);
    }
}

/* Traces the rays of l through the BVH from its root. */
static void pb_trace(pstate *ps, const plist *l)
{
    bvlevel *l0 = &ps->lv[0];
    if (!ps->bvh->nnodes) return;
    l0->n = l->n;
    for (int j = 0; j < l->n; j++) {
        const int i = l->idx[j];
        const rt_ray *r = &ps->ray[i];
        l0->idx[j] = (uint16_t)i;
        l0->tin[j] = r->tmin;
        ps->cull[i] = rt_bvh_cull_bound(!ps->shadow && ps->hit[i].tri != RT_NO_HIT ? ps->hit[i].t : r->tmax);
    }
    if (ps->bvh->width == 2) pb_visit2(ps, 0, 0);
    else pb_visitw(ps, 0, 0);
}

/* The packet's rays from the root: their interval in the k-d tree's box
 * (0: the ray misses it), or the ray's own on a BVH (whose root box test
 * clips). */
static int pk_clip(const rt_tracer_ctx *ctx, const rt_ray *r, float *t0, float *t1)
{
    if (ctx->kd) return rt_kd_clip(ctx->kd, r, t0, t1);
    *t0 = r->tmin;
    *t1 = r->tmax;
    return 1;
}

/* Chunk-stack levels of the secondary modes: a Whitted chunk leaves up to
 * two children on the stack per generation, a path chunk one. */
static int pk_levels(const rt_render_opts *o) { return o->mode == RT_MODE_PATH ? 2 : o->depth + 1; }

static int pk_layout(const rt_tracer_ctx *ctx, rt_layout *L, rt_err *e)
{
    size_t npix = (size_t)ctx->opt->W * (size_t)ctx->opt->H;
    int P = ctx->opt->packet;
    if (rt_reg_geometry(ctx, L, 1, e) < 0) return -1;
    if (rt_mm_add(L, "rays.primary", RT_CLS_RAY, 32, npix, e) < 0) return -1;
    if (rt_mm_add(L, "packet.hits", RT_CLS_HIT, 8, (uint64_t)P * P, e) < 0) return -1;
    if (rt_render_secondary(ctx->opt) &&
        rt_mm_add(L, "packet.rays", RT_CLS_RAY, RT_SREC_SIZE, (uint64_t)P * P * (uint64_t)pk_levels(ctx->opt), e) < 0)
        return -1;
    if (rt_mm_add(L, "fb", RT_CLS_FB, 12, npix, e) < 0) return -1;
    return 0;
}

/* Traces the packet's active rays (list l, intervals already clipped). */
static void trace_packet(pstate *ps, plist *l)
{
    if (!l->n) return;
    if (ps->ipk) rt_inst_pk_trace(ps->ipk, ps->tv, ps->ray, ps->hit, ps->done, ps->shadow, ps->pnodes, ps->ptests, l->idx, l->n);
    else if (ps->bvh) pb_trace(ps, l);
    else visit(ps, 0, l, 0);
}

/* Buffers of the secondary modes. */
typedef struct psec {
    rt_path *chunk;       /* levels * NP rays: the chunk stack */
    int *clen;            /* rays per stacked chunk */
    rt_shade_out *out;    /* NP step results */
    rt_acc *acc;          /* NP pixel sums (packet-local index) */
    rt_hit *h0;           /* NP primary hits (depth channel) */
    uint64_t packets, rays, self_hits;
} psec;

/* Packet-local index of pixel pix in the packet at (px, py), pw wide. */
static int pk_local(const rt_render_opts *o, uint32_t pix, int px, int py, int pw)
{
    return (int)(pix % (uint32_t)o->W) - px + ((int)(pix / (uint32_t)o->W) - py) * pw;
}

/* Pops the chunk on top of the stack (*height levels) and traces it as a
 * packet: closest hits, shading, shadow packets per light; its children
 * are pushed as new chunks (refracted rays below, reflected rays on top). */
static void pk_chunk(pstate *ps, const rt_tracer_ctx *ctx, psec *S, int *height, plist *top, rt_ray *eye, rt_hit *hit,
                     rt_ray *sray, uint8_t *want, rt_image *img, rt_run_stats *st, int px, int py, int pw)
{
    const rt_scene *sc = ctx->sc;
    const rt_render_opts *o = ctx->opt;
    const rt_layout *L = ctx->L;
    rt_rec *rec = ctx->rec;
    const int NP = o->packet * o->packet;
    const int reg_hits = rt_mm_find(L, "packet.hits"), reg_pr = rt_mm_find(L, "packet.rays");
    const int reg_ray = rt_mm_find(L, "rays.primary");
    const int lv = --*height;
    rt_path *rays = &S->chunk[(size_t)lv * NP];
    const int n = S->clen[lv];
    RT_ASSERT(lv >= 0 && lv < pk_levels(o) && n >= 1 && n <= NP); /* P5 */
    top->n = 0;
    rt_rec_set_gen(rec, rays[0].depth); /* a chunk is one generation */
    for (int k = 0; k < n; k++) {
        if (rays[k].depth) RT_REC(rec, rt_mm_addr(L, reg_pr, (uint64_t)lv * NP + k), RT_SREC_SIZE, 0, RT_CLS_RAY);
        else RT_REC(rec, rt_mm_addr(L, reg_ray, rays[k].pix), 32, 0, RT_CLS_RAY);
        rt_shade_path_ray(&rays[k], &eye[k]);
        hit[k].tri = RT_NO_HIT;
        hit[k].t = INFINITY;
        ps->pnodes[k] = ps->ptests[k] = 0;
        float t0, t1;
        if (pk_clip(ctx, &eye[k], &t0, &t1)) {
            top->idx[top->n] = (uint16_t)k, top->t0[top->n] = t0, top->t1[top->n++] = t1;
        }
    }
    if (rays[0].depth) {
        S->packets++;
        S->rays += (uint64_t)n;
    } else {
        st->rays_primary += (uint64_t)n;
    }
    ps->ray = eye;
    ps->hit = hit;
    ps->shadow = 0;
    ps->tv->mark_bit = rays[0].depth ? 4 : 1;
    trace_packet(ps, top);
    for (int k = 0; k < n; k++) RT_REC(rec, rt_mm_addr(L, reg_hits, k), 8, 1, RT_CLS_HIT);
    for (int k = 0; k < n; k++) {
        const rt_path *p = &rays[k];
        int h = hit[k].tri != RT_NO_HIT, li = pk_local(o, p->pix, px, py, pw);
        RT_REC(rec, rt_mm_addr(L, reg_hits, k), 8, 0, RT_CLS_HIT);
        if (h) rt_reg_shade(ctx, rec, hit[k].tri);
        if (!p->depth && !p->sample) S->h0[li] = hit[k];
        rt_shade_step(sc, o, p, &eye[k], h ? &hit[k] : NULL, &S->out[k]);
        S->self_hits += (uint64_t)S->out[k].self_hit;
        rt_acc_add(&S->acc[li], S->out[k].c);
    }
    ps->shadow = 1;
    ps->tv->mark_bit = 2;
    for (int i = 0; i < RT_NLIGHTS; i++) {
        if (!(o->lights & (1u << i))) continue;
        top->n = 0;
        for (int k = 0; k < n; k++) {
            want[k] = S->out[k].want[i];
            ps->done[k] = 0;
            if (!want[k]) continue;
            RT_REC(rec, rt_mm_addr(L, reg_hits, k), 8, 0, RT_CLS_HIT);
            sray[k] = S->out[k].sray[i];
            st->rays_shadow++;
            float t0, t1;
            if (pk_clip(ctx, &sray[k], &t0, &t1)) {
                top->idx[top->n] = (uint16_t)k, top->t0[top->n] = t0, top->t1[top->n++] = t1;
            }
        }
        ps->ray = sray;
        trace_packet(ps, top);
        for (int k = 0; k < n; k++)
            if (want[k] && !ps->done[k]) rt_acc_add(&S->acc[pk_local(o, rays[k].pix, px, py, pw)], S->out[k].lc[i]);
    }
    for (int k = 0; k < n; k++) {
        img->nodes[rays[k].pix] += ps->pnodes[k];
        img->tests[rays[k].pix] += ps->ptests[k];
    }
    /* children (their parents' data now lives in out[]): refracted rays
     * into this level, reflected rays (or a path's continuation) above */
    for (int kind = RT_PATH_REFRACT; kind >= 0; kind--) {
        int m = 0, dst = *height;
        RT_ASSERT(dst < pk_levels(o)); /* P5: the stack never outgrows its levels */
        rt_path *d = &S->chunk[(size_t)dst * NP];
        for (int k = 0; k < n; k++)
            for (int c = 0; c < S->out[k].nchild; c++) {
                if (S->out[k].child[c].kind != kind) continue;
                d[m] = S->out[k].child[c];
                RT_REC(rec, rt_mm_addr(L, reg_pr, (uint64_t)dst * NP + m), RT_SREC_SIZE, 1, RT_CLS_RAY);
                m++;
            }
        if (m) S->clen[(*height)++] = m;
    }
}

/* One packet in a secondary mode: for each sample the primary chunk, then
 * chunks until the stack is empty; then the pixels. */
static void pk_secondary(pstate *ps, const rt_tracer_ctx *ctx, psec *S, plist *top, rt_ray *eye, rt_hit *hit,
                         rt_ray *sray, uint8_t *want, rt_image *img, rt_run_stats *st, int px, int py, int pw, int ph)
{
    const rt_render_opts *o = ctx->opt;
    const int n = pw * ph, spp = o->mode == RT_MODE_PATH ? o->spp : 1;
    rt_cam_frame cam;
    rt_cam_setup(&cam, ctx->sc, o->W, o->H);
    memset(S->acc, 0, sizeof *S->acc * (size_t)n);
    for (int s = 0; s < spp; s++) {
        for (int k = 0; k < n; k++) {
            int x = px + k % pw, y = py + k / pw;
            rt_ray r;
            rt_cam_ray(&cam, x, y, &r);
            rt_shade_path_start(&S->chunk[k], &r, (uint32_t)y * (uint32_t)o->W + (uint32_t)x, (uint32_t)s);
        }
        S->clen[0] = n;
        int height = 1;
        while (height) pk_chunk(ps, ctx, S, &height, top, eye, hit, sray, want, img, st, px, py, pw);
    }
    rt_rec_set_gen(ctx->rec, 0); /* the pixel writes: the primary rays' */
    for (int k = 0; k < n; k++) {
        int x = px + k % pw, y = py + k / pw;
        uint32_t pix = (uint32_t)y * (uint32_t)o->W + (uint32_t)x;
        rt_ray r;
        rt_cam_ray(&cam, x, y, &r);
        rt_acc_pixel(&S->acc[k], spp, &r, &S->h0[k], img, pix);
        RT_REC(ctx->rec, rt_mm_addr(ctx->L, rt_mm_find(ctx->L, "fb"), pix), 12, 1, RT_CLS_FB);
    }
}

/* Authored lights: per enabled light and sample in order, one shadow packet
 * of the packet's hits that want that sample; lw[k * nlight + i] sums the
 * weights of pixel k's unoccluded samples of light i (the recursive
 * tracer's sums, added in the same order). */
static void pk_lights(pstate *ps, const rt_tracer_ctx *ctx, plist *top, const rt_ray *eye, const rt_hit *hit, rt_ray *sray,
                      uint8_t *want, float *swt, float *lw, int n, rt_run_stats *st)
{
    const rt_scene *sc = ctx->sc;
    const rt_layout *L = ctx->L;
    const int reg_hits = rt_mm_find(L, "packet.hits");
    const uint32_t nl = sc->nlight;
    memset(lw, 0, sizeof *lw * (size_t)n * nl);
    for (uint32_t li = 0; li < nl; li++) {
        if (!rt_render_light_on(ctx->opt, li)) continue;
        for (uint32_t smp = 0, ns = rt_shade_light_nsamples(sc, ctx->opt, li); smp < ns; smp++) {
            top->n = 0;
            for (int k = 0; k < n; k++) {
                RT_REC(ctx->rec, rt_mm_addr(L, reg_hits, k), 8, 0, RT_CLS_HIT);
                uint32_t tri;
                want[k] = 0;
                ps->done[k] = 0;
                if (hit[k].tri == RT_NO_HIT) continue;
                if (!rt_shade_sample_ray(sc, ctx->opt, &eye[k], &hit[k], li, smp, &sray[k], &swt[k], &tri)) continue;
                rt_reg_light(ctx, ctx->rec, li, tri);
                want[k] = 1;
                st->rays_shadow++;
                float t0, t1;
                if (pk_clip(ctx, &sray[k], &t0, &t1)) {
                    top->idx[top->n] = (uint16_t)k, top->t0[top->n] = t0, top->t1[top->n++] = t1;
                }
            }
            ps->ray = sray;
            ps->shadow = 1;
            ps->tv->mark_bit = 2;
            trace_packet(ps, top);
            for (int k = 0; k < n; k++)
                if (want[k] && !ps->done[k]) lw[(size_t)k * nl + li] += swt[k];
        }
    }
}

static int pk_run(const rt_tracer_ctx *ctx, rt_image *img, rt_run_stats *st, rt_err *e)
{
    const rt_scene *sc = ctx->sc;
    const rt_render_opts *o = ctx->opt;
    const int W = o->W, H = o->H, P = o->packet, NP = P * P;
    const rt_layout *L = ctx->L;
    rt_rec *rec = ctx->rec;
    int reg_ray = rt_mm_find(L, "rays.primary"), reg_fb = rt_mm_find(L, "fb");
    int reg_shade = rt_mm_find(L, "tri.shade"), reg_hits = rt_mm_find(L, "packet.hits");
    rt_trav tv;
    rt_reg_trav(&tv, ctx);
    pstate ps = {&tv, ctx->kd, sc, rec, L, tv.reg_node, tv.reg_idx, tv.reg_tri, NULL, NULL, NULL, 0, NULL, NULL, NULL, 0, NULL, NULL, NULL, 0, NULL};
    const int two_level = ctx->acc->kind == RT_ACCEL_INST; /* its own packet walk (accel/inst.c) */
    const rt_bvh *bvh = tv.width && !two_level ? tv.bvh : NULL; /* a BVH, else the k-d tree */
    ps.maxdepth = two_level ? 1 : bvh ? (int)bvh->depth + 2 : (int)ctx->kd->maxdepth + 2;
    ps.bvh = bvh;
    ps.np = NP;
    int rc = -1;
    if (two_level && !(ps.ipk = rt_inst_pk_new(ctx->acc->as, NP, e))) return -1;
    rt_ray *eye = rt_calloc(NP, sizeof *eye, e);
    rt_ray *sray = eye ? rt_calloc(NP, sizeof *sray, e) : NULL;
    rt_hit *hit = sray ? rt_calloc(NP, sizeof *hit, e) : NULL;
    uint8_t *done = hit ? rt_calloc(NP, 1, e) : NULL;
    uint8_t *want = done ? rt_calloc(NP, 1, e) : NULL;
    int *vis = want ? rt_calloc((size_t)NP * RT_NLIGHTS, sizeof *vis, e) : NULL;
    float *pn = vis ? rt_calloc(NP, sizeof *pn, e) : NULL;
    float *pt = pn ? rt_calloc(NP, sizeof *pt, e) : NULL;
    const uint32_t nmark = rt_scene_model_nslot(sc, two_level); /* marks per shading slot of the model */
    uint8_t *mark = pt ? rt_calloc(nmark ? nmark : 1, 1, e) : NULL;
    plist *store = mark ? rt_calloc((size_t)2 * (ps.maxdepth + 1) + 1, sizeof *store, e) : NULL;
    void *pool = store ? rt_calloc(((size_t)2 * (ps.maxdepth + 1) + 1) * NP, 12, e) : NULL;
    const int authored = rt_shade_authored(sc, o) && o->lights; /* the file's lights (--light-samples) */
    float *lw = pool && authored ? rt_calloc((size_t)NP * sc->nlight, sizeof *lw, e) : NULL;
    float *swt = lw ? rt_calloc(NP, sizeof *swt, e) : NULL;
    psec S;
    memset(&S, 0, sizeof S);
    /* BVH packets: per level the rays (idx, tin) and, wide, their slots */
    const size_t nlv = (size_t)ps.maxdepth + 1, lvb = ((size_t)NP * (4 + 4 * 8 + 2 + 1) + 7) & ~(size_t)7;
    bvlevel *bl = pool && bvh ? rt_calloc(nlv, sizeof *bl, e) : NULL;
    unsigned char *lvpool = bl ? rt_calloc(nlv, lvb, e) : NULL;
    float *cull = lvpool ? rt_calloc(NP, sizeof *cull, e) : NULL;
    if (bvh && !cull) goto done;
    for (size_t k = 0; bvh && k < nlv; k++) {
        unsigned char *p = lvpool + k * lvb;
        bl[k].tin = (float *)(void *)p, p += 4 * (size_t)NP;
        bl[k].tn = (float *)(void *)p, p += 4 * 8 * (size_t)NP;
        bl[k].idx = (uint16_t *)(void *)p, p += 2 * (size_t)NP;
        bl[k].mask = p;
    }
    ps.lv = bl;
    ps.cull = cull;
    const int secondary = rt_render_secondary(o);
    if (pool && secondary) {
        size_t lv = (size_t)pk_levels(o);
        if (!(S.chunk = rt_calloc(lv * NP, sizeof *S.chunk, e)) || !(S.clen = rt_calloc(lv, sizeof *S.clen, e)) ||
            !(S.out = rt_calloc(NP, sizeof *S.out, e)) || !(S.acc = rt_calloc(NP, sizeof *S.acc, e)) ||
            !(S.h0 = rt_calloc(NP, sizeof *S.h0, e)))
            goto done;
    }
    if (!pool || (authored && !swt)) goto done;
    {
        unsigned char *p = pool;
        for (int k = 0; k < 2 * (ps.maxdepth + 1) + 1; k++) {
            store[k].t0 = (float *)p, p += 4 * (size_t)NP;
            store[k].t1 = (float *)p, p += 4 * (size_t)NP;
            store[k].idx = (uint16_t *)p, p += 4 * (size_t)NP; /* keeps the next floats aligned */
        }
    }
    ps.done = done;
    ps.pnodes = pn;
    ps.ptests = pt;
    ps.store = store;
    tv.mark = mark;
    plist *top = &store[2 * (ps.maxdepth + 1)];
    rt_cam_frame cam;
    rt_cam_setup(&cam, sc, W, H);

    uint64_t q = 0; /* kept packets so far: the work share (pixels.h) */
    for (int py = 0; py < H; py += P) {
        for (int px = 0; px < W; px += P) {
            if (!rt_pixel_kept(o, px, py)) continue; /* subsampling: tiles hold whole packets */
            if (!rt_pixel_packet_part(q++, ctx->part, ctx->nparts)) continue;
            int pw = W - px < P ? W - px : P, ph = H - py < P ? H - py : P;
            int n = pw * ph;
            if (secondary) {
                pk_secondary(&ps, ctx, &S, top, eye, hit, sray, want, img, st, px, py, pw, ph);
                continue;
            }
            /* primary rays */
            top->n = 0;
            for (int k = 0; k < n; k++) {
                int x = px + k % pw, y = py + k / pw;
                uint32_t pix = (uint32_t)y * (uint32_t)W + (uint32_t)x;
                RT_REC(rec, rt_mm_addr(L, reg_ray, pix), 32, 0, RT_CLS_RAY);
                rt_cam_ray(&cam, x, y, &eye[k]);
                hit[k].tri = RT_NO_HIT;
                hit[k].t = INFINITY;
                pn[k] = pt[k] = 0;
                float t0, t1;
                if (pk_clip(ctx, &eye[k], &t0, &t1)) {
                    top->idx[top->n] = (uint16_t)k, top->t0[top->n] = t0, top->t1[top->n++] = t1;
                }
            }
            st->rays_primary += (uint64_t)n;
            ps.ray = eye;
            ps.hit = hit;
            ps.shadow = 0;
            tv.mark_bit = 1;
            trace_packet(&ps, top);
            for (int k = 0; k < n; k++) RT_REC(rec, rt_mm_addr(L, reg_hits, k), 8, 1, RT_CLS_HIT);
            if (authored) { /* the file's lights: one shadow packet per light and sample */
                pk_lights(&ps, ctx, top, eye, hit, sray, want, swt, lw, n, st);
                for (int k = 0; k < n; k++) {
                    int x = px + k % pw, y = py + k / pw;
                    uint32_t pix = (uint32_t)y * (uint32_t)W + (uint32_t)x;
                    RT_REC(rec, rt_mm_addr(L, reg_hits, k), 8, 0, RT_CLS_HIT);
                    if (hit[k].tri != RT_NO_HIT)
                        RT_REC(rec, rt_mm_addr(L, reg_shade, rt_scene_model_slot(sc, hit[k].tri, two_level)), 16, 0,
                               RT_CLS_SHADE);
                    rt_shade_pixel_lw(sc, o, &eye[k], hit[k].tri != RT_NO_HIT ? &hit[k] : NULL, &lw[(size_t)k * sc->nlight],
                                      img, pix);
                    img->nodes[pix] = pn[k];
                    img->tests[pix] = pt[k];
                    RT_REC(rec, rt_mm_addr(L, reg_fb, pix), 12, 1, RT_CLS_FB);
                }
                continue;
            }
            /* shadow packets, one per light */
            memset(vis, 0, sizeof(int) * (size_t)NP * RT_NLIGHTS);
            for (int li = 0; li < RT_NLIGHTS; li++) {
                if (!(o->lights & (1u << li))) continue;
                top->n = 0;
                for (int k = 0; k < n; k++) {
                    RT_REC(rec, rt_mm_addr(L, reg_hits, k), 8, 0, RT_CLS_HIT);
                    want[k] = 0;
                    done[k] = 0;
                    if (hit[k].tri == RT_NO_HIT) continue;
                    if (!rt_shade_ray(sc, &eye[k], &hit[k], li, &sray[k])) continue;
                    want[k] = 1;
                    st->rays_shadow++;
                    float t0, t1;
                    if (pk_clip(ctx, &sray[k], &t0, &t1)) {
                        top->idx[top->n] = (uint16_t)k, top->t0[top->n] = t0, top->t1[top->n++] = t1;
                    }
                }
                ps.ray = sray;
                ps.shadow = 1;
                tv.mark_bit = 2;
                trace_packet(&ps, top);
                for (int k = 0; k < n; k++) vis[k * RT_NLIGHTS + li] = want[k] && !done[k];
            }
            /* shade and write */
            for (int k = 0; k < n; k++) {
                int x = px + k % pw, y = py + k / pw;
                uint32_t pix = (uint32_t)y * (uint32_t)W + (uint32_t)x;
                RT_REC(rec, rt_mm_addr(L, reg_hits, k), 8, 0, RT_CLS_HIT);
                if (hit[k].tri != RT_NO_HIT) {
                    RT_REC(rec, rt_mm_addr(L, reg_shade, rt_scene_model_slot(sc, hit[k].tri, two_level)), 16, 0,
                           RT_CLS_SHADE);
                    rt_shade_pixel(sc, &eye[k], &hit[k], &vis[k * RT_NLIGHTS], o->lights, img, pix);
                } else {
                    rt_shade_pixel(sc, &eye[k], NULL, NULL, o->lights, img, pix);
                }
                img->nodes[pix] = pn[k];
                img->tests[pix] = pt[k];
                RT_REC(rec, rt_mm_addr(L, reg_fb, pix), 12, 1, RT_CLS_FB);
            }
        }
    }
    rt_stats_finish(st, &tv, mark, nmark);
    if (secondary)
        snprintf(st->extra, sizeof st->extra,
                 "packet=%d rays_secondary=%" PRIu64 " secondary_packets=%" PRIu64 " secondary_fill=%.3f self_hits=%" PRIu64,
                 P, S.rays, S.packets, S.packets ? (double)S.rays / ((double)S.packets * NP) : 0.0, S.self_hits);
    else
        snprintf(st->extra, sizeof st->extra, "packet=%d", P);
    if (tv.xforms) { /* the two-level structure: rays transformed into an object's space */
        size_t l = strlen(st->extra);
        snprintf(st->extra + l, sizeof st->extra - l, " xforms=%" PRIu64, tv.xforms);
    }
    rc = 0;
done:
    rt_inst_pk_free(ps.ipk);
    free(cull);
    free(lvpool);
    free(bl);
    free(S.chunk);
    free(S.clen);
    free(S.out);
    free(S.acc);
    free(S.h0);
    free(pool);
    free(store);
    free(mark);
    free(pt);
    free(pn);
    free(swt);
    free(lw);
    free(vis);
    free(want);
    free(done);
    free(hit);
    free(sray);
    free(eye);
    return rc;
}

/* Subsampled runs trace or skip whole packets: the tile holds whole ones. */
static int pk_check_opts(const rt_render_opts *o, rt_err *e)
{
    if (o->packet <= 0) return rt_errf(e, "--packet: %d is not a packet edge", o->packet);
    if (o->subsample > 1 && o->subtile % o->packet)
        return rt_errf(e, "packet tracer: subsampling tile %d is not a multiple of the packet edge %d (whole packets "
                          "are traced or skipped)", o->subtile, o->packet);
    return 0;
}

static void pk_params(const rt_render_opts *o, char *buf, size_t n) { snprintf(buf, n, "packet=%d", o->packet); }

const rt_tracer rt_tracer_packet = {
    .name = "packet",
    .desc = "P x P ray packets tiled over the image, shadow packets per light",
    .modes = RT_TRACER_ALL_MODES,
    .accels = RT_ACCEL_BIT(RT_ACCEL_KD) | RT_ACCEL_BVH_BITS | RT_ACCEL_BIT(RT_ACCEL_INST),
    .accel_default = RT_ACCEL_KD,
    .opts = RT_OPTG_PACKET | RT_OPTG_THREADS | RT_OPTG_CORES,
    .traits = RT_TR_LIGHTS,
    .figures = RT_FIG_NAVRATIL,
    .check_opts = pk_check_opts,
    .params = pk_params,
    .layout = pk_layout,
    .run = pk_run,
};
