/*
 * engine.c -- the cache engine table and the replacement policies' table
 * (see engine.h). A new policy is one file defining its rt_repl_ops and one
 * line below.
 */
#include "engine.h"

#include <string.h>

const rt_cache_engine *const rt_cache_engines[] = {
    &rt_engine_stack,   /* LRU, fully associative, write-back write-allocate: every size in one pass */
    &rt_engine_persize, /* any policy, associativity and write policy: one cache per size */
    &rt_engine_opt,     /* Belady's MIN: buffers the stream, simulates each size when it ends */
    NULL,
};

/* the policies, one file each (repl_<name>.c), one line each */
extern const rt_repl_ops rt_repl_fifo, rt_repl_random, rt_repl_plru, rt_repl_srrip, rt_repl_brrip;
const rt_repl_ops *const rt_repl_policies[] = {
    &rt_repl_fifo,
    &rt_repl_random,
    &rt_repl_plru,
    &rt_repl_srrip,
    &rt_repl_brrip,
    NULL,
};

static int npolicies(void)
{
    int k = 0;
    while (rt_repl_policies[k]) k++;
    return k;
}

const rt_repl_ops *rt_repl_ops_for(int repl)
{
    return repl >= 1 && repl <= npolicies() ? rt_repl_policies[repl - 1] : NULL;
}

/* The name of policy value k: "lru", a hooks policy, or the policy of an
 * engine of its own (after the hooks, in table order); NULL past the end. */
static const char *name_at(int k)
{
    if (k == 0) return "lru";
    int p = npolicies();
    if (k <= p) return rt_repl_policies[k - 1]->name;
    k -= p;
    for (int g = 0; rt_cache_engines[g]; g++) {
        const char *r = rt_cache_engines[g]->repl;
        if (r && strcmp(r, "lru") && --k == 0) return r;
    }
    return NULL;
}

int rt_sim_repl_parse(const char *name, int *repl, rt_err *e)
{
    for (int k = 0; name && name_at(k); k++)
        if (!strcmp(name, name_at(k))) return *repl = k, 0;
    return rt_errf(e, "unknown replacement policy '%s' (want one of %s)", name ? name : "", rt_sim_repl_list());
}

const char *rt_sim_repl_name(int repl)
{
    const char *n = repl >= 0 ? name_at(repl) : NULL;
    return n ? n : "?";
}

int rt_sim_repl_random(int repl)
{
    const rt_repl_ops *o = rt_repl_ops_for(repl);
    return o && o->random;
}

const char *rt_sim_repl_list(void)
{
    static char buf[256];
    if (!buf[0]) {
        for (int k = 0; name_at(k); k++) {
            if (k) strncat(buf, ",", sizeof buf - strlen(buf) - 1);
            strncat(buf, name_at(k), sizeof buf - strlen(buf) - 1);
        }
    }
    return buf;
}

int rt_cache_engine_fits(const rt_cache_engine *g, const rt_sim_config *c)
{
    /* an engine of a named policy serves only it; the hooks engine serves
     * LRU (its own lists) and every policy of the table */
    if (g->repl ? strcmp(g->repl, rt_sim_repl_name(c->repl)) != 0 : (c->repl != 0 && !rt_repl_ops_for(c->repl)))
        return 0;
    if (!(g->caps & (c->assoc ? RT_ENG_SETASSOC : RT_ENG_FULLASSOC))) return 0;
    if (c->feeds_below && !g->set_below) return 0;
    if (c->write_through && !(g->caps & RT_ENG_WT)) return 0;
    if (c->no_write_allocate && !(g->caps & RT_ENG_NWA)) return 0;
    return 1;
}

const rt_cache_engine *rt_cache_engine_for(const rt_sim_config *c)
{
    for (int k = 0; rt_cache_engines[k]; k++)
        if (rt_cache_engine_fits(rt_cache_engines[k], c)) return rt_cache_engines[k];
    return NULL;
}
