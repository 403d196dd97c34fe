/*
 * check_scene.h -- building small scenes by hand in the tests: a grey
 * triangle appended, a scene finished, each exiting with the library's
 * message on failure (a test that cannot build its input cannot check
 * anything). Static inline, like check.h.
 */
#ifndef RT_CHECK_SCENE_H
#define RT_CHECK_SCENE_H

#include "scene.h"

#include <stdio.h>
#include <stdlib.h>

static const float check_grey[3] = {0.5f, 0.5f, 0.5f};

/* Appends the grey triangle abc to s. */
static inline void add(rt_scene *s, rt_vec3 a, rt_vec3 b, rt_vec3 c)
{
    rt_err e = {{0}};
    if (rt_scene_add_tri(s, a, b, c, check_grey, &e) < 0) {
        fprintf(stderr, "add_tri: %s\n", e.msg);
        exit(1);
    }
}

/* Computes s's bounds (rt_scene_finish). */
static inline void finish(rt_scene *s)
{
    rt_err e = {{0}};
    if (rt_scene_finish(s, &e) < 0) {
        fprintf(stderr, "finish: %s\n", e.msg);
        exit(1);
    }
}

#endif
