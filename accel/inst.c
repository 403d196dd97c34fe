/*
 * inst.c -- true instancing: a two-level BVH over a scene's object
 * instances (accel kind "inst", selected by `--instances bvh`).
 *
 * A pbrt ObjectInstance places a shared object under a transformation. The
 * loader still makes the flattened copy (rt_scene.tri: shading, lights and
 * every other structure read it), and keeps beside it the objects'
 * triangles in object space (rt_scene.otri) and one record per instance
 * (rt_scene.irec: the object, where its copy starts in tri, the
 * object-to-world matrix). This structure is what the memory model sees
 * of instancing:
 *
 *   tlas.node  a binary BVH (pbrt's 32-byte LinearBVHNode) over the
 *              instances' world boxes; a leaf holds instances;
 *   inst       one 64-byte record per instance: the world-to-object
 *              matrix (12 floats, 48 B), the index of its bottom-level
 *              structure, its first triangle; read once per ray that
 *              enters the instance (its box was met), after which the ray
 *              is transformed into object space (counted in tv->xforms);
 *   blas.node  one binary BVH per object (the same 32-byte nodes), all
 *              objects' trees one after another, shared by every instance;
 *   blas.tri   the objects' 36-byte triangle records in leaf order, once
 *              per object, shared by every instance.
 * The triangles outside any instance record (outside objects, objects of
 * one or two triangles the loader copies at once, projective instances)
 * form one more bottom-level tree, in world space, entered through an
 * instance of the identity (instance 0 when there are such triangles);
 * so do singular instances (the loader records invertible ones only).
 *
 * Hits. The walk meets boxes with the object-space ray, but tests each
 * candidate triangle on its world-space copy in tri with the shared
 * watertight test (rt_isect_core) and the world ray, so hits follow the
 * rule of hit.h bit for bit and images equal the flattened structures'
 * (a hit is the scene's triangle index first + local, the shading copy).
 * To keep that exact while culling in object space, every bottom-level
 * box is padded (RT_INST_PAD, relative) and its ray interval widened:
 * rounding in the transformation can then only visit more, never miss.
 * The recorded read of a tested triangle is its shared blas.tri record.
 *
 * Invariants (rt_inst_check verifies each against the scene):
 *   (I1) every scene triangle belongs to exactly one instance: the
 *        records cover disjoint ranges first .. first + count of tri, and
 *        the loose tree holds exactly the rest, each once;
 *   (I2) an instance's flattened copy is its object transformed: world
 *        vertex = m x object vertex within rounding (relative 1e-4);
 *   (I3) every bottom-level tree is a well-formed depth-first BVH2: the
 *        first child follows its parent, the second child's index lies
 *        after it within the tree, leaves hold 1..RT_INST_LEAF records and
 *        partition the tree's records, each record once;
 *   (I4) every node's box contains its children's boxes and its leaf
 *        triangles (object space; world space for the loose tree);
 *   (I5) the top-level tree is a well-formed BVH2 over the instances, each
 *        in exactly one leaf, and every node's box contains the world box
 *        of the instances below it;
 *   (I6) each instance's world-to-object matrix is the inverse of its
 *        object-to-world matrix (product within 1e-4 of the identity).
 *
 * Kept instances (rt_scene.kept, scene.h: the loader made no flattened
 * copy; `--instances bvh` loads a .pbrt file so). tri then holds only the
 * loose triangles, which form the loose tree (covered[] maps them to their
 * scene indices in the flattened numbering); a candidate triangle of an
 * instance is made from its shared record with the loader's flattening
 * arithmetic (rt_scene_inst_tri), so it is the flattened copy bit for bit
 * and hits, ties and images are those of the flattened scene.
 *
 * The same model kept or flattened: an instance's world box is the exact
 * box of its triangles (rt_scene_inst_boxes: the flattened copy's bounds,
 * found from the object without making it) padded once by RT_INST_PAD,
 * and a tested triangle's mark goes to its shading slot of the instancing
 * model (rt_scene_model_slot: a loose triangle, or an object triangle
 * shared by all its instances), so a sweep over the flattened scene and a
 * render or trace over the kept one record the same accesses. For a kept
 * scene (I1) holds by rt_scene_check_kept's arithmetic (the records'
 * ranges and the loose triangles partition the indices), checked here on
 * covered[], and (I2) by construction.
 *
 * Nesting: the pbrt loader flattens an ObjectInstance inside ObjectBegin
 * into the object being defined, so the records are one level deep and
 * a nested object is one bottom-level tree.
 */
#include "inst.h"
#include "accel.h"
#include "rt_assert.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#define RT_INST_LEAF 4
#define RT_INST_PAD 1e-4f

static int box_has_tri(const rt_bvh2_node *n, const rt_tri *t, float slack) {
    for (int c = 0; c < 3; c++) {
        const float *p = &t->p[c].x;
        for (int a = 0; a < 3; a++)
            if (p[a] < n->lo[a] - slack || p[a] > n->hi[a] + slack)
                return 0;
    }
    return 1;
}

/* ---- building -------------------------------------------------------------- */

typedef struct bitem {
    float lo[3], hi[3], c[3];
    uint32_t id;
} bitem;

/* Orders items by centroid on one axis, ties by id (a total order: the
 * build is deterministic); one comparator per axis, no shared state, so
 * builds may run in parallel threads. */
static int cmp_on(const bitem *x, const bitem *y, int axis) {
    float u = x->c[axis], v = y->c[axis];
    if (u < v)
        return -1;
    if (u > v)
        return 1;
    return x->id < y->id ? -1 : x->id > y->id;
}
static int cmp_x(const void *a, const void *b) { return cmp_on(a, b, 0); }
static int cmp_y(const void *a, const void *b) { return cmp_on(a, b, 1); }
static int cmp_z(const void *a, const void *b) { return cmp_on(a, b, 2); }

typedef struct builder {
    rt_bvh2_node *node;
    uint32_t n, cap;
    uint32_t *order; /* leaf order: item ids */
    uint32_t norder;
    rt_err *e;
} builder;

/* Median split on the widest centroid axis; depth-first node order. */
static int build_rec(builder *B, bitem *it, uint32_t n, int depth) {
    if (B->n == B->cap) {
        uint32_t nc = B->cap ? 2 * B->cap : 64;
        rt_bvh2_node *nn = rt_reallocarray(B->node, nc, sizeof *nn, B->e);
        if (!nn)
            return -1;
        B->node = nn;
        B->cap = nc;
    }
    uint32_t me = B->n++;
    rt_bvh2_node nd;
    memset(&nd, 0, sizeof nd);
    float clo[3], chi[3];
    for (int a = 0; a < 3; a++)
        nd.lo[a] = clo[a] = INFINITY, nd.hi[a] = chi[a] = -INFINITY;
    for (uint32_t i = 0; i < n; i++)
        for (int a = 0; a < 3; a++) {
            nd.lo[a] = fminf(nd.lo[a], it[i].lo[a]);
            nd.hi[a] = fmaxf(nd.hi[a], it[i].hi[a]);
            clo[a] = fminf(clo[a], it[i].c[a]);
            chi[a] = fmaxf(chi[a], it[i].c[a]);
        }
    if (n <= RT_INST_LEAF || depth >= RT_BVH_MAX_DEPTH - 1) {
        nd.offset = B->norder;
        nd.ntri = (uint16_t)n;
        for (uint32_t i = 0; i < n; i++)
            B->order[B->norder++] = it[i].id;
        B->node[me] = nd;
        return 0;
    }
    int ax = 0;
    for (int a = 1; a < 3; a++)
        if (chi[a] - clo[a] > chi[ax] - clo[ax])
            ax = a;
    qsort(it, n, sizeof *it, ax == 0 ? cmp_x : ax == 1 ? cmp_y : cmp_z);
    uint32_t h = n / 2;
    nd.axis = (uint8_t)ax;
    if (build_rec(B, it, h, depth + 1) < 0)
        return -1;
    nd.offset = B->n;
    if (build_rec(B, it + h, n - h, depth + 1) < 0)
        return -1;
    B->node[me] = nd;
    return 0;
}

static void tri_item(bitem *b, const rt_tri *t, uint32_t id, float pad) {
    for (int a = 0; a < 3; a++) {
        float x = (&t->p[0].x)[a], y = (&t->p[1].x)[a], z = (&t->p[2].x)[a];
        float lo = fminf(x, fminf(y, z)), hi = fmaxf(x, fmaxf(y, z));
        float s = pad * (hi - lo + fabsf(lo) + fabsf(hi));
        b->lo[a] = lo - s;
        b->hi[a] = hi + s;
        b->c[a] = 0.5f * (lo + hi);
    }
    b->id = id;
}

/* One bottom-level tree over tris[0..n) into the shared arrays. */
static int build_blas(rt_inst *I, const rt_tri *tris, uint32_t n, rt_inst_blas *bl, rt_err *e) {
    bitem *it = rt_reallocarray(NULL, n ? n : 1, sizeof *it, e);
    builder B = {0};
    B.e = e;
    B.order = rt_reallocarray(NULL, n ? n : 1, sizeof *B.order, e);
    if (!it || !B.order)
        goto fail;
    for (uint32_t i = 0; i < n; i++)
        tri_item(&it[i], &tris[i], i, RT_INST_PAD);
    if (build_rec(&B, it, n, 0) < 0)
        goto fail;
    /* append */
    rt_bvh2_node *nn = rt_reallocarray(I->bnode, (size_t)I->nbnode + B.n, sizeof *nn, e);
    if (!nn)
        goto fail;
    I->bnode = nn;
    rt_tri *nt = rt_reallocarray(I->btri, (size_t)I->nbtri + n + 1, sizeof *nt, e);
    if (!nt)
        goto fail;
    I->btri = nt;
    uint32_t *nr = rt_reallocarray(I->bref, (size_t)I->nbtri + n + 1, sizeof *nr, e);
    if (!nr)
        goto fail;
    I->bref = nr;
    bl->node0 = I->nbnode;
    bl->nnode = B.n;
    bl->tri0 = I->nbtri;
    bl->ntri = n;
    for (uint32_t k = 0; k < B.n; k++) {
        rt_bvh2_node d = B.node[k];
        if (d.ntri)
            d.offset += bl->tri0; /* leaves: global record index */
        else
            d.offset += bl->node0; /* interior: global node index */
        I->bnode[I->nbnode + k] = d;
    }
    for (uint32_t k = 0; k < n; k++) {
        I->btri[I->nbtri + k] = tris[B.order[k]];
        I->bref[I->nbtri + k] = B.order[k];
    }
    I->nbnode += B.n;
    I->nbtri += n;
    free(it);
    free(B.node);
    free(B.order);
    return 0;
fail:
    free(it);
    free(B.node);
    free(B.order);
    return -1;
}

static int invert3x4(const double m[3][4], double r[3][4]) {
    double a = m[0][0], b = m[0][1], c = m[0][2], d = m[1][0], e = m[1][1], f = m[1][2], g = m[2][0], h = m[2][1],
           k = m[2][2];
    double det = a * (e * k - f * h) - b * (d * k - f * g) + c * (d * h - e * g);
    if (!(fabs(det) > 1e-300) || !isfinite(det))
        return -1;
    double inv[3][3] = {{(e * k - f * h) / det, (c * h - b * k) / det, (b * f - c * e) / det},
                        {(f * g - d * k) / det, (a * k - c * g) / det, (c * d - a * f) / det},
                        {(d * h - e * g) / det, (b * g - a * h) / det, (a * e - b * d) / det}};
    for (int i = 0; i < 3; i++) {
        for (int j = 0; j < 3; j++)
            r[i][j] = inv[i][j];
        r[i][3] = -(inv[i][0] * m[0][3] + inv[i][1] * m[1][3] + inv[i][2] * m[2][3]);
    }
    return 0;
}

void rt_inst_free(rt_inst *I) {
    if (!I)
        return;
    free(I->tnode);
    free(I->torder);
    free(I->inst);
    free(I->blas);
    free(I->bnode);
    free(I->btri);
    free(I->bref);
    free(I->covered);
    free(I);
}

rt_inst *rt_inst_build(const rt_scene *sc, rt_err *e) {
    rt_inst *I = rt_calloc(1, sizeof *I, e);
    if (!I)
        return NULL;
    uint8_t *cov = rt_calloc(sc->ntri ? sc->ntri : 1, 1, e);
    rt_tri *loose = NULL;
    bitem *it = NULL;
    rt_bounds *rbox = NULL; /* the records' exact world boxes */
    if (!cov)
        goto fail;
    for (uint32_t i = 0; i < sc->nirec && !sc->kept; i++) {
        const rt_scene_inst *q = &sc->irec[i];
        if (q->obj >= sc->nobj) {
            rt_errf(e, "instance %u: object %u of %u", i, q->obj, sc->nobj);
            goto fail;
        }
        const rt_scene_obj *o = &sc->obj[q->obj];
        if ((uint64_t)q->first + o->count > sc->ntri) {
            rt_errf(e, "instance %u: triangles beyond the scene", i);
            goto fail;
        }
        for (uint32_t j = 0; j < o->count; j++)
            cov[q->first + j] = 1;
    }
    uint32_t nloose = 0;
    for (uint32_t i = 0; i < sc->ntri; i++)
        nloose += !cov[i];
    if (!(loose = rt_reallocarray(NULL, nloose ? nloose : 1, sizeof *loose, e)))
        goto fail;
    if (!(I->covered = rt_reallocarray(NULL, nloose ? nloose : 1, sizeof *I->covered, e)))
        goto fail;
    for (uint32_t i = 0, k = 0; i < sc->ntri; i++)
        if (!cov[i])
            I->covered[k] = i, loose[k++] = sc->tri[i];
    if (sc->kept) { /* every stored triangle is loose: its index in the flattened numbering */
        uint32_t r = 0;
        uint64_t inst = 0; /* the records' triangles before loose triangle k */
        for (uint32_t k = 0; k < nloose; k++) {
            while (r < sc->nirec && sc->irec[r].loose <= k)
                inst += sc->obj[sc->irec[r++].obj].count;
            I->covered[k] = (uint32_t)(k + inst);
        }
    }
    I->nloose = nloose;
    /* bottom level: the loose tree (index nobj), then each object once */
    I->nblas = sc->nobj + 1;
    if (!(I->blas = rt_calloc(I->nblas, sizeof *I->blas, e)))
        goto fail;
    for (uint32_t i = 0; i < sc->nirec; i++) /* the objects some record names (checked above) */
        I->blas[sc->irec[i].obj].used = 1;
    for (uint32_t k = 0; k < sc->nobj; k++) {
        if (!I->blas[k].used)
            continue;
        const rt_scene_obj *o = &sc->obj[k];
        if ((uint64_t)o->start + o->count > sc->notri) {
            rt_errf(e, "object %u: triangles beyond the object store", k);
            goto fail;
        }
        if (build_blas(I, sc->otri + o->start, o->count, &I->blas[k], e) < 0)
            goto fail;
        I->blas[k].used = 1;
    }
    if (nloose) {
        if (build_blas(I, loose, nloose, &I->blas[sc->nobj], e) < 0)
            goto fail;
        I->blas[sc->nobj].used = 1;
    }
    /* instances: the loose one first (identity), then the records in order */
    I->ninst = sc->nirec + (nloose ? 1 : 0);
    if (!(I->inst = rt_calloc(I->ninst ? I->ninst : 1, sizeof *I->inst, e)))
        goto fail;
    if (!(it = rt_reallocarray(NULL, I->ninst ? I->ninst : 1, sizeof *it, e)))
        goto fail;
    if (!(rbox = rt_calloc(sc->nirec ? sc->nirec : 1, sizeof *rbox, e)) || rt_scene_inst_boxes(sc, rbox, e) < 0)
        goto fail;
    for (uint32_t i = 0; i < I->ninst; i++) {
        rt_inst_rec *r = &I->inst[i];
        if (nloose && i == 0) {
            r->identity = 1;
            r->blas = sc->nobj;
            r->first = 0;
            for (int a = 0; a < 3; a++)
                for (int b = 0; b < 4; b++)
                    r->w2o[a][b] = r->o2w[a][b] = a == b;
        } else {
            const rt_scene_inst *q = &sc->irec[i - (nloose ? 1 : 0)];
            r->blas = q->obj;
            r->first = q->first;
            memcpy(r->o2w, q->m, sizeof r->o2w);
            if (invert3x4(q->m, r->w2o) < 0) {
                rt_errf(e, "instance %u: singular transformation", i);
                goto fail;
            }
        }
        /* world box: an instance's, the exact box of its triangles (the
         * flattened copy's, kept or not: rt_scene_inst_boxes) padded once;
         * the loose tree's, its triangles' padded boxes */
        for (int a = 0; a < 3; a++)
            it[i].lo[a] = INFINITY, it[i].hi[a] = -INFINITY;
        if (!r->identity) { /* the exact box of its triangles, padded once */
            const rt_bounds *x = &rbox[i - (nloose ? 1 : 0)];
            const float lo[3] = {x->lo.x, x->lo.y, x->lo.z}, hi[3] = {x->hi.x, x->hi.y, x->hi.z};
            for (int a = 0; a < 3; a++) {
                float pad = RT_INST_PAD * (hi[a] - lo[a] + fabsf(lo[a]) + fabsf(hi[a]));
                it[i].lo[a] = lo[a] - pad;
                it[i].hi[a] = hi[a] + pad;
            }
        } else {
            for (uint32_t k = 0; k < nloose; k++) {
                bitem t;
                tri_item(&t, &loose[k], 0, RT_INST_PAD);
                for (int a = 0; a < 3; a++)
                    it[i].lo[a] = fminf(it[i].lo[a], t.lo[a]), it[i].hi[a] = fmaxf(it[i].hi[a], t.hi[a]);
            }
        }
        for (int a = 0; a < 3; a++)
            it[i].c[a] = 0.5f * (it[i].lo[a] + it[i].hi[a]);
        it[i].id = i;
    }
    builder B = {0};
    B.e = e;
    if (!(B.order = rt_reallocarray(NULL, I->ninst ? I->ninst : 1, sizeof *B.order, e)))
        goto fail;
    if (I->ninst && build_rec(&B, it, I->ninst, 0) < 0) {
        free(B.node);
        free(B.order);
        goto fail;
    }
    I->tnode = B.node;
    I->ntnode = B.n;
    I->torder = B.order;
    free(it);
    free(rbox);
    free(loose);
    free(cov);
    return I;
fail:
    free(it);
    free(rbox);
    free(loose);
    free(cov);
    rt_inst_free(I);
    return NULL;
}

/* ---- walking ------------------------------------------------------------------ */

/* Slab test of a box against (o, inv) on [t0, t1]. */
static int slab(const float lo[3], const float hi[3], const float o[3], const float inv[3], float t0, float t1) {
    for (int a = 0; a < 3; a++) {
        float n = (lo[a] - o[a]) * inv[a], f = (hi[a] - o[a]) * inv[a];
        if (n != n)
            n = -INFINITY; /* 0 * inf: the origin on the plane */
        if (f != f)
            f = INFINITY;
        if (n > f) {
            float s = n;
            n = f;
            f = s;
        }
        if (n > t0)
            t0 = n;
        if (f < t1)
            t1 = f;
        if (t0 > t1)
            return 0;
    }
    return 1;
}

typedef struct walk {
    rt_trav *tv;
    const rt_inst *I;
    const rt_ray *r;
    rt_hit best;
    int any; /* occluded query */
    int found;
} walk;

#define REC_NODE(tv, reg, i, sz, cls)                                                                                  \
    do {                                                                                                               \
        if ((tv)->rec && (reg) >= 0)                                                                                   \
            RT_REC((tv)->rec, rt_mm_addr((tv)->L, (reg), (i)), (sz), 0, (cls));                                        \
    } while (0)

/* Walks the bottom-level tree of instance k with the ray in object space. */
static void walk_blas(walk *W, uint32_t k) {
    rt_trav *tv = W->tv;
    const rt_inst *I = W->I;
    const rt_inst_rec *q = &I->inst[k];
    const rt_inst_blas *bl = &I->blas[q->blas];
    const rt_ray *r = W->r;
    tv->nodes++; /* entering an instance is a step of the walk: its record is read */
    REC_NODE(tv, tv->reg_inst, k, RT_INST_RECSIZE, RT_CLS_INST);
    float o[3], d[3], inv[3];
    const float wo[3] = {r->o.x, r->o.y, r->o.z}, wd[3] = {r->d.x, r->d.y, r->d.z};
    if (q->identity) {
        memcpy(o, wo, sizeof o);
        memcpy(d, wd, sizeof d);
    } else {
        tv->xforms++;
        for (int a = 0; a < 3; a++) {
            o[a] = (float)(q->w2o[a][0] * wo[0] + q->w2o[a][1] * wo[1] + q->w2o[a][2] * wo[2] + q->w2o[a][3]);
            d[a] = (float)(q->w2o[a][0] * wd[0] + q->w2o[a][1] * wd[1] + q->w2o[a][2] * wd[2]);
        }
    }
    for (int a = 0; a < 3; a++)
        inv[a] = 1.0f / d[a];
    uint32_t stack[RT_BVH_MAX_DEPTH + 2];
    int sp = 0;
    uint32_t cur = bl->node0;
    for (;;) {
        const rt_bvh2_node *n = &I->bnode[cur];
        tv->nodes++;
        REC_NODE(tv, tv->reg_node, cur, 32, RT_CLS_NODE);
        float t1 = W->best.t;
        t1 = t1 * (1.0f + 1e-3f) + 1e-6f; /* widened: rounding of the transformed ray only visits more */
        if (slab(n->lo, n->hi, o, inv, -1e-6f - fabsf(r->tmin) * 1e-3f + r->tmin, t1)) {
            if (n->ntri) {
                for (uint32_t j = n->offset; j < n->offset + n->ntri; j++) {
                    uint32_t tri = q->identity ? I->covered[I->bref[j]] : q->first + I->bref[j];
                    const rt_scene *sc = tv->sc;
                    const rt_tri *T;
                    rt_tri wt;
                    /* the mark goes to the model's shading slot (rt_scene_model_slot) */
                    const uint32_t slot = q->identity ? I->bref[j] : I->nloose + sc->obj[q->blas].start + I->bref[j];
                    if (!sc->kept)
                        T = &sc->tri[tri];
                    else if (q->identity)
                        T = &sc->tri[I->bref[j]];
                    else {
                        rt_scene_inst_tri(q->o2w, &I->btri[j], &wt);
                        T = &wt;
                    }
                    tv->tests++;
                    if (tv->mark)
                        tv->mark[slot] |= tv->mark_bit;
                    if (tv->rec && tv->reg_tri >= 0)
                        RT_REC(tv->rec, rt_mm_addr(tv->L, tv->reg_tri, j), 36, 0, RT_CLS_TRI);
                    float t, u, v;
                    if (!rt_isect_core(r, T, &t, &u, &v) || !(t > r->tmin))
                        continue;
                    if (W->any) {
                        if (t < r->tmax && !rt_alpha_cut(tv->sc->alpha, &tv->alpha, tv->rec, r, tri, u, v)) {
                            W->found = 1;
                            return;
                        }
                        continue;
                    }
                    if (rt_hit_better(&W->best, t, tri) && t < r->tmax &&
                        !rt_alpha_cut(tv->sc->alpha, &tv->alpha, tv->rec, r, tri, u, v)) {
                        W->best.t = t, W->best.tri = tri, W->best.u = u, W->best.v = v;
                        W->found = 1;
                    }
                }
            } else {
                /* nearer child first by the split axis and the ray's sign */
                uint32_t first = cur + 1, second = n->offset;
                if (d[n->axis] < 0) {
                    uint32_t s = first;
                    first = second;
                    second = s;
                }
                stack[sp++] = second;
                cur = first;
                continue;
            }
        }
        if (!sp)
            return;
        cur = stack[--sp];
    }
}

static void walk_tlas(walk *W) {
    rt_trav *tv = W->tv;
    const rt_inst *I = W->I;
    const rt_ray *r = W->r;
    if (!I->ntnode)
        return;
    const float o[3] = {r->o.x, r->o.y, r->o.z}, inv[3] = {r->inv_d.x, r->inv_d.y, r->inv_d.z},
                d[3] = {r->d.x, r->d.y, r->d.z};
    uint32_t stack[RT_BVH_MAX_DEPTH + 2];
    int sp = 0;
    uint32_t cur = 0;
    for (;;) {
        const rt_bvh2_node *n = &I->tnode[cur];
        tv->nodes++;
        REC_NODE(tv, tv->reg_top, cur, 32, RT_CLS_TLAS);
        if (slab(n->lo, n->hi, o, inv, r->tmin - 1e-6f - fabsf(r->tmin) * 1e-3f, W->best.t * (1.0f + 1e-3f) + 1e-6f)) {
            if (n->ntri) {
                for (uint32_t j = n->offset; j < n->offset + n->ntri; j++) {
                    walk_blas(W, I->torder[j]);
                    if (W->any && W->found)
                        return;
                }
            } else {
                uint32_t first = cur + 1, second = n->offset;
                if (d[n->axis] < 0) {
                    uint32_t s = first;
                    first = second;
                    second = s;
                }
                stack[sp++] = second;
                cur = first;
                continue;
            }
        }
        if (!sp)
            return;
        cur = stack[--sp];
    }
}

int rt_inst_visit(rt_trav *tv, const rt_ray *r, uint32_t cur, rt_hit *best, int any, int *found, uint32_t kid[2]) {
    walk W = {.tv = tv, .I = tv->as, .r = r, .best = *best, .any = any};
    const rt_inst *I = W.I;
    const rt_bvh2_node *n = &I->tnode[cur];
    int k = 0;
    tv->nodes++;
    REC_NODE(tv, tv->reg_top, cur, 32, RT_CLS_TLAS);
    const float o[3] = {r->o.x, r->o.y, r->o.z}, inv[3] = {r->inv_d.x, r->inv_d.y, r->inv_d.z},
                d[3] = {r->d.x, r->d.y, r->d.z};
    if (slab(n->lo, n->hi, o, inv, r->tmin - 1e-6f - fabsf(r->tmin) * 1e-3f, W.best.t * (1.0f + 1e-3f) + 1e-6f)) {
        if (n->ntri) {
            for (uint32_t j = n->offset; j < n->offset + n->ntri; j++) {
                walk_blas(&W, I->torder[j]);
                if (W.any && W.found)
                    break;
            }
        } else {
            /* walk_tlas's order: the first child is walked next, the second stacked */
            kid[0] = cur + 1, kid[1] = n->offset;
            if (d[n->axis] < 0) {
                kid[0] = n->offset;
                kid[1] = cur + 1;
            }
            k = 2;
        }
    }
    *best = W.best;
    if (W.found)
        *found = 1;
    return k;
}

static int inst_closest(rt_trav *tv, const rt_ray *r, rt_hit *h) {
    walk W = {.tv = tv, .I = tv->as, .r = r};
    rt_hit_none(&W.best);
    W.best.t = r->tmax;
    walk_tlas(&W);
    if (!W.found) {
        rt_hit_none(h);
        return 0;
    }
    *h = W.best;
    return 1;
}

static int inst_occluded(rt_trav *tv, const rt_ray *r) {
    walk W = {.tv = tv, .I = tv->as, .r = r, .any = 1};
    rt_hit_none(&W.best);
    W.best.t = r->tmax;
    walk_tlas(&W);
    return W.found;
}

/* ---- packets (the packet tracer) -------------------------------------------------
 *
 * A packet walks both levels together, with the discipline of the packet
 * tracer's BVH walk (tracegen/packet.c): a node is visited when one of the
 * packet's rays still needs it, its record read once per packet visit and
 * counted once in tv->nodes; every ray present tests the node's box by
 * itself with the single-ray walk's widened interval above (its own best
 * hit bounding it), so each ray visits exactly the nodes whose box it
 * meets within its bound, and tests every triangle that could beat its
 * hit. Children go in the order of the packet's first ray present (its
 * direction's sign on the split axis; in the bottom level its object-space
 * direction). At a top-level leaf each instance is entered by the rays
 * whose walk reaches it: its 64-byte record is read once for the packet
 * (one node visit), each of those rays is transformed into object space
 * (tv->xforms counts rays, as the single walk does) and the packet walks
 * the shared bottom-level tree with them; a leaf's shared triangle
 * records are read once per packet visit and tested against every ray
 * present, on the world-space copies with the world rays (rt_isect_core),
 * so hits are the hit rule's (hit.h) bit for bit. In any-hit mode an
 * occluded ray leaves, and the walk stops when none is left.
 */
struct rt_inst_pk {
    const rt_inst *I;
    int np;
    uint16_t *lv;       /* per level np slots: the rays present */
    int nlv;            /* levels: 2 (RT_BVH_MAX_DEPTH + 2) */
    float (*oo)[3], (*od)[3], (*oinv)[3]; /* per slot: the ray in the current instance's object space */
    /* per call */
    rt_trav *tv;
    const rt_ray *ray;
    rt_hit *hit;
    uint8_t *done;
    int shadow;
    float *pnodes, *ptests;
};

rt_inst_pk *rt_inst_pk_new(const rt_inst *I, int np, rt_err *e) {
    rt_inst_pk *k = rt_calloc(1, sizeof *k, e);
    if (!k)
        return NULL;
    k->I = I;
    k->np = np;
    k->nlv = 2 * (RT_BVH_MAX_DEPTH + 2);
    k->lv = rt_calloc((size_t)k->nlv * np, sizeof *k->lv, e);
    k->oo = rt_calloc((size_t)np, sizeof *k->oo, e);
    k->od = rt_calloc((size_t)np, sizeof *k->od, e);
    k->oinv = rt_calloc((size_t)np, sizeof *k->oinv, e);
    if (!k->lv || !k->oo || !k->od || !k->oinv) {
        rt_inst_pk_free(k);
        return NULL;
    }
    return k;
}

void rt_inst_pk_free(rt_inst_pk *k) {
    if (!k)
        return;
    free(k->lv);
    free(k->oo);
    free(k->od);
    free(k->oinv);
    free(k);
}

/* The visit bound of slot i: its best hit so far (closest), else tmax. */
static inline float pk_bound(const rt_inst_pk *k, int i) {
    float t = !k->shadow && k->hit[i].tri != RT_NO_HIT ? k->hit[i].t : k->ray[i].tmax;
    return t * (1.0f + 1e-3f) + 1e-6f;
}

static inline float pk_lo(const rt_ray *r) { return r->tmin - 1e-6f - fabsf(r->tmin) * 1e-3f; }

/* Drops the occluded rays (any-hit) of the n slots at l; the rays left. */
static int pk_live(const rt_inst_pk *k, uint16_t *l, int n) {
    if (!k->shadow)
        return n;
    int m = 0;
    for (int j = 0; j < n; j++)
        if (!k->done[l[j]])
            l[m++] = l[j];
    return m;
}

/* Bottom-level node cur of instance q with the n rays at level d. */
static void pk_blas(rt_inst_pk *k, const rt_inst_rec *q, uint32_t cur, int d, int n) {
    rt_trav *tv = k->tv;
    const rt_inst *I = k->I;
    uint16_t *l = k->lv + (size_t)d * k->np;
    RT_ASSERT(d < k->nlv && n <= k->np);
    n = pk_live(k, l, n);
    if (!n)
        return;
    const rt_bvh2_node *nd = &I->bnode[cur];
    tv->nodes++;
    REC_NODE(tv, tv->reg_node, cur, 32, RT_CLS_NODE);
    int m = 0;
    for (int j = 0; j < n; j++) {
        const int i = l[j];
        if (k->pnodes)
            k->pnodes[i] += 1;
        if (slab(nd->lo, nd->hi, k->oo[i], k->oinv[i], pk_lo(&k->ray[i]), pk_bound(k, i)))
            l[m++] = (uint16_t)i;
    }
    n = m;
    if (!n)
        return;
    if (nd->ntri) {
        for (uint32_t j = nd->offset; j < nd->offset + nd->ntri && n > 0; j++) {
            /* the candidate, its mark and its record as in walk_blas */
            uint32_t tri = q->identity ? I->covered[I->bref[j]] : q->first + I->bref[j];
            const rt_scene *sc = tv->sc;
            const uint32_t slot = q->identity ? I->bref[j] : I->nloose + sc->obj[q->blas].start + I->bref[j];
            const rt_tri *T;
            rt_tri wt;
            if (!sc->kept)
                T = &sc->tri[tri];
            else if (q->identity)
                T = &sc->tri[I->bref[j]];
            else {
                rt_scene_inst_tri(q->o2w, &I->btri[j], &wt);
                T = &wt;
            }
            if (tv->mark)
                tv->mark[slot] |= tv->mark_bit;
            if (tv->rec && tv->reg_tri >= 0)
                RT_REC(tv->rec, rt_mm_addr(tv->L, tv->reg_tri, j), 36, 0, RT_CLS_TRI);
            for (int x = 0; x < n; x++) {
                const int i = l[x];
                const rt_ray *r = &k->ray[i];
                float t, u, v;
                tv->tests++;
                if (k->ptests)
                    k->ptests[i] += 1;
                if (!rt_isect_core(r, T, &t, &u, &v) || !(t > r->tmin && t < r->tmax))
                    continue;
                if (k->shadow) {
                    k->done[i] = 1;
                } else if (rt_hit_better(&k->hit[i], t, tri)) {
                    rt_hit *h = &k->hit[i];
                    h->t = t, h->tri = tri, h->u = u, h->v = v;
                }
            }
            n = pk_live(k, l, n);
        }
        return;
    }
    const int i0 = l[0];
    const uint32_t c[2] = {k->od[i0][nd->axis] < 0 ? nd->offset : cur + 1, k->od[i0][nd->axis] < 0 ? cur + 1 : nd->offset};
    uint16_t *nx = l + k->np;
    for (int ci = 0; ci < 2; ci++) {
        memcpy(nx, l, sizeof *l * (size_t)n);
        pk_blas(k, q, c[ci], d + 1, n);
    }
}

/* Instance e with the n rays at level d (their walk reached it). */
static void pk_enter(rt_inst_pk *k, uint32_t e, int d, int n) {
    rt_trav *tv = k->tv;
    const rt_inst_rec *q = &k->I->inst[e];
    uint16_t *l = k->lv + (size_t)d * k->np;
    n = pk_live(k, l, n);
    if (!n)
        return;
    tv->nodes++; /* the record: once for the packet */
    REC_NODE(tv, tv->reg_inst, e, RT_INST_RECSIZE, RT_CLS_INST);
    for (int j = 0; j < n; j++) {
        const int i = l[j];
        const rt_ray *r = &k->ray[i];
        const float wo[3] = {r->o.x, r->o.y, r->o.z}, wd[3] = {r->d.x, r->d.y, r->d.z};
        if (k->pnodes)
            k->pnodes[i] += 1;
        if (q->identity) {
            memcpy(k->oo[i], wo, sizeof wo);
            memcpy(k->od[i], wd, sizeof wd);
        } else {
            tv->xforms++;
            for (int a = 0; a < 3; a++) {
                k->oo[i][a] = (float)(q->w2o[a][0] * wo[0] + q->w2o[a][1] * wo[1] + q->w2o[a][2] * wo[2] + q->w2o[a][3]);
                k->od[i][a] = (float)(q->w2o[a][0] * wd[0] + q->w2o[a][1] * wd[1] + q->w2o[a][2] * wd[2]);
            }
        }
        for (int a = 0; a < 3; a++)
            k->oinv[i][a] = 1.0f / k->od[i][a];
    }
    uint16_t *nx = l + k->np;
    memcpy(nx, l, sizeof *l * (size_t)n);
    pk_blas(k, q, k->I->blas[q->blas].node0, d + 1, n);
}

/* Top-level node cur with the n rays at level d. */
static void pk_tlas(rt_inst_pk *k, uint32_t cur, int d, int n) {
    rt_trav *tv = k->tv;
    const rt_inst *I = k->I;
    uint16_t *l = k->lv + (size_t)d * k->np;
    RT_ASSERT(d < k->nlv && n <= k->np);
    n = pk_live(k, l, n);
    if (!n)
        return;
    const rt_bvh2_node *nd = &I->tnode[cur];
    tv->nodes++;
    REC_NODE(tv, tv->reg_top, cur, 32, RT_CLS_TLAS);
    int m = 0;
    for (int j = 0; j < n; j++) {
        const int i = l[j];
        const rt_ray *r = &k->ray[i];
        const float o[3] = {r->o.x, r->o.y, r->o.z}, inv[3] = {r->inv_d.x, r->inv_d.y, r->inv_d.z};
        if (k->pnodes)
            k->pnodes[i] += 1;
        if (slab(nd->lo, nd->hi, o, inv, pk_lo(r), pk_bound(k, i)))
            l[m++] = (uint16_t)i;
    }
    n = m;
    if (!n)
        return;
    uint16_t *nx = l + k->np;
    if (nd->ntri) {
        for (uint32_t j = nd->offset; j < nd->offset + nd->ntri && n > 0; j++) {
            memcpy(nx, l, sizeof *l * (size_t)n);
            pk_enter(k, I->torder[j], d + 1, n);
            n = pk_live(k, l, n);
        }
        return;
    }
    const rt_ray *r0 = &k->ray[l[0]];
    const float d0 = nd->axis == 0 ? r0->d.x : nd->axis == 1 ? r0->d.y : r0->d.z;
    const uint32_t c[2] = {d0 < 0 ? nd->offset : cur + 1, d0 < 0 ? cur + 1 : nd->offset};
    for (int ci = 0; ci < 2; ci++) {
        memcpy(nx, l, sizeof *l * (size_t)n);
        pk_tlas(k, c[ci], d + 1, n);
    }
}

void rt_inst_pk_trace(rt_inst_pk *k, rt_trav *tv, const rt_ray *ray, rt_hit *hit, uint8_t *done, int shadow,
                      float *pnodes, float *ptests, const uint16_t *idx, int n) {
    if (!k->I->ntnode || n <= 0)
        return;
    RT_ASSERT(n <= k->np);
    k->tv = tv;
    k->ray = ray;
    k->hit = hit;
    k->done = done;
    k->shadow = shadow;
    k->pnodes = pnodes;
    k->ptests = ptests;
    memcpy(k->lv, idx, sizeof *idx * (size_t)n);
    pk_tlas(k, 0, 0, n);
}

/* ---- checking -------------------------------------------------------------------- */

static int check_tree(const rt_bvh2_node *nd, uint32_t node0, uint32_t nnode, uint32_t rec0, uint32_t nrec,
                      uint8_t *seen, const char *what, rt_err *e) {
    /* (I3) depth-first: walk with a stack, every node reached once */
    uint32_t stack[RT_BVH_MAX_DEPTH + 2];
    int sp = 0;
    uint32_t cur = node0, visited = 0;
    for (;;) {
        const rt_bvh2_node *n = &nd[cur];
        visited++;
        if (n->ntri) {
            if (n->ntri > RT_INST_LEAF || n->offset < rec0 || (uint64_t)n->offset + n->ntri > (uint64_t)rec0 + nrec)
                return rt_errf(e, "inst: (I3) %s node %u: leaf range %u+%u outside its records", what, cur, n->offset,
                               n->ntri);
            for (uint32_t j = n->offset; j < n->offset + n->ntri; j++) {
                if (seen[j - rec0])
                    return rt_errf(e, "inst: (I3) %s record %u in two leaves", what, j);
                seen[j - rec0] = 1;
            }
        } else {
            if (n->axis > 2 || n->offset <= cur + 1 || n->offset >= node0 + nnode || cur + 1 >= node0 + nnode)
                return rt_errf(e, "inst: (I3) %s node %u: children %u, %u outside the tree", what, cur, cur + 1,
                               n->offset);
            const rt_bvh2_node *c[2] = {&nd[cur + 1], &nd[n->offset]};
            for (int k = 0; k < 2; k++)
                for (int a = 0; a < 3; a++)
                    if (c[k]->lo[a] < n->lo[a] || c[k]->hi[a] > n->hi[a])
                        return rt_errf(e, "inst: (I4) %s node %u: a child's box leaves its box", what, cur);
            if (sp >= RT_BVH_MAX_DEPTH + 1)
                return rt_errf(e, "inst: (I3) %s deeper than %d", what, RT_BVH_MAX_DEPTH);
            stack[sp++] = n->offset;
            cur = cur + 1;
            continue;
        }
        if (!sp)
            break;
        cur = stack[--sp];
    }
    if (visited != nnode)
        return rt_errf(e, "inst: (I3) %s: %u of %u nodes reached", what, visited, nnode);
    for (uint32_t j = 0; j < nrec; j++)
        if (!seen[j])
            return rt_errf(e, "inst: (I3) %s record %u in no leaf", what, rec0 + j);
    return 0;
}

int rt_inst_check(const rt_inst *I, const rt_scene *sc, rt_err *e) {
    int rc = -1;
    uint8_t *cov = rt_calloc(sc->ntri ? sc->ntri : 1, 1, e);
    uint8_t *seen = rt_calloc((size_t)I->nbtri + I->ninst + 1, 1, e);
    if (!cov || !seen || rt_scene_check_kept(sc, e) < 0)
        goto out;
    /* (I1) */
    for (uint32_t i = 0; i < I->ninst; i++) {
        const rt_inst_rec *q = &I->inst[i];
        if (q->blas >= I->nblas || !I->blas[q->blas].used) {
            rt_errf(e, "inst: (I1) instance %u: bottom-level structure %u does not exist", i, q->blas);
            goto out;
        }
        const rt_inst_blas *bl = &I->blas[q->blas];
        if (sc->kept && !q->identity) { /* (I1) by the records' arithmetic (rt_scene_check_kept), (I2) by construction */
            const rt_scene_inst *sq = &sc->irec[i - (I->nloose ? 1 : 0)];
            if (q->blas != sq->obj || q->first != sq->first || memcmp(q->o2w, sq->m, sizeof q->o2w)) {
                rt_errf(e, "inst: (I1) instance %u is not its scene record", i);
                goto out;
            }
        }
        for (uint32_t j = 0; j < bl->ntri && !(sc->kept && !q->identity); j++) {
            uint32_t tri = q->identity
                               ? (I->bref[bl->tri0 + j] < I->nloose ? I->covered[I->bref[bl->tri0 + j]] : UINT32_MAX)
                               : q->first + I->bref[bl->tri0 + j];
            if (sc->kept) { /* a loose triangle: its index maps back to its place in tri */
                uint32_t lj;
                if (tri >= sc->nflat || rt_scene_kept_find(sc, tri, &lj) >= 0 || lj != I->bref[bl->tri0 + j] ||
                    lj >= sc->ntri || cov[lj]) {
                    rt_errf(e, "inst: (I1) loose triangle %u: index %u is not its own or in two instances",
                            I->bref[bl->tri0 + j], tri);
                    goto out;
                }
                cov[lj] = 1;
                continue;
            }
            if (tri >= sc->ntri || cov[tri]) {
                rt_errf(e, "inst: (I1) instance %u: scene triangle %u outside the scene or in two instances", i, tri);
                goto out;
            }
            cov[tri] = 1;
            /* (I2) */
            const rt_tri *ot = &I->btri[bl->tri0 + j], *wt = &sc->tri[tri];
            for (int c = 0; c < 3; c++) {
                const float *p = &ot->p[c].x, *w = &wt->p[c].x;
                for (int a = 0; a < 3; a++) {
                    double x = q->o2w[a][0] * p[0] + q->o2w[a][1] * p[1] + q->o2w[a][2] * p[2] + q->o2w[a][3];
                    if (fabs(x - w[a]) > 1e-4 * (1 + fabs(x))) {
                        rt_errf(e, "inst: (I2) instance %u: triangle %u is not its object's triangle transformed", i,
                                tri);
                        goto out;
                    }
                }
            }
        }
        /* (I6) */
        for (int a = 0; a < 3; a++)
            for (int b = 0; b < 4; b++) {
                double s = (b == 3 ? q->w2o[a][3] : 0);
                for (int k = 0; k < 3; k++)
                    s += q->w2o[a][k] * q->o2w[k][b];
                if (fabs(s - (a == b)) > 1e-4 * (1 + fabs(q->o2w[a][b]))) {
                    rt_errf(e, "inst: (I6) instance %u: the matrices are not inverses", i);
                    goto out;
                }
            }
    }
    for (uint32_t i = 0; i < sc->ntri; i++)
        if (!cov[i]) {
            rt_errf(e, "inst: (I1) scene triangle %u in no instance", i);
            goto out;
        }
    /* (I3), (I4) per bottom-level tree */
    for (uint32_t k = 0; k < I->nblas; k++) {
        const rt_inst_blas *bl = &I->blas[k];
        if (!bl->used)
            continue;
        if ((uint64_t)bl->node0 + bl->nnode > I->nbnode || (uint64_t)bl->tri0 + bl->ntri > I->nbtri) {
            rt_errf(e, "inst: (I3) tree %u outside the shared arrays", k);
            goto out;
        }
        memset(seen, 0, (size_t)I->nbtri + 1);
        if (check_tree(I->bnode, bl->node0, bl->nnode, bl->tri0, bl->ntri, seen, "bottom-level", e) < 0)
            goto out;
        for (uint32_t j = 0; j < bl->ntri; j++) {
            if (I->bref[bl->tri0 + j] >= bl->ntri) {
                rt_errf(e, "inst: (I3) tree %u record %u: object triangle %u of %u", k, bl->tri0 + j,
                        I->bref[bl->tri0 + j], bl->ntri);
                goto out;
            }
        }
        for (uint32_t m = bl->node0; m < bl->node0 + bl->nnode; m++) {
            const rt_bvh2_node *n = &I->bnode[m];
            for (uint32_t j = n->offset; n->ntri && j < n->offset + n->ntri; j++)
                if (!box_has_tri(n, &I->btri[j], 0)) {
                    rt_errf(e, "inst: (I4) bottom-level node %u: triangle record %u outside its box", m, j);
                    goto out;
                }
        }
    }
    /* (I5) */
    if (I->ninst) {
        memset(seen, 0, (size_t)I->nbtri + I->ninst + 1);
        if (check_tree(I->tnode, 0, I->ntnode, 0, I->ninst, seen, "top-level", e) < 0)
            goto out;
        for (uint32_t m = 0; m < I->ntnode; m++) {
            const rt_bvh2_node *n = &I->tnode[m];
            for (uint32_t j = n->offset; n->ntri && j < n->offset + n->ntri; j++) {
                uint32_t k = I->torder[j];
                if (k >= I->ninst) {
                    rt_errf(e, "inst: (I5) top-level leaf entry %u: instance %u of %u", j, k, I->ninst);
                    goto out;
                }
                if (seen[I->nbtri + k]) {
                    rt_errf(e, "inst: (I5) instance %u in two top-level leaves", k);
                    goto out;
                }
                seen[I->nbtri + k] = 1;
                const rt_inst_rec *q = &I->inst[k];
                const rt_inst_blas *bl = &I->blas[q->blas];
                for (uint32_t t = 0; t < bl->ntri; t++) {
                    uint32_t tri = q->identity ? I->covered[I->bref[bl->tri0 + t]] : q->first + I->bref[bl->tri0 + t];
                    rt_tri wt;
                    const rt_tri *T = &wt;
                    if (!sc->kept)
                        T = &sc->tri[tri];
                    else if (q->identity)
                        T = &sc->tri[I->bref[bl->tri0 + t]];
                    else
                        rt_scene_inst_tri(q->o2w, &I->btri[bl->tri0 + t], &wt);
                    if (!box_has_tri(n, T, 0)) {
                        rt_errf(e, "inst: (I5) top-level node %u: instance %u's triangle %u outside its box", m, k,
                                tri);
                        goto out;
                    }
                }
            }
        }
    }
    rc = 0;
out:
    free(cov);
    free(seen);
    return rc;
}

/* ---- the accel layer's member ----------------------------------------------------- */

static void *inst_build(const rt_scene *sc, const rt_accel_params *p, rt_err *e) {
    (void)p;
    return rt_inst_build(sc, e);
}

static void inst_free(void *as) { rt_inst_free(as); }

static int inst_regions(const void *as, const rt_scene *sc, rt_layout *L, rt_err *e) {
    const rt_inst *I = as;
    (void)sc;
    if (rt_mm_add(L, "tlas.node", RT_CLS_TLAS, 32, I->ntnode ? I->ntnode : 1, e) < 0 ||
        rt_mm_add(L, "inst", RT_CLS_INST, RT_INST_RECSIZE, I->ninst ? I->ninst : 1, e) < 0 ||
        rt_mm_add(L, "blas.node", RT_CLS_NODE, 32, I->nbnode ? I->nbnode : 1, e) < 0 ||
        rt_mm_add(L, "blas.tri", RT_CLS_TRI, 36, I->nbtri ? I->nbtri : 1, e) < 0)
        return -1;
    return 0;
}

static void inst_trav_init(rt_trav *tv, const void *as, const rt_layout *L) {
    tv->as = as;
    tv->width = 2;
    if (!L)
        return; /* not recording */
    tv->reg_top = rt_mm_find(L, "tlas.node");
    tv->reg_inst = rt_mm_find(L, "inst");
    tv->reg_node = rt_mm_find(L, "blas.node");
    tv->reg_tri = rt_mm_find(L, "blas.tri");
}

static int inst_check_as(const void *as, const rt_scene *sc, rt_err *e) { return rt_inst_check(as, sc, e); }

static void inst_info(const void *as, rt_accel_info *inf) {
    const rt_inst *I = as;
    inf->nodes = (uint64_t)I->ntnode + I->nbnode;
    inf->bytes = 32 * inf->nodes + (uint64_t)RT_INST_RECSIZE * I->ninst;
    inf->depth = 0;
}

const rt_accel_ops rt_accel_inst = {
    .name = "inst",
    .desc = "two-level BVH: a top-level BVH over instances, one shared BVH per object (--instances bvh)",
    .flags = RT_ACCEL_OWN_TRIS,
    .build = inst_build,
    .free = inst_free,
    .regions = inst_regions,
    .trav_init = inst_trav_init,
    .closest = inst_closest,
    .occluded = inst_occluded,
    .check = inst_check_as,
    .info = inst_info,
};
