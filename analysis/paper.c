/*
 * paper.c -- the paper's tables from the database, and our values beside
 * the paper's published ones.
 *
 * Figures 4-6 (primary rays): geometry and ray traffic in MB (2^20 bytes)
 * per tracer and cache size, and the geometry and total traffic reduction
 * of the dynamic tracer against recursive and packet. Figures 7-9 (primary
 * + shadow rays): geometry traffic reduction per light and for all three
 * lights (the paper's text: "we show how much our algorithm reduces
 * geometry traffic"; total = 1 switches to total traffic). A scene table
 * gives triangles and the potentially visible triangles (tested by primary
 * rays; by primary + shadow rays) as the paper's Figure 3 caption does.
 *
 * Reduction uses the paper's formula (rt_report_reduction), baseline /
 * dynamic - 1, everywhere; where the dynamic tracer moves more it is shown
 * as the factor dynamic / baseline ("7.25× more": the paper's room 32K
 * total, 36.86 vs 267.28 MB, which the paper prints as -625.1%; its
 * tables are read into the one formula by rt_report_paper_reduction). Packets are not reported where the cache cannot hold one
 * packet of rays (P^2 x 32 B) plus any geometry: sizes <= P^2 x 32 B (1K
 * and 2K for 8x8), as in the paper.
 *
 * Every table writes to the caller's FILE *; write errors surface in
 * rt_report_flush at the end of each public function.
 */
#include "analysis_int.h"
#include "experiment.h"
#include "scene.h"

#include <inttypes.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

/* Paper figure numbers of the three paper scenes, by name. */
static int fig_of_name(const char *name)
{
    if (!strcmp(name, "room")) return 4;
    if (!strcmp(name, "grove")) return 5;
    if (!strcmp(name, "sphereflake")) return 6;
    return 0;
}

/* The canonical parameters of built-in scene name at its defaults (the
 * "key=default" of each part of rt_scene_builtin_params, joined by ','),
 * into buf; '' when it takes none or is unknown. */
static void default_params(const char *name, char *buf, size_t n)
{
    char help[2048];
    buf[0] = 0;
    if (rt_scene_builtin_params(name, help, sizeof help) < 0) return;
    size_t w = 0;
    for (const char *p = help; *p;) {
        while (*p == ' ' || *p == ';') p++;
        const char *eq = strchr(p, '='), *sp = eq ? strpbrk(eq, " ;") : NULL;
        /* a parameter is "key=default (min..max): help"; a part of a
         * help text such as "v=1: apex spheres" is not one */
        if (eq && sp && strpbrk(p, " ;") >= eq && sp[0] == ' ' && sp[1] == '(') {
            int l = snprintf(buf + w, n - w, "%s%.*s", w ? "," : "", (int)(sp - p), p);
            if (l < 0 || (size_t)l >= n - w) break;
            w += (size_t)l;
        }
        if (!sp) break;
        const char *next = strchr(sp, ';');
        if (!next) break;
        p = next + 1;
    }
}

/* The stored parameters of scene label into buf ('' if none). */
static int scene_params(const rt_report *R, const char *label, char *buf, size_t n, rt_err *e)
{
    int i = rt_report_scene_index(R, label);
    buf[0] = 0;
    if (i < 0) return 0;
    sqlite3_stmt *st = rt_report_stmt(R->h, "SELECT params FROM scenes WHERE name = ?1 AND hash = ?2 LIMIT 1",
                                      R->dbpath, e, "ss", R->scene_name[i], R->scene_hash[i]);
    if (!st) return -1;
    int rc = sqlite3_step(st);
    if (rc == SQLITE_ROW && sqlite3_column_text(st, 0)) snprintf(buf, n, "%s", (const char *)sqlite3_column_text(st, 0));
    return rt_report_done(st, rc, R->dbpath, e);
}

/* The paper figure (4, 5, 6) of scene label: one of the paper's scenes at
 * the paper's parameters (the built-in defaults); 0 otherwise, with why
 * in why (n bytes; '' for a scene the paper does not have). -1 on a
 * database error. */
static int fig_primary_why(const rt_report *R, const char *label, char *why, size_t n, rt_err *e)
{
    int i = rt_report_scene_index(R, label);
    why[0] = 0;
    int f = fig_of_name(i >= 0 ? R->scene_name[i] : label);
    if (!f) return 0;
    char have[256], want[256];
    if (scene_params(R, label, have, sizeof have, e) < 0) return -1;
    default_params(i >= 0 ? R->scene_name[i] : label, want, sizeof want);
    if (strcmp(have, want)) {
        snprintf(why, n, "parameters %s, the paper's Figure %d is %s", have[0] ? have : "(none)", f, want);
        return 0;
    }
    return f;
}

/* The paper figure of scene label, or 0 (not a paper scene at the paper's
 * parameters, or a database error: then the figure is just not named). */
static int fig_primary_of(const rt_report *R, const char *label)
{
    char why[300];
    rt_err e = {0};
    int f = fig_primary_why(R, label, why, sizeof why, &e);
    return f > 0 ? f : 0;
}

static int packet_shown(const rt_report *R, uint64_t size) { return size > (uint64_t)R->packet * R->packet * 32; }

/* The three tracers' geometry (g) and ray (r) MB at one size and light
 * mask, in the order recursive, packet, dynamic; has[k] = 0 (values NAN)
 * when the run is absent or, for packets, not reported at that size. */
/* The figure's three columns: the Navratil tracers in registry order
 * (baseline, packet, scheduled). */
static const char *tracer3(int k)
{
    const rt_tracer *t[3] = {NULL, NULL, NULL};
    rt_report_fig_tracers(RT_FIG_NAVRATIL, t, 3);
    return t[k] ? t[k]->name : "";
}
static int values3(const rt_report *R, const char *scene, unsigned lights, uint64_t size, double g[3], double r[3],
                   int has[3], rt_err *e)
{
    for (int k = 0; k < 3; k++) {
        int f = rt_report_value(R, scene, tracer3(k), lights, size, &g[k], &r[k], e);
        if (f < 0) return -1;
        has[k] = f && (k != 1 || packet_shown(R, size));
        if (!has[k]) g[k] = r[k] = NAN;
    }
    return 0;
}

static void cell(const rt_report *R, FILE *out, int ok, double v, const char *fmt)
{
    if (R->csv) {
        fputc(',', out);
        if (ok && !isnan(v)) fprintf(out, fmt, v);
    } else {
        fputs(" | ", out);
        if (ok && !isnan(v)) fprintf(out, fmt, v);
        else fputs("—", out);
    }
}

/* A reduction cell (rt_report_fmt_reduction): "521.5%", "7.25× more", or
 * in CSV the number. */
static void red_cell(const rt_report *R, FILE *out, int ok, double v)
{
    char b[64];
    fputs(R->csv ? "," : " | ", out);
    fputs(rt_report_fmt_reduction(ok ? v : NAN, R->csv, b, sizeof b), out);
}

int rt_report_primary(const rt_report *R, const char *scene, FILE *out, rt_err *e)
{
    int fig = fig_primary_of(R, scene);
    if (R->csv) {
        fprintf(out, "figure,scene,cache_bytes,geom_recursive,geom_packet,geom_dynamic,ray_recursive,ray_packet,"
                     "ray_dynamic,geomred_recursive_pct,geomred_packet_pct,totalred_recursive_pct,totalred_packet_pct\n");
    } else {
        fprintf(out, "\n### Figure ");
        if (fig) fprintf(out, "%d", fig);
        else fputc('-', out);
        fprintf(out, ": data traffic (MB) for `%s`, primary rays, %dx%d\n\n", scene, R->W, R->H);
        fprintf(out, "| cache | geometry recursive | packet | dynamic | ray recursive | packet | dynamic | geometry "
                     "reduction vs recursive | vs packet | total reduction vs recursive | vs packet |\n");
        fprintf(out, "|---|---|---|---|---|---|---|---|---|---|---|\n");
    }
    int hidden = 0;
    for (int i = 0; i < R->nsizes; i++) {
        uint64_t s = R->sizes[i];
        double g[3], r[3];
        int h[3];
        if (values3(R, scene, 0, s, g, r, h, e) < 0) return -1;
        if (!h[0] && !h[1] && !h[2]) continue;
        if (R->csv) fprintf(out, "%d,%s,%" PRIu64, fig, scene, s);
        else fprintf(out, "| %" PRIu64 " K", s / 1024);
        for (int k = 0; k < 3; k++) cell(R, out, h[k], g[k], "%.2f");
        for (int k = 0; k < 3; k++) cell(R, out, h[k], r[k], "%.2f");
        red_cell(R, out, h[0] && h[2], rt_report_reduction(g[0], g[2]));
        red_cell(R, out, h[1] && h[2], rt_report_reduction(g[1], g[2]));
        red_cell(R, out, h[0] && h[2], rt_report_reduction(g[0] + r[0], g[2] + r[2]));
        red_cell(R, out, h[1] && h[2], rt_report_reduction(g[1] + r[1], g[2] + r[2]));
        fputs(R->csv ? "\n" : " |\n", out);
        if (!packet_shown(R, s)) { /* a packet run the table leaves out */
            double pg, pr;
            int f = rt_report_value(R, scene, tracer3(1), 0, s, &pg, &pr, e);
            if (f < 0) return -1;
            hidden += f;
        }
    }
    if (!R->csv && hidden)
        fprintf(out, "\n— packet at %" PRIu64 " K and below: not reported where the cache cannot hold one packet of rays "
                     "(%dx%d rays x 32 B = %d B), as in the paper; the database holds those runs (`--format csv`).\n",
                (uint64_t)R->packet * R->packet * 32 / 1024, R->packet, R->packet, R->packet * R->packet * 32);
    return rt_report_flush(out, e);
}

/* Light masks of Figures 7-9's columns: light 0, 1, 2, all three. */
static const unsigned masks4[4] = {1, 2, 4, 7};

/* Reduction of the dynamic tracer against recursive (k = 0) or packet
 * (k = 1), on geometry or, with R->total, total traffic. */
static double red_vs(const rt_report *R, const double g[3], const double r[3], int k)
{
    return R->total ? rt_report_reduction(g[k] + r[k], g[2] + r[2]) : rt_report_reduction(g[k], g[2]);
}

int rt_report_shadows(const rt_report *R, const char *scene, FILE *out, rt_err *e)
{
    int fig = fig_primary_of(R, scene);
    if (R->csv) {
        fprintf(out, "figure,scene,cache_bytes,light0_recursive_pct,light0_packet_pct,light1_recursive_pct,"
                     "light1_packet_pct,light2_recursive_pct,light2_packet_pct,all_recursive_pct,all_packet_pct\n");
    } else {
        fprintf(out, "\n### Figure ");
        if (fig) fprintf(out, "%d", fig + 3);
        else fputc('-', out);
        fprintf(out, ": %s traffic reduction for `%s` with shadows, %dx%d\n\n", R->total ? "total" : "geometry", scene,
                R->W, R->H);
        fprintf(out, "| cache | light 0 vs recursive | vs packet | light 1 vs recursive | vs packet | light 2 vs "
                     "recursive | vs packet | all 3 lights vs recursive | vs packet |\n|---|---|---|---|---|---|---|---|"
                     "---|\n");
    }
    for (int i = 0; i < R->nsizes; i++) {
        uint64_t s = R->sizes[i];
        int any = 0, ok[8];
        double v[8];
        for (int l = 0; l < 4; l++) {
            double g[3], r[3];
            int h[3];
            if (values3(R, scene, masks4[l], s, g, r, h, e) < 0) return -1;
            for (int k = 0; k < 2; k++) {
                ok[2 * l + k] = h[k] && h[2];
                v[2 * l + k] = ok[2 * l + k] ? red_vs(R, g, r, k) : NAN;
            }
            any |= h[0] || h[1] || h[2];
        }
        if (!any) continue;
        if (R->csv) fprintf(out, "%d,%s,%" PRIu64, fig ? fig + 3 : 0, scene, s);
        else fprintf(out, "| %" PRIu64 " K", s / 1024);
        for (int k = 0; k < 8; k++) red_cell(R, out, ok[k], v[k]);
        fputs(R->csv ? "\n" : " |\n", out);
    }
    return rt_report_flush(out, e);
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

/* The stats of the scene's first exact, full-frame run of tracer with
 * light mask lights: 1 and out filled, 0 when there is none, -1 on error. */
static int run_stats(const rt_report *R, const char *scene, const char *tracer, unsigned lights, char *out, size_t n,
                     rt_err *e)
{
    int i = rt_report_scene_index(R, scene);
    sqlite3_stmt *st = rt_report_stmt(
        R->h,
        "SELECT r.stats FROM runs r JOIN scenes s ON s.id = r.scene_id WHERE s.name = ?1 AND (?6 = '' OR s.hash = ?6)"
        " AND r.tracer = ?2 AND r.lights = ?3 AND r.W = ?4 AND r.H = ?5 AND r.sim_method = 'exact'"
        " AND r.params NOT LIKE '%subsample=%' ORDER BY r.id LIMIT 1",
        R->dbpath, e, "ssIiis", i >= 0 ? R->scene_name[i] : scene, tracer, (int64_t)lights, R->W, R->H,
        i >= 0 ? R->scene_hash[i] : "");
    if (!st) return -1;
    int rc = sqlite3_step(st), found = 0;
    if (rc == SQLITE_ROW && sqlite3_column_text(st, 0)) {
        snprintf(out, n, "%s", (const char *)sqlite3_column_text(st, 0));
        found = 1;
    }
    if (rt_report_done(st, rc, R->dbpath, e) < 0) return -1;
    return found;
}

int rt_report_scenes(const rt_report *R, FILE *out, rt_err *e)
{
    if (R->csv) fprintf(out, "scene,triangles,pv_primary,pv_primary_shadow,W,H\n");
    else
        fprintf(out,
                "\n### Scenes (the paper's Figure 3 statistics), %dx%d\n\n| scene | triangles | potentially visible, "
                "primary | primary + shadow | paper |\n|---|---|---|---|---|\n",
                R->W, R->H);
    for (int i = 0; i < R->nscenes; i++) {
        const char *sc = R->scenes[i];
        sqlite3_stmt *st = rt_report_stmt(R->h, "SELECT triangles FROM scenes WHERE name = ?1 AND hash = ?2 ORDER BY id LIMIT 1",
                                          R->dbpath, e, "ss", R->scene_name[i], R->scene_hash[i]);
        if (!st) return -1;
        int64_t tri = 0;
        int rc = sqlite3_step(st);
        if (rc == SQLITE_ROW) tri = sqlite3_column_int64(st, 0);
        if (rt_report_done(st, rc, R->dbpath, e) < 0) return -1;
        char stats[1024];
        double pvp = NAN, pva = NAN;
        const char *ref = rt_tracer_reference()->name;
        int f = run_stats(R, sc, ref, 7, stats, sizeof stats, e);
        if (f > 0) {
            stat_of(stats, "pv_primary", &pvp);
            stat_of(stats, "pv_all", &pva);
        } else if (f == 0 && (f = run_stats(R, sc, ref, 0, stats, sizeof stats, e)) > 0) {
            stat_of(stats, "pv_primary", &pvp);
        }
        if (f < 0) return -1;
        const char *paper = !strcmp(sc, "room")          ? "47K; 6.6K; 7.7K"
                            : !strcmp(sc, "grove")       ? "164K; 127K; 142K"
                            : !strcmp(sc, "sphereflake") ? "797K; 258K; 535K"
                                                         : "";
        if (R->csv) {
            fprintf(out, "%s,%" PRId64 ",", sc, tri);
            if (!isnan(pvp)) fprintf(out, "%.0f", pvp);
            fputc(',', out);
            if (!isnan(pva)) fprintf(out, "%.0f", pva);
            fprintf(out, ",%d,%d\n", R->W, R->H);
        } else {
            fprintf(out, "| %s | %" PRId64 " | ", sc, tri);
            if (!isnan(pvp)) fprintf(out, "%.0f", pvp);
            else fputs("—", out);
            fputs(" | ", out);
            if (!isnan(pva)) fprintf(out, "%.0f", pva);
            else fputs("—", out);
            fprintf(out, " | %s |\n", paper);
        }
    }
    return rt_report_flush(out, e);
}

int rt_report_tables(const rt_report *R, const char *figure, FILE *out, rt_err *e)
{
    int all = !strcmp(figure, "all"), fig = 0;
    if (!all && strcmp(figure, "scenes")) {
        if (strlen(figure) != 1 || figure[0] < '4' || figure[0] > '9')
            return rt_errf(e, "figure '%s' is not 4..9, scenes or all", figure);
        fig = figure[0] - '0';
    }
    if (!R->csv) fprintf(out, "# raytraffic report: %s\n", R->dbpath);
    if (!R->csv && all && rt_report_summary(R, out, e) < 0) return -1;
    if (!R->csv)
        fprintf(out,
                "\n## Figures\n\nTraffic in MB (2^20 bytes) between DRAM and a fully associative LRU cache "
                "with 64-byte lines (write-back, write-allocate). Reduction = baseline / dynamic - 1 in percent "
                "(the paper's formula); where dynamic moves more, its factor instead: \"3.60× more\" = 3.60 times "
                "the baseline's.\n");
    if ((all || !strcmp(figure, "scenes")) && rt_report_scenes(R, out, e) < 0) return -1;
    int shown = 0;
    for (int i = 0; i < R->nscenes; i++) {
        int f = fig_primary_of(R, R->scenes[i]);
        if ((all || (f && fig == f)) && rt_report_primary(R, R->scenes[i], out, e) < 0) return -1;
        shown += f && fig == f;
    }
    for (int i = 0; i < R->nscenes; i++) {
        int f = fig_primary_of(R, R->scenes[i]);
        if ((all || (f && fig == f + 3)) && rt_report_shadows(R, R->scenes[i], out, e) < 0) return -1;
        shown += f && fig == f + 3;
    }
    static const char *const fig_scene[3] = {"room", "grove", "sphereflake"};
    if (fig && !shown)
        return rt_errf(e, "%s: nothing to show for figure %d: no run of the paper's %s at its parameters at %dx%d",
                       R->dbpath, fig, fig_scene[(fig - 4) % 3], R->W, R->H);
    return rt_report_flush(out, e);
}

/* ---- paper comparison ------------------------------------------------- */

#define MAX_PAPER_ROWS 64

typedef struct paper_row {
    char scene[32]; /* room, grove, sphereflake */
    int kb;         /* cache size, KB */
    double v[10];   /* the table's columns; NAN where the paper shows a dash */
} paper_row;

/* Reads one of the paper's tables (header line, then scene,kb,v...):
 * the number of rows, or -1 with "path: reason". */
static int load_csv(const char *path, paper_row *rows, int max, int ncols, rt_err *e)
{
    FILE *f = fopen(path, "r");
    if (!f) return rt_errf(e, "%s: cannot read the paper's tables", path);
    char line[1024];
    int n = 0;
    if (fgets(line, sizeof line, f)) {
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
    }
    int bad = ferror(f);
    fclose(f);
    return bad ? rt_errf(e, "%s: cannot read the paper's tables", path) : n;
}

/* The data file in the source tree, else in the installed data folder. */
static const char *data_path(const char *name, char *buf, size_t n)
{
    snprintf(buf, n, "%s/%s", RT_SRCDATADIR, name);
    if (access(buf, R_OK) == 0) return buf;
    snprintf(buf, n, "%s/%s", RT_DATADIR, name);
    return buf;
}

static void ratio_cell(const rt_report *R, FILE *out, double ours, double paper)
{
    if (R->csv) {
        fputc(',', out);
        if (!isnan(ours)) fprintf(out, "%.2f", ours);
        fputc(',', out);
        if (!isnan(paper)) fprintf(out, "%.2f", paper);
        return;
    }
    if (isnan(ours) || isnan(paper)) fputs(" | —", out);
    else if (paper != 0 && (ours > 0) == (paper > 0)) fprintf(out, " | %.2f / %.2f (%.2fx)", ours, paper, ours / paper);
    else fprintf(out, " | %.2f / %.2f", ours, paper);
}

/* The label of R's scene named name at the paper's parameters: its index
 * in R->scenes, or -1 when there is none (why then says why, '' when R has
 * no scene of that name at all), or -2 on a database error. */
static int paper_scene(const rt_report *R, const char *name, char *why, size_t n, rt_err *e)
{
    why[0] = 0;
    for (int i = 0; i < R->nscenes; i++) {
        if (strcmp(R->scene_name[i], name)) continue;
        char w[300];
        int f = fig_primary_why(R, R->scenes[i], w, sizeof w, e);
        if (f < 0) return -2;
        if (f) return i;
        snprintf(why, n, "%s", w);
    }
    return -1;
}

/* Whether R's resolution is the paper's (1024x1024): only then are
 * traffic volumes (MB) set beside the paper's; reductions, being ratios,
 * are compared at any resolution. */
static int paper_res(const rt_report *R) { return R->W == 1024 && R->H == 1024; }

/* "ours / paper" of two reductions (CSV: two columns). */
static void red_pair(const rt_report *R, FILE *out, double ours, double paper)
{
    char a[64], b[64];
    if (R->csv) {
        fprintf(out, ",%s,%s", rt_report_fmt_reduction(ours, 1, a, sizeof a), rt_report_fmt_reduction(paper, 1, b, sizeof b));
        return;
    }
    fprintf(out, " | %s / %s", rt_report_fmt_reduction(ours, 0, a, sizeof a), rt_report_fmt_reduction(paper, 0, b, sizeof b));
}

/* One scene's primary-ray points, ours (R's runs) and the paper's (its
 * rows of prim), at the paper's sizes; the number of points. */
static int primary_points(const rt_report *R, const char *sc, const char *name, const paper_row *prim, int np,
                          rt_report_point *ours, rt_report_point *paper, int max, rt_err *e)
{
    int n = 0;
    for (int k = 0; k < np && n < max; k++) {
        const paper_row *pr = &prim[k];
        if (strcmp(pr->scene, name)) continue;
        double g[3], r[3];
        int h[3];
        if (values3(R, sc, 0, (uint64_t)pr->kb * 1024, g, r, h, e) < 0) return -1;
        ours[n] = (rt_report_point){(uint64_t)pr->kb, {g[0], g[2]}, {r[0], r[2]}};
        paper[n] = (rt_report_point){(uint64_t)pr->kb, {pr->v[0], pr->v[2]}, {pr->v[3], pr->v[5]}};
        n++;
    }
    return n;
}

void rt_report_write_findings(FILE *out, const char *sc, const rt_report_findings *f, const rt_report_findings *paper)
{
    char a[64], b[64];
    fprintf(out, "- dynamic moves less geometry than recursive at %d of %d sizes", f->dyn_less, f->nsizes);
    if (paper) fprintf(out, " (paper: %d of %d)", paper->dyn_less, paper->nsizes);
    fprintf(out, ".\n- largest geometry reduction vs recursive: %s at %" PRIu64 " K",
            rt_report_fmt_reduction(f->best_red, 0, a, sizeof a), f->best_size);
    if (paper) fprintf(out, " (paper: %s at %" PRIu64 " K)", rt_report_fmt_reduction(paper->best_red, 0, b, sizeof b),
                       paper->best_size);
    fprintf(out, ".\n- dynamic moves more ray data than recursive at %d of %d sizes", f->ray_more, f->nsizes);
    if (paper) fprintf(out, " (paper: %d of %d)", paper->ray_more, paper->nsizes);
    fputs(".\n- total traffic: ", out);
    if (f->turn_size)
        fprintf(out, "dynamic moves more than recursive from %" PRIu64 " K on (%s there, %s at %" PRIu64 " K)",
                f->turn_size, rt_report_fmt_reduction(f->turn_red, 0, a, sizeof a),
                rt_report_fmt_reduction(f->last_total, 0, b, sizeof b), f->last_size);
    else if (f->nsizes)
        fprintf(out, "no crossover: dynamic moves less than recursive at %" PRIu64 " K (%s)", f->last_size,
                rt_report_fmt_reduction(f->last_total, 0, a, sizeof a));
    else fputs("no sizes to compare", out);
    if (paper) {
        if (paper->turn_size) fprintf(out, " (paper: from %" PRIu64 " K on)", paper->turn_size);
        else fputs(" (paper: no crossover)", out);
    }
    fputs(".\n", out);
    (void)sc;
}

/* Primary rays of one scene beside the paper's Figure 4-6 rows, then
 * (Markdown) the findings of both (rt_report_find). name is the paper's
 * scene name of label sc. */
static int compare_primary(const rt_report *R, const char *sc, const char *name, const paper_row *prim, int np,
                           FILE *out, rt_err *e)
{
    int mb = paper_res(R);
    if (R->csv)
        fprintf(out, "scene,cache_kb,geom_recursive_ours,geom_recursive_paper,geom_packet_ours,geom_packet_paper,"
                     "geom_dynamic_ours,geom_dynamic_paper,ray_dynamic_ours,ray_dynamic_paper,geomred_recursive_ours,"
                     "geomred_recursive_paper,totalred_recursive_ours,totalred_recursive_paper\n");
    else if (mb)
        fprintf(out,
                "\n### `%s`, primary rays: MB (ours / paper (ratio)) and reductions (ours / paper)\n\n| cache | geometry "
                "recursive | geometry packet | geometry dynamic | ray dynamic | geometry reduction vs recursive | total "
                "reduction vs recursive |\n|---|---|---|---|---|---|---|\n",
                sc);
    else
        fprintf(out,
                "\n### `%s`, primary rays: reductions vs recursive (ours / paper)\n\nTraffic volumes are not compared: "
                "ours are at %dx%d, the paper's at 1024x1024 (a run at the paper's resolution, `sweep -W 1024 -H 1024`, "
                "adds them); reductions are ratios and are compared.\n\n| cache | geometry reduction | total reduction "
                "|\n|---|---|---|\n",
                sc, R->W, R->H);
    for (int k = 0; k < np; k++) {
        const paper_row *pr = &prim[k];
        if (strcmp(pr->scene, name)) continue;
        double g[3], r[3];
        int h[3];
        if (values3(R, sc, 0, (uint64_t)pr->kb * 1024, g, r, h, e) < 0) return -1;
        double red = rt_report_reduction(g[0], g[2]), tot = rt_report_reduction(g[0] + r[0], g[2] + r[2]);
        if (R->csv) fprintf(out, "%s,%d", name, pr->kb);
        else fprintf(out, "| %d K", pr->kb);
        if (mb || R->csv) {
            ratio_cell(R, out, mb ? g[0] : NAN, pr->v[0]);
            ratio_cell(R, out, mb ? g[1] : NAN, pr->v[1]);
            ratio_cell(R, out, mb ? g[2] : NAN, pr->v[2]);
            ratio_cell(R, out, mb ? r[2] : NAN, pr->v[5]);
        }
        red_pair(R, out, red, pr->v[6]);
        red_pair(R, out, tot, pr->v[8]);
        fputs(R->csv ? "\n" : " |\n", out);
    }
    if (R->csv) return 0;
    rt_report_point ours[MAX_PAPER_ROWS], paper[MAX_PAPER_ROWS];
    int n = primary_points(R, sc, name, prim, np, ours, paper, MAX_PAPER_ROWS, e);
    if (n < 0) return -1;
    rt_report_findings fo, fp;
    rt_report_find(ours, n, &fo);
    rt_report_find(paper, n, &fp);
    if (!fo.nsizes) return 0;
    fprintf(out, "\nFindings for `%s` (ours, the paper's in brackets):\n", sc);
    rt_report_write_findings(out, sc, &fo, &fp);
    return 0;
}

/* Shadow rays of one scene: reductions vs recursive beside Figures 7-9. */
static int compare_shadows(const rt_report *R, const char *sc, const char *name, const paper_row *shad, int ns,
                           FILE *out, rt_err *e)
{
    if (R->csv)
        fprintf(out, "scene,cache_kb,light0_ours,light0_paper,light1_ours,light1_paper,light2_ours,light2_paper,"
                     "all_ours,all_paper\n");
    else
        fprintf(out,
                "\n### `%s` with shadows: %s reduction vs recursive (ours / paper)\n\n| cache | light 0 | light 1 | "
                "light 2 | all 3 |\n|---|---|---|---|---|\n",
                sc, R->total ? "total" : "geometry");
    for (int k = 0; k < ns; k++) {
        const paper_row *pr = &shad[k];
        if (strcmp(pr->scene, name)) continue;
        if (R->csv) fprintf(out, "%s,%d", name, pr->kb);
        else fprintf(out, "| %d K", pr->kb);
        for (int l = 0; l < 4; l++) {
            double g[3], r[3];
            int h[3];
            if (values3(R, sc, masks4[l], (uint64_t)pr->kb * 1024, g, r, h, e) < 0) return -1;
            red_pair(R, out, h[0] && h[2] ? red_vs(R, g, r, 0) : NAN, pr->v[2 * l]);
        }
        fputs(R->csv ? "\n" : " |\n", out);
    }
    return 0;
}

/* ---- agreement with the paper ------------------------------------------ */

int rt_report_within2(double ours, double paper)
{
    if (isnan(ours) || isnan(paper)) return 0;
    if (ours == 0 || paper == 0) return ours == paper;
    if ((ours > 0) != (paper > 0)) return 0;
    double a = fabs(ours), b = fabs(paper);
    return a <= 2 * b && b <= 2 * a;
}

/* Both tables of the paper, read once per call. */
typedef struct paper_tables {
    paper_row prim[MAX_PAPER_ROWS], shad[MAX_PAPER_ROWS];
    int np, ns;
} paper_tables;

/* The paper's reduction columns [first, first + n) of rows, as printed
 * (losses -100 (d / b - 1)), in the one formula (rt_report_reduction). */
static void paper_reductions(paper_row *rows, int nrows, int first, int n)
{
    for (int k = 0; k < nrows; k++)
        for (int c = first; c < first + n; c++) rows[k].v[c] = rt_report_paper_reduction(rows[k].v[c]);
}

static int load_tables(paper_tables *t, rt_err *e)
{
    char p1[4096], p2[4096];
    if ((t->np = load_csv(data_path("paper_primary.csv", p1, sizeof p1), t->prim, MAX_PAPER_ROWS, 10, e)) < 0) return -1;
    if ((t->ns = load_csv(data_path("paper_shadows.csv", p2, sizeof p2), t->shad, MAX_PAPER_ROWS, 8, e)) < 0) return -1;
    paper_reductions(t->prim, t->np, 6, 4);
    paper_reductions(t->shad, t->ns, 0, 8);
    return 0;
}

/* A reduction's distance from zero as judged for agreement: the percent
 * of a gain, and of a loss the excess factor (d / b - 1, negated), so that
 * "2x more" and "3x more" are within 2x of each other and "2x more" and
 * "5x more" are not (on b / d - 1 every loss lies in (-100%, 0) and all
 * would look alike). */
static double agree_scale(double red)
{
    if (isnan(red) || red >= 0) return red;
    return -100.0 * (1.0 / (1.0 + red / 100.0) - 1.0);
}

static void count_cell(rt_report_agree *a, int fig, double ours, double paper)
{
    if (isnan(ours) || isnan(paper)) return;
    a->cells[fig]++;
    a->within[fig] += rt_report_within2(ours, paper);
}

/* The agreement of scene label sc (the paper's scene name) with the
 * paper: cells within 2x (traffic volumes only at the paper's
 * resolution), and the findings of both (rt_report_find). */
static int agreement(const rt_report *R, const char *sc, const char *name, const paper_tables *t, rt_report_agree *a,
                     rt_err *e)
{
    memset(a, 0, sizeof *a);
    int mb = paper_res(R);
    for (int k = 0; k < t->np; k++) {
        const paper_row *pr = &t->prim[k];
        if (strcmp(pr->scene, name)) continue;
        double g[3], r[3];
        int h[3];
        if (values3(R, sc, 0, (uint64_t)pr->kb * 1024, g, r, h, e) < 0) return -1;
        /* the paper's columns: geometry and ray MB of the three tracers,
         * geometry and total reduction vs recursive and vs packet */
        const double ours[10] = {g[0], g[1], g[2], r[0], r[1], r[2], rt_report_reduction(g[0], g[2]),
                                 rt_report_reduction(g[1], g[2]), rt_report_reduction(g[0] + r[0], g[2] + r[2]),
                                 rt_report_reduction(g[1] + r[1], g[2] + r[2])};
        for (int c = mb ? 0 : 6; c < 10; c++)
            count_cell(a, 0, c < 6 ? ours[c] : agree_scale(ours[c]), c < 6 ? pr->v[c] : agree_scale(pr->v[c]));
        double red = ours[6], tot = ours[8];
        if (isnan(red) || isnan(tot)) continue;
        int mine = r[2] > r[0], theirs = pr->v[5] > pr->v[3];
        a->paper_ray_more += theirs;
        a->ray_both += mine && theirs;
    }
    rt_report_point ours[MAX_PAPER_ROWS], paper[MAX_PAPER_ROWS];
    int n = primary_points(R, sc, name, t->prim, t->np, ours, paper, MAX_PAPER_ROWS, e);
    if (n < 0) return -1;
    rt_report_findings fo, fp;
    rt_report_find(ours, n, &fo);
    rt_report_find(paper, n, &fp);
    a->nsizes = fo.nsizes;
    a->dyn_less = fo.dyn_less;
    a->ray_more = fo.ray_more;
    a->turn_kb = (int)fo.turn_size;
    a->paper_turn_kb = (int)fp.turn_size;
    for (int k = 0; k < t->ns; k++) {
        const paper_row *pr = &t->shad[k];
        if (strcmp(pr->scene, name)) continue;
        for (int l = 0; l < 4; l++) {
            double g[3], r[3];
            int h[3];
            if (values3(R, sc, masks4[l], (uint64_t)pr->kb * 1024, g, r, h, e) < 0) return -1;
            for (int c = 0; c < 2; c++)
                count_cell(a, 1, h[c] && h[2] ? agree_scale(red_vs(R, g, r, c)) : NAN, agree_scale(pr->v[2 * l + c]));
        }
    }
    return 0;
}

int rt_report_agreement(const rt_report *R, const char *sc, rt_report_agree *a, rt_err *e)
{
    paper_tables *t = rt_calloc(1, sizeof *t, e);
    if (!t) return -1;
    int i = rt_report_scene_index(R, sc);
    int rc = load_tables(t, e) < 0 ? -1 : agreement(R, sc, i >= 0 ? R->scene_name[i] : sc, t, a, e);
    free(t);
    return rc;
}

/* The turn sizes agree when within one power of two of each other. */
static int turn_agrees(const rt_report_agree *a)
{
    return a->turn_kb && a->paper_turn_kb && a->turn_kb <= 2 * a->paper_turn_kb && a->paper_turn_kb <= 2 * a->turn_kb;
}

static void pct(FILE *out, int n, int d)
{
    if (d) fprintf(out, "%d/%d (%.0f%%)", n, d, 100.0 * n / d);
    else fputs("—", out);
}

/* Whether the database holds runs of a named model other than lean (then
 * --compare-paper adds the agreement table for every model): 1, 0, -1. */
static int has_named_model(const rt_report *R, rt_err *e)
{
    sqlite3_stmt *st = rt_report_stmt(
        R->h, "SELECT 1 FROM runs WHERE sim_method = 'exact' AND sim_params LIKE 'model=%' LIMIT 1", R->dbpath, e, "");
    if (!st) return -1;
    int rc = sqlite3_step(st), found = rc == SQLITE_ROW;
    if (rt_report_done(st, rc, R->dbpath, e) < 0) return -1;
    return found;
}

/* Whether the database holds exact runs of R's model (its sim_params) in
 * layout geom: 1, 0, -1. */
static int has_layout(const rt_report *R, int geom, rt_err *e)
{
    char lay[48];
    rt_report_layout_key(geom, lay, sizeof lay);
    sqlite3_stmt *st = rt_report_stmt(R->h,
                                      "SELECT 1 FROM runs r WHERE r.sim_method = 'exact' AND r.sim_params = ?1 AND (CASE "
                                      "WHEN ?2 = '' THEN instr(r.params, 'layout=') = 0 ELSE instr(r.params || ' ', ?2) > 0 "
                                      "END) LIMIT 1",
                                      R->dbpath, e, "ss", R->sim_params, lay);
    if (!st) return -1;
    int rc = sqlite3_step(st), found = rc == SQLITE_ROW;
    if (rt_report_done(st, rc, R->dbpath, e) < 0) return -1;
    return found;
}

/* The agreement table's rows of one model and layout (M), labelled mn. */
static int agreement_rows(const rt_report *R, const rt_report *M, const char *mn, const paper_tables *t, FILE *out,
                          rt_err *e)
{
    static const char *const sc3[3] = {"room", "grove", "sphereflake"};
    for (int si = 0; si < 3; si++) {
        char why[300];
        int i = paper_scene(R, sc3[si], why, sizeof why, e);
        if (i == -2) return -1;
        if (i < 0) continue;
        rt_report_agree a;
        if (agreement(M, R->scenes[i], sc3[si], t, &a, e) < 0) return -1;
        if (!a.cells[0] && !a.cells[1]) continue;
        if (R->csv) {
            fprintf(out, "%s,%s,%d,%d,%d,%d,%d,%d,%d,%d,%d,%d,%d\n", mn, sc3[si], a.cells[0], a.within[0], a.cells[1],
                    a.within[1], a.nsizes, a.dyn_less, a.ray_more, a.paper_ray_more, a.ray_both, a.turn_kb,
                    a.paper_turn_kb);
            continue;
        }
        fprintf(out, "| %s | %s | ", mn, sc3[si]);
        pct(out, a.within[0], a.cells[0]);
        fputs(" | ", out);
        pct(out, a.within[1], a.cells[1]);
        fprintf(out, " | %s (%d of %d) | %s (%d of %d; paper %d) | ", a.nsizes && a.dyn_less == a.nsizes ? "yes" : "no",
                a.dyn_less, a.nsizes, a.paper_ray_more && a.ray_both == a.paper_ray_more ? "yes" : "no", a.ray_more,
                a.nsizes, a.paper_ray_more);
        if (a.turn_kb) fprintf(out, "%s: %d K", turn_agrees(&a) ? "yes" : "no", a.turn_kb);
        else fputs("no: never", out);
        fprintf(out, " (%d K) |\n", a.paper_turn_kb);
    }
    return 0;
}

/* The agreement table: per model (R's, or every model), per layout the
 * database holds runs of under that model (the model's own first, so the
 * models' layouts are side by side) and per paper scene, the share of
 * Figure 4-9 cells within 2x of the paper's and whether each of the
 * paper's findings holds. */
static int agreement_table(const rt_report *R, const paper_tables *t, FILE *out, rt_err *e)
{
    if (R->csv)
        fprintf(out, "model,scene,fig4_6_cells,fig4_6_within2,fig7_9_cells,fig7_9_within2,sizes,dynamic_less_geometry,"
                     "ray_more,paper_ray_more,ray_more_where_paper,turn_kb,paper_turn_kb\n");
    else
        fprintf(out, "\n### Agreement with the paper, %dx%d (paper at 1024x1024)\n\nCells within 2x of the paper's (same "
                     "sign, ratio 1/2..2); findings: dynamic moves less geometry than recursive at every size; dynamic "
                     "moves more ray data than recursive wherever the paper's does; total traffic turns against "
                     "dynamic (stays at or below zero reduction from that size on) within one power of two of the "
                     "paper's size.\n\n| model | scene | Fig. 4-6 cells within 2x "
                     "| Fig. 7-9 cells within 2x | less geometry at every size | ray overhead | turns against dynamic "
                     "at (paper) |\n|---|---|---|---|---|---|---|\n",
                R->W, R->H);
    rt_report M = *R;
    for (int m = 0; m < RT_EXP_NMODELS; m++) {
        if (R->model >= 0 && m != R->model) continue;
        if (rt_report_set_model(&M, m, e) < 0) return -1;
        const int own = M.geom;
        /* the model's own layout, then every other layout it has runs in */
        for (int li = -1; li <= RT_GEOM_PBRT64; li++) {
            if (li == own) continue;
            M.geom = li < 0 ? own : li;
            int has = li < 0 ? 1 : has_layout(&M, M.geom, e);
            if (has < 0) return -1;
            if (!has) continue;
            char mn[64];
            if (li < 0) snprintf(mn, sizeof mn, "%s", rt_exp_model_get(m)->name);
            else snprintf(mn, sizeof mn, "%s (layout %s)", rt_exp_model_get(m)->name, rt_render_geom_name(li));
            if (agreement_rows(R, &M, mn, t, out, e) < 0) return -1;
        }
    }
    return 0;
}

int rt_report_compare_paper(const rt_report *R, FILE *out, rt_err *e)
{
    paper_tables *t = rt_calloc(1, sizeof *t, e);
    if (!t) return -1;
    int rc = -1;
    if (load_tables(t, e) < 0) goto done;
    static const char *const sc3[3] = {"room", "grove", "sphereflake"};
    int idx[3], any = 0;
    char why[3][300];
    for (int si = 0; si < 3; si++) {
        idx[si] = paper_scene(R, sc3[si], why[si], sizeof why[si], e);
        if (idx[si] == -2) goto done;
        any |= idx[si] >= 0;
    }
    if (!R->csv) {
        fprintf(out, "\n## Comparison with the paper, %dx%d (the paper's at 1024x1024)\n", R->W, R->H);
        for (int si = 0; si < 3; si++)
            if (idx[si] < 0 && why[si][0])
                fprintf(out, "\nComparison omitted for `%s`: not the paper's setup (%s).\n", sc3[si], why[si]);
        if (!any) {
            fputs("\nNo scene of the paper at the paper's parameters: nothing to compare.\n", out);
            rc = rt_report_flush(out, e);
            goto done;
        }
    }
    for (int si = 0; si < 3; si++)
        if (idx[si] >= 0 && compare_primary(R, R->scenes[idx[si]], sc3[si], t->prim, t->np, out, e) < 0) goto done;
    for (int si = 0; si < 3; si++)
        if (idx[si] >= 0 && compare_shadows(R, R->scenes[idx[si]], sc3[si], t->shad, t->ns, out, e) < 0) goto done;
    if (!R->csv)
        fprintf(out, "\nWhy numbers differ: our room and grove are procedural stand-ins of the same size, not the "
                     "paper's models; our k-d tree (SAH, pbrt costs, no mailboxing) and the paper's differ in depth and "
                     "leaf size, which moves queue points and so ray traffic; our memory model counts shading reads, "
                     "hit records and the ray buffer explicitly; runs below 1024x1024 use fewer pixels than the "
                     "paper's.\n");
    /* the agreement table: asked for a model, or the database holds a
     * named model's runs (a database of default runs prints as before) */
    int named = R->model >= 0 ? 1 : has_named_model(R, e);
    if (named < 0) goto done;
    if (named && agreement_table(R, t, out, e) < 0) goto done;
    rc = rt_report_flush(out, e);
done:
    free(t);
    return rc;
}

/* ---- the summary ------------------------------------------------------- */


/* One scene's findings as sentences (numbers ours, the paper's in
 * brackets when paper is non-NULL). */
static void finding_sentences(FILE *out, const rt_report_findings *f, const rt_report_findings *paper)
{
    char a[64], b[64];
    if (!f->nsizes) {
        fputs("No size has both the recursive and the dynamic run.", out);
        return;
    }
    fprintf(out, "Dynamic moves less geometry than recursive at %d of %d sizes", f->dyn_less, f->nsizes);
    if (paper) fprintf(out, " (paper: %d of %d)", paper->dyn_less, paper->nsizes);
    fprintf(out, "; its largest reduction is %s at %" PRIu64 " K", rt_report_fmt_reduction(f->best_red, 0, a, sizeof a),
            f->best_size / 1024);
    if (paper)
        fprintf(out, " (paper: %s at %" PRIu64 " K)", rt_report_fmt_reduction(paper->best_red, 0, b, sizeof b),
                paper->best_size);
    fprintf(out, ". It moves more ray data than recursive at %d of %d sizes", f->ray_more, f->nsizes);
    if (paper) fprintf(out, " (paper: %d of %d)", paper->ray_more, paper->nsizes);
    fputs(". ", out);
    if (f->turn_size)
        fprintf(out, "Total traffic turns against dynamic from %" PRIu64 " K on (%s there, %s at %" PRIu64 " K)",
                f->turn_size / 1024, rt_report_fmt_reduction(f->turn_red, 0, a, sizeof a),
                rt_report_fmt_reduction(f->last_total, 0, b, sizeof b), f->last_size / 1024);
    else
        fprintf(out, "Total traffic does not turn against dynamic for good (%s at %" PRIu64 " K)",
                rt_report_fmt_reduction(f->last_total, 0, a, sizeof a), f->last_size / 1024);
    if (paper) {
        if (paper->turn_size) fprintf(out, " (paper: from %" PRIu64 " K on)", paper->turn_size);
        else fputs(" (paper: never)", out);
    }
    fputs(".", out);
}

#define PAPER_TRACERS_R "tracer IN @NAVRATIL@"

/* The provenance query's runs: the figures' runs (the paper's three
 * tracers, exact, full frame, the k-d tree) at R's resolution. */
#define SUMMARY_RUNS                                                                                                 \
    " FROM runs r WHERE r.W = ?1 AND r.H = ?2 AND r.sim_method = 'exact' AND r.tracer IN @NAVRATIL@"               \
    " AND r.params NOT LIKE '%subsample=%' AND instr(r.params, 'accel=') = 0 AND @DIMS@"

/* Column 0 of the first row of sql (SUMMARY_RUNS bound) into buf; '' if none. */
static int summary_text(const rt_report *R, const char *sql, char *buf, size_t n, rt_err *e)
{
    buf[0] = 0;
    sqlite3_stmt *st = rt_report_stmt(R->h, sql, R->dbpath, e, "ii", R->W, R->H);
    if (!st) return -1;
    int rc = sqlite3_step(st);
    if (rc == SQLITE_ROW && sqlite3_column_text(st, 0)) snprintf(buf, n, "%s", (const char *)sqlite3_column_text(st, 0));
    return rt_report_done(st, rc, R->dbpath, e);
}

/* One count (column 0 of sql, ?1 ?2 = R's W, H) into *n. */
static int summary_count(const rt_report *R, const char *sql, long long *n, rt_err *e)
{
    char b[32];
    if (summary_text(R, sql, b, sizeof b, e) < 0) return -1;
    *n = atoll(b);
    return 0;
}

/* The runs of the paper's tracers that the figures leave out because they
 * are of another setup, each with the option that selects it: a figure
 * holds one value of every dimension it does not vary. */
static int summary_others(const rt_report *R, FILE *out, rt_err *e)
{
    char res[256] = "";
    sqlite3_stmt *st = rt_report_stmt(R->h,
                                      "SELECT DISTINCT W, H FROM runs WHERE sim_method = 'exact' AND " PAPER_TRACERS_R
                                      " AND params NOT LIKE '%subsample=%' AND (W <> ?1 OR H <> ?2) ORDER BY W * H DESC",
                                      R->dbpath, e, "ii", R->W, R->H);
    if (!st) return -1;
    int rc;
    size_t w = 0;
    while ((rc = sqlite3_step(st)) == SQLITE_ROW && w + 64 < sizeof res)
        w += (size_t)snprintf(res + w, sizeof res - w, "%s%dx%d (`-W %d -H %d`)", w ? ", " : "",
                              sqlite3_column_int(st, 0), sqlite3_column_int(st, 1), sqlite3_column_int(st, 0),
                              sqlite3_column_int(st, 1));
    if (rt_report_done(st, rc, R->dbpath, e) < 0) return -1;
    long long accel, sub, approx, model, layout, dims;
    if (summary_count(R, "SELECT COUNT(*) FROM runs WHERE " PAPER_TRACERS_R " AND instr(params, 'accel=') > 0 AND ?1 + ?2 > 0",
                      &accel, e) < 0 ||
        summary_count(R, "SELECT COUNT(*) FROM runs WHERE " PAPER_TRACERS_R " AND params LIKE '%subsample=%' AND ?1 + ?2 > 0",
                      &sub, e) < 0 ||
        summary_count(R, "SELECT COUNT(*) FROM runs WHERE " PAPER_TRACERS_R " AND sim_method <> 'exact' AND ?1 + ?2 > 0",
                      &approx, e) < 0 ||
        summary_count(R,
                      R->model < 0 ? "SELECT COUNT(*) FROM runs WHERE " PAPER_TRACERS_R " AND sim_method = 'exact' AND "
                                     "sim_params LIKE 'model=%' AND ?1 + ?2 > 0"
                                   : "SELECT COUNT(*) FROM runs WHERE " PAPER_TRACERS_R " AND sim_method = 'exact' AND "
                                     "sim_params NOT LIKE 'model=%' AND ?1 + ?2 > 0",
                      &model, e) < 0 ||
        summary_count(R, "SELECT COUNT(*) FROM runs WHERE " PAPER_TRACERS_R " AND instr(params, 'layout=') > 0 AND ?1 + ?2 > 0",
                      &layout, e) < 0 ||
        summary_count(R, "SELECT COUNT(*) FROM runs r WHERE r." PAPER_TRACERS_R " AND NOT @DIMS@ AND ?1 + ?2 > 0", &dims,
                      e) < 0)
        return -1;
    if (!res[0] && !accel && !sub && !approx && !model && !(R->model < 0 && layout) && !dims) return 0;
    fputs("- Not in the figures (another setup, each with the option that shows it):", out);
    const char *sep = " ";
    if (res[0]) fprintf(out, "%sruns at %s", sep, res), sep = "; ";
    if (accel) fprintf(out, "%s%lld on another structure (`--figure accel`)", sep, accel), sep = "; ";
    if (model)
        fprintf(out, "%s%lld of %s (`--model %s`)", sep, model, R->model < 0 ? "a named model" : "another model",
                R->model < 0 ? "paper" : "lean"),
            sep = "; ";
    if (R->model < 0 && layout) fprintf(out, "%s%lld in another layout (`--model M --layout L`)", sep, layout), sep = "; ";
    if (dims)
        fprintf(out, "%s%lld of another replacement policy, hierarchy, core count, light model or instancing (their "
                     "own reports)", sep, dims), sep = "; ";
    if (sub || approx)
        fprintf(out, "%s%lld reduced (subsampled) and %lld approximate runs (`--appendix`)", sep, sub, approx);
    fputs(".\n", out);
    return 0;
}

int rt_report_summary(const rt_report *R, FILE *out, rt_err *e)
{
    char nruns[32], first[64], last[64], rev[200], cmd[1024], ver[64], nrev[32];
    if (summary_text(R, "SELECT COUNT(*)" SUMMARY_RUNS, nruns, sizeof nruns, e) < 0 ||
        summary_text(R, "SELECT MIN(r.created)" SUMMARY_RUNS, first, sizeof first, e) < 0 ||
        summary_text(R, "SELECT MAX(r.created)" SUMMARY_RUNS, last, sizeof last, e) < 0 ||
        summary_text(R, "SELECT r.git_rev" SUMMARY_RUNS " GROUP BY r.git_rev ORDER BY COUNT(*) DESC, r.git_rev LIMIT 1",
                     rev, sizeof rev, e) < 0 ||
        summary_text(R, "SELECT COUNT(DISTINCT r.git_rev)" SUMMARY_RUNS, nrev, sizeof nrev, e) < 0 ||
        summary_text(R, "SELECT r.tool_version" SUMMARY_RUNS " GROUP BY r.tool_version ORDER BY COUNT(*) DESC LIMIT 1",
                     ver, sizeof ver, e) < 0 ||
        summary_text(R, "SELECT r.command" SUMMARY_RUNS " GROUP BY r.command ORDER BY COUNT(*) DESC, r.command LIMIT 1",
                     cmd, sizeof cmd, e) < 0)
        return -1;
    char preset[64] = "none (explicit options)";
    const char *p = strstr(cmd, "--preset");
    if (p) {
        p += 8;
        if (*p == '=' || *p == ' ') p++;
        size_t l = strcspn(p, " ");
        if (l) snprintf(preset, sizeof preset, "%.*s", (int)l, p);
    }
    fprintf(out, "\n## Summary\n\n");
    fprintf(out, "- What was run: %s exact runs of the recursive, packet and dynamic tracers at %dx%d on %d scene%s, ",
            nruns, R->W, R->H, R->nscenes, R->nscenes == 1 ? "" : "s");
    if (R->nsizes)
        fprintf(out, "%d cache sizes from %" PRIu64 " K to %" PRIu64 " K", R->nsizes, R->sizes[0] / 1024,
                R->sizes[R->nsizes - 1] / 1024);
    fprintf(out, " (fully associative LRU, 64-byte lines, %s), the k-d tree%s%s.\n", R->policy,
            R->model >= 0 ? ", model " : "", R->model >= 0 ? rt_exp_model_get(R->model)->name : "");
    fprintf(out, "- Revision: %s (raytraffic %s)", rev[0] ? rev : "unknown", ver[0] ? ver : "unknown");
    if (atoi(nrev) > 1) fprintf(out, "; the runs come from %s revisions, this one the most common", nrev);
    fprintf(out, ".\n- Date: %s (first run %s).\n", last[0] ? last : "unknown", first[0] ? first : "unknown");
    fprintf(out, "- Command: `%s`.\n- Preset: %s.\n", cmd[0] ? cmd : "unknown", preset);
    if (summary_others(R, out, e) < 0) return -1;
    fputs("\n### Findings\n", out);
    paper_tables *t = rt_calloc(1, sizeof *t, e);
    if (!t) return -1;
    int rc = -1;
    if (load_tables(t, e) < 0) goto done;
    for (int i = 0; i < R->nscenes; i++) {
        const char *sc = R->scenes[i];
        rt_report_point pts[RT_REPORT_MAXSIZES];
        int n = 0;
        for (int k = 0; k < R->nsizes; k++) {
            double g[3], r[3];
            int h[3];
            if (values3(R, sc, 0, R->sizes[k], g, r, h, e) < 0) goto done;
            pts[n++] = (rt_report_point){R->sizes[k], {g[0], g[2]}, {r[0], r[2]}};
        }
        rt_report_findings f, fp;
        rt_report_find(pts, n, &f);
        char why[300];
        int fig = fig_primary_why(R, sc, why, sizeof why, e);
        if (fig < 0) goto done;
        const rt_report_findings *paper = NULL;
        if (fig) {
            rt_report_point po[MAX_PAPER_ROWS], pp[MAX_PAPER_ROWS];
            int np = primary_points(R, sc, R->scene_name[i], t->prim, t->np, po, pp, MAX_PAPER_ROWS, e);
            if (np < 0) goto done;
            rt_report_find(pp, np, &fp);
            paper = &fp;
        }
        fprintf(out, "\n**%s**", sc);
        if (fig) fprintf(out, " (Figure %d; the paper's values in brackets, at 1024x1024)", fig);
        else if (why[0]) fprintf(out, " (not the paper's setup: %s)", why);
        fputs(": ", out);
        finding_sentences(out, &f, paper);
        fputc('\n', out);
    }
    rc = rt_report_flush(out, e);
done:
    free(t);
    return rc;
}

/* ---- tidy tables (CSV, JSON) ------------------------------------------- */

/* Writes s as a JSON string. */
static void json_str(FILE *f, const char *s)
{
    fputc('"', f);
    for (const unsigned char *p = (const unsigned char *)s; *p; p++) {
        if (*p == '"' || *p == '\\') fprintf(f, "\\%c", *p);
        else if (*p < 0x20) fprintf(f, "\\u%04x", *p);
        else fputc(*p, f);
    }
    fputc('"', f);
}

/* Writes s as one CSV field (quoted when it holds a comma, quote or line
 * break). */
static void csv_str(FILE *f, const char *s)
{
    if (!strpbrk(s, ",\"\n\r")) {
        fputs(s, f);
        return;
    }
    fputc('"', f);
    for (const char *p = s; *p; p++) {
        if (*p == '"') fputc('"', f);
        fputc(*p, f);
    }
    fputc('"', f);
}

/* Column i of st's current row as a value: integers as they are, reals in
 * full precision (%.17g), text quoted; NULL as an empty CSV field or
 * JSON null. */
static void tidy_value(FILE *f, sqlite3_stmt *st, int i, int json)
{
    switch (sqlite3_column_type(st, i)) {
    case SQLITE_INTEGER: fprintf(f, "%lld", (long long)sqlite3_column_int64(st, i)); break;
    case SQLITE_FLOAT: fprintf(f, "%.17g", sqlite3_column_double(st, i)); break;
    case SQLITE_NULL:
        if (json) fputs("null", f);
        break;
    default: {
        const char *t = (const char *)sqlite3_column_text(st, i);
        if (json) json_str(f, t ? t : "");
        else csv_str(f, t ? t : "");
    }
    }
}

/* Whether the runs table has the columns of schema 6 (a report reads
 * older files as they are). */
static int has_v6(sqlite3 *h)
{
    sqlite3_stmt *st;
    int r = 0;
    if (sqlite3_prepare_v2(h, "SELECT 1 FROM pragma_table_info('runs') WHERE name = 'hierarchy'", -1, &st, NULL) ==
        SQLITE_OK)
        r = sqlite3_step(st) == SQLITE_ROW;
    sqlite3_finalize(st);
    return r;
}

/* The rows of one figure (4-9) of scene label sc, long format: one row
 * per run x cache size x class, every configuration column, counters in
 * bytes and line touches. The runs are the figure's own: those
 * rt_report_value reads (R's resolution, model or default setup, the k-d
 * tree, full frame; the dynamic run scheduled for each size; packets
 * included at every size). */
static sqlite3_stmt *tidy_stmt(const rt_report *R, const char *sc, int fig, int kind, const char *table, rt_err *e)
{
    int i = rt_report_scene_index(R, sc);
    if (i < 0) {
        rt_errf(e, "%s: no scene %s", R->dbpath, sc);
        return NULL;
    }
    char lay[48];
    rt_report_layout_key(R->geom, lay, sizeof lay);
    const char *dims = has_v6(R->h) ? "r.repl, r.hierarchy, r.cores, r.light_model, r.instances"
                                    : "'lru' AS repl, '' AS hierarchy, 1 AS cores, 'point' AS light_model, "
                                      "'flatten' AS instances";
    char sql[4096];
    snprintf(sql, sizeof sql,
             "SELECT '%s' AS tbl, %d AS figure, s.name AS scene, s.params AS scene_params, s.hash AS scene_hash, r.id AS run_id,"
             " r.tracer, CASE WHEN instr(r.params, 'accel=') > 0 THEN 'other' ELSE '' END AS accel, r.W, r.H,"
             " r.lights, r.sched_size, r.gmax, r.params, r.sim_method, r.sim_params, %s, c.size AS cache_size,"
             " c.line, c.assoc, c.policy, k.grp AS class_group, t.class, t.accesses, t.read_misses, t.write_misses,"
             " t.writebacks, t.wt_bytes, t.traffic_bytes"
             " FROM runs r JOIN scenes s ON s.id = r.scene_id JOIN traffic t ON t.run_id = r.id"
             " JOIN cache_configs c ON c.id = t.config_id JOIN classes k ON k.name = t.class"
             " WHERE s.name = ?1 AND s.hash = ?2 AND r.W = ?3 AND r.H = ?4 AND r.tracer IN (?5, ?6, ?7)"
             " AND r.sim_method = 'exact' AND r.params NOT LIKE '%%subsample=%%' AND r.params NOT LIKE '%%mode=%%'"
             " AND instr(r.params, 'accel=') = 0 AND c.line = 64 AND c.assoc = 0 AND (r.sched_size = 0 OR"
             " r.sched_size = c.size) AND @DIMS@ AND (%s) AND %s"
             " ORDER BY r.lights, c.size, CASE r.tracer WHEN ?5 THEN 0 WHEN ?6 THEN 1 ELSE 2 END, t.class",
             table, fig, dims, kind == 0 ? "r.lights = 0" : "r.lights IN (1, 2, 4, 7)",
             R->model < 0 ? "c.policy = 'wb-wa' AND r.sim_params NOT LIKE 'model=%' AND instr(r.params, 'layout=') = 0"
                            " AND instr(r.params, 'queue_stores=') = 0"
                          : "c.policy = ?8 AND r.sim_params = ?9 AND (CASE WHEN ?10 = '' THEN instr(r.params, "
                            "'layout=') = 0 ELSE instr(r.params || ' ', ?10) > 0 END) AND (r.sched_size = 0 OR "
                            "(instr(r.params, 'queue_stores=stream') > 0) = ?11)");
    return rt_report_stmt(R->h, sql, R->dbpath, e, R->model < 0 ? "ssiisss" : "ssiisssssi", R->scene_name[i],
                          R->scene_hash[i], R->W, R->H, tracer3(0), tracer3(1), tracer3(2), R->policy, R->sim_params,
                          lay, R->stream);
}

/* Writes one figure's tidy table: CSV with a header line, or a JSON
 * object {"figure", "scene", "caption", "columns", "rows"}. The number of
 * rows, or -1. */
static long tidy_table(const rt_report *R, const char *sc, int fig, int kind, const char *table, int json, FILE *out,
                       rt_err *e)
{
    if (strchr(table, '\'')) return rt_errf(e, "bad table name");
    sqlite3_stmt *st = tidy_stmt(R, sc, fig, kind, table, e);
    if (!st) return -1;
    int nc = sqlite3_column_count(st);
    char cap[512];
    char fn[32] = "";
    if (fig) snprintf(fn, sizeof fn, "Figure %d: ", fig);
    snprintf(cap, sizeof cap,
             "%s%s, %s, %dx%d; traffic in bytes between DRAM and a fully associative LRU cache with 64-byte "
             "lines (%s); one row per run x cache size x class",
             fn, sc, kind == 0 ? "primary rays" : "primary and shadow rays (lights 0, 1, 2, all)", R->W, R->H, R->policy);
    if (json) {
        fprintf(out, "{\"table\": \"%s\", \"figure\": %d, \"scene\": ", table, fig);
        json_str(out, sc);
        fputs(", \"caption\": ", out);
        json_str(out, cap);
        fputs(", \"columns\": [", out);
        for (int c = 0; c < nc; c++) {
            if (c) fputs(", ", out);
            json_str(out, sqlite3_column_name(st, c));
        }
        fputs("], \"rows\": [", out);
    } else {
        for (int c = 0; c < nc; c++) fprintf(out, "%s%s", c ? "," : "", sqlite3_column_name(st, c));
        fputc('\n', out);
    }
    long n = 0;
    int rc;
    while ((rc = sqlite3_step(st)) == SQLITE_ROW) {
        if (json) fputs(n ? ",\n  [" : "\n  [", out);
        for (int c = 0; c < nc; c++) {
            if (c) fputs(json ? ", " : ",", out);
            tidy_value(out, st, c, json);
        }
        fputs(json ? "]" : "\n", out);
        n++;
    }
    if (json) fputs("]}", out);
    if (rt_report_done(st, rc, R->dbpath, e) < 0) return -1;
    return n;
}

int rt_report_tidy(const rt_report *R, const char *figure, int json, const char *dir, FILE *log, FILE *out, rt_err *e)
{
    int all = !strcmp(figure, "all"), fig = 0;
    if (!all) {
        if (strlen(figure) != 1 || figure[0] < '4' || figure[0] > '9')
            return rt_errf(e, "--format %s: figure '%s' has no tidy table (4..9 or all)", json ? "json" : "csv", figure);
        fig = figure[0] - '0';
    }
    if (!json && all && !dir)
        return rt_errf(e, "--format csv writes one table per figure: give --out DIR for all of them, or --figure N "
                          "for one on stdout");
    if (dir && rt_plot_mkdir(dir, e) < 0) return -1;
    if (json && !dir) fprintf(out, "{\"database\": "), json_str(out, R->dbpath), fputs(", \"figures\": [\n", out);
    int shown = 0;
    /* the scene table (Figure 3), one table of its own */
    if (dir && all) {
        char path[4096];
        rt_out *o = NULL;
        rt_report S = *R;
        S.csv = 1;
        rt_plot_path(path, sizeof path, dir, "scenes", "", ".csv");
        FILE *to = rt_plot_open(path, &o, e);
        if (!to) return -1;
        if (rt_report_scenes(&S, to, e) < 0) {
            rt_out_abort(o);
            return -1;
        }
        if (rt_plot_commit(o, e) < 0) return -1;
        if (log) fprintf(log, "wrote %s\n", path);
    }
    for (int kind = 0; kind < 2; kind++) {
        for (int i = 0; i < R->nscenes; i++) {
            int f = fig_primary_of(R, R->scenes[i]);
            int tf = f ? f + 3 * kind : 0; /* the paper's figure number, 0 for another scene */
            if (fig && tf != fig) continue;
            /* one table: primary rays (Figures 4-6), or shadows (7-9) */
            char table[32];
            if (tf) snprintf(table, sizeof table, "figure%d", tf);
            else snprintf(table, sizeof table, "%s", kind ? "shadows" : "primary");
            FILE *to = out;
            rt_out *o = NULL;
            char path[4096];
            if (dir) {
                char name[40];
                snprintf(name, sizeof name, "%s-", table);
                rt_plot_path(path, sizeof path, dir, name, R->scenes[i], json ? ".json" : ".csv");
                if (!(to = rt_plot_open(path, &o, e))) return -1;
            } else if (json && shown) {
                fputs(",\n", out);
            }
            long n = tidy_table(R, R->scenes[i], tf, kind, table, json, to, e);
            if (n < 0) {
                if (o) rt_out_abort(o);
                return -1;
            }
            if (json && dir) fputc('\n', to);
            if (o && n == 0) { /* no rows: no file */
                rt_out_abort(o);
                continue;
            }
            if (o && rt_plot_commit(o, e) < 0) return -1;
            if (o && log) fprintf(log, "wrote %s (%ld rows)\n", path, n);
            shown++;
        }
    }
    if (json && !dir) fputs("\n]}\n", out);
    if (!shown)
        return rt_errf(e, "%s: nothing to show%s%s at %dx%d", R->dbpath, fig ? " for figure " : "", fig ? figure : "",
                       R->W, R->H);
    return rt_report_flush(out, e);
}

/* ---- the paper's values for plots -------------------------------------- */

int rt_report_paper_point(const rt_report *R, const char *label, uint64_t kb, double geom[3], double ray[3],
                          double shadow[4], rt_err *e)
{
    for (int k = 0; k < 3; k++) geom[k] = ray[k] = NAN;
    for (int l = 0; l < 4; l++) shadow[l] = NAN;
    char why[300];
    int f = fig_primary_why(R, label, why, sizeof why, e);
    if (f <= 0) return f;
    int i = rt_report_scene_index(R, label);
    paper_tables *t = rt_calloc(1, sizeof *t, e);
    if (!t) return -1;
    int found = 0;
    if (load_tables(t, e) < 0) {
        free(t);
        return -1;
    }
    for (int k = 0; k < t->np; k++)
        if (!strcmp(t->prim[k].scene, R->scene_name[i]) && (uint64_t)t->prim[k].kb == kb) {
            for (int c = 0; c < 3; c++) {
                geom[c] = t->prim[k].v[c];
                ray[c] = t->prim[k].v[3 + c];
            }
            found = 1;
        }
    for (int k = 0; k < t->ns; k++)
        if (!strcmp(t->shad[k].scene, R->scene_name[i]) && (uint64_t)t->shad[k].kb == kb) {
            for (int l = 0; l < 4; l++) shadow[l] = t->shad[k].v[2 * l];
            found = 1;
        }
    free(t);
    return found;
}
