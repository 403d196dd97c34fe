/*
 * sim_bench.c -- simulator throughput benchmark (rt_sim_bench, see bench.h).
 *
 * Replays the synthetic ray-tracer trace of synth.h (30 references per ray,
 * hot tree top, streaming triangles), regenerated in chunks so every pass
 * sees the same references and only simulation is timed: once through the
 * one-pass 13-size simulator, then through 13 single-size ones.
 *
 * The reference beside those figures is a naive LRU: one recency-ordered
 * array of line numbers per size, searched linearly and shifted on every
 * touch, obviously correct and slow. It runs only a short prefix of the
 * stream (its cost grows with the cache size), the one-pass simulator runs
 * the same prefix, and their miss counts must agree: the speed-up printed
 * is measured on identical references in the same process.
 */
#include "bench.h"
#include "msim.h"
#include "sim.h"
#include "synth.h"

#include <stdlib.h>
#include <string.h>

#define CHUNK 65536
#define NAIVE_REFS 100000 /* prefix the naive LRU runs (about a second) */

/* ---- naive per-size LRU ------------------------------------------------- */

typedef struct naive {
    uint64_t line;                        /* line size, bytes */
    int k;                                /* sizes */
    uint64_t cap[RT_SIM_MAXSIZES];        /* lines per size */
    uint64_t used[RT_SIM_MAXSIZES];       /* lines resident per size */
    uint64_t *mru[RT_SIM_MAXSIZES];       /* per size: line numbers, most recent first */
    uint64_t miss[RT_SIM_MAXSIZES][RT_NCLASS]; /* misses (read + write) per size and class */
} naive;

static void naive_free(naive *n)
{
    for (int i = 0; i < n->k; i++) free(n->mru[i]);
}

static int naive_init(naive *n, const uint64_t *sizes, int k, uint64_t line)
{
    memset(n, 0, sizeof *n);
    n->line = line;
    n->k = k;
    for (int i = 0; i < k; i++) {
        n->cap[i] = sizes[i] / line;
        if (!(n->mru[i] = malloc(n->cap[i] * sizeof *n->mru[i]))) {
            naive_free(n);
            return -1;
        }
    }
    return 0;
}

/* One touch of line L by class cls at every size: find, move to front. */
static void naive_touch(naive *n, uint64_t L, int cls)
{
    for (int s = 0; s < n->k; s++) {
        uint64_t *m = n->mru[s], i = 0;
        while (i < n->used[s] && m[i] != L) i++;
        if (i == n->used[s]) { /* miss: the last entry falls out when full */
            n->miss[s][cls]++;
            if (n->used[s] < n->cap[s]) n->used[s]++;
            i = n->used[s] - 1;
        }
        memmove(m + 1, m, i * sizeof *m);
        m[0] = L;
    }
}

static void naive_put(naive *n, const rt_access *a, size_t cnt)
{
    for (size_t i = 0; i < cnt; i++) {
        uint64_t end = a[i].addr + (a[i].size ? a[i].size : 1);
        for (uint64_t L = a[i].addr / n->line; L * n->line < end; L++) naive_touch(n, L, a[i].cls);
    }
}

/* ---- timing -------------------------------------------------------------- */

/* Runs nrefs references through sims[0..nsim-1] (or through nv when
 * nsim is 0); returns seconds spent simulating (generation excluded). */
static double run(rt_msim **sims, int nsim, naive *nv, rt_access *buf, uint64_t nrefs)
{
    rt_synth g;
    rt_synth_init(&g);
    double t = 0;
    for (uint64_t done = 0; done < nrefs;) {
        size_t n = nrefs - done < CHUNK ? (size_t)(nrefs - done) : CHUNK;
        rt_synth_fill(&g, buf, n);
        double t0 = rt_now();
        for (int i = 0; i < nsim; i++) rt_msim_put(sims[i], buf, n);
        if (!nsim) naive_put(nv, buf, n);
        t += rt_now() - t0;
        done += n;
    }
    return t;
}

int rt_sim_bench_n(FILE *out, uint64_t nrefs)
{
    rt_sim_config c;
    rt_sim_config_default(&c);
    rt_access *buf = malloc(CHUNK * sizeof *buf);
    rt_msim *one = rt_msim_new(c.sizes, c.nsizes, c.line, NULL);
    if (!buf || !one) {
        free(buf);
        rt_msim_free(one);
        return -1;
    }
    double t1 = run(&one, 1, NULL, buf, nrefs);
    rt_sim_counts geo4m, geo1k;
    rt_msim_get(one, c.nsizes - 1, RT_CLS_TRI, &geo4m);
    rt_msim_get(one, 0, RT_CLS_TRI, &geo1k);
    rt_msim_free(one);

    double tsep = 0;
    for (int i = 0; i < c.nsizes; i++) {
        rt_msim *m = rt_msim_new(&c.sizes[i], 1, c.line, NULL);
        if (!m) {
            free(buf);
            return -1;
        }
        tsep += run(&m, 1, NULL, buf, nrefs);
        rt_msim_free(m);
    }

    /* the reference: naive LRU and one-pass simulator on the same prefix */
    uint64_t np = nrefs < NAIVE_REFS ? nrefs : NAIVE_REFS;
    naive nv;
    rt_msim *pre = rt_msim_new(c.sizes, c.nsizes, c.line, NULL);
    if (!pre || naive_init(&nv, c.sizes, c.nsizes, c.line) < 0) {
        rt_msim_free(pre);
        free(buf);
        return -1;
    }
    double tnaive = run(NULL, 0, &nv, buf, np);
    double tpre = run(&pre, 1, NULL, buf, np);
    int agree = 1;
    for (int i = 0; i < c.nsizes; i++)
        for (int k = 0; k < RT_NCLASS; k++) {
            rt_sim_counts x;
            rt_msim_get(pre, i, k, &x);
            if (x.read_misses + x.write_misses != nv.miss[i][k]) agree = 0;
        }
    rt_msim_free(pre);
    naive_free(&nv);
    free(buf);
    double rn = (double)np / tnaive; /* naive refs/s */
    fprintf(out, "cachesim: %llu synthetic references, 13 sizes 1K..4M, 64-byte lines, fully associative LRU\n",
            (unsigned long long)nrefs);
    fprintf(out, "cachesim: naive per-size LRU:    %8.3f s  %7.3f M refs/s on the first %llu refs, 13 sizes (the reference)\n",
            tnaive, rn / 1e6, (unsigned long long)np);
    fprintf(out, "cachesim: one pass, same refs:   %8.3f s  %7.1f M refs/s  %8.1fx naive LRU (misses %s)\n", tpre,
            (double)np / tpre / 1e6, (double)np / tpre / rn, agree ? "agree" : "DIFFER");
    fprintf(out, "cachesim: one pass, 13 sizes:    %8.3f s  %7.1f M refs/s  %8.1fx naive LRU\n", t1,
            (double)nrefs / t1 / 1e6, (double)nrefs / t1 / rn);
    fprintf(out, "cachesim: 13 sizes one by one:   %8.3f s  %7.1f M refs/s  %8.1fx naive LRU (%.1f M refs/s per size, %.1fx slower than one pass)\n",
            tsep, (double)nrefs / tsep / 1e6, (double)nrefs / tsep / rn, (double)nrefs * c.nsizes / tsep / 1e6,
            tsep / t1);
    fprintf(out, "cachesim: (check) tri read misses 1K %llu, 4M %llu\n", (unsigned long long)geo1k.read_misses,
            (unsigned long long)geo4m.read_misses);
    return agree ? 0 : -1;
}

int rt_sim_bench(FILE *out) { return rt_sim_bench_n(out, 20000000ULL); }

/* ---- replay of a trace file ----------------------------------------------- */

/* Keeps the first NAIVE_REFS references of a replay and drops the rest. */
typedef struct prefix {
    rt_access *a;
    size_t n;
} prefix;

static int prefix_put(rt_sink *s, const rt_access *a, size_t n)
{
    prefix *p = s->ctx;
    size_t take = n < NAIVE_REFS - p->n ? n : NAIVE_REFS - p->n;
    memcpy(p->a + p->n, a, take * sizeof *a);
    p->n += take;
    return 0;
}

static int dcmp(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* One exact 13-size replay of path on nthreads; seconds, or -1. *out
 * keeps the simulator (caller frees). */
static double replay_once(const char *path, int nthreads, rt_sim **out, uint64_t *refs, rt_err *e)
{
    rt_sim_config c;
    rt_sim_config_default(&c);
    double t0 = rt_now();
    rt_sim *s = rt_sim_new(&c, e);
    rt_sim_input in;
    rt_repeats rp;
    if (s) rt_sim_repeats(s, &rp); /* as `sim` does: used with two threads */
    if (!s || rt_sim_replay_filtered(rt_sim_sink(s), &rp, path, RT_SIM_IN_AUTO, 0, nthreads, NULL, &in, e) < 0 ||
        rt_sim_finish(s) < 0) {
        rt_sim_free(s);
        return -1;
    }
    double t = rt_now() - t0;
    *refs = in.refs;
    *out = s;
    return t;
}

int rt_replay_bench(FILE *out, const char *path, int reps, rt_err *e)
{
    if (reps < 1) reps = 1;
    if (reps > 15) reps = 15;
    /* the reference: the naive LRU on the file's first references */
    prefix p = {malloc(NAIVE_REFS * sizeof *p.a), 0};
    if (!p.a) return rt_errf(e, "out of memory");
    rt_sink ps = {prefix_put, &p};
    naive nv;
    rt_sim_config c;
    rt_sim_config_default(&c);
    if (rt_sim_replay_threads(&ps, path, RT_SIM_IN_AUTO, 0, 1, NULL, NULL, e) < 0) {
        free(p.a);
        return -1;
    }
    if (naive_init(&nv, c.sizes, c.nsizes, c.line) < 0) {
        free(p.a);
        return rt_errf(e, "out of memory");
    }
    double t0 = rt_now();
    naive_put(&nv, p.a, p.n);
    double tnaive = rt_now() - t0;
    naive_free(&nv);
    free(p.a);
    double rn = (double)p.n / tnaive;

    double t[2][15];
    uint64_t refs = 0;
    int agree = 1;
    for (int r = 0; r < reps; r++) {
        rt_sim *s[2] = {NULL, NULL};
        for (int k = 0; k < 2; k++) /* alternate, so load drifts hit both alike */
            if ((t[k][r] = replay_once(path, k + 1, &s[k], &refs, e)) < 0) {
                rt_sim_free(s[0]);
                return -1;
            }
        for (int i = 0; i < c.nsizes; i++)
            for (int k = 0; k < RT_NCLASS; k++) {
                rt_sim_counts x, y;
                rt_sim_get(s[0], i, k, &x);
                rt_sim_get(s[1], i, k, &y);
                agree &= !memcmp(&x, &y, sizeof x);
            }
        rt_sim_free(s[0]);
        rt_sim_free(s[1]);
    }
    qsort(t[0], (size_t)reps, sizeof t[0][0], dcmp);
    qsort(t[1], (size_t)reps, sizeof t[1][0], dcmp);
    double m1 = t[0][reps / 2], m2 = t[1][reps / 2];
    fprintf(out, "replay: %s, %llu references, exact 13 sizes 1K..4M, whole replay (decoding included), median of %d\n",
            path, (unsigned long long)refs, reps);
    fprintf(out, "replay: naive per-size LRU:  %8.3f s  %7.3f M refs/s on the first %zu refs (the reference)\n", tnaive,
            rn / 1e6, p.n);
    fprintf(out, "replay: --threads 1:         %8.3f s  %7.1f M refs/s  %8.1fx naive LRU  1.00\n", m1,
            (double)refs / m1 / 1e6, (double)refs / m1 / rn);
    fprintf(out, "replay: --threads 2:         %8.3f s  %7.1f M refs/s  %8.1fx naive LRU  %.2fx --threads 1 (counters %s)\n",
            m2, (double)refs / m2 / 1e6, (double)refs / m2 / rn, m1 / m2, agree ? "agree" : "DIFFER");
    return agree ? 0 : rt_errf(e, "the two-thread replay's counters differ from the one-thread replay's");
}
