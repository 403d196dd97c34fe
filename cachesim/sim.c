/*
 * sim.c -- the rt_sim front door: configurations, the sink, per-size /
 * per-class / per-group results (see sim.h). The engine is the first entry
 * of the engine table (engine.h) that fits the configuration; everything
 * else goes through its function pointers.
 */
#include "sim.h"
#include "engine.h"

#include <stdlib.h>
#include <string.h>

struct rt_sim {
    rt_sim_config cfg;               /* as created */
    const rt_cache_engine *eng;      /* the engine table's entry */
    void *st;                        /* its state */
    rt_sink sink;                    /* put() -> rt_sim_put */
    uint64_t refs;                   /* references seen */
};

void rt_sim_config_default(rt_sim_config *c)
{
    memset(c, 0, sizeof *c);
    c->nsizes = RT_SIM_PAPER_NSIZES;
    for (int i = 0; i < c->nsizes; i++) c->sizes[i] = 1024ULL << i;
    c->line = 64;
    c->assoc = 0;
}

static int cmp_u64(const void *a, const void *b)
{
    uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return x < y ? -1 : x > y;
}

int rt_sim_parse_sizes(const char *s, rt_sim_config *c, rt_err *e)
{
    char buf[512];
    if (!s || !*s || strlen(s) >= sizeof buf) return rt_errf(e, "bad size list '%s'", s ? s : "");
    strcpy(buf, s);
    char *dash = strchr(buf, '-');
    int n = 0;
    if (dash && !strchr(buf, ',')) {
        *dash = 0;
        uint64_t lo, hi;
        if (rt_parse_size(buf, &lo) || rt_parse_size(dash + 1, &hi) || lo == 0 || hi < lo)
            return rt_errf(e, "bad size range '%s' (want e.g. 1K-4M)", s);
        for (uint64_t v = lo; v <= hi; v *= 2) {
            if (n == RT_SIM_MAXSIZES) return rt_errf(e, "size range '%s' has more than %d sizes", s, RT_SIM_MAXSIZES);
            c->sizes[n++] = v;
            if (v > UINT64_MAX / 2) break;
        }
    } else {
        for (char *tok = strtok(buf, ","); tok; tok = strtok(NULL, ",")) {
            uint64_t v;
            if (rt_parse_size(tok, &v) || v == 0) return rt_errf(e, "bad cache size '%s'", tok);
            if (n == RT_SIM_MAXSIZES) return rt_errf(e, "more than %d sizes in '%s'", RT_SIM_MAXSIZES, s);
            c->sizes[n++] = v;
        }
        qsort(c->sizes, (size_t)n, sizeof c->sizes[0], cmp_u64);
        for (int i = 1; i < n; i++)
            if (c->sizes[i] == c->sizes[i - 1]) return rt_errf(e, "size list '%s' repeats a size", s);
    }
    if (n == 0) return rt_errf(e, "empty size list");
    c->nsizes = n;
    return 0;
}

const char *rt_sim_policy_name(const rt_sim_config *c)
{
    static const char *const names[16] = {
        "wb-wa",          "wb-nwa",          "wt-wa",          "wt-nwa",
        "wb-wa+flush",    "wb-nwa+flush",    "wt-wa+flush",    "wt-nwa+flush",
        "wb-wa+fullline", "wb-nwa+fullline", "wt-wa+fullline", "wt-nwa+fullline",
        "wb-wa+flush+fullline", "wb-nwa+flush+fullline", "wt-wa+flush+fullline", "wt-nwa+flush+fullline"};
    return names[(c->write_through ? 2 : 0) + (c->no_write_allocate ? 1 : 0) + (c->flush ? 4 : 0) +
                 (c->write_miss_fullline ? 8 : 0)];
}

int rt_sim_config_check(const rt_sim_config *c, rt_err *e)
{
    if (c->nsizes < 1 || c->nsizes > RT_SIM_MAXSIZES) return rt_errf(e, "need 1..%d cache sizes", RT_SIM_MAXSIZES);
    if (c->line == 0) return rt_errf(e, "line size must be at least 1 byte");
    uint64_t unit = (uint64_t)c->line * (c->assoc ? c->assoc : 1);
    for (int i = 0; i < c->nsizes; i++) {
        if (i && c->sizes[i] <= c->sizes[i - 1]) return rt_errf(e, "cache sizes must increase");
        if (c->sizes[i] < unit || c->sizes[i] % unit)
            return rt_errf(e, "cache size %llu is not a multiple of line x assoc = %llu bytes",
                           (unsigned long long)c->sizes[i], (unsigned long long)unit);
        if (c->sizes[i] / c->line >= (1u << 30)) return rt_errf(e, "cache size %llu too large", (unsigned long long)c->sizes[i]);
    }
    if (!strcmp(rt_sim_repl_name(c->repl), "?")) return rt_errf(e, "unknown replacement policy %d", c->repl);
    const rt_repl_ops *ops = rt_repl_ops_for(c->repl);
    if (ops && ops->pow2_ways) {
        for (int i = 0; i < c->nsizes; i++) {
            uint64_t w = c->assoc ? c->assoc : c->sizes[i] / c->line;
            if (w & (w - 1))
                return rt_errf(e, "replacement policy %s needs a power-of-two number of ways (cache size %llu has %llu)",
                               ops->name, (unsigned long long)c->sizes[i], (unsigned long long)w);
        }
    }
    const rt_cache_engine *g = rt_cache_engine_for(c);
    if (!g) {
        rt_sim_config top = *c;
        top.feeds_below = 0;
        if (c->feeds_below && rt_cache_engine_for(&top))
            return rt_errf(e, "replacement policy %s cannot feed a cache level below it (only a last level can be %s)",
                           rt_sim_repl_name(c->repl), rt_sim_repl_name(c->repl));
        return rt_errf(e, "no cache engine simulates replacement policy %s with this configuration",
                       rt_sim_repl_name(c->repl));
    }
    /* an engine that allocates each cache's lines up front (the stack
     * simulator grows with the lines seen): check before */
    uint64_t bytes = g->state_bytes(c);
    if (bytes) {
        char what[160];
        snprintf(what, sizeof what, "simulating cache sizes up to %llu bytes (%u-way, per-size engine)",
                 (unsigned long long)c->sizes[c->nsizes - 1], c->assoc);
        if (rt_mem_fits(bytes, what, e) < 0) return -1;
    }
    return 0;
}

static int sink_put(rt_sink *sk, const rt_access *a, size_t n) { return rt_sim_put(sk->ctx, a, n); }

rt_sim *rt_sim_new(const rt_sim_config *c, rt_err *e)
{
    if (rt_sim_config_check(c, e)) return NULL;
    rt_sim *s = rt_calloc(1, sizeof *s, e);
    if (!s) return NULL;
    s->cfg = *c;
    s->sink.put = sink_put;
    s->sink.ctx = s;
    s->eng = rt_cache_engine_for(c);
    s->st = s->eng->create(c, e);
    if (!s->st) {
        free(s);
        return NULL;
    }
    return s;
}

void rt_sim_free(rt_sim *s)
{
    if (!s) return;
    s->eng->destroy(s->st);
    free(s);
}

const rt_sim_config *rt_sim_get_config(const rt_sim *s) { return &s->cfg; }
const char *rt_sim_engine(const rt_sim *s) { return s->eng->name; }

int rt_sim_phases(const rt_sim *s, double out[2])
{
    out[0] = out[1] = 0;
    if (!s->eng->phases) return -1;
    s->eng->phases(s->st, out);
    return 0;
}
rt_sink *rt_sim_sink(rt_sim *s) { return &s->sink; }

static void sim_add_repeats(void *ctx, const uint64_t *cnt)
{
    rt_sim *s = ctx;
    for (int cg = 0; cg < RT_NCLASS * RT_MAXGEN; cg++) s->refs += cnt[cg];
    s->eng->repeats(s->st, cnt);
}

void rt_sim_repeats(rt_sim *s, rt_repeats *out)
{
    memset(out, 0, sizeof *out);
    /* the one-pass LRU engine; and an LRU write-allocate level of a
     * hierarchy (a repeat is a hit on the most recent line of its set) */
    int level = s->cfg.feeds_below && s->cfg.repl == 0 && !s->cfg.no_write_allocate && s->eng->repeats;
    if (!((s->eng->caps & RT_ENG_REPEATS) && !s->cfg.no_write_allocate) && !level) return;
    out->line = s->cfg.line;
    out->add = sim_add_repeats;
    out->ctx = s;
}
uint64_t rt_sim_refs(const rt_sim *s) { return s->refs; }

int rt_sim_set_below(rt_sim *s, rt_sink *below, rt_err *e)
{
    if (!s->eng->set_below)
        return rt_errf(e, "engine %s (replacement %s) cannot feed a cache level below it", s->eng->name,
                       rt_sim_repl_name(s->cfg.repl));
    return s->eng->set_below(s->st, below, e);
}

int rt_sim_put(rt_sim *s, const rt_access *a, size_t n)
{
    s->refs += n;
    return s->eng->access(s->st, a, n);
}

int rt_sim_finish(rt_sim *s)
{
    s->eng->finish(s->st, s->cfg.flush);
    return 0;
}

/* Counters of one class, generation bucket gen or all of them (gen < 0). */
static void get_cg(const rt_sim *s, int i, int cls, int gen, rt_sim_counts *out)
{
    memset(out, 0, sizeof *out);
    if (i < 0 || i >= s->cfg.nsizes) return;
    s->eng->counts(s->st, i, cls, gen, out);
}

static void add_counts(rt_sim_counts *out, const rt_sim_counts *t)
{
    out->accesses += t->accesses;
    out->read_misses += t->read_misses;
    out->write_misses += t->write_misses;
    out->writebacks += t->writebacks;
    out->wt_bytes += t->wt_bytes;
    out->traffic_bytes += t->traffic_bytes;
    out->nofetch += t->nofetch;
}

static void get_group(const rt_sim *s, int i, int group, int gen, rt_sim_counts *out)
{
    memset(out, 0, sizeof *out);
    for (int c = 0; c < RT_NCLASS; c++) {
        if ((int)rt_class_group(c) != group) continue;
        rt_sim_counts t;
        get_cg(s, i, c, gen, &t);
        add_counts(out, &t);
    }
}

void rt_sim_get(const rt_sim *s, int i, int cls, rt_sim_counts *out) { get_cg(s, i, cls, -1, out); }
void rt_sim_get_group(const rt_sim *s, int i, int group, rt_sim_counts *out) { get_group(s, i, group, -1, out); }

void rt_sim_get_gen(const rt_sim *s, int i, int cls, int gen, rt_sim_counts *out)
{
    if (gen < 0) memset(out, 0, sizeof *out);
    else get_cg(s, i, cls, gen, out);
}

void rt_sim_get_group_gen(const rt_sim *s, int i, int group, int gen, rt_sim_counts *out)
{
    if (gen < 0) memset(out, 0, sizeof *out);
    else get_group(s, i, group, gen, out);
}

int rt_sim_check(const rt_sim *s, rt_err *e)
{
    if (s->eng->check(s->st, e)) return -1;
    for (int i = 0; i < s->cfg.nsizes; i++)
        for (int c = 0; c < RT_NCLASS; c++) {
            rt_sim_counts all, sum, t;
            rt_sim_get(s, i, c, &all);
            memset(&sum, 0, sizeof sum);
            for (int g = 0; g < RT_MAXGEN; g++) {
                rt_sim_get_gen(s, i, c, g, &t);
                add_counts(&sum, &t);
            }
            if (memcmp(&all, &sum, sizeof all))
                return rt_errf(e, "sim: size %llu class %s: generations do not sum to the class counters",
                               (unsigned long long)s->cfg.sizes[i], rt_class_name(c));
        }
    return 0;
}

