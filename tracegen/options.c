/* options.c -- defaults and parsing of the render options (see options.h). */
#include "options.h"
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
