/*
 * repl_random.c -- random replacement (engine.h): a full set evicts a way
 * drawn uniformly from the cache's random stream (rt_repl_rand, seeded
 * from rt_sim_config.seed: `sim --seed`), so a run is deterministic for a
 * seed. One draw per eviction, none on hits or on fills of free ways.
 * No state of its own, hence no invariant beyond the engine's. Not a stack
 * algorithm: simulated per size (each size draws the same stream).
 */
#include "engine.h"

static void rnd_hit(rt_repl_set *s, uint32_t w)
{
    (void)s;
    (void)w;
}

static void rnd_fill(rt_repl_set *s, uint32_t w)
{
    (void)s;
    (void)w;
}

static uint32_t rnd_victim(rt_repl_set *s) { return rt_repl_rand(s->rng, s->ways); }

const rt_repl_ops rt_repl_random = {
    .name = "random",
    .random = 1,
    .hit = rnd_hit,
    .fill = rnd_fill,
    .victim = rnd_victim,
};
