/*
 * fuzz_scene.h -- the checks the OBJ and PLY fuzz targets share: a loaded
 * scene has triangles, finite vertices inside its bounds and inside the
 * coordinate range (rt_scene_check_range), a shading record per triangle;
 * a refused file has a message.
 */
#ifndef RT_FUZZ_SCENE_H
#define RT_FUZZ_SCENE_H

#include "fuzz.h"
#include "scene.h"

#include <math.h>

static inline void rt_fuzz_check_scene(rt_scene *s, const rt_err *e)
{
    if (!s) {
        if (!e->msg[0]) rt_fuzz_fail("refused without a message");
        return;
    }
    if (s->ntri == 0 || !s->tri || !s->shade) rt_fuzz_fail("scene with %u triangles", s->ntri);
    const rt_bounds *b = &s->bounds;
    for (uint32_t i = 0; i < s->ntri; i++)
        for (int k = 0; k < 3; k++) {
            rt_vec3 p = s->tri[i].p[k];
            if (!isfinite(p.x) || !isfinite(p.y) || !isfinite(p.z)) rt_fuzz_fail("triangle %u: not finite", i);
            if (p.x < b->lo.x || p.x > b->hi.x || p.y < b->lo.y || p.y > b->hi.y || p.z < b->lo.z || p.z > b->hi.z)
                rt_fuzz_fail("triangle %u: vertex outside the bounds", i);
        }
    rt_err e2 = {0};
    if (rt_scene_check_range(s, "fuzz", &e2) < 0) rt_fuzz_fail("loaded scene out of range: %s", e2.msg);
    (void)rt_scene_hash(s);
    rt_fuzz_accepted = 1;
    rt_scene_free(s);
}

#endif
