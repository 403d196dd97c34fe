/*
 * treelet.c -- `report --figure treelet`: the two schedulers against their
 * unscheduled baselines. Treelet scheduling on a BVH (Aila and Karras
 * 2010; tracegen/treelet.c) is set beside the reference tracer on the same
 * BVH, and the dynamic scheduler on the k-d tree (Navratil et al. 2007) is
 * set beside the reference tracer on the k-d tree.
 *
 * Which runs play which part comes from the tracers' traits, not their
 * names: the reference tracer (RT_TR_REFERENCE) is the baseline on
 * whichever structure its run used (params "accel=X", else its default);
 * the tracers of figure RT_FIG_TREELET are the treelet schedulers; the
 * scheduled tracer of figure RT_FIG_NAVRATIL is the k-d scheduler. A
 * scheduled run counts at the cache size it was scheduled for.
 *
 * For every scene, mode (with its parameters), lighting, resolution,
 * treelet run variant (its own parameters, e.g. a ray window) and cache
 * size: total DRAM traffic (fully associative, 64-byte lines,
 * write-back write-allocate, exact runs) and its split into geometry
 * (classes node, index, tri, shade), ray (ray, hit), stack (stream: the
 * treelet tracer's spilled traversal stacks) and queue (queue, qtable);
 * then the saving of each scheduler against its baseline, the reduction
 * base / sched - 1 of every report (rt_report_reduction; a loss shown as
 * its factor, "3.60× more"). With a plot
 * folder, per (scene, mode, lighting, resolution, variant) a picture of
 * total and geometry traffic against cache size for the four runs.
 */
#include "analysis_int.h"
#include "experiment.h"

#include <errno.h>
#include <inttypes.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

enum { ROLE_BASE, ROLE_TREELET, ROLE_DYN, NROLE };
enum { C_GEO, C_RAY, C_STACK, C_QUEUE, C_TOTAL, NC };

typedef struct trow {
    char scene[128], mode[160], variant[160];
    int role, accel, lights, W, H;
    uint64_t size;
    double mb[NC];
} trow;

/* The mode part of a run key ("mode=path spp=1 bounces=4 ..." onward; ""
 * for the primary modes) and the part before it (the tracer's own). */
static void split_params(const char *params, char *own, size_t no, char *mode, size_t nm)
{
    const char *m = strstr(params, "mode=");
    snprintf(mode, nm, "%s", m ? m : "");
    size_t l = m ? (size_t)(m - params) : strlen(params);
    while (l && params[l - 1] == ' ') l--;
    snprintf(own, no, "%.*s", (int)l, params);
}

/* The structure a run used: "accel=X" in its key, else its default. */
static int run_accel(const rt_tracer *tr, const char *params)
{
    const char *a = strstr(params, "accel=");
    if (a) {
        char name[16];
        size_t l = strcspn(a + 6, " ");
        snprintf(name, sizeof name, "%.*s", (int)(l < 15 ? l : 15), a + 6);
        int k = rt_accel_from_name(name);
        if (k > 0) return k;
    }
    return tr->accel_default;
}

/* The tracer's own parameters without its structure. */
static void strip_accel(char *own)
{
    char *a = strstr(own, "accel=");
    if (!a) return;
    char *end = a + strcspn(a, " ");
    if (*end == ' ') end++;
    memmove(a, end, strlen(end) + 1);
    size_t l = strlen(own);
    while (l && own[l - 1] == ' ') own[--l] = 0;
}

static int role_of(const rt_tracer *tr)
{
    if (!tr) return -1;
    if (tr->traits & RT_TR_REFERENCE) return ROLE_BASE;
    if (tr->figures & RT_FIG_TREELET) return ROLE_TREELET;
    if ((tr->figures & RT_FIG_NAVRATIL) && (tr->traits & RT_TR_SCHEDULED)) return ROLE_DYN;
    return -1;
}

static long read_rows(sqlite3 *h, const char *dbpath, trow **out, rt_err *e)
{
    static const char sql[] =
        "SELECT s.name, r.tracer, r.params, r.lights, r.W, r.H, r.sched_size, c.size,"
        " SUM(CASE WHEN t.class IN ('node', 'index', 'tri', 'shade') THEN t.traffic_bytes ELSE 0 END),"
        " SUM(CASE WHEN t.class IN ('ray', 'hit') THEN t.traffic_bytes ELSE 0 END),"
        " SUM(CASE WHEN t.class = 'stream' THEN t.traffic_bytes ELSE 0 END),"
        " SUM(CASE WHEN t.class IN ('queue', 'qtable') THEN t.traffic_bytes ELSE 0 END),"
        " SUM(t.traffic_bytes)"
        " FROM traffic t JOIN runs r ON r.id = t.run_id JOIN cache_configs c ON c.id = t.config_id"
        " JOIN scenes s ON s.id = r.scene_id"
        " WHERE c.line = 64 AND c.assoc = 0 AND c.policy = 'wb-wa' AND r.sim_method = 'exact'"
        " AND r.params NOT LIKE '%subsample=%' AND r.params NOT LIKE '%sim=all-sizes%'"
        " AND (r.sched_size = 0 OR r.sched_size = c.size)"
        " GROUP BY r.id, c.id ORDER BY s.name, r.params, r.lights, r.W, c.size, r.tracer";
    sqlite3_stmt *st = rt_report_stmt(h, sql, dbpath, e, "");
    if (!st) return -1;
    trow *R = NULL;
    long n = 0, cap = 0;
    int rc;
    while ((rc = sqlite3_step(st)) == SQLITE_ROW) {
        const rt_tracer *tr = rt_tracer_find((const char *)sqlite3_column_text(st, 1));
        int role = role_of(tr);
        if (role < 0) continue;
        if (role == ROLE_DYN && sqlite3_column_int64(st, 6) == 0) continue;
        if (n == cap) {
            cap = cap ? 2 * cap : 64;
            trow *q = rt_reallocarray(R, (size_t)cap, sizeof *R, e);
            if (!q) {
                free(R);
                sqlite3_finalize(st);
                return -1;
            }
            R = q;
        }
        trow *p = &R[n++];
        memset(p, 0, sizeof *p);
        const char *params = (const char *)sqlite3_column_text(st, 2);
        snprintf(p->scene, sizeof p->scene, "%s", (const char *)sqlite3_column_text(st, 0));
        split_params(params ? params : "", p->variant, sizeof p->variant, p->mode, sizeof p->mode);
        p->role = role;
        p->accel = run_accel(tr, params ? params : "");
        strip_accel(p->variant);
        p->lights = sqlite3_column_int(st, 3);
        p->W = sqlite3_column_int(st, 4);
        p->H = sqlite3_column_int(st, 5);
        p->size = (uint64_t)sqlite3_column_int64(st, 7);
        for (int c = 0; c < NC; c++) p->mb[c] = sqlite3_column_double(st, 8 + c) / 1048576.0;
    }
    if (rt_report_done(st, rc, dbpath, e) < 0) {
        free(R);
        return -1;
    }
    *out = R;
    return n;
}

static int same_point(const trow *a, const trow *b)
{
    return !strcmp(a->scene, b->scene) && !strcmp(a->mode, b->mode) && a->lights == b->lights && a->W == b->W &&
           a->H == b->H && a->size == b->size;
}

/* The first row of role with a's point (and structure, accel > 0). */
static const trow *find(const trow *R, long n, const trow *a, int role, int accel)
{
    for (long i = 0; i < n; i++)
        if (R[i].role == role && same_point(&R[i], a) && (accel <= 0 || R[i].accel == accel)) return &R[i];
    return NULL;
}

static double saved_in(const trow *base, const trow *s, int c)
{
    if (!base || !s) return NAN;
    return rt_report_reduction(base->mb[c], s->mb[c]);
}
static double saved(const trow *base, const trow *s) { return saved_in(base, s, C_TOTAL); }

/* A reduction (rt_report_fmt_reduction) as a cell. */
static void red_cell(FILE *out, int csv, double v)
{
    char b[64];
    rt_report_fmt_reduction(v, csv, b, sizeof b);
    if (csv) fprintf(out, ",%s", b);
    else fprintf(out, " %s |", b);
}

static void cell(FILE *out, int csv, double v, const char *fmt)
{
    if (csv) {
        if (isnan(v)) fputs(",", out);
        else {
            fputc(',', out);
            fprintf(out, fmt, v);
        }
    } else if (isnan(v)) {
        fputs(" - |", out);
    } else {
        fputc(' ', out);
        fprintf(out, fmt, v);
        fputs(" |", out);
    }
}

/* A treelet row's group: same scene, mode, lighting, resolution, variant, structure. */
static int same_group(const trow *a, const trow *b)
{
    return !strcmp(a->scene, b->scene) && !strcmp(a->mode, b->mode) && a->lights == b->lights && a->W == b->W &&
           a->H == b->H && !strcmp(a->variant, b->variant) && a->accel == b->accel;
}

/* DIR/treelet-SCENE-MODE-lLIGHTS-WxH-ACCEL[-VARIANT].{dat,gp,png}. */
static int group_plot(const rt_plot_opts *po, const trow *R, long n, const trow *const *g, int ng, rt_err *e)
{
    const trow *a = g[0];
    char base[4096], dat[4200], gpf[4200], png[4200], tail[600];
    const char *m = a->mode[0] ? a->mode + 5 : (a->lights ? "shadow" : "raycast");
    snprintf(tail, sizeof tail, "%s-%.*s-l%d-%dx%d-%s%s%s", a->scene, (int)strcspn(m, " "), m, a->lights, a->W, a->H,
             rt_accel_name(a->accel), a->variant[0] ? "-" : "", a->variant);
    int k = snprintf(base, sizeof base, "%s/treelet-", po->dir);
    for (const char *s = tail; *s && k + 1 < (int)sizeof base; s++) base[k++] = *s == '/' || *s == ' ' ? '_' : *s;
    base[k] = 0;
    snprintf(dat, sizeof dat, "%s.dat", base);
    snprintf(gpf, sizeof gpf, "%s.gp", base);
    snprintf(png, sizeof png, "%s.png", base);
    struct rt_out *o; /* through src/outfile.c: unique temporary, renamed when complete */
    FILE *f = rt_plot_open(dat, &o, e);
    if (!f) return -1;
    fprintf(f, "# cache_kb, total MB and geometry MB of: baseline on the BVH, treelet, baseline on the k-d tree, "
               "dynamic (NaN: no run)\n");
    for (int i = 0; i < ng; i++) {
        const trow *t = g[i], *b = find(R, n, t, ROLE_BASE, t->accel), *d = find(R, n, t, ROLE_DYN, 0);
        const trow *bk = d ? find(R, n, t, ROLE_BASE, d->accel) : NULL;
        const trow *cols[4] = {b, t, bk, d};
        fprintf(f, "%" PRIu64, t->size / 1024);
        for (int c = 0; c < 4; c++)
            if (cols[c]) fprintf(f, " %.6g %.6g", cols[c]->mb[C_TOTAL], cols[c]->mb[C_GEO]);
            else fprintf(f, " NaN NaN");
        fprintf(f, "\n");
    }
    if (rt_plot_commit(o, e) < 0) return -1;
    if (!(f = rt_plot_open(gpf, &o, e))) return -1;
    char title[900];
    char ln[48];
    snprintf(title, sizeof title, "%s, %s, lights %s, %dx%d, %s %s", a->scene, a->mode[0] ? a->mode : m,
             rt_exp_lights_name((unsigned)a->lights, ln, sizeof ln), a->W, a->H, rt_accel_name(a->accel), a->variant);
    fprintf(f, "set terminal pngcairo size 1100,520\nset output ");
    rt_plot_quote_path(f, png);
    fprintf(f, "\nset title ");
    rt_plot_quote(f, title);
    fprintf(f, " noenhanced\nset logscale x 2\nset logscale y\nset format y \"10^{%%L}\"\n"
               "set xlabel \"cache size (KB)\"\nset ylabel \"DRAM traffic (MB)\"\nset grid\nset key outside right top\nplot ");
    static const char *const name[4] = {"recursive (BVH)", "treelet", "recursive (k-d)", "dynamic (k-d)"};
    static const char *const col[4] = {"#0072b2", "#d55e00", "#56b4e9", "#e69f00"};
    for (int c = 0; c < 4; c++) {
        if (c) fprintf(f, ", ''");
        else rt_plot_quote_path(f, dat);
        fprintf(f, " u 1:%d w lp lc rgb \"%s\" pt 7 t \"%s total\", '' u 1:%d w lp dt 2 lc rgb \"%s\" pt 6 t \"%s "
                   "geometry\"",
                2 + 2 * c, col[c], name[c], 3 + 2 * c, col[c], name[c]);
    }
    fprintf(f, "\n");
    if (rt_plot_commit(o, e) < 0) return -1;
    if (!po->gnuplot) return 0;
    if (rt_plot_run(po->gnuplot, gpf, e) < 0) return -1;
    if (po->log) fprintf(po->log, "wrote %s\n", png);
    return 0;
}

int rt_report_treelet(sqlite3 *h, const char *dbpath, const char *scene, int csv, const rt_plot_opts *plot, FILE *out,
                      rt_err *e)
{
    trow *R = NULL;
    long n = read_rows(h, dbpath, &R, e);
    if (n < 0) return -1;
    long nt = 0;
    for (long i = 0; i < n; i++) nt += R[i].role == ROLE_TREELET && (!scene || !strcmp(R[i].scene, scene));
    if (!nt) {
        free(R);
        return rt_errf(e, "%s: no treelet runs%s (sweep --tracers recursive,treelet --accel bvh4)", dbpath,
                       scene ? " for that scene" : "");
    }
    const trow **g = calloc((size_t)nt, sizeof *g);
    if (!g) {
        free(R);
        return rt_errf(e, "out of memory");
    }
    if (plot && rt_plot_mkdir(plot->dir, e) < 0) {
        free(g);
        free(R);
        return -1;
    }
    if (csv)
        fprintf(out, "scene,mode,lights,W,H,accel,variant,cache_bytes,base_total_mb,base_geo_mb,base_ray_mb,"
                     "treelet_total_mb,treelet_geo_mb,treelet_ray_mb,treelet_stack_mb,treelet_queue_mb,treelet_saved_pct,"
                     "treelet_geo_saved_pct,"
                     "kd_total_mb,dynamic_total_mb,dynamic_geo_mb,dynamic_ray_mb,dynamic_queue_mb,dynamic_saved_pct\n");
    else
        fprintf(out, "# Treelets against recursive order, beside the dynamic scheduler\n\nDatabase: %s. DRAM traffic in "
                     "MB (fully associative, 64-byte lines, write-back); a scheduled run counts at the size it was "
                     "scheduled for. Split: geometry = node+index+tri+shade, ray = ray+hit, stack = spilled traversal "
                     "stacks (class stream), queue = queue+qtable. Saved = the reduction baseline / scheduled - 1 "
                     "in percent (the paper's formula, as every report uses): the treelet run against the recursive "
                     "run on the same BVH, dynamic against recursive on the k-d tree; where the scheduler moves more, "
                     "its factor (\"3.60x more\"); geo saved: the same on geometry alone.\n", dbpath);
    int rc = 0;
    double best = NAN, bestg = NAN;
    const trow *bestp = NULL, *bestgp = NULL;
    for (long i = 0; i < n && rc == 0; i++) {
        if (R[i].role != ROLE_TREELET || (scene && strcmp(R[i].scene, scene))) continue;
        int seen = 0;
        for (long j = 0; j < i && !seen; j++) seen = R[j].role == ROLE_TREELET && same_group(&R[j], &R[i]);
        if (seen) continue;
        int ng = 0;
        for (long j = i; j < n; j++)
            if (R[j].role == ROLE_TREELET && same_group(&R[j], &R[i])) g[ng++] = &R[j];
        const trow *a = g[0];
        if (!csv) {
            char ln[48];
            fprintf(out, "\n### %s, %s, lights %s, %dx%d, %s%s%s\n\n", a->scene,
                    a->mode[0] ? a->mode : (a->lights ? "shadow" : "raycast"),
                    rt_exp_lights_name((unsigned)a->lights, ln, sizeof ln), a->W, a->H, rt_accel_name(a->accel),
                    a->variant[0] ? ", " : "", a->variant);
            fprintf(out, "| cache | recursive (BVH) | geo | ray | treelet | geo | ray | stack | queue | saved | geo saved | "
                         "recursive (k-d) | dynamic | geo | ray | queue | saved |\n"
                         "|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n");
        }
        for (int k = 0; k < ng; k++) {
            const trow *t = g[k], *b = find(R, n, t, ROLE_BASE, t->accel), *d = find(R, n, t, ROLE_DYN, 0);
            const trow *bk = d ? find(R, n, t, ROLE_BASE, d->accel) : NULL;
            const double st = saved(b, t), sd = saved(bk, d);
            if (!isnan(st) && (isnan(best) || st > best)) {
                best = st;
                bestp = t;
            }
            if (csv) fprintf(out, "%s,\"%s\",%d,%d,%d,%s,\"%s\",%" PRIu64, t->scene, t->mode, t->lights, t->W, t->H,
                             rt_accel_name(t->accel), t->variant, t->size);
            else fprintf(out, "| %" PRIu64 "K |", t->size / 1024);
            cell(out, csv, b ? b->mb[C_TOTAL] : NAN, "%.1f");
            cell(out, csv, b ? b->mb[C_GEO] : NAN, "%.1f");
            cell(out, csv, b ? b->mb[C_RAY] : NAN, "%.1f");
            static const int tc[5] = {C_TOTAL, C_GEO, C_RAY, C_STACK, C_QUEUE};
            for (int c = 0; c < 5; c++) cell(out, csv, t->mb[tc[c]], "%.1f");
            red_cell(out, csv, st);
            const double sg = saved_in(b, t, C_GEO);
            red_cell(out, csv, sg);
            if (!isnan(sg) && (isnan(bestg) || sg > bestg)) {
                bestg = sg;
                bestgp = t;
            }
            cell(out, csv, bk ? bk->mb[C_TOTAL] : NAN, "%.1f");
            cell(out, csv, d ? d->mb[C_TOTAL] : NAN, "%.1f");
            cell(out, csv, d ? d->mb[C_GEO] : NAN, "%.1f");
            cell(out, csv, d ? d->mb[C_RAY] : NAN, "%.1f");
            cell(out, csv, d ? d->mb[C_QUEUE] : NAN, "%.1f");
            red_cell(out, csv, sd);
            fputc('\n', out);
        }
        if (plot) rc = group_plot(plot, R, n, g, ng, e);
    }
    char bb[64], bg[64], l1[48], l2[48];
    if (!csv && rc == 0 && bestp)
        fprintf(out, "\nLargest treelet saving: %s (%s, %s, lights %s, %dx%d, %s, %" PRIu64 "K).\n",
                rt_report_fmt_reduction(best, 0, bb, sizeof bb), bestp->scene, bestp->mode[0] ? bestp->mode : "primary",
                rt_exp_lights_name((unsigned)bestp->lights, l1, sizeof l1), bestp->W, bestp->H,
                rt_accel_name(bestp->accel), bestp->size / 1024);
    if (!csv && rc == 0 && bestgp)
        fprintf(out, "Largest treelet saving in geometry: %s (%s, %s, lights %s, %dx%d, %s, %" PRIu64 "K).\n",
                rt_report_fmt_reduction(bestg, 0, bg, sizeof bg), bestgp->scene,
                bestgp->mode[0] ? bestgp->mode : "primary", rt_exp_lights_name((unsigned)bestgp->lights, l2, sizeof l2),
                bestgp->W, bestgp->H, rt_accel_name(bestgp->accel), bestgp->size / 1024);
    free(g);
    free(R);
    if (rc < 0) return -1;
    return rt_report_flush(out, e);
}
