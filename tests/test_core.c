/* test_core.c -- Hilbert order, EXR round trip, memory model, size parsing,
 * light lists: the small core pieces, each against a hand-checked answer.
 *
 * `test_core --exr-pixel FILE X Y` prints pixel (X, Y) of an EXR as
 * "R G B Z nodes tests" and `test_core --exr-sums FILE` the sums of the
 * nodes and tests channels, for tests/render_cli.sh (the shell has no EXR
 * reader). */
#include "check.h"
#include "hilbert.h"
#include "image.h"
#include "memmodel.h"
#include "rt.h"
#include "tracer.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

static void test_hilbert(void)
{
    static const int sizes[][2] = {{1, 1}, {2, 2}, {3, 5}, {7, 3}, {64, 64}, {100, 37}, {1, 257}, {513, 2}};
    for (size_t s = 0; s < sizeof sizes / sizeof sizes[0]; s++) {
        int W = sizes[s][0], H = sizes[s][1];
        uint32_t *order = calloc((size_t)W * H, sizeof *order);
        unsigned char *seen = calloc((size_t)W * H, 1);
        rt_hilbert_order(W, H, order);
        int dup = 0;
        for (int i = 0; i < W * H; i++) {
            if (order[i] >= (uint32_t)(W * H) || seen[order[i]]) dup++;
            else seen[order[i]] = 1;
        }
        int missing = 0;
        for (int i = 0; i < W * H; i++) missing += !seen[i];
        CHECK(!dup && !missing, "hilbert %dx%d: %d duplicates, %d missing", W, H, dup, missing);
        free(order);
        free(seen);
    }
    /* The blocked order equals rt_hilbert_d2xy of every d, pixels outside
     * the image skipped (the definition), on squares, strips and odd sizes. */
    static const int ref_sizes[][2] = {{1, 1}, {1, 2}, {2, 1}, {3, 3},   {4, 4},    {5, 17},  {16, 16}, {17, 16},
                                       {31, 33}, {64, 1}, {100, 37}, {1, 257}, {513, 2}, {256, 256}, {1024, 1024},
                                       {1000, 3}, {2048, 24}};
    for (size_t s = 0; s < sizeof ref_sizes / sizeof ref_sizes[0]; s++) {
        const int W = ref_sizes[s][0], H = ref_sizes[s][1];
        uint32_t *order = calloc((size_t)W * H, sizeof *order), n = 1;
        rt_hilbert_order(W, H, order);
        while (n < (uint32_t)W || n < (uint32_t)H) n *= 2;
        size_t k = 0, bad = 0;
        for (uint64_t d = 0; d < (uint64_t)n * n; d++) {
            uint32_t x, y;
            rt_hilbert_d2xy(n, d, &x, &y);
            if (x < (uint32_t)W && y < (uint32_t)H) bad += order[k++] != y * (uint32_t)W + x;
        }
        CHECK(k == (size_t)W * H && bad == 0, "hilbert %dx%d: %zu of %zu pixels out of d2xy's order", W, H, bad, k);
        free(order);
    }
    /* On a power-of-two square consecutive pixels are 4-neighbours. */
    int W = 32;
    uint32_t order[32 * 32];
    rt_hilbert_order(W, W, order);
    int jumps = 0;
    for (int i = 1; i < W * W; i++) {
        int dx = abs((int)(order[i] % W) - (int)(order[i - 1] % W));
        int dy = abs((int)(order[i] / W) - (int)(order[i - 1] / W));
        jumps += dx + dy != 1;
    }
    CHECK(jumps == 0, "hilbert 32x32 has %d non-adjacent steps", jumps);
    /* The curve of side 2 is (0,0) (0,1) (1,1) (1,0). */
    uint32_t x, y;
    rt_hilbert_d2xy(2, 0, &x, &y); CHECK(x == 0 && y == 0, "d=0");
    rt_hilbert_d2xy(2, 1, &x, &y); CHECK(x == 0 && y == 1, "d=1");
    rt_hilbert_d2xy(2, 2, &x, &y); CHECK(x == 1 && y == 1, "d=2");
    rt_hilbert_d2xy(2, 3, &x, &y); CHECK(x == 1 && y == 0, "d=3");
}

static void test_exr(void)
{
    rt_err e = {0};
    rt_image *im = rt_image_new(37, 19, &e);
    CHECK(im != NULL, "image_new: %s", e.msg);
    if (!im) return;
    for (int i = 0; i < 37 * 19; i++) {
        im->rgb[3 * i] = (float)i * 0.25f;
        im->rgb[3 * i + 1] = -1.0f / (float)(i + 1);
        im->rgb[3 * i + 2] = 1e30f;
        im->nodes[i] = (float)(i % 97);
        im->tests[i] = (float)(i * 3);
        im->depth[i] = (i % 5) ? (float)i : INFINITY;
    }
    char path[] = "/tmp/rt_test_exr_XXXXXX";
    int fd = mkstemp(path);
    close(fd);
    rt_exr_attr a[] = {{"raytraffic:test", "yes"}};
    CHECK(rt_exr_write(path, im, a, 1, &e) == 0, "exr write: %s", e.msg);
    rt_image *back = rt_exr_read(path, &e);
    CHECK(back != NULL, "exr read: %s", e.msg);
    if (back) {
        size_t n = 37 * 19;
        CHECK(back->W == 37 && back->H == 19, "size %dx%d", back->W, back->H);
        CHECK(!memcmp(back->rgb, im->rgb, n * 3 * sizeof(float)), "rgb differs");
        CHECK(!memcmp(back->nodes, im->nodes, n * sizeof(float)), "nodes differ");
        CHECK(!memcmp(back->tests, im->tests, n * sizeof(float)), "tests differ");
        CHECK(!memcmp(back->depth, im->depth, n * sizeof(float)), "depth differs");
    }
    rt_image_free(back);
    /* A file that is not an EXR gives an error naming it. */
    FILE *f = fopen(path, "wb");
    fputs("not an exr", f);
    fclose(f);
    back = rt_exr_read(path, &e);
    CHECK(back == NULL && strstr(e.msg, path), "bad exr accepted or message lacks path: %s", e.msg);
    rt_image_free(back);
    CHECK(rt_exr_write("/nonexistent-dir/x.exr", im, NULL, 0, &e) < 0 && strstr(e.msg, "/nonexistent-dir"),
          "unwritable path: %s", e.msg);
    unlink(path);
    rt_image_free(im);
}

static void test_memmodel(void)
{
    rt_layout L;
    rt_err e;
    rt_mm_init(&L);
    int a = rt_mm_add(&L, "a", RT_CLS_NODE, 8, 1000, &e);
    int b = rt_mm_add(&L, "b", RT_CLS_TRI, 36, 3, &e);
    int c = rt_mm_add(&L, "c", RT_CLS_RAY, 32, 0, &e);
    CHECK(a == 0 && b == 1 && c == 2, "indices");
    CHECK(L.r[0].base == RT_MM_BASE, "first base");
    CHECK(L.r[1].base == RT_MM_BASE + 8192, "second base %llx", (unsigned long long)L.r[1].base);
    CHECK(L.r[2].base == L.r[1].base + 4096, "third base");
    CHECK(rt_mm_addr(&L, b, 2) == L.r[1].base + 72, "record address");
    CHECK(rt_mm_find(&L, "c") == 2 && rt_mm_find(&L, "zz") == -1, "find");
    CHECK(rt_class_group(RT_CLS_SHADE) == RT_GROUP_GEOMETRY && rt_class_group(RT_CLS_QUEUE) == RT_GROUP_RAY &&
              rt_class_group(RT_CLS_FB) == RT_GROUP_OTHER,
          "groups");
    for (int k = 0; k < RT_NCLASS; k++) CHECK(rt_class_from_name(rt_class_name(k)) == k, "class name %d", k);
    /* the checker accepts what rt_mm_add builds and names each broken invariant */
    CHECK(rt_mm_check(&L, &e) == 0, "check: %s", e.msg);
    static const struct {
        const char *what;
        int reg;
        int field; /* 0 base += 8, 1 base = previous base, 2 recsize 0, 3 class, 4 name = "a", 5 next */
    } bad[] = {{"aligned", 1, 0, }, {"overlaps", 2, 1}, {"zero record size", 1, 2}, {"class", 2, 3},
               {"named twice", 2, 4}, {"does not start", 0, 0}, {"next free", 0, 5}};
    for (size_t k = 0; k < sizeof bad / sizeof bad[0]; k++) {
        rt_layout M = L;
        rt_region *r = &M.r[bad[k].reg];
        switch (bad[k].field) {
        case 0: r->base += 8; break;
        case 1: r->base = M.r[bad[k].reg - 1].base; break;
        case 2: r->recsize = 0; break;
        case 3: r->cls = RT_NCLASS; break;
        case 4: strcpy(r->name, "a"); break;
        default: M.next = M.r[M.n - 1].base; break;
        }
        e.msg[0] = 0;
        CHECK(rt_mm_check(&M, &e) < 0 && strstr(e.msg, bad[k].what), "broken layout (%s) accepted: %s", bad[k].what,
              e.msg);
    }
}

static void test_parsers(void)
{
    uint64_t v;
    CHECK(rt_parse_size("64K", &v) == 0 && v == 65536, "64K");
    CHECK(rt_parse_size("4M", &v) == 0 && v == 4194304, "4M");
    CHECK(rt_parse_size("1kb", &v) == 0 && v == 1024, "1kb");
    CHECK(rt_parse_size("100", &v) == 0 && v == 100, "100");
    CHECK(rt_parse_size("-1", &v) < 0 && rt_parse_size("1X", &v) < 0 && rt_parse_size("", &v) < 0, "bad sizes");
    CHECK(rt_parse_size("99999999999999999999", &v) < 0 && rt_parse_size("17179869184G", &v) < 0, "overflow");
    unsigned m;
    CHECK(rt_parse_lights("all", &m) == 0 && m == 7, "all");
    CHECK(rt_parse_lights("none", &m) == 0 && m == 0, "none");
    CHECK(rt_parse_lights("0,2", &m) == 0 && m == 5, "0,2");
    CHECK(rt_parse_lights("3,17", &m) == 0 && m == (1u << 3 | 1u << 17), "3,17 (whether they exist: at setup)");
    CHECK(rt_parse_lights("32", &m) < 0 && rt_parse_lights("0,", &m) < 0 && rt_parse_lights("a", &m) < 0, "bad");
    CHECK(fabs(rt_dtan(0.5) - 0.54630248984379051) < 1e-15, "dtan");
    CHECK(fabs(rt_dtan(1.2) - 2.5721516221263188) < 1e-13, "dtan 1.2");
}

/* The --exr-pixel and --exr-sums modes; exit 1 if the file does not read. */
static int exr_query(int argc, char **argv)
{
    rt_err e = {0};
    rt_image *im = rt_exr_read(argv[2], &e);
    if (!im) return fprintf(stderr, "%s\n", e.msg), 1;
    int rc = 0;
    if (!strcmp(argv[1], "--exr-sums")) {
        double nodes = 0, tests = 0;
        for (size_t i = 0; i < (size_t)im->W * im->H; i++) {
            nodes += im->nodes[i];
            tests += im->tests[i];
        }
        printf("%.0f %.0f\n", nodes, tests);
    } else if (argc == 5) {
        int x = atoi(argv[3]), y = atoi(argv[4]);
        if (x < 0 || y < 0 || x >= im->W || y >= im->H) {
            fprintf(stderr, "pixel (%d, %d) outside %dx%d\n", x, y, im->W, im->H);
            rc = 1;
        } else {
            size_t i = (size_t)y * im->W + x;
            printf("%.9g %.9g %.9g %.9g %.9g %.9g\n", im->rgb[3 * i], im->rgb[3 * i + 1], im->rgb[3 * i + 2],
                   im->depth[i], im->nodes[i], im->tests[i]);
        }
    } else {
        fprintf(stderr, "usage: test_core --exr-pixel FILE X Y | --exr-sums FILE\n");
        rc = 1;
    }
    rt_image_free(im);
    return rc;
}

int main(int argc, char **argv)
{
    if (argc > 2 && (!strcmp(argv[1], "--exr-pixel") || !strcmp(argv[1], "--exr-sums"))) return exr_query(argc, argv);
    test_hilbert();
    test_exr();
    test_memmodel();
    test_parsers();
    if (failures) fprintf(stderr, "%d failure(s)\n", failures);
    return failures ? 1 : 0;
}
