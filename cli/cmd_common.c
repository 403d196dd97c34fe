/* cmd_common.c -- option parsing and output helpers shared by the
 * subcommands, so the same option is spelled and checked the same way
 * everywhere and JSON strings are escaped one way. */
#include "cmd.h"
#include "feedback.h"
#include "grid.h"
#include "scene.h"

#include <errno.h>
#include <ctype.h>
#include <limits.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

const struct option rt_render_longopts[] = {
    {"lights", required_argument, NULL, RT_OPT_LIGHTS},
    {"cache-size", required_argument, NULL, RT_OPT_CACHE_SIZE},
    {"gmax", required_argument, NULL, RT_OPT_GMAX},
    {"packet", required_argument, NULL, RT_OPT_PACKET},
    {"qorder", required_argument, NULL, RT_OPT_QORDER},
    {"hit-rule", required_argument, NULL, RT_OPT_HIT_RULE},
    {"qp-measure", required_argument, NULL, RT_OPT_QP_MEASURE},
    {"threads", required_argument, NULL, RT_OPT_THREADS},
    {"subsample", required_argument, NULL, RT_OPT_SUBSAMPLE},
    {"mode", required_argument, NULL, RT_OPT_MODE},
    {"depth", required_argument, NULL, RT_OPT_DEPTH},
    {"spp", required_argument, NULL, RT_OPT_SPP},
    {"bounces", required_argument, NULL, RT_OPT_BOUNCES},
    {"layout", required_argument, NULL, RT_OPT_LAYOUT},
    {"queue-stores", required_argument, NULL, RT_OPT_QUEUE_STORES},
    {"accel", required_argument, NULL, RT_OPT_ACCEL},
    {"grid-min", required_argument, NULL, RT_OPT_GRID_MIN},
    {"grid-density", required_argument, NULL, RT_OPT_GRID_DENSITY},
    {"record-stores", required_argument, NULL, RT_OPT_RECORD_STORES},
    {"vb-size", required_argument, NULL, RT_OPT_VB_SIZE},
    {"oracle", required_argument, NULL, RT_OPT_ORACLE},
    {"oracle-fraction", required_argument, NULL, RT_OPT_ORACLE_FRACTION},
    {"unroll", required_argument, NULL, RT_OPT_UNROLL},
    {"unroll-suppress", no_argument, NULL, RT_OPT_UNROLL_SUPPRESS},
    {"look-at", required_argument, NULL, RT_OPT_LOOK_AT},
    {"fov", required_argument, NULL, RT_OPT_FOV},
    {"light", required_argument, NULL, RT_OPT_LIGHT},
    {"treelet-tris", no_argument, NULL, RT_OPT_TREELET_TRIS},
    {"ray-window", required_argument, NULL, RT_OPT_RAY_WINDOW},
    {"light-samples", required_argument, NULL, RT_OPT_LIGHT_SAMPLES},
    {"tracer", required_argument, NULL, 't'},
    {"width", required_argument, NULL, 'W'},
    {"height", required_argument, NULL, 'H'},
    {NULL, 0, NULL, 0},
};

struct option *rt_cmd_merge_opts(const struct option *own)
{
    size_t a = 0, b = 0;
    while (own[a].name) a++;
    while (rt_render_longopts[b].name) b++;
    struct option *t = calloc(a + b + 1, sizeof *t);
    if (!t) return NULL;
    memcpy(t, own, a * sizeof *t);
    memcpy(t + a, rt_render_longopts, b * sizeof *t);
    return t;
}

int rt_cmd_parse_long(const char *s, long lo, long hi, long *out)
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

/* Parses a comma list of finite numbers of magnitude at most 1e30 (the
 * scene coordinate range), no spaces, into out[0..max). Returns how many,
 * or -1. */
static int parse_floats(const char *s, float *out, int max)
{
    int n = 0;
    for (;;) {
        char *end;
        if (n == max || !*s || isspace((unsigned char)*s) || *s == ',') return -1;
        errno = 0;
        double v = strtod(s, &end);
        if (end == s || errno || !isfinite(v) || fabs(v) > 1e30) return -1;
        for (const char *q = s; q < end; q++) /* decimal only: no hex, inf or nan */
            if (!strchr("0123456789+-.eE", *q)) return -1;
        out[n++] = (float)v;
        if (!*end) return n;
        if (*end != ',') return -1;
        s = end + 1;
    }
}

int rt_cmd_parse_double(const char *s, double *out)
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

int rt_cmd_check_text(const char *cmd, const char *opt, const char *arg)
{
    for (const unsigned char *p = (const unsigned char *)arg; *p; p++)
        if (*p < 0x20 || *p == 0x7f) {
            char q[128];
            rt_cmd_error(cmd, "%s: '%s' contains a control character (\\x%02x); not allowed in scene names and "
                              "file names", opt, rt_esc(q, sizeof q, arg, 4096), *p);
            return -1;
        }
    return 0;
}

static int render_opt(const char *cmd, int c, const char *arg, rt_render_opts *o, const char **tracer)
{
    long v;
    uint64_t u;
    switch (c) {
    case 't':
        if (!rt_tracer_find(arg)) {
            rt_cmd_error(cmd, "unknown tracer '%s' (%s)", arg, rt_tracer_names());
            return -1;
        }
        if (o->mode != RT_MODE_DEFAULT && !(rt_tracer_find(arg)->modes & (1u << o->mode))) {
            rt_cmd_error(cmd, "--mode: the %s tracer cannot run mode %s", arg, rt_render_mode_name(o->mode));
            return -1;
        }
        *tracer = arg;
        return 1;
    case RT_OPT_MODE: {
        int m = rt_render_mode_from_name(arg);
        const rt_tracer *tr = *tracer ? rt_tracer_find(*tracer) : rt_tracer_reference();
        if (m < 0) {
            rt_cmd_error(cmd, "--mode: '%s' is not raycast, shadow, whitted or path", arg);
            return -1;
        }
        if (tr && !(tr->modes & (1u << m))) {
            rt_cmd_error(cmd, "--mode: the %s tracer cannot run mode %s", tr->name, arg);
            return -1;
        }
        o->mode = m;
        return 1;
    }
    case RT_OPT_DEPTH:
        if (rt_cmd_parse_long(arg, 1, RT_DEPTH_MAX, &v) < 0) {
            rt_cmd_error(cmd, "--depth: '%s' is not in 1..%d", arg, RT_DEPTH_MAX);
            return -1;
        }
        o->depth = (int)v;
        return 1;
    case RT_OPT_ACCEL: {
        int a = rt_accel_from_name(arg);
        if (a < 0) {
            rt_cmd_error(cmd, "--accel: unknown structure '%s' (%s)", arg, rt_accel_names());
            return -1;
        }
        o->accel = a;
        return 1;
    }
    case RT_OPT_VB_SIZE:
        if (rt_parse_size(arg, &u) < 0 || u < RT_FB_REC_SIZE) {
            rt_cmd_error(cmd, "--vb-size: '%s' is not a size like 512M (>= 64)", arg);
            return -1;
        }
        o->vb_size = u;
        return 1;
    case RT_OPT_SPP:
        if (rt_cmd_parse_long(arg, 1, RT_SPP_MAX, &v) < 0) {
            rt_cmd_error(cmd, "--spp: '%s' is not in 1..%d", arg, RT_SPP_MAX);
            return -1;
        }
        o->spp = (int)v;
        return 1;
    case RT_OPT_BOUNCES:
        if (rt_cmd_parse_long(arg, 0, RT_BOUNCES_MAX, &v) < 0) {
            rt_cmd_error(cmd, "--bounces: '%s' is not in 0..%d", arg, RT_BOUNCES_MAX);
            return -1;
        }
        o->bounces = (int)v;
        return 1;
    case RT_OPT_GRID_MIN:
        if (rt_cmd_parse_long(arg, 1, RT_GRID_MAX_CELLS, &v) < 0) {
            rt_cmd_error(cmd, "--grid-min: '%s' is not in 1..%u (the grid holds at most %u cells)", arg,
                         (unsigned)RT_GRID_MAX_CELLS, (unsigned)RT_GRID_MAX_CELLS);
            return -1;
        }
        o->grid_min = (uint32_t)v;
        return 1;
    case RT_OPT_ORACLE:
        if (!strcmp(arg, "naive")) o->oracle = RT_ORACLE_NAIVE;
        else if (!strcmp(arg, "threshold")) o->oracle = RT_ORACLE_THRESHOLD;
        else {
            rt_cmd_error(cmd, "--oracle: '%s' is not naive or threshold", arg);
            return -1;
        }
        return 1;
    case RT_OPT_GRID_DENSITY: {
        char *end;
        double f = strtod(arg, &end);
        if (end == arg || *end || !(f > 0) || f > RT_GRID_DENSITY_MAX) {
            rt_cmd_error(cmd, "--grid-density: '%s' is not in (0, %d] (cells per triangle)", arg, RT_GRID_DENSITY_MAX);
            return -1;
        }
        o->grid_density = f;
        return 1;
    }
    case RT_OPT_RECORD_STORES:
        if ((v = rt_render_rstores_from_name(arg)) < 0) {
            rt_cmd_error(cmd, "--record-stores: '%s' is not non-temporal or write-allocate", arg);
            return -1;
        }
        o->rstores = (int)v;
        return 1;
    case RT_OPT_ORACLE_FRACTION: {
        double f;
        if (rt_cmd_parse_double(arg, &f) < 0 || !(f > 0) || f > 1) {
            rt_cmd_error(cmd, "--oracle-fraction: '%s' is not in (0, 1]", arg);
            return -1;
        }
        o->oracle_frac = f;
        return 1;
    }
    case RT_OPT_UNROLL: {
        char buf[64], *comma;
        long t, i;
        snprintf(buf, sizeof buf, "%s", arg);
        if (!(comma = strchr(buf, ',')) || (*comma = 0, rt_cmd_parse_long(buf, 1, 1 << 20, &t) < 0) ||
            rt_cmd_parse_long(comma + 1, 1, 1 << 20, &i) < 0) {
            rt_cmd_error(cmd, "--unroll: '%s' is not T,I with both in 1..1048576", arg);
            return -1;
        }
        o->unroll_t = (int)t;
        o->unroll_i = (int)i;
        return 1;
    }
    case RT_OPT_UNROLL_SUPPRESS:
        o->unroll_suppress = 1;
        return 1;
    case RT_OPT_LOOK_AT: {
        float f[9];
        int n = parse_floats(arg, f, 9);
        if (n != 6 && n != 9) {
            rt_cmd_error(cmd, "--look-at: '%s' is not EX,EY,EZ,AX,AY,AZ[,UX,UY,UZ] (numbers within 1e30)", arg);
            return -1;
        }
        rt_vec3 d = rt_v3(f[3] - f[0], f[4] - f[1], f[5] - f[2]);
        rt_vec3 up = n == 9 ? rt_v3(f[6], f[7], f[8]) : rt_v3(0, 0, 1), x = rt_cross(d, up);
        if (!(rt_dot(d, d) > 0) || (n == 9 && !(rt_dot(x, x) > 0))) {
            rt_cmd_error(cmd, "--look-at: '%s': the eye must differ from the point looked at, and up must not be zero "
                              "or along the view direction", arg);
            return -1;
        }
        o->view.look = 1;
        o->view.up_set = n == 9;
        memcpy(o->view.eye, f, sizeof o->view.eye);
        memcpy(o->view.at, f + 3, sizeof o->view.at);
        if (n == 9) memcpy(o->view.up, f + 6, sizeof o->view.up);
        return 1;
    }
    case RT_OPT_FOV: {
        float f;
        if (parse_floats(arg, &f, 1) != 1 || !(f > 0 && f < 180)) {
            rt_cmd_error(cmd, "--fov: '%s' is not a vertical field of view in (0, 180) degrees", arg);
            return -1;
        }
        o->view.fov = f;
        return 1;
    }
    case RT_OPT_LIGHT: {
        float f[4] = {0, 0, 0, 0};
        int n = parse_floats(arg, f, 4);
        if (n != 3 && n != 4) {
            rt_cmd_error(cmd, "--light: '%s' is not X,Y,Z[,POWER] (numbers within 1e30)", arg);
            return -1;
        }
        if (n == 4 && !(f[3] > 0)) {
            rt_cmd_error(cmd, "--light: power '%g' is not positive", (double)f[3]);
            return -1;
        }
        if (o->view.nlights == RT_NLIGHTS) {
            rt_cmd_error(cmd, "--light: at most %d lights (a scene has %d)", RT_NLIGHTS, RT_NLIGHTS);
            return -1;
        }
        memcpy(o->view.light[o->view.nlights++], f, sizeof f);
        return 1;
    }
    case RT_OPT_TREELET_TRIS:
        o->treelet_tris = 1;
        return 1;
    case RT_OPT_RAY_WINDOW:
        if (!strcmp(arg, "all")) {
            o->ray_window = 0;
            return 1;
        }
        if (rt_parse_size(arg, &u) < 0 || u < 1 || u > UINT32_MAX) {
            rt_cmd_error(cmd, "--ray-window: '%s' is not a ray count like 64K (>= 1) or all", arg);
            return -1;
        }
        o->ray_window = (uint32_t)u;
        return 1;
    case 'W':
    case 'H':
        if (rt_cmd_parse_long(arg, 1, 65536, &v) < 0) {
            rt_cmd_error(cmd, "-%c: '%s' is not an image size in 1..65536", c, arg);
            return -1;
        }
        if (c == 'W') o->W = (int)v; else o->H = (int)v;
        o->film &= c == 'W' ? ~RT_FILM_W : ~RT_FILM_H; /* given: not from the scene's Film */
        return 1;
    case RT_OPT_LIGHTS:
        if (rt_parse_lights(arg, &o->lights) < 0) {
            rt_cmd_error(cmd, "--lights: '%s' is not all, none or a list like 0,2 (indices 0..31)", arg);
            return -1;
        }
        o->lights_all = !strcmp(arg, "all");
        return 1;
    case RT_OPT_LIGHT_SAMPLES:
        if (rt_cmd_parse_long(arg, 1, RT_LIGHT_SAMPLES_MAX, &v) < 0) {
            rt_cmd_error(cmd, "--light-samples: '%s' is not a sample count in 1..%d", arg, RT_LIGHT_SAMPLES_MAX);
            return -1;
        }
        o->light_samples = (uint32_t)v;
        return 1;
    case RT_OPT_CACHE_SIZE:
        if (rt_parse_size(arg, &u) < 0 || u < 64) {
            rt_cmd_error(cmd, "--cache-size: '%s' is not a size like 64K (>= 64)", arg);
            return -1;
        }
        o->sched_size = u;
        return 1;
    case RT_OPT_GMAX:
        if (rt_parse_size(arg, &u) < 0 || u == 0) {
            rt_cmd_error(cmd, "--gmax: '%s' is not a positive byte count", arg);
            return -1;
        }
        o->gmax = u;
        return 1;
    case RT_OPT_PACKET:
        if (rt_cmd_parse_long(arg, 1, 256, &v) < 0) {
            rt_cmd_error(cmd, "--packet: '%s' is not in 1..256", arg);
            return -1;
        }
        o->packet = (int)v;
        return 1;
    case RT_OPT_QORDER:
        if (!strcmp(arg, "fullest")) o->qorder = RT_QORDER_FULLEST;
        else if (!strcmp(arg, "tree")) o->qorder = RT_QORDER_TREE;
        else {
            rt_cmd_error(cmd, "--qorder: '%s' is not fullest or tree", arg);
            return -1;
        }
        return 1;
    case RT_OPT_HIT_RULE:
        if ((v = rt_render_hit_rule_from_name(arg)) < 0) {
            rt_cmd_error(cmd, "--hit-rule: '%s' is not exact or first", arg);
            return -1;
        }
        o->hit_rule = (int)v;
        return 1;
    case RT_OPT_QP_MEASURE:
        if ((v = rt_render_qp_measure_from_name(arg)) < 0) {
            rt_cmd_error(cmd, "--qp-measure: '%s' is not all or triangles", arg);
            return -1;
        }
        o->qp_measure = (int)v;
        return 1;
    case RT_OPT_THREADS:
        if (rt_cmd_parse_long(arg, 1, 1024, &v) < 0) {
            rt_cmd_error(cmd, "--threads: '%s' is not in 1..1024", arg);
            return -1;
        }
        o->threads = (int)v;
        return 1;
    case RT_OPT_SUBSAMPLE: {
        char buf[64], *colon;
        long t = 8;
        snprintf(buf, sizeof buf, "%s", arg);
        if ((colon = strchr(buf, ':'))) {
            *colon = 0;
            if (rt_cmd_parse_long(colon + 1, 1, 4096, &t) < 0) {
                rt_cmd_error(cmd, "--subsample: tile '%s' is not in 1..4096", colon + 1);
                return -1;
            }
        }
        if (rt_cmd_parse_long(buf, 1, 1L << 20, &v) < 0) {
            rt_cmd_error(cmd, "--subsample: '%s' is not K or K:TILE with K in 1..1048576", arg);
            return -1;
        }
        o->subsample = (uint32_t)v;
        o->subtile = (int)t;
        return 1;
    }
    case RT_OPT_LAYOUT:
        if ((v = rt_render_geom_from_name(arg)) < 0) {
            rt_cmd_error(cmd, "--layout: '%s' is not compact, mesh, pbrt or pbrt64", arg);
            return -1;
        }
        o->geom = (int)v;
        return 1;
    case RT_OPT_QUEUE_STORES:
        if ((v = rt_render_qstores_from_name(arg)) < 0) {
            rt_cmd_error(cmd, "--queue-stores: '%s' is not write-allocate or non-temporal", arg);
            return -1;
        }
        if (!strcmp(arg, "stream"))
            fprintf(stderr, "raytraffic %s: note: --queue-stores stream is now spelled non-temporal\n", cmd);
        o->qstores = (int)v;
        return 1;
    default:
        return 0;
    }
}

/* The tracer-specific option behind a front-end option code, or -1. */
static int given_id(int c)
{
    switch (c) {
    case RT_OPT_PACKET: return RT_RO_PACKET;
    case RT_OPT_CACHE_SIZE: return RT_RO_CACHE_SIZE;
    case RT_OPT_GMAX: return RT_RO_GMAX;
    case RT_OPT_QORDER: return RT_RO_QORDER;
    case RT_OPT_HIT_RULE: return RT_RO_HIT_RULE;
    case RT_OPT_QP_MEASURE: return RT_RO_QP_MEASURE;
    case RT_OPT_THREADS: return RT_RO_THREADS;
    case RT_OPT_QUEUE_STORES: return RT_RO_QUEUE_STORES;
    case RT_OPT_GRID_MIN: return RT_RO_GRID_MIN;
    case RT_OPT_VB_SIZE: return RT_RO_VB_SIZE;
    case RT_OPT_ORACLE: return RT_RO_ORACLE;
    case RT_OPT_ORACLE_FRACTION: return RT_RO_ORACLE_FRACTION;
    case RT_OPT_GRID_DENSITY: return RT_RO_GRID_DENSITY;
    case RT_OPT_RECORD_STORES: return RT_RO_RECORD_STORES;
    case RT_OPT_UNROLL: return RT_RO_UNROLL;
    case RT_OPT_UNROLL_SUPPRESS: return RT_RO_UNROLL_SUPPRESS;
    case RT_OPT_ACCEL: return RT_RO_ACCEL;
    case RT_OPT_TREELET_TRIS: return RT_RO_TREELET_TRIS;
    case RT_OPT_RAY_WINDOW: return RT_RO_RAY_WINDOW;
    default: return -1;
    }
}

/* The option parsed as render_opt does; an accepted option of one tracer
 * group is remembered in o->given, so the tracer can refuse it. */
int rt_cmd_render_opt(const char *cmd, int c, const char *arg, rt_render_opts *o, const char **tracer)
{
    int r = render_opt(cmd, c, arg, o, tracer), id = given_id(c);
    if (r > 0 && id >= 0) o->given |= 1u << id;
    return r;
}

int rt_cmd_check_tracer_opts(const char *cmd, const char *tracer, const rt_render_opts *o)
{
    rt_err e = {0};
    const rt_tracer *tr = tracer ? rt_tracer_find(tracer) : rt_tracer_reference();
    if (!tr) {
        rt_cmd_error(cmd, "unknown tracer '%s' (%s)", tracer, rt_tracer_names());
        return -1;
    }
    if (rt_tracer_check_given(tr, o, &e) < 0 || rt_tracer_check_opts(tr, o, &e) < 0) {
        rt_cmd_error(cmd, "%s", e.msg);
        return -1;
    }
    return 0;
}

int rt_cmd_parse_rate(const char *s, double *out)
{
    char buf[64];
    double v, q = 1;
    if (!s || strlen(s) >= sizeof buf) return -1;
    snprintf(buf, sizeof buf, "%s", s);
    char *slash = strchr(buf, '/');
    if (slash) {
        *slash = 0;
        if (rt_cmd_parse_double(slash + 1, &q) < 0 || !(q >= 1)) return -1;
    }
    if (rt_cmd_parse_double(buf, &v) < 0) return -1;
    v /= q;
    if (!(v > 0) || v > 1) return -1;
    *out = v;
    return 0;
}

int rt_cmd_parse_line(const char *cmd, const char *arg, uint32_t *line)
{
    uint64_t v;
    if (rt_parse_size(arg, &v) < 0 || v == 0 || v > (1u << 20)) {
        rt_cmd_error(cmd, "--line: '%s' is not a line size in 1..1M bytes", arg);
        return -1;
    }
    *line = (uint32_t)v;
    return 0;
}

void rt_cmd_json_str(FILE *f, const char *s)
{
    fputc('"', f);
    for (; *s; s++) {
        unsigned char c = (unsigned char)*s;
        if (c == '"' || c == '\\') fprintf(f, "\\%c", c);
        else if (c < 0x20) fprintf(f, "\\u%04x", c);
        else fputc(c, f);
    }
    fputc('"', f);
}

const char *rt_cmd_scene_material(const char *cmd, const char *spec, const char *name, char *buf, size_t n)
{
    if (!name) return spec;
    int known = 0;
    for (int i = 0; rt_material_preset_names[i]; i++) known |= !strcmp(name, rt_material_preset_names[i]);
    if (!known) {
        rt_cmd_error(cmd, "--material: unknown preset '%s' (diffuse, mirror, glass)", name);
        return NULL;
    }
    /* a built-in name or a mesh path, then ':' and k=v parameters */
    const char *colon = strrchr(spec, ':');
    const char *slash = strrchr(spec, '/');
    int has_params = colon && (!slash || colon > slash) && strchr(colon, '=');
    if ((size_t)snprintf(buf, n, "%s%smaterial=%s", spec, has_params ? "," : ":", name) >= n) {
        rt_cmd_error(cmd, "--material: scene spec too long");
        return NULL;
    }
    return buf;
}
