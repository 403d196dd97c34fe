/*
 * kdtree.c -- building and checking the SAH k-d tree.
 *
 * Representation. The tree is two flat arrays, exactly the records a tracer
 * reads and the memory model charges for:
 *
 *   nodes[]  8-byte nodes in depth-first preorder, root at 0. An interior
 *            node stores the split position (float bits, w0) and, in w1,
 *            the split axis in the low two bits and the index of its above
 *            child in the upper 30; its below child is always the next node
 *            (index + 1), so the below subtree occupies the index range
 *            [i + 1, above) and the above subtree [above, end of i). A leaf
 *            has low bits 3, its triangle count in the upper 30 bits of w1
 *            and the offset of its first entry in idx[] in w0.
 *   idx[]    the leaves' triangle-index lists, concatenated in leaf order,
 *            each list strictly ascending (so traversal meets equal-t hits
 *            in index order and the checker can binary-search).
 *
 * This is pbrt's KdTreeAccel layout (Pharr and Humphreys, 2004/2016). There
 * are no bounds in the nodes; a traversal derives each node's cell from the
 * tree bounds (the bounds of all triangles) and the splits above it.
 *
 * Invariants (verified by rt_kd_check):
 *   I1  node 0 is the root; every interior node i has i + 1 < above < nnodes,
 *       every node is reached exactly once from the root;
 *   I2  an interior node's split lies strictly inside its cell;
 *   I3  leaf ranges lie in idx[0, nidx), partition it in leaf order, hold
 *       strictly ascending triangle indices < ntri;
 *   I4  completeness: a triangle whose bounding box overlaps a leaf's cell
 *       with positive extent on every axis (on an axis where the box is
 *       flat: the plane lies strictly inside the cell) is in that leaf; a
 *       box touching a split plane from one side only is in that side; a
 *       box lying flat in a split plane is in at least one of the two sides.
 *       Every point of a triangle is therefore inside the closed cell of a
 *       leaf that lists it, which is all a traversal needs;
 *   I5  soundness: a triangle listed in a leaf has a box meeting the leaf's
 *       closed cell;
 *   I6  no leaf is deeper than the depth limit (<= RT_KD_DEPTH_CAP), so the
 *       traversal's fixed stack cannot overflow; statistics match the tree;
 *   I7  the host-side copy, when present, is exact: hnodes[i] == nodes[i]
 *       but for leaf w0, which numbers the leaf's first quad, quads are
 *       handed out to leaves in node order, ceil(n / 4) each, covering
 *       quads[0, nquads); lane j of a leaf's quads carries idx[first + j],
 *       its triangle's nine coordinates bit for bit, and the degenerate
 *       flag exactly when rt_isect_degenerate holds; padding lanes are
 *       RT_KD_QUAD_PAD with zero coordinates.
 *
 * Build. pbrt's SAH recursion: at each node, sweep the sorted bounding-box
 * edges along the axis of largest extent, cost = trav + isect * (1 - eb) *
 * (pB * nB + pA * nA) with eb = empty bonus when a side is empty, accept
 * the cheapest candidate strictly inside the cell; retry the other axes
 * only when no candidate exists; count a bad refine when the best cost
 * exceeds isect * n, and make a leaf at n <= max_leaf_tris, at the depth
 * limit, on the third bad refine along a path, or when the best cost
 * exceeds 4 * isect * n with n < 16. A triangle goes below when its start
 * edge sorts before the chosen edge and above when its end edge sorts after
 * it; edges sort by (position, start before end, triangle index), a total
 * order, so the tree is identical on every machine.
 *
 * Speed. Instead of re-sorting at every node (pbrt, O(N log^2 N)), the
 * edges of all three axes are radix-sorted once at the root as 64-bit keys
 * (ordered float bits, type bit, triangle index). Because the candidates are
 * the triangles' unclipped box edges, a child's sorted edge lists are just
 * the stable filter of its parent's lists to the child's triangles, one
 * linear pass per node: O(N log N) in total. The lists live in one arena
 * used as a stack: the below child's lists are compacted in place over the
 * parent's, the above child's are appended at the top and popped when its
 * subtree is done, so memory stays within a small multiple of the root's
 * 48 bytes per triangle.
 */
#include "config.h"
#include "kdtree.h"
#include "isect.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#define TRI_MASK 0x7fffffffu
#define EV_END 0x80000000u   /* type bit in the low word: end sorts after start */

void rt_kd_default_params(rt_kd_params *p)
{
    p->isect_cost = 80.0f;
    p->trav_cost = 1.0f;
    p->empty_bonus = 0.5f;
    p->max_depth = 0;
    p->max_leaf_tris = 1;
}

/* pbrt: round(8 + 1.3 * Log2Int(N)), with the integer log2 (floor), so the
 * limit is exact integer arithmetic on every machine. */
static int default_max_depth(uint32_t n)
{
    int lg = 0;
    while (n > 1) {
        n >>= 1;
        lg++;
    }
    return (80 + 13 * lg + 5) / 10;
}

/* Float <-> order-preserving unsigned key. -0 is folded into +0 first. */
static uint32_t f2key(float f)
{
    f += 0.0f;
    uint32_t b;
    memcpy(&b, &f, sizeof b);
    return (b & 0x80000000u) ? ~b : (b | 0x80000000u);
}

static float key2f(uint32_t k)
{
    uint32_t b = (k & 0x80000000u) ? (k & 0x7fffffffu) : ~k;
    float f;
    memcpy(&f, &b, sizeof f);
    return f;
}

static inline float ev_pos(uint64_t e) { return key2f((uint32_t)(e >> 32)); }
static inline uint32_t ev_tri(uint64_t e) { return (uint32_t)e & TRI_MASK; }
static inline int ev_is_end(uint64_t e) { return ((uint32_t)e & EV_END) != 0; }

/* LSD radix sort of 64-bit keys, 16-bit digits; skips digits that are the
 * same in every key. tmp has room for n keys. Result ends in a. */
static void radix_sort64(uint64_t *a, uint64_t *tmp, size_t n, uint32_t *cnt /* 65536 */)
{
    uint64_t *src = a, *dst = tmp;
    for (int shift = 0; shift < 64; shift += 16) {
        memset(cnt, 0, 65536 * sizeof *cnt);
        for (size_t i = 0; i < n; i++) cnt[(src[i] >> shift) & 0xffff]++;
        if (n == 0 || cnt[(src[0] >> shift) & 0xffff] == n) continue;
        uint32_t sum = 0;
        for (size_t d = 0; d < 65536; d++) {
            uint32_t c = cnt[d];
            cnt[d] = sum;
            sum += c;
        }
        for (size_t i = 0; i < n; i++) dst[cnt[(src[i] >> shift) & 0xffff]++] = src[i];
        uint64_t *t = src;
        src = dst;
        dst = t;
    }
    if (src != a) memcpy(a, src, n * sizeof *a);
}

static int build_host(rt_kdtree *t, const rt_scene *s, rt_err *e);

typedef struct build {
    const rt_kd_params *p; /* costs and limits */
    int max_depth;         /* resolved depth limit */
    uint64_t *ev;          /* edge arena (stack of per-node lists) */
    size_t evcap;          /* entries allocated */
    uint8_t *side;         /* per triangle: 1 below, 2 above, 3 both */
    uint32_t *tmpidx;      /* scratch for a leaf's list, ntri entries */
    rt_kdnode *nodes;      /* output nodes */
    uint32_t nnodes, nodecap;
    uint32_t *idx;         /* output index lists */
    uint32_t nidx, idxcap;
    rt_kdtree *t;          /* statistics go here */
    rt_err *e;             /* error sink */
} build;

static int ev_reserve(build *B, size_t need)
{
    if (need <= B->evcap) return 0;
    size_t cap = B->evcap + B->evcap / 2;
    if (cap < need) cap = need;
    uint64_t *p = rt_reallocarray(B->ev, cap, sizeof *p, B->e);
    if (!p) return -1;
    B->ev = p;
    B->evcap = cap;
    return 0;
}

static int64_t new_node(build *B)
{
    if (B->nnodes == B->nodecap) {
        if (B->nodecap >= (1u << 30)) return rt_errf(B->e, "k-d tree exceeds 2^30 nodes");
        uint32_t cap = B->nodecap ? B->nodecap * 2 : 1024;
        if (cap > (1u << 30)) cap = 1u << 30;
        rt_kdnode *p = rt_reallocarray(B->nodes, cap, sizeof *p, B->e);
        if (!p) return -1;
        B->nodes = p;
        B->nodecap = cap;
    }
    B->nodes[B->nnodes].w0 = 0;
    B->nodes[B->nnodes].w1 = 0;
    return B->nnodes++;
}

static int cmp_u32(const void *a, const void *b)
{
    uint32_t x = *(const uint32_t *)a, y = *(const uint32_t *)b;
    return (x > y) - (x < y);
}

static int make_leaf(build *B, uint32_t node, size_t base, uint32_t n, int depth)
{
    /* The axis-0 list holds one start edge per triangle. */
    uint32_t k = 0;
    for (size_t i = 0; i < 2 * (size_t)n; i++) {
        uint64_t e = B->ev[base + i];
        if (!ev_is_end(e)) B->tmpidx[k++] = ev_tri(e);
    }
    qsort(B->tmpidx, n, sizeof *B->tmpidx, cmp_u32); /* distinct keys: deterministic */
    if ((uint64_t)B->nidx + n > UINT32_MAX) return rt_errf(B->e, "k-d tree index list exceeds 2^32 entries");
    if (B->nidx + n > B->idxcap) {
        uint64_t cap = (uint64_t)B->idxcap * 2;
        if (cap < (uint64_t)B->nidx + n) cap = (uint64_t)B->nidx + n;
        if (cap > UINT32_MAX) cap = UINT32_MAX;
        uint32_t *p = rt_reallocarray(B->idx, (size_t)cap, sizeof *p, B->e);
        if (!p) return -1;
        B->idx = p;
        B->idxcap = (uint32_t)cap;
    }
    memcpy(B->idx + B->nidx, B->tmpidx, n * sizeof *B->idx);
    B->nodes[node].w0 = B->nidx;
    B->nodes[node].w1 = (n << 2) | 3u;
    B->nidx += n;
    rt_kdtree *t = B->t;
    t->nleaves++;
    if (n == 0) t->nempty++;
    if ((uint32_t)depth > t->maxdepth) t->maxdepth = (uint32_t)depth;
    if (n > t->maxleaf) t->maxleaf = n;
    return 0;
}

static int max_extent(const rt_bounds *b)
{
    float dx = b->hi.x - b->lo.x, dy = b->hi.y - b->lo.y, dz = b->hi.z - b->lo.z;
    if (dx > dy && dx > dz) return 0;
    return dy > dz ? 1 : 2;
}

/*
 * Builds the subtree for the n triangles whose sorted edge lists are at
 * ev[base .. base + 6n) (axis a at base + 2n*a); ev[top ..) is free.
 */
static int build_node(build *B, size_t base, uint32_t n, size_t top, rt_bounds cell, int depth, int bad)
{
    int64_t nodei = new_node(B);
    if (nodei < 0) return -1;
    uint32_t node = (uint32_t)nodei;
    const rt_kd_params *p = B->p;
    if (n <= (uint32_t)(p->max_leaf_tris > 0 ? p->max_leaf_tris : 0) || depth >= B->max_depth)
        return make_leaf(B, node, base, n, depth);

    const float lo[3] = {cell.lo.x, cell.lo.y, cell.lo.z};
    const float hi[3] = {cell.hi.x, cell.hi.y, cell.hi.z};
    const float d[3] = {hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]};
    const float totalSA = 2.0f * (d[0] * d[1] + d[0] * d[2] + d[1] * d[2]);
    const float invTotalSA = 1.0f / totalSA;
    const float oldCost = p->isect_cost * (float)n;
    float bestCost = INFINITY;
    int bestAxis = -1;
    size_t bestOffset = 0;
    int axis = max_extent(&cell);
    for (int retries = 0; retries < 3; retries++) {
        const uint64_t *ev = B->ev + base + 2 * (size_t)n * axis;
        const int a0 = (axis + 1) % 3, a1 = (axis + 2) % 3;
        const float cap = d[a0] * d[a1], perim = d[a0] + d[a1];
        const float clo = lo[axis], chi = hi[axis];
        uint32_t nBelow = 0, nAbove = n;
        for (size_t i = 0; i < 2 * (size_t)n; i++) {
            const uint64_t e = ev[i];
            const int isEnd = ev_is_end(e);
            if (isEnd) --nAbove;
            const float tt = ev_pos(e);
            if (tt > clo && tt < chi) {
                const float belowSA = 2.0f * (cap + (tt - clo) * perim);
                const float aboveSA = 2.0f * (cap + (chi - tt) * perim);
                const float pBelow = belowSA * invTotalSA, pAbove = aboveSA * invTotalSA;
                const float eb = (nAbove == 0 || nBelow == 0) ? p->empty_bonus : 0.0f;
                const float cost =
                    p->trav_cost + p->isect_cost * (1.0f - eb) * (pBelow * (float)nBelow + pAbove * (float)nAbove);
                if (cost < bestCost) {
                    bestCost = cost;
                    bestAxis = axis;
                    bestOffset = i;
                }
            }
            if (!isEnd) ++nBelow;
        }
        if (bestAxis != -1) break;
        axis = (axis + 1) % 3;
    }
    if (bestCost > oldCost) ++bad;
    if ((bestCost > 4.0f * oldCost && n < 16) || bestAxis == -1 || bad == 3)
        return make_leaf(B, node, base, n, depth);

    /* Classify against the chosen edge. */
    const uint64_t *bev = B->ev + base + 2 * (size_t)n * bestAxis;
    const float tsplit = ev_pos(bev[bestOffset]);
    for (size_t i = 0; i < 2 * (size_t)n; i++)
        if (!ev_is_end(bev[i])) B->side[ev_tri(bev[i])] = 0;
    uint32_t nl = 0, nr = 0;
    for (size_t i = 0; i < 2 * (size_t)n; i++) {
        const uint64_t e = bev[i];
        if (!ev_is_end(e)) {
            if (i < bestOffset) {
                B->side[ev_tri(e)] |= 1;
                nl++;
            }
        } else if (i > bestOffset) {
            B->side[ev_tri(e)] |= 2;
            nr++;
        }
    }
    /* Split the three lists: above child's appended at top, below child's
     * compacted in place (write index never passes the read index). */
    const size_t rbase = top;
    if (ev_reserve(B, rbase + 6 * (size_t)nr + 1) < 0) return -1;
    {
        uint64_t *ev = B->ev;
        size_t wl = base, wr = rbase;
        const size_t end = base + 6 * (size_t)n;
        const uint8_t *side = B->side;
        for (size_t k = base; k < end; k++) {
            /* Branchless: always store, advance by the side bits. The
             * stray store at wr lands in reserved space, the one at wl on
             * an entry already read. */
            const uint64_t e = ev[k];
            const unsigned sd = side[ev_tri(e)];
            ev[wr] = e;
            wr += sd >> 1;
            ev[wl] = e;
            wl += sd & 1u;
        }
    }
    const size_t ntop = rbase + 6 * (size_t)nr;

    rt_bounds c0 = cell, c1 = cell;
    rt_set_axis(&c0.hi, bestAxis, tsplit);
    rt_set_axis(&c1.lo, bestAxis, tsplit);
    if (build_node(B, base, nl, ntop, c0, depth + 1, bad) < 0) return -1;
    if (B->nnodes >= (1u << 30)) return rt_errf(B->e, "k-d tree exceeds 2^30 nodes");
    uint32_t above = B->nnodes;
    uint32_t sbits;
    memcpy(&sbits, &tsplit, sizeof sbits);
    B->nodes[node].w0 = sbits;
    B->nodes[node].w1 = (above << 2) | (uint32_t)bestAxis;
    return build_node(B, rbase, nr, ntop, c1, depth + 1, bad);
}


rt_kdtree *rt_kd_build(const rt_scene *s, const rt_kd_params *params, rt_err *e)
{
    double t0 = rt_now();
    rt_kd_params defp;
    if (!params) {
        rt_kd_default_params(&defp);
        params = &defp;
    }
    const uint32_t N = s->ntri;
    if (N > TRI_MASK) {
        rt_errf(e, "k-d tree: %u triangles exceed the limit of 2^31-1", N);
        return NULL;
    }
    rt_kdtree *t = rt_calloc(1, sizeof *t, e);
    if (!t) return NULL;
    build B;
    memset(&B, 0, sizeof B);
    B.p = params;
    B.t = t;
    B.e = e;
    B.max_depth = params->max_depth > 0 ? params->max_depth : default_max_depth(N);
    if (B.max_depth > RT_KD_DEPTH_CAP) B.max_depth = RT_KD_DEPTH_CAP;
    t->max_depth = (uint32_t)B.max_depth;

    rt_bounds tb = rt_bounds_empty();
    for (uint32_t i = 0; i < N; i++) {
        rt_bounds b = rt_tri_bounds(&s->tri[i]);
        rt_bounds_union(&tb, &b);
    }
    t->bounds = tb;

    uint32_t *cnt = NULL;
    uint64_t *tmp = NULL;
    B.evcap = 6 * (size_t)N * 2 + 64;
    B.ev = rt_calloc(B.evcap, sizeof *B.ev, e);
    B.side = rt_calloc(N ? N : 1, 1, e);
    B.tmpidx = rt_calloc(N ? N : 1, sizeof *B.tmpidx, e);
    cnt = rt_calloc(65536, sizeof *cnt, e);
    tmp = rt_calloc(2 * (size_t)N + 1, sizeof *tmp, e);
    if (!B.ev || !B.side || !B.tmpidx || !cnt || !tmp) goto fail;
    B.idxcap = N + 1024;
    B.idx = rt_calloc(B.idxcap, sizeof *B.idx, e);
    if (!B.idx) goto fail;

    for (int a = 0; a < 3; a++) {
        uint64_t *ev = B.ev + 2 * (size_t)N * a;
        for (uint32_t i = 0; i < N; i++) {
            rt_bounds b = rt_tri_bounds(&s->tri[i]);
            ev[2 * (size_t)i] = ((uint64_t)f2key(rt_axis(b.lo, a)) << 32) | i;
            ev[2 * (size_t)i + 1] = ((uint64_t)f2key(rt_axis(b.hi, a)) << 32) | EV_END | i;
        }
        radix_sort64(ev, tmp, 2 * (size_t)N, cnt);
    }
    free(tmp);
    tmp = NULL;
    free(cnt);
    cnt = NULL;

    if (build_node(&B, 0, N, 6 * (size_t)N, tb, 0, 0) < 0) goto fail;

    free(B.ev);
    free(B.side);
    free(B.tmpidx);
    t->nodes = B.nodes;
    t->nnodes = B.nnodes;
    t->idx = B.idx;
    t->nidx = B.nidx;
    /* Trim to size (shrinking realloc; keep the larger block on failure). */
    if (t->nnodes) {
        rt_kdnode *pn = realloc(t->nodes, t->nnodes * sizeof *pn);
        if (pn) t->nodes = pn;
    }
    if (t->nidx) {
        uint32_t *pi = realloc(t->idx, t->nidx * sizeof *pi);
        if (pi) t->idx = pi;
    }
    /* Without memory for the host copy the tree still works (plain walk). */
    rt_err he = {0};
    (void)build_host(t, s, &he);
    t->build_sec = rt_now() - t0;
    return t;
fail:
    free(cnt);
    free(tmp);
    free(B.ev);
    free(B.side);
    free(B.tmpidx);
    free(B.nodes);
    free(B.idx);
    free(t);
    return NULL;
}

/* Fills lane j of a quad with triangle tri (or padding when tri is
 * RT_KD_QUAD_PAD); degen: whether the triangle is degenerate. */
static void quad_lane(rt_kd_quad *q, int j, const rt_scene *s, uint32_t tri, int degen)
{
    if (tri == RT_KD_QUAD_PAD) {
        for (int c = 0; c < 9; c++) q->p[c][j] = 0.0f;
        q->tri[j] = RT_KD_QUAD_PAD;
        return;
    }
    const float *p = (const float *)(const void *)&s->tri[tri];
    for (int c = 0; c < 9; c++) q->p[c][j] = p[c];
    q->tri[j] = tri | (degen ? RT_KD_QUAD_DEGEN : 0u);
}

/* Builds the host-side copy (I7) when it fits in RT_KD_HOST_MAX. 0 (built,
 * or too large and skipped), or -1 on out of memory; either way without a
 * copy the tree is still usable: the traversal takes the plain path. */
static int build_host(rt_kdtree *t, const rt_scene *s, rt_err *e)
{
    uint64_t nq = 0;
    for (uint32_t i = 0; i < t->nnodes; i++)
        if (rt_kd_is_leaf(&t->nodes[i])) nq += (rt_kd_ntri(&t->nodes[i]) + 3) / 4;
    if (nq > UINT32_MAX || nq * sizeof(rt_kd_quad) + (uint64_t)t->nnodes * sizeof(rt_kdnode) > RT_KD_HOST_MAX)
        return 0; /* too large to be worth it: the plain walk */
    rt_kdnode *hn = rt_calloc(t->nnodes ? t->nnodes : 1, sizeof *hn, e);
    rt_kd_quad *q = rt_calloc(nq ? nq : 1, sizeof *q, e);
    uint8_t *degen = rt_calloc(s->ntri ? s->ntri : 1, 1, e); /* once per triangle, not per entry */
    if (!hn || !q || !degen) {
        free(hn);
        free(q);
        free(degen);
        return -1;
    }
    for (uint32_t i = 0; i < s->ntri; i++) degen[i] = (uint8_t)rt_isect_degenerate(&s->tri[i]);
    uint32_t next = 0;
    for (uint32_t i = 0; i < t->nnodes; i++) {
        hn[i] = t->nodes[i];
        if (!rt_kd_is_leaf(&t->nodes[i])) continue;
        const uint32_t n = rt_kd_ntri(&t->nodes[i]), first = rt_kd_first(&t->nodes[i]);
        hn[i].w0 = next;
        for (uint32_t k = 0; k < (n + 3) / 4 * 4; k++) {
            const uint32_t tri = k < n ? t->idx[first + k] : RT_KD_QUAD_PAD;
            quad_lane(&q[next + k / 4], (int)(k % 4), s, tri, k < n && degen[tri]);
        }
        next += (n + 3) / 4;
    }
    free(degen);
    t->hnodes = hn;
    t->quads = q;
    t->nquads = next;
    return 0;
}

/* I7: the host copy agrees with nodes, idx and the scene. */
static int check_host(const rt_kdtree *t, const rt_scene *s, rt_err *e)
{
    if (!t->hnodes && !t->quads) return 0;
    if (!t->hnodes || !t->quads) return rt_errf(e, "k-d tree: host copy half present");
    uint32_t next = 0;
    for (uint32_t i = 0; i < t->nnodes; i++) {
        const rt_kdnode *nd = &t->nodes[i], *hd = &t->hnodes[i];
        if (hd->w1 != nd->w1 || (!rt_kd_is_leaf(nd) && hd->w0 != nd->w0))
            return rt_errf(e, "k-d tree: host node %u differs from node %u", i, i);
        if (!rt_kd_is_leaf(nd)) continue;
        const uint32_t n = rt_kd_ntri(nd), first = rt_kd_first(nd), nq = (n + 3) / 4;
        if (hd->w0 != next || (uint64_t)next + nq > t->nquads)
            return rt_errf(e, "k-d tree: leaf %u has quads at %u, expected %u of %u", i, hd->w0, next, t->nquads);
        for (uint32_t k = 0; k < nq * 4; k++) {
            const rt_kd_quad *q = &t->quads[next + k / 4];
            const int j = (int)(k % 4);
            rt_kd_quad want;
            const uint32_t tri = k < n ? t->idx[first + k] : RT_KD_QUAD_PAD;
            quad_lane(&want, j, s, tri, k < n && rt_isect_degenerate(&s->tri[tri]));
            int same = q->tri[j] == want.tri[j];
            for (int c = 0; c < 9; c++) same &= memcmp(&q->p[c][j], &want.p[c][j], sizeof(float)) == 0;
            if (!same) return rt_errf(e, "k-d tree: leaf %u lane %u of its quads differs from its entry", i, k);
        }
        next += nq;
    }
    if (next != t->nquads) return rt_errf(e, "k-d tree: leaves use %u quads of %u", next, t->nquads);
    return 0;
}

void rt_kd_free(rt_kdtree *t)
{
    if (!t) return;
    free(t->nodes);
    free(t->idx);
    free(t->hnodes);
    free(t->quads);
    free(t);
}

double rt_kd_mean_leaf_tris(const rt_kdtree *t)
{
    uint32_t full = t->nleaves - t->nempty;
    return full ? (double)t->nidx / full : 0.0;
}

/* ---- checking ---------------------------------------------------------- */

static int leaf_has(const rt_kdtree *t, const rt_kdnode *nd, uint32_t tri)
{
    const uint32_t *a = t->idx + rt_kd_first(nd);
    uint32_t lo = 0, hi = rt_kd_ntri(nd);
    while (lo < hi) {
        uint32_t mid = lo + (hi - lo) / 2;
        if (a[mid] < tri) lo = mid + 1;
        else hi = mid;
    }
    return lo < rt_kd_ntri(nd) && a[lo] == tri;
}

/* I4 for one triangle: 1 when every leaf the box must reach lists it. */
static int covers(const rt_kdtree *t, uint32_t node, uint32_t tri, const rt_bounds *b, int depth)
{
    const rt_kdnode *nd = &t->nodes[node];
    if (rt_kd_is_leaf(nd)) return leaf_has(t, nd, tri);
    if (depth > RT_KD_DEPTH_CAP) return 0;
    const int a = rt_kd_axis(nd);
    const float s = rt_kd_split(nd), lo = rt_axis(b->lo, a), hi = rt_axis(b->hi, a);
    const uint32_t below = node + 1, above = rt_kd_above(nd);
    if (lo < s && hi > s) return covers(t, below, tri, b, depth + 1) && covers(t, above, tri, b, depth + 1);
    if (lo < s) return covers(t, below, tri, b, depth + 1); /* hi <= s */
    if (hi > s) return covers(t, above, tri, b, depth + 1); /* lo >= s */
    /* lo == hi == s: flat in the plane, at least one side. */
    return covers(t, below, tri, b, depth + 1) || covers(t, above, tri, b, depth + 1);
}

typedef struct chk_item {
    uint32_t node;  /* node index */
    uint32_t depth; /* root = 0 */
    rt_bounds cell; /* node's cell */
} chk_item;

int rt_kd_check(const rt_kdtree *t, const rt_scene *s, rt_err *e)
{
    if (!t || !t->nodes || t->nnodes == 0) return rt_errf(e, "k-d tree: no nodes");
    if (t->max_depth > RT_KD_DEPTH_CAP) return rt_errf(e, "k-d tree: depth limit %u above cap %d", t->max_depth, RT_KD_DEPTH_CAP);
    rt_bounds tb = rt_bounds_empty();
    for (uint32_t i = 0; i < s->ntri; i++) {
        rt_bounds b = rt_tri_bounds(&s->tri[i]);
        rt_bounds_union(&tb, &b);
    }
    if (memcmp(&tb, &t->bounds, sizeof tb) != 0) return rt_errf(e, "k-d tree: bounds differ from the triangles' bounds");

    uint8_t *seen = rt_calloc(t->nnodes, 1, e);
    chk_item *stack = rt_calloc(RT_KD_DEPTH_CAP + 2, sizeof *stack, e);
    if (!seen || !stack) {
        free(seen);
        free(stack);
        return -1;
    }
    int rc = -1;
    uint32_t nleaves = 0, nempty = 0, maxdepth = 0, maxleaf = 0;
    uint64_t nextidx = 0;
    int sp = 0;
    stack[sp].node = 0;
    stack[sp].depth = 0;
    stack[sp].cell = t->bounds;
    sp++;
    while (sp > 0) {
        chk_item it = stack[--sp];
        uint32_t i = it.node;
        if (seen[i]) {
            rt_errf(e, "k-d tree: node %u reached twice", i);
            goto out;
        }
        seen[i] = 1;
        if (it.depth > t->max_depth) {
            rt_errf(e, "k-d tree: node %u at depth %u exceeds the limit %u", i, it.depth, t->max_depth);
            goto out;
        }
        const rt_kdnode *nd = &t->nodes[i];
        if (rt_kd_is_leaf(nd)) {
            uint32_t n = rt_kd_ntri(nd), first = rt_kd_first(nd);
            nleaves++;
            if (n == 0) nempty++;
            if (n > maxleaf) maxleaf = n;
            if (it.depth > maxdepth) maxdepth = it.depth;
            if ((uint64_t)first + n > t->nidx) {
                rt_errf(e, "k-d tree: leaf %u range [%u, +%u) outside the index list (%u)", i, first, n, t->nidx);
                goto out;
            }
            if (n > 0 && first != nextidx) {
                rt_errf(e, "k-d tree: leaf %u starts at %u, expected %llu", i, first, (unsigned long long)nextidx);
                goto out;
            }
            nextidx += n;
            for (uint32_t k = 0; k < n; k++) {
                uint32_t tri = t->idx[first + k];
                if (tri >= s->ntri) {
                    rt_errf(e, "k-d tree: leaf %u lists triangle %u >= %u", i, tri, s->ntri);
                    goto out;
                }
                if (k > 0 && t->idx[first + k - 1] >= tri) {
                    rt_errf(e, "k-d tree: leaf %u list not strictly ascending", i);
                    goto out;
                }
                rt_bounds b = rt_tri_bounds(&s->tri[tri]);
                for (int a = 0; a < 3; a++)
                    if (rt_axis(b.lo, a) > rt_axis(it.cell.hi, a) || rt_axis(b.hi, a) < rt_axis(it.cell.lo, a)) {
                        rt_errf(e, "k-d tree: leaf %u lists triangle %u whose box misses its cell", i, tri);
                        goto out;
                    }
            }
            continue;
        }
        uint32_t above = rt_kd_above(nd);
        int a = rt_kd_axis(nd);
        float sp_ = rt_kd_split(nd);
        if (!(i + 1 < above && above < t->nnodes)) {
            rt_errf(e, "k-d tree: node %u has above child %u (nodes %u)", i, above, t->nnodes);
            goto out;
        }
        if (!(sp_ > rt_axis(it.cell.lo, a) && sp_ < rt_axis(it.cell.hi, a))) {
            rt_errf(e, "k-d tree: node %u split %g on axis %d outside its cell", i, (double)sp_, a);
            goto out;
        }
        if (sp + 2 > RT_KD_DEPTH_CAP + 2) {
            rt_errf(e, "k-d tree: deeper than %d", RT_KD_DEPTH_CAP);
            goto out;
        }
        chk_item c1 = {above, it.depth + 1, it.cell};
        rt_set_axis(&c1.cell.lo, a, sp_);
        chk_item c0 = {i + 1, it.depth + 1, it.cell};
        rt_set_axis(&c0.cell.hi, a, sp_);
        stack[sp++] = c1;
        stack[sp++] = c0; /* below first: preorder */
    }
    for (uint32_t i = 0; i < t->nnodes; i++)
        if (!seen[i]) {
            rt_errf(e, "k-d tree: node %u unreachable", i);
            goto out;
        }
    if (nextidx != t->nidx) {
        rt_errf(e, "k-d tree: leaves cover %llu index entries of %u", (unsigned long long)nextidx, t->nidx);
        goto out;
    }
    if (nleaves != t->nleaves || nempty != t->nempty || maxdepth != t->maxdepth || maxleaf != t->maxleaf) {
        rt_errf(e, "k-d tree: statistics disagree (leaves %u/%u empty %u/%u depth %u/%u maxleaf %u/%u)", nleaves,
                t->nleaves, nempty, t->nempty, maxdepth, t->maxdepth, maxleaf, t->maxleaf);
        goto out;
    }
    for (uint32_t tri = 0; tri < s->ntri; tri++) {
        rt_bounds b = rt_tri_bounds(&s->tri[tri]);
        if (!covers(t, 0, tri, &b, 0)) {
            rt_errf(e, "k-d tree: triangle %u missing from a leaf its box overlaps", tri);
            goto out;
        }
    }
    if (check_host(t, s, e) < 0) goto out;
    rc = 0;
out:
    free(seen);
    free(stack);
    return rc;
}

/* ---- subtree sizes ------------------------------------------------------ */

int rt_kd_subtree_sizes(const rt_kdtree *t, uint32_t ntri, rt_kd_subsize *out, rt_err *e)
{
    const uint32_t nn = t->nnodes;
    uint32_t *parent = rt_calloc(nn, sizeof *parent, e);
    uint8_t *depth = rt_calloc(nn, 1, e);
    int64_t *cnt = rt_calloc(nn, sizeof *cnt, e);
    uint32_t *last = rt_calloc(ntri ? ntri : 1, sizeof *last, e);
    int rc = -1;
    if (!parent || !depth || !cnt || !last) goto out;
    for (uint32_t i = 0; i < nn; i++) {
        out[i].nodes = 1;
        out[i].nidx = 0;
        out[i].ntri = 0;
    }
    parent[0] = UINT32_MAX;
    for (uint32_t i = 0; i < nn; i++) {
        const rt_kdnode *nd = &t->nodes[i];
        if (rt_kd_is_leaf(nd)) continue;
        parent[i + 1] = i;
        parent[rt_kd_above(nd)] = i;
        depth[i + 1] = (uint8_t)(depth[i] + 1);
        depth[rt_kd_above(nd)] = (uint8_t)(depth[i] + 1);
    }
    for (uint32_t i = 0; i < ntri; i++) last[i] = UINT32_MAX;
    /* Distinct triangles per subtree: +1 at every leaf listing a triangle,
     * -1 at the lowest common ancestor of consecutive (preorder) leaves
     * listing the same triangle; subtree sums then count each once. */
    for (uint32_t i = 0; i < nn; i++) {
        const rt_kdnode *nd = &t->nodes[i];
        if (!rt_kd_is_leaf(nd)) continue;
        const uint32_t n = rt_kd_ntri(nd), first = rt_kd_first(nd);
        out[i].nidx = n;
        for (uint32_t k = 0; k < n; k++) {
            uint32_t tri = t->idx[first + k];
            if (tri >= ntri) {
                rt_errf(e, "k-d tree: leaf %u lists triangle %u >= %u", i, tri, ntri);
                goto out;
            }
            cnt[i]++;
            if (last[tri] != UINT32_MAX) {
                uint32_t a = last[tri], b = i;
                while (depth[a] > depth[b]) a = parent[a];
                while (depth[b] > depth[a]) b = parent[b];
                while (a != b) {
                    a = parent[a];
                    b = parent[b];
                }
                cnt[a]--;
            }
            last[tri] = i;
        }
    }
    for (uint32_t i = nn; i-- > 1;) {
        uint32_t pi = parent[i];
        out[pi].nodes += out[i].nodes;
        out[pi].nidx += out[i].nidx;
        cnt[pi] += cnt[i];
    }
    for (uint32_t i = 0; i < nn; i++) out[i].ntri = (uint32_t)cnt[i];
    rc = 0;
out:
    free(parent);
    free(depth);
    free(cnt);
    free(last);
    return rc;
}
