/* test_layout.c -- the memory-layout options and the dynamic tracer's queue
 * counters. The mesh vertex index against a quadratic reference (first
 * corner with an equal position, numbered in order of first use) on built-in
 * scenes and on a hand-made one with -0/+0 and NaN coordinates; the run
 * parameters name a non-default layout or queue store and nothing else;
 * images are the same in both layouts with recording on; streaming queue
 * stores change exactly the queue-record writes; the per-cause queue
 * counters add up to the enqueues and match what the record stream shows
 * (ray-buffer reads are re-entries, 8-byte hit-record reads are candidate
 * visits), and leave the statistics unchanged when off.
 *
 * `test_layout --queue-stats SPEC W H [CACHE [LIGHTS]]` (lights: all by
 * default, none for primary rays only) instead prints the dynamic
 * tracer's statistics with the counters (docs/results.md). */
#include "scene_load.h"
#include "check.h"
#include "mesh.h"
#include "run.h"

#include <inttypes.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ---- the vertex index ------------------------------------------------------ */

static int same(rt_vec3 a, rt_vec3 b) { return a.x == b.x && a.y == b.y && a.z == b.z; }

static void mesh_vs_reference(const rt_scene *sc, const char *what)
{
    rt_err e = {0};
    rt_mesh *m = rt_mesh_build(sc, &e);
    CHECK(m != NULL, "%s: %s", what, e.msg);
    if (!m) return;
    size_t n = (size_t)sc->ntri * 3;
    uint32_t *id = calloc(n, sizeof *id), nv = 0;
    size_t bad = 0;
    for (size_t c = 0; c < n && id; c++) {
        rt_vec3 p = sc->tri[c / 3].p[c % 3];
        size_t f = c;
        for (size_t d = 0; d < c; d++)
            if (same(sc->tri[d / 3].p[d % 3], p)) {
                f = d;
                break;
            }
        id[c] = f == c ? nv++ : id[f];
        bad += m->vidx[c] != id[c];
    }
    CHECK(m->ntri == sc->ntri && m->nvert == nv && bad == 0, "%s: %u vertices, reference %u; %zu indices differ", what,
          m->nvert, nv, bad);
    free(id);
    rt_mesh_free(m);
}

static void mesh_index(void)
{
    static const char *const specs[] = {"cornell", "knot", "sphereflake:level=1"};
    for (size_t i = 0; i < sizeof specs / sizeof specs[0]; i++) {
        rt_err e = {0};
        rt_scene *sc = rt_scene_load(specs[i], &e);
        CHECK(sc != NULL, "%s: %s", specs[i], e.msg);
        if (sc) mesh_vs_reference(sc, specs[i]);
        rt_scene_free(sc);
    }
    /* by hand: a quad (4 vertices), -0 sharing with +0, a NaN never shared */
    rt_err e = {0};
    rt_scene *sc = rt_scene_new(4, &e);
    const float c[3] = {1, 1, 1};
    const float nan = NAN;
    CHECK(sc && rt_scene_add_tri(sc, rt_v3(0, 0, 0), rt_v3(1, 0, 0), rt_v3(1, 1, 0), c, &e) == 0 &&
              rt_scene_add_tri(sc, rt_v3(-0.0f, 0, 0), rt_v3(1, 1, 0), rt_v3(0, 1, 0), c, &e) == 0 &&
              rt_scene_add_tri(sc, rt_v3(nan, 0, 0), rt_v3(nan, 0, 0), rt_v3(0, 1, 0), c, &e) == 0,
          "hand-made scene: %s", e.msg);
    if (!sc) return;
    rt_mesh *m = rt_mesh_build(sc, &e);
    static const uint32_t want[9] = {0, 1, 2, 0, 2, 3, 4, 5, 3};
    CHECK(m && m->nvert == 6 && !memcmp(m->vidx, want, sizeof want), "hand-made scene: %u vertices, indices %u %u %u / %u %u %u / %u %u %u",
          m ? m->nvert : 0, m ? m->vidx[0] : 0, m ? m->vidx[1] : 0, m ? m->vidx[2] : 0, m ? m->vidx[3] : 0,
          m ? m->vidx[4] : 0, m ? m->vidx[5] : 0, m ? m->vidx[6] : 0, m ? m->vidx[7] : 0, m ? m->vidx[8] : 0);
    mesh_vs_reference(sc, "hand-made scene");
    rt_mesh_free(m);
    rt_scene_free(sc);
}

/* ---- run parameters --------------------------------------------------------- */

static void params(void)
{
    rt_render_opts o;
    rt_render_default_opts(&o);
    char b[256];
    CHECK(!strcmp(rt_job_params("dynamic", &o, NULL, b, sizeof b), "qorder=fullest threads=4"), "default: '%s'", b);
    CHECK(!strcmp(rt_job_params("recursive", &o, NULL, b, sizeof b), ""), "default recursive: '%s'", b);
    o.geom = RT_GEOM_MESH;
    o.qstores = RT_QSTORES_STREAM;
    CHECK(!strcmp(rt_job_params("dynamic", &o, NULL, b, sizeof b), "qorder=fullest threads=4 layout=mesh queue_stores=stream"),
          "mesh, stream: '%s'", b);
    CHECK(!strcmp(rt_job_params("packet", &o, "sim=x", b, sizeof b), "packet=8 layout=mesh sim=x"), "packet mesh: '%s'", b);
    o.mode = RT_MODE_WHITTED;
    CHECK(!strcmp(rt_job_params("recursive", &o, NULL, b, sizeof b), "mode=whitted depth=5 layout=mesh"), "whitted mesh: '%s'",
          b);
    o.geom = RT_GEOM_COMPACT;
    CHECK(!strcmp(rt_job_params("recursive", &o, NULL, b, sizeof b), "mode=whitted depth=5"), "recursive stream: '%s'", b);
    CHECK(rt_render_geom_from_name("mesh") == RT_GEOM_MESH && rt_render_geom_from_name("compact") == RT_GEOM_COMPACT &&
              rt_render_geom_from_name("pbrt") == -1 && rt_render_qstores_from_name("stream") == RT_QSTORES_STREAM &&
              rt_render_qstores_from_name("write-allocate") == RT_QSTORES_WRITE_ALLOCATE &&
              rt_render_qstores_from_name("nt") == -1,
          "option names");
    rt_err e = {0};
    o.geom = 7;
    CHECK(rt_render_check_mode(&o, &e) < 0 && strstr(e.msg, "--layout"), "layout 7 accepted: %s", e.msg);
    o.geom = 0;
    o.qstores = -1;
    CHECK(rt_render_check_mode(&o, &e) < 0 && strstr(e.msg, "--queue-stores"), "queue stores -1 accepted: %s", e.msg);
}

/* ---- recorded runs ------------------------------------------------------------ */

typedef struct rec {
    rt_access *a;
    size_t n, cap;
} rec;

static int rec_put(rt_sink *s, const rt_access *a, size_t n)
{
    rec *r = s->ctx;
    if (r->n + n > r->cap) {
        size_t c = r->cap ? r->cap * 2 : 1 << 16;
        while (c < r->n + n) c *= 2;
        rt_access *p = realloc(r->a, c * sizeof *p);
        if (!p) return -1;
        r->a = p;
        r->cap = c;
    }
    memcpy(r->a + r->n, a, n * sizeof *a);
    r->n += n;
    return 0;
}

/* One recorded run; the image, statistics, records and layout. 0 or -1. */
static int run(rt_scene *sc, rt_kdtree *kd, const char *tracer, const rt_render_opts *o, rt_image **img,
               rt_run_stats *st, rec *r, rt_layout *L)
{
    rt_err e = {0};
    rt_job j;
    memset(r, 0, sizeof *r);
    *img = NULL;
    if (rt_job_setup_borrowed(&j, sc, kd, tracer, o, &e) < 0) {
        CHECK(0, "setup %s: %s", tracer, e.msg);
        return -1;
    }
    j.check = 1;
    rt_sink sink = {rec_put, r};
    *img = rt_image_new(o->W, o->H, &e);
    int rc = *img ? rt_job_run(&j, &sink, *img, st, &e) : -1;
    CHECK(rc == 0, "run %s: %s", tracer, e.msg);
    *L = j.L;
    rt_job_free(&j);
    return rc;
}

static rt_kdtree *load(const char *spec, rt_scene **sc)
{
    rt_err e = {0};
    *sc = rt_scene_load(spec, &e);
    rt_kd_params kp;
    rt_kd_default_params(&kp);
    rt_kdtree *kd = *sc ? rt_kd_build(*sc, &kp, &e) : NULL;
    CHECK(kd != NULL, "%s: %s", spec, e.msg);
    return kd;
}

/* Images with recording on are the same in both layouts, every tracer. */
static void layouts_same_images(const char *spec)
{
    rt_scene *sc;
    rt_kdtree *kd = load(spec, &sc);
    if (!kd) return;
    static const char *const tracers[] = {"recursive", "packet", "dynamic"};
    for (int t = 0; t < 3; t++)
        for (int mode = RT_MODE_SHADOW; mode <= RT_MODE_WHITTED; mode++) {
            rt_render_opts o;
            rt_render_default_opts(&o);
            o.W = 24;
            o.H = 20;
            o.lights = 7;
            o.mode = mode;
            o.sched_size = 4096;
            rt_image *a, *b;
            rt_run_stats sa, sb;
            rec ra, rb;
            rt_layout La, Lb;
            run(sc, kd, tracers[t], &o, &a, &sa, &ra, &La);
            o.geom = RT_GEOM_MESH;
            run(sc, kd, tracers[t], &o, &b, &sb, &rb, &Lb);
            CHECK(a && b && !memcmp(a->rgb, b->rgb, sizeof(float) * 3 * 24 * 20) &&
                      !memcmp(a->depth, b->depth, sizeof(float) * 24 * 20),
                  "%s %s mode %d: images differ between layouts", spec, tracers[t], mode);
            CHECK(rb.n > ra.n && sa.tests == sb.tests && sa.nodes == sb.nodes && !strcmp(sa.extra, sb.extra),
                  "%s %s mode %d: mesh run: %zu records (compact %zu), statistics '%s' vs '%s'", spec, tracers[t], mode, rb.n,
                  ra.n, sb.extra, sa.extra);
            rt_image_free(a);
            rt_image_free(b);
            free(ra.a);
            free(rb.a);
        }
    rt_kd_free(kd);
    rt_scene_free(sc);
}

/* Streaming queue stores: the same records, the queue-record writes marked
 * RT_WRITE_STREAM (one per enqueue), nothing else. */
static void queue_stores(const char *spec)
{
    rt_scene *sc;
    rt_kdtree *kd = load(spec, &sc);
    if (!kd) return;
    rt_render_opts o;
    rt_render_default_opts(&o);
    o.W = 32;
    o.H = 32;
    o.lights = 7;
    o.sched_size = 8192;
    rt_image *a, *b;
    rt_run_stats sa, sb;
    rec ra, rb;
    rt_layout La, Lb;
    run(sc, kd, "dynamic", &o, &a, &sa, &ra, &La);
    o.qstores = RT_QSTORES_STREAM;
    run(sc, kd, "dynamic", &o, &b, &sb, &rb, &Lb);
    int rq = rt_mm_find(&La, "dyn.queues");
    size_t diff = 0, stream = 0, wrong = 0, plain_queue_writes = 0;
    for (size_t i = 0; i < ra.n && i < rb.n; i++) {
        const rt_access *x = &ra.a[i], *y = &rb.a[i];
        diff += x->addr != y->addr || x->size != y->size || x->cls != y->cls || x->gen != y->gen;
        if (y->write == RT_WRITE_STREAM) {
            stream++;
            wrong += x->write != 1 || y->cls != RT_CLS_QUEUE || y->addr < La.r[rq].base;
        } else {
            wrong += x->write != y->write;
        }
        plain_queue_writes += x->cls == RT_CLS_QUEUE && x->write == 1;
    }
    char k[] = "enqueues=";
    const char *p = strstr(sa.extra, k);
    uint64_t enq = p ? strtoull(p + strlen(k), NULL, 10) : 0;
    CHECK(ra.n == rb.n && diff == 0 && wrong == 0 && stream == enq && plain_queue_writes == enq && enq > 0 &&
              !strcmp(sa.extra, sb.extra),
          "%s: %zu/%zu records, %zu differ, %zu streaming stores (%zu wrong) for %" PRIu64 " enqueues", spec, ra.n, rb.n, diff,
          stream, wrong, enq);
    rt_image_free(a);
    rt_image_free(b);
    free(ra.a);
    free(rb.a);
    rt_kd_free(kd);
    rt_scene_free(sc);
}

static uint64_t key(const char *s, const char *k)
{
    char b[64];
    snprintf(b, sizeof b, " %s=", k);
    const char *p = strstr(s, b);
    CHECK(p != NULL, "statistics lack %s: %s", k, s);
    return p ? strtoull(p + strlen(b), NULL, 10) : 0;
}

/* The per-cause counters against the record stream. */
static void queue_counters(const char *spec, uint64_t cache, int mode)
{
    rt_scene *sc;
    rt_kdtree *kd = load(spec, &sc);
    if (!kd) return;
    rt_render_opts o;
    rt_render_default_opts(&o);
    o.W = 32;
    o.H = 24;
    o.lights = 5;
    o.mode = mode;
    o.sched_size = cache;
    rt_image *a, *b;
    rt_run_stats sa, sb;
    rec ra, rb;
    rt_layout La, Lb;
    run(sc, kd, "dynamic", &o, &a, &sa, &ra, &La);
    o.queue_stats = 1;
    run(sc, kd, "dynamic", &o, &b, &sb, &rb, &Lb);
    size_t la = strlen(sa.extra);
    CHECK(!strncmp(sa.extra, sb.extra, la) && !strncmp(sb.extra + la, " q_first_pri=", 13),
          "%s: statistics with counters '%s' do not extend '%s'", spec, sb.extra, sa.extra);
    CHECK(!strstr(sa.extra, "q_first"), "%s: counters without the switch: %s", spec, sa.extra);
    const char *s = sb.extra;
    uint64_t enq = key(s, "enqueues"), fp = key(s, "q_first_pri"), fs = key(s, "q_first_sec"),
             fsh = key(s, "q_first_shadow"), ex = key(s, "q_exit"), ca = key(s, "q_cand"), v = key(s, "v"),
             vc = key(s, "v_cand"), vk = key(s, "v_cand_kept"), sm = key(s, "q_small"), lf = key(s, "q_leaf"),
             vn = key(s, "v_notest");
    /* from the records: ray-buffer reads happen exactly at re-entries, an
     * 8-byte hit-record read exactly when a candidate is brought along */
    int rb_ = rt_mm_find(&Lb, "dyn.raybuf"), rh = rt_mm_find(&Lb, "dyn.hits");
    uint64_t rbr = 0, h8 = 0;
    for (size_t i = 0; i < rb.n; i++) {
        const rt_access *x = &rb.a[i];
        int in_rb = x->addr >= Lb.r[rb_].base && x->addr < Lb.r[rb_].base + 32 * Lb.r[rb_].count;
        int in_h = x->addr >= Lb.r[rh].base && x->addr < Lb.r[rh].base + 24 * Lb.r[rh].count;
        rbr += in_rb && !x->write;
        h8 += in_h && !x->write && x->size == 8;
    }
    CHECK(fp + fs + fsh + ex + ca == enq && v == enq && vc == ca && vk <= vc && sm <= enq && lf <= enq && vn <= v,
          "%s: counters do not add up: %s", spec, s);
    CHECK(rbr == ex + ca && h8 == vc, "%s: %" PRIu64 " ray-buffer reads for %" PRIu64 " re-entries, %" PRIu64
          " candidate reads for %" PRIu64 " candidate visits", spec, rbr, ex + ca, h8, vc);
    CHECK(fp <= sb.rays_primary && (mode == RT_MODE_WHITTED) == (fs > 0) && fsh > 0 && fsh <= sb.rays_shadow,
          "%s: first enqueues %" PRIu64 "/%" PRIu64 "/%" PRIu64 " for %" PRIu64 " primary, %" PRIu64 " shadow rays", spec,
          fp, fs, fsh, sb.rays_primary, sb.rays_shadow);
    rt_image_free(a);
    rt_image_free(b);
    free(ra.a);
    free(rb.a);
    /* the root the only queue point: nothing is queued, every counter 0 */
    o.sched_size = 1ull << 30;
    run(sc, kd, "dynamic", &o, &b, &sb, &rb, &Lb);
    CHECK(key(sb.extra, "queue_points") == 1 && key(sb.extra, "q_first_pri") == 0 && key(sb.extra, "v") == 0 &&
              key(sb.extra, "q_exit") == 0,
          "%s: root only: %s", spec, sb.extra);
    rt_image_free(b);
    free(rb.a);
    rt_kd_free(kd);
    rt_scene_free(sc);
}

/* ---- the measurement front end -------------------------------------------------- */

static int queue_stats_main(int argc, char **argv)
{
    if (argc < 5) {
        fprintf(stderr, "usage: test_layout --queue-stats SPEC W H [CACHE [LIGHTS]]\n");
        return 2;
    }
    rt_render_opts o;
    rt_render_default_opts(&o);
    o.W = atoi(argv[3]);
    o.H = atoi(argv[4]);
    o.lights = 7;
    o.queue_stats = 1;
    if (argc > 5) o.sched_size = strtoull(argv[5], NULL, 10);
    if (argc > 6 && rt_render_parse_lights(argv[6], &o.lights) < 0) {
        fprintf(stderr, "test_layout: bad light list '%s'\n", argv[6]);
        return 2;
    }
    rt_err e = {0};
    rt_job j;
    rt_run_stats st;
    if (rt_job_setup(&j, argv[2], "dynamic", &o, &e) < 0) {
        fprintf(stderr, "test_layout: %s\n", e.msg);
        return 1;
    }
    rt_image *im = rt_image_new(o.W, o.H, &e);
    int rc = im ? rt_job_run(&j, NULL, im, &st, &e) : -1;
    if (rc == 0) printf("%s %dx%d primary=%" PRIu64 " shadow=%" PRIu64 " %s\n", argv[2], o.W, o.H, st.rays_primary,
                        st.rays_shadow, st.extra);
    else fprintf(stderr, "test_layout: %s\n", e.msg);
    rt_image_free(im);
    rt_job_free(&j);
    return rc ? 1 : 0;
}

int main(int argc, char **argv)
{
    if (argc > 1 && !strcmp(argv[1], "--queue-stats")) return queue_stats_main(argc, argv);
    mesh_index();
    params();
    layouts_same_images("cornell");
    layouts_same_images("sphereflake:level=1");
    queue_stores("sphereflake:level=2");
    queue_counters("sphereflake:level=2", 8192, RT_MODE_SHADOW);
    queue_counters("cornell", 2048, RT_MODE_WHITTED);
    queue_counters("knot", 16384, RT_MODE_SHADOW);
    if (failures) fprintf(stderr, "%d failure(s)\n", failures);
    return failures ? 1 : 0;
}
