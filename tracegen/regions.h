/*
 * regions.h -- the recorder glue every tracer shares (prefix rt_reg_): the
 * geometry regions of the memory model and a traversal context that
 * records into them.
 *
 * Every tracer on the same structure reads the same nodes and triangles,
 * so they are declared once here, first and in a fixed order, and get the
 * same modeled addresses in every run of a scene on that structure
 * (docs/memory-model.md).
 */
#ifndef RT_REGIONS_H
#define RT_REGIONS_H

#include "tracer.h"

/* Adds the geometry regions, in this order: the structure's own
 * (rt_accel_regions: kd.nodes 8 B x nodes and kd.index 4 B x entries for
 * the k-d tree; grid.cells and grid.lists for the grid; none for naive),
 * tri.verts (36 B x triangles) and, when
 * want_shade, tri.shade (16 B x triangles) and, when rt_reg_wants_mat, mat.
 * In the mesh layout (ctx->opt->geom, ctx->mesh) tri.verts is replaced by
 * tri.vidx (12 B x triangles) and mesh.pos (12 B x vertices), and
 * tri.shade is followed by mesh.normal (12 B x vertices). Last, for a
 * scene with alpha textures, alpha.tri and alpha.texel (rt_alpha_regions,
 * src/alpha.h). Look them up
 * with rt_mm_find. 0, or -1 when the layout is full. */
int rt_reg_geometry(const rt_tracer_ctx *ctx, rt_layout *L, int want_shade, rt_err *e);

/* 1 when the run reads material records: a secondary mode (whitted, path)
 * on a scene whose triangles use a non-diffuse material. Then
 * rt_reg_geometry adds the region mat (RT_MAT_RECSIZE B x materials,
 * class shade) right after tri.shade. */
int rt_reg_wants_mat(const rt_tracer_ctx *ctx);
/* Records the reads of one shaded hit on triangle tri: its 16-byte tri.shade
 * record and, when the region mat exists, its material record. */
void rt_reg_shade(const rt_tracer_ctx *ctx, rt_rec *rec, uint32_t tri);

/* 1 when the run samples authored lights other than points (--light-samples
 * on a scene with area, distant or infinite lights, shadow rays on). Then
 * rt_reg_geometry adds, after the shading regions, the region lights
 * (RT_LIGHT_RECSIZE B x authored lights, class shade) and, when a mesh
 * light exists, lights.cdf (4 B x emitting triangles, class shade). A
 * scene lit by point lights alone keeps its layout. */
int rt_reg_wants_lights(const rt_tracer_ctx *ctx);
/* Records the reads one light sample makes (only when the lights region
 * exists): the light's record and, for a mesh light (tri != RT_NO_HIT),
 * the cdf entry its search ends at and the sampled triangle's vertices
 * (tri.verts, when the run has that region). */
void rt_reg_light(const rt_tracer_ctx *ctx, rt_rec *rec, uint32_t light, uint32_t tri);

/* Initialises a traversal context for ctx: its tree, scene and recorder,
 * with the geometry regions looked up in ctx->L. */
void rt_reg_trav(rt_trav *tv, const rt_tracer_ctx *ctx);

#endif
