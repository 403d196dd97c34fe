/*
 * instances.c -- `report --figure instances`: traffic per level of the
 * two-level instancing structure (`--instances bvh`) beside the same
 * tracer on the flattened scene.
 *
 * The runs compared are those of one tracer that differ only in their
 * structure (as `--figure accel` groups them): exact, full-frame runs (no
 * subsampling, no scheduled size) with the same scene (name and hash),
 * resolution, lights, simulator parameters and run key once the key's
 * "accel=X" and "instances=bvh" are taken out. A group is reported when it
 * holds a two-level run and a flattened one. Per run and cache size (64-
 * byte lines, fully associative; the first policy in name order when
 * several were simulated), the geometry traffic by level, in MB (2^20
 * bytes):
 *
 *   two-level run:  tlas   class tlas, the top-level nodes;
 *                   inst   class inst, the instance records (read per ray
 *                          that enters an instance);
 *                   blas   classes node, index and tri: the shared
 *                          bottom-level nodes and triangles;
 *                   shade  class shade (the flattened triangle's shading
 *                          record, as in the flattened run);
 *   flattened run:  nodes  classes node and index (the structure),
 *                   tri    class tri, shade;
 *   both:           geometry, every class of the geometry group (alpha
 *                   included where a run has it).
 *
 * then, in Markdown, the two-level run's geometry over each flattened
 * run's at the smallest and the largest size. Everything printed comes
 * from counts, so the output is deterministic.
 */
#include "analysis_int.h"
#include "experiment.h"

#include <inttypes.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#define MAXS RT_REPORT_MAXSIZES

enum { L_TLAS, L_INST, L_BLAS, L_SHADE, L_GEOM, NLEV }; /* two-level levels; flattened: BLAS = nodes + tri split below */

typedef struct irun {
    long long id;
    rt_report_group g; /* the group it is compared in */
    char structure[32];
    int two_level;
    int nsizes;
    uint64_t size[MAXS];
    double lev[MAXS][NLEV]; /* two-level: tlas, inst, blas, shade, geometry */
    double nodes[MAXS], tri[MAXS]; /* flattened: the structure's nodes and index lists, triangles */
} irun;

/* The run key without "accel=X" and "instances=bvh" into key; the
 * structure (the accel named, the tracer's default, or "inst") into
 * structure. 0, or -1 for a tracer or structure not known. */
static int split_key(const char *tracer, const char *params, char *key, size_t n, char *structure, size_t sn,
                     int *two_level)
{
    const rt_tracer *tr = rt_tracer_find(tracer);
    if (!tr) return -1;
    int accel = tr->accel_default;
    *two_level = 0;
    size_t k = 0;
    key[0] = 0;
    for (const char *p = params; *p;) {
        size_t len = strcspn(p, " ");
        if (len > 6 && !strncmp(p, "accel=", 6)) {
            char name[32];
            snprintf(name, sizeof name, "%.*s", (int)(len - 6 < 31 ? len - 6 : 31), p + 6);
            if ((accel = rt_accel_from_name(name)) <= 0) return -1;
        } else if (len == 13 && !strncmp(p, "instances=bvh", 13)) {
            *two_level = 1;
        } else if (len) {
            k += (size_t)snprintf(key + k, k < n ? n - k : 0, "%s%.*s", k ? " " : "", (int)len, p);
        }
        p += len;
        while (*p == ' ') p++;
    }
    snprintf(structure, sn, "%s", *two_level ? "inst" : rt_accel_name(accel));
    return k < n ? 0 : -1;
}

/* Traffic of run a by class per cache size (64-byte lines, fully associative). */
static int read_levels(sqlite3 *h, irun *a, rt_err *e)
{
    sqlite3_stmt *st = rt_report_stmt(h,
                                      "SELECT c.size, c.policy, t.class, t.traffic_bytes FROM traffic t"
                                      " JOIN cache_configs c ON c.id = t.config_id JOIN classes k ON k.name = t.class"
                                      " WHERE t.run_id = ?1 AND c.line = 64 AND c.assoc = 0 AND k.grp = 'geometry'"
                                      " ORDER BY c.size, c.policy, t.class",
                                      "instances", e, "I", (int64_t)a->id);
    if (!st) return -1;
    int rc;
    char pol[32] = "";
    a->nsizes = 0;
    while ((rc = sqlite3_step(st)) == SQLITE_ROW) {
        uint64_t s = (uint64_t)sqlite3_column_int64(st, 0);
        const char *p = (const char *)sqlite3_column_text(st, 1), *cls = (const char *)sqlite3_column_text(st, 2);
        double b = sqlite3_column_double(st, 3);
        if (!a->nsizes || a->size[a->nsizes - 1] != s) {
            if (a->nsizes == MAXS) continue;
            a->size[a->nsizes++] = s;
            snprintf(pol, sizeof pol, "%s", p ? p : "");
        } else if (strcmp(pol, p ? p : "")) {
            continue; /* another policy at this size */
        }
        int i = a->nsizes - 1;
        int c = rt_class_from_name(cls ? cls : "");
        a->lev[i][L_GEOM] += b;
        if (c == RT_CLS_TLAS) a->lev[i][L_TLAS] += b;
        else if (c == RT_CLS_INST) a->lev[i][L_INST] += b;
        else if (c == RT_CLS_SHADE) a->lev[i][L_SHADE] += b;
        else if (c == RT_CLS_NODE || c == RT_CLS_INDEX) a->lev[i][L_BLAS] += b, a->nodes[i] += b;
        else if (c == RT_CLS_TRI) a->lev[i][L_BLAS] += b, a->tri[i] += b;
    }
    return rt_report_done(st, rc, "instances", e);
}

static int same_group(const irun *a, const irun *b) { return !rt_report_group_cmp(&a->g, &b->g); }

static int by_group(const void *x, const void *y)
{
    const irun *a = x, *b = y;
    int c = rt_report_group_cmp(&a->g, &b->g);
    if (c) return c;
    if (a->two_level != b->two_level) return a->two_level > b->two_level ? -1 : 1; /* the two-level run first */
    if ((c = strcmp(a->structure, b->structure))) return c;
    return a->id < b->id ? -1 : a->id > b->id;
}

/* Index of size s in run a, or -1. */
static int at(const irun *a, uint64_t s)
{
    for (int i = 0; i < a->nsizes; i++)
        if (a->size[i] == s) return i;
    return -1;
}

static void cell(FILE *o, int csv, double v)
{
    fputs(csv ? "," : " | ", o);
    if (isnan(v)) fputs(csv ? "" : "—", o);
    else if (csv) fprintf(o, "%.0f", v);
    else fprintf(o, "%.3f", v / 1048576.0);
}

/* The sizes of a group: the union of its runs' sizes, ascending. */
static int group_sizes(const irun *g, int n, uint64_t *sz)
{
    int ns = 0;
    for (int i = 0; i < n; i++) ns = rt_report_size_union(sz, ns, MAXS, g[i].size, g[i].nsizes);
    return ns;
}

static void group_label(const irun *a, char *b, size_t n)
{
    rt_report_run_label(b, n, &a->g);
}

/* The value of level row r of run a at size s (NAN: not simulated). */
static double value(const irun *a, const char *row, uint64_t s)
{
    int i = at(a, s);
    if (i < 0) return NAN;
    if (!strcmp(row, "tlas")) return a->lev[i][L_TLAS];
    if (!strcmp(row, "inst")) return a->lev[i][L_INST];
    if (!strcmp(row, "blas")) return a->lev[i][L_BLAS];
    if (!strcmp(row, "nodes")) return a->nodes[i];
    if (!strcmp(row, "tri")) return a->tri[i];
    if (!strcmp(row, "shade")) return a->lev[i][L_SHADE];
    return a->lev[i][L_GEOM];
}

static void group_table(FILE *o, int csv, const irun *g, int n, const uint64_t *sz, int ns)
{
    static const char *const two[] = {"tlas", "inst", "blas", "shade", "geometry"};
    static const char *const flat[] = {"nodes", "tri", "shade", "geometry"};
    char lab[800];
    group_label(g, lab, sizeof lab);
    if (!csv) {
        fprintf(o, "\n### %s\n\n| structure | level", lab);
        for (int k = 0; k < ns; k++) fprintf(o, " | %" PRIu64 " KB", sz[k] / 1024);
        fputs(" |\n|---|---", o);
        for (int k = 0; k < ns; k++) fputs("|---:", o);
        fputs("|\n", o);
    }
    for (int i = 0; i < n; i++) {
        const char *const *rows = g[i].two_level ? two : flat;
        int nr = g[i].two_level ? 5 : 4;
        char name[48];
        snprintf(name, sizeof name, "%s%s", g[i].structure, g[i].two_level ? " (two-level)" : " (flatten)");
        for (int r = 0; r < nr; r++) {
            if (csv) {
                for (int k = 0; k < ns; k++) {
                    fputc('"', o);
                    for (const char *p = lab; *p; p++) fputs(*p == '"' ? "\"\"" : (char[2]){*p, 0}, o);
                    fprintf(o, "\",%s,%s,%s,%" PRIu64, g[i].structure, g[i].two_level ? "bvh" : "flatten", rows[r],
                            sz[k]);
                    cell(o, 1, value(&g[i], rows[r], sz[k]));
                    fputc('\n', o);
                }
                continue;
            }
            fprintf(o, "| %s | %s", r ? "" : name, rows[r]);
            for (int k = 0; k < ns; k++) cell(o, 0, value(&g[i], rows[r], sz[k]));
            fputs(" |\n", o);
        }
    }
    if (csv || !ns) return;
    /* the two-level run's geometry against each flattened run's */
    fputs("\nTwo-level geometry over flattened:", o);
    const uint64_t ends[2] = {sz[0], sz[ns - 1]};
    for (int e = 0; e < (ns > 1 ? 2 : 1); e++) {
        fprintf(o, "%s at %" PRIu64 " KB", e ? ";" : "", ends[e] / 1024);
        for (int i = 1; i < n; i++) {
            double a = value(&g[0], "geometry", ends[e]), b = value(&g[i], "geometry", ends[e]);
            if (isnan(a) || isnan(b)) continue;
            if (b > 0) fprintf(o, " %.2fx %s", a / b, g[i].structure);
            else fprintf(o, " %.3f MB against 0 (%s)", a / 1048576.0, g[i].structure);
        }
    }
    fputs(".\n", o);
}

int rt_report_instances(sqlite3 *h, const char *scene, int csv, FILE *out, rt_err *e)
{
    sqlite3_stmt *st = rt_report_stmt(
        h,
        "SELECT r.id, s.name, s.hash, r.W, r.H, r.lights, r.tracer, r.params, r.sim_params FROM runs r"
        " JOIN scenes s ON s.id = r.scene_id WHERE r.sim_method = 'exact' AND r.sched_size = 0"
        " AND r.params NOT LIKE '%subsample=%' AND r.params NOT LIKE '%sim=all-sizes%'"
        " AND (?1 IS NULL OR s.name = ?1) ORDER BY r.id",
        "instances", e, "s", scene);
    if (!st) return -1;
    irun *A = NULL;
    long n = 0;
    int rc;
    while ((rc = sqlite3_step(st)) == SQLITE_ROW) {
        irun *na = realloc(A, (size_t)(n + 1) * sizeof *A);
        if (!na) {
            sqlite3_finalize(st);
            free(A);
            return rt_errf(e, "out of memory");
        }
        A = na;
        irun *a = &A[n];
        memset(a, 0, sizeof *a);
        const char *params = (const char *)sqlite3_column_text(st, 7), *sp = (const char *)sqlite3_column_text(st, 8);
        snprintf(a->g.tracer, sizeof a->g.tracer, "%s", (const char *)sqlite3_column_text(st, 6));
        if (split_key(a->g.tracer, params ? params : "", a->g.key, sizeof a->g.key, a->structure, sizeof a->structure,
                      &a->two_level) < 0)
            continue;
        a->id = sqlite3_column_int64(st, 0);
        snprintf(a->g.scene, sizeof a->g.scene, "%s", (const char *)sqlite3_column_text(st, 1));
        snprintf(a->g.hash, sizeof a->g.hash, "%s", (const char *)sqlite3_column_text(st, 2));
        a->g.W = sqlite3_column_int(st, 3);
        a->g.H = sqlite3_column_int(st, 4);
        a->g.lights = sqlite3_column_int(st, 5);
        snprintf(a->g.sim_params, sizeof a->g.sim_params, "%s", sp ? sp : "");
        n++;
    }
    if (rt_report_done(st, rc, "instances", e) < 0) {
        free(A);
        return -1;
    }
    for (long i = 0; i < n; i++)
        if (read_levels(h, &A[i], e) < 0) {
            free(A);
            return -1;
        }
    if (n) qsort(A, (size_t)n, sizeof *A, by_group);
    if (csv) fputs("group,structure,instances,level,cache_bytes,bytes\n", out);
    else
        fputs("## Instancing: geometry traffic per level, two-level against flattened\n\n"
              "Runs of one tracer that differ only in their structure, one of them `--instances bvh`. Two-level "
              "run: tlas (top-level nodes), inst (instance records), blas (the shared bottom-level nodes and "
              "triangles), shade; flattened runs: nodes (nodes and index lists), tri, shade; both: all geometry "
              "classes. MB (2^20 bytes) per cache size (64-byte lines, fully associative).\n",
              out);
    int groups = 0;
    for (long i = 0; i < n;) {
        long j = i + 1;
        while (j < n && same_group(&A[i], &A[j])) j++;
        /* one run per structure (the first stored), the two-level one first */
        irun *g = &A[i];
        int m = 0;
        for (long k = i; k < j; k++)
            if (!m || strcmp(g[m - 1].structure, A[k].structure)) g[m++] = A[k];
        if (m >= 2 && g[0].two_level) {
            uint64_t sz[MAXS];
            int ns = group_sizes(g, m, sz);
            group_table(out, csv, g, m, sz, ns);
            groups++;
        }
        i = j;
    }
    free(A);
    if (!groups)
        return rt_errf(e, "no two-level run beside a flattened run of the same tracer%s%s (sweep --instances bvh "
                          "and a plain sweep of the same scene)",
                       scene ? " on " : "", scene ? scene : "");
    return rt_report_flush(out, e);
}
