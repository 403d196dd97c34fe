/*
 * incl.c -- inclusive and exclusive hierarchies, one chain of levels per
 * last-level size (see incl.h for the model).
 *
 * Each level of a chain is a cache: slots (line, dirty, classes, links of
 * its set's recency list, most recent first) and an open-addressing table
 * line -> slot. An LRU level evicts its list's tail and fills any free
 * slot. A level with another policy (rt_repl_ops, engine.h: fifo, random,
 * plru, srrip, brrip) keeps the list too (for the checker) but its slot
 * s*ways + w is way w of set s: a hit calls the policy's hit hook, a fill
 * takes the lowest free way of the set and calls fill, and the victim hook
 * is asked only of a full set. A line that leaves without an eviction
 * (back-invalidated, or taken out by an exclusive lookup) leaves its way
 * free and the policy is not told: the next fill of the set takes that way
 * first, as a cache fills invalid ways before it replaces.
 *
 * INVARIANTS (rt_incl_check):
 *   I1 every level: each set's list holds exactly its used slots, linked
 *      both ways, at most ways of them, each line in the set its number
 *      selects, and the table finds every resident line at its slot and
 *      holds no other;
 *   I2 inclusive: every line resident in level k is resident in level k+1;
 *   I3 exclusive: no line is resident in two levels;
 *   I4 counters: read + write misses <= accesses at every level and class.
 */
#include "incl.h"

#include "engine.h"

#include <stdlib.h>
#include <string.h>

#define NIL UINT32_MAX

typedef struct islot {
    uint64_t line;
    uint32_t prev, next;
    uint8_t dirty, cls, wcls; /* the last toucher's and the last writer's class */
    uint8_t valid;            /* holds a line */
} islot;

typedef struct ilevel {
    uint64_t nsets;
    uint32_t ways;
    islot *slot;     /* nsets * ways; set s owns [s*ways, (s+1)*ways) */
    uint32_t *head, *tail, *used, *freel; /* per set: list ends, used count, a free slot stack top */
    uint32_t *fnext; /* free-list links (LRU levels) */
    const rt_repl_ops *ops; /* the policy's hooks, NULL = LRU (the list) */
    uint32_t *pw, *ps;      /* ops: per way and per set words (rt_repl_set), ways of each per set */
    uint32_t *lowfree;      /* ops: per set, every way below it holds a line */
    uint64_t rng;           /* ops: the policy's random state, seeded as the per-size engine's */
    uint64_t *hkey;  /* line + 1, 0 = empty */
    uint32_t *hval;
    uint64_t hmask;
    uint64_t acc[RT_NCLASS], rm[RT_NCLASS], wm[RT_NCLASS], wb[RT_NCLASS], mv[RT_NCLASS], bi[RT_NCLASS],
        biwb[RT_NCLASS];
} ilevel;

typedef struct chain {
    int n;
    ilevel lv[RT_HIER_MAXLEVELS];
} chain;

struct rt_incl {
    rt_hier_config cfg;
    int excl;
    uint32_t line;
    int nchains;
    chain *ch;
    uint64_t refs;
};

/* ---- one level ---- */

static inline uint64_t hh(const ilevel *l, uint64_t line) { return (line * 0x9E3779B97F4A7C15ULL) & l->hmask; }

static uint32_t find(const ilevel *l, uint64_t line)
{
    for (uint64_t i = hh(l, line);; i = (i + 1) & l->hmask) {
        if (l->hkey[i] == 0) return NIL;
        if (l->hkey[i] == line + 1) return l->hval[i];
    }
}

static void hput(ilevel *l, uint64_t line, uint32_t v)
{
    uint64_t i = hh(l, line);
    while (l->hkey[i]) i = (i + 1) & l->hmask;
    l->hkey[i] = line + 1;
    l->hval[i] = v;
}

static void hdel(ilevel *l, uint64_t line)
{
    uint64_t i = hh(l, line);
    while (l->hkey[i] != line + 1) i = (i + 1) & l->hmask;
    /* backward-shift deletion keeps every probe sequence unbroken */
    for (uint64_t j = i;;) {
        l->hkey[i] = 0;
        for (;;) {
            j = (j + 1) & l->hmask;
            if (!l->hkey[j]) return;
            uint64_t k = hh(l, l->hkey[j] - 1);
            if (i <= j ? (i < k && k <= j) : (i < k || k <= j)) continue;
            break;
        }
        l->hkey[i] = l->hkey[j];
        l->hval[i] = l->hval[j];
        i = j;
    }
}

static int level_init(ilevel *l, uint64_t size, uint32_t line, uint32_t assoc, int repl, uint64_t seed, rt_err *e)
{
    memset(l, 0, sizeof *l);
    l->ops = rt_repl_ops_for(repl);
    l->rng = seed * 0x9E3779B97F4A7C15ULL + 0x2545F4914F6CDD1DULL; /* as setassoc.c; never 0 */
    if (!l->rng) l->rng = 1;
    uint64_t lines = size / line;
    l->ways = assoc ? assoc : (uint32_t)lines;
    l->nsets = lines / l->ways;
    uint64_t cap = 16;
    while (cap < 2 * lines) cap *= 2;
    l->hmask = cap - 1;
    l->slot = rt_calloc(lines, sizeof *l->slot, e);
    l->head = rt_calloc(l->nsets, sizeof *l->head, e);
    l->tail = rt_calloc(l->nsets, sizeof *l->tail, e);
    l->used = rt_calloc(l->nsets, sizeof *l->used, e);
    l->freel = rt_calloc(l->nsets, sizeof *l->freel, e);
    l->fnext = rt_calloc(lines, sizeof *l->fnext, e);
    l->hkey = rt_calloc(cap, sizeof *l->hkey, e);
    l->hval = rt_calloc(cap, sizeof *l->hval, e);
    if (!l->slot || !l->head || !l->tail || !l->used || !l->freel || !l->fnext || !l->hkey || !l->hval) return -1;
    if (l->ops) {
        l->pw = rt_calloc(lines, sizeof *l->pw, e);
        l->ps = rt_calloc(lines, sizeof *l->ps, e);
        l->lowfree = rt_calloc(l->nsets, sizeof *l->lowfree, e);
        if (!l->pw || !l->ps || !l->lowfree) return -1;
    }
    for (uint64_t s = 0; s < l->nsets; s++) {
        l->head[s] = l->tail[s] = NIL;
        l->freel[s] = (uint32_t)(s * l->ways);
        for (uint32_t w = 0; w < l->ways; w++)
            l->fnext[s * l->ways + w] = w + 1 < l->ways ? (uint32_t)(s * l->ways + w + 1) : NIL;
    }
    return 0;
}

static void level_free(ilevel *l)
{
    free(l->slot);
    free(l->head);
    free(l->tail);
    free(l->used);
    free(l->freel);
    free(l->fnext);
    free(l->hkey);
    free(l->hval);
    free(l->pw);
    free(l->ps);
    free(l->lowfree);
}

static inline rt_repl_set rset(ilevel *l, uint64_t s)
{
    rt_repl_set rs = {l->ways, l->pw + s * l->ways, l->ps + s * l->ways, &l->rng};
    return rs;
}

/* The slot a full set gives up: the list's tail (LRU) or the policy's victim. */
static uint32_t victim(ilevel *l, uint64_t s)
{
    if (!l->ops) return l->tail[s];
    rt_repl_set rs = rset(l, s);
    return (uint32_t)(s * l->ways + l->ops->victim(&rs));
}

static void unlink_s(ilevel *l, uint64_t s, uint32_t x)
{
    islot *sl = l->slot;
    if (sl[x].prev != NIL) sl[sl[x].prev].next = sl[x].next;
    else l->head[s] = sl[x].next;
    if (sl[x].next != NIL) sl[sl[x].next].prev = sl[x].prev;
    else l->tail[s] = sl[x].prev;
}

static void push_front(ilevel *l, uint64_t s, uint32_t x)
{
    islot *sl = l->slot;
    sl[x].prev = NIL;
    sl[x].next = l->head[s];
    if (l->head[s] != NIL) sl[l->head[s]].prev = x;
    else l->tail[s] = x;
    l->head[s] = x;
}

/* Takes slot x out of the level (its set, the table) and frees it. */
static void remove_slot(ilevel *l, uint32_t x)
{
    uint64_t s = l->slot[x].line % l->nsets;
    unlink_s(l, s, x);
    hdel(l, l->slot[x].line);
    l->used[s]--;
    l->slot[x].valid = 0;
    if (l->ops) {
        uint32_t w = (uint32_t)(x - s * l->ways);
        if (w < l->lowfree[s]) l->lowfree[s] = w;
    } else {
        l->fnext[x] = l->freel[s];
        l->freel[s] = x;
    }
}

/* Places line (absent, its set not full) at the most recent position. */
static uint32_t insert(ilevel *l, uint64_t line, int dirty, unsigned cls, unsigned wcls)
{
    uint64_t s = line % l->nsets;
    uint32_t x;
    if (l->ops) { /* the lowest free way */
        uint32_t w = l->lowfree[s];
        while (l->slot[s * l->ways + w].valid) w++;
        l->lowfree[s] = w + 1;
        x = (uint32_t)(s * l->ways + w);
        rt_repl_set rs = rset(l, s);
        l->ops->fill(&rs, w);
    } else {
        x = l->freel[s];
        l->freel[s] = l->fnext[x];
    }
    l->used[s]++;
    l->slot[x].valid = 1;
    islot *q = &l->slot[x];
    q->line = line;
    q->dirty = (uint8_t)dirty;
    q->cls = (uint8_t)cls;
    q->wcls = (uint8_t)wcls;
    push_front(l, s, x);
    hput(l, line, x);
    return x;
}

static void touch_hit(ilevel *l, uint32_t x, int w, unsigned cls)
{
    uint64_t s = l->slot[x].line % l->nsets;
    if (l->ops) {
        rt_repl_set rs = rset(l, s);
        l->ops->hit(&rs, (uint32_t)(x - s * l->ways));
    }
    if (l->head[s] != x) {
        unlink_s(l, s, x);
        push_front(l, s, x);
    }
    l->slot[x].cls = (uint8_t)cls;
    if (w) {
        l->slot[x].dirty = 1;
        l->slot[x].wcls = (uint8_t)cls;
    }
}

/* ---- inclusive ---- */

/* Level j >= 1 evicts slot x: the levels above lose the line. */
static void back_invalidate(chain *c, int j, uint32_t x)
{
    islot *v = &c->lv[j].slot[x];
    for (int i = 0; i < j; i++) {
        ilevel *u = &c->lv[i];
        uint32_t y = find(u, v->line);
        if (y == NIL) continue;
        u->bi[u->slot[y].cls]++;
        if (u->slot[y].dirty) {
            u->biwb[u->slot[y].wcls]++;
            if (!v->dirty) v->wcls = u->slot[y].wcls;
            v->dirty = 1;
        }
        remove_slot(u, y);
    }
}

static void incl_touch(chain *c, int k, uint64_t L, int w, unsigned cls)
{
    ilevel *l = &c->lv[k];
    l->acc[cls]++;
    uint32_t x = find(l, L);
    if (x != NIL) {
        touch_hit(l, x, w, cls);
        return;
    }
    if (w) l->wm[cls]++;
    else l->rm[cls]++;
    if (k + 1 < c->n) incl_touch(c, k + 1, L, 0, cls); /* fetch (may back-invalidate here) */
    uint64_t s = L % l->nsets;
    if (l->used[s] == l->ways) {
        uint32_t v = victim(l, s);
        if (k > 0) back_invalidate(c, k, v);
        islot q = l->slot[v];
        remove_slot(l, v);
        if (q.dirty) {
            l->wb[q.wcls]++;
            if (k + 1 < c->n) incl_touch(c, k + 1, q.line, 1, q.wcls);
        }
    }
    insert(l, L, w, cls, cls);
}

/* ---- exclusive ---- */

/* Moves a victim (line, dirty, classes) into level k, cascading. */
static void excl_down(chain *c, int k, const islot *q)
{
    if (k == c->n) return; /* memory: the last level counted it */
    ilevel *l = &c->lv[k];
    uint64_t s = q->line % l->nsets;
    if (l->used[s] == l->ways) {
        uint32_t v = victim(l, s);
        islot o = l->slot[v];
        remove_slot(l, v);
        if (o.dirty) l->wb[o.wcls]++;
        else if (k + 1 < c->n) l->mv[o.cls]++;
        excl_down(c, k + 1, &o);
    }
    insert(l, q->line, q->dirty, q->cls, q->wcls);
}

static void excl_touch(chain *c, uint64_t L, int w, unsigned cls)
{
    ilevel *l0 = &c->lv[0];
    l0->acc[cls]++;
    uint32_t x = find(l0, L);
    if (x != NIL) {
        touch_hit(l0, x, w, cls);
        return;
    }
    if (w) l0->wm[cls]++;
    else l0->rm[cls]++;
    int dirty = 0;
    unsigned wcls = cls;
    for (int j = 1; j < c->n; j++) {
        ilevel *l = &c->lv[j];
        l->acc[cls]++;
        uint32_t y = find(l, L);
        if (y != NIL) {
            dirty = l->slot[y].dirty;
            wcls = l->slot[y].wcls;
            remove_slot(l, y);
            break;
        }
        l->rm[cls]++; /* a lookup for level 0: a read */
    }
    uint64_t s = L % l0->nsets;
    if (l0->used[s] == l0->ways) {
        uint32_t v = victim(l0, s);
        islot o = l0->slot[v];
        remove_slot(l0, v);
        if (o.dirty) l0->wb[o.wcls]++;
        else if (c->n > 1) l0->mv[o.cls]++;
        excl_down(c, 1, &o);
    }
    if (w) {
        dirty = 1;
        wcls = cls;
    }
    insert(l0, L, dirty, cls, wcls);
}

/* ---- the chains ---- */

rt_incl *rt_incl_new(const rt_hier_config *h, rt_err *e)
{
    if (h->inclusion != RT_INCL_INCLUSIVE && h->inclusion != RT_INCL_EXCLUSIVE)
        return rt_errf(e, "rt_incl: the hierarchy is neither inclusive nor exclusive"), NULL;
    rt_incl *x = rt_calloc(1, sizeof *x, e);
    if (!x) return NULL;
    x->cfg = *h;
    x->excl = h->inclusion == RT_INCL_EXCLUSIVE;
    x->line = h->level[0].line;
    const rt_sim_config *last = &h->level[h->nlevels - 1];
    x->nchains = last->nsizes;
    if (!(x->ch = rt_calloc((size_t)x->nchains, sizeof *x->ch, e))) goto fail;
    for (int i = 0; i < x->nchains; i++) {
        chain *c = &x->ch[i];
        for (int k = 0; k < h->nlevels; k++) {
            const rt_sim_config *lc = &h->level[k];
            uint64_t size = k + 1 == h->nlevels ? lc->sizes[i] : lc->sizes[0];
            c->n = k + 1;
            if (level_init(&c->lv[k], size, lc->line, lc->assoc, lc->repl, lc->seed, e)) goto fail;
        }
    }
    return x;
fail:
    rt_incl_free(x);
    return NULL;
}

void rt_incl_free(rt_incl *x)
{
    if (!x) return;
    for (int i = 0; x->ch && i < x->nchains; i++)
        for (int k = 0; k < x->ch[i].n; k++) level_free(&x->ch[i].lv[k]);
    free(x->ch);
    free(x);
}

int rt_incl_put(rt_incl *x, const rt_access *a, size_t n)
{
    const uint64_t ls = x->line;
    for (size_t r = 0; r < n; r++) {
        uint64_t addr = a[r].addr;
        uint32_t sz = a[r].size ? a[r].size : 1;
        unsigned cls = a[r].cls < RT_NCLASS ? a[r].cls : RT_CLS_FB;
        int w = a[r].write != 0;
        uint64_t first = addr / ls, last = (addr + sz - 1) / ls;
        for (int i = 0; i < x->nchains; i++)
            for (uint64_t L = first; L <= last; L++) {
                if (x->excl) excl_touch(&x->ch[i], L, w, cls);
                else incl_touch(&x->ch[i], 0, L, w, cls);
            }
    }
    x->refs += n;
    return 0;
}

uint64_t rt_incl_refs(const rt_incl *x) { return x->refs; }

void rt_incl_get(const rt_incl *x, int k, int i, int cls, rt_hier_counts *out)
{
    memset(out, 0, sizeof *out);
    if (i < 0 || i >= x->nchains || k < 0 || k >= x->cfg.nlevels || cls < 0 || cls >= RT_NCLASS) return;
    const ilevel *l = &x->ch[i].lv[k];
    out->c.accesses = l->acc[cls];
    out->c.read_misses = l->rm[cls];
    out->c.write_misses = l->wm[cls];
    out->c.writebacks = l->wb[cls];
    out->backinvals = l->bi[cls];
    out->bi_writebacks = l->biwb[cls];
    out->c.traffic_bytes = (l->rm[cls] + l->wm[cls] + l->wb[cls] + l->mv[cls] + l->biwb[cls]) * (uint64_t)x->line;
}

static int level_check(const ilevel *l, const char *name, rt_err *e)
{
    uint64_t resident = 0;
    for (uint64_t s = 0; s < l->nsets; s++) {
        uint32_t cnt = 0, prev = NIL;
        for (uint32_t y = l->head[s]; y != NIL; prev = y, y = l->slot[y].next) {
            if (++cnt > l->ways || y / l->ways != s)
                return rt_errf(e, "level %s set %llu: its list leaves the set or has more than %u lines", name,
                               (unsigned long long)s, l->ways);
            if (l->slot[y].prev != prev)
                return rt_errf(e, "level %s set %llu: a broken back link", name, (unsigned long long)s);
            if (l->slot[y].line % l->nsets != s)
                return rt_errf(e, "level %s set %llu: line %llu in the wrong set", name, (unsigned long long)s,
                               (unsigned long long)l->slot[y].line);
            if (find(l, l->slot[y].line) != y)
                return rt_errf(e, "level %s: the table does not find line %llu at its slot", name,
                               (unsigned long long)l->slot[y].line);
        }
        if (cnt != l->used[s] || l->tail[s] != prev)
            return rt_errf(e, "level %s set %llu: %u lines listed, %u used", name, (unsigned long long)s, cnt,
                           l->used[s]);
        uint32_t nvalid = 0;
        for (uint32_t w = 0; w < l->ways; w++) nvalid += l->slot[s * l->ways + w].valid;
        if (nvalid != cnt)
            return rt_errf(e, "level %s set %llu: %u slots hold a line, %u listed", name, (unsigned long long)s, nvalid,
                           cnt);
        if (l->ops) {
            for (uint32_t w = 0; w < l->lowfree[s] && w < l->ways; w++)
                if (!l->slot[s * l->ways + w].valid)
                    return rt_errf(e, "level %s set %llu: way %u is free below the first free way %u", name,
                                   (unsigned long long)s, w, l->lowfree[s]);
            rt_repl_set rs = rset((ilevel *)l, s);
            /* holes left by back-invalidation: the set's state is that of a
             * set that has been full, so the policy is checked as one */
            if (l->ops->check && l->ops->check(&rs, l->ways, e)) return -1;
        }
        resident += cnt;
    }
    uint64_t keys = 0;
    for (uint64_t i = 0; i <= l->hmask; i++) keys += l->hkey[i] != 0;
    if (keys != resident)
        return rt_errf(e, "level %s: the table holds %llu lines, the sets %llu", name, (unsigned long long)keys,
                       (unsigned long long)resident);
    for (int c = 0; c < RT_NCLASS; c++)
        if (l->rm[c] + l->wm[c] > l->acc[c]) return rt_errf(e, "level %s: more misses than accesses", name);
    return 0;
}

int rt_incl_check(const rt_incl *x, rt_err *e)
{
    for (int i = 0; i < x->nchains; i++) {
        const chain *c = &x->ch[i];
        for (int k = 0; k < c->n; k++) {
            const ilevel *l = &c->lv[k];
            if (level_check(l, x->cfg.name[k], e)) return -1; /* I1, I4 */
            for (uint64_t s = 0; s < l->nsets; s++)
                for (uint32_t y = l->head[s]; y != NIL; y = l->slot[y].next) {
                    uint64_t L = l->slot[y].line;
                    if (!x->excl && k + 1 < c->n && find(&c->lv[k + 1], L) == NIL) /* I2 */
                        return rt_errf(e, "inclusive: line %llu in level %s is not in level %s", (unsigned long long)L,
                                       x->cfg.name[k], x->cfg.name[k + 1]);
                    if (x->excl) /* I3 */
                        for (int j = k + 1; j < c->n; j++)
                            if (find(&c->lv[j], L) != NIL)
                                return rt_errf(e, "exclusive: line %llu is in levels %s and %s", (unsigned long long)L,
                                               x->cfg.name[k], x->cfg.name[j]);
                }
        }
    }
    return 0;
}
