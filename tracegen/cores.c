/* cores.c -- simulated cores inside one tracer run: per-core recorders,
 * the modeled clock phase by phase (see cores.h). */
#include "cores.h"

#include "run.h" /* RT_CORE_TICK: the tick of the work-share cores, the same clock */

#include <inttypes.h>
#include <stdlib.h>
#include <string.h>

/* Core k's chain ends here: the references wait in its buffer. */
static int buf_put(rt_sink *s, const rt_access *a, size_t n)
{
    rt_core_buf *b = s->ctx;
    rt_cores *c = b->c;
    b->recorded += n;
    if (b->done) b->late += n;
    if (c->failed || !c->out) return c->failed ? -1 : 0;
    if (b->n + n > b->cap) {
        size_t nc = b->cap ? 2 * b->cap : 8192;
        while (nc < b->n + n) nc *= 2;
        rt_access *na = realloc(b->a, nc * sizeof *na);
        if (!na) {
            c->failed = 1;
            return -1;
        }
        b->a = na;
        b->cap = nc;
    }
    memcpy(b->a + b->n, a, n * sizeof *a);
    b->n += n;
    return 0;
}

int rt_cores_init(rt_cores *c, int n, rt_csink *out, rt_err *e)
{
    memset(c, 0, sizeof *c);
    if (n < 1) return rt_errf(e, "simulated cores: %d cores (internal error)", n);
    c->n = n;
    c->out = out;
    if (!(c->buf = rt_calloc((size_t)n, sizeof *c->buf, e))) return -1;
    for (int k = 0; k < n; k++) {
        c->buf[k].sink.put = buf_put;
        c->buf[k].sink.ctx = &c->buf[k];
        c->buf[k].c = c;
        c->buf[k].core = (unsigned)k;
    }
    if (out && (!(c->rec = rt_calloc((size_t)n, sizeof *c->rec, e)) || !(c->back = rt_calloc((size_t)n, sizeof *c->back, e))))
        return -1;
    return 0;
}

void rt_cores_free(rt_cores *c)
{
    if (!c) return;
    for (int k = 0; c->buf && k < c->n; k++) free(c->buf[k].a);
    free(c->buf);
    free(c->rec);
    free(c->back);
    memset(c, 0, sizeof *c);
}

void rt_cores_set_rec(rt_cores *c, int k, rt_rec *front, rt_rec *back)
{
    if (!c->rec) return;
    c->rec[k] = front;
    c->back[k] = back != front ? back : NULL;
}

static void flush_core(rt_cores *c, int k)
{
    if (!c->rec || !c->rec[k]) return;
    if (rt_rec_flush(c->rec[k]) < 0) c->failed = 1;
    if (c->back[k] && rt_rec_flush(c->back[k]) < 0) c->failed = 1;
}

/* Emits every complete tick: each core is done or holds a full tick. */
static int emit(rt_cores *c)
{
    if (!c->out) return 0;
    for (;;) {
        int any = 0;
        for (int k = 0; k < c->n; k++) {
            const size_t pend = c->buf[k].n - c->buf[k].head;
            if (!c->buf[k].done && pend < RT_CORE_TICK) goto out; /* core k's tick is not recorded yet */
            any |= pend > 0;
        }
        if (!any) break;
        for (int k = 0; k < c->n && !c->failed; k++) {
            rt_core_buf *b = &c->buf[k];
            size_t m = b->n - b->head;
            if (!m) continue;
            if (m > RT_CORE_TICK) m = RT_CORE_TICK;
            if (c->out->put(c->out, (unsigned)k, b->a + b->head, m) < 0) c->failed = 1;
            b->head += m;
            c->emitted += m;
        }
        c->ticks++;
        if (c->failed) break;
    }
out:
    for (int k = 0; k < c->n; k++) { /* the emitted prefix goes once it is half the buffer */
        rt_core_buf *b = &c->buf[k];
        if (b->head == b->n) {
            b->head = b->n = 0;
        } else if (b->head >= b->n - b->head) {
            memmove(b->a, b->a + b->head, (b->n - b->head) * sizeof *b->a);
            b->n -= b->head;
            b->head = 0;
        }
    }
    return c->failed ? -1 : 0;
}

void rt_cores_done(rt_cores *c, int k)
{
    flush_core(c, k);
    c->buf[k].done = 1;
}

int rt_cores_sync(rt_cores *c)
{
    for (int k = 0; k < c->n; k++) flush_core(c, k);
    return emit(c);
}

int rt_cores_barrier(rt_cores *c)
{
    for (int k = 0; k < c->n; k++) rt_cores_done(c, k);
    int rc = emit(c);
    for (int k = 0; k < c->n; k++) c->buf[k].done = 0;
    c->phases++;
    return rc;
}

enum { STEP_SYNC = 16 }; /* rounds of items between syncs in rt_cores_steps */

int rt_cores_steps(rt_cores *c, uint64_t n, int (*fn)(void *u, int k, uint64_t i), void *u)
{
    const int N = c->n;
    uint64_t most = 0;
    for (int k = 0; k < N; k++) {
        const uint64_t len = rt_cores_lo(n, N, k + 1) - rt_cores_lo(n, N, k);
        if (len > most) most = len;
        if (!len) rt_cores_done(c, k);
    }
    int rc = 0;
    for (uint64_t j = 0; j < most && !rc; j++) {
        for (int k = 0; k < N && !rc; k++) {
            const uint64_t lo = rt_cores_lo(n, N, k), len = rt_cores_lo(n, N, k + 1) - lo;
            if (j >= len) continue;
            rc = fn(u, k, lo + j);
            if (j + 1 == len) rt_cores_done(c, k);
        }
        if (j % STEP_SYNC == STEP_SYNC - 1 && rt_cores_sync(c) < 0) rc = -1;
    }
    if (rt_cores_barrier(c) < 0 && !rc) rc = -1;
    return rc;
}

int rt_cores_check(const rt_cores *c, rt_err *e)
{
    uint64_t rec = 0;
    for (int k = 0; k < c->n; k++) {
        const rt_core_buf *b = &c->buf[k];
        if (b->n != b->head || b->done)
            return rt_errf(e, "cores C1: core %d holds %zu references (%s) between phases", k, b->n - b->head,
                           b->done ? "done" : "open");
        if (c->rec && c->rec[k] && (c->rec[k]->n || (c->back[k] && c->back[k]->n)))
            return rt_errf(e, "cores C1: core %d's recorder holds references between phases", k);
        if (b->late)
            return rt_errf(e, "cores C3: core %d recorded %" PRIu64 " references after its phase was done", k, b->late);
        rec += b->recorded;
    }
    if (c->bad_claims)
        return rt_errf(e, "cores C4: %" PRIu64 " items recorded by a core outside its chunk (the first: item %" PRIu64
                       " of %" PRIu64 " by core %d, whose chunk is %" PRIu64 "-%" PRIu64 ")", c->bad_claims, c->bad_i,
                       c->bad_n, c->bad_k, rt_cores_lo(c->bad_n, c->n, c->bad_k), rt_cores_lo(c->bad_n, c->n, c->bad_k + 1));
    if (c->out && !c->failed && rec != c->emitted)
        return rt_errf(e, "cores C2: %" PRIu64 " references recorded, %" PRIu64 " emitted", rec, c->emitted);
    return 0;
}
