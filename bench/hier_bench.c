/*
 * hier_bench.c -- throughput of a two-level hierarchy and of OPT against
 * the single-level LRU replay (rt_hier_bench, see bench.h).
 *
 * Three replays of the same trace, each whole (decoding included, two
 * threads and the repeat filter, as `sim` runs them), median of reps:
 *   single  the paper's setting: 13 fully associative LRU sizes 1K..4M;
 *   hier    L1=32K/8/64/lru in front of the same 13 LLC sizes, every LLC
 *           size in one pass (non-inclusive: the L1's output does not
 *           depend on the LLC);
 *   opt     --repl opt at the 13 sizes (buffer, backward pass, forward).
 * It prints references/s of each and the ratios hier/single (throughput)
 * and opt/single (time), OPT's backward next-use pass and forward
 * simulation alone (rt_sim_phases) and the backward pass over the LRU
 * replay, all from the same runs, and checks that a one-level "hierarchy" of the
 * 13 sizes gives the single run's counters.
 */
#include "bench.h"
#include "hier.h"
#include "sim.h"

#include <stdlib.h>
#include <string.h>

static int dcmp(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* One replay of path into a hierarchy of spec; seconds or -1. */
static double run_hier(const char *path, const char *spec, int repl_opt, rt_hier **out, uint64_t *refs, rt_err *e)
{
    rt_sim_config base;
    rt_sim_config_default(&base);
    rt_hier_config hc;
    if (rt_hier_parse(spec, &base, &hc, e)) return -1;
    if (repl_opt && rt_sim_repl_parse("opt", &hc.level[hc.nlevels - 1].repl, e)) return -1;
    double t0 = rt_now();
    rt_hier *h = rt_hier_new(&hc, e);
    if (!h) return -1;
    rt_repeats rp;
    rt_hier_repeats(h, &rp);
    rt_sim_input in;
    if (rt_sim_replay_filtered(rt_hier_sink(h), &rp, path, RT_SIM_IN_AUTO, 0, 2, NULL, &in, e) < 0 ||
        rt_hier_finish(h) < 0) {
        rt_hier_free(h);
        return -1;
    }
    double t = rt_now() - t0;
    *refs = in.refs;
    *out = h;
    return t;
}

int rt_hier_bench(FILE *out, const char *path, int reps, rt_err *e)
{
    if (reps < 1) reps = 1;
    if (reps > 9) reps = 9;
    static const char *const specs[3] = {"LLC=1K-4M/full/64/lru", "L1=32K/8/64/lru,LLC=1K-4M/full/64/lru",
                                         "LLC=1K-4M/full/64/lru"};
    static const char *const what[3] = {"single level, 13 LRU sizes", "L1 32K 8-way + 13 LLC sizes",
                                        "OPT, 13 sizes"};
    double t[3][9], ph[2][9];
    uint64_t refs = 0;
    int agree = 1;
    for (int r = 0; r < reps; r++)
        for (int k = 0; k < 3; k++) { /* interleaved, so load drifts hit all alike */
            rt_hier *h = NULL;
            if ((t[k][r] = run_hier(path, specs[k], k == 2, &h, &refs, e)) < 0) return -1;
            if (k == 2) {
                double p[2];
                rt_sim_phases(rt_hier_level(h, 0), p);
                ph[0][r] = p[0];
                ph[1][r] = p[1];
            }
            if (k == 0 && r == 0) { /* the one-level hierarchy is the plain simulator */
                rt_sim_config c;
                rt_sim_config_default(&c);
                rt_sim *s = rt_sim_new(&c, e);
                rt_repeats rp;
                if (!s) return rt_hier_free(h), -1;
                rt_sim_repeats(s, &rp);
                if (rt_sim_replay_filtered(rt_sim_sink(s), &rp, path, RT_SIM_IN_AUTO, 0, 2, NULL, NULL, e) < 0) {
                    rt_sim_free(s);
                    rt_hier_free(h);
                    return -1;
                }
                rt_sim_finish(s);
                for (int i = 0; i < c.nsizes; i++)
                    for (int cls = 0; cls < RT_NCLASS; cls++) {
                        rt_sim_counts x, y;
                        rt_sim_get(s, i, cls, &x);
                        rt_sim_get(rt_hier_level(h, 0), i, cls, &y);
                        agree &= !memcmp(&x, &y, sizeof x);
                    }
                rt_sim_free(s);
            }
            rt_hier_free(h);
        }
    double m[3];
    for (int k = 0; k < 3; k++) {
        qsort(t[k], (size_t)reps, sizeof t[k][0], dcmp);
        m[k] = t[k][reps / 2];
    }
    double mp[2];
    for (int k = 0; k < 2; k++) {
        qsort(ph[k], (size_t)reps, sizeof ph[k][0], dcmp);
        mp[k] = ph[k][reps / 2];
    }
    fprintf(out, "hierarchy: %s, %llu references, whole replays (decoding included, 2 threads), median of %d\n", path,
            (unsigned long long)refs, reps);
    for (int k = 0; k < 3; k++)
        fprintf(out, "hierarchy: %-28s %8.3f s  %7.1f M refs/s\n", what[k], m[k], (double)refs / m[k] / 1e6);
    fprintf(out, "hierarchy: two-level throughput / single-level: %.2f (target >= 0.60)\n", m[0] / m[1]);
    fprintf(out, "hierarchy: OPT backward pass %.3f s, forward simulation %.3f s (the rest: decoding and buffering)\n",
            mp[0], mp[1]);
    fprintf(out, "hierarchy: OPT backward pass / LRU time: %.2f (target <= 2)\n", mp[0] / m[0]);
    fprintf(out, "hierarchy: OPT time / LRU time: %.2f\n", m[2] / m[0]);
    fprintf(out, "hierarchy: one-level hierarchy = plain simulator: %s\n", agree ? "agree" : "DIFFER");
    return agree ? 0 : rt_errf(e, "a one-level hierarchy's counters differ from the plain simulator's");
}
