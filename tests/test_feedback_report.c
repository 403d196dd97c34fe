/*
 * test_feedback_report.c -- `report --figure feedback` against hand-made
 * runs whose numbers were worked out by hand.
 *
 * The database: a knot feedback run (whitted depth 2, one light, 16x16,
 * 400 rays traced) at 4 KB and 64 KB; dynamic runs scheduled for each size
 * (and one of another depth that must not be paired); two stream-multipass
 * runs, grid_min=16 stored first, so the default-grid feedback run must
 * pick the second; a grid_min=16 feedback run that must pick the first; a
 * multipass and a feedback run with write-allocate record stores, which
 * pair with each other only; a
 * cornell raycast feedback run with nothing to compare. Checked: the class
 * table, bytes per ray and per generation of the three designs, the
 * finding sentence, CSV, the scene filter, the error without runs and the
 * plot's data file.
 */
#include "analysis.h"
#include "db.h"
#include "memmodel.h"
#include "check.h"

#include <sqlite3.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef struct row {
    uint64_t size;
    int cls;
    uint64_t bytes;
} row;

static void store(rt_db *db, const char *scene, const char *tracer, int W, unsigned lights, uint64_t sched,
                  const char *params, const char *stats, const row *rows, size_t n)
{
    rt_db_traffic t[16];
    rt_err e = {0};
    for (size_t i = 0; i < n; i++) {
        memset(&t[i], 0, sizeof t[i]);
        t[i].size = rows[i].size;
        t[i].line = 64;
        t[i].policy = "wb-wa";
        t[i].cls = rows[i].cls;
        t[i].traffic_bytes = rows[i].bytes;
        t[i].accesses = rows[i].bytes / 64 + 1;
        t[i].read_misses = rows[i].bytes / 64;
    }
    rt_db_run r;
    memset(&r, 0, sizeof r);
    r.scene = scene;
    r.scene_hash = !strcmp(scene, "knot") ? 0xabc : 0xdef;
    r.ntri = 1024;
    r.tracer = tracer;
    r.W = r.H = W;
    r.lights = lights;
    r.sched_size = sched;
    r.params = params;
    r.command = "test_feedback_report";
    r.stats = stats;
    CHECK(rt_db_store_run(db, &r, t, n, NULL, &e) == 0, "store %s: %s", tracer, e.msg);
}

typedef struct mem {
    char *buf;
    size_t len;
    FILE *f;
} mem;

/* What rt_report_feedback writes (caller frees); rc into *rc. */
static char *report(sqlite3 *h, const char *scene, int csv, const rt_plot_opts *p, int *rc, rt_err *e)
{
    mem m = {NULL, 0, NULL};
    m.f = open_memstream(&m.buf, &m.len);
    if (!m.f) exit(1);
    *rc = rt_report_feedback(h, scene, csv, p, m.f, e);
    fclose(m.f);
    if (!m.buf) exit(1); /* out of memory: nothing can be checked */
    return m.buf;
}

static void build(rt_db *db)
{
    enum { K4 = 4096, K64 = 65536 };
    /* 400 rays; 4K: total 200000, stream 128000 = 64.0%, 320.0 B/ray, 160.0 per generation;
     * 64K: total 122000, stream 102400 = 83.9%, 256.0 B/ray, 128.0 per generation */
    const row fb[] = {{K4, RT_CLS_STREAM, 128000}, {K4, RT_CLS_NODE, 40000}, {K4, RT_CLS_INDEX, 8000},
                      {K4, RT_CLS_TRI, 16000},     {K4, RT_CLS_SHADE, 4000}, {K4, RT_CLS_FB, 4000},
                      {K64, RT_CLS_STREAM, 102400}, {K64, RT_CLS_NODE, 10000}, {K64, RT_CLS_INDEX, 2000},
                      {K64, RT_CLS_TRI, 4000},     {K64, RT_CLS_SHADE, 1000}, {K64, RT_CLS_FB, 2600}};
    const char *rays400 = "rays_primary=256 rays_shadow=60 nodes=9 rays_secondary=84";
    const char *rays500 = "rays_primary=256 rays_shadow=100 rays_secondary=144";
    store(db, "knot", "feedback", 16, 1, 0, "mode=whitted depth=2", rays400, fb, 12);
    /* scheduled for 4K: ray group 20000 + 30000 + 2000 + 8000 = 60000 -> 150.0 B/ray; its
     * 64K row is not the run scheduled there; tri is not ray state */
    const row d4[] = {{K4, RT_CLS_RAY, 20000}, {K4, RT_CLS_QUEUE, 30000}, {K4, RT_CLS_QTABLE, 2000},
                      {K4, RT_CLS_HIT, 8000},  {K4, RT_CLS_TRI, 99999},   {K64, RT_CLS_RAY, 777777}};
    store(db, "knot", "dynamic", 16, 1, K4, "qorder=fullest threads=4 mode=whitted depth=2", rays400, d4, 6);
    /* scheduled for 64K: 4000 + 6000 + 2000 = 12000 -> 30.0 B/ray */
    const row d64[] = {{K64, RT_CLS_RAY, 4000}, {K64, RT_CLS_QUEUE, 6000}, {K64, RT_CLS_HIT, 2000}};
    store(db, "knot", "dynamic", 16, 1, K64, "qorder=fullest threads=4 mode=whitted depth=2", rays400, d64, 3);
    /* another mode: never paired */
    const row d3[] = {{K4, RT_CLS_RAY, 9999999}, {K64, RT_CLS_RAY, 9999999}};
    store(db, "knot", "dynamic", 16, 1, K4, "qorder=fullest threads=4 mode=whitted depth=3", rays400, d3, 2);
    /* multipass with write-allocate record stores, stored before the others: only the
     * write-allocate feedback run pairs with it: 4K 1200000 / 500 = 2400.0 */
    const row mwa[] = {{K4, RT_CLS_STREAM, 1200000}};
    store(db, "knot", "stream-multipass", 16, 1, 0, "record_stores=write-allocate mode=whitted depth=2", rays500, mwa,
          1);
    /* multipass, grid_min=16 first: 4K 400000 / 500 = 800.0 */
    const row m16[] = {{K4, RT_CLS_STREAM, 400000}, {K4, RT_CLS_NODE, 5}};
    store(db, "knot", "stream-multipass", 16, 1, 0, "grid_min=16 mode=whitted depth=2", rays500, m16, 2);
    /* multipass, default grid: 800000 / 500 = 1600.0, 80000 / 500 = 160.0 */
    const row m[] = {{K4, RT_CLS_STREAM, 800000}, {K64, RT_CLS_STREAM, 80000}, {K64, RT_CLS_FB, 123}};
    store(db, "knot", "stream-multipass", 16, 1, 0, "mode=whitted depth=2", rays500, m, 3);
    /* feedback grid_min=16 at 4K: 64000 / 400 = 160.0 */
    const row f16[] = {{K4, RT_CLS_STREAM, 64000}, {K4, RT_CLS_NODE, 64000}};
    store(db, "knot", "feedback", 16, 1, 0, "grid_min=16 mode=whitted depth=2", rays400, f16, 2);
    /* feedback with write-allocate records at 4K: 96000 / 400 = 240.0 */
    const row fwa[] = {{K4, RT_CLS_STREAM, 96000}};
    store(db, "knot", "feedback", 16, 1, 0, "record_stores=write-allocate mode=whitted depth=2", rays400, fwa, 1);
    /* cornell raycast, 64 rays, one generation: 6400 / 64 = 100.0 */
    const row c[] = {{K4, RT_CLS_STREAM, 6400}};
    store(db, "cornell", "feedback", 8, 0, 0, "", "rays_primary=64", c, 1);
}

int main(void)
{
    char dir[] = "/tmp/rt_test_fbreport_XXXXXX";
    if (!mkdtemp(dir)) return 1;
    char path[256];
    snprintf(path, sizeof path, "%s/f.db", dir);
    rt_err e = {0};
    rt_db *db = rt_db_open(path, &e);
    CHECK(db, "rt_db_open: %s", e.msg);
    if (!db) return 1;
    build(db);
    sqlite3 *h = rt_db_handle(db);
    int rc;

    char *txt = report(h, NULL, 0, NULL, &rc, &e);
    CHECK(rc == 0, "report: %s", e.msg);
    static const char *const want[] = {
        /* MB: 128000 / 2^20 = 0.122, 40000 -> 0.038, 8000 -> 0.008, 16000 -> 0.015, 4000 -> 0.004 */
        "### knot 16x16 lights 0 mode=whitted depth=2: traffic per class (MB = 2^20 bytes)\n\n"
        "| cache | stream (vb) | node (grid) | index (list) | tri | shade | fb | total | stream share |\n"
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|\n"
        "| 4 KB | 0.122 | 0.038 | 0.008 | 0.015 | 0.004 | 0.004 | 0.191 | 64.0% |\n"
        "| 64 KB | 0.098 | 0.010 | 0.002 | 0.004 | 0.001 | 0.002 | 0.116 | 83.9% |\n",
        "Rays traced (primary + shadow + secondary): dynamic 400, stream-multipass 500, feedback 400; "
        "2 generations, so per generation = per ray / 2.\n",
        "| 4 KB | 150.0 | 1600.0 | 320.0 | 75.0 | 800.0 | 160.0 |\n"
        "| 64 KB | 30.0 | 160.0 | 256.0 | 15.0 | 80.0 | 128.0 |\n",
        /* 256 / 30 = 8.53, 256 / 160 = 1.60 */
        "At 64 KB the 64-byte records move 256.0 B per traced ray (83.9% of the run's traffic); 8.53x the 30.0 B of "
        "Navrátil queued rays (dynamic); 1.60x the 160.0 B of Purcell state (stream-multipass).\n",
        /* grid_min=16 pairs with the grid_min=16 multipass run: 160 / 150 = 1.07, 160 / 800 = 0.20 */
        "| 4 KB | 150.0 | 800.0 | 160.0 | 75.0 | 400.0 | 80.0 |\n",
        /* record stores pair with record stores: 2400.0, half 1200.0 */
        "| 4 KB | 150.0 | 2400.0 | 240.0 | 75.0 | 1200.0 | 120.0 |\n",
        "(50.0% of the run's traffic); 1.07x the 150.0 B of Navrátil queued rays (dynamic); 0.20x the 800.0 B",
        /* nothing to compare, one generation */
        "### cornell 8x8 lights none: ray-state bytes per traced ray\n\nRays traced (primary + shadow + secondary): "
        "dynamic —, stream-multipass —, feedback 64; 1 generation, so per generation = per ray / 1.\n",
        "| 4 KB | — | — | 100.0 | — | — | 100.0 |\n",
        "(100.0% of the run's traffic); no dynamic run to compare; no stream-multipass run to compare.\n",
    };
    for (size_t i = 0; i < sizeof want / sizeof *want; i++)
        CHECK(strstr(txt, want[i]), "report lacks\n%s\nin\n%s", want[i], txt);
    /* order: scene name, then params ("grid_min=16 ..." before "mode=...") */
    char *a = strstr(txt, "### cornell"), *b = strstr(txt, "### knot 16x16 lights 0 grid_min"),
         *c = strstr(txt, "### knot 16x16 lights 0 mode");
    CHECK(a && b && c && a < b && b < c, "run order");
    free(txt);

    txt = report(h, NULL, 1, NULL, &rc, &e);
    CHECK(rc == 0, "csv: %s", e.msg);
    CHECK(strstr(txt, "\"knot 16x16 lights 0 mode=whitted depth=2\",4096,64,0,wb-wa,128000,40000,8000,16000,"
                             "4000,4000,200000\n"), "csv classes:\n%s", txt);
    CHECK(strstr(txt, "\"knot 16x16 lights 0 mode=whitted depth=2\",65536,64,0,wb-wa,400,500,400,30.00,160.00,"
                             "256.00,15.00,80.00,128.00\n"), "csv per ray:\n%s", txt);
    CHECK(strstr(txt, "\"cornell 8x8 lights none\",4096,64,0,wb-wa,,,64,,,100.00,,,100.00\n"), "csv dashes:\n%s", txt);
    free(txt);

    txt = report(h, "cornell", 0, NULL, &rc, &e);
    CHECK(rc == 0 && strstr(txt, "### cornell") && !strstr(txt, "### knot"), "scene filter:\n%s", txt);
    free(txt);
    txt = report(h, "room", 0, NULL, &rc, &e);
    CHECK(rc < 0 && strstr(e.msg, "no runs of the feedback tracer on room"), "no runs: %d %s", rc, e.msg);
    free(txt);

    /* the plot's data file (no gnuplot: data and script only) */
    char pdir[300], dat[400], line[512];
    snprintf(pdir, sizeof pdir, "%s/plots", dir);
    rt_plot_opts po = {pdir, NULL, NULL};
    txt = report(h, "knot", 0, &po, &rc, &e);
    CHECK(rc == 0, "plot: %s", e.msg);
    free(txt);
    snprintf(dat, sizeof dat, "%s/feedback-knot_16x16_lights_0_mode-whitted_depth-2.dat", pdir);
    FILE *f = fopen(dat, "r");
    CHECK(f, "no %s", dat);
    if (f) {
        CHECK(fgets(line, sizeof line, f) && line[0] == '#', "dat header");
        /* MB with %.6g: 128000 / 2^20 = 0.12207, 40000 -> 0.038147, ...; then 150, 1600, 320 B/ray */
        CHECK(fgets(line, sizeof line, f) &&
                  !strcmp(line, "4 0.12207 0.038147 0.00762939 0.0152588 0.0038147 0.0038147 150 1600 320\n"),
              "dat 4K: %s", line);
        CHECK(fgets(line, sizeof line, f) &&
                  !strcmp(line, "64 0.0976562 0.00953674 0.00190735 0.0038147 0.000953674 0.00247955 30 160 256\n"),
              "dat 64K: %s", line);
        fclose(f);
    }
    snprintf(dat, sizeof dat, "%s/feedback-knot_16x16_lights_0_mode-whitted_depth-2.gp", pdir);
    CHECK((f = fopen(dat, "r")) != NULL, "no %s", dat);
    if (f) fclose(f);

    rt_db_close(db);
    if (check_rm_tree(dir) != 0) fprintf(stderr, "could not remove %s\n", dir);
    return failures ? 1 : 0;
}
