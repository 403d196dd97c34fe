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
 * by one chunk, independent of the trace's length. After -1 every later
 * call returns -1 with the same message; after 0, 0 again.
 *
 * Sample index (format version 3): after every data chunk the writer
 * stores a side chunk with what a sampled simulation needs of it -- the
 * chunk's line-touch counts per class, its records that touch a line of a
 * golden-ratio line sample, and the exact windows of the hybrid method
 * (cachesim/approx.h) that end in it. rt_tr_read_side returns those
 * instead of the records and reads no record (docs/trace-format.md says
 * what it verifies and what it does not); rt_tr_read checks each side
 * chunk against the records it decodes.
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
    uint64_t sched_size;    /* dynamic: cache size scheduled for (0 = n/a) */
    uint64_t gmax;          /* dynamic: geometry budget (0 = n/a) */
    char params[512];       /* other tracer parameters, "k=v k=v" */
    rt_layout layout;       /* the region table */
    uint32_t generations;   /* highest ray generation a record may carry, 0..255;
                               0 (primary rays only): written as format
                               version 1, every record generation 0; > 0:
                               version 2, a generation per record */
} rt_tr_meta;

/* Per-class totals, kept by the writer and stored in the footer. */
typedef struct rt_tr_totals {
    uint64_t refs[RT_NCLASS];  /* references per class */
    uint64_t bytes[RT_NCLASS]; /* bytes referenced per class (sum of sizes) */
    uint64_t writes[RT_NCLASS];/* write references per class */
    uint64_t nrefs;            /* all references */
    uint64_t nchunks;          /* chunks written */
} rt_tr_totals;

/* Format constants (layout in trace.c and docs/trace-format.md). With
 * rt_tr_wopts.sample set (rt_tr_default_wopts) the writer writes version 3,
 * records and sample index; without it version 1 when meta.generations ==
 * 0 (the bytes of every trace without generations are those of a version-1
 * writer) and version 2 otherwise. The reader accepts 1..RT_TR_FORMAT_VERSION. */
#define RT_TR_FORMAT_VERSION 3        /* newest version; the reader accepts 1..this */
#define RT_TR_MAX_GENERATION 255      /* largest meta.generations / record generation */
#define RT_TR_DEFAULT_LEVEL 3         /* zlib level (3: ~2x faster than 6, +30% size) */
#define RT_TR_DEFAULT_CHUNK 65536     /* records per chunk */
#define RT_TR_MAX_CHUNK (1u << 20)    /* largest records-per-chunk accepted */

/* The sample index a version-3 writer stores (the defaults of the hybrid
 * method in cachesim/approx.h at 64-byte lines, seed 1): lines of
 * RT_TR_SAMPLE_LINE bytes sampled at rate 2^-RT_TR_SAMPLE_SHIFT; one
 * window of RT_TR_SAMPLE_WINDOW records every RT_TR_SAMPLE_PERIOD, its
 * warm-up rebuilding the RT_TR_SAMPLE_CMAX most recent lines from at most
 * RT_TR_SAMPLE_HIST records before it. */
#define RT_TR_SAMPLE_LINE 64
#define RT_TR_SAMPLE_SHIFT 6
#define RT_TR_SAMPLE_SEED 1
#define RT_TR_SAMPLE_PERIOD 65536
#define RT_TR_SAMPLE_WINDOW 1024
#define RT_TR_SAMPLE_CMAX 256
#define RT_TR_SAMPLE_HIST 32768

/* Parameters of a trace's sample index, as stored in its header. */
typedef struct rt_tr_sample_params {
    uint32_t line;          /* line size in bytes, a power of two */
    uint32_t shift;         /* line sample rate 2^-shift (0..32) */
    uint64_t seed;          /* sampling seed: golden offset and window placement */
    uint64_t period;        /* one window every period records, 4096..2^40 */
    uint64_t window;        /* records per window, 1..min(period/2, 16384) */
    uint64_t cmax;          /* lines rebuilt at a window start, 1..4096 */
    uint64_t hist;          /* records scanned back at most, <= min(period - window, 2^20) */
} rt_tr_sample_params;

/* Writer options: zlib level 0..9, records per chunk 1..RT_TR_MAX_CHUNK,
 * and whether to write version 3 with a sample index (1, the default) or
 * the version 1/2 format of earlier writers (0). A zeroed field keeps the
 * earlier format, so options built as {level, chunk} still mean what they
 * meant. */
typedef struct rt_tr_wopts {
    int level;              /* zlib compression level, default 3 */
    uint32_t chunk_records; /* records per chunk, default 65536 */
    int sample;             /* 1: version 3 with the sample index (default); 0: version 1/2 */
} rt_tr_wopts;
void rt_tr_default_wopts(rt_tr_wopts *o);

typedef struct rt_tr_writer rt_tr_writer;
/* Opens PATH.tmp and writes the header. NULL on failure (bad metadata,
 * e.g. generations > RT_TR_MAX_GENERATION; I/O error; out of memory).
 * rt_tr_create uses the default level and chunk size and writes the
 * version 1/2 format (no sample index): its bytes are those of the
 * writers before version 3. rt_tr_create_opts with rt_tr_default_wopts
 * writes version 3. */
rt_tr_writer *rt_tr_create(const char *path, const rt_tr_meta *m, rt_err *e);
rt_tr_writer *rt_tr_create_opts(const char *path, const rt_tr_meta *m, const rt_tr_wopts *o, rt_err *e);
/* Totals of the records accepted so far (owned by w). */
const rt_tr_totals *rt_tr_writer_totals(const rt_tr_writer *w);
/* Message of the first failed put() (I/O error, class out of range, size
 * 0, generation above meta.generations), or "" if none. Owned by w. */
const char *rt_tr_writer_error(const rt_tr_writer *w);
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
/* Records carry their generation (version 1: always 0). */
long rt_tr_read(rt_tr_reader *r, rt_access *buf, size_t cap, rt_err *e);
/* on = 0, before the first rt_tr_read: version-3 side chunks are still
 * read, CRC-checked and inflated, but not rebuilt from the records and
 * compared (the default, on, does that). For readers whose results do not
 * depend on the side chunks: an exact replay spends a third of its
 * decoding time on the rebuild otherwise. */
void rt_tr_set_side_check(rt_tr_reader *r, int on);
/* Byte size of the file (known from rt_tr_open) and a 64-bit FNV-1a hash
 * (rt_fnv1a) of all its bytes (computed while reading; valid after
 * rt_tr_read returned 0). */
uint64_t rt_tr_file_bytes(const rt_tr_reader *r);
uint64_t rt_tr_file_hash(const rt_tr_reader *r);
/* Format version of the open file (1..3) and its records-per-chunk
 * limit. meta.generations is 0 for version 1, 1..255 for version 2, 0..255
 * for version 3. */
uint32_t rt_tr_get_version(const rt_tr_reader *r);
uint32_t rt_tr_get_chunk_records(const rt_tr_reader *r);
void rt_tr_close(rt_tr_reader *r);

/* 1 and the parameters in *p if the trace has a sample index (version
 * 3), else 0. */
int rt_tr_get_sample_params(const rt_tr_reader *r, rt_tr_sample_params *p);

/* One exact window of the sample index: the warm-up lines (one touch
 * each, address line x line-size, size 1, least recent first, write set
 * if the scan saw the line written, class of that write or of the latest
 * touch), then the window's records. */
typedef struct rt_tr_window {
    const rt_access *warm;  /* warm-up touches, least recent first */
    uint32_t nwarm;         /* <= cmax */
    int short_warmup;       /* fewer than cmax lines found, history not from the trace start */
    uint64_t scanned;       /* history records the backward scan read */
    const rt_access *recs;  /* the window's records */
    uint32_t nrecs;         /* = params.window */
} rt_tr_window;

/* The sample index of one data chunk. */
typedef struct rt_tr_side {
    uint64_t nrefs;                      /* records of the data chunk */
    uint64_t touches[RT_NCLASS][2];      /* its line touches (params.line) by class, read/write */
    const rt_access *sampled;            /* its records touching a sampled line, in order */
    uint64_t nsampled;
    const rt_tr_window *win;             /* windows that end in this chunk, in order */
    uint32_t nwin;
} rt_tr_side;

/* Reads the next chunk's sample index into *s (pointers owned by r, valid
 * until the next call): 1, 0 at the verified end of the trace, -1 on an
 * error (message names file and byte offset). Every byte is read, hashed
 * (rt_tr_file_hash) and CRC-checked, but data chunks are not inflated
 * and their records not decoded; the footer's totals are checked against
 * the side chunks' (docs/trace-format.md). A reader serves either
 * rt_tr_read or rt_tr_read_side: the first call decides, the other then
 * fails. -1 also for a trace without a sample index. */
int rt_tr_read_side(rt_tr_reader *r, rt_tr_side *s, rt_err *e);

#endif
