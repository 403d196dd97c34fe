/*
 * mesh.h -- the pbrt-style triangle-mesh geometry layout (prefix rt_mesh_):
 * an index of the scene's unique vertex positions, and the recorder that
 * turns the tracers' triangle and shading reads into the mesh's accesses.
 *
 * The scene holds triangles as three positions each. A pbrt mesh (the
 * layout of the k-d tree the paper measured) stores per triangle three
 * 4-byte vertex indices, and per unique vertex a 12-byte position and a
 * 12-byte normal in separate arrays. Vertices are shared by exact float
 * equality of positions (-0 equals +0; a NaN coordinate is never shared)
 * and numbered in order of first use (triangle order, then corner order),
 * so the index is a function of the scene alone.
 *
 * With --layout mesh the tracers record exactly what they record in the
 * compact layout; a translating recorder placed between them and the sink
 * (rt_mesh_rec_new, installed by rt_job_run) expands, in program order,
 *   - a triangle read (36 bytes at record t of tri.vidx, the tracers'
 *     triangle region) into the 12-byte index record t of tri.vidx and the
 *     three 12-byte positions it names in mesh.pos (pbrt's intersection
 *     test: indices, then p[v0], p[v1], p[v2]);
 *   - a shading read (16 bytes at record t of tri.shade) into the index
 *     record t, the three normals in mesh.normal, then the shading record
 *     itself (pbrt's shading geometry reads the indices and the normals).
 * Everything else passes through unchanged, generation included.
 */
#ifndef RT_MESH_H
#define RT_MESH_H

#include "memmodel.h"
#include "scene.h"

typedef struct rt_mesh {
    uint32_t ntri;   /* triangles of the scene */
    uint32_t nvert;  /* unique positions */
    uint32_t *vidx;  /* 3 x ntri vertex indices, corner k of triangle t at 3t + k */
} rt_mesh;

/* Builds the vertex index of sc. NULL on out of memory (message in e). */
rt_mesh *rt_mesh_build(const rt_scene *sc, rt_err *e);
/* Accepts NULL. */
void rt_mesh_free(rt_mesh *m);

/* Bytes per record of the mesh regions (docs/memory-model.md). */
#define RT_MESH_VIDX_SIZE 12 /* tri.vidx: three uint32 vertex indices */
#define RT_MESH_POS_SIZE 12  /* mesh.pos: three floats */
#define RT_MESH_NRM_SIZE 12  /* mesh.normal: three floats */

/* The translating recorder for a run in the mesh layout over L (which must
 * hold tri.vidx and mesh.pos; tri.shade and mesh.normal when shading is
 * recorded): accesses recorded into it reach out expanded as described
 * above. Flush it (rt_rec_flush) before out; free with rt_mesh_rec_free.
 * NULL on out of memory or when L lacks the mesh regions (message in e). */
rt_rec *rt_mesh_rec_new(const rt_mesh *m, const rt_layout *L, rt_rec *out, rt_err *e);
/* Frees the recorder and its sink; accepts NULL. */
void rt_mesh_rec_free(rt_rec *r);

#endif
