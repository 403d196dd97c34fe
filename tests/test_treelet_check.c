/*
 * test_treelet_check.c -- the treelet scheduler's checkers can fail: the
 * plan's checker (T1) and the state checker (T2-T4; T2 is the ray-queue
 * core's Q1-Q5, rt_rq_check) pass on a real plan and a real run state, and
 * each rejects a corrupted copy naming the invariant. The tracer file is compiled into this test (its functions
 * are static) under another name for its registry entry.
 */
#define rt_tracer_treelet rt_tracer_treelet_under_test
#include "scene_load.h"
#include "../tracegen/treelet.c"

#include "check.h"

static void expect_fail(int rc, const rt_err *e, const char *inv, const char *what)
{
    CHECK(rc < 0, "%s: the checker accepted it", what);
    CHECK(rc >= 0 || strstr(e->msg, inv), "%s: message '%s' does not name %s", what, e->msg, inv);
}

static void test_plan(const rt_scene *sc, int kind)
{
    rt_err e = {0};
    rt_accel acc;
    rt_accel_params ap = {0, 0, 0};
    CHECK(rt_accel_build(&acc, kind, sc, &ap, &e) == 0, "build: %s", e.msg);
    rt_render_opts o;
    rt_render_default_opts(&o);
    o.accel = kind;
    o.sched_size = 1024; /* budget 512 B: several treelets */
    rt_tracer_ctx ctx = {sc, &acc, NULL, &o, NULL, NULL, NULL, 1, NULL, 0, 1, NULL};
    void *pv = NULL;
    CHECK(tl_plan(&ctx, &pv, &e) == 0, "plan: %s", e.msg);
    tplan *P = pv;
    if (!P) {
        rt_accel_free(&acc);
        return;
    }
    const rt_bvh *b = acc.as;
    CHECK(P->nt > 2, "bvh%d: %u treelets", b->width, P->nt);
    CHECK(check_plan(P, b, &e) == 0, "bvh%d: a real plan fails: %s", b->width, e.msg);
    /* a node moved to another treelet than its parent's */
    uint32_t i = 1;
    while (i < b->nnodes && P->troot[P->tl[i]] == i) i++;
    if (i < b->nnodes) {
        uint32_t keep = P->tl[i];
        P->tl[i] = (keep + 1) % P->nt;
        expect_fail(check_plan(P, b, &e), &e, "T1", "node in a foreign treelet");
        P->tl[i] = keep;
    }
    /* a node's root bit wrong (the walk would keep a crossing child in its treelet) */
    if (i < b->nnodes) {
        P->rootbit[i / 64] ^= (uint64_t)1 << (i % 64);
        expect_fail(check_plan(P, b, &e), &e, "T1", "root bit of a non-root");
        P->rootbit[i / 64] ^= (uint64_t)1 << (i % 64);
    }
    P->rootbit[P->troot[1] / 64] ^= (uint64_t)1 << (P->troot[1] % 64);
    expect_fail(check_plan(P, b, &e), &e, "T1", "root bit of a root cleared");
    P->rootbit[P->troot[1] / 64] ^= (uint64_t)1 << (P->troot[1] % 64);
    /* a treelet's bytes miscounted */
    P->tbytes[0] += 1;
    expect_fail(check_plan(P, b, &e), &e, "T1", "bytes miscounted");
    P->tbytes[0] -= 1;
    /* the greedy rule stopped too early: a budget that fits the next node */
    const uint64_t budget = P->budget;
    P->budget = budget * 8;
    expect_fail(check_plan(P, b, &e), &e, "T1", "stopped early");
    P->budget = budget;
    CHECK(check_plan(P, b, &e) == 0, "restored plan fails: %s", e.msg);
    tl_plan_free(P);
    rt_accel_free(&acc);
}

static void test_state(const rt_scene *sc)
{
    rt_err e = {0};
    rt_accel acc;
    rt_accel_params ap = {0, 0, 0};
    CHECK(rt_accel_build(&acc, RT_ACCEL_BVH4, sc, &ap, &e) == 0, "build: %s", e.msg);
    rt_render_opts o;
    rt_render_default_opts(&o);
    o.W = o.H = 4;
    o.accel = RT_ACCEL_BVH4;
    o.sched_size = 1024;
    rt_layout L;
    rt_mm_init(&L);
    rt_tracer_ctx ctx = {sc, &acc, NULL, &o, &L, NULL, NULL, 1, NULL, 0, 1, NULL};
    void *pv = NULL;
    CHECK(tl_plan(&ctx, &pv, &e) == 0, "plan: %s", e.msg);
    ctx.plan = pv;
    CHECK(tl_layout(&ctx, &L, &e) == 0, "layout: %s", e.msg);
    rt_image *img = rt_image_new(o.W, o.H, &e);
    rt_run_stats st;
    memset(&st, 0, sizeof st);
    tl_run T;
    CHECK(img && tl_init(&T, &ctx, img, &st, &e) == 0, "init: %s", e.msg);
    rt_cam_frame cam;
    rt_cam_setup(&cam, sc, o.W, o.H);
    /* two camera rays started: both queued at the root treelet */
    for (uint32_t s = 0; s < 2; s++) {
        rt_ray r;
        rt_cam_ray(&cam, 1 + (int)s, 2, &r);
        T.want[s] = 1;
        CHECK(start(&T, s, &r, 0) == 0, "ray %u finished at its start", s);
    }
    CHECK(check_state(&T, &e) == 0, "a real state fails: %s", e.msg);
    CHECK(T.rq.count[0] == 2 && T.rq.queued == 2, "root queue holds %u rays, %llu queued", T.rq.count[0],
          (unsigned long long)T.rq.queued);
    T.rq.count[0]--;
    expect_fail(check_state(&T, &e), &e, "Q3", "queue count off by one");
    T.rq.count[0]++;
    T.rq.queued++;
    expect_fail(check_state(&T, &e), &e, "Q3", "rays queued miscounted");
    T.rq.queued--;
    T.ray[1].stk[0].tl = 1;
    expect_fail(check_state(&T, &e), &e, "T3", "queued away from its stack top");
    T.ray[1].stk[0].tl = 0;
    T.ray[0].reg = 0;
    expect_fail(check_state(&T, &e), &e, "T4", "a queued ray holding an entry in registers");
    T.ray[0].reg = 1;
    T.done[1] = 1;
    expect_fail(check_state(&T, &e), &e, "T3", "a finished ray still queued");
    T.done[1] = 0;
    int32_t keep = T.rq.bnext[T.rq.freelist];
    T.rq.bnext[T.rq.freelist] = T.rq.head[0];
    expect_fail(check_state(&T, &e), &e, "Q2", "a queue's block also on the free list");
    T.rq.bnext[T.rq.freelist] = keep;
    T.rq.bk_head[1] = T.rq.bk_head[2];
    expect_fail(check_state(&T, &e), &e, "Q4", "a queue out of its bucket");
    T.rq.bk_head[1] = -1; /* bucket 1 was empty: queue 0 holds two rays */
    CHECK(strstr(e.msg, "treelet: ray queue") != NULL, "core's message names the scheduler: %s", e.msg);
    CHECK(check_state(&T, &e) == 0, "restored state fails: %s", e.msg);
    /* the run finishes what was started */
    run_queues(&T);
    CHECK(T.err == 0 && end_generation(&T, 2, &e) == 0, "generation: %s", e.msg);
    tl_free(&T);
    rt_image_free(img);
    tl_plan_free(pv);
    rt_accel_free(&acc);
}

int main(void)
{
    rt_err e = {0};
    rt_scene *sc = rt_scene_load("knot", &e);
    CHECK(sc != NULL, "load: %s", e.msg);
    if (!sc) return 1;
    test_plan(sc, RT_ACCEL_BVH2);
    test_plan(sc, RT_ACCEL_BVH4);
    test_plan(sc, RT_ACCEL_BVH8);
    test_state(sc);
    rt_scene_free(sc);
    return failures ? 1 : 0;
}
