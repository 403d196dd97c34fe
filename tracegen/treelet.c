/*
 * treelet.c -- treelet scheduling on a BVH (Aila and Karras, "Architecture
 * considerations for tracing incoherent rays", HPG 2010), beside the
 * k-d tree's dynamic scheduler (dynamic.c, Navrátil et al. 2007).
 *
 * The tree is cut into treelets, connected pieces of the BVH whose bytes
 * fit a budget derived from the cache size the run is scheduled for. Each
 * treelet has a ray queue. A ray walks the tree exactly as the single-ray
 * walk does (rt_bvh_closest: the same nodes in the same order, the same
 * stack), but only while the next node belongs to the treelet being
 * processed; when the node on top of its stack lies in another treelet the
 * ray is suspended and appended to that treelet's queue. Queues are
 * processed one at a time until all are empty, so a treelet's nodes are
 * read by many rays while they are in cache.
 *
 * Formation (the plan, once per job). Treelets grow greedily from a root:
 * the frontier starts as the root; repeatedly the frontier node of largest
 * surface area (the probability that a ray entering the treelet visits it;
 * ties: the lower node index) is taken into the treelet and its interior
 * children join the frontier, until the next node would take the treelet
 * past the budget (a treelet always takes its root, so a node larger than
 * the budget is a treelet of its own). The nodes left on the frontier
 * become the roots of further treelets, formed in the order they were
 * left (breadth first over treelets). A node's bytes are its modeled
 * record (32, 128 or 80 bytes) and, with --treelet-tris, the 36-byte
 * triangles of the leaves it holds (bvh2: the leaf node's own; wide trees:
 * its leaf children's). A node's area is its box's: bvh2 the node's own,
 * wide trees the slot box in its parent (the root: the scene's bounds).
 *
 * Budget. --gmax B gives it; otherwise it is half the scheduled cache size:
 * while a treelet is processed the cache also holds the lines of the ray
 * state, stack entries and queue entries streaming through it (each read
 * once per visit), and with LRU replacement a treelet as large as the
 * cache would be evicted by them before its rays are done; half the cache
 * keeps the treelet's working set and a window of streaming lines. A budget
 * smaller than one node is refused (usage error naming the option).
 *
 * Memory modeled (regions, class):
 *   tl.rays   (ray)    64 B per ray slot (one line): origin, direction,
 *                      tmin, best t, best triangle, barycentrics, stack
 *                      depth (48 B), then a 16-byte short stack holding the
 *                      ray's first stack entries. Written when a ray
 *                      starts (48 B and the root entry); read whole when
 *                      it is taken from a queue; when it is suspended,
 *                      the hit and depth (20 B at offset 28) and the
 *                      short-stack entries not yet in memory are written
 *                      in one access.
 *   tl.stack  (stream) the deeper stack entries, one area per slot of
 *                      stack_bound entries (bvh2: 4 B node index; wide: 8 B
 *                      reference and entry distance). The walk's stack
 *                      lives in registers while a ray is inside a treelet;
 *                      when it is suspended the entries without a valid
 *                      copy in memory are written (one access per
 *                      suspension for the deep ones); popping a deep entry
 *                      not in registers reads it with up to seven entries
 *                      below it (one access; a short-stack entry came with
 *                      the record), whose memory copies stay valid. So
 *                      an entry is written at most once per push; an entry
 *                      a refill brought back but the ray left unpopped is
 *                      read again by a later refill. Stack traffic is
 *                      recorded in class stream (the traffic class of ray
 *                      state that is not a ray record), so the database's
 *                      class list is unchanged; this tracer is its only
 *                      user on a BVH. The short stack travels with the
 *                      record and counts as ray traffic.
 *   tl.qtable (qtable) 8 B per treelet: one read-modify-write per enqueue
 *                      (the tail) and when the queue is taken (the reset),
 *                      each recorded as one write: with write-allocate
 *                      caches a read and a write of the same bytes move
 *                      the same lines as the write alone.
 *   tl.queues (queue)  chains of 64-entry blocks (256 B) of 4-byte ray
 *                      slot numbers from a pool with a LIFO free list: one
 *                      entry written per enqueue; the entries of a block
 *                      read in one access when the queue is processed;
 *                      a block returns to the pool once read.
 *   tl.hits   (hit)    24 B per slot: the closest hit, written when a ray
 *                      is shaded (only when a light is enabled) and read
 *                      by each shadow generation.
 *   tl.spawn  (ray)    whitted and path modes: 64-byte path records of the
 *                      rays waiting for their generation (as dynamic.c).
 *   rays.primary, fb   as the recursive tracer.
 * The geometry (the node region, bvh.tri, tri.shade) is the structure's, at
 * the addresses every tracer on it shares; a node is recorded once per
 * visit and a triangle once per test, as in the single-ray walk.
 *
 * Generations (as dynamic.c). Pixels are taken in rt_pixel_order in
 * windows of --ray-window rays (default all of the frame). Per window: the
 * closest-hit generation (every ray started at the root treelet, then the
 * queues until empty), then one shadow generation per enabled light (from
 * the hit toward the light; with a file's own lights, --light-samples, one
 * per light and sample). Whitted and path modes keep a stack of
 * batches (refracted rays one level, reflected and path rays another) and
 * shade each ray with rt_shade_step, summing contributions in an rt_acc,
 * so the order of rays does not change the image.
 *
 * Queues (the ray-queue core, rayq.c, shared with dynamic.c): one per
 * treelet, entries 4-byte ray slot numbers; the core's pool, buckets and
 * batch stack, this file's modeled addresses for them. Queue order
 * (--qorder): the fullest queue first (buckets by count), or tree order
 * (treelets by number, repeated until empty).
 *
 * Invariants, holding between steps (after a generation's rays have been
 * started and after every queue processed; in test mode, ctx->check,
 * check_plan verifies T1 once per run and check_state T2-T4 at every
 * step, and tests/test_treelet_check.c shows both rejecting corrupted
 * copies):
 *   T1  plan: every node lies in exactly one treelet; treelet 0 holds the
 *       root; a node's parent lies in the node's treelet unless the node
 *       is that treelet's root, and a node's root bit is set exactly when
 *       it is its treelet's root (so a walk in treelet t pushes a child
 *       with treelet t unless its root bit says to look it up); a
 *       treelet's bytes are the sum of its nodes' and at most the budget
 *       unless it is its root alone; the greedy rule stopped correctly:
 *       the frontier node of largest area would have taken the treelet
 *       past the budget;
 *   T2  queues, pool, buckets, batch stack: the ray-queue core's Q1-Q5
 *       (rayq.c, checked by rt_rq_check): a queue of c rays is a chain of
 *       ceil(c / 64) blocks ending at its tail; every block lies in exactly
 *       one queue's chain or on the free list; the counts sum to the rays
 *       queued; with fullest-first order every treelet is in the bucket of
 *       its count, none above the fullest bound (what was T5 here is Q4);
 *   T3  rays: every ray of the generation is in exactly one queue or
 *       finished (started = finished + queued), and a queued ray is in the
 *       queue of the treelet of the entry on top of its stack;
 *   T4  stacks: a queued ray's entries are all in memory and none in
 *       registers (reg = mem = depth), depth <= stack_bound; an entry's
 *       treelet is the treelet of its node (a leaf: of the node that
 *       pushed it);
 *   T6  resolution (checked as each ray finishes): its closest hit or its
 *       visibility is the one the single-ray walk finds;
 *   T7  simulated cores (ctx->cores, checked after every round): core k's
 *       count cq[k] is the sum of the counts of its treelets' queues
 *       (treelet t on core t mod N); a ray marked moving (mv: queued by
 *       another core than its treelet's) is queued, and the rays moved =
 *       moved rays read by the core they moved to + moved rays queued; the
 *       interleave's C1-C3 (cores.h: nothing buffered between rounds).
 * At the end of every generation: all queues empty, every wanted ray
 * finished exactly once.
 *
 * Simulated cores (--cores N, ctx->cores; cores.h): treelet t belongs to
 * core t mod N. A generation's rays are started, and later shaded, by the
 * cores in contiguous chunks of the slots; then rounds: every core with
 * rays queued in its treelets takes its next queue (the order's first
 * among its own), all at the round's start, the cores walk their rays in
 * turn (ray j of each core, then j + 1), a suspended ray goes to the queue
 * of its next treelet whoever owns it (moved when that is another core),
 * and a barrier ends the round. One core is rt_rq_run's order exactly.
 * The receiver's first references to a moved ray (its record, the deep
 * stack entries it refills in that visit) are counted as bytes_moved.
 *
 * Two-level instancing (--instances bvh, accel/inst.c; P->inst). The plan
 * cuts the top-level BVH (a bvh2 over instances, seen as P->top; with
 * --treelet-tris a leaf counts its 64-byte instance records) and a ray
 * walks it exactly as the single-ray walk does (rt_inst_visit: the same
 * top-level nodes in the same order). An instance leaf the ray reaches is
 * handled inside the treelet holding the leaf: rt_inst_visit reads the
 * instance's record (class inst), transforms the ray and walks the
 * object's shared tree to completion (classes node and tri, shared by all
 * instances), so a suspended ray carries only top-level stack entries and
 * never an instance. T1-T7 hold as stated over the top level (T4's node
 * is a top-level node; T6 compares with the two-level single walk). Marks
 * and shading reads go to the model's shading slots (rt_scene_model_slot).
 *
 * Images are bit-identical to the recursive tracer's on the same BVH: each
 * ray visits the same nodes and tests the same triangles in the same order
 * as rt_bvh_closest / rt_bvh_occluded, so it ends with the same hit.
 */
#include "bvh.h"
#include "camera.h"
#include "inst.h"
#include "cores.h"
#include "hit.h"
#include "rayq.h"
#include "regions.h"
#include "shade.h"
#include "stats.h"
#include "tracer.h"

#include <inttypes.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#if defined(__linux__)
#include <sys/mman.h>
#endif

#define QBLK RT_RQ_BLK  /* queue entries per block (64) */
#define RAY_REC 64     /* bytes of a ray-state record: one line */
#define RAY_STATE 48   /* ... of which the ray and its hit; then the short stack */
#define RAY_SUSP_OFS 28 /* the hit and stack depth: 20 bytes */
#define RAY_SUSP 20
#define SHORT_STACK 16 /* bytes of stack entries kept in the ray record */
#define REFILL 8       /* deep stack entries read back per access, at most */

/* Asks the kernel to back the whole 2 MiB pages inside [p, p + n) with huge
 * pages: one page fault per 2 MiB of host ray records instead of 512. The
 * caller writes the memory before it reads it, so each fault takes a fresh
 * huge page rather than first mapping the shared zero page and copying it
 * at the first write. A hint, without effect where it is not offered. */
static void hint_huge(void *p, size_t n)
{
#if defined(MADV_HUGEPAGE)
    const uintptr_t H = (uintptr_t)2 << 20;
    const uintptr_t lo = ((uintptr_t)p + H - 1) & ~(H - 1), hi = ((uintptr_t)p + n) & ~(H - 1);
    if (hi > lo) (void)madvise((void *)lo, hi - lo, MADV_HUGEPAGE);
#else
    (void)p;
    (void)n;
#endif
}

/* ---- the plan: treelets of one tree and budget ---------------------------- */

typedef struct tplan {
    int width;          /* 2, 4, 8 */
    uint64_t budget;    /* bytes per treelet */
    int tris;           /* leaves' triangles count */
    uint32_t nnodes;    /* nodes of the tree */
    uint32_t nt;        /* treelets (>= 1; 1 for an empty tree) */
    uint32_t *tl;       /* treelet of each node */
    uint32_t *parent;   /* parent node (UINT32_MAX: the root) */
    float *area;        /* surface area per node */
    uint32_t *cost;     /* bytes per node */
    uint32_t *troot;    /* root node per treelet */
    uint64_t *rootbit;  /* bit i: node i is its treelet's root (the walk looks up tl[] only for those) */
    uint64_t *tbytes;   /* bytes per treelet */
    uint32_t *tdepth;   /* treelets on the path from the root, the treelet's own included */
    uint32_t maxdepth;  /* deepest tdepth */
    uint64_t bytes_max; /* largest treelet */
    const rt_inst *inst; /* the two-level structure (--instances bvh): the plan cuts its top level */
    rt_bvh top;          /* ... seen as a bvh2 (nodes borrowed from inst->tnode); unused otherwise */
} tplan;

static void tl_plan_free(void *p)
{
    tplan *P = p;
    if (!P) return;
    free(P->tl);
    free(P->parent);
    free(P->area);
    free(P->cost);
    free(P->troot);
    free(P->rootbit);
    free(P->tbytes);
    free(P->tdepth);
    free(P);
}

static float box_area(float lx, float ly, float lz, float hx, float hy, float hz)
{
    float dx = hx - lx, dy = hy - ly, dz = hz - lz;
    if (!(dx >= 0) || !(dy >= 0) || !(dz >= 0)) return 0.0f;
    return 2.0f * (dx * dy + dy * dz + dz * dx);
}

/* The interior children of node i (nodes), and the triangles of its leaves. */
static int children(const rt_bvh *b, uint32_t i, uint32_t kid[8], float karea[8], uint32_t *ntri)
{
    int k = 0;
    *ntri = 0;
    if (b->width == 2) {
        const rt_bvh2_node *n = &b->n2[i];
        if (n->ntri) {
            *ntri = n->ntri;
            return 0;
        }
        const uint32_t c[2] = {i + 1, n->offset};
        for (int j = 0; j < 2; j++) {
            const rt_bvh2_node *m = &b->n2[c[j]];
            kid[k] = c[j];
            karea[k++] = box_area(m->lo[0], m->lo[1], m->lo[2], m->hi[0], m->hi[1], m->hi[2]);
        }
        return k;
    }
    for (int s = 0; s < b->width; s++) {
        uint32_t ref, cnt;
        const float *lo, *hi;
        int W = b->width;
        if (!rt_bvh_wide_child(W, b->n4, b->h8, i, s, &ref, &cnt)) continue;
        if (W == 4) {
            lo = &b->n4[i].lo[0][0];
            hi = &b->n4[i].hi[0][0];
        } else {
            lo = &b->h8[i].lo[0][0];
            hi = &b->h8[i].hi[0][0];
        }
        if (cnt) {
            *ntri += cnt;
            continue;
        }
        kid[k] = ref;
        karea[k++] = box_area(lo[s], lo[W + s], lo[2 * W + s], hi[s], hi[W + s], hi[2 * W + s]);
    }
    return k;
}

/* Max-heap of frontier nodes by (area, lower index). */
typedef struct fheap {
    uint32_t *v;
    size_t n;
    const float *area;
} fheap;

static int fh_above(const fheap *h, uint32_t a, uint32_t b)
{
    return h->area[a] > h->area[b] || (h->area[a] == h->area[b] && a < b);
}

static void fh_push(fheap *h, uint32_t x)
{
    size_t i = h->n++;
    h->v[i] = x;
    while (i > 0) {
        size_t p = (i - 1) / 2;
        if (!fh_above(h, h->v[i], h->v[p])) break;
        uint32_t t = h->v[i];
        h->v[i] = h->v[p];
        h->v[p] = t;
        i = p;
    }
}

static uint32_t fh_pop(fheap *h)
{
    uint32_t top = h->v[0];
    h->v[0] = h->v[--h->n];
    size_t i = 0;
    for (;;) {
        size_t l = 2 * i + 1, r = l + 1, m = i;
        if (l < h->n && fh_above(h, h->v[l], h->v[m])) m = l;
        if (r < h->n && fh_above(h, h->v[r], h->v[m])) m = r;
        if (m == i) break;
        uint32_t t = h->v[i];
        h->v[i] = h->v[m];
        h->v[m] = t;
        i = m;
    }
    return top;
}

/* The budget a run's options give (bytes), and the option that gave it. */
static uint64_t tl_budget(const rt_render_opts *o, const char **opt)
{
    if (opt) *opt = o->gmax ? "--gmax" : "--cache-size";
    return o->gmax ? o->gmax : o->sched_size / 2;
}

static int tl_plan(const rt_tracer_ctx *ctx, void **out, rt_err *e)
{
    const int two = ctx->acc->kind == RT_ACCEL_INST;
    *out = NULL;
    if (!ctx->acc->as || (!two && !rt_accel_bvh_width(ctx->acc->kind)))
        return rt_errf(e, "treelet: runs on a BVH only (internal error)");
    tplan *P = rt_calloc(1, sizeof *P, e);
    if (!P) return -1;
    const rt_bvh *b = ctx->acc->as;
    if (two) { /* the top level, a bvh2 over the instances: its leaves' entries are instances */
        P->inst = ctx->acc->as;
        P->top.width = 2;
        P->top.nnodes = P->inst->ntnode;
        P->top.n2 = P->inst->tnode;
        b = &P->top;
    }
    const uint32_t leafrec = two ? RT_INST_RECSIZE : 36u; /* --treelet-tris: a leaf entry's bytes */
    P->width = b->width;
    P->budget = tl_budget(ctx->opt, NULL);
    P->tris = ctx->opt->treelet_tris;
    P->nnodes = b->nnodes;
    size_t nn = b->nnodes ? b->nnodes : 1;
    uint32_t *roots = NULL;
    fheap H = {0};
    if (!(P->tl = rt_calloc(nn, sizeof *P->tl, e)) || !(P->parent = rt_calloc(nn, sizeof *P->parent, e)) ||
        !(P->area = rt_calloc(nn, sizeof *P->area, e)) || !(P->cost = rt_calloc(nn, sizeof *P->cost, e)) ||
        !(P->troot = rt_calloc(nn, sizeof *P->troot, e)) || !(P->tbytes = rt_calloc(nn, sizeof *P->tbytes, e)) ||
        !(P->tdepth = rt_calloc(nn, sizeof *P->tdepth, e)) ||
        !(P->rootbit = rt_calloc(nn / 64 + 1, sizeof *P->rootbit, e)) || !(roots = rt_calloc(nn, sizeof *roots, e)) ||
        !(H.v = rt_calloc(nn, sizeof *H.v, e)))
        goto fail;
    const uint32_t nsize = rt_bvh_node_size(b->width);
    /* areas, parents and costs; children follow their parent in the array */
    for (uint32_t i = 0; i < b->nnodes; i++) P->parent[i] = UINT32_MAX;
    if (b->nnodes)
        P->area[0] = box_area(b->bounds.lo.x, b->bounds.lo.y, b->bounds.lo.z, b->bounds.hi.x, b->bounds.hi.y,
                              b->bounds.hi.z);
    for (uint32_t i = 0; i < b->nnodes; i++) {
        uint32_t kid[8], nt;
        float ka[8];
        int k = children(b, i, kid, ka, &nt);
        P->cost[i] = nsize + (P->tris ? leafrec * nt : 0u);
        for (int j = 0; j < k; j++) {
            P->parent[kid[j]] = i;
            P->area[kid[j]] = ka[j];
        }
    }
    if (b->width == 2)
        for (uint32_t i = 0; i < b->nnodes; i++)
            P->area[i] = box_area(b->n2[i].lo[0], b->n2[i].lo[1], b->n2[i].lo[2], b->n2[i].hi[0], b->n2[i].hi[1],
                                  b->n2[i].hi[2]);
    /* greedy formation, treelets breadth first */
    H.area = P->area;
    size_t rhead = 0, rtail = 0;
    uint32_t nt = 0;
    if (b->nnodes) roots[rtail++] = 0;
    while (rhead < rtail) {
        const uint32_t r = roots[rhead++], t = nt++;
        uint64_t bytes = 0;
        P->troot[t] = r;
        P->rootbit[r / 64] |= (uint64_t)1 << (r % 64);
        P->tdepth[t] = r == 0 ? 1 : P->tdepth[P->tl[P->parent[r]]] + 1;
        if (P->tdepth[t] > P->maxdepth) P->maxdepth = P->tdepth[t];
        H.n = 0;
        fh_push(&H, r);
        while (H.n) {
            const uint32_t n = H.v[0];
            if (bytes && bytes + P->cost[n] > P->budget) break;
            fh_pop(&H);
            P->tl[n] = t;
            bytes += P->cost[n];
            uint32_t kid[8], ntr;
            float ka[8];
            int k = children(b, n, kid, ka, &ntr);
            for (int j = 0; j < k; j++) fh_push(&H, kid[j]);
        }
        P->tbytes[t] = bytes;
        if (bytes > P->bytes_max) P->bytes_max = bytes;
        /* the frontier left, in node order, roots later treelets */
        uint32_t *f = H.v;
        size_t fn = H.n;
        for (size_t i = 1; i < fn; i++) { /* insertion sort: frontiers are short */
            uint32_t x = f[i];
            size_t j = i;
            while (j > 0 && f[j - 1] > x) {
                f[j] = f[j - 1];
                j--;
            }
            f[j] = x;
        }
        for (size_t i = 0; i < fn; i++) roots[rtail++] = f[i];
    }
    P->nt = nt ? nt : 1;
    free(roots);
    free(H.v);
    *out = P;
    return 0;
fail:
    free(roots);
    free(H.v);
    tl_plan_free(P);
    return -1;
}

/* T1 on a plan against its tree. */
static int check_plan(const tplan *P, const rt_bvh *b, rt_err *e)
{
    if (P->inst && (b != &P->top || P->top.width != 2 || P->top.n2 != P->inst->tnode || P->top.nnodes != P->inst->ntnode))
        return rt_errf(e, "treelet T1: the plan's tree is not the two-level structure's top level");
    if (!b->nnodes) return 0;
    uint64_t *sum = rt_calloc(P->nt, sizeof *sum, e);
    uint32_t *cnt = rt_calloc(P->nt, sizeof *cnt, e);
    int rc = -1;
    if (!sum || !cnt) goto done;
    if (P->tl[0] != 0 || P->troot[0] != 0) {
        rt_errf(e, "treelet T1: the root lies in treelet %u, treelet 0's root is %u", P->tl[0], P->troot[0]);
        goto done;
    }
    for (uint32_t i = 0; i < b->nnodes; i++) {
        const uint32_t t = P->tl[i];
        if (t >= P->nt) {
            rt_errf(e, "treelet T1: node %u in treelet %u of %u", i, t, P->nt);
            goto done;
        }
        sum[t] += P->cost[i];
        cnt[t]++;
        const int isroot = P->troot[t] == i;
        if (isroot != (int)(P->rootbit[i / 64] >> (i % 64) & 1)) {
            rt_errf(e, "treelet T1: node %u is%s its treelet's root, its root bit says%s", i, isroot ? "" : " not",
                    isroot ? " not" : " so");
            goto done;
        }
        if (i != 0 && !isroot && P->tl[P->parent[i]] != t) {
            rt_errf(e, "treelet T1: node %u in treelet %u, its parent %u in treelet %u", i, t, P->parent[i],
                    P->tl[P->parent[i]]);
            goto done;
        }
        if (isroot && i != 0 && P->tl[P->parent[i]] == t) {
            rt_errf(e, "treelet T1: treelet %u's root %u has its parent in the same treelet", t, i);
            goto done;
        }
    }
    for (uint32_t t = 0; t < P->nt; t++) {
        if (P->tl[P->troot[t]] != t) {
            rt_errf(e, "treelet T1: treelet %u's root %u lies in treelet %u", t, P->troot[t], P->tl[P->troot[t]]);
            goto done;
        }
        if (sum[t] != P->tbytes[t] || (sum[t] > P->budget && cnt[t] != 1)) {
            rt_errf(e, "treelet T1: treelet %u holds %u nodes of %" PRIu64 " bytes (plan %" PRIu64 ", budget %" PRIu64 ")",
                    t, cnt[t], sum[t], P->tbytes[t], P->budget);
            goto done;
        }
    }
    /* the greedy stop: the largest-area frontier node would not fit */
    {
        uint32_t *fmax = rt_calloc(P->nt, sizeof *fmax, e);
        if (!fmax) goto done;
        for (uint32_t t = 0; t < P->nt; t++) fmax[t] = UINT32_MAX;
        for (uint32_t i = 1; i < b->nnodes; i++) {
            const uint32_t t = P->tl[P->parent[i]];
            if (P->tl[i] == t) continue;
            const uint32_t m = fmax[t];
            if (m == UINT32_MAX || P->area[i] > P->area[m] || (P->area[i] == P->area[m] && i < m)) fmax[t] = i;
        }
        for (uint32_t t = 0; t < P->nt; t++)
            if (fmax[t] != UINT32_MAX && P->tbytes[t] + P->cost[fmax[t]] <= P->budget) {
                rt_errf(e, "treelet T1: treelet %u (%" PRIu64 " bytes) stopped before node %u (%u bytes) fits the budget %" PRIu64,
                        t, P->tbytes[t], fmax[t], P->cost[fmax[t]], P->budget);
                free(fmax);
                goto done;
            }
        free(fmax);
    }
    rc = 0;
done:
    free(sum);
    free(cnt);
    return rc;
}

/* ---- the run's state --------------------------------------------------------- */

typedef struct sent {
    uint32_t a, n; /* rt_bvh_ref: node (n = 0) or leaf range */
    float t;       /* entry distance */
    uint32_t tl;   /* treelet it is processed in */
} sent;

#define INL 9 /* stack entries held inside the host record (deeper ones: the run's stack arena) */
#define TRAY_SIZE 256 /* bytes of a host record: four lines */

/* Host state of a ray slot (not modeled: tl.rays is), TRAY_SIZE bytes on
 * a line boundary: a visit reads the first two lines (the ray, the cull
 * bound, the stack's depth and place) and the line of its stack top; with
 * up to INL entries the stack lies in the same record. The slab form of
 * the ray (rt_bvh_wray) is derived from r at each visit, not kept. */
typedef struct tray {
    rt_ray r;         /* the traversal ray: o, inv_d, tmin for the boxes, the rest for triangles */
    float cull;       /* cull bound of the best hit */
    uint16_t sp, cap; /* stack depth and capacity (both <= stack_bound < 2^16) */
    uint16_t mem, reg; /* entries [0, mem) have valid memory copies, [reg, sp) are in registers;
                        * reg <= mem <= sp, and a queued ray has reg = mem = sp */
    sent *stk;        /* inl, or an arena array (cap doubles
                       * from INL while sp <= stack_bound <= 443, so cap stays below 2^10) */
    float best, bu, bv; /* best hit so far (best starts at tmax) */
    uint32_t btri;    /* best hit's scene index (0 while none) */
    uint8_t found, any, occluded; /* a hit is held; any-hit (shadow) ray; its result */
    sent inl[INL];    /* the first INL stack entries */
} tray;
_Static_assert(sizeof(tray) == TRAY_SIZE, "a host ray record is four lines");

/* The stack arena: slabs from which deep stacks are carved (bump
 * allocation, all freed at the end of the run). */
typedef struct tslab {
    struct tslab *next; /* the slab allocated before */
    size_t used, cap;   /* entries carved, entries held */
    sent v[];
} tslab;
#define SLAB_ENTRIES 65536

typedef struct tl_run {
    const rt_tracer_ctx *ctx;
    const rt_scene *sc;
    const rt_bvh *b;
    const tplan *P;
    const rt_layout *L;
    rt_rec *rec;
    rt_trav tv;       /* counts, marks, regions */
    int reg_ray, reg_fb, reg_rays, reg_stack, reg_qt, reg_q, reg_hits, reg_spawn, reg_shade;
    uint32_t nsize, esize, stack_bound;
    uint32_t slots;   /* ray slots (the window) */
    uint32_t nslot;   /* the model's shading slots (rt_scene_model_nslot): the marks */
    size_t npix;
    tray *ray;        /* slots records of TRAY_SIZE bytes, line-aligned inside ray_mem */
    void *ray_mem;    /* the allocation holding ray */
    tslab *slab;      /* the stack arena's newest slab */
    /* the queues (one per treelet, entries are 4-byte slot numbers), their
     * block pool and buckets, the batch stack (T2: the ray-queue core's
     * Q1-Q5, rayq.c) */
    rt_rq rq;
    int qwrite;       /* the write kind of a queue entry's store (--queue-stores) */
    /* the generation (T3) */
    uint8_t *want, *done; /* per slot */
    uint64_t started, finished;
    int shadow, light;
    /* per slot results */
    rt_hit *hit;      /* closest hit per slot */
    uint8_t *vis;     /* per pixel (primary modes): bit i light i visible */
    int authored;     /* the file's lights (--light-samples; shade.h): a generation per light and sample */
    float *lw, *swt;  /* authored: per pixel x light the unoccluded weights; per slot this sample's weight */
    rt_ray *bray;     /* closest ray per slot (secondary modes: the path ray; primary modes derive the camera ray) */
    rt_ray *bsray;    /* shadow ray per slot */
    /* secondary modes */
    int secondary;
    rt_shade_out *out;
    rt_acc *acc;
    rt_hit *h0;
    /* statistics */
    uint64_t enq, events, ev_max, visits, stack_w, stack_r, spills, refills, nsec, self_hits, susp, qreads;
    uint32_t max_sp;
    uint8_t *mark;
    rt_image *img;
    rt_run_stats *st;
    rt_err *e;
    int err;          /* 1: internal failure, 2: invariant broken (message in e) */
    /* simulated cores (ctx->cores; NULL: one core, today's run): treelet t
     * on core t mod ncores, rounds with a barrier (T7) */
    rt_cores *cores;
    int ncores, core;  /* cores; the core whose work is being recorded */
    uint64_t *cq;      /* per core: rays queued in its treelets */
    uint64_t *cvis;    /* per core: queue visits (rays walked) */
    uint8_t *mv;       /* per slot: queued by a core that does not own the treelet */
    uint8_t *need;     /* per core, a round's scratch: it holds queued rays */
    uint32_t *pick, *rn, *tcur; /* per core: a round's queue and its rays; tree order's next treelet */
    rt_rq_cur *rcur;   /* per core: a round's cursor */
    uint64_t rounds, moved, moved_reads;
    uint64_t moved_bytes; /* ray state the receivers read for moved rays: records and deep stack refills */
    int moving;        /* the ray being walked has just moved to this core */
} tl_run;

/* ---- queues ------------------------------------------------------------------- */

static void enqueue(tl_run *T, uint32_t q, uint32_t slot)
{
    uint64_t at;
    uint32_t *x = rt_rq_push(&T->rq, q, &at);
    if (!x) {
        if (!T->err) rt_errf(T->e, "treelet: queue pool exhausted (internal error)");
        T->err = 1;
        return;
    }
    *x = slot;
    RT_REC(T->rec, rt_mm_addr(T->L, T->reg_q, at), 4, T->qwrite, RT_CLS_QUEUE);
    RT_REC(T->rec, rt_mm_addr(T->L, T->reg_qt, q), 8, 1, RT_CLS_QTABLE);
    T->enq++;
    if (T->cores) { /* T7: the owner's count; a ray handed to another core moves */
        const uint32_t k = q % (uint32_t)T->ncores;
        const uint8_t m = k != (uint32_t)T->core;
        T->cq[k]++;
        T->mv[slot] = m;
        T->moved += m;
    }
}

/* ---- simulated cores ------------------------------------------------------------ */

/* Core k's work is recorded from here on. */
static inline void use_core(tl_run *T, int k)
{
    T->core = k;
    T->rec = rt_cores_rec(T->cores, k);
}

/* Per-slot work (starting, shading a slot of n): slot s is its chunk's
 * core's (cores.h: contiguous chunks of the slots). */
static inline void slot_core(tl_run *T, uint32_t s, uint32_t n)
{
    if (T->cores) use_core(T, rt_cores_owner(s, n, T->ncores));
}

/* The generation stamped on every core's references. */
static void set_gen(tl_run *T, int g)
{
    if (!T->cores) {
        rt_rec_set_gen(T->rec, g);
        return;
    }
    for (int k = 0; k < T->ncores; k++) rt_rec_set_gen(rt_cores_rec(T->cores, k), g);
}

/* The end of a phase (simulated cores): the barrier. */
static void barrier(tl_run *T)
{
    if (!T->cores) return;
    if (rt_cores_barrier(T->cores) < 0 && !T->err) {
        rt_errf(T->e, "trace sink failed");
        T->err = 1;
    }
}

/* ---- one ray in one treelet ---------------------------------------------------- */

/* Moves R's stack to an arena array of twice its capacity (the old array,
 * if from the arena, stays carved: stacks only grow within a run). 0, or
 * -1 out of memory (T->err set). */
static int grow(tl_run *T, tray *R)
{
    const size_t nc = 2 * (size_t)R->cap;
    tslab *sl = T->slab;
    if (!sl || sl->cap - sl->used < nc) {
        const size_t cap = nc > SLAB_ENTRIES ? nc : SLAB_ENTRIES;
        tslab *n = malloc(sizeof *n + cap * sizeof n->v[0]);
        if (!n) {
            if (!T->err) rt_errf(T->e, "treelet: out of memory for a ray stack");
            T->err = 1;
            return -1;
        }
        n->next = sl;
        n->used = 0;
        n->cap = cap;
        T->slab = sl = n;
    }
    sent *v = sl->v + sl->used;
    sl->used += nc;
    memcpy(v, R->stk, sizeof *v * R->sp);
    R->stk = v;
    R->cap = (uint16_t)nc;
    return 0;
}

static inline void push(tl_run *T, tray *R, const rt_bvh_ref *x, uint32_t tl)
{
    if (R->sp == R->cap && grow(T, R) < 0) return;
    if (R->mem > R->sp) R->mem = R->sp; /* that position's memory copy is stale */
    R->stk[R->sp++] = (sent){x->a, x->n, x->t, tl};
    RT_ASSERT(R->sp <= T->stack_bound); /* T4: the modeled stack area holds it */
    if (R->sp > T->max_sp) T->max_sp = R->sp;
}

/* The walk's working copy of a ray's hit state (locals while a ray is
 * inside a treelet, stored back into its record when it leaves). */
typedef struct thit {
    float best, bu, bv; /* best hit so far (best starts at tmax) */
    float cull;         /* rt_bvh_cull_bound(best) */
    uint32_t btri;      /* best hit's scene index (0 while none) */
    int found;          /* a hit is held */
} thit;

/* Tests records [first, first + n) (bvh.c's leaf_tris) of ray r. 1: an
 * any-hit ray is occluded. Counts tests in *ntest. */
static RT_ALWAYS_INLINE int leaf(const tl_run *T, const rt_ray *r, int any, thit *H, uint32_t first, uint32_t n,
                                 uint64_t tri_base, uint64_t *ntest)
{
    const rt_bvh *b = T->b;
    rt_rec *rec = T->rec;
    uint8_t *mark = T->mark;
    const uint8_t bit = T->tv.mark_bit;
    for (uint32_t k = first; k < first + n; k++) {
        const uint32_t o = b->orig[k];
        ++*ntest;
        mark[o] |= bit;
        RT_REC(rec, tri_base + 36ull * k, 36, 0, RT_CLS_TRI);
        float t, u, v;
        if (!rt_isect_core(r, rt_bvh_tri(b, k), &t, &u, &v)) continue;
        if (any) {
            if (t > r->tmin && t < r->tmax && !rt_alpha_cut(T->tv.sc->alpha, &T->tv.alpha, T->rec, r, o, u, v)) return 1;
        } else if (t > r->tmin && rt_hit_better(&(const rt_hit){H->best, H->btri, H->bu, H->bv}, t, o) &&
                   !rt_alpha_cut(T->tv.sc->alpha, &T->tv.alpha, T->rec, r, o, u, v)) {
            /* the hit rule of accel/hit.h (btri is 0 while none is held:
             * best is then tmax, which no hit in (tmin, tmax) ties) */
            H->found = 1;
            H->best = t;
            H->btri = o;
            H->bu = u;
            H->bv = v;
            H->cull = rt_bvh_cull_bound(t);
        }
    }
    return 0;
}

/* Modeled address of stack entry k of slot s: the first entries in the
 * ray record's short stack, the others in the slot's area of tl.stack. */
static uint64_t stack_addr(const tl_run *T, uint32_t s, uint32_t k)
{
    const uint32_t nin = SHORT_STACK / T->esize;
    if (k < nin) return rt_mm_addr(T->L, T->reg_rays, s) + RAY_STATE + (uint64_t)k * T->esize;
    return rt_mm_addr(T->L, T->reg_stack, (uint64_t)s * T->stack_bound + (k - nin));
}

/* walk() on the two-level structure (P->inst): the ray walks the top
 * level as rt_inst_visit's single walk does, node by node in this
 * treelet; an instance leaf it reaches is handled inside this treelet by
 * rt_inst_visit walking the instance's shared tree to completion (its
 * record read as inst, the ray transformed, the bottom-level nodes and
 * shared triangles read as node and tri), so a suspended ray carries only
 * top-level stack entries, never an instance. */
static int walk_inst(tl_run *T, uint32_t s, uint32_t t)
{
    tray *R = &T->ray[s];
    const rt_ray ray = R->r;
    const int any = R->any;
    rt_rec *rec = T->rec;
    T->tv.rec = rec; /* the instance walk records through tv (this core's recorder) */
    const uint32_t *ptl = T->P->tl;
    const uint64_t *rootbit = T->P->rootbit;
    const uint32_t esize = T->esize, nin = SHORT_STACK / esize;
    rt_hit best = {.t = R->best, .tri = R->found ? R->btri : RT_NO_HIT, .u = R->bu, .v = R->bv};
    int found = R->found;
    sent *stk = R->stk;
    uint32_t sp = R->sp, mem = R->mem, reg = R->reg, cap = R->cap, max_sp = T->max_sp;
    int ret = 1, occluded = 0;
    for (;;) {
        if (sp == 0) break;
        const uint32_t idx = sp - 1;
        const sent e = stk[idx];
        if (e.tl != t) { /* suspend, as walk() does */
            const uint32_t top_in = sp < nin ? sp : nin;
            const uint32_t end = mem < top_in ? RAY_STATE + top_in * esize : RAY_SUSP_OFS + RAY_SUSP;
            RT_REC(rec, rt_mm_addr(T->L, T->reg_rays, s) + RAY_SUSP_OFS, end - RAY_SUSP_OFS, 1, RT_CLS_RAY);
            const uint32_t lo = mem > nin ? mem : nin;
            if (sp > lo) {
                RT_REC(rec, stack_addr(T, s, lo), (sp - lo) * esize, 1, RT_CLS_STREAM);
                T->stack_w += sp - lo;
                T->spills++;
            }
            mem = reg = sp;
            T->susp++;
            enqueue(T, e.tl, s);
            ret = 0;
            break;
        }
        if (idx < reg) { /* the refill, as walk() does */
            uint32_t lo = idx;
            if (idx >= nin) {
                lo = idx + 1 >= nin + REFILL ? idx + 1 - REFILL : nin;
                RT_REC(rec, stack_addr(T, s, lo), (idx + 1 - lo) * esize, 0, RT_CLS_STREAM);
                if (T->moving) T->moved_bytes += (idx + 1 - lo) * esize;
                T->stack_r += idx + 1 - lo;
                T->refills++;
            }
            reg = lo;
        }
        sp = idx;
        if (mem > idx) mem = idx;
        uint32_t kid[2];
        int hit = 0;
        const int k = rt_inst_visit(&T->tv, &ray, e.a, &best, any, &hit, kid);
        if (hit) found = 1;
        if (any && hit) {
            occluded = 1;
            break;
        }
        if (!k) continue;
        if (sp + 2 > cap) {
            R->sp = (uint16_t)sp;
            if (grow(T, R) < 0) break;
            stk = R->stk;
            cap = R->cap;
        }
        if (mem > sp) mem = sp;
        for (int j = 1; j >= 0; j--) { /* kid[0] on top: walked next */
            const uint32_t a = kid[j];
            const uint32_t tl = rootbit[a / 64] >> (a % 64) & 1 ? ptl[a] : t;
            stk[sp++] = (sent){a, 0, ray.tmin, tl};
        }
        if (sp > max_sp) max_sp = sp;
    }
    if (occluded) {
        R->occluded = 1;
        sp = mem = reg = 0;
    }
    R->sp = (uint16_t)sp;
    R->mem = (uint16_t)mem;
    R->reg = (uint16_t)reg;
    R->best = best.t;
    R->bu = best.u;
    R->bv = best.v;
    R->btri = found ? best.tri : 0;
    R->found = (uint8_t)found;
    T->max_sp = max_sp;
    return ret;
}

/* Walks ray slot s inside treelet t. Returns 1 when it finished (stack
 * empty or occluded), 0 when it was suspended and queued at its next
 * treelet. The ray's stack depths, hit state and counters live in locals
 * while it is inside the treelet (stores through the mark bytes and the
 * recorder would otherwise reload them at every node) and go back into
 * its record when it leaves. */
static int walk(tl_run *T, uint32_t s, uint32_t t)
{
    if (T->P->inst) return walk_inst(T, s, t);
    tray *R = &T->ray[s];
    const rt_bvh *b = T->b;
    const int W = b->width;
    const rt_ray ray = R->r;
    const int any = R->any;
    rt_bvh_wray w;
    rt_bvh_wray_init(&w, &ray, W);
    rt_rec *rec = T->rec;
    const uint32_t *ptl = T->P->tl;
    const uint64_t *rootbit = T->P->rootbit;
    const uint32_t esize = T->esize, nin = SHORT_STACK / esize, nsize = T->nsize;
    const uint64_t nbase = rec ? T->L->r[T->tv.reg_node].base : 0;
    const uint64_t tri_base = rec ? T->L->r[T->tv.reg_tri].base : 0;
    thit H = {R->best, R->bu, R->bv, R->cull, R->btri, R->found};
    sent *stk = R->stk;
    uint32_t sp = R->sp, mem = R->mem, reg = R->reg, cap = R->cap, max_sp = T->max_sp;
    uint64_t nodes = 0, tests = 0;
    int ret = 1, occluded = 0;
    for (;;) {
        if (sp == 0) break;
        const uint32_t idx = sp - 1;
        const sent e = stk[idx];
        const int culled = W != 2 && e.t > H.cull;
        if (!culled && e.tl != t) {
            /* suspend: the hit and depth, with the short-stack entries
             * not yet in memory, in one write to the record; the deeper
             * entries not yet in memory in one write to tl.stack */
            const uint32_t top_in = sp < nin ? sp : nin;
            const uint32_t end = mem < top_in ? RAY_STATE + top_in * esize : RAY_SUSP_OFS + RAY_SUSP;
            RT_REC(rec, rt_mm_addr(T->L, T->reg_rays, s) + RAY_SUSP_OFS, end - RAY_SUSP_OFS, 1, RT_CLS_RAY);
            const uint32_t lo = mem > nin ? mem : nin;
            if (sp > lo) {
                RT_REC(rec, stack_addr(T, s, lo), (sp - lo) * esize, 1, RT_CLS_STREAM);
                T->stack_w += sp - lo;
                T->spills++;
            }
            mem = reg = sp;
            T->susp++;
            enqueue(T, e.tl, s);
            ret = 0;
            break;
        }
        if (idx < reg) {
            /* not in registers: the short stack came with the record; a
             * deep entry is read with up to REFILL - 1 entries below it,
             * in one access (their memory copies stay valid) */
            uint32_t lo = idx;
            if (idx >= nin) {
                lo = idx + 1 >= nin + REFILL ? idx + 1 - REFILL : nin;
                RT_REC(rec, stack_addr(T, s, lo), (idx + 1 - lo) * esize, 0, RT_CLS_STREAM);
                if (T->moving) T->moved_bytes += (idx + 1 - lo) * esize;
                T->stack_r += idx + 1 - lo;
                T->refills++;
            }
            reg = lo;
        }
        sp = idx;
        if (mem > idx) mem = idx;
        if (culled) continue;
        if (e.n) { /* a wide node's leaf child */
            if (leaf(T, &ray, any, &H, e.a, e.n, tri_base, &tests)) {
                occluded = 1;
                break;
            }
            continue;
        }
        nodes++;
        RT_REC(rec, nbase + (uint64_t)nsize * e.a, nsize, 0, RT_CLS_NODE);
        rt_bvh_ref out[8];
        const int k = rt_bvh_step(b, &w, e.a, H.cull, out);
        if (W == 2 && k == 1) {
            if (leaf(T, &ray, any, &H, out[0].a, out[0].n, tri_base, &tests)) {
                occluded = 1;
                break;
            }
            continue;
        }
        if (!k) continue;
        if (sp + (uint32_t)k > cap) {
            R->sp = (uint16_t)sp;
            if (grow(T, R) < 0) break;
            stk = R->stk;
            cap = R->cap;
        }
        if (mem > sp) mem = sp; /* the memory copies from sp up are stale */
        /* a child lies in this treelet unless it is a treelet's root (T1) */
        for (int j = 0; j < k; j++) {
            const uint32_t a = out[j].a;
            const uint32_t tl = !out[j].n && (rootbit[a / 64] >> (a % 64) & 1) ? ptl[a] : t;
            stk[sp++] = (sent){a, out[j].n, out[j].t, tl};
        }
        if (sp > max_sp) max_sp = sp;
    }
    if (occluded) {
        R->occluded = 1;
        sp = mem = reg = 0;
    }
    R->sp = (uint16_t)sp;
    R->mem = (uint16_t)mem;
    R->reg = (uint16_t)reg;
    R->best = H.best;
    R->bu = H.bu;
    R->bv = H.bv;
    R->cull = H.cull;
    R->btri = H.btri;
    R->found = (uint8_t)H.found;
    T->max_sp = max_sp;
    T->tv.nodes += nodes;
    T->tv.tests += tests;
    return ret;
}

/* Starts slot s on ray r (closest, or any hit for a shadow ray): state
 * written, the root on its stack, queued at the root's treelet. A tree
 * without nodes finishes it at once (returns 1). */
static int start(tl_run *T, uint32_t s, const rt_ray *r, int any)
{
    tray *R = &T->ray[s];
    R->r = *r;
    R->best = r->tmax;
    R->bu = R->bv = 0.0f;
    R->btri = 0;
    R->found = 0;
    R->any = (uint8_t)any;
    R->occluded = 0;
    R->cull = rt_bvh_cull_bound(r->tmax);
    R->sp = R->mem = R->reg = 0;
    T->started++;
    /* the state and the root as the first short-stack entry */
    RT_REC(T->rec, rt_mm_addr(T->L, T->reg_rays, s), RAY_STATE + (T->b->nnodes ? T->esize : 0), 1, RT_CLS_RAY);
    if (!T->b->nnodes) return 1;
    rt_bvh_ref root = {0, 0, r->tmin};
    push(T, R, &root, 0);
    R->mem = R->reg = 1;
    enqueue(T, 0, s);
    return 0;
}

/* ---- resolution -------------------------------------------------------------- */

/* T6: the single-ray walk, unrecorded and uncounted, finds the same. */
static void check_resolution(tl_run *T, uint32_t s)
{
    if (!T->ctx->check || T->err) return;
    const tray *R = &T->ray[s];
    rt_trav ref = T->tv;
    ref.rec = NULL;
    ref.mark = NULL;
    if (R->any) {
        int occ = T->ctx->acc->ops->occluded(&ref, &R->r);
        if (occ != R->occluded) {
            rt_errf(T->e, "treelet T6: shadow ray %u resolved %s, the single-ray walk finds it %s", s,
                    R->occluded ? "occluded" : "visible", occ ? "occluded" : "visible");
            T->err = 2;
        }
        return;
    }
    rt_hit h;
    T->ctx->acc->ops->closest(&ref, &R->r, &h);
    uint32_t tri = R->found ? R->btri : RT_NO_HIT;
    if (h.tri != tri || (tri != RT_NO_HIT && (h.t != R->best || h.u != R->bu || h.v != R->bv))) {
        rt_errf(T->e, "treelet T6: ray %u resolved with triangle %d at t %a, the single-ray walk finds %d at %a", s,
                tri == RT_NO_HIT ? -1 : (int)tri, R->best, h.tri == RT_NO_HIT ? -1 : (int)h.tri, h.t);
        T->err = 2;
    }
}

/* A ray finished: its result into the slot's record. */
static void finish(tl_run *T, uint32_t s)
{
    tray *R = &T->ray[s];
    check_resolution(T, s);
    if (T->done[s]) {
        if (!T->err) rt_errf(T->e, "treelet T3: ray %u finished twice", s);
        T->err = 2;
    }
    T->done[s]++;
    T->finished++;
    if (R->any) return;
    rt_hit *h = &T->hit[s];
    if (R->found) {
        h->t = R->best;
        h->tri = R->btri;
        h->u = R->bu;
        h->v = R->bv;
    } else {
        rt_hit_none(h);
    }
}

/* ---- invariants (T2-T4) --------------------------------------------------------- */

static int check_state(const tl_run *T, rt_err *e)
{
    const tplan *P = T->P;
    if (rt_rq_check(&T->rq, e) < 0) return -1;
    uint8_t *inq = rt_calloc(T->slots ? T->slots : 1, 1, e);
    int rc = -1;
    if (!inq) goto done;
    for (uint32_t q = 0; q < P->nt; q++)
        for (rt_rq_cur c = rt_rq_peek(&T->rq, q); c.left; rt_rq_skip(&T->rq, &c)) {
            const uint32_t s = *(const uint32_t *)rt_rq_at(&T->rq, &c);
            const tray *R = s < T->slots ? &T->ray[s] : NULL;
            if (!R || !T->want[s] || T->done[s] || inq[s]) {
                rt_errf(e, "treelet T3: queue %u holds ray %u (wanted %d, finished %d, queued before %d)", q, s,
                        R ? T->want[s] : -1, R ? T->done[s] : -1, R ? inq[s] : -1);
                goto done;
            }
            inq[s] = 1;
            if (!R->sp || R->stk[R->sp - 1].tl != q) {
                rt_errf(e, "treelet T3: ray %u queued at treelet %u, the top of its stack is in %d", s, q,
                        R->sp ? (int)R->stk[R->sp - 1].tl : -1);
                goto done;
            }
        }
    if (T->started != T->finished + T->rq.queued) {
        rt_errf(e, "treelet T3: %" PRIu64 " rays started, %" PRIu64 " finished, %" PRIu64 " queued", T->started,
                T->finished, T->rq.queued);
        goto done;
    }
    if (T->cores) { /* T7 */
        const uint32_t N = (uint32_t)T->ncores;
        uint64_t inflight = 0;
        for (uint32_t k = 0; k < N; k++) {
            uint64_t sum = 0;
            for (uint32_t q = k; q < P->nt; q += N) sum += T->rq.count[q];
            if (sum != T->cq[k]) {
                rt_errf(e, "treelet T7: core %u's treelets hold %" PRIu64 " rays, its count says %" PRIu64, k, sum,
                        T->cq[k]);
                goto done;
            }
        }
        for (uint32_t s = 0; s < T->slots; s++) {
            if (T->mv[s] && !inq[s]) {
                rt_errf(e, "treelet T7: ray %u is marked moving between cores but is in no queue", s);
                goto done;
            }
            inflight += T->mv[s];
        }
        if (T->moved != T->moved_reads + inflight) {
            rt_errf(e, "treelet T7: %" PRIu64 " rays moved between cores, %" PRIu64 " read by the core they moved to, %" PRIu64
                    " queued on the way", T->moved, T->moved_reads, inflight);
            goto done;
        }
        if (rt_cores_check(T->cores, e) < 0) goto done;
    }
    for (uint32_t s = 0; s < T->slots; s++) {
        if (T->want[s] && !T->done[s] && !inq[s]) {
            rt_errf(e, "treelet T3: ray %u is neither queued nor finished", s);
            goto done;
        }
        const tray *R = &T->ray[s];
        if (!inq[s]) continue;
        if (R->mem != R->sp || R->reg != R->sp || R->sp > T->stack_bound) {
            rt_errf(e, "treelet T4: queued ray %u has %u stack entries, %u in memory, from %u in registers (bound %u)",
                    s, R->sp, R->mem, R->reg,
                    T->stack_bound);
            goto done;
        }
        for (uint32_t k = 0; k < R->sp; k++) {
            const sent *x = &R->stk[k];
            if (!x->n && (x->a >= T->b->nnodes || P->tl[x->a] != x->tl)) {
                rt_errf(e, "treelet T4: ray %u stack entry %u: node %u in treelet %u, entry says %u", s, k, x->a,
                        x->a < T->b->nnodes ? P->tl[x->a] : UINT32_MAX, x->tl);
                goto done;
            }
        }
    }
    rc = 0;
done:
    free(inq);
    return rc;
}

/* Test mode: T2-T4 between steps. */
static void step_check(tl_run *T)
{
    if (!T->ctx->check || T->err) return;
    if (check_state(T, T->e) < 0) T->err = 2;
}

/* ---- processing ------------------------------------------------------------------ */

#define PF_REC 8  /* queue entries ahead whose ray record is prefetched */
#define PF_NODE 4 /* ... whose next node is prefetched */

/* Host prefetch of slot s's record (all its lines). */
static inline void prefetch_rec(const tl_run *T, uint32_t s)
{
#if defined(__GNUC__)
    const char *h = (const char *)&T->ray[s];
    for (int l = 0; l < TRAY_SIZE; l += 64) __builtin_prefetch(h + l);
#else
    (void)T;
    (void)s;
#endif
}

/* Host prefetch of the node on top of R's stack (R's record was
 * prefetched PF_REC - PF_NODE entries earlier). */
static inline void prefetch_top(const tl_run *T, const tray *R)
{
#if defined(__GNUC__)
    if (!R->sp || R->stk[R->sp - 1].n) return;
    const uint32_t a = R->stk[R->sp - 1].a;
    const rt_bvh *bv = T->b;
    const char *nd = bv->width == 2   ? (const char *)&bv->n2[a]
                     : bv->width == 4 ? (const char *)&bv->n4[a]
                                      : (const char *)&bv->h8[a];
    __builtin_prefetch(nd);
    if (bv->width != 2) __builtin_prefetch(nd + 64);
#else
    (void)T;
    (void)R;
#endif
}

/* Ray k of the n taken from queue q: its block's entries (read together
 * at the block's first), its record, its walk in treelet q. */
static RT_ALWAYS_INLINE void visit(tl_run *T, uint32_t q, rt_rq_cur *cur, uint32_t k, uint32_t n)
{
    if (cur->pos == 0) { /* a block's entries are read together */
        const uint32_t m = n - k < QBLK ? n - k : QBLK;
        RT_REC(T->rec, rt_mm_addr(T->L, T->reg_q, (uint64_t)cur->b * QBLK), 4 * m, 0, RT_CLS_QUEUE);
        T->qreads++;
    }
    uint32_t s;
    rt_rq_pop(&T->rq, cur, &s); /* a block read to its end goes back to the pool */
    RT_REC(T->rec, rt_mm_addr(T->L, T->reg_rays, s), RAY_REC, 0, RT_CLS_RAY);
    T->visits++;
    if (T->cores) {
        T->cvis[T->core]++;
        T->moving = T->mv[s];
        if (T->mv[s]) { /* T7: the receiver reads the moved ray's state */
            T->moved_reads++;
            T->moved_bytes += RAY_REC;
            T->mv[s] = 0;
        }
    }
    if (walk(T, s, q)) finish(T, s);
    T->moving = 0;
}

/* Takes queue q whole and walks its rays in treelet q. */
static void process(tl_run *T, uint32_t q)
{
    RT_REC(T->rec, rt_mm_addr(T->L, T->reg_qt, q), 8, 1, RT_CLS_QTABLE); /* taken: read and reset */
    rt_rq_cur cur;
    const uint32_t n = rt_rq_take(&T->rq, q, &cur);
    T->events++;
    if (n > T->ev_max) T->ev_max = n;
    /* host prefetches (no modeled traffic): the record of the ray PF_REC
     * entries on and the node on top of the stack of the ray PF_NODE
     * entries on, through the block chain (cursors ra/pa and rn/pn run
     * ahead of k and read a block's link before that block is freed); the
     * first PF_REC records at once, so a short queue's misses overlap */
    rt_rq_cur ca = cur, cn = cur;
    for (uint32_t j = 0; j < n && j < PF_REC; j++) {
        prefetch_rec(T, *(const uint32_t *)rt_rq_at(&T->rq, &ca));
        rt_rq_skip(&T->rq, &ca);
    }
    for (uint32_t j = 0; j < n && j < PF_NODE; j++) rt_rq_skip(&T->rq, &cn);
    for (uint32_t k = 0; k < n && !T->err; k++) {
        if (k + PF_REC < n) {
            prefetch_rec(T, *(const uint32_t *)rt_rq_at(&T->rq, &ca));
            rt_rq_skip(&T->rq, &ca);
        }
        if (k + PF_NODE < n) {
            prefetch_top(T, &T->ray[*(const uint32_t *)rt_rq_at(&T->rq, &cn)]);
            rt_rq_skip(&T->rq, &cn);
        }
        visit(T, q, &cur, k, n);
    }
}

/* The ray-queue core's step: processes queue q, then (test mode) checks. */
static int process_step(void *u, uint32_t q)
{
    tl_run *T = u;
    process(T, q);
    step_check(T);
    return T->err;
}

/* Tree order on cores: core k's next treelet, the first non-empty one of
 * its own (k, k + N, ...) at or after tcur[k], wrapping (with one core,
 * rt_rq_run's sweep by number). */
static uint32_t tree_pick(tl_run *T, int k)
{
    const uint32_t N = (uint32_t)T->ncores, nq = T->rq.nq;
    for (int pass = 0; pass < 2; pass++)
        for (uint32_t q = pass ? (uint32_t)k : T->tcur[k]; q < nq && (!pass || q < T->tcur[k]); q += N)
            if (T->rq.count[q]) {
                T->tcur[k] = q + N;
                return q;
            }
    return UINT32_MAX;
}

enum { ROUND_SYNC = 16 }; /* rays of each core between syncs of the interleave */

/* Processes the queues on the simulated cores until all are empty, round
 * by round (T7): every core with rays queued in its treelets takes its
 * next queue (the order's first among its own: fullest, or tree order),
 * all at the round's start; the cores then walk their rays in turn (ray j
 * of core 0, of core 1, ..., then ray j + 1), a ray suspended into any
 * treelet is appended to that treelet's queue for a later round; a
 * barrier ends the round. With one core this is rt_rq_run's order. */
static void run_rounds(tl_run *T)
{
    const int N = T->ncores;
    for (int k = 0; k < N; k++) T->tcur[k] = (uint32_t)k;
    while (T->rq.queued && !T->err) {
        for (int k = 0; k < N; k++) T->need[k] = T->cq[k] > 0;
        if (T->rq.order == RT_RQ_FULLEST) rt_rq_pick_classes(&T->rq, (uint32_t)N, T->need, T->pick);
        else
            for (int k = 0; k < N; k++) T->pick[k] = T->need[k] ? tree_pick(T, k) : UINT32_MAX;
        uint32_t most = 0;
        for (int k = 0; k < N; k++) {
            T->rn[k] = 0;
            if (T->pick[k] == UINT32_MAX) {
                rt_cores_done(T->cores, k);
                continue;
            }
            const uint32_t q = T->pick[k];
            use_core(T, k);
            RT_REC(T->rec, rt_mm_addr(T->L, T->reg_qt, q), 8, 1, RT_CLS_QTABLE); /* taken: read and reset */
            const uint32_t n = rt_rq_take(&T->rq, q, &T->rcur[k]);
            T->rn[k] = n;
            T->cq[k] -= n;
            T->events++;
            if (n > T->ev_max) T->ev_max = n;
            if (n > most) most = n;
        }
        for (uint32_t j = 0; j < most && !T->err; j++) {
            for (int k = 0; k < N && !T->err; k++) {
                if (j >= T->rn[k]) continue;
                use_core(T, k);
                visit(T, T->pick[k], &T->rcur[k], j, T->rn[k]);
                if (j + 1 == T->rn[k]) rt_cores_done(T->cores, k);
            }
            if (j % ROUND_SYNC == ROUND_SYNC - 1) rt_cores_sync(T->cores);
        }
        if (T->err) return; /* taken rays left unpopped: the run fails */
        barrier(T);
        T->rounds++;
        step_check(T);
    }
}

/* Processes queues until all are empty. */
static void run_queues(tl_run *T)
{
    if (T->err) return;
    if (T->cores) run_rounds(T);
    else rt_rq_run(&T->rq, process_step, T);
}

/* End of a generation: queues empty, each wanted ray finished once. */
static int end_generation(tl_run *T, uint32_t n, rt_err *e)
{
    if (T->err) return -1;
    if (T->rq.queued) return rt_errf(e, "treelet: %" PRIu64 " rays still queued after a generation", T->rq.queued);
    for (uint32_t s = 0; s < n; s++)
        if (T->want[s] != T->done[s])
            return rt_errf(e, "treelet T3: ray %u wanted %u times, finished %u times", s, T->want[s], T->done[s]);
    return 0;
}

/* The camera ray of pixel p (primary modes derive it where it is needed
 * rather than keep one per slot). */
static void eye_ray(const tl_run *T, const rt_cam_frame *cam, uint32_t p, rt_ray *r)
{
    const uint32_t W = (uint32_t)T->ctx->opt->W;
    rt_cam_ray(cam, (int)(p % W), (int)(p / W), r);
}

/* A generation of closest-hit rays in slots 0..n-1: with cam, the camera
 * rays of pixels pix[0..n-1]; without, T->bray. */
static int gen_closest(tl_run *T, uint32_t n, const rt_cam_frame *cam, const uint32_t *pix, rt_err *e)
{
    T->shadow = 0;
    memset(T->want, 0, T->slots);
    memset(T->done, 0, T->slots);
    T->started = T->finished = 0;
    for (uint32_t s = 0; s < n; s++) {
        rt_ray eye;
        if (cam) eye_ray(T, cam, pix[s], &eye);
        T->want[s] = 1;
        slot_core(T, s, n);
        if (start(T, s, cam ? &eye : &T->bray[s], 0)) finish(T, s);
    }
    barrier(T); /* every core's rays started */
    step_check(T);
    run_queues(T);
    return end_generation(T, n, e);
}

/* A shadow generation for light li: slots whose out/ray want it. */
static int gen_shadow(tl_run *T, int li, uint32_t n, const uint8_t *wantli, rt_err *e)
{
    T->shadow = 1;
    T->light = li;
    memset(T->want, 0, T->slots);
    memset(T->done, 0, T->slots);
    T->started = T->finished = 0;
    for (uint32_t s = 0; s < n; s++) {
        slot_core(T, s, n);
        RT_REC(T->rec, rt_mm_addr(T->L, T->reg_hits, s), 24, 0, RT_CLS_HIT);
        if (!wantli[s]) continue;
        T->want[s] = 1;
        T->st->rays_shadow++;
        if (start(T, s, &T->bsray[s], 1)) finish(T, s);
    }
    barrier(T); /* every core's rays started */
    step_check(T);
    run_queues(T);
    return end_generation(T, n, e);
}

/* ---- primary modes ------------------------------------------------------------------ */

static int window_primary(tl_run *T, const uint32_t *pix, uint32_t n, rt_err *e)
{
    const rt_render_opts *o = T->ctx->opt;
    rt_cam_frame cam;
    rt_cam_setup(&cam, T->sc, o->W, o->H);
    set_gen(T, 0);
    T->tv.mark_bit = 1;
    for (uint32_t s = 0; s < n; s++) {
        slot_core(T, s, n);
        RT_REC(T->rec, rt_mm_addr(T->L, T->reg_ray, pix[s]), 32, 0, RT_CLS_RAY);
    }
    T->st->rays_primary += n;
    if (gen_closest(T, n, &cam, pix, e) < 0) return -1;
    uint8_t *wl = T->want + T->slots; /* scratch beside want: n bytes */
    for (uint32_t s = 0; s < n; s++) {
        slot_core(T, s, n);
        if (T->hit[s].tri != RT_NO_HIT)
            RT_REC(T->rec, rt_mm_addr(T->L, T->reg_shade, rt_scene_model_slot(T->sc, T->hit[s].tri, T->P->inst != NULL)), 16,
                   0, RT_CLS_SHADE);
        if (o->lights) RT_REC(T->rec, rt_mm_addr(T->L, T->reg_hits, s), 24, 1, RT_CLS_HIT);
    }
    T->tv.mark_bit = 2;
    for (uint32_t li = 0; T->authored && li < T->sc->nlight; li++) { /* the file's lights, sample by sample */
        if (!rt_render_light_on(o, li)) continue;
        for (uint32_t smp = 0, ns = rt_shade_light_nsamples(T->sc, o, li); smp < ns; smp++) {
            for (uint32_t s = 0; s < n; s++) {
                uint32_t tri;
                wl[s] = 0;
                if (T->hit[s].tri == RT_NO_HIT) continue;
                rt_ray eye;
                eye_ray(T, &cam, pix[s], &eye);
                wl[s] = rt_shade_sample_ray(T->sc, o, &eye, &T->hit[s], li, smp, &T->bsray[s], &T->swt[s], &tri) != 0;
                slot_core(T, s, n);
                if (wl[s]) rt_reg_light(T->ctx, T->rec, li, tri);
            }
            if (gen_shadow(T, (int)li, n, wl, e) < 0) return -1;
            for (uint32_t s = 0; s < n; s++)
                if (wl[s] && !T->ray[s].occluded) T->lw[(size_t)pix[s] * T->sc->nlight + li] += T->swt[s];
        }
    }
    for (int li = 0; li < RT_NLIGHTS && !T->authored; li++) {
        if (!(o->lights & (1u << li))) continue;
        for (uint32_t s = 0; s < n; s++) {
            wl[s] = 0;
            if (T->hit[s].tri == RT_NO_HIT) continue;
            rt_ray eye;
            eye_ray(T, &cam, pix[s], &eye);
            wl[s] = rt_shade_ray(T->sc, &eye, &T->hit[s], li, &T->bsray[s]) != 0;
        }
        if (gen_shadow(T, li, n, wl, e) < 0) return -1;
        for (uint32_t s = 0; s < n; s++)
            if (wl[s] && !T->ray[s].occluded) T->vis[pix[s]] |= (uint8_t)(1u << li);
    }
    for (uint32_t s = 0; s < n; s++) {
        const uint32_t p = pix[s];
        const rt_hit *h = &T->hit[s];
        rt_ray eye;
        eye_ray(T, &cam, p, &eye);
        slot_core(T, s, n);
        if (h->tri == RT_NO_HIT) {
            rt_shade_pixel(T->sc, &eye, NULL, NULL, o->lights, T->img, p);
        } else if (T->authored) {
            rt_shade_pixel_lw(T->sc, o, &eye, h, &T->lw[(size_t)p * T->sc->nlight], T->img, p);
        } else {
            int vis[RT_NLIGHTS];
            for (int i = 0; i < RT_NLIGHTS; i++) vis[i] = (T->vis[p] >> i) & 1;
            rt_shade_pixel(T->sc, &eye, h, vis, o->lights, T->img, p);
        }
        RT_REC(T->rec, rt_mm_addr(T->L, T->reg_fb, p), 12, 1, RT_CLS_FB);
    }
    return 0;
}

/* ---- secondary modes: batches of one generation (dynamic.c's scheme) ------------- */

/* The ray-queue core's batch trace: the batch at level lv (its closest
 * hits, shading, shadow rays); the core then pushes the children in out. */
static int batch_trace(void *u, int lv, const rt_path *rays, uint32_t n, const rt_shade_out **out, rt_err *e)
{
    tl_run *T = u;
    const rt_render_opts *o = T->ctx->opt;
    T->tv.mark_bit = rays[0].depth ? 4 : 1;
    if (T->cores) set_gen(T, rays[0].depth); /* the core set the batch's on core 0's recorder */
    for (uint32_t s = 0; s < n; s++) {
        slot_core(T, s, n);
        rt_shade_path_ray(&rays[s], &T->bray[s]);
        if (rays[s].depth) {
            RT_REC(T->rec, rt_mm_addr(T->L, T->reg_spawn, (uint64_t)lv * T->slots + s), RT_SREC_SIZE, 0, RT_CLS_RAY);
            T->nsec++;
        } else {
            RT_REC(T->rec, rt_mm_addr(T->L, T->reg_ray, rays[s].pix), 32, 0, RT_CLS_RAY);
            T->st->rays_primary++;
        }
    }
    if (gen_closest(T, n, NULL, NULL, e) < 0) return -1;
    for (uint32_t s = 0; s < n; s++) {
        const rt_hit *h = &T->hit[s];
        const rt_hit *hp = h->tri != RT_NO_HIT ? h : NULL;
        const uint32_t px = rays[s].pix;
        slot_core(T, s, n);
        if (!rays[s].depth && !rays[s].sample) T->h0[px] = *h;
        if (hp) rt_reg_shade(T->ctx, T->rec, h->tri);
        if (o->lights) RT_REC(T->rec, rt_mm_addr(T->L, T->reg_hits, s), 24, 1, RT_CLS_HIT);
        rt_shade_step(T->sc, o, &rays[s], &T->bray[s], hp, &T->out[s]);
        T->self_hits += (uint64_t)T->out[s].self_hit;
        rt_acc_add(&T->acc[px], T->out[s].c);
        RT_REC(T->rec, rt_mm_addr(T->L, T->reg_fb, px), 12, 0, RT_CLS_FB);
        RT_REC(T->rec, rt_mm_addr(T->L, T->reg_fb, px), 12, 1, RT_CLS_FB);
    }
    uint8_t *wl = T->want + T->slots; /* scratch beside want: n bytes */
    T->tv.mark_bit = 2;
    for (int li = 0; li < RT_NLIGHTS; li++) {
        if (!(o->lights & (1u << li))) continue;
        for (uint32_t s = 0; s < n; s++) {
            wl[s] = T->out[s].want[li];
            if (wl[s]) T->bsray[s] = T->out[s].sray[li];
        }
        if (gen_shadow(T, li, n, wl, e) < 0) return -1;
        for (uint32_t s = 0; s < n; s++)
            if (wl[s] && !T->ray[s].occluded) {
                const uint32_t px = rays[s].pix;
                slot_core(T, s, n);
                rt_acc_add(&T->acc[px], T->out[s].lc[li]);
                RT_REC(T->rec, rt_mm_addr(T->L, T->reg_fb, px), 12, 0, RT_CLS_FB);
                RT_REC(T->rec, rt_mm_addr(T->L, T->reg_fb, px), 12, 1, RT_CLS_FB);
            }
    }
    *out = T->out;
    return 0;
}

static int window_secondary(tl_run *T, const uint32_t *pix, uint32_t n, rt_err *e)
{
    const rt_render_opts *o = T->ctx->opt;
    const int spp = o->mode == RT_MODE_PATH ? o->spp : 1;
    rt_cam_frame cam;
    rt_cam_setup(&cam, T->sc, o->W, o->H);
    rt_path *base = rt_rq_base(&T->rq, e);
    if (!base) return -1;
    for (int s = 0; s < spp; s++) {
        for (uint32_t k = 0; k < n; k++) {
            rt_ray eye;
            rt_cam_ray(&cam, (int)(pix[k] % (uint32_t)o->W), (int)(pix[k] / (uint32_t)o->W), &eye);
            rt_shade_path_start(&base[k], &eye, pix[k], (uint32_t)s);
        }
        /* on cores, core 0 writes the spawned rays' records */
        if (rt_rq_batches(&T->rq, n, batch_trace, T, T->cores ? rt_cores_rec(T->cores, 0) : T->rec, T->L, T->reg_spawn,
                          e) < 0)
            return -1;
    }
    set_gen(T, 0);
    for (uint32_t k = 0; k < n; k++) {
        const uint32_t p = pix[k];
        slot_core(T, k, n);
        rt_ray eye;
        rt_cam_ray(&cam, (int)(p % (uint32_t)o->W), (int)(p / (uint32_t)o->W), &eye);
        rt_acc_pixel(&T->acc[p], spp, &eye, T->h0[p].tri != RT_NO_HIT ? &T->h0[p] : NULL, T->img, p);
        RT_REC(T->rec, rt_mm_addr(T->L, T->reg_fb, p), 12, 1, RT_CLS_FB);
    }
    return 0;
}

/* ---- tracer interface ---------------------------------------------------------------- */

static uint32_t slots_of(const rt_render_opts *o)
{
    const size_t npix = (size_t)o->W * (size_t)o->H;
    return o->ray_window && o->ray_window < npix ? o->ray_window : (uint32_t)npix;
}

static int levels_of(const rt_render_opts *o) { return o->mode == RT_MODE_PATH ? 2 : o->depth + 1; }

static uint32_t stack_bound_of(int width) { return (uint32_t)(width - 1) * RT_BVH_MAX_DEPTH + 2; }

static uint32_t nblk_of(uint32_t slots, uint32_t nt)
{
    return slots / QBLK + (nt < slots ? nt : slots) + 3;
}

static int tl_layout(const rt_tracer_ctx *ctx, rt_layout *L, rt_err *e)
{
    const tplan *P = ctx->plan;
    if (!P) return rt_errf(e, "treelet: layout without a plan (internal error)");
    const size_t npix = (size_t)ctx->opt->W * (size_t)ctx->opt->H;
    const uint32_t slots = slots_of(ctx->opt);
    const uint32_t esize = P->width == 2 ? 4 : 8;
    if (rt_reg_geometry(ctx, L, 1, e) < 0) return -1;
    if (rt_mm_add(L, "rays.primary", RT_CLS_RAY, 32, npix, e) < 0) return -1;
    if (rt_mm_add(L, "fb", RT_CLS_FB, 12, npix, e) < 0) return -1;
    if (rt_mm_add(L, "tl.rays", RT_CLS_RAY, RAY_REC, slots, e) < 0) return -1;
    if (rt_mm_add(L, "tl.stack", RT_CLS_STREAM, esize, (uint64_t)slots * stack_bound_of(P->width), e) < 0) return -1;
    if (rt_mm_add(L, "tl.qtable", RT_CLS_QTABLE, 8, P->nt, e) < 0) return -1;
    if (rt_mm_add(L, "tl.queues", RT_CLS_QUEUE, 4, (uint64_t)nblk_of(slots, P->nt) * QBLK, e) < 0) return -1;
    if (rt_mm_add(L, "tl.hits", RT_CLS_HIT, 24, slots, e) < 0) return -1;
    if (rt_render_secondary(ctx->opt) &&
        rt_mm_add(L, "tl.spawn", RT_CLS_RAY, RT_SREC_SIZE, (uint64_t)slots * (uint64_t)levels_of(ctx->opt), e) < 0)
        return -1;
    return 0;
}

static void tl_free(tl_run *T)
{
    while (T->slab) {
        tslab *n = T->slab->next;
        free(T->slab);
        T->slab = n;
    }
    free(T->ray_mem);
    rt_rq_free(&T->rq);
    free(T->want);
    free(T->done);
    free(T->hit);
    free(T->vis);
    free(T->lw);
    free(T->swt);
    free(T->bray);
    free(T->bsray);
    free(T->out);
    free(T->acc);
    free(T->h0);
    free(T->mark);
    free(T->cq);
    free(T->cvis);
    free(T->mv);
    free(T->need);
    free(T->pick);
    free(T->rn);
    free(T->tcur);
    free(T->rcur);
}

/* An array whose entries are all written before they are read (queue
 * blocks, per-slot hits and rays, the secondary modes' shading results):
 * not zeroed, which would cost a pass over memory the run then writes
 * anyway. */
static void *uninit(size_t n, size_t size, rt_err *e) { return rt_reallocarray(NULL, n, size, e); }

static int tl_init(tl_run *T, const rt_tracer_ctx *ctx, rt_image *img, rt_run_stats *st, rt_err *e)
{
    const rt_render_opts *o = ctx->opt;
    const tplan *P = ctx->plan;
    memset(T, 0, sizeof *T);
    if (!P) return rt_errf(e, "treelet: run without a plan (internal error)");
    T->ctx = ctx;
    T->sc = ctx->sc;
    T->b = P->inst ? &P->top : ctx->acc->as;
    T->P = P;
    T->L = ctx->L;
    T->rec = ctx->rec;
    T->img = img;
    T->st = st;
    T->e = e;
    T->npix = (size_t)o->W * (size_t)o->H;
    T->slots = slots_of(o);
    T->nsize = rt_bvh_node_size(P->width);
    T->esize = P->width == 2 ? 4 : 8;
    T->stack_bound = stack_bound_of(P->width);
    T->nslot = rt_scene_model_nslot(T->sc, P->inst != NULL); /* marks and shading records per model slot */
    rt_reg_trav(&T->tv, ctx);
    T->reg_ray = rt_mm_find(T->L, "rays.primary");
    T->reg_fb = rt_mm_find(T->L, "fb");
    T->reg_rays = rt_mm_find(T->L, "tl.rays");
    T->reg_stack = rt_mm_find(T->L, "tl.stack");
    T->reg_qt = rt_mm_find(T->L, "tl.qtable");
    T->reg_q = rt_mm_find(T->L, "tl.queues");
    T->reg_hits = rt_mm_find(T->L, "tl.hits");
    T->reg_spawn = rt_mm_find(T->L, "tl.spawn");
    T->reg_shade = rt_mm_find(T->L, "tri.shade");
    const uint32_t nt = P->nt, ns = T->slots;
    T->secondary = rt_render_secondary(o);
    T->qwrite = o->qstores == RT_QSTORES_STREAM ? RT_WRITE_STREAM : 1;
    const rt_rq_config qc = {.name = "treelet",
                             .nq = nt,
                             .nblk = nblk_of(ns, nt),
                             .esize = sizeof(uint32_t),
                             .maxcount = ns + 1,
                             .order = o->qorder == RT_QORDER_FULLEST ? RT_RQ_FULLEST : RT_RQ_TREE,
                             .levels = T->secondary ? levels_of(o) : 0,
                             .level_cap = ns};
    if (rt_rq_init(&T->rq, &qc, e) < 0 || !(T->ray_mem = rt_calloc((size_t)ns + 1, TRAY_SIZE, e)) ||
        !(T->want = rt_calloc(2 * (size_t)ns, 1, e)) || !(T->done = rt_calloc(ns, 1, e)) ||
        !(T->hit = uninit(ns, sizeof *T->hit, e)) || !(T->bsray = uninit(ns, sizeof *T->bsray, e)) || !(T->mark = rt_calloc(T->nslot ? T->nslot : 1, 1, e)))
        return -1;
    T->ray = (tray *)(void *)((char *)T->ray_mem + (64 - (uintptr_t)T->ray_mem % 64) % 64);
    hint_huge(T->ray_mem, ((size_t)ns + 1) * TRAY_SIZE);
    for (uint32_t s = 0; s < ns; s++) { /* written first (hint_huge) */
        T->ray[s].stk = T->ray[s].inl;
        T->ray[s].cap = INL;
    }
    T->tv.mark = T->mark;
    if (T->secondary) {
        if (!(T->out = uninit(ns, sizeof *T->out, e)) || !(T->bray = uninit(ns, sizeof *T->bray, e)) ||
            !(T->acc = rt_calloc(T->npix, sizeof *T->acc, e)) || !(T->h0 = rt_calloc(T->npix, sizeof *T->h0, e)))
            return -1;
        for (size_t p = 0; p < T->npix; p++) T->h0[p].tri = RT_NO_HIT;
    } else if (!(T->vis = rt_calloc(T->npix, 1, e))) {
        return -1;
    }
    if (ctx->cores) {
        const size_t N = (size_t)ctx->cores->n;
        T->cores = ctx->cores;
        T->ncores = ctx->cores->n;
        T->rec = rt_cores_rec(T->cores, 0);
        if (!(T->cq = rt_calloc(N, sizeof *T->cq, e)) || !(T->cvis = rt_calloc(N, sizeof *T->cvis, e)) ||
            !(T->mv = rt_calloc(ns, 1, e)) || !(T->need = rt_calloc(N, 1, e)) || !(T->pick = rt_calloc(N, sizeof *T->pick, e)) ||
            !(T->rn = rt_calloc(N, sizeof *T->rn, e)) || !(T->tcur = rt_calloc(N, sizeof *T->tcur, e)) ||
            !(T->rcur = rt_calloc(N, sizeof *T->rcur, e)))
            return -1;
    }
    T->authored = rt_shade_authored(T->sc, o) && o->lights && !T->secondary;
    if (T->authored && (!(T->lw = rt_calloc(T->npix * T->sc->nlight, sizeof *T->lw, e)) ||
                        !(T->swt = rt_calloc(ns, sizeof *T->swt, e))))
        return -1;
    return 0;
}

static void report(const tl_run *T, rt_run_stats *st)
{
    const tplan *P = T->P;
    rt_stats_finish(st, &T->tv, T->mark, T->nslot);
    uint64_t sum = 0;
    for (uint32_t t = 0; t < P->nt; t++) sum += P->tbytes[t];
    snprintf(st->extra, sizeof st->extra,
             "budget=%" PRIu64 " treelets=%u treelet_bytes_mean=%.1f treelet_bytes_max=%" PRIu64
             " treelet_depth=%u ray_window=%u enqueues=%" PRIu64 " visits=%" PRIu64 " queue_events=%" PRIu64
             " rays_per_event_mean=%.1f rays_per_event_max=%" PRIu64 " peak_queued=%" PRIu64 " suspends=%" PRIu64
             " stack_writes=%" PRIu64 " stack_reads=%" PRIu64 " stack_spills=%" PRIu64 " stack_refills=%" PRIu64 " stack_max=%u queue_block_reads=%" PRIu64,
             P->budget, P->nt, P->nt ? (double)sum / P->nt : 0.0, P->bytes_max, P->maxdepth, T->slots, T->enq,
             T->visits, T->events, T->events ? (double)T->visits / (double)T->events : 0.0, T->ev_max, T->rq.peak,
             T->susp, T->stack_w, T->stack_r, T->spills, T->refills, T->max_sp, T->qreads);
    if (T->secondary) {
        size_t l = strlen(st->extra);
        snprintf(st->extra + l, sizeof st->extra - l, " batches=%" PRIu64 " rays_secondary=%" PRIu64 " self_hits=%" PRIu64,
                 T->rq.batches, T->nsec, T->self_hits);
    }
    if (T->ncores > 1) { /* simulated cores: rounds, rays moved, the busiest core's share of the visits */
        uint64_t mx = 0;
        for (int k = 0; k < T->ncores; k++) mx = T->cvis[k] > mx ? T->cvis[k] : mx;
        size_t l = strlen(st->extra);
        snprintf(st->extra + l, sizeof st->extra - l, " cores=%d rounds=%" PRIu64 " rays_moved=%" PRIu64
                 " bytes_moved=%" PRIu64 " core_visits_max=%" PRIu64, T->ncores, T->rounds, T->moved, T->moved_bytes, mx);
    }
}

static int tl_run_fn(const rt_tracer_ctx *ctx, rt_image *img, rt_run_stats *st, rt_err *e)
{
    tl_run T;
    int rc = -1;
    uint32_t *order = NULL;
    if (tl_init(&T, ctx, img, st, e) < 0 || !(order = rt_calloc(T.npix, sizeof *order, e))) goto done;
    if (ctx->check && check_plan(T.P, T.b, e) < 0) goto done;
    const size_t ntr = rt_pixel_order_part(ctx->opt, ctx->part, ctx->nparts, order);
    for (size_t k = 0; k < ntr; k += T.slots) {
        const uint32_t n = (uint32_t)(ntr - k < T.slots ? ntr - k : T.slots);
        if ((T.secondary ? window_secondary(&T, order + k, n, e) : window_primary(&T, order + k, n, e)) < 0) goto done;
    }
    report(&T, st);
    rc = 0;
done:
    tl_free(&T);
    free(order);
    return rc;
}

extern const rt_tracer rt_tracer_treelet;

static int tl_check_opts(const rt_render_opts *o, rt_err *e)
{
    const char *opt;
    const uint64_t budget = tl_budget(o, &opt);
    const int k = rt_tracer_accel(&rt_tracer_treelet, o);
    const int width = k == RT_ACCEL_INST ? 2 /* the top level */
                      : rt_accel_bvh_width(k) ? rt_accel_bvh_width(k) : 4; /* the default, bvh4, before the check */
    const uint32_t ns = rt_bvh_node_size(width);
    if (budget < ns)
        return rt_errf_usage(e, "%s: a treelet budget of %" PRIu64 " bytes%s is smaller than one %u-byte bvh%d node", opt,
                             budget, o->gmax ? "" : " (half the cache size)", ns, width);
    return 0;
}

static void tl_params(const rt_render_opts *o, char *buf, size_t n)
{
    int l = snprintf(buf, n, "qorder=%s", o->qorder == RT_QORDER_TREE ? "tree" : "fullest");
    if (l > 0 && (size_t)l < n && o->treelet_tris) l += snprintf(buf + l, n - (size_t)l, " treelet_tris=1");
    if (l > 0 && (size_t)l < n && o->ray_window) snprintf(buf + l, n - (size_t)l, " ray_window=%u", o->ray_window);
}

const rt_tracer rt_tracer_treelet = {
    .name = "treelet",
    .desc = "rays queued at cache-sized BVH treelets (Aila and Karras 2010)",
    .modes = RT_TRACER_ALL_MODES,
    .accels = RT_ACCEL_BVH_BITS | RT_ACCEL_BIT(RT_ACCEL_INST),
    .accel_default = RT_ACCEL_BVH4,
    .opts = RT_OPTG_SCHED | RT_OPTG_QUEUES | RT_OPTG_TREELET | RT_OPTG_THREADS | RT_OPTG_CORES,
    .traits = RT_TR_SCHEDULED | RT_TR_QUEUES | RT_TR_LIGHTS | RT_TR_CORE_PHASES,
    .figures = RT_FIG_TREELET,
    .check_opts = tl_check_opts,
    .params = tl_params,
    .layout = tl_layout,
    .run = tl_run_fn,
    .plan = tl_plan,
    .plan_free = tl_plan_free,
};
