/*
 * repl_rrip.c -- re-reference interval prediction (engine.h): SRRIP and
 * BRRIP of Jaleel, Theobald, Steely & Emer, "High Performance Cache
 * Replacement Using Re-Reference Interval Prediction (RRIP)", ISCA 2010,
 * with M = 2 bits per line: a re-reference prediction value (RRPV) 0..3,
 * 3 = "re-referenced in the distant future".
 *
 * State: way[w] = the RRPV of way w.
 *   hit        RRPV = 0 (hit priority, SRRIP-HP: the paper's better variant);
 *   victim     the first way (lowest index) with RRPV 3; if none, every RRPV
 *              of the set is raised by the same amount until the largest is
 *              3 (the paper's "increment all and repeat", done at once);
 *   fill       SRRIP: RRPV = 2 (a long re-reference interval);
 *              BRRIP: RRPV = 3 (distant), except with probability 1/32
 *              (epsilon of the paper) RRPV = 2; one draw from the cache's
 *              random stream per fill (seeded, deterministic).
 * Invariant (check): every filled way's RRPV is 0..3.
 * Neither is a stack algorithm (the victim depends on the set's size):
 * simulated per size. Fully associative caches scan all ways per miss.
 */
#include "engine.h"

#define RRPV_MAX 3u

static void rrip_hit(rt_repl_set *s, uint32_t w) { s->way[w] = 0; }

static void srrip_fill(rt_repl_set *s, uint32_t w) { s->way[w] = RRPV_MAX - 1; }

static void brrip_fill(rt_repl_set *s, uint32_t w)
{
    s->way[w] = rt_repl_rand(s->rng, 32) == 0 ? RRPV_MAX - 1 : RRPV_MAX;
}

static uint32_t rrip_victim(rt_repl_set *s)
{
    uint32_t top = 0;
    for (uint32_t w = 0; w < s->ways; w++) {
        if (s->way[w] == RRPV_MAX) return w;
        if (s->way[w] > top) top = s->way[w];
    }
    uint32_t add = RRPV_MAX - top, first = 0;
    for (uint32_t w = s->ways; w-- > 0;) {
        s->way[w] += add;
        if (s->way[w] == RRPV_MAX) first = w;
    }
    return first;
}

static int rrip_check(const rt_repl_set *s, uint32_t used, rt_err *e)
{
    for (uint32_t w = 0; w < used; w++)
        if (s->way[w] > RRPV_MAX) return rt_errf(e, "rrip: way %u has RRPV %u", w, s->way[w]);
    return 0;
}

const rt_repl_ops rt_repl_srrip = {
    .name = "srrip",
    .hit = rrip_hit,
    .fill = srrip_fill,
    .victim = rrip_victim,
    .check = rrip_check,
};

const rt_repl_ops rt_repl_brrip = {
    .name = "brrip",
    .random = 1,
    .hit = rrip_hit,
    .fill = brrip_fill,
    .victim = rrip_victim,
    .check = rrip_check,
};
