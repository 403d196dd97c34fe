/*
 * test_msim_check.c -- the stack simulator's checker (rt_msim_check, the
 * invariants of cachesim/msim.c's essay) can fail: on a real recency stack
 * filled by a random stream it passes; each corrupted copy (a broken prev
 * link, a cycle, a group order broken, a marker moved, a count off, a
 * dirty bit in a smaller cache, a stale hash slot, a write-back count above
 * the writes) is rejected with a message naming what broke; restored, it
 * passes again and the stream goes on. The simulator file is compiled into
 * this test so the test can reach its private state.
 */
#include "../cachesim/msim.c"

#include "check.h"

static void expect(const rt_msim *m, const char *needle, const char *what)
{
    rt_err e = {0};
    int rc = rt_msim_check(m, &e);
    CHECK(rc < 0, "%s: the checker accepted it", what);
    CHECK(rc >= 0 || strstr(e.msg, needle), "%s: message '%s' lacks '%s'", what, e.msg, needle);
}

static void fill(rt_msim *m, uint64_t seed, int n)
{
    rt_access a[256];
    uint64_t x = seed;
    for (int done = 0; done < n; done += 256) {
        for (int i = 0; i < 256; i++) {
            x = x * 6364136223846793005ull + 1442695040888963407ull;
            a[i].addr = ((x >> 33) % 400) * 64;
            a[i].size = 8;
            a[i].write = (x >> 20) % 4 == 0;
            a[i].cls = (uint8_t)((x >> 24) % 3);
            a[i].gen = 0;
        }
        CHECK(rt_msim_put(m, a, 256) == 0, "put");
    }
}

int main(void)
{
    const uint64_t sz[4] = {1024, 4096, 8192, 16384};
    rt_msim *m = rt_msim_new(sz, 4, 64, NULL);
    CHECK(m != NULL, "rt_msim_new");
    if (!m) return 1;
    fill(m, 7, 4096);
    rt_err e = {0};
    CHECK(rt_msim_check(m, &e) == 0, "a real stack: %s", e.msg);
    CHECK(m->nused > 32 && m->head != NIL, "the stream filled the stack (%u lines)", m->nused);

    /* the second node on the list, and the one after it */
    uint32_t a = m->nodes[m->head].next, b = m->nodes[a].next;

    uint32_t save = m->nodes[a].prev;
    m->nodes[a].prev = b;
    expect(m, "prev link broken", "a prev link pointing down");
    m->nodes[a].prev = save;

    save = m->nodes[b].next;
    m->nodes[b].next = m->head;
    expect(m, "prev link broken", "a next link back to the head (a cycle)");
    m->nodes[b].next = save;

    /* groups: the head is in group 0; put it in the last group */
    unsigned g = m->nodes[m->head].grp;
    m->nodes[m->head].grp = (unsigned)m->k - 1;
    expect(m, "group", "the head in the largest cache's group");
    m->nodes[m->head].grp = g;

    m->nodes[m->head].grp = (unsigned)m->k;
    expect(m, "group", "a group beyond k");
    m->nodes[m->head].grp = g;

    uint32_t mk = m->marker[0];
    m->marker[0] = m->head;
    expect(m, "marker 0", "a moved size marker");
    m->marker[0] = mk;

    m->cnt[1]++;
    expect(m, "group 1 has", "a group count off by one");
    m->cnt[1]--;

    /* a dirty bit for a cache smaller than the node's group */
    uint32_t deep = m->tail;
    unsigned dg = m->nodes[deep].grp;
    CHECK(dg > 0, "the tail sits below the smallest cache (group %u)", dg);
    uint32_t d = m->nodes[deep].dirty;
    m->nodes[deep].dirty |= 1u;
    if (dg > 0) expect(m, "dirty in a smaller cache", "a dirty bit in a smaller cache");
    m->nodes[deep].dirty = d;

    /* a hash slot naming the wrong line */
    uint64_t line = m->lines[a];
    m->lines[a] = line + 100000;
    expect(m, "hash", "a node whose line the table does not hold");
    m->lines[a] = line;

    uint64_t wb = m->wb[0][0];
    m->wb[0][0] = UINT64_MAX / 2;
    expect(m, "write-backs", "more write-backs than writes");
    m->wb[0][0] = wb;

    uint32_t nu = m->nused;
    m->nused = m->ncap + 1;
    expect(m, "nodes used", "more nodes used than allocated");
    m->nused = nu;

    /* restored: it passes, and the stream goes on */
    CHECK(rt_msim_check(m, &e) == 0, "restored: %s", e.msg);
    fill(m, 11, 2048);
    CHECK(rt_msim_check(m, &e) == 0, "after more references: %s", e.msg);
    rt_msim_free(m);
    return failures ? 1 : 0;
}
