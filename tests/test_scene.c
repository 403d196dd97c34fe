/*
 * test_scene.c -- tests for the built-in scenes and the scene container:
 * exact triangle counts, parameter parsing, determinism (golden hashes that
 * catch drift across machines and libm versions), watertight spheres, OBJ
 * export -> import round trip (with its MTL), the built-ins' materials and
 * the material=PRESET parameter, and out-of-memory paths.
 * Exit status 0 = all passed.
 */
#include "config.h"
#include "check.h"
#include "outfile.h"
#include "scene.h"
#include "scene_load.h"

#include <inttypes.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

static rt_scene *load(const char *spec)
{
    rt_err e = {0};
    rt_scene *s = rt_scene_load(spec, &e);
    CHECK(s != NULL, "%s: %s", spec, e.msg);
    return s;
}

static void test_counts(void)
{
    static const struct {
        const char *spec;
        uint32_t ntri;
    } exact[] = {
        {"sphereflake", 797150},          {"sphereflake:level=0", 110}, {"sphereflake:level=1", 1082},
        {"sphereflake:level=2", 9830},    {"sphereflake:tess=1,level=1", 10 * 12 + 2},
        {"knot", 1024},                   {"knot:segs=10,sides=4", 80}, {"cornell:glass=0", 36},
        {"cornell", 36 + 12 * 4 * 4}, /* the glass sphere: a cube sphere with tess 4 */
        {"grove:v=1,trees=1,depth=0,tess=1", 22},
        {"grove:trees=1,depth=0,tess=1,leaves=10", 8 + 10 + 2},
        {"grove:v=1", 168302}, {"grove", 163722},
        {"room:v=1", 46588}, {"room", 46588},
    };
    for (size_t i = 0; i < sizeof exact / sizeof exact[0]; i++) {
        double t0 = rt_now();
        rt_scene *s = load(exact[i].spec);
        double dt = rt_now() - t0;
        if (!s) continue;
        CHECK(s->ntri == exact[i].ntri, "%s: %u triangles, want %u", exact[i].spec, s->ntri, exact[i].ntri);
        if (!strcmp(exact[i].spec, "sphereflake"))
            CHECK(dt < 2.0, "sphereflake took %.2f s", dt); /* ~0.2 s at -O2; generous for sanitizers */
        CHECK(s->bounds.lo.x <= s->bounds.hi.x, "%s: empty bounds", exact[i].spec);
        rt_scene_free(s);
    }
    static const struct {
        const char *spec;
        double want;
    } approx[] = {{"grove", 164000}, {"room", 47000}};
    for (size_t i = 0; i < 2; i++) {
        rt_scene *s = load(approx[i].spec);
        if (!s) continue;
        double r = s->ntri / approx[i].want;
        CHECK(r > 0.95 && r < 1.05, "%s: %u triangles, want within 5%% of %.0f", approx[i].spec, s->ntri,
              approx[i].want);
        rt_scene_free(s);
    }
}

static void test_params(void)
{
    rt_scene *s = load("sphereflake:level=1");
    if (s) {
        CHECK(!strcmp(s->name, "sphereflake"), "name '%s'", s->name);
        CHECK(!strcmp(s->params, "level=1,tess=3"), "params '%s'", s->params);
        rt_scene_free(s);
    }
    s = load("knot:q=5,p=3");
    if (s) {
        CHECK(!strcmp(s->params, "p=3,q=5,segs=64,sides=8"), "params '%s'", s->params);
        rt_scene_free(s);
    }
    static const struct {
        const char *spec, *needle;
    } bad[] = {
        {"sphereflake:foo=1", "unknown parameter 'foo'"},
        {"sphereflake:level=9", "out of range"},
        {"sphereflake:level=x", "not an integer"},
        {"sphereflake:level=", "not an integer"},
        {"sphereflake:level", "key=value"},
        {"sphereflake:level=1,level=2", "twice"},
        {"sphereflake:level=1,", "empty parameter"},
        {"cornell:x=1", "unknown parameter 'x'"},
        {"no-such-scene", "unknown scene"},
        {"", "empty"},
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        rt_err e = {0};
        rt_scene *t = rt_scene_load(bad[i].spec, &e);
        CHECK(t == NULL, "%s accepted", bad[i].spec);
        CHECK(strstr(e.msg, bad[i].needle) != NULL, "%s: message '%s' lacks '%s'", bad[i].spec, e.msg,
              bad[i].needle);
        CHECK(strchr(e.msg, '\n') == NULL, "%s: multi-line message", bad[i].spec);
        rt_scene_free(t);
    }
    for (int i = 0; rt_scene_builtin_names[i]; i++)
        CHECK(rt_scene_describe(rt_scene_builtin_names[i]) != NULL, "%s has no description",
              rt_scene_builtin_names[i]);
    CHECK(rt_scene_describe("nope") == NULL, "describe(nope)");
}

/* Golden hashes: if one of these changes, every trace and result row made
 * before is no longer comparable. Change them only on purpose, and say so
 * in docs/scenes.md. */
static void test_determinism(void)
{
    /* The scenes as they were before materials keep their hashes: grove,
     * room and mesh files have none, cornell:glass=0 is the old cornell and
     * material=diffuse takes the mirrors off sphereflake and knot. */
    static const struct {
        const char *spec;
        uint64_t hash;
    } golden[] = {
        {"sphereflake:level=1", UINT64_C(0x5f0744b7c20e81f8)},
        {"knot", UINT64_C(0xd1e3d5dafa3c6623)},
        {"cornell", UINT64_C(0xf300c26a09a52be5)},
        {"sphereflake:level=1,material=diffuse", UINT64_C(0xa732da7c33ae6fa0)},
        {"knot:material=diffuse", UINT64_C(0x97f7f72f2020f483)},
        {"cornell:glass=0", UINT64_C(0x2ad0a3a6fc13cbc1)},
        /* version 1 of room and grove is the scene before version 2 */
        {"room:v=1", UINT64_C(0xc77149f3d2c548a0)},
        {"grove:v=1,trees=1,depth=2", UINT64_C(0x1fc227feea7e44e9)},
        {"room", UINT64_C(0x24cb83bc22b1b46d)},
        {"grove:trees=1,depth=2", UINT64_C(0x93339bd8bdef411e)},
    };
    for (size_t i = 0; i < sizeof golden / sizeof golden[0]; i++) {
        rt_scene *a = load(golden[i].spec), *b = load(golden[i].spec);
        if (!a || !b) {
            rt_scene_free(a);
            rt_scene_free(b);
            continue;
        }
        uint64_t ha = rt_scene_hash(a), hb = rt_scene_hash(b);
        CHECK(ha == hb, "%s: two builds differ", golden[i].spec);
        CHECK(ha == golden[i].hash, "%s: hash %016" PRIx64 ", golden %016" PRIx64, golden[i].spec, ha,
              golden[i].hash);
        /* The hash covers lights and camera too. */
        a->light[2].x += 1.0f;
        CHECK(rt_scene_hash(a) != hb, "%s: hash ignores lights", golden[i].spec);
        rt_scene_free(a);
        rt_scene_free(b);
    }
    const char *specs[] = {"grove", "room", "sphereflake:level=2"};
    for (size_t i = 0; i < 3; i++) {
        rt_scene *a = load(specs[i]), *b = load(specs[i]);
        if (a && b) {
            CHECK(a->ntri == b->ntri && !memcmp(a->tri, b->tri, sizeof *a->tri * a->ntri), "%s differs", specs[i]);
            CHECK(rt_scene_hash(a) == rt_scene_hash(b), "%s hash differs", specs[i]);
        }
        rt_scene_free(a);
        rt_scene_free(b);
    }
}

/* Sphereflake facts: the root sphere's vertices lie on radius 0.5, the
 * floor is at z = -0.5, and every edge of a sphere is shared by exactly two
 * of its triangles with bit-identical endpoints (watertight). */
static int same(rt_vec3 a, rt_vec3 b) { return !memcmp(&a, &b, sizeof a); }

static void test_sphereflake_geometry(void)
{
    rt_scene *s = load("sphereflake:level=0,tess=3");
    if (!s) return;
    for (uint32_t i = 0; i < 108; i++)
        for (int k = 0; k < 3; k++) {
            rt_vec3 p = s->tri[i].p[k];
            double r = sqrt((double)p.x * p.x + (double)p.y * p.y + (double)p.z * p.z);
            CHECK(fabs(r - 0.5) < 1e-6, "vertex radius %.9g", r);
        }
    CHECK(s->tri[108].p[0].z == -0.5f && s->bounds.lo.x == -12.0f, "floor");
    /* Each directed edge must appear reversed in exactly one other triangle. */
    int open = 0;
    for (uint32_t i = 0; i < 108; i++)
        for (int k = 0; k < 3; k++) {
            rt_vec3 a = s->tri[i].p[k], b = s->tri[i].p[(k + 1) % 3];
            int m = 0;
            for (uint32_t j = 0; j < 108; j++)
                for (int l = 0; l < 3; l++)
                    if (same(s->tri[j].p[l], b) && same(s->tri[j].p[(l + 1) % 3], a)) m++;
            if (m != 1) open++;
        }
    CHECK(open == 0, "%d sphere edges not shared exactly once", open);
    /* Outward winding: the normal points away from the centre. */
    int inward = 0;
    for (uint32_t i = 0; i < 108; i++) {
        rt_vec3 *p = s->tri[i].p;
        rt_vec3 n = rt_cross(rt_sub(p[1], p[0]), rt_sub(p[2], p[0]));
        if (rt_dot(n, p[0]) <= 0) inward++;
    }
    CHECK(inward == 0, "%d inward-facing sphere triangles", inward);
    CHECK(s->cam.eye.x == 2.1f && s->cam.eye.y == 1.3f && s->cam.eye.z == 1.7f, "camera");
    CHECK(s->light[0].x == 4.0f && s->light[1].y == -4.0f && s->light[2].z == 5.0f, "lights");
    rt_scene_free(s);
    /* Level 1: 9 children of radius 1/6 whose centres are at distance 2/3. */
    s = load("sphereflake:level=1,tess=2");
    if (s) {
        for (int c = 1; c <= 9; c++) {
            rt_bounds b = rt_bounds_empty();
            for (uint32_t i = 48u * c; i < 48u * (c + 1); i++)
                for (int k = 0; k < 3; k++) rt_bounds_grow(&b, s->tri[i].p[k]);
            double cx = 0.5 * (b.lo.x + b.hi.x), cy = 0.5 * (b.lo.y + b.hi.y), cz = 0.5 * (b.lo.z + b.hi.z);
            double d = sqrt(cx * cx + cy * cy + cz * cz);
            CHECK(fabs(d - 2.0 / 3.0) < 1e-5, "child %d at distance %.9g", c, d);
            CHECK(fabs((b.hi.x - b.lo.x) - 1.0 / 3.0) < 1e-5, "child %d diameter %.9g", c, (double)(b.hi.x - b.lo.x));
        }
        rt_scene_free(s);
    }
}

static void test_colours_and_lights(void)
{
    for (int i = 0; rt_scene_builtin_names[i]; i++) {
        const char *n = rt_scene_builtin_names[i];
        if (!strcmp(n, "sphereflake")) n = "sphereflake:level=1";
        rt_scene *s = load(n);
        if (!s) continue;
        int bad = 0;
        for (uint32_t t = 0; t < s->ntri; t++)
            for (int k = 0; k < 3; k++)
                if (!(s->shade[t].rgb[k] >= 0 && s->shade[t].rgb[k] <= 1)) bad++;
        CHECK(bad == 0, "%s: %d colour components outside [0,1]", n, bad);
        CHECK(s->light_power > 0 && s->ambient > 0, "%s: lighting", n);
        CHECK(!same(s->cam.eye, s->cam.at), "%s: degenerate camera", n);
        /* A well-exposed sum: a surface lit head-on by all lights stays near 1. */
        double peak = s->ambient + 3 * s->light_power;
        CHECK(peak > 0.8 && peak < 2.0, "%s: peak %.2f", n, peak);
        rt_scene_free(s);
    }
    rt_scene *s = load("room");
    if (s) {
        CHECK(same(s->light[0], s->cam.eye), "room: light 0 not at the camera");
        /* Camera inside the flat, below the ceiling. */
        CHECK(s->cam.eye.x > 0 && s->cam.eye.x < 15 && s->cam.eye.z < 2.6f, "room: camera outside");
        rt_scene_free(s);
    }
}

/* The built-ins' materials: which triangles carry which terms, and that the
 * colours (what primary and shadow rays shade) did not change. */
static void test_builtin_materials(void)
{
    static const struct {
        const char *spec;
        uint32_t flags;
    } want[] = {
        {"sphereflake:level=1", RT_MAT_SPECULAR}, {"knot", RT_MAT_SPECULAR},
        {"cornell", RT_MAT_TRANSMIT},             {"cornell:glass=0", 0},
        {"room", 0},                              {"grove:trees=1,depth=2", 0},
        {"knot:material=glass", RT_MAT_TRANSMIT}, {"cornell:material=mirror", RT_MAT_SPECULAR},
        {"knot:material=diffuse", 0},
    };
    for (size_t i = 0; i < sizeof want / sizeof want[0]; i++) {
        rt_scene *s = load(want[i].spec);
        if (!s) continue;
        CHECK(rt_scene_material_flags(s) == want[i].flags, "%s: flags %u, want %u", want[i].spec,
              (unsigned)rt_scene_material_flags(s), (unsigned)want[i].flags);
        rt_scene_free(s);
    }
    /* sphereflake: every sphere a grey mirror of 0.5 (SPD balls' Ks), the
     * floor (the last 2 triangles) plain; colours as without materials. */
    rt_scene *s = load("sphereflake:level=1"), *d = load("sphereflake:level=1,material=diffuse");
    if (s && d) {
        CHECK(s->nmat == 2 && d->nmat == 1, "nmat %u, %u", s->nmat, d->nmat);
        int bad = 0;
        for (uint32_t i = 0; i < s->ntri; i++) {
            const rt_material *m = &s->mat[s->shade[i].mat];
            int floor = i >= s->ntri - 2;
            if (floor ? s->shade[i].mat != 0 : (m->ks[0] != 0.5f || m->ks[2] != 0.5f || m->kt[0] != 0))
                bad++;
            if (memcmp(s->shade[i].rgb, d->shade[i].rgb, sizeof s->shade[i].rgb)) bad++;
        }
        CHECK(bad == 0, "sphereflake: %d triangles with the wrong material or colour", bad);
        CHECK(!strcmp(d->params, "level=1,tess=3,material=diffuse"), "params '%s'", d->params);
    }
    rt_scene_free(s);
    rt_scene_free(d);
    /* cornell: the old 36 triangles first, unchanged, then the glass
     * sphere (kt 1, ior 1.5, no ks: Fresnel is the tracer's). */
    s = load("cornell");
    d = load("cornell:glass=0");
    if (s && d && s->ntri == 228 && d->ntri == 36) {
        CHECK(!memcmp(s->tri, d->tri, 36 * sizeof *s->tri) && !memcmp(s->shade, d->shade, 36 * sizeof *s->shade),
              "cornell: the box changed under the glass sphere");
        const rt_material *g = &s->mat[s->shade[100].mat];
        CHECK(s->shade[100].mat == 1 && s->shade[227].mat == 1 && g->kt[1] == 1.0f && g->ior == 1.5f &&
                  g->ks[0] == 0 && g->flags == RT_MAT_TRANSMIT,
              "cornell glass: mat %u kt %g ior %g", (unsigned)s->shade[100].mat, (double)g->kt[1], (double)g->ior);
        /* The sphere stays clear of the walls and both blocks (x, y within
         * [0.13, 0.37], z within [0, 0.24]). */
        rt_bounds b = rt_bounds_empty();
        for (uint32_t i = 36; i < 228; i++)
            for (int k = 0; k < 3; k++) rt_bounds_grow(&b, s->tri[i].p[k]);
        CHECK(b.lo.x >= 0.129f && b.hi.x <= 0.371f && b.lo.y >= 0.099f && b.hi.y <= 0.341f && b.lo.z >= 0 &&
                  b.hi.z <= 0.241f, "glass sphere bounds (%g %g %g)-(%g %g %g)", (double)b.lo.x, (double)b.lo.y,
              (double)b.lo.z, (double)b.hi.x, (double)b.hi.y, (double)b.hi.z);
        CHECK(!strcmp(s->params, "glass=1") && !strcmp(d->params, "glass=0"), "params '%s' '%s'", s->params,
              d->params);
    } else CHECK(0, "cornell: %u and %u triangles", s ? s->ntri : 0, d ? d->ntri : 0);
    rt_scene_free(s);
    rt_scene_free(d);
    /* Presets: mirror 0.8, glass kt 1 ior 1.5 on every triangle. */
    s = load("knot:material=mirror");
    if (s) {
        int bad = 0;
        for (uint32_t i = 0; i < s->ntri; i++) bad += s->shade[i].mat != 1;
        CHECK(bad == 0 && s->nmat == 2 && s->mat[1].ks[1] == 0.8f && s->mat[1].kt[0] == 0 && s->mat[1].ior == 1.0f,
              "knot:material=mirror");
        rt_scene_free(s);
    }
    static const struct {
        const char *spec, *needle;
    } bad[] = {
        {"knot:material=chrome", "unknown material 'chrome'"},
        {"knot:material=", "unknown material ''"},
        {"knot:material=glass,material=mirror", "twice"},
        {"knot:material=glass,foo=1", "unknown parameter 'foo'"},
        {"cornell:glass=2", "out of range"},
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        rt_err e = {0};
        rt_scene *t = rt_scene_load(bad[i].spec, &e);
        CHECK(t == NULL && strstr(e.msg, bad[i].needle), "%s: '%s' (want '%s')", bad[i].spec, e.msg, bad[i].needle);
        rt_scene_free(t);
    }
}

/* The material listing: one line per material with its use count. */
static void test_describe_materials(void)
{
    rt_scene *s = load("cornell");
    if (!s) return;
    FILE *f = tmpfile();
    CHECK(f != NULL, "tmpfile");
    if (f) {
        CHECK(rt_scene_describe_materials(s, f) == 0, "describe_materials");
        rewind(f);
        char line[4][256] = {"", "", "", ""};
        int n = 0;
        while (n < 4 && fgets(line[n], sizeof line[n], f)) n++;
        CHECK(n == 3, "%d lines, want a header and 2 materials", n);
        CHECK(!strncmp(line[0], "mat ", 4), "header '%s'", line[0]);
        CHECK(strstr(line[1], "(plain)") && strstr(line[1], " 36 ") && strstr(line[1], "diffuse"), "line 1 '%s'",
              line[1]);
        CHECK(strstr(line[2], "glass") && strstr(line[2], " 192 ") && strstr(line[2], "transmit") &&
                  strstr(line[2], "1 1 1") && strstr(line[2], "1.5"),
              "line 2 '%s'", line[2]);
        fclose(f);
    }
    rt_scene_free(s);
}

static char tmpdir[256];

static void test_export_roundtrip(void)
{
    const char *specs[] = {"knot", "cornell", "sphereflake:level=1", "room"};
    for (size_t i = 0; i < 4; i++) {
        rt_scene *s = load(specs[i]);
        if (!s) continue;
        char path[512];
        snprintf(path, sizeof path, "%s/export%zu.obj", tmpdir, i);
        rt_err e = {0};
        CHECK(rt_scene_export_obj(s, path, &e) == 0, "export: %s", e.msg);
        rt_scene *t = rt_scene_load(path, &e);
        CHECK(t != NULL, "re-import: %s", e.msg);
        if (t) {
            CHECK(t->ntri == s->ntri, "%s: %u triangles after round trip, want %u", specs[i], t->ntri, s->ntri);
            if (t->ntri == s->ntri)
                CHECK(!memcmp(t->tri, s->tri, sizeof *s->tri * s->ntri), "%s: coordinates changed", specs[i]);
            CHECK(!strcmp(t->name, strrchr(path, '/') + 1), "name '%s'", t->name);
            /* Through the MTL: each triangle keeps its colour and its
             * material's terms (the table may be split per colour). */
            int bad = 0;
            for (uint32_t k = 0; s->nmat > 1 && k < s->ntri && t->ntri == s->ntri; k++) {
                const rt_material *a = &s->mat[s->shade[k].mat], *b = &t->mat[t->shade[k].mat];
                if (memcmp(s->shade[k].rgb, t->shade[k].rgb, sizeof s->shade[k].rgb) ||
                    memcmp(a->ks, b->ks, sizeof a->ks) || memcmp(a->kt, b->kt, sizeof a->kt) ||
                    memcmp(a->ke, b->ke, sizeof a->ke) || a->ior != b->ior || a->flags != b->flags)
                    bad++;
            }
            CHECK(bad == 0, "%s: %d triangles changed colour or material in the round trip", specs[i], bad);
            CHECK(rt_scene_material_flags(t) == rt_scene_material_flags(s), "%s: flags", specs[i]);
            char mpath[512];
            snprintf(mpath, sizeof mpath, "%s/export%zu.mtl", tmpdir, i);
            CHECK((access(mpath, F_OK) == 0) == (s->nmat > 1), "%s: MTL beside the OBJ: %s", specs[i],
                  s->nmat > 1 ? "missing" : "written without materials");
        }
        rt_scene_free(t);
        rt_scene_free(s);
    }
    /* A scene without materials gets no MTL, and its OBJ names none. */
    char mpath[512];
    snprintf(mpath, sizeof mpath, "%s/export3.mtl", tmpdir);
    CHECK(access(mpath, F_OK) != 0, "room: an MTL was written");
    /* A failing OBJ takes its MTL with it. */
    rt_scene *s = load("knot");
    if (s) {
        char path[512];
        snprintf(path, sizeof path, "%s/fail.obj", tmpdir);
        snprintf(mpath, sizeof mpath, "%s/fail.mtl", tmpdir);
        rt_err e = {0};
        rt_out_fail_after = 5000; /* the MTL (~9 KB) fails too: try one that passes it */
        int rc = rt_scene_export_obj(s, path, &e);
        rt_out_fail_after = 20000; /* MTL fits, OBJ (~100 KB) does not */
        int rc2 = rt_scene_export_obj(s, path, &e);
        rt_out_fail_after = -1;
        CHECK(rc < 0 && rc2 < 0, "export under a failing disk succeeded");
        CHECK(access(path, F_OK) != 0 && access(mpath, F_OK) != 0, "a failed export left a file");
        rt_scene_free(s);
    }
    s = load("cornell");
    if (s) {
        rt_err e = {0};
        CHECK(rt_scene_export_obj(s, "/nonexistent-dir/x.obj", &e) < 0, "export to a bad path succeeded");
        CHECK(strstr(e.msg, "/nonexistent-dir/x.obj") != NULL, "message '%s'", e.msg);
        rt_scene_free(s);
    }
}

static void test_container(void)
{
    rt_scene_free(NULL);
    rt_err e = {0};
    rt_scene *s = rt_scene_new(0, &e);
    CHECK(s != NULL, "new: %s", e.msg);
    if (!s) return;
    snprintf(s->name, sizeof s->name, "unit");
    CHECK(rt_scene_finish(s, &e) < 0, "finish accepted an empty scene");
    for (int i = 0; i < 1000; i++)
        rt_scene_add_tri(s, rt_v3((float)i, 0, 0), rt_v3(0, (float)i, 0), rt_v3(0, 0, 1), NULL, &e);
    CHECK(s->ntri == 1000, "%u triangles", s->ntri);
    CHECK(rt_scene_finish(s, &e) == 0, "finish: %s", e.msg);
    CHECK(s->bounds.hi.x == 999.0f && s->bounds.lo.z == 0.0f && s->bounds.hi.z == 1.0f, "bounds");
    CHECK(s->shade[5].rgb[0] > 0 && s->shade[5].rgb[0] < 1, "default grey");
    rt_scene_autoframe(s);
    CHECK(same(s->light[0], s->cam.eye), "autoframe: light 0 at the camera");
    s->tri[7].p[1].y = NAN;
    CHECK(rt_scene_finish(s, &e) < 0 && strstr(e.msg, "non-finite"), "finish accepted NaN: '%s'", e.msg);
    s->tri[7].p[1].y = INFINITY;
    CHECK(rt_scene_finish(s, &e) < 0, "finish accepted Inf");
    rt_scene_free(s);
}

/* Every allocation failure is reported, never a crash or a leak. */
static void test_oom(void)
{
    const char *specs[] = {"cornell", "knot", "sphereflake:level=1", "room"};
    for (size_t i = 0; i < 4; i++) {
        int ok = 0;
        for (long n = 1; n < 200 && !ok; n++) {
            rt_err e = {0};
            rt_fail_alloc_after = n;
            rt_scene *s = rt_scene_load(specs[i], &e);
            rt_fail_alloc_after = 0;
            if (s) ok = 1;
            else CHECK(strstr(e.msg, "memory") != NULL, "%s: alloc %ld: message '%s'", specs[i], n, e.msg);
            rt_scene_free(s);
        }
        CHECK(ok, "%s never succeeded", specs[i]);
    }
}

int main(void)
{
    const char *td = getenv("TMPDIR");
    snprintf(tmpdir, sizeof tmpdir, "%s/rt_test_scene.XXXXXX", td && *td ? td : "/tmp");
    if (!mkdtemp(tmpdir)) {
        perror("mkdtemp");
        return 1;
    }
    test_counts();
    test_params();
    test_determinism();
    test_sphereflake_geometry();
    test_colours_and_lights();
    test_builtin_materials();
    test_describe_materials();
    test_export_roundtrip();
    test_container();
    test_oom();
    if (check_rm_tree(tmpdir) != 0) fprintf(stderr, "warning: could not remove %s\n", tmpdir);
    if (failures) fprintf(stderr, "%d failure(s)\n", failures);
    else printf("test_scene: all passed\n");
    return failures ? 1 : 0;
}
