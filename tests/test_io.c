/*
 * test_io.c -- reliability of inputs and outputs (docs/reliability.md).
 *
 * Outputs: the rules of outfile.c checked on the file system (missing,
 * regular, symlinked, dangling, directory and device targets), a failing
 * write at every small offset through the fault hook leaving the target
 * untouched and no temporary behind, and the same for the trace, PNG, PPM,
 * EXR and OBJ writers. Inputs: PLY headers that lie about their counts
 * (each must be refused well within a second; alarm(120) ends a spin), the
 * coordinate range, din files with NUL bytes, escaping of control bytes,
 * the size parser, and auto-framing for tall images. Exit 0 = all passed.
 */
#include "config.h"
#include "din.h"
#include "image.h"
#include "outfile.h"
#include "scene.h"
#include "scene_load.h"
#include "sindex.h"
#include "sindex_int.h"
#include "trace.h"
#include "check.h"

#include <dirent.h>
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>




/* Whole file as a NUL-terminated string (caller frees), or NULL. */
static char *read_all(const char *path, size_t *pn)
{
    char *b = NULL;
    size_t n = 0;
    rt_err e;
    if (rt_slurp(path, &b, &n, &e) < 0) return NULL;
    if (pn) *pn = n;
    return b;
}

/* Names in check_dir (besides "." and ".."), to catch leftover temporaries. */
static int count_entries(void)
{
    DIR *d = opendir(check_dir);
    int n = 0;
    struct dirent *de;
    while (d && (de = readdir(d)))
        if (strcmp(de->d_name, ".") && strcmp(de->d_name, "..")) n++;
    if (d) closedir(d);
    return n;
}

static void clean_dir(void)
{
    DIR *d = opendir(check_dir);
    struct dirent *de;
    while (d && (de = readdir(d))) {
        if (!strcmp(de->d_name, ".") || !strcmp(de->d_name, "..")) continue;
        const char *p = check_path(de->d_name);
        if (unlink(p) != 0) rmdir(p);
    }
    if (d) closedir(d);
}

static int write_text(const char *path, const char *text, rt_err *e)
{
    rt_out *o = rt_out_open(path, e);
    if (!o) return -1;
    fputs(text, rt_out_stream(o));
    return rt_out_commit(o, e);
}

/* ---- outfile rules ---------------------------------------------------------- */

static void test_outfile_rules(void)
{
    rt_err e = {0};
    struct stat st;
    clean_dir();

    /* missing target: created whole, with the umask's mode, nothing else */
    CHECK(write_text(check_path("a.txt"), "hello\n", &e) == 0, "write: %s", e.msg);
    char *b = read_all(check_path("a.txt"), NULL);
    CHECK(b && !strcmp(b, "hello\n"), "content '%s'", b ? b : "(none)");
    free(b);
    mode_t um = umask(022);
    umask(um);
    CHECK(stat(check_path("a.txt"), &st) == 0 && (st.st_mode & 0777) == (0666 & ~um), "mode %o",
          (unsigned)(st.st_mode & 0777));
    CHECK(count_entries() == 1, "%d entries after one write", count_entries());

    /* existing regular target: replaced, its mode kept */
    chmod(check_path("a.txt"), 0640);
    CHECK(write_text(check_path("a.txt"), "second\n", &e) == 0, "rewrite: %s", e.msg);
    b = read_all(check_path("a.txt"), NULL);
    CHECK(b && !strcmp(b, "second\n"), "content '%s'", b ? b : "(none)");
    free(b);
    CHECK(stat(check_path("a.txt"), &st) == 0 && (st.st_mode & 0777) == 0640, "mode %o not kept",
          (unsigned)(st.st_mode & 0777));

    /* symlink to a regular file: the link stays a link, the file changes */
    CHECK(symlink("a.txt", check_path("link")) == 0, "symlink");
    CHECK(write_text(check_path("link"), "via link\n", &e) == 0, "via link: %s", e.msg);
    CHECK(lstat(check_path("link"), &st) == 0 && S_ISLNK(st.st_mode), "the link was replaced");
    b = read_all(check_path("a.txt"), NULL);
    CHECK(b && !strcmp(b, "via link\n"), "target content '%s'", b ? b : "(none)");
    free(b);

    /* dangling symlink (and a chain of two): creates the target */
    CHECK(symlink("new.txt", check_path("dangle")) == 0 && symlink("dangle", check_path("chain")) == 0, "symlink");
    CHECK(write_text(check_path("chain"), "new\n", &e) == 0, "dangling: %s", e.msg);
    CHECK(lstat(check_path("chain"), &st) == 0 && S_ISLNK(st.st_mode), "chain link replaced");
    CHECK(lstat(check_path("new.txt"), &st) == 0 && S_ISREG(st.st_mode), "target not created");

    /* directory: a clear error, nothing left inside */
    CHECK(mkdir(check_path("d"), 0755) == 0, "mkdir");
    int before = count_entries();
    CHECK(write_text(check_path("d"), "x", &e) < 0 && strstr(e.msg, "is a directory"), "directory: '%s'", e.msg);
    CHECK(count_entries() == before, "entries changed");
    CHECK(rmdir(check_path("d")) == 0, "directory not empty: a temporary was left in it");

    /* symlink loop */
    CHECK(symlink("loop2", check_path("loop1")) == 0 && symlink("loop1", check_path("loop2")) == 0, "symlink");
    CHECK(write_text(check_path("loop1"), "x", &e) < 0 && strstr(e.msg, "symbolic links"), "loop: '%s'", e.msg);

    /* devices through a link: written in place, the link and device stay */
    CHECK(symlink("/dev/null", check_path("null")) == 0, "symlink");
    CHECK(write_text(check_path("null"), "gone\n", &e) == 0, "/dev/null: %s", e.msg);
    CHECK(lstat(check_path("null"), &st) == 0 && S_ISLNK(st.st_mode), "link to /dev/null replaced");
    CHECK(stat("/dev/null", &st) == 0 && S_ISCHR(st.st_mode), "/dev/null is no longer a device");
    if (stat("/dev/full", &st) == 0 && S_ISCHR(st.st_mode)) {
        CHECK(symlink("/dev/full", check_path("full")) == 0, "symlink");
        CHECK(write_text(check_path("full"), "x\n", &e) < 0 && strstr(e.msg, "No space left"), "/dev/full: '%s'",
              e.msg);
    }

    /* abort: no file, no temporary */
    before = count_entries();
    rt_out *o = rt_out_open(check_path("aborted"), &e);
    CHECK(o != NULL, "open: %s", e.msg);
    if (o) fputs("partial", rt_out_stream(o));
    rt_out_abort(o);
    CHECK(count_entries() == before, "abort left %d entries (had %d)", count_entries(), before);
    rt_out_abort(NULL);
    clean_dir();
}

/* A write failing after every small byte count: the target keeps its old
 * content and no temporary remains. */
static void test_outfile_faults(void)
{
    rt_err e = {0};
    clean_dir();
    check_write_file(check_path("keep.txt"), "old\n", 4);
    for (long long k = 0; k < 12; k++) {
        rt_out_fail_after = k;
        int rc = write_text(check_path("keep.txt"), "0123456789ab", &e);
        CHECK(rc < 0 && strstr(e.msg, "No space left"), "fail after %lld: rc %d '%s'", k, rc, e.msg);
        char *b = read_all(check_path("keep.txt"), NULL);
        CHECK(b && !strcmp(b, "old\n"), "after %lld: target changed to '%s'", k, b ? b : "(none)");
        free(b);
        CHECK(count_entries() == 1, "after %lld: %d entries", k, count_entries());
    }
    rt_out_fail_after = 12; /* exactly enough */
    CHECK(write_text(check_path("keep.txt"), "0123456789ab", &e) == 0, "12 bytes allowed: %s", e.msg);
    rt_out_fail_after = -1;
    clean_dir();
}

/* ---- the writers through the fault hook ------------------------------------ */

static void test_writers_faults(void)
{
    rt_err e = {0};
    clean_dir();
    rt_image *im = rt_image_new(8, 6, &e);
    CHECK(im != NULL, "image: %s", e.msg);
    if (!im) return;
    for (size_t i = 0; i < 3 * 48; i++) im->rgb[i] = (float)(i % 7) / 7.0f;
    rt_scene *s = rt_scene_builtin("cornell", "", &e);
    CHECK(s != NULL, "cornell: %s", e.msg);
    rt_tr_meta m;
    memset(&m, 0, sizeof m);
    snprintf(m.scene, sizeof m.scene, "synthetic");

    /* sizes of the complete outputs, then failures inside each */
    static const char *const names[] = {"o.png", "o.ppm", "o.exr", "o.obj", "o.rtt"};
    for (int w = 0; w < 5; w++) {
        for (int pass = 0; pass < 2; pass++) {
            size_t full = 0;
            if (pass == 1) {
                char *b = read_all(check_path(names[w]), &full);
                free(b);
                unlink(check_path(names[w]));
                rt_out_fail_after = (long long)(full / 2);
            }
            int rc;
            e.msg[0] = 0;
            if (w == 0) rc = rt_png_write(check_path(names[w]), im, &e);
            else if (w == 1) rc = rt_ppm_write(check_path(names[w]), im, &e);
            else if (w == 2) rc = rt_exr_write(check_path(names[w]), im, NULL, 0, &e);
            else if (w == 3) rc = s ? rt_scene_export_obj(s, check_path(names[w]), &e) : -1;
            else {
                rt_tr_writer *tw = rt_tr_create(check_path(names[w]), &m, &e);
                rc = tw ? 0 : -1;
                rt_access a[100];
                for (int i = 0; i < 100; i++) a[i] = (rt_access){(uint64_t)i * 4099u, 4, 0, 0, 0};
                if (tw && rt_tr_sink(tw)->put(rt_tr_sink(tw), a, 100) < 0) rc = -1;
                if (tw) rc = rt_tr_finish(tw, &e) < 0 ? -1 : rc;
            }
            rt_out_fail_after = -1;
            struct stat st;
            if (pass == 0) {
                CHECK(rc == 0 && stat(check_path(names[w]), &st) == 0 && st.st_size > 0, "%s: %s", names[w], e.msg);
            } else {
                CHECK(rc < 0, "%s: failed write reported as success", names[w]);
                CHECK(strstr(e.msg, "No space left") != NULL, "%s: message '%s'", names[w], e.msg);
                CHECK(stat(check_path(names[w]), &st) != 0, "%s: half-written file left", names[w]);
                CHECK(count_entries() == w, "%s: %d entries, temporary left?", names[w], count_entries());
            }
        }
        check_write_file(check_path(names[w]), "x", 1); /* keep the count of entries simple */
    }
    rt_scene_free(s);
    rt_image_free(im);
    clean_dir();
}

/* ---- PLY headers that lie ---------------------------------------------------- */

static void ply_refused(const char *name, const char *text, const char *needle)
{
    check_write_file(check_path(name), text, strlen(text));
    rt_err e = {0};
    double t0 = rt_now();
    rt_scene *s = rt_scene_load_ply(check_path(name), &e);
    double dt = rt_now() - t0;
    CHECK(s == NULL, "%s: accepted", name);
    CHECK(!needle || strstr(e.msg, needle), "%s: message '%s' lacks '%s'", name, e.msg, needle);
    CHECK(dt < 1.0, "%s: took %.2f s", name, dt);
    rt_scene_free(s);
}

#define TRI_DATA "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"

static void test_ply_counts(void)
{
    /* elements without properties: nothing bounds their count but refusal */
    ply_refused("noprop.ply",
                "ply\nformat ascii 1.0\nelement junk 4294967295\nelement vertex 3\nproperty float x\n"
                "property float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\n"
                "end_header\n" TRI_DATA,
                "noprop.ply:3: element 'junk' has 4294967295 instances but no properties");
    ply_refused("noprop_bin.ply",
                "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                "property float z\nelement face 1\nproperty list uchar int vertex_indices\nelement junk 4000000000\n"
                "end_header\n",
                "element 'junk' has 4000000000 instances but no properties");
    /* ascii: more values than the data can hold (vertex count near 2^32) */
    ply_refused("ascii_liar.ply",
                "ply\nformat ascii 1.0\nelement vertex 4294967295\nproperty float x\nproperty float y\n"
                "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n" TRI_DATA,
                "truncated vertex data");
    /* the sum over elements counts, not each element alone */
    ply_refused("ascii_sum.ply",
                "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
                "element face 1\nproperty list uchar int vertex_indices\nelement extra 7\nproperty uchar a\n"
                "end_header\n" TRI_DATA,
                "truncated extra data");
    /* ascii list longer than the bytes left */
    ply_refused("ascii_list.ply",
                "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
                "element face 1\nproperty list uint int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n"
                "4294967295 0 1 2\n",
                "list of 4294967295");
    /* binary: many properties times a huge count */
    ply_refused("bin_liar.ply",
                "ply\nformat binary_big_endian 1.0\nelement vertex 4294967295\nproperty double x\n"
                "property double y\nproperty double z\nelement face 4294967295\n"
                "property list uchar int vertex_indices\nend_header\n",
                "truncated vertex data");
    /* no format line: refused (it used to default to ascii) */
    ply_refused("noformat.ply",
                "ply\ncomment made by hand\nelement vertex 3\nproperty float x\nproperty float y\n"
                "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n" TRI_DATA,
                "noformat.ply:3: expected a format line");
    ply_refused("formatlate.ply",
                "ply\nelement vertex 3\nformat ascii 1.0\nproperty float x\nproperty float y\nproperty float z\n"
                "element face 1\nproperty list uchar int vertex_indices\nend_header\n" TRI_DATA,
                "expected a format line");
    /* control bytes in a quoted token are escaped */
    ply_refused("ctrl.ply", "ply\nformat ascii 1.0\n\x1b[2Jelement vertex 3\nend_header\n", "'\\x1b[2Jelement'");
    /* the well-formed file these were made from loads */
    const char *good = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                       "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n" TRI_DATA;
    check_write_file(check_path("good.ply"), good, strlen(good));
    rt_err e = {0};
    rt_scene *s = rt_scene_load_ply(check_path("good.ply"), &e);
    CHECK(s && s->ntri == 1, "good.ply: %s", e.msg);
    rt_scene_free(s);
}

/* ---- coordinate range ------------------------------------------------------- */

static const char *const cube_faces =
    "f 1 2 3 4\nf 5 8 7 6\nf 1 5 6 2\nf 2 6 7 3\nf 3 7 8 4\nf 5 1 4 8\n";

/* Writes a cube of edge `scale` at (off, off, off) and loads it. */
static rt_scene *load_cube(const char *name, double scale, double off, rt_err *e)
{
    char text[2048];
    int k = 0;
    for (int i = 0; i < 8; i++) {
        int x = (i == 1 || i == 2 || i == 5 || i == 6), y = (i == 2 || i == 3 || i == 6 || i == 7), z = i >= 4;
        k += snprintf(text + k, sizeof text - (size_t)k, "v %.9g %.9g %.9g\n", off + x * scale, off + y * scale,
                      off + z * scale);
    }
    snprintf(text + k, sizeof text - (size_t)k, "%s", cube_faces);
    check_write_file(check_path(name), text, strlen(text));
    return rt_scene_load_obj(check_path(name), e);
}

static void cube_refused(const char *name, double scale, double off, const char *needle)
{
    rt_err e = {0};
    rt_scene *s = load_cube(name, scale, off, &e);
    CHECK(s == NULL, "%s accepted", name);
    CHECK(strstr(e.msg, name) && strstr(e.msg, needle), "%s: message '%s' lacks '%s'", name, e.msg, needle);
    rt_scene_free(s);
}

static void test_coord_range(void)
{
    rt_err e = {0};
    /* the four probes: flat shading, background, camera at infinity, a point */
    cube_refused("scale1e10.obj", 1e10, 0, "scene extent 1.73205081e+10 above 1e+09");
    cube_refused("scale1e15.obj", 1e15, 0, ":2: coordinate 1e+15 out of range");
    cube_refused("scale3e38.obj", 3.4e38, 0, ":2: coordinate 3.4e+38 out of range");
    cube_refused("off1e20.obj", 1, 1e20, ":1: coordinate 1e+20 out of range");
    /* within 1e13 but too small for its offset */
    cube_refused("off1e8.obj", 1, 1e8, "below 1/8192 of its largest coordinate");
    /* NaN and Inf with file:line */
    check_write_file(check_path("nan.obj"), "v 0 0 0\nv 1 0 0\nv nan 1 0\nf 1 2 3\n", 33);
    rt_scene *s = rt_scene_load_obj(check_path("nan.obj"), &e);
    CHECK(!s && strstr(e.msg, "nan.obj:3: coordinate is not a finite number"), "nan: '%s'", e.msg);
    rt_scene_free(s);
    check_write_file(check_path("inf.obj"), "v 0 0 0\nv -inf 0 0\nv 0 1 0\nf 1 2 3\n", 33);
    s = rt_scene_load_obj(check_path("inf.obj"), &e);
    CHECK(!s && strstr(e.msg, "inf.obj:2: coordinate is not a finite number"), "inf: '%s'", e.msg);
    rt_scene_free(s);
    /* inside the range: accepted (largest extent, offset at the ratio) */
    s = load_cube("scale5e8.obj", 5e8, 0, &e);
    CHECK(s != NULL, "5e8 cube refused: %s", e.msg);
    rt_scene_free(s);
    s = load_cube("off1e3.obj", 1, 1e3, &e);
    CHECK(s != NULL, "unit cube at 1e3 refused: %s", e.msg);
    rt_scene_free(s);
    /* PLY gets the same checks */
    const char *ply = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                      "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
                      "0 0 0\n1e20 0 0\n0 1 0\n3 0 1 2\n";
    check_write_file(check_path("far.ply"), ply, strlen(ply));
    s = rt_scene_load_ply(check_path("far.ply"), &e);
    CHECK(!s && strstr(e.msg, "far.ply:11: vertex 1: coordinate 1e+20 out of range"), "far.ply: '%s'", e.msg);
    rt_scene_free(s);
    /* the built-in scenes are inside it */
    for (int i = 0; rt_scene_builtin_names[i]; i++) {
        if (!strcmp(rt_scene_builtin_names[i], "sphereflake") || !strcmp(rt_scene_builtin_names[i], "grove"))
            continue; /* large; same generators as the others */
        s = rt_scene_builtin(rt_scene_builtin_names[i], "", &e);
        CHECK(s && rt_scene_check_range(s, "builtin", &e) == 0, "%s: %s", rt_scene_builtin_names[i], e.msg);
        rt_scene_free(s);
    }
}

/* ---- framing for tall images ------------------------------------------------ */

static void test_fit_aspect(void)
{
    rt_err e = {0};
    rt_scene *s = load_cube("frame.obj", 2, -1, &e);
    CHECK(s != NULL, "cube: %s", e.msg);
    if (!s) return;
    rt_camera c0 = s->cam;
    rt_vec3 l0 = s->light[0];
    rt_scene_fit_aspect(s, 64, 64);
    CHECK(!memcmp(&c0, &s->cam, sizeof c0) && !memcmp(&l0, &s->light[0], sizeof l0), "square image moved the camera");
    rt_scene_fit_aspect(s, 256, 128);
    CHECK(!memcmp(&c0, &s->cam, sizeof c0), "wide image moved the camera");
    /* bounding sphere radius sqrt(3); tan(half-angle) = tan(22.5) W/H */
    static const int WH[][2] = {{128, 256}, {64, 256}, {100, 101}, {1, 512}};
    for (int k = 0; k < 4; k++) {
        rt_scene_fit_aspect(s, WH[k][0], WH[k][1]);
        double dx = (double)s->cam.eye.x - s->cam.at.x, dy = (double)s->cam.eye.y - s->cam.at.y,
               dz = (double)s->cam.eye.z - s->cam.at.z;
        double dist = sqrt(dx * dx + dy * dy + dz * dz);
        double t = 0.41421356237309503 * WH[k][0] / WH[k][1];
        double sin_h = t / sqrt(1 + t * t);
        CHECK(dist * sin_h >= sqrt(3.0) * 0.999999, "%dx%d: sphere of radius %.4f does not fit: dist %.4f sin %.4f",
              WH[k][0], WH[k][1], sqrt(3.0), dist, sin_h);
        CHECK(!memcmp(&s->light[0], &s->cam.eye, sizeof(rt_vec3)), "light 0 left behind");
    }
    rt_scene_free(s);
    /* built-in scenes have hand-set cameras: untouched */
    s = rt_scene_builtin("cornell", "", &e);
    if (s) {
        c0 = s->cam;
        rt_scene_fit_aspect(s, 128, 256);
        CHECK(!memcmp(&c0, &s->cam, sizeof c0), "built-in camera moved");
    }
    rt_scene_free(s);
}

/* ---- small parsers ---------------------------------------------------------- */

static void test_small(void)
{
    uint64_t v = 7;
    static const char *const bad[] = {" -64", "-64", "+64", " 64", "64 ", "\t64", "", "K", "0x40", "64KK", "-0"};
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++)
        CHECK(rt_parse_size(bad[i], &v) < 0, "'%s' accepted as %llu", bad[i], (unsigned long long)v);
    CHECK(rt_parse_size("64K", &v) == 0 && v == 65536, "64K -> %llu", (unsigned long long)v);
    CHECK(rt_parse_size("0", &v) == 0 && v == 0, "0 -> %llu", (unsigned long long)v);

    char q[32];
    CHECK(!strcmp(rt_esc(q, sizeof q, "a\x1b[2Jb\n\x7f\xc3", 100), "a\\x1b[2Jb\\x0a\\x7f\\xc3"), "esc '%s'", q);
    CHECK(!strcmp(rt_esc(q, sizeof q, "abcdef", 3), "abc"), "esc max '%s'", q);
    rt_esc(q, 12, "\x01\x02\x03\x04\x05", 100);
    CHECK(strlen(q) < 12 && strstr(q, "..."), "esc truncation '%s'", q);

    /* din: garbage after a NUL byte is refused with file:line */
    check_write_file(check_path("nul.din"), "0 1000\n1 2000\0garbage\n", 22);
    rt_err e = {0};
    rt_din *d = rt_din_open(check_path("nul.din"), 0, &e);
    CHECK(d != NULL, "din open: %s", e.msg);
    if (d) {
        rt_access a[8];
        long n = rt_din_read(d, a, 8, &e);
        CHECK(n < 0 && strstr(e.msg, "nul.din:2: NUL byte"), "din NUL: n %ld '%s'", n, e.msg);
        rt_din_close(d);
    }
}

/* ---- format version 3: the sample index ---------------------------------- */

#include "rt_math.h"
#include <zlib.h>

#define V3_N 327000u     /* records: four windows of the default sample index, and 344 records of a fifth */
#define V3_CHUNK 50000u  /* not the window period: windows straddle chunks */

/* A deterministic stream with runs, jumps, lines straddled, writes, every
 * class and generations 0..3. */
static rt_access *v3_stream(size_t n)
{
    rt_access *a = malloc(n * sizeof *a);
    if (!a) return NULL;
    rnd_seed(31);
    uint64_t addr = RT_MM_BASE;
    for (size_t i = 0; i < n; i++) {
        uint64_t r = rnd64();
        if (r % 7 == 0) addr = RT_MM_BASE + (rnd64() % 20000) * 8; /* a jump among ~2500 lines */
        else addr += (r >> 8) % 3 ? 8 : 40;
        a[i].addr = addr;
        a[i].size = (r >> 16) % 11 == 0 ? 100 : 8;
        a[i].write = (r >> 24) % 13 == 0;
        a[i].cls = (uint8_t)((r >> 32) % RT_NCLASS);
        a[i].gen = (uint8_t)((i / 777) % 4);
    }
    return a;
}

static int v3_write(const char *path, const rt_access *a, size_t n, int sample, rt_err *e)
{
    rt_tr_meta m;
    memset(&m, 0, sizeof m);
    snprintf(m.tracer, sizeof m.tracer, "test");
    rt_mm_init(&m.layout);
    m.generations = 3;
    rt_tr_wopts o;
    rt_si_wopts(&o);
    o.chunk_records = V3_CHUNK;
    if (!sample) o.payload = NULL;
    rt_tr_writer *w = rt_tr_create_opts(path, &m, &o, e);
    if (!w) return -1;
    rt_sink *s = rt_tr_sink(w);
    for (size_t i = 0; i < n; i += 4096) /* batches across chunk ends */
        if (s->put(s, a + i, n - i < 4096 ? n - i : 4096) < 0) {
            rt_errf(e, "%s", rt_tr_writer_error(w));
            rt_tr_abort(w);
            return -1;
        }
    return rt_tr_finish(w, e);
}

/* Reads every record (rt_tr_read); the count, or -1 with e. */
static int v3_side_check = 1; /* rt_tr_set_side_check for v3_read_all */

static long v3_read_all(const char *path, rt_access *out, size_t cap, rt_err *e)
{
    rt_tr_reader *r = rt_si_open(path, e);
    if (!r) return -1;
    rt_tr_set_side_check(r, v3_side_check);
    long n = 0, k;
    while ((k = rt_tr_read(r, out + n, cap - (size_t)n, e)) > 0) n += k;
    rt_tr_close(r);
    return k < 0 ? -1 : n;
}

/* Reads the whole sample index; 0 at the verified end, -1 with e. */
static int v3_read_side(const char *path, rt_err *e)
{
    rt_tr_reader *r = rt_tr_open(path, e);
    if (!r) return -1;
    rt_si_reader *d = rt_si_reader_new(r, e);
    rt_si_side sd;
    int k = -1;
    while (d && (k = rt_si_read(d, &sd, e)) > 0) {
    }
    rt_si_reader_free(d);
    rt_tr_close(r);
    return k;
}

static int acc_eq(const rt_access *x, const rt_access *y)
{
    return x->addr == y->addr && x->size == y->size && (x->write != 0) == (y->write != 0) && x->cls == y->cls &&
           x->gen == y->gen;
}

/* The reference sample: a line L is sampled iff L G + mix(seed ^ G) < 2^64 / 64
 * (mod 2^64), as in shards.c's golden filter. */
static int ref_sampled(const rt_access *r)
{
    const uint64_t G = 0x9e3779b97f4a7c15ULL, off = rt_mix64(RT_SI_SEED ^ G);
    for (uint64_t L = r->addr / RT_SI_LINE; L <= (r->addr + r->size - 1) / RT_SI_LINE; L++)
        if (L * G + off < (1ULL << (64 - RT_SI_SHIFT))) return 1;
    return 0;
}

/* The reference warm-up of the window starting at s: walk back from s - 1
 * over at most RT_SI_HIST records, listing distinct lines (linear
 * search) until RT_SI_CMAX; a line is written if a write to it is
 * met before the walk stops. warm[] least recent first. */
static uint32_t ref_warm(const rt_access *a, uint64_t s, rt_access *warm, uint64_t *scanned, int *shrt)
{
    static rt_access found[RT_SI_CMAX]; /* most recent first */
    uint32_t k = 0;
    uint64_t lo = s > RT_SI_HIST ? s - RT_SI_HIST : 0, i = s;
    while (i > lo && k < RT_SI_CMAX) {
        const rt_access *r = &a[--i];
        uint64_t f = r->addr / RT_SI_LINE, l = (r->addr + r->size - 1) / RT_SI_LINE;
        for (uint64_t L = l + 1; L-- > f && k < RT_SI_CMAX;) {
            uint32_t j = 0;
            while (j < k && found[j].addr != L * RT_SI_LINE) j++;
            if (j == k) found[k++] = (rt_access){L * RT_SI_LINE, 1, r->write != 0, r->cls, 0};
            else if (r->write && !found[j].write) {
                found[j].write = 1;
                found[j].cls = r->cls;
            }
        }
    }
    *scanned = s - i;
    *shrt = k < RT_SI_CMAX && lo > 0;
    for (uint32_t j = 0; j < k; j++) warm[j] = found[k - 1 - j];
    return k;
}

/* Version 3 round trip: the records read back are those written, exactly
 * as from the version-2 file of the same stream; the sample index equals
 * the reference filter of the records, chunk by chunk. */
static void test_v3_roundtrip(void)
{
    rt_err e = {0};
    rt_access *a = v3_stream(V3_N), *b = malloc((V3_N + 1) * sizeof *b);
    CHECK(a && b, "out of memory");
    if (!a || !b) return;
    const char *p3 = check_path("v3.rtt"), *p2 = check_path("v2.rtt");
    CHECK(v3_write(p3, a, V3_N, 1, &e) == 0 && v3_write(p2, a, V3_N, 0, &e) == 0, "write: %s", e.msg);
    const char *paths[2] = {p3, p2};
    for (int v = 0; v < 2; v++) {
        long n = v3_read_all(paths[v], b, V3_N + 1, &e);
        long bad = 0;
        for (long i = 0; i < n && i < (long)V3_N; i++) bad += !acc_eq(&a[i], &b[i]);
        CHECK(n == (long)V3_N && bad == 0, "%s: %ld records read back, %ld differ (%s)", paths[v], n, bad, e.msg);
    }
    rt_tr_reader *r = rt_tr_open(p3, &e), *r2 = rt_tr_open(p2, &e);
    rt_tr_sample_params sp;
    CHECK(r && r2 && rt_tr_get_version(r) == 3 && rt_tr_get_version(r2) == 2 && rt_tr_get_sample_params(r, &sp) &&
              !rt_tr_get_sample_params(r2, &sp),
          "versions: %s", e.msg);
    CHECK(sp.line == RT_SI_LINE && sp.shift == RT_SI_SHIFT && sp.period == RT_SI_PERIOD &&
              sp.window == RT_SI_WINDOW && sp.cmax == RT_SI_CMAX && sp.hist == RT_SI_HIST,
          "sample parameters");
    rt_si_side sd;
    rt_si_reader *d2 = r2 ? rt_si_reader_new(r2, &e) : NULL, *d = r ? rt_si_reader_new(r, &e) : NULL;
    CHECK(d2 && rt_si_read(d2, &sd, &e) < 0 && strstr(e.msg, "no side payloads"), "v2 side read: %s", e.msg);
    rt_si_reader_free(d2);
    rt_tr_close(r2);
    /* chunk by chunk against the reference */
    static rt_access warm[RT_SI_CMAX];
    uint64_t start = 0, nextwin = RT_SI_PERIOD - RT_SI_WINDOW, nwin = 0, badc = 0, chunks = 0;
    int k = -1;
    while (d && (k = rt_si_read(d, &sd, &e)) > 0) {
        uint64_t end = start + sd.nrefs, touch[RT_NCLASS][2] = {{0}}, ns = 0, sbad = 0;
        for (uint64_t i = start; i < end; i++) {
            const rt_access *x = &a[i];
            touch[x->cls][x->write != 0] += (x->addr + x->size - 1) / 64 - x->addr / 64 + 1;
            if (ref_sampled(x)) sbad += ns >= sd.nsampled || !acc_eq(x, &sd.sampled[ns++]);
        }
        badc += sd.nrefs != (end > V3_N ? 0 : (V3_N - start < V3_CHUNK ? V3_N - start : V3_CHUNK));
        badc += memcmp(touch, sd.touches, sizeof touch) != 0;
        CHECK(ns == sd.nsampled && sbad == 0, "chunk %llu: %llu sampled records, reference %llu, %llu differ",
              (unsigned long long)chunks, (unsigned long long)sd.nsampled, (unsigned long long)ns,
              (unsigned long long)sbad);
        /* windows whose last record is in this chunk */
        uint32_t w = 0;
        for (; nextwin + RT_SI_WINDOW <= end; nextwin += RT_SI_PERIOD, w++, nwin++) {
            uint64_t scanned;
            int shrt;
            uint32_t nw = ref_warm(a, nextwin, warm, &scanned, &shrt);
            if (w >= sd.nwin) break;
            const rt_si_window *x = &sd.win[w];
            int ok = x->nwarm == nw && x->scanned == scanned && x->short_warmup == shrt &&
                     x->nrecs == RT_SI_WINDOW;
            for (uint32_t j = 0; ok && j < nw; j++) ok = acc_eq(&x->warm[j], &warm[j]);
            for (uint32_t j = 0; ok && j < x->nrecs; j++) ok = acc_eq(&x->recs[j], &a[nextwin + j]);
            CHECK(ok, "window at %llu: %u warm lines (reference %u), %llu scanned (%llu)",
                  (unsigned long long)nextwin, x->nwarm, nw, (unsigned long long)x->scanned,
                  (unsigned long long)scanned);
        }
        /* the last chunk also holds the window the trace ends in */
        uint32_t partial = end == V3_N && nextwin < V3_N;
        CHECK(sd.nwin == w + partial, "chunk %llu: %u windows, reference %u", (unsigned long long)chunks, sd.nwin,
              w + partial);
        if (partial && sd.nwin == w + 1)
            CHECK(sd.win[w].nrecs == V3_N - nextwin, "partial window: %u records", sd.win[w].nrecs);
        start = end;
        chunks++;
    }
    CHECK(r && k == 0 && start == V3_N && badc == 0 && nwin == 4 && chunks == (V3_N + V3_CHUNK - 1) / V3_CHUNK,
          "side read: %d, %llu records, %llu windows, %llu bad chunk totals: %s", k, (unsigned long long)start,
          (unsigned long long)nwin, (unsigned long long)badc, e.msg);
    /* the same provenance hash either way */
    uint64_t h_side = r ? rt_tr_file_hash(r) : 0;
    rt_si_reader_free(d);
    rt_tr_close(r);
    r = rt_si_open(p3, &e);
    while (r && rt_tr_read(r, b, V3_N + 1, &e) > 0) {
    }
    CHECK(r && rt_tr_file_hash(r) == h_side && h_side != 0, "file hash differs between the readers");
    d = r ? rt_si_reader_new(r, &e) : NULL;
    CHECK(d && rt_si_read(d, &sd, &e) < 0, "side read after record read accepted");
    rt_si_reader_free(d);
    rt_tr_close(r);
    free(a);
    free(b);
}

/* File offsets of the chunks of a trace (magic positions), from its bytes. */
static size_t v3_chunks(const unsigned char *b, size_t len, size_t *off, int *side, size_t max)
{
    size_t at = 16 + (size_t)(b[12] | b[13] << 8 | b[14] << 16 | (size_t)b[15] << 24) + 4, k = 0;
    while (at + 24 <= len && k < max && (!memcmp(b + at, "RTCK", 4) || !memcmp(b + at, "RTSM", 4))) {
        off[k] = at;
        side[k] = b[at + 2] == 'S';
        size_t C = b[at + 16] | b[at + 17] << 8 | b[at + 18] << 16 | (size_t)b[at + 19] << 24;
        at += 24 + C;
        k++;
    }
    return k;
}

/* Both readers on a damaged file: -1, with the file and a byte offset in
 * the message. */
static void v3_both_fail(const char *path, const char *what, size_t where, const char *needle)
{
    static rt_access buf[V3_N + 1];
    rt_err e1 = {0}, e2 = {0};
    long n = v3_read_all(path, buf, V3_N + 1, &e1);
    int k = v3_read_side(path, &e2);
    CHECK(n < 0 && strstr(e1.msg, path) && strstr(e1.msg, "byte ") && (!needle || strstr(e1.msg, needle)),
          "records reader, %s at %zu: %ld, %s", what, where, n, e1.msg);
    CHECK(k < 0 && strstr(e2.msg, path) && strstr(e2.msg, "byte ") && (!needle || strstr(e2.msg, needle)),
          "side reader, %s at %zu: %d, %s", what, where, k, e2.msg);
    /* the records reader that only CRC-checks the side chunks (exact replays) */
    v3_side_check = 0;
    n = v3_read_all(path, buf, V3_N + 1, &e1);
    v3_side_check = 1;
    CHECK(n < 0 && strstr(e1.msg, path) && strstr(e1.msg, "byte ") && (!needle || strstr(e1.msg, needle)),
          "records reader without the side rebuild, %s at %zu: %ld, %s", what, where, n, e1.msg);
}

/* Bit flips and cuts in the side chunks (and in the data chunks, which the
 * side reader CRC-checks without inflating) fail both readers; a side
 * chunk rewritten with a valid CRC but content the records do not make
 * fails the records reader. */
static void test_v3_corrupt(void)
{
    rt_err e = {0};
    rt_access *a = v3_stream(V3_N);
    const char *p3 = check_path("v3c.rtt"), *bad = check_path("v3bad.rtt");
    CHECK(a && v3_write(p3, a, V3_N, 1, &e) == 0, "write: %s", e.msg);
    free(a);
    size_t len = 0;
    unsigned char *b = (unsigned char *)read_all(p3, &len);
    if (!b) return;
    size_t off[64];
    int side[64];
    size_t nc = v3_chunks(b, len, off, side, 64);
    CHECK(nc == 2 * ((V3_N + V3_CHUNK - 1) / V3_CHUNK), "%zu chunks found", nc);
    for (size_t c = 0; c < nc; c++) {
        if (c >= 2 && c + 2 < nc) continue; /* the first and the last pair: early and late failures */
        size_t C = b[off[c] + 16] | b[off[c] + 17] << 8 | b[off[c] + 18] << 16 | (size_t)b[off[c] + 19] << 24;
        /* every byte of the chunk header, and a stride of the payload */
        for (size_t i = 0; i < 24 + C; i += i < 24 ? 1 : (side[c] ? 293 : 4999)) {
            b[off[c] + i] ^= (unsigned char)(1u << (i % 8));
            check_write_file(bad, b, len);
            b[off[c] + i] ^= (unsigned char)(1u << (i % 8));
            v3_both_fail(bad, side[c] ? "bit flip in a side chunk" : "bit flip in a chunk", off[c] + i, NULL);
        }
        if (!side[c]) continue;
        /* cuts inside the side chunk */
        for (size_t i = 0; i < 24 + C; i += i < 24 ? 3 : 1009) {
            check_write_file(bad, b, off[c] + i);
            v3_both_fail(bad, "cut in a side chunk", off[c] + i, NULL);
        }
    }
    /* impossible sample-index parameters in a header with a valid CRC:
     * the line size (first field after generations) not a power of two */
    {
        size_t P = b[12] | b[13] << 8 | b[14] << 16 | (size_t)b[15] << 24, at = 16 + P - (4 + 1 + 5 * 8);
        unsigned char *x = malloc(len);
        memcpy(x, b, len);
        CHECK(x[at] == RT_SI_LINE && x[at + 1] == 0, "sample line field not where expected");
        x[at] = 48;
        uint32_t c = (uint32_t)crc32(0, x, (uInt)(16 + P));
        for (int i = 0; i < 4; i++) x[16 + P + i] = (unsigned char)(c >> (8 * i));
        check_write_file(bad, x, len);
        free(x);
        rt_tr_reader *r = rt_tr_open(bad, &e);
        CHECK(!r && strstr(e.msg, "impossible sample index (line 48") && strstr(e.msg, "byte "),
              "bad sample line accepted: %s", e.msg);
        rt_tr_close(r);
    }
    /* a side chunk dropped: the next data chunk comes where it should be */
    if (nc >= 4) {
        size_t cut = off[1], next = off[2];
        unsigned char *x = malloc(len);
        memcpy(x, b, cut);
        memcpy(x + cut, b + next, len - next);
        check_write_file(bad, x, len - (next - cut));
        free(x);
        v3_both_fail(bad, "side chunk dropped", cut, "side chunk");
    }
    /* side chunk 0 re-made with one sampled record changed and a valid CRC */
    if (nc >= 2) {
        size_t at = off[1];
        uint32_t U = b[at + 12] | b[at + 13] << 8 | b[at + 14] << 16 | (uint32_t)b[at + 15] << 24;
        uint32_t C = b[at + 16] | b[at + 17] << 8 | b[at + 18] << 16 | (uint32_t)b[at + 19] << 24;
        unsigned char *raw = malloc(U), *x = malloc(len + 4096);
        uLongf ul = U;
        CHECK(uncompress(raw, &ul, b + at + 24, C) == Z_OK && ul == U, "side chunk 0 inflates");
        size_t q = 1; /* past the flags, 50 class totals and the sampled count: the first sampled record's tag */
        for (int v = 0; v < 51; v++) {
            while (raw[q] & 0x80) q++;
            q++;
        }
        raw[q] ^= 0x10; /* its write bit */
        uLongf cl = compressBound(U);
        unsigned char *z = malloc(cl);
        compress2(z, &cl, raw, U, 6);
        memcpy(x, b, at + 16);
        for (int i = 0; i < 4; i++) x[at + 16 + i] = (unsigned char)(cl >> (8 * i));
        memcpy(x + at + 24, z, cl);
        uint32_t crcv = (uint32_t)crc32(crc32(0, x + at, 20), z, (uInt)cl);
        for (int i = 0; i < 4; i++) x[at + 20 + i] = (unsigned char)(crcv >> (8 * i));
        memcpy(x + at + 24 + cl, b + at + 24 + C, len - (at + 24 + C));
        size_t xl = len - C + cl;
        check_write_file(bad, x, xl);
        static rt_access buf[V3_N + 1];
        long n = v3_read_all(bad, buf, V3_N + 1, &e);
        CHECK(n < 0 && strstr(e.msg, "does not match the records") && strstr(e.msg, bad),
              "re-made side chunk under the records reader: %s", e.msg);
        /* the side reader cannot know; what it checks still holds */
        CHECK(v3_read_side(bad, &e) == 0, "re-made side chunk under the side reader: %s", e.msg);
        /* nor can the records reader told not to rebuild them, whose records are all there */
        static rt_access good[V3_N + 1];
        v3_side_check = 0;
        n = v3_read_all(bad, buf, V3_N + 1, &e);
        v3_side_check = 1;
        CHECK(n == V3_N && v3_read_all(p3, good, V3_N + 1, &e) == V3_N && !memcmp(buf, good, sizeof *buf * V3_N),
              "re-made side chunk, records without the side rebuild: %ld, %s", n, e.msg);
        free(raw);
        free(x);
        free(z);
    }
    free(b);
}

/* The sample index's maker: its invariants (rt_si_check) hold after every
 * batch and every chunk end of a stream fed in uneven batches, and each
 * corrupted copy of its state fails the invariant it breaks. */
static void test_si_check(void)
{
    rt_err e = {0};
    rt_access *a = v3_stream(V3_N);
    rt_si_maker *m = a ? rt_si_payload.open(&rt_si_payload.params, 3, &e) : NULL;
    CHECK(m, "maker: %s", e.msg);
    if (!m) {
        free(a);
        return;
    }
    rt_tr_sample_params bp = rt_si_payload.params;
    bp.line = 48;
    CHECK(!rt_si_payload.open(&bp, 3, &e) && strstr(e.msg, "impossible parameters (line 48"),
          "maker with line 48: %s", e.msg);
    size_t i = 0, chunk_end = V3_CHUNK, bad = 0, checks = 0;
    uint64_t seed = 7;
    while (i < V3_N) {
        seed = seed * 6364136223846793005ULL + 1442695040888963407ULL;
        size_t k = 1 + (size_t)(seed >> 33) % 9000;
        if (k > V3_N - i) k = V3_N - i;
        if (k > chunk_end - i) k = chunk_end - i;
        CHECK(rt_si_payload.put(m, a + i, k) == 0, "put: out of memory");
        i += k;
        bad += rt_si_check(m, &e) < 0;
        checks++;
        if (i == chunk_end || i == V3_N) {
            const unsigned char *pb;
            size_t pn;
            /* bit 0: last; bits 1-2: classes stored beyond 10 (the stream has all 13) */
            CHECK(rt_si_payload.chunk(m, i == V3_N, &pb, &pn) == 0 && pn > 0 &&
                      pb[0] == ((i == V3_N) | (RT_NCLASS - RT_NCLASS_V1) << 1),
                  "chunk at %zu: flags %#x", i, pn ? pb[0] : 0u);
            bad += rt_si_check(m, &e) < 0;
            checks++;
            chunk_end += V3_CHUNK;
        }
        if (bad) break;
    }
    CHECK(bad == 0 && checks > 60, "maker invariants after %zu records (%zu checks): %s", i, checks, e.msg);
    /* mid-window: a state where a window runs and history is kept */
    rt_si_payload.close(m);
    m = rt_si_payload.open(&rt_si_payload.params, 3, &e);
    if (!m) {
        free(a);
        return;
    }
    size_t mid = RT_SI_PERIOD - RT_SI_WINDOW + 100;
    CHECK(rt_si_payload.put(m, a, mid) == 0 && rt_si_check(m, &e) == 0 && m->wn == 100 &&
              m->hn == RT_SI_HIST, "mid-window state: wn %llu hn %llu: %s", (unsigned long long)m->wn,
          (unsigned long long)m->hn, e.msg);
    struct {
        const char *inv;
        int what;
    } cases[] = {{"I1", 0}, {"I2", 1}, {"I3", 2}, {"I4", 3}, {"I5", 4}, {"I5", 5}, {"I6", 6}, {"I6", 7}, {"I7", 8}, {"I7", 9}};
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        rt_si_maker x = *m; /* shares m's buffers; rt_si_check only reads them */
        switch (cases[c].what) {
        case 0: x.shift++; break;                    /* shift is not log2(line) */
        case 1: x.wn = x.p.window; break;            /* a full window left open */
        case 2: x.next += 1; break;                  /* off the window grid */
        case 3: x.wn = 0; break;                     /* records past next, no window */
        case 4: x.hn -= 1; break;                    /* the ring lost a record */
        case 5: x.hhead = x.p.hist; break;           /* head outside the ring */
        case 6: x.refs[RT_CLS_NODE]++; break;        /* tallies above the chunk's records */
        case 7: x.writes[RT_CLS_TRI] = x.refs[RT_CLS_TRI] + 1; break; /* more writes than refs */
        case 8: x.setmask = 2 * x.setmask + 1; break; /* set size not as allocated */
        case 9: x.samp.n = x.samp.cap + 1; break;    /* encoded bytes past the buffer */
        }
        int rc = rt_si_check(&x, &e);
        CHECK(rc < 0 && strstr(e.msg, cases[c].inv), "corruption %d: %s expected, got %d: %s", cases[c].what,
              cases[c].inv, rc, e.msg);
    }
    CHECK(rt_si_check(m, &e) == 0, "the original still checks: %s", e.msg);
    rt_si_payload.close(m);
    free(a);
}

/* ---- rt_open_target and stale temporaries --------------------------------- */

static int match_all(const char *name)
{
    return strncmp(name, "job", 3) == 0;
}

static void test_open_target(void)
{
    rt_err e = {0};
    clean_dir();
    /* names SQLite stores nowhere: usage errors for databases only */
    static const char *const mem[] = {":memory:", ":x", ":", ""};
    for (int i = 0; i < 4; i++) {
        e.usage = 0;
        CHECK(rt_open_target(mem[i], RT_TARGET_DB, &e) < 0 && e.usage == 1, "db '%s' accepted (usage %d)", mem[i],
              e.usage);
        e.usage = 0;
        CHECK(rt_open_target(mem[i], RT_TARGET_DB_READ, &e) < 0 && e.usage == 1, "db read '%s' accepted", mem[i]);
    }
    CHECK(count_entries() == 0, "a refused name created a file");
    /* absent, regular, folder, FIFO, device */
    const char *a = check_path("a.db");
    CHECK(rt_open_target(a, RT_TARGET_DB, &e) == RT_TARGET_ABSENT, "absent db: %s", e.msg);
    CHECK(rt_open_target(a, RT_TARGET_DB_READ, &e) < 0 && strstr(e.msg, "No such file"), "absent read: %s", e.msg);
    CHECK(rt_open_target(a, RT_TARGET_OUTPUT, &e) == RT_TARGET_ABSENT, "absent output: %s", e.msg);
    CHECK(write_text(a, "x", &e) == 0, "write: %s", e.msg);
    for (int k = 0; k < 3; k++) CHECK(rt_open_target(a, k, &e) == RT_TARGET_REGULAR, "regular, kind %d: %s", k, e.msg);
    CHECK(rt_open_target(check_path("no/such.db"), RT_TARGET_DB, &e) < 0 && strstr(e.msg, "No such file"),
          "db in a missing folder: %s", e.msg);
    CHECK(mkdir(check_path("d"), 0777) == 0, "mkdir");
    for (int k = 0; k < 3; k++)
        CHECK(rt_open_target(check_path("d"), k, &e) < 0 && strstr(e.msg, "is a directory"), "folder, kind %d: %s", k,
              e.msg);
    CHECK(mkfifo(check_path("f"), 0666) == 0, "mkfifo");
    CHECK(symlink("f", check_path("lf")) == 0, "symlink");
    CHECK(rt_open_target(check_path("f"), RT_TARGET_OUTPUT, &e) == RT_TARGET_STREAM, "FIFO output: %s", e.msg);
    CHECK(rt_open_target(check_path("lf"), RT_TARGET_DB, &e) < 0 && strstr(e.msg, "is a FIFO"), "link to FIFO: %s",
          e.msg);
    CHECK(rt_open_target("/dev/null", RT_TARGET_OUTPUT, &e) == RT_TARGET_STREAM, "/dev/null output: %s", e.msg);
    CHECK(rt_open_target("/dev/null", RT_TARGET_DB, &e) < 0 && strstr(e.msg, "character device"), "/dev/null db: %s",
          e.msg);
    CHECK(rt_open_target("/dev/null", RT_TARGET_DB_READ, &e) < 0 && strstr(e.msg, "character device"),
          "/dev/null db read: %s", e.msg);

    /* stale temporaries: only unlocked regular files of the pattern go */
    clean_dir();
    static const char *const gone[] = {".job1.rtt.AbC123", ".jobx.Zz9999"};
    static const char *const kept[] = {".job2.rtt.AbC12", ".other.AbC123", "job3.rtt.AbC123", ".job4.rtt.AbC12!",
                                       ".job5.rtt.Hld123"};
    for (int i = 0; i < 2; i++) CHECK(write_text(check_path(gone[i]), "x", &e) == 0, "write: %s", e.msg);
    for (int i = 0; i < 5; i++) CHECK(write_text(check_path(kept[i]), "x", &e) == 0, "write: %s", e.msg);
    CHECK(mkfifo(check_path(".job6.rtt.Fifo12"), 0666) == 0, "mkfifo");
    /* a live writer's temporary: rt_out_open holds its lock */
    rt_out *live = rt_out_open(check_path("job7.rtt"), &e);
    CHECK(live != NULL, "open: %s", e.msg);
    int held = open(check_path(kept[4]), O_RDONLY); /* another process's lock would do the same */
    CHECK(held >= 0 && flock(held, LOCK_EX) == 0, "flock: %s", strerror(errno));
    int n0 = count_entries();
    long nr = rt_out_remove_stale(check_dir, match_all, &e);
    CHECK(nr == 2, "removed %ld (%d entries fewer), want 2: %s", nr, n0 - count_entries(), e.msg);
    struct stat st;
    for (int i = 0; i < 2; i++) CHECK(lstat(check_path(gone[i]), &st) != 0, "%s not removed", gone[i]);
    for (int i = 0; i < 5; i++) CHECK(lstat(check_path(kept[i]), &st) == 0, "%s removed", kept[i]);
    CHECK(lstat(check_path(".job6.rtt.Fifo12"), &st) == 0, "a FIFO was removed");
    close(held);
    fputs("live", rt_out_stream(live));
    CHECK(rt_out_commit(live, &e) == 0, "the live writer's commit failed: %s", e.msg);
    char *b = read_all(check_path("job7.rtt"), NULL);
    CHECK(b && !strcmp(b, "live"), "live writer's file '%s'", b ? b : "(none)");
    free(b);
    CHECK(rt_out_remove_stale(check_path("nope"), match_all, &e) < 0, "a missing folder was read");
    clean_dir();
}

/* A chunk of base classes keeps the ten-class payload (flags bits 1-2 zero);
 * only a chunk with a later class lists up to it (here 12: the bits say 3), and both read back
 * through the checked reader and the sampled reader. */
static void test_v3_later_classes(void)
{
    rt_err e = {0};
    rt_access *a = v3_stream(V3_N), *b = malloc((V3_N + 1) * sizeof *b);
    CHECK(a && b, "out of memory");
    if (!a || !b) return;
    for (size_t i = 0; i < V3_N; i++) a[i].cls %= RT_NCLASS_V1;
    a[2 * V3_CHUNK + 7].cls = RT_CLS_ALPHA;
    const char *p = check_path("v3cls.rtt");
    CHECK(v3_write(p, a, V3_N, 1, &e) == 0, "write: %s", e.msg);
    CHECK(v3_read_all(p, b, V3_N + 1, &e) == (long)V3_N, "checked read: %s", e.msg);
    CHECK(v3_read_side(p, &e) == 0, "side read: %s", e.msg);
    rt_tr_reader *r = rt_tr_open(p, &e);
    rt_tr_payload pl;
    int k, bad = 0, nch = 0;
    while (r && (k = rt_tr_read_payload(r, &pl, &e)) > 0) {
        bad += (pl.bytes[0] >> 1) != (pl.index == 2 ? 3 : 0);
        nch++;
    }
    CHECK(nch == (int)((V3_N + V3_CHUNK - 1) / V3_CHUNK) && bad == 0, "%d chunks, %d with the wrong class flag: %s",
          nch, bad, e.msg);
    rt_tr_close(r);
    free(a);
    free(b);
}

int main(void)
{
    alarm(120); /* a spinning loader ends the test instead of hanging it (generous: the
                 * test takes 3 s of CPU, several times that under ASan on a loaded machine) */
    if (!check_tmpdir("test_io")) {
        perror("mkdtemp");
        return 1;
    }
    test_outfile_rules();
    test_open_target();
    test_outfile_faults();
    test_writers_faults();
    clean_dir();
    test_ply_counts();
    test_coord_range();
    test_fit_aspect();
    test_small();
    clean_dir();
    test_v3_roundtrip();
    test_v3_corrupt();
    test_v3_later_classes();
    test_si_check();
    clean_dir();
    rmdir(check_dir);
    if (failures) fprintf(stderr, "%d failure(s)\n", failures);
    return failures ? 1 : 0;
}
