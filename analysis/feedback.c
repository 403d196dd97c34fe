/*
 * feedback.c -- `report --figure feedback`: what the feedback tracer's
 * 64-byte ray records cost in memory traffic (Ralovich & Magdics 2009).
 *
 * Two tables per feedback run (scene, resolution, lights, parameters):
 *   - traffic per class and cache configuration: stream (the two vertex
 *     buffers vb.read / vb.write), node (the grid texture), index (the
 *     reference lists), tri, shade (texture 1), fb (render targets);
 *   - ray-state bytes moved per traced ray, and per ray generation, by the
 *     three stream-like designs on the same scene, resolution, lights and
 *     mode: Navrátil's 32-byte queued rays (the dynamic run scheduled for
 *     that cache size, its ray-group classes ray, queue, qtable and hit),
 *     Purcell's multipass state textures (a stream-multipass run, class
 *     stream) and the feedback records (class stream), each divided by its
 *     own run's rays traced (rays_primary + rays_shadow + rays_secondary of
 *     the statistics string) and by the generations of the mode (1 for
 *     raycast and shadow, D for whitted depth D: the eye rays and D - 1
 *     bounces, B + 1 for path with B bounces).
 * A design without a matching run shows a dash. Among several multipass
 * runs the one with the feedback run's grid_min and record-store keys is
 * taken, else the first stored. With a plot folder, DIR/feedback-LABEL.{dat,gp,png}: the
 * classes and the three designs against cache size. Only exact runs
 * without subsampling are read.
 */
#include "analysis_int.h"
#include "experiment.h"

#include <errno.h>
#include <inttypes.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#define NCLS 6
static const char *const cls_name[NCLS] = {"stream", "node", "index", "tri", "shade", "fb"};
static const char *const cls_title[NCLS] = {"stream (vb)", "node (grid)", "index (list)", "tri", "shade", "fb"};

/* The designs compared: the tracers of RT_FIG_FEEDBACK in registry order
 * (the scheduled tracer's queued rays, Purcell's multipass state, the
 * feedback records), each with the classes that hold its ray state. */
enum { D_NAV, D_PURCELL, D_FB, ND };
static const char *design_tracer(int d)
{
    const rt_tracer *t[ND] = {NULL, NULL, NULL};
    rt_report_fig_tracers(RT_FIG_FEEDBACK, t, ND);
    return t[d] ? t[d]->name : "";
}
static const char *design_classes(int d)
{
    const rt_tracer *t[ND] = {NULL, NULL, NULL};
    rt_report_fig_tracers(RT_FIG_FEEDBACK, t, ND);
    return rt_tracer_is(t[d], RT_TR_QUEUES) ? "ray,queue,qtable,hit" : "stream";
}
static const char *design_title(int d)
{
    static char buf[ND][96];
    const rt_tracer *t[ND] = {NULL, NULL, NULL};
    rt_report_fig_tracers(RT_FIG_FEEDBACK, t, ND);
    if (!t[d]) return "";
    if (rt_tracer_is(t[d], RT_TR_QUEUES)) snprintf(buf[d], sizeof buf[d], "Navrátil queued rays (%s)", t[d]->name);
    else if (rt_tracer_is(t[d], RT_TR_MULTIPASS)) snprintf(buf[d], sizeof buf[d], "Purcell state (%s)", t[d]->name);
    else snprintf(buf[d], sizeof buf[d], "%s records", t[d]->name);
    return buf[d];
}

/* One cache configuration of a feedback run and what was measured there. */
typedef struct fcfg {
    long long id;
    uint64_t size;
    int line, assoc;
    char policy[16];
    double cls[NCLS];  /* bytes per class */
    double total;      /* bytes, every class */
    double state[ND];  /* ray-state bytes per design; NAN = no run */
    double rays[ND];   /* rays traced by that design's run */
} fcfg;

typedef struct frun {
    long long id;
    char scene[300], hash[17], params[160], mode[160], label[800];
    int W, H, lights, gens, grid_min;
    double rays;
} frun;

static double stat_num(const char *stats, const char *key)
{
    size_t k = strlen(key);
    for (const char *p = stats; p && (p = strstr(p, key)); p += k)
        if ((p == stats || p[-1] == ' ') && p[k] == '=') return strtod(p + k + 1, NULL);
    return NAN;
}

/* Rays traced: primary, shadow and secondary rays of the statistics. */
static double rays_traced(const char *stats)
{
    double p = stat_num(stats, "rays_primary"), s = stat_num(stats, "rays_shadow"),
           r = stat_num(stats, "rays_secondary");
    if (isnan(p)) return NAN;
    return p + (isnan(s) ? 0 : s) + (isnan(r) ? 0 : r);
}

/* The mode part of a run key ("mode=..." onward, "" for the lights'
 * default mode): what must match between the designs. */
static const char *mode_of(const char *params)
{
    const char *m = strstr(params, "mode=");
    return m ? m : "";
}

/* Ray generations of a mode: whitted depth D -> D, path bounces B -> B+1. */
static int generations(const char *mode)
{
    const char *p;
    if (strstr(mode, "mode=whitted") && (p = strstr(mode, "depth="))) return atoi(p + 6) > 0 ? atoi(p + 6) : 1;
    if (strstr(mode, "mode=path") && (p = strstr(mode, "bounces="))) return atoi(p + 8) + 1;
    return 1;
}

static int grid_min_of(const char *params)
{
    const char *p = strstr(params, "grid_min=");
    return p && (p == params || p[-1] == ' ') ? atoi(p + 9) : 0;
}

/* 1 when the run key records write-allocate record stores (the key names
 * only the non-default). */
static int wa_records(const char *params)
{
    const char *p = strstr(params, "record_stores=write-allocate");
    return p && (p == params || p[-1] == ' ');
}

/* Bytes of the listed classes (comma list) of run at config cfg into *b.
 * 1 when the run has rows there, 0 when none, -1 on error. */
static int class_bytes(sqlite3 *h, long long run, long long cfg, const char *classes, double *b, rt_err *e)
{
    sqlite3_stmt *st = rt_report_stmt(h,
                                      "SELECT COUNT(*), TOTAL(traffic_bytes) FROM traffic WHERE run_id = ?1 AND "
                                      "config_id = ?2 AND instr(',' || ?3 || ',', ',' || class || ',') > 0",
                                      "feedback", e, "IIs", (int64_t)run, (int64_t)cfg, classes);
    if (!st) return -1;
    int rc = sqlite3_step(st), found = 0;
    if (rc == SQLITE_ROW) {
        found = sqlite3_column_int(st, 0) > 0;
        *b = sqlite3_column_double(st, 1);
    }
    if (rt_report_done(st, rc, "feedback", e) < 0) return -1;
    return found;
}

/* Fills c->state[d] and c->rays[d] for design d (not the feedback run
 * itself) from the matching run: same scene, resolution, lights and mode;
 * the dynamic run scheduled for c's size. */
static int other_design(sqlite3 *h, const frun *f, fcfg *c, int d, rt_err *e)
{
    sqlite3_stmt *st = rt_report_stmt(
        h,
        "SELECT r.id, r.params, r.stats FROM runs r JOIN scenes s ON s.id = r.scene_id WHERE r.tracer = ?1"
        " AND s.name = ?2 AND s.hash = ?3 AND r.W = ?4 AND r.H = ?5 AND r.lights = ?6 AND r.sim_method = 'exact'"
        " AND r.params NOT LIKE '%subsample=%' AND r.params NOT LIKE '%sim=all-sizes%'"
        " AND (?1 <> 'dynamic' OR r.sched_size = ?7) ORDER BY r.id",
        "feedback", e, "sssiiiI", design_tracer(d), f->scene, f->hash, f->W, f->H, f->lights, (int64_t)c->size);
    if (!st) return -1;
    long long best = -1;
    int best_gm = 0, rc;
    double rays = NAN;
    while ((rc = sqlite3_step(st)) == SQLITE_ROW) {
        const char *params = (const char *)sqlite3_column_text(st, 1);
        if (strcmp(mode_of(params ? params : ""), f->mode)) continue;
        int gm = grid_min_of(params) == f->grid_min && wa_records(params) == wa_records(f->params);
        if (best >= 0 && (best_gm || !gm)) continue;
        best = sqlite3_column_int64(st, 0);
        best_gm = gm;
        rays = rays_traced((const char *)sqlite3_column_text(st, 2));
    }
    if (rt_report_done(st, rc, "feedback", e) < 0) return -1;
    c->state[d] = NAN;
    c->rays[d] = rays;
    if (best < 0) return 0;
    double b = 0;
    int r = class_bytes(h, best, c->id, design_classes(d), &b, e);
    if (r < 0) return -1;
    if (r) c->state[d] = b;
    return 0;
}

/* The configurations of run f with its traffic per class and the three
 * designs' ray-state bytes; *out malloc'd. The count, or -1. */
static long read_cfgs(sqlite3 *h, const frun *f, fcfg **out, rt_err *e)
{
    sqlite3_stmt *st = rt_report_stmt(h,
                                      "SELECT c.id, c.size, c.line, c.assoc, c.policy, t.class, t.traffic_bytes FROM traffic t"
                                      " JOIN cache_configs c ON c.id = t.config_id WHERE t.run_id = ?1"
                                      " ORDER BY c.size, c.line, c.assoc, c.policy, c.id",
                                      "feedback", e, "I", (int64_t)f->id);
    if (!st) return -1;
    fcfg *C = NULL;
    long n = 0;
    int rc;
    while ((rc = sqlite3_step(st)) == SQLITE_ROW) {
        long long id = sqlite3_column_int64(st, 0);
        if (!n || C[n - 1].id != id) {
            fcfg *nc = realloc(C, (size_t)(n + 1) * sizeof *C);
            if (!nc) {
                sqlite3_finalize(st);
                free(C);
                return rt_errf(e, "out of memory");
            }
            C = nc;
            fcfg *c = &C[n++];
            memset(c, 0, sizeof *c);
            c->id = id;
            c->size = (uint64_t)sqlite3_column_int64(st, 1);
            c->line = sqlite3_column_int(st, 2);
            c->assoc = sqlite3_column_int(st, 3);
            snprintf(c->policy, sizeof c->policy, "%s", (const char *)sqlite3_column_text(st, 4));
        }
        const char *k = (const char *)sqlite3_column_text(st, 5);
        double b = sqlite3_column_double(st, 6);
        C[n - 1].total += b;
        for (int i = 0; i < NCLS; i++)
            if (k && !strcmp(k, cls_name[i])) C[n - 1].cls[i] += b;
    }
    if (rt_report_done(st, rc, "feedback", e) < 0) {
        free(C);
        return -1;
    }
    for (long i = 0; i < n; i++) {
        C[i].state[D_FB] = C[i].cls[0];
        C[i].rays[D_FB] = f->rays;
        if (other_design(h, f, &C[i], D_NAV, e) < 0 || other_design(h, f, &C[i], D_PURCELL, e) < 0) {
            free(C);
            return -1;
        }
    }
    *out = C;
    return n;
}

/* "4 KB", with line, ways and policy when not 64 B fully associative wb-wa. */
static void cfg_label(const fcfg *c, char *b, size_t n)
{
    int k = snprintf(b, n, "%" PRIu64 " KB", c->size / 1024);
    if (c->line != 64 || c->assoc != 0 || strcmp(c->policy, "wb-wa"))
        snprintf(b + k, n - (size_t)k, " %d B %d-way %s", c->line, c->assoc, c->policy);
}

static void num(FILE *o, int csv, const char *fmt, double v)
{
    if (isnan(v)) fputs(csv ? "," : " | —", o);
    else {
        fputs(csv ? "," : " | ", o);
        fprintf(o, fmt, v);
    }
}

/* Bytes per traced ray of design d at c, per generation when gens > 0. */
static double per_ray(const fcfg *c, int d, int gens)
{
    if (isnan(c->state[d]) || !(c->rays[d] > 0)) return NAN;
    return c->state[d] / c->rays[d] / (gens > 0 ? gens : 1);
}

static void run_tables(FILE *o, int csv, const frun *f, const fcfg *C, long n)
{
    if (csv) {
        fprintf(o, "# traffic per class (bytes)\nrun,cache_bytes,line,assoc,policy");
        for (int i = 0; i < NCLS; i++) fprintf(o, ",%s", cls_name[i]);
        fprintf(o, ",total\n");
        for (long i = 0; i < n; i++) {
            fprintf(o, "\"%s\",%" PRIu64 ",%d,%d,%s", f->label, C[i].size, C[i].line, C[i].assoc, C[i].policy);
            for (int k = 0; k < NCLS; k++) fprintf(o, ",%.0f", C[i].cls[k]);
            fprintf(o, ",%.0f\n", C[i].total);
        }
        fprintf(o, "# ray-state bytes per traced ray (generations %d)\nrun,cache_bytes,line,assoc,policy,"
                   "dynamic_rays,multipass_rays,feedback_rays,dynamic,multipass,feedback,dynamic_per_gen,"
                   "multipass_per_gen,feedback_per_gen\n", f->gens);
        for (long i = 0; i < n; i++) {
            fprintf(o, "\"%s\",%" PRIu64 ",%d,%d,%s", f->label, C[i].size, C[i].line, C[i].assoc, C[i].policy);
            for (int d = 0; d < ND; d++) num(o, 1, "%.0f", C[i].rays[d]);
            for (int g = 0; g < 2; g++)
                for (int d = 0; d < ND; d++) num(o, 1, "%.2f", per_ray(&C[i], d, g ? f->gens : 0));
            fputc('\n', o);
        }
        return;
    }
    char lab[96];
    fprintf(o, "\n### %s: traffic per class (MB = 2^20 bytes)\n\n| cache", f->label);
    for (int k = 0; k < NCLS; k++) fprintf(o, " | %s", cls_title[k]);
    fprintf(o, " | total | stream share |\n|---");
    for (int k = 0; k < NCLS + 2; k++) fputs("|---:", o);
    fputs("|\n", o);
    for (long i = 0; i < n; i++) {
        cfg_label(&C[i], lab, sizeof lab);
        fprintf(o, "| %s", lab);
        for (int k = 0; k < NCLS; k++) num(o, 0, "%.3f", C[i].cls[k] / 1048576.0);
        num(o, 0, "%.3f", C[i].total / 1048576.0);
        num(o, 0, "%.1f%%", C[i].total > 0 ? 100.0 * C[i].cls[0] / C[i].total : NAN);
        fputs(" |\n", o);
    }
    fprintf(o, "\n### %s: ray-state bytes per traced ray\n\nRays traced (primary + shadow + secondary): ", f->label);
    for (int d = 0; d < ND; d++) {
        fprintf(o, "%s%s ", d ? ", " : "", design_tracer(d));
        if (n && !isnan(C[n - 1].rays[d])) fprintf(o, "%.0f", C[n - 1].rays[d]);
        else fputs("—", o);
    }
    fprintf(o, "; %d generation%s, so per generation = per ray / %d.\n\n| cache", f->gens, f->gens == 1 ? "" : "s",
            f->gens);
    for (int d = 0; d < ND; d++) fprintf(o, " | %s", design_title(d));
    for (int d = 0; d < ND; d++) fprintf(o, " | per gen. %s", design_tracer(d));
    fputs(" |\n|---", o);
    for (int k = 0; k < 2 * ND; k++) fputs("|---:", o);
    fputs("|\n", o);
    for (long i = 0; i < n; i++) {
        cfg_label(&C[i], lab, sizeof lab);
        fprintf(o, "| %s", lab);
        for (int g = 0; g < 2; g++)
            for (int d = 0; d < ND; d++) num(o, 0, "%.1f", per_ray(&C[i], d, g ? f->gens : 0));
        fputs(" |\n", o);
    }
    if (!n) return;
    /* the finding at the largest configuration */
    const fcfg *c = &C[n - 1];
    cfg_label(c, lab, sizeof lab);
    fprintf(o, "\nAt %s the 64-byte records move %.1f B per traced ray (%.1f%% of the run's traffic)", lab,
            per_ray(c, D_FB, 0), c->total > 0 ? 100.0 * c->cls[0] / c->total : 0.0);
    for (int d = D_NAV; d <= D_PURCELL; d++) {
        double v = per_ray(c, d, 0), fb = per_ray(c, D_FB, 0);
        if (isnan(v)) fprintf(o, "; no %s run to compare", design_tracer(d));
        else if (v > 0) fprintf(o, "; %.2fx the %.1f B of %s", fb / v, v, design_title(d));
        else fprintf(o, "; %s moves none", design_title(d));
    }
    fputs(".\n", o);
}

/* DIR/feedback-LABEL.{dat,gp,png}: classes (MB) and the designs' bytes per
 * ray against cache size. */
static int run_plot(const rt_plot_opts *po, const frun *f, const fcfg *C, long n, rt_err *e)
{
    char base[4096], dat[4200], gpf[4200], png[4200], name[sizeof f->label];
    size_t k = 0;
    for (const char *s = f->label; *s && k + 1 < sizeof name; s++) name[k++] = *s == ' ' ? '_' : *s == '=' ? '-' : *s;
    name[k] = 0;
    rt_plot_path(base, sizeof base, po->dir, "feedback-", name, "");
    snprintf(dat, sizeof dat, "%s.dat", base);
    snprintf(gpf, sizeof gpf, "%s.gp", base);
    snprintf(png, sizeof png, "%s.png", base);
    rt_out *o;
    FILE *fp = rt_plot_open(dat, &o, e);
    if (!fp) return -1;
    fprintf(fp, "# cache_kb, MB of stream node index tri shade fb, bytes per ray of dynamic multipass feedback\n");
    for (long i = 0; i < n; i++) {
        /* one cache family on the axis: fully associative 64-byte lines
         * (Purcell's 48-byte direct-mapped texture cache is in the table) */
        if (C[i].line != 64 || C[i].assoc != 0) continue;
        fprintf(fp, "%" PRIu64, C[i].size / 1024);
        for (int c = 0; c < NCLS; c++) fprintf(fp, " %.6g", C[i].cls[c] / 1048576.0);
        for (int d = 0; d < ND; d++) {
            double v = per_ray(&C[i], d, 0);
            if (isnan(v)) fprintf(fp, " NaN");
            else fprintf(fp, " %.6g", v);
        }
        fputc('\n', fp);
    }
    if (rt_plot_commit(o, e) < 0) return -1;
    if (!(fp = rt_plot_open(gpf, &o, e))) return -1;
    fprintf(fp, "set terminal pngcairo size 1100,560\nset output ");
    rt_plot_quote_path(fp, png);
    fprintf(fp, "\nset multiplot layout 1,2 title ");
    rt_plot_quote(fp, f->label);
    fprintf(fp, " noenhanced\nset logscale x 2\nset xlabel \"cache size (fully associative, 64-byte lines)\"\n"
                "set grid\nset key below horizontal maxrows 3 noenhanced\nset bmargin 9\nset xrange [0.8:5120]\n"
                "set xtics (\"1K\" 1, \"4K\" 4, \"16K\" 16, \"64K\" 64, \"256K\" 256, \"1M\" 1024, \"4M\" 4096)\n"
                "set title \"traffic per class\"\nset ylabel \"MB\"\nplot ");
    static const char *const col[] = {"#0072b2", "#e69f00", "#009e73", "#d55e00", "#cc79a7", "#56b4e9"};
    for (int c = 0; c < NCLS; c++) {
        if (c) fputs(", ''", fp);
        else rt_plot_quote_path(fp, dat);
        fprintf(fp, " u 1:%d w lp lc rgb \"%s\" pt 7 t ", 2 + c, col[c]);
        rt_plot_quote(fp, cls_title[c]);
    }
    fprintf(fp, "\nset title \"ray-state bytes per traced ray\"\nset ylabel \"bytes\"\nplot ");
    for (int d = 0; d < ND; d++) {
        if (d) fputs(", ''", fp);
        else rt_plot_quote_path(fp, dat);
        fprintf(fp, " u 1:%d w lp lc rgb \"%s\" pt 7 t ", 2 + NCLS + d, col[d]);
        rt_plot_quote(fp, design_title(d));
    }
    fprintf(fp, "\nunset multiplot\n");
    if (rt_plot_commit(o, e) < 0) return -1;
    const char *outs[] = {png, NULL};
    return rt_plot_draw(po, gpf, outs, png, e);
}

int rt_report_feedback(sqlite3 *h, const char *scene, int csv, const rt_plot_opts *plot, FILE *out, rt_err *e)
{
    sqlite3_stmt *st = rt_report_stmt(
        h,
        "SELECT r.id, s.name, s.hash, r.W, r.H, r.lights, r.params, r.stats FROM runs r JOIN scenes s ON s.id = r.scene_id"
        " WHERE r.tracer = 'feedback' AND r.sim_method = 'exact' AND r.params NOT LIKE '%subsample=%'"
        " AND (?1 IS NULL OR s.name = ?1) ORDER BY s.name, r.W, r.H, r.lights, r.params, r.id",
        "feedback", e, "s", scene);
    if (!st) return -1;
    frun *F = NULL;
    long n = 0;
    int rc;
    while ((rc = sqlite3_step(st)) == SQLITE_ROW) {
        frun *nf = realloc(F, (size_t)(n + 1) * sizeof *F);
        if (!nf) {
            sqlite3_finalize(st);
            free(F);
            return rt_errf(e, "out of memory");
        }
        F = nf;
        frun *f = &F[n++];
        memset(f, 0, sizeof *f);
        f->id = sqlite3_column_int64(st, 0);
        snprintf(f->scene, sizeof f->scene, "%s", (const char *)sqlite3_column_text(st, 1));
        snprintf(f->hash, sizeof f->hash, "%s", (const char *)sqlite3_column_text(st, 2));
        f->W = sqlite3_column_int(st, 3);
        f->H = sqlite3_column_int(st, 4);
        f->lights = sqlite3_column_int(st, 5);
        snprintf(f->params, sizeof f->params, "%s", (const char *)sqlite3_column_text(st, 6));
        snprintf(f->mode, sizeof f->mode, "%s", mode_of(f->params));
        f->gens = generations(f->mode);
        f->grid_min = grid_min_of(f->params);
        f->rays = rays_traced((const char *)sqlite3_column_text(st, 7));
        char ln[48];
        snprintf(f->label, sizeof f->label, "%s %dx%d lights %s%s%s", f->scene, f->W, f->H,
                 rt_exp_lights_name((unsigned)f->lights, ln, sizeof ln), f->params[0] ? " " : "", f->params);
    }
    if (rt_report_done(st, rc, "feedback", e) < 0) {
        free(F);
        return -1;
    }
    if (!n) {
        free(F);
        return rt_errf(e, "no runs of the feedback tracer%s%s (sweep --tracers feedback)", scene ? " on " : "",
                       scene ? scene : "");
    }
    if (plot && rt_plot_mkdir(plot->dir, e) < 0) {
        free(F);
        return -1;
    }
    if (!csv)
        fprintf(out, "## The feedback tracer: traffic of 64-byte ray records\n\nRay state per traced ray: "
                     "Navrátil's queued rays (dynamic: classes ray, queue, qtable, hit; the run scheduled for the "
                     "size), Purcell's multipass state (stream-multipass: class stream), the feedback records "
                     "(class stream), same scene, resolution, lights and mode.\n");
    int r = 0;
    for (long i = 0; i < n && r == 0; i++) {
        fcfg *C = NULL;
        long nc = read_cfgs(h, &F[i], &C, e);
        if (nc < 0) {
            r = -1;
            break;
        }
        run_tables(out, csv, &F[i], C, nc);
        if (plot) r = run_plot(plot, &F[i], C, nc, e);
        free(C);
    }
    free(F);
    if (r < 0) return -1;
    return rt_report_flush(out, e);
}
