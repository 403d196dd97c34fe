/*
 * pbrtlayout.h -- the pbrt-v1 object layout (prefix rt_pbrt_): what the
 * first edition of pbrt's k-d tree traversal (KdTreeAccel::Intersect,
 * accelerators/kdtree.cpp) reads and writes per node and per tested
 * triangle, object by object, on a machine with 4-byte pointers
 * (`--layout pbrt`, the paper's 2007 machine) or 8-byte pointers
 * (`--layout pbrt64`).
 *
 * The objects, in the order a test touches them (docs/memory-model.md,
 * "The pbrt layout", gives each size and the line of pbrt's code it comes
 * from):
 *   - the node (8 bytes, as in every layout); a leaf holding one primitive
 *     keeps the MailboxPrim pointer in the node itself, a leaf holding n > 1
 *     points to an array of n MailboxPrim pointers allocated from a
 *     MemoryArena (each allocation rounded up to 8 bytes, 32 KiB blocks, in
 *     leaf creation order = node order): region pbrt.plist;
 *   - the MailboxPrim (primitive reference + lastMailboxId), one array in
 *     FullyRefine's order, which pops from the back of its todo list, so
 *     triangle t's mailbox is entry ntri-1-t: region pbrt.mbox. Read on
 *     every test; when lastMailboxId differs from the walk's id it is
 *     written (the line becomes dirty) and the test goes on, otherwise the
 *     test ends after that 4-byte read;
 *   - the GeometricPrimitive (vtable, reference count, shape, material,
 *     area light), one `new` each in triangle order: region pbrt.prim, one
 *     malloc chunk per record (glibc: the request plus one size word,
 *     rounded up to 8 bytes, 16 with 8-byte pointers); a test reads its
 *     vtable pointer and shape;
 *   - the Triangle (Shape's vtable, count, two Transforms of two matrix
 *     references, two flags; mesh reference, vertex-index pointer), one
 *     `new` each in triangle order: region pbrt.shape, chunks as above; a
 *     test reads the vtable pointer, then mesh and v;
 *   - the TriangleMesh (one object): a test reads its point-array pointer p;
 *     region pbrt.mesh;
 *   - the three vertex indices (tri.vidx, 12 bytes) and the three positions
 *     (mesh.pos, 12 bytes each), as in the mesh layout (mesh.h).
 * Virtual tables (two shared read-only lines), statistics counters, the
 * stack and what only a hit touches (Triangle::Intersect's uv and
 * WorldToObject reads) are not modeled.
 *
 * How the tracers' stream becomes that: the tracers record exactly what
 * they record in the compact layout, into a translating recorder
 * (rt_pbrt_rec_new, installed by rt_job_run) that expands, in program
 * order,
 *   - a kd.index read of leaf entries [e, e+k) into the read of those
 *     entries' pointers in pbrt.plist, or into nothing when the entries
 *     belong to a one-primitive leaf (its pointer is in the node);
 *   - a triangle read (36 bytes at record t of tri.vidx) that follows a
 *     kd.index read with only triangle reads in between and names one of
 *     that read's entries after the last one tested (every tracer tests a
 *     leaf's entries in list order, each once) -- a test -- into the
 *     mailbox check and, unless the mailbox skips it, the write of the
 *     mailbox and the reads above; any other triangle read (the dynamic
 *     tracer computing a hit found in an earlier visit) into the
 *     Triangle's vtable pointer, mesh and v, the mesh's p, the indices and
 *     positions;
 *   - a shading read (16 bytes at record t of tri.shade) into the
 *     GeometricPrimitive (GetBSDF: shape, material), the Triangle's
 *     vtable, mesh and v, the mesh's normal pointers, the indices, the
 *     three normals (mesh.normal), then the shading record itself.
 * Mailbox ids: pbrt takes a new id per KdTreeAccel::Intersect call. The
 * recorder sees no call boundaries, so it takes a new id where a walk
 * starts: every read of the root node (kd.nodes record 0: a ray's or a
 * packet's walk from the root) and every read of a queue record (class
 * queue: the dynamic tracer resumes one ray's walk in a subtree). Within a
 * dynamic tracer's oversized leaf, rays of a batch share the last id.
 * Everything else passes through unchanged, generation included.
 */
#ifndef RT_PBRTLAYOUT_H
#define RT_PBRTLAYOUT_H

#include "kdtree.h"
#include "memmodel.h"
#include "mesh.h"

/* Sizes and field offsets of pbrt-v1's objects for one pointer width. */
typedef struct rt_pbrt_sizes {
    uint32_t ptr;          /* pointer (and Reference<T>) bytes: 4 or 8 */
    uint32_t mbox;         /* sizeof(MailboxPrim) */
    uint32_t mbox_id;      /* offset of lastMailboxId */
    uint32_t prim;         /* sizeof(GeometricPrimitive) */
    uint32_t prim_chunk;   /* its malloc chunk (record of pbrt.prim) */
    uint32_t prim_read;    /* bytes a test reads from its start: vtable pointer .. shape */
    uint32_t shape;        /* sizeof(Triangle) */
    uint32_t shape_chunk;  /* its malloc chunk (record of pbrt.shape) */
    uint32_t shape_mesh;   /* offset of Triangle::mesh (v follows it) */
    uint32_t mesh;         /* sizeof(TriangleMesh) */
    uint32_t mesh_p;       /* offset of TriangleMesh::p (n and s follow it) */
    uint32_t arena_block;  /* MemoryArena block size (32768) */
} rt_pbrt_sizes;

/* The sizes for geom (RT_GEOM_PBRT: 4-byte pointers, RT_GEOM_PBRT64: 8). */
void rt_pbrt_sizes_get(int geom, rt_pbrt_sizes *z);

/* Bytes of the MemoryArena blocks holding the leaves' pointer lists of kd
 * (leaves with more than one entry, in node order). */
uint64_t rt_pbrt_plist_bytes(const rt_kdtree *kd, int geom);

/* Adds the pbrt regions after tri.vidx and mesh.pos, in this order:
 * pbrt.plist (index, 8 B x arena granules), pbrt.mbox (tri, sizeof
 * MailboxPrim x ntri), pbrt.prim (tri, chunk x ntri), pbrt.shape (tri,
 * chunk x ntri), pbrt.mesh (tri, sizeof TriangleMesh x 1). 0 or -1. */
int rt_pbrt_regions(rt_layout *L, const rt_kdtree *kd, uint32_t ntri, int geom, rt_err *e);

/* The translating recorder for a run in the pbrt layout geom over L (which
 * must hold the mesh regions of mesh.h and the pbrt regions above), the
 * mesh's vertex index m and the run's k-d tree kd: accesses recorded into
 * it reach out expanded as described above. Flush it (rt_rec_flush) before
 * out; free with rt_pbrt_rec_free. NULL on out of memory or when L lacks a
 * region (message in e). */
rt_rec *rt_pbrt_rec_new(const rt_mesh *m, const rt_kdtree *kd, const rt_layout *L, int geom, rt_rec *out, rt_err *e);
/* Tests seen (triangle reads taken as tests) and how many of them the
 * mailbox skipped, so far. */
void rt_pbrt_rec_counts(const rt_rec *r, uint64_t *tests, uint64_t *skips);
/* Frees the recorder and its sink; accepts NULL. */
void rt_pbrt_rec_free(rt_rec *r);

#endif
