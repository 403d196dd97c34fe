/*
 * bvh_avx.c -- the bvh8 fast walk of bvh_walk.h (recording or not) compiled with AVX.
 * Only this file is built with -mavx (configure checks the compiler takes
 * it); bvh.c calls it only for a tree whose fast_avx is set, which the
 * build sets only on a processor with AVX, so the rest of the toolkit runs
 * anywhere.
 */
#include "config.h"

#include "bvh_walk.h"

#if !defined(__AVX__)
#error "bvh_avx.c must be compiled with -mavx"
#endif

int rt_bvh_walk8_avx(rt_bvh_trav *tv, const rt_ray *r, rt_hit *h, int any)
{
    return any ? walk_fast_for(tv, r, NULL, 1, 8) : walk_fast_for(tv, r, h, 0, 8);
}
