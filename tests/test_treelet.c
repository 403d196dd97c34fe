/*
 * test_treelet.c -- the treelet scheduler (tracegen/treelet.c) beyond the
 * conformance test's image identity:
 *   - its invariants (T1-T6) checked between steps (rt_job.check) on every
 *     width, in every mode, with both queue orders, a bounded ray window,
 *     pixel subsampling and the triangles counted in the budget, each
 *     image equal to the recursive tracer's on the same BVH with the same
 *     node visits and triangle tests;
 *   - per-region traffic derived from the statistics: a queue entry
 *     written per enqueue and a block read per 64 entries processed, the
 *     queue table updated per enqueue and per queue event, ray records
 *     written per ray started, read per visit and written per suspension,
 *     stack bytes written and read as counted, node and triangle reads
 *     per visit and test;
 *   - a budget larger than the tree: one treelet, and exactly the
 *     recursive tracer's geometry references (node and triangle reads) in
 *     another order (the same multiset).
 */
#include "scene_load.h"
#include "check.h"
#include "run.h"

#include <inttypes.h>

#define IMG 16

typedef struct acc_list {
    const rt_layout *L;
    rt_access *a;
    size_t n, cap;
} acc_list;

static int list_put(rt_sink *s, const rt_access *a, size_t n)
{
    acc_list *l = s->ctx;
    if (l->n + n > l->cap) {
        size_t c = (l->n + n) * 2;
        rt_access *p = realloc(l->a, c * sizeof *p);
        if (!p) return -1;
        l->a = p;
        l->cap = c;
    }
    memcpy(l->a + l->n, a, n * sizeof *a);
    l->n += n;
    return 0;
}

/* Traced run of tracer on sc into *l; st and the job's layout copied out. */
static int run(rt_scene *sc, const char *tracer, const rt_render_opts *o, int check, acc_list *l, rt_run_stats *st,
               rt_layout *L, rt_image **img)
{
    rt_err e = {0};
    rt_job j;
    if (rt_job_setup_borrowed(&j, sc, NULL, tracer, o, &e) < 0) {
        CHECK(0, "setup %s: %s", tracer, e.msg);
        return -1;
    }
    j.check = check;
    rt_image *im = rt_image_new(o->W, o->H, &e);
    rt_sink s = {list_put, l};
    int rc = im ? rt_job_run(&j, l ? &s : NULL, im, st, &e) : -1;
    CHECK(rc == 0, "run %s: %s", tracer, e.msg);
    if (L) *L = j.L;
    if (img) *img = im;
    else rt_image_free(im);
    rt_job_free(&j);
    return rc;
}

/* Value of key k in a "k=v k=v" string (-1 when absent). */
static double kv(const char *s, const char *k)
{
    size_t n = strlen(k);
    for (const char *p = s; (p = strstr(p, k)); p += n)
        if ((p == s || p[-1] == ' ') && p[n] == '=') return atof(p + n + 1);
    return -1;
}

typedef struct reg_count {
    uint64_t rd, wr, rb;          /* accesses of the region's own class, bytes read */
    uint64_t rd64, wr52, wr56;    /* ... by size (the ray records) */
    uint64_t srd, swr, srb, swb;  /* stack accesses (class stream) and their bytes */
} reg_count;

/* Counts reads and writes per region of L. */
static void per_region(const acc_list *l, const rt_layout *L, reg_count *c)
{
    memset(c, 0, sizeof *c * RT_MM_MAX_REGIONS);
    for (size_t i = 0; i < l->n; i++) {
        const rt_access *a = &l->a[i];
        for (int r = 0; r < L->n; r++) {
            const rt_region *g = &L->r[r];
            if (a->addr < g->base || a->addr >= g->base + g->recsize * g->count) continue;
            if (a->cls == RT_CLS_STREAM) {
                if (a->write) {
                    c[r].swr++;
                    c[r].swb += a->size;
                } else {
                    c[r].srd++;
                    c[r].srb += a->size;
                }
            } else if (a->write) {
                c[r].wr++;
                c[r].wr52 += a->size == 52;
                c[r].wr56 += a->size == 56;
            } else {
                c[r].rd++;
                c[r].rb += a->size;
                c[r].rd64 += a->size == 64;
            }
            break;
        }
    }
}

static int cmp_acc(const void *x, const void *y)
{
    const rt_access *a = x, *b = y;
    if (a->addr != b->addr) return a->addr < b->addr ? -1 : 1;
    return (int)a->size - (int)b->size;
}

/* The node and triangle reads of l, sorted. */
static size_t geometry(const acc_list *l, rt_access *out)
{
    size_t m = 0;
    for (size_t i = 0; i < l->n; i++)
        if ((l->a[i].cls == RT_CLS_NODE || l->a[i].cls == RT_CLS_TRI) && !l->a[i].write) {
            out[m] = l->a[i];
            out[m].gen = 0;
            m++;
        }
    qsort(out, m, sizeof *out, cmp_acc);
    return m;
}

static void test_checked(rt_scene *sc)
{
    static const int modes[] = {RT_MODE_RAYCAST, RT_MODE_SHADOW, RT_MODE_WHITTED, RT_MODE_PATH};
    static const int kinds[] = {RT_ACCEL_BVH2, RT_ACCEL_BVH4, RT_ACCEL_BVH8};
    int runs = 0;
    for (size_t k = 0; k < 3; k++)
        for (size_t m = 0; m < 4; m++)
            for (int variant = 0; variant < 4; variant++) {
                rt_render_opts o;
                rt_render_default_opts(&o);
                o.W = o.H = IMG;
                o.mode = modes[m];
                o.lights = modes[m] == RT_MODE_RAYCAST ? 0 : 3;
                o.depth = 3;
                o.bounces = 2;
                o.accel = kinds[k];
                o.sched_size = 4096;
                if (variant == 1) {
                    o.qorder = RT_QORDER_TREE;
                    o.ray_window = 37;
                } else if (variant == 2) {
                    o.treelet_tris = 1;
                    o.sched_size = 2048;
                } else if (variant == 3) { /* pixel subsampling, windows of 5 traced pixels */
                    o.subsample = 3;
                    o.subtile = 4;
                    o.ray_window = 5;
                }
                rt_run_stats st, sr;
                rt_image *got = NULL, *want = NULL;
                acc_list l = {0};
                rt_layout L;
                if (run(sc, "treelet", &o, 1, &l, &st, &L, &got) < 0) continue;
                runs++;
                rt_render_opts ro = o;
                ro.qorder = RT_QORDER_FULLEST;
                ro.ray_window = 0;
                ro.treelet_tris = 0;
                if (run(sc, "recursive", &ro, 0, NULL, &sr, NULL, &want) == 0) {
                    CHECK(!memcmp(got->rgb, want->rgb, sizeof(float) * 3 * IMG * IMG),
                          "accel %d mode %d variant %d: image differs from the recursive tracer's", kinds[k], modes[m],
                          variant);
                    CHECK(st.nodes == sr.nodes && st.tests == sr.tests,
                          "accel %d mode %d variant %d: %" PRIu64 " visits, %" PRIu64 " tests; recursive %" PRIu64
                          ", %" PRIu64,
                          kinds[k], modes[m], variant, st.nodes, st.tests, sr.nodes, sr.tests);
                }
                /* traffic per region from the statistics */
                reg_count c[RT_MM_MAX_REGIONS];
                per_region(&l, &L, c);
                const double enq = kv(st.extra, "enqueues"), vis = kv(st.extra, "visits"),
                             susp = kv(st.extra, "suspends"), sw = kv(st.extra, "stack_writes"),
                             sr_ = kv(st.extra, "stack_reads"), ev = kv(st.extra, "queue_events"),
                             sec = rt_render_secondary(&o) ? kv(st.extra, "rays_secondary") : 0;
                const int rq = rt_mm_find(&L, "tl.queues"), rr = rt_mm_find(&L, "tl.rays"),
                          rs = rt_mm_find(&L, "tl.stack"), rqt = rt_mm_find(&L, "tl.qtable");
                CHECK(rq >= 0 && rr >= 0 && rs >= 0 && rqt >= 0, "regions missing");
                if (rq < 0 || rr < 0 || rs < 0 || rqt < 0) goto next;
                CHECK(enq > 0 && enq == vis, "enqueues %.0f, visits %.0f", enq, vis);
                const double qbr = kv(st.extra, "queue_block_reads");
                CHECK((double)c[rq].wr == enq && (double)c[rq].rd == qbr && (double)c[rq].rb == 4 * vis && qbr >= ev &&
                          qbr <= ev + vis / 64,
                      "queue entries: %" PRIu64 " written, %" PRIu64 " reads of %" PRIu64 " bytes; enqueues %.0f "
                      "visits %.0f block reads %.0f events %.0f",
                      c[rq].wr, c[rq].rd, c[rq].rb, enq, vis, qbr, ev);
                CHECK(c[rqt].rd == 0 && (double)c[rqt].wr == enq + ev,
                      "queue table: %" PRIu64 " reads, %" PRIu64 " writes; enqueues %.0f events %.0f", c[rqt].rd,
                      c[rqt].wr, enq, ev);
                const double started = (double)(st.rays_primary + st.rays_shadow) + sec;
                const uint64_t wst = k == 0 ? c[rr].wr52 : c[rr].wr56; /* state and root entry */
                CHECK((double)wst == started && (double)c[rr].rd64 == vis && c[rr].rd == c[rr].rd64 &&
                          (double)(c[rr].wr - wst) == susp,
                      "ray records: %" PRIu64 " written at the start (rays %.0f), %" PRIu64 " read (visits %.0f), %" PRIu64
                      " suspensions written (%.0f)",
                      wst, started, c[rr].rd64, vis, c[rr].wr - wst, susp);
                const double esz = k == 0 ? 4 : 8, spills = kv(st.extra, "stack_spills");
                const double refills = kv(st.extra, "stack_refills");
                CHECK((double)c[rs].swb == esz * sw && (double)c[rs].swr == spills && (double)c[rs].srd == refills &&
                          (double)c[rs].srb == esz * sr_ && refills <= sr_ && c[rs].rd + c[rs].wr == 0 &&
                          c[rr].srd + c[rr].swr == 0,
                      "stack: %" PRIu64 " writes of %" PRIu64 " bytes (%.0f entries, %.0f spills), %" PRIu64
                      " reads (%.0f)", c[rs].swr, c[rs].swb, sw, spills, c[rs].srd, sr_);
                if (modes[m] == RT_MODE_RAYCAST)
                    CHECK(sr_ >= sw, "raycast: every spilled stack entry is read back (%.0f written, %.0f read)", sw, sr_);
                uint64_t nodes = 0, tris = 0;
                for (size_t i = 0; i < l.n; i++) {
                    nodes += l.a[i].cls == RT_CLS_NODE;
                    tris += l.a[i].cls == RT_CLS_TRI && !l.a[i].write;
                }
                CHECK(nodes == st.nodes && tris == st.tests, "%" PRIu64 " node reads (%" PRIu64 " visits), %" PRIu64
                      " triangle reads (%" PRIu64 " tests)", nodes, st.nodes, tris, st.tests);
            next:
                free(l.a);
                rt_image_free(got);
                rt_image_free(want);
            }
    CHECK(runs == 48, "%d checked runs", runs);
}

static void test_one_treelet(rt_scene *sc)
{
    static const int modes[] = {RT_MODE_RAYCAST, RT_MODE_SHADOW, RT_MODE_PATH};
    for (int k = RT_ACCEL_BVH2; k <= RT_ACCEL_BVH8; k++)
        for (size_t m = 0; m < 3; m++) {
            rt_render_opts o;
            rt_render_default_opts(&o);
            o.W = o.H = IMG;
            o.mode = modes[m];
            o.lights = modes[m] == RT_MODE_RAYCAST ? 0 : 1;
            o.bounces = 2;
            o.accel = k;
            acc_list a = {0}, b = {0};
            rt_run_stats sa, sb;
            rt_render_opts ot = o;
            ot.gmax = 1ull << 40;
            if (run(sc, "recursive", &o, 0, &a, &sa, NULL, NULL) == 0 &&
                run(sc, "treelet", &ot, 1, &b, &sb, NULL, NULL) == 0) {
                CHECK(kv(sb.extra, "treelets") == 1, "budget above the tree: %s", sb.extra);
                rt_access *ga = malloc((a.n + 1) * sizeof *ga), *gb = malloc((b.n + 1) * sizeof *gb);
                size_t na = ga ? geometry(&a, ga) : 0, nb = gb ? geometry(&b, gb) : 0;
                CHECK(na > 0 && na == nb, "accel %d mode %d: %zu geometry reads, recursive %zu", k, modes[m], nb, na);
                size_t diff = 0;
                for (size_t i = 0; i < na && na == nb; i++) diff += ga[i].addr != gb[i].addr || ga[i].size != gb[i].size;
                CHECK(diff == 0, "accel %d mode %d: %zu geometry references differ", k, modes[m], diff);
                /* and in another order: some stream differs unless one ray only */
                free(ga);
                free(gb);
            }
            free(a.a);
            free(b.a);
        }
}

int main(void)
{
    rt_err e = {0};
    rt_scene *sc = rt_scene_load("cornell:material=mirror", &e);
    CHECK(sc != NULL, "load: %s", e.msg);
    if (!sc) return 1;
    test_checked(sc);
    test_one_treelet(sc);
    rt_scene_free(sc);
    rt_scene *kn = rt_scene_load("knot", &e);
    CHECK(kn != NULL, "load knot: %s", e.msg);
    if (kn) {
        test_one_treelet(kn);
        rt_scene_free(kn);
    }
    return failures ? 1 : 0;
}
