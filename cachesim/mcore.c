/* mcore.c -- many cores sharing a cache hierarchy (see mcore.h).
 *
 * Each private level of each core is one set-associative cache of
 * setassoc.c (rt_sa: every replacement policy, touched one line at a time
 * so the model sees each hit and miss); what it sends down goes through a
 * small sink of this file into the core's next private level or, from the
 * last, into a buffer of references for the shared levels, one rt_hier
 * (hier.h) fed in batches. Buffering is exact: under NINE nothing the
 * shared levels do changes the private ones. */
#include "mcore.h"

#include "engine.h"
#include "setassoc.h"
#include "sim_int.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

enum { SHBUF = 4096 };

/* A set of line numbers (open addressing, linear probing, backward-shift
 * deletion): the lines a core's level lost to another core's write. */
typedef struct lineset {
    uint64_t *k; /* line + 1; 0 = empty */
    size_t cap, n;
} lineset;

typedef struct mc_below {
    rt_sink sink; /* what level p of the core sends down */
    struct rt_mc *m;
    int core, p;  /* the sending core and level */
} mc_below;

typedef struct mc_level {
    rt_sa *sa;
    lineset lost;
    mc_below below;
    uint64_t coh[RT_SIM_NCG]; /* coherence misses */
    uint64_t cwb[RT_SIM_NCG]; /* coherence write-backs (last private level only) */
    uint64_t inv[RT_SIM_NCG]; /* invalidations, by the invalidating write's index */
    uint64_t got;             /* touches that came from the level above (invariant 3) */
} mc_level;

typedef struct mc_core {
    mc_level lv[RT_HIER_MAXLEVELS];
    uint64_t sent; /* lines this core's last private level sent to the shared levels */
} mc_core;

/* The sharer filter (several cores only): a table of FBITS-bit hashes of
 * line numbers, each slot the union over the lines hashing there of the
 * cores (bit k % 63) that may hold them in a private level (set when a
 * line enters a core's first private level; never cleared, so a superset)
 * and (bit 63) whether any of them was ever written. A write probes only
 * the cores the slot names; a read miss probes none when the slot was
 * never written (geometry). Exact: it only skips probes that would find
 * nothing. Small enough (128 KB) to stay in the host's cache. */
enum { FBITS = 14 };
#define WROTE (1ull << 63)

struct rt_mc {
    rt_mc_config cfg;
    uint64_t *hold; /* the filter: may-hold core masks and the written bit */
    int np;        /* private levels */
    uint32_t line; /* their line size */
    mc_core *cores;
    rt_hier *sh;
    rt_access buf[SHBUF]; /* pending references to the shared levels */
    size_t nbuf;
    uint64_t sent; /* references handed to the shared levels */
    uint64_t refs;
    rt_sink sink;
    rt_csink csink;
    int failed;
    rt_err err;
};

/* ---- the lost-line sets ------------------------------------------------- */

static uint64_t mix(uint64_t x)
{
    x ^= x >> 33;
    x *= 0xff51afd7ed558ccdULL;
    x ^= x >> 33;
    return x;
}

static int ls_grow(lineset *s)
{
    size_t cap = s->cap ? 2 * s->cap : 64;
    uint64_t *k = calloc(cap, sizeof *k);
    if (!k) return -1;
    for (size_t i = 0; i < s->cap; i++) {
        if (!s->k[i]) continue;
        size_t j = (size_t)mix(s->k[i]) & (cap - 1);
        while (k[j]) j = (j + 1) & (cap - 1);
        k[j] = s->k[i];
    }
    free(s->k);
    s->k = k;
    s->cap = cap;
    return 0;
}

static int ls_add(lineset *s, uint64_t line)
{
    if (2 * (s->n + 1) > s->cap && ls_grow(s) < 0) return -1;
    const uint64_t key = line + 1;
    size_t j = (size_t)mix(key) & (s->cap - 1);
    while (s->k[j]) {
        if (s->k[j] == key) return 0;
        j = (j + 1) & (s->cap - 1);
    }
    s->k[j] = key;
    s->n++;
    return 0;
}

/* Removes line; 1 if it was there. */
static int ls_take(lineset *s, uint64_t line)
{
    if (!s->n) return 0;
    const uint64_t key = line + 1;
    const size_t m = s->cap - 1;
    size_t j = (size_t)mix(key) & m;
    while (s->k[j] && s->k[j] != key) j = (j + 1) & m;
    if (!s->k[j]) return 0;
    size_t hole = j;
    for (size_t i = (j + 1) & m; s->k[i]; i = (i + 1) & m) {
        size_t home = (size_t)mix(s->k[i]) & m;
        if (((i - home) & m) >= ((i - hole) & m)) {
            s->k[hole] = s->k[i];
            hole = i;
        }
    }
    s->k[hole] = 0;
    s->n--;
    return 1;
}

/* ---- configuration ------------------------------------------------------ */

/* Scopes: 1 private, 2 shared, 0 not given. */
static int set_scopes(rt_mc_config *c, const int *scope, rt_err *e)
{
    const rt_hier_config *h = &c->h;
    const int n = h->nlevels;
    int sc[RT_HIER_MAXLEVELS];
    for (int k = 0; k < n; k++)
        sc[k] = scope[k] ? scope[k] : k == n - 1 ? 2 : k == 0 ? 1 : sc[k - 1];
    if (h->inclusion != RT_INCL_NINE)
        return rt_errf(e, "--hierarchy: with cores the hierarchy is non-inclusive (nine), not %s",
                       rt_hier_inclusion_name(h->inclusion));
    if (sc[n - 1] != 2) return rt_errf(e, "--hierarchy: the last level, %s, is shared (its traffic is the memory traffic)", h->name[n - 1]);
    c->nprivate = 0;
    for (int k = 0; k < n; k++) {
        if (sc[k] == 1 && k > 0 && sc[k - 1] == 2)
            return rt_errf(e, "--hierarchy: level %s is private below the shared level %s", h->name[k], h->name[k - 1]);
        if (sc[k] != 1) continue;
        const rt_sim_config *l = &h->level[k];
        if (l->write_through || l->no_write_allocate)
            return rt_errf(e, "--hierarchy: private level %s: write-back write-allocate only (the coherence is write-back)", h->name[k]);
        if (l->line != h->level[0].line)
            return rt_errf(e, "--hierarchy: private levels have one line size (%s: %u, %s: %u)", h->name[0],
                           h->level[0].line, h->name[k], l->line);
        c->nprivate++;
    }
    return 0;
}

int rt_mc_parse_base(const char *spec, const rt_sim_config *base, rt_mc_config *c, rt_err *e)
{
    memset(c, 0, sizeof *c);
    c->ncores = 1;
    char buf[1024], out[1024];
    if (!spec || !*spec || strlen(spec) >= sizeof buf) return rt_errf(e, "--hierarchy: bad spec '%s'", spec ? spec : "");
    snprintf(buf, sizeof buf, "%s", spec);
    int scope[RT_HIER_MAXLEVELS + 2] = {0}, nl = 0;
    size_t at = 0;
    out[0] = 0;
    for (char *p = buf, *t; (t = strsep(&p, ","));) {
        if (strchr(t, '=')) {
            if (nl == RT_HIER_MAXLEVELS) return rt_errf(e, "--hierarchy: '%s': more than %d levels", spec, RT_HIER_MAXLEVELS);
            size_t len = strlen(t);
            if (len > 8 && !strcmp(t + len - 8, "/private")) scope[nl] = 1, t[len - 8] = 0;
            else if (len > 7 && !strcmp(t + len - 7, "/shared")) scope[nl] = 2, t[len - 7] = 0;
            nl++;
        }
        at += (size_t)snprintf(out + at, sizeof out - at, "%s%s", at ? "," : "", t);
    }
    rt_sim_config def;
    if (!base) rt_sim_config_default(&def);
    if (rt_hier_parse(out, base ? base : &def, &c->h, e) < 0) {
        char m[sizeof e->msg];
        snprintf(m, sizeof m, "%s", e ? e->msg : "");
        return rt_errf(e, "--hierarchy: %s", m);
    }
    return set_scopes(c, scope, e);
}

int rt_mc_parse(const char *spec, rt_mc_config *c, rt_err *e) { return rt_mc_parse_base(spec, NULL, c, e); }

int rt_mc_from_hier(const rt_hier_config *h, rt_mc_config *c, rt_err *e)
{
    memset(c, 0, sizeof *c);
    c->ncores = 1;
    c->h = *h;
    int scope[RT_HIER_MAXLEVELS] = {0};
    return set_scopes(c, scope, e);
}

void rt_mc_spec(const rt_mc_config *c, char *buf, size_t n)
{
    char h[1024];
    rt_hier_spec(&c->h, h, sizeof h);
    size_t at = 0;
    int k = 0;
    buf[0] = 0;
    for (char *p = h, *t; (t = strsep(&p, ",")) && at < n;) {
        const int level = strchr(t, '=') != NULL;
        at += (size_t)snprintf(buf + at, n - at, "%s%s%s", at ? "," : "", t,
                               !level ? "" : k < c->nprivate ? "/private" : "/shared");
        k += level;
    }
}

void rt_mc_shared_config(const rt_mc_config *c, rt_hier_config *out)
{
    memset(out, 0, sizeof *out);
    out->inclusion = RT_INCL_NINE;
    for (int k = c->nprivate; k < c->h.nlevels; k++) {
        memcpy(out->name[out->nlevels], c->h.name[k], sizeof out->name[0]);
        out->level[out->nlevels++] = c->h.level[k];
    }
}

/* ---- the model ------------------------------------------------------------ */

static int below_put(rt_sink *s, const rt_access *a, size_t n);

void rt_mc_free(rt_mc *m)
{
    if (!m) return;
    for (int k = 0; m->cores && k < m->cfg.ncores; k++)
        for (int p = 0; p < m->np; p++) {
            rt_sa_free(m->cores[k].lv[p].sa);
            free(m->cores[k].lv[p].lost.k);
        }
    free(m->cores);
    free(m->hold);
    rt_hier_free(m->sh);
    free(m);
}

rt_mc *rt_mc_new(const rt_mc_config *c, rt_err *e)
{
    if (c->ncores < 1 || c->ncores > RT_MC_MAXCORES)
        return rt_errf(e, "%d cores not in 1..%d", c->ncores, RT_MC_MAXCORES), NULL;
    if (c->nprivate < 0 || c->nprivate >= c->h.nlevels)
        return rt_errf(e, "hierarchy: %d private levels of %d (the last is shared)", c->nprivate, c->h.nlevels), NULL;
    rt_mc *m = rt_calloc(1, sizeof *m, e);
    if (!m) return NULL;
    m->cfg = *c;
    m->np = c->nprivate;
    m->line = c->h.level[0].line;
    if (!(m->cores = rt_calloc((size_t)c->ncores, sizeof *m->cores, e))) goto fail;
    if (c->ncores > 1 && m->np &&
        !(m->hold = rt_calloc((size_t)1 << FBITS, sizeof *m->hold, e)))
        goto fail;
    for (int k = 0; k < c->ncores; k++)
        for (int p = 0; p < m->np; p++) {
            const rt_sim_config *l = &c->h.level[p];
            mc_level *v = &m->cores[k].lv[p];
            if (l->nsizes != 1 || l->write_through || l->no_write_allocate || l->line != m->line) {
                rt_errf(e, "hierarchy: private level %s: one size, write-back write-allocate, line %u", c->h.name[p], m->line);
                goto fail;
            }
            rt_err se = {0};
            if (rt_sim_config_check(l, &se) < 0 || (l->repl > 0 && !rt_repl_ops_for(l->repl))) {
                rt_errf(e, "hierarchy: private level %s: %s", c->h.name[p], se.msg[0] ? se.msg : "policy not per-size");
                goto fail;
            }
            if (!(v->sa = rt_sa_new(l->sizes[0], l->line, l->assoc, 0, 0, rt_repl_ops_for(l->repl), l->seed, e))) goto fail;
            rt_sa_set_fullline(v->sa, l->write_miss_fullline);
            v->below.sink.put = below_put;
            v->below.sink.ctx = &v->below;
            v->below.m = m;
            v->below.core = k;
            v->below.p = p;
            if (rt_sa_set_below(v->sa, &v->below.sink, e) < 0) goto fail;
        }
    rt_hier_config sh;
    rt_mc_shared_config(c, &sh);
    if (!(m->sh = rt_hier_new(&sh, e))) goto fail;
    return m;
fail:
    rt_mc_free(m);
    return NULL;
}

static int sh_flush(rt_mc *m)
{
    if (!m->nbuf) return 0;
    int rc = rt_hier_put(m->sh, m->buf, m->nbuf);
    m->sent += m->nbuf;
    m->nbuf = 0;
    if (rc < 0) {
        rt_errf(&m->err, "the shared levels' state could not grow (out of memory)");
        m->failed = 1;
    }
    return rc;
}

static inline void sh_send(rt_mc *m, const rt_access *a)
{
    m->buf[m->nbuf++] = *a;
    if (m->nbuf == SHBUF) sh_flush(m);
}

/* A coherence write-back of core k's line: to the shared levels, charged
 * to its last private level. */
static void coh_writeback(rt_mc *m, int k, uint64_t line, unsigned cg)
{
    mc_core *c = &m->cores[k];
    c->lv[m->np - 1].cwb[cg]++;
    c->sent++;
    rt_access a;
    memset(&a, 0, sizeof a);
    a.addr = line * m->line;
    a.size = m->line;
    a.write = 1;
    a.cls = (uint8_t)(cg % RT_NCLASS);
    a.gen = (uint8_t)(cg / RT_NCLASS);
    sh_send(m, &a);
}

static inline size_t fslot(uint64_t line) { return (size_t)((line * 0x9E3779B97F4A7C15ULL) >> (64 - FBITS)); }
static inline uint64_t cbit(const struct rt_mc *m, int k) { (void)m; return 1ull << (k % 63); }
/* The cores other than self the slot may name (past 63 cores bits are
 * shared: self's kept, a superset). */
static inline uint64_t others_of(const rt_mc *m, uint64_t slot, int self)
{
    return slot & ~WROTE & ~(m->cfg.ncores <= 63 ? cbit(m, self) : 0);
}

/* Write-invalidate: every other core drops line from each private level
 * (one write-back when a copy was dirty). cg: the invalidating write's. */
static int invalidate(rt_mc *m, int self, uint64_t line, unsigned cg)
{
    const size_t h = fslot(line);
    m->hold[h] |= WROTE;
    const uint64_t others = others_of(m, m->hold[h], self);
    if (!others) return 0;
    for (int k = 0; k < m->cfg.ncores; k++) {
        if (k == self || !(others & cbit(m, k))) continue;
        mc_core *c = &m->cores[k];
        int dirty = 0;
        unsigned dcg = 0;
        for (int p = 0; p < m->np; p++) {
            unsigned w = 0;
            int r = rt_sa_drop(c->lv[p].sa, line, &w);
            if (!r) continue;
            c->lv[p].inv[cg]++;
            if (ls_add(&c->lv[p].lost, line) < 0) return -1;
            if (r == 2 && !dirty) dirty = 1, dcg = w; /* the innermost dirty copy is the newest */
        }
        if (dirty) coh_writeback(m, k, line, dcg);
    }
    return 0;
}

/* A read miss of core `self`: the other core holding line dirty writes it
 * back and keeps it clean. */
static void downgrade(rt_mc *m, int self, uint64_t line)
{
    const size_t h = fslot(line);
    const uint64_t slot = m->hold[h];
    m->hold[h] = slot | cbit(m, self); /* the line enters self's private levels */
    if (!(slot & WROTE)) return;
    const uint64_t others = others_of(m, slot, self);
    for (int k = 0; k < m->cfg.ncores; k++) {
        if (k == self || !(others & cbit(m, k))) continue;
        mc_core *c = &m->cores[k];
        int dirty = 0;
        unsigned dcg = 0;
        for (int p = 0; p < m->np; p++) {
            unsigned w = 0;
            if (rt_sa_clean(c->lv[p].sa, line, &w) && !dirty) dirty = 1, dcg = w;
        }
        if (dirty) {
            coh_writeback(m, k, line, dcg);
            return; /* at most one core holds it dirty (invariant 2) */
        }
    }
}

/* One touch of line at private level p of core k. */
static inline void ptouch(rt_mc *m, int k, int p, uint64_t line, int write, unsigned cg, uint32_t bytes, uint64_t lo)
{
    mc_level *v = &m->cores[k].lv[p];
    if (rt_sa_touch(v->sa, line, write, cg, bytes, lo)) return; /* a write-back write-allocate hit sends nothing */
    if (v->lost.n && ls_take(&v->lost, line)) v->coh[cg]++;
    if (p == 0 && m->hold) {
        if (!write) downgrade(m, k, line);
        else m->hold[fslot(line)] |= cbit(m, k); /* the line enters k's private levels */
    }
    rt_sa_send_below(v->sa);
}

/* What level p of a core sends down: whole lines of the private line size. */
static int below_put(rt_sink *s, const rt_access *a, size_t n)
{
    mc_below *b = s->ctx;
    rt_mc *m = b->m;
    if (b->p + 1 == m->np) {
        for (size_t i = 0; i < n; i++) sh_send(m, &a[i]);
        m->cores[b->core].sent += n;
        return m->failed ? -1 : 0;
    }
    m->cores[b->core].lv[b->p + 1].got += n;
    for (size_t i = 0; i < n; i++)
        ptouch(m, b->core, b->p + 1, a[i].addr / m->line, a[i].write, rt_sim_cg(&a[i]), a[i].size, a[i].addr);
    return m->failed ? -1 : 0;
}

int rt_mc_put(rt_mc *m, unsigned core, const rt_access *a, size_t n)
{
    if (m->failed) return -1;
    if (core >= (unsigned)m->cfg.ncores) {
        rt_errf(&m->err, "reference of core %u, the model has %d", core, m->cfg.ncores);
        m->failed = 1;
        return -1;
    }
    if (!m->np) { /* every level shared: the references go straight down */
        for (size_t i = 0; i < n; i++) sh_send(m, &a[i]);
        m->refs += n;
        return m->failed ? -1 : 0;
    }
    const uint64_t ls = m->line;
    const int many = m->cfg.ncores > 1;
    for (size_t i = 0; i < n; i++) {
        const uint64_t addr = a[i].addr;
        const uint32_t sz = a[i].size ? a[i].size : 1;
        const unsigned cg = rt_sim_cg(&a[i]);
        const int w = a[i].write == RT_WRITE_STREAM ? RT_WRITE_STREAM : a[i].write != 0;
        const uint64_t end = addr + sz, first = addr / ls, last = (end - 1) / ls;
        for (uint64_t L = first; L <= last; L++) {
            const uint64_t lo = L == first ? addr : L * ls, hi = L == last ? end : (L + 1) * ls;
            if (w && many && invalidate(m, (int)core, L, cg) < 0) {
                rt_errf(&m->err, "out of memory");
                m->failed = 1;
                return -1;
            }
            ptouch(m, (int)core, 0, L, w, cg, (uint32_t)(hi - lo), lo);
        }
        m->refs++;
    }
    return m->failed ? -1 : 0;
}

static int mc_cput(rt_csink *s, unsigned core, const rt_access *a, size_t n) { return rt_mc_put(s->ctx, core, a, n); }
static int mc_put(rt_sink *s, const rt_access *a, size_t n) { return rt_mc_put(s->ctx, 0, a, n); }

rt_csink *rt_mc_csink(rt_mc *m)
{
    m->csink.put = mc_cput;
    m->csink.ctx = m;
    return &m->csink;
}

rt_sink *rt_mc_sink(rt_mc *m)
{
    m->sink.put = mc_put;
    m->sink.ctx = m;
    return &m->sink;
}

int rt_mc_finish(rt_mc *m)
{
    if (m->failed) return -1;
    for (int k = 0; k < m->cfg.ncores; k++)
        for (int p = 0; p < m->np; p++)
            if (m->cfg.h.level[p].flush) rt_sa_flush(m->cores[k].lv[p].sa);
    if (m->failed || sh_flush(m) < 0) return -1;
    return rt_hier_finish(m->sh);
}

const char *rt_mc_error(const rt_mc *m) { return m->err.msg; }
const rt_mc_config *rt_mc_get_config(const rt_mc *m) { return &m->cfg; }
const rt_hier *rt_mc_shared_hier(const rt_mc *m) { return m->sh; }
const rt_sim *rt_mc_shared(const rt_mc *m) { return rt_hier_level(m->sh, m->cfg.h.nlevels - m->np - 1); }
uint64_t rt_mc_refs(const rt_mc *m) { return m->refs; }

void rt_mc_get_level(const rt_mc *m, int p, int core, int cls, int gen, rt_mc_counts *out)
{
    memset(out, 0, sizeof *out);
    if (p < 0 || p >= m->np || core < 0 || core >= m->cfg.ncores || cls < -1 || cls >= RT_NCLASS || gen >= RT_MAXGEN) return;
    const mc_level *v = &m->cores[core].lv[p];
    for (int c = cls < 0 ? 0 : cls; c < (cls < 0 ? RT_NCLASS : cls + 1); c++) {
        rt_sim_counts s;
        rt_sa_get_gen(v->sa, c, gen, &s);
        out->accesses += s.accesses;
        out->misses += s.read_misses + s.write_misses;
        out->nofetch += s.nofetch;
        out->writebacks += s.writebacks;
        out->traffic_bytes += s.traffic_bytes;
        for (int g = gen < 0 ? 0 : gen; g < (gen < 0 ? RT_MAXGEN : gen + 1); g++) {
            const int cg = g * RT_NCLASS + c;
            out->coherence_misses += v->coh[cg];
            out->coh_writebacks += v->cwb[cg];
            out->writebacks += v->cwb[cg];
            out->traffic_bytes += v->cwb[cg] * m->line;
            out->invalidations += v->inv[cg];
        }
    }
}

void rt_mc_get(const rt_mc *m, int core, int cls, rt_mc_counts *out) { rt_mc_get_level(m, 0, core, cls, -1, out); }

/* ---- the checker ------------------------------------------------------- */

typedef struct chk {
    const rt_mc *m;
    int core;
    uint64_t line; /* the offending line */
    int other;
} chk;

static int dirty_alone(void *ctx, uint64_t line, int dirty)
{
    chk *c = ctx;
    if (!dirty) return 0;
    for (int k = 0; k < c->m->cfg.ncores; k++) {
        if (k == c->core) continue;
        for (int p = 0; p < c->m->np; p++)
            if (rt_sa_holds(c->m->cores[k].lv[p].sa, line)) {
                c->line = line;
                c->other = k;
                return 1;
            }
    }
    return 0;
}

int rt_mc_check(const rt_mc *m, rt_err *e)
{
    uint64_t down = 0;
    for (int k = 0; k < m->cfg.ncores; k++) {
        const mc_core *c = &m->cores[k];
        for (int p = 0; p < m->np; p++) {
            const mc_level *v = &c->lv[p];
            if (rt_sa_check(v->sa, e) < 0) return -1; /* 1 */
            uint64_t sent = 0;
            for (int cl = 0; cl < RT_NCLASS; cl++)
                for (int g = 0; g < RT_MAXGEN; g++) {
                    rt_sim_counts s;
                    rt_sa_get_gen(v->sa, cl, g, &s);
                    const int cg = g * RT_NCLASS + cl;
                    if (v->coh[cg] > s.read_misses + s.write_misses)
                        return rt_errf(e, "invariant 1: core %d level %s class %d: %llu coherence misses of %llu", k,
                                       m->cfg.h.name[p], cl, (unsigned long long)v->coh[cg],
                                       (unsigned long long)(s.read_misses + s.write_misses));
                    sent += s.read_misses + s.write_misses - s.nofetch + s.writebacks;
                    if (p + 1 < m->np && v->cwb[cg]) return rt_errf(e, "invariant 4: coherence write-backs at inner level %s", m->cfg.h.name[p]);
                }
            if (p + 1 < m->np && c->lv[p + 1].got != sent) /* 3 */
                return rt_errf(e, "invariant 3: core %d: level %s sent %llu lines, %s got %llu", k, m->cfg.h.name[p],
                               (unsigned long long)sent, m->cfg.h.name[p + 1], (unsigned long long)c->lv[p + 1].got);
            if (p + 1 == m->np) {
                uint64_t cw = 0;
                for (int cg = 0; cg < RT_SIM_NCG; cg++) cw += v->cwb[cg];
                if (sent + cw != c->sent)
                    return rt_errf(e, "invariant 4: core %d: level %s sent %llu lines and %llu coherence write-backs, counted %llu", k,
                                   m->cfg.h.name[p], (unsigned long long)sent, (unsigned long long)cw, (unsigned long long)c->sent);
            }
            chk ck = {m, k, 0, -1};
            if (rt_sa_foreach(v->sa, dirty_alone, &ck) < 0) /* 2 */
                return rt_errf(e, "invariant 2: line %llu dirty in core %d's %s and held by core %d",
                               (unsigned long long)ck.line, k, m->cfg.h.name[p], ck.other);
        }
        down += c->sent;
    }
    if (!m->np) down = m->refs;
    if (down != m->sent + m->nbuf || rt_hier_refs(m->sh) != m->sent)
        return rt_errf(e, "invariant 4: the private levels sent %llu lines, the shared levels got %llu (+%zu pending)",
                       (unsigned long long)down, (unsigned long long)rt_hier_refs(m->sh), m->nbuf);
    return rt_hier_check(m->sh, e);
}
