/* stats.c -- end-of-run statistics shared by the tracers (see stats.h). */
#include "stats.h"

void rt_stats_finish(rt_run_stats *st, const rt_trav *tv, const uint8_t *mark, uint32_t ntri)
{
    st->nodes = tv->nodes;
    st->tests = tv->tests;
    for (uint32_t i = 0; i < ntri; i++) {
        st->pv_primary += mark[i] & 1;
        st->pv_all += mark[i] != 0;
    }
}
