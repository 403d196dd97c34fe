/*
 * approx_bench.c -- speed and error of the sampled estimators against the
 * exact simulator (rt_approx_bench, see approx.h).
 *
 * Input: the synthetic ray-tracer trace of synth.h (the one sim_bench.c
 * replays), regenerated in chunks so every pass sees the same stream, or a
 * .rtt / din file read in chunks. Only the time spent inside
 * the simulator (put and finish) is measured; generation and decompression
 * are excluded.
 *
 * Errors are measured against the exact one-pass simulator on the same
 * stream: miss ratio = (read + write misses) / accesses over all classes
 * per size, absolute error averaged and maximized over the sizes that have
 * an estimate; traffic error = |estimate - exact| / exact over sizes >= 16K
 * (all classes, then the geometry and ray groups).
 */
#include "bench.h"
#include "sindex.h"
#include "synth.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#define CHUNK 65536

typedef struct result result;
static void fill(const rt_sim_config *c, const rt_approx *a, result *res);

/* A pass over the input: synthetic or a file. */
typedef struct source {
    const char *path; /* NULL = synthetic */
    uint64_t nrefs;   /* synthetic length */
    uint64_t done;    /* synthetic references produced */
    rt_synth g;       /* synthetic state */
    int fmt;          /* file format */
    rt_tr_reader *tr; /* .rtt reader */
    rt_din *din;      /* din reader */
} source;

static int src_open(source *s, const char *path, uint64_t nrefs, rt_err *e)
{
    memset(s, 0, sizeof *s);
    s->path = path;
    s->nrefs = nrefs;
    rt_synth_init(&s->g);
    if (!path) return 0;
    s->fmt = rt_sim_sniff(path, e);
    if (s->fmt < 0) return -1;
    if (s->fmt == RT_SIM_IN_DIN) s->din = rt_din_open(path, RT_CLS_FB, e);
    else s->tr = rt_si_open(path, e);
    return s->din || s->tr ? 0 : -1;
}

static long src_read(source *s, rt_access *buf, size_t cap, rt_err *e)
{
    if (!s->path) {
        size_t n = s->nrefs - s->done < cap ? (size_t)(s->nrefs - s->done) : cap;
        rt_synth_fill(&s->g, buf, n);
        s->done += n;
        return (long)n;
    }
    return s->din ? rt_din_read(s->din, buf, cap, e) : rt_tr_read(s->tr, buf, cap, e);
}

static void src_close(source *s)
{
    rt_din_close(s->din);
    rt_tr_close(s->tr);
}

typedef struct result {
    double secs;                          /* time inside the simulator */
    int avail[RT_SIM_MAXSIZES];           /* size has an estimate */
    double mr[RT_SIM_MAXSIZES];           /* miss ratio, all classes */
    double traffic[RT_SIM_MAXSIZES][3];   /* all classes, geometry, ray */
} result;

static int run(const rt_sim_config *c, const rt_approx_config *ac, const char *path, uint64_t nrefs,
               rt_access *buf, result *res, rt_err *e)
{
    memset(res, 0, sizeof *res);
    rt_approx *a = rt_approx_new(c, ac, e);
    if (!a) return -1;
    source src;
    int rc = -1;
    if (src_open(&src, path, nrefs, e)) goto out;
    long n;
    while ((n = src_read(&src, buf, CHUNK, e)) > 0) {
        double t0 = rt_now();
        rt_approx_put(a, buf, (size_t)n);
        res->secs += rt_now() - t0;
    }
    src_close(&src);
    if (n < 0) goto out;
    double t0 = rt_now();
    if (rt_approx_finish(a, e)) goto out;
    res->secs += rt_now() - t0;
    fill(c, a, res);
    rc = 0;
out:
    rt_approx_free(a);
    return rc;
}

/* A whole-file replay as `raytraffic sim` does it (rt_approx_replay_file,
 * two threads: reading, checking and decoding included), timed; the
 * sample index is used when it fits (note empty), else every record. */
static int run_file(const rt_sim_config *c, const rt_approx_config *ac, const char *path, result *res, char *note,
                    size_t nn, rt_err *e)
{
    memset(res, 0, sizeof *res);
    double t0 = rt_now();
    rt_approx *a = rt_approx_new(c, ac, e);
    if (!a) return -1;
    int rc = rt_approx_replay_file(a, path, RT_SIM_IN_AUTO, RT_CLS_FB, 2, NULL, NULL, note, nn, e) ||
                     rt_approx_finish(a, e)
                 ? -1
                 : 0;
    res->secs = rt_now() - t0;
    if (!rc) fill(c, a, res);
    rt_approx_free(a);
    return rc;
}

static void fill(const rt_sim_config *c, const rt_approx *a, result *res)
{
    for (int i = 0; i < c->nsizes; i++) {
        if (!rt_approx_available(a, i, NULL)) continue;
        res->avail[i] = 1;
        uint64_t acc = 0, miss = 0;
        for (int k = 0; k < RT_NCLASS; k++) {
            rt_sim_counts t;
            rt_approx_get(a, i, k, &t, NULL);
            acc += t.accesses;
            miss += t.read_misses + t.write_misses;
            res->traffic[i][0] += (double)t.traffic_bytes;
            if (rt_class_group(k) == RT_GROUP_GEOMETRY) res->traffic[i][1] += (double)t.traffic_bytes;
            if (rt_class_group(k) == RT_GROUP_RAY) res->traffic[i][2] += (double)t.traffic_bytes;
        }
        res->mr[i] = acc ? (double)miss / (double)acc : 0;
    }
}

/* Mean and largest |miss ratio error| of r against ex over r's sizes. */
static int mr_err(const rt_sim_config *c, const result *ex, const result *r, double *mean, double *mx)
{
    int nav = 0;
    *mean = *mx = 0;
    for (int i = 0; i < c->nsizes; i++) {
        if (!r->avail[i]) continue;
        nav++;
        double d = fabs(r->mr[i] - ex->mr[i]);
        *mean += d;
        if (d > *mx) *mx = d;
    }
    if (nav) *mean /= nav;
    return nav;
}

static int cmp_double(const void *x, const void *y)
{
    double a = *(const double *)x, b = *(const double *)y;
    return a < b ? -1 : a > b;
}

/* End to end on an .rtt: exact and hybrid `sim` as the command runs them,
 * median of three runs each. */
static int end_to_end(FILE *out, const rt_sim_config *c, const char *path, rt_err *e)
{
    rt_approx_config ac[2];
    rt_approx_config_default(&ac[0]);
    ac[0].method = RT_APPROX_EXACT;
    rt_approx_config_default(&ac[1]);
    ac[1].method = RT_APPROX_HYBRID;
    ac[1].rate = rt_approx_default_rate(RT_APPROX_HYBRID);
    result *r = rt_calloc(2, sizeof *r, e);
    if (!r) return -1;
    double med[2];
    char note[2][RT_ERR_LEN];
    for (int m = 0; m < 2; m++) {
        double t[3];
        for (int k = 0; k < 3; k++) {
            if (run_file(c, &ac[m], path, &r[m], note[m], sizeof note[m], e)) {
                free(r);
                return -1;
            }
            t[k] = r[m].secs;
        }
        qsort(t, 3, sizeof t[0], cmp_double);
        med[m] = t[1];
    }
    double mean, mx;
    int nav = mr_err(c, &r[0], &r[1], &mean, &mx);
    fprintf(out, "\nEnd to end (the whole `sim` replay: read, check, decode, simulate; 2 threads; median of 3):\n\n");
    fprintf(out, "| method | reads | time (s) | speedup | sizes | MR err mean | MR err max |\n");
    fprintf(out, "|---|---|---:|---:|---:|---:|---:|\n");
    fprintf(out, "| exact | every record | %.3f | 1.0 | %d | 0 | 0 |\n", med[0], c->nsizes);
    fprintf(out, "| hybrid | %s | %.3f | %.1f | %d | %.4f | %.4f |\n",
            note[1][0] ? "every record (no fitting sample index)" : "the sample index", med[1],
            med[1] > 0 ? med[0] / med[1] : 0, nav, mean, mx);
    free(r);
    return 0;
}

int rt_approx_bench_n(FILE *out, const char *trace_path, uint64_t nrefs, rt_err *e)
{
    rt_sim_config c;
    rt_sim_config_default(&c);
    static const struct {
        int method;
        double rate;
        uint64_t smax, exact_below, window_below; /* window_below: hybrid only */
    } runs[] = {
        {RT_APPROX_SHARDS_RATE, 0.1, 0, 0, 0},       {RT_APPROX_SHARDS_RATE, 0.01, 0, 0, 0},
        {RT_APPROX_SHARDS_RATE, 0.001, 0, 0, 0},     {RT_APPROX_SHARDS_RATE, 0.01, 0, 16384, 0},
        {RT_APPROX_SHARDS_RATE, 0.001, 0, 65536, 0}, {RT_APPROX_SHARDS_FIXED, 0, 4096, 0, 0},
        {RT_APPROX_SHARDS_FIXED, 0, 16384, 0, 0},    {RT_APPROX_SHARDS_FIXED, 0, 16384, 16384, 0},
        {RT_APPROX_STATSTACK, 0.01, 0, 0, 0},        {RT_APPROX_STATSTACK, 0.001, 0, 0, 0},
        {RT_APPROX_STATSTACK, 0.0001, 0, 0, 0},      {RT_APPROX_STATSTACK, 0.001, 0, 16384, 0},
        {RT_APPROX_HYBRID, 1.0 / 64, 0, 0, 32768},   {RT_APPROX_HYBRID, 1.0 / 64, 0, 0, 8192},
        {RT_APPROX_HYBRID, 1.0 / 128, 0, 0, 32768},  {RT_APPROX_HYBRID, 1.0 / 128, 0, 0, 8192},
        {RT_APPROX_HYBRID, 1.0 / 64, 0, 0, 0},
    };
    rt_access *buf = rt_calloc(CHUNK, sizeof *buf, e);
    result *ex = rt_calloc(1, sizeof *ex, e), *r = rt_calloc(1, sizeof *r, e);
    int rc = -1;
    if (!buf || !ex || !r) goto out;
    rt_approx_config ac;
    rt_approx_config_default(&ac);
    ac.method = RT_APPROX_EXACT;
    if (run(&c, &ac, trace_path, nrefs, buf, ex, e)) goto out;
    fprintf(out, "Input: %s; 13 sizes 1K..4M, 64-byte lines, fully associative LRU, write-back.\n\n",
            trace_path ? trace_path : "synthetic ray-tracer trace");
    fprintf(out, "| method | params | time (s) | speedup | sizes | MR err mean | MR err max | traffic err max "
                 ">=16K | geometry | ray |\n");
    fprintf(out, "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|\n");
    fprintf(out, "| exact | | %.3f | 1.0 | %d | 0 | 0 | 0 | 0 | 0 |\n", ex->secs, c.nsizes);
    for (size_t k = 0; k < sizeof runs / sizeof runs[0]; k++) {
        rt_approx_config_default(&ac);
        ac.method = runs[k].method;
        ac.rate = runs[k].rate;
        if (runs[k].smax) ac.smax = runs[k].smax;
        ac.exact_below = runs[k].exact_below;
        if (ac.method == RT_APPROX_HYBRID) ac.window_below = runs[k].window_below;
        if (run(&c, &ac, trace_path, nrefs, buf, r, e)) goto out;
        double mean, mx, tmax[3] = {0, 0, 0};
        int nav = mr_err(&c, ex, r, &mean, &mx);
        for (int i = 0; i < c.nsizes; i++) {
            if (!r->avail[i] || c.sizes[i] < 16384) continue;
            for (int g = 0; g < 3; g++) {
                double rel = ex->traffic[i][g] > 0 ? fabs(r->traffic[i][g] - ex->traffic[i][g]) / ex->traffic[i][g]
                                                   : (r->traffic[i][g] > 0 ? 1 : 0);
                if (rel > tmax[g]) tmax[g] = rel;
            }
        }
        char params[128];
        rt_approx_params(&ac, params, sizeof params);
        fprintf(out, "| %s | %s | %.3f | %.1f | %d | %.4f | %.4f | %.2f%% | %.2f%% | %.2f%% |\n",
                rt_approx_method_name(ac.method), params, r->secs, r->secs > 0 ? ex->secs / r->secs : 0, nav,
                mean, mx, 100 * tmax[0], 100 * tmax[1], 100 * tmax[2]);
    }
    if (trace_path && rt_sim_sniff(trace_path, e) == RT_SIM_IN_RTT && end_to_end(out, &c, trace_path, e)) goto out;
    rc = 0;
out:
    free(buf);
    free(ex);
    free(r);
    return rc;
}

int rt_approx_bench(FILE *out, const char *trace_path, rt_err *e)
{
    return rt_approx_bench_n(out, trace_path, 20000000ULL, e);
}
