/* rt.c -- error formatting and quoting, version, clock, checked allocation,
 * hashing, size parsing, deterministic sin/cos, whole-file reads. */
#include "config.h"
#include "rt.h"
#include "gitrev.h"

#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

long rt_fail_alloc_after = 0;
uint64_t rt_scene_max_bytes = RT_SCENE_MAX_BYTES_DEFAULT;

static void errv(rt_err *e, int usage, const char *fmt, va_list ap)
{
    if (!e) return;
    vsnprintf(e->msg, sizeof e->msg, fmt, ap);
    for (char *p = e->msg; *p; p++)
        if (*p == '\n' || *p == '\r') *p = ' ';
    e->usage = usage;
}

int rt_errf(rt_err *e, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    errv(e, 0, fmt, ap);
    va_end(ap);
    return -1;
}

int rt_errf_usage(rt_err *e, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    errv(e, 1, fmt, ap);
    va_end(ap);
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
    /* strtoull skips whitespace and accepts a sign (" -64" is 2^64-64):
     * insist on a digit first. */
    if (!s || *s < '0' || *s > '9') return -1;
    errno = 0;
    char *end;
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

/* Reads f to its end, or until more than max_bytes were read, into a
 * malloc'd NUL-terminated buffer starting at cap bytes (*pbuf, *pn).
 * *bad: a read error. 0, 1 when the buffer could not grow (more than
 * SIZE_MAX / 2), or -1 out of memory (e set, nothing allocated). f stays
 * open. */
static int read_stream(FILE *f, size_t cap, uint64_t max_bytes, char **pbuf, size_t *pn, int *bad, rt_err *e)
{
    size_t n = 0;
    int huge = 0;
    char *buf = rt_calloc(cap, 1, e);
    if (!buf) return -1;
    for (;;) {
        if (n + 1 >= cap) {
            if (cap > SIZE_MAX / 2) {
                huge = 1;
                break;
            }
            char *nb = rt_reallocarray(buf, cap * 2, 1, e);
            if (!nb) {
                free(buf);
                return -1;
            }
            buf = nb;
            cap *= 2;
        }
        size_t got = fread(buf + n, 1, cap - 1 - n, f);
        n += got;
        if (got == 0 || (uint64_t)n > max_bytes) break;
    }
    *bad = ferror(f);
    buf[n < cap ? n : cap - 1] = 0;
    *pbuf = buf;
    *pn = n;
    return huge;
}

int rt_slurp(const char *path, char **pbuf, size_t *pn, rt_err *e)
{
    FILE *f = fopen(path, "rb");
    if (!f) return rt_errf(e, "%s: %s", path, strerror(errno));
    char *buf;
    size_t n;
    int bad, rc = read_stream(f, 1 << 16, UINT64_MAX, &buf, &n, &bad, e);
    fclose(f);
    if (rc < 0) return -1;
    if (rc > 0 || bad) {
        free(buf);
        return rc > 0 ? rt_errf(e, "%s: file too large", path) : rt_errf(e, "%s: read error", path);
    }
    *pbuf = buf;
    *pn = n;
    return 0;
}

const char *rt_esc(char *buf, size_t n, const char *s, size_t max)
{
    static const char hex[] = "0123456789abcdef";
    size_t k = 0;
    if (n == 0) return buf;
    for (size_t i = 0; i < max && s[i]; i++) {
        unsigned char c = (unsigned char)s[i];
        int plain = c >= 0x20 && c < 0x7f;
        size_t need = plain ? 1 : 4;
        if (k + need + 4 > n) { /* room for "..." and the NUL */
            memcpy(buf + k, "...", 3);
            k += 3;
            break;
        }
        if (plain) buf[k++] = (char)c;
        else {
            buf[k++] = '\\';
            buf[k++] = 'x';
            buf[k++] = hex[c >> 4];
            buf[k++] = hex[c & 15];
        }
    }
    buf[k] = 0;
    return buf;
}

/* sin and cos of r radians, |r| <= pi/4, by Taylor series to degree 19/18
 * (truncation error < 1e-19, below double rounding). Horner form. */
static void sincos_small(double r, double *s, double *c)
{
    double r2 = r * r;
    double ps = 1.0 / 121645100408832000.0; /* 1/19! */
    ps = 1.0 / 355687428096000.0 - r2 * ps;  /* 1/17! */
    ps = 1.0 / 1307674368000.0 - r2 * ps;    /* 1/15! */
    ps = 1.0 / 6227020800.0 - r2 * ps;       /* 1/13! */
    ps = 1.0 / 39916800.0 - r2 * ps;         /* 1/11! */
    ps = 1.0 / 362880.0 - r2 * ps;           /* 1/9! */
    ps = 1.0 / 5040.0 - r2 * ps;             /* 1/7! */
    ps = 1.0 / 120.0 - r2 * ps;              /* 1/5! */
    ps = 1.0 / 6.0 - r2 * ps;                /* 1/3! */
    *s = r - r * r2 * ps;
    double pc = 1.0 / 6402373705728000.0; /* 1/18! */
    pc = 1.0 / 20922789888000.0 - r2 * pc; /* 1/16! */
    pc = 1.0 / 87178291200.0 - r2 * pc;    /* 1/14! */
    pc = 1.0 / 479001600.0 - r2 * pc;      /* 1/12! */
    pc = 1.0 / 3628800.0 - r2 * pc;        /* 1/10! */
    pc = 1.0 / 40320.0 - r2 * pc;          /* 1/8! */
    pc = 1.0 / 720.0 - r2 * pc;            /* 1/6! */
    pc = 1.0 / 24.0 - r2 * pc;             /* 1/4! */
    pc = 0.5 - r2 * pc;                    /* 1/2! */
    *c = 1.0 - r2 * pc;
}

void rt_dsincos_deg(double deg, double *s, double *c)
{
    /* Reduce in degrees (exact for the angles the generators use) to the
     * nearest multiple q of 90, after whole turns. fmod is exact (the
     * remainder of two doubles is a double), defined for every finite
     * angle, and equals deg - 360 trunc(deg / 360) wherever that
     * expression was exact, so angles below 2^53 degrees reduce as they
     * did; a non-finite angle gives NaN sine and cosine. */
    if (!isfinite(deg)) {
        *s = *c = NAN;
        return;
    }
    deg = fmod(deg, 360.0);
    if (deg < 0) deg += 360.0;
    if (deg >= 360.0) deg = 0; /* -tiny + 360 rounds to 360 */
    int q = (int)((deg + 45.0) / 90.0);
    double r = (deg - 90.0 * q) * (3.14159265358979323846 / 180.0);
    double ss, cc;
    sincos_small(r, &ss, &cc);
    switch (q & 3) {
    case 0: *s = ss; *c = cc; break;
    case 1: *s = cc; *c = -ss; break;
    case 2: *s = -ss; *c = -cc; break;
    default: *s = -cc; *c = ss; break;
    }
}

/* ---- scene files ----------------------------------------------------------- */

static const char *file_kind(mode_t m)
{
    if (S_ISDIR(m)) return "a directory";
    if (S_ISCHR(m)) return "a character device";
    if (S_ISBLK(m)) return "a block device";
    if (S_ISFIFO(m)) return "a FIFO";
    if (S_ISSOCK(m)) return "a socket";
    return "not a regular file";
}

FILE *rt_open_regular(const char *path, uint64_t max_bytes, rt_err *e)
{
    char q[300];
    rt_esc(q, sizeof q, path, 4096);
    /* O_NONBLOCK: opening a FIFO for reading would otherwise wait for a
     * writer for ever; O_NOCTTY: a terminal never becomes ours */
    int fd = open(path, O_RDONLY | O_NONBLOCK | O_NOCTTY | O_CLOEXEC);
    if (fd < 0) {
        int err = errno;
        rt_errf(e, "%s: %s", q, strerror(err));
        errno = err;
        return NULL;
    }
    struct stat sb;
    int err = 0;
    if (fstat(fd, &sb) < 0) {
        err = errno;
        rt_errf(e, "%s: %s", q, strerror(err));
    } else if (!S_ISREG(sb.st_mode)) {
        err = EINVAL;
        rt_errf(e, "%s: not a regular file (%s)", q, file_kind(sb.st_mode));
    } else if ((uint64_t)sb.st_size > max_bytes) {
        err = EFBIG;
        rt_errf(e, "%s: %llu bytes is larger than the limit of %llu bytes (RT_SCENE_MAX_BYTES)", q,
                (unsigned long long)sb.st_size, (unsigned long long)max_bytes);
    } else {
        int fl = fcntl(fd, F_GETFL);
        if (fl < 0 || fcntl(fd, F_SETFL, fl & ~O_NONBLOCK) < 0) {
            err = errno;
            rt_errf(e, "%s: %s", q, strerror(err));
        }
    }
    FILE *f = err ? NULL : fdopen(fd, "rb");
    if (!f && !err) {
        err = errno;
        rt_errf(e, "%s: %s", q, strerror(err));
    }
    if (!f) {
        close(fd);
        errno = err;
    }
    return f;
}

int rt_slurp_regular(const char *path, uint64_t max_bytes, char **pbuf, size_t *pn, rt_err *e)
{
    FILE *f = rt_open_regular(path, max_bytes, e);
    if (!f) return -1;
    char q[300];
    rt_esc(q, sizeof q, path, 4096);
    struct stat sb;
    size_t cap = 1 << 16, n;
    /* the size fstat saw, plus room to notice growth */
    if (fstat(fileno(f), &sb) == 0 && (uint64_t)sb.st_size < SIZE_MAX - 2) cap = (size_t)sb.st_size + 2;
    char *buf;
    int bad, rc = read_stream(f, cap, max_bytes, &buf, &n, &bad, e);
    fclose(f);
    if (rc < 0) return -1;
    if (bad || rc > 0 || (uint64_t)n > max_bytes) {
        free(buf);
        errno = bad ? EIO : EFBIG;
        if (bad) return rt_errf(e, "%s: read error", q);
        return rt_errf(e, "%s: grew past the limit of %llu bytes while read (RT_SCENE_MAX_BYTES)", q,
                       (unsigned long long)max_bytes);
    }
    *pbuf = buf;
    *pn = n;
    return 0;
}

const char *rt_path_dir(const char *path, char *out, size_t n)
{
    const char *slash = strrchr(path, '/');
    size_t dl = slash ? (size_t)(slash - path) + 1 : 0;
    if (n == 0) return out;
    if (dl >= n) dl = 0;
    memcpy(out, path, dl);
    out[dl] = 0;
    return out;
}

int rt_path_within(const char *base_dir, const char *rel, char *out, size_t n, rt_err *e)
{
    char q[200];
    rt_esc(q, sizeof q, rel, 4096);
    if (!rel[0]) return rt_errf(e, "'': empty name");
    if (rel[0] == '/') return rt_errf(e, "'%s': absolute path (a file a scene names must be inside its folder)", q);
    long depth = 0;
    for (const char *p = rel; *p;) {
        const char *s = strchr(p, '/');
        size_t len = s ? (size_t)(s - p) : strlen(p);
        if (len == 2 && p[0] == '.' && p[1] == '.') {
            if (--depth < 0)
                return rt_errf(e, "'%s': leaves the folder of the file naming it (no '..' above that folder)", q);
        } else if (len && !(len == 1 && p[0] == '.')) {
            depth++;
        }
        p += len;
        if (*p == '/') p++;
    }
    if (depth == 0) return rt_errf(e, "'%s': names the folder itself, not a file", q);
    size_t bl = strlen(base_dir), rl = strlen(rel);
    if (bl + rl + 1 > n) return rt_errf(e, "'%s': path too long", q);
    memcpy(out, base_dir, bl);
    memcpy(out + bl, rel, rl + 1);
    return 0;
}

const char *rt_name_fit(char *buf, size_t n, const char *name)
{
    size_t len = strlen(name);
    if (len < n) {
        memcpy(buf, name, len + 1);
        return buf;
    }
    if (n < 24) {
        if (n) buf[0] = 0;
        return buf;
    }
    size_t keep = n - 18; /* '~', 16 digits, NUL */
    memcpy(buf, name, keep);
    snprintf(buf + keep, 18, "~%016llx", (unsigned long long)rt_fnv1a(RT_FNV_INIT, name, len));
    return buf;
}

uint64_t rt_phys_memory(void)
{
    long pages = sysconf(_SC_PHYS_PAGES), page = sysconf(_SC_PAGESIZE);
    if (pages <= 0 || page <= 0) return 0;
    return (uint64_t)pages * (uint64_t)page;
}

int rt_mem_fits(uint64_t bytes, const char *what, rt_err *e)
{
    uint64_t phys = rt_phys_memory();
    if (!phys || bytes <= phys) return 0;
    return rt_errf(e, "%s needs %.0f MB, more than the %.0f MB of memory this machine has", what,
                   (double)bytes / 1048576.0, (double)phys / 1048576.0);
}

void *rt_calloc_aligned(size_t n, size_t size, size_t align, rt_err *e)
{
    if (size && n > SIZE_MAX / size) {
        rt_errf(e, "allocation of %zu x %zu bytes overflows", n, size);
        return NULL;
    }
    const size_t bytes = (n ? n : 1) * (size ? size : 1);
    void *p = NULL;
    if (alloc_should_fail() || posix_memalign(&p, align, bytes) != 0) p = NULL;
    if (!p) {
        rt_errf(e, "out of memory allocating %zu bytes", bytes);
        return NULL;
    }
    memset(p, 0, bytes);
    return p;
}
