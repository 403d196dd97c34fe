/*
 * test_inst.c -- the two-level instancing structure (accel/inst.c) against
 * brute force on the flattened scene, and its checker on corrupted copies.
 *
 * The scene: a 12-triangle box object instanced four times (identity,
 * rotated, scaled non-uniformly, rotated + scaled + translated), a
 * sphere object instanced twice, a flat 4-triangle card (a box of zero
 * depth) instanced twice, and a loose ground quad; all
 * in a .pbrt file written here. Random rays (origins in and around the
 * scene, random directions, random tmin/tmax) must give bit-identical
 * closest hits and the same occlusion as rt_brute_closest/occluded on the
 * flattened triangles; the walk must have transformed rays and read the
 * instance records.
 */
#include "accel.h"
#include "check.h"
#include "config.h"
#include "inst.h"
#include "run.h"
#include "scene.h"
#include "scene_load.h"
#include "trace.h"
#include "tracer.h"

#include <zlib.h>

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static const char *scene_text =
    "LookAt 0 3 -12  0 0 0  0 1 0\n"
    "Camera \"perspective\" \"float fov\" 45\n"
    "WorldBegin\n"
    "Shape \"trianglemesh\" \"point3 P\" [-8 -2 -8  8 -2 -8  8 -2 8  -8 -2 8] \"integer indices\" [0 1 2 0 2 3]\n"
    "ObjectBegin \"box\"\n"
    "Shape \"trianglemesh\" \"point3 P\" [-1 -1 -1 1 -1 -1 1 1 -1 -1 1 -1 -1 -1 1 1 -1 1 1 1 1 -1 1 1]\n"
    "  \"integer indices\" [0 1 2 0 2 3  4 6 5 4 7 6  0 4 5 0 5 1  3 2 6 3 6 7  0 3 7 0 7 4  1 5 6 1 6 2]\n"
    "ObjectEnd\n"
    "AttributeBegin\n"
    "  Translate 2 0 0\n"
    "  ObjectBegin \"ball\"\n"
    "  Shape \"sphere\" \"float radius\" 0.8\n"
    "  ObjectEnd\n"
    "AttributeEnd\n"
    "ObjectInstance \"box\"\n"
    "AttributeBegin Translate -3 0 1 Rotate 30 0 1 0 Rotate 20 1 0 0 ObjectInstance \"box\" AttributeEnd\n"
    "AttributeBegin Translate 3 1 2 Scale 0.5 2 1 ObjectInstance \"box\" AttributeEnd\n"
    "AttributeBegin Translate 0 2.5 3 Rotate -45 0 0 1 Scale 0.7 0.7 0.7 Translate 0.5 0 0 ObjectInstance \"box\" "
    "AttributeEnd\n"
    "ObjectBegin \"card\"\n"
    "Shape \"trianglemesh\" \"point3 P\" [-1 -1 0 0 -1 0 1 -1 0 -1 1 0 0 1 0 1 1 0] \"integer indices\" [0 1 4 0 4 3 1 2 5 1 5 4]\n"
    "ObjectEnd\n"
    "AttributeBegin Translate 0 0 -2 Rotate 33 0 1 0 Rotate 10 1 0 0 ObjectInstance \"card\" AttributeEnd\n"
    "AttributeBegin Translate 4 0 -2 ObjectInstance \"card\" AttributeEnd\n"
    "AttributeBegin Translate -4 0 -3 ObjectInstance \"ball\" AttributeEnd\n"
    "AttributeBegin Translate 1 -1 -4 Rotate 90 1 0 0 Scale 1.5 1 1 ObjectInstance \"ball\" AttributeEnd\n";

static uint64_t rng = 0x9e3779b97f4a7c15ull;
static double urand(void) {
    rng ^= rng << 13, rng ^= rng >> 7, rng ^= rng << 17;
    return (double)(rng >> 11) / 9007199254740992.0;
}

static int same_hit(const rt_hit *a, const rt_hit *b) {
    return a->tri == b->tri && memcmp(&a->t, &b->t, sizeof a->t) == 0 && memcmp(&a->u, &b->u, sizeof a->u) == 0 &&
           memcmp(&a->v, &b->v, sizeof a->v) == 0;
}

static void corrupt_and_check(const rt_scene *s, rt_inst *I) {
    rt_err e;
    CHECK(rt_inst_check(I, s, &e) == 0, "intact structure rejected: %s", e.msg);
    /* (I4): a bottom-level root's box shrunk to a point */
    rt_bvh2_node save = I->bnode[0];
    for (int a = 0; a < 3; a++)
        I->bnode[0].hi[a] = I->bnode[0].lo[a];
    CHECK(rt_inst_check(I, s, &e) < 0 && strstr(e.msg, "(I4)"), "shrunk box: '%s'", e.msg);
    I->bnode[0] = save;
    /* (I2): an instance's matrix changed (translation) */
    uint32_t k = I->ninst - 1;
    double m = I->inst[k].o2w[0][3];
    I->inst[k].o2w[0][3] += 1.0;
    CHECK(rt_inst_check(I, s, &e) < 0 && strstr(e.msg, "(I2)"), "moved instance: '%s'", e.msg);
    I->inst[k].o2w[0][3] = m;
    CHECK(rt_inst_check(I, s, &e) == 0, "restored (I2): %s", e.msg);
    /* (I6): the inverse no longer the inverse */
    double w = I->inst[k].w2o[1][3];
    I->inst[k].w2o[1][3] += 0.5;
    CHECK(rt_inst_check(I, s, &e) < 0 && strstr(e.msg, "(I6)"), "bad inverse: '%s'", e.msg);
    I->inst[k].w2o[1][3] = w;
    /* (I1): two instances naming the same triangles */
    uint32_t f = I->inst[2].first;
    I->inst[2].first = I->inst[1].first;
    CHECK(rt_inst_check(I, s, &e) < 0 && strstr(e.msg, "(I1)"), "overlapping instances: '%s'", e.msg);
    I->inst[2].first = f;
    /* (I3): a leaf's range beyond its tree */
    for (uint32_t n = 0; n < I->nbnode; n++)
        if (I->bnode[n].ntri) {
            uint32_t o = I->bnode[n].offset;
            I->bnode[n].offset = I->nbtri + 5;
            CHECK(rt_inst_check(I, s, &e) < 0 && strstr(e.msg, "(I3)"), "leaf outside: '%s'", e.msg);
            I->bnode[n].offset = o;
            CHECK(rt_inst_check(I, s, &e) == 0, "restored (I3): %s", e.msg);
            break;
        }
    /* (I5): an instance missing from the top level (its entry repeated) */
    uint32_t t0 = I->torder[0];
    I->torder[0] = I->torder[1];
    e.msg[0] = 0;
    CHECK(rt_inst_check(I, s, &e) < 0 && strstr(e.msg, "(I5)"), "top-level entry repeated: '%s'", e.msg);
    I->torder[0] = t0;
    CHECK(rt_inst_check(I, s, &e) == 0, "restored structure rejected: %s", e.msg);
}

/* Counts the accesses per region of the job's layout; any access outside
 * every region is counted in bad. */
typedef struct tally {
    const rt_layout *L;
    uint64_t n, bad, per[RT_MM_MAX_REGIONS], cls[RT_NCLASS];
    uint64_t off;    /* accesses whose class is not their region's */
    uint64_t xforms; /* the run's transformed rays (its statistics) */
    uint64_t hash;   /* FNV-1a over (address, size, class) in order: the stream */
} tally;

static int tally_put(rt_sink *s, const rt_access *a, size_t n) {
    tally *t = s->ctx;
    for (size_t i = 0; i < n; i++) {
        int r = -1;
        for (int k = 0; k < t->L->n; k++)
            if (a[i].addr >= t->L->r[k].base &&
                a[i].addr + a[i].size <= t->L->r[k].base + t->L->r[k].recsize * t->L->r[k].count)
                r = k;
        t->n++;
        if (a[i].cls < RT_NCLASS)
            t->cls[a[i].cls]++;
        const uint64_t v[3] = {a[i].addr, a[i].size, a[i].cls};
        for (int k = 0; k < 3; k++)
            t->hash = (t->hash ^ v[k]) * 0x100000001b3ull;
        if (r < 0)
            t->bad++;
        else
            t->per[r]++;
        if (r >= 0 && a[i].cls != t->L->r[r].cls)
            t->off++;
    }
    return 0;
}

static rt_image *render_with(const char *tracer, rt_scene *s, int mode, int instances, tally *t, rt_job *j) {
    rt_err e = {0};
    rt_render_opts o;
    rt_render_default_opts(&o);
    o.W = 40, o.H = 32;
    o.mode = mode;
    o.lights = 7;
    if (instances)
        o.instances = 1, o.accel = RT_ACCEL_INST;
    CHECK(rt_job_setup_borrowed(j, s, NULL, tracer, &o, &e) == 0, "setup %s: %s", tracer, e.msg);
    rt_image *im = rt_image_new(o.W, o.H, &e);
    t->L = &j->L;
    rt_sink sk = {tally_put, t};
    rt_run_stats st;
    CHECK(rt_job_run(j, &sk, im, &st, &e) == 0, "run: %s", e.msg);
    CHECK(!instances || strstr(st.extra, "xforms="), "the bvh run's statistics lack xforms: '%s'", st.extra);
    CHECK(instances || !strstr(st.extra, "xforms="), "the flattened run counts xforms: '%s'", st.extra);
    const char *x = strstr(st.extra, "xforms=");
    t->xforms = x ? strtoull(x + 7, NULL, 10) : 0;
    return im;
}

static rt_image *render(rt_scene *s, int mode, int instances, tally *t, rt_job *j) {
    return render_with("recursive", s, mode, instances, t, j);
}

/* Packets straight through rt_inst_pk_trace: random packets of 64 rays
 * (coherent bundles around a direction, and fully random ones), closest
 * hits bit for bit and occlusion equal to brute force on the flattened
 * triangles; the per-slot counters add up to what tv counted per ray. */
static void test_packets(const rt_scene *s, const rt_accel *a, const rt_scene *ref, const char *what) {
    rt_err e = {0};
    enum { NP = 64 };
    rt_inst_pk *k = rt_inst_pk_new(a->as, NP, &e);
    CHECK(k != NULL, "%s: packet walker: %s", what, e.msg);
    if (!k)
        return;
    rt_trav tv;
    rt_accel_trav(a, &tv, s, NULL, NULL);
    int bad = 0, hits = 0, occl = 0;
    for (int p = 0; p < 300; p++) {
        rt_ray ray[NP];
        rt_hit hit[NP];
        uint8_t done[NP];
        uint16_t idx[NP];
        float pn[NP] = {0}, pt[NP] = {0};
        rt_vec3 o = rt_v3((float)(urand() * 20 - 10), (float)(urand() * 8 - 2), (float)(urand() * 10 - 14));
        rt_vec3 c = rt_v3((float)(urand() * 10 - 5), (float)(urand() * 4 - 2), (float)(urand() * 10));
        int n = 1 + (int)(urand() * NP);
        for (int j = 0; j < n; j++) {
            rt_vec3 d = rt_v3(c.x - o.x + (float)(urand() * 4 - 2), c.y - o.y + (float)(urand() * 4 - 2),
                              c.z - o.z + (float)(urand() * 4 - 2));
            if (p % 3 == 2)
                d = rt_v3((float)(urand() * 2 - 1), (float)(urand() * 2 - 1), (float)(urand() * 2 - 1));
            rt_ray_init(&ray[j], p % 5 == 4 ? rt_v3(o.x + (float)urand(), o.y, o.z) : o, d);
            if (j % 4 == 1)
                ray[j].tmin = (float)(urand() * 0.5), ray[j].tmax = (float)(1 + urand() * 20);
            rt_hit_none(&hit[j]);
            done[j] = 0;
            idx[j] = (uint16_t)(n - 1 - j); /* slots in any order */
        }
        uint64_t n0 = tv.nodes, t0 = tv.tests;
        rt_inst_pk_trace(k, &tv, ray, hit, done, 0, pn, pt, idx, n);
        float sn = 0, st = 0;
        for (int j = 0; j < n; j++) {
            rt_hit h;
            int b = rt_brute_closest(ref, &ray[j], &h);
            if ((b != (hit[j].tri != RT_NO_HIT) || (b && !same_hit(&h, &hit[j]))) && bad++ < 5)
                CHECK(0, "%s packet %d ray %d: brute %d tri %u t %.9g, packet tri %u t %.9g", what, p, j, b, h.tri,
                      (double)h.t, hit[j].tri, (double)hit[j].t);
            hits += b;
            sn += pn[j], st += pt[j];
        }
        /* a packet test is one test per ray present; a visit is counted once per packet */
        CHECK((uint64_t)st == tv.tests - t0 && tv.nodes - n0 <= (uint64_t)sn, "%s packet %d: tests %llu vs %g, nodes %llu vs %g",
              what, p, (unsigned long long)(tv.tests - t0), (double)st, (unsigned long long)(tv.nodes - n0), (double)sn);
        rt_inst_pk_trace(k, &tv, ray, hit, done, 1, NULL, NULL, idx, n);
        for (int j = 0; j < n; j++) {
            int b = rt_brute_occluded(ref, &ray[j]);
            if (b != done[j] && bad++ < 5)
                CHECK(0, "%s packet %d ray %d: occluded brute %d packet %d", what, p, j, b, done[j]);
            occl += b;
        }
    }
    CHECK(bad == 0, "%s: %d packet rays differ", what, bad);
    CHECK(hits > 2000 && occl >= hits, "%s: %d hits, %d occluded: the packets should meet the scene", what, hits, occl);
    CHECK(tv.xforms > 0, "%s: no packet ray transformed", what);
    rt_inst_pk_free(k);
}

/* The packet tracer through the two-level structure: float images equal
 * the flattened scene's in every mode, accesses by class as the recursive
 * tracer's (tlas, inst, blas node/tri exactly their regions'). */
static void test_packet_images(rt_scene *s) {
    const int modes[] = {RT_MODE_RAYCAST, RT_MODE_SHADOW, RT_MODE_WHITTED, RT_MODE_PATH};
    for (int m = 0; m < 4; m++) {
        tally ta = {0}, tb = {0};
        rt_job ja, jb;
        memset(&ja, 0, sizeof ja);
        memset(&jb, 0, sizeof jb);
        rt_image *a = render_with("packet", s, modes[m], 0, &ta, &ja), *b = render_with("packet", s, modes[m], 1, &tb, &jb);
        if (a && b) {
            size_t diff = 0;
            for (size_t i = 0; i < (size_t)a->W * a->H * 3; i++)
                diff += memcmp(&a->rgb[i], &b->rgb[i], sizeof(float)) != 0;
            CHECK(diff == 0, "packet mode %d: %zu channel values differ between flatten and bvh", modes[m], diff);
        }
        int ri = rt_mm_find(&jb.L, "inst"), rtl = rt_mm_find(&jb.L, "tlas.node"), rbn = rt_mm_find(&jb.L, "blas.node"),
            rbt = rt_mm_find(&jb.L, "blas.tri");
        CHECK(ta.bad == 0 && tb.bad == 0 && tb.off == 0 && ri >= 0 && rtl >= 0 && rbn >= 0 && rbt >= 0,
              "packet mode %d: off-layout %llu, %llu, off-class %llu", modes[m], (unsigned long long)ta.bad,
              (unsigned long long)tb.bad, (unsigned long long)tb.off);
        if (ri >= 0 && rtl >= 0 && rbn >= 0 && rbt >= 0)
            CHECK(tb.cls[RT_CLS_TLAS] == tb.per[rtl] && tb.cls[RT_CLS_INST] == tb.per[ri] && tb.per[ri] > 0 &&
                      tb.cls[RT_CLS_NODE] == tb.per[rbn] && tb.cls[RT_CLS_TRI] == tb.per[rbt] && tb.xforms > 0,
                  "packet mode %d: classes tlas %llu inst %llu, %llu xforms", modes[m],
                  (unsigned long long)tb.cls[RT_CLS_TLAS], (unsigned long long)tb.cls[RT_CLS_INST],
                  (unsigned long long)tb.xforms);
        rt_image_free(a);
        rt_image_free(b);
        rt_job_free(&ja);
        rt_job_free(&jb);
    }
}

/* The packet walk over the kept scene (no flattened copy): packets'
 * hits equal brute force on the flattened scene s, and the packet
 * tracer's images over the kept scene equal the flattened scene's. */
static void test_packet_kept(const char *path, rt_scene *s) {
    rt_err e = {0};
    rt_scene *k = rt_scene_load_flags(path, RT_LOAD_KEEP_INSTANCES, &e);
    CHECK(k != NULL && k->kept, "kept load: %s", e.msg);
    if (!k)
        return;
    rt_accel a;
    CHECK(rt_accel_build(&a, RT_ACCEL_INST, k, NULL, &e) == 0, "kept build: %s", e.msg);
    if (a.as) {
        test_packets(k, &a, s, "kept");
        rt_accel_free(&a);
    }
    const int modes[] = {RT_MODE_RAYCAST, RT_MODE_SHADOW, RT_MODE_WHITTED, RT_MODE_PATH};
    for (int m = 0; m < 4; m++) {
        tally ta = {0}, tb = {0};
        rt_job ja, jb;
        memset(&ja, 0, sizeof ja);
        memset(&jb, 0, sizeof jb);
        rt_image *ia = render_with("packet", s, modes[m], 0, &ta, &ja), *ib = render_with("packet", k, modes[m], 1, &tb, &jb);
        if (ia && ib)
            CHECK(!memcmp(ia->rgb, ib->rgb, (size_t)ib->W * ib->H * 3 * sizeof(float)),
                  "packet over the kept scene, mode %d: image differs from the flattened scene's", modes[m]);
        CHECK(tb.bad == 0 && tb.off == 0 && tb.n > 0, "packet kept, mode %d: %llu accesses off the layout, %llu off class",
              modes[m], (unsigned long long)tb.bad, (unsigned long long)tb.off);
        rt_image_free(ia);
        rt_image_free(ib);
        rt_job_free(&ja);
        rt_job_free(&jb);
    }
    rt_scene_free(k);
}

/* The recursive tracer's images through the two-level structure equal the
 * flattened scene's float for float, in every mode; its accesses all lie
 * in its layout, instance records and top-level nodes are read, and the
 * shared triangle region is smaller than the flattened one. */
static void test_images(rt_scene *s) {
    const int modes[] = {RT_MODE_RAYCAST, RT_MODE_SHADOW, RT_MODE_WHITTED};
    for (int m = 0; m < 3; m++) {
        tally ta = {0}, tb = {0};
        rt_job ja, jb;
        memset(&ja, 0, sizeof ja);
        memset(&jb, 0, sizeof jb);
        rt_image *a = render(s, modes[m], 0, &ta, &ja), *b = render(s, modes[m], 1, &tb, &jb);
        if (a && b) {
            size_t diff = 0;
            for (size_t i = 0; i < (size_t)a->W * a->H * 3; i++)
                diff += memcmp(&a->rgb[i], &b->rgb[i], sizeof(float)) != 0;
            CHECK(diff == 0, "mode %d: %zu channel values differ between flatten and bvh", modes[m], diff);
        }
        CHECK(ta.bad == 0 && tb.bad == 0 && tb.n > 0, "mode %d: accesses off the layout: %llu, %llu", modes[m],
              (unsigned long long)ta.bad, (unsigned long long)tb.bad);
        int ri = rt_mm_find(&jb.L, "inst"), rtl = rt_mm_find(&jb.L, "tlas.node"), rbt = rt_mm_find(&jb.L, "blas.tri"),
            rft = rt_mm_find(&ja.L, "tri.verts");
        CHECK(ri >= 0 && rtl >= 0 && rbt >= 0 && rft >= 0 && rt_mm_find(&jb.L, "tri.verts") < 0, "regions %d %d %d %d",
              ri, rtl, rbt, rft);
        if (ri >= 0 && rtl >= 0 && rbt >= 0 && rft >= 0) {
            CHECK(tb.per[ri] > 0 && tb.per[rtl] > 0 && tb.per[rbt] > 0,
                  "mode %d: inst %llu, tlas %llu, blas.tri %llu reads", modes[m], (unsigned long long)tb.per[ri],
                  (unsigned long long)tb.per[rtl], (unsigned long long)tb.per[rbt]);
            CHECK(jb.L.r[rbt].count < ja.L.r[rft].count, "shared triangles %llu, flattened %llu",
                  (unsigned long long)jb.L.r[rbt].count, (unsigned long long)ja.L.r[rft].count);
        }
        /* traffic per level: the top level is class tlas, the instance
         * records class inst, the bottom level node and tri, each exactly
         * its region's accesses; the flattened run has neither new class */
        int rbn = rt_mm_find(&jb.L, "blas.node");
        CHECK(ta.off == 0 && tb.off == 0, "mode %d: %llu, %llu accesses with another class than their region's",
              modes[m], (unsigned long long)ta.off, (unsigned long long)tb.off);
        if (ri >= 0 && rtl >= 0 && rbt >= 0 && rbn >= 0) {
            CHECK(jb.L.r[rtl].cls == RT_CLS_TLAS && jb.L.r[ri].cls == RT_CLS_INST && jb.L.r[rbn].cls == RT_CLS_NODE &&
                      jb.L.r[rbt].cls == RT_CLS_TRI,
                  "region classes %u %u %u %u", jb.L.r[rtl].cls, jb.L.r[ri].cls, jb.L.r[rbn].cls, jb.L.r[rbt].cls);
            CHECK(tb.cls[RT_CLS_TLAS] == tb.per[rtl] && tb.cls[RT_CLS_INST] == tb.per[ri] &&
                      tb.cls[RT_CLS_NODE] == tb.per[rbn] && tb.cls[RT_CLS_TRI] == tb.per[rbt],
                  "mode %d: class counts tlas %llu inst %llu node %llu tri %llu", modes[m],
                  (unsigned long long)tb.cls[RT_CLS_TLAS], (unsigned long long)tb.cls[RT_CLS_INST],
                  (unsigned long long)tb.cls[RT_CLS_NODE], (unsigned long long)tb.cls[RT_CLS_TRI]);
            /* every transformed ray read its instance's record first */
            CHECK(tb.cls[RT_CLS_INST] >= tb.xforms && tb.xforms > 0, "mode %d: %llu record reads, %llu transformations",
                  modes[m], (unsigned long long)tb.cls[RT_CLS_INST], (unsigned long long)tb.xforms);
        }
        CHECK(ta.cls[RT_CLS_TLAS] == 0 && ta.cls[RT_CLS_INST] == 0 && ta.cls[RT_CLS_ALPHA] == 0,
              "mode %d: the flattened run has tlas %llu, inst %llu accesses", modes[m],
              (unsigned long long)ta.cls[RT_CLS_TLAS], (unsigned long long)ta.cls[RT_CLS_INST]);
        rt_image_free(a);
        rt_image_free(b);
        rt_job_free(&ja);
        rt_job_free(&jb);
    }
}

/* The treelet tracer on the two-level structure (treelets over the top
 * level; an instance leaf walked to completion inside the treelet that
 * holds it): in test mode (T1-T7, T6 comparing every ray with the
 * single-ray walk the random rays above compare with brute force), with a
 * budget of 64 bytes (two top-level nodes per treelet: several treelets
 * and suspended rays where the top level has more nodes), its images
 * equal the flattened scene's treelet run's and the recursive tracer's
 * bit for bit, and its accesses per class are the
 * recursive tracer's on the same structure (tlas, inst, node, tri: the
 * same nodes, records and triangles per ray), each exactly its region's;
 * on the scene loaded kept (no flattened copy) the same image and the very
 * same record stream. */
static rt_image *render_tl(const char *tracer, rt_scene *s, int mode, int instances, uint64_t gmax, tally *t, rt_job *j,
                           rt_run_stats *st) {
    rt_err e = {0};
    rt_render_opts o;
    rt_render_default_opts(&o);
    o.W = 24, o.H = 20;
    o.mode = mode;
    o.lights = 7;
    o.gmax = gmax;
    if (instances)
        o.instances = 1, o.accel = RT_ACCEL_INST;
    CHECK(rt_job_setup_borrowed(j, s, NULL, tracer, &o, &e) == 0, "setup %s: %s", tracer, e.msg);
    j->check = 1;
    rt_image *im = rt_image_new(o.W, o.H, &e);
    t->L = &j->L;
    rt_sink sk = {tally_put, t};
    CHECK(rt_job_run(j, &sk, im, st, &e) == 0, "run %s: %s", tracer, e.msg);
    return im;
}

static double kv(const char *s, const char *k) {
    size_t n = strlen(k);
    for (const char *p = s; (p = strstr(p, k)); p += n)
        if ((p == s || p[-1] == ' ') && p[n] == '=')
            return atof(p + n + 1);
    return -1;
}

static void test_treelet(rt_scene *s, rt_scene *kept, const char *what, int min_tl) {
    const int modes[] = {RT_MODE_SHADOW, RT_MODE_WHITTED, RT_MODE_PATH};
    const uint64_t gm[] = {64};
    for (int m = 0; m < 3; m++)
        for (int g = 0; g < 1; g++) {
            tally ta = {0}, tb = {0}, tr = {0};
            rt_job ja, jb, jr;
            rt_run_stats sa, sb, sr;
            memset(&ja, 0, sizeof ja);
            memset(&jb, 0, sizeof jb);
            memset(&jr, 0, sizeof jr);
            rt_image *a = render_tl("treelet", s, modes[m], 0, 0, &ta, &ja, &sa); /* bvh4 nodes: the default budget */
            rt_image *b = render_tl("treelet", s, modes[m], 1, gm[g], &tb, &jb, &sb);
            rt_image *r = render_tl("recursive", s, modes[m], 1, 0, &tr, &jr, &sr);
            if (kept) { /* the kept scene (no flattened copy): the same image and accesses */
                tally tk = {0};
                rt_job jk;
                rt_run_stats sk;
                memset(&jk, 0, sizeof jk);
                rt_image *k = render_tl("treelet", kept, modes[m], 1, gm[g], &tk, &jk, &sk);
                size_t dk = 0;
                for (size_t i = 0; k && b && i < (size_t)k->W * k->H * 3; i++)
                    dk += memcmp(&k->rgb[i], &b->rgb[i], sizeof(float)) != 0;
                CHECK(k && b && dk == 0 && tk.bad == 0 && tk.n == tb.n && tk.hash == tb.hash,
                      "%s kept treelet mode %d: %zu channel values differ, %llu accesses (flattened %llu), off-layout %llu",
                      what, modes[m], dk, (unsigned long long)tk.n, (unsigned long long)tb.n, (unsigned long long)tk.bad);
                rt_image_free(k);
                rt_job_free(&jk);
            }
            if (a && b && r) {
                size_t diff = 0, dr = 0;
                for (size_t i = 0; i < (size_t)a->W * a->H * 3; i++) {
                    diff += memcmp(&a->rgb[i], &b->rgb[i], sizeof(float)) != 0;
                    dr += memcmp(&r->rgb[i], &b->rgb[i], sizeof(float)) != 0;
                }
                CHECK(diff == 0 && dr == 0, "%s treelet mode %d gmax %llu: %zu channel values differ from the flattened "
                      "run, %zu from the recursive bvh run", what, modes[m], (unsigned long long)gm[g], diff, dr);
            }
            const double ntl = kv(sb.extra, "treelets"), nsusp = kv(sb.extra, "suspends");
            CHECK(ntl >= min_tl && (min_tl < 2 || nsusp > 0), "%s treelet mode %d: %g treelets (want %d), %g suspends "
                  "with gmax 64", what, modes[m], ntl, min_tl, nsusp);
            int ri = rt_mm_find(&jb.L, "inst"), rtl = rt_mm_find(&jb.L, "tlas.node"), rbn = rt_mm_find(&jb.L, "blas.node"),
                rbt = rt_mm_find(&jb.L, "blas.tri");
            CHECK(ta.bad == 0 && tb.bad == 0 && tb.off == 0 && ri >= 0 && rtl >= 0 && rbn >= 0 && rbt >= 0,
                  "%s treelet mode %d: off-layout %llu, %llu, off-class %llu", what, modes[m],
                  (unsigned long long)ta.bad, (unsigned long long)tb.bad, (unsigned long long)tb.off);
            if (ri >= 0 && rtl >= 0 && rbn >= 0 && rbt >= 0)
                CHECK(tb.cls[RT_CLS_TLAS] == tb.per[rtl] && tb.cls[RT_CLS_INST] == tb.per[ri] &&
                          tb.cls[RT_CLS_NODE] == tb.per[rbn] && tb.cls[RT_CLS_TRI] == tb.per[rbt] &&
                          tb.cls[RT_CLS_TLAS] > 0 && tb.cls[RT_CLS_INST] > 0,
                      "%s treelet mode %d: regions' accesses off their classes", what, modes[m]);
            static const int geo[] = {RT_CLS_TLAS, RT_CLS_INST, RT_CLS_NODE, RT_CLS_TRI, RT_CLS_SHADE};
            for (int c = 0; c < 5; c++)
                CHECK(tb.cls[geo[c]] == tr.cls[geo[c]], "%s treelet mode %d gmax %llu: class %d accesses %llu, the "
                      "recursive tracer's %llu", what, modes[m], (unsigned long long)gm[g], geo[c],
                      (unsigned long long)tb.cls[geo[c]], (unsigned long long)tr.cls[geo[c]]);
            CHECK(sb.nodes == sr.nodes && sb.tests == sr.tests && sb.pv_all == sr.pv_all,
                  "%s treelet mode %d: nodes %llu tests %llu, recursive %llu %llu", what, modes[m],
                  (unsigned long long)sb.nodes, (unsigned long long)sb.tests, (unsigned long long)sr.nodes,
                  (unsigned long long)sr.tests);
            CHECK(ta.cls[RT_CLS_TLAS] == 0 && ta.cls[RT_CLS_INST] == 0, "%s treelet flattened run reads tlas/inst", what);
            rt_image_free(a);
            rt_image_free(b);
            rt_image_free(r);
            rt_job_free(&ja);
            rt_job_free(&jb);
            rt_job_free(&jr);
        }
}

/* Nested instancing two deep: "leaf" (a box), "branch" (two leaves and a
 * triangle of its own), "tree" (three branches); instanced at the top as
 * two trees and one branch. The same geometry written without objects
 * (each instance an AttributeBegin block with its transformation around
 * the shapes) is the independent expectation: the two files' triangles
 * must be the same set within rounding, the two-level structure must hold
 * the three top-level instances (each a record: the objects are large),
 * pass its checker and give brute force's hits for every ray. */
#define NEST_BOX "Shape \"trianglemesh\" \"point3 P\" [-1 -1 -1 1 -1 -1 1 1 -1 -1 1 -1 -1 -1 1 1 -1 1 1 1 1 -1 1 1] " \
                 "\"integer indices\" [0 1 2 0 2 3  4 6 5 4 7 6  0 4 5 0 5 1  3 2 6 3 6 7  0 3 7 0 7 4  1 5 6 1 6 2]\n"
#define NEST_TRI "Shape \"trianglemesh\" \"point3 P\" [0 0 0  1 0 0  0 2 0] \"integer indices\" [0 1 2]\n"
#define NEST_L1 "AttributeBegin Translate 2 0 0 Rotate 30 0 0 1 Scale 0.5 0.5 0.5 "
#define NEST_L2 "AttributeBegin Translate -2 1 0 Rotate 45 0 1 0 "
#define NEST_B1 "AttributeBegin Translate 0 3 0 Rotate 20 1 0 0 "
#define NEST_B2 "AttributeBegin Translate 0 -3 1 Scale 1 0.5 1 "
#define NEST_B3 "AttributeBegin Translate 4 0 -2 Rotate 90 0 0 1 "
#define NEST_T1 "AttributeBegin Translate -6 0 8 Rotate 15 0 1 0 "
#define NEST_T2 "AttributeBegin Translate 6 0 10 Scale 1.2 1.2 1.2 "
#define NEST_TB "AttributeBegin Translate 0 -1 4 Rotate 60 0 0 1 "
#define END "AttributeEnd\n"
#define NEST_HEAD "LookAt 0 2 -10  0 0 6  0 1 0\nCamera \"perspective\" \"float fov\" 50\nWorldBegin\n" \
                  "LightSource \"point\" \"point3 from\" [0 10 -5] \"rgb I\" [40 40 40]\n"
#define BRANCH_FLAT NEST_L1 NEST_BOX END NEST_L2 NEST_BOX END NEST_TRI
#define TREE_FLAT NEST_B1 BRANCH_FLAT END NEST_B2 BRANCH_FLAT END NEST_B3 BRANCH_FLAT END
static const char *nest_text =
    NEST_HEAD "ObjectBegin \"leaf\"\n" NEST_BOX "ObjectEnd\n"
    "ObjectBegin \"branch\"\n" NEST_L1 "ObjectInstance \"leaf\"\n" END NEST_L2 "ObjectInstance \"leaf\"\n" END NEST_TRI
    "ObjectEnd\n"
    "ObjectBegin \"tree\"\n" NEST_B1 "ObjectInstance \"branch\"\n" END NEST_B2 "ObjectInstance \"branch\"\n" END NEST_B3
    "ObjectInstance \"branch\"\n" END "ObjectEnd\n"
    "Shape \"trianglemesh\" \"point3 P\" [-20 -4 -20  20 -4 -20  20 -4 30  -20 -4 30] \"integer indices\" [0 1 2 0 2 3]\n"
    NEST_T1 "ObjectInstance \"tree\"\n" END NEST_T2 "ObjectInstance \"tree\"\n" END NEST_TB "ObjectInstance \"branch\"\n" END;
static const char *nest_flat_text =
    NEST_HEAD "Shape \"trianglemesh\" \"point3 P\" [-20 -4 -20  20 -4 -20  20 -4 30  -20 -4 30] \"integer indices\" [0 1 2 0 2 3]\n"
    NEST_T1 TREE_FLAT END NEST_T2 TREE_FLAT END NEST_TB BRANCH_FLAT END;

static int cmp_f3(const void *a, const void *b) {
    const float *x = a, *y = b;
    for (int i = 0; i < 3; i++)
        if (x[i] != y[i])
            return x[i] < y[i] ? -1 : 1;
    return 0;
}

static int cmp_f9(const void *a, const void *b) {
    const float *x = a, *y = b;
    for (int i = 0; i < 9; i++)
        if (x[i] != y[i])
            return x[i] < y[i] ? -1 : 1;
    return 0;
}

/* The scene's triangles as sorted 9-float keys (vertices rounded to 1e-3,
 * each triangle's vertices in sorted order), for comparing two scenes as
 * sets. */
static float *tri_keys(const rt_scene *s) {
    float *k = malloc((size_t)s->ntri * 9 * sizeof *k);
    if (!k)
        return NULL;
    for (uint32_t i = 0; i < s->ntri; i++) {
        float v[3][3];
        for (int c = 0; c < 3; c++) {
            const float *p = &s->tri[i].p[c].x;
            for (int a = 0; a < 3; a++)
                v[c][a] = roundf(p[a] * 1000.0f) / 1000.0f + 0.0f;
        }
        qsort(v, 3, sizeof v[0], cmp_f3);
        memcpy(k + 9 * (size_t)i, v, sizeof v);
    }
    qsort(k, s->ntri, 9 * sizeof *k, cmp_f9);
    return k;
}

static void test_nested(void) {
    rt_err e = {0};
    char *pn = check_path("nested.pbrt"), *pf = check_path("nested_flat.pbrt");
    check_write_file(pn, nest_text, strlen(nest_text));
    check_write_file(pf, nest_flat_text, strlen(nest_flat_text));
    rt_scene *s = rt_scene_load(pn, &e);
    CHECK(s != NULL, "nested: %s", e.msg);
    rt_scene *f = rt_scene_load(pf, &e);
    CHECK(f != NULL, "nested, written flat: %s", e.msg);
    if (!s || !f) {
        rt_scene_free(s);
        rt_scene_free(f);
        return;
    }
    /* branch = 2 x 12 + 1 = 25 triangles, tree = 75; 2 trees + 1 branch + ground */
    CHECK(s->ntri == 2 + 2 * 75 + 25 && f->ntri == s->ntri, "triangles: nested %u, flat %u, want %u", s->ntri, f->ntri,
          2 + 2 * 75 + 25);
    CHECK(s->nirec == 3 && s->ninst == 3, "top-level instance records %u, instances %u (want 3)", s->nirec, s->ninst);
    float *ka = tri_keys(s), *kb = tri_keys(f);
    size_t diff = 0;
    for (uint32_t i = 0; ka && kb && i < s->ntri && s->ntri == f->ntri; i++)
        for (int j = 0; j < 9; j++)
            diff += fabsf(ka[9 * i + j] - kb[9 * i + j]) > 2e-3f;
    CHECK(ka && kb && diff == 0, "nested and flat triangles differ in %zu coordinates", diff);
    free(ka);
    free(kb);
    rt_accel a;
    CHECK(rt_accel_build(&a, RT_ACCEL_INST, s, NULL, &e) == 0, "nested build: %s", e.msg);
    rt_inst *I = a.as;
    CHECK(rt_accel_check(&a, s, &e) == 0, "nested check: %s", e.msg);
    CHECK(I->ninst == 4 && I->nloose == 2, "nested: %u instances (with the loose one), %u loose", I->ninst, I->nloose);
    /* shared: tree (75) and branch (25) once each, the ground's 2 */
    CHECK(I->nbtri == 75 + 25 + 2, "nested: %u shared records, want 102", I->nbtri);
    rt_trav tv;
    rt_accel_trav(&a, &tv, s, NULL, NULL);
    int bad = 0, hits = 0;
    for (int i = 0; i < 5000; i++) {
        rt_vec3 o = rt_v3((float)(urand() * 30 - 15), (float)(urand() * 10 - 3), (float)(urand() * 30 - 10));
        rt_vec3 d = rt_v3((float)(urand() * 2 - 1), (float)(urand() * 2 - 1), (float)(urand() * 2 - 1));
        if (i % 2 == 0)
            d = rt_v3((float)(urand() * 16 - 8) - o.x, (float)(urand() * 6 - 3) - o.y, (float)(urand() * 8 + 4) - o.z);
        rt_ray r;
        rt_ray_init(&r, o, d);
        rt_hit h1, h2;
        int b1 = rt_brute_closest(s, &r, &h1), b2 = a.ops->closest(&tv, &r, &h2);
        if ((b1 != b2 || (b1 && !same_hit(&h1, &h2))) && bad++ < 5)
            CHECK(0, "nested ray %d: brute %d tri %u, inst %d tri %u", i, b1, h1.tri, b2, h2.tri);
        if (rt_brute_occluded(s, &r) != a.ops->occluded(&tv, &r) && bad++ < 5)
            CHECK(0, "nested ray %d: occlusion differs", i);
        hits += b1;
    }
    CHECK(bad == 0 && hits > 1000, "nested: %d rays differ, %d hits", bad, hits);
    test_packets(s, &a, s, "nested");
    test_treelet(s, NULL, "nested", 1); /* three top-level instances: one node */
    rt_accel_free(&a);
    /* the same file loaded with its instances kept (no flattened copy) */
    rt_scene *k = rt_scene_load_flags(pn, RT_LOAD_KEEP_INSTANCES, &e);
    CHECK(k && k->kept && k->nflat == s->ntri && k->nirec == 3, "nested kept: %s", k ? "counts" : e.msg);
    if (k && rt_accel_build(&a, RT_ACCEL_INST, k, NULL, &e) == 0) {
        CHECK(rt_accel_check(&a, k, &e) == 0, "nested kept check: %s", e.msg);
        test_packets(k, &a, s, "nested kept");
        rt_accel_free(&a);
    }
    rt_scene_free(k);
    rt_scene_free(s);
    rt_scene_free(f);
}

/* Kept instances (scene.h): the file loaded without its flattened copy
 * numbers, places and shades every triangle as the flattened scene does
 * (bit for bit), has its bounds and camera, passes both checkers (and
 * fails them on corrupted records), and the two-level walk over it gives
 * the flattened scene's brute-force hits; the recursive tracer's images
 * equal the flattened scene's in every mode, and the shading reads stay in
 * the layout. */
static void test_kept(const char *path, rt_scene *s) {
    rt_err e = {0};
    rt_scene *k = rt_scene_load_flags(path, RT_LOAD_KEEP_INSTANCES, &e);
    CHECK(k != NULL, "kept load: %s", e.msg);
    if (!k)
        return;
    CHECK(k->kept && k->nflat == s->ntri && k->ntri == 2 && k->nirec == s->nirec && k->notri == s->notri &&
              rt_scene_nshade(k) == 2 + s->notri && rt_scene_nflat(s) == s->ntri && !s->kept,
          "kept: flat %u (flattened %u), loose %u, records %u, object triangles %u", k->nflat, s->ntri, k->ntri,
          k->nirec, k->notri);
    CHECK(rt_scene_check_kept(k, &e) == 0, "kept: %s", e.msg);
    CHECK(!memcmp(&k->bounds, &s->bounds, sizeof k->bounds) && !memcmp(&k->cam, &s->cam, sizeof k->cam),
          "kept: bounds or camera differ from the flattened scene's");
    uint32_t bad = 0;
    for (uint32_t i = 0; i < s->ntri && i < k->nflat; i++) {
        rt_tri tmp;
        const rt_tri *t = rt_scene_tri_of(k, i, &tmp);
        bad += memcmp(t, &s->tri[i], sizeof *t) != 0 || memcmp(rt_scene_shade_of(k, i), &s->shade[i], sizeof s->shade[i]);
    }
    CHECK(bad == 0, "kept: %u triangles differ from the flattened copy", bad);
    CHECK(rt_scene_check_lights(k, &e) == 0, "kept lights: %s", e.msg);
    /* corrupted records */
    rt_scene_inst q1 = k->irec[1];
    k->irec[1].loose++;
    CHECK(rt_scene_check_kept(k, &e) < 0 && strstr(e.msg, "loose triangles before it"), "loose count: %s", e.msg);
    k->irec[1] = q1;
    k->irec[1].first = k->irec[0].first;
    CHECK(rt_scene_check_kept(k, &e) < 0 && strstr(e.msg, "not after"), "overlapping records: %s", e.msg);
    k->irec[1] = q1;
    k->nflat++;
    CHECK(rt_scene_check_kept(k, &e) < 0, "wrong total accepted");
    k->nflat--;
    CHECK(rt_scene_check_kept(k, &e) == 0, "restored: %s", e.msg);

    rt_accel a;
    CHECK(rt_accel_build(&a, RT_ACCEL_INST, k, NULL, &e) == 0, "kept build: %s", e.msg);
    if (a.as) {
        rt_inst *I = a.as;
        CHECK(rt_accel_check(&a, k, &e) == 0, "kept check: %s", e.msg);
        I->covered[0] ^= 1; /* a loose triangle's index pointing at another */
        CHECK(rt_inst_check(I, k, &e) < 0 && strstr(e.msg, "(I1)"), "kept: wrong loose index accepted: %s", e.msg);
        I->covered[0] ^= 1;
        rt_trav tv;
        rt_accel_trav(&a, &tv, k, NULL, NULL);
        int nbad = 0, hits = 0;
        for (int i = 0; i < 20000; i++) {
            rt_vec3 o = rt_v3((float)(urand() * 20 - 10), (float)(urand() * 10 - 3), (float)(urand() * 20 - 10));
            rt_vec3 d = rt_v3((float)(urand() * 2 - 1), (float)(urand() * 2 - 1), (float)(urand() * 2 - 1));
            if (i % 2 == 0) /* aimed at an instance's centre */
                d = rt_v3(-3 - o.x, 0 - o.y, 1 - o.z);
            rt_ray r;
            rt_ray_init(&r, o, d);
            if (i % 3 == 1)
                r.tmin = (float)(urand() * 0.5), r.tmax = (float)(1 + urand() * 20);
            rt_hit h1, h2;
            int b1 = rt_brute_closest(s, &r, &h1), b2 = a.ops->closest(&tv, &r, &h2);
            hits += b1;
            if ((b1 != b2 || (b1 && !same_hit(&h1, &h2)) || rt_brute_occluded(s, &r) != a.ops->occluded(&tv, &r)) &&
                nbad++ < 5)
                CHECK(0, "kept ray %d: brute %d tri %u t %.9g, inst %d tri %u t %.9g", i, b1, h1.tri, (double)h1.t, b2,
                      h2.tri, (double)h2.t);
        }
        CHECK(nbad == 0 && hits > 5000, "kept: %d rays differ, %d hits", nbad, hits);
        rt_accel_free(&a);
    }
    const int modes[] = {RT_MODE_RAYCAST, RT_MODE_SHADOW, RT_MODE_WHITTED};
    for (int m = 0; m < 3; m++) {
        tally ta = {0}, tb = {0}, tc = {0};
        rt_job ja, jb, jc;
        memset(&ja, 0, sizeof ja);
        memset(&jb, 0, sizeof jb);
        memset(&jc, 0, sizeof jc);
        rt_image *ia = render(s, modes[m], 0, &ta, &ja), *ib = render(k, modes[m], 1, &tb, &jb);
        /* the two-level structure over the flattened scene: the same model,
         * so the same layout and the same access stream as over the kept one */
        rt_image *ic = render(s, modes[m], 1, &tc, &jc);
        int same_layout = jb.L.n == jc.L.n;
        for (int r = 0; same_layout && r < jb.L.n; r++)
            same_layout = !strcmp(jb.L.r[r].name, jc.L.r[r].name) && jb.L.r[r].count == jc.L.r[r].count &&
                          jb.L.r[r].base == jc.L.r[r].base;
        CHECK(same_layout && tb.n == tc.n && tb.hash == tc.hash && tb.hash != 0,
              "kept, mode %d: layout %d, %llu accesses (hash %016llx) over the kept scene, %llu (%016llx) over the "
              "flattened one",
              modes[m], same_layout, (unsigned long long)tb.n, (unsigned long long)tb.hash, (unsigned long long)tc.n,
              (unsigned long long)tc.hash);
        if (ic && ib)
            CHECK(!memcmp(ic->rgb, ib->rgb, (size_t)ib->W * ib->H * 3 * sizeof(float)), "kept, mode %d: image differs from "
                  "the flattened two-level run's", modes[m]);
        rt_image_free(ic);
        rt_job_free(&jc);
        if (ia && ib) {
            size_t diff = 0;
            for (size_t i = 0; i < (size_t)ia->W * ia->H * 3; i++)
                diff += memcmp(&ia->rgb[i], &ib->rgb[i], sizeof(float)) != 0;
            CHECK(diff == 0, "kept, mode %d: %zu channel values differ from the flattened scene's", modes[m], diff);
        }
        CHECK(tb.bad == 0 && tb.n > 0, "kept, mode %d: %llu accesses off the layout", modes[m],
              (unsigned long long)tb.bad);
        rt_image_free(ia);
        rt_image_free(ib);
        rt_job_free(&ja);
        rt_job_free(&jb);
    }
    rt_scene_free(k);
}

/* Reads a whole file; NULL if it cannot. */
static unsigned char *slurp(const char *path, size_t *n) {
    FILE *f = fopen(path, "rb");
    if (!f)
        return NULL;
    unsigned char *b = malloc(1 << 16);
    *n = b ? fread(b, 1, 1 << 16, f) : 0;
    fclose(f);
    return b;
}

/* Reads the trace at path to its end: records read, or -1 (message in e). */
static long read_trace(const char *path, rt_tr_totals *tot, rt_err *e) {
    rt_tr_reader *r = rt_tr_open(path, e);
    if (!r)
        return -1;
    rt_access buf[256];
    long n = 0, k;
    while ((k = rt_tr_read(r, buf, 256, e)) > 0)
        n += k;
    if (k == 0 && tot)
        *tot = *rt_tr_get_totals(r);
    rt_tr_close(r);
    return k < 0 ? -1 : n;
}

static void put32le(unsigned char *p, uint32_t v) {
    for (int i = 0; i < 4; i++)
        p[i] = (unsigned char)(v >> (8 * i));
}

/* The footer holds 10 classes, or up to the highest with a reference:
 * a trace with records of classes tlas and inst ends in a 12-class
 * footer (316 bytes), read back with its totals; the reader takes 10..13
 * classes (a 13-class copy of it, the extra class empty, reads) and
 * refuses 9 and 14 naming the footer; a 10-class trace is 268 bytes of
 * footer. */
static void test_footer(void) {
    rt_err e = {0};
    rt_tr_meta m;
    memset(&m, 0, sizeof m);
    snprintf(m.tracer, sizeof m.tracer, "recursive");
    rt_mm_init(&m.layout);
    rt_mm_add(&m.layout, "tlas.node", RT_CLS_TLAS, 32, 8, NULL);
    rt_mm_add(&m.layout, "inst", RT_CLS_INST, 64, 4, NULL);
    rt_mm_add(&m.layout, "blas.node", RT_CLS_NODE, 32, 8, NULL);
    const rt_access a[] = {
        {m.layout.r[0].base, 32, 0, RT_CLS_TLAS, 0}, {m.layout.r[1].base + 64, 64, 0, RT_CLS_INST, 0},
        {m.layout.r[2].base, 32, 0, RT_CLS_NODE, 0}, {m.layout.r[0].base + 32, 32, 0, RT_CLS_TLAS, 0},
    };
    for (int withnew = 0; withnew < 2; withnew++) {
        const char *p = check_path(withnew ? "cls12.rtt" : "cls10.rtt");
        rt_tr_writer *w = rt_tr_create(p, &m, &e);
        rt_sink *sk = w ? rt_tr_sink(w) : NULL;
        CHECK(sk && sk->put(sk, withnew ? a : a + 2, withnew ? 4 : 1) == 0 && rt_tr_finish(w, &e) == 0, "write: %s",
              e.msg);
        size_t n = 0;
        unsigned char *b = slurp(p, &n);
        const size_t flen = withnew ? 28 + 24 * 12 : 268;
        CHECK(b && n > flen && !memcmp(b + n - flen, "RTND", 4) && b[n - flen + 4] == (withnew ? 12 : 10),
              "%s: footer of %zu bytes not found (%zu bytes)", p, flen, n);
        rt_tr_totals t;
        long got = read_trace(p, &t, &e);
        CHECK(got == (withnew ? 4 : 1), "%s read: %ld (%s)", p, got, e.msg);
        if (got > 0 && withnew)
            CHECK(t.refs[RT_CLS_TLAS] == 2 && t.bytes[RT_CLS_TLAS] == 64 && t.refs[RT_CLS_INST] == 1 &&
                      t.bytes[RT_CLS_INST] == 64 && t.refs[RT_CLS_NODE] == 1 && t.refs[RT_CLS_ALPHA] == 0,
                  "totals tlas %llu inst %llu node %llu", (unsigned long long)t.refs[RT_CLS_TLAS],
                  (unsigned long long)t.refs[RT_CLS_INST], (unsigned long long)t.refs[RT_CLS_NODE]);
        if (!b || !withnew || n <= flen) {
            free(b);
            continue;
        }
        /* forged class counts, CRC made right */
        const int nc[3] = {13, 9, 14};
        for (int k = 0; k < 3; k++) {
            unsigned char *c = calloc(1, n + 48);
            size_t foot = n - flen, cn = foot + 28 + 24 * (size_t)(nc[k] < 12 ? 12 : nc[k]);
            memcpy(c, b, n - 4);
            put32le(c + foot + 4, (uint32_t)nc[k]);
            size_t crcat = cn - 4; /* 13, 14: extra empty class slots before the CRC */
            put32le(c + crcat, (uint32_t)crc32(0, c + foot, (uInt)(crcat - foot)));
            const char *q = check_path("forged.rtt");
            check_write_file(q, c, cn);
            long r = read_trace(q, NULL, &e);
            if (nc[k] == 13)
                CHECK(r == 4, "13-class footer: %ld (%s)", r, e.msg);
            else
                CHECK(r < 0 && strstr(e.msg, "footer: ") && strstr(e.msg, "classes, expected 10..13"),
                      "%d-class footer: %ld '%s'", nc[k], r, e.msg);
            free(c);
        }
        free(b);
    }
}

/* Kept instances around instances that stay flattened: a singular one
 * (Scale 1 0 1) between two records and a loose triangle after it. The
 * singular copy is loose, in its flattened place; every index still
 * resolves to the flattened scene's triangle and shading record, and the
 * walk over the kept scene gives the flattened scene's brute-force hits. */
static void test_kept_singular(void) {
    static const char *text =
        "LookAt 0 3 -12  0 0 0  0 1 0\n"
        "Camera \"perspective\" \"float fov\" 45\n"
        "WorldBegin\n"
        "Shape \"trianglemesh\" \"point3 P\" [-8 -2 -8  8 -2 -8  8 -2 8  -8 -2 8] \"integer indices\" [0 1 2 0 2 3]\n"
        "ObjectBegin \"box\"\n"
        "Material \"diffuse\" \"rgb reflectance\" [0.2 0.6 0.3]\n"
        "Shape \"trianglemesh\" \"point3 P\" [-1 -1 -1 1 -1 -1 1 1 -1 -1 1 -1 -1 -1 1 1 -1 1 1 1 1 -1 1 1]\n"
        "  \"integer indices\" [0 1 2 0 2 3  4 6 5 4 7 6  0 4 5 0 5 1  3 2 6 3 6 7  0 3 7 0 7 4  1 5 6 1 6 2]\n"
        "ObjectEnd\n"
        "AttributeBegin Translate -3 0 0 Rotate 30 0 1 0 ObjectInstance \"box\" AttributeEnd\n"
        "AttributeBegin Translate 0 1 0 Scale 1 0 1 ObjectInstance \"box\" AttributeEnd\n"
        "Shape \"trianglemesh\" \"point3 P\" [-1 3 0  1 3 0  0 4 0] \"integer indices\" [0 1 2]\n"
        "AttributeBegin Translate 3 0 1 Scale 0.5 1.5 1 ObjectInstance \"box\" AttributeEnd\n";
    rt_err e = {0};
    char *path = check_path("kept_singular.pbrt");
    check_write_file(path, text, strlen(text));
    rt_scene *f = rt_scene_load(path, &e), *k = rt_scene_load_flags(path, RT_LOAD_KEEP_INSTANCES, &e);
    CHECK(f && k, "load: %s", e.msg);
    if (!f || !k) {
        rt_scene_free(f);
        rt_scene_free(k);
        return;
    }
    /* flattened: 2 + 12 + 12 + 1 + 12 = 39; kept: the ground, the singular copy, the triangle */
    CHECK(f->ntri == 39 && k->nflat == 39 && k->ntri == 15 && k->nirec == 2 && k->irec[0].first == 2 &&
              k->irec[1].first == 27 && k->irec[1].loose == 15,
          "flat %u/%u, loose %u, records %u", f->ntri, k->nflat, k->ntri, k->nirec);
    CHECK(rt_scene_check_kept(k, &e) == 0, "kept: %s", e.msg);
    uint32_t bad = 0;
    for (uint32_t i = 0; i < f->ntri && i < k->nflat; i++) {
        rt_tri tmp;
        bad += memcmp(rt_scene_tri_of(k, i, &tmp), &f->tri[i], sizeof(rt_tri)) != 0 ||
               memcmp(rt_scene_shade_of(k, i), &f->shade[i], sizeof(rt_shade)) != 0;
    }
    CHECK(bad == 0 && !memcmp(&k->bounds, &f->bounds, sizeof k->bounds), "%u triangles differ (or the bounds)", bad);
    rt_accel a;
    CHECK(rt_accel_build(&a, RT_ACCEL_INST, k, NULL, &e) == 0, "build: %s", e.msg);
    if (a.as) {
        CHECK(rt_accel_check(&a, k, &e) == 0, "check: %s", e.msg);
        rt_trav tv;
        rt_accel_trav(&a, &tv, k, NULL, NULL);
        int nbad = 0, hits = 0;
        for (int i = 0; i < 5000; i++) {
            rt_vec3 o = rt_v3((float)(urand() * 12 - 6), (float)(urand() * 8 - 3), (float)(urand() * 12 - 6));
            rt_vec3 d = rt_v3((float)(urand() * 2 - 1), (float)(urand() * 2 - 1), (float)(urand() * 2 - 1));
            if (i % 2) /* at the singular copy, the flat square y = 1 */
                d = rt_v3((float)(urand() * 2 - 1) - o.x, 1 - o.y, (float)(urand() * 2 - 1) - o.z);
            rt_ray r;
            rt_ray_init(&r, o, d);
            rt_hit h1, h2;
            int b1 = rt_brute_closest(f, &r, &h1), b2 = a.ops->closest(&tv, &r, &h2);
            hits += b1;
            if ((b1 != b2 || (b1 && !same_hit(&h1, &h2)) || rt_brute_occluded(f, &r) != a.ops->occluded(&tv, &r)) &&
                nbad++ < 5)
                CHECK(0, "ray %d: brute %d tri %u, kept inst %d tri %u", i, b1, h1.tri, b2, h2.tri);
        }
        CHECK(nbad == 0 && hits > 1000, "%d rays differ, %d hits", nbad, hits);
        rt_accel_free(&a);
    }
    rt_scene_free(f);
    rt_scene_free(k);
}

int main(void) {
    rt_err e = {0};
    char *path = check_path("inst.pbrt");
    check_write_file(path, scene_text, strlen(scene_text));
    rt_scene *s = rt_scene_load(path, &e);
    CHECK(s != NULL, "load: %s", e.msg);
    if (!s)
        return 1;
    CHECK(s->ninst == 8 && s->nirec == 8 && s->nobj == 3, "instances %u, records %u, objects %u", s->ninst, s->nirec,
          s->nobj);
    rt_accel a;
    CHECK(rt_accel_build(&a, RT_ACCEL_INST, s, NULL, &e) == 0, "build: %s", e.msg);
    rt_inst *I = a.as;
    CHECK(I->ninst == 9 && I->nloose == 2, "instances %u (with the loose one), loose triangles %u", I->ninst,
          I->nloose);
    /* shared bottom level: each object's triangles once, plus the loose ones */
    uint32_t want = s->obj[0].count + s->obj[1].count + s->obj[2].count + 2;
    CHECK(I->nbtri == want, "shared records %u, expected %u (flattened: %u)", I->nbtri, want, s->ntri);
    CHECK(rt_accel_check(&a, s, &e) == 0, "check: %s", e.msg);

    rt_trav tv;
    rt_accel_trav(&a, &tv, s, NULL, NULL);
    int bad = 0, hits = 0, occl = 0;
    for (int i = 0; i < 20000; i++) {
        rt_vec3 o = rt_v3((float)(urand() * 20 - 10), (float)(urand() * 10 - 3), (float)(urand() * 20 - 10));
        rt_vec3 d = rt_v3((float)(urand() * 2 - 1), (float)(urand() * 2 - 1), (float)(urand() * 2 - 1));
        if (i % 4 == 0) /* aimed at an instance's centre */
            d = rt_v3(-3 - o.x, 0 - o.y, 1 - o.z);
        if (i % 4 == 1)
            d = rt_v3(-4 - o.x, 0 - o.y, -3 - o.z);
        if (i % 4 == 2) /* at the flat card (its object-space box has no depth) */
            d = rt_v3((float)(urand() - 0.5) - o.x, (float)(urand() - 0.5) - o.y, -2 - o.z);
        rt_ray r;
        rt_ray_init(&r, o, d);
        if (i % 3 == 1)
            r.tmin = (float)(urand() * 0.5), r.tmax = (float)(1 + urand() * 20);
        rt_hit h1, h2;
        int b1 = rt_brute_closest(s, &r, &h1), b2 = a.ops->closest(&tv, &r, &h2);
        if (b1 != b2 || (b1 && !same_hit(&h1, &h2))) {
            if (bad++ < 5)
                CHECK(0, "ray %d: brute %d tri %u t %.9g, inst %d tri %u t %.9g", i, b1, h1.tri, (double)h1.t, b2,
                      h2.tri, (double)h2.t);
        }
        hits += b1;
        int o1 = rt_brute_occluded(s, &r), o2 = a.ops->occluded(&tv, &r);
        if (o1 != o2 && bad++ < 5)
            CHECK(0, "ray %d: occluded brute %d inst %d", i, o1, o2);
        occl += o1;
    }
    CHECK(bad == 0, "%d rays differ", bad);
    CHECK(hits > 5000 && occl >= hits, "hits %d, occluded %d: the rays should meet the scene often", hits, occl);
    CHECK(tv.xforms > 0 && tv.tests < (uint64_t)20000 * 2 * s->ntri, "transformed %llu, tests %llu",
          (unsigned long long)tv.xforms, (unsigned long long)tv.tests);

    test_packets(s, &a, s, "scene");
    corrupt_and_check(s, I);
    test_images(s);
    test_packet_images(s);
    {
        rt_scene *k = rt_scene_load_flags(path, RT_LOAD_KEEP_INSTANCES, &e);
        CHECK(k && k->kept, "kept load: %s", k ? "not kept" : e.msg);
        test_treelet(s, k, "scene", 3);
        rt_scene_free(k);
    }
    test_kept(path, s);
    test_kept_singular();
    test_packet_kept(path, s);
    test_footer();
    test_nested();
    rt_accel_free(&a);
    rt_scene_free(s);

    if (failures)
        fprintf(stderr, "test_inst: %d failures\n", failures);
    return failures != 0;
}
