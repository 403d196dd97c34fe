/*
 * bench.c -- simulator throughput benchmark (rt_sim_bench, see sim.h).
 *
 * The synthetic trace imitates a k-d tree ray tracer with coherent rays
 * (consecutive rays are neighbours, as in Hilbert order): per ray, read the
 * 32-byte ray record, walk an 18-level path down a breadth-first array of
 * 8-byte nodes (the top levels change every few thousand rays, the deepest
 * every ray), then visit two leaves, each an index read (16 B) and four
 * 36-byte triangles (straddling lines) at a leaf-dependent place in a
 * 500K-triangle array, and write 16 bytes of hit record back into the ray.
 * 30 references per ray. The stream is generated in chunks from a fixed
 * seed, so every pass sees the same references and only simulation is
 * timed.
 */
#include "bench.h"
#include "msim.h"
#include "sim.h"

#include <stdlib.h>
#include <string.h>

#define CHUNK 65536
#define NODE_BASE 0x10000000ULL
#define INDEX_BASE 0x11000000ULL
#define TRI_BASE 0x12000000ULL
#define RAY_BASE 0x20000000ULL
#define NTRI 500000u
#define NRAY (1u << 20)

typedef struct gen {
    uint64_t ray;     /* current ray */
    int phase;        /* step within the current ray */
    uint64_t node;    /* current node index (breadth-first, root 1) */
    uint64_t leaf;    /* current leaf's first triangle */
} gen;

static inline uint64_t mix(uint64_t x)
{
    x ^= x >> 33;
    x *= 0xff51afd7ed558ccdULL;
    x ^= x >> 33;
    x *= 0xc4ceb9fe1a85ec53ULL;
    return x ^ (x >> 33);
}

#define DEPTH 18

static void gen_fill(gen *g, rt_access *a, size_t n)
{
    for (size_t i = 0; i < n; i++) {
        int p = g->phase++;
        uint64_t ray = g->ray;
        if (p == 0) { /* read the ray */
            a[i] = (rt_access){RAY_BASE + (ray % NRAY) * 32, 32, 0, RT_CLS_RAY};
            g->node = 1;
        } else if (p <= DEPTH) { /* one level down: coherent choice */
            int sh = 14 - p > 0 ? 14 - p : 0;
            uint64_t bit = mix(((ray >> sh) << 5) ^ (uint64_t)p) & 1;
            g->node = g->node * 2 + bit;
            a[i] = (rt_access){NODE_BASE + g->node * 8, 8, 0, RT_CLS_NODE};
        } else if (p == DEPTH + 1 || p == DEPTH + 6) { /* leaf index list */
            uint64_t leaf = g->node ^ (p == DEPTH + 6 ? 1 : 0);
            g->leaf = mix(leaf) % (NTRI - 4);
            a[i] = (rt_access){INDEX_BASE + (leaf & 0xfffff) * 16, 16, 0, RT_CLS_INDEX};
        } else if (p <= DEPTH + 10) { /* four triangles per leaf */
            uint64_t t = g->leaf + (uint64_t)((p - DEPTH - 2) % 5);
            a[i] = (rt_access){TRI_BASE + t * 36, 36, 0, RT_CLS_TRI};
        } else { /* write the hit back into the ray record; next ray */
            a[i] = (rt_access){RAY_BASE + (ray % NRAY) * 32 + 16, 16, 1, RT_CLS_RAY};
            g->phase = 0;
            g->ray++;
        }
    }
}

/* Runs nrefs references through sims[0..nsim-1]; returns seconds spent
 * simulating (generation excluded). */
static double run(rt_msim **sims, int nsim, rt_access *buf, uint64_t nrefs)
{
    gen g = {0, 0, 1, 0};
    double t = 0;
    for (uint64_t done = 0; done < nrefs;) {
        size_t n = nrefs - done < CHUNK ? (size_t)(nrefs - done) : CHUNK;
        gen_fill(&g, buf, n);
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
