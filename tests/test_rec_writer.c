/*
 * test_rec_writer.c -- the recorder's local writer (rt_rec_wbegin, wput,
 * wend: memmodel.h) hands the sink the very batches rt_rec_push would:
 * the same accesses, fields, generations and batch boundaries, across
 * several buffer fills and mixed with plain pushes before and after. In a
 * checking build (RT_ASSERT on) a plain push while a writer is open is a
 * broken contract and aborts at wend.
 */
#include "check.h"
#include "memmodel.h"

#include <signal.h>

#define NMAX 40000

typedef struct log {
    rt_access a[NMAX];
    size_t n;
    size_t batch[64]; /* sizes of the batches the sink received */
    int nb;
} log_t;

static int put(rt_sink *s, const rt_access *a, size_t n)
{
    log_t *L = s->ctx;
    if (L->n + n > NMAX || L->nb == 64) return -1;
    memcpy(L->a + L->n, a, n * sizeof *a);
    L->n += n;
    L->batch[L->nb++] = n;
    return 0;
}

/* The same stream, through plain pushes (writer 0) or with the middle part
 * through a local writer (writer 1). */
static void stream(rt_rec *r, int writer)
{
    for (uint32_t i = 0; i < 1000; i++) rt_rec_push(r, 4096 + 8ull * i, 8, i % 3 == 0, RT_CLS_NODE);
    rt_rec_set_gen(r, 3);
    if (writer) {
        rt_rec_w w;
        rt_rec_wbegin(&w, r);
        for (uint32_t i = 0; i < 10000; i++) rt_rec_wput(&w, 1ull << 20 | 36ull * i, 36, (uint8_t)(i % 2 ? RT_CLS_TRI : RT_CLS_INDEX));
        rt_rec_wend(&w);
    } else {
        for (uint32_t i = 0; i < 10000; i++) rt_rec_push(r, 1ull << 20 | 36ull * i, 36, 0, i % 2 ? RT_CLS_TRI : RT_CLS_INDEX);
    }
    rt_rec_set_gen(r, 1);
    for (uint32_t i = 0; i < 3000; i++) rt_rec_push(r, 77 + i, 1, 1, RT_CLS_FB);
    rt_rec_flush(r);
}

static log_t la, lb;

int main(void)
{
    rt_err e = {0};
    rt_sink sa = {put, &la}, sb = {put, &lb};
    rt_rec *ra = rt_rec_new(&sa, &e), *rb = rt_rec_new(&sb, &e);
    CHECK(ra && rb, "recorders: %s", e.msg);
    if (!ra || !rb) return 1;
    stream(ra, 0);
    stream(rb, 1);
    CHECK(la.n == 14000 && lb.n == la.n, "accesses: %zu plain, %zu through the writer", la.n, lb.n);
    CHECK(la.nb == lb.nb && la.nb == 4, "batches: %d plain, %d through the writer", la.nb, lb.nb);
    for (int k = 0; k < la.nb && k < lb.nb; k++)
        CHECK(la.batch[k] == lb.batch[k] && (k == la.nb - 1 || la.batch[k] == RT_REC_BUF), "batch %d: %zu vs %zu", k,
              la.batch[k], lb.batch[k]);
    size_t diff = 0;
    for (size_t i = 0; i < la.n && i < lb.n; i++) diff += memcmp(&la.a[i], &lb.a[i], sizeof la.a[i]) != 0;
    CHECK(diff == 0, "%zu accesses differ", diff);
    CHECK(lb.a[1000].gen == 3 && lb.a[1000].cls == RT_CLS_INDEX && lb.a[1000].write == 0 && lb.a[13999].gen == 1,
          "writer's fields: gen %u cls %u", lb.a[1000].gen, lb.a[1000].cls);
    CHECK(ra->total == 14000 && rb->total == 14000 && rb->n == 0, "totals %llu %llu",
          (unsigned long long)ra->total, (unsigned long long)rb->total);
    rt_rec_free(ra);
    rt_rec_free(rb);
    if (RT_ASSERTS_ON) {
        fflush(NULL);
        pid_t pid = fork();
        if (pid == 0) {
            static log_t lc;
            rt_sink sc = {put, &lc};
            rt_rec *rc = rt_rec_new(&sc, NULL);
            if (!rc) _exit(3);
            rt_rec_w w;
            rt_rec_wbegin(&w, rc);
            rt_rec_wput(&w, 1, 1, RT_CLS_NODE);
            rt_rec_push(rc, 2, 1, 0, RT_CLS_NODE); /* the contract: nothing else records meanwhile */
            (void)freopen("/dev/null", "w", stderr);
            rt_rec_wend(&w);
            _exit(0);
        }
        int st = 0;
        CHECK(pid > 0 && waitpid(pid, &st, 0) == pid, "fork/wait");
        CHECK(WIFSIGNALED(st) && WTERMSIG(st) == SIGABRT, "a push inside an open writer did not abort (status %d)", st);
    }
    return failures ? 1 : 0;
}
