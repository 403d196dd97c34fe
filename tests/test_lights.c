/*
 * test_lights.c -- lights as authored (scene.h "Lights as authored",
 * shade.h, --light-samples): pbrt files of one floor triangle seen from
 * above, lit by each light kind, with the shadow-ray counts worked out by
 * hand (every one of the 8 x 8 pixels hits the floor, so a light casts
 * 64 x its samples rays, or none when it lies below the floor); sampled
 * points checked to lie on their emitter; an occluder that darkens every
 * sample to the ambient term; all seven tracers' counts and images
 * identical (the scheduled ones checking each shadow ray against the
 * single-ray test, feedback its buffer bounds); the memory model's light
 * records read once per sample; the point model left exactly as it was (built-in scenes with
 * and without --light-samples give the same image and counts); the light
 * regions of the memory model present only for non-point lights; the
 * checker refusing broken light records; light selection by index.
 * Exit status 0 = all passed.
 */
#include "config.h"
#include "check.h"
#include "run.h"
#include "scene.h"
#include "scene_load.h"
#include "shade.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* The floor: one triangle in z = 0 far wider than the view; camera at
 * z = 5 looking down, 8 x 8 pixels, all on the floor. */
static const char *const floor_pbrt =
    "LookAt 0 0 5  0 0 0  0 1 0\n"
    "Camera \"perspective\" \"float fov\" 40\n"
    "Film \"rgb\" \"integer xresolution\" 8 \"integer yresolution\" 8\n"
    "WorldBegin\n"
    "Shape \"trianglemesh\" \"point3 P\" [-50 -50 0  50 -50 0  0 50 0] \"integer indices\" [0 1 2]\n";

/* The light declarations of each case. */
static const char *const k_point = "LightSource \"point\" \"point3 from\" [0 0 10]\n";
static const char *const k_point_below = "LightSource \"point\" \"point3 from\" [0 0 -10]\n";
static const char *const k_mesh =
    "AttributeBegin\nAreaLightSource \"diffuse\" \"rgb L\" [4 4 4]\n"
    "Shape \"trianglemesh\" \"point3 P\" [-1 -1 10  1 -1 10  0 1 10] \"integer indices\" [0 1 2]\nAttributeEnd\n";
static const char *const k_sphere =
    "AttributeBegin\nAreaLightSource \"diffuse\" \"rgb L\" [4 4 4]\nTranslate 0 0 10\n"
    "Shape \"sphere\" \"float radius\" 1\nAttributeEnd\n";
static const char *const k_disk = /* the disk's +z side faces away from the floor: emitters are two-sided */
    "AttributeBegin\nAreaLightSource \"diffuse\" \"rgb L\" [4 4 4]\nTranslate 0 0 10\n"
    "Shape \"disk\" \"float radius\" 2\nAttributeEnd\n";
static const char *const k_distant = "LightSource \"distant\" \"point3 from\" [0 0 1] \"point3 to\" [0 0 0]\n";
static const char *const k_distant_below = "LightSource \"distant\" \"point3 from\" [0 0 -1] \"point3 to\" [0 0 0]\n";
static const char *const k_infinite = "LightSource \"infinite\" \"rgb L\" [1 1 1]\n";
/* A roof at z = 7.5 between the floor and every light above it (and above
 * the camera, so the view still sees the floor). */
static const char *const k_roof =
    "Shape \"trianglemesh\" \"point3 P\" [-500 -500 7.5  500 -500 7.5  0 500 7.5] \"integer indices\" [0 1 2]\n";

static rt_scene *load(const char *name, const char *lights)
{
    char text[4096];
    snprintf(text, sizeof text, "%s%s", floor_pbrt, lights);
    check_write_file(check_path(name), text, strlen(text));
    rt_err e = {0};
    rt_scene *s = rt_scene_load(check_path(name), &e);
    CHECK(s != NULL, "%s: %s", name, e.msg);
    if (s) CHECK(rt_scene_check_lights(s, &e) == 0, "%s: checker: %s", name, e.msg);
    return s;
}

typedef struct run_out {
    rt_image *im;
    rt_run_stats st;
    int has_lights_region, has_cdf_region;
} run_out;

static int run(rt_scene *sc, const char *tracer, unsigned lights, int all, uint32_t samples, run_out *r)
{
    rt_render_opts o;
    rt_render_default_opts(&o);
    o.W = o.H = 8;
    o.lights = lights;
    o.lights_all = all;
    o.light_samples = samples;
    rt_err e = {0};
    rt_job j;
    memset(r, 0, sizeof *r);
    if (rt_job_setup_borrowed(&j, sc, NULL, tracer, &o, &e) < 0) {
        CHECK(0, "setup %s: %s", tracer, e.msg);
        return -1;
    }
    r->has_lights_region = rt_mm_find(&j.L, "lights") >= 0;
    r->has_cdf_region = rt_mm_find(&j.L, "lights.cdf") >= 0;
    j.check = 1; /* the scheduled tracers verify their invariants, each shadow ray against the single-ray test */
    r->im = rt_image_new(j.opt.W, j.opt.H, &e);
    if (!r->im || rt_job_run(&j, NULL, r->im, &r->st, &e) < 0) {
        CHECK(0, "run %s: %s", tracer, e.msg);
        rt_image_free(r->im);
        r->im = NULL;
        rt_job_free(&j);
        return -1;
    }
    rt_job_free(&j);
    return 0;
}

static int same_rgb(const rt_image *a, const rt_image *b)
{
    return a && b && a->W == b->W && a->H == b->H && !memcmp(a->rgb, b->rgb, sizeof(float) * 3 * (size_t)a->W * a->H);
}

/* The tracers that trace the file's lights (RT_TR_LIGHTS), reference first. */
static const char *const lit_tracers[] = {"recursive",        "packet",           "dynamic", "treelet",
                                          "stream-branching", "stream-multipass", "feedback"};

/* Every kind alone: hand-counted shadow rays, both tracers alike. */
static void test_counts(void)
{
    static const struct {
        const char *name, *decl;
        int kind;
        uint64_t rays; /* 64 hits x samples (16) or x 1; 0 when the light is below the floor */
        int region;    /* the light regions exist */
    } c[] = {
        {"point.pbrt", NULL, RT_LIGHT_POINT, 64, 0},
        {"pointbelow.pbrt", NULL, RT_LIGHT_POINT, 0, 0},
        {"mesh.pbrt", NULL, RT_LIGHT_MESH, 64 * 16, 1},
        {"sphere.pbrt", NULL, RT_LIGHT_SPHERE, 64 * 16, 1},
        {"disk.pbrt", NULL, RT_LIGHT_DISK, 64 * 16, 1},
        {"distant.pbrt", NULL, RT_LIGHT_DISTANT, 64, 1},
        {"distantbelow.pbrt", NULL, RT_LIGHT_DISTANT, 0, 1},
        {"infinite.pbrt", NULL, RT_LIGHT_INFINITE, 64 * 16, 1},
    };
    const char *decl[] = {k_point, k_point_below, k_mesh, k_sphere, k_disk, k_distant, k_distant_below, k_infinite};
    for (size_t i = 0; i < sizeof c / sizeof c[0]; i++) {
        rt_scene *s = load(c[i].name, decl[i]);
        if (!s) continue;
        CHECK(s->nlight == 1 && s->lights[0].kind == c[i].kind, "%s: %u lights, kind %d", c[i].name, s->nlight,
              s->nlight ? s->lights[0].kind : -1);
        run_out a, b;
        if (run(s, "recursive", 1, 0, 16, &a) == 0) {
            CHECK(a.st.rays_primary == 64, "%s: %llu primary rays", c[i].name, (unsigned long long)a.st.rays_primary);
            CHECK(a.st.rays_shadow == c[i].rays, "%s: recursive %llu shadow rays, by hand %llu", c[i].name,
                  (unsigned long long)a.st.rays_shadow, (unsigned long long)c[i].rays);
            CHECK(a.has_lights_region == c[i].region, "%s: lights region %d, expected %d", c[i].name,
                  a.has_lights_region, c[i].region);
            CHECK(a.has_cdf_region == (c[i].kind == RT_LIGHT_MESH), "%s: cdf region %d", c[i].name, a.has_cdf_region);
            for (size_t t = 1; t < sizeof lit_tracers / sizeof lit_tracers[0]; t++) {
                if (run(s, lit_tracers[t], 1, 0, 16, &b) < 0) continue;
                CHECK(b.st.rays_shadow == c[i].rays, "%s: %s %llu shadow rays, by hand %llu", c[i].name, lit_tracers[t],
                      (unsigned long long)b.st.rays_shadow, (unsigned long long)c[i].rays);
                CHECK(same_rgb(a.im, b.im), "%s: recursive and %s images differ", c[i].name, lit_tracers[t]);
                /* feedback keeps light records in shader constants (docs/memory-model.md) */
                CHECK(b.has_lights_region == (c[i].region && strcmp(lit_tracers[t], "feedback")), "%s: %s lights region %d",
                      c[i].name, lit_tracers[t], b.has_lights_region);
                rt_image_free(b.im);
            }
        }
        rt_image_free(a.im);
        /* samples 4: the sampled kinds scale, the others do not */
        if (run(s, "recursive", 1, 0, 4, &a) == 0) {
            uint64_t want = c[i].rays == 64 * 16 ? 64 * 4 : c[i].rays;
            CHECK(a.st.rays_shadow == want, "%s: 4 samples: %llu shadow rays, by hand %llu", c[i].name,
                  (unsigned long long)a.st.rays_shadow, (unsigned long long)want);
        }
        rt_image_free(a.im);
        rt_scene_free(s);
    }
}

/* The sampled points lie on their emitters. */
static void test_points_on_emitters(void)
{
    const char *decl[] = {k_mesh, k_sphere, k_disk};
    const char *name[] = {"pm.pbrt", "ps.pbrt", "pd.pbrt"};
    for (int c = 0; c < 3; c++) {
        rt_scene *s = load(name[c], decl[c]);
        if (!s) continue;
        rt_render_opts o;
        rt_render_default_opts(&o);
        o.lights = 1;
        o.light_samples = 64;
        const rt_light *L = &s->lights[0];
        int bad = 0, n = 0;
        for (int q = 0; q < 16; q++) {
            /* eye rays straight down onto floor points */
            rt_vec3 fp = rt_v3(-1.5f + 0.2f * (float)q, 0.7f - 0.1f * (float)q, 0.0f);
            rt_ray eye;
            rt_ray_init(&eye, rt_v3(fp.x, fp.y, 5.0f), rt_v3(0, 0, -1));
            rt_hit h;
            h.tri = 0;
            /* barycentrics of fp in the floor triangle */
            const rt_vec3 *P = s->tri[0].p;
            float det = (P[1].x - P[0].x) * (P[2].y - P[0].y) - (P[2].x - P[0].x) * (P[1].y - P[0].y);
            h.u = ((fp.x - P[0].x) * (P[2].y - P[0].y) - (P[2].x - P[0].x) * (fp.y - P[0].y)) / det;
            h.v = ((P[1].x - P[0].x) * (fp.y - P[0].y) - (fp.x - P[0].x) * (P[1].y - P[0].y)) / det;
            h.t = 5.0f;
            for (uint32_t k = 0; k < 64; k++) {
                rt_ray sr;
                float w;
                uint32_t tri;
                if (!rt_shade_sample_ray(s, &o, &eye, &h, 0, k, &sr, &w, &tri)) {
                    bad++;
                    continue;
                }
                n++;
                rt_vec3 e = rt_add(sr.o, sr.d); /* the segment's end: the sampled point */
                if (!(w > 0 && w <= 1.0f && sr.tmax < 1.0f)) bad++;
                if (L->kind == RT_LIGHT_MESH) {
                    /* on z = 10, inside the emitter triangle (-1,-1) (1,-1) (0,1) */
                    int in = fabsf(e.z - 10.0f) < 1e-4f && e.y >= -1.0f - 1e-4f && e.y <= 1.0f + 1e-4f &&
                             fabsf(e.x) <= (1.0f - e.y) * 0.5f + 1e-4f;
                    if (!in || tri != 1) bad++;
                } else if (L->kind == RT_LIGHT_SPHERE) {
                    /* on the sphere, on the cap the floor point sees: (e - c).(p - c) >= r^2 */
                    rt_vec3 ec = rt_sub(e, L->p), pc = rt_sub(fp, L->p);
                    if (!(fabsf(rt_len(ec) - 1.0f) < 1e-4f) || !(rt_dot(ec, pc) >= 1.0f - 1e-3f)) bad++;
                } else {
                    /* in the plane z = 10, within radius 2 of the centre */
                    if (!(fabsf(e.z - 10.0f) < 1e-4f) || !(e.x * e.x + e.y * e.y <= 4.0f + 1e-3f)) bad++;
                }
            }
        }
        CHECK(bad == 0 && n == 16 * 64, "%s: %d of %d samples off their emitter", name[c], bad, n);
        rt_scene_free(s);
    }
}

/* The distributions against what they must be: a mesh light of two
 * triangles with areas 1 : 3 gets a quarter of the samples on the small
 * one; the sky's cosine-distributed directions fall on either side of a
 * vertical plane equally often and have E[cos] = 2/3 (pdf cos/pi); a
 * disk's points fill its inner half-radius disk a quarter of the time.
 * 16 floor points x 256 samples = 4096 draws: the bounds are > 5 standard
 * deviations wide, and the draws are fixed (a hash), so the test is exact
 * on every machine. */
static void test_distributions(void)
{
    static const char *const two =
        "AttributeBegin\nAreaLightSource \"diffuse\"\n"
        "Shape \"trianglemesh\" \"point3 P\" [0 0 10  1 0 10  0 1 10   2 0 10  5 0 10  2 1 10] "
        "\"integer indices\" [0 1 2  3 4 5]\nAttributeEnd\n";
    const char *decl[] = {two, k_infinite, k_disk};
    const char *name[] = {"dm.pbrt", "di.pbrt", "dd.pbrt"};
    for (int c = 0; c < 3; c++) {
        rt_scene *s = load(name[c], decl[c]);
        if (!s) continue;
        rt_render_opts o;
        rt_render_default_opts(&o);
        o.lights = 1;
        o.light_samples = 256;
        uint64_t n = 0, small = 0, west = 0, inner = 0;
        double cosum = 0;
        for (int q = 0; q < 16; q++) {
            rt_ray eye;
            rt_ray_init(&eye, rt_v3(0.1f * (float)q - 0.7f, 0.05f * (float)q, 5.0f), rt_v3(0, 0, -1));
            rt_hit h = {5.0f, 0, 0.3f + 0.01f * (float)q, 0.2f + 0.005f * (float)q};
            for (uint32_t k = 0; k < 256; k++) {
                rt_ray sr;
                float w;
                uint32_t tri;
                if (!rt_shade_sample_ray(s, &o, &eye, &h, 0, k, &sr, &w, &tri)) continue;
                n++;
                rt_vec3 d = rt_norm(sr.d), end = rt_add(sr.o, sr.d);
                small += tri == 1;
                west += d.x < 0;
                cosum += d.z; /* the floor's normal is +z */
                inner += (end.x * end.x + end.y * end.y) < 1.0f; /* the disk: radius 2 at the origin */
            }
        }
        CHECK(n == 16 * 256, "%s: %llu of 4096 samples cast", name[c], (unsigned long long)n);
        if (c == 0) CHECK(small > 1024 - 150 && small < 1024 + 150, "mesh: %llu of 4096 on the 1/4-area triangle",
                          (unsigned long long)small);
        if (c == 1) {
            CHECK(west > 2048 - 170 && west < 2048 + 170, "sky: %llu of 4096 toward -x", (unsigned long long)west);
            CHECK(fabs(cosum / (double)n - 2.0 / 3.0) < 0.02, "sky: mean cos %.4f, cosine sampling gives 2/3",
                  cosum / (double)n);
        }
        if (c == 2) CHECK(inner > 1024 - 150 && inner < 1024 + 150, "disk: %llu of 4096 within half the radius",
                          (unsigned long long)inner);
        rt_scene_free(s);
    }
}

/* Shading values: unoccluded sky = ambient + power; a roof between floor
 * and light leaves the ambient term alone, with the rays still cast. */
static void test_shading(void)
{
    rt_scene *s = load("sky.pbrt", k_infinite);
    run_out a;
    if (s && run(s, "recursive", 1, 0, 16, &a) == 0) {
        const float *alb = s->shade[0].rgb;
        int bad = 0;
        for (int p = 0; p < 64; p++)
            for (int k = 0; k < 3; k++) {
                float want = alb[k] * s->ambient + alb[k] * ((16.0f / 16.0f) * (s->light_power * 1.0f));
                bad += a.im->rgb[3 * p + k] != want;
            }
        CHECK(bad == 0, "open sky: %d channels differ from albedo x (ambient + power)", bad);
        rt_image_free(a.im);
    }
    rt_scene_free(s);
    char decl[1024];
    const char *kinds[] = {k_mesh, k_sphere, k_disk, k_distant, k_infinite, k_point};
    const uint64_t rays[] = {64 * 16, 64 * 16, 64 * 16, 64, 64 * 16, 64};
    for (int c = 0; c < 6; c++) {
        snprintf(decl, sizeof decl, "%s%s", k_roof, kinds[c]);
        s = load("roof.pbrt", decl);
        if (!s) continue;
        if (run(s, "recursive", 1, 0, 16, &a) == 0) {
            const float *alb = s->shade[0].rgb;
            int bad = 0;
            for (int p = 0; p < 64; p++)
                for (int k = 0; k < 3; k++) bad += a.im->rgb[3 * p + k] != alb[k] * s->ambient;
            CHECK(bad == 0, "roof, light %d: %d channels lit through the roof", c, bad);
            CHECK(a.st.rays_shadow == rays[c], "roof, light %d: %llu shadow rays, by hand %llu", c,
                  (unsigned long long)a.st.rays_shadow, (unsigned long long)rays[c]);
            rt_image_free(a.im);
        }
        rt_scene_free(s);
    }
}

/* Escaping primary rays are environment hits: a floor on the quadrant
 * x, y > 0 only fills 4 x 4 of the 8 x 8 pixels (pixel centres never on
 * an axis), so 48 rays escape and 16 hits x 4 samples go to the sky. */
static void test_env_hits(void)
{
    static const char *const quad =
        "LookAt 0 0 5  0 0 0  0 1 0\nCamera \"perspective\" \"float fov\" 40\n"
        "Film \"rgb\" \"integer xresolution\" 8 \"integer yresolution\" 8\nWorldBegin\n"
        "LightSource \"infinite\"\n"
        "Shape \"trianglemesh\" \"point3 P\" [0 0 0  50 0 0  0 50 0] \"integer indices\" [0 1 2]\n";
    check_write_file(check_path("quad.pbrt"), quad, strlen(quad));
    rt_err e = {0};
    rt_scene *s = rt_scene_load(check_path("quad.pbrt"), &e);
    CHECK(s != NULL, "quad.pbrt: %s", e.msg);
    if (!s) return;
    run_out a, b;
    if (run(s, "recursive", 1, 0, 4, &a) == 0) {
        CHECK(a.st.rays_shadow == 16 * 4 && strstr(a.st.extra, "env_hits=48"), "sky: %llu shadow rays, '%s'",
              (unsigned long long)a.st.rays_shadow, a.st.extra);
        for (size_t t = 1; t < sizeof lit_tracers / sizeof lit_tracers[0]; t++)
            if (run(s, lit_tracers[t], 1, 0, 4, &b) == 0) {
                CHECK(b.st.rays_shadow == 16 * 4 && strstr(b.st.extra, "env_hits=48") && same_rgb(a.im, b.im),
                      "%s sky: %llu shadow rays, '%s'", lit_tracers[t], (unsigned long long)b.st.rays_shadow, b.st.extra);
                rt_image_free(b.im);
            }
    }
    rt_image_free(a.im);
    /* the point model counts none */
    if (run(s, "recursive", 1, 0, 0, &a) == 0) CHECK(!strstr(a.st.extra, "env_hits"), "point model: '%s'", a.st.extra);
    rt_image_free(a.im);
    rt_scene_free(s);
}

/* ---- the memory model: light records read once per sample ---------------- */

typedef struct ltally {
    const rt_layout *L;
    int rl, rc, rv;          /* lights, lights.cdf, tri.verts (-1: absent) */
    uint64_t lights, cdf, verts, outside, bad;
    char why[200];
} ltally;

static int ltally_put(rt_sink *sk, const rt_access *a, size_t n)
{
    ltally *t = sk->ctx;
    for (size_t i = 0; i < n; i++) {
        int r = -1;
        for (int k = 0; k < t->L->n; k++)
            if (a[i].addr >= t->L->r[k].base && a[i].addr < t->L->r[k].base + (uint64_t)t->L->r[k].recsize * t->L->r[k].count)
                r = k;
        if (r < 0) {
            t->outside++;
            continue;
        }
        if (r != t->rl && r != t->rc) {
            if (r == t->rv && !a[i].write) t->verts++;
            continue;
        }
        const uint64_t off = a[i].addr - t->L->r[r].base;
        if (a[i].write || a[i].cls != RT_CLS_SHADE || off % t->L->r[r].recsize || a[i].size != t->L->r[r].recsize) {
            if (!t->bad++)
                snprintf(t->why, sizeof t->why, "%s access: write %u class %u offset %llu size %u", t->L->r[r].name,
                         a[i].write, a[i].cls, (unsigned long long)off, a[i].size);
            continue;
        }
        if (r == t->rl) t->lights++;
        else t->cdf++;
    }
    return 0;
}

/* Every sample reads its light's 64-byte record (a mesh light also its
 * area-table entry and the sampled triangle), in every tracer; a point-lit
 * run has neither region. */
static void test_memory_model(void)
{
    const char *decl[] = {k_mesh, k_sphere, k_distant, k_infinite, k_point};
    const char *name[] = {"mm.pbrt", "ms.pbrt", "md.pbrt", "mi.pbrt", "mp.pbrt"};
    const uint64_t rays[] = {64 * 16, 64 * 16, 64, 64 * 16, 64};
    for (int c = 0; c < 5; c++) {
        rt_scene *s = load(name[c], decl[c]);
        if (!s) continue;
        const int mesh = s->lights[0].kind == RT_LIGHT_MESH, point = s->lights[0].kind == RT_LIGHT_POINT;
        for (size_t t = 0; t < sizeof lit_tracers / sizeof lit_tracers[0]; t++) {
            if (!strcmp(lit_tracers[t], "feedback")) continue; /* its light records are shader constants */
            rt_render_opts o;
            rt_render_default_opts(&o);
            o.W = o.H = 8;
            o.lights = 1;
            o.light_samples = 16;
            rt_err e = {0};
            rt_job j;
            if (rt_job_setup_borrowed(&j, s, NULL, lit_tracers[t], &o, &e) < 0) {
                CHECK(0, "%s %s: %s", name[c], lit_tracers[t], e.msg);
                continue;
            }
            ltally T = {&j.L, rt_mm_find(&j.L, "lights"), rt_mm_find(&j.L, "lights.cdf"), rt_mm_find(&j.L, "tri.verts"),
                        0, 0, 0, 0, 0, ""};
            int rl = T.rl;
            CHECK((T.rl >= 0) == !point && (T.rc >= 0) == mesh, "%s %s: regions lights %d, lights.cdf %d", name[c],
                  lit_tracers[t], T.rl, T.rc);
            if (T.rl >= 0)
                CHECK(j.L.r[T.rl].recsize == RT_LIGHT_RECSIZE && j.L.r[T.rl].count == s->nlight &&
                          j.L.r[T.rl].cls == RT_CLS_SHADE,
                      "%s: lights region %u x %llu", name[c], j.L.r[T.rl].recsize, (unsigned long long)j.L.r[T.rl].count);
            if (T.rc >= 0)
                CHECK(j.L.r[T.rc].recsize == 4 && j.L.r[T.rc].count == s->lights[0].count, "%s: lights.cdf region",
                      name[c]);
            rt_sink sink = {ltally_put, &T};
            rt_run_stats st;
            rt_image *im = rt_image_new(8, 8, &e);
            j.check = 1;
            if (!im || rt_job_run(&j, &sink, im, &st, &e) < 0) CHECK(0, "%s %s: run: %s", name[c], lit_tracers[t], e.msg);
            CHECK(T.outside == 0 && T.bad == 0, "%s %s: %llu accesses outside the regions, %llu bad (%s)", name[c],
                  lit_tracers[t], (unsigned long long)T.outside, (unsigned long long)T.bad, T.why);
            CHECK(st.rays_shadow == rays[c], "%s %s: %llu shadow rays", name[c], lit_tracers[t],
                  (unsigned long long)st.rays_shadow);
            CHECK(T.lights == (rl >= 0 ? rays[c] : 0) && T.cdf == (mesh ? rays[c] : 0),
                  "%s %s: %llu light-record and %llu area-table reads for %llu samples", name[c], lit_tracers[t],
                  (unsigned long long)T.lights, (unsigned long long)T.cdf, (unsigned long long)rays[c]);
            /* a mesh light's samples read their triangles on top of the traversal's tests */
            if (mesh && T.rv >= 0) CHECK(T.verts >= rays[c], "%s %s: %llu triangle reads", name[c], lit_tracers[t],
                                         (unsigned long long)T.verts);
            rt_image_free(im);
            rt_job_free(&j);
        }
        rt_scene_free(s);
    }
}

/* Several lights: all of them, selection by index, more than three. */
static void test_selection(void)
{
    char decl[4096];
    snprintf(decl, sizeof decl, "%s%s%s%s%s%s", k_point, k_mesh, k_distant, k_infinite, k_point_below, k_sphere);
    rt_scene *s = load("all.pbrt", decl);
    if (!s) return;
    /* in file order: point, mesh, distant, infinite, point below, sphere */
    CHECK(s->nlight == 6, "6 lights, got %u", s->nlight);
    run_out a, b;
    /* all: 64 (point) + 64 (distant) + 1024 (sky) + 0 (below) + 1024 (mesh) + 1024 (sphere) */
    if (run(s, "recursive", 7, 1, 16, &a) == 0) {
        CHECK(a.st.rays_shadow == 64 + 64 + 1024 + 0 + 1024 + 1024, "all: %llu shadow rays",
              (unsigned long long)a.st.rays_shadow);
        for (size_t t = 1; t < sizeof lit_tracers / sizeof lit_tracers[0]; t++)
            if (run(s, lit_tracers[t], 7, 1, 16, &b) == 0) {
                CHECK(b.st.rays_shadow == a.st.rays_shadow && same_rgb(a.im, b.im), "all: %s differs", lit_tracers[t]);
                rt_image_free(b.im);
            }
        rt_image_free(a.im);
    }
    unsigned m;
    CHECK(rt_render_parse_lights("1,5", &m) == 0 && m == (1u << 1 | 1u << 5), "parse 1,5: %u", m);
    CHECK(rt_render_parse_lights("31", &m) == 0 && m == 1u << 31, "parse 31");
    CHECK(rt_render_parse_lights("32", &m) < 0 && rt_render_parse_lights("05", &m) < 0, "parse bad indices");
    if (run(s, "recursive", (1u << 1) | (1u << 5), 0, 16, &a) == 0) {
        CHECK(a.st.rays_shadow == 1024 + 1024, "lights 1,5 (mesh, sphere): %llu shadow rays", (unsigned long long)a.st.rays_shadow);
        rt_image_free(a.im);
    }
    /* light 6 does not exist: refused, naming it */
    rt_render_opts o;
    rt_render_default_opts(&o);
    o.W = o.H = 8;
    o.lights = 1u << 6;
    o.light_samples = 4;
    rt_err e = {0};
    rt_job j;
    CHECK(rt_job_setup_borrowed(&j, s, NULL, "recursive", &o, &e) < 0 && strstr(e.msg, "light 6 does not exist"),
          "light 6: %s", e.msg);
    /* secondary modes follow the point lights only: refused */
    o.lights = 1;
    o.mode = RT_MODE_WHITTED;
    CHECK(rt_job_setup_borrowed(&j, s, NULL, "recursive", &o, &e) < 0 && strstr(e.msg, "--light-samples"),
          "whitted: %s", e.msg);
    /* the point model of the same file: lights 0..2 only */
    o.mode = RT_MODE_DEFAULT;
    o.light_samples = 0;
    o.lights = 1u << 3;
    CHECK(rt_job_setup_borrowed(&j, s, NULL, "recursive", &o, &e) < 0 && strstr(e.msg, "light 3 does not exist"),
          "point model light 3: %s", e.msg);
    rt_scene_free(s);
}

/* The point model is untouched: a built-in scene (no authored lights)
 * renders the same with and without --light-samples, and a file of point
 * lights alone renders the same under both models. */
static void test_point_model(void)
{
    rt_err e = {0};
    rt_scene *s = rt_scene_load("cornell", &e);
    CHECK(s != NULL && s->nlight == 0, "cornell: %s", e.msg);
    if (s) {
        const char *tr[] = {"recursive", "packet"};
        for (int t = 0; t < 2; t++) {
            run_out a, b;
            if (run(s, tr[t], 7, 1, 0, &a) == 0 && run(s, tr[t], 7, 1, 16, &b) == 0) {
                CHECK(same_rgb(a.im, b.im) && a.st.rays_shadow == b.st.rays_shadow && !b.has_lights_region,
                      "cornell %s: --light-samples changed the point model", tr[t]);
            }
            rt_image_free(a.im);
            rt_image_free(b.im);
        }
        rt_scene_free(s);
    }
    char decl[512];
    snprintf(decl, sizeof decl, "%s%s", k_point, "LightSource \"point\" \"point3 from\" [3 1 4]\n");
    s = load("points.pbrt", decl);
    if (s) {
        run_out a, b;
        if (run(s, "recursive", 3, 0, 0, &a) == 0 && run(s, "recursive", 3, 0, 16, &b) == 0)
            CHECK(same_rgb(a.im, b.im) && a.st.rays_shadow == 128 && b.st.rays_shadow == 128 && !b.has_lights_region,
                  "point lights: the two models differ (%llu, %llu rays)", (unsigned long long)a.st.rays_shadow,
                  (unsigned long long)b.st.rays_shadow);
        /* at most three point lights: every tracer runs them (the point lights hold them) */
        const char *all_tracers[] = {"packet", "dynamic", "treelet", "stream-branching", "stream-multipass", "feedback"};
        for (int t = 0; t < 6; t++) {
            run_out c;
            if (run(s, all_tracers[t], 3, 0, 16, &c) == 0)
                CHECK(same_rgb(a.im, c.im), "point lights, --light-samples: %s differs", all_tracers[t]);
            rt_image_free(c.im);
            /* "all" is the file's two lights, not the point model's third (at the camera) */
            if (run(s, all_tracers[t], 7, 1, 16, &c) == 0)
                CHECK(same_rgb(a.im, c.im) && c.st.rays_shadow == 128, "point lights, all: %s differs (%llu rays)",
                      all_tracers[t], (unsigned long long)c.st.rays_shadow);
            rt_image_free(c.im);
        }
        rt_image_free(a.im);
        rt_image_free(b.im);
        rt_scene_free(s);
    }
}

/* The loader's light handlers: bad input is one error naming file and
 * line; what is approximated is a warning; transforms apply. */
static void test_loader(void)
{
    char text[4096];
    rt_err e = {0};
    snprintf(text, sizeof text, "%s%s", floor_pbrt, "LightSource \"distant\" \"point3 from\" [1 2 3] \"point3 to\" [1 2 3]\n");
    check_write_file(check_path("same.pbrt"), text, strlen(text));
    rt_scene *s = rt_scene_load(check_path("same.pbrt"), &e);
    CHECK(!s && strstr(e.msg, "same.pbrt:6") && strstr(e.msg, "coincide"), "distant from = to: %s", e.msg);
    rt_scene_free(s);
    snprintf(text, sizeof text, "%s%s", floor_pbrt, "LightSource \"distant\" \"point3 from\" [0 0]\n");
    check_write_file(check_path("short.pbrt"), text, strlen(text));
    s = rt_scene_load(check_path("short.pbrt"), &e);
    CHECK(!s && strstr(e.msg, "short.pbrt:6"), "distant from with 2 values: %s", e.msg);
    rt_scene_free(s);
    /* a light inside an object, an infinite light's image, a distant light under a transform */
    snprintf(text, sizeof text, "%s%s", floor_pbrt,
             "ObjectBegin \"lamp\"\nAreaLightSource \"diffuse\"\n"
             "Shape \"trianglemesh\" \"point3 P\" [0 0 9  1 0 9  0 1 9] \"integer indices\" [0 1 2]\nObjectEnd\n"
             "ObjectInstance \"lamp\"\n"
             "LightSource \"infinite\" \"string filename\" \"sky.exr\"\n"
             "AttributeBegin\nRotate 90 1 0 0\nLightSource \"distant\" \"point3 from\" [0 0 1] \"point3 to\" [0 0 0]\n"
             "AttributeEnd\n"
             "AttributeBegin\nAreaLightSource \"diffuse\"\nTranslate 1 2 8\nScale 3 3 3\n"
             "Shape \"disk\" \"float radius\" 0.5 \"float height\" 1\nAttributeEnd\n");
    check_write_file(check_path("mix.pbrt"), text, strlen(text));
    s = rt_scene_load(check_path("mix.pbrt"), &e);
    CHECK(s != NULL, "mix.pbrt: %s", e.msg);
    if (!s) return;
    CHECK(strstr(s->warning, "area light inside an object") && strstr(s->warning, "image ignored"),
          "warnings: %s", s->warning);
    CHECK(s->nlight == 3 && s->lights[0].kind == RT_LIGHT_INFINITE && s->lights[1].kind == RT_LIGHT_DISTANT &&
              s->lights[2].kind == RT_LIGHT_DISK,
          "3 lights (infinite, distant, disk): %u", s->nlight);
    if (s->nlight == 3) {
        /* Rotate 90 about x takes +z to -y: the light lies toward -y */
        const rt_light *d = &s->lights[1], *k = &s->lights[2];
        CHECK(fabsf(d->d.x) < 1e-6f && fabsf(d->d.y + 1.0f) < 1e-6f && fabsf(d->d.z) < 1e-6f, "distant toward (%g %g %g)",
              (double)d->d.x, (double)d->d.y, (double)d->d.z);
        /* the disk: centre (1, 2, 8 + 3 x 1), radius 3 x 0.5, normal +z */
        CHECK(fabsf(k->p.x - 1) < 1e-5f && fabsf(k->p.y - 2) < 1e-5f && fabsf(k->p.z - 11) < 1e-5f &&
                  fabsf(k->r - 1.5f) < 1e-5f && fabsf(k->d.z - 1) < 1e-6f,
              "disk at (%g %g %g) r %g n.z %g", (double)k->p.x, (double)k->p.y, (double)k->p.z, (double)k->r,
              (double)k->d.z);
    }
    rt_scene_free(s);
    /* instances before a lamp: its triangles move up past theirs, and the light follows */
    snprintf(text, sizeof text, "%s%s", floor_pbrt,
             "ObjectBegin \"box\"\nShape \"trianglemesh\" \"point3 P\" [0 0 1  1 0 1  0 1 1  0 0 2  1 0 2  0 1 2] "
             "\"integer indices\" [0 1 2  3 4 5  0 1 5  1 2 3]\nObjectEnd\n"
             "ObjectInstance \"box\"\nTranslate 3 0 0\nObjectInstance \"box\"\n"
             "AttributeBegin\nAreaLightSource \"diffuse\"\n"
             "Shape \"trianglemesh\" \"point3 P\" [-1 -1 9  1 -1 9  0 1 9] \"integer indices\" [0 1 2]\nAttributeEnd\n"
             "ObjectInstance \"box\"\n");
    check_write_file(check_path("inst.pbrt"), text, strlen(text));
    s = rt_scene_load(check_path("inst.pbrt"), &e);
    CHECK(s != NULL, "inst.pbrt: %s", e.msg);
    if (!s) return;
    /* (4-triangle objects are instanced at the end of the load) floor 0, two instances 1..8, the lamp 9,
     * the last instance 10..13 */
    CHECK(s->ntri == 14 && s->nlight == 1 && s->lights[0].kind == RT_LIGHT_MESH && s->lights[0].first == 9 &&
              s->lights[0].count == 1,
          "%u triangles, light first %u count %u", s->ntri, s->nlight ? s->lights[0].first : 0,
          s->nlight ? s->lights[0].count : 0);
    if (s->ntri == 14) CHECK(s->tri[9].p[0].z == 9.0f && s->tri[9].p[2].y == 1.0f, "triangle 9 is not the lamp");
    CHECK(rt_scene_check_lights(s, &e) == 0, "checker: %s", e.msg);
    rt_scene_free(s);
}

/* The checker and rt_scene_add_light refuse broken records. */
static void test_checker(void)
{
    rt_err e = {0};
    rt_scene *s = load("chk.pbrt", k_mesh);
    if (!s) return;
    rt_light l;
    memset(&l, 0, sizeof l);
    snprintf(l.at, sizeof l.at, "x.pbrt:3");
    l.kind = RT_LIGHT_DISK;
    l.d = rt_v3(0, 0, 1);
    l.r = 0;
    l.scale = 1;
    CHECK(rt_scene_add_light(s, &l, &e) < 0 && strstr(e.msg, "x.pbrt:3") && strstr(e.msg, "radius"), "disk r 0: %s",
          e.msg);
    l.r = 1;
    l.d = rt_v3(0, 0, 2);
    CHECK(rt_scene_add_light(s, &l, &e) < 0 && strstr(e.msg, "unit"), "disk normal length 2: %s", e.msg);
    l.kind = RT_LIGHT_MESH;
    l.first = 1;
    l.count = 5;
    CHECK(rt_scene_add_light(s, &l, &e) < 0 && strstr(e.msg, "range"), "mesh out of range: %s", e.msg);
    CHECK(rt_scene_check_lights(s, &e) == 0, "still valid: %s", e.msg);
    /* the area table of the loaded mesh light: one triangle, ends in 1 */
    CHECK(s->lights[0].kind == RT_LIGHT_MESH && s->lights[0].count == 1 && s->lights[0].cdf[0] == 1.0f, "mesh cdf");
    s->lights[0].cdf[0] = 0.5f;
    CHECK(rt_scene_check_lights(s, &e) < 0 && strstr(e.msg, "invariant 4"), "broken cdf: %s", e.msg);
    s->lights[0].cdf[0] = 1.0f;
    s->lights[0].kind = 17;
    CHECK(rt_scene_check_lights(s, &e) < 0 && strstr(e.msg, "invariant 2"), "bad kind: %s", e.msg);
    s->lights[0].kind = RT_LIGHT_MESH;
    rt_scene_free(s);
}

int main(void)
{
    if (!check_tmpdir("test_lights")) {
        perror("mkdtemp");
        return 1;
    }
    test_counts();
    test_points_on_emitters();
    test_distributions();
    test_shading();
    test_env_hits();
    test_memory_model();
    test_selection();
    test_point_model();
    test_checker();
    test_loader();
    if (check_rm_tree(check_dir) != 0) fprintf(stderr, "warning: could not remove %s\n", check_dir);
    if (failures) fprintf(stderr, "%d failure(s)\n", failures);
    else printf("test_lights: all passed\n");
    return failures ? 1 : 0;
}
