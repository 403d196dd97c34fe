/*
 * rayq.c -- the ray-queue core: block pool, queues, fullest-first buckets
 * and the secondary-ray batch stack (rayq.h), one copy for every
 * scheduler.
 *
 * Representation. The pool is nblk blocks of RT_RQ_BLK entries of esize
 * bytes (ent[]); bnext[b] links block b to the next block of its queue's
 * chain, or of the free list, -1 ending either. The free list is LIFO: a
 * block read to its end is pushed on it and the next block a push needs
 * is popped from it, so the blocks a run uses (and the addresses a
 * scheduler models for them) follow from the order of pushes and pops
 * alone. A queue q is head[q] .. tail[q] with count[q] rays; entries are
 * appended at the tail and read from the head, and a queue is always
 * taken whole, so its first entry is at position 0 of its head block.
 * With fullest-first order every queue sits in one bucket list, the one
 * of its count: bk_head[c] starts a doubly linked list (bk_next, bk_prev)
 * of the queues holding c rays, a queue moving to the head of the next
 * bucket at every push and back to bucket 0 when taken; bk_max bounds the
 * fullest count and is lowered lazily by rt_rq_run as buckets empty. The
 * batch stack is nlvl levels of level_cap path records; the levels below
 * height hold lvlen[l] rays each, the top one the batch traced next.
 *
 * Invariants, holding between calls (rt_rq_check verifies them; RT_ASSERT
 * guards the links each function relies on):
 *   Q1  queue shape: queue q is empty (head = tail = -1, count = 0) or a
 *       chain of ceil(count / RT_RQ_BLK) blocks from head to tail, with
 *       bnext[tail] = -1;
 *   Q2  pool: every block lies in exactly one queue's chain or on the free
 *       list, and on it once;
 *   Q3  counts: the counts sum to queued, and queued <= peak; no queue
 *       holds more than bk_cap rays;
 *   Q4  buckets (fullest-first order only): every queue is in exactly one
 *       bucket, the one of its count; bk_prev mirrors bk_next (the first
 *       of a bucket has bk_prev = -1); no queue holds more than bk_max
 *       rays and bk_max <= bk_cap;
 *   Q5  batch stack: 0 <= height <= nlvl; every level below height has
 *       its array and holds at most level_cap rays.
 * While a taken queue is being popped (inside a scheduler's step) its
 * detached blocks are in no queue and not free, so Q2 holds again only
 * once the last of its entries is popped; rt_rq_check is called between
 * steps.
 *
 * Where the core came from: dynamic.c (I4, I5) and treelet.c (T2, T5)
 * held the same pool, buckets and batch stack, each with its checker;
 * both now hold an rt_rq and check it with rt_rq_check, their own
 * checkers keeping what only they know (what an entry means).
 */
#include "rayq.h"

#include <inttypes.h>
#include <stdlib.h>
#include <string.h>

int rt_rq_init(rt_rq *rq, const rt_rq_config *c, rt_err *e)
{
    memset(rq, 0, sizeof *rq);
    rq->name = c->name ? c->name : "ray queue";
    rq->nq = c->nq;
    rq->nblk = c->nblk;
    rq->esize = c->esize;
    rq->order = c->order;
    rq->nlvl = c->levels;
    rq->level_cap = c->level_cap;
    rq->bk_cap = c->maxcount;
    rq->freelist = -1;
    if (c->esize == 0 || c->nblk > (uint32_t)INT32_MAX || c->nq > (uint32_t)INT32_MAX || c->maxcount == UINT32_MAX ||
        c->levels < 0)
        return rt_errf(e, "%s: ray queue sizes out of range (internal error)", rq->name);
    const size_t nq = c->nq ? c->nq : 1;
    /* entries are written before they are read: not zeroed */
    if (!(rq->ent = rt_reallocarray(NULL, (size_t)c->nblk * RT_RQ_BLK, c->esize, e)) ||
        !(rq->bnext = rt_calloc(c->nblk ? c->nblk : 1, sizeof *rq->bnext, e)) ||
        !(rq->head = rt_calloc(nq, sizeof *rq->head, e)) || !(rq->tail = rt_calloc(nq, sizeof *rq->tail, e)) ||
        !(rq->count = rt_calloc(nq, sizeof *rq->count, e)) ||
        !(rq->bk_head = rt_calloc((size_t)c->maxcount + 1, sizeof *rq->bk_head, e)) ||
        !(rq->bk_next = rt_calloc(nq, sizeof *rq->bk_next, e)) || !(rq->bk_prev = rt_calloc(nq, sizeof *rq->bk_prev, e)))
        return -1;
    if (c->levels && (!(rq->lvl = rt_calloc((size_t)c->levels, sizeof *rq->lvl, e)) ||
                      !(rq->lvlen = rt_calloc((size_t)c->levels, sizeof *rq->lvlen, e))))
        return -1;
    for (uint32_t i = 0; i < rq->nblk; i++) rq->bnext[i] = i + 1 < rq->nblk ? (int32_t)(i + 1) : -1;
    rq->freelist = rq->nblk ? 0 : -1;
    for (uint32_t q = 0; q < rq->nq; q++) rq->head[q] = rq->tail[q] = -1;
    for (size_t k = 0; k <= c->maxcount; k++) rq->bk_head[k] = -1;
    /* every queue in bucket 0, the highest-numbered first (as the schedulers
     * linked them before the core was shared) */
    for (uint32_t q = 0; q < rq->nq; q++) {
        rq->bk_prev[q] = -1;
        rq->bk_next[q] = rq->bk_head[0];
        if (rq->bk_head[0] >= 0) rq->bk_prev[rq->bk_head[0]] = (int32_t)q;
        rq->bk_head[0] = (int32_t)q;
    }
    return 0;
}

void rt_rq_free(rt_rq *rq)
{
    if (!rq) return;
    free(rq->ent);
    free(rq->bnext);
    free(rq->head);
    free(rq->tail);
    free(rq->count);
    free(rq->bk_head);
    free(rq->bk_next);
    free(rq->bk_prev);
    for (int l = 0; rq->lvl && l < rq->nlvl; l++) free(rq->lvl[l]);
    free(rq->lvl);
    free(rq->lvlen);
    memset(rq, 0, sizeof *rq);
}

/* ---- buckets (Q4) -------------------------------------------------------------- */

static inline void bk_unlink(rt_rq *rq, uint32_t q)
{
    const uint32_t c = rq->count[q];
    RT_ASSERT(c <= rq->bk_cap);
    RT_ASSERT(rq->bk_prev[q] >= 0 ? rq->bk_next[rq->bk_prev[q]] == (int32_t)q : rq->bk_head[c] == (int32_t)q);
    if (rq->bk_prev[q] >= 0) rq->bk_next[rq->bk_prev[q]] = rq->bk_next[q];
    else rq->bk_head[c] = rq->bk_next[q];
    if (rq->bk_next[q] >= 0) rq->bk_prev[rq->bk_next[q]] = rq->bk_prev[q];
}

static inline void bk_link(rt_rq *rq, uint32_t q)
{
    const uint32_t c = rq->count[q];
    RT_ASSERT(c <= rq->bk_cap);
    rq->bk_prev[q] = -1;
    rq->bk_next[q] = rq->bk_head[c];
    if (rq->bk_head[c] >= 0) rq->bk_prev[rq->bk_head[c]] = (int32_t)q;
    rq->bk_head[c] = (int32_t)q;
    if (c > rq->bk_max) rq->bk_max = c;
}

/* ---- queues (Q1-Q3) ------------------------------------------------------------ */

void *rt_rq_push(rt_rq *rq, uint32_t q, uint64_t *at)
{
    RT_ASSERT(q < rq->nq);
    int32_t tb = rq->tail[q];
    const uint32_t pos = rq->count[q] % RT_RQ_BLK;
    RT_ASSERT((tb < 0) == (rq->count[q] == 0)); /* Q1 */
    if (tb < 0 || pos == 0) {
        const int32_t nb = rq->freelist;
        if (nb < 0) return NULL;
        RT_ASSERT((uint32_t)nb < rq->nblk);
        rq->freelist = rq->bnext[nb];
        rq->bnext[nb] = -1;
        if (tb < 0) rq->head[q] = nb;
        else rq->bnext[tb] = nb;
        rq->tail[q] = tb = nb;
    }
    RT_ASSERT(rq->bnext[tb] == -1); /* Q1: the tail ends its chain */
    const int fullest = rq->order == RT_RQ_FULLEST;
    if (fullest) bk_unlink(rq, q);
    rq->count[q]++;
    if (fullest) bk_link(rq, q);
    if (++rq->queued > rq->peak) rq->peak = rq->queued;
    const size_t i = (size_t)tb * RT_RQ_BLK + pos;
    *at = i;
    return rq->ent + i * rq->esize;
}

uint32_t rt_rq_take(rt_rq *rq, uint32_t q, rt_rq_cur *c)
{
    RT_ASSERT(q < rq->nq);
    const uint32_t n = rq->count[q];
    RT_ASSERT(n <= rq->queued); /* Q3 */
    c->b = rq->head[q];
    c->pos = 0;
    c->left = n;
    const int fullest = rq->order == RT_RQ_FULLEST;
    if (fullest) bk_unlink(rq, q);
    rq->head[q] = rq->tail[q] = -1;
    rq->count[q] = 0;
    if (fullest) bk_link(rq, q);
    rq->queued -= n;
    return n;
}

void rt_rq_pop(rt_rq *rq, rt_rq_cur *c, void *out)
{
    memcpy(out, rt_rq_at(rq, c), rq->esize);
    c->left--;
    if (++c->pos == RT_RQ_BLK || c->left == 0) { /* block read: back to the pool */
        const int32_t b = c->b, nx = rq->bnext[b];
        RT_ASSERT(c->left == 0 ? nx == -1 : nx >= 0); /* Q1: the chain is as long as the count */
        rq->bnext[b] = rq->freelist;
        rq->freelist = b;
        c->b = nx;
        c->pos = 0;
    }
}

rt_rq_cur rt_rq_peek(const rt_rq *rq, uint32_t q)
{
    rt_rq_cur c = {rq->head[q], 0, rq->count[q]};
    return c;
}

int rt_rq_run(rt_rq *rq, rt_rq_step_fn step, void *user)
{
    int rc = 0;
    if (rq->order == RT_RQ_FULLEST) {
        while (rq->queued && !rc) {
            while (rq->bk_max > 0 && rq->bk_head[rq->bk_max] < 0) rq->bk_max--;
            RT_ASSERT(rq->bk_max > 0); /* Q3, Q4: queued rays are in some non-empty queue */
            if (!rq->bk_max) break;
            rc = step(user, (uint32_t)rq->bk_head[rq->bk_max]);
        }
        return rc;
    }
    while (rq->queued && !rc)
        for (uint32_t q = 0; q < rq->nq && !rc; q++)
            if (rq->count[q]) rc = step(user, q);
    return rc;
}

void rt_rq_pick_classes(const rt_rq *rq, uint32_t nclass, const uint8_t *need, uint32_t *pick)
{
    uint32_t left = 0;
    for (uint32_t c = 0; c < nclass; c++) {
        pick[c] = UINT32_MAX;
        left += need[c] != 0;
    }
    RT_ASSERT(rq->order == RT_RQ_FULLEST);
    for (uint32_t b = rq->bk_max; b > 0 && left; b--)
        for (int32_t q = rq->bk_head[b]; q >= 0 && left; q = rq->bk_next[q]) {
            const uint32_t c = (uint32_t)q % nclass;
            if (need[c] && pick[c] == UINT32_MAX) {
                pick[c] = (uint32_t)q;
                left--;
            }
        }
}

uint32_t rt_rq_pick(rt_rq *rq, uint32_t *out, uint32_t max, uint32_t *cursor)
{
    uint32_t m = 0;
    if (!max || !rq->queued) return 0;
    if (rq->order == RT_RQ_FULLEST) {
        while (rq->bk_max > 0 && rq->bk_head[rq->bk_max] < 0) rq->bk_max--;
        for (uint32_t c = rq->bk_max; c > 0 && m < max; c--)
            for (int32_t q = rq->bk_head[c]; q >= 0 && m < max; q = rq->bk_next[q]) out[m++] = (uint32_t)q;
        return m;
    }
    uint32_t q = *cursor < rq->nq ? *cursor : 0;
    for (uint32_t k = 0; k < rq->nq && m < max; k++, q = q + 1 == rq->nq ? 0 : q + 1)
        if (rq->count[q]) out[m++] = q;
    *cursor = q;
    return m;
}

/* ---- batch stack (Q5) ------------------------------------------------------------ */

static rt_path *level(rt_rq *rq, int l, rt_err *e)
{
    if (!rq->lvl[l]) rq->lvl[l] = rt_calloc(rq->level_cap ? rq->level_cap : 1, sizeof *rq->lvl[l], e);
    return rq->lvl[l];
}

rt_path *rt_rq_base(rt_rq *rq, rt_err *e)
{
    if (rq->nlvl < 1) {
        rt_errf(e, "%s: no batch stack (internal error)", rq->name);
        return NULL;
    }
    return level(rq, 0, e);
}

int rt_rq_batches(rt_rq *rq, uint32_t n, rt_rq_trace_fn trace, void *user, rt_rec *rec, const rt_layout *L,
                  int reg_spawn, rt_err *e)
{
    if (rq->nlvl < 1 || !rq->lvl[0]) return rt_errf(e, "%s: no batch stack (internal error)", rq->name);
    RT_ASSERT(n <= rq->level_cap);
    rq->lvlen[0] = n;
    rq->height = 1;
    while (rq->height) {
        const int lv = --rq->height;
        const uint32_t m = rq->lvlen[lv];
        const rt_path *rays = rq->lvl[lv];
        const rt_shade_out *out = NULL;
        RT_ASSERT(m <= rq->level_cap); /* Q5 */
        rq->batches++;
        rt_rec_set_gen(rec, rays[0].depth); /* a batch is one generation */
        if (trace(user, lv, rays, m, &out, e) < 0) return -1;
        /* children: refracted rays into this level, the others above it */
        for (int kind = RT_PATH_REFRACT; kind >= 0; kind--) {
            const int dst = rq->height;
            uint32_t k = 0;
            if (dst >= rq->nlvl) return rt_errf(e, "%s: batch stack overflow (internal error)", rq->name);
            rt_path *d = level(rq, dst, e);
            if (!d) return -1;
            for (uint32_t s = 0; s < m; s++)
                for (int c = 0; c < out[s].nchild; c++) {
                    if (out[s].child[c].kind != kind) continue;
                    RT_ASSERT(k < rq->level_cap); /* Q5: a ray has at most one child of a kind */
                    d[k] = out[s].child[c];
                    RT_REC(rec, rt_mm_addr(L, reg_spawn, (uint64_t)dst * rq->level_cap + k), RT_SREC_SIZE, 1, RT_CLS_RAY);
                    k++;
                }
            if (k) rq->lvlen[rq->height++] = k;
        }
    }
    return 0;
}

/* ---- invariants --------------------------------------------------------------- */

static int check_queues(const rt_rq *rq, uint8_t *seen, rt_err *e)
{
    uint64_t total = 0;
    for (uint32_t q = 0; q < rq->nq; q++) {
        if (rq->count[q] > rq->bk_cap)
            return rt_errf(e, "%s: ray queue Q3: queue %u holds %u rays, more than %u", rq->name, q, rq->count[q],
                           rq->bk_cap);
        if (rq->head[q] < 0) {
            if (rq->tail[q] >= 0 || rq->count[q])
                return rt_errf(e, "%s: ray queue Q1: queue %u has no head but tail %d, %u rays", rq->name, q, rq->tail[q],
                               rq->count[q]);
            continue;
        }
        const uint32_t want = (rq->count[q] + RT_RQ_BLK - 1) / RT_RQ_BLK;
        uint32_t nb = 0;
        int32_t b = rq->head[q], last = -1;
        while (b >= 0 && nb <= want) {
            if ((uint32_t)b >= rq->nblk || seen[b])
                return rt_errf(e, "%s: ray queue Q2: block %d reached twice (queue %u)", rq->name, b, q);
            seen[b] = 1;
            nb++;
            last = b;
            b = rq->bnext[b];
        }
        if (nb != want || last != rq->tail[q] || b >= 0)
            return rt_errf(e, "%s: ray queue Q1: queue %u holds %u rays in %u blocks ending at %d, expected %u ending at %d",
                           rq->name, q, rq->count[q], nb, last, want, rq->tail[q]);
        total += rq->count[q];
    }
    if (total != rq->queued || rq->queued > rq->peak)
        return rt_errf(e, "%s: ray queue Q3: queues hold %" PRIu64 " rays, %" PRIu64 " counted, peak %" PRIu64, rq->name,
                       total, rq->queued, rq->peak);
    for (int32_t b = rq->freelist; b >= 0; b = rq->bnext[b]) {
        if ((uint32_t)b >= rq->nblk || seen[b])
            return rt_errf(e, "%s: ray queue Q2: free block %d also in use or listed twice", rq->name, b);
        seen[b] = 1;
    }
    for (uint32_t b = 0; b < rq->nblk; b++)
        if (!seen[b]) return rt_errf(e, "%s: ray queue Q2: block %u is in no queue and not free", rq->name, b);
    return 0;
}

static int check_buckets(const rt_rq *rq, uint8_t *seen, rt_err *e)
{
    if (rq->bk_max > rq->bk_cap)
        return rt_errf(e, "%s: ray queue Q4: fullest bound %u above the largest count %u", rq->name, rq->bk_max, rq->bk_cap);
    uint32_t listed = 0;
    for (uint32_t c = 0; c <= rq->bk_max; c++) { /* all nq found here: none above bk_max */
        int32_t prev = -1;
        for (int32_t q = rq->bk_head[c]; q >= 0; q = rq->bk_next[q]) {
            if ((uint32_t)q >= rq->nq || seen[q]) return rt_errf(e, "%s: ray queue Q4: queue %d listed twice", rq->name, q);
            seen[q] = 1;
            listed++;
            if (rq->count[q] != c)
                return rt_errf(e, "%s: ray queue Q4: queue %d with %u rays in bucket %u", rq->name, q, rq->count[q], c);
            if (rq->bk_prev[q] != prev)
                return rt_errf(e, "%s: ray queue Q4: queue %d links back to %d, not %d", rq->name, q, rq->bk_prev[q], prev);
            prev = q;
        }
    }
    if (listed != rq->nq)
        return rt_errf(e, "%s: ray queue Q4: %u of %u queues in buckets up to the fullest bound %u", rq->name, listed,
                       rq->nq, rq->bk_max);
    return 0;
}

static int check_stack(const rt_rq *rq, rt_err *e)
{
    if (rq->height < 0 || rq->height > rq->nlvl)
        return rt_errf(e, "%s: ray queue Q5: stack height %d outside 0..%d", rq->name, rq->height, rq->nlvl);
    for (int l = 0; l < rq->height; l++)
        if (!rq->lvl[l] || rq->lvlen[l] > rq->level_cap)
            return rt_errf(e, "%s: ray queue Q5: level %d holds %u rays (capacity %u%s)", rq->name, l, rq->lvlen[l],
                           rq->level_cap, rq->lvl[l] ? "" : ", no array");
    return 0;
}

int rt_rq_check(const rt_rq *rq, rt_err *e)
{
    size_t n = rq->nblk > rq->nq ? rq->nblk : rq->nq;
    uint8_t *seen = rt_calloc(n ? n : 1, 1, e);
    if (!seen) return -1;
    int rc = check_queues(rq, seen, e);
    if (rc == 0 && rq->order == RT_RQ_FULLEST) {
        memset(seen, 0, n);
        rc = check_buckets(rq, seen, e);
    }
    if (rc == 0) rc = check_stack(rq, e);
    free(seen);
    return rc;
}
