/*
 * test_noembree.c -- bench/embree_bench.c compiled without Embree
 * (RT_NO_EMBREE), as on a machine without libembree-dev: it builds, says
 * it was not built with Embree, and its entry points fail with that
 * message instead of measuring anything.
 */
#include "check.h"
#include "bench.h"

#include <stdio.h>
#include <string.h>

int main(void)
{
    rt_embree_result r;
    rt_err e = {0};
    CHECK(rt_embree_built() == 0, "built with Embree although RT_NO_EMBREE");
    CHECK(rt_embree_bench(NULL, 4, 4, &r, &e) == -1 && strstr(e.msg, "not built"),
          "rt_embree_bench without Embree: '%s'", e.msg);
    e.msg[0] = 0;
    CHECK(rt_embree_bench_reps(NULL, 4, 4, 3, &r, &e) == -1 && strstr(e.msg, "not built"),
          "rt_embree_bench_reps without Embree: '%s'", e.msg);
    double v[4] = {3, 1, 4, 2};
    CHECK(rt_bench_median(v, 4) == 2.5, "median of 1..4: %g", rt_bench_median(v, 4));
    if (failures) {
        fprintf(stderr, "test_noembree: %d failure(s)\n", failures);
        return 1;
    }
    printf("test_noembree: ok\n");
    return 0;
}
