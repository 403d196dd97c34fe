/*
 * tracer.c -- what all tracers share: the registry, options, the camera,
 * the shading rule, shadow-ray construction and the geometry regions.
 * Keeping these in one place is what makes the tracers' images
 * bit-identical: they differ only in the order they trace rays.
 */
#include "tracer.h"
#include "hilbert.h"

#include <math.h>
#include <stdlib.h>
#include <stdio.h>
#include <string.h>

extern const rt_tracer rt_tracer_recursive;
extern const rt_tracer rt_tracer_packet;
extern const rt_tracer rt_tracer_dynamic;

const rt_tracer *const rt_tracers[] = {
    &rt_tracer_recursive,
    &rt_tracer_packet,
    &rt_tracer_dynamic,
    NULL,
};

const rt_tracer *rt_tracer_find(const char *name)
{
    for (int i = 0; rt_tracers[i]; i++)
        if (!strcmp(rt_tracers[i]->name, name)) return rt_tracers[i];
    return NULL;
}

void rt_render_default_opts(rt_render_opts *o)
{
    memset(o, 0, sizeof *o);
    o->W = 512;
    o->H = 512;
    o->lights = 0;
    o->packet = 8;
    o->cache_size = 64 * 1024;
    o->gmax = 0;
    o->qorder = RT_QORDER_FULLEST;
    o->threads = 4;
    o->subsample = 1;
    o->subtile = 8;
}

int rt_pixel_kept(const rt_render_opts *o, int x, int y)
{
    if (o->subsample <= 1) return 1;
    uint64_t t = ((uint64_t)(uint32_t)(x / o->subtile) << 32) | (uint32_t)(y / o->subtile);
    /* splitmix64 finalizer: tiles are chosen independently of position */
    t += 0x9e3779b97f4a7c15ULL;
    t = (t ^ (t >> 30)) * 0xbf58476d1ce4e5b9ULL;
    t = (t ^ (t >> 27)) * 0x94d049bb133111ebULL;
    t ^= t >> 31;
    return t % o->subsample == 0;
}

size_t rt_pixel_order(const rt_render_opts *o, uint32_t *order)
{
    size_t npix = (size_t)o->W * (size_t)o->H, n = 0;
    rt_hilbert_order(o->W, o->H, order);
    if (o->subsample <= 1) return npix;
    for (size_t k = 0; k < npix; k++) {
        uint32_t p = order[k];
        if (rt_pixel_kept(o, (int)(p % (uint32_t)o->W), (int)(p / (uint32_t)o->W))) order[n++] = p;
    }
    return n;
}

void rt_subsample_params(const rt_render_opts *o, char *buf, size_t n)
{
    if (n) buf[0] = 0;
    if (o->subsample > 1) snprintf(buf, n, " subsample=%u tile=%d", (unsigned)o->subsample, o->subtile);
}

int rt_check_subsample(const rt_render_opts *o, const char *tracer, rt_err *e)
{
    if (o->subsample < 1 || o->subtile < 1) return rt_errf(e, "subsampling needs K >= 1 and a tile of >= 1 pixel");
    if (o->subsample > 1 && tracer && !strcmp(tracer, "packet") && o->subtile % o->packet)
        return rt_errf(e, "packet tracer: subsampling tile %d is not a multiple of the packet edge %d (whole packets "
                          "are traced or skipped)", o->subtile, o->packet);
    return 0;
}

int rt_parse_lights(const char *s, unsigned *mask)
{
    if (!strcmp(s, "all")) {
        *mask = (1u << RT_NLIGHTS) - 1;
        return 0;
    }
    if (!strcmp(s, "none") || !*s) {
        *mask = 0;
        return 0;
    }
    unsigned m = 0;
    const char *p = s;
    while (*p) {
        if (*p < '0' || *p >= '0' + RT_NLIGHTS) return -1;
        m |= 1u << (*p - '0');
        p++;
        if (*p == ',') {
            p++;
            if (!*p) return -1;
        } else if (*p) {
            return -1;
        }
    }
    *mask = m;
    return 0;
}

int rt_layout_geometry(const rt_tracer_ctx *ctx, rt_layout *L, int want_shade, rt_err *e)
{
    const rt_kdtree *kd = ctx->kd;
    if (rt_mm_add(L, "kd.nodes", RT_CLS_NODE, 8, kd->nnodes, e) < 0) return -1;
    if (rt_mm_add(L, "kd.index", RT_CLS_INDEX, 4, kd->nidx, e) < 0) return -1;
    if (rt_mm_add(L, "tri.verts", RT_CLS_TRI, 36, ctx->sc->ntri, e) < 0) return -1;
    if (want_shade && rt_mm_add(L, "tri.shade", RT_CLS_SHADE, 16, ctx->sc->ntri, e) < 0) return -1;
    return 0;
}

void rt_trav_init(rt_trav *tv, const rt_tracer_ctx *ctx)
{
    memset(tv, 0, sizeof *tv);
    tv->kd = ctx->kd;
    tv->sc = ctx->sc;
    tv->rec = ctx->rec;
    tv->L = ctx->L;
    tv->reg_node = rt_mm_find(ctx->L, "kd.nodes");
    tv->reg_idx = rt_mm_find(ctx->L, "kd.index");
    tv->reg_tri = rt_mm_find(ctx->L, "tri.verts");
}

/* sin and cos by Taylor series in double for |x| <= pi/2: only + - * /, so
 * the result is the same on every IEEE machine (libm's last bit is not). */
static void dsincos(double x, double *s, double *c)
{
    double term = x, sum = x;
    for (int k = 1; k < 30; k++) {
        term *= -x * x / ((2.0 * k) * (2.0 * k + 1.0));
        sum += term;
    }
    *s = sum;
    term = 1.0;
    sum = 1.0;
    for (int k = 1; k < 30; k++) {
        term *= -x * x / ((2.0 * k - 1.0) * (2.0 * k));
        sum += term;
    }
    *c = sum;
}

double rt_dtan(double x)
{
    double s, c;
    dsincos(x, &s, &c);
    return s / c;
}

void rt_cam_setup(rt_cam_frame *f, const rt_scene *sc, int W, int H)
{
    const rt_camera *c = &sc->cam;
    rt_vec3 dir = rt_norm(rt_sub(c->at, c->eye));
    rt_vec3 right = rt_norm(rt_cross(dir, c->up));
    rt_vec3 up = rt_cross(right, dir);
    double half_h = rt_dtan(0.5 * (double)c->fovy_deg * 3.14159265358979323846 / 180.0);
    double half_w = half_h * (double)W / (double)H;
    f->eye = c->eye;
    f->dir = dir;
    f->right = rt_mul(right, (float)half_w);
    f->up = rt_mul(up, (float)half_h);
    f->W = W;
    f->H = H;
}

void rt_camera_ray(const rt_cam_frame *f, int x, int y, rt_ray *r)
{
    float sx = (float)(2.0 * ((double)x + 0.5) / f->W - 1.0);
    float sy = (float)(1.0 - 2.0 * ((double)y + 0.5) / f->H);
    rt_vec3 d = rt_add(f->dir, rt_add(rt_mul(f->right, sx), rt_mul(f->up, sy)));
    rt_ray_init(r, f->eye, d);
}

/* Unit geometric normal facing the side the eye ray came from. */
static rt_vec3 facing_normal(const rt_scene *sc, const rt_ray *eye, const rt_hit *h)
{
    rt_vec3 n = rt_norm(rt_tri_normal(&sc->tri[h->tri]));
    if (rt_dot(n, eye->d) > 0) n = rt_mul(n, -1.0f);
    return n;
}

/* From barycentrics, not o + t d: the robust offset assumes a point
 * computed on the triangle (o + t d can land a few ULPs off it at large
 * scales and let the shadow ray re-hit its own triangle). */
static rt_vec3 hit_point(const rt_scene *sc, const rt_hit *h)
{
    return rt_tri_point(&sc->tri[h->tri], h->u, h->v);
}

int rt_shadow_ray(const rt_scene *sc, const rt_ray *eye, const rt_hit *h, int light, rt_ray *sr)
{
    rt_vec3 n = facing_normal(sc, eye, h);
    rt_vec3 p = hit_point(sc, h);
    rt_vec3 l = rt_sub(sc->light[light], p);
    if (!(rt_dot(n, l) > 0)) return 0;
    rt_vec3 o = rt_offset_origin(p, n);
    rt_ray_init(sr, o, rt_sub(sc->light[light], o));
    sr->tmin = 0.0f;
    sr->tmax = 1.0f;
    return 1;
}

void rt_shade_hit(const rt_scene *sc, const rt_ray *eye, const rt_hit *h, const int vis[RT_NLIGHTS],
                  unsigned lights, float rgb[3])
{
    const float *alb = sc->shade[h->tri].rgb;
    rt_vec3 n = facing_normal(sc, eye, h);
    if (!lights) {
        float c = -rt_dot(n, rt_norm(eye->d));
        for (int k = 0; k < 3; k++) rgb[k] = alb[k] * (sc->ambient + c * sc->light_power);
        return;
    }
    for (int k = 0; k < 3; k++) rgb[k] = alb[k] * sc->ambient;
    rt_vec3 p = hit_point(sc, h);
    for (int i = 0; i < RT_NLIGHTS; i++) {
        if (!(lights & (1u << i)) || !vis[i]) continue;
        rt_vec3 l = rt_norm(rt_sub(sc->light[i], p));
        float ndl = rt_dot(n, l);
        if (!(ndl > 0)) continue;
        float s = ndl * sc->light_power;
        for (int k = 0; k < 3; k++) rgb[k] += alb[k] * s;
    }
}
