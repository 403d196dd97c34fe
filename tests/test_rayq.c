/*
 * test_rayq.c -- the ray-queue core (tracegen/rayq.c) against a naive
 * model, and its checker made to fire.
 *
 * Model: per queue a plain FIFO array of the entries pushed, a pool count,
 * and for fullest-first order the queue that must come next (the largest
 * count, ties to the queue that reached its count last). Random pushes,
 * takes and pops (takes interleaved with pushes elsewhere, as a scheduler
 * does) must give the model's entries in the model's order, rt_rq_check
 * must pass after every whole step, and the LIFO pool must hand back the
 * block freed last. rt_rq_run must visit queues in the model's order for
 * both queue orders. The batch stack is run with a trace callback whose
 * children are hand-counted. Then every invariant Q1-Q5 is broken on a
 * copy of a real state and rt_rq_check must name it.
 */
#include "check.h"
#include "rayq.h"

#include <inttypes.h>
#include <signal.h>

#define NQ 7
#define MAXE 4096

typedef struct model {
    uint32_t ent[NQ][MAXE];
    uint32_t n[NQ];
    uint64_t stamp[NQ]; /* when queue q last changed its count by a push */
    uint64_t clock;
} model;

/* The fullest-first rule: the largest count, ties to the latest push. */
static int model_next(const model *M)
{
    int best = -1;
    for (int q = 0; q < NQ; q++) {
        if (!M->n[q]) continue;
        if (best < 0 || M->n[q] > M->n[best] || (M->n[q] == M->n[best] && M->stamp[q] > M->stamp[best])) best = q;
    }
    return best;
}

static uint64_t rng = 88172645463325252ull;
static uint32_t next_u32(void)
{
    rng ^= rng << 13;
    rng ^= rng >> 7;
    rng ^= rng << 17;
    return (uint32_t)(rng >> 11);
}

static int push(rt_rq *rq, model *M, uint32_t q, uint32_t v)
{
    uint64_t at;
    uint32_t *x = rt_rq_push(rq, q, &at);
    if (!x) return -1;
    CHECK(at < (uint64_t)rq->nblk * RT_RQ_BLK, "entry index %" PRIu64 " outside the pool", at);
    *x = v;
    M->ent[q][M->n[q]++] = v;
    M->stamp[q] = ++M->clock;
    return 0;
}

/* Takes q whole; pushes a few entries to other queues between pops (as a
 * scheduler's step does) and checks the entries come out in FIFO order. */
static void take(rt_rq *rq, model *M, uint32_t q)
{
    rt_rq_cur c;
    const uint32_t n = rt_rq_take(rq, q, &c);
    CHECK(n == M->n[q], "queue %u: took %u rays, model holds %u", q, n, M->n[q]);
    uint32_t got[MAXE], want[MAXE];
    memcpy(want, M->ent[q], sizeof want[0] * M->n[q]);
    M->n[q] = 0;
    for (uint32_t k = 0; k < n; k++) {
        rt_rq_pop(rq, &c, &got[k]);
        CHECK(got[k] == want[k], "queue %u entry %u: %u, model %u", q, k, got[k], want[k]);
        if (next_u32() % 4 == 0) {
            uint32_t o = (q + 1 + next_u32() % (NQ - 1)) % NQ;
            if (M->n[o] < 200) push(rq, M, o, next_u32());
        }
    }
    CHECK(c.left == 0, "queue %u: cursor left %u", q, c.left);
}

static void test_model(int order)
{
    rt_err e = {0};
    rt_rq rq;
    const rt_rq_config cfg = {"model", NQ, 40, sizeof(uint32_t), MAXE, order, 0, 0};
    CHECK(rt_rq_init(&rq, &cfg, &e) == 0, "init: %s", e.msg);
    CHECK(rt_rq_check(&rq, &e) == 0, "empty core fails: %s", e.msg);
    model M;
    memset(&M, 0, sizeof M);
    int bad = 0;
    for (int step = 0; step < 3000 && !bad; step++) {
        uint32_t r = next_u32() % 10, q = next_u32() % NQ;
        if (r < 7) {
            if (M.n[q] < 300) push(&rq, &M, q, next_u32());
        } else {
            take(&rq, &M, q);
        }
        uint64_t total = 0;
        for (int k = 0; k < NQ; k++) total += M.n[k];
        bad |= rt_rq_check(&rq, &e) < 0;
        bad |= rq.queued != total;
    }
    CHECK(!bad, "order %d: after random steps: %s (queued %" PRIu64 ")", order, e.msg, rq.queued);
    rt_rq_free(&rq);
}

/* rt_rq_run's order, checked by a step that asks the model. */
typedef struct runctx {
    rt_rq *rq;
    model *M;
    int order;
    uint32_t prev; /* tree order: the queue processed before */
    int wrong, steps;
} runctx;

static int run_step(void *u, uint32_t q)
{
    runctx *C = u;
    C->steps++;
    if (C->order == RT_RQ_FULLEST) {
        int want = model_next(C->M);
        if ((int)q != want) C->wrong++;
    } else {
        /* tree order: the next non-empty queue after prev, by number,
         * wrapping to 0 for the next round */
        uint32_t want = UINT32_MAX;
        for (uint32_t k = 1; k <= NQ && want == UINT32_MAX; k++) {
            uint32_t x = C->prev == UINT32_MAX ? k - 1 : (C->prev + k) % NQ;
            if (C->M->n[x]) want = x;
        }
        if (q != want) C->wrong++;
        C->prev = q;
    }
    /* a step pushes to a later queue now and then: new work found */
    rt_rq_cur c;
    const uint32_t n = rt_rq_take(C->rq, q, &c);
    if (n != C->M->n[q]) C->wrong++;
    C->M->n[q] = 0;
    for (uint32_t k = 0; k < n; k++) {
        uint32_t v;
        rt_rq_pop(C->rq, &c, &v);
        if (v < 40 && q + 1 < NQ) push(C->rq, C->M, q + 1 + v % (NQ - 1 - q), v + 100);
    }
    if (rt_rq_check(C->rq, NULL) < 0) C->wrong++;
    return C->steps > 10000;
}

static void test_run(int order)
{
    rt_err e = {0};
    rt_rq rq;
    const rt_rq_config cfg = {"run", NQ, 64, sizeof(uint32_t), MAXE, order, 0, 0};
    CHECK(rt_rq_init(&rq, &cfg, &e) == 0, "init: %s", e.msg);
    model M;
    memset(&M, 0, sizeof M);
    for (uint32_t q = 0; q < NQ; q++)
        for (uint32_t k = 0; k < (q * 37) % 11 + 1; k++) push(&rq, &M, q, k * 13 % 50);
    runctx C = {&rq, &M, order, UINT32_MAX, 0, 0};
    int rc = rt_rq_run(&rq, run_step, &C);
    CHECK(rc == 0 && rq.queued == 0 && C.wrong == 0 && C.steps >= NQ,
          "order %d: rc %d, %" PRIu64 " left, %d of %d steps out of the model's order", order, rc, rq.queued, C.wrong,
          C.steps);
    /* a step asking to stop stops the run */
    push(&rq, &M, 3, 1);
    push(&rq, &M, 5, 1);
    C.steps = 10000;
    rc = rt_rq_run(&rq, run_step, &C);
    CHECK(rc != 0 && rq.queued > 0, "a stopping step: rc %d, %" PRIu64 " left", rc, rq.queued);
    rt_rq_free(&rq);
}

/* The pool: LIFO reuse, exhaustion leaves the queue as it was. */
static void test_pool(void)
{
    rt_err e = {0};
    rt_rq rq;
    const rt_rq_config cfg = {"pool", 3, 3, 12, MAXE, RT_RQ_FULLEST, 0, 0};
    CHECK(rt_rq_init(&rq, &cfg, &e) == 0, "init: %s", e.msg);
    uint64_t at;
    /* queue 0 takes blocks 0 and 1 (65 entries), queue 1 block 2 */
    for (int k = 0; k < 65; k++) CHECK(rt_rq_push(&rq, 0, &at), "push %d", k);
    CHECK(at == 1 * RT_RQ_BLK + 0, "65th entry at %" PRIu64 ", expected block 1 position 0", at);
    CHECK(rt_rq_push(&rq, 1, &at) && at == 2 * RT_RQ_BLK, "queue 1's first entry at %" PRIu64, at);
    for (int k = 1; k < 64; k++) rt_rq_push(&rq, 1, &at);
    CHECK(rt_rq_push(&rq, 1, &at) == NULL, "a push past the pool succeeded");
    CHECK(rq.count[1] == 64 && rq.queued == 129 && rt_rq_check(&rq, &e) == 0, "after a failed push: %u rays: %s",
          rq.count[1], e.msg);
    CHECK(rt_rq_push(&rq, 2, &at) == NULL && rq.count[2] == 0 && rq.head[2] == -1, "queue 2 got a block");
    /* taking queue 0 frees block 0 then block 1: the next block is 1 */
    rt_rq_cur c;
    unsigned char buf[12];
    CHECK(rt_rq_take(&rq, 0, &c) == 65, "take");
    while (c.left) rt_rq_pop(&rq, &c, buf);
    CHECK(rq.freelist == 1 && rq.bnext[1] == 0 && rq.bnext[0] == -1, "free list %d -> %d -> %d", rq.freelist,
          rq.bnext[1], rq.bnext[0]);
    CHECK(rt_rq_push(&rq, 2, &at) && at == 1 * RT_RQ_BLK, "reuse: entry at %" PRIu64 ", expected block 1", at);
    CHECK(rq.peak == 129 && rt_rq_check(&rq, &e) == 0, "peak %" PRIu64 ": %s", rq.peak, e.msg);
    rt_rq_free(&rq);
    rt_rq_free(&rq); /* freeing twice (zeroed) is fine */
}

/* The batch stack: a trace whose rays each spawn one reflected child
 * until depth 2 and one refracted child at depth 0. */
typedef struct bctx {
    rt_shade_out out[16];
    int seq[64][3]; /* per batch: level, rays, depth */
    int nb;
} bctx;

static int trace(void *u, int lv, const rt_path *rays, uint32_t n, const rt_shade_out **out, rt_err *e)
{
    bctx *B = u;
    if (B->nb < 64) {
        B->seq[B->nb][0] = lv;
        B->seq[B->nb][1] = (int)n;
        B->seq[B->nb][2] = rays[0].depth;
    }
    B->nb++;
    for (uint32_t s = 0; s < n; s++) {
        rt_shade_out *o = &B->out[s];
        memset(o, 0, sizeof *o);
        if (rays[s].depth < 2) {
            o->child[o->nchild] = rays[s];
            o->child[o->nchild].depth = (uint16_t)(rays[s].depth + 1);
            o->child[o->nchild].kind = 0;
            o->nchild++;
        }
        if (rays[s].depth == 0 && s % 2 == 0) {
            o->child[o->nchild] = rays[s];
            o->child[o->nchild].depth = 1;
            o->child[o->nchild].kind = RT_PATH_REFRACT;
            o->nchild++;
        }
    }
    *out = B->out;
    return 0;
}

static void test_batches(void)
{
    rt_err e = {0};
    rt_rq rq;
    const rt_rq_config cfg = {"batch", 0, 0, 4, 8, RT_RQ_TREE, 4, 8};
    CHECK(rt_rq_init(&rq, &cfg, &e) == 0, "init: %s", e.msg);
    rt_path *base = rt_rq_base(&rq, &e);
    CHECK(base != NULL, "base: %s", e.msg);
    if (!base) return;
    for (int s = 0; s < 4; s++) {
        memset(&base[s], 0, sizeof base[s]);
        base[s].pix = (uint32_t)s;
    }
    bctx B;
    memset(&B, 0, sizeof B);
    CHECK(rt_rq_batches(&rq, 4, trace, &B, NULL, NULL, -1, &e) == 0, "batches: %s", e.msg);
    /* hand-traced: 4 primaries (lv 0) push 2 refracted (lv 0) and 4
     * reflected (lv 1); the reflected batch runs first (top), its 4
     * children (depth 2) at lv 1 again; they spawn none; then the
     * refracted batch at lv 0 (depth 1): 2 children at depth 2, lv 0. */
    const int want[][3] = {{0, 4, 0}, {1, 4, 1}, {1, 4, 2}, {0, 2, 1}, {0, 2, 2}};
    const int nw = (int)(sizeof want / sizeof want[0]);
    CHECK(B.nb == nw && rq.batches == (uint64_t)nw && rq.height == 0, "%d batches (%" PRIu64 " counted), want %d",
          B.nb, rq.batches, nw);
    for (int k = 0; k < nw && k < B.nb; k++)
        CHECK(B.seq[k][0] == want[k][0] && B.seq[k][1] == want[k][1] && B.seq[k][2] == want[k][2],
              "batch %d: level %d, %d rays, depth %d; want %d, %d, %d", k, B.seq[k][0], B.seq[k][1], B.seq[k][2],
              want[k][0], want[k][1], want[k][2]);
    CHECK(rt_rq_check(&rq, &e) == 0, "after the batches: %s", e.msg);
    rt_rq_free(&rq);
    /* one level is too few for this tree of batches (the reflected
     * children of the first batch go above it): an error, no crash */
    const rt_rq_config small = {"batch", 0, 0, 4, 8, RT_RQ_TREE, 1, 8};
    CHECK(rt_rq_init(&rq, &small, &e) == 0 && (base = rt_rq_base(&rq, &e)), "init: %s", e.msg);
    if (base) {
        memset(base, 0, 4 * sizeof *base);
        memset(&B, 0, sizeof B);
        CHECK(rt_rq_batches(&rq, 4, trace, &B, NULL, NULL, -1, &e) < 0 && strstr(e.msg, "batch: batch stack overflow"),
              "overflow: %s", e.msg);
    }
    rt_rq_free(&rq);
}

static void expect(const rt_rq *rq, const char *inv, const char *what)
{
    rt_err e = {0};
    int rc = rt_rq_check(rq, &e);
    CHECK(rc < 0 && strstr(e.msg, inv) && strstr(e.msg, "corrupt: ray queue"), "%s: %s expected, got %d: '%s'", what,
          inv, rc, e.msg);
}

/* Every invariant broken on a real state; the checker names it. */
static void test_corrupt(void)
{
    rt_err e = {0};
    rt_rq rq;
    const rt_rq_config cfg = {"corrupt", 4, 8, 4, 200, RT_RQ_FULLEST, 3, 16};
    CHECK(rt_rq_init(&rq, &cfg, &e) == 0, "init: %s", e.msg);
    uint64_t at;
    for (int k = 0; k < 70; k++) *(uint32_t *)rt_rq_push(&rq, 1, &at) = (uint32_t)k; /* 2 blocks */
    for (int k = 0; k < 3; k++) *(uint32_t *)rt_rq_push(&rq, 2, &at) = (uint32_t)k;
    CHECK(rt_rq_base(&rq, &e) != NULL, "base: %s", e.msg);
    rq.lvlen[0] = 5;
    rq.height = 1;
    CHECK(rt_rq_check(&rq, &e) == 0, "a real state fails: %s", e.msg);
    rt_rq x;
    /* Q1: an empty queue with a tail; a chain a block short of its count */
    x = rq;
    int32_t t3 = x.tail[3];
    x.tail[3] = 0;
    expect(&x, "Q1", "empty queue with a tail");
    x.tail[3] = t3;
    uint32_t *cnt = x.count;
    uint32_t c1 = cnt[1];
    cnt[1] = 150; /* 3 blocks wanted, 2 in the chain */
    expect(&x, "Q1", "count beyond its chain");
    cnt[1] = c1;
    /* Q2: a block on two lists; a block lost */
    int32_t *bn = x.bnext;
    int32_t keep = bn[x.freelist];
    bn[x.freelist] = x.head[2];
    expect(&x, "Q2", "a queue's block on the free list too");
    bn[x.freelist] = keep;
    x.freelist = bn[x.freelist];
    expect(&x, "Q2", "a free block lost");
    x.freelist = rq.freelist;
    /* Q3: miscounted, peak below the count, a count above the capacity */
    x.queued++;
    expect(&x, "Q3", "rays queued miscounted");
    x.queued--;
    x.peak = x.queued - 1;
    expect(&x, "Q3", "peak below the rays queued");
    x.peak = rq.peak;
    x.bk_cap = 50;
    expect(&x, "Q3", "a queue above the capacity");
    x.bk_cap = rq.bk_cap;
    /* Q4: a queue out of its bucket, a broken back link, the fullest bound low */
    int32_t *bh = x.bk_head;
    int32_t h3 = bh[3];
    bh[3] = 1; /* queue 1 (70 rays) also in bucket 3 */
    expect(&x, "Q4", "a queue in a foreign bucket");
    bh[3] = h3;
    int32_t *bp = x.bk_prev;
    const int32_t first = bh[0]; /* bucket 0 holds queues 3 and 0 */
    bp[first] = 2;
    expect(&x, "Q4", "a back link not mirroring");
    bp[first] = -1;
    x.bk_max = 3;
    expect(&x, "Q4", "fullest bound below a count");
    x.bk_max = rq.bk_max;
    /* Q5: the stack above its levels, a level over capacity */
    x.height = 4;
    expect(&x, "Q5", "stack height above its levels");
    x.height = 1;
    uint32_t *ll = x.lvlen;
    ll[0] = 17;
    expect(&x, "Q5", "a level over its capacity");
    ll[0] = 5;
    x.height = 2; /* level 1 has no array */
    expect(&x, "Q5", "a level without its array");
    x.height = 1;
    CHECK(rt_rq_check(&rq, &e) == 0, "restored state fails: %s", e.msg);
    rq.height = 0;
    rt_rq_free(&rq);
}

/* A tree-order core keeps no bucket invariant; a config out of range is refused. */
static void test_config(void)
{
    rt_err e = {0};
    rt_rq rq;
    const rt_rq_config zero = {"cfg", 2, 2, 0, 8, RT_RQ_TREE, 0, 0};
    CHECK(rt_rq_init(&rq, &zero, &e) < 0 && strstr(e.msg, "cfg: ray queue sizes"), "esize 0: %s", e.msg);
    rt_rq_free(&rq);
    const rt_rq_config tree = {"cfg", 2, 2, 4, 8, RT_RQ_TREE, 0, 0};
    CHECK(rt_rq_init(&rq, &tree, &e) == 0, "init: %s", e.msg);
    uint64_t at;
    rt_rq_push(&rq, 1, &at);
    rq.bk_head[0] = 1; /* buckets are not kept in tree order: not checked */
    CHECK(rt_rq_check(&rq, &e) == 0, "tree order checks buckets: %s", e.msg);
    CHECK(rt_rq_base(&rq, &e) == NULL && strstr(e.msg, "no batch stack"), "base without levels: %s", e.msg);
    rt_rq_free(&rq);
}

/* RT_ASSERT: compiled away in a plain build (the condition is not even
 * evaluated); in a checking build (--enable-sanitizers, --enable-debug) a
 * broken contract aborts: a queue link corrupted under rt_rq_push. */
static void test_assert(void)
{
    int x = 0;
    RT_ASSERT(++x == 1);
    CHECK(x == RT_ASSERTS_ON, "RT_ASSERT evaluated its condition %d times (asserts %s)", x,
          RT_ASSERTS_ON ? "on" : "off");
    if (!RT_ASSERTS_ON) return;
    fflush(NULL);
    pid_t pid = fork();
    if (pid == 0) {
        rt_rq rq;
        const rt_rq_config cfg = {"assert", 2, 4, 4, 8, RT_RQ_FULLEST, 0, 0};
        if (rt_rq_init(&rq, &cfg, NULL) < 0) _exit(3);
        uint64_t at;
        rt_rq_push(&rq, 0, &at);
        rq.bk_head[1] = -1; /* queue 0 no longer heads its bucket: the next push's unlink asserts */
        (void)freopen("/dev/null", "w", stderr);
        rt_rq_push(&rq, 0, &at);
        _exit(0);
    }
    int st = 0;
    CHECK(pid > 0 && waitpid(pid, &st, 0) == pid, "fork/wait");
    CHECK(WIFSIGNALED(st) && WTERMSIG(st) == SIGABRT, "a broken queue link did not abort (status %d)", st);
}

int main(void)
{
    test_model(RT_RQ_FULLEST);
    test_model(RT_RQ_TREE);
    test_run(RT_RQ_FULLEST);
    test_run(RT_RQ_TREE);
    test_pool();
    test_batches();
    test_corrupt();
    test_config();
    test_assert();
    return failures ? 1 : 0;
}
