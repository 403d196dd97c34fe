/* regions.c -- geometry regions and the recording traversal context (see
 * regions.h). */
#include "regions.h"

#include <string.h>

int rt_reg_geometry(const rt_tracer_ctx *ctx, rt_layout *L, int want_shade, rt_err *e)
{
    const rt_kdtree *kd = ctx->kd;
    if (rt_mm_add(L, "kd.nodes", RT_CLS_NODE, 8, kd->nnodes, e) < 0) return -1;
    if (rt_mm_add(L, "kd.index", RT_CLS_INDEX, 4, kd->nidx, e) < 0) return -1;
    if (rt_mm_add(L, "tri.verts", RT_CLS_TRI, 36, ctx->sc->ntri, e) < 0) return -1;
    if (want_shade && rt_mm_add(L, "tri.shade", RT_CLS_SHADE, 16, ctx->sc->ntri, e) < 0) return -1;
    return 0;
}

void rt_reg_trav(rt_trav *tv, const rt_tracer_ctx *ctx)
{
    memset(tv, 0, sizeof *tv);
    tv->kd = ctx->kd;
    tv->sc = ctx->sc;
    tv->rec = ctx->rec;
    tv->L = ctx->L;
    tv->reg_node = rt_mm_find(ctx->L, "kd.nodes");
    tv->reg_idx = rt_mm_find(ctx->L, "kd.index");
    tv->reg_tri = rt_mm_find(ctx->L, "tri.verts");
}
