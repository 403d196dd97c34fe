/* mcore_rows.c -- multi-core hierarchy counters as rows (see mcore_rows.h). */
#include "mcore_rows.h"
#include "rows.h"

#include <string.h>

size_t rt_mc_db_level_cap(const rt_mc *m)
{
    const rt_mc_config *c = rt_mc_get_config(m);
    return (size_t)(c->ncores + c->shared.nsizes) * RT_NCLASS;
}

size_t rt_mc_db_level_rows(const rt_mc *m, rt_db_level *rows)
{
    const rt_mc_config *c = rt_mc_get_config(m);
    size_t n = 0;
    for (int k = 0; k < c->ncores; k++)
        for (int cls = 0; cls < RT_NCLASS; cls++) {
            rt_mc_counts x;
            rt_mc_get(m, k, cls, &x);
            if (!x.accesses) continue;
            rt_db_level *r = &rows[n++];
            memset(r, 0, sizeof *r);
            r->level = 1;
            r->level_name = c->priv_name;
            r->core = k;
            r->size = c->priv_size;
            r->line = c->line;
            r->assoc = c->priv_assoc;
            r->cls = cls;
            r->gen = -1;
            r->accesses = x.accesses;
            r->misses = x.misses;
            r->writebacks = x.writebacks;
            r->traffic_bytes = x.traffic_bytes;
        }
    for (int z = 0; z < c->shared.nsizes; z++)
        for (int cls = 0; cls < RT_NCLASS; cls++) {
            rt_sim_counts x;
            rt_sim_get(rt_mc_shared(m), z, cls, &x);
            if (!x.accesses) continue;
            rt_db_level *r = &rows[n++];
            memset(r, 0, sizeof *r);
            r->level = 2;
            r->level_name = c->shared_name;
            r->core = -1;
            r->size = c->shared.sizes[z];
            r->line = c->shared.line;
            r->assoc = 0;
            r->cls = cls;
            r->gen = -1;
            r->accesses = x.accesses;
            r->misses = x.read_misses + x.write_misses;
            r->writebacks = x.writebacks;
            r->traffic_bytes = x.traffic_bytes;
        }
    return n;
}

size_t rt_mc_db_traffic_rows(const rt_mc *m, rt_db_traffic *rows) { return rt_sim_db_rows(rt_mc_shared(m), rows); }
