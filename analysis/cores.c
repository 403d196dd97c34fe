/*
 * cores.c -- `report --figure cores` (rt_report_cores, analysis.h): the
 * multi-core runs (a hierarchy with private levels, `sim --hierarchy` or
 * their rows from anywhere else) against their core count.
 *
 * Per scene (and image size, lights, private level): for each shared size
 * of RT_CORES_SIZES present, a table of DRAM traffic in MB (the run's
 * traffic rows: what reaches memory below the shared level) with one row
 * per core count and one column per tracer, then each tracer's reduction
 * against the recursive tracer on the same structure (its default, or the
 * one named in the column) at the same core count, 100 (R / T - 1) %
 * (rt_report_reduction, the paper's formula);
 * (a tracer on another structure than its default is its own column,
 * "recursive/bvh4") and the shared level's miss rate (misses / accesses of the last
 * level, all classes). With a plot folder: DIR/cores-SCENE.png, DRAM traffic against
 * cores (log 2) at the largest of those sizes, one line per tracer.
 */
#include "analysis_int.h"
#include "experiment.h"

#include <inttypes.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#define NT 8
#define NC 16
static const uint64_t cores_sizes[] = {256u << 10, 4u << 20};
enum { NSZ = 2 };

typedef struct cell {
    double mb, miss; /* DRAM MB; shared miss rate (NaN: none) */
} cell;

typedef struct group {
    char scene[256];
    int W, H, lights;
    char l1[160];
    char tracer[NT][32];
    int nt;
    int cores[NC];
    int nc;
    cell v[NSZ][NC][NT];
} group;

static int idx_of(char (*names)[32], int *n, int max, const char *s)
{
    for (int i = 0; i < *n; i++)
        if (!strcmp(names[i], s)) return i;
    if (*n == max) return -1;
    snprintf(names[*n], 32, "%s", s);
    return (*n)++;
}

/* The structure a column's tracer runs on: after '/' in its label, else
 * its tracer's default. */
static void structure_of(const char *label, char *buf, size_t n)
{
    const char *sl = strchr(label, '/');
    if (sl) {
        snprintf(buf, n, "%s", sl + 1);
        return;
    }
    const rt_tracer *tr = rt_tracer_find(label);
    snprintf(buf, n, "%s", tr && rt_accel_name(tr->accel_default) ? rt_accel_name(tr->accel_default) : "?");
}

int rt_report_cores(sqlite3 *h, const char *dbpath, const char *scene, int csv, const rt_plot_opts *plot, FILE *out,
                    rt_err *e)
{
    const char *sql =
        "SELECT s.name, r.W, r.H, r.lights, r.tracer, r.cores, r.hierarchy, c.size, SUM(t.traffic_bytes),"
        " (SELECT CAST(SUM(l.misses) AS REAL) / SUM(l.accesses) FROM level_traffic l WHERE l.run_id = r.id"
        "  AND l.level = (SELECT MAX(m.level) FROM level_traffic m WHERE m.run_id = r.id) AND l.core = -1"
        "  AND l.cache_size = c.size AND l.gen = -1), r.params"
        " FROM traffic t JOIN runs r ON r.id = t.run_id JOIN cache_configs c ON c.id = t.config_id"
        " JOIN scenes s ON s.id = r.scene_id"
        " WHERE r.hierarchy LIKE '%/private,%' AND (c.size = ?1 OR c.size = ?2)"
        " GROUP BY r.id, c.id ORDER BY s.name, r.W, r.H, r.lights, r.hierarchy, r.cores, r.tracer, c.size";
    sqlite3_stmt *st = rt_report_stmt(h, sql, dbpath, e, "II", (int64_t)cores_sizes[0], (int64_t)cores_sizes[1]);
    if (!st) return -1;
    group *G = NULL;
    int ng = 0, capg = 0, rc;
    while ((rc = sqlite3_step(st)) == SQLITE_ROW) {
        const char *sn = (const char *)sqlite3_column_text(st, 0);
        if (scene && strcmp(sn, scene)) continue;
        const int W = sqlite3_column_int(st, 1), H = sqlite3_column_int(st, 2), li = sqlite3_column_int(st, 3);
        const char *hier = (const char *)sqlite3_column_text(st, 6);
        char l1[160];
        const char *lastc = strrchr(hier, ','); /* the private levels: all but the last */
        snprintf(l1, sizeof l1, "%.*s", lastc ? (int)(lastc - hier) : (int)strlen(hier), hier);
        group *g = ng ? &G[ng - 1] : NULL;
        if (!g || strcmp(g->scene, sn) || g->W != W || g->H != H || g->lights != li || strcmp(g->l1, l1)) {
            if (ng == capg) {
                capg = capg ? 2 * capg : 4;
                group *ng2 = realloc(G, (size_t)capg * sizeof *G);
                if (!ng2) {
                    sqlite3_finalize(st);
                    free(G);
                    return rt_errf(e, "out of memory");
                }
                G = ng2;
            }
            g = &G[ng++];
            memset(g, 0, sizeof *g);
            snprintf(g->scene, sizeof g->scene, "%s", sn);
            g->W = W, g->H = H, g->lights = li;
            snprintf(g->l1, sizeof g->l1, "%s", l1);
            for (int z = 0; z < NSZ; z++)
                for (int c = 0; c < NC; c++)
                    for (int t = 0; t < NT; t++) g->v[z][c][t].mb = g->v[z][c][t].miss = NAN;
        }
        /* the tracer, with its structure when not its default (accel=X in the key) */
        char tl[32];
        const char *par = (const char *)sqlite3_column_text(st, 10), *acc = par ? strstr(par, "accel=") : NULL;
        if (acc) snprintf(tl, sizeof tl, "%s/%.*s", (const char *)sqlite3_column_text(st, 4), (int)strcspn(acc + 6, " "),
                          acc + 6);
        else snprintf(tl, sizeof tl, "%s", (const char *)sqlite3_column_text(st, 4));
        const int t = idx_of(g->tracer, &g->nt, NT, tl);
        const int cores = sqlite3_column_int(st, 5);
        int c = 0;
        while (c < g->nc && g->cores[c] != cores) c++;
        if (c == g->nc && g->nc < NC) g->cores[g->nc++] = cores;
        const uint64_t size = (uint64_t)sqlite3_column_int64(st, 7);
        const int z = size == cores_sizes[0] ? 0 : 1;
        if (t < 0 || c >= NC) continue;
        g->v[z][c][t].mb = (double)sqlite3_column_int64(st, 8) / 1048576.0;
        g->v[z][c][t].miss = sqlite3_column_type(st, 9) == SQLITE_NULL ? NAN : sqlite3_column_double(st, 9);
    }
    if (rt_report_done(st, rc, dbpath, e) < 0) {
        free(G);
        return -1;
    }
    if (!ng) {
        free(G);
        return rt_errf(e, "%s: no multi-core runs%s (trace --cores N, then sim --hierarchy "
                          "L1=32K/8/64/lru/private,LLC=1K-4M/full/64/lru/shared --db)", dbpath,
                       scene ? " for that scene" : "");
    }
    if (plot && rt_plot_mkdir(plot->dir, e) < 0) {
        free(G);
        return -1;
    }
    if (csv) fprintf(out, "scene,W,H,lights,private,shared_bytes,cores,tracer,dram_mb,shared_miss_rate,reduction_vs_recursive_pct\n");
    else
        fprintf(out, "# Many cores sharing the last level\n\nDatabase: %s. DRAM traffic in MB below the shared level "
                     "(its LRU, fully associative, 64-byte lines) against the number of cores, each with the private "
                     "level named; reduction = 100 (recursive / tracer - 1), the paper's formula, at the same core count, against the recursive tracer on the same structure; shared miss rate = "
                     "misses / accesses of the shared level.\n", dbpath);
    rc = 0;
    for (int i = 0; i < ng && rc == 0; i++) {
        group *g = &G[i];
        /* each tracer's baseline: the recursive tracer on the same structure */
        int base[NT], any_base = 0;
        for (int t = 0; t < g->nt; t++) {
            char sname[32];
            structure_of(g->tracer[t], sname, sizeof sname);
            base[t] = -1;
            for (int u = 0; u < g->nt; u++) {
                char su[32];
                structure_of(g->tracer[u], su, sizeof su);
                if (u != t && !strncmp(g->tracer[u], "recursive", 9) && (!g->tracer[u][9] || g->tracer[u][9] == '/') &&
                    !strcmp(sname, su) && strncmp(g->tracer[t], "recursive", 9))
                    base[t] = u;
            }
            any_base |= base[t] >= 0;
        }
        (void)any_base;
        for (int z = 0; z < NSZ; z++) {
            int any = 0;
            for (int c = 0; c < g->nc; c++)
                for (int t = 0; t < g->nt; t++) any |= !isnan(g->v[z][c][t].mb);
            if (!any) continue;
            if (!csv) {
                char ln[64];
                fprintf(out, "\n### %s, %dx%d, lights %s, private %s, shared %" PRIu64 "K\n\n| cores |", g->scene, g->W,
                        g->H, rt_exp_lights_name((unsigned)g->lights, ln, sizeof ln), g->l1, cores_sizes[z] / 1024);
                for (int t = 0; t < g->nt; t++) fprintf(out, " %s MB | miss |", g->tracer[t]);
                for (int t = 0; t < g->nt; t++)
                    if (base[t] >= 0) fprintf(out, " %s vs %s |", g->tracer[t], g->tracer[base[t]]);
                fprintf(out, "\n|---:|");
                for (int t = 0; t < g->nt; t++) fprintf(out, "---:|---:|");
                for (int t = 0; t < g->nt; t++)
                    if (base[t] >= 0) fprintf(out, "---:|");
                fprintf(out, "\n");
            }
            for (int c = 0; c < g->nc; c++) {
                const cell *v = g->v[z][c];
                if (!csv) fprintf(out, "| %d |", g->cores[c]);
                for (int t = 0; t < g->nt; t++) {
                    const double red = base[t] >= 0 ? rt_report_reduction(v[base[t]].mb, v[t].mb) : NAN;
                    if (csv) {
                        if (isnan(v[t].mb)) continue;
                        fprintf(out, "%s,%d,%d,%d,%s,%" PRIu64 ",%d,%s,%.3f,", g->scene, g->W, g->H, g->lights, g->l1,
                                cores_sizes[z], g->cores[c], g->tracer[t], v[t].mb);
                        if (!isnan(v[t].miss)) fprintf(out, "%.4f", v[t].miss);
                        fprintf(out, ",");
                        if (!isnan(red)) fprintf(out, "%.1f", red);
                        fprintf(out, "\n");
                        continue;
                    }
                    if (isnan(v[t].mb)) fprintf(out, " - | - |");
                    else if (isnan(v[t].miss)) fprintf(out, " %.2f | - |", v[t].mb);
                    else fprintf(out, " %.2f | %.1f%% |", v[t].mb, 100 * v[t].miss);
                }
                if (!csv) {
                    for (int t = 0; t < g->nt; t++) {
                        if (base[t] < 0) continue;
                        const double red = rt_report_reduction(v[base[t]].mb, v[t].mb);
                        if (isnan(red)) fprintf(out, " - |");
                        else fprintf(out, " %.1f%% |", red);
                    }
                    fprintf(out, "\n");
                }
            }
        }
        if (plot) { /* DRAM traffic against cores at the largest size */
            char dat[4200], gp[4200], png[4200], name[600];
            snprintf(name, sizeof name, "%s-%dx%d-l%d", g->scene, g->W, g->H, g->lights);
            rt_plot_path(dat, sizeof dat, plot->dir, "cores-", name, ".dat");
            rt_plot_path(gp, sizeof gp, plot->dir, "cores-", name, ".gp");
            rt_plot_path(png, sizeof png, plot->dir, "cores-", name, ".png");
            struct rt_out *o;
            FILE *f = rt_plot_open(dat, &o, e);
            if (!f) {
                rc = -1;
                break;
            }
            fprintf(f, "# cores, then DRAM MB per tracer at %" PRIu64 "K\n", cores_sizes[NSZ - 1] / 1024);
            for (int c = 0; c < g->nc; c++) {
                fprintf(f, "%d", g->cores[c]);
                for (int t = 0; t < g->nt; t++)
                    if (isnan(g->v[NSZ - 1][c][t].mb)) fprintf(f, " NaN");
                    else fprintf(f, " %.4g", g->v[NSZ - 1][c][t].mb);
                fprintf(f, "\n");
            }
            if (rt_plot_commit(o, e) < 0 || !(f = rt_plot_open(gp, &o, e))) {
                rc = -1;
                break;
            }
            char title[900], ln[64];
            snprintf(title, sizeof title, "%s, %dx%d, lights %s: DRAM traffic below a shared %" PRIu64 "K, private %s",
                     g->scene, g->W, g->H, rt_exp_lights_name((unsigned)g->lights, ln, sizeof ln),
                     cores_sizes[NSZ - 1] / 1024, g->l1);
            fprintf(f, "set terminal pngcairo size 800,500\nset output ");
            rt_plot_quote_path(f, png);
            fprintf(f, "\nset title ");
            rt_plot_quote(f, title);
            fprintf(f, " noenhanced\nset logscale x 2\nset xlabel \"cores\"\nset ylabel \"DRAM traffic (MB)\"\nset grid\n"
                       "set key top left\nplot ");
            for (int t = 0; t < g->nt; t++) {
                if (t) fprintf(f, ", ''");
                else rt_plot_quote_path(f, dat);
                fprintf(f, " u 1:%d w lp pt 7 t \"%s\"", 2 + t, g->tracer[t]);
            }
            fprintf(f, "\n");
            if (rt_plot_commit(o, e) < 0) {
                rc = -1;
                break;
            }
            const char *outs[] = {png, NULL};
            if (rt_plot_draw(plot, gp, outs, png, e) < 0) rc = -1;
        }
    }
    free(G);
    if (rc == 0) rc = rt_report_flush(out, e);
    return rc;
}
