/*
 * sindex.h -- the sample index of a version-3 trace: the side payload
 * raytraffic stores after every data chunk (prefix rt_si_).
 *
 * The trace format (src/trace.h) stores side payloads without knowing what
 * they hold. This module is their maker and their reader: for each data
 * chunk, its line-touch counts per class, its records that touch a line of
 * a golden-ratio line sample (cachesim/sample.h), and the exact windows of the
 * hybrid method (cachesim/approx.h, window.c) that end in it, with their
 * warm-up lines -- what the hybrid method needs of a chunk, so that
 * `sim --method hybrid` reads a trace without decoding its records.
 * Layout: docs/trace-format.md, "Sample index"; invariants: sindex.c.
 *
 * Writing: rt_si_wopts gives writer options (rt_tr_create_opts) that
 * write version 3 with the sample index (the default of `raytraffic
 * trace`). Checking: rt_si_open opens a trace whose rt_tr_read re-makes
 * every side payload from the records and fails on one that differs.
 * Reading: rt_si_read decodes the sample index chunk by chunk without the
 * records.
 */
#ifndef RT_SINDEX_H
#define RT_SINDEX_H

#include "rt.h"
#include "trace.h"

#include <stdint.h>

/* The sample index a writer stores (the defaults of the hybrid method in
 * cachesim/approx.h at 64-byte lines, seed 1): lines of RT_SI_LINE bytes
 * sampled at rate 2^-RT_SI_SHIFT; one window of RT_SI_WINDOW records every
 * RT_SI_PERIOD, its warm-up rebuilding the RT_SI_CMAX most recent lines
 * from at most RT_SI_HIST records before it. */
#define RT_SI_LINE 64
#define RT_SI_SHIFT 6
#define RT_SI_SEED 1
#define RT_SI_PERIOD 65536
#define RT_SI_WINDOW 1024
#define RT_SI_CMAX 256
#define RT_SI_HIST 32768

/* The maker of the sample index, with the parameters above: the payload
 * maker rt_si_wopts and rt_si_open hand to the trace format. */
extern const rt_tr_payload_ops rt_si_payload;

/* rt_tr_default_wopts with the sample index: version 3. */
void rt_si_wopts(rt_tr_wopts *o);

/* rt_tr_open, then rt_tr_set_payload_check with rt_si_payload: the
 * reader's rt_tr_read fails on a side chunk that is not the sample index
 * its records make (trace-info, trace-dump, the tests). Versions 1 and 2
 * read as with rt_tr_open. NULL with e on failure. */
rt_tr_reader *rt_si_open(const char *path, rt_err *e);

/* Checks the invariants of a maker made by rt_si_payload.open (sindex.c,
 * I1-I7): 0, or -1 with the first one violated in e. */
int rt_si_check(const void *maker, rt_err *e);

/* One exact window of the sample index: the warm-up lines (one touch
 * each, address line x line-size, size 1, least recent first, write set
 * if the scan saw the line written, class of that write or of the latest
 * touch), then the window's records. */
typedef struct rt_si_window {
    const rt_access *warm;  /* warm-up touches, least recent first */
    uint32_t nwarm;         /* <= cmax */
    int short_warmup;       /* fewer than cmax lines found, history not from the trace start */
    uint64_t scanned;       /* history records the backward scan read */
    const rt_access *recs;  /* the window's records */
    uint32_t nrecs;         /* = params.window */
} rt_si_window;

/* The sample index of one data chunk. */
typedef struct rt_si_side {
    uint64_t nrefs;                      /* records of the data chunk */
    uint64_t touches[RT_NCLASS][2];      /* its line touches (params.line) by class, read/write */
    const rt_access *sampled;            /* its records touching a sampled line, in order */
    uint64_t nsampled;
    const rt_si_window *win;             /* windows that end in this chunk, in order */
    uint32_t nwin;
} rt_si_side;

/* Decoder of a trace's sample index. rt_si_reader_new borrows r (opened,
 * not yet read; it must outlive the decoder): NULL with e only when out of
 * memory. */
typedef struct rt_si_reader rt_si_reader;
rt_si_reader *rt_si_reader_new(rt_tr_reader *r, rt_err *e);
/* Reads the next chunk's sample index into *s (pointers owned by the
 * decoder, valid until the next call): 1, 0 at the verified end of the
 * trace, -1 on an error (message names file and byte offset). It reads
 * through rt_tr_read_payload (every byte read, hashed and CRC-checked,
 * data chunks not inflated), checks each payload's structure, record
 * encoding and class totals against its chunk, and the footer's totals
 * against the payloads' (docs/trace-format.md); it cannot see a payload
 * that disagrees with valid-CRC records (rt_si_open's check can). -1 also
 * for a trace without a sample index (versions 1 and 2). A reader serves
 * either rt_tr_read or rt_si_read: the first call decides. */
int rt_si_read(rt_si_reader *d, rt_si_side *s, rt_err *e);
void rt_si_reader_free(rt_si_reader *d);

#endif
