/*
 * test_feedback_check.c -- the feedback tracer's ping-pong buffer checks
 * (F1-F3 of tracegen/feedback.c) can fail. A real run in test mode passes;
 * the same run on a corrupted plan fails naming F1 (a buffer capacity one
 * record short of the frame: the primary fill overflows it) and F2 (the
 * per-pixel emission bounds E[] zeroed: the first pass appends more than
 * they allow); a vertex buffer holding a record still waiting for shading
 * fails naming F3 when the geometry stage reads it. On 3 simulated cores
 * the run in test mode passes, and a record read by another core than its
 * chunk's fails naming F4 at the pass's barrier. The tracer file is
 * compiled into this test (its functions are static) under another name
 * for its registry entry.
 */
#define rt_tracer_feedback rt_tracer_feedback_under_test
#include "scene_load.h"
#include "../tracegen/feedback.c"

#include "check.h"

#include <inttypes.h>

static int run(const rt_tracer_ctx *ctx, rt_err *e)
{
    const rt_render_opts *o = ctx->opt;
    rt_image *img = rt_image_new(o->W, o->H, e);
    rt_run_stats st;
    memset(&st, 0, sizeof st);
    int rc = img ? fb_run_tracer(ctx, img, &st, e) : -1;
    rt_image_free(img);
    return rc;
}

static void test_run(const rt_scene *sc)
{
    rt_err e = {0};
    rt_accel acc;
    rt_accel_params ap = {0, 0, 0};
    CHECK(rt_accel_build(&acc, RT_ACCEL_GRID, sc, &ap, &e) == 0, "build: %s", e.msg);
    rt_render_opts o;
    rt_render_default_opts(&o);
    o.W = o.H = 8;
    o.accel = RT_ACCEL_GRID;
    o.mode = RT_MODE_SHADOW;
    o.lights = 1;
    rt_layout L;
    rt_mm_init(&L);
    rt_tracer_ctx ctx = {sc, &acc, NULL, &o, &L, NULL, NULL, 1, NULL, 0, 1, NULL, NULL};
    void *pv = NULL;
    CHECK(fb_plan_make(&ctx, &pv, &e) == 0, "plan: %s", e.msg);
    fb_plan *pl = pv;
    if (!pl) goto out;
    ctx.plan = pl;
    CHECK(fb_layout(&ctx, &L, &e) == 0, "layout: %s", e.msg);
    CHECK(run(&ctx, &e) == 0, "a real run fails: %s", e.msg);
    /* F1: the buffer a record short of the frame's eye rays */
    const uint64_t cap = pl->cap;
    pl->cap = (uint64_t)o.W * (uint64_t)o.H - 1;
    CHECK(run(&ctx, &e) < 0 && strstr(e.msg, "F1"), "capacity below the frame: '%s'", e.msg);
    pl->cap = cap;
    /* F2: no record allowed per pixel in the first pass */
    const double e0 = pl->z.E[0], e1 = pl->z.E[1];
    pl->z.E[0] = pl->z.E[1] = 0;
    CHECK(run(&ctx, &e) < 0 && strstr(e.msg, "F2"), "emission bound zeroed: '%s'", e.msg);
    pl->z.E[0] = e0;
    pl->z.E[1] = e1;
    CHECK(run(&ctx, &e) == 0, "the restored plan fails: %s", e.msg);
    /* on 3 cores (untraced): the run passes F4 at every barrier */
    rt_cores c;
    CHECK(rt_cores_init(&c, 3, NULL, &e) == 0, "cores: %s", e.msg);
    ctx.cores = &c;
    CHECK(run(&ctx, &e) == 0 && c.phases >= 3, "a real run on 3 cores fails: %s (%" PRIu64 " barriers)", e.msg, c.phases);
    /* F4: record 0 of a pass of 10 read by core 2 (its chunk is 6-9) */
    fb_run R;
    memset(&R, 0, sizeof R);
    R.ctx = &ctx;
    R.cores = &c;
    R.ncores = 3;
    fb_item(&R, 0, 10);
    rt_cores_claim(R.cores, R.core, 0, 10);
    CHECK(fb_pass_end(&R, &e) == 0, "record 0 by its own core fails: %s", e.msg);
    R.core = 2;
    rt_cores_claim(R.cores, R.core, 0, 10);
    CHECK(fb_pass_end(&R, &e) < 0 && strstr(e.msg, "F4") && strstr(e.msg, "C4"), "record 0 by core 2: '%s'", e.msg);
    rt_cores_free(&c);
    ctx.cores = NULL;
out:
    fb_plan_free(pv);
    rt_accel_free(&acc);
}

/* F3: the geometry stage reads a record that is neither to be traced nor
 * already written (one left in the shading state). */
static void test_stage(void)
{
    rt_err e = {0};
    fb_run R;
    memset(&R, 0, sizeof R);
    rt_fb_rec buf[2];
    rt_fb_ray ray;
    memset(&ray, 0, sizeof ray);
    ray.tri = RT_NO_HIT;
    ray.state = RT_FB_WRITTEN;
    rt_fb_pack(&ray, &buf[0]);
    ray.state = RT_FB_SHADE;
    rt_fb_pack(&ray, &buf[1]);
    R.vb[0] = buf;
    R.n[0] = 2;
    CHECK(stage(&R, 0, 0, &e) == 0 && R.s.gs_drop_written == 1, "a written record is not dropped: %s", e.msg);
    CHECK(stage(&R, 0, 1, &e) < 0 && strstr(e.msg, "F3") && strstr(e.msg, "record 1"), "a shading record read: '%s'",
          e.msg);
}

int main(void)
{
    rt_err e = {0};
    rt_scene *sc = rt_scene_load("cornell", &e);
    CHECK(sc != NULL, "load: %s", e.msg);
    if (!sc) return 1;
    test_run(sc);
    test_stage();
    rt_scene_free(sc);
    return failures ? 1 : 0;
}
