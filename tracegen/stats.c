/* stats.c -- end-of-run statistics shared by the tracers (see stats.h). */
#include "stats.h"

#include <string.h>

void rt_stats_finish(rt_run_stats *st, const rt_trav *tv, const uint8_t *mark, uint32_t ntri)
{
    if (st->mark_keep && ntri) memcpy(st->mark_keep, mark, ntri);
    st->nodes = tv->nodes;
    st->tests = tv->tests;
    /* eight marks at a time: bit 0 of every byte counted for pv_primary,
     * and of every byte with its eight bits or-ed into bit 0 for pv_all;
     * (x * low) >> 56 sums the bytes of x (each 0 or 1 here) */
    const uint64_t low = 0x0101010101010101ull;
    uint64_t prim = 0, all = 0;
    uint32_t i = 0;
    for (; i + 8 <= ntri; i += 8) {
        uint64_t w;
        memcpy(&w, mark + i, sizeof w);
        uint64_t nz = w | w >> 4; /* bit 8k + j of the shifts comes from byte k for j < 4, 2, 1 */
        nz |= nz >> 2;
        nz |= nz >> 1;
        prim += ((w & low) * low) >> 56;
        all += ((nz & low) * low) >> 56;
    }
    for (; i < ntri; i++) {
        prim += mark[i] & 1;
        all += mark[i] != 0;
    }
    st->pv_primary += prim;
    st->pv_all += all;
}
