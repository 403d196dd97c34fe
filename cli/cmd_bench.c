/* cmd_bench.c -- `raytraffic bench`: throughput figures for the README.
 *
 * Measures, on one core: k-d tree build time; primary-ray throughput of each
 * tracer untraced, recording into a null sink (the cost of recording), into
 * a trace file (recording + encoding + zlib), and streaming into the
 * one-pass 13-size cache simulator; and the simulator's own throughput on a
 * synthetic trace. Results go to stdout as a Markdown table (or TSV).
 *
 * The render modes (bench/mode_bench.c): path tracing's error against time,
 * rays/s per tracer and mode, and the tracers' images compared bit for bit.
 * The streaming tracers (bench/stream_bench.c, --what stream): stream-branching
 * against recursive untraced, and a traced stream-multipass run into the
 * sweep's simulators, on the bunny. The treelet tracer (bench/treelet_bench.c,
 * --what treelet): traced and untraced against the recursive tracer on the
 * same BVH, each repetition's ratio and the medians.
 * Each item has its own default image size; -W/-H override them all.
 *
 * Absolute figures depend on the machine, so the output opens with the CPU
 * model, the online CPUs, the version, the git revision and the date, and
 * every figure stands beside a ratio to a reference measured in the same
 * run: tracer rows against the untraced recursive tracer, simulator rows
 * against a naive per-size LRU (bench/sim_bench.c). */
#include "scene_load.h"
#include "analysis.h"
#include "bench.h"
#include "cmd.h"
#include "run.h"
#include "approx.h"
#include "sim.h"
#include "sindex.h"
#include "trace.h"

#include <inttypes.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

static void usage(FILE *f)
{
    fprintf(f,
            "Usage: raytraffic bench [options]\n\n"
            "Measures tracer, trace and simulator throughput on one core.\n\n"
            "Options:\n"
            "  --scene SPEC       scene (default sphereflake)\n"
            "  -W N, -H N         image size (default 1024x1024; path-error 64x64,\n"
            "                     modes 512x512, identical 1024x1024)\n"
            "  --lights L         lights for the tracer runs (default none: primary rays)\n"
            "  --tracers LIST     comma list (default recursive,packet,dynamic)\n"
            "  --cache-size S     dynamic tracer's schedule (default 64K)\n"
            "  --what LIST        tracers,trace,sim,replay,hierarchy,approx,path-error,modes,\n"
            "                     identical,stream,embree,bvh,treelet,threads,cores,\n"
            "                     scale, scale-quick (a 3.54 M-triangle mesh 256x256 and a\n"
            "                     1.2 G-triangle instanced forest 512x512 --instances bvh,\n"
            "                     each rendered by a child process: peak RSS and wall time;\n"
            "                     scale-quick: the same at a tiny size; files under --tmpdir)\n"
            "                     (default tracers,trace,sim); replay: the exact simulator\n"
            "                     on --trace FILE, one and two threads, decoding included;\n"
            "                     hierarchy: L1 32K + 13 LLC sizes in one pass, and OPT,\n"
            "                     against the single-level replay of --trace FILE;\n"
            "                     approx: sampled simulators\n"
            "                     against exact (docs/approx.md) on --trace or the synthetic\n"
            "                     trace; path-error: path-mode RMSE against a --ref-spp\n"
            "                     reference for spp 1, 4, 16, 64; modes: rays/s per tracer in\n"
            "                     shadow, whitted and path mode; identical: every tracer's\n"
            "                     image against the recursive one in every mode (exit 1 on\n"
            "                     a difference); stream: stream-branching rays/s against\n"
            "                     recursive and a traced stream-multipass run with the 13-size\n"
            "                     simulator and the texture cache (scene bunny unless --scene);\n"
            "                     embree: Embree's rtcIntersect1 on the same\n"
            "                     primary rays (one thread), against the untraced recursive\n"
            "                     tracer (needs a build with libembree-dev);\n"
            "                     bvh: untraced primary rays through bvh2, bvh4 and bvh8\n"
            "                     against the k-d tree (and Embree when built), --reps runs;\n"
            "                     treelet: the treelet tracer against the recursive one on\n"
            "                     bvh4 and bvh8 (--accel: one BVH), untraced, into a null\n"
            "                     sink and into a trace file, --reps runs, medians;\n"
            "                     threads: untraced runs on 1..--threads N host threads\n"
            "                     (default: the online CPUs) of the --tracers that split\n"
            "                     (default recursive,packet,treelet), wall and CPU time,\n"
            "                     speedup, images compared, beside the modeled traffic;\n"
            "                     cores: the multi-core hierarchy (--hierarchy, default\n"
            "                     L1=32K/8/64/lru/private,LLC=1K-4M/full/64/lru/shared) on\n"
            "                     --cores N (default 8) against one core, refs/s and ratio\n"
            "                     (default 256x256)\n"
            "  --hierarchy SPEC   cores: the hierarchy\n"
            "  --scenes LIST      scenes of path-error, modes, identical (defaults cornell;\n"
            "                     sphereflake,cornell; cornell,knot,sphereflake)\n"
            "  --ref-spp N        path-error reference samples per pixel (default 1024)\n"
            "  --plot DIR         path-error: DIR/path-error-SCENE.png (gnuplot), .dat, .gp\n"
            "  --trace FILE       .rtt or din trace for --what approx (required by replay)\n"
            "  --reps N           replay, bvh, treelet, threads, cores: runs, median or best\n"
            "                     printed (default 3)\n"
            "  --sim-refs N       synthetic simulator trace length (default 20000000)\n"
            "  --tmpdir DIR       where trace files are written (default /tmp)\n"
            "  -h, --help         this help\n");
}

/* The "model name" of /proc/cpuinfo into buf ("unknown" without one). */
static void cpu_model(char *buf, size_t n)
{
    snprintf(buf, n, "unknown");
    FILE *f = fopen("/proc/cpuinfo", "r");
    if (!f) return;
    char line[512];
    while (fgets(line, sizeof line, f)) {
        char *colon = strchr(line, ':');
        if (strncmp(line, "model name", 10) || !colon) continue;
        colon += 1 + (colon[1] == ' ');
        colon[strcspn(colon, "\n")] = 0;
        snprintf(buf, n, "%s", colon);
        break;
    }
    fclose(f);
}

/* The provenance lines under the title: machine and date. */
static void print_machine(void)
{
    char cpu[256], date[64];
    time_t now = time(NULL);
    struct tm tmv;
    cpu_model(cpu, sizeof cpu);
    if (!gmtime_r(&now, &tmv) || !strftime(date, sizeof date, "%Y-%m-%d %H:%M:%S UTC", &tmv))
        snprintf(date, sizeof date, "unknown");
    printf("machine: %s, %ld online CPUs\ndate: %s\n\n", cpu, sysconf(_SC_NPROCESSORS_ONLN), date);
}

static int null_put(rt_sink *s, const rt_access *a, size_t n)
{
    (void)a;
    *(uint64_t *)s->ctx += n;
    return 0;
}

/* One tracer's rows. do_sim here: also stream the tracer into the
 * simulator in-process. *ref: the untraced recursive tracer's rays/s, the
 * reference of the last column; 0 = this run is it (set here). */
static int bench_tracer(rt_job *j, const char *tmpdir, int do_trace, int do_sim, int untraced_only, double *ref)
{
    rt_err e = {0};
    rt_image *img = rt_image_new(j->opt.W, j->opt.H, &e);
    rt_run_stats st;
    if (!img) return -1;
    const char *name = j->tr->name;
    uint64_t rays;
    /* untraced */
    if (rt_job_run(j, NULL, img, &st, &e) < 0) goto fail;
    rays = st.rays_primary + st.rays_shadow;
    double base = st.seconds;
    if (*ref == 0) *ref = (double)rays / st.seconds;
#define VSREF(sec) ((double)rays / (sec) / *ref)
    printf("| %s | untraced%s | %.2f | %.2f | | 1.00 | %.2f |\n", name, untraced_only ? " (reference)" : "", st.seconds,
           (double)rays / st.seconds * 1e-6, VSREF(st.seconds));
    fflush(stdout);
    if (untraced_only) goto done;
    /* recording into a null sink */
    uint64_t cnt = 0;
    rt_sink ns = {null_put, &cnt};
    if (rt_job_run(j, &ns, img, &st, &e) < 0) goto fail;
    printf("| %s | recording (null sink) | %.2f | %.2f | %.1f | %.2f | %.2f |\n", name, st.seconds,
           (double)rays / st.seconds * 1e-6, (double)st.accesses / (double)rays, st.seconds / base, VSREF(st.seconds));
    fflush(stdout);
    if (do_trace) {
        char path[4096];
        snprintf(path, sizeof path, "%s/rt-bench-%ld.rtt", tmpdir, (long)getpid());
        rt_tr_meta m;
        rt_job_meta(j, rt_cmd_line(), &m);
        rt_tr_wopts wo; /* as `trace` writes them: version 3, with the sample index */
        rt_si_wopts(&wo);
        rt_tr_writer *w = rt_tr_create_opts(path, &m, &wo, &e);
        if (!w) goto fail;
        double t0 = rt_now();
        if (rt_job_run(j, rt_tr_sink(w), img, &st, &e) < 0) {
            rt_tr_abort(w);
            goto fail;
        }
        if (rt_tr_finish(w, &e) < 0) goto fail;
        double sec = rt_now() - t0;
        FILE *f = fopen(path, "rb");
        long bytes = 0;
        if (f) {
            fseek(f, 0, SEEK_END);
            bytes = ftell(f);
            fclose(f);
        }
        printf("| %s | trace file (%.2f B/ref, %.1f MB) | %.2f | %.2f | %.1f | %.2f | %.2f |\n", name,
               st.accesses ? (double)bytes / (double)st.accesses : 0.0, bytes / 1048576.0, sec,
               (double)rays / sec * 1e-6, (double)st.accesses / (double)rays, sec / base, VSREF(sec));
        fflush(stdout);
        unlink(path);
    }
    if (do_sim) {
        rt_sim_config c;
        rt_sim_config_default(&c);
        rt_sim *s = rt_sim_new(&c, &e);
        if (!s) goto fail;
        double t0 = rt_now();
        if (rt_job_run(j, rt_sim_sink(s), img, &st, &e) < 0) {
            rt_sim_free(s);
            goto fail;
        }
        double sec = rt_now() - t0;
        printf("| %s | in-process 13-size simulation | %.2f | %.2f | %.1f | %.2f | %.2f |\n", name, sec,
               (double)rays / sec * 1e-6, (double)st.accesses / (double)rays, sec / base, VSREF(sec));
        fflush(stdout);
        rt_sim_free(s);
    }
#undef VSREF
done:
    rt_image_free(img);
    return 0;
fail:
    rt_cmd_error("bench", "%s", e.msg);
    rt_image_free(img);
    return -1;
}

/* Embree's rtcIntersect1 on the primary rays of scene at o's size, beside
 * the untraced recursive tracer measured here on the same rays (no lights). */
static int bench_embree(const char *scene, const rt_render_opts *o0)
{
    if (!rt_embree_built()) {
        printf("embree: not built (libembree-dev missing)\n\n");
        return 0;
    }
    rt_err e = {0};
    rt_render_opts o = *o0;
    o.lights = 0;
    rt_scene *sc = rt_scene_load(scene, &e);
    rt_kdtree *kd = NULL;
    rt_image *img = NULL;
    rt_job j;
    int have_job = 0, rc = -1;
    rt_run_stats st;
    rt_embree_result r;
    rt_kd_params kp;
    rt_kd_default_params(&kp);
    if (!sc || !(kd = rt_kd_build(sc, &kp, &e)) || !(img = rt_image_new(o.W, o.H, &e)) ||
        rt_job_setup_borrowed(&j, sc, kd, "recursive", &o, &e) < 0)
        goto out;
    have_job = 1;
    if (rt_job_run(&j, NULL, img, &st, &e) < 0 || rt_embree_bench(sc, o.W, o.H, &r, &e) < 0) goto out;
    double ours = (double)st.rays_primary / st.seconds, theirs = (double)r.rays / r.sec;
    printf("Embree %s, rtcIntersect1, one thread, the same %dx%d primary rays in Hilbert order (Embree scene built in "
           "%.2f s, not timed):\n\n",
           r.version, o.W, o.H, r.build_sec);
    printf("| tracer | seconds | Mrays/s | hits | recursive untraced rays/s over this |\n|---|---|---|---|---|\n");
    printf("| recursive (untraced) | %.2f | %.2f | | 1.00 |\n", st.seconds, ours * 1e-6);
    printf("| embree rtcIntersect1 | %.2f | %.2f | %" PRIu64 " | %.2f |\n\n", r.sec, theirs * 1e-6, r.hits,
           ours / theirs);
    rc = 0;
out:
    if (rc < 0) rt_cmd_error("bench", "%s", e.msg);
    if (have_job) rt_job_free(&j);
    rt_image_free(img);
    rt_kd_free(kd);
    rt_scene_free(sc);
    return rc;
}

int main_bench(int argc, char **argv)
{
    static const struct option own[] = {
        {"scene", required_argument, NULL, 's'},
        {"tracers", required_argument, NULL, 'T'},
        {"what", required_argument, NULL, 'w'},
        {"sim-refs", required_argument, NULL, 'n'},
        {"tmpdir", required_argument, NULL, 'd'},
        {"trace", required_argument, NULL, 1100},
        {"reps", required_argument, NULL, 1110},
        {"hierarchy", required_argument, NULL, 1111},
        {"scenes", required_argument, NULL, 1101},
        {"ref-spp", required_argument, NULL, 1102},
        {"plot", required_argument, NULL, 1103},
        {"help", no_argument, NULL, 'h'},
        {NULL, 0, NULL, 0},
    };
    rt_render_opts o;
    rt_render_default_opts(&o);
    o.W = o.H = 0; /* 0: the item's own default size */
    const char *scenes = NULL, *plotdir = NULL, *hierarchy = "L1=32K/8/64/lru/private,LLC=1K-4M/full/64/lru/shared";
    long refspp = 1024, reps = 3;
    const char *scene = NULL, *tracers = "recursive,packet,dynamic", *what = "tracers,trace,sim";
    const char *tmpdir = "/tmp", *dummy = NULL, *trace = NULL;
    uint64_t simrefs = 20000000;
    struct option *lo = rt_cmd_longopts(RT_OC_BENCH, own);
    char so[32];
    int c, threads_given = 0, tracers_given = 0;
    const int thr_index = rt_render_opt_find("--threads");
    if (!lo) return RT_EXIT_FAIL;
    optind = 1;
    while ((c = getopt_long(argc, argv, rt_cmd_shortopts(RT_OC_BENCH, "h", so, sizeof so), lo, NULL)) != -1) {
        if (rt_cmd_opt_index(c) == thr_index) threads_given = 1;
        int r = rt_cmd_render_opt("bench", c, optarg, &o, &dummy);
        if (r < 0) {
            free(lo);
            return RT_EXIT_USAGE;
        }
        if (r > 0) continue;
        switch (c) {
        case 's': scene = optarg; break;
        case 'T': tracers = optarg, tracers_given = 1; break;
        case 'w': what = optarg; break;
        case 'd': tmpdir = optarg; break;
        case 1100: trace = optarg; break;
        case 1110:
            if (rt_cmd_parse_long(optarg, 1, 15, &reps) < 0) {
                rt_cmd_error("bench", "--reps: '%s' is not a count in 1..15", optarg);
                free(lo);
                return RT_EXIT_USAGE;
            }
            break;
        case 1101: scenes = optarg; break;
        case 1111: hierarchy = optarg; break;
        case 1103: plotdir = optarg; break;
        case 1102:
            if (rt_cmd_parse_long(optarg, 1, RT_SPP_MAX, &refspp) < 0) {
                rt_cmd_error("bench", "--ref-spp: '%s' is not a sample count in 1..%d", optarg, RT_SPP_MAX);
                free(lo);
                return RT_EXIT_USAGE;
            }
            break;
        case 'n':
            if (rt_parse_size(optarg, &simrefs) < 0 || simrefs == 0) {
                rt_cmd_error("bench", "--sim-refs: '%s' is not a positive count", optarg);
                free(lo);
                return RT_EXIT_USAGE;
            }
            break;
        case 'h': usage(stdout); free(lo); return RT_EXIT_OK;
        default: free(lo); return RT_EXIT_USAGE;
        }
    }
    free(lo);
    if (optind != argc) {
        rt_cmd_error("bench", "unexpected argument '%s'", argv[optind]);
        return RT_EXIT_USAGE;
    }
    int do_tr = 0, do_trace = 0, do_sim = 0, do_approx = 0, do_perr = 0, do_modes = 0, do_ident = 0, do_stream = 0, do_embree = 0, do_bvh = 0,
        do_replay = 0, do_treelet = 0, do_hier = 0, do_threads = 0, do_cores = 0, do_scale = 0;
    {
        char *list = strdup(what), *save = NULL;
        for (char *t = strtok_r(list, ",", &save); t; t = strtok_r(NULL, ",", &save)) {
            if (!strcmp(t, "tracers")) do_tr = 1;
            else if (!strcmp(t, "trace")) do_trace = 1;
            else if (!strcmp(t, "sim")) do_sim = 1;
            else if (!strcmp(t, "replay")) do_replay = 1;
            else if (!strcmp(t, "hierarchy")) do_hier = 1;
            else if (!strcmp(t, "approx")) do_approx = 1;
            else if (!strcmp(t, "path-error")) do_perr = 1;
            else if (!strcmp(t, "modes")) do_modes = 1;
            else if (!strcmp(t, "identical")) do_ident = 1;
            else if (!strcmp(t, "stream")) do_stream = 1;
            else if (!strcmp(t, "embree")) do_embree = 1;
            else if (!strcmp(t, "bvh")) do_bvh = 1;
            else if (!strcmp(t, "treelet")) do_treelet = 1;
            else if (!strcmp(t, "threads")) do_threads = 1;
            else if (!strcmp(t, "cores")) do_cores = 1;
            else if (!strcmp(t, "scale")) do_scale = 1;
            else if (!strcmp(t, "scale-quick")) do_scale = 2;
            else {
                rt_cmd_error("bench", "--what: unknown item '%s' (tracers, trace, sim, replay, hierarchy, approx, path-error, "
                             "modes, identical, stream, embree, bvh, treelet, threads, cores, scale, scale-quick)", t);
                free(list);
                return RT_EXIT_USAGE;
            }
        }
        free(list);
    }
    if (do_hier && !trace) {
        rt_cmd_error("bench", "--what hierarchy needs --trace FILE (e.g. a trace of sphereflake 1024x1024)");
        return RT_EXIT_USAGE;
    }
    if (do_replay && !trace) {
        rt_cmd_error("bench", "--what replay needs --trace FILE");
        return RT_EXIT_USAGE;
    }
    const char *stream_scene = scene ? scene : "bunny"; /* the paper's scene */
    if (!scene) scene = "sphereflake";
    int W0 = o.W, H0 = o.H; /* as given; 0 = each item's default */
    const int host_threads = o.host_threads; /* --threads: the threads item's largest count; the others run on one */
    o.host_threads = 1;
    o.W = W0 ? W0 : 1024;
    o.H = H0 ? H0 : 1024;
    if (do_tr || do_trace || do_sim || do_approx || do_embree || do_bvh || do_treelet || do_threads || do_cores)
        printf("raytraffic %s (%s) bench: scene %s, %dx%d, lights %u, one core\n\n", rt_version(), rt_git_rev(),
               scene, o.W, o.H, o.lights);
    else
        printf("raytraffic %s (%s) bench, one core\n\n", rt_version(), rt_git_rev());
    print_machine();
    if (do_tr || do_trace) {
        rt_err e = {0};
        rt_scene *sc = rt_scene_load(scene, &e);
        if (!sc) {
            rt_cmd_error("bench", "%s", e.msg);
            return RT_EXIT_FAIL;
        }
        rt_kd_params kp;
        rt_kd_default_params(&kp);
        rt_kdtree *kd = rt_kd_build(sc, &kp, &e);
        if (!kd) {
            rt_cmd_error("bench", "%s", e.msg);
            rt_scene_free(sc);
            return RT_EXIT_FAIL;
        }
        printf("k-d tree: %" PRIu32 " triangles, %" PRIu32 " nodes, %" PRIu32 " leaves, depth %" PRIu32
               ", %.2f triangles per non-empty leaf, built in %.2f s\n\n",
               sc->ntri, kd->nnodes, kd->nleaves, kd->maxdepth, rt_kd_mean_leaf_tris(kd), kd->build_sec);
        printf("| tracer | mode | seconds | Mrays/s | refs/ray | time vs untraced | rays/s vs recursive untraced "
               "|\n|---|---|---|---|---|---|---|\n");
        char *list = strdup(tracers), *save = NULL;
        int rc = 0;
        double ref = 0; /* untraced recursive rays/s; measured first when the list does not start with it */
        const char *refname = rt_tracer_reference()->name;
        size_t rl = strlen(refname);
        if (strncmp(tracers, refname, rl) || (tracers[rl] && tracers[rl] != ',')) {
            rt_job j;
            rt_err e2 = {0};
            if (rt_job_setup_borrowed(&j, sc, kd, refname, &o, &e2) < 0) {
                rt_cmd_error("bench", "%s", e2.msg);
                rc = -1;
            } else {
                rc = bench_tracer(&j, tmpdir, 0, 0, 1, &ref);
                rt_job_free(&j);
            }
        }
        for (char *t = strtok_r(list, ",", &save); t && rc == 0; t = strtok_r(NULL, ",", &save)) {
            rt_job j;
            rt_err e2 = {0};
            if (rt_job_setup_borrowed(&j, sc, kd, t, &o, &e2) < 0) {
                rt_cmd_error("bench", "%s", e2.msg);
                rc = -1;
                break;
            }
            rc = bench_tracer(&j, tmpdir, do_trace, do_sim, 0, &ref);
            rt_job_free(&j);
        }
        free(list);
        rt_kd_free(kd);
        rt_scene_free(sc);
        if (rc < 0) return RT_EXIT_FAIL;
        printf("\n");
    }
    if (do_embree && bench_embree(scene, &o) < 0) return RT_EXIT_FAIL;
    if (do_bvh) {
        rt_err e = {0};
        rt_scene *sc = rt_scene_load(scene, &e);
        fflush(stdout);
        int r = sc ? rt_bvh_bench_primary(stdout, sc, o.W, o.H, (int)reps, &e) : -1;
        rt_scene_free(sc);
        if (r < 0) {
            rt_cmd_error("bench", "%s", e.msg);
            return RT_EXIT_FAIL;
        }
    }
    if (do_treelet) {
        rt_err e = {0};
        rt_scene *sc = rt_scene_load(scene, &e);
        fflush(stdout);
        int r = sc ? rt_treelet_bench(stdout, sc, &o, (int)reps, tmpdir, rt_cmd_line(), &e) : -1;
        rt_scene_free(sc);
        if (r < 0) {
            rt_cmd_error("bench", "%s", e.msg);
            return RT_EXIT_FAIL;
        }
    }
    if (do_threads) {
        rt_err e = {0};
        rt_scene *sc = rt_scene_load(scene, &e);
        long ncpu = sysconf(_SC_NPROCESSORS_ONLN);
        int maxt = threads_given ? host_threads : ncpu >= 1 && ncpu <= 1024 ? (int)ncpu : 1;
        rt_render_opts to = o;
        to.W = W0 ? W0 : 512;
        to.H = H0 ? H0 : 512;
        fflush(stdout);
        int r = sc ? rt_threads_bench(stdout, sc, &to, tracers_given ? tracers : "recursive,packet,treelet", maxt,
                                      (int)reps, &e)
                   : -1;
        rt_scene_free(sc);
        if (r < 0) {
            rt_cmd_error("bench", "%s", e.msg);
            return RT_EXIT_FAIL;
        }
    }
    if (do_scale) {
        rt_err e = {0};
        printf("Scenes at scale (%s):\n\n", do_scale == 2 ? "tiny sizes" : "3.54 M-triangle mesh, 1.2 G-triangle forest");
        fflush(stdout);
        if (rt_scale_bench(stdout, tmpdir, do_scale == 2, &e) < 0) {
            rt_cmd_error("bench", "%s", e.msg);
            return RT_EXIT_FAIL;
        }
    }
    if (do_cores) {
        rt_err e = {0};
        rt_scene *sc = rt_scene_load(scene, &e);
        rt_render_opts co = o;
        co.W = W0 ? W0 : 256;
        co.H = H0 ? H0 : 256;
        fflush(stdout);
        int r = sc ? rt_cores_bench(stdout, sc, &co, tracers_given ? tracers : "recursive", hierarchy, (int)reps, &e) : -1;
        rt_scene_free(sc);
        if (r < 0) {
            rt_cmd_error("bench", "%s", e.msg);
            return RT_EXIT_FAIL;
        }
    }
    if (do_sim) {
        printf("Cache simulator on a synthetic trace:\n\n");
        fflush(stdout);
        if (rt_sim_bench_n(stdout, simrefs) < 0) {
            rt_cmd_error("bench", "simulator benchmark: out of memory, or the naive LRU disagrees with the simulator");
            return RT_EXIT_FAIL;
        }
    }
    if (do_replay) {
        rt_err e = {0};
        printf("%sReplay of a trace file:\n\n", do_sim ? "\n" : "");
        fflush(stdout);
        if (rt_replay_bench(stdout, trace, (int)reps, &e) < 0) {
            rt_cmd_error("bench", "%s", e.msg);
            return RT_EXIT_FAIL;
        }
    }
    if (do_hier) {
        rt_err e = {0};
        printf("Cache hierarchy and OPT against the single-level replay:\n\n");
        fflush(stdout);
        if (rt_hier_bench(stdout, trace, (int)reps, &e) < 0) {
            rt_cmd_error("bench", "%s", e.msg);
            return RT_EXIT_FAIL;
        }
    }
    if (do_approx) {
        rt_err e = {0};
        printf("\nSampled simulation against exact (time inside the simulators):\n\n");
        fflush(stdout);
        if (rt_approx_bench_n(stdout, trace, simrefs, &e) < 0) {
            rt_cmd_error("bench", "%s", e.msg);
            return RT_EXIT_FAIL;
        }
    }
    rt_mode_bench mb = {NULL, tracers, 0, 0, (int)refspp, o};
    int blank = !(do_sim || do_approx); /* the output so far ends with a blank line */
    if (do_perr) {
        rt_err e = {0};
        char gp[4096];
        rt_plot_opts po = {plotdir, NULL, stdout};
        if (plotdir) {
            if (rt_plot_find_gnuplot(gp, sizeof gp) == 0) po.gnuplot = gp;
            else rt_cmd_error("bench", "gnuplot not found (apt-get install gnuplot-nox): writing data files only");
        }
        mb.scenes = scenes ? scenes : "cornell";
        mb.W = W0 ? W0 : 64;
        mb.H = H0 ? H0 : 64;
        printf("%sPath tracing, error against time:\n\n", blank ? "" : "\n");
        fflush(stdout);
        if (rt_mode_bench_path_error(stdout, &mb, plotdir ? &po : NULL, &e) < 0) {
            rt_cmd_error("bench", "%s", e.msg);
            return RT_EXIT_FAIL;
        }
        blank = 1;
    }
    if (do_modes) {
        rt_err e = {0};
        mb.scenes = scenes ? scenes : "sphereflake,cornell";
        mb.W = W0 ? W0 : 512;
        mb.H = H0 ? H0 : 512;
        if (!blank) printf("\n");
        fflush(stdout);
        if (rt_mode_bench_modes(stdout, &mb, &e) < 0) {
            rt_cmd_error("bench", "%s", e.msg);
            return RT_EXIT_FAIL;
        }
        blank = 0;
    }
    if (do_ident) {
        rt_err e = {0};
        mb.scenes = scenes ? scenes : "cornell,knot,sphereflake";
        mb.W = W0 ? W0 : 1024;
        mb.H = H0 ? H0 : 1024;
        if (!blank) printf("\n");
        fflush(stdout);
        int nd = rt_mode_bench_identical(stdout, &mb, &e);
        if (nd < 0) {
            rt_cmd_error("bench", "%s", e.msg);
            return RT_EXIT_FAIL;
        }
        if (nd > 0) {
            rt_cmd_error("bench", "%d image%s differ%s from the recursive tracer's", nd, nd == 1 ? "" : "s",
                         nd == 1 ? "s" : "");
            return RT_EXIT_FAIL;
        }
    }
    if (do_stream) {
        rt_err e = {0};
        if (!blank) printf("\n");
        fflush(stdout);
        if (rt_stream_bench(stdout, stream_scene, &o, &e) < 0) {
            rt_cmd_error("bench", "%s", e.msg);
            return RT_EXIT_FAIL;
        }
    }
    return RT_EXIT_OK;
}
