/*
 * repl_plru.c -- tree pseudo-LRU replacement (engine.h), as in the caches
 * of many processors: a binary tree over the ways (a power of two) whose
 * ways - 1 inner nodes each hold one bit pointing to the half that was used
 * less recently.
 *
 * State: set[1 .. ways-1] are the nodes in heap order (node k's children
 * are 2k and 2k+1; way w is leaf ways + w); set[0] is unused. A touch (hit
 * or fill) walks from the way's leaf to the root and points every node on
 * the way away from it (bit = 1: the victim is on the right). The victim
 * is found by following the bits from the root. With one way there is no
 * node and the victim is way 0.
 * Invariant (check): every node bit is 0 or 1.
 * PLRU is not a stack algorithm: simulated per size.
 */
#include "engine.h"

static void plru_touch(rt_repl_set *s, uint32_t w)
{
    for (uint32_t k = s->ways + w; k > 1; k >>= 1) s->set[k >> 1] = (k & 1) == 0; /* came from the left: point right */
}

static uint32_t plru_victim(rt_repl_set *s)
{
    uint32_t k = 1;
    while (k < s->ways) k = 2 * k + s->set[k];
    return k - s->ways;
}

static int plru_check(const rt_repl_set *s, uint32_t used, rt_err *e)
{
    (void)used;
    if (s->ways & (s->ways - 1)) return rt_errf(e, "plru: %u ways is not a power of two", s->ways);
    for (uint32_t k = 1; k < s->ways; k++)
        if (s->set[k] > 1) return rt_errf(e, "plru: node %u holds %u", k, s->set[k]);
    return 0;
}

const rt_repl_ops rt_repl_plru = {
    .name = "plru",
    .pow2_ways = 1,
    .hit = plru_touch,
    .fill = plru_touch,
    .victim = plru_victim,
    .check = plru_check,
};
