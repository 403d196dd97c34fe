/*
 * test_tcores.c -- tracers that split their own work over simulated cores
 * (cores.h: treelet, stream-branching, stream-multipass, feedback).
 *
 *   - the chunk rule against its definition written out, and by hand
 *     (10 items on 4 cores: 0-1, 2-4, 5-6, 7-9);
 *   - the phase interleave by hand: what rt_cores hands its sink for
 *     streams written out reference by reference (ticks of 16, a done core
 *     drops out, nothing crosses a barrier), the incremental sync, the
 *     turn order of rt_cores_steps; the checker rejects a core left done
 *     (C1), a miscount (C2), a reference after a core's phase (C3) and
 *     an item claimed by a core outside its chunk (C4);
 *   - per tracer, mode and core count (1, 2, 3, 8), in test mode (the
 *     tracers' own invariant checks run): one core is the one-core run
 *     reference for reference (all core 0); on N cores the image and the
 *     rays, node visits and triangle tests are one core's, the stream and
 *     feedback tracers make exactly one core's references (the same
 *     multiset: every ray traced once, by one core), the treelet tracer
 *     the same geometry references; the interleave's hash is golden
 *     (cornell 24 x 24, all lights, 3 cores);
 *   - the split by hand: on a 5 x 2 image on 4 cores, who touches the
 *     stencil, the ray state and the vertex-buffer records of item i.
 * The treelet tracer's rule (treelet t on core t mod N) and its T7 are
 * checked in tests/test_treelet_check.c, beside its other invariants.
 */
#include "check.h"
#include "cores.h"
#include "run.h"
#include "trace.h"
#include "coll.h"

#include <inttypes.h>

static int cmp_access(const void *p, const void *q)
{
    const rt_access *x = p, *y = q;
    if (x->addr != y->addr) return x->addr < y->addr ? -1 : 1;
    if (x->size != y->size) return x->size < y->size ? -1 : 1;
    if (x->write != y->write) return x->write < y->write ? -1 : 1;
    if (x->cls != y->cls) return x->cls < y->cls ? -1 : 1;
    return (int)x->gen - (int)y->gen;
}

/* ---- the chunk rule ---------------------------------------------------------- */

static void test_chunks(void)
{
    const uint64_t hand[5] = {0, 2, 5, 7, 10};
    for (int k = 0; k <= 4; k++) CHECK(rt_cores_lo(10, 4, k) == hand[k], "lo(10, 4, %d) = %" PRIu64, k, rt_cores_lo(10, 4, k));
    const int own[10] = {0, 0, 1, 1, 1, 2, 2, 3, 3, 3};
    for (uint64_t i = 0; i < 10; i++) CHECK(rt_cores_owner(i, 10, 4) == own[i], "owner(%" PRIu64 ", 10, 4)", i);
    for (uint64_t n = 1; n <= 40; n++)
        for (int N = 1; N <= 9; N++) {
            uint64_t covered = 0;
            for (int k = 0; k < N; k++) {
                const uint64_t lo = n * (uint64_t)k / (uint64_t)N, hi = n * (uint64_t)(k + 1) / (uint64_t)N;
                CHECK(rt_cores_lo(n, N, k) == lo && hi >= lo, "n %" PRIu64 " N %d k %d", n, N, k);
                for (uint64_t i = lo; i < hi; i++) {
                    CHECK(rt_cores_owner(i, n, N) == k, "owner(%" PRIu64 ", %" PRIu64 ", %d) != %d", i, n, N, k);
                    covered++;
                }
            }
            CHECK(covered == n && rt_cores_lo(n, N, N) == n, "n %" PRIu64 " N %d: %" PRIu64 " items covered", n, N,
                  covered);
        }
}

/* ---- the phase interleave by hand ----------------------------------------------- */

static void rec_n(rt_rec *r, uint64_t from, int n)
{
    for (int i = 0; i < n; i++) RT_REC(r, from + (uint64_t)i, 4, 0, RT_CLS_NODE);
}

/* got[from..] is core `core`'s addresses lo..lo+n-1; returns from + n. */
static size_t expect_run(const coll *got, size_t from, unsigned core, uint64_t lo, int n, const char *what)
{
    int bad = from + (size_t)n > got->n;
    for (int i = 0; !bad && i < n; i++) bad = got->core[from + i] != core || got->a[from + i].addr != lo + (uint64_t)i;
    CHECK(!bad, "%s: want core %u addresses %" PRIu64 "..%" PRIu64 " at %zu", what, core, lo, lo + (uint64_t)n - 1,
          from);
    return from + (size_t)n;
}

typedef struct step_log {
    rt_cores *c;
    int k[16];
    uint64_t i[16];
    int n;
} step_log;

static int step_fn(void *u, int k, uint64_t i)
{
    step_log *l = u;
    if (l->n < 16) {
        l->k[l->n] = k;
        l->i[l->n++] = i;
    }
    rec_n(rt_cores_rec(l->c, k), 1000 + i, 1);
    return 0;
}

static void test_interleave(void)
{
    rt_err e = {0};
    coll got = {0};
    rt_csink cs = {coll_cput, &got};
    rt_cores c;
    rt_rec *r[3];
    CHECK(rt_cores_init(&c, 3, &cs, &e) == 0, "init: %s", e.msg);
    for (int k = 0; k < 3; k++) {
        r[k] = rt_rec_new(rt_cores_sink(&c, k), &e);
        rt_cores_set_rec(&c, k, r[k], r[k]);
    }
    /* phase 1: core 0 20 references, core 1 5, core 2 none */
    rec_n(r[0], 0, 20);
    rec_n(r[1], 100, 3);
    CHECK(rt_cores_sync(&c) == 0 && got.n == 0, "sync emitted %zu before core 1's tick was there", got.n);
    rec_n(r[1], 103, 2);
    rt_cores_done(&c, 1);
    rt_cores_done(&c, 2);
    CHECK(rt_cores_sync(&c) == 0 && got.n == 21, "sync: %zu references, want one tick of 16 + 5", got.n);
    CHECK(rt_cores_check(&c, &e) < 0 && strstr(e.msg, "C1"), "a phase in progress passes C1: '%s'", e.msg);
    CHECK(rt_cores_barrier(&c) == 0, "barrier");
    size_t at = expect_run(&got, 0, 0, 0, 16, "tick 1, core 0");
    at = expect_run(&got, at, 1, 100, 5, "tick 1, core 1");
    at = expect_run(&got, at, 0, 16, 4, "tick 2, core 0");
    CHECK(got.n == 25 && c.ticks == 2 && c.phases == 1, "phase 1: %zu references in %" PRIu64 " ticks", got.n, c.ticks);
    CHECK(rt_cores_check(&c, &e) == 0, "between phases: %s", e.msg);
    /* phase 2: nothing of phase 1 is left; core 2 17, core 0 1 */
    rec_n(r[2], 200, 17);
    rec_n(r[0], 50, 1);
    CHECK(rt_cores_barrier(&c) == 0, "barrier 2");
    at = expect_run(&got, at, 0, 50, 1, "phase 2 tick 1, core 0");
    at = expect_run(&got, at, 2, 200, 16, "phase 2 tick 1, core 2");
    at = expect_run(&got, at, 2, 216, 1, "phase 2 tick 2, core 2");
    CHECK(at == got.n, "phase 2: %zu references, want %zu", got.n, at);
    /* the turn order: 5 items on the 3 cores, chunks 0, 1-2 and 3-4 */
    step_log l = {.c = &c};
    CHECK(rt_cores_steps(&c, 5, step_fn, &l) == 0, "steps");
    const int wk[5] = {0, 1, 2, 1, 2};
    const uint64_t wi[5] = {0, 1, 3, 2, 4};
    CHECK(l.n == 5, "steps called fn %d times", l.n);
    for (int s = 0; s < 5 && s < l.n; s++) CHECK(l.k[s] == wk[s] && l.i[s] == wi[s], "step %d: core %d item %" PRIu64, s, l.k[s], l.i[s]);
    CHECK(rt_cores_check(&c, &e) == 0, "after steps: %s", e.msg);
    /* the checker's corruptions */
    c.buf[1].done = 1;
    CHECK(rt_cores_check(&c, &e) < 0 && strstr(e.msg, "C1"), "a core left done: '%s'", e.msg);
    c.buf[1].done = 0;
    c.emitted++;
    CHECK(rt_cores_check(&c, &e) < 0 && strstr(e.msg, "C2"), "emitted miscounted: '%s'", e.msg);
    c.emitted--;
    rt_cores_claim(&c, 2, 6, 10); /* item 6 of 10 on 3 cores: core 1's chunk is 3-5, core 2's 6-9 */
    CHECK(rt_cores_check(&c, &e) == 0, "a claim of one's own item: %s", e.msg);
    rt_cores_claim(&c, 1, 6, 10);
    CHECK(rt_cores_check(&c, &e) < 0 && strstr(e.msg, "C4") && strstr(e.msg, "item 6 of 10 by core 1"),
          "an item claimed by another core: '%s'", e.msg);
    c.bad_claims = 0;
    rt_cores_done(&c, 2);
    rec_n(r[2], 300, 1);
    rt_cores_sync(&c);
    rt_cores_barrier(&c);
    CHECK(rt_cores_check(&c, &e) < 0 && strstr(e.msg, "C3"), "a reference after the core's phase: '%s'", e.msg);
    for (int k = 0; k < 3; k++) rt_rec_free(r[k]);
    rt_cores_free(&c);
    coll_free(&got);
}

/* ---- the tracers ------------------------------------------------------------------ */

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

/* The references of classes node and triangle, sorted. */
static size_t geometry(const coll *c, rt_access *out)
{
    size_t n = 0;
    for (size_t i = 0; i < c->n; i++)
        if (c->a[i].cls == RT_CLS_NODE || c->a[i].cls == RT_CLS_TRI) out[n++] = c->a[i];
    qsort(out, n, sizeof *out, cmp_access);
    return n;
}

static void opts_for(rt_render_opts *o, int mode, int W, int H)
{
    rt_render_default_opts(o);
    o->W = W;
    o->H = H;
    o->lights = 7;
    o->mode = mode;
    o->depth = 3;
    o->bounces = 2;
}

/* Runs tracer on `cores` cores into got (test mode) and one core into one;
 * returns the interleave's hash (0 on failure). */
static uint64_t check_one(const char *tracer, int mode, int cores, int W, int H)
{
    rt_render_opts o;
    opts_for(&o, mode, W, H);
    o.cores = cores;
    if (!strcmp(tracer, "treelet")) o.sched_size = 2048; /* several treelets */
    rt_err e = {0};
    rt_job j;
    if (rt_job_setup(&j, "cornell", tracer, &o, &e) < 0) {
        CHECK(0, "%s: %s", tracer, e.msg);
        return 0;
    }
    j.check = 1;
    const size_t np = (size_t)W * (size_t)H;
    rt_image *img = rt_image_new(W, H, &e), *ref = rt_image_new(W, H, &e);
    rt_run_stats st, s1;
    coll got = {0}, one = {0};
    rt_csink cs = {coll_cput, &got};
    CHECK(rt_job_run_cores(&j, &cs, img, &st, &e) == 0, "%s mode %d on %d cores: %s", tracer, mode, cores, e.msg);
    CHECK(st.accesses == got.n, "%s: accesses %" PRIu64 " of %zu", tracer, st.accesses, got.n);
    j.opt.cores = 1;
    rt_sink s = {coll_put, &one};
    CHECK(rt_job_run(&j, &s, ref, &s1, &e) == 0, "%s: %s", tracer, e.msg);
    if (cores == 1) {
        size_t d = got.n == one.n ? 0 : 1;
        for (size_t i = 0; i < one.n && !d; i++)
            if (!same_access(&one.a[i], &got.a[i]) || got.core[i]) d = i + 1;
        CHECK(!d, "%s mode %d: one core differs from the one-core run at %zu (%zu against %zu references)", tracer, mode,
              d - 1, got.n, one.n);
    } else {
        size_t hi = 0;
        for (size_t i = 0; i < got.n; i++) hi = got.core[i] > hi ? got.core[i] : hi;
        CHECK(hi == (size_t)cores - 1 || (size_t)cores > np, "%s on %d cores: the highest core seen is %zu", tracer, cores, hi);
    }
    if (strcmp(tracer, "treelet")) { /* the same references, by whichever core */
        CHECK(got.n == one.n, "%s mode %d on %d cores: %zu references, one core %zu", tracer, mode, cores, got.n, one.n);
        if (got.n == one.n) {
            rt_access *x = malloc(got.n * sizeof *x + 1), *y = malloc(one.n * sizeof *y + 1);
            memcpy(x, got.a, got.n * sizeof *x);
            memcpy(y, one.a, one.n * sizeof *y);
            qsort(x, got.n, sizeof *x, cmp_access);
            qsort(y, one.n, sizeof *y, cmp_access);
            size_t d = 0;
            for (size_t i = 0; i < got.n && !d; i++)
                if (!same_access(&x[i], &y[i])) d = i + 1;
            CHECK(!d, "%s mode %d on %d cores: not one core's references (sorted, first difference at %zu)", tracer, mode,
                  cores, d - 1);
            free(x);
            free(y);
        }
    } else { /* every ray walks its nodes and triangles once */
        rt_access *x = malloc(got.n * sizeof *x + 1), *y = malloc(one.n * sizeof *y + 1);
        size_t nx = geometry(&got, x), ny = geometry(&one, y), d = nx == ny ? 0 : 1;
        for (size_t i = 0; i < nx && !d; i++)
            if (!same_access(&x[i], &y[i])) d = i + 1;
        CHECK(!d, "treelet mode %d on %d cores: geometry references differ from one core's (%zu, %zu)", mode, cores, nx,
              ny);
        free(x);
        free(y);
    }
    CHECK(!memcmp(img->rgb, ref->rgb, 3 * np * sizeof(float)) && !memcmp(img->depth, ref->depth, np * sizeof(float)),
          "%s mode %d on %d cores: the image differs from one core's", tracer, mode, cores);
    CHECK(st.rays_primary == s1.rays_primary && st.rays_shadow == s1.rays_shadow && st.nodes == s1.nodes &&
              st.tests == s1.tests && st.pv_all == s1.pv_all,
          "%s mode %d on %d cores: rays, visits or tests differ from one core's", tracer, mode, cores);
    /* untraced on N cores: the same image and counts */
    j.opt.cores = cores;
    rt_run_stats su;
    rt_image *un = rt_image_new(W, H, &e);
    CHECK(rt_job_run(&j, NULL, un, &su, &e) == 0 && !memcmp(un->rgb, ref->rgb, 3 * np * sizeof(float)) &&
              su.nodes == s1.nodes && (cores == 1 || strstr(su.extra, "cores=")),
          "%s on %d cores untraced: %s '%s'", tracer, cores, e.msg, su.extra);
    rt_image_free(un);
    uint64_t h = hash_stream(&got);
    coll_free(&got);
    coll_free(&one);
    rt_image_free(img);
    rt_image_free(ref);
    rt_job_free(&j);
    return h;
}

/* The split by hand: 5 x 2 primary rays on 4 cores, the ten items in chunks
 * 0-1, 2-4, 5-6, 7-9. Item i is: multipass, stream slot i (its stencil and
 * state); branching, the i-th pixel of the Hilbert order (its state record
 * is the pixel's); feedback, record i of the first pass's input (the
 * fill's buffer, vb.read). */
static void check_split(const char *tracer, const char *region)
{
    const int own[10] = {0, 0, 1, 1, 1, 2, 2, 3, 3, 3};
    rt_render_opts o;
    opts_for(&o, RT_MODE_RAYCAST, 5, 2);
    o.lights = 0;
    o.cores = 4;
    rt_err e = {0};
    rt_job j;
    if (rt_job_setup(&j, "cornell", tracer, &o, &e) < 0) {
        CHECK(0, "%s: %s", tracer, e.msg);
        return;
    }
    uint32_t order[10], rank[10];
    CHECK(rt_pixel_order(&j.opt, order) == 10, "10 pixels");
    for (int k = 0; k < 10; k++) rank[order[k]] = (uint32_t)k;
    const int branching = !strcmp(tracer, "stream-branching");
    coll got = {0};
    rt_csink cs = {coll_cput, &got};
    rt_image *img = rt_image_new(5, 2, &e);
    rt_run_stats st;
    CHECK(rt_job_run_cores(&j, &cs, img, &st, &e) == 0, "%s: %s", tracer, e.msg);
    const int g = rt_mm_find(&j.L, region);
    CHECK(g >= 0, "%s: no region %s", tracer, region);
    size_t seen = 0, wrong = 0;
    for (size_t i = 0; g >= 0 && i < got.n; i++) {
        const rt_region *x = &j.L.r[g];
        const rt_access *a = &got.a[i];
        if (a->addr < x->base || a->addr >= x->base + (uint64_t)x->recsize * x->count) continue;
        if (!strcmp(region, "vb.read") && a->write) continue; /* the fill writes it: read in pass 1 */
        uint64_t item = (a->addr - x->base) / x->recsize;
        if (item >= 10) continue;
        if (branching) item = rank[item];
        seen++;
        if (got.core[i] != own[item]) wrong++;
    }
    CHECK(seen >= 10 && !wrong, "%s: %zu of %zu references to %s made by another core than their item's", tracer, wrong,
          seen, region);
    coll_free(&got);
    rt_image_free(img);
    rt_job_free(&j);
}

int main(void)
{
    test_chunks();
    test_interleave();
    const char *tracers[] = {"treelet", "stream-branching", "stream-multipass", "feedback"};
    const int counts[] = {1, 2, 3, 8};
    for (int t = 0; t < 4; t++) {
        for (int c = 0; c < 4; c++) check_one(tracers[t], RT_MODE_SHADOW, counts[c], 12, 10);
        check_one(tracers[t], RT_MODE_WHITTED, 3, 10, 8);
        if (t != 3) check_one(tracers[t], RT_MODE_PATH, 2, 8, 8); /* feedback: no path mode */
        check_one(tracers[t], RT_MODE_RAYCAST, 1, 8, 8);
    }
    check_split("stream-multipass", "stream.stencil");
    check_split("stream-multipass", "stream.state");
    check_split("stream-branching", "stream.state");
    check_split("feedback", "vb.read");
    /* golden: the interleave of cornell 24 x 24, all lights, 3 cores */
    const uint64_t golden[4] = {0x5799d8705c98871bull, 0xf0f13e68d07e5886ull, 0xb5b76181e0f72f42ull, 0x2a5f47661f18b247ull};
    for (int t = 0; t < 4; t++) {
        uint64_t h = check_one(tracers[t], RT_MODE_SHADOW, 3, 24, 24);
        if (getenv("RT_PRINT_GOLDEN")) printf("%s 0x%016" PRIx64 "\n", tracers[t], h);
        CHECK(h == golden[t], "%s: interleave hash %016" PRIx64 ", golden %016" PRIx64, tracers[t], h, golden[t]);
    }
    return failures ? 1 : 0;
}
