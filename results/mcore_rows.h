/*
 * mcore_rows.h -- the multi-core hierarchy's counters (cachesim/mcore.h) as
 * database rows (prefix rt_mc_db_): the traffic rows of a run are what
 * reaches memory (the last level's, per size and class, as rows.c makes
 * them for one cache; per generation too when the stream has them), and
 * the per-level rows (level_traffic) are each private level once per core
 * (core 0..N-1, per class) and each shared level per size (core -1, per
 * class), numbered from the core outward (level 1 = the first private
 * level), with a row per generation too when gens is set: accesses,
 * misses (read and write), write-backs (coherence write-backs included)
 * and the bytes the level moves to the one below. Only classes with an
 * access get a row. With one core the rows are the one-core hierarchy's
 * (rows.h rt_hier_db_level_rows) but for the private levels' core 0.
 */
#ifndef RT_MCORE_ROWS_H
#define RT_MCORE_ROWS_H

#include "db.h"
#include "mcore.h"

/* Room for rt_mc_db_level_rows. */
size_t rt_mc_db_level_cap(const rt_mc *m);
/* Per-level rows into rows (rt_mc_db_level_cap entries); returns how many. */
size_t rt_mc_db_level_rows_gen(const rt_mc *m, int gens, rt_db_level *rows);
size_t rt_mc_db_level_rows(const rt_mc *m, rt_db_level *rows);
/* Memory traffic rows (last-level sizes x RT_NCLASS entries); returns how many. */
size_t rt_mc_db_traffic_rows(const rt_mc *m, rt_db_traffic *rows);

#endif
