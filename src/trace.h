/*
 * trace.h -- the raytraffic trace file (.rtt): writer and streaming reader.
 *
 * (The essay comment describing the on-disk format and its invariants is in
 * trace.c and docs/trace-format.md.)
 *
 * Writer: rt_tr_create opens PATH.tmp, writes the header; accesses arrive
 * through the rt_sink returned by rt_tr_sink (so a tracer's recorder can
 * feed it directly); rt_tr_finish writes the last chunk and the footer,
 * flushes and renames PATH.tmp to PATH. rt_tr_abort removes PATH.tmp, so an
 * interrupted write never leaves a file that looks complete.
 *
 * Reader: rt_tr_open checks magic and version and parses the header;
 * rt_tr_read fills a caller buffer with records and returns how many
 * (> 0), 0 at the verified end of the trace, or -1 on truncation or
 * corruption (message names the file and byte offset). Memory is bounded
 * by one chunk, independent of the trace's length.
 */
#ifndef RT_TRACE_H
#define RT_TRACE_H

#include "memmodel.h"
#include "rt.h"

#include <stdint.h>

typedef struct rt_tr_meta {
    char tool_version[32];  /* raytraffic version that wrote it */
    char git_rev[48];       /* its git revision */
    char command[1024];     /* command line that produced it */
    char scene[128];        /* scene spec (name or file) */
    char scene_params[128]; /* canonical scene parameters */
    uint64_t scene_hash;    /* rt_scene_hash */
    uint32_t ntri;          /* scene triangles */
    char tracer[32];        /* "recursive", "packet", "dynamic", ... */
    int32_t W, H;           /* image size */
    uint32_t lights;        /* enabled-light mask */
    uint64_t cache_size;    /* dynamic: cache size scheduled for (0 = n/a) */
    uint64_t gmax;          /* dynamic: geometry budget (0 = n/a) */
    char params[512];       /* other tracer parameters, "k=v k=v" */
    rt_layout layout;       /* the region table */
} rt_tr_meta;

/* Per-class totals, kept by the writer and stored in the footer. */
typedef struct rt_tr_totals {
    uint64_t refs[RT_NCLASS];  /* references per class */
    uint64_t bytes[RT_NCLASS]; /* bytes referenced per class (sum of sizes) */
    uint64_t writes[RT_NCLASS];/* write references per class */
    uint64_t nrefs;            /* all references */
    uint64_t nchunks;          /* chunks written */
} rt_tr_totals;

typedef struct rt_tr_writer rt_tr_writer;
rt_tr_writer *rt_tr_create(const char *path, const rt_tr_meta *m, rt_err *e);
rt_sink *rt_tr_sink(rt_tr_writer *w);
/* Finishes and renames into place. Frees w in every case. 0 or -1. */
int rt_tr_finish(rt_tr_writer *w, rt_err *e);
/* Discards the temporary file and frees w (NULL is fine). */
void rt_tr_abort(rt_tr_writer *w);

typedef struct rt_tr_reader rt_tr_reader;
rt_tr_reader *rt_tr_open(const char *path, rt_err *e);
const rt_tr_meta *rt_tr_get_meta(const rt_tr_reader *r);
/* Totals from the footer; valid only after rt_tr_read returned 0. */
const rt_tr_totals *rt_tr_get_totals(const rt_tr_reader *r);
long rt_tr_read(rt_tr_reader *r, rt_access *buf, size_t cap, rt_err *e);
/* Byte size of the file and a 64-bit hash of its contents (computed while
 * reading; valid after rt_tr_read returned 0). */
uint64_t rt_tr_file_bytes(const rt_tr_reader *r);
uint64_t rt_tr_file_hash(const rt_tr_reader *r);
void rt_tr_close(rt_tr_reader *r);

#endif
