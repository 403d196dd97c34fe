/* shade.c -- the shared shading rule and shadow-ray construction (see
 * shade.h). Keeping them in one place is what makes the tracers' images
 * bit-identical. */
#include "shade.h"

#include <math.h>
#include <string.h>

/* Unit geometric normal facing the side the eye ray came from. */
static rt_vec3 facing_normal(const rt_scene *sc, const rt_ray *eye, const rt_hit *h)
{
    rt_tri tmp;
    rt_vec3 n = rt_norm(rt_tri_normal(rt_scene_tri_of(sc, h->tri, &tmp)));
    if (rt_dot(n, eye->d) > 0) n = rt_mul(n, -1.0f);
    return n;
}

/* From barycentrics, not o + t d: the robust offset assumes a point
 * computed on the triangle (o + t d can land a few ULPs off it at large
 * scales and let the shadow ray re-hit its own triangle). */
static rt_vec3 hit_point(const rt_scene *sc, const rt_hit *h)
{
    rt_tri tmp;
    return rt_tri_point(rt_scene_tri_of(sc, h->tri, &tmp), h->u, h->v);
}

int rt_shade_ray(const rt_scene *sc, const rt_ray *eye, const rt_hit *h, int light, rt_ray *sr)
{
    rt_vec3 n = facing_normal(sc, eye, h);
    rt_vec3 p = hit_point(sc, h);
    rt_vec3 l = rt_sub(sc->light[light], p);
    if (!(rt_dot(n, l) > 0)) return 0;
    rt_vec3 o = rt_offset_origin_scaled(p, n, rt_scene_offset_scale(sc));
    rt_ray_init(sr, o, rt_sub(sc->light[light], o));
    sr->tmin = 0.0f;
    sr->tmax = 1.0f;
    return 1;
}

void rt_shade_hit(const rt_scene *sc, const rt_ray *eye, const rt_hit *h, const int vis[RT_NLIGHTS],
                  unsigned lights, float rgb[3])
{
    const float *alb = rt_scene_shade_of(sc, h->tri)->rgb;
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
        float s = ndl * (sc->light_power * sc->light_scale[i]);
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

/* ---- lights as authored (shade.h) ------------------------------------------- */

int rt_shade_authored(const rt_scene *sc, const rt_render_opts *o) { return o->light_samples > 0 && sc->nlight > 0; }

uint32_t rt_shade_light_nsamples(const rt_scene *sc, const rt_render_opts *o, uint32_t i)
{
    int k = sc->lights[i].kind;
    return k == RT_LIGHT_POINT || k == RT_LIGHT_DISTANT ? 1u : o->light_samples;
}

/* Uniform float in [0, 1) for dimension dim of sample k of light i at hit h. */
static float light_rand(const rt_hit *h, uint32_t i, uint32_t k, uint32_t dim)
{
    uint32_t ub, vb;
    memcpy(&ub, &h->u, 4);
    memcpy(&vb, &h->v, 4);
    uint64_t x = rt_mix64(((uint64_t)h->tri << 32 | ub) ^ 0x9e3779b97f4a7c15ULL);
    x = rt_mix64(x ^ ((uint64_t)vb << 32 | i) ^ 0xc2b2ae3d27d4eb4fULL);
    x = rt_mix64(x ^ ((uint64_t)k << 32 | dim) ^ 0x165667b19e3779f9ULL);
    return (float)(x >> 40) * (1.0f / 16777216.0f);
}

/* A point of the unit disk by rejection from the hash (no trigonometry:
 * the same bits on every machine); the centre after 16 misses. */
static void light_disk(const rt_hit *h, uint32_t i, uint32_t k, float *x, float *y)
{
    *x = *y = 0.0f;
    for (uint32_t t = 0; t < 16; t++) {
        float a = 2.0f * light_rand(h, i, k, 2 + 2 * t) - 1.0f, b = 2.0f * light_rand(h, i, k, 3 + 2 * t) - 1.0f;
        if (a * a + b * b < 1.0f && a * a + b * b > 0x1p-20f) {
            *x = a;
            *y = b;
            return;
        }
    }
}

/* Duff et al. (JCGT 2017) orthonormal basis t, s about unit n. */
static void light_basis(rt_vec3 n, rt_vec3 *t, rt_vec3 *s)
{
    float sign = copysignf(1.0f, n.z), a = -1.0f / (sign + n.z), b = n.x * n.y * a;
    *t = rt_v3(1.0f + sign * n.x * n.x * a, sign * b, -sign * n.x);
    *s = rt_v3(b, sign + n.y * n.y * a, -n.y);
}

/* Length that takes a ray from o past every point of the scene. */
static float reach(const rt_scene *sc, rt_vec3 o)
{
    rt_vec3 c = rt_mul(rt_add(sc->bounds.lo, sc->bounds.hi), 0.5f);
    return 2.0f * (rt_len(rt_sub(sc->bounds.hi, sc->bounds.lo)) + rt_len(rt_sub(o, c))) + 1.0f;
}

int rt_shade_sample_ray(const rt_scene *sc, const rt_render_opts *o, const rt_ray *eye, const rt_hit *h, uint32_t i,
                        uint32_t k, rt_ray *sr, float *w, uint32_t *tri)
{
    (void)o;
    const rt_light *L = &sc->lights[i];
    rt_vec3 n = facing_normal(sc, eye, h);
    rt_vec3 p = hit_point(sc, h);
    rt_vec3 q, dir;
    float tmax = 1.0f;
    *tri = RT_NO_HIT;
    *w = 0.0f;
    switch (L->kind) {
    case RT_LIGHT_POINT:
        q = L->p;
        break;
    case RT_LIGHT_MESH: {
        float a = light_rand(h, i, k, 0);
        uint32_t lo = 0, hi = L->count - 1; /* first entry with cdf > a */
        while (lo < hi) {
            uint32_t mid = lo + (hi - lo) / 2;
            if (L->cdf[mid] > a) hi = mid;
            else lo = mid + 1;
        }
        *tri = L->first + lo;
        float b1 = light_rand(h, i, k, 1), b2 = light_rand(h, i, k, 2);
        if (b1 + b2 > 1.0f) b1 = 1.0f - b1, b2 = 1.0f - b2;
        rt_tri tmp;
        q = rt_tri_point(rt_scene_tri_of(sc, *tri, &tmp), b1, b2);
        tmax = 0.999f;
        break;
    }
    case RT_LIGHT_SPHERE: {
        rt_vec3 pc = rt_sub(p, L->p);
        float dist = rt_len(pc);
        if (!(dist > L->r)) return 0;
        rt_vec3 wc = rt_mul(pc, 1.0f / dist), t, s;
        light_basis(wc, &t, &s);
        /* uniform on the cap seen from p: cos in [r / dist, 1] */
        float zmin = L->r / dist, z = zmin + (1.0f - zmin) * light_rand(h, i, k, 0);
        float x, y;
        light_disk(h, i, k, &x, &y); /* its direction about wc: (x, y) / |(x, y)| */
        if (!(x * x + y * y > 0)) x = 1.0f, y = 0.0f;
        float rr = sqrtf(fmaxf(0.0f, 1.0f - z * z)) / sqrtf(x * x + y * y);
        rt_vec3 u = rt_add(rt_add(rt_mul(t, x * rr), rt_mul(s, y * rr)), rt_mul(wc, z));
        q = rt_add(L->p, rt_mul(u, L->r));
        tmax = 0.999f;
        break;
    }
    case RT_LIGHT_DISK: {
        rt_vec3 t, s;
        float x, y;
        light_basis(L->d, &t, &s);
        light_disk(h, i, k, &x, &y);
        q = rt_add(L->p, rt_add(rt_mul(t, x * L->r), rt_mul(s, y * L->r)));
        tmax = 0.999f;
        break;
    }
    case RT_LIGHT_DISTANT: {
        float c = rt_dot(n, L->d);
        if (!(c > 0)) return 0;
        rt_vec3 so = rt_offset_origin(p, n);
        rt_ray_init(sr, so, rt_mul(L->d, reach(sc, so)));
        sr->tmin = 0.0f;
        sr->tmax = 1.0f;
        *w = c;
        return 1;
    }
    default: { /* RT_LIGHT_INFINITE: cosine-distributed about n */
        rt_vec3 t, s;
        float x, y;
        light_basis(n, &t, &s);
        light_disk(h, i, k, &x, &y);
        float z = sqrtf(fmaxf(0.0f, 1.0f - x * x - y * y));
        dir = rt_add(rt_add(rt_mul(t, x), rt_mul(s, y)), rt_mul(n, z));
        if (!(rt_dot(n, dir) > 0)) return 0;
        rt_vec3 so = rt_offset_origin(p, n);
        rt_ray_init(sr, so, rt_mul(dir, reach(sc, so)));
        sr->tmin = 0.0f;
        sr->tmax = 1.0f;
        *w = 1.0f;
        return 1;
    }
    }
    /* to the point q: as rt_shade_ray does for a point light */
    rt_vec3 l = rt_sub(q, p);
    if (!(rt_dot(n, l) > 0)) return 0;
    rt_vec3 so = rt_offset_origin(p, n);
    rt_ray_init(sr, so, rt_sub(q, so));
    sr->tmin = 0.0f;
    sr->tmax = tmax;
    *w = rt_dot(n, rt_norm(l));
    return *w > 0;
}

void rt_shade_pixel_lw(const rt_scene *sc, const rt_render_opts *o, const rt_ray *eye, const rt_hit *h,
                       const float *lw, rt_image *img, size_t pix)
{
    float rgb[3];
    if (h) {
        const float *alb = rt_scene_shade_of(sc, h->tri)->rgb;
        for (int k = 0; k < 3; k++) rgb[k] = alb[k] * sc->ambient;
        for (uint32_t i = 0; i < sc->nlight; i++) {
            if (!rt_render_light_on(o, i) || !(lw[i] > 0)) continue;
            float s = (lw[i] / (float)rt_shade_light_nsamples(sc, o, i)) * (sc->light_power * sc->lights[i].scale);
            for (int k = 0; k < 3; k++) rgb[k] += alb[k] * s;
        }
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

/* ---- secondary modes (whitted, path) ---------------------------------------- */

void rt_shade_path_start(rt_path *p, const rt_ray *eye, uint32_t pix, uint32_t sample)
{
    memset(p, 0, sizeof *p);
    p->o = eye->o;
    p->d = eye->d;
    p->w[0] = p->w[1] = p->w[2] = 1.0f;
    p->pix = pix;
    p->sample = sample;
    p->from_tri = RT_NO_HIT;
}

void rt_shade_path_ray(const rt_path *p, rt_ray *r) { rt_ray_init(r, p->o, p->d); }

float rt_shade_rand(uint32_t pix, uint32_t sample, uint32_t bounce, uint32_t dim)
{
    /* counter-based: two rounds of the murmur3 finalizer over the counters */
    uint64_t h = rt_mix64(((uint64_t)pix << 32) ^ sample ^ 0x9e3779b97f4a7c15ULL);
    h = rt_mix64(h ^ ((uint64_t)bounce << 32) ^ dim ^ 0xd1b54a32d192ed03ULL);
    return (float)(h >> 40) * (1.0f / 16777216.0f);
}

#define ACC_ONE 4294967296.0           /* 2^32: fixed-point scale */
#define ACC_LIM 2305843009213693952LL  /* 2^61: saturation bound */

void rt_acc_add(rt_acc *a, const float c[3])
{
    for (int k = 0; k < 3; k++) {
        double x = (double)c[k] * ACC_ONE;
        if (!(x == x)) continue;
        if (x > (double)ACC_LIM) x = (double)ACC_LIM;
        if (x < -(double)ACC_LIM) x = -(double)ACC_LIM;
        int64_t v = a->v[k] + (int64_t)floor(x + 0.5);
        a->v[k] = v > ACC_LIM ? ACC_LIM : v < -ACC_LIM ? -ACC_LIM : v;
    }
}

void rt_acc_pixel(const rt_acc *a, int spp, const rt_ray *eye, const rt_hit *h, rt_image *img, size_t pix)
{
    for (int k = 0; k < 3; k++) img->rgb[3 * pix + k] = (float)((double)a->v[k] / ACC_ONE / (double)spp);
    img->depth[pix] = h && h->tri != RT_NO_HIT ? h->t * rt_len(eye->d) : INFINITY;
}

static float gamma_n(int n)
{
    const float eps = 0x1p-24f;
    return (n * eps) / (1 - n * eps);
}

rt_vec3 rt_shade_offset(const rt_tri *tri, float u, float v, rt_vec3 n, int side)
{
    rt_vec3 p = rt_tri_point(tri, u, v);
    /* p = p0 + (u (p1 - p0) + v (p2 - p0)): five roundings on terms bounded
     * by |p0|, |u| (|p0| + |p1|), |v| (|p0| + |p2|); gamma(7) covers them
     * with margin (pbrt bounds its barycentric sum the same way). */
    const float *P = (const float *)(const void *)tri->p;
    const float *pp = (const float *)(const void *)&p;
    float err[3], fu = fabsf(u), fv = fabsf(v), ext = 0.0f;
    for (int k = 0; k < 3; k++) {
        float a0 = fabsf(P[k]), a1 = fabsf(P[3 + k]), a2 = fabsf(P[6 + k]);
        err[k] = gamma_n(7) * (a0 + fu * (a0 + a1) + fv * (a0 + a2));
        for (int i = 0; i < 3; i++) ext = fmaxf(ext, fabsf(P[3 * i + k] - pp[k]));
    }
    /* pbrt's triangle test also rejects hits with t below its own error
     * bound (deltaT); rt_isect_tri does not, so the offset covers that
     * error too: the watertight test misjudges a point's depth by at most a
     * few roundings of the vertices' distances from the origin, at most the
     * triangle's extent about p (a plane at x = 0 has no point error, yet a
     * ray leaving it finds its own triangle at t ~ 1e-8 without this). */
    float d = fabsf(n.x) * err[0] + fabsf(n.y) * err[1] + fabsf(n.z) * err[2] + gamma_n(16) * ext;
    rt_vec3 off = rt_mul(n, side > 0 ? d : -d);
    float *po = (float *)(void *)&p;
    const float *of = (const float *)(const void *)&off;
    for (int k = 0; k < 3; k++) {
        po[k] = po[k] + of[k];
        if (of[k] > 0) po[k] = nextafterf(po[k], INFINITY);
        else if (of[k] < 0) po[k] = nextafterf(po[k], -INFINITY);
    }
    return p;
}

static int nonzero(const float w[3]) { return w[0] != 0.0f || w[1] != 0.0f || w[2] != 0.0f; }

/* A child ray: the parent's record with a new origin, direction, weight. */
static void child(rt_shade_out *out, const rt_path *p, rt_vec3 o, rt_vec3 d, const float w[3], uint32_t tri)
{
    if (!nonzero(w)) return;
    rt_path *c = &out->child[out->nchild++];
    *c = *p;
    c->o = o;
    c->d = d;
    for (int k = 0; k < 3; k++) c->w[k] = w[k];
    c->depth = (uint16_t)(p->depth + 1);
    c->from_tri = tri;
    c->kind = 0;
}

static float mat_ior(const rt_scene *sc, uint16_t m) { return m < sc->nmat ? sc->mat[m].ior : 1.0f; }

/* Snell refraction of unit d at facing unit normal n (n.d < 0) through the
 * surface of material m, with the ray's media stack in c (updated). Returns
 * 0 on total internal reflection. */
static int refract_dir(const rt_scene *sc, rt_vec3 d, rt_vec3 n, uint16_t m, rt_path *c, rt_vec3 *t)
{
    int inside = c->nmed && c->med[c->nmed - 1] == m;
    float eta_i, eta_t;
    if (inside) {
        eta_i = mat_ior(sc, m);
        eta_t = c->nmed >= 2 ? mat_ior(sc, c->med[c->nmed - 2]) : 1.0f;
    } else {
        eta_i = c->nmed ? mat_ior(sc, c->med[c->nmed - 1]) : 1.0f;
        eta_t = mat_ior(sc, m);
    }
    float eta = eta_i / eta_t, cosi = -rt_dot(d, n);
    float k = 1.0f - eta * eta * (1.0f - cosi * cosi);
    if (k < 0.0f) return 0;
    *t = rt_add(rt_mul(d, eta), rt_mul(n, eta * cosi - sqrtf(k)));
    if (inside) {
        c->nmed--;
    } else {
        if (c->nmed == RT_PATH_MEDIA) { /* deeper nesting: forget the outermost */
            memmove(c->med, c->med + 1, sizeof c->med[0] * (RT_PATH_MEDIA - 1));
            c->nmed--;
        }
        c->med[c->nmed++] = m;
    }
    return 1;
}

static rt_vec3 reflect_dir(rt_vec3 d, rt_vec3 n) { return rt_sub(d, rt_mul(n, 2.0f * rt_dot(d, n))); }

/* Cosine-weighted direction about unit n from the path's random numbers;
 * the disk point is drawn by rejection (no trigonometry, so the same bits
 * on every machine). */
static rt_vec3 cosine_dir(rt_vec3 n, const rt_path *p)
{
    float x = 0.0f, y = 0.0f;
    for (uint32_t k = 0; k < 16; k++) {
        float a = 2.0f * rt_shade_rand(p->pix, p->sample, p->depth, 1 + 2 * k) - 1.0f;
        float b = 2.0f * rt_shade_rand(p->pix, p->sample, p->depth, 2 + 2 * k) - 1.0f;
        if (a * a + b * b < 1.0f) {
            x = a;
            y = b;
            break;
        }
    }
    float z = sqrtf(fmaxf(0.0f, 1.0f - x * x - y * y));
    /* Duff et al. (JCGT 2017) orthonormal basis */
    float sign = copysignf(1.0f, n.z), a = -1.0f / (sign + n.z), b = n.x * n.y * a;
    rt_vec3 t = rt_v3(1.0f + sign * n.x * n.x * a, sign * b, -sign * n.x);
    rt_vec3 s = rt_v3(b, sign + n.y * n.y * a, -n.y);
    return rt_add(rt_add(rt_mul(t, x), rt_mul(s, y)), rt_mul(n, z));
}

static float avg3(const float v[3]) { return (v[0] + v[1] + v[2]) * (1.0f / 3.0f); }

void rt_shade_step(const rt_scene *sc, const rt_render_opts *o, const rt_path *p, const rt_ray *r, const rt_hit *h,
                   rt_shade_out *out)
{
    memset(out, 0, sizeof *out);
    if (!h || h->tri == RT_NO_HIT) {
        out->c[0] = p->w[0] * sc->background.x;
        out->c[1] = p->w[1] * sc->background.y;
        out->c[2] = p->w[2] * sc->background.z;
        return;
    }
    const int path = o->mode == RT_MODE_PATH;
    rt_tri Tt;
    const rt_tri *T = rt_scene_tri_of(sc, h->tri, &Tt);
    const rt_shade *S = rt_scene_shade_of(sc, h->tri);
    const uint16_t m = (uint16_t)(S->mat < sc->nmat ? S->mat : 0);
    const rt_material *M = &sc->mat[m];
    const float *alb = S->rgb;
    out->self_hit = h->tri == p->from_tri;
    rt_vec3 n = facing_normal(sc, r, h);
    rt_vec3 d = rt_norm(r->d);
    rt_vec3 ph = hit_point(sc, h);

    /* what needs no visibility: ambient (whitted) or nothing, plus emission */
    for (int k = 0; k < 3; k++) {
        float local = path ? 0.0f : alb[k] * sc->ambient;
        if (!path && !o->lights) local = alb[k] * (sc->ambient + -rt_dot(n, d) * sc->light_power);
        out->c[k] = p->w[k] * (local + M->ke[k]);
    }
    /* shadow rays: next-event estimation to the point lights */
    rt_vec3 so = rt_shade_offset(T, h->u, h->v, n, 1);
    for (int i = 0; i < RT_NLIGHTS; i++) {
        if (!(o->lights & (1u << i))) continue;
        rt_vec3 l = rt_norm(rt_sub(sc->light[i], ph));
        float ndl = rt_dot(n, l);
        if (!(ndl > 0)) continue;
        float s = ndl * (sc->light_power * sc->light_scale[i]);
        for (int k = 0; k < 3; k++) out->lc[i][k] = p->w[k] * (alb[k] * s);
        if (!nonzero(out->lc[i])) continue;
        out->want[i] = 1;
        rt_ray_init(&out->sray[i], so, rt_sub(sc->light[i], so));
        out->sray[i].tmin = 0.0f;
        out->sray[i].tmax = 1.0f;
    }

    rt_vec3 refl = reflect_dir(d, n);
    if (!path) {
        if (p->depth + 1 >= o->depth) return;
        float wr[3], wt[3];
        for (int k = 0; k < 3; k++) {
            wr[k] = p->w[k] * M->ks[k];
            wt[k] = p->w[k] * M->kt[k];
        }
        rt_path c = *p;
        rt_vec3 tdir;
        int refr = nonzero(wt) && refract_dir(sc, d, n, m, &c, &tdir);
        if (nonzero(wt) && !refr) /* total internal reflection: the refracted weight reflects */
            for (int k = 0; k < 3; k++) wr[k] = p->w[k] * (M->ks[k] + M->kt[k]);
        child(out, p, so, refl, wr, h->tri);
        if (refr) {
            child(out, &c, rt_shade_offset(T, h->u, h->v, n, -1), tdir, wt, h->tri);
            out->child[out->nchild - 1].kind = RT_PATH_REFRACT;
        }
        return;
    }

    /* path: one continuation, chosen with probability proportional to the
     * mean of each term */
    if (p->depth >= o->bounces) return;
    float pd = avg3(alb), ps = avg3(M->ks), pt = avg3(M->kt), sum = pd + ps + pt;
    if (!(sum > 0.0f)) return;
    float u = rt_shade_rand(p->pix, p->sample, p->depth, 0) * sum;
    float w[3];
    if ((u < pd && pd > 0.0f) || (!(ps > 0.0f) && !(pt > 0.0f))) {
        for (int k = 0; k < 3; k++) w[k] = p->w[k] * (alb[k] * (sum / pd));
        child(out, p, so, cosine_dir(n, p), w, h->tri);
    } else if ((u < pd + ps && ps > 0.0f) || !(pt > 0.0f)) {
        for (int k = 0; k < 3; k++) w[k] = p->w[k] * (M->ks[k] * (sum / ps));
        child(out, p, so, refl, w, h->tri);
    } else {
        rt_path c = *p;
        rt_vec3 tdir;
        for (int k = 0; k < 3; k++) w[k] = p->w[k] * (M->kt[k] * (sum / pt));
        if (refract_dir(sc, d, n, m, &c, &tdir)) child(out, &c, rt_shade_offset(T, h->u, h->v, n, -1), tdir, w, h->tri);
        else child(out, p, so, refl, w, h->tri); /* total internal reflection */
    }
}
