/* cmd_sweep_cores.c -- `raytraffic sweep --hierarchy SPEC --cores LIST`:
 * the multi-core matrix, scenes x tracers x core counts, each job's cores
 * recorded in process (tracegen/run.h rt_job_run_cores) straight into the
 * multi-core hierarchy (cachesim/mcore.h) and stored as `sim --hierarchy
 * --db` stores a trace of the same job: the same run key (the trace
 * header's, cores and hierarchy included), memory traffic rows and
 * per-level rows. One process, jobs in order; a run already stored is
 * stored again (its rows replaced). */
#include "cmd.h"
#include "experiment.h"
#include "mcore.h"
#include "mcore_rows.h"
#include "run.h"
#include "scene_load.h"

#include <getopt.h>
#include <inttypes.h>
#include <stdlib.h>
#include <string.h>

static void usage(FILE *f)
{
    fprintf(f,
            "Usage: raytraffic sweep --hierarchy SPEC --cores LIST [options]\n\n"
            "Runs every scene x tracer x core count through N private caches above a\n"
            "shared level (see sim --hierarchy X --help) and stores the runs.\n\n"
            "Options:\n"
            "  --hierarchy SPEC   e.g. L1=32K/8/64/lru/private,LLC=1K-4M/full/64/lru/shared\n"
            "  --cores LIST       core counts, e.g. 1,2,4,8,16,32,64 (default 1)\n"
            "  --scenes LIST      comma list (default sphereflake)\n"
            "  --tracers LIST     comma list of tracers that split their work (recursive,\n"
            "                     packet, treelet: work shares; dynamic: its queues dealt\n"
            "                     to the cores in rounds; default recursive)\n"
            "  --db FILE          results database (default raytraffic.db)\n"
            "  -W N, -H N, --lights L, --accel A, --cache-size S ...  as for render\n"
            "  -h, --help         this help\n");
}

/* The comma list s as up to max ints in 1..256; count, or -1. */
static int parse_cores(const char *s, int *out, int max)
{
    int n = 0;
    char buf[256];
    if (strlen(s) >= sizeof buf) return -1;
    snprintf(buf, sizeof buf, "%s", s);
    for (char *save = NULL, *t = strtok_r(buf, ",", &save); t; t = strtok_r(NULL, ",", &save)) {
        long v;
        if (n == max || rt_cmd_parse_long(t, 1, RT_TR_MAX_CORES, &v) < 0) return -1;
        out[n++] = (int)v;
    }
    return n;
}

static int run_one(rt_db *db, rt_job *j, const rt_mc_config *cfg0, int n, rt_err *e)
{
    rt_mc_config cfg = *cfg0;
    cfg.ncores = n;
    j->opt.cores = n;
    rt_mc *mc = rt_mc_new(&cfg, e);
    rt_image *img = mc ? rt_image_new(j->opt.W, j->opt.H, e) : NULL;
    rt_tr_meta *m = img ? rt_calloc(1, sizeof *m, e) : NULL;
    rt_db_traffic *tr = m ? rt_calloc((size_t)cfg.h.level[cfg.h.nlevels - 1].nsizes * RT_NCLASS, sizeof *tr, e) : NULL;
    rt_db_level *lv = tr ? rt_calloc(rt_mc_db_level_cap(mc), sizeof *lv, e) : NULL;
    int rc = -1;
    rt_run_stats st;
    double t0 = rt_now();
    if (lv && rt_job_run_cores(j, rt_mc_csink(mc), img, &st, e) == 0) {
        if (rt_mc_finish(mc) < 0) {
            rt_errf(e, "%s", rt_mc_error(mc));
        } else {
            char spec[200], stats[600];
            rt_mc_spec(&cfg, spec, sizeof spec);
            rt_job_meta(j, rt_cmd_line(), m);
            rt_db_run run;
            rt_exp_run_from_meta(m, &run);
            run.hierarchy = spec;
            run.cores = n;
            run.refs = rt_mc_refs(mc);
            run.command = rt_cmd_line();
            run.wall_time = rt_now() - t0;
            snprintf(stats, sizeof stats, "rays_primary=%" PRIu64 " rays_shadow=%" PRIu64 " nodes=%" PRIu64
                                          " tests=%" PRIu64 " pv_primary=%" PRIu64 " pv_all=%" PRIu64 "%s%s",
                     st.rays_primary, st.rays_shadow, st.nodes, st.tests, st.pv_primary, st.pv_all,
                     st.extra[0] ? " " : "", st.extra);
            run.stats = stats;
            rt_db_rows R = {.traffic = tr, .ntraffic = rt_mc_db_traffic_rows(mc, tr), .level = lv,
                            .nlevel = rt_mc_db_level_rows(mc, lv)};
            int64_t id = 0;
            rc = rt_db_store(db, &run, &R, &id, e);
            if (rc == 0)
                fprintf(stderr, "raytraffic sweep: %s %s, %d core%s: run %lld, %" PRIu64 " references, %.1f s\n",
                        j->sc->name, j->tr->name, n, n == 1 ? "" : "s", (long long)id, run.refs, run.wall_time);
        }
    }
    free(lv);
    free(tr);
    free(m);
    rt_image_free(img);
    rt_mc_free(mc);
    return rc;
}

int rt_cmd_sweep_cores(int argc, char **argv)
{
    static const struct option own[] = {
        {"hierarchy", required_argument, NULL, 'y'},
        {"cores", required_argument, NULL, 'c'},
        {"scenes", required_argument, NULL, 's'},
        {"tracers", required_argument, NULL, 'T'},
        {"db", required_argument, NULL, 'd'},
        {"help", no_argument, NULL, 'h'},
        {NULL, 0, NULL, 0},
    };
    rt_render_opts o;
    rt_render_default_opts(&o);
    o.W = o.H = 256;
    const char *spec = NULL, *scenes = "sphereflake", *tracers = "recursive", *dbpath = "raytraffic.db", *dummy = NULL;
    int cores[64] = {1}, nc = 1, c;
    struct option *lo = rt_cmd_longopts(RT_OC_RUN, own); /* the one-job options (--lights, --accel, ...) */
    char so[32];
    if (!lo) return RT_EXIT_FAIL;
    optind = 1;
    while ((c = getopt_long(argc, argv, rt_cmd_shortopts(RT_OC_RUN, "h", so, sizeof so), lo, NULL)) != -1) {
        if (c == 'c' || c == 'y' || c == 's' || c == 'T' || c == 'd' || c == 'h') {
            switch (c) {
            case 'y': spec = optarg; break;
            case 's': scenes = optarg; break;
            case 'T': tracers = optarg; break;
            case 'd': dbpath = optarg; break;
            case 'h': usage(stdout); free(lo); return RT_EXIT_OK;
            default:
                if ((nc = parse_cores(optarg, cores, 64)) < 1) {
                    rt_cmd_error("sweep", "--cores: '%s' is not a comma list of 1..%d", optarg, RT_TR_MAX_CORES);
                    free(lo);
                    return RT_EXIT_USAGE;
                }
            }
            continue;
        }
        int r = rt_cmd_render_opt("sweep", c, optarg, &o, &dummy);
        if (r <= 0) {
            if (!r) rt_cmd_error("sweep", "with --hierarchy: option not supported (see sweep --hierarchy X --help)");
            free(lo);
            return RT_EXIT_USAGE;
        }
    }
    free(lo);
    rt_err e = {0};
    rt_mc_config cfg;
    if (!spec || rt_mc_parse(spec, &cfg, &e) < 0) {
        rt_cmd_error("sweep", "%s", spec ? e.msg : "--hierarchy needs SPEC");
        return RT_EXIT_USAGE;
    }
    if (optind != argc) {
        rt_cmd_error("sweep", "unexpected argument '%s'", argv[optind]);
        return RT_EXIT_USAGE;
    }
    /* every tracer known, and split over cores when asked for more than one */
    char tl[512];
    snprintf(tl, sizeof tl, "%s", tracers);
    for (char *save = NULL, *t = strtok_r(tl, ",", &save); t; t = strtok_r(NULL, ",", &save)) {
        const rt_tracer *tr = rt_tracer_find(t);
        if (!tr) {
            rt_cmd_error("sweep", "--tracers: unknown tracer '%s' (%s)", t, rt_tracer_names());
            return RT_EXIT_USAGE;
        }
        for (int k = 0; k < nc; k++)
            if (cores[k] > 1 && !rt_tracer_simulates_cores(tr) && !rt_tracer_is(tr, RT_TR_CORES)) {
                rt_cmd_error("sweep", "--cores %d: the %s tracer's work is not split over cores yet (run it with "
                                      "--cores 1)", cores[k], t);
                return RT_EXIT_USAGE;
            }
        for (int k = 0; k < nc; k++)
            if (cores[k] > 1 && rt_tracer_is(tr, RT_TR_CORES) && rt_render_secondary(&o)) {
                rt_cmd_error("sweep", "--cores %d: the %s tracer runs the whitted and path modes on one core", cores[k], t);
                return RT_EXIT_USAGE;
            }
    }
    rt_db *db = rt_db_open(dbpath, &e);
    if (!db) {
        rt_cmd_error("sweep", "%s", e.msg);
        return RT_EXIT_FAIL;
    }
    int status = RT_EXIT_OK;
    char sl[2048];
    snprintf(sl, sizeof sl, "%s", scenes);
    for (char *s1 = NULL, *sn = strtok_r(sl, ",", &s1); sn && status == RT_EXIT_OK; sn = strtok_r(NULL, ",", &s1)) {
        rt_scene *sc = rt_scene_load(sn, &e);
        if (!sc || rt_render_apply_view(&o, sc, &e) < 0) {
            rt_cmd_error("sweep", "%s", e.msg);
            rt_scene_free(sc);
            status = RT_EXIT_FAIL;
            break;
        }
        snprintf(tl, sizeof tl, "%s", tracers);
        for (char *s2 = NULL, *t = strtok_r(tl, ",", &s2); t && status == RT_EXIT_OK; t = strtok_r(NULL, ",", &s2)) {
            rt_job j;
            if (rt_job_setup_borrowed(&j, sc, NULL, t, &o, &e) < 0) {
                rt_cmd_error("sweep", "%s", e.msg);
                status = e.usage ? RT_EXIT_USAGE : RT_EXIT_FAIL;
                break;
            }
            for (int k = 0; k < nc && status == RT_EXIT_OK; k++)
                if (run_one(db, &j, &cfg, cores[k], &e) < 0) {
                    rt_cmd_error("sweep", "%s", e.msg);
                    status = RT_EXIT_FAIL;
                }
            rt_job_free(&j);
        }
        rt_scene_free(sc);
    }
    rt_db_close(db);
    return status;
}
