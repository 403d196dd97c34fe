/*
 * fuzz_gz.c -- fuzz target for gzip input (src/scene_file.c): the input is
 * a scene file's bytes, gzip or not. The reader's contract is checked on
 * memory (content within the limit, NUL-terminated, a plain input handed
 * back unchanged, a refusal with a reason), then the same bytes go through
 * the PLY loader as a file, which tells gzip by content (fuzz_scene.h
 * checks the scene).
 */
#include "scene_file.h"
#include "scene_load.h"
#include "fuzz_scene.h"

#include <stdlib.h>
#include <string.h>

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    const uint64_t max = 1u << 20;
    char *out = NULL, why[200];
    size_t n = 0;
    int gz = 0;
    if (rt_sfile_read_mem(data, size, max, &out, &n, &gz, why, sizeof why) == 0) {
        if (n > max) rt_fuzz_fail("%zu bytes over the limit", n);
        if (out[n] != 0) rt_fuzz_fail("no NUL after the content");
        if (!gz && (n != size || memcmp(out, data, size))) rt_fuzz_fail("plain input changed");
        if (gz != (size >= 2 && data[0] == 0x1f && data[1] == 0x8b)) rt_fuzz_fail("gzip told wrongly");
        free(out);
    } else if (!why[0]) {
        rt_fuzz_fail("refused without a reason");
    }
    rt_err e = {0};
    uint64_t keep = rt_scene_max_bytes;
    rt_scene_max_bytes = max;
    rt_fuzz_check_scene(rt_scene_load_ply(rt_fuzz_file(data, size), &e), &e);
    rt_scene_max_bytes = keep;
    return 0;
}
