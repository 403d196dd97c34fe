/*
 * scene_file.c -- a scene file's bytes, plain or gzip (scene_file.h).
 *
 * One loop reads the source in 64 KiB pieces. The first two bytes decide:
 * gzip's magic 1f 8b sends every piece through zlib's inflate (gzip
 * wrapper, windowBits 15 + 16; a member that ends is followed by another
 * when bytes remain, as gzip writes concatenated files), anything else is
 * copied. Invariants: (F1) the output buffer never holds more than
 * max_bytes + 1 bytes of content (it grows by doubling up to
 * max_bytes + 2, and the first byte past max_bytes ends the read with a
 * refusal); (F2) a gzip source is accepted only when its last member ended
 * (Z_STREAM_END) and no byte follows that is not another member; (F3) on
 * failure nothing stays allocated and why names the compressed byte where
 * zlib stopped.
 */
#include "config.h"
#include "scene_file.h"

#include <errno.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>
#include <zlib.h>

#define CHUNK 65536

typedef struct outbuf {
    char *p;
    size_t n, cap; /* content bytes, allocated bytes (content + NUL fits) */
    uint64_t max;  /* the limit on content */
} outbuf;

/* Room for at least one more content byte (and the NUL). 0, or -1 when
 * the content already passed the limit or memory ran out. */
static int out_room(outbuf *o, char *why, size_t nwhy)
{
    if (o->n + 1 < o->cap) return 0;
    uint64_t lim = o->max + 2;
    if ((uint64_t)o->cap >= lim || o->cap > SIZE_MAX / 2) {
        snprintf(why, nwhy, "more than %llu bytes", (unsigned long long)o->max);
        return -1;
    }
    uint64_t nc = o->cap ? 2 * (uint64_t)o->cap : CHUNK;
    if (nc > lim) nc = lim;
    char *np = realloc(o->p, (size_t)nc);
    if (!np) {
        snprintf(why, nwhy, "out of memory allocating %llu bytes", (unsigned long long)nc);
        return -1;
    }
    o->p = np;
    o->cap = (size_t)nc;
    return 0;
}

static int too_big(const outbuf *o, int gz, char *why, size_t nwhy)
{
    if ((uint64_t)o->n <= o->max) return 0;
    snprintf(why, nwhy, "more than %llu bytes%s", (unsigned long long)o->max, gz ? " (decompressed)" : "");
    return -1;
}

static ssize_t rd_retry(rt_sfile_read_fn rd, void *ctx, void *buf, size_t n)
{
    for (;;) {
        ssize_t r = rd(ctx, buf, n);
        if (r >= 0 || errno != EINTR) return r;
    }
}

int rt_sfile_read(rt_sfile_read_fn rd, void *ctx, uint64_t max_bytes, char **pbuf, size_t *pn, int *gz, char *why,
                  size_t nwhy)
{
    unsigned char *in = malloc(CHUNK);
    outbuf o = {NULL, 0, 0, max_bytes};
    z_stream z;
    int zinit = 0, rc = -1, is_gz = 0;
    size_t have = 0;       /* bytes in `in` not yet used */
    uint64_t got = 0;      /* bytes read from the source */
    int eof = 0;
    memset(&z, 0, sizeof z);
    why[0] = 0;
    if (!in) {
        snprintf(why, nwhy, "out of memory");
        goto done;
    }
    /* the first two bytes (or fewer at the end) decide */
    while (have < 2 && !eof) {
        ssize_t r = rd_retry(rd, ctx, in + have, CHUNK - have);
        if (r < 0) {
            snprintf(why, nwhy, "%s", strerror(errno));
            goto done;
        }
        if (r == 0) eof = 1;
        have += (size_t)r;
        got += (uint64_t)r;
    }
    is_gz = have >= 2 && in[0] == 0x1f && in[1] == 0x8b;
    if (!is_gz) {
        for (;;) {
            size_t off = 0;
            while (off < have) {
                if (out_room(&o, why, nwhy) < 0) goto done;
                size_t k = o.cap - 1 - o.n;
                if (k > have - off) k = have - off;
                memcpy(o.p + o.n, in + off, k);
                o.n += k;
                off += k;
                if (too_big(&o, 0, why, nwhy) < 0) goto done;
            }
            have = 0;
            if (eof) break;
            ssize_t r = rd_retry(rd, ctx, in, CHUNK);
            if (r < 0) {
                snprintf(why, nwhy, "%s", strerror(errno));
                goto done;
            }
            if (r == 0) eof = 1;
            have = (size_t)r;
            got += (uint64_t)r;
        }
    } else {
        if (inflateInit2(&z, 15 + 16) != Z_OK) {
            snprintf(why, nwhy, "gzip: cannot start zlib");
            goto done;
        }
        zinit = 1;
        z.next_in = in;
        z.avail_in = (uInt)have;
        int in_member = 1;
        for (;;) {
            if (z.avail_in == 0 && !eof) {
                ssize_t r = rd_retry(rd, ctx, in, CHUNK);
                if (r < 0) {
                    snprintf(why, nwhy, "%s", strerror(errno));
                    goto done;
                }
                if (r == 0) eof = 1;
                got += (uint64_t)r;
                z.next_in = in;
                z.avail_in = (uInt)r;
            }
            if (z.avail_in == 0 && eof) {
                if (in_member) {
                    snprintf(why, nwhy, "truncated gzip data (the stream ends at compressed byte %llu)",
                             (unsigned long long)got);
                    goto done;
                }
                break;
            }
            if (!in_member) { /* another member follows */
                if (inflateReset(&z) != Z_OK) {
                    snprintf(why, nwhy, "gzip: cannot restart zlib");
                    goto done;
                }
                in_member = 1;
            }
            if (out_room(&o, why, nwhy) < 0) {
                snprintf(why, nwhy, "more than %llu bytes (decompressed)", (unsigned long long)max_bytes);
                goto done;
            }
            size_t room = o.cap - 1 - o.n;
            z.next_out = (unsigned char *)o.p + o.n;
            z.avail_out = room > (1u << 30) ? (1u << 30) : (uInt)room;
            uInt before = z.avail_out;
            int ret = inflate(&z, Z_NO_FLUSH);
            o.n += before - z.avail_out;
            if (too_big(&o, 1, why, nwhy) < 0) goto done;
            if (ret == Z_STREAM_END) in_member = 0;
            else if (ret == Z_OK || ret == Z_BUF_ERROR) continue;
            else {
                snprintf(why, nwhy, "gzip data: %s (compressed byte %llu)",
                         ret == Z_MEM_ERROR ? "out of memory" : z.msg ? z.msg : "damaged",
                         (unsigned long long)(got - z.avail_in));
                goto done;
            }
        }
    }
    /* o.n <= o.cap - 1 always (every copy and inflate leaves that room),
     * so the NUL fits */
    if (!o.p) { /* an empty source */
        o.p = malloc(1);
        if (!o.p) {
            snprintf(why, nwhy, "out of memory");
            goto done;
        }
    }
    o.p[o.n] = 0;
    *pbuf = o.p;
    *pn = o.n;
    *gz = is_gz;
    o.p = NULL;
    rc = 0;
done:
    if (zinit) inflateEnd(&z);
    free(in);
    free(o.p);
    return rc;
}

/* A regular file read through its descriptor: never more bytes than
 * fstat gave at the start, so a file that grows while read, or a
 * pseudo-file whose size says 0 but whose reads never end (/proc), is
 * refused instead of read to the limit. */
typedef struct fdsrc {
    int fd;
    int bounded;        /* a regular file: size holds */
    uint64_t size, got; /* its size at the start, bytes read */
    int grew;
} fdsrc;

static ssize_t fd_read(void *ctx, void *buf, size_t n)
{
    fdsrc *f = ctx;
    ssize_t r = read(f->fd, buf, n);
    if (r > 0) {
        f->got += (uint64_t)r;
        if (f->bounded && f->got > f->size) {
            f->grew = 1;
            errno = EFBIG;
            return -1;
        }
    }
    return r;
}

int rt_sfile_read_fd(int fd, uint64_t max_bytes, char **pbuf, size_t *pn, int *gz, char *why, size_t nwhy)
{
    fdsrc f = {fd, 0, 0, 0, 0};
    struct stat st;
    if (fstat(fd, &st) == 0 && S_ISREG(st.st_mode)) {
        f.bounded = 1;
        f.size = (uint64_t)st.st_size;
    }
    int rc = rt_sfile_read(fd_read, &f, max_bytes, pbuf, pn, gz, why, nwhy);
    if (rc < 0 && f.grew)
        snprintf(why, nwhy, "the file holds more than the %llu bytes it had when opened (it grew, or is not a plain "
                 "file)", (unsigned long long)f.size);
    return rc;
}

typedef struct memsrc {
    const unsigned char *p;
    size_t n, pos;
} memsrc;

static ssize_t mem_read(void *ctx, void *buf, size_t n)
{
    memsrc *m = ctx;
    size_t k = m->n - m->pos;
    if (k > n) k = n;
    memcpy(buf, m->p + m->pos, k);
    m->pos += k;
    return (ssize_t)k;
}

int rt_sfile_read_mem(const void *data, size_t n, uint64_t max_bytes, char **pbuf, size_t *pn, int *gz, char *why,
                      size_t nwhy)
{
    memsrc m = {data, n, 0};
    return rt_sfile_read(mem_read, &m, max_bytes, pbuf, pn, gz, why, nwhy);
}

int rt_sfile_slurp(const char *path, uint64_t max_bytes, char **pbuf, size_t *pn, rt_err *e)
{
    FILE *f = rt_open_regular(path, max_bytes, e);
    if (!f) return -1;
    char why[200], q[300];
    int gz;
    int rc = rt_sfile_read_fd(fileno(f), max_bytes, pbuf, pn, &gz, why, sizeof why);
    fclose(f);
    if (rc < 0) {
        rt_esc(q, sizeof q, path, 4096);
        return rt_errf(e, "%s: %s%s", q, why, strstr(why, "more than") ? " (RT_SCENE_MAX_BYTES)" : "");
    }
    return 0;
}

int rt_sfile_warn(rt_scene *s, const char *kind, const char *first, rt_err *e, const char *fmt, ...)
{
    for (uint32_t i = 0; i < s->nwarn; i++)
        if (!strcmp(s->warn[i].kind, kind)) {
            s->warn[i].count++;
            return 0;
        }
    if (s->nwarn == RT_SCENE_MAX_WARN) { /* the last entry counts the rest */
        rt_scene_warn *w = &s->warn[s->nwarn - 1];
        if (strcmp(w->kind, "other")) {
            snprintf(w->kind, sizeof w->kind, "other");
            snprintf(w->msg, sizeof w->msg, "more than %d kinds of warnings: the others", RT_SCENE_MAX_WARN - 1);
        }
        w->count++;
        return 0;
    }
    if ((s->nwarn & (s->nwarn - 1)) == 0) { /* 0, 1, 2, 4, ...: grow */
        uint32_t nc = s->nwarn ? 2 * s->nwarn : 1;
        rt_scene_warn *nw = rt_reallocarray(s->warn, nc, sizeof *nw, e);
        if (!nw) return -1;
        s->warn = nw;
    }
    rt_scene_warn *w = &s->warn[s->nwarn++];
    memset(w, 0, sizeof *w);
    snprintf(w->kind, sizeof w->kind, "%s", kind);
    snprintf(w->first, sizeof w->first, "%s", first);
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(w->msg, sizeof w->msg, fmt, ap);
    va_end(ap);
    w->count = 1;
    rt_sfile_warn_summary(s);
    return 0;
}

void rt_sfile_warn_summary(rt_scene *s)
{
    size_t cap = sizeof s->warning, k = 0;
    uint32_t shown = 0;
    s->warning[0] = 0;
    for (uint32_t i = 0; i < s->nwarn; i++) {
        char one[520];
        const rt_scene_warn *w = &s->warn[i];
        if (w->count > 1) snprintf(one, sizeof one, "%s: %s (x%u)", w->first, w->msg, (unsigned)w->count);
        else snprintf(one, sizeof one, "%s: %s", w->first, w->msg);
        size_t need = strlen(one) + (k ? 2 : 0);
        if (k + need + 40 >= cap) break;
        snprintf(s->warning + k, cap - k, "%s%s", k ? "; " : "", one);
        k = strlen(s->warning);
        shown++;
    }
    if (shown < s->nwarn)
        snprintf(s->warning + k, cap - k, "%s(+%u more kinds of warnings)", k ? " " : "", (unsigned)(s->nwarn - shown));
}
