/*
 * setassoc.c -- set-associative (and direct-mapped, and fully associative)
 * cache of one size, any line size, any write policy, LRU or any
 * replacement policy of the engine table (engine.h); and the table's
 * per-size engine (one such cache per size).
 *
 * Mapping: line = addr / line_size, set = line % nsets (so 48-byte lines, as
 * in Purcell et al.'s 64 KB direct-mapped texture cache, work: nothing needs
 * a power of two). Each set owns `assoc` consecutive slots; its resident
 * lines form an LRU list (head = most recent) threaded through the slots.
 * A hash table (line -> slot) finds a line in O(1) whatever the
 * associativity, so the same code serves direct-mapped caches and one-set
 * fully associative caches with a non-default write policy.
 *
 * Replacement: without a policy (LRU, rt_sim_config.repl = 0) the set's
 * list above. With one (rt_repl_ops), the list is not kept (head and tail
 * stay NIL): a set fills its ways in order, the policy is told of every
 * hit and fill and names the victim of a full set, over two words of
 * state per way (rt_repl_set: one per way, one for the set) and the
 * cache's random state, seeded from rt_sim_config.seed.
 *
 * Policies (Dinero IV semantics, docs/cachesim.md):
 *   write-back     a write hit or allocated write miss marks the line dirty;
 *                  evicting a dirty line costs one line (a write-back),
 *                  charged to the class and ray generation of the last
 *                  write to the line;
 *   write-through  each write touch sends the bytes it covers inside that
 *                  line to memory (wt_bytes); lines are never dirty;
 *   write-allocate a write miss fetches the line like a read miss;
 *   no-write-allocate a write miss leaves the cache unchanged and sends its
 *                  bytes to memory (wt_bytes), whatever the hit policy;
 *   full-line writes (rt_sa_set_fullline, Dinero IV's rule) an allocating
 *                  write miss whose bytes cover the whole line fetches
 *                  nothing (counted in nofetch);
 *   streaming stores (rt_access.write == RT_WRITE_STREAM) an allocating
 *                  miss fetches nothing on any line, whole or not (the
 *                  same no-fetch path, counted in nofetch); a hit is an
 *                  ordinary write; with no-write-allocate they write
 *                  around the cache like any write;
 *   flush          (rt_sa_flush, Dinero IV's end of run) every dirty line
 *                  is written back, charged to its last writer.
 * Counters are kept per (class, generation) index (sim_int.h); per-class
 * figures are sums over the generations.
 * Coherence (rt_sa_drop, for cachesim/mcore.c): a line another core's
 * write invalidates leaves a HOLE in its set, refilled before any fresh way
 * or victim (the lowest hole first, as hardware fills an invalid way); a
 * hole is in no list and not in the table. Without invalidations (every
 * one-core cache) there are none and nothing changes.
 * Invariants (rt_sa_check): each set's list (LRU; with a policy, its first
 * used[s] slots less the holes) has used[s] - holes[s] <= assoc slots, all
 * inside the set, each in the hash table under its line, whose set is s; a
 * dirty slot's writer index is valid; per index, misses <= accesses,
 * write-backs <= write touches, no-fetch misses <= write misses (none with
 * no-write-allocate, and without full-line writes at most the streaming
 * touches); with a policy, the policy's own check on every set.
 */
#include "setassoc.h"
#include "engine.h"
#include "sim_int.h"

#include <stdlib.h>
#include <string.h>

#define NIL UINT32_MAX

typedef struct saslot {
    uint64_t line;  /* resident line number */
    uint32_t prev;  /* more recent slot in the set, NIL at head */
    uint32_t next;  /* less recent, NIL at tail */
    uint8_t dirty;  /* write-back: modified since fetched */
    uint8_t wcg;    /* (class, generation) index of the last write */
    uint8_t hole;   /* emptied by rt_sa_drop (a coherence invalidation): free, refilled first */
} saslot;

typedef struct saset {
    uint32_t head, tail; /* MRU / LRU slot, NIL when empty */
    uint32_t used;       /* slots filled so far (the first `used` of the set), holes included */
    uint32_t holes;      /* of them, emptied by rt_sa_drop and not refilled yet */
} saset;

typedef struct sahash {
    uint64_t key; /* line */
    uint32_t val; /* slot, NIL = empty */
} sahash;

struct rt_sa {
    uint64_t size;       /* bytes */
    uint32_t line;       /* bytes per line */
    uint32_t assoc;      /* ways per set */
    uint64_t nsets;      /* sets */
    int wt, nwa;         /* write-through, no-write-allocate */
    int fullline;        /* an allocating write miss covering its line fetches nothing */
    saslot *slots;       /* nsets * assoc */
    saset *sets;         /* nsets */
    sahash *ht;          /* line -> slot */
    const rt_repl_ops *ops; /* replacement policy, NULL = the LRU lists */
    uint32_t *pw, *ps;   /* the policy's words: per way, per set (assoc per set), nsets * assoc each */
    uint64_t rng;        /* the policy's random state */
    rt_sink *below;      /* the next level of a hierarchy, or NULL */
    rt_access *out;      /* its references, in order, sent when a batch ends or the buffer fills */
    size_t nout;
    int below_err;       /* the level below refused a batch */
    uint64_t hmask;      /* table size - 1 */
    int hshift;          /* 64 - log2(table size) */
    /* counters per (class, generation) index */
    uint64_t acc[RT_SIM_NCG], rm[RT_SIM_NCG], wm[RT_SIM_NCG], wb[RT_SIM_NCG], wtb[RT_SIM_NCG];
    uint64_t nf[RT_SIM_NCG]; /* write misses allocated without a fetch */
    uint64_t wr[RT_SIM_NCG]; /* write touches (for rt_sa_check) */
    uint64_t sw[RT_SIM_NCG]; /* streaming-store touches (for rt_sa_check) */
};

static inline uint64_t hs(const rt_sa *c, uint64_t line) { return (line * 0x9E3779B97F4A7C15ULL) >> c->hshift; }

static uint32_t h_find(const rt_sa *c, uint64_t line)
{
    for (uint64_t i = hs(c, line);; i = (i + 1) & c->hmask) {
        if (c->ht[i].val == NIL) return NIL;
        if (c->ht[i].key == line) return c->ht[i].val;
    }
}

static void h_insert(rt_sa *c, uint64_t line, uint32_t val)
{
    uint64_t i = hs(c, line);
    while (c->ht[i].val != NIL) i = (i + 1) & c->hmask;
    c->ht[i].key = line;
    c->ht[i].val = val;
}

static void h_delete(rt_sa *c, uint64_t line)
{
    uint64_t i = hs(c, line);
    while (c->ht[i].val == NIL || c->ht[i].key != line) i = (i + 1) & c->hmask;
    for (uint64_t j = i;;) {
        j = (j + 1) & c->hmask;
        if (c->ht[j].val == NIL) break;
        uint64_t h = hs(c, c->ht[j].key);
        if (i <= j ? (i < h && h <= j) : (i < h || h <= j)) continue;
        c->ht[i] = c->ht[j];
        i = j;
    }
    c->ht[i].val = NIL;
}

uint64_t rt_sa_state_bytes(uint64_t size, uint32_t line, uint32_t assoc, int policy)
{
    uint64_t nlines = line ? size / line : 0, tsize = 16;
    uint64_t nsets = assoc ? nlines / assoc : 1;
    while (tsize < 2 * nlines) tsize <<= 1;
    return sizeof(rt_sa) + nlines * sizeof(saslot) + nsets * sizeof(saset) + tsize * sizeof(uint64_t) +
           (policy ? 2 * nlines * sizeof(uint32_t) : 0);
}

rt_sa *rt_sa_new(uint64_t size, uint32_t line, uint32_t assoc, int write_through, int no_write_allocate,
                 const rt_repl_ops *ops, uint64_t seed, rt_err *e)
{
    if (line == 0 || size < line || size % line)
        return rt_errf(e, "cache size %llu is not a positive multiple of the %u-byte line", (unsigned long long)size,
                       line), NULL;
    uint64_t nlines = size / line;
    if (assoc == 0) assoc = (uint32_t)(nlines < UINT32_MAX ? nlines : 0);
    if (assoc == 0 || nlines % assoc || nlines >= (1u << 30))
        return rt_errf(e, "cache of %llu lines cannot be split into %u-way sets", (unsigned long long)nlines, assoc),
               NULL;
    rt_sa *c = rt_calloc(1, sizeof *c, e);
    if (!c) return NULL;
    c->size = size;
    c->line = line;
    c->assoc = assoc;
    c->nsets = nlines / assoc;
    c->wt = write_through;
    c->nwa = no_write_allocate;
    uint64_t tsize = 16;
    int bits = 4;
    while (tsize < 2 * nlines) tsize <<= 1, bits++;
    c->hmask = tsize - 1;
    c->hshift = 64 - bits;
    c->slots = rt_calloc(nlines, sizeof *c->slots, e);
    c->sets = rt_calloc(c->nsets, sizeof *c->sets, e);
    c->ht = rt_calloc(tsize, sizeof *c->ht, e);
    c->ops = ops;
    c->rng = seed * 0x9E3779B97F4A7C15ULL + 0x2545F4914F6CDD1DULL; /* never 0 */
    if (!c->rng) c->rng = 1;
    if (ops) {
        c->pw = rt_calloc(nlines, sizeof *c->pw, e);
        c->ps = rt_calloc(nlines, sizeof *c->ps, e);
    }
    if (!c->slots || !c->sets || !c->ht || (ops && (!c->pw || !c->ps))) {
        rt_sa_free(c);
        return NULL;
    }
    for (uint64_t i = 0; i < c->nsets; i++) c->sets[i].head = c->sets[i].tail = NIL;
    for (uint64_t i = 0; i < tsize; i++) c->ht[i].val = NIL;
    return c;
}

void rt_sa_free(rt_sa *c)
{
    if (!c) return;
    free(c->slots);
    free(c->sets);
    free(c->ht);
    free(c->pw);
    free(c->ps);
    free(c->out);
    free(c);
}

#define OUT_CAP 4096

int rt_sa_below_failed(const rt_sa *c) { return c->below_err; }

void rt_sa_add_repeats(rt_sa *c, const uint64_t *cnt)
{
    for (int cg = 0; cg < RT_SIM_NCG; cg++) c->acc[cg] += cnt[cg];
}

int rt_sa_set_below(rt_sa *c, rt_sink *below, rt_err *e)
{
    if (below && !c->out && !(c->out = rt_calloc(OUT_CAP, sizeof *c->out, e))) return -1;
    c->below = below;
    return 0;
}

/* Sends the buffered references to the level below. */
static void out_flush(rt_sa *c)
{
    if (c->nout && c->below && c->below->put(c->below, c->out, c->nout) < 0) c->below_err = 1;
    c->nout = 0;
}

/* One reference to the level below: a line fetched (write 0), a line
 * written back (write 1, whole line) or bytes written through / around. */
static inline void emit(rt_sa *c, uint64_t addr, uint32_t size, int write, unsigned cg)
{
    if (!c->below) return;
    if (c->nout == OUT_CAP) out_flush(c);
    rt_access *o = &c->out[c->nout++];
    o->addr = addr;
    o->size = size;
    o->write = (uint8_t)write;
    o->cls = (uint8_t)(cg % RT_NCLASS);
    o->gen = (uint8_t)(cg / RT_NCLASS);
}

static inline rt_repl_set repl_set(rt_sa *c, uint64_t set)
{
    rt_repl_set rs = {c->assoc, c->pw + set * c->assoc, c->ps + set * c->assoc, &c->rng};
    return rs;
}

static inline void unlink_slot(rt_sa *c, saset *s, uint32_t x)
{
    saslot *sl = c->slots;
    if (sl[x].prev != NIL) sl[sl[x].prev].next = sl[x].next;
    else s->head = sl[x].next;
    if (sl[x].next != NIL) sl[sl[x].next].prev = sl[x].prev;
    else s->tail = sl[x].prev;
}

static inline void push_head(rt_sa *c, saset *s, uint32_t x)
{
    saslot *sl = c->slots;
    sl[x].prev = NIL;
    sl[x].next = s->head;
    if (s->head != NIL) sl[s->head].prev = x;
    else s->tail = x;
    s->head = x;
}

/* One line touch; w = 0 read, 1 write, RT_WRITE_STREAM streaming store;
 * bytes = bytes of the reference inside this line. 1 on a hit, 0 on a miss. */
static inline int touch(rt_sa *c, uint64_t L, int w, unsigned cg, uint32_t bytes, uint64_t lo)
{
    uint64_t set = L % c->nsets;
    saset *s = &c->sets[set];
    saslot *sl = c->slots;
    c->acc[cg]++;
    c->wr[cg] += w != 0;
    c->sw[cg] += w == RT_WRITE_STREAM;
    uint32_t x = (s->head != NIL && sl[s->head].line == L) ? s->head : h_find(c, L);
    const int hit = x != NIL;
    uint64_t wbline = UINT64_MAX; /* a dirty victim's line, written back at the end */
    unsigned wbcg = 0;
    if (x != NIL) {
        if (c->ops) {
            rt_repl_set rs = repl_set(c, set);
            c->ops->hit(&rs, (uint32_t)(x - set * c->assoc));
        } else if (x != s->head) {
            unlink_slot(c, s, x);
            push_head(c, s, x);
        }
    } else {
        if (w) c->wm[cg]++;
        else c->rm[cg]++;
        if (w && c->nwa) { /* write around the cache */
            c->wtb[cg] += bytes;
            emit(c, lo, bytes, 1, cg);
            return 0;
        }
        int fetch = !(w == RT_WRITE_STREAM || (w && c->fullline && bytes == c->line));
        if (!fetch) c->nf[cg]++; /* streaming store, or Dinero's full-line write: nothing to fetch */
        rt_repl_set rs;
        if (c->ops) rs = repl_set(c, set);
        if (s->holes) { /* the lowest way a coherence invalidation emptied */
            x = (uint32_t)(set * c->assoc);
            while (!sl[x].hole) x++;
            sl[x].hole = 0;
            s->holes--;
        } else if (s->used < c->assoc) {
            x = (uint32_t)(set * c->assoc + s->used++);
        } else {
            x = c->ops ? (uint32_t)(set * c->assoc + c->ops->victim(&rs)) : s->tail;
            if (sl[x].dirty) {
                c->wb[sl[x].wcg]++;
                wbline = sl[x].line; /* sent down after the fetch, as Dinero IV does */
                wbcg = sl[x].wcg;
            }
            if (!c->ops) unlink_slot(c, s, x);
            h_delete(c, sl[x].line);
        }
        if (fetch) emit(c, L * c->line, c->line, 0, cg);
        sl[x].line = L;
        sl[x].dirty = 0;
        h_insert(c, L, x);
        if (c->ops) c->ops->fill(&rs, (uint32_t)(x - set * c->assoc));
        else push_head(c, s, x);
    }
    if (w) {
        if (c->wt) {
            c->wtb[cg] += bytes;
            emit(c, lo, bytes, 1, cg);
        } else {
            sl[x].dirty = 1;
            sl[x].wcg = (uint8_t)cg;
        }
    }
    if (wbline != UINT64_MAX) emit(c, wbline * c->line, c->line, 1, wbcg);
    return hit;
}

void rt_sa_put(rt_sa *c, const rt_access *a, size_t n)
{
    const uint64_t ls = c->line;
    for (size_t i = 0; i < n; i++) {
        uint64_t addr = a[i].addr;
        uint32_t sz = a[i].size ? a[i].size : 1;
        unsigned cg = rt_sim_cg(&a[i]);
        uint64_t end = addr + sz; /* exclusive */
        uint64_t first = addr / ls, last = (end - 1) / ls;
        for (uint64_t L = first; L <= last; L++) {
            uint64_t lo = L == first ? addr : L * ls;
            uint64_t hi = L == last ? end : (L + 1) * ls;
            touch(c, L, a[i].write == RT_WRITE_STREAM ? RT_WRITE_STREAM : a[i].write != 0, cg, (uint32_t)(hi - lo), lo);
        }
    }
    if (c->below) out_flush(c);
}

int rt_sa_touch(rt_sa *c, uint64_t line, int write, unsigned cg, uint32_t bytes, uint64_t lo)
{
    return touch(c, line, write, cg, bytes, lo);
}

void rt_sa_send_below(rt_sa *c)
{
    if (c->below) out_flush(c);
}

int rt_sa_drop(rt_sa *c, uint64_t line, unsigned *wcg)
{
    const uint32_t x = h_find(c, line);
    if (x == NIL) return 0;
    saset *s = &c->sets[line % c->nsets];
    if (!c->ops) unlink_slot(c, s, x);
    h_delete(c, line);
    const int dirty = c->slots[x].dirty;
    if (dirty && wcg) *wcg = c->slots[x].wcg;
    c->slots[x].dirty = 0;
    c->slots[x].hole = 1;
    s->holes++;
    return 1 + dirty;
}

int rt_sa_clean(rt_sa *c, uint64_t line, unsigned *wcg)
{
    const uint32_t x = h_find(c, line);
    if (x == NIL || !c->slots[x].dirty) return 0;
    if (wcg) *wcg = c->slots[x].wcg;
    c->slots[x].dirty = 0;
    return 1;
}

int rt_sa_holds(const rt_sa *c, uint64_t line)
{
    const uint32_t x = h_find(c, line);
    return x == NIL ? 0 : 1 + c->slots[x].dirty;
}

int rt_sa_foreach(const rt_sa *c, int (*fn)(void *ctx, uint64_t line, int dirty), void *ctx)
{
    for (uint64_t s = 0; s < c->nsets; s++)
        for (uint64_t x = s * c->assoc; x < s * c->assoc + c->sets[s].used; x++)
            if (!c->slots[x].hole && fn(ctx, c->slots[x].line, c->slots[x].dirty)) return -1;
    return 0;
}

void rt_sa_get_gen(const rt_sa *c, int cls, int gen, rt_sim_counts *out)
{
    memset(out, 0, sizeof *out);
    if (cls < 0 || cls >= RT_NCLASS || gen >= RT_MAXGEN) return;
    for (int b = gen < 0 ? 0 : gen; b < (gen < 0 ? RT_MAXGEN : gen + 1); b++) {
        int cg = b * RT_NCLASS + cls;
        out->accesses += c->acc[cg];
        out->read_misses += c->rm[cg];
        out->write_misses += c->wm[cg];
        out->writebacks += c->wb[cg];
        out->wt_bytes += c->wtb[cg];
        out->nofetch += c->nf[cg];
    }
    uint64_t fetches = out->read_misses + (c->nwa ? 0 : out->write_misses - out->nofetch);
    out->traffic_bytes = (fetches + out->writebacks) * c->line + out->wt_bytes;
}

void rt_sa_get(const rt_sa *c, int cls, rt_sim_counts *out) { rt_sa_get_gen(c, cls, -1, out); }

void rt_sa_set_fullline(rt_sa *c, int on) { c->fullline = on != 0; }

void rt_sa_flush(rt_sa *c)
{
    /* Dinero IV's order (misc.c d4copyback pushes set by set, most recent
     * first, onto a stack the level below then pops): sets from the last,
     * within a set the least recent line first (with a policy: the last way
     * first). Only the order the level below sees depends on it. */
    for (uint64_t s = c->nsets; s-- > 0;) {
        if (c->ops) {
            for (uint64_t x = s * c->assoc + c->sets[s].used; x-- > s * c->assoc;)
                if (c->slots[x].dirty) {
                    c->wb[c->slots[x].wcg]++;
                    emit(c, c->slots[x].line * c->line, c->line, 1, c->slots[x].wcg);
                    c->slots[x].dirty = 0;
                }
        } else {
            for (uint32_t x = c->sets[s].tail; x != NIL; x = c->slots[x].prev)
                if (c->slots[x].dirty) {
                    c->wb[c->slots[x].wcg]++;
                    emit(c, c->slots[x].line * c->line, c->line, 1, c->slots[x].wcg);
                    c->slots[x].dirty = 0;
                }
        }
    }
    if (c->below) out_flush(c);
}

int rt_sa_check(const rt_sa *c, rt_err *e)
{
    uint64_t total = 0;
    for (uint64_t s = 0; s < c->nsets; s++) {
        const saset *st = &c->sets[s];
        if (st->used > c->assoc || st->holes > st->used) return rt_errf(e, "setassoc: set %llu over-full", (unsigned long long)s);
        if (c->ops) {
            if (st->head != NIL || st->tail != NIL) return rt_errf(e, "setassoc: set %llu keeps a list under a policy", (unsigned long long)s);
            uint32_t holes = 0;
            for (uint32_t x = (uint32_t)(s * c->assoc); x < s * c->assoc + st->used; x++) {
                if (c->slots[x].hole) {
                    holes++;
                    if (c->slots[x].dirty) return rt_errf(e, "setassoc: slot %u is a dirty hole", x);
                    continue;
                }
                if (c->slots[x].line % c->nsets != s) return rt_errf(e, "setassoc: line in wrong set");
                if (h_find(c, c->slots[x].line) != x) return rt_errf(e, "setassoc: slot %u missing from hash", x);
                if (c->wt && c->slots[x].dirty) return rt_errf(e, "setassoc: dirty line in write-through cache");
                if (c->slots[x].dirty && c->slots[x].wcg >= RT_SIM_NCG)
                    return rt_errf(e, "setassoc: slot %u has writer index %u", x, c->slots[x].wcg);
            }
            if (holes != st->holes) return rt_errf(e, "setassoc: set %llu counts %u holes, has %u", (unsigned long long)s, st->holes, holes);
            rt_repl_set rs = repl_set((rt_sa *)c, s);
            if (c->ops->check && c->ops->check(&rs, st->used, e)) return -1;
            total += st->used - holes;
            continue;
        }
        uint32_t n = 0, prev = NIL;
        for (uint32_t x = st->head; x != NIL; x = c->slots[x].next) {
            if (++n > st->used) return rt_errf(e, "setassoc: set %llu list too long", (unsigned long long)s);
            if (x / c->assoc != s) return rt_errf(e, "setassoc: slot %u outside set %llu", x, (unsigned long long)s);
            if (c->slots[x].prev != prev) return rt_errf(e, "setassoc: broken prev link at slot %u", x);
            if (c->slots[x].line % c->nsets != s) return rt_errf(e, "setassoc: line in wrong set");
            if (h_find(c, c->slots[x].line) != x) return rt_errf(e, "setassoc: slot %u missing from hash", x);
            if (c->wt && c->slots[x].dirty) return rt_errf(e, "setassoc: dirty line in write-through cache");
            if (c->slots[x].dirty && c->slots[x].wcg >= RT_SIM_NCG)
                return rt_errf(e, "setassoc: slot %u has writer index %u", x, c->slots[x].wcg);
            prev = x;
        }
        uint32_t holes = 0;
        for (uint32_t x = (uint32_t)(s * c->assoc); x < s * c->assoc + st->used; x++) holes += c->slots[x].hole;
        if (holes != st->holes || n + holes != st->used || st->tail != prev)
            return rt_errf(e, "setassoc: set %llu count/tail mismatch", (unsigned long long)s);
        total += n;
    }
    uint64_t inhash = 0;
    for (uint64_t i = 0; i <= c->hmask; i++) inhash += c->ht[i].val != NIL;
    if (inhash != total) return rt_errf(e, "setassoc: hash has %llu entries, sets %llu", (unsigned long long)inhash,
                                        (unsigned long long)total);
    for (int cg = 0; cg < RT_SIM_NCG; cg++)
        if (c->rm[cg] + c->wm[cg] > c->acc[cg] || c->wm[cg] > c->wr[cg] || c->wb[cg] > c->wr[cg] ||
            c->nf[cg] > c->wm[cg] || (c->nf[cg] && c->nwa) || (!c->fullline && c->nf[cg] > c->sw[cg]))
            return rt_errf(e, "setassoc: counters of class %s generation %d inconsistent", rt_class_name(cg % RT_NCLASS),
                           cg / RT_NCLASS);
    return 0;
}

/* ---- the engine table's per-size entry (engine.h): one cache per size ---- */

typedef struct persize {
    int n;
    rt_sa *sa[RT_SIM_MAXSIZES];
} persize;

static uint64_t eng_state_bytes(const rt_sim_config *c)
{
    uint64_t bytes = 0;
    for (int i = 0; i < c->nsizes; i++) bytes += rt_sa_state_bytes(c->sizes[i], c->line, c->assoc, c->repl != 0);
    return bytes;
}

static void eng_destroy(void *st)
{
    persize *p = st;
    if (!p) return;
    for (int i = 0; i < p->n; i++) rt_sa_free(p->sa[i]);
    free(p);
}

static void *eng_create(const rt_sim_config *c, rt_err *e)
{
    persize *p = rt_calloc(1, sizeof *p, e);
    if (!p) return NULL;
    for (int i = 0; i < c->nsizes; i++) {
        p->sa[i] = rt_sa_new(c->sizes[i], c->line, c->assoc, c->write_through, c->no_write_allocate,
                             rt_repl_ops_for(c->repl), c->seed, e);
        if (!p->sa[i]) {
            eng_destroy(p);
            return NULL;
        }
        p->n++;
        rt_sa_set_fullline(p->sa[i], c->write_miss_fullline);
    }
    return p;
}

static int eng_access(void *st, const rt_access *a, size_t n)
{
    persize *p = st;
    for (int i = 0; i < p->n; i++) rt_sa_put(p->sa[i], a, n);
    return p->n == 1 && rt_sa_below_failed(p->sa[0]) ? -1 : 0;
}

static void eng_finish(void *st, int flush)
{
    persize *p = st;
    if (!flush) return;
    for (int i = 0; i < p->n; i++) rt_sa_flush(p->sa[i]);
}

static void eng_counts(const void *st, int i, int cls, int gen, rt_sim_counts *out)
{
    const persize *p = st;
    rt_sa_get_gen(p->sa[i], cls, gen, out);
}

static void eng_repeats(void *st, const uint64_t *cnt)
{
    persize *p = st;
    for (int i = 0; i < p->n; i++) rt_sa_add_repeats(p->sa[i], cnt);
}

static int eng_set_below(void *st, rt_sink *below, rt_err *e)
{
    persize *p = st;
    if (p->n != 1) return rt_errf(e, "a cache level that feeds another has one size, not %d", p->n);
    return rt_sa_set_below(p->sa[0], below, e);
}

static int eng_check(const void *st, rt_err *e)
{
    const persize *p = st;
    for (int i = 0; i < p->n; i++)
        if (rt_sa_check(p->sa[i], e)) return -1;
    return 0;
}

const rt_cache_engine rt_engine_persize = {
    .name = "exact-persize",
    .repl = NULL, /* LRU and every policy of rt_repl_policies */
    .caps = RT_ENG_FULLASSOC | RT_ENG_SETASSOC | RT_ENG_WT | RT_ENG_NWA,
    .state_bytes = eng_state_bytes,
    .create = eng_create,
    .destroy = eng_destroy,
    .access = eng_access,
    .finish = eng_finish,
    .counts = eng_counts,
    .check = eng_check,
    .repeats = eng_repeats, /* offered for hierarchy levels (sim.c: rt_sim_repeats) */
    .set_below = eng_set_below,
};
