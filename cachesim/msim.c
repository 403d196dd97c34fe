/*
 * msim.c -- exact fully associative LRU for many cache sizes in one pass.
 *
 * WHAT IT IS. LRU has the inclusion property (Mattson et al. 1970): after
 * any reference sequence, an LRU cache of C lines holds exactly the C most
 * recently used distinct lines. So one recency stack -- all distinct lines
 * ordered from most to least recently used -- describes every fully
 * associative LRU cache at once: a cache of C lines is the top C entries.
 * A reference to a line at stack depth d (1 = top) hits in every cache of
 * at least d lines and misses in every smaller one.
 *
 * REPRESENTATION. With a fixed set of k sizes C_0 < C_1 < ... < C_{k-1}
 * (in lines) we do not need the exact depth, only which interval it falls
 * in (Kim, Hill and Wood 1991). The stack is a doubly linked list threaded
 * through an index array (nodes[], 32-bit links, NIL = UINT32_MAX), head =
 * most recently used. Each node carries its *group* g: the node is at depth
 * in (C_{g-1}, C_g] (C_{-1} = 0). There is one *marker* per group pointing
 * at the group's deepest (least recently used) node, and a count per group.
 * Lines deeper than C_{k-1} are in no simulated cache and are dropped from
 * the structure, so it never holds more than C_{k-1} nodes. An open-
 * addressing hash table (linear probing, Fibonacci hashing, backward-shift
 * deletion, load <= 1/2) maps a line number to its node.
 *
 * A REFERENCE to line L:
 *   1. look L up; if present its group g says it hits in sizes g..k-1 and
 *      misses in 0..g-1; if absent g = k (misses everywhere). We count the
 *      reference once, in hist[class][write][g]; the misses of size i are
 *      the sum of hist over g > i, computed when results are read. So the
 *      per-reference counting cost does not depend on k;
 *   2. unlink L (fixing its group's marker and count) or, on a miss with a
 *      full stack, evict the bottom node (it leaves cache k-1) and reuse it;
 *   3. push L on top as group 0; then cascade: while group j holds more than
 *      its capacity cap[j] = C_j - C_{j-1}, its marker node crosses into
 *      group j+1 (retag it, move the marker one node up). Only tags and
 *      markers change, never links, and the cascade stops at group g, so the
 *      cost is O(g) <= O(k).
 *
 * DIRTY STATE. A line can be dirty in one cache and clean in another (a
 * larger cache keeps a line a smaller one has already written back). Each
 * node has a bitmask: bit i set = the line is dirty in the cache of size i.
 * A write sets all k bits (write-allocate: after the write every cache
 * holds the line, modified). When a node crosses from group j to j+1 it
 * leaves cache j: if bit j is set, cache j writes it back; the bit is
 * cleared. Write-backs are charged to the class of the reference that last
 * wrote the line (wcls), which is the same reference for every size in
 * which the line is dirty, since every write dirties all sizes.
 *
 * INVARIANTS (checked by rt_msim_check):
 *   - the list from head follows next links to tail, prev links mirror
 *     them, and it has nused nodes, each in the hash table under its line;
 *   - group tags are non-decreasing from head to tail; group j has cnt[j]
 *     nodes, 0 <= cnt[j] <= cap[j], and marker[j] is its last node (NIL iff
 *     cnt[j] == 0);
 *   - if cnt[j] < cap[j] then every group after j is empty (the stack fills
 *     from the top), hence nused <= C_{k-1};
 *   - a node in group g has no dirty bit below g (it is in no cache smaller
 *     than C_g);
 *   - mru_line is the line of the head node.
 *
 * SPEED. A repeat of the most recently used line (the common case: several
 * fields of one record, a record spanning two lines) takes a fast path
 * without hashing. Power-of-two lines use a shift, other sizes a division.
 * While simulating a batch, the hash slot of the reference a few ahead is
 * prefetched.
 */
#include "msim.h"

#include <stdlib.h>
#include <string.h>

#define NIL UINT32_MAX
#define PREFETCH_AHEAD 16 /* hash slot prefetch distance */
#define PREFETCH_NODE 4   /* node prefetch distance (slot should be cached by then) */

typedef struct msnode {
    uint64_t line;  /* line number (address / line size) */
    uint32_t prev;  /* towards the top (more recent); NIL at head */
    uint32_t next;  /* towards the bottom; NIL at tail */
    uint32_t dirty; /* bit i: dirty in the cache of size i */
    uint8_t grp;    /* size interval the node's depth is in */
    uint8_t wcls;   /* class of the last write to the line */
} msnode;

typedef struct msslot {
    uint64_t key; /* line number */
    uint32_t val; /* node index, NIL = empty slot */
} msslot;

struct rt_msim {
    int k;                                   /* number of sizes */
    uint32_t line;                           /* line size in bytes */
    int shift;                               /* log2(line), or -1 if not a power of two */
    uint64_t sizes[RT_SIM_MAXSIZES];         /* sizes in bytes */
    uint32_t cap[RT_SIM_MAXSIZES + 1];       /* group capacities in lines */
    uint32_t cnt[RT_SIM_MAXSIZES + 1];       /* nodes per group */
    uint32_t marker[RT_SIM_MAXSIZES + 1];    /* last node of each group */
    uint32_t allmask;                        /* k low bits set */
    uint32_t cmax;                           /* lines of the largest cache */
    uint32_t nused;                          /* nodes in use (all in the list) */
    uint32_t head, tail;                     /* list ends */
    uint64_t mru_line;                       /* line of head (valid if head != NIL) */
    msnode *nodes;                           /* cmax nodes */
    msslot *ht;                              /* hash table */
    uint64_t hmask;                          /* table size - 1 */
    int hshift;                              /* 64 - log2(table size) */
    uint64_t hist[RT_NCLASS][2][RT_SIM_MAXSIZES + 1]; /* touches by class, write, group */
    uint64_t wb[RT_SIM_MAXSIZES][RT_NCLASS]; /* write-backs by size, class */
};

static inline uint64_t hslot(const rt_msim *m, uint64_t line)
{
    return (line * 0x9E3779B97F4A7C15ULL) >> m->hshift;
}

static inline uint32_t h_find(const rt_msim *m, uint64_t line)
{
    uint64_t i = hslot(m, line);
    for (;;) {
        const msslot *s = &m->ht[i];
        if (s->val == NIL) return NIL;
        if (s->key == line) return s->val;
        i = (i + 1) & m->hmask;
    }
}

static inline void h_insert(rt_msim *m, uint64_t line, uint32_t val)
{
    uint64_t i = hslot(m, line);
    while (m->ht[i].val != NIL) i = (i + 1) & m->hmask;
    m->ht[i].key = line;
    m->ht[i].val = val;
}

static void h_delete(rt_msim *m, uint64_t line)
{
    uint64_t i = hslot(m, line);
    while (m->ht[i].key != line || m->ht[i].val == NIL) i = (i + 1) & m->hmask;
    /* backward-shift deletion keeps every probe chain unbroken */
    uint64_t j = i;
    for (;;) {
        j = (j + 1) & m->hmask;
        if (m->ht[j].val == NIL) break;
        uint64_t h = hslot(m, m->ht[j].key);
        /* leave slot j alone if its home h is cyclically in (i, j] */
        if (i <= j ? (i < h && h <= j) : (i < h || h <= j)) continue;
        m->ht[i] = m->ht[j];
        i = j;
    }
    m->ht[i].val = NIL;
}

rt_msim *rt_msim_new(const uint64_t *sizes, int k, uint32_t line, rt_err *e)
{
    if (k < 1 || k > RT_SIM_MAXSIZES) return rt_errf(e, "msim: %d sizes (1..%d allowed)", k, RT_SIM_MAXSIZES), NULL;
    if (line == 0) return rt_errf(e, "msim: line size 0"), NULL;
    uint64_t prev = 0;
    for (int i = 0; i < k; i++) {
        if (sizes[i] <= prev || sizes[i] % line)
            return rt_errf(e, "msim: sizes must increase and be multiples of the %u-byte line", line), NULL;
        if (sizes[i] / line >= (1u << 30)) return rt_errf(e, "msim: cache of %llu lines is too large",
                                                         (unsigned long long)(sizes[i] / line)), NULL;
        prev = sizes[i];
    }
    rt_msim *m = rt_calloc(1, sizeof *m, e);
    if (!m) return NULL;
    m->k = k;
    m->line = line;
    m->shift = -1;
    if ((line & (line - 1)) == 0) {
        m->shift = 0;
        while ((1u << m->shift) != line) m->shift++;
    }
    uint64_t c_prev = 0;
    for (int i = 0; i < k; i++) {
        m->sizes[i] = sizes[i];
        uint64_t c = sizes[i] / line;
        m->cap[i] = (uint32_t)(c - c_prev);
        m->marker[i] = NIL;
        c_prev = c;
    }
    m->cap[k] = 0;
    m->marker[k] = NIL;
    m->allmask = k == 32 ? UINT32_MAX : ((1u << k) - 1);
    m->cmax = (uint32_t)c_prev;
    m->head = m->tail = NIL;
    uint64_t tsize = 16;
    int bits = 4;
    while (tsize < 2 * (uint64_t)m->cmax) tsize <<= 1, bits++;
    m->hmask = tsize - 1;
    m->hshift = 64 - bits;
    m->nodes = rt_calloc(m->cmax, sizeof *m->nodes, e);
    m->ht = rt_calloc(tsize, sizeof *m->ht, e);
    if (!m->nodes || !m->ht) {
        rt_msim_free(m);
        return NULL;
    }
    for (uint64_t i = 0; i < tsize; i++) m->ht[i].val = NIL;
    return m;
}

void rt_msim_free(rt_msim *m)
{
    if (!m) return;
    free(m->nodes);
    free(m->ht);
    free(m);
}

/* One line touch. */
static inline void touch(rt_msim *restrict m, uint64_t L, unsigned w, unsigned cls)
{
    msnode *restrict nd = m->nodes;
    if (L == m->mru_line && m->head != NIL) { /* fast path: top of stack */
        m->hist[cls][w][0]++;
        if (w) {
            nd[m->head].dirty = m->allmask;
            nd[m->head].wcls = (uint8_t)cls;
        }
        return;
    }
    uint32_t x = h_find(m, L);
    unsigned g;
    if (x != NIL) {
        g = nd[x].grp;
        if (m->marker[g] == x) m->marker[g] = m->cnt[g] > 1 ? nd[x].prev : NIL;
        m->cnt[g]--;
        /* unlink (x is not the head: the head is mru_line) */
        uint32_t p = nd[x].prev, n = nd[x].next;
        nd[p].next = n;
        if (n != NIL) nd[n].prev = p;
        else m->tail = p;
    } else {
        g = (unsigned)m->k;
        if (m->nused == m->cmax) {
            /* evict the bottom line: it leaves the largest cache */
            unsigned kk = (unsigned)m->k - 1;
            x = m->tail;
            if (nd[x].dirty & (1u << kk)) m->wb[kk][nd[x].wcls]++;
            m->marker[kk] = m->cnt[kk] > 1 ? nd[x].prev : NIL;
            m->cnt[kk]--;
            m->tail = nd[x].prev;
            if (m->tail != NIL) nd[m->tail].next = NIL;
            else m->head = NIL;
            h_delete(m, nd[x].line);
        } else {
            x = m->nused++;
        }
        nd[x].line = L;
        nd[x].dirty = 0;
        h_insert(m, L, x);
    }
    m->hist[cls][w][g]++;
    /* push on top as group 0 */
    nd[x].prev = NIL;
    nd[x].next = m->head;
    if (m->head != NIL) nd[m->head].prev = x;
    else m->tail = x;
    m->head = x;
    m->mru_line = L;
    nd[x].grp = 0;
    if (w) {
        nd[x].dirty = m->allmask;
        nd[x].wcls = (uint8_t)cls;
    }
    if (++m->cnt[0] == 1) m->marker[0] = x;
    /* cascade: overflowing groups hand their last node down */
    for (unsigned j = 0; m->cnt[j] > m->cap[j]; j++) {
        uint32_t y = m->marker[j];
        nd[y].grp = (uint8_t)(j + 1);
        if (nd[y].dirty & (1u << j)) {
            m->wb[j][nd[y].wcls]++;
            nd[y].dirty &= ~(1u << j);
        }
        m->marker[j] = nd[y].prev;
        m->cnt[j]--;
        if (++m->cnt[j + 1] == 1) m->marker[j + 1] = y;
    }
}

static inline void put_batch(rt_msim *restrict m, const rt_access *a, size_t n, const int pow2)
{
    const int sh = m->shift;
    const uint64_t ls = m->line;
    for (size_t i = 0; i < n; i++) {
        if (i + PREFETCH_AHEAD < n) {
            uint64_t pl = pow2 ? a[i + PREFETCH_AHEAD].addr >> sh : a[i + PREFETCH_AHEAD].addr / ls;
            __builtin_prefetch(&m->ht[hslot(m, pl)]);
        }
        if (i + PREFETCH_NODE < n) {
            uint64_t pl = pow2 ? a[i + PREFETCH_NODE].addr >> sh : a[i + PREFETCH_NODE].addr / ls;
            const msslot *ps = &m->ht[hslot(m, pl)];
            if (ps->val != NIL && ps->key == pl) {
                __builtin_prefetch(&m->nodes[ps->val]);
            }
        }
        uint64_t addr = a[i].addr;
        uint32_t sz = a[i].size ? a[i].size : 1;
        unsigned cls = a[i].cls < RT_NCLASS ? a[i].cls : RT_CLS_FB;
        unsigned w = a[i].write ? 1 : 0;
        uint64_t first = pow2 ? addr >> sh : addr / ls;
        uint64_t last = pow2 ? (addr + sz - 1) >> sh : (addr + sz - 1) / ls;
        touch(m, first, w, cls);
        for (uint64_t L = first + 1; L <= last; L++) touch(m, L, w, cls);
    }
}

void rt_msim_put(rt_msim *m, const rt_access *a, size_t n)
{
    if (m->shift >= 0) put_batch(m, a, n, 1);
    else put_batch(m, a, n, 0);
}

void rt_msim_get(const rt_msim *m, int i, int cls, rt_sim_counts *out)
{
    memset(out, 0, sizeof *out);
    if (i < 0 || i >= m->k || cls < 0 || cls >= RT_NCLASS) return;
    for (int g = 0; g <= m->k; g++) {
        out->accesses += m->hist[cls][0][g] + m->hist[cls][1][g];
        if (g > i) {
            out->read_misses += m->hist[cls][0][g];
            out->write_misses += m->hist[cls][1][g];
        }
    }
    out->writebacks = m->wb[i][cls];
    out->traffic_bytes = (out->read_misses + out->write_misses + out->writebacks) * m->line;
}

int rt_msim_check(const rt_msim *m, rt_err *e)
{
    const msnode *nd = m->nodes;
    uint32_t cnt[RT_SIM_MAXSIZES + 1] = {0};
    uint32_t last[RT_SIM_MAXSIZES + 1];
    for (int j = 0; j <= m->k; j++) last[j] = NIL;
    uint32_t seen = 0, prev = NIL;
    unsigned gprev = 0;
    for (uint32_t x = m->head; x != NIL; x = nd[x].next) {
        if (x >= m->nused) return rt_errf(e, "msim: node %u beyond nused %u", x, m->nused);
        if (++seen > m->nused) return rt_errf(e, "msim: list longer than %u nodes (cycle?)", m->nused);
        if (nd[x].prev != prev) return rt_errf(e, "msim: node %u prev link broken", x);
        unsigned g = nd[x].grp;
        if (g >= (unsigned)m->k) return rt_errf(e, "msim: node %u has group %u >= k", x, g);
        if (g < gprev) return rt_errf(e, "msim: groups decrease along the stack at node %u", x);
        gprev = g;
        cnt[g]++;
        last[g] = x;
        if (nd[x].dirty & ~m->allmask) return rt_errf(e, "msim: node %u has dirty bits beyond k", x);
        if (nd[x].dirty & ((1u << g) - 1)) return rt_errf(e, "msim: node %u (group %u) dirty in a smaller cache", x, g);
        if (h_find(m, nd[x].line) != x) return rt_errf(e, "msim: node %u not found in hash table", x);
        prev = x;
    }
    if (seen != m->nused) return rt_errf(e, "msim: list has %u nodes, nused %u", seen, m->nused);
    if (m->tail != prev) return rt_errf(e, "msim: tail mismatch");
    if (m->head != NIL && nd[m->head].line != m->mru_line) return rt_errf(e, "msim: mru_line is not the head line");
    for (int j = 0; j < m->k; j++) {
        if (cnt[j] != m->cnt[j]) return rt_errf(e, "msim: group %d has %u nodes, count says %u", j, cnt[j], m->cnt[j]);
        if (cnt[j] > m->cap[j]) return rt_errf(e, "msim: group %d over capacity", j);
        if (m->marker[j] != last[j]) return rt_errf(e, "msim: marker %d is not the group's last node", j);
        if (cnt[j] < m->cap[j])
            for (int l = j + 1; l < m->k; l++)
                if (cnt[l]) return rt_errf(e, "msim: group %d not full but group %d non-empty", j, l);
    }
    uint64_t inhash = 0;
    for (uint64_t i = 0; i <= m->hmask; i++)
        if (m->ht[i].val != NIL) {
            inhash++;
            if (m->ht[i].val >= m->nused || nd[m->ht[i].val].line != m->ht[i].key)
                return rt_errf(e, "msim: stale hash slot %llu", (unsigned long long)i);
        }
    if (inhash != m->nused) return rt_errf(e, "msim: hash holds %llu lines, stack %u", (unsigned long long)inhash, m->nused);
    return 0;
}

void rt_msim_test_add(rt_msim *m, int cls, int write, int g, uint64_t n)
{
    if (cls >= 0 && cls < RT_NCLASS && g >= 0 && g <= m->k) m->hist[cls][write ? 1 : 0][g] += n;
}
