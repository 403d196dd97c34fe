/*
 * test_bvh.c -- the bounding volume hierarchies (accel/bvh.h) against
 * brute force and the k-d tree.
 *
 * For random triangle soups, a tessellated sphere, coplanar overlapping
 * triangles and every built-in scene (reduced sizes), at widths 2, 4 and 8:
 * rt_bvh_check passes; rt_bvh_closest returns exactly rt_brute_closest's
 * rt_hit (t, u, v, triangle, bit for bit) and exactly rt_kd_closest's on
 * random rays, rays aimed at vertices and edge midpoints, axis-parallel
 * rays with signed zeros, rays starting on surfaces and segments;
 * rt_bvh_occluded agrees with the closest hit and with rt_brute_occluded;
 * the SSE2 walk (and, where the processor has AVX, bvh8's AVX walk, run
 * beside its SSE2 copy) equals the scalar reference walk (rt_bvh_plain) in
 * hits, node and test counts and marks, and records the reference walk's
 * stream access for access (a hash of the whole sequence, the SSE2 and AVX
 * copies taking turns); recorded node bytes
 * are nodes x node size and triangle bytes tests x 36, every access inside
 * its region; two builds are byte-identical. The checker rejects a shrunk
 * box, a dropped and a duplicated triangle; a failing allocator at every
 * allocation of the build gives an error (and, under ASan, no leak); bad
 * parameters and awkward input (degenerate triangles, one triangle, a
 * shared centroid, coordinates of +-1e30 and at the loaders' range limit)
 * give a valid tree or an error.
 * The k-d tree equals brute force too, bit for bit, but on rays starting
 * exactly on a triangle that lies flat in one of its split planes, where
 * brute force takes that triangle at a t of rounding size and the k-d walk
 * does not look behind the plane (docs/kdtree.md; kd_own_start checks each
 * such ray is one, the count is printed).
 * Quick tier: 20,000 rays per scene against the k-d tree and the scalar
 * walk, brute force on up to 20,000 (fewer on the larger scenes); a ray
 * whose BVH hit differs from the k-d tree's is always decided by brute
 * force. RT_TEST_LONG=1: 100,000 rays,
 * all against brute force, and the full sphereflake (brute force on 200 of
 * its rays). Exit 0 on success.
 */
#include "config.h"
#include "bvh.h"
#include "check.h"
#include "check_scene.h"
#include "kdtrav.h"
#include "kdtree.h"
#include "memmodel.h"
#include "scene.h"
#include "scene_load.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static const int widths[3] = {2, 4, 8};

static int same_bits(float a, float b) { return memcmp(&a, &b, sizeof a) == 0; }

static int same_hit(const rt_hit *a, const rt_hit *b)
{
    return a->tri == b->tri && same_bits(a->t, b->t) && same_bits(a->u, b->u) && same_bits(a->v, b->v);
}

/*
 * The one way the k-d tree may differ from brute force (docs/kdtree.md,
 * "Agreement with brute force"): the ray starts exactly on a triangle
 * lying flat in an axis plane that is one of the tree's split planes, the
 * walk does not go behind that plane, and brute force takes the ray's own
 * triangle at a t of rounding size. 1 when the brute-force hit hb is such
 * a hit on ray r.
 */
static int kd_own_start(const rt_kdtree *kd, const rt_scene *s, const rt_ray *r, const rt_hit *hb)
{
    if (hb->tri == RT_NO_HIT) return 0;
    const rt_tri *t = &s->tri[hb->tri];
    const float o[3] = {r->o.x, r->o.y, r->o.z}, d[3] = {fabsf(r->d.x), fabsf(r->d.y), fabsf(r->d.z)};
    const float om = fmaxf(fmaxf(fabsf(o[0]), fabsf(o[1])), fabsf(o[2])), dm = fmaxf(fmaxf(d[0], d[1]), d[2]);
    if (!(hb->t * dm <= (1.0f + om) * (1.0f / 1048576.0f))) return 0; /* not at the origin */
    for (int a = 0; a < 3; a++) {
        if (rt_axis(t->p[0], a) != o[a] || rt_axis(t->p[1], a) != o[a] || rt_axis(t->p[2], a) != o[a]) continue;
        for (uint32_t i = 0; i < kd->nnodes; i++)
            if (!rt_kd_is_leaf(&kd->nodes[i]) && rt_kd_axis(&kd->nodes[i]) == a && rt_kd_split(&kd->nodes[i]) == o[a])
                return 1;
    }
    return 0;
}

static rt_bvh *build_w(const rt_scene *s, int w, rt_err *e)
{
    rt_bvh_params p;
    rt_bvh_default_params(&p, w);
    return rt_bvh_build(s, &p, e);
}

/* ---- sinks ---------------------------------------------------------------- */

typedef struct counts {
    uint64_t n[RT_NCLASS];     /* accesses per class */
    uint64_t bytes[RT_NCLASS]; /* bytes per class */
    int bad;                   /* accesses outside their region or off a record */
    uint64_t hash;             /* FNV-1a over (addr, size, cls) in order: the sequence */
    const rt_layout *L;
} counts;

static int count_put(rt_sink *sk, const rt_access *a, size_t n)
{
    counts *c = sk->ctx;
    for (size_t i = 0; i < n; i++) {
        c->n[a[i].cls]++;
        c->bytes[a[i].cls] += a[i].size;
        const uint64_t v[3] = {a[i].addr, a[i].size, a[i].cls};
        for (int k = 0; k < 3; k++) c->hash = (c->hash ^ v[k]) * 0x100000001b3ull;
        int ok = 0;
        for (int r = 0; r < c->L->n; r++) {
            const rt_region *g = &c->L->r[r];
            if (g->cls == a[i].cls && a[i].addr >= g->base && a[i].addr + a[i].size <= g->base + g->recsize * g->count &&
                (a[i].addr - g->base) % g->recsize == 0 && a[i].size == g->recsize)
                ok = 1;
        }
        if (!ok) c->bad++;
    }
    return 0;
}

/* ---- rays ------------------------------------------------------------------ */

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

/* Ray kind k (mod 10): 0..3 random interior, 4 a segment, 5 axis-parallel
 * with signed zeros, 6 camera ray, 7 aimed at a vertex or an edge midpoint
 * of a random triangle (shared edges), 8 from a point on a random
 * triangle's surface in a random direction, 9 along an edge of a random
 * triangle (origin at a vertex beyond the edge's other end). */
static void gen_ray(const rt_scene *s, const cam *c, rt_ray *r, int k)
{
    const rt_bounds b = s->bounds;
    const rt_vec3 ext = rt_sub(b.hi, b.lo);
    rt_vec3 o = rt_v3(uf(b.lo.x - 0.05f * ext.x, b.hi.x + 0.05f * ext.x), uf(b.lo.y - 0.05f * ext.y, b.hi.y + 0.05f * ext.y),
                      uf(b.lo.z - 0.05f * ext.z, b.hi.z + 0.05f * ext.z));
    rt_vec3 d = rand_dir();
    k %= 10;
    const rt_tri *t = s->ntri ? &s->tri[rnd64() % s->ntri] : NULL;
    if (k == 5) {
        d = rt_v3((rnd64() & 1) ? -0.0f : 0.0f, (rnd64() & 1) ? -0.0f : 0.0f, (rnd64() & 1) ? -0.0f : 0.0f);
        rt_set_axis(&d, (int)(rnd64() % 3), (rnd64() & 1) ? -1.0f : 1.0f);
        if (t && (rnd64() & 1)) { /* through a vertex, exactly along an axis */
            const rt_vec3 p = t->p[rnd64() % 3];
            o = p;
            for (int a = 0; a < 3; a++)
                if (rt_axis(d, a) != 0.0f) rt_set_axis(&o, a, rt_axis(p, a) - rt_axis(d, a) * rt_axis(ext, a));
        }
    } else if (k == 6) {
        o = c->eye;
        d = rt_add(c->dir, rt_add(rt_mul(c->right, uf(-1, 1)), rt_mul(c->up, uf(-1, 1))));
    } else if (k == 7 && t) {
        const int v = (int)(rnd64() % 3);
        const rt_vec3 target = (rnd64() & 1) ? t->p[v] : rt_mul(rt_add(t->p[v], t->p[(v + 1) % 3]), 0.5f);
        d = rt_sub(target, o);
    } else if (k == 8 && t) {
        float u = uf(0, 1), v = uf(0, 1);
        if (u + v > 1) u = 1 - u, v = 1 - v;
        o = rt_tri_point(t, u, v);
    } else if (k == 9 && t) {
        const int v = (int)(rnd64() % 3);
        const rt_vec3 a = t->p[v], e = t->p[(v + 1) % 3];
        d = rt_sub(e, a);
        o = rt_sub(a, rt_mul(d, uf(0, 2)));
    }
    if (d.x == 0 && d.y == 0 && d.z == 0) d = rt_v3(0, 0, 1);
    rt_ray_init(r, o, d);
    if (k == 4) {
        const float len = rt_len(ext);
        r->tmin = uf(0, 0.1f * len);
        r->tmax = r->tmin + uf(0, len);
    }
}

/* ---- one scene ------------------------------------------------------------ */

typedef struct wtree {
    rt_bvh *b;
    rt_layout L;
    int rn, rt;
    rt_bvh_trav fast, plain, recd; /* SSE2 (bvh8: AVX where it runs), scalar, recording */
    rt_bvh_trav sse, precd;        /* bvh8's SSE2 copy beside the AVX one; the scalar walk recording */
    counts cnt, cnt_p;
    rt_sink sink, sink_p;
    uint8_t *mark_f, *mark_p;
} wtree;

static void run_scene(const char *name, const rt_scene *s, long nrays, long nbrute)
{
    rt_err e = {0};
    const double t0 = rt_now();
    rt_kdtree *kd = rt_kd_build(s, NULL, &e);
    CHECK(kd != NULL, "%s: kd build: %s", name, e.msg);
    if (!kd) return;
    rt_trav kv;
    memset(&kv, 0, sizeof kv);
    kv.kd = kd;
    kv.sc = s;
    wtree T[3];
    memset(T, 0, sizeof T);
    for (int w = 0; w < 3; w++) {
        wtree *x = &T[w];
        x->b = build_w(s, widths[w], &e);
        CHECK(x->b != NULL, "%s bvh%d: build: %s", name, widths[w], e.msg);
        if (!x->b) goto out;
        CHECK(rt_bvh_check(x->b, s, &e) == 0, "%s bvh%d: check: %s", name, widths[w], e.msg);
        /* determinism */
        rt_bvh *b2 = build_w(s, widths[w], &e);
        const rt_bvh *b1 = x->b;
        const size_t nsz = rt_bvh_node_size(widths[w]);
        const void *n1 = widths[w] == 2 ? (const void *)b1->n2 : widths[w] == 4 ? (const void *)b1->n4 : (const void *)b1->n8;
        const void *n2 = !b2 ? NULL : widths[w] == 2 ? (const void *)b2->n2 : widths[w] == 4 ? (const void *)b2->n4 : (const void *)b2->n8;
        CHECK(b2 && b2->nnodes == b1->nnodes && (!b1->nnodes || !memcmp(n1, n2, nsz * b1->nnodes)) &&
                  !memcmp(b1->orig, b2->orig, 4 * (size_t)b1->ntri) && b1->sah == b2->sah,
              "%s bvh%d: two builds differ", name, widths[w]);
        rt_bvh_free(b2);
        rt_mm_init(&x->L);
        CHECK(rt_bvh_layout(x->b, &x->L, &x->rn, &x->rt, &e) == 0 && x->rn == 0 && x->rt == 1, "%s: layout: %s", name,
              e.msg);
        CHECK(rt_bvh_layout(x->b, &x->L, NULL, NULL, &e) < 0, "%s: a second layout passes", name);
        x->cnt.L = x->cnt_p.L = &x->L;
        x->cnt.hash = x->cnt_p.hash = 0xcbf29ce484222325ull;
        x->sink.put = x->sink_p.put = count_put;
        x->sink.ctx = &x->cnt;
        x->sink_p.ctx = &x->cnt_p;
        x->mark_f = calloc(s->ntri ? s->ntri : 1, 1);
        x->mark_p = calloc(s->ntri ? s->ntri : 1, 1);
        rt_bvh_trav_init(&x->fast, x->b, s, NULL, NULL);
        rt_bvh_trav_init(&x->plain, x->b, s, NULL, NULL);
        rt_bvh_trav_init(&x->recd, x->b, s, rt_rec_new(&x->sink, &e), &x->L);
        CHECK(x->recd.rec && x->recd.reg_node == x->rn && x->recd.reg_tri == x->rt, "%s: trav init", name);
        rt_bvh_trav_init(&x->sse, x->b, s, NULL, NULL);
        rt_bvh_trav_init(&x->precd, x->b, s, rt_rec_new(&x->sink_p, &e), &x->L);
        CHECK(x->precd.rec != NULL, "%s: trav init", name);
        CHECK(x->b->fast_avx == (widths[w] == 8 && rt_bvh_avx_usable()), "%s bvh%d: fast_avx %d", name, widths[w],
              x->b->fast_avx);
        x->fast.mark = x->mark_f;
        x->plain.mark = x->mark_p;
        x->fast.mark_bit = x->plain.mark_bit = 4;
    }
    cam c;
    cam_setup(&c, s);
    const double t1 = rt_now();
    long hits = 0, bad = 0;
    long kd_own = 0; /* rays where the k-d tree differs from brute force: all must start on their own triangle */
    for (long i = 0; i < nrays && bad < 10; i++) {
        rt_ray r;
        gen_ray(s, &c, &r, (int)i);
        rt_hit hk, hb;
        const int ak = rt_kd_closest(&kv, &r, &hk);
        const int brute = i < nbrute;
        int ab = 0;
        if (brute) {
            ab = rt_brute_closest(s, &r, &hb);
            if (!(ak == ab && same_hit(&hk, &hb))) {
                const int own = kd_own_start(kd, s, &r, &hb);
                CHECK(own, "%s ray %ld kind %ld: k-d hit %d tri %u t %a u %a, brute force %d tri %u t %a u %a", name, i,
                      i % 10, ak, hk.tri, (double)hk.t, (double)hk.u, ab, hb.tri, (double)hb.t, (double)hb.u);
                kd_own += own;
                if (!own) bad++;
            }
        }
        hits += ak;
        for (int w = 0; w < 3; w++) {
            wtree *x = &T[w];
            rt_hit h, hp, hr;
            const int a = rt_bvh_closest(&x->fast, &r, &h);
            const uint64_t pn0 = x->plain.nodes, pt0 = x->plain.tests;
            const int ap = rt_bvh_plain(&x->plain, &r, &hp, 0);
            const uint64_t pn = x->plain.nodes - pn0, pt = x->plain.tests - pt0, sn0 = x->sse.nodes, st0 = x->sse.tests;
            /* the recording walk: bvh8's AVX and SSE2 copies take turns */
            const int avx = x->b->fast_avx;
            x->b->fast_avx = avx && (i & 1);
            const int ar = rt_bvh_closest(&x->recd, &r, &hr);
            x->b->fast_avx = avx;
            rt_hit hpr, hs;
            const int apr = rt_bvh_plain(&x->precd, &r, &hpr, 0);
            x->b->fast_avx = 0;
            const int as = rt_bvh_closest(&x->sse, &r, &hs);
            const uint64_t sn = x->sse.nodes - sn0, stt = x->sse.tests - st0;
            const int os = rt_bvh_occluded(&x->sse, &r);
            x->b->fast_avx = avx;
            CHECK(apr == ap && same_hit(&hpr, &hp) && as == ap && same_hit(&hs, &hp) && os == as &&
                      sn == pn && stt == pt,
                  "%s bvh%d ray %ld: the SSE2 copy or the recording reference walk differs", name, widths[w], i);
            int ok;
            if (brute) {
                ok = a == ab && same_hit(&h, &hb);
            } else {
                ok = a == ak && same_hit(&h, &hk);
                if (!ok) { /* brute force decides; the k-d tree may differ only on its own start */
                    rt_hit hb2;
                    const int ab2 = rt_brute_closest(s, &r, &hb2);
                    ok = a == ab2 && same_hit(&h, &hb2);
                    if (ok && w == 0) {
                        const int own = kd_own_start(kd, s, &r, &hb2);
                        CHECK(own, "%s ray %ld kind %ld: k-d hit %d tri %u t %a, brute force and bvh %d tri %u t %a", name,
                              i, i % 10, ak, hk.tri, (double)hk.t, ab2, hb2.tri, (double)hb2.t);
                        kd_own += own;
                        if (!own) bad++;
                    }
                }
            }
            CHECK(ok, "%s bvh%d ray %ld kind %ld: hit %d tri %u t %a u %a, kd %d tri %u t %a u %a", name, widths[w], i,
                  i % 10, a, h.tri, (double)h.t, (double)h.u, ak, hk.tri, (double)hk.t, (double)hk.u);
            CHECK(ap == a && ar == a && same_hit(&hp, &h) && same_hit(&hr, &h) && x->fast.nodes == x->plain.nodes &&
                      x->fast.tests == x->plain.tests && x->recd.nodes == x->fast.nodes,
                  "%s bvh%d ray %ld: the scalar / recording walk differs (nodes %llu/%llu tests %llu/%llu)", name,
                  widths[w], i, (unsigned long long)x->fast.nodes, (unsigned long long)x->plain.nodes,
                  (unsigned long long)x->fast.tests, (unsigned long long)x->plain.tests);
            const int oc = rt_bvh_occluded(&x->fast, &r);
            const int op = rt_bvh_plain(&x->plain, &r, NULL, 1);
            const int orc = rt_bvh_occluded(&x->recd, &r);
            CHECK(rt_bvh_plain(&x->precd, &r, NULL, 1) == orc, "%s bvh%d ray %ld: recorded occlusion", name, widths[w], i);
            CHECK(oc == a && op == oc && orc == oc && x->fast.tests == x->plain.tests && x->fast.nodes == x->plain.nodes,
                  "%s bvh%d ray %ld: occluded %d/%d/%d, closest %d", name, widths[w], i, oc, op, orc, a);
            if (brute && (i & 7) == 0) CHECK(oc == rt_brute_occluded(s, &r), "%s bvh%d ray %ld: occluded vs brute", name, widths[w], i);
            if (a && (i & 7) == 1) {
                rt_ray sr = r;
                sr.tmax = h.t; /* clear unless another triangle has the same t */
                CHECK(rt_bvh_occluded(&x->fast, &sr) == rt_kd_occluded(&kv, &sr) &&
                          rt_bvh_plain(&x->plain, &sr, NULL, 1) == rt_kd_occluded(&kv, &sr) &&
                          rt_bvh_occluded(&x->recd, &sr) == rt_kd_occluded(&kv, &sr) &&
                          rt_bvh_plain(&x->precd, &sr, NULL, 1) == rt_kd_occluded(&kv, &sr),
                      "%s bvh%d ray %ld: short occlusion", name, widths[w], i);
            }
            if (!ok) bad++;
        }
    }
    for (int w = 0; w < 3; w++) {
        wtree *x = &T[w];
        CHECK(!memcmp(x->mark_f, x->mark_p, s->ntri), "%s bvh%d: marks differ", name, widths[w]);
        CHECK(rt_rec_flush(x->recd.rec) == 0 && rt_rec_flush(x->precd.rec) == 0, "flush");
        CHECK(x->cnt.hash == x->cnt_p.hash && x->cnt.n[RT_CLS_NODE] == x->cnt_p.n[RT_CLS_NODE] &&
                  x->cnt.n[RT_CLS_TRI] == x->cnt_p.n[RT_CLS_TRI],
              "%s bvh%d: the recording walk's access stream differs from the reference walk's", name, widths[w]);
        const uint64_t nsz = rt_bvh_node_size(widths[w]);
        CHECK(x->cnt.n[RT_CLS_NODE] == x->recd.nodes && x->cnt.bytes[RT_CLS_NODE] == nsz * x->recd.nodes,
              "%s bvh%d: node bytes %llu != %llu nodes x %llu", name, widths[w],
              (unsigned long long)x->cnt.bytes[RT_CLS_NODE], (unsigned long long)x->recd.nodes, (unsigned long long)nsz);
        CHECK(x->cnt.n[RT_CLS_TRI] == x->recd.tests && x->cnt.bytes[RT_CLS_TRI] == 36 * x->recd.tests,
              "%s bvh%d: triangle bytes %llu != 36 x %llu tests", name, widths[w],
              (unsigned long long)x->cnt.bytes[RT_CLS_TRI], (unsigned long long)x->recd.tests);
        CHECK(x->cnt.bad == 0, "%s bvh%d: %d accesses outside their records", name, widths[w], x->cnt.bad);
        rt_bvh_stat st;
        rt_bvh_stats(x->b, &st);
        printf("%-32s bvh%d tris %7u nodes %7u leaves %7u depth %2u sah %8.3f build %.3fs | %.1f nodes %.1f tests/ray\n",
               name, widths[w], s->ntri, st.nodes, st.leaves, st.depth, st.sah, st.build_sec,
               (double)x->fast.nodes / (2.0 * (double)nrays), (double)x->fast.tests / (2.0 * (double)nrays));
    }
    printf("%-32s builds and checks %.2fs, %ld rays (%ld against brute force) %.2fs | k-d equals brute force but on %ld"
           " rays starting on their own triangle in a split plane\n",
           name, t1 - t0, nrays, nbrute < nrays ? nbrute : nrays, rt_now() - t1, kd_own);
    CHECK(hits > nrays / 20, "%s: only %ld of %ld rays hit: the comparison saw too few hits", name, hits, nrays);
out:
    for (int w = 0; w < 3; w++) {
        rt_rec_free(T[w].recd.rec);
        rt_rec_free(T[w].precd.rec);
        free(T[w].mark_f);
        free(T[w].mark_p);
        rt_bvh_free(T[w].b);
    }
    rt_kd_free(kd);
}

/* ---- small and awkward cases ------------------------------------------------ */

/* Build all widths, check, compare with brute force on n random rays. */
static void small_scene(const char *name, const rt_scene *s, long n)
{
    rt_err e = {0};
    cam c;
    cam_setup(&c, s);
    for (int w = 0; w < 3; w++) {
        rt_bvh *b = build_w(s, widths[w], &e);
        CHECK(b != NULL, "%s bvh%d: %s", name, widths[w], e.msg);
        if (!b) continue;
        CHECK(rt_bvh_check(b, s, &e) == 0, "%s bvh%d: check: %s", name, widths[w], e.msg);
        rt_bvh_trav tv;
        rt_bvh_trav_init(&tv, b, s, NULL, NULL);
        for (long i = 0; i < n; i++) {
            rt_ray r;
            gen_ray(s, &c, &r, (int)i);
            rt_hit h, hb;
            const int a = rt_bvh_closest(&tv, &r, &h), ab = rt_brute_closest(s, &r, &hb);
            CHECK(a == ab && same_hit(&h, &hb), "%s bvh%d ray %ld: hit %d tri %u t %g, brute %d tri %u t %g", name,
                  widths[w], i, a, h.tri, (double)h.t, ab, hb.tri, (double)hb.t);
            CHECK(rt_bvh_occluded(&tv, &r) == rt_brute_occluded(s, &r), "%s bvh%d ray %ld: occluded", name, widths[w], i);
        }
        rt_bvh_free(b);
    }
}

/* A tree that shares the scene's triangles (share_tris = 1, the default
 * from RT_BVH_SHARE_MIN triangles on) is the copying tree without its
 * copy: the same nodes, and on n rays the same hits, visits and tests. */
static void shared_vs_copy(const char *name, const rt_scene *s, long n)
{
    rt_err e = {0};
    cam c;
    cam_setup(&c, s);
    for (int w = 0; w < 3; w++) {
        rt_bvh_params p;
        rt_bvh_default_params(&p, widths[w]);
        CHECK(p.share_tris == -1, "default share_tris %d", p.share_tris);
        rt_bvh *d = rt_bvh_build(s, &p, &e);
        p.share_tris = 0;
        rt_bvh *cp = rt_bvh_build(s, &p, &e);
        p.share_tris = 1;
        rt_bvh *sh = rt_bvh_build(s, &p, &e);
        CHECK(d && cp && sh, "%s bvh%d: %s", name, widths[w], e.msg);
        if (d && cp && sh) {
            CHECK((d->tri == NULL) == (s->ntri >= RT_BVH_SHARE_MIN) && cp->tri != NULL && sh->tri == NULL,
                  "%s bvh%d: which trees copy", name, widths[w]);
            CHECK(rt_bvh_check(sh, s, &e) == 0, "%s bvh%d shared: check: %s", name, widths[w], e.msg);
            CHECK(sh->nnodes == cp->nnodes && !memcmp(sh->orig, cp->orig, s->ntri * sizeof *sh->orig),
                  "%s bvh%d: shared tree's nodes or order differ", name, widths[w]);
            rt_bvh_trav ta, tb, tp;
            rt_bvh_trav_init(&ta, cp, s, NULL, NULL);
            rt_bvh_trav_init(&tb, sh, s, NULL, NULL);
            rt_bvh_trav_init(&tp, sh, s, NULL, NULL);
            long hits = 0;
            for (long i = 0; i < n; i++) {
                rt_ray r;
                gen_ray(s, &c, &r, (int)i);
                rt_hit ha, hb, hp;
                const int a = rt_bvh_closest(&ta, &r, &ha), b = rt_bvh_closest(&tb, &r, &hb);
                const int pl = rt_bvh_plain(&tp, &r, &hp, 0);
                hits += a;
                CHECK(a == b && pl == b && same_hit(&ha, &hb) && same_hit(&hp, &hb) &&
                          rt_bvh_occluded(&ta, &r) == rt_bvh_occluded(&tb, &r),
                      "%s bvh%d ray %ld: shared tree hit %d tri %u, copy %d tri %u", name, widths[w], i, b, hb.tri, a,
                      ha.tri);
            }
            CHECK(ta.nodes == tb.nodes && ta.tests == tb.tests && hits > n / 20,
                  "%s bvh%d: visits %llu / %llu, tests %llu / %llu, %ld hits", name, widths[w],
                  (unsigned long long)ta.nodes, (unsigned long long)tb.nodes, (unsigned long long)ta.tests,
                  (unsigned long long)tb.tests, hits);
        }
        rt_bvh_free(d);
        rt_bvh_free(cp);
        rt_bvh_free(sh);
    }
}

static void test_small_cases(void)
{
    rt_err e = {0};
    /* Empty scene: no nodes; nothing hits. */
    rt_scene *s = rt_scene_new(0, NULL);
    for (int w = 0; w < 3; w++) {
        rt_bvh *b = build_w(s, widths[w], &e);
        CHECK(b && b->nnodes == 0 && rt_bvh_check(b, s, &e) == 0, "empty bvh%d: %s", widths[w], e.msg);
        if (b) {
            rt_bvh_trav tv;
            rt_bvh_trav_init(&tv, b, s, NULL, NULL);
            rt_ray r;
            rt_ray_init(&r, rt_v3(0, 0, 0), rt_v3(1, 0, 0));
            rt_hit h;
            CHECK(!rt_bvh_closest(&tv, &r, &h) && h.tri == RT_NO_HIT && !rt_bvh_occluded(&tv, &r), "empty hit");
        }
        rt_bvh_free(b);
    }
    rt_bvh_free(NULL);
    rt_scene_free(s);

    /* Bad parameters. */
    s = make_soup(50);
    rt_bvh_params p;
    rt_bvh_default_params(&p, 3);
    CHECK(!rt_bvh_build(s, &p, &e) && strstr(e.msg, "width"), "width 3 accepted: %s", e.msg);
    rt_bvh_default_params(&p, 4);
    p.max_leaf = 0;
    CHECK(!rt_bvh_build(s, &p, &e) && strstr(e.msg, "leaf"), "leaf size 0 accepted");
    rt_bvh_default_params(&p, 8);
    p.max_leaf = 5;
    CHECK(!rt_bvh_build(s, &p, &e), "bvh8 leaf size 5 accepted");
    rt_bvh_default_params(&p, 2);
    p.isect_cost = NAN;
    CHECK(!rt_bvh_build(s, &p, &e), "NaN cost accepted");
    /* Leaf sizes 1 and 16 (bvh2, bvh4), 1 (bvh8). */
    for (int w = 0; w < 3; w++)
        for (int ml = 1; ml <= 16; ml += 15) {
            if (widths[w] == 8 && ml > 4) continue;
            rt_bvh_default_params(&p, widths[w]);
            p.max_leaf = ml;
            rt_bvh *b = rt_bvh_build(s, &p, &e);
            CHECK(b && rt_bvh_check(b, s, &e) == 0, "bvh%d leaf %d: %s", widths[w], ml, e.msg);
            rt_bvh_free(b);
        }
    rt_scene_free(s);

    /* One triangle; a stack of identical triangles (ties: lowest index). */
    s = rt_scene_new(1, NULL);
    add(s, rt_v3(0, 0, 0), rt_v3(1, 0, 0), rt_v3(0, 1, 0));
    finish(s);
    small_scene("one triangle", s, 500);
    rt_scene_free(s);
    s = rt_scene_new(40, NULL);
    for (int i = 0; i < 40; i++) add(s, rt_v3(0, 0, 0), rt_v3(1, 0, 0), rt_v3(0, 1, 0));
    finish(s);
    for (int w = 0; w < 3; w++) {
        rt_bvh *b = build_w(s, widths[w], &e);
        CHECK(b && rt_bvh_check(b, s, &e) == 0, "stack bvh%d: %s", widths[w], e.msg);
        if (!b) continue;
        rt_bvh_trav tv;
        rt_bvh_trav_init(&tv, b, s, NULL, NULL);
        rt_ray r;
        rt_ray_init(&r, rt_v3(0.25f, 0.25f, 1), rt_v3(0, 0, -1));
        rt_hit h;
        CHECK(rt_bvh_closest(&tv, &r, &h) && h.tri == 0 && h.t == 1.0f, "stack bvh%d: tri %u t %g", widths[w], h.tri,
              (double)h.t);
        rt_bvh_free(b);
    }
    small_scene("identical stack", s, 500);
    rt_scene_free(s);

    /* Coplanar overlapping triangles in z = 0 (and z = 0.5), listed in
     * shuffled spatial order: every perpendicular ray ties at one t, and
     * the lowest index among those it hits must win. */
    s = rt_scene_new(600, NULL);
    for (int i = 0; i < 600; i++) {
        const float z = (i % 3 == 0) ? 0.5f : 0.0f;
        const rt_vec3 ctr = rt_v3(uf(0, 1), uf(0, 1), z);
        const float r0 = uf(0.05f, 0.3f);
        add(s, rt_add(ctr, rt_v3(-r0, -r0, 0)), rt_add(ctr, rt_v3(r0, -r0, 0)), rt_add(ctr, rt_v3(0, r0, 0)));
    }
    finish(s);
    small_scene("coplanar", s, 2000);
    for (int w = 0; w < 3; w++) {
        rt_bvh *b = build_w(s, widths[w], &e);
        if (!b) continue;
        rt_bvh_trav tv;
        rt_bvh_trav_init(&tv, b, s, NULL, NULL);
        int ok = 1;
        for (int i = 0; i < 2000; i++) {
            rt_ray r;
            rt_ray_init(&r, rt_v3(uf(0, 1), uf(0, 1), (i & 1) ? 2.0f : -1.0f), rt_v3(0, 0, (i & 1) ? -1.0f : 1.0f));
            rt_hit h, hb;
            ok &= rt_bvh_closest(&tv, &r, &h) == rt_brute_closest(s, &r, &hb) && same_hit(&h, &hb);
        }
        CHECK(ok, "coplanar bvh%d: perpendicular ties", widths[w]);
        rt_bvh_free(b);
    }
    rt_scene_free(s);

    /* Many triangles sharing one centroid: the count split keeps leaves small. */
    s = rt_scene_new(300, NULL);
    for (int i = 0; i < 300; i++) {
        const rt_vec3 d = rand_dir();
        const float k = uf(0.1f, 1.0f);
        add(s, rt_mul(d, k), rt_mul(d, -k), rt_v3(0, 0, 0)); /* box centre 0: symmetric */
    }
    finish(s);
    for (int w = 0; w < 3; w++) {
        rt_bvh *b = build_w(s, widths[w], &e);
        CHECK(b && rt_bvh_check(b, s, &e) == 0 && b->depth <= 12, "shared centroid bvh%d: %s (depth %u)", widths[w],
              e.msg, b ? b->depth : 0);
        rt_bvh_free(b);
    }
    small_scene("shared centroid", s, 1000);
    rt_scene_free(s);

    /* Degenerate triangles only: a valid tree; nothing hits. */
    s = rt_scene_new(100, NULL);
    for (int i = 0; i < 100; i++) {
        const rt_vec3 a = rt_v3(uf(0, 1), uf(0, 1), uf(0, 1)), d = rand_dir();
        if (i & 1) add(s, a, a, a);
        else add(s, a, rt_add(a, d), rt_add(a, rt_mul(d, 2.0f)));
    }
    finish(s);
    small_scene("degenerate", s, 500);
    rt_scene_free(s);

    /* Huge coordinates: +-1e30 (no loader accepts them, the builder must
     * still cope) and the loaders' limit, 1e13 with extent 1e9. */
    for (int pass = 0; pass < 2; pass++) {
        const float big = pass ? 7e12f : 1e30f, ext = pass ? 5.2e8f : 1e30f;
        s = rt_scene_new(200, NULL);
        for (int i = 0; i < 200; i++) {
            const rt_vec3 ctr = pass ? rt_v3(big - uf(0, ext), big - uf(0, ext), big - uf(0, ext))
                                     : rt_v3(uf(-big, big), uf(-big, big), uf(-big, big));
            const float sz = 0.02f * ext;
            add(s, rt_add(ctr, rt_mul(rand_dir(), sz)), rt_add(ctr, rt_mul(rand_dir(), sz)), rt_add(ctr, rt_mul(rand_dir(), sz)));
        }
        if (!pass) add(s, rt_v3(-big, -big, -big), rt_v3(big, -big, -big), rt_v3(big, big, big));
        else add(s, rt_v3(big - ext, big - ext, big - ext), rt_v3(big, big - ext, big), rt_v3(big, big, big));
        finish(s);
        if (pass) CHECK(rt_scene_check_range(s, "range", &e) == 0, "the range-limit scene is out of range: %s", e.msg);
        small_scene(pass ? "range limit" : "1e30", s, 1000);
        rt_scene_free(s);
    }

    /* Out of memory at every allocation of the build. */
    s = make_soup(200);
    for (int w = 0; w < 3; w++) {
        long k;
        for (k = 1; k < 100; k++) {
            rt_err fe = {0};
            rt_fail_alloc_after = k;
            rt_bvh *b = build_w(s, widths[w], &fe);
            const int failed = b == NULL;
            rt_fail_alloc_after = 0;
            if (failed) CHECK(fe.msg[0] != 0, "bvh%d: allocation %ld failed without a message", widths[w], k);
            else CHECK(rt_bvh_check(b, s, &e) == 0, "bvh%d oom %ld: %s", widths[w], k, e.msg);
            rt_bvh_free(b);
            if (!failed) break;
        }
        CHECK(k > 3 && k < 100, "bvh%d: %ld allocations", widths[w], k);
    }
    rt_scene_free(s);
}

/* ---- the checker rejects corrupted trees ------------------------------------ */

static void test_corrupt(void)
{
    rt_err e = {0};
    rt_scene *s = make_soup(400);
    for (int w = 0; w < 3; w++) {
        rt_bvh *b = build_w(s, widths[w], &e);
        CHECK(b && rt_bvh_check(b, s, &e) == 0, "corrupt base bvh%d: %s", widths[w], e.msg);
        if (!b) continue;
        /* a shrunk child box: the first non-flat one */
        int done = 0;
        for (uint32_t i = 1; i < b->nnodes && !done && widths[w] == 2; i++) {
            rt_bvh2_node *n = &b->n2[i];
            if (n->hi[0] > n->lo[0]) {
                const float keep_ = n->hi[0];
                n->hi[0] = nextafterf(keep_, -INFINITY);
                CHECK(rt_bvh_check(b, s, &e) < 0, "bvh2: a shrunk box passes");
                n->hi[0] = keep_;
                done = 1;
            }
        }
        for (uint32_t i = 0; i < b->nnodes && !done && widths[w] == 4; i++) {
            rt_bvh4_node *n = &b->n4[i];
            if (n->child[1] != RT_BVH4_EMPTY && n->lo[1][1] < n->hi[1][1]) {
                const float keep_ = n->lo[1][1];
                n->lo[1][1] = nextafterf(keep_, INFINITY);
                CHECK(rt_bvh_check(b, s, &e) < 0, "bvh4: a shrunk box passes");
                n->lo[1][1] = keep_;
                done = 1;
            }
        }
        for (uint32_t i = 0; i < b->nnodes && !done && widths[w] == 8; i++) {
            rt_bvh8_node *n = &b->n8[i];
            if (n->meta[0] && n->qhi[2][0] > n->qlo[2][0] + 1) {
                const uint8_t keep_ = n->qhi[2][0];
                n->qhi[2][0] = n->qlo[2][0];
                CHECK(rt_bvh_check(b, s, &e) < 0, "bvh8: a shrunk quantized box passes");
                n->qhi[2][0] = keep_;
                b->h8[i].hi[2][0] = nextafterf(b->h8[i].hi[2][0], INFINITY);
                CHECK(rt_bvh_check(b, s, &e) < 0, "bvh8: a host copy that differs passes");
                b->h8[i].hi[2][0] = nextafterf(b->h8[i].hi[2][0], -INFINITY);
                done = 1;
            }
        }
        CHECK(done, "bvh%d: no box to shrink", widths[w]);
        CHECK(rt_bvh_check(b, s, &e) == 0, "bvh%d restored: %s", widths[w], e.msg);
        /* a dropped triangle: one leaf one shorter */
        done = 0;
        for (uint32_t i = 0; i < b->nnodes && !done; i++) {
            if (widths[w] == 2 && b->n2[i].ntri > 1) {
                b->n2[i].ntri--;
                CHECK(rt_bvh_check(b, s, &e) < 0 && strstr(e.msg, "no leaf"), "bvh2: a dropped triangle passes: %s", e.msg);
                b->n2[i].ntri++;
                done = 1;
            } else if (widths[w] == 4) {
                for (int k = 0; k < 4 && !done; k++) {
                    uint64_t *c = &b->n4[i].child[k];
                    if (*c != RT_BVH4_EMPTY && rt_bvh4_is_leaf(*c) && rt_bvh4_count(*c) > 1) {
                        *c -= 1ull << 32;
                        CHECK(rt_bvh_check(b, s, &e) < 0 && strstr(e.msg, "no leaf"), "bvh4: a dropped triangle passes: %s", e.msg);
                        *c += 1ull << 32;
                        done = 1;
                    }
                }
            } else if (widths[w] == 8) {
                for (int k = 0; k < 8 && !done; k++) {
                    uint8_t *m = &b->n8[i].meta[k];
                    if (*m && !(b->n8[i].imask >> k & 1u) && (*m >> 5) > 1) {
                        *m = (uint8_t)(*m - 0x20);
                        CHECK(rt_bvh_check(b, s, &e) < 0, "bvh8: a dropped triangle passes");
                        *m = (uint8_t)(*m + 0x20);
                        done = 1;
                    }
                }
            }
        }
        CHECK(done, "bvh%d: no leaf to shorten", widths[w]);
        CHECK(rt_bvh_check(b, s, &e) == 0, "bvh%d restored: %s", widths[w], e.msg);
        /* a duplicated triangle: a record naming another's triangle */
        if (b->ntri > 2) {
            const uint32_t keep_ = b->orig[1];
            b->orig[1] = b->orig[2];
            CHECK(rt_bvh_check(b, s, &e) < 0, "bvh%d: a duplicated triangle passes", widths[w]);
            b->orig[1] = keep_;
            rt_tri kt = b->tri[1];
            b->tri[1] = b->tri[2];
            CHECK(rt_bvh_check(b, s, &e) < 0, "bvh%d: a duplicated record passes", widths[w]);
            b->tri[1] = kt;
        }
        /* a leaf overlapping its neighbour's records (and losing its own) */
        done = 0;
        for (uint32_t i = 0; i < b->nnodes && !done && widths[w] == 2; i++)
            if (b->n2[i].ntri && b->n2[i].offset > 0) {
                b->n2[i].offset--;
                CHECK(rt_bvh_check(b, s, &e) < 0, "bvh2: overlapping leaves pass");
                b->n2[i].offset++;
                done = 1;
            }
        CHECK(rt_bvh_check(b, s, &e) == 0, "bvh%d restored: %s", widths[w], e.msg);
        /* a degenerate flag that disagrees with its triangle */
        b->degen[0] ^= 1u;
        CHECK(rt_bvh_check(b, s, &e) < 0 && strstr(e.msg, "degenerate flag"), "bvh%d: a wrong degenerate flag passes: %s",
              widths[w], e.msg);
        b->degen[0] ^= 1u;
        CHECK(rt_bvh_check(b, s, &e) == 0, "bvh%d restored: %s", widths[w], e.msg);
        /* a wrong statistic */
        b->sah *= 1.0 + 1e-12;
        CHECK(rt_bvh_check(b, s, &e) < 0 && strstr(e.msg, "SAH"), "bvh%d: a wrong SAH cost passes", widths[w]);
        rt_bvh_free(b);
    }
    rt_scene_free(s);
}

int main(int argc, char **argv)
{
    rnd_seed(0x243f6a8885a308d3ULL);
    const long scale = argc > 1 ? atol(argv[1]) : 1; /* ray-count multiplier */
    const int full = check_long();
    const long rays = (full ? 100000 : 20000) * scale;
    test_small_cases();
    test_corrupt();

    rt_scene *s = make_soup(300);
    run_scene("soup-300", s, rays, rays);
    rt_scene_free(s);
    s = make_soup(2000);
    run_scene("soup-2000", s, rays, full ? rays : rays / 2);
    shared_vs_copy("soup-2000", s, 3000);
    rt_scene_free(s);
    s = make_sphere(8);
    run_scene("sphere-r8", s, rays, rays);
    rt_scene_free(s);

    /* Every built-in scene, reduced where it is large. */
    static const struct {
        const char *spec;
        long brute_quick; /* rays compared with brute force in the quick tier */
    } bi[] = {
        {"cornell", 20000},
        {"knot", 20000},
        {"sphereflake:level=2,tess=2", 8000},
        {"grove:trees=1,depth=4,tess=2,leaves=16", 20000},
        {"room", 1000},
        {"bunny", 800},
    };
    for (size_t i = 0; i < sizeof bi / sizeof bi[0]; i++) {
        rt_err e = {0};
        s = rt_scene_load(bi[i].spec, &e);
        CHECK(s != NULL, "scene %s: %s", bi[i].spec, e.msg);
        if (!s) continue;
        run_scene(bi[i].spec, s, rays, full ? rays : bi[i].brute_quick * scale);
        rt_scene_free(s);
    }
    if (full) { /* the full sphereflake (797,150 triangles), brute force on 200 rays */
        rt_err e = {0};
        s = rt_scene_load("sphereflake", &e);
        CHECK(s != NULL, "sphereflake: %s", e.msg);
        if (s) run_scene("sphereflake", s, rays, 200);
        rt_scene_free(s);
    }
    if (failures) fprintf(stderr, "%d failures\n", failures);
    return failures ? 1 : 0;
}
