/*
 * accel.c -- `report --figure accel`: the acceleration structures side by
 * side (k-d tree, bvh2, bvh4, bvh8, and any other a tracer ran on).
 *
 * The runs compared are those of one tracer that differ only in their
 * structure: exact, full-frame runs (no subsampling, no scheduled size)
 * with the same scene (name and hash), resolution, lights, simulator
 * parameters and run key once the key's "accel=X" is taken out (a run
 * without it is on its tracer's default structure, tracer.h). Such a group
 * is reported when it holds two structures or more, one table row per
 * structure:
 *
 *   - the structure's footprint from the run's statistics (accel_nodes,
 *     accel_bytes: nodes and index lists, not triangles; stored by
 *     `sweep --accels`; a dash for a run stored without them),
 *   - the work per ray: node visits and triangle tests of the run over its
 *     rays traced (rays_primary + rays_shadow + rays_secondary; the packet
 *     tracer counts a node once per packet visit),
 *   - geometry traffic (classes of the geometry group: nodes, index lists,
 *     triangles) at every cache size with 64-byte lines, fully associative
 *     (the first policy in name order when several were simulated),
 *
 * then, in Markdown, which structure moves the least geometry at the
 * smallest and at the largest size. With a plot folder, per group
 * DIR/accel-LABEL.{dat,gp} and, with gnuplot, .png: geometry traffic
 * against cache size, one line per structure (written through outfile.h).
 * Everything printed comes from counts, so the output is deterministic.
 */
#include "analysis_int.h"
#include "experiment.h"
#include "outfile.h"

#include <inttypes.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#define MAXS RT_REPORT_MAXSIZES

typedef struct arun {
    long long id;
    rt_report_group g;            /* the group it is compared in */
    int accel;                    /* rt_accel_kind */
    double nodes, bytes;          /* footprint; NAN when not stored */
    double nvisit, ntest, rays;   /* the run's counts */
    int nsizes;
    uint64_t size[MAXS];          /* ascending */
    double geom[MAXS];            /* geometry bytes at size[i] */
} arun;

static double stat_num(const char *stats, const char *key)
{
    size_t k = strlen(key);
    for (const char *p = stats; p && (p = strstr(p, key)); p += k)
        if ((p == stats || p[-1] == ' ') && p[k] == '=') return strtod(p + k + 1, NULL);
    return NAN;
}

/* The run key without its "accel=X" word into key; the structure named
 * there (or the tracer's default) into *accel. 0, or -1 when neither is
 * known (an unregistered tracer or structure). */
static int split_key(const char *tracer, const char *params, char *key, size_t n, int *accel)
{
    const rt_tracer *tr = rt_tracer_find(tracer);
    if (!tr) return -1;
    *accel = tr->accel_default;
    size_t k = 0;
    key[0] = 0;
    for (const char *p = params; *p;) {
        size_t len = strcspn(p, " ");
        if (len > 6 && !strncmp(p, "accel=", 6)) {
            char name[32];
            snprintf(name, sizeof name, "%.*s", (int)(len - 6 < 31 ? len - 6 : 31), p + 6);
            if ((*accel = rt_accel_from_name(name)) <= 0) return -1;
        } else if (len) {
            k += (size_t)snprintf(key + k, k < n ? n - k : 0, "%s%.*s", k ? " " : "", (int)len, p);
        }
        p += len;
        while (*p == ' ') p++;
    }
    return k < n ? 0 : -1;
}

/* Geometry bytes of run a per cache size (64-byte lines, fully associative). */
static int read_geom(sqlite3 *h, arun *a, rt_err *e)
{
    sqlite3_stmt *st = rt_report_stmt(h,
                                      "SELECT c.size, c.policy, TOTAL(t.traffic_bytes) FROM traffic t"
                                      " JOIN cache_configs c ON c.id = t.config_id JOIN classes k ON k.name = t.class"
                                      " WHERE t.run_id = ?1 AND c.line = 64 AND c.assoc = 0 AND k.grp = 'geometry'"
                                      " GROUP BY c.size, c.policy ORDER BY c.size, c.policy",
                                      "accel", e, "I", (int64_t)a->id);
    if (!st) return -1;
    int rc;
    a->nsizes = 0;
    while ((rc = sqlite3_step(st)) == SQLITE_ROW) {
        uint64_t s = (uint64_t)sqlite3_column_int64(st, 0);
        if (a->nsizes && a->size[a->nsizes - 1] == s) continue; /* another policy */
        if (a->nsizes == MAXS) continue;
        a->size[a->nsizes] = s;
        a->geom[a->nsizes++] = sqlite3_column_double(st, 2);
    }
    return rt_report_done(st, rc, "accel", e);
}

static int same_group(const arun *a, const arun *b) { return !rt_report_group_cmp(&a->g, &b->g); }

static int by_group(const void *x, const void *y)
{
    const arun *a = x, *b = y;
    int c = rt_report_group_cmp(&a->g, &b->g);
    if (c) return c;
    if (a->accel != b->accel) return a->accel < b->accel ? -1 : 1;
    return a->id < b->id ? -1 : a->id > b->id;
}

/* Geometry bytes of run a at size s, NAN when it was not simulated there. */
static double geom_at(const arun *a, uint64_t s)
{
    for (int i = 0; i < a->nsizes; i++)
        if (a->size[i] == s) return a->geom[i];
    return NAN;
}

static double per_ray(double v, const arun *a) { return a->rays > 0 ? v / a->rays : NAN; }

static void cell(FILE *o, int csv, const char *fmt, double v)
{
    fputs(csv ? "," : " | ", o);
    if (isnan(v)) fputs(csv ? "" : "—", o);
    else fprintf(o, fmt, v);
}

/* The sizes of a group: the union of its runs' sizes, ascending. */
static int group_sizes(const arun *g, int n, uint64_t *sz)
{
    int ns = 0;
    for (int i = 0; i < n; i++) ns = rt_report_size_union(sz, ns, MAXS, g[i].size, g[i].nsizes);
    return ns;
}

static void group_label(const arun *a, char *b, size_t n)
{
    rt_report_run_label(b, n, &a->g);
}

/* The structure moving the least geometry at size s (NULL: none). */
static const arun *least_at(const arun *g, int n, uint64_t s)
{
    const arun *best = NULL;
    for (int i = 0; i < n; i++) {
        double v = geom_at(&g[i], s);
        if (!isnan(v) && (!best || v < geom_at(best, s))) best = &g[i];
    }
    return best;
}

static void finding(FILE *o, const arun *g, int n, uint64_t s)
{
    const arun *b = least_at(g, n, s);
    if (!b) return;
    double bv = geom_at(b, s);
    fprintf(o, "at %" PRIu64 " KB %s (%.3f MB", s / 1024, rt_accel_name(b->accel), bv / 1048576.0);
    for (int i = 0; i < n; i++) {
        double v = geom_at(&g[i], s);
        if (&g[i] == b || isnan(v)) continue;
        if (bv > 0) fprintf(o, "; %s %.2fx", rt_accel_name(g[i].accel), v / bv);
        else fprintf(o, "; %s %.3f MB", rt_accel_name(g[i].accel), v / 1048576.0);
    }
    fputs(")", o);
}

static void group_table(FILE *o, int csv, const arun *g, int n, const uint64_t *sz, int ns)
{
    char lab[800];
    group_label(g, lab, sizeof lab);
    if (csv) {
        for (int i = 0; i < n; i++)
            for (int k = 0; k < ns; k++) {
                fputc('"', o);
                for (const char *p = lab; *p; p++) fputs(*p == '"' ? "\"\"" : (char[2]){*p, 0}, o);
                fprintf(o, "\",%s", rt_accel_name(g[i].accel));
                cell(o, 1, "%.0f", g[i].nodes);
                cell(o, 1, "%.0f", g[i].bytes);
                cell(o, 1, "%.4f", per_ray(g[i].nvisit, &g[i]));
                cell(o, 1, "%.4f", per_ray(g[i].ntest, &g[i]));
                fprintf(o, ",%" PRIu64, sz[k]);
                cell(o, 1, "%.0f", geom_at(&g[i], sz[k]));
                fputc('\n', o);
            }
        return;
    }
    fprintf(o, "\n### %s\n\n| structure | nodes | struct. KB | nodes/ray | tests/ray", lab);
    for (int k = 0; k < ns; k++) fprintf(o, " | %" PRIu64 " KB", sz[k] / 1024);
    fputs(" |\n|---", o);
    for (int k = 0; k < ns + 4; k++) fputs("|---:", o);
    fputs("|\n", o);
    for (int i = 0; i < n; i++) {
        fprintf(o, "| %s", rt_accel_name(g[i].accel));
        cell(o, 0, "%.0f", g[i].nodes);
        cell(o, 0, "%.1f", g[i].bytes / 1024.0);
        cell(o, 0, "%.2f", per_ray(g[i].nvisit, &g[i]));
        cell(o, 0, "%.2f", per_ray(g[i].ntest, &g[i]));
        for (int k = 0; k < ns; k++) cell(o, 0, "%.3f", geom_at(&g[i], sz[k]) / 1048576.0);
        fputs(" |\n", o);
    }
    if (!ns) return;
    fputs("\nLeast geometry traffic: ", o);
    finding(o, g, n, sz[0]);
    if (ns > 1) {
        fputs("; ", o);
        finding(o, g, n, sz[ns - 1]);
    }
    fputs(".\n", o);
}

/* DIR/accel-LABEL.{dat,gp,png}. */
static int group_plot(const rt_plot_opts *po, const arun *g, int n, const uint64_t *sz, int ns, rt_err *e)
{
    char lab[800], base[4096], dat[4200], gpf[4200], png[4200];
    group_label(g, lab, sizeof lab);
    int k = snprintf(base, sizeof base, "%s/accel-", po->dir);
    for (const char *s = lab; *s && k + 1 < (int)sizeof base; s++)
        base[k++] = (*s == '/' || *s == ' ' || *s == ':' || *s == '=') ? (*s == '=' ? '-' : '_') : *s;
    base[k] = 0;
    snprintf(dat, sizeof dat, "%s.dat", base);
    snprintf(gpf, sizeof gpf, "%s.gp", base);
    snprintf(png, sizeof png, "%s.png", base);
    rt_out *out = rt_out_open(dat, e);
    if (!out) return -1;
    FILE *f = rt_out_stream(out);
    fprintf(f, "# cache_kb, geometry MB of");
    for (int i = 0; i < n; i++) fprintf(f, " %s", rt_accel_name(g[i].accel));
    fputc('\n', f);
    for (int s = 0; s < ns; s++) {
        fprintf(f, "%" PRIu64, sz[s] / 1024);
        for (int i = 0; i < n; i++) {
            double v = geom_at(&g[i], sz[s]);
            if (isnan(v)) fputs(" NaN", f);
            else fprintf(f, " %.6g", v / 1048576.0);
        }
        fputc('\n', f);
    }
    if (rt_out_commit(out, e) < 0) return -1;
    if (!(out = rt_out_open(gpf, e))) return -1;
    f = rt_out_stream(out);
    fprintf(f, "set terminal pngcairo size 1000,500\nset output ");
    rt_plot_quote_path(f, png);
    fprintf(f, "\nset title ");
    rt_plot_quote(f, lab);
    fprintf(f, " noenhanced\nset logscale x 2\nset logscale y\nset format y \"%%g\"\nset xlabel \"cache size\"\n"
               "set xrange [0.8:5120]\n"
               "set xtics (\"1K\" 1, \"4K\" 4, \"16K\" 16, \"64K\" 64, \"256K\" 256, \"1M\" 1024, \"4M\" 4096)\n"
               "set ylabel \"geometry traffic (MB)\"\nset grid\nset key outside right top noenhanced\nplot ");
    static const char *const col[] = {"#0072b2", "#e69f00", "#009e73", "#d55e00", "#cc79a7", "#56b4e9", "#000000"};
    for (int i = 0; i < n; i++) {
        char t[96];
        if (isnan(g[i].bytes)) snprintf(t, sizeof t, "%s", rt_accel_name(g[i].accel));
        else snprintf(t, sizeof t, "%s (%.2f MB structure)", rt_accel_name(g[i].accel), g[i].bytes / 1048576.0);
        if (i) fputs(", ''", f);
        else rt_plot_quote_path(f, dat);
        fprintf(f, " u 1:%d w lp lc rgb \"%s\" pt 7 t ", 2 + i, col[i % 7]);
        rt_plot_quote(f, t);
    }
    fputc('\n', f);
    if (rt_out_commit(out, e) < 0) return -1;
    if (!po->gnuplot) return 0;
    if (rt_plot_run(po->gnuplot, gpf, e) < 0) return -1;
    if (po->log) fprintf(po->log, "wrote %s\n", png);
    return 0;
}

int rt_report_accel(sqlite3 *h, const char *scene, int csv, const rt_plot_opts *plot, FILE *out, rt_err *e)
{
    sqlite3_stmt *st = rt_report_stmt(
        h,
        "SELECT r.id, s.name, s.hash, r.W, r.H, r.lights, r.tracer, r.params, r.stats, r.sim_params FROM runs r"
        " JOIN scenes s ON s.id = r.scene_id WHERE r.sim_method = 'exact' AND r.sched_size = 0"
        " AND r.params NOT LIKE '%subsample=%' AND r.params NOT LIKE '%sim=all-sizes%'"
        " AND (?1 IS NULL OR s.name = ?1) ORDER BY r.id",
        "accel", e, "s", scene);
    if (!st) return -1;
    arun *A = NULL;
    long n = 0;
    int rc;
    while ((rc = sqlite3_step(st)) == SQLITE_ROW) {
        arun a;
        memset(&a, 0, sizeof a);
        const char *params = (const char *)sqlite3_column_text(st, 7), *stats = (const char *)sqlite3_column_text(st, 8);
        const char *sp = (const char *)sqlite3_column_text(st, 9);
        snprintf(a.g.tracer, sizeof a.g.tracer, "%s", (const char *)sqlite3_column_text(st, 6));
        if (split_key(a.g.tracer, params ? params : "", a.g.key, sizeof a.g.key, &a.accel) < 0) continue;
        a.id = sqlite3_column_int64(st, 0);
        snprintf(a.g.scene, sizeof a.g.scene, "%s", (const char *)sqlite3_column_text(st, 1));
        snprintf(a.g.hash, sizeof a.g.hash, "%s", (const char *)sqlite3_column_text(st, 2));
        a.g.W = sqlite3_column_int(st, 3);
        a.g.H = sqlite3_column_int(st, 4);
        a.g.lights = sqlite3_column_int(st, 5);
        snprintf(a.g.sim_params, sizeof a.g.sim_params, "%s", sp ? sp : "");
        a.nodes = stat_num(stats, "accel_nodes");
        a.bytes = stat_num(stats, "accel_bytes");
        a.nvisit = stat_num(stats, "nodes");
        a.ntest = stat_num(stats, "tests");
        double p = stat_num(stats, "rays_primary"), s = stat_num(stats, "rays_shadow"),
               r = stat_num(stats, "rays_secondary");
        a.rays = isnan(p) ? NAN : p + (isnan(s) ? 0 : s) + (isnan(r) ? 0 : r);
        arun *na = realloc(A, (size_t)(n + 1) * sizeof *A);
        if (!na) {
            sqlite3_finalize(st);
            free(A);
            return rt_errf(e, "out of memory");
        }
        A = na;
        A[n++] = a;
    }
    if (rt_report_done(st, rc, "accel", e) < 0) {
        free(A);
        return -1;
    }
    for (long i = 0; i < n; i++)
        if (read_geom(h, &A[i], e) < 0) {
            free(A);
            return -1;
        }
    if (n) qsort(A, (size_t)n, sizeof *A, by_group);
    if (plot && rt_plot_mkdir(plot->dir, e) < 0) {
        free(A);
        return -1;
    }
    if (csv) fputs("group,structure,nodes,bytes,nodes_per_ray,tests_per_ray,cache_bytes,geometry_bytes\n", out);
    else
        fputs("## Acceleration structures: footprint, work per ray and geometry traffic\n\n"
              "Runs of one tracer that differ only in their structure. nodes, struct. KB: the structure's node records "
              "and index lists (not triangles); nodes/ray, tests/ray: node visits and triangle tests over rays "
              "traced (packet: a node counted once per packet visit); then geometry traffic in MB (2^20 bytes) "
              "per cache size (64-byte lines, fully associative).\n",
              out);
    int groups = 0, r = 0;
    for (long i = 0; i < n && r == 0;) {
        long j = i + 1;
        while (j < n && same_group(&A[i], &A[j])) j++;
        /* one run per structure: the first stored */
        arun *g = &A[i];
        int m = 0;
        for (long k = i; k < j; k++)
            if (!m || g[m - 1].accel != A[k].accel) g[m++] = A[k];
        if (m >= 2) {
            uint64_t sz[MAXS];
            int ns = group_sizes(g, m, sz);
            group_table(out, csv, g, m, sz, ns);
            if (plot) r = group_plot(plot, g, m, sz, ns, e);
            groups++;
        }
        i = j;
    }
    free(A);
    if (r < 0) return -1;
    if (!groups)
        return rt_errf(e, "no runs of one tracer on two or more structures%s%s (sweep --accels kd,bvh2,bvh4,bvh8)",
                       scene ? " on " : "", scene ? scene : "");
    return rt_report_flush(out, e);
}
