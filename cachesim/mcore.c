/* mcore.c -- many cores sharing a cache hierarchy (see mcore.h). */
#include "mcore.h"

#include <ctype.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

enum { SHBUF = 4096 };

typedef struct way {
    uint64_t tag;   /* line number + 1; 0 = empty */
    uint64_t stamp; /* last use (the core's clock); LRU = smallest */
    uint8_t dirty;
    uint8_t cls, gen; /* the last write's class and generation (dirty lines) */
} way;

/* A set of line numbers (open addressing, linear probing, backward-shift
 * deletion): the lines a core lost to another core's write. */
typedef struct lineset {
    uint64_t *k; /* line + 1; 0 = empty */
    size_t cap, n;
} lineset;

typedef struct mc_core {
    way *w;       /* nsets x assoc */
    uint64_t clock;
    lineset lost;
    rt_mc_counts c[RT_NCLASS];
    uint64_t fetches[RT_NCLASS];
} mc_core;

struct rt_mc {
    rt_mc_config cfg;
    uint32_t sets, assoc, shift; /* private level geometry; shift = log2(line) */
    mc_core *cores;
    rt_sim *sh;
    rt_access buf[SHBUF]; /* pending references to the shared level */
    size_t nbuf;
    uint64_t sent;        /* references handed to the shared level */
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
    /* backward shift: later entries of the run move up into the hole */
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

static int pow2(uint64_t v) { return v && !(v & (v - 1)); }

/* One level "NAME=SIZE/WAYS/LINE/REPL[/SCOPE]" (text[0..len)). */
static int parse_level(const char *text, size_t len, char *name, uint64_t *lo, uint64_t *hi, uint32_t *ways,
                       uint32_t *line, int *scope, rt_err *e)
{
    char b[128], *f[6];
    if (len >= sizeof b) return rt_errf(e, "--hierarchy: level '%.*s' too long", (int)len, text);
    memcpy(b, text, len);
    b[len] = 0;
    char *eq = strchr(b, '=');
    if (!eq || eq == b || eq - b >= 16) return rt_errf(e, "--hierarchy: '%s' is not NAME=SIZE/WAYS/LINE/lru[/private|shared]", b);
    *eq = 0;
    memcpy(name, b, (size_t)(eq - b) + 1);
    int nf = 0;
    for (char *p = eq + 1, *save = NULL, *t = strtok_r(p, "/", &save); t; t = strtok_r(NULL, "/", &save)) {
        if (nf == 6) break;
        f[nf++] = t;
    }
    if (nf < 4 || nf > 5) return rt_errf(e, "--hierarchy: level %s needs SIZE/WAYS/LINE/lru[/private|shared]", name);
    char *dash = strchr(f[0], '-');
    if (dash) *dash = 0;
    if (rt_parse_size(f[0], lo) < 0 || (dash && rt_parse_size(dash + 1, hi) < 0) || !*lo)
        return rt_errf(e, "--hierarchy: level %s: '%s' is not a size or a range like 1K-4M", name, f[0]);
    if (!dash) *hi = *lo;
    if (*hi < *lo || (dash && (!pow2(*lo) || !pow2(*hi))))
        return rt_errf(e, "--hierarchy: level %s: a size range runs between powers of two, low to high", name);
    uint64_t v;
    if (!strcmp(f[1], "full")) *ways = 0;
    else if (rt_parse_size(f[1], &v) < 0 || !v || v > 65536)
        return rt_errf(e, "--hierarchy: level %s: ways '%s' is not 1..65536 or full", name, f[1]);
    else *ways = (uint32_t)v;
    if (rt_parse_size(f[2], &v) < 0 || !pow2(v) || v > 65536)
        return rt_errf(e, "--hierarchy: level %s: line '%s' is not a power of two up to 64K", name, f[2]);
    *line = (uint32_t)v;
    if (strcmp(f[3], "lru")) return rt_errf(e, "--hierarchy: level %s: replacement '%s': only lru", name, f[3]);
    *scope = nf == 5 ? (!strcmp(f[4], "private") ? 1 : !strcmp(f[4], "shared") ? 2 : -1) : 0;
    if (*scope < 0) return rt_errf(e, "--hierarchy: level %s: '%s' is not private or shared", name, f[4]);
    return 0;
}

int rt_mc_parse(const char *spec, rt_mc_config *c, rt_err *e)
{
    memset(c, 0, sizeof *c);
    const char *comma = spec ? strchr(spec, ',') : NULL;
    if (!comma || strchr(comma + 1, ','))
        return rt_errf(e, "--hierarchy: '%s': two levels, a private one and a shared one, e.g. "
                          "L1=32K/8/64/lru/private,LLC=1K-4M/full/64/lru/shared", spec ? spec : "");
    uint64_t lo[2], hi[2];
    uint32_t ways[2], line[2];
    int scope[2];
    char name[2][16];
    if (parse_level(spec, (size_t)(comma - spec), name[0], &lo[0], &hi[0], &ways[0], &line[0], &scope[0], e) < 0 ||
        parse_level(comma + 1, strlen(comma + 1), name[1], &lo[1], &hi[1], &ways[1], &line[1], &scope[1], e) < 0)
        return -1;
    if ((scope[0] && scope[0] != 1) || (scope[1] && scope[1] != 2))
        return rt_errf(e, "--hierarchy: the first level is private, the last shared");
    if (line[0] != line[1]) return rt_errf(e, "--hierarchy: one line size for both levels (%u, %u)", line[0], line[1]);
    if (lo[0] != hi[0]) return rt_errf(e, "--hierarchy: the private level %s has one size", name[0]);
    const uint64_t lines = lo[0] / line[0];
    if (lo[0] % line[0] || !lines || (ways[0] && lines % ways[0]))
        return rt_errf(e, "--hierarchy: %s: %llu bytes is not a whole number of %u-way sets of %u-byte lines", name[0],
                       (unsigned long long)lo[0], ways[0], line[0]);
    if (ways[1]) return rt_errf(e, "--hierarchy: the shared level %s is fully associative (full) in this model", name[1]);
    c->ncores = 1;
    snprintf(c->priv_name, sizeof c->priv_name, "%s", name[0]);
    snprintf(c->shared_name, sizeof c->shared_name, "%s", name[1]);
    c->priv_size = lo[0];
    c->priv_assoc = ways[0] == lines ? 0 : ways[0];
    c->line = line[0];
    rt_sim_config_default(&c->shared);
    c->shared.line = line[1];
    c->shared.nsizes = 0;
    for (uint64_t s = lo[1]; s <= hi[1]; s *= 2) {
        if (c->shared.nsizes == RT_SIM_MAXSIZES) return rt_errf(e, "--hierarchy: more than %d shared sizes", RT_SIM_MAXSIZES);
        c->shared.sizes[c->shared.nsizes++] = s;
        if (s == hi[1]) break;
    }
    return rt_sim_config_check(&c->shared, e);
}

/* 32K, 4M, 1G, or the byte count. */
static void fmt_size(uint64_t v, char *buf, size_t n)
{
    static const char suf[] = "KMG";
    int k = -1;
    while (k < 2 && v >= 1024 && v % 1024 == 0) v /= 1024, k++;
    if (k < 0) snprintf(buf, n, "%llu", (unsigned long long)v);
    else snprintf(buf, n, "%llu%c", (unsigned long long)v, suf[k]);
}

void rt_mc_spec(const rt_mc_config *c, char *buf, size_t n)
{
    char ps[32], lo[32], hi[32], ways[16];
    fmt_size(c->priv_size, ps, sizeof ps);
    fmt_size(c->shared.sizes[0], lo, sizeof lo);
    fmt_size(c->shared.sizes[c->shared.nsizes - 1], hi, sizeof hi);
    if (c->priv_assoc) snprintf(ways, sizeof ways, "%u", c->priv_assoc);
    else snprintf(ways, sizeof ways, "full");
    if (c->shared.nsizes > 1)
        snprintf(buf, n, "%s=%s/%s/%u/lru/private,%s=%s-%s/full/%u/lru/shared", c->priv_name, ps, ways, c->line,
                 c->shared_name, lo, hi, c->shared.line);
    else
        snprintf(buf, n, "%s=%s/%s/%u/lru/private,%s=%s/full/%u/lru/shared", c->priv_name, ps, ways, c->line,
                 c->shared_name, lo, c->shared.line);
}

/* ---- the model ------------------------------------------------------------ */

rt_mc *rt_mc_new(const rt_mc_config *c, rt_err *e)
{
    if (c->ncores < 1 || c->ncores > RT_MC_MAXCORES)
        return rt_errf(e, "%d cores not in 1..%d", c->ncores, RT_MC_MAXCORES), NULL;
    if (!pow2(c->line) || c->shared.line != c->line || !c->priv_size || c->priv_size % c->line)
        return rt_errf(e, "hierarchy: private level of %llu bytes, lines %u and %u", (unsigned long long)c->priv_size,
                       c->line, c->shared.line), NULL;
    const uint64_t lines = c->priv_size / c->line;
    const uint32_t assoc = c->priv_assoc ? c->priv_assoc : (uint32_t)lines;
    if (lines % assoc || lines > (1u << 24)) return rt_errf(e, "hierarchy: %llu lines in %u ways", (unsigned long long)lines, assoc), NULL;
    rt_mc *m = rt_calloc(1, sizeof *m, e);
    if (!m) return NULL;
    m->cfg = *c;
    m->assoc = assoc;
    m->sets = (uint32_t)(lines / assoc);
    while ((1u << m->shift) < c->line) m->shift++;
    m->sink.put = NULL;
    if (!(m->cores = rt_calloc((size_t)c->ncores, sizeof *m->cores, e))) goto fail;
    for (int k = 0; k < c->ncores; k++)
        if (!(m->cores[k].w = rt_calloc(lines, sizeof(way), e))) goto fail;
    if (!(m->sh = rt_sim_new(&c->shared, e))) goto fail;
    return m;
fail:
    rt_mc_free(m);
    return NULL;
}

void rt_mc_free(rt_mc *m)
{
    if (!m) return;
    for (int k = 0; m->cores && k < m->cfg.ncores; k++) {
        free(m->cores[k].w);
        free(m->cores[k].lost.k);
    }
    free(m->cores);
    rt_sim_free(m->sh);
    free(m);
}

static int sh_flush(rt_mc *m)
{
    if (!m->nbuf) return 0;
    int rc = rt_sim_put(m->sh, m->buf, m->nbuf);
    m->sent += m->nbuf;
    m->nbuf = 0;
    return rc;
}

static inline int sh_send(rt_mc *m, uint64_t line, int write, unsigned cls, unsigned gen)
{
    rt_access *a = &m->buf[m->nbuf++];
    memset(a, 0, sizeof *a);
    a->addr = line << m->shift;
    a->size = m->cfg.line;
    a->write = (uint8_t)(write ? RT_WRITE_STREAM : 0);
    a->cls = (uint8_t)cls;
    a->gen = (uint8_t)gen;
    return m->nbuf == SHBUF ? sh_flush(m) : 0;
}

/* Write-invalidate: every other core drops line (a dirty copy written back). */
static int invalidate(rt_mc *m, int self, uint64_t line)
{
    const uint64_t tag = line + 1;
    const uint32_t set = (uint32_t)(line % m->sets);
    for (int k = 0; k < m->cfg.ncores; k++) {
        if (k == self) continue;
        mc_core *o = &m->cores[k];
        way *w = o->w + (size_t)set * m->assoc;
        for (uint32_t i = 0; i < m->assoc; i++) {
            if (w[i].tag != tag) continue;
            if (w[i].dirty) {
                o->c[w[i].cls].writebacks++;
                if (sh_send(m, line, 1, w[i].cls, w[i].gen) < 0) return -1;
            }
            o->c[w[i].cls].invalidations++;
            memset(&w[i], 0, sizeof w[i]);
            if (ls_add(&o->lost, line) < 0) return -1;
            break;
        }
    }
    return 0;
}

/* A read miss of core `self`: a copy dirty in another core is written back
 * first (to the shared level, charged to that core) and stays there clean. */
static int downgrade(rt_mc *m, int self, uint64_t line)
{
    const uint64_t tag = line + 1;
    const uint32_t set = (uint32_t)(line % m->sets);
    for (int k = 0; k < m->cfg.ncores; k++) {
        if (k == self) continue;
        way *w = m->cores[k].w + (size_t)set * m->assoc;
        for (uint32_t i = 0; i < m->assoc; i++)
            if (w[i].tag == tag) {
                if (w[i].dirty) {
                    m->cores[k].c[w[i].cls].writebacks++;
                    w[i].dirty = 0;
                    return sh_send(m, line, 1, w[i].cls, w[i].gen); /* at most one dirty copy */
                }
                break;
            }
    }
    return 0;
}

/* One line touch of core k. */
static inline int touch(rt_mc *m, int k, uint64_t line, unsigned write, unsigned cls, unsigned gen)
{
    mc_core *c = &m->cores[k];
    rt_mc_counts *cc = &c->c[cls];
    const uint64_t tag = line + 1, now = ++c->clock;
    way *w = c->w + (size_t)(line % m->sets) * m->assoc, *victim = w;
    cc->accesses++;
    for (uint32_t i = 0; i < m->assoc; i++) {
        if (w[i].tag == tag) {
            w[i].stamp = now;
            if (write) {
                w[i].dirty = 1;
                w[i].cls = (uint8_t)cls;
                w[i].gen = (uint8_t)gen;
                if (m->cfg.ncores > 1) return invalidate(m, k, line);
            }
            return 0;
        }
        if (w[i].stamp < victim->stamp) victim = &w[i]; /* empty ways (stamp 0) first */
    }
    cc->misses++;
    if (c->lost.n && ls_take(&c->lost, line)) cc->coherence_misses++;
    /* the order the shared level sees (mcore.h): the other cores' write-backs
     * (invalidation or downgrade), the victim's, then the fetch */
    if (write && m->cfg.ncores > 1 && invalidate(m, k, line) < 0) return -1;
    if (!write && m->cfg.ncores > 1 && downgrade(m, k, line) < 0) return -1;
    if (victim->tag && victim->dirty) {
        c->c[victim->cls].writebacks++;
        if (sh_send(m, victim->tag - 1, 1, victim->cls, victim->gen) < 0) return -1;
    }
    if (write == RT_WRITE_STREAM) cc->nofetch++;
    else {
        c->fetches[cls]++;
        if (sh_send(m, line, 0, cls, gen) < 0) return -1;
    }
    victim->tag = tag;
    victim->stamp = now;
    victim->dirty = write != 0;
    victim->cls = (uint8_t)cls;
    victim->gen = (uint8_t)gen;
    return 0;
}

int rt_mc_put(rt_mc *m, unsigned core, const rt_access *a, size_t n)
{
    if (m->failed) return -1;
    if (core >= (unsigned)m->cfg.ncores) {
        rt_errf(&m->err, "reference of core %u, the model has %d", core, m->cfg.ncores);
        m->failed = 1;
        return -1;
    }
    for (size_t i = 0; i < n; i++) {
        if (a[i].cls >= RT_NCLASS || !a[i].size) {
            rt_errf(&m->err, "reference %llu: %s", (unsigned long long)m->refs, a[i].size ? "class out of range" : "size 0");
            m->failed = 1;
            return -1;
        }
        uint64_t last = a[i].addr + (a[i].size - 1);
        if (last < a[i].addr) last = UINT64_MAX;
        const uint64_t l0 = a[i].addr >> m->shift, l1 = last >> m->shift;
        for (uint64_t l = l0;; l++) {
            if (touch(m, (int)core, l, a[i].write, a[i].cls, a[i].gen) < 0) {
                rt_errf(&m->err, "out of memory");
                m->failed = 1;
                return -1;
            }
            if (l == l1) break;
        }
        m->refs++;
    }
    return 0;
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
    if (sh_flush(m) < 0) return -1;
    return rt_sim_finish(m->sh);
}

const char *rt_mc_error(const rt_mc *m) { return m->err.msg; }
const rt_mc_config *rt_mc_get_config(const rt_mc *m) { return &m->cfg; }
const rt_sim *rt_mc_shared(const rt_mc *m) { return m->sh; }
uint64_t rt_mc_refs(const rt_mc *m) { return m->refs; }

void rt_mc_get(const rt_mc *m, int core, int cls, rt_mc_counts *out)
{
    memset(out, 0, sizeof *out);
    if (core < 0 || core >= m->cfg.ncores || cls < -1 || cls >= RT_NCLASS) return;
    const mc_core *c = &m->cores[core];
    for (int k = cls < 0 ? 0 : cls; k < (cls < 0 ? RT_NCLASS : cls + 1); k++) {
        out->accesses += c->c[k].accesses;
        out->misses += c->c[k].misses;
        out->coherence_misses += c->c[k].coherence_misses;
        out->nofetch += c->c[k].nofetch;
        out->writebacks += c->c[k].writebacks;
        out->invalidations += c->c[k].invalidations;
        out->traffic_bytes += (c->fetches[k] + c->c[k].writebacks) * m->cfg.line;
    }
}

int rt_mc_check(const rt_mc *m, rt_err *e)
{
    uint64_t down = 0;
    for (int k = 0; k < m->cfg.ncores; k++) {
        const mc_core *c = &m->cores[k];
        for (uint32_t s = 0; s < m->sets; s++) {
            const way *w = c->w + (size_t)s * m->assoc;
            for (uint32_t i = 0; i < m->assoc; i++) {
                if (!w[i].tag) continue;
                const uint64_t line = w[i].tag - 1;
                if (line % m->sets != s) return rt_errf(e, "invariant 1: core %d holds line %llu in set %u", k, (unsigned long long)line, s);
                for (uint32_t j = i + 1; j < m->assoc; j++)
                    if (w[j].tag == w[i].tag) return rt_errf(e, "invariant 1: core %d holds line %llu twice", k, (unsigned long long)line);
                if (!w[i].dirty) continue;
                for (int o = 0; o < m->cfg.ncores; o++) {
                    if (o == k) continue;
                    const way *x = m->cores[o].w + (size_t)s * m->assoc;
                    for (uint32_t j = 0; j < m->assoc; j++)
                        if (x[j].tag == w[i].tag)
                            return rt_errf(e, "invariant 3: line %llu dirty in core %d and held by core %d",
                                           (unsigned long long)line, k, o);
                }
            }
        }
        uint64_t miss = 0, got = 0;
        for (int cl = 0; cl < RT_NCLASS; cl++) {
            const rt_mc_counts *x = &c->c[cl];
            if (x->misses > x->accesses || x->coherence_misses > x->misses)
                return rt_errf(e, "invariant 2: core %d class %d: %llu accesses, %llu misses, %llu coherence", k, cl,
                               (unsigned long long)x->accesses, (unsigned long long)x->misses,
                               (unsigned long long)x->coherence_misses);
            miss += x->misses;
            got += c->fetches[cl] + x->nofetch;
            down += c->fetches[cl] + x->writebacks;
        }
        if (miss != got) return rt_errf(e, "invariant 2: core %d: %llu misses, %llu fetches and no-fetch fills", k,
                                        (unsigned long long)miss, (unsigned long long)got);
    }
    if (down != m->sent + m->nbuf)
        return rt_errf(e, "invariant 4: the private levels sent %llu lines, the shared level got %llu",
                       (unsigned long long)down, (unsigned long long)(m->sent + m->nbuf));
    return rt_sim_check(m->sh, e);
}
