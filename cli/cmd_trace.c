/* cmd_trace.c -- `raytraffic trace`: render a scene with a tracer and record
 * every modeled memory access into a .rtt trace file. */
#include "cmd.h"
#include "experiment.h"
#include "scene_load.h"
#include "grid.h"
#include "image.h"
#include "run.h"
#include "sindex.h"
#include "trace.h"

#include <errno.h>
#include <inttypes.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>


static void usage(FILE *f)
{
    fprintf(f,
            "Usage: raytraffic trace SCENE [options] -o out.rtt\n\n"
            "Render SCENE (a built-in name like sphereflake, name:k=v,... or an .obj/.ply/.pbrt file)\n"
            "with a tracer and record every modeled memory reference (address, size,\n"
            "read/write, class) into a compressed, self-describing trace file. The file is\n"
            "written to a temporary beside it and renamed when complete; on failure nothing\n"
            "is left.\n"
            "Inspect it with trace-info and trace-dump, replay it with sim.\n\n"
            "Options:\n"
            "  --material M       give every triangle the preset M: diffuse, mirror or glass\n"
            "                     (same as the scene parameter :material=M)\n"
            "  -o FILE            output trace (required)\n"
            "  --level N          zlib level 0..9 (default %d)\n"
            "  --no-sample        write format version 1/2, without the sample index that\n"
            "                     lets `sim --method hybrid` skip the records (about 10%%\n"
            "                     smaller; docs/trace-format.md)\n"
            "  --strict           refuse a scene whose loading warned\n"
            "  --sim              then replay the trace written through `sim` and print its\n"
            "                     tables to stdout (the same as `sim` on the file)\n"
            "  --repl P, --hierarchy SPEC, --sizes LIST, --line N, --assoc full|N\n"
            "                     with --sim: the caches, as `sim` takes them\n",
            RT_TR_DEFAULT_LEVEL);
    rt_cmd_render_help(f, RT_OC_TRACE);
    fprintf(f,
            "                     (trace defaults: -W 512 -H 512, --lights none)\n"
            "  -h, --help         this help\n");
}

enum { OPT_LEVEL = 2000, OPT_NO_SAMPLE, OPT_STRICT, OPT_SIM, OPT_SIMOPT };

#define SIM_MAXARGS (2 * 16 + 3) /* "sim", 16 options with values, the trace, NULL */

int main_trace(int argc, char **argv)
{
    static const struct option own[] = {
        {"output", required_argument, NULL, 'o'},
        {"level", required_argument, NULL, OPT_LEVEL},
        {"no-sample", no_argument, NULL, OPT_NO_SAMPLE},
        {"strict", no_argument, NULL, OPT_STRICT},
        {"material", required_argument, NULL, 'M'},
        {"sim", no_argument, NULL, OPT_SIM},
        {"repl", required_argument, NULL, OPT_SIMOPT},
        {"hierarchy", required_argument, NULL, OPT_SIMOPT},
        {"sizes", required_argument, NULL, OPT_SIMOPT},
        {"line", required_argument, NULL, OPT_SIMOPT},
        {"assoc", required_argument, NULL, OPT_SIMOPT},
        {"help", no_argument, NULL, 'h'},
        {NULL, 0, NULL, 0},
    };
    /* --sim: `sim OPTIONS OUT` once the trace is written */
    char *sargv[SIM_MAXARGS];
    char sopt[16][24];
    int sargc = 1, sim = 0, nsim = 0;
    sargv[0] = "sim";
    rt_render_opts o;
    rt_render_default_opts(&o);
    o.film = RT_FILM_W | RT_FILM_H; /* a pbrt scene's Film sets the size -W/-H do not */
    o.W = o.H = 512;
    o.lights = 0;
    rt_tr_wopts wo;
    rt_si_wopts(&wo);
    const char *material = NULL;
    const char *tracer = "recursive", *out = NULL;
    int c, strict = 0;
    if (argc == 1) {
        usage(stdout);
        return RT_EXIT_OK;
    }
    struct option *lo = rt_cmd_longopts(RT_OC_TRACE, own);
    char so[32];
    if (!lo) return RT_EXIT_FAIL;
    optind = 1;
    int li = -1;
    while ((c = getopt_long(argc, argv, rt_cmd_shortopts(RT_OC_TRACE, "o:h", so, sizeof so), lo, &li)) != -1) {
        int r = rt_cmd_render_opt("trace", c, optarg, &o, &tracer);
        if (r < 0) goto usage_err;
        if (r > 0) continue;
        switch (c) {
        case 'o':
            if (!*optarg) {
                rt_cmd_error("trace", "-o: empty file name");
                goto usage_err;
            }
            out = optarg;
            break;
        case 'M': material = optarg; break;
        case OPT_LEVEL:
            if (strlen(optarg) != 1 || optarg[0] < '0' || optarg[0] > '9') {
                rt_cmd_error("trace", "--level: '%s' is not a zlib level 0..9", optarg);
                goto usage_err;
            }
            wo.level = optarg[0] - '0';
            break;
        case OPT_NO_SAMPLE: wo.payload = NULL; break;
        case OPT_STRICT: strict = 1; break;
        case OPT_SIM: sim = 1; break;
        case OPT_SIMOPT:
            if (nsim == 16) {
                rt_cmd_error("trace", "too many simulator options");
                goto usage_err;
            }
            snprintf(sopt[nsim], sizeof sopt[nsim], "--%s", lo[li].name);
            sargv[sargc++] = sopt[nsim++];
            sargv[sargc++] = optarg;
            break;
        case 'h': usage(stdout); free(lo); return RT_EXIT_OK;
        default: goto usage_err;
        }
    }
    free(lo);
    lo = NULL;
    if (optind != argc - 1) {
        rt_cmd_error("trace", "expected exactly one SCENE (see --help)");
        return RT_EXIT_USAGE;
    }
    const char *scene = argv[optind]; /* before sim's parsing below moves optind */
    if (!out) {
        rt_cmd_error("trace", "missing -o out.rtt");
        return RT_EXIT_USAGE;
    }
    if (nsim && !sim) {
        rt_cmd_error("trace", "%s applies only with --sim", sargv[1]);
        return RT_EXIT_USAGE;
    }
    sargv[sargc++] = (char *)out;
    sargv[sargc] = NULL;
    /* the simulator's options are checked as sim checks them, before tracing */
    if (sim && rt_cmd_sim_check_args(sargc, sargv) < 0) return RT_EXIT_USAGE;

    rt_err e = {0};
    rt_job j;
    rt_image *img = NULL;
    rt_tr_writer *w = NULL;
    rt_run_stats st;
    rt_tr_meta *m = NULL;
    int rc = RT_EXIT_FAIL;
    /* options the tracer does not read, and subsampling that would trace
     * nothing, are usage errors, found before the scene is loaded */
    if (rt_cmd_check_tracer_opts("trace", tracer, &o) < 0) return RT_EXIT_USAGE;
    char specbuf[4200];
    const char *spec = rt_cmd_scene_material("trace", scene, material, specbuf, sizeof specbuf);
    if (!spec) return RT_EXIT_USAGE;
    if (rt_job_setup(&j, spec, tracer, &o, &e) < 0) {
        rt_cmd_error("trace", "%s", e.msg);
        /* options asking too much (an S_VB overflow, a grid over its cell
         * limit: only the scene reveals them) are usage errors */
        return e.usage ? RT_EXIT_USAGE : RT_EXIT_FAIL;
    }
    /* -W and -H both given (no size left to the Film) on a film of another aspect */
    if (!o.film && rt_scene_fit_film(j.sc, j.opt.W, j.opt.H, &e) < 0) {
        rt_cmd_error("trace", "%s", e.msg);
        rt_job_free(&j);
        return RT_EXIT_FAIL;
    }
    if (strict && rt_cmd_strict("trace", j.sc) < 0) {
        rt_job_free(&j);
        return RT_EXIT_FAIL;
    }
    rt_cmd_print_warnings("trace", j.sc);
    o.W = j.opt.W; /* the scene's Film may have set them */
    o.H = j.opt.H;
    rt_scene_fit_aspect(j.sc, o.W, o.H); /* tall images: keep the whole mesh in view */
    if (!(m = rt_calloc(1, sizeof *m, &e))) goto fail;
    rt_job_meta(&j, rt_cmd_line(), m);
    if (m->cores > 1) wo.payload = NULL; /* version 4: simulated cores, no sample index */
    if (!(w = rt_tr_create_opts(out, m, &wo, &e))) goto fail;
    if (!(img = rt_image_new(o.W, o.H, &e))) goto fail;
    double t0 = rt_now();
    if ((m->cores > 1 ? rt_job_run_cores(&j, rt_tr_csink(w), img, &st, &e) : rt_job_run(&j, rt_tr_sink(w), img, &st, &e)) <
        0) {
        if (rt_tr_writer_error(w)[0]) rt_errf(&e, "%s", rt_tr_writer_error(w));
        goto fail;
    }
    rt_tr_totals tot = *rt_tr_writer_totals(w);
    tot.nchunks = (tot.nrefs + wo.chunk_records - 1) / wo.chunk_records; /* incl. the last, partial one */
    rt_tr_writer *wf = w;
    w = NULL;
    int frc = rt_tr_finish(wf, &e);
    if (frc < 0) goto fail;
    double sec = rt_now() - t0;
    struct stat sb;
    uint64_t fbytes = stat(out, &sb) == 0 ? (uint64_t)sb.st_size : 0;
    uint64_t bytes = 0;
    for (int k = 0; k < RT_NCLASS; k++) bytes += tot.bytes[k];
    fprintf(stderr, "wrote %s: %" PRIu64 " references (%" PRIu64 " bytes referenced) in %" PRIu64
                    " chunks, %" PRIu64 " bytes on disk, %.3f bytes/reference\n",
            out, tot.nrefs, bytes, tot.nchunks, fbytes, tot.nrefs ? (double)fbytes / (double)tot.nrefs : 0.0);
    char ln[48];
    fprintf(stderr, "scene %s (%" PRIu32 " triangles), tracer %s, %dx%d, lights %s; %" PRIu64 " primary + %" PRIu64
                    " shadow rays; traced in %.2f s (%.1f M references/s)\n",
            j.sc->name, rt_scene_nflat(j.sc), j.tr->name, o.W, o.H, rt_exp_lights_name(o.lights, ln, sizeof ln),
            st.rays_primary, st.rays_shadow, sec,
            sec > 0 ? (double)tot.nrefs / sec * 1e-6 : 0.0);
    rc = RT_EXIT_OK;
    if (sim) {
        fflush(stderr);
        rc = main_sim(sargc, sargv); /* the same tables as `sim` on the file */
    }
    goto done;
fail:
    rt_cmd_error("trace", "%s", e.msg);
done:
    rt_tr_abort(w);
    rt_image_free(img);
    free(m);
    rt_job_free(&j);
    return rc;
usage_err:
    free(lo);
    return RT_EXIT_USAGE;
}
