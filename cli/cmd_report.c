/*
 * cmd_report.c -- `raytraffic report`: the paper's tables from the database.
 *
 * Figures 4-6 (primary rays): geometry and ray traffic in MB (2^20 bytes)
 * per tracer and cache size, and the geometry and total traffic reduction
 * of the dynamic tracer against recursive and packet. Figures 7-9 (primary
 * + shadow rays): geometry traffic reduction per light and for all three
 * lights (the paper's text: "we show how much our algorithm reduces
 * geometry traffic"; --total switches to total traffic). A scene table
 * gives triangles and the potentially visible triangles (tested by primary
 * rays; by primary + shadow rays) as the paper's Figure 3 caption does.
 *
 * Reduction uses the paper's definition: baseline / dynamic - 1 when the
 * dynamic tracer moves less, and -(dynamic / baseline - 1) when it moves
 * more (the paper's room 32K total: 36.86 vs 267.28 MB -> -625.1%).
 * Packets are not reported where the cache cannot hold one packet of rays
 * (P^2 x 32 B) plus any geometry: sizes <= P^2 x 32 B (1K and 2K for 8x8),
 * as in the paper.
 *
 * The dynamic tracer's value at cache size S comes from its run scheduled
 * for S and simulated at S.
 */
#include "cmd.h"
#include "db.h"
#include "image.h"
#include "run.h"

#include <errno.h>
#include <inttypes.h>
#include <math.h>
#include <sqlite3.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "config.h"

#define MAXS 32
#define MAXSCENES 16

typedef struct rep {
    sqlite3 *h;
    const char *dbpath;
    int csv;
    int total7; /* figures 7-9 on total instead of geometry traffic */
    int W, H;   /* resolution to report (0 = largest present) */
    int nsizes;
    uint64_t sizes[MAXS];
    int nscenes;
    char scenes[MAXSCENES][128];
    int packet; /* packet edge of the packet runs (for the 1K/2K rule) */
} rep;

/* Paper figure numbers of the three paper scenes. */
static int fig_primary(const char *scene)
{
    if (!strcmp(scene, "room")) return 4;
    if (!strcmp(scene, "grove")) return 5;
    if (!strcmp(scene, "sphereflake")) return 6;
    return 0;
}

static double reduction(double base, double dyn)
{
    if (!(base > 0) || !(dyn > 0)) return NAN;
    return base >= dyn ? 100.0 * (base / dyn - 1.0) : -100.0 * (dyn / base - 1.0);
}

/* Geometry and ray MB of one run at one cache size; returns 0 when absent. */
static int traffic(rep *R, const char *scene, const char *tracer, unsigned lights, uint64_t sched, uint64_t size,
                   double *geom, double *ray)
{
    static const char *sql =
        "SELECT geometry_mb, ray_mb FROM v_paper WHERE scene = ?1 AND tracer = ?2 AND lights = ?3"
        " AND sched_cache_size = ?4 AND cache_size = ?5 AND W = ?6 AND H = ?7 ORDER BY geometry_mb LIMIT 1";
    sqlite3_stmt *st;
    if (sqlite3_prepare_v2(R->h, sql, -1, &st, NULL) != SQLITE_OK) return 0;
    sqlite3_bind_text(st, 1, scene, -1, SQLITE_STATIC);
    sqlite3_bind_text(st, 2, tracer, -1, SQLITE_STATIC);
    sqlite3_bind_int64(st, 3, lights);
    sqlite3_bind_int64(st, 4, (sqlite3_int64)sched);
    sqlite3_bind_int64(st, 5, (sqlite3_int64)size);
    sqlite3_bind_int(st, 6, R->W);
    sqlite3_bind_int(st, 7, R->H);
    int found = 0;
    if (sqlite3_step(st) == SQLITE_ROW) {
        *geom = sqlite3_column_double(st, 0);
        *ray = sqlite3_column_double(st, 1);
        found = 1;
    }
    sqlite3_finalize(st);
    return found;
}

/* Value of the tracer at size: dynamic is scheduled for that size. */
static int tval(rep *R, const char *scene, const char *tracer, unsigned lights, uint64_t size, double *g, double *r)
{
    return traffic(R, scene, tracer, lights, strcmp(tracer, "dynamic") ? 0 : size, size, g, r);
}

static int packet_shown(const rep *R, uint64_t size) { return size > (uint64_t)R->packet * R->packet * 32; }

static void cell(const rep *R, int ok, double v, const char *fmt)
{
    if (R->csv) {
        if (ok && !isnan(v)) printf(",");
        else printf(",");
        if (ok && !isnan(v)) printf(fmt, v);
    } else {
        printf(" | ");
        if (ok && !isnan(v)) printf(fmt, v);
        else printf("—");
    }
}

static const char *size_label(uint64_t s, char *buf)
{
    sprintf(buf, "%" PRIu64 " K", s / 1024);
    return buf;
}

static void print_primary(rep *R, const char *scene)
{
    int fig = fig_primary(scene);
    char b[32];
    if (R->csv) {
        printf("figure,scene,cache_bytes,geom_recursive,geom_packet,geom_dynamic,ray_recursive,ray_packet,ray_dynamic,"
               "geomred_recursive_pct,geomred_packet_pct,totalred_recursive_pct,totalred_packet_pct\n");
    } else {
        printf("\n### Figure %s: data traffic (MB) for `%s`, primary rays, %dx%d\n\n", fig ? (char[]){'0' + fig, 0} : "-",
               scene, R->W, R->H);
        printf("| cache | geometry recursive | packet | dynamic | ray recursive | packet | dynamic | geometry reduction "
               "vs recursive | vs packet | total reduction vs recursive | vs packet |\n");
        printf("|---|---|---|---|---|---|---|---|---|---|---|\n");
    }
    for (int i = 0; i < R->nsizes; i++) {
        uint64_t s = R->sizes[i];
        double gr = 0, rr = 0, gp = 0, rp = 0, gd = 0, rd = 0;
        int hr = tval(R, scene, "recursive", 0, s, &gr, &rr);
        int hp = tval(R, scene, "packet", 0, s, &gp, &rp) && packet_shown(R, s);
        int hd = tval(R, scene, "dynamic", 0, s, &gd, &rd);
        if (!hr && !hp && !hd) continue;
        if (R->csv) printf("%d,%s,%" PRIu64, fig, scene, s);
        else printf("| %s", size_label(s, b));
        cell(R, hr, gr, "%.2f");
        cell(R, hp, gp, "%.2f");
        cell(R, hd, gd, "%.2f");
        cell(R, hr, rr, "%.2f");
        cell(R, hp, rp, "%.2f");
        cell(R, hd, rd, "%.2f");
        cell(R, hr && hd, reduction(gr, gd), "%.1f%%");
        cell(R, hp && hd, reduction(gp, gd), "%.1f%%");
        cell(R, hr && hd, reduction(gr + rr, gd + rd), "%.1f%%");
        cell(R, hp && hd, reduction(gp + rp, gd + rd), "%.1f%%");
        printf(R->csv ? "\n" : " |\n");
    }
}

static void print_shadows(rep *R, const char *scene)
{
    int fig = fig_primary(scene);
    static const unsigned masks[4] = {1, 2, 4, 7};
    char b[32];
    if (R->csv) {
        printf("figure,scene,cache_bytes,light0_recursive_pct,light0_packet_pct,light1_recursive_pct,light1_packet_pct,"
               "light2_recursive_pct,light2_packet_pct,all_recursive_pct,all_packet_pct\n");
    } else {
        printf("\n### Figure %s: %s traffic reduction for `%s` with shadows, %dx%d\n\n",
               fig ? (char[]){'0' + fig + 3, 0} : "-", R->total7 ? "total" : "geometry", scene, R->W, R->H);
        printf("| cache | light 0 vs recursive | vs packet | light 1 vs recursive | vs packet | light 2 vs recursive | "
               "vs packet | all 3 lights vs recursive | vs packet |\n|---|---|---|---|---|---|---|---|---|\n");
    }
    for (int i = 0; i < R->nsizes; i++) {
        uint64_t s = R->sizes[i];
        int any = 0;
        double v[8];
        int ok[8];
        for (int l = 0; l < 4; l++) {
            double gr, rr, gp, rp, gd, rd;
            int hr = tval(R, scene, "recursive", masks[l], s, &gr, &rr);
            int hp = tval(R, scene, "packet", masks[l], s, &gp, &rp) && packet_shown(R, s);
            int hd = tval(R, scene, "dynamic", masks[l], s, &gd, &rd);
            ok[2 * l] = hr && hd;
            ok[2 * l + 1] = hp && hd;
            v[2 * l] = ok[2 * l] ? (R->total7 ? reduction(gr + rr, gd + rd) : reduction(gr, gd)) : NAN;
            v[2 * l + 1] = ok[2 * l + 1] ? (R->total7 ? reduction(gp + rp, gd + rd) : reduction(gp, gd)) : NAN;
            any |= hr || hp || hd;
        }
        if (!any) continue;
        if (R->csv) printf("%d,%s,%" PRIu64, fig ? fig + 3 : 0, scene, s);
        else printf("| %s", size_label(s, b));
        for (int k = 0; k < 8; k++) cell(R, ok[k], v[k], "%.1f%%");
        printf(R->csv ? "\n" : " |\n");
    }
}

/* Looks up "key=value" in a run's stats string. */
static int stat_of(const char *stats, const char *key, double *v)
{
    size_t kl = strlen(key);
    for (const char *p = stats; p && *p;) {
        if (!strncmp(p, key, kl) && p[kl] == '=') {
            *v = strtod(p + kl + 1, NULL);
            return 1;
        }
        p = strchr(p, ' ');
        if (p) p++;
    }
    return 0;
}

static int run_stats(rep *R, const char *scene, const char *tracer, unsigned lights, char *out, size_t n)
{
    static const char *sql = "SELECT r.stats FROM runs r JOIN scenes s ON s.id = r.scene_id WHERE s.name = ?1 AND "
                             "r.tracer = ?2 AND r.lights = ?3 AND r.W = ?4 AND r.H = ?5 AND r.sim_method = 'exact' "
                             "AND r.params NOT LIKE '%subsample=%' ORDER BY r.id LIMIT 1";
    sqlite3_stmt *st;
    if (sqlite3_prepare_v2(R->h, sql, -1, &st, NULL) != SQLITE_OK) return 0;
    sqlite3_bind_text(st, 1, scene, -1, SQLITE_STATIC);
    sqlite3_bind_text(st, 2, tracer, -1, SQLITE_STATIC);
    sqlite3_bind_int64(st, 3, lights);
    sqlite3_bind_int(st, 4, R->W);
    sqlite3_bind_int(st, 5, R->H);
    int found = 0;
    if (sqlite3_step(st) == SQLITE_ROW && sqlite3_column_text(st, 0)) {
        snprintf(out, n, "%s", (const char *)sqlite3_column_text(st, 0));
        found = 1;
    }
    sqlite3_finalize(st);
    return found;
}

static void print_scenes(rep *R)
{
    if (R->csv) printf("scene,triangles,pv_primary,pv_primary_shadow,W,H\n");
    else
        printf("\n### Scenes (the paper's Figure 3 statistics), %dx%d\n\n| scene | triangles | potentially visible, "
               "primary | primary + shadow | paper |\n|---|---|---|---|---|\n",
               R->W, R->H);
    for (int i = 0; i < R->nscenes; i++) {
        const char *sc = R->scenes[i];
        sqlite3_stmt *st;
        int64_t tri = 0;
        if (sqlite3_prepare_v2(R->h, "SELECT triangles FROM scenes WHERE name = ?1 ORDER BY id LIMIT 1", -1, &st, NULL) ==
            SQLITE_OK) {
            sqlite3_bind_text(st, 1, sc, -1, SQLITE_STATIC);
            if (sqlite3_step(st) == SQLITE_ROW) tri = sqlite3_column_int64(st, 0);
            sqlite3_finalize(st);
        }
        char stats[1024];
        double pvp = NAN, pva = NAN;
        if (run_stats(R, sc, "recursive", 7, stats, sizeof stats)) {
            stat_of(stats, "pv_primary", &pvp);
            stat_of(stats, "pv_all", &pva);
        } else if (run_stats(R, sc, "recursive", 0, stats, sizeof stats)) {
            stat_of(stats, "pv_primary", &pvp);
        }
        const char *paper = !strcmp(sc, "room")          ? "47K; 6.6K; 7.7K"
                            : !strcmp(sc, "grove")       ? "164K; 127K; 142K"
                            : !strcmp(sc, "sphereflake") ? "797K; 258K; 535K"
                                                         : "";
        if (R->csv) {
            printf("%s,%" PRId64 ",", sc, tri);
            if (!isnan(pvp)) printf("%.0f", pvp);
            printf(",");
            if (!isnan(pva)) printf("%.0f", pva);
            printf(",%d,%d\n", R->W, R->H);
        } else {
            printf("| %s | %" PRId64 " | ", sc, tri);
            if (!isnan(pvp)) printf("%.0f", pvp); else printf("—");
            printf(" | ");
            if (!isnan(pva)) printf("%.0f", pva); else printf("—");
            printf(" | %s |\n", paper);
        }
    }
}

/* ---- paper comparison ------------------------------------------------- */

typedef struct paper_row {
    char scene[32];
    int kb;
    double v[10]; /* NAN when the paper shows a dash */
} paper_row;

static int load_csv(const char *path, paper_row *rows, int max, int ncols)
{
    FILE *f = fopen(path, "r");
    if (!f) return -1;
    char line[1024];
    int n = 0;
    if (!fgets(line, sizeof line, f)) {
        fclose(f);
        return 0;
    }
    while (n < max && fgets(line, sizeof line, f)) {
        char *save = NULL, *tok = strtok_r(line, ",\n", &save);
        if (!tok) continue;
        paper_row *r = &rows[n];
        snprintf(r->scene, sizeof r->scene, "%s", tok);
        char *p = save;
        r->kb = (int)strtol(p, &p, 10);
        for (int k = 0; k < ncols; k++) {
            if (*p == ',') p++;
            if (*p == ',' || *p == '\n' || !*p) r->v[k] = NAN;
            else r->v[k] = strtod(p, &p);
        }
        n++;
    }
    fclose(f);
    return n;
}

static const char *data_path(const char *name, char *buf, size_t n)
{
    snprintf(buf, n, "%s/%s", RT_SRCDATADIR, name);
    if (access(buf, R_OK) == 0) return buf;
    snprintf(buf, n, "%s/%s", RT_DATADIR, name);
    return buf;
}

static void ratio_cell(const rep *R, double ours, double paper)
{
    if (R->csv) {
        printf(",");
        if (!isnan(ours)) printf("%.2f", ours);
        printf(",");
        if (!isnan(paper)) printf("%.2f", paper);
        return;
    }
    if (isnan(ours) || isnan(paper)) printf(" | —");
    else if (paper != 0 && (ours > 0) == (paper > 0)) printf(" | %.2f / %.2f (%.2fx)", ours, paper, ours / paper);
    else printf(" | %.2f / %.2f", ours, paper);
}

static int compare_paper(rep *R)
{
    char p1[4096], p2[4096];
    static paper_row prim[64], shad[64];
    int np = load_csv(data_path("paper_primary.csv", p1, sizeof p1), prim, 64, 10);
    int ns = load_csv(data_path("paper_shadows.csv", p2, sizeof p2), shad, 64, 8);
    if (np < 0 || ns < 0) {
        rt_cmd_error("report", "%s: cannot read the paper's tables", np < 0 ? p1 : p2);
        return -1;
    }
    if (!R->csv)
        printf("\n## Comparison with the paper (ours / paper (ratio)), %dx%d; paper at 1024x1024\n\n", R->W, R->H);
    static const char *const sc3[3] = {"room", "grove", "sphereflake"};
    for (int si = 0; si < 3; si++) {
        const char *sc = sc3[si];
        int present = 0;
        for (int i = 0; i < R->nscenes; i++) present |= !strcmp(R->scenes[i], sc);
        if (!present) continue;
        if (R->csv)
            printf("scene,cache_kb,geom_recursive_ours,geom_recursive_paper,geom_packet_ours,geom_packet_paper,"
                   "geom_dynamic_ours,geom_dynamic_paper,ray_dynamic_ours,ray_dynamic_paper,geomred_recursive_ours,"
                   "geomred_recursive_paper\n");
        else
            printf("\n### `%s`, primary rays (MB; reduction in %%)\n\n| cache | geometry recursive | geometry packet | "
                   "geometry dynamic | ray dynamic | geometry reduction vs recursive |\n|---|---|---|---|---|---|\n",
                   sc);
        /* qualitative findings */
        int n_dyn_less = 0, n_cmp = 0, n_ray_more = 0, n_paper_ray_more = 0;
        double best_ours = -1e30, best_paper = -1e30;
        int best_ours_kb = 0, best_paper_kb = 0, cross_ours = 0, cross_paper = 0;
        for (int k = 0; k < np; k++) {
            paper_row *pr = &prim[k];
            if (strcmp(pr->scene, sc)) continue;
            uint64_t s = (uint64_t)pr->kb * 1024;
            double gr = NAN, rr = NAN, gp = NAN, rp = NAN, gd = NAN, rd = NAN;
            if (!tval(R, sc, "recursive", 0, s, &gr, &rr)) gr = rr = NAN;
            if (!tval(R, sc, "packet", 0, s, &gp, &rp) || !packet_shown(R, s)) gp = rp = NAN;
            if (!tval(R, sc, "dynamic", 0, s, &gd, &rd)) gd = rd = NAN;
            double red = reduction(gr, gd), tot = reduction(gr + rr, gd + rd);
            if (R->csv) printf("%s,%d", sc, pr->kb);
            else printf("| %d K", pr->kb);
            ratio_cell(R, gr, pr->v[0]);
            ratio_cell(R, gp, pr->v[1]);
            ratio_cell(R, gd, pr->v[2]);
            ratio_cell(R, rd, pr->v[5]);
            ratio_cell(R, red, pr->v[6]);
            printf(R->csv ? "\n" : " |\n");
            if (!isnan(red)) {
                n_cmp++;
                n_dyn_less += red > 0;
                n_ray_more += rd > rr;
                n_paper_ray_more += pr->v[5] > pr->v[3];
                if (red > best_ours) best_ours = red, best_ours_kb = pr->kb;
                if (pr->v[6] > best_paper) best_paper = pr->v[6], best_paper_kb = pr->kb;
                if (!cross_ours && tot < 0) cross_ours = pr->kb;
                if (!cross_paper && pr->v[8] < 0) cross_paper = pr->kb;
            }
        }
        if (R->csv || !n_cmp) continue;
        printf("\nFindings for `%s`:\n", sc);
        printf("- dynamic moves less geometry than recursive at %d of %d sizes (paper: all 13).\n", n_dyn_less, n_cmp);
        printf("- largest geometry reduction vs recursive: %.0f%% at %d K (paper: %.0f%% at %d K) — %s.\n", best_ours,
               best_ours_kb, best_paper, best_paper_kb,
               (best_ours_kb <= 32) == (best_paper_kb <= 32) ? "both at small caches, agrees" : "differs");
        printf("- dynamic ray traffic exceeds recursive at %d of %d sizes (paper: %d): the ray-traffic overhead %s.\n",
               n_ray_more, n_cmp, n_paper_ray_more, n_ray_more * 2 >= n_cmp ? "agrees" : "differs");
        if (cross_ours || cross_paper)
            printf("- total traffic turns against dynamic from %d K (paper: %d K).\n", cross_ours, cross_paper);
    }
    /* shadows */
    for (int si = 0; si < 3; si++) {
        const char *sc = sc3[si];
        int present = 0;
        for (int i = 0; i < R->nscenes; i++) present |= !strcmp(R->scenes[i], sc);
        if (!present) continue;
        if (R->csv)
            printf("scene,cache_kb,light0_ours,light0_paper,light1_ours,light1_paper,light2_ours,light2_paper,"
                   "all_ours,all_paper\n");
        else
            printf("\n### `%s` with shadows: geometry reduction vs recursive (%%)\n\n| cache | light 0 | light 1 | "
                   "light 2 | all 3 |\n|---|---|---|---|---|\n",
                   sc);
        static const unsigned masks[4] = {1, 2, 4, 7};
        for (int k = 0; k < ns; k++) {
            paper_row *pr = &shad[k];
            if (strcmp(pr->scene, sc)) continue;
            uint64_t s = (uint64_t)pr->kb * 1024;
            if (R->csv) printf("%s,%d", sc, pr->kb);
            else printf("| %d K", pr->kb);
            for (int l = 0; l < 4; l++) {
                double gr, rr, gd, rd, v = NAN;
                if (tval(R, sc, "recursive", masks[l], s, &gr, &rr) && tval(R, sc, "dynamic", masks[l], s, &gd, &rd))
                    v = R->total7 ? reduction(gr + rr, gd + rd) : reduction(gr, gd);
                ratio_cell(R, v, pr->v[2 * l]);
            }
            printf(R->csv ? "\n" : " |\n");
        }
    }
    if (!R->csv)
        printf("\nWhy numbers differ: our room and grove are procedural stand-ins of the same size, not the paper's "
               "models; our k-d tree (SAH, pbrt costs, no mailboxing) and the paper's differ in depth and leaf size, "
               "which moves queue points and so ray traffic; our memory model counts shading reads, hit records and "
               "the ray buffer explicitly; quick-preset runs use fewer pixels than the paper's 1024x1024.\n");
    return 0;
}

/* ---- plots ----------------------------------------------------------------- */

static int plots(rep *R, const char *dir)
{
    if (mkdir(dir, 0777) < 0 && errno != EEXIST) {
        rt_cmd_error("report", "%s: %s", dir, strerror(errno));
        return -1;
    }
    const char *gp = getenv("RT_GNUPLOT");
    if (!gp || !*gp) gp = GNUPLOT_PATH[0] ? GNUPLOT_PATH : "gnuplot";
    char cmd[8192];
    snprintf(cmd, sizeof cmd, "'%s' -e 'exit' >/dev/null 2>&1", gp);
    int have_gp = system(cmd) == 0;
    if (!have_gp)
        rt_cmd_error("report", "gnuplot not found (apt-get install gnuplot-nox): writing data files only, no plots");
    for (int i = 0; i < R->nscenes; i++) {
        const char *sc = R->scenes[i];
        char dat[4096], gpf[4096];
        snprintf(dat, sizeof dat, "%s/%s-traffic.dat", dir, sc);
        FILE *f = fopen(dat, "w");
        if (!f) {
            rt_cmd_error("report", "%s: %s", dat, strerror(errno));
            return -1;
        }
        fprintf(f, "# cache_kb geom_recursive geom_packet geom_dynamic ray_recursive ray_packet ray_dynamic (MB, "
                   "primary rays)\n");
        for (int k = 0; k < R->nsizes; k++) {
            uint64_t s = R->sizes[k];
            double v[6];
            int h[3];
            h[0] = tval(R, sc, "recursive", 0, s, &v[0], &v[3]);
            h[1] = tval(R, sc, "packet", 0, s, &v[1], &v[4]) && packet_shown(R, s);
            h[2] = tval(R, sc, "dynamic", 0, s, &v[2], &v[5]);
            fprintf(f, "%" PRIu64, s / 1024);
            for (int c = 0; c < 6; c++)
                if (h[c % 3] && v[c] > 0) fprintf(f, " %.6g", v[c]);
                else fprintf(f, " NaN");
            fprintf(f, "\n");
        }
        fclose(f);
        if (!have_gp) continue;
        snprintf(gpf, sizeof gpf, "%s/%s-traffic.gp", dir, sc);
        f = fopen(gpf, "w");
        if (!f) return -1;
        for (int t = 0; t < 2; t++) {
            const char *term = t ? "svg size 900,420 dynamic" : "pngcairo size 900,420";
            const char *ext = t ? "svg" : "png";
            fprintf(f,
                    "set terminal %s\nset output '%s/%s-traffic.%s'\nset multiplot layout 1,2 title '%s: DRAM traffic, "
                    "primary rays, %dx%d'\n"
                    "set logscale xy\nset xlabel 'cache size (KB)'\nset ylabel 'MB'\nset grid\nset key top right\n"
                    "set xtics (1,4,16,64,256,1024,4096)\n"
                    "set title 'geometry traffic'\nplot '%s' u 1:2 w lp t 'recursive', '' u 1:3 w lp t 'packet', '' u "
                    "1:4 w lp t 'dynamic'\n"
                    "set title 'ray traffic'\nplot '%s' u 1:5 w lp t 'recursive', '' u 1:6 w lp t 'packet', '' u 1:7 "
                    "w lp t 'dynamic'\nunset multiplot\n",
                    term, dir, sc, ext, sc, R->W, R->H, dat, dat);
        }
        fclose(f);
        snprintf(cmd, sizeof cmd, "'%s' '%s' 2>&1", gp, gpf);
        if (system(cmd) != 0) {
            rt_cmd_error("report", "%s: gnuplot failed", gpf);
            return -1;
        }
        fprintf(stderr, "wrote %s/%s-traffic.png and .svg\n", dir, sc);
    }
    /* Side-by-side image of the rendered scenes (recursive, all lights). */
    int tile = 256, n = R->nscenes;
    if (n > 0) {
        unsigned char *all = calloc((size_t)tile * n * tile * 3, 1);
        if (!all) return -1;
        for (int i = 0; i < n; i++) {
            rt_err e = {""};
            rt_render_opts o;
            rt_render_default_opts(&o);
            o.W = o.H = tile;
            o.lights = 7;
            rt_job j;
            if (rt_job_setup(&j, R->scenes[i], "recursive", &o, &e) < 0) {
                rt_cmd_error("report", "%s", e.msg);
                continue;
            }
            rt_image *im = rt_image_new(tile, tile, &e);
            rt_run_stats st;
            if (im && rt_job_run(&j, NULL, im, &st, &e) == 0) {
                unsigned char *px = malloc((size_t)tile * tile * 3);
                if (px) {
                    rt_image_to_rgb8(im, px);
                    for (int y = 0; y < tile; y++)
                        memcpy(all + ((size_t)y * tile * n + (size_t)i * tile) * 3, px + (size_t)y * tile * 3,
                               (size_t)tile * 3);
                    free(px);
                }
            }
            rt_image_free(im);
            rt_job_free(&j);
        }
        char path[4096];
        snprintf(path, sizeof path, "%s/scenes.png", dir);
        rt_err e = {""};
        if (rt_png_write_rgb8(path, tile * n, tile, all, &e) < 0) rt_cmd_error("report", "%s", e.msg);
        else fprintf(stderr, "wrote %s\n", path);
        free(all);
    }
    return 0;
}

/* ---- setup ------------------------------------------------------------------ */

static int load_axes(rep *R, const char *only_scene)
{
    sqlite3_stmt *st;
    if (!R->W) {
        if (sqlite3_prepare_v2(R->h, "SELECT W, H FROM runs WHERE sim_method = 'exact' ORDER BY W * H DESC LIMIT 1", -1,
                               &st, NULL) != SQLITE_OK)
            return -1;
        if (sqlite3_step(st) == SQLITE_ROW) {
            R->W = sqlite3_column_int(st, 0);
            R->H = sqlite3_column_int(st, 1);
        }
        sqlite3_finalize(st);
    }
    if (sqlite3_prepare_v2(R->h,
                           "SELECT DISTINCT c.size FROM traffic t JOIN cache_configs c ON c.id = t.config_id WHERE "
                           "c.line = 64 AND c.assoc = 0 AND c.policy = 'wb-wa' ORDER BY c.size",
                           -1, &st, NULL) != SQLITE_OK)
        return -1;
    while (sqlite3_step(st) == SQLITE_ROW && R->nsizes < MAXS) R->sizes[R->nsizes++] = (uint64_t)sqlite3_column_int64(st, 0);
    sqlite3_finalize(st);
    /* scenes in the paper's order first, then the rest by name */
    if (sqlite3_prepare_v2(R->h,
                           "SELECT DISTINCT s.name FROM runs r JOIN scenes s ON s.id = r.scene_id WHERE r.W = ?1 AND "
                           "r.H = ?2 ORDER BY CASE s.name WHEN 'room' THEN 0 WHEN 'grove' THEN 1 WHEN 'sphereflake' "
                           "THEN 2 ELSE 3 END, s.name",
                           -1, &st, NULL) != SQLITE_OK)
        return -1;
    sqlite3_bind_int(st, 1, R->W);
    sqlite3_bind_int(st, 2, R->H);
    while (sqlite3_step(st) == SQLITE_ROW && R->nscenes < MAXSCENES) {
        const char *n = (const char *)sqlite3_column_text(st, 0);
        if (only_scene && strcmp(n, only_scene)) continue;
        snprintf(R->scenes[R->nscenes++], sizeof R->scenes[0], "%s", n);
    }
    sqlite3_finalize(st);
    R->packet = 8;
    if (sqlite3_prepare_v2(R->h, "SELECT params FROM runs WHERE tracer = 'packet' LIMIT 1", -1, &st, NULL) == SQLITE_OK) {
        if (sqlite3_step(st) == SQLITE_ROW && sqlite3_column_text(st, 0)) {
            const char *p = strstr((const char *)sqlite3_column_text(st, 0), "packet=");
            if (p) R->packet = atoi(p + 7);
        }
        sqlite3_finalize(st);
    }
    return 0;
}

int rt_report_speed_error(sqlite3 *h, int csv, const char *plotdir);

static void usage(FILE *f)
{
    fprintf(f,
            "Usage: raytraffic report [options]\n\n"
            "Prints the paper's tables (Figures 3-9) from a results database.\n\n"
            "Options:\n"
            "  --db FILE          results database (default raytraffic.db)\n"
            "  --figure F         4|5|6 (primary), 7|8|9 (shadows), scenes, or all (default all)\n"
            "  --scene NAME       only this scene (figures 4-9 map room, grove, sphereflake)\n"
            "  --format md|csv    Markdown tables (default) or CSV\n"
            "  -W N, -H N         resolution to report (default: the largest in the database)\n"
            "  --total            figures 7-9 on total instead of geometry traffic\n"
            "  --compare-paper    our values beside the paper's, with ratios and findings\n"
            "  --plot DIR         traffic-vs-cache-size plots (PNG, SVG; gnuplot) and scenes.png\n"
            "  --speed-error      speed against error of approximate simulation\n"
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
        {"help", no_argument, NULL, 'h'},           {NULL, 0, NULL, 0},
    };
    rep R;
    memset(&R, 0, sizeof R);
    R.dbpath = "raytraffic.db";
    const char *figure = "all", *only = NULL, *plotdir = NULL;
    int compare = 0, speed = 0, c;
    optind = 1;
    while ((c = getopt_long(argc, argv, "hW:H:", lo, NULL)) != -1) {
        switch (c) {
        case 'd': R.dbpath = optarg; break;
        case 'f':
            if (strcmp(optarg, "all") && strcmp(optarg, "scenes") &&
                !(strlen(optarg) == 1 && optarg[0] >= '4' && optarg[0] <= '9')) {
                rt_cmd_error("report", "--figure: '%s' is not 4..9, scenes or all", optarg);
                return RT_EXIT_USAGE;
            }
            figure = optarg;
            break;
        case 's': only = optarg; break;
        case 'F':
            if (!strcmp(optarg, "csv")) R.csv = 1;
            else if (strcmp(optarg, "md")) {
                rt_cmd_error("report", "--format: '%s' is not md or csv", optarg);
                return RT_EXIT_USAGE;
            }
            break;
        case 't': R.total7 = 1; break;
        case 'c': compare = 1; break;
        case 'p': plotdir = optarg; break;
        case 'e': speed = 1; break;
        case 'W': R.W = atoi(optarg); break;
        case 'H': R.H = atoi(optarg); break;
        case 'h': usage(stdout); return RT_EXIT_OK;
        default: return RT_EXIT_USAGE;
        }
    }
    if (optind != argc) {
        rt_cmd_error("report", "unexpected argument '%s'", argv[optind]);
        return RT_EXIT_USAGE;
    }
    struct stat sb;
    if (stat(R.dbpath, &sb) < 0) {
        rt_cmd_error("report", "%s: %s (run `raytraffic sweep` first)", R.dbpath, strerror(errno));
        return RT_EXIT_FAIL;
    }
    rt_err e = {""};
    rt_db *db = rt_db_open(R.dbpath, &e);
    if (!db) {
        rt_cmd_error("report", "%s", e.msg);
        return RT_EXIT_FAIL;
    }
    R.h = rt_db_handle(db);
    if (load_axes(&R, only) < 0) {
        rt_cmd_error("report", "%s: %s", R.dbpath, sqlite3_errmsg(R.h));
        rt_db_close(db);
        return RT_EXIT_FAIL;
    }
    int rc = RT_EXIT_OK;
    if (speed) {
        rc = rt_report_speed_error(R.h, R.csv, plotdir) < 0 ? RT_EXIT_FAIL : RT_EXIT_OK;
        rt_db_close(db);
        return rc;
    }
    if (!R.nscenes) {
        rt_cmd_error("report", "%s: no runs%s", R.dbpath, only ? " for that scene" : "");
        rt_db_close(db);
        return RT_EXIT_FAIL;
    }
    if (!R.csv)
        printf("# raytraffic report: %s\n\nTraffic in MB (2^20 bytes) between DRAM and a fully associative LRU cache "
               "with 64-byte lines (write-back, write-allocate). Reduction = baseline / dynamic - 1 (negative: "
               "-(dynamic / baseline - 1)).\n",
               R.dbpath);
    int all = !strcmp(figure, "all");
    if (all || !strcmp(figure, "scenes")) print_scenes(&R);
    for (int i = 0; i < R.nscenes; i++) {
        int f = fig_primary(R.scenes[i]);
        if (all || (f && figure[0] - '0' == f)) print_primary(&R, R.scenes[i]);
    }
    for (int i = 0; i < R.nscenes; i++) {
        int f = fig_primary(R.scenes[i]);
        if (all || (f && figure[0] - '0' == f + 3)) print_shadows(&R, R.scenes[i]);
    }
    if (compare && compare_paper(&R) < 0) rc = RT_EXIT_FAIL;
    if (plotdir && plots(&R, plotdir) < 0) rc = RT_EXIT_FAIL;
    rt_db_close(db);
    return rc;
}
