/*
 * fuzz_ply.c -- fuzz target for the PLY loader (rt_scene_load_ply,
 * src/scene_ply.c). The input is the file; the checks are in fuzz_scene.h.
 */
#include "scene_load.h"
#include "fuzz_scene.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    rt_err e = {0};
    rt_fuzz_check_scene(rt_scene_load_ply(rt_fuzz_file(data, size), &e), &e);
    return 0;
}
