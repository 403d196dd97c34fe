/* test_tracers.c -- the three tracers agree: identical RGB images on every
 * built-in scene (reduced size) for several schedules; the dynamic
 * scheduler's queue-point selection matches the paper's Figure 1; every ray
 * of every generation is resolved exactly once and the scheduler's
 * invariants (rt_dyn_check) hold at every step; with the root as the only
 * queue point the dynamic tracer reads exactly the geometry the recursive
 * tracer reads, in the same order. Each tracer's traffic is checked on its
 * own: every access lies in a region of the memory model's table
 * (docs/memory-model.md) with that region's class and record size, and the
 * per-region reference counts follow from the run's statistics and a
 * single-ray reference render; golden files (tests/golden/tracer_*.txt,
 * rewritten only with RT_REDO_GOLDEN=1) hold a hash of each full record
 * stream so a reordering is caught. The render modes: every mode of every
 * tracer matches an independent brute-force renderer (within a derived
 * tolerance) and the tracers agree bit for bit, with materials added to
 * the built-in scenes; the secondary modes' traffic follows the table. */
#include "scene_load.h"
#include "camera.h"
#include "check.h"
#include "dynamic.h"
#include "run.h"
#include "shade.h"
#include "stats.h"

#include <inttypes.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Renders with the tracer's invariant checks on (test mode) unless
 * quick is set: checking after every queue costs O(queues) per queue. */
static int quick;

static rt_image *render(rt_scene *sc, rt_kdtree *kd, const char *tracer, rt_render_opts *o, rt_sink *sink,
                        rt_run_stats *st)
{
    rt_err e = {0};
    rt_job j;
    if (rt_job_setup_borrowed(&j, sc, kd, tracer, o, &e) < 0) {
        CHECK(0, "setup %s: %s", tracer, e.msg);
        return NULL;
    }
    j.check = !quick;
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
    rt_err e = {0};
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
            o.sched_size = caches[c];
            o.qorder = qo;
            /* invariants checked at every step on the small trees and the larger budgets */
            quick = caches[c] < 262144 && strncmp(spec, "cornell", 7) && strcmp(spec, "knot");
            rt_image *dy = render(sc, kd, "dynamic", &o, NULL, &st);
            quick = 0;
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
    o.sched_size = 65536;
    o.qorder = 0;
    o.gmax = 200; /* forces oversized leaves processed in blocks */
    quick = strncmp(spec, "cornell", 7) && strcmp(spec, "knot"); /* a queue per leaf */
    rt_image *dy = render(sc, kd, "dynamic", &o, NULL, &st);
    quick = 0;
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

/* The derivation of g_max as it was first written, through rt_dyn_select
 * alone: the reference for rt_dyn_derive_gmax's counting walk. */
static uint64_t derive_ref(const rt_kdtree *kd, const uint64_t *g, uint64_t cache, uint64_t raybuf, int *fallback)
{
    *fallback = 0;
    if (cache <= raybuf) return 0;
    int32_t *qp = malloc(sizeof *qp * kd->nnodes);
    uint64_t gm = cache - raybuf;
    for (int it = 0; it < 64; it++) {
        uint32_t ntop = 0, nq = rt_dyn_select(kd, g, gm, qp, &ntop);
        uint64_t resident = raybuf + 8ull * ntop + 8ull * nq;
        uint64_t next = cache > resident ? cache - resident : 0;
        if (next >= gm) break;
        gm = next;
        if (gm == 0) break;
    }
    if (gm == 0) {
        uint64_t budget = (cache - raybuf) / 2, lo = 1, hi = g[0];
        while (lo < hi) {
            uint64_t mid = lo + (hi - lo) / 2;
            uint32_t ntop = 0, nq = rt_dyn_select(kd, g, mid, qp, &ntop);
            if (8ull * ntop + 8ull * nq <= budget) hi = mid;
            else lo = mid + 1;
        }
        gm = lo;
        *fallback = 1;
    }
    free(qp);
    return gm;
}

static void derive_gmax(void)
{
    rt_err e = {0};
    rt_scene *sc = rt_scene_load("sphereflake:level=2", &e);
    rt_kd_params kp;
    rt_kd_default_params(&kp);
    rt_kdtree *kd = sc ? rt_kd_build(sc, &kp, &e) : NULL;
    CHECK(kd != NULL, "scene: %s", e.msg);
    if (!kd) return;
    uint64_t *g = malloc(sizeof *g * kd->nnodes);
    CHECK(rt_dyn_subtree_geometry(kd, sc->ntri, g, &e) == 0, "subtree geometry: %s", e.msg);
    int fallbacks = 0, n = 0;
    for (uint64_t cache = 64; cache <= (8u << 20); cache = cache * 3 / 2 + 7, n++) {
        int f0 = -1, f1 = -1;
        uint64_t a = rt_dyn_derive_gmax(kd, g, cache, 128, &f0), b = derive_ref(kd, g, cache, 128, &f1);
        CHECK(a == b && f0 == f1, "cache %" PRIu64 ": g_max %" PRIu64 " (fallback %d), reference %" PRIu64 " (%d)",
              cache, a, f0, b, f1);
        fallbacks += f1;
    }
    CHECK(fallbacks > 0 && fallbacks < n, "the cases must include the fallback and the normal rule (%d of %d)",
          fallbacks, n);
    free(g);
    rt_kd_free(kd);
    rt_scene_free(sc);
}

/* rt_stats_finish counts marks eight at a time: against a byte loop on
 * random marks (every bit value, runs of zeros) of every length and offset
 * around a word. */
static void stats_marks(void)
{
    uint8_t mark[80];
    uint64_t x = 0x9e3779b97f4a7c15ull;
    for (int round = 0; round < 200; round++) {
        for (int i = 0; i < 80; i++) {
            x = x * 6364136223846793005ull + 1442695040888963407ull;
            const unsigned r = (unsigned)(x >> 56);
            mark[i] = round % 3 == 0 ? (uint8_t)r : r < 128 ? 0 : (uint8_t)(1u << (r & 7));
        }
        for (uint32_t off = 0; off < 9; off++)
            for (uint32_t n = 0; n + off <= 80; n += 7) {
                rt_run_stats st;
                rt_trav tv;
                memset(&st, 0, sizeof st);
                memset(&tv, 0, sizeof tv);
                rt_stats_finish(&st, &tv, mark + off, n);
                uint64_t p = 0, a = 0;
                for (uint32_t i = 0; i < n; i++) {
                    p += mark[off + i] & 1;
                    a += mark[off + i] != 0;
                }
                CHECK(st.pv_primary == p && st.pv_all == a, "stats: %u marks at %u: %" PRIu64 "/%" PRIu64
                      ", byte loop %" PRIu64 "/%" PRIu64, n, off, st.pv_primary, st.pv_all, p, a);
            }
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
    rt_err e = {0};
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
    rt_err e = {0};
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
    o.sched_size = 4096;
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

/* ---- traffic: sizes from the region table, counts from the statistics ---- */

/* The memory model's region table (docs/memory-model.md), written out here
 * independently of the tracers: class and record size of every region. */
static const struct {
    const char *name;
    int cls;
    uint32_t recsize;
} model[] = {
    {"kd.nodes", RT_CLS_NODE, 8},      {"kd.index", RT_CLS_INDEX, 4},     {"tri.verts", RT_CLS_TRI, 36},
    {"tri.shade", RT_CLS_SHADE, 16},   {"rays.primary", RT_CLS_RAY, 32},  {"packet.hits", RT_CLS_HIT, 8},
    {"dyn.raybuf", RT_CLS_RAY, 32},    {"dyn.qtable", RT_CLS_QTABLE, 8},  {"dyn.qpbox", RT_CLS_QTABLE, 24},
    {"dyn.top", RT_CLS_NODE, 8},       {"dyn.hits", RT_CLS_HIT, 24},      {"fb", RT_CLS_FB, 12},
    {"dyn.queues", RT_CLS_QUEUE, 32},  {"mat", RT_CLS_SHADE, 48},         {"packet.rays", RT_CLS_RAY, 64},
    {"dyn.spawn", RT_CLS_RAY, 64},     {"tri.vidx", RT_CLS_TRI, 12},      {"mesh.pos", RT_CLS_TRI, 12},
    {"mesh.normal", RT_CLS_SHADE, 12},
};

/* Per-region tallies of one run's record stream, plus structural facts. */
typedef struct tally {
    const rt_layout *L;
    const rt_kdtree *kd;
    uint64_t reads[RT_MM_MAX_REGIONS], writes[RT_MM_MAX_REGIONS], bytes[RT_MM_MAX_REGIONS];
    uint64_t by_size[RT_MM_MAX_REGIONS][2][4]; /* dyn.hits: [write][size 4, 8, 24, other] */
    uint64_t cls_refs[RT_NCLASS], cls_bytes[RT_NCLASS];
    uint64_t leaf_visits, leaf_bytes; /* node reads of leaves with triangles, their lists' bytes */
    uint64_t hash, n;                 /* FNV-1a over (addr, size, write, cls) in order */
    size_t bad;                       /* accesses breaking the region table */
    char why[256];                    /* the first of them */
    int tri_prefix;                   /* tri reads after an index read follow its list (-1: not checked) */
    uint32_t list_first, list_n, list_pos; /* the last index list read, tri reads since */
    size_t bad_order;
    /* mesh layout: a tri.vidx read is followed by the three positions it
     * names (a triangle test) or by the three normals and the tri.shade
     * record of the same triangle (shading) */
    const rt_mesh *mesh;              /* NULL: compact layout */
    uint32_t mtri;                    /* triangle of the last tri.vidx read */
    int mpend, mkind;                 /* vertex records still expected; 0 positions, 1 normals */
    int mshade;                       /* a tri.shade read of mtri is expected next */
    size_t bad_mesh;
    char why_mesh[160];
} tally;

/* One access against the mesh expansion rule (region name rn, record rec). */
static void mesh_order(tally *t, const char *rn, uint64_t rec)
{
    const char *why = NULL;
    int pos = !strcmp(rn, "mesh.pos"), nrm = !strcmp(rn, "mesh.normal");
    if (t->mpend) {
        int k = 3 - t->mpend;
        if (!pos && !nrm) why = "a triangle index record not followed by three vertex records";
        else if (k > 0 && t->mkind != nrm) why = "positions and normals mixed";
        else if (rec != t->mesh->vidx[3 * (size_t)t->mtri + (size_t)k]) why = "vertex record is not the triangle's vertex";
        t->mkind = nrm;
        if (!--t->mpend && nrm) t->mshade = 1;
    } else if (t->mshade) {
        if (strcmp(rn, "tri.shade") || rec != t->mtri) why = "normals not followed by the triangle's shading record";
        t->mshade = 0;
    } else if (pos || nrm) {
        why = "vertex record without a triangle index record";
    }
    if (!strcmp(rn, "tri.vidx")) {
        t->mtri = (uint32_t)rec;
        t->mpend = 3;
    }
    if (why && !t->bad_mesh++) snprintf(t->why_mesh, sizeof t->why_mesh, "access %" PRIu64 " (%s %" PRIu64 "): %s", t->n, rn, rec, why);
}

static void fnv(uint64_t *h, uint64_t v, int nbytes)
{
    for (int i = 0; i < nbytes; i++) {
        *h ^= (v >> (8 * i)) & 0xff;
        *h *= 0x100000001b3ULL;
    }
}

static int tally_put(rt_sink *s, const rt_access *a, size_t n)
{
    tally *t = s->ctx;
    const rt_layout *L = t->L;
    for (size_t i = 0; i < n; i++, t->n++) {
        fnv(&t->hash, a[i].addr, 8);
        fnv(&t->hash, a[i].size, 4);
        fnv(&t->hash, a[i].write, 1);
        fnv(&t->hash, a[i].cls, 1);
        t->cls_refs[a[i].cls < RT_NCLASS ? a[i].cls : 0]++;
        t->cls_bytes[a[i].cls < RT_NCLASS ? a[i].cls : 0] += a[i].size;
        int r = -1;
        for (int k = 0; k < L->n; k++)
            if (a[i].addr >= L->r[k].base && a[i].addr < L->r[k].base + L->r[k].recsize * L->r[k].count) r = k;
        const char *why = NULL;
        uint64_t off = r >= 0 ? a[i].addr - L->r[r].base : 0, rec = r >= 0 ? off / L->r[r].recsize : 0;
        if (r < 0) why = "outside every region";
        else if (a[i].cls != L->r[r].cls) why = "class differs from its region's";
        else if (off % L->r[r].recsize) why = "not at a record boundary";
        else if (!strcmp(L->r[r].name, "kd.index") ? a[i].size % 4 != 0 || off + a[i].size > 4 * L->r[r].count
                 : !strcmp(L->r[r].name, "dyn.hits") ? a[i].size != 24 && a[i].size != 8 && a[i].size != 4
                                                      : a[i].size != L->r[r].recsize)
            why = "size is not the region's record size";
        if (why) {
            if (!t->bad++)
                snprintf(t->why, sizeof t->why, "access %" PRIu64 " (addr %#" PRIx64 " size %u cls %u) %s (%s)", t->n,
                         a[i].addr, a[i].size, a[i].cls, why, r >= 0 ? L->r[r].name : "-");
            continue;
        }
        a[i].write ? t->writes[r]++ : t->reads[r]++;
        t->bytes[r] += a[i].size;
        if (t->mesh) mesh_order(t, L->r[r].name, rec);
        /* the list-order check below sees a mesh triangle test at its first
         * position read (a tri.vidx read followed by normals is shading) */
        int tri_test = !strcmp(L->r[r].name, "tri.verts") ||
                       (t->mesh && !strcmp(L->r[r].name, "mesh.pos") && t->mpend == 2);
        if (t->mesh && tri_test) rec = t->mtri;
        if (!strcmp(L->r[r].name, "dyn.hits"))
            t->by_size[r][a[i].write][a[i].size == 4 ? 0 : a[i].size == 8 ? 1 : a[i].size == 24 ? 2 : 3]++;
        if (!strcmp(L->r[r].name, "kd.nodes") && rec < t->kd->nnodes) {
            const rt_kdnode *nd = &t->kd->nodes[rec];
            if (rt_kd_is_leaf(nd) && rt_kd_ntri(nd)) {
                t->leaf_visits++;
                t->leaf_bytes += 4ull * rt_kd_ntri(nd);
            }
            t->list_n = 0;
        } else if (!strcmp(L->r[r].name, "kd.index")) {
            t->list_first = (uint32_t)rec;
            t->list_n = a[i].size / 4;
            t->list_pos = 0;
        } else if (tri_test && t->tri_prefix >= 0) {
            if (t->list_pos >= t->list_n || t->kd->idx[t->list_first + t->list_pos] != rec) t->bad_order++;
            t->list_pos++;
        } else if (t->tri_prefix >= 0 && strcmp(L->r[r].name, "tri.vidx") && strcmp(L->r[r].name, "mesh.pos")) {
            t->list_n = 0;
        }
    }
    return 0;
}

static uint64_t reads(const tally *t, const char *region)
{
    int r = rt_mm_find(t->L, region);
    return r >= 0 ? t->reads[r] : 0;
}
static uint64_t writes(const tally *t, const char *region)
{
    int r = rt_mm_find(t->L, region);
    return r >= 0 ? t->writes[r] : 0;
}
static uint64_t bytes_of(const tally *t, const char *region)
{
    int r = rt_mm_find(t->L, region);
    return r >= 0 ? t->bytes[r] : 0;
}

/* What a single-ray render finds (src/kdtrav.c, tested against brute force
 * in test_kdtree): traced pixels, hits, shadow rays and visible lights. */
typedef struct reference {
    uint64_t pixels, hits, shadow, visible;
} reference;

static reference single_ray(const rt_scene *sc, const rt_kdtree *kd, const rt_render_opts *o)
{
    reference R = {0, 0, 0, 0};
    rt_cam_frame cam;
    rt_cam_setup(&cam, sc, o->W, o->H);
    rt_trav tv;
    memset(&tv, 0, sizeof tv);
    tv.kd = kd;
    tv.sc = sc;
    for (int y = 0; y < o->H; y++)
        for (int x = 0; x < o->W; x++) {
            if (!rt_pixel_kept(o, x, y)) continue;
            rt_ray r;
            rt_hit h;
            rt_cam_ray(&cam, x, y, &r);
            R.pixels++;
            if (!rt_kd_closest(&tv, &r, &h)) continue;
            R.hits++;
            for (int i = 0; i < RT_NLIGHTS; i++) {
                rt_ray sr;
                if (!(o->lights & (1u << i)) || !rt_shade_ray(sc, &r, &h, i, &sr)) continue;
                R.shadow++;
                R.visible += !rt_kd_occluded(&tv, &sr);
            }
        }
    return R;
}

static uint64_t extra_u64(const rt_run_stats *st, const char *key)
{
    char k[64];
    snprintf(k, sizeof k, " %s=", key);
    const char *p = strstr(st->extra, k);
    if (!p && !strncmp(st->extra, k + 1, strlen(k + 1))) p = st->extra - 1;
    CHECK(p != NULL, "statistics lack %s: %s", key, st->extra);
    return p ? strtoull(p + strlen(k), NULL, 10) : 0;
}

static int nlights(unsigned m)
{
    int n = 0;
    for (int i = 0; i < RT_NLIGHTS; i++) n += (m >> i) & 1;
    return n;
}

/* One recorded run: the region table against the model, every access
 * against the table, and the per-region counts the statistics imply. Fills
 * *out (for golden files). */
static void traffic_run(rt_scene *sc, rt_kdtree *kd, const char *spec, const char *tracer, const rt_render_opts *o,
                        tally *out)
{
    rt_err e = {0};
    rt_job j;
    rt_run_stats st;
    memset(out, 0, sizeof *out);
    if (rt_job_setup_borrowed(&j, sc, kd, tracer, o, &e) < 0) {
        CHECK(0, "%s %s: %s", spec, tracer, e.msg);
        return;
    }
    j.check = 1;
    const char *tag = tracer;
    for (int r = 0; r < j.L.n; r++) {
        int known = 0;
        for (size_t m = 0; m < sizeof model / sizeof model[0]; m++) {
            if (strcmp(model[m].name, j.L.r[r].name)) continue;
            known = 1;
            CHECK(j.L.r[r].cls == model[m].cls && j.L.r[r].recsize == model[m].recsize,
                  "%s %s: region %s has class %u and %u-byte records; the memory model says %d and %u", spec, tag,
                  j.L.r[r].name, j.L.r[r].cls, j.L.r[r].recsize, model[m].cls, model[m].recsize);
        }
        CHECK(known, "%s %s: region %s is not in the memory model's table", spec, tag, j.L.r[r].name);
    }
    tally *t = out;
    t->L = &j.L;
    t->kd = kd;
    t->hash = 0xcbf29ce484222325ULL;
    t->tri_prefix = strcmp(tracer, "dynamic") ? 1 : -1;
    t->mesh = j.mesh;
    const int mesh = o->geom == RT_GEOM_MESH;
    if (mesh) tag = !strcmp(tracer, "recursive") ? "recursive/mesh" : !strcmp(tracer, "packet") ? "packet/mesh" : "dynamic/mesh";
    CHECK(!mesh == (j.mesh == NULL) && !mesh == (rt_mm_find(&j.L, "tri.verts") >= 0),
          "%s %s: the job's mesh and regions do not follow the layout", spec, tag);
    rt_sink sink = {tally_put, t};
    rt_image *im = rt_image_new(o->W, o->H, &e);
    if (!im || rt_job_run(&j, &sink, im, &st, &e) < 0) {
        CHECK(0, "%s %s: %s", spec, tag, e.msg);
        rt_image_free(im);
        rt_job_free(&j);
        return;
    }
    reference R = single_ray(sc, kd, o);
    const uint64_t P = st.rays_primary, H = R.hits, NL = (uint64_t)nlights(o->lights);
    /* triangle reads: 36-byte records, or (mesh) the index records not read for shading */
    const uint64_t TRI = mesh ? reads(t, "tri.vidx") - reads(t, "tri.shade") : reads(t, "tri.verts");
    const uint64_t TRIB = mesh ? TRI * 36 : bytes_of(t, "tri.verts");
    if (mesh) {
        int pr = rt_mm_find(&j.L, "mesh.pos"), nr = rt_mm_find(&j.L, "mesh.normal");
        CHECK(pr >= 0 && j.L.r[pr].count == j.mesh->nvert && (nr < 0 || j.L.r[nr].count == j.mesh->nvert),
              "%s %s: vertex arrays do not hold the mesh's %u vertices", spec, tag, j.mesh->nvert);
        CHECK(t->bad_mesh == 0, "%s %s: %zu accesses break the mesh expansion; first: %s", spec, tag, t->bad_mesh,
              t->why_mesh);
        CHECK(reads(t, "mesh.pos") == 3 * TRI && bytes_of(t, "mesh.pos") == 36 * TRI && !writes(t, "mesh.pos"),
              "%s %s: %" PRIu64 " position reads for %" PRIu64 " triangle reads", spec, tag, reads(t, "mesh.pos"), TRI);
        CHECK(reads(t, "mesh.normal") == 3 * H && bytes_of(t, "mesh.normal") == 36 * H && !writes(t, "mesh.normal"),
              "%s %s: %" PRIu64 " normal reads for %" PRIu64 " hits", spec, tag, reads(t, "mesh.normal"), H);
        CHECK(bytes_of(t, "tri.vidx") == 12 * reads(t, "tri.vidx") && !writes(t, "tri.vidx") && reads(t, "tri.vidx") >= H,
              "%s %s: %" PRIu64 " index-record reads, %" PRIu64 " B", spec, tag, reads(t, "tri.vidx"), bytes_of(t, "tri.vidx"));
    }
    CHECK(t->bad == 0, "%s %s: %zu accesses break the region table; first: %s", spec, tag, t->bad, t->why);
    CHECK(t->n == st.accesses, "%s %s: %" PRIu64 " accesses seen, %" PRIu64 " reported", spec, tag, t->n, st.accesses);
    CHECK(P == R.pixels && st.rays_shadow == R.shadow, "%s %s: %" PRIu64 "/%" PRIu64 " rays, reference %" PRIu64 "/%" PRIu64,
          spec, tag, P, st.rays_shadow, R.pixels, R.shadow);
    /* geometry */
    CHECK(reads(t, "tri.shade") == H && !writes(t, "tri.shade"), "%s %s: %" PRIu64 " shading reads, %" PRIu64 " hits", spec,
          tag, reads(t, "tri.shade"), H);
    /* a leaf visit reads its whole list (an oversized leaf at a dynamic
     * queue point instead reads it block by block: same bytes, more reads) */
    int blocked = !strcmp(tracer, "dynamic") && extra_u64(&st, "oversized_leaves") > 0;
    CHECK((blocked ? reads(t, "kd.index") >= t->leaf_visits : reads(t, "kd.index") == t->leaf_visits) &&
              bytes_of(t, "kd.index") == t->leaf_bytes,
          "%s %s: %" PRIu64 " index reads (%" PRIu64 " B) for %" PRIu64 " visits of non-empty leaves (%" PRIu64 " B)", spec,
          tag, reads(t, "kd.index"), bytes_of(t, "kd.index"), t->leaf_visits, t->leaf_bytes);
    CHECK(TRIB == 36 * TRI && !writes(t, "tri.verts"), "%s %s: triangle bytes %" PRIu64, spec, tag, TRIB);
    CHECK(reads(t, "rays.primary") == P && bytes_of(t, "rays.primary") == 32 * P && !writes(t, "rays.primary"),
          "%s %s: %" PRIu64 " primary ray reads for %" PRIu64 " rays", spec, tag, reads(t, "rays.primary"), P);
    /* the tests channel sums to the tests; the nodes channel counts per-ray
     * visits, which are the statistics' node visits for single rays only */
    double sn = 0, stt = 0;
    for (size_t p = 0; p < (size_t)o->W * o->H; p++) sn += im->nodes[p], stt += im->tests[p];
    CHECK(stt == (double)st.tests, "%s %s: tests channel sums to %.0f, statistics %" PRIu64, spec, tag, stt, st.tests);
    if (!strcmp(tracer, "recursive"))
        CHECK(sn == (double)st.nodes, "%s %s: nodes channel sums to %.0f, statistics %" PRIu64, spec, tag, sn, st.nodes);
    if (!strcmp(tracer, "recursive")) {
        CHECK(reads(t, "kd.nodes") == st.nodes && bytes_of(t, "kd.nodes") == 8 * st.nodes,
              "%s %s: %" PRIu64 " node reads, %" PRIu64 " visits", spec, tag, reads(t, "kd.nodes"), st.nodes);
        CHECK(TRIB == 36 * st.tests, "%s %s: %" PRIu64 " triangle bytes for %" PRIu64 " tests", spec, tag, TRIB, st.tests);
        CHECK(writes(t, "fb") == P && !reads(t, "fb") && bytes_of(t, "fb") == 12 * P, "%s %s: framebuffer %" PRIu64 "w/%" PRIu64
              "r", spec, tag, writes(t, "fb"), reads(t, "fb"));
        CHECK(t->bad_order == 0, "%s %s: %zu triangle reads not in their leaf's list order", spec, tag, t->bad_order);
    } else if (!strcmp(tracer, "packet")) {
        CHECK(reads(t, "kd.nodes") == st.nodes, "%s %s: %" PRIu64 " node reads, %" PRIu64 " packet visits", spec, tag,
              reads(t, "kd.nodes"), st.nodes);
        CHECK(TRI <= st.tests && TRI > 0, "%s %s: %" PRIu64 " triangle reads, %" PRIu64
              " ray tests", spec, tag, TRI, st.tests);
        CHECK(writes(t, "packet.hits") == P && reads(t, "packet.hits") == P * (1 + NL) && bytes_of(t, "packet.hits") == 8 * P * (2 + NL),
              "%s %s: hit buffer %" PRIu64 "w/%" PRIu64 "r", spec, tag, writes(t, "packet.hits"), reads(t, "packet.hits"));
        CHECK(writes(t, "fb") == P && !reads(t, "fb") && bytes_of(t, "fb") == 12 * P, "%s %s: framebuffer %" PRIu64 "w/%" PRIu64
              "r", spec, tag, writes(t, "fb"), reads(t, "fb"));
        CHECK(t->bad_order == 0, "%s %s: %zu triangle reads not in their leaf's list order", spec, tag, t->bad_order);
    } else {
        uint64_t enq = extra_u64(&st, "enqueues"), ev = extra_u64(&st, "queue_events");
        uint64_t over = extra_u64(&st, "oversized_leaves");
        int hr = rt_mm_find(&j.L, "dyn.hits");
        CHECK(writes(t, "dyn.queues") == enq && reads(t, "dyn.queues") == enq && bytes_of(t, "dyn.queues") == 64 * enq,
              "%s %s: queues %" PRIu64 "w/%" PRIu64 "r for %" PRIu64 " enqueues", spec, tag, writes(t, "dyn.queues"),
              reads(t, "dyn.queues"), enq);
        CHECK(reads(t, "dyn.qtable") == enq + ev && writes(t, "dyn.qtable") == enq && bytes_of(t, "dyn.qtable") == 8 * (2 * enq + ev),
              "%s %s: queue table %" PRIu64 "r/%" PRIu64 "w for %" PRIu64 " enqueues, %" PRIu64 " events", spec, tag,
              reads(t, "dyn.qtable"), writes(t, "dyn.qtable"), enq, ev);
        CHECK(reads(t, "dyn.qpbox") == ev && !writes(t, "dyn.qpbox"), "%s %s: %" PRIu64 " box reads, %" PRIu64 " events", spec,
              tag, reads(t, "dyn.qpbox"), ev);
        CHECK(writes(t, "dyn.raybuf") == enq && reads(t, "dyn.raybuf") <= enq, "%s %s: ray buffer %" PRIu64 "w/%" PRIu64 "r", spec,
              tag, writes(t, "dyn.raybuf"), reads(t, "dyn.raybuf"));
        CHECK(writes(t, "fb") == P + R.visible && reads(t, "fb") == R.visible && bytes_of(t, "fb") == 12 * (P + 2 * R.visible),
              "%s %s: framebuffer %" PRIu64 "w/%" PRIu64 "r, %" PRIu64 " pixels, %" PRIu64 " visible lights", spec, tag,
              writes(t, "fb"), reads(t, "fb"), P, R.visible);
        if (hr >= 0)
            CHECK(t->by_size[hr][1][2] == H && t->by_size[hr][1][0] == P - H && t->by_size[hr][0][2] == P * NL &&
                      !t->by_size[hr][0][0] && t->by_size[hr][1][3] + t->by_size[hr][0][3] == 0,
                  "%s %s: hit records: %" PRIu64 " 24-B writes (hits %" PRIu64 "), %" PRIu64 " 4-B writes, %" PRIu64
                  " 24-B reads", spec, tag, t->by_size[hr][1][2], H, t->by_size[hr][1][0], t->by_size[hr][0][2]);
        if (over == 0) {
            CHECK(reads(t, "kd.nodes") + reads(t, "dyn.top") == st.nodes, "%s %s: %" PRIu64 "+%" PRIu64 " node reads, %" PRIu64
                  " visits", spec, tag, reads(t, "kd.nodes"), reads(t, "dyn.top"), st.nodes);
            /* one read per test, plus one when a hit settled outside its
             * subtree is shaded (its vertices are not in cache then) */
            CHECK(TRI >= st.tests && TRI <= st.tests + H,
                  "%s %s: %" PRIu64 " triangle reads for %" PRIu64 " tests and %" PRIu64 " hits", spec, tag,
                  TRI, st.tests, H);
            if (extra_u64(&st, "queue_points") == 1)
                CHECK(TRI == st.tests, "%s %s: root only: %" PRIu64 " triangle reads, %" PRIu64 " tests",
                      spec, tag, TRI, st.tests);
        }
    }
    t->L = NULL;
    rt_image_free(im);
    rt_job_free(&j);
}

/* Golden record streams: one small file per tracer and scene. */
static void golden(const char *name, const char *spec, const char *tracer, const rt_render_opts *o, const tally *t,
                   const rt_layout *L)
{
    char text[4096];
    size_t n = 0;
    n += (size_t)snprintf(text + n, sizeof text - n, "# %s %s %dx%d lights=%u cache=%" PRIu64 " qorder=%d (RT_REDO_GOLDEN=1 rewrites)\n",
                          spec, tracer, o->W, o->H, o->lights, o->sched_size, o->qorder);
    n += (size_t)snprintf(text + n, sizeof text - n, "accesses %" PRIu64 "\nstream_fnv1a %016" PRIx64 "\n", t->n, t->hash);
    for (int c = 0; c < RT_NCLASS; c++)
        if (t->cls_refs[c])
            n += (size_t)snprintf(text + n, sizeof text - n, "class %s refs %" PRIu64 " bytes %" PRIu64 "\n", rt_class_name(c),
                                  t->cls_refs[c], t->cls_bytes[c]);
    for (int r = 0; r < L->n && n < sizeof text; r++)
        n += (size_t)snprintf(text + n, sizeof text - n, "region %s reads %" PRIu64 " writes %" PRIu64 " bytes %" PRIu64 "\n",
                              L->r[r].name, t->reads[r], t->writes[r], t->bytes[r]);
    const char *dir = getenv("srcdir");
    char path[1024];
    snprintf(path, sizeof path, "%s/tests/golden/tracer_%s.txt", dir ? dir : ".", name);
    if (getenv("RT_REDO_GOLDEN") && !strcmp(getenv("RT_REDO_GOLDEN"), "1")) {
        FILE *f = fopen(path, "w");
        CHECK(f && fputs(text, f) >= 0 && fclose(f) == 0, "cannot write %s", path);
        return;
    }
    char want[4096];
    FILE *f = fopen(path, "r");
    size_t m = f ? fread(want, 1, sizeof want - 1, f) : 0;
    if (f) fclose(f);
    want[m] = 0;
    CHECK(f != NULL, "missing golden file %s (RT_REDO_GOLDEN=1 writes it)", path);
    if (f) CHECK(!strcmp(want, text), "%s differs from this run:\n--- expected\n%s--- got\n%s", path, want, text);
}

static void traffic(const char *spec, int W, int H, const char *gold)
{
    rt_err e = {0};
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
    o.sched_size = 4096;
    static const char *tracers[] = {"recursive", "packet", "dynamic"};
    tally ctl[3];
    uint64_t ctri[3];
    for (int t = 0; t < 3; t++) {
        tally tl;
        traffic_run(sc, kd, spec, tracers[t], &o, &tl);
        ctl[t] = tl;
        rt_job j;
        if (rt_job_setup_borrowed(&j, sc, kd, tracers[t], &o, &e) == 0) {
            tl.L = &j.L;
            ctri[t] = reads(&tl, "tri.verts");
            if (gold) {
                char name[128];
                snprintf(name, sizeof name, "%s_%s", tracers[t], gold);
                golden(name, spec, tracers[t], &o, &tl, &j.L);
            }
            rt_job_free(&j);
        }
    }
    /* the mesh layout: the same stream but for the triangle and shading
     * reads, each expanded (mesh.h); the dynamic tracer also with
     * oversized leaves (a 1 KiB schedule) */
    o.geom = RT_GEOM_MESH;
    for (int t = 0; t < 4; t++) {
        tally tl;
        if (t == 3) o.sched_size = 1024;
        traffic_run(sc, kd, spec, tracers[t < 3 ? t : 2], &o, &tl);
        if (t == 3) break;
        rt_job j;
        if (rt_job_setup_borrowed(&j, sc, kd, tracers[t], &o, &e) < 0) continue;
        tl.L = &j.L;
        uint64_t tri = reads(&tl, "tri.vidx") - reads(&tl, "tri.shade");
        CHECK(tri == ctri[t], "%s %s: %" PRIu64 " triangle reads in the mesh layout, %" PRIu64 " in the compact one", spec,
              tracers[t], tri, ctri[t]);
        for (int c = 0; c < RT_NCLASS; c++)
            if (c != RT_CLS_TRI && c != RT_CLS_SHADE)
                CHECK(tl.cls_refs[c] == ctl[t].cls_refs[c] && tl.cls_bytes[c] == ctl[t].cls_bytes[c],
                      "%s %s: class %s: %" PRIu64 " refs in the mesh layout, %" PRIu64 " in the compact one", spec, tracers[t],
                      rt_class_name(c), tl.cls_refs[c], ctl[t].cls_refs[c]);
        rt_job_free(&j);
    }
    o.geom = RT_GEOM_COMPACT;
    o.sched_size = 4096;
    /* the dynamic tracer at other budgets and orders, and with light subsets */
    static const uint64_t caches[] = {1024, 16384, 1u << 24};
    for (int qo = 0; qo < 2; qo++)
        for (size_t c = 0; c < sizeof caches / sizeof caches[0]; c++) {
            tally tl;
            o.sched_size = caches[c];
            o.qorder = qo;
            o.lights = c == 1 ? 5 : 7;
            traffic_run(sc, kd, spec, "dynamic", &o, &tl);
        }
    o.lights = 0;
    o.qorder = 0;
    o.sched_size = 2048;
    for (int t = 0; t < 3; t++) {
        tally tl;
        traffic_run(sc, kd, spec, tracers[t], &o, &tl);
    }
    rt_kd_free(kd);
    rt_scene_free(sc);
}

/* A subsampling factor above the tile count (or one that keeps no tile)
 * would trace nothing: the job refuses it, naming the option and the tiles. */
static void subsample_refused(void)
{
    rt_err e = {0};
    rt_scene *sc = rt_scene_load("cornell:glass=0", &e);
    rt_kd_params kp;
    rt_kd_default_params(&kp);
    rt_kdtree *kd = sc ? rt_kd_build(sc, &kp, &e) : NULL;
    CHECK(kd != NULL, "cornell: %s", e.msg);
    if (!kd) {
        rt_scene_free(sc);
        return;
    }
    rt_render_opts o;
    rt_render_default_opts(&o);
    o.W = 20; /* 3 x 2 tiles of 8 (partial tiles count) */
    o.H = 16;
    o.subtile = 8;
    CHECK(rt_pixel_tiles(&o) == 6, "20x16 in tiles of 8: %" PRIu64 " tiles", rt_pixel_tiles(&o));
    static const char *tracers[] = {"recursive", "packet", "dynamic"};
    for (uint32_t K = 2; K <= 9; K++) {
        o.subsample = K;
        int kept = 0;
        for (int y = 0; y < o.H; y++)
            for (int x = 0; x < o.W; x++) kept += rt_pixel_kept(&o, x, y);
        for (int t = 0; t < 3; t++) {
            rt_job j;
            e.msg[0] = 0;
            int rc = rt_job_setup_borrowed(&j, sc, kd, tracers[t], &o, &e);
            if (rc == 0) rt_job_free(&j);
            if (K > 6)
                CHECK(rc < 0 && strstr(e.msg, "--subsample") && strstr(e.msg, "6 tiles"),
                      "%s: subsample %u of 6 tiles accepted or unnamed: %s", tracers[t], K, e.msg);
            else
                CHECK((rc == 0) == (kept > 0) && (rc == 0 || strstr(e.msg, "--subsample")),
                      "%s: subsample %u keeping %d pixels: rc %d (%s)", tracers[t], K, kept, rc, e.msg);
        }
    }
    rt_kd_free(kd);
    rt_scene_free(sc);
}

/* ---- secondary modes against an independent brute-force renderer -------
 *
 * ref_* below is written apart from tracegen/shade.c from the rules in
 * docs/tracers.md ("Modes"): real recursion instead of a ray stack, brute
 * force over all triangles instead of the k-d tree, and a double-precision
 * running sum in recursion order instead of the fixed-point accumulator.
 * Each contribution is computed with the same float operations, so the two
 * differ only in summation: the tracer rounds every contribution to 2^-32
 * (error <= 2^-33 each) and rounds the final sum to float once, the
 * reference sums in double (error ~ N 2^-53 |sum|) and rounds once; with N
 * contributions the results differ by at most N 2^-33 + 2 ulp(|v|), the
 * tolerance checked (per channel, after dividing by spp for both). */

typedef struct refr {
    const rt_scene *sc;
    const rt_render_opts *o;
    double acc[3];
    long n;       /* contributions added */
    long self;    /* rays that hit the triangle they left */
} refr;

static float ref_rand(uint32_t pix, uint32_t s, uint32_t b, uint32_t dim)
{
    uint64_t h = rt_mix64(((uint64_t)pix << 32) ^ s ^ 0x9e3779b97f4a7c15ULL);
    h = rt_mix64(h ^ ((uint64_t)b << 32) ^ dim ^ 0xd1b54a32d192ed03ULL);
    return (float)(h >> 40) * (1.0f / 16777216.0f);
}

static void ref_add(refr *R, float r, float g, float b)
{
    R->acc[0] += r;
    R->acc[1] += g;
    R->acc[2] += b;
    R->n++;
}

/* pbrt-v3 OffsetRayOrigin for the point at (u, v) of T. */
static rt_vec3 ref_offset(const rt_tri *T, float u, float v, rt_vec3 n, int side)
{
    const float g7 = (7 * 0x1p-24f) / (1 - 7 * 0x1p-24f);
    rt_vec3 e1 = rt_sub(T->p[1], T->p[0]), e2 = rt_sub(T->p[2], T->p[0]);
    rt_vec3 p = rt_add(T->p[0], rt_add(rt_mul(e1, u), rt_mul(e2, v)));
    const float g16 = (16 * 0x1p-24f) / (1 - 16 * 0x1p-24f);
    float c[3] = {p.x, p.y, p.z}, nn[3] = {n.x, n.y, n.z}, d = 0, ext = 0;
    float p0[3] = {T->p[0].x, T->p[0].y, T->p[0].z}, p1[3] = {T->p[1].x, T->p[1].y, T->p[1].z},
          p2[3] = {T->p[2].x, T->p[2].y, T->p[2].z};
    for (int k = 0; k < 3; k++) {
        float a0 = fabsf(p0[k]);
        d += fabsf(nn[k]) * (g7 * (a0 + fabsf(u) * (a0 + fabsf(p1[k])) + fabsf(v) * (a0 + fabsf(p2[k]))));
        ext = fmaxf(ext, fmaxf(fabsf(p0[k] - c[k]), fmaxf(fabsf(p1[k] - c[k]), fabsf(p2[k] - c[k]))));
    }
    d = d + g16 * ext;
    for (int k = 0; k < 3; k++) {
        float off = nn[k] * (side > 0 ? d : -d);
        c[k] = c[k] + off;
        if (off > 0) c[k] = nextafterf(c[k], INFINITY);
        if (off < 0) c[k] = nextafterf(c[k], -INFINITY);
    }
    return rt_v3(c[0], c[1], c[2]);
}

static float ref_ior(const rt_scene *sc, int m) { return m >= 0 ? sc->mat[m].ior : 1.0f; }

static void ref_trace(refr *R, rt_vec3 o, rt_vec3 dir, const float w[3], int depth, uint32_t pix, uint32_t s,
                      const uint16_t *med, int nmed, uint32_t from, rt_hit *first)
{
    const rt_scene *sc = R->sc;
    const rt_render_opts *op = R->o;
    const int path = op->mode == RT_MODE_PATH;
    rt_ray r;
    rt_hit h;
    rt_ray_init(&r, o, dir);
    if (!rt_brute_closest(sc, &r, &h)) {
        ref_add(R, w[0] * sc->background.x, w[1] * sc->background.y, w[2] * sc->background.z);
        if (first) first->tri = RT_NO_HIT;
        return;
    }
    if (first) *first = h;
    R->self += h.tri == from;
    const rt_tri *T = &sc->tri[h.tri];
    const float *alb = sc->shade[h.tri].rgb;
    int mi = (int)sc->shade[h.tri].mat;
    const rt_material *M = &sc->mat[mi];
    rt_vec3 n = rt_norm(rt_tri_normal(T));
    if (rt_dot(n, r.d) > 0) n = rt_mul(n, -1.0f);
    rt_vec3 d = rt_norm(r.d), ph = rt_tri_point(T, h.u, h.v);
    float loc[3];
    for (int k = 0; k < 3; k++) {
        loc[k] = path ? 0.0f : alb[k] * sc->ambient;
        if (!path && !op->lights) loc[k] = alb[k] * (sc->ambient + -rt_dot(n, d) * sc->light_power);
    }
    ref_add(R, w[0] * (loc[0] + M->ke[0]), w[1] * (loc[1] + M->ke[1]), w[2] * (loc[2] + M->ke[2]));
    rt_vec3 so = ref_offset(T, h.u, h.v, n, 1);
    for (int i = 0; i < RT_NLIGHTS; i++) {
        if (!(op->lights & (1u << i))) continue;
        rt_vec3 l = rt_norm(rt_sub(sc->light[i], ph));
        float ndl = rt_dot(n, l);
        if (!(ndl > 0)) continue;
        float f = ndl * sc->light_power, c[3];
        for (int k = 0; k < 3; k++) c[k] = w[k] * (alb[k] * f);
        if (c[0] == 0 && c[1] == 0 && c[2] == 0) continue;
        rt_ray sr;
        rt_ray_init(&sr, so, rt_sub(sc->light[i], so));
        sr.tmin = 0;
        sr.tmax = 1;
        if (!rt_brute_occluded(sc, &sr)) ref_add(R, c[0], c[1], c[2]);
    }
    rt_vec3 refl = rt_sub(d, rt_mul(n, 2.0f * rt_dot(d, n)));
    /* refraction through material mi with the media stack */
    uint16_t cm[RT_PATH_MEDIA];
    int cn = nmed;
    memcpy(cm, med, sizeof cm);
    int inside = nmed && med[nmed - 1] == mi;
    float ei = inside ? ref_ior(sc, mi) : ref_ior(sc, nmed ? med[nmed - 1] : -1);
    float et = inside ? ref_ior(sc, nmed >= 2 ? med[nmed - 2] : -1) : ref_ior(sc, mi);
    float eta = ei / et, cosi = -rt_dot(d, n), kk = 1.0f - eta * eta * (1.0f - cosi * cosi);
    int tir = kk < 0.0f;
    rt_vec3 tdir = tir ? d : rt_add(rt_mul(d, eta), rt_mul(n, eta * cosi - sqrtf(kk)));
    if (inside) cn--;
    else {
        if (cn == RT_PATH_MEDIA) {
            memmove(cm, cm + 1, sizeof cm[0] * (RT_PATH_MEDIA - 1));
            cn--;
        }
        cm[cn++] = (uint16_t)mi;
    }
    if (!path) {
        if (depth + 1 >= op->depth) return;
        float wr[3], wt[3];
        int anyt = 0, anyr = 0;
        for (int k = 0; k < 3; k++) {
            wr[k] = w[k] * M->ks[k];
            wt[k] = w[k] * M->kt[k];
            anyt |= wt[k] != 0;
        }
        if (anyt && tir)
            for (int k = 0; k < 3; k++) wr[k] = w[k] * (M->ks[k] + M->kt[k]);
        for (int k = 0; k < 3; k++) anyr |= wr[k] != 0;
        if (anyr) ref_trace(R, so, refl, wr, depth + 1, pix, s, med, nmed, h.tri, NULL);
        if (anyt && !tir) ref_trace(R, ref_offset(T, h.u, h.v, n, -1), tdir, wt, depth + 1, pix, s, cm, cn, h.tri, NULL);
        return;
    }
    if (depth >= op->bounces) return;
    float pd = (alb[0] + alb[1] + alb[2]) * (1.0f / 3.0f), ps = (M->ks[0] + M->ks[1] + M->ks[2]) * (1.0f / 3.0f);
    float pt = (M->kt[0] + M->kt[1] + M->kt[2]) * (1.0f / 3.0f), sum = pd + ps + pt;
    if (!(sum > 0)) return;
    float u = ref_rand(pix, s, (uint32_t)depth, 0) * sum, nw[3];
    int any = 0;
    if ((u < pd && pd > 0) || (!(ps > 0) && !(pt > 0))) {
        for (int k = 0; k < 3; k++) any |= (nw[k] = w[k] * (alb[k] * (sum / pd))) != 0;
        float x = 0, y = 0;
        for (uint32_t j = 0; j < 16; j++) {
            float a = 2.0f * ref_rand(pix, s, (uint32_t)depth, 1 + 2 * j) - 1.0f;
            float b = 2.0f * ref_rand(pix, s, (uint32_t)depth, 2 + 2 * j) - 1.0f;
            if (a * a + b * b < 1.0f) {
                x = a, y = b;
                break;
            }
        }
        float z = sqrtf(fmaxf(0.0f, 1.0f - x * x - y * y));
        float sg = copysignf(1.0f, n.z), aa = -1.0f / (sg + n.z), bb = n.x * n.y * aa;
        rt_vec3 t1 = rt_v3(1.0f + sg * n.x * n.x * aa, sg * bb, -sg * n.x), t2 = rt_v3(bb, sg + n.y * n.y * aa, -n.y);
        rt_vec3 nd = rt_add(rt_add(rt_mul(t1, x), rt_mul(t2, y)), rt_mul(n, z));
        if (any) ref_trace(R, so, nd, nw, depth + 1, pix, s, med, nmed, h.tri, NULL);
    } else if ((u < pd + ps && ps > 0) || !(pt > 0)) {
        for (int k = 0; k < 3; k++) any |= (nw[k] = w[k] * (M->ks[k] * (sum / ps))) != 0;
        if (any) ref_trace(R, so, refl, nw, depth + 1, pix, s, med, nmed, h.tri, NULL);
    } else {
        for (int k = 0; k < 3; k++) any |= (nw[k] = w[k] * (M->kt[k] * (sum / pt))) != 0;
        if (!any) return;
        if (tir) ref_trace(R, so, refl, nw, depth + 1, pix, s, med, nmed, h.tri, NULL);
        else ref_trace(R, ref_offset(T, h.u, h.v, n, -1), tdir, nw, depth + 1, pix, s, cm, cn, h.tri, NULL);
    }
}

/* Compares img with the reference, pixel by pixel; returns the number of
 * values that are not bit-identical (all must lie within the tolerance). */
static size_t ref_compare(const rt_scene *sc, const rt_render_opts *o, const rt_image *img, const char *what,
                          long *self)
{
    rt_cam_frame cam;
    rt_cam_setup(&cam, sc, o->W, o->H);
    size_t inexact = 0;
    int bad = 0;
    for (int y = 0; y < o->H; y++)
        for (int x = 0; x < o->W; x++) {
            size_t pix = (size_t)y * o->W + x;
            rt_ray eye;
            rt_cam_ray(&cam, x, y, &eye);
            float v[3];
            long n = 1;
            if (o->mode == RT_MODE_RAYCAST || o->mode == RT_MODE_SHADOW) {
                rt_hit h;
                int vis[RT_NLIGHTS] = {0};
                unsigned lights = o->mode == RT_MODE_RAYCAST ? 0 : o->lights;
                if (rt_brute_closest(sc, &eye, &h)) {
                    for (int i = 0; i < RT_NLIGHTS; i++) {
                        rt_ray sr;
                        if ((lights & (1u << i)) && rt_shade_ray(sc, &eye, &h, i, &sr)) vis[i] = !rt_brute_occluded(sc, &sr);
                    }
                    rt_shade_hit(sc, &eye, &h, vis, lights, v);
                } else {
                    v[0] = sc->background.x, v[1] = sc->background.y, v[2] = sc->background.z;
                }
            } else {
                int spp = o->mode == RT_MODE_PATH ? o->spp : 1;
                refr R = {sc, o, {0, 0, 0}, 0, 0};
                float w[3] = {1, 1, 1};
                uint16_t med[RT_PATH_MEDIA] = {0};
                for (int s = 0; s < spp; s++) ref_trace(&R, eye.o, eye.d, w, 0, (uint32_t)pix, (uint32_t)s, med, 0, RT_NO_HIT, NULL);
                for (int k = 0; k < 3; k++) v[k] = (float)(R.acc[k] / spp);
                n = R.n;
                *self += R.self;
            }
            for (int k = 0; k < 3; k++) {
                float a = img->rgb[3 * pix + k];
                double tol = (double)n * 0x1p-33 + 2.0 * (nextafterf(fabsf(v[k]), INFINITY) - fabsf(v[k]));
                if (o->mode == RT_MODE_RAYCAST || o->mode == RT_MODE_SHADOW) tol = 0;
                if (memcmp(&a, &v[k], sizeof a)) inexact++;
                if (!(fabs((double)a - v[k]) <= tol) && bad++ < 3)
                    CHECK(0, "%s: pixel (%d,%d) channel %d: %.9g, reference %.9g (%ld contributions)", what, x, y, k, a,
                          v[k], n);
            }
        }
    return inexact;
}

/* Adds hand-made materials to a built-in scene: mirrors, glass (ior 1.5,
 * a little mirror), emitters and a glossy mix on every 7th triangle. */
static void add_materials(rt_scene *sc)
{
    rt_err e = {0};
    rt_material m[4];
    memset(m, 0, sizeof m);
    for (int k = 0; k < 3; k++) {
        m[0].ks[k] = 0.8f;
        m[1].kt[k] = 0.9f, m[1].ks[k] = 0.05f;
        m[2].ke[k] = 0.5f;
        m[3].ks[k] = 0.3f;
    }
    m[1].kt[2] = 0.7f;
    for (int i = 0; i < 4; i++) m[i].ior = i == 1 ? 1.5f : 1.0f;
    int id[4];
    for (int i = 0; i < 4; i++) {
        id[i] = rt_scene_add_material(sc, &m[i], &e);
        CHECK(id[i] > 0, "add material: %s", e.msg);
    }
    for (uint32_t t = 0; t < sc->ntri; t++)
        if (t % 7 < 4 && id[t % 7] > 0) sc->shade[t].mat = (uint32_t)id[t % 7];
}

static const char *const mode_tracers[] = {"recursive", "packet", "dynamic", NULL};

/* Every mode of every tracer that runs it against the reference, and the
 * tracers against each other bit for bit. */
static void modes_vs_reference(const char *spec, int W, int H)
{
    rt_err e = {0};
    rt_scene *sc = rt_scene_load(spec, &e);
    CHECK(sc != NULL, "%s: %s", spec, e.msg);
    if (!sc) return;
    add_materials(sc);
    rt_kd_params kp;
    rt_kd_default_params(&kp);
    rt_kdtree *kd = rt_kd_build(sc, &kp, &e);
    CHECK(kd != NULL, "%s: %s", spec, e.msg);
    for (int mode = RT_MODE_RAYCAST; mode <= RT_MODE_PATH; mode++) {
        rt_render_opts o;
        rt_render_default_opts(&o);
        o.W = W, o.H = H, o.lights = 7, o.mode = mode;
        o.depth = 4, o.spp = 2, o.bounces = 3;
        o.sched_size = 4096;
        rt_image *first = NULL;
        for (int t = 0; mode_tracers[t]; t++) {
            const rt_tracer *tr = rt_tracer_find(mode_tracers[t]);
            if (!(tr->modes & (1u << mode))) continue;
            rt_run_stats st;
            rt_image *im = render(sc, kd, mode_tracers[t], &o, NULL, &st);
            if (!im) continue;
            char what[128];
            snprintf(what, sizeof what, "%s %s mode %s", spec, mode_tracers[t], rt_render_mode_name(mode));
            if (!first) {
                long self = 0;
                size_t inexact = ref_compare(sc, &o, im, what, &self);
                printf("%s: %zu of %d values not bit-identical to the reference (within tolerance)\n", what, inexact,
                       3 * W * H);
                CHECK(self == 0, "%s: %ld reference rays hit the triangle they left", what, self);
                const char *p = strstr(st.extra, "self_hits=");
                if (p) CHECK(strtoull(p + 10, NULL, 10) == 0, "%s: %s", what, st.extra);
                first = im;
            } else {
                CHECK(count_diff(first, im) == 0, "%s differs from recursive in %zu values", what, count_diff(first, im));
                rt_image_free(im);
            }
        }
        rt_image_free(first);
    }
    rt_kd_free(kd);
    rt_scene_free(sc);
}

/* Traffic of the render modes on a scene with hand-made materials, the
 * tracers' invariant checks on (the dynamic tracer's I7: every ray resolved
 * as the single-ray traversal resolves it): every access lies in a region
 * of the table; in every mode every tracer shades the same hits (tri.shade
 * reads agree) into a bit-identical image; in the secondary modes each
 * reads one material record per shaded hit (none in the others); the
 * stored secondary rays are written once and read once each; and a shadow
 * run of the same scene touches no material record: its stream is the one
 * of the scene without materials, access for access. */
static void traffic_modes(const char *spec, int W, int H)
{
    rt_err e = {0};
    rt_scene *sc = rt_scene_load(spec, &e), *plain = rt_scene_load(spec, &e);
    CHECK(sc && plain, "%s: %s", spec, e.msg);
    if (!sc || !plain) return;
    add_materials(sc);
    rt_kd_params kp;
    rt_kd_default_params(&kp);
    rt_kdtree *kd = rt_kd_build(sc, &kp, &e), *kdp = rt_kd_build(plain, &kp, &e);
    for (int t = 0; mode_tracers[t]; t++) {
        rt_render_opts o;
        rt_render_default_opts(&o);
        o.W = W, o.H = H, o.lights = 7, o.sched_size = 4096;
        tally *a = calloc(2, sizeof *a);
        traffic_run(sc, kd, spec, mode_tracers[t], &o, &a[0]);
        traffic_run(plain, kdp, spec, mode_tracers[t], &o, &a[1]);
        CHECK(a[0].hash == a[1].hash && a[0].n == a[1].n, "%s %s: materials change the shadow-mode stream", spec,
              mode_tracers[t]);
        free(a);
    }
    for (int mode = RT_MODE_RAYCAST; mode <= RT_MODE_PATH; mode++) {
        const int secondary = mode >= RT_MODE_WHITTED;
        uint64_t shade0 = 0;
        rt_image *first = NULL;
        for (int t = 0; mode_tracers[t]; t++) {
            rt_render_opts o;
            rt_render_default_opts(&o);
            o.W = W, o.H = H, o.lights = 7, o.sched_size = 4096, o.mode = mode, o.depth = 4, o.spp = 2, o.bounces = 3;
            rt_job j;
            rt_run_stats st;
            const char *tr = mode_tracers[t];
            if (rt_job_setup_borrowed(&j, sc, kd, tr, &o, &e) < 0) {
                CHECK(0, "%s %s: %s", spec, tr, e.msg);
                continue;
            }
            j.check = 1;
            tally *ty = calloc(1, sizeof *ty);
            ty->L = &j.L;
            ty->kd = kd;
            ty->tri_prefix = -1;
            rt_sink sink = {tally_put, ty};
            rt_image *im = rt_image_new(W, H, &e);
            CHECK(im && rt_job_run(&j, &sink, im, &st, &e) == 0, "%s %s: %s", spec, tr, e.msg);
            const char *m = rt_render_mode_name(mode);
            CHECK(ty->bad == 0, "%s %s %s: %zu accesses break the region table; first: %s", spec, tr, m, ty->bad, ty->why);
            /* the same hits shaded the same way: bit-identical images */
            if (!first) first = im;
            else if (im) CHECK(count_diff(first, im) == 0, "%s %s %s: image differs from recursive in %zu values", spec, tr, m,
                               count_diff(first, im));
            if (!secondary) CHECK(reads(ty, "mat") == 0, "%s %s %s: %" PRIu64 " material reads", spec, tr, m, reads(ty, "mat"));
            else CHECK(reads(ty, "mat") == reads(ty, "tri.shade") && reads(ty, "mat") > 0 && !writes(ty, "mat"),
                  "%s %s %s: %" PRIu64 " material reads for %" PRIu64 " shaded hits", spec, tr, m, reads(ty, "mat"),
                  reads(ty, "tri.shade"));
            if (!shade0) shade0 = reads(ty, "tri.shade");
            CHECK(reads(ty, "tri.shade") == shade0, "%s %s %s: %" PRIu64 " shaded hits, recursive %" PRIu64, spec, tr, m,
                  reads(ty, "tri.shade"), shade0);
            if (!secondary) {
                if (im != first) rt_image_free(im);
                free(ty);
                rt_job_free(&j);
                continue;
            }
            uint64_t nsec = extra_u64(&st, "rays_secondary");
            CHECK(nsec > 0, "%s %s %s: no secondary rays (%s)", spec, tr, m, st.extra);
            const char *store = !strcmp(tr, "packet") ? "packet.rays" : !strcmp(tr, "dynamic") ? "dyn.spawn" : NULL;
            if (store)
                CHECK(writes(ty, store) == nsec && reads(ty, store) == nsec,
                      "%s %s %s: %s written %" PRIu64 ", read %" PRIu64 " times for %" PRIu64 " rays", spec, tr, m, store,
                      writes(ty, store), reads(ty, store), nsec);
            if (!strcmp(tr, "packet")) printf("%s packet %s: %s\n", spec, m, st.extra);
            if (im != first) rt_image_free(im);
            free(ty);
            rt_job_free(&j);
        }
        rt_image_free(first);
    }
    rt_kd_free(kd);
    rt_kd_free(kdp);
    rt_scene_free(sc);
    rt_scene_free(plain);
}

int main(void)
{
    traffic_modes("cornell", 16, 16);
    traffic_modes("sphereflake:level=1", 16, 16);
    modes_vs_reference("cornell", 24, 20);
    modes_vs_reference("knot", 20, 20);
    modes_vs_reference("sphereflake:level=1", 20, 20);
    subsample_refused();
    traffic("cornell:glass=0", 16, 16, "cornell");
    traffic("knot", 16, 16, "knot");
    traffic("sphereflake:level=1", 24, 20, NULL);
    subsampling("cornell:glass=0", 64, 48, 4, 8);
    subsampling("sphereflake:level=2", 48, 48, 3, 1);
    figure1();
    derive_gmax();
    stats_marks();
    degenerate();
    same_images("cornell:glass=0", 48, 40);
    same_images("cornell", 32, 24); /* with the glass sphere */
    same_images("knot", 48, 48);
    same_images("sphereflake:level=2", 48, 48);
    same_images("grove", 40, 32);
    same_images("room", 48, 36);
    if (failures) fprintf(stderr, "%d failure(s)\n", failures);
    return failures ? 1 : 0;
}
