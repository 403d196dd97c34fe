/*
 * tracer.c -- the tracer registry. What the tracers share lives beside it,
 * one job per file: options.c, pixels.c (subsampling and order), camera.c,
 * shade.c (shading rule and shadow rays), regions.c (geometry regions and
 * the recording traversal), stats.c.
 */
#include "tracer.h"

#include <string.h>

extern const rt_tracer rt_tracer_recursive;
extern const rt_tracer rt_tracer_packet;
extern const rt_tracer rt_tracer_dynamic;
extern const rt_tracer rt_tracer_stream_branching;
extern const rt_tracer rt_tracer_stream_multipass;
extern const rt_tracer rt_tracer_feedback;

const rt_tracer *const rt_tracer_all[] = {
    &rt_tracer_recursive,
    &rt_tracer_packet,
    &rt_tracer_dynamic,
    &rt_tracer_stream_branching,
    &rt_tracer_stream_multipass,
    &rt_tracer_feedback,
    NULL,
};

const rt_tracer *rt_tracer_find(const char *name)
{
    for (int i = 0; rt_tracer_all[i]; i++)
        if (!strcmp(rt_tracer_all[i]->name, name)) return rt_tracer_all[i];
    return NULL;
}
