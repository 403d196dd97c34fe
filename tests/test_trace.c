/* test_trace.c -- the .rtt trace format: exact round trips of random record
 * streams (version 1, and version 2 with ray generations), rejection of
 * every truncation and of corrupted bytes in both versions, hand-made
 * chunks with bad generation bytes, version and magic checks, interrupted
 * writes, determinism, the bytes of version-1 files against those of the
 * writer before version 2 existed, out-of-memory paths. The quick tier cuts
 * a 500-record file of each version at every byte and skips the 300,000-
 * record round trips; the long tier (RT_TEST_LONG=1) uses 3,000 and runs them.
 *
 * `test_trace --synthetic PATH` writes the small deterministic trace that
 * tests/trace_cli.sh dumps and compares against tests/golden/. */
#include "check.h"
#include "memmodel.h"
#include "rt.h"
#include "trace.h"

#include <dirent.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>
#include <zlib.h>

static int exists(const char *p)
{
    struct stat st;
    return stat(p, &st) == 0;
}

/* The writer's temporary for int.rtt (".int.rtt.XXXXXX", see outfile.c). */
static int tmp_exists(void)
{
    DIR *d = opendir(check_dir);
    struct dirent *de;
    int found = 0;
    while (d && (de = readdir(d))) found |= !strncmp(de->d_name, ".int.rtt.", 9);
    if (d) closedir(d);
    return found;
}

static void fill_meta(rt_tr_meta *m)
{
    memset(m, 0, sizeof *m);
    snprintf(m->tool_version, sizeof m->tool_version, "0.1.0");
    snprintf(m->git_rev, sizeof m->git_rev, "0123456789ab-dirty");
    snprintf(m->command, sizeof m->command, "raytraffic trace sphereflake -t recursive -o x.rtt");
    snprintf(m->scene, sizeof m->scene, "sphereflake");
    snprintf(m->scene_params, sizeof m->scene_params, "level=4 tess=3");
    m->scene_hash = 0xfedcba9876543210ULL;
    m->ntri = 797150;
    snprintf(m->tracer, sizeof m->tracer, "dynamic");
    m->W = 1024;
    m->H = 768;
    m->lights = 5;
    m->sched_size = 65536;
    m->gmax = 12345;
    snprintf(m->params, sizeof m->params, "qorder=fullest threads=4");
    rt_mm_init(&m->layout);
    rt_mm_add(&m->layout, "kd.nodes", RT_CLS_NODE, 8, 1000, NULL);
    rt_mm_add(&m->layout, "kd.index", RT_CLS_INDEX, 4, 5000, NULL);
    rt_mm_add(&m->layout, "tri.verts", RT_CLS_TRI, 36, 797150, NULL);
    rt_mm_add(&m->layout, "rays", RT_CLS_RAY, 32, 1 << 20, NULL);
    rt_mm_add(&m->layout, "fb", RT_CLS_FB, 12, 1 << 20, NULL);
}

static int meta_equal(const rt_tr_meta *a, const rt_tr_meta *b)
{
    if (strcmp(a->tool_version, b->tool_version) || strcmp(a->git_rev, b->git_rev) ||
        strcmp(a->command, b->command) || strcmp(a->scene, b->scene) || strcmp(a->scene_params, b->scene_params) ||
        a->scene_hash != b->scene_hash || a->ntri != b->ntri || strcmp(a->tracer, b->tracer) || a->W != b->W ||
        a->H != b->H || a->lights != b->lights || a->sched_size != b->sched_size || a->gmax != b->gmax ||
        strcmp(a->params, b->params) || a->layout.n != b->layout.n || a->layout.next != b->layout.next ||
        a->generations != b->generations)
        return 0;
    for (int i = 0; i < a->layout.n; i++) {
        const rt_region *x = &a->layout.r[i], *y = &b->layout.r[i];
        if (strcmp(x->name, y->name) || x->cls != y->cls || x->recsize != y->recsize || x->count != y->count ||
            x->base != y->base)
            return 0;
    }
    return 1;
}

/* A random stream with the features the coder special-cases. */
static rt_access *random_stream(size_t n)
{
    rt_access *a = calloc(n ? n : 1, sizeof *a);
    static const uint64_t extremes[] = {0, 1, 0x7fffffffffffffffULL, 0x8000000000000000ULL, UINT64_MAX,
                                        UINT64_MAX - 1, RT_MM_BASE};
    static const uint32_t sizes[] = {1, 4, 8, 32, 36, 0x7fffffff, 0x80000000u, UINT32_MAX};
    size_t i = 0;
    while (i < n) {
        int kind = (int)(rnd64() % 6);
        size_t run = 1 + (size_t)(rnd64() % 200);
        uint8_t cls = (uint8_t)(rnd64() % RT_NCLASS);
        uint32_t size = sizes[rnd64() % 8];
        uint64_t addr = rnd64();
        for (size_t k = 0; k < run && i < n; k++, i++) {
            rt_access *x = &a[i];
            x->write = (uint8_t)(rnd64() & 1);
            switch (kind) {
            case 0: /* sequential run, same class and size */
                x->cls = cls; x->size = size; x->addr = addr; addr += size;
                break;
            case 1: /* extremes */
                x->cls = (uint8_t)(rnd64() % RT_NCLASS);
                x->addr = extremes[rnd64() % 7];
                x->size = sizes[rnd64() % 8];
                break;
            case 2: /* fully random */
                x->cls = (uint8_t)(rnd64() % RT_NCLASS);
                x->addr = rnd64();
                x->size = (uint32_t)(1 + rnd64() % UINT32_MAX);
                break;
            case 3: /* repeated address */
                x->cls = cls; x->addr = addr; x->size = size;
                break;
            case 4: /* small deltas both ways, interleaved classes */
                x->cls = (uint8_t)(rnd64() % 3);
                addr += (uint64_t)((int64_t)(rnd64() % 4001) - 2000);
                x->addr = addr; x->size = (uint32_t)(4 << (rnd64() % 4));
                break;
            default: /* tree-like: 8-byte nodes in a region */
                x->cls = RT_CLS_NODE; x->size = 8;
                x->addr = RT_MM_BASE + 8 * (rnd64() % 100000);
                break;
            }
        }
    }
    return a;
}

/* Gives a's records generations 0..maxgen: mostly runs (as tracers record
 * them), sometimes a change at every record. */
static void add_gens(rt_access *a, size_t n, unsigned maxgen)
{
    size_t i = 0;
    while (i < n) {
        size_t run = rnd64() % 4 ? 1 + (size_t)(rnd64() % 300) : 1 + (size_t)(rnd64() % 3);
        uint8_t g = (uint8_t)(rnd64() % (maxgen + 1));
        for (size_t k = 0; k < run && i < n; k++, i++) a[i].gen = g;
    }
}

static int write_trace_opts(const char *path, const rt_tr_meta *m, const rt_access *a, size_t n,
                            const rt_tr_wopts *o, rt_err *e);
static int write_trace(const char *path, const rt_tr_meta *m, const rt_access *a, size_t n, int level,
                       uint32_t chunk, rt_err *e)
{
    rt_tr_wopts o = {level, chunk, NULL};
    return write_trace_opts(path, m, a, n, &o, e);
}

/* Writes a[0..n) with options o in batches of varying size; 0 or -1 (e). */
static int write_trace_opts(const char *path, const rt_tr_meta *m, const rt_access *a, size_t n,
                            const rt_tr_wopts *o, rt_err *e)
{
    rt_tr_writer *w = rt_tr_create_opts(path, m, o, e);
    if (!w) return -1;
    rt_sink *s = rt_tr_sink(w);
    size_t i = 0;
    while (i < n) { /* batches of varying size, as a recorder would */
        size_t k = 1 + (size_t)(rnd64() % 5000);
        if (k > n - i) k = n - i;
        if (s->put(s, a + i, k) < 0) {
            rt_errf(e, "%s", rt_tr_writer_error(w));
            rt_tr_abort(w);
            return -1;
        }
        i += k;
    }
    return rt_tr_finish(w, e);
}

/* Reads the whole file with buffer capacity cap. Returns records read, or
 * -1 with e set. Compares against want when non-NULL (*mismatch set). */
static long read_all(const char *path, size_t cap, const rt_access *want, size_t nwant, int *mismatch, rt_err *e,
                     rt_tr_totals *tot)
{
    rt_tr_reader *r = rt_tr_open(path, e);
    if (!r) return -1;
    rt_access *buf = calloc(cap, sizeof *buf);
    long total = 0, k;
    while ((k = rt_tr_read(r, buf, cap, e)) > 0) {
        if (want)
            for (long i = 0; i < k; i++) {
                size_t j = (size_t)total + (size_t)i;
                if (j >= nwant || buf[i].addr != want[j].addr || buf[i].size != want[j].size ||
                    buf[i].write != want[j].write || buf[i].cls != want[j].cls || buf[i].gen != want[j].gen) {
                    if (!*mismatch)
                        fprintf(stderr, "  first mismatch at record %zu\n", j);
                    *mismatch = 1;
                }
            }
        total += k;
    }
    if (k == 0 && rt_tr_read(r, buf, cap, NULL) != 0) total = -2; /* 0 must be sticky */
    if (k == 0 && tot) *tot = *rt_tr_get_totals(r);
    free(buf);
    rt_tr_close(r);
    return k < 0 ? -1 : total;
}

static void test_round_trip(unsigned generations)
{
    rt_tr_meta m, *mm = &m;
    fill_meta(mm);
    mm->generations = generations;
    static const size_t ns[] = {0, 1, 2, 1000, 65535, 65536, 65537, 300000};
    static const uint32_t chunks[] = {1, 7, 1000, 65536};
    /* the chunk-boundary sizes stay in the quick tier; 300,000 is long only */
    size_t nns = sizeof ns / sizeof ns[0] - (check_long() ? 0 : 1);
    for (size_t t = 0; t < nns; t++) {
        size_t n = ns[t];
        rt_access *a = random_stream(n);
        if (generations) add_gens(a, n, generations);
        for (size_t c = 0; c < 4; c++) {
            if (chunks[c] == 1 && n > 70000) continue;
            rt_err e = {0};
            const char *p = check_path("rt.rtt");
            int level = (int)(c * 3); /* 0, 3, 6, 9 */
            int rc = write_trace(p, mm, a, n, level, chunks[c], &e);
            CHECK(rc == 0, "write n=%zu chunk=%u: %s", n, chunks[c], e.msg);
            CHECK(!exists(check_path("rt.rtt.tmp")), "tmp left behind");
            size_t caps[] = {1, 3, 4096, 100000};
            for (size_t q = 0; q < 4; q++) {
                if (caps[q] < 4096 && n > 70000) continue;
                int mis = 0;
                rt_tr_totals tot;
                long got = read_all(p, caps[q], a, n, &mis, &e, &tot);
                CHECK(got == (long)n && !mis, "round trip n=%zu chunk=%u cap=%zu: got %ld mismatch %d (%s)", n,
                      chunks[c], caps[q], got, mis, e.msg);
                if (got == (long)n) {
                    uint64_t refs = 0;
                    for (int k = 0; k < RT_NCLASS; k++) refs += tot.refs[k];
                    CHECK(tot.nrefs == n && refs == n, "footer totals");
                    CHECK(tot.nchunks == (n + chunks[c] - 1) / chunks[c], "chunk count %llu",
                          (unsigned long long)tot.nchunks);
                }
            }
            rt_tr_reader *r = rt_tr_open(p, &e);
            CHECK(r && meta_equal(rt_tr_get_meta(r), mm), "metadata round trip");
            if (r) {
                CHECK(rt_tr_get_version(r) == (generations ? 2u : 1u), "version %u", rt_tr_get_version(r));
                CHECK(rt_tr_get_chunk_records(r) == chunks[c], "chunk records");
            }
            rt_tr_close(r);
        }
        free(a);
    }
    /* per-class totals against a direct count */
    size_t n = 50000;
    rt_access *a = random_stream(n);
    if (generations) add_gens(a, n, generations);
    rt_tr_totals want;
    memset(&want, 0, sizeof want);
    for (size_t i = 0; i < n; i++) {
        want.refs[a[i].cls]++;
        want.bytes[a[i].cls] += a[i].size;
        want.writes[a[i].cls] += a[i].write;
    }
    rt_err e = {0};
    rt_tr_totals tot;
    int mis = 0;
    CHECK(write_trace(check_path("tot.rtt"), mm, a, n, 6, 4096, &e) == 0, "%s", e.msg);
    CHECK(read_all(check_path("tot.rtt"), 4096, a, n, &mis, &e, &tot) == (long)n, "%s", e.msg);
    for (int c = 0; c < RT_NCLASS; c++)
        CHECK(tot.refs[c] == want.refs[c] && tot.bytes[c] == want.bytes[c] && tot.writes[c] == want.writes[c],
              "totals of class %d", c);
    free(a);
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
    unlink(p); /* a new file: rewriting a truncated one makes ext4 flush it */
    FILE *f = fopen(p, "wb");
    if (n) fwrite(b, 1, n, f);
    fclose(f);
}

/* Expects the file to be rejected (open fails or a read returns -1) with a
 * message naming the file and a byte offset. Returns 1 if rejected. */
static int rejected(const char *p, char *msg, size_t msgcap)
{
    rt_err e = {0};
    long got = read_all(p, 4096, NULL, 0, NULL, &e, NULL);
    if (msg) snprintf(msg, msgcap, "%s", e.msg);
    if (got != -1) return 0;
    if (!strstr(e.msg, p) || !strstr(e.msg, "byte ")) {
        fprintf(stderr, "  message lacks file or offset: %s\n", e.msg);
        return 0;
    }
    return 1;
}

static void test_corruption(unsigned generations)
{
    rt_tr_meta m;
    fill_meta(&m);
    m.generations = generations;
    size_t n = check_long() ? 3000 : 500; /* every truncation: one file per byte */
    rt_access *a = random_stream(n);
    if (generations) add_gens(a, n, generations);
    rt_err e = {0};
    const char *good = check_path("good.rtt"), *bad = check_path("bad.rtt");
    CHECK(write_trace(good, &m, a, n, 6, 700, &e) == 0, "%s", e.msg);
    free(a);
    size_t len;
    unsigned char *b = slurp(good, &len);
    CHECK(b && len > 100, "slurp");
    if (!b) return;
    /* every truncation point */
    int bad_trunc = 0;
    for (size_t k = 0; k < len; k++) {
        spit(bad, b, k);
        if (!rejected(bad, NULL, 0)) {
            if (bad_trunc++ < 5) fprintf(stderr, "  truncation at %zu of %zu accepted\n", k, len);
        }
    }
    CHECK(bad_trunc == 0, "%d of %zu truncations accepted", bad_trunc, len);
    char msg[RT_ERR_LEN];
    spit(bad, b, len - 1);
    CHECK(rejected(bad, msg, sizeof msg) && strstr(msg, "trunc"), "truncation message: %s", msg);
    /* every bit of the header (magic .. CRC) and of the footer */
    uint32_t hlen = 16 + (b[12] | b[13] << 8 | (uint32_t)b[14] << 16 | (uint32_t)b[15] << 24) + 4;
    size_t footlen = 4 + 4 + 16 + 24 * RT_NCLASS + 4;
    int bad_flip = 0, nflip = 0;
    for (size_t bit = 0; bit < 8 * (size_t)len; bit++) {
        size_t byte = bit / 8;
        int in_hdr = byte < hlen, in_foot = byte >= len - footlen;
        if (!in_hdr && !in_foot && rnd64() % 64) continue; /* ~1 in 64 chunk bits: several hundred */
        b[byte] ^= (unsigned char)(1u << (bit % 8));
        spit(bad, b, len);
        b[byte] ^= (unsigned char)(1u << (bit % 8));
        nflip++;
        if (!rejected(bad, NULL, 0) && bad_flip++ < 5) fprintf(stderr, "  flip of bit %zu accepted\n", bit);
    }
    CHECK(bad_flip == 0, "%d of %d bit flips accepted", bad_flip, nflip);
    CHECK(nflip > 2000, "only %d flips tried", nflip);
    /* a CRC mismatch names the chunk */
    b[hlen + 30] ^= 0x40;
    spit(bad, b, len);
    b[hlen + 30] ^= 0x40;
    CHECK(rejected(bad, msg, sizeof msg) && strstr(msg, "chunk 0 CRC mismatch"), "chunk CRC message: %s", msg);
    /* wrong magic */
    memcpy(b, "RTTRACF", 7);
    spit(bad, b, len);
    memcpy(b, "RTTRACE", 7);
    CHECK(rejected(bad, msg, sizeof msg) && strstr(msg, "magic"), "magic message: %s", msg);
    /* trailing garbage */
    unsigned char *b2 = malloc(len + 3);
    memcpy(b2, b, len);
    memcpy(b2 + len, "xyz", 3);
    spit(bad, b2, len + 3);
    free(b2);
    CHECK(rejected(bad, msg, sizeof msg) && strstr(msg, "trailing"), "trailing message: %s", msg);
    /* a newer format version, with a valid header CRC */
    unsigned char v = b[8];
    CHECK(v == (generations ? 2 : 1), "written as version %u", v);
    b[8] = RT_TR_FORMAT_VERSION + 1;
    uint32_t c = (uint32_t)crc32(0, b, hlen - 4);
    unsigned char save[4];
    memcpy(save, b + hlen - 4, 4);
    for (int i = 0; i < 4; i++) b[hlen - 4 + i] = (unsigned char)(c >> (8 * i));
    spit(bad, b, len);
    char vname[32];
    snprintf(vname, sizeof vname, "version %d", RT_TR_FORMAT_VERSION + 1);
    CHECK(rejected(bad, msg, sizeof msg) && strstr(msg, vname) && strstr(msg, "newer"), "version message: %s", msg);
    /* the other known version, with a valid header CRC: the payload's
     * generations field is missing (1 read as 2) or left over (2 read as 1) */
    b[8] = v == 1 ? 2 : 1;
    c = (uint32_t)crc32(0, b, hlen - 4);
    for (int i = 0; i < 4; i++) b[hlen - 4 + i] = (unsigned char)(c >> (8 * i));
    spit(bad, b, len);
    CHECK(rejected(bad, msg, sizeof msg) && strstr(msg, "header"), "version swap message: %s", msg);
    b[8] = v;
    memcpy(b + hlen - 4, save, 4);
    /* the restored bytes read fine again */
    spit(bad, b, len);
    CHECK(!rejected(bad, msg, sizeof msg), "restored copy rejected: %s", msg);
    /* an empty file and a missing file */
    spit(bad, b, 0);
    CHECK(rejected(bad, NULL, 0), "empty file accepted");
    rt_err e2 = {0};
    CHECK(!rt_tr_open(check_path("no-such.rtt"), &e2) && strstr(e2.msg, "no-such.rtt"), "missing file: %s", e2.msg);
    free(b);
}

static void test_interrupted(void)
{
    rt_tr_meta m;
    fill_meta(&m);
    rt_err e = {0};
    const char *p = check_path("int.rtt");
    size_t n = 100000;
    rt_access *a = random_stream(n);
    rt_tr_writer *w = rt_tr_create(p, &m, &e);
    CHECK(w != NULL, "%s", e.msg);
    if (!w) return;
    rt_sink *s = rt_tr_sink(w);
    CHECK(s->put(s, a, n) == 0, "put");
    CHECK(!exists(p), "unfinished trace visible at PATH");
    CHECK(tmp_exists(), "no tmp file while writing");
    rt_tr_abort(w);
    CHECK(!exists(p) && !tmp_exists(), "abort left a file");
    rt_tr_abort(NULL);
    /* a bad record makes put fail and finish fail, leaving nothing */
    w = rt_tr_create(p, &m, &e);
    s = rt_tr_sink(w);
    rt_access badrec = {RT_MM_BASE, 8, 0, RT_NCLASS, 0};
    CHECK(s->put(s, a, 10) == 0 && s->put(s, &badrec, 1) < 0, "class out of range accepted");
    CHECK(strstr(rt_tr_writer_error(w), "class"), "writer error: %s", rt_tr_writer_error(w));
    CHECK(rt_tr_finish(w, &e) < 0 && strstr(e.msg, "class"), "finish after failed put: %s", e.msg);
    CHECK(!exists(p) && !tmp_exists(), "failed finish left a file");
    w = rt_tr_create(p, &m, &e);
    s = rt_tr_sink(w);
    badrec.cls = 0;
    badrec.size = 0;
    CHECK(s->put(s, &badrec, 1) < 0, "size 0 accepted");
    rt_tr_abort(w);
    /* metadata that does not fit */
    rt_tr_meta m2 = m;
    m2.layout.r[1].cls = 200;
    CHECK(!rt_tr_create(p, &m2, &e) && !tmp_exists(), "bad region class accepted");
    m2 = m;
    memset(m2.scene, 'x', sizeof m2.scene); /* no NUL */
    CHECK(!rt_tr_create(p, &m2, &e), "unterminated string accepted");
    rt_tr_wopts o = {10, 100, NULL};
    CHECK(!rt_tr_create_opts(p, &m, &o, &e), "level 10 accepted");
    o.level = 6;
    o.chunk_records = 0;
    CHECK(!rt_tr_create_opts(p, &m, &o, &e), "chunk 0 accepted");
    /* unwritable directory */
    CHECK(!rt_tr_create("/nonexistent-dir/x.rtt", &m, &e) && strstr(e.msg, "/nonexistent-dir/x.rtt"),
          "unwritable path: %s", e.msg);
    free(a);
}

static void test_deterministic(void)
{
    rt_tr_meta m;
    fill_meta(&m);
    size_t n = 200000;
    rt_access *a = random_stream(n);
    rt_err e = {0};
    rnd_seed(42); /* same batch sizes too */
    CHECK(write_trace(check_path("d1.rtt"), &m, a, n, 6, 65536, &e) == 0, "%s", e.msg);
    rnd_seed(4242); /* different batching must not matter */
    CHECK(write_trace(check_path("d2.rtt"), &m, a, n, 6, 65536, &e) == 0, "%s", e.msg);
    size_t l1, l2;
    unsigned char *b1 = slurp(check_path("d1.rtt"), &l1), *b2 = slurp(check_path("d2.rtt"), &l2);
    CHECK(b1 && b2 && l1 == l2 && !memcmp(b1, b2, l1), "same input gives different files");
    /* the file hash is FNV-1a of the bytes */
    rt_tr_reader *r = rt_tr_open(check_path("d1.rtt"), &e);
    rt_access buf[4096];
    while (rt_tr_read(r, buf, 4096, &e) > 0) {}
    CHECK(rt_tr_file_hash(r) == rt_fnv1a(RT_FNV_INIT, b1, l1), "file hash");
    CHECK(rt_tr_file_bytes(r) == l1, "file bytes");
    rt_tr_close(r);
    free(b1);
    free(b2);
    free(a);
}

static void test_oom(void)
{
    rt_tr_meta m;
    fill_meta(&m);
    rt_access a[100];
    for (int i = 0; i < 100; i++) a[i] = (rt_access){RT_MM_BASE + 8u * (unsigned)i, 8, 0, RT_CLS_NODE, 0};
    rt_err e = {0};
    const char *p = check_path("oom.rtt");
    CHECK(write_trace(p, &m, a, 100, 6, 65536, &e) == 0, "%s", e.msg);
    for (long k = 1; k < 12; k++) {
        rt_fail_alloc_after = k;
        rt_tr_writer *w = rt_tr_create(check_path("oom2.rtt"), &m, &e);
        rt_fail_alloc_after = 0;
        if (w) rt_tr_abort(w);
        CHECK(!exists(check_path("oom2.rtt.tmp")), "tmp after failed create");
        rt_fail_alloc_after = k;
        rt_tr_reader *r = rt_tr_open(p, &e);
        rt_fail_alloc_after = 0;
        rt_tr_close(r);
    }
}

static void le32(unsigned char *p, uint32_t v)
{
    for (int i = 0; i < 4; i++) p[i] = (unsigned char)(v >> (8 * i));
}

static size_t header_len(const unsigned char *b)
{
    return 16 + (b[12] | b[13] << 8 | (uint32_t)b[14] << 16 | (uint32_t)b[15] << 24) + 4;
}

/* Writes hdr (a whole file header) and one chunk of n records encoded as
 * raw[0..rlen), with valid lengths and CRC; no footer. */
static void handmade_x(const char *path, const unsigned char *hdr, size_t hlen, const unsigned char *raw, size_t rlen,
                       uint32_t n, long at, unsigned char x);

static void handmade(const char *path, const unsigned char *hdr, size_t hlen, const unsigned char *raw, size_t rlen,
                     uint32_t n)
{
    handmade_x(path, hdr, hlen, raw, rlen, n, 0, 0);
}

/* The same with byte at of the zlib stream xor-ed with x before the CRC is
 * computed (at < 0: counted from the stream's end). */
static void handmade_x(const char *path, const unsigned char *hdr, size_t hlen, const unsigned char *raw, size_t rlen,
                       uint32_t n, long at, unsigned char x)
{
    uLong clen = compressBound((uLong)rlen);
    unsigned char *f = malloc(hlen + 24 + clen);
    memcpy(f, hdr, hlen);
    unsigned char *ck = f + hlen;
    compress2(ck + 24, &clen, raw, (uLong)rlen, 6);
    ck[24 + (at < 0 ? (long)clen + at : at)] ^= x;
    memcpy(ck, "RTCK", 4);
    le32(ck + 4, 0);
    le32(ck + 8, n);
    le32(ck + 12, (uint32_t)rlen);
    le32(ck + 16, (uint32_t)clen);
    le32(ck + 20, (uint32_t)crc32(crc32(0, ck, 20), ck + 24, (uInt)clen));
    spit(path, f, hlen + 24 + clen);
    free(f);
}

/* Reads the first record of path with a one-record buffer; returns what
 * rt_tr_read returned. */
static long first_record(const char *path, rt_access *a, rt_err *e)
{
    rt_tr_reader *r = rt_tr_open(path, e);
    if (!r) return -1;
    long k = rt_tr_read(r, a, 1, e);
    rt_tr_close(r);
    return k;
}

static int synthetic_level(const char *path, int level);

static void test_generations(void)
{
    rt_tr_meta m;
    fill_meta(&m);
    rt_err e = {0};
    const char *p = check_path("gen.rtt");
    /* the writer keeps generations within what the header declares */
    rt_access rec = {RT_MM_BASE, 8, 0, RT_CLS_NODE, 1};
    rt_tr_writer *w = rt_tr_create(p, &m, &e);
    rt_sink *s = rt_tr_sink(w);
    CHECK(s->put(s, &rec, 1) < 0 && strstr(rt_tr_writer_error(w), "generation 1"),
          "generation in a version-1 trace: %s", rt_tr_writer_error(w));
    rt_tr_abort(w);
    m.generations = 3;
    w = rt_tr_create(p, &m, &e);
    s = rt_tr_sink(w);
    rec.gen = 3;
    CHECK(s->put(s, &rec, 1) == 0, "generation 3 of 3: %s", rt_tr_writer_error(w));
    rec.gen = 4;
    CHECK(s->put(s, &rec, 1) < 0 && strstr(rt_tr_writer_error(w), "generation 4 above the 3"),
          "generation 4 of 3: %s", rt_tr_writer_error(w));
    rt_tr_abort(w);
    m.generations = RT_TR_MAX_GENERATION + 1;
    CHECK(!rt_tr_create(p, &m, &e) && strstr(e.msg, "generations"), "256 generations accepted: %s", e.msg);
    m.generations = RT_TR_MAX_GENERATION;
    w = rt_tr_create(p, &m, &e);
    s = rt_tr_sink(w);
    rec.gen = 255;
    CHECK(w && s->put(s, &rec, 1) == 0 && rt_tr_finish(w, &e) == 0, "generation 255: %s", e.msg);
    rt_access got;
    CHECK(first_record(p, &got, &e) == 1 && got.gen == 255, "generation 255 read back: %s", e.msg);

    /* a generation costs one byte per change and nothing per record: four
     * sequential records, generations 0 1 1 0 (tag, 5-byte address, size,
     * then a tag each) */
    rt_access four[4];
    for (int i = 0; i < 4; i++) four[i] = (rt_access){RT_MM_BASE + 8u * (unsigned)i, 8, 0, RT_CLS_NODE, 0};
    size_t l1, l2;
    m.generations = 0;
    CHECK(write_trace(check_path("g1.rtt"), &m, four, 4, 0, 100, &e) == 0, "%s", e.msg);
    four[1].gen = four[2].gen = 1;
    m.generations = 1;
    CHECK(write_trace(check_path("g2.rtt"), &m, four, 4, 0, 100, &e) == 0, "%s", e.msg);
    unsigned char *b1 = slurp(check_path("g1.rtt"), &l1), *b2 = slurp(check_path("g2.rtt"), &l2);
    size_t h1 = header_len(b1), h2 = header_len(b2);
    uint32_t u1 = b1[h1 + 12], u2 = b2[h2 + 12];
    CHECK(h2 == h1 + 4 && u1 == 1 + 5 + 1 + 3 && u2 == u1 + 2, "encoded lengths: header %zu/%zu, chunk %u/%u", h1,
          h2, u1, u2);
    free(b1);
    free(b2);

    /* a version-2 trace whose records are all generation 0 differs from the
     * version-1 trace only in its header */
    rt_access *a = random_stream(20000);
    m.generations = 0;
    CHECK(write_trace(check_path("g1.rtt"), &m, a, 20000, 6, 3000, &e) == 0, "%s", e.msg);
    m.generations = 7;
    CHECK(write_trace(check_path("g2.rtt"), &m, a, 20000, 6, 3000, &e) == 0, "%s", e.msg);
    b1 = slurp(check_path("g1.rtt"), &l1);
    b2 = slurp(check_path("g2.rtt"), &l2);
    h1 = header_len(b1);
    h2 = header_len(b2);
    CHECK(b1[8] == 1 && b2[8] == 2 && l1 - h1 == l2 - h2 && !memcmp(b1 + h1, b2 + h2, l1 - h1),
          "generation-0 chunks differ between versions");
    free(a);

    /* hand-made chunks: generation bytes a writer never produces */
    const unsigned char *hv2 = b2, *hv1 = b1; /* headers: generations 7, none */
    struct {
        const unsigned char *hdr;
        size_t hlen;
        unsigned char raw[12];
        size_t rlen;
        uint32_t n;
        const char *msg; /* NULL: valid, first record has generation 2 */
    } cases[] = {
        {hv2, h2, {0x80 | RT_CLS_NODE, 2, 0x10, 0x08}, 4, 1, NULL},
        {hv2, h2, {0x80 | RT_CLS_NODE, 0, 0x10, 0x08}, 4, 1, "record 0: generation byte repeats"},
        {hv2, h2, {0x80 | RT_CLS_NODE, 2, 0x10, 0x08, 0x80 | RT_CLS_NODE, 2, 0x10}, 7, 2,
         "record 1: generation byte repeats"},
        {hv2, h2, {0x80 | RT_CLS_NODE, 8, 0x10, 0x08}, 4, 1, "generation above the header"},
        {hv2, h2, {0x80 | RT_CLS_NODE}, 1, 1, "runs past the end"},
        {hv2, h2, {0x80 | 0x0f, 2, 0x10, 0x08}, 4, 1, "class out of range"},
        {hv1, h1, {0x80 | RT_CLS_NODE, 0x10, 0x08}, 3, 1, "reserved tag bit"},
    };
    const char *hm = check_path("hand.rtt");
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        handmade(hm, cases[i].hdr, cases[i].hlen, cases[i].raw, cases[i].rlen, cases[i].n);
        long k = first_record(hm, &got, &e);
        if (!cases[i].msg)
            CHECK(k == 1 && got.gen == 2 && got.addr == 8 && got.size == 8 && got.cls == RT_CLS_NODE,
                  "hand-made case %zu: %ld records, generation %u (%s)", i, k, got.gen, e.msg);
        else {
            char msg[RT_ERR_LEN];
            CHECK(rejected(hm, msg, sizeof msg) && strstr(msg, cases[i].msg), "hand-made case %zu: %s", i, msg);
        }
    }
    /* the zlib wrapper of a chunk with a valid CRC: its header is checked
     * (method, window, preset dictionary, check bits); its Adler-32 is
     * covered by the chunk CRC alone and not recomputed */
    {
        const unsigned char one[4] = {0x80 | RT_CLS_NODE, 2, 0x10, 0x08};
        struct {
            long at;
            unsigned char x;
            const char *msg; /* NULL: read */
        } zc[] = {{0, 0x01, "incorrect header check"},  /* method 9 */
                  {0, 0x80, "incorrect header check"},  /* window 2^16 */
                  {1, 0x20, "incorrect header check"},  /* preset dictionary */
                  {1, 0x01, "incorrect header check"},  /* check bits */
                  {2, 0xff, "does not inflate to 4 bytes"},
                  {-1, 0x5a, NULL}};                    /* Adler-32 */
        for (size_t i = 0; i < sizeof zc / sizeof zc[0]; i++) {
            handmade_x(hm, hv2, h2, one, 4, 1, zc[i].at, zc[i].x);
            char msg[RT_ERR_LEN] = "";
            if (zc[i].msg)
                CHECK(rejected(hm, msg, sizeof msg) && strstr(msg, zc[i].msg), "zlib case %zu: %s", i, msg);
            else
                CHECK(first_record(hm, &got, &e) == 1 && got.gen == 2 && got.addr == 8, "zlib case %zu: %s", i,
                      e.msg);
        }
    }
    free(b1);
    free(b2);

    /* a recorder stamps its current generation on every access, across
     * buffer flushes, into the writer and back out of the reader */
    m.generations = 255;
    w = rt_tr_create(p = check_path("rec.rtt"), &m, &e);
    rt_rec *rc = w ? rt_rec_new(rt_tr_sink(w), &e) : NULL;
    CHECK(rc && rc->gen == 0, "recorder: %s", e.msg);
    enum { NR = 3 * RT_REC_BUF + 7 };
    static uint8_t want[NR];
    for (int i = 0; i < NR; i++) {
        int g = i % 500 == 0 ? (i / 500) % 7 - 1 : -2; /* -1 and 300 are clamped */
        if (i == 1000) g = 300;
        if (g != -2) rt_rec_set_gen(rc, g);
        want[i] = rc->gen;
        RT_REC(rc, RT_MM_BASE + 8u * (unsigned)(i % 77), 8, i & 1, RT_CLS_NODE);
    }
    rt_rec_set_gen(NULL, 3); /* recording off: a no-op */
    CHECK(want[0] == 0 && want[1000] == 255 && want[1500] == 2, "clamping: %u %u %u", want[0], want[1000], want[1500]);
    CHECK(rt_rec_flush(rc) == 0 && rt_tr_finish(w, &e) == 0, "recorded trace: %s", e.msg);
    rt_rec_free(rc);
    rt_tr_reader *rr = rt_tr_open(p, &e);
    static rt_access back[NR + 1];
    long nb = rr ? rt_tr_read(rr, back, NR + 1, &e) : -1;
    int bad = 0;
    for (long i = 0; i < nb && i < NR; i++) bad += back[i].gen != want[i];
    CHECK(nb == NR && bad == 0, "recorded generations: %ld records, %d wrong (%s)", nb, bad, e.msg);
    rt_tr_close(rr);

    /* version-1 bytes are those of the writer before version 2 (the
     * synthetic trace, stored zlib blocks so only the format matters) */
    p = check_path("syn0.rtt");
    CHECK(synthetic_level(p, 0) == 0, "synthetic trace");
    b1 = slurp(p, &l1);
    CHECK(b1 && l1 == 846 && rt_fnv1a(RT_FNV_INIT, b1, l1) == 0x5f1614d05baafcf3ULL,
          "version-1 bytes changed: %zu bytes, hash %016llx", l1,
          b1 ? (unsigned long long)rt_fnv1a(RT_FNV_INIT, b1, l1) : 0ULL);
    free(b1);
}

/* The deterministic synthetic trace for the din golden file. */
static int synthetic(const char *path) { return synthetic_level(path, 6); }

static int synthetic_level(const char *path, int level)
{
    rt_tr_meta m;
    fill_meta(&m);
    snprintf(m.git_rev, sizeof m.git_rev, "synthetic");
    rt_access a[] = {
        {0x10000000, 8, 0, RT_CLS_NODE, 0},   {0x10000008, 8, 0, RT_CLS_NODE, 0},  {0x10000038, 8, 0, RT_CLS_NODE, 0},
        {0x10001000, 4, 0, RT_CLS_INDEX, 0},  {0x10001004, 4, 0, RT_CLS_INDEX, 0}, {0x10002020, 36, 0, RT_CLS_TRI, 0},
        {0x10002044, 36, 0, RT_CLS_TRI, 0},   {0x10003000, 32, 0, RT_CLS_RAY, 0},  {0x10003000, 32, 1, RT_CLS_RAY, 0},
        {0x1000303c, 8, 1, RT_CLS_HIT, 0},    {0x10004000, 200, 0, RT_CLS_QUEUE, 0}, {0x1000403f, 1, 1, RT_CLS_FB, 0},
        {0x1000403f, 2, 1, RT_CLS_FB, 0},     {0xffffffffffffffc0ULL, 64, 0, RT_CLS_STREAM, 0},
        {0xfffffffffffffff0ULL, 100, 1, RT_CLS_STREAM, 0},
    };
    rt_err e = {0};
    rt_tr_wopts o = {level, 4, NULL};
    rt_tr_writer *w = rt_tr_create_opts(path, &m, &o, &e);
    if (!w) return fprintf(stderr, "%s\n", e.msg), 1;
    rt_sink *s = rt_tr_sink(w);
    if (s->put(s, a, sizeof a / sizeof a[0]) < 0) return fprintf(stderr, "%s\n", rt_tr_writer_error(w)), 1;
    if (rt_tr_finish(w, &e) < 0) return fprintf(stderr, "%s\n", e.msg), 1;
    return 0;
}

/* ---- side payloads are opaque to the format ---- */

/* A toy payload maker: per chunk, the flags byte, then the chunk's record
 * count and the sum of its sizes as two u32 (toy_mode 1: a byte more on
 * the reader's side, so the payload check must fail; 2: the flags byte
 * wrong, so the writer must refuse it). */
typedef struct toy {
    uint32_t n, sum;            /* of the chunk so far */
    unsigned char out[16];      /* the payload made */
} toy;
static int toy_mode;
static void *toy_open(const rt_tr_sample_params *p, unsigned gens, rt_err *e)
{
    (void)p;
    (void)gens;
    return rt_calloc(1, sizeof(toy), e);
}
static int toy_put(void *ctx, const rt_access *a, size_t n)
{
    toy *t = ctx;
    for (size_t i = 0; i < n; i++) t->sum += a[i].size;
    t->n += (uint32_t)n;
    return 0;
}
static int toy_chunk(void *ctx, int last, const unsigned char **bytes, size_t *len)
{
    toy *t = ctx;
    t->out[0] = (unsigned char)((last ? 1 : 0) ^ (toy_mode == 2));
    for (int i = 0; i < 4; i++) {
        t->out[1 + i] = (unsigned char)(t->n >> (8 * i));
        t->out[5 + i] = (unsigned char)(t->sum >> (8 * i));
    }
    *bytes = t->out;
    *len = 9 + (toy_mode == 1);
    t->n = t->sum = 0;
    return 0;
}
static void toy_close(void *ctx) { free(ctx); }
static const rt_tr_payload_ops toy_ops = {
    {64, 6, 1, 65536, 1024, 256, 32768}, toy_open, toy_put, toy_chunk, toy_close};

/* The format stores whatever a maker makes (version 3), hands it back raw
 * (rt_tr_read_payload), re-makes and compares it with a maker set by
 * rt_tr_set_payload_check, and enforces its own two rules (the flags
 * byte; the parameters' ranges). */
static void test_opaque_payload(void)
{
    rt_tr_meta m;
    fill_meta(&m);
    const size_t N = 1000;
    rt_access *a = random_stream(N);
    const char *p = check_path("toy.rtt");
    rt_err e = {0};
    rt_tr_wopts o = {1, 300, &toy_ops};
    toy_mode = 0;
    CHECK(write_trace_opts(p, &m, a, N, &o, &e) == 0, "toy write: %s", e.msg);
    /* raw payloads: 4 chunks, each the toy's 9 bytes, the last marked */
    rt_tr_reader *r = rt_tr_open(p, &e);
    CHECK(r && rt_tr_get_version(r) == 3, "toy trace: version");
    rt_tr_payload pl;
    int k, nch = 0, bad = 0;
    uint32_t total = 0;
    while (r && (k = rt_tr_read_payload(r, &pl, &e)) > 0) {
        uint32_t n = pl.bytes[1] | pl.bytes[2] << 8 | pl.bytes[3] << 16 | (uint32_t)pl.bytes[4] << 24;
        bad += pl.len != 9 || n != pl.nrefs || pl.index != (uint64_t)nch || pl.last != (nch == 3) ||
               pl.bytes[0] != (nch == 3);
        total += n;
        nch++;
    }
    CHECK(r && k == 0 && nch == 4 && bad == 0 && total == N, "raw payloads: %d chunks, %d bad, %u records: %s", nch,
          bad, total, e.msg);
    rt_tr_close(r);
    /* the records with the payload check: every payload is what the toy makes */
    static rt_access back[1000];
    r = rt_tr_open(p, &e);
    if (r) rt_tr_set_payload_check(r, &toy_ops);
    long got = 0, g;
    while (r && (g = rt_tr_read(r, back + got, N - (size_t)got + 1, &e)) > 0) got += g;
    CHECK(r && got == (long)N && !memcmp(a, back, N * sizeof *a), "toy records with the check: %ld: %s", got, e.msg);
    rt_tr_close(r);
    /* a maker that makes other bytes than the file holds: the check fails */
    toy_mode = 1;
    r = rt_tr_open(p, &e);
    if (r) rt_tr_set_payload_check(r, &toy_ops);
    got = 0;
    while (r && (g = rt_tr_read(r, back, N + 1, &e)) > 0) got += g;
    CHECK(r && g < 0 && strstr(e.msg, "side chunk 0 does not match the records of chunk 0") && strstr(e.msg, p) &&
              strstr(e.msg, "byte "), "toy payload mismatch: %s", e.msg);
    rt_tr_close(r);
    /* ... and without the check (plain rt_tr_open) the file reads */
    r = rt_tr_open(p, &e);
    got = 0;
    while (r && (g = rt_tr_read(r, back, N + 1, &e)) > 0) got += g;
    CHECK(r && g == 0 && got == (long)N, "toy file without the check: %ld: %s", got, e.msg);
    rt_tr_close(r);
    /* the writer refuses a payload with a wrong flags byte */
    toy_mode = 2;
    CHECK(write_trace_opts(p, &m, a, N, &o, &e) < 0 && strstr(e.msg, "does not fit the format"),
          "wrong flags byte accepted: %s", e.msg);
    toy_mode = 0;
    /* and a maker whose parameters the header cannot hold */
    rt_tr_payload_ops badp = toy_ops;
    badp.params.line = 48;
    o.payload = &badp;
    CHECK(!rt_tr_create_opts(p, &m, &o, &e) && strstr(e.msg, "impossible parameters (line 48"),
          "impossible parameters accepted: %s", e.msg);
    free(a);
}

/* ---- classes beyond the base ten ---- */

/* The footer stores ten classes unless a later class is referenced, then
 * up to the highest referenced: a trace of the base classes keeps its
 * 268-byte footer (and so its bytes); a count out of 10..13 is refused. */
static void test_later_classes(void)
{
    rt_tr_meta m;
    fill_meta(&m);
    const size_t N = 3000;
    rt_access *a = random_stream(N);
    for (size_t i = 0; i < N; i++) a[i].cls %= RT_NCLASS_V1;
    const char *p = check_path("cls.rtt");
    rt_err e = {0};
    static const struct { int cls; unsigned nc; } c[] = {
        {-1, 10}, {RT_CLS_TLAS, 11}, {RT_CLS_INST, 12}, {RT_CLS_ALPHA, 13}};
    for (int k = 0; k < 4; k++) {
        if (c[k].cls >= 0) a[N / 2].cls = (uint8_t)c[k].cls;
        CHECK(write_trace(p, &m, a, N, 6, 1000, &e) == 0, "write (class %d): %s", c[k].cls, e.msg);
        size_t n = 0;
        unsigned char *b = slurp(p, &n);
        size_t fl = 28 + 24 * (size_t)c[k].nc;
        CHECK(b && n > fl && !memcmp(b + n - fl, "RTND", 4) && b[n - fl + 4] == c[k].nc,
              "class %d: footer of %u classes (%zu bytes) not found", c[k].cls, c[k].nc, fl);
        int mism = 0;
        rt_tr_totals t;
        long got = read_all(p, 4096, a, N, &mism, &e, &t);
        CHECK(got == (long)N && !mism && (c[k].cls < 0 || t.refs[c[k].cls] == 1), "class %d: read %ld: %s",
              c[k].cls, got, e.msg);
        if (k == 0 && b && n > fl) { /* a class count out of range, with a valid CRC */
            unsigned char *f = malloc(n);
            memcpy(f, b, n);
            le32(f + n - fl + 4, 14);
            le32(f + n - 4, (uint32_t)crc32(0, f + n - fl, (uInt)(fl - 4)));
            spit(p, f, n);
            char msg[512];
            CHECK(rejected(p, msg, sizeof msg) && strstr(msg, "14 classes, expected 10..13"), "nc 14: %s", msg);
            free(f);
        }
        free(b);
    }
    free(a);
}

int main(int argc, char **argv)
{
    if (argc == 3 && !strcmp(argv[1], "--synthetic")) return synthetic(argv[2]);
    if (!check_tmpdir("test_trace")) return perror("mkdtemp"), 1;
    double t0 = rt_now();
    test_round_trip(0);
    test_round_trip(5);
    test_round_trip(RT_TR_MAX_GENERATION);
    test_corruption(0);
    test_corruption(3);
    test_generations();
    test_interrupted();
    test_deterministic();
    test_oom();
    test_opaque_payload();
    test_later_classes();
    check_rmdir();
    fprintf(stderr, "test_trace: %d failures (%.1f s)\n", failures, rt_now() - t0);
    return failures ? 1 : 0;
}
