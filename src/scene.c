/*
 * scene.c -- the scene container: allocation and growth, bounds and
 * validation, the default camera and lights for loaded meshes, the identity
 * hash, OBJ (and MTL) export, the material presets and the material listing.
 * The loaders fill it; the dispatch over them (rt_scene_load) lives above
 * them in scene_load.c, so the container includes no loader.
 *
 * Everything here is deterministic and machine independent: the hash reads
 * every float as its IEEE-754 bit pattern in little-endian byte order, and
 * rt_scene_autoframe uses only + - * / and sqrt.
 */
#include "config.h"
#include "scene.h"
#include "alpha.h"
#include "outfile.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include <sys/file.h>
#include <fcntl.h>

/* Light grey for meshes without colour. */
static const float default_grey[3] = {0.7f, 0.7f, 0.7f};

/* The public struct has no capacity field, so every scene is allocated
 * inside this private wrapper (public part first, so the pointers are
 * interchangeable). Scenes must therefore come from rt_scene_new. */
typedef struct scene_priv {
    rt_scene pub;  /* what callers see */
    uint32_t cap;  /* allocated triangles in pub.tri and pub.shade */
    int framed;    /* camera set by rt_scene_autoframe */
} scene_priv;

rt_scene *rt_scene_new(uint32_t ntri, rt_err *e)
{
    scene_priv *p = rt_calloc(1, sizeof *p, e);
    if (!p) return NULL;
    rt_scene *s = &p->pub;
    s->bounds = rt_bounds_empty();
    s->light_power = 0.45f;
    for (int i = 0; i < RT_NLIGHTS; i++) s->light_scale[i] = 1.0f;
    s->ambient = 0.1f;
    s->background = rt_v3(0.05f, 0.05f, 0.08f);
    s->cam.up = rt_v3(0, 0, 1);
    s->cam.at = rt_v3(0, 0, 0);
    s->cam.eye = rt_v3(0, -1, 0);
    s->cam.fovy_deg = 45.0f;
    s->mat = rt_calloc(1, sizeof *s->mat, e);
    if (!s->mat) {
        rt_scene_free(s);
        return NULL;
    }
    s->mat[0].ior = 1.0f;
    s->nmat = 1;
    if (rt_scene_reserve(s, ntri ? ntri : 16, e) < 0) {
        rt_scene_free(s);
        return NULL;
    }
    return s;
}

int rt_scene_reserve(rt_scene *s, uint32_t ntri, rt_err *e)
{
    scene_priv *p = (scene_priv *)s;
    if (ntri <= p->cap) return 0;
    rt_tri *t = rt_reallocarray(s->tri, ntri, sizeof *t, e);
    if (!t) return -1;
    s->tri = t;
    rt_shade *h = rt_reallocarray(s->shade, ntri, sizeof *h, e);
    if (!h) return -1;
    s->shade = h;
    p->cap = ntri;
    return 0;
}

int rt_scene_add_tri_mat(rt_scene *s, rt_vec3 a, rt_vec3 b, rt_vec3 c, const float rgb[3], uint32_t mat, rt_err *e)
{
    if (mat >= s->nmat) return rt_errf(e, "%s: material %u of %u does not exist", s->name, (unsigned)mat, (unsigned)s->nmat);
    scene_priv *p = (scene_priv *)s;
    uint32_t n = s->ntri;
    if (n >= p->cap) {
        if (n >= UINT32_MAX / 2) return rt_errf(e, "%s: too many triangles", s->name);
        if (rt_scene_reserve(s, n < 16 ? 16 : 2 * n, e) < 0) return -1;
    }
    rt_tri *t = &s->tri[n];
    t->p[0] = a;
    t->p[1] = b;
    t->p[2] = c;
    const float *col = rgb ? rgb : default_grey;
    rt_shade *h = &s->shade[n];
    h->rgb[0] = col[0];
    h->rgb[1] = col[1];
    h->rgb[2] = col[2];
    h->mat = mat;
    s->ntri = n + 1;
    return 0;
}

int rt_scene_add_tri(rt_scene *s, rt_vec3 a, rt_vec3 b, rt_vec3 c, const float rgb[3], rt_err *e)
{
    return rt_scene_add_tri_mat(s, a, b, c, rgb, 0, e);
}

static int bad_term(float v) { return !(v >= 0.0f) || v > 1e30f; }

int rt_scene_add_material(rt_scene *s, const rt_material *m, rt_err *e)
{
    const char *nm = m->name[0] ? m->name : "(unnamed)";
    for (int k = 0; k < 3; k++)
        if (bad_term(m->ks[k]) || bad_term(m->kt[k]) || bad_term(m->ke[k]))
            return rt_errf(e, "%s: material '%s': a term is negative, NaN or infinite", s->name, nm);
    if (!(m->ior >= 1.0f && m->ior <= 100.0f))
        return rt_errf(e, "%s: material '%s': index of refraction %g outside [1, 100]", s->name, nm, (double)m->ior);
    if (s->nmat >= 65536) return rt_errf(e, "%s: more than 65536 materials", s->name);
    /* the table grows by doubling (the allocation holds the next power of
     * two entries at least): one entry at a time made a file of many
     * materials quadratic where realloc copies (sanitizer builds) */
    if ((s->nmat & (s->nmat - 1)) == 0) {
        rt_material *t = rt_reallocarray(s->mat, s->nmat ? 2 * (size_t)s->nmat : 1, sizeof *t, e);
        if (!t) return -1;
        s->mat = t;
    }
    rt_material *d = &s->mat[s->nmat];
    *d = *m;
    d->name[sizeof d->name - 1] = 0;
    d->flags = 0;
    for (int k = 0; k < 3; k++) {
        if (m->ks[k] > 0) d->flags |= RT_MAT_SPECULAR;
        if (m->kt[k] > 0) d->flags |= RT_MAT_TRANSMIT;
        if (m->ke[k] > 0) d->flags |= RT_MAT_EMIT;
    }
    return (int)s->nmat++;
}

uint32_t rt_scene_material_flags(const rt_scene *s)
{
    uint32_t used = 0;
    for (uint32_t m = 1; m < s->nmat; m++) used |= s->mat[m].flags;
    if (!used) return 0;
    used = 0;
    for (uint32_t i = 0, n = rt_scene_nshade(s); i < n; i++) used |= s->mat[s->shade[i].mat].flags;
    return used;
}

const char *const rt_material_preset_names[] = {"diffuse", "mirror", "glass", NULL};

int rt_scene_set_material(rt_scene *s, const char *name, rt_err *e)
{
    rt_material m;
    memset(&m, 0, sizeof m);
    m.ior = 1.0f;
    if (!strcmp(name, "mirror")) {
        m.ks[0] = m.ks[1] = m.ks[2] = 0.8f;
    } else if (!strcmp(name, "glass")) {
        m.kt[0] = m.kt[1] = m.kt[2] = 1.0f;
        m.ior = 1.5f;
    } else if (strcmp(name, "diffuse") != 0) {
        char q[48];
        return rt_errf(e, "%s: unknown material '%s' (known: diffuse, mirror, glass)", s->name,
                       rt_esc(q, sizeof q, name, 32));
    }
    snprintf(m.name, sizeof m.name, "%s", name);
    /* Drop the table but entry 0; the preset (if not plain) becomes 1. */
    s->nmat = 1;
    uint32_t idx = 0;
    if (strcmp(name, "diffuse") != 0) {
        int r = rt_scene_add_material(s, &m, e);
        if (r < 0) return -1;
        idx = (uint32_t)r;
    }
    for (uint32_t i = 0, n = rt_scene_nshade(s); i < n; i++) s->shade[i].mat = idx;
    return 0;
}

int rt_scene_describe_materials(const rt_scene *s, FILE *f)
{
    uint32_t *use = calloc(s->nmat, sizeof *use);
    if (use)
        for (uint32_t i = 0, n = rt_scene_nshade(s); i < n; i++)
            if (s->shade[i].mat < s->nmat) use[s->shade[i].mat]++;
    fprintf(f, "%-4s %-20s %10s %-15s %-26s %-26s %-6s %s\n", "mat", "name", "triangles", "flags", "ks", "kt",
            "ior", "ke");
    for (uint32_t m = 0; m < s->nmat; m++) {
        const rt_material *t = &s->mat[m];
        char fl[32] = "";
        if (t->flags & RT_MAT_SPECULAR) strcat(fl, "specular,");
        if (t->flags & RT_MAT_TRANSMIT) strcat(fl, "transmit,");
        if (t->flags & RT_MAT_EMIT) strcat(fl, "emit,");
        if (fl[0]) fl[strlen(fl) - 1] = 0;
        else strcpy(fl, "diffuse");
        char ks[48], kt[48], ke[48], tri[16];
        snprintf(ks, sizeof ks, "%g %g %g", (double)t->ks[0], (double)t->ks[1], (double)t->ks[2]);
        snprintf(kt, sizeof kt, "%g %g %g", (double)t->kt[0], (double)t->kt[1], (double)t->kt[2]);
        snprintf(ke, sizeof ke, "%g %g %g", (double)t->ke[0], (double)t->ke[1], (double)t->ke[2]);
        if (use) snprintf(tri, sizeof tri, "%u", (unsigned)use[m]);
        else snprintf(tri, sizeof tri, "?");
        char nm[40];
        rt_esc(nm, sizeof nm, m ? t->name : "(plain)", sizeof t->name);
        fprintf(f, "%-4u %-20s %10s %-15s %-26s %-26s %-6g %s\n", (unsigned)m, nm, tri, fl, ks, kt, (double)t->ior,
                ke);
    }
    free(use);
    return ferror(f) ? -1 : 0;
}

void rt_scene_free(rt_scene *s)
{
    if (!s) return;
    free(s->tri);
    free(s->shade);
    free(s->mat);
    free(s->obj);
    free(s->otri);
    free(s->irec);
    for (uint32_t i = 0; i < s->nlight; i++) free(s->lights[i].cdf);
    free(s->lights);
    free(s->warn);
    rt_alpha_free(s->alpha);
    free(s);
}

/* ---- lights as authored (scene.h) ------------------------------------------ */

const char *rt_light_kind_name(int kind)
{
    static const char *const names[RT_LIGHT_KINDS] = {"point", "mesh", "sphere", "disk", "distant", "infinite"};
    return kind >= 0 && kind < RT_LIGHT_KINDS ? names[kind] : "?";
}

static int finite_v(rt_vec3 v) { return isfinite(v.x) && isfinite(v.y) && isfinite(v.z); }

/* Invariants 2, 3, 5 of one light (4 needs the scene: check_mesh). */
static const char *light_problem(const rt_light *l)
{
    if (l->kind < 0 || l->kind >= RT_LIGHT_KINDS) return "unknown kind (invariant 2)";
    if (!finite_v(l->p) || !finite_v(l->d) || !isfinite(l->r))
        return "non-finite position, direction or radius (invariant 2)";
    if (l->kind == RT_LIGHT_DISTANT || l->kind == RT_LIGHT_DISK) {
        float n = rt_len(l->d);
        if (!(fabsf(n - 1.0f) <= 1e-3f)) return "direction not of unit length (invariant 3)";
    }
    if ((l->kind == RT_LIGHT_SPHERE || l->kind == RT_LIGHT_DISK) && !(l->r > 0)) return "radius not > 0 (invariant 3)";
    if (!(l->scale >= 0) || !isfinite(l->scale)) return "scale negative or not finite (invariant 5)";
    return NULL;
}

static const char *mesh_problem(const rt_scene *s, const rt_light *l)
{
    if (l->kind != RT_LIGHT_MESH) return NULL;
    const uint32_t nt = rt_scene_nflat(s);
    if (!l->count || l->first > nt || l->count > nt - l->first) return "triangles out of range (invariant 4)";
    if (!l->cdf) return "no area table (invariant 4)";
    for (uint32_t i = 0; i < l->count; i++)
        if (!(l->cdf[i] >= (i ? l->cdf[i - 1] : 0.0f))) return "area table decreasing (invariant 4)";
    if (l->cdf[l->count - 1] != 1.0f) return "area table not ending in 1 (invariant 4)";
    return NULL;
}

int rt_scene_add_light(rt_scene *s, const rt_light *l, rt_err *e)
{
    rt_light c = *l;
    c.cdf = NULL;
    c.at[sizeof c.at - 1] = 0;
    const char *why = light_problem(&c);
    if (why) return rt_errf(e, "%s: %s light: %s", c.at[0] ? c.at : s->name, rt_light_kind_name(c.kind), why);
    if (c.kind == RT_LIGHT_MESH) {
        if (!c.count || c.first > s->ntri || c.count > s->ntri - c.first)
            return rt_errf(e, "%s: mesh light: triangles out of range (invariant 4)", c.at[0] ? c.at : s->name);
        if (!(c.cdf = rt_calloc(c.count, sizeof *c.cdf, e))) return -1;
        double sum = 0, *acc = rt_calloc(c.count, sizeof *acc, e);
        if (!acc) {
            free(c.cdf);
            return -1;
        }
        for (uint32_t i = 0; i < c.count; i++) {
            const rt_vec3 *v = s->tri[c.first + i].p;
            sum += 0.5 * (double)rt_len(rt_cross(rt_sub(v[1], v[0]), rt_sub(v[2], v[0])));
            acc[i] = sum;
        }
        for (uint32_t i = 0; i < c.count; i++)
            c.cdf[i] = sum > 0 ? (float)(acc[i] / sum) : (float)(i + 1) / (float)c.count;
        c.cdf[c.count - 1] = 1.0f;
        free(acc);
    }
    rt_light *n = rt_reallocarray(s->lights, (size_t)s->nlight + 1, sizeof *n, e);
    if (!n) {
        free(c.cdf);
        return -1;
    }
    s->lights = n;
    s->lights[s->nlight++] = c;
    return 0;
}

int rt_scene_check_lights(const rt_scene *s, rt_err *e)
{
    if ((s->nlight == 0) != (s->lights == NULL))
        return rt_errf(e, "%s: light count and table disagree (invariant 1)", s->name);
    for (uint32_t i = 0; i < s->nlight; i++) {
        const char *why = light_problem(&s->lights[i]);
        if (!why) why = mesh_problem(s, &s->lights[i]);
        if (why) return rt_errf(e, "%s: light %u (%s): %s", s->name, i, rt_light_kind_name(s->lights[i].kind), why);
    }
    return 0;
}

int rt_scene_nonpoint_lights(const rt_scene *s)
{
    for (uint32_t i = 0; i < s->nlight; i++)
        if (s->lights[i].kind != RT_LIGHT_POINT) return 1;
    return 0;
}

/*
 * The bounds of a kept scene's instanced triangles, exactly those of the
 * flattened copy, without making it. A world coordinate is
 * (float)(x) with x = m0 vx + m1 vy + m2 vz + m3 computed in double
 * (rt_scene_inst_tri), and rounding to float is monotone, so the largest
 * world coordinate is (float) of the largest computed x over the object's
 * vertices (the smallest likewise). The object's triangles are cut into
 * chunks of CHUNK with a box each; over a chunk x lies within its box's
 * support values (the linear bounds of the box, in double) widened by the
 * rounding of the computation (SLACK relative, far above its few ulps),
 * so only the chunks whose bound reaches the best value found so far are
 * evaluated vertex by vertex, starting with the most promising one.
 */
#define CHUNK 64u
#define SLACK 1e-12

typedef struct chunkbox {
    double lo[3], hi[3];
} chunkbox;

static double lin(const double *m, const double v[3]) { return m[0] * v[0] + m[1] * v[1] + m[2] * v[2] + m[3]; }

/* Largest (sign 1) or smallest (sign -1) computed coordinate along row m
 * over object triangles t[0 .. n), chunks cb. */
static double kept_extreme(const double *m, const rt_tri *t, uint32_t n, const chunkbox *cb, uint32_t nc, int sign)
{
    uint32_t bestc = 0;
    double bestu = -INFINITY;
    for (uint32_t c = 0; c < nc; c++) { /* the chunk with the highest bound first */
        double u = m[3];
        for (int a = 0; a < 3; a++) {
            const double x = m[a] * cb[c].lo[a], y = m[a] * cb[c].hi[a];
            u += sign > 0 ? (x > y ? x : y) : (x < y ? x : y);
        }
        if (sign * u > bestu) bestu = sign * u, bestc = c;
    }
    double best = -INFINITY; /* sign x, maximized */
    for (uint32_t pass = 0; pass < 2; pass++)
        for (uint32_t c = pass ? 0 : bestc; c < (pass ? nc : bestc + 1); c++) {
            if (pass && c == bestc) continue;
            double u = m[3], mag = fabs(m[3]);
            for (int a = 0; a < 3; a++) {
                const double x = m[a] * cb[c].lo[a], y = m[a] * cb[c].hi[a];
                u += sign > 0 ? (x > y ? x : y) : (x < y ? x : y);
                mag += fabs(x) > fabs(y) ? fabs(x) : fabs(y);
            }
            if (pass && sign * u + SLACK * mag < best) continue;
            const uint32_t end = (c + 1) * CHUNK < n ? (c + 1) * CHUNK : n;
            for (uint32_t j = c * CHUNK; j < end; j++)
                for (int k = 0; k < 3; k++) {
                    const double v[3] = {t[j].p[k].x, t[j].p[k].y, t[j].p[k].z};
                    const double x = sign * lin(m, v);
                    if (x > best) best = x;
                }
        }
    return sign * best;
}

int rt_scene_inst_boxes(const rt_scene *s, rt_bounds *box, rt_err *e)
{
    uint32_t nc = 0;
    for (uint32_t k = 0; k < s->nobj; k++) nc += (s->obj[k].count + CHUNK - 1) / CHUNK;
    chunkbox *cb = rt_calloc(nc ? nc : 1, sizeof *cb, e);
    uint32_t *c0 = rt_calloc(s->nobj ? s->nobj : 1, sizeof *c0, e); /* each object's first chunk */
    if (!cb || !c0) {
        free(cb);
        free(c0);
        return -1;
    }
    for (uint32_t k = 0, c = 0; k < s->nobj; k++) {
        c0[k] = c;
        const rt_scene_obj *o = &s->obj[k];
        for (uint32_t j = 0; j < o->count; j++) {
            if (j % CHUNK == 0) {
                for (int a = 0; a < 3; a++) cb[c].lo[a] = INFINITY, cb[c].hi[a] = -INFINITY;
                c++;
            }
            const rt_tri *t = &s->otri[o->start + j];
            for (int v = 0; v < 3; v++)
                for (int a = 0; a < 3; a++) {
                    const double x = (&t->p[v].x)[a];
                    if (x < cb[c - 1].lo[a]) cb[c - 1].lo[a] = x;
                    if (x > cb[c - 1].hi[a]) cb[c - 1].hi[a] = x;
                }
        }
    }
    int rc = 0;
    for (uint32_t k = 0; k < s->nirec && rc == 0; k++) {
        const rt_scene_inst *q = &s->irec[k];
        const rt_scene_obj *o = &s->obj[q->obj];
        box[k] = rt_bounds_empty();
        if (!o->count) continue;
        const uint32_t n = (o->count + CHUNK - 1) / CHUNK;
        float lo[3], hi[3];
        for (int a = 0; a < 3; a++) {
            lo[a] = (float)kept_extreme(q->m[a], s->otri + o->start, o->count, cb + c0[q->obj], n, -1);
            hi[a] = (float)kept_extreme(q->m[a], s->otri + o->start, o->count, cb + c0[q->obj], n, 1);
            if (!isfinite(lo[a]) || !isfinite(hi[a])) {
                rc = rt_errf(e, "%s: instance %u has a non-finite vertex", s->name, k);
                break;
            }
        }
        if (rc == 0) {
            rt_bounds_grow(&box[k], rt_v3(lo[0], lo[1], lo[2]));
            rt_bounds_grow(&box[k], rt_v3(hi[0], hi[1], hi[2]));
        }
    }
    free(cb);
    free(c0);
    return rc;
}

/* A kept scene's bounds: its records' boxes added to the loose triangles'. */
static int kept_bounds(const rt_scene *s, rt_bounds *b, rt_err *e)
{
    rt_bounds *box = rt_calloc(s->nirec ? s->nirec : 1, sizeof *box, e);
    if (!box || rt_scene_inst_boxes(s, box, e) < 0) {
        free(box);
        return -1;
    }
    for (uint32_t k = 0; k < s->nirec; k++)
        if (box[k].lo.x <= box[k].hi.x) rt_bounds_grow(b, box[k].lo), rt_bounds_grow(b, box[k].hi);
    free(box);
    return 0;
}

int rt_scene_finish(rt_scene *s, rt_err *e)
{
    if (rt_scene_nflat(s) == 0) return rt_errf(e, "%s: scene has no triangles", s->name);
    rt_bounds b = rt_bounds_empty();
    for (uint32_t i = 0; i < s->ntri; i++)
        for (int k = 0; k < 3; k++) {
            rt_vec3 p = s->tri[i].p[k];
            if (!isfinite(p.x) || !isfinite(p.y) || !isfinite(p.z))
                return rt_errf(e, "%s: triangle %u has a non-finite vertex", s->name, i);
            rt_bounds_grow(&b, p);
        }
    if (s->kept && kept_bounds(s, &b, e) < 0) return -1;
    s->bounds = b;
    return 0;
}

int rt_scene_kept_find(const rt_scene *s, uint32_t i, uint32_t *j)
{
    /* the last record with first <= i */
    uint32_t lo = 0, hi = s->nirec;
    while (lo < hi) {
        const uint32_t mid = lo + (hi - lo) / 2;
        if (s->irec[mid].first <= i) lo = mid + 1;
        else hi = mid;
    }
    if (lo == 0) {
        *j = i;
        return -1;
    }
    const rt_scene_inst *q = &s->irec[lo - 1];
    const uint32_t n = s->obj[q->obj].count;
    if (i - q->first < n) {
        *j = i - q->first;
        return (int)(lo - 1);
    }
    *j = q->loose + (i - q->first - n);
    return -1;
}

int rt_scene_check_kept(const rt_scene *s, rt_err *e)
{
    if (!s->kept) return 0;
    uint64_t inst = 0;
    for (uint32_t k = 0; k < s->nirec; k++) {
        const rt_scene_inst *q = &s->irec[k];
        if (q->obj >= s->nobj || (uint64_t)s->obj[q->obj].start + s->obj[q->obj].count > s->notri)
            return rt_errf(e, "%s: kept instance %u: object %u outside the object store", s->name, k, q->obj);
        const uint32_t n = s->obj[q->obj].count;
        if (k && q->first < (uint64_t)s->irec[k - 1].first + s->obj[s->irec[k - 1].obj].count)
            return rt_errf(e, "%s: kept instance %u: not after the one before it", s->name, k);
        if ((uint64_t)q->first + n > s->nflat)
            return rt_errf(e, "%s: kept instance %u: triangles beyond the %u of the flattened scene", s->name, k,
                           s->nflat);
        if ((uint64_t)q->loose + inst != q->first || q->loose > s->ntri)
            return rt_errf(e, "%s: kept instance %u: %u loose triangles before it, its position says %llu", s->name, k,
                           q->loose, (unsigned long long)(q->first - inst));
        inst += n;
    }
    if (inst != s->nirec_tri)
        return rt_errf(e, "%s: kept instances: the records hold %llu triangles, the scene says %u", s->name,
                       (unsigned long long)inst, s->nirec_tri);
    if ((uint64_t)s->ntri + inst != s->nflat)
        return rt_errf(e, "%s: kept instances: %u loose + %llu instanced triangles, not %u", s->name, s->ntri,
                       (unsigned long long)inst, s->nflat);
    return 0;
}

int rt_scene_check_range(const rt_scene *s, const char *where, rt_err *e)
{
    rt_bounds b = s->bounds;
    if (!(b.lo.x <= b.hi.x)) return 0; /* empty: rt_scene_finish refuses it */
    double m = 0;
    float c[6] = {b.lo.x, b.lo.y, b.lo.z, b.hi.x, b.hi.y, b.hi.z};
    for (int k = 0; k < 6; k++) m = fmax(m, fabs((double)c[k]));
    double dx = (double)b.hi.x - b.lo.x, dy = (double)b.hi.y - b.lo.y, dz = (double)b.hi.z - b.lo.z;
    double d = sqrt(dx * dx + dy * dy + dz * dz);
    if (m > RT_COORD_MAX)
        return rt_errf(e, "%s: coordinate magnitude %.9g above %g (docs/scenes.md: coordinate range)", where, m,
                       RT_COORD_MAX);
    /* a far-off scene whose extent rounded away: the relative rule says why */
    if (d < m * RT_EXTENT_MIN_REL && m > 0)
        return rt_errf(e, "%s: scene extent %.9g is below 1/8192 of its largest coordinate %.9g: single "
                          "precision cannot resolve it there (docs/scenes.md: coordinate range)", where, d, m);
    if (!(d >= RT_EXTENT_MIN))
        return rt_errf(e, "%s: scene extent %.9g is below %g: single precision cannot shade it (normals underflow; "
                          "docs/scenes.md: coordinate range); scale the scene up", where, d, RT_EXTENT_MIN);
    if (d > RT_EXTENT_MAX)
        return rt_errf(e, "%s: scene extent %.9g above %g: shading would overflow single precision "
                          "(docs/scenes.md: coordinate range)", where, d, RT_EXTENT_MAX);
    return 0;
}

float rt_scene_offset_scale(const rt_scene *s)
{
    rt_bounds b = s->bounds;
    if (!(b.lo.x <= b.hi.x)) return 1.0f;
    double dx = (double)b.hi.x - b.lo.x, dy = (double)b.hi.y - b.lo.y, dz = (double)b.hi.z - b.lo.z;
    double d = sqrt(dx * dx + dy * dy + dz * dz);
    d *= 16; /* RT_OFFSET_SCALE_FROM: 1 from a diagonal of 1/16 up */
    return d < 1 && d > 0 ? (float)d : 1.0f;
}

/* Places the camera so the bounding sphere fits a W x H image. */
static void frame(rt_scene *s, int W, int H)
{
    rt_bounds b = s->bounds;
    if (!(b.lo.x <= b.hi.x)) b.lo = b.hi = rt_v3(0, 0, 0);
    double cx = 0.5 * ((double)b.lo.x + b.hi.x), cy = 0.5 * ((double)b.lo.y + b.hi.y),
           cz = 0.5 * ((double)b.lo.z + b.hi.z);
    double dx = (double)b.hi.x - b.lo.x, dy = (double)b.hi.y - b.lo.y, dz = (double)b.hi.z - b.lo.z;
    double rad = 0.5 * sqrt(dx * dx + dy * dy + dz * dz);
    if (!(rad > 0)) rad = 1;
    /* Meshes from OBJ/PLY are conventionally y-up. View from the front
     * (+z), a little right and above; distance so the bounding sphere fits
     * the 45-degree field: rad / sin(22.5 deg), plus a margin. */
    const double sin22_5 = 0.38268343236508977;
    double dist = 1.1 * rad / sin22_5;
    if (W < H) {
        /* The horizontal half-angle h is narrower: tan h = tan 22.5 * W/H,
         * and the sphere fits when dist * sin h >= 1.1 rad. */
        const double tan22_5 = 0.41421356237309503;
        double t = tan22_5 * (double)W / (double)H;
        dist = 1.1 * rad * sqrt(1.0 + t * t) / t;
    }
    double vx = 0.4, vy = 0.35, vz = 1.0;
    double vl = sqrt(vx * vx + vy * vy + vz * vz);
    vx /= vl, vy /= vl, vz /= vl;
    s->cam.at = rt_v3((float)cx, (float)cy, (float)cz);
    s->cam.eye = rt_v3((float)(cx + dist * vx), (float)(cy + dist * vy), (float)(cz + dist * vz));
    s->cam.up = rt_v3(0, 1, 0);
    s->cam.fovy_deg = 45.0f;
    /* Light 0 at the camera (the paper's best case for recursive tracers);
     * lights 1 and 2 above, to the left and to the right. */
    s->light[0] = s->cam.eye;
    s->light[1] = rt_v3((float)(cx - 1.5 * rad), (float)(cy + 2.0 * rad), (float)(cz + 1.0 * rad));
    s->light[2] = rt_v3((float)(cx + 2.0 * rad), (float)(cy + 1.5 * rad), (float)(cz - 0.5 * rad));
    s->light_power = 0.45f;
    s->ambient = 0.1f;
    s->background = rt_v3(0.05f, 0.05f, 0.08f);
    ((scene_priv *)s)->framed = 1;
}

void rt_scene_autoframe(rt_scene *s) { frame(s, 1, 1); }

int rt_scene_set_camera(rt_scene *s, rt_vec3 eye, rt_vec3 at, rt_vec3 up, float fovy_deg, rt_err *e)
{
    rt_vec3 d = rt_sub(at, eye), c = rt_cross(d, up);
    if (!(rt_dot(d, d) > 0)) return rt_errf_usage(e, "--look-at: the eye and the point looked at coincide");
    if (!(rt_dot(c, c) > 0)) return rt_errf_usage(e, "--look-at: the up vector is zero or along the view direction");
    if (!(fovy_deg > 0 && fovy_deg < 180)) return rt_errf_usage(e, "--fov: %g is not in (0, 180) degrees", (double)fovy_deg);
    s->cam.eye = eye;
    s->cam.at = at;
    s->cam.up = up;
    s->cam.fovy_deg = fovy_deg;
    ((scene_priv *)s)->framed = 0;
    return 0;
}

void rt_scene_fit_aspect(rt_scene *s, int W, int H)
{
    if (((scene_priv *)s)->framed && W > 0 && W < H) frame(s, W, H);
}

/* Hashes values as little-endian 32-bit words, independent of the host. */
static uint64_t hash_u32(uint64_t h, uint32_t v)
{
    unsigned char b[4] = {(unsigned char)v, (unsigned char)(v >> 8), (unsigned char)(v >> 16),
                          (unsigned char)(v >> 24)};
    return rt_fnv1a(h, b, 4);
}

static uint64_t hash_f(uint64_t h, float f)
{
    uint32_t u;
    memcpy(&u, &f, 4);
    return hash_u32(h, u);
}

static uint64_t hash_v(uint64_t h, rt_vec3 v) { return hash_f(hash_f(hash_f(h, v.x), v.y), v.z); }

uint64_t rt_scene_hash(const rt_scene *s)
{
    uint64_t h = RT_FNV_INIT;
    h = hash_u32(h, s->ntri);
    for (uint32_t i = 0; i < s->ntri; i++)
        for (int k = 0; k < 3; k++) h = hash_v(h, s->tri[i].p[k]);
    for (uint32_t i = 0, n = rt_scene_nshade(s); i < n; i++) {
        for (int k = 0; k < 3; k++) h = hash_f(h, s->shade[i].rgb[k]);
        h = hash_u32(h, s->shade[i].mat);
    }
    /* kept instances: the records and the objects' triangles, not the
     * flattened copy (so the hash differs from the flattened scene's) */
    if (s->kept) {
        h = hash_u32(hash_u32(h, 0x6b657074u), s->nflat);
        for (uint32_t i = 0; i < s->notri; i++)
            for (int k = 0; k < 3; k++) h = hash_v(h, s->otri[i].p[k]);
        for (uint32_t k = 0; k < s->nirec; k++) {
            const rt_scene_inst *q = &s->irec[k];
            h = hash_u32(hash_u32(hash_u32(hash_u32(h, q->first), s->obj[q->obj].start), s->obj[q->obj].count), q->loose);
            for (int a = 0; a < 3; a++)
                for (int b = 0; b < 4; b++) h = rt_fnv1a(h, &q->m[a][b], sizeof q->m[a][b]);
        }
    }
    /* The table enters the hash only when a scene has materials beyond the
     * plain one, so scenes made before materials keep their hashes. */
    for (uint32_t m = 1; m < s->nmat; m++) {
        const rt_material *t = &s->mat[m];
        for (int k = 0; k < 3; k++) h = hash_f(hash_f(hash_f(h, t->ks[k]), t->kt[k]), t->ke[k]);
        h = hash_f(h, t->ior);
    }
    h = hash_v(h, s->cam.eye);
    h = hash_v(h, s->cam.at);
    h = hash_v(h, s->cam.up);
    h = hash_f(h, s->cam.fovy_deg);
    if (s->cam.mirror) h = hash_u32(h, 1); /* only pbrt scenes set it: other hashes unchanged */
    for (int i = 0; i < RT_NLIGHTS; i++) h = hash_v(h, s->light[i]);
    h = hash_f(h, s->light_power);
    for (int i = 0; i < RT_NLIGHTS; i++) /* only a light with its own power: other hashes unchanged */
        if (s->light_scale[i] != 1.0f) h = hash_f(hash_u32(h, (uint32_t)i), s->light_scale[i]);
    h = hash_f(h, s->ambient);
    h = hash_v(h, s->background);
    /* authored lights only when one is not a point light (a file whose
     * lights are all points is lit by light[] above): other hashes unchanged */
    if (rt_scene_nonpoint_lights(s))
        for (uint32_t i = 0; i < s->nlight; i++) {
            const rt_light *l = &s->lights[i];
            h = hash_u32(h, (uint32_t)l->kind);
            h = hash_f(hash_v(hash_v(h, l->p), l->d), l->r);
            h = hash_u32(hash_u32(hash_f(h, l->scale), l->first), l->count);
        }
    if (s->alpha) { /* only a scene with alpha textures: other hashes unchanged */
        const rt_scene_alpha *A = s->alpha;
        h = hash_u32(hash_u32(h, 0x616c7068u), A->nmap);
        for (uint32_t k = 0; k < A->nmap; k++) h = hash_u32(hash_u32(h, A->map[k].w), A->map[k].h);
        for (uint64_t i = 0; i < A->ntexel; i++) h = hash_f(h, A->texel[i]);
        h = hash_u32(h, A->ntri);
        for (uint32_t t = 0; t < A->nrec; t++) {
            h = hash_u32(h, A->tmap[t]);
            if (A->tmap[t])
                for (int j = 0; j < 6; j++) h = hash_f(h, A->uv[6 * (size_t)t + j]);
        }
    }
    return h;
}

/* One MTL material per distinct (material, colour) pair, since MTL keeps
 * the diffuse colour in the material while the scene keeps it per triangle. */
typedef struct mtlkey {
    uint32_t mat;    /* index into s->mat */
    float rgb[3];    /* Kd */
} mtlkey;

typedef struct mtlset {
    mtlkey *key;     /* distinct pairs in order of first use */
    uint32_t n, cap; /* used, allocated */
    uint32_t *slot;  /* open-addressing hash: 1 + index into key, 0 = empty */
    uint32_t nslot;  /* power of two, > 2 n */
} mtlset;

static uint32_t mtlkey_hash(const mtlkey *k)
{
    uint64_t h = hash_u32(RT_FNV_INIT, k->mat);
    for (int i = 0; i < 3; i++) h = hash_f(h, k->rgb[i]);
    return (uint32_t)(h ^ (h >> 32));
}

/* Index of the pair (mat, rgb), added when new; -1 when out of memory. */
static long mtlset_find(mtlset *t, uint32_t mat, const float rgb[3], rt_err *e)
{
    mtlkey k = {mat, {rgb[0], rgb[1], rgb[2]}};
    if (2 * (t->n + 1) >= t->nslot) {
        uint32_t ns = t->nslot ? 2 * t->nslot : 64;
        uint32_t *sl = rt_calloc(ns, sizeof *sl, e);
        if (!sl) return -1;
        for (uint32_t i = 0; i < t->n; i++) {
            uint32_t h = mtlkey_hash(&t->key[i]) & (ns - 1);
            while (sl[h]) h = (h + 1) & (ns - 1);
            sl[h] = i + 1;
        }
        free(t->slot);
        t->slot = sl;
        t->nslot = ns;
    }
    uint32_t h = mtlkey_hash(&k) & (t->nslot - 1);
    while (t->slot[h]) {
        const mtlkey *o = &t->key[t->slot[h] - 1];
        if (o->mat == mat && !memcmp(o->rgb, k.rgb, sizeof k.rgb)) return (long)t->slot[h] - 1;
        h = (h + 1) & (t->nslot - 1);
    }
    if (t->n == t->cap) {
        uint32_t nc = t->cap ? 2 * t->cap : 16;
        mtlkey *nk = rt_reallocarray(t->key, nc, sizeof *nk, e);
        if (!nk) return -1;
        t->key = nk;
        t->cap = nc;
    }
    t->key[t->n] = k;
    t->slot[h] = t->n + 1;
    return (long)t->n++;
}

/* The MTL name of pair i: the material's name (characters outside
 * [A-Za-z0-9_.-] replaced by '_', "plain" for entry 0) and the pair index. */
static void mtl_name(const rt_scene *s, const mtlkey *k, uint32_t i, char *buf, size_t n)
{
    char nm[sizeof s->mat[0].name];
    snprintf(nm, sizeof nm, "%s", k->mat && s->mat[k->mat].name[0] ? s->mat[k->mat].name : "plain");
    for (char *p = nm; *p; p++) {
        char c = *p;
        if (!((c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' || c == '.' ||
              c == '-'))
            *p = '_';
    }
    snprintf(buf, n, "%s_%u", nm, (unsigned)i);
}

/* Writes the MTL for the pairs: terms chosen so that the OBJ loader's
 * illum mapping (docs/scenes.md) gives back the same ks, kt, ior and ke. */
static void write_mtl(FILE *f, const rt_scene *s, const mtlset *t)
{
    fprintf(f, "# raytraffic %s material export\n# scene %s%s%s\n", rt_version(), s->name, s->params[0] ? ":" : "",
            s->params);
    for (uint32_t i = 0; i < t->n; i++) {
        const mtlkey *k = &t->key[i];
        const rt_material *m = &s->mat[k->mat];
        char nm[64];
        mtl_name(s, k, i, nm, sizeof nm);
        fprintf(f, "\nnewmtl %s\nKd %.9g %.9g %.9g\n", nm, (double)k->rgb[0], (double)k->rgb[1], (double)k->rgb[2]);
        int illum = (m->flags & RT_MAT_TRANSMIT) ? 7 : (m->flags & RT_MAT_SPECULAR) ? 3 : 2;
        fprintf(f, "illum %d\n", illum);
        if (illum != 2)
            fprintf(f, "Ks %.9g %.9g %.9g\n", (double)m->ks[0], (double)m->ks[1], (double)m->ks[2]);
        if (illum == 7)
            fprintf(f, "Tr 1\nTf %.9g %.9g %.9g\nNi %.9g\n", (double)m->kt[0], (double)m->kt[1], (double)m->kt[2],
                    (double)m->ior);
        if (m->flags & RT_MAT_EMIT)
            fprintf(f, "Ke %.9g %.9g %.9g\n", (double)m->ke[0], (double)m->ke[1], (double)m->ke[2]);
    }
}

int rt_scene_export_obj(const rt_scene *s, const char *path, rt_err *e)
{
    rt_out *o = rt_out_open(path, e);
    if (!o) return -1;
    FILE *f = rt_out_stream(o);
    /* With materials, the pairs are numbered before anything is written. */
    mtlset mt = {NULL, 0, 0, NULL, 0};
    uint32_t *pair = NULL;
    rt_out *om = NULL;
    char *mpath = NULL;
    if (s->nmat > 1) {
        size_t n = strlen(path);
        mpath = rt_calloc(n + 8, 1, e);
        pair = rt_calloc(s->ntri ? s->ntri : 1, sizeof *pair, e);
        int ok = mpath && pair;
        for (uint32_t i = 0; ok && i < s->ntri; i++) {
            long k = mtlset_find(&mt, s->shade[i].mat, s->shade[i].rgb, e);
            if (k < 0) ok = 0;
            else pair[i] = (uint32_t)k;
        }
        if (ok) {
            memcpy(mpath, path, n + 1);
            if (n >= 4 && mpath[n - 4] == '.' && (mpath[n - 3] | 32) == 'o' && (mpath[n - 2] | 32) == 'b' &&
                (mpath[n - 1] | 32) == 'j')
                n -= 4;
            memcpy(mpath + n, ".mtl", 5);
            om = rt_out_open(mpath, e);
        }
        if (!om) {
            rt_out_abort(o);
            free(mt.key);
            free(mt.slot);
            free(pair);
            free(mpath);
            return -1;
        }
        write_mtl(rt_out_stream(om), s, &mt);
    }
    fprintf(f, "# raytraffic %s scene export\n# scene %s%s%s\n# triangles %u\n", rt_version(), s->name,
            s->params[0] ? ":" : "", s->params, s->ntri);
    fprintf(f, "# camera eye %.9g %.9g %.9g at %.9g %.9g %.9g up %.9g %.9g %.9g fovy %.9g\n",
            (double)s->cam.eye.x, (double)s->cam.eye.y, (double)s->cam.eye.z, (double)s->cam.at.x,
            (double)s->cam.at.y, (double)s->cam.at.z, (double)s->cam.up.x, (double)s->cam.up.y,
            (double)s->cam.up.z, (double)s->cam.fovy_deg);
    for (int i = 0; i < RT_NLIGHTS; i++)
        fprintf(f, "# light %d %.9g %.9g %.9g\n", i, (double)s->light[i].x, (double)s->light[i].y,
                (double)s->light[i].z);
    if (om) {
        const char *base = strrchr(mpath, '/');
        fprintf(f, "mtllib %s\n", base ? base + 1 : mpath);
    }
    /* Vertices: three per triangle, %.9g round-trips a float exactly. */
    for (uint32_t i = 0; i < s->ntri; i++)
        for (int k = 0; k < 3; k++)
            fprintf(f, "v %.9g %.9g %.9g\n", (double)s->tri[i].p[k].x, (double)s->tri[i].p[k].y,
                    (double)s->tri[i].p[k].z);
    /* Faces, one group per run of equal colour (and material), named by a
     * comment (and a usemtl). */
    for (uint32_t i = 0; i < s->ntri; i++) {
        const float *c = s->shade[i].rgb;
        int newrun = i == 0 || memcmp(c, s->shade[i - 1].rgb, sizeof s->shade[i].rgb) != 0;
        if (newrun) fprintf(f, "# rgb %.9g %.9g %.9g\n", (double)c[0], (double)c[1], (double)c[2]);
        if (om && (newrun || pair[i] != pair[i - 1])) {
            char nm[64];
            mtl_name(s, &mt.key[pair[i]], pair[i], nm, sizeof nm);
            fprintf(f, "usemtl %s\n", nm);
        }
        unsigned long v = 3ul * i + 1;
        fprintf(f, "f %lu %lu %lu\n", v, v + 1, v + 2);
    }
    free(mt.key);
    free(mt.slot);
    free(pair);
    /* The MTL first; if the OBJ then fails, the MTL goes too, so a failed
     * export leaves neither. Both renames happen under an exclusive lock on
     * the target's folder, so concurrent exports to one name leave the OBJ
     * and the MTL of the same writer (the last one to take the lock). */
    int lockfd = -1;
    if (om) {
        size_t pl = strlen(path);
        char *dir = rt_calloc(pl + 2, 1, e);
        if (dir) {
            rt_path_dir(path, dir, pl + 2);
            lockfd = open(dir[0] ? dir : ".", O_RDONLY | O_DIRECTORY | O_CLOEXEC);
            free(dir);
        }
        if (lockfd >= 0)
            while (flock(lockfd, LOCK_EX) < 0 && errno == EINTR) {
            }
    }
    if (om && rt_out_commit(om, e) < 0) {
        rt_out_abort(o);
        free(mpath);
        if (lockfd >= 0) close(lockfd);
        return -1;
    }
    int rc = rt_out_commit(o, e); /* complete, or no file and an error */
    if (rc < 0 && mpath) remove(mpath);
    if (lockfd >= 0) close(lockfd); /* releases the lock */
    free(mpath);
    return rc;
}
