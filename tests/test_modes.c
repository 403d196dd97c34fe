/* test_modes.c -- the render modes: option checks and run identity (a
 * default-mode run keeps its parameter string, so existing run keys and
 * traces stay as they were; other modes add theirs), the front end's usage
 * errors, the order-independent pixel sum, and the robustness of secondary
 * rays: a mirror box at scales 1e-3, 1 and 1e3 renders the same image in
 * every tracer with no ray re-hitting its own triangle, and hard cases
 * followed ray by ray with brute-force intersection (grazing reflection,
 * leaving glass at the critical angle, a sphere of one dielectric inside a
 * sphere of another, reflection off the edge two triangles share). */
#include "check.h"
#include "check_scene.h"
#include "run.h"
#include "shade.h"

#include <inttypes.h>
#include <sys/wait.h>

/* ---- options and identity ------------------------------------------------ */

static void params(void)
{
    static const char *const tr[] = {"recursive", "packet", "dynamic"};
    char a[256], b[256];
    for (int t = 0; t < 3; t++)
        for (unsigned lights = 0; lights < 8; lights += 7) {
            rt_render_opts o;
            rt_render_default_opts(&o);
            o.lights = lights;
            rt_job_params(tr[t], &o, "sim=all-sizes", a, sizeof a);
            o.mode = lights ? RT_MODE_SHADOW : RT_MODE_RAYCAST; /* the default, spelled out */
            o.depth = 9, o.spp = 3, o.bounces = 7;              /* unused by these modes */
            rt_job_params(tr[t], &o, "sim=all-sizes", b, sizeof b);
            CHECK(!strcmp(a, b), "%s: default mode changes the run key: '%s' vs '%s'", tr[t], a, b);
            o.mode = lights ? RT_MODE_RAYCAST : RT_MODE_SHADOW;
            rt_job_params(tr[t], &o, NULL, b, sizeof b);
            CHECK(strstr(b, lights ? "mode=raycast" : "mode=shadow") != NULL, "%s: '%s'", tr[t], b);
            o.mode = RT_MODE_WHITTED;
            rt_job_params(tr[t], &o, "x=1", b, sizeof b);
            CHECK(strstr(b, "mode=whitted depth=9 x=1") != NULL, "%s: '%s'", tr[t], b);
            o.mode = RT_MODE_PATH;
            o.subsample = 4;
            rt_job_params(tr[t], &o, NULL, b, sizeof b);
            CHECK(strstr(b, "mode=path spp=3 bounces=7 subsample=4 tile=8") != NULL, "%s: '%s'", tr[t], b);
        }
    rt_render_opts o;
    rt_render_default_opts(&o);
    rt_job_params("recursive", &o, NULL, a, sizeof a);
    CHECK(!strcmp(a, ""), "recursive default params '%s'", a);
    rt_job_params("dynamic", &o, NULL, a, sizeof a);
    CHECK(!strcmp(a, "qorder=fullest threads=4"), "dynamic default params '%s'", a);
    CHECK(o.mode == RT_MODE_DEFAULT && o.depth == 5 && o.spp == 1 && o.bounces == 4, "defaults");
    CHECK(rt_render_mode(&o) == RT_MODE_RAYCAST, "no lights: raycast");
    o.lights = 1;
    CHECK(rt_render_mode(&o) == RT_MODE_SHADOW, "lights: shadow");
    CHECK(rt_render_mode_from_name("whitted") == RT_MODE_WHITTED && rt_render_mode_from_name("Path") < 0, "names");

    struct {
        int depth, spp, bounces;
        const char *opt;
    } bad[] = {{0, 1, 4, "--depth"}, {65, 1, 4, "--depth"}, {5, 0, 4, "--spp"}, {5, 1, -1, "--bounces"}};
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        rt_err e = {0};
        rt_job j;
        rt_render_default_opts(&o);
        o.W = o.H = 8;
        o.mode = RT_MODE_WHITTED;
        o.depth = bad[i].depth, o.spp = bad[i].spp, o.bounces = bad[i].bounces;
        CHECK(rt_render_check_mode(&o, &e) < 0 && strstr(e.msg, bad[i].opt), "%s accepted or unnamed: %s", bad[i].opt,
              e.msg);
        e.msg[0] = 0;
        CHECK(rt_job_setup(&j, "cornell", "recursive", &o, &e) < 0 && strstr(e.msg, bad[i].opt), "job took %s: %s",
              bad[i].opt, e.msg);
    }
}

/* The front end: bad values are usage errors (exit 2) naming the option. */
static void cli(void)
{
    const char *bin = getenv("RT_BIN");
    CHECK(bin != NULL, "RT_BIN not set (run through make check)");
    if (!bin) return;
    static const struct {
        const char *args, *opt;
    } bad[] = {
        {"render cornell -o /dev/null --depth 0", "--depth"},  {"render cornell -o /dev/null --depth 65", "--depth"},
        {"render cornell -o /dev/null --spp 0", "--spp"},      {"render cornell -o /dev/null --bounces -1", "--bounces"},
        {"render cornell -o /dev/null --mode mirror", "--mode"}, {"trace cornell -o /dev/null --mode x", "--mode"},
        {"bench --depth 0", "--depth"},
    };
    char args[512], msg[512];
    const char *dir = check_tmpdir("modes");
    CHECK(dir != NULL, "no temporary directory");
    if (!dir) return;
    char err[600], out[600];
    snprintf(err, sizeof err, "%s/err", dir);
    snprintf(out, sizeof out, "%s/out", dir);
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        /* the fixed argument string split at spaces: no shell involved */
        char *argv[32];
        int argc = 0;
        snprintf(args, sizeof args, "%s", bad[i].args);
        argv[argc++] = (char *)bin;
        for (char *t = strtok(args, " "); t && argc < 31; t = strtok(NULL, " ")) argv[argc++] = t;
        argv[argc] = NULL;
        int rc = check_run(argv, NULL, err);
        CHECK(rc >= 0 && WIFEXITED(rc) && WEXITSTATUS(rc) == 2, "'%s' exited %d, not 2", bad[i].args, WEXITSTATUS(rc));
        FILE *f = fopen(err, "r");
        size_t n = f ? fread(msg, 1, sizeof msg - 1, f) : 0;
        if (f) fclose(f);
        msg[n] = 0;
        CHECK(strstr(msg, bad[i].opt) != NULL, "'%s': message does not name %s: %s", bad[i].args, bad[i].opt, msg);
    }
    /* a secondary mode renders, and its statistics report no self-hits */
    char exr[600];
    snprintf(exr, sizeof exr, "%s/w.exr", dir);
    char *wargv[] = {(char *)bin, "render", "cornell", "-W", "16", "-H", "16", "--lights", "all", "--mode", "whitted",
                     "-t", "dynamic", "-o", exr, "--json", NULL};
    int rc = check_run(wargv, out, out);
    CHECK(rc >= 0 && WIFEXITED(rc) && WEXITSTATUS(rc) == 0, "whitted render exited %d", WEXITSTATUS(rc));
    check_rmdir();
}

/* The fixed-point sum does not depend on the order of additions. */
static void accumulator(void)
{
    float v[64][3];
    rnd_seed(7);
    for (int i = 0; i < 64; i++)
        for (int k = 0; k < 3; k++) v[i][k] = (float)(unif() * 10.0 - 2.0) * (i % 5 ? 1.0f : 1e-6f);
    rt_acc a = {{0, 0, 0}}, b = {{0, 0, 0}};
    double ref[3] = {0, 0, 0};
    for (int i = 0; i < 64; i++) {
        rt_acc_add(&a, v[i]);
        rt_acc_add(&b, v[63 - i]);
        for (int k = 0; k < 3; k++) ref[k] += v[i][k];
    }
    CHECK(!memcmp(&a, &b, sizeof a), "sum depends on order");
    for (int k = 0; k < 3; k++)
        CHECK(fabs((double)a.v[k] / 4294967296.0 - ref[k]) <= 64 * 0x1p-33, "channel %d: %.12g vs %.12g", k,
              (double)a.v[k] / 4294967296.0, ref[k]);
}

/* ---- scenes by hand -------------------------------------------------------- */

/* A closed box [-s, s]^3 of mirrors (ks 0.7, albedo 0.3 tinted per face)
 * seen from inside, lights inside; everything scales with s. */
static rt_scene *mirror_box(float s)
{
    rt_err e = {0};
    rt_scene *sc = rt_scene_new(12, &e);
    int m = add_mat(sc, 0.7f, 0.0f, 1.0f);
    rt_vec3 P[8];
    for (int i = 0; i < 8; i++) P[i] = rt_v3(i & 1 ? s : -s, i & 2 ? s : -s, i & 4 ? s : -s);
    static const int f[6][4] = {{0, 1, 3, 2}, {4, 6, 7, 5}, {0, 4, 5, 1}, {2, 3, 7, 6}, {0, 2, 6, 4}, {1, 5, 7, 3}};
    for (int i = 0; i < 6; i++) {
        float rgb[3] = {0.3f, 0.3f, 0.3f};
        rgb[i % 3] = 0.1f;
        add_quad(sc, P[f[i][0]], P[f[i][1]], P[f[i][2]], P[f[i][3]], rgb, m);
    }
    CHECK(rt_scene_finish(sc, &e) == 0, "finish: %s", e.msg);
    sc->cam.eye = rt_v3(0.1f * s, -0.8f * s, 0.15f * s);
    sc->cam.at = rt_v3(0.3f * s, 0.0f, -0.1f * s);
    sc->cam.up = rt_v3(0, 0, 1);
    sc->cam.fovy_deg = 70.0f;
    sc->light[0] = rt_v3(0.5f * s, 0.5f * s, 0.5f * s);
    sc->light[1] = rt_v3(-0.5f * s, 0.2f * s, -0.3f * s);
    sc->light[2] = rt_v3(0.0f, -0.6f * s, 0.7f * s);
    return sc;
}

static rt_image *render(rt_scene *sc, const char *tracer, const rt_render_opts *o, rt_run_stats *st)
{
    rt_err e = {0};
    rt_kd_params kp;
    rt_kd_default_params(&kp);
    rt_kdtree *kd = rt_kd_build(sc, &kp, &e);
    rt_job j;
    rt_image *im = NULL;
    if (!kd || rt_job_setup_borrowed(&j, sc, kd, tracer, o, &e) < 0) {
        CHECK(0, "%s: %s", tracer, e.msg);
        rt_kd_free(kd);
        return NULL;
    }
    j.check = 1;
    im = rt_image_new(o->W, o->H, &e);
    if (!im || rt_job_run(&j, NULL, im, st, &e) < 0) {
        CHECK(0, "run %s: %s", tracer, e.msg);
        rt_image_free(im);
        im = NULL;
    }
    rt_job_free(&j);
    rt_kd_free(kd);
    return im;
}

static uint64_t self_hits(const rt_run_stats *st)
{
    const char *p = strstr(st->extra, "self_hits=");
    CHECK(p != NULL, "no self_hits in '%s'", st->extra);
    return p ? strtoull(p + 10, NULL, 10) : 1;
}

/* The mirror box at three scales: every tracer, whitted and path. Radiance
 * does not depend on scale here (point lights without falloff, directions
 * only), so the images agree up to rounding: the offsets are a few ULPs of
 * the coordinates, relative to the scale, and move hit points by a relative
 * ~1e-6; the tolerance is |a - b| <= 1e-4 (1 + |a|) per value, except values
 * whose path crosses an edge of the box differently (a ray landing within
 * ~1e-6 of an edge), at most 1% of them. */
static void scales(void)
{
    static const float sc_s[3] = {1.0f, 1e-3f, 1e3f}; /* the first is the reference */
    static const char *const tr[] = {"recursive", "packet", "dynamic"};
    for (int mode = RT_MODE_WHITTED; mode <= RT_MODE_PATH; mode++) {
        rt_image *ref = NULL;
        for (int s = 0; s < 3; s++) {
            rt_scene *sc = mirror_box(sc_s[s]);
            rt_render_opts o;
            rt_render_default_opts(&o);
            o.W = o.H = 24;
            o.lights = 7;
            o.mode = mode;
            o.depth = 6;
            o.spp = 2;
            o.sched_size = 1024;
            rt_image *first = NULL;
            for (int t = 0; t < 3; t++) {
                rt_run_stats st;
                rt_image *im = render(sc, tr[t], &o, &st);
                if (!im) continue;
                CHECK(self_hits(&st) == 0, "scale %g %s %s: %s", sc_s[s], tr[t], rt_render_mode_name(mode), st.extra);
                if (!first) first = im;
                else {
                    CHECK(rt_image_rgb_equal(first, im), "scale %g: %s differs from recursive", sc_s[s], tr[t]);
                    rt_image_free(im);
                }
            }
            if (first && s == 0) ref = first, first = NULL;
            if (first && ref) {
                size_t n = (size_t)o.W * o.H * 3, off = 0;
                double worst = 0;
                for (size_t i = 0; i < n; i++) {
                    double a = ref->rgb[i], b = first->rgb[i], d = fabs(a - b) / (1 + fabs(a));
                    if (d > 1e-4) off++;
                    if (d > worst) worst = d;
                }
                printf("mirror box %s, scale %g vs 1: %zu of %zu values beyond 1e-4, worst %.3g\n",
                       rt_render_mode_name(mode), sc_s[s], off, n, worst);
                CHECK(off * 100 <= n, "scale %g: %zu values differ", sc_s[s], off);
            }
            rt_image_free(first);
            rt_scene_free(sc);
        }
        rt_image_free(ref);
    }
}

/* ---- hard cases, ray by ray ------------------------------------------------ */

typedef struct step {
    uint32_t tri;  /* hit triangle, RT_NO_HIT on a miss */
    int nmed;      /* media the ray that hit travelled in */
    int self;      /* it hit the triangle it left */
    rt_vec3 d;     /* its direction */
} step;

/* Follows a ray through the scene with brute-force intersection, taking the
 * child of the given kind at each hit (0 reflection, RT_PATH_REFRACT
 * refraction, falling back to the other one); returns the steps. */
static int follow(const rt_scene *sc, const rt_render_opts *o, rt_path p, int kind, step *out, int max)
{
    int n = 0;
    for (;;) {
        rt_ray r;
        rt_hit h;
        rt_shade_out so;
        rt_shade_path_ray(&p, &r);
        int hit = rt_brute_closest(sc, &r, &h);
        rt_shade_step(sc, o, &p, &r, hit ? &h : NULL, &so);
        if (n < max) {
            out[n].tri = hit ? h.tri : RT_NO_HIT;
            out[n].nmed = p.nmed;
            out[n].self = so.self_hit;
            out[n].d = p.d;
        }
        n++;
        if (!hit || !so.nchild || n >= max) return n;
        int c = so.nchild > 1 && so.child[1].kind == kind ? 1 : 0;
        if (so.child[0].kind == kind) c = 0;
        p = so.child[c];
    }
}

static rt_path ray_from(rt_vec3 o, rt_vec3 d)
{
    rt_ray r;
    rt_path p;
    rt_ray_init(&r, o, d);
    rt_shade_path_start(&p, &r, 0, 0);
    return p;
}

static const float grey[3] = {0.5f, 0.5f, 0.5f};

/* A mirror floor hit at 89.9 degrees from the normal: the reflection must
 * leave it and reach the wall behind, at every scale. */
static void grazing(void)
{
    for (float s = 1e-3f; s < 2e3f; s *= 1000.0f) {
        rt_err e = {0};
        rt_scene *sc = rt_scene_new(8, &e);
        int m = add_mat(sc, 0.9f, 0, 1);
        /* floor: two triangles sharing the diagonal; wall at x = 10 s */
        add_quad(sc, rt_v3(-10 * s, -10 * s, 0), rt_v3(10 * s, -10 * s, 0), rt_v3(10 * s, 10 * s, 0),
                 rt_v3(-10 * s, 10 * s, 0), grey, m);
        add_quad(sc, rt_v3(10 * s, -10 * s, -1 * s), rt_v3(10 * s, 10 * s, -1 * s), rt_v3(10 * s, 10 * s, 10 * s),
                 rt_v3(10 * s, -10 * s, 10 * s), grey, 0);
        rt_scene_finish(sc, &e);
        rt_render_opts o;
        rt_render_default_opts(&o);
        o.mode = RT_MODE_WHITTED;
        o.depth = 3;
        float a = 0.1f * 3.14159265f / 180.0f; /* 0.1 degrees above the floor */
        step st[4];
        int n = follow(sc, &o, ray_from(rt_v3(-5 * s, 0.3f * s, 5 * s * a), rt_v3(1, 0.02f, -a)), 0, st, 4);
        CHECK(n >= 2 && st[0].tri < 2 && st[1].tri >= 2 && st[1].tri != RT_NO_HIT && !st[0].self && !st[1].self,
              "scale %g: grazing reflection hit %u then %u (n %d)", s, st[0].tri, n > 1 ? st[1].tri : 99u, n);
        rt_scene_free(sc);
    }
}

/* A closed glass box (ior 1.5) with a ray inside meeting the top face at
 * the critical angle asin(1/1.5), a hair below it and a hair above it:
 * below, the ray leaves nearly parallel to the face without touching it
 * again; at and above it is totally reflected (the refracted weight goes
 * into the reflection) and stays inside. */
static void critical(void)
{
    rt_err e = {0};
    rt_scene *sc = rt_scene_new(12, &e);
    int g = add_mat(sc, 0.0f, 0.9f, 1.5f);
    rt_vec3 P[8];
    for (int i = 0; i < 8; i++) P[i] = rt_v3(i & 1 ? 1.0f : -1.0f, i & 2 ? 1.0f : -1.0f, i & 4 ? 1.0f : -1.0f);
    static const int f[6][4] = {{0, 1, 3, 2}, {4, 6, 7, 5}, {0, 4, 5, 1}, {2, 3, 7, 6}, {0, 2, 6, 4}, {1, 5, 7, 3}};
    for (int i = 0; i < 6; i++) add_quad(sc, P[f[i][0]], P[f[i][1]], P[f[i][2]], P[f[i][3]], grey, g);
    rt_scene_finish(sc, &e);
    rt_render_opts o;
    rt_render_default_opts(&o);
    o.mode = RT_MODE_WHITTED;
    o.depth = 3;
    double tc = asin(1.0 / 1.5);
    for (int c = -1; c <= 1; c++) {
        double th = tc + c * 1e-4;
        rt_path p = ray_from(rt_v3(-0.9f, 0.1f, 0.0f), rt_v3((float)sin(th), 0.0f, (float)cos(th)));
        p.nmed = 1, p.med[0] = (uint16_t)g; /* inside the glass */
        rt_ray r;
        rt_hit h;
        rt_shade_out so;
        rt_shade_path_ray(&p, &r);
        CHECK(rt_brute_closest(sc, &r, &h) && (h.tri == 2 || h.tri == 3), "critical %d: hit %u", c, h.tri);
        rt_shade_step(sc, &o, &p, &r, &h, &so);
        float cosi = (float)cos(th), k = 1.0f - 2.25f * (1.0f - cosi * cosi); /* the step's own TIR test */
        printf("critical angle %+d: %s\n", c, k >= 0.0f ? "refracted, leaves grazing" : "totally reflected");
        if (k >= 0.0f) {
            CHECK(so.nchild == 1 && so.child[0].kind == RT_PATH_REFRACT && so.child[0].nmed == 0,
                  "angle %d: expected one refracted ray leaving the glass (children %d)", c, so.nchild);
            step st[3];
            int n = follow(sc, &o, so.child[0], RT_PATH_REFRACT, st, 3);
            CHECK(n == 1 && st[0].tri == RT_NO_HIT, "angle %d: the refracted ray hit triangle %u", c, st[0].tri);
            CHECK(fabsf(so.child[0].d.z) < 0.05f * rt_len(so.child[0].d), "angle %d: not grazing (%g)", c,
                  (double)so.child[0].d.z);
        } else {
            CHECK(so.nchild == 1 && so.child[0].kind == 0 && so.child[0].nmed == 1 &&
                      fabsf(so.child[0].w[0] - 0.9f) < 1e-6f,
                  "angle %d: expected the total internal reflection with weight kt (children %d, w %g)", c, so.nchild,
                  so.nchild ? (double)so.child[0].w[0] : 0.0);
            step st[2];
            int n = follow(sc, &o, so.child[0], 0, st, 2);
            CHECK(n >= 1 && st[0].tri != RT_NO_HIT && st[0].tri != h.tri && !st[0].self,
                  "angle %d: the reflected ray left the glass or re-hit its face (%u)", c, st[0].tri);
        }
    }
    rt_scene_free(sc);
}

/* Lat-long sphere of radius rad about the origin. */
static void sphere(rt_scene *sc, float rad, int mat)
{
    const int NU = 24, NV = 12;
    for (int j = 0; j < NV; j++)
        for (int i = 0; i < NU; i++) {
            rt_vec3 q[4];
            for (int c = 0; c < 4; c++) {
                int u = i + (c == 1 || c == 2), v = j + (c >= 2);
                double ph = 2 * 3.14159265358979 * u / NU, th = 3.14159265358979 * v / NV;
                q[c] = rt_v3((float)(rad * sin(th) * cos(ph)), (float)(rad * sin(th) * sin(ph)), (float)(rad * cos(th)));
            }
            rt_err e = {0};
            if (j > 0) rt_scene_add_tri_mat(sc, q[0], q[1], q[2], grey, (uint32_t)mat, &e);
            if (j < NV - 1) rt_scene_add_tri_mat(sc, q[0], q[2], q[3], grey, (uint32_t)mat, &e);
        }
}

/* Snell: |d_t x n| |d_i| = eta_i / eta_t |d_i x n| |d_t| for unit n. */
static double snell_ratio(rt_vec3 di, rt_vec3 dt, rt_vec3 n)
{
    n = rt_norm(n);
    double si = rt_len(rt_cross(rt_norm(di), n)), st = rt_len(rt_cross(rt_norm(dt), n));
    return st / si;
}

/* Glass (1.5) sphere of radius 1 holding a water (1.33) sphere of radius
 * 0.5: a ray off the axis crosses four interfaces with the media stack
 * 1 -> 2 -> 1 -> 0 and each refraction follows Snell's law with the indices
 * on both sides (1/1.5, 1.5/1.33, 1.33/1.5, 1.5/1). */
static void nested(void)
{
    rt_err e = {0};
    rt_scene *sc = rt_scene_new(1200, &e);
    int glass = add_mat(sc, 0.0f, 1.0f, 1.5f), water = add_mat(sc, 0.0f, 1.0f, 1.33f);
    sphere(sc, 1.0f, glass);
    uint32_t nouter = sc->ntri;
    sphere(sc, 0.5f, water);
    rt_scene_finish(sc, &e);
    rt_render_opts o;
    rt_render_default_opts(&o);
    o.mode = RT_MODE_WHITTED;
    o.depth = 8;
    step st[8];
    int n = follow(sc, &o, ray_from(rt_v3(-3.0f, 0.11f, 0.07f), rt_v3(1.0f, 0.0f, 0.0f)), RT_PATH_REFRACT, st, 8);
    static const double want_eta[4] = {1 / 1.5, 1.5 / 1.33, 1.33 / 1.5, 1.5 / 1.0};
    static const int want_med[5] = {0, 1, 2, 1, 0};
    CHECK(n == 5, "nested: %d steps, expected 4 hits and a miss", n);
    for (int i = 0; i < 5 && i < n; i++) {
        CHECK(st[i].nmed == want_med[i], "nested: ray %d travels in %d media, expected %d", i, st[i].nmed, want_med[i]);
        CHECK(!st[i].self, "nested: ray %d re-hit its triangle", i);
        if (i < 4) {
            CHECK(st[i].tri != RT_NO_HIT && (st[i].tri < nouter) == (i == 0 || i == 3), "nested: hit %d on %u", i,
                  st[i].tri);
            if (st[i].tri == RT_NO_HIT) break;
            double r = snell_ratio(st[i].d, st[i + 1].d, rt_tri_normal(&sc->tri[st[i].tri]));
            CHECK(fabs(r - want_eta[i]) < 1e-4 * want_eta[i], "nested: interface %d bends by %.6f, Snell says %.6f", i, r,
                  want_eta[i]);
        }
    }
    CHECK(n < 5 || st[4].tri == RT_NO_HIT, "nested: the last ray hit %u", st[4].tri);
    rt_scene_free(sc);
}

/* Reflection off the edge two mirror triangles share: a flat quad hit on its
 * diagonal, and a convex ridge hit on its crest; the reflected ray must
 * leave both triangles and reach the ceiling. */
static void shared_edge(void)
{
    for (int ridge = 0; ridge < 2; ridge++)
        for (float s = 1e-3f; s < 2e3f; s *= 1000.0f) {
            rt_err e = {0};
            rt_scene *sc = rt_scene_new(8, &e);
            int m = add_mat(sc, 0.9f, 0, 1);
            float hz = ridge ? 0.3f * s : 0.0f; /* crest height along the diagonal */
            /* diagonal from (-s, -s) to (s, s) */
            rt_scene_add_tri_mat(sc, rt_v3(-s, -s, hz), rt_v3(s, -s, 0), rt_v3(s, s, hz), grey, (uint32_t)m, &e);
            rt_scene_add_tri_mat(sc, rt_v3(-s, -s, hz), rt_v3(s, s, hz), rt_v3(-s, s, 0), grey, (uint32_t)m, &e);
            add_quad(sc, rt_v3(-5 * s, -5 * s, 3 * s), rt_v3(5 * s, -5 * s, 3 * s), rt_v3(5 * s, 5 * s, 3 * s),
                     rt_v3(-5 * s, 5 * s, 3 * s), grey, 0);
            rt_scene_finish(sc, &e);
            rt_render_opts o;
            rt_render_default_opts(&o);
            o.mode = RT_MODE_WHITTED;
            o.depth = 3;
            int bad = 0;
            for (int k = -8; k <= 8; k++) {
                float t = 0.1f * (float)k; /* points along the shared edge */
                rt_vec3 target = rt_v3(t * s, t * s, hz);
                rt_vec3 org = rt_v3(0.2f * s, -0.5f * s, 2.0f * s);
                step st[3];
                int n = follow(sc, &o, ray_from(org, rt_sub(target, org)), 0, st, 3);
                if (!(n >= 2 && st[0].tri < 2 && st[1].tri >= 2 && st[1].tri != RT_NO_HIT)) bad++;
            }
            CHECK(bad == 0, "%s at scale %g: %d of 17 reflections off the shared edge went wrong",
                  ridge ? "ridge" : "flat quad", s, bad);
            rt_scene_free(sc);
        }
}

int main(void)
{
    params();
    cli();
    accumulator();
    grazing();
    critical();
    nested();
    shared_edge();
    scales();
    if (failures) fprintf(stderr, "%d failure(s)\n", failures);
    return failures ? 1 : 0;
}
