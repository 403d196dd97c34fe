/*
 * test_loaders.c -- tests for the OBJ and PLY loaders: the meshes in
 * data/meshes, every OBJ face-corner form, ascii / binary little-endian /
 * binary big-endian PLY of the same mesh giving identical triangles, and
 * malformed input written into a temporary directory (every truncation
 * point of a binary PLY, bad tokens, out-of-range and zero indices, short
 * faces, NaN/Inf, bad headers, empty meshes, random corruption), which must
 * be rejected with a one-line message naming the file -- or, for random
 * corruption, at least never crash. MTL material libraries: a Cornell box
 * in the format of McGuire's CornellBox-Original, the illum mapping, the
 * missing-library warning and malformed MTL named by file and line. Mesh
 * files without materials keep their golden hashes.
 * Exit status 0 = all passed.
 */
#include "config.h"
#include "check.h"
#include "scene.h"
#include "scene_load.h"
#include "ply_read.h"

#include <errno.h>
#include <inttypes.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>
#include <zlib.h>


static void write_text(const char *path, const char *text) { check_write_file(path, text, strlen(text)); }

static const char *datafile(const char *name)
{
    static char buf[2][600];
    static int k;
    k ^= 1;
    const char *src = getenv("RT_SRCDIR");
    if (src && *src) snprintf(buf[k], sizeof buf[k], "%s/data/meshes/%s", src, name);
    else snprintf(buf[k], sizeof buf[k], "%s/meshes/%s", RT_SRCDATADIR, name);
    return buf[k];
}

static int veq(rt_vec3 a, float x, float y, float z) { return a.x == x && a.y == y && a.z == z; }

/* Loads text written to a temp file; expects failure whose message holds
 * the file name and `needle`. */
static void expect_fail_text(const char *name, const char *text, const char *needle)
{
    const char *p = check_path(name);
    check_write_file(p, text, strlen(text));
    rt_err e = {0};
    rt_scene *s = rt_scene_load(p, &e);
    CHECK(s == NULL, "%s accepted:\n%s", name, text);
    CHECK(strstr(e.msg, p) != NULL, "%s: message '%s' lacks the file name", name, e.msg);
    CHECK(!needle || strstr(e.msg, needle) != NULL, "%s: message '%s' lacks '%s'", name, e.msg, needle);
    CHECK(strchr(e.msg, '\n') == NULL, "%s: multi-line message", name);
    rt_scene_free(s);
}

static rt_scene *expect_ok_text(const char *name, const char *text, uint32_t ntri)
{
    const char *p = check_path(name);
    check_write_file(p, text, strlen(text));
    rt_err e = {0};
    rt_scene *s = rt_scene_load(p, &e);
    CHECK(s != NULL, "%s rejected: %s", name, e.msg);
    if (s) CHECK(s->ntri == ntri, "%s: %u triangles, want %u", name, s->ntri, ntri);
    return s;
}

static void test_obj(void)
{
    rt_err e = {0};
    rt_scene *s = rt_scene_load(datafile("cube.obj"), &e);
    CHECK(s != NULL, "cube.obj: %s", e.msg);
    if (s) {
        CHECK(s->ntri == 12, "cube: %u triangles", s->ntri);
        CHECK(veq(s->bounds.lo, 0, 0, 0) && veq(s->bounds.hi, 1, 1, 1), "cube bounds");
        /* Quad 1 4 3 2 fans into (1,4,3) and (1,3,2). */
        CHECK(veq(s->tri[0].p[0], 0, 0, 0) && veq(s->tri[0].p[1], 0, 1, 0) && veq(s->tri[0].p[2], 1, 1, 0), "quad fan 1");
        CHECK(veq(s->tri[1].p[0], 0, 0, 0) && veq(s->tri[1].p[1], 1, 1, 0) && veq(s->tri[1].p[2], 1, 0, 0), "quad fan 2");
        CHECK(!strcmp(s->name, "cube.obj"), "name '%s'", s->name);
        CHECK(s->cam.fovy_deg > 0 && !veq(s->cam.eye, s->cam.at.x, s->cam.at.y, s->cam.at.z), "autoframe");
        rt_scene_free(s);
    }
    s = rt_scene_load(datafile("forms.obj"), &e);
    CHECK(s != NULL, "forms.obj: %s", e.msg);
    if (s) {
        CHECK(s->ntri == 7, "forms: %u triangles", s->ntri);
        if (s->ntri == 7) {
            CHECK(veq(s->tri[2].p[2], 1, 1, 0), "v/vt/vn corner");
            CHECK(veq(s->tri[3].p[0], 0, 0, 0) && veq(s->tri[3].p[2], 1, 1, 0), "negative indices");
            /* Pentagon 1 2 3 5 4: (1,2,3) (1,3,5) (1,5,4). */
            CHECK(veq(s->tri[5].p[2], 0.5f, 1.5f, 0) && veq(s->tri[6].p[1], 0.5f, 1.5f, 0) &&
                      veq(s->tri[6].p[2], 0, 1, 0), "pentagon fan");
        }
        rt_scene_free(s);
    }
    s = expect_ok_text("neg.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -3 -2 -1\nv 5 5 5\nf -4 -1 -2\n", 2);
    if (s && s->ntri == 2) CHECK(veq(s->tri[1].p[1], 5, 5, 5), "relative index after more vertices");
    rt_scene_free(s);
    rt_scene_free(expect_ok_text("exp.obj", "v 1e-3 -2.5E+1 +3\nv 1 0 0\nv 0 1 0\nvt 0.5 0.5\nf 1/1 2/1 3/1\n", 1));
    rt_scene_free(expect_ok_text("noeol.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3", 1));
    rt_scene_free(expect_ok_text("upper.OBJ", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", 1));

    static const struct {
        const char *name, *text, *needle;
    } bad[] = {
        {"badnum.obj", "v 0 0 0\nv 1 0 x\n", ":2: bad number 'x'"},
        {"badnum2.obj", "v 0 0 0\nv 1 0 1.5q\n", ":2: bad number"},
        {"fewcoord.obj", "v 0 0\n", ":1: vertex has 2 coordinates"},
        {"nan.obj", "v 0 0 0\nv 1 0 0\nv nan 1 0\nf 1 2 3\n", ":3: coordinate is not a finite"},
        {"inf.obj", "v 0 0 0\nv 1 0 0\nv 0 -inf 0\nf 1 2 3\n", ":3:"},
        {"huge.obj", "v 0 0 0\nv 1 0 0\nv 0 1e39 0\nf 1 2 3\n", ":3:"},
        {"range.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n", ":4: face index 9 out of range (3 vertices)"},
        {"forward.obj", "v 0 0 0\nv 1 0 0\nf 1 2 3\nv 0 1 0\n", ":3: face index 3 out of range"},
        {"negrange.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -1 -2 -4\n", ":4: face index -4 out of range"},
        {"zero.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n", ":4: face index 0"},
        {"short.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2\n", ":4: face has 2 vertices"},
        {"badidx.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 a\n", ":4: bad face index 'a'"},
        {"badidx2.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3/x\n", ":4: bad face index '3/x'"},
        {"badidx3.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3//1/1\n", ":4: bad face index"},
        {"bigidx.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 99999999999999999999999\n", ":4:"},
        {"empty.obj", "", "no faces"},
        {"nofaces.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\n# only vertices\n", "no faces"},
        {"fnodata.obj", "v 0 0 0\nf\n", ":2:"},
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) expect_fail_text(bad[i].name, bad[i].text, bad[i].needle);
    /* Embedded NUL byte. */
    const char nul[] = "v 0 0 0\nv 1 0\0 0\nv 0 1 0\nf 1 2 3\n";
    check_write_file(check_path("nul.obj"), nul, sizeof nul - 1);
    rt_err e2 = {0};
    s = rt_scene_load(check_path("nul.obj"), &e2);
    CHECK(s == NULL && strstr(e2.msg, "nul.obj:2:"), "NUL byte: '%s'", e2.msg);
    rt_scene_free(s);
    /* Random corruption of an OBJ: any outcome but a crash. */
    static const char good[] = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nf 1/1 2/1 3/1\nf -4//1 -2//1 -1//1\n"
                               "f 1 2 3 4\n";
    static const char alphabet[] = "0123456789-+./ \n\r\tvfeEnaiN#x";
    uint32_t st = 777;
    char buf[sizeof good];
    for (int it = 0; it < 3000; it++) {
        memcpy(buf, good, sizeof good);
        for (int k = 0; k < 1 + it % 3; k++) {
            st = st * 1664525u + 1013904223u;
            size_t at = (st >> 8) % (sizeof good - 1);
            st = st * 1664525u + 1013904223u;
            buf[at] = alphabet[(st >> 24) % (sizeof alphabet - 1)];
        }
        check_write_file(check_path("fuzz.obj"), buf, sizeof good - 1 - (it % 7 == 0 ? it % 11 : 0));
        rt_err fe = {0};
        rt_scene *t = rt_scene_load(check_path("fuzz.obj"), &fe);
        if (!t) CHECK(strstr(fe.msg, "fuzz.obj") != NULL, "fuzz: message '%s'", fe.msg);
        rt_scene_free(t);
    }
    /* Missing file. */
    s = rt_scene_load(check_path("missing.obj"), &e2);
    CHECK(s == NULL && strstr(e2.msg, "missing.obj"), "missing file: '%s'", e2.msg);
    rt_scene_free(s);
}

/* ------------------------------------------------------------------------ */
/* PLY                                                                       */

/* A small mesh: 5 vertices (a square pyramid), a quad base and 4 sides. */
static const float pv[5][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0.5f, 0.5f, 1.25f}};
static const int pf[5][4] = {{0, 3, 2, 1}, {0, 1, 4, -1}, {1, 2, 4, -1}, {2, 3, 4, -1}, {3, 0, 4, -1}};

typedef struct wbuf {
    unsigned char d[4096];
    size_t n;
} wbuf;

static void put(wbuf *w, const void *p, size_t n, int be)
{
    const unsigned char *b = p;
    for (size_t i = 0; i < n; i++) w->d[w->n++] = b[be ? n - 1 - i : i];
}

static int host_be(void)
{
    uint16_t x = 1;
    unsigned char c;
    memcpy(&c, &x, 1);
    return c == 0;
}

/* Writes the pyramid as PLY in the given format, with extra properties and
 * an extra element to skip (including a list property). */
static size_t make_ply(wbuf *w, const char *fmt)
{
    int ascii = !strcmp(fmt, "ascii"), be = !strcmp(fmt, "binary_big_endian");
    w->n = 0;
    char hdr[1024];
    snprintf(hdr, sizeof hdr,
             "ply\nformat %s 1.0\ncomment test pyramid\n"
             "element material 1\nproperty list uchar float kd\n"
             "element vertex 5\nproperty double x\nproperty float y\nproperty float z\n"
             "property uchar red\nproperty list ushort short junk\n"
             "element face 5\nproperty uchar flags\nproperty list uchar uint vertex_indices\n"
             "end_header\n",
             fmt);
    memcpy(w->d, hdr, strlen(hdr));
    w->n = strlen(hdr);
    if (ascii) {
        char b[1024];
        size_t k = 0;
        k += (size_t)snprintf(b + k, sizeof b - k, "3 0.5 0.25 1\n");
        for (int i = 0; i < 5; i++)
            k += (size_t)snprintf(b + k, sizeof b - k, "%.9g %.9g %.9g 200 2 -1 7\n", (double)pv[i][0],
                                  (double)pv[i][1], (double)pv[i][2]);
        for (int i = 0; i < 5; i++) {
            int c = pf[i][3] < 0 ? 3 : 4;
            k += (size_t)snprintf(b + k, sizeof b - k, "1 %d", c);
            for (int j = 0; j < c; j++) k += (size_t)snprintf(b + k, sizeof b - k, " %d", pf[i][j]);
            k += (size_t)snprintf(b + k, sizeof b - k, "\n");
        }
        memcpy(w->d + w->n, b, k);
        w->n += k;
        return w->n;
    }
    int swap = be != host_be();
    unsigned char u8 = 3;
    put(w, &u8, 1, 0);
    float kd[3] = {0.5f, 0.25f, 1};
    for (int i = 0; i < 3; i++) put(w, &kd[i], 4, swap);
    for (int i = 0; i < 5; i++) {
        double x = pv[i][0];
        put(w, &x, 8, swap);
        put(w, &pv[i][1], 4, swap);
        put(w, &pv[i][2], 4, swap);
        u8 = 200;
        put(w, &u8, 1, 0);
        uint16_t n = 2;
        put(w, &n, 2, swap);
        int16_t j1 = -1, j2 = 7;
        put(w, &j1, 2, swap);
        put(w, &j2, 2, swap);
    }
    for (int i = 0; i < 5; i++) {
        u8 = 1;
        put(w, &u8, 1, 0);
        u8 = (unsigned char)(pf[i][3] < 0 ? 3 : 4);
        put(w, &u8, 1, 0);
        for (int j = 0; j < u8; j++) {
            uint32_t x = (uint32_t)pf[i][j];
            put(w, &x, 4, swap);
        }
    }
    return w->n;
}

static void test_ply_formats(void)
{
    const char *fmts[] = {"ascii", "binary_little_endian", "binary_big_endian"};
    rt_scene *sc[3] = {NULL, NULL, NULL};
    static wbuf w;
    for (int i = 0; i < 3; i++) {
        make_ply(&w, fmts[i]);
        char name[64];
        snprintf(name, sizeof name, "pyr_%d.ply", i);
        check_write_file(check_path(name), w.d, w.n);
        rt_err e = {0};
        sc[i] = rt_scene_load(check_path(name), &e);
        CHECK(sc[i] != NULL, "%s: %s", fmts[i], e.msg);
        if (sc[i]) CHECK(sc[i]->ntri == 6, "%s: %u triangles", fmts[i], sc[i]->ntri);
    }
    if (sc[0] && sc[0]->ntri == 6) {
        CHECK(veq(sc[0]->tri[0].p[0], 0, 0, 0) && veq(sc[0]->tri[0].p[1], 0, 1, 0) && veq(sc[0]->tri[0].p[2], 1, 1, 0),
              "ascii quad fan");
        CHECK(veq(sc[0]->tri[2].p[2], 0.5f, 0.5f, 1.25f), "apex");
    }
    for (int i = 1; i < 3; i++)
        if (sc[0] && sc[i] && sc[0]->ntri == sc[i]->ntri)
            CHECK(!memcmp(sc[0]->tri, sc[i]->tri, sizeof(rt_tri) * sc[0]->ntri), "%s differs from ascii", fmts[i]);
    for (int i = 0; i < 3; i++) rt_scene_free(sc[i]);

    rt_err e = {0};
    rt_scene *s = rt_scene_load(datafile("tetra_ascii.ply"), &e);
    CHECK(s != NULL, "tetra_ascii.ply: %s", e.msg);
    if (s) {
        CHECK(s->ntri == 4, "tetra: %u", s->ntri);
        rt_scene_free(s);
    }

    /* Every truncation of the binary files fails with a byte offset. */
    for (int f = 1; f < 3; f++) {
        make_ply(&w, fmts[f]);
        int bad = 0;
        for (size_t n = 0; n < w.n; n++) {
            check_write_file(check_path("trunc.ply"), w.d, n);
            rt_err te = {0};
            rt_scene *t = rt_scene_load(check_path("trunc.ply"), &te);
            if (t || !strstr(te.msg, check_path("trunc.ply")) || strchr(te.msg, '\n')) {
                if (!bad) fprintf(stderr, "truncation at %zu of %zu: %s\n", n, w.n, t ? "accepted" : te.msg);
                bad++;
            }
            rt_scene_free(t);
        }
        CHECK(bad == 0, "%s: %d truncations not rejected properly", fmts[f], bad);
    }
    /* Truncating ascii at every line boundary fails too. */
    make_ply(&w, "ascii");
    int bad = 0;
    for (size_t n = 0; n < w.n; n++) {
        if (n && w.d[n - 1] != '\n') continue;
        check_write_file(check_path("trunc_a.ply"), w.d, n);
        rt_err te = {0};
        rt_scene *t = rt_scene_load(check_path("trunc_a.ply"), &te);
        if (t || !strstr(te.msg, "trunc_a.ply")) bad++;
        rt_scene_free(t);
    }
    CHECK(bad == 0, "ascii: %d line truncations not rejected", bad);

    /* Random corruption of the binary file: any outcome but a crash. */
    make_ply(&w, "binary_little_endian");
    uint32_t st = 12345;
    static wbuf c;
    for (int it = 0; it < 3000; it++) {
        c = w;
        int nflip = 1 + it % 4;
        for (int k = 0; k < nflip; k++) {
            st = st * 1664525u + 1013904223u;
            size_t at = (st >> 8) % c.n;
            st = st * 1664525u + 1013904223u;
            c.d[at] = (unsigned char)(st >> 24);
        }
        check_write_file(check_path("fuzz.ply"), c.d, c.n);
        rt_err fe = {0};
        rt_scene *t = rt_scene_load(check_path("fuzz.ply"), &fe);
        if (!t) CHECK(strstr(fe.msg, "fuzz.ply") != NULL, "fuzz: message '%s'", fe.msg);
        rt_scene_free(t);
    }
}

static void test_ply_malformed(void)
{
    const char *H = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
                    "element face 1\nproperty list uchar int vertex_indices\nend_header\n";
    char t[1024];
    static const struct {
        const char *name, *body, *needle;
    } data[] = {
        {"a_badnum.ply", "0 0 0\n1 0 x\n0 1 0\n3 0 1 2\n", ":11: bad number 'x'"},
        {"a_nan.ply", "0 0 0\n1 0 nan\n0 1 0\n3 0 1 2\n", ":11:"},
        {"a_inf.ply", "0 0 0\n1 0 0\n0 1 inf\n3 0 1 2\n", "not a finite"},
        {"a_range.ply", "0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n", ":13: face 0: vertex index 3 out of range (3 vertices)"},
        {"a_negidx.ply", "0 0 0\n1 0 0\n0 1 0\n3 0 1 -1\n", "out of range"},
        {"a_short.ply", "0 0 0\n1 0 0\n0 1 0\n2 0 1\n", "face 0 has 2 vertices"},
        {"a_badcount.ply", "0 0 0\n1 0 0\n0 1 0\n300 0 1 2\n", "out of range"},
        {"a_trunc.ply", "0 0 0\n1 0 0\n0 1 0\n3 0 1\n", "truncated face data"},
        {"a_floatidx.ply", "0 0 0\n1 0 0\n0 1 0\n3 0 1 1.5\n", "bad integer"},
    };
    for (size_t i = 0; i < sizeof data / sizeof data[0]; i++) {
        snprintf(t, sizeof t, "%s%s", H, data[i].body);
        expect_fail_text(data[i].name, t, data[i].needle);
    }
    static const struct {
        const char *name, *text, *needle;
    } hdr[] = {
        {"h_magic.ply", "plx\nformat ascii 1.0\nend_header\n", ":1: not a PLY file"},
        {"h_fmt.ply", "ply\nformat binary_middle_endian 1.0\nend_header\n", ":2: unknown format"},
        {"h_ver.ply", "ply\nformat ascii 2.0\nend_header\n", ":2: unsupported PLY version"},
        {"h_nofmt.ply", "ply\nelement vertex 3\nend_header\n", ":2: expected a format line"},
        {"h_noend.ply", "ply\nformat ascii 1.0\nelement vertex 3\n", "no end_header"},
        {"h_prop.ply", "ply\nformat ascii 1.0\nproperty float x\nend_header\n", ":3: property before any element"},
        {"h_type.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty real x\nend_header\n", ":4: unknown property type 'real'"},
        {"h_lcount.ply", "ply\nformat ascii 1.0\nelement face 1\nproperty list float int vertex_indices\nend_header\n",
         "not an integer type"},
        {"h_count.ply", "ply\nformat ascii 1.0\nelement vertex -3\nend_header\n", ":3: bad element count"},
        {"h_count2.ply", "ply\nformat ascii 1.0\nelement vertex 99999999999\nend_header\n", "bad element count"},
        {"h_kw.ply", "ply\nformat ascii 1.0\nbogus line\nend_header\n", ":3: unknown header keyword 'bogus'"},
        {"h_novert.ply", "ply\nformat ascii 1.0\nelement face 0\nproperty list uchar int vertex_indices\nend_header\n",
         "no 'vertex' element"},
        {"h_noxyz.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
                        "element face 0\nproperty list uchar int vertex_indices\nend_header\n0 0\n", "lacks scalar x, y and z"},
        {"h_noface.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\n"
                         "end_header\n0 0 0\n", "point clouds"},
        {"h_floatidx.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\n"
                           "element face 1\nproperty list uchar float vertex_indices\nend_header\n0 0 0\n3 0 0 0\n",
         "not an integer type"},
        {"h_empty.ply", "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
                        "element face 0\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n",
         "empty mesh"},
        {"h_liar.ply", "ply\nformat binary_little_endian 1.0\nelement vertex 4000000000\nproperty float x\n"
                       "property float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\n"
                       "end_header\n", "truncated vertex data"},
        {"h_zero.ply", "", ":1:"},
    };
    for (size_t i = 0; i < sizeof hdr / sizeof hdr[0]; i++) expect_fail_text(hdr[i].name, hdr[i].text, hdr[i].needle);

    /* Binary NaN coordinate and out-of-range index report byte offsets. */
    static wbuf w;
    const char *bh = "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                     "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n";
    size_t hl = strlen(bh);
    w.n = 0;
    memcpy(w.d, bh, hl);
    w.n = hl;
    int swap = host_be();
    float v[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    for (int i = 0; i < 9; i++) put(&w, &v[i], 4, swap);
    unsigned char three = 3;
    put(&w, &three, 1, 0);
    int32_t idx[3] = {0, 1, 5};
    for (int i = 0; i < 3; i++) put(&w, &idx[i], 4, swap);
    check_write_file(check_path("b_range.ply"), w.d, w.n);
    rt_err e = {0};
    rt_scene *s = rt_scene_load(check_path("b_range.ply"), &e);
    char want[64];
    snprintf(want, sizeof want, "byte %zu: face 0: vertex index 5 out of range", hl + 36 + 1 + 8);
    CHECK(s == NULL && strstr(e.msg, want), "binary range: '%s' (want '%s')", e.msg, want);
    rt_scene_free(s);
    w.d[hl + 4] = 0, w.d[hl + 5] = 0, w.d[hl + 6] = 0xc0, w.d[hl + 7] = 0x7f; /* y of vertex 0: NaN (LE) */
    check_write_file(check_path("b_nan.ply"), w.d, w.n);
    s = rt_scene_load(check_path("b_nan.ply"), &e);
    snprintf(want, sizeof want, "byte %zu: vertex 0: coordinate is not a finite", hl + 4);
    CHECK(s == NULL && strstr(e.msg, want), "binary NaN: '%s' (want '%s')", e.msg, want);
    rt_scene_free(s);
}

/* ------------------------------------------------------------------------ */
/* MTL                                                                       */

/* In the format of McGuire's CornellBox-Original.mtl (Williams College,
 * public domain): Ns/Ni/d/Tr/Tf/illum/Ka/Kd/Ks/Ke per material, trailing
 * comments, the light emitting through Ke. */
static const char cb_mtl[] =
    "# The original Cornell Box in OBJ format.\n"
    "# Note that the real box is not a perfect cube, so\n"
    "# the faces are imperfect in this data set.\n"
    "\n"
    "newmtl leftWall\n"
    "Ns 10.0000\nNi 1.5000\nd 1.0000\nTr 0.0000\nTf 1.0000 1.0000 1.0000\nillum 2\n"
    "Ka 0.63 0.065 0.05   # Dummy ambient color\n"
    "Kd 0.63 0.065 0.05\nKs 0 0 0\nKe 0 0 0\n"
    "\n"
    "newmtl rightWall\n"
    "Ns 10.0000\nNi 1.5000\nd 1.0000\nTr 0.0000\nTf 1.0000 1.0000 1.0000\nillum 2\n"
    "Ka 0.14 0.45 0.091   # Dummy ambient color\n"
    "Kd 0.14 0.45 0.091\nKs 0 0 0\nKe 0 0 0\n"
    "\n"
    "newmtl floor\n"
    "Ns 10.0000\nNi 1.0000\nd 1.0000\nTr 0.0000\nTf 1.0000 1.0000 1.0000\nillum 2\n"
    "Ka 0.725 0.71 0.68   # Dummy ambient color\n"
    "Kd 0.725 0.71 0.68\nKs 0 0 0\nKe 0 0 0\n"
    "\n"
    "newmtl light\n"
    "Ns 10.0000\nNi 1.5000\nd 1.0000\nTr 0.0000\nTf 1.0000 1.0000 1.0000\nillum 2\n"
    "Ka 0.78 0.78 0.78   # Dummy ambient color\n"
    "Kd 0.78 0.78 0.78\nKs 0 0 0\nKe 17 12 4\n";

static const char cb_obj[] =
    "# The original Cornell Box in OBJ format.\n"
    "mtllib CornellBox-Original.mtl\n"
    "\n"
    "o stray\n" /* before any usemtl: the default material */
    "v 0.5 0.5 0.5\nv 0.6 0.5 0.5\nv 0.5 0.6 0.5\n"
    "f -3 -2 -1\n"
    "o floor\n"
    "usemtl floor\n"
    "v -1.01 0.00 0.99\nv 1.00 0.00 0.99\nv 1.00 0.00 -1.04\nv -0.99 0.00 -1.04\n"
    "g floor\n"
    "f -4 -3 -2 -1\n"
    "o leftWall\n"
    "usemtl leftWall\n"
    "v -1.02 1.99 0.99\nv -1.02 1.99 -1.04\nv -0.99 0.00 -1.04\nv -1.01 0.00 0.99\n"
    "f -4 -3 -2 -1\n"
    "o rightWall\n"
    "usemtl rightWall\n"
    "v 1.00 0.00 -1.04\nv 1.00 0.00 0.99\nv 0.99 1.99 0.99\nv 0.99 1.99 -1.04\n"
    "f -4 -3 -2 -1\n"
    "usemtl floor\n" /* switching back mid-file reuses the table entry */
    "f 4 5 6\n"
    "o light\n"
    "usemtl light\n"
    "v -0.24 1.98 0.16\nv -0.24 1.98 -0.22\nv 0.23 1.98 -0.22\nv 0.23 1.98 0.16\n"
    "f -4 -3 -2 -1\n";

static int rgb_is(const float *c, float r, float g, float b) { return c[0] == r && c[1] == g && c[2] == b; }

static void test_mtl_cornell(void)
{
    char dir[600], obj[700];
    snprintf(dir, sizeof dir, "%s/cb", check_dir);
    mkdir(dir, 0700);
    snprintf(obj, sizeof obj, "%s/CornellBox-Original.obj", dir);
    check_write_file(check_path("cb/CornellBox-Original.mtl"), cb_mtl, strlen(cb_mtl));
    check_write_file(obj, cb_obj, strlen(cb_obj));
    rt_err e = {0};
    rt_scene *s = rt_scene_load(obj, &e); /* the MTL is found beside the OBJ, not in the working folder */
    CHECK(s != NULL, "CornellBox-Original: %s", e.msg);
    if (!s) return;
    CHECK(s->ntri == 1 + 2 * 4 + 1, "%u triangles", s->ntri);
    CHECK(s->warning[0] == 0, "warning '%s'", s->warning);
    /* Materials enter the table in order of first use. */
    CHECK(s->nmat == 5, "nmat %u", s->nmat);
    if (s->ntri == 10 && s->nmat == 5) {
        CHECK(s->shade[0].mat == 0 && rgb_is(s->shade[0].rgb, 0.7f, 0.7f, 0.7f), "face before usemtl");
        CHECK(s->shade[1].mat == 1 && s->shade[2].mat == 1 && rgb_is(s->shade[1].rgb, 0.725f, 0.71f, 0.68f),
              "floor");
        CHECK(s->shade[3].mat == 2 && rgb_is(s->shade[3].rgb, 0.63f, 0.065f, 0.05f), "left wall red");
        CHECK(s->shade[5].mat == 3 && rgb_is(s->shade[5].rgb, 0.14f, 0.45f, 0.091f), "right wall green");
        CHECK(s->shade[7].mat == 1 && rgb_is(s->shade[7].rgb, 0.725f, 0.71f, 0.68f), "usemtl floor again");
        CHECK(s->shade[8].mat == 4 && s->shade[9].mat == 4 && rgb_is(s->shade[8].rgb, 0.78f, 0.78f, 0.78f),
              "light");
        CHECK(!strcmp(s->mat[2].name, "leftWall") && !strcmp(s->mat[4].name, "light"), "names");
        const rt_material *l = &s->mat[4];
        CHECK(l->ke[0] == 17 && l->ke[1] == 12 && l->ke[2] == 4 && l->flags == RT_MAT_EMIT, "light Ke");
        /* illum 2: Ni 1.5 and Tf do not make a wall glass; ior stays 1. */
        CHECK(s->mat[2].flags == 0 && s->mat[2].ior == 1.0f && s->mat[2].kt[0] == 0, "walls plain");
    }
    CHECK(rt_scene_material_flags(s) == RT_MAT_EMIT, "flags %u", (unsigned)rt_scene_material_flags(s));
    rt_scene_free(s);
}

/* Loads MTL text (as lib.mtl beside an OBJ using material m) and returns
 * the scene, or NULL with the message in e. */
static rt_scene *load_mtl_text(const char *name, const char *mtl, rt_err *e)
{
    char mname[64], oname[64], obj[256];
    snprintf(mname, sizeof mname, "%s.mtl", name);
    snprintf(oname, sizeof oname, "%s.obj", name);
    check_write_file(check_path(mname), mtl, strlen(mtl));
    snprintf(obj, sizeof obj, "mtllib %s\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl m\nf 1 2 3\n", mname);
    check_write_file(check_path(oname), obj, strlen(obj));
    return rt_scene_load(check_path(oname), e);
}

static void test_mtl_mapping(void)
{
    static const struct {
        const char *name, *mtl;
        float ks, kt, ior, ke;
        uint32_t flags;
    } cases[] = {
        {"ill0", "newmtl m\nillum 0\nKs 0.5 0.5 0.5\n", 0, 0, 1, 0, 0},
        {"ill1", "newmtl m\nillum 1\nKs 0.5\n", 0, 0, 1, 0, 0},
        {"ill2", "newmtl m\nKs 0.5\nNi 1.3\nd 0.5\n", 0, 0, 1, 0, 0}, /* default illum 2 */
        {"ill3", "newmtl m\nillum 3\nKs 0.75\n", 0.75f, 0, 1, 0, RT_MAT_SPECULAR},
        {"ill5", "newmtl m\nillum 5\nKs 0.25 0.25 0.25\n", 0.25f, 0, 1, 0, RT_MAT_SPECULAR},
        {"ill4", "newmtl m\nillum 4\nKs 0.1\nd 0.25\nNi 1.33\n", 0.1f, 0.75f, 1.33f, 0,
         RT_MAT_SPECULAR | RT_MAT_TRANSMIT},
        {"ill6", "newmtl m\nillum 6\nTr 0.5\nNi 1.5\n", 0, 0.5f, 1.5f, 0, RT_MAT_TRANSMIT},
        {"ill7", "newmtl m\nillum 7\nNi 1.5\nTf 0.5\n", 0, 0.5f, 1.5f, 0, RT_MAT_TRANSMIT}, /* no d: t = 1 */
        {"ill7d", "newmtl m\nillum 7\nd 1\nKs 0.5\nNi 2\n", 0.5f, 0, 1, 0, RT_MAT_SPECULAR}, /* opaque */
        {"emit", "newmtl m\nillum 1\nKe 2 2 2\nfoo bar baz\nmap_Kd tex.png\n", 0, 0, 1, 2, RT_MAT_EMIT},
        {"crlf", "newmtl m\r\nillum 3\r\nKs 1\r\n", 1, 0, 1, 0, RT_MAT_SPECULAR},
        {"case", "newmtl m\nILLUM 3\nks 0.5\n", 0.5f, 0, 1, 0, RT_MAT_SPECULAR},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        rt_err e = {0};
        rt_scene *s = load_mtl_text(cases[i].name, cases[i].mtl, &e);
        CHECK(s != NULL, "%s: %s", cases[i].name, e.msg);
        if (!s) continue;
        const rt_material *m = &s->mat[s->shade[0].mat];
        CHECK(s->shade[0].mat == 1 && m->ks[1] == cases[i].ks && m->kt[2] == cases[i].kt && m->ior == cases[i].ior &&
                  m->ke[0] == cases[i].ke && m->flags == cases[i].flags,
              "%s: ks %g kt %g ior %g ke %g flags %u", cases[i].name, (double)m->ks[1], (double)m->kt[2],
              (double)m->ior, (double)m->ke[0], (unsigned)m->flags);
        rt_scene_free(s);
    }
    /* Tf colours the transmittance; Kd with one number is grey. */
    rt_err e = {0};
    rt_scene *s = load_mtl_text("tf", "newmtl m\nillum 7\nTf 1 0.5 0.25\nd 0.5\nKd 0.25\n", &e);
    CHECK(s != NULL, "tf: %s", e.msg);
    if (s) {
        const rt_material *m = &s->mat[1];
        CHECK(m->kt[0] == 0.5f && m->kt[1] == 0.25f && m->kt[2] == 0.125f, "Tf: kt %g %g %g", (double)m->kt[0],
              (double)m->kt[1], (double)m->kt[2]);
        CHECK(rgb_is(s->shade[0].rgb, 0.25f, 0.25f, 0.25f), "Kd grey");
        rt_scene_free(s);
    }
    /* Several libraries on one mtllib line; a later one defines m. */
    write_text(check_path("a.mtl"), "newmtl x\nKd 1 0 0\n");
    write_text(check_path("b.mtl"), "newmtl m\nKd 0 0 1\nillum 3\nKs 0.5\n");
    const char two[] = "mtllib a.mtl   b.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl x\nf 1 2 3\nusemtl m\nf 1 2 3\n";
    s = expect_ok_text("two.obj", two, 2);
    if (s && s->ntri == 2) {
        CHECK(rgb_is(s->shade[0].rgb, 1, 0, 0) && rgb_is(s->shade[1].rgb, 0, 0, 1), "colours from two libraries");
        CHECK(s->shade[0].mat == 1 && s->shade[1].mat == 2 && s->mat[2].ks[0] == 0.5f, "materials from two libraries");
    }
    rt_scene_free(s);
}

static void test_mtl_errors(void)
{
    /* Malformed MTL: one line naming the MTL file and its line. */
    static const struct {
        const char *name, *mtl, *needle;
    } bad[] = {
        {"e_num", "newmtl m\nKd 0.5 x 0.5\n", "e_num.mtl:2: Kd: bad number 'x'"},
        {"e_nan", "# c\nnewmtl m\nKs nan 0 0\n", "e_nan.mtl:3: Ks: 'nan' is not a finite number"},
        {"e_inf", "newmtl m\nKe 1 1 inf\n", "e_inf.mtl:2: Ke: 'inf' is not a finite number"},
        {"e_big", "newmtl m\nKe 1 1 1e39\n", "e_big.mtl:2: Ke:"},
        {"e_neg", "newmtl m\n\nKd -0.1 0 0\n", "e_neg.mtl:3: Kd: negative value '-0.1'"},
        {"e_ni", "newmtl m\nNi 0.5\n", "e_ni.mtl:2: Ni 0.5 outside [1, 100]"},
        {"e_ni0", "newmtl m\nillum 2\nNi 0\n", "e_ni0.mtl:3: Ni 0 outside"},
        {"e_d", "newmtl m\nd 1.5\n", "e_d.mtl:2: d 1.5 outside [0, 1]"},
        {"e_tr", "newmtl m\nTr 2\n", "e_tr.mtl:2: Tr 2 outside [0, 1]"},
        {"e_ill", "newmtl m\nillum 11\n", "e_ill.mtl:2: illum 11 is not"},
        {"e_ill2", "newmtl m\nillum 2.5\n", "e_ill2.mtl:2: illum 2.5 is not"},
        {"e_two", "newmtl m\nKd 1 1\n", "e_two.mtl:2: Kd: 2 numbers"},
        {"e_four", "newmtl m\nKd 1 1 1 1\n", "e_four.mtl:2: Kd: more than 3 numbers"},
        {"e_empty", "newmtl m\nKs\n", "e_empty.mtl:2: Ks without a value"},
        {"e_before", "Kd 1 1 1\nnewmtl m\n", "e_before.mtl:1: Kd before any newmtl"},
        {"e_noname", "newmtl\n", "e_noname.mtl:1: newmtl without a name"},
        {"e_tf", "newmtl m\nTf 1 nan 1\n", "e_tf.mtl:2: Tf:"},
        {"e_tf2", "newmtl m\nTf 1 1.5 1\n", "e_tf2.mtl:2: Tf 1.5 outside [0, 1]"},
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        rt_err e = {0};
        rt_scene *s = load_mtl_text(bad[i].name, bad[i].mtl, &e);
        CHECK(s == NULL && strstr(e.msg, bad[i].needle) && !strchr(e.msg, '\n'), "%s: '%s' (want '%s')",
              bad[i].name, e.msg, bad[i].needle);
        rt_scene_free(s);
    }
    /* OBJ side: usemtl of an undefined material, names missing. */
    write_text(check_path("ok.mtl"), "newmtl m\nKd 1 0 0\n");
    static const struct {
        const char *name, *text, *needle;
    } obad[] = {
        {"undef.obj", "mtllib ok.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nusemtl mm\nf 1 2 3\n",
         "undef.obj:6: usemtl mm: no such material"},
        {"noname.obj", "mtllib ok.mtl\nusemtl   \n", "noname.obj:2: usemtl without a name"},
        {"nolib.obj", "mtllib\n", "nolib.obj:1: mtllib without a file name"},
        /* a library used before it is named */
        {"late.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nmtllib ok.mtl\nusemtl x\nf 1 2 3\n", "late.obj:5: usemtl x"},
    };
    for (size_t i = 0; i < sizeof obad / sizeof obad[0]; i++) expect_fail_text(obad[i].name, obad[i].text, obad[i].needle);
    /* Random corruption of an MTL: loads, or fails naming the OBJ or the
     * MTL; never a crash. */
    static const char good[] = "newmtl m\nKd 0.5 0.5 0.5\nKs 0.2\nNi 1.5\nd 0.5\nTf 1 1 1\nillum 7\nKe 0 0 0\n";
    static const char alphabet[] = "0123456789-+. \n\r\t#xnaiNdKsTf";
    uint32_t st = 4242;
    char buf[sizeof good];
    for (int it = 0; it < 800; it++) {
        memcpy(buf, good, sizeof good);
        for (int k = 0; k < 1 + it % 3; k++) {
            st = st * 1664525u + 1013904223u;
            size_t at = (st >> 8) % (sizeof good - 1);
            st = st * 1664525u + 1013904223u;
            buf[at] = alphabet[(st >> 24) % (sizeof alphabet - 1)];
        }
        rt_err e = {0};
        rt_scene *s = load_mtl_text("fz", buf, &e);
        if (s) {
            const rt_material *m = &s->mat[s->shade[0].mat];
            CHECK(m->ior >= 1 && m->kt[0] >= 0 && m->kt[0] <= 1, "fuzz: ior %g kt %g", (double)m->ior, (double)m->kt[0]);
        } else CHECK(strstr(e.msg, "fz.mtl:") || strstr(e.msg, "fz.obj:"), "fuzz: message '%s'", e.msg);
        rt_scene_free(s);
    }
    /* A library that is a folder, not a file: an error, not a warning. */
    mkdir(check_path("dir.mtl"), 0700);
    expect_fail_text("dirlib.obj", "mtllib dir.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
                     "dirlib.obj:1: material library ");
}

/* A missing library loads with the default material and a warning; so does
 * a usemtl with no library named at all. */
static void test_mtl_missing(void)
{
    const char text[] = "v 0 0 0\nv 1 0 0\nv 0 1 0\nmtllib gone.mtl ok2.mtl\nusemtl m\nf 1 2 3\nusemtl x\nf 1 2 3\n";
    write_text(check_path("ok2.mtl"), "newmtl x\nillum 3\nKs 0.5\nKd 0 1 0\n");
    rt_scene *s = expect_ok_text("missing.obj", text, 2);
    if (s) {
        CHECK(strstr(s->warning, "missing.obj:4: material library ") && strstr(s->warning, "gone.mtl not found") &&
                  strstr(s->warning, "missing.obj:5: usemtl m: not in the libraries found; default material"),
              "warning '%s'", s->warning);
        CHECK(s->nwarn == 2 && !strcmp(s->warn[0].kind, "mtllib missing") && !strcmp(s->warn[1].kind, "usemtl unknown") &&
                  s->warn[1].count == 1 && strstr(s->warn[1].first, "missing.obj:5"),
              "warnings: %u kinds", s->nwarn);
        CHECK(s->ntri == 2 && s->shade[0].mat == 0 && rgb_is(s->shade[0].rgb, 0.7f, 0.7f, 0.7f),
              "undefined material m: default");
        CHECK(s->ntri == 2 && s->shade[1].mat == 1 && rgb_is(s->shade[1].rgb, 0, 1, 0), "x from the library found");
        rt_scene_free(s);
    }
    s = expect_ok_text("nomtllib.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl red\nf 1 2 3\n", 1);
    if (s) {
        CHECK(strstr(s->warning, "nomtllib.obj:4: usemtl red: no mtllib") != NULL, "warning '%s'", s->warning);
        CHECK(s->nmat == 1 && s->shade[0].mat == 0, "default material");
        rt_scene_free(s);
    }
}

/* Meshes without materials keep the hashes they had before materials;
 * material=PRESET works on mesh files. */
static void test_mesh_hashes(void)
{
    /* cube.obj says "usemtl grey" without a library, forms.obj names a
     * library that does not exist: both load as before, with a warning. */
    static const struct {
        const char *file, *params;
        uint64_t hash;
        uint32_t flags;
        const char *warning;
    } golden[] = {
        {"cube.obj", "", UINT64_C(0x3566215f5c38233e), 0, "cube.obj:12: usemtl grey: no mtllib names a library"},
        {"forms.obj", "", UINT64_C(0x389091ddc7b3a129), 0, "forms.obj:2: material library "},
        {"tetra_ascii.ply", "", UINT64_C(0xc5ddf801132c1a07), 0, NULL},
        {"tetra_ascii.ply", ":material=diffuse", UINT64_C(0xc5ddf801132c1a07), 0, NULL},
        {"tetra_ascii.ply", ":material=mirror", 0, RT_MAT_SPECULAR, NULL},
        {"cube.obj", ":material=glass", 0, RT_MAT_TRANSMIT, "usemtl grey"},
    };
    for (size_t i = 0; i < sizeof golden / sizeof golden[0]; i++) {
        char spec[700];
        snprintf(spec, sizeof spec, "%s%s", datafile(golden[i].file), golden[i].params);
        rt_err e = {0};
        rt_scene *s = rt_scene_load(spec, &e);
        CHECK(s != NULL, "%s: %s", spec, e.msg);
        if (!s) continue;
        if (golden[i].hash)
            CHECK(rt_scene_hash(s) == golden[i].hash, "%s%s: hash %016" PRIx64 ", golden %016" PRIx64,
                  golden[i].file, golden[i].params, rt_scene_hash(s), golden[i].hash);
        CHECK(rt_scene_material_flags(s) == golden[i].flags, "%s%s: flags %u", golden[i].file, golden[i].params,
              (unsigned)rt_scene_material_flags(s));
        CHECK(s->nmat == (golden[i].flags ? 2u : 1u), "%s%s: nmat %u", golden[i].file, golden[i].params, s->nmat);
        CHECK(golden[i].warning ? strstr(s->warning, golden[i].warning) != NULL : s->warning[0] == 0,
              "%s%s: warning '%s'", golden[i].file, golden[i].params, s->warning);
        CHECK(!strcmp(s->params, golden[i].params[0] ? golden[i].params + 1 : ""), "params '%s'", s->params);
        rt_scene_free(s);
    }
    rt_err e = {0};
    char spec[700];
    snprintf(spec, sizeof spec, "%s:scale=2", datafile("cube.obj"));
    rt_scene *s = rt_scene_load(spec, &e);
    CHECK(s == NULL && strstr(e.msg, "unknown parameter 'scale=2'"), "mesh parameter: '%s'", e.msg);
    rt_scene_free(s);
}

/* Scene files: regular files only, a size cap, material libraries inside
 * the OBJ's folder (docs/reliability.md §16). Before: `mtllib /dev/zero`
 * read without end, a FIFO blocked for ever, ../../etc/passwd was read. */
static void test_scene_files(void)
{
    rt_err e = {0};
    char out[256];
    /* rt_path_within: the rule on names */
    static const struct { const char *rel; int ok; } cases[] = {
        {"a.mtl", 1}, {"./a.mtl", 1}, {"sub/a.mtl", 1}, {"sub/../a.mtl", 1}, {"sub//a.mtl", 1},
        {"a/b/../../c.mtl", 1}, {"..a.mtl", 1}, {"a..", 1},
        {"", 0}, {"/etc/passwd", 0}, {"/dev/zero", 0}, {"../a.mtl", 0}, {"..", 0}, {".", 0},
        {"sub/../../a.mtl", 0}, {"./../a.mtl", 0}, {"a/b/../../../c", 0}, {"../../../../etc/passwd", 0},
        {"sub/..", 0},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        int r = rt_path_within("dir/", cases[i].rel, out, sizeof out, &e);
        CHECK((r == 0) == cases[i].ok, "rt_path_within('%s') = %d (%s)", cases[i].rel, r, e.msg);
        if (r == 0) {
            char want[256];
            snprintf(want, sizeof want, "dir/%s", cases[i].rel);
            CHECK(!strcmp(out, want), "rt_path_within('%s') gave '%s'", cases[i].rel, out);
        }
    }
    CHECK(rt_path_within("", "a.mtl", out, sizeof out, &e) == 0 && !strcmp(out, "a.mtl"), "no folder: '%s'", out);
    CHECK(rt_path_within("d/", "abcdef", out, 5, &e) < 0 && strstr(e.msg, "too long"), "overflow: '%s'", e.msg);
    CHECK(!strcmp(rt_path_dir("a/b/c.obj", out, sizeof out), "a/b/"), "rt_path_dir: '%s'", out);
    CHECK(!strcmp(rt_path_dir("c.obj", out, sizeof out), ""), "rt_path_dir: '%s'", out);
    CHECK(!strcmp(rt_path_dir("/c.obj", out, sizeof out), "/"), "rt_path_dir: '%s'", out);

    /* rt_open_regular: devices, FIFOs, folders and big files refused */
    FILE *f;
    f = rt_open_regular("/dev/zero", 1 << 20, &e);
    CHECK(!f && strstr(e.msg, "not a regular file") && strstr(e.msg, "character device"), "/dev/zero: %s", e.msg);
    if (f) fclose(f);
    const char *fifo = check_path("fifo.obj");
    CHECK(mkfifo(fifo, 0600) == 0, "mkfifo");
    f = rt_open_regular(fifo, 1 << 20, &e); /* must not block */
    CHECK(!f && strstr(e.msg, "FIFO"), "FIFO: %s", e.msg);
    if (f) fclose(f);
    f = rt_open_regular(check_dir, 1 << 20, &e);
    CHECK(!f && strstr(e.msg, "directory"), "folder: %s", e.msg);
    if (f) fclose(f);
    const char *big = check_path("big.obj");
    write_text(big, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    f = rt_open_regular(big, 10, &e);
    CHECK(!f && strstr(e.msg, "larger than the limit of 10 bytes"), "cap: %s", e.msg);
    if (f) fclose(f);
    f = rt_open_regular(big, 1000, &e);
    CHECK(f != NULL, "regular file refused: %s", e.msg);
    if (f) fclose(f);
    f = rt_open_regular(check_path("none.obj"), 1000, &e);
    CHECK(!f && errno == ENOENT, "missing file: errno %d", errno);
    char *buf = NULL;
    size_t n = 0;
    CHECK(rt_slurp_regular(big, 1000, &buf, &n, &e) == 0 && n == 32 && buf[n] == 0, "slurp: %zu %s", n, e.msg);
    free(buf);

    /* the loaders: a mesh that is a FIFO or a link to /dev/zero, over the cap */
    const char *zl = check_path("devzero.obj");
    CHECK(symlink("/dev/zero", zl) == 0, "symlink");
    rt_scene *s = rt_scene_load(zl, &e);
    CHECK(!s && strstr(e.msg, "not a regular file"), "devzero.obj: %s", e.msg);
    rt_scene_free(s);
    s = rt_scene_load(fifo, &e);
    CHECK(!s && strstr(e.msg, "FIFO"), "fifo.obj: %s", e.msg);
    rt_scene_free(s);
    const char *pfifo = check_path("fifo.ply");
    CHECK(mkfifo(pfifo, 0600) == 0, "mkfifo");
    s = rt_scene_load(pfifo, &e);
    CHECK(!s && strstr(e.msg, "FIFO"), "fifo.ply: %s", e.msg);
    rt_scene_free(s);
    uint64_t keep = rt_scene_max_bytes;
    rt_scene_max_bytes = 20;
    s = rt_scene_load(big, &e);
    CHECK(!s && strstr(e.msg, "larger than the limit"), "cap: %s", e.msg);
    rt_scene_free(s);
    rt_scene_max_bytes = keep;
    s = rt_scene_load(big, &e);
    CHECK(s && s->ntri == 1, "big.obj under the default cap: %s", e.msg);
    rt_scene_free(s);

    /* material libraries: outside the folder, devices and FIFOs refused */
    const char *tri = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
    char text[512];
    static const char *const bad[] = {"/dev/zero", "/etc/passwd", "../x.mtl", "../../../../etc/passwd",
                                      "sub/../../x.mtl"};
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        snprintf(text, sizeof text, "mtllib %s\n%s", bad[i], tri);
        expect_fail_text("lib.obj", text, "material library");
    }
    const char *mfifo = check_path("fifo.mtl");
    CHECK(mkfifo(mfifo, 0600) == 0, "mkfifo");
    snprintf(text, sizeof text, "mtllib fifo.mtl\n%s", tri);
    expect_fail_text("lib.obj", text, "FIFO");
    CHECK(symlink("/dev/zero", check_path("devzero.mtl")) == 0, "symlink");
    snprintf(text, sizeof text, "mtllib devzero.mtl\n%s", tri);
    expect_fail_text("lib.obj", text, "character device");
    /* inside the folder: fine, also through a subfolder and back */
    CHECK(mkdir(check_path("sub"), 0700) == 0, "mkdir");
    write_text(check_path("red.mtl"), "newmtl red\nKd 1 0 0\n");
    snprintf(text, sizeof text, "mtllib sub/../red.mtl\n%susemtl red\nf 1 2 3\n", tri);
    s = expect_ok_text("lib.obj", text, 2);
    CHECK(s && s->tri && s->shade, "load");
    rt_scene_free(s);
}

/* Line ends, hex floats, duplicated PLY properties (docs/reliability.md
 * §26). Before: a CR-only file failed with "bad number 'v'", "0x1p0" was
 * a coordinate, a second `x` property silently replaced the first. */
static void test_lesser_formats(void)
{
    static const char *const ends[] = {"\n", "\r\n", "\r"};
    uint64_t h0 = 0;
    for (int k = 0; k < 3; k++) {
        char text[512];
        snprintf(text, sizeof text, "# tri%sv 0 0 0%sv 1 0 0%sv 0 1 0%sv 0 0 1%sf 1 2 3%sf 1 2 4%s", ends[k], ends[k],
                 ends[k], ends[k], ends[k], ends[k], ends[k]);
        rt_scene *s = expect_ok_text("ends.obj", text, 2);
        if (s && k == 0) h0 = rt_scene_hash(s);
        if (s) CHECK(rt_scene_hash(s) == h0, "line ends %d: another scene", k);
        rt_scene_free(s);
    }
    /* a CR-only MTL beside it */
    write_text(check_path("cr.mtl"), "newmtl red\rKd 1 0 0\r");
    rt_scene *s = expect_ok_text("crm.obj", "mtllib cr.mtl\rv 0 0 0\rv 1 0 0\rv 0 1 0\rusemtl red\rf 1 2 3\r", 1);
    if (s) CHECK(s->shade && s->shade[0].rgb[0] == 1.0f && s->shade[0].rgb[1] == 0.0f, "CR-only MTL: colour");
    rt_scene_free(s);
    /* the line number of a CR-only file counts CRs */
    expect_fail_text("crbad.obj", "v 0 0 0\rv 1 0 0\rv 0 1 0\rf 1 2 9\r", "crbad.obj:4:");
    expect_fail_text("hex.obj", "v 0 0 0\nv 0x1p0 0 0\nv 0 1 0\nf 1 2 3\n", "hex.obj:2: bad number '0x1p0'");
    write_text(check_path("hex.mtl"), "newmtl a\nKd 0x1p-1 0 0\n");
    write_text(check_path("hexm.obj"), "mtllib hex.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    rt_err e = {0};
    s = rt_scene_load(check_path("hexm.obj"), &e);
    CHECK(!s && strstr(e.msg, "hex.mtl:2: Kd: bad number '0x1p-1'"), "hex in MTL: %s", e.msg);
    rt_scene_free(s);
    expect_fail_text("hex.ply",
                     "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
                     "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n0x1p0 0 0\n0 1 0\n"
                     "3 0 1 2\n",
                     "bad number '0x1p0'");
    expect_fail_text("dupx.ply",
                     "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
                     "property float x\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
                     "0 0 0 5\n1 0 0 5\n0 1 0 5\n3 0 1 2\n",
                     "dupx.ply:7: property 'x' given twice in element 'vertex'");
}

/* The shared PLY reader (ply_read.c): the mesh the PLY loader, the bunny
 * and pbrt's plymesh all read; its checker passes on a parsed mesh and
 * names the invariant a corrupted one breaks. A gzipped OBJ (by content,
 * under a plain name) loads as the plain one. */
static void test_ply_reader(void)
{
    const char *ply = "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
                      "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n"
                      "4 0 1 2 3\n";
    rt_ply_mesh m;
    rt_err e = {0};
    CHECK(rt_ply_parse("q.ply", ply, strlen(ply), &m, &e) == 0, "parse: %s", e.msg);
    CHECK(m.nv == 4 && m.nidx == 6 && m.idx[0] == 0 && m.idx[1] == 1 && m.idx[2] == 2 && m.idx[3] == 0 &&
              m.idx[4] == 2 && m.idx[5] == 3,
          "the quad fanned: nv %u nidx %zu", m.nv, m.nidx);
    CHECK(rt_ply_check(&m, &e) == 0, "check: %s", e.msg);
    m.idx[4] = 4;
    CHECK(rt_ply_check(&m, &e) < 0 && strstr(e.msg, "(P1)"), "P1 not caught: %s", e.msg);
    m.idx[4] = 2;
    m.nidx = 5;
    CHECK(rt_ply_check(&m, &e) < 0 && strstr(e.msg, "(P2)"), "P2 not caught: %s", e.msg);
    m.nidx = 6;
    m.v[3].y = 1e20f;
    CHECK(rt_ply_check(&m, &e) < 0 && strstr(e.msg, "(P3)"), "P3 not caught: %s", e.msg);
    rt_ply_mesh_free(&m);
    CHECK(rt_ply_parse("bad.ply", "ply\nformat ascii 1.0\n", 21, &m, &e) < 0 && m.v == NULL && m.idx == NULL &&
              strstr(e.msg, "bad.ply:3: header has no end_header line"),
          "bad header: %s", e.msg);
    /* a gzipped OBJ under a plain name: the same triangles */
    const char *obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
    write_text(check_path("plain.obj"), obj);
    char cmd[1200];
    snprintf(cmd, sizeof cmd, "%s", check_path("gz.obj"));
    gzFile g = gzopen(cmd, "wb");
    CHECK(g != NULL, "gzopen");
    if (g) {
        gzwrite(g, obj, (unsigned)strlen(obj));
        gzclose(g);
    }
    rt_scene *a = rt_scene_load(check_path("plain.obj"), &e), *b = rt_scene_load(check_path("gz.obj"), &e);
    CHECK(a && b && a->ntri == 1 && b->ntri == 1 && !memcmp(a->tri, b->tri, sizeof *a->tri), "gzipped OBJ: %s", e.msg);
    rt_scene_free(a);
    rt_scene_free(b);
}

int main(void)
{
    if (!check_tmpdir("test_loaders")) {
        perror("mkdtemp");
        return 1;
    }
    test_obj();
    test_ply_formats();
    test_ply_malformed();
    test_mtl_cornell();
    test_mtl_mapping();
    test_mtl_errors();
    test_mtl_missing();
    test_mesh_hashes();
    test_scene_files();
    test_lesser_formats();
    test_ply_reader();
    if (check_rm_tree(check_dir) != 0) fprintf(stderr, "warning: could not remove %s\n", check_dir);
    if (failures) fprintf(stderr, "%d failure(s)\n", failures);
    else printf("test_loaders: all passed\n");
    return failures ? 1 : 0;
}
