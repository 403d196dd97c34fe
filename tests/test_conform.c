/*
 * test_conform.c -- every registered tracer, in every mode it declares, on
 * every acceleration structure it declares (rt_tracer_all, its traits):
 *   - the image is bit-identical to the reference tracer's (RT_TR_REFERENCE)
 *     on its default structure;
 *   - every recorded access lies in a region of the run's layout, and the
 *     structure's regions (node, index classes) are read as their class;
 *     the access count is the statistics' count;
 *   - the trace file written from the same run reads back with the same
 *     records (count and FNV-1a hash, a streaming store as the plain write
 *     a trace stores) and per-class totals;
 *   - the record stream's hash equals the golden one in
 *     tests/golden/conform.txt (RT_REDO_GOLDEN=1 rewrites it);
 *   - the run's structure passes its checker.
 * A tracer added to the registry is covered without editing this file;
 * only the golden file gains its lines.
 */
#include "scene_load.h"
#include "check.h"
#include "run.h"
#include "sindex.h"
#include "stats.h"
#include "trace.h"

#include <inttypes.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#define IMG_W 16
#define IMG_H 16

typedef struct tally {
    const rt_layout *L;
    uint64_t n, hash;
    uint64_t thash; /* the hash with the write kind as a trace stores it (one bit: a streaming store reads back as a write) */
    uint64_t refs[RT_NCLASS], bytes[RT_NCLASS];
    uint64_t bad;
    char why[200];
    rt_sink *next; /* also forwarded here (a trace writer), or NULL */
} tally;

static void fnv(uint64_t *h, uint64_t v, int nbytes)
{
    for (int i = 0; i < nbytes; i++) {
        *h ^= (v >> (8 * i)) & 0xff;
        *h *= 0x100000001b3ULL;
    }
}

static void tally_one(tally *t, const rt_access *a)
{
    fnv(&t->hash, a->addr, 8);
    fnv(&t->hash, a->size, 4);
    fnv(&t->hash, a->write, 1);
    fnv(&t->hash, a->cls, 1);
    fnv(&t->hash, a->gen, 1);
    fnv(&t->thash, a->addr, 8);
    fnv(&t->thash, a->size, 4);
    fnv(&t->thash, a->write != 0, 1);
    fnv(&t->thash, a->cls, 1);
    fnv(&t->thash, a->gen, 1);
    t->n++;
    if (a->cls < RT_NCLASS) {
        t->refs[a->cls]++;
        t->bytes[a->cls] += a->size;
    }
    if (!t->L) return;
    const rt_layout *L = t->L;
    int r = -1;
    for (int k = 0; k < L->n; k++)
        if (a->addr >= L->r[k].base && a->addr < L->r[k].base + L->r[k].recsize * L->r[k].count) r = k;
    /* a structure's regions (node, index classes) are read as their own
     * class; a tracer may keep several classes in one other region (the
     * feedback tracer's triangle texture holds shading texels too) */
    int structural = r >= 0 && (L->r[r].cls == RT_CLS_NODE || L->r[r].cls == RT_CLS_INDEX);
    const char *why = r < 0                                    ? "outside every region"
                      : a->cls >= RT_NCLASS                    ? "class out of range"
                      : structural && a->cls != L->r[r].cls    ? "class differs from its structure region's"
                                                               : NULL;
    if (why && !t->bad++)
        snprintf(t->why, sizeof t->why, "access %" PRIu64 " at 0x%" PRIx64 ": %s", t->n - 1, a->addr, why);
}

static int tally_put(rt_sink *s, const rt_access *a, size_t n)
{
    tally *t = s->ctx;
    for (size_t i = 0; i < n; i++) tally_one(t, &a[i]);
    return t->next ? t->next->put(t->next, a, n) : 0;
}

/* Renders untraced (img) and traced into a tally and a trace file. */
static rt_image *run(rt_scene *sc, const rt_tracer *tr, const rt_render_opts *o, tally *t, const char *path,
                     rt_run_stats *st, const rt_accel **acc_out, rt_job *j)
{
    rt_err e = {0};
    if (rt_job_setup_borrowed(j, sc, NULL, tr->name, o, &e) < 0) {
        CHECK(0, "setup %s: %s", tr->name, e.msg);
        return NULL;
    }
    rt_image *im = rt_image_new(o->W, o->H, &e);
    if (!im) return NULL;
    if (!t) {
        if (rt_job_run(j, NULL, im, st, &e) < 0) CHECK(0, "run %s: %s", tr->name, e.msg);
        return im;
    }
    rt_tr_meta m;
    rt_job_meta(j, "test_conform", &m);
    rt_tr_wopts wo;
    rt_si_wopts(&wo);
    rt_tr_writer *w = rt_tr_create_opts(path, &m, &wo, &e);
    CHECK(w != NULL, "trace create: %s", e.msg);
    t->L = &j->L;
    t->next = w ? rt_tr_sink(w) : NULL;
    rt_sink s = {tally_put, t};
    if (rt_job_run(j, &s, im, st, &e) < 0) CHECK(0, "traced run %s: %s", tr->name, e.msg);
    if (w) CHECK(rt_tr_finish(w, &e) == 0, "trace finish: %s", e.msg);
    *acc_out = &j->acc;
    return im;
}

/* Reads the trace back: same records, same per-class totals. */
static void round_trip(const char *path, const tally *t, const char *what)
{
    rt_err e = {0};
    rt_tr_reader *r = rt_si_open(path, &e);
    CHECK(r != NULL, "%s: open: %s", what, e.msg);
    if (!r) return;
    tally b;
    memset(&b, 0, sizeof b);
    b.hash = b.thash = 0xcbf29ce484222325ULL;
    rt_access buf[4096];
    long n;
    while ((n = rt_tr_read(r, buf, 4096, &e)) > 0)
        for (long i = 0; i < n; i++) tally_one(&b, &buf[i]);
    CHECK(n == 0, "%s: read: %s", what, e.msg);
    CHECK(b.n == t->n && b.thash == t->thash, "%s: trace has %" PRIu64 " records (hash %016" PRIx64 "), run %" PRIu64
          " (%016" PRIx64 ")", what, b.n, b.thash, t->n, t->thash);
    const rt_tr_totals *tt = rt_tr_get_totals(r);
    for (int c = 0; c < RT_NCLASS && n == 0; c++)
        CHECK(tt->refs[c] == t->refs[c] && tt->bytes[c] == t->bytes[c], "%s: class %d totals differ", what, c);
    rt_tr_close(r);
}

int main(void)
{
    static const char *const scenes[] = {"cornell", "knot"};
    static const int modes[] = {RT_MODE_RAYCAST, RT_MODE_SHADOW, RT_MODE_WHITTED, RT_MODE_PATH};
    const rt_tracer *ref = rt_tracer_reference();
    if (!check_tmpdir("conform")) return 1;
    const char *tpath = check_path("run.rtt");
    char *golden = NULL;
    size_t ng = 0;
    FILE *gf = open_memstream(&golden, &ng);
    int combos = 0;
    for (size_t s = 0; s < sizeof scenes / sizeof *scenes; s++) {
        rt_err e = {0};
        rt_scene *sc = rt_scene_load(scenes[s], &e);
        CHECK(sc != NULL, "load %s: %s", scenes[s], e.msg);
        if (!sc) continue;
        for (size_t m = 0; m < sizeof modes / sizeof *modes; m++) {
            rt_render_opts o;
            rt_render_default_opts(&o);
            o.W = IMG_W;
            o.H = IMG_H;
            o.lights = modes[m] == RT_MODE_RAYCAST ? 0 : (1u << RT_NLIGHTS) - 1;
            o.mode = modes[m];
            o.depth = 3;
            o.bounces = 2;
            o.sched_size = 4096;
            rt_run_stats st;
            rt_job jr;
            const rt_accel *acc = NULL;
            rt_image *want = run(sc, ref, &o, NULL, NULL, &st, &acc, &jr);
            rt_job_free(&jr);
            if (!want) continue;
            for (int t = 0; rt_tracer_all[t]; t++) {
                const rt_tracer *tr = rt_tracer_all[t];
                if (!(tr->modes & (1u << modes[m]))) continue;
                for (int k = 1; k < RT_ACCEL_NKINDS; k++) {
                    if (!(tr->accels & RT_ACCEL_BIT(k))) continue;
                    char what[160];
                    snprintf(what, sizeof what, "%s %s %s %s", tr->name, rt_render_mode_name(modes[m]),
                             rt_accel_name(k), scenes[s]);
                    rt_render_opts to = o;
                    to.accel = k;
                    tally ty;
                    memset(&ty, 0, sizeof ty);
                    ty.hash = ty.thash = 0xcbf29ce484222325ULL;
                    rt_job j;
                    rt_image *got = run(sc, tr, &to, &ty, tpath, &st, &acc, &j);
                    combos++;
                    if (!got) continue;
                    size_t diff = 0;
                    for (size_t i = 0; i < (size_t)IMG_W * IMG_H * 3; i++)
                        diff += memcmp(&got->rgb[i], &want->rgb[i], sizeof(float)) != 0;
                    CHECK(diff == 0, "%s: %zu channel values differ from %s's image", what, diff, ref->name);
                    CHECK(ty.bad == 0, "%s: %" PRIu64 " accesses off the layout; first %s", what, ty.bad, ty.why);
                    CHECK(ty.n == st.accesses && ty.n > 0, "%s: %" PRIu64 " accesses recorded, statistics say %" PRIu64,
                          what, ty.n, st.accesses);
                    CHECK(rt_accel_check(acc, sc, &e) == 0, "%s: structure check: %s", what, e.msg);
                    {
                        /* the statistics' form (stats.h), also among the
                         * keys a sweep's runs.stats puts around them */
                        char all[1024], obj[4096];
                        snprintf(all, sizeof all,
                                 "rays_primary=0 rays_shadow=0 nodes=0 tests=0 pv_primary=0 pv_all=0 render_seconds=0 "
                                 "sim_seconds=0%s%s accel=kd accel_nodes=0 accel_bytes=0 accel_build_seconds=0",
                                 st.extra[0] ? " " : "", st.extra);
                        CHECK(rt_stats_json(st.extra, obj, sizeof obj, &e) == 0 &&
                                  rt_stats_json(all, obj, sizeof obj, &e) == 0,
                              "%s: statistics '%s': %s", what, st.extra, e.msg);
                    }
                    if (tr->traits & RT_TR_REFERENCE) {
                        /* one node record per visit, one triangle record per test */
                        CHECK(ty.refs[RT_CLS_TRI] == st.tests, "%s: %" PRIu64 " triangle reads, %" PRIu64 " tests",
                              what, ty.refs[RT_CLS_TRI], st.tests);
                        /* (the two-level structure: top-level nodes and instance records count as visits) */
                        const uint64_t nr = ty.refs[RT_CLS_NODE] + ty.refs[RT_CLS_TLAS] + ty.refs[RT_CLS_INST];
                        CHECK(nr == st.nodes, "%s: %" PRIu64 " node reads, %" PRIu64 " visits", what, nr, st.nodes);
                    }
                    round_trip(tpath, &ty, what);
                    fprintf(gf, "%s accesses %" PRIu64 " fnv1a %016" PRIx64 "\n", what, ty.n, ty.hash);
                    rt_image_free(got);
                    rt_job_free(&j);
                    unlink(tpath);
                }
            }
            rt_image_free(want);
        }
        rt_scene_free(sc);
    }
    fclose(gf);
    CHECK(combos >= 40, "only %d tracer/mode/structure combinations ran", combos);
    /* golden record-stream hashes */
    const char *dir = getenv("RT_SRCDIR");
    char path[1024];
    snprintf(path, sizeof path, "%s/tests/golden/conform.txt", dir ? dir : ".");
    const char *redo = getenv("RT_REDO_GOLDEN");
    if (redo && !strcmp(redo, "1")) {
        check_write_file(path, golden, ng);
        fprintf(stderr, "regenerated %s\n", path);
    } else {
        FILE *f = fopen(path, "rb");
        CHECK(f != NULL, "missing golden file %s (RT_REDO_GOLDEN=1 writes it)", path);
        if (f) {
            char *want = calloc(1, ng + 2);
            size_t nw = want ? fread(want, 1, ng + 1, f) : 0;
            fclose(f);
            CHECK(want && nw == ng && !memcmp(want, golden, ng), "record streams differ from %s:\n%s", path, golden);
            free(want);
        }
    }
    free(golden);
    rmdir(check_dir);
    printf("%d tracer/mode/structure combinations conform\n", combos);
    return failures ? 1 : 0;
}
