/*
 * test_cores.c -- simulated cores (rt_job_run_cores, run.h).
 *
 *   - the interleave against a naive merge: each core's references from a
 *     run of its share alone (rt_job_run_part), merged by the rule written
 *     out here (a tick: 16 references of every running core, cores in
 *     order), equal, reference for reference and core for core, what
 *     rt_job_run_cores hands its sink, for every work-share tracer, several
 *     core counts (1, 2, 3, 8, and more cores than share tiles) and modes;
 *   - N = 1 is the one-core run: the same references as rt_job_run; on N
 *     cores recursive and packet make the same number of references;
 *   - the image and the statistics are those of one core;
 *   - each core has its own copy of the scratch regions (hits, stacks,
 *     queues) above the layout, geometry stays where it is;
 *   - the interleave is the same on every machine: a golden FNV-1a hash of
 *     (core, address, size, write, class, generation) for cornell 24 x 24
 *     with all lights on 3 cores, per tracer.
 * The tracers that split their own work over the cores (treelet, the
 * stream tracers, feedback) are tests/test_tcores.c's.
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

/* Returns the interleaved stream's hash (0 on failure). */
static uint64_t check_one(const char *tracer, int mode, int cores, int W, int H)
{
    rt_render_opts o;
    rt_render_default_opts(&o);
    o.W = W;
    o.H = H;
    o.lights = 7;
    o.mode = mode;
    o.depth = 3;
    o.bounces = 2;
    o.packet = 4;
    o.cores = cores;
    rt_err e = {0};
    rt_job j;
    if (rt_job_setup(&j, "cornell", tracer, &o, &e) < 0) {
        CHECK(0, "%s: %s", tracer, e.msg);
        return 0;
    }
    size_t np = (size_t)W * (size_t)H;
    rt_image *img = rt_image_new(W, H, &e), *ref = rt_image_new(W, H, &e);
    rt_run_stats st, s1;
    coll got = {0}, one = {0};
    rt_csink cs = {coll_cput, &got};
    CHECK(rt_job_run_cores(&j, &cs, img, &st, &e) == 0, "%s on %d cores: %s", tracer, cores, e.msg);
    /* the naive merge of the cores' own streams */
    coll *part = calloc((size_t)cores, sizeof *part);
    for (int k = 0; k < cores; k++) {
        rt_sink s = {coll_put, &part[k]};
        rt_run_stats ps;
        rt_image *pi = rt_image_new(W, H, &e);
        CHECK(rt_job_run_part(&j, &s, k, cores, pi, &ps, &e) == 0, "part %d: %s", k, e.msg);
        rt_image_free(pi);
    }
    coll want = {0};
    size_t *pos = calloc((size_t)cores, sizeof *pos);
    for (int left = cores; left > 0;) {
        left = 0;
        for (int k = 0; k < cores; k++) {
            size_t m = part[k].n - pos[k];
            if (!m) continue;
            if (m > RT_CORE_TICK) m = RT_CORE_TICK;
            coll_add(&want, (unsigned)k, part[k].a + pos[k], m);
            pos[k] += m;
            left++;
        }
    }
    size_t bad = got.n == want.n ? 0 : 1;
    for (size_t i = 0; !bad && i < got.n; i++)
        if (!same_access(&got.a[i], &want.a[i]) || got.core[i] != want.core[i]) bad = i + 1;
    CHECK(!bad, "%s mode %d on %d cores: %zu references, the naive merge %zu; first difference at %zu", tracer, mode,
          cores, got.n, want.n, bad ? bad - 1 : 0);
    CHECK(st.accesses == got.n, "%s: accesses %" PRIu64 " of %zu", tracer, st.accesses, got.n);
    /* scratch regions: each core above the layout its own copy; geometry and per-pixel records shared */
    size_t misplaced = 0;
    for (size_t i = 0; i < got.n; i++) {
        const unsigned c = got.a[i].cls;
        const int scratch = c == RT_CLS_HIT || c == RT_CLS_STREAM || c == RT_CLS_QUEUE || c == RT_CLS_QTABLE;
        const int geo = rt_class_group((int)c) == RT_GROUP_GEOMETRY;
        if ((geo && got.a[i].addr >= j.L.next) || (scratch && got.core[i] > 0 && got.a[i].addr < j.L.next) ||
            (scratch && got.core[i] == 0 && got.a[i].addr >= j.L.next))
            misplaced++;
    }
    CHECK(!misplaced, "%s on %d cores: %zu references in the wrong copy of their region", tracer, cores, misplaced);
    /* one core's run: the same references in total, the same image and statistics */
    j.opt.cores = 1;
    rt_sink s = {coll_put, &one};
    CHECK(rt_job_run(&j, &s, ref, &s1, &e) == 0, "%s: %s", tracer, e.msg);
    /* recursive, packet: a pixel's references do not depend on the others */
    CHECK(one.n == got.n, "%s on %d cores: %zu references, one core %zu", tracer, cores, got.n, one.n);
    if (cores == 1) {
        size_t d = 0;
        for (size_t i = 0; i < one.n && !d; i++)
            if (!same_access(&one.a[i], &got.a[i]) || got.core[i]) d = i + 1;
        CHECK(!d, "%s: one core differs from rt_job_run at %zu", tracer, d - 1);
    }
    CHECK(!memcmp(img->rgb, ref->rgb, 3 * np * sizeof(float)) && !memcmp(img->nodes, ref->nodes, np * sizeof(float)) &&
              !memcmp(img->tests, ref->tests, np * sizeof(float)) && !memcmp(img->depth, ref->depth, np * sizeof(float)),
          "%s on %d cores: the image differs from one core's", tracer, cores);
    CHECK(st.rays_primary == s1.rays_primary && st.rays_shadow == s1.rays_shadow && st.nodes == s1.nodes &&
              st.tests == s1.tests && st.pv_primary == s1.pv_primary && st.pv_all == s1.pv_all,
          "%s on %d cores: statistics differ from one core's", tracer, cores);
    uint64_t h = hash_stream(&got);
    for (int k = 0; k < cores; k++) {
        free(part[k].a);
        free(part[k].core);
    }
    free(part);
    free(pos);
    free(want.a);
    free(want.core);
    free(got.a);
    free(got.core);
    free(one.a);
    free(one.core);
    rt_image_free(img);
    rt_image_free(ref);
    rt_job_free(&j);
    return h;
}

int main(void)
{
    const char *tracers[] = {"recursive", "packet"};
    const int counts[] = {1, 2, 3, 8, 40};
    for (int t = 0; t < 2; t++) {
        for (int c = 0; c < 5; c++) check_one(tracers[t], RT_MODE_SHADOW, counts[c], 20, 12);
        check_one(tracers[t], RT_MODE_WHITTED, 3, 16, 16);
        check_one(tracers[t], RT_MODE_PATH, 2, 16, 8);
    }
    /* golden: the interleave of cornell 24 x 24, all lights, 3 cores */
    const uint64_t golden[2] = {0x08e8ee1d1a565931ull, 0x995d4bb2f547659aull};
    for (int t = 0; t < 2; t++) {
        uint64_t h = check_one(tracers[t], RT_MODE_SHADOW, 3, 24, 24);
        if (getenv("RT_PRINT_GOLDEN")) printf("%s 0x%016" PRIx64 "\n", tracers[t], h);
        CHECK(h == golden[t], "%s: interleave hash %016" PRIx64 ", golden %016" PRIx64, tracers[t], h, golden[t]);
    }
    return failures ? 1 : 0;
}
