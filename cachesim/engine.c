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

const rt_repl_ops *rt_repl_ops_for(int repl)
{
    if (repl < 1) return NULL;
    for (int k = 0; rt_repl_policies[k]; k++)
        if (k == repl - 1) return rt_repl_policies[k];
    return NULL;
}

int rt_sim_repl_parse(const char *name, int *repl, rt_err *e)
{
    if (name && !strcmp(name, "lru")) return *repl = 0, 0;
    for (int k = 0; name && rt_repl_policies[k]; k++)
        if (!strcmp(name, rt_repl_policies[k]->name)) return *repl = k + 1, 0;
    return rt_errf(e, "unknown replacement policy '%s' (want one of %s)", name ? name : "", rt_sim_repl_list());
}

const char *rt_sim_repl_name(int repl)
{
    if (repl == 0) return "lru";
    const rt_repl_ops *o = rt_repl_ops_for(repl);
    return o ? o->name : "?";
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
        strcpy(buf, "lru");
        for (int k = 0; rt_repl_policies[k]; k++) {
            strncat(buf, ",", sizeof buf - strlen(buf) - 1);
            strncat(buf, rt_repl_policies[k]->name, sizeof buf - strlen(buf) - 1);
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
