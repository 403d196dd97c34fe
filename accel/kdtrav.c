/*
 * kdtrav.c -- single-ray k-d tree traversal (closest hit and any hit) with
 * memory-access recording, and the brute-force reference.
 *
 * The traversal is pbrt's KdTreeAccel::Intersect: clip the ray to the tree
 * bounds (near and far faces by the direction's sign), then walk front to
 * back; at an interior node the near child (the side holding the origin,
 * or the side the direction points to when the origin lies on the plane)
 * is visited first and the far one pushed with its parametric interval
 * when the plane crossing falls inside the current interval -- or within
 * RT_KD_TOUCH of it, so a cell the ray touches only at an edge or corner is
 * visited too, and a NaN plane distance (the ray lies in the split plane)
 * visits both over the whole interval (rt_kd_step, kdtrav.h, the rule every
 * walk shares). Leaves test every listed triangle against the ray's own
 * interval (never the leaf's), so rounding in the plane distances cannot
 * lose a hit; closest-hit traversal stops as soon as the best hit lies
 * before the next entry's distance (by a margin of 2^-16 relative,
 * rt_kd_past, so that hits in a split plane and exact ties are resolved as
 * brute force does), or skips that entry and pops on once an in-plane
 * entry has been pushed (one that may begin before those above it).
 *
 * What is recorded (when tv->rec != NULL), in program order: one 8-byte read
 * of kd.nodes per node visited; at a leaf with n > 0 triangles one read of
 * 4n bytes of kd.index at its first entry; one 36-byte read of tri.verts per
 * triangle tested. No mailboxing. tv->nodes and tv->tests count the same
 * events whether or not recording is on.
 *
 * Two walks produce that one behaviour. traverse_plain is the walk as
 * written above, on the modeled nodes, one scalar test per entry; it is
 * the reference (rt_kd_plain_sub) and serves trees without a host copy.
 * traverse_fast runs the same node decisions on the host copy (kdtree.h)
 * and tests a leaf's quads four triangles at a time (quad_isect); lanes
 * whose edge function is exactly 0 go through the scalar core for its
 * double-precision branch, and an any-hit walk counts, marks and records
 * entries only up to the one that stops it, so every observable -- hit
 * bits, counts, marks, recorded stream -- equals the plain walk's
 * (tests/test_kdtree.c compares them on random and adversarial rays).
 * The fast walk is specialised by inlining for closest/any and for
 * recording or not; without recording its node loop keeps its state in
 * registers and calls the leaf tests out of line.
 */
#include "config.h"
#include "kdtrav.h"
#include "accel.h"

#include <float.h>
#include <math.h>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif

/* pbrt's gamma(3): relative bound on three roundings. */
#define GAMMA3 ((3.0f * FLT_EPSILON * 0.5f) / (1.0f - 3.0f * FLT_EPSILON * 0.5f))

int rt_kd_clip(const rt_kdtree *kd, const rt_ray *r, float *t0, float *t1)
{
    const rt_bounds *b = &kd->bounds;
    if (kd->nidx == 0 || !(b->lo.x <= b->hi.x && b->lo.y <= b->hi.y && b->lo.z <= b->hi.z)) return 0;
    const float *lo = (const float *)(const void *)&b->lo;
    const float *hi = (const float *)(const void *)&b->hi;
    const float *o = (const float *)(const void *)&r->o;
    const float *inv = (const float *)(const void *)&r->inv_d;
    float a = r->tmin, c = r->tmax;
    for (int k = 0; k < 3; k++) {
        /* near and far faces by the direction's sign, not by comparing
         * the distances: one of them is NaN when the origin lies on a face
         * and the direction is +-0 on this axis, and a comparison would
         * then keep the other (+-inf) on the wrong side. */
        const int neg = signbit(inv[k]) != 0;
        float tn = ((neg ? hi[k] : lo[k]) - o[k]) * inv[k];
        float tf = ((neg ? lo[k] : hi[k]) - o[k]) * inv[k];
        tf *= 1.0f + 2.0f * GAMMA3;
        /* NaN (origin on a slab face, direction 0 on that axis) constrains
         * nothing: the comparisons below are false. */
        if (tn > a) a = tn;
        if (tf < c) c = tf;
        if (a > c) return 0;
    }
    *t0 = a;
    *t1 = c;
    return 1;
}

typedef struct todo {
    uint32_t node; /* node to visit */
    float tmin;    /* its parametric interval */
    float tmax;
} todo;

/* The next stack entry to visit, into *e (1), or 0 when the walk is over:
 * an entry past the best hit ends it, or is skipped when an entry beneath
 * may begin earlier (an RT_KD_INPLANE push made the stack unordered). */
static RT_ALWAYS_INLINE int pop_next(const todo *stack, int *sp, float best, int any, int ordered, todo *e)
{
    while (*sp > 0) {
        *e = stack[--*sp];
        if (any || !rt_kd_past(best, e->tmin)) return 1;
        if (ordered) return 0;
    }
    return 0;
}

/*
 * The traversal, shared by all four entry points. `any` is a constant at
 * every call site, so the compiler emits a closest-hit and an any-hit
 * loop. For closest hit, *h is in/out: a hit already in it is only replaced
 * by a closer one (equal t: lower triangle index). Returns 1 when *h holds
 * a hit (closest) or the ray is occluded (any).
 */
static RT_ALWAYS_INLINE int traverse_plain(rt_trav *tv, const rt_ray *rp, uint32_t node, float tMin, float tMax,
                                           rt_hit *h, const int any)
{
    /* A local copy: stores through mark[] (a char pointer) and into the
     * recorder could alias *rp and force reloads in the inner loop. */
    const rt_ray ray = *rp, *r = &ray;
    const rt_kdnode *nodes = tv->kd->nodes;
    const uint32_t *idx = tv->kd->idx;
    const rt_tri *tris = tv->sc->tri;
    rt_rec *rec = tv->rec;
    const rt_layout *L = tv->L;
    uint8_t *mark = tv->mark;
    const uint8_t mbit = tv->mark_bit;
    const float *o = (const float *)(const void *)&r->o;
    const float *d = (const float *)(const void *)&r->d;
    const float *inv = (const float *)(const void *)&r->inv_d;
    const float rtmin = r->tmin, rtmax = r->tmax;

    int found = 0;
    float best = rtmax, bu = 0.0f, bv = 0.0f;
    uint32_t besttri = 0; /* 0 while no hit: an equal t never wins */
    if (!any && h->tri != RT_NO_HIT) {
        found = 1;
        best = h->t;
        besttri = h->tri;
        bu = h->u;
        bv = h->v;
    }
    todo stack[RT_KD_STACK];
    int sp = 0;
    uint64_t nvisit = 0, ntest = 0;
    int occluded = 0;
    float tMinW = rt_kd_wlo(tMin), tMaxW = rt_kd_whi(tMax); /* the interval widened (rt_kd_step_w) */
    int ordered = 1; /* no RT_KD_INPLANE entry pushed: entries begin later the deeper they lie */

    if (!any && rt_kd_past(best, tMin)) goto done;
    for (;;) {
        const rt_kdnode *nd = &nodes[node];
        nvisit++;
        RT_REC(rec, rt_mm_addr(L, tv->reg_node, node), 8, 0, RT_CLS_NODE);
        const uint32_t w1 = nd->w1;
        if ((w1 & 3u) != 3u) {
            const int axis = (int)(w1 & 3u);
            const float split = rt_kd_split(nd);
            const float tPlane = (split - o[axis]) * inv[axis];
            const int belowFirst = o[axis] < split || (o[axis] == split && d[axis] <= 0.0f);
            const uint32_t above = w1 >> 2;
            const uint32_t first = belowFirst ? node + 1 : above;
            const uint32_t second = belowFirst ? above : node + 1;
            float near_end, far_start;
            const int step = rt_kd_step_w(tPlane, tMin, tMax, tMinW, tMaxW, &near_end, &far_start);
            if (step == RT_KD_NEAR) {
                node = first;
            } else if (step == RT_KD_FAR) {
                node = second;
            } else {
                stack[sp].node = second;
                stack[sp].tmin = far_start;
                stack[sp].tmax = tMax;
                sp++;
                node = first;
                tMax = near_end;
                tMaxW = rt_kd_whi(tMax);
                if (step & RT_KD_INPLANE) ordered = 0;
            }
            continue;
        }
        const uint32_t n = w1 >> 2;
        if (n > 0) {
            const uint32_t firstidx = nd->w0;
            RT_REC(rec, rt_mm_addr(L, tv->reg_idx, firstidx), 4u * n, 0, RT_CLS_INDEX);
            const uint32_t *list = idx + firstidx;
            for (uint32_t k = 0; k < n; k++) {
                const uint32_t tri = list[k];
                ntest++;
                if (mark) mark[tri] |= mbit;
                RT_REC(rec, rt_mm_addr(L, tv->reg_tri, tri), 36, 0, RT_CLS_TRI);
                float t, u, v;
                if (!rt_isect_core(r, &tris[tri], &t, &u, &v)) continue;
                if (any) {
                    if (t > rtmin && t < rtmax && !rt_alpha_cut(tv->sc->alpha, &tv->alpha, tv->rec, r, tri, u, v)) {
                        occluded = 1;
                        goto done;
                    }
                } else if (t > rtmin && (t < best || (t == best && tri < besttri)) &&
                           !rt_alpha_cut(tv->sc->alpha, &tv->alpha, tv->rec, r, tri, u, v)) {
                    found = 1;
                    best = t;
                    besttri = tri;
                    bu = u;
                    bv = v;
                }
            }
        }
        todo e;
        if (!pop_next(stack, &sp, best, any, ordered, &e)) goto done;
        node = e.node;
        tMin = e.tmin;
        tMax = e.tmax;
        tMinW = rt_kd_wlo(tMin);
        tMaxW = rt_kd_whi(tMax);
    }
done:
    tv->nodes += nvisit;
    tv->tests += ntest;
    if (any) return occluded;
    if (found) {
        h->t = best;
        h->tri = besttri;
        h->u = bu;
        h->v = bv;
    }
    return found;
}

#if defined(__SSE2__)
/*
 * Four ray/triangle tests of one quad (kdtree.h), lane by lane the
 * arithmetic of rt_isect_core: the same IEEE single-precision operations
 * in the same order (SSE2 has no FMA and divps is exact), so each lane's
 * t, u, v are bit-identical to the scalar test. Returns in *hit the lanes
 * that passed the float test (finite t, triangle not degenerate) and in
 * *fb the live lanes with an edge function exactly 0, which the caller
 * sends through the scalar core (its double-precision branch).
 */
typedef struct quad_ray {
    __m128 ox, oy, oz; /* origin in the permuted axes kx, ky, kz */
    __m128 Sx, Sy, Sz; /* shear */
    int kx, ky, kz;
} quad_ray;

static RT_ALWAYS_INLINE void quad_isect(const quad_ray *qr, const rt_kd_quad *q, __m128 *t_out, __m128 *u_out,
                                        __m128 *v_out, unsigned *hit, unsigned *fb)
{
    const __m128 zero = _mm_setzero_ps();
    const __m128 Ax0 = _mm_sub_ps(_mm_loadu_ps(q->p[qr->kx]), qr->ox);
    const __m128 Ay0 = _mm_sub_ps(_mm_loadu_ps(q->p[qr->ky]), qr->oy);
    const __m128 Az0 = _mm_sub_ps(_mm_loadu_ps(q->p[qr->kz]), qr->oz);
    const __m128 Bx0 = _mm_sub_ps(_mm_loadu_ps(q->p[3 + qr->kx]), qr->ox);
    const __m128 By0 = _mm_sub_ps(_mm_loadu_ps(q->p[3 + qr->ky]), qr->oy);
    const __m128 Bz0 = _mm_sub_ps(_mm_loadu_ps(q->p[3 + qr->kz]), qr->oz);
    const __m128 Cx0 = _mm_sub_ps(_mm_loadu_ps(q->p[6 + qr->kx]), qr->ox);
    const __m128 Cy0 = _mm_sub_ps(_mm_loadu_ps(q->p[6 + qr->ky]), qr->oy);
    const __m128 Cz0 = _mm_sub_ps(_mm_loadu_ps(q->p[6 + qr->kz]), qr->oz);
    const __m128 Ax = _mm_sub_ps(Ax0, _mm_mul_ps(qr->Sx, Az0)), Ay = _mm_sub_ps(Ay0, _mm_mul_ps(qr->Sy, Az0));
    const __m128 Bx = _mm_sub_ps(Bx0, _mm_mul_ps(qr->Sx, Bz0)), By = _mm_sub_ps(By0, _mm_mul_ps(qr->Sy, Bz0));
    const __m128 Cx = _mm_sub_ps(Cx0, _mm_mul_ps(qr->Sx, Cz0)), Cy = _mm_sub_ps(Cy0, _mm_mul_ps(qr->Sy, Cz0));
    const __m128 U = _mm_sub_ps(_mm_mul_ps(Cx, By), _mm_mul_ps(Cy, Bx));
    const __m128 V = _mm_sub_ps(_mm_mul_ps(Ax, Cy), _mm_mul_ps(Ay, Cx));
    const __m128 W = _mm_sub_ps(_mm_mul_ps(Bx, Ay), _mm_mul_ps(By, Ax));
    /* live: not degenerate and not padding (both have the top bit set) */
    const unsigned live = ~(unsigned)_mm_movemask_ps(_mm_castsi128_ps(_mm_loadu_si128((const __m128i *)(const void *)q->tri))) & 15u;
    const __m128 z = _mm_or_ps(_mm_or_ps(_mm_cmpeq_ps(U, zero), _mm_cmpeq_ps(V, zero)), _mm_cmpeq_ps(W, zero));
    const __m128 neg = _mm_or_ps(_mm_or_ps(_mm_cmplt_ps(U, zero), _mm_cmplt_ps(V, zero)), _mm_cmplt_ps(W, zero));
    const __m128 pos = _mm_or_ps(_mm_or_ps(_mm_cmpgt_ps(U, zero), _mm_cmpgt_ps(V, zero)), _mm_cmpgt_ps(W, zero));
    const __m128 det = _mm_add_ps(_mm_add_ps(U, V), W);
    const __m128 T = _mm_add_ps(_mm_add_ps(_mm_mul_ps(U, _mm_mul_ps(qr->Sz, Az0)), _mm_mul_ps(V, _mm_mul_ps(qr->Sz, Bz0))),
                                _mm_mul_ps(W, _mm_mul_ps(qr->Sz, Cz0)));
    const __m128 inv = _mm_div_ps(_mm_set1_ps(1.0f), det);
    const __m128 t = _mm_mul_ps(T, inv);
    const __m128 inf = _mm_set1_ps(INFINITY);
    /* the scalar test's accept: no zero edge, signs agree, det != 0
     * (NaN passes, as in the scalar code), t finite */
    __m128 ok = _mm_andnot_ps(_mm_or_ps(z, _mm_and_ps(neg, pos)), _mm_cmpneq_ps(det, zero));
    ok = _mm_and_ps(ok, _mm_and_ps(_mm_cmpgt_ps(t, _mm_sub_ps(zero, inf)), _mm_cmplt_ps(t, inf)));
    *hit = (unsigned)_mm_movemask_ps(ok) & live;
    *fb = (unsigned)_mm_movemask_ps(z) & live;
    *t_out = t;
    *u_out = _mm_mul_ps(V, inv);
    *v_out = _mm_mul_ps(W, inv);
}

/* The per-ray state a leaf needs, set up once per ray. */
typedef struct leaf_ctx {
    quad_ray qr;          /* the ray for quad_isect */
    const rt_ray *r;      /* the ray (scalar fallback, interval) */
    const rt_tri *tris;   /* scene triangles (scalar fallback) */
    uint8_t *mark;        /* rt_trav's mark array, or NULL */
    uint8_t mbit;         /* its bit */
    rt_rec_w w;           /* recorder's local writer (memmodel.h; recording walk only) */
    uint64_t tri_base;    /* triangle region: base and record size (rt_mm_addr, */
    uint64_t tri_size;    /* hoisted: the recorder's stores may alias the layout) */
    const rt_scene_alpha *alpha; /* the scene's alpha textures (NULL: none) */
    const rt_alpha_at *aat;      /* where the filter records */
    rt_rec *rec;                 /* the walk's recorder (NULL: not recording) */
} leaf_ctx;

/* The alpha filter (rt_alpha_cut) inside a leaf: the filter records
 * through the recorder itself, so the local writer hands its count back
 * around it (memmodel.h: nothing else may record between wbegin and
 * wend). */
static RT_ALWAYS_INLINE int leaf_cut(leaf_ctx *c, const int recording, uint32_t tri, float u, float v)
{
    if (__builtin_expect(c->alpha == NULL, 1)) return 0;
    if (recording) rt_rec_wend(&c->w);
    const int cut = rt_alpha_cut(c->alpha, c->aat, c->rec, c->r, tri, u, v);
    if (recording) rt_rec_wbegin(&c->w, c->w.rec);
    return cut;
}

static RT_ALWAYS_INLINE void leaf_setup(leaf_ctx *c, const rt_trav *tv, const rt_ray *r, const float *o,
                                        const int recording)
{
    c->r = r;
    c->tris = tv->sc->tri;
    c->mark = tv->mark;
    c->mbit = tv->mark_bit;
    c->alpha = tv->sc->alpha;
    c->aat = &tv->alpha;
    c->rec = tv->rec;
    if (recording) rt_rec_wbegin(&c->w, tv->rec);
    c->tri_base = recording ? tv->L->r[tv->reg_tri].base : 0;
    c->tri_size = recording ? tv->L->r[tv->reg_tri].recsize : 0;
    c->qr.kx = r->kx;
    c->qr.ky = r->ky;
    c->qr.kz = r->kz;
    c->qr.ox = _mm_set1_ps(o[r->kx]);
    c->qr.oy = _mm_set1_ps(o[r->ky]);
    c->qr.oz = _mm_set1_ps(o[r->kz]);
    c->qr.Sx = _mm_set1_ps(r->Sx);
    c->qr.Sy = _mm_set1_ps(r->Sy);
    c->qr.Sz = _mm_set1_ps(r->Sz);
}

/* The closest-hit state carried through the leaves. */
typedef struct best_hit {
    float t, u, v; /* best hit so far; t starts at the ray's tmax */
    uint32_t tri;  /* its triangle; 0 while no hit, so an equal t never wins */
    int found;     /* a hit is held */
} best_hit;

/*
 * Tests the n entries of one leaf (its quads from q on) with the outcome
 * of the plain walk's entry-by-entry loop: any = 0 updates *b (all entries
 * tested); any = 1 returns 1 at the first entry hit inside (tmin, tmax),
 * and entries past it are neither counted, marked nor recorded. *ntest
 * grows by the entries tested. Hits are rare, so lanes are resolved one
 * by one in entry order only when the quad reports some.
 */
static RT_ALWAYS_INLINE int leaf_test(leaf_ctx *c, const rt_kd_quad *q, uint32_t n, best_hit *b,
                                      uint64_t *ntest, const int any, const int recording, const int strict)
{
    const float rtmin = c->r->tmin, rtmax = c->r->tmax;
    int occluded = 0;
    for (uint32_t base = 0; base < n; base += 4, q++) {
        unsigned lanes = n - base < 4 ? n - base : 4; /* entries of this quad tested */
        __m128 t4, u4, v4;
        unsigned hit, fb;
        quad_isect(&c->qr, q, &t4, &u4, &v4, &hit, &fb);
        unsigned todo_m = hit | fb; /* padding lanes are never live */
        if (todo_m) {
            float ts[4], us[4], vs[4];
            _mm_storeu_ps(ts, t4);
            _mm_storeu_ps(us, u4);
            _mm_storeu_ps(vs, v4);
            do {
                const unsigned j = (unsigned)__builtin_ctz(todo_m);
                todo_m &= todo_m - 1u;
                const uint32_t tri = q->tri[j] & ~RT_KD_QUAD_DEGEN;
                float t = ts[j], u = us[j], v = vs[j];
                /* the fallback lane's triangle is live: not degenerate */
                if (!(hit >> j & 1u) && !rt_isect_core_nd(c->r, &c->tris[tri], &t, &u, &v)) continue;
                if (any) {
                    if (t > rtmin && t < rtmax && !leaf_cut(c, recording, tri, u, v)) {
                        occluded = 1;
                        lanes = j + 1;
                        break;
                    }
                } else if ((strict ? t > rtmin && t < rtmax && (!b->found || t < b->t || (t == b->t && tri < b->tri))
                                   : t > rtmin && (t < b->t || (t == b->t && tri < b->tri))) &&
                           !leaf_cut(c, recording, tri, u, v)) {
                    b->found = 1;
                    b->t = t;
                    b->tri = tri;
                    b->u = u;
                    b->v = v;
                }
            } while (todo_m);
        }
        *ntest += lanes;
        if (c->mark || recording)
            for (unsigned j = 0; j < lanes; j++) {
                const uint32_t tri = q->tri[j] & ~RT_KD_QUAD_DEGEN;
                if (c->mark) c->mark[tri] |= c->mbit;
                if (recording) rt_rec_wput(&c->w, c->tri_base + tri * c->tri_size, 36, RT_CLS_TRI);
            }
        if (any && occluded) return 1;
    }
    return 0;
}

/* The untraced walk calls its leaves out of line: the node loop then keeps
 * its few values in registers (measured faster than inlining). */
static RT_NOINLINE void leaf_closest(leaf_ctx *c, const rt_kd_quad *q, uint32_t n, best_hit *b, uint64_t *ntest)
{
    leaf_test(c, q, n, b, ntest, 0, 0, 0);
}

static RT_NOINLINE int leaf_any(leaf_ctx *c, const rt_kd_quad *q, uint32_t n, uint64_t *ntest)
{
    return leaf_test(c, q, n, NULL, ntest, 1, 0, 0);
}

/*
 * The traversal on the host-side copy (kdtree.h): the node walk of
 * traverse_plain on hnodes, leaves tested four triangles at a time. The
 * order of everything observable is the plain one: nodes visited, tests
 * counted, triangles marked and accesses recorded entry by entry, and an
 * any-hit walk stops after the same entry. `recording` is a constant at
 * every call site, so the untraced walk carries no recorder branches.
 * The early-exit test (rt_kd_past) runs where tMin or the best hit can
 * change -- at entry and after each pop -- since a descent changes
 * neither; the ray is read field by field (copying the struct whole
 * stalls on the caller's fresh field-wise stores).
 */
static RT_ALWAYS_INLINE int traverse_fast(rt_trav *tv, const rt_ray *r, uint32_t node, float tMin, float tMax,
                                          rt_hit *h, const int any, const int recording)
{
    const rt_kdnode *nodes = tv->kd->hnodes;
    const rt_kd_quad *quads = tv->kd->quads;
    const float o[3] = {r->o.x, r->o.y, r->o.z};
    const float inv[3] = {r->inv_d.x, r->inv_d.y, r->inv_d.z};
    const uint8_t dle0[3] = {r->d.x <= 0.0f, r->d.y <= 0.0f, r->d.z <= 0.0f};
    leaf_ctx c;
    leaf_setup(&c, tv, r, o, recording);

    best_hit b = {r->tmax, 0.0f, 0.0f, 0, 0};
    if (!any && h->tri != RT_NO_HIT) {
        b.found = 1;
        b.t = h->t;
        b.tri = h->tri;
        b.u = h->u;
        b.v = h->v;
    }
    const uint64_t node_base = recording ? tv->L->r[tv->reg_node].base : 0;
    const uint64_t idx_base = recording ? tv->L->r[tv->reg_idx].base : 0;
    const uint64_t node_size = recording ? tv->L->r[tv->reg_node].recsize : 0;
    const uint64_t idx_size = recording ? tv->L->r[tv->reg_idx].recsize : 0;
    todo stack[RT_KD_STACK];
    int sp = 0;
    uint64_t nvisit = 0, ntest = 0;
    int occluded = 0;
    float tMinW = rt_kd_wlo(tMin), tMaxW = rt_kd_whi(tMax); /* the interval widened (rt_kd_step_w) */
    int ordered = 1; /* no RT_KD_INPLANE entry pushed: entries begin later the deeper they lie */

    if (!any && rt_kd_past(b.t, tMin)) goto done;
    for (;;) {
        const rt_kdnode *nd = &nodes[node];
        nvisit++;
        if (recording) rt_rec_wput(&c.w, node_base + node * node_size, 8, RT_CLS_NODE);
        uint32_t w1 = nd->w1;
        while ((w1 & 3u) != 3u) { /* descend to a leaf */
            const uint32_t axis = w1 & 3u;
            const float split = rt_kd_split(nd);
            const float oa = o[axis];
            const float tPlane = (split - oa) * inv[axis];
            const int belowFirst = oa < split || (oa == split && dle0[axis]);
            const uint32_t above = w1 >> 2;
            const uint32_t first = belowFirst ? node + 1 : above;
            const uint32_t second = belowFirst ? above : node + 1;
            float near_end, far_start;
            const int step = rt_kd_step_w(tPlane, tMin, tMax, tMinW, tMaxW, &near_end, &far_start);
            if (step == RT_KD_NEAR) {
                node = first;
            } else if (step == RT_KD_FAR) {
                node = second;
            } else {
                stack[sp].node = second;
                stack[sp].tmin = far_start;
                stack[sp].tmax = tMax;
                sp++;
                node = first;
                tMax = near_end;
                tMaxW = rt_kd_whi(tMax);
                if (step & RT_KD_INPLANE) ordered = 0;
            }
            nd = &nodes[node];
            nvisit++;
            if (recording) rt_rec_wput(&c.w, node_base + node * node_size, 8, RT_CLS_NODE);
            w1 = nd->w1;
        }
        const uint32_t n = w1 >> 2;
        if (n > 0) {
            const rt_kd_quad *q = quads + nd->w0;
            if (recording) {
                rt_rec_wput(&c.w, idx_base + tv->kd->nodes[node].w0 * idx_size, 4u * n, RT_CLS_INDEX);
                if (leaf_test(&c, q, n, &b, &ntest, any, 1, 0)) {
                    occluded = 1;
                    break;
                }
            } else if (any) {
                if (leaf_any(&c, q, n, &ntest)) {
                    occluded = 1;
                    break;
                }
            } else {
                leaf_closest(&c, q, n, &b, &ntest);
            }
        }
        todo e;
        if (!pop_next(stack, &sp, b.t, any, ordered, &e)) goto done;
        node = e.node;
        tMin = e.tmin;
        tMax = e.tmax;
        tMinW = rt_kd_wlo(tMin);
        tMaxW = rt_kd_whi(tMax);
    }
done:
    if (recording) rt_rec_wend(&c.w);
    tv->nodes += nvisit;
    tv->tests += ntest;
    if (any) return occluded;
    if (b.found) {
        h->t = b.t;
        h->tri = b.tri;
        h->u = b.u;
        h->v = b.v;
    }
    return b.found;
}

/* Picks the walk: the host copy when the tree has one, with or without
 * the recorder; the plain walk otherwise. */
static RT_ALWAYS_INLINE int traverse(rt_trav *tv, const rt_ray *r, uint32_t node, float t0, float t1, rt_hit *h,
                                     const int any)
{
    if (!tv->kd->hnodes) return traverse_plain(tv, r, node, t0, t1, h, any);
    if (tv->rec) return traverse_fast(tv, r, node, t0, t1, h, any, 1);
    return traverse_fast(tv, r, node, t0, t1, h, any, 0);
}
#else
#define traverse traverse_plain
#endif

int rt_kd_closest(rt_trav *tv, const rt_ray *r, rt_hit *h)
{
    rt_hit_none(h);
    float t0, t1;
    if (!rt_kd_clip(tv->kd, r, &t0, &t1)) return 0;
    return traverse(tv, r, 0, t0, t1, h, 0);
}

int rt_kd_occluded(rt_trav *tv, const rt_ray *r)
{
    float t0, t1;
    if (!rt_kd_clip(tv->kd, r, &t0, &t1)) return 0;
    return traverse(tv, r, 0, t0, t1, NULL, 1);
}

int rt_kd_closest_sub(rt_trav *tv, const rt_ray *r, uint32_t node, float t0, float t1, rt_hit *h)
{
    return traverse(tv, r, node, t0, t1, h, 0);
}

int rt_kd_occluded_sub(rt_trav *tv, const rt_ray *r, uint32_t node, float t0, float t1)
{
    return traverse(tv, r, node, t0, t1, NULL, 1);
}

/* The leaf functions' hit rule: t (u, v) of triangle tri replaces *h when
 * *h holds no hit, or t is closer, or equal with a lower index. 1 then. */
static inline int take_hit(rt_hit *h, float t, float u, float v, uint32_t tri)
{
    if (!(h->tri == RT_NO_HIT || t < h->t || (t == h->t && tri < h->tri))) return 0;
    h->t = t;
    h->tri = tri;
    h->u = u;
    h->v = v;
    return 1;
}

#if defined(__SSE2__)
/* A quad walk's best hit b into *h (b started from *h): 1 when it changed. */
static inline int take_best(rt_hit *h, const best_hit *b)
{
    if (!(b->found && (h->tri == RT_NO_HIT || b->tri != h->tri || b->t != h->t))) return 0;
    h->t = b->t;
    h->tri = b->tri;
    h->u = b->u;
    h->v = b->v;
    return 1;
}
#endif

int rt_kd_leaf(rt_trav *tv, const rt_ray *r, uint32_t node, rt_hit *h, int any)
{
    const rt_kdnode *nd = &tv->kd->nodes[node];
    const uint32_t n = rt_kd_ntri(nd), first = rt_kd_first(nd);
    if (n == 0) return 0;
    RT_REC(tv->rec, rt_mm_addr(tv->L, tv->reg_idx, first), 4u * n, 0, RT_CLS_INDEX);
#if defined(__SSE2__)
    if (tv->kd->hnodes) {
        const float o[3] = {r->o.x, r->o.y, r->o.z};
        const rt_kd_quad *q = tv->kd->quads + tv->kd->hnodes[node].w0;
        leaf_ctx c;
        best_hit b = {h ? h->t : 0.0f, h ? h->u : 0.0f, h ? h->v : 0.0f, h ? h->tri : 0, h && h->tri != RT_NO_HIT};
        uint64_t ntest = 0;
        int rc;
        if (tv->rec) {
            leaf_setup(&c, tv, r, o, 1);
            rc = any ? leaf_test(&c, q, n, NULL, &ntest, 1, 1, 1) : leaf_test(&c, q, n, &b, &ntest, 0, 1, 1);
            rt_rec_wend(&c.w);
        } else {
            leaf_setup(&c, tv, r, o, 0);
            rc = any ? leaf_test(&c, q, n, NULL, &ntest, 1, 0, 1) : leaf_test(&c, q, n, &b, &ntest, 0, 0, 1);
        }
        tv->tests += ntest;
        return any ? rc : take_best(h, &b);
    }
#endif
    int changed = 0;
    for (uint32_t k = 0; k < n; k++) {
        const uint32_t tri = tv->kd->idx[first + k];
        RT_REC(tv->rec, rt_mm_addr(tv->L, tv->reg_tri, tri), 36, 0, RT_CLS_TRI);
        tv->tests++;
        if (tv->mark) tv->mark[tri] |= tv->mark_bit;
        float t, u, v;
        if (!rt_isect_core(r, &tv->sc->tri[tri], &t, &u, &v) || !(t > r->tmin && t < r->tmax)) continue;
        if (any) {
            if (rt_alpha_cut(tv->sc->alpha, &tv->alpha, tv->rec, r, tri, u, v)) continue;
            return 1;
        }
        if ((h->tri == RT_NO_HIT || t < h->t || (t == h->t && tri < h->tri)) &&
            !rt_alpha_cut(tv->sc->alpha, &tv->alpha, tv->rec, r, tri, u, v))
            changed |= take_hit(h, t, u, v, tri);
    }
    return changed;
}

int rt_kd_leaf_scan(const rt_trav *tv, const rt_ray *r, uint32_t node, rt_hit *h, int any, uint32_t *ntested)
{
    const rt_kdnode *nd = &tv->kd->nodes[node];
    const uint32_t n = rt_kd_ntri(nd), first = rt_kd_first(nd);
    *ntested = 0;
    if (n == 0) return 0;
#if defined(__SSE2__)
    if (tv->kd->hnodes) {
        const float o[3] = {r->o.x, r->o.y, r->o.z};
        leaf_ctx c;
        leaf_setup(&c, tv, r, o, 0);
        c.mark = NULL; /* the caller marks what it reads */
        const rt_kd_quad *q = tv->kd->quads + tv->kd->hnodes[node].w0;
        uint64_t ntest = 0;
        if (any) {
            const int rc = leaf_test(&c, q, n, NULL, &ntest, 1, 0, 1);
            *ntested = (uint32_t)ntest;
            return rc;
        }
        best_hit b = {h->t, h->u, h->v, h->tri, h->tri != RT_NO_HIT};
        leaf_test(&c, q, n, &b, &ntest, 0, 0, 1);
        *ntested = (uint32_t)ntest;
        return take_best(h, &b);
    }
#endif
    int changed = 0;
    for (uint32_t k = 0; k < n; k++) {
        const uint32_t tri = tv->kd->idx[first + k];
        float t, u, v;
        *ntested = k + 1;
        if (!rt_isect_core(r, &tv->sc->tri[tri], &t, &u, &v) || !(t > r->tmin && t < r->tmax)) continue;
        if (any) {
            if (rt_alpha_cut(tv->sc->alpha, &tv->alpha, tv->rec, r, tri, u, v)) continue;
            return 1;
        }
        if ((h->tri == RT_NO_HIT || t < h->t || (t == h->t && tri < h->tri)) &&
            !rt_alpha_cut(tv->sc->alpha, &tv->alpha, tv->rec, r, tri, u, v))
            changed |= take_hit(h, t, u, v, tri);
    }
    return changed;
}

int rt_kd_plain_sub(rt_trav *tv, const rt_ray *r, uint32_t node, float t0, float t1, rt_hit *h, int any)
{
    return any ? traverse_plain(tv, r, node, t0, t1, NULL, 1) : traverse_plain(tv, r, node, t0, t1, h, 0);
}

/* ---- the k-d tree as a member of the acceleration layer (accel.h) -------- */

static void *kd_build(const rt_scene *sc, const rt_accel_params *p, rt_err *e)
{
    (void)p;
    rt_kd_params kp;
    rt_kd_default_params(&kp);
    return rt_kd_build(sc, &kp, e);
}

static void kd_free(void *as) { rt_kd_free(as); }

/* kd.nodes (8-byte nodes) and kd.index (4-byte leaf entries): the
 * addresses every k-d tracer shares. */
static int kd_regions(const void *as, const rt_scene *sc, rt_layout *L, rt_err *e)
{
    const rt_kdtree *kd = as;
    (void)sc;
    if (rt_mm_add(L, "kd.nodes", RT_CLS_NODE, 8, kd->nnodes, e) < 0) return -1;
    return rt_mm_add(L, "kd.index", RT_CLS_INDEX, 4, kd->nidx, e) < 0 ? -1 : 0;
}

static void kd_trav_init(rt_trav *tv, const void *as, const rt_layout *L)
{
    tv->kd = as;
    tv->reg_node = rt_mm_find(L, "kd.nodes");
    tv->reg_idx = rt_mm_find(L, "kd.index");
}

static int kd_check(const void *as, const rt_scene *sc, rt_err *e) { return rt_kd_check(as, sc, e); }

static void kd_info(const void *as, rt_accel_info *inf)
{
    const rt_kdtree *kd = as;
    inf->nodes = kd->nnodes;
    inf->bytes = 8 * (uint64_t)kd->nnodes + 4 * (uint64_t)kd->nidx;
    inf->depth = kd->maxdepth;
}

const rt_accel_ops rt_accel_kd = {
    .name = "kd",
    .desc = "SAH k-d tree, 8-byte nodes (pbrt; Navratil et al. 2007)",
    .build = kd_build,
    .free = kd_free,
    .regions = kd_regions,
    .trav_init = kd_trav_init,
    .closest = rt_kd_closest,
    .occluded = rt_kd_occluded,
    .check = kd_check,
    .info = kd_info,
};
