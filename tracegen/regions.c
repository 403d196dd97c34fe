/* regions.c -- geometry regions and the recording traversal context (see
 * regions.h). */
#include "regions.h"
#include "mesh.h"
#include "pbrtlayout.h"
#include "shade.h"

#include <string.h>

int rt_reg_geometry(const rt_tracer_ctx *ctx, rt_layout *L, int want_shade, rt_err *e)
{
    if (rt_accel_regions(ctx->acc, ctx->sc, L, e) < 0) return -1;
    const int own = (ctx->acc->ops->flags & RT_ACCEL_OWN_TRIS) != 0; /* triangles in the structure's order */
    if (rt_geom_uses_mesh(ctx->opt->geom)) {
        if (!ctx->mesh) return rt_errf(e, "mesh layout without a vertex index (internal error)");
        if (rt_geom_is_pbrt(ctx->opt->geom) && !ctx->kd)
            return rt_errf(e, "--layout %s without a k-d tree (internal error)", rt_render_geom_name(ctx->opt->geom));
        if (rt_mm_add(L, "tri.vidx", RT_CLS_TRI, RT_MESH_VIDX_SIZE, ctx->sc->ntri, e) < 0 ||
            rt_mm_add(L, "mesh.pos", RT_CLS_TRI, RT_MESH_POS_SIZE, ctx->mesh->nvert, e) < 0)
            return -1;
        if (rt_geom_is_pbrt(ctx->opt->geom) && rt_pbrt_regions(L, ctx->kd, ctx->sc->ntri, ctx->opt->geom, e) < 0)
            return -1;
        if (want_shade && (rt_mm_add(L, "tri.shade", RT_CLS_SHADE, 16, ctx->sc->ntri, e) < 0 ||
                           rt_mm_add(L, "mesh.normal", RT_CLS_SHADE, RT_MESH_NRM_SIZE, ctx->mesh->nvert, e) < 0))
            return -1;
    } else {
        if (!own && rt_mm_add(L, "tri.verts", RT_CLS_TRI, 36, ctx->sc->ntri, e) < 0) return -1;
        /* instancing (--instances bvh): the loose triangles' records, then
         * each object's once (rt_scene_model_slot), kept or flattened alike */
        if (want_shade && rt_mm_add(L, "tri.shade", RT_CLS_SHADE, 16,
                                    rt_scene_model_nslot(ctx->sc, ctx->acc->kind == RT_ACCEL_INST), e) < 0)
            return -1;
    }
    if (want_shade && rt_reg_wants_mat(ctx) &&
        rt_mm_add(L, "mat", RT_CLS_SHADE, RT_MAT_RECSIZE, ctx->sc->nmat, e) < 0)
        return -1;
    if (rt_reg_wants_lights(ctx)) {
        uint64_t ncdf = 0;
        for (uint32_t i = 0; i < ctx->sc->nlight; i++)
            if (ctx->sc->lights[i].kind == RT_LIGHT_MESH) ncdf += ctx->sc->lights[i].count;
        if (rt_mm_add(L, "lights", RT_CLS_SHADE, RT_LIGHT_RECSIZE, ctx->sc->nlight, e) < 0) return -1;
        if (ncdf && rt_mm_add(L, "lights.cdf", RT_CLS_SHADE, 4, ncdf, e) < 0) return -1;
    }
    return rt_alpha_regions(L, ctx->sc->alpha, e);
}

int rt_reg_wants_lights(const rt_tracer_ctx *ctx)
{
    return rt_shade_authored(ctx->sc, ctx->opt) && ctx->opt->lights && rt_render_mode(ctx->opt) != RT_MODE_RAYCAST &&
           rt_scene_nonpoint_lights(ctx->sc);
}

void rt_reg_light(const rt_tracer_ctx *ctx, rt_rec *rec, uint32_t light, uint32_t tri)
{
    if (!rec) return;
    const rt_layout *L = ctx->L;
    int rl = rt_mm_find(L, "lights");
    if (rl < 0) return;
    RT_REC(rec, rt_mm_addr(L, rl, light), RT_LIGHT_RECSIZE, 0, RT_CLS_SHADE);
    if (tri == RT_NO_HIT) return;
    int rc = rt_mm_find(L, "lights.cdf"), rv = rt_mm_find(L, "tri.verts");
    uint64_t base = 0; /* the light's entries follow the earlier mesh lights' */
    for (uint32_t i = 0; i < light; i++)
        if (ctx->sc->lights[i].kind == RT_LIGHT_MESH) base += ctx->sc->lights[i].count;
    if (rc >= 0) RT_REC(rec, rt_mm_addr(L, rc, base + (tri - ctx->sc->lights[light].first)), 4, 0, RT_CLS_SHADE);
    if (rv >= 0) RT_REC(rec, rt_mm_addr(L, rv, tri), 36, 0, RT_CLS_TRI);
}

int rt_reg_wants_mat(const rt_tracer_ctx *ctx)
{
    return rt_render_secondary(ctx->opt) && rt_scene_material_flags(ctx->sc) != 0;
}

void rt_reg_shade(const rt_tracer_ctx *ctx, rt_rec *rec, uint32_t tri)
{
    if (!rec) return;
    const rt_layout *L = ctx->L;
    int rs = rt_mm_find(L, "tri.shade"), rm = rt_mm_find(L, "mat");
    RT_REC(rec, rt_mm_addr(L, rs, rt_scene_model_slot(ctx->sc, tri, ctx->acc->kind == RT_ACCEL_INST)), 16, 0,
           RT_CLS_SHADE);
    if (rm >= 0) RT_REC(rec, rt_mm_addr(L, rm, rt_scene_shade_of(ctx->sc, tri)->mat), RT_MAT_RECSIZE, 0, RT_CLS_SHADE);
}

void rt_reg_trav(rt_trav *tv, const rt_tracer_ctx *ctx)
{
    rt_accel_trav(ctx->acc, tv, ctx->sc, ctx->rec, ctx->L);
    if (ctx->acc->ops->flags & RT_ACCEL_OWN_TRIS) return; /* its own triangle region */
    /* the mesh and pbrt layouts' triangle reads land on the index records
     * and are expanded by their recorders (mesh.h, pbrtlayout.h) */
    tv->reg_tri = rt_mm_find(ctx->L, rt_geom_uses_mesh(ctx->opt->geom) ? "tri.vidx" : "tri.verts");
}
