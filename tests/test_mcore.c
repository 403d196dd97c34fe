/*
 * test_mcore.c -- the multi-core hierarchy (cachesim/mcore.h) against a
 * naive reference written out here from the rules of mcore.h alone: per
 * core and set an LRU list (most recent first) of lines with their dirty
 * bit and last writer, a list of lines each core lost to another core's
 * write, and per shared size one fully associative LRU list, replaying the
 * interleaved stream reference by reference, line touch by line touch.
 *
 *   - random multi-core streams (a small address range, so lines are
 *     shared and written by several cores; reads, writes and streaming
 *     stores; several classes and generations), 1, 2, 3 and 8 cores,
 *     private caches set-associative, direct-mapped and fully associative:
 *     every core's counters per class and every shared size's counters per
 *     class equal the reference's, and rt_mc_check passes;
 *   - coherence counts on a hand-made two-core stream, by hand;
 *   - the hierarchy spec: the form parses to 32K/8/64 private and
 *     the 13 sizes 1K..4M shared, its canonical spelling round-trips, and
 *     bad specs are refused naming the part.
 */
#include "check.h"
#include "mcore.h"

#include <inttypes.h>

/* ---- the naive reference ----------------------------------------------- */

typedef struct nline {
    uint64_t line;
    int dirty, cls, gen;
} nline;

typedef struct ncore {
    nline *set; /* sets x assoc, each set most recent first, n[s] valid */
    int *n;
    uint64_t *lost;
    size_t nlost, caplost;
    rt_mc_counts c[RT_NCLASS];
    uint64_t fetches[RT_NCLASS];
} ncore;

typedef struct nshared {
    uint64_t size;
    nline *l; /* most recent first */
    int n, cap;
    rt_sim_counts c[RT_NCLASS];
} nshared;

typedef struct naive {
    int ncores, sets, assoc, nsz;
    uint32_t line;
    ncore *core;
    nshared sh[RT_SIM_MAXSIZES];
} naive;

static void sh_ref(naive *N, uint64_t line, int write, int cls, int gen)
{
    for (int z = 0; z < N->nsz; z++) {
        nshared *s = &N->sh[z];
        s->c[cls].accesses++;
        int i;
        for (i = 0; i < s->n && s->l[i].line != line; i++) {}
        nline x;
        if (i < s->n) {
            x = s->l[i];
            memmove(s->l + 1, s->l, (size_t)i * sizeof *s->l);
        } else {
            if (write) s->c[cls].write_misses++, s->c[cls].nofetch++;
            else s->c[cls].read_misses++;
            if (!write) s->c[cls].traffic_bytes += N->line;
            if (s->n == s->cap) {
                nline v = s->l[s->n - 1];
                if (v.dirty) s->c[v.cls].writebacks++, s->c[v.cls].traffic_bytes += N->line;
                s->n--;
            }
            memmove(s->l + 1, s->l, (size_t)s->n * sizeof *s->l);
            s->n++;
            x.line = line;
            x.dirty = 0;
            x.cls = cls;
            x.gen = gen;
        }
        if (write) x.dirty = 1, x.cls = cls, x.gen = gen;
        s->l[0] = x;
    }
}

static int take_lost(ncore *c, uint64_t line)
{
    for (size_t i = 0; i < c->nlost; i++)
        if (c->lost[i] == line) {
            c->lost[i] = c->lost[--c->nlost];
            return 1;
        }
    return 0;
}

static void add_lost(ncore *c, uint64_t line)
{
    for (size_t i = 0; i < c->nlost; i++)
        if (c->lost[i] == line) return;
    if (c->nlost == c->caplost) c->lost = realloc(c->lost, (c->caplost = 2 * c->caplost + 8) * sizeof *c->lost);
    c->lost[c->nlost++] = line;
}

static void naive_touch(naive *N, int k, uint64_t line, int write, int cls, int gen)
{
    ncore *c = &N->core[k];
    int s = (int)(line % (uint64_t)N->sets);
    nline *set = c->set + (size_t)s * (size_t)N->assoc;
    c->c[cls].accesses++;
    int i;
    for (i = 0; i < c->n[s] && set[i].line != line; i++) {}
    int hit = i < c->n[s];
    if (!hit) {
        c->c[cls].misses++;
        if (take_lost(c, line)) c->c[cls].coherence_misses++;
    }
    if (write && N->ncores > 1) /* the others drop it */
        for (int o = 0; o < N->ncores; o++) {
            if (o == k) continue;
            ncore *d = &N->core[o];
            nline *ds = d->set + (size_t)s * (size_t)N->assoc;
            for (int j = 0; j < d->n[s]; j++) {
                if (ds[j].line != line) continue;
                if (ds[j].dirty) d->c[ds[j].cls].writebacks++, sh_ref(N, line, 1, ds[j].cls, ds[j].gen);
                d->c[ds[j].cls].invalidations++;
                memmove(ds + j, ds + j + 1, (size_t)(d->n[s] - j - 1) * sizeof *ds);
                d->n[s]--;
                add_lost(d, line);
                break;
            }
        }
    if (!hit && !write && N->ncores > 1) /* a dirty copy elsewhere is written back and kept clean */
        for (int o = 0; o < N->ncores; o++) {
            if (o == k) continue;
            ncore *d = &N->core[o];
            nline *ds = d->set + (size_t)s * (size_t)N->assoc;
            for (int j = 0; j < d->n[s]; j++)
                if (ds[j].line == line && ds[j].dirty) {
                    d->c[ds[j].cls].writebacks++;
                    sh_ref(N, line, 1, ds[j].cls, ds[j].gen);
                    ds[j].dirty = 0;
                }
        }
    nline x;
    if (hit) {
        x = set[i];
        memmove(set + 1, set, (size_t)i * sizeof *set);
    } else {
        if (c->n[s] == N->assoc) {
            nline v = set[N->assoc - 1];
            if (v.dirty) c->c[v.cls].writebacks++, sh_ref(N, v.line, 1, v.cls, v.gen);
            c->n[s]--;
        }
        if (write == RT_WRITE_STREAM) c->c[cls].nofetch++;
        else c->fetches[cls]++, sh_ref(N, line, 0, cls, gen);
        memmove(set + 1, set, (size_t)c->n[s] * sizeof *set);
        c->n[s]++;
        x.line = line;
        x.dirty = 0;
        x.cls = cls;
        x.gen = gen;
    }
    if (write) x.dirty = 1, x.cls = cls, x.gen = gen;
    set[0] = x;
}

static void naive_init(naive *N, const rt_mc_config *c)
{
    memset(N, 0, sizeof *N);
    N->ncores = c->ncores;
    N->line = c->line;
    uint64_t lines = c->priv_size / c->line;
    N->assoc = c->priv_assoc ? (int)c->priv_assoc : (int)lines;
    N->sets = (int)(lines / (uint64_t)N->assoc);
    N->core = calloc((size_t)N->ncores, sizeof *N->core);
    for (int k = 0; k < N->ncores; k++) {
        N->core[k].set = calloc(lines, sizeof(nline));
        N->core[k].n = calloc((size_t)N->sets, sizeof(int));
    }
    N->nsz = c->shared.nsizes;
    for (int z = 0; z < N->nsz; z++) {
        N->sh[z].size = c->shared.sizes[z];
        N->sh[z].cap = (int)(c->shared.sizes[z] / c->line);
        N->sh[z].l = calloc((size_t)N->sh[z].cap, sizeof(nline));
    }
}

static void naive_free(naive *N)
{
    for (int k = 0; k < N->ncores; k++) free(N->core[k].set), free(N->core[k].n), free(N->core[k].lost);
    free(N->core);
    for (int z = 0; z < N->nsz; z++) free(N->sh[z].l);
}

/* ---- the comparison ------------------------------------------------------ */

static void compare(const rt_mc_config *cfg, size_t nrefs, uint64_t span)
{
    rt_err e = {0};
    rt_mc *m = rt_mc_new(cfg, &e);
    CHECK(m, "%s", e.msg);
    if (!m) return;
    naive N;
    naive_init(&N, cfg);
    const uint32_t line = cfg->line;
    for (size_t i = 0; i < nrefs;) {
        unsigned k = (unsigned)(rnd64() % (uint64_t)cfg->ncores);
        size_t run = 1 + (size_t)(rnd64() % 20);
        rt_access a[20];
        size_t n = 0;
        for (; n < run && i < nrefs; n++, i++) {
            memset(&a[n], 0, sizeof a[n]);
            a[n].addr = RT_MM_BASE + rnd64() % span;
            a[n].size = (uint32_t)(1 + rnd64() % (2 * line));
            unsigned r = (unsigned)(rnd64() % 10);
            a[n].write = (uint8_t)(r < 6 ? 0 : r < 9 ? 1 : RT_WRITE_STREAM);
            a[n].cls = (uint8_t)(rnd64() % 4);
            a[n].gen = (uint8_t)(rnd64() % 3);
            uint64_t last = a[n].addr + a[n].size - 1;
            for (uint64_t l = a[n].addr / line; l <= last / line; l++)
                naive_touch(&N, (int)k, l, a[n].write, a[n].cls, a[n].gen);
        }
        CHECK(rt_mc_put(m, k, a, n) == 0, "%s", rt_mc_error(m));
    }
    CHECK(rt_mc_finish(m) == 0, "finish");
    CHECK(rt_mc_check(m, &e) == 0, "check: %s", e.msg);
    int bad = 0;
    for (int k = 0; k < cfg->ncores; k++)
        for (int c = 0; c < RT_NCLASS; c++) {
            rt_mc_counts got;
            rt_mc_get(m, k, c, &got);
            const rt_mc_counts *w = &N.core[k].c[c];
            uint64_t traffic = (N.core[k].fetches[c] + w->writebacks) * line;
            if ((got.accesses != w->accesses || got.misses != w->misses || got.coherence_misses != w->coherence_misses ||
                 got.nofetch != w->nofetch || got.writebacks != w->writebacks || got.invalidations != w->invalidations ||
                 got.traffic_bytes != traffic) && bad++ < 3)
                fprintf(stderr, "  %d cores, core %d class %d: acc %" PRIu64 "/%" PRIu64 " miss %" PRIu64 "/%" PRIu64
                                " coh %" PRIu64 "/%" PRIu64 " wb %" PRIu64 "/%" PRIu64 " inv %" PRIu64 "/%" PRIu64 "\n",
                        cfg->ncores, k, c, got.accesses, w->accesses, got.misses, w->misses, got.coherence_misses,
                        w->coherence_misses, got.writebacks, w->writebacks, got.invalidations, w->invalidations);
        }
    for (int z = 0; z < N.nsz; z++)
        for (int c = 0; c < RT_NCLASS; c++) {
            rt_sim_counts got;
            rt_sim_get(rt_mc_shared(m), z, c, &got);
            const rt_sim_counts *w = &N.sh[z].c[c];
            if ((got.accesses != w->accesses || got.read_misses != w->read_misses || got.write_misses != w->write_misses ||
                 got.writebacks != w->writebacks || got.traffic_bytes != w->traffic_bytes) && bad++ < 6)
                fprintf(stderr, "  %d cores, shared %" PRIu64 " class %d: acc %" PRIu64 "/%" PRIu64 " rm %" PRIu64 "/%" PRIu64
                                " wm %" PRIu64 "/%" PRIu64 " wb %" PRIu64 "/%" PRIu64 " traffic %" PRIu64 "/%" PRIu64 "\n",
                        cfg->ncores, N.sh[z].size, c, got.accesses, w->accesses, got.read_misses, w->read_misses,
                        got.write_misses, w->write_misses, got.writebacks, w->writebacks, got.traffic_bytes,
                        w->traffic_bytes);
        }
    uint64_t coh = 0;
    for (int k = 0; k < cfg->ncores; k++) {
        rt_mc_counts all;
        rt_mc_get(m, k, -1, &all);
        coh += all.coherence_misses;
    }
    CHECK(!bad, "%d counters differ from the naive reference (%d cores, %" PRIu64 " B private, %u ways)", bad,
          cfg->ncores, cfg->priv_size, cfg->priv_assoc);
    CHECK(cfg->ncores == 1 ? coh == 0 : coh > 0, "%d cores: %" PRIu64 " coherence misses", cfg->ncores, coh);
    naive_free(&N);
    rt_mc_free(m);
}

static void config(rt_mc_config *c, int cores, uint64_t priv, uint32_t assoc, uint32_t line, int nsz)
{
    memset(c, 0, sizeof *c);
    c->ncores = cores;
    snprintf(c->priv_name, sizeof c->priv_name, "L1");
    snprintf(c->shared_name, sizeof c->shared_name, "LLC");
    c->priv_size = priv;
    c->priv_assoc = assoc;
    c->line = line;
    rt_sim_config_default(&c->shared);
    c->shared.line = line;
    c->shared.nsizes = nsz;
    for (int z = 0; z < nsz; z++) c->shared.sizes[z] = (uint64_t)line * 4u << z;
}

static void test_handmade(void)
{
    rt_mc_config c;
    config(&c, 2, 1024, 2, 64, 3);
    rt_err e = {0};
    rt_mc *m = rt_mc_new(&c, &e);
    rt_access r = {RT_MM_BASE, 8, 0, RT_CLS_RAY, 0}, w = {RT_MM_BASE, 8, 1, RT_CLS_RAY, 0},
              g = {RT_MM_BASE + 4096, 8, 0, RT_CLS_TRI, 0};
    /* both read A and geometry G: clean copies in both */
    rt_mc_put(m, 0, &r, 1);
    rt_mc_put(m, 1, &r, 1);
    rt_mc_put(m, 0, &g, 1);
    rt_mc_put(m, 1, &g, 1);
    rt_mc_put(m, 1, &w, 1); /* core 1 writes A: core 0's clean copy invalidated, no write-back */
    rt_mc_put(m, 0, &r, 1); /* core 0 misses on A: a coherence miss; core 1 writes A back, keeps it clean */
    rt_mc_put(m, 0, &w, 1); /* core 0 writes A: core 1's clean copy invalidated */
    rt_mc_put(m, 1, &r, 1); /* core 1: a coherence miss; core 0 writes A back, keeps it clean */
    rt_mc_put(m, 0, &g, 1); /* geometry: hits in both, never invalidated */
    rt_mc_put(m, 1, &g, 1);
    rt_mc_finish(m);
    rt_mc_counts a0, a1, g0, g1;
    rt_mc_get(m, 0, RT_CLS_RAY, &a0);
    rt_mc_get(m, 1, RT_CLS_RAY, &a1);
    rt_mc_get(m, 0, RT_CLS_TRI, &g0);
    rt_mc_get(m, 1, RT_CLS_TRI, &g1);
    CHECK(a0.accesses == 3 && a0.misses == 2 && a0.coherence_misses == 1 && a0.invalidations == 1 && a0.writebacks == 1,
          "core 0 rays: %" PRIu64 " acc %" PRIu64 " miss %" PRIu64 " coh %" PRIu64 " inv %" PRIu64 " wb", a0.accesses,
          a0.misses, a0.coherence_misses, a0.invalidations, a0.writebacks);
    CHECK(a1.accesses == 3 && a1.misses == 2 && a1.coherence_misses == 1 && a1.invalidations == 1 && a1.writebacks == 1,
          "core 1 rays: %" PRIu64 " acc %" PRIu64 " miss %" PRIu64 " coh %" PRIu64 " inv %" PRIu64 " wb", a1.accesses,
          a1.misses, a1.coherence_misses, a1.invalidations, a1.writebacks);
    CHECK(g0.accesses == 2 && g0.misses == 1 && !g0.invalidations && g1.accesses == 2 && g1.misses == 1 && !g1.invalidations,
          "geometry: %" PRIu64 "/%" PRIu64 " and %" PRIu64 "/%" PRIu64, g0.misses, g0.accesses, g1.misses, g1.accesses);
    /* the shared level saw: A fetched 4 times (2 + 2 misses) and written back twice, G fetched twice */
    rt_sim_counts ray, tri;
    rt_sim_get(rt_mc_shared(m), 2, RT_CLS_RAY, &ray);
    rt_sim_get(rt_mc_shared(m), 2, RT_CLS_TRI, &tri);
    CHECK(ray.accesses == 6 && ray.read_misses == 1 && ray.writebacks == 0 && tri.accesses == 2 && tri.read_misses == 1,
          "shared: rays %" PRIu64 " acc %" PRIu64 " rm, tri %" PRIu64 " acc %" PRIu64 " rm", ray.accesses, ray.read_misses,
          tri.accesses, tri.read_misses);
    CHECK(rt_mc_check(m, &e) == 0, "%s", e.msg);
    rt_mc_free(m);
}

static void test_spec(void)
{
    rt_mc_config c;
    rt_err e = {0};
    CHECK(rt_mc_parse("L1=32K/8/64/lru/private,LLC=1K-4M/full/64/lru/shared", &c, &e) == 0, "%s", e.msg);
    CHECK(c.priv_size == 32768 && c.priv_assoc == 8 && c.line == 64 && c.shared.nsizes == 13 &&
              c.shared.sizes[0] == 1024 && c.shared.sizes[12] == 4u << 20 && !strcmp(c.priv_name, "L1") &&
              !strcmp(c.shared_name, "LLC"),
          "parsed %" PRIu64 "/%u/%u, %d sizes", c.priv_size, c.priv_assoc, c.line, c.shared.nsizes);
    char spec[160];
    rt_mc_spec(&c, spec, sizeof spec);
    CHECK(!strcmp(spec, "L1=32K/8/64/lru/private,LLC=1K-4M/full/64/lru/shared"), "canonical '%s'", spec);
    CHECK(rt_mc_parse("A=16K/4/64/lru,B=256K/full/64/lru", &c, &e) == 0 && c.shared.nsizes == 1, "no suffix: %s", e.msg);
    const char *bad[][2] = {
        {"L1=32K/8/64/lru/private", "two levels"},
        {"L1=32K/8/64/lru/shared,LLC=1M/full/64/lru/shared", "first level is private"},
        {"L1=32K/8/64/lru,LLC=1M/full/128/lru", "one line size"},
        {"L1=32K/8/64/fifo,LLC=1M/full/64/lru", "only lru"},
        {"L1=32K/8/64/lru,LLC=1M/8/64/lru", "fully associative"},
        {"L1=32K/x/64/lru,LLC=1M/full/64/lru", "ways 'x'"},
        {"L1=3K-4K/8/64/lru,LLC=1M/full/64/lru", "powers of two"},
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        memset(&e, 0, sizeof e);
        CHECK(rt_mc_parse(bad[i][0], &c, &e) < 0 && strstr(e.msg, bad[i][1]), "'%s': '%s'", bad[i][0], e.msg);
    }
}

int main(void)
{
    rt_mc_config c;
    const int cores[] = {1, 2, 3, 8};
    for (int i = 0; i < 4; i++) {
        config(&c, cores[i], 1024, 2, 64, 4); /* 8 sets of 2 */
        compare(&c, 20000, 64 * 200);
        config(&c, cores[i], 512, 1, 32, 3); /* direct-mapped */
        compare(&c, 20000, 32 * 100);
        config(&c, cores[i], 256, 0, 64, 3); /* fully associative: 4 lines */
        compare(&c, 10000, 64 * 40);
    }
    test_handmade();
    test_spec();
    return failures ? 1 : 0;
}
