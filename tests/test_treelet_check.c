/*
 * test_treelet_check.c -- the treelet scheduler's checkers can fail: the
 * plan's checker (T1) and the state checker (T2-T4; T2 is the ray-queue
 * core's Q1-Q5, rt_rq_check) pass on a real plan and a real run state, and
 * each rejects a corrupted copy naming the invariant. The tracer file is compiled into this test (its functions
 * are static) under another name for its registry entry.
 * Simulated cores: T7 (each core's count of the rays queued in its
 * treelets, the rays moved between cores and read by the core they moved
 * to, the interleave's C1-C3) passes on a real state and rejects corrupted
 * ones; on N cores every node reference is made by the core that owns the
 * node's treelet (treelet t on core t mod N) and the rays moved are
 * counted.
 */
#include "run.h"
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
    rt_tracer_ctx ctx = {sc, &acc, NULL, &o, NULL, NULL, NULL, 1, NULL, 0, 1, NULL, NULL};
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
    rt_tracer_ctx ctx = {sc, &acc, NULL, &o, &L, NULL, NULL, 1, NULL, 0, 1, NULL, NULL};
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

/* T7 on a state with three cores (untraced): rays started by cores 1 and
 * 2 move to core 0, which owns the root treelet. */
static void test_state_cores(const rt_scene *sc)
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
    rt_cores c;
    CHECK(rt_cores_init(&c, 3, NULL, &e) == 0, "cores: %s", e.msg);
    rt_tracer_ctx ctx = {sc, &acc, NULL, &o, &L, NULL, NULL, 1, NULL, 0, 1, NULL, &c};
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
    for (uint32_t s = 0; s < 3; s++) {
        rt_ray r;
        rt_cam_ray(&cam, 1 + (int)s, 2, &r);
        T.want[s] = 1;
        use_core(&T, (int)s);
        CHECK(start(&T, s, &r, 0) == 0, "ray %u finished at its start", s);
    }
    CHECK(T.cq[0] == 3 && T.cq[1] == 0 && T.moved == 2, "root's core holds %" PRIu64 " rays, %" PRIu64 " moved", T.cq[0],
          T.moved);
    CHECK(check_state(&T, &e) == 0, "a real state fails: %s", e.msg);
    T.cq[0]--;
    T.cq[1]++;
    expect_fail(check_state(&T, &e), &e, "T7", "a core's queued rays miscounted");
    T.cq[0]++;
    T.cq[1]--;
    T.mv[2] = 0;
    expect_fail(check_state(&T, &e), &e, "T7", "a moving ray unmarked");
    T.mv[2] = 1;
    T.mv[5] = 1;
    expect_fail(check_state(&T, &e), &e, "T7", "a ray marked moving that is in no queue");
    T.mv[5] = 0;
    c.buf[2].done = 1;
    expect_fail(check_state(&T, &e), &e, "C1", "a core left done between rounds");
    c.buf[2].done = 0;
    CHECK(check_state(&T, &e) == 0, "restored state fails: %s", e.msg);
    /* the rounds finish what was started; the moved rays were read by core 0 */
    run_queues(&T);
    CHECK(T.err == 0 && end_generation(&T, 3, &e) == 0, "generation: %s", e.msg);
    CHECK(T.moved >= 2 && T.moved == T.moved_reads && T.rounds >= 1, "moved %" PRIu64 ", read %" PRIu64 ", rounds %" PRIu64,
          T.moved, T.moved_reads, T.rounds);
    tl_free(&T);
    rt_cores_free(&c);
    rt_image_free(img);
    tl_plan_free(pv);
    rt_accel_free(&acc);
}

typedef struct ccoll {
    rt_access *a;
    uint8_t *core;
    size_t n, cap;
} ccoll;

static int ccoll_put(rt_csink *s, unsigned core, const rt_access *a, size_t n)
{
    ccoll *c = s->ctx;
    if (c->n + n > c->cap) {
        c->cap = 2 * (c->n + n);
        c->a = realloc(c->a, c->cap * sizeof *c->a);
        c->core = realloc(c->core, c->cap);
    }
    memcpy(c->a + c->n, a, n * sizeof *a);
    memset(c->core + c->n, (int)core, n);
    c->n += n;
    return 0;
}

/* On N cores a node is read only by the core of its treelet (t mod N). */
static void test_rule(int N, int mode, int qorder)
{
    rt_render_opts o;
    rt_render_default_opts(&o);
    o.W = 16;
    o.H = 12;
    o.lights = 7;
    o.mode = mode;
    o.qorder = qorder;
    o.sched_size = 2048;
    o.cores = N;
    rt_err e = {0};
    rt_job j;
    CHECK(rt_job_setup(&j, "knot", "treelet", &o, &e) == 0, "setup: %s", e.msg);
    j.check = 1;
    ccoll got = {0};
    rt_csink cs = {ccoll_put, &got};
    rt_image *img = rt_image_new(o.W, o.H, &e);
    rt_run_stats st;
    CHECK(rt_job_run_cores(&j, &cs, img, &st, &e) == 0, "run on %d cores: %s", N, e.msg);
    const tplan *P = j.plan;
    const rt_region *nr = NULL;
    for (int g = 0; g < j.L.n; g++)
        if (j.L.r[g].cls == RT_CLS_NODE) nr = &j.L.r[g];
    CHECK(nr && P && P->nt > (uint32_t)N, "node region and %u treelets", P ? P->nt : 0);
    size_t nodes = 0, wrong = 0;
    unsigned seen = 0;
    for (size_t i = 0; nr && i < got.n; i++) {
        if (got.a[i].cls != RT_CLS_NODE) continue;
        const uint64_t idx = (got.a[i].addr - nr->base) / nr->recsize;
        nodes++;
        if (idx >= P->nnodes || P->tl[idx] % (uint32_t)N != got.core[i]) wrong++;
        seen |= 1u << got.core[i];
    }
    CHECK(nodes > 0 && !wrong, "%d cores: %zu of %zu node references by a core that does not own the node's treelet", N,
          wrong, nodes);
    CHECK(seen == (1u << N) - 1, "%d cores: cores %#x read nodes", N, seen);
    CHECK(strstr(st.extra, "rays_moved=") && !strstr(st.extra, "rays_moved=0 "), "no ray moved: %s", st.extra);
    /* the receivers read at least each moved ray's record */
    const char *pm = strstr(st.extra, "rays_moved="), *pb = strstr(st.extra, "bytes_moved=");
    CHECK(pm && pb && strtoull(pb + 12, NULL, 10) >= 64 * strtoull(pm + 11, NULL, 10), "bytes moved: %s", st.extra);
    free(got.a);
    free(got.core);
    rt_image_free(img);
    rt_job_free(&j);
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
    test_state_cores(sc);
    rt_scene_free(sc);
    test_rule(2, RT_MODE_SHADOW, RT_QORDER_FULLEST);
    test_rule(5, RT_MODE_SHADOW, RT_QORDER_TREE);
    test_rule(3, RT_MODE_PATH, RT_QORDER_FULLEST);
    return failures ? 1 : 0;
}
