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
#include <stdio.h>

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
/* rt_calloc on an address that is a multiple of align (a power of two, a
 * multiple of sizeof(void *)), for arrays walked by cache line; free() it. */
void *rt_calloc_aligned(size_t n, size_t size, size_t align, rt_err *e);

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

/* ---- scene files: regular files only, bounded, inside the scene's folder ---- */

/* The largest scene file (mesh, material library, scene description) the
 * loaders read: RT_SCENE_MAX_BYTES_DEFAULT (4 GiB) unless the front end
 * changed it (`raytraffic` reads $RT_SCENE_MAX_BYTES, a size like 512M). */
#define RT_SCENE_MAX_BYTES_DEFAULT (4ULL << 30)
extern uint64_t rt_scene_max_bytes;

/* Opens path for reading ("rb") only if it is a regular file of at most
 * max_bytes bytes (symlinks are followed; what counts is the target).
 * The open is non-blocking so that a FIFO cannot block it; the file is
 * then checked with fstat and O_NONBLOCK cleared before it is handed
 * back. Refused with a one-line message in e, NULL returned and errno
 * set:
 *   - "PATH: No such file or directory" (ENOENT) and other open errors;
 *   - "PATH: not a regular file (a FIFO / character device / directory /
 *     ...)" (EINVAL): devices like /dev/zero, FIFOs, sockets, folders;
 *   - "PATH: N bytes is larger than the limit of M bytes (RT_SCENE_MAX_BYTES)"
 *     (EFBIG).
 * The caller must still stop reading after max_bytes (the file may grow
 * while read): rt_slurp_regular does. Every loader of a scene file opens
 * it here (OBJ, MTL, PLY; a scene-description loader should too). */
FILE *rt_open_regular(const char *path, uint64_t max_bytes, rt_err *e);

/* rt_slurp through rt_open_regular: the whole regular file of at most
 * max_bytes bytes into a malloc'd NUL-terminated buffer (*pbuf, length
 * *pn, caller frees). A file that grows past max_bytes while read is
 * refused too. 0, or -1 with a message (errno as rt_open_regular's, or
 * EIO for a read error). */
int rt_slurp_regular(const char *path, uint64_t max_bytes, char **pbuf, size_t *pn, rt_err *e);

/* The path of a file a scene file names (a material library, an included
 * file, a texture), checked against the rule of docs/scenes.md ("Files a
 * scene names"): rel must be relative (no leading '/'), non-empty, and
 * must not climb out of base_dir: its components are walked, "." and
 * empty ones skipped, ".." goes up one level and may never go above
 * base_dir itself ("a/../b.mtl" is fine, "../b.mtl" and "a/../../b.mtl"
 * are not). The rule is on names only: a symlink inside base_dir is
 * followed. base_dir is the folder of the referring file as a prefix:
 * "" (the current folder) or a string ending in '/' ("scenes/",
 * "/data/mesh/"); rt_path_dir gives it. Writes base_dir followed by rel as
 * written into out (n bytes). 0, or -1 with "'REL': absolute path" /
 * "'REL': leaves the folder of the file naming it" / "'REL': empty name" /
 * "'REL': path too long" in e (the caller adds file and line). */
int rt_path_within(const char *base_dir, const char *rel, char *out, size_t n, rt_err *e);

/* The folder prefix of path for rt_path_within: everything up to and
 * including its last '/', or "" when it has none. Into out (n bytes);
 * returns out ("" if it does not fit). */
const char *rt_path_dir(const char *path, char *out, size_t n);

/* ---- scene files: regular files only, bounded, inside the scene's folder ---- */

/* The largest scene file (mesh, material library, scene description) the
 * loaders read: RT_SCENE_MAX_BYTES_DEFAULT (4 GiB) unless the front end
 * changed it (`raytraffic` reads $RT_SCENE_MAX_BYTES, a size like 512M). */
#define RT_SCENE_MAX_BYTES_DEFAULT (4ULL << 30)
extern uint64_t rt_scene_max_bytes;

/* Copies name into buf (n bytes, n >= 24) whole when it fits; else cuts it
 * and ends it with "~" and the 16 hex digits of rt_fnv1a over the whole
 * name, so that two long names differing anywhere stay two distinct
 * strings, the same on every run. For fixed-size fields and file names
 * (trace headers, plot and kept-trace file names). Returns buf. */
const char *rt_name_fit(char *buf, size_t n, const char *name);

/* Physical memory of this machine in bytes (sysconf), 0 if unknown. */
uint64_t rt_phys_memory(void);

/* 0 when bytes of memory fit in the machine's physical memory (or it is
 * unknown), else -1 with "WHAT needs N MB, more than the M MB of memory
 * this machine has". For the checks made before allocating what an
 * option asks for (an image, a cache simulator's state). */
int rt_mem_fits(uint64_t bytes, const char *what, rt_err *e);

#endif
