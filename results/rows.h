/*
 * rows.h -- simulator counters as database rows (module prefix rt_rows_).
 *
 * The only place where a simulator's counters become rt_db_traffic rows:
 * one row per (size, class) with at least one access, sizes in order; and
 * rt_db_gen rows: one per (size, class, generation bucket) with at least
 * one access, from the exact simulators only (the estimators keep no
 * generations); and rt_db_se rows: one per size with an estimate, from an
 * estimator that estimated its error (rt_approx_db_has_se).
 */
#ifndef RT_ROWS_H
#define RT_ROWS_H

#include "approx.h"
#include "hier.h"
#include "db.h"
#include "sim.h"

#include <stddef.h>

/* rows must hold nsizes * RT_NCLASS entries; returns the rows written. */
size_t rt_sim_db_rows(const rt_sim *s, rt_db_traffic *rows);
/* Same for the sizes an approximate simulator has estimates for. */
size_t rt_approx_db_rows(const rt_approx *a, rt_db_traffic *rows);
/* Per-generation rows; grows must hold nsizes * RT_NCLASS * RT_MAXGEN
 * entries; returns the rows written. For an rt_approx, only the sizes it
 * simulates exactly have rows (all of them for RT_APPROX_EXACT). */
size_t rt_sim_db_gen_rows(const rt_sim *s, rt_db_gen *grows);
size_t rt_approx_db_gen_rows(const rt_approx *a, rt_db_gen *grows);

/* Whether an approximate run of this configuration has standard errors to
 * store: the hybrid method with ac->errors set. The one test of it, for
 * the rows below and for the run key (rt_exp_key_method). */
int rt_approx_db_has_se(const rt_approx_config *ac);
/* Standard-error rows (after rt_approx_finish): one per size that has an
 * estimate, se[g] = rt_approx_traffic_se of group g (RT_NGROUP: all
 * classes), -1 where it has none; none at all unless rt_approx_db_has_se.
 * se must hold nsizes entries; returns the rows written. */
size_t rt_approx_db_se_rows(const rt_approx *a, rt_db_se *se);

/* Per-level rows of a hierarchy (after rt_hier_finish): one per (level,
 * size, class) with accesses, generation -1 (all), and with gens one per
 * (level, size, class, generation bucket) with accesses too; core -1 (shared);
 * misses = read + write misses, traffic_bytes = what the level moves to the
 * one below. An inclusive or exclusive hierarchy (one chain per last-level
 * size, generations pooled) has one row per (chain, level, class) with
 * accesses or back-invalidations: last_size the chain's last-level size,
 * backinvals and bi_writebacks filled in, generation -1 only (gens is
 * ignored). out must hold rt_hier_db_level_max(h) entries; returns the
 * rows written. */
size_t rt_hier_db_level_max(const rt_hier *h);
size_t rt_hier_db_level_rows(const rt_hier *h, int gens, rt_db_level *out);
/* The same rows for the levels first.. of hc simulated by h (h's level 0
 * is hc's level first: the shared levels of a multi-core machine, named
 * and numbered as in the whole hierarchy), non-inclusive. */
size_t rt_hier_level_rows_at(const rt_hier *h, const rt_hier_config *hc, int first, int gens, rt_db_level *out);
/* The traffic rows of a hierarchy run (what reaches memory): its last
 * level's counters per size and class, as rt_sim_db_rows writes them (for
 * a non-inclusive one, exactly rt_sim_db_rows of the last level). rows
 * must hold last-level sizes x RT_NCLASS entries; returns the rows written. */
size_t rt_hier_db_rows(const rt_hier *h, rt_db_traffic *rows);

#endif
