/*
 * trace.h -- the raytraffic trace file (.rtt): writer and streaming reader
 * (prefix rt_tr_).
 *
 * A trace is the complete, ordered stream of memory references (address,
 * size, read|write, class, ray generation: rt_access, memmodel.h) that one
 * tracer made while rendering one image, with the metadata that says where
 * it came from (rt_tr_meta: tool, revision, command, scene, tracer, image
 * size, the region table of the modeled memory). The file is a header, then
 * chunks of at most chunk_records records (each one zlib stream of records
 * coded against the previous address and size of their class: trace_rec.h),
 * then, in version 3, a side chunk after every chunk, then a footer with
 * per-class totals. Integers are little-endian, so a trace is the same file
 * on every machine; every byte is covered by a CRC-32 or a magic, so a
 * flipped bit or a truncation is always reported. The byte layout and
 * every check a reader makes are spelled out in trace.c and
 * docs/trace-format.md; what a caller needs is below.
 *
 * Conventions: functions returning a pointer return NULL on failure,
 * functions returning int return 0 (or a count) on success and -1 on
 * failure; a failure's message is written into e (may be NULL), one line
 * naming the file and, for a reader, the byte offset. Nothing here prints.
 * Metadata and totals returned by pointer are owned by the writer or reader
 * and valid until it is finished, aborted or closed.
 *
 * Writer: rt_tr_create opens a unique temporary beside PATH (outfile.h),
 * written as PATH.tmp below, and writes the header; accesses arrive
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
 * Side payloads (format version 3): after every data chunk the writer
 * stores a side chunk whose payload is opaque to the format: bytes a
 * payload maker (rt_tr_payload_ops, handed to the writer in rt_tr_wopts)
 * makes from the chunk's records, compressed and CRC-checked like a chunk.
 * The maker raytraffic uses is the sample index of cachesim/sindex.h; the
 * header stores its parameters (rt_tr_sample_params), which bound a
 * payload's length. A reader returns the payloads raw
 * (rt_tr_read_payload) without reading any record, or, while it decodes
 * the records (rt_tr_read), re-makes each payload with a maker set by
 * rt_tr_set_payload_check and compares the bytes.
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
    uint32_t cores;         /* simulated cores whose interleaved references the trace
                               holds: 0 or 1, one core (versions 1-3 as before);
                               2..RT_TR_MAX_CORES: version 4, each reference's core
                               from core-switch records (rt_tr_put_core,
                               rt_tr_read_cores) */
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
 * rt_tr_wopts.payload set the writer writes version 3, records and side
 * payloads; without it version 1 when meta.generations == 0 (the bytes of
 * every trace without generations are those of a version-1 writer) and
 * version 2 otherwise. The reader accepts 1..RT_TR_FORMAT_VERSION. */
#define RT_TR_FORMAT_VERSION 4        /* newest version; the reader accepts 1..this */
#define RT_TR_MAX_CORES 256           /* largest meta.cores (a core id is one byte) */
#define RT_TR_MAX_GENERATION 255      /* largest meta.generations / record generation */
#define RT_TR_DEFAULT_LEVEL 3         /* zlib level (3: ~2x faster than 6, +30% size) */
#define RT_TR_DEFAULT_CHUNK 65536     /* records per chunk */
#define RT_TR_MAX_CHUNK (1u << 20)    /* largest records-per-chunk accepted */

/* Parameters of a version-3 trace's side payloads, as stored in its header
 * (the meaning of each is the payload maker's: cachesim/sindex.h). The
 * format checks their ranges and bounds a side payload of a chunk of n
 * records by them: at most 1 + 520 + 17 n + (n / period + 2) (31 + 17
 * (cmax + window)) bytes (docs/trace-format.md). */
typedef struct rt_tr_sample_params {
    uint32_t line;          /* line size in bytes, a power of two, 2..65536 */
    uint32_t shift;         /* line sample rate 2^-shift (0..32) */
    uint64_t seed;          /* sampling seed: golden offset and window placement */
    uint64_t period;        /* one window every period records, 4096..2^40 */
    uint64_t window;        /* records per window, 1..min(period/2, 16384) */
    uint64_t cmax;          /* lines rebuilt at a window start, 1..4096 */
    uint64_t hist;          /* records scanned back at most, <= min(period - window, 2^20) */
} rt_tr_sample_params;

/* A maker of side payloads: given every record of a trace in order, it
 * makes one payload per data chunk, a deterministic function of the
 * records (so a reader can re-make and compare it). open starts a maker
 * for the header's parameters and generation limit (NULL with e on
 * failure); put feeds n valid records (0, or -1: out of memory); chunk
 * ends the data chunk whose records were fed since the last call and sets
 * *bytes (owned by the maker, valid until its next call) and *len to its
 * payload, whose byte 0 must have bit 0 set if last (the trace ends with
 * this chunk) and clear if not, bits 1-2 (RT_TR_SIDE_MAKER) as the maker
 * likes and the others clear, and whose length must be 1..the bound above (0, or
 * -1: out of memory); close frees it (NULL is fine). */
#define RT_TR_SIDE_MAKER 0x06 /* bits of a side payload's byte 0 the maker owns (sample index: classes beyond 10) */
typedef struct rt_tr_payload_ops {
    rt_tr_sample_params params; /* what a writer stores in the header and opens the maker with */
    void *(*open)(const rt_tr_sample_params *p, unsigned generations, rt_err *e);
    int (*put)(void *ctx, const rt_access *a, size_t n);
    int (*chunk)(void *ctx, int last, const unsigned char **bytes, size_t *len);
    void (*close)(void *ctx);
} rt_tr_payload_ops;

/* Writer options: zlib level 0..9, records per chunk 1..RT_TR_MAX_CHUNK,
 * and the maker of side payloads (version 3; cachesim/sindex.h
 * rt_si_wopts sets the sample index's) or NULL for the version 1/2
 * format of earlier writers. rt_tr_default_wopts sets the default level
 * and chunk size and no payload; a zeroed payload keeps the earlier
 * format, so options built as {level, chunk} still mean what they meant. */
typedef struct rt_tr_wopts {
    int level;              /* zlib compression level, default 3 */
    uint32_t chunk_records; /* records per chunk, default 65536 */
    const rt_tr_payload_ops *payload; /* non-NULL: version 3 with its side payloads; NULL: version 1/2 */
} rt_tr_wopts;

/* Fills *o with the defaults: RT_TR_DEFAULT_LEVEL, RT_TR_DEFAULT_CHUNK,
 * no payload (the version 1/2 format). */
void rt_tr_default_wopts(rt_tr_wopts *o);

typedef struct rt_tr_writer rt_tr_writer;
/* Opens PATH.tmp (a unique temporary beside PATH; PATH itself is replaced
 * only by rt_tr_finish; rt_out_open, outfile.h, says which targets are
 * refused) and writes the header from m (read during the call only). NULL on failure (bad metadata,
 * e.g. generations > RT_TR_MAX_GENERATION; bad options or payload
 * parameters; I/O error; out of memory). rt_tr_create uses
 * rt_tr_default_wopts: the version 1/2 format, whose bytes are those of
 * the writers before version 3. */
rt_tr_writer *rt_tr_create(const char *path, const rt_tr_meta *m, rt_err *e);
rt_tr_writer *rt_tr_create_opts(const char *path, const rt_tr_meta *m, const rt_tr_wopts *o, rt_err *e);
/* Totals of the records accepted so far (owned by w). */
const rt_tr_totals *rt_tr_writer_totals(const rt_tr_writer *w);
/* Message of the first failed put() (I/O error, class out of range, size
 * 0, generation above meta.generations, a payload maker's failure), or ""
 * if none. Owned by w. */
const char *rt_tr_writer_error(const rt_tr_writer *w);
/* The sink accesses are written through (owned by w; a recorder may hold
 * it until rt_tr_finish or rt_tr_abort). Its put() encodes the records
 * into the current chunk, compressing and writing a chunk (and, version 3,
 * its side chunk) each time chunk_records are pending; it returns -1 after
 * the first failure, whose message rt_tr_writer_error gives, and drops
 * every later access. */
rt_sink *rt_tr_sink(rt_tr_writer *w);
/* The writer as a core sink (rt_tr_put_core): for meta.cores > 1. */
rt_csink *rt_tr_csink(rt_tr_writer *w);
/* Puts n records made by core `core` (< meta.cores; version 4): a
 * core-switch record (2 bytes) goes before the first of them when the
 * previous record was another core's or a chunk starts. The sink's put
 * is core 0's. 0, or -1 (the error in rt_tr_writer_error). */
int rt_tr_put_core(rt_tr_writer *w, unsigned core, const rt_access *a, size_t n);
/* Writes the last chunk and the footer, flushes, and renames PATH.tmp to
 * PATH. Frees w in every case (the temporary is removed on failure). 0, or
 * -1 naming the first failure: a failed put(), an I/O error, a failed
 * rename. */
int rt_tr_finish(rt_tr_writer *w, rt_err *e);
/* Discards the temporary file and frees w (NULL is fine). */
void rt_tr_abort(rt_tr_writer *w);

typedef struct rt_tr_reader rt_tr_reader;
/* Opens path (a regular file) and reads and checks its header: magic,
 * version 1..RT_TR_FORMAT_VERSION, header CRC, every field in range. NULL
 * with e naming the file and offset on any failure. Memory: one chunk's
 * buffers, whatever the trace's length. */
rt_tr_reader *rt_tr_open(const char *path, rt_err *e);
/* The header's metadata (owned by r). */
const rt_tr_meta *rt_tr_get_meta(const rt_tr_reader *r);
/* Totals from the footer; valid only after rt_tr_read returned 0. */
const rt_tr_totals *rt_tr_get_totals(const rt_tr_reader *r);
/* Decodes up to cap records into buf, in the order they were written;
 * records carry their generation (version 1: always 0). Returns the count
 * (> 0), 0 at the verified end of the trace (the footer's CRC and totals
 * checked, nothing after it), or -1 on truncation or corruption, e naming
 * the file and byte offset. After -1 every later call returns -1 with the
 * same message; after 0, 0 again. */
long rt_tr_read(rt_tr_reader *r, rt_access *buf, size_t cap, rt_err *e);
/* The same, with each record's core in cores[i] (cores may be NULL;
 * versions 1-3: every record core 0). */
long rt_tr_read_cores(rt_tr_reader *r, rt_access *buf, uint8_t *cores, size_t cap, rt_err *e);
/* Before the first rt_tr_read of a version-3 trace: the maker whose
 * payloads the trace is meant to hold (cachesim/sindex.h rt_si_open sets
 * the sample index's). rt_tr_read then feeds it every record it decodes
 * and fails, naming the file and the side chunk's offset, when a side
 * payload is not byte for byte what it makes; without one (the default),
 * side chunks are read, CRC-checked and inflated but not compared. Ignored
 * for versions 1 and 2. */
void rt_tr_set_payload_check(rt_tr_reader *r, const rt_tr_payload_ops *ops);
/* on = 0, before the first rt_tr_read: the payload check set above is
 * not made (side chunks still read, CRC-checked and inflated). For
 * readers whose results do not depend on the side chunks: an exact replay
 * spends a third of its decoding time on the rebuild otherwise. on = 1
 * (the default) makes it again. */
void rt_tr_set_side_check(rt_tr_reader *r, int on);
/* Byte size of the file (known from rt_tr_open) and a 64-bit FNV-1a hash
 * (rt_fnv1a) of all its bytes (computed while reading; valid after
 * rt_tr_read returned 0). */
uint64_t rt_tr_file_bytes(const rt_tr_reader *r);
uint64_t rt_tr_file_hash(const rt_tr_reader *r);
/* Format version of the open file (1..4) and its records-per-chunk
 * limit. meta.generations is 0 for version 1, 1..255 for version 2, 0..255
 * for versions 3 and 4; meta.cores is 1 for versions 1-3, 2..256 for 4. */
uint32_t rt_tr_get_version(const rt_tr_reader *r);
uint32_t rt_tr_get_chunk_records(const rt_tr_reader *r);
/* Closes the file and frees r (NULL is fine). */
void rt_tr_close(rt_tr_reader *r);

/* 1 and the parameters in *p if the trace has side payloads (version 3),
 * else 0. */
int rt_tr_get_sample_params(const rt_tr_reader *r, rt_tr_sample_params *p);

/* One side payload, as rt_tr_read_payload returns it. */
typedef struct rt_tr_payload {
    const unsigned char *bytes; /* the inflated payload (owned by the reader, valid until its next call) */
    uint32_t len;               /* its length, >= 1 */
    int last;                   /* its byte 0: 1 for the last data chunk, else 0 */
    uint32_t nrefs;             /* records of its data chunk */
    uint64_t index;             /* its data chunk's index, 0, 1, ... */
    uint64_t offset;            /* file offset of the side chunk, for messages */
} rt_tr_payload;

/* Reads the next data chunk's side payload into *p: 1, 0 at the verified
 * end of the trace, -1 on an error (message names file and byte offset).
 * Every byte is read, hashed (rt_tr_file_hash) and CRC-checked, and side
 * chunks are inflated, but data chunks are not inflated and their records
 * not decoded; the footer's chunk and record counts are checked, and its
 * per-class totals against what rt_tr_payload_tally reported, if anything
 * was (docs/trace-format.md). A reader serves either rt_tr_read or
 * rt_tr_read_payload: the first call decides, the other then fails. -1
 * also for a trace without side payloads. */
int rt_tr_read_payload(rt_tr_reader *r, rt_tr_payload *p, rt_err *e);
/* The per-class totals (refs, bytes, writes; nrefs and nchunks ignored)
 * a payload decoder found in the payload just read, for the footer check
 * at the end of rt_tr_read_payload. */
void rt_tr_payload_tally(rt_tr_reader *r, const rt_tr_totals *t);
/* A payload decoder's verdict on the payload just read: the reader fails
 * from now on with "FILE: byte OFFSET: side chunk INDEX: " and the
 * message; returns -1 with that message in e. */
#if defined(__GNUC__)
__attribute__((format(printf, 3, 4)))
#endif
int rt_tr_payload_fail(rt_tr_reader *r, rt_err *e, const char *fmt, ...);

#endif
