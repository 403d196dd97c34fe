/*
 * check.h -- what every test program shares, so that each one holds only
 * its tests: the CHECK macro, the random numbers the randomized tests draw,
 * a private temporary directory, a tolerance compare and the test tier.
 *
 * CHECK(cond, fmt, ...) prints "file:line: FAIL cond: message" and counts
 * the failure in `failures`; after CHECK_MAX_FAILURES the program exits 1,
 * so a broken invariant checked in a loop does not flood the log. A test's
 * main ends with `return failures ? 1 : 0;` (exit 0 = pass, 1 = fail, the
 * automake convention; 77 would mean "skipped" and is never used: a test
 * that cannot run its checks fails).
 *
 * Tiers: `make check` is the quick tier; `make check-long` sets
 * RT_TEST_LONG=1 and the tests that scale (check_long()) run at full size.
 * Quick sizes still compare real values, only fewer of them.
 *
 * Everything here is static inline (or a macro) so a test that does not use
 * a helper gets no unused-function warning.
 */
#ifndef RT_CHECK_H
#define RT_CHECK_H

#include "rt_math.h"

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <errno.h>
#include <fcntl.h>
#include <dirent.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#define CHECK_MAX_FAILURES 20

static int failures;

#define CHECK(cond, ...)                                                                                   \
    do {                                                                                                   \
        if (!(cond)) {                                                                                     \
            fprintf(stderr, "%s:%d: FAIL %s: ", __FILE__, __LINE__, #cond);                                \
            fprintf(stderr, __VA_ARGS__);                                                                  \
            fputc('\n', stderr);                                                                           \
            if (++failures >= CHECK_MAX_FAILURES) {                                                        \
                fprintf(stderr, "%s: stopping after %d failures\n", __FILE__, failures);                   \
                exit(1);                                                                                   \
            }                                                                                              \
        }                                                                                                  \
    } while (0)

/* 1 when the long tier runs (RT_TEST_LONG set and not "0"). */
static inline int check_long(void)
{
    const char *v = getenv("RT_TEST_LONG");
    return v && *v && strcmp(v, "0") != 0;
}

/* ---- random numbers: splitmix64, reseeded by each test that needs a
 * reproducible stream ---------------------------------------------------- */

static uint64_t check_rng_state = 0x9e3779b97f4a7c15ULL;

static inline void rnd_seed(uint64_t s) { check_rng_state = s; }

static inline uint64_t rnd64(void)
{
    uint64_t z = (check_rng_state += 0x9e3779b97f4a7c15ULL);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
}

/* Uniform in [0, 1) with 53 bits. */
static inline double unif(void) { return (double)(rnd64() >> 11) * (1.0 / 9007199254740992.0); }

/* Uniform in [a, b). */
static inline float uf(float a, float b) { return (float)(a + (b - a) * unif()); }

/* A uniformly distributed unit vector (rejection from the cube). */
static inline rt_vec3 rand_dir(void)
{
    for (;;) {
        rt_vec3 v = rt_v3(uf(-1, 1), uf(-1, 1), uf(-1, 1));
        float l = rt_dot(v, v);
        if (l > 1e-4f && l <= 1.0f) return rt_mul(v, 1.0f / sqrtf(l));
    }
}

/* ---- floats ------------------------------------------------------------- */

/* |got - want| <= abs_tol + rel_tol * |want|. */
static inline int check_near(double got, double want, double rel_tol, double abs_tol)
{
    return fabs(got - want) <= abs_tol + rel_tol * fabs(want);
}

/* ---- temporary files ----------------------------------------------------- */

static char check_dir[256];

/* Creates a private directory under $TMPDIR (default /tmp) named after the
 * test; returns its path, or NULL (errno set). */
static inline const char *check_tmpdir(const char *test)
{
    const char *t = getenv("TMPDIR");
    snprintf(check_dir, sizeof check_dir, "%s/rt_%s_XXXXXX", t && *t ? t : "/tmp", test);
    return mkdtemp(check_dir);
}

/* check_dir/name in one of eight rotating buffers (so a few can be live at
 * once, e.g. a path and its ".tmp"). */
static inline char *check_path(const char *name)
{
    static char buf[8][512];
    static int k;
    char *p = buf[k++ & 7];
    snprintf(p, sizeof buf[0], "%s/%s", check_dir, name);
    return p;
}

/* Writes n bytes of data to path (created or truncated); exits on
 * failure (a test that cannot write its input cannot check anything). */
static inline void check_write_file(const char *path, const void *data, size_t n)
{
    FILE *f = fopen(path, "wb");
    if (!f || fwrite(data, 1, n, f) != n || fclose(f) != 0) {
        perror(path);
        exit(1);
    }
}

/* Removes dir and everything in it, without a shell (depth first, links
 * removed, not followed). 0, or -1 if something could not be removed. */
static inline int check_rm_tree(const char *dir)
{
    struct stat st;
    if (lstat(dir, &st) != 0) return -1;
    if (!S_ISDIR(st.st_mode)) return unlink(dir) == 0 ? 0 : -1;
    DIR *d = opendir(dir);
    if (!d) return -1;
    int rc = 0;
    struct dirent *de;
    while ((de = readdir(d))) {
        if (!strcmp(de->d_name, ".") || !strcmp(de->d_name, "..")) continue;
        char sub[4096];
        if ((size_t)snprintf(sub, sizeof sub, "%s/%s", dir, de->d_name) >= sizeof sub || check_rm_tree(sub) != 0)
            rc = -1;
    }
    closedir(d);
    return rmdir(dir) == 0 ? rc : -1;
}

/* Removes the directory made by check_tmpdir and everything in it. */
static inline void check_rmdir(void)
{
    if (check_dir[0] && check_rm_tree(check_dir) != 0) fprintf(stderr, "could not remove %s\n", check_dir);
}

/* Runs argv (argv[0] looked up by execvp, never through a shell) with
 * stdout and stderr sent to the files out and err (NULL = /dev/null);
 * returns the wait status, or -1 if it could not be started. */
static inline int check_run(char *const argv[], const char *out, const char *err)
{
    fflush(NULL);
    pid_t pid = fork();
    if (pid < 0) return -1;
    if (pid == 0) {
        int fo = open(out ? out : "/dev/null", O_WRONLY | O_CREAT | O_TRUNC, 0644);
        int fe = err && out && !strcmp(err, out) ? fo : open(err ? err : "/dev/null", O_WRONLY | O_CREAT | O_TRUNC, 0644);
        if (fo < 0 || fe < 0 || dup2(fo, 1) < 0 || dup2(fe, 2) < 0) _exit(126);
        execvp(argv[0], argv);
        _exit(127);
    }
    int status;
    while (waitpid(pid, &status, 0) < 0)
        if (errno != EINTR) return -1;
    return status;
}

#endif
