/*
 * report.c -- what every report shares: the read-only database, the
 * report's axes and the one query every table is made of.
 *
 * A report reads, never writes, and creates no file. Even a read-only
 * SQLite connection creates the -wal and -shm files of a WAL database
 * when they are missing (and fails where the folder is read-only), so the
 * open depends on the -wal file:
 * - no -wal file: no connection has the database open and everything is
 *   in the main file (the last connection to close checkpoints and removes
 *   the -wal), so it is opened immutable (URI immutable=1): no locks, no
 *   side files, and a read-only file in a read-only folder works;
 * - a -wal file: a writer is active (a sweep) or was killed, and the -wal
 *   may hold committed runs, so it is opened read-only the normal way
 *   (mode=ro), reading the -wal under the usual locks.
 *
 * Axes: the resolution (the largest exact run's unless asked), the cache
 * sizes with fully associative 64-byte write-back write-allocate traffic,
 * the scenes at that resolution (the paper's room, grove, sphereflake
 * first; a scene is a (name, content hash) pair, so two different meshes of
 * one file name stay two scenes, each labelled with the path it was given
 * as), and the packet edge of the packet runs, which decides where
 * packets are not reported (a cache that cannot hold one packet of rays).
 */
#include "analysis_int.h"
#include "db.h"
#include "experiment.h"

#include <ctype.h>
#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

/* The tracer names the traits give the paper's figures (RT_FIG_NAVRATIL:
 * baseline, packet, scheduled), as SQL: the one place the report's
 * queries learn them (tokens @BASE@, @PACKET@, @SCHED@, @NAVRATIL@). */
static char *expand_tracers(sqlite3 *h, const char *sql, rt_err *e)
{
    const rt_tracer *t[3] = {NULL, NULL, NULL};
    rt_report_fig_tracers(RT_FIG_NAVRATIL, t, 3);
    char q[3][64], in[200];
    for (int k = 0; k < 3; k++) snprintf(q[k], sizeof q[k], "'%s'", t[k] ? t[k]->name : "");
    snprintf(in, sizeof in, "(%s, %s, %s)", q[0], q[1], q[2]);
    /* @DIMS@: the schema-6 dimensions at the values every figure is
     * drawn for (LRU, one level, one core, point lights, flattened
     * instances); runs of other values are other setups. Older files have
     * only such runs. */
    sqlite3_stmt *c;
    int v6 = 0;
    if (sqlite3_prepare_v2(h, "SELECT 1 FROM pragma_table_info('runs') WHERE name = 'hierarchy'", -1, &c, NULL) ==
        SQLITE_OK)
        v6 = sqlite3_step(c) == SQLITE_ROW;
    sqlite3_finalize(c);
    const char *dims = v6 ? "(r.repl = 'lru' AND r.hierarchy = '' AND r.cores = 1 AND r.light_model = 'point' AND "
                            "r.instances = 'flatten')"
                          : "1";
    static const char *const tok[5] = {"@BASE@", "@PACKET@", "@SCHED@", "@NAVRATIL@", "@DIMS@"};
    const char *val[5] = {q[0], q[1], q[2], in, dims};
    size_t n = strlen(sql) + 1;
    for (const char *p = sql; (p = strchr(p, '@')); p++)
        n += sizeof in + strlen(dims);
    char *out = rt_calloc(n, 1, e), *w = out;
    if (!out) return NULL;
    for (const char *p = sql; *p;) {
        int hit = -1;
        for (int k = 0; k < 5 && hit < 0; k++)
            if (!strncmp(p, tok[k], strlen(tok[k]))) hit = k;
        if (hit < 0) {
            *w++ = *p++;
            continue;
        }
        w += sprintf(w, "%s", val[hit]);
        p += strlen(tok[hit]);
    }
    *w = 0;
    return out;
}

sqlite3_stmt *rt_report_stmt(sqlite3 *h, const char *sql, const char *context, rt_err *e, const char *types, ...)
{
    sqlite3_stmt *st;
    char *x = strchr(sql, '@') ? expand_tracers(h, sql, e) : NULL;
    if (strchr(sql, '@') && !x) return NULL;
    int prc = sqlite3_prepare_v2(h, x ? x : sql, -1, &st, NULL);
    free(x);
    if (prc != SQLITE_OK) {
        rt_errf(e, "%s: %s", context, sqlite3_errmsg(h));
        return NULL;
    }
    va_list ap;
    va_start(ap, types);
    for (int i = 0; types[i]; i++) {
        if (types[i] == 's') sqlite3_bind_text(st, i + 1, va_arg(ap, const char *), -1, SQLITE_TRANSIENT);
        else if (types[i] == 'i') sqlite3_bind_int(st, i + 1, va_arg(ap, int));
        else sqlite3_bind_int64(st, i + 1, (sqlite3_int64)va_arg(ap, int64_t));
    }
    va_end(ap);
    return st;
}

int rt_report_done(sqlite3_stmt *st, int rc, const char *context, rt_err *e)
{
    if (rc != SQLITE_ROW && rc != SQLITE_DONE) rt_errf(e, "%s: %s", context, sqlite3_errmsg(sqlite3_db_handle(st)));
    sqlite3_finalize(st);
    return rc != SQLITE_ROW && rc != SQLITE_DONE ? -1 : 0;
}

int rt_report_flush(FILE *out, rt_err *e)
{
    if (fflush(out) != 0 || ferror(out)) return rt_errf(e, "write error: %s", strerror(errno ? errno : EIO));
    return 0;
}

int rt_report_db_open(const char *path, sqlite3 **ph, rt_err *e)
{
    /* the one reading rule of results/db.c (immutable without a -wal
     * file, nothing created beside it; FIFOs, devices and memory refused) */
    *ph = NULL;
    struct stat sb;
    if (path && path[0] && path[0] != ':' && stat(path, &sb) < 0 && errno == ENOENT)
        return rt_errf(e, "%s: %s (run `raytraffic sweep` first)", path, strerror(errno));
    void *h = NULL;
    int ver = 0;
    if (rt_db_open_read(path, &h, &ver, e) < 0) return -1;
    *ph = h;
    return 0;
}

/* A scene's label: its name, and when another scene has that name but
 * other content, the path it was given as (else its parameters, else its
 * hash), plus the hash if that path is shared too. P is s's path column
 * and O another scene's ('' before schema 3, which had no paths). */
#define LABEL_EXPR(P, O)                                                                                      \
    "(CASE WHEN EXISTS(SELECT 1 FROM scenes o WHERE o.name = s.name AND o.hash <> s.hash) THEN s.name || ' (' " \
    "|| CASE WHEN " P " <> '' THEN " P " WHEN s.params <> '' THEN s.params ELSE substr(s.hash, 1, 8) END "     \
    "|| CASE WHEN " P " <> '' AND EXISTS(SELECT 1 FROM scenes o WHERE o.name = s.name AND o.hash <> s.hash "    \
    "AND " O " = " P ") THEN ' #' || substr(s.hash, 1, 8) ELSE '' END || ')' ELSE s.name END)"

/* 1 if the scenes table has the paths of schema 3. */
static int has_paths(sqlite3 *h)
{
    sqlite3_stmt *st;
    int r = 0;
    if (sqlite3_prepare_v2(h, "SELECT 1 FROM pragma_table_info('scenes') WHERE name = 'abspath'", -1, &st, NULL) ==
        SQLITE_OK)
        r = sqlite3_step(st) == SQLITE_ROW;
    sqlite3_finalize(st);
    return r;
}

char *rt_report_label_sql(sqlite3 *h, const char *sql, rt_err *e)
{
    const char *lab = has_paths(h) ? LABEL_EXPR("s.path", "o.path") : LABEL_EXPR("''", "''");
    size_t n = strlen(sql) + 1, ll = strlen(lab);
    for (const char *p = sql; (p = strstr(p, "@LABEL@")); p += 7) n += ll;
    char *out = rt_calloc(n, 1, e), *w = out;
    if (!out) return NULL;
    for (const char *p = sql, *q; *p; p = q + 7) {
        if (!(q = strstr(p, "@LABEL@"))) {
            strcpy(w, p);
            break;
        }
        memcpy(w, p, (size_t)(q - p));
        w += q - p;
        memcpy(w, lab, ll);
        w += ll;
        *w = 0;
    }
    return out;
}

int rt_report_scene_index(const rt_report *R, const char *label)
{
    for (int i = 0; i < R->nscenes; i++)
        if (!strcmp(R->scenes[i], label)) return i;
    for (int i = 0; i < R->nscenes; i++)
        if (!strcmp(R->scene_name[i], label)) return i;
    return -1;
}

/* Runs that belong in the paper's figures: its three tracers, primary and
 * shadow rays only (no mode= parameter). */
#define PAPER_RUNS "r.tracer IN @NAVRATIL@ AND r.params NOT LIKE '%mode=%' AND @DIMS@"
#define PAPER_TRACERS "tracer IN @NAVRATIL@"

int rt_report_init(rt_report *R, sqlite3 *h, const char *dbpath, const rt_report_opts *o, rt_err *e)
{
    memset(R, 0, sizeof *R);
    R->h = h;
    R->dbpath = dbpath;
    R->csv = o->csv;
    R->total = o->total;
    R->W = o->W;
    R->H = o->H;
    R->packet = 8;
    R->model = -1;
    snprintf(R->policy, sizeof R->policy, "wb-wa");
    sqlite3_stmt *st;
    int rc;
    int model = -1;
    if (o->model && (model = rt_exp_model_find(o->model)) < 0)
        return rt_errf(e, "model '%s' is not lean or paper", o->model);
    if (!R->W) {
        st = rt_report_stmt(h, "SELECT W, H FROM runs r WHERE sim_method = 'exact' AND tracer IN @NAVRATIL@ AND @DIMS@"
                            " ORDER BY W * H DESC LIMIT 1", dbpath,
                            e, "");
        if (!st) return -1;
        if ((rc = sqlite3_step(st)) == SQLITE_ROW) {
            R->W = sqlite3_column_int(st, 0);
            R->H = sqlite3_column_int(st, 1);
        }
        if (rt_report_done(st, rc, dbpath, e) < 0) return -1;
    }
    /* no model asked: the default runs; a database holding only one named
     * model's exact runs is read as that model's (never a mix) */
    if (model < 0) {
        st = rt_report_stmt(h,
                            "SELECT (SELECT COUNT(*) FROM runs WHERE sim_method = 'exact' AND sim_params NOT LIKE 'model=%'"
                            " AND " PAPER_TRACERS "), (SELECT COUNT(*) FROM runs WHERE sim_method = 'exact' AND"
                            " sim_params LIKE 'model=paper%' AND " PAPER_TRACERS ")",
                            dbpath, e, "");
        if (!st) return -1;
        if ((rc = sqlite3_step(st)) == SQLITE_ROW && sqlite3_column_int64(st, 0) == 0 && sqlite3_column_int64(st, 1) > 0)
            model = RT_EXP_MODEL_PAPER;
        if (rt_report_done(st, rc, dbpath, e) < 0) return -1;
    }
    if (rt_report_set_model(R, model, e) < 0) return -1;
    if (o->layout) {
        int g = rt_render_geom_from_name(o->layout);
        if (g < 0 || model < 0) return rt_errf(e, "layout '%s' needs a model and one of compact, mesh, pbrt, pbrt64", o->layout);
        R->geom = g;
    }
    /* scenes, one per (name, content hash), in the paper's order first,
     * of runs of the paper's tracers in its modes (render modes of other
     * papers' tracers have reports of their own: --figure purcell, ...),
     * then the rest by label; the latest known place of a mesh file */
    char *sql = rt_report_label_sql(
        h,
        has_paths(h)
            ? "SELECT @LABEL@ AS label, s.name, s.hash, MAX(s.abspath) FROM runs r JOIN scenes s ON s.id = r.scene_id"
              " WHERE r.W = ?1 AND r.H = ?2 AND " PAPER_RUNS " GROUP BY s.name, s.hash ORDER BY CASE s.name WHEN 'room' THEN 0 WHEN"
              " 'grove' THEN 1 WHEN 'sphereflake' THEN 2 ELSE 3 END, label"
            : "SELECT @LABEL@ AS label, s.name, s.hash, '' FROM runs r JOIN scenes s ON s.id = r.scene_id"
              " WHERE r.W = ?1 AND r.H = ?2 AND " PAPER_RUNS " GROUP BY s.name, s.hash ORDER BY CASE s.name WHEN 'room' THEN 0 WHEN"
              " 'grove' THEN 1 WHEN 'sphereflake' THEN 2 ELSE 3 END, label",
        e);
    if (!sql) return -1;
    st = rt_report_stmt(h, sql, dbpath, e, "ii", R->W, R->H);
    free(sql);
    if (!st) return -1;
    int cap = 0;
    while ((rc = sqlite3_step(st)) == SQLITE_ROW) {
        const char *lab = (const char *)sqlite3_column_text(st, 0), *n = (const char *)sqlite3_column_text(st, 1);
        const char *hash = (const char *)sqlite3_column_text(st, 2), *abs = (const char *)sqlite3_column_text(st, 3);
        /* --scene picks a label, or every scene of a name */
        if (o->scene && strcmp(lab, o->scene) && strcmp(n, o->scene)) continue;
        if (R->nscenes == cap) {
            int nc = cap ? 2 * cap : 16;
            char **a = rt_reallocarray(R->scenes, (size_t)nc, sizeof *a, e);
            if (a) R->scenes = a;
            char **b = a ? rt_reallocarray(R->scene_name, (size_t)nc, sizeof *b, e) : NULL;
            if (b) R->scene_name = b;
            char(*c)[17] = b ? rt_reallocarray(R->scene_hash, (size_t)nc, sizeof *c, e) : NULL;
            if (c) R->scene_hash = c;
            char **d = c ? rt_reallocarray(R->scene_abspath, (size_t)nc, sizeof *d, e) : NULL;
            if (d) R->scene_abspath = d;
            if (!d) {
                sqlite3_finalize(st);
                return -1;
            }
            cap = nc;
        }
        int k = R->nscenes;
        R->scenes[k] = strdup(lab);
        R->scene_name[k] = strdup(n);
        R->scene_abspath[k] = strdup(abs ? abs : "");
        snprintf(R->scene_hash[k], sizeof R->scene_hash[0], "%s", hash ? hash : "");
        R->nscenes++;
        if (!R->scenes[k] || !R->scene_name[k] || !R->scene_abspath[k]) {
            sqlite3_finalize(st);
            return rt_errf(e, "%s: out of memory reading the scenes", dbpath);
        }
    }
    if (rt_report_done(st, rc, dbpath, e) < 0) return -1;
    st = rt_report_stmt(h, "SELECT params FROM runs WHERE tracer = @PACKET@ LIMIT 1", dbpath, e, "");
    if (!st) return -1;
    if ((rc = sqlite3_step(st)) == SQLITE_ROW && sqlite3_column_text(st, 0)) {
        const char *p = strstr((const char *)sqlite3_column_text(st, 0), "packet=");
        if (p) R->packet = atoi(p + 7);
    }
    return rt_report_done(st, rc, dbpath, e);
}

void rt_report_free(rt_report *R)
{
    if (!R) return;
    for (int i = 0; i < R->nscenes; i++) {
        if (R->scenes) free(R->scenes[i]);
        if (R->scene_name) free(R->scene_name[i]);
        if (R->scene_abspath) free(R->scene_abspath[i]);
    }
    free(R->scenes);
    free(R->scene_name);
    free(R->scene_hash);
    free(R->scene_abspath);
    R->scenes = R->scene_name = R->scene_abspath = NULL;
    R->scene_hash = NULL;
    R->nscenes = 0;
}

int rt_report_set_model(rt_report *R, int model, rt_err *e)
{
    const rt_exp_model *m = rt_exp_model_get(model);
    if (model != -1 && !m) return rt_errf(e, "model %d unknown", model);
    R->model = model;
    R->geom = RT_GEOM_COMPACT;
    R->stream = 0;
    R->sim_params[0] = 0;
    snprintf(R->policy, sizeof R->policy, "wb-wa");
    if (m) {
        rt_sim_config sc;
        rt_render_opts ro;
        rt_sim_config_default(&sc);
        rt_render_default_opts(&ro);
        rt_exp_model_apply(m, &ro, &sc);
        snprintf(R->policy, sizeof R->policy, "%s", rt_sim_policy_name(&sc));
        rt_exp_sim_params(model, &sc, R->sim_params, sizeof R->sim_params);
        R->geom = ro.geom;
        R->stream = ro.qstores == RT_QSTORES_STREAM;
    }
    R->nsizes = 0;
    sqlite3_stmt *st = rt_report_stmt(R->h,
                                      "SELECT DISTINCT c.size FROM traffic t JOIN cache_configs c ON c.id = t.config_id "
                                      "WHERE c.line = 64 AND c.assoc = 0 AND c.policy = ?1 ORDER BY c.size",
                                      R->dbpath, e, "s", R->policy);
    if (!st) return -1;
    int rc;
    while ((rc = sqlite3_step(st)) == SQLITE_ROW && R->nsizes < RT_REPORT_MAXSIZES)
        R->sizes[R->nsizes++] = (uint64_t)sqlite3_column_int64(st, 0);
    return rt_report_done(st, rc, R->dbpath, e);
}

int rt_report_size_union(uint64_t *sz, int ns, int max, const uint64_t *add, int nadd)
{
    for (int k = 0; k < nadd; k++) {
        int j = 0;
        while (j < ns && sz[j] < add[k]) j++;
        if ((j < ns && sz[j] == add[k]) || ns == max) continue;
        memmove(sz + j + 1, sz + j, sizeof *sz * (size_t)(ns - j));
        sz[j] = add[k];
        ns++;
    }
    return ns;
}

int rt_report_group_cmp(const rt_report_group *a, const rt_report_group *b)
{
    int c;
    if ((c = strcmp(a->scene, b->scene)) || (c = strcmp(a->hash, b->hash))) return c;
    if (a->W != b->W) return a->W < b->W ? -1 : 1;
    if (a->H != b->H) return a->H < b->H ? -1 : 1;
    if (a->lights != b->lights) return a->lights < b->lights ? -1 : 1;
    if ((c = strcmp(a->tracer, b->tracer)) || (c = strcmp(a->key, b->key))) return c;
    return strcmp(a->sim_params, b->sim_params);
}

void rt_report_run_label(char *b, size_t n, const rt_report_group *g)
{
    char ln[48];
    snprintf(b, n, "%s %dx%d lights %s: %s%s%s%s%s", g->scene, g->W, g->H,
             rt_exp_lights_name((unsigned)g->lights, ln, sizeof ln), g->tracer, g->key[0] ? " " : "", g->key,
             g->sim_params[0] ? " " : "", g->sim_params);
}

double rt_report_reduction(double base, double dyn)
{
    if (!(base > 0) || !(dyn > 0)) return NAN;
    return 100.0 * (base / dyn - 1.0);
}

double rt_report_paper_reduction(double printed)
{
    if (isnan(printed) || printed >= 0) return printed;
    /* printed = -100 (d / b - 1): d / b = 1 - printed / 100 */
    return 100.0 * (1.0 / (1.0 - printed / 100.0) - 1.0);
}

const char *rt_report_fmt_reduction(double red, int csv, char *buf, size_t n)
{
    if (isnan(red) || red <= -100) snprintf(buf, n, "%s", csv ? "" : "—");
    else if (csv) snprintf(buf, n, "%.10g", red);
    else if (red >= 0) snprintf(buf, n, "%.1f%%", red);
    else snprintf(buf, n, "%.2f× more", 1.0 / (1.0 + red / 100.0));
    return buf;
}

void rt_report_find(const rt_report_point *p, int n, rt_report_findings *f)
{
    memset(f, 0, sizeof *f);
    f->best_red = NAN;
    f->turn_red = NAN;
    for (int i = 0; i < n; i++) {
        double red = rt_report_reduction(p[i].geom[0], p[i].geom[1]);
        double tot = rt_report_reduction(p[i].geom[0] + p[i].ray[0], p[i].geom[1] + p[i].ray[1]);
        if (isnan(red) || isnan(tot)) continue;
        f->nsizes++;
        f->dyn_less += red > 0;
        f->ray_more += p[i].ray[1] > p[i].ray[0];
        if (isnan(f->best_red) || red > f->best_red) {
            f->best_red = red;
            f->best_size = p[i].size;
        }
        /* the crossover: negative from here on, never again positive */
        if (tot > 0) {
            f->turn_size = 0;
            f->turn_red = NAN;
        } else if (!f->turn_size && tot < 0) {
            f->turn_size = p[i].size;
            f->turn_red = tot;
        }
        f->last_size = p[i].size;
        f->last_total = tot;
    }
}

int rt_report_fig_tracers(unsigned fig, const rt_tracer **out, int max)
{
    int n = 0;
    for (int i = 0; rt_tracer_all[i] && n < max; i++)
        if (rt_tracer_all[i]->figures & fig) out[n++] = rt_tracer_all[i];
    return n;
}

const char *rt_report_layout_key(int geom, char *buf, size_t n)
{
    if (geom == RT_GEOM_COMPACT || !rt_render_geom_name(geom)) snprintf(buf, n, "%s", "");
    else snprintf(buf, n, "layout=%s ", rt_render_geom_name(geom));
    return buf;
}

int rt_report_value(const rt_report *R, const char *scene, const char *tracer, unsigned lights, uint64_t size,
                    double *geom, double *ray, rt_err *e)
{
    /* a scheduled tracer's value at a size is its run scheduled for that size */
    int64_t sched = rt_tracer_is(rt_tracer_find(tracer), RT_TR_SCHEDULED) ? (int64_t)size : 0;
    char lay[48];
    rt_report_layout_key(R->geom, lay, sizeof lay);
    /* v_paper's rows, of the one scene (name, hash) the label stands for */
    int i = rt_report_scene_index(R, scene);
    const char *name = i >= 0 ? R->scene_name[i] : scene, *hash = i >= 0 ? R->scene_hash[i] : "";
    /* the traffic rows of the matching runs, summed per run by group (not
     * through v_traffic_group, which SQLite would aggregate whole for
     * every cell: runs are found first, their rows by the run index) */
#define VALUE_SQL(COND)                                                                                              \
    "SELECT SUM(CASE WHEN k.grp = 'geometry' THEN t.traffic_bytes ELSE 0 END) / 1048576.0 AS geometry_mb,"         \
    " SUM(CASE WHEN k.grp = 'ray' THEN t.traffic_bytes ELSE 0 END) / 1048576.0 AS ray_mb"                           \
    " FROM runs r JOIN scenes s ON s.id = r.scene_id JOIN traffic t ON t.run_id = r.id"                              \
    " JOIN cache_configs c ON c.id = t.config_id JOIN classes k ON k.name = t.class"                                 \
    " WHERE c.line = 64 AND c.assoc = 0 AND r.sim_method = 'exact' AND r.params NOT LIKE '%subsample=%'"             \
    " AND instr(r.params, 'accel=') = 0 AND s.name = ?1 AND (?8 = '' OR s.hash = ?8) AND r.tracer = ?2"              \
    " AND r.lights = ?3 AND r.sched_size = ?4 AND c.size = ?5 AND r.W = ?6 AND r.H = ?7 AND @DIMS@ AND " COND       \
    " GROUP BY r.id, c.id ORDER BY geometry_mb LIMIT 1"
    sqlite3_stmt *st =
        R->model < 0
            /* no model: the toolkit's default runs (no model, compact
             * layout, default queue stores), never another setup's */
            ? rt_report_stmt(R->h,
                             VALUE_SQL("c.policy = 'wb-wa' AND r.sim_params NOT LIKE 'model=%'"
                                       " AND instr(r.params, 'layout=') = 0 AND instr(r.params, 'queue_stores=') = 0"),
                             R->dbpath, e, "ssIIIiis", name, tracer,
                             (int64_t)lights, sched, (int64_t)size, R->W, R->H, hash)
            /* one model: its accounting, its key, its layout and queue stores */
            : rt_report_stmt(
                  R->h,
                  VALUE_SQL("c.policy = ?9 AND r.sim_params = ?10"
                            " AND (CASE WHEN ?11 = '' THEN instr(r.params, 'layout=') = 0 ELSE instr(r.params || ' ', ?11)"
                            " > 0 END) AND (r.sched_size = 0 OR (instr(r.params, 'queue_stores=stream') > 0) = ?12)"),
                  R->dbpath, e, "ssIIIiissssi", name, tracer, (int64_t)lights, sched, (int64_t)size, R->W, R->H, hash,
                  R->policy, R->sim_params, lay, R->stream);
#undef VALUE_SQL
    if (!st) return -1;
    int rc = sqlite3_step(st), found = rc == SQLITE_ROW;
    if (found) {
        *geom = sqlite3_column_double(st, 0);
        *ray = sqlite3_column_double(st, 1);
    }
    if (rt_report_done(st, rc, R->dbpath, e) < 0) return -1;
    return found;
}

int rt_report_csv_split(FILE *in, const char *dir, const char *prefix, FILE *log, rt_err *e)
{
    if (rt_plot_mkdir(dir, e) < 0) return -1;
    char line[8192], title[256] = "";
    int ntab = 0, rc = 0;
    rt_out *o = NULL;
    FILE *to = NULL;
    char path[4096] = "";
    rewind(in);
    while (rc == 0 && fgets(line, sizeof line, in)) {
        if (line[0] == '#') { /* a table's title: the next line starts it */
            snprintf(title, sizeof title, "%s", line + 1 + (line[1] == ' '));
            title[strcspn(title, "\n")] = 0;
            if (to && rt_plot_commit(o, e) < 0) rc = -1;
            else if (to && log) fprintf(log, "wrote %s\n", path);
            to = NULL;
            continue;
        }
        if (!to) {
            /* DIR/PREFIX-N-TITLE.csv, the title as a file-name word */
            char slug[96];
            size_t k = 0;
            for (const char *p = title; *p && k + 1 < sizeof slug; p++)
                slug[k++] = (*p >= 'a' && *p <= 'z') || (*p >= '0' && *p <= '9') ? *p
                            : (*p >= 'A' && *p <= 'Z')                          ? (char)(*p - 'A' + 'a')
                                                                                : '-';
            slug[k] = 0;
            char name[200];
            snprintf(name, sizeof name, "%s-%d%s%s", prefix, ++ntab, slug[0] ? "-" : "", slug);
            rt_plot_path(path, sizeof path, dir, "", name, ".csv");
            if (!(to = rt_plot_open(path, &o, e))) return -1;
        }
        fputs(line, to);
    }
    if (rc == 0 && to) {
        if (rt_plot_commit(o, e) < 0) return -1;
        if (log) fprintf(log, "wrote %s\n", path);
    } else if (to) {
        rt_out_abort(o);
    }
    if (rc == 0 && ferror(in)) return rt_errf(e, "cannot read the report back");
    if (rc == 0 && !ntab) return rt_errf(e, "nothing to show: the report has no table");
    return rc;
}
