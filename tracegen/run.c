/* run.c -- set up and run one rendering job (see run.h). */
#include "scene_load.h"
#include "run.h"
#include "cores.h"
#include "pbrtlayout.h"
#include "shade.h"
#include "stats.h"

#include <inttypes.h>
#include <math.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* The tracer's plan, then its regions. On failure the plan is freed. */
static int layout(rt_job *j, rt_err *e)
{
    rt_tracer_ctx ctx = {j->sc, &j->acc, rt_job_kd(j), &j->opt, &j->L, NULL, NULL, 0, NULL, 0, 1, NULL, NULL};
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
    if (!rt_tracer_simulates_cores(j->tr)) j->opt.cores = 1; /* dynamic: --cores is its o->threads */
    if (j->opt.cores < 1 || j->opt.cores > RT_TR_MAX_CORES)
        return rt_errf_usage(e, "--cores %d: the %s tracer runs on 1..%d simulated cores", j->opt.cores, j->tr->name,
                             RT_TR_MAX_CORES);
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
    /* the two-level structure reads the instances as records: for the
     * recursive, packet and treelet tracers (which read triangles and
     * shading through rt_scene_tri_of / rt_scene_slot) a .pbrt file is
     * loaded without its flattened copy (scene.h, "Kept instances"); other
     * tracers get it */
    const int keep = j->opt.accel == RT_ACCEL_INST && (j->tr == rt_tracer_reference() || !strcmp(j->tr->name, "packet") ||
                                                       !strcmp(j->tr->name, "treelet"));
    j->sc = rt_scene_load_flags(scene_spec, keep ? RT_LOAD_KEEP_INSTANCES : 0, e);
    if (!j->sc) return -1;
    if (rt_render_apply_view(&j->opt, j->sc, e) < 0 || apply_film(j, e) < 0 || build_accel(j, NULL, e) < 0 ||
        layout(j, e) < 0) {
        rt_job_free(j);
        return -1;
    }
    return 0;
}

/* ---- host threads: one work share each (pixels.h) ---------------------- */

typedef struct share_run {
    const rt_job *j;
    rt_tracer_ctx ctx;
    rt_image *img;
    rt_run_stats st;
    rt_err e;
    int rc;
} share_run;

static int run_share(rt_job *j, rt_sink *sink, int part, int nparts, rt_image *img, rt_run_stats *st, rt_err *e);
static void env_hits(const rt_job *j, const rt_image *img, rt_run_stats *st);

static void *share_main(void *arg)
{
    share_run *s = arg;
    s->rc = run_share((rt_job *)s->j, NULL, s->ctx.part, s->ctx.nparts, s->img, &s->st, &s->e);
    return NULL;
}

/* The statistics strings of the shares as one: a token equal in every
 * share stays; "k=N" integers are summed (the largest for a key naming a
 * max or peak); "k=X" decimals are averaged over the shares. Strings of
 * different shapes: share 0's. */
static void merge_extra(const share_run *s, int n, char *out, size_t cap)
{
    char tok[64][96];
    int ntok = 0;
    const char *p = s[0].st.extra;
    snprintf(out, cap, "%s", p);
    while (*p && ntok < 64) {
        while (*p == ' ') p++;
        size_t l = strcspn(p, " ");
        if (!l) break;
        if (l >= sizeof tok[0]) return;
        memcpy(tok[ntok], p, l);
        tok[ntok++][l] = 0;
        p += l;
    }
    if (*p) return;
    char merged[sizeof s[0].st.extra] = "";
    size_t ml = 0;
    for (int t = 0; t < ntok; t++) {
        char *eq = strchr(tok[t], '=');
        int same = 1, integer = eq && eq[1], isnum = eq && eq[1];
        double sum = 0, mx = 0;
        for (int k = 0; k < n; k++) {
            const char *q = s[k].st.extra;
            for (int u = 0; u <= t; u++) { /* token t of share k */
                while (*q == ' ') q++;
                size_t l = strcspn(q, " ");
                if (u < t) {
                    q += l;
                    continue;
                }
                if (l != strlen(tok[t]) || strncmp(q, tok[t], l)) same = 0;
                if (!eq || strncmp(q, tok[t], (size_t)(eq - tok[t]) + 1)) {
                    isnum = 0;
                    break;
                }
                char *end;
                const char *v = q + (eq - tok[t]) + 1;
                double x = strtod(v, &end);
                if (end == v || (size_t)(end - q) != l) isnum = 0;
                if (memchr(v, '.', l - (size_t)(v - q))) integer = 0;
                sum += x;
                if (!k || x > mx) mx = x;
            }
        }
        char one[128];
        if (same || !isnum) snprintf(one, sizeof one, "%s", tok[t]);
        else if (integer)
            snprintf(one, sizeof one, "%.*s=%.0f", (int)(eq - tok[t]), tok[t],
                     strstr(tok[t], "max") || strstr(tok[t], "peak") ? mx : sum);
        else snprintf(one, sizeof one, "%.*s=%.1f", (int)(eq - tok[t]), tok[t], sum / n);
        ml += (size_t)snprintf(merged + ml, sizeof merged - ml, "%s%s", ml ? " " : "", one);
        if (ml >= sizeof merged) return;
    }
    snprintf(out, cap, "%s", merged);
}

/* The shares' statistics as one run's: counts summed, the marks (n rows
 * of the scene's triangles, or 1 byte) or-ed for the visible sets. */
static void merge_shares(const rt_job *j, const share_run *s, int n, uint8_t *marks, rt_run_stats *st)
{
    const uint32_t nslot = rt_scene_model_nslot(j->sc, j->acc.kind == RT_ACCEL_INST); /* marks, per model slot */
    const uint32_t ntri = nslot ? nslot : 1;
    for (int k = 0; k < n; k++) {
        st->rays_primary += s[k].st.rays_primary;
        st->rays_shadow += s[k].st.rays_shadow;
        st->nodes += s[k].st.nodes;
        st->tests += s[k].st.tests;
    }
    for (int k = 1; k < n; k++)
        for (uint32_t i = 0; i < ntri; i++) marks[i] |= marks[(size_t)k * ntri + i];
    rt_trav none;
    memset(&none, 0, sizeof none);
    rt_run_stats pv;
    memset(&pv, 0, sizeof pv);
    rt_stats_finish(&pv, &none, marks, nslot);
    st->pv_primary = pv.pv_primary;
    st->pv_all = pv.pv_all;
    merge_extra(s, n, st->extra, sizeof st->extra);
}

/* An untraced run on n host threads: the tracer's run on each work share,
 * the statistics summed and the marks or-ed for the visible sets. */
static int run_threads(rt_job *j, int n, rt_image *img, rt_run_stats *st, rt_err *e)
{
    const uint32_t nslot = rt_scene_model_nslot(j->sc, j->acc.kind == RT_ACCEL_INST); /* marks, per model slot */
    const uint32_t ntri = nslot ? nslot : 1;
    share_run *s = rt_calloc((size_t)n, sizeof *s, e);
    uint8_t *marks = s ? rt_calloc((size_t)n, ntri, e) : NULL;
    pthread_t *tid = marks ? rt_calloc((size_t)n, sizeof *tid, e) : NULL;
    int started = 0, rc = 0;
    if (!tid) goto done;
    for (int k = 0; k < n; k++) {
        s[k].j = j;
        s[k].ctx = (rt_tracer_ctx){j->sc, &j->acc, rt_job_kd(j), &j->opt, &j->L, NULL, j->plan, j->check, j->mesh, k, n, NULL, NULL};
        s[k].img = img;
        s[k].st.mark_keep = marks + (size_t)k * ntri;
    }
    for (; started < n; started++)
        if (pthread_create(&tid[started], NULL, share_main, &s[started])) break;
    for (int k = 0; k < started; k++) pthread_join(tid[k], NULL);
    if (started < n) {
        rc = rt_errf(e, "--threads %d: could not start host thread %d", n, started + 1);
        goto done;
    }
    for (int k = 0; k < n; k++)
        if (s[k].rc < 0) {
            *e = s[k].e;
            rc = -1;
            goto done;
        }
    merge_shares(j, s, n, marks, st);
    env_hits(j, img, st);
done:
    free(tid);
    free(marks);
    free(s);
    return tid ? rc : -1;
}

/* ---- a core's own copy of its scratch regions (run.h) -------------------- */

typedef struct reloc {
    rt_sink self;        /* the wrapper: relocates, then hands on */
    rt_sink *to;
    uint64_t lo[RT_MM_MAX_REGIONS], hi[RT_MM_MAX_REGIONS]; /* the scratch regions [lo, hi) */
    int n;
    uint64_t off;        /* core * span */
    rt_access buf[RT_REC_BUF];
} reloc;

static int reloc_put(rt_sink *s, const rt_access *a, size_t n)
{
    reloc *r = s->ctx;
    while (n) {
        size_t k = n < RT_REC_BUF ? n : RT_REC_BUF;
        for (size_t i = 0; i < k; i++) {
            r->buf[i] = a[i];
            for (int g = 0; g < r->n; g++)
                if (a[i].addr >= r->lo[g] && a[i].addr < r->hi[g]) {
                    r->buf[i].addr += r->off;
                    break;
                }
        }
        if (r->to->put(r->to, r->buf, k) < 0) return -1;
        a += k;
        n -= k;
    }
    return 0;
}

/* Sets r up for core `part`: 0 when it relocates nothing (core 0, or no
 * scratch region), 1 when r->self is to be used. */
static int reloc_init(reloc *r, const rt_layout *L, int part, rt_sink *to)
{
    r->n = 0;
    r->to = to;
    r->self.put = reloc_put;
    r->self.ctx = r;
    if (part <= 0) return 0;
    for (int g = 0; g < L->n; g++) {
        const rt_region *x = &L->r[g];
        if (rt_class_group(x->cls) == RT_GROUP_GEOMETRY || !strcmp(x->name, "rays.primary") || !strcmp(x->name, "fb"))
            continue;
        r->lo[r->n] = x->base;
        r->hi[r->n++] = x->base + (uint64_t)x->recsize * x->count;
    }
    const uint64_t span = (L->next - RT_MM_BASE + 4095) & ~(uint64_t)4095;
    r->off = (uint64_t)part * span;
    return r->n > 0;
}

/* One tracer run of work share part of nparts, recording into sink (NULL:
 * untraced) through the layout's translating recorder. Fills st (its
 * mark_keep as set by the caller). 0 or -1. */
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

static int run_share(rt_job *j, rt_sink *sink, int part, int nparts, rt_image *img, rt_run_stats *st, rt_err *e)
{
    rt_rec *rec = NULL;
    reloc *rl = NULL;
    if (sink && nparts > 1) { /* a core's scratch regions: its own copy (run.h) */
        if (!(rl = rt_calloc(1, sizeof *rl, e))) return -1;
        if (reloc_init(rl, &j->L, part, sink)) sink = &rl->self;
    }
    if (sink && !(rec = rt_rec_new(sink, e))) {
        free(rl);
        return -1;
    }
    /* mesh layout: the tracer records into the translating recorder, which
     * feeds rec (mesh.h) */
    rt_rec *trec = rec;
    const int pbrt = rt_geom_is_pbrt(j->opt.geom);
    if (rec && j->opt.geom == RT_GEOM_MESH && !(trec = rt_mesh_rec_new(j->mesh, &j->L, rec, e))) {
        rt_rec_free(rec);
        free(rl);
        return -1;
    }
    /* pbrt layouts: pbrt-v1's objects and mailboxes (pbrtlayout.h) */
    if (rec && pbrt && !(trec = rt_pbrt_rec_new(j->mesh, rt_job_kd(j), &j->L, j->opt.geom, rec, e))) {
        rt_rec_free(rec);
        free(rl);
        return -1;
    }
    rt_tracer_ctx ctx = {j->sc, &j->acc, rt_job_kd(j), &j->opt, &j->L, trec, j->plan, j->check, j->mesh, part, nparts, NULL, NULL};
    int rc = j->tr->run(&ctx, img, st, e);
    if (rc == 0 && nparts == 1) env_hits(j, img, st); /* n shares: once, over the whole image */
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
    free(rl);
    return rc;
}

int rt_job_run_part(rt_job *j, rt_sink *sink, int part, int nparts, rt_image *img, rt_run_stats *st, rt_err *e)
{
    memset(st, 0, sizeof *st);
    if (nparts < 1 || part < 0 || part >= nparts) return rt_errf(e, "work share %d of %d", part, nparts);
    if (nparts > 1 && !(j->tr->opts & RT_OPTG_THREADS))
        return rt_errf(e, "the %s tracer does not split its work", j->tr->name);
    return run_share(j, sink, part, nparts, img, st, e);
}

/* ---- a tracer that splits its own work over the cores (cores.h) -------- */

/* One run of a tracer with RT_TR_CORE_PHASES, ctx.cores set: core k records through its own
 * recorder (and the mesh layout's translator in front of it) into the
 * phase interleave, which hands the references to cs (NULL: untraced). */
static int run_phased_cores(rt_job *j, rt_csink *cs, rt_image *img, rt_run_stats *st, rt_err *e)
{
    const int n = j->opt.cores > 1 ? j->opt.cores : 1;
    rt_cores c;
    rt_rec **rec = NULL, **trec = NULL;
    int rc = -1;
    if (rt_cores_init(&c, n, cs, e) < 0) goto done;
    if (cs && (!(rec = rt_calloc((size_t)n, sizeof *rec, e)) || !(trec = rt_calloc((size_t)n, sizeof *trec, e))))
        goto done;
    if (cs && rt_geom_is_pbrt(j->opt.geom)) {
        rt_errf_usage(e, "--layout %s: one core's layout (the %s tracer splits its work over cores itself)",
                      rt_render_geom_name(j->opt.geom), j->tr->name);
        goto done;
    }
    for (int k = 0; cs && k < n; k++) {
        if (!(rec[k] = rt_rec_new(rt_cores_sink(&c, k), e))) goto done;
        trec[k] = rec[k];
        if (j->opt.geom == RT_GEOM_MESH && !(trec[k] = rt_mesh_rec_new(j->mesh, &j->L, rec[k], e))) goto done;
        rt_cores_set_rec(&c, k, trec[k], rec[k]);
    }
    rt_tracer_ctx ctx = {j->sc, &j->acc, rt_job_kd(j), &j->opt, &j->L, cs ? trec[0] : NULL, j->plan, j->check,
                         j->mesh, 0, 1, NULL, &c};
    rc = j->tr->run(&ctx, img, st, e);
    if (rt_cores_barrier(&c) < 0 && rc == 0) rc = rt_errf(e, "trace sink failed");
    if (rc == 0) env_hits(j, img, st);
    for (int k = 0; cs && k < n; k++) st->accesses += rec[k]->total;
done:
    for (int k = 0; trec && k < n; k++) {
        if (trec[k] && trec[k] != rec[k]) rt_mesh_rec_free(trec[k]);
        rt_rec_free(rec[k]);
    }
    free(trec);
    free(rec);
    rt_cores_free(&c);
    return rc;
}

/* A core sink that forgets the cores: rt_job_run's sink behind the interleave. */
static int plain_put(rt_csink *cs, unsigned core, const rt_access *a, size_t n)
{
    (void)core;
    rt_sink *s = cs->ctx;
    return s->put(s, a, n);
}

int rt_job_run(rt_job *j, rt_sink *sink, rt_image *img, rt_run_stats *st, rt_err *e)
{
    memset(st, 0, sizeof *st);
    if (img->W != j->opt.W || img->H != j->opt.H)
        return rt_errf(e, "image is %dx%d, job wants %dx%d", img->W, img->H, j->opt.W, j->opt.H);
    if (j->opt.host_threads > 1) {
        if (sink)
            return rt_errf_usage(e, "--threads %d: a trace is one ordered stream, recorded on one thread "
                                    "(simulated cores: --cores)", j->opt.host_threads);
        if (rt_tracer_is(j->tr, RT_TR_CORES)) { /* its N-core rounds on N host threads */
            double t0 = rt_now();
            rt_tracer_ctx ctx = {j->sc, &j->acc, rt_job_kd(j), &j->opt, &j->L, NULL, j->plan, j->check, j->mesh, 0, 1, NULL, NULL};
            int rc = j->tr->run(&ctx, img, st, e);
            if (rc == 0) env_hits(j, img, st);
            st->seconds = rt_now() - t0;
            return rc;
        }
        if (!(j->tr->opts & RT_OPTG_THREADS))
            return rt_errf_usage(e, "--threads %d: the %s tracer runs on one host thread", j->opt.host_threads,
                                 j->tr->name);
        double t0 = rt_now();
        int rc = run_threads(j, j->opt.host_threads, img, st, e);
        st->seconds = rt_now() - t0;
        return rc;
    }
    if (sink && j->opt.cores > 1) {
        rt_csink cs = {plain_put, sink};
        return rt_job_run_cores(j, &cs, img, st, e);
    }
    double t0 = rt_now();
    int rc = !sink && j->opt.cores > 1 && rt_tracer_is(j->tr, RT_TR_CORE_PHASES) ? run_phased_cores(j, NULL, img, st, e)
                                                                               : run_share(j, sink, 0, 1, img, st, e);
    st->seconds = rt_now() - t0;
    return rc;
}

/* ---- simulated cores: the modeled clock (run.h) -------------------------- */

enum { CORE_QCAP = 1u << 14 }; /* records a core may run ahead of the interleave */

typedef struct core_run {
    share_run s;            /* the share: job, context, statistics, error */
    rt_sink qsink;          /* the core's recorder feeds the queue */
    pthread_mutex_t mu;     /* guards everything below */
    pthread_cond_t cv;      /* signalled on a change the other side waits for */
    rt_access *q;           /* ring of CORE_QCAP records */
    size_t head, n;         /* oldest record, records queued */
    int done;               /* the core's run returned */
    int stop;               /* the interleave stopped: put fails from now */
    int waiting;            /* 1 producer waits for room, 2 consumer waits for records */
} core_run;

static int q_put(rt_sink *s, const rt_access *a, size_t n)
{
    core_run *c = s->ctx;
    pthread_mutex_lock(&c->mu);
    while (n) {
        while (c->n == CORE_QCAP && !c->stop) {
            c->waiting = 1;
            pthread_cond_wait(&c->cv, &c->mu);
        }
        if (c->stop) {
            pthread_mutex_unlock(&c->mu);
            return -1;
        }
        size_t tail = (c->head + c->n) % CORE_QCAP, room = CORE_QCAP - c->n, k = n < room ? n : room;
        if (k > CORE_QCAP - tail) k = CORE_QCAP - tail;
        memcpy(c->q + tail, a, k * sizeof *a);
        c->n += k;
        a += k;
        n -= k;
        if (c->waiting == 2 && (c->n >= RT_CORE_TICK)) {
            c->waiting = 0;
            pthread_cond_signal(&c->cv);
        }
    }
    pthread_mutex_unlock(&c->mu);
    return 0;
}

static void *core_main(void *arg)
{
    core_run *c = arg;
    share_run *s = &c->s;
    s->rc = run_share((rt_job *)s->j, &c->qsink, s->ctx.part, s->ctx.nparts, s->img, &s->st, &s->e);
    pthread_mutex_lock(&c->mu);
    c->done = 1;
    pthread_cond_signal(&c->cv);
    pthread_mutex_unlock(&c->mu);
    return NULL;
}

/* Core c's next tick: up to RT_CORE_TICK records into out (fewer only at
 * its end). Returns how many; 0 when the core is finished. */
static size_t q_take(core_run *c, rt_access *out)
{
    pthread_mutex_lock(&c->mu);
    while (c->n < RT_CORE_TICK && !c->done) {
        c->waiting = 2;
        pthread_cond_wait(&c->cv, &c->mu);
    }
    size_t k = c->n < RT_CORE_TICK ? c->n : RT_CORE_TICK;
    for (size_t i = 0; i < k; i++) out[i] = c->q[(c->head + i) % CORE_QCAP];
    c->head = (c->head + k) % CORE_QCAP;
    c->n -= k;
    if (c->waiting == 1) {
        c->waiting = 0;
        pthread_cond_signal(&c->cv);
    }
    pthread_mutex_unlock(&c->mu);
    return k;
}

/* A tracer that splits its own work over the cores (RT_TR_CORES): one run
 * on the calling thread, handing its cores' references to cs itself. */
static int run_own_cores(rt_job *j, rt_csink *cs, rt_image *img, rt_run_stats *st, rt_err *e)
{
    if (j->opt.geom != RT_GEOM_COMPACT)
        return rt_errf_usage(e, "--cores %d: the %s tracer runs on several cores in the compact layout only (--layout %s)",
                             j->opt.cores, j->tr->name, rt_render_geom_name(j->opt.geom));
    rt_tracer_ctx ctx = {j->sc, &j->acc, rt_job_kd(j), &j->opt, &j->L, NULL, j->plan, j->check, j->mesh, 0, 1, cs, NULL};
    double t0 = rt_now();
    int rc = j->tr->run(&ctx, img, st, e);
    if (rc == 0) env_hits(j, img, st);
    st->seconds = rt_now() - t0;
    return rc;
}

int rt_job_run_cores(rt_job *j, rt_csink *cs, rt_image *img, rt_run_stats *st, rt_err *e)
{
    memset(st, 0, sizeof *st);
    const int n = j->opt.cores > 1 ? j->opt.cores : 1;
    if (img->W != j->opt.W || img->H != j->opt.H)
        return rt_errf(e, "image is %dx%d, job wants %dx%d", img->W, img->H, j->opt.W, j->opt.H);
    if (n > 1 && rt_tracer_is(j->tr, RT_TR_CORES)) return run_own_cores(j, cs, img, st, e);
    if (rt_tracer_is(j->tr, RT_TR_CORE_PHASES)) {
        double t0 = rt_now();
        int rc = run_phased_cores(j, cs, img, st, e);
        st->seconds = rt_now() - t0;
        return rc;
    }
    if (n > 1 && !(j->tr->opts & RT_OPTG_THREADS))
        return rt_errf_usage(e, "--cores %d: the %s tracer does not split its work over cores", n, j->tr->name);
    const uint32_t nslot = rt_scene_model_nslot(j->sc, j->acc.kind == RT_ACCEL_INST); /* marks, per model slot */
    const uint32_t ntri = nslot ? nslot : 1;
    core_run *c = rt_calloc((size_t)n, sizeof *c, e);
    uint8_t *marks = c ? rt_calloc((size_t)n, ntri, e) : NULL;
    pthread_t *tid = marks ? rt_calloc((size_t)n, sizeof *tid, e) : NULL;
    int started = 0, inited = 0, rc = 0;
    double t0 = rt_now();
    if (!tid) goto done;
    for (; inited < n; inited++) {
        core_run *k = &c[inited];
        k->s.j = j;
        k->s.ctx.part = inited;
        k->s.ctx.nparts = n;
        k->s.img = img;
        k->s.st.mark_keep = marks + (size_t)inited * ntri;
        k->qsink.put = q_put;
        k->qsink.ctx = k;
        if (!(k->q = rt_calloc(CORE_QCAP, sizeof *k->q, e))) break;
        pthread_mutex_init(&k->mu, NULL);
        pthread_cond_init(&k->cv, NULL);
    }
    if (inited < n) {
        rc = -1;
        goto done;
    }
    for (; started < n; started++)
        if (pthread_create(&tid[started], NULL, core_main, &c[started])) break;
    if (started < n) rc = rt_errf(e, "--cores %d: could not start the thread of core %d", n, started);
    /* the modeled clock: a tick of every running core in turn */
    rt_access tick[RT_CORE_TICK];
    int running = rc == 0 ? n : 0;
    uint8_t *fin = rt_calloc((size_t)n, 1, e);
    if (!fin) rc = -1, running = 0;
    while (running > 0) {
        for (int k = 0; k < n; k++) {
            if (fin[k]) continue;
            size_t got = q_take(&c[k], tick);
            if (!got) {
                fin[k] = 1;
                running--;
                continue;
            }
            if (cs->put(cs, (unsigned)k, tick, got) < 0) {
                rc = rt_errf(e, "trace sink failed");
                running = 0;
                break;
            }
        }
    }
    free(fin);
    for (int k = 0; k < n; k++) { /* producers still running (a failed sink) stop */
        pthread_mutex_lock(&c[k].mu);
        c[k].stop = 1;
        pthread_cond_broadcast(&c[k].cv);
        pthread_mutex_unlock(&c[k].mu);
    }
    for (int k = 0; k < started; k++) pthread_join(tid[k], NULL);
    if (rc == 0)
        for (int k = 0; k < n; k++)
            if (c[k].s.rc < 0) {
                *e = c[k].s.e;
                rc = -1;
                break;
            }
    if (rc == 0) {
        share_run *s = rt_calloc((size_t)n, sizeof *s, e);
        if (!s) rc = -1;
        for (int k = 0; s && k < n; k++) s[k] = c[k].s;
        if (s) merge_shares(j, s, n, marks, st);
        for (int k = 0; s && k < n; k++) st->accesses += s[k].st.accesses;
        free(s);
    }
done:
    for (int k = 0; c && k < inited; k++) {
        pthread_mutex_destroy(&c[k].mu);
        pthread_cond_destroy(&c[k].cv);
    }
    for (int k = 0; c && k < n; k++) free(c[k].q);
    free(tid);
    free(marks);
    free(c);
    st->seconds = rt_now() - t0;
    return tid ? rc : -1;
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
    m->ntri = rt_scene_nflat(j->sc);
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
    m->cores = j->opt.cores > 1 ? (uint32_t)j->opt.cores : 1; /* > 1: a version-4 trace */
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
        snprintf(tp, sizeof tp, "%s%s", o->accel == RT_ACCEL_INST ? "instances=bvh" : "accel=",
                 o->accel == RT_ACCEL_INST ? "" : rt_accel_name(o->accel));
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
