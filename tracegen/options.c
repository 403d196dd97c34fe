/* options.c -- defaults and parsing of the render options (see options.h). */
#include "options.h"
#include "grid.h"
#include "scene.h"

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
    o->queue_stats = 0;
    o->accel = RT_ACCEL_DEFAULT;
    o->vb_size = 0;
    o->grid_min = 0;
    o->oracle = RT_ORACLE_THRESHOLD;
    o->oracle_frac = 0.2;
    o->unroll_t = 1;
    o->unroll_i = 1;
    o->unroll_suppress = 0;
}

static const char *const geom_names[] = {"compact", "mesh"};
/* "non-temporal" was called "stream" before (still accepted: rt_render_
 * qstores_from_name; the run key keeps "queue_stores=stream" so databases
 * written before stay comparable). */
static const char *const qstores_names[] = {"write-allocate", "non-temporal"};

const char *rt_render_geom_name(int geom) { return geom >= 0 && geom <= RT_GEOM_MESH ? geom_names[geom] : NULL; }

int rt_render_geom_from_name(const char *name)
{
    for (int g = 0; g <= RT_GEOM_MESH; g++)
        if (!strcmp(name, geom_names[g])) return g;
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
    [RT_RO_THREADS] = {"--threads", RT_OPTG_SCHED},
    [RT_RO_QUEUE_STORES] = {"--queue-stores", RT_OPTG_QUEUES},
    [RT_RO_GRID_MIN] = {"--grid-min", RT_OPTG_GRID},
    [RT_RO_VB_SIZE] = {"--vb-size", RT_OPTG_VB},
    [RT_RO_ORACLE] = {"--oracle", RT_OPTG_ORACLE},
    [RT_RO_ORACLE_FRACTION] = {"--oracle-fraction", RT_OPTG_ORACLE},
    [RT_RO_UNROLL] = {"--unroll", RT_OPTG_ORACLE},
    [RT_RO_UNROLL_SUPPRESS] = {"--unroll-suppress", RT_OPTG_ORACLE},
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
    if (o->accel != RT_ACCEL_DEFAULT && !rt_accel_name(o->accel))
        return rt_errf(e, "--accel: unknown acceleration structure %d", o->accel);
    if (o->grid_min > RT_GRID_MAX_CELLS) /* 0 = the tracer's default */
        return rt_errf(e, "--grid-min: %u is not in 1..%u", (unsigned)o->grid_min, (unsigned)RT_GRID_MAX_CELLS);
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
        if (*p < '0' || *p >= '0' + RT_NLIGHTS) return -1;
        m |= 1u << (*p - '0');
        p++;
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
