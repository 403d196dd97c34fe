/*
 * stream_bench.c -- `raytraffic bench --what stream`: the speed of the
 * streaming tracers of Purcell et al. 2002 (tracegen/stream.c) on their
 * paper's scene.
 *
 * Two figures: stream-branching's untraced primary rays/s on one core,
 * beside the recursive tracer's measured in the same run on the same scene
 * and tree (the ratio is what the grid walk costs against the k-d tree);
 * and the wall time of a traced stream-multipass run streaming into the
 * exact 13-size simulator and the paper's texture cache (the simulators a
 * sweep feeds, results/experiment.h), from job setup (grid build included)
 * to the last reference.
 */
#include "scene_load.h"
#include "bench.h"
#include "experiment.h"
#include "run.h"

#include <inttypes.h>
#include <string.h>

/* One untraced run; returns seconds (the tracer's own clock) or -1. */
static double untraced(rt_scene *sc, rt_kdtree *kd, const char *tracer, const rt_render_opts *o, uint64_t *rays,
                       rt_err *e)
{
    rt_job j;
    rt_run_stats st;
    if (rt_job_setup_borrowed(&j, sc, kd, tracer, o, e) < 0) return -1;
    rt_image *img = rt_image_new(o->W, o->H, e);
    int rc = img ? rt_job_run(&j, NULL, img, &st, e) : -1;
    rt_image_free(img);
    rt_job_free(&j);
    if (rc < 0) return -1;
    *rays = st.rays_primary + st.rays_shadow;
    return st.seconds;
}

int rt_stream_bench(FILE *out, const char *scene, const rt_render_opts *base, rt_err *e)
{
    rt_render_opts o = *base;
    o.mode = RT_MODE_RAYCAST;
    o.lights = 0;
    rt_scene *sc = rt_scene_load(scene, e);
    if (!sc) return -1;
    rt_kd_params kp;
    rt_kd_default_params(&kp);
    rt_kdtree *kd = rt_kd_build(sc, &kp, e);
    rt_sim *sim = NULL, *tex = NULL;
    rt_image *img = NULL;
    int rc = -1;
    if (!kd) goto out;
    fprintf(out, "Streaming tracers (Purcell et al. 2002) on %s, %dx%d primary rays, one core:\n\n", scene, o.W, o.H);
    fprintf(out, "| tracer | run | seconds | Mrays/s | vs recursive |\n|---|---|---:|---:|---:|\n");
    uint64_t rr = 0, rb = 0;
    double tr = untraced(sc, kd, "recursive", &o, &rr, e);
    if (tr < 0) goto out;
    fprintf(out, "| recursive | untraced | %.2f | %.2f | 1.00 |\n", tr, rr / tr * 1e-6);
    fflush(out);
    double tb = untraced(sc, kd, "stream-branching", &o, &rb, e);
    if (tb < 0) goto out;
    fprintf(out, "| stream-branching | untraced | %.2f | %.2f | %.2f |\n", tb, rb / tb * 1e-6,
            (rb / tb) / (rr / tr));
    fflush(out);
    /* traced multipass into the sweep's simulators: 13 sizes and the texture cache */
    rt_sim_config c, tc;
    rt_sim_config_default(&c);
    tc = c;
    tc.nsizes = 1;
    tc.sizes[0] = RT_EXP_TEXCACHE_SIZE;
    tc.line = RT_EXP_TEXCACHE_LINE;
    tc.assoc = 1;
    if (!(sim = rt_sim_new(&c, e)) || !(tex = rt_sim_new(&tc, e)) || !(img = rt_image_new(o.W, o.H, e))) goto out;
    rt_exp_fan fan;
    rt_exp_fan_init(&fan);
    rt_exp_fan_add(&fan, rt_sim_sink(sim), e);
    rt_exp_fan_add(&fan, rt_sim_sink(tex), e);
    double t0 = rt_now();
    rt_job j;
    rt_run_stats st;
    if (rt_job_setup_borrowed(&j, sc, kd, "stream-multipass", &o, e) < 0) goto out;
    int r = rt_job_run(&j, rt_exp_fan_sink(&fan), img, &st, e);
    rt_job_free(&j);
    if (r < 0) goto out;
    double wall = rt_now() - t0;
    uint64_t rays = st.rays_primary + st.rays_shadow;
    fprintf(out, "| stream-multipass | traced: 13 sizes + texture cache | %.2f | %.2f | %.2f |\n", wall,
            rays / wall * 1e-6, (rays / wall) / (rr / tr));
    fprintf(out, "\nTraced multipass: %" PRIu64 " references (%.1f per ray); tracer %.2f s, 13-size simulator "
                 "%.2f s, texture cache %.2f s (inside the run's %.2f s)\n",
            st.accesses, (double)st.accesses / (double)rays, st.seconds - fan.sec[0] - fan.sec[1], fan.sec[0],
            fan.sec[1], wall);
    rc = 0;
out:
    rt_image_free(img);
    rt_sim_free(sim);
    rt_sim_free(tex);
    rt_kd_free(kd);
    rt_scene_free(sc);
    return rc;
}
