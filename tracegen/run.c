/* run.c -- set up and run one rendering job (see run.h). */
#include "run.h"

#include <inttypes.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* The tracer's plan, then its regions. On failure the plan is freed. */
static int layout(rt_job *j, rt_err *e)
{
    rt_tracer_ctx ctx = {j->sc, j->kd, &j->opt, &j->L, NULL, NULL, 0, NULL};
    rt_mm_init(&j->L);
    if (j->opt.geom == RT_GEOM_MESH && !j->mesh && !(j->mesh = rt_mesh_build(j->sc, e))) return -1;
    ctx.mesh = j->mesh;
    if (j->tr->plan && j->tr->plan(&ctx, &j->plan, e) < 0) return -1;
    ctx.plan = j->plan;
    if (j->tr->layout(&ctx, &j->L, e) == 0) return 0;
    if (j->tr->plan_free) j->tr->plan_free(j->plan);
    j->plan = NULL;
    return -1;
}

static int check_opts(const rt_render_opts *o, rt_err *e)
{
    if (o->W <= 0 || o->H <= 0 || o->W > 65536 || o->H > 65536)
        return rt_errf(e, "image size %dx%d out of range (1..65536)", o->W, o->H);
    if (o->packet <= 0 || o->packet > 256) return rt_errf(e, "packet size %d out of range (1..256)", o->packet);
    return rt_render_check_mode(o, e);
}

/* The tracer must be able to run the mode. */
static int check_tracer_mode(const rt_tracer *tr, const rt_render_opts *o, rt_err *e)
{
    int m = rt_render_mode(o);
    if (!(tr->modes & (1u << m)))
        return rt_errf(e, "--mode: the %s tracer cannot run mode %s", tr->name, rt_render_mode_name(m));
    return 0;
}

int rt_job_setup_borrowed(rt_job *j, rt_scene *sc, rt_kdtree *kd, const char *tracer, const rt_render_opts *o,
                          rt_err *e)
{
    memset(j, 0, sizeof *j);
    j->tr = rt_tracer_find(tracer);
    if (!j->tr) return rt_errf(e, "unknown tracer '%s'", tracer);
    if (check_opts(o, e) < 0 || check_tracer_mode(j->tr, o, e) < 0) return -1;
    if (rt_pixel_check(o, tracer, e) < 0) return -1;
    j->sc = sc;
    j->kd = kd;
    j->opt = *o;
    if (rt_render_mode(o) == RT_MODE_RAYCAST) j->opt.lights = 0; /* primary rays only */
    j->kd_sec = kd->build_sec;
    j->borrowed = 1;
    if (layout(j, e) < 0) {
        rt_job_free(j);
        return -1;
    }
    return 0;
}

int rt_job_setup(rt_job *j, const char *scene_spec, const char *tracer, const rt_render_opts *o, rt_err *e)
{
    memset(j, 0, sizeof *j);
    j->tr = rt_tracer_find(tracer);
    if (!j->tr) return rt_errf(e, "unknown tracer '%s'", tracer);
    if (check_opts(o, e) < 0 || check_tracer_mode(j->tr, o, e) < 0) return -1;
    if (rt_pixel_check(o, tracer, e) < 0) return -1;
    j->opt = *o;
    if (rt_render_mode(o) == RT_MODE_RAYCAST) j->opt.lights = 0; /* primary rays only */
    j->sc = rt_scene_load(scene_spec, e);
    if (!j->sc) return -1;
    rt_kd_params kp;
    rt_kd_default_params(&kp);
    j->kd = rt_kd_build(j->sc, &kp, e);
    if (!j->kd) {
        rt_job_free(j);
        return -1;
    }
    j->kd_sec = j->kd->build_sec;
    if (layout(j, e) < 0) {
        rt_job_free(j);
        return -1;
    }
    return 0;
}

int rt_job_run(rt_job *j, rt_sink *sink, rt_image *img, rt_run_stats *st, rt_err *e)
{
    rt_rec *rec = NULL;
    memset(st, 0, sizeof *st);
    if (img->W != j->opt.W || img->H != j->opt.H)
        return rt_errf(e, "image is %dx%d, job wants %dx%d", img->W, img->H, j->opt.W, j->opt.H);
    if (sink && !(rec = rt_rec_new(sink, e))) return -1;
    /* mesh layout: the tracer records into the translating recorder, which
     * feeds rec (mesh.h) */
    rt_rec *trec = rec;
    if (rec && j->opt.geom == RT_GEOM_MESH && !(trec = rt_mesh_rec_new(j->mesh, &j->L, rec, e))) {
        rt_rec_free(rec);
        return -1;
    }
    rt_tracer_ctx ctx = {j->sc, j->kd, &j->opt, &j->L, trec, j->plan, j->check, j->mesh};
    double t0 = rt_now();
    int rc = j->tr->run(&ctx, img, st, e);
    if (trec != rec) {
        rt_rec_flush(trec);
        rt_mesh_rec_free(trec);
    }
    if (rec) {
        if (rt_rec_flush(rec) < 0 && rc == 0) rc = rt_errf(e, "trace sink failed");
        st->accesses = rec->total;
        rt_rec_free(rec);
    }
    st->seconds = rt_now() - t0;
    return rc;
}

uint32_t rt_job_generations(const rt_job *j)
{
    /* the highest generation the run can stamp: whitted depth-1, path bounces */
    if (rt_render_mode(&j->opt) == RT_MODE_WHITTED) return (uint32_t)(j->opt.depth - 1);
    if (rt_render_mode(&j->opt) == RT_MODE_PATH) return (uint32_t)j->opt.bounces;
    return 0;
}

void rt_job_meta(const rt_job *j, const char *command, rt_tr_meta *m)
{
    memset(m, 0, sizeof *m);
    snprintf(m->tool_version, sizeof m->tool_version, "%s", rt_version());
    snprintf(m->git_rev, sizeof m->git_rev, "%s", rt_git_rev());
    snprintf(m->command, sizeof m->command, "%s", command ? command : "");
    rt_name_fit(m->scene, sizeof m->scene, j->sc->name); /* a longer name: prefix~hash */
    snprintf(m->scene_params, sizeof m->scene_params, "%s", j->sc->params);
    m->scene_hash = rt_scene_hash(j->sc);
    m->ntri = j->sc->ntri;
    snprintf(m->tracer, sizeof m->tracer, "%s", j->tr->name);
    m->W = j->opt.W;
    m->H = j->opt.H;
    m->lights = j->opt.lights;
    if (!strcmp(j->tr->name, "dynamic")) {
        m->sched_size = j->opt.sched_size;
        m->gmax = j->opt.gmax;
    }
    rt_job_params(j->tr->name, &j->opt, NULL, m->params, sizeof m->params);
    m->generations = rt_job_generations(j);
    m->layout = j->L;
}

/* " mode=..." and that mode's parameters, only when the mode is not the one
 * the lights select by default, so existing run keys stay as they were. */
static void mode_params(const rt_render_opts *o, char *buf, size_t n)
{
    int m = rt_render_mode(o);
    rt_render_opts d = *o;
    d.mode = RT_MODE_DEFAULT;
    buf[0] = 0;
    if (m == rt_render_mode(&d)) return;
    if (m == RT_MODE_WHITTED) snprintf(buf, n, "mode=whitted depth=%d", o->depth);
    else if (m == RT_MODE_PATH) snprintf(buf, n, "mode=path spp=%d bounces=%d", o->spp, o->bounces);
    else snprintf(buf, n, "mode=%s", rt_render_mode_name(m));
}

/* The memory-layout choices, each only when not the default, so existing
 * run keys stay as they were: " layout=mesh", " queue_stores=stream"
 * (dynamic only: the other tracers keep no queues). */
static void layout_params(const char *tracer, const rt_render_opts *o, char *buf, size_t n)
{
    size_t l = strlen(buf);
    if (o->geom != RT_GEOM_COMPACT)
        snprintf(buf + l, n - l, "%slayout=%s", l ? " " : "", rt_render_geom_name(o->geom));
    l = strlen(buf);
    if (!strcmp(tracer, "dynamic") && o->qstores != RT_QSTORES_WRITE_ALLOCATE)
        snprintf(buf + l, n - l, "%squeue_stores=%s", l ? " " : "", rt_render_qstores_name(o->qstores));
}

/* The feedback tracer's options, only those that differ from the defaults
 * ("accel=naive grid_min=N vb-size=B"), so a default run's key is empty. */
static void feedback_params(const rt_render_opts *o, char *buf, size_t n)
{
    size_t l = 0;
    buf[0] = 0;
    if (o->accel != RT_ACCEL_GRID) snprintf(buf, n, "accel=%s", rt_render_accel_name(o->accel));
    l = strlen(buf);
    if (o->grid_min && o->grid_min != 64) snprintf(buf + l, n - l, "%sgrid_min=%u", l ? " " : "", (unsigned)o->grid_min);
    l = strlen(buf);
    if (o->vb_size) snprintf(buf + l, n - l, "%svb-size=%" PRIu64, l ? " " : "", o->vb_size);
}

/* The stream tracers' parameters that differ from their defaults, so a
 * default run's key is just the tracer name. */
static void stream_params(const char *tracer, const rt_render_opts *o, char *buf, size_t n)
{
    size_t l = 0;
    buf[0] = 0;
    if (o->grid_min) l += (size_t)snprintf(buf + l, n - l, " grid_min=%u", (unsigned)o->grid_min);
    if (strcmp(tracer, "stream-multipass") || l >= n) {
        if (l) memmove(buf, buf + 1, strlen(buf));
        return;
    }
    if (o->oracle == RT_ORACLE_NAIVE && l < n) l += (size_t)snprintf(buf + l, n - l, " oracle=naive");
    if (o->oracle != RT_ORACLE_NAIVE && o->oracle_frac != 0.2 && l < n)
        l += (size_t)snprintf(buf + l, n - l, " oracle_fraction=%g", o->oracle_frac);
    if ((o->unroll_t != 1 || o->unroll_i != 1) && l < n)
        l += (size_t)snprintf(buf + l, n - l, " unroll=%d,%d", o->unroll_t, o->unroll_i);
    if (o->unroll_suppress && l < n) l += (size_t)snprintf(buf + l, n - l, " unroll_suppress=1");
    if (buf[0]) memmove(buf, buf + 1, strlen(buf));
}

const char *rt_job_params(const char *tracer, const rt_render_opts *o, const char *extra, char *buf, size_t n)
{
    if (!n) return buf;
    char tp[128] = "", mp[160];
    if (!extra) extra = "";
    if (!strcmp(tracer, "dynamic"))
        snprintf(tp, sizeof tp, "qorder=%s threads=%d", o->qorder == RT_QORDER_TREE ? "tree" : "fullest", o->threads);
    else if (!strcmp(tracer, "packet"))
        snprintf(tp, sizeof tp, "packet=%d", o->packet);
    else if (!strcmp(tracer, "feedback"))
        feedback_params(o, tp, sizeof tp);
    else if (!strncmp(tracer, "stream-", 7))
        stream_params(tracer, o, tp, sizeof tp);
    mode_params(o, mp, sizeof mp);
    layout_params(tracer, o, mp, sizeof mp);
    /* tracer parameters, mode, extra: space-separated, empty parts left out */
    const char *part[3] = {tp, mp, extra};
    size_t l = 0;
    buf[0] = 0;
    for (int i = 0; i < 3; i++) {
        if (!*part[i]) continue;
        snprintf(buf + l, n - l, "%s%s", l ? " " : "", part[i]);
        l = strlen(buf);
    }
    rt_pixel_params(o, buf + l, n - l);
    return buf;
}

void rt_job_free(rt_job *j)
{
    if (!j) return;
    if (j->plan && j->tr && j->tr->plan_free) j->tr->plan_free(j->plan);
    rt_mesh_free(j->mesh);
    if (!j->borrowed) {
        rt_kd_free(j->kd);
        rt_scene_free(j->sc);
    }
    memset(j, 0, sizeof *j);
}
