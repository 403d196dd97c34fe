/*
 * test_io.c -- reliability of inputs and outputs (docs/reliability.md).
 *
 * Outputs: the rules of outfile.c checked on the file system (missing,
 * regular, symlinked, dangling, directory and device targets), a failing
 * write at every small offset through the fault hook leaving the target
 * untouched and no temporary behind, and the same for the trace, PNG, PPM,
 * EXR and OBJ writers. Inputs: PLY headers that lie about their counts
 * (each must be refused well within a second; alarm(10) ends a spin), the
 * coordinate range, din files with NUL bytes, escaping of control bytes,
 * the size parser, and auto-framing for tall images. Exit 0 = all passed.
 */
#include "config.h"
#include "din.h"
#include "image.h"
#include "outfile.h"
#include "scene.h"
#include "trace.h"
#include "check.h"

#include <dirent.h>
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
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
    rt_err e = {""};
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
    rt_err e = {""};
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
    rt_err e = {""};
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
    rt_err e = {""};
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
    rt_err e = {""};
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
    rt_err e = {""};
    rt_scene *s = load_cube(name, scale, off, &e);
    CHECK(s == NULL, "%s accepted", name);
    CHECK(strstr(e.msg, name) && strstr(e.msg, needle), "%s: message '%s' lacks '%s'", name, e.msg, needle);
    rt_scene_free(s);
}

static void test_coord_range(void)
{
    rt_err e = {""};
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
    rt_err e = {""};
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
    rt_err e = {""};
    rt_din *d = rt_din_open(check_path("nul.din"), 0, &e);
    CHECK(d != NULL, "din open: %s", e.msg);
    if (d) {
        rt_access a[8];
        long n = rt_din_read(d, a, 8, &e);
        CHECK(n < 0 && strstr(e.msg, "nul.din:2: NUL byte"), "din NUL: n %ld '%s'", n, e.msg);
        rt_din_close(d);
    }
}

int main(void)
{
    alarm(10); /* a spinning loader ends the test instead of hanging it */
    if (!check_tmpdir("test_io")) {
        perror("mkdtemp");
        return 1;
    }
    test_outfile_rules();
    test_outfile_faults();
    test_writers_faults();
    clean_dir();
    test_ply_counts();
    test_coord_range();
    test_fit_aspect();
    test_small();
    clean_dir();
    rmdir(check_dir);
    if (failures) fprintf(stderr, "%d failure(s)\n", failures);
    return failures ? 1 : 0;
}
