/* shade.c -- the shared shading rule and shadow-ray construction (see
 * shade.h). Keeping them in one place is what makes the tracers' images
 * bit-identical. */
#include "shade.h"

#include <math.h>

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

int rt_shade_ray(const rt_scene *sc, const rt_ray *eye, const rt_hit *h, int light, rt_ray *sr)
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

void rt_shade_pixel(const rt_scene *sc, const rt_ray *eye, const rt_hit *h, const int vis[RT_NLIGHTS],
                    unsigned lights, rt_image *img, size_t pix)
{
    float rgb[3];
    if (h) {
        rt_shade_hit(sc, eye, h, vis, lights, rgb);
        img->depth[pix] = h->t * rt_len(eye->d);
    } else {
        rgb[0] = sc->background.x;
        rgb[1] = sc->background.y;
        rgb[2] = sc->background.z;
        img->depth[pix] = INFINITY;
    }
    img->rgb[3 * pix] = rgb[0];
    img->rgb[3 * pix + 1] = rgb[1];
    img->rgb[3 * pix + 2] = rgb[2];
}
