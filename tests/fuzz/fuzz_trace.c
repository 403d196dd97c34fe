/*
 * fuzz_trace.c -- fuzz target for the .rtt trace reader (src/trace.c) and
 * the decoder of its sample index (cachesim/sindex.c).
 *
 * Every byte of a trace is covered by a CRC and every chunk is a zlib
 * stream, so random mutations of a file are almost all refused at the
 * first CRC. The first input byte therefore chooses how the rest becomes
 * the file (bits 0-1) and the reader's buffer size (bits 2-7, 1..253):
 *
 *   0  the file as given: magic, CRC and framing checks;
 *   1  the file with its CRCs recomputed wherever the framing (header
 *      length, chunk lengths, footer) can be followed: header and footer
 *      parsing, chunk bounds, inflate errors;
 *   2  like 1, but each chunk's body is the record bytes before zlib: the
 *      harness compresses them and fills in U, C and the CRC, so the
 *      record decoder sees arbitrary records (and, for side chunks, the
 *      sample-index decoder arbitrary payloads).
 *
 * Each file is read twice: its records (rt_tr_read, with the sample
 * index's payload check) and its sample index (rt_si_read).
 *
 * Contracts checked: metadata strings are terminated; no read returns
 * more than asked; every record has class < RT_NCLASS, size >= 1, write
 * 0 or 1; a 0 (verified end) comes only with footer totals equal to the
 * records returned, after every byte (file size and FNV-1a hash of the
 * file match), and stays 0; a -1 has a message and repeats with the same
 * message. The sample-index read: each chunk's sampled records and
 * windows are valid records within the header's bounds, a 0 comes after
 * every byte with the footer's count equal to the chunks' records, -1 as
 * above.
 */
#include "fuzz.h"
#include "sindex.h"
#include "trace.h"

#include <zlib.h>

#define CHUNK_HDR 24u
#define FOOT_LEN_N(nc) (4u + 4u + 16u + 24u * (size_t)(nc) + 4u) /* nc classes, 10..13 */

static uint32_t rd32(const uint8_t *p) { return p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24; }
static void wr32(uint8_t *p, uint32_t v)
{
    for (int i = 0; i < 4; i++) p[i] = (uint8_t)(v >> (8 * i));
}
static uint32_t crc(uint32_t c, const uint8_t *p, size_t n) { return (uint32_t)crc32(c, p, (uInt)n); }

/* Rebuilds the input (mode 1 or 2) into out (capacity cap); returns its
 * length. Bytes the framing cannot explain are copied unchanged. */
static size_t rebuild(const uint8_t *in, size_t n, int plain, uint8_t *out, size_t cap)
{
    size_t i = 0, o = 0;
    if (n < 16 || memcmp(in, "RTTRACE", 8) != 0) goto rest;
    size_t P = rd32(in + 12);
    if (16 + P + 4 > n) goto rest;
    memcpy(out, in, 16 + P);
    wr32(out + 16 + P, crc(0, out, 16 + P));
    i = o = 20 + P;
    while (i + CHUNK_HDR <= n && (memcmp(in + i, "RTCK", 4) == 0 || memcmp(in + i, "RTSM", 4) == 0)) {
        size_t C = rd32(in + i + 16);
        if (i + CHUNK_HDR + C > n) break;
        uint8_t *h = out + o;
        memcpy(h, in + i, 20);
        if (plain) {
            uLongf clen = (uLongf)(cap - o - CHUNK_HDR);
            if (compress2(h + CHUNK_HDR, &clen, in + i + CHUNK_HDR, (uLong)C, 1) != Z_OK) rt_fuzz_fail("compress2");
            wr32(h + 12, (uint32_t)C);
            wr32(h + 16, (uint32_t)clen);
            C = clen;
        } else {
            memcpy(h + CHUNK_HDR, in + i + CHUNK_HDR, C);
        }
        wr32(h + 20, crc(crc(0, h, 20), h + CHUNK_HDR, C));
        i += CHUNK_HDR + rd32(in + i + 16);
        o += CHUNK_HDR + C;
    }
    if (i + 8 <= n && memcmp(in + i, "RTND", 4) == 0) {
        uint32_t nc = rd32(in + i + 4);
        size_t flen = FOOT_LEN_N(nc >= RT_NCLASS_V1 && nc <= RT_NCLASS ? nc : RT_NCLASS_V1);
        if (i + flen <= n) {
            memcpy(out + o, in + i, flen - 4);
            wr32(out + o + flen - 4, crc(0, out + o, flen - 4));
            i += flen;
            o += flen;
        }
    }
rest:
    memcpy(out + o, in + i, n - i);
    return o + n - i;
}

static int meta_ok(const rt_tr_meta *m)
{
#define T(f) (memchr(m->f, 0, sizeof m->f) != NULL)
    return T(tool_version) && T(git_rev) && T(command) && T(scene) && T(scene_params) && T(tracer) && T(params);
#undef T
}

static int rec_ok(const rt_access *a) { return a->cls < RT_NCLASS && a->size >= 1 && a->write <= 1; }

/* The sample-index read of the file at path (n bytes, in). */
static void side_read(const char *path, const uint8_t *in, size_t n)
{
    rt_err e = {0};
    rt_tr_reader *r = rt_tr_open(path, &e);
    if (!r) return;
    rt_si_reader *d = rt_si_reader_new(r, &e);
    if (!d) rt_fuzz_fail("no sample-index decoder: %s", e.msg);
    rt_tr_sample_params sp;
    int has = rt_tr_get_sample_params(r, &sp);
    rt_si_side sd;
    uint64_t nrefs = 0;
    int k;
    while ((k = rt_si_read(d, &sd, &e)) > 0) {
        if (!has) rt_fuzz_fail("a sample index read from a trace without one");
        if (sd.nsampled > sd.nrefs) rt_fuzz_fail("%llu sampled of %llu records", (unsigned long long)sd.nsampled,
                                                 (unsigned long long)sd.nrefs);
        for (uint64_t i = 0; i < sd.nsampled; i++)
            if (!rec_ok(&sd.sampled[i])) rt_fuzz_fail("bad sampled record");
        for (uint32_t j = 0; j < sd.nwin; j++) {
            const rt_si_window *w = &sd.win[j];
            if (w->nwarm > sp.cmax || w->nrecs < 1 || w->nrecs > sp.window || w->scanned > sp.hist)
                rt_fuzz_fail("window %u: %u warm-up lines, %u records, %llu scanned", j, w->nwarm, w->nrecs,
                             (unsigned long long)w->scanned);
            for (uint32_t i = 0; i < w->nwarm; i++)
                if (!rec_ok(&w->warm[i])) rt_fuzz_fail("bad warm-up record");
            for (uint32_t i = 0; i < w->nrecs; i++)
                if (!rec_ok(&w->recs[i])) rt_fuzz_fail("bad window record");
        }
        nrefs += sd.nrefs;
    }
    if (k == 0) {
        if (rt_tr_get_totals(r)->nrefs != nrefs) rt_fuzz_fail("footer count differs from the side chunks'");
        if (rt_tr_file_bytes(r) != n || rt_tr_file_hash(r) != rt_fnv1a(RT_FNV_INIT, in, n))
            rt_fuzz_fail("sample-index read ended before every byte");
        if (rt_si_read(d, &sd, &e) != 0) rt_fuzz_fail("sample-index read after the end is not 0");
    } else {
        rt_err e2 = {0};
        if (!e.msg[0]) rt_fuzz_fail("sample-index error without a message");
        if (rt_si_read(d, &sd, &e2) != -1 || strcmp(e.msg, e2.msg) != 0)
            rt_fuzz_fail("a second sample-index read after an error differs: '%s' then '%s'", e.msg, e2.msg);
    }
    rt_si_reader_free(d);
    rt_tr_close(r);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (size < 1) return 0;
    int mode = (data[0] & 3) % 3;
    size_t cap = 1 + (size_t)(data[0] >> 2) * 4;
    const uint8_t *in = data + 1;
    size_t n = size - 1;
    uint8_t *file = NULL;
    if (mode > 0) {
        /* compressBound per chunk: 13 bytes + 0.1% more than the input. */
        size_t fcap = 2 * n + 64 * (n / CHUNK_HDR + 1) + 64;
        if (!(file = malloc(fcap))) return 0;
        n = rebuild(in, n, mode == 2, file, fcap);
        in = file;
    }
    const char *path = rt_fuzz_file(in, n);
    rt_err e = {0};
    rt_tr_reader *r = rt_si_open(path, &e);
    if (!r) {
        if (!e.msg[0]) rt_fuzz_fail("open refused without a message");
        free(file);
        return 0;
    }
    if (!meta_ok(rt_tr_get_meta(r))) rt_fuzz_fail("unterminated metadata string");
    rt_access buf[256];
    rt_tr_totals sum;
    memset(&sum, 0, sizeof sum);
    long got;
    while ((got = rt_tr_read(r, buf, cap, &e)) > 0) {
        if ((size_t)got > cap) rt_fuzz_fail("read %ld records into %zu", got, cap);
        for (long k = 0; k < got; k++) {
            const rt_access *a = &buf[k];
            if (a->cls >= RT_NCLASS || a->size == 0 || a->write > 1)
                rt_fuzz_fail("record: class %u size %u write %u", a->cls, a->size, a->write);
            sum.refs[a->cls]++;
            sum.bytes[a->cls] += a->size;
            sum.writes[a->cls] += a->write;
            sum.nrefs++;
        }
    }
    if (got == 0) {
        const rt_tr_totals *t = rt_tr_get_totals(r);
        if (t->nrefs != sum.nrefs) rt_fuzz_fail("footer says %llu references, read %llu",
                                                (unsigned long long)t->nrefs, (unsigned long long)sum.nrefs);
        for (int c = 0; c < RT_NCLASS; c++)
            if (t->refs[c] != sum.refs[c] || t->bytes[c] != sum.bytes[c] || t->writes[c] != sum.writes[c])
                rt_fuzz_fail("footer totals of class %d differ from the records read", c);
        if (rt_tr_file_bytes(r) != n) rt_fuzz_fail("file bytes %llu, input %zu",
                                                   (unsigned long long)rt_tr_file_bytes(r), n);
        if (rt_tr_file_hash(r) != rt_fnv1a(RT_FNV_INIT, in, n)) rt_fuzz_fail("file hash differs");
        if (rt_tr_read(r, buf, cap, &e) != 0) rt_fuzz_fail("read after the end is not 0");
        rt_fuzz_accepted = 1;
    } else {
        rt_err e2 = {0};
        if (!e.msg[0]) rt_fuzz_fail("error without a message");
        if (rt_tr_read(r, buf, cap, &e2) != -1 || strcmp(e.msg, e2.msg) != 0)
            rt_fuzz_fail("a second read after an error differs: '%s' then '%s'", e.msg, e2.msg);
    }
    rt_tr_close(r);
    side_read(path, in, n);
    free(file);
    return 0;
}
