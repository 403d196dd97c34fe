/*
 * kdtree.h -- SAH k-d tree with 8-byte nodes, in the manner of pbrt.
 *
 * Node encoding (two 32-bit words, 8 bytes, the modeled record):
 *   interior: w0 = bit pattern of the float split position;
 *             w1 = (above_child << 2) | axis, axis in {0,1,2};
 *             the below child is the next node in the array (index + 1).
 *   leaf:     w0 = offset of the leaf's first entry in the index list;
 *             w1 = (ntri << 2) | 3.
 * Invariants (checked by rt_kd_check):
 *   - node 0 is the root; every interior node i has below = i + 1 and
 *     i + 1 < above < nnodes; every node is reachable exactly once;
 *   - leaf index ranges lie inside idx[0..nidx) and every entry < ntri;
 *   - every triangle whose bounds overlap a leaf's cell (clipped to the
 *     scene bounds) appears in that leaf, so traversal never misses a hit
 *     (a box that only touches a split plane goes to its own side, a box
 *     lying flat in the plane to at least one side: kdtree.c, I4);
 *   - leaf lists are strictly ascending, each idx entry in exactly one leaf;
 *   - depth <= max_depth.
 * Build: SAH with intersection cost 80, traversal cost 1, empty bonus 0.5,
 * max depth round(8 + 1.3 log2 N) with pbrt's integer (floor) log2,
 * capped at RT_KD_DEPTH_CAP; split candidates at triangle bounding-box
 * edges (exact sweep over edges presorted once, O(N log N) overall).
 * The essay at the top of kdtree.c details representation and invariants.
 *
 * Host-side copy (not modeled, never recorded): hnodes and quads repeat the
 * tree in a form the traversal reads faster. hnodes[i] equals nodes[i]
 * except that a leaf's w0 is the index of its first quad; a leaf of n
 * triangles owns ceil(n / 4) consecutive quads (leaf order, no sharing),
 * each holding 4 triangles' vertices component-major (p[3 * vertex + axis]
 * [lane]) so four ray/triangle tests run as one SSE2 computation. Lane j
 * of the leaf's quads is entry j of its index list: tri[] holds idx[first
 * + j] with RT_KD_QUAD_DEGEN set when rt_isect_degenerate holds (such a
 * triangle never hits); padding lanes hold RT_KD_QUAD_PAD and zero
 * vertices. The copy is built with the tree, reflects the scene's
 * triangles at build time, and is verified by rt_kd_check. It costs 160
 * bytes per four entries of a leaf (268 MB for the 797,150-triangle
 * sphereflake), so it is skipped above RT_KD_HOST_MAX bytes or when memory
 * runs out; a tree without it (hnodes == NULL, also one assembled by hand)
 * is traversed by the plain path, which gives the same results.
 */
#ifndef RT_KDTREE_H
#define RT_KDTREE_H

#include "rt.h"
#include "rt_math.h"
#include "scene.h"

#include <stdint.h>
#include <string.h>

typedef struct rt_kdnode {
    uint32_t w0; /* split float bits, or first index-list entry (leaf) */
    uint32_t w1; /* (above << 2) | axis, or (ntri << 2) | 3 (leaf) */
} rt_kdnode;

static inline int rt_kd_is_leaf(const rt_kdnode *n) { return (n->w1 & 3u) == 3u; }
static inline int rt_kd_axis(const rt_kdnode *n) { return (int)(n->w1 & 3u); }
static inline uint32_t rt_kd_above(const rt_kdnode *n) { return n->w1 >> 2; }
static inline uint32_t rt_kd_ntri(const rt_kdnode *n) { return n->w1 >> 2; }
static inline uint32_t rt_kd_first(const rt_kdnode *n) { return n->w0; }
static inline float rt_kd_split(const rt_kdnode *n)
{
    float f;
    memcpy(&f, &n->w0, sizeof f);
    return f;
}

/* Hard cap on the depth limit: a traversal pushes at most one stack entry
 * per level, so trees never outgrow kdtrav.h's RT_KD_STACK (64). */
#define RT_KD_DEPTH_CAP 60

/* Four triangles of one leaf, component-major (see the top). 160 bytes. */
typedef struct rt_kd_quad {
    float p[9][4];   /* p[3 * vertex + axis][lane] */
    uint32_t tri[4]; /* triangle index, | RT_KD_QUAD_DEGEN; padding RT_KD_QUAD_PAD */
} rt_kd_quad;

#define RT_KD_QUAD_DEGEN 0x80000000u /* the triangle never hits (zero area) */
#define RT_KD_HOST_MAX (2ull << 30)  /* largest host copy built (bytes) */
#define RT_KD_QUAD_PAD 0xffffffffu   /* a lane past the leaf's last entry */

typedef struct rt_kd_params {
    float isect_cost;  /* 80 */
    float trav_cost;   /* 1 */
    float empty_bonus; /* 0.5 */
    int max_depth;     /* <= 0: round(8 + 1.3 log2 N) */
    int max_leaf_tris; /* make a leaf at or below this many triangles (1) */
} rt_kd_params;

void rt_kd_default_params(rt_kd_params *p);

typedef struct rt_kdtree {
    rt_kdnode *nodes;     /* nnodes nodes, root first */
    uint32_t nnodes;
    uint32_t *idx;        /* leaf triangle-index lists, concatenated */
    uint32_t nidx;
    rt_bounds bounds;     /* scene bounds the tree was built in */
    /* statistics */
    uint32_t nleaves;     /* leaves, including empty ones */
    uint32_t nempty;      /* empty leaves */
    uint32_t maxdepth;    /* deepest leaf (root = depth 0) */
    uint32_t maxleaf;     /* most triangles in one leaf */
    double build_sec;     /* wall time of rt_kd_build */
    uint32_t max_depth;   /* depth limit the tree was built with */
    /* host-side copy for fast traversal (see the top; NULL: none) */
    rt_kdnode *hnodes;    /* nodes[] with leaf w0 = first quad */
    rt_kd_quad *quads;    /* leaves' triangles, 4 per quad */
    uint32_t nquads;
} rt_kdtree;

/* Builds the tree over all triangles of s. NULL on failure (out of memory). */
rt_kdtree *rt_kd_build(const rt_scene *s, const rt_kd_params *p, rt_err *e);
void rt_kd_free(rt_kdtree *t);
/* Verifies the invariants above; 0 if all hold, else -1 with the first
 * violation described. Intended for tests (it is O(N * depth)). */
int rt_kd_check(const rt_kdtree *t, const rt_scene *s, rt_err *e);
/* Mean triangles per non-empty leaf. */
double rt_kd_mean_leaf_tris(const rt_kdtree *t);

/* Size of the subtree rooted at a node (for queue-point selection). */
typedef struct rt_kd_subsize {
    uint32_t nodes; /* nodes in the subtree, itself included */
    uint32_t nidx;  /* index-list entries in its leaves (with repeats) */
    uint32_t ntri;  /* distinct triangles referenced by its leaves */
} rt_kd_subsize;

/* Fills out[0..nnodes) for every node; ntri is the scene's triangle count.
 * Returns 0, or -1 (out of memory, or an index >= ntri). O(refs * depth). */
int rt_kd_subtree_sizes(const rt_kdtree *t, uint32_t ntri, rt_kd_subsize *out, rt_err *e);

/* Modeled geometry bytes of a subtree: nodes, index entries, triangles. */
static inline uint64_t rt_kd_subsize_bytes(const rt_kd_subsize *z)
{
    return 8ull * z->nodes + 4ull * z->nidx + 36ull * z->ntri;
}

#endif
