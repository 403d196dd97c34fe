/*
 * test_threads.c -- host threads (rt_job_run with opt.host_threads > 1) and
 * the work shares behind them (pixels.h).
 *
 *   - rt_pixel_order_part: for several part counts, the parts together are
 *     exactly rt_pixel_order's pixels, each once, each part in that order,
 *     share tile t in part t mod n (checked against a direct deal);
 *   - every tracer of the RT_OPTG_THREADS group, on small scenes in every
 *     mode it runs, on 2, 3 and 7 threads: the image (RGB, depth, both cost
 *     channels) bit for bit the one-thread image, and the rays, node visits,
 *     triangle tests and potentially visible sets equal;
 *   - the refusals: a traced run and a tracer outside the group.
 */
#include "scene_load.h"
#include "check.h"
#include "run.h"

#include <inttypes.h>

static int same_plane(const float *a, const float *b, size_t n) { return !memcmp(a, b, n * sizeof *a); }

static void check_partition(int W, int H, uint32_t sub, int tile)
{
    rt_render_opts o;
    rt_render_default_opts(&o);
    o.W = W;
    o.H = H;
    o.subsample = sub;
    o.subtile = tile;
    size_t np = (size_t)W * (size_t)H;
    uint32_t *all = calloc(np, sizeof *all), *part = calloc(np, sizeof *part);
    uint8_t *seen = calloc(np, 1);
    size_t n = rt_pixel_order(&o, all);
    for (int parts = 1; parts <= 9; parts++) {
        memset(seen, 0, np);
        size_t total = 0;
        for (int p = 0; p < parts; p++) {
            size_t m = rt_pixel_order_part(&o, p, parts, part);
            /* the direct deal: share tile t to part t mod parts, in order */
            size_t k = 0, bad = 0;
            for (size_t i = 0; i < n; i++)
                if ((int)((i / RT_SHARE_TILE) % (size_t)parts) == p) {
                    if (k >= m || part[k] != all[i]) bad++;
                    k++;
                }
            CHECK(k == m && !bad, "%dx%d sub %u: part %d of %d has %zu pixels, deal %zu, %zu misplaced", W, H, sub, p,
                  parts, m, k, bad);
            for (size_t i = 0; i < m; i++) seen[part[i]]++;
            total += m;
        }
        size_t once = 0;
        for (size_t i = 0; i < n; i++) once += seen[all[i]] == 1;
        CHECK(total == n && once == n, "%dx%d: %d parts cover %zu of %zu pixels (%zu once)", W, H, parts, total, n, once);
    }
    free(all);
    free(part);
    free(seen);
}

static void run_job(rt_job *j, int threads, rt_image *img, rt_run_stats *st)
{
    rt_err e = {0};
    j->opt.host_threads = threads;
    CHECK(rt_job_run(j, NULL, img, st, &e) == 0, "%s on %d threads: %s", j->tr->name, threads, e.msg);
}

static void check_tracer(const char *scene, const char *tracer, int mode)
{
    rt_render_opts o;
    rt_render_default_opts(&o);
    o.W = 40;
    o.H = 28; /* not a power of two: Hilbert tiles cut by the edges */
    o.lights = 7;
    o.mode = mode;
    o.spp = 2;
    o.depth = 3;
    o.bounces = 2;
    o.packet = 4;
    rt_err e = {0};
    rt_job j;
    if (rt_job_setup(&j, scene, tracer, &o, &e) < 0) {
        CHECK(0, "%s %s: %s", scene, tracer, e.msg);
        return;
    }
    rt_image *ref = rt_image_new(o.W, o.H, &e);
    rt_run_stats s1;
    run_job(&j, 1, ref, &s1);
    CHECK(s1.rays_primary == (uint64_t)o.W * (uint64_t)o.H * (mode == RT_MODE_PATH ? 2u : 1u), "%s: %" PRIu64 " primary",
          tracer, s1.rays_primary);
    const int counts[] = {2, 3, 7};
    for (int c = 0; c < 3; c++) {
        rt_image *img = rt_image_new(o.W, o.H, &e);
        rt_run_stats sn;
        run_job(&j, counts[c], img, &sn);
        size_t n = (size_t)o.W * (size_t)o.H;
        CHECK(same_plane(ref->rgb, img->rgb, 3 * n) && same_plane(ref->depth, img->depth, n) &&
                  same_plane(ref->nodes, img->nodes, n) && same_plane(ref->tests, img->tests, n),
              "%s %s mode %d: the image of %d threads differs from one thread's", scene, tracer, mode, counts[c]);
        CHECK(sn.rays_primary == s1.rays_primary && sn.rays_shadow == s1.rays_shadow && sn.nodes == s1.nodes &&
                  sn.tests == s1.tests && sn.pv_primary == s1.pv_primary && sn.pv_all == s1.pv_all,
              "%s %s mode %d, %d threads: rays %" PRIu64 "+%" PRIu64 " nodes %" PRIu64 " tests %" PRIu64 " pv %" PRIu64
              "/%" PRIu64 ", one thread %" PRIu64 "+%" PRIu64 " %" PRIu64 " %" PRIu64 " %" PRIu64 "/%" PRIu64,
              scene, tracer, mode, counts[c], sn.rays_primary, sn.rays_shadow, sn.nodes, sn.tests, sn.pv_primary,
              sn.pv_all, s1.rays_primary, s1.rays_shadow, s1.nodes, s1.tests, s1.pv_primary, s1.pv_all);
        rt_image_free(img);
    }
    rt_image_free(ref);
    rt_job_free(&j);
}

static int null_put(rt_sink *s, const rt_access *a, size_t n)
{
    (void)s;
    (void)a;
    (void)n;
    return 0;
}

static void check_refusals(void)
{
    rt_render_opts o;
    rt_render_default_opts(&o);
    o.W = o.H = 16;
    rt_err e = {0};
    rt_job j;
    CHECK(rt_job_setup(&j, "cornell", "recursive", &o, &e) == 0, "%s", e.msg);
    rt_image *img = rt_image_new(16, 16, &e);
    rt_run_stats st;
    rt_sink ns = {null_put, NULL};
    j.opt.host_threads = 2;
    CHECK(rt_job_run(&j, &ns, img, &st, &e) < 0 && e.usage && strstr(e.msg, "--threads"), "traced run on 2 threads: '%s'",
          e.msg);
    rt_job_free(&j);
    memset(&e, 0, sizeof e);
    CHECK(rt_job_setup(&j, "cornell", "dynamic", &o, &e) == 0, "%s", e.msg);
    j.opt.host_threads = 2;
    /* the dynamic tracer: its 2-core rounds on 2 host threads (tests/test_dynamic_cores) */
    CHECK(rt_job_run(&j, NULL, img, &st, &e) == 0 && strstr(st.extra, " cores=2 rounds="), "dynamic on 2 threads: '%s' '%s'",
          e.msg, st.extra);
    rt_job_free(&j);
    rt_image_free(img);
}

int main(void)
{
    check_partition(64, 64, 1, 8);
    check_partition(37, 23, 1, 8);
    check_partition(50, 40, 3, 4);
    const char *scenes[] = {"cornell", "sphereflake:level=2"};
    for (int s = 0; s < 2; s++) {
        for (int m = RT_MODE_RAYCAST; m <= RT_MODE_PATH; m++) {
            check_tracer(scenes[s], "recursive", m);
            check_tracer(scenes[s], "packet", m);
            check_tracer(scenes[s], "treelet", m);
        }
    }
    check_refusals();
    return failures ? 1 : 0;
}
