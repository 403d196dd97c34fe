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
 *            u32 format version       1, 2 or 3; a reader rejects versions it
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
 *   [side]   version 3, after every chunk: the same 24-byte layout with
 *            magic "RTSM", the index and n of its chunk, and a payload
 *            (below) of at most side_bound(n) bytes
 *   footer   "RTND"                   footer magic
 *            u32 nclass               10 (RT_NCLASS_V1), or up to 13
 *                                     (RT_NCLASS): 1 + the highest class
 *                                     with a reference when that is >= 10
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
 * Version 3 appends u32 generations (0..255: 0 = no generation bytes) and
 * the sample index's parameters (rt_tr_sample_params): u32 line, u8
 * shift, u64 seed, period, window, cmax, hist. Every str must fit its
 * rt_tr_meta field with its NUL and may not contain NUL bytes; the payload
 * must be consumed exactly.
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
 * SIDE CHUNKS (version 3). The payload of chunk k's side chunk is opaque
 * to the format: bytes a payload maker (rt_tr_payload_ops, trace.h) made
 * from chunk k's records. The format reads one byte of it, byte 0, the
 * flags (bit 0: the last chunk; bits 1-2 the maker's, the sample index's
 * count of classes beyond RT_NCLASS_V1; other bits zero), and bounds its length
 * by the header's parameters (side_bound). raytraffic's maker is the
 * sample index, cachesim/sindex.c, which documents the rest of the bytes
 * (and docs/trace-format.md). The writer stores what its maker makes;
 * rt_tr_read re-makes each payload with the maker set by
 * rt_tr_set_payload_check and compares the bytes; rt_tr_read_payload
 * hands the payloads to a decoder without touching the records.
 *
 * Address arithmetic wraps modulo 2^64, so every address 0..2^64-1 has an
 * encoding. A k-d traversal revisits the same node sequences for
 * neighbouring rays, so the byte stream repeats itself and zlib removes the
 * rest: see docs/trace-format.md for measured bytes per reference.
 *
 * INVARIANTS a reader checks (every violation is an error naming the file
 * and byte offset, never a short successful read):
 *   - magic, version and header CRC; chunk magic, index, bounds on n/U/C,
 *     chunk CRC; the zlib stream's header is valid, its deflate data ends
 *     exactly where the 4-byte Adler-32 begins, at C - 4, and inflates to
 *     exactly U bytes (the Adler-32 itself is covered by the chunk CRC and
 *     not recomputed); the records consume exactly U bytes;
 *   - class < RT_NCLASS, bit 7 clear (version 1), a generation byte that
 *     changes the generation and stays <= the header's (version 2),
 *     varints not overlong, size >= 1;
 *   - the footer's CRC is valid, and its totals equal the totals of the
 *     records actually read; nothing follows the footer;
 *   - version 3: each chunk is followed by its side chunk (magic, index,
 *     n, bounds, CRC, exact inflate, flags); only the last is marked last;
 *     with a payload check set (rt_tr_set_payload_check), the payload
 *     equals, byte for byte, the one the maker makes from the chunk's
 *     records.
 *   Every byte of the file is covered by a CRC or checked against a magic,
 *   so any single flipped bit and any truncation is detected. rt_tr_read
 *   returns 0 only after all of this has been verified.
 *
 *   rt_tr_read_payload (the sampled read) checks every magic, header, bound
 *   and CRC, data chunks included, and the footer's chunk and record
 *   counts, and its class totals against those the payload decoder
 *   reports (rt_tr_payload_tally); the decoder checks the payloads'
 *   structure and record encoding (cachesim/sindex.c). It does not
 *   inflate data chunks, so it cannot see a side chunk that disagrees
 *   with valid-CRC records (a forged file or a writer bug).
 *
 * WRITER. Records are encoded as they arrive (through the rt_sink) into a
 * buffer of one chunk; a full buffer is deflated and written when the next
 * record arrives (or at rt_tr_finish, which so knows the last chunk), then
 * its side chunk (version 3). Memory is one chunk's raw and compressed
 * buffers (~2 MiB at the default 64K records), plus for version 3 what
 * the payload maker keeps (the sample index: a 512 KiB history and one
 * payload).
 * The file goes through outfile.c: a unique temporary beside PATH, renamed
 * to PATH only by rt_tr_finish after the footer is flushed and synced;
 * rt_tr_abort removes the temporary. So a file at PATH is always complete,
 * and of two writers to one PATH the last to finish wins.
 *
 * READER. Reads sequentially through stdio, keeps one chunk in memory and
 * decodes records into the caller's buffer on demand; it hashes every byte
 * (FNV-1a 64) for provenance, in both read modes.
 */
#include "trace.h"
#include "trace_rec.h"
#include "outfile.h"
#include "rt_math.h"

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
static const unsigned char SIDE_MAGIC[4] = {'R', 'T', 'S', 'M'};

#define MAX_HDR_PAYLOAD 65536u
#define CHUNK_HDR 24u
/* A footer of nc classes; nc is RT_NCLASS_V1 .. RT_NCLASS (foot_nclass). */
#define FOOT_LEN_N(nc) (4u + 4u + 16u + 24u * (unsigned)(nc) + 4u)
#define FOOT_LEN FOOT_LEN_N(RT_NCLASS) /* the largest */

/* Classes a footer (and a sample-index payload) stores for these
 * per-class reference counts: RT_NCLASS_V1, or up to the highest class
 * with a reference, so traces without the later classes keep their bytes. */
static int foot_nclass(const uint64_t *refs)
{
    int nc = RT_NCLASS_V1;
    for (int c = RT_NCLASS_V1; c < RT_NCLASS; c++)
        if (refs[c]) nc = c + 1;
    return nc;
}

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

/* ---- side payload parameters ------------------------------------------------ */

/* Largest side payload of a chunk of n records: the format's bound, from
 * the header's parameters (trace.h). It is the largest sample index
 * (cachesim/sindex.c) of a chunk: flags, 65 class totals (13 classes;
 * the bound grew by 150 bytes when classes 10..12 came) and two counts,
 * every record sampled, and the windows that can end in it (they end at
 * least period records apart, so at most n / period + 1, plus the partial
 * one of the last chunk), each with its header and cmax + window records. */
static uint64_t side_bound(const rt_tr_sample_params *p, uint64_t n)
{
    uint64_t nw = n / p->period + 2;
    return 1 + RT_NCLASS * 5 * 10 + 2 * 10 + n * RT_TRC_MAX_REC + nw * (31 + (p->cmax + p->window) * RT_TRC_MAX_REC);
}

/* 1 if the parameters are in the ranges the format allows (trace.h). The
 * upper bounds keep a side chunk's bound (side_bound) within ~50 MiB even
 * at 2^20 records per chunk. */
static int sample_params_ok(const rt_tr_sample_params *sp)
{
    return !(sp->line < 2 || sp->line > 65536 || (sp->line & (sp->line - 1)) || sp->shift > 32 ||
             sp->period < 4096 || sp->period > (1ULL << 40) || sp->window < 1 || sp->window > sp->period / 2 ||
             sp->window > 16384 || sp->cmax < 1 || sp->cmax > 4096 || sp->hist > sp->period - sp->window ||
             sp->hist > (1u << 20));
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
    unsigned char *out;     /* compressed chunk (header + payload), data or side */
    size_t outcap;          /* its capacity */
    z_stream zs;            /* deflate state, reset per chunk */
    int zinit;              /* zs initialised */
    rt_trc_coder cd;        /* record coder of the current chunk */
    unsigned maxgen;        /* meta.generations: 0 = no generation bytes */
    unsigned cores;         /* meta.cores: 1, or 2..256 (version 4: core switches) */
    unsigned core;          /* the core of the records being put (rt_tr_put_core; 0 otherwise) */
    rt_csink csink;         /* rt_tr_csink: ctx = this */
    const rt_tr_payload_ops *pops; /* side payload maker (version 3), or NULL */
    void *pctx;             /* its state */
    rt_tr_sample_params sp; /* its parameters, as in the header */
    rt_tr_totals tot;       /* totals so far */
    uint64_t written;       /* bytes written to the file */
    int failed;             /* a put failed; err holds why */
    rt_err err;             /* first failure */
};

void rt_tr_default_wopts(rt_tr_wopts *o)
{
    o->level = RT_TR_DEFAULT_LEVEL;
    o->chunk_records = RT_TR_DEFAULT_CHUNK;
    o->payload = NULL;
}

static int w_write(rt_tr_writer *w, const void *p, size_t n, rt_err *e)
{
    if (fwrite(p, 1, n, w->f) != n)
        return rt_errf(e, "%s: byte %llu: write failed: %s", w->path, (unsigned long long)w->written,
                       strerror(errno ? errno : EIO));
    w->written += n;
    return 0;
}

/* Deflates len bytes into w->out after a 24-byte chunk header with magic,
 * index, n, U, C and CRC, and writes it. */
static int w_deflate(rt_tr_writer *w, const unsigned char *magic, uint32_t n, const unsigned char *src, size_t len,
                     rt_err *e)
{
    unsigned char *h = w->out;
    w->zs.next_in = (unsigned char *)src;
    w->zs.avail_in = (uInt)len;
    w->zs.next_out = w->out + CHUNK_HDR;
    w->zs.avail_out = (uInt)(w->outcap - CHUNK_HDR);
    int zr = deflate(&w->zs, Z_FINISH);
    if (zr != Z_STREAM_END) return rt_errf(e, "%s: zlib deflate failed (%d)", w->path, zr);
    size_t clen = w->outcap - CHUNK_HDR - w->zs.avail_out;
    if (deflateReset(&w->zs) != Z_OK) return rt_errf(e, "%s: zlib deflateReset failed", w->path);
    memcpy(h, magic, 4);
    put32(h + 4, (uint32_t)w->tot.nchunks);
    put32(h + 8, n);
    put32(h + 12, (uint32_t)len);
    put32(h + 16, (uint32_t)clen);
    uint32_t c = crc(crc(0, h, 20), h + CHUNK_HDR, clen);
    put32(h + 20, c);
    return w_write(w, h, CHUNK_HDR + clen, e);
}

/* Writes the current chunk (and its side chunk); last: the trace ends
 * with it. */
static int w_flush_chunk(rt_tr_writer *w, int last, rt_err *e)
{
    if (w->nrec == 0) return 0;
    if (w->tot.nchunks >= UINT32_MAX) return rt_errf(e, "%s: more than 2^32-1 chunks", w->path);
    if (w_deflate(w, CHUNK_MAGIC, w->nrec, w->raw, w->rawlen, e) < 0) return -1;
    if (w->pops) {
        const unsigned char *pb = NULL;
        size_t plen = 0;
        if (w->pops->chunk(w->pctx, last, &pb, &plen) < 0) return rt_errf(e, "%s: out of memory", w->path);
        if (plen < 1 || plen > side_bound(&w->sp, w->nrec) || (pb[0] & ~RT_TR_SIDE_MAKER) != (last ? 1 : 0))
            return rt_errf(e, "%s: chunk %llu: the side payload made (%zu bytes, flags %#x) does not fit the format",
                           w->path, (unsigned long long)w->tot.nchunks, plen, plen ? pb[0] : 0u);
        if (w_deflate(w, SIDE_MAGIC, w->nrec, pb, plen, e) < 0) return -1;
    }
    w->tot.nchunks++;
    w->nrec = 0;
    w->rawlen = 0;
    memset(&w->cd, 0, sizeof w->cd);
    return 0;
}

static int w_put(rt_sink *s, const rt_access *a, size_t n)
{
    rt_tr_writer *w = s->ctx;
    if (w->failed) return -1;
    size_t fed = 0; /* a[0..fed) went to the payload maker */
    for (size_t i = 0; i < n; i++) {
        unsigned cls = a[i].cls, gen = a[i].gen;
        if (cls >= RT_NCLASS || a[i].size == 0 || gen > w->maxgen) {
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
        /* a full chunk is written when the next record comes, so that
         * rt_tr_finish knows which chunk is the last */
        if (w->nrec == w->chunk_records) {
            if (w->pops && w->pops->put(w->pctx, a + fed, i - fed) < 0) {
                rt_errf(&w->err, "%s: out of memory", w->path);
                w->failed = 1;
                return -1;
            }
            fed = i;
            if (w_flush_chunk(w, 0, &w->err) < 0) {
                w->failed = 1;
                return -1;
            }
        }
        if (w->core != w->cd.core) { /* version 4: the core switch */
            w->raw[w->rawlen++] = RT_TRC_SWITCH;
            w->raw[w->rawlen++] = (unsigned char)w->core;
            w->cd.core = w->core;
        }
        w->rawlen = (size_t)(rt_trc_enc(&w->cd, w->raw + w->rawlen, &a[i]) - w->raw);
        w->tot.refs[cls]++;
        w->tot.bytes[cls] += a[i].size;
        w->tot.writes[cls] += a[i].write != 0;
        w->tot.nrefs++;
        w->nrec++;
    }
    if (w->pops && w->pops->put(w->pctx, a + fed, n - fed) < 0) {
        rt_errf(&w->err, "%s: out of memory", w->path);
        w->failed = 1;
        return -1;
    }
    return 0;
}

/* sp non-NULL: version 3 with that sample index. */
static int encode_header(hbuf *h, const rt_tr_meta *m, uint32_t chunk_records, int level,
                         const rt_tr_sample_params *sp)
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
    if (sp) { /* version 3 */
        hb_u32(h, m->generations);
        hb_u32(h, sp->line);
        hb_u8(h, sp->shift);
        hb_u64(h, sp->seed);
        hb_u64(h, sp->period);
        hb_u64(h, sp->window);
        hb_u64(h, sp->cmax);
        hb_u64(h, sp->hist);
    } else if (m->cores > 1) { /* version 4 */
        hb_u32(h, m->generations);
        hb_u32(h, m->cores);
    } else if (m->generations) {
        hb_u32(h, m->generations); /* version 2 */
    }
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
    const rt_tr_payload_ops *po = o->payload;
    if (po && (!sample_params_ok(&po->params) || !po->open || !po->put || !po->chunk || !po->close)) {
        free(h);
        return rt_errf(e, "%s: side payload maker with impossible parameters (line %u, rate 2^-%u, period %llu, "
                       "window %llu, %llu lines, history %llu) or functions missing", path, po->params.line,
                       po->params.shift, (unsigned long long)po->params.period, (unsigned long long)po->params.window,
                       (unsigned long long)po->params.cmax, (unsigned long long)po->params.hist), NULL;
    }
    if (m->cores > RT_TR_MAX_CORES || (m->cores > 1 && po)) {
        free(h);
        return rt_errf(e, "%s: %u cores%s", path, m->cores,
                       m->cores > RT_TR_MAX_CORES ? " (at most 256)" : ": a version-4 trace has no side payloads"), NULL;
    }
    if (m->W < 0 || m->H < 0 || encode_header(h, m, o->chunk_records, o->level, po ? &po->params : NULL) < 0) {
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
    w->cores = m->cores > 1 ? m->cores : 1;
    size_t plen = strlen(path);
    w->path = rt_calloc(plen + 1, 1, e);
    const uint32_t maxrec = w->cores > 1 ? RT_TRC_MAX_REC_V4 : RT_TRC_MAX_REC;
    w->raw = w->path ? rt_calloc(o->chunk_records, maxrec, e) : NULL;
    if (!w->raw) goto fail;
    memcpy(w->path, path, plen + 1);
    if (deflateInit(&w->zs, o->level) != Z_OK) {
        rt_errf(e, "%s: zlib deflateInit failed", path);
        goto fail;
    }
    w->zinit = 1;
    uint64_t ulen = (uint64_t)o->chunk_records * maxrec;
    if (po) {
        w->sp = po->params;
        if (!(w->pctx = po->open(&w->sp, m->generations, e))) goto fail;
        w->pops = po;
        ulen = side_bound(&w->sp, o->chunk_records); /* > the records' bound */
    }
    w->outcap = CHUNK_HDR + deflateBound(&w->zs, (uLong)ulen);
    if (!(w->out = rt_calloc(w->outcap, 1, e))) goto fail;
    if (!(w->of = rt_out_open(path, e))) goto fail;
    w->f = rt_out_stream(w->of);
    unsigned char pre[16];
    memcpy(pre, HDR_MAGIC, 8);
    put32(pre + 8, w->cores > 1 ? 4 : po ? 3 : m->generations ? 2 : 1);
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

static int w_put_core(rt_csink *s, unsigned core, const rt_access *a, size_t n)
{
    return rt_tr_put_core(s->ctx, core, a, n);
}

rt_csink *rt_tr_csink(rt_tr_writer *w)
{
    w->csink.put = w_put_core;
    w->csink.ctx = w;
    return &w->csink;
}
const rt_tr_totals *rt_tr_writer_totals(const rt_tr_writer *w) { return &w->tot; }
const char *rt_tr_writer_error(const rt_tr_writer *w) { return w->err.msg; }

static void w_free(rt_tr_writer *w)
{
    if (w->zinit) deflateEnd(&w->zs);
    if (w->pops) w->pops->close(w->pctx);
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
    if (w_flush_chunk(w, 1, e) < 0) goto fail;
    unsigned char f[FOOT_LEN];
    const int nc = foot_nclass(w->tot.refs);
    const unsigned flen = FOOT_LEN_N(nc);
    memcpy(f, FOOT_MAGIC, 4);
    put32(f + 4, (uint32_t)nc);
    put64(f + 8, w->tot.nrefs);
    put64(f + 16, w->tot.nchunks);
    for (int c = 0; c < nc; c++) {
        put64(f + 24 + 24 * c, w->tot.refs[c]);
        put64(f + 32 + 24 * c, w->tot.bytes[c]);
        put64(f + 40 + 24 * c, w->tot.writes[c]);
    }
    put32(f + flen - 4, crc(0, f, flen - 4));
    if (w_write(w, f, flen, e) < 0) goto fail;
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
enum { RM_NONE = 0, RM_RECORDS = 1, RM_SIDE = 2 };

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
    int has_sample;         /* version 3: a side chunk follows every data chunk */
    int no_side_check;      /* records mode: side chunks read but not rebuilt (rt_tr_set_side_check) */
    rt_tr_sample_params sp; /* its parameters */
    int mode;               /* RM_*: which read function this reader serves */
    uint32_t data_n;        /* records of the last data chunk */
    int side_pending;       /* records mode: the side chunk of the current data chunk is unread */
    int last_seen;          /* a side chunk marked last has been read */
    const rt_tr_payload_ops *vops; /* records mode: the maker that re-makes each side payload to check it */
    void *vctx;             /* its state, once rt_tr_read started (NULL: no check) */
    unsigned char *sraw;    /* side payload, inflated */
    size_t srawcap;         /* its capacity: side_bound(chunk_records) */
    int tallied;            /* side mode: rt_tr_payload_tally was called */
    rt_trc_coder cd;        /* decoder state of the current chunk */
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
        uint32_t lo = r->version == 2 ? 1 : 0; /* versions 3, 4 also hold traces without generations */
        m->generations = hg_u32(h);
        if (!h->bad && (m->generations < lo || m->generations > RT_TR_MAX_GENERATION))
            return r_fail(r, base + h->n - 4, "header: %u generations not in %u..%d", m->generations, lo,
                          RT_TR_MAX_GENERATION);
    }
    m->cores = 1;
    if (r->version == 4) {
        size_t at = h->n;
        m->cores = hg_u32(h);
        if (!h->bad && (m->cores < 2 || m->cores > RT_TR_MAX_CORES))
            return r_fail(r, base + at, "header: %u cores not in 2..%d", m->cores, RT_TR_MAX_CORES);
    }
    if (r->version == 3) {
        rt_tr_sample_params *sp = &r->sp;
        size_t at = h->n;
        sp->line = hg_u32(h);
        sp->shift = hg_u8(h);
        sp->seed = hg_u64(h);
        sp->period = hg_u64(h);
        sp->window = hg_u64(h);
        sp->cmax = hg_u64(h);
        sp->hist = hg_u64(h);
        if (!h->bad && !sample_params_ok(sp))
            return r_fail(r, base + at,
                          "header: impossible sample index (line %u, rate 2^-%u, period %llu, window %llu, "
                          "%llu lines, history %llu)",
                          sp->line, sp->shift, (unsigned long long)sp->period, (unsigned long long)sp->window,
                          (unsigned long long)sp->cmax, (unsigned long long)sp->hist);
        r->has_sample = 1;
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
    r->maxrec = r->version == 4 ? RT_TRC_MAX_REC_V4 : r->version >= 2 ? RT_TRC_MAX_REC : RT_TRC_MAX_REC_V1;
    r->rawcap = (size_t)r->chunk_records * r->maxrec;
    r->ccap = (size_t)bound_compressed(r->rawcap);
    if (r->has_sample) {
        r->srawcap = (size_t)side_bound(&r->sp, r->chunk_records);
        r->ccap = (size_t)bound_compressed(r->srawcap); /* side chunks are the larger */
        if (!(r->sraw = rt_calloc(r->srawcap, 1, e))) goto fail_quiet;
    }
    if (!(r->raw = rt_calloc(r->rawcap, 1, e)) || !(r->cbuf = rt_calloc(r->ccap, 1, e))) goto fail_quiet;
    if (inflateInit2(&r->zs, -15) != Z_OK) { /* raw: inflate_exact checks the zlib wrapper itself */
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

int rt_tr_get_sample_params(const rt_tr_reader *r, rt_tr_sample_params *p)
{
    if (!r->has_sample) return 0;
    *p = r->sp;
    return 1;
}

/* Reads the header and compressed bytes of a chunk whose magic has been
 * consumed at r->chunk_off, checks its bounds and CRC; *U and *C are its
 * lengths, the bytes are in r->cbuf. A side chunk (side = 1) must follow
 * the data chunk of its index and repeat its record count. */
static int read_chunk_bytes(rt_tr_reader *r, int side, uint32_t *Up, uint32_t *Cp)
{
    unsigned char h[CHUNK_HDR];
    uint64_t at = r->chunk_off;
    memcpy(h, side ? SIDE_MAGIC : CHUNK_MAGIC, 4);
    if (r_read(r, h + 4, CHUNK_HDR - 4, side ? "a side chunk header" : "a chunk header") < 0) return -1;
    uint32_t idx = get32(h + 4), n = get32(h + 8), U = get32(h + 12), C = get32(h + 16);
    uint64_t want = side ? r->got.nchunks - 1 : r->got.nchunks;
    const char *what = side ? "side chunk" : "chunk";
    if (idx != want)
        return r_fail(r, at + 4, "%s %u found where %s %llu was expected", what, idx, what, (unsigned long long)want);
    if (side) {
        if (n != r->data_n)
            return r_fail(r, at + 8, "side chunk %u: %u records, its data chunk has %u", idx, n, r->data_n);
        if (U < 1 || (uint64_t)U > side_bound(&r->sp, n))
            return r_fail(r, at + 12, "side chunk %u: payload length %u impossible for %u records", idx, U, n);
    } else {
        if (n < 1 || n > r->chunk_records)
            return r_fail(r, at + 8, "chunk %u: record count %u not in 1..%u", idx, n, r->chunk_records);
        if (U < n || (uint64_t)U > (uint64_t)n * r->maxrec)
            return r_fail(r, at + 12, "chunk %u: encoded length %u impossible for %u records", idx, U, n);
    }
    if (C < 1 || C > bound_compressed(U) || C > r->ccap)
        return r_fail(r, at + 16, "%s %u: compressed length %u impossible for %u bytes", what, idx, C, U);
    if (r_read(r, r->cbuf, C, side ? "a side chunk's data" : "a chunk's data") < 0) return -1;
    if (crc(crc(0, h, 20), r->cbuf, C) != get32(h + 20)) return r_fail(r, at, "%s %u CRC mismatch", what, idx);
    *Up = U;
    *Cp = C;
    if (!side) {
        if (r->last_seen)
            return r_fail(r, at, "chunk %u follows the side chunk marked last", idx);
        r->data_n = n;
        r->got.nchunks++;
    }
    return 0;
}

/* Inflates r->cbuf (C bytes) into dst, which must receive exactly U bytes. */
static int inflate_exact(rt_tr_reader *r, unsigned char *dst, uint32_t U, uint32_t C, const char *what)
{
    uint64_t idx = r->got.nchunks - 1;
    if (inflateReset(&r->zs) != Z_OK) return r_fail(r, r->chunk_off, "%s %llu: zlib inflateReset failed", what,
                                                     (unsigned long long)idx);
    /* The zlib wrapper: its 2-byte header (deflate, window <= 32K, no
     * preset dictionary, check bits) is verified here and the deflate data
     * inflated raw; the 4-byte Adler-32 of the output is not recomputed:
     * the chunk's CRC-32 already covers every compressed byte, the Adler-32
     * included, and recomputing it cost the decoding thread, the slower of
     * a two-thread replay's, 6% of its time. */
    const unsigned char *h = r->cbuf;
    if (C < 6 || (h[0] & 0x0f) != 8 || (h[0] >> 4) > 7 || (h[1] & 0x20) || ((unsigned)h[0] << 8 | h[1]) % 31)
        return r_fail(r, r->chunk_off + CHUNK_HDR, "%s %llu: zlib data does not inflate to %u bytes (%s)", what,
                      (unsigned long long)idx, U, C < 6 ? "stream too short" : "incorrect header check");
    r->zs.next_in = r->cbuf + 2;
    r->zs.avail_in = C - 6;
    r->zs.next_out = dst;
    r->zs.avail_out = U;
    int zr = inflate(&r->zs, Z_FINISH);
    if (zr != Z_STREAM_END || r->zs.avail_in != 0 || r->zs.avail_out != 0)
        return r_fail(r, r->chunk_off + CHUNK_HDR, "%s %llu: zlib data does not inflate to %u bytes (%s)", what,
                      (unsigned long long)idx, U,
                      r->zs.msg ? r->zs.msg : zr == Z_STREAM_END ? "length mismatch" : "stream error");
    return 0;
}

/* Reads the rest of a data chunk whose magic has been consumed at
 * r->chunk_off and makes its records current. */
static int read_chunk(rt_tr_reader *r)
{
    uint32_t U, C;
    if (read_chunk_bytes(r, 0, &U, &C) < 0 || inflate_exact(r, r->raw, U, C, "chunk") < 0) return -1;
    r->rpos = 0;
    r->rlen = U;
    r->rleft = r->rnum = r->data_n;
    memset(&r->cd, 0, sizeof r->cd);
    r->side_pending = r->has_sample;
    return 0;
}

/* Reads the side chunk that must follow the data chunk just read (its
 * magic not yet consumed) into r->sraw; *U is its payload length. */
static int read_side_chunk(rt_tr_reader *r, uint32_t *U)
{
    unsigned char m[4];
    uint64_t idx = r->got.nchunks - 1;
    r->chunk_off = r->off;
    if (r_read(r, m, 4, "a side chunk magic") < 0) return -1;
    if (memcmp(m, SIDE_MAGIC, 4) != 0)
        return r_fail(r, r->chunk_off, "chunk %llu: its side chunk is missing (found %02x %02x %02x %02x)",
                      (unsigned long long)idx, m[0], m[1], m[2], m[3]);
    uint32_t C;
    if (read_chunk_bytes(r, 1, U, &C) < 0 || inflate_exact(r, r->sraw, *U, C, "side chunk") < 0) return -1;
    if (r->sraw[0] & ~(1 | RT_TR_SIDE_MAKER))
        return r_fail(r, r->chunk_off + CHUNK_HDR, "side chunk %llu: unknown flags %#x", (unsigned long long)idx,
                      r->sraw[0]);
    r->last_seen = r->sraw[0] & 1;
    r->side_pending = 0;
    return 0;
}

/* Records mode: the side chunk of the data chunk whose records have all
 * been decoded (and fed to r->vctx) must be the one the records make. */
static int check_side(rt_tr_reader *r)
{
    uint32_t U;
    if (read_side_chunk(r, &U) < 0) return -1;
    uint64_t idx = r->got.nchunks - 1;
    const unsigned char *mb = NULL;
    size_t mn = 0;
    if (r->vops->chunk(r->vctx, r->last_seen, &mb, &mn) < 0) return r_fail(r, r->chunk_off, "out of memory");
    if (mn != U || memcmp(mb, r->sraw, U) != 0) {
        size_t k = 0;
        while (k < U && k < mn && mb[k] == r->sraw[k]) k++;
        return r_fail(r, r->chunk_off, "side chunk %llu does not match the records of chunk %llu (payload byte %zu "
                      "of %u differs from the sample index the records make)",
                      (unsigned long long)idx, (unsigned long long)idx, k, U);
    }
    return 0;
}

static int read_footer(rt_tr_reader *r)
{
    unsigned char f[FOOT_LEN];
    uint64_t at = r->chunk_off;
    memcpy(f, FOOT_MAGIC, 4);
    if (r_read(r, f + 4, 4, "the footer") < 0) return -1;
    const uint32_t nc = get32(f + 4); /* checked before the rest is read: it sets the footer's length */
    if (nc < RT_NCLASS_V1 || nc > RT_NCLASS)
        return r_fail(r, at + 4, "footer: %u classes, expected %d..%d", nc, RT_NCLASS_V1, RT_NCLASS);
    const unsigned flen = FOOT_LEN_N(nc);
    if (r_read(r, f + 8, flen - 8, "the footer") < 0) return -1;
    if (crc(0, f, flen - 4) != get32(f + flen - 4)) return r_fail(r, at, "footer CRC mismatch");
    rt_tr_totals *t = &r->foot;
    memset(t, 0, sizeof *t); /* classes beyond nc: none */
    t->nrefs = get64(f + 8);
    t->nchunks = get64(f + 16);
    for (int c = 0; c < (int)nc; c++) {
        t->refs[c] = get64(f + 24 + 24 * c);
        t->bytes[c] = get64(f + 32 + 24 * c);
        t->writes[c] = get64(f + 40 + 24 * c);
    }
    if (r->has_sample && r->got.nchunks > 0 && !r->last_seen)
        return r_fail(r, at, "footer follows a side chunk not marked last");
    if (t->nchunks != r->got.nchunks)
        return r_fail(r, at, "footer says %llu chunks, file has %llu", (unsigned long long)t->nchunks,
                      (unsigned long long)r->got.nchunks);
    if (t->nrefs != r->got.nrefs)
        return r_fail(r, at, "footer says %llu references, file has %llu", (unsigned long long)t->nrefs,
                      (unsigned long long)r->got.nrefs);
    for (int c = 0; c < RT_NCLASS && (r->mode != RM_SIDE || r->tallied); c++)
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
    if (!memcmp(m, SIDE_MAGIC, 4))
        return r_fail(r, r->chunk_off, r->has_sample ? "side chunk where a chunk or the footer was expected"
                                                      : "side chunk in a trace of format version %u", r->version);
    return r_fail(r, r->chunk_off, "bad chunk magic %02x %02x %02x %02x", m[0], m[1], m[2], m[3]);
}

static int dec_fail(rt_tr_reader *r, const char *what)
{
    return r_fail(r, r->chunk_off, "chunk %llu: record %u: %s", (unsigned long long)(r->got.nchunks - 1),
                  r->rnum - r->rleft, what);
}

void rt_tr_set_side_check(rt_tr_reader *r, int on) { r->no_side_check = !on; }
void rt_tr_set_payload_check(rt_tr_reader *r, const rt_tr_payload_ops *ops)
{
    if (r->mode == RM_NONE) r->vops = ops;
}

/* Adds a[0..n) to the totals, on four rows in turn so that neighbours,
 * which mostly share a class, do not wait on each other's increments. */
static void tally(rt_tr_totals *t, const rt_access *a, size_t n)
{
    uint64_t refs[4][RT_NCLASS] = {{0}}, bytes[4][RT_NCLASS] = {{0}}, wr[4][RT_NCLASS] = {{0}};
    for (size_t i = 0; i < n; i++) {
        unsigned c = a[i].cls;
        refs[i & 3][c]++;
        bytes[i & 3][c] += a[i].size;
        wr[i & 3][c] += a[i].write;
    }
    for (int c = 0; c < RT_NCLASS; c++)
        for (int k = 0; k < 4; k++) {
            t->refs[c] += refs[k][c];
            t->bytes[c] += bytes[k][c];
            t->writes[c] += wr[k][c];
        }
    t->nrefs += n;
}

int rt_tr_put_core(rt_tr_writer *w, unsigned core, const rt_access *a, size_t n)
{
    if (w->failed) return -1;
    if (core >= w->cores) {
        rt_errf(&w->err, "%s: record %llu: core %u, the header declares %u", w->path, (unsigned long long)w->tot.nrefs,
                core, w->cores);
        w->failed = 1;
        return -1;
    }
    w->core = core;
    int rc = w_put(&w->sink, a, n);
    w->core = 0;
    return rc;
}

long rt_tr_read(rt_tr_reader *r, rt_access *buf, size_t cap, rt_err *e) { return rt_tr_read_cores(r, buf, NULL, cap, e); }

long rt_tr_read_cores(rt_tr_reader *r, rt_access *buf, uint8_t *cores, size_t cap, rt_err *e)
{
    if (r->state == RS_FAILED) return rt_errf(e, "%s", r->err.msg);
    if (r->state == RS_DONE) return 0;
    if (cap == 0) return rt_errf(e, "%s: rt_tr_read called with an empty buffer", r->path);
    if (cap > (size_t)LONG_MAX) cap = (size_t)LONG_MAX;
    if (r->mode == RM_SIDE) return rt_errf(e, "%s: rt_tr_read after rt_tr_read_payload", r->path);
    r->mode = RM_RECORDS;
    if (r->has_sample && !r->no_side_check && r->vops && !r->vctx &&
        !(r->vctx = r->vops->open(&r->sp, r->meta.generations, e)))
        return -1;
    size_t n = 0, fed = 0; /* buf[0..fed) went to the side chunk check */
    while (n < cap) {
        if (r->rleft == 0) {
            if (r->rpos != r->rlen) {
                dec_fail(r, "encoded bytes left over after the last record");
                return rt_errf(e, "%s", r->err.msg);
            }
            if (r->side_pending && !r->vctx) { /* no payload check, or rt_tr_set_side_check(r, 0) */
                uint32_t U;
                if (read_side_chunk(r, &U) < 0) return rt_errf(e, "%s", r->err.msg);
                continue;
            }
            if (r->side_pending) {
                if (r->vops->put(r->vctx, buf + fed, n - fed) < 0) {
                    r_fail(r, r->off, "out of memory");
                    return rt_errf(e, "%s", r->err.msg);
                }
                fed = n;
                if (check_side(r) < 0) return rt_errf(e, "%s", r->err.msg);
                continue;
            }
            if (advance(r) < 0) return rt_errf(e, "%s", r->err.msg);
            if (r->state == RS_DONE) break;
            continue;
        }
        /* a run of records in locals (the decoder state, the position,
         * the totals), written back once */
        const unsigned char *p = r->raw + r->rpos, *end = r->raw + r->rlen;
        const size_t m = r->rleft < cap - n ? r->rleft : cap - n;
        const unsigned maxgen = r->meta.generations;
        rt_trc_coder cd = r->cd;
        size_t i = 0;
        int dr = RT_TRC_OK;
        if (r->version == 4) {
            const unsigned nc = r->meta.cores;
            while (i < m && (dr = rt_trc_dec4(&p, end, &cd, maxgen, nc, &buf[n + i])) == RT_TRC_OK) {
                if (cores) cores[n + i] = (uint8_t)cd.core;
                i++;
            }
        } else {
            while (i < m && (dr = rt_trc_dec(&p, end, &cd, maxgen, &buf[n + i])) == RT_TRC_OK) i++;
            if (cores) memset(cores + n, 0, i);
        }
        tally(&r->got, buf + n, i);
        r->cd = cd;
        r->rpos = (size_t)(p - r->raw);
        r->rleft -= (uint32_t)i;
        n += i;
        if (dr != RT_TRC_OK) {
            dec_fail(r, rt_trc_msg(dr));
            return rt_errf(e, "%s", r->err.msg);
        }
    }
    if (r->vctx && r->vops->put(r->vctx, buf + fed, n - fed) < 0) {
        r_fail(r, r->off, "out of memory");
        return rt_errf(e, "%s", r->err.msg);
    }
    return (long)n;
}

int rt_tr_read_payload(rt_tr_reader *r, rt_tr_payload *s, rt_err *e)
{
    memset(s, 0, sizeof *s);
    if (r->state == RS_FAILED) return rt_errf(e, "%s", r->err.msg);
    if (!r->has_sample)
        return rt_errf(e, "%s: no side payloads (format version %u; version 3 has them)", r->path, r->version);
    if (r->mode == RM_RECORDS) return rt_errf(e, "%s: rt_tr_read_payload after rt_tr_read", r->path);
    r->mode = RM_SIDE;
    if (r->state == RS_DONE) return 0;
    unsigned char m[4];
    r->chunk_off = r->off;
    size_t got = fread(m, 1, 4, r->f);
    r->hash = rt_fnv1a(r->hash, m, got);
    r->off += got;
    if (got != 4) {
        if (ferror(r->f)) r_fail(r, r->off, "read error: %s", strerror(errno ? errno : EIO));
        else if (got == 0)
            r_fail(r, r->off, "file ends before the footer (truncated trace: %llu chunks read)",
                   (unsigned long long)r->got.nchunks);
        else r_fail(r, r->off, "file ends inside a chunk magic (truncated trace)");
        return rt_errf(e, "%s", r->err.msg);
    }
    if (!memcmp(m, FOOT_MAGIC, 4)) return read_footer(r) < 0 ? rt_errf(e, "%s", r->err.msg) : 0;
    if (memcmp(m, CHUNK_MAGIC, 4)) {
        r_fail(r, r->chunk_off, "bad chunk magic %02x %02x %02x %02x", m[0], m[1], m[2], m[3]);
        return rt_errf(e, "%s", r->err.msg);
    }
    uint32_t U, C;
    /* the data chunk: CRC-checked and hashed, not inflated */
    if (read_chunk_bytes(r, 0, &U, &C) < 0 || read_side_chunk(r, &U) < 0) return rt_errf(e, "%s", r->err.msg);
    r->got.nrefs += r->data_n;
    s->bytes = r->sraw;
    s->len = U;
    s->last = r->last_seen;
    s->nrefs = r->data_n;
    s->index = r->got.nchunks - 1;
    s->offset = r->chunk_off;
    return 1;
}

void rt_tr_payload_tally(rt_tr_reader *r, const rt_tr_totals *t)
{
    for (int c = 0; c < RT_NCLASS; c++) {
        r->got.refs[c] += t->refs[c];
        r->got.bytes[c] += t->bytes[c];
        r->got.writes[c] += t->writes[c];
    }
    r->tallied = 1;
}

int rt_tr_payload_fail(rt_tr_reader *r, rt_err *e, const char *fmt, ...)
{
    char msg[RT_ERR_LEN];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    if (r->state != RS_FAILED)
        r_fail(r, r->chunk_off, "side chunk %llu: %s", (unsigned long long)(r->got.nchunks - 1), msg);
    return rt_errf(e, "%s", r->err.msg);
}

void rt_tr_close(rt_tr_reader *r)
{
    if (!r) return;
    if (r->f) fclose(r->f);
    if (r->zinit) inflateEnd(&r->zs);
    if (r->vctx) r->vops->close(r->vctx);
    free(r->sraw);
    free(r->raw);
    free(r->cbuf);
    free(r->path);
    free(r);
}
