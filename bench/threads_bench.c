/*
 * threads_bench.c -- `raytraffic bench --what threads` (rt_threads_bench,
 * see bench.h): untraced runs of the tracers that split over host threads
 * (the RT_OPTG_THREADS group: recursive, packet, treelet) on 1..N threads,
 * beside the modeled traffic of the same run.
 *
 * Per tracer one job (the structure built once, not timed); per repetition
 * the runs on 1, 2, ..., N threads back to back, so a change in the shared
 * machine's load hits every thread count alike. A run is timed on the wall
 * and on the process's CPU clock (all its threads): on a machine other
 * processes load, the wall time of N threads stretches while the CPU time
 * does not, so the row gives both, the wall speedup over one thread and the
 * CPU time over the wall time (the parallelism the run got). Each image is
 * compared bit for bit (RGB, depth and both cost channels) with the
 * one-thread image. The modeled traffic beside it -- references recorded and
 * DRAM bytes of the 64 KiB fully associative LRU cache, one traced run on
 * one thread -- is the same for every thread count: host threads change how
 * fast the model runs, never what it records. Nothing here assumes a
 * number of CPUs; N is the caller's.
 */
#include "bench.h"
#include "run.h"
#include "sim.h"

#include <inttypes.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

static double process_cpu(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* 1 when every plane of a and b holds the same bytes. */
static int same_image(const rt_image *a, const rt_image *b)
{
    size_t n = (size_t)a->W * (size_t)a->H;
    return !memcmp(a->rgb, b->rgb, 3 * n * sizeof *a->rgb) && !memcmp(a->depth, b->depth, n * sizeof *a->depth) &&
           !memcmp(a->nodes, b->nodes, n * sizeof *a->nodes) && !memcmp(a->tests, b->tests, n * sizeof *a->tests);
}

static void clear_image(rt_image *a)
{
    size_t n = (size_t)a->W * (size_t)a->H;
    memset(a->rgb, 0, 3 * n * sizeof *a->rgb);
    memset(a->nodes, 0, n * sizeof *a->nodes);
    memset(a->tests, 0, n * sizeof *a->tests);
    memset(a->depth, 0, n * sizeof *a->depth);
}

/* The modeled traffic of job j: references and the 64 KiB size's DRAM bytes. */
static int modeled(rt_job *j, rt_image *img, uint64_t *refs, uint64_t *dram, rt_err *e)
{
    rt_sim_config c;
    rt_sim_config_default(&c);
    rt_sim *s = rt_sim_new(&c, e);
    rt_run_stats st;
    if (!s) return -1;
    int saved = j->opt.host_threads;
    j->opt.host_threads = 1;
    int rc = rt_job_run(j, rt_sim_sink(s), img, &st, e);
    j->opt.host_threads = saved;
    if (rc == 0) {
        rt_sim_finish(s);
        *refs = st.accesses;
        *dram = 0;
        for (int i = 0; i < c.nsizes; i++)
            if (c.sizes[i] == 65536)
                for (int cls = 0; cls < RT_NCLASS; cls++) {
                    rt_sim_counts k;
                    rt_sim_get(s, i, cls, &k);
                    *dram += k.traffic_bytes;
                }
    }
    rt_sim_free(s);
    return rc;
}

int rt_threads_bench(FILE *out, rt_scene *sc, const rt_render_opts *base, const char *tracers, int maxthreads,
                     int reps, rt_err *e)
{
    if (maxthreads < 1 || maxthreads > 1024) return rt_errf(e, "--threads %d: not in 1..1024", maxthreads);
    if (reps < 1 || reps > RT_BENCH_MAX_REPS) return rt_errf(e, "reps %d out of range", reps);
    fprintf(out, "Host threads (untraced, %dx%d, lights %u; wall and process CPU seconds, median of %d runs; the "
                 "modeled traffic is one traced run):\n\n",
            base->W, base->H, base->lights, reps);
    fprintf(out, "| tracer | threads | wall s | CPU s | wall speedup over 1 | CPU / wall | image | modeled refs | "
                 "DRAM bytes at 64K |\n|---|---|---|---|---|---|---|---|---|\n");
    char *list = strdup(tracers), *save = NULL;
    if (!list) return rt_errf(e, "out of memory");
    int rc = 0;
    for (char *t = strtok_r(list, ",", &save); t && rc == 0; t = strtok_r(NULL, ",", &save)) {
        const rt_tracer *tr = rt_tracer_find(t);
        if (!tr) {
            rc = rt_errf(e, "unknown tracer '%s' (%s)", t, rt_tracer_names());
            break;
        }
        if (!(tr->opts & RT_OPTG_THREADS) && !rt_tracer_is(tr, RT_TR_CORES)) {
            fprintf(out, "| %s | (runs on one host thread) | | | | | | | |\n", t);
            continue;
        }
        rt_render_opts o = *base;
        o.host_threads = 1;
        rt_job j;
        if (rt_job_setup_borrowed(&j, sc, NULL, t, &o, e) < 0) {
            rc = -1;
            break;
        }
        rt_image *ref = rt_image_new(j.opt.W, j.opt.H, e), *img = ref ? rt_image_new(j.opt.W, j.opt.H, e) : NULL;
        double *wall = calloc((size_t)maxthreads * (size_t)reps, sizeof *wall);
        double *cpu = calloc((size_t)maxthreads * (size_t)reps, sizeof *cpu);
        int *same = calloc((size_t)maxthreads, sizeof *same);
        uint64_t refs = 0, dram = 0;
        if (!img || !wall || !cpu || !same) {
            if (img) rc = rt_errf(e, "out of memory");
            else rc = -1;
        }
        for (int n = 0; n < maxthreads; n++) same[n] = 1;
        for (int r = 0; r < reps && rc == 0; r++)
            for (int n = 1; n <= maxthreads && rc == 0; n++) {
                rt_run_stats st;
                j.opt.host_threads = n;
                rt_image *dst = n == 1 && r == 0 ? ref : img;
                clear_image(dst);
                const double c0 = process_cpu();
                if (rt_job_run(&j, NULL, dst, &st, e) < 0) {
                    rc = -1;
                    break;
                }
                cpu[(size_t)(n - 1) * (size_t)reps + (size_t)r] = process_cpu() - c0;
                wall[(size_t)(n - 1) * (size_t)reps + (size_t)r] = st.seconds;
                if (dst != ref && !same_image(ref, img)) same[n - 1] = 0;
            }
        if (rc == 0) rc = modeled(&j, img, &refs, &dram, e);
        double w1 = 0;
        for (int n = 1; n <= maxthreads && rc == 0; n++) {
            const double w = rt_bench_median(wall + (size_t)(n - 1) * (size_t)reps, reps);
            const double c = rt_bench_median(cpu + (size_t)(n - 1) * (size_t)reps, reps);
            if (n == 1) w1 = w;
            fprintf(out, "| %s | %d | %.3f | %.3f | %.2f | %.2f | %s | %" PRIu64 " | %" PRIu64 " |\n", t, n, w, c,
                    w > 0 ? w1 / w : 0.0, w > 0 ? c / w : 0.0, same[n - 1] ? "identical" : "DIFFERS", refs, dram);
            if (!same[n - 1]) rc = rt_errf(e, "%s: the image of %d threads differs from one thread's", t, n);
        }
        fflush(out);
        free(wall);
        free(cpu);
        free(same);
        rt_image_free(img);
        rt_image_free(ref);
        rt_job_free(&j);
    }
    free(list);
    fprintf(out, "\n");
    return rc;
}
