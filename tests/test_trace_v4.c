/*
 * test_trace_v4.c -- trace format version 4: references of several
 * simulated cores in one stream, a core-switch record (tag 0x0f and the
 * core byte) before a reference whose core differs from the previous one's.
 *
 *   - round trip: random streams with random core runs (and generations),
 *     several chunk sizes and read buffers; every record and its core read
 *     back (rt_tr_read_cores), the metadata and version 4; rt_tr_read
 *     alone reads the same records;
 *   - the cost: a hand-counted stream, a switch costs 2 encoded bytes and
 *     a run of one core none, so a chunk's U is the single-core U plus 2 per
 *     switch (and one per chunk that starts on another core than 0);
 *   - one core writes versions 1-3 exactly as before (cores 0 and 1 give
 *     the same bytes), and cores above 256, or with side payloads, are refused;
 *   - corruption: every truncation and every header and footer bit and a
 *     sample of chunk bits rejected, naming file and byte; hand-made chunks
 *     with a switch to the current core, to a core >= the header's, two
 *     switches in a row and a switch at a chunk's end are each rejected
 *     with their message.
 */
#include "check.h"
#include "trace.h"
#include "trace_rec.h"

#include <zlib.h>

static void fill_meta(rt_tr_meta *m, unsigned cores, unsigned gens)
{
    memset(m, 0, sizeof *m);
    snprintf(m->tool_version, sizeof m->tool_version, "0.1.0");
    snprintf(m->git_rev, sizeof m->git_rev, "0123456789ab");
    snprintf(m->command, sizeof m->command, "raytraffic trace cornell --cores %u -o x.rtt", cores);
    snprintf(m->scene, sizeof m->scene, "cornell");
    snprintf(m->tracer, sizeof m->tracer, "recursive");
    m->W = m->H = 64;
    m->generations = gens;
    m->cores = cores;
    rt_mm_init(&m->layout);
    rt_mm_add(&m->layout, "kd.nodes", RT_CLS_NODE, 8, 1000, NULL);
    rt_mm_add(&m->layout, "rays", RT_CLS_RAY, 32, 4096, NULL);
}

/* n records in runs of one core (lengths 1..max_run), small deltas, random
 * classes and generations <= gens. */
static void stream(rt_access *a, uint8_t *core, size_t n, unsigned cores, unsigned gens, size_t max_run)
{
    size_t i = 0;
    uint64_t addr = RT_MM_BASE;
    while (i < n) {
        size_t run = 1 + (size_t)(rnd64() % max_run);
        uint8_t c = (uint8_t)(rnd64() % cores), g = (uint8_t)(gens ? rnd64() % (gens + 1) : 0);
        for (size_t k = 0; k < run && i < n; k++, i++) {
            memset(&a[i], 0, sizeof a[i]);
            addr += (uint64_t)((int64_t)(rnd64() % 2001) - 1000);
            a[i].addr = addr;
            a[i].size = (uint32_t)(8 << (rnd64() % 3));
            a[i].cls = (uint8_t)(rnd64() % RT_NCLASS);
            a[i].write = (uint8_t)(rnd64() % 4 == 0);
            a[i].gen = g;
            core[i] = c;
        }
    }
}

static int write_v4(const char *path, const rt_tr_meta *m, const rt_access *a, const uint8_t *core, size_t n,
                    uint32_t chunk, rt_err *e)
{
    rt_tr_wopts o = {6, chunk, NULL};
    rt_tr_writer *w = rt_tr_create_opts(path, m, &o, e);
    if (!w) return -1;
    size_t i = 0;
    while (i < n) { /* a core's run in pieces of varying size */
        size_t k = 1;
        while (i + k < n && core[i + k] == core[i] && k < 1 + rnd64() % 700) k++;
        if (rt_tr_put_core(w, core[i], a + i, k) < 0) {
            rt_errf(e, "%s", rt_tr_writer_error(w));
            rt_tr_abort(w);
            return -1;
        }
        i += k;
    }
    return rt_tr_finish(w, e);
}

/* Reads path whole; compares with a/core when given. Records read or -1. */
static long read_v4(const char *path, size_t cap, const rt_access *a, const uint8_t *core, size_t n, int *mis, rt_err *e)
{
    rt_tr_reader *r = rt_tr_open(path, e);
    if (!r) return -1;
    rt_access *buf = calloc(cap, sizeof *buf);
    uint8_t *cb = calloc(cap, 1);
    long total = 0, k;
    while ((k = rt_tr_read_cores(r, buf, cb, cap, e)) > 0) {
        for (long i = 0; a && i < k; i++) {
            size_t j = (size_t)total + (size_t)i;
            if (j >= n || buf[i].addr != a[j].addr || buf[i].size != a[j].size || buf[i].cls != a[j].cls ||
                buf[i].write != a[j].write || buf[i].gen != a[j].gen || cb[i] != core[j])
                *mis = 1;
        }
        total += k;
    }
    free(buf);
    free(cb);
    rt_tr_close(r);
    return k < 0 ? -1 : total;
}

static unsigned char *slurp(const char *p, size_t *n)
{
    FILE *f = fopen(p, "rb");
    if (!f) return NULL;
    fseek(f, 0, SEEK_END);
    long len = ftell(f);
    fseek(f, 0, SEEK_SET);
    unsigned char *b = malloc((size_t)len + 1);
    *n = fread(b, 1, (size_t)len, f);
    fclose(f);
    return b;
}

static void spit(const char *p, const unsigned char *b, size_t n)
{
    unlink(p);
    FILE *f = fopen(p, "wb");
    if (n) fwrite(b, 1, n, f);
    fclose(f);
}

static int rejected(const char *p, char *msg, size_t cap)
{
    rt_err e = {0};
    long got = read_v4(p, 4096, NULL, NULL, 0, NULL, &e);
    if (msg) snprintf(msg, cap, "%s", e.msg);
    return got == -1 && strstr(e.msg, p) && strstr(e.msg, "byte ");
}

static void test_round_trip(void)
{
    const size_t ns[] = {1, 2, 999, 65536, 70001};
    const uint32_t chunks[] = {1, 7, 4096, 65536};
    const unsigned cores[] = {2, 3, 64, 256};
    for (int t = 0; t < 5; t++)
        for (int c = 0; c < 4; c++) {
            size_t n = ns[t];
            if (chunks[c] == 1 && n > 1000) continue;
            unsigned nc = cores[(t + c) % 4], gens = (t + c) % 2 ? 3 : 0;
            rt_access *a = calloc(n, sizeof *a);
            uint8_t *core = calloc(n, 1);
            stream(a, core, n, nc, gens, c % 2 ? 3 : 300);
            rt_tr_meta m;
            fill_meta(&m, nc, gens);
            rt_err e = {0};
            const char *p = check_path("v4.rtt");
            CHECK(write_v4(p, &m, a, core, n, chunks[c], &e) == 0, "write n=%zu: %s", n, e.msg);
            const size_t caps[] = {1, 5, 4096};
            for (int q = 0; q < 3; q++) {
                if (caps[q] < 4096 && n > 1000) continue;
                int mis = 0;
                long got = read_v4(p, caps[q], a, core, n, &mis, &e);
                CHECK(got == (long)n && !mis, "v4 n=%zu chunk %u cores %u cap %zu: got %ld mismatch %d (%s)", n,
                      chunks[c], nc, caps[q], got, mis, e.msg);
            }
            rt_tr_reader *r = rt_tr_open(p, &e);
            CHECK(r && rt_tr_get_version(r) == 4 && rt_tr_get_meta(r)->cores == nc &&
                      rt_tr_get_meta(r)->generations == gens && !strcmp(rt_tr_get_meta(r)->command, m.command),
                  "v4 header: version %u cores %u", r ? rt_tr_get_version(r) : 0, r ? rt_tr_get_meta(r)->cores : 0);
            /* rt_tr_read reads the same records */
            rt_access *b = calloc(n, sizeof *b);
            long k = 0, got = 0;
            while (r && (k = rt_tr_read(r, b + got, n - (size_t)got + 1, &e)) > 0) got += k;
            int same = got == (long)n;
            for (size_t i = 0; same && i < n; i++) same = b[i].addr == a[i].addr && b[i].cls == a[i].cls;
            CHECK(same && k == 0, "rt_tr_read of a v4 trace: %ld of %zu", got, n);
            free(b);
            rt_tr_close(r);
            free(a);
            free(core);
        }
}

/* 2 bytes per switch: U of a v4 chunk against U of the same records on one core. */
static void test_cost(void)
{
    const size_t n = 1000;
    rt_access *a = calloc(n, sizeof *a);
    uint8_t *core = calloc(n, 1);
    stream(a, core, n, 4, 0, 10);
    size_t switches = 0;
    for (size_t i = 0; i < n; i++) switches += core[i] != (i ? core[i - 1] : 0);
    rt_tr_meta m1, m4;
    fill_meta(&m1, 1, 0);
    fill_meta(&m4, 4, 0);
    rt_err e = {0};
    uint8_t zero[1000] = {0};
    CHECK(write_v4(check_path("one.rtt"), &m1, a, zero, n, 65536, &e) == 0, "%s", e.msg);
    CHECK(write_v4(check_path("four.rtt"), &m4, a, core, n, 65536, &e) == 0, "%s", e.msg);
    size_t l1, l4;
    unsigned char *b1 = slurp(check_path("one.rtt"), &l1), *b4 = slurp(check_path("four.rtt"), &l4);
    size_t h1 = 16 + (b1[12] | b1[13] << 8) + 4, h4 = 16 + (b4[12] | b4[13] << 8) + 4;
    uint32_t u1 = b1[h1 + 12] | b1[h1 + 13] << 8 | (uint32_t)b1[h1 + 14] << 16;
    uint32_t u4 = b4[h4 + 12] | b4[h4 + 13] << 8 | (uint32_t)b4[h4 + 14] << 16;
    CHECK(b1[8] == 1 && b4[8] == 4, "versions %u and %u", b1[8], b4[8]);
    CHECK(u4 == u1 + 2 * switches, "U %u on 4 cores, %u on one, %zu switches: want +2 each", u4, u1, switches);
    /* cores 0 and 1 are the same single-core file */
    m1.cores = 0;
    CHECK(write_v4(check_path("zero.rtt"), &m1, a, zero, n, 65536, &e) == 0, "%s", e.msg);
    size_t l0;
    unsigned char *b0 = slurp(check_path("zero.rtt"), &l0);
    CHECK(l0 == l1 && !memcmp(b0, b1, l1), "cores 0 and 1 write different files");
    free(b0);
    free(b1);
    free(b4);
    /* refusals */
    m4.cores = 257;
    CHECK(!rt_tr_create(check_path("x.rtt"), &m4, &e) && strstr(e.msg, "257 cores"), "257 cores: %s", e.msg);
    m4.cores = 4;
    rt_tr_writer *w = rt_tr_create(check_path("x.rtt"), &m4, &e);
    CHECK(w && rt_tr_put_core(w, 4, a, 1) < 0 && strstr(rt_tr_writer_error(w), "core 4"), "core 4 of 4 accepted");
    rt_tr_abort(w);
    free(a);
    free(core);
}

static void test_corruption(void)
{
    const size_t n = 400;
    rt_access *a = calloc(n, sizeof *a);
    uint8_t *core = calloc(n, 1);
    stream(a, core, n, 8, 2, 20);
    rt_tr_meta m;
    fill_meta(&m, 8, 2);
    rt_err e = {0};
    const char *good = check_path("good.rtt"), *bad = check_path("bad.rtt");
    CHECK(write_v4(good, &m, a, core, n, 150, &e) == 0, "%s", e.msg);
    size_t len;
    unsigned char *b = slurp(good, &len);
    int acc = 0;
    for (size_t k = 0; k < len; k++) {
        spit(bad, b, k);
        if (!rejected(bad, NULL, 0) && acc++ < 5) fprintf(stderr, "  truncation at %zu accepted\n", k);
    }
    CHECK(acc == 0, "%d of %zu truncations accepted", acc, len);
    size_t hlen = 16 + (b[12] | b[13] << 8) + 4, foot = 4 + 4 + 16 + 24 * RT_NCLASS + 4;
    int flips = 0;
    acc = 0;
    for (size_t bit = 0; bit < 8 * len; bit++) {
        size_t byte = bit / 8;
        if (byte >= hlen && byte < len - foot && rnd64() % 16) continue;
        b[byte] ^= (unsigned char)(1u << (bit % 8));
        spit(bad, b, len);
        b[byte] ^= (unsigned char)(1u << (bit % 8));
        flips++;
        if (!rejected(bad, NULL, 0) && acc++ < 5) fprintf(stderr, "  flip of bit %zu accepted\n", bit);
    }
    CHECK(acc == 0 && flips > 1000, "%d of %d bit flips accepted", acc, flips);
    /* hand-made chunks after the good header: one record (class 1, 8 bytes at 16) */
    const unsigned char rec[] = {0x01, 0x20, 0x08}; /* tag class 1, address delta zigzag(16), size 8 */
    struct {
        unsigned char raw[16];
        size_t len;
        uint32_t n;
        const char *want;
    } cases[] = {
        {{0x0f, 0x00, 0x01, 0x20, 0x08}, 5, 1, "core switch to the current core"},
        {{0x0f, 0x08, 0x01, 0x20, 0x08}, 5, 1, "core switch above the header's cores"},
        {{0x0f, 0x02, 0x0f, 0x03, 0x01, 0x20, 0x08}, 7, 1, "core switch not followed by a reference"},
        {{0x01, 0x20, 0x08, 0x0f, 0x02}, 5, 2, "core switch not followed by a reference"},
        {{0x1f, 0x02, 0x01, 0x20, 0x08}, 5, 1, "class out of range"},
    };
    (void)rec;
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        uLong clen = compressBound((uLong)cases[c].len);
        unsigned char *f = malloc(hlen + 24 + clen);
        memcpy(f, b, hlen);
        unsigned char *ck = f + hlen;
        compress2(ck + 24, &clen, cases[c].raw, (uLong)cases[c].len, 6);
        memcpy(ck, "RTCK", 4);
        const uint32_t v[4] = {0, cases[c].n, (uint32_t)cases[c].len, (uint32_t)clen};
        for (int k = 0; k < 4; k++)
            for (int i = 0; i < 4; i++) ck[4 + 4 * k + i] = (unsigned char)(v[k] >> (8 * i));
        uint32_t cr = (uint32_t)crc32(crc32(0, ck, 20), ck + 24, (uInt)clen);
        for (int i = 0; i < 4; i++) ck[20 + i] = (unsigned char)(cr >> (8 * i));
        spit(bad, f, hlen + 24 + clen);
        free(f);
        char msg[RT_ERR_LEN];
        CHECK(rejected(bad, msg, sizeof msg) && strstr(msg, cases[c].want), "case %zu: '%s', want '%s'", c, msg,
              cases[c].want);
    }
    free(b);
    free(a);
    free(core);
}

int main(void)
{
    if (!check_tmpdir("test_trace_v4")) return perror("mkdtemp"), 1;
    test_round_trip();
    test_cost();
    test_corruption();
    check_rmdir();
    return failures ? 1 : 0;
}
