/*
 * fuzz_pbrt.c -- fuzz target for the pbrt scene loader (rt_scene_load_pbrt,
 * src/scene_pbrt.c). The input is the top-level file; includes and PLY
 * files it names resolve against the scratch file's folder and are refused
 * unless they stay inside it. The scene is capped at maxtri=200000 so a
 * short input cannot ask for gigabytes of triangles (subdivision levels,
 * instances). Checks: those of fuzz_scene.h, plus a loaded scene's image
 * size (0 or 1..65536), instancing counts that add up, a warning that
 * fits its buffer, and the two-level instancing structure (accel/inst.c)
 * built from its instance records and passing its checker.
 */
#include "scene_load.h"
#include "fuzz_scene.h"
#include "inst.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    rt_err e = {0};
    rt_scene *s = rt_scene_load_pbrt(rt_fuzz_file(data, size), "maxtri=200000", &e);
    if (s) {
        if (s->film_w < 0 || s->film_w > 65536 || s->film_h < 0 || s->film_h > 65536 || (!s->film_w != !s->film_h))
            rt_fuzz_fail("film %dx%d", s->film_w, s->film_h);
        if (s->ntri > 200000) rt_fuzz_fail("%u triangles above maxtri", s->ntri);
        if (s->ninst && (s->ntri_inst > s->ntri || s->ntri_unique > s->ntri))
            rt_fuzz_fail("instancing counts %u unique, %u instanced of %u", s->ntri_unique, s->ntri_inst, s->ntri);
        if (!memchr(s->warning, 0, sizeof s->warning)) rt_fuzz_fail("warning not terminated");
        if (!(s->cam.fovy_deg > 0 && s->cam.fovy_deg < 180)) rt_fuzz_fail("fovy %g", (double)s->cam.fovy_deg);
        if (s->nirec) {
            rt_err ie = {0};
            rt_inst *I = rt_inst_build(s, &ie);
            if (!I) rt_fuzz_fail("two-level build: %s", ie.msg);
            if (rt_inst_check(I, s, &ie) < 0) rt_fuzz_fail("two-level check: %s", ie.msg);
            rt_inst_free(I);
        }
    }
    rt_fuzz_check_scene(s, &e);
    return 0;
}
