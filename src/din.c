/*
 * din.c -- reader for Dinero IV "din" text traces.
 *
 * Each line is "LABEL ADDRESS [ignored...]": LABEL 0 = data read, 1 = data
 * write, 2 = instruction fetch (simulated as a read); ADDRESS is
 * hexadecimal with or without 0x. Any other label, a missing or malformed
 * address, or a NUL byte, is an error naming file:line. Blank lines are skipped. Every
 * record becomes a 1-byte reference of the class given at open (default
 * "other"), as Dinero IV itself treats din records without a size.
 *
 * The reader fills a large buffer with fread and scans the lines by hand
 * (a line costs a few dozen instructions; getline + strtoull cost several
 * times that). Buffer invariants, all offsets into buf:
 *   hashed <= pos <= lim <= len + 1 <= cap + 1;
 *   [0, hashed) has been added to hash and bytes;
 *   [pos, lim) holds complete lines, each ending with '\n' (at the end of
 *   file a last line without one gets a sentinel '\n' at buf[len], which is
 *   not part of the input and is never hashed);
 *   nul is the offset of the first NUL byte at or after pos, or SIZE_MAX.
 * So the scanner never looks past a '\n' and needs no bounds checks inside
 * a line. The accepted syntax, the messages and the hash are exactly those
 * of the getline + strtoul/strtoull reader it replaced (kept as the
 * reference in tests/test_sim.c): label digits saturate to ULONG_MAX, an
 * address above 2^64-1 is an error, "0x" needs a hex digit after it.
 */
#include "din.h"

#include <errno.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define DIN_BLOCK (256 * 1024) /* first buffer size; grows for longer lines */

struct rt_din {
    FILE *f;          /* open file */
    char *path;       /* for messages */
    int cls;          /* class of every record */
    uint64_t lineno;  /* lines read */
    uint64_t hash;    /* FNV-1a of bytes read */
    uint64_t bytes;   /* bytes read */
    char *buf;        /* input block, cap + 1 bytes (room for the sentinel) */
    size_t cap;       /* its capacity without the sentinel byte */
    size_t len;       /* bytes of input in buf */
    size_t pos;       /* start of the next line */
    size_t lim;       /* end of the last complete line in buf */
    size_t hashed;    /* bytes of buf already hashed */
    size_t nul;       /* first NUL at or after pos, SIZE_MAX if none */
    int eof;          /* fread saw the end of the file */
};

/* Hex digit values, 255 for anything else. */
static const unsigned char hexval[256] = {
    255, 255, 255, 255, 255, 255, 255, 255, 255, 255, 255, 255, 255, 255, 255, 255,
    255, 255, 255, 255, 255, 255, 255, 255, 255, 255, 255, 255, 255, 255, 255, 255,
    255, 255, 255, 255, 255, 255, 255, 255, 255, 255, 255, 255, 255, 255, 255, 255,
    0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 255, 255, 255, 255, 255, 255,
    255, 10, 11, 12, 13, 14, 15, 255, 255, 255, 255, 255, 255, 255, 255, 255,
    255, 255, 255, 255, 255, 255, 255, 255, 255, 255, 255, 255, 255, 255, 255, 255,
    255, 10, 11, 12, 13, 14, 15, 255, 255, 255, 255, 255, 255, 255, 255, 255,
    255, 255, 255, 255, 255, 255, 255, 255, 255, 255, 255, 255, 255, 255, 255, 255,
    255, 255, 255, 255, 255, 255, 255, 255, 255, 255, 255, 255, 255, 255, 255, 255,
    255, 255, 255, 255, 255, 255, 255, 255, 255, 255, 255, 255, 255, 255, 255, 255,
    255, 255, 255, 255, 255, 255, 255, 255, 255, 255, 255, 255, 255, 255, 255, 255,
    255, 255, 255, 255, 255, 255, 255, 255, 255, 255, 255, 255, 255, 255, 255, 255,
    255, 255, 255, 255, 255, 255, 255, 255, 255, 255, 255, 255, 255, 255, 255, 255,
    255, 255, 255, 255, 255, 255, 255, 255, 255, 255, 255, 255, 255, 255, 255, 255,
    255, 255, 255, 255, 255, 255, 255, 255, 255, 255, 255, 255, 255, 255, 255, 255,
    255, 255, 255, 255, 255, 255, 255, 255, 255, 255, 255, 255, 255, 255, 255, 255,
};

rt_din *rt_din_open(const char *path, int cls, rt_err *e)
{
    if (cls < 0 || cls >= RT_NCLASS) return rt_errf(e, "%s: bad din class %d", path, cls), NULL;
    rt_din *d = rt_calloc(1, sizeof *d, e);
    if (!d) return NULL;
    d->path = strdup(path);
    d->f = fopen(path, "rb");
    if (!d->path || !d->f) {
        rt_errf(e, "%s: %s", path, strerror(errno));
        rt_din_close(d);
        return NULL;
    }
    if (!(d->buf = rt_calloc(DIN_BLOCK + 1, 1, e))) {
        rt_din_close(d);
        return NULL;
    }
    d->cap = DIN_BLOCK;
    d->cls = cls;
    d->hash = RT_FNV_INIT;
    d->nul = SIZE_MAX;
    return d;
}

/* Adds the consumed input [hashed, pos) (without the sentinel) to the hash. */
static void account(rt_din *d)
{
    size_t end = d->pos < d->len ? d->pos : d->len;
    if (end > d->hashed) {
        d->hash = rt_fnv1a(d->hash, d->buf + d->hashed, end - d->hashed);
        d->bytes += end - d->hashed;
        d->hashed = end;
    }
}

static void find_nul(rt_din *d)
{
    const char *z = d->pos < d->len ? memchr(d->buf + d->pos, 0, d->len - d->pos) : NULL;
    d->nul = z ? (size_t)(z - d->buf) : SIZE_MAX;
}

/* Makes [pos, lim) non-empty: moves the unfinished line to the front and
 * reads until a '\n' or the end of the file. 1 = lines ready, 0 = end of
 * file, -1 = read error or out of memory. */
static int refill(rt_din *d, rt_err *e)
{
    account(d);
    if (d->eof) return 0;
    size_t keep = d->len - d->pos;
    memmove(d->buf, d->buf + d->pos, keep);
    d->len = keep;
    d->pos = d->hashed = d->lim = 0;
    for (;;) {
        if (d->len == d->cap) {
            char *nb = rt_reallocarray(d->buf, 2 * d->cap + 1, 1, e);
            if (!nb) return -1;
            d->buf = nb;
            d->cap *= 2;
        }
        size_t got = fread(d->buf + d->len, 1, d->cap - d->len, d->f);
        if (got == 0) {
            if (ferror(d->f)) return rt_errf(e, "%s:%llu: read error", d->path, (unsigned long long)d->lineno + 1);
            d->eof = 1;
            if (d->len == 0) return 0;
            d->buf[d->len] = '\n'; /* sentinel ending the last line */
            d->lim = d->len + 1;
            find_nul(d);
            return 1;
        }
        size_t nl = d->len + got; /* one past the last '\n' of the new bytes, or d->len */
        while (nl > d->len && d->buf[nl - 1] != '\n') nl--;
        int found = nl > d->len;
        d->len += got;
        if (found) {
            d->lim = nl;
            find_nul(d);
            return 1;
        }
    }
}

/* A bad line starting at p: consumes it and reports msg, or the NUL byte
 * if the line holds one (that message takes precedence, as a NUL ends the
 * line for any C string parser). Returns -1. */
static long bad_line(rt_din *d, const char *p, const char *msg, unsigned long label, rt_err *e)
{
    const char *nl = memchr(p, '\n', (size_t)(d->buf + d->lim - p));
    d->pos = (size_t)(nl - d->buf) + 1;
    account(d);
    unsigned long long ln = (unsigned long long)d->lineno;
    if (d->nul < d->pos) {
        find_nul(d);
        return rt_errf(e, "%s:%llu: NUL byte in line", d->path, ln);
    }
    find_nul(d);
    if (!msg) return rt_errf(e, "%s:%llu: unsupported din label %lu (0 read, 1 write, 2 fetch)", d->path, ln, label);
    return rt_errf(e, "%s:%llu: %s", d->path, ln, msg);
}

long rt_din_read(rt_din *d, rt_access *buf, size_t cap, rt_err *e)
{
    size_t n = 0;
    const uint8_t cls = (uint8_t)d->cls;
    while (n < cap) {
        if (d->pos >= d->lim) {
            int r = refill(d, e);
            if (r < 0) return -1;
            if (r == 0) break;
        }
        const char *p = d->buf + d->pos, *q = p;
        d->lineno++;
        while (*q == ' ' || *q == '\t') q++;
        if (*q == '\n' || *q == '\r') { /* blank */
            while (*q != '\n') q++;
            if (d->nul <= (size_t)(q - d->buf)) return bad_line(d, p, "", 0, e);
            d->pos = (size_t)(q - d->buf) + 1;
            continue;
        }
        if ((unsigned)(*q - '0') > 9) return bad_line(d, p, "expected 'label address'", 0, e);
        unsigned long label = 0;
        for (unsigned dg; (dg = (unsigned)(*q - '0')) <= 9; q++)
            label = label > (ULONG_MAX - dg) / 10 ? ULONG_MAX : label * 10 + dg;
        if (*q != ' ' && *q != '\t') return bad_line(d, p, "expected 'label address'", 0, e);
        if (label > 2) return bad_line(d, p, NULL, label, e);
        while (*q == ' ' || *q == '\t') q++;
        if (hexval[(unsigned char)*q] == 0xff) return bad_line(d, p, "missing hexadecimal address", 0, e);
        if (q[0] == '0' && (q[1] == 'x' || q[1] == 'X') && hexval[(unsigned char)q[2]] != 0xff) q += 2;
        uint64_t addr = 0;
        int over = 0;
        for (unsigned v; (v = hexval[(unsigned char)*q]) != 0xff; q++) {
            over |= addr >> 60 != 0;
            addr = addr << 4 | v;
        }
        /* after the address: end of line or any isspace() byte */
        if (over || !(*q == '\n' || *q == ' ' || *q == '\t' || *q == '\r' || *q == '\v' || *q == '\f'))
            return bad_line(d, p, "bad hexadecimal address", 0, e);
        while (*q != '\n') q++;
        if (d->nul <= (size_t)(q - d->buf)) return bad_line(d, p, "", 0, e);
        d->pos = (size_t)(q - d->buf) + 1;
        buf[n].addr = addr;
        buf[n].size = 1;
        buf[n].write = label == 1;
        buf[n].cls = cls;
        buf[n].gen = 0;
        n++;
    }
    account(d);
    return (long)n;
}

uint64_t rt_din_file_hash(const rt_din *d) { return d->hash; }
uint64_t rt_din_file_bytes(const rt_din *d) { return d->bytes; }

void rt_din_close(rt_din *d)
{
    if (!d) return;
    if (d->f) fclose(d->f);
    free(d->path);
    free(d->buf);
    free(d);
}
