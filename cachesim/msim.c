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
 * through an index array of 16-byte hot records (nodes[]: 32-bit prev/next
 * links, NIL = UINT32_MAX, dirty mask, group, last writer's class and
 * generation), head =
 * most recently used; node i's line number is kept apart in lines[i]. Each
 * node carries its *group* g: the node is at depth in (C_{g-1}, C_g]
 * (C_{-1} = 0). There is one *marker* per group pointing at the group's
 * deepest (least recently used) node, and a count per group. Lines deeper
 * than C_{k-1} are in no simulated cache and are dropped from the
 * structure, so it never holds more than C_{k-1} nodes. An open-addressing
 * hash table (linear probing, Fibonacci hashing h = L * PHI, backward-shift
 * deletion, load <= 1/2) maps a line to its node; a slot is 64 bits: the
 * top 32 bits of h (a fingerprint whose top bits are the slot's home, so
 * deletion needs no line numbers) and the node index. A fingerprint match
 * is confirmed against lines[].
 *
 * A REFERENCE to line L:
 *   1. look L up; if present its group g says it hits in sizes g..k-1 and
 *      misses in 0..g-1; if absent g = k (misses everywhere). We count the
 *      touch once, in hist[cg][kind][g] (cg: the reference's class and
 *      ray generation folded into one index, sim_int.h; kind 0 read, 1
 *      write, 2 a write that misses without a fetch: a streaming store
 *      (rt_access.write == RT_WRITE_STREAM) on every line it touches, and
 *      a write covering the whole line when write_miss_fullline asks for
 *      those apart; a kind-2 hit is an ordinary write); the misses of size
 *      i are the sum of hist over g > i, computed when results are read. So
 *      the per-reference counting cost depends on neither k nor the number
 *      of generations;
 *   2. unlink L (fixing its group's marker and count) or, on a miss with a
 *      full stack, evict the bottom node (it leaves cache k-1) and reuse it;
 *   3. push L on top as group 0; then cascade: while group j holds more than
 *      its capacity cap[j] = C_j - C_{j-1}, its marker node crosses into
 *      group j+1 (retag it, move the marker one node up). Only tags and
 *      markers change, never links, and the cascade stops at group g, so the
 *      cost is O(g) <= O(k).
 *   Once the stack holds C_{k-1} lines every group is full and stays full
 *   (a hit takes one node out of group g and the cascade hands one back; a
 *   miss evicts one from group k-1 and the cascade refills it), so the
 *   steady-state path moves only markers and tags -- exactly g boundary
 *   crossings for a hit, k-1 for a miss -- and keeps no counts; the generic
 *   path (touch_fill) runs while the stack fills and when C_{k-1} = 1.
 *
 * DIRTY STATE. A line can be dirty in one cache and clean in another (a
 * larger cache keeps a line a smaller one has already written back). Each
 * node has a bitmask: bit i set = the line is dirty in the cache of size i.
 * A write sets all k bits (write-allocate: after the write every cache
 * holds the line, modified). When a node crosses from group j to j+1 it
 * leaves cache j: if bit j is set, cache j writes it back; the bit is
 * cleared. Write-backs are charged to the class and generation of the
 * reference that last wrote the line (wcg), which is the same reference for
 * every size in which the line is dirty, since every write dirties all
 * sizes. FLUSH (rt_msim_flush, Dinero IV's end of run): every node's set
 * dirty bits are exactly the caches that hold it modified, so each set bit
 * i is one write-back from cache i; the bits are then cleared.
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
 *     than C_g); a dirty node's wcg is a valid (class, generation) index;
 *   - for every size i and index cg, wb[i][cg] is at most the write touches
 *     counted for cg, kinds 1 and 2 (each write-back from cache i needs its
 *     own last write since the line's previous write-back from cache i);
 *   - without write_miss_fullline, kind-2 touches come only from streaming
 *     stores, so their count per cg is at most the streaming touches
 *     recorded in nstream[cg] (counted per reference, off the hot path of
 *     ordinary writes);
 *   - mru_line is the line of the head node;
 *   - every slot's fingerprint is the top half of lines[node] * PHI, and
 *     full is set iff nused == C_{k-1} >= 2.
 *
 * SPEED. The costs are memory latency (at 4 MB: 1 MB of nodes, 0.5 MB of
 * lines, 1 MB of hash table, touched at random) and instructions. A repeat
 * of the most recently used line takes a fast path without hashing.
 * Memory: nodes, lines[] and the table are sized for ncap nodes, 4096
 * at first, and grown (doubled, the table rebuilt at twice the nodes)
 * before a batch whose lines could outgrow them, never beyond cmax; a
 * cache far larger than the lines a stream touches (sim --sizes 16G of a
 * small trace) costs only those lines. Invariant: nused <= ncap <= cmax
 * and the table has at least 2 * ncap slots (rt_msim_check).
 *
 * Power-of-two lines use a shift, other sizes a division. rt_msim_put
 * pipelines each batch: a reference's lines are hashed and their slots
 * prefetched PF_SLOT references ahead, the slots are read and the nodes and
 * lines prefetched PF_NODE ahead (the node index is kept as a *hint*: since
 * every node below nused is in the stack with its line in lines[], a hint
 * with lines[hint] == L is L's node and the probe is skipped), and the
 * nodes' list neighbours (which the unlink writes) are prefetched PF_NEIGH
 * ahead. The next victim's node, line and slot are warmed ahead of the
 * eviction, and each marker prefetches its new node when it moves, so the
 * next crossing of that boundary finds it in cache. Prefetches are hints
 * only; results do not depend on them.
 * The pipeline pays for itself only when references reach deep into the
 * stack, whose nodes are then outside the L1 cache: on a ray tracer's
 * trace most touches stay in the top few hundred lines, and walking the
 * batch plainly, one reference after the other, is 15-40% faster (sf.rtt:
 * 13 sizes 1.04 s pipelined vs 0.87 s plain, one 16 KB size 0.87 vs 0.52 s),
 * while on a trace with little locality the pipeline is up to 2.5x faster.
 * So rt_msim_put picks the walk per batch: the pipeline when more than one
 * reference in 10 of the previous batch touched a group below the top
 * DEEP_LINES lines (or missed), the plain walk otherwise. Both walks call the same
 * touch(), so the choice changes no counter (tested with each forced).
 */
#include "msim.h"
#include "engine.h"
#include "sim_int.h"

#include <stdlib.h>
#include <string.h>

#define NIL UINT32_MAX
#define PHI 0x9E3779B97F4A7C15ULL /* Fibonacci hashing multiplier (odd) */
#define PF_SLOT 16 /* hash slot prefetch distance, in references */
#define PF_NODE 5  /* node prefetch distance (its slot should be cached by then) */
#define DEEP_LINES 512 /* stack depth whose nodes, lines and slots (~40 B each) fill a 32 KB L1 */
#ifndef DEEP_SHARE
#define DEEP_SHARE 10 /* the pipeline for a batch after one with more than 1 in DEEP_SHARE deep touches */
#endif
#ifndef PF_NEIGH
#define PF_NEIGH 2 /* neighbour prefetch distance (the node should be cached by then) */
#endif

/* Hot part of a stack entry: 16 bytes, four per cache line. The line
 * number lives apart in lines[] (read on lookups to confirm a fingerprint
 * match and on eviction). */
typedef struct msnode {
    uint32_t prev;  /* towards the top (more recent); NIL at head */
    uint32_t next;  /* towards the bottom; NIL at tail */
    uint32_t dirty; /* bit i: dirty in the cache of size i */
    uint8_t grp;    /* size interval the node's depth is in */
    uint8_t wcg;    /* (class, generation) index of the last write to the line */
    uint16_t pad;
} msnode;

/* Nodes allocated at first; more as lines arrive (grow). */
#define MSIM_INIT_NODES 4096u

struct rt_msim {
    /* hot fields first */
    uint32_t head, tail;                     /* list ends */
    uint32_t nused;                          /* nodes in use (all in the list) */
    uint32_t cmax;                           /* lines of the largest cache */
    uint32_t ncap;                           /* nodes allocated, nused <= ncap <= cmax (grown by rt_msim_put) */
    int oom;                                 /* a growth failed: rt_msim_put refuses every batch */
    uint64_t mru_line;                       /* line of head (valid if head != NIL) */
    msnode *nodes;                           /* ncap nodes */
    uint64_t *lines;                         /* ncap line numbers (node i holds lines[i]) */
    uint64_t *ht;                            /* hash slots: fingerprint << 32 | node, node NIL = empty */
    uint64_t hmask;                          /* table size - 1 */
    int hshift;                              /* 64 - log2(table size) */
    int fpshift;                             /* 32 - log2(table size): home = fingerprint >> fpshift */
    int k;                                   /* number of sizes */
    uint32_t allmask;                        /* k low bits set */
    int shift;                               /* log2(line), or -1 if not a power of two */
    uint32_t line;                           /* line size in bytes */
    uint32_t cnt[RT_SIM_MAXSIZES + 1];       /* nodes per group */
    uint32_t cap[RT_SIM_MAXSIZES + 1];       /* group capacities in lines */
    uint32_t marker[RT_SIM_MAXSIZES + 1];    /* last node of each group */
    int full;                                /* nused == cmax >= 2: steady state */
    int fullline;                            /* count whole-line writes apart (kind 2) */
    int engine;                              /* RT_MSIM_AUTO, _PLAIN or _PIPELINED */
    int pipe;                                /* auto: the next batch takes the pipeline */
    uint64_t nbatch[2];                      /* batches walked plainly, through the pipeline */
    unsigned gdeep;                          /* first group whose nodes lie below DEEP_LINES */
    uint64_t hist[RT_SIM_NCG][3][RT_SIM_MAXSIZES + 1]; /* touches by (class, gen), kind, group */
    uint64_t wb[RT_SIM_MAXSIZES][RT_SIM_NCG]; /* write-backs by size, (class, gen) */
    uint64_t nstream[RT_SIM_NCG];            /* line touches of streaming stores, by (class, gen) */
    uint64_t sizes[RT_SIM_MAXSIZES];         /* sizes in bytes */
};

static inline uint64_t hslot(const rt_msim *m, uint64_t line) { return (line * PHI) >> m->hshift; }

static inline uint32_t h_find(const rt_msim *m, uint64_t line)
{
    uint64_t h = line * PHI, i = h >> m->hshift;
    uint32_t fp = (uint32_t)(h >> 32);
    for (;;) {
        uint64_t s = m->ht[i];
        uint32_t v = (uint32_t)s;
        if (v == NIL) return NIL;
        if ((uint32_t)(s >> 32) == fp && m->lines[v] == line) return v;
        i = (i + 1) & m->hmask;
    }
}

static inline void h_insert(rt_msim *m, uint64_t line, uint32_t val)
{
    uint64_t h = line * PHI, i = h >> m->hshift;
    while ((uint32_t)m->ht[i] != NIL) i = (i + 1) & m->hmask;
    m->ht[i] = (h & 0xFFFFFFFF00000000ULL) | val;
}

/* Removes node x (holding lines[x]) from the table. */
static inline void h_delete(rt_msim *m, uint32_t x)
{
    uint64_t *restrict ht = m->ht;
    const uint64_t mask = m->hmask;
    uint64_t i = hslot(m, m->lines[x]);
    while ((uint32_t)ht[i] != x) i = (i + 1) & mask;
    /* backward-shift deletion keeps every probe chain unbroken; a slot's
     * home is the top bits of its fingerprint */
    uint64_t j = i;
    for (;;) {
        j = (j + 1) & mask;
        uint64_t s = ht[j];
        if ((uint32_t)s == NIL) break;
        uint64_t h = (s >> 32) >> m->fpshift;
        /* leave slot j alone if its home h is cyclically in (i, j] */
        if (i <= j ? (i < h && h <= j) : (i < h || h <= j)) continue;
        ht[i] = s;
        i = j;
    }
    ht[i] = UINT64_MAX;
}

static int set_table(rt_msim *m, uint32_t nodes, rt_err *e);

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
    /* group g's nodes are deeper than C_{g-1}: the first group whose nodes
     * all lie below the top DEEP_LINES (k + 1: none, the stack is small) */
    m->gdeep = (unsigned)k + 1;
    for (int i = 0; i < k; i++)
        if (sizes[i] / line >= DEEP_LINES) {
            m->gdeep = (unsigned)i + 1;
            break;
        }
    m->allmask = k == 32 ? UINT32_MAX : ((1u << k) - 1);
    m->cmax = (uint32_t)c_prev;
    m->head = m->tail = NIL;
    /* the state grows with the lines seen (rt_msim_put), never beyond
     * cmax: a 16 GB cache over a small trace costs what the trace touches */
    m->ncap = m->cmax < MSIM_INIT_NODES ? m->cmax : MSIM_INIT_NODES;
    m->nodes = rt_calloc(m->ncap, sizeof *m->nodes, e);
    m->lines = rt_calloc(m->ncap, sizeof *m->lines, e);
    if (!m->nodes || !m->lines || set_table(m, m->ncap, e) < 0) {
        rt_msim_free(m);
        return NULL;
    }
    return m;
}

/* A hash table of at least 2 * nodes slots, with every node below nused
 * inserted again (its fingerprints depend on the table size). */
static int set_table(rt_msim *m, uint32_t nodes, rt_err *e)
{
    uint64_t tsize = 16;
    int bits = 4;
    while (tsize < 2 * (uint64_t)nodes) tsize <<= 1, bits++; /* bits <= 31 */
    if (m->ht && tsize == m->hmask + 1) return 0;
    uint64_t *ht = rt_calloc(tsize, sizeof *ht, e);
    if (!ht) return -1;
    free(m->ht);
    m->ht = ht;
    memset(m->ht, 0xFF, tsize * sizeof *m->ht);
    m->hmask = tsize - 1;
    m->hshift = 64 - bits;
    m->fpshift = 32 - bits;
    for (uint32_t x = 0; x < m->nused; x++) h_insert(m, m->lines[x], x);
    return 0;
}

/* Room for need nodes (at most cmax): nodes and lines at least doubled,
 * the table resized to match. 0, or -1 (out of memory; m unchanged but
 * for larger arrays). */
static int grow(rt_msim *m, uint64_t need)
{
    if (need > m->cmax) need = m->cmax;
    if (need <= m->ncap) return 0;
    uint64_t nc = 2 * (uint64_t)m->ncap;
    if (nc < need) nc = need;
    if (nc > m->cmax) nc = m->cmax;
    msnode *nd = rt_reallocarray(m->nodes, nc, sizeof *nd, NULL);
    if (!nd) return -1;
    m->nodes = nd;
    uint64_t *ln = rt_reallocarray(m->lines, nc, sizeof *ln, NULL);
    if (!ln) return -1;
    m->lines = ln;
    if (set_table(m, (uint32_t)nc, NULL) < 0) return -1;
    m->ncap = (uint32_t)nc;
    return 0;
}

void rt_msim_free(rt_msim *m)
{
    if (!m) return;
    free(m->nodes);
    free(m->lines);
    free(m->ht);
    free(m);
}

/* Generic touch, used while the stack is filling (and for a one-line
 * largest cache): group counts change, the cascade stops at the first group
 * that does not overflow. x is L's node or NIL. */
static void touch_fill(rt_msim *restrict m, uint64_t L, uint32_t x, unsigned w, unsigned cg)
{
    msnode *restrict nd = m->nodes;
    unsigned g;
    if (x != NIL) {
        g = nd[x].grp;
        uint32_t p = nd[x].prev, n = nd[x].next;
        if (m->marker[g] == x) m->marker[g] = m->cnt[g] > 1 ? p : NIL;
        m->cnt[g]--;
        /* unlink (x is not the head: the head is mru_line) */
        nd[p].next = n;
        if (n != NIL) nd[n].prev = p;
        else m->tail = p;
    } else {
        g = (unsigned)m->k;
        if (m->nused == m->cmax) {
            /* evict the bottom line: it leaves the largest cache */
            unsigned kk = (unsigned)m->k - 1;
            x = m->tail;
            if (nd[x].dirty & (1u << kk)) m->wb[kk][nd[x].wcg]++;
            m->marker[kk] = m->cnt[kk] > 1 ? nd[x].prev : NIL;
            m->cnt[kk]--;
            m->tail = nd[x].prev;
            if (m->tail != NIL) nd[m->tail].next = NIL;
            else m->head = NIL;
            h_delete(m, x);
        } else {
            x = m->nused++;
        }
        m->lines[x] = L;
        nd[x].dirty = 0;
        h_insert(m, L, x);
    }
    m->hist[cg][w][g]++;
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
        nd[x].wcg = (uint8_t)cg;
    }
    if (++m->cnt[0] == 1) m->marker[0] = x;
    /* cascade: overflowing groups hand their last node down */
    for (unsigned j = 0; m->cnt[j] > m->cap[j]; j++) {
        uint32_t y = m->marker[j];
        nd[y].grp = (uint8_t)(j + 1);
        if (nd[y].dirty & (1u << j)) {
            m->wb[j][nd[y].wcg]++;
            nd[y].dirty &= ~(1u << j);
        }
        m->marker[j] = nd[y].prev;
        m->cnt[j]--;
        if (++m->cnt[j + 1] == 1) m->marker[j + 1] = y;
    }
    m->full = m->nused == m->cmax && m->cmax > 1;
}

/* One line touch. L is the line, h = L * PHI, hint a node that may hold L
 * (or NIL), cg the reference's (class, generation) index. */
static inline __attribute__((always_inline)) unsigned touch(rt_msim *restrict m, uint64_t L, uint64_t h,
                                                             uint32_t hint, unsigned w, unsigned cg)
{
    msnode *restrict nd = m->nodes;
    if (L == m->mru_line && m->head != NIL) { /* fast path: top of stack */
        m->hist[cg][w][0]++;
        if (w) {
            nd[m->head].dirty = m->allmask;
            nd[m->head].wcg = (uint8_t)cg;
        }
        return 0;
    }
    uint32_t x;
    /* every node below nused is in the stack and lines[] is its line, so a
     * hint that names L is L's node */
    if (hint < m->nused && m->lines[hint] == L) {
        x = hint;
    } else {
        uint64_t i = h >> m->hshift;
        uint32_t fp = (uint32_t)(h >> 32);
        for (;;) {
            uint64_t s = m->ht[i];
            x = (uint32_t)s;
            if (x == NIL || ((uint32_t)(s >> 32) == fp && m->lines[x] == L)) break;
            i = (i + 1) & m->hmask;
        }
    }
    if (__builtin_expect(!m->full, 0)) {
        unsigned gf = x != NIL ? nd[x].grp : (unsigned)m->k;
        touch_fill(m, L, x, w, cg);
        return gf;
    }
    /* Steady state: the stack holds cmax lines, every group is full and
     * stays full, so no count changes. A hit at group g hands one node
     * across each boundary 0..g-1; a miss evicts the tail and hands one
     * node across each boundary 0..k-2. */
    unsigned g, ncas;
    if (x != NIL) {
        g = nd[x].grp;
        ncas = g;
        uint32_t p = nd[x].prev, n = nd[x].next;
        /* x's successor as last of group g is p: p is in group g, or p is
         * the last of group g-1 and is about to cross into g */
        if (m->marker[g] == x) m->marker[g] = p;
        nd[p].next = n;
        if (n != NIL) nd[n].prev = p;
        else m->tail = p;
    } else {
        unsigned kk = (unsigned)m->k - 1;
        g = kk + 1;
        ncas = kk;
        x = m->tail;
        uint32_t p = nd[x].prev; /* not NIL: cmax >= 2 */
        if (nd[x].dirty & (1u << kk)) m->wb[kk][nd[x].wcg]++;
        m->marker[kk] = p; /* as above */
        m->tail = p;
        nd[p].next = NIL;
        uint32_t q = nd[p].prev; /* the victim after next: warm it */
        if (q != NIL) {
            __builtin_prefetch(&nd[q], 1);
            __builtin_prefetch(&m->lines[q]);
        }
        h_delete(m, x);
        m->lines[x] = L;
        nd[x].dirty = 0;
        uint64_t i = h >> m->hshift;
        while ((uint32_t)m->ht[i] != NIL) i = (i + 1) & m->hmask;
        m->ht[i] = (h & 0xFFFFFFFF00000000ULL) | x;
    }
    m->hist[cg][w][g]++;
    uint32_t hd = m->head;
    nd[x].prev = NIL;
    nd[x].next = hd;
    nd[hd].prev = x;
    m->head = x;
    m->mru_line = L;
    nd[x].grp = 0;
    if (w) {
        nd[x].dirty = m->allmask;
        nd[x].wcg = (uint8_t)cg;
    }
    uint32_t *restrict mk = m->marker;
    for (unsigned j = 0; j < ncas; j++) {
        uint32_t y = mk[j];
        msnode *ny = &nd[y];
        ny->grp = (uint8_t)(j + 1);
        uint32_t d = ny->dirty;
        if (__builtin_expect(d & (1u << j), 0)) {
            m->wb[j][ny->wcg]++;
            ny->dirty = d & ~(1u << j);
        }
        uint32_t p = ny->prev; /* not NIL: group j holds cap[j] + 1 >= 2 nodes now */
        mk[j] = p;
        __builtin_prefetch(&nd[p], 1); /* the next node to cross this boundary */
    }
    return g;
}

/* Prefetch pipeline: references are hashed PF_SLOT ahead (slot
 * prefetched), their nodes found PF_NODE ahead (node and line prefetched,
 * the node remembered as a hint), and the nodes' list neighbours prefetched
 * PF_NEIGH ahead. */
#define RING 32 /* > PF_SLOT, power of two */
typedef struct pfent {
    uint64_t f, l;   /* first and last line of the reference */
    uint64_t hf, hl; /* their hashes */
    uint32_t xf, xl; /* hints: nodes that held them PF_NODE references ago, or NIL */
} pfent;

static inline uint32_t pf_node(const rt_msim *m, uint64_t L, uint64_t h)
{
    uint64_t s = m->ht[h >> m->hshift];
    uint32_t v = (uint32_t)s;
    if (v != NIL && (s >> 32) == (h >> 32)) {
        __builtin_prefetch(&m->nodes[v], 1);
        __builtin_prefetch(&m->lines[v]);
        (void)L;
        return v;
    }
    return NIL;
}

static inline void pf_neigh(const rt_msim *m, uint32_t x)
{
    if (x < m->nused) {
        const msnode *nx = &m->nodes[x];
        uint32_t p = nx->prev, n = nx->next;
        if (p != NIL) __builtin_prefetch(&m->nodes[p], 1);
        if (n != NIL) __builtin_prefetch(&m->nodes[n], 1);
    }
}

/* Kinds of the first (wf), middle (wm) and last (wl) line touches of
 * reference r spanning lines first..last: a streaming store is kind 2 on
 * every line it touches, and a write that covers a whole line is kind 2
 * when those are counted apart. Counts the streaming touches. */
static inline void kinds(rt_msim *restrict m, const rt_access *r, uint64_t first, uint64_t last, unsigned cg,
                         unsigned *wf, unsigned *wm, unsigned *wl)
{
    const uint64_t ls = m->line;
    unsigned w = r->write ? 1 : 0;
    *wf = *wm = *wl = w;
    if (r->write == RT_WRITE_STREAM) {
        *wf = *wm = *wl = 2;
        m->nstream[cg] += last > first ? last - first + 1 : 1;
    } else if (w && m->fullline) {
        uint64_t lo = r->addr, end = lo + (r->size ? r->size : 1); /* exclusive */
        if (end > lo) {
            *wm = 2;
            if (first * ls == lo && (first + 1) * ls <= end) *wf = 2;
            if ((last + 1) * ls == end) *wl = 2;
        }
    }
}

/* Simulates a[0..n) through the prefetch pipeline; returns the touches
 * that went deeper than the first gdeep groups (see rt_msim_put). */
static inline size_t put_batch(rt_msim *restrict m, const rt_access *a, size_t n, const int pow2)
{
    const int sh = m->shift;
    const uint64_t ls = m->line;
    const unsigned gd = m->gdeep;
    size_t deep = 0;
    pfent ring[RING];
#define LINE_OF(x) (pow2 ? (x) >> sh : (x) / ls)
#define STAGE_SLOT(idx)                                                          \
    do {                                                                         \
        const rt_access *r_ = &a[idx];                                           \
        pfent *e_ = &ring[(idx) & (RING - 1)];                                   \
        e_->f = LINE_OF(r_->addr);                                               \
        e_->l = LINE_OF(r_->addr + (r_->size ? r_->size : 1) - 1);               \
        e_->hf = e_->f * PHI;                                                    \
        e_->hl = e_->l * PHI;                                                    \
        e_->xf = e_->xl = NIL;                                                   \
        __builtin_prefetch(&m->ht[e_->hf >> m->hshift]);                         \
        if (e_->l != e_->f) __builtin_prefetch(&m->ht[e_->hl >> m->hshift]);     \
    } while (0)
    size_t pre = n < PF_SLOT ? n : PF_SLOT;
    for (size_t i = 0; i < pre; i++) STAGE_SLOT(i);
    for (size_t i = 0; i < n; i++) {
        if (i + PF_SLOT < n) STAGE_SLOT(i + PF_SLOT);
        if (i + PF_NODE < n) {
            pfent *e = &ring[(i + PF_NODE) & (RING - 1)];
            e->xf = pf_node(m, e->f, e->hf);
            if (e->l != e->f) e->xl = pf_node(m, e->l, e->hl);
        }
        if (PF_NEIGH && i + PF_NEIGH < n) {
            const pfent *e = &ring[(i + PF_NEIGH) & (RING - 1)];
            pf_neigh(m, e->xf);
            if (e->l != e->f) pf_neigh(m, e->xl);
        }
        if (m->full) /* the slot of the next victim */
            __builtin_prefetch(&m->ht[hslot(m, m->lines[m->tail])]);
        const pfent *e = &ring[i & (RING - 1)];
        unsigned cg = rt_sim_cg(&a[i]), wf, wm, wl;
        uint64_t first = e->f, last = e->l;
        kinds(m, &a[i], first, last, cg, &wf, &wm, &wl);
        deep += touch(m, first, e->hf, e->xf, wf, cg) >= gd;
        if (last > first) { /* (an end past 2^64 - 1 touches the first line only) */
            for (uint64_t L = first + 1; L < last; L++) deep += touch(m, L, L * PHI, NIL, wm, cg) >= gd;
            deep += touch(m, last, e->hl, e->xl, wl, cg) >= gd;
        }
    }
#undef STAGE_SLOT
#undef LINE_OF
    return deep;
}

/* The same without the prefetch pipeline: one reference after the other. */
static inline size_t put_plain(rt_msim *restrict m, const rt_access *a, size_t n, const int pow2)
{
    const int sh = m->shift;
    const uint64_t ls = m->line;
    const unsigned gd = m->gdeep;
    size_t deep = 0;
    for (size_t i = 0; i < n; i++) {
        const rt_access *r = &a[i];
        uint64_t first = pow2 ? r->addr >> sh : r->addr / ls;
        uint64_t end = r->addr + (r->size ? r->size : 1) - 1;
        uint64_t last = pow2 ? end >> sh : end / ls;
        unsigned cg = rt_sim_cg(r), wf, wm, wl;
        kinds(m, r, first, last, cg, &wf, &wm, &wl);
        deep += touch(m, first, first * PHI, NIL, wf, cg) >= gd;
        if (last > first) {
            for (uint64_t L = first + 1; L < last; L++) deep += touch(m, L, L * PHI, NIL, wm, cg) >= gd;
            deep += touch(m, last, last * PHI, NIL, wl, cg) >= gd;
        }
    }
    return deep;
}

int rt_msim_put(rt_msim *m, const rt_access *a, size_t n)
{
    size_t deep;
    if (m->oom) return -1;
    if (m->ncap < m->cmax) {
        /* room for every line this batch could add */
        uint64_t need = m->nused;
        for (size_t i = 0; i < n && need < m->cmax; i++) {
            uint64_t lo = a[i].addr, hi = a[i].addr + (a[i].size ? a[i].size : 1) - 1;
            need += m->shift >= 0 ? (hi >> m->shift) - (lo >> m->shift) + 1 : hi / m->line - lo / m->line + 1;
        }
        if (need > m->ncap && grow(m, need) < 0) {
            m->oom = 1;
            return -1;
        }
    }
    int pipe = m->engine == RT_MSIM_PIPELINED || (m->engine == RT_MSIM_AUTO && m->pipe);
    if (pipe) deep = m->shift >= 0 ? put_batch(m, a, n, 1) : put_batch(m, a, n, 0);
    else deep = m->shift >= 0 ? put_plain(m, a, n, 1) : put_plain(m, a, n, 0);
    /* the next batch takes the pipeline when more than 1 in DEEP_SHARE of these
     * references went below the L1-sized top of the stack */
    m->pipe = deep * DEEP_SHARE > n;
    m->nbatch[pipe]++;
    return 0;
}

void rt_msim_set_engine(rt_msim *m, int engine) { m->engine = engine; }

void rt_msim_add_repeats(rt_msim *m, const uint64_t *cnt)
{
    for (int cg = 0; cg < RT_SIM_NCG; cg++) m->hist[cg][0][0] += cnt[cg];
}

void rt_msim_engine_batches(const rt_msim *m, uint64_t out[2])
{
    out[0] = m->nbatch[0];
    out[1] = m->nbatch[1];
}

void rt_msim_get_gen(const rt_msim *m, int i, int cls, int gen, rt_sim_counts *out)
{
    memset(out, 0, sizeof *out);
    if (i < 0 || i >= m->k || cls < 0 || cls >= RT_NCLASS || gen >= RT_MAXGEN) return;
    for (int b = gen < 0 ? 0 : gen; b < (gen < 0 ? RT_MAXGEN : gen + 1); b++) {
        int cg = b * RT_NCLASS + cls;
        for (int g = 0; g <= m->k; g++) {
            out->accesses += m->hist[cg][0][g] + m->hist[cg][1][g] + m->hist[cg][2][g];
            if (g > i) {
                out->read_misses += m->hist[cg][0][g];
                out->write_misses += m->hist[cg][1][g] + m->hist[cg][2][g];
                out->nofetch += m->hist[cg][2][g];
            }
        }
        out->writebacks += m->wb[i][cg];
    }
    out->traffic_bytes = (out->read_misses + out->write_misses - out->nofetch + out->writebacks) * m->line;
}

void rt_msim_get(const rt_msim *m, int i, int cls, rt_sim_counts *out) { rt_msim_get_gen(m, i, cls, -1, out); }

void rt_msim_set_fullline(rt_msim *m, int on) { m->fullline = on != 0; }

void rt_msim_flush(rt_msim *m)
{
    /* a node dirty in cache i (bit i) is resident there: write it back */
    for (uint32_t x = 0; x < m->nused; x++) {
        msnode *nd = &m->nodes[x];
        for (uint32_t d = nd->dirty; d; d &= d - 1) m->wb[__builtin_ctz(d)][nd->wcg]++;
        nd->dirty = 0;
    }
}

int rt_msim_check(const rt_msim *m, rt_err *e)
{
    if (m->nused > m->ncap || m->ncap > m->cmax || m->hmask + 1 < 2 * (uint64_t)m->ncap)
        return rt_errf(e, "msim: %u nodes used, %u allocated, %u at most, %llu hash slots", m->nused, m->ncap, m->cmax,
                       (unsigned long long)(m->hmask + 1));
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
        if (nd[x].dirty && nd[x].wcg >= RT_SIM_NCG) return rt_errf(e, "msim: node %u has writer index %u", x, nd[x].wcg);
        if (h_find(m, m->lines[x]) != x) return rt_errf(e, "msim: node %u not found in hash table", x);
        prev = x;
    }
    if (seen != m->nused) return rt_errf(e, "msim: list has %u nodes, nused %u", seen, m->nused);
    if (m->tail != prev) return rt_errf(e, "msim: tail mismatch");
    if (m->head != NIL && m->lines[m->head] != m->mru_line) return rt_errf(e, "msim: mru_line is not the head line");
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
        if ((uint32_t)m->ht[i] != NIL) {
            uint32_t v = (uint32_t)m->ht[i];
            inhash++;
            if (v >= m->nused || (m->ht[i] >> 32) != ((m->lines[v] * PHI) >> 32))
                return rt_errf(e, "msim: stale hash slot %llu", (unsigned long long)i);
        }
    if (m->full != (m->nused == m->cmax && m->cmax > 1)) return rt_errf(e, "msim: steady-state flag wrong");
    if (inhash != m->nused) return rt_errf(e, "msim: hash holds %llu lines, stack %u", (unsigned long long)inhash, m->nused);
    for (int cg = 0; cg < RT_SIM_NCG; cg++) {
        uint64_t writes = 0;
        uint64_t kind2 = 0;
        for (int g = 0; g <= m->k; g++) writes += m->hist[cg][1][g] + m->hist[cg][2][g], kind2 += m->hist[cg][2][g];
        if (!m->fullline && kind2 > m->nstream[cg])
            return rt_errf(e, "msim: %llu no-fetch write touches for class %s generation %d, %llu streaming",
                           (unsigned long long)kind2, rt_class_name(cg % RT_NCLASS), cg / RT_NCLASS,
                           (unsigned long long)m->nstream[cg]);
        for (int i = 0; i < m->k; i++)
            if (m->wb[i][cg] > writes)
                return rt_errf(e, "msim: size %d: %llu write-backs charged to class %s generation %d, which wrote %llu times",
                               i, (unsigned long long)m->wb[i][cg], rt_class_name(cg % RT_NCLASS), cg / RT_NCLASS,
                               (unsigned long long)writes);
    }
    return 0;
}

void rt_msim_test_add(rt_msim *m, int cls, int write, int g, uint64_t n)
{
    if (cls >= 0 && cls < RT_NCLASS && g >= 0 && g <= m->k) m->hist[cls][write ? 1 : 0][g] += n;
}

/* ---- the engine table's entry (engine.h) ---- */

static uint64_t eng_state_bytes(const rt_sim_config *c)
{
    (void)c;
    return 0; /* grows with the lines seen */
}

static void *eng_create(const rt_sim_config *c, rt_err *e)
{
    rt_msim *m = rt_msim_new(c->sizes, c->nsizes, c->line, e);
    if (m) rt_msim_set_fullline(m, c->write_miss_fullline);
    return m;
}

static void eng_destroy(void *st) { rt_msim_free(st); }
static int eng_access(void *st, const rt_access *a, size_t n) { return rt_msim_put(st, a, n); }
static void eng_finish(void *st, int flush)
{
    if (flush) rt_msim_flush(st);
}
static void eng_counts(const void *st, int i, int cls, int gen, rt_sim_counts *out) { rt_msim_get_gen(st, i, cls, gen, out); }
static int eng_check(const void *st, rt_err *e) { return rt_msim_check(st, e); }
static void eng_repeats(void *st, const uint64_t *cnt) { rt_msim_add_repeats(st, cnt); }

const rt_cache_engine rt_engine_stack = {
    .name = "exact-stack",
    .repl = "lru",
    .caps = RT_ENG_FULLASSOC | RT_ENG_ONEPASS | RT_ENG_REPEATS,
    .state_bytes = eng_state_bytes,
    .create = eng_create,
    .destroy = eng_destroy,
    .access = eng_access,
    .finish = eng_finish,
    .counts = eng_counts,
    .check = eng_check,
    .repeats = eng_repeats,
};
