/*
 * rt.h -- conventions shared by every raytraffic module.
 *
 * The library never prints and never exits. A function that can fail takes
 * an `rt_err *` as its last argument, returns NULL or a negative value on
 * failure, and writes one line (no trailing newline) into the error, naming
 * the file and position where there is one ("scene.obj:12: bad index").
 * The front end prefixes the subcommand name and prints it. `rt_err *` may
 * be NULL when the caller does not want the message.
 *
 * Naming: each module has a short prefix (rt_kd_, rt_tr_, rt_sim_, ...);
 * destroy functions accept NULL.
 */
#ifndef RT_H
#define RT_H

#include <stddef.h>
#include <stdint.h>
#include <stdarg.h>

#define RT_ERR_LEN 512

typedef struct rt_err {
    char msg[RT_ERR_LEN]; /* one line, no newline; empty when no error */
    int usage;            /* 1: the options ask for what cannot be done (front ends exit 2) */
} rt_err;

/* Formats a message into e (if non-NULL) and clears e->usage. Always
 * returns -1 so callers can write `return rt_errf(e, ...)`. */
int rt_errf(rt_err *e, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 2, 3)))
#endif
    ;
/* As rt_errf, and marks the error as the options' (e->usage = 1): the
 * request itself cannot be run (an S_VB overflow, a grid over its cell
 * limit), which the front ends report as a usage error (exit 2). */
int rt_errf_usage(rt_err *e, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 2, 3)))
#endif
    ;

/* Tool version ("0.1.0") and git revision ("abc123def456" or "unknown"). */
const char *rt_version(void);
const char *rt_git_rev(void);

/* Monotonic wall clock in seconds. */
double rt_now(void);

/* Allocation that reports failure through rt_err instead of aborting.
 * Returns NULL (and sets e) when n*size overflows or memory is exhausted. */
void *rt_calloc(size_t n, size_t size, rt_err *e);
void *rt_reallocarray(void *p, size_t n, size_t size, rt_err *e);

/* Test hook: when > 0, the n-th following rt_calloc/rt_reallocarray call
 * fails (counts down; 0 disables). Lets tests exercise out-of-memory paths. */
extern long rt_fail_alloc_after;

/* 64-bit FNV-1a, used for scene and trace identity hashes. */
uint64_t rt_fnv1a(uint64_t h, const void *data, size_t n);
#define RT_FNV_INIT 0xcbf29ce484222325ULL

/* Parses sizes like "64", "64K", "4M", "1G" (binary multiples): digits
 * first, no sign, no whitespace anywhere. Returns 0 and stores the value,
 * or -1 on a malformed or overflowing string. */
int rt_parse_size(const char *s, uint64_t *out);

/* Copies s (at most max bytes, stopping at NUL) into buf of n bytes for
 * quoting input in an error message: control bytes, DEL and bytes >= 0x80
 * become \xNN, so a hostile file cannot move the terminal's cursor or
 * forge lines. Truncates (with "...") to fit. Returns buf. */
const char *rt_esc(char *buf, size_t n, const char *s, size_t max);

/* sin and cos of an angle in degrees, using only + - * / so that the
 * result is the same on every IEEE machine (libm's last bit is not).
 * Multiples of 90 degrees give exact 0 and +-1. */
void rt_dsincos_deg(double deg, double *s, double *c);

/* Reads a whole file into a malloc'd NUL-terminated buffer (*pbuf, length
 * *pn, caller frees). 0, or -1 with "path: reason". */
int rt_slurp(const char *path, char **pbuf, size_t *pn, rt_err *e);

#endif
