/* run.c -- set up and run one rendering job (see run.h). */
#include "scene_load.h"
#include "run.h"
#include "pbrtlayout.h"
#include "shade.h"

#include <inttypes.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* The tracer's plan, then its regions. On failure the plan is freed. */
static int layout(rt_job *j, rt_err *e)
{
    rt_tracer_ctx ctx = {j->sc, &j->acc, rt_job_kd(j), &j->opt, &j->L, NULL, NULL, 0, NULL};
    rt_mm_init(&j->L);
    if (rt_geom_uses_mesh(j->opt.geom) && !j->mesh && !(j->mesh = rt_mesh_build(j->sc, e))) return -1;
    ctx.mesh = j->mesh;
    if (j->tr->plan && j->tr->plan(&ctx, &j->plan, e) < 0) return -1;
    ctx.plan = j->plan;
    if (j->tr->layout(&ctx, &j->L, e) == 0) return 0;
    if (j->tr->plan_free) j->tr->plan_free(j->plan);
    j->plan = NULL;
    return -1;
}

/* The structure the tracer runs on: the caller's k-d tree when that is the
 * one, else built here (owned). */
static int build_accel(rt_job *j, rt_kdtree *kd, rt_err *e)
{
    int kind = j->opt.accel;
    if (kind == RT_ACCEL_KD && kd) {
        rt_accel_wrap(&j->acc, RT_ACCEL_KD, kd, kd->build_sec);
        j->acc_borrowed = 1;
        return 0;
    }
    rt_accel_params p = {j->opt.grid_min, 0, j->opt.grid_density};
    return rt_accel_build(&j->acc, kind, j->sc, &p, e);
}

static int check_opts(const rt_render_opts *o, rt_err *e)
{
    if (o->W <= 0 || o->H <= 0 || o->W > 65536 || o->H > 65536)
        return rt_errf(e, "image size %dx%d out of range (1..65536)", o->W, o->H);
    if (o->packet <= 0 || o->packet > 256) return rt_errf(e, "packet size %d out of range (1..256)", o->packet);
    return rt_render_check_mode(o, e);
}

/* The tracer must be able to run the mode and the option values. */
static int check_tracer(const rt_tracer *tr, const rt_render_opts *o, rt_err *e)
{
    int m = rt_render_mode(o);
    if (!(tr->modes & (1u << m)))
        return rt_errf(e, "--mode: the %s tracer cannot run mode %s", tr->name, rt_render_mode_name(m));
    return rt_tracer_check_opts(tr, o, e);
}

/* Options and tracer; the structure resolved (opt.accel never DEFAULT). */
static int setup_opts(rt_job *j, const char *tracer, const rt_render_opts *o, rt_err *e)
{
    memset(j, 0, sizeof *j);
    j->tr = rt_tracer_find(tracer);
    if (!j->tr) return rt_errf(e, "unknown tracer '%s' (%s)", tracer, rt_tracer_names());
    if (check_opts(o, e) < 0 || check_tracer(j->tr, o, e) < 0) return -1;
    j->opt = *o;
    j->opt.accel = rt_tracer_accel(j->tr, o);
    if (rt_geom_is_pbrt(o->geom) && j->opt.accel != RT_ACCEL_KD)
        return rt_errf_usage(e, "--layout %s: models pbrt's k-d tree; the %s tracer runs on %s", rt_render_geom_name(o->geom),
                             j->tr->name, rt_accel_name(j->opt.accel));
    if (rt_render_mode(o) == RT_MODE_RAYCAST) j->opt.lights = 0; /* primary rays only */
    return 0;
}

/* A scene with a default image size (a pbrt Film) sets the sizes the
 * options left to it; the options are checked again with the final size. */
static int apply_film(rt_job *j, rt_err *e)
{
    j->opt.lights = rt_render_lights(&j->opt); /* with --light, only the lights given exist */
    if (rt_render_check_scene_lights(&j->opt, j->sc, e) < 0) return -1;
    if (rt_shade_authored(j->sc, &j->opt) && j->opt.lights_all && j->opt.lights && j->sc->nlight < 32)
        j->opt.lights = (1u << j->sc->nlight) - 1u; /* "all": the file's lights, none of the point model's fill */
    if (rt_shade_authored(j->sc, &j->opt) && j->opt.view.nlights)
        return rt_errf_usage(e, "--light replaces the three point lights, --light-samples traces %s's own lights: "
                                "give one of them", j->sc->name);
    /* the file's lights: a file of at most three point lights is lit alike by
     * the point lights (light[] holds them in order), which every tracer and
     * mode traces; other lights need the sampling tracers and shadow mode */
    if (rt_shade_authored(j->sc, &j->opt) && j->opt.lights &&
        (rt_scene_nonpoint_lights(j->sc) || j->sc->nlight > RT_NLIGHTS)) {
        if (!rt_tracer_is(j->tr, RT_TR_LIGHTS))
            return rt_errf_usage(e, "--light-samples: the %s tracer traces the three point lights only (the file's own "
                                 "lights)", j->tr->name);
        if (rt_render_secondary(&j->opt))
            return rt_errf_usage(e, "--light-samples: mode %s follows the three point lights only (the file's own "
                                 "lights: shadow mode)", rt_render_mode_name(rt_render_mode(&j->opt)));
    }
    rt_render_apply_film(&j->opt, j->sc->film_w, j->sc->film_h);
    if (check_opts(&j->opt, e) < 0 || rt_pixel_check(&j->opt, e) < 0) return -1;
    return 0;
}

int rt_job_setup_borrowed(rt_job *j, rt_scene *sc, rt_kdtree *kd, const char *tracer, const rt_render_opts *o,
                          rt_err *e)
{
    if (setup_opts(j, tracer, o, e) < 0) return -1;
    j->sc = sc;
    j->borrowed = 1;
    if (apply_film(j, e) < 0 || build_accel(j, kd, e) < 0 || layout(j, e) < 0) {
        rt_job_free(j);
        return -1;
    }
    return 0;
}

int rt_job_setup(rt_job *j, const char *scene_spec, const char *tracer, const rt_render_opts *o, rt_err *e)
{
    if (setup_opts(j, tracer, o, e) < 0) return -1;
    j->sc = rt_scene_load(scene_spec, e);
    if (!j->sc) return -1;
    if (rt_render_apply_view(&j->opt, j->sc, e) < 0 || apply_film(j, e) < 0 || build_accel(j, NULL, e) < 0 ||
        layout(j, e) < 0) {
        rt_job_free(j);
        return -1;
    }
    return 0;
}

/* The file's lights with an enabled infinite one: primary rays that escape
 * are environment hits, counted in the statistics (env_hits=N; not with
 * subsampling, which leaves pixels untraced). */
static void env_hits(const rt_job *j, const rt_image *img, rt_run_stats *st)
{
    const rt_scene *sc = j->sc;
    if (!rt_shade_authored(sc, &j->opt) || !j->opt.lights || j->opt.subsample != 1) return;
    int sky = 0;
    for (uint32_t i = 0; i < sc->nlight; i++) sky |= sc->lights[i].kind == RT_LIGHT_INFINITE && rt_render_light_on(&j->opt, i);
    if (!sky) return;
    uint64_t n = 0;
    for (size_t p = 0; p < (size_t)img->W * img->H; p++) n += img->depth[p] == INFINITY;
    size_t l = strlen(st->extra);
    snprintf(st->extra + l, sizeof st->extra - l, "%senv_hits=%" PRIu64, l ? " " : "", n);
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
    const int pbrt = rt_geom_is_pbrt(j->opt.geom);
    if (rec && j->opt.geom == RT_GEOM_MESH && !(trec = rt_mesh_rec_new(j->mesh, &j->L, rec, e))) {
        rt_rec_free(rec);
        return -1;
    }
    /* pbrt layouts: pbrt-v1's objects and mailboxes (pbrtlayout.h) */
    if (rec && pbrt && !(trec = rt_pbrt_rec_new(j->mesh, rt_job_kd(j), &j->L, j->opt.geom, rec, e))) {
        rt_rec_free(rec);
        return -1;
    }
    rt_tracer_ctx ctx = {j->sc, &j->acc, rt_job_kd(j), &j->opt, &j->L, trec, j->plan, j->check, j->mesh};
    double t0 = rt_now();
    int rc = j->tr->run(&ctx, img, st, e);
    if (rc == 0) env_hits(j, img, st);
    if (trec != rec) {
        rt_rec_flush(trec);
        if (pbrt) {
            uint64_t nt, ns;
            rt_pbrt_rec_counts(trec, &nt, &ns);
            size_t l = strlen(st->extra);
            snprintf(st->extra + l, sizeof st->extra - l, "%smbox_tests=%" PRIu64 " mbox_skips=%" PRIu64,
                     l ? " " : "", nt, ns);
            rt_pbrt_rec_free(trec);
        } else {
            rt_mesh_rec_free(trec);
        }
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
    if (rt_tracer_is(j->tr, RT_TR_SCHEDULED)) {
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
 * (only tracers that keep queues). */
static void layout_params(const rt_tracer *tr, const rt_render_opts *o, char *buf, size_t n)
{
    size_t l = strlen(buf);
    if (o->geom != RT_GEOM_COMPACT)
        snprintf(buf + l, n - l, "%slayout=%s", l ? " " : "", rt_render_geom_name(o->geom));
    l = strlen(buf);
    if (rt_tracer_is(tr, RT_TR_QUEUES) && o->qstores != RT_QSTORES_WRITE_ALLOCATE)
        snprintf(buf + l, n - l, "%squeue_stores=stream", l ? " " : ""); /* the key's spelling since version 1 */
}

const char *rt_job_params(const char *tracer, const rt_render_opts *o, const char *extra, char *buf, size_t n)
{
    if (!n) return buf;
    char tp[160] = "", own[128] = "", mp[480];
    const rt_tracer *tr = rt_tracer_find(tracer);
    if (!extra) extra = "";
    /* the structure when not the tracer's default, then the tracer's own */
    if (tr && o->accel != RT_ACCEL_DEFAULT && o->accel != tr->accel_default && (tr->accels & RT_ACCEL_BIT(o->accel)))
        snprintf(tp, sizeof tp, "accel=%s", rt_accel_name(o->accel));
    if (tr && tr->params) tr->params(o, own, sizeof own);
    if (own[0]) {
        size_t l = strlen(tp);
        snprintf(tp + l, sizeof tp - l, "%s%s", l ? " " : "", own);
    }
    mode_params(o, mp, sizeof mp);
    layout_params(tr, o, mp, sizeof mp);
    rt_render_view_params(o, mp, sizeof mp);
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
    if (!j->acc_borrowed) rt_accel_free(&j->acc);
    if (!j->borrowed) rt_scene_free(j->sc);
    memset(j, 0, sizeof *j);
}
