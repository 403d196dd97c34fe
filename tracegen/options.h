/*
 * options.h -- render options shared by every tracer (prefix rt_render_).
 *
 * One struct carries what a run is asked to do: image size, lights, and the
 * per-tracer knobs (packet edge, the dynamic scheduler's cache budget and
 * queue order, pixel subsampling). A tracer reads only the fields it needs;
 * the job records the ones that shaped its run (run.c, rt_job_meta).
 */
#ifndef RT_OPTIONS_H
#define RT_OPTIONS_H

#include "rt.h"

#include <stdint.h>

typedef enum rt_qorder {
    RT_QORDER_FULLEST = 0, /* dynamic: process the fullest queue next */
    RT_QORDER_TREE = 1     /* dynamic: queue points in tree (depth-first) order */
} rt_qorder;

typedef struct rt_render_opts {
    int W, H;            /* image size */
    unsigned lights;     /* bit i set: light i enabled */
    int packet;          /* packet edge in pixels (packet tracer), 8 */
    uint64_t sched_size; /* dynamic: cache size the schedule targets (bytes) */
    uint64_t gmax;       /* dynamic: explicit geometry budget, 0 = derive */
    int qorder;          /* dynamic: rt_qorder */
    int threads;         /* dynamic: modeled threads (ray buffer = 2 rays each) */
    uint32_t subsample;  /* reduced experiment: trace 1 in K tiles (1 = all) */
    int subtile;         /* subsampling tile edge in pixels (default 8) */
} rt_render_opts;

/* Fills o with the defaults: 512 x 512, no lights, packet 8, a 64 KiB
 * schedule, fullest-first queues, 4 threads, no subsampling (tile 8). */
void rt_render_default_opts(rt_render_opts *o);

/* Parses "all", "none" (or ""), or a comma list of light indices "0,2" into
 * a light mask. 0, or -1 on a malformed list (*mask untouched). */
int rt_render_parse_lights(const char *s, unsigned *mask);

/* Former name, kept for the front end and its tests. */
static inline int rt_parse_lights(const char *s, unsigned *mask) { return rt_render_parse_lights(s, mask); }

#endif
