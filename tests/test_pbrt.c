/*
 * test_pbrt.c -- tests for the pbrt-v4 loader (src/scene_pbrt.c): every
 * supported directive, nested attributes and transforms (world coordinates
 * worked out by hand), instancing counts, includes with relative paths and
 * a binary PLY of quads (tests/data/pbrt), Loop subdivision at levels 0-2
 * (triangle counts and limit positions computed by hand), each material
 * mapping, lights and the camera (fov conversion, pbrt's left-handed
 * screen), the one-warning-per-kind rule, every bad input the loader must
 * refuse with FILE:LINE:COL (cycles, escapes, FIFOs, huge claims), every
 * truncation of the Cornell box, and the Cornell box itself: 36 triangles,
 * its lamp emitting and visible, identical images from every tracer.
 * Exit status 0 = all passed.
 */
#include "config.h"
#include "camera.h"
#include "check.h"
#include "kdtree.h"
#include "run.h"
#include "scene.h"
#include "scene_load.h"
#include "scene_file.h"

#include <inttypes.h>
#include <stdint.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>
#include <zlib.h>

static const char *srcfile(const char *rel)
{
    static char buf[4][600];
    static int k;
    k = (k + 1) & 3;
    const char *src = getenv("RT_SRCDIR");
    if (src && *src) snprintf(buf[k], sizeof buf[k], "%s/%s", src, rel);
    else snprintf(buf[k], sizeof buf[k], "%s/../%s", RT_SRCDATADIR, rel);
    return buf[k];
}

static void write_text(const char *name, const char *text)
{
    check_write_file(check_path(name), text, strlen(text));
}

/* Writes text as NAME in the temporary folder and loads it (spec: the path,
 * then ":" params if any). */
static rt_scene *load_text(const char *name, const char *text, const char *params, rt_err *e)
{
    write_text(name, text);
    char spec[700];
    snprintf(spec, sizeof spec, "%s%s%s", check_path(name), params ? ":" : "", params ? params : "");
    return rt_scene_load(spec, e);
}

static rt_scene *expect_ok(const char *name, const char *text, uint32_t ntri)
{
    rt_err e = {0};
    rt_scene *s = load_text(name, text, NULL, &e);
    CHECK(s != NULL, "%s refused: %s", name, e.msg);
    if (s) CHECK(s->ntri == ntri, "%s: %u triangles, expected %u", name, s->ntri, ntri);
    return s;
}

static void expect_fail(const char *name, const char *text, const char *needle)
{
    rt_err e = {0};
    rt_scene *s = load_text(name, text, NULL, &e);
    CHECK(s == NULL, "%s accepted:\n%s", name, text);
    CHECK(strstr(e.msg, needle) != NULL, "%s: message '%s' lacks '%s'", name, e.msg, needle);
    CHECK(strchr(e.msg, '\n') == NULL, "%s: message has a newline", name);
    rt_scene_free(s);
}

static int vnear(rt_vec3 a, double x, double y, double z, double tol)
{
    return check_near(a.x, x, 0, tol) && check_near(a.y, y, 0, tol) && check_near(a.z, z, 0, tol);
}

static int veq(rt_vec3 a, float x, float y, float z) { return a.x == x && a.y == y && a.z == z; }

#define TRI "Shape \"trianglemesh\" \"point3 P\" [ 0 0 0  1 0 0  0 1 0 ]\n"

/* ------------------------------------------------------------------------ */

static void test_tokens(void)
{
    /* comments anywhere, a bare single value, brackets spread over lines,
     * escapes in strings, bool values bare and quoted, CRLF */
    rt_scene *s = expect_ok("tok.pbrt",
                            "# comment\r\nWorldBegin # after a directive\r\n"
                            "MakeNamedMaterial \"a \\\"q\\\" b\" \"string type\" \"diffuse\"\n"
                            "  \"rgb reflectance\" [ 0.25 # inside a list\n 0.5\n 0.75 ]\n"
                            "NamedMaterial \"a \\\"q\\\" b\"\n"
                            "Shape \"sphere\" \"float radius\" 2 \"bool flag\" true \"bool other\" \"false\"\n"
                            "Shape \"trianglemesh\" \"point3 P\" [ 0 0 0 1e0 0 0 0 .5 0 ] \"integer indices\" [0 1 2]\n"
                            "WorldEnd # pbrt-v3\n",
                            109);
    if (s) {
        CHECK(s->shade[0].rgb[0] == 0.25f && s->shade[0].rgb[1] == 0.5f && s->shade[0].rgb[2] == 0.75f,
              "named material with escapes: %g %g %g", s->shade[0].rgb[0], s->shade[0].rgb[1], s->shade[0].rgb[2]);
        CHECK(veq(s->tri[108].p[2], 0, 0.5f, 0), "last vertex (%g %g %g)", s->tri[108].p[2].x, s->tri[108].p[2].y,
              s->tri[108].p[2].z);
        CHECK(s->warning[0] == 0, "warning '%s'", s->warning);
        CHECK(!strcmp(s->params, "tess=3"), "params '%s'", s->params);
    }
    rt_scene_free(s);
}

static void test_transforms(void)
{
    rt_scene *s = expect_ok(
        "xf.pbrt",
        "WorldBegin\n"
        "AttributeBegin\n"
        "  Translate 1 2 3\n"
        "  AttributeBegin\n"
        "    Scale 2 2 2\n"
        "    Rotate 90 0 0 1\n"
        "    Shape \"trianglemesh\" \"point3 P\" [ 1 0 0  0 1 0  0 0 1 ]\n" /* 0 */
        "  AttributeEnd\n"
        "  " TRI /* 1: translated only */
        "AttributeEnd\n" TRI /* 2: identity */
        "Transform [ 1 0 0 0  0 1 0 0  0 0 1 0  5 6 7 1 ]\n"
        "ConcatTransform [ 2 0 0 0  0 2 0 0  0 0 2 0  0 0 0 1 ]\n" TRI /* 3 */
        "Identity\nTranslate 100 0 0\nCoordinateSystem \"mine\"\nIdentity\n"
        "TransformBegin\n  Translate 0 0 9\n  Material \"diffuse\" \"rgb reflectance\" [ 0.1 0.2 0.3 ]\n"
        "TransformEnd\n" TRI /* 4: not moved, but the material stays */
        "CoordSysTransform \"mine\"\n" TRI /* 5 */
        "CoordSysTransform \"world\"\n" TRI, /* 6 */
        7);
    if (s) {
        const rt_tri *t = s->tri;
        CHECK(veq(t[0].p[0], 1, 4, 3) && veq(t[0].p[1], -1, 2, 3) && veq(t[0].p[2], 1, 2, 5),
              "T S R: (%g %g %g) (%g %g %g) (%g %g %g)", t[0].p[0].x, t[0].p[0].y, t[0].p[0].z, t[0].p[1].x,
              t[0].p[1].y, t[0].p[1].z, t[0].p[2].x, t[0].p[2].y, t[0].p[2].z);
        CHECK(veq(t[1].p[0], 1, 2, 3) && veq(t[1].p[1], 2, 2, 3) && veq(t[1].p[2], 1, 3, 3), "inner block restored");
        CHECK(veq(t[2].p[0], 0, 0, 0) && veq(t[2].p[1], 1, 0, 0), "outer block restored");
        CHECK(veq(t[3].p[0], 5, 6, 7) && veq(t[3].p[1], 7, 6, 7) && veq(t[3].p[2], 5, 8, 7),
              "Transform (column-major) then ConcatTransform: (%g %g %g)", t[3].p[1].x, t[3].p[1].y, t[3].p[1].z);
        CHECK(veq(t[4].p[1], 1, 0, 0) && s->shade[4].rgb[2] == 0.3f, "TransformEnd restores the matrix only");
        CHECK(veq(t[5].p[1], 101, 0, 0), "CoordSysTransform: (%g %g %g)", t[5].p[1].x, t[5].p[1].y, t[5].p[1].z);
        CHECK(veq(t[6].p[1], 1, 0, 0), "the world coordinate system");
        CHECK(s->shade[0].rgb[0] == 0.5f && s->shade[0].mat == 0, "pbrt's default material: diffuse 0.5");
    }
    rt_scene_free(s);
    /* Rotate about a general axis: 120 degrees about (1,1,1) permutes x -> y -> z */
    s = expect_ok("rot.pbrt", "WorldBegin\nRotate 120 1 1 1\n" TRI, 1);
    if (s)
        CHECK(vnear(s->tri[0].p[1], 0, 1, 0, 1e-6) && vnear(s->tri[0].p[2], 0, 0, 1, 1e-6),
              "Rotate 120 (1,1,1): (%g %g %g)", s->tri[0].p[1].x, s->tri[0].p[1].y, s->tri[0].p[1].z);
    rt_scene_free(s);
}

static int count_str(const char *hay, const char *needle)
{
    int n = 0;
    for (const char *p = hay; (p = strstr(p, needle)); p++) n++;
    return n;
}

static void test_instancing(void)
{
    rt_scene *s = expect_ok("inst.pbrt",
                            "WorldBegin\n"
                            "ObjectBegin \"pair\"\n"
                            "  Translate 0 0 1\n"
                            "  Material \"diffuse\" \"rgb reflectance\" [ 0.9 0.1 0.1 ]\n"
                            "  Shape \"trianglemesh\" \"point3 P\" [ 0 0 0  1 0 0  0 1 0 ]\n"
                            "  Shape \"trianglemesh\" \"point3 P\" [ 0 0 0  1 0 0  0 0 1 ]\n"
                            "ObjectEnd\n"
                            "ObjectBegin \"unused\"\n" TRI TRI TRI "ObjectEnd\n"
                            "Shape \"trianglemesh\" \"point3 P\" [ 5 5 5  6 5 5  5 6 5 ]\n"
                            "Translate 10 0 0\nObjectInstance \"pair\"\n"
                            "Translate 10 0 0\nObjectInstance \"pair\"\nObjectInstance \"pair\"\n"
                            "Shape \"trianglemesh\" \"point3 P\" [ 7 7 7  8 7 7  7 8 7 ]\n",
                            8);
    if (s) {
        CHECK(s->ninst == 3 && s->ntri_unique == 4 && s->ntri_inst == 6, "instances %u, unique %u, instanced %u",
              s->ninst, s->ntri_unique, s->ntri_inst);
        CHECK(veq(s->tri[0].p[0], 5, 5, 5) && s->shade[0].rgb[0] == 0.5f, "the triangle outside the objects");
        CHECK(veq(s->tri[1].p[0], 10, 0, 1) && veq(s->tri[1].p[1], 11, 0, 1) && veq(s->tri[1].p[2], 10, 1, 1),
              "first instance (%g %g %g)", s->tri[1].p[0].x, s->tri[1].p[0].y, s->tri[1].p[0].z);
        CHECK(veq(s->tri[2].p[2], 10, 0, 2) && s->shade[2].rgb[0] == 0.9f, "the object's material travels with it");
        CHECK(veq(s->tri[5].p[0], 20, 0, 1) && veq(s->tri[3].p[0], 20, 0, 1), "second and third instance");
        CHECK(veq(s->tri[7].p[0], 27, 7, 7), "a triangle after the instances stays last (%g %g %g)", s->tri[7].p[0].x,
              s->tri[7].p[0].y, s->tri[7].p[0].z);
    }
    rt_scene_free(s);
    /* objects of 3 triangles and more are recorded and made at the end (2
     * and fewer at once): the order is the file's either way */
    s = expect_ok("inst3.pbrt",
                  "WorldBegin\nObjectBegin \"three\"\n" TRI TRI TRI "ObjectEnd\nObjectBegin \"one\"\n" TRI "ObjectEnd\n"
                  "Shape \"trianglemesh\" \"point3 P\" [ 5 5 5  6 5 5  5 6 5 ]\n"
                  "Translate 10 0 0\nObjectInstance \"three\"\nObjectInstance \"one\"\n"
                  "Shape \"trianglemesh\" \"point3 P\" [ 7 7 7  8 7 7  7 8 7 ]\n"
                  "Translate 10 0 0\nObjectInstance \"three\"\n"
                  "Shape \"trianglemesh\" \"point3 P\" [ 9 9 9  8 9 9  9 8 9 ]\n",
                  10);
    if (s) {
        static const float x0[10] = {5, 10, 10, 10, 10, 17, 20, 20, 20, 29};
        int ok = 1;
        for (int i = 0; i < 10; i++) ok &= s->tri[i].p[0].x == x0[i];
        CHECK(ok, "instances in file order: x %g %g %g %g %g %g %g %g %g %g", s->tri[0].p[0].x, s->tri[1].p[0].x,
              s->tri[2].p[0].x, s->tri[3].p[0].x, s->tri[4].p[0].x, s->tri[5].p[0].x, s->tri[6].p[0].x,
              s->tri[7].p[0].x, s->tri[8].p[0].x, s->tri[9].p[0].x);
        CHECK(s->ninst == 3 && s->ntri_inst == 7 && s->ntri_unique == 7, "counts %u %u %u", s->ninst, s->ntri_inst,
              s->ntri_unique);
    }
    rt_scene_free(s);
    rt_err e = {0};
    s = load_text("inst3inf.pbrt",
                  "WorldBegin\nObjectBegin \"three\"\n" TRI TRI TRI "ObjectEnd\nScale 1e30 1e30 1e30\n"
                  "ObjectInstance \"three\"\n", NULL, &e);
    CHECK(!s && strstr(e.msg, "inst3inf.pbrt:8:16: ObjectInstance: vertex (1e+30, 0, 0) is not finite or beyond") &&
              count_str(e.msg, "inst3inf.pbrt") == 1,
          "deferred instance out of range: %s", s ? "accepted" : e.msg);
    rt_scene_free(s);
    s = expect_ok("noinst.pbrt", "WorldBegin\n" TRI, 1);
    if (s) CHECK(s->ninst == 0 && s->ntri_unique == 0 && s->ntri_inst == 0, "no instancing, no counts");
    rt_scene_free(s);
}

/* Writes text gzip-compressed as NAME in the temporary folder, in
 * `members` gzip members (split evenly), as gzip does for cat a.gz b.gz. */
static void write_gz(const char *name, const char *text, int members)
{
    size_t n = strlen(text), at = 0;
    FILE *f = fopen(check_path(name), "wb");
    CHECK(f != NULL, "cannot write %s", name);
    if (!f) return;
    for (int m = 0; m < members; m++) {
        size_t part = m == members - 1 ? n - at : n / (size_t)members;
        z_stream z;
        memset(&z, 0, sizeof z);
        CHECK(deflateInit2(&z, 9, Z_DEFLATED, 15 + 16, 8, Z_DEFAULT_STRATEGY) == Z_OK, "deflateInit2");
        uLong cap = deflateBound(&z, (uLong)part);
        unsigned char *out = malloc(cap);
        z.next_in = (unsigned char *)(uintptr_t)(text + at);
        z.avail_in = (uInt)part;
        z.next_out = out;
        z.avail_out = (uInt)cap;
        CHECK(deflate(&z, Z_FINISH) == Z_STREAM_END, "deflate");
        fwrite(out, 1, cap - z.avail_out, f);
        deflateEnd(&z);
        free(out);
        at += part;
    }
    fclose(f);
}

/* gzip by content: a .pbrt.gz top file, an Include of a .pbrt.gz, a
 * plymesh of a .ply.gz and a gzipped file under a plain name load the
 * same triangles as the plain files; two members concatenate; a cut or
 * damaged stream, and one that inflates past the limit, are refused with
 * the file and the compressed byte. */
static void test_gzip(void)
{
    const char *ply = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
                      "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
    write_gz("gz_m.ply.gz", ply, 1);
    write_gz("gz_inc.pbrt.gz", "Shape \"trianglemesh\" \"point3 P\" [ 0 0 5  1 0 5  0 1 5 ]\n", 1);
    const char *top = "WorldBegin\nInclude \"gz_inc.pbrt.gz\"\nTranslate 2 0 0\n"
                      "Shape \"plymesh\" \"string filename\" \"gz_m.ply.gz\"\n" TRI;
    write_gz("gz_top.pbrt.gz", top, 2);
    write_gz("gz_plain_name.pbrt", top, 1);
    write_text("gz_top_plain.pbrt", top);
    rt_err e = {0};
    rt_scene *a = rt_scene_load(check_path("gz_top.pbrt.gz"), &e);
    CHECK(a != NULL, "gz_top.pbrt.gz: %s", e.msg);
    rt_scene *b = rt_scene_load(check_path("gz_plain_name.pbrt"), &e);
    CHECK(b != NULL, "gz_plain_name.pbrt: %s", e.msg);
    rt_scene *c = rt_scene_load(check_path("gz_top_plain.pbrt"), &e);
    CHECK(c != NULL, "gz_top_plain.pbrt: %s", e.msg);
    if (a && b && c) {
        CHECK(a->ntri == 3 && b->ntri == 3 && c->ntri == 3, "triangles %u %u %u", a->ntri, b->ntri, c->ntri);
        CHECK(veq(a->tri[0].p[0], 0, 0, 5) && veq(a->tri[1].p[1], 3, 0, 0) && veq(a->tri[2].p[2], 2, 1, 0),
              "gzip geometry");
        CHECK(a->ntri == c->ntri && !memcmp(a->tri, c->tri, c->ntri * sizeof *c->tri) &&
                  !memcmp(b->tri, c->tri, c->ntri * sizeof *c->tri),
              "gzip and plain files give different triangles");
    }
    rt_scene_free(a);
    rt_scene_free(b);
    rt_scene_free(c);
    /* a .pbrt.gz spec takes parameters as a .pbrt one does */
    char spec[700];
    snprintf(spec, sizeof spec, "%s:tess=2", check_path("gz_top.pbrt.gz"));
    a = rt_scene_load(spec, &e);
    CHECK(a && a->ntri == 3 && !strcmp(a->params, "tess=2"), "%s: %s", spec, a ? a->params : e.msg);
    rt_scene_free(a);
    /* the PLY loader on its own, by content */
    a = rt_scene_load(check_path("gz_m.ply.gz"), &e);
    CHECK(a && a->ntri == 1, "gz_m.ply.gz: %s", a ? "wrong count" : e.msg);
    rt_scene_free(a);
    /* damaged: cut in the middle, a bad byte in the header's method */
    FILE *f = fopen(check_path("gz_top.pbrt.gz"), "rb");
    unsigned char buf[4096];
    size_t n = f ? fread(buf, 1, sizeof buf, f) : 0;
    if (f) fclose(f);
    CHECK(n > 40, "gz_top.pbrt.gz has %zu bytes", n);
    check_write_file(check_path("gz_cut.pbrt.gz"), buf, 30);
    a = rt_scene_load(check_path("gz_cut.pbrt.gz"), &e);
    CHECK(!a && strstr(e.msg, "gz_cut.pbrt.gz: truncated gzip data (the stream ends at compressed byte 30)"),
          "cut gzip: %s", a ? "accepted" : e.msg);
    rt_scene_free(a);
    buf[2] = 7; /* compression method must be 8 */
    check_write_file(check_path("gz_bad.pbrt"), buf, n);
    a = rt_scene_load(check_path("gz_bad.pbrt"), &e);
    CHECK(!a && strstr(e.msg, "gz_bad.pbrt: gzip data: unknown compression method"), "bad gzip: %s",
          a ? "accepted" : e.msg);
    CHECK(!a && !strchr(e.msg, '\n'), "one line");
    rt_scene_free(a);
    /* an Include that is cut names the including line */
    write_text("gz_inc_cut.pbrt", "WorldBegin\nInclude \"gz_cut.pbrt.gz\"\n");
    a = rt_scene_load(check_path("gz_inc_cut.pbrt"), &e);
    CHECK(!a && strstr(e.msg, "gz_inc_cut.pbrt:2:9: Include \"gz_cut.pbrt.gz\": truncated gzip data"), "cut include: %s",
          a ? "accepted" : e.msg);
    rt_scene_free(a);
    /* a bomb: 200 KB of comments compress to a few hundred bytes; the
     * limit is on the inflated bytes */
    size_t big = 200000;
    char *text = malloc(big + 200);
    CHECK(text != NULL, "malloc");
    if (!text) return;
    memset(text, '#', big);
    memcpy(text + big, "\nWorldBegin\n" TRI, strlen("\nWorldBegin\n" TRI) + 1);
    write_gz("gz_bomb.pbrt.gz", text, 1);
    write_gz("gz_bomb.ply.gz", text, 1);
    free(text);
    uint64_t keep = rt_scene_max_bytes;
    rt_scene_max_bytes = 100000;
    a = rt_scene_load(check_path("gz_bomb.pbrt.gz"), &e);
    CHECK(!a && strstr(e.msg, "gz_bomb.pbrt.gz: more than 100000 bytes (decompressed)"), "pbrt bomb: %s",
          a ? "accepted" : e.msg);
    rt_scene_free(a);
    a = rt_scene_load(check_path("gz_bomb.ply.gz"), &e);
    CHECK(!a && strstr(e.msg, "gz_bomb.ply.gz: more than 100000 bytes (decompressed) (RT_SCENE_MAX_BYTES)"),
          "ply bomb: %s", a ? "accepted" : e.msg);
    rt_scene_free(a);
    rt_scene_max_bytes = keep;
    a = rt_scene_load(check_path("gz_bomb.pbrt.gz"), &e);
    CHECK(a && a->ntri == 1, "the bomb under the normal limit: %s", a ? "wrong count" : e.msg);
    rt_scene_free(a);
    /* a pseudo-file whose size says 0 but whose reads go on (/proc): refused
     * at once, not read to the limit */
    if (access("/proc/self/status", R_OK) == 0) {
        write_text("gz_proc.pbrt", "WorldBegin\nInclude \"../../../../../../../../proc/self/status\"\n");
        a = rt_scene_load(check_path("gz_proc.pbrt"), &e);
        CHECK(!a && strstr(e.msg, "gz_proc.pbrt:2:9: ") && strstr(e.msg, "holds more than the 0 bytes it had when opened"),
              "/proc file: %s", a ? "accepted" : e.msg);
        rt_scene_free(a);
    }
    /* the reader itself: empty, one byte, the magic alone */
    char *out;
    size_t on;
    int gz;
    char why[200];
    CHECK(rt_sfile_read_mem("", 0, 10, &out, &on, &gz, why, sizeof why) == 0 && on == 0 && out[0] == 0 && !gz,
          "empty source");
    free(out);
    CHECK(rt_sfile_read_mem("x", 1, 10, &out, &on, &gz, why, sizeof why) == 0 && on == 1 && !strcmp(out, "x"),
          "one byte");
    free(out);
    CHECK(rt_sfile_read_mem("\x1f\x8b", 2, 10, &out, &on, &gz, why, sizeof why) < 0 && strstr(why, "truncated gzip"),
          "the magic alone: %s", why);
    CHECK(rt_sfile_read_mem("0123456789a", 11, 10, &out, &on, &gz, why, sizeof why) < 0 &&
              !strcmp(why, "more than 10 bytes"),
          "11 plain bytes over a limit of 10: %s", why);
    CHECK(rt_sfile_read_mem("0123456789", 10, 10, &out, &on, &gz, why, sizeof why) == 0 && on == 10, "10 of 10");
    free(out);
}

/* Asset paths as pbrt resolves them: relative to the file that names
 * them, ".." allowed, nested includes each relative to their own folder;
 * a missing file's message names the real folder it was looked for in. */
static void test_asset_paths(void)
{
    mkdir(check_path("pav"), 0700);
    mkdir(check_path("pav/parts"), 0700);
    mkdir(check_path("land"), 0700);
    mkdir(check_path("land/geometry"), 0700);
    const char *ply = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
                      "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
    write_text("land/geometry/mesh_00064.ply", ply);
    write_text("land/tree.pbrt", "Shape \"trianglemesh\" \"point3 P\" [ 0 0 9  1 0 9  0 1 9 ]\n");
    write_text("pav/parts/p.pbrt", "Include \"../../land/tree.pbrt\"\n"
                                   "Shape \"plymesh\" \"string filename\" \"../../land/geometry/mesh_00064.ply\"\n");
    write_text("pav/scene.pbrt", "WorldBegin\nShape \"plymesh\" \"string filename\" \"../land/geometry/mesh_00064.ply\"\n"
                                 "Translate 5 0 0\nInclude \"parts/p.pbrt\"\n");
    rt_err e = {0};
    rt_scene *s = rt_scene_load(check_path("pav/scene.pbrt"), &e);
    CHECK(s != NULL, "pav/scene.pbrt: %s", e.msg);
    if (s) {
        CHECK(s->ntri == 3, "pav: %u triangles", s->ntri);
        if (s->ntri == 3)
            CHECK(veq(s->tri[0].p[1], 1, 0, 0) && veq(s->tri[1].p[0], 5, 0, 9) && veq(s->tri[2].p[1], 6, 0, 0),
                  "pav geometry");
    }
    rt_scene_free(s);
    write_text("pav/miss.pbrt", "WorldBegin\nInclude \"parts/../nope.pbrt\"\n");
    s = rt_scene_load(check_path("pav/miss.pbrt"), &e);
    char want[900];
    char *real;
    real = realpath(check_path("pav"), NULL); /* parts/.. as the file system resolves it */
    snprintf(want, sizeof want, "miss.pbrt:2:9: Include \"parts/../nope.pbrt\": no such file in %s", real);
    CHECK(!s && strstr(e.msg, want), "missing: '%s' lacks '%s'", s ? "accepted" : e.msg, want);
    free(real);
    rt_scene_free(s);
}

static void test_includes(void)
{
    rt_err e = {0};
    rt_scene *s = rt_scene_load(srcfile("tests/data/pbrt/main.pbrt"), &e);
    CHECK(s != NULL, "main.pbrt: %s", e.msg);
    if (!s) return;
    CHECK(s->ntri == 5, "main.pbrt: %u triangles (4 from the quads, 1 from the import)", s->ntri);
    /* quads (0,1,4,3), (1,2,5,4) fanned, translated by x + 10 */
    if (s->ntri == 5) {
        CHECK(veq(s->tri[0].p[0], 10, 0, 0) && veq(s->tri[0].p[1], 11, 0, 0) && veq(s->tri[0].p[2], 11, 1, 0),
              "PLY quad 0, fan 0: (%g %g %g)", s->tri[0].p[2].x, s->tri[0].p[2].y, s->tri[0].p[2].z);
        CHECK(veq(s->tri[1].p[2], 10, 1, 0) && veq(s->tri[3].p[0], 11, 0, 0) && veq(s->tri[3].p[2], 11, 1, 0),
              "PLY fans");
        CHECK(veq(s->tri[4].p[1], 1, 0, 0) && s->shade[4].rgb[2] == 0.75f, "imported triangle and material");
        CHECK(s->shade[0].rgb[0] == 0.5f, "the PLY's triangles get the state's material");
    }
    CHECK(s->film_w == 40 && s->film_h == 30, "film %dx%d", s->film_w, s->film_h);
    rt_scene_free(s);
}


static double now_sec(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* Kept instances (RT_LOAD_KEEP_INSTANCES, scene.h): 70,000 instances of a
 * 972-triangle object, refused when flattened (test_amplification), load
 * holding one copy of the object, numbered as the 68,040,000 triangles of
 * the flattened scene; instances beyond the 2^32 - 2 triangle indices are
 * refused at the line of the first one over, naming the limit, before the
 * rest of the file is read. */
static void test_kept_limits(void)
{
    size_t cap = 70000 * 20 + 200, k = 0;
    char *text = malloc(cap);
    CHECK(text != NULL, "malloc");
    if (!text) return;
    k += (size_t)snprintf(text, cap, "WorldBegin\nObjectBegin \"s\"\nShape \"sphere\"\nObjectEnd\n");
    for (int i = 0; i < 70000; i++) k += (size_t)snprintf(text + k, cap - k, "ObjectInstance \"s\"\n");
    write_text("kept70k.pbrt", text);
    char spec[700];
    snprintf(spec, sizeof spec, "%s:tess=9", check_path("kept70k.pbrt"));
    rt_err e = {0};
    double t0 = now_sec();
    rt_scene *s = rt_scene_load_flags(spec, RT_LOAD_KEEP_INSTANCES, &e);
    double dt = now_sec() - t0;
    CHECK(s && s->kept && s->ntri == 0 && s->notri == 972 && s->nirec == 70000 && s->nflat == 70000u * 972 &&
              rt_scene_nshade(s) == 972,
          "70000 kept instances: %s", s ? "wrong counts" : e.msg);
    CHECK(!s || rt_scene_check_kept(s, &e) == 0, "70000 kept instances: %s", e.msg);
    CHECK(dt < 5.0, "70000 kept instances loaded in %.3f s", dt);
    rt_scene_free(s);
    /* a tetrahedron subdivided 8 times: 4 x 4^8 = 262,144 triangles; the
     * 16,384th instance reaches 2^32 > 2^32 - 2 */
    k = (size_t)snprintf(text, cap, "WorldBegin\nObjectBegin \"t\"\nShape \"loopsubdiv\" \"integer levels\" 8 "
                                    "\"point3 P\" [0 0 0 1 0 0 0 1 0 0 0 1] \"integer indices\" [0 2 1 0 1 3 0 3 2 1 2 3]\n"
                                    "ObjectEnd\n");
    for (int i = 0; i < 17000; i++) k += (size_t)snprintf(text + k, cap - k, "ObjectInstance \"t\"\n");
    write_text("kept4g.pbrt", text);
    s = rt_scene_load_flags(check_path("kept4g.pbrt"), RT_LOAD_KEEP_INSTANCES, &e);
    char want[200];
    snprintf(want, sizeof want, "kept4g.pbrt:%d:16: the instances would make %llu triangles, more than the 4294967294 "
             "triangle indices", 4 + 16384, 16384ULL * 262144);
    CHECK(!s && strstr(e.msg, want), "kept, 17000 x 262144: '%s' lacks '%s'", s ? "accepted" : e.msg, want);
    rt_scene_free(s);
    free(text);
}

/* Amplification is refused before anything is allocated: a 131-byte
 * tetrahedron at levels 12 (4 x 4^12 = 2^26 triangles, exactly maxtri),
 * 70,000 instances of a 972-triangle object (68 M triangles > maxtri), each
 * in well under a second, naming the limit and the spec parameter that
 * raises it. */
static void test_amplification(void)
{
    const char *tet = "WorldBegin\nShape \"loopsubdiv\" \"integer levels\" 12\n"
                      "\"point3 P\" [0 0 0 1 0 0 0 1 0 0 0 1]\n\"integer indices\" [0 2 1 0 1 3 0 3 2 1 2 3]\n";
    CHECK(strlen(tet) == 131, "the tetrahedron file has %zu bytes", strlen(tet));
    double t0 = now_sec();
    expect_fail("tet12.pbrt", tet,
                "tet12.pbrt:2:20: Shape \"loopsubdiv\": 4 faces at levels 12 make over 16777216 triangles, more "
                "than maxsubdiv=4194304 (raise it with the spec parameter FILE.pbrt:maxsubdiv=N)");
    double dt = now_sec() - t0;
    CHECK(dt < 0.5, "levels 12 refused after %.3f s", dt);
    rt_err e = {0};
    rt_scene *s;
    s = load_text("tet3.pbrt", tet, "maxsubdiv=256", &e);
    CHECK(!s && strstr(e.msg, "more than maxsubdiv=256"), "levels 12 at maxsubdiv=256: %s", s ? "accepted" : e.msg);
    rt_scene_free(s);
    s = load_text("tet12c.pbrt", tet, "maxsubdiv=100000000,maxtri=1000", &e);
    CHECK(!s && strstr(e.msg, "tet12c.pbrt:2:7: the scene would have 67108864 triangles, more than maxtri=1000 "
                              "(raise it with the spec parameter FILE.pbrt:maxtri=N)"),
          "maxtri message: %s", s ? "accepted" : e.msg);
    rt_scene_free(s);
    /* instances: counted before they are made */
    size_t cap = 70000 * 20 + 200, k = 0;
    char *text = malloc(cap);
    CHECK(text != NULL, "malloc");
    if (!text) return;
    k += (size_t)snprintf(text, cap, "WorldBegin\nObjectBegin \"s\"\nShape \"sphere\"\nObjectEnd\n");
    for (int i = 0; i < 70000; i++) k += (size_t)snprintf(text + k, cap - k, "ObjectInstance \"s\"\n");
    t0 = now_sec();
    s = load_text("inst70k.pbrt", text, "tess=9", &e);
    dt = now_sec() - t0;
    /* 12 x 9 x 9 = 972 triangles each; instance 69043 is the first over 2^26 (69043 x 972 > 67108864 >= 69042 x 972),
     * on line 4 + 69043 */
    char want[160];
    snprintf(want, sizeof want, "inst70k.pbrt:%d:16: the scene would have %llu triangles, more than maxtri=67108864",
             4 + 69043, 69043ULL * 972);
    CHECK(!s && strstr(e.msg, want), "70000 instances: '%s' lacks '%s'", e.msg, want);
    CHECK(dt < 2.0, "70000 instances refused after %.3f s", dt);
    rt_scene_free(s);
    free(text);
    /* 70,000 distinct conductors, each on a triangle: the table's limit
     * is met at the 65,536th (entry 0 is the plain one) with its line, in
     * linear time (hashed lookup) */
    cap = 70000 * 140 + 100;
    text = malloc(cap);
    CHECK(text != NULL, "malloc");
    if (!text) return;
    k = (size_t)snprintf(text, cap, "WorldBegin\n");
    for (int i = 1; i <= 70000; i++)
        k += (size_t)snprintf(text + k, cap - k, "Material \"conductor\" \"rgb reflectance\" [ %.7f 0.5 0.5 ]\n" TRI,
                              i * 1e-6);
    t0 = now_sec();
    s = load_text("mat70k.pbrt", text, NULL, &e);
    dt = now_sec() - t0;
    snprintf(want, sizeof want, "mat70k.pbrt:%d:7: ", 1 + 2 * 65536);
    CHECK(!s && strstr(e.msg, want) && strstr(e.msg, "more than 65536 distinct materials") && count_str(e.msg, "mat70k") == 1,
          "70000 materials: '%s' lacks '%s'", s ? "accepted" : e.msg, want);
    CHECK(dt < 3.0, "70000 materials refused after %.3f s", dt);
    rt_scene_free(s);
    free(text);
}

static void test_loopsubdiv(void)
{
    static const char tetra[] = "WorldBegin\nShape \"loopsubdiv\" \"integer levels\" %d\n"
                                "  \"point3 P\" [ 1 1 1  1 -1 -1  -1 1 -1  -1 -1 1 ]\n"
                                "  \"integer indices\" [ 0 1 2  0 2 3  0 3 1  1 3 2 ]\n";
    for (int level = 0; level <= 2; level++) {
        char text[400], name[32];
        snprintf(text, sizeof text, tetra, level);
        snprintf(name, sizeof name, "loop%d.pbrt", level);
        rt_scene *s = expect_ok(name, text, 4u << (2 * level));
        if (!s) continue;
        /* an original vertex's limit point: 2/5 p + 1/5 (sum of the others) = p/5, at every level */
        CHECK(vnear(s->tri[0].p[0], 0.2, 0.2, 0.2, 1e-6), "level %d: vertex 0 at (%.9g %.9g %.9g), expected 0.2", level,
              s->tri[0].p[0].x, s->tri[0].p[0].y, s->tri[0].p[0].z);
        if (level == 1) /* edge (0,1): (a + b) / 4 on level 1, valence 6: 1/2 m + 1/12 sum = 7/48 (a + b) */
            CHECK(vnear(s->tri[0].p[1], 14.0 / 48, 0, 0, 1e-6), "level 1: edge vertex (%.9g %.9g %.9g), expected 7/24",
                  s->tri[0].p[1].x, s->tri[0].p[1].y, s->tri[0].p[1].z);
        rt_scene_free(s);
    }
    /* boundary rules on one triangle */
    rt_scene *s = expect_ok("loopb0.pbrt",
                            "WorldBegin\nShape \"loopsubdiv\" \"integer levels\" 0 \"point3 P\" [ 0 0 0 1 0 0 0 1 0 ] "
                            "\"integer indices\" [ 0 1 2 ]\n",
                            1);
    if (s) /* 3/5 p + 1/5 (q + r) */
        CHECK(vnear(s->tri[0].p[0], 0.2, 0.2, 0, 1e-6) && vnear(s->tri[0].p[1], 0.6, 0.2, 0, 1e-6),
              "boundary limit (%g %g %g)", s->tri[0].p[1].x, s->tri[0].p[1].y, s->tri[0].p[1].z);
    rt_scene_free(s);
    s = expect_ok("loopb1.pbrt",
                  "WorldBegin\nShape \"loopsubdiv\" \"integer levels\" 1 \"point3 P\" [ 0 0 0 1 0 0 0 1 0 ] "
                  "\"integer indices\" [ 0 1 2 ]\n",
                  4);
    /* edge (0,1): (1/2, 0, 0); its boundary neighbours (1/8, 1/8, 0), (3/4, 1/8, 0); limit 3/5 m + 1/5 (...) */
    if (s)
        CHECK(vnear(s->tri[0].p[1], 0.475, 0.05, 0, 1e-6), "boundary edge limit (%.9g %.9g %.9g), expected (0.475 0.05 0)",
              s->tri[0].p[1].x, s->tri[0].p[1].y, s->tri[0].p[1].z);
    rt_scene_free(s);
    expect_fail("loopbad.pbrt",
                "WorldBegin\nShape \"loopsubdiv\" \"point3 P\" [ 0 0 0 1 0 0 0 1 0 0 0 1 ] "
                "\"integer indices\" [ 0 1 2  0 1 3 ]\n",
                "loopbad.pbrt:2:7: Shape \"loopsubdiv\": faces 0 and 1 run along edge 0-1 the same way");
    expect_fail("loopbig.pbrt",
                "WorldBegin\nShape \"loopsubdiv\" \"integer levels\" 40 \"point3 P\" [ 0 0 0 1 0 0 0 1 0 ] "
                "\"integer indices\" [ 0 1 2 ]\n",
                "loopbig.pbrt:2:20: Shape \"loopsubdiv\": 1 faces at levels 40 make over 16777216 triangles, more than "
                "maxsubdiv=4194304 (raise it with the spec parameter FILE.pbrt:maxsubdiv=N)");
    test_amplification();
    test_kept_limits();
}

static void test_shapes(void)
{
    rt_err e = {0};
    /* sphere: tessellation from the spec, radius and placement from the file */
    rt_scene *s = load_text("sph.pbrt", "WorldBegin\nTranslate 0 0 5\nShape \"sphere\" \"float radius\" 2\n", "tess=2",
                            &e);
    CHECK(s && s->ntri == 48, "tess=2 sphere: %u triangles (%s)", s ? s->ntri : 0, e.msg);
    if (s) {
        double worst = 0;
        for (uint32_t i = 0; i < s->ntri; i++)
            for (int k = 0; k < 3; k++) {
                rt_vec3 p = s->tri[i].p[k];
                double d = sqrt((double)p.x * p.x + (double)p.y * p.y + ((double)p.z - 5) * (p.z - 5));
                if (fabs(d - 2) > worst) worst = fabs(d - 2);
            }
        CHECK(worst < 1e-6, "sphere vertices off the radius by %g", worst);
        CHECK(!strcmp(s->params, "tess=2"), "params '%s'", s->params);
    }
    rt_scene_free(s);
    s = expect_ok("sph3.pbrt", "WorldBegin\nShape \"sphere\" \"float zmax\" 0.5\n", 108);
    if (s) CHECK(strstr(s->warning, "sph3.pbrt:2: Shape \"sphere\": zmin, zmax and phimax ignored"), "'%s'", s->warning);
    rt_scene_free(s);
    s = load_text("sph4.pbrt", "WorldBegin\nShape \"sphere\"\n", "tess=65", &e);
    CHECK(!s && strstr(e.msg, "tess=65 out of range 1..64"), "tess=65: %s", e.msg);
    rt_scene_free(s);
    s = load_text("sph5.pbrt", "WorldBegin\nShape \"sphere\"\n", "colour=1", &e);
    CHECK(!s && strstr(e.msg, "unknown parameter 'colour'"), "colour=1: %s", e.msg);
    rt_scene_free(s);
    /* bilinear patches p00 p10 p01 p11: (p00 p10 p11), (p00 p11 p01) */
    s = expect_ok("bil.pbrt",
                  "WorldBegin\nShape \"bilinearmesh\" \"point3 P\" [ 0 0 0  2 0 0  0 3 0  2 3 0  4 0 0  4 3 0 ]\n"
                  "  \"integer indices\" [ 0 1 2 3  1 4 3 5 ]\n",
                  4);
    if (s)
        CHECK(veq(s->tri[0].p[2], 2, 3, 0) && veq(s->tri[1].p[1], 2, 3, 0) && veq(s->tri[1].p[2], 0, 3, 0) &&
                  veq(s->tri[2].p[1], 4, 0, 0) && veq(s->tri[3].p[2], 2, 3, 0),
              "bilinear split");
    rt_scene_free(s);
    s = expect_ok("bil1.pbrt", "WorldBegin\nShape \"bilinearmesh\" \"point3 P\" [ 0 0 0  1 0 0  0 1 0  1 1 0 ]\n", 2);
    rt_scene_free(s);
    /* trianglemesh with indices and shared vertices */
    s = expect_ok("tm.pbrt",
                  "WorldBegin\nShape \"trianglemesh\" \"point3 P\" [ 0 0 0 1 0 0 1 1 0 0 1 0 ] \"integer indices\" "
                  "[ 0 1 2 0 2 3 ] \"normal N\" [ 0 0 1 0 0 1 0 0 1 0 0 1 ] \"point2 uv\" [ 0 0 1 0 1 1 0 1 ]\n",
                  2);
    if (s) CHECK(veq(s->tri[1].p[2], 0, 1, 0), "indexed corner");
    rt_scene_free(s);
}

static int rgb_is(const float *c, float r, float g, float b) { return c[0] == r && c[1] == g && c[2] == b; }

/* disk (fan, annulus), cylinder (one band) at 8 x tess segments over
 * phimax, vertices checked against libm; interface material and alpha 0
 * leave a shape out, partial and texture alpha warn */
static void test_shapes2(void)
{
    rt_scene *s = expect_ok("disk.pbrt", "WorldBegin\nShape \"disk\" \"float radius\" 2 \"float height\" 0.5\n", 24);
    double c15 = cos(15 * M_PI / 180), s15 = sin(15 * M_PI / 180);
    if (s) {
        CHECK(vnear(s->tri[0].p[0], 0, 0, 0.5, 1e-7) && vnear(s->tri[0].p[1], 2, 0, 0.5, 1e-7) &&
                  vnear(s->tri[0].p[2], 2 * c15, 2 * s15, 0.5, 1e-6),
              "disk fan 0: (%g %g %g)", s->tri[0].p[2].x, s->tri[0].p[2].y, s->tri[0].p[2].z);
        CHECK(vnear(s->tri[23].p[2], 2, 0, 0.5, 1e-6), "the fan closes: (%g %g %g)", s->tri[23].p[2].x,
              s->tri[23].p[2].y, s->tri[23].p[2].z);
        CHECK(s->nwarn == 0, "disk warned: %s", s->warning);
    }
    rt_scene_free(s);
    s = expect_ok("ann.pbrt", "WorldBegin\nShape \"disk\" \"float innerradius\" 0.5 \"float phimax\" 90\n", 48);
    if (s) {
        double c = cos(90.0 / 24 * M_PI / 180), sn = sin(90.0 / 24 * M_PI / 180);
        CHECK(vnear(s->tri[0].p[0], 0.5, 0, 0, 1e-7) && vnear(s->tri[1].p[2], 0.5 * c, 0.5 * sn, 0, 1e-6) &&
                  vnear(s->tri[47].p[1], 0, 1, 0, 1e-6),
              "annulus over 90 degrees");
    }
    rt_scene_free(s);
    rt_err e = {0};
    s = load_text("cyl.pbrt", "WorldBegin\nShape \"cylinder\" \"float radius\" 3 \"float zmin\" 0 \"float zmax\" 2\n",
                  "tess=1", &e);
    CHECK(s && s->ntri == 16, "tess=1 cylinder: %u triangles (%s)", s ? s->ntri : 0, e.msg);
    if (s && s->ntri == 16) {
        double c45 = cos(M_PI / 4);
        CHECK(vnear(s->tri[0].p[0], 3, 0, 0, 1e-6) && vnear(s->tri[0].p[1], 3 * c45, 3 * c45, 0, 1e-6) &&
                  vnear(s->tri[0].p[2], 3 * c45, 3 * c45, 2, 1e-6) && vnear(s->tri[1].p[2], 3, 0, 2, 1e-6),
              "cylinder band 0");
        double worst = 0;
        for (uint32_t i = 0; i < s->ntri; i++)
            for (int k = 0; k < 3; k++) {
                rt_vec3 p = s->tri[i].p[k];
                double d = fabs(sqrt((double)p.x * p.x + (double)p.y * p.y) - 3);
                if (d > worst) worst = d;
            }
        CHECK(worst < 1e-6, "cylinder vertices off the radius by %g", worst);
    }
    rt_scene_free(s);
    expect_fail("cyl0.pbrt", "WorldBegin\nShape \"cylinder\" \"float zmin\" 1 \"float zmax\" 1\n",
                "cyl0.pbrt:2:7: Shape \"cylinder\": zmin and zmax coincide");
    expect_fail("disk0.pbrt", "WorldBegin\nShape \"disk\" \"float radius\" 1 \"float innerradius\" 1\n",
                "innerradius must be in [0, radius)");
    /* interface: the shapes are not made; alpha 0 likewise */
    s = expect_ok("iface.pbrt",
                  "WorldBegin\nAttributeBegin\nMaterial \"interface\"\nShape \"sphere\"\nShape \"disk\"\nAttributeEnd\n" TRI
                  "Shape \"sphere\" \"float alpha\" 0\n"
                  "Shape \"trianglemesh\" \"point3 P\" [ 0 0 1 1 0 1 0 1 1 ] \"float alpha\" 0.5\n"
                  "Shape \"trianglemesh\" \"point3 P\" [ 0 0 2 1 0 2 0 1 2 ] \"texture alpha\" \"leaf\"\n",
                  3);
    if (s) {
        CHECK(s->nwarn == 4, "%u kinds of warnings: %s", s->nwarn, s->warning);
        if (s->nwarn == 4) {
            CHECK(!strcmp(s->warn[0].kind, "interface") && s->warn[0].count == 2 && strstr(s->warn[0].first, "iface.pbrt:4"),
                  "interface warning '%s' x%u", s->warn[0].kind, s->warn[0].count);
            CHECK(!strcmp(s->warn[1].kind, "alpha 0") && strstr(s->warn[1].first, ":8"), "alpha 0 warning");
            CHECK(!strcmp(s->warn[2].kind, "alpha partial") && !strcmp(s->warn[3].kind, "alpha texture"),
                  "alpha warnings '%s' '%s'", s->warn[2].kind, s->warn[3].kind);
        }
        CHECK(veq(s->tri[1].p[0], 0, 0, 1) && veq(s->tri[2].p[0], 0, 0, 2), "the opaque shapes stay");
    }
    rt_scene_free(s);
    expect_fail("ifaceonly.pbrt", "WorldBegin\nMaterial \"interface\"\n" TRI, "no triangles");
    expect_fail("alpha2.pbrt", "WorldBegin\nShape \"sphere\" \"float alpha\" 2\n",
                "alpha2.pbrt:2:16: Shape \"sphere\": alpha 2 outside [0, 1]");
    expect_fail("alphas.pbrt", "WorldBegin\nShape \"sphere\" \"string alpha\" \"x\"\n", "\"alpha\" must be float or texture");
}

static void test_materials(void)
{
    rt_scene *s = expect_ok("mat.pbrt",
                            "WorldBegin\n"
                            "Material \"diffuse\" \"rgb reflectance\" [ 0.1 0.2 0.3 ]\n" TRI /* 0 */
                            "Material \"conductor\" \"rgb reflectance\" [ 0.9 0.8 0.7 ]\n" TRI /* 1 */
                            "Material \"conductor\" \"rgb eta\" [ 0.2 0.2 0.2 ] \"rgb k\" [ 3 3 3 ]\n" TRI /* 2 */
                            "Material \"dielectric\" \"float eta\" 1.33\n" TRI /* 3 */
                            "Material \"coateddiffuse\" \"rgb reflectance\" [ 0.4 0.5 0.6 ]\n" TRI /* 4 */
                            "Material \"hair\"\n" TRI /* 5 */
                            "MakeNamedMaterial \"gold\" \"string type\" \"conductor\" \"rgb reflectance\" [ 1 0.8 0.3 ]\n"
                            "NamedMaterial \"gold\"\n" TRI /* 6 */
                            "Material \"diffuse\"\n" TRI /* 7 */
                            "Material \"conductor\"\n" TRI /* 8: pbrt's default copper */
                            "Material \"diffuse\" \"spectrum reflectance\" [ 400 0.2 700 0.4 ]\n" TRI /* 9 */
                            "AttributeBegin\n AreaLightSource \"diffuse\" \"rgb L\" [ 2 3 4 ] \"float scale\" 0.5\n"
                            " Material \"diffuse\" \"rgb reflectance\" [ 0.1 0.2 0.3 ]\n" TRI /* 10 */
                            "AttributeEnd\n" TRI, /* 11: the light ends with the block */
                            12);
    if (!s) return;
    const rt_material *M = s->mat;
    CHECK(rgb_is(s->shade[0].rgb, 0.1f, 0.2f, 0.3f) && s->shade[0].mat == 0, "diffuse: colour, plain material");
    const rt_material *m1 = &M[s->shade[1].mat];
    CHECK(s->shade[1].mat && rgb_is(m1->ks, 0.9f, 0.8f, 0.7f) && (m1->flags & RT_MAT_SPECULAR) &&
              rgb_is(s->shade[1].rgb, 0.9f, 0.8f, 0.7f),
          "conductor reflectance -> mirror ks");
    float f0 = (float)(9.64 / 10.44); /* ((n-1)^2 + k^2) / ((n+1)^2 + k^2), n 0.2, k 3 */
    CHECK(check_near(M[s->shade[2].mat].ks[0], f0, 1e-6, 0), "conductor eta, k -> F0 %g, expected %g",
          M[s->shade[2].mat].ks[0], f0);
    const rt_material *m3 = &M[s->shade[3].mat];
    CHECK(rgb_is(m3->kt, 1, 1, 1) && m3->ior == 1.33f && (m3->flags & RT_MAT_TRANSMIT) && m3->ks[0] == 0,
          "dielectric -> glass with eta");
    const rt_material *m4 = &M[s->shade[4].mat];
    CHECK(rgb_is(s->shade[4].rgb, 0.4f, 0.5f, 0.6f) && check_near(m4->ks[0], 0.04, 1e-6, 0) && m4->kt[0] == 0,
          "coateddiffuse -> diffuse + specular 0.04 (ks %g)", m4->ks[0]);
    CHECK(s->shade[5].mat == 0 && rgb_is(s->shade[5].rgb, 0.5f, 0.5f, 0.5f), "unsupported -> plain diffuse 0.5");
    CHECK(rgb_is(M[s->shade[6].mat].ks, 1, 0.8f, 0.3f) && !strcmp(M[s->shade[6].mat].name, "gold"), "named material");
    CHECK(s->shade[7].mat == 0 && rgb_is(s->shade[7].rgb, 0.5f, 0.5f, 0.5f), "default diffuse reflectance 0.5");
    CHECK(rgb_is(M[s->shade[8].mat].ks, 0.955f, 0.638f, 0.538f), "default conductor: copper");
    CHECK(check_near(s->shade[9].rgb[0], 0.3, 1e-6, 0), "spectrum -> mean grey %g", s->shade[9].rgb[0]);
    const rt_material *m10 = &M[s->shade[10].mat];
    CHECK(rgb_is(m10->ke, 1, 1.5f, 2) && (m10->flags & RT_MAT_EMIT) && rgb_is(s->shade[10].rgb, 0.1f, 0.2f, 0.3f),
          "area light -> ke = L x scale (%g %g %g)", m10->ke[0], m10->ke[1], m10->ke[2]);
    CHECK(s->shade[11].mat == 0, "the area light ends with its block");
    CHECK(s->shade[1].mat != s->shade[6].mat && s->shade[0].mat == s->shade[7].mat, "table entries shared when equal");
    CHECK(strstr(s->warning, "mat.pbrt:12: Material \"hair\" not supported") != NULL, "warning '%s'", s->warning);
    rt_scene_free(s);
}

static void test_camera(void)
{
    rt_scene *s = expect_ok("cam.pbrt",
                            "LookAt 0 0 5  0 0 0  0 1 0\nCamera \"perspective\" \"float fov\" 45\n"
                            "Film \"rgb\" \"integer xresolution\" 200 \"integer yresolution\" 100\nWorldBegin\n" TRI,
                            1);
    if (s) {
        CHECK(veq(s->cam.eye, 0, 0, 5) && veq(s->cam.at, 0, 0, 4) && veq(s->cam.up, 0, 1, 0), "LookAt frame");
        CHECK(s->cam.fovy_deg == 45.0f && s->cam.mirror == 1, "wide film: fovy %g, mirror %d", s->cam.fovy_deg,
              s->cam.mirror);
        CHECK(s->film_w == 200 && s->film_h == 100, "film");
        rt_cam_frame f;
        rt_cam_setup(&f, s, 200, 100);
        /* pbrt: image right = up x dir = y x -z = -x */
        CHECK(f.right.x < 0, "pbrt's screen: image x along -x (right %g)", f.right.x);
        CHECK(s->light[0].z == 5 && s->light[2].z == 5, "no lights: at the camera");
    }
    rt_scene_free(s);
    s = expect_ok("cam2.pbrt",
                  "Scale -1 1 1\nLookAt 0 0 5  0 0 0  0 1 0\nCamera \"perspective\" \"float fov\" 90\n"
                  "Film \"rgb\" \"integer xresolution\" 100 \"integer yresolution\" 200\nWorldBegin\n" TRI,
                  1);
    if (s) {
        /* tall film: the fov spans x; vertical half-tangent 2: 2 atan 2 */
        CHECK(check_near(s->cam.fovy_deg, 126.86989764584402, 1e-6, 0), "tall film: fovy %.9g", s->cam.fovy_deg);
        CHECK(s->cam.mirror == 0, "Scale -1 1 1: right-handed view");
        rt_cam_frame f;
        rt_cam_setup(&f, s, 100, 200);
        CHECK(f.right.x > 0, "mirrored camera: image x along +x");
        CHECK(veq(s->cam.eye, 0, 0, 5), "eye");
    }
    rt_scene_free(s);
    s = expect_ok("cam3.pbrt",
                  "LookAt 0 0 5  0 0 0  0 1 0\nCamera \"perspective\" \"float fov\" 90 \"float screenwindow\" [ -1 1 "
                  "-0.5 0.5 ]\nWorldBegin\n" TRI,
                  1);
    if (s) CHECK(check_near(s->cam.fovy_deg, 53.13010235415598, 1e-6, 0), "screenwindow: fovy %.9g", s->cam.fovy_deg);
    rt_scene_free(s);
    s = expect_ok("cam4.pbrt",
                  "LookAt 0 0 5  0 0 0  0 1 0\nCamera \"perspective\" \"float frameaspectratio\" 0.5\nWorldBegin\n" TRI,
                  1);
    if (s) CHECK(check_near(s->cam.fovy_deg, 126.86989764584402, 1e-6, 0), "frameaspectratio: fovy %.9g", s->cam.fovy_deg);
    rt_scene_free(s);
    /* no Camera: auto-framed like a mesh file */
    s = expect_ok("cam5.pbrt", "WorldBegin\n" TRI, 1);
    if (s) CHECK(s->cam.fovy_deg == 45.0f && s->cam.mirror == 0 && s->film_w == 0, "auto-framed");
    rt_scene_free(s);
}

static void test_lights(void)
{
    rt_scene *s = expect_ok("lights.pbrt",
                            "LookAt 0 0 5  0 0 0  0 1 0\nCamera \"perspective\"\nWorldBegin\n"
                            "AttributeBegin\n  Translate 1 0 0\n  LightSource \"point\" \"point3 from\" [ 0 0 5 ] "
                            "\"rgb I\" [ 5 5 5 ]\nAttributeEnd\n"                                    /* 4-7 */
                            "AttributeBegin\n  AreaLightSource \"diffuse\" \"rgb L\" [ 1 1 1 ]\n"
                            "  Shape \"trianglemesh\" \"point3 P\" [ 0 0 1  0 1 1  1 0 1 ]\nAttributeEnd\n" /* 8-11 */
                            "LightSource \"spot\" \"point3 from\" [ 0 2 0 ] \"point3 to\" [ 0 0 0 ]\n"       /* 12 */
                            "Shape \"trianglemesh\" \"point3 P\" [ -1 -1 0  1 -1 0  0 1 0 ]\n"                /* 13 */
                            "AttributeBegin\n  AreaLightSource \"diffuse\"\n"
                            "  Shape \"trianglemesh\" \"point3 P\" [ 0 0 1  0 -1 1  -1 0 1 ]\nAttributeEnd\n" /* 14-17 */
                            "LightSource \"infinite\"\n",                                            /* 18 */
                            3);
    if (s) {
        CHECK(veq(s->light[0], 1, 0, 5) && veq(s->light[1], 0, 2, 0), "point and spot lights first: (%g %g %g)",
              s->light[0].x, s->light[0].y, s->light[0].z);
        /* the first area light: centroid (1/3, 1/3, 1), facing down, 0.025 x diagonal 3 below */
        CHECK(vnear(s->light[2], 1.0 / 3, 1.0 / 3, 0.925, 1e-6), "area light (%.9g %.9g %.9g)", s->light[2].x,
              s->light[2].y, s->light[2].z);
        CHECK(strstr(s->warning, "lights.pbrt:16: more than 3 lights") != NULL, "warning '%s'", s->warning);
        CHECK(strstr(s->warning, "lights.pbrt:18: LightSource \"infinite\" skipped") != NULL, "warning '%s'",
              s->warning);
    }
    rt_scene_free(s);
}

static void test_warnings(void)
{
    rt_scene *s = expect_ok("warn.pbrt",
                            "Sampler \"halton\" \"integer pixelsamples\" 16\n"
                            "Integrator \"path\"\n"
                            "Sampler \"sobol\"\n"
                            "ColorSpace \"srgb\"\nOption \"bool disablepixeljitter\" true\n"
                            "WorldBegin\n"
                            "Texture \"t\" \"spectrum\" \"imagemap\" \"string filename\" \"x.png\"\n"
                            "Shape \"nurbs\"\nShape \"nurbs\" \"float radius\" 2\n"
                            "ReverseOrientation\n" TRI,
                            1);
    if (s) {
        CHECK(strstr(s->warning, "warn.pbrt:1: Sampler skipped") != NULL, "'%s'", s->warning);
        CHECK(strstr(s->warning, "warn.pbrt:2: Integrator skipped") != NULL, "'%s'", s->warning);
        const char *w = strstr(s->warning, "Sampler");
        CHECK(w && !strstr(w + 1, "Sampler"),
              "one warning per kind: '%s'", s->warning);
        static const char *const kinds[] = {"ColorSpace", "Option", "warn.pbrt:7: Texture", "warn.pbrt:8: Shape \"nurbs\"",
                                            "ReverseOrientation"};
        for (int i = 0; i < 5; i++) CHECK(strstr(s->warning, kinds[i]) != NULL, "no warning for %s", kinds[i]);
    }
    rt_scene_free(s);
    /* more kinds than fit: the rest are counted */
    char text[2000] = "WorldBegin\n" TRI;
    for (int i = 0; i < 40; i++) {
        size_t k = strlen(text);
        snprintf(text + k, sizeof text - k, "Shape \"kind%d\"\n", i);
    }
    {
        size_t k = strlen(text);
        snprintf(text + k, sizeof text - k, "Shape \"kind3\"\nShape \"kind3\"\nSampler \"x\"\n");
    }
    s = expect_ok("warn2.pbrt", text, 1);
    if (s) {
        CHECK(strstr(s->warning, "more kinds of warnings)") != NULL && strlen(s->warning) < sizeof s->warning,
              "overflow: '%s'", s->warning);
        /* every kind is kept, counted, with its first line */
        CHECK(s->nwarn == 41, "%u kinds of warnings, expected 41", s->nwarn);
        if (s->nwarn == 41) {
            CHECK(!strcmp(s->warn[3].kind, "Shape \"kind3\"") && s->warn[3].count == 3 &&
                      strstr(s->warn[3].first, "warn2.pbrt:6") && !strcmp(s->warn[3].msg, "Shape \"kind3\" skipped"),
                  "kind3: '%s' x%u at '%s': '%s'", s->warn[3].kind, s->warn[3].count, s->warn[3].first, s->warn[3].msg);
            CHECK(!strcmp(s->warn[40].kind, "Sampler") && s->warn[40].count == 1 && strstr(s->warn[40].first, ":45"),
                  "Sampler: '%s' at '%s'", s->warn[40].kind, s->warn[40].first);
            CHECK(s->warn[39].count == 1 && strstr(s->warn[39].first, "warn2.pbrt:42"), "kind39 at '%s'",
                  s->warn[39].first);
        }
    }
    rt_scene_free(s);
    /* more kinds than are kept: the last entry counts the others */
    size_t cap = 300 * 24 + 100, k = 0;
    char *big = malloc(cap);
    CHECK(big != NULL, "malloc");
    if (!big) return;
    k = (size_t)snprintf(big, cap, "WorldBegin\n" TRI);
    for (int i = 0; i < 300; i++) k += (size_t)snprintf(big + k, cap - k, "Shape \"k%d\"\n", i);
    s = expect_ok("warn3.pbrt", big, 1);
    if (s) CHECK(s->nwarn == 256 && !strcmp(s->warn[255].kind, "other") && s->warn[255].count == 300 - 255,
                 "300 kinds: %u entries, last '%s' x%u", s->nwarn, s->nwarn ? s->warn[s->nwarn - 1].kind : "",
                 s->nwarn ? s->warn[s->nwarn - 1].count : 0);
    rt_scene_free(s);
    free(big);
}

static void test_errors(void)
{
    static const struct {
        const char *text, *needle;
    } bad[] = {
        {"WorldBegin\nFoo 1 2\n", "e.pbrt:2:1: unknown directive 'Foo' (not a pbrt directive)"},
        {"WorldBegin\nInclude \"nope.pbrt\"\n", "e.pbrt:2:9: Include \"nope.pbrt\": no such file"},
        {"WorldBegin\nAttributeEnd\n", "e.pbrt:2:1: AttributeEnd without a matching AttributeBegin"},
        {"WorldBegin\nAttributeBegin\n" TRI, "the AttributeBegin at "},
        {"WorldBegin\nTransformBegin\nAttributeEnd\n", "e.pbrt:3:1: AttributeEnd closes the TransformBegin at"},
        {"WorldBegin\nShape \"trianglemesh\" \"float P\" [ 0 0 0 1 0 0 0 1 0 ]\n", "e.pbrt:2:22: parameter \"float P\": \"P\" must be point3"},
        {"WorldBegin\nShape \"trianglemesh\" \"point3 P\" [ 0 0 0 1 0 0 0 1 ]\n", "8 values, expected a multiple of 3"},
        {"WorldBegin\nShape \"trianglemesh\" \"point3 P\" [ 0 0 0 1 0 0 0 1 0 ] \"integer indices\" [ 0 1 3 ]\n",
         "index 3 (entry 2) out of range (3 vertices)"},
        {"WorldBegin\nShape \"trianglemesh\" \"point3 P\" [ 0 0 0 1 0 0 0 1 0 0 0 1 ]\n", "\"integer indices\" missing"},
        {"WorldBegin\nShape \"trianglemesh\" \"point3 P\" [ 0 0 0 1 0 0 0 1 0 ] \"integer indices\" [ 0 1 2.5 ]\n",
         "2.5' is not an integer"},
        {"WorldBegin\nShape \"trianglemesh\" \"point3 P\" [ 0 0 0 1 0 0 0 1 0 ] \"integer indices\" [ 0 1 4000000000 ]\n",
         "is not an integer"},
        {"Film \"rgb\" \"integer xresolution\" 1000000000\nWorldBegin\n" TRI, "Film: resolution 1000000000x720 outside 1..65536"},
        {"WorldBegin\nShape \"trianglemesh\" \"colour P\" [ 0 ]\n", "unknown parameter type 'colour'"},
        {"WorldBegin\nShape \"trianglemesh\" \"point3 P\"\n", "expected a value"},
        {"WorldBegin\nShape \"trianglemesh\" \"point3 P\" [ 0 0 0 1 0 0 0 1 0\n", "expected a value or ']'"},
        {"WorldBegin\nShape \"trianglemesh \"point3 P\" [ 0 ]\n", "e.pbrt:2:22: unknown directive 'point3'"},
        {"WorldBegin\nShape \"trianglemesh\n", "e.pbrt:2:7: string without its closing"},
        {"WorldBegin\nShape \"trianglemesh\" \"point3 P\" [ 0 0 0 1 0 0 0 1 1e999 ]\n", "out of range"},
        {TRI, "e.pbrt:1:1: Shape before WorldBegin"},
        {"WorldBegin\nCamera \"perspective\"\n", "e.pbrt:2:1: Camera inside the world block"},
        {"WorldBegin\nObjectInstance \"x\"\n", "ObjectInstance \"x\": no such object"},
        {"WorldBegin\nNamedMaterial \"x\"\n", "NamedMaterial \"x\": no such material"},
        {"WorldBegin\nObjectBegin \"a\"\nObjectBegin \"b\"\n", "e.pbrt:3:1: ObjectBegin \"b\" inside another ObjectBegin"},
        {"WorldBegin\nObjectBegin \"a\"\nObjectInstance \"a\"\n", "ObjectInstance \"a\" inside its own definition"},
        {"WorldBegin\nObjectBegin \"a\"\n" TRI, "e.pbrt:2:1 has no ObjectEnd"},
        {"WorldBegin\nObjectBegin \"a\"\nObjectEnd\nObjectBegin \"a\"\n", "object defined twice"},
        {"WorldBegin\nObjectEnd\n", "ObjectEnd without ObjectBegin"},
        {"WorldBegin\n[ 1 ]\n", "e.pbrt:2:1: expected a directive, got '['"},
        {"WorldBegin\nLookAt 0 0 0 0 0 0 0 1 0\n", "the eye and the point looked at coincide"},
        {"LookAt 0 0 0 0 0 1 0 0 1\n", "the up vector is parallel"},
        {"Scale 0 0 0\nCamera \"perspective\"\n", "Camera: the current transformation is singular"},
        {"Camera \"perspective\" \"float fov\" 180\n", "fov 180 outside (0, 180)"},
        {"WorldBegin\nShape \"sphere\" \"float radius\" -1\n", "radius must be positive"},
        {"WorldBegin\nWorldBegin\n", "WorldBegin given twice"},
        {"WorldBegin\nShape \"trianglemesh\" \"point3 P\" [ 0 0 0 1 0 0 0 1 0 ] \"point3 P\" [ 0 ]\n", "given twice"},
        {"WorldBegin\nMaterial \"dielectric\" \"float eta\" -1\n", "eta -1 outside"},
        {"WorldBegin\nShape \"plymesh\" \"string filename\" \"none.ply\"\n", "plymesh \"none.ply\": no such file"},
        {"WorldBegin\nShape \"plymesh\"\n", "missing \"string filename\""},
        {"WorldBegin\nRotate 10 0 0 0\n", "Rotate: the axis is zero"},
        {"WorldBegin\nCoordSysTransform \"nope\"\n", "no such coordinate system"},
        {"WorldBegin\n", "e.pbrt: no triangles"},
        {"WorldBegin\nShape \"trianglemesh\" \"point3 P\" [ 0 0 0 1e29 0 0 0 1 0 ]\n", "is not finite or beyond 1e+13"},
        {"WorldBegin\nInclude \"/etc/hostname\"\n", "absolute paths are not allowed"},
        {"WorldBegin\nInclude \"../x-absent.pbrt\"\n", "e.pbrt:2:9: Include \"../x-absent.pbrt\": no such file in /"},
        {"WorldBegin\nInclude \"/etc/hostname\"\n", "absolute paths are not allowed"},
        {"WorldBegin\nImport \"e.pbrt\"\n", "e.pbrt:2:8: Import \"e.pbrt\": a file cannot import itself"},
        {"WorldBegin\nInclude \"./e.pbrt\"\n", "a file cannot include itself"},
        {"WorldBegin\nActiveTransform Sometimes\n", "expected StartTime, EndTime or All"},
        {"WorldBegin\nShape \"trianglemesh\" \"point3 P\" [ 0 0 0 1 0 0 0 1 0 ] \"bool b\" maybe\n",
         "expected true or false"},
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) expect_fail("e.pbrt", bad[i].text, bad[i].needle);
    /* parameters of one directive are capped (duplicates are looked for) */
    {
        size_t cap = 300 * 24 + 64;
        char *t = malloc(cap);
        size_t k = (size_t)snprintf(t, cap, "WorldBegin\nShape \"sphere\"");
        for (int i = 0; i < 300; i++) k += (size_t)snprintf(t + k, cap - k, " \"float p%d\" 1", i);
        snprintf(t + k, cap - k, "\n");
        expect_fail("params.pbrt", t, "params.pbrt:2:");
        expect_fail("params.pbrt", t, "more than 256 parameters");
        free(t);
    }
    /* NUL byte */
    static const char nul[] = "WorldBegin\nShape \0 \"sphere\"\n";
    check_write_file(check_path("nul.pbrt"), nul, sizeof nul - 1);
    rt_err e = {0};
    rt_scene *s = rt_scene_load(check_path("nul.pbrt"), &e);
    CHECK(!s && strstr(e.msg, "nul.pbrt:2:7: NUL byte"), "NUL: %s", e.msg);
    rt_scene_free(s);
    /* maxtri: instances and spheres are counted before they are made */
    s = load_text("max.pbrt",
                  "WorldBegin\nObjectBegin \"o\"\nShape \"sphere\"\nObjectEnd\nObjectInstance \"o\"\nObjectInstance \"o\"\n",
                  "maxtri=200", &e);
    CHECK(!s && strstr(e.msg, "max.pbrt:6:16: the scene would have 216 triangles, more than maxtri=200"), "maxtri: %s",
          e.msg);
    rt_scene_free(s);
    /* include cycles, a FIFO, a link out of the folder, a folder */
    mkdir(check_path("cyc"), 0700);
    write_text("cyc/a.pbrt", "WorldBegin\nInclude \"sub/b.pbrt\"\n");
    mkdir(check_path("cyc/sub"), 0700);
    write_text("cyc/sub/b.pbrt", TRI "Include \"../a.pbrt\"\n");
    s = rt_scene_load(check_path("cyc/a.pbrt"), &e);
    CHECK(!s && strstr(e.msg, "cyc/sub/b.pbrt:2:9: Include \"../a.pbrt\": include cycle") && strstr(e.msg, "a.pbrt is already"),
          "cycle: %s", e.msg);
    rt_scene_free(s);
    CHECK(mkfifo(check_path("cyc/fifo.pbrt"), 0600) == 0, "mkfifo");
    write_text("cyc/f.pbrt", "WorldBegin\nInclude \"fifo.pbrt\"\n");
    s = rt_scene_load(check_path("cyc/f.pbrt"), &e);
    CHECK(!s && strstr(e.msg, "Include \"fifo.pbrt\": not a regular file"), "fifo: %s", e.msg);
    rt_scene_free(s);
    s = rt_scene_load(check_path("cyc/fifo.pbrt"), &e);
    CHECK(!s && strstr(e.msg, "not a regular file"), "fifo as the scene: %s", e.msg);
    rt_scene_free(s);
    write_text("outside.pbrt", TRI);
    CHECK(symlink("../outside.pbrt", check_path("cyc/link.pbrt")) == 0, "symlink");
    write_text("cyc/l.pbrt", "WorldBegin\nInclude \"link.pbrt\"\n");
    s = rt_scene_load(check_path("cyc/l.pbrt"), &e);
    CHECK(s && s->ntri == 1, "a link to a file outside the folder is followed: %s", s ? "wrong count" : e.msg);
    rt_scene_free(s);
    /* a link to a FIFO: the opened descriptor is checked, nothing blocks */
    CHECK(symlink("fifo.pbrt", check_path("cyc/tofifo.pbrt")) == 0, "symlink");
    write_text("cyc/lf.pbrt", "WorldBegin\nInclude \"tofifo.pbrt\"\n");
    s = rt_scene_load(check_path("cyc/lf.pbrt"), &e);
    CHECK(!s && strstr(e.msg, "lf.pbrt:2:9: Include \"tofifo.pbrt\": not a regular file"), "link to a FIFO: %s",
          s ? "accepted" : e.msg);
    rt_scene_free(s);
    write_text("cyc/d.pbrt", "WorldBegin\nInclude \"sub\"\n");
    s = rt_scene_load(check_path("cyc/d.pbrt"), &e);
    CHECK(!s && strstr(e.msg, "Include \"sub\": a folder, not a file"), "folder: %s", e.msg);
    rt_scene_free(s);
    /* an included file's errors name it */
    write_text("cyc/sub/bad.pbrt", TRI "Frobnicate\n");
    write_text("cyc/i.pbrt", "WorldBegin\nInclude \"sub/bad.pbrt\"\n");
    s = rt_scene_load(check_path("cyc/i.pbrt"), &e);
    CHECK(!s && strstr(e.msg, "cyc/sub/bad.pbrt:2:1: unknown directive 'Frobnicate'"), "included: %s", e.msg);
    rt_scene_free(s);
}

/* Every prefix of the Cornell box loads or is refused with a message. */
static void test_truncations(void)
{
    char *buf = NULL;
    size_t n = 0;
    rt_err e = {0};
    if (rt_slurp(srcfile("data/pbrt/cornell.pbrt"), &buf, &n, &e) < 0) {
        CHECK(0, "%s", e.msg);
        return;
    }
    int ok = 0, refused = 0;
    for (size_t k = 0; k <= n; k += check_long() ? 1 : 7) {
        check_write_file(check_path("cut.pbrt"), buf, k);
        e.msg[0] = 0;
        rt_scene *s = rt_scene_load(check_path("cut.pbrt"), &e);
        if (s) ok++;
        else {
            refused++;
            CHECK(e.msg[0] && strstr(e.msg, "cut.pbrt"), "prefix %zu refused without naming the file: '%s'", k, e.msg);
        }
        rt_scene_free(s);
    }
    CHECK(ok > 0 && refused > 0, "prefixes: %d loaded, %d refused", ok, refused);
    free(buf);
}

static size_t count_diff(const rt_image *a, const rt_image *b)
{
    size_t d = 0;
    for (size_t i = 0; i < (size_t)a->W * a->H * 3; i++) d += memcmp(&a->rgb[i], &b->rgb[i], sizeof(float)) != 0;
    return d;
}

static rt_image *render(rt_scene *sc, rt_kdtree *kd, const char *tracer, const rt_render_opts *o)
{
    rt_err e = {0};
    rt_job j;
    rt_run_stats st;
    if (rt_job_setup_borrowed(&j, sc, kd, tracer, o, &e) < 0) {
        CHECK(0, "setup %s: %s", tracer, e.msg);
        return NULL;
    }
    rt_image *im = rt_image_new(j.opt.W, j.opt.H, &e);
    if (!im || rt_job_run(&j, NULL, im, &st, &e) < 0) {
        CHECK(0, "run %s: %s", tracer, e.msg);
        rt_image_free(im);
        im = NULL;
    }
    rt_job_free(&j);
    return im;
}

static void test_cornell(void)
{
    rt_err e = {0};
    rt_scene *s = rt_scene_load(srcfile("data/pbrt/cornell.pbrt"), &e);
    CHECK(s != NULL, "cornell.pbrt: %s", e.msg);
    if (!s) return;
    CHECK(s->ntri == 36 && s->ninst == 2 && s->ntri_inst == 24 && s->ntri_unique == 24,
          "cornell.pbrt: %u triangles, %u instances", s->ntri, s->ninst);
    CHECK(s->warning[0] == 0, "warning '%s'", s->warning);
    CHECK(veq(s->cam.eye, 0.5f, -1.35f, 0.5f) && s->cam.fovy_deg == 40.0f && s->cam.mirror == 0, "its usual view");
    CHECK(s->film_w == 256 && s->film_h == 256, "film");
    /* the built-in box: same bounds */
    rt_scene *b = rt_scene_load("cornell:glass=0", &e);
    if (b) CHECK(!memcmp(&b->bounds, &s->bounds, sizeof b->bounds), "bounds differ from the built-in box");
    rt_scene_free(b);
    int emit = 0;
    for (uint32_t i = 0; i < s->ntri; i++)
        if (s->mat[s->shade[i].mat].flags & RT_MAT_EMIT) emit++;
    CHECK(emit == 2, "%d emitting triangles", emit);
    rt_kd_params kp;
    rt_kd_default_params(&kp);
    rt_kdtree *kd = rt_kd_build(s, &kp, &e);
    CHECK(kd != NULL, "%s", e.msg);
    if (!kd) {
        rt_scene_free(s);
        return;
    }
    rt_render_opts o;
    rt_render_default_opts(&o);
    o.W = o.H = 48;
    o.lights = 7;
    rt_image *ref = render(s, kd, "recursive", &o);
    for (int t = 0; rt_tracer_all[t]; t++) {
        const char *name = rt_tracer_all[t]->name;
        if (!strcmp(name, "recursive")) continue;
        rt_image *im = render(s, kd, name, &o);
        if (ref && im) CHECK(count_diff(ref, im) == 0, "cornell.pbrt: %s differs in %zu values", name, count_diff(ref, im));
        rt_image_free(im);
    }
    /* the lamp in a path-traced image: pixel (24, 5) looks at the panel
     * (rows 4.7 to 6.6 of 48 see it), which emits 17 12 4 */
    o.mode = RT_MODE_PATH;
    o.lights = 0;
    o.bounces = 0;
    rt_image *pt = render(s, kd, "recursive", &o);
    if (pt) {
        const float *c = &pt->rgb[3 * (5 * 48 + 24)], *w = &pt->rgb[3 * (24 * 48 + 24)];
        CHECK(c[0] > 1 && c[0] > c[1] && c[1] > c[2], "lamp pixel %g %g %g", c[0], c[1], c[2]);
        CHECK(w[0] < 1, "back wall pixel %g %g %g", w[0], w[1], w[2]);
    }
    rt_image_free(pt);
    /* the film sets the size when the options leave it free */
    o.film = RT_FILM_W | RT_FILM_H;
    o.mode = RT_MODE_DEFAULT;
    rt_image *full = render(s, kd, "recursive", &o);
    CHECK(full && full->W == 256 && full->H == 256, "film size %dx%d", full ? full->W : 0, full ? full->H : 0);
    rt_image_free(full);
    rt_image_free(ref);
    rt_kd_free(kd);
    rt_scene_free(s);
}

static void test_film_opts(void)
{
    rt_render_opts o;
    rt_render_default_opts(&o);
    rt_render_apply_film(&o, 400, 300);
    CHECK(o.W == 512 && o.H == 512, "no bits: sizes kept");
    o.film = RT_FILM_W | RT_FILM_H;
    rt_render_apply_film(&o, 400, 300);
    CHECK(o.W == 400 && o.H == 300 && o.film == 0, "both from the film");
    o.W = 100;
    o.film = RT_FILM_H;
    rt_render_apply_film(&o, 400, 300);
    CHECK(o.W == 100 && o.H == 75, "H from the aspect: %d", o.H);
    o.H = 90;
    o.film = RT_FILM_W;
    rt_render_apply_film(&o, 400, 300);
    CHECK(o.W == 120 && o.H == 90, "W from the aspect: %d", o.W);
    o.film = RT_FILM_W | RT_FILM_H;
    rt_render_apply_film(&o, 0, 0);
    CHECK(o.W == 120 && o.H == 90, "no film: kept");
}

/* Strictness and finiteness (hostile input): hex floats, the smallest
 * integer, "rgb eta" lengths, huge rotation angles (reduced exactly, so
 * Rotate 1e22 is Rotate 280), transformations that overflow, lights,
 * cameras and vertices that leave float range: each a one-line
 * FILE:LINE:COL error naming the file once. */

static void test_strict_finite(void)
{
    expect_fail("hex.pbrt", "WorldBegin\nShape \"trianglemesh\" \"point3 P\" [ 0x1p0 0 0 1 0 0 0 1 0 ]\n",
                "hex.pbrt:2:35: bad number '0x1p0'");
    expect_fail("hex2.pbrt", "WorldBegin\nTranslate 0X10 0 0\n", "hex2.pbrt:2:11: bad number '0X10'");
    expect_fail("imin.pbrt",
                "WorldBegin\nShape \"trianglemesh\" \"point3 P\" [ 0 0 0 1 0 0 0 1 0 ] \"integer indices\" [ -2147483648 1 2 ]\n",
                "index -2147483648 (entry 0) out of range (3 vertices)");
    expect_fail("imin2.pbrt",
                "WorldBegin\nShape \"trianglemesh\" \"point3 P\" [ 0 0 0 1 0 0 0 1 0 ] \"integer indices\" [ -2147483649 1 2 ]\n",
                "'-2147483649' is not an integer");
    expect_fail("eta2.pbrt", "WorldBegin\nMaterial \"dielectric\" \"rgb eta\" [ 1.5 1.5 ]\n" TRI,
                "eta2.pbrt:2:23: parameter \"rgb eta\": 2 values, expected 3");
    expect_fail("eta4.pbrt", "WorldBegin\nMaterial \"dielectric\" \"rgb eta\" [ 1.5 1.5 1.5 1.5 ]\n" TRI,
                "4 values, expected 3");
    rt_scene *s = expect_ok("eta3.pbrt", "WorldBegin\nMaterial \"dielectric\" \"rgb eta\" [ 1.4 1.5 1.6 ]\n" TRI, 1);
    if (s) CHECK(check_near(s->mat[s->shade[0].mat].ior, 1.5, 1e-6, 0), "rgb eta: ior %g", s->mat[s->shade[0].mat].ior);
    rt_scene_free(s);

    /* 10^22 is a double; 10^22 mod 360 = 280 exactly */
    double sn, cs, s2, c2;
    rt_dsincos_deg(1e22, &sn, &cs);
    rt_dsincos_deg(280, &s2, &c2);
    CHECK(sn == s2 && cs == c2, "dsincos(1e22) = %.17g %.17g, dsincos(280) = %.17g %.17g", sn, cs, s2, c2);
    CHECK(check_near(sn, -0.984807753012208, 0, 1e-15) && check_near(cs, 0.1736481776669303, 0, 1e-15),
          "dsincos(280) = %.17g %.17g", sn, cs);
    rt_dsincos_deg(-1e300, &sn, &cs);
    CHECK(isfinite(sn) && isfinite(cs) && check_near(sn * sn + cs * cs, 1, 0, 1e-15), "dsincos(-1e300) %g %g", sn, cs);
    rt_dsincos_deg(-1e-300, &sn, &cs);
    CHECK(sn == 0 && cs == 1, "dsincos(-1e-300) %g %g", sn, cs);
    s = expect_ok("rot22.pbrt",
                  "WorldBegin\nRotate 1e22 0 0 1\nLightSource \"point\" \"point3 from\" [ 1 0 0 ]\n"
                  "Shape \"trianglemesh\" \"point3 P\" [ 1 0 0 0 1 0 0 0 1 ]\n",
                  1);
    if (s) CHECK(vnear(s->light[0], 0.17364817766693, -0.98480775301221, 0, 1e-6), "Rotate 1e22 light (%g %g %g)",
                 s->light[0].x, s->light[0].y, s->light[0].z);
    rt_scene_free(s);

    expect_fail("lightinf.pbrt", "WorldBegin\nScale 1e30 1e30 1e30\nScale 1e30 1 1\nLightSource \"point\" \"point3 from\" [ 1 0 0 ]\n" TRI,
                "lightinf.pbrt:4:13: LightSource: the light's position (inf, 0, 0) is not finite");
    expect_fail("lightbig.pbrt", "WorldBegin\nTranslate 1e20 0 0\nLightSource \"point\"\n" TRI,
                "lightbig.pbrt:3:13: LightSource: the light's position (1e+20, 0, 0) is not finite or beyond");
    expect_fail("ctminf.pbrt",
                "WorldBegin\nScale 1e30 1 1\nScale 1e30 1 1\nScale 1e30 1 1\nScale 1e30 1 1\nScale 1e30 1 1\n"
                "Scale 1e30 1 1\nScale 1e30 1 1\nScale 1e30 1 1\nScale 1e30 1 1\nScale 1e30 1 1\nScale 1e30 1 1\n" TRI,
                "ctminf.pbrt:12:1: Scale: the transformation is no longer finite");
    expect_fail("caminf.pbrt", "Translate 1e20 0 0\nCamera \"perspective\"\nWorldBegin\n" TRI,
                "caminf.pbrt:2:1: Camera: the eye (-1e+20, 0, 0) is not finite or beyond");
    rt_err e = {0};
    s = load_text("vinf.pbrt", "WorldBegin\nScale 1e30 1e30 1e30\nScale 1e30 1 1\n" TRI, NULL, &e);
    CHECK(!s && strstr(e.msg, "vinf.pbrt:4:7: Shape \"trianglemesh\": vertex (inf, 0, 0) is not finite or beyond 1e+13") &&
              count_str(e.msg, "vinf.pbrt") == 1,
          "non-finite vertex: '%s'", e.msg);
    rt_scene_free(s);
    s = load_text("vinf2.pbrt",
                  "WorldBegin\nObjectBegin \"o\"\n" TRI "ObjectEnd\nScale 1e30 1e30 1e30\nObjectInstance \"o\"\n", NULL,
                  &e);
    CHECK(!s && strstr(e.msg, "vinf2.pbrt:6:16: ObjectInstance: vertex (1e+30, 0, 0) is not finite or beyond") &&
              count_str(e.msg, "vinf2.pbrt") == 1,
          "non-finite instance vertex: '%s'", e.msg);
    rt_scene_free(s);
}

/* -W and -H on a film of another aspect keep the film's horizontal
 * extent (checked against libm's atan); the film's own aspect, scenes
 * without a Film and cropwindow (warned) */
static void test_film_fit(void)
{
    rt_scene *s = expect_ok("fit.pbrt",
                            "Film \"rgb\" \"integer xresolution\" 40 \"integer yresolution\" 30 "
                            "\"float cropwindow\" [ 0 0.5 0 0.5 ]\n"
                            "Camera \"perspective\" \"float fov\" 45\nWorldBegin\n" TRI,
                            1);
    rt_err e = {0};
    if (s) {
        CHECK(s->nwarn == 1 && !strcmp(s->warn[0].kind, "Film cropwindow") && strstr(s->warn[0].first, "fit.pbrt:1"),
              "cropwindow warning: %u '%s'", s->nwarn, s->nwarn ? s->warn[0].msg : "");
        /* pbrt's fov spans the shorter axis: 45 degrees vertical on 40x30 */
        CHECK(check_near(s->cam.fovy_deg, 45, 1e-6, 0), "fovy %g", s->cam.fovy_deg);
        CHECK(rt_scene_fit_film(s, 80, 60, &e) == 0 && s->cam.fovy_deg == 45.0f, "the film's aspect: unchanged");
        CHECK(rt_scene_fit_film(s, 8, 8, &e) == 1, "8x8 on 40x30: adjusted");
        double want = 2 * atan(tan(22.5 * M_PI / 180) * 40.0 / 30.0) * 180 / M_PI;
        CHECK(check_near(s->cam.fovy_deg, want, 1e-6, 0), "8x8: fovy %.9g, expected %.9g", s->cam.fovy_deg, want);
        CHECK(s->nwarn == 2 && !strcmp(s->warn[1].kind, "image aspect") && strstr(s->warn[1].msg, "horizontal extent is kept"),
              "image aspect warning");
    }
    rt_scene_free(s);
    s = expect_ok("nofilm.pbrt", "WorldBegin\n" TRI, 1);
    if (s) {
        float f = s->cam.fovy_deg;
        CHECK(rt_scene_fit_film(s, 8, 3, &e) == 0 && s->cam.fovy_deg == f && s->nwarn == 0, "no Film: unchanged");
    }
    rt_scene_free(s);
}

/* curves as ribbons: a straight cubic Bezier along x, 8 pieces (16
 * triangles), widened across its tangent facing the camera (or z without
 * one), tapered by width0/width1; bspline and degree 2 control points;
 * wrong counts refused */
static void test_curves(void)
{
    const char *straight = "\"point3 P\" [ 0 0 0  1 0 0  2 0 0  3 0 0 ] \"float width\" 0.2";
    char text[600];
    snprintf(text, sizeof text, "WorldBegin\nShape \"curve\" %s\n", straight);
    rt_scene *s = expect_ok("curve.pbrt", text, 16);
    if (s) {
        /* no camera: across cross(x, z) = -y, the points at x = 3u */
        CHECK(vnear(s->tri[0].p[0], 0, 0.1, 0, 1e-7) && vnear(s->tri[0].p[1], 0, -0.1, 0, 1e-7) &&
                  vnear(s->tri[0].p[2], 0.375, -0.1, 0, 1e-6) && vnear(s->tri[15].p[2], 3, 0.1, 0, 1e-6),
              "curve ribbon: (%g %g %g) (%g %g %g)", s->tri[0].p[2].x, s->tri[0].p[2].y, s->tri[0].p[2].z,
              s->tri[15].p[2].x, s->tri[15].p[2].y, s->tri[15].p[2].z);
        CHECK(s->nwarn == 1 && !strcmp(s->warn[0].kind, "curve") && strstr(s->warn[0].msg, "camera-facing ribbons, 8 pieces"),
              "curve warning: %s", s->warning);
    }
    rt_scene_free(s);
    /* the eye above (y = 5): the ribbon turns to face it, across z */
    snprintf(text, sizeof text,
             "LookAt 1.5 5 0  1.5 0 0  0 0 1\nCamera \"perspective\"\nWorldBegin\nScale 2 2 2\nShape \"curve\" %s "
             "\"integer splitdepth\" 1\n", straight);
    s = expect_ok("curve2.pbrt", text, 4);
    if (s) {
        int ok = 1;
        for (uint32_t i = 0; i < s->ntri; i++)
            for (int k = 0; k < 3; k++) ok &= fabsf(s->tri[i].p[k].y) < 1e-6f && fabsf(fabsf(s->tri[i].p[k].z) - 0.2f) < 1e-6f;
        CHECK(ok, "curve facing y: (%g %g %g)", s->tri[0].p[0].x, s->tri[0].p[0].y, s->tri[0].p[0].z);
        CHECK(vnear(s->tri[3].p[2], 6, 0, -0.2, 1e-6) || vnear(s->tri[3].p[2], 6, 0, 0.2, 1e-6), "scaled end (%g %g %g)",
              s->tri[3].p[2].x, s->tri[3].p[2].y, s->tri[3].p[2].z);
    }
    rt_scene_free(s);
    /* taper to a point; bspline (1 segment of 4 points); degree 2 */
    s = expect_ok("curve3.pbrt",
                  "WorldBegin\nShape \"curve\" \"point3 P\" [ 0 0 0  1 0 0  2 0 0  3 0 0 ] \"float width0\" 0.2 "
                  "\"float width1\" 0\n",
                  16);
    if (s) CHECK(vnear(s->tri[15].p[2], 3, 0, 0, 1e-6) && vnear(s->tri[15].p[1], 3, 0, 0, 1e-6), "taper to 0");
    rt_scene_free(s);
    s = expect_ok("curve4.pbrt",
                  "WorldBegin\nShape \"curve\" \"string basis\" \"bspline\" \"point3 P\" [ 0 0 0  3 0 0  6 0 0  9 0 0 ]\n",
                  16);
    /* uniform B-spline of evenly spaced points: from (p0 + 4p1 + p2)/6 = 3 to (p1 + 4p2 + p3)/6 = 6 */
    if (s) CHECK(check_near(s->tri[0].p[0].x, 3, 0, 1e-6) && check_near(s->tri[15].p[2].x, 6, 0, 1e-5), "bspline ends %g %g",
                 s->tri[0].p[0].x, s->tri[15].p[2].x);
    rt_scene_free(s);
    s = expect_ok("curve5.pbrt", "WorldBegin\nShape \"curve\" \"integer degree\" 2 \"point3 P\" [ 0 0 0  1 0 0  2 0 0  3 0 0  4 0 0 ]\n",
                  32);
    rt_scene_free(s);
    expect_fail("curve6.pbrt", "WorldBegin\nShape \"curve\" \"point3 P\" [ 0 0 0  1 0 0  2 0 0  3 0 0  4 0 0 ]\n",
                "curve6.pbrt:2:7: Shape \"curve\": 5 control points do not make bezier segments of degree 3");
    expect_fail("curve7.pbrt", "WorldBegin\nShape \"curve\" \"string type\" \"ribbon\" \"point3 P\" [ 0 0 0  1 0 0  2 0 0  3 0 0 ]\n",
                "type \"ribbon\" needs 2 normals");
    s = expect_ok("curve8.pbrt",
                  "WorldBegin\nShape \"curve\" \"string type\" \"ribbon\" \"point3 P\" [ 0 0 0  1 0 0  2 0 0  3 0 0 ] "
                  "\"normal N\" [ 0 1 0  0 1 0 ]\n",
                  16);
    if (s) CHECK(fabsf(s->tri[0].p[0].y) < 1e-7f && fabsf(fabsf(s->tri[0].p[0].z) - 0.5f) < 1e-6f,
                 "ribbon across cross(x, y) = z: (%g %g %g)", s->tri[0].p[0].x, s->tri[0].p[0].y, s->tri[0].p[0].z);
    rt_scene_free(s);
}

int main(void)
{
    if (!check_tmpdir("test_pbrt")) {
        perror("mkdtemp");
        return 1;
    }
    test_tokens();
    test_transforms();
    test_instancing();
    test_includes();
    test_asset_paths();
    test_gzip();
    test_loopsubdiv();
    test_shapes();
    test_shapes2();
    test_curves();
    test_materials();
    test_camera();
    test_lights();
    test_warnings();
    test_errors();
    test_truncations();
    test_film_opts();
    test_strict_finite();
    test_film_fit();
    test_cornell();
    if (check_rm_tree(check_dir) != 0) fprintf(stderr, "warning: could not remove %s\n", check_dir);
    if (failures) fprintf(stderr, "%d failure(s)\n", failures);
    else printf("test_pbrt: all passed\n");
    return failures ? 1 : 0;
}
