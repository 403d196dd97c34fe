/*
 * rows.c -- simulator counters -> database rows, the only place.
 *
 * Exact and approximate simulators differ only in how a (size, class)
 * counter is fetched and whether a size has an estimate; one loop writes
 * the rows for both, per class or per (class, generation). Standard errors
 * (hybrid estimators only) are per size and group.
 */
#include "rows.h"

#include <string.h>

/* Fetches size i, class c (generation g, or all when g < 0) into t; 0 ok,
 * -1 when the size has no value. */
typedef int (*get_fn)(const void *sim, int i, int c, int g, rt_sim_counts *t);

/* Rows of every (size, class) (gens = 0) or every (size, class,
 * generation) (gens = RT_MAXGEN) with accesses, elem bytes apart (the
 * counters first in each element); returns the rows written. */
static size_t fill(const rt_sim_config *cfg, const void *sim, get_fn get, int gens, void *out, size_t elem)
{
    size_t n = 0;
    for (int i = 0; i < cfg->nsizes; i++)
        for (int c = 0; c < RT_NCLASS; c++)
            for (int g = gens ? 0 : -1; g < gens; g++) {
                rt_sim_counts t;
                if (get(sim, i, c, g, &t) || !t.accesses) continue;
                rt_db_traffic *r = (rt_db_traffic *)((char *)out + elem * n++);
                if (gens) ((rt_db_gen *)r)->gen = g;
                r->size = cfg->sizes[i];
                r->line = cfg->line;
                r->assoc = cfg->assoc;
                r->policy = rt_sim_policy_name(cfg);
                r->cls = c;
                r->accesses = t.accesses;
                r->read_misses = t.read_misses;
                r->write_misses = t.write_misses;
                r->writebacks = t.writebacks;
                r->wt_bytes = t.wt_bytes;
                r->traffic_bytes = t.traffic_bytes;
            }
    return n;
}

static int get_exact(const void *sim, int i, int c, int g, rt_sim_counts *t)
{
    if (g < 0) rt_sim_get(sim, i, c, t);
    else rt_sim_get_gen(sim, i, c, g, t);
    return 0;
}

static int get_approx(const void *sim, int i, int c, int g, rt_sim_counts *t)
{
    if (!rt_approx_available(sim, i, NULL)) return -1;
    if (g >= 0) return rt_approx_get_gen(sim, i, c, g, t, NULL) ? -1 : 0;
    return rt_approx_get(sim, i, c, t, NULL) ? -1 : 0;
}

size_t rt_sim_db_rows(const rt_sim *s, rt_db_traffic *rows)
{
    return fill(rt_sim_get_config(s), s, get_exact, 0, rows, sizeof *rows);
}

size_t rt_approx_db_rows(const rt_approx *a, rt_db_traffic *rows)
{
    return fill(rt_approx_get_config(a), a, get_approx, 0, rows, sizeof *rows);
}

size_t rt_sim_db_gen_rows(const rt_sim *s, rt_db_gen *grows)
{
    return fill(rt_sim_get_config(s), s, get_exact, RT_MAXGEN, grows, sizeof *grows);
}

size_t rt_approx_db_gen_rows(const rt_approx *a, rt_db_gen *grows)
{
    return fill(rt_approx_get_config(a), a, get_approx, RT_MAXGEN, grows, sizeof *grows);
}

int rt_approx_db_has_se(const rt_approx_config *ac) { return ac->method == RT_APPROX_HYBRID && ac->errors; }

size_t rt_approx_db_se_rows(const rt_approx *a, rt_db_se *se)
{
    const rt_sim_config *cfg = rt_approx_get_config(a);
    size_t n = 0;
    if (!rt_approx_db_has_se(rt_approx_get_approx_config(a))) return 0;
    for (int i = 0; i < cfg->nsizes; i++) {
        uint64_t acc = 0; /* a size without traffic rows gets no error row either */
        for (int c = 0; c < RT_NCLASS; c++) {
            rt_sim_counts t;
            if (get_approx(a, i, c, -1, &t) == 0) acc += t.accesses;
        }
        if (!acc) continue;
        rt_db_se *x = &se[n++];
        x->size = cfg->sizes[i];
        x->line = cfg->line;
        x->assoc = cfg->assoc;
        x->policy = rt_sim_policy_name(cfg);
        for (int g = 0; g <= RT_NGROUP; g++)
            if (rt_approx_traffic_se(a, i, g, &x->se[g], NULL)) x->se[g] = -1;
    }
    return n;
}

size_t rt_hier_db_level_max(const rt_hier *h)
{
    const rt_hier_config *hc = rt_hier_get_config(h);
    size_t n = 0;
    if (hc->inclusion != RT_INCL_NINE) return (size_t)hc->nlevels * hc->level[hc->nlevels - 1].nsizes * RT_NCLASS;
    for (int k = 0; k < hc->nlevels; k++) n += (size_t)hc->level[k].nsizes * RT_NCLASS * (1 + RT_MAXGEN);
    return n;
}

/* An inclusive or exclusive hierarchy's level rows: per chain, level, class. */
static size_t incl_level_rows(const rt_hier *h, rt_db_level *out)
{
    const rt_hier_config *hc = rt_hier_get_config(h);
    const rt_sim_config *lc = &hc->level[hc->nlevels - 1];
    size_t n = 0;
    for (int i = 0; i < lc->nsizes; i++)
        for (int k = 0; k < hc->nlevels; k++) {
            const rt_sim_config *c = &hc->level[k];
            for (int cls = 0; cls < RT_NCLASS; cls++) {
                rt_hier_counts t;
                rt_hier_get(h, k, i, cls, &t);
                if (!t.c.accesses && !t.backinvals) continue;
                rt_db_level *r = &out[n++];
                memset(r, 0, sizeof *r);
                r->level = k + 1;
                r->level_name = hc->name[k];
                r->core = -1;
                r->size = k + 1 == hc->nlevels ? lc->sizes[i] : c->sizes[0];
                r->line = c->line;
                r->assoc = c->assoc;
                r->policy = rt_sim_policy_name(c);
                r->repl = rt_sim_repl_name(c->repl);
                r->cls = cls;
                r->gen = -1;
                r->accesses = t.c.accesses;
                r->misses = t.c.read_misses + t.c.write_misses;
                r->writebacks = t.c.writebacks;
                r->traffic_bytes = t.c.traffic_bytes;
                r->last_size = lc->sizes[i];
                r->backinvals = t.backinvals;
                r->bi_writebacks = t.bi_writebacks;
            }
        }
    return n;
}

size_t rt_hier_db_rows(const rt_hier *h, rt_db_traffic *rows)
{
    const rt_hier_config *hc = rt_hier_get_config(h);
    const rt_sim_config *lc = &hc->level[hc->nlevels - 1];
    if (hc->inclusion == RT_INCL_NINE) return rt_sim_db_rows(rt_hier_level(h, hc->nlevels - 1), rows);
    size_t n = 0;
    for (int i = 0; i < lc->nsizes; i++)
        for (int cls = 0; cls < RT_NCLASS; cls++) {
            rt_hier_counts t;
            rt_hier_get(h, hc->nlevels - 1, i, cls, &t);
            if (!t.c.accesses) continue;
            rt_db_traffic *r = &rows[n++];
            memset(r, 0, sizeof *r);
            r->size = lc->sizes[i];
            r->line = lc->line;
            r->assoc = lc->assoc;
            r->policy = rt_sim_policy_name(lc);
            r->cls = cls;
            r->accesses = t.c.accesses;
            r->read_misses = t.c.read_misses;
            r->write_misses = t.c.write_misses;
            r->writebacks = t.c.writebacks;
            r->wt_bytes = t.c.wt_bytes;
            r->traffic_bytes = t.c.traffic_bytes;
        }
    return n;
}

size_t rt_hier_level_rows_at(const rt_hier *h, const rt_hier_config *hc, int first, int gens, rt_db_level *out)
{
    size_t n = 0;
    for (int k = first; k < hc->nlevels; k++) {
        const rt_sim_config *c = &hc->level[k];
        for (int i = 0; i < c->nsizes; i++)
            for (int cls = 0; cls < RT_NCLASS; cls++)
                for (int g = -1; g < (gens ? RT_MAXGEN : 0); g++) {
                    rt_sim_counts t;
                    if (g < 0) rt_sim_get(rt_hier_level(h, k - first), i, cls, &t);
                    else rt_sim_get_gen(rt_hier_level(h, k - first), i, cls, g, &t);
                    if (!t.accesses) continue;
                    rt_db_level *r = &out[n++];
                    memset(r, 0, sizeof *r);
                    r->level = k + 1;
                    r->level_name = hc->name[k];
                    r->core = -1;
                    r->size = c->sizes[i];
                    r->line = c->line;
                    r->assoc = c->assoc;
                    r->policy = rt_sim_policy_name(c);
                    r->repl = rt_sim_repl_name(c->repl);
                    r->cls = cls;
                    r->gen = g;
                    r->accesses = t.accesses;
                    r->misses = t.read_misses + t.write_misses;
                    r->writebacks = t.writebacks;
                    r->traffic_bytes = t.traffic_bytes;
                }
    }
    return n;
}

size_t rt_hier_db_level_rows(const rt_hier *h, int gens, rt_db_level *out)
{
    const rt_hier_config *hc = rt_hier_get_config(h);
    if (hc->inclusion != RT_INCL_NINE) return incl_level_rows(h, out);
    return rt_hier_level_rows_at(h, hc, 0, gens, out);
}
