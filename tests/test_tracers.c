/* test_tracers.c -- the three tracers agree: identical RGB images on every
 * built-in scene (reduced size) for several schedules; the dynamic
 * scheduler's queue-point selection matches the paper's Figure 1; every ray
 * of every generation is resolved exactly once; with the root as the only
 * queue point the dynamic tracer reads exactly the geometry the recursive
 * tracer reads, in the same order. */
#include "check.h"
#include "dynamic.h"
#include "run.h"

#include <inttypes.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static rt_image *render(rt_scene *sc, rt_kdtree *kd, const char *tracer, rt_render_opts *o, rt_sink *sink,
                        rt_run_stats *st)
{
    rt_err e = {""};
    rt_job j;
    if (rt_job_setup_borrowed(&j, sc, kd, tracer, o, &e) < 0) {
        CHECK(0, "setup %s: %s", tracer, e.msg);
        return NULL;
    }
    rt_image *im = rt_image_new(o->W, o->H, &e);
    if (!im || rt_job_run(&j, sink, im, st, &e) < 0) {
        CHECK(0, "run %s: %s", tracer, e.msg);
        rt_image_free(im);
        im = NULL;
    }
    rt_job_free(&j);
    return im;
}

static size_t count_diff(const rt_image *a, const rt_image *b)
{
    size_t n = 0;
    for (size_t i = 0; i < (size_t)a->W * a->H * 3; i++) n += memcmp(&a->rgb[i], &b->rgb[i], sizeof(float)) != 0;
    return n;
}

static void same_images(const char *spec, int W, int H)
{
    rt_err e = {""};
    rt_scene *sc = rt_scene_load(spec, &e);
    CHECK(sc != NULL, "%s: %s", spec, e.msg);
    if (!sc) return;
    rt_kd_params kp;
    rt_kd_default_params(&kp);
    rt_kdtree *kd = rt_kd_build(sc, &kp, &e);
    CHECK(kd != NULL, "%s: %s", spec, e.msg);
    rt_render_opts o;
    rt_render_default_opts(&o);
    o.W = W;
    o.H = H;
    o.lights = 7;
    rt_run_stats st;
    rt_image *ref = render(sc, kd, "recursive", &o, NULL, &st);
    uint64_t shadow_rays = st.rays_shadow;
    rt_image *pk = render(sc, kd, "packet", &o, NULL, &st);
    if (ref && pk) CHECK(count_diff(ref, pk) == 0, "%s: packet differs in %zu values", spec, count_diff(ref, pk));
    CHECK(st.rays_shadow == shadow_rays, "%s: packet traced %" PRIu64 " shadow rays, recursive %" PRIu64, spec,
          st.rays_shadow, shadow_rays);
    rt_image_free(pk);
    o.packet = 5; /* packets that do not tile the image evenly */
    pk = render(sc, kd, "packet", &o, NULL, &st);
    if (ref && pk) CHECK(count_diff(ref, pk) == 0, "%s: 5x5 packet differs", spec);
    rt_image_free(pk);
    static const uint64_t caches[] = {1024, 16384, 262144, 4u << 20};
    for (int qo = 0; qo < 2; qo++) {
        for (size_t c = 0; c < sizeof caches / sizeof caches[0]; c++) {
            o.cache_size = caches[c];
            o.qorder = qo;
            rt_image *dy = render(sc, kd, "dynamic", &o, NULL, &st);
            if (ref && dy)
                CHECK(count_diff(ref, dy) == 0, "%s: dynamic (cache %" PRIu64 ", qorder %d) differs in %zu values", spec,
                      caches[c], qo, count_diff(ref, dy));
            /* every ray resolved exactly once (the tracer also checks per pixel) */
            uint64_t rays = 0, resolved = 0;
            const char *p = strstr(st.extra, " rays="), *q = strstr(st.extra, " resolved=");
            CHECK(p && q, "%s: dynamic statistics lack ray counts: %s", spec, st.extra);
            if (p && q) {
                rays = strtoull(p + 6, NULL, 10);
                resolved = strtoull(q + 10, NULL, 10);
            }
            CHECK(rays == resolved && rays == st.rays_primary + st.rays_shadow,
                  "%s: dynamic created %" PRIu64 " rays, resolved %" PRIu64 ", traced %" PRIu64, spec, rays, resolved,
                  st.rays_primary + st.rays_shadow);
            CHECK(st.rays_shadow == shadow_rays, "%s: dynamic shadow rays %" PRIu64 " vs %" PRIu64, spec, st.rays_shadow,
                  shadow_rays);
            rt_image_free(dy);
        }
    }
    o.cache_size = 65536;
    o.qorder = 0;
    o.gmax = 200; /* forces oversized leaves processed in blocks */
    rt_image *dy = render(sc, kd, "dynamic", &o, NULL, &st);
    if (ref && dy) CHECK(count_diff(ref, dy) == 0, "%s: dynamic with gmax=200 differs", spec);
    rt_image_free(dy);
    rt_image_free(ref);
    rt_kd_free(kd);
    rt_scene_free(sc);
}

/* Figure 1: A (26) -> B (16) -> C (10) -> D leaves. */
static void figure1(void)
{
    rt_kdtree kd;
    memset(&kd, 0, sizeof kd);
    rt_kdnode n[15];
    uint64_t g[15];
    /* depth-first layout: A=0, B1=1, C1=2, D=3,4, C2=5, D=6,7, B2=8, C3=9, D=10,11, C4=12, D=13,14 */
    static const int above[15] = {8, 5, 4, -1, -1, 7, -1, -1, 12, 11, -1, -1, 14, -1, -1};
    static const int level[15] = {0, 1, 2, 3, 3, 2, 3, 3, 1, 2, 3, 3, 2, 3, 3};
    static const uint64_t gl[4] = {26, 16, 10, 4};
    for (int i = 0; i < 15; i++) {
        if (above[i] < 0) {
            n[i].w0 = 0;
            n[i].w1 = (1u << 2) | 3u;
        } else {
            float split = 0.5f;
            memcpy(&n[i].w0, &split, 4);
            n[i].w1 = ((uint32_t)above[i] << 2) | 0u;
        }
        g[i] = gl[level[i]];
    }
    kd.nodes = n;
    kd.nnodes = 15;
    int32_t qp[15];
    struct {
        uint64_t gmax;
        int level, count;
    } cases[] = {{1000, 0, 1}, {26, 0, 1}, {25, 1, 2}, {16, 1, 2}, {15, 2, 4}, {10, 2, 4}, {9, 3, 8}, {4, 3, 8}, {1, 3, 8}, {0, 3, 8}};
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        uint32_t ntop = 0, nq = rt_dyn_select(&kd, g, cases[c].gmax, qp, &ntop);
        CHECK((int)nq == cases[c].count, "gmax %" PRIu64 ": %u queue points, want %d", cases[c].gmax, nq, cases[c].count);
        int ok = 1;
        for (int i = 0; i < 15; i++) ok &= (qp[i] >= 0) == (level[i] == cases[c].level);
        CHECK(ok, "gmax %" PRIu64 ": queue points not at level %d", cases[c].gmax, cases[c].level);
        CHECK((int)ntop == cases[c].count - 1, "gmax %" PRIu64 ": tree top %u nodes", cases[c].gmax, ntop);
        /* numbered in depth-first order */
        int next = 0;
        for (int i = 0; i < 15; i++)
            if (qp[i] >= 0) ok &= qp[i] == next++;
        CHECK(ok, "queue points not numbered depth first");
    }
}

/* Collects geometry-class accesses. */
typedef struct collect {
    rt_access *a;
    size_t n, cap;
} collect;

static int collect_put(rt_sink *s, const rt_access *a, size_t n)
{
    collect *c = s->ctx;
    for (size_t i = 0; i < n; i++) {
        if (a[i].cls != RT_CLS_NODE && a[i].cls != RT_CLS_INDEX && a[i].cls != RT_CLS_TRI) continue;
        if (c->n == c->cap) {
            c->cap = c->cap ? 2 * c->cap : 4096;
            c->a = realloc(c->a, c->cap * sizeof *c->a);
        }
        c->a[c->n++] = a[i];
    }
    return 0;
}

static void degenerate(void)
{
    rt_err e = {""};
    rt_scene *sc = rt_scene_load("sphereflake:level=1", &e);
    rt_kd_params kp;
    rt_kd_default_params(&kp);
    rt_kdtree *kd = sc ? rt_kd_build(sc, &kp, &e) : NULL;
    CHECK(kd != NULL, "scene: %s", e.msg);
    if (!kd) return;
    rt_render_opts o;
    rt_render_default_opts(&o);
    o.W = 40;
    o.H = 30;
    o.lights = 0;
    o.gmax = UINT64_MAX / 4;
    collect c1 = {0}, c2 = {0};
    rt_sink s1 = {collect_put, &c1}, s2 = {collect_put, &c2};
    rt_run_stats st1, st2;
    rt_image *a = render(sc, kd, "recursive", &o, &s1, &st1);
    rt_image *b = render(sc, kd, "dynamic", &o, &s2, &st2);
    CHECK(strstr(st2.extra, "queue_points=1 ") != NULL, "unlimited budget: %s", st2.extra);
    CHECK(c1.n == c2.n && c1.n > 0 && !memcmp(c1.a, c2.a, c1.n * sizeof *c1.a),
          "root-only dynamic reads different geometry: %zu vs %zu accesses", c1.n, c2.n);
    if (a && b) {
        CHECK(!memcmp(a->nodes, b->nodes, sizeof(float) * 1200) && !memcmp(a->tests, b->tests, sizeof(float) * 1200),
              "per-pixel nodes/tests differ");
        CHECK(count_diff(a, b) == 0, "images differ");
    }
    CHECK(st1.nodes == st2.nodes && st1.tests == st2.tests, "totals differ");
    free(c1.a);
    free(c2.a);
    rt_image_free(a);
    rt_image_free(b);
    rt_kd_free(kd);
    rt_scene_free(sc);
}

/* Pixel subsampling: every tracer traces exactly the kept tiles, which
 * match the full render bit for bit; untraced pixels stay zero and are
 * never referenced; K = 1 is the full render. */
static void subsampling(const char *spec, int W, int H, uint32_t K, int tile)
{
    rt_err e = {""};
    rt_scene *sc = rt_scene_load(spec, &e);
    rt_kd_params kp;
    rt_kd_default_params(&kp);
    rt_kdtree *kd = sc ? rt_kd_build(sc, &kp, &e) : NULL;
    CHECK(kd != NULL, "%s: %s", spec, e.msg);
    if (!kd) {
        rt_scene_free(sc);
        return;
    }
    rt_render_opts o;
    rt_render_default_opts(&o);
    o.W = W;
    o.H = H;
    o.lights = 7;
    o.cache_size = 4096;
    rt_run_stats st;
    rt_image *full = render(sc, kd, "recursive", &o, NULL, &st);
    o.subsample = K;
    o.subtile = tile;
    size_t kept = 0;
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) kept += (size_t)rt_pixel_kept(&o, x, y);
    CHECK(kept > 0 && kept < (size_t)W * H, "%s: subsample %u kept %zu of %d pixels", spec, K, kept, W * H);
    uint32_t *order = calloc((size_t)W * H, sizeof *order);
    CHECK(order && rt_pixel_order(&o, order) == kept, "%s: rt_pixel_order disagrees with rt_pixel_kept", spec);
    free(order);
    static const char *tracers[] = {"recursive", "packet", "dynamic"};
    for (int t = 0; t < 3; t++) {
        if (t == 1 && tile % o.packet) continue;
        collect c = {0};
        rt_sink sink = {collect_put, &c};
        rt_image *im = render(sc, kd, tracers[t], &o, &sink, &st);
        if (!im || !full) {
            rt_image_free(im);
            free(c.a);
            continue;
        }
        CHECK(st.rays_primary == kept, "%s %s: %" PRIu64 " primary rays, %zu pixels kept", spec, tracers[t],
              st.rays_primary, kept);
        size_t bad = 0;
        for (int y = 0; y < H; y++)
            for (int x = 0; x < W; x++) {
                size_t p = (size_t)y * W + x;
                int k = rt_pixel_kept(&o, x, y);
                for (int ch = 0; ch < 3; ch++) {
                    float want = k ? full->rgb[3 * p + ch] : 0.0f;
                    bad += memcmp(&im->rgb[3 * p + ch], &want, sizeof want) != 0;
                }
            }
        CHECK(bad == 0, "%s %s subsample %u:%d: %zu values differ from the full render", spec, tracers[t], K, tile, bad);
        /* no framebuffer write to an untraced pixel */
        rt_job j;
        if (rt_job_setup_borrowed(&j, sc, kd, tracers[t], &o, &e) == 0) {
            int fb = rt_mm_find(&j.L, "fb");
            size_t stray = 0;
            for (size_t i = 0; i < c.n; i++) {
                uint64_t b = rt_mm_addr(&j.L, fb, 0), end = rt_mm_addr(&j.L, fb, (uint64_t)W * H);
                if (c.a[i].addr < b || c.a[i].addr >= end) continue;
                uint64_t p = (c.a[i].addr - b) / 12;
                stray += !rt_pixel_kept(&o, (int)(p % (uint64_t)W), (int)(p / (uint64_t)W));
            }
            CHECK(stray == 0, "%s %s: %zu framebuffer accesses to untraced pixels", spec, tracers[t], stray);
            rt_job_free(&j);
        }
        free(c.a);
        rt_image_free(im);
    }
    /* K = 1 is the full experiment, bit for bit */
    o.subsample = 1;
    rt_image *same = render(sc, kd, "dynamic", &o, NULL, &st);
    if (same && full) CHECK(count_diff(same, full) == 0, "%s: subsample 1 differs from the full render", spec);
    CHECK(st.rays_primary == (uint64_t)W * H, "%s: subsample 1 traced %" PRIu64 " rays", spec, st.rays_primary);
    /* the packet tracer refuses tiles that split packets */
    o.subsample = K;
    o.subtile = 4;
    rt_job j;
    CHECK(rt_job_setup_borrowed(&j, sc, kd, "packet", &o, &e) < 0 && strstr(e.msg, "multiple of the packet"),
          "packet tracer accepted tile 4: %s", e.msg);
    rt_image_free(same);
    rt_image_free(full);
    rt_kd_free(kd);
    rt_scene_free(sc);
}

int main(void)
{
    subsampling("cornell", 64, 48, 4, 8);
    subsampling("sphereflake:level=2", 48, 48, 3, 1);
    figure1();
    degenerate();
    same_images("cornell", 48, 40);
    same_images("knot", 48, 48);
    same_images("sphereflake:level=2", 48, 48);
    same_images("grove", 40, 32);
    same_images("room", 48, 36);
    if (failures) fprintf(stderr, "%d failure(s)\n", failures);
    return failures ? 1 : 0;
}
