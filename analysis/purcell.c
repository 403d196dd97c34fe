/*
 * purcell.c -- `report --figure purcell`: the runs of the streaming
 * tracers (stream-branching, stream-multipass) beside Purcell et al. 2002.
 *
 * Everything comes from the runs' statistics strings (tracegen/stream.c
 * writes v, t, s, the pass counts, the per-kernel executions and bytes and
 * the bytes per data type) and, for Figure 9, from their traffic rows: the
 * cache configuration nearest the paper's (64 KB direct-mapped, 48-byte
 * lines) among those simulated. The paper's bunny values are read from
 * data/purcell_bunny.csv, its Table 1 from the tracers (rt_stream_table,
 * which tests/test_stream.c checks against data/purcell_table1.csv).
 * Tables are Markdown, or CSV with --format csv.
 */
#include "analysis.h"
#include "stream.h"

#include <inttypes.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

/* ---- statistics strings --------------------------------------------------- */

static double stat_num(const char *stats, const char *key)
{
    size_t k = strlen(key);
    for (const char *p = stats; (p = strstr(p, key)); p += k)
        if ((p == stats || p[-1] == ' ') && p[k] == '=') return strtod(p + k + 1, NULL);
    return NAN;
}

static int stat_vec(const char *stats, const char *key, double *v, int n)
{
    size_t k = strlen(key);
    for (int i = 0; i < n; i++) v[i] = NAN;
    for (const char *p = stats; (p = strstr(p, key)); p += k)
        if ((p == stats || p[-1] == ' ') && p[k] == '=') {
            const char *q = p + k + 1;
            for (int i = 0; i < n; i++) {
                char *end;
                v[i] = strtod(q, &end);
                if (end == q) return -1;
                q = end + (*end == ',');
            }
            return 0;
        }
    return -1;
}

/* ---- the paper's bunny values ----------------------------------------------- */

enum { PV, PT, PS, PTOT, PTRAV, PISECT, POTHER, PMAXT, PMAXI, PSIMD, NPAPER };
static const char *const paper_keys[NPAPER] = {"v", "t", "s", "passes_total", "passes_traversal",
                                               "passes_intersection", "passes_other", "max_traversals",
                                               "max_intersections", "simd_efficiency"};

static int read_paper(double *pv, rt_err *e)
{
    char path[1024], line[256];
    snprintf(path, sizeof path, "%s/purcell_bunny.csv", RT_SRCDATADIR);
    if (access(path, R_OK) != 0) snprintf(path, sizeof path, "%s/purcell_bunny.csv", RT_DATADIR);
    FILE *f = fopen(path, "r");
    if (!f) return rt_errf(e, "%s: cannot open the paper's bunny values", path);
    for (int i = 0; i < NPAPER; i++) pv[i] = NAN;
    while (fgets(line, sizeof line, f)) {
        char *c = strchr(line, ',');
        if (!c) continue;
        *c = 0;
        for (int i = 0; i < NPAPER; i++)
            if (!strcmp(line, paper_keys[i])) pv[i] = strtod(c + 1, NULL);
    }
    fclose(f);
    for (int i = 0; i < NPAPER; i++)
        if (isnan(pv[i])) return rt_errf(e, "%s: no value for %s", path, paper_keys[i]);
    return 0;
}

/* ---- runs ---------------------------------------------------------------------- */

typedef struct prun {
    long long id;
    char scene[64], tracer[32], params[160], label[320];
    int W, H, mp;
    char *stats;
} prun;

static void cell(FILE *o, int csv, const char *s) { fprintf(o, csv ? ",%s" : " | %s", s); }
static void celld(FILE *o, int csv, const char *fmt, double v)
{
    char b[64];
    if (isnan(v)) snprintf(b, sizeof b, "%s", csv ? "" : "—");
    else snprintf(b, sizeof b, fmt, v);
    cell(o, csv, b);
}
static void head(FILE *o, int csv, const char *title, const char *cols, int ncols)
{
    if (csv) {
        fprintf(o, "# %s\nrun,%s\n", title, cols);
        return;
    }
    fprintf(o, "\n### %s\n\n| run", title);
    char c[512];
    snprintf(c, sizeof c, "%s", cols);
    for (char *t = strtok(c, ","); t; t = strtok(NULL, ",")) fprintf(o, " | %s", t);
    fputs(" |\n|---", o);
    for (int i = 0; i < ncols; i++) fputs("|---:", o);
    fputs("|\n", o);
}
static void row_start(FILE *o, int csv, const char *label) { fprintf(o, csv ? "\"%s\"" : "| %s", label); }
static void row_end(FILE *o, int csv) { fputs(csv ? "\n" : " |\n", o); }

/* Figure 9: per class, traffic with the cache nearest 64 KB / 48 B / direct
 * mapped over the bytes referenced. Prints nothing for runs without rows. */
static int fig9_row(sqlite3 *h, const prun *r, int csv, FILE *o, rt_err *e)
{
    static const char *const cls[] = {"node", "index", "tri", "shade", "stream", "fb"};
    double d[RT_SD_N];
    stat_vec(r->stats, "dbytes", d, RT_SD_N);
    const double ref[6] = {d[RT_SD_GRID], d[RT_SD_LIST], d[RT_SD_TRI], d[RT_SD_SHADE], d[RT_SD_STATE],
                           d[RT_SD_STENCIL] + d[RT_SD_FB]};
    sqlite3_stmt *st;
    const char *sql = "SELECT c.id, c.size, c.line, c.assoc FROM traffic t JOIN cache_configs c ON c.id = t.config_id"
                      " WHERE t.run_id = ?1 GROUP BY c.id"
                      " ORDER BY abs(c.size - 65536), c.line <> 48, c.assoc <> 1, c.id LIMIT 1";
    if (sqlite3_prepare_v2(h, sql, -1, &st, NULL) != SQLITE_OK) return rt_errf(e, "figure 9: %s", sqlite3_errmsg(h));
    sqlite3_bind_int64(st, 1, r->id);
    long long cfg = -1, size = 0, line = 0, assoc = 0;
    if (sqlite3_step(st) == SQLITE_ROW) {
        cfg = sqlite3_column_int64(st, 0);
        size = sqlite3_column_int64(st, 1);
        line = sqlite3_column_int64(st, 2);
        assoc = sqlite3_column_int64(st, 3);
    }
    sqlite3_finalize(st);
    if (cfg < 0) return 0;
    double got[6] = {0, 0, 0, 0, 0, 0}, tot = 0, rtot = 0;
    if (sqlite3_prepare_v2(h, "SELECT class, traffic_bytes FROM traffic WHERE run_id = ?1 AND config_id = ?2", -1, &st,
                           NULL) != SQLITE_OK)
        return rt_errf(e, "figure 9: %s", sqlite3_errmsg(h));
    sqlite3_bind_int64(st, 1, r->id);
    sqlite3_bind_int64(st, 2, cfg);
    while (sqlite3_step(st) == SQLITE_ROW) {
        const char *c = (const char *)sqlite3_column_text(st, 0);
        for (int i = 0; i < 6; i++)
            if (c && !strcmp(c, cls[i])) got[i] += sqlite3_column_double(st, 1);
    }
    sqlite3_finalize(st);
    char cache[96];
    snprintf(cache, sizeof cache, "%lld B, %lld B lines, %s", size, line, assoc ? (assoc == 1 ? "direct" : "set-assoc.") : "fully assoc.");
    row_start(o, csv, r->label);
    cell(o, csv, cache);
    for (int i = 0; i < 6; i++) {
        celld(o, csv, "%.3f", ref[i] > 0 ? got[i] / ref[i] : NAN);
        tot += got[i];
        rtot += ref[i];
    }
    celld(o, csv, "%.3f", rtot > 0 ? tot / rtot : NAN);
    row_end(o, csv);
    return 0;
}

int rt_report_purcell(sqlite3 *h, const char *scene, int csv, FILE *o, rt_err *e)
{
    double pv[NPAPER];
    if (read_paper(pv, e) < 0) return -1;
    sqlite3_stmt *st;
    const char *sql = "SELECT r.id, s.name, r.tracer, r.W, r.H, r.params, r.stats FROM runs r JOIN scenes s ON s.id = "
                      "r.scene_id WHERE r.tracer IN ('stream-branching', 'stream-multipass') AND (?1 IS NULL OR s.name = ?1)"
                      " ORDER BY s.name, r.W, r.H, r.params, r.tracer, r.id";
    if (sqlite3_prepare_v2(h, sql, -1, &st, NULL) != SQLITE_OK) return rt_errf(e, "purcell: %s", sqlite3_errmsg(h));
    if (scene) sqlite3_bind_text(st, 1, scene, -1, SQLITE_TRANSIENT);
    prun *runs = NULL;
    size_t n = 0;
    int rc = 0;
    while (sqlite3_step(st) == SQLITE_ROW) {
        prun *nr = realloc(runs, (n + 1) * sizeof *runs);
        if (!nr) {
            rc = rt_errf(e, "out of memory");
            break;
        }
        runs = nr;
        prun *r = &runs[n];
        memset(r, 0, sizeof *r);
        r->id = sqlite3_column_int64(st, 0);
        snprintf(r->scene, sizeof r->scene, "%s", (const char *)sqlite3_column_text(st, 1));
        snprintf(r->tracer, sizeof r->tracer, "%s", (const char *)sqlite3_column_text(st, 2));
        r->W = sqlite3_column_int(st, 3);
        r->H = sqlite3_column_int(st, 4);
        snprintf(r->params, sizeof r->params, "%s", (const char *)sqlite3_column_text(st, 5));
        r->stats = strdup((const char *)sqlite3_column_text(st, 6));
        r->mp = !strcmp(r->tracer, "stream-multipass");
        snprintf(r->label, sizeof r->label, "%s %s %dx%d%s%s", r->scene, r->mp ? "multipass" : "branching", r->W, r->H,
                 r->params[0] ? " " : "", r->params);
        n++;
        if (!r->stats) {
            rc = rt_errf(e, "out of memory");
            break;
        }
    }
    sqlite3_finalize(st);
    if (rc == 0 && !n) rc = rt_errf(e, "no runs of the stream tracers%s%s", scene ? " on " : "", scene ? scene : "");
    if (rc < 0) goto out;

    if (!csv) fputs("## Purcell et al. 2002: the streaming ray tracer\n", o);
    head(o, csv, "Figure 6: per ray (voxels pierced, triangles tested, shading calculations)", "v,t,s,rays", 4);
    row_start(o, csv, "paper: bunny ray cast 1024x1024");
    celld(o, csv, "%.2f", pv[PV]);
    celld(o, csv, "%.2f", pv[PT]);
    celld(o, csv, "%.2f", pv[PS]);
    celld(o, csv, "%.0f", 1024.0 * 1024.0);
    row_end(o, csv);
    for (size_t i = 0; i < n; i++) {
        row_start(o, csv, runs[i].label);
        celld(o, csv, "%.2f", stat_num(runs[i].stats, "v"));
        celld(o, csv, "%.2f", stat_num(runs[i].stats, "t"));
        celld(o, csv, "%.3f", stat_num(runs[i].stats, "s"));
        celld(o, csv, "%.0f", stat_num(runs[i].stats, "rays"));
        row_end(o, csv);
    }

    head(o, csv, "Table 2: passes of the multipass system",
         "total,traversal,intersection,other,max traversals,max intersections,SIMD efficiency", 7);
    row_start(o, csv, "paper: bunny ray cast 1024x1024");
    for (int k = PTOT; k <= PMAXI; k++) celld(o, csv, "%.0f", pv[k]);
    celld(o, csv, "%.3f", pv[PSIMD]);
    row_end(o, csv);
    static const char *const t2[] = {"passes", "pass_trav", "pass_isect", "pass_other", "max_trav", "max_isect"};
    for (size_t i = 0; i < n; i++) {
        if (!runs[i].mp) continue;
        row_start(o, csv, runs[i].label);
        for (int k = 0; k < 6; k++) celld(o, csv, "%.0f", stat_num(runs[i].stats, t2[k]));
        celld(o, csv, "%.3f", stat_num(runs[i].stats, "simd"));
        row_end(o, csv);
    }

    char cols[256] = "";
    for (int k = 0; k < RT_SK_N; k++) {
        strcat(cols, rt_stream_table(1)[k].name);
        strcat(cols, k + 1 < RT_SK_N ? "," : ",total");
    }
    head(o, csv, "Figure 7: instructions per kernel (millions; Table 1 x kernel executions)", cols, RT_SK_N + 1);
    for (size_t i = 0; i < n; i++) {
        double kx[RT_SK_N], tot = 0;
        stat_vec(runs[i].stats, "kexec", kx, RT_SK_N);
        row_start(o, csv, runs[i].label);
        for (int k = 0; k < RT_SK_N; k++) {
            double v = kx[k] * rt_stream_table(runs[i].mp)[k].instr / 1e6;
            celld(o, csv, "%.2f", v);
            tot += v;
        }
        celld(o, csv, "%.2f", tot);
        row_end(o, csv);
    }
    head(o, csv, "Figure 7: bandwidth per kernel (MB = 2^20 bytes)", cols, RT_SK_N + 1);
    for (size_t i = 0; i < n; i++) {
        double kb[RT_SK_N], tot = 0;
        stat_vec(runs[i].stats, "kbytes", kb, RT_SK_N);
        row_start(o, csv, runs[i].label);
        for (int k = 0; k < RT_SK_N; k++) {
            celld(o, csv, "%.2f", kb[k] / 1048576.0);
            tot += kb[k];
        }
        celld(o, csv, "%.2f", tot / 1048576.0);
        row_end(o, csv);
    }
    head(o, csv, "Figure 8: bandwidth by data type (MB)", "stencil,state,grid,lists,triangles,shading,framebuffer,total",
         RT_SD_N + 1);
    for (size_t i = 0; i < n; i++) {
        double d[RT_SD_N], tot = 0;
        stat_vec(runs[i].stats, "dbytes", d, RT_SD_N);
        row_start(o, csv, runs[i].label);
        for (int k = 0; k < RT_SD_N; k++) {
            celld(o, csv, "%.2f", d[k] / 1048576.0);
            tot += d[k];
        }
        celld(o, csv, "%.2f", tot / 1048576.0);
        row_end(o, csv);
    }
    head(o, csv, "Figure 9: traffic with the cache / bytes referenced",
         "cache,grid,lists,triangles,shading,state,stencil+framebuffer,total", 8);
    for (size_t i = 0; i < n && rc == 0; i++) rc = fig9_row(h, &runs[i], csv, o, e);
out:
    for (size_t i = 0; i < n; i++) free(runs[i].stats);
    free(runs);
    return rc;
}
