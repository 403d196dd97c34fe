/* mesh.c -- the pbrt-style mesh layout: vertex index and translating
 * recorder (see mesh.h). */
#include "mesh.h"

#include <math.h>
#include <stdlib.h>

/* ---- vertex index ----------------------------------------------------------- */

typedef struct corner {
    float x, y, z; /* position */
    uint32_t c;    /* corner id 3t + k */
} corner;

static int has_nan(const corner *a) { return isnan(a->x) || isnan(a->y) || isnan(a->z); }

/* A total order: positions by (x, y, z) float comparison (so -0 sits with
 * +0), then corner id; corners with a NaN coordinate after all others. */
static int corner_cmp(const void *pa, const void *pb)
{
    const corner *a = pa, *b = pb;
    int na = has_nan(a), nb = has_nan(b);
    if (na != nb) return na - nb;
    if (!na) {
        if (a->x != b->x) return a->x < b->x ? -1 : 1;
        if (a->y != b->y) return a->y < b->y ? -1 : 1;
        if (a->z != b->z) return a->z < b->z ? -1 : 1;
    }
    return a->c < b->c ? -1 : a->c > b->c;
}

static int same_pos(const corner *a, const corner *b)
{
    return a->x == b->x && a->y == b->y && a->z == b->z; /* false for NaN */
}

rt_mesh *rt_mesh_build(const rt_scene *sc, rt_err *e)
{
    size_t n = (size_t)sc->ntri * 3;
    rt_mesh *m = rt_calloc(1, sizeof *m, e);
    corner *cs = NULL;
    uint32_t *rep = NULL;
    if (!m || !(m->vidx = rt_calloc(n ? n : 1, sizeof *m->vidx, e)) || !(cs = rt_calloc(n ? n : 1, sizeof *cs, e)) ||
        !(rep = rt_calloc(n ? n : 1, sizeof *rep, e))) {
        free(cs);
        free(rep);
        rt_mesh_free(m);
        return NULL;
    }
    m->ntri = sc->ntri;
    for (size_t i = 0; i < n; i++) {
        rt_vec3 p = sc->tri[i / 3].p[i % 3];
        cs[i] = (corner){p.x, p.y, p.z, (uint32_t)i};
    }
    qsort(cs, n, sizeof *cs, corner_cmp);
    /* rep[c]: the first corner (lowest id) with c's position */
    for (size_t i = 0; i < n; i++)
        rep[cs[i].c] = i > 0 && same_pos(&cs[i], &cs[i - 1]) ? rep[cs[i - 1].c] : cs[i].c;
    /* number the representatives in corner order: first use */
    uint32_t nv = 0;
    for (size_t c = 0; c < n; c++) m->vidx[c] = rep[c] == c ? nv++ : m->vidx[rep[c]];
    m->nvert = nv;
    free(cs);
    free(rep);
    return m;
}

void rt_mesh_free(rt_mesh *m)
{
    if (!m) return;
    free(m->vidx);
    free(m);
}

/* ---- translating recorder ---------------------------------------------------- */

typedef struct mrec {
    rt_sink sink;          /* what the inner recorder feeds */
    rt_rec *out;           /* the run's recorder */
    const rt_mesh *m;
    uint64_t vidx0, vidx1; /* tri.vidx [base, end) */
    uint64_t pos0;         /* mesh.pos base */
    uint64_t sh0, sh1;     /* tri.shade [base, end); empty without it */
    uint64_t nrm0;         /* mesh.normal base */
} mrec;

static uint64_t region_end(const rt_region *r) { return r->base + (uint64_t)r->recsize * r->count; }

static void emit(rt_rec *o, uint64_t addr, uint32_t size, int cls) { rt_rec_push(o, addr, size, 0, cls); }

/* The index record of triangle t, then one 12-byte record per vertex of
 * the array at base (positions or normals). */
static void expand(mrec *M, uint32_t t, uint64_t base, int cls)
{
    emit(M->out, M->vidx0 + (uint64_t)t * RT_MESH_VIDX_SIZE, RT_MESH_VIDX_SIZE, RT_CLS_TRI);
    for (int k = 0; k < 3; k++) emit(M->out, base + (uint64_t)M->m->vidx[3 * (size_t)t + k] * RT_MESH_POS_SIZE, 12, cls);
}

static int mrec_put(rt_sink *s, const rt_access *a, size_t n)
{
    mrec *M = s->ctx;
    rt_rec *o = M->out;
    for (size_t i = 0; i < n; i++) {
        const rt_access *x = &a[i];
        rt_rec_set_gen(o, x->gen);
        if (!x->write && x->cls == RT_CLS_TRI && x->size == 36 && x->addr >= M->vidx0 && x->addr < M->vidx1 &&
            (x->addr - M->vidx0) % RT_MESH_VIDX_SIZE == 0) {
            expand(M, (uint32_t)((x->addr - M->vidx0) / RT_MESH_VIDX_SIZE), M->pos0, RT_CLS_TRI);
            continue;
        }
        if (!x->write && x->cls == RT_CLS_SHADE && x->size == 16 && x->addr >= M->sh0 && x->addr < M->sh1 &&
            (x->addr - M->sh0) % 16 == 0)
            expand(M, (uint32_t)((x->addr - M->sh0) / 16), M->nrm0, RT_CLS_SHADE);
        rt_rec_push(o, x->addr, x->size, x->write, x->cls);
    }
    return o->failed ? -1 : 0;
}

rt_rec *rt_mesh_rec_new(const rt_mesh *m, const rt_layout *L, rt_rec *out, rt_err *e)
{
    int rv = rt_mm_find(L, "tri.vidx"), rp = rt_mm_find(L, "mesh.pos");
    int rs = rt_mm_find(L, "tri.shade"), rn = rt_mm_find(L, "mesh.normal");
    if (!m || rv < 0 || rp < 0 || (rs >= 0) != (rn >= 0)) {
        rt_errf(e, "mesh layout: the run's regions lack the mesh arrays (internal error)");
        return NULL;
    }
    mrec *M = rt_calloc(1, sizeof *M, e);
    if (!M) return NULL;
    M->sink.put = mrec_put;
    M->sink.ctx = M;
    M->out = out;
    M->m = m;
    M->vidx0 = L->r[rv].base;
    M->vidx1 = region_end(&L->r[rv]);
    M->pos0 = L->r[rp].base;
    if (rs >= 0) {
        M->sh0 = L->r[rs].base;
        M->sh1 = region_end(&L->r[rs]);
        M->nrm0 = L->r[rn].base;
    }
    rt_rec *r = rt_rec_new(&M->sink, e);
    if (!r) free(M);
    return r;
}

void rt_mesh_rec_free(rt_rec *r)
{
    if (!r) return;
    free(r->sink->ctx);
    rt_rec_free(r);
}
