/*
 * fuzz.h -- what the fuzz harnesses share: the input as a file, and a
 * standalone main for AFL++ and for replaying corpora.
 *
 * Every harness defines LLVMFuzzerTestOneInput(data, size), the libFuzzer
 * entry point. The loaders under test read paths, not buffers, so
 * rt_fuzz_file() writes the input into one scratch file per process (a
 * memfd on Linux: nothing is left behind when a run is killed) and returns
 * its path. The harnesses check the readers' contracts, not just the
 * absence of crashes, and call rt_fuzz_fail() (abort) when one is broken,
 * so libFuzzer and AFL++ record the input as a crash.
 *
 * Built with -DRT_FUZZ_MAIN, a harness gets its own main: each argument is
 * a file (a directory: each file in it) that is run through
 * LLVMFuzzerTestOneInput; without arguments stdin is read, which is what
 * afl-fuzz feeds. Each file's verdict is printed to stdout, "PATH:
 * accepted" or "PATH: refused". tests/fuzz_replay.sh uses it to replay the corpora and
 * the regression inputs in `make check`.
 */
#ifndef RT_FUZZ_H
#define RT_FUZZ_H

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include <fcntl.h>
#include <sys/types.h>
#include <sys/stat.h>
#if defined(__linux__)
#include <sys/syscall.h>
#endif

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

/* Set by a harness when the input was read to its verified end (accepted)
 * rather than refused; the standalone main reports it per file. */
static int rt_fuzz_accepted;

/* Reports a broken contract and aborts, so the fuzzer keeps the input. */
#define rt_fuzz_fail(...)                                                       \
    do {                                                                        \
        fprintf(stderr, "%s:%d: contract broken: ", __FILE__, __LINE__);       \
        fprintf(stderr, __VA_ARGS__);                                           \
        fputc('\n', stderr);                                                    \
        abort();                                                                \
    } while (0)

/* Writes data into the process's scratch file and returns its path, or
 * aborts (no input can be tested without it). */
static inline const char *rt_fuzz_file(const uint8_t *data, size_t size)
{
    static int fd = -1;
    static char path[4096];
    if (fd < 0) {
#if defined(__linux__) && defined(SYS_memfd_create)
        fd = (int)syscall(SYS_memfd_create, "rt_fuzz", 0);
        if (fd >= 0) snprintf(path, sizeof path, "/proc/self/fd/%d", fd);
#endif
        if (fd < 0) {
            const char *dir = getenv("TMPDIR");
            snprintf(path, sizeof path, "%s/rt_fuzz.XXXXXX", dir && *dir ? dir : "/tmp");
            fd = mkstemp(path);
        }
        if (fd < 0) rt_fuzz_fail("cannot create the scratch file");
    }
    if (ftruncate(fd, 0) < 0) rt_fuzz_fail("ftruncate failed");
    size_t done = 0;
    while (done < size) {
        ssize_t w = pwrite(fd, data + done, size - done, (off_t)done);
        if (w <= 0) rt_fuzz_fail("write failed");
        done += (size_t)w;
    }
    return path;
}

#ifdef RT_FUZZ_MAIN
#include <dirent.h>

static int rt_fuzz_run_file(const char *path)
{
    FILE *f = strcmp(path, "-") ? fopen(path, "rb") : stdin;
    if (!f) {
        perror(path);
        return -1;
    }
    size_t n = 0, cap = 4096;
    uint8_t *buf = malloc(cap);
    for (size_t got; buf && (got = fread(buf + n, 1, cap - n, f)) > 0;) {
        n += got;
        if (n == cap) {
            uint8_t *nb = realloc(buf, cap *= 2);
            if (!nb) free(buf);
            buf = nb;
        }
    }
    int bad = !buf || ferror(f);
    if (f != stdin) fclose(f);
    if (bad) {
        fprintf(stderr, "%s: read failed\n", path);
        free(buf);
        return -1;
    }
    rt_fuzz_accepted = 0;
    LLVMFuzzerTestOneInput(buf, n);
    printf("%s: %s\n", path, rt_fuzz_accepted ? "accepted" : "refused");
    free(buf);
    return 0;
}

int main(int argc, char **argv)
{
    int rc = 0, runs = 0;
    if (argc < 2) return rt_fuzz_run_file("-") < 0;
    for (int i = 1; i < argc; i++) {
        struct stat st;
        if (stat(argv[i], &st) == 0 && S_ISDIR(st.st_mode)) {
            DIR *d = opendir(argv[i]);
            struct dirent *de;
            while (d && (de = readdir(d))) {
                if (de->d_name[0] == '.') continue;
                char p[4096];
                snprintf(p, sizeof p, "%s/%s", argv[i], de->d_name);
                if (rt_fuzz_run_file(p) < 0) rc = 1;
                runs++;
            }
            if (d) closedir(d);
        } else {
            if (rt_fuzz_run_file(argv[i]) < 0) rc = 1;
            runs++;
        }
    }
    fprintf(stderr, "%s: %d inputs run\n", argv[0], runs);
    return rc;
}
#endif

#endif
