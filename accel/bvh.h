/*
 * bvh.h -- bounding volume hierarchies (binary, 4-wide, 8-wide compressed)
 * with memory-access recording: the BVH family beside the k-d tree.
 *
 * One rt_bvh is one tree of one width, built from a scene by top-down
 * binned SAH (bvh.c explains the build and states the invariants that
 * rt_bvh_check verifies). Three modeled node layouts (docs/memory-model.md
 * draws their bytes):
 *
 *   bvh2  32-byte nodes in depth-first order, pbrt's LinearBVHNode: the
 *         node's box (6 floats), the second child's index or the leaf's
 *         first triangle, the triangle count (0: interior) and the split
 *         axis. The first child of an interior node is the next node.
 *   bvh4  128-byte nodes (Embree's BVH4): the four children's boxes as a
 *         structure of arrays (96 B) and four 8-byte child references.
 *   bvh8  80-byte compressed nodes after Ylitie, Karras and Laine (HPG
 *         2017): a grid origin and three power-of-two scales, the children's
 *         boxes quantized to 8 bits per plane on that grid (rounded
 *         outwards, so a ray that meets a child's exact box meets its
 *         quantized box), the internal children stored consecutively from a
 *         base index and the leaf children's triangles from another.
 *
 * Triangles are copied into leaf order, so a leaf is a contiguous range of
 * 36-byte triangle records (the compact k-d layout's record) and no index
 * list exists; orig[] keeps each record's scene triangle index, which is
 * what hits, shading, marks and the tie rule use.
 *
 * Hits. Closest hit is the smallest t in (tmin, tmax) and, among equal t,
 * the smallest ORIGINAL triangle index -- the rule of the k-d tree and of
 * rt_brute_closest -- computed with the same watertight test
 * (rt_isect_core), so a BVH, the k-d tree and brute force return the same
 * rt_hit bit for bit. Any hit: some triangle with t in (tmin, tmax).
 *
 * Recording (tv->rec != NULL), in program order: one read of the node
 * record per node visited (32, 128 or 80 bytes; a wide node, holding its
 * children's boxes, is read once), one 36-byte read of bvh.tri per
 * triangle tested. tv->nodes and tv->tests count the same events whether
 * or not recording is on.
 */
#ifndef RT_BVH_H
#define RT_BVH_H

#include "isect.h"
#include "kdtrav.h" /* rt_hit, RT_NO_HIT, rt_hit_none */
#include "memmodel.h"
#include "rt.h"
#include "scene.h"

#include <math.h>
#include <stdint.h>

/* Deepest node the builder makes (root = depth 0): SAH splits down to
 * depth RT_BVH_SAH_DEPTH, halving by count below it, so leaves never lie
 * deeper than 63 and the traversal stacks below cannot overflow. */
#define RT_BVH_SAH_DEPTH 32
#define RT_BVH_MAX_DEPTH 63
#define RT_BVH_MAX_LEAF 16   /* largest leaf size accepted (bvh8: 4) */
#define RT_BVH_MAX_TRIS 0x7fffffffu
#define RT_BVH_BINS 32       /* SAH bins per axis */

/* pbrt's LinearBVHNode, 32 bytes. */
typedef struct rt_bvh2_node {
    float lo[3], hi[3]; /* the node's box */
    uint32_t offset;    /* interior: index of the second child; leaf: first triangle */
    uint16_t ntri;      /* triangles of a leaf; 0 for an interior node */
    uint8_t axis;       /* interior: split axis (0..2), the visiting order's key */
    uint8_t pad;        /* zero */
} rt_bvh2_node;
_Static_assert(sizeof(rt_bvh2_node) == 32, "bvh2 node must be 32 bytes");

/* A 4-wide node, 128 bytes: boxes as a structure of arrays, lane = slot. */
typedef struct rt_bvh4_node {
    float lo[3][4];     /* lo[axis][slot] */
    float hi[3][4];     /* hi[axis][slot] */
    uint64_t child[4];  /* child references (below) */
} rt_bvh4_node;
_Static_assert(sizeof(rt_bvh4_node) == 128, "bvh4 node must be 128 bytes");

/* bvh4 child reference: an interior child is its node index (bit 63
 * clear); a leaf has bit 63 set, its triangle count in bits 32..62 and its
 * first triangle in bits 0..31; an empty slot is RT_BVH4_EMPTY (a leaf of
 * no triangles) and has the empty box lo = +inf, hi = -inf. */
#define RT_BVH4_LEAF (1ull << 63)
#define RT_BVH4_EMPTY RT_BVH4_LEAF
static inline int rt_bvh4_is_leaf(uint64_t c) { return (c & RT_BVH4_LEAF) != 0; }
static inline uint32_t rt_bvh4_first(uint64_t c) { return (uint32_t)c; }
static inline uint32_t rt_bvh4_count(uint64_t c) { return (uint32_t)(c >> 32) & 0x7fffffffu; }

/*
 * A compressed 8-wide node, 80 bytes. Slot s's box on axis a is
 *   [origin[a] + qlo[a][s] * 2^(e[a] - 127), origin[a] + qhi[a][s] * 2^(e[a] - 127)]
 * evaluated in float (the product is exact, the sum rounds once), which
 * contains the slot's exact box (rt_bvh8_dequant). meta[s]: 0 for an empty
 * slot; an interior child (imask bit s set) has 0x20 | (24 + rank), its
 * node index being child_base + rank, rank = interior slots before s; a
 * leaf has its triangle count (1..7) in the top three bits and its first
 * triangle's offset from tri_base (0..31) in the low five.
 */
typedef struct rt_bvh8_node {
    float origin[3];    /* grid origin: the node's exact box lo */
    uint8_t e[3];       /* biased exponents: scale = 2^(e - 127), 1..254 */
    uint8_t imask;      /* bit s: slot s is an interior node */
    uint32_t child_base;/* index of the first interior child */
    uint32_t tri_base;  /* first triangle of the first leaf child */
    uint8_t meta[8];    /* per slot, above */
    uint8_t qlo[3][8];  /* quantized lower planes [axis][slot] */
    uint8_t qhi[3][8];  /* quantized upper planes */
} rt_bvh8_node;
_Static_assert(sizeof(rt_bvh8_node) == 80, "bvh8 node must be 80 bytes");

/* The host-side copy of a bvh8 node (not modeled, never recorded): its
 * dequantized boxes, structure of arrays, and decoded references. */
typedef struct rt_bvh8_host {
    float lo[3][8], hi[3][8]; /* dequantized; empty slot: +inf / -inf */
    uint32_t ref[8];          /* interior: node index; leaf: first triangle */
    uint32_t cnt[8];          /* leaf: triangles; interior: 0; empty: RT_BVH8_NONE */
} rt_bvh8_host;
#define RT_BVH8_NONE 0xffffffffu

/* The float value of quantized plane q on a node's grid along axis a. */
static inline float rt_bvh8_dequant(const rt_bvh8_node *n, int a, unsigned q)
{
    union {
        uint32_t u;
        float f;
    } s;
    s.u = (uint32_t)n->e[a] << 23;
    return n->origin[a] + (float)q * s.f;
}

/* The slots set in mask (at most 8), ordered by key[slot] ascending, ties
 * by the lower slot, into ord; returns how many. The visit order of a
 * wide node's hit children (nearest entry first). */
static inline int rt_bvh_order_slots(unsigned mask, const float *key, int ord[8])
{
    int k = 0;
    for (; mask; mask &= mask - 1) {
        const int s = __builtin_ctz(mask);
        int j = k++;
        while (j > 0 && key[ord[j - 1]] > key[s]) {
            ord[j] = ord[j - 1];
            j--;
        }
        ord[j] = s;
    }
    return k;
}

/* Child s of wide node `node` (width 4 or 8): 1 and its reference (*ra:
 * the child node, or a leaf's first triangle record) and triangle count
 * (*rn: 0 for an interior child), or 0 for an empty slot. */
static inline int rt_bvh_wide_child(int W, const rt_bvh4_node *n4, const rt_bvh8_host *h8, uint32_t node, int s,
                                    uint32_t *ra, uint32_t *rn)
{
    if (W == 4) {
        const uint64_t c = n4[node].child[s];
        if (c == RT_BVH4_EMPTY) return 0;
        *ra = (uint32_t)c;
        *rn = rt_bvh4_is_leaf(c) ? rt_bvh4_count(c) : 0;
        return 1;
    }
    *ra = h8[node].ref[s];
    *rn = h8[node].cnt[s];
    return *rn != RT_BVH8_NONE;
}

typedef struct rt_bvh_params {
    int width;        /* 2, 4 or 8 */
    int max_leaf;     /* most triangles per leaf: 1..RT_BVH_MAX_LEAF (bvh8: 1..4); default 4 */
    float trav_cost;  /* SAH cost of visiting a node: 1 */
    float isect_cost; /* SAH cost of one triangle test: 1 */
    int share_tris;   /* 1: no copy of the triangles in leaf order, leaves read the scene's through orig;
                         0: the copy; -1 (default): shared from RT_BVH_SHARE_MIN triangles on */
} rt_bvh_params;

/* Scenes of this many triangles or more share the scene's triangle array
 * by default (36 bytes per triangle less, one indirection per test). */
#define RT_BVH_SHARE_MIN (1u << 20)

/* Defaults for a width (2, 4 or 8). */
void rt_bvh_default_params(rt_bvh_params *p, int width);

typedef struct rt_bvh {
    int width;              /* 2, 4 or 8 */
    int max_leaf;           /* leaf size limit it was built with */
    uint32_t nnodes;        /* nodes of the width's array (0: empty scene) */
    rt_bvh2_node *n2;       /* width 2: nnodes nodes, root first */
    rt_bvh4_node *n4;       /* width 4 */
    rt_bvh8_node *n8;       /* width 8: the modeled nodes */
    rt_bvh8_host *h8;       /* width 8: the host copy, one per node */
    uint32_t ntri;          /* triangles (the scene's) */
    rt_tri *tri;            /* triangles in leaf order; NULL when shared (rt_bvh_params.share_tris):
                               record i is then stri[orig[i]] (rt_bvh_tri) */
    const rt_tri *stri;     /* the scene's triangles (not owned; the scene outlives the tree) */
    uint32_t *orig;         /* orig[i]: scene index of record i */
    uint32_t *degen;        /* bit i: tri[i] is degenerate (rt_isect_degenerate), so it never
                               hits: tested once at build, not on every hit (host only, not modeled) */
    rt_bounds bounds;       /* of all triangles (the root's box) */
    /* statistics (rt_bvh_check recomputes them) */
    uint32_t nleaves;       /* leaves */
    uint32_t depth;         /* deepest leaf, root node = depth 0 */
    double sah;             /* SAH cost of the tree (bvh.c) */
    float trav_cost;        /* the SAH costs it was built with */
    float isect_cost;
    double build_sec;       /* wall time of rt_bvh_build */
    float pad;              /* every box is its triangles' boxes grown by pad on each side (bvh.c, B8) */
    int fast_avx;           /* 1: the unrecorded bvh8 walk tests a node's eight boxes in one AVX
                               vector (set by the build when the processor has AVX and the build
                               made the AVX copy; clearing it selects the SSE2 walk, with the
                               same results) */
} rt_bvh;

/* Triangle record i (leaf order): the copy, or the scene's triangle. */
static inline const rt_tri *rt_bvh_tri(const rt_bvh *b, uint32_t i) { return b->tri ? &b->tri[i] : &b->stri[b->orig[i]]; }

/* 1 when record i (leaf order) is a degenerate triangle, from a tree's
 * degen bits. */
static inline int rt_bvh_degenerate(const uint32_t *degen, uint32_t i) { return (int)(degen[i >> 5] >> (i & 31)) & 1; }

/* 1 when this build has the AVX copy of the bvh8 walk and the processor
 * runs it (the value rt_bvh_build stores in fast_avx for width 8). */
int rt_bvh_avx_usable(void);

/* Builds a tree of p->width over all triangles of s (p NULL: width 4
 * defaults). NULL with e set on failure: bad parameters, more than
 * RT_BVH_MAX_TRIS triangles, out of memory. */
rt_bvh *rt_bvh_build(const rt_scene *s, const rt_bvh_params *p, rt_err *e);
/* Frees a tree; accepts NULL. */
void rt_bvh_free(rt_bvh *b);
/* Verifies the invariants (bvh.c, B1-B7) against the scene; 0, or -1 with
 * the first violation described. For tests: O(nodes + triangles). */
int rt_bvh_check(const rt_bvh *b, const rt_scene *s, rt_err *e);

/* Bytes of one modeled node of a width (32, 128, 80), 0 for other widths. */
uint32_t rt_bvh_node_size(int width);
/* Name of a width's node region: "bvh2.node", "bvh4.node", "bvh8.node". */
const char *rt_bvh_node_region(int width);

typedef struct rt_bvh_stat {
    int width;        /* 2, 4, 8 */
    uint32_t nodes;   /* modeled nodes */
    uint32_t leaves;  /* leaves */
    uint32_t depth;   /* deepest leaf */
    uint64_t bytes;   /* modeled bytes: nodes x node size + triangles x 36 */
    double build_sec; /* wall time of the build */
    double sah;       /* SAH cost */
} rt_bvh_stat;
void rt_bvh_stats(const rt_bvh *b, rt_bvh_stat *st);

/*
 * Declares the tree's regions in L, in this order: the width's node region
 * (rt_bvh_node_region, class node, rt_bvh_node_size bytes x nodes) and
 * "bvh.tri" (class tri, 36 B x triangles, leaf order). Stores their indices
 * in *reg_node and *reg_tri (either may be NULL). 0, or -1 when the layout
 * is full or already has such a region.
 */
int rt_bvh_layout(const rt_bvh *b, rt_layout *L, int *reg_node, int *reg_tri, rt_err *e);

/* Traversal state for one tree of one scene: the acceleration layer's
 * rt_trav (hit.h), so its walks call these with no copy. Read here: bvh,
 * sc, rec, L, reg_node, reg_tri (region indices in L), the running counts
 * nodes and tests, and mark / mark_bit (optional per scene triangle:
 * mark[tri] |= mark_bit on every test). */
typedef rt_trav rt_bvh_trav;

/* Zeroes tv and sets its tree, scene and recorder; with L non-NULL the
 * regions are looked up by name (rt_bvh_layout's names). */
void rt_bvh_trav_init(rt_bvh_trav *tv, const rt_bvh *b, const rt_scene *sc, rt_rec *rec, const rt_layout *L);

/* Closest hit in (r->tmin, r->tmax): returns 1 and fills *h (tri = scene
 * index); on a miss returns 0 with rt_hit_none(h). */
int rt_bvh_closest(rt_bvh_trav *tv, const rt_ray *r, rt_hit *h);
/* Any hit in (r->tmin, r->tmax) (shadow rays): 1 if occluded. */
int rt_bvh_occluded(rt_bvh_trav *tv, const rt_ray *r);

/*
 * The scalar reference walk: the same visit order, counts, marks and
 * recorded stream as rt_bvh_closest / rt_bvh_occluded (any = 1), with
 * every box tested one lane at a time. The fast path (SSE2) must equal it
 * exactly; tests compare them.
 */
int rt_bvh_plain(rt_bvh_trav *tv, const rt_ray *r, rt_hit *h, int any);


/*
 * One node at a time, for tracers that walk the tree themselves (the
 * treelet scheduler suspends a walk between nodes). rt_bvh_step does what
 * rt_bvh_closest does at one visited node, with the same box arithmetic,
 * and neither records nor counts: the caller records the node read at
 * rt_mm_addr(L, reg_node, node) and counts the visit.
 *
 *   bvh2: the node's own box is tested under cull; a miss returns 0; a hit
 *         leaf returns its triangle range as out[0] (n > 0), to be tested
 *         at once; a hit interior node returns its two children in push
 *         order, out[0] the far one, out[1] the one visited next (t =
 *         -inf: the binary walk culls no popped entry).
 *   bvh4, bvh8: the children's boxes are tested under cull; the hit ones
 *         are returned in push order (farthest entry first, ties: the
 *         higher slot first), interior children with n = 0, leaves with
 *         their range; a walk pops an entry, skips it when its t exceeds
 *         the current cull bound, tests a leaf's triangles, visits a node.
 * Returns the number of entries in out (0..8).
 */
typedef struct rt_bvh_wray {
    float o[3], inv[3]; /* origin, 1/d */
    int neg[3];         /* 1/d negative: the near plane is hi */
    float tmin;         /* the ray's tmin */
    int nofs[3], fofs[3]; /* wide trees: per axis the float offsets of the near and far box rows */
} rt_bvh_wray;

typedef struct rt_bvh_ref {
    uint32_t a; /* interior: node index; leaf: first triangle record */
    uint32_t n; /* leaf: triangles; interior: 0 */
    float t;    /* entry distance (bvh2 interior children: -inf) */
} rt_bvh_ref;

/* The slab form of r for rt_bvh_step on trees of width `width` (computed
 * once per ray, or once per stretch of steps, not per node). */
void rt_bvh_wray_init(rt_bvh_wray *w, const rt_ray *r, int width);
/* The visit bound of a best hit at x: x + |x| 2^-16 (the walk's margin). */
static inline float rt_bvh_cull_bound(float x) { return x + fabsf(x) * (1.0f / 65536.0f); }
int rt_bvh_step(const rt_bvh *b, const rt_bvh_wray *w, uint32_t node, float cull, rt_bvh_ref out[8]);

#endif
