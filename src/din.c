/*
 * din.c -- reader for Dinero IV "din" text traces.
 *
 * Each line is "LABEL ADDRESS [ignored...]": LABEL 0 = data read, 1 = data
 * write, 2 = instruction fetch (simulated as a read); ADDRESS is
 * hexadecimal with or without 0x. Any other label, a missing or malformed
 * address, or a NUL byte, is an error naming file:line. Blank lines are skipped. Every
 * record becomes a 1-byte reference of the class given at open (default
 * "other"), as Dinero IV itself treats din records without a size.
 */
#include "din.h"

#include <ctype.h>
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

struct rt_din {
    FILE *f;          /* open file */
    char *path;       /* for messages */
    int cls;          /* class of every record */
    uint64_t lineno;  /* lines read */
    uint64_t hash;    /* FNV-1a of bytes read */
    uint64_t bytes;   /* bytes read */
    char *buf;        /* getline buffer */
    size_t bufcap;    /* its capacity */
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
    d->cls = cls;
    d->hash = RT_FNV_INIT;
    return d;
}

long rt_din_read(rt_din *d, rt_access *buf, size_t cap, rt_err *e)
{
    size_t n = 0;
    while (n < cap) {
        ssize_t len = getline(&d->buf, &d->bufcap, d->f);
        if (len < 0) {
            if (ferror(d->f)) return rt_errf(e, "%s:%llu: read error", d->path, (unsigned long long)d->lineno + 1);
            break;
        }
        d->lineno++;
        d->bytes += (uint64_t)len;
        d->hash = rt_fnv1a(d->hash, d->buf, (size_t)len);
        /* strtoull would stop at a NUL and take what follows for the end
         * of the line: a text trace has no NUL bytes. */
        if (memchr(d->buf, 0, (size_t)len))
            return rt_errf(e, "%s:%llu: NUL byte in line", d->path, (unsigned long long)d->lineno);
        const char *p = d->buf;
        while (*p == ' ' || *p == '\t') p++;
        if (*p == '\n' || *p == '\r' || *p == 0) continue;
        if (!isdigit((unsigned char)*p))
            return rt_errf(e, "%s:%llu: expected 'label address'", d->path, (unsigned long long)d->lineno);
        char *end;
        unsigned long label = strtoul(p, &end, 10);
        if (end == p || (*end != ' ' && *end != '\t'))
            return rt_errf(e, "%s:%llu: expected 'label address'", d->path, (unsigned long long)d->lineno);
        if (label > 2)
            return rt_errf(e, "%s:%llu: unsupported din label %lu (0 read, 1 write, 2 fetch)", d->path,
                           (unsigned long long)d->lineno, label);
        p = end;
        while (*p == ' ' || *p == '\t') p++;
        if (!isxdigit((unsigned char)*p))
            return rt_errf(e, "%s:%llu: missing hexadecimal address", d->path, (unsigned long long)d->lineno);
        errno = 0;
        unsigned long long addr = strtoull(p, &end, 16);
        if (errno || (*end && !isspace((unsigned char)*end)))
            return rt_errf(e, "%s:%llu: bad hexadecimal address", d->path, (unsigned long long)d->lineno);
        buf[n].addr = addr;
        buf[n].size = 1;
        buf[n].write = label == 1;
        buf[n].cls = (uint8_t)d->cls;
        buf[n].gen = 0;
        n++;
    }
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
