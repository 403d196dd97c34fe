/* test_layout.c -- the memory-layout options and the dynamic tracer's queue
 * counters. The mesh vertex index against a quadratic reference (first
 * corner with an equal position, numbered in order of first use) on built-in
 * scenes and on a hand-made one with -0/+0 and NaN coordinates; the run
 * parameters name a non-default layout or queue store and nothing else;
 * images are the same in both layouts with recording on; streaming queue
 * stores change exactly the queue-record writes; the per-cause queue
 * counters add up to the enqueues and match what the record stream shows
 * (ray-buffer reads are re-entries, 8-byte hit-record reads are candidate
 * visits), and leave the statistics unchanged when off. The pbrt layouts:
 * the recorder's stream against hand-computed addresses and sizes on a
 * hand-made two-leaf tree (pointer lists, a one-primitive leaf, a mailbox
 * skip within a walk and none across walks, non-test and shading reads)
 * and on a one-triangle scene run end to end, 4- and 8-byte pointers; the
 * mailbox writes leave dirty lines that a simulator writes back as
 * geometry traffic (none in the compact layout); images and statistics
 * equal to the compact layout's.
 *
 * `test_layout --queue-stats SPEC W H [CACHE [LIGHTS]]` (lights: all by
 * default, none for primary rays only) instead prints the dynamic
 * tracer's statistics with the counters (docs/results.md). */
#include "scene_load.h"
#include "check.h"
#include "experiment.h"
#include "mesh.h"
#include "pbrtlayout.h"
#include "run.h"
#include "sim.h"

#include <errno.h>
#include <inttypes.h>
#include <math.h>
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
    o.geom = RT_GEOM_PBRT;
    CHECK(!strcmp(rt_job_params("recursive", &o, NULL, b, sizeof b), "mode=whitted depth=5 layout=pbrt"),
          "whitted pbrt: '%s'", b);
    o.geom = RT_GEOM_PBRT64;
    o.mode = RT_MODE_DEFAULT;
    CHECK(!strcmp(rt_job_params("dynamic", &o, NULL, b, sizeof b), "qorder=fullest threads=4 layout=pbrt64 queue_stores=stream"),
          "dynamic pbrt64: '%s'", b);
    o.mode = RT_MODE_WHITTED;
    o.geom = RT_GEOM_COMPACT;
    CHECK(!strcmp(rt_job_params("recursive", &o, NULL, b, sizeof b), "mode=whitted depth=5"), "recursive stream: '%s'", b);
    CHECK(rt_render_geom_from_name("mesh") == RT_GEOM_MESH && rt_render_geom_from_name("compact") == RT_GEOM_COMPACT &&
              rt_render_geom_from_name("pbrt") == RT_GEOM_PBRT && rt_render_geom_from_name("pbrt64") == RT_GEOM_PBRT64 &&
              rt_render_geom_from_name("pbrt32") == -1 && !strcmp(rt_render_geom_name(RT_GEOM_PBRT), "pbrt") &&
              rt_render_geom_name(4) == NULL && rt_render_qstores_from_name("stream") == RT_QSTORES_STREAM &&
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

static uint64_t key(const char *s, const char *k);

/* Images with recording on are the same in every layout, every tracer. */
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
            for (int g = RT_GEOM_MESH; g <= RT_GEOM_PBRT64; g++) {
                o.geom = g;
                run(sc, kd, tracers[t], &o, &b, &sb, &rb, &Lb);
                CHECK(a && b && !memcmp(a->rgb, b->rgb, sizeof(float) * 3 * 24 * 20) &&
                          !memcmp(a->depth, b->depth, sizeof(float) * 24 * 20),
                      "%s %s mode %d: images differ between layouts compact and %s", spec, tracers[t], mode,
                      rt_render_geom_name(g));
                /* the pbrt layouts append their mailbox counts */
                size_t la = strlen(sa.extra);
                int same_stats = g == RT_GEOM_MESH ? !strcmp(sa.extra, sb.extra)
                                                   : !strncmp(sa.extra, sb.extra, la) && strstr(sb.extra + la, "mbox_tests=");
                CHECK(rb.n > ra.n && sa.tests == sb.tests && sa.nodes == sb.nodes && same_stats,
                      "%s %s mode %d: %s run: %zu records (compact %zu), statistics '%s' vs '%s'", spec, tracers[t], mode,
                      rt_render_geom_name(g), rb.n, ra.n, sb.extra, sa.extra);
                /* the recorder takes as tests exactly the triangle reads of
                 * leaves: one per ray and triangle, one per packet and
                 * triangle for packets */
                if (g != RT_GEOM_MESH) {
                    uint64_t mt = key(sb.extra, "mbox_tests"), ms = key(sb.extra, "mbox_skips");
                    CHECK((t == 1 ? mt > 0 && mt < sb.tests : mt == sb.tests) && ms < mt, "%s %s mode %d: %" PRIu64
                          " tests, recorder %" PRIu64 " (%" PRIu64 " skipped)", spec, tracers[t], mode, sb.tests, mt, ms);
                }
                rt_image_free(b);
                free(rb.a);
            }
            rt_image_free(a);
            free(ra.a);
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
    const char *p = !strncmp(s, b + 1, strlen(b + 1)) ? s - 1 : strstr(s, b); /* at the start, or after a space */
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


/* ---- the pbrt layouts ------------------------------------------------------------ */

/* An expected access. */
typedef struct want {
    uint64_t addr;
    uint32_t size;
    int write, cls;
} want;

static void expect(const rec *r, const want *w, size_t n, const char *what)
{
    size_t bad = r->n == n ? n : 0;
    for (size_t i = 0; i < n && i < r->n; i++) {
        const rt_access *x = &r->a[i];
        if (x->addr != w[i].addr || x->size != w[i].size || x->write != w[i].write || x->cls != w[i].cls) {
            bad = i;
            break;
        }
    }
    CHECK(r->n == n && bad == n, "%s: %zu records (want %zu), first difference at %zu: %#" PRIx64 " %u %s cls %d, want %#" PRIx64
          " %u %s cls %d", what, r->n, n, bad, bad < r->n ? r->a[bad].addr : 0, bad < r->n ? r->a[bad].size : 0,
          bad < r->n && r->a[bad].write ? "W" : "R", bad < r->n ? r->a[bad].cls : -1, bad < n ? w[bad].addr : 0,
          bad < n ? w[bad].size : 0, bad < n && w[bad].write ? "W" : "R", bad < n ? w[bad].cls : -1);
}

/* The recorder alone on a hand-made tree: root, leaf A {0, 1}, leaf B {0};
 * three triangles (2 is in no leaf), seven vertices. */
static void pbrt_recorder(int geom)
{
    rt_err e = {0};
    rt_scene *sc = rt_scene_new(3, &e);
    const float c[3] = {1, 1, 1};
    CHECK(sc && rt_scene_add_tri(sc, rt_v3(0, 0, 0), rt_v3(1, 0, 0), rt_v3(0, 1, 0), c, &e) == 0 &&
              rt_scene_add_tri(sc, rt_v3(1, 0, 0), rt_v3(1, 1, 0), rt_v3(0, 1, 0), c, &e) == 0 &&
              rt_scene_add_tri(sc, rt_v3(5, 0, 0), rt_v3(6, 0, 0), rt_v3(5, 1, 0), c, &e) == 0,
          "pbrt scene: %s", e.msg);
    rt_mesh *m = sc ? rt_mesh_build(sc, &e) : NULL;
    CHECK(m && m->nvert == 7, "pbrt mesh: %s", e.msg);
    if (!m) {
        rt_scene_free(sc);
        return;
    }
    rt_kdnode nodes[3] = {{0, (2u << 2) | 0}, {0, (2u << 2) | 3}, {2, (1u << 2) | 3}};
    uint32_t idx[3] = {0, 1, 0};
    rt_kdtree kd;
    memset(&kd, 0, sizeof kd);
    kd.nodes = nodes;
    kd.nnodes = 3;
    kd.idx = idx;
    kd.nidx = 3;
    rt_pbrt_sizes z;
    rt_pbrt_sizes_get(geom, &z);
    const uint32_t P = geom == RT_GEOM_PBRT64 ? 8 : 4;
    CHECK(z.ptr == P && z.mbox == 2 * P && z.prim == (P == 4 ? 20 : 40) && z.shape == (P == 4 ? 36 : 72) &&
              z.mesh == (P == 4 ? 56 : 104) && rt_pbrt_plist_bytes(&kd, geom) == 32768,
          "pbrt sizes (%u-byte pointers): mailbox %u, primitive %u, shape %u, mesh %u, lists %" PRIu64, P, z.mbox, z.prim,
          z.shape, z.mesh, rt_pbrt_plist_bytes(&kd, geom));
    rt_layout L;
    rt_mm_init(&L);
    CHECK(rt_mm_add(&L, "kd.nodes", RT_CLS_NODE, 8, 3, &e) >= 0 && rt_mm_add(&L, "kd.index", RT_CLS_INDEX, 4, 3, &e) >= 0 &&
              rt_mm_add(&L, "tri.vidx", RT_CLS_TRI, 12, 3, &e) >= 0 && rt_mm_add(&L, "mesh.pos", RT_CLS_TRI, 12, 7, &e) >= 0 &&
              rt_pbrt_regions(&L, &kd, 3, geom, &e) == 0 && rt_mm_add(&L, "tri.shade", RT_CLS_SHADE, 16, 3, &e) >= 0 &&
              rt_mm_add(&L, "mesh.normal", RT_CLS_SHADE, 12, 7, &e) >= 0 && rt_mm_add(&L, "fb", RT_CLS_FB, 12, 1, &e) >= 0,
          "pbrt layout: %s", e.msg);
    /* the region bases: 4 KiB apart in declaration order, the list arena one 32 KiB block */
    const uint64_t B = RT_MM_BASE, nodes0 = B, idx0 = B + 0x1000, vidx0 = B + 0x2000, pos0 = B + 0x3000, pl0 = B + 0x4000,
                   mb0 = pl0 + 0x8000, pr0 = mb0 + 0x1000, sh0 = pr0 + 0x1000, me0 = sh0 + 0x1000, shade0 = me0 + 0x1000,
                   nrm0 = shade0 + 0x1000, fb0 = nrm0 + 0x1000;
    CHECK(L.r[rt_mm_find(&L, "pbrt.mbox")].base == mb0 && L.r[rt_mm_find(&L, "fb")].base == fb0 &&
              L.r[rt_mm_find(&L, "pbrt.prim")].recsize == (P == 4 ? 24u : 48u) &&
              L.r[rt_mm_find(&L, "pbrt.shape")].recsize == (P == 4 ? 40u : 80u),
          "pbrt region bases");
    rec r = {0};
    rt_sink sink = {rec_put, &r};
    rt_rec *out = rt_rec_new(&sink, &e);
    rt_rec *pr = out ? rt_pbrt_rec_new(m, &kd, &L, geom, out, &e) : NULL;
    CHECK(pr != NULL, "pbrt recorder: %s", e.msg);
    if (!pr) {
        rt_rec_free(out);
        rt_mesh_free(m);
        rt_scene_free(sc);
        return;
    }
    /* walk 1: root, leaf A (list of 2), triangles 0 and 1, leaf B (one
     * primitive), triangle 0 again; then a non-test read of triangle 1, its
     * shading and a pixel write; walk 2: root, leaf B, triangle 0 */
    RT_REC(pr, nodes0, 8, 0, RT_CLS_NODE);
    RT_REC(pr, nodes0 + 8, 8, 0, RT_CLS_NODE);
    RT_REC(pr, idx0, 8, 0, RT_CLS_INDEX);
    RT_REC(pr, vidx0, 36, 0, RT_CLS_TRI);
    RT_REC(pr, vidx0 + 12, 36, 0, RT_CLS_TRI);
    RT_REC(pr, nodes0 + 16, 8, 0, RT_CLS_NODE);
    RT_REC(pr, idx0 + 8, 4, 0, RT_CLS_INDEX);
    RT_REC(pr, vidx0, 36, 0, RT_CLS_TRI);
    RT_REC(pr, fb0, 12, 1, RT_CLS_FB);
    RT_REC(pr, vidx0 + 12, 36, 0, RT_CLS_TRI);
    RT_REC(pr, shade0 + 16, 16, 0, RT_CLS_SHADE);
    RT_REC(pr, nodes0, 8, 0, RT_CLS_NODE);
    RT_REC(pr, nodes0 + 16, 8, 0, RT_CLS_NODE);
    RT_REC(pr, idx0 + 8, 4, 0, RT_CLS_INDEX);
    RT_REC(pr, vidx0, 36, 0, RT_CLS_TRI);
    rt_rec_flush(pr);
    uint64_t nt, ns;
    rt_pbrt_rec_counts(pr, &nt, &ns);
    rt_pbrt_rec_free(pr);
    rt_rec_flush(out);
    rt_rec_free(out);
    const int T = RT_CLS_TRI, S = RT_CLS_SHADE;
    /* vertex indices as numbered by first use: 0 1 2 / 1 3 2 / 4 5 6 */
    const uint64_t mbox0 = mb0 + 2 * z.mbox, mbox1 = mb0 + 1 * z.mbox; /* FullyRefine's reverse order */
    const uint64_t id = P; /* offset of lastMailboxId */
    const uint64_t sh1 = sh0 + z.shape_chunk, pr1 = pr0 + z.prim_chunk, mesh_p = P == 4 ? 40 : 72, tmesh = P == 4 ? 28 : 56;
    const want w[] = {
        {nodes0, 8, 0, RT_CLS_NODE},
        {nodes0 + 8, 8, 0, RT_CLS_NODE},
        {pl0, 2 * P, 0, RT_CLS_INDEX}, /* leaf A's pointer list */
        /* test of triangle 0 */
        {mbox0, (uint32_t)id + 4, 0, T},
        {mbox0 + id, 4, 1, T},
        {pr0, 3 * P, 0, T},
        {sh0, P, 0, T},
        {sh0 + tmesh, 2 * P, 0, T},
        {me0 + mesh_p, P, 0, T},
        {vidx0, 12, 0, T},
        {pos0, 12, 0, T},
        {pos0 + 12, 12, 0, T},
        {pos0 + 24, 12, 0, T},
        /* test of triangle 1 */
        {mbox1, (uint32_t)id + 4, 0, T},
        {mbox1 + id, 4, 1, T},
        {pr1, 3 * P, 0, T},
        {sh1, P, 0, T},
        {sh1 + tmesh, 2 * P, 0, T},
        {me0 + mesh_p, P, 0, T},
        {vidx0 + 12, 12, 0, T},
        {pos0 + 12, 12, 0, T},
        {pos0 + 36, 12, 0, T},
        {pos0 + 24, 12, 0, T},
        /* leaf B: the pointer is in the node; triangle 0 again: the mailbox skips it */
        {nodes0 + 16, 8, 0, RT_CLS_NODE},
        {mbox0 + id, 4, 0, T},
        {fb0, 12, 1, RT_CLS_FB},
        /* triangle 1 read outside a leaf: no mailbox, no primitive */
        {sh1, P, 0, T},
        {sh1 + tmesh, 2 * P, 0, T},
        {me0 + mesh_p, P, 0, T},
        {vidx0 + 12, 12, 0, T},
        {pos0 + 12, 12, 0, T},
        {pos0 + 36, 12, 0, T},
        {pos0 + 24, 12, 0, T},
        /* shading of triangle 1: primitive, shape, mesh->n and s, normals, record */
        {pr1, z.prim, 0, S},
        {sh1, P, 0, S},
        {sh1 + tmesh, 2 * P, 0, S},
        {me0 + mesh_p + P, 2 * P, 0, S},
        {vidx0 + 12, 12, 0, T},
        {nrm0 + 12, 12, 0, S},
        {nrm0 + 36, 12, 0, S},
        {nrm0 + 24, 12, 0, S},
        {shade0 + 16, 16, 0, S},
        /* walk 2: a new mailbox id, triangle 0 tested in full */
        {nodes0, 8, 0, RT_CLS_NODE},
        {nodes0 + 16, 8, 0, RT_CLS_NODE},
        {mbox0, (uint32_t)id + 4, 0, T},
        {mbox0 + id, 4, 1, T},
        {pr0, 3 * P, 0, T},
        {sh0, P, 0, T},
        {sh0 + tmesh, 2 * P, 0, T},
        {me0 + mesh_p, P, 0, T},
        {vidx0, 12, 0, T},
        {pos0, 12, 0, T},
        {pos0 + 12, 12, 0, T},
        {pos0 + 24, 12, 0, T},
    };
    expect(&r, w, sizeof w / sizeof w[0], rt_render_geom_name(geom));
    CHECK(nt == 4 && ns == 1, "%s: %" PRIu64 " tests, %" PRIu64 " skipped (want 4, 1)", rt_render_geom_name(geom), nt, ns);
    free(r.a);
    rt_mesh_free(m);
    rt_scene_free(sc);
}

/* One triangle, one pixel, end to end: the primary ray, the root leaf
 * (one primitive: no list), one test, the shading, the pixel. */
static void pbrt_one_triangle(int geom)
{
    static const char obj[] = "v -1 -1 0\nv 1 -1 0\nv 0 1 0\nf 1 2 3\n";
    const char *path = check_path("one.obj");
    check_write_file(path, obj, sizeof obj - 1);
    rt_scene *sc;
    rt_kdtree *kd = load(path, &sc);
    if (!kd) return;
    CHECK(kd->nnodes == 1 && kd->nidx == 1, "one triangle: %u nodes, %u entries", kd->nnodes, kd->nidx);
    rt_render_opts o;
    rt_render_default_opts(&o);
    o.W = o.H = 1;
    o.geom = geom;
    rt_image *im;
    rt_run_stats st;
    rec r;
    rt_layout L;
    if (run(sc, kd, "recursive", &o, &im, &st, &r, &L) == 0) {
        rt_pbrt_sizes z;
        rt_pbrt_sizes_get(geom, &z);
        const uint32_t P = z.ptr;
#define A(name) L.r[rt_mm_find(&L, name)].base
        const int T = RT_CLS_TRI, S = RT_CLS_SHADE;
        const want w[] = {
            {A("rays.primary"), 32, 0, RT_CLS_RAY},
            {A("kd.nodes"), 8, 0, RT_CLS_NODE},
            {A("pbrt.mbox"), P + 4, 0, T},
            {A("pbrt.mbox") + P, 4, 1, T},
            {A("pbrt.prim"), 3 * P, 0, T},
            {A("pbrt.shape"), P, 0, T},
            {A("pbrt.shape") + 7 * P, 2 * P, 0, T},
            {A("pbrt.mesh") + z.mesh_p, P, 0, T},
            {A("tri.vidx"), 12, 0, T},
            {A("mesh.pos"), 12, 0, T},
            {A("mesh.pos") + 12, 12, 0, T},
            {A("mesh.pos") + 24, 12, 0, T},
            {A("pbrt.prim"), 5 * P, 0, S},
            {A("pbrt.shape"), P, 0, S},
            {A("pbrt.shape") + 7 * P, 2 * P, 0, S},
            {A("pbrt.mesh") + z.mesh_p + P, 2 * P, 0, S},
            {A("tri.vidx"), 12, 0, T},
            {A("mesh.normal"), 12, 0, S},
            {A("mesh.normal") + 12, 12, 0, S},
            {A("mesh.normal") + 24, 12, 0, S},
            {A("tri.shade"), 16, 0, S},
            {A("fb"), 12, 1, RT_CLS_FB},
        };
#undef A
        CHECK(isfinite(im->depth[0]), "one triangle: the pixel's ray misses");
        expect(&r, w, sizeof w / sizeof w[0], geom == RT_GEOM_PBRT ? "one triangle, pbrt" : "one triangle, pbrt64");
    }
    rt_image_free(im);
    free(r.a);
    rt_kd_free(kd);
    rt_scene_free(sc);
}

/* The mailbox writes dirty geometry lines: a simulator writes them back as
 * geometry traffic, where the compact layout's geometry is never written. */
static void pbrt_writebacks(const char *spec)
{
    rt_scene *sc;
    rt_kdtree *kd = load(spec, &sc);
    if (!kd) return;
    rt_sim_config c;
    rt_sim_config_default(&c);
    c.nsizes = 1;
    c.sizes[0] = 4096;
    uint64_t wb[2] = {0, 0}, wr[2] = {0, 0};
    for (int k = 0; k < 2; k++) {
        rt_render_opts o;
        rt_render_default_opts(&o);
        o.W = o.H = 32;
        o.lights = 7;
        o.geom = k ? RT_GEOM_PBRT : RT_GEOM_COMPACT;
        rt_err e = {0};
        rt_sim *sim = rt_sim_new(&c, &e);
        rt_job j;
        CHECK(sim && rt_job_setup_borrowed(&j, sc, kd, "recursive", &o, &e) == 0, "%s: %s", spec, e.msg);
        if (!sim) continue;
        rt_image *im = rt_image_new(o.W, o.H, &e);
        rt_run_stats st;
        CHECK(im && rt_job_run(&j, rt_sim_sink(sim), im, &st, &e) == 0 && rt_sim_finish(sim) == 0, "%s: %s", spec, e.msg);
        rt_sim_counts n;
        rt_sim_get(sim, 0, RT_CLS_TRI, &n);
        wb[k] = n.writebacks;
        wr[k] = n.write_misses;
        rt_image_free(im);
        rt_job_free(&j);
        rt_sim_free(sim);
    }
    /* the pbrt layouts model the k-d tree: a tracer on the grid is refused */
    rt_render_opts o;
    rt_render_default_opts(&o);
    o.geom = RT_GEOM_PBRT;
    rt_err e = {0};
    rt_job j;
    CHECK(rt_job_setup_borrowed(&j, sc, kd, "stream-branching", &o, &e) < 0 && e.usage && strstr(e.msg, "k-d tree"),
          "pbrt layout on the grid: %s", e.msg);
    /* ... and a sweep's job of such a tracer keeps the compact layout */
    rt_exp_config xc;
    memset(&xc, 0, sizeof xc);
    rt_render_default_opts(&xc.ro);
    xc.ro.geom = RT_GEOM_PBRT;
    rt_exp_job jr = {.scene = 0, .lighting = -1, .tracer = "recursive", .proxy = -1, .mode = RT_MODE_DEFAULT, .accel = RT_ACCEL_DEFAULT}, js = jr;
    js.tracer = "stream-branching";
    CHECK(rt_exp_job_opts(&xc, &jr).geom == RT_GEOM_PBRT && rt_exp_job_opts(&xc, &js).geom == RT_GEOM_COMPACT,
          "pbrt layout in a sweep of k-d and grid tracers");
    CHECK(wb[0] == 0 && wr[0] == 0 && wb[1] > 0, "%s at 4 KB: triangle write-backs compact %" PRIu64 ", pbrt %" PRIu64, spec,
          wb[0], wb[1]);
    rt_kd_free(kd);
    rt_scene_free(sc);
}


/* ---- the dynamic tracer's hypothesis options -------------------------------------- */

/* --hit-rule first ends a ray in the subtree where it found a hit: no
 * candidate re-entries, fewer enqueues, never a closer hit than the exact
 * rule's; --qp-measure triangles changes only the schedule, never the
 * image; both are in the run key and refused by the other tracers. */
static void dyn_hypotheses(const char *spec)
{
    rt_render_opts o;
    rt_render_default_opts(&o);
    char b[256];
    o.hit_rule = RT_HIT_FIRST;
    o.qp_measure = RT_QPM_TRIANGLES;
    CHECK(!strcmp(rt_job_params("dynamic", &o, NULL, b, sizeof b), "qorder=fullest threads=4 hit_rule=first qp_measure=triangles"),
          "hypotheses' key: '%s'", b);
    CHECK(!strcmp(rt_job_params("recursive", &o, NULL, b, sizeof b), ""), "recursive with hypotheses: '%s'", b);
    CHECK(rt_render_hit_rule_from_name("first") == RT_HIT_FIRST && rt_render_qp_measure_from_name("triangles") == RT_QPM_TRIANGLES &&
              rt_render_hit_rule_from_name("closest") == -1 && !strcmp(rt_render_qp_measure_name(RT_QPM_ALL), "all") &&
              rt_render_opt_group(rt_render_opt_find("--hit-rule")) == RT_OPTG_SCHED &&
              !strcmp(rt_render_opt_name(rt_render_opt_find("qp-measure")), "--qp-measure"),
          "hypotheses' names");
    rt_err e = {0};
    o.given = (uint64_t)1 << rt_render_opt_find("--hit-rule");
    CHECK(rt_tracer_check_given(rt_tracer_find("recursive"), &o, &e) < 0 && strstr(e.msg, "--hit-rule"),
          "--hit-rule accepted by the recursive tracer: %s", e.msg);
    o.hit_rule = 2;
    CHECK(rt_render_check_mode(&o, &e) < 0 && strstr(e.msg, "--hit-rule"), "hit rule 2 accepted: %s", e.msg);

    rt_scene *sc;
    rt_kdtree *kd = load(spec, &sc);
    if (!kd) return;
    rt_render_default_opts(&o);
    o.W = 40;
    o.H = 32;
    o.sched_size = 4096;
    o.queue_stats = 1;
    rt_image *a, *f, *t;
    rt_run_stats sa, sf, st;
    rec ra, rf, rt;
    rt_layout La, Lf, Lt;
    run(sc, kd, "dynamic", &o, &a, &sa, &ra, &La);
    o.hit_rule = RT_HIT_FIRST;
    run(sc, kd, "dynamic", &o, &f, &sf, &rf, &Lf);
    o.hit_rule = RT_HIT_EXACT;
    o.qp_measure = RT_QPM_TRIANGLES;
    run(sc, kd, "dynamic", &o, &t, &st, &rt, &Lt);
    if (a && f && t) {
        size_t closer = 0, lost = 0, differ = 0;
        for (int p = 0; p < o.W * o.H; p++) {
            closer += f->depth[p] < a->depth[p];
            lost += isfinite(a->depth[p]) && !isfinite(f->depth[p]);
            differ += f->depth[p] != a->depth[p];
        }
        CHECK(closer == 0 && lost == 0, "%s first hit: %zu pixels closer, %zu lost (%zu differ)", spec, closer, lost, differ);
        CHECK(key(sf.extra, "q_cand") == 0 && key(sa.extra, "q_cand") > 0 &&
                  key(sf.extra, "enqueues") < key(sa.extra, "enqueues") && sf.tests < sa.tests,
              "%s first hit: %s / exact: %s", spec, sf.extra, sa.extra);
        CHECK(!memcmp(a->rgb, t->rgb, sizeof(float) * 3 * 40 * 32) && key(st.extra, "gmax") != key(sa.extra, "gmax"),
              "%s qp-measure triangles: image differs or the same budget: %s / %s", spec, st.extra, sa.extra);
    }
    rt_image_free(a);
    rt_image_free(f);
    rt_image_free(t);
    free(ra.a);
    free(rf.a);
    free(rt.a);
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
    pbrt_recorder(RT_GEOM_PBRT);
    pbrt_recorder(RT_GEOM_PBRT64);
    if (check_tmpdir("test_layout")) {
        pbrt_one_triangle(RT_GEOM_PBRT);
        pbrt_one_triangle(RT_GEOM_PBRT64);
        check_rm_tree(check_dir);
    } else {
        CHECK(0, "temporary directory: %s", strerror(errno));
    }
    pbrt_writebacks("sphereflake:level=1");
    dyn_hypotheses("sphereflake:level=2");
    if (failures) fprintf(stderr, "%d failure(s)\n", failures);
    return failures ? 1 : 0;
}
