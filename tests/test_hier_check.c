/*
 * test_hier_check.c -- the hierarchy's checker (rt_hier_check, H1-H3 of
 * cachesim/hier.c) can fail: on a real two-level hierarchy fed a random
 * stream it passes; a level that no longer feeds the next (H2) and a last
 * level that saw references its upper level never sent (H3) are rejected,
 * naming the levels. The hierarchy file is compiled into this test to
 * reach its levels.
 */
#include "../cachesim/hier.c"

#include "check.h"

static void stream(rt_access *a, int n, uint64_t seed)
{
    uint64_t x = seed;
    for (int i = 0; i < n; i++) {
        x = x * 6364136223846793005ull + 1442695040888963407ull;
        a[i].addr = ((x >> 33) % 2000) * 64;
        a[i].size = 8;
        a[i].write = (x >> 20) % 5 == 0;
        a[i].cls = (uint8_t)((x >> 24) % 3);
        a[i].gen = 0;
    }
}

int main(void)
{
    rt_sim_config base;
    rt_sim_config_default(&base);
    rt_hier_config hc;
    rt_err e = {0};
    CHECK(rt_hier_parse("L1=4K/4/64/lru,LLC=1K-64K/full/64/lru", &base, &hc, &e) == 0, "parse: %s", e.msg);
    rt_hier *h = rt_hier_new(&hc, &e);
    CHECK(h != NULL, "rt_hier_new: %s", e.msg);
    if (!h) return 1;
    static rt_access a[20000];
    stream(a, 20000, 5);
    CHECK(rt_hier_put(h, a, 20000) == 0, "put");
    CHECK(rt_hier_check(h, &e) == 0, "a real hierarchy: %s", e.msg);

    /* H2: the upper level no longer feeds the last */
    h->cfg.level[0].feeds_below = 0;
    CHECK(rt_hier_check(h, &e) < 0 && strstr(e.msg, "does not feed"), "H2 not caught: '%s'", e.msg);
    h->cfg.level[0].feeds_below = 1;
    CHECK(rt_hier_check(h, &e) == 0, "restored: %s", e.msg);

    /* H3: references reach the last level around the first */
    CHECK(rt_sim_put(h->lv[1], a, 10) == 0, "put below");
    e.msg[0] = 0;
    CHECK(rt_hier_check(h, &e) < 0 && strstr(e.msg, "saw") && strstr(e.msg, "sent"), "H3 not caught: '%s'", e.msg);
    rt_hier_free(h);
    return failures ? 1 : 0;
}
