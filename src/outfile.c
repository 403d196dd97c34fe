/*
 * outfile.c -- safe output files: complete or absent, never half-written.
 *
 * A careless `-o` can name anything, and two runs can name the same file.
 * The rules, applied by rt_out_open to the path it is given:
 *
 *   1. A symlink is followed (up to 40 levels) and the rules apply to what
 *      it points at; the link itself stays a link.
 *   2. A directory is an error ("PATH: is a directory").
 *   3. An existing non-regular file (character device, FIFO, socket) is
 *      written in place: `-o /dev/null` must not replace /dev/null with a
 *      regular file, and `-o /dev/stdout` or a FIFO is a stream.
 *   4. A regular or missing file gets a unique temporary in the same folder
 *      (".NAME.XXXXXX" from mkstemp, i.e. O_EXCL), so the final rename is
 *      atomic and two writers never share a temporary: the last rename wins
 *      and the target is always one writer's complete output.
 *   5. rt_out_commit does fflush, fsync (regular files only: devices refuse
 *      it), a checked fclose, then rename. A write error anywhere, reported
 *      late by fflush/fclose (ENOSPC, EIO) or early by fwrite, fails the
 *      commit; every failure path removes the temporary. The temporary gets
 *      the target's mode if it existed, else 0666 & ~umask, as fopen would.
 *
 * Temporaries still open are listed in a small lock-free table so a signal
 * handler can unlink them (rt_out_remove_temporaries). The fault hook
 * rt_out_fail_after wraps the stream in a cookie (glibc's fopencookie) that
 * fails with ENOSPC after N bytes; it costs nothing when disabled.
 */
#define _GNU_SOURCE
#include "outfile.h"

#include <errno.h>
#include <limits.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/types.h>
#include <fcntl.h>
#include <unistd.h>

long long rt_out_fail_after = -1;

struct rt_out {
    FILE *f;          /* stream being written */
    int fd;           /* its descriptor (for fsync) */
    char *path;       /* as given, for messages */
    char *target;     /* after following symlinks: what the rename replaces */
    char *tmp;        /* temporary beside target, or NULL when in place */
    int slot;         /* index in live[], or -1 */
    int werr;         /* errno of the first failed write, if the fault hook saw it */
};

/* ---- temporaries a signal handler may remove ------------------------------- */

#define NLIVE 64
static _Atomic(char *) live[NLIVE];

static int live_add(char *tmp)
{
    for (int i = 0; i < NLIVE; i++) {
        char *expect = NULL;
        if (atomic_compare_exchange_strong(&live[i], &expect, tmp)) return i;
    }
    return -1; /* table full: the file is still removed on every error path */
}

static void live_del(int slot)
{
    if (slot >= 0) atomic_store(&live[slot], NULL);
}

void rt_out_remove_temporaries(void)
{
    for (int i = 0; i < NLIVE; i++) {
        char *p = atomic_load(&live[i]);
        if (p) unlink(p);
    }
}

/* ---- fault injection ---------------------------------------------------------- */

typedef struct fail_cookie {
    int fd;
    long long left; /* bytes still allowed */
    int *werr;      /* rt_out.werr */
} fail_cookie;

static ssize_t fc_write(void *c, const char *buf, size_t n)
{
    fail_cookie *k = c;
    if (k->left <= 0) {
        errno = *k->werr = ENOSPC;
        return -1;
    }
    size_t m = (long long)n > k->left ? (size_t)k->left : n;
    size_t done = 0;
    while (done < m) {
        ssize_t r = write(k->fd, buf + done, m - done);
        if (r < 0) {
            if (errno == EINTR) continue;
            return done ? (ssize_t)done : -1;
        }
        done += (size_t)r;
    }
    k->left -= (long long)done;
    if (done < n) *k->werr = ENOSPC; /* glibc takes a short cookie write as the error */
    return (ssize_t)done;
}

static int fc_close(void *c)
{
    fail_cookie *k = c;
    int rc = close(k->fd);
    free(k);
    return rc;
}

static FILE *open_stream(int fd, int *werr)
{
    if (rt_out_fail_after < 0) return fdopen(fd, "wb");
    fail_cookie *k = malloc(sizeof *k);
    if (!k) return NULL;
    k->fd = fd;
    k->left = rt_out_fail_after;
    k->werr = werr;
    cookie_io_functions_t io = {NULL, fc_write, NULL, fc_close};
    FILE *f = fopencookie(k, "wb", io);
    if (!f) free(k);
    return f;
}

/* ---- paths ----------------------------------------------------------------------- */

static char *dupstr(const char *s, rt_err *e)
{
    size_t n = strlen(s) + 1;
    char *p = rt_calloc(n, 1, e);
    if (p) memcpy(p, s, n);
    return p;
}

/* Length of the folder part of p including its last '/', 0 if none. */
static size_t dir_len(const char *p)
{
    const char *s = strrchr(p, '/');
    return s ? (size_t)(s - p) + 1 : 0;
}

/* Follows symlinks from path; returns the final path (malloc'd) and its
 * lstat in *st (st_mode 0 when it does not exist). NULL on error. */
static char *resolve(const char *path, struct stat *st, rt_err *e)
{
    char *p = dupstr(path, e);
    for (int depth = 0; p; depth++) {
        if (lstat(p, st) != 0) {
            if (errno != ENOENT) {
                rt_errf(e, "%s: %s", path, strerror(errno));
                break;
            }
            st->st_mode = 0;
            return p;
        }
        if (!S_ISLNK(st->st_mode)) return p;
        if (depth == 40) {
            rt_errf(e, "%s: too many levels of symbolic links", path);
            break;
        }
        char link[PATH_MAX];
        ssize_t n = readlink(p, link, sizeof link - 1);
        if (n < 0) {
            rt_errf(e, "%s: %s", path, strerror(errno));
            break;
        }
        link[n] = 0;
        size_t d = link[0] == '/' ? 0 : dir_len(p);
        char *q = rt_calloc(d + (size_t)n + 1, 1, e);
        if (!q) break;
        memcpy(q, p, d);
        memcpy(q + d, link, (size_t)n + 1);
        free(p);
        p = q;
    }
    free(p);
    return NULL;
}

static mode_t default_mode(void)
{
    mode_t m = umask(022);
    umask(m);
    return 0666 & ~m;
}

rt_out *rt_out_open(const char *path, rt_err *e)
{
    if (!path || !*path) return rt_errf(e, "empty output path"), NULL;
    rt_out *o = rt_calloc(1, sizeof *o, e);
    if (!o) return NULL;
    o->fd = -1;
    o->slot = -1;
    struct stat st;
    if (!(o->path = dupstr(path, e)) || !(o->target = resolve(path, &st, e))) goto fail;
    if (S_ISDIR(st.st_mode)) {
        rt_errf(e, "%s: is a directory", path);
        goto fail;
    }
    if (st.st_mode != 0 && !S_ISREG(st.st_mode)) {
        /* device, FIFO, socket: write in place */
        if ((o->fd = open(o->target, O_WRONLY | O_CLOEXEC)) < 0) {
            rt_errf(e, "%s: %s", path, strerror(errno));
            goto fail;
        }
    } else {
        size_t d = dir_len(o->target);
        const char *base = o->target + d;
        if (!(o->tmp = rt_calloc(d + strlen(base) + 9, 1, e))) goto fail;
        memcpy(o->tmp, o->target, d);
        sprintf(o->tmp + d, ".%s.XXXXXX", base);
        if ((o->fd = mkstemp(o->tmp)) < 0) {
            rt_errf(e, "%s: cannot create a temporary beside it: %s", path, strerror(errno));
            free(o->tmp);
            o->tmp = NULL;
            goto fail;
        }
        o->slot = live_add(o->tmp);
        mode_t mode = st.st_mode ? (st.st_mode & 07777) : default_mode();
        if (fchmod(o->fd, mode) != 0) {
            rt_errf(e, "%s: %s", o->tmp, strerror(errno));
            goto fail;
        }
    }
    if (!(o->f = open_stream(o->fd, &o->werr))) {
        rt_errf(e, "%s: %s", path, strerror(errno));
        goto fail;
    }
    return o;
fail:
    rt_out_abort(o);
    return NULL;
}

FILE *rt_out_stream(rt_out *o) { return o->f; }
const char *rt_out_path(const rt_out *o) { return o->path; }

static void out_free(rt_out *o)
{
    live_del(o->slot);
    free(o->path);
    free(o->target);
    free(o->tmp);
    free(o);
}

void rt_out_abort(rt_out *o)
{
    if (!o) return;
    if (o->f) fclose(o->f);
    else if (o->fd >= 0) close(o->fd);
    if (o->tmp) unlink(o->tmp);
    out_free(o);
}

int rt_out_write(rt_out *o, const void *p, size_t n)
{
    errno = 0;
    if (fwrite(p, 1, n, o->f) == n) return 0;
    if (!o->werr) o->werr = errno ? errno : EIO;
    return -1;
}

int rt_out_commit(rt_out *o, rt_err *e)
{
    if (!o) return rt_errf(e, "rt_out_commit: no output");
    int bad = ferror(o->f), err = 0;
    errno = 0;
    if (fflush(o->f) != 0 || bad) err = o->werr ? o->werr : errno ? errno : EIO;
    else if (o->tmp && fsync(o->fd) != 0) err = errno;
    FILE *f = o->f;
    o->f = NULL;
    o->fd = -1;
    if (fclose(f) != 0 && !err) err = errno;
    if (err) {
        rt_errf(e, "%s: write failed: %s", o->path, strerror(err));
        rt_out_abort(o);
        return -1;
    }
    if (o->tmp && rename(o->tmp, o->target) != 0) {
        rt_errf(e, "%s: cannot rename %s over it: %s", o->path, o->tmp, strerror(errno));
        rt_out_abort(o);
        return -1;
    }
    out_free(o);
    return 0;
}

int rt_out_probe(const char *path, rt_err *e)
{
    rt_out *o = rt_out_open(path, e);
    if (!o) return -1;
    rt_out_abort(o);
    return 0;
}
