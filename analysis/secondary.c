/*
 * secondary.c -- `report --figure secondary`: is scheduling worth it for
 * incoherent rays? Dynamic against recursive order, per ray generation.
 *
 * Navratil et al. (2007, section 2.1.2 and the conclusion) claim that the
 * dynamic scheduler keeps beating recursive order once rays are secondary.
 * The whitted and path runs of a sweep store their traffic per generation
 * (table traffic_gen, view v_gen); this report pairs, for every scene,
 * mode (with its depth / spp / bounces), lighting, resolution, cache size
 * and generation, the recursive run with the dynamic run scheduled for that
 * size, and prints the paper's reduction (rt_report_reduction: 100 (base /
 * dyn - 1), negative when dynamic moves more) for geometry and for total
 * traffic. Per scene one sentence says at how many (mode, size) points
 * dynamic moves less geometry and less total traffic than recursive over
 * the secondary generations (generations >= 1 summed), which is the claim
 * tested on our model. With a plot folder, one picture per (scene, mode,
 * lighting): reduction against cache size, a line per generation.
 */
#include "analysis_int.h"
#include "experiment.h"

#include <errno.h>
#include <inttypes.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#define MAXG 8 /* generation buckets (RT_MAXGEN) */

/* One (scene, mode, lighting, resolution, size) point: MB per generation. */
typedef struct point {
    char scene[300], mode[16], params[160];
    int lights, W, H;
    uint64_t size;
    int ngen;                          /* generations present (max gen + 1) */
    double geo[2][MAXG], tot[2][MAXG]; /* [recursive, dynamic][gen] */
    int has[2][MAXG];
} point;

/* The mode's own parameters out of a recursive run's params ("mode=..."
 * onward): what tells two sweeps of one mode apart. */
static void mode_params(const char *params, char *out, size_t n)
{
    const char *m = strstr(params, "mode=");
    snprintf(out, n, "%s", m ? m : params);
}

/* Reads every paired point; *pts malloc'd. The count, or -1. */
static long read_points(sqlite3 *h, const char *dbpath, point **pts, rt_err *e)
{
    /* recursive rows and the dynamic rows scheduled for the size they are
     * simulated at, of the same scene, mode (parameters included: the
     * recursive run's params are the dynamic run's tail), lights and size */
    static const char sql[] =
        "SELECT b.scene, b.mode, b.params, b.lights, b.W, b.H, b.cache_size, b.gen, b.geometry_mb, b.total_mb,"
        " d.geometry_mb, d.total_mb FROM v_gen b JOIN v_gen d ON d.scene = b.scene AND d.mode = b.mode"
        " AND d.lights = b.lights AND d.W = b.W AND d.H = b.H AND d.cache_size = b.cache_size AND d.gen = b.gen"
        " AND d.tracer = 'dynamic' AND d.sched_size = d.cache_size AND instr(d.params, b.params) > 0"
        " AND d.params NOT LIKE '%sim=all-sizes%'"
        " WHERE b.tracer = 'recursive' AND b.mode IN ('whitted', 'path')"
        " ORDER BY CASE b.scene WHEN 'cornell' THEN 0 WHEN 'sphereflake' THEN 1 WHEN 'knot' THEN 2 ELSE 3 END,"
        " b.scene, b.mode DESC, b.params, b.lights, b.W, b.cache_size, b.gen";
    sqlite3_stmt *st = rt_report_stmt(h, sql, dbpath, e, "");
    if (!st) return -1;
    long n = 0, cap = 0;
    point *P = NULL;
    int rc;
    while ((rc = sqlite3_step(st)) == SQLITE_ROW) {
        char scene[300], mode[16], params[160];
        rt_name_fit(scene, sizeof scene, (const char *)sqlite3_column_text(st, 0));
        snprintf(mode, sizeof mode, "%s", (const char *)sqlite3_column_text(st, 1));
        mode_params((const char *)sqlite3_column_text(st, 2), params, sizeof params);
        int lights = sqlite3_column_int(st, 3), W = sqlite3_column_int(st, 4), H = sqlite3_column_int(st, 5);
        uint64_t size = (uint64_t)sqlite3_column_int64(st, 6);
        int g = sqlite3_column_int(st, 7);
        if (g < 0 || g >= MAXG) continue;
        point *p = n ? &P[n - 1] : NULL;
        if (!p || strcmp(p->scene, scene) || strcmp(p->mode, mode) || strcmp(p->params, params) ||
            p->lights != lights || p->W != W || p->H != H || p->size != size) {
            if (n == cap) {
                cap = cap ? 2 * cap : 64;
                point *q = rt_reallocarray(P, (size_t)cap, sizeof *P, e);
                if (!q) {
                    free(P);
                    sqlite3_finalize(st);
                    return -1;
                }
                P = q;
            }
            p = &P[n++];
            memset(p, 0, sizeof *p);
            snprintf(p->scene, sizeof p->scene, "%s", scene);
            snprintf(p->mode, sizeof p->mode, "%s", mode);
            snprintf(p->params, sizeof p->params, "%s", params);
            p->lights = lights, p->W = W, p->H = H, p->size = size;
        }
        for (int t = 0; t < 2; t++) {
            p->geo[t][g] = sqlite3_column_double(st, 8 + 2 * t);
            p->tot[t][g] = sqlite3_column_double(st, 9 + 2 * t);
            p->has[t][g] = 1;
        }
        if (g + 1 > p->ngen) p->ngen = g + 1;
    }
    if (rt_report_done(st, rc, dbpath, e) < 0) {
        free(P);
        return -1;
    }
    *pts = P;
    return n;
}

/* Sum over generations >= 1 of recursive (t 0) or dynamic (t 1). */
static double secondary_sum(const point *p, int t, int total)
{
    double s = 0;
    for (int g = 1; g < p->ngen; g++) s += total ? p->tot[t][g] : p->geo[t][g];
    return s;
}

static int same_group(const point *a, const point *b)
{
    return !strcmp(a->scene, b->scene) && !strcmp(a->mode, b->mode) && !strcmp(a->params, b->params) &&
           a->lights == b->lights && a->W == b->W && a->H == b->H;
}

static void print_pct(FILE *out, int csv, double v)
{
    char b[64];
    rt_report_fmt_reduction(v, csv, b, sizeof b);
    if (csv) fprintf(out, ",%s", b);
    else fprintf(out, " %s |", b);
}

/* The tables of points [a, b) (one scene, mode, lighting, resolution). */
static void group_table(FILE *out, int csv, const point *P, long a, long b)
{
    int ng = 0;
    for (long i = a; i < b; i++)
        if (P[i].ngen > ng) ng = P[i].ngen;
    if (!csv) {
        char ln[48];
        fprintf(out, "\n### %s, %s (%s), lights %s, %dx%d\n\n", P[a].scene, P[a].mode, P[a].params,
                rt_exp_lights_name((unsigned)P[a].lights, ln, sizeof ln), P[a].W, P[a].H);
        fprintf(out, "Reduction of dynamic vs recursive (base / dyn - 1): geometry | total traffic, per generation.\n\n");
        fprintf(out, "| cache |");
        for (int g = 0; g < ng; g++) fprintf(out, " g%d geom | g%d total |", g, g);
        fprintf(out, " g>=1 geom | g>=1 total |\n|---:|");
        for (int g = 0; g <= ng; g++) fprintf(out, "---:|---:|");
        fprintf(out, "\n");
    }
    for (long i = a; i < b; i++) {
        const point *p = &P[i];
        if (csv) fprintf(out, "%s,%s,\"%s\",%d,%d,%d,%" PRIu64, p->scene, p->mode, p->params, p->lights, p->W, p->H,
                         p->size);
        else fprintf(out, "| %" PRIu64 "K |", p->size / 1024);
        for (int g = 0; g < ng; g++) {
            int ok = p->has[0][g] && p->has[1][g];
            print_pct(out, csv, ok ? rt_report_reduction(p->geo[0][g], p->geo[1][g]) : NAN);
            print_pct(out, csv, ok ? rt_report_reduction(p->tot[0][g], p->tot[1][g]) : NAN);
        }
        for (int g = ng; csv && g < MAXG; g++) fprintf(out, ",,");
        print_pct(out, csv, rt_report_reduction(secondary_sum(p, 0, 0), secondary_sum(p, 1, 0)));
        print_pct(out, csv, rt_report_reduction(secondary_sum(p, 0, 1), secondary_sum(p, 1, 1)));
        fprintf(out, "\n");
    }
}

/* One sentence per scene over its points [a, b): the claim on our model. */
static void scene_sentence(FILE *out, const point *P, long a, long b)
{
    int m = 0, geo = 0, tot = 0, g0 = 0;
    for (long i = a; i < b; i++) {
        if (P[i].ngen < 2) continue;
        m++;
        geo += secondary_sum(&P[i], 1, 0) < secondary_sum(&P[i], 0, 0);
        tot += secondary_sum(&P[i], 1, 1) < secondary_sum(&P[i], 0, 1);
        g0 += P[i].geo[1][0] < P[i].geo[0][0];
    }
    const char *verdict = !m ? "cannot be tested (no secondary generation)"
                          : 2 * geo > m && 2 * tot > m ? "holds"
                          : 2 * geo > m ? "holds for geometry only"
                                        : "does not hold";
    fprintf(out,
            "- **%s**: dynamic moves less geometry than recursive in generations >= 1 at %d of %d (mode, lighting, "
            "size) points, less total traffic at %d of %d (generation 0: less geometry at %d of %d); the claim %s on "
            "our model.\n",
            P[a].scene, geo, m, tot, m, g0, m, verdict);
}

/* DIR/secondary-SCENE-MODE-lLIGHTS-WxH.{dat,gp,png}: data, script, picture. */
static int group_plot(const rt_plot_opts *po, const point *P, long a, long b, rt_err *e)
{
    char base[4096], dat[4200], gpf[4200], png[4200];
    char tail[600];
    snprintf(tail, sizeof tail, "%s-%s-l%d-%dx%d", P[a].scene, P[a].mode, P[a].lights, P[a].W, P[a].H);
    rt_plot_path(base, sizeof base, po->dir, "secondary-", tail, "");
    snprintf(dat, sizeof dat, "%s.dat", base);
    snprintf(gpf, sizeof gpf, "%s.gp", base);
    snprintf(png, sizeof png, "%s.png", base);
    int ng = 0;
    for (long i = a; i < b; i++)
        if (P[i].ngen > ng) ng = P[i].ngen;
    rt_out *o;
    FILE *f = rt_plot_open(dat, &o, e);
    if (!f) return -1;
    fprintf(f, "# cache_kb then per generation: geometry reduction %%, total reduction %%\n");
    for (long i = a; i < b; i++) {
        fprintf(f, "%" PRIu64, P[i].size / 1024);
        for (int g = 0; g < ng; g++) {
            double r[2] = {rt_report_reduction(P[i].geo[0][g], P[i].geo[1][g]),
                           rt_report_reduction(P[i].tot[0][g], P[i].tot[1][g])};
            for (int t = 0; t < 2; t++)
                if (isnan(r[t])) fprintf(f, " NaN");
                else fprintf(f, " %.4g", r[t]);
        }
        fprintf(f, "\n");
    }
    if (rt_plot_commit(o, e) < 0) return -1;
    if (!(f = rt_plot_open(gpf, &o, e))) return -1;
    char title[900];
    char ln[48];
    snprintf(title, sizeof title, "%s, %s (%s), lights %s, %dx%d: dynamic vs recursive per generation", P[a].scene,
             P[a].mode, P[a].params, rt_exp_lights_name((unsigned)P[a].lights, ln, sizeof ln), P[a].W, P[a].H);
    fprintf(f, "set terminal pngcairo size 1000,420\nset output ");
    rt_plot_quote_path(f, png);
    fprintf(f, "\nset multiplot layout 1,2 title ");
    rt_plot_quote(f, title);
    fprintf(f, " noenhanced\nset logscale x 2\nset xlabel \"cache size (KB)\"\nset ylabel \"reduction (%%)\"\n"
               "set grid\nset key top left\nset xzeroaxis lw 2\n");
    static const char *const what[2] = {"geometry traffic", "total traffic"};
    static const char *const col[] = {"#0072b2", "#e69f00", "#009e73", "#d55e00",
                                      "#cc79a7", "#56b4e9", "#000000", "#f0e442"};
    for (int t = 0; t < 2; t++) {
        fprintf(f, "set title \"%s\"\nplot ", what[t]);
        for (int g = 0; g < ng; g++) {
            if (g) fprintf(f, ", ");
            if (g) fprintf(f, "''");
            else rt_plot_quote_path(f, dat);
            fprintf(f, " u 1:%d w lp lc rgb \"%s\" pt 7 t \"gen %d\"", 2 + 2 * g + t, col[g % 8], g);
        }
        fprintf(f, "\n");
    }
    fprintf(f, "unset multiplot\n");
    if (rt_plot_commit(o, e) < 0) return -1;
    const char *outs[] = {png, NULL};
    return rt_plot_draw(po, gpf, outs, png, e);
}

int rt_report_secondary(sqlite3 *h, const char *dbpath, int csv, const rt_plot_opts *plot, FILE *out, rt_err *e)
{
    point *P = NULL;
    long n = read_points(h, dbpath, &P, e);
    if (n < 0) return -1;
    if (n == 0) {
        free(P);
        return rt_errf(e, "%s: no pair of recursive and dynamic runs with generations (sweep --modes whitted,path "
                          "--tracers recursive,dynamic)", dbpath);
    }
    if (plot && rt_plot_mkdir(plot->dir, e) < 0) {
        free(P);
        return -1;
    }
    if (csv)
        fprintf(out, "scene,mode,mode_params,lights,W,H,cache_bytes,g0_geom_pct,g0_total_pct,g1_geom_pct,g1_total_pct,"
                     "g2_geom_pct,g2_total_pct,g3_geom_pct,g3_total_pct,g4_geom_pct,g4_total_pct,g5_geom_pct,"
                     "g5_total_pct,g6_geom_pct,g6_total_pct,g7_geom_pct,g7_total_pct,sec_geom_pct,sec_total_pct\n");
    else
        fprintf(out, "# Secondary rays: dynamic vs recursive per generation\n\nDatabase: %s. Reduction = recursive "
                     "/ dynamic - 1 in percent (the paper's formula; where dynamic moves more, its factor: \"3.60x "
                     "more\" = 3.60 times recursive's), the dynamic run scheduled for each size; "
                     "g>=1 sums the secondary generations.\n", dbpath);
    int rc = 0;
    for (long a = 0, b; a < n && rc == 0; a = b) {
        for (b = a + 1; b < n && same_group(&P[a], &P[b]); b++) {}
        group_table(out, csv, P, a, b);
        if (plot) rc = group_plot(plot, P, a, b, e);
    }
    if (!csv && rc == 0) {
        fprintf(out, "\n## Finding per scene\n\n");
        for (long a = 0, b; a < n; a = b) {
            for (b = a + 1; b < n && !strcmp(P[a].scene, P[b].scene); b++) {}
            scene_sentence(out, P, a, b);
        }
    }
    free(P);
    if (rc < 0) return -1;
    return rt_report_flush(out, e);
}
