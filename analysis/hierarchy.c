/*
 * hierarchy.c -- `report --figure hierarchy`: cache hierarchies and
 * replacement policies (docs/cachesim.md).
 *
 * Two tables, Markdown, everything from counts (deterministic):
 *
 *   1. Per level: for every run simulated through a hierarchy (runs.hierarchy
 *      not ''), one row per (level, cache size): the level's accesses,
 *      misses and the bytes it moves to the level below, per class group
 *      (geometry, ray, other, KB = 1024 bytes); the last level's bytes are
 *      the DRAM traffic. The heading names the inclusion (non-inclusive,
 *      inclusive, exclusive); an inclusive or exclusive run has its levels
 *      once per last-level size (one chain each: the rows lead with that
 *      size) and two more columns, the back-invalidations and their
 *      write-backs. A file older than schema 8 has no such runs.
 *   2. Policy comparison: single-level exact runs that differ only in their
 *      replacement policy (same scene, hash, tracer, resolution, lights,
 *      run key, simulator parameters, no hierarchy) and include an `opt`
 *      run: one row per cache size (64-byte lines, fully associative or
 *      the associativity of the opt run), total traffic in KB per policy
 *      (lru, plru, srrip, brrip, fifo, random, opt: those present), and
 *      LRU's gap to OPT, 100 (LRU / OPT - 1) %: how much of the tracer's
 *      traffic at that size is the policy's rather than the ray order's.
 *
 * Returns -1 with a message when neither table has a run.
 */
#include "analysis_int.h"
#include "experiment.h"

#include <inttypes.h>
#include <stdlib.h>
#include <string.h>

#define NPOL 7
static const char *const pols[NPOL] = {"lru", "plru", "srrip", "brrip", "fifo", "random", "opt"};

/* 1 if level_traffic has schema 8's inclusion columns. */
static int has_inclusion(sqlite3 *h)
{
    sqlite3_stmt *st;
    int r = 0;
    if (sqlite3_prepare_v2(h, "SELECT 1 FROM pragma_table_info('level_traffic') WHERE name = 'last_size'", -1, &st,
                           NULL) == SQLITE_OK)
        r = sqlite3_step(st) == SQLITE_ROW;
    sqlite3_finalize(st);
    return r;
}

/* The inclusion of a stored spec (rt_hier_spec writes it last, nine never). */
static const char *inclusion_of(const char *spec, int *incl)
{
    size_t n = strlen(spec);
    *incl = 1;
    if (n > 10 && !strcmp(spec + n - 10, ",inclusive")) return "inclusive";
    if (n > 10 && !strcmp(spec + n - 10, ",exclusive")) return "exclusive";
    *incl = 0;
    return "non-inclusive";
}

static int levels(sqlite3 *h, const char *scene, FILE *out, int *nrows, rt_err *e)
{
    int hi = has_inclusion(h);
    char sql[1600];
    snprintf(sql, sizeof sql,
             "SELECT r.id, s.name, r.tracer, r.W, r.H, r.lights, r.hierarchy, l.level, l.level_name, l.cache_size, l.line,"
             " l.assoc, l.repl, SUM(l.accesses), SUM(l.misses),"
             " TOTAL(CASE WHEN k.grp = 'geometry' THEN l.traffic_bytes END),"
             " TOTAL(CASE WHEN k.grp = 'ray' THEN l.traffic_bytes END),"
             " TOTAL(CASE WHEN k.grp = 'other' THEN l.traffic_bytes END), %s"
             " FROM level_traffic l JOIN runs r ON r.id = l.run_id JOIN scenes s ON s.id = r.scene_id"
             " JOIN classes k ON k.name = l.class"
             " WHERE r.hierarchy <> '' AND l.gen = -1 AND l.core = -1 AND (?1 IS NULL OR s.name = ?1)"
             " GROUP BY r.id, %s l.level, l.cache_size, l.line, l.assoc, l.policy, l.repl"
             " ORDER BY s.name, r.W, r.H, r.lights, r.tracer, r.id, %s l.level, l.cache_size",
             hi ? "l.last_size, SUM(l.backinvals), SUM(l.bi_writebacks)" : "0, 0, 0", hi ? "l.last_size," : "",
             hi ? "l.last_size," : "");
    sqlite3_stmt *st = rt_report_stmt(h, sql, "hierarchy", e, scene ? "s" : "", scene);
    if (!st) return -1;
    long long last = -1;
    int rc, incl = 0;
    while ((rc = sqlite3_step(st)) == SQLITE_ROW) {
        long long id = sqlite3_column_int64(st, 0);
        if (id != last) {
            if (!*nrows) fprintf(out, "## Cache hierarchies: traffic per level\n");
            const char *spec = (const char *)sqlite3_column_text(st, 6);
            const char *in = inclusion_of(spec, &incl);
            char ln[64];
            fprintf(out, "\n### %s, %s, %dx%d, lights %s, run %lld: %s (%s)\n\n", sqlite3_column_text(st, 1),
                    sqlite3_column_text(st, 2), sqlite3_column_int(st, 3), sqlite3_column_int(st, 4),
                    rt_exp_lights_name((unsigned)sqlite3_column_int(st, 5), ln, sizeof ln), id, spec, in);
            if (incl)
                fprintf(out, "| last-level size | level | size | line | ways | repl | accesses | misses | geometry KB |"
                             " ray KB | other KB | to the level below KB | back-invalidations | their write-backs |\n"
                             "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
            else
                fprintf(out, "| level | size | line | ways | repl | accesses | misses | geometry KB | ray KB | other KB |"
                             " to the level below KB |\n|---|---|---|---|---|---|---|---|---|---|---|\n");
            last = id;
        }
        if (incl) fprintf(out, "| %lld ", sqlite3_column_int64(st, 18));
        double g = sqlite3_column_double(st, 15), r = sqlite3_column_double(st, 16), o = sqlite3_column_double(st, 17);
        int assoc = sqlite3_column_int(st, 11);
        char ways[16];
        if (assoc) snprintf(ways, sizeof ways, "%d", assoc);
        else strcpy(ways, "full");
        fprintf(out, "| %s | %lld | %d | %s | %s | %lld | %lld | %.1f | %.1f | %.1f | %.1f |", sqlite3_column_text(st, 8),
                sqlite3_column_int64(st, 9), sqlite3_column_int(st, 10), ways, sqlite3_column_text(st, 12),
                sqlite3_column_int64(st, 13), sqlite3_column_int64(st, 14), g / 1024, r / 1024, o / 1024,
                (g + r + o) / 1024);
        if (incl) fprintf(out, " %lld | %lld |", sqlite3_column_int64(st, 19), sqlite3_column_int64(st, 20));
        fputc('\n', out);
        (*nrows)++;
    }
    return rt_report_done(st, rc, "hierarchy", e);
}

/* One group of runs differing only in their policy: traffic per size. */
typedef struct pgroup {
    long long id[NPOL]; /* run per policy, 0 = none */
    int assoc;
} pgroup;

static int policy_table(sqlite3 *h, const pgroup *g, FILE *out, rt_err *e)
{
    /* sizes: those of the opt run */
    sqlite3_stmt *st = rt_report_stmt(h,
                                      "SELECT c.size, TOTAL(t.traffic_bytes) FROM traffic t JOIN cache_configs c ON"
                                      " c.id = t.config_id WHERE t.run_id = ?1 AND c.line = 64 AND c.assoc = ?2"
                                      " GROUP BY c.size ORDER BY c.size",
                                      "hierarchy", e, "Ii", (int64_t)g->id[NPOL - 1], g->assoc);
    if (!st) return -1;
    fprintf(out, "| size |");
    for (int p = 0; p < NPOL; p++)
        if (g->id[p]) fprintf(out, " %s KB |", pols[p]);
    fprintf(out, " LRU gap to OPT |\n|---|");
    for (int p = 0; p < NPOL; p++)
        if (g->id[p]) fprintf(out, "---|");
    fprintf(out, "---|\n");
    int rc;
    while ((rc = sqlite3_step(st)) == SQLITE_ROW) {
        int64_t size = sqlite3_column_int64(st, 0);
        double opt = sqlite3_column_double(st, 1), lru = -1;
        fprintf(out, "| %" PRId64 " |", size);
        for (int p = 0; p < NPOL; p++) {
            if (!g->id[p]) continue;
            sqlite3_stmt *q = rt_report_stmt(h,
                                             "SELECT TOTAL(t.traffic_bytes), COUNT(*) FROM traffic t JOIN cache_configs c"
                                             " ON c.id = t.config_id WHERE t.run_id = ?1 AND c.size = ?2 AND c.line = 64"
                                             " AND c.assoc = ?3",
                                             "hierarchy", e, "IIi", (int64_t)g->id[p], size, g->assoc);
            if (!q) return sqlite3_finalize(st), -1;
            double v = -1;
            int r2 = sqlite3_step(q);
            if (r2 == SQLITE_ROW && sqlite3_column_int(q, 1) > 0) v = sqlite3_column_double(q, 0);
            if (rt_report_done(q, r2, "hierarchy", e) < 0) return sqlite3_finalize(st), -1;
            if (p == 0) lru = v;
            if (v < 0) fprintf(out, " - |");
            else fprintf(out, " %.1f |", v / 1024);
        }
        if (lru >= 0 && opt > 0) fprintf(out, " %.1f%% |\n", 100 * (lru / opt - 1));
        else fprintf(out, " - |\n");
    }
    return rt_report_done(st, rc, "hierarchy", e);
}

static int policies(sqlite3 *h, const char *scene, FILE *out, int *ngroups, rt_err *e)
{
    /* every opt run, then the runs of its group */
    sqlite3_stmt *st = rt_report_stmt(
        h,
        "SELECT r.id, s.name, r.scene_id, r.tracer, r.W, r.H, r.lights, r.params, r.sim_params,"
        " (SELECT MIN(c.assoc) FROM traffic t JOIN cache_configs c ON c.id = t.config_id WHERE t.run_id = r.id)"
        " FROM runs r JOIN scenes s ON s.id = r.scene_id"
        " WHERE r.repl = 'opt' AND r.hierarchy = '' AND r.sim_method = 'exact' AND (?1 IS NULL OR s.name = ?1)"
        " ORDER BY s.name, r.W, r.H, r.lights, r.tracer, r.id",
        "hierarchy", e, scene ? "s" : "", scene);
    if (!st) return -1;
    int rc;
    while ((rc = sqlite3_step(st)) == SQLITE_ROW) {
        pgroup g;
        memset(&g, 0, sizeof g);
        g.id[NPOL - 1] = sqlite3_column_int64(st, 0);
        g.assoc = sqlite3_column_int(st, 9);
        for (int p = 0; p < NPOL - 1; p++) {
            sqlite3_stmt *q = rt_report_stmt(h,
                                             "SELECT MIN(id) FROM runs WHERE scene_id = ?1 AND tracer = ?2 AND W = ?3 AND"
                                             " H = ?4 AND lights = ?5 AND params = ?6 AND sim_params = ?7 AND repl = ?8"
                                             " AND hierarchy = '' AND sim_method = 'exact'",
                                             "hierarchy", e, "Isiiisss", (int64_t)sqlite3_column_int64(st, 2),
                                             (const char *)sqlite3_column_text(st, 3), sqlite3_column_int(st, 4),
                                             sqlite3_column_int(st, 5), sqlite3_column_int(st, 6),
                                             (const char *)sqlite3_column_text(st, 7),
                                             (const char *)sqlite3_column_text(st, 8), pols[p]);
            if (!q) return sqlite3_finalize(st), -1;
            int r2 = sqlite3_step(q);
            if (r2 == SQLITE_ROW) g.id[p] = sqlite3_column_int64(q, 0);
            if (rt_report_done(q, r2, "hierarchy", e) < 0) return sqlite3_finalize(st), -1;
        }
        if (!*ngroups) fprintf(out, "\n## Replacement policies against OPT\n");
        char ways[32];
        if (g.assoc) snprintf(ways, sizeof ways, "%d-way", g.assoc);
        else strcpy(ways, "fully associative");
        char ln[64];
        fprintf(out, "\n### %s, %s, %dx%d, lights %s (%s, 64-byte lines; total traffic)\n\n", sqlite3_column_text(st, 1),
                sqlite3_column_text(st, 3), sqlite3_column_int(st, 4), sqlite3_column_int(st, 5),
                rt_exp_lights_name((unsigned)sqlite3_column_int(st, 6), ln, sizeof ln), ways);
        if (policy_table(h, &g, out, e) < 0) return sqlite3_finalize(st), -1;
        (*ngroups)++;
    }
    return rt_report_done(st, rc, "hierarchy", e);
}

int rt_report_hierarchy(sqlite3 *h, const char *scene, FILE *out, rt_err *e)
{
    int nrows = 0, ngroups = 0;
    if (levels(h, scene, out, &nrows, e) < 0 || policies(h, scene, out, &ngroups, e) < 0) return -1;
    if (!nrows && !ngroups)
        return rt_errf(e, "no hierarchy runs (sweep/sim --hierarchy) and no --repl opt runs to compare policies with");
    return rt_report_flush(out, e);
}
