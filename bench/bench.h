/*
 * bench.h -- benchmark code behind `raytraffic bench` (module prefixes
 * rt_sim_bench, rt_approx_bench). Not part of the library.
 */
#ifndef RT_BENCH_H
#define RT_BENCH_H

#include "approx.h"
#include "sim.h"

#include <stdint.h>
#include <stdio.h>

/* ---- benchmark -------------------------------------------------------- */

/* Generates a 20-million-reference synthetic trace (hot tree-top lines,
 * streaming triangles, ray records) and reports to out the references/s of
 * the one-pass 13-size simulation and the time of simulating the 13 sizes
 * one at a time. Returns 0 or -1 (out of memory). */
int rt_sim_bench(FILE *out);
/* Same with a chosen trace length (tests use a short one). */
int rt_sim_bench_n(FILE *out, uint64_t nrefs);

/* ---- benchmark -------------------------------------------------------- */

/* Runs the exact simulator and each method at several parameters over a
 * synthetic 20-million-reference trace (trace_path NULL) or a .rtt/din
 * file, and writes a Markdown table to out: wall time of simulation, speed-
 * up over exact, mean and max absolute miss-ratio error over the available
 * sizes, and the max relative traffic error (all classes, and per group)
 * over the sizes >= 16K. Returns 0 or -1 (file or memory error; nothing is
 * printed for it, the message goes to e). */
int rt_approx_bench(FILE *out, const char *trace_path, rt_err *e);
/* Same with a chosen synthetic length (tests use a short one). */
int rt_approx_bench_n(FILE *out, const char *trace_path, uint64_t nrefs, rt_err *e);

#endif
