/*
 * cmd_sweep.c -- `raytraffic sweep`: the paper's experiment as one command.
 *
 * The matrix is scene x lighting x tracer (x scheduled cache size for the
 * dynamic tracer). Each job renders in-process with its accesses streamed
 * straight into the cache simulator (optionally also into a trace file) and
 * stores one run in the database in one transaction:
 *   - recursive, packet: one run simulated at every size in one pass;
 *   - dynamic: one run per cache size S, scheduled for S and simulated at S
 *     (or at every size with --dynamic-all-sizes, which shows what a
 *     mis-tuned schedule costs).
 * Jobs whose run key is already in the database are skipped, so an
 * interrupted sweep rerun with the same arguments finishes the rest and
 * loses nothing. --jobs N forks N workers that claim jobs in order from a
 * shared counter; each worker keeps the current scene and its k-d tree.
 * --list-jobs prints one self-contained command per job, each writing its
 * own database, for GNU parallel or a Slurm array; `raytraffic db merge`
 * joins the shards.
 */
#include "cmd.h"
#include "rows.h"
#include "run.h"
#include "approx.h"
#include "sim.h"
#include "trace.h"

#include <errno.h>
#include <inttypes.h>
#include <signal.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#define MAX_LIST 32

typedef struct lighting {
    const char *label; /* "primary", "0", "1", "2", "all" */
    unsigned mask;
} lighting;

typedef struct job {
    int scene;       /* index into opts.scenes */
    int lighting;    /* index into opts.lightings */
    const char *tracer;
    uint64_t sched;  /* dynamic: scheduled cache size; 0 otherwise */
    int proxy;       /* index into opts.proxies, -1 = the full experiment */
} job;

/* A reduced experiment run beside each job (--proxy): a lower resolution
 * (res:N, N pixels wide, same aspect) or pixel subsampling (sub:K[:T]). */
typedef struct proxy {
    int W, H;          /* res: image size; 0 = unchanged */
    uint32_t subsample; /* sub: 1 in K tiles */
    int subtile;
} proxy;

typedef struct sweep_opts {
    const char *preset;
    char *scenes[MAX_LIST];
    int nscenes;
    char *tracers[MAX_LIST];
    int ntracers;
    lighting lightings[MAX_LIST];
    int nlightings;
    rt_sim_config sim;
    rt_render_opts ro;
    const char *db;
    const char *keep;
    int jobs;
    int list;
    long only; /* --job K, -1 = all */
    int dyn_all;
    rt_approx_config approx[8]; /* --approx: estimators run beside the exact simulation */
    int napprox;
    proxy proxies[8];
    int nproxies;
} sweep_opts;

typedef struct shared {
    atomic_long next;     /* next job to claim */
    atomic_long done;     /* jobs finished (run or skipped) */
    atomic_long skipped;  /* of which skipped */
    atomic_int failed;    /* a worker failed */
} shared;

static void usage(FILE *f)
{
    fprintf(f,
            "Usage: raytraffic sweep [options]\n\n"
            "Runs scene x lighting x tracer x cache size into a results database.\n\n"
            "Options:\n"
            "  --preset P         quick (default; 256x256) or paper (1024x1024): room, grove,\n"
            "                     sphereflake; lighting primary,0,1,2,all; recursive, packet,\n"
            "                     dynamic; sizes 1K-4M\n"
            "  --scenes LIST      comma list of scene specs (overrides the preset)\n"
            "  --tracers LIST     comma list of tracers\n"
            "  --lights LIST      comma list of lightings: primary, 0, 1, 2, all\n"
            "  --sizes LIST       cache sizes: 1K-4M (powers of two) or 1K,64K,...\n"
            "  --line N           line size in bytes (default 64)\n"
            "  -W N, -H N         image size (overrides the preset)\n"
            "  --db FILE          results database (default raytraffic.db)\n"
            "  --jobs N           worker processes (default 1)\n"
            "  --keep-traces DIR  also write every job's trace to DIR\n"
            "  --dynamic-all-sizes  simulate each dynamic schedule at every size\n"
            "  --approx LIST      also run approximate simulators on the same access stream\n"
            "                     and store them beside the exact runs: comma list of\n"
            "                     shards:RATE[:EXACT_BELOW], shards-fixed:SMAX[:EXACT_BELOW],\n"
            "                     statstack:RATE[:EXACT_BELOW], hybrid[:RATE[:WINDOW_BELOW[:PERIOD]]]\n"
            "                     (rates as 0.01 or 1/64; see report --speed-error)\n"
            "  --proxy LIST       also run reduced experiments of every job (exact simulation,\n"
            "                     compared with the full run by report --speed-error): comma\n"
            "                     list of res:N (N pixels wide, same aspect) and sub:K[:T]\n"
            "                     (trace 1 in K tiles of TxT pixels, T default 8)\n"
            "  --qorder O, --threads N  dynamic scheduler options (see render --help)\n"
            "  --list-jobs        print one self-contained command per job and exit\n"
            "  --job K            run only job K (0-based) of the matrix\n"
            "  -h, --help         this help\n\n"
            "Rerunning with the same arguments skips finished runs. A progress bar with ETA\n"
            "is drawn on stderr when it is a terminal, else one line per finished run.\n");
}

static int split_list(char *s, char **out, int max)
{
    int n = 0;
    char *save = NULL;
    for (char *t = strtok_r(s, ",", &save); t; t = strtok_r(NULL, ",", &save)) {
        if (n == max) return -1;
        out[n++] = t;
    }
    return n;
}

static int parse_lightings(char *s, sweep_opts *o)
{
    char *items[MAX_LIST];
    int n = split_list(s, items, MAX_LIST);
    if (n <= 0) return -1;
    for (int i = 0; i < n; i++) {
        lighting *l = &o->lightings[i];
        if (!strcmp(items[i], "primary") || !strcmp(items[i], "none")) {
            l->label = "primary";
            l->mask = 0;
        } else if (!strcmp(items[i], "all")) {
            l->label = "all";
            l->mask = 7;
        } else if (!strcmp(items[i], "0") || !strcmp(items[i], "1") || !strcmp(items[i], "2")) {
            l->label = items[i];
            l->mask = 1u << (items[i][0] - '0');
        } else {
            return -1;
        }
    }
    o->nlightings = n;
    return 0;
}

static int build_matrix(const sweep_opts *o, job **out)
{
    size_t cap = (size_t)o->nscenes * o->nlightings * o->ntracers * (o->sim.nsizes + 1) * (o->nproxies + 1), n = 0;
    job *J = calloc(cap ? cap : 1, sizeof *J);
    if (!J) return -1;
    for (int s = 0; s < o->nscenes; s++)
        for (int l = 0; l < o->nlightings; l++)
            for (int t = 0; t < o->ntracers; t++) {
                if (!strcmp(o->tracers[t], "dynamic")) {
                    for (int k = 0; k < o->sim.nsizes; k++) J[n++] = (job){s, l, o->tracers[t], o->sim.sizes[k], -1};
                } else {
                    J[n++] = (job){s, l, o->tracers[t], 0, -1};
                }
            }
    /* reduced experiments after all full ones, so a partial sweep has the
     * references first */
    size_t nbase = n;
    for (int p = 0; p < o->nproxies; p++)
        for (size_t i = 0; i < nbase; i++) {
            J[n] = J[i];
            J[n++].proxy = p;
        }
    *out = J;
    return (int)n;
}

/* A sink that feeds several sinks (exact simulator, approximate
 * simulators, trace file) and times each, so the speed of each simulator on
 * the same stream is measured without the tracer's time. */
#define MAXFAN 10
typedef struct fan {
    rt_sink self;
    int n;
    rt_sink *to[MAXFAN];
    double sec[MAXFAN];
} fan;

static int fan_put(rt_sink *s, const rt_access *acc, size_t n)
{
    fan *f = s->ctx;
    int rc = 0;
    for (int i = 0; i < f->n; i++) {
        double t0 = rt_now();
        if (f->to[i]->put(f->to[i], acc, n) < 0) rc = -1;
        f->sec[i] += rt_now() - t0;
    }
    return rc;
}

static int parse_approx(char *s, sweep_opts *o, rt_err *e)
{
    char *items[MAX_LIST];
    int n = split_list(s, items, MAX_LIST);
    if (n <= 0 || n > 8) return rt_errf(e, "--approx: expected 1 to 8 comma-separated methods");
    for (int i = 0; i < n; i++) {
        rt_approx_config *ac = &o->approx[i];
        rt_approx_config_default(ac);
        char *save = NULL, *m = strtok_r(items[i], ":", &save), *p = strtok_r(NULL, ":", &save),
             *x = strtok_r(NULL, ":", &save), *y = strtok_r(NULL, ":", &save);
        int method = m ? rt_approx_method_from_name(m) : -1;
        if (method <= 0 || (!p && method != RT_APPROX_HYBRID))
            return rt_errf(e, "--approx: '%s' is not shards:RATE, shards-fixed:SMAX, statstack:RATE or hybrid[:RATE]",
                           m ? m : "");
        ac->method = method;
        ac->rate = rt_approx_default_rate(method);
        if (method == RT_APPROX_SHARDS_FIXED) {
            uint64_t v;
            if (rt_parse_size(p, &v) < 0) return rt_errf(e, "--approx: bad sample size '%s'", p);
            ac->smax = v;
        } else if (p && rt_cmd_parse_rate(p, &ac->rate) < 0) {
            return rt_errf(e, "--approx: bad rate '%s' (a number in (0, 1] or 1/N)", p);
        }
        /* third field: exact-below, or for hybrid the window-below size */
        uint64_t *third = method == RT_APPROX_HYBRID ? &ac->window_below : &ac->exact_below;
        if (x && rt_parse_size(x, third) < 0) return rt_errf(e, "--approx: bad size '%s'", x);
        /* fourth field, hybrid only: the window period */
        if (y && (method != RT_APPROX_HYBRID || rt_parse_size(y, &ac->period) < 0))
            return rt_errf(e, "--approx: bad fourth field '%s' (hybrid:RATE:WINDOW_BELOW:PERIOD)", y);
        rt_sim_config dc;
        rt_sim_config_default(&dc);
        if (rt_approx_config_check(&dc, ac, e) < 0) return -1;
    }
    o->napprox = n;
    return 0;
}

static int parse_proxies(char *s, sweep_opts *o, rt_err *e)
{
    char *items[8];
    int n = split_list(s, items, 8);
    if (n <= 0) return rt_errf(e, "--proxy: expected 1 to 8 comma-separated items res:N or sub:K[:T]");
    for (int i = 0; i < n; i++) {
        proxy *p = &o->proxies[i];
        char *end;
        memset(p, 0, sizeof *p);
        p->subsample = 1;
        p->subtile = 8;
        if (!strncmp(items[i], "res:", 4)) {
            long v = strtol(items[i] + 4, &end, 10);
            if (*end || v < 8 || v > 65536) return rt_errf(e, "--proxy: '%s': res:N needs N in 8..65536", items[i]);
            p->W = (int)v;
        } else if (!strncmp(items[i], "sub:", 4)) {
            long k = strtol(items[i] + 4, &end, 10), t = 8;
            if (*end == ':') t = strtol(end + 1, &end, 10);
            if (*end || k < 2 || k > 1L << 20 || t < 1 || t > 4096)
                return rt_errf(e, "--proxy: '%s': sub:K[:T] needs K in 2..1048576 and T in 1..4096", items[i]);
            p->subsample = (uint32_t)k;
            p->subtile = (int)t;
        } else {
            return rt_errf(e, "--proxy: '%s' is not res:N or sub:K[:T]", items[i]);
        }
    }
    o->nproxies = n;
    return 0;
}

/* The render options of job jb (its proxy applied). */
static rt_render_opts job_opts(const sweep_opts *o, const job *jb)
{
    rt_render_opts ro = o->ro;
    ro.lights = o->lightings[jb->lighting].mask;
    ro.cache_size = jb->sched ? jb->sched : ro.cache_size;
    if (jb->proxy >= 0) {
        const proxy *p = &o->proxies[jb->proxy];
        if (p->W) {
            ro.H = (int)(((int64_t)o->ro.H * p->W + o->ro.W / 2) / o->ro.W);
            ro.W = p->W;
            if (ro.H < 1) ro.H = 1;
        }
        if (p->subsample > 1) {
            ro.subsample = p->subsample;
            ro.subtile = p->subtile;
        }
    }
    return ro;
}

typedef struct worker {
    const sweep_opts *o;
    rt_db *db;
    int cur_scene;
    rt_scene *sc;
    rt_kdtree *kd;
    uint64_t scene_hash;
} worker;

static void key_for(const worker *w, const job *jb, char *params, size_t np, rt_db_run *k)
{
    const sweep_opts *o = w->o;
    rt_render_opts ro = job_opts(o, jb);
    memset(k, 0, sizeof *k);
    k->scene = w->sc->name;
    k->scene_params = w->sc->params;
    k->scene_hash = w->scene_hash;
    k->tracer = jb->tracer;
    k->W = ro.W;
    k->H = ro.H;
    k->lights = o->lightings[jb->lighting].mask;
    k->cache_size = jb->sched;
    k->gmax = 0;
    if (!strcmp(jb->tracer, "dynamic"))
        snprintf(params, np, "qorder=%s threads=%d%s", o->ro.qorder == RT_QORDER_TREE ? "tree" : "fullest",
                 o->ro.threads, o->dyn_all ? " sim=all-sizes" : "");
    else if (!strcmp(jb->tracer, "packet"))
        snprintf(params, np, "packet=%d", o->ro.packet);
    else
        params[0] = 0;
    rt_subsample_params(&ro, params + strlen(params), np - strlen(params));
    k->params = params;
    k->sim_method = "exact";
    k->sim_params = "";
    k->ntri = w->sc->ntri;
}

static int load_scene(worker *w, int s, rt_err *e)
{
    if (w->cur_scene == s) return 0;
    rt_kd_free(w->kd);
    rt_scene_free(w->sc);
    w->kd = NULL;
    w->cur_scene = -1;
    w->sc = rt_scene_load(w->o->scenes[s], e);
    if (!w->sc) return -1;
    w->scene_hash = rt_scene_hash(w->sc);
    w->cur_scene = s;
    return 0;
}

/* Runs one job. Returns 1 if run, 0 if skipped (already stored), -1. */
static int run_job(worker *w, const job *jb, long index, rt_err *e)
{
    const sweep_opts *o = w->o;
    if (load_scene(w, jb->scene, e) < 0) return -1;
    char params[128];
    rt_db_run run;
    key_for(w, jb, params, sizeof params, &run);
    int has = rt_db_has_run(w->db, &run, e);
    if (has < 0) return -1;
    char aparams[8][128];
    /* approximate methods are compared over several sizes: only for jobs
     * simulated at every size (recursive, packet, --dynamic-all-sizes) */
    int napprox = (jb->sched && !o->dyn_all) || jb->proxy >= 0 ? 0 : o->napprox;
    for (int a = 0; a < napprox && has; a++) {
        rt_db_run k = run;
        k.sim_method = rt_approx_method_name(o->approx[a].method);
        k.sim_params = rt_approx_params(&o->approx[a], aparams[a], sizeof aparams[a]);
        has = rt_db_has_run(w->db, &k, e);
        if (has < 0) return -1;
    }
    if (has) return 0;
    if (!w->kd) {
        rt_kd_params kp;
        rt_kd_default_params(&kp);
        if (!(w->kd = rt_kd_build(w->sc, &kp, e))) return -1;
    }
    double t0 = rt_now();
    rt_render_opts ro = job_opts(o, jb);
    rt_sim_config sc = o->sim;
    if (jb->sched && !o->dyn_all) {
        sc.nsizes = 1;
        sc.sizes[0] = jb->sched;
    }
    rt_job j;
    if (rt_job_setup_borrowed(&j, w->sc, w->kd, jb->tracer, &ro, e) < 0) return -1;
    rt_sim *sim = rt_sim_new(&sc, e);
    rt_image *img = sim ? rt_image_new(ro.W, ro.H, e) : NULL;
    rt_tr_writer *tw = NULL;
    rt_db_traffic *rows = NULL;
    rt_approx *ap[8] = {NULL};
    int rc = -1;
    char tpath[4096] = "";
    if (!img) goto done;
    fan fn;
    memset(&fn, 0, sizeof fn);
    fn.self.put = fan_put;
    fn.self.ctx = &fn;
    fn.to[fn.n++] = rt_sim_sink(sim);
    for (int a = 0; a < napprox; a++) {
        if (!(ap[a] = rt_approx_new(&sc, &o->approx[a], e))) goto done;
        fn.to[fn.n++] = rt_approx_sink(ap[a]);
    }
    rt_sink *sink = &fn.self;
    if (o->keep) {
        snprintf(tpath, sizeof tpath, "%s/job%04ld-%s-%s-%s%s%" PRIu64 "%s.rtt", o->keep, index, o->scenes[jb->scene],
                 o->lightings[jb->lighting].label, jb->tracer, jb->sched ? "-" : "", jb->sched,
                 jb->proxy >= 0 ? "-proxy" : "");
        for (char *p = tpath + strlen(o->keep) + 1; *p; p++)
            if (*p == '/' || *p == ':' || *p == ',' || *p == '=') *p = '_';
        rt_tr_meta m;
        rt_job_meta(&j, rt_cmd_line(), &m);
        if (!(tw = rt_tr_create(tpath, &m, e))) goto done;
        fn.to[fn.n++] = rt_tr_sink(tw);
    }
    rt_run_stats st;
    if (rt_job_run(&j, sink, img, &st, e) < 0) goto done;
    if (tw) {
        int r = rt_tr_finish(tw, e);
        tw = NULL;
        if (r < 0) goto done;
    }
    size_t nrows = (size_t)sc.nsizes * RT_NCLASS, k;
    if (!(rows = rt_calloc(nrows, sizeof *rows, e))) goto done;
    k = rt_sim_db_rows(sim, rows);
    char stats[768];
    snprintf(stats, sizeof stats,
             "rays_primary=%" PRIu64 " rays_shadow=%" PRIu64 " nodes=%" PRIu64 " tests=%" PRIu64 " pv_primary=%" PRIu64
             " pv_all=%" PRIu64 " render_seconds=%.3f sim_seconds=%.3f%s%s",
             st.rays_primary, st.rays_shadow, st.nodes, st.tests, st.pv_primary, st.pv_all, st.seconds, fn.sec[0],
             st.extra[0] ? " " : "", st.extra);
    run.refs = rt_sim_refs(sim);
    run.command = rt_cmd_line();
    run.wall_time = rt_now() - t0;
    run.stats = stats;
    if (rt_db_store_run(w->db, &run, rows, k, NULL, e) < 0) goto done;
    for (int a = 0; a < napprox; a++) {
        double t0a = rt_now();
        if (rt_approx_finish(ap[a], e) < 0) goto done;
        double fin = rt_now() - t0a;
        size_t na = rt_approx_db_rows(ap[a], rows);
        rt_db_run ra = run;
        char astats[sizeof stats + 64];
        ra.sim_method = rt_approx_method_name(o->approx[a].method);
        ra.sim_params = rt_approx_params(&o->approx[a], aparams[a], sizeof aparams[a]);
        ra.wall_time = fn.sec[1 + a] + fin;
        snprintf(astats, sizeof astats, "sim_seconds=%.3f exact_sim_seconds=%.3f", fn.sec[1 + a] + fin, fn.sec[0]);
        ra.stats = astats;
        if (rt_db_store_run(w->db, &ra, rows, na, NULL, e) < 0) goto done;
    }
    rc = 1;
done:
    for (int a = 0; a < napprox; a++) rt_approx_free(ap[a]);
    if (tw) rt_tr_abort(tw);
    free(rows);
    rt_image_free(img);
    rt_sim_free(sim);
    rt_job_free(&j);
    return rc;
}

static void job_label(const sweep_opts *o, const job *jb, char *buf, size_t n)
{
    char px[64] = "";
    if (jb->proxy >= 0) {
        const proxy *p = &o->proxies[jb->proxy];
        if (p->W) snprintf(px, sizeof px, " [res:%d]", p->W);
        else snprintf(px, sizeof px, " [sub:%u:%d]", (unsigned)p->subsample, p->subtile);
    }
    if (jb->sched)
        snprintf(buf, n, "%s %s %s @%" PRIu64 "K%s", o->scenes[jb->scene], o->lightings[jb->lighting].label, jb->tracer,
                 jb->sched / 1024, px);
    else
        snprintf(buf, n, "%s %s %s%s", o->scenes[jb->scene], o->lightings[jb->lighting].label, jb->tracer, px);
}

static int worker_loop(const sweep_opts *o, const job *J, long nj, shared *sh, int tty)
{
    rt_err e = {""};
    worker w = {o, NULL, -1, NULL, NULL, 0};
    if (!(w.db = rt_db_open(o->db, &e))) {
        rt_cmd_error("sweep", "%s", e.msg);
        atomic_store(&sh->failed, 1);
        return -1;
    }
    int rc = 0;
    for (;;) {
        if (atomic_load(&sh->failed)) break;
        long i = o->only >= 0 ? (atomic_fetch_add(&sh->next, 1) == 0 ? o->only : nj) : atomic_fetch_add(&sh->next, 1);
        if (i >= nj) break;
        double t0 = rt_now();
        int r = run_job(&w, &J[i], i, &e);
        char label[256];
        job_label(o, &J[i], label, sizeof label);
        if (r < 0) {
            rt_cmd_error("sweep", "job %ld (%s): %s", i, label, e.msg);
            atomic_store(&sh->failed, 1);
            rc = -1;
            break;
        }
        if (r == 0) atomic_fetch_add(&sh->skipped, 1);
        long d = atomic_fetch_add(&sh->done, 1) + 1;
        if (!tty) {
            fprintf(stderr, "[%ld/%ld] %s: %s (%.1f s)\n", d, o->only >= 0 ? 1 : nj, label, r ? "done" : "already in database",
                    rt_now() - t0);
        }
        if (o->only >= 0) break;
    }
    rt_kd_free(w.kd);
    rt_scene_free(w.sc);
    rt_db_close(w.db);
    return rc;
}

static void progress(shared *sh, long nj, double t0)
{
    long d = atomic_load(&sh->done), s = atomic_load(&sh->skipped);
    double el = rt_now() - t0;
    double rate = d > s ? el / (double)(d - s) : 0;
    double eta = rate * (double)(nj - d);
    int width = 30, fill = nj ? (int)(width * d / nj) : width;
    fprintf(stderr, "\r[%.*s%*s] %ld/%ld runs, %.0f s elapsed, ETA %.0f s ", fill,
            "##############################", width - fill, "", d, nj, el, d > s ? eta : 0.0);
}

static void print_jobs(const sweep_opts *o, long nj, int argc, char **argv)
{
    char base[4096];
    snprintf(base, sizeof base, "%s", o->db);
    size_t bl = strlen(base);
    if (bl > 3 && !strcmp(base + bl - 3, ".db")) base[bl - 3] = 0;
    for (long i = 0; i < nj; i++) {
        printf("raytraffic sweep");
        for (int a = 1; a < argc; a++) {
            if (!strcmp(argv[a], "--list-jobs")) continue;
            if (!strcmp(argv[a], "--db") || !strcmp(argv[a], "--jobs") || !strcmp(argv[a], "--job")) {
                a++;
                continue;
            }
            if (!strncmp(argv[a], "--db=", 5) || !strncmp(argv[a], "--jobs=", 7) || !strncmp(argv[a], "--job=", 6))
                continue;
            printf(" '%s'", argv[a]);
        }
        printf(" --job %ld --db '%s.job%04ld.db'\n", i, base, i);
    }
}

static int sweep_impl(int argc, char **argv, char **own_lists)
{
    static const struct option own[] = {
        {"preset", required_argument, NULL, 'p'},
        {"scenes", required_argument, NULL, 's'},
        {"tracers", required_argument, NULL, 'T'},
        {"lights", required_argument, NULL, 'l'},
        {"sizes", required_argument, NULL, 'z'},
        {"line", required_argument, NULL, 'L'},
        {"db", required_argument, NULL, 'd'},
        {"jobs", required_argument, NULL, 'j'},
        {"keep-traces", required_argument, NULL, 'k'},
        {"dynamic-all-sizes", no_argument, NULL, 'a'},
        {"list-jobs", no_argument, NULL, 'P'},
        {"job", required_argument, NULL, 'J'},
        {"approx", required_argument, NULL, 'A'},
        {"proxy", required_argument, NULL, 'X'},
        {"help", no_argument, NULL, 'h'},
        {NULL, 0, NULL, 0},
    };
    sweep_opts o;
    memset(&o, 0, sizeof o);
    o.preset = "quick";
    o.db = "raytraffic.db";
    o.jobs = 1;
    o.only = -1;
    rt_render_default_opts(&o.ro);
    rt_sim_config_default(&o.sim);
    char *sizes_arg = NULL;
#define scenes_arg own_lists[0]
#define tracers_arg own_lists[1]
#define lights_arg own_lists[2]
    int W = 0, H = 0, c;
    long line = 64;
    rt_err e = {""};
    /* -W/-H and the dynamic options come from the shared table; --lights is
     * this command's own (a list of lightings), so the shared one is not used. */
    static const struct option shared_opts[] = {
        {"qorder", required_argument, NULL, RT_OPT_QORDER},
        {"threads", required_argument, NULL, RT_OPT_THREADS},
        {"packet", required_argument, NULL, RT_OPT_PACKET},
        {"width", required_argument, NULL, 'W'},
        {"height", required_argument, NULL, 'H'},
        {NULL, 0, NULL, 0},
    };
    struct option lo[sizeof own / sizeof own[0] + sizeof shared_opts / sizeof shared_opts[0]];
    memcpy(lo, own, sizeof own - sizeof own[0]);
    memcpy(lo + sizeof own / sizeof own[0] - 1, shared_opts, sizeof shared_opts);
    optind = 1;
    while ((c = getopt_long(argc, argv, "hW:H:", lo, NULL)) != -1) {
        const char *dummy = NULL;
        if (c == 'W' || c == 'H') {
            rt_render_opts tmp = o.ro;
            if (rt_cmd_render_opt("sweep", c, optarg, &tmp, &dummy) < 0) return RT_EXIT_USAGE;
            if (c == 'W') W = tmp.W; else H = tmp.H;
            continue;
        }
        int r = rt_cmd_render_opt("sweep", c, optarg, &o.ro, &dummy);
        if (r < 0) return RT_EXIT_USAGE;
        if (r > 0) continue;
        switch (c) {
        case 'p':
            if (strcmp(optarg, "quick") && strcmp(optarg, "paper")) {
                rt_cmd_error("sweep", "--preset: '%s' is not quick or paper", optarg);
                return RT_EXIT_USAGE;
            }
            o.preset = optarg;
            break;
        /* copies: the lists are split in place and argv is reprinted by
         * --list-jobs */
        case 's': free(scenes_arg); scenes_arg = strdup(optarg); break;
        case 'T': free(tracers_arg); tracers_arg = strdup(optarg); break;
        case 'l': free(lights_arg); lights_arg = strdup(optarg); break;
        case 'z': sizes_arg = optarg; break;
        case 'L': {
            char *end;
            line = strtol(optarg, &end, 10);
            if (*end || line < 1 || line > 65536) {
                rt_cmd_error("sweep", "--line: '%s' is not a line size in 1..65536", optarg);
                return RT_EXIT_USAGE;
            }
            break;
        }
        case 'd': o.db = optarg; break;
        case 'j': {
            char *end;
            long v = strtol(optarg, &end, 10);
            if (*end || v < 1 || v > 256) {
                rt_cmd_error("sweep", "--jobs: '%s' is not in 1..256", optarg);
                return RT_EXIT_USAGE;
            }
            o.jobs = (int)v;
            break;
        }
        case 'k': o.keep = optarg; break;
        case 'a': o.dyn_all = 1; break;
        case 'A':
            free(own_lists[3]);
            own_lists[3] = strdup(optarg);
            if (parse_approx(own_lists[3], &o, &e) < 0) {
                rt_cmd_error("sweep", "%s", e.msg);
                return RT_EXIT_USAGE;
            }
            break;
        case 'X':
            free(own_lists[4]);
            own_lists[4] = strdup(optarg);
            if (parse_proxies(own_lists[4], &o, &e) < 0) {
                rt_cmd_error("sweep", "%s", e.msg);
                return RT_EXIT_USAGE;
            }
            break;
        case 'P': o.list = 1; break;
        case 'J': {
            char *end;
            o.only = strtol(optarg, &end, 10);
            if (*end || o.only < 0) {
                rt_cmd_error("sweep", "--job: '%s' is not a job index", optarg);
                return RT_EXIT_USAGE;
            }
            break;
        }
        case 'h': usage(stdout); return RT_EXIT_OK;
        default: return RT_EXIT_USAGE;
        }
    }
    if (optind != argc) {
        rt_cmd_error("sweep", "unexpected argument '%s'", argv[optind]);
        return RT_EXIT_USAGE;
    }
    int paper = !strcmp(o.preset, "paper");
    o.ro.W = W ? W : (paper ? 1024 : 256);
    o.ro.H = H ? H : (paper ? 1024 : 256);
    char defscenes[] = "room,grove,sphereflake", deftracers[] = "recursive,packet,dynamic",
         deflights[] = "primary,0,1,2,all";
    if ((o.nscenes = split_list(scenes_arg ? scenes_arg : defscenes, o.scenes, MAX_LIST)) <= 0) {
        rt_cmd_error("sweep", "--scenes: empty or too long list");
        return RT_EXIT_USAGE;
    }
    if ((o.ntracers = split_list(tracers_arg ? tracers_arg : deftracers, o.tracers, MAX_LIST)) <= 0) {
        rt_cmd_error("sweep", "--tracers: empty or too long list");
        return RT_EXIT_USAGE;
    }
    for (int t = 0; t < o.ntracers; t++)
        if (!rt_tracer_find(o.tracers[t])) {
            rt_cmd_error("sweep", "--tracers: unknown tracer '%s'", o.tracers[t]);
            return RT_EXIT_USAGE;
        }
    for (int p = 0; p < o.nproxies; p++)
        for (int t = 0; t < o.ntracers; t++) {
            rt_render_opts ro = o.ro;
            ro.subsample = o.proxies[p].subsample;
            ro.subtile = o.proxies[p].subtile;
            if (rt_check_subsample(&ro, o.tracers[t], &e) < 0) {
                rt_cmd_error("sweep", "--proxy: %s", e.msg);
                return RT_EXIT_USAGE;
            }
        }
    if (parse_lightings(lights_arg ? lights_arg : deflights, &o) < 0) {
        rt_cmd_error("sweep", "--lights: expected a comma list of primary, 0, 1, 2, all");
        return RT_EXIT_USAGE;
    }
    o.sim.line = (uint32_t)line;
    if (sizes_arg && rt_sim_parse_sizes(sizes_arg, &o.sim, &e) < 0) {
        rt_cmd_error("sweep", "--sizes: %s", e.msg);
        return RT_EXIT_USAGE;
    }
    if (rt_sim_config_check(&o.sim, &e) < 0) {
        rt_cmd_error("sweep", "%s", e.msg);
        return RT_EXIT_USAGE;
    }
    job *J = NULL;
    int nj = build_matrix(&o, &J);
    if (nj < 0) {
        rt_cmd_error("sweep", "out of memory");
        return RT_EXIT_FAIL;
    }
    if (o.only >= nj) {
        rt_cmd_error("sweep", "--job %ld: the matrix has %d jobs (0..%d)", o.only, nj, nj - 1);
        free(J);
        return RT_EXIT_USAGE;
    }
    if (o.list) {
        print_jobs(&o, nj, argc, argv);
        free(J);
        return RT_EXIT_OK;
    }
    if (o.keep && mkdir(o.keep, 0777) < 0 && errno != EEXIST) {
        rt_cmd_error("sweep", "%s: %s", o.keep, strerror(errno));
        free(J);
        return RT_EXIT_FAIL;
    }
    /* Create the schema once before workers start. */
    rt_db *db = rt_db_open(o.db, &e);
    if (!db) {
        rt_cmd_error("sweep", "%s", e.msg);
        free(J);
        return RT_EXIT_FAIL;
    }
    rt_db_close(db);
    shared *sh = mmap(NULL, sizeof *sh, PROT_READ | PROT_WRITE, MAP_SHARED | MAP_ANONYMOUS, -1, 0);
    if (sh == MAP_FAILED) {
        rt_cmd_error("sweep", "mmap: %s", strerror(errno));
        free(J);
        return RT_EXIT_FAIL;
    }
    atomic_init(&sh->next, 0);
    atomic_init(&sh->done, 0);
    atomic_init(&sh->skipped, 0);
    atomic_init(&sh->failed, 0);
    int tty = isatty(2);
    long total = o.only >= 0 ? 1 : nj;
    double t0 = rt_now();
    fprintf(stderr, "sweep: %ld run(s) (%d scenes x %d lightings x %d tracers, %d sizes) at %dx%d into %s, %d worker(s)\n",
            total, o.nscenes, o.nlightings, o.ntracers, o.sim.nsizes, o.ro.W, o.ro.H, o.db, o.jobs);
    int rc = 0;
    int nw = o.jobs < total ? o.jobs : (int)total;
    if (nw <= 1) {
        if (tty) {
            /* single process: draw the bar between jobs from a child-free loop */
            pid_t pid = fork();
            if (pid == 0) _exit(worker_loop(&o, J, nj, sh, 1) < 0 ? 1 : 0);
            nw = 1;
            int status;
            while (waitpid(pid, &status, WNOHANG) == 0) {
                progress(sh, total, t0);
                usleep(250000);
            }
            progress(sh, total, t0);
            fputc('\n', stderr);
            rc = WIFEXITED(status) && WEXITSTATUS(status) == 0 ? 0 : -1;
        } else {
            rc = worker_loop(&o, J, nj, sh, 0);
        }
    } else {
        pid_t pids[256];
        for (int k = 0; k < nw; k++) {
            pids[k] = fork();
            if (pids[k] == 0) _exit(worker_loop(&o, J, nj, sh, tty) < 0 ? 1 : 0);
            if (pids[k] < 0) {
                rt_cmd_error("sweep", "fork: %s", strerror(errno));
                atomic_store(&sh->failed, 1);
                nw = k;
                rc = -1;
                break;
            }
        }
        int alive = nw;
        while (alive > 0) {
            int status;
            pid_t p = tty ? waitpid(-1, &status, WNOHANG) : waitpid(-1, &status, 0);
            if (p > 0) {
                alive--;
                if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) rc = -1;
            } else if (p == 0) {
                progress(sh, total, t0);
                usleep(250000);
            } else if (errno != EINTR) {
                break;
            }
        }
        if (tty) {
            progress(sh, total, t0);
            fputc('\n', stderr);
        }
    }
    long skipped = atomic_load(&sh->skipped), done = atomic_load(&sh->done);
    fprintf(stderr, "sweep: %ld run(s) finished (%ld already in the database) in %.1f s; results in %s\n", done, skipped,
            rt_now() - t0, o.db);
    munmap(sh, sizeof *sh);
    free(J);
    return rc < 0 || done < total ? RT_EXIT_FAIL : RT_EXIT_OK;
}

#undef scenes_arg
#undef tracers_arg
#undef lights_arg

int main_sweep(int argc, char **argv)
{
    char *lists[5] = {NULL, NULL, NULL, NULL, NULL};
    int rc = sweep_impl(argc, argv, lists);
    for (int i = 0; i < 5; i++) free(lists[i]);
    return rc;
}
