/*
 * test_dynamic_cores.c -- the dynamic scheduler on N simulated cores
 * (tracegen/dynamic.c, "Many cores"; rt_job_run_cores with RT_TR_CORES).
 *
 *   - N = 1 through rt_job_run_cores is rt_job_run's stream, reference for
 *     reference, and that stream is today's (a golden hash);
 *   - a one-pixel image on 2 cores: its one ray is started by core 0 and
 *     every round has one queue, taken by core 0: the one-core stream, all
 *     of it core 0's, nothing moved;
 *   - N = 2, 3, 8 (fullest first and tree order, shadow rays on), test mode
 *     (the invariants, I8 included, checked at every step; every ray
 *     resolved once per generation): every ray follows its one-core path,
 *     so the image, node visits, triangle tests, enqueues and rays popped
 *     are one core's; the only references added are the queue table entry
 *     and cell box (2 per queue event) of the extra queue events; each
 *     moved ray's read turns from a queue entry into ray state (RT_CLS_RAY
 *     up by rays_moved, RT_CLS_QUEUE down by it), other classes as on one
 *     core; every core makes references, its ray buffer its own (above the
 *     layout for cores > 0); rays popped per core within the run's;
 *   - the interleave is the same on every machine (golden hash, 3 cores);
 *   - host threads (rt_job_run with opt.host_threads = N, untraced: the
 *     N-core rounds on N threads): one core's image, the statistics of the
 *     simulated N-core run, with the invariants checked at every step.
 */
#include "check.h"
#include "run.h"
#include "trace.h"
#include "coll.h"

#include <inttypes.h>

static uint64_t hash_stream(const coll *c)
{
    uint64_t h = 1469598103934665603ull;
    for (size_t i = 0; i < c->n; i++) {
        unsigned char b[16];
        const rt_access *a = &c->a[i];
        memcpy(b, &a->addr, 8);
        memcpy(b + 8, &a->size, 4);
        b[12] = a->write;
        b[13] = a->cls;
        b[14] = a->gen;
        b[15] = c->core[i];
        h = rt_fnv1a(h, b, 16);
    }
    return h;
}

/* The value of key k ("queue_events") in a statistics string, or -1. */
static long long statv(const char *extra, const char *k)
{
    size_t l = strlen(k);
    for (const char *p = extra; (p = strstr(p, k)); p += l)
        if ((p == extra || p[-1] == ' ') && p[l] == '=') return strtoll(p + l + 1, NULL, 10);
    return -1;
}

typedef struct run {
    coll s;
    rt_run_stats st;
    rt_image *img;
} run;

static int run_job(rt_job *j, int cores, run *r)
{
    rt_err e = {0};
    memset(r, 0, sizeof *r);
    r->img = rt_image_new(j->opt.W, j->opt.H, &e);
    j->opt.cores = cores;
    rt_csink cs = {coll_cput, &r->s};
    int rc = r->img ? rt_job_run_cores(j, &cs, r->img, &r->st, &e) : -1;
    CHECK(rc == 0, "dynamic on %d cores: %s", cores, e.msg);
    return rc;
}

static void run_free(run *r)
{
    coll_free(&r->s);
    rt_image_free(r->img);
}

static int setup(rt_job *j, int W, int H, unsigned lights, int qorder)
{
    rt_render_opts o;
    rt_render_default_opts(&o);
    o.W = W;
    o.H = H;
    o.lights = lights;
    o.sched_size = 8192; /* several queue points on the knot */
    o.qorder = qorder;
    rt_err e = {0};
    if (rt_job_setup(j, "knot", "dynamic", &o, &e) < 0) {
        CHECK(0, "setup: %s", e.msg);
        return -1;
    }
    j->check = 1;
    return 0;
}

static size_t count_cls(const coll *c, int cls)
{
    size_t n = 0;
    for (size_t i = 0; i < c->n; i++) n += c->a[i].cls == cls;
    return n;
}

/* N = 1: rt_job_run_cores is rt_job_run; returns the stream's hash. */
static uint64_t one_core(void)
{
    rt_job j;
    if (setup(&j, 16, 12, 7, RT_QORDER_FULLEST) < 0) return 0;
    run a;
    coll b = {0};
    rt_err e = {0};
    uint64_t h = 0;
    if (run_job(&j, 1, &a) == 0) {
        rt_sink s = {coll_put, &b};
        rt_image *img = rt_image_new(16, 12, &e);
        rt_run_stats st;
        CHECK(rt_job_run(&j, &s, img, &st, &e) == 0, "rt_job_run: %s", e.msg);
        size_t d = a.s.n == b.n ? 0 : 1;
        for (size_t i = 0; !d && i < b.n; i++)
            if (!same_access(&a.s.a[i], &b.a[i]) || a.s.core[i]) d = i + 1;
        CHECK(!d, "one core: %zu references, rt_job_run %zu, first difference at %zu", a.s.n, b.n, d ? d - 1 : 0);
        CHECK(statv(a.st.extra, "cores") < 0, "one core's statistics name cores: %s", a.st.extra);
        h = hash_stream(&b);
        rt_image_free(img);
    }
    coll_free(&b);
    run_free(&a);
    rt_job_free(&j);
    return h;
}

/* One pixel on 2 cores: one core's stream, all of it core 0's. */
static void one_pixel(void)
{
    rt_job j;
    if (setup(&j, 1, 1, 7, RT_QORDER_FULLEST) < 0) return;
    run a, b;
    if (run_job(&j, 1, &a) == 0 && run_job(&j, 2, &b) == 0) {
        size_t d = a.s.n == b.s.n ? 0 : 1;
        for (size_t i = 0; !d && i < a.s.n; i++)
            if (!same_access(&a.s.a[i], &b.s.a[i]) || b.s.core[i]) d = i + 1;
        CHECK(!d, "one pixel on 2 cores: %zu references, one core %zu, first difference at %zu", b.s.n, a.s.n,
              d ? d - 1 : 0);
        CHECK(statv(b.st.extra, "rays_moved") == 0 && statv(b.st.extra, "core_rays_min") == 0 &&
                  statv(b.st.extra, "core_rays_max") == statv(a.st.extra, "enqueues") &&
                  statv(b.st.extra, "rounds") == statv(a.st.extra, "queue_events") && statv(a.st.extra, "enqueues") >= 1,
              "one pixel on 2 cores: %s (one core: %s)", b.st.extra, a.st.extra);
    }
    run_free(&a);
    run_free(&b);
    rt_job_free(&j);
}

/* N cores against one: returns the N-core stream's hash. */
static uint64_t n_cores(int N, int qorder)
{
    rt_job j;
    if (setup(&j, 16, 12, 7, qorder) < 0) return 0;
    run a, b;
    uint64_t h = 0;
    if (run_job(&j, 1, &a) == 0 && run_job(&j, N, &b) == 0) {
        const char *x1 = a.st.extra, *xn = b.st.extra;
        const size_t np = 16 * 12;
        CHECK(!memcmp(a.img->rgb, b.img->rgb, 3 * np * sizeof(float)) &&
                  !memcmp(a.img->nodes, b.img->nodes, np * sizeof(float)) &&
                  !memcmp(a.img->tests, b.img->tests, np * sizeof(float)) &&
                  !memcmp(a.img->depth, b.img->depth, np * sizeof(float)),
              "%d cores: the image differs from one core's", N);
        CHECK(a.st.rays_primary == b.st.rays_primary && a.st.rays_shadow == b.st.rays_shadow &&
                  a.st.nodes == b.st.nodes && a.st.tests == b.st.tests && a.st.pv_all == b.st.pv_all,
              "%d cores: ray, node or test counts differ from one core's", N);
        const char *same[] = {"enqueues", "rays", "resolved", "queue_points"};
        for (int i = 0; i < 4; i++)
            CHECK(statv(x1, same[i]) >= 0 && statv(x1, same[i]) == statv(xn, same[i]), "%d cores: %s %lld, one core %lld", N,
                  same[i], statv(xn, same[i]), statv(x1, same[i]));
        const long long ev1 = statv(x1, "queue_events"), evn = statv(xn, "queue_events"), moved = statv(xn, "rays_moved");
        CHECK(statv(xn, "cores") == N && statv(xn, "rounds") > 0 && statv(xn, "rounds") <= evn &&
                  moved > 0 && moved <= statv(xn, "enqueues") && statv(xn, "bytes_moved") == 32 * moved &&
                  statv(xn, "core_rays_max") <= statv(xn, "enqueues") && statv(xn, "core_rays_min") <= statv(xn, "core_rays_max"),
              "%d cores: %s", N, xn);
        CHECK(b.s.n == a.s.n + 2 * (size_t)(evn - ev1), "%d cores: %zu references, one core %zu + 2 x %lld queue events", N,
              b.s.n, a.s.n, evn - ev1);
        CHECK(b.st.accesses == b.s.n, "%d cores: accesses %" PRIu64 " of %zu", N, b.st.accesses, b.s.n);
        for (int c = 0; c < RT_NCLASS; c++) {
            long long want = (long long)count_cls(&a.s, c);
            if (c == RT_CLS_RAY) want += moved;
            if (c == RT_CLS_QUEUE) want -= moved;
            if (c == RT_CLS_QTABLE) want += 2 * (evn - ev1);
            CHECK((long long)count_cls(&b.s, c) == want, "%d cores: class %d has %zu references, want %lld", N, c,
                  count_cls(&b.s, c), want);
        }
        /* every core makes references */
        uint64_t *per = calloc((size_t)N, sizeof *per);
        int bad_core = 0;
        for (size_t i = 0; i < b.s.n; i++) {
            if (b.s.core[i] >= N) bad_core = 1;
            else per[b.s.core[i]]++;
        }
        CHECK(!bad_core, "%d cores: a reference of core >= %d", N, N);
        for (int k = 0; k < N; k++) CHECK(per[k] > 0, "%d cores: core %d made no reference", N, k);
        free(per);
        /* a core's private ray buffer: above the layout for cores > 0 */
        const int rb = rt_mm_find(&j.L, "dyn.raybuf");
        const uint64_t lo = j.L.r[rb].base, hi = lo + 32ull * j.L.r[rb].count;
        const uint64_t span = (j.L.next - RT_MM_BASE + 4095) & ~(uint64_t)4095;
        size_t misplaced = 0;
        for (size_t i = 0; i < b.s.n; i++) {
            const uint64_t ad = b.s.a[i].addr, off = (uint64_t)b.s.core[i] * span;
            const int in_own = ad >= lo + off && ad < hi + off;
            const int in_any = ad >= lo && (ad - lo) % span < hi - lo && ad < lo + (uint64_t)N * span;
            if (in_any != in_own) misplaced++;
        }
        CHECK(!misplaced, "%d cores: %zu references in another core's ray buffer", N, misplaced);
        h = hash_stream(&b.s);
    }
    run_free(&a);
    run_free(&b);
    rt_job_free(&j);
    return h;
}

/* render --threads N: the N-core rounds on N host threads, untraced: the
 * image of one core, the statistics of the simulated N-core run. */
static void host_threads(int N, int qorder, unsigned lights)
{
    rt_job j;
    if (setup(&j, 16, 12, lights, qorder) < 0) return;
    run a, b;
    rt_err e = {0};
    if (run_job(&j, 1, &a) == 0 && run_job(&j, N, &b) == 0) {
        rt_image *img = rt_image_new(16, 12, &e);
        rt_run_stats st;
        j.opt.cores = 1;
        j.opt.host_threads = N;
        CHECK(img && rt_job_run(&j, NULL, img, &st, &e) == 0, "--threads %d: %s", N, e.msg);
        const size_t np = 16 * 12;
        CHECK(img && !memcmp(a.img->rgb, img->rgb, 3 * np * sizeof(float)) &&
                  !memcmp(a.img->nodes, img->nodes, np * sizeof(float)) &&
                  !memcmp(a.img->tests, img->tests, np * sizeof(float)) &&
                  !memcmp(a.img->depth, img->depth, np * sizeof(float)),
              "--threads %d: the image differs from one thread's", N);
        CHECK(!strcmp(st.extra, b.st.extra) && st.nodes == b.st.nodes && st.tests == b.st.tests &&
                  st.pv_all == b.st.pv_all && st.pv_primary == b.st.pv_primary && st.rays_shadow == b.st.rays_shadow,
              "--threads %d: statistics '%s', the %d-core run's '%s'", N, st.extra, N, b.st.extra);
        rt_image_free(img);
    }
    run_free(&a);
    run_free(&b);
    rt_job_free(&j);
}

int main(void)
{
    const uint64_t h1 = one_core();
    /* the one-core stream of knot 16 x 12, lights 7, cache 8 KB: the hash of the code before cores */
    CHECK(h1 == UINT64_C(0xb434c475143043a9), "one core's stream hash %016" PRIx64 " is not the golden one", h1);
    one_pixel();
    uint64_t h3 = 0;
    for (int N = 2; N <= 8; N = N == 3 ? 8 : N + 1) {
        uint64_t h = n_cores(N, RT_QORDER_FULLEST);
        if (N == 3) h3 = h;
        n_cores(N, RT_QORDER_TREE);
    }
    host_threads(2, RT_QORDER_FULLEST, 7);
    host_threads(3, RT_QORDER_TREE, 7);
    host_threads(8, RT_QORDER_FULLEST, 0);
    CHECK(h3 == UINT64_C(0xab8ff5d94c8c2a70), "3 cores' stream hash %016" PRIx64 " is not the golden one", h3);
    return failures ? 1 : 0;
}
