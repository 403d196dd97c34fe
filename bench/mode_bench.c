/*
 * mode_bench.c -- the render modes measured: path tracing's error against
 * its time, every tracer's throughput per mode, and the three tracers'
 * images compared bit for bit (rt_mode_bench_*, see bench.h).
 *
 * Each scene is loaded and its k-d tree built once; every run borrows them
 * (rt_job_setup_borrowed), so the figures hold the tracers' run() alone.
 * The machine these run on is shared and noisy, so every time is printed
 * beside a ratio to a reference taken in the same invocation: spp = 1 for
 * the path error, the untraced run and the recursive tracer for the
 * throughput. The lights are all three in every mode that uses them.
 *
 * Rays are counted as traced: primary + secondary (the extra statistic
 * rays_secondary of the whitted and path modes) + shadow rays, so rays/s
 * compares modes whose rays per pixel differ by an order of magnitude.
 *
 * Path error: RMSE over every pixel and the three linear RGB channels of
 * an spp-sample render against one of ref_spp samples. Sample s of a pixel
 * draws the same random numbers in both (counter-based, docs/tracers.md),
 * so the low-spp image's samples are the reference's first ones; the
 * expected error is then sigma sqrt(1/spp - 1/ref_spp), a few per cent
 * below sigma / sqrt(spp) at spp = 64 against 1024.
 */
#include "scene_load.h"
#include "analysis.h"
#include "bench.h"
#include "image.h"
#include "outfile.h"
#include "run.h"

#include <errno.h>
#include <inttypes.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

/* A scene and its tree, shared by every run on it. */
typedef struct loaded {
    rt_scene *sc;
    rt_kdtree *kd;
} loaded;

static int load(loaded *L, const char *spec, rt_err *e)
{
    L->kd = NULL;
    if (!(L->sc = rt_scene_load(spec, e))) return -1;
    rt_kd_params kp;
    rt_kd_default_params(&kp);
    if (!(L->kd = rt_kd_build(L->sc, &kp, e))) {
        rt_scene_free(L->sc);
        L->sc = NULL;
        return -1;
    }
    return 0;
}

static void unload(loaded *L)
{
    rt_kd_free(L->kd);
    rt_scene_free(L->sc);
}

static int count_put(rt_sink *s, const rt_access *a, size_t n)
{
    (void)a;
    *(uint64_t *)s->ctx += n;
    return 0;
}

/* Rays a run traced: primary, secondary and shadow. */
static uint64_t rays_traced(const rt_run_stats *st)
{
    uint64_t n = st->rays_primary + st->rays_shadow;
    const char *p = strstr(st->extra, "rays_secondary=");
    if (p) n += strtoull(p + strlen("rays_secondary="), NULL, 10);
    return n;
}

/* One run of tracer on L with options o into img (sink NULL: untraced). */
static int run_one(const loaded *L, const char *tracer, const rt_render_opts *o, rt_sink *sink, rt_image *img,
                   rt_run_stats *st, rt_err *e)
{
    rt_job j;
    if (rt_job_setup_borrowed(&j, L->sc, L->kd, tracer, o, e) < 0) return -1;
    int rc = rt_job_run(&j, sink, img, st, e);
    rt_job_free(&j);
    return rc;
}

static int write_failed(FILE *out, rt_err *e)
{
    if (fflush(out) == 0 && !ferror(out)) return 0;
    return rt_errf(e, "writing the table: %s", strerror(errno));
}

/* ---- path tracing: error against time ------------------------------------------- */

static double rmse(const rt_image *a, const rt_image *ref)
{
    size_t n = (size_t)a->W * (size_t)a->H * 3;
    double s = 0;
    for (size_t i = 0; i < n; i++) {
        double d = (double)a->rgb[i] - (double)ref->rgb[i];
        s += d * d;
    }
    return sqrt(s / (double)n);
}

/* DIR/path-error-SCENE.{dat,gp} and, with gnuplot, .png: RMSE against
 * seconds on log axes, with the 1/sqrt(time) line through spp = 1. */
static int plot_path_error(const rt_plot_opts *p, const char *scene, const int *spp, const double *sec,
                           const double *err, int n, rt_err *e)
{
    if (mkdir(p->dir, 0777) < 0 && errno != EEXIST) return rt_errf(e, "%s: %s", p->dir, strerror(errno));
    char base[4096], dat[4200], gp[4200], png[4200];
    int k = snprintf(base, sizeof base, "%s/path-error-", p->dir);
    for (const char *c = scene; *c && k + 1 < (int)sizeof base; c++) base[k++] = *c == '/' ? '_' : *c;
    base[k] = 0;
    snprintf(dat, sizeof dat, "%s.dat", base);
    snprintf(gp, sizeof gp, "%s.gp", base);
    snprintf(png, sizeof png, "%s.png", base);
    rt_out *o = rt_out_open(dat, e); /* src/outfile.c: unique temporary, renamed when complete */
    if (!o) return -1;
    FILE *f = rt_out_stream(o);
    fprintf(f, "# spp seconds rmse\n");
    for (int i = 0; i < n; i++) fprintf(f, "%d %.6g %.6g\n", spp[i], sec[i], err[i]);
    if (rt_out_commit(o, e) < 0) return -1;
    if (!(o = rt_out_open(gp, e))) return -1;
    f = rt_out_stream(o);
    fprintf(f, "set terminal pngcairo size 800,600 enhanced\nset output ");
    rt_plot_quote_path(f, png);
    fprintf(f, "\nset logscale xy\nset format x \"10^{%%L}\"\nset format y \"10^{%%L}\"\nset xtics 10\nset ytics 10\n"
               "set grid\nset xlabel \"seconds\"\nset ylabel \"RMSE (linear RGB)\"\nset key top right\n"
               "set title ");
    char title[300];
    snprintf(title, sizeof title, "path tracing on %s: error against time", scene);
    rt_plot_quote(f, title);
    /* the Monte Carlo rate: error ~ time^-1/2 from the spp = 1 point */
    fprintf(f, " noenhanced\nplot ");
    rt_plot_quote_path(f, dat);
    fprintf(f, " u 2:3 w lp pt 7 ps 1.2 lc rgb \"#0072b2\" t \"measured (spp 1, 4, 16, 64)\", \\\n  ");
    rt_plot_quote_path(f, dat);
    fprintf(f, " u 2:(%.9g*sqrt(%.9g/$2)) w l dt 2 lc rgb \"#d55e00\" t \"RMSE ~ time^{-1/2}\"\n", err[0], sec[0]);
    if (rt_out_commit(o, e) < 0) return -1;
    if (!p->gnuplot) {
        if (p->log) fprintf(p->log, "wrote %s and %s (no gnuplot: no picture)\n", dat, gp);
        return 0;
    }
    if (rt_plot_run(p->gnuplot, gp, e) < 0) return -1;
    if (p->log) fprintf(p->log, "wrote %s\n", png);
    return 0;
}

int rt_mode_bench_path_error(FILE *out, const rt_mode_bench *b, const rt_plot_opts *plot, rt_err *e)
{
    static const int spps[] = {1, 4, 16, 64};
    enum { NSPP = (int)(sizeof spps / sizeof spps[0]) };
    char *list = strdup(b->scenes), *save = NULL;
    if (!list) return rt_errf(e, "out of memory");
    int rc = 0;
    for (char *s = strtok_r(list, ",", &save); s && rc == 0; s = strtok_r(NULL, ",", &save)) {
        loaded L;
        if (load(&L, s, e) < 0) {
            rc = -1;
            break;
        }
        rt_render_opts o = b->base;
        o.W = b->W;
        o.H = b->H;
        o.lights = 7;
        o.mode = RT_MODE_PATH;
        o.spp = b->ref_spp;
        rt_image *ref = rt_image_new(o.W, o.H, e), *img = rt_image_new(o.W, o.H, e);
        rt_run_stats st;
        double sec[NSPP], err[NSPP];
        rc = ref && img ? run_one(&L, "recursive", &o, NULL, ref, &st, e) : -1;
        if (rc == 0) {
            fprintf(out, "Path tracing on %s, %dx%d, lights all, bounces %d, recursive tracer; reference %d spp "
                         "rendered in %.2f s.\n\n",
                    s, o.W, o.H, o.bounces, o.spp, st.seconds);
            fprintf(out, "| spp | seconds | RMSE | seconds vs spp=1 | RMSE vs spp=1 | 1/sqrt(spp) |\n"
                         "|---:|---:|---:|---:|---:|---:|\n");
        }
        for (int i = 0; i < NSPP && rc == 0; i++) {
            o.spp = spps[i];
            if ((rc = run_one(&L, "recursive", &o, NULL, img, &st, e)) < 0) break;
            sec[i] = st.seconds;
            err[i] = rmse(img, ref);
            fprintf(out, "| %d | %.3f | %.5f | %.2f | %.3f | %.3f |\n", spps[i], sec[i], err[i],
                    sec[0] > 0 ? sec[i] / sec[0] : 0.0, err[0] > 0 ? err[i] / err[0] : 0.0, 1 / sqrt(spps[i]));
            rc = write_failed(out, e);
        }
        if (rc == 0 && plot) rc = plot_path_error(plot, s, spps, sec, err, NSPP, e);
        if (rc == 0) fprintf(out, "\n");
        rt_image_free(ref);
        rt_image_free(img);
        unload(&L);
    }
    free(list);
    return rc < 0 ? -1 : write_failed(out, e);
}

/* ---- rays/s per tracer and mode ------------------------------------------------- */

/* The modes of the throughput table, as the brief of docs/bench.md asks. */
typedef struct mode_case {
    const char *label; /* column text */
    int mode, depth, spp, bounces;
} mode_case;

static const mode_case throughput_modes[] = {
    {"shadow", RT_MODE_SHADOW, 5, 1, 4},
    {"whitted depth 5", RT_MODE_WHITTED, 5, 1, 4},
    {"path spp 4 bounces 4", RT_MODE_PATH, 5, 4, 4},
};

int rt_mode_bench_modes(FILE *out, const rt_mode_bench *b, rt_err *e)
{
    enum { NMODE = (int)(sizeof throughput_modes / sizeof throughput_modes[0]) };
    char *list = strdup(b->scenes), *save = NULL;
    if (!list) return rt_errf(e, "out of memory");
    fprintf(out, "Rays/s per tracer and mode, %dx%d, lights all; rays = primary + secondary + shadow; "
                 "traced = recording into a counting sink.\n\n",
            b->W, b->H);
    fprintf(out, "| scene | mode | tracer | rays | untraced s | Mrays/s | vs recursive | traced s | Mrays/s | refs/ray "
                 "| traced vs untraced |\n|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|\n");
    int rc = 0;
    /* per scene, the recursive tracer's Mrays/s in shadow and whitted mode
     * (untraced, traced) for the ratio below the table */
    int nsc = 0;
    char names[16][128];
    double rec[16][NMODE][2];
    memset(rec, 0, sizeof rec);
    for (char *s = strtok_r(list, ",", &save); s && rc == 0; s = strtok_r(NULL, ",", &save)) {
        loaded L;
        if (load(&L, s, e) < 0) {
            rc = -1;
            break;
        }
        rt_image *img = rt_image_new(b->W, b->H, e);
        rc = img ? 0 : -1;
        int si = nsc < 16 ? nsc++ : -1;
        if (si >= 0) snprintf(names[si], sizeof names[si], "%s", s);
        for (int m = 0; m < NMODE && rc == 0; m++) {
            rt_render_opts o = b->base;
            o.W = b->W;
            o.H = b->H;
            o.lights = 7;
            o.mode = throughput_modes[m].mode;
            o.depth = throughput_modes[m].depth;
            o.spp = throughput_modes[m].spp;
            o.bounces = throughput_modes[m].bounces;
            double rec_rate = 0;
            char *tl = strdup(b->tracers), *ts = NULL;
            if (!tl) {
                rc = rt_errf(e, "out of memory");
                break;
            }
            for (char *t = strtok_r(tl, ",", &ts); t && rc == 0; t = strtok_r(NULL, ",", &ts)) {
                rt_run_stats su, sr;
                if ((rc = run_one(&L, t, &o, NULL, img, &su, e)) < 0) break;
                uint64_t cnt = 0;
                rt_sink sink = {count_put, &cnt};
                if ((rc = run_one(&L, t, &o, &sink, img, &sr, e)) < 0) break;
                uint64_t rays = rays_traced(&su);
                double ru = su.seconds > 0 ? (double)rays / su.seconds * 1e-6 : 0;
                double rt = sr.seconds > 0 ? (double)rays / sr.seconds * 1e-6 : 0;
                if (rt_tracer_is(rt_tracer_find(t), RT_TR_REFERENCE)) {
                    rec_rate = ru;
                    if (si >= 0) {
                        rec[si][m][0] = ru;
                        rec[si][m][1] = rt;
                    }
                }
                char vs[32] = "";
                if (rec_rate > 0) snprintf(vs, sizeof vs, "%.2f", ru / rec_rate);
                fprintf(out, "| %s | %s | %s | %" PRIu64 " | %.2f | %.3f | %s | %.2f | %.3f | %.1f | %.2f |\n", s,
                        throughput_modes[m].label, t, rays, su.seconds, ru, vs, sr.seconds, rt,
                        rays ? (double)cnt / (double)rays : 0.0, su.seconds > 0 ? sr.seconds / su.seconds : 0.0);
                rc = write_failed(out, e);
            }
            free(tl);
        }
        rt_image_free(img);
        unload(&L);
    }
    free(list);
    if (rc < 0) return -1;
    /* the recursive tracer's cost per ray in whitted against shadow mode */
    fprintf(out, "\nRecursive tracer, whitted (depth 5) Mrays/s / shadow Mrays/s, per ray traced "
                 "(target: within 1.5x, i.e. 0.67..1.5):\n\n");
    for (int i = 0; i < nsc; i++) {
        if (rec[i][0][0] <= 0 || rec[i][1][0] <= 0) continue; /* recursive not in --tracers */
        double r[2];
        for (int k = 0; k < 2; k++) r[k] = rec[i][1][k] / rec[i][0][k];
        int met = r[0] >= 1 / 1.5 && r[0] <= 1.5 && r[1] >= 1 / 1.5 && r[1] <= 1.5;
        fprintf(out, "whitted/shadow %s: untraced %.3f / %.3f = %.2f, traced %.3f / %.3f = %.2f (%s)\n", names[i],
                rec[i][1][0], rec[i][0][0], r[0], rec[i][1][1], rec[i][0][1], r[1], met ? "within 1.5x" : "outside 1.5x");
    }
    return write_failed(out, e);
}

/* ---- the three tracers' images, bit for bit --------------------------------------- */

static const mode_case identical_modes[] = {
    {"raycast", RT_MODE_RAYCAST, 5, 1, 4},
    {"shadow", RT_MODE_SHADOW, 5, 1, 4},
    {"whitted", RT_MODE_WHITTED, 5, 1, 4},
    {"path", RT_MODE_PATH, 5, 1, 4},
};

int rt_mode_bench_identical(FILE *out, const rt_mode_bench *b, rt_err *e)
{
    enum { NMODE = (int)(sizeof identical_modes / sizeof identical_modes[0]) };
    char *list = strdup(b->scenes), *save = NULL;
    if (!list) return rt_errf(e, "out of memory");
    fprintf(out, "RGB bit for bit against the recursive tracer, %dx%d; raycast without lights, the other modes "
                 "with all three; whitted depth 5, path spp 1 bounces 4.\n\n",
            b->W, b->H);
    fprintf(out, "| scene | mode | tracer | result | seconds | seconds vs recursive |\n|---|---|---|---|---:|---:|\n");
    int rc = 0, ndiff = 0;
    double t0 = rt_now();
    for (char *s = strtok_r(list, ",", &save); s && rc == 0; s = strtok_r(NULL, ",", &save)) {
        loaded L;
        if (load(&L, s, e) < 0) {
            rc = -1;
            break;
        }
        rt_image *ref = rt_image_new(b->W, b->H, e), *img = rt_image_new(b->W, b->H, e);
        rc = ref && img ? 0 : -1;
        for (int m = 0; m < NMODE && rc == 0; m++) {
            rt_render_opts o = b->base;
            o.W = b->W;
            o.H = b->H;
            o.lights = identical_modes[m].mode == RT_MODE_RAYCAST ? 0 : 7;
            o.mode = identical_modes[m].mode;
            o.depth = identical_modes[m].depth;
            o.spp = identical_modes[m].spp;
            o.bounces = identical_modes[m].bounces;
            rt_run_stats st;
            if ((rc = run_one(&L, "recursive", &o, NULL, ref, &st, e)) < 0) break;
            double base = st.seconds;
            fprintf(out, "| %s | %s | recursive | reference | %.2f | 1.00 |\n", s, identical_modes[m].label, base);
            char *tl = strdup(b->tracers), *ts = NULL;
            if (!tl) {
                rc = rt_errf(e, "out of memory");
                break;
            }
            for (char *t = strtok_r(tl, ",", &ts); t && rc == 0; t = strtok_r(NULL, ",", &ts)) {
                if (rt_tracer_is(rt_tracer_find(t), RT_TR_REFERENCE)) continue;
                /* poisoned (NaN bytes): a pixel the tracer never writes is a DIFF */
                memset(img->rgb, 0xff, sizeof(float) * 3 * (size_t)b->W * (size_t)b->H);
                if ((rc = run_one(&L, t, &o, NULL, img, &st, e)) < 0) break;
                int same = rt_image_rgb_equal(img, ref);
                ndiff += !same;
                fprintf(out, "| %s | %s | %s | %s | %.2f | %.2f |\n", s, identical_modes[m].label, t,
                        same ? "OK" : "DIFF", st.seconds, base > 0 ? st.seconds / base : 0.0);
                rc = write_failed(out, e);
            }
            free(tl);
        }
        rt_image_free(ref);
        rt_image_free(img);
        unload(&L);
    }
    free(list);
    if (rc < 0) return -1;
    fprintf(out, "\n%d case%s differ%s; %.1f s in all (scene loading and tree building included).\n", ndiff,
            ndiff == 1 ? "" : "s", ndiff == 1 ? "s" : "", rt_now() - t0);
    return write_failed(out, e) < 0 ? -1 : ndiff;
}
