/*
 * bench.h -- benchmark code behind `raytraffic bench` (module prefixes
 * rt_sim_bench, rt_approx_bench, rt_mode_bench). Not part of the library.
 */
#ifndef RT_BENCH_H
#define RT_BENCH_H

#include "analysis.h"
#include "approx.h"
#include "options.h"
#include "scene.h"
#include "sim.h"

#include <stdint.h>
#include <stdio.h>

/* ---- benchmark -------------------------------------------------------- */

/* Generates a 20-million-reference synthetic trace (hot tree-top lines,
 * streaming triangles, ray records) and reports to out the references/s of
 * the one-pass 13-size simulation and the time of simulating the 13 sizes
 * one at a time, each beside its ratio to a naive per-size LRU measured in
 * the same call on the first 100000 references (the one-pass simulator's
 * speed on that same prefix is printed too). Returns 0, or -1 when out of
 * memory or when the naive LRU's miss counts differ from the simulator's
 * (the lines are printed first, marked DIFFER). */
int rt_sim_bench(FILE *out);
/* Same with a chosen trace length (tests use a short one). */
int rt_sim_bench_n(FILE *out, uint64_t nrefs);
/* Replays the .rtt or din file at path through the exact 13-size simulator
 * reps times (1..15) on one and on two threads, whole replay timed
 * (decoding included), and prints the medians beside the naive per-size
 * LRU on the file's first 100000 references and beside --threads 1. 0, or
 * -1 (file error, or the two replays' counters differ) with e set. */
int rt_replay_bench(FILE *out, const char *path, int reps, rt_err *e);
/* Replays path (reps times, 1..9, medians) as the single-level 13-size LRU
 * run, as a two-level hierarchy (L1 32K 8-way LRU + the 13 sizes as LLC, in
 * one pass) and with OPT at the 13 sizes; prints each one's references/s,
 * the two-level/single throughput ratio and the OPT/LRU time ratio (bench
 * --what hierarchy, bench/hier_bench.c). 0, or -1 with e set (file error,
 * or a one-level hierarchy differs from the plain simulator). */
int rt_hier_bench(FILE *out, const char *path, int reps, rt_err *e);

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

/* ---- render modes (mode_bench.c) ---------------------------------------- */

/* What the mode benchmarks run on. Every run copies base (packet edge,
 * dynamic schedule, threads...) and sets its own size, lights and mode. */
typedef struct rt_mode_bench {
    const char *scenes;  /* comma list of scene specs */
    const char *tracers; /* comma list of tracers (modes, identical) */
    int W, H;            /* image size */
    int ref_spp;         /* path error: samples per pixel of the reference */
    rt_render_opts base; /* the other render options */
} rt_mode_bench;

/* Path tracing on each scene (recursive tracer, all lights, base.bounces):
 * a reference of ref_spp samples, then spp = 1, 4, 16, 64, each as a
 * Markdown table row: spp, seconds, RMSE over all pixels and linear RGB
 * channels against the reference, seconds and RMSE as ratios to spp = 1,
 * and 1/sqrt(spp). With plot non-NULL, also DIR/path-error-SCENE.dat, .gp
 * and with gnuplot .png (RMSE against seconds, log-log), one "wrote" line
 * per scene to plot->log. 0 or -1 (message in e). */
int rt_mode_bench_path_error(FILE *out, const rt_mode_bench *b, const rt_plot_opts *plot, rt_err *e);

/* Rays/s (primary + secondary + shadow) of each tracer on each scene in
 * shadow, whitted (depth 5) and path (spp 4, bounces 4) mode, all lights,
 * untraced and into a counting sink (references per ray), each beside its
 * ratio to the recursive tracer and to the untraced run; then per scene the
 * recursive tracer's whitted rays/s over its shadow rays/s. 0 or -1. */
int rt_mode_bench_modes(FILE *out, const rt_mode_bench *b, rt_err *e);

/* Each tracer but recursive against the recursive tracer on each scene in
 * the four modes (raycast without lights; shadow, whitted depth 5 and path
 * spp 1 with all lights): one row per case, OK when the RGB planes are
 * bit-identical, else DIFF. Returns the number of DIFF cases, or -1. */
int rt_mode_bench_identical(FILE *out, const rt_mode_bench *b, rt_err *e);

/* ---- streaming tracers (stream_bench.c) ------------------------------------ */

/* On scene with base's size and options (raycast, no lights): the
 * recursive and stream-branching tracers' untraced primary rays/s, then a
 * stream-multipass run fed to the exact 13-size simulator and the texture
 * cache (RT_EXP_TEXCACHE_*), timed from job setup to the end, as a
 * Markdown table with each rays/s over the recursive tracer's, and a line
 * splitting the traced run's time. 0 or -1 (message in e). */
int rt_stream_bench(FILE *out, const char *scene, const rt_render_opts *base, rt_err *e);

/* ---- Embree comparison (embree_bench.c) --------------------------------- */

typedef struct rt_embree_result {
    char version[32]; /* Embree's version, "" when not built */
    double build_sec; /* Embree scene build (not in sec) */
    double sec;       /* the ray loop (wall; best of the reps) */
    double cpu_sec;   /* the ray loop's CPU time of the calling thread (best of the reps) */
    double cpu_med;   /* the same, median of the reps */
    double job_cpu_sec; /* the tracer's job around rtcIntersect1 (below): CPU time, best of the reps */
    double job_cpu_med; /* the same, median of the reps */
    uint64_t rays;    /* W * H */
    uint64_t hits;    /* rays that hit a triangle */
} rt_embree_result;

/* 1 when configure found Embree 3 (HAVE_EMBREE), else 0. */
int rt_embree_built(void);
/* W x H primary rays of sc's camera (rt_cam_ray), in Hilbert order, one
 * rtcIntersect1 each on a one-thread Embree device holding sc's triangles.
 * 0, or -1 with e set (without Embree: "embree: not built ..."). */
int rt_embree_bench(const rt_scene *sc, int W, int H, rt_embree_result *out, rt_err *e);
/* The same with the ray loop run reps times (>= 1, at most RT_BENCH_MAX_REPS)
 * on one Embree scene; then reps runs of the untraced recursive tracer's job
 * (no lights) with rtcIntersect1 as its walk: the pixel order computed
 * (rt_pixel_order, its array allocated) and the camera set up inside the
 * timed region, then per pixel rt_cam_ray, rtcIntersect1, rt_shade_pixel of
 * the hit (or the miss) into a W x H image and the pixel's two cost
 * channels written (0: Embree counts nothing). What the tracer does and this
 * loop does not: the per-triangle marks, the node and test counters and the
 * statistics at the end (rt_stats_finish). */
int rt_embree_bench_reps(const rt_scene *sc, int W, int H, int reps, rt_embree_result *out, rt_err *e);
/* CPU seconds of the calling thread (CLOCK_THREAD_CPUTIME_ID): a time that
 * other processes on a loaded machine do not stretch. */
double rt_bench_thread_cpu(void);
/* The median of v[0..n) (n >= 1; the mean of the middle two for even n);
 * sorts v. */
double rt_bench_median(double *v, int n);
#define RT_BENCH_MAX_REPS 15

/* ---- BVH widths against the k-d tree (bvh_bench.c) ----------------------- */

/* W x H primary rays of sc's camera (rt_cam_ray, Hilbert order), untraced,
 * through the k-d tree and bvh2, bvh4, bvh8 (default parameters), one
 * closest-hit query each, the ray loop timed alone (best of reps); with
 * Embree built, rtcIntersect1 on the same rays too. Writes a Markdown table
 * to out: build time, nodes, modeled MB, seconds, Mrays/s, nodes and tests
 * per ray, hits differing from the k-d tree's that brute force does not
 * confirm (up to 1000 differences are decided by rt_brute_closest outside
 * the timed loop; the confirmed ones are listed under the table), the k-d
 * tree's time over each row's and each row's rays/s over Embree's. 0, or
 * -1 with e set (out of memory, or a BVH hit wrong: printed first). */
int rt_bvh_bench_primary(FILE *out, const rt_scene *sc, int W, int H, int reps, rt_err *e);

/* ---- the treelet tracer against the recursive one (treelet_bench.c) ------ */

/* base's primary rays (W x H, base's lights) on sc through bvh4 and bvh8
 * (base->accel, when set, alone: a BVH), the recursive and the treelet
 * tracer back to back per repetition: untraced, recording into a null sink
 * and writing a version-3 trace file in tmpdir (removed; command goes into
 * its header). A Markdown table to out: wall and thread CPU seconds of
 * both, the ratios treelet over recursive, references per ray, one row per
 * repetition and the medians (of times and of ratios). 0, or -1 with e set. */
int rt_treelet_bench(FILE *out, rt_scene *sc, const rt_render_opts *base, int reps, const char *tmpdir,
                     const char *command, rt_err *e);

/* ---- host threads (threads_bench.c) --------------------------------------- */

/* Each tracer of the comma list on sc with base's options, untraced, on 1..
 * maxthreads host threads (tracers that run on one thread get a row saying
 * so), reps runs each: a Markdown table to out of the median wall and
 * process CPU seconds, the wall speedup over one thread, CPU over wall, the
 * image against one thread's (bit for bit) and the modeled references and
 * 64 KiB DRAM bytes of one traced run. 0, or -1 with e set (an image that
 * differs is printed first, then an error). */
int rt_threads_bench(FILE *out, rt_scene *sc, const rt_render_opts *base, const char *tracers, int maxthreads,
                     int reps, rt_err *e);

/* ---- many cores (cores_bench.c) -------------------------------------------- */

/* tracer's run of base on sc recorded on one core and on base->cores (8
 * when 1) simulated cores, then reps times each stream through hierarchy
 * (mcore.h) on 1 and on N cores, and the one-level simulator on the
 * one-core stream: a Markdown table to out of M references per thread-CPU
 * second and the ratio N cores over one, per repetition and the medians.
 * 0, or -1 with e set. */
int rt_cores_bench(FILE *out, rt_scene *sc, const rt_render_opts *base, const char *tracer, const char *hierarchy,
                   int reps, rt_err *e);

/* ---- scenes at scale (scale_bench.c) -------------------------------------- */

/* A closed bumpy torus of 2 x rows x cols triangles as a binary PLY. */
int rt_scale_write_mesh(const char *path, int rows, int cols, rt_err *e);
/* dir/tree0.ply .. tree<variants-1>.ply (a crown of rows x cols vertices and
 * a trunk) and dir/forest.pbrt instancing them on a grid x grid field;
 * the unique and instanced triangle counts. 0, or -1 with e set. */
int rt_scale_write_forest(const char *dir, int variants, int rows, int cols, int grid, uint64_t *unique,
                          uint64_t *instanced, rt_err *e);
/* Writes both scenes under tmpdir (full size, or tiny when quick), renders
 * each in a child process and prints a Markdown table of peak RSS and wall
 * time to out. 0, or -1 with e set (a failing child's output printed). */
int rt_scale_bench(FILE *out, const char *tmpdir, int quick, rt_err *e);

#endif
