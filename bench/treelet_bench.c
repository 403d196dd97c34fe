/*
 * treelet_bench.c -- the treelet row of `raytraffic bench` (rt_treelet_bench,
 * see bench.h): the treelet tracer against the recursive tracer on the same
 * BVH, traced and untraced, in one process.
 *
 * Both tracers shoot the same primary rays (the options' image size, no
 * lights unless given) through the same structure (each job builds its own
 * copy with the default parameters; the builds are not timed). Per
 * repetition, for each way of running -- untraced, recording into a null
 * sink, writing a trace file as `trace` does (version 3, sample index,
 * through rt_tr_finish) -- the recursive run and then the treelet run are
 * timed back to back, so a change in the machine's load hits both; the row
 * gives both times and the ratio treelet over recursive, on wall time and on
 * the thread's CPU time (which other processes on a loaded machine do not
 * stretch). A last row per structure and way gives the medians of the
 * repetitions' times and of their ratios. The jobs run with ctx->check off,
 * as every run outside the tests does.
 */
#include "bench.h"
#include "run.h"
#include "trace.h"

#include <inttypes.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

enum { WAY_UNTRACED, WAY_NULL, WAY_FILE, NWAY };
static const char *const way_name[NWAY] = {"untraced", "null sink", "trace file"};

typedef struct tb_time {
    double sec, cpu; /* wall and thread CPU seconds */
    uint64_t refs;   /* references recorded (0 untraced) */
    uint64_t rays;   /* primary + shadow rays */
} tb_time;

static int null_put(rt_sink *s, const rt_access *a, size_t n)
{
    (void)a;
    *(uint64_t *)s->ctx += n;
    return 0;
}

/* One run of job j the way given; the trace file (WAY_FILE) is path,
 * removed afterwards. 0 or -1. */
static int timed_run(rt_job *j, int way, const char *path, const char *command, rt_image *img, tb_time *t,
                     rt_err *e)
{
    rt_run_stats st;
    uint64_t cnt = 0;
    rt_sink ns = {null_put, &cnt};
    rt_tr_writer *w = NULL;
    if (way == WAY_FILE) {
        rt_tr_meta m;
        rt_job_meta(j, command, &m);
        rt_tr_wopts wo;
        rt_tr_default_wopts(&wo);
        if (!(w = rt_tr_create_opts(path, &m, &wo, e))) return -1;
    }
    const double t0 = rt_now(), c0 = rt_bench_thread_cpu();
    int rc = rt_job_run(j, way == WAY_UNTRACED ? NULL : way == WAY_NULL ? &ns : rt_tr_sink(w), img, &st, e);
    if (w) {
        if (rc < 0) rt_tr_abort(w);
        else rc = rt_tr_finish(w, e);
    }
    t->sec = rt_now() - t0;
    t->cpu = rt_bench_thread_cpu() - c0;
    t->refs = st.accesses;
    t->rays = st.rays_primary + st.rays_shadow;
    if (way == WAY_FILE) unlink(path);
    return rc;
}

static int cmp_double(const void *a, const void *b)
{
    const double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

static double median(double *v, int n)
{
    qsort(v, (size_t)n, sizeof *v, cmp_double);
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

/* The rows of one structure. */
static int bench_accel(FILE *out, rt_scene *sc, const rt_render_opts *base, int kind, int reps, const char *tmpdir,
                       const char *command, rt_err *e)
{
    rt_render_opts o = *base;
    o.accel = kind;
    rt_job jr, jt;
    int have_r = 0, have_t = 0, rc = -1;
    rt_image *img = rt_image_new(o.W, o.H, e);
    tb_time *tm = rt_calloc((size_t)reps * NWAY * 2, sizeof *tm, e);
    double *col = rt_calloc((size_t)reps, sizeof *col, e);
    char path[4096];
    snprintf(path, sizeof path, "%s/rt-bench-treelet-%ld.rtt", tmpdir, (long)getpid());
    if (!img || !tm || !col) goto out;
    if (rt_job_setup_borrowed(&jr, sc, NULL, "recursive", &o, e) < 0) goto out;
    have_r = 1;
    if (rt_job_setup_borrowed(&jt, sc, NULL, "treelet", &o, e) < 0) goto out;
    have_t = 1;
#define TM(rep, way, tr) tm[((size_t)(rep) * NWAY + (way)) * 2 + (tr)]
    for (int rep = 0; rep < reps; rep++)
        for (int way = 0; way < NWAY; way++) {
            if (timed_run(&jr, way, path, command, img, &TM(rep, way, 0), e) < 0) goto out;
            if (timed_run(&jt, way, path, command, img, &TM(rep, way, 1), e) < 0) goto out;
            const tb_time *r = &TM(rep, way, 0), *t = &TM(rep, way, 1);
            char rpr[48] = " |";
            if (way != WAY_UNTRACED)
                snprintf(rpr, sizeof rpr, " %.1f | %.1f", r->rays ? (double)r->refs / (double)r->rays : 0.0,
                         t->rays ? (double)t->refs / (double)t->rays : 0.0);
            fprintf(out, "| %s | %s | %d | %.3f | %.3f | %.2f | %.3f | %.3f | %.2f |%s |\n", rt_accel_name(kind),
                    way_name[way], rep + 1, r->sec, t->sec, t->sec / r->sec, r->cpu, t->cpu, t->cpu / r->cpu, rpr);
            fflush(out);
        }
    for (int way = 0; way < NWAY; way++) {
        double m[6];
        for (int k = 0; k < 6; k++) {
            for (int rep = 0; rep < reps; rep++) {
                const tb_time *r = &TM(rep, way, 0), *t = &TM(rep, way, 1);
                const double v[6] = {r->sec, t->sec, t->sec / r->sec, r->cpu, t->cpu, t->cpu / r->cpu};
                col[rep] = v[k];
            }
            m[k] = median(col, reps);
        }
        fprintf(out, "| %s | %s | median | %.3f | %.3f | **%.2f** | %.3f | %.3f | **%.2f** | | |\n", rt_accel_name(kind),
                way_name[way], m[0], m[1], m[2], m[3], m[4], m[5]);
    }
#undef TM
    rc = 0;
out:
    if (have_r) rt_job_free(&jr);
    if (have_t) rt_job_free(&jt);
    rt_image_free(img);
    free(tm);
    free(col);
    return rc;
}

int rt_treelet_bench(FILE *out, rt_scene *sc, const rt_render_opts *base, int reps, const char *tmpdir,
                     const char *command, rt_err *e)
{
    /* the wide BVHs of the accel table, or the one --accel names */
    int kinds[RT_ACCEL_NKINDS], nk = 0;
    for (int k = 1; k < RT_ACCEL_NKINDS; k++)
        if (rt_accel_bvh_width(k) > 2) kinds[nk++] = k;
    if (base->accel != RT_ACCEL_DEFAULT) {
        if (!rt_accel_bvh_width(base->accel))
            return rt_errf(e, "--what treelet: the treelet tracer runs on a BVH, not on %s", rt_accel_name(base->accel));
        kinds[0] = base->accel;
        nk = 1;
    }
    if (reps < 1) reps = 1;
    fprintf(out,
            "The treelet tracer against the recursive tracer on the same BVH, %dx%d, lights %u, %u triangles (per "
            "repetition the recursive run, then the treelet run; seconds: wall time of the run, a trace file through "
            "its last write; CPU: the thread's CPU time; ratios treelet over recursive; medians over %d "
            "repetitions):\n\n",
            base->W, base->H, base->lights, sc->ntri, reps);
    fprintf(out, "| structure | run | rep | recursive s | treelet s | ratio | recursive CPU s | treelet CPU s | CPU ratio "
                 "| recursive refs/ray | treelet refs/ray |\n|---|---|---|---|---|---|---|---|---|---|---|\n");
    fflush(out);
    for (int i = 0; i < nk; i++)
        if (bench_accel(out, sc, base, kinds[i], reps, tmpdir, command, e) < 0) return -1;
    fprintf(out, "\n");
    return 0;
}
