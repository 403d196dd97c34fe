/* pbrtlayout.c -- the pbrt-v1 object layout: sizes, regions and the
 * translating recorder (see pbrtlayout.h). */
#include "pbrtlayout.h"
#include "options.h"

#include <stdlib.h>

void rt_pbrt_sizes_get(int geom, rt_pbrt_sizes *z)
{
    if (geom == RT_GEOM_PBRT64) {
        /* LP64: 8-byte pointers, int 4, objects aligned to 8, glibc chunks
         * of 16 bytes with an 8-byte size word */
        *z = (rt_pbrt_sizes){.ptr = 8,
                             .mbox = 16,       /* primitive 0..7, lastMailboxId 8..11, padding */
                             .mbox_id = 8,
                             .prim = 40,       /* vptr 0, nReferences 8, shape 16, material 24, areaLight 32 */
                             .prim_chunk = 48, /* (40 + 8 + 15) & ~15 */
                             .prim_read = 24,  /* vptr .. shape */
                             .shape = 72,      /* Shape 56 (vptr, count, 2 x 16 Transform, 2 flags), mesh 56, v 64 */
                             .shape_chunk = 80,
                             .shape_mesh = 56,
                             .mesh = 104, /* Shape 56, ntris, nverts, vertexIndex 64, p 72, n 80, s 88, uvs 96 */
                             .mesh_p = 72,
                             .arena_block = 32768};
        return;
    }
    /* ILP32: 4-byte pointers, glibc chunks of 8 bytes with a 4-byte size word */
    *z = (rt_pbrt_sizes){.ptr = 4,
                         .mbox = 8,        /* primitive 0..3, lastMailboxId 4..7 */
                         .mbox_id = 4,
                         .prim = 20,       /* vptr 0, nReferences 4, shape 8, material 12, areaLight 16 */
                         .prim_chunk = 24, /* (20 + 4 + 7) & ~7 */
                         .prim_read = 12,  /* vptr .. shape */
                         .shape = 36,      /* Shape 28 (vptr, count, 2 x 8 Transform, 2 flags + 2), mesh 28, v 32 */
                         .shape_chunk = 40,
                         .shape_mesh = 28,
                         .mesh = 56, /* Shape 28, ntris 28, nverts 32, vertexIndex 36, p 40, n 44, s 48, uvs 52 */
                         .mesh_p = 40,
                         .arena_block = 32768};
}

/* Walks the leaves of kd in node order as KdTreeAccel::buildTree creates
 * them, allocating each list of n > 1 pointers from the MemoryArena
 * (MemoryArena::Alloc: rounded up to 8 bytes; a request that does not fit
 * the current block starts a new block of max(request, 32768) bytes, the
 * blocks modeled one after another). When off is not NULL, off[e] is set
 * to the byte offset of index entry e's pointer (UINT32_MAX for entries of
 * one-primitive leaves). Returns the bytes of all blocks. */
static uint64_t arena_walk(const rt_kdtree *kd, const rt_pbrt_sizes *z, uint32_t *off)
{
    uint64_t base = 0, blk = z->arena_block, pos = 0;
    if (off)
        for (uint32_t e = 0; e < kd->nidx; e++) off[e] = UINT32_MAX;
    for (uint32_t i = 0; i < kd->nnodes; i++) {
        const rt_kdnode *nd = &kd->nodes[i];
        if (!rt_kd_is_leaf(nd)) continue;
        uint32_t n = rt_kd_ntri(nd), first = rt_kd_first(nd);
        if (n < 2) continue;
        uint64_t sz = ((uint64_t)n * z->ptr + 7) & ~(uint64_t)7;
        if (pos + sz > blk) {
            base += blk;
            blk = sz > z->arena_block ? sz : z->arena_block;
            pos = 0;
        }
        if (off && off[first] == UINT32_MAX && base + pos + sz <= UINT32_MAX)
            for (uint32_t k = 0; k < n; k++) off[first + k] = (uint32_t)(base + pos + (uint64_t)k * z->ptr);
        pos += sz;
    }
    return base + blk;
}

uint64_t rt_pbrt_plist_bytes(const rt_kdtree *kd, int geom)
{
    rt_pbrt_sizes z;
    rt_pbrt_sizes_get(geom, &z);
    return arena_walk(kd, &z, NULL);
}

int rt_pbrt_regions(rt_layout *L, const rt_kdtree *kd, uint32_t ntri, int geom, rt_err *e)
{
    rt_pbrt_sizes z;
    rt_pbrt_sizes_get(geom, &z);
    if (rt_mm_add(L, "pbrt.plist", RT_CLS_INDEX, 8, rt_pbrt_plist_bytes(kd, geom) / 8, e) < 0 ||
        rt_mm_add(L, "pbrt.mbox", RT_CLS_TRI, z.mbox, ntri, e) < 0 ||
        rt_mm_add(L, "pbrt.prim", RT_CLS_TRI, z.prim_chunk, ntri, e) < 0 ||
        rt_mm_add(L, "pbrt.shape", RT_CLS_TRI, z.shape_chunk, ntri, e) < 0 ||
        rt_mm_add(L, "pbrt.mesh", RT_CLS_TRI, z.mesh, 1, e) < 0)
        return -1;
    return 0;
}

/* ---- translating recorder ---------------------------------------------------- */

typedef struct prec {
    rt_sink sink;           /* what the inner recorder feeds */
    rt_rec *out;            /* the run's recorder */
    const rt_mesh *m;
    rt_pbrt_sizes z;
    uint32_t ntri;
    uint32_t *off;          /* index entry -> byte offset in pbrt.plist (UINT32_MAX: in the node) */
    uint32_t *mbid;         /* lastMailboxId per triangle (0: never tested) */
    uint32_t rayid;         /* the current walk's id (>= 1) */
    const uint32_t *idx;    /* the tree's index lists */
    int in_leaf;            /* since the last kd.index read only triangle reads came */
    uint64_t cur, end;      /* the entries [cur, end) of that read not yet tested */
    uint64_t tests, skips;
    uint64_t node0;                 /* kd.nodes base (the root's record) */
    uint64_t idx0, idx1;            /* kd.index [base, end) */
    uint64_t vidx0, vidx1;          /* tri.vidx [base, end) */
    uint64_t pos0;                  /* mesh.pos base */
    uint64_t sh0, sh1;              /* tri.shade [base, end); empty without it */
    uint64_t nrm0;                  /* mesh.normal base */
    uint64_t pl0, mb0, pr0, tr0, me0; /* pbrt.plist, .mbox, .prim, .shape, .mesh bases */
} prec;

static uint64_t region_end(const rt_region *r) { return r->base + (uint64_t)r->recsize * r->count; }

static void rd(prec *P, uint64_t addr, uint32_t size) { rt_rec_push(P->out, addr, size, 0, RT_CLS_TRI); }

/* The three vertex indices of t, then one 12-byte record per vertex of the
 * array at base (positions or normals). */
static void vertices(prec *P, uint32_t t, uint64_t base, int cls)
{
    rt_rec_push(P->out, P->vidx0 + (uint64_t)t * RT_MESH_VIDX_SIZE, RT_MESH_VIDX_SIZE, 0, RT_CLS_TRI);
    for (int k = 0; k < 3; k++)
        rt_rec_push(P->out, base + (uint64_t)P->m->vidx[3 * (size_t)t + k] * RT_MESH_POS_SIZE, 12, 0, cls);
}

/* The Triangle's vtable pointer, its mesh and v, and the mesh's field at
 * mesh_off (1 or 2 pointers). */
static void shape(prec *P, uint32_t t, uint32_t mesh_off, uint32_t mesh_n, int cls)
{
    uint64_t s = P->tr0 + (uint64_t)t * P->z.shape_chunk;
    rt_rec_push(P->out, s, P->z.ptr, 0, cls);
    rt_rec_push(P->out, s + P->z.shape_mesh, 2 * P->z.ptr, 0, cls);
    rt_rec_push(P->out, P->me0 + mesh_off, mesh_n * P->z.ptr, 0, cls);
}

/* One test of triangle t in a leaf (KdTreeAccel::Intersect's leaf loop,
 * GeometricPrimitive::Intersect, Triangle::Intersect). */
static void test(prec *P, uint32_t t)
{
    const rt_pbrt_sizes *z = &P->z;
    uint64_t mb = P->mb0 + (uint64_t)(P->ntri - 1 - t) * z->mbox;
    P->tests++;
    if (P->mbid[t] == P->rayid) { /* already tested by this walk */
        P->skips++;
        rd(P, mb + z->mbox_id, 4);
        return;
    }
    P->mbid[t] = P->rayid;
    rd(P, mb, z->mbox_id + 4);                            /* lastMailboxId and the primitive reference */
    rt_rec_push(P->out, mb + z->mbox_id, 4, 1, RT_CLS_TRI); /* mp->lastMailboxId = rayId */
    rd(P, P->pr0 + (uint64_t)t * z->prim_chunk, z->prim_read); /* vtable pointer .. shape */
    shape(P, t, z->mesh_p, 1, RT_CLS_TRI);                /* vtable, mesh, v; mesh->p */
    vertices(P, t, P->pos0, RT_CLS_TRI);
}

static int prec_put(rt_sink *s, const rt_access *a, size_t n)
{
    prec *P = s->ctx;
    rt_rec *o = P->out;
    for (size_t i = 0; i < n; i++) {
        const rt_access *x = &a[i];
        rt_rec_set_gen(o, x->gen);
        if (!x->write) {
            if (x->cls == RT_CLS_QUEUE || (x->addr == P->node0 && x->cls == RT_CLS_NODE)) P->rayid++;
            if (x->addr >= P->idx0 && x->addr < P->idx1 && x->cls == RT_CLS_INDEX) {
                uint64_t e0 = (x->addr - P->idx0) / 4, k = x->size / 4;
                P->in_leaf = 1;
                P->cur = e0;
                P->end = e0 + k;
                if (P->off[e0] != UINT32_MAX)
                    rt_rec_push(o, P->pl0 + P->off[e0], (uint32_t)(k * P->z.ptr), 0, RT_CLS_INDEX);
                continue;
            }
            if (x->cls == RT_CLS_TRI && x->size == 36 && x->addr >= P->vidx0 && x->addr < P->vidx1 &&
                (x->addr - P->vidx0) % RT_MESH_VIDX_SIZE == 0) {
                uint32_t t = (uint32_t)((x->addr - P->vidx0) / RT_MESH_VIDX_SIZE);
                /* a test reads the next entries of the list in order; a
                 * triangle not among them is read for another reason */
                uint64_t j = P->cur;
                while (P->in_leaf && j < P->end && P->idx[j] != t) j++;
                if (P->in_leaf && j < P->end) {
                    P->cur = j + 1;
                    test(P, t);
                } else {
                    shape(P, t, P->z.mesh_p, 1, RT_CLS_TRI);
                    vertices(P, t, P->pos0, RT_CLS_TRI);
                }
                continue;
            }
            P->in_leaf = 0;
            if (x->cls == RT_CLS_SHADE && x->size == 16 && x->addr >= P->sh0 && x->addr < P->sh1 &&
                (x->addr - P->sh0) % 16 == 0) {
                uint32_t t = (uint32_t)((x->addr - P->sh0) / 16);
                rt_rec_push(o, P->pr0 + (uint64_t)t * P->z.prim_chunk, P->z.prim, 0, RT_CLS_SHADE);
                shape(P, t, P->z.mesh_p + P->z.ptr, 2, RT_CLS_SHADE); /* mesh->n, mesh->s */
                vertices(P, t, P->nrm0, RT_CLS_SHADE);
            }
        } else {
            P->in_leaf = 0;
        }
        rt_rec_push(o, x->addr, x->size, x->write, x->cls);
    }
    return o->failed ? -1 : 0;
}

rt_rec *rt_pbrt_rec_new(const rt_mesh *m, const rt_kdtree *kd, const rt_layout *L, int geom, rt_rec *out, rt_err *e)
{
    int rn = rt_mm_find(L, "kd.nodes"), ri = rt_mm_find(L, "kd.index"), rv = rt_mm_find(L, "tri.vidx");
    int rp = rt_mm_find(L, "mesh.pos"), rs = rt_mm_find(L, "tri.shade"), rnm = rt_mm_find(L, "mesh.normal");
    int rpl = rt_mm_find(L, "pbrt.plist"), rmb = rt_mm_find(L, "pbrt.mbox"), rpr = rt_mm_find(L, "pbrt.prim");
    int rtr = rt_mm_find(L, "pbrt.shape"), rme = rt_mm_find(L, "pbrt.mesh");
    if (!m || !kd || !rt_geom_is_pbrt(geom) || rn < 0 || ri < 0 || rv < 0 || rp < 0 || rpl < 0 || rmb < 0 ||
        rpr < 0 || rtr < 0 || rme < 0 || (rs >= 0) != (rnm >= 0)) {
        rt_errf(e, "pbrt layout: the run's regions lack the pbrt objects (internal error)");
        return NULL;
    }
    prec *P = rt_calloc(1, sizeof *P, e);
    if (!P) return NULL;
    P->off = rt_calloc(kd->nidx ? kd->nidx : 1, sizeof *P->off, e);
    P->mbid = rt_calloc(m->ntri ? m->ntri : 1, sizeof *P->mbid, e);
    if (!P->off || !P->mbid) {
        free(P->off);
        free(P->mbid);
        free(P);
        return NULL;
    }
    rt_pbrt_sizes_get(geom, &P->z);
    arena_walk(kd, &P->z, P->off);
    P->sink.put = prec_put;
    P->sink.ctx = P;
    P->out = out;
    P->m = m;
    P->ntri = m->ntri;
    P->rayid = 1;
    P->idx = kd->idx;
    P->node0 = L->r[rn].base;
    P->idx0 = L->r[ri].base;
    P->idx1 = region_end(&L->r[ri]);
    P->vidx0 = L->r[rv].base;
    P->vidx1 = region_end(&L->r[rv]);
    P->pos0 = L->r[rp].base;
    if (rs >= 0) {
        P->sh0 = L->r[rs].base;
        P->sh1 = region_end(&L->r[rs]);
        P->nrm0 = L->r[rnm].base;
    }
    P->pl0 = L->r[rpl].base;
    P->mb0 = L->r[rmb].base;
    P->pr0 = L->r[rpr].base;
    P->tr0 = L->r[rtr].base;
    P->me0 = L->r[rme].base;
    rt_rec *r = rt_rec_new(&P->sink, e);
    if (!r) {
        free(P->off);
        free(P->mbid);
        free(P);
    }
    return r;
}

void rt_pbrt_rec_counts(const rt_rec *r, uint64_t *tests, uint64_t *skips)
{
    const prec *P = r ? r->sink->ctx : NULL;
    *tests = P ? P->tests : 0;
    *skips = P ? P->skips : 0;
}

void rt_pbrt_rec_free(rt_rec *r)
{
    if (!r) return;
    prec *P = r->sink->ctx;
    free(P->off);
    free(P->mbid);
    free(P);
    rt_rec_free(r);
}
