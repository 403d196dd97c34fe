/* mcore_rows.c -- multi-core hierarchy counters as rows (see mcore_rows.h). */
#include "mcore_rows.h"
#include "rows.h"

#include <string.h>

size_t rt_mc_db_level_cap(const rt_mc *m)
{
    const rt_mc_config *c = rt_mc_get_config(m);
    size_t n = 0;
    for (int k = 0; k < c->h.nlevels; k++)
        n += (size_t)(k < c->nprivate ? c->ncores : c->h.level[k].nsizes) * RT_NCLASS * (1 + RT_MAXGEN);
    return n;
}

size_t rt_mc_db_level_rows_gen(const rt_mc *m, int gens, rt_db_level *rows)
{
    const rt_mc_config *c = rt_mc_get_config(m);
    size_t n = 0;
    for (int p = 0; p < c->nprivate; p++) {
        const rt_sim_config *l = &c->h.level[p];
        for (int k = 0; k < c->ncores; k++)
            for (int cls = 0; cls < RT_NCLASS; cls++)
                for (int g = -1; g < (gens ? RT_MAXGEN : 0); g++) {
                    rt_mc_counts x;
                    rt_mc_get_level(m, p, k, cls, g, &x);
                    if (!x.accesses) continue;
                    rt_db_level *r = &rows[n++];
                    memset(r, 0, sizeof *r);
                    r->level = p + 1;
                    r->level_name = c->h.name[p];
                    r->core = k;
                    r->size = l->sizes[0];
                    r->line = l->line;
                    r->assoc = l->assoc;
                    r->policy = rt_sim_policy_name(l);
                    r->repl = rt_sim_repl_name(l->repl);
                    r->cls = cls;
                    r->gen = g;
                    r->accesses = x.accesses;
                    r->misses = x.misses;
                    r->writebacks = x.writebacks;
                    r->traffic_bytes = x.traffic_bytes;
                }
    }
    return n + rt_hier_level_rows_at(rt_mc_shared_hier(m), &c->h, c->nprivate, gens, rows + n);
}

size_t rt_mc_db_level_rows(const rt_mc *m, rt_db_level *rows) { return rt_mc_db_level_rows_gen(m, 0, rows); }

size_t rt_mc_db_traffic_rows(const rt_mc *m, rt_db_traffic *rows) { return rt_sim_db_rows(rt_mc_shared(m), rows); }
