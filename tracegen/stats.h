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

/* The statistics string's form (st->extra, and runs.stats in the
 * database): tokens "key=value" separated by single spaces, where
 *   1. a key is one or more of [A-Za-z0-9_] and appears once;
 *   2. a value is one token, non-empty, without spaces, quotes, backslashes
 *      or control characters: a number, or a word such as a grid size
 *      "4x4x4" or a list "1,2,3".
 * rt_stats_json writes such a string as a JSON object into out (n bytes):
 * values that are JSON numbers as numbers, the others as strings, keys in
 * the string's order; "" gives "{}". Returns 0, or -1 with e saying which
 * token breaks the form (out then holds "{}" when n allows). It is also
 * the form's checker: tests/test_conform.c runs it on every tracer, mode
 * and structure, with the keys a sweep's runs.stats adds around them. */
int rt_stats_json(const char *s, char *out, size_t n, rt_err *e);

/* 1 when v[0..len) is a number in JSON's grammar (-?int frac? exp?). */
int rt_stats_is_number(const char *v, size_t len);

#endif
