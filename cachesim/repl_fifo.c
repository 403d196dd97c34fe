/*
 * repl_fifo.c -- first-in first-out replacement (engine.h): a full set
 * evicts the line that was placed in it longest ago; hits change nothing.
 *
 * State: set[0] is the hand, the way filled longest ago. Ways fill in
 * order 0, 1, ..., so the oldest is way 0 and the hand starts there; each
 * eviction takes the hand's way (which then holds the newest line) and
 * moves the hand to the next way, cyclically.
 * Invariant (check): hand < ways, and 0 while the set is not yet full.
 * FIFO is not a stack algorithm (Belady's anomaly), so it runs per size.
 */
#include "engine.h"

static void fifo_hit(rt_repl_set *s, uint32_t w)
{
    (void)s;
    (void)w;
}

static void fifo_fill(rt_repl_set *s, uint32_t w)
{
    (void)s;
    (void)w;
}

static uint32_t fifo_victim(rt_repl_set *s)
{
    uint32_t w = s->set[0];
    s->set[0] = w + 1 == s->ways ? 0 : w + 1;
    return w;
}

static int fifo_check(const rt_repl_set *s, uint32_t used, rt_err *e)
{
    if (s->set[0] >= s->ways || (used < s->ways && s->set[0] != 0))
        return rt_errf(e, "fifo: hand %u in a set of %u ways (%u filled)", s->set[0], s->ways, used);
    return 0;
}

const rt_repl_ops rt_repl_fifo = {
    .name = "fifo",
    .hit = fifo_hit,
    .fill = fifo_fill,
    .victim = fifo_victim,
    .check = fifo_check,
};
