/* cmd_render.c -- `raytraffic render`: render a scene with a tracer to an
 * OpenEXR image (RGB + cost channels + depth) and print render statistics. */
#include "cmd.h"
#include "scene_load.h"
#include "outfile.h"
#include "grid.h"
#include "feedback.h"
#include "image.h"
#include "run.h"
#include "stats.h"

#include <inttypes.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>


static void usage(FILE *f)
{
    fprintf(f,
            "Usage: raytraffic render SCENE [options] -o out.exr\n\n"
            "Render SCENE (a built-in name like sphereflake, name:k=v,... or an .obj/.ply/.pbrt file)\n"
            "and write a float OpenEXR with channels R, G, B, Z (depth), nodes and tests\n"
            "(per-pixel k-d nodes visited and triangles tested).\n\n"
            "Options:\n"
            "  --material M       give every triangle the preset M: diffuse, mirror or glass\n"
            "                     (same as the scene parameter :material=M)\n"
            "  -o FILE            output EXR (required)\n"
            "  --png FILE         also write an 8-bit gamma-2.2 preview PNG\n"
            "  --heatmap FILE     also write the triangle tests per pixel as a heat-map PNG\n"
            "                     (log scale up to 4 x triangles: grid and naive comparable)\n"
            "  --ppm FILE         same as a binary PPM\n"
            "  --json             print statistics as JSON on stdout (with the scene's warnings)\n"
            "  --strict           refuse a scene whose loading warned (a skipped or\n"
            "                     approximated feature)\n");
    rt_cmd_render_help(f, RT_OC_RENDER);
    fprintf(f,
            "  -h, --help         this help\n\n"
            "Statistics (stderr, or JSON): rays traced, nodes visited and triangles tested\n"
            "per ray, and the distinct triangles tested by primary rays and by all rays\n"
            "(the paper's potentially visible geometry).\n");
}

void rt_print_run_stats(FILE *f, const rt_job *j, const rt_run_stats *st, int json);

void rt_print_run_stats(FILE *f, const rt_job *j, const rt_run_stats *st, int json)
{
    uint64_t rays = st->rays_primary + st->rays_shadow;
    double per = rays ? 1.0 / (double)rays : 0;
    if (json) {
        /* names and the statistics string come from files: escaped */
        fputs("{\"scene\": ", f);
        rt_cmd_json_str(f, j->sc->name);
        fprintf(f,
                ", \"tracer\": \"%s\", \"width\": %d, \"height\": %d, \"lights\": %u, "
                "\"triangles\": %" PRIu32 ", \"rays_primary\": %" PRIu64 ", \"rays_shadow\": %" PRIu64
                ", \"nodes\": %" PRIu64 ", \"tests\": %" PRIu64 ", \"nodes_per_ray\": %.3f, \"tests_per_ray\": %.3f"
                ", \"pv_primary\": %" PRIu64 ", \"pv_all\": %" PRIu64 ", \"%s_build_seconds\": %.3f"
                ", \"render_seconds\": %.3f, \"mrays_per_second\": %.3f",
                j->tr->name, j->opt.W, j->opt.H, j->opt.lights, rt_scene_nflat(j->sc), st->rays_primary, st->rays_shadow,
                st->nodes, st->tests, (double)st->nodes * per, (double)st->tests * per, st->pv_primary, st->pv_all,
                rt_accel_name(j->acc.kind), j->acc.build_sec, st->seconds,
                st->seconds > 0 ? (double)rays / st->seconds * 1e-6 : 0.0);
        rt_accel_info ai;
        rt_accel_info_of(&j->acc, &ai);
        fprintf(f, ", \"accel\": \"%s\", \"accel_nodes\": %" PRIu64 ", \"accel_bytes\": %" PRIu64 ", \"accel_depth\": %" PRIu32,
                rt_accel_name(j->acc.kind), ai.nodes, ai.bytes, ai.depth);
        /* the tracer's statistics as an object; "extra" (the same as the
         * old k=v string) is kept one release for older readers */
        char obj[4096];
        rt_err se;
        if (rt_stats_json(st->extra, obj, sizeof obj, &se) == 0) fprintf(f, ", \"stats\": %s", obj);
        else fputs(", \"stats\": null", f);
        if (st->extra[0]) {
            fputs(", \"extra\": ", f);
            rt_cmd_json_str(f, st->extra);
        }
        fputs(", ", f);
        rt_cmd_json_warnings(f, j->sc);
        fputs("}\n", f);
        return;
    }
    fprintf(f, "scene %s (%" PRIu32 " triangles), tracer %s, %dx%d, lights %u\n", j->sc->name, rt_scene_nflat(j->sc),
            j->tr->name, j->opt.W, j->opt.H, j->opt.lights);
    fprintf(f, "rays: %" PRIu64 " primary + %" PRIu64 " shadow; per ray %.2f nodes, %.2f triangle tests\n",
            st->rays_primary, st->rays_shadow, (double)st->nodes * per, (double)st->tests * per);
    fprintf(f, "potentially visible triangles: %" PRIu64 " primary, %" PRIu64 " primary+shadow\n", st->pv_primary,
            st->pv_all);
    fprintf(f, "%s build %.2f s, render %.2f s (%.2f Mrays/s)\n", j->acc.kind == RT_ACCEL_KD ? "k-d" : rt_accel_name(j->acc.kind),
            j->acc.build_sec, st->seconds,
            st->seconds > 0 ? (double)rays / st->seconds * 1e-6 : 0.0);
    if (st->extra[0]) fprintf(f, "%s\n", st->extra);
}

int main_render(int argc, char **argv)
{
    static const struct option own[] = {
        {"output", required_argument, NULL, 'o'},
        {"ppm", required_argument, NULL, 'p'},
        {"png", required_argument, NULL, 'g'},
        {"json", no_argument, NULL, 'j'},
        {"strict", no_argument, NULL, 'S'},
        {"material", required_argument, NULL, 'M'},
        {"heatmap", required_argument, NULL, 'K'},
        {"help", no_argument, NULL, 'h'},
        {NULL, 0, NULL, 0},
    };
    rt_render_opts o;
    rt_render_default_opts(&o);
    o.film = RT_FILM_W | RT_FILM_H; /* a pbrt scene's Film sets the size -W/-H do not */
    const char *material = NULL;
    const char *tracer = "recursive", *out = NULL, *ppm = NULL, *png = NULL, *heat = NULL;
    int json = 0, strict = 0, c, rc = RT_EXIT_FAIL;
    struct option *lo = rt_cmd_longopts(RT_OC_RENDER, own);
    char so[32];
    if (!lo) return RT_EXIT_FAIL;
    optind = 1;
    while ((c = getopt_long(argc, argv, rt_cmd_shortopts(RT_OC_RENDER, "o:h", so, sizeof so), lo, NULL)) != -1) {
        int r = rt_cmd_render_opt("render", c, optarg, &o, &tracer);
        if (r < 0) goto usage_err;
        if (r > 0) continue;
        switch (c) {
        case 'o':
            if (!*optarg) {
                rt_cmd_error("render", "-o: empty file name");
                goto usage_err;
            }
            out = optarg;
            break;
        case 'M': material = optarg; break;
        case 'p': ppm = optarg; break;
        case 'g': png = optarg; break;
        case 'K': heat = optarg; break;
        case 'j': json = 1; break;
        case 'S': strict = 1; break;
        case 'h': usage(stdout); free(lo); return RT_EXIT_OK;
        default: goto usage_err;
        }
    }
    free(lo);
    lo = NULL;
    if (optind != argc - 1) {
        rt_cmd_error("render", "expected exactly one SCENE (see --help)");
        return RT_EXIT_USAGE;
    }
    if (!out) {
        rt_cmd_error("render", "missing -o out.exr");
        return RT_EXIT_USAGE;
    }
    rt_err e = {0};
    rt_job j;
    rt_image *img = NULL;
    rt_run_stats st;
    /* options the tracer does not read, and subsampling that would trace
     * nothing, are usage errors, found before the scene is loaded */
    if (rt_cmd_check_tracer_opts("render", tracer, &o) < 0) return RT_EXIT_USAGE;
    /* every output writable before anything is rendered or written */
    const char *outs[4] = {out, ppm, png, heat};
    for (int k = 0; k < 4; k++)
        if (outs[k] && rt_out_probe(outs[k], &e) < 0) {
            rt_cmd_error("render", "%s", e.msg);
            return RT_EXIT_FAIL;
        }
    char specbuf[4200];
    const char *spec = rt_cmd_scene_material("render", argv[optind], material, specbuf, sizeof specbuf);
    if (!spec) return RT_EXIT_USAGE;
    if (rt_job_setup(&j, spec, tracer, &o, &e) < 0) {
        rt_cmd_error("render", "%s", e.msg);
        /* options asking too much (an S_VB overflow, a grid over its cell
         * limit: only the scene reveals them) are usage errors */
        return e.usage ? RT_EXIT_USAGE : RT_EXIT_FAIL;
    }
    /* -W and -H both given (no size left to the Film) on a film of another aspect */
    if (!o.film && rt_scene_fit_film(j.sc, j.opt.W, j.opt.H, &e) < 0) {
        rt_cmd_error("render", "%s", e.msg);
        rt_job_free(&j);
        return RT_EXIT_FAIL;
    }
    if (strict && rt_cmd_strict("render", j.sc) < 0) {
        rt_job_free(&j);
        return RT_EXIT_FAIL;
    }
    rt_cmd_print_warnings("render", j.sc);
    o.W = j.opt.W; /* the scene's Film may have set them */
    o.H = j.opt.H;
    rt_scene_fit_aspect(j.sc, o.W, o.H); /* tall images: keep the whole mesh in view */
    if (!(img = rt_image_new(o.W, o.H, &e)) || rt_job_run(&j, NULL, img, &st, &e) < 0) goto fail;
    char hash[32], params[128];
    snprintf(hash, sizeof hash, "%016llx", (unsigned long long)rt_scene_hash(j.sc));
    snprintf(params, sizeof params, "W=%d H=%d lights=%u", o.W, o.H, o.lights);
    rt_exr_attr attrs[] = {
        {"raytraffic:version", rt_version()}, {"raytraffic:git", rt_git_rev()},
        {"raytraffic:command", rt_cmd_line()}, {"raytraffic:scene", j.sc->name},
        {"raytraffic:scene_hash", hash},     {"raytraffic:tracer", j.tr->name},
        {"raytraffic:params", params},
    };
    if (rt_exr_write(out, img, attrs, (int)(sizeof attrs / sizeof attrs[0]), &e) < 0) goto fail;
    if (ppm && rt_ppm_write(ppm, img, &e) < 0) goto fail;
    if (png && rt_png_write(png, img, &e) < 0) goto fail;
    if (heat) {
        unsigned char *rgb = rt_calloc((size_t)o.W * (size_t)o.H, 3, &e);
        if (!rgb) goto fail;
        rt_fb_heatmap(img, j.sc->ntri, rgb);
        int hr = rt_png_write_rgb8(heat, o.W, o.H, rgb, &e);
        free(rgb);
        if (hr < 0) goto fail;
    }
    rt_print_run_stats(json ? stdout : stderr, &j, &st, json);
    fprintf(stderr, "wrote %s\n", out);
    rc = RT_EXIT_OK;
    goto done;
fail:
    rt_cmd_error("render", "%s", e.msg);
done:
    rt_image_free(img);
    rt_job_free(&j);
    return rc;
usage_err:
    free(lo);
    return RT_EXIT_USAGE;
}
