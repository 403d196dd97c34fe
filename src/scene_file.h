/*
 * scene_file.h -- reading a scene file (prefix rt_sfile): plain or gzip,
 * told apart by content, bounded the same way.
 *
 * Every loader (OBJ and its MTL, PLY, pbrt and the files it names) reads
 * its files here. A file whose first two bytes are gzip's magic (1f 8b)
 * is inflated while it is read (zlib, one member after another, as gzip
 * writes them), whatever its name ends in, so "head.ply.gz", a gzipped
 * file named "mesh.obj" and "scene.pbrt.gz" all load. The limit is on what
 * the loader gets: the decompressed bytes, so a small file that inflates
 * beyond it is refused as a large plain file is, before more than the
 * limit is held.
 */
#ifndef RT_SCENE_FILE_H
#define RT_SCENE_FILE_H

#include "rt.h"
#include "scene.h"

#include <stddef.h>
#include <stdint.h>
#include <sys/types.h>

/* A source of bytes: reads at most n bytes into buf, returns how many (0 at
 * the end) or -1 with errno. */
typedef ssize_t (*rt_sfile_read_fn)(void *ctx, void *buf, size_t n);

/* Reads the whole source into a malloc'd NUL-terminated buffer (*pbuf,
 * *pn, caller frees), inflating it when it starts with gzip's magic
 * (*gz = 1, else 0). More than max_bytes of content (after inflation) is
 * refused. 0, or -1 with a one-line reason in why ("gzip data: invalid
 * block type (compressed byte 37)", "truncated gzip data (compressed byte
 * 120)", "more than N bytes (decompressed)", a read error); nothing is
 * held on failure. */
int rt_sfile_read(rt_sfile_read_fn rd, void *ctx, uint64_t max_bytes, char **pbuf, size_t *pn, int *gz, char *why,
                  size_t nwhy);

/* rt_sfile_read from an open file descriptor (read from its current
 * position; not closed). */
int rt_sfile_read_fd(int fd, uint64_t max_bytes, char **pbuf, size_t *pn, int *gz, char *why, size_t nwhy);

/* rt_sfile_read from memory (the fuzz targets and tests). */
int rt_sfile_read_mem(const void *data, size_t n, uint64_t max_bytes, char **pbuf, size_t *pn, int *gz, char *why,
                      size_t nwhy);

/* A scene file by name: opened once with rt_open_regular (regular files
 * only, never blocking on a FIFO), checked on the opened descriptor, then
 * read as rt_sfile_read does with max_bytes. 0, or -1 with "PATH: reason"
 * in e. */
int rt_sfile_slurp(const char *path, uint64_t max_bytes, char **pbuf, size_t *pn, rt_err *e);

/* Load warnings (rt_scene.warn): at most RT_SCENE_MAX_WARN kinds are
 * kept, one entry each with its count and first place; the kinds beyond
 * are counted in one last entry of kind "other". */
#define RT_SCENE_MAX_WARN 256

/* Records one occurrence of warning `kind` at `first` ("FILE:LINE") with
 * message fmt (kept from the first occurrence) in s->warn, and keeps
 * s->warning, the one-line summary the front ends print when they print
 * one line, in step. 0, or -1 out of memory (e set). */
int rt_sfile_warn(rt_scene *s, const char *kind, const char *first, rt_err *e, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 5, 6)))
#endif
    ;

/* Rewrites s->warning from s->warn: "FIRST: MSG (xN)" joined by "; ",
 * with "(+K more kinds of warnings)" when they do not all fit. */
void rt_sfile_warn_summary(rt_scene *s);

#endif
