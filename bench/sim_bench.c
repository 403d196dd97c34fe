/*
 * sim_bench.c -- simulator throughput benchmark (rt_sim_bench, see bench.h).
 *
 * Replays the synthetic ray-tracer trace of synth.h (30 references per ray,
 * hot tree top, streaming triangles), regenerated in chunks so every pass
 * sees the same references and only simulation is timed: once through the
 * one-pass 13-size simulator, then through 13 single-size ones.
 */
#include "bench.h"
#include "msim.h"
#include "sim.h"
#include "synth.h"

#include <stdlib.h>
#include <string.h>

#define CHUNK 65536

/* Runs nrefs references through sims[0..nsim-1]; returns seconds spent
 * simulating (generation excluded). */
static double run(rt_msim **sims, int nsim, rt_access *buf, uint64_t nrefs)
{
    rt_synth g;
    rt_synth_init(&g);
    double t = 0;
    for (uint64_t done = 0; done < nrefs;) {
        size_t n = nrefs - done < CHUNK ? (size_t)(nrefs - done) : CHUNK;
        rt_synth_fill(&g, buf, n);
        double t0 = rt_now();
        for (int i = 0; i < nsim; i++) rt_msim_put(sims[i], buf, n);
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
    double t1 = run(&one, 1, buf, nrefs);
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
        tsep += run(&m, 1, buf, nrefs);
        rt_msim_free(m);
    }
    free(buf);
    fprintf(out, "cachesim: %llu synthetic references, 13 sizes 1K..4M, 64-byte lines, fully associative LRU\n",
            (unsigned long long)nrefs);
    fprintf(out, "cachesim: one pass, 13 sizes:    %8.3f s  %7.1f M refs/s\n", t1, (double)nrefs / t1 / 1e6);
    fprintf(out, "cachesim: 13 sizes one by one:   %8.3f s  %7.1f M refs/s per size (%.1fx slower than one pass)\n",
            tsep, (double)nrefs * c.nsizes / tsep / 1e6, tsep / t1);
    fprintf(out, "cachesim: (check) tri read misses 1K %llu, 4M %llu\n", (unsigned long long)geo1k.read_misses,
            (unsigned long long)geo4m.read_misses);
    return 0;
}

int rt_sim_bench(FILE *out) { return rt_sim_bench_n(out, 20000000ULL); }
