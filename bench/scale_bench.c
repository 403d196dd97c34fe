/*
 * scale_bench.c -- scenes at scale (`raytraffic bench --what scale`,
 * `make bench-scale`; docs/performance.md "Scale").
 *
 * Two scenes are written into a fresh folder under --tmpdir, each then
 * rendered by a child `raytraffic render` (execv of this very binary, no
 * shell) whose peak resident set and wall time wait4 reports:
 *
 *   mesh    one closed bumpy torus as a binary PLY, rows x cols quads (two
 *           triangles each; the full size 1330 x 1331 = 3,540,460
 *           triangles, the crown's count), rendered 256 x 256 with the
 *           default structure (bvh8): the bytes per flattened triangle;
 *   forest  a .pbrt file over `variants` tree objects (each a PLY: a
 *           bumpy crown and a trunk), grid x grid ObjectInstances of them
 *           (jittered, rotated, scaled), on a ground quad; the full size
 *           8 trees of 130,048 triangles and 96 x 96 = 9,216 instances,
 *           1.2 G instanced triangles from 1.04 M unique, rendered
 *           512 x 512 with `--instances bvh` (instances kept, not
 *           flattened; scene_pbrt.c).
 *
 * The generators use no libm (angles through rt_dsincos_deg, positions in
 * double with + - * /; a fixed linear congruential sequence for the
 * jitter), so the files are the same bytes on every machine.
 */
#include "config.h"

#include "bench.h"

#include <errno.h>
#include <inttypes.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/time.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

static void put_f32(unsigned char *b, float f)
{
    uint32_t u;
    memcpy(&u, &f, 4);
    for (int i = 0; i < 4; i++) b[i] = (unsigned char)(u >> (8 * i));
}
static void put_u32(unsigned char *b, uint32_t u)
{
    for (int i = 0; i < 4; i++) b[i] = (unsigned char)(u >> (8 * i));
}

/* A PLY writer over a grid surface: pos(ctx, i, j, xyz) for i < rows,
 * j < cols (rows wrap when wrap_r, else rows - 1 bands). */
typedef void (*grid_fn)(const void *ctx, int i, int j, double p[3]);

typedef struct grid {
    grid_fn pos;
    const void *ctx;
    int rows, cols; /* vertices */
    int wrap_r;     /* rows wrap around (a closed torus) */
} grid;

static uint64_t grid_faces(const grid *g) { return 2ull * (uint64_t)(g->wrap_r ? g->rows : g->rows - 1) * g->cols; }

static int write_ply(const char *path, const grid *gs, int ng, rt_err *e)
{
    char tmp[4096];
    if (snprintf(tmp, sizeof tmp, "%s.tmp", path) >= (int)sizeof tmp) return rt_errf(e, "%s: path too long", path);
    FILE *f = fopen(tmp, "wb");
    if (!f) return rt_errf(e, "%s: %s", tmp, strerror(errno));
    uint64_t nv = 0, nf = 0;
    for (int k = 0; k < ng; k++) nv += (uint64_t)gs[k].rows * gs[k].cols, nf += grid_faces(&gs[k]);
    fprintf(f, "ply\nformat binary_little_endian 1.0\nelement vertex %" PRIu64 "\nproperty float x\nproperty float y\n"
               "property float z\nelement face %" PRIu64 "\nproperty list uchar int vertex_indices\nend_header\n",
            nv, nf);
    unsigned char b[16];
    for (int k = 0; k < ng; k++)
        for (int i = 0; i < gs[k].rows; i++)
            for (int j = 0; j < gs[k].cols; j++) {
                double p[3];
                gs[k].pos(gs[k].ctx, i, j, p);
                for (int a = 0; a < 3; a++) put_f32(b + 4 * a, (float)p[a]);
                fwrite(b, 1, 12, f);
            }
    uint32_t base = 0;
    for (int k = 0; k < ng; k++) {
        const grid *g = &gs[k];
        int bands = g->wrap_r ? g->rows : g->rows - 1;
        for (int i = 0; i < bands; i++)
            for (int j = 0; j < g->cols; j++) {
                uint32_t i1 = (uint32_t)((i + 1) % g->rows), j1 = (uint32_t)((j + 1) % g->cols);
                uint32_t a = base + (uint32_t)i * g->cols + (uint32_t)j, bb = base + (uint32_t)i * g->cols + j1,
                         c = base + i1 * g->cols + j1, d = base + i1 * g->cols + (uint32_t)j;
                uint32_t t[2][3] = {{a, bb, c}, {a, c, d}};
                for (int q = 0; q < 2; q++) {
                    b[0] = 3;
                    for (int v = 0; v < 3; v++) put_u32(b + 1 + 4 * v, t[q][v]);
                    fwrite(b, 1, 13, f);
                }
            }
        base += (uint32_t)(g->rows * g->cols);
    }
    if (ferror(f) | fclose(f)) {
        remove(tmp);
        return rt_errf(e, "%s: write error", tmp);
    }
    if (rename(tmp, path) < 0) {
        remove(tmp);
        return rt_errf(e, "%s: %s", path, strerror(errno));
    }
    return 0;
}

/* ---- the torus ------------------------------------------------------------- */

typedef struct torus {
    int rows, cols;
} torus;

static void torus_pos(const void *ctx, int i, int j, double p[3])
{
    const torus *t = ctx;
    double su, cu, sv, cv, s1, c1, s2, c2;
    double u = 360.0 * i / t->rows, v = 360.0 * j / t->cols;
    rt_dsincos_deg(u, &su, &cu);
    rt_dsincos_deg(v, &sv, &cv);
    rt_dsincos_deg(7 * u, &s1, &c1);
    rt_dsincos_deg(11 * v, &s2, &c2);
    double r = 0.3 + 0.03 * s1 * c2;
    p[0] = (1 + r * cv) * cu;
    p[1] = r * sv;
    p[2] = (1 + r * cv) * su;
}

int rt_scale_write_mesh(const char *path, int rows, int cols, rt_err *e)
{
    torus t = {rows, cols};
    grid g = {torus_pos, &t, rows, cols, 1};
    return write_ply(path, &g, 1, e);
}

/* ---- the trees ---------------------------------------------------------------- */

typedef struct tree {
    int rows, cols; /* crown: latitude bands + 1, longitudes */
    int variant;
} tree;

static void crown_pos(const void *ctx, int i, int j, double p[3])
{
    const tree *t = ctx;
    double st, ct, sp, cp, s1, c1, s2, c2;
    double th = 5.0 + 170.0 * i / (t->rows - 1), ph = 360.0 * j / t->cols; /* open at the poles */
    rt_dsincos_deg(th, &st, &ct);
    rt_dsincos_deg(ph, &sp, &cp);
    rt_dsincos_deg((5 + t->variant) * th, &s1, &c1);
    rt_dsincos_deg((7 + 2 * t->variant) * ph, &s2, &c2);
    double r = (0.9 + 0.05 * t->variant) * (1 + 0.08 * s1 * c2);
    p[0] = r * st * cp;
    p[1] = 2.2 + 1.3 * r * ct;
    p[2] = r * st * sp;
}

static void trunk_pos(const void *ctx, int i, int j, double p[3])
{
    (void)ctx;
    double s, c;
    rt_dsincos_deg(360.0 * j / 64, &s, &c);
    p[0] = 0.15 * c;
    p[1] = 1.4 * i / 15;
    p[2] = 0.15 * s;
}

/* Triangles of one tree of crown rows x cols. */
static uint64_t tree_tris(int rows, int cols) { return 2ull * (rows - 1) * cols + 2ull * 15 * 64; }

static uint32_t lcg(uint64_t *s)
{
    *s = *s * 6364136223846793005ull + 1442695040888963407ull;
    return (uint32_t)(*s >> 33);
}

int rt_scale_write_forest(const char *dir, int variants, int rows, int cols, int gridn, uint64_t *unique,
                          uint64_t *instanced, rt_err *e)
{
    char path[4096], tmp[4200];
    *unique = *instanced = 0;
    for (int k = 0; k < variants; k++) {
        tree t = {rows, cols, k};
        grid g[2] = {{crown_pos, &t, rows, cols, 0}, {trunk_pos, NULL, 16, 64, 0}};
        if (snprintf(path, sizeof path, "%s/tree%d.ply", dir, k) >= (int)sizeof path)
            return rt_errf(e, "%s: path too long", dir);
        if (write_ply(path, g, 2, e) < 0) return -1;
        *unique += tree_tris(rows, cols);
    }
    snprintf(path, sizeof path, "%s/forest.pbrt", dir);
    snprintf(tmp, sizeof tmp, "%s.tmp", path);
    FILE *f = fopen(tmp, "w");
    if (!f) return rt_errf(e, "%s: %s", tmp, strerror(errno));
    double half = 1.5 * gridn;
    fprintf(f, "# %d trees of %" PRIu64 " triangles, %d x %d instances (raytraffic bench --what scale)\n", variants,
            tree_tris(rows, cols), gridn, gridn);
    fprintf(f, "LookAt %g %g %g  0 0 %g  0 1 0\nCamera \"perspective\" \"float fov\" 50\n", -0.2 * half, 0.35 * half + 4,
            -1.1 * half, 0.2 * half);
    fprintf(f, "Film \"rgb\" \"integer xresolution\" 512 \"integer yresolution\" 512\nWorldBegin\n");
    fprintf(f, "LightSource \"point\" \"point3 from\" [%g %g %g] \"rgb I\" [50 50 50]\n", 0.3 * half, 2 * half, -half);
    fprintf(f, "AttributeBegin\nMaterial \"diffuse\" \"rgb reflectance\" [0.4 0.3 0.2]\n"
               "Shape \"trianglemesh\" \"point3 P\" [%g 0 %g  %g 0 %g  %g 0 %g  %g 0 %g] \"integer indices\" [0 1 2 0 2 3]\n"
               "AttributeEnd\n",
            -half - 2, -half - 2, half + 2, -half - 2, half + 2, half + 2, -half - 2, half + 2);
    for (int k = 0; k < variants; k++)
        fprintf(f, "ObjectBegin \"tree%d\"\nMaterial \"diffuse\" \"rgb reflectance\" [0.%02d 0.%02d 0.1]\n"
                   "Shape \"plymesh\" \"string filename\" \"tree%d.ply\"\nObjectEnd\n",
                k, 5 + 3 * (k % 8), 30 + 4 * (k % 8), k);
    uint64_t s = 12345;
    for (int i = 0; i < gridn; i++)
        for (int j = 0; j < gridn; j++) {
            double x = -half + 3.0 * i + 1.5 + ((int)(lcg(&s) % 1001) - 500) * 0.002;
            double z = -half + 3.0 * j + 1.5 + ((int)(lcg(&s) % 1001) - 500) * 0.002;
            int rot = (int)(lcg(&s) % 360), k = (int)(lcg(&s) % (uint32_t)variants);
            double sc = 0.7 + 0.001 * (lcg(&s) % 601);
            fprintf(f, "AttributeBegin Translate %.3f 0 %.3f Rotate %d 0 1 0 Scale %.3f %.3f %.3f ObjectInstance \"tree%d\" "
                       "AttributeEnd\n",
                    x, z, rot, sc, sc, sc, k);
            *instanced += tree_tris(rows, cols);
        }
    if (ferror(f) | fclose(f)) {
        remove(tmp);
        return rt_errf(e, "%s: write error", tmp);
    }
    if (rename(tmp, path) < 0) {
        remove(tmp);
        return rt_errf(e, "%s: %s", path, strerror(errno));
    }
    return 0;
}

/* ---- the bench ------------------------------------------------------------------ */

/* Runs this binary with argv (execv, no shell), output to logpath; peak
 * resident kilobytes and wall seconds. Exit status or -1. */
static int run_child(char *const argv[], const char *logpath, long *maxrss_kb, double *wall)
{
    struct timespec t0, t1;
    clock_gettime(CLOCK_MONOTONIC, &t0);
    fflush(stdout);
    pid_t pid = fork();
    if (pid < 0) return -1;
    if (pid == 0) {
        FILE *lf = freopen(logpath, "w", stdout);
        if (!lf || dup2(fileno(stdout), 2) < 0) _exit(127);
        execv("/proc/self/exe", argv);
        _exit(127);
    }
    int st;
    struct rusage ru;
    if (wait4(pid, &st, 0, &ru) < 0) return -1;
    clock_gettime(CLOCK_MONOTONIC, &t1);
    *maxrss_kb = ru.ru_maxrss;
    *wall = (double)(t1.tv_sec - t0.tv_sec) + 1e-9 * (double)(t1.tv_nsec - t0.tv_nsec);
    return WIFEXITED(st) ? WEXITSTATUS(st) : -1;
}

static void show_log(FILE *out, const char *logpath)
{
    FILE *f = fopen(logpath, "r");
    char line[512];
    if (!f) return;
    while (fgets(line, sizeof line, f)) fprintf(out, "    %s", line);
    fclose(f);
}

int rt_scale_bench(FILE *out, const char *tmpdir, int quick, rt_err *e)
{
    char dir[4096], mesh[4200], forest[4200], img[4200], logp[4200];
    if (snprintf(dir, sizeof dir, "%s/rt-scale-XXXXXX", tmpdir) >= (int)sizeof dir)
        return rt_errf(e, "--tmpdir: path too long");
    if (!mkdtemp(dir)) return rt_errf(e, "%s: %s", dir, strerror(errno));
    snprintf(mesh, sizeof mesh, "%s/torus.ply", dir);
    snprintf(forest, sizeof forest, "%s/forest.pbrt", dir);
    snprintf(img, sizeof img, "%s/out.exr", dir);
    snprintf(logp, sizeof logp, "%s/log", dir);
    const int rows = quick ? 60 : 1330, cols = quick ? 61 : 1331;
    const int variants = quick ? 2 : 8, crow = quick ? 9 : 251, ccol = quick ? 16 : 256, gridn = quick ? 6 : 96;
    const char *mw = quick ? "64" : "256", *fw = quick ? "64" : "512";
    int rc = -1;
    uint64_t unique, instanced;
    char row[2][512];
    long kb;
    double wall;
    fprintf(out, "scale: files in %s\n", dir);
    if (rt_scale_write_mesh(mesh, rows, cols, e) < 0) goto done;
    uint64_t ntri = 2ull * rows * cols;
    {
        char *av[] = {"raytraffic", "render", mesh, "--accel", "bvh8", "-W", (char *)mw, "-H", (char *)mw, "-o", img, NULL};
        int st = run_child(av, logp, &kb, &wall);
        if (st != 0) {
            show_log(out, logp);
            rt_errf(e, "render %s: exit status %d", mesh, st);
            goto done;
        }
        show_log(out, logp);
        snprintf(row[0], sizeof row[0], "| torus mesh (bvh8) | %" PRIu64 " | %sx%s | %.3f GB | %.1f | %.1f |\n", ntri,
                 mw, mw, kb * 1024.0 / 1e9, kb * 1024.0 / (double)ntri, wall);
    }
    if (rt_scale_write_forest(dir, variants, crow, ccol, gridn, &unique, &instanced, e) < 0) goto done;
    {
        char *av[] = {"raytraffic", "render", forest, "--instances", "bvh", "--lights", "all", "-W", (char *)fw,
                      "-H", (char *)fw, "-o", img, NULL};
        int st = run_child(av, logp, &kb, &wall);
        if (st != 0) {
            show_log(out, logp);
            rt_errf(e, "render %s --instances bvh: exit status %d", forest, st);
            goto done;
        }
        show_log(out, logp);
        snprintf(row[1], sizeof row[1],
                 "| forest, %d instances of %d trees (--instances bvh --lights all) | %" PRIu64 " instanced, %" PRIu64
                 " unique | %sx%s | %.3f GB | %.1f per unique | %.1f |\n",
                 gridn * gridn, variants, instanced, unique, fw, fw, kb * 1024.0 / 1e9, kb * 1024.0 / (double)unique,
                 wall);
    }
    fprintf(out, "\n| scene | triangles | image | peak RSS | bytes per triangle | wall s |\n|---|---|---|---|---|---|\n%s%s",
            row[0], row[1]);
    rc = 0;
done:
    /* the files go; the folder too when empty */
    remove(mesh), remove(forest), remove(img), remove(logp);
    for (int k = 0; k < variants; k++) {
        char p[4300];
        snprintf(p, sizeof p, "%s/tree%d.ply", dir, k);
        remove(p);
    }
    rmdir(dir);
    return rc;
}
