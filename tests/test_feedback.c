/*
 * test_feedback.c -- the feedback tracer (tracegen/feedback.c): the 64-byte
 * record and its packing, the buffer size S_VB and its refusal, pass
 * counts and buffer occupancy on hand-built scenes (a mirror pair, a
 * scene without hits), the fixed emit order seen in the trace, and images
 * against the recursive tracer in raycast, shadow and whitted modes, with
 * the grid and with every triangle; the record stores (non-temporal by
 * default, write-allocate as an option) and their traffic.
 */
#include "scene_load.h"
#include "check.h"
#include "check_scene.h"
#include "feedback.h"
#include "grid.h"
#include "kdtree.h"
#include "run.h"
#include "sim.h"

#include <inttypes.h>
#include <stddef.h>

/* ---- helpers ------------------------------------------------------------- */

/* A number from the statistics string ("key=value"), or -1. */
static double stat_of(const rt_run_stats *st, const char *key)
{
    char k[64];
    snprintf(k, sizeof k, " %s=", key);
    const char *p = strstr(st->extra, k);
    if (!p && !strncmp(st->extra, k + 1, strlen(k + 1))) p = st->extra - 1;
    return p ? strtod(p + strlen(k), NULL) : -1;
}

/* The i-th entry of a comma list in the statistics ("records_in=a,b,c"). */
static double stat_at(const rt_run_stats *st, const char *key, int i)
{
    char k[64];
    snprintf(k, sizeof k, " %s=", key);
    const char *p = strstr(st->extra, k);
    if (!p) return -1;
    p += strlen(k);
    for (; i > 0; i--) {
        p = strchr(p, ',');
        if (!p) return -1;
        p++;
    }
    return strtod(p, NULL);
}

typedef struct capture {
    rt_access *a;
    size_t n, cap;
} capture;

static int cap_put(rt_sink *s, const rt_access *a, size_t n)
{
    capture *c = s->ctx;
    if (c->n + n > c->cap) {
        size_t nc = (c->n + n) * 2;
        rt_access *na = realloc(c->a, nc * sizeof *na);
        if (!na) return -1;
        c->a = na;
        c->cap = nc;
    }
    memcpy(c->a + c->n, a, n * sizeof *a);
    c->n += n;
    return 0;
}

/* Renders scene sc (borrowed) with tracer; NULL on failure. cap: record
 * the accesses. */
static rt_image *render_sc(rt_scene *sc, const char *tracer, const rt_render_opts *o, rt_run_stats *st, capture *cap,
                           rt_layout *L)
{
    rt_err e = {0};
    rt_kd_params kp;
    rt_kd_default_params(&kp);
    rt_kdtree *kd = rt_kd_build(sc, &kp, &e);
    rt_job j;
    rt_image *im = NULL;
    rt_sink sink = {cap_put, cap};
    if (!kd || rt_job_setup_borrowed(&j, sc, kd, tracer, o, &e) < 0) {
        CHECK(0, "%s: %s", tracer, e.msg);
        rt_kd_free(kd);
        return NULL;
    }
    j.check = 1;
    im = rt_image_new(o->W, o->H, &e);
    if (!im || rt_job_run(&j, cap ? &sink : NULL, im, st, &e) < 0) {
        CHECK(0, "run %s: %s", tracer, e.msg);
        rt_image_free(im);
        im = NULL;
    }
    if (L) *L = j.L;
    rt_job_free(&j);
    rt_kd_free(kd);
    return im;
}

static rt_image *render_spec(const char *spec, const char *tracer, const rt_render_opts *o, rt_run_stats *st)
{
    rt_err e = {0};
    rt_job j;
    rt_image *im = NULL;
    if (rt_job_setup(&j, spec, tracer, o, &e) < 0) {
        CHECK(0, "%s %s: %s", spec, tracer, e.msg);
        return NULL;
    }
    j.check = 1;
    im = rt_image_new(o->W, o->H, &e);
    if (!im || rt_job_run(&j, NULL, im, st, &e) < 0) {
        CHECK(0, "run %s %s: %s", spec, tracer, e.msg);
        rt_image_free(im);
        im = NULL;
    }
    rt_job_free(&j);
    return im;
}

/* Two facing mirrors z = -1 and z = +1, 10 wide; the camera between them
 * looks along +z with a narrow view, so every ray bounces between them for
 * ever. Light 0 between the mirrors off the axis. */
static rt_scene *mirror_pair(void)
{
    rt_err e = {0};
    rt_scene *sc = rt_scene_new(4, &e);
    int m = add_mat(sc, 0.5f, 0.0f, 1.0f);
    const float grey[3] = {0.4f, 0.4f, 0.4f};
    const float S = 5.0f;
    add_quad(sc, rt_v3(-S, -S, 1), rt_v3(S, -S, 1), rt_v3(S, S, 1), rt_v3(-S, S, 1), grey, m);
    add_quad(sc, rt_v3(-S, -S, -1), rt_v3(-S, S, -1), rt_v3(S, S, -1), rt_v3(S, -S, -1), grey, m);
    CHECK(rt_scene_finish(sc, &e) == 0, "finish: %s", e.msg);
    sc->cam.eye = rt_v3(0, 0, 0);
    sc->cam.at = rt_v3(0, 0, 1);
    sc->cam.up = rt_v3(0, 1, 0);
    sc->cam.fovy_deg = 20.0f;
    sc->light[0] = rt_v3(3.0f, 2.0f, 0.2f);
    sc->light[1] = rt_v3(-3.0f, 1.0f, -0.3f);
    sc->light[2] = rt_v3(0.5f, -4.0f, 0.1f);
    sc->background = rt_v3(0, 0, 0);
    return sc;
}

/* One triangle behind the camera, black background: no ray hits. */
static rt_scene *nothing(void)
{
    rt_err e = {0};
    rt_scene *sc = rt_scene_new(1, &e);
    const float grey[3] = {0.5f, 0.5f, 0.5f};
    CHECK(rt_scene_add_tri(sc, rt_v3(-1, -1, -5), rt_v3(1, -1, -5), rt_v3(0, 1, -5), grey, &e) == 0, "tri");
    CHECK(rt_scene_finish(sc, &e) == 0, "finish: %s", e.msg);
    sc->cam.eye = rt_v3(0, 0, 0);
    sc->cam.at = rt_v3(0, 0, 1);
    sc->cam.up = rt_v3(0, 1, 0);
    sc->cam.fovy_deg = 40.0f;
    sc->background = rt_v3(0, 0, 0);
    return sc;
}

/* ---- the record ----------------------------------------------------------- */

static void record(void)
{
    CHECK(sizeof(rt_fb_rec) == 64, "record is %zu bytes", sizeof(rt_fb_rec));
    CHECK(offsetof(rt_fb_rec, orig_t) == 16 && offsetof(rt_fb_rec, dir_idx) == 32 &&
              offsetof(rt_fb_rec, uv_state) == 48,
          "Listing 2 order");
    rnd_seed(7);
    for (int i = 0; i < 2000; i++) {
        rt_fb_ray a, b;
        rt_fb_rec r;
        memset(&a, 0, sizeof a);
        a.pix = (uint32_t)rnd64();
        for (int k = 0; k < 3; k++) a.w[k] = uf(-2, 2);
        a.o = rt_v3(uf(-9, 9), uf(-9, 9), uf(-9, 9));
        a.d = rand_dir();
        a.t = i % 3 ? uf(0, 100) : INFINITY;
        a.tri = i % 5 ? (uint32_t)rnd64() : RT_NO_HIT;
        a.state = (uint8_t)(rnd64() % 3);
        a.type = (uint8_t)(rnd64() % 4);
        a.gen = (uint8_t)(rnd64() % 65);
        if (a.type == RT_FB_SHADOW) {
            a.light = (uint32_t)(rnd64() % 3);
        } else {
            a.u = uf(0, 1);
            a.v = uf(0, 1);
            a.nmed = (uint8_t)(rnd64() % 5);
            for (int k = 0; k < a.nmed; k++) a.med[k] = (uint8_t)rnd64();
        }
        rt_fb_pack(&a, &r);
        rt_fb_unpack(&r, &b);
        CHECK(!memcmp(&a, &b, sizeof a), "round trip of record %d", i);
        uint32_t u;
        memcpy(&u, &r.pos[0], 4);
        CHECK(u == a.pix, "pos.x holds the pixel's bits");
        memcpy(&u, &r.dir_idx[3], 4);
        CHECK(u == a.tri, "dir_idx.w holds the triangle's bits");
        memcpy(&u, &r.uv_state[2], 4);
        CHECK((u & 3) == a.state && (u >> 2 & 3) == a.type && (u >> 4 & 127) == a.gen, "state word %08x", u);
        CHECK(r.orig_t[3] == a.t || (isinf(a.t) && isinf(r.orig_t[3])), "orig_t.w is t");
        if (failures) return;
    }
}

/* ---- S_VB ------------------------------------------------------------------ */

static void sizes(void)
{
    rt_err e = {0};
    rt_render_opts o;
    rt_fb_sizes z;
    rt_scene *pair = mirror_pair(), *diff = nothing();
    rt_render_default_opts(&o);
    /* raycast: one record per pixel */
    o.mode = RT_MODE_RAYCAST;
    CHECK(rt_fb_size(diff, &o, &z, &e) == 0 && z.G == 1 && z.G2 == 0 && z.passes == 1 &&
              z.svb == 512.0 * 512 * 64,
          "raycast: G %g G' %g passes %d svb %g", z.G, z.G2, z.passes, z.svb);
    /* shadow, three lights: E = 1, 3 */
    o.mode = RT_MODE_SHADOW;
    o.lights = 7;
    CHECK(rt_fb_size(diff, &o, &z, &e) == 0 && z.E[1] == 3 && z.G == 3 && z.G2 == 1 && z.passes == 2,
          "shadow: G %g G' %g", z.G, z.G2);
    /* the paper's Figure 4: shadows and one bounce of mirrors at 512^2,
     * E = 1, 2 (shadow + reflected), 1 (the reflected hit's shadow ray):
     * S_VB = 512 x 512 x (2 + 1) x 64 = 48 MiB */
    o.mode = RT_MODE_WHITTED;
    o.lights = 1;
    o.depth = 2;
    CHECK(rt_fb_size(pair, &o, &z, &e) == 0 && z.branching == 1 && z.E[0] == 1 && z.E[1] == 2 && z.E[2] == 1 &&
              z.G == 2 && z.G2 == 1 && z.svb == 48.0 * 1024 * 1024 && z.passes == 3,
          "figure 4: E %g %g %g svb %g", z.E[0], z.E[1], z.E[2], z.svb);
    /* mirrors do not grow: depth 64 fits */
    o.depth = 64;
    CHECK(rt_fb_size(pair, &o, &z, &e) == 0 && z.G == 2 && z.G2 == 2, "depth 64 mirrors: %s", e.msg);
    /* glass and mirror: b = 2, E = 1, 1+2, 2+4, 4 at depth 3 */
    rt_err e2 = {0};
    rt_scene *gl = rt_scene_new(2, &e2);
    int m = add_mat(gl, 0.2f, 0.7f, 1.5f);
    const float c[3] = {0.5f, 0.5f, 0.5f};
    add_quad(gl, rt_v3(-1, -1, 1), rt_v3(1, -1, 1), rt_v3(1, 1, 1), rt_v3(-1, 1, 1), c, m);
    CHECK(rt_scene_finish(gl, &e2) == 0, "finish");
    o.depth = 3;
    CHECK(rt_fb_size(gl, &o, &z, &e) == 0 && z.branching == 2 && z.E[1] == 3 && z.E[2] == 6 && z.E[3] == 4 &&
              z.G == 6 && z.G2 == 4,
          "glass: E %g %g %g", z.E[1], z.E[2], z.E[3]);
    /* refusal: depth beyond what the default 2 GiB holds (b = 2 doubles
     * the buffer per generation), and an explicit limit */
    o.depth = 12;
    CHECK(rt_fb_size(gl, &o, &z, &e) < 0 && rt_fb_refused(&e) && strstr(e.msg, "--vb-size"), "depth 12: %s", e.msg);
    char need[64];
    snprintf(need, sizeof need, "%.0f bytes", z.svb);
    CHECK(strstr(e.msg, need) != NULL, "message gives the size needed: %s", e.msg);
    o.depth = 2;
    o.vb_size = 48ull * 1024 * 1024 - 1;
    CHECK(rt_fb_size(pair, &o, &z, &e) < 0 && rt_fb_refused(&e) && strstr(e.msg, "50331648 bytes"), "limit: %s",
          e.msg);
    /* a run refused at setup */
    o.W = o.H = 8;
    o.vb_size = 64;
    rt_kd_params kp;
    rt_kd_default_params(&kp);
    rt_kdtree *kd = rt_kd_build(pair, &kp, &e);
    rt_job j;
    CHECK(kd && rt_job_setup_borrowed(&j, pair, kd, "feedback", &o, &e) < 0 && rt_fb_refused(&e), "setup: %s", e.msg);
    rt_err other = {"unknown tracer", 0};
    CHECK(!rt_fb_refused(&other), "other errors are not refusals");
    rt_kd_free(kd);
    rt_scene_free(gl);
    rt_scene_free(pair);
    rt_scene_free(diff);
}

/* ---- passes ---------------------------------------------------------------- */

static void passes(void)
{
    rt_render_opts o;
    rt_run_stats st;
    rt_render_default_opts(&o);
    o.W = o.H = 16;
    const double N = 256;
    rt_scene *pair = mirror_pair();
    /* no lights: depth D gives D passes; every pass after the first reads
     * the N rays to trace and the N passed through the pass before */
    o.mode = RT_MODE_WHITTED;
    for (int D = 1; D <= 6; D++) {
        o.depth = D;
        rt_image *im = render_sc(pair, "feedback", &o, &st, NULL, NULL);
        CHECK(stat_of(&st, "passes") == D, "depth %d: %g passes (%s)", D, stat_of(&st, "passes"), st.extra);
        CHECK(stat_of(&st, "rays_secondary") == N * (D - 1), "depth %d: secondary %g", D, stat_of(&st, "rays_secondary"));
        for (int p = 0; p < D; p++)
            CHECK(stat_at(&st, "records_in", p) == (p ? 2 * N : N), "depth %d pass %d: %g records", D, p,
                  stat_at(&st, "records_in", p));
        rt_image_free(im);
    }
    /* one light: one more pass for the last generation's shadow rays;
     * the buffer never exceeds its capacity W H (G + G') */
    o.lights = 1;
    o.depth = 4;
    rt_image *im = render_sc(pair, "feedback", &o, &st, NULL, NULL);
    CHECK(stat_of(&st, "passes") == 5 && stat_of(&st, "G") == 2 && stat_of(&st, "G2") == 2, "light: %s", st.extra);
    CHECK(stat_of(&st, "occupancy") > 0.4 && stat_of(&st, "occupancy") <= 1.0, "occupancy %g", stat_of(&st, "occupancy"));
    CHECK(st.rays_shadow == 4 * N, "shadow rays %" PRIu64, st.rays_shadow);
    rt_image_free(im);
    rt_scene_free(pair);

    /* no hits: the buffer is empty after one pass */
    rt_scene *none = nothing();
    static const int modes[] = {RT_MODE_RAYCAST, RT_MODE_SHADOW, RT_MODE_WHITTED};
    for (int i = 0; i < 3; i++) {
        rt_render_default_opts(&o);
        o.W = o.H = 16;
        o.mode = modes[i];
        o.lights = 1;
        for (int a = 0; a < 2; a++) {
            o.accel = a ? RT_ACCEL_NAIVE : RT_ACCEL_GRID;
            im = render_sc(none, "feedback", &o, &st, NULL, NULL);
            CHECK(stat_of(&st, "passes") == 1 && stat_at(&st, "records_out", 0) == 0 && st.tests == 0,
                  "mode %d accel %d: %s", modes[i], a, st.extra);
            CHECK(stat_of(&st, "vs_box_out") == N, "box test rejects all: %g", stat_of(&st, "vs_box_out"));
            rt_image_free(im);
        }
    }
    rt_scene_free(none);
}

/* The fixed emit order seen in the trace: one pixel of a glass-and-mirror
 * quad with one light, whitted depth 2. The first pass appends to
 * vb.write, in order, the eye ray passed through (generation 0), its
 * shadow ray (0), the reflected ray (1) and the refracted ray (1); the
 * second pass drops the first without a texture read, traces the shadow
 * ray without shading it (it reads no material texel) and traces and
 * shades the two secondary rays. */
static void order(void)
{
    rt_err e = {0};
    rt_scene *sc = rt_scene_new(2, &e);
    int m = add_mat(sc, 0.3f, 0.6f, 1.5f);
    const float c[3] = {0.5f, 0.5f, 0.5f};
    add_quad(sc, rt_v3(-1, -1, 1), rt_v3(1, -1, 1), rt_v3(1, 1, 1), rt_v3(-1, 1, 1), c, m);
    /* diffuse walls behind the camera and beyond the glass */
    add_quad(sc, rt_v3(-2, -2, -1), rt_v3(2, -2, -1), rt_v3(2, 2, -1), rt_v3(-2, 2, -1), c, 0);
    add_quad(sc, rt_v3(-2, -2, 3), rt_v3(2, -2, 3), rt_v3(2, 2, 3), rt_v3(-2, 2, 3), c, 0);
    CHECK(rt_scene_finish(sc, &e) == 0, "finish");
    sc->cam.eye = rt_v3(0.1f, 0.05f, 0);
    sc->cam.at = rt_v3(0.1f, 0.05f, 1);
    sc->cam.up = rt_v3(0, 1, 0);
    sc->cam.fovy_deg = 10.0f;
    sc->light[0] = rt_v3(0.3f, 0.2f, 0.5f);
    rt_render_opts o;
    rt_render_default_opts(&o);
    o.W = o.H = 1;
    o.mode = RT_MODE_WHITTED;
    o.depth = 2;
    o.lights = 1;
    rt_run_stats st;
    capture cap = {NULL, 0, 0};
    rt_layout L;
    rt_image *im = render_sc(sc, "feedback", &o, &st, &cap, &L);
    int vr = rt_mm_find(&L, "vb.read"), vw = rt_mm_find(&L, "vb.write"), tri = rt_mm_find(&L, "tri");
    CHECK(vr >= 0 && vw >= 0 && tri >= 0, "regions");
    /* writes to vb.write in pass 1 (before pass 2 reads it), in order */
    int gens[8], nw = 0;
    size_t first_read = cap.n;
    for (size_t i = 0; i < cap.n && first_read == cap.n; i++)
        if (!cap.a[i].write && cap.a[i].addr >= L.r[vw].base && cap.a[i].addr < L.r[vw].base + 64 * L.r[vw].count)
            first_read = i;
    for (size_t i = 0; i < first_read && nw < 8; i++) {
        const rt_access *a = &cap.a[i];
        if (a->write && a->addr >= L.r[vw].base && a->addr < L.r[vw].base + 64 * L.r[vw].count) {
            CHECK(a->addr == rt_mm_addr(&L, vw, (uint64_t)nw), "stream-out is sequential");
            gens[nw++] = a->gen;
        }
    }
    CHECK(nw == 4 && gens[0] == 0 && gens[1] == 0 && gens[2] == 1 && gens[3] == 1, "%d writes, gens %d %d %d %d", nw,
          gens[0], gens[1], gens[2], gens[3]);
    /* reads of vb.write (pass 2) and what happens between them */
    size_t rd[5];
    int nr = 0;
    for (size_t i = 0; i < cap.n; i++) {
        const rt_access *a = &cap.a[i];
        if (!a->write && a->addr >= L.r[vw].base && a->addr < L.r[vw].base + 64 * L.r[vw].count && nr < 4) {
            CHECK(a->addr == rt_mm_addr(&L, vw, (uint64_t)nr), "pass 2 reads in buffer order");
            rd[nr++] = i;
        }
    }
    rd[nr] = cap.n;
    CHECK(nr == 4, "%d reads in pass 2", nr);
    if (nr == 4) {
        CHECK(rd[1] == rd[0] + 1, "the passed-through eye ray is dropped at once");
        int shade[4] = {0};
        for (int k = 1; k < 4; k++)
            for (size_t i = rd[k] + 1; i < rd[k + 1]; i++)
                shade[k] += cap.a[i].cls == RT_CLS_SHADE;
        CHECK(shade[1] == 0 && shade[2] > 0 && shade[3] > 0, "shading reads %d %d %d: shadow, reflected, refracted",
              shade[1], shade[2], shade[3]);
    }
    CHECK(stat_of(&st, "passes") == 3, "passes %g", stat_of(&st, "passes"));
    free(cap.a);
    rt_image_free(im);
    rt_scene_free(sc);
}

/* ---- images ------------------------------------------------------------------ */

/* Largest |a - b| over RGB and depth, and the count of differing values. */
static size_t diff(const rt_image *a, const rt_image *b, double *maxd)
{
    size_t n = (size_t)a->W * a->H, nd = 0;
    *maxd = 0;
    for (size_t i = 0; i < 3 * n; i++) {
        double d = fabs((double)a->rgb[i] - b->rgb[i]);
        if (d > *maxd) *maxd = d;
        nd += a->rgb[i] != b->rgb[i];
    }
    for (size_t i = 0; i < n; i++) nd += !(a->depth[i] == b->depth[i]);
    return nd;
}

/* Equation 1 differs from the recursive tracer's fixed-point sum only by
 * float rounding: per pixel at most five terms (eye colour c0 and light
 * term l0, reflected c1 and l1, and -l1 when that shadow ray is occluded)
 * go through at most four float additions, each off by at most 2^-24 of
 * a partial sum bounded by S = the sum of the terms' magnitudes; the
 * recursive tracer rounds each of its four terms to 2^-33 and its total
 * to float (2^-24 S). Bound: 5 * 2^-24 * S + 4 * 2^-33, with S <=
 * 2 (1 + ks) (ambient + light_power) for albedos <= 1. */
static double eq1_bound(const rt_scene *sc, float ks)
{
    double S = 2.0 * (1.0 + ks) * (sc->ambient + sc->light_power);
    return 5.0 * ldexp(1.0, -24) * S + 4.0 * ldexp(1.0, -33);
}

static void images(void)
{
    static const struct {
        const char *spec;
        int mode, depth;
        unsigned lights;
        int exact;         /* 1: bit-identical; 0: within eq1_bound */
        const char *comp;  /* the compositing it must choose */
        int naive;         /* also render with --accel naive */
    } c[] = {
        {"cornell", RT_MODE_RAYCAST, 1, 0, 1, "eq1", 1},
        {"cornell", RT_MODE_SHADOW, 1, 1, 1, "eq1", 1},          /* Equation 1 */
        {"knot", RT_MODE_SHADOW, 1, 2, 1, "eq1", 0},             /* Equation 1, light 1 */
        {"cornell", RT_MODE_SHADOW, 1, 7, 1, "mrt-lights", 1},   /* a target per light */
        {"cornell:material=mirror", RT_MODE_WHITTED, 2, 1, 0, "eq1", 1}, /* Equation 1, one bounce */
        {"cornell:material=mirror", RT_MODE_WHITTED, 1, 1, 0, "eq1", 0},
        {"cornell:material=mirror", RT_MODE_WHITTED, 4, 7, 1, "mrt-generations", 1},
        {"cornell:material=glass", RT_MODE_WHITTED, 4, 1, 1, "mrt-generations", 0},
        {"knot:material=mirror", RT_MODE_WHITTED, 3, 5, 1, "mrt-generations", 0},
    };
    for (size_t i = 0; i < sizeof c / sizeof c[0]; i++) {
        rt_render_opts o;
        rt_run_stats s0, s1, s2;
        memset(&s2, 0, sizeof s2);
        rt_render_default_opts(&o);
        o.W = o.H = check_long() ? 64 : 24;
        o.mode = c[i].mode;
        o.depth = c[i].depth;
        o.lights = c[i].lights;
        rt_image *ref = render_spec(c[i].spec, "recursive", &o, &s0);
        rt_image *fb = render_spec(c[i].spec, "feedback", &o, &s1);
        o.accel = RT_ACCEL_NAIVE;
        rt_image *nv = c[i].naive ? render_spec(c[i].spec, "feedback", &o, &s2) : NULL;
        if (!ref || !fb || (c[i].naive && !nv)) {
            rt_image_free(ref), rt_image_free(fb), rt_image_free(nv);
            continue;
        }
        double md;
        size_t nd = diff(ref, fb, &md);
        if (c[i].exact) {
            CHECK(nd == 0, "%s mode %d depth %d lights %u: %zu values differ (max %g)", c[i].spec, c[i].mode,
                  c[i].depth, c[i].lights, nd, md);
        } else {
            rt_err e = {0};
            rt_scene *sc = rt_scene_load(c[i].spec, &e);
            double b = sc ? eq1_bound(sc, 0.8f) : 0;
            CHECK(sc && md <= b, "%s depth %d: max difference %g above the bound %g", c[i].spec, c[i].depth, md, b);
            for (size_t p = 0; p < (size_t)o.W * o.H; p++)
                CHECK(ref->depth[p] == fb->depth[p], "depth of pixel %zu", p);
            rt_scene_free(sc);
        }
        char want[64];
        snprintf(want, sizeof want, "composite=%s ", c[i].comp);
        CHECK(strstr(s1.extra, want) != NULL, "%s: want %s: %s", c[i].spec, want, s1.extra);
        CHECK(!nv || diff(fb, nv, &md) == 0, "%s: grid and naive images differ", c[i].spec);
        /* the same rays: hits and shadow rays of the recursive tracer */
        CHECK(s1.rays_primary == s0.rays_primary && s1.rays_shadow == s0.rays_shadow, "%s: rays %" PRIu64 "/%" PRIu64
              " vs %" PRIu64 "/%" PRIu64, c[i].spec, s1.rays_primary, s1.rays_shadow, s0.rays_primary, s0.rays_shadow);
        /* naive: every eye ray inside the box tests every triangle */
        CHECK(!nv || s2.tests > s1.tests, "%s: naive %" PRIu64 " tests, grid %" PRIu64, c[i].spec, s2.tests, s1.tests);
        if (nv && c[i].mode == RT_MODE_RAYCAST) {
            rt_err e = {0};
            rt_scene *sc = rt_scene_load(c[i].spec, &e);
            double want_t = sc ? (double)sc->ntri * (double)(s2.rays_primary - (uint64_t)stat_of(&s2, "vs_box_out")) : -1;
            CHECK((double)s2.tests == want_t, "naive raycast: %" PRIu64 " tests, want %g", s2.tests, want_t);
            rt_scene_free(sc);
        }
        rt_image_free(ref);
        rt_image_free(fb);
        rt_image_free(nv);
    }
    /* subsampling: the same tiles, the same pixels */
    rt_render_opts o;
    rt_run_stats st;
    rt_render_default_opts(&o);
    o.W = o.H = 32;
    o.lights = 7;
    o.subsample = 3;
    o.subtile = 4;
    o.mode = RT_MODE_WHITTED;
    o.depth = 3;
    rt_image *a = render_spec("cornell:material=mirror", "recursive", &o, &st);
    rt_image *b = render_spec("cornell:material=mirror", "feedback", &o, &st);
    double md;
    CHECK(a && b && diff(a, b, &md) == 0, "subsampled images differ");
    CHECK(st.rays_primary > 0 && st.rays_primary < 1024 / 2, "subsampled: %" PRIu64 " eye rays", st.rays_primary);
    rt_image_free(a);
    rt_image_free(b);
    /* the tests channel sums to the counter */
    rt_render_default_opts(&o);
    o.W = o.H = 16;
    o.lights = 1;
    rt_image *im = render_spec("cornell", "feedback", &o, &st);
    if (im) {
        double sum = 0;
        for (int p = 0; p < 256; p++) sum += im->tests[p];
        CHECK(sum == (double)st.tests && st.tests > 0, "tests channel %g vs %" PRIu64, sum, st.tests);
        unsigned char rgb[3 * 256];
        rt_fb_heatmap(im, 32, rgb);
        int blue = 0;
        for (int p = 0; p < 256; p++) blue += im->tests[p] == 0 && rgb[3 * p + 2] == 255 && rgb[3 * p] == 0;
        int zero = 0;
        for (int p = 0; p < 256; p++) zero += im->tests[p] == 0;
        CHECK(blue == zero, "zero cost is blue");
        rt_image_free(im);
    }
}

/* Options: --accel and --grid-min checked, the mode path refused, the
 * run key unchanged for defaults. */
static void options(void)
{
    rt_render_opts o;
    rt_err e = {0};
    char buf[256];
    rt_render_default_opts(&o);
    CHECK(rt_accel_from_name("grid") == RT_ACCEL_GRID && rt_accel_from_name("naive") == RT_ACCEL_NAIVE &&
              rt_accel_from_name("bvh") == -1,
          "accel names");
    o.accel = RT_ACCEL_NKINDS; /* the first kind that does not exist */
    CHECK(rt_render_check_mode(&o, &e) < 0 && strstr(e.msg, "--accel"), "accel %d: %s", RT_ACCEL_NKINDS, e.msg);
    o.accel = RT_ACCEL_GRID;
    o.grid_min = RT_GRID_MAX_CELLS + 1u;
    CHECK(rt_render_check_mode(&o, &e) < 0 && strstr(e.msg, "--grid-min"), "grid-min too large: %s", e.msg);
    o.grid_min = 0; /* the tracer's default, 64 */
    CHECK(!strcmp(rt_job_params("feedback", &o, NULL, buf, sizeof buf), ""), "default key '%s'", buf);
    o.grid_min = 64;
    CHECK(!strcmp(rt_job_params("feedback", &o, NULL, buf, sizeof buf), ""), "default key '%s'", buf);
    CHECK(!strcmp(rt_job_params("recursive", &o, NULL, buf, sizeof buf), ""), "recursive key '%s'", buf);
    o.accel = RT_ACCEL_NAIVE;
    o.grid_min = 32;
    o.vb_size = 1 << 20;
    CHECK(!strcmp(rt_job_params("feedback", &o, NULL, buf, sizeof buf), "accel=naive grid_min=32 vb-size=1048576"),
          "key '%s'", buf);
    CHECK(!strcmp(rt_job_params("packet", &o, NULL, buf, sizeof buf), "packet=8"), "packet key '%s'", buf);
    o.rstores = RT_RSTORES_WRITE_ALLOCATE;
    CHECK(!strcmp(rt_job_params("feedback", &o, NULL, buf, sizeof buf),
                  "accel=naive grid_min=32 vb-size=1048576 record_stores=write-allocate"),
          "key '%s'", buf);
    o.accel = RT_ACCEL_GRID;
    o.grid_min = 0;
    o.grid_density = 4;
    o.vb_size = 0;
    o.rstores = RT_RSTORES_NON_TEMPORAL;
    CHECK(!strcmp(rt_job_params("feedback", &o, NULL, buf, sizeof buf), "grid_density=4"), "key '%s'", buf);
    CHECK(rt_render_check_mode(&o, &e) == 0, "density alone: %s", e.msg);
    o.grid_min = 16;
    CHECK(rt_render_check_mode(&o, &e) < 0 && e.usage && strstr(e.msg, "--grid-density"), "both rules: %s", e.msg);
    o.grid_min = 0;
    o.grid_density = RT_GRID_DENSITY_MAX * 2.0;
    CHECK(rt_render_check_mode(&o, &e) < 0 && strstr(e.msg, "--grid-density"), "density too large: %s", e.msg);
    o.grid_density = 0;
    o.rstores = 5;
    CHECK(rt_render_check_mode(&o, &e) < 0 && strstr(e.msg, "--record-stores"), "rstores 5: %s", e.msg);
    CHECK(rt_render_rstores_from_name("non-temporal") == RT_RSTORES_NON_TEMPORAL &&
              rt_render_rstores_from_name("write-allocate") == RT_RSTORES_WRITE_ALLOCATE &&
              rt_render_rstores_from_name("stream") == -1,
          "record-store names");
    rt_render_default_opts(&o);
    o.mode = RT_MODE_PATH;
    rt_job j;
    CHECK(rt_job_setup(&j, "cornell", "feedback", &o, &e) < 0 && strstr(e.msg, "path"), "path: %s", e.msg);
}

/* ---- record stores ------------------------------------------------------- */

/* Stream-class traffic of captured accesses in one 1 KiB fully associative
 * cache of 64-byte lines, flushed at the end. */
static uint64_t stream_traffic(const capture *c)
{
    rt_err e = {0};
    rt_sim_config cfg;
    rt_sim_config_default(&cfg);
    cfg.nsizes = 1;
    cfg.sizes[0] = 1024;
    cfg.flush = 1;
    rt_sim *sim = rt_sim_new(&cfg, &e);
    CHECK(sim != NULL, "sim: %s", e.msg);
    if (!sim) return 0;
    rt_sim_put(sim, c->a, c->n);
    rt_sim_finish(sim);
    rt_sim_counts k;
    rt_sim_get(sim, 0, RT_CLS_STREAM, &k);
    rt_sim_free(sim);
    return k.traffic_bytes;
}

/* Stream-out writes whole 64-byte records without reading them: every
 * vertex-buffer write is a streaming store by default (an ordinary write
 * with --record-stores write-allocate), so at a cache the buffers never fit
 * a record costs one line per read and one write-back per write, where
 * write-allocate adds a fetch per write: 64 (R + W) against 64 (R + 2 W). */
static void stores(void)
{
    rt_err e = {0};
    rt_scene *sc = rt_scene_load("knot:material=mirror", &e);
    CHECK(sc != NULL, "knot: %s", e.msg);
    if (!sc) return;
    uint64_t traffic[2] = {0, 0}, nr[2] = {0, 0}, nw[2] = {0, 0};
    for (int wa = 0; wa < 2; wa++) {
        rt_render_opts o;
        rt_render_default_opts(&o);
        o.W = o.H = 32;
        o.mode = RT_MODE_WHITTED;
        o.depth = 2;
        o.lights = 1;
        o.rstores = wa ? RT_RSTORES_WRITE_ALLOCATE : RT_RSTORES_NON_TEMPORAL;
        rt_run_stats st;
        capture cap = {NULL, 0, 0};
        rt_layout L;
        rt_image *im = render_sc(sc, "feedback", &o, &st, &cap, &L);
        CHECK(im != NULL, "render");
        int vb0 = rt_mm_find(&L, "vb.read"), vb1 = rt_mm_find(&L, "vb.write");
        uint64_t lo = L.r[vb0].base, hi = L.r[vb1].base + L.r[vb1].recsize * L.r[vb1].count, bad = 0;
        CHECK(L.r[vb0].base % 64 == 0 && L.r[vb1].base % 64 == 0, "buffers are line-aligned");
        for (size_t i = 0; i < cap.n; i++) {
            const rt_access *a = &cap.a[i];
            if (a->cls != RT_CLS_STREAM) continue;
            CHECK(a->addr >= lo && a->addr < hi && a->size == 64, "stream access outside the buffers");
            if (a->write) {
                nw[wa]++;
                bad += a->write != (wa ? 1 : RT_WRITE_STREAM);
            } else {
                nr[wa]++;
            }
        }
        CHECK(bad == 0, "%s: %" PRIu64 " record writes of the wrong kind", wa ? "write-allocate" : "non-temporal", bad);
        CHECK(nr[wa] == (uint64_t)stat_of(&st, "vs_records"), "records read %" PRIu64 ", vs_records %.0f", nr[wa],
              stat_of(&st, "vs_records"));
        CHECK(nw[wa] == (uint64_t)stat_of(&st, "gs_emitted") + 32 * 32, "records written %" PRIu64, nw[wa]);
        traffic[wa] = stream_traffic(&cap);
        free(cap.a);
        rt_image_free(im);
    }
    CHECK(nr[0] == nr[1] && nw[0] == nw[1] && nw[0] > 1024, "same records either way");
    CHECK(traffic[0] == 64 * (nr[0] + nw[0]), "non-temporal: stream traffic %" PRIu64 ", want 64 (%" PRIu64 " + %" PRIu64 ")",
          traffic[0], nr[0], nw[0]);
    CHECK(traffic[1] == 64 * (nr[1] + 2 * nw[1]),
          "write-allocate: stream traffic %" PRIu64 ", want 64 (%" PRIu64 " + 2 x %" PRIu64 ")", traffic[1], nr[1], nw[1]);
    rt_scene_free(sc);
}

/* ---- the modeled stage shares -------------------------------------------- */

/* The shares follow from the stage counters and the per-operation costs
 * counted from the paper's listings (docs/feedback.md, "The stage shares"):
 * vertex 15 per record + 16 per box test + 28 per triangle test, geometry
 * 8 per record + 8 per emit (+ 14 per child ray), fragment 10 per emitted
 * record + 16 per shaded ray (blending 0). Ray casting with every triangle
 * has no child rays, list reads or final pass, so the counters in the
 * statistics give the shares by hand. On the paper's 36-triangle Cornell
 * box the vertex share falls from ray casting to shadows to shadows with a
 * mirror bounce, as the paper's Table 1 does (85.3 / 77.4 / 72.7%). */
static void shares(void)
{
    double vs[3] = {0, 0, 0};
    static const int modes[3] = {RT_MODE_RAYCAST, RT_MODE_SHADOW, RT_MODE_WHITTED};
    for (int m = 0; m < 3; m++) {
        rt_render_opts o;
        rt_render_default_opts(&o);
        o.W = o.H = 32;
        o.accel = RT_ACCEL_NAIVE;
        o.mode = modes[m];
        o.lights = m ? 1 : 0;
        o.depth = 2;
        rt_run_stats st;
        rt_image *im = render_spec("cornell:glass=0,material=mirror", "feedback", &o, &st);
        CHECK(im != NULL, "render");
        rt_image_free(im);
        vs[m] = stat_of(&st, "modeled_share_vs");
        if (m) continue;
        const double R = stat_of(&st, "vs_records"), T = stat_of(&st, "vs_tests"), E = stat_of(&st, "gs_emitted"),
                     S = stat_of(&st, "fs_shaded");
        CHECK(R == 1024 && T == 36 * 1024 && E == 1024 && S == 1024, "raycast counters %.0f %.0f %.0f %.0f", R, T, E, S);
        const double v = 15 * R + 16 * R + 28 * T, g = 8 * R + 8 * E, f = 10 * E + 16 * S, tot = v + g + f;
        CHECK(fabs(stat_of(&st, "modeled_share_vs") - 100 * v / tot) < 0.006 &&
                  fabs(stat_of(&st, "modeled_share_gs") - 100 * g / tot) < 0.006 &&
                  fabs(stat_of(&st, "modeled_share_fs") - 100 * f / tot) < 0.006,
              "raycast shares %s, want %.2f %.2f %.2f", st.extra, 100 * v / tot, 100 * g / tot, 100 * f / tot);
    }
    CHECK(vs[0] > vs[1] && vs[1] > vs[2], "vertex share %.2f / %.2f / %.2f does not fall as the paper's", vs[0], vs[1],
          vs[2]);
}

int main(void)
{
    record();
    shares();
    stores();
    sizes();
    options();
    passes();
    order();
    images();
    return failures ? 1 : 0;
}
