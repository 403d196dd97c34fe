/*
 * outfile.c -- safe output files: complete or absent, never half-written.
 *
 * A careless `-o` can name anything, and two runs can name the same file.
 * The rules, applied by rt_out_open to the path it is given (1-3 are
 * rt_open_target's, which databases go through too):
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
 *      and the target is always one writer's complete output. The writer
 *      holds an exclusive flock on its temporary until commit or abort, so
 *      a temporary left by a killed process (kill -9 runs no handler) is
 *      told from a live one: rt_out_remove_stale removes the former only.
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
#include <dirent.h>
#include <sys/file.h>
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

/* 1 if descriptor fd is still the file named path (not unlinked, not
 * replaced). */
static int same_file(int fd, const char *path)
{
    struct stat a, b;
    return fstat(fd, &a) == 0 && lstat(path, &b) == 0 && a.st_dev == b.st_dev && a.st_ino == b.st_ino;
}

/* mkstemp on tmp (ending in XXXXXX; close-on-exec) holding
 * an exclusive flock for as long as the descriptor is open: the mark of a
 * live temporary for rt_out_remove_stale. A stale-temporary remover may
 * take a new file's lock first and unlink it; then the name no longer
 * names our file, and a new one is made. The descriptor, or -1 (errno). */
static int make_temporary(char *tmp)
{
    for (int tries = 0; tries < 100; tries++) {
        memcpy(tmp + strlen(tmp) - 6, "XXXXXX", 6);
        int fd = mkostemp(tmp, O_CLOEXEC);
        if (fd < 0) return -1;
        if (flock(fd, LOCK_EX | LOCK_NB) == 0 && same_file(fd, tmp)) return fd;
        if (errno == ENOLCK || errno == EINVAL) return fd; /* no locks here: a remover cannot lock either */
        close(fd);
    }
    errno = EEXIST;
    return -1;
}

static const char *kind_name(mode_t m)
{
    return S_ISFIFO(m) ? "a FIFO" : S_ISCHR(m) ? "a character device" : S_ISBLK(m) ? "a block device"
         : S_ISSOCK(m) ? "a socket" : "not a regular file";
}

/* rt_open_target's rule; *target (malloc'd, symlinks followed) and *st
 * (st_mode 0 when absent) for rt_out_open when target is non-NULL. */
static int classify(const char *path, int kind, char **target, struct stat *st, rt_err *e)
{
    const int db = kind == RT_TARGET_DB || kind == RT_TARGET_DB_READ;
    if (!path || !*path)
        return db ? rt_errf_usage(e, "empty database name: SQLite would keep it in a temporary file")
                  : rt_errf_usage(e, "empty output path");
    if (db && path[0] == ':')
        return rt_errf_usage(e, "'%s' is not a file name: SQLite keeps such a database in memory, nothing would be "
                                "stored (for a file of that name write ./%s)", path, path);
    char *t = resolve(path, st, e);
    if (!t) return -1;
    int rc = -1;
    if (S_ISDIR(st->st_mode)) {
        rt_errf(e, "%s: is a directory", path);
    } else if (st->st_mode == 0) {
        if (kind == RT_TARGET_DB_READ) {
            rt_errf(e, "%s: %s", path, strerror(ENOENT));
        } else if (kind == RT_TARGET_DB) {
            /* SQLite creates the file: its folder must exist (and be one) */
            size_t d = dir_len(t);
            char *dir = rt_calloc(d + 2, 1, e);
            struct stat ds;
            if (dir) {
                memcpy(dir, d ? t : ".", d ? d : 1);
                if (stat(dir, &ds) != 0) rt_errf(e, "%s: %s", path, strerror(errno));
                else if (!S_ISDIR(ds.st_mode)) rt_errf(e, "%s: %s", path, strerror(ENOTDIR));
                else rc = RT_TARGET_ABSENT;
                free(dir);
            }
        } else {
            rc = RT_TARGET_ABSENT;
        }
    } else if (S_ISREG(st->st_mode)) {
        rc = RT_TARGET_REGULAR;
    } else if (db) {
        rt_errf(e, "%s: is %s, not a regular file%s", path, kind_name(st->st_mode),
                kind == RT_TARGET_DB ? ": a database must be a regular file (or absent, to create it)" : "");
    } else {
        rc = RT_TARGET_STREAM;
    }
    if (rc >= 0 && target) *target = t;
    else free(t);
    return rc;
}

int rt_open_target(const char *path, int kind, rt_err *e)
{
    struct stat st;
    return classify(path, kind, NULL, &st, e);
}

rt_out *rt_out_open(const char *path, rt_err *e)
{
    rt_out *o = rt_calloc(1, sizeof *o, e);
    if (!o) return NULL;
    o->fd = -1;
    o->slot = -1;
    struct stat st;
    int kind;
    if (!(o->path = dupstr(path ? path : "", e)) || (kind = classify(path, RT_TARGET_OUTPUT, &o->target, &st, e)) < 0)
        goto fail;
    if (kind == RT_TARGET_STREAM) {
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
        if ((o->fd = make_temporary(o->tmp)) < 0) {
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

/* ---- temporaries of dead writers -------------------------------------------- */

/* 1 if c is one of mkstemp's six-character suffix letters. */
static int tmp_char(char c)
{
    return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9');
}

long rt_out_remove_stale(const char *dir, int (*match)(const char *name), rt_err *e)
{
    DIR *dp = opendir(dir);
    if (!dp) return rt_errf(e, "%s: %s", dir, strerror(errno));
    int dfd = dirfd(dp);
    long removed = 0;
    struct dirent *de;
    char name[NAME_MAX + 1];
    while ((de = readdir(dp))) {
        size_t n = strlen(de->d_name);
        /* ".NAME.XXXXXX": a dot, at least one byte of name, a dot, six */
        if (n < 9 || de->d_name[0] != '.' || de->d_name[n - 7] != '.') continue;
        int ok = 1;
        for (size_t k = n - 6; k < n; k++) ok &= tmp_char(de->d_name[k]);
        if (!ok) continue;
        memcpy(name, de->d_name + 1, n - 8);
        name[n - 8] = 0;
        if (!match(name)) continue;
        int fd = openat(dfd, de->d_name, O_RDONLY | O_NOFOLLOW | O_NONBLOCK | O_CLOEXEC);
        if (fd < 0) continue;
        struct stat a, b;
        /* a regular file nobody holds, still under that name */
        if (fstat(fd, &a) == 0 && S_ISREG(a.st_mode) && flock(fd, LOCK_EX | LOCK_NB) == 0 &&
            fstatat(dfd, de->d_name, &b, AT_SYMLINK_NOFOLLOW) == 0 && a.st_dev == b.st_dev && a.st_ino == b.st_ino &&
            unlinkat(dfd, de->d_name, 0) == 0)
            removed++;
        close(fd);
    }
    closedir(dp);
    return removed;
}
