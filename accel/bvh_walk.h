/*
 * bvh_walk.h -- the parts of the BVH walks that two translation units
 * compile: bvh.c (every walk; SSE2 where the target has it) and bvh_avx.c
 * (only the bvh8 fast walk, recording or not, built with AVX and chosen at
 * run time when the processor has it, rt_bvh.fast_avx). Private to those
 * two files.
 *
 * Every path -- scalar reference lanes, SSE2 four-box and AVX eight-box
 * tests -- performs the same IEEE single-precision operations in the same
 * order on the same operands (no contraction: the build passes
 * -ffp-contract=off), so every walk visits the same nodes and returns the
 * same hits, bit for bit; tests/test_bvh.c runs each against the others.
 */
#ifndef RT_BVH_WALK_H
#define RT_BVH_WALK_H

#include "bvh.h"

#include <float.h>
#include <math.h>
#include <stdint.h>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif
#if defined(__AVX__)
#include <immintrin.h>
#endif

/* The bvh8 fast walk compiled with AVX (bvh_avx.c): rt_bvh_closest's
 * (any 0) and rt_bvh_occluded's (any 1) walk, recording when tv->rec is
 * set. Call only when tv->bvh->fast_avx is set. */
int rt_bvh_walk8_avx(rt_bvh_trav *tv, const rt_ray *r, rt_hit *h, int any);

/* pbrt's gamma(3): the far distance is widened by 1 + 2 gamma(3). */
#define GAMMA3 ((3.0f * FLT_EPSILON * 0.5f) / (1.0f - 3.0f * FLT_EPSILON * 0.5f))
#define FAR_SCALE (1.0f + 2.0f * GAMMA3)
#define RT_BVH_STACK 512 /* >= 1 + 7 x RT_BVH_MAX_DEPTH */

/* The ray as the slab tests read it. */
typedef struct wray {
    float o[3], inv[3]; /* origin, 1/d */
    int neg[3];         /* 1/d negative (d < 0 or d = -0): near plane is hi */
    float tmin;         /* the ray's tmin */
} wray;

static RT_ALWAYS_INLINE void wray_init(wray *w, const rt_ray *r)
{
    w->o[0] = r->o.x;
    w->o[1] = r->o.y;
    w->o[2] = r->o.z;
    w->inv[0] = r->inv_d.x;
    w->inv[1] = r->inv_d.y;
    w->inv[2] = r->inv_d.z;
    /* written out, not a loop: an indexed store would keep w in memory */
    w->neg[0] = signbit(w->inv[0]) != 0;
    w->neg[1] = signbit(w->inv[1]) != 0;
    w->neg[2] = signbit(w->inv[2]) != 0;
    w->tmin = r->tmin;
}

/* One box (the reference lane): 1 when hit, with its entry distance. */
static RT_ALWAYS_INLINE int box_lane(const wray *w, float lx, float ly, float lz, float hx, float hy, float hz,
                                     float cull, float *tnear)
{
    const float lo[3] = {lx, ly, lz}, hi[3] = {hx, hy, hz};
    float tn = w->tmin, tf = INFINITY;
    for (int a = 0; a < 3; a++) {
        const float np = w->neg[a] ? hi[a] : lo[a], fp = w->neg[a] ? lo[a] : hi[a];
        const float n = (np - w->o[a]) * w->inv[a];
        const float f = (fp - w->o[a]) * w->inv[a];
        tn = n > tn ? n : tn; /* NaN constrains nothing */
        tf = f < tf ? f : tf;
    }
    tf = tf * FAR_SCALE;
    tf = tf < cull ? tf : cull;
    *tnear = tn;
    return tn <= tf;
}

#if defined(__SSE2__)
typedef struct wsse {
    __m128 o[3], inv[3]; /* broadcast origin and 1/d */
    __m128 tmin, inf, scale;
} wsse;

static RT_ALWAYS_INLINE void wsse_init(wsse *q, const wray *w)
{
    q->o[0] = _mm_set1_ps(w->o[0]);
    q->o[1] = _mm_set1_ps(w->o[1]);
    q->o[2] = _mm_set1_ps(w->o[2]);
    q->inv[0] = _mm_set1_ps(w->inv[0]);
    q->inv[1] = _mm_set1_ps(w->inv[1]);
    q->inv[2] = _mm_set1_ps(w->inv[2]);
    q->tmin = _mm_set1_ps(w->tmin);
    q->inf = _mm_set1_ps(INFINITY);
    q->scale = _mm_set1_ps(FAR_SCALE);
}

/* Four boxes at base (lanes of rows [axis][0..3]): box_lane's operations
 * lane by lane (maxps/minps are a > b ? a : b and a < b ? a : b). nofs and
 * fofs: per axis the float offset of the near and far row (wray_rows).
 * Returns the hit lanes' mask; entry distances in tn_out. */
static RT_ALWAYS_INLINE unsigned box4(const wsse *q, const float *base, const int *nofs, const int *fofs, float cull,
                                      float *tn_out)
{
    const __m128 n0 = _mm_mul_ps(_mm_sub_ps(_mm_loadu_ps(base + nofs[0]), q->o[0]), q->inv[0]);
    const __m128 f0 = _mm_mul_ps(_mm_sub_ps(_mm_loadu_ps(base + fofs[0]), q->o[0]), q->inv[0]);
    const __m128 n1 = _mm_mul_ps(_mm_sub_ps(_mm_loadu_ps(base + nofs[1]), q->o[1]), q->inv[1]);
    const __m128 f1 = _mm_mul_ps(_mm_sub_ps(_mm_loadu_ps(base + fofs[1]), q->o[1]), q->inv[1]);
    const __m128 n2 = _mm_mul_ps(_mm_sub_ps(_mm_loadu_ps(base + nofs[2]), q->o[2]), q->inv[2]);
    const __m128 f2 = _mm_mul_ps(_mm_sub_ps(_mm_loadu_ps(base + fofs[2]), q->o[2]), q->inv[2]);
    const __m128 tn = _mm_max_ps(n2, _mm_max_ps(n1, _mm_max_ps(n0, q->tmin)));
    __m128 tf = _mm_min_ps(f2, _mm_min_ps(f1, _mm_min_ps(f0, q->inf)));
    tf = _mm_mul_ps(tf, q->scale);
    tf = _mm_min_ps(tf, _mm_set1_ps(cull));
    _mm_storeu_ps(tn_out, tn);
    return (unsigned)_mm_movemask_ps(_mm_cmple_ps(tn, tf));
}
#endif

#if defined(__AVX__)
/* box4 on eight boxes (bvh8's node) in one 256-bit vector: the same
 * operations lane by lane, so the same bits (vmaxps/vminps as maxps/minps,
 * vcmpps LE_OQ as cmpleps). */
typedef struct wavx {
    __m256 o[3], inv[3];
    __m256 tmin, inf, scale;
} wavx;

static RT_ALWAYS_INLINE void wavx_init(wavx *q, const wray *w)
{
    q->o[0] = _mm256_set1_ps(w->o[0]);
    q->o[1] = _mm256_set1_ps(w->o[1]);
    q->o[2] = _mm256_set1_ps(w->o[2]);
    q->inv[0] = _mm256_set1_ps(w->inv[0]);
    q->inv[1] = _mm256_set1_ps(w->inv[1]);
    q->inv[2] = _mm256_set1_ps(w->inv[2]);
    q->tmin = _mm256_set1_ps(w->tmin);
    q->inf = _mm256_set1_ps(INFINITY);
    q->scale = _mm256_set1_ps(FAR_SCALE);
}

static RT_ALWAYS_INLINE unsigned box8(const wavx *q, const float *base, const int *nofs, const int *fofs, float cull,
                                      float *tn_out)
{
    const __m256 n0 = _mm256_mul_ps(_mm256_sub_ps(_mm256_loadu_ps(base + nofs[0]), q->o[0]), q->inv[0]);
    const __m256 f0 = _mm256_mul_ps(_mm256_sub_ps(_mm256_loadu_ps(base + fofs[0]), q->o[0]), q->inv[0]);
    const __m256 n1 = _mm256_mul_ps(_mm256_sub_ps(_mm256_loadu_ps(base + nofs[1]), q->o[1]), q->inv[1]);
    const __m256 f1 = _mm256_mul_ps(_mm256_sub_ps(_mm256_loadu_ps(base + fofs[1]), q->o[1]), q->inv[1]);
    const __m256 n2 = _mm256_mul_ps(_mm256_sub_ps(_mm256_loadu_ps(base + nofs[2]), q->o[2]), q->inv[2]);
    const __m256 f2 = _mm256_mul_ps(_mm256_sub_ps(_mm256_loadu_ps(base + fofs[2]), q->o[2]), q->inv[2]);
    const __m256 tn = _mm256_max_ps(n2, _mm256_max_ps(n1, _mm256_max_ps(n0, q->tmin)));
    __m256 tf = _mm256_min_ps(f2, _mm256_min_ps(f1, _mm256_min_ps(f0, q->inf)));
    tf = _mm256_mul_ps(tf, q->scale);
    tf = _mm256_min_ps(tf, _mm256_set1_ps(cull));
    _mm256_storeu_ps(tn_out, tn);
    return (unsigned)_mm256_movemask_ps(_mm256_cmp_ps(tn, tf, _CMP_LE_OQ));
}
#endif

/* The best hit so far and the walk's counters. */
typedef struct wstate {
    float best, bu, bv; /* best t (starts at tmax), its barycentrics */
    uint32_t btri;      /* its scene index; 0 while none, so an equal t never wins */
    int found;          /* a hit is held */
    float cull;         /* rt_bvh_cull_bound(best) */
    float tmin, tmax;   /* the ray's interval, held so the walks need no copy of the ray */
    uint64_t nvisit, ntest;
    uint64_t tri_base;  /* bvh.tri base address (recording) */
    /* the tree's arrays and the marks, held here: a store through mark
     * (a char pointer) would otherwise force them to be reloaded from the
     * tree and the traversal state after every triangle */
    const rt_tri *tri;  /* the tree's copy in leaf order, or NULL: stri[orig[k]] */
    const rt_tri *stri; /* the scene's triangles */
    const uint32_t *orig, *degen;
    uint8_t *mark;
    uint8_t mark_bit;
    rt_rec *rec;
    const rt_scene_alpha *alpha; /* the scene's alpha textures (NULL: none) */
    const rt_alpha_at *aat;      /* where the filter records */
#if defined(__SSE2__)
    rt_isect_sse iq;    /* the ray for the triangle test */
#endif
} wstate;

/* Tests records [first, first + n). any: 1 at the first hit in (tmin, tmax). */
static RT_ALWAYS_INLINE int leaf_tris(const rt_ray *r, uint32_t first, uint32_t n, wstate *S,
                                      const int any)
{
    for (uint32_t k = first; k < first + n; k++) {
        const uint32_t o = S->orig[k];
        S->ntest++;
        if (S->mark) S->mark[o] |= S->mark_bit;
        RT_REC(S->rec, S->tri_base + 36ull * k, 36, 0, RT_CLS_TRI);
        float t, u, v;
        const rt_tri *T = S->tri ? &S->tri[k] : &S->stri[o];
#if defined(__SSE2__)
        if (!rt_isect_core_nd_sse(&S->iq, r, T, &t, &u, &v)) continue;
#else
        if (!rt_isect_core_nd(r, T, &t, &u, &v)) continue;
#endif
        if (rt_bvh_degenerate(S->degen, k)) continue;
        if (any) {
            if (t > S->tmin && t < S->tmax && !rt_alpha_cut(S->alpha, S->aat, S->rec, r, o, u, v)) return 1;
        } else if (t > S->tmin && (t < S->best || (t == S->best && o < S->btri)) &&
                   !rt_alpha_cut(S->alpha, S->aat, S->rec, r, o, u, v)) {
            S->found = 1;
            S->best = t;
            S->btri = o;
            S->bu = u;
            S->bv = v;
            S->cull = rt_bvh_cull_bound(t);
        }
    }
    return 0;
}

static RT_ALWAYS_INLINE int finish(rt_bvh_trav *tv, const wstate *S, rt_hit *h, const int any, int occluded)
{
    tv->nodes += S->nvisit;
    tv->tests += S->ntest;
    if (any) return occluded;
    if (!S->found) {
        rt_hit_none(h);
        return 0;
    }
    h->t = S->best;
    h->tri = S->btri;
    h->u = S->bu;
    h->v = S->bv;
    return 1;
}

static RT_ALWAYS_INLINE void wstate_init(wstate *S, const rt_bvh_trav *tv, const rt_ray *r)
{
    S->best = r->tmax;
    S->bu = S->bv = 0.0f;
    S->btri = 0;
    S->found = 0;
    S->cull = rt_bvh_cull_bound(r->tmax);
    S->tmin = r->tmin;
    S->tmax = r->tmax;
    S->nvisit = S->ntest = 0;
    S->tri_base = tv->rec ? tv->L->r[tv->reg_tri].base : 0;
    S->tri = tv->bvh->tri;
    S->stri = tv->bvh->stri;
    S->orig = tv->bvh->orig;
    S->degen = tv->bvh->degen;
    S->mark = tv->mark;
    S->mark_bit = tv->mark_bit;
    S->rec = tv->rec;
    S->alpha = tv->sc ? tv->sc->alpha : NULL;
    S->aat = &tv->alpha;
#if defined(__SSE2__)
    rt_isect_sse_init(&S->iq, r);
#endif
}

typedef struct sentry {
    uint32_t a; /* interior: node index; leaf: first triangle record */
    uint32_t n; /* leaf: triangles; interior: 0 */
    float t;    /* entry distance */
} sentry;

#if defined(__SSE2__)
/* The fast wide walk (rt_bvh_closest and rt_bvh_occluded, recording or
 * not): walk_wide's visits in walk_wide's order, with the same counts,
 * marks, hits and recorded accesses, in fewer instructions. Of a node's hit children the
 * nearest is entered at once instead of being pushed and popped (it passes
 * the pop's cull test: a hit box's entry is <= its clipped far distance <=
 * the cull bound, which nothing changes in between); the others are pushed
 * farthest first as walk_wide pushes them, so every later pop, cull test
 * and leaf happens exactly as there.
 *
 * oct: the ray's octant (bit a: 1/d negative on axis a), a constant in
 * every copy walk_octant makes, so the near and far rows' offsets are
 * constants too and leave their registers to the loop; -1: read from the
 * ray. recd: 1 records walk_wide's accesses in walk_wide's order (a node
 * as it is visited, a triangle as it is tested), 0 records nothing, a
 * constant so the untraced copies carry no recording code. Compiled with
 * AVX (bvh_avx.c), a bvh8 node's eight boxes are tested in one vector. */
static RT_ALWAYS_INLINE int walk_fast(rt_bvh_trav *tv, const rt_ray *r, rt_hit *h, const int any, const int W,
                                      const int oct, const int recd)
{
    const rt_bvh *b = tv->bvh;
    wstate S;
    wstate_init(&S, tv, r);
    if (!recd) S.rec = NULL;
    rt_rec *const rec = S.rec;
    const uint64_t nbase = rec ? tv->L->r[tv->reg_node].base : 0;
    const uint32_t nsize = rec ? rt_bvh_node_size(W) : 0;
    wray w;
    wray_init(&w, r);
    /* walk_wide pops the root with its entry t = tmin */
    if (!b->nnodes || w.tmin > S.cull) return finish(tv, &S, h, any, 0);
#if defined(__AVX__)
    wavx q8;
    if (W == 8) wavx_init(&q8, &w);
#endif
    wsse q;
    wsse_init(&q, &w);
    int nofs[3], fofs[3];
    for (int a = 0; a < 3; a++) {
        const int ng = oct >= 0 ? (oct >> a) & 1 : w.neg[a];
        nofs[a] = a * W + (ng ? 3 * W : 0);
        fofs[a] = a * W + (ng ? 0 : 3 * W);
    }
    const rt_bvh4_node *n4 = b->n4;
    const rt_bvh8_host *h8 = b->h8;
    sentry st[RT_BVH_STACK];
    int sp = 0, occluded = 0;
    uint32_t node = 0;
    for (;;) {
        S.nvisit++;
        RT_REC(rec, nbase + (uint64_t)nsize * node, nsize, 0, RT_CLS_NODE);
        const float *base = W == 4 ? &n4[node].lo[0][0] : &h8[node].lo[0][0];
        float tn[8];
#if defined(__AVX__)
        unsigned mask = W == 8 ? box8(&q8, base, nofs, fofs, S.cull, tn) : box4(&q, base, nofs, fofs, S.cull, tn);
#else
        unsigned mask = box4(&q, base, nofs, fofs, S.cull, tn);
        if (W == 8) mask |= box4(&q, base + 4, nofs, fofs, S.cull, tn + 4) << 4;
#endif
        if (mask) {
            int s0 = __builtin_ctz(mask);
            const unsigned rest = mask & (mask - 1);
            if (rest && !(rest & (rest - 1))) {
                /* two hit children, the most common case of several: the
                 * far one pushed (ties: the higher slot), the near entered */
                int s1 = __builtin_ctz(rest);
                if (tn[s1] < tn[s0]) {
                    const int x = s0;
                    s0 = s1;
                    s1 = x;
                }
                uint32_t ra, rn;
                if (rt_bvh_wide_child(W, n4, h8, node, s1, &ra, &rn)) st[sp++] = (sentry){ra, rn, tn[s1]};
            } else if (rest) {
                int ord[8], k = rt_bvh_order_slots(mask, tn, ord);
                while (--k > 0) {
                    const int s = ord[k];
                    uint32_t ra, rn;
                    if (rt_bvh_wide_child(W, n4, h8, node, s, &ra, &rn)) st[sp++] = (sentry){ra, rn, tn[s]};
                }
                s0 = ord[0];
            }
            uint32_t ra, rn;
            if (rt_bvh_wide_child(W, n4, h8, node, s0, &ra, &rn)) {
                if (!rn) {
                    node = ra;
                    continue;
                }
                if (leaf_tris(r, ra, rn, &S, any)) {
                    occluded = 1;
                    break;
                }
            }
        }
        /* the next entry that survives the cull bound: leaves are tested
         * as they come off the stack, a node is visited */
        for (;;) {
            if (sp == 0) return finish(tv, &S, h, any, occluded);
            const sentry e = st[--sp];
            if (e.t > S.cull) continue;
            if (!e.n) {
                node = e.a;
                break;
            }
            if (leaf_tris(r, e.a, e.n, &S, any)) return finish(tv, &S, h, any, 1);
        }
    }
    return finish(tv, &S, h, any, occluded);
}

/* walk_fast in the ray's octant's copy, untraced. */
static RT_ALWAYS_INLINE int walk_octant(rt_bvh_trav *tv, const rt_ray *r, rt_hit *h, const int any, const int W)
{
    switch ((signbit(r->inv_d.x) ? 1 : 0) | (signbit(r->inv_d.y) ? 2 : 0) | (signbit(r->inv_d.z) ? 4 : 0)) {
    case 0: return walk_fast(tv, r, h, any, W, 0, 0);
    case 1: return walk_fast(tv, r, h, any, W, 1, 0);
    case 2: return walk_fast(tv, r, h, any, W, 2, 0);
    case 3: return walk_fast(tv, r, h, any, W, 3, 0);
    case 4: return walk_fast(tv, r, h, any, W, 4, 0);
    case 5: return walk_fast(tv, r, h, any, W, 5, 0);
    case 6: return walk_fast(tv, r, h, any, W, 6, 0);
    default: return walk_fast(tv, r, h, any, W, 7, 0);
    }
}

/* The fast walk for tv: the recording copy when tv records, else the
 * untraced copy of the ray's octant. */
static RT_ALWAYS_INLINE int walk_fast_for(rt_bvh_trav *tv, const rt_ray *r, rt_hit *h, const int any, const int W)
{
    return tv->rec ? walk_fast(tv, r, h, any, W, -1, 1) : walk_octant(tv, r, h, any, W);
}
#endif

#endif
