/*
 * recursive.c -- the baseline: single rays, one pixel at a time in
 * Hilbert-curve order (Whitted-style, depth first).
 *
 * For each pixel: read its 32-byte primary ray record, find the closest
 * hit, read the hit triangle's shading record, trace one shadow ray per
 * enabled light from the hit point toward the light (in registers: shadow
 * rays are never stored), shade, and write the pixel. All of a pixel's rays
 * finish before the next pixel starts, which is what keeps ray traffic
 * minimal and lets geometry thrash when the cache is small.
 */
#include "camera.h"
#include "regions.h"
#include "shade.h"
#include "stats.h"
#include "tracer.h"

#include <math.h>
#include <stdlib.h>

static int rec_layout(const rt_tracer_ctx *ctx, rt_layout *L, rt_err *e)
{
    size_t npix = (size_t)ctx->opt->W * (size_t)ctx->opt->H;
    if (rt_reg_geometry(ctx, L, 1, e) < 0) return -1;
    if (rt_mm_add(L, "rays.primary", RT_CLS_RAY, 32, npix, e) < 0) return -1;
    if (rt_mm_add(L, "fb", RT_CLS_FB, 12, npix, e) < 0) return -1;
    return 0;
}

static int rec_run(const rt_tracer_ctx *ctx, rt_image *img, rt_run_stats *st, rt_err *e)
{
    const rt_scene *sc = ctx->sc;
    const rt_render_opts *o = ctx->opt;
    const int W = o->W, H = o->H;
    rt_rec *rec = ctx->rec;
    const rt_layout *L = ctx->L;
    int reg_ray = rt_mm_find(L, "rays.primary"), reg_fb = rt_mm_find(L, "fb"), reg_shade = rt_mm_find(L, "tri.shade");
    uint32_t *order = rt_calloc((size_t)W * H, sizeof *order, e);
    uint8_t *mark = rt_calloc(sc->ntri ? sc->ntri : 1, 1, e);
    if (!order || !mark) {
        free(order);
        free(mark);
        return -1;
    }
    size_t npix = rt_pixel_order(o, order);
    rt_cam_frame cam;
    rt_cam_setup(&cam, sc, W, H);
    rt_trav tv;
    rt_reg_trav(&tv, ctx);
    tv.mark = mark;

    for (size_t k = 0; k < npix; k++) {
        uint32_t pix = order[k];
        int x = (int)(pix % (uint32_t)W), y = (int)(pix / (uint32_t)W);
        uint64_t n0 = tv.nodes, t0 = tv.tests;
        rt_ray ray;
        rt_hit h;
        RT_REC(rec, rt_mm_addr(L, reg_ray, pix), 32, 0, RT_CLS_RAY);
        rt_cam_ray(&cam, x, y, &ray);
        tv.mark_bit = 1;
        st->rays_primary++;
        if (rt_kd_closest(&tv, &ray, &h)) {
            int vis[RT_NLIGHTS] = {0};
            RT_REC(rec, rt_mm_addr(L, reg_shade, h.tri), 16, 0, RT_CLS_SHADE);
            tv.mark_bit = 2;
            for (int i = 0; i < RT_NLIGHTS; i++) {
                rt_ray sr;
                if (!(o->lights & (1u << i)) || !rt_shade_ray(sc, &ray, &h, i, &sr)) continue;
                st->rays_shadow++;
                vis[i] = !rt_kd_occluded(&tv, &sr);
            }
            rt_shade_pixel(sc, &ray, &h, vis, o->lights, img, pix);
        } else {
            rt_shade_pixel(sc, &ray, NULL, NULL, o->lights, img, pix);
        }
        img->nodes[pix] = (float)(tv.nodes - n0);
        img->tests[pix] = (float)(tv.tests - t0);
        RT_REC(rec, rt_mm_addr(L, reg_fb, pix), 12, 1, RT_CLS_FB);
    }
    rt_stats_finish(st, &tv, mark, sc->ntri);
    free(order);
    free(mark);
    return 0;
}

const rt_tracer rt_tracer_recursive = {
    .name = "recursive",
    .desc = "single rays in Hilbert-curve order, shadow rays depth first (Whitted)",
    .layout = rec_layout,
    .run = rec_run,
};
