/*
 * embree_bench.c -- the Embree comparison row of `raytraffic bench`
 * (rt_embree_bench, see bench.h).
 *
 * An outside yardstick for the tracers' speed: the scene's triangles in an
 * Embree 3 scene (default build quality, one-thread device), and the same
 * primary rays our tracers shoot -- rt_cam_ray of every pixel, in the
 * Hilbert order of rt_pixel_order -- each through rtcIntersect1, one ray at
 * a time as the recursive tracer does. Only the ray loop is timed; the
 * Embree scene's build is reported apart. Built only when configure found
 * Embree (HAVE_EMBREE); otherwise rt_embree_bench says so and does nothing.
 *
 * That loop is Embree's walk alone (camera ray, rtcIntersect1, a hit
 * counter). The untraced recursive tracer does more around its walk: it
 * computes the pixel order, shades every hit and writes the image. A second
 * loop does that same job with rtcIntersect1 in place of the tracer's walk
 * (bench.h lists what each side does), so the tracer's speed can be set
 * beside Embree's on the same work as well as beside the bare walk.
 */
#include "config.h"

#include "bench.h"
#include "camera.h"
#include "hilbert.h"
#include "image.h"
#include "pixels.h"
#include "shade.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

/* RT_NO_EMBREE: the branch without Embree, which tests/test_noembree builds
 * on every machine (a developer with Embree installed never compiles it
 * otherwise) */
#if defined(HAVE_EMBREE) && !defined(RT_NO_EMBREE)
#include <embree3/rtcore.h>

/* Builds the Embree scene of sc's triangles on dev; NULL with e set. */
static RTCScene build(RTCDevice dev, const rt_scene *sc, rt_err *e)
{
    RTCScene s = rtcNewScene(dev);
    RTCGeometry g = s ? rtcNewGeometry(dev, RTC_GEOMETRY_TYPE_TRIANGLE) : NULL;
    float *v = g ? rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float),
                                           3 * (size_t)sc->ntri)
                 : NULL;
    unsigned *ix = v ? rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned),
                                               sc->ntri)
                     : NULL;
    if (!ix) {
        rt_errf(e, "embree: cannot create the scene (%d)", (int)rtcGetDeviceError(dev));
        if (g) rtcReleaseGeometry(g);
        if (s) rtcReleaseScene(s);
        return NULL;
    }
    for (uint32_t t = 0; t < sc->ntri; t++)
        for (int k = 0; k < 3; k++) {
            const rt_vec3 *p = &sc->tri[t].p[k];
            v[9 * (size_t)t + 3 * (size_t)k] = p->x;
            v[9 * (size_t)t + 3 * (size_t)k + 1] = p->y;
            v[9 * (size_t)t + 3 * (size_t)k + 2] = p->z;
            ix[3 * (size_t)t + (size_t)k] = 3 * t + (unsigned)k;
        }
    rtcCommitGeometry(g);
    rtcAttachGeometry(s, g);
    rtcReleaseGeometry(g);
    rtcCommitScene(s);
    if (rtcGetDeviceError(dev) != RTC_ERROR_NONE) {
        rt_errf(e, "embree: scene build failed");
        rtcReleaseScene(s);
        return NULL;
    }
    return s;
}

int rt_embree_bench(const rt_scene *sc, int W, int H, rt_embree_result *out, rt_err *e)
{
    return rt_embree_bench_reps(sc, W, H, 1, out, e);
}

/* Embree's ray for r, with no hit yet. */
static void rayhit(struct RTCRayHit *rh, const rt_ray *r)
{
    rh->ray.org_x = r->o.x;
    rh->ray.org_y = r->o.y;
    rh->ray.org_z = r->o.z;
    rh->ray.dir_x = r->d.x;
    rh->ray.dir_y = r->d.y;
    rh->ray.dir_z = r->d.z;
    rh->ray.tnear = r->tmin;
    rh->ray.tfar = r->tmax;
    rh->ray.time = 0;
    rh->ray.mask = 0xffffffffu;
    rh->ray.id = 0;
    rh->ray.flags = 0;
    rh->hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rh->hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
}

/* One run of the untraced recursive tracer's job (recursive.c, no lights)
 * with rtcIntersect1 as the walk, into img (bench.h). 0 or -1. */
static int job(RTCScene s, struct RTCIntersectContext *ctx, const rt_scene *sc, rt_image *img, rt_err *e)
{
    const int W = img->W, H = img->H;
    rt_render_opts o;
    rt_render_default_opts(&o);
    o.W = W;
    o.H = H;
    o.lights = 0;
    uint32_t *order = rt_calloc((size_t)W * H, sizeof *order, e);
    if (!order) return -1;
    const size_t npix = rt_pixel_order(&o, order);
    rt_cam_frame cam;
    rt_cam_setup(&cam, sc, W, H);
    for (size_t k = 0; k < npix; k++) {
        const uint32_t pix = order[k];
        rt_ray r;
        rt_cam_ray(&cam, (int)(pix % (uint32_t)W), (int)(pix / (uint32_t)W), &r);
        struct RTCRayHit rh;
        rayhit(&rh, &r);
        rtcIntersect1(s, ctx, &rh);
        if (rh.hit.geomID != RTC_INVALID_GEOMETRY_ID) {
            const rt_hit h = {rh.ray.tfar, rh.hit.primID, rh.hit.u, rh.hit.v};
            rt_shade_pixel(sc, &r, &h, NULL, 0, img, pix);
        } else {
            rt_shade_pixel(sc, &r, NULL, NULL, 0, img, pix);
        }
        img->nodes[pix] = 0.0f;
        img->tests[pix] = 0.0f;
    }
    free(order);
    return 0;
}

int rt_embree_bench_reps(const rt_scene *sc, int W, int H, int reps, rt_embree_result *out, rt_err *e)
{
    memset(out, 0, sizeof *out);
    snprintf(out->version, sizeof out->version, "%d.%d.%d", RTC_VERSION_MAJOR, RTC_VERSION_MINOR, RTC_VERSION_PATCH);
    uint32_t *order = malloc((size_t)W * (size_t)H * sizeof *order);
    RTCDevice dev = rtcNewDevice("threads=1");
    if (!order || !dev) {
        rt_errf(e, order ? "embree: cannot create a device" : "out of memory");
        free(order);
        if (dev) rtcReleaseDevice(dev);
        return -1;
    }
    double t0 = rt_now();
    RTCScene s = build(dev, sc, e);
    out->build_sec = rt_now() - t0;
    if (!s) {
        free(order);
        rtcReleaseDevice(dev);
        return -1;
    }
    rt_hilbert_order(W, H, order);
    rt_cam_frame cam;
    rt_cam_setup(&cam, sc, W, H);
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    uint64_t hits = 0;
    size_t npix = (size_t)W * (size_t)H;
    if (reps < 1) reps = 1;
    if (reps > RT_BENCH_MAX_REPS) reps = RT_BENCH_MAX_REPS;
    double cpu[RT_BENCH_MAX_REPS];
    for (int rep = 0; rep < reps; rep++) {
        hits = 0;
        t0 = rt_now();
        const double c0 = rt_bench_thread_cpu();
        for (size_t k = 0; k < npix; k++) {
            uint32_t pix = order[k];
            rt_ray r;
            rt_cam_ray(&cam, (int)(pix % (uint32_t)W), (int)(pix / (uint32_t)W), &r);
            struct RTCRayHit rh;
            rayhit(&rh, &r);
            rtcIntersect1(s, &ctx, &rh);
            hits += rh.hit.geomID != RTC_INVALID_GEOMETRY_ID;
        }
        const double sec = rt_now() - t0;
        cpu[rep] = rt_bench_thread_cpu() - c0;
        if (rep == 0 || sec < out->sec) out->sec = sec;
        if (rep == 0 || cpu[rep] < out->cpu_sec) out->cpu_sec = cpu[rep];
    }
    out->cpu_med = rt_bench_median(cpu, reps);
    out->rays = npix;
    out->hits = hits;
    free(order);
    int rc = 0;
    rt_image *img = rt_image_new(W, H, e);
    if (!img) rc = -1;
    for (int rep = 0; rep < reps && rc == 0; rep++) {
        const double c0 = rt_bench_thread_cpu();
        if ((rc = job(s, &ctx, sc, img, e)) < 0) break;
        cpu[rep] = rt_bench_thread_cpu() - c0;
        if (rep == 0 || cpu[rep] < out->job_cpu_sec) out->job_cpu_sec = cpu[rep];
    }
    if (rc == 0) out->job_cpu_med = rt_bench_median(cpu, reps);
    rt_image_free(img);
    rtcReleaseScene(s);
    rtcReleaseDevice(dev);
    return rc;
}

int rt_embree_built(void) { return 1; }

#else

int rt_embree_bench(const rt_scene *sc, int W, int H, rt_embree_result *out, rt_err *e)
{
    return rt_embree_bench_reps(sc, W, H, 1, out, e);
}

int rt_embree_bench_reps(const rt_scene *sc, int W, int H, int reps, rt_embree_result *out, rt_err *e)
{
    (void)reps;
    (void)sc, (void)W, (void)H;
    memset(out, 0, sizeof *out);
    rt_errf(e, "embree: not built (libembree-dev missing)");
    return -1;
}

int rt_embree_built(void) { return 0; }

#endif

static int cmp_double(const void *a, const void *b)
{
    const double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

double rt_bench_median(double *v, int n)
{
    qsort(v, (size_t)n, sizeof *v, cmp_double);
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

double rt_bench_thread_cpu(void)
{
    struct timespec ts;
    if (clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts) != 0) return rt_now();
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}
