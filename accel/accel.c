/*
 * accel.c -- the acceleration-structure table, the naive member (every
 * triangle against every ray) and the brute-force reference (see accel.h).
 */
#include "accel.h"
#include "kdtree.h"

#include <stdio.h>
#include <string.h>

extern const rt_accel_ops rt_accel_kd;
extern const rt_accel_ops rt_accel_grid;
extern const rt_accel_ops rt_accel_bvh2, rt_accel_bvh4, rt_accel_bvh8;
extern const rt_accel_ops rt_accel_inst;
static const rt_accel_ops rt_accel_naive;

const rt_accel_ops *const rt_accel_table[RT_ACCEL_NKINDS] = {
    [RT_ACCEL_KD] = &rt_accel_kd,
    [RT_ACCEL_GRID] = &rt_accel_grid,
    [RT_ACCEL_NAIVE] = &rt_accel_naive,
    [RT_ACCEL_BVH2] = &rt_accel_bvh2,
    [RT_ACCEL_BVH4] = &rt_accel_bvh4,
    [RT_ACCEL_BVH8] = &rt_accel_bvh8,
    [RT_ACCEL_INST] = &rt_accel_inst,
};

int rt_accel_bvh_width(int kind)
{
    static const int width[RT_ACCEL_NKINDS] = {[RT_ACCEL_BVH2] = 2, [RT_ACCEL_BVH4] = 4, [RT_ACCEL_BVH8] = 8};
    return kind > 0 && kind < RT_ACCEL_NKINDS ? width[kind] : 0;
}

const char *rt_accel_name(int kind)
{
    return kind > 0 && kind < RT_ACCEL_NKINDS && rt_accel_table[kind] ? rt_accel_table[kind]->name : NULL;
}

int rt_accel_from_name(const char *name)
{
    for (int k = 1; k < RT_ACCEL_NKINDS; k++) /* inst is chosen by --instances, not by name */
        if (k != RT_ACCEL_INST && rt_accel_table[k] && !strcmp(rt_accel_table[k]->name, name)) return k;
    return -1;
}

const char *rt_accel_names(void)
{
    static char buf[128];
    if (!buf[0]) {
        size_t l = 0;
        for (int k = 1; k < RT_ACCEL_NKINDS && l < sizeof buf; k++)
            if (rt_accel_table[k] && k != RT_ACCEL_INST)
                l += (size_t)snprintf(buf + l, sizeof buf - l, "%s%s", l ? ", " : "", rt_accel_table[k]->name);
    }
    return buf;
}

int rt_accel_build(rt_accel *a, int kind, const rt_scene *sc, const rt_accel_params *p, rt_err *e)
{
    memset(a, 0, sizeof *a);
    if (!rt_accel_name(kind)) return rt_errf(e, "unknown acceleration structure %d", kind);
    const rt_accel_ops *ops = rt_accel_table[kind];
    rt_accel_params def = {0};
    double t0 = rt_now();
    void *as = NULL;
    if (ops->build && !(as = ops->build(sc, p ? p : &def, e))) return -1;
    a->kind = kind;
    a->ops = ops;
    a->as = as;
    a->build_sec = rt_now() - t0;
    return 0;
}

void rt_accel_wrap(rt_accel *a, int kind, void *as, double build_sec)
{
    memset(a, 0, sizeof *a);
    a->kind = kind;
    a->ops = rt_accel_name(kind) ? rt_accel_table[kind] : NULL;
    a->as = as;
    a->build_sec = build_sec;
}

void rt_accel_free(rt_accel *a)
{
    if (!a) return;
    if (a->ops && a->ops->free) a->ops->free(a->as);
    memset(a, 0, sizeof *a);
}

int rt_accel_regions(const rt_accel *a, const rt_scene *sc, rt_layout *L, rt_err *e)
{
    return a->ops->regions ? a->ops->regions(a->as, sc, L, e) : 0;
}

void rt_accel_trav(const rt_accel *a, rt_trav *tv, const rt_scene *sc, rt_rec *rec, const rt_layout *L)
{
    memset(tv, 0, sizeof *tv);
    tv->sc = sc;
    tv->rec = rec;
    tv->L = L;
    tv->reg_node = tv->reg_idx = tv->reg_tri = tv->reg_top = tv->reg_inst = -1;
    a->ops->trav_init(tv, a->as, L);
    rt_alpha_at_init(&tv->alpha, L);
}

int rt_accel_check(const rt_accel *a, const rt_scene *sc, rt_err *e)
{
    return a->ops->check ? a->ops->check(a->as, sc, e) : 0;
}

void rt_accel_info_of(const rt_accel *a, rt_accel_info *inf)
{
    memset(inf, 0, sizeof *inf);
    if (a->ops && a->ops->info) a->ops->info(a->as, inf);
}

/* ---- naive: every triangle, in index order ------------------------------- */

static void naive_trav_init(rt_trav *tv, const void *as, const rt_layout *L)
{
    (void)as;
    (void)L;
    (void)tv;
}

/* Counts, marks and (with a recorder and a triangle region) records every
 * triangle as tested, in index order: one triangle-record read each. The
 * naive structure has no regions of its own. */
static void naive_count(rt_trav *tv)
{
    tv->tests += tv->sc->ntri;
    if (tv->mark)
        for (uint32_t i = 0; i < tv->sc->ntri; i++) tv->mark[i] |= tv->mark_bit;
    if (tv->rec && tv->reg_tri >= 0) {
        const rt_region *g = &tv->L->r[tv->reg_tri];
        for (uint32_t i = 0; i < tv->sc->ntri; i++)
            RT_REC(tv->rec, rt_mm_addr(tv->L, tv->reg_tri, i), g->recsize, 0, RT_CLS_TRI);
    }
}

static int brute_closest_at(const rt_scene *sc, const rt_ray *rp, rt_hit *h, const rt_alpha_at *at, rt_rec *rec);
static int brute_occluded_at(const rt_scene *sc, const rt_ray *rp, const rt_alpha_at *at, rt_rec *rec);

static int naive_closest(rt_trav *tv, const rt_ray *r, rt_hit *h)
{
    naive_count(tv);
    return brute_closest_at(tv->sc, r, h, &tv->alpha, tv->rec);
}

static int naive_occluded(rt_trav *tv, const rt_ray *r)
{
    naive_count(tv);
    return brute_occluded_at(tv->sc, r, &tv->alpha, tv->rec);
}

static const rt_accel_ops rt_accel_naive = {
    .name = "naive",
    .desc = "no structure: every triangle against every ray",
    .trav_init = naive_trav_init,
    .closest = naive_closest,
    .occluded = naive_occluded,
};

/* ---- the brute-force reference ------------------------------------------- */

int rt_brute_closest(const rt_scene *sc, const rt_ray *rp, rt_hit *h) { return brute_closest_at(sc, rp, h, NULL, NULL); }
int rt_brute_occluded(const rt_scene *sc, const rt_ray *rp) { return brute_occluded_at(sc, rp, NULL, NULL); }

static int brute_closest_at(const rt_scene *sc, const rt_ray *rp, rt_hit *h, const rt_alpha_at *at, rt_rec *rec)
{
    const rt_ray ray = *rp, *r = &ray;
    const rt_tri *tris = sc->tri;
    const uint32_t n = sc->ntri;
    rt_hit best;
    rt_hit_none(&best);
    best.t = r->tmax;
    for (uint32_t i = 0; i < n; i++) {
        float t, u, v;
        if (!rt_isect_core(r, &tris[i], &t, &u, &v)) continue;
        /* Ascending i: an equal t never beats the earlier, lower index. */
        if (t > r->tmin && t < best.t && !rt_alpha_cut(sc->alpha, at, rec, r, i, u, v)) {
            best.t = t;
            best.tri = i;
            best.u = u;
            best.v = v;
        }
    }
    if (best.tri == RT_NO_HIT) {
        rt_hit_none(h);
        return 0;
    }
    *h = best;
    return 1;
}

static int brute_occluded_at(const rt_scene *sc, const rt_ray *rp, const rt_alpha_at *at, rt_rec *rec)
{
    const rt_ray ray = *rp, *r = &ray;
    const rt_tri *tris = sc->tri;
    const uint32_t n = sc->ntri;
    for (uint32_t i = 0; i < n; i++) {
        float t, u, v;
        if (rt_isect_core(r, &tris[i], &t, &u, &v) && t > r->tmin && t < r->tmax &&
            !rt_alpha_cut(sc->alpha, at, rec, r, i, u, v))
            return 1;
    }
    return 0;
}

int rt_accel_parse_mask(const char *list, unsigned *mask, rt_err *e)
{
    unsigned m = 0;
    if (!strcmp(list, "none")) {
        *mask = 0;
        return 0;
    }
    if (!strcmp(list, "all")) {
        for (int k = 1; k < RT_ACCEL_NKINDS; k++)
            if (rt_accel_table[k] && k != RT_ACCEL_INST) m |= RT_ACCEL_BIT(k);
        *mask = m;
        return 0;
    }
    for (const char *p = list;;) {
        size_t n = strcspn(p, ",");
        char name[32];
        int k = -1;
        if (n && n < sizeof name) {
            memcpy(name, p, n);
            name[n] = 0;
            k = rt_accel_from_name(name);
        }
        if (k <= 0) return rt_errf(e, "unknown structure '%.*s' (%s, or all or none)", (int)(n < 64 ? n : 64), p, rt_accel_names());
        m |= RT_ACCEL_BIT(k);
        if (!p[n]) break;
        p += n + 1;
    }
    *mask = m;
    return 0;
}

int rt_accel_survey(const rt_scene *sc, unsigned mask, const rt_accel_params *p, rt_accel_survey_row *rows, rt_err *e)
{
    int n = 0;
    for (int k = 1; k < RT_ACCEL_NKINDS; k++) {
        if (!(mask & RT_ACCEL_BIT(k)) || !rt_accel_table[k]) continue;
        rt_accel a;
        rt_err be = {0};
        if (rt_accel_build(&a, k, sc, p, &be) < 0) return rt_errf(e, "%s: %s", rt_accel_name(k), be.msg);
        rt_accel_survey_row *r = &rows[n++];
        memset(r, 0, sizeof *r);
        r->kind = k;
        r->build_sec = a.build_sec;
        rt_accel_info_of(&a, &r->info);
        if (k == RT_ACCEL_KD) {
            const rt_kdtree *kd = a.as;
            r->has_kd = 1;
            r->kd_leaves = kd->nleaves;
            r->kd_empty = kd->nempty;
            r->kd_entries = kd->nidx;
            r->kd_max_leaf = kd->maxleaf;
            r->kd_mean_leaf = rt_kd_mean_leaf_tris(kd);
        }
        rt_accel_free(&a);
    }
    return n;
}
