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
 *
 * With authored lights (--light-samples N) a hit traces every sample of
 * every enabled light in turn, depth first like the point lights
 * (rec_lights).
 *
 * Secondary modes (whitted, path): per pixel and sample, the rays of the
 * Whitted tree or the path are followed depth first from a small stack
 * (reflection before refraction); each hit reads its shading and material
 * records and traces its shadow rays at once. Secondary rays live in
 * registers like shadow rays, so they add no ray-record traffic here.
 */
#include "camera.h"
#include "regions.h"
#include "shade.h"
#include "stats.h"
#include "tracer.h"

#include <inttypes.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

static int rec_layout(const rt_tracer_ctx *ctx, rt_layout *L, rt_err *e)
{
    size_t npix = (size_t)ctx->opt->W * (size_t)ctx->opt->H;
    if (rt_reg_geometry(ctx, L, 1, e) < 0) return -1;
    if (rt_mm_add(L, "rays.primary", RT_CLS_RAY, 32, npix, e) < 0) return -1;
    if (rt_mm_add(L, "fb", RT_CLS_FB, 12, npix, e) < 0) return -1;
    return 0;
}

/* Whitted and path modes: depth first per pixel (see the top). */
static void rec_secondary(const rt_tracer_ctx *ctx, rt_trav *tv, const rt_cam_frame *cam, uint32_t pix,
                          rt_image *img, rt_run_stats *st, uint64_t *nsec, uint64_t *nself)
{
    const rt_scene *sc = ctx->sc;
    const rt_render_opts *o = ctx->opt;
    const int W = o->W, spp = o->mode == RT_MODE_PATH ? o->spp : 1;
    int x = (int)(pix % (uint32_t)W), y = (int)(pix / (uint32_t)W);
    int reg_ray = rt_mm_find(ctx->L, "rays.primary");
    rt_path stack[2 * RT_DEPTH_MAX + 4];
    rt_acc acc = {{0, 0, 0}};
    rt_ray eye;
    rt_hit h0;
    rt_shade_out out;
    h0.tri = RT_NO_HIT;
    rt_cam_ray(cam, x, y, &eye);
    for (int s = 0; s < spp; s++) {
        int sp = 0;
        rt_rec_set_gen(ctx->rec, 0);
        RT_REC(ctx->rec, rt_mm_addr(ctx->L, reg_ray, pix), 32, 0, RT_CLS_RAY);
        st->rays_primary++;
        rt_shade_path_start(&stack[sp++], &eye, pix, (uint32_t)s);
        while (sp) {
            rt_path p = stack[--sp];
            rt_ray r;
            rt_hit h;
            rt_shade_path_ray(&p, &r);
            rt_rec_set_gen(ctx->rec, p.depth); /* this ray, its shading and shadow rays */
            tv->mark_bit = p.depth ? 4 : 1;
            int hit = ctx->acc->ops->closest(tv, &r, &h);
            if (!p.depth && !s) h0 = h;
            if (p.depth) (*nsec)++;
            if (hit) rt_reg_shade(ctx, ctx->rec, h.tri);
            rt_shade_step(sc, o, &p, &r, hit ? &h : NULL, &out);
            *nself += (uint64_t)out.self_hit;
            rt_acc_add(&acc, out.c);
            tv->mark_bit = 2;
            for (int i = 0; i < RT_NLIGHTS; i++) {
                if (!out.want[i]) continue;
                st->rays_shadow++;
                if (!ctx->acc->ops->occluded(tv, &out.sray[i])) rt_acc_add(&acc, out.lc[i]);
            }
            for (int c = out.nchild; c-- > 0;) stack[sp++] = out.child[c];
        }
    }
    rt_acc_pixel(&acc, spp, &eye, h0.tri != RT_NO_HIT ? &h0 : NULL, img, pix);
    rt_rec_set_gen(ctx->rec, 0); /* the pixel write: the primary ray's */
}

/* Authored lights: every sample of every enabled light from the hit h, in
 * light then sample order; lw[i] gets the weights of the unoccluded ones. */
static void rec_lights(const rt_tracer_ctx *ctx, rt_trav *tv, const rt_ray *eye, const rt_hit *h, float *lw,
                       rt_run_stats *st)
{
    const rt_scene *sc = ctx->sc;
    for (uint32_t i = 0; i < sc->nlight; i++) {
        lw[i] = 0.0f;
        if (!rt_render_light_on(ctx->opt, i)) continue;
        for (uint32_t k = 0, n = rt_shade_light_nsamples(sc, ctx->opt, i); k < n; k++) {
            rt_ray sr;
            float w;
            uint32_t tri;
            if (!rt_shade_sample_ray(sc, ctx->opt, eye, h, i, k, &sr, &w, &tri)) continue;
            rt_reg_light(ctx, ctx->rec, i, tri);
            st->rays_shadow++;
            if (!ctx->acc->ops->occluded(tv, &sr)) lw[i] += w;
        }
    }
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
    const int inst = ctx->acc->kind == RT_ACCEL_INST; /* marks and shading reads per model slot */
    const uint32_t nmark = rt_scene_model_nslot(sc, inst);
    uint8_t *mark = rt_calloc(nmark ? nmark : 1, 1, e);
    if (!order || !mark) {
        free(order);
        free(mark);
        return -1;
    }
    size_t npix = rt_pixel_order_part(o, ctx->part, ctx->nparts, order);
    rt_cam_frame cam;
    rt_cam_setup(&cam, sc, W, H);
    rt_trav tv;
    rt_reg_trav(&tv, ctx);
    tv.mark = mark;
    const int secondary = rt_render_secondary(o);
    uint64_t nsec = 0, nself = 0;
    const int authored = rt_shade_authored(sc, o) && o->lights; /* the file's lights (--light-samples) */
    float *lw = authored ? rt_calloc(sc->nlight, sizeof *lw, e) : NULL;
    if (authored && !lw) {
        free(order);
        free(mark);
        return -1;
    }

    for (size_t k = 0; k < npix; k++) {
        uint32_t pix = order[k];
        int x = (int)(pix % (uint32_t)W), y = (int)(pix / (uint32_t)W);
        uint64_t n0 = tv.nodes, t0 = tv.tests;
        if (secondary) {
            rec_secondary(ctx, &tv, &cam, pix, img, st, &nsec, &nself);
            img->nodes[pix] = (float)(tv.nodes - n0);
            img->tests[pix] = (float)(tv.tests - t0);
            RT_REC(rec, rt_mm_addr(L, reg_fb, pix), 12, 1, RT_CLS_FB);
            continue;
        }
        rt_ray ray;
        rt_hit h;
        RT_REC(rec, rt_mm_addr(L, reg_ray, pix), 32, 0, RT_CLS_RAY);
        rt_cam_ray(&cam, x, y, &ray);
        tv.mark_bit = 1;
        st->rays_primary++;
        if (authored) {
            int hit = ctx->acc->ops->closest(&tv, &ray, &h);
            if (hit) {
                RT_REC(rec, rt_mm_addr(L, reg_shade, rt_scene_model_slot(sc, h.tri, inst)), 16, 0, RT_CLS_SHADE);
                tv.mark_bit = 2;
                rec_lights(ctx, &tv, &ray, &h, lw, st);
            }
            rt_shade_pixel_lw(sc, o, &ray, hit ? &h : NULL, lw, img, pix);
        } else if (ctx->acc->ops->closest(&tv, &ray, &h)) {
            int vis[RT_NLIGHTS] = {0};
            RT_REC(rec, rt_mm_addr(L, reg_shade, rt_scene_model_slot(sc, h.tri, inst)), 16, 0, RT_CLS_SHADE);
            tv.mark_bit = 2;
            for (unsigned left = o->lights & ((1u << RT_NLIGHTS) - 1u); left; left &= left - 1u) {
                const int i = __builtin_ctz(left); /* the lights in turn, none without lights */
                rt_ray sr;
                if (!rt_shade_ray(sc, &ray, &h, i, &sr)) continue;
                st->rays_shadow++;
                vis[i] = !ctx->acc->ops->occluded(&tv, &sr);
            }
            rt_shade_pixel(sc, &ray, &h, vis, o->lights, img, pix);
        } else {
            rt_shade_pixel(sc, &ray, NULL, NULL, o->lights, img, pix);
        }
        img->nodes[pix] = (float)(tv.nodes - n0);
        img->tests[pix] = (float)(tv.tests - t0);
        RT_REC(rec, rt_mm_addr(L, reg_fb, pix), 12, 1, RT_CLS_FB);
    }
    rt_stats_finish(st, &tv, mark, nmark);
    if (secondary)
        snprintf(st->extra, sizeof st->extra, "rays_secondary=%" PRIu64 " self_hits=%" PRIu64, nsec, nself);
    if (tv.xforms) { /* the two-level structure: rays transformed into an object's space */
        size_t l = strlen(st->extra);
        snprintf(st->extra + l, sizeof st->extra - l, "%sxforms=%" PRIu64, l ? " " : "", tv.xforms);
    }
    free(order);
    free(mark);
    free(lw);
    return 0;
}

const rt_tracer rt_tracer_recursive = {
    .name = "recursive",
    .desc = "single rays in Hilbert-curve order, shadow rays depth first (Whitted)",
    .modes = RT_TRACER_ALL_MODES,
    .accels = RT_ACCEL_BIT(RT_ACCEL_KD) | RT_ACCEL_BVH_BITS | RT_ACCEL_BIT(RT_ACCEL_NAIVE) | RT_ACCEL_BIT(RT_ACCEL_INST),
    .accel_default = RT_ACCEL_KD,
    .opts = RT_OPTG_THREADS | RT_OPTG_CORES,
    .traits = RT_TR_REFERENCE | RT_TR_LIGHTS,
    .figures = RT_FIG_NAVRATIL,
    .layout = rec_layout,
    .run = rec_run,
};
