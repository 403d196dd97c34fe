/*
 * rows.h -- simulator counters as database rows (module prefix rt_rows_).
 *
 * The only place where a simulator's counters become rt_db_traffic rows:
 * one row per (size, class) with at least one access, sizes in order; and
 * rt_db_gen rows: one per (size, class, generation bucket) with at least
 * one access, from the exact simulators only (the estimators keep no
 * generations).
 */
#ifndef RT_ROWS_H
#define RT_ROWS_H

#include "approx.h"
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

#endif
