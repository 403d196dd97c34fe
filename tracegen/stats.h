/*
 * stats.h -- the run statistics every tracer reports (prefix rt_stats_).
 *
 * Node visits and triangle tests are counted by the traversal context
 * (rt_trav); which triangles were tested is kept as a per-triangle mark,
 * bit 1 for primary rays and bit 2 for shadow rays, from which the
 * potentially visible sets are counted at the end of the run.
 */
#ifndef RT_STATS_H
#define RT_STATS_H

#include "tracer.h"

/* Copies tv's node visits and triangle tests into st and counts the
 * distinct triangles tested by primary rays (mark bit 1: pv_primary) and by
 * any ray (pv_all) from mark[0..ntri). */
void rt_stats_finish(rt_run_stats *st, const rt_trav *tv, const uint8_t *mark, uint32_t ntri);

#endif
