/* rt.c -- error formatting, version, clock, checked allocation, hashing. */
#include "config.h"
#include "rt.h"
#include "gitrev.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

long rt_fail_alloc_after = 0;

int rt_errf(rt_err *e, const char *fmt, ...)
{
    if (e) {
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(e->msg, sizeof e->msg, fmt, ap);
        va_end(ap);
        for (char *p = e->msg; *p; p++)
            if (*p == '\n' || *p == '\r') *p = ' ';
    }
    return -1;
}

const char *rt_version(void) { return PACKAGE_VERSION; }
const char *rt_git_rev(void) { return RT_GIT_REV; }

double rt_now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static int alloc_should_fail(void)
{
    if (rt_fail_alloc_after > 0 && --rt_fail_alloc_after == 0) return 1;
    return 0;
}

void *rt_calloc(size_t n, size_t size, rt_err *e)
{
    if (size && n > SIZE_MAX / size) {
        rt_errf(e, "allocation of %zu x %zu bytes overflows", n, size);
        return NULL;
    }
    void *p = alloc_should_fail() ? NULL : calloc(n ? n : 1, size ? size : 1);
    if (!p) rt_errf(e, "out of memory allocating %zu bytes", n * size);
    return p;
}

void *rt_reallocarray(void *p, size_t n, size_t size, rt_err *e)
{
    if (size && n > SIZE_MAX / size) {
        rt_errf(e, "allocation of %zu x %zu bytes overflows", n, size);
        return NULL;
    }
    void *q = alloc_should_fail() ? NULL : realloc(p, (n && size) ? n * size : 1);
    if (!q) rt_errf(e, "out of memory allocating %zu bytes", n * size);
    return q;
}

uint64_t rt_fnv1a(uint64_t h, const void *data, size_t n)
{
    const unsigned char *p = data;
    for (size_t i = 0; i < n; i++) {
        h ^= p[i];
        h *= 0x100000001b3ULL;
    }
    return h;
}

int rt_parse_size(const char *s, uint64_t *out)
{
    if (!s || !*s) return -1;
    errno = 0;
    char *end;
    if (*s == '-') return -1;
    unsigned long long v = strtoull(s, &end, 10);
    if (errno || end == s) return -1;
    unsigned shift = 0;
    if (*end) {
        switch (*end) {
        case 'k': case 'K': shift = 10; break;
        case 'm': case 'M': shift = 20; break;
        case 'g': case 'G': shift = 30; break;
        default: return -1;
        }
        end++;
        if (*end == 'B' || *end == 'b') end++;
        if (*end) return -1;
    }
    if (shift && v > (UINT64_MAX >> shift)) return -1;
    *out = (uint64_t)v << shift;
    return 0;
}

int rt_slurp(const char *path, char **pbuf, size_t *pn, rt_err *e)
{
    FILE *f = fopen(path, "rb");
    if (!f) return rt_errf(e, "%s: %s", path, strerror(errno));
    size_t cap = 1 << 16, n = 0;
    char *buf = rt_calloc(cap, 1, e);
    if (!buf) {
        fclose(f);
        return -1;
    }
    for (;;) {
        if (n + 1 >= cap) {
            if (cap > SIZE_MAX / 2) {
                free(buf);
                fclose(f);
                return rt_errf(e, "%s: file too large", path);
            }
            char *nb = rt_reallocarray(buf, cap * 2, 1, e);
            if (!nb) {
                free(buf);
                fclose(f);
                return -1;
            }
            buf = nb;
            cap *= 2;
        }
        size_t got = fread(buf + n, 1, cap - 1 - n, f);
        n += got;
        if (got == 0) break;
    }
    int bad = ferror(f);
    fclose(f);
    if (bad) {
        free(buf);
        return rt_errf(e, "%s: read error", path);
    }
    buf[n] = 0;
    *pbuf = buf;
    *pn = n;
    return 0;
}
