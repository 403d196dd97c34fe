/*
 * mcore_rows.h -- the multi-core hierarchy's counters (cachesim/mcore.h) as
 * database rows (prefix rt_mc_db_): the traffic rows of a run are what
 * reaches memory (the shared level's, per size and class, as rows.c makes
 * them for one cache), and the per-level rows (schema version 6,
 * level_traffic) are level 1 once per core (core 0..N-1, its private
 * cache, per class) and level 2 per shared size (core -1, per class):
 * accesses, misses (read and write), write-backs and the bytes the level
 * moves to the one below. Only classes with an access get a row.
 */
#ifndef RT_MCORE_ROWS_H
#define RT_MCORE_ROWS_H

#include "db.h"
#include "mcore.h"

/* Room for rt_mc_db_level_rows: (ncores + nsizes) * RT_NCLASS. */
size_t rt_mc_db_level_cap(const rt_mc *m);
/* Per-level rows into rows (rt_mc_db_level_cap entries); returns how many. */
size_t rt_mc_db_level_rows(const rt_mc *m, rt_db_level *rows);
/* Memory traffic rows (nsizes * RT_NCLASS entries); returns how many. */
size_t rt_mc_db_traffic_rows(const rt_mc *m, rt_db_traffic *rows);

#endif
