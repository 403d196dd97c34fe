/*
 * test_kdtree.c -- the k-d tree against brute force.
 *
 * For random triangle soups (with flat, axis-aligned, coplanar, tiny, huge
 * and degenerate triangles), a tessellated sphere and reduced versions of
 * the built-in scenes: rt_kd_check passes; rt_kd_closest finds the same
 * triangle at the same t as rt_brute_closest and rt_kd_occluded agrees with
 * rt_brute_occluded on many random rays (from random points inside the
 * bounds in random and axis-parallel directions, plus camera rays); two
 * builds are byte-identical; recorded accesses agree with the counters;
 * subtree sizes agree with a direct count; subtree-restricted traversal
 * composed over a cut of the tree equals the full traversal.
 * The quick tier compares 20,000 rays per scene (3,000 on room); the long
 * tier (RT_TEST_LONG=1) 100,000. An optional argument multiplies both.
 * Exit 0 on success; failures are printed and exit 1.
 */
#include "config.h"
#include "check.h"
#include "check_scene.h"
#include "kdtrav.h"
#include "kdtree.h"
#include "memmodel.h"
#include "scene.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>



/* ---- counting sink ------------------------------------------------------ */

typedef struct counts {
    uint64_t n[RT_NCLASS];     /* accesses per class */
    uint64_t bytes[RT_NCLASS]; /* bytes per class */
    int bad;                   /* an access outside its region */
    const rt_layout *L;
} counts;

static int count_put(rt_sink *sk, const rt_access *a, size_t n)
{
    counts *c = sk->ctx;
    for (size_t i = 0; i < n; i++) {
        c->n[a[i].cls]++;
        c->bytes[a[i].cls] += a[i].size;
        int ok = 0;
        for (int r = 0; r < c->L->n; r++) {
            const rt_region *g = &c->L->r[r];
            if (g->cls == a[i].cls && a[i].addr >= g->base && a[i].addr + a[i].size <= g->base + g->recsize * g->count)
                ok = 1;
        }
        if (!ok) c->bad++;
    }
    return 0;
}

/* ---- ray generation ----------------------------------------------------- */

typedef struct cam {
    rt_vec3 eye, dir, right, up;
} cam;

static void cam_setup(cam *c, const rt_scene *s)
{
    c->eye = s->cam.eye;
    c->dir = rt_norm(rt_sub(s->cam.at, s->cam.eye));
    c->right = rt_norm(rt_cross(c->dir, s->cam.up));
    c->up = rt_cross(c->right, c->dir);
    float th = tanf(s->cam.fovy_deg * 0.5f * 3.14159265f / 180.0f);
    c->right = rt_mul(c->right, th);
    c->up = rt_mul(c->up, th);
}

/* Ray kind k: 0..5 random interior, 6 axis-parallel with signed zeros,
 * 7 camera ray. Shadow-ish intervals on some. */
static void gen_ray(const rt_scene *s, const cam *c, rt_ray *r, int k)
{
    rt_bounds b = s->bounds;
    rt_vec3 ext = rt_sub(b.hi, b.lo);
    rt_vec3 o = rt_v3(uf(b.lo.x - 0.05f * ext.x, b.hi.x + 0.05f * ext.x), uf(b.lo.y - 0.05f * ext.y, b.hi.y + 0.05f * ext.y),
                      uf(b.lo.z - 0.05f * ext.z, b.hi.z + 0.05f * ext.z));
    rt_vec3 d;
    if (k == 7) {
        o = c->eye;
        d = rt_add(c->dir, rt_add(rt_mul(c->right, uf(-1, 1)), rt_mul(c->up, uf(-1, 1))));
    } else if (k == 6) {
        int ax = (int)(rnd64() % 3);
        d = rt_v3((rnd64() & 1) ? -0.0f : 0.0f, (rnd64() & 1) ? -0.0f : 0.0f, (rnd64() & 1) ? -0.0f : 0.0f);
        rt_set_axis(&d, ax, (rnd64() & 1) ? -1.0f : 1.0f);
    } else {
        d = rand_dir();
    }
    rt_ray_init(r, o, d);
    if (k == 5) { /* a segment, like a shadow ray */
        float len = rt_len(ext);
        r->tmin = uf(0, 0.1f * len);
        r->tmax = r->tmin + uf(0, len);
    }
}

/* Compares kd and brute force on nrays rays; returns rays that hit. */
static long compare_rays(const char *name, const rt_scene *s, const rt_kdtree *kd, long nrays)
{
    rt_trav tv;
    memset(&tv, 0, sizeof tv);
    tv.kd = kd;
    tv.sc = s;
    cam c;
    cam_setup(&c, s);
    long hits = 0;
    for (long i = 0; i < nrays; i++) {
        rt_ray r;
        gen_ray(s, &c, &r, (int)(i % 8));
        rt_hit hk, hb;
        int a = rt_kd_closest(&tv, &r, &hk);
        int b = rt_brute_closest(s, &r, &hb);
        hits += b;
        CHECK(a == b, "%s ray %ld: kd hit %d brute hit %d (brute tri %u t %.9g)", name, i, a, b, hb.tri, (double)hb.t);
        if (a && b) {
            CHECK(hk.tri == hb.tri, "%s ray %ld: kd tri %u t %.9g, brute tri %u t %.9g", name, i, hk.tri,
                  (double)hk.t, hb.tri, (double)hb.t);
            CHECK(fabsf(hk.t - hb.t) <= 1e-6f * fabsf(hb.t), "%s ray %ld: t %.9g vs %.9g", name, i, (double)hk.t,
                  (double)hb.t);
        }
        /* Occlusion over the same interval, and over (tmin, hit t) which
         * must be clear unless another triangle has the same t. */
        int oa = rt_kd_occluded(&tv, &r);
        CHECK(oa == b, "%s ray %ld: kd occluded %d but brute closest %d", name, i, oa, b);
        if ((i & 7) == 0) {
            int ob = rt_brute_occluded(s, &r);
            CHECK(oa == ob, "%s ray %ld: kd occluded %d brute %d", name, i, oa, ob);
        }
        if (b && (i & 7) == 1) {
            rt_ray sr = r;
            sr.tmax = hb.t;
            CHECK(rt_kd_occluded(&tv, &sr) == rt_brute_occluded(s, &sr), "%s ray %ld: short occlusion differs", name, i);
        }
    }
    return hits;
}

/* Subtree sizes against a direct count on every node. */
static void check_subsizes(const rt_kdtree *kd, const rt_scene *s)
{
    rt_kd_subsize *z = calloc(kd->nnodes, sizeof *z);
    uint8_t *seen = calloc(s->ntri, 1);
    rt_err e = {{0}};
    CHECK(rt_kd_subtree_sizes(kd, s->ntri, z, &e) == 0, "subtree sizes: %s", e.msg);
    for (uint32_t i = 0; i < kd->nnodes; i++) {
        /* The subtree of i is the index range [i, i + nodes). */
        uint32_t end = i + z[i].nodes, nidx = 0, ntri = 0;
        CHECK(end <= kd->nnodes, "subtree %u overruns", i);
        if (end > kd->nnodes) break;
        memset(seen, 0, s->ntri);
        for (uint32_t j = i; j < end; j++) {
            const rt_kdnode *nd = &kd->nodes[j];
            if (!rt_kd_is_leaf(nd)) continue;
            nidx += rt_kd_ntri(nd);
            for (uint32_t k = 0; k < rt_kd_ntri(nd); k++) {
                uint32_t t = kd->idx[rt_kd_first(nd) + k];
                if (!seen[t]) ntri++;
                seen[t] = 1;
            }
        }
        CHECK(nidx == z[i].nidx && ntri == z[i].ntri, "node %u: sizes %u/%u vs %u/%u", i, z[i].nidx, z[i].ntri, nidx,
              ntri);
    }
    CHECK(z[0].nodes == kd->nnodes && z[0].nidx == kd->nidx, "root sizes");
    free(z);
    free(seen);
}

/*
 * A scheduler-style walk: front to back down to depth `cut` (or a leaf), then
 * rt_kd_closest_sub on each subtree, stopping once the hit precedes the next
 * subtree. Must equal rt_kd_closest.
 */
static void cut_walk(rt_trav *tv, const rt_ray *r, uint32_t node, float t0, float t1, int depth, int cut, rt_hit *h)
{
    const rt_kdnode *nd = &tv->kd->nodes[node];
    if (h->tri != RT_NO_HIT && rt_kd_past(h->t, t0)) return;
    if (depth == cut || rt_kd_is_leaf(nd)) {
        rt_kd_closest_sub(tv, r, node, t0, t1, h);
        return;
    }
    int a = rt_kd_axis(nd);
    float sp = rt_kd_split(nd), o = rt_axis(r->o, a), d = rt_axis(r->d, a);
    float tp = (sp - o) * rt_axis(r->inv_d, a);
    int belowFirst = o < sp || (o == sp && d <= 0);
    uint32_t first = belowFirst ? node + 1 : rt_kd_above(nd), second = belowFirst ? rt_kd_above(nd) : node + 1;
    if (tp > t1 || tp <= 0) cut_walk(tv, r, first, t0, t1, depth + 1, cut, h);
    else if (tp < t0) cut_walk(tv, r, second, t0, t1, depth + 1, cut, h);
    else if (tp == tp) {
        cut_walk(tv, r, first, t0, tp, depth + 1, cut, h);
        cut_walk(tv, r, second, tp, t1, depth + 1, cut, h);
    } else {
        cut_walk(tv, r, first, t0, t1, depth + 1, cut, h);
        cut_walk(tv, r, second, t0, t1, depth + 1, cut, h);
    }
}

/* Recording, marks, determinism, subtree traversal. */
static void check_extras(const char *name, const rt_scene *s, const rt_kdtree *kd, long nrays)
{
    rt_err e = {{0}};
    /* Determinism. */
    rt_kdtree *kd2 = rt_kd_build(s, NULL, &e);
    CHECK(kd2 != NULL, "%s rebuild: %s", name, e.msg);
    if (kd2) {
        CHECK(kd2->nnodes == kd->nnodes && kd2->nidx == kd->nidx &&
                  !memcmp(kd2->nodes, kd->nodes, kd->nnodes * sizeof *kd->nodes) &&
                  !memcmp(kd2->idx, kd->idx, kd->nidx * sizeof *kd->idx),
              "%s: two builds differ", name);
        rt_kd_free(kd2);
    }
    /* Recording. */
    rt_layout L;
    rt_mm_init(&L);
    int rn = rt_mm_add(&L, "kd.nodes", RT_CLS_NODE, 8, kd->nnodes, &e);
    int ri = rt_mm_add(&L, "kd.index", RT_CLS_INDEX, 4, kd->nidx ? kd->nidx : 1, &e);
    int rtr = rt_mm_add(&L, "tri.verts", RT_CLS_TRI, 36, s->ntri, &e);
    CHECK(rn >= 0 && ri >= 0 && rtr >= 0, "layout: %s", e.msg);
    counts cnt;
    memset(&cnt, 0, sizeof cnt);
    cnt.L = &L;
    rt_sink sink = {count_put, &cnt};
    rt_rec *rec = rt_rec_new(&sink, &e);
    CHECK(rec != NULL, "rec: %s", e.msg);
    uint8_t *mark = calloc(s->ntri, 1);
    rt_trav tv;
    memset(&tv, 0, sizeof tv);
    tv.kd = kd;
    tv.sc = s;
    tv.rec = rec;
    tv.L = &L;
    tv.reg_node = rn;
    tv.reg_idx = ri;
    tv.reg_tri = rtr;
    tv.mark = mark;
    tv.mark_bit = 2;
    rt_trav plain;
    memset(&plain, 0, sizeof plain);
    plain.kd = kd;
    plain.sc = s;
    rt_trav sub = plain;
    cam c;
    cam_setup(&c, s);
    for (long i = 0; i < nrays; i++) {
        rt_ray r;
        gen_ray(s, &c, &r, (int)(i % 8));
        rt_hit h1, h2;
        int a = rt_kd_closest(&tv, &r, &h1);
        int b = rt_kd_closest(&plain, &r, &h2);
        CHECK(a == b && (!a || (h1.tri == h2.tri && h1.t == h2.t)), "%s: recording changes the result", name);
        if (a) CHECK(mark[h1.tri] & 2, "%s: hit triangle not marked", name);
        (void)rt_kd_occluded(&tv, &r);
        (void)rt_kd_occluded(&plain, &r);
        /* Subtree composition at several cuts. */
        rt_hit hc;
        rt_hit_none(&hc);
        float t0, t1;
        if (rt_kd_clip(kd, &r, &t0, &t1)) cut_walk(&sub, &r, 0, t0, t1, 0, 1 + (int)(i % 6), &hc);
        CHECK(hc.tri == h2.tri && (!b || hc.t == h2.t), "%s ray %ld: cut walk tri %u vs %u", name, i, hc.tri, h2.tri);
        if (rt_kd_clip(kd, &r, &t0, &t1))
            CHECK(rt_kd_occluded_sub(&sub, &r, 0, t0, t1) == b, "%s ray %ld: occluded_sub differs", name, i);
    }
    CHECK(rt_rec_flush(rec) == 0, "flush");
    CHECK(cnt.n[RT_CLS_NODE] == tv.nodes, "%s: node accesses %llu != nodes %llu", name,
          (unsigned long long)cnt.n[RT_CLS_NODE], (unsigned long long)tv.nodes);
    CHECK(cnt.n[RT_CLS_TRI] == tv.tests, "%s: tri accesses %llu != tests %llu", name,
          (unsigned long long)cnt.n[RT_CLS_TRI], (unsigned long long)tv.tests);
    CHECK(cnt.bytes[RT_CLS_NODE] == 8 * tv.nodes && cnt.bytes[RT_CLS_TRI] == 36 * tv.tests, "%s: access sizes", name);
    CHECK(cnt.bytes[RT_CLS_INDEX] >= 4 * tv.tests, "%s: index bytes %llu < 4 * tests", name,
          (unsigned long long)cnt.bytes[RT_CLS_INDEX]);
    CHECK(cnt.bad == 0, "%s: %d accesses outside their region", name, cnt.bad);
    CHECK(tv.nodes == plain.nodes && tv.tests == plain.tests, "%s: recorded run counted differently", name);
    rt_rec_free(rec);
    free(mark);
}

static void run_scene(const char *name, rt_scene *s, long nrays, long nextra, int subsizes)
{
    rt_err e = {{0}};
    double t0 = rt_now();
    rt_kdtree *kd = rt_kd_build(s, NULL, &e);
    CHECK(kd != NULL, "%s: build: %s", name, e.msg);
    if (!kd) return;
    double t1 = rt_now();
    CHECK(rt_kd_check(kd, s, &e) == 0, "%s: check: %s", name, e.msg);
    double t2 = rt_now();
    long hits = compare_rays(name, s, kd, nrays);
    double t3 = rt_now();
    check_extras(name, s, kd, nextra);
    if (subsizes) check_subsizes(kd, s);
    printf("%-22s tris %7u nodes %7u leaves %6u empty %6u depth %2u/%2u maxleaf %4u mean %.2f | build %.3fs "
           "check %.3fs rays %ld (%ld hit) %.2fs\n",
           name, s->ntri, kd->nnodes, kd->nleaves, kd->nempty, kd->maxdepth, kd->max_depth, kd->maxleaf,
           rt_kd_mean_leaf_tris(kd), t1 - t0, t2 - t1, nrays, hits, t3 - t2);
    rt_kd_free(kd);
}

static void test_small_cases(void)
{
    rt_err e = {{0}};
    /* Empty scene: one empty leaf; nothing hits. */
    rt_scene *s = rt_scene_new(0, NULL); /* not finished: finish rejects it */
    rt_kdtree *kd = rt_kd_build(s, NULL, &e);
    CHECK(kd && kd->nnodes == 1 && kd->nidx == 0, "empty scene tree");
    if (kd) {
        CHECK(rt_kd_check(kd, s, &e) == 0, "empty check: %s", e.msg);
        rt_trav tv;
        memset(&tv, 0, sizeof tv);
        tv.kd = kd;
        tv.sc = s;
        rt_ray r;
        rt_ray_init(&r, rt_v3(0, 0, 0), rt_v3(1, 0, 0));
        rt_hit h;
        CHECK(!rt_kd_closest(&tv, &r, &h) && h.tri == RT_NO_HIT, "empty scene hit");
        CHECK(!rt_kd_occluded(&tv, &r), "empty scene occluded");
    }
    rt_kd_free(kd);
    rt_kd_free(NULL);
    rt_scene_free(s);
    /* A single triangle and a stack of identical triangles (ties). */
    s = rt_scene_new(8, NULL);
    for (int i = 0; i < 8; i++) add(s, rt_v3(0, 0, 0), rt_v3(1, 0, 0), rt_v3(0, 1, 0));
    finish(s);
    kd = rt_kd_build(s, NULL, &e);
    CHECK(kd != NULL && rt_kd_check(kd, s, &e) == 0, "stack: %s", e.msg);
    if (kd) {
        rt_trav tv;
        memset(&tv, 0, sizeof tv);
        tv.kd = kd;
        tv.sc = s;
        rt_ray r;
        rt_ray_init(&r, rt_v3(0.25f, 0.25f, 1), rt_v3(0, 0, -1));
        rt_hit h;
        CHECK(rt_kd_closest(&tv, &r, &h) && h.tri == 0 && h.t == 1.0f, "tie: tri %u t %g", h.tri, (double)h.t);
    }
    rt_kd_free(kd);
    rt_scene_free(s);
    /* Out-of-memory paths: every allocation in the build fails in turn. */
    s = make_soup(200);
    for (long k = 1; k < 40; k++) {
        rt_fail_alloc_after = k;
        rt_kdtree *t = rt_kd_build(s, NULL, &e);
        int failed = t == NULL;
        rt_fail_alloc_after = 0;
        if (t) CHECK(rt_kd_check(t, s, &e) == 0, "oom %ld: %s", k, e.msg);
        rt_kd_free(t);
        if (!failed) break;
    }
    rt_scene_free(s);
}

int main(int argc, char **argv)
{
    rnd_seed(0x9e3779b97f4a7c15ULL);
    long scale = argc > 1 ? atol(argv[1]) : 1; /* ray-count multiplier */
    /* The quick tier compares fewer rays (brute force on room's 46,588
     * triangles is most of the time); the long tier runs 100,000 per scene. */
    int full = check_long();
    long rays = full ? 100000 : 20000;
    test_small_cases();

    rt_scene *s = make_soup(300);
    run_scene("soup-300", s, rays * scale, 5000, 1);
    rt_scene_free(s);
    s = make_soup(2000);
    run_scene("soup-2000", s, rays * scale, 5000, 0);
    rt_scene_free(s);
    s = make_sphere(8);
    run_scene("sphere-r8", s, rays * scale, 5000, 1);
    rt_scene_free(s);

    /* Built-in scenes at reduced size; rays in the long and quick tiers. */
    static const struct {
        const char *name, *params;
        long rays, quick;
    } bi[] = {
        {"cornell", NULL, 100000, 100000},
        {"knot", NULL, 100000, 20000},
        {"sphereflake", "level=2,tess=2", 100000, 20000},
        {"grove", "trees=1,depth=4,tess=2", 100000, 20000},
        {"room", NULL, 100000, 3000},
    };
    for (size_t i = 0; i < sizeof bi / sizeof bi[0]; i++) {
        rt_err e = {{0}};
        s = rt_scene_builtin(bi[i].name, bi[i].params, &e);
        CHECK(s != NULL, "builtin %s: %s", bi[i].name, e.msg);
        if (!s) continue;
        char label[64];
        snprintf(label, sizeof label, "%s%s%s", bi[i].name, bi[i].params ? ":" : "", bi[i].params ? bi[i].params : "");
        run_scene(label, s, (full ? bi[i].rays : bi[i].quick) * scale, 3000, s->ntri < 5000);
        rt_scene_free(s);
    }
    if (failures) fprintf(stderr, "%d failures\n", failures);
    return failures ? 1 : 0;
}
