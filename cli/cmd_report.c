/*
 * cmd_report.c -- `raytraffic report`: the paper's tables, the comparison
 * with the paper, speed against error and plots, from the database.
 *
 * Only the command line lives here: the tables and plots are computed by
 * analysis/ (analysis.h), which writes to stdout through the FILE * it is
 * given and returns errors that this file prints. The database is opened
 * read-only.
 *
 * One rule for every figure: what is to be shown is written to a
 * temporary stream first and copied to stdout only when the whole report
 * succeeded, so a report with nothing to show (no runs, no run of the
 * figure's scene, no approximate run) or one that fails half-way prints
 * one line on stderr, exits 1 and writes nothing on stdout.
 */
#include "analysis.h"
#include "experiment.h"
#include "cmd.h"

#include <stdio.h>
#include <stdlib.h>
#include <errno.h>
#include <string.h>

static void usage(FILE *f)
{
    fprintf(f,
            "Usage: raytraffic report [options]\n\n"
            "Prints the paper's tables (Figures 3-9) from a results database.\n\n"
            "Options:\n"
            "  --db FILE          results database (default raytraffic.db)\n"
            "  --figure F         4|5|6 (primary), 7|8|9 (shadows), scenes, or all (default all);\n"
            "                     secondary: dynamic vs recursive per ray generation (whitted,\n"
            "                     path runs), with --plot one picture per scene and mode;\n"
            "                     purcell: stream-* runs beside Purcell et al. 2002 (Figure 6,\n"
            "                     Table 2, Figures 7-9; with --plot their stacked bars)\n"
            "                     feedback: feedback runs' traffic per class and ray-state\n"
            "                     bytes per ray beside dynamic and stream-multipass (--plot)\n"
            "                     accel: the structures of each tracer side by side: footprint,\n"
            "                     nodes and tests per ray, geometry traffic per cache size\n"
            "                     (runs of sweep --accels; --plot: traffic against cache size)\n"
            "                     instances: --instances bvh runs beside the same tracer on the\n"
            "                     flattened scene, geometry traffic per level (tlas, inst, blas)\n"
            "                     and cache size\n"
            "                     treelet: treelet vs recursive on the BVH, dynamic vs recursive\n"
            "                     on the k-d tree, traffic split geometry/ray/stack/queue (--plot)\n"
            "                     cores: DRAM traffic and shared-level miss rate against the\n"
            "                     core count of multi-core runs (sim --hierarchy --db), each\n"
            "                     tracer's reduction against recursive (--plot)\n"
            "  --scene NAME       only this scene (figures 4-9 map room, grove, sphereflake)\n"
            "  --format md|csv|json  Markdown tables (default); for figures 4-9 (and all),\n"
            "                     csv and json write tidy tables: one row per run x cache size\n"
            "                     x class, every configuration column, bytes in full precision,\n"
            "                     one table per figure (csv on stdout only for one --figure N;\n"
            "                     json: one object holding them all); other figures: csv\n"
            "  --out DIR          with --format csv|json: one file per table in DIR\n"
            "                     (figureN-SCENE, primary-SCENE / shadows-SCENE for other\n"
            "                     scenes, scenes.csv; other figures FIGURE-N-TITLE.csv)\n"
            "  -W N, -H N         resolution to report (default: the largest in the database)\n"
            "  --total            figures 7-9 on total instead of geometry traffic\n"
            "  --compare-paper    our values beside the paper's, with ratios and findings, and\n"
            "                     (with --model, or when the database holds --model paper runs)\n"
            "                     the agreement table per scene and model; with --figure\n"
            "                     purcell: ours / paper (ratio) per cell and an agreement\n"
            "                     line per figure\n"
            "  --model M          only runs of model M (lean, paper; see sweep --help)\n"
            "  --layout L         with --model: that model's runs in layout L (compact, mesh,\n"
            "                     pbrt, pbrt64) instead of the model's own\n"
            "  --plot DIR         traffic-vs-cache-size plots (PNG, SVG; gnuplot) and scenes.png\n"
            "  --speed-error      speed against error of approximate simulation and reduced\n"
            "                     experiments, with the standard errors of hybrid runs\n"
            "  --appendix         the diagnostics appendix (the same as --speed-error; run.sh\n"
            "                     writes it to appendix.md, beside report.md)\n"
            "  -h, --help         this help\n");
}

int main_report(int argc, char **argv)
{
    static const struct option lo[] = {
        {"db", required_argument, NULL, 'd'},       {"figure", required_argument, NULL, 'f'},
        {"scene", required_argument, NULL, 's'},    {"format", required_argument, NULL, 'F'},
        {"total", no_argument, NULL, 't'},          {"compare-paper", no_argument, NULL, 'c'},
        {"plot", required_argument, NULL, 'p'},     {"speed-error", no_argument, NULL, 'e'},
        {"width", required_argument, NULL, 'W'},    {"height", required_argument, NULL, 'H'},
        {"model", required_argument, NULL, 'm'},    {"layout", required_argument, NULL, 'L'},
        {"appendix", no_argument, NULL, 'A'},      {"out", required_argument, NULL, 'o'},
        {"help", no_argument, NULL, 'h'},           {NULL, 0, NULL, 0},
    };
    rt_report_opts o = {0};
    const char *dbpath = "raytraffic.db", *figure = "all", *plotdir = NULL, *outdir = NULL;
    int json = 0;
    int compare = 0, speed = 0, c;
    optind = 1;
    while ((c = getopt_long(argc, argv, "hW:H:", lo, NULL)) != -1) {
        switch (c) {
        case 'd': dbpath = optarg; break;
        case 'f':
            if (strcmp(optarg, "all") && strcmp(optarg, "scenes") && strcmp(optarg, "secondary") && strcmp(optarg, "purcell") && strcmp(optarg, "feedback") &&
                strcmp(optarg, "accel") && strcmp(optarg, "treelet") && strcmp(optarg, "hierarchy") && strcmp(optarg, "cores") &&
                strcmp(optarg, "instances") &&
                !(strlen(optarg) == 1 && optarg[0] >= '4' && optarg[0] <= '9')) {
                rt_cmd_error("report", "--figure: '%s' is not 4..9, scenes, secondary, purcell, feedback, accel, instances, treelet, hierarchy, cores or all", optarg);
                return RT_EXIT_USAGE;
            }
            figure = optarg;
            break;
        case 's': o.scene = optarg; break;
        case 'm':
            if (rt_exp_model_find(optarg) < 0) {
                rt_cmd_error("report", "--model: '%s' is not lean or paper", optarg);
                return RT_EXIT_USAGE;
            }
            o.model = optarg;
            break;
        case 'L':
            if (rt_render_geom_from_name(optarg) < 0) {
                rt_cmd_error("report", "--layout: '%s' is not compact, mesh, pbrt or pbrt64", optarg);
                return RT_EXIT_USAGE;
            }
            o.layout = optarg;
            break;
        case 'F':
            if (!strcmp(optarg, "csv")) o.csv = 1;
            else if (!strcmp(optarg, "json")) json = 1;
            else if (strcmp(optarg, "md")) {
                rt_cmd_error("report", "--format: '%s' is not md, csv or json", optarg);
                return RT_EXIT_USAGE;
            }
            break;
        case 't': o.total = 1; break;
        case 'c': compare = 1; break;
        case 'p': plotdir = optarg; break;
        case 'e': speed = 1; break;
        case 'A': speed = 1; break;
        case 'o': outdir = optarg; break;
        case 'W':
        case 'H': {
            long v;
            if (rt_cmd_parse_long(optarg, 1, 65536, &v) < 0) {
                rt_cmd_error("report", "-%c: '%s' is not an image size in 1..65536", c, optarg);
                return RT_EXIT_USAGE;
            }
            if (c == 'W') o.W = (int)v; else o.H = (int)v;
            break;
        }
        case 'h': usage(stdout); return RT_EXIT_OK;
        default: return RT_EXIT_USAGE;
        }
    }
    if (optind != argc) {
        rt_cmd_error("report", "unexpected argument '%s'", argv[optind]);
        return RT_EXIT_USAGE;
    }
    int tidy = (o.csv || json) && !speed && (!strcmp(figure, "all") || (strlen(figure) == 1 && figure[0] >= '4'));
    if (json && !tidy) {
        rt_cmd_error("report", "--format json: only figures 4-9 (and all) have tidy tables");
        return RT_EXIT_USAGE;
    }
    if (outdir && !o.csv && !json) {
        rt_cmd_error("report", "--out needs --format csv or json");
        return RT_EXIT_USAGE;
    }
    if (tidy && !json && !outdir && !strcmp(figure, "all")) {
        rt_cmd_error("report", "--format csv writes one table per figure: give --out DIR for all of them, or --figure N "
                               "for one on stdout");
        return RT_EXIT_USAGE;
    }
    if (o.layout && !o.model) {
        rt_cmd_error("report", "--layout needs --model");
        return RT_EXIT_USAGE;
    }
    /* --figure N --compare-paper: the comparison of that figure's scene
     * only (4/7 room, 5/8 grove, 6/9 sphereflake) */
    static const char *const fig_scene[3] = {"room", "grove", "sphereflake"};
    if (compare && !o.scene && strlen(figure) == 1 && figure[0] >= '4' && figure[0] <= '9')
        o.scene = fig_scene[(figure[0] - '4') % 3];
    rt_err e = {0};
    sqlite3 *h;
    if (rt_report_db_open(dbpath, &h, &e) < 0) {
        rt_cmd_error("report", "%s", e.msg);
        return e.usage ? RT_EXIT_USAGE : RT_EXIT_FAIL;
    }
    char gp[4096];
    rt_plot_opts po = {plotdir, NULL, stderr};
    if (plotdir) {
        if (rt_plot_find_gnuplot(gp, sizeof gp) == 0) po.gnuplot = gp;
        else
            rt_cmd_error("report", "gnuplot not found (apt-get install gnuplot-nox): writing data files only, no plots");
    }
    rt_report R;
    FILE *out = tmpfile();
    if (!out) {
        rt_cmd_error("report", "cannot make a temporary file for the report");
        sqlite3_close(h);
        return RT_EXIT_FAIL;
    }
    int rc = rt_report_init(&R, h, dbpath, &o, &e);
    if (rc == 0 && speed) {
        rc = rt_report_speed_error(h, o.csv, plotdir ? &po : NULL, out, &e);
    } else if (rc == 0 && !strcmp(figure, "purcell")) {
        rc = rt_report_purcell(h, o.scene, o.csv, compare, plotdir ? &po : NULL, out, &e);
    } else if (rc == 0 && !strcmp(figure, "feedback")) {
        rc = rt_report_feedback(h, o.scene, o.csv, plotdir ? &po : NULL, out, &e);
    } else if (rc == 0 && !strcmp(figure, "accel")) {
        rc = rt_report_accel(h, o.scene, o.csv, plotdir ? &po : NULL, out, &e);
    } else if (rc == 0 && !strcmp(figure, "instances")) {
        rc = rt_report_instances(h, o.scene, o.csv, out, &e);
    } else if (rc == 0 && !strcmp(figure, "hierarchy")) {
        rc = rt_report_hierarchy(h, o.scene, out, &e);
    } else if (rc == 0 && !strcmp(figure, "treelet")) {
        rc = rt_report_treelet(h, dbpath, o.scene, o.csv, plotdir ? &po : NULL, out, &e);
    } else if (rc == 0 && !strcmp(figure, "cores")) {
        rc = rt_report_cores(h, dbpath, o.scene, o.csv, plotdir ? &po : NULL, out, &e);
    } else if (rc == 0 && !strcmp(figure, "secondary")) {
        rc = rt_report_secondary(h, dbpath, o.csv, plotdir ? &po : NULL, out, &e);
    } else if (rc == 0 && !R.nscenes) {
        snprintf(e.msg, sizeof e.msg, "%s: no runs%s", dbpath, o.scene ? " for that scene" : "");
        rc = -1;
    } else if (rc == 0 && tidy) {
        rc = rt_report_tidy(&R, figure, json, outdir, stderr, out, &e);
    } else if (rc == 0) {
        rc = rt_report_tables(&R, figure, out, &e);
        if (rc == 0 && compare) rc = rt_report_compare_paper(&R, out, &e);
        if (rc == 0 && plotdir) rc = rt_plot_traffic(&R, &po, &e);
        if (rc == 0 && plotdir) rc = rt_plot_scenes(&R, &po, &e);
    }
    /* another figure's CSV tables, one file each (tidy ones wrote theirs) */
    if (rc == 0 && outdir && !tidy) rc = rt_report_csv_split(out, outdir, speed ? "speed-error" : figure, stderr, &e);
    /* the report reaches stdout whole, or not at all */
    else if (rc == 0) {
        char buf[65536];
        size_t n;
        int err = 0;
        rewind(out);
        errno = 0;
        while ((n = fread(buf, 1, sizeof buf, out)) > 0)
            if (fwrite(buf, 1, n, stdout) != n) {
                err = errno;
                break;
            }
        if (!err && fflush(stdout) != 0) err = errno;
        if (err || ferror(out) || ferror(stdout)) {
            snprintf(e.msg, sizeof e.msg, "write error: %s", err ? strerror(err) : "the standard output");
            clearerr(stdout); /* said once, here: not again at exit */
            rc = -1;
        }
    }
    fclose(out);
    if (rc < 0) rt_cmd_error("report", "%s", e.msg);
    rt_report_free(&R);
    sqlite3_close(h);
    return rc < 0 ? RT_EXIT_FAIL : RT_EXIT_OK;
}
