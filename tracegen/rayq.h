/*
 * rayq.h -- the ray-queue core shared by the scheduled tracers (prefix
 * rt_rq_): ray queues as chains of fixed-size blocks from one pool, the
 * fullest-first bucket lists that pick the next queue, and the stack of
 * secondary-ray batches of the whitted and path modes.
 *
 * A scheduler (dynamic.c on a k-d tree, treelet.c on a BVH, a wavefront
 * tracer) decides what a queue stands for (a queue point, a treelet) and
 * what an entry holds (a pixel id and an interval, a ray slot number); the
 * core stores entries as opaque bytes of a size fixed at rt_rq_init and
 * knows nothing of rays, trees or the scheduler's state. The scheduler's
 * work is handed in as callbacks: rt_rq_run calls a queue step for the
 * queue to process next, rt_rq_batches calls a batch trace for every
 * batch of the stack. The core records no memory traffic of its own
 * except the spawned rays' records (rt_rq_batches, region given by the
 * caller): where a scheduler models its queue table and blocks, it
 * records them itself, from the block and position the core reports.
 *
 * The invariants Q1-Q5 (stated at the top of rayq.c) hold between calls;
 * rt_rq_check verifies them and names the broken one. Every function
 * assumes them (RT_ASSERT where cheap) and keeps them.
 *
 * Ownership: rt_rq_init allocates everything the core holds; rt_rq_free
 * releases it (a zeroed or failed rt_rq too). Entry pointers the core
 * returns stay valid until the block holding them returns to the pool
 * (rt_rq_pop of the block's last entry). Errors go through rt_err; no
 * function prints.
 */
#ifndef RT_RAYQ_H
#define RT_RAYQ_H

#include "memmodel.h"
#include "rt.h"
#include "rt_assert.h"
#include "shade.h"

#include <stddef.h>
#include <stdint.h>

#define RT_RQ_BLK 64 /* entries per queue block */

/* Queue order: the fullest queue first (bucket lists by count) or tree
 * order (queues by number, repeated until all are empty). */
enum { RT_RQ_TREE = 0, RT_RQ_FULLEST = 1 };

/* What rt_rq_init sizes. */
typedef struct rt_rq_config {
    const char *name;   /* the scheduler's name, first word of every message ("dynamic") */
    uint32_t nq;        /* queues (0 is allowed: the core then holds none) */
    uint32_t nblk;      /* blocks in the pool; a push fails once all are in use */
    size_t esize;       /* bytes per entry, >= 1 */
    uint32_t maxcount;  /* most rays one queue can hold (buckets 0..maxcount) */
    int order;          /* RT_RQ_FULLEST or RT_RQ_TREE */
    int levels;         /* levels of the batch stack (0: no batches, primary modes) */
    uint32_t level_cap; /* rays per level */
} rt_rq_config;

/* The core's state. Fields are public for the inline cursor functions
 * and for tests that corrupt them; schedulers read count[], queued and
 * peak only, and change nothing but through the functions below. */
typedef struct rt_rq {
    const char *name;
    uint32_t nq, nblk;
    size_t esize;
    int order;
    /* block pool and queues (Q1-Q3) */
    unsigned char *ent;    /* nblk * RT_RQ_BLK entries of esize bytes */
    int32_t *bnext;        /* next block of a chain or of the free list, -1 at the end */
    int32_t freelist;      /* first free block, -1 when the pool is used up */
    int32_t *head, *tail;  /* per queue: first and last block, -1 when empty */
    uint32_t *count;       /* per queue: rays queued */
    uint64_t queued, peak; /* rays in all queues; the most there ever were */
    /* fullest-first buckets (Q4; RT_RQ_FULLEST only) */
    int32_t *bk_head;      /* per count 0..bk_cap: first queue with that many rays, -1 none */
    int32_t *bk_next, *bk_prev; /* per queue: its neighbours in its bucket, -1 none */
    uint32_t bk_max, bk_cap; /* no queue holds more than bk_max rays; bk_cap = maxcount */
    /* batch stack (Q5) */
    rt_path **lvl;         /* per level: level_cap rays, allocated on first use */
    uint32_t *lvlen;       /* per level: rays waiting there */
    int nlvl, height;      /* levels; levels in use (0..height-1) */
    uint32_t level_cap;
    uint64_t batches;      /* batches traced */
} rt_rq;

/* Sets up an empty core: every block on the free list in index order,
 * every queue empty and (fullest first) in bucket 0, the stack empty.
 * 0, or -1 with e (out of memory, or a config breaking the limits above;
 * rq must still be freed with rt_rq_free). */
int rt_rq_init(rt_rq *rq, const rt_rq_config *c, rt_err *e);
/* Releases what rt_rq_init allocated; rq may be zeroed or half made. */
void rt_rq_free(rt_rq *rq);

/* ---- queues ---------------------------------------------------------------- */

/* Appends an entry to queue q: returns where to write its esize bytes
 * (the caller fills them before the next call into the core) and sets
 * *at to its index in the pool (block * RT_RQ_BLK + position: the
 * scheduler's modeled address of the entry). A block is taken from the
 * free list when q is empty or its tail block is full. NULL when the pool
 * is used up (the queue is then unchanged; the caller reports it). */
void *rt_rq_push(rt_rq *rq, uint32_t q, uint64_t *at);

/* A position in a chain of blocks: the next entry is at block b,
 * position pos, and left entries remain. */
typedef struct rt_rq_cur {
    int32_t b;
    uint32_t pos;
    uint32_t left;
} rt_rq_cur;

/* Detaches queue q whole: q becomes empty (bucket 0), rq->queued drops
 * by its count, and *c walks the detached chain. Returns the count. Its
 * rays must then be popped, all of them (rt_rq_pop), before the core is
 * checked: the detached blocks return to the pool only as they are read.
 * Rays pushed while they are popped, to q or any other queue, may reuse
 * the blocks already read. */
uint32_t rt_rq_take(rt_rq *rq, uint32_t q, rt_rq_cur *c);

/* The entry at the cursor (c->left > 0), not consumed. */
static inline void *rt_rq_at(const rt_rq *rq, const rt_rq_cur *c)
{
    RT_ASSERT(c->left > 0 && c->b >= 0 && (uint32_t)c->b < rq->nblk && c->pos < RT_RQ_BLK);
    return rq->ent + ((size_t)c->b * RT_RQ_BLK + c->pos) * rq->esize;
}

/* Moves a look-ahead cursor (a copy of the one rt_rq_take set) one entry
 * on without freeing anything; it must stay ahead of the popping cursor,
 * whose blocks it reads the links of. */
static inline void rt_rq_skip(const rt_rq *rq, rt_rq_cur *c)
{
    RT_ASSERT(c->left > 0);
    c->left--;
    if (++c->pos == RT_RQ_BLK) {
        c->pos = 0;
        c->b = rq->bnext[c->b];
    }
}

/* Copies the entry at the cursor into out (esize bytes), moves on, and
 * returns its block to the pool when that was the block's last entry to
 * read (the last of a full block or the queue's last). The block may be
 * reused by the next push, so entries are copied out before processing. */
void rt_rq_pop(rt_rq *rq, rt_rq_cur *c, void *out);

/* A read-only cursor over the entries still in queue q, oldest first, for
 * checkers (rt_rq_at and rt_rq_skip walk it). */
rt_rq_cur rt_rq_peek(const rt_rq *rq, uint32_t q);

/* A scheduler's step: processes queue q (rt_rq_take and every pop) and
 * returns 0 to go on, non-zero to stop (an error the scheduler keeps). */
typedef int (*rt_rq_step_fn)(void *user, uint32_t q);

/* Processes queues until all are empty or a step says stop: the fullest
 * queue first (ties: the queue last made that full) or, in tree order,
 * every non-empty queue by number, round after round. Returns the last
 * step's value (0 when the queues emptied; the caller's end-of-generation
 * check sees rays left queued should Q3/Q4 be broken). */
int rt_rq_run(rt_rq *rq, rt_rq_step_fn step, void *user);

/* For a scheduler that deals the queues to nclass cores (queue q to class
 * q mod nclass): into pick[c], for every class c with need[c] set, the
 * queue of that class rt_rq_run would take first if it held only that
 * class's queues -- fullest first, ties in bucket order -- or UINT32_MAX
 * when the class has no non-empty queue. Fullest-first order only (tree
 * order needs no buckets: the scheduler scans count[]). With one class it
 * is rt_rq_run's next queue. Scans the buckets from the fullest down until
 * every needed class is found; changes nothing. */
void rt_rq_pick_classes(const rt_rq *rq, uint32_t nclass, const uint8_t *need, uint32_t *pick);

/* The work of one round of several cores: up to max distinct non-empty
 * queues into out, in the order rt_rq_run would process them were none
 * refilled meanwhile -- fullest first (the buckets from the fullest down,
 * each bucket's queues from its head: the one last made that full first)
 * or, in tree order, by number from *cursor on, wrapping (*cursor is then
 * the queue after the last one picked; start it at 0). Changes nothing
 * else (fullest first lowers bk_max past empty buckets, as rt_rq_run
 * does); the caller takes and pops the queues. Returns how
 * many were picked (0 when no ray is queued). */
uint32_t rt_rq_pick(rt_rq *rq, uint32_t *out, uint32_t max, uint32_t *cursor);

/* ---- batch stack -------------------------------------------------------------- */

/* Level 0's rays (level_cap of them), to be filled with a generation's
 * first rays before rt_rq_batches. NULL on out of memory (e set). */
rt_path *rt_rq_base(rt_rq *rq, rt_err *e);

/* A batch trace: traces the n rays of the batch at level lv (all its
 * generations: closest hits, shadow rays, shading) and points *out at n
 * shading results whose children are the next batches. 0, or -1 with e. */
typedef int (*rt_rq_trace_fn)(void *user, int lv, const rt_path *rays, uint32_t n, const rt_shade_out **out,
                              rt_err *e);

/* Runs the stack from n rays at level 0 until it is empty. Per batch: pops
 * the top level, counts the batch, sets the recorder's generation to the
 * batch's (its first ray's depth), calls trace, then pushes the children
 * the results hold, the refracted ones (RT_PATH_REFRACT) onto the level
 * just freed and the others above it, each level only when it holds a
 * ray; every pushed ray's record is written at region reg_spawn, entry
 * level * level_cap + index (rec may be NULL). 0, or -1 with e (trace's
 * error, out of memory, or a stack deeper than its levels). */
int rt_rq_batches(rt_rq *rq, uint32_t n, rt_rq_trace_fn trace, void *user, rt_rec *rec, const rt_layout *L,
                  int reg_spawn, rt_err *e);

/* ---- invariants ------------------------------------------------------------ */

/* Verifies Q1-Q5 (rayq.c) between calls: 0, or -1 with a message naming
 * the scheduler and the broken invariant ("dynamic: ray queue Q2: ...").
 * Runs in time linear in the pool, queues and levels; allocates a mark
 * per block and per queue (-1 with e when that fails). */
int rt_rq_check(const rt_rq *rq, rt_err *e);

#endif
