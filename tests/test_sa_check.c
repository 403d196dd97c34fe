/*
 * test_sa_check.c -- the set-associative simulator's checker (rt_sa_check,
 * cachesim/setassoc.c) can fail: on a real 4-way cache filled by a random
 * stream it passes; each corrupted copy (a set over-full, a broken prev
 * link, a line in the wrong set, a slot the hash table does not hold, a
 * dirty line in a write-through cache, counters that do not add up) is
 * rejected with a message naming what broke; restored, it passes again.
 * The simulator file is compiled into this test to reach its state.
 */
#include "../cachesim/setassoc.c"

#include "check.h"

static void expect(const rt_sa *c, const char *needle, const char *what)
{
    rt_err e = {0};
    int rc = rt_sa_check(c, &e);
    CHECK(rc < 0, "%s: the checker accepted it", what);
    CHECK(rc >= 0 || strstr(e.msg, needle), "%s: message '%s' lacks '%s'", what, e.msg, needle);
}

static void fill(rt_sa *c, uint64_t seed, int n)
{
    rt_access a[256];
    uint64_t x = seed;
    for (int done = 0; done < n; done += 256) {
        for (int i = 0; i < 256; i++) {
            x = x * 6364136223846793005ull + 1442695040888963407ull;
            a[i].addr = ((x >> 33) % 300) * 64;
            a[i].size = 8;
            a[i].write = (x >> 20) % 4 == 0;
            a[i].cls = (uint8_t)((x >> 24) % 3);
            a[i].gen = 0;
        }
        rt_sa_put(c, a, 256);
    }
}

int main(void)
{
    rt_err e = {0};
    rt_sa *c = rt_sa_new(4096, 64, 4, 0, 0, NULL, 1, &e);
    CHECK(c != NULL, "rt_sa_new: %s", e.msg);
    if (!c) return 1;
    fill(c, 3, 4096);
    CHECK(rt_sa_check(c, &e) == 0, "a real cache: %s", e.msg);
    saset *st = &c->sets[1];
    CHECK(st->used == c->assoc && st->head != NIL, "set 1 is full (%u of %u ways)", st->used, c->assoc);

    uint32_t u = st->used;
    st->used = c->assoc + 1;
    expect(c, "over-full", "a set holding more lines than ways");
    st->used = u;

    uint32_t x = c->slots[st->head].next, save = c->slots[x].prev;
    c->slots[x].prev = x;
    expect(c, "broken prev link", "a prev link to itself");
    c->slots[x].prev = save;

    uint64_t line = c->slots[x].line;
    c->slots[x].line = line + 1; /* the next set's line */
    expect(c, "wrong set", "a line in another set's ways");
    c->slots[x].line = line + c->nsets; /* right set, but not in the table */
    expect(c, "missing from hash", "a line the hash table does not hold");
    c->slots[x].line = line;

    uint64_t acc = c->acc[0];
    c->acc[0] = 0;
    expect(c, "inconsistent", "more misses than accesses");
    c->acc[0] = acc;

    CHECK(rt_sa_check(c, &e) == 0, "restored: %s", e.msg);
    fill(c, 5, 1024);
    CHECK(rt_sa_check(c, &e) == 0, "after more references: %s", e.msg);
    rt_sa_free(c);

    /* write-through: no line may be dirty */
    c = rt_sa_new(4096, 64, 4, 1, 0, NULL, 1, &e);
    CHECK(c != NULL, "rt_sa_new write-through: %s", e.msg);
    if (!c) return 1;
    fill(c, 9, 1024);
    CHECK(rt_sa_check(c, &e) == 0, "write-through: %s", e.msg);
    c->slots[c->sets[0].head].dirty = 1;
    expect(c, "dirty line in write-through", "a dirty line in a write-through cache");
    c->slots[c->sets[0].head].dirty = 0;
    CHECK(rt_sa_check(c, &e) == 0, "write-through restored: %s", e.msg);
    rt_sa_free(c);
    return failures ? 1 : 0;
}
