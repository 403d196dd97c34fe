/*
 * dynamic.c -- dynamically scheduled rays (Navrátil et al. 2007, section 2).
 *
 * Rays are traced from the root of the k-d tree down to the first queue
 * point on their path (the "tree top", assumed resident) and appended to
 * that queue point's ray queue in main memory. Queues are then processed
 * one at a time: every ray in the queue traverses the queue point's subtree
 * (whose geometry was chosen to fit in the cache) until it finds its hit or
 * leaves the subtree, in which case it continues through the tree top to
 * its next queue point, or leaves the scene. Rays are processed in
 * generations: all primary rays; then, per point light, shadow rays traced
 * from the light toward the hit points (with a file's own lights,
 * --light-samples: per light and sample, from the sampled point); then
 * newly spawned non-shadow rays (none with the diffuse shading used here).
 *
 * Choices the paper leaves open (docs/tracers.md):
 *   - queue order: fullest queue first (default) or depth-first tree order,
 *     repeated until all queues are empty (--qorder fullest|tree);
 *   - a ray's position is kept as its entry distance t into the next queue
 *     point (the 32-byte record holds origin, direction, pixel id, t); the
 *     exit distance is recomputed from the queue point's cell box, read once
 *     per queue processing (region dyn.qpbox, 24 B per queue point);
 *   - a closest-hit candidate found beyond the subtree's exit (a triangle
 *     reaching into later cells) is kept in the pixel's hit record, flagged
 *     in the ray's pixel id, and settled in a later queue point, so the hit
 *     is exactly the one a single-ray traversal finds (--hit-rule exact);
 *     --hit-rule first tests the hypothesis that the paper's tracer took
 *     such a hit at once (section 2.1.1: a ray "is processed until either
 *     a successful intersection is found or until the ray leaves the
 *     bounds of the subtree"): the ray resolves in the subtree where it
 *     found a hit, a closer hit in a later cell is missed (I7 is not
 *     checked for primary rays then, and images may differ);
 *   - a subtree fits when its nodes, index entries and distinct triangles
 *     fit g_max (--qp-measure all), or, testing the hypothesis that the
 *     paper counted only geometry against the cache because the nodes
 *     stay resident (sections 2.1.1, 2.2), its triangles alone
 *     (--qp-measure triangles);
 *   - queues are chains of 64-ray blocks (2 KB) from a pool with a LIFO
 *     free list; the queue table entry (8 B) is read and written on every
 *     enqueue and when a queue is processed;
 *   - rays popped from a queue pass through a ray buffer of two rays per
 *     modeled thread (region dyn.raybuf), written on load and read when the
 *     ray moves on to another queue;
 *   - when the root is the only queue point (everything fits), rays are
 *     traced straight away without queueing: recursive order; so is a ray
 *     whose interval clipped to the scene's box is empty (no queue point is
 *     entered with an empty interval, yet the single-ray traversal tests
 *     the triangles of the cells at that point, where rounding can place a
 *     hit).
 *
 * Representation. The schedule (the plan, computed once per job from the
 * tree and the budget, and shared read-only by the layout and the run)
 * holds per node: g[] subtree geometry bytes, hastris[] (the subtree lists
 * a triangle), qp[] (queue-point number or -1) and topid[] (entry in the
 * packed tree top, region dyn.top, or -1); per queue point qnode[] (its
 * node). The run's state holds the queues in the ray-queue core (rt_rq,
 * rayq.c): one queue per queue point, chains of 64-entry blocks from a
 * pool with a LIFO free list, each entry a qent (pixel id and interval),
 * the fullest-first buckets and, in the secondary modes, the batch stack;
 * this file models their memory (dyn.qtable, dyn.queues, dyn.spawn) from
 * the blocks and positions the core reports. Per pixel the hit record
 * (hit_t, hit_tri, barycentrics), the visibility bits and resolved[] (rays
 * of the current generation resolved).
 *
 * Invariants, holding between steps (after a generation's rays have been
 * started and after each queue is drained; verified by rt_dyn_check):
 *   I1  queue points: qp numbers 0..nq-1 in node order (depth first) and
 *       qnode is its inverse; a queue point's subtree holds triangles and
 *       fits (g <= gmax) unless it is a leaf; every proper ancestor of a
 *       queue point is a tree-top node; hastris[] is the OR of the leaves'
 *       triangle counts below each node;
 *   I2  tree top: the top interior nodes are exactly the interior nodes
 *       with triangles, no queue point and g > gmax, whose ancestors are all
 *       top interior nodes; there are ntop of them; topid numbers the root,
 *       the top interior nodes and their children depth first 0..ntopent-1
 *       (a below child right after its parent) and is -1 elsewhere;
 *   I3  queues, block pool, buckets and batch stack: the ray-queue core's
 *       Q1-Q5 (queue chains as long as their counts, every block in one
 *       chain or free once, counts summing to the rays queued, every queue
 *       in the bucket of its count, the stack within its levels), checked
 *       by rt_rq_check; what were I4 and I5 here are its Q2 and Q4;
 *   I6  generations: a queued entry holds a pixel traced in this generation
 *       whose ray is not yet resolved, and no pixel is queued twice (a ray is
 *       in one queue at a time); a candidate flag appears only in the
 *       primary generation, on a pixel whose hit record holds a triangle;
 *       resolved[p] <= 1; rays started = rays resolved + rays queued.
 *   I7  resolution (checked as each ray resolves, not between steps): a
 *       ray's closest hit (triangle and t), or a shadow ray's visibility,
 *       is the one the single-ray traversal finds for the same ray.
 *   I8  cores (N > 1 simulated cores only): the running core is < N;
 *       between steps no core holds references not yet interleaved; the
 *       cores' popped rays and drained queues sum to the run's (ev_rays,
 *       events); rays moved <= rays popped; rounds <= events <= N x
 *       rounds; every queued ray's owner is a core < N.
 * check_generation adds the end-of-generation condition: queues empty and
 * every wanted pixel resolved exactly once.
 *
 * Many cores (opt->cores = N > 1, traced through a core sink: sweep
 * --hierarchy ... --cores N; the whitted and path modes stay on one core).
 * The scheduled work units -- a queue point with the rays it holds -- are
 * dealt to cores in rounds, all on one host thread, deterministically:
 *   - a generation's rays are started by the cores in N contiguous runs of
 *     the pixel order (ray k of n by core k * N / n);
 *   - then rounds until the queues are empty: up to N queues are picked in
 *     the queue order (the N fullest, ties as for one core, or the next N
 *     non-empty by number), core i takes the i-th (reads its table entry
 *     and cell box, detaches it) and drains it; rays queued during the
 *     round, also into a queue being drained, wait for a later round;
 *   - a step (a generation's start, a round) ends with a barrier: each
 *     core's references were recorded into its own buffer and are
 *     interleaved in the modeled clock's ticks (run.h: RT_CORE_TICK
 *     references of core 0, then core 1, ..., a core whose step is done
 *     dropping out), the next step starts when all are done.
 * Queues, the queue table, hit records and the frame buffer are shared
 * (one copy, main memory); each core has its own ray buffer (dyn.raybuf
 * moved up by core x the layout's span, as run.h moves a share's scratch).
 * A ray queued by one core and popped by another moves between them: it is
 * counted (rays_moved, bytes_moved = 32 per ray) and its 32-byte record is
 * read by the receiving core as ray state (RT_CLS_RAY) instead of as a
 * queue entry. Every ray follows the same path through the queue points
 * as on one core (its traversal does not depend on the schedule), so
 * images, node visits, triangle tests, enqueues and rays popped are those
 * of one core; only the order, the queue events and the traffic change.
 * N = 1 is the one-core code path, unchanged.
 *
 * Images are bit-identical to the recursive tracer's: the same camera rays,
 * the same closest hit (ties to the lower triangle index), the same shadow
 * test (the shadow segment is intersected as the ray from the offset hit
 * point toward the light, whichever way it is traversed) and the same
 * shading rule applied to the per-light visibility.
 */
#include "dynamic.h"
#include "camera.h"
#include "rayq.h"
#include "regions.h"
#include "run.h"
#include "shade.h"
#include "stats.h"
#include "tracer.h"

#include <inttypes.h>
#include <math.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define QBLK RT_RQ_BLK    /* rays per queue block (64) */
#define CAND_FLAG 0x80000000u

/* ---- queue-point selection ---------------------------------------------- */

/* g[i] under a measure (rt_qp_measure): every byte of the subtree, or
 * only its distinct triangles' (--qp-measure triangles). */
static int subtree_measure(const rt_kdtree *kd, uint32_t ntri, int measure, uint64_t *g, rt_err *e)
{
    rt_kd_subsize *z = rt_calloc(kd->nnodes, sizeof *z, e);
    if (!z || rt_kd_subtree_sizes(kd, ntri, z, e) < 0) {
        free(z);
        return -1;
    }
    for (uint32_t i = 0; i < kd->nnodes; i++)
        g[i] = measure == RT_QPM_TRIANGLES ? 36ull * z[i].ntri : rt_kd_subsize_bytes(&z[i]);
    free(z);
    return 0;
}

int rt_dyn_subtree_geometry(const rt_kdtree *kd, uint32_t ntri, uint64_t *g, rt_err *e)
{
    return subtree_measure(kd, ntri, RT_QPM_ALL, g, e);
}

/* mark[i] = -2 where node i's subtree holds triangles, -3 where it is
 * empty (children have larger indices: one backward pass). */
static void mark_subtrees(const rt_kdtree *kd, int32_t *mark)
{
    for (uint32_t i = kd->nnodes; i-- > 0;) {
        const rt_kdnode *n = &kd->nodes[i];
        int any = rt_kd_is_leaf(n) ? rt_kd_ntri(n) > 0 : (mark[i + 1] == -2 || mark[rt_kd_above(n)] == -2);
        mark[i] = any ? -2 : -3;
    }
}

/* The queue-point walk from the root (marks from mark_subtrees): empty
 * subtrees are crossed in the top; a subtree with triangles whose geometry
 * fits gmax, or a leaf, is the next queue point (depth-first numbers); the
 * nodes above are the top. With qp non-NULL the visited nodes get their
 * queue point or -1 there (qp may be mark itself: a node's mark is read
 * before its qp is written, and only its children, with larger indices,
 * are read after). Touches only the visited nodes. */
static uint32_t select_walk(const rt_kdtree *kd, const uint64_t *g, const int32_t *mark, uint64_t gmax, int32_t *qp,
                            uint32_t *ntop)
{
    uint32_t nq = 0, top = 0;
    uint32_t stack[RT_KD_STACK * 2 + 8];
    int sp = 0;
    stack[sp++] = 0;
    while (sp) {
        uint32_t i = stack[--sp];
        const rt_kdnode *nd = &kd->nodes[i];
        int has_tris = mark[i] == -2;
        if (qp) qp[i] = -1;
        if (!has_tris) continue;
        if (g[i] <= gmax || rt_kd_is_leaf(nd)) {
            if (qp) qp[i] = (int32_t)nq;
            nq++;
            continue;
        }
        top++;
        RT_ASSERT(sp + 2 <= (int)(sizeof stack / sizeof stack[0])); /* the tree's depth bounds the walk */
        stack[sp++] = rt_kd_above(nd); /* below first: depth-first order */
        stack[sp++] = i + 1;
    }
    if (ntop) *ntop = top;
    return nq;
}

uint32_t rt_dyn_select(const rt_kdtree *kd, const uint64_t *g, uint64_t gmax, int32_t *qp, uint32_t *ntop)
{
    /* qp doubles as the marks; the walk overwrites what it visits and the
     * rest becomes -1 */
    mark_subtrees(kd, qp);
    uint32_t nq = select_walk(kd, g, qp, gmax, qp, ntop);
    for (uint32_t i = 0; i < kd->nnodes; i++)
        if (qp[i] < -1) qp[i] = -1;
    return nq;
}

/* hastris[i] = 1 iff node i's subtree holds a triangle (children have
 * larger indices: one backward pass). */
static void mark_hastris(const rt_kdtree *kd, uint8_t *hastris)
{
    for (uint32_t i = kd->nnodes; i-- > 0;) {
        const rt_kdnode *n = &kd->nodes[i];
        hastris[i] = rt_kd_is_leaf(n) ? rt_kd_ntri(n) > 0 : (hastris[i + 1] || hastris[rt_kd_above(n)]);
    }
}

uint64_t rt_dyn_derive_gmax(const rt_kdtree *kd, const uint64_t *g, uint64_t sched_size, uint64_t raybuf_bytes,
                            int *fallback)
{
    if (fallback) *fallback = 0;
    if (sched_size <= raybuf_bytes) return 0;
    int32_t *mark = malloc(sizeof *mark * (kd->nnodes ? kd->nnodes : 1));
    if (!mark) return 0;
    mark_subtrees(kd, mark);
    uint64_t gm = sched_size - raybuf_bytes;
    for (int it = 0; it < 64; it++) {
        uint32_t ntop = 0, nq = select_walk(kd, g, mark, gm, NULL, &ntop);
        uint64_t resident = raybuf_bytes + 8ull * ntop + 8ull * nq;
        uint64_t next = sched_size > resident ? sched_size - resident : 0;
        if (next >= gm) break; /* the selection for gm fits */
        gm = next;
        if (gm == 0) break;
    }
    if (gm == 0) {
        /* The tree top and queue table cannot be resident beside any
         * geometry. Keep the routing structure resident instead (every ray
         * passes through it): the smallest g_max whose top and table fit in
         * half the cache left by the ray buffer; subtree geometry then
         * streams through the other half (docs/tracers.md). g is monotone:
         * a larger g_max never selects more queue points. */
        uint64_t budget = (sched_size - raybuf_bytes) / 2, lo = 1, hi = g[0];
        while (lo < hi) {
            uint64_t mid = lo + (hi - lo) / 2;
            uint32_t ntop = 0, nq = select_walk(kd, g, mark, mid, NULL, &ntop);
            if (8ull * ntop + 8ull * nq <= budget) hi = mid;
            else lo = mid + 1;
        }
        gm = lo;
        if (fallback) *fallback = 1;
    }
    free(mark);
    return gm;
}

/* ---- the plan: queue points and tree top for one tree and budget ------- */

typedef struct dplan {
    uint64_t gmax;     /* geometry budget of a subtree (bytes) */
    int fallback;      /* top could not be resident: half-cache rule used */
    uint32_t nq;       /* queue points */
    uint32_t ntop;     /* top interior nodes (above the queue points) */
    uint32_t ntopent;  /* entries of the packed top (region dyn.top) */
    uint64_t *g;       /* subtree geometry per node */
    int32_t *qp;       /* queue point of node, or -1 */
    uint32_t *qnode;   /* node of queue point (at least one entry) */
    int32_t *topid;    /* packed tree-top entry per node, -1 below queue points */
    uint8_t *hastris;  /* subtree holds triangles */
} dplan;

static uint64_t raybuf_bytes(const rt_render_opts *o) { return 2ull * (uint64_t)o->threads * 32; }

static void dyn_plan_free(void *p)
{
    dplan *P = p;
    if (!P) return;
    free(P->g);
    free(P->qp);
    free(P->qnode);
    free(P->topid);
    free(P->hastris);
    free(P);
}

/* The tree top (interior nodes above the queue points, the queue points and
 * the roots of empty subtrees) is packed depth first into its own region,
 * dyn.top: it is the structure that routes rays to queues and is kept apart
 * from the subtrees so it can stay in cache. */
static void pack_top(const rt_kdtree *kd, dplan *P)
{
    mark_hastris(kd, P->hastris);
    for (uint32_t i = 0; i < kd->nnodes; i++) P->topid[i] = -1;
    uint32_t stack[RT_KD_STACK * 2 + 8], id = 0;
    int sp = 0;
    stack[sp++] = 0;
    while (sp) {
        uint32_t i = stack[--sp];
        P->topid[i] = (int32_t)id++;
        const rt_kdnode *n = &kd->nodes[i];
        if (P->qp[i] >= 0 || !P->hastris[i] || rt_kd_is_leaf(n)) continue;
        RT_ASSERT(sp + 2 <= (int)(sizeof stack / sizeof stack[0])); /* the tree's depth bounds the walk */
        stack[sp++] = rt_kd_above(n);
        stack[sp++] = i + 1;
    }
    P->ntopent = id;
}

static int dyn_plan(const rt_tracer_ctx *ctx, void **out, rt_err *e)
{
    const rt_kdtree *kd = ctx->kd;
    size_t nn = kd->nnodes ? kd->nnodes : 1;
    *out = NULL;
    dplan *P = rt_calloc(1, sizeof *P, e);
    if (!P || !(P->g = rt_calloc(nn, sizeof *P->g, e)) || !(P->qp = rt_calloc(nn, sizeof *P->qp, e)) ||
        !(P->topid = rt_calloc(nn, sizeof *P->topid, e)) || !(P->hastris = rt_calloc(nn, 1, e)) ||
        subtree_measure(kd, ctx->sc->ntri, ctx->opt->qp_measure, P->g, e) < 0) {
        dyn_plan_free(P);
        return -1;
    }
    P->gmax = ctx->opt->gmax ? ctx->opt->gmax
                             : rt_dyn_derive_gmax(kd, P->g, ctx->opt->sched_size, raybuf_bytes(ctx->opt), &P->fallback);
    P->nq = rt_dyn_select(kd, P->g, P->gmax, P->qp, &P->ntop);
    if (!(P->qnode = rt_calloc(P->nq ? P->nq : 1, sizeof *P->qnode, e))) {
        dyn_plan_free(P);
        return -1;
    }
    for (uint32_t n = 0; n < kd->nnodes; n++)
        if (P->qp[n] >= 0) P->qnode[P->qp[n]] = n;
    pack_top(kd, P);
    *out = P;
    return 0;
}

/* ---- scheduler state ------------------------------------------------------ */

typedef struct qent {
    uint32_t pix;  /* pixel id; CAND_FLAG: a candidate hit is pending */
    float t0, t1;  /* interval within the queue point's cell */
} qent;

/* Why rays enter queue points: every enqueue is counted once among the
 * first four causes (first_* for a ray's first queue point, exit and cand
 * for re-entries), and independently by the queue point it enters (small,
 * leaf); visits are rays processed in a queue point's subtree. Appended to
 * the statistics only with opt->queue_stats (docs/results.md). */
typedef struct qstat {
    uint64_t first_primary;   /* first queue point of a primary (generation 0) ray */
    uint64_t first_secondary; /* first queue point of a reflected, refracted or path ray */
    uint64_t first_shadow;    /* first queue point of a shadow ray (traced from its light) */
    uint64_t exit;            /* re-entry: left a subtree with no hit (or not occluded) */
    uint64_t cand;            /* re-entry: a hit found beyond the subtree's exit (a triangle
                               * in several cells) must be settled further on */
    uint64_t small;           /* into a queue point holding at most gmax/8 bytes of geometry */
    uint64_t leaf;            /* into a queue point that is a leaf */
    uint64_t visits;          /* rays processed in a subtree */
    uint64_t v_notest;        /* ... that tested no triangle there (crossed only empty cells) */
    uint64_t v_cand;          /* ... that carried a candidate hit */
    uint64_t v_cand_kept;     /* ... whose candidate stayed the best (visit only settled it) */
} qstat;

struct rt_dyn {
    const rt_tracer_ctx *ctx;
    const rt_scene *sc;
    const rt_kdtree *kd;
    const rt_layout *L;
    const dplan *P;      /* the schedule (I1, I2) */
    rt_rec *rec;
    rt_trav tv;
    int reg_shade, reg_ray, reg_fb, reg_hits, reg_qt, reg_q, reg_box, reg_rb, reg_top;
    const int32_t *topid;   /* = P->topid */
    const uint8_t *hastris; /* = P->hastris */
    uint64_t gmax;          /* = P->gmax */
    const int32_t *qp;      /* = P->qp */
    const uint32_t *qnode;  /* = P->qnode */
    uint32_t nq, ntop;      /* = P->nq, P->ntop */
    size_t npix;         /* W x H */
    /* the queues, their block pool and buckets, the batch stack (I3: the
     * ray-queue core's Q1-Q5, rayq.c); entries are qent */
    rt_rq rq;
    /* per-pixel state (I6) */
    rt_cam_frame cam;
    float *hit_t;
    uint32_t *hit_tri;
    float *hit_u, *hit_v; /* barycentrics of the final hit */
    uint8_t *vis;        /* bit i: light i visible */
    uint8_t *resolved;   /* rays of this generation resolved per pixel */
    uint8_t *want;       /* pixel has a ray in this generation */
    int shadow;          /* current generation: 0 primary, 1 shadow */
    int light;           /* light of the shadow generation */
    uint32_t sample;     /* authored lights: sample of the shadow generation */
    int authored;        /* the file's lights (--light-samples; shade.h): one generation per light and sample */
    float *lw, *swt;     /* authored: per pixel x light the unoccluded weights; per pixel this sample's weight */
    uint32_t rbslot, rbslots;
    /* statistics */
    uint64_t events, ev_rays, ev_max, enq, created, done;
    uint32_t *qtimes;    /* times each queue was processed */
    uint8_t *mark;
    rt_image *img;
    rt_run_stats *st;
    rt_err *e;           /* receives a broken invariant's message */
    int err;             /* 1: block pool exhausted; 2: invariant broken (message in e) */
    /* secondary modes: a batch of rays in slots 0..nb-1 (slot ids take the
     * place of pixel ids in the queues, hit records and checks) */
    int secondary;       /* whitted or path mode */
    rt_ray *bray;        /* ray per slot (NULL: slot = pixel, camera rays) */
    rt_ray *bsray;       /* shadow ray per slot for the current light */
    uint32_t *bpix;      /* pixel per slot */
    rt_shade_out *out;   /* step result per slot */
    rt_acc *acc;         /* pixel sums */
    rt_hit *h0;          /* primary hit per pixel (depth channel) */
    int reg_spawn;       /* the batch stack (in rq) writes level l's rays at l * npix */
    uint64_t nsec, self_hits;
    qstat qs;            /* why rays enter queue points (opt->queue_stats) */
    /* simulated cores (I8; opt->cores > 1 with a core sink, ctx->cs) */
    int ncores;          /* 1: one core, rec = ctx->rec (everything below unused) */
    int core;            /* the core whose references are being recorded: rec = crec[core] */
    rt_rec **crec;       /* per core: its recorder, into cbuf[core] */
    struct corebuf *cbuf; /* per core: its references of the current step, not yet interleaved */
    uint32_t *crbslot;   /* per core: its ray-buffer slot counter (rbslot is the running core's) */
    uint8_t *owner;      /* per ray slot: the core that queued it (valid while it is queued) */
    uint64_t span;       /* core k's ray buffer is dyn.raybuf moved up by k x span */
    uint64_t *core_rays; /* per core: rays it popped from queues */
    uint64_t *core_events; /* per core: queues it drained */
    uint64_t rounds, moved; /* rounds of queue work; popped rays another core had queued */
    uint32_t *pick;      /* a round's queues, core i drains pick[i] */
    uint32_t *pick_n;    /* ... and how many rays it took from it */
    rt_rq_cur *pick_cur; /* ... and its cursor over them */
    uint32_t tcur;       /* tree order: where the next round's pick starts */
    /* host threads (render --threads N, untraced): the N-core rounds, core
     * i's queue drained on host thread i by its worker copy wk[i] */
    int threaded;        /* 1: the rounds run on host threads */
    struct rt_dyn *wk;   /* per core: the worker's copy of the run's state, for one round */
    struct wstage *ws;   /* per core: its popped rays and the rays it queued in the round */
    uint8_t *wmark;      /* per core: its triangle marks (ntri bytes each), or-ed in at the end */
    rt_err *werr;        /* per core: its error */
    struct wstage *stage; /* a worker: where enqueue stages its rays (NULL: the queues) */
    pthread_t *wtid;     /* per core: its host thread (cores 1..N-1, started at the first round) */
    struct wpool *pool;  /* the workers' rendezvous */
};
typedef struct rt_dyn dyn;

/* A worker's round: the rays it pops (list, popped by the main thread
 * before the round) and those it queues (q[i], e[i]: pushed by the main
 * thread after the round, core by core in order, as the one-thread rounds
 * push them). */
typedef struct wstage {
    struct qent *list;
    uint32_t nlist, caplist;
    uint32_t *q;
    struct qent *e;
    size_t n, cap;
    int oom;
} wstage;

/* A core's references of the current step (a generation's start, a round
 * of queues), held until every core's are known and interleaved. */
typedef struct corebuf {
    rt_sink sink;  /* the core's recorder hands its full buffers here */
    rt_access *a;
    size_t n, cap;
} corebuf;

static int corebuf_put(rt_sink *s, const rt_access *a, size_t n)
{
    corebuf *b = s->ctx;
    if (b->n + n > b->cap) {
        size_t cap = b->cap ? b->cap : 4 * RT_REC_BUF;
        while (cap < b->n + n) cap *= 2;
        rt_access *x = realloc(b->a, cap * sizeof *x);
        if (!x) return -1;
        b->a = x;
        b->cap = cap;
    }
    memcpy(b->a + b->n, a, n * sizeof *a);
    b->n += n;
    return 0;
}

/* Makes core k the one whose references are recorded (its recorder, its
 * ray-buffer slot). */
static void set_core(dyn *D, int k)
{
    if (D->ncores <= 1 || k == D->core) return;
    D->crbslot[D->core] = D->rbslot;
    D->core = k;
    D->rbslot = D->crbslot[k];
    if (D->crec) {
        D->rec = D->crec[k];
        D->tv.rec = D->rec;
    }
}

/* The start of a generation: ray k of n is started by core k * N / n
 * (N contiguous runs of the pixel order, one per core). */
static void start_core(dyn *D, size_t k, size_t n)
{
    if (D->ncores > 1) set_core(D, (int)((uint64_t)k * (uint64_t)D->ncores / (uint64_t)n));
}

/* The end of a step: the cores' references in the modeled clock's ticks
 * (run.h: RT_CORE_TICK references of core 0, then of core 1, ..., a core
 * whose step's references are used up dropping out), handed to the core
 * sink; the cores meet there (a barrier) before the next step. */
static void interleave(dyn *D)
{
    if (D->ncores <= 1 || !D->crec) return;
    const unsigned N = (unsigned)D->ncores;
    for (unsigned k = 0; k < N; k++)
        if (rt_rec_flush(D->crec[k]) < 0 && !D->err) D->err = 3;
    rt_csink *cs = D->ctx->cs;
    for (size_t at = 0, any = 1; any && !D->err; at += RT_CORE_TICK) {
        any = 0;
        for (unsigned k = 0; k < N; k++) {
            const corebuf *b = &D->cbuf[k];
            if (b->n <= at) continue;
            const size_t m = b->n - at < RT_CORE_TICK ? b->n - at : RT_CORE_TICK;
            if (cs->put(cs, k, b->a + at, m) < 0) {
                D->err = 3;
                break;
            }
            any = 1;
        }
    }
    for (unsigned k = 0; k < N; k++) D->cbuf[k].n = 0;
}

/* The pixel a ray slot belongs to. */
static inline uint32_t PIX(const dyn *D, uint32_t slot) { return D->bpix ? D->bpix[slot] : slot; }

/* Rays of the current generation are made from the pixel id alone, so the
 * queues need not hold their 32-byte contents in host memory (they are
 * modeled in dyn.queues). */
static void make_rays(dyn *D, uint32_t pix, rt_ray *trav, rt_ray *test)
{
    if (D->bray) {
        if (!D->shadow) {
            *trav = *test = D->bray[pix];
            return;
        }
        *test = D->bsray[pix];
        rt_ray_init(trav, D->sc->light[D->light], rt_sub(test->o, D->sc->light[D->light]));
        trav->tmin = 0.0f;
        trav->tmax = 1.0f;
        return;
    }
    int x = (int)(pix % (uint32_t)D->cam.W), y = (int)(pix / (uint32_t)D->cam.W);
    rt_ray eye;
    rt_cam_ray(&D->cam, x, y, &eye);
    if (!D->shadow) {
        *trav = eye;
        *test = eye;
        return;
    }
    rt_hit h = {D->hit_t[pix], D->hit_tri[pix], D->hit_u[pix], D->hit_v[pix]};
    if (D->authored) { /* from the segment's far end (the light's point) back to the hit */
        float w;
        uint32_t tri;
        rt_shade_sample_ray(D->sc, D->ctx->opt, &eye, &h, (uint32_t)D->light, D->sample, test, &w, &tri);
        rt_vec3 end = rt_add(test->o, test->d);
        rt_ray_init(trav, end, rt_sub(test->o, end));
        trav->tmin = 0.0f;
        trav->tmax = 1.0f;
        return;
    }
    rt_shade_ray(D->sc, &eye, &h, D->light, test);
    rt_ray_init(trav, D->sc->light[D->light], rt_sub(test->o, D->sc->light[D->light]));
    trav->tmin = 0.0f;
    trav->tmax = 1.0f;
}

/* ---- queues ---------------------------------------------------------------- */

static uint64_t qaddr(const dyn *D, uint64_t at) { return rt_mm_addr(D->L, D->reg_q, at); }

/* The running core's current ray-buffer slot (each core has its own buffer). */
static uint64_t rbaddr(const dyn *D)
{
    return rt_mm_addr(D->L, D->reg_rb, D->rbslot % D->rbslots) + (uint64_t)D->core * D->span;
}

static void enqueue(dyn *D, uint32_t q, uint32_t pix, float t0, float t1)
{
    if (D->stage) { /* a worker's round (untraced): staged for the main thread */
        wstage *w = D->stage;
        if (w->n == w->cap) {
            size_t cap = w->cap ? 2 * w->cap : 1024;
            uint32_t *nq = realloc(w->q, cap * sizeof *nq);
            if (nq) w->q = nq;
            qent *ne = nq ? realloc(w->e, cap * sizeof *ne) : NULL;
            if (!ne) {
                w->oom = 1;
                D->err = 1;
                return;
            }
            w->e = ne;
            w->cap = cap;
        }
        w->q[w->n] = q;
        w->e[w->n++] = (qent){pix, t0, t1};
        D->owner[pix & ~CAND_FLAG] = (uint8_t)D->core;
        D->enq++;
        return;
    }
    RT_REC(D->rec, rt_mm_addr(D->L, D->reg_qt, q), 8, 0, RT_CLS_QTABLE);
    uint64_t at;
    qent *e = rt_rq_push(&D->rq, q, &at);
    if (!e) {
        D->err = 1;
        return;
    }
    e->pix = pix;
    e->t0 = t0;
    e->t1 = t1;
    if (D->owner) D->owner[pix & ~CAND_FLAG] = (uint8_t)D->core;
    /* streaming stores: a block's lines are filled whole (two records each)
     * before the queue is drained, so they need not be fetched */
    RT_REC(D->rec, qaddr(D, at), 32, D->ctx->opt->qstores == RT_QSTORES_STREAM ? RT_WRITE_STREAM : 1, RT_CLS_QUEUE);
    RT_REC(D->rec, rt_mm_addr(D->L, D->reg_qt, q), 8, 1, RT_CLS_QTABLE);
    D->enq++;
}

/* ---- traversal ------------------------------------------------------------- */

typedef struct tstack {
    uint32_t node;
    float t0, t1;
} tstack;

/* One front-to-back step at an interior node (rt_kd_step, the rule of
 * every k-d walk): returns the child to visit next, narrowing *tmax and
 * pushing the far child when the ray visits both. */
static inline uint32_t interior_step(const rt_kdnode *nd, uint32_t node, const rt_ray *r, float tmin, float *tmax,
                                     tstack *stack, int *sp)
{
    int axis = rt_kd_axis(nd);
    float split = rt_kd_split(nd);
    /* the axis-th component by index, not rt_axis's branches */
    const float o = ((const float *)(const void *)&r->o)[axis], d = ((const float *)(const void *)&r->d)[axis];
    const float tp = (split - o) * ((const float *)(const void *)&r->inv_d)[axis];
    int below_first = o < split || (o == split && d <= 0);
    uint32_t nearc = below_first ? node + 1 : rt_kd_above(nd);
    uint32_t farc = below_first ? rt_kd_above(nd) : node + 1;
    float near_end, far_start;
    const int step = rt_kd_step(tp, tmin, *tmax, &near_end, &far_start);
    if (step == RT_KD_NEAR) return nearc;
    if (step == RT_KD_FAR) return farc;
    RT_ASSERT(*sp < RT_KD_STACK); /* a tree no deeper than RT_KD_STACK: no far child is dropped */
    if (*sp < RT_KD_STACK) {
        stack[*sp].node = farc;
        stack[*sp].t0 = far_start;
        stack[*sp].t1 = *tmax;
        (*sp)++;
    }
    *tmax = near_end;
    return nearc;
}

/* Descends the tree top from the root over [t0, t1] of r and returns the
 * first queue point (other than skip) the ray enters with a non-empty
 * interval, or -1 when it leaves the scene first. */
static int32_t to_queue_point(dyn *D, const rt_ray *r, float t0, float t1, int32_t skip, float *qa, float *qb)
{
    const rt_kdtree *kd = D->kd;
    tstack stack[RT_KD_STACK];
    int sp = 0;
    uint32_t node = 0;
    float tmin = t0, tmax = t1;
    for (;;) {
        const rt_kdnode *nd = &kd->nodes[node];
        RT_REC(D->rec, rt_mm_addr(D->L, D->reg_top, (uint64_t)D->topid[node]), 8, 0, RT_CLS_NODE);
        D->tv.nodes++;
        int32_t q = D->qp[node];
        if (q >= 0) {
            if (q != skip && tmax > tmin) {
                *qa = tmin;
                *qb = tmax;
                return q;
            }
        } else if (D->hastris[node] && !rt_kd_is_leaf(nd)) {
            node = interior_step(nd, node, r, tmin, &tmax, stack, &sp);
            continue;
        }
        if (!sp) return -1;
        sp--;
        node = stack[sp].node;
        tmin = stack[sp].t0;
        tmax = stack[sp].t1;
    }
}

/* Tests the triangles of a leaf against one ray (rt_kd_leaf: recorded,
 * counted and marked through D->tv, whose recorder and marks are D's).
 * Returns 1 when a shadow ray is occluded. */
static int leaf_test(dyn *D, const rt_kdnode *nd, const rt_ray *test, float *best_t, uint32_t *best_tri)
{
    const uint32_t node = (uint32_t)(nd - D->kd->nodes);
    if (D->shadow) return rt_kd_leaf(&D->tv, test, node, NULL, 1);
    rt_hit h = {*best_t, *best_tri, 0.0f, 0.0f};
    rt_kd_leaf(&D->tv, test, node, &h, 0);
    *best_t = h.t;
    *best_tri = h.tri;
    return 0;
}

/* Traverses the subtree at node over [a, b] (front to back, pbrt rules).
 * Returns 1 when a shadow ray is occluded. */
static int subtree(dyn *D, uint32_t root, const rt_ray *trav, const rt_ray *test, float a, float b, float *best_t,
                   uint32_t *best_tri)
{
    const rt_kdtree *kd = D->kd;
    tstack stack[RT_KD_STACK];
    int sp = 0;
    uint32_t node = root;
    float tmin = a, tmax = b;
    for (;;) {
        /* past the best hit: skip this entry, not the rest (an entry pushed
         * by a ray lying in a split plane can begin before those above it) */
        if (!D->shadow && *best_tri != RT_NO_HIT && rt_kd_past(*best_t, tmin)) goto pop;
        const rt_kdnode *nd = &kd->nodes[node];
        RT_REC(D->rec, rt_mm_addr(D->L, D->tv.reg_node, node), 8, 0, RT_CLS_NODE);
        D->tv.nodes++;
        if (rt_kd_is_leaf(nd)) {
            if (leaf_test(D, nd, test, best_t, best_tri)) return 1;
        } else {
            node = interior_step(nd, node, trav, tmin, &tmax, stack, &sp);
            continue;
        }
    pop:
        if (!sp) return 0;
        sp--;
        node = stack[sp].node;
        tmin = stack[sp].t0;
        tmax = stack[sp].t1;
    }
}

/* ---- resolution ------------------------------------------------------------ */

/* Test mode: the closest hit (or the visibility) a ray is resolved with
 * must be the one the single-ray traversal finds for the same ray (I7).
 * The reference runs unrecorded and uncounted. */
static void check_resolution(dyn *D, uint32_t pix, uint32_t tri, float t, int visible)
{
    /* the first-hit rule gives up I7 for primary rays by design */
    if (!D->ctx->check || D->err || (!D->shadow && D->ctx->opt->hit_rule == RT_HIT_FIRST)) return;
    rt_ray trav, test;
    make_rays(D, pix, &trav, &test);
    rt_trav ref = D->tv;
    ref.rec = NULL;
    ref.mark = NULL;
    if (D->shadow) {
        int vis = !rt_kd_occluded(&ref, &test);
        if (vis != visible) {
            rt_errf(D->e, "dynamic I7: shadow ray %u resolved %s, the single-ray traversal finds it %s", pix,
                    visible ? "visible" : "occluded", vis ? "visible" : "occluded");
            D->err = 2;
        }
        return;
    }
    rt_hit h;
    rt_kd_closest(&ref, &test, &h);
    if (h.tri != tri || (tri != RT_NO_HIT && h.t != t)) {
        rt_errf(D->e, "dynamic I7: ray %u resolved with triangle %d at t %a, the single-ray traversal finds %d at %a", pix,
                tri == RT_NO_HIT ? -1 : (int)tri, t, h.tri == RT_NO_HIT ? -1 : (int)h.tri, h.t);
        D->err = 2;
    }
}

static void resolve_primary(dyn *D, uint32_t pix, float t, uint32_t tri, int tri_cached)
{
    check_resolution(D, pix, tri, t, 0);
    D->resolved[pix]++;
    D->done++;
    D->hit_t[pix] = t;
    D->hit_tri[pix] = tri;
    if (tri != RT_NO_HIT) {
        /* barycentrics of the final hit: the same test on the same ray
         * gives the same t, u, v as during traversal */
        rt_ray eye;
        float tt;
        if (D->bray) eye = D->bray[pix];
        else rt_cam_ray(&D->cam, (int)(pix % (uint32_t)D->cam.W), (int)(pix / (uint32_t)D->cam.W), &eye);
        rt_isect_tri(&eye, &D->sc->tri[tri], &tt, &D->hit_u[pix], &D->hit_v[pix]);
    }
    if (D->secondary) {
        /* the pixel sum is read, added to and written back per ray */
        uint32_t px = PIX(D, pix);
        if (tri == RT_NO_HIT) {
            RT_REC(D->rec, rt_mm_addr(D->L, D->reg_hits, pix), 4, 1, RT_CLS_HIT);
        } else {
            if (!tri_cached) RT_REC(D->rec, rt_mm_addr(D->L, D->tv.reg_tri, tri), 36, 0, RT_CLS_TRI);
            rt_reg_shade(D->ctx, D->rec, tri);
            RT_REC(D->rec, rt_mm_addr(D->L, D->reg_hits, pix), 24, 1, RT_CLS_HIT);
        }
        RT_REC(D->rec, rt_mm_addr(D->L, D->reg_fb, px), 12, 0, RT_CLS_FB);
        RT_REC(D->rec, rt_mm_addr(D->L, D->reg_fb, px), 12, 1, RT_CLS_FB);
        return;
    }
    if (tri == RT_NO_HIT) {
        RT_REC(D->rec, rt_mm_addr(D->L, D->reg_hits, pix), 4, 1, RT_CLS_HIT);
        RT_REC(D->rec, rt_mm_addr(D->L, D->reg_fb, pix), 12, 1, RT_CLS_FB);
        return;
    }
    /* The hit record keeps t, triangle, offset origin and facing mask for
     * the shadow generations; computing them needs the triangle's vertices
     * (in cache when the hit was found in this subtree). */
    if (!tri_cached) RT_REC(D->rec, rt_mm_addr(D->L, D->tv.reg_tri, tri), 36, 0, RT_CLS_TRI);
    RT_REC(D->rec, rt_mm_addr(D->L, D->reg_shade, tri), 16, 0, RT_CLS_SHADE);
    RT_REC(D->rec, rt_mm_addr(D->L, D->reg_hits, pix), 24, 1, RT_CLS_HIT);
    RT_REC(D->rec, rt_mm_addr(D->L, D->reg_fb, pix), 12, 1, RT_CLS_FB);
}

static void resolve_shadow(dyn *D, uint32_t pix, int visible)
{
    check_resolution(D, pix, RT_NO_HIT, 0.0f, visible);
    D->resolved[pix]++;
    D->done++;
    if (!visible) return;
    if (D->authored) D->lw[(size_t)pix * D->sc->nlight + (size_t)D->light] += D->swt[pix];
    else D->vis[pix] |= (uint8_t)(1u << D->light);
    if (D->secondary) rt_acc_add(&D->acc[PIX(D, pix)], D->out[pix].lc[D->light]);
    RT_REC(D->rec, rt_mm_addr(D->L, D->reg_fb, PIX(D, pix)), 12, 0, RT_CLS_FB);
    RT_REC(D->rec, rt_mm_addr(D->L, D->reg_fb, PIX(D, pix)), 12, 1, RT_CLS_FB);
}

/* Moves a ray on from tmin: to its next queue point, or resolves it. */
static void advance(dyn *D, uint32_t pixf, const rt_ray *trav, float tmin, float tmax, int32_t skip, float best_t,
                    uint32_t best_tri, int from_buffer)
{
    uint32_t pix = pixf & ~CAND_FLAG;
    float qa, qb;
    uint64_t n0 = D->tv.nodes;
    /* With a candidate hit only cells the single-ray traversal would still
     * enter (rt_kd_past: entered before the hit, with its margin) can hold a
     * closer or equal-t, lower-index hit: stop the search there. */
    if (!D->shadow && best_tri != RT_NO_HIT) {
        float lim = nextafterf(best_t / (1.0f - 1.0f / 65536.0f), INFINITY);
        if (lim < tmax) tmax = lim;
    }
    int32_t q = tmax > tmin ? to_queue_point(D, trav, tmin, tmax, skip, &qa, &qb) : -1;
    D->img->nodes[PIX(D, pix)] += (float)(D->tv.nodes - n0);
    if (q >= 0) {
        qstat *S = &D->qs;
        if (from_buffer && (pixf & CAND_FLAG)) S->cand++;
        else if (from_buffer) S->exit++;
        else if (D->shadow) S->first_shadow++;
        else if (D->tv.mark_bit == 1) S->first_primary++;
        else S->first_secondary++;
        S->small += D->P->g[D->qnode[q]] <= D->gmax / 8;
        S->leaf += rt_kd_is_leaf(&D->kd->nodes[D->qnode[q]]);
        if (from_buffer) RT_REC(D->rec, rbaddr(D), 32, 0, RT_CLS_RAY);
        enqueue(D, (uint32_t)q, pixf, qa, qb);
        return;
    }
    if (D->shadow) resolve_shadow(D, pix, 1);
    else resolve_primary(D, pix, best_t, best_tri, 0);
}

/* Processes one ray popped from queue q. */
static void process(dyn *D, uint32_t q, const qent *e)
{
    uint32_t pix = e->pix & ~CAND_FLAG;
    rt_ray trav, test;
    make_rays(D, pix, &trav, &test);
    float best_t = INFINITY;
    uint32_t best_tri = RT_NO_HIT;
    if (e->pix & CAND_FLAG) {
        RT_REC(D->rec, rt_mm_addr(D->L, D->reg_hits, pix), 8, 0, RT_CLS_HIT);
        best_t = D->hit_t[pix];
        best_tri = D->hit_tri[pix];
    }
    uint32_t root = D->qnode[q];
    uint64_t n0 = D->tv.nodes, k0 = D->tv.tests;
    const uint32_t cand_tri = best_tri;
    int occluded = subtree(D, root, &trav, &test, e->t0, e->t1, &best_t, &best_tri);
    D->qs.visits++;
    D->qs.v_notest += D->tv.tests == k0;
    if (e->pix & CAND_FLAG) {
        D->qs.v_cand++;
        D->qs.v_cand_kept += best_tri == cand_tri;
    }
    D->img->nodes[PIX(D, pix)] += (float)(D->tv.nodes - n0);
    D->img->tests[PIX(D, pix)] += (float)(D->tv.tests - k0);
    if (D->shadow) {
        if (occluded) {
            resolve_shadow(D, pix, 0);
            return;
        }
    } else if (best_tri != RT_NO_HIT && (rt_kd_past(best_t, e->t1) || D->ctx->opt->hit_rule == RT_HIT_FIRST)) {
        resolve_primary(D, pix, best_t, best_tri, 1);
        return;
    }
    uint32_t pixf = pix;
    if (!D->shadow && best_tri != RT_NO_HIT) {
        /* candidate beyond this subtree: park it in the hit record */
        if (!(e->pix & CAND_FLAG) || D->hit_tri[pix] != best_tri || D->hit_t[pix] != best_t)
            RT_REC(D->rec, rt_mm_addr(D->L, D->reg_hits, pix), 8, 1, RT_CLS_HIT);
        D->hit_t[pix] = best_t;
        D->hit_tri[pix] = best_tri;
        pixf |= CAND_FLAG;
    }
    float t0, t1;
    rt_kd_clip(D->kd, &trav, &t0, &t1);
    advance(D, pixf, &trav, e->t1, t1, (int32_t)q, best_t, best_tri, 1);
}

/* Oversized leaf queue point: blocks of rays against blocks of geometry. */
static void process_oversized(dyn *D, uint32_t q, const qent *es, uint32_t n)
{
    const rt_kdnode *nd = &D->kd->nodes[D->qnode[q]];
    uint32_t ntri = rt_kd_ntri(nd), first = rt_kd_first(nd);
    uint32_t gblk = (uint32_t)(D->gmax / 40);
    if (gblk < 1) gblk = 1;
    rt_ray trav[256], test[256];
    float bt[256];
    uint32_t btri[256];
    uint8_t occl[256];
    RT_REC(D->rec, rt_mm_addr(D->L, D->tv.reg_node, D->qnode[q]), 8, 0, RT_CLS_NODE);
    for (uint32_t i = 0; i < n; i++) {
        uint32_t pix = es[i].pix & ~CAND_FLAG;
        make_rays(D, pix, &trav[i], &test[i]);
        bt[i] = INFINITY;
        btri[i] = RT_NO_HIT;
        occl[i] = 0;
        D->tv.nodes++;
        if (es[i].pix & CAND_FLAG) {
            RT_REC(D->rec, rt_mm_addr(D->L, D->reg_hits, pix), 8, 0, RT_CLS_HIT);
            bt[i] = D->hit_t[pix];
            btri[i] = D->hit_tri[pix];
        }
    }
    for (uint32_t g0 = 0; g0 < ntri; g0 += gblk) {
        uint32_t g1 = g0 + gblk < ntri ? g0 + gblk : ntri;
        RT_REC(D->rec, rt_mm_addr(D->L, D->tv.reg_idx, first + g0), 4 * (g1 - g0), 0, RT_CLS_INDEX);
        for (uint32_t k = g0; k < g1; k++) {
            uint32_t tri = D->kd->idx[first + k];
            int read = 0;
            for (uint32_t i = 0; i < n; i++) {
                if (occl[i]) continue;
                if (!read) {
                    RT_REC(D->rec, rt_mm_addr(D->L, D->tv.reg_tri, tri), 36, 0, RT_CLS_TRI);
                    if (D->mark) D->mark[tri] |= D->tv.mark_bit;
                    read = 1;
                }
                float t, u, v;
                D->tv.tests++;
                D->img->tests[PIX(D, es[i].pix & ~CAND_FLAG)] += 1;
                if (!rt_isect_core(&test[i], &D->sc->tri[tri], &t, &u, &v) || !(t > test[i].tmin && t < test[i].tmax))
                    continue;
                if (D->shadow) {
                    if (!rt_alpha_cut(D->sc->alpha, &D->tv.alpha, D->rec, &test[i], tri, u, v)) occl[i] = 1;
                } else if ((btri[i] == RT_NO_HIT || t < bt[i] || (t == bt[i] && tri < btri[i])) &&
                           !rt_alpha_cut(D->sc->alpha, &D->tv.alpha, D->rec, &test[i], tri, u, v)) {
                    bt[i] = t;
                    btri[i] = tri;
                }
            }
        }
    }
    for (uint32_t i = 0; i < n; i++) {
        uint32_t pix = es[i].pix & ~CAND_FLAG;
        D->qs.visits++;
        if (es[i].pix & CAND_FLAG) {
            D->qs.v_cand++;
            D->qs.v_cand_kept += btri[i] == D->hit_tri[pix];
        }
        if (D->shadow && occl[i]) {
            resolve_shadow(D, pix, 0);
            continue;
        }
        if (!D->shadow && btri[i] != RT_NO_HIT && (rt_kd_past(bt[i], es[i].t1) || D->ctx->opt->hit_rule == RT_HIT_FIRST)) {
            resolve_primary(D, pix, bt[i], btri[i], 0);
            continue;
        }
        uint32_t pixf = pix;
        if (!D->shadow && btri[i] != RT_NO_HIT) {
            RT_REC(D->rec, rt_mm_addr(D->L, D->reg_hits, pix), 8, 1, RT_CLS_HIT);
            D->hit_t[pix] = bt[i];
            D->hit_tri[pix] = btri[i];
            pixf |= CAND_FLAG;
        }
        float t0, t1;
        rt_kd_clip(D->kd, &trav[i], &t0, &t1);
        advance(D, pixf, &trav[i], es[i].t1, t1, (int32_t)q, bt[i], btri[i], 1);
    }
}

/* Detaches queue q for the running core (its table entry and cell box
 * read): returns its count, *cur walks its rays. */
static uint32_t drain_take(dyn *D, uint32_t q, rt_rq_cur *cur)
{
    uint32_t n = D->rq.count[q];
    if (!n) return 0;
    D->events++;
    D->ev_rays += n;
    if (n > D->ev_max) D->ev_max = n;
    D->qtimes[q]++;
    if (D->core_rays) {
        D->core_rays[D->core] += n;
        D->core_events[D->core]++;
    }
    RT_REC(D->rec, rt_mm_addr(D->L, D->reg_qt, q), 8, 0, RT_CLS_QTABLE);
    RT_REC(D->rec, rt_mm_addr(D->L, D->reg_box, q), 24, 0, RT_CLS_QTABLE);
    rt_rq_take(&D->rq, q, cur);
    return n;
}

/* Pops and processes the n rays of queue q detached by drain_take. A ray
 * another core queued moves to the running core: its 32-byte record is
 * read as ray state (RT_CLS_RAY) there, not as a queue entry. */
static void drain_pop(dyn *D, uint32_t q, rt_rq_cur *curp, uint32_t n)
{
    rt_rq_cur cur = *curp;
    const qent *list = D->stage ? D->stage->list : NULL; /* a worker: popped for it */
    const rt_kdnode *nd = &D->kd->nodes[D->qnode[q]];
    int oversized = rt_kd_is_leaf(nd) && 40ull * rt_kd_ntri(nd) > D->gmax;
    qent batch[256];
    uint32_t nb = 0, bsz = D->rbslots < 256 ? D->rbslots : 256;
    while (n) {
        qent e;
        int moved = 0;
        if (list) {
            e = *list++;
        } else if (D->owner) {
            const qent *pe = rt_rq_at(&D->rq, &cur);
            moved = D->owner[pe->pix & ~CAND_FLAG] != (uint8_t)D->core;
            D->moved += (uint64_t)moved;
        }
        if (!list) {
            RT_REC(D->rec, qaddr(D, (uint64_t)cur.b * RT_RQ_BLK + cur.pos), 32, 0, moved ? RT_CLS_RAY : RT_CLS_QUEUE);
            rt_rq_pop(&D->rq, &cur, &e);
        }
        D->rbslot++;
        RT_REC(D->rec, rbaddr(D), 32, 1, RT_CLS_RAY);
        n--;
        if (oversized) {
            batch[nb++] = e;
            if (nb == bsz || n == 0) {
                process_oversized(D, q, batch, nb);
                nb = 0;
            }
        } else {
            process(D, q, &e);
        }
    }
    *curp = cur;
}

/* Pops every ray of queue q (rays never re-enter q: cells are convex). */
static void drain(dyn *D, uint32_t q)
{
    rt_rq_cur cur;
    uint32_t n = drain_take(D, q, &cur);
    if (n) drain_pop(D, q, &cur, n);
}

static int check_state(const dyn *D, rt_err *e);

/* Test mode: verifies the invariants at a step boundary, all of them
 * (I1-I6) when a generation's rays have started, the run's state (I3-I6)
 * after each drained queue. */
static void step_check(dyn *D, int all)
{
    if (D->ctx->check && !D->err && (all ? rt_dyn_check(D, D->e) : check_state(D, D->e)) < 0) D->err = 2;
}

/* The ray-queue core's step: drains queue q, then (test mode) checks. */
static int drain_step(void *u, uint32_t q)
{
    dyn *D = u;
    drain(D, q);
    step_check(D, 0);
    return D->err;
}

static void worker_round(dyn *W)
{
    rt_rq_cur none = {0, 0, 0};
    drain_pop(W, W->pick[W->core], &none, W->stage->nlist);
}

/* The host threads of cores 1..N-1, started once per run: each waits for
 * the next round (gen), drains its queue when it has one (core < m) and
 * reports back (left); quit ends them. */
typedef struct warg {
    struct wpool *p;
    uint32_t i; /* the worker's core */
} warg;

typedef struct wpool {
    pthread_mutex_t mu;
    pthread_cond_t go, done;
    uint64_t gen;       /* rounds announced */
    uint32_t m;         /* cores with a queue in the current round */
    uint32_t left;      /* started workers still draining in it */
    uint32_t started;   /* threads running: cores 1..started */
    int quit;
    dyn *D;
    warg *args;         /* per core: the thread's argument */
} wpool;

static void *worker_main(void *arg)
{
    const warg *a = arg;
    wpool *p = a->p;
    uint64_t seen = 0;
    pthread_mutex_lock(&p->mu);
    for (;;) {
        while (p->gen == seen && !p->quit) pthread_cond_wait(&p->go, &p->mu);
        if (p->quit) break;
        seen = p->gen;
        const int mine = a->i < p->m;
        pthread_mutex_unlock(&p->mu);
        if (mine) worker_round(&p->D->wk[a->i]);
        pthread_mutex_lock(&p->mu);
        if (mine && --p->left == 0) pthread_cond_signal(&p->done);
    }
    pthread_mutex_unlock(&p->mu);
    return NULL;
}

static void pool_stop(dyn *D)
{
    wpool *p = D->pool;
    if (!p) return;
    pthread_mutex_lock(&p->mu);
    p->quit = 1;
    pthread_cond_broadcast(&p->go);
    pthread_mutex_unlock(&p->mu);
    for (uint32_t i = 1; i <= p->started; i++) pthread_join(D->wtid[i], NULL);
    pthread_mutex_destroy(&p->mu);
    pthread_cond_destroy(&p->go);
    pthread_cond_destroy(&p->done);
    free(p->args);
    free(p);
    D->pool = NULL;
}

/* Runs cores 0..m-1's rounds: core 0 (and any core whose thread could not
 * start) here, the others on their threads; returns when all are done. */
static void pool_round(dyn *D, uint32_t m)
{
    wpool *p = D->pool;
    if (!p) { /* the first round: start the threads (none: every core runs here) */
        p = calloc(1, sizeof *p);
        warg *args = p ? calloc((size_t)D->ncores, sizeof *args) : NULL;
        if (!args) {
            free(p);
            p = NULL;
        } else {
            pthread_mutex_init(&p->mu, NULL);
            pthread_cond_init(&p->go, NULL);
            pthread_cond_init(&p->done, NULL);
            p->D = D;
            p->args = args;
            D->pool = p;
            for (uint32_t i = 1; i < (uint32_t)D->ncores; i++) {
                args[i] = (warg){p, i};
                if (pthread_create(&D->wtid[i], NULL, worker_main, &args[i])) break;
                p->started = i;
            }
        }
    }
    const uint32_t on = p ? (m - 1 < p->started ? m - 1 : p->started) : 0; /* cores 1..on on threads */
    if (p) {
        pthread_mutex_lock(&p->mu);
        p->m = m;
        p->left = on;
        p->gen++;
        pthread_cond_broadcast(&p->go);
        pthread_mutex_unlock(&p->mu);
    }
    worker_round(&D->wk[0]);
    for (uint32_t i = on + 1; i < m; i++) worker_round(&D->wk[i]);
    if (p) {
        pthread_mutex_lock(&p->mu);
        while (p->left) pthread_cond_wait(&p->done, &p->mu);
        pthread_mutex_unlock(&p->mu);
    }
}

/* One round on host threads (untraced): the main thread pops the m
 * picked queues (counting the rays that change cores, as drain_pop does),
 * worker i drains its list on host thread i (worker 0 on this thread) into
 * its own counters, marks and staged queue entries, and after the join the
 * main thread adds the counters and pushes the staged entries, worker by
 * worker in order: the queues then hold what the one-thread round leaves
 * there, in the same order, so the next rounds are the same. */
static void threaded_round(dyn *D, uint32_t m)
{
    for (uint32_t i = 0; i < m; i++) {
        wstage *w = &D->ws[i];
        const uint32_t n = D->pick_n[i];
        w->n = 0;
        w->nlist = 0;
        if (n > w->caplist) {
            qent *x = realloc(w->list, (size_t)n * sizeof *x);
            if (!x) {
                D->err = 1;
                return;
            }
            w->list = x;
            w->caplist = n;
        }
        for (uint32_t k = 0; k < n; k++) {
            const qent *pe = rt_rq_at(&D->rq, &D->pick_cur[i]);
            D->moved += (uint64_t)(D->owner[pe->pix & ~CAND_FLAG] != (uint8_t)i);
            rt_rq_pop(&D->rq, &D->pick_cur[i], &w->list[w->nlist++]);
        }
        dyn *W = &D->wk[i];
        *W = *D; /* the run's state; what is the worker's own follows */
        W->threaded = 0;
        W->stage = w;
        W->core = (int)i;
        W->rbslot = D->crbslot[i];
        W->mark = W->tv.mark = D->wmark + (size_t)i * (D->sc->ntri ? D->sc->ntri : 1);
        W->e = &D->werr[i];
        W->err = 0;
        W->enq = W->done = 0;
        W->tv.nodes = W->tv.tests = 0;
        memset(&W->qs, 0, sizeof W->qs);
    }
    pool_round(D, m);
    for (uint32_t i = 0; i < m; i++) {
        dyn *W = &D->wk[i];
        D->crbslot[i] = W->rbslot;
        D->enq += W->enq;
        D->done += W->done;
        D->tv.nodes += W->tv.nodes;
        D->tv.tests += W->tv.tests;
        const qstat *a = &W->qs;
        qstat *b = &D->qs;
        b->first_primary += a->first_primary;
        b->first_secondary += a->first_secondary;
        b->first_shadow += a->first_shadow;
        b->exit += a->exit;
        b->cand += a->cand;
        b->small += a->small;
        b->leaf += a->leaf;
        b->visits += a->visits;
        b->v_notest += a->v_notest;
        b->v_cand += a->v_cand;
        b->v_cand_kept += a->v_cand_kept;
        if (W->err && !D->err) {
            D->err = W->err;
            if (W->err == 2) *D->e = *W->e;
        }
        const wstage *w = &D->ws[i];
        for (size_t k = 0; k < w->n && !D->err; k++) {
            uint64_t at;
            qent *e = rt_rq_push(&D->rq, w->q[k], &at);
            if (!e) D->err = 1;
            else *e = w->e[k];
        }
    }
}

/* N cores: rounds. Each round picks up to N queues in the queue order
 * (rt_rq_pick: the N fullest, or the next N by number), core i takes the
 * i-th (its table entry read, the queue detached) and then drains it; rays
 * queued during the round wait for a later one. The cores' references are
 * interleaved at the round's end (interleave). */
static void run_rounds(dyn *D)
{
    while (!D->err && D->rq.queued) {
        const uint32_t m = rt_rq_pick(&D->rq, D->pick, (uint32_t)D->ncores, &D->tcur);
        if (!m) break;
        for (uint32_t i = 0; i < m; i++) {
            set_core(D, (int)i);
            D->pick_n[i] = drain_take(D, D->pick[i], &D->pick_cur[i]);
        }
        if (D->threaded) {
            threaded_round(D, m);
        } else {
            for (uint32_t i = 0; i < m && !D->err; i++) {
                set_core(D, (int)i);
                drain_pop(D, D->pick[i], &D->pick_cur[i], D->pick_n[i]);
            }
        }
        interleave(D);
        D->rounds++;
        step_check(D, 0);
    }
}

static void run_queues(dyn *D)
{
    if (D->err) return;
    if (D->ncores > 1) run_rounds(D);
    else rt_rq_run(&D->rq, drain_step, D);
}

/* Starts a ray of the current generation from the root. */
static void start(dyn *D, uint32_t pix)
{
    rt_ray trav, test;
    make_rays(D, pix, &trav, &test);
    D->created++;
    float t0, t1;
    if (!rt_kd_clip(D->kd, &trav, &t0, &t1)) {
        if (D->shadow) resolve_shadow(D, pix, 1);
        else resolve_primary(D, pix, INFINITY, RT_NO_HIT, 0);
        return;
    }
    if ((D->nq == 1 && D->qnode[0] == 0) || !(t1 > t0)) {
        /* Everything fits: no queues, recursive order. So too a ray whose
         * clipped interval is empty (its origin on a face of the scene's
         * box, leaving through it, or a ray touching the box at one point):
         * it has no extent to schedule, and no queue point is entered with
         * an empty interval, yet the single-ray traversal still visits the
         * cells at that point and tests their triangles against the ray's
         * own interval, where rounding can place a hit (a reflected ray
         * leaving a box's corner finds the adjacent wall at t ~ 1e-9). */
        uint64_t n0 = D->tv.nodes, k0 = D->tv.tests;
        if (!D->shadow) {
            rt_hit h;
            if (rt_kd_closest(&D->tv, &trav, &h)) resolve_primary(D, pix, h.t, h.tri, 1);
            else resolve_primary(D, pix, INFINITY, RT_NO_HIT, 0);
        } else {
            float bt = INFINITY;
            uint32_t btri = RT_NO_HIT;
            resolve_shadow(D, pix, !subtree(D, 0, &trav, &test, t0, t1, &bt, &btri));
        }
        D->img->nodes[PIX(D, pix)] += (float)(D->tv.nodes - n0);
        D->img->tests[PIX(D, pix)] += (float)(D->tv.tests - k0);
        return;
    }
    advance(D, pix, &trav, t0, t1, -1, INFINITY, RT_NO_HIT, 0);
}

static int check_generation(dyn *D, const uint8_t *want, size_t npix, rt_err *e)
{
    if (D->err == 2) return -1;
    if (D->err == 3) return rt_errf(e, "dynamic: trace sink failed (or out of memory holding a core's references)");
    if (D->err) return rt_errf(e, "dynamic: queue block pool exhausted (internal error)");
    if (D->rq.queued) return rt_errf(e, "dynamic: %" PRIu64 " rays left in queues (internal error)", D->rq.queued);
    for (size_t p = 0; p < npix; p++)
        if (D->resolved[p] != want[p])
            return rt_errf(e, "dynamic: pixel %zu resolved %u times, expected %u (internal error)", p, D->resolved[p],
                           want[p]);
    return 0;
}


/* ---- invariant checker ---------------------------------------------------- */

static int check_plan(const dyn *D, rt_err *e)
{
    const rt_kdtree *kd = D->kd;
    const dplan *P = D->P;
    uint32_t nq = 0, ntop = 0, ntopent = 0;
    for (uint32_t i = 0; i < kd->nnodes; i++) {
        const rt_kdnode *n = &kd->nodes[i];
        int leaf = rt_kd_is_leaf(n);
        int any = leaf ? rt_kd_ntri(n) > 0 : (P->hastris[i + 1] || P->hastris[rt_kd_above(n)]);
        if (!P->hastris[i] != !any) return rt_errf(e, "dynamic I1: node %u hastris %u, subtree says %d", i, P->hastris[i], any);
        if (P->qp[i] >= 0) {
            if ((uint32_t)P->qp[i] != nq || P->qnode[nq] != i)
                return rt_errf(e, "dynamic I1: node %u is queue point %d, expected %u in node order", i, P->qp[i], nq);
            if (!any || (!leaf && P->g[i] > P->gmax))
                return rt_errf(e, "dynamic I1: queue point at node %u (g %" PRIu64 ", gmax %" PRIu64 ", triangles %d)", i,
                               P->g[i], P->gmax, any);
            nq++;
        } else if (P->qp[i] != -1) {
            return rt_errf(e, "dynamic I1: node %u has queue-point mark %d", i, P->qp[i]);
        }
        if (P->topid[i] >= 0) ntopent++;
    }
    if (nq != P->nq) return rt_errf(e, "dynamic I1: %u queue points marked, plan says %u", nq, P->nq);
    if (ntopent != P->ntopent) return rt_errf(e, "dynamic I2: %u top entries, plan says %u", ntopent, P->ntopent);
    if (kd->nnodes && P->topid[0] != 0) return rt_errf(e, "dynamic I2: the root is top entry %d", P->topid[0]);
    /* Walk the top from the root: interior top nodes route to both children. */
    uint32_t stack[RT_KD_STACK * 2 + 8];
    int sp = 0;
    if (kd->nnodes) stack[sp++] = 0;
    while (sp) {
        uint32_t i = stack[--sp];
        const rt_kdnode *n = &kd->nodes[i];
        if (P->topid[i] < 0) return rt_errf(e, "dynamic I2: node %u reached through the top has no top entry", i);
        if (P->qp[i] >= 0 || !P->hastris[i] || rt_kd_is_leaf(n)) continue;
        if (P->g[i] <= P->gmax)
            return rt_errf(e, "dynamic I2: top node %u fits (g %" PRIu64 " <= gmax %" PRIu64 ") but is no queue point", i,
                           P->g[i], P->gmax);
        ntop++;
        if (P->topid[i + 1] != P->topid[i] + 1)
            return rt_errf(e, "dynamic I2: top node %u (entry %d) not followed by its below child", i, P->topid[i]);
        if (sp + 2 > (int)(sizeof stack / sizeof stack[0])) return rt_errf(e, "dynamic I2: top deeper than the stack");
        stack[sp++] = rt_kd_above(n);
        stack[sp++] = i + 1;
    }
    if (ntop != P->ntop) return rt_errf(e, "dynamic I2: %u top interior nodes, plan says %u", ntop, P->ntop);
    return 0;
}

static int check_rays(const dyn *D, uint8_t *seen_pix, rt_err *e)
{
    for (uint32_t q = 0; q < D->nq; q++) {
        for (rt_rq_cur c = rt_rq_peek(&D->rq, q); c.left; rt_rq_skip(&D->rq, &c)) {
            const qent *qe = rt_rq_at(&D->rq, &c);
            uint32_t pix = qe->pix & ~CAND_FLAG;
            if (pix >= D->npix || !D->want[pix] || D->resolved[pix] || seen_pix[pix])
                return rt_errf(e, "dynamic I6: queue %u holds pixel %u (wanted %d, resolved %d, queued before %d)", q, pix,
                               pix < D->npix ? D->want[pix] : -1, pix < D->npix ? D->resolved[pix] : -1,
                               pix < D->npix ? seen_pix[pix] : -1);
            seen_pix[pix] = 1;
            if ((qe->pix & CAND_FLAG) && (D->shadow || D->hit_tri[pix] == RT_NO_HIT))
                return rt_errf(e, "dynamic I6: pixel %u flagged with a candidate hit it lacks", pix);
        }
    }
    for (size_t p = 0; p < D->npix; p++)
        if (D->resolved[p] > 1) return rt_errf(e, "dynamic I6: pixel %zu resolved %u times", p, D->resolved[p]);
    if (D->created != D->done + D->rq.queued)
        return rt_errf(e, "dynamic I6: %" PRIu64 " rays started, %" PRIu64 " resolved, %" PRIu64 " queued", D->created,
                       D->done, D->rq.queued);
    return 0;
}

/* I8: the cores' state between steps. */
static int check_cores(const dyn *D, rt_err *e)
{
    if (D->ncores <= 1) return 0;
    if (D->core < 0 || D->core >= D->ncores)
        return rt_errf(e, "dynamic I8: running core %d of %d", D->core, D->ncores);
    uint64_t rays = 0, events = 0;
    for (int k = 0; k < D->ncores; k++) {
        rays += D->core_rays[k];
        events += D->core_events[k];
        if (D->crec && (D->cbuf[k].n || D->crec[k]->n))
            return rt_errf(e, "dynamic I8: core %d holds %zu references not interleaved", k, D->cbuf[k].n + D->crec[k]->n);
    }
    if (rays != D->ev_rays || events != D->events)
        return rt_errf(e, "dynamic I8: the cores popped %" PRIu64 " rays in %" PRIu64 " queue events, the run %" PRIu64
                          " in %" PRIu64, rays, events, D->ev_rays, D->events);
    if (D->moved > D->ev_rays)
        return rt_errf(e, "dynamic I8: %" PRIu64 " rays moved between cores, %" PRIu64 " popped", D->moved, D->ev_rays);
    if (D->events < D->rounds || D->events > D->rounds * (uint64_t)D->ncores)
        return rt_errf(e, "dynamic I8: %" PRIu64 " queue events in %" PRIu64 " rounds of %d cores", D->events, D->rounds,
                       D->ncores);
    for (uint32_t q = 0; q < D->nq; q++)
        for (rt_rq_cur c = rt_rq_peek(&D->rq, q); c.left; rt_rq_skip(&D->rq, &c)) {
            const uint32_t pix = ((const qent *)rt_rq_at(&D->rq, &c))->pix & ~CAND_FLAG;
            if (pix < D->npix && D->owner[pix] >= D->ncores)
                return rt_errf(e, "dynamic I8: ray %u in queue %u owned by core %u of %d", pix, q, D->owner[pix],
                               D->ncores);
        }
    return 0;
}

/* I3-I6, I8: the run's state (the plan does not change during a run): the
 * ray-queue core's Q1-Q5, then what its entries mean. */
static int check_state(const dyn *D, rt_err *e)
{
    if (rt_rq_check(&D->rq, e) < 0 || check_cores(D, e) < 0) return -1;
    uint8_t *seen = rt_calloc(D->npix ? D->npix : 1, 1, e);
    if (!seen) return -1;
    int rc = check_rays(D, seen, e);
    free(seen);
    return rc;
}

int rt_dyn_check(const rt_dyn *D, rt_err *e)
{
    return check_plan(D, e) < 0 ? -1 : check_state(D, e);
}

/* ---- tracer interface --------------------------------------------------------- */

/* Batch-stack levels of the secondary modes (see secondary_run). */
static int dyn_levels(const rt_render_opts *o) { return o->mode == RT_MODE_PATH ? 2 : o->depth + 1; }

static int dyn_layout(const rt_tracer_ctx *ctx, rt_layout *L, rt_err *e)
{
    const dplan *P = ctx->plan;
    if (!P) return rt_errf(e, "dynamic: layout without a plan (internal error)");
    size_t npix = (size_t)ctx->opt->W * (size_t)ctx->opt->H;
    uint64_t nq = P->nq ? P->nq : 1, ntop = P->ntopent;
    if (rt_reg_geometry(ctx, L, 1, e) < 0) return -1;
    if (rt_mm_add(L, "rays.primary", RT_CLS_RAY, 32, npix, e) < 0) return -1;
    if (rt_mm_add(L, "dyn.raybuf", RT_CLS_RAY, 32, 2ull * (uint64_t)ctx->opt->threads, e) < 0) return -1;
    if (rt_mm_add(L, "dyn.qtable", RT_CLS_QTABLE, 8, nq, e) < 0) return -1;
    if (rt_mm_add(L, "dyn.qpbox", RT_CLS_QTABLE, 24, nq, e) < 0) return -1;
    if (rt_mm_add(L, "dyn.top", RT_CLS_NODE, 8, ntop, e) < 0) return -1;
    if (rt_mm_add(L, "dyn.hits", RT_CLS_HIT, 24, npix, e) < 0) return -1;
    if (rt_mm_add(L, "fb", RT_CLS_FB, 12, npix, e) < 0) return -1;
    if (rt_render_secondary(ctx->opt) &&
        rt_mm_add(L, "dyn.spawn", RT_CLS_RAY, RT_SREC_SIZE, (uint64_t)npix * (uint64_t)dyn_levels(ctx->opt), e) < 0)
        return -1;
    if (rt_mm_add(L, "dyn.queues", RT_CLS_QUEUE, 32, ((uint64_t)npix / QBLK + nq + 2) * QBLK, e) < 0) return -1;
    return 0;
}

static void dyn_free(dyn *D)
{
    pool_stop(D);
    for (int k = 0; D->crec && k < D->ncores; k++) rt_rec_free(D->crec[k]);
    for (int k = 0; D->cbuf && k < D->ncores; k++) free(D->cbuf[k].a);
    free(D->crec);
    free(D->cbuf);
    free(D->crbslot);
    free(D->owner);
    free(D->core_rays);
    free(D->core_events);
    free(D->pick);
    free(D->pick_n);
    free(D->pick_cur);
    for (int k = 0; D->ws && k < D->ncores; k++) {
        free(D->ws[k].list);
        free(D->ws[k].q);
        free(D->ws[k].e);
    }
    free(D->ws);
    free(D->wk);
    free(D->wmark);
    free(D->werr);
    free(D->wtid);
    free(D->lw);
    free(D->swt);
    rt_rq_free(&D->rq);
    free(D->qtimes);
    free(D->hit_t);
    free(D->hit_tri);
    free(D->hit_u);
    free(D->hit_v);
    free(D->vis);
    free(D->resolved);
    free(D->want);
    free(D->mark);
    free(D->bray);
    free(D->bsray);
    free(D->bpix);
    free(D->out);
    free(D->acc);
    free(D->h0);
}

/* N simulated cores (opt->cores > 1 with a core sink): a recorder and a
 * buffer per core, the rays' owners, the round's picks. 0 or -1. */
static int cores_init(dyn *D, rt_err *e)
{
    const rt_tracer_ctx *ctx = D->ctx;
    D->ncores = 1;
    const int threaded = !ctx->rec && !ctx->cs && ctx->opt->host_threads > 1;
    if (!threaded && (!ctx->cs || ctx->opt->cores <= 1)) return 0;
    const int N = threaded ? ctx->opt->host_threads : ctx->opt->cores;
    if (N > RT_TR_MAX_CORES)
        return rt_errf_usage(e, "--%s %d: the dynamic tracer runs on 1..%d cores", threaded ? "threads" : "cores", N,
                             RT_TR_MAX_CORES);
    if (D->secondary)
        return rt_errf_usage(e, "--%s %d: the dynamic tracer runs the whitted and path modes on one %s",
                             threaded ? "threads" : "cores", N, threaded ? "thread" : "core");
    if (threaded) {
        const size_t ntri = D->sc->ntri ? D->sc->ntri : 1;
        D->threaded = 1;
        if (!(D->wk = rt_calloc((size_t)N, sizeof *D->wk, e)) || !(D->ws = rt_calloc((size_t)N, sizeof *D->ws, e)) ||
            !(D->wmark = rt_calloc((size_t)N, ntri, e)) || !(D->werr = rt_calloc((size_t)N, sizeof *D->werr, e)) ||
            !(D->wtid = rt_calloc((size_t)N, sizeof *D->wtid, e)))
            return -1;
        D->ncores = N;
    } else {
        if (!(D->crec = rt_calloc((size_t)N, sizeof *D->crec, e)) || !(D->cbuf = rt_calloc((size_t)N, sizeof *D->cbuf, e)))
            return -1;
        D->ncores = N; /* dyn_free frees what was made */
    }
    for (int k = 0; k < N && D->crec; k++) {
        D->cbuf[k].sink.put = corebuf_put;
        D->cbuf[k].sink.ctx = &D->cbuf[k];
        if (!(D->crec[k] = rt_rec_new(&D->cbuf[k].sink, e))) return -1;
    }
    if (!(D->crbslot = rt_calloc((size_t)N, sizeof *D->crbslot, e)) || !(D->owner = rt_calloc(D->npix ? D->npix : 1, 1, e)) ||
        !(D->core_rays = rt_calloc((size_t)N, sizeof *D->core_rays, e)) ||
        !(D->core_events = rt_calloc((size_t)N, sizeof *D->core_events, e)) ||
        !(D->pick = rt_calloc((size_t)N, sizeof *D->pick, e)) || !(D->pick_n = rt_calloc((size_t)N, sizeof *D->pick_n, e)) ||
        !(D->pick_cur = rt_calloc((size_t)N, sizeof *D->pick_cur, e)))
        return -1;
    D->span = (D->L->next - RT_MM_BASE + 4095) & ~(uint64_t)4095;
    D->core = 0;
    if (D->crec) {
        D->rec = D->crec[0];
        D->tv.rec = D->rec;
    }
    return 0;
}

/* Sets up the run's state: regions, the plan, an empty block pool on the
 * free list, empty queues in bucket 0. 0 or -1 (D freed by the caller). */
static int dyn_init(dyn *D, const rt_tracer_ctx *ctx, rt_image *img, rt_run_stats *st, rt_err *e)
{
    const rt_render_opts *o = ctx->opt;
    const rt_layout *L = ctx->L;
    const dplan *P = ctx->plan;
    const size_t npix = (size_t)o->W * (size_t)o->H;
    memset(D, 0, sizeof *D);
    if (!P) return rt_errf(e, "dynamic: run without a plan (internal error)");
    D->ctx = ctx;
    D->sc = ctx->sc;
    D->kd = ctx->kd;
    D->L = L;
    D->P = P;
    D->rec = ctx->rec;
    D->img = img;
    D->st = st;
    D->e = e;
    D->npix = npix;
    rt_reg_trav(&D->tv, ctx);
    D->reg_shade = rt_mm_find(L, "tri.shade");
    D->reg_ray = rt_mm_find(L, "rays.primary");
    D->reg_fb = rt_mm_find(L, "fb");
    D->reg_hits = rt_mm_find(L, "dyn.hits");
    D->reg_qt = rt_mm_find(L, "dyn.qtable");
    D->reg_q = rt_mm_find(L, "dyn.queues");
    D->reg_box = rt_mm_find(L, "dyn.qpbox");
    D->reg_rb = rt_mm_find(L, "dyn.raybuf");
    D->reg_top = rt_mm_find(L, "dyn.top");
    D->rbslots = (uint32_t)(2 * o->threads);
    rt_cam_setup(&D->cam, D->sc, o->W, o->H);
    D->qp = P->qp;
    D->qnode = P->qnode;
    D->topid = P->topid;
    D->hastris = P->hastris;
    D->gmax = P->gmax;
    D->nq = P->nq;
    D->ntop = P->ntop;
    uint32_t nq = D->nq ? D->nq : 1;
    D->secondary = rt_render_secondary(o);
    const rt_rq_config qc = {.name = "dynamic",
                             .nq = D->nq,
                             .nblk = (uint32_t)(npix / QBLK + nq + 2),
                             .esize = sizeof(qent),
                             .maxcount = (uint32_t)(npix + 1),
                             .order = o->qorder == RT_QORDER_FULLEST ? RT_RQ_FULLEST : RT_RQ_TREE,
                             .levels = D->secondary ? dyn_levels(o) : 0,
                             .level_cap = (uint32_t)npix};
    if (rt_rq_init(&D->rq, &qc, e) < 0 || !(D->qtimes = rt_calloc(nq, sizeof *D->qtimes, e)) ||
        !(D->hit_t = rt_calloc(npix, sizeof *D->hit_t, e)) ||
        !(D->hit_tri = rt_calloc(npix, sizeof *D->hit_tri, e)) || !(D->hit_u = rt_calloc(npix, sizeof *D->hit_u, e)) ||
        !(D->hit_v = rt_calloc(npix, sizeof *D->hit_v, e)) || !(D->vis = rt_calloc(npix, 1, e)) ||
        !(D->resolved = rt_calloc(npix, 1, e)) || !(D->want = rt_calloc(npix, 1, e)) ||
        !(D->mark = rt_calloc(D->sc->ntri ? D->sc->ntri : 1, 1, e)))
        return -1;
    D->tv.mark = D->mark;
    D->reg_spawn = rt_mm_find(L, "dyn.spawn");
    D->authored = rt_shade_authored(D->sc, o) && o->lights && !D->secondary;
    if (D->authored && (!(D->lw = rt_calloc(npix * D->sc->nlight, sizeof *D->lw, e)) ||
                        !(D->swt = rt_calloc(npix, sizeof *D->swt, e))))
        return -1;
    if (D->secondary) {
        if (!(D->bray = rt_calloc(npix, sizeof *D->bray, e)) || !(D->bsray = rt_calloc(npix, sizeof *D->bsray, e)) ||
            !(D->bpix = rt_calloc(npix, sizeof *D->bpix, e)) || !(D->out = rt_calloc(npix, sizeof *D->out, e)) ||
            !(D->acc = rt_calloc(npix, sizeof *D->acc, e)) || !(D->h0 = rt_calloc(npix, sizeof *D->h0, e)))
            return -1;
        for (size_t p = 0; p < npix; p++) D->h0[p].tri = RT_NO_HIT;
    }
    return cores_init(D, e);
}

/* Generation 0: a primary ray per traced pixel, then the queues. */
static int primary_generation(dyn *D, const uint32_t *order, size_t ntr, rt_err *e)
{
    D->shadow = 0;
    D->tv.mark_bit = 1;
    for (size_t k = 0; k < ntr; k++) D->want[order[k]] = 1;
    for (size_t k = 0; k < ntr; k++) {
        start_core(D, k, ntr);
        RT_REC(D->rec, rt_mm_addr(D->L, D->reg_ray, order[k]), 32, 0, RT_CLS_RAY);
        start(D, order[k]);
    }
    D->st->rays_primary = ntr;
    interleave(D);
    step_check(D, 1);
    run_queues(D);
    return check_generation(D, D->want, D->npix, e);
}

/* A shadow generation for light li: from the light toward each lit hit. */
static int shadow_generation(dyn *D, int li, const uint32_t *order, size_t ntr, rt_err *e)
{
    const int W = D->ctx->opt->W;
    D->light = li;
    memset(D->resolved, 0, D->npix);
    for (size_t k = 0; k < ntr; k++) {
        uint32_t pix = order[k];
        D->want[pix] = 0;
        start_core(D, k, ntr);
        RT_REC(D->rec, rt_mm_addr(D->L, D->reg_hits, pix), 24, 0, RT_CLS_HIT);
        if (D->hit_tri[pix] == RT_NO_HIT) continue;
        rt_ray eye, sr;
        rt_cam_ray(&D->cam, (int)(pix % (uint32_t)W), (int)(pix / (uint32_t)W), &eye);
        rt_hit h = {D->hit_t[pix], D->hit_tri[pix], D->hit_u[pix], D->hit_v[pix]};
        if (!rt_shade_ray(D->sc, &eye, &h, li, &sr)) continue;
        D->want[pix] = 1;
        D->st->rays_shadow++;
        start(D, pix);
    }
    interleave(D);
    step_check(D, 1);
    run_queues(D);
    return check_generation(D, D->want, D->npix, e);
}

/* Authored lights: a shadow generation per enabled light and sample, each
 * from the sampled points toward the hits (rt_shade_sample_ray). */
static int authored_generations(dyn *D, const uint32_t *order, size_t ntr, rt_err *e)
{
    const int W = D->ctx->opt->W;
    const rt_scene *sc = D->sc;
    for (uint32_t li = 0; li < sc->nlight; li++) {
        if (!rt_render_light_on(D->ctx->opt, li)) continue;
        for (uint32_t smp = 0, ns = rt_shade_light_nsamples(sc, D->ctx->opt, li); smp < ns; smp++) {
            D->light = (int)li;
            D->sample = smp;
            memset(D->resolved, 0, D->npix);
            for (size_t k = 0; k < ntr; k++) {
                uint32_t pix = order[k], tri;
                D->want[pix] = 0;
                start_core(D, k, ntr);
                RT_REC(D->rec, rt_mm_addr(D->L, D->reg_hits, pix), 24, 0, RT_CLS_HIT);
                if (D->hit_tri[pix] == RT_NO_HIT) continue;
                rt_ray eye, sr;
                rt_cam_ray(&D->cam, (int)(pix % (uint32_t)W), (int)(pix / (uint32_t)W), &eye);
                rt_hit h = {D->hit_t[pix], D->hit_tri[pix], D->hit_u[pix], D->hit_v[pix]};
                if (!rt_shade_sample_ray(sc, D->ctx->opt, &eye, &h, li, smp, &sr, &D->swt[pix], &tri)) continue;
                rt_reg_light(D->ctx, D->rec, li, tri);
                D->want[pix] = 1;
                D->st->rays_shadow++;
                start(D, pix);
            }
            interleave(D);
            step_check(D, 1);
            run_queues(D);
            if (check_generation(D, D->want, D->npix, e) < 0) return -1;
        }
    }
    return 0;
}

/* The final image: the shared shading rule on the per-light visibility. */
static void shade_image(dyn *D)
{
    const rt_render_opts *o = D->ctx->opt;
    for (size_t p = 0; p < D->npix; p++) {
        int x = (int)(p % (size_t)o->W), y = (int)(p / (size_t)o->W);
        if (!rt_pixel_kept(o, x, y)) continue; /* not traced */
        rt_ray eye;
        rt_cam_ray(&D->cam, x, y, &eye);
        if (D->hit_tri[p] == RT_NO_HIT) {
            rt_shade_pixel(D->sc, &eye, NULL, NULL, o->lights, D->img, p);
            continue;
        }
        rt_hit h = {D->hit_t[p], D->hit_tri[p], D->hit_u[p], D->hit_v[p]};
        if (D->authored) {
            rt_shade_pixel_lw(D->sc, o, &eye, &h, &D->lw[p * D->sc->nlight], D->img, p);
            continue;
        }
        int vis[RT_NLIGHTS];
        for (int i = 0; i < RT_NLIGHTS; i++) vis[i] = (D->vis[p] >> i) & 1;
        rt_shade_pixel(D->sc, &eye, &h, vis, o->lights, D->img, p);
    }
}

static void report(const dyn *D, rt_run_stats *st)
{
    const rt_render_opts *o = D->ctx->opt;
    if (D->threaded) /* the workers' marks */
        for (int k = 0; k < D->ncores; k++)
            for (uint32_t t = 0; t < D->sc->ntri; t++) D->mark[t] |= D->wmark[(size_t)k * D->sc->ntri + t];
    rt_stats_finish(st, &D->tv, D->mark, D->sc->ntri);
    uint32_t qmax = 0, oversized = 0;
    for (uint32_t q = 0; q < D->nq; q++) {
        if (D->qtimes[q] > qmax) qmax = D->qtimes[q];
        const rt_kdnode *nd = &D->kd->nodes[D->qnode[q]];
        oversized += rt_kd_is_leaf(nd) && 40ull * rt_kd_ntri(nd) > D->gmax;
    }
    snprintf(st->extra, sizeof st->extra,
             "gmax=%" PRIu64 " gmax_rule=%s queue_points=%u top_nodes=%u oversized_leaves=%u enqueues=%" PRIu64
             " queue_events=%" PRIu64 " rays_per_event_mean=%.1f rays_per_event_max=%" PRIu64
             " peak_queued_bytes=%" PRIu64 " events_per_queue_mean=%.2f events_per_queue_max=%u rays=%" PRIu64
             " resolved=%" PRIu64,
             D->gmax, o->gmax ? "given" : (D->P->fallback ? "top-first" : "resident-top"), D->nq, D->ntop, oversized,
             D->enq, D->events, D->events ? (double)D->ev_rays / (double)D->events : 0.0, D->ev_max, D->rq.peak * 32,
             D->nq ? (double)D->events / D->nq : 0.0, qmax, D->created, D->done);
    if (D->secondary) {
        size_t l = strlen(st->extra);
        snprintf(st->extra + l, sizeof st->extra - l, " batches=%" PRIu64 " rays_secondary=%" PRIu64 " self_hits=%" PRIu64,
                 D->rq.batches, D->nsec, D->self_hits);
    }
    if (D->ncores > 1) {
        uint64_t cmin = UINT64_MAX, cmax = 0;
        for (int k = 0; k < D->ncores; k++) {
            if (D->core_rays[k] < cmin) cmin = D->core_rays[k];
            if (D->core_rays[k] > cmax) cmax = D->core_rays[k];
        }
        size_t l = strlen(st->extra);
        snprintf(st->extra + l, sizeof st->extra - l,
                 " cores=%d rounds=%" PRIu64 " rays_moved=%" PRIu64 " bytes_moved=%" PRIu64 " core_rays_min=%" PRIu64
                 " core_rays_max=%" PRIu64,
                 D->ncores, D->rounds, D->moved, 32 * D->moved, cmin, cmax);
        for (int k = 0; D->crec && k < D->ncores; k++) st->accesses += D->crec[k]->total;
    }
    if (o->queue_stats) {
        const qstat *S = &D->qs;
        size_t l = strlen(st->extra);
        snprintf(st->extra + l, sizeof st->extra - l,
                 " q_first_pri=%" PRIu64 " q_first_sec=%" PRIu64 " q_first_shadow=%" PRIu64 " q_exit=%" PRIu64
                 " q_cand=%" PRIu64 " q_small=%" PRIu64 " q_leaf=%" PRIu64 " v=%" PRIu64 " v_notest=%" PRIu64
                 " v_cand=%" PRIu64 " v_cand_kept=%" PRIu64,
                 S->first_primary, S->first_secondary, S->first_shadow, S->exit, S->cand, S->small, S->leaf, S->visits,
                 S->v_notest, S->v_cand, S->v_cand_kept);
    }
}

/* ---- secondary modes: generations of batches ------------------------------
 *
 * A batch is up to npix rays in slots 0..n-1 (slot ids stand where pixel ids
 * stand in the primary-only run). Per batch, as in section 2.1.2: its
 * closest-hit generation (every ray started at the root and queued at the
 * queue point holding its origin's path), then its shadow rays, one
 * generation per light, traced from the light; then its newly spawned rays.
 * Those form the next generation: the refracted rays one batch, the others
 * (reflected rays, path continuations) another, pushed on a stack of
 * levels so at most depth + 1 batches wait (region dyn.spawn, one level of
 * npix 64-byte records each: written when spawned, read when started).
 * After every generation check_generation verifies that each ray was
 * resolved exactly once, and in test mode rt_dyn_check runs at every step. */

static int batch_closest(dyn *D, int lv, const rt_path *rays, uint32_t n, rt_err *e)
{
    D->shadow = 0;
    D->tv.mark_bit = rays[0].depth ? 4 : 1;
    memset(D->want, 0, D->npix);
    memset(D->resolved, 0, D->npix);
    for (uint32_t k = 0; k < n; k++) {
        rt_shade_path_ray(&rays[k], &D->bray[k]);
        D->bpix[k] = rays[k].pix;
        D->want[k] = 1;
    }
    for (uint32_t k = 0; k < n; k++) {
        if (rays[k].depth) {
            RT_REC(D->rec, rt_mm_addr(D->L, D->reg_spawn, (uint64_t)lv * D->npix + k), RT_SREC_SIZE, 0, RT_CLS_RAY);
            D->nsec++;
        } else {
            RT_REC(D->rec, rt_mm_addr(D->L, D->reg_ray, rays[k].pix), 32, 0, RT_CLS_RAY);
            D->st->rays_primary++;
        }
        start(D, k);
    }
    step_check(D, 1);
    run_queues(D);
    return check_generation(D, D->want, D->npix, e);
}

static int batch_shadow(dyn *D, int li, uint32_t n, rt_err *e)
{
    D->shadow = 1;
    D->light = li;
    D->tv.mark_bit = 2;
    memset(D->resolved, 0, D->npix);
    for (uint32_t k = 0; k < n; k++) {
        D->want[k] = 0;
        RT_REC(D->rec, rt_mm_addr(D->L, D->reg_hits, k), 24, 0, RT_CLS_HIT);
        if (!D->out[k].want[li]) continue;
        D->bsray[k] = D->out[k].sray[li];
        D->want[k] = 1;
        D->st->rays_shadow++;
        start(D, k);
    }
    step_check(D, 1);
    run_queues(D);
    return check_generation(D, D->want, D->npix, e);
}

/* The ray-queue core's batch trace: the batch at level lv (its closest
 * hits, shading, shadow rays); the core then pushes the children in out. */
static int batch_trace(void *u, int lv, const rt_path *rays, uint32_t n, const rt_shade_out **out, rt_err *e)
{
    dyn *D = u;
    const rt_render_opts *o = D->ctx->opt;
    if (batch_closest(D, lv, rays, n, e) < 0) return -1;
    for (uint32_t k = 0; k < n; k++) {
        rt_hit h = {D->hit_t[k], D->hit_tri[k], D->hit_u[k], D->hit_v[k]};
        const rt_hit *hp = h.tri != RT_NO_HIT ? &h : NULL;
        if (!rays[k].depth && !rays[k].sample) D->h0[rays[k].pix] = h;
        rt_shade_step(D->sc, o, &rays[k], &D->bray[k], hp, &D->out[k]);
        D->self_hits += (uint64_t)D->out[k].self_hit;
        rt_acc_add(&D->acc[rays[k].pix], D->out[k].c);
    }
    for (int li = 0; li < RT_NLIGHTS; li++)
        if ((o->lights & (1u << li)) && batch_shadow(D, li, n, e) < 0) return -1;
    *out = D->out;
    return 0;
}

static int secondary_run(dyn *D, const uint32_t *order, size_t ntr, rt_err *e)
{
    const rt_render_opts *o = D->ctx->opt;
    const int spp = o->mode == RT_MODE_PATH ? o->spp : 1;
    rt_path *base = rt_rq_base(&D->rq, e);
    if (!base) return -1;
    for (int s = 0; s < spp; s++) {
        for (size_t k = 0; k < ntr; k++) {
            rt_ray eye;
            rt_cam_ray(&D->cam, (int)(order[k] % (uint32_t)o->W), (int)(order[k] / (uint32_t)o->W), &eye);
            rt_shade_path_start(&base[k], &eye, order[k], (uint32_t)s);
        }
        if (rt_rq_batches(&D->rq, (uint32_t)ntr, batch_trace, D, D->rec, D->L, D->reg_spawn, e) < 0) return -1;
    }
    for (size_t k = 0; k < ntr; k++) {
        uint32_t p = order[k];
        rt_ray eye;
        rt_cam_ray(&D->cam, (int)(p % (uint32_t)o->W), (int)(p / (uint32_t)o->W), &eye);
        rt_acc_pixel(&D->acc[p], spp, &eye, D->h0[p].tri != RT_NO_HIT ? &D->h0[p] : NULL, D->img, p);
    }
    return 0;
}

static int dyn_run(const rt_tracer_ctx *ctx, rt_image *img, rt_run_stats *st, rt_err *e)
{
    const rt_render_opts *o = ctx->opt;
    dyn D;
    int rc = -1;
    uint32_t *order = NULL;
    if (dyn_init(&D, ctx, img, st, e) < 0 || !(order = rt_calloc(D.npix, sizeof *order, e))) goto done;
    const size_t ntr = rt_pixel_order(o, order); /* traced pixels (all unless subsampling) */
    if (D.secondary) {
        if (secondary_run(&D, order, ntr, e) < 0) goto done;
        report(&D, st);
        rc = 0;
        goto done;
    }
    if (primary_generation(&D, order, ntr, e) < 0) goto done;
    D.shadow = 1;
    D.tv.mark_bit = 2;
    if (D.authored && authored_generations(&D, order, ntr, e) < 0) goto done;
    for (int li = 0; li < RT_NLIGHTS && !D.authored; li++)
        if ((o->lights & (1u << li)) && shadow_generation(&D, li, order, ntr, e) < 0) goto done;
    shade_image(&D);
    report(&D, st);
    rc = 0;
done:
    dyn_free(&D);
    free(order);
    return rc;
}

static void dyn_params(const rt_render_opts *o, char *buf, size_t n)
{
    snprintf(buf, n, "qorder=%s threads=%d", o->qorder == RT_QORDER_TREE ? "tree" : "fullest", o->threads);
    /* the hypotheses' options only when not the default: existing keys stay */
    size_t l = strlen(buf);
    if (o->hit_rule != RT_HIT_EXACT) snprintf(buf + l, n - l, " hit_rule=%s", rt_render_hit_rule_name(o->hit_rule));
    l = strlen(buf);
    if (o->qp_measure != RT_QPM_ALL)
        snprintf(buf + l, n - l, " qp_measure=%s", rt_render_qp_measure_name(o->qp_measure));
}

const rt_tracer rt_tracer_dynamic = {
    .name = "dynamic",
    .desc = "dynamically scheduled rays queued at cache-sized subtrees (Navratil et al. 2007)",
    .modes = RT_TRACER_ALL_MODES,
    .accels = RT_ACCEL_BIT(RT_ACCEL_KD),
    .accel_default = RT_ACCEL_KD,
    .opts = RT_OPTG_SCHED | RT_OPTG_QUEUES | RT_OPTG_CORES,
    .traits = RT_TR_SCHEDULED | RT_TR_QUEUES | RT_TR_LIGHTS | RT_TR_CORES,
    .figures = RT_FIG_NAVRATIL | RT_FIG_FEEDBACK,
    .params = dyn_params,
    .layout = dyn_layout,
    .run = dyn_run,
    .plan = dyn_plan,
    .plan_free = dyn_plan_free,
};
