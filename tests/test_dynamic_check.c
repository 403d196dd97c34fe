/*
 * test_dynamic_check.c -- the dynamic scheduler's checker (rt_dyn_check,
 * I1-I6 of tracegen/dynamic.c, with I3 the ray-queue core's Q1-Q5, and I8
 * on 3 simulated cores) can fail: it passes on a real plan and a real run state with rays queued at
 * several queue points, rejects each corrupted copy naming the broken
 * invariant, passes again once restored, and the run then finishes the
 * generation. The tracer file is compiled into this test (its functions
 * are static) under another name for its registry entry.
 */
#define rt_tracer_dynamic rt_tracer_dynamic_under_test
#include "scene_load.h"
#include "../tracegen/dynamic.c"

#include "check.h"

static void expect_fail(const dyn *D, const char *inv, const char *what)
{
    rt_err e = {0};
    int rc = rt_dyn_check(D, &e);
    CHECK(rc < 0, "%s: the checker accepted it", what);
    CHECK(rc >= 0 || strstr(e.msg, inv), "%s: message '%s' does not name %s", what, e.msg, inv);
}

static void test_state(const rt_scene *sc, int qorder)
{
    rt_err e = {0};
    rt_accel acc;
    rt_accel_params ap = {0, 0, 0};
    CHECK(rt_accel_build(&acc, RT_ACCEL_KD, sc, &ap, &e) == 0, "build: %s", e.msg);
    rt_render_opts o;
    rt_render_default_opts(&o);
    o.W = o.H = 8;
    o.accel = RT_ACCEL_KD;
    o.sched_size = 8192; /* several queue points on the knot */
    o.qorder = qorder;
    rt_layout L;
    rt_mm_init(&L);
    rt_tracer_ctx ctx = {sc, &acc, acc.as, &o, &L, NULL, NULL, 1, NULL, 0, 1, NULL, NULL};
    void *pv = NULL;
    CHECK(dyn_plan(&ctx, &pv, &e) == 0, "plan: %s", e.msg);
    dplan *P = pv;
    ctx.plan = pv;
    CHECK(P && P->nq > 2, "%u queue points", P ? P->nq : 0);
    CHECK(dyn_layout(&ctx, &L, &e) == 0, "layout: %s", e.msg);
    rt_image *img = rt_image_new(o.W, o.H, &e);
    rt_run_stats st;
    memset(&st, 0, sizeof st);
    dyn D;
    memset(&D, 0, sizeof D);
    CHECK(img && dyn_init(&D, &ctx, img, &st, &e) == 0, "init: %s", e.msg);
    if (!img || !P || P->nq <= 2) goto out;
    /* every pixel's primary ray started: queued at its first queue point */
    D.shadow = 0;
    D.tv.mark_bit = 1;
    for (uint32_t p = 0; p < D.npix; p++) D.want[p] = 1;
    for (uint32_t p = 0; p < D.npix; p++) start(&D, p);
    uint32_t busy = 0, q0 = UINT32_MAX;
    for (uint32_t q = 0; q < D.nq; q++)
        if (D.rq.count[q]) {
            busy++;
            if (q0 == UINT32_MAX) q0 = q;
        }
    CHECK(D.rq.queued > 8 && busy >= 2, "%" PRIu64 " rays queued at %u queue points", D.rq.queued, busy);
    CHECK(rt_dyn_check(&D, &e) == 0, "a real state fails: %s", e.msg);
    if (q0 == UINT32_MAX) goto out;
    /* I1: the queue-point table no longer the inverse of qp */
    uint32_t keep = P->qnode[0];
    P->qnode[0] = P->qnode[1];
    expect_fail(&D, "I1", "qnode not the inverse of qp");
    P->qnode[0] = keep;
    /* I2: the top miscounted */
    P->ntop++;
    expect_fail(&D, "I2", "top interior nodes miscounted");
    P->ntop--;
    /* I3 (the core's Q3, Q2, Q4): counts, pool, buckets */
    D.rq.queued--;
    expect_fail(&D, "Q3", "rays queued miscounted");
    D.rq.queued++;
    int32_t fb = D.rq.bnext[D.rq.freelist];
    D.rq.bnext[D.rq.freelist] = D.rq.head[q0];
    expect_fail(&D, "Q2", "a queue's block also free");
    D.rq.bnext[D.rq.freelist] = fb;
    if (qorder == RT_QORDER_FULLEST) {
        int32_t h = D.rq.bk_head[0]; /* the empty queues' bucket */
        D.rq.bk_head[0] = (int32_t)q0;
        expect_fail(&D, "Q4", "a queue in a foreign bucket");
        D.rq.bk_head[0] = h;
    }
    /* I6: a queued ray already resolved; rays started miscounted; a
     * candidate flag on a pixel with no hit */
    qent *first = rt_rq_at(&D.rq, &(rt_rq_cur){D.rq.head[q0], 0, 1});
    const uint32_t pix = first->pix & ~CAND_FLAG;
    D.resolved[pix] = 1;
    expect_fail(&D, "I6", "a resolved ray still queued");
    D.resolved[pix] = 0;
    D.created++;
    expect_fail(&D, "I6", "rays started miscounted");
    D.created--;
    const uint32_t flag = first->pix & CAND_FLAG, tri = D.hit_tri[pix];
    first->pix = pix | CAND_FLAG;
    D.hit_tri[pix] = RT_NO_HIT;
    expect_fail(&D, "I6", "a candidate flag without a hit");
    first->pix = pix | flag;
    D.hit_tri[pix] = tri;
    CHECK(rt_dyn_check(&D, &e) == 0, "restored state fails: %s", e.msg);
    /* the run finishes what was started, checking at every step */
    run_queues(&D);
    CHECK(D.err == 0 && check_generation(&D, D.want, D.npix, &e) == 0, "generation: %s", e.msg);
out:
    dyn_free(&D);
    rt_image_free(img);
    dyn_plan_free(pv);
    rt_accel_free(&acc);
}

static int count_put(rt_csink *s, unsigned core, const rt_access *a, size_t n)
{
    (void)core;
    (void)a;
    *(size_t *)s->ctx += n;
    return 0;
}

/* I8 on 3 simulated cores: a real state passes, each corrupted copy fails
 * naming I8, the restored one passes and the run finishes. */
static void test_cores(const rt_scene *sc)
{
    rt_err e = {0};
    rt_accel acc;
    rt_accel_params ap = {0, 0, 0};
    CHECK(rt_accel_build(&acc, RT_ACCEL_KD, sc, &ap, &e) == 0, "build: %s", e.msg);
    rt_render_opts o;
    rt_render_default_opts(&o);
    o.W = o.H = 8;
    o.accel = RT_ACCEL_KD;
    o.sched_size = 8192;
    o.cores = 3;
    rt_layout L;
    rt_mm_init(&L);
    size_t got = 0;
    rt_csink cs = {count_put, &got};
    rt_tracer_ctx ctx = {sc, &acc, acc.as, &o, &L, NULL, NULL, 1, NULL, 0, 1, &cs, NULL};
    void *pv = NULL;
    CHECK(dyn_plan(&ctx, &pv, &e) == 0, "plan: %s", e.msg);
    ctx.plan = pv;
    CHECK(dyn_layout(&ctx, &L, &e) == 0, "layout: %s", e.msg);
    rt_image *img = rt_image_new(o.W, o.H, &e);
    rt_run_stats st;
    memset(&st, 0, sizeof st);
    dyn D;
    memset(&D, 0, sizeof D);
    CHECK(img && dyn_init(&D, &ctx, img, &st, &e) == 0, "init: %s", e.msg);
    if (!img || D.ncores != 3) goto out;
    D.shadow = 0;
    D.tv.mark_bit = 1;
    for (uint32_t p = 0; p < D.npix; p++) D.want[p] = 1;
    for (uint32_t p = 0; p < D.npix; p++) {
        start_core(&D, p, D.npix);
        start(&D, p);
    }
    CHECK(D.core == 2, "the last ray started by core %d", D.core);
    interleave(&D);
    CHECK(got > 0 && D.rq.queued > 8, "%zu references, %" PRIu64 " rays queued", got, D.rq.queued);
    CHECK(rt_dyn_check(&D, &e) == 0, "a real state fails: %s", e.msg);
    uint32_t q0 = 0;
    while (q0 < D.nq && !D.rq.count[q0]) q0++;
    if (q0 == D.nq) goto out;
    const uint32_t pix = ((const qent *)rt_rq_at(&D.rq, &(rt_rq_cur){D.rq.head[q0], 0, 1}))->pix & ~CAND_FLAG;
    const uint8_t own = D.owner[pix];
    D.owner[pix] = 3;
    expect_fail(&D, "I8", "a queued ray owned by no core");
    D.owner[pix] = own;
    D.core_rays[1]++;
    expect_fail(&D, "I8", "the cores' popped rays miscounted");
    D.core_rays[1]--;
    D.rounds = 1;
    expect_fail(&D, "I8", "more rounds than queue events");
    D.rounds = 0;
    RT_REC(D.crec[1], 64, 4, 0, RT_CLS_RAY);
    expect_fail(&D, "I8", "a core's references not interleaved");
    D.crec[1]->n--;
    D.core = 3;
    expect_fail(&D, "I8", "running core out of range");
    D.core = 2;
    CHECK(rt_dyn_check(&D, &e) == 0, "restored state fails: %s", e.msg);
    run_queues(&D);
    CHECK(D.err == 0 && check_generation(&D, D.want, D.npix, &e) == 0, "generation: %s", e.msg);
    CHECK(D.rounds > 0 && D.moved > 0 && D.core_rays[0] + D.core_rays[1] + D.core_rays[2] == D.ev_rays,
          "rounds %" PRIu64 ", moved %" PRIu64, D.rounds, D.moved);
out:
    dyn_free(&D);
    rt_image_free(img);
    dyn_plan_free(pv);
    rt_accel_free(&acc);
}

int main(void)
{
    rt_err e = {0};
    rt_scene *sc = rt_scene_load("knot", &e);
    CHECK(sc != NULL, "load: %s", e.msg);
    if (!sc) return 1;
    test_state(sc, RT_QORDER_FULLEST);
    test_state(sc, RT_QORDER_TREE);
    test_cores(sc);
    rt_scene_free(sc);
    return failures ? 1 : 0;
}
