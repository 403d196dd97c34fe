/*
 * rows.c -- simulator counters -> database rows, the only place.
 *
 * Exact and approximate simulators differ only in how a (size, class)
 * counter is fetched and whether a size has an estimate; one loop writes
 * the rows for both.
 */
#include "rows.h"

/* Fetches size i, class c into t; 0 ok, -1 when the size has no value. */
typedef int (*get_fn)(const void *sim, int i, int c, rt_sim_counts *t);

static size_t fill_rows(const rt_sim_config *cfg, const void *sim, get_fn get, rt_db_traffic *rows)
{
    size_t n = 0;
    for (int i = 0; i < cfg->nsizes; i++)
        for (int c = 0; c < RT_NCLASS; c++) {
            rt_sim_counts t;
            if (get(sim, i, c, &t) || !t.accesses) continue;
            rt_db_traffic *r = &rows[n++];
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

static int get_exact(const void *sim, int i, int c, rt_sim_counts *t)
{
    rt_sim_get(sim, i, c, t);
    return 0;
}

static int get_approx(const void *sim, int i, int c, rt_sim_counts *t)
{
    if (!rt_approx_available(sim, i, NULL)) return -1;
    return rt_approx_get(sim, i, c, t, NULL) ? -1 : 0;
}

size_t rt_sim_db_rows(const rt_sim *s, rt_db_traffic *rows)
{
    return fill_rows(rt_sim_get_config(s), s, get_exact, rows);
}

size_t rt_approx_db_rows(const rt_approx *a, rt_db_traffic *rows)
{
    return fill_rows(rt_approx_get_config(a), a, get_approx, rows);
}
