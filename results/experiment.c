/*
 * experiment.c -- jobs rendered in-process into simulators and stored as
 * runs (see experiment.h).
 *
 * One job is: load (or keep) the scene and its tree, build the run key,
 * skip if stored, render with the access stream fanned out to the exact
 * simulator, the approximate ones and a trace writer, then turn counters
 * into rows (rows.c) and store them. The fan-out keeps one timer per
 * target, so the stored sim_seconds of each simulator is its own time on
 * the same stream.
 */
#include "scene_load.h"
#include "experiment.h"
#include "mcore.h"
#include "mcore_rows.h"
#include "rows.h"
#include "run.h"
#include "sindex.h"

#include <inttypes.h>
#include <pthread.h>
#include <signal.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ---- fan-out sink ------------------------------------------------------ */

static int fan_put(rt_sink *s, const rt_access *acc, size_t n)
{
    rt_exp_fan *f = s->ctx;
    int rc = 0;
    for (int i = 0; i < f->n; i++) {
        double t0 = rt_now();
        if (f->to[i]->put(f->to[i], acc, n) < 0) rc = -1;
        f->sec[i] += rt_now() - t0;
    }
    return rc;
}

void rt_exp_fan_init(rt_exp_fan *f)
{
    memset(f, 0, sizeof *f);
    f->self.put = fan_put;
    f->self.ctx = f;
}

int rt_exp_fan_add(rt_exp_fan *f, rt_sink *to, rt_err *e)
{
    if (f->n == RT_EXP_MAXFAN) return rt_errf(e, "fan-out: more than %d sinks", RT_EXP_MAXFAN);
    f->to[f->n] = to;
    return f->n++;
}

rt_sink *rt_exp_fan_sink(rt_exp_fan *f) { return &f->self; }

/* ---- matrix ------------------------------------------------------------ */

/* 1 if the sweep has a shadow-or-default mode and a lighting without
 * lights: it already holds the raycast runs. */
static int has_primary_lighting(const rt_exp_config *c, int nm, const int *modes)
{
    int def = 0;
    for (int m = 0; m < nm; m++) def |= modes[m] == RT_MODE_DEFAULT || modes[m] == RT_MODE_SHADOW;
    for (int l = 0; l < c->nlightings && def; l++)
        if (!c->lightings[l].mask) return 1;
    return 0;
}

long rt_exp_matrix(const rt_exp_config *c, rt_exp_job **out, rt_err *e)
{
    static const int def_mode[1] = {RT_MODE_DEFAULT};
    const int nm = c->nmodes > 0 ? c->nmodes : 1, *modes = c->nmodes > 0 ? c->modes : def_mode;
    static const int def_accel[1] = {RT_ACCEL_DEFAULT};
    const int na = c->naccels > 0 ? c->naccels : 1, *accels = c->naccels > 0 ? c->accels : def_accel;
    size_t cap = (size_t)c->nscenes * nm * (c->nlightings + 1) * c->ntracers * na * (c->sim.nsizes + 1) *
                 (c->nproxies + 1), n = 0;
    rt_exp_job *J = rt_calloc(cap ? cap : 1, sizeof *J, e);
    if (!J) return -1;
    const int raycast_done = has_primary_lighting(c, nm, modes);
    for (int s = 0; s < c->nscenes; s++)
        for (int m = 0; m < nm; m++) {
            int mode = modes[m] == RT_MODE_SHADOW ? RT_MODE_DEFAULT : modes[m];
            if (mode == RT_MODE_RAYCAST && raycast_done) continue;
            for (int l = mode == RT_MODE_RAYCAST ? -1 : 0; l < (mode == RT_MODE_RAYCAST ? 0 : c->nlightings); l++) {
                if ((mode == RT_MODE_WHITTED || mode == RT_MODE_PATH) && !c->lightings[l].mask) continue;
                for (int t = 0; t < c->ntracers; t++) {
                    const rt_tracer *tr = rt_tracer_find(c->tracers[t]);
                    if (mode != RT_MODE_DEFAULT && tr && !(tr->modes & (1u << mode))) continue;
                    /* the swept structures the tracer runs on (its traits) */
                    for (int a = 0; a < na; a++) {
                        const int acc = accels[a];
                        if (acc != RT_ACCEL_DEFAULT && tr && !(tr->accels & RT_ACCEL_BIT(acc))) continue;
                        if (rt_tracer_is(tr, RT_TR_SCHEDULED)) {
                            for (int k = 0; k < c->sim.nsizes; k++)
                                J[n++] = (rt_exp_job){s, l, c->tracers[t], c->sim.sizes[k], -1, mode, acc, 0};
                        } else {
                            J[n++] = (rt_exp_job){s, l, c->tracers[t], 0, -1, mode, acc, 0};
                        }
                    }
                }
            }
        }
    if (c->ncores > 0) { /* the core counts, innermost */
        rt_exp_job *K = rt_calloc(n * (size_t)c->ncores + 1, sizeof *K, e);
        if (!K) {
            free(J);
            return -1;
        }
        size_t m = 0;
        for (size_t i = 0; i < n; i++)
            for (int k = 0; k < c->ncores; k++) {
                K[m] = J[i];
                K[m++].cores = c->cores[k];
            }
        free(J);
        if (c->nproxies && !(J = rt_calloc(m * (size_t)(c->nproxies + 1), sizeof *J, e))) {
            free(K);
            return -1;
        }
        if (c->nproxies) {
            memcpy(J, K, m * sizeof *J);
            free(K);
        } else
            J = K;
        n = m;
    }
    size_t nbase = n;
    for (int p = 0; p < c->nproxies; p++)
        for (size_t i = 0; i < nbase; i++) {
            J[n] = J[i];
            J[n++].proxy = p;
        }
    *out = J;
    return (long)n;
}

rt_render_opts rt_exp_job_opts(const rt_exp_config *c, const rt_exp_job *jb)
{
    rt_render_opts ro = c->ro;
    ro.lights = jb->lighting >= 0 ? c->lightings[jb->lighting].mask : 0;
    ro.lights_all = jb->lighting >= 0 && !strcmp(c->lightings[jb->lighting].label, "all"); /* every light of a file */
    ro.lights = rt_render_lights(&ro); /* with --light, only the lights given exist */
    /* a raycast job is the run without lights: the default mode keeps its key */
    ro.mode = jb->mode == RT_MODE_RAYCAST ? RT_MODE_DEFAULT : jb->mode;
    ro.sched_size = jb->sched_size ? jb->sched_size : ro.sched_size;
    if (jb->cores > 0) { /* a core-count sweep: as --cores N (on the machine: its cores alone) */
        ro.cores = jb->cores;
        if (!c->mc) ro.threads = jb->cores;
    }
    if (jb->accel != RT_ACCEL_DEFAULT) ro.accel = jb->accel;
    /* a structure the tracer cannot run on (a sweep of several tracers):
     * its own default */
    const rt_tracer *tr = rt_tracer_find(jb->tracer);
    if (tr && !(tr->accels & RT_ACCEL_BIT(rt_tracer_accel(tr, &ro)))) {
        ro.accel = RT_ACCEL_DEFAULT;
        ro.instances = 0; /* --instances bvh: a tracer with its own walk runs on the flattened scene */
    }
    /* the pbrt layouts model pbrt's k-d tree: a tracer on another
     * structure keeps the compact layout (and its key) */
    if (tr && rt_geom_is_pbrt(ro.geom) && rt_tracer_accel(tr, &ro) != RT_ACCEL_KD) ro.geom = RT_GEOM_COMPACT;
    if (jb->proxy >= 0) {
        const rt_exp_proxy *p = &c->proxies[jb->proxy];
        if (p->W) {
            ro.H = (int)(((int64_t)c->ro.H * p->W + c->ro.W / 2) / c->ro.W);
            ro.W = p->W;
            ro.film &= ~RT_FILM_W; /* a Film's aspect still sets H */
            if (ro.H < 1) ro.H = 1;
        }
        if (p->subsample > 1) {
            ro.subsample = p->subsample;
            ro.subtile = p->subtile;
        }
    }
    return ro;
}

/* ---- named models ------------------------------------------------------ */

static const rt_exp_model models[RT_EXP_NMODELS] = {
    {"lean", RT_GEOM_COMPACT, RT_QSTORES_WRITE_ALLOCATE, 0, 0},
    /* docs/results.md, "Models": Dinero IV's printed traffic includes the
     * end-of-run flush and skips the fetch of full-line writes; the
     * paper's k-d tree is "similar to the k-d tree used in PBRT", so its
     * tracer touches pbrt-v1's objects per tested triangle (the pbrt
     * layout, 4-byte pointers: it doubles the Figure 6 cells within 2x of
     * the compact layout's); streaming queue stores are not in the text
     * (Dinero has none) */
    {"paper", RT_GEOM_PBRT, RT_QSTORES_WRITE_ALLOCATE, 1, 1},
};

const rt_exp_model *rt_exp_model_get(int i) { return i >= 0 && i < RT_EXP_NMODELS ? &models[i] : NULL; }

int rt_exp_model_find(const char *name)
{
    for (int i = 0; i < RT_EXP_NMODELS; i++)
        if (name && !strcmp(name, models[i].name)) return i;
    return -1;
}

void rt_exp_model_apply(const rt_exp_model *m, rt_render_opts *ro, rt_sim_config *sc)
{
    ro->geom = m->geom;
    ro->qstores = m->qstores;
    sc->flush = m->flush;
    sc->write_miss_fullline = m->fullline;
}

const char *rt_exp_sim_params(int model, const rt_sim_config *sc, char *buf, size_t n)
{
    const char *pol = rt_sim_policy_name(sc);
    int l = 0;
    buf[0] = 0;
    if (model != RT_EXP_MODEL_LEAN && rt_exp_model_get(model))
        l = snprintf(buf, n, "model=%s", models[model].name);
    if (l < 0 || (size_t)l >= n) return buf;
    if (sc->flush || sc->write_miss_fullline) snprintf(buf + l, n - (size_t)l, "%spolicy=%s", l ? " " : "", pol);
    return buf;
}

/* ---- lights -------------------------------------------------------------- */

const char *rt_exp_lights_name(unsigned mask, char *buf, size_t n)
{
    if (!n) return buf;
    buf[0] = 0;
    if (!mask) snprintf(buf, n, "none");
    else if (mask == (1u << RT_NLIGHTS) - 1) snprintf(buf, n, "all");
    else {
        size_t k = 0;
        for (int i = 0; i < 32 && k + 12 < n; i++)
            if (mask >> i & 1) k += (size_t)snprintf(buf + k, n - k, "%s%d", k ? "+" : "", i);
    }
    return buf;
}

/* ---- run identity ------------------------------------------------------ */

const char *rt_exp_tracer_params(const char *tracer, const rt_render_opts *ro, int all_sizes, char *buf, size_t n)
{
    return rt_job_params(tracer, ro, all_sizes ? "sim=all-sizes" : NULL, buf, n);
}

/* A spec naming a mesh file (what rt_scene_load reads as a file). */
static int is_mesh_spec(const char *s)
{
    size_t n = strlen(s);
    return (n >= 4 && (!strcasecmp(s + n - 4, ".obj") || !strcasecmp(s + n - 4, ".ply"))) ||
           (n >= 5 && !strcasecmp(s + n - 5, ".pbrt"));
}

/* Absolute path of an existing file into buf (PATH_MAX), '' if unknown. */
static const char *abs_path(const char *path, char *buf)
{
    char tmp[PATH_MAX];
    if (!realpath(path, tmp)) tmp[0] = 0;
    snprintf(buf, 4096, "%s", tmp);
    return buf;
}

void rt_exp_job_key(const rt_exp_config *c, const rt_exp_job *jb, const rt_scene *sc, uint64_t scene_hash,
                    rt_exp_key *k)
{
    rt_render_opts ro = rt_exp_job_opts(c, jb);
    rt_render_apply_film(&ro, sc->film_w, sc->film_h);
    int dynamic = rt_tracer_is(rt_tracer_find(jb->tracer), RT_TR_SCHEDULED);
    memset(k, 0, sizeof *k);
    rt_db_run *r = &k->run;
    r->scene = sc->name;
    r->scene_params = sc->params;
    r->scene_hash = scene_hash;
    r->ntri = sc->ntri;
    r->tracer = jb->tracer;
    r->W = ro.W;
    r->H = ro.H;
    r->lights = ro.lights;
    r->light_model = ro.light_samples ? "authored" : NULL; /* --light-samples: the file's own lights */
    const rt_tracer *rtr = rt_tracer_find(jb->tracer);
    r->instances = rtr && rt_tracer_accel(rtr, &ro) == RT_ACCEL_INST ? "bvh" : NULL; /* --instances bvh */
    r->sched_size = dynamic ? ro.sched_size : 0;
    r->gmax = dynamic ? ro.gmax : 0;
    r->params = rt_exp_tracer_params(jb->tracer, &ro, dynamic && c->dyn_all, k->params, sizeof k->params);
    r->sim_method = "exact";
    r->sim_params = rt_exp_sim_params(c->model, &c->sim, k->exact_sim_params, sizeof k->exact_sim_params);
    r->repl = c->sim.repl ? rt_sim_repl_name(c->sim.repl) : NULL;
    if (c->hier) r->hierarchy = rt_hier_spec(c->hier, k->hierarchy, sizeof k->hierarchy);
    if (c->mc) {
        rt_mc_spec(c->mc, k->hierarchy, sizeof k->hierarchy);
        r->hierarchy = k->hierarchy;
    }
    /* simulated cores of a splitting tracer (--cores N in a one-core sweep: their interleaved
     * stream in the one cache); the dynamic tracer's --cores is its threads= parameter */
    const rt_tracer *ktr = rt_tracer_find(jb->tracer);
    r->cores = (rt_tracer_simulates_cores(ktr) || (c->mc && rt_tracer_is(ktr, RT_TR_CORES))) && ro.cores > 1 ? ro.cores : 1;
    if (is_mesh_spec(c->scenes[jb->scene])) {
        r->scene_path = c->scenes[jb->scene];
        r->scene_abspath = abs_path(c->scenes[jb->scene], k->abspath);
    }
}

void rt_exp_key_method(rt_exp_key *k, const rt_approx_config *ac)
{
    k->run.sim_method = rt_approx_method_name(ac->method);
    k->run.sim_params = rt_approx_params(ac, k->sim_params, sizeof k->sim_params);
    if (rt_approx_db_has_se(ac)) {
        size_t n = strlen(k->sim_params);
        snprintf(k->sim_params + n, sizeof k->sim_params - n, " errors=1");
    }
}

void rt_exp_run_from_meta(const rt_tr_meta *m, rt_db_run *r)
{
    memset(r, 0, sizeof *r);
    r->scene = m->scene;
    r->scene_params = m->scene_params;
    r->scene_hash = m->scene_hash;
    r->ntri = m->ntri;
    r->tracer = m->tracer;
    r->W = m->W;
    r->H = m->H;
    r->lights = m->lights;
    r->light_model = strstr(m->params, "light_model=authored") ? "authored" : NULL; /* the run key says it */
    r->instances = strstr(m->params, "instances=bvh") ? "bvh" : NULL;
    r->sched_size = m->sched_size;
    r->gmax = m->gmax;
    r->params = m->params;
    r->sim_method = "exact";
    r->sim_params = "";
    r->cores = m->cores > 1 ? (int)m->cores : 1; /* a version-4 trace's simulated cores */
}

void rt_exp_run_from_din(const char *path, int din_class, uint64_t file_hash, rt_exp_key *k)
{
    const char *base = strrchr(path, '/');
    memset(k, 0, sizeof *k);
    snprintf(k->scene, sizeof k->scene, "din:%s", base ? base + 1 : path);
    snprintf(k->params, sizeof k->params, "din_class=%s", rt_class_name(din_class));
    k->run.scene = k->scene;
    k->run.scene_hash = file_hash;
    k->run.tracer = "din";
    k->run.params = k->params;
    k->run.sim_method = "exact";
    k->run.sim_params = "";
    k->run.scene_path = path;
    k->run.scene_abspath = abs_path(path, k->abspath);
}

/* ---- running jobs ------------------------------------------------------ */

struct rt_exp_worker {
    const rt_exp_config *c; /* borrowed */
    rt_db *db;              /* borrowed */
    int cur_scene;          /* index of sc, -1 = none */
    rt_scene *sc;           /* current scene, or NULL */
    rt_kdtree *kd;          /* its tree, built on the first job that runs */
    uint64_t scene_hash;    /* rt_scene_hash(sc) */
    rt_exp_stages t;        /* stage times, summed over jobs */
};

void rt_exp_worker_stages(const rt_exp_worker *w, rt_exp_stages *out) { *out = w->t; }

rt_exp_worker *rt_exp_worker_new(const rt_exp_config *c, rt_db *db, rt_err *e)
{
    rt_exp_worker *w = rt_calloc(1, sizeof *w, e);
    if (!w) return NULL;
    w->c = c;
    w->db = db;
    w->cur_scene = -1;
    return w;
}

void rt_exp_worker_free(rt_exp_worker *w)
{
    if (!w) return;
    rt_kd_free(w->kd);
    rt_scene_free(w->sc);
    free(w);
}

static int load_scene(rt_exp_worker *w, int s, rt_err *e);

/* The worker keeps one k-d tree per scene for the tracers that run on it;
 * a job on another structure builds its own (run.h). */
static int worker_kd(rt_exp_worker *w, const rt_exp_job *jb, rt_err *e)
{
    const rt_tracer *tr = rt_tracer_find(jb->tracer);
    rt_render_opts jro = rt_exp_job_opts(w->c, jb);
    if (w->kd || !tr || rt_tracer_accel(tr, &jro) != RT_ACCEL_KD) return 0;
    rt_kd_params kp;
    rt_kd_default_params(&kp);
    double tk = rt_now();
    w->kd = rt_kd_build(w->sc, &kp, e);
    w->t.scene += rt_now() - tk;
    return w->kd ? 0 : -1;
}

int rt_exp_worker_preload(rt_exp_worker *w, const rt_exp_job *J, long nj, rt_err *e)
{
    if (nj < 1) return 0;
    for (long i = 1; i < nj; i++)
        if (J[i].scene != J[0].scene) return 0;
    if (load_scene(w, J[0].scene, e) < 0) return -1;
    for (long i = 0; i < nj && !w->kd; i++)
        if (worker_kd(w, &J[i], e) < 0) return -1;
    memset(&w->t, 0, sizeof w->t); /* the caller counts the preload once, not per worker */
    return 1;
}

void rt_exp_worker_set_db(rt_exp_worker *w, rt_db *db) { w->db = db; }

static int load_scene(rt_exp_worker *w, int s, rt_err *e)
{
    if (w->cur_scene == s) return 0;
    rt_kd_free(w->kd);
    rt_scene_free(w->sc);
    w->kd = NULL;
    w->cur_scene = -1;
    double t0 = rt_now();
    w->sc = rt_scene_load(w->c->scenes[s], e);
    w->t.scene += rt_now() - t0;
    if (!w->sc) return -1;
    if (rt_render_apply_view(&w->c->ro, w->sc, e) < 0) { /* the user's camera and lights: every job's */
        rt_scene_free(w->sc);
        w->sc = NULL;
        return -1;
    }
    w->scene_hash = rt_scene_hash(w->sc);
    w->cur_scene = s;
    return 0;
}

/* Approximate methods are compared over several sizes: only jobs simulated
 * at every size (recursive, packet, --dynamic-all-sizes) run them. */
static int job_napprox(const rt_exp_config *c, const rt_exp_job *jb)
{
    return (jb->sched_size && !c->dyn_all) || jb->proxy >= 0 ? 0 : c->napprox;
}

/* 1 if the job's exact run and all its approximate runs are stored. */
static int job_stored(rt_exp_worker *w, const rt_exp_job *jb, const rt_exp_key *key, rt_err *e)
{
    int has = rt_db_has_run(w->db, &key->run, e);
    for (int a = 0; a < job_napprox(w->c, jb) && has > 0; a++) {
        rt_exp_key k = *key;
        k.run.params = k.params;
        rt_exp_key_method(&k, &w->c->approx[a]);
        has = rt_db_has_run(w->db, &k.run, e);
    }
    return has;
}

/* The state of one job being run. */
typedef struct jobrun {
    rt_job j;                          /* scene, tree, tracer, options */
    int have_job;                      /* j needs rt_job_free */
    rt_sim *sim;                       /* the exact simulator */
    rt_sim *tex;                       /* the texture cache of a GPU tracer (add_texture_cache), or NULL */
    rt_approx *ap[RT_EXP_MAXAPPROX];   /* approximate simulators */
    int napprox;
    rt_tr_writer *tw;                  /* trace writer, or NULL */
    rt_exp_fan fan;                    /* sim, ap[0..napprox-1], tw */
    rt_image *img;
    rt_sim_config sc;                  /* sizes simulated */
    rt_run_stats st;                   /* tracer statistics */
    int accel_stats;                   /* a job of a structure sweep: its stats name the structure's footprint */
    rt_hier *hier;                     /* the configuration's hierarchy (then sim is NULL), or NULL */
    rt_mc *mc;                         /* the configuration's multi-core machine (then sim is NULL), or NULL */
    rt_csink tee;                      /* mc: the cores' references into mc and, without their cores, the fan */
    double mc_sec;                     /* seconds inside mc */
    int tee_err;                       /* the fan refused a batch */
} jobrun;

/* The core sink of a job on the multi-core machine: each core's batch into
 * the machine, then (the texture cache, a kept trace) into the fan-out as
 * one stream. */
static int tee_put(rt_csink *s, unsigned core, const rt_access *a, size_t n)
{
    jobrun *r = s->ctx;
    double t0 = rt_now();
    int rc = rt_mc_put(r->mc, core, a, n);
    r->mc_sec += rt_now() - t0;
    if (r->fan.n && rt_exp_fan_sink(&r->fan)->put(rt_exp_fan_sink(&r->fan), a, n) < 0) r->tee_err = 1, rc = -1;
    return rc;
}

static void jobrun_free(jobrun *r)
{
    for (int a = 0; a < r->napprox; a++) rt_approx_free(r->ap[a]);
    if (r->tw) rt_tr_abort(r->tw);
    rt_image_free(r->img);
    rt_sim_free(r->sim);
    rt_hier_free(r->hier);
    rt_mc_free(r->mc);
    rt_sim_free(r->tex);
    if (r->have_job) rt_job_free(&r->j);
}

static int open_trace(rt_exp_worker *w, jobrun *r, const rt_exp_job *jb, long index, rt_err *e)
{
    const rt_exp_config *c = w->c;
    char path[4096], scene[161];
    const int sec = jb->mode == RT_MODE_WHITTED || jb->mode == RT_MODE_PATH;
    /* a long scene spec is cut and ends in its hash: the file name stays
     * under NAME_MAX and distinct (the run keeps the whole name) */
    rt_name_fit(scene, sizeof scene, c->scenes[jb->scene]);
    const char *acc = jb->accel != RT_ACCEL_DEFAULT ? rt_accel_name(jb->accel) : NULL;
    snprintf(path, sizeof path, "%s/job%04ld-%s-%s%s%s-%s%s%s%s%" PRIu64 "%s.rtt", c->keep, index, scene,
             jb->lighting >= 0 ? c->lightings[jb->lighting].label : "primary", sec ? "-" : "",
             sec ? rt_render_mode_name(jb->mode) : "", jb->tracer, acc ? "-" : "", acc ? acc : "",
             jb->sched_size ? "-" : "", jb->sched_size, jb->proxy >= 0 ? "-proxy" : "");
    for (char *p = path + strlen(c->keep) + 1; *p; p++)
        if (*p == '/' || *p == ':' || *p == ',' || *p == '=') *p = '_';
    rt_tr_meta m;
    rt_job_meta(&r->j, c->command, &m);
    rt_tr_wopts wo; /* as `trace` writes them: version 3, with the sample index */
    rt_si_wopts(&wo);
    /* the fan-out carries no core ids: an N-core job's kept trace is its interleaved
     * stream as one core's (`trace --cores N` writes the cores, version 4) */
    m.cores = 1;
    if (!(r->tw = rt_tr_create_opts(path, &m, &wo, e))) return -1;
    return rt_exp_fan_add(&r->fan, rt_tr_sink(r->tw), e) < 0 ? -1 : 0;
}

/* Purcell et al. 2002 simulate every run of their GPU tracers also with a
 * 64 KB direct-mapped texture cache of 48-byte lines (1365 lines, 65520
 * bytes): the jobs of the stream and feedback tracers feed one more exact
 * simulator of that cache (the sweep's write policy), whose rows carry
 * line 48 and associativity 1, so they never mix with the sweep's fully
 * associative rows. Other tracers get none (r->tex stays NULL). */
static int add_texture_cache(const rt_exp_config *c, jobrun *r, const rt_exp_job *jb, rt_err *e)
{
    if (!rt_tracer_is(rt_tracer_find(jb->tracer), RT_TR_TEXCACHE)) return 0;
    rt_sim_config tc = c->sim;
    tc.nsizes = 1;
    tc.sizes[0] = RT_EXP_TEXCACHE_SIZE;
    tc.line = RT_EXP_TEXCACHE_LINE;
    tc.assoc = 1;
    if (!(r->tex = rt_sim_new(&tc, e))) return -1;
    return rt_exp_fan_add(&r->fan, rt_sim_sink(r->tex), e) < 0 ? -1 : 0;
}

/* The sizes a job simulates: every size of the configuration, or its
 * scheduled size alone (a dynamic job without dyn_all). */
static rt_sim_config job_sizes(const rt_exp_config *c, const rt_exp_job *jb)
{
    rt_sim_config sc = c->sim;
    if (jb->sched_size && !c->dyn_all) {
        sc.nsizes = 1;
        sc.sizes[0] = jb->sched_size;
    }
    return sc;
}

/* Sets up the simulators, the fan-out and the trace, then renders. have
 * (NULL = none) marks sizes already stored, which are not simulated. */
static int render_job(rt_exp_worker *w, jobrun *r, const rt_exp_job *jb, long index, const int *have, rt_err *e)
{
    const rt_exp_config *c = w->c;
    rt_render_opts ro = rt_exp_job_opts(c, jb);
    rt_render_apply_film(&ro, w->sc->film_w, w->sc->film_h);
    r->sc = job_sizes(c, jb);
    if (have) {
        int k = 0;
        for (int i = 0; i < r->sc.nsizes; i++)
            if (!have[i]) r->sc.sizes[k++] = r->sc.sizes[i];
        r->sc.nsizes = k;
    }
    if (rt_job_setup_borrowed(&r->j, w->sc, w->kd, jb->tracer, &ro, e) < 0) return -1;
    r->have_job = 1;
    /* on the machine, a tracer that splits its own work (the dynamic
     * scheduler) runs on the job's cores; its --cores stays its threads */
    if (c->mc && rt_tracer_is(r->j.tr, RT_TR_CORES)) r->j.opt.cores = ro.cores > 1 ? ro.cores : 1;
    r->accel_stats = jb->accel != RT_ACCEL_DEFAULT;
    rt_exp_fan_init(&r->fan);
    if (c->mc) { /* the multi-core machine: the job's simulated cores, its last level at the job's sizes */
        rt_mc_config mc = *c->mc;
        rt_sim_config *last = &mc.h.level[mc.h.nlevels - 1];
        last->nsizes = r->sc.nsizes;
        memcpy(last->sizes, r->sc.sizes, sizeof last->sizes);
        mc.ncores = r->j.opt.cores > 1 ? r->j.opt.cores : 1;
        if (!(r->mc = rt_mc_new(&mc, e)) || !(r->img = rt_image_new(ro.W, ro.H, e))) return -1;
        r->tee.put = tee_put;
        r->tee.ctx = r;
    } else if (c->hier) { /* the hierarchy instead of one level; its last level at the job's sizes */
        rt_hier_config hc = *c->hier;
        rt_sim_config *last = &hc.level[hc.nlevels - 1];
        last->nsizes = r->sc.nsizes;
        memcpy(last->sizes, r->sc.sizes, sizeof last->sizes);
        if (!(r->hier = rt_hier_new(&hc, e)) || !(r->img = rt_image_new(ro.W, ro.H, e))) return -1;
        rt_exp_fan_add(&r->fan, rt_hier_sink(r->hier), e);
    } else {
        if (!(r->sim = rt_sim_new(&r->sc, e)) || !(r->img = rt_image_new(ro.W, ro.H, e))) return -1;
        rt_exp_fan_add(&r->fan, rt_sim_sink(r->sim), e);
    }
    for (int a = 0; a < job_napprox(c, jb); a++) {
        if (!(r->ap[a] = rt_approx_new(&r->sc, &c->approx[a], e))) return -1;
        r->napprox = a + 1;
        if (rt_exp_fan_add(&r->fan, rt_approx_sink(r->ap[a]), e) < 0) return -1;
    }
    if (add_texture_cache(c, r, jb, e) < 0) return -1;
    if (c->keep && open_trace(w, r, jb, index, e) < 0) return -1;
    double t0 = rt_now();
    int rrc = r->mc ? rt_job_run_cores(&r->j, &r->tee, r->img, &r->st, e)
                    : rt_job_run(&r->j, rt_exp_fan_sink(&r->fan), r->img, &r->st, e);
    if (r->mc && rrc < 0 && !r->tee_err && rt_mc_error(r->mc)[0]) rt_errf(e, "%s", rt_mc_error(r->mc));
    double sim = r->mc ? r->mc_sec : 0;
    for (int i = 0; i < (r->mc ? 0 : 1 + r->napprox); i++) sim += r->fan.sec[i];
    w->t.tracing += rt_now() - t0 - sim;
    w->t.simulation += sim;
    if (rrc < 0) return -1;
    if (r->tw) {
        int rc = rt_tr_finish(r->tw, e);
        r->tw = NULL;
        if (rc < 0) return -1;
    }
    return 0;
}

/* Stores the exact run, then each approximate run. */
static int store_job(rt_exp_worker *w, jobrun *r, rt_exp_key *key, double t0, rt_err *e)
{
    size_t nrows = (size_t)(r->sc.nsizes + 1) * RT_NCLASS; /* + the texture cache's */
    rt_db_traffic *rows = rt_calloc(nrows, sizeof *rows, e);
    rt_db_se *se = rows ? rt_calloc((size_t)r->sc.nsizes + 1, sizeof *se, e) : NULL;
    if (!se) {
        free(rows);
        return -1;
    }
    double ts = rt_now();
    rt_db_level *lv = NULL; /* a hierarchy's per-level rows */
    size_t nlv = 0;
    if (r->mc) {
        if (rt_mc_finish(r->mc) < 0) rt_errf(e, "%s", rt_mc_error(r->mc));
        else lv = rt_calloc(rt_mc_db_level_cap(r->mc), sizeof *lv, e);
        if (!lv) {
            free(rows);
            free(se);
            return -1;
        }
        r->sim = (rt_sim *)rt_mc_shared(r->mc); /* borrowed */
        nlv = rt_mc_db_level_rows_gen(r->mc, rt_job_generations(&r->j) > 0, lv);
    } else if (r->hier) {
        rt_hier_finish(r->hier);
        /* borrowed; NULL for an inclusive or exclusive hierarchy (its rows: rt_hier_db_rows, no generations) */
        r->sim = (rt_sim *)rt_hier_level(r->hier, rt_hier_get_config(r->hier)->nlevels - 1);
        if (!(lv = rt_calloc(rt_hier_db_level_max(r->hier), sizeof *lv, e))) {
            r->sim = NULL;
            free(rows);
            free(se);
            return -1;
        }
        nlv = rt_hier_db_level_rows(r->hier, rt_job_generations(&r->j) > 0, lv);
    } else
        rt_sim_finish(r->sim); /* the flush, when the accounting asks for it */
    size_t k = r->hier ? rt_hier_db_rows(r->hier, rows) : rt_sim_db_rows(r->sim, rows);
    if (r->tex) k += rt_sim_db_rows(r->tex, rows + k);
    w->t.simulation += rt_now() - ts;
    char stats[896], acc[128] = "";
    const rt_run_stats *st = &r->st;
    if (r->accel_stats) { /* the structure swept: its footprint (report --figure accel) */
        rt_accel_info inf;
        rt_accel_info_of(&r->j.acc, &inf);
        snprintf(acc, sizeof acc, " accel=%s accel_nodes=%" PRIu64 " accel_bytes=%" PRIu64 " accel_build_seconds=%.3f",
                 rt_accel_name(r->j.acc.kind), inf.nodes, inf.bytes, r->j.acc.build_sec);
    }
    snprintf(stats, sizeof stats,
             "rays_primary=%" PRIu64 " rays_shadow=%" PRIu64 " nodes=%" PRIu64 " tests=%" PRIu64 " pv_primary=%" PRIu64
             " pv_all=%" PRIu64 " render_seconds=%.3f sim_seconds=%.3f%s%s%s",
             st->rays_primary, st->rays_shadow, st->nodes, st->tests, st->pv_primary, st->pv_all, st->seconds,
             r->mc ? r->mc_sec : r->fan.sec[0], st->extra[0] ? " " : "", st->extra, acc);
    rt_db_run run = key->run;
    run.refs = r->mc ? rt_mc_refs(r->mc) : r->hier ? rt_hier_refs(r->hier) : rt_sim_refs(r->sim);
    run.command = w->c->command;
    run.wall_time = rt_now() - t0;
    run.stats = stats;
    /* per-generation rows when the stream carried generations (exact only) */
    rt_db_gen *grows = NULL;
    size_t ng = 0;
    if (rt_job_generations(&r->j) > 0 && r->sim) {
        if (!(grows = rt_calloc(nrows * RT_MAXGEN, sizeof *grows, e))) {
            free(rows);
            free(se);
            free(lv);
            if (r->hier || r->mc) r->sim = NULL;
            return -1;
        }
        ng = rt_sim_db_gen_rows(r->sim, grows);
    }
    double td = rt_now();
    /* the stop signals wait until the commit is counted (on_stored) */
    sigset_t stop, old;
    sigemptyset(&stop);
    sigaddset(&stop, SIGTERM);
    sigaddset(&stop, SIGINT);
    sigaddset(&stop, SIGHUP);
    pthread_sigmask(SIG_BLOCK, &stop, &old);
    int rc;
    if (r->hier || r->mc) {
        rt_db_rows R = {.traffic = rows, .ntraffic = k, .gen = grows, .ngen = ng, .level = lv, .nlevel = nlv};
        rc = rt_db_store(w->db, &run, &R, NULL, e);
        r->sim = NULL; /* the hierarchy's level, freed with it */
    } else
        rc = rt_db_store_run_gen(w->db, &run, rows, k, grows, ng, NULL, e);
    free(lv);
    if (rc == 0 && w->c->on_stored) w->c->on_stored(w->c->on_stored_arg);
    pthread_sigmask(SIG_SETMASK, &old, NULL);
    w->t.database += rt_now() - td;
    free(grows);
    for (int a = 0; a < r->napprox && rc == 0; a++) {
        double t0a = rt_now();
        if ((rc = rt_approx_finish(r->ap[a], e)) < 0) break;
        double sec = r->fan.sec[1 + a] + (rt_now() - t0a);
        size_t na = rt_approx_db_rows(r->ap[a], rows);
        size_t nse = rt_approx_db_se_rows(r->ap[a], se);
        w->t.simulation += rt_now() - t0a;
        char astats[sizeof stats + 64];
        rt_exp_key_method(key, &w->c->approx[a]);
        rt_db_run ra = run;
        ra.sim_method = key->run.sim_method;
        ra.sim_params = key->run.sim_params;
        ra.wall_time = sec;
        snprintf(astats, sizeof astats, "sim_seconds=%.3f exact_sim_seconds=%.3f", sec, r->fan.sec[0]);
        ra.stats = astats;
        td = rt_now();
        rt_db_rows R = {.traffic = rows, .ntraffic = na, .se = se, .nse = nse};
        rc = rt_db_store(w->db, &ra, &R, NULL, e);
        w->t.database += rt_now() - td;
    }
    free(rows);
    free(se);
    return rc;
}

int rt_exp_run_job(rt_exp_worker *w, const rt_exp_job *jb, long index, rt_err *e)
{
    if (load_scene(w, jb->scene, e) < 0) return -1;
    rt_exp_key key;
    rt_exp_job_key(w->c, jb, w->sc, w->scene_hash, &key);
    double td = rt_now();
    int has = job_stored(w, jb, &key, e);
    w->t.database += rt_now() - td;
    if (has < 0) return -1;
    /* a stored run may lack sizes or a line size asked for now (a rerun
     * with other --sizes or --line): those are simulated and added to it */
    rt_sim_config want = job_sizes(w->c, jb);
    int have[RT_SIM_MAXSIZES], *hp = NULL;
    if (has > 0) {
        td = rt_now();
        int missing = rt_db_missing_sizes(w->db, &key.run, want.sizes, want.nsizes, want.line, want.assoc,
                                          rt_sim_policy_name(&want), have, e);
        w->t.database += rt_now() - td;
        if (missing < 0) return -1;
        if (missing == 0) return 0;
        hp = have;
    }
    if (worker_kd(w, jb, e) < 0) return -1;
    double t0 = rt_now();
    jobrun r;
    memset(&r, 0, sizeof r);
    int rc = render_job(w, &r, jb, index, hp, e);
    if (rc == 0) rc = store_job(w, &r, &key, t0, e);
    jobrun_free(&r);
    return rc < 0 ? -1 : 1;
}
