/*
 * synth.c -- the synthetic ray-tracer trace of the benchmarks (synth.h).
 *
 * Address regions are far apart so no two kinds of record share a line;
 * the per-level branch is a hash of the ray number with its low bits
 * dropped (fewer at deeper levels), which is what makes the tree top hot
 * and the leaves change with every ray.
 */
#include "synth.h"
#include "rt_math.h"

#define NODE_BASE 0x10000000ULL
#define INDEX_BASE 0x11000000ULL
#define TRI_BASE 0x12000000ULL
#define RAY_BASE 0x20000000ULL
#define NTRI 500000u
#define NRAY (1u << 20)
#define DEPTH 18


void rt_synth_init(rt_synth *g)
{
    g->ray = 0;
    g->phase = 0;
    g->node = 1;
    g->leaf = 0;
}

void rt_synth_fill(rt_synth *g, rt_access *a, size_t n)
{
    for (size_t i = 0; i < n; i++) {
        int p = g->phase++;
        uint64_t ray = g->ray;
        if (p == 0) { /* read the ray */
            a[i] = (rt_access){RAY_BASE + (ray % NRAY) * 32, 32, 0, RT_CLS_RAY, 0};
            g->node = 1;
        } else if (p <= DEPTH) { /* one level down: coherent choice */
            int sh = 14 - p > 0 ? 14 - p : 0;
            uint64_t bit = rt_mix64(((ray >> sh) << 5) ^ (uint64_t)p) & 1;
            g->node = g->node * 2 + bit;
            a[i] = (rt_access){NODE_BASE + g->node * 8, 8, 0, RT_CLS_NODE, 0};
        } else if (p == DEPTH + 1 || p == DEPTH + 6) { /* leaf index list */
            uint64_t leaf = g->node ^ (p == DEPTH + 6 ? 1 : 0);
            g->leaf = rt_mix64(leaf) % (NTRI - 4);
            a[i] = (rt_access){INDEX_BASE + (leaf & 0xfffff) * 16, 16, 0, RT_CLS_INDEX, 0};
        } else if (p <= DEPTH + 10) { /* four triangles per leaf */
            uint64_t t = g->leaf + (uint64_t)((p - DEPTH - 2) % 5);
            a[i] = (rt_access){TRI_BASE + t * 36, 36, 0, RT_CLS_TRI, 0};
        } else { /* write the hit back into the ray record; next ray */
            a[i] = (rt_access){RAY_BASE + (ray % NRAY) * 32 + 16, 16, 1, RT_CLS_RAY, 0};
            g->phase = 0;
            g->ray++;
        }
    }
}
