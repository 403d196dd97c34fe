/* options.c -- defaults and parsing of the render options (see options.h). */
#include "options.h"
#include "grid.h"
#include "scene.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

void rt_render_default_opts(rt_render_opts *o)
{
    memset(o, 0, sizeof *o);
    o->W = 512;
    o->H = 512;
    o->lights = 0;
    o->packet = 8;
    o->sched_size = 64 * 1024;
    o->gmax = 0;
    o->qorder = RT_QORDER_FULLEST;
    o->threads = 4;
    o->subsample = 1;
    o->subtile = 8;
    o->mode = RT_MODE_DEFAULT;
    o->depth = 5;
    o->spp = 1;
    o->bounces = 4;
    o->geom = RT_GEOM_COMPACT;
    o->qstores = RT_QSTORES_WRITE_ALLOCATE;
    o->hit_rule = RT_HIT_EXACT;
    o->qp_measure = RT_QPM_ALL;
    o->queue_stats = 0;
    o->accel = RT_ACCEL_DEFAULT;
    o->vb_size = 0;
    o->grid_min = 0;
    o->grid_density = 0;
    o->rstores = RT_RSTORES_NON_TEMPORAL;
    o->oracle = RT_ORACLE_THRESHOLD;
    o->oracle_frac = 0.2;
    o->unroll_t = 1;
    o->unroll_i = 1;
    o->unroll_suppress = 0;
}

void rt_render_apply_film(rt_render_opts *o, int film_w, int film_h)
{
    unsigned f = o->film;
    o->film = 0;
    if (film_w <= 0 || film_h <= 0 || !f) return;
    if (f == (RT_FILM_W | RT_FILM_H)) {
        o->W = film_w;
        o->H = film_h;
        return;
    }
    int64_t v = f == RT_FILM_W ? ((int64_t)o->H * film_w + film_h / 2) / film_h
                               : ((int64_t)o->W * film_h + film_w / 2) / film_w;
    if (v < 1) v = 1;
    if (v > 65536) v = 65536;
    if (f == RT_FILM_W) o->W = (int)v;
    else o->H = (int)v;
}

static const char *const geom_names[] = {"compact", "mesh", "pbrt", "pbrt64"};

/* "non-temporal" was called "stream" before (still accepted: rt_render_
 * qstores_from_name; the run key keeps "queue_stores=stream" so databases
 * written before stay comparable). */
static const char *const qstores_names[] = {"write-allocate", "non-temporal"};

static const char *const rstores_names[] = {"non-temporal", "write-allocate"};

const char *rt_render_rstores_name(int rs)
{
    return rs >= 0 && rs <= RT_RSTORES_WRITE_ALLOCATE ? rstores_names[rs] : NULL;
}

int rt_render_rstores_from_name(const char *name)
{
    for (int r = 0; r <= RT_RSTORES_WRITE_ALLOCATE; r++)
        if (!strcmp(name, rstores_names[r])) return r;
    return -1;
}

const char *rt_render_geom_name(int geom) { return geom >= 0 && geom <= RT_GEOM_PBRT64 ? geom_names[geom] : NULL; }

int rt_render_geom_from_name(const char *name)
{
    for (int g = 0; g <= RT_GEOM_PBRT64; g++)
        if (!strcmp(name, geom_names[g])) return g;
    return -1;
}

static const char *const hit_rule_names[] = {"exact", "first"};
static const char *const qp_measure_names[] = {"all", "triangles"};

const char *rt_render_hit_rule_name(int r) { return r >= 0 && r <= RT_HIT_FIRST ? hit_rule_names[r] : NULL; }

int rt_render_hit_rule_from_name(const char *name)
{
    for (int r = 0; r <= RT_HIT_FIRST; r++)
        if (!strcmp(name, hit_rule_names[r])) return r;
    return -1;
}

const char *rt_render_qp_measure_name(int m) { return m >= 0 && m <= RT_QPM_TRIANGLES ? qp_measure_names[m] : NULL; }

int rt_render_qp_measure_from_name(const char *name)
{
    for (int m = 0; m <= RT_QPM_TRIANGLES; m++)
        if (!strcmp(name, qp_measure_names[m])) return m;
    return -1;
}

const char *rt_render_qstores_name(int qs)
{
    return qs >= 0 && qs <= RT_QSTORES_STREAM ? qstores_names[qs] : NULL;
}

int rt_render_qstores_from_name(const char *name)
{
    for (int q = 0; q <= RT_QSTORES_STREAM; q++)
        if (!strcmp(name, qstores_names[q])) return q;
    if (!strcmp(name, "stream")) return RT_QSTORES_STREAM; /* the former name */
    return -1;
}

static const struct {
    const char *name;
    unsigned group;
} opt_info[RT_RO_COUNT] = {
    [RT_RO_PACKET] = {"--packet", RT_OPTG_PACKET},
    [RT_RO_CACHE_SIZE] = {"--cache-size", RT_OPTG_SCHED},
    [RT_RO_GMAX] = {"--gmax", RT_OPTG_SCHED},
    [RT_RO_QORDER] = {"--qorder", RT_OPTG_SCHED},
    [RT_RO_HIT_RULE] = {"--hit-rule", RT_OPTG_SCHED},
    [RT_RO_QP_MEASURE] = {"--qp-measure", RT_OPTG_SCHED},
    [RT_RO_THREADS] = {"--threads", RT_OPTG_SCHED},
    [RT_RO_QUEUE_STORES] = {"--queue-stores", RT_OPTG_QUEUES},
    [RT_RO_GRID_MIN] = {"--grid-min", RT_OPTG_GRID},
    [RT_RO_VB_SIZE] = {"--vb-size", RT_OPTG_VB},
    [RT_RO_ORACLE] = {"--oracle", RT_OPTG_ORACLE},
    [RT_RO_ORACLE_FRACTION] = {"--oracle-fraction", RT_OPTG_ORACLE},
    [RT_RO_UNROLL] = {"--unroll", RT_OPTG_ORACLE},
    [RT_RO_UNROLL_SUPPRESS] = {"--unroll-suppress", RT_OPTG_ORACLE},
    [RT_RO_GRID_DENSITY] = {"--grid-density", RT_OPTG_GRID},
    [RT_RO_RECORD_STORES] = {"--record-stores", RT_OPTG_RECORDS},
    [RT_RO_ACCEL] = {"--accel", 0},
    [RT_RO_TREELET_TRIS] = {"--treelet-tris", RT_OPTG_TREELET},
    [RT_RO_RAY_WINDOW] = {"--ray-window", RT_OPTG_TREELET},
};

const char *rt_render_opt_name(int id) { return id >= 0 && id < RT_RO_COUNT ? opt_info[id].name : NULL; }
unsigned rt_render_opt_group(int id) { return id >= 0 && id < RT_RO_COUNT ? opt_info[id].group : 0; }

static const char *const mode_names[] = {"default", "raycast", "shadow", "whitted", "path"};

int rt_render_mode(const rt_render_opts *o)
{
    if (o->mode != RT_MODE_DEFAULT) return o->mode;
    return o->lights ? RT_MODE_SHADOW : RT_MODE_RAYCAST;
}

const char *rt_render_mode_name(int mode)
{
    return mode >= 0 && mode <= RT_MODE_PATH ? mode_names[mode] : NULL;
}

int rt_render_mode_from_name(const char *name)
{
    for (int m = RT_MODE_RAYCAST; m <= RT_MODE_PATH; m++)
        if (!strcmp(name, mode_names[m])) return m;
    return -1;
}

int rt_render_check_mode(const rt_render_opts *o, rt_err *e)
{
    if (o->mode < RT_MODE_DEFAULT || o->mode > RT_MODE_PATH) return rt_errf(e, "--mode: unknown mode %d", o->mode);
    if (o->depth < 1 || o->depth > RT_DEPTH_MAX)
        return rt_errf(e, "--depth: %d is not in 1..%d", o->depth, RT_DEPTH_MAX);
    if (o->spp < 1 || o->spp > RT_SPP_MAX) return rt_errf(e, "--spp: %d is not in 1..%d", o->spp, RT_SPP_MAX);
    if (o->bounces < 0 || o->bounces > RT_BOUNCES_MAX)
        return rt_errf(e, "--bounces: %d is not in 0..%d", o->bounces, RT_BOUNCES_MAX);
    if (!rt_render_geom_name(o->geom)) return rt_errf(e, "--layout: unknown layout %d", o->geom);
    if (!rt_render_qstores_name(o->qstores)) return rt_errf(e, "--queue-stores: unknown value %d", o->qstores);
    if (!rt_render_hit_rule_name(o->hit_rule)) return rt_errf(e, "--hit-rule: unknown value %d", o->hit_rule);
    if (!rt_render_qp_measure_name(o->qp_measure)) return rt_errf(e, "--qp-measure: unknown value %d", o->qp_measure);
    if (o->accel != RT_ACCEL_DEFAULT && !rt_accel_name(o->accel))
        return rt_errf(e, "--accel: unknown acceleration structure %d", o->accel);
    if (o->grid_min > RT_GRID_MAX_CELLS) /* 0 = the tracer's default */
        return rt_errf(e, "--grid-min: %u is not in 1..%u", (unsigned)o->grid_min, (unsigned)RT_GRID_MAX_CELLS);
    if (!(o->grid_density >= 0) || o->grid_density > RT_GRID_DENSITY_MAX)
        return rt_errf(e, "--grid-density: %g is not in (0, %g]", o->grid_density, (double)RT_GRID_DENSITY_MAX);
    if (o->grid_density > 0 && o->grid_min)
        return rt_errf_usage(e, "--grid-density and --grid-min are two rules for one grid: give one");
    if (!rt_render_rstores_name(o->rstores)) return rt_errf(e, "--record-stores: unknown value %d", o->rstores);
    return 0;
}

int rt_render_parse_lights(const char *s, unsigned *mask)
{
    if (!strcmp(s, "all")) {
        *mask = (1u << RT_NLIGHTS) - 1;
        return 0;
    }
    if (!strcmp(s, "none") || !*s) {
        *mask = 0;
        return 0;
    }
    unsigned m = 0;
    const char *p = s;
    while (*p) {
        if (*p < '0' || *p > '9') return -1;
        unsigned i = (unsigned)(*p++ - '0');
        if (i && *p >= '0' && *p <= '9') i = 10 * i + (unsigned)(*p++ - '0'); /* two digits, no leading 0 */
        if (i > 31) return -1;
        m |= 1u << i;
        if (*p == ',') {
            p++;
            if (!*p) return -1;
        } else if (*p) {
            return -1;
        }
    }
    *mask = m;
    return 0;
}

int rt_render_apply_view(const rt_render_opts *o, rt_scene *sc, rt_err *e)
{
    const rt_render_view *v = &o->view;
    if (v->look || v->fov > 0) {
        rt_vec3 eye = sc->cam.eye, at = sc->cam.at, up = sc->cam.up;
        if (v->look) {
            eye = rt_v3(v->eye[0], v->eye[1], v->eye[2]);
            at = rt_v3(v->at[0], v->at[1], v->at[2]);
            if (v->up_set) up = rt_v3(v->up[0], v->up[1], v->up[2]);
        }
        if (rt_scene_set_camera(sc, eye, at, up, v->fov > 0 ? v->fov : sc->cam.fovy_deg, e) < 0) return -1;
    }
    for (int i = 0; i < v->nlights && i < RT_NLIGHTS; i++) {
        sc->light[i] = rt_v3(v->light[i][0], v->light[i][1], v->light[i][2]);
        sc->light_scale[i] = v->light[i][3] > 0 ? v->light[i][3] / sc->light_power : 1.0f;
    }
    return 0;
}

uint32_t rt_render_nlights(const rt_render_opts *o, const rt_scene *sc)
{
    return o->light_samples && sc->nlight ? sc->nlight : RT_NLIGHTS;
}

int rt_render_light_on(const rt_render_opts *o, uint32_t i)
{
    return (o->lights_all && o->lights) || (i < 32 && ((o->lights >> i) & 1u));
}

int rt_render_check_scene_lights(const rt_render_opts *o, const rt_scene *sc, rt_err *e)
{
    if (o->light_samples > RT_LIGHT_SAMPLES_MAX)
        return rt_errf_usage(e, "--light-samples: %u is not in 0..%d", (unsigned)o->light_samples, RT_LIGHT_SAMPLES_MAX);
    uint32_t n = rt_render_nlights(o, sc);
    for (uint32_t i = n; i < 32 && !o->lights_all; i++) /* "all": the lights there are */
        if ((o->lights >> i) & 1u)
            return rt_errf_usage(e, "--lights: light %u does not exist (%s has %u light%s%s)", (unsigned)i, sc->name,
                                 (unsigned)n, n == 1 ? "" : "s",
                                 o->light_samples || !sc->nlight ? "" : "; --light-samples N uses the file's own");
    return 0;
}

unsigned rt_render_lights(const rt_render_opts *o)
{
    int n = o->view.nlights;
    return n > 0 && n < RT_NLIGHTS ? o->lights & ((1u << n) - 1) : o->lights;
}

/* Appends the shortest decimal that reads back as the float f ("0.9", not
 * "0.899999976"), after sep, at buf + *l. */
static void put_float(char *buf, size_t n, size_t *l, const char *sep, float f)
{
    char t[32];
    for (int p = 6; p <= 9; p++) {
        snprintf(t, sizeof t, "%.*g", p, (double)f);
        if (strtof(t, NULL) == f) break;
    }
    if (*l < n) *l += (size_t)snprintf(buf + *l, n - *l, "%s%s", sep, t);
}

void rt_render_view_params(const rt_render_opts *o, char *buf, size_t n)
{
    const rt_render_view *v = &o->view;
    size_t l = strlen(buf);
    if (v->look) {
        for (int k = 0; k < 6; k++)
            put_float(buf, n, &l, k ? "," : l ? " look_at=" : "look_at=", k < 3 ? v->eye[k] : v->at[k - 3]);
        for (int k = 0; k < 3 && v->up_set; k++) put_float(buf, n, &l, ",", v->up[k]);
    }
    if (v->fov > 0) put_float(buf, n, &l, l ? " fov=" : "fov=", v->fov);
    for (int i = 0; i < v->nlights; i++) {
        char key[32];
        snprintf(key, sizeof key, "%slight%d=", l ? " " : "", i);
        for (int k = 0; k < 3; k++) put_float(buf, n, &l, k ? "," : key, v->light[i][k]);
        if (v->light[i][3] > 0) put_float(buf, n, &l, ",", v->light[i][3]);
    }
    if (o->light_samples && l < n) /* the authored model: only then, so other keys stay as they were */
        l += (size_t)snprintf(buf + l, n - l, "%slight_model=authored light_samples=%u%s", l ? " " : "",
                              (unsigned)o->light_samples, o->lights_all ? " lights=all" : "");
}
