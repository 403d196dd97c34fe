/* options.c -- defaults and parsing of the render options (see options.h). */
#include "options.h"
#include "feedback.h"
#include "grid.h"
#include "scene.h"

#include <ctype.h>
#include <errno.h>
#include <math.h>
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
    o->cores = 1;
    o->host_threads = 1;
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
    if (o->instances && o->accel != RT_ACCEL_INST)
        return rt_errf_usage(e, "--instances bvh chooses the two-level structure: it does not combine with --accel %s",
                             rt_accel_name(o->accel) ? rt_accel_name(o->accel) : "?");
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
        if (*p == ',' || *p == '+') { /* "0,2" and the printed name "0+2" */
            p++;
            if (!*p) return -1;
        } else if (*p) {
            return -1;
        }
    }
    *mask = m;
    return 0;
}

static int frame_check(rt_vec3 eye, rt_vec3 at, rt_vec3 up);

int rt_render_apply_view(const rt_render_opts *o, rt_scene *sc, rt_err *e)
{
    const rt_render_view *v = &o->view;
    if (v->look || v->fov > 0) {
        rt_vec3 eye = sc->cam.eye, at = sc->cam.at, up = sc->cam.up;
        if (v->look) {
            eye = rt_v3(v->eye[0], v->eye[1], v->eye[2]);
            at = rt_v3(v->at[0], v->at[1], v->at[2]);
            if (v->up_set) up = rt_v3(v->up[0], v->up[1], v->up[2]);
            int fc = frame_check(eye, at, up);
            if (fc == 1 || fc == 3)
                return rt_errf_usage(e, "--look-at: the view direction is not finite in single precision");
            if (fc == 2 && !v->up_set) {
                return rt_errf_usage(e, "--look-at: the scene's up vector (%g,%g,%g) is along the view direction; give "
                                        "another as --look-at EX,EY,EZ,AX,AY,AZ,UX,UY,UZ", (double)up.x, (double)up.y,
                                     (double)up.z);
            }
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

/* ---- the strict parsers ------------------------------------------------ */

int rt_opt_parse_long(const char *s, long lo, long hi, long *out)
{
    char *end;
    /* strtol skips white space and takes '+': a digit first, or '-' and one */
    if (!s || !((*s >= '0' && *s <= '9') || (*s == '-' && s[1] >= '0' && s[1] <= '9'))) return -1;
    errno = 0;
    long v = strtol(s, &end, 10);
    if (errno || end == s || *end || v < lo || v > hi) return -1;
    *out = v;
    return 0;
}

int rt_opt_parse_double(const char *s, double *out)
{
    /* strtod also takes white space, '+', hex ("0x10"), "nan", "inf" and
     * "infinity": only [-]digits[.digits][e[+-]digits] or [-].digits... */
    if (!s) return -1;
    const char *p = s;
    if (*p == '-') p++;
    if (!((*p >= '0' && *p <= '9') || (*p == '.' && p[1] >= '0' && p[1] <= '9'))) return -1;
    for (const char *q = p; *q; q++)
        if (!((*q >= '0' && *q <= '9') || *q == '.' || *q == 'e' || *q == 'E' || *q == '-' || *q == '+')) return -1;
    char *end;
    errno = 0;
    double v = strtod(s, &end);
    if (end == s || *end || errno == ERANGE || !isfinite(v)) return -1;
    *out = v;
    return 0;
}

/* A comma list of finite numbers of magnitude at most 1e30 (the scene
 * coordinate range), each through rt_opt_parse_double, into out[0..max).
 * How many, or -1. */
static int parse_floats(const char *s, float *out, int max)
{
    char buf[64];
    int n = 0;
    for (;;) {
        const char *comma = strchr(s, ',');
        size_t l = comma ? (size_t)(comma - s) : strlen(s);
        double v;
        if (n == max || l >= sizeof buf) return -1;
        memcpy(buf, s, l);
        buf[l] = 0;
        if (rt_opt_parse_double(buf, &v) < 0 || fabs(v) > 1e30) return -1;
        out[n++] = (float)v;
        if (!comma) return n;
        s = comma + 1;
    }
}

/* The camera frame the renderer builds from eye, at and up (camera.c):
 * 0 when it is finite and right-handed, 1 when the view direction is not
 * finite (coordinates too large), 2 when up is zero or along it, 3 when
 * eye and at coincide (or are too close to normalize their difference). */
static int frame_check(rt_vec3 eye, rt_vec3 at, rt_vec3 up)
{
    rt_vec3 d = rt_sub(at, eye);
    if (!(isfinite(d.x) && isfinite(d.y) && isfinite(d.z))) return 1;
    if (!(rt_dot(d, d) > 0) && isfinite(rt_dot(d, d))) return 3;
    rt_vec3 dir = rt_norm(d);
    if (!(isfinite(dir.x) && isfinite(dir.y) && isfinite(dir.z)) || !(rt_dot(dir, dir) > 0.5f)) return 1;
    rt_vec3 c = rt_cross(dir, up);
    if (!(isfinite(c.x) && isfinite(c.y) && isfinite(c.z))) return 1;
    if (!(rt_dot(c, c) > 0)) return 2;
    rt_vec3 right = rt_norm(c);
    if (!(isfinite(right.x) && isfinite(right.y) && isfinite(right.z)) || !(rt_dot(right, right) > 0.5f)) return 2;
    return 0;
}

/* ---- the parsers of the table ------------------------------------------ */

#define LONG_OPT(fn, opt, lo, hi, field, fmt)                                   \
    static int fn(rt_render_opts *o, const char *arg, rt_err *e)                \
    {                                                                            \
        long v;                                                                  \
        if (rt_opt_parse_long(arg, lo, hi, &v) < 0) return rt_errf(e, opt ": '%s' " fmt, arg); \
        o->field = (int)v;                                                       \
        return 0;                                                                \
    }

LONG_OPT(p_depth, "--depth", 1, RT_DEPTH_MAX, depth, "is not in 1..64")
LONG_OPT(p_spp, "--spp", 1, RT_SPP_MAX, spp, "is not in 1..65536")
LONG_OPT(p_bounces, "--bounces", 0, RT_BOUNCES_MAX, bounces, "is not in 0..1000")
LONG_OPT(p_packet, "--packet", 1, 256, packet, "is not in 1..256")
LONG_OPT(p_host_threads, "--threads", 1, 1024, host_threads, "is not in 1..1024")

/* --cores N: the dynamic tracer's modeled threads and the other tracers'
 * simulated cores (the job keeps the one its tracer reads: run.c) */
static int p_cores(rt_render_opts *o, const char *arg, rt_err *e)
{
    long v;
    if (rt_opt_parse_long(arg, 1, RT_MAX_CORES, &v) < 0) return rt_errf(e, "--cores: '%s' is not in 1..%d", arg, RT_MAX_CORES);
    o->threads = (int)v;
    o->cores = (int)v;
    return 0;
}
_Static_assert(RT_DEPTH_MAX == 64 && RT_SPP_MAX == 65536 && RT_BOUNCES_MAX == 1000, "messages above");

/* -W (w = 1) or -H: a given size is not taken from the scene's Film */
static int p_size(int w, rt_render_opts *o, const char *arg, rt_err *e)
{
    long v;
    if (rt_opt_parse_long(arg, 1, 65536, &v) < 0) return rt_errf(e, "-%c: '%s' is not an image size in 1..65536", w ? 'W' : 'H', arg);
    if (w) o->W = (int)v;
    else o->H = (int)v;
    o->film &= w ? ~RT_FILM_W : ~RT_FILM_H;
    return 0;
}
static int p_width(rt_render_opts *o, const char *arg, rt_err *e) { return p_size(1, o, arg, e); }
static int p_height(rt_render_opts *o, const char *arg, rt_err *e) { return p_size(0, o, arg, e); }

static int p_lights(rt_render_opts *o, const char *arg, rt_err *e)
{
    if (rt_parse_lights(arg, &o->lights) < 0) return rt_errf(e, "--lights: '%s' is not all, none or a list like 0,2", arg);
    o->lights_named = strcmp(arg, "all") ? o->lights : 0;
    o->lights_all = !strcmp(arg, "all"); /* every light of a file (--light-samples) */
    return 0;
}

static int p_light_samples(rt_render_opts *o, const char *arg, rt_err *e)
{
    long v;
    if (rt_opt_parse_long(arg, 1, RT_LIGHT_SAMPLES_MAX, &v) < 0)
        return rt_errf(e, "--light-samples: '%s' is not a sample count in 1..%d", arg, RT_LIGHT_SAMPLES_MAX);
    o->light_samples = (uint32_t)v;
    return 0;
}

static int p_look_at(rt_render_opts *o, const char *arg, rt_err *e)
{
    float f[9];
    int n = parse_floats(arg, f, 9);
    if (n != 6 && n != 9)
        return rt_errf(e, "--look-at: '%s' is not EX,EY,EZ,AX,AY,AZ[,UX,UY,UZ] (numbers within 1e30)", arg);
    rt_vec3 eye = rt_v3(f[0], f[1], f[2]), at = rt_v3(f[3], f[4], f[5]);
    /* the scene's up is checked when the scene is known (rt_render_apply_view) */
    int fc = frame_check(eye, at, n == 9 ? rt_v3(f[6], f[7], f[8]) : rt_v3(0, 0, 1));
    if (fc == 3) return rt_errf(e, "--look-at: '%s': the eye must differ from the point looked at", arg);
    if (fc == 1)
        return rt_errf(e, "--look-at: '%s': the view direction is not finite in single precision (keep the "
                          "eye and the point looked at within about 1e18 of each other)", arg);
    if (n == 9 && fc == 2)
        return rt_errf(e, "--look-at: '%s': the up vector must not be zero or along the view direction", arg);
    o->view.look = 1;
    o->view.up_set = n == 9;
    memcpy(o->view.eye, f, sizeof o->view.eye);
    memcpy(o->view.at, f + 3, sizeof o->view.at);
    if (n == 9) memcpy(o->view.up, f + 6, sizeof o->view.up);
    return 0;
}

static int p_fov(rt_render_opts *o, const char *arg, rt_err *e)
{
    float f;
    if (parse_floats(arg, &f, 1) != 1 || !(f > 0 && f < 180))
        return rt_errf(e, "--fov: '%s' is not a vertical field of view in (0, 180) degrees", arg);
    o->view.fov = f;
    return 0;
}

static int p_light(rt_render_opts *o, const char *arg, rt_err *e)
{
    float f[4] = {0, 0, 0, 0};
    int n = parse_floats(arg, f, 4);
    if (n != 3 && n != 4) return rt_errf(e, "--light: '%s' is not X,Y,Z[,POWER] (numbers within 1e30)", arg);
    if (n == 4 && !(f[3] > 0)) return rt_errf(e, "--light: power '%g' is not positive", (double)f[3]);
    if (o->view.nlights == RT_NLIGHTS)
        return rt_errf(e, "--light: at most %d lights (a scene has %d)", RT_NLIGHTS, RT_NLIGHTS);
    memcpy(o->view.light[o->view.nlights++], f, sizeof f);
    return 0;
}

static int p_cache_size(rt_render_opts *o, const char *arg, rt_err *e)
{
    uint64_t u;
    if (rt_parse_size(arg, &u) < 0 || u < 64) return rt_errf(e, "--cache-size: '%s' is not a size like 64K (>= 64)", arg);
    o->sched_size = u;
    return 0;
}

static int p_gmax(rt_render_opts *o, const char *arg, rt_err *e)
{
    uint64_t u;
    if (rt_parse_size(arg, &u) < 0 || u == 0) return rt_errf(e, "--gmax: '%s' is not a positive byte count", arg);
    o->gmax = u;
    return 0;
}

static int p_subsample(rt_render_opts *o, const char *arg, rt_err *e)
{
    char buf[64], *colon;
    long t = 8, v;
    snprintf(buf, sizeof buf, "%s", arg);
    if ((colon = strchr(buf, ':'))) {
        *colon = 0;
        if (rt_opt_parse_long(colon + 1, 1, 4096, &t) < 0)
            return rt_errf(e, "--subsample: tile '%s' is not in 1..4096", colon + 1);
    }
    if (rt_opt_parse_long(buf, 1, 1L << 20, &v) < 0)
        return rt_errf(e, "--subsample: '%s' is not K or K:TILE with K in 1..1048576", arg);
    o->subsample = (uint32_t)v;
    o->subtile = (int)t;
    return 0;
}

static int p_qorder(rt_render_opts *o, const char *arg, rt_err *e)
{
    if (!strcmp(arg, "fullest")) o->qorder = RT_QORDER_FULLEST;
    else if (!strcmp(arg, "tree")) o->qorder = RT_QORDER_TREE;
    else return rt_errf(e, "--qorder: '%s' is not fullest or tree", arg);
    return 0;
}

static int p_hit_rule(rt_render_opts *o, const char *arg, rt_err *e)
{
    int v = rt_render_hit_rule_from_name(arg);
    if (v < 0) return rt_errf(e, "--hit-rule: '%s' is not exact or first", arg);
    o->hit_rule = v;
    return 0;
}

static int p_qp_measure(rt_render_opts *o, const char *arg, rt_err *e)
{
    int v = rt_render_qp_measure_from_name(arg);
    if (v < 0) return rt_errf(e, "--qp-measure: '%s' is not all or triangles", arg);
    o->qp_measure = v;
    return 0;
}

static int p_mode(rt_render_opts *o, const char *arg, rt_err *e)
{
    int m = rt_render_mode_from_name(arg);
    if (m < 0) return rt_errf(e, "--mode: '%s' is not raycast, shadow, whitted or path", arg);
    o->mode = m;
    return 0;
}

static int p_layout(rt_render_opts *o, const char *arg, rt_err *e)
{
    int v = rt_render_geom_from_name(arg);
    if (v < 0) return rt_errf(e, "--layout: '%s' is not compact, mesh, pbrt or pbrt64", arg);
    o->geom = v;
    return 0;
}

static int p_queue_stores(rt_render_opts *o, const char *arg, rt_err *e)
{
    int v = rt_render_qstores_from_name(arg);
    if (v < 0) return rt_errf(e, "--queue-stores: '%s' is not write-allocate or non-temporal", arg);
    o->qstores = v;
    if (!strcmp(arg, "stream")) {
        rt_errf(e, "note: --queue-stores stream is now spelled non-temporal");
        return 1;
    }
    return 0;
}

static int p_instances(rt_render_opts *o, const char *arg, rt_err *e)
{
    if (!strcmp(arg, "flatten")) {
        if (o->instances) o->accel = RT_ACCEL_DEFAULT;
        o->instances = 0;
    } else if (!strcmp(arg, "bvh")) {
        o->instances = 1;
        o->accel = RT_ACCEL_INST;
    } else
        return rt_errf(e, "--instances: unknown mode '%s' (flatten, bvh)", arg);
    return 0;
}

static int p_accel(rt_render_opts *o, const char *arg, rt_err *e)
{
    int a = rt_accel_from_name(arg);
    if (a < 0) return rt_errf(e, "--accel: unknown structure '%s' (%s)", arg, rt_accel_names());
    o->accel = a;
    return 0;
}

static int p_vb_size(rt_render_opts *o, const char *arg, rt_err *e)
{
    uint64_t u;
    if (rt_parse_size(arg, &u) < 0 || u < RT_FB_REC_SIZE) return rt_errf(e, "--vb-size: '%s' is not a size like 512M (>= 64)", arg);
    o->vb_size = u;
    return 0;
}

static int p_grid_min(rt_render_opts *o, const char *arg, rt_err *e)
{
    long v;
    if (rt_opt_parse_long(arg, 1, RT_GRID_MAX_CELLS, &v) < 0)
        return rt_errf(e, "--grid-min: '%s' is not in 1..%u (the grid holds at most %u cells)", arg,
                       (unsigned)RT_GRID_MAX_CELLS, (unsigned)RT_GRID_MAX_CELLS);
    o->grid_min = (uint32_t)v;
    return 0;
}

static int p_grid_density(rt_render_opts *o, const char *arg, rt_err *e)
{
    double f;
    if (rt_opt_parse_double(arg, &f) < 0 || !(f > 0) || f > RT_GRID_DENSITY_MAX)
        return rt_errf(e, "--grid-density: '%s' is not in (0, %d] (cells per triangle)", arg, RT_GRID_DENSITY_MAX);
    o->grid_density = f;
    return 0;
}

static int p_record_stores(rt_render_opts *o, const char *arg, rt_err *e)
{
    int v = rt_render_rstores_from_name(arg);
    if (v < 0) return rt_errf(e, "--record-stores: '%s' is not non-temporal or write-allocate", arg);
    o->rstores = v;
    return 0;
}

static int p_oracle(rt_render_opts *o, const char *arg, rt_err *e)
{
    if (!strcmp(arg, "naive")) o->oracle = RT_ORACLE_NAIVE;
    else if (!strcmp(arg, "threshold")) o->oracle = RT_ORACLE_THRESHOLD;
    else return rt_errf(e, "--oracle: '%s' is not naive or threshold", arg);
    return 0;
}

static int p_oracle_fraction(rt_render_opts *o, const char *arg, rt_err *e)
{
    double f;
    if (rt_opt_parse_double(arg, &f) < 0 || !(f > 0) || f > 1) return rt_errf(e, "--oracle-fraction: '%s' is not in (0, 1]", arg);
    o->oracle_frac = f;
    return 0;
}

static int p_unroll(rt_render_opts *o, const char *arg, rt_err *e)
{
    char buf[64], *comma;
    long t, i;
    snprintf(buf, sizeof buf, "%s", arg);
    if (!(comma = strchr(buf, ',')) || (*comma = 0, rt_opt_parse_long(buf, 1, 1 << 20, &t) < 0) ||
        rt_opt_parse_long(comma + 1, 1, 1 << 20, &i) < 0)
        return rt_errf(e, "--unroll: '%s' is not T,I with both in 1..1048576", arg);
    o->unroll_t = (int)t;
    o->unroll_i = (int)i;
    return 0;
}

static int p_unroll_suppress(rt_render_opts *o, const char *arg, rt_err *e)
{
    (void)arg, (void)e;
    o->unroll_suppress = 1;
    return 0;
}

static int p_treelet_tris(rt_render_opts *o, const char *arg, rt_err *e)
{
    (void)arg, (void)e;
    o->treelet_tris = 1;
    return 0;
}

static int p_ray_window(rt_render_opts *o, const char *arg, rt_err *e)
{
    uint64_t u;
    if (!strcmp(arg, "all")) {
        o->ray_window = 0;
        return 0;
    }
    if (rt_parse_size(arg, &u) < 0 || u < 1 || u > UINT32_MAX)
        return rt_errf(e, "--ray-window: '%s' is not a ray count like 64K (>= 1) or all", arg);
    o->ray_window = (uint32_t)u;
    return 0;
}

/* ---- the table (see options.h) ----------------------------------------- */

#define ALL (RT_OC_RUN | RT_OC_SWEEP)
#define H "\n" /* between help lines */

const rt_render_optdef rt_render_optdefs[] = {
    /* --help lists the registered tracers here (cli/cmd_common.c, from rt_tracer_all) */
    {"--tracer", 't', "TRACER", 0, RT_OC_RUN, NULL, NULL, NULL, "the tracer (default: the reference tracer)", NULL,
     "recursive"},
    {"--width", 'W', "N", 0, ALL, NULL, p_width, "-W N, -H N",
     "image size in pixels (a .pbrt scene: its Film's by default;" H "one of them alone keeps the Film's aspect ratio)",
     "  -W N, -H N         image size (overrides the preset and a .pbrt scene's Film)\n", "32"},
    {"--height", 'H', "N", 0, ALL, NULL, p_height, NULL, NULL, "", "24"},
    {"--lights", 0, "L", 0, RT_OC_RUN, NULL, p_lights, NULL,
     "all | none | comma list of lights 0,1,2 (default none; with" H
     "--light-samples, indices 0..31 of the file's lights, all = every one)",
     NULL, "0,2"},
    {"--light-samples", 0, "N", 0, ALL, "light_samples", p_light_samples, NULL,
     "the scene file's own lights: N shadow rays per hit to each area" H
     "or infinite light, 1 to point and distant ones (default: the" H "three point lights)",
     NULL, "16"},
    {"--look-at", 0, "EX,EY,EZ,AX,AY,AZ[,UX,UY,UZ]", 0, ALL, "look_at", p_look_at, NULL,
     "camera at E looking at A (up: the scene's)",
     "  --look-at EX,EY,EZ,AX,AY,AZ[,UX,UY,UZ], --fov DEGREES, --light X,Y,Z[,POWER]\n"
     "                     every scene's camera and lights (see render --help; in the\n"
     "                     run key when given)\n",
     "0,-3,1,0,0,0"},
    {"--fov", 0, "DEGREES", 0, ALL, "fov", p_fov, NULL, "vertical field of view (default: the scene's)", "", "40"},
    {"--light", 0, "X,Y,Z[,POWER]", 0, ALL, "light0", p_light, NULL,
     "a point light (repeat up to 3 times: lights 0, 1, 2 replace" H
     "the scene's; POWER default: the scene's light power)",
     "", "0.5,0.5,0.9"},
    {"--packet", 0, "N", RT_OPTG_PACKET, ALL, "packet", p_packet, NULL, "packet edge in pixels for -t packet (default 8)",
     NULL, "4"},
    {"--cache-size", 0, "S", RT_OPTG_SCHED, RT_OC_RUN, NULL, p_cache_size, NULL,
     "dynamic, treelet: cache size to schedule for, e.g. 64K (default 64K)", NULL, "16K"},
    {"--gmax", 0, "B", RT_OPTG_SCHED, RT_OC_RUN, NULL, p_gmax, NULL,
     "dynamic: explicit geometry budget in bytes (overrides derivation);" H
     "treelet: the treelet byte budget (default half the cache size)",
     NULL, "8K"},
    {"--subsample", 0, "K[:T]", 0, RT_OC_RUN, "subsample", p_subsample, NULL,
     "reduced experiment: trace 1 in K tiles of TxT pixels (T default 8;" H
     "1 = single pixels; packet tracer: T a multiple of the packet)",
     NULL, "2:8"},
    {"--qorder", 0, "O", RT_OPTG_SCHED, ALL, "qorder", p_qorder, NULL,
     "dynamic, treelet: queue order, fullest | tree (default fullest)",
     "  --qorder O, --cores N, --hit-rule R, --qp-measure M  dynamic scheduler options\n"
     "                     (see render --help)\n",
     "tree"},
    {"--hit-rule", 0, "R", RT_OPTG_SCHED, ALL, "hit_rule", p_hit_rule, NULL,
     "dynamic: a hit beyond the subtree's exit, exact (settled in" H
     "later queue points) | first (taken; images may differ)",
     "", "first"},
    {"--qp-measure", 0, "M", RT_OPTG_SCHED, ALL, "qp_measure", p_qp_measure, NULL,
     "dynamic: subtree size for queue points, all (nodes, lists," H "triangles) | triangles (default all)", "",
     "triangles"},
    /* no key: the dynamic tracer writes it as threads=N (its .params), the
     * others' cores are the run's cores column */
    {"--cores", 0, "N", RT_OPTG_CORES, ALL, NULL, p_cores, NULL,
     "dynamic: modeled cores, 2 rays buffered each (default 4; formerly" H
     "--threads; sweep --hierarchy: its queues dealt to N cores in" H
     "rounds); recursive, packet: simulated cores, one work share" H
     "each; treelet: treelets dealt to cores; stream-*, feedback: each" H
     "pass's rays in chunks (trace: a version-4 trace; default 1)",
     "", "2"},
    {"--threads", 0, "N", RT_OPTG_THREADS, ALL, NULL, p_host_threads, NULL,
     "render, bench: real host threads (recursive, packet, treelet;" H
     "dynamic: its N-core rounds; images identical to one thread;" H
     "default 1); trace and sweep refuse it",
     "", "2"},
    {"--mode", 0, "M", 0, RT_OC_RUN, "mode", p_mode, NULL,
     "raycast | shadow | whitted | path (default shadow with lights," H "else raycast)", NULL, "shadow"},
    {"--depth", 0, "N", 0, ALL, "depth", p_depth, NULL,
     "whitted: ray generations per path, primary included (1..64, 5)",
     "  --depth N, --spp N, --bounces B  whitted / path parameters (see render --help)\n", "3"},
    {"--spp", 0, "N", 0, ALL, "spp", p_spp, NULL, "path: samples per pixel (default 1)", "", "2"},
    {"--bounces", 0, "B", 0, ALL, "bounces", p_bounces, NULL, "path: bounces after the primary hit (0..1000, default 4)", "",
     "2"},
    {"--layout", 0, "L", 0, ALL, "layout", p_layout, NULL,
     "geometry layout, compact | mesh (pbrt-style shared vertices)" H
     "| pbrt | pbrt64 (pbrt-v1's k-d tree objects and mailboxes," H "4- or 8-byte pointers) (default compact)",
     "  --layout L         geometry layout, compact | mesh | pbrt | pbrt64\n", "mesh"},
    {"--queue-stores", 0, "S", RT_OPTG_QUEUES, ALL, "queue_stores", p_queue_stores, NULL,
     "dynamic: queue writes, write-allocate | stream (default" H "write-allocate)",
     "  --queue-stores S   dynamic: write-allocate | stream (streaming stores)\n", "non-temporal"},
    {"--accel", 0, "A", 0, ALL, "accel", p_accel, NULL,
     "acceleration structure: kd | bvh2 | bvh4 | bvh8 (recursive," H "packet; default kd), grid | naive (feedback; default grid)",
     "  --accel A, --grid-min N, --grid-density L, --record-stores S, --vb-size S\n"
     "                     acceleration structure, feedback / stream tracer options\n"
     "                     (see render --help; in the run key when not the tracer's default)\n",
     "bvh4"},
    {"--instances", 0, "M", 0, ALL, "instances", p_instances, NULL,
     "object instances: flatten (copied into the triangle array;" H "default) | bvh (a top-level BVH over instances, one shared" H
     "BVH per object; the recursive, packet and treelet" H "tracers; render and trace then load a .pbrt file's" H
     "instances unflattened)",
     "", "bvh"},
    {"--vb-size", 0, "S", RT_OPTG_VB, ALL, "vb-size", p_vb_size, NULL,
     "feedback: limit of one vertex buffer, e.g. 512M (default 2G)", "", "512M"},
    {"--grid-min", 0, "N", RT_OPTG_GRID, ALL, "grid_min", p_grid_min, NULL,
     "grid tracers: grid cells along the smallest axis (default 64," H "halved until the grid fits the cell limit)", "",
     "32"},
    {"--grid-density", 0, "L", RT_OPTG_GRID, ALL, "grid_density", p_grid_density, NULL,
     "grid tracers: about L cells per triangle instead (0 < L <= 1024)", "", "4"},
    {"--record-stores", 0, "S", RT_OPTG_RECORDS, ALL, "record_stores", p_record_stores, NULL,
     "feedback, stream tracers: non-temporal (whole records, lines not" H "fetched; default) | write-allocate", "",
     "write-allocate"},
    {"--oracle", 0, "O", RT_OPTG_ORACLE, RT_OC_RUN, "oracle", p_oracle, NULL,
     "stream-multipass: naive | threshold (default threshold)", NULL, "naive"},
    {"--oracle-fraction", 0, "F", RT_OPTG_ORACLE, RT_OC_RUN, "oracle_fraction", p_oracle_fraction, NULL,
     "stream-multipass: intersect once F of the active rays need it" H "(0 < F <= 1, default 0.2)", NULL, "0.5"},
    {"--unroll", 0, "T,I", RT_OPTG_ORACLE, RT_OC_RUN, "unroll", p_unroll, NULL,
     "stream-multipass: traversal steps, intersection tests per pass (1,1)", NULL, "2,3"},
    {"--unroll-suppress", 0, NULL, RT_OPTG_ORACLE, RT_OC_RUN, "unroll_suppress", p_unroll_suppress, NULL,
     "stream-multipass: no texel reads for rays done mid-pass", NULL, NULL},
    {"--treelet-tris", 0, NULL, RT_OPTG_TREELET, ALL, "treelet_tris", p_treelet_tris, NULL,
     "treelet: leaves' triangles count against the treelet budget",
     "  --treelet-tris, --ray-window N  treelet scheduler options (see render --help)\n", NULL},
    {"--ray-window", 0, "N", RT_OPTG_TREELET, ALL, "ray_window", p_ray_window, NULL,
     "treelet: rays in flight per generation, e.g. 64K (default all)", "", "64K"},
#ifdef RT_OPTDEFS_EXAMPLE
    /* tests/options_cli.sh builds the front end with this one entry more and
     * finds it in render, trace and sweep, their --help and the refusal */
    {"--example-edge", 0, "N", RT_OPTG_PACKET, RT_OC_RUN | RT_OC_SWEEP, "packet", p_packet, NULL,
     "packet: the packet edge again (an entry the tests add)", NULL, "4"},
#endif
};
#undef ALL
#undef H

const int rt_render_noptdefs = (int)(sizeof rt_render_optdefs / sizeof rt_render_optdefs[0]);
_Static_assert(sizeof rt_render_optdefs / sizeof rt_render_optdefs[0] <= 64, "rt_render_opts.given holds 64 bits");

int rt_render_opt_find(const char *name)
{
    if (!name) return -1;
    if (name[0] == '-' && name[1] == '-') name += 2;
    for (int i = 0; i < rt_render_noptdefs; i++)
        if (!strcmp(rt_render_optdefs[i].name + 2, name)) return i;
    return -1;
}

const char *rt_render_opt_name(int id) { return id >= 0 && id < rt_render_noptdefs ? rt_render_optdefs[id].name : NULL; }
unsigned rt_render_opt_group(int id) { return id >= 0 && id < rt_render_noptdefs ? rt_render_optdefs[id].group : 0; }

int rt_render_optdefs_check(rt_err *e) { return rt_render_optdefs_check_table(rt_render_optdefs, rt_render_noptdefs, e); }

int rt_render_optdefs_check_table(const rt_render_optdef *t, int n, rt_err *e)
{
    if (n > 64) return rt_errf(e, "%d options: more than 64 (4)", n);
    for (int i = 0; i < n; i++) {
        const rt_render_optdef *d = &t[i];
        if (!d->name || strncmp(d->name, "--", 2) || !d->name[2]) return rt_errf(e, "option %d: a name '--NAME' (1)", i);
        for (int j = 0; j < i; j++) {
            if (!strcmp(t[j].name, d->name)) return rt_errf(e, "%s: declared twice (1)", d->name);
            if (d->short_name && t[j].short_name == d->short_name)
                return rt_errf(e, "%s: short name -%c taken by %s (2)", d->name, d->short_name, t[j].name);
        }
        if (!d->parse && strcmp(d->name, "--tracer")) return rt_errf(e, "%s: no parser (3)", d->name);
        if (d->help && !d->help[0]) return rt_errf(e, "%s: empty help (5)", d->name);
        if (!d->help && i == 0) return rt_errf(e, "%s: no help and no entry before (5)", d->name);
        if (d->help && d->arg && !d->example) return rt_errf(e, "%s: no example value (5)", d->name);
        if (!d->cmds) return rt_errf(e, "%s: no command takes it", d->name);
    }
    return 0;
}

int rt_render_check_lights(const rt_render_opts *o, rt_err *e)
{
    int n = o->view.nlights;
    if (n <= 0 || !(o->lights_named >> n)) return 0;
    int bad = n;
    while (!(o->lights_named >> bad & 1)) bad++;
    return rt_errf_usage(e, "--lights: light %d is not defined: --light was given %d time%s (light%s 0%s)", bad, n,
                         n > 1 ? "s" : "", n > 1 ? "s" : "", n == 2 ? " and 1" : n == 3 ? ", 1 and 2" : "");
}
