/*
 * cores_bench.c -- `raytraffic bench --what cores` (rt_cores_bench, see
 * bench.h): the multi-core hierarchy's throughput (cachesim/mcore.h).
 *
 * One job (the scene, the recursive tracer unless --tracers names another
 * splitting tracer, the options' size and lights) is recorded twice into
 * memory: on one core and interleaved on N simulated cores (rt_job_run_cores,
 * N = --cores, default 8). Then, per repetition and back to back, the same
 * hierarchy (default private 32K/8/64 L1s and the 13 shared sizes
 * 1K..4M, fully associative) replays the one-core stream on one core and
 * the N-core stream on N cores; each replay is timed on the thread's CPU
 * clock (other processes on a loaded machine do not stretch it) and on the
 * wall. Beside them the one-core hierarchy of the same levels (hier.h,
 * no cores) replays the one-core stream. The row gives references per CPU
 * second of each and the ratio of the N-core model to the one-core
 * hierarchy, the figure the issue bounds (>= 0.5), and the median of the
 * repetitions.
 */
#include "bench.h"
#include "hier.h"
#include "mcore.h"
#include "run.h"

#include <inttypes.h>
#include <stdlib.h>
#include <string.h>

typedef struct stream {
    rt_access *a;
    uint8_t *core;
    size_t n, cap;
    int oom;
} stream;

static void add(stream *s, unsigned core, const rt_access *a, size_t n)
{
    if (s->oom) return;
    if (s->n + n > s->cap) {
        size_t cap = 2 * (s->n + n);
        rt_access *na = realloc(s->a, cap * sizeof *na);
        uint8_t *nc = na ? realloc(s->core, cap) : NULL;
        if (na) s->a = na;
        if (!nc) {
            s->oom = 1;
            return;
        }
        s->core = nc;
        s->cap = cap;
    }
    memcpy(s->a + s->n, a, n * sizeof *a);
    memset(s->core + s->n, (int)core, n);
    s->n += n;
}

static int put1(rt_sink *s, const rt_access *a, size_t n)
{
    add(s->ctx, 0, a, n);
    return ((stream *)s->ctx)->oom ? -1 : 0;
}

static int putc_(rt_csink *s, unsigned core, const rt_access *a, size_t n)
{
    add(s->ctx, core, a, n);
    return ((stream *)s->ctx)->oom ? -1 : 0;
}

/* Replays s on a fresh model of cfg with ncores; CPU seconds, or -1. */
static double replay(const rt_mc_config *cfg0, int ncores, const stream *s, double *wall, rt_err *e)
{
    rt_mc_config cfg = *cfg0;
    cfg.ncores = ncores;
    rt_mc *m = rt_mc_new(&cfg, e);
    if (!m) return -1;
    const double t0 = rt_now(), c0 = rt_bench_thread_cpu();
    for (size_t i = 0; i < s->n;) {
        size_t j = i + 1;
        while (j < s->n && s->core[j] == s->core[i] && j - i < 4096) j++;
        if (rt_mc_put(m, s->core[i], s->a + i, j - i) < 0) {
            rt_errf(e, "%s", rt_mc_error(m));
            rt_mc_free(m);
            return -1;
        }
        i = j;
    }
    rt_mc_finish(m);
    const double c = rt_bench_thread_cpu() - c0;
    *wall = rt_now() - t0;
    rt_mc_free(m);
    return c;
}

int rt_cores_bench(FILE *out, rt_scene *sc, const rt_render_opts *base, const char *tracer, const char *hierarchy,
                   int reps, rt_err *e)
{
    rt_mc_config cfg;
    if (rt_mc_parse(hierarchy, &cfg, e) < 0) return -1;
    const int N = base->cores > 1 ? base->cores : 8;
    rt_render_opts o = *base;
    o.cores = N;
    o.host_threads = 1;
    rt_job j;
    if (rt_job_setup_borrowed(&j, sc, NULL, tracer, &o, e) < 0) return -1;
    rt_image *img = rt_image_new(j.opt.W, j.opt.H, e);
    stream one = {0}, many = {0};
    rt_run_stats st;
    rt_sink s1 = {put1, &one};
    rt_csink sn = {putc_, &many};
    int rc = -1;
    double *r1 = calloc((size_t)reps * 3, sizeof *r1);
    if (!img || !r1) goto done;
    if (rt_job_run_cores(&j, &sn, img, &st, e) < 0) goto done;
    j.opt.cores = 1;
    if (rt_job_run(&j, &s1, img, &st, e) < 0) goto done;
    if (one.oom || many.oom) {
        rt_errf(e, "out of memory holding the streams");
        goto done;
    }
    char spec[200];
    rt_mc_spec(&cfg, spec, sizeof spec);
    fprintf(out, "Many cores: %s, %dx%d, lights %u, %s; %zu references on 1 core, %zu on %d cores (thread CPU time):\n\n",
            tracer, j.opt.W, j.opt.H, j.opt.lights, spec, one.n, many.n, N);
    fprintf(out, "| rep | one-core hierarchy M refs/s | model, 1 core M refs/s | model, %d cores M refs/s | %d cores over the one-core hierarchy |\n"
                 "|---|---|---|---|---|\n", N, N);
    for (int r = 0; r < reps; r++) {
        double w;
        rt_hier *h = rt_hier_new(&cfg.h, e);
        if (!h) goto done;
        const double c0 = rt_bench_thread_cpu();
        for (size_t i = 0; i < one.n; i += 4096) rt_hier_put(h, one.a + i, one.n - i < 4096 ? one.n - i : 4096);
        rt_hier_finish(h);
        const double ch = rt_bench_thread_cpu() - c0;
        rt_hier_free(h);
        const double c1 = replay(&cfg, 1, &one, &w, e), cn = c1 < 0 ? -1 : replay(&cfg, N, &many, &w, e);
        if (cn < 0) goto done;
        r1[r] = (double)one.n / ch;
        r1[reps + r] = (double)many.n / cn;
        r1[2 * reps + r] = r1[reps + r] / r1[r];
        fprintf(out, "| %d | %.1f | %.1f | %.1f | %.2f |\n", r + 1, r1[r] * 1e-6, (double)one.n / c1 * 1e-6,
                r1[reps + r] * 1e-6, r1[2 * reps + r]);
    }
    fprintf(out, "| median | %.1f | | %.1f | %.2f |\n\n", rt_bench_median(r1, reps) * 1e-6,
            rt_bench_median(r1 + reps, reps) * 1e-6, rt_bench_median(r1 + 2 * reps, reps));
    rc = 0;
done:
    free(r1);
    free(one.a);
    free(one.core);
    free(many.a);
    free(many.core);
    rt_image_free(img);
    rt_job_free(&j);
    return rc;
}
