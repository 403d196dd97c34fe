/*
 * trace.c -- the raytraffic trace file (.rtt): writer and streaming reader.
 *
 * WHAT IT IS. A trace is the complete, ordered stream of memory references
 * (address, size, read|write, class, ray generation) one tracer made while
 * rendering one
 * image, plus everything needed to say where it came from. Traces are big
 * (tens to hundreds of millions of references), are read many times (one
 * pass per cache configuration), and are kept as evidence for published
 * numbers, so the format is compact, streamable with bounded memory,
 * self-describing and tamper-evident.
 *
 * LAYOUT. All integers are little-endian and are written byte by byte, so a
 * given trace is the same file on every machine. "u32"/"u64" are unsigned
 * fixed-width; "str" is a u16 length followed by that many bytes (no NUL).
 *
 *   header   "RTTRACE\0"              8 bytes magic
 *            u32 format version       1 or 2; a reader rejects versions it
 *                                     does not know (message names both)
 *            u32 P                    payload length (<= 64 KiB)
 *            P bytes payload          see below
 *            u32 CRC-32               of all header bytes before it
 *   chunk*   "RTCK"                   chunk magic
 *            u32 chunk index          0, 1, 2, ... (detects lost/reordered chunks)
 *            u32 n                    records, 1..chunk_records
 *            u32 U                    encoded (uncompressed) length, n..16n
 *                                     (version 2: n..17n)
 *            u32 C                    compressed length, 1..compressBound(U)+64
 *            u32 CRC-32               of the 20 bytes above, then the C bytes
 *            C bytes                  one complete zlib stream inflating to U bytes
 *   footer   "RTND"                   footer magic
 *            u32 nclass               10 (RT_NCLASS)
 *            u64 nrefs, u64 nchunks
 *            nclass x (u64 refs, u64 bytes, u64 writes)
 *            u32 CRC-32               of the footer bytes before it
 *   (end of file: any byte after the footer is an error)
 *
 * Header payload (version 1): u32 chunk_records, u8 zlib level (for
 * information), str tool_version, str git_rev, str command, str scene,
 * str scene_params, u64 scene_hash, u32 ntri, str tracer, u32 W, u32 H,
 * u32 lights, u64 sched_size, u64 gmax, str params, then the region table:
 * u32 nregions (<= RT_MM_MAX_REGIONS), u64 layout.next, and per region
 * str name, u8 class, u32 recsize, u64 count, u64 base. Version 2 appends
 * u32 generations (1..255, the highest generation a record may carry).
 * Every str must fit its rt_tr_meta field with its NUL and may not contain
 * NUL bytes; the payload must be consumed exactly.
 *
 * RECORD ENCODING (inside a chunk, before zlib). Per class c the coder
 * keeps the previous address A[c] and size S[c], both 0 at the start of
 * every chunk (chunks decode independently). A record is:
 *
 *   tag byte   bits 0-3 class, bit 4 write, bit 5 size == S[c],
 *              bit 6 address == A[c] + S[c] ("sequential"), bit 7 version
 *              1: zero; version 2: the generation changes
 *   [u8]       version 2, if bit 7: the record's generation G, which must
 *              differ from the current one and be <= the header's
 *              generations; it stays current for the records after it
 *   [varint]   unless bit 6: zigzag(address - A[c]) as LEB128, <= 10 bytes
 *   [varint]   unless bit 5: size as LEB128, 1..2^32-1, <= 5 bytes
 *
 * The current generation is 0 at the start of every chunk. Tracers work on
 * one generation for many references in a row (the recursive tracer per
 * ray, breadth-first tracers per wave), so a generation costs one byte
 * per change, nothing per record, and a version-2 chunk whose records are
 * all generation 0 is byte for byte a version-1 chunk. The writer picks
 * version 1 when the metadata declares no generations, so traces of runs
 * without secondary rays stay exactly what they were.
 *
 * Address arithmetic wraps modulo 2^64, so every address 0..2^64-1 has an
 * encoding. A k-d traversal revisits the same node sequences for
 * neighbouring rays, so the byte stream repeats itself and zlib removes the
 * rest: see docs/trace-format.md for measured bytes per reference.
 *
 * INVARIANTS a reader checks (every violation is an error naming the file
 * and byte offset, never a short successful read):
 *   - magic, version and header CRC; chunk magic, index, bounds on n/U/C,
 *     chunk CRC; the zlib stream ends exactly at C bytes and inflates to
 *     exactly U bytes; the records consume exactly U bytes;
 *   - class < RT_NCLASS, bit 7 clear (version 1), a generation byte that
 *     changes the generation and stays <= the header's (version 2),
 *     varints not overlong, size >= 1;
 *   - the footer's CRC is valid, and its totals equal the totals of the
 *     records actually read; nothing follows the footer.
 *   Every byte of the file is covered by a CRC or checked against a magic,
 *   so any single flipped bit and any truncation is detected. rt_tr_read
 *   returns 0 only after all of this has been verified.
 *
 * WRITER. Records are encoded as they arrive (through the rt_sink) into a
 * buffer of one chunk; a full buffer is deflated and written. Memory is one
 * chunk's raw and compressed buffers (~2 MiB at the default 64K records).
 * The file goes through outfile.c: a unique temporary beside PATH, renamed
 * to PATH only by rt_tr_finish after the footer is flushed and synced;
 * rt_tr_abort removes the temporary. So a file at PATH is always complete,
 * and of two writers to one PATH the last to finish wins.
 *
 * READER. Reads sequentially through stdio, keeps one chunk in memory and
 * decodes records into the caller's buffer on demand; it hashes every byte
 * (FNV-1a 64) for provenance.
 */
#include "trace.h"
#include "outfile.h"

#include <errno.h>
#include <limits.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>
#include <zlib.h>

static const unsigned char HDR_MAGIC[8] = {'R', 'T', 'T', 'R', 'A', 'C', 'E', 0};
static const unsigned char CHUNK_MAGIC[4] = {'R', 'T', 'C', 'K'};
static const unsigned char FOOT_MAGIC[4] = {'R', 'T', 'N', 'D'};

#define MAX_HDR_PAYLOAD 65536u
#define MAX_REC_BYTES_V1 16u /* tag + 10-byte address varint + 5-byte size varint */
#define MAX_REC_BYTES 17u    /* version 2: + generation byte */
#define CHUNK_HDR 24u
#define FOOT_LEN (4u + 4u + 16u + 24u * RT_NCLASS + 4u)

#define TAG_CLASS 0x0fu
#define TAG_WRITE 0x10u
#define TAG_SAMESIZE 0x20u
#define TAG_SEQ 0x40u
#define TAG_GEN 0x80u /* version 2; reserved (zero) in version 1 */

/* ---- little-endian helpers ------------------------------------------------ */

static void put32(unsigned char *p, uint32_t v)
{
    for (int i = 0; i < 4; i++) p[i] = (unsigned char)(v >> (8 * i));
}
static void put64(unsigned char *p, uint64_t v)
{
    for (int i = 0; i < 8; i++) p[i] = (unsigned char)(v >> (8 * i));
}
static uint32_t get32(const unsigned char *p)
{
    uint32_t v = 0;
    for (int i = 0; i < 4; i++) v |= (uint32_t)p[i] << (8 * i);
    return v;
}
static uint64_t get64(const unsigned char *p)
{
    uint64_t v = 0;
    for (int i = 0; i < 8; i++) v |= (uint64_t)p[i] << (8 * i);
    return v;
}

static uint32_t crc(uint32_t c, const unsigned char *p, size_t n)
{
    while (n > 0) {
        uInt k = n > 0x40000000u ? 0x40000000u : (uInt)n;
        c = (uint32_t)crc32(c, p, k);
        p += k;
        n -= k;
    }
    return c;
}

static uint64_t bound_compressed(uint64_t u) { return (uint64_t)compressBound((uLong)u) + 64; }

/* ---- header payload buffer ------------------------------------------------ */

typedef struct hbuf {
    unsigned char b[MAX_HDR_PAYLOAD]; /* bytes */
    size_t n;                         /* used (writer) or position (reader) */
    size_t len;                       /* payload length (reader) */
    int bad;                          /* overflow / underflow */
} hbuf;

static void hb_bytes(hbuf *h, const void *p, size_t n)
{
    if (h->bad || n > sizeof h->b - h->n) {
        h->bad = 1;
        return;
    }
    memcpy(h->b + h->n, p, n);
    h->n += n;
}
static void hb_u8(hbuf *h, unsigned v)
{
    unsigned char c = (unsigned char)v;
    hb_bytes(h, &c, 1);
}
static void hb_u32(hbuf *h, uint32_t v)
{
    unsigned char b[4];
    put32(b, v);
    hb_bytes(h, b, 4);
}
static void hb_u64(hbuf *h, uint64_t v)
{
    unsigned char b[8];
    put64(b, v);
    hb_bytes(h, b, 8);
}
static void hb_str(hbuf *h, const char *s, size_t cap)
{
    size_t n = strnlen(s, cap);
    if (n >= cap || n > 0xffff) {
        h->bad = 1;
        return;
    }
    unsigned char b[2] = {(unsigned char)n, (unsigned char)(n >> 8)};
    hb_bytes(h, b, 2);
    hb_bytes(h, s, n);
}

static const unsigned char *hg(hbuf *h, size_t n)
{
    if (h->bad || n > h->len - h->n) {
        h->bad = 1;
        return NULL;
    }
    const unsigned char *p = h->b + h->n;
    h->n += n;
    return p;
}
static unsigned hg_u8(hbuf *h)
{
    const unsigned char *p = hg(h, 1);
    return p ? p[0] : 0;
}
static uint32_t hg_u32(hbuf *h)
{
    const unsigned char *p = hg(h, 4);
    return p ? get32(p) : 0;
}
static uint64_t hg_u64(hbuf *h)
{
    const unsigned char *p = hg(h, 8);
    return p ? get64(p) : 0;
}
/* Reads a str into dst[cap]; returns 0 or -1 (too long / NUL inside). */
static int hg_str(hbuf *h, char *dst, size_t cap)
{
    const unsigned char *p = hg(h, 2);
    if (!p) return -1;
    size_t n = (size_t)p[0] | (size_t)p[1] << 8;
    if (n >= cap) return -1;
    if (!(p = hg(h, n))) return -1;
    if (memchr(p, 0, n)) return -1;
    memcpy(dst, p, n);
    dst[n] = 0;
    return 0;
}

/* ---- writer ---------------------------------------------------------------- */

struct rt_tr_writer {
    rt_sink sink;           /* handed to recorders; ctx = this */
    rt_out *of;             /* the output (a temporary until finished) */
    FILE *f;                /* its stream */
    char *path;             /* final path, for messages */
    uint32_t chunk_records; /* records per chunk */
    unsigned char *raw;     /* encoded records of the current chunk */
    size_t rawlen;          /* bytes in raw */
    uint32_t nrec;          /* records in raw */
    unsigned char *out;     /* compressed chunk (header + payload) */
    size_t outcap;          /* its capacity */
    z_stream zs;            /* deflate state, reset per chunk */
    int zinit;              /* zs initialised */
    uint64_t prev_addr[16]; /* per-class coder state */
    uint32_t prev_size[16];
    unsigned prev_gen;      /* current generation in the chunk */
    unsigned maxgen;        /* meta.generations: 0 = version 1 */
    rt_tr_totals tot;       /* totals so far */
    uint64_t written;       /* bytes written to the file */
    int failed;             /* a put failed; err holds why */
    rt_err err;             /* first failure */
};

void rt_tr_default_wopts(rt_tr_wopts *o)
{
    o->level = RT_TR_DEFAULT_LEVEL;
    o->chunk_records = RT_TR_DEFAULT_CHUNK;
}

static int w_write(rt_tr_writer *w, const void *p, size_t n, rt_err *e)
{
    if (fwrite(p, 1, n, w->f) != n)
        return rt_errf(e, "%s: byte %llu: write failed: %s", w->path, (unsigned long long)w->written,
                       strerror(errno ? errno : EIO));
    w->written += n;
    return 0;
}

static int w_flush_chunk(rt_tr_writer *w, rt_err *e)
{
    if (w->nrec == 0) return 0;
    if (w->tot.nchunks >= UINT32_MAX) return rt_errf(e, "%s: more than 2^32-1 chunks", w->path);
    unsigned char *h = w->out;
    w->zs.next_in = w->raw;
    w->zs.avail_in = (uInt)w->rawlen;
    w->zs.next_out = w->out + CHUNK_HDR;
    w->zs.avail_out = (uInt)(w->outcap - CHUNK_HDR);
    int zr = deflate(&w->zs, Z_FINISH);
    if (zr != Z_STREAM_END) return rt_errf(e, "%s: zlib deflate failed (%d)", w->path, zr);
    size_t clen = w->outcap - CHUNK_HDR - w->zs.avail_out;
    if (deflateReset(&w->zs) != Z_OK) return rt_errf(e, "%s: zlib deflateReset failed", w->path);
    memcpy(h, CHUNK_MAGIC, 4);
    put32(h + 4, (uint32_t)w->tot.nchunks);
    put32(h + 8, w->nrec);
    put32(h + 12, (uint32_t)w->rawlen);
    put32(h + 16, (uint32_t)clen);
    uint32_t c = crc(crc(0, h, 20), h + CHUNK_HDR, clen);
    put32(h + 20, c);
    if (w_write(w, h, CHUNK_HDR + clen, e) < 0) return -1;
    w->tot.nchunks++;
    w->nrec = 0;
    w->rawlen = 0;
    memset(w->prev_addr, 0, sizeof w->prev_addr);
    memset(w->prev_size, 0, sizeof w->prev_size);
    w->prev_gen = 0;
    return 0;
}

static inline unsigned char *put_varint(unsigned char *p, uint64_t v)
{
    while (v >= 0x80) {
        *p++ = (unsigned char)(v | 0x80);
        v >>= 7;
    }
    *p++ = (unsigned char)v;
    return p;
}

static int w_put(rt_sink *s, const rt_access *a, size_t n)
{
    rt_tr_writer *w = s->ctx;
    if (w->failed) return -1;
    for (size_t i = 0; i < n; i++) {
        unsigned cls = a[i].cls, gen = a[i].gen;
        uint64_t addr = a[i].addr;
        uint32_t size = a[i].size;
        if (cls >= RT_NCLASS || size == 0 || gen > w->maxgen) {
            if (gen > w->maxgen)
                rt_errf(&w->err, "%s: record %llu: generation %u above the %u declared in the header%s", w->path,
                        (unsigned long long)w->tot.nrefs, gen, w->maxgen,
                        w->maxgen ? "" : " (set rt_tr_meta.generations for a run with secondary rays)");
            else
                rt_errf(&w->err, "%s: record %llu: %s", w->path, (unsigned long long)w->tot.nrefs,
                        cls >= RT_NCLASS ? "class out of range" : "size 0");
            w->failed = 1;
            return -1;
        }
        unsigned char *p = w->raw + w->rawlen;
        unsigned char *tag = p++;
        unsigned t = cls | (a[i].write ? TAG_WRITE : 0);
        if (gen != w->prev_gen) { /* only possible in version 2 */
            t |= TAG_GEN;
            *p++ = (unsigned char)gen;
            w->prev_gen = gen;
        }
        uint64_t pa = w->prev_addr[cls];
        uint32_t ps = w->prev_size[cls];
        if (addr == pa + ps) t |= TAG_SEQ;
        else {
            uint64_t d = addr - pa;
            p = put_varint(p, (d << 1) ^ (0 - (d >> 63)));
        }
        if (size == ps) t |= TAG_SAMESIZE;
        else p = put_varint(p, size);
        *tag = (unsigned char)t;
        w->rawlen = (size_t)(p - w->raw);
        w->prev_addr[cls] = addr;
        w->prev_size[cls] = size;
        w->tot.refs[cls]++;
        w->tot.bytes[cls] += size;
        w->tot.writes[cls] += a[i].write != 0;
        w->tot.nrefs++;
        if (++w->nrec == w->chunk_records && w_flush_chunk(w, &w->err) < 0) {
            w->failed = 1;
            return -1;
        }
    }
    return 0;
}

static int encode_header(hbuf *h, const rt_tr_meta *m, uint32_t chunk_records, int level)
{
    h->n = 0;
    h->bad = 0;
    hb_u32(h, chunk_records);
    hb_u8(h, (unsigned)level);
    hb_str(h, m->tool_version, sizeof m->tool_version);
    hb_str(h, m->git_rev, sizeof m->git_rev);
    hb_str(h, m->command, sizeof m->command);
    hb_str(h, m->scene, sizeof m->scene);
    hb_str(h, m->scene_params, sizeof m->scene_params);
    hb_u64(h, m->scene_hash);
    hb_u32(h, m->ntri);
    hb_str(h, m->tracer, sizeof m->tracer);
    hb_u32(h, (uint32_t)m->W);
    hb_u32(h, (uint32_t)m->H);
    hb_u32(h, m->lights);
    hb_u64(h, m->sched_size);
    hb_u64(h, m->gmax);
    hb_str(h, m->params, sizeof m->params);
    const rt_layout *L = &m->layout;
    if (L->n < 0 || L->n > RT_MM_MAX_REGIONS) return -1;
    hb_u32(h, (uint32_t)L->n);
    hb_u64(h, L->next);
    for (int i = 0; i < L->n; i++) {
        const rt_region *r = &L->r[i];
        if (r->cls >= RT_NCLASS) return -1;
        hb_str(h, r->name, sizeof r->name);
        hb_u8(h, r->cls);
        hb_u32(h, r->recsize);
        hb_u64(h, r->count);
        hb_u64(h, r->base);
    }
    if (m->generations > RT_TR_MAX_GENERATION) return -1;
    if (m->generations) hb_u32(h, m->generations); /* version 2 */
    return h->bad ? -1 : 0;
}

rt_tr_writer *rt_tr_create(const char *path, const rt_tr_meta *m, rt_err *e)
{
    rt_tr_wopts o;
    rt_tr_default_wopts(&o);
    return rt_tr_create_opts(path, m, &o, e);
}

rt_tr_writer *rt_tr_create_opts(const char *path, const rt_tr_meta *m, const rt_tr_wopts *o, rt_err *e)
{
    if (o->level < 0 || o->level > 9) return rt_errf(e, "%s: zlib level %d not in 0..9", path, o->level), NULL;
    if (o->chunk_records < 1 || o->chunk_records > RT_TR_MAX_CHUNK)
        return rt_errf(e, "%s: %u records per chunk not in 1..%u", path, o->chunk_records, RT_TR_MAX_CHUNK), NULL;
    hbuf *h = rt_calloc(1, sizeof *h, e);
    if (!h) return NULL;
    if (m->W < 0 || m->H < 0 || encode_header(h, m, o->chunk_records, o->level) < 0) {
        free(h);
        return rt_errf(e, "%s: trace metadata does not fit the format (string too long, bad region table, "
                       "more than %d generations)", path, RT_TR_MAX_GENERATION), NULL;
    }
    rt_tr_writer *w = rt_calloc(1, sizeof *w, e);
    if (!w) {
        free(h);
        return NULL;
    }
    w->sink.put = w_put;
    w->sink.ctx = w;
    w->chunk_records = o->chunk_records;
    w->maxgen = m->generations;
    size_t plen = strlen(path);
    w->path = rt_calloc(plen + 1, 1, e);
    w->raw = w->path ? rt_calloc(o->chunk_records, MAX_REC_BYTES, e) : NULL;
    if (!w->raw) goto fail;
    memcpy(w->path, path, plen + 1);
    if (deflateInit(&w->zs, o->level) != Z_OK) {
        rt_errf(e, "%s: zlib deflateInit failed", path);
        goto fail;
    }
    w->zinit = 1;
    w->outcap = CHUNK_HDR + deflateBound(&w->zs, (uLong)o->chunk_records * MAX_REC_BYTES);
    if (!(w->out = rt_calloc(w->outcap, 1, e))) goto fail;
    if (!(w->of = rt_out_open(path, e))) goto fail;
    w->f = rt_out_stream(w->of);
    unsigned char pre[16];
    memcpy(pre, HDR_MAGIC, 8);
    put32(pre + 8, m->generations ? 2 : 1);
    put32(pre + 12, (uint32_t)h->n);
    unsigned char c[4];
    put32(c, crc(crc(0, pre, 16), h->b, h->n));
    if (w_write(w, pre, 16, e) < 0 || w_write(w, h->b, h->n, e) < 0 || w_write(w, c, 4, e) < 0) goto fail;
    free(h);
    return w;
fail:
    free(h);
    rt_tr_abort(w);
    return NULL;
}

rt_sink *rt_tr_sink(rt_tr_writer *w) { return &w->sink; }
const rt_tr_totals *rt_tr_writer_totals(const rt_tr_writer *w) { return &w->tot; }
const char *rt_tr_writer_error(const rt_tr_writer *w) { return w->err.msg; }

static void w_free(rt_tr_writer *w)
{
    if (w->zinit) deflateEnd(&w->zs);
    free(w->raw);
    free(w->out);
    free(w->path);
    free(w);
}

int rt_tr_finish(rt_tr_writer *w, rt_err *e)
{
    if (!w) return rt_errf(e, "rt_tr_finish: no writer");
    if (w->failed) {
        rt_errf(e, "%s", w->err.msg);
        rt_tr_abort(w);
        return -1;
    }
    if (w_flush_chunk(w, e) < 0) goto fail;
    unsigned char f[FOOT_LEN];
    memcpy(f, FOOT_MAGIC, 4);
    put32(f + 4, RT_NCLASS);
    put64(f + 8, w->tot.nrefs);
    put64(f + 16, w->tot.nchunks);
    for (int c = 0; c < RT_NCLASS; c++) {
        put64(f + 24 + 24 * c, w->tot.refs[c]);
        put64(f + 32 + 24 * c, w->tot.bytes[c]);
        put64(f + 40 + 24 * c, w->tot.writes[c]);
    }
    put32(f + FOOT_LEN - 4, crc(0, f, FOOT_LEN - 4));
    if (w_write(w, f, FOOT_LEN, e) < 0) goto fail;
    rt_out *of = w->of;
    w->of = NULL;
    w->f = NULL;
    int rc = rt_out_commit(of, e);
    w_free(w);
    return rc;
fail:
    rt_tr_abort(w);
    return -1;
}

void rt_tr_abort(rt_tr_writer *w)
{
    if (!w) return;
    rt_out_abort(w->of);
    w_free(w);
}

/* ---- reader ---------------------------------------------------------------- */

enum { RS_CHUNKS = 0, RS_DONE = 1, RS_FAILED = -1 };

struct rt_tr_reader {
    FILE *f;                /* the file */
    char *path;             /* for messages */
    uint64_t off;           /* bytes consumed */
    uint64_t fsize;         /* file size (fstat) */
    uint64_t hash;          /* FNV-1a of bytes consumed */
    uint32_t version;       /* format version */
    uint32_t chunk_records; /* max records per chunk */
    rt_tr_meta meta;        /* header */
    rt_tr_totals got;       /* totals of records decoded */
    rt_tr_totals foot;      /* footer totals (valid when state == RS_DONE) */
    unsigned char *raw;     /* current chunk, inflated */
    size_t rawcap;          /* capacity: chunk_records * maxrec */
    uint32_t maxrec;        /* largest encoded record: 16 (version 1), 17 */
    unsigned char *cbuf;    /* current chunk, compressed */
    size_t ccap;            /* capacity */
    size_t rpos, rlen;      /* decode position and length in raw */
    uint32_t rleft;         /* records left in the current chunk */
    uint32_t rnum;          /* records in the current chunk */
    uint64_t chunk_off;     /* file offset of the current chunk */
    uint64_t prev_addr[16]; /* per-class decoder state */
    uint32_t prev_size[16];
    unsigned prev_gen;      /* current generation in the chunk */
    z_stream zs;            /* inflate state */
    int zinit;              /* zs initialised */
    int state;              /* RS_* */
    rt_err err;             /* sticky error */
};

/* Records the failure and returns -1. */
#if defined(__GNUC__)
__attribute__((format(printf, 3, 4)))
#endif
static int r_fail(rt_tr_reader *r, uint64_t off, const char *fmt, ...)
{
    char msg[RT_ERR_LEN];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    rt_errf(&r->err, "%s: byte %llu: %s", r->path, (unsigned long long)off, msg);
    r->state = RS_FAILED;
    return -1;
}

/* Reads exactly n bytes; a short read is a truncation error naming what. */
static int r_read(rt_tr_reader *r, void *p, size_t n, const char *what)
{
    size_t got = fread(p, 1, n, r->f);
    r->hash = rt_fnv1a(r->hash, p, got);
    r->off += got;
    if (got != n) {
        if (ferror(r->f)) return r_fail(r, r->off, "read error: %s", strerror(errno ? errno : EIO));
        return r_fail(r, r->off, "file ends inside %s (truncated trace: %llu more bytes expected)", what,
                      (unsigned long long)(n - got));
    }
    return 0;
}

static int parse_header(rt_tr_reader *r, hbuf *h)
{
    rt_tr_meta *m = &r->meta;
    uint64_t base = 16; /* payload offset, for messages */
    r->chunk_records = hg_u32(h);
    if (!h->bad && (r->chunk_records < 1 || r->chunk_records > RT_TR_MAX_CHUNK))
        return r_fail(r, base, "header: %u records per chunk not in 1..%u", r->chunk_records, RT_TR_MAX_CHUNK);
    (void)hg_u8(h); /* zlib level, informative */
#define STR(field)                                                                                   \
    if (hg_str(h, m->field, sizeof m->field) < 0)                                                    \
        return r_fail(r, base + h->n, "header: bad %s string", #field);
    STR(tool_version)
    STR(git_rev)
    STR(command)
    STR(scene)
    STR(scene_params)
    m->scene_hash = hg_u64(h);
    m->ntri = hg_u32(h);
    STR(tracer)
    uint32_t W = hg_u32(h), H = hg_u32(h);
    if (W > INT32_MAX || H > INT32_MAX) return r_fail(r, base + h->n, "header: bad image size");
    m->W = (int32_t)W;
    m->H = (int32_t)H;
    m->lights = hg_u32(h);
    m->sched_size = hg_u64(h);
    m->gmax = hg_u64(h);
    STR(params)
    uint32_t nreg = hg_u32(h);
    if (nreg > RT_MM_MAX_REGIONS)
        return r_fail(r, base + h->n, "header: %u regions (at most %d)", nreg, RT_MM_MAX_REGIONS);
    m->layout.n = (int)nreg;
    m->layout.next = hg_u64(h);
    for (uint32_t i = 0; i < nreg; i++) {
        rt_region *g = &m->layout.r[i];
        if (hg_str(h, g->name, sizeof g->name) < 0)
            return r_fail(r, base + h->n, "header: bad name of region %u", i);
        g->cls = (uint8_t)hg_u8(h);
        if (g->cls >= RT_NCLASS) return r_fail(r, base + h->n, "header: region %u has class %u", i, g->cls);
        g->recsize = hg_u32(h);
        g->count = hg_u64(h);
        g->base = hg_u64(h);
    }
#undef STR
    if (r->version >= 2) {
        m->generations = hg_u32(h);
        if (!h->bad && (m->generations < 1 || m->generations > RT_TR_MAX_GENERATION))
            return r_fail(r, base + h->n - 4, "header: %u generations not in 1..%d", m->generations,
                          RT_TR_MAX_GENERATION);
    }
    if (h->bad) return r_fail(r, base + h->len, "header: payload too short");
    if (h->n != h->len) return r_fail(r, base + h->n, "header: %zu unparsed payload bytes", h->len - h->n);
    rt_err me;
    if (rt_mm_check(&m->layout, &me) < 0) return r_fail(r, base, "header: %s", me.msg);
    return 0;
}

rt_tr_reader *rt_tr_open(const char *path, rt_err *e)
{
    rt_tr_reader *r = rt_calloc(1, sizeof *r, e);
    if (!r) return NULL;
    hbuf *h = NULL;
    size_t plen = strlen(path);
    if (!(r->path = rt_calloc(plen + 1, 1, e))) goto fail_quiet;
    memcpy(r->path, path, plen + 1);
    r->hash = RT_FNV_INIT;
    if (!(r->f = fopen(path, "rb"))) {
        rt_errf(e, "%s: %s", path, strerror(errno));
        goto fail_quiet;
    }
    struct stat stb;
    if (fstat(fileno(r->f), &stb) == 0) r->fsize = (uint64_t)stb.st_size;
    if (!(h = rt_calloc(1, sizeof *h, e))) goto fail_quiet;
    unsigned char pre[16];
    if (r_read(r, pre, 8, "the header magic") < 0) goto fail;
    if (memcmp(pre, HDR_MAGIC, 8) != 0) {
        r_fail(r, 0, "not a raytraffic trace (bad magic)");
        goto fail;
    }
    if (r_read(r, pre + 8, 8, "the header") < 0) goto fail;
    r->version = get32(pre + 8);
    h->len = get32(pre + 12);
    if (r->version == 0 || r->version > RT_TR_FORMAT_VERSION) {
        r_fail(r, 8, "trace format version %u is not supported (this raytraffic %s reads versions 1..%d)%s",
               r->version, rt_version(), RT_TR_FORMAT_VERSION,
               r->version > RT_TR_FORMAT_VERSION ? "; the file was written by a newer raytraffic" : "");
        goto fail;
    }
    if (h->len > MAX_HDR_PAYLOAD) {
        r_fail(r, 12, "header payload length %zu exceeds %u", h->len, MAX_HDR_PAYLOAD);
        goto fail;
    }
    unsigned char cb[4];
    if (r_read(r, h->b, h->len, "the header") < 0 || r_read(r, cb, 4, "the header CRC") < 0) goto fail;
    if (crc(crc(0, pre, 16), h->b, h->len) != get32(cb)) {
        r_fail(r, 16 + h->len, "header CRC mismatch");
        goto fail;
    }
    if (parse_header(r, h) < 0) goto fail;
    free(h);
    h = NULL;
    r->maxrec = r->version >= 2 ? MAX_REC_BYTES : MAX_REC_BYTES_V1;
    r->rawcap = (size_t)r->chunk_records * r->maxrec;
    r->ccap = (size_t)bound_compressed(r->rawcap);
    if (!(r->raw = rt_calloc(r->rawcap, 1, e)) || !(r->cbuf = rt_calloc(r->ccap, 1, e))) goto fail_quiet;
    if (inflateInit(&r->zs) != Z_OK) {
        rt_errf(e, "%s: zlib inflateInit failed", path);
        goto fail_quiet;
    }
    r->zinit = 1;
    return r;
fail:
    rt_errf(e, "%s", r->err.msg);
fail_quiet:
    free(h);
    rt_tr_close(r);
    return NULL;
}

const rt_tr_meta *rt_tr_get_meta(const rt_tr_reader *r) { return &r->meta; }
const rt_tr_totals *rt_tr_get_totals(const rt_tr_reader *r) { return &r->foot; }
uint64_t rt_tr_file_bytes(const rt_tr_reader *r) { return r->fsize; }
uint64_t rt_tr_file_hash(const rt_tr_reader *r) { return r->hash; }
uint32_t rt_tr_get_version(const rt_tr_reader *r) { return r->version; }
uint32_t rt_tr_get_chunk_records(const rt_tr_reader *r) { return r->chunk_records; }

/* Reads the rest of a chunk whose magic has been consumed at r->chunk_off. */
static int read_chunk(rt_tr_reader *r)
{
    unsigned char h[CHUNK_HDR];
    uint64_t at = r->chunk_off;
    memcpy(h, CHUNK_MAGIC, 4);
    if (r_read(r, h + 4, CHUNK_HDR - 4, "a chunk header") < 0) return -1;
    uint32_t idx = get32(h + 4), n = get32(h + 8), U = get32(h + 12), C = get32(h + 16);
    if (idx != r->got.nchunks)
        return r_fail(r, at + 4, "chunk %u found where chunk %llu was expected", idx,
                      (unsigned long long)r->got.nchunks);
    if (n < 1 || n > r->chunk_records)
        return r_fail(r, at + 8, "chunk %u: record count %u not in 1..%u", idx, n, r->chunk_records);
    if (U < n || (uint64_t)U > (uint64_t)n * r->maxrec)
        return r_fail(r, at + 12, "chunk %u: encoded length %u impossible for %u records", idx, U, n);
    if (C < 1 || C > bound_compressed(U) || C > r->ccap)
        return r_fail(r, at + 16, "chunk %u: compressed length %u impossible for %u bytes", idx, C, U);
    if (r_read(r, r->cbuf, C, "a chunk's data") < 0) return -1;
    if (crc(crc(0, h, 20), r->cbuf, C) != get32(h + 20)) return r_fail(r, at, "chunk %u CRC mismatch", idx);
    if (inflateReset(&r->zs) != Z_OK) return r_fail(r, at, "chunk %u: zlib inflateReset failed", idx);
    r->zs.next_in = r->cbuf;
    r->zs.avail_in = C;
    r->zs.next_out = r->raw;
    r->zs.avail_out = U;
    int zr = inflate(&r->zs, Z_FINISH);
    if (zr != Z_STREAM_END || r->zs.avail_in != 0 || r->zs.avail_out != 0)
        return r_fail(r, at + CHUNK_HDR, "chunk %u: zlib data does not inflate to %u bytes (%s)", idx, U,
                      r->zs.msg ? r->zs.msg : zr == Z_STREAM_END ? "length mismatch" : "stream error");
    r->rpos = 0;
    r->rlen = U;
    r->rleft = r->rnum = n;
    memset(r->prev_addr, 0, sizeof r->prev_addr);
    memset(r->prev_size, 0, sizeof r->prev_size);
    r->prev_gen = 0;
    r->got.nchunks++;
    return 0;
}

static int read_footer(rt_tr_reader *r)
{
    unsigned char f[FOOT_LEN];
    uint64_t at = r->chunk_off;
    memcpy(f, FOOT_MAGIC, 4);
    if (r_read(r, f + 4, FOOT_LEN - 4, "the footer") < 0) return -1;
    if (crc(0, f, FOOT_LEN - 4) != get32(f + FOOT_LEN - 4)) return r_fail(r, at, "footer CRC mismatch");
    if (get32(f + 4) != RT_NCLASS) return r_fail(r, at + 4, "footer: %u classes, expected %d", get32(f + 4), RT_NCLASS);
    rt_tr_totals *t = &r->foot;
    t->nrefs = get64(f + 8);
    t->nchunks = get64(f + 16);
    for (int c = 0; c < RT_NCLASS; c++) {
        t->refs[c] = get64(f + 24 + 24 * c);
        t->bytes[c] = get64(f + 32 + 24 * c);
        t->writes[c] = get64(f + 40 + 24 * c);
    }
    if (t->nchunks != r->got.nchunks)
        return r_fail(r, at, "footer says %llu chunks, file has %llu", (unsigned long long)t->nchunks,
                      (unsigned long long)r->got.nchunks);
    if (t->nrefs != r->got.nrefs)
        return r_fail(r, at, "footer says %llu references, file has %llu", (unsigned long long)t->nrefs,
                      (unsigned long long)r->got.nrefs);
    for (int c = 0; c < RT_NCLASS; c++)
        if (t->refs[c] != r->got.refs[c] || t->bytes[c] != r->got.bytes[c] || t->writes[c] != r->got.writes[c])
            return r_fail(r, at, "footer totals of class %s do not match the records", rt_class_name(c));
    int ch = fgetc(r->f);
    if (ch != EOF) {
        uint64_t extra = r->fsize > r->off ? r->fsize - r->off : 1;
        return r_fail(r, r->off, "%llu bytes of trailing garbage after the footer", (unsigned long long)extra);
    }
    if (ferror(r->f)) return r_fail(r, r->off, "read error: %s", strerror(errno ? errno : EIO));
    r->state = RS_DONE;
    return 0;
}

/* Next chunk or the footer. */
static int advance(rt_tr_reader *r)
{
    unsigned char m[4];
    r->chunk_off = r->off;
    size_t got = fread(m, 1, 4, r->f);
    r->hash = rt_fnv1a(r->hash, m, got);
    r->off += got;
    if (got == 0 && !ferror(r->f))
        return r_fail(r, r->off, "file ends before the footer (truncated trace: %llu chunks, %llu records read)",
                      (unsigned long long)r->got.nchunks, (unsigned long long)r->got.nrefs);
    if (got != 4) {
        if (ferror(r->f)) return r_fail(r, r->off, "read error: %s", strerror(errno ? errno : EIO));
        return r_fail(r, r->off, "file ends inside a chunk magic (truncated trace)");
    }
    if (!memcmp(m, CHUNK_MAGIC, 4)) return read_chunk(r);
    if (!memcmp(m, FOOT_MAGIC, 4)) return read_footer(r);
    return r_fail(r, r->chunk_off, "bad chunk magic %02x %02x %02x %02x", m[0], m[1], m[2], m[3]);
}

static int dec_fail(rt_tr_reader *r, const char *what)
{
    return r_fail(r, r->chunk_off, "chunk %llu: record %u: %s", (unsigned long long)(r->got.nchunks - 1),
                  r->rnum - r->rleft, what);
}

long rt_tr_read(rt_tr_reader *r, rt_access *buf, size_t cap, rt_err *e)
{
    if (r->state == RS_FAILED) return rt_errf(e, "%s", r->err.msg);
    if (r->state == RS_DONE) return 0;
    if (cap == 0) return rt_errf(e, "%s: rt_tr_read called with an empty buffer", r->path);
    if (cap > (size_t)LONG_MAX) cap = (size_t)LONG_MAX;
    size_t n = 0;
    while (n < cap) {
        if (r->rleft == 0) {
            if (r->rpos != r->rlen) {
                dec_fail(r, "encoded bytes left over after the last record");
                return rt_errf(e, "%s", r->err.msg);
            }
            if (advance(r) < 0) return rt_errf(e, "%s", r->err.msg);
            if (r->state == RS_DONE) break;
            continue;
        }
        const unsigned char *p = r->raw + r->rpos, *end = r->raw + r->rlen;
        if (p == end) goto short_rec;
        unsigned t = *p++;
        unsigned cls = t & TAG_CLASS, gen = r->prev_gen;
        if (t & TAG_GEN) {
            if (!r->meta.generations) goto bad_tag; /* version 1: reserved */
            if (p == end) goto short_rec;
            gen = *p++;
            if (gen == r->prev_gen) goto same_gen;
            if (gen > r->meta.generations) goto bad_gen;
        }
        if (cls >= RT_NCLASS) goto bad_class;
        uint64_t addr = r->prev_addr[cls];
        uint32_t size = r->prev_size[cls];
        if (t & TAG_SEQ) addr += size;
        else {
            uint64_t z = 0;
            for (int sh = 0;; sh += 7) {
                if (p == end) goto short_rec;
                unsigned b = *p++;
                if (sh == 63 && b > 1) goto overflow;
                z |= (uint64_t)(b & 0x7f) << sh;
                if (!(b & 0x80)) break;
            }
            addr += (z >> 1) ^ (0 - (z & 1));
        }
        if (!(t & TAG_SAMESIZE)) {
            uint64_t v = 0;
            for (int sh = 0;; sh += 7) {
                if (p == end) goto short_rec;
                unsigned b = *p++;
                if (sh == 28 && b > 0x0f) goto overflow;
                v |= (uint64_t)(b & 0x7f) << sh;
                if (!(b & 0x80)) break;
            }
            size = (uint32_t)v;
        }
        if (size == 0) goto zero_size;
        r->prev_addr[cls] = addr;
        r->prev_size[cls] = size;
        r->prev_gen = gen;
        r->rpos = (size_t)(p - r->raw);
        r->rleft--;
        rt_access *a = &buf[n++];
        a->addr = addr;
        a->size = size;
        a->write = (t & TAG_WRITE) != 0;
        a->cls = (uint8_t)cls;
        a->gen = (uint8_t)gen;
        r->got.refs[cls]++;
        r->got.bytes[cls] += size;
        r->got.writes[cls] += a->write;
        r->got.nrefs++;
        continue;
    bad_tag:
        dec_fail(r, "reserved tag bit set");
        return rt_errf(e, "%s", r->err.msg);
    bad_class:
        dec_fail(r, "class out of range");
        return rt_errf(e, "%s", r->err.msg);
    same_gen:
        dec_fail(r, "generation byte repeats the current generation");
        return rt_errf(e, "%s", r->err.msg);
    bad_gen:
        dec_fail(r, "generation above the header's");
        return rt_errf(e, "%s", r->err.msg);
    short_rec:
        dec_fail(r, "record runs past the end of the chunk");
        return rt_errf(e, "%s", r->err.msg);
    overflow:
        dec_fail(r, "varint overflow");
        return rt_errf(e, "%s", r->err.msg);
    zero_size:
        dec_fail(r, "size 0");
        return rt_errf(e, "%s", r->err.msg);
    }
    return (long)n;
}

void rt_tr_close(rt_tr_reader *r)
{
    if (!r) return;
    if (r->f) fclose(r->f);
    if (r->zinit) inflateEnd(&r->zs);
    free(r->raw);
    free(r->cbuf);
    free(r->path);
    free(r);
}
