/*
 * msim.h -- one-pass multi-size fully associative LRU simulator (private to
 * cachesim/; the public entry point is sim.h). See the essay in msim.c.
 */
#ifndef RT_MSIM_H
#define RT_MSIM_H

#include "sim.h"

typedef struct rt_msim rt_msim;

/* k sizes (bytes, strictly increasing, each a multiple of line, k <=
 * RT_SIM_MAXSIZES), line size in bytes (any; powers of two are faster). */
rt_msim *rt_msim_new(const uint64_t *sizes, int k, uint32_t line, rt_err *e);
/* on: from now on a write miss covering its whole line fetches nothing
 * (rt_sim_config.write_miss_fullline); set before the first reference. */
void rt_msim_set_fullline(rt_msim *m, int on);
void rt_msim_free(rt_msim *m);
/* Simulates n references. The state grows with the distinct lines seen
 * (never beyond the largest cache's lines), before the batch that needs
 * it: 0, or -1 when that growth ran out of memory (then every later batch
 * is refused too and the counters stop at the batch before). */
int rt_msim_put(rt_msim *m, const rt_access *a, size_t n);
/* Counters of size index i, class cls, summed over the generations
 * (traffic_bytes filled in). */
void rt_msim_get(const rt_msim *m, int i, int cls, rt_sim_counts *out);
/* The same for generation bucket gen (0..RT_MAXGEN-1); gen < 0 sums them. */
void rt_msim_get_gen(const rt_msim *m, int i, int cls, int gen, rt_sim_counts *out);
int rt_msim_check(const rt_msim *m, rt_err *e);
/* How rt_msim_put walks a batch (results are the same either way):
 * RT_MSIM_AUTO (default) picks per batch from the previous one's depth
 * profile; the others force one way, for tests and benchmarks. */
enum { RT_MSIM_AUTO = 0, RT_MSIM_PLAIN = 1, RT_MSIM_PIPELINED = 2 };
void rt_msim_set_engine(rt_msim *m, int engine);
/* Batches walked so far: out[0] plainly, out[1] through the pipeline. */
void rt_msim_engine_batches(const rt_msim *m, uint64_t out[2]);
/* Writes back every dirty line of every size (counted as write-backs of
 * the line's last writer) and leaves them clean and resident. */
void rt_msim_flush(rt_msim *m);
/* Counts cnt[cg] reads that hit the top of the stack (rt_repeats). */
void rt_msim_add_repeats(rt_msim *m, const uint64_t *cnt);
/* Test hook: adds n generation-0 touches of (cls, write) at stack group g (0..k, k =
 * missed everywhere) to the counters, without simulating them; lets tests
 * check that counters and their sums are 64-bit without 2^32 references. */
void rt_msim_test_add(rt_msim *m, int cls, int write, int g, uint64_t n);

#endif
