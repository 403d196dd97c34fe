/*
 * bvh.c -- building, checking and traversing the bounding volume
 * hierarchies of bvh.h (binary, 4-wide, 8-wide compressed).
 *
 * Build. One binary tree is built top-down by binned SAH, then emitted in
 * the requested width:
 *
 *   - Every triangle is a 32-byte primitive record (its box and scene
 *     index); records start in ascending scene-index order and every
 *     partition is stable, so each node's range stays in ascending index
 *     order.
 *   - At a node of n triangles: its box and the box of its centroids
 *     (centroid = 0.5 lo + 0.5 hi of the triangle's box; both boxes are
 *     accumulated while the parent partitions). On every axis where the
 *     centroids spread, they are put in RT_BVH_BINS (32) equal bins,
 *     bin = (int)((c - lo) * scale) clamped to 0..31, scale = 32 / (hi - lo)
 *     rounded to float (at most 1e30); the 31 planes between bins are
 *     scored with cost = trav + isect * (A_L n_L + A_R n_R) / A, the areas
 *     computed in float on boxes scaled by the power of two that brings
 *     the node's largest extent into [0.5, 1) (exact, never overflowing);
 *     ties keep the first axis and the lowest plane. A node of at most
 *     max_leaf triangles becomes a leaf when isect * n <= that cost; a
 *     larger one is always split. The box arithmetic runs four lanes at a
 *     time (SSE2, or a scalar loop: the same IEEE operations).
 *   - When the centroids coincide on every axis (no plane separates them)
 *     or the node lies at depth RT_BVH_SAH_DEPTH (32) or deeper, the range
 *     is halved by count: the lower half in triangle index order goes left.
 *     So leaves hold at most max_leaf triangles and lie no deeper than
 *     32 + 31 = RT_BVH_MAX_DEPTH, whatever the input.
 *   - The build is a loop over an explicit task stack (depth-first, left
 *     child first); nothing depends on pointer values, on qsort or on
 *     threads: the same scene gives the same bytes on every machine.
 *
 * Collapse. bvh4 and bvh8 collapse the binary tree greedily: a wide node
 * starts with the two children of a binary node and repeatedly opens (replaces
 * by its two children, in place) the interior child of largest surface
 * area -- ties: the lowest slot -- until it has `width` children or all
 * are leaves. A binary leaf root becomes a wide root with one leaf child.
 *
 * Emission. bvh2: depth-first preorder, first child at index + 1, leaf
 * triangles appended as leaves are met (pbrt). Wide trees: a node's
 * interior children get consecutive indices when the node is emitted, and
 * its leaf children's triangles are appended contiguously in slot order;
 * nodes are then processed depth-first, slot order. So children always
 * follow their parent in the array, and a bvh8 node addresses its interior
 * children as child_base + rank and its leaves as tri_base + offset.
 *
 * Quantization (bvh8). The grid origin is the node's exact box lo; per axis
 * the smallest biased exponent e (1..254) for which origin + 255 * 2^(e-127)
 * reaches the box hi (in float); a child's planes are qlo = the largest q
 * whose dequantized value is <= the child's exact lo and qhi = the smallest
 * q whose value is >= its exact hi, both checked in the float arithmetic
 * of rt_bvh8_dequant, so the dequantized box contains the exact one.
 *
 * SAH cost (the statistic): (trav * sum of interior node areas + isect *
 * sum over leaves of triangles x leaf area) / root area, over the boxes a
 * traversal tests (bvh8: dequantized), summed in node order, slot order, in
 * double; with a root of zero area every area counts 1.
 *
 * Invariants (rt_bvh_check):
 *   B1  structure: every node is reached from the root exactly once; bvh2:
 *       an interior node i has first child i + 1 and second child in
 *       (i + 1, nnodes); wide: children follow their parent, interior
 *       children of a bvh8 node are consecutive from child_base; non-root
 *       wide nodes have at least two children, the root at least one;
 *   B2  leaves hold 1..max_leaf triangles in a range of tri[]; the ranges
 *       cover every record exactly once; bvh8 leaf offsets < 32, counts < 8;
 *   B3  orig[] is a permutation of the scene's indices and tri[i] is scene
 *       triangle orig[i] bit for bit -- with B2: every triangle in exactly
 *       one leaf; bit i of degen[] is rt_isect_degenerate(&tri[i]);
 *   B4  boxes (bvh2, bvh4): every box contains the boxes of its triangles
 *       and lies inside its parent's box (the root's: bounds, the union of
 *       all triangle boxes); empty bvh4 slots have lo = +inf, hi = -inf;
 *   B5  bvh8: exponents in 1..254, origin = the node's exact box lo, the
 *       grid reaches its exact hi, every slot's dequantized box contains its
 *       child's exact box (conservative rounding), qlo <= qhi; empty slots
 *       have meta 0 and no imask bit;
 *   B6  the bvh8 host copy equals the dequantized nodes;
 *   B7  depth <= RT_BVH_MAX_DEPTH; bvh2 nnodes = 2 leaves - 1, wide nnodes
 *       < leaves (or 1); statistics (leaves, depth) and the stored SAH cost
 *       equal a recomputation;
 *   B8  "a triangle's box" above is its exact box grown by pad on every
 *       side, pad = 2^(e - 20) for the largest coordinate magnitude m (at
 *       least 1) in [2^(e-1), 2^e): far more than the few coordinate ulps
 *       by which the watertight test's computed hit point may miss the
 *       triangle's plane. Without it a ray leaving a surface (a shadow ray
 *       from a floor point rounded 5e-10 above z = 0) starts outside the
 *       flat box, the slab test culls it, and a hit the triangle test
 *       accepts at t ~ 2e-9 -- which the hit rule counts, and brute force
 *       and the k-d tree find -- is lost.
 *
 * Traversal. Boxes are tested by the slab method with the ray's precomputed
 * reciprocal: per axis the near and far plane distances (chosen by the sign
 * of 1/d, so -0 directions are handled), a NaN distance (origin in a face
 * plane of a flat direction) constraining nothing; the far distance is
 * widened by 1 + 2 gamma(3) (pbrt), and the interval is clipped to
 * [tmin, bound(best)] where bound(x) = x + |x| 2^-16: a box whose entry
 * lies up to 2^-16 relative beyond the best hit so far is still visited,
 * because the triangle test rounds t differently from the slab test, and a
 * hit in a box face at the same t with a lower index must still be found
 * (the k-d tree's rt_kd_past margin). A box is hit when tnear <= tfar.
 * bvh2 visits the first child first unless the ray goes negative along the
 * node's split axis (pbrt); wide nodes test all children's boxes and visit
 * the hit ones nearest entry first (ties: lower slot), leaves as they come
 * off the stack. A triangle replaces the best hit when t > tmin and t is
 * smaller, or equal with a lower ORIGINAL index; it starts at t = tmax with
 * no triangle, so t must be < tmax.
 *
 * The reference walk (rt_bvh_plain: walk2, walk_wide) tests boxes one by
 * one; the fast walk of bvh_walk.h (rt_bvh_closest, rt_bvh_occluded,
 * recording or not) makes exactly its visits with four boxes per SSE2
 * vector, or eight per AVX vector for bvh8 (bvh_avx.c, when the processor
 * has AVX: fast_avx). Every lane does the scalar lane's IEEE operations in
 * the same order (max/min written as a > b ? a : b, which is what
 * maxps/minps compute, NaN included), so all agree bit for bit in hits,
 * counts, marks and recorded accesses (tests/test_bvh.c compares them).
 */
#include "config.h"
#include "bvh.h"
#include "accel.h"

#include <float.h>
#include <stddef.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif

/* ---- build ------------------------------------------------------------- */

/* Four floats, one SSE2 register where there is one; the build's box
 * arithmetic is min, max, +, - and * lane by lane, the same on every path. */
#if defined(__SSE2__)
typedef __m128 vf;
static inline vf vload(const float *p) { return _mm_loadu_ps(p); }
static inline void vstore(float *p, vf a) { _mm_storeu_ps(p, a); }
static inline vf vmin(vf a, vf b) { return _mm_min_ps(a, b); }
static inline vf vmax(vf a, vf b) { return _mm_max_ps(a, b); }
static inline vf vadd(vf a, vf b) { return _mm_add_ps(a, b); }
static inline vf vsub(vf a, vf b) { return _mm_sub_ps(a, b); }
static inline vf vmul(vf a, vf b) { return _mm_mul_ps(a, b); }
static inline vf vset1(float x) { return _mm_set1_ps(x); }
#else
typedef struct vf {
    float v[4];
} vf;
static inline vf vload(const float *p)
{
    vf r;
    memcpy(r.v, p, sizeof r.v);
    return r;
}
static inline void vstore(float *p, vf a) { memcpy(p, a.v, sizeof a.v); }
#define VF_OP(name, expr)                                  \
    static inline vf name(vf a, vf b)                      \
    {                                                      \
        vf r;                                              \
        for (int k = 0; k < 4; k++) r.v[k] = (expr);       \
        return r;                                          \
    }
VF_OP(vmin, a.v[k] < b.v[k] ? a.v[k] : b.v[k])
VF_OP(vmax, a.v[k] > b.v[k] ? a.v[k] : b.v[k])
VF_OP(vadd, a.v[k] + b.v[k])
VF_OP(vsub, a.v[k] - b.v[k])
VF_OP(vmul, a.v[k] * b.v[k])
static inline vf vset1(float x)
{
    vf r = {{x, x, x, x}};
    return r;
}
#endif

/* A triangle's box, 32 bytes; lane 3 of lo carries the scene index. Its
 * centroid is 0.5 lo + 0.5 hi (computed where needed, always so). */
typedef struct prim {
    float lo[3];  /* box */
    uint32_t idx; /* scene index */
    float hi[3];
    float pad;    /* 0 */
} prim;

typedef struct bnode {
    rt_bounds box; /* exact box */
    uint32_t a;    /* interior: left child (right = a + 1); leaf: first prim */
    uint32_t n;    /* leaf: triangles; interior: 0 */
    uint8_t axis;  /* interior: split axis */
} bnode;

typedef struct task {
    uint32_t node, begin, end; /* node and its prim range */
    int depth;                 /* root = 0 */
    float lo[4], hi[4];        /* box of the range (lanes 0..2) */
    float clo[4], chi[4];      /* box of its centroids */
} task;

void rt_bvh_default_params(rt_bvh_params *p, int width)
{
    p->width = width;
    p->max_leaf = 4;
    p->trav_cost = 1.0f;
    p->isect_cost = 1.0f;
    p->share_tris = -1;
}

uint32_t rt_bvh_node_size(int width)
{
    return width == 2 ? 32u : width == 4 ? 128u : width == 8 ? 80u : 0u;
}

int rt_bvh_avx_usable(void)
{
#if defined(RT_HAVE_AVX_WALK)
    return __builtin_cpu_supports("avx") ? 1 : 0;
#else
    return 0;
#endif
}

const char *rt_bvh_node_region(int width)
{
    return width == 2 ? "bvh2.node" : width == 4 ? "bvh4.node" : width == 8 ? "bvh8.node" : NULL;
}

/* A triangle's box grown by pad on every side (B8). */
static rt_bounds tri_box(const rt_tri *t, float pad)
{
    rt_bounds b = rt_tri_bounds(t);
    b.lo = rt_v3(b.lo.x - pad, b.lo.y - pad, b.lo.z - pad);
    b.hi = rt_v3(b.hi.x + pad, b.hi.y + pad, b.hi.z + pad);
    return b;
}

/* The pad of B8: 2^-20 of the largest coordinate magnitude (at least 1),
 * rounded up to a power of two. The watertight triangle test, rounding
 * in scaled coordinates, accepts hits whose computed point lies a few ulps
 * of the coordinates off the triangle's plane -- a ray leaving a surface
 * can hit it again at t ~ 1e-9 -- and the hit rule (hit.h) says such a hit
 * counts; exact boxes would cull it (the ray starts outside the flat box
 * and moves away), so every box is grown by far more than that error. */
static float bvh_pad(const rt_scene *s)
{
    float m = 1.0f; /* coordinates are finite: the loaders check their range */
    for (uint32_t i = 0; i < s->ntri; i++)
        for (int k = 0; k < 3; k++) {
            const rt_vec3 *p = &s->tri[i].p[k];
            const float ax = fabsf(p->x), ay = fabsf(p->y), az = fabsf(p->z);
            if (ax > m) m = ax;
            if (ay > m) m = ay;
            if (az > m) m = az;
        }
    int ex;
    frexpf(m, &ex);
    return ldexpf(1.0f, ex - 20);
}

static inline float bget(const rt_vec3 *v, int a) { return ((const float *)(const void *)v)[a]; }
static inline void bset(rt_vec3 *v, int a, float x) { ((float *)(void *)v)[a] = x; }


static int box_inside(const rt_bounds *in, const rt_bounds *out)
{
    for (int k = 0; k < 3; k++)
        if (!(bget(&in->lo, k) >= bget(&out->lo, k) && bget(&in->hi, k) <= bget(&out->hi, k))) return 0;
    return 1;
}

/* Surface area in double (0 for an empty or inverted box). */
static double area(const float lo[3], const float hi[3])
{
    double d[3];
    for (int k = 0; k < 3; k++) {
        d[k] = (double)hi[k] - (double)lo[k];
        if (!(d[k] >= 0.0)) return 0.0;
    }
    return 2.0 * (d[0] * d[1] + d[1] * d[2] + d[2] * d[0]);
}

static double barea(const rt_bounds *b)
{
    const float lo[3] = {b->lo.x, b->lo.y, b->lo.z}, hi[3] = {b->hi.x, b->hi.y, b->hi.z};
    return area(lo, hi);
}

typedef struct build {
    const rt_bvh_params *p;
    prim *pr, *tmp;   /* prims and the partition's scratch */
    uint32_t *idx;    /* after the tree is built: pr[i].idx alone (pr compacted in place) */
    bnode *bn;        /* binary nodes, root 0, children in pairs */
    uint32_t nb;      /* used */
    uint32_t nleaves; /* binary leaves */
    uint32_t ninner;  /* binary interior nodes */
} build;

static inline vf centroid(const prim *q)
{
    const vf h = vset1(0.5f);
    return vadd(vmul(vload(q->lo), h), vmul(vload(q->hi), h));
}

/* Bin of lane x = (c - clo) * scale (>= 0, maybe inf): 0..RT_BVH_BINS-1. */
static inline int bin_of(float x) { return x < (float)(RT_BVH_BINS - 1) ? (int)x : RT_BVH_BINS - 1; }

/* Accumulated boxes of one side of a partition. */
typedef struct side {
    vf lo, hi, clo, chi;
} side;

static inline void side_init(side *d)
{
    d->lo = d->clo = vset1(INFINITY);
    d->hi = d->chi = vset1(-INFINITY);
}

static inline void side_add(side *d, const prim *q, vf c)
{
    d->lo = vmin(d->lo, vload(q->lo));
    d->hi = vmax(d->hi, vload(q->hi));
    d->clo = vmin(d->clo, c);
    d->chi = vmax(d->chi, c);
}

static inline void side_task(const side *d, task *t)
{
    vstore(t->lo, d->lo);
    vstore(t->hi, d->hi);
    vstore(t->clo, d->clo);
    vstore(t->chi, d->chi);
}

/* Half the surface area of the box [lo, hi] scaled by sc (lanes 0..2). */
static inline float half_area(vf lo, vf hi, vf sc)
{
    float d[4];
    vstore(d, vmul(vsub(hi, lo), sc));
    return d[0] * d[1] + d[1] * d[2] + d[2] * d[0];
}

static void build_tree(build *B, const task *root)
{
    const rt_bvh_params *p = B->p;
    task st[RT_BVH_MAX_DEPTH + 4];
    int sp = 0;
    st[sp++] = *root;
    B->nb = 1;
    vf blo[3][RT_BVH_BINS], bhi[3][RT_BVH_BINS];
    uint32_t bcnt[3][RT_BVH_BINS];
    while (sp > 0) {
        const task t = st[--sp];
        const uint32_t n = t.end - t.begin;
        bnode *nd = &B->bn[t.node];
        for (int k = 0; k < 3; k++) {
            bset(&nd->box.lo, k, t.lo[k]);
            bset(&nd->box.hi, k, t.hi[k]);
        }
        int leaf = n <= 1;
        int axis = -1, split = -1;
        float scale[4] = {0, 0, 0, 0};
        if (!leaf && t.depth < RT_BVH_SAH_DEPTH) {
            int live[3], any = 0;
            for (int k = 0; k < 3; k++) {
                const float ext = t.chi[k] - t.clo[k];
                live[k] = ext > 0.0f;
                if (live[k]) {
                    const double sc = (double)RT_BVH_BINS / (double)ext;
                    scale[k] = sc < 1e30 ? (float)sc : 1e30f;
                    any = 1;
                }
                for (int j = 0; j < RT_BVH_BINS; j++) {
                    blo[k][j] = vset1(INFINITY);
                    bhi[k][j] = vset1(-INFINITY);
                    bcnt[k][j] = 0;
                }
            }
            if (any) {
                const vf clo = vload(t.clo), vs = vload(scale);
                for (uint32_t i = t.begin; i < t.end; i++) {
                    const prim *q = &B->pr[i];
                    float x[4];
                    vstore(x, vmul(vsub(centroid(q), clo), vs));
                    const vf lo = vload(q->lo), hi = vload(q->hi);
                    for (int k = 0; k < 3; k++) {
                        const int j = bin_of(x[k]);
                        blo[k][j] = vmin(blo[k][j], lo);
                        bhi[k][j] = vmax(bhi[k][j], hi);
                        bcnt[k][j]++;
                    }
                }
                /* Areas in float on boxes scaled by a power of two that
                 * brings the node's largest extent near 1 (exact, and no
                 * overflow); half areas, as only comparisons matter. */
                float emax = 0.0f;
                for (int k = 0; k < 3; k++)
                    if (t.hi[k] - t.lo[k] > emax) emax = t.hi[k] - t.lo[k];
                int ex = 0;
                if (emax > 0.0f && emax < INFINITY) frexpf(emax, &ex);
                const vf vsc = vset1(ldexpf(1.0f, -ex));
                float best = INFINITY;
                for (int k = 0; k < 3; k++) {
                    if (!live[k]) continue;
                    float rcost[RT_BVH_BINS];
                    uint32_t rn[RT_BVH_BINS];
                    vf lo = vset1(INFINITY), hi = vset1(-INFINITY);
                    uint32_t cnt = 0;
                    for (int j = RT_BVH_BINS - 1; j > 0; j--) {
                        lo = vmin(lo, blo[k][j]);
                        hi = vmax(hi, bhi[k][j]);
                        cnt += bcnt[k][j];
                        rn[j] = cnt;
                        rcost[j] = cnt ? half_area(lo, hi, vsc) * (float)cnt : 0.0f;
                    }
                    lo = vset1(INFINITY);
                    hi = vset1(-INFINITY);
                    cnt = 0;
                    for (int j = 0; j < RT_BVH_BINS - 1; j++) {
                        lo = vmin(lo, blo[k][j]);
                        hi = vmax(hi, bhi[k][j]);
                        cnt += bcnt[k][j];
                        if (cnt == 0 || rn[j + 1] == 0) continue;
                        const float c = half_area(lo, hi, vsc) * (float)cnt + rcost[j + 1];
                        if (c < best) {
                            best = c;
                            axis = k;
                            split = j;
                        }
                    }
                }
                if (axis >= 0) {
                    const float A = half_area(vload(t.lo), vload(t.hi), vsc);
                    const float splitc = p->trav_cost * A + p->isect_cost * best;
                    if (n <= (uint32_t)p->max_leaf && p->isect_cost * (float)n * A <= splitc) leaf = 1;
                }
            }
        } else if (!leaf && n <= (uint32_t)p->max_leaf) {
            leaf = 1; /* below the SAH depth: only size decides */
        }
        if (leaf) {
            nd->a = t.begin;
            nd->n = n;
            nd->axis = 0;
            B->nleaves++;
            continue;
        }
        side L, R;
        side_init(&L);
        side_init(&R);
        uint32_t mid;
        if (axis >= 0) {
            /* stable partition by bin: the lower bins go left */
            const vf clo = vload(t.clo), vs = vload(scale);
            uint32_t l = t.begin, r = 0;
            for (uint32_t i = t.begin; i < t.end; i++) {
                const prim q = B->pr[i];
                const vf c = centroid(&q);
                float x[4];
                vstore(x, vmul(vsub(c, clo), vs));
                if (bin_of(x[axis]) <= split) {
                    side_add(&L, &q, c);
                    B->pr[l++] = q;
                } else {
                    side_add(&R, &q, c);
                    B->tmp[r++] = q;
                }
            }
            memcpy(B->pr + l, B->tmp, r * sizeof *B->pr);
            mid = l;
        } else {
            /* halve by count: the ranges are in ascending index order */
            mid = t.begin + n / 2;
            for (uint32_t i = t.begin; i < t.end; i++) side_add(i < mid ? &L : &R, &B->pr[i], centroid(&B->pr[i]));
            float ext = -1.0f;
            axis = 0;
            for (int k = 0; k < 3; k++) {
                const float x = t.chi[k] - t.clo[k];
                if (x > ext) {
                    ext = x;
                    axis = k;
                }
            }
        }
        const uint32_t l = B->nb;
        B->nb += 2;
        B->ninner++;
        nd->a = l;
        nd->n = 0;
        nd->axis = (uint8_t)axis;
        task tl = {l, t.begin, mid, t.depth + 1, {0}, {0}, {0}, {0}};
        task tr = {l + 1, mid, t.end, t.depth + 1, {0}, {0}, {0}, {0}};
        side_task(&L, &tl);
        side_task(&R, &tr);
        st[sp++] = tr;
        st[sp++] = tl;
    }
}

/* ---- emission ------------------------------------------------------------ */

typedef struct emit {
    const build *B;
    rt_bvh *b;
    uint32_t tpos; /* triangles emitted */
    const rt_scene *s;
} emit;

static void emit_leaf_tris(emit *E, const bnode *nd)
{
    for (uint32_t k = 0; k < nd->n; k++) {
        const uint32_t idx = E->B->idx[nd->a + k];
        if (E->b->tri) E->b->tri[E->tpos] = E->s->tri[idx];
        E->b->orig[E->tpos] = idx;
        if (rt_isect_degenerate(&E->s->tri[idx])) E->b->degen[E->tpos >> 5] |= 1u << (E->tpos & 31);
        E->tpos++;
    }
}

static void emit2(emit *E)
{
    const bnode *bn = E->B->bn;
    rt_bvh *b = E->b;
    typedef struct item {
        uint32_t bnode, parent; /* parent: node whose offset to patch, or UINT32_MAX */
        uint32_t depth;
    } item;
    item st[RT_BVH_MAX_DEPTH + 4];
    int sp = 0;
    uint32_t out = 0;
    st[sp++] = (item){0, UINT32_MAX, 0};
    while (sp > 0) {
        item it = st[--sp];
        const bnode *nd = &bn[it.bnode];
        const uint32_t i = out++;
        rt_bvh2_node *o = &b->n2[i];
        memset(o, 0, sizeof *o);
        if (it.parent != UINT32_MAX) b->n2[it.parent].offset = i;
        memcpy(o->lo, &nd->box.lo, sizeof o->lo);
        memcpy(o->hi, &nd->box.hi, sizeof o->hi);
        if (nd->n) {
            o->offset = E->tpos;
            o->ntri = (uint16_t)nd->n;
            emit_leaf_tris(E, nd);
            if (it.depth > b->depth) b->depth = it.depth;
            b->nleaves++;
            continue;
        }
        o->axis = nd->axis;
        st[sp++] = (item){nd->a + 1, i, it.depth + 1};
        st[sp++] = (item){nd->a, UINT32_MAX, it.depth + 1};
    }
    b->nnodes = out;
}

/* The children of binary node i collapsed to at most W (header comment). */
static int collapse(const bnode *bn, uint32_t i, int W, uint32_t kids[8])
{
    if (bn[i].n) {
        kids[0] = i;
        return 1;
    }
    int k = 2;
    kids[0] = bn[i].a;
    kids[1] = bn[i].a + 1;
    while (k < W) {
        int j = -1;
        double best = -1.0;
        for (int s = 0; s < k; s++) {
            if (bn[kids[s]].n) continue;
            const double A = barea(&bn[kids[s]].box);
            if (A > best) {
                best = A;
                j = s;
            }
        }
        if (j < 0) break;
        const uint32_t c = kids[j];
        for (int s = k; s > j + 1; s--) kids[s] = kids[s - 1];
        kids[j] = bn[c].a;
        kids[j + 1] = bn[c].a + 1;
        k++;
    }
    return k;
}

static float deq(const rt_bvh8_node *n, int a, unsigned q) { return rt_bvh8_dequant(n, a, q); }

/* Quantizes node o's grid on box P and the k child boxes kb[] (header). */
static void quantize(rt_bvh8_node *o, const rt_bounds *P, const rt_bounds *kb, int k)
{
    for (int a = 0; a < 3; a++) {
        const float lo = bget(&P->lo, a), hi = bget(&P->hi, a);
        o->origin[a] = lo;
        int e = 1;
        const double d = (double)hi - (double)lo;
        if (d > 0.0) {
            int x;
            frexp(d / 255.0, &x); /* d / 255 <= 2^x */
            e = x + 127 - 2;
            if (e < 1) e = 1;
            if (e > 254) e = 254;
        }
        o->e[a] = (uint8_t)e;
        while (o->e[a] < 254 && deq(o, a, 255) < hi) o->e[a]++;
        while (o->e[a] > 1) {
            o->e[a]--;
            if (deq(o, a, 255) < hi) {
                o->e[a]++;
                break;
            }
        }
        union {
            uint32_t u;
            float f;
        } sc;
        sc.u = (uint32_t)o->e[a] << 23;
        const double step = (double)sc.f;
        for (int s = 0; s < k; s++) {
            const float clo = bget(&kb[s].lo, a), chi = bget(&kb[s].hi, a);
            double fl = floor(((double)clo - (double)lo) / step), ce = ceil(((double)chi - (double)lo) / step);
            unsigned ql = fl < 0 ? 0u : fl > 255 ? 255u : (unsigned)fl;
            unsigned qh = ce < 0 ? 0u : ce > 255 ? 255u : (unsigned)ce;
            while (ql > 0 && deq(o, a, ql) > clo) ql--;
            while (ql < 255 && deq(o, a, ql + 1) <= clo) ql++;
            while (qh < 255 && deq(o, a, qh) < chi) qh++;
            while (qh > 0 && deq(o, a, qh - 1) >= chi) qh--;
            if (ql > qh) ql = qh; /* a flat box on a step of equal values */
            o->qlo[a][s] = (uint8_t)ql;
            o->qhi[a][s] = (uint8_t)qh;
        }
        for (int s = k; s < 8; s++) {
            o->qlo[a][s] = 255;
            o->qhi[a][s] = 0;
        }
    }
}

/* The host copy of one bvh8 node (B6). */
static void host8(const rt_bvh8_node *o, rt_bvh8_host *h)
{
    int rank = 0;
    for (int s = 0; s < 8; s++) {
        const uint8_t m = o->meta[s];
        if (m == 0) {
            for (int a = 0; a < 3; a++) {
                h->lo[a][s] = INFINITY;
                h->hi[a][s] = -INFINITY;
            }
            h->ref[s] = 0;
            h->cnt[s] = RT_BVH8_NONE;
            continue;
        }
        for (int a = 0; a < 3; a++) {
            h->lo[a][s] = deq(o, a, o->qlo[a][s]);
            h->hi[a][s] = deq(o, a, o->qhi[a][s]);
        }
        if (o->imask >> s & 1u) {
            h->ref[s] = o->child_base + (uint32_t)rank++;
            h->cnt[s] = 0;
        } else {
            h->ref[s] = o->tri_base + (m & 31u);
            h->cnt[s] = m >> 5;
        }
    }
}

/* The wide nodes emit_wide makes (the same collapse, nothing stored), so
 * the node arrays are allocated at their size. */
static uint32_t count_wide(const bnode *bn, int W)
{
    uint32_t st[8 * (RT_BVH_MAX_DEPTH + 4)];
    int sp = 0;
    uint32_t nw = 1;
    st[sp++] = 0;
    while (sp > 0) {
        uint32_t kids[8];
        const int k = collapse(bn, st[--sp], W, kids);
        for (int s = 0; s < k; s++)
            if (!bn[kids[s]].n) {
                nw++;
                st[sp++] = kids[s];
            }
    }
    return nw;
}

static int emit_wide(emit *E, rt_err *e)
{
    const bnode *bn = E->B->bn;
    rt_bvh *b = E->b;
    const int W = b->width;
    typedef struct item {
        uint32_t bnode, node, depth;
    } item;
    const size_t cap = (size_t)W * (RT_BVH_MAX_DEPTH + 4);
    item *st = rt_calloc(cap, sizeof *st, e);
    if (!st) return -1;
    int sp = 0;
    uint32_t nw = 1;
    st[sp++] = (item){0, 0, 0};
    while (sp > 0) {
        const item it = st[--sp];
        uint32_t kids[8];
        const int k = collapse(bn, it.bnode, W, kids);
        uint32_t child[8];
        rt_bounds kb[8];
        const uint32_t child_base = nw, tri_base = E->tpos;
        for (int s = 0; s < k; s++) {
            const bnode *c = &bn[kids[s]];
            kb[s] = c->box;
            if (c->n) {
                child[s] = E->tpos;
                emit_leaf_tris(E, c);
                b->nleaves++;
                if (it.depth + 1 > b->depth) b->depth = it.depth + 1;
            } else {
                child[s] = nw++;
            }
        }
        if (W == 4) {
            rt_bvh4_node *o = &b->n4[it.node];
            for (int s = 0; s < 4; s++) {
                const rt_bounds bx = s < k ? kb[s] : rt_bounds_empty();
                for (int a = 0; a < 3; a++) {
                    o->lo[a][s] = bget(&bx.lo, a);
                    o->hi[a][s] = bget(&bx.hi, a);
                }
                if (s >= k) o->child[s] = RT_BVH4_EMPTY;
                else if (bn[kids[s]].n)
                    o->child[s] = RT_BVH4_LEAF | ((uint64_t)bn[kids[s]].n << 32) | child[s];
                else o->child[s] = child[s];
            }
        } else {
            rt_bvh8_node *o = &b->n8[it.node];
            memset(o, 0, sizeof *o);
            o->child_base = child_base;
            o->tri_base = tri_base;
            int rank = 0;
            for (int s = 0; s < k; s++) {
                if (bn[kids[s]].n) {
                    o->meta[s] = (uint8_t)((bn[kids[s]].n << 5) | (child[s] - tri_base));
                } else {
                    o->imask |= (uint8_t)(1u << s);
                    o->meta[s] = (uint8_t)(0x20u | (24u + (unsigned)rank++));
                }
            }
            const rt_bounds P = it.node == 0 ? b->bounds : bn[it.bnode].box;
            quantize(o, &P, kb, k);
        }
        for (int s = k; s-- > 0;)
            if (!bn[kids[s]].n) st[sp++] = (item){kids[s], child[s], it.depth + 1};
    }
    free(st);
    b->nnodes = nw;
    return 0;
}

/* SAH cost over the tree's stored boxes (header comment). */
static double sah_cost(const rt_bvh *b, double ct, double ci)
{
    const double A0 = barea(&b->bounds);
    double sum = 0.0;
    const int unit = !(A0 > 0.0);
#define W_(x) (unit ? 1.0 : (x))
    if (b->width == 2) {
        for (uint32_t i = 0; i < b->nnodes; i++) {
            const rt_bvh2_node *n = &b->n2[i];
            const double A = W_(area(n->lo, n->hi));
            sum += n->ntri ? ci * n->ntri * A : ct * A;
        }
    } else {
        if (b->nnodes) sum += ct * W_(A0); /* the root */
        for (uint32_t i = 0; i < b->nnodes; i++)
            for (int s = 0; s < b->width; s++) {
                float lo[3], hi[3];
                uint32_t cnt;
                if (b->width == 4) {
                    const rt_bvh4_node *n = &b->n4[i];
                    if (n->child[s] == RT_BVH4_EMPTY) continue;
                    for (int a = 0; a < 3; a++) lo[a] = n->lo[a][s], hi[a] = n->hi[a][s];
                    cnt = rt_bvh4_is_leaf(n->child[s]) ? rt_bvh4_count(n->child[s]) : 0;
                } else {
                    const rt_bvh8_node *n = &b->n8[i];
                    if (n->meta[s] == 0) continue;
                    for (int a = 0; a < 3; a++) lo[a] = deq(n, a, n->qlo[a][s]), hi[a] = deq(n, a, n->qhi[a][s]);
                    cnt = (n->imask >> s & 1u) ? 0 : (uint32_t)(n->meta[s] >> 5);
                }
                const double A = W_(area(lo, hi));
                sum += cnt ? ci * cnt * A : ct * A;
            }
    }
#undef W_
    return unit ? sum : sum / A0;
}

rt_bvh *rt_bvh_build(const rt_scene *s, const rt_bvh_params *params, rt_err *e)
{
    const double t0 = rt_now();
    rt_bvh_params defp;
    if (!params) {
        rt_bvh_default_params(&defp, 4);
        params = &defp;
    }
    const int W = params->width;
    if (W != 2 && W != 4 && W != 8) {
        rt_errf(e, "bvh: width %d (expected 2, 4 or 8)", W);
        return NULL;
    }
    const int maxleaf_lim = W == 8 ? 4 : RT_BVH_MAX_LEAF;
    if (params->max_leaf < 1 || params->max_leaf > maxleaf_lim) {
        rt_errf(e, "bvh%d: leaf size %d (expected 1..%d)", W, params->max_leaf, maxleaf_lim);
        return NULL;
    }
    if (!(params->trav_cost >= 0.0f && params->isect_cost > 0.0f && params->trav_cost < INFINITY &&
          params->isect_cost < INFINITY)) {
        rt_errf(e, "bvh%d: SAH costs must be finite, traversal >= 0, intersection > 0", W);
        return NULL;
    }
    const uint32_t N = s->ntri;
    if (N > RT_BVH_MAX_TRIS) {
        rt_errf(e, "bvh%d: %u triangles exceed the limit of 2^31-1", W, N);
        return NULL;
    }
    rt_bvh *b = rt_calloc(1, sizeof *b, e);
    if (!b) return NULL;
    b->width = W;
    b->max_leaf = params->max_leaf;
    b->trav_cost = params->trav_cost;
    b->isect_cost = params->isect_cost;
    b->ntri = N;
    b->bounds = rt_bounds_empty();
    b->pad = bvh_pad(s);
    b->fast_avx = W == 8 && rt_bvh_avx_usable();
    build B;
    memset(&B, 0, sizeof B);
    B.p = params;
    /* Peak memory (docs/performance.md "Scale"): the arrays the walk keeps
     * are made when the builder's temporaries they outlive are gone or
     * compacted -- the triangle copy (when not shared) after the tree is
     * built, the bvh8 host copy after the binary nodes are freed. */
    const int share = params->share_tris < 0 ? N >= RT_BVH_SHARE_MIN : params->share_tris != 0;
    b->stri = s->tri;
    b->orig = rt_calloc(N ? N : 1, sizeof *b->orig, e);
    b->degen = rt_calloc(N / 32 + 1, sizeof *b->degen, e);
    if (!b->orig || !b->degen) goto fail;
    if (N == 0 && !share && !(b->tri = rt_calloc_aligned(1, sizeof *b->tri, 64, e))) goto fail;
    if (N == 0) {
        b->build_sec = rt_now() - t0;
        return b;
    }
    B.pr = rt_calloc(N, sizeof *B.pr, e);
    B.tmp = rt_calloc(N, sizeof *B.tmp, e);
    B.bn = rt_calloc(2 * (size_t)N - 1, sizeof *B.bn, e);
    if (!B.pr || !B.tmp || !B.bn) goto fail;
    side all;
    side_init(&all);
    for (uint32_t i = 0; i < N; i++) {
        const rt_bounds tb = tri_box(&s->tri[i], b->pad);
        prim *q = &B.pr[i];
        memcpy(q->lo, &tb.lo, sizeof q->lo);
        memcpy(q->hi, &tb.hi, sizeof q->hi);
        q->idx = i;
        q->pad = 0.0f;
        side_add(&all, q, centroid(q));
        rt_bounds_union(&b->bounds, &tb);
    }
    task root = {0, 0, N, 0, {0}, {0}, {0}, {0}};
    side_task(&all, &root);
    build_tree(&B, &root);
    free(B.tmp);
    B.tmp = NULL;
    /* the prims' scene indices alone, in place (4 of their 32 bytes) */
    B.idx = (uint32_t *)(void *)B.pr;
    for (uint32_t i = 0; i < N; i++) {
        const uint32_t x = B.pr[i].idx;
        B.idx[i] = x;
    }
    B.pr = NULL;
    {
        uint32_t *ni = realloc(B.idx, (size_t)N * sizeof *ni);
        if (ni) B.idx = ni;
    }
    if (!share && !(b->tri = rt_calloc_aligned(N, sizeof *b->tri, 64, e))) goto fail;

    emit E = {&B, b, 0, s};
    if (W == 2) {
        b->n2 = rt_calloc(B.nb, sizeof *b->n2, e);
        if (!b->n2) goto fail;
        emit2(&E);
    } else {
        const uint32_t cap = count_wide(B.bn, W);
        if (W == 4) {
            b->n4 = rt_calloc_aligned(cap, sizeof *b->n4, 64, e);
            if (!b->n4) goto fail;
        } else {
            b->n8 = rt_calloc(cap, sizeof *b->n8, e);
            if (!b->n8) goto fail;
        }
        if (emit_wide(&E, e) < 0) goto fail;
        RT_ASSERT(b->nnodes == cap);
    }
    free(B.idx);
    free(B.bn);
    B.idx = NULL;
    B.bn = NULL;
    if (W == 8) {
        b->h8 = rt_calloc_aligned(b->nnodes ? b->nnodes : 1, sizeof *b->h8, 64, e);
        if (!b->h8) goto fail;
        for (uint32_t i = 0; i < b->nnodes; i++) host8(&b->n8[i], &b->h8[i]);
    }
    b->sah = sah_cost(b, params->trav_cost, params->isect_cost);
    b->build_sec = rt_now() - t0;
    return b;
fail:
    free(B.pr);
    free(B.tmp);
    free(B.idx);
    free(B.bn);
    rt_bvh_free(b);
    return NULL;
}

void rt_bvh_free(rt_bvh *b)
{
    if (!b) return;
    free(b->n2);
    free(b->n4);
    free(b->n8);
    free(b->h8);
    free(b->tri);
    free(b->orig);
    free(b->degen);
    free(b);
}

void rt_bvh_stats(const rt_bvh *b, rt_bvh_stat *st)
{
    st->width = b->width;
    st->nodes = b->nnodes;
    st->leaves = b->nleaves;
    st->depth = b->depth;
    st->bytes = (uint64_t)b->nnodes * rt_bvh_node_size(b->width) + 36ull * b->ntri;
    st->build_sec = b->build_sec;
    st->sah = b->sah;
}

int rt_bvh_layout(const rt_bvh *b, rt_layout *L, int *reg_node, int *reg_tri, rt_err *e)
{
    const char *nn = rt_bvh_node_region(b->width);
    if (!nn) return rt_errf(e, "bvh: width %d has no layout", b->width);
    if (rt_mm_find(L, nn) >= 0 || rt_mm_find(L, "bvh.tri") >= 0) return rt_errf(e, "bvh: layout already has %s", nn);
    const int rn = rt_mm_add(L, nn, RT_CLS_NODE, rt_bvh_node_size(b->width), b->nnodes, e);
    if (rn < 0) return -1;
    const int rt = rt_mm_add(L, "bvh.tri", RT_CLS_TRI, 36, b->ntri, e);
    if (rt < 0) return -1;
    if (reg_node) *reg_node = rn;
    if (reg_tri) *reg_tri = rt;
    return 0;
}

/* ---- checking -------------------------------------------------------------- */

typedef struct chk {
    const rt_bvh *b;
    const rt_scene *s;
    uint8_t *covered; /* per record: leaves covering it */
    uint8_t *seen;    /* per node: reached */
    rt_bounds *nbox;  /* wide: exact box of each node's subtree */
    uint32_t nleaves, depth;
    rt_err *e;
} chk;

/* A leaf of n records from first, at depth d, inside box (NULL: skip). */
static int chk_leaf(chk *C, uint32_t where, uint32_t first, uint32_t n, uint32_t d, const rt_bounds *box,
                    rt_bounds *exact)
{
    const rt_bvh *b = C->b;
    if (n < 1 || n > (uint32_t)b->max_leaf)
        return rt_errf(C->e, "bvh%d: node %u has a leaf of %u triangles (1..%d)", b->width, where, n, b->max_leaf);
    if ((uint64_t)first + n > b->ntri)
        return rt_errf(C->e, "bvh%d: node %u leaf [%u, +%u) outside the %u triangles", b->width, where, first, n,
                       b->ntri);
    if (d > RT_BVH_MAX_DEPTH) return rt_errf(C->e, "bvh%d: leaf at depth %u > %d", b->width, d, RT_BVH_MAX_DEPTH);
    C->nleaves++;
    if (d > C->depth) C->depth = d;
    for (uint32_t k = first; k < first + n; k++) {
        if (C->covered[k]++)
            return rt_errf(C->e, "bvh%d: triangle record %u is in two leaves", b->width, k);
        const rt_bounds tb = tri_box(rt_bvh_tri(b, k), b->pad);
        if (box && !box_inside(&tb, box))
            return rt_errf(C->e, "bvh%d: node %u: triangle %u pokes out of its leaf's box", b->width, where, b->orig[k]);
        if (exact) rt_bounds_union(exact, &tb);
    }
    return 0;
}

/* Set bits of m below bit s: a bvh8 interior slot's rank. */
static uint32_t bits_below(unsigned m, int s)
{
    uint32_t c = 0;
    for (int k = 0; k < s; k++) c += m >> k & 1u;
    return c;
}

static int chk_visit(chk *C, uint32_t i)
{
    if (i >= C->b->nnodes) return rt_errf(C->e, "bvh%d: child %u beyond %u nodes", C->b->width, i, C->b->nnodes);
    if (C->seen[i]) return rt_errf(C->e, "bvh%d: node %u reached twice", C->b->width, i);
    C->seen[i] = 1;
    return 0;
}

static int check2(chk *C)
{
    const rt_bvh *b = C->b;
    typedef struct item {
        uint32_t node, depth;
        rt_bounds parent;
    } item;
    item st[RT_BVH_MAX_DEPTH + 4];
    int sp = 0;
    st[sp++] = (item){0, 0, b->bounds};
    while (sp > 0) {
        const item it = st[--sp];
        if (chk_visit(C, it.node) < 0) return -1;
        const rt_bvh2_node *n = &b->n2[it.node];
        rt_bounds box;
        memcpy(&box.lo, n->lo, sizeof n->lo);
        memcpy(&box.hi, n->hi, sizeof n->hi);
        if (!box_inside(&box, &it.parent)) return rt_errf(C->e, "bvh2: node %u's box leaves its parent's", it.node);
        if (n->pad) return rt_errf(C->e, "bvh2: node %u padding not zero", it.node);
        if (n->ntri) {
            if (chk_leaf(C, it.node, n->offset, n->ntri, it.depth, &box, NULL) < 0) return -1;
            continue;
        }
        if (n->axis > 2) return rt_errf(C->e, "bvh2: node %u axis %u", it.node, n->axis);
        if (!(n->offset > it.node + 1 && n->offset < b->nnodes))
            return rt_errf(C->e, "bvh2: node %u second child %u (nodes %u)", it.node, n->offset, b->nnodes);
        if (it.depth >= RT_BVH_MAX_DEPTH) return rt_errf(C->e, "bvh2: deeper than %d", RT_BVH_MAX_DEPTH);
        st[sp++] = (item){n->offset, it.depth + 1, box};
        st[sp++] = (item){it.node + 1, it.depth + 1, box};
    }
    if (b->nnodes != 2 * C->nleaves - 1)
        return rt_errf(C->e, "bvh2: %u nodes for %u leaves", b->nnodes, C->nleaves);
    return 0;
}

/* Wide trees, forward pass: structure, leaves, bvh4 containment (B1, B2,
 * B4); the exact boxes follow in reverse node order. */
static int check_wide(chk *C)
{
    const rt_bvh *b = C->b;
    const int W = b->width;
    typedef struct item {
        uint32_t node, depth;
        rt_bounds box; /* bvh4: the node's box as its parent states it */
    } item;
    const size_t cap = (size_t)W * (RT_BVH_MAX_DEPTH + 4);
    item *st = rt_calloc(cap, sizeof *st, C->e);
    if (!st) return -1;
    int rc = -1;
    size_t sp = 0;
    st[sp++] = (item){0, 0, b->bounds};
    while (sp > 0) {
        const item it = st[--sp];
        const uint32_t i = it.node;
        if (chk_visit(C, i) < 0) goto out;
        int nkids = 0, rank = 0, nleafslots = 0;
        uint32_t tnext = 0;
        for (int s = 0; s < W; s++) {
            uint32_t child = 0, first = 0, cnt = 0;
            int kind; /* 0 empty, 1 interior, 2 leaf */
            rt_bounds box;
            if (W == 4) {
                const rt_bvh4_node *n = &b->n4[i];
                for (int a = 0; a < 3; a++) {
                    bset(&box.lo, a, n->lo[a][s]);
                    bset(&box.hi, a, n->hi[a][s]);
                }
                const uint64_t c = n->child[s];
                kind = c == RT_BVH4_EMPTY ? 0 : rt_bvh4_is_leaf(c) ? 2 : 1;
                if (kind == 0) {
                    for (int a = 0; a < 3; a++)
                        if (!(n->lo[a][s] == INFINITY && n->hi[a][s] == -INFINITY)) {
                            rt_errf(C->e, "bvh4: node %u empty slot %d has a box", i, s);
                            goto out;
                        }
                    continue;
                }
                if (!box_inside(&box, &it.box)) {
                    rt_errf(C->e, "bvh4: node %u slot %d box leaves its parent's", i, s);
                    goto out;
                }
                if (kind == 1) {
                    if (c >> 32) {
                        rt_errf(C->e, "bvh4: node %u slot %d reference %llx", i, s, (unsigned long long)c);
                        goto out;
                    }
                    child = (uint32_t)c;
                } else {
                    first = rt_bvh4_first(c);
                    cnt = rt_bvh4_count(c);
                }
            } else {
                const rt_bvh8_node *n = &b->n8[i];
                const uint8_t m = n->meta[s];
                const int inner = n->imask >> s & 1u;
                if (m == 0) {
                    if (inner) {
                        rt_errf(C->e, "bvh8: node %u empty slot %d in imask", i, s);
                        goto out;
                    }
                    continue;
                }
                for (int a = 0; a < 3; a++)
                    if (n->qlo[a][s] > n->qhi[a][s]) {
                        rt_errf(C->e, "bvh8: node %u slot %d axis %d qlo > qhi", i, s, a);
                        goto out;
                    }
                if (inner) {
                    if (m != (uint8_t)(0x20u | (24u + (unsigned)rank))) {
                        rt_errf(C->e, "bvh8: node %u slot %d meta %02x for interior rank %d", i, s, m, rank);
                        goto out;
                    }
                    kind = 1;
                    child = n->child_base + (uint32_t)rank++;
                } else {
                    kind = 2;
                    first = n->tri_base + (m & 31u);
                    cnt = m >> 5;
                    if ((m & 31u) != tnext) {
                        rt_errf(C->e, "bvh8: node %u slot %d leaf offset %u, expected %u", i, s, m & 31u, tnext);
                        goto out;
                    }
                    tnext += cnt;
                }
            }
            nkids++;
            if (kind == 1) {
                if (child <= i) {
                    rt_errf(C->e, "bvh%d: node %u child %u does not follow it", W, i, child);
                    goto out;
                }
                if (it.depth + 1 > RT_BVH_MAX_DEPTH) {
                    rt_errf(C->e, "bvh%d: deeper than %d", W, RT_BVH_MAX_DEPTH);
                    goto out;
                }
                if (sp >= cap) {
                    rt_errf(C->e, "bvh%d: traversal stack overflow at node %u", W, i);
                    goto out;
                }
                st[sp++] = (item){child, it.depth + 1, box};
            } else {
                nleafslots++;
                if (chk_leaf(C, i, first, cnt, it.depth + 1, W == 4 ? &box : NULL, NULL) < 0) goto out;
            }
        }
        (void)nleafslots;
        if (nkids < (i == 0 ? 1 : 2)) {
            rt_errf(C->e, "bvh%d: node %u has %d children", W, i, nkids);
            goto out;
        }
    }
    if (b->nnodes > 1 && b->nnodes >= C->nleaves) {
        rt_errf(C->e, "bvh%d: %u nodes for %u leaves", W, b->nnodes, C->nleaves);
        goto out;
    }
    for (uint32_t i = 0; i < b->nnodes; i++)
        if (!C->seen[i]) {
            rt_errf(C->e, "bvh%d: node %u unreachable", W, i);
            goto out;
        }
    /* Exact subtree boxes, children before parents (they follow them; every
     * reference was range-checked above, as every node is reachable). */
    for (uint32_t i = b->nnodes; i-- > 0;) {
        rt_bounds nb = rt_bounds_empty();
        for (int s = 0; s < W; s++) {
            rt_bounds ex = rt_bounds_empty();
            rt_bounds slot;
            int inner;
            if (W == 4) {
                const uint64_t c = b->n4[i].child[s];
                if (c == RT_BVH4_EMPTY) continue;
                inner = !rt_bvh4_is_leaf(c);
                if (inner) ex = C->nbox[(uint32_t)c];
                else
                    for (uint32_t k = rt_bvh4_first(c); k < rt_bvh4_first(c) + rt_bvh4_count(c); k++) {
                        const rt_bounds tb = tri_box(rt_bvh_tri(b, k), b->pad);
                        rt_bounds_union(&ex, &tb);
                    }
                for (int a = 0; a < 3; a++) {
                    bset(&slot.lo, a, b->n4[i].lo[a][s]);
                    bset(&slot.hi, a, b->n4[i].hi[a][s]);
                }
            } else {
                const rt_bvh8_node *n = &b->n8[i];
                if (n->meta[s] == 0) continue;
                inner = n->imask >> s & 1u;
                if (inner) ex = C->nbox[n->child_base + bits_below(n->imask, s)];
                else
                    for (uint32_t k = n->tri_base + (n->meta[s] & 31u); k < n->tri_base + (n->meta[s] & 31u) + (n->meta[s] >> 5u); k++) {
                        const rt_bounds tb = tri_box(rt_bvh_tri(b, k), b->pad);
                        rt_bounds_union(&ex, &tb);
                    }
                for (int a = 0; a < 3; a++) {
                    bset(&slot.lo, a, deq(n, a, n->qlo[a][s]));
                    bset(&slot.hi, a, deq(n, a, n->qhi[a][s]));
                }
            }
            if (!box_inside(&ex, &slot)) {
                rt_errf(C->e, "bvh%d: node %u slot %d box does not contain its %s", W, i, s,
                        inner ? "subtree's triangles" : "triangles");
                goto out;
            }
            rt_bounds_union(&nb, &ex);
        }
        C->nbox[i] = nb;
        if (W == 8) {
            const rt_bvh8_node *n = &b->n8[i];
            for (int a = 0; a < 3; a++) {
                if (n->e[a] < 1 || n->e[a] > 254) {
                    rt_errf(C->e, "bvh8: node %u exponent %u", i, n->e[a]);
                    goto out;
                }
                if (n->origin[a] != bget(&nb.lo, a) || deq(n, a, 255) < bget(&nb.hi, a)) {
                    rt_errf(C->e, "bvh8: node %u grid on axis %d does not span its box", i, a);
                    goto out;
                }
            }
            rt_bvh8_host want;
            host8(n, &want);
            if (memcmp(&want, &b->h8[i], sizeof want) != 0) {
                rt_errf(C->e, "bvh8: node %u host copy differs from its dequantized node", i);
                goto out;
            }
        }
    }
    if (b->nnodes && !box_inside(&C->nbox[0], &b->bounds)) {
        rt_errf(C->e, "bvh%d: root box leaves the bounds", W);
        goto out;
    }
    rc = 0;
out:
    free(st);
    return rc;
}

int rt_bvh_check(const rt_bvh *b, const rt_scene *s, rt_err *e)
{
    if (!b) return rt_errf(e, "bvh: no tree");
    const int W = b->width;
    if (W != 2 && W != 4 && W != 8) return rt_errf(e, "bvh: width %d", W);
    if (b->ntri != s->ntri) return rt_errf(e, "bvh%d: %u triangles, the scene has %u", W, b->ntri, s->ntri);
    if ((b->nnodes == 0) != (b->ntri == 0)) return rt_errf(e, "bvh%d: %u nodes for %u triangles", W, b->nnodes, b->ntri);
    if (b->nnodes && !(W == 2 ? b->n2 != NULL : W == 4 ? b->n4 != NULL : b->n8 && b->h8))
        return rt_errf(e, "bvh%d: node array missing", W);
    rt_bounds tb = rt_bounds_empty();
    for (uint32_t i = 0; i < s->ntri; i++) {
        const rt_bounds x = tri_box(&s->tri[i], b->pad);
        rt_bounds_union(&tb, &x);
    }
    if (memcmp(&tb, &b->bounds, sizeof tb) != 0) return rt_errf(e, "bvh%d: bounds differ from the triangles'", W);
    chk C;
    memset(&C, 0, sizeof C);
    C.b = b;
    C.s = s;
    C.e = e;
    int rc = -1;
    uint8_t *perm = rt_calloc(b->ntri ? b->ntri : 1, 1, e);
    C.covered = rt_calloc(b->ntri ? b->ntri : 1, 1, e);
    C.seen = rt_calloc(b->nnodes ? b->nnodes : 1, 1, e);
    C.nbox = W != 2 ? rt_calloc(b->nnodes ? b->nnodes : 1, sizeof *C.nbox, e) : NULL;
    if (!perm || !C.covered || !C.seen || (W != 2 && !C.nbox)) goto out;
    /* B3 */
    for (uint32_t i = 0; i < b->ntri; i++) {
        const uint32_t o = b->orig[i];
        if (o >= s->ntri || perm[o]++) {
            rt_errf(e, "bvh%d: record %u names triangle %u twice or out of range", W, i, o);
            goto out;
        }
        if (b->tri && memcmp(&b->tri[i], &s->tri[o], sizeof(rt_tri)) != 0) {
            rt_errf(e, "bvh%d: record %u differs from scene triangle %u", W, i, o);
            goto out;
        }
        if (rt_bvh_degenerate(b->degen, i) != rt_isect_degenerate(&s->tri[o])) {
            rt_errf(e, "bvh%d: record %u: degenerate flag %d, the triangle's %d", W, i, rt_bvh_degenerate(b->degen, i),
                    rt_isect_degenerate(&s->tri[o]));
            goto out;
        }
    }
    if (b->nnodes) {
        if ((W == 2 ? check2(&C) : check_wide(&C)) < 0) goto out;
        for (uint32_t i = 0; i < b->nnodes; i++)
            if (!C.seen[i]) {
                rt_errf(e, "bvh%d: node %u unreachable", W, i);
                goto out;
            }
    }
    for (uint32_t i = 0; i < b->ntri; i++)
        if (C.covered[i] != 1) {
            rt_errf(e, "bvh%d: triangle %u (record %u) is in no leaf", W, b->orig[i], i);
            goto out;
        }
    if (C.nleaves != b->nleaves || C.depth != b->depth) {
        rt_errf(e, "bvh%d: statistics disagree (leaves %u/%u depth %u/%u)", W, C.nleaves, b->nleaves, C.depth,
                b->depth);
        goto out;
    }
    {
        const double sah = sah_cost(b, b->trav_cost, b->isect_cost);
        if (!(sah == b->sah)) {
            rt_errf(e, "bvh%d: stored SAH cost %.17g, recomputed %.17g", W, b->sah, sah);
            goto out;
        }
    }
    rc = 0;
out:
    free(perm);
    free(C.covered);
    free(C.seen);
    free(C.nbox);
    return rc;
}

/* ---- traversal -------------------------------------------------------------- */

#include "bvh_walk.h"


/* bvh2: pbrt's walk. */
static RT_ALWAYS_INLINE int walk2(rt_bvh_trav *tv, const rt_ray *rp, rt_hit *h, const int any)
{
    /* a local copy: stores through mark[] (a char pointer) and into the
     * recorder could alias *rp and force reloads in the leaves */
    const rt_ray ray = *rp, *r = &ray;
    const rt_bvh *b = tv->bvh;
    wstate S;
    wstate_init(&S, tv, r);
    if (!b->nnodes) return finish(tv, &S, h, any, 0);
    wray w;
    wray_init(&w, r);
    rt_rec *rec = tv->rec;
    const uint64_t nbase = rec ? tv->L->r[tv->reg_node].base : 0;
    uint32_t st[RT_BVH_MAX_DEPTH + 2];
    int sp = 0, occluded = 0;
    uint32_t node = 0;
    for (;;) {
        const rt_bvh2_node *nd = &b->n2[node];
        S.nvisit++;
        RT_REC(rec, nbase + 32ull * node, 32, 0, RT_CLS_NODE);
        float tn;
        if (box_lane(&w, nd->lo[0], nd->lo[1], nd->lo[2], nd->hi[0], nd->hi[1], nd->hi[2], S.cull, &tn)) {
            if (nd->ntri) {
                if (leaf_tris(r, nd->offset, nd->ntri, &S, any)) {
                    occluded = 1;
                    break;
                }
            } else {
                if (w.neg[nd->axis]) {
                    st[sp++] = node + 1;
                    node = nd->offset;
                } else {
                    st[sp++] = nd->offset;
                    node = node + 1;
                }
                continue;
            }
        }
        if (sp == 0) break;
        node = st[--sp];
    }
    return finish(tv, &S, h, any, occluded);
}

/* bvh4 and bvh8, the reference walk (rt_bvh_plain): the children's boxes
 * tested one by one (box_lane), the hit ones pushed farthest first (by
 * entry, ties: the higher slot), every entry popped, culled against the
 * best hit so far, and visited or its leaf tested. walk_fast must do
 * exactly what this does. */
static RT_ALWAYS_INLINE int walk_wide(rt_bvh_trav *tv, const rt_ray *rp, rt_hit *h, const int any, const int W)
{
    const rt_ray ray = *rp, *r = &ray; /* as in walk2 */
    const rt_bvh *b = tv->bvh;
    wstate S;
    wstate_init(&S, tv, r);
    if (!b->nnodes) return finish(tv, &S, h, any, 0);
    wray w;
    wray_init(&w, r);
    rt_rec *rec = tv->rec;
    const uint64_t nbase = rec ? tv->L->r[tv->reg_node].base : 0;
    const uint32_t nsize = rec ? rt_bvh_node_size(W) : 0;
    sentry st[RT_BVH_STACK];
    int sp = 0, occluded = 0;
    st[sp++] = (sentry){0, 0, w.tmin};
    while (sp > 0) {
        const sentry e = st[--sp];
        if (e.t > S.cull) continue;
        if (e.n) {
            if (leaf_tris(r, e.a, e.n, &S, any)) {
                occluded = 1;
                break;
            }
            continue;
        }
        S.nvisit++;
        RT_REC(rec, nbase + (uint64_t)nsize * e.a, nsize, 0, RT_CLS_NODE);
        /* the children's boxes: rows lo[axis][slot], then hi[axis][slot]
         * (bvh4: the modeled node; bvh8: the dequantized host copy); an
         * empty slot's box (+inf, -inf) is never hit */
        const float *base = W == 4 ? &b->n4[e.a].lo[0][0] : &b->h8[e.a].lo[0][0];
        float tn[8];
        unsigned mask = 0;
        for (int s = 0; s < W; s++)
            mask |= (unsigned)box_lane(&w, base[s], base[W + s], base[2 * W + s], base[3 * W + s], base[4 * W + s],
                                       base[5 * W + s], S.cull, &tn[s])
                    << s;
        if (!mask) continue;
        /* order the hit children by (entry, slot), push the farthest first */
        int ord[8], k = rt_bvh_order_slots(mask, tn, ord);
        while (k > 0) {
            const int s = ord[--k];
            uint32_t ra, rn;
            if (!rt_bvh_wide_child(W, b->n4, b->h8, e.a, s, &ra, &rn)) continue;
            st[sp++] = (sentry){ra, rn, tn[s]};
        }
    }
    return finish(tv, &S, h, any, occluded);
}


static RT_ALWAYS_INLINE int walk(rt_bvh_trav *tv, const rt_ray *r, rt_hit *h, const int any, const int simd)
{
#if defined(__SSE2__)
    if (simd) {
        if (tv->bvh->width == 4) return walk_fast_for(tv, r, h, any, 4);
        if (tv->bvh->width == 8) return walk_fast_for(tv, r, h, any, 8);
    }
#endif
    switch (tv->bvh->width) {
    case 2: return walk2(tv, r, h, any);
    case 4: return walk_wide(tv, r, h, any, 4);
    default: return walk_wide(tv, r, h, any, 8);
    }
}

#if defined(__SSE2__)
#define FAST 1
#else
#define FAST 0
#endif

/* One visited node (bvh.h): walk2's and walk_wide's step without the
 * recording and counting. */
void rt_bvh_wray_init(rt_bvh_wray *w, const rt_ray *r, int width)
{
    _Static_assert(offsetof(rt_bvh_wray, nofs) == sizeof(wray), "rt_bvh_wray opens with wray");
    wray x;
    wray_init(&x, r);
    memcpy(w, &x, sizeof x);
    for (int a = 0; a < 3; a++) {
        w->nofs[a] = a * width + (x.neg[a] ? 3 * width : 0);
        w->fofs[a] = a * width + (x.neg[a] ? 0 : 3 * width);
    }
}

/* rt_bvh_step on a wide node, W a constant after inlining. */
static RT_ALWAYS_INLINE int step_wide(const rt_bvh *b, const rt_bvh_wray *wr, uint32_t node, float cull,
                                      rt_bvh_ref out[8], const int W)
{
    const float *base = W == 4 ? &b->n4[node].lo[0][0] : &b->h8[node].lo[0][0];
    float tn[8];
    unsigned mask = 0;
#if defined(__SSE2__)
    wsse q;
    for (int a = 0; a < 3; a++) {
        q.o[a] = _mm_set1_ps(wr->o[a]);
        q.inv[a] = _mm_set1_ps(wr->inv[a]);
    }
    q.tmin = _mm_set1_ps(wr->tmin);
    q.inf = _mm_set1_ps(INFINITY);
    q.scale = _mm_set1_ps(FAR_SCALE);
    mask = box4(&q, base, wr->nofs, wr->fofs, cull, tn);
    if (W == 8) mask |= box4(&q, base + 4, wr->nofs, wr->fofs, cull, tn + 4) << 4;
#else
    wray w;
    memcpy(&w, wr, sizeof w);
    for (int s = 0; s < W; s++)
        mask |= (unsigned)box_lane(&w, base[s], base[W + s], base[2 * W + s], base[3 * W + s], base[4 * W + s],
                                   base[5 * W + s], cull, &tn[s])
                << s;
#endif
    int ord[8], k = rt_bvh_order_slots(mask, tn, ord), m = 0;
    while (k > 0) {
        const int s = ord[--k];
        uint32_t ra, rn;
        if (!rt_bvh_wide_child(W, b->n4, b->h8, node, s, &ra, &rn)) continue;
        out[m++] = (rt_bvh_ref){ra, rn, tn[s]};
    }
    return m;
}

int rt_bvh_step(const rt_bvh *b, const rt_bvh_wray *wr, uint32_t node, float cull, rt_bvh_ref out[8])
{
    if (b->width == 4) return step_wide(b, wr, node, cull, out, 4);
    if (b->width == 8) return step_wide(b, wr, node, cull, out, 8);
    wray w;
    memcpy(&w, wr, sizeof w);
    const rt_bvh2_node *nd = &b->n2[node];
    float tn;
    if (!box_lane(&w, nd->lo[0], nd->lo[1], nd->lo[2], nd->hi[0], nd->hi[1], nd->hi[2], cull, &tn)) return 0;
    if (nd->ntri) {
        out[0] = (rt_bvh_ref){nd->offset, nd->ntri, tn};
        return 1;
    }
    const uint32_t nearc = w.neg[nd->axis] ? nd->offset : node + 1;
    const uint32_t farc = w.neg[nd->axis] ? node + 1 : nd->offset;
    out[0] = (rt_bvh_ref){farc, 0, -INFINITY};
    out[1] = (rt_bvh_ref){nearc, 0, -INFINITY};
    return 2;
}

/* The AVX copy is tested first, in a function of its own, so a ray bound
 * for it pays no prologue of the inlined walks below. */
static RT_NOINLINE int walk_closest(rt_bvh_trav *tv, const rt_ray *r, rt_hit *h) { return walk(tv, r, h, 0, FAST); }
static RT_NOINLINE int walk_occluded(rt_bvh_trav *tv, const rt_ray *r) { return walk(tv, r, NULL, 1, FAST); }

int rt_bvh_closest(rt_bvh_trav *tv, const rt_ray *r, rt_hit *h)
{
#if defined(RT_HAVE_AVX_WALK)
    if (tv->bvh->fast_avx) return rt_bvh_walk8_avx(tv, r, h, 0);
#endif
    return walk_closest(tv, r, h);
}

int rt_bvh_occluded(rt_bvh_trav *tv, const rt_ray *r)
{
#if defined(RT_HAVE_AVX_WALK)
    if (tv->bvh->fast_avx) return rt_bvh_walk8_avx(tv, r, NULL, 1);
#endif
    return walk_occluded(tv, r);
}

int rt_bvh_plain(rt_bvh_trav *tv, const rt_ray *r, rt_hit *h, int any)
{
    return any ? walk(tv, r, NULL, 1, 0) : walk(tv, r, h, 0, 0);
}

void rt_bvh_trav_init(rt_bvh_trav *tv, const rt_bvh *b, const rt_scene *sc, rt_rec *rec, const rt_layout *L)
{
    memset(tv, 0, sizeof *tv);
    tv->bvh = b;
    tv->sc = sc;
    tv->rec = rec;
    tv->L = L;
    tv->width = b->width;
    tv->reg_node = tv->reg_idx = tv->reg_tri = -1;
    if (L) {
        const char *nn = rt_bvh_node_region(b->width);
        tv->reg_node = nn ? rt_mm_find(L, nn) : -1;
        tv->reg_tri = rt_mm_find(L, "bvh.tri");
    }
    rt_alpha_at_init(&tv->alpha, L);
}

/* ---- the BVHs as members of the acceleration layer (accel.h) ------------- */

static void *bvh_build_w(const rt_scene *sc, const rt_accel_params *p, int width, rt_err *e)
{
    rt_bvh_params bp;
    rt_bvh_default_params(&bp, width);
    if (p->max_leaf) bp.max_leaf = p->max_leaf;
    return rt_bvh_build(sc, &bp, e);
}
static void *bvh2_build(const rt_scene *sc, const rt_accel_params *p, rt_err *e) { return bvh_build_w(sc, p, 2, e); }
static void *bvh4_build(const rt_scene *sc, const rt_accel_params *p, rt_err *e) { return bvh_build_w(sc, p, 4, e); }
static void *bvh8_build(const rt_scene *sc, const rt_accel_params *p, rt_err *e) { return bvh_build_w(sc, p, 8, e); }

static void bvh_free_as(void *as) { rt_bvh_free(as); }

static int bvh_regions(const void *as, const rt_scene *sc, rt_layout *L, rt_err *e)
{
    (void)sc;
    return rt_bvh_layout(as, L, NULL, NULL, e);
}

static void bvh_trav_init(rt_trav *tv, const void *as, const rt_layout *L)
{
    const rt_bvh *b = as;
    const char *nn = rt_bvh_node_region(b->width);
    tv->bvh = b;
    tv->width = b->width;
    tv->reg_node = nn ? rt_mm_find(L, nn) : -1;
    tv->reg_tri = rt_mm_find(L, "bvh.tri");
}


static int bvh_check_as(const void *as, const rt_scene *sc, rt_err *e) { return rt_bvh_check(as, sc, e); }

static void bvh_info(const void *as, rt_accel_info *inf)
{
    rt_bvh_stat st;
    rt_bvh_stats(as, &st);
    inf->nodes = st.nodes;
    inf->bytes = (uint64_t)st.nodes * rt_bvh_node_size(st.width);
    inf->depth = st.depth;
}

#define BVH_OPS(W, DESC)                                                                                      \
    const rt_accel_ops rt_accel_bvh##W = {                                                                    \
        .name = "bvh" #W,                                                                                     \
        .desc = DESC,                                                                                         \
        .flags = RT_ACCEL_OWN_TRIS,                                                                           \
        .build = bvh##W##_build,                                                                              \
        .free = bvh_free_as,                                                                                  \
        .regions = bvh_regions,                                                                               \
        .trav_init = bvh_trav_init,                                                                           \
        .closest = rt_bvh_closest,                                                                            \
        .occluded = rt_bvh_occluded,                                                                          \
        .check = bvh_check_as,                                                                                \
        .info = bvh_info,                                                                                     \
    }
BVH_OPS(2, "binary BVH, 32-byte nodes in depth-first order (pbrt's LinearBVHNode)");
BVH_OPS(4, "4-wide BVH, 128-byte nodes with SoA child boxes (Embree's BVH4)");
BVH_OPS(8, "8-wide compressed BVH, 80-byte nodes, 8-bit child boxes (Ylitie, Karras, Laine 2017)");
