/*
 * bvh_bench.c -- the BVH row of `raytraffic bench` (rt_bvh_bench_primary,
 * see bench.h): untraced primary rays through the k-d tree and through
 * each BVH width, one ray at a time.
 *
 * The rays are those the recursive tracer and the Embree row shoot:
 * rt_cam_ray of every pixel, in the Hilbert order of rt_hilbert_order.
 * Each structure is built from the same scene (best of min(reps, 3)
 * builds), then the ray loop is timed alone (best of reps runs, Embree's
 * too); every BVH hit is compared with
 * the k-d tree's (triangle and t bit for bit), a mismatch decided by brute
 * force, and the rays where the BVH differs from both are reported, so a
 * fast but wrong row cannot pass unnoticed. With Embree built, its
 * rtcIntersect1 on the same rays is measured too (rt_embree_bench) and every
 * row gets its rays/s over Embree's.
 *
 * A second table runs the recursive tracer itself (rt_job, no lights: camera
 * rays, the walk through the structure's ops, shading, the image) on each
 * structure, untraced and recording into a null sink, best of reps each
 * (and the untraced median): its rays/s over Embree's walk alone and over
 * Embree doing the tracer's job (rt_embree_bench_reps: the pixel order,
 * camera rays, rtcIntersect1, shading, the image), and the recording run's
 * time over the untraced.
 */
#include "config.h"

#include "bench.h"
#include "bvh.h"
#include "camera.h"
#include "hilbert.h"
#include "kdtrav.h"
#include "kdtree.h"
#include "run.h"

#include <inttypes.h>
#include <stdlib.h>
#include <string.h>

typedef struct row {
    char name[16];    /* "k-d tree", "bvh2", ... */
    double build_sec; /* build wall time */
    double build_cpu; /* build CPU time (one thread) */
    uint64_t bytes;   /* modeled bytes of nodes (+ index) + triangles */
    uint32_t nodes;   /* nodes of the structure */
    double sec;       /* best ray loop */
    double cpu;       /* best ray loop, CPU time of the thread */
    uint64_t hits;    /* rays that hit */
    uint64_t visits;  /* nodes visited over all rays (one run) */
    uint64_t tests;   /* triangle tests over all rays (one run) */
    uint64_t differ;  /* rays whose hit differs from the k-d tree's and brute force's */
    uint64_t kd_off;  /* rays where it equals brute force and the k-d tree does not */
} row;

static int null_put(rt_sink *s, const rt_access *a, size_t n)
{
    (void)a;
    *(uint64_t *)s->ctx += n;
    return 0;
}

/* The recursive tracer on structure kind: best and median untraced and best
 * recording seconds of reps runs each, alternating. 0 or -1. */
static int tracer_row(const rt_scene *sc, int kind, int W, int H, int reps, double *untraced, double *untraced_med,
                      double *recorded, double *refs_per_ray, rt_err *e)
/* (times: CPU seconds of the thread) */
{
    double tu[RT_BENCH_MAX_REPS];
    rt_render_opts o;
    rt_render_default_opts(&o);
    o.W = W;
    o.H = H;
    o.lights = 0;
    o.accel = kind;
    rt_job j;
    rt_image *img = rt_image_new(W, H, e);
    if (!img) return -1;
    if (rt_job_setup_borrowed(&j, (rt_scene *)sc, NULL, "recursive", &o, e) < 0) {
        rt_image_free(img);
        return -1;
    }
    int rc = 0;
    for (int rep = 0; rep < reps && rc == 0; rep++) {
        rt_run_stats st;
        uint64_t cnt = 0;
        rt_sink ns = {null_put, &cnt};
        double c0 = rt_bench_thread_cpu();
        if ((rc = rt_job_run(&j, NULL, img, &st, e)) < 0) break;
        double c = rt_bench_thread_cpu() - c0;
        tu[rep] = c;
        if (rep == 0 || c < *untraced) *untraced = c;
        c0 = rt_bench_thread_cpu();
        if ((rc = rt_job_run(&j, &ns, img, &st, e)) < 0) break;
        c = rt_bench_thread_cpu() - c0;
        if (rep == 0 || c < *recorded) *recorded = c;
        *refs_per_ray = (double)st.accesses / (double)(st.rays_primary ? st.rays_primary : 1);
    }
    if (rc == 0) *untraced_med = rt_bench_median(tu, reps);
    rt_job_free(&j);
    rt_image_free(img);
    return rc;
}

int rt_bvh_bench_primary(FILE *out, const rt_scene *sc, int W, int H, int reps, rt_err *e)
{
    const size_t npix = (size_t)W * (size_t)H;
    uint32_t *order = rt_calloc(npix, sizeof *order, e);
    rt_hit *ref = rt_calloc(npix, sizeof *ref, e);
    enum { NDIFF = 1000 }; /* differences brute force decides; more count as wrong */
    uint32_t dpix[NDIFF];
    rt_hit dhit[NDIFF];
    rt_kdtree *kd = NULL;
    /* row 0 the k-d tree, then the BVHs of the accel table in kind order */
    row rows[RT_ACCEL_NKINDS];
    int bvh_kind[RT_ACCEL_NKINDS], nrows = 1;
    memset(rows, 0, sizeof rows);
    for (int k = 1; k < RT_ACCEL_NKINDS; k++)
        if (rt_accel_bvh_width(k)) bvh_kind[nrows++] = k;
    int rc = -1;
    if (!order || !ref) goto out;
    if (reps < 1) reps = 1;
    if (reps > RT_BENCH_MAX_REPS) reps = RT_BENCH_MAX_REPS;
    rt_hilbert_order(W, H, order);
    rt_cam_frame cam;
    rt_cam_setup(&cam, sc, W, H);

    /* every build runs nbuild times, the best kept: one build's time
     * varies by a quarter from run to run on a shared machine */
    const int nbuild = reps < 3 ? reps : 3;
    double t0, c0;
    snprintf(rows[0].name, sizeof rows[0].name, "k-d tree");
    for (int i = 0; i < nbuild; i++) {
        rt_kd_free(kd);
        t0 = rt_now();
        c0 = rt_bench_thread_cpu();
        if (!(kd = rt_kd_build(sc, NULL, e))) goto out;
        const double sec = rt_now() - t0, cpu = rt_bench_thread_cpu() - c0;
        if (i == 0 || sec < rows[0].build_sec) rows[0].build_sec = sec;
        if (i == 0 || cpu < rows[0].build_cpu) rows[0].build_cpu = cpu;
    }
    rows[0].nodes = kd->nnodes;
    rows[0].bytes = 8ull * kd->nnodes + 4ull * kd->nidx + 36ull * sc->ntri;
    for (int rep = 0; rep < reps; rep++) {
        rt_trav tv;
        memset(&tv, 0, sizeof tv);
        tv.kd = kd;
        tv.sc = sc;
        uint64_t hits = 0;
        t0 = rt_now();
        c0 = rt_bench_thread_cpu();
        for (size_t k = 0; k < npix; k++) {
            const uint32_t pix = order[k];
            rt_ray r;
            rt_cam_ray(&cam, (int)(pix % (uint32_t)W), (int)(pix / (uint32_t)W), &r);
            hits += (uint64_t)rt_kd_closest(&tv, &r, &ref[k]);
        }
        const double sec = rt_now() - t0, cpu = rt_bench_thread_cpu() - c0;
        if (rep == 0 || sec < rows[0].sec) rows[0].sec = sec;
        if (rep == 0 || cpu < rows[0].cpu) rows[0].cpu = cpu;
        rows[0].hits = hits;
        rows[0].visits = tv.nodes;
        rows[0].tests = tv.tests;
    }
    rt_kd_free(kd);
    kd = NULL;

    for (int w = 1; w < nrows; w++) {
        row *x = &rows[w];
        rt_bvh_params p;
        rt_bvh_default_params(&p, rt_accel_bvh_width(bvh_kind[w]));
        rt_bvh *b = NULL;
        rt_bvh_stat st;
        for (int i = 0; i < nbuild; i++) {
            rt_bvh_free(b);
            c0 = rt_bench_thread_cpu();
            if (!(b = rt_bvh_build(sc, &p, e))) goto out;
            const double cpu = rt_bench_thread_cpu() - c0;
            rt_bvh_stats(b, &st);
            if (i == 0 || cpu < x->build_cpu) x->build_cpu = cpu;
            if (i == 0 || st.build_sec < x->build_sec) x->build_sec = st.build_sec;
        }
        snprintf(x->name, sizeof x->name, "%s", rt_accel_name(bvh_kind[w]));
        x->nodes = st.nodes;
        x->bytes = st.bytes;
        for (int rep = 0; rep < reps; rep++) {
            rt_bvh_trav tv;
            rt_bvh_trav_init(&tv, b, sc, NULL, NULL);
            uint64_t hits = 0, differ = 0;
            t0 = rt_now();
            c0 = rt_bench_thread_cpu();
            for (size_t k = 0; k < npix; k++) {
                const uint32_t pix = order[k];
                rt_ray r;
                rt_cam_ray(&cam, (int)(pix % (uint32_t)W), (int)(pix / (uint32_t)W), &r);
                rt_hit h;
                hits += (uint64_t)rt_bvh_closest(&tv, &r, &h);
                if (h.tri != ref[k].tri || memcmp(&h.t, &ref[k].t, sizeof h.t) != 0) {
                    if (differ < NDIFF) {
                        dpix[differ] = (uint32_t)k;
                        dhit[differ] = h;
                    }
                    differ++;
                }
            }
            const double sec = rt_now() - t0, cpu = rt_bench_thread_cpu() - c0;
            if (rep == 0 || sec < x->sec) x->sec = sec;
            if (rep == 0 || cpu < x->cpu) x->cpu = cpu;
            x->hits = hits;
            if (rep > 0) continue;
            /* brute force decides each difference, outside the timed loop
             * (the k-d tree has been seen to miss hits exactly at vertices) */
            x->differ = differ;
            for (uint64_t i = 0; i < differ && i < NDIFF; i++) {
                const uint32_t pix = order[dpix[i]];
                rt_ray r;
                rt_cam_ray(&cam, (int)(pix % (uint32_t)W), (int)(pix / (uint32_t)W), &r);
                rt_hit hb;
                rt_brute_closest(sc, &r, &hb);
                if (hb.tri == dhit[i].tri && memcmp(&hb.t, &dhit[i].t, sizeof hb.t) == 0) {
                    x->differ--;
                    x->kd_off++;
                }
            }
            x->visits = tv.nodes;
            x->tests = tv.tests;
        }
        rt_bvh_free(b);
    }

    rt_embree_result er;
    memset(&er, 0, sizeof er);
    rt_err ee = {0};
    const int have_embree = rt_embree_built() && rt_embree_bench_reps(sc, W, H, reps, &er, &ee) == 0;
    fprintf(out,
            "Untraced primary rays, %dx%d in Hilbert order, one ray at a time, %u triangles (builds: best of %d; ray loop: best of %d, "
            "wall and CPU time of the thread apart; hits compared with the k-d tree's, triangle and t bit for bit; "
            "ratios on CPU time, which a loaded machine does not stretch)%s:\n\n",
            W, H, sc->ntri, nbuild, reps, have_embree ? "" : "; Embree not built");
    fprintf(out, "| structure | build s | build CPU s | build CPU over k-d | nodes | MB | seconds | CPU s | Mrays/s (CPU) "
                 "| nodes/ray | tests/ray | differ | k-d CPU over this | rays/s over Embree (CPU) |\n"
                 "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
    for (int i = 0; i < nrows; i++) {
        const row *x = &rows[i];
        char emb[32] = "";
        if (have_embree) snprintf(emb, sizeof emb, "%.2f", er.cpu_sec / x->cpu);
        fprintf(out,
                "| %s | %.2f | %.2f | %.2f | %" PRIu32 " | %.1f | %.3f | %.3f | %.2f | %.1f | %.2f | %" PRIu64
                " | %.2f | %s |\n",
                x->name, x->build_sec, x->build_cpu, x->build_cpu / rows[0].build_cpu, x->nodes,
                (double)x->bytes / 1048576.0, x->sec, x->cpu, (double)npix / x->cpu * 1e-6,
                (double)x->visits / (double)npix, (double)x->tests / (double)npix, x->differ, rows[0].cpu / x->cpu, emb);
    }
    if (have_embree)
        fprintf(out, "| embree %s | %.2f | | | | | %.3f | %.3f | %.2f | | | | %.2f | 1.00 |\n", er.version, er.build_sec,
                er.sec, er.cpu_sec, (double)er.rays / er.cpu_sec * 1e-6, rows[0].cpu / er.cpu_sec);
    fprintf(out, "\nThe walks: bvh2 one box at a time; bvh4 on SSE2, four boxes per vector; bvh8 %s.\n",
            rt_bvh_avx_usable() ? "with AVX, eight boxes per vector (the processor has it)"
                                : "on SSE2, four boxes per vector (no AVX copy, or the processor lacks AVX)");
    for (int i = 1; i < nrows; i++)
        if (rows[i].kd_off)
            fprintf(out, "%s: %" PRIu64 " hits differ from the k-d tree's and equal brute force's\n", rows[i].name,
                    rows[i].kd_off);
    fprintf(out, "\n");
    /* the recursive tracer on each structure */
    int kinds[RT_ACCEL_NKINDS];
    double tu[RT_ACCEL_NKINDS] = {0}, tum[RT_ACCEL_NKINDS] = {0}, trc[RT_ACCEL_NKINDS] = {0}, rpr[RT_ACCEL_NKINDS] = {0};
    kinds[0] = RT_ACCEL_KD;
    for (int i = 1; i < nrows; i++) kinds[i] = bvh_kind[i];
    for (int i = 0; i < nrows; i++)
        if (tracer_row(sc, kinds[i], W, H, reps, &tu[i], &tum[i], &trc[i], &rpr[i], e) < 0) goto out;
    fprintf(out, "The recursive tracer on each structure, the same primary rays, no lights (untraced and recording "
                 "into a null sink; CPU time of the thread, best of %d each, the untraced run's median beside it). "
                 "Over Embree: against rtcIntersect1 alone (the table above), and against Embree doing the tracer's "
                 "job (pixel order, camera rays, rtcIntersect1, shading, the image; best / median of %d each):\n\n",
            reps, reps);
    fprintf(out, "| structure | untraced CPU s | median | Mrays/s | recording CPU s | recording over untraced | refs/ray | "
                 "untraced k-d CPU over this | over Embree's walk (best / median) | over Embree's job (best / median) "
                 "|\n|---|---|---|---|---|---|---|---|---|---|\n");
    for (int i = 0; i < nrows; i++) {
        char emb[32] = "", job[32] = "";
        if (have_embree) {
            snprintf(emb, sizeof emb, "%.2f / %.2f", er.cpu_sec / tu[i], er.cpu_med / tum[i]);
            snprintf(job, sizeof job, "%.2f / %.2f", er.job_cpu_sec / tu[i], er.job_cpu_med / tum[i]);
        }
        fprintf(out, "| %s | %.3f | %.3f | %.2f | %.3f | %.2f | %.1f | %.2f | %s | %s |\n", rt_accel_name(kinds[i]),
                tu[i], tum[i], (double)npix / tu[i] * 1e-6, trc[i], trc[i] / tu[i], rpr[i], tu[0] / tu[i], emb, job);
    }
    if (have_embree)
        fprintf(out, "| embree's job | %.3f | %.3f | %.2f | | | | %.2f | %.2f / %.2f | 1.00 / 1.00 |\n", er.job_cpu_sec,
                er.job_cpu_med, (double)npix / er.job_cpu_sec * 1e-6, tu[0] / er.job_cpu_sec,
                er.cpu_sec / er.job_cpu_sec, er.cpu_med / er.job_cpu_med);
    fprintf(out, "\n");
    rc = 0;
    for (int i = 1; i < nrows; i++)
        if (rows[i].differ) rc = rt_errf(e, "%s: %" PRIu64 " hits differ from the k-d tree's", rows[i].name, rows[i].differ);
out:
    rt_kd_free(kd);
    free(order);
    free(ref);
    return rc;
}
