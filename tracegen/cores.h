/*
 * cores.h -- simulated cores inside one tracer run (prefix rt_cores_):
 * the per-core stepping shared by the tracers that split their own work
 * over N cores (trait RT_TR_CORE_PHASES: treelet, stream-branching,
 * stream-multipass, feedback) instead of running N independent work
 * shares (run.h, rt_job_run_cores, for recursive and packet).
 *
 * Such a tracer's work is a sequence of PHASES separated by barriers (a
 * treelet round, a stream pass, a feedback pass). Within a phase core k
 * does its own part of the work and records it into its own recorder,
 * rt_cores_rec(c, k); the phase ends with rt_cores_barrier. The cores'
 * references reach the run's core sink in the order of the modeled clock,
 * the one run.h states for work shares, applied phase by phase:
 *
 *   A TICK is RT_CORE_TICK references of every core that still has
 *   references in the phase: core 0 issues its next RT_CORE_TICK (fewer
 *   at its phase's end), then core 1, ..., core N-1. A core whose phase
 *   work is done drops out until the barrier; the next phase starts when
 *   every core's phase is done.
 *
 * So a phase's trace is the tick interleave of the cores' phase streams,
 * and the run's is the phases' one after another. The order depends only
 * on each core's own references, never on host timing; one core gives
 * exactly the references of the one-core run, in order.
 *
 * The tracer runs the cores' work on the calling thread in an order of
 * its choosing (the state each core changes is the tracer's own, so the
 * order matters only where the tracer says it does). Core k's references
 * wait in its buffer until the interleave can emit them: rt_cores_sync
 * emits every tick that is complete (each core either done with its phase,
 * rt_cores_done, or holding RT_CORE_TICK references), so a tracer that
 * steps the cores in turn (rt_cores_steps: an item of each core, then the
 * next) keeps the buffers short; one that runs a phase core after core
 * holds the phase's references (16 bytes each) until the barrier.
 *
 * The work split the tracers share: a phase of n items (rays of a stream,
 * records of a vertex buffer, pixels) is cut into N contiguous chunks, core
 * k holding items [floor(k n / N), floor((k + 1) n / N)) (rt_cores_lo;
 * rt_cores_owner inverts it). The treelet tracer deals treelets instead
 * (treelet t on core t mod N; tracegen/treelet.c).
 *
 * Invariants (rt_cores_check verifies them; the tracers' checkers call it
 * between phases): C1 every core's buffer is empty between phases (all of
 * a phase's references emitted at its barrier) and every core is open
 * again; C2 the references emitted equal the references recorded (the
 * recorders' totals); C3 within a phase a done core records nothing more;
 * C4 every item a tracer claims (rt_cores_claim: "core k records item i
 * of n now") is in core k's chunk.
 *
 * Untraced (no core sink): the recorders are NULL, the phases and their
 * counts still advance, nothing is buffered.
 */
#ifndef RT_CORES_H
#define RT_CORES_H

#include "memmodel.h"
#include "rt.h"

#include <stddef.h>
#include <stdint.h>

typedef struct rt_core_buf {
    rt_sink sink;      /* the end of core k's recorder chain: appends to a[] */
    struct rt_cores *c;
    unsigned core;
    rt_access *a;      /* references recorded and not yet emitted: a[head, n) */
    size_t head, n, cap;
    int done;          /* the core's phase work is done (C3: it records nothing more) */
    uint64_t recorded; /* references that reached this buffer */
    uint64_t late;     /* ... of which after the core was done in its phase (C3) */
} rt_core_buf;

typedef struct rt_cores {
    int n;             /* cores, >= 1 */
    rt_csink *out;     /* the run's core sink; NULL untraced */
    rt_rec **rec;      /* per core: the recorder the tracer records into (NULL untraced) */
    rt_rec **back;     /* per core: the recorder behind rec[k] (a layout's translator sits in front), or NULL */
    rt_core_buf *buf;  /* per core */
    uint64_t phases;   /* barriers passed */
    uint64_t ticks;    /* ticks emitted */
    uint64_t emitted;  /* references handed to out */
    int failed;        /* out refused a batch: later references are dropped, rt_cores_failed */
    uint64_t bad_claims; /* C4: claims outside the claiming core's chunk; the first: */
    uint64_t bad_i, bad_n;
    int bad_k;
} rt_cores;

/* Sets up n cores (1..RT_TR_MAX_CORES is the caller's business) feeding
 * out (NULL: untraced). The recorders are installed by the caller:
 * rt_cores_sink(c, k) is where core k's chain must end, rt_cores_set_rec
 * names its front and back. 0, or -1 with e (c must still be freed). */
int rt_cores_init(rt_cores *c, int n, rt_csink *out, rt_err *e);
/* Frees the buffers and the recorder arrays, not the recorders (the
 * caller's). Accepts a zeroed or half made c. */
void rt_cores_free(rt_cores *c);
/* The sink core k's recorder chain ends in. */
static inline rt_sink *rt_cores_sink(rt_cores *c, int k) { return &c->buf[k].sink; }
/* Core k records into front; back (may be front or NULL) is the recorder
 * that feeds rt_cores_sink(c, k). rt_cores_sync flushes front, then back. */
void rt_cores_set_rec(rt_cores *c, int k, rt_rec *front, rt_rec *back);
/* The recorder of core k (NULL untraced). */
static inline rt_rec *rt_cores_rec(const rt_cores *c, int k) { return c->rec ? c->rec[k] : NULL; }

/* Core k's work in this phase is done (it drops out of the ticks). */
void rt_cores_done(rt_cores *c, int k);
/* Flushes the recorders and emits every complete tick. 0, or -1 once the
 * core sink failed. */
int rt_cores_sync(rt_cores *c);
/* Ends the phase: every core done, all buffered references emitted tick
 * by tick, every core open again, phases + 1. 0 or -1 (the sink failed). */
int rt_cores_barrier(rt_cores *c);
/* 1 once the core sink refused a batch. */
static inline int rt_cores_failed(const rt_cores *c) { return c->failed; }

/* Core k's chunk of a phase of n items: [rt_cores_lo(n, N, k), rt_cores_lo(n, N, k + 1)). */
static inline uint64_t rt_cores_lo(uint64_t n, int N, int k) { return n * (uint64_t)k / (uint64_t)N; }
/* The core whose chunk holds item i < n. */
static inline int rt_cores_owner(uint64_t i, uint64_t n, int N) { return (int)(((i + 1) * (uint64_t)N - 1) / n); }

/* A tracer's claim as it records work on item i of a phase of n items:
 * core k (the one whose recorder is current) is doing it. C4 holds when
 * every claim is the chunk rule's; a wrong one is counted (the first
 * kept) for rt_cores_check. */
static inline void rt_cores_claim(rt_cores *c, int k, uint64_t i, uint64_t n)
{
    if (rt_cores_owner(i, n, c->n) != k && !c->bad_claims++) {
        c->bad_k = k;
        c->bad_i = i;
        c->bad_n = n;
    }
}

/* One phase of n items over the cores' chunks, stepped in turn: item j of
 * core 0's chunk, item j of core 1's, ..., then item j + 1, with core k's
 * recorder current for its items (fn(u, k, i) records through
 * rt_cores_rec(c, k)); a core whose chunk is used up is done; then the
 * barrier. fn returns 0, or non-zero to stop (returned, after the barrier).
 * Returns 0, fn's value, or -1 when the sink failed. */
int rt_cores_steps(rt_cores *c, uint64_t n, int (*fn)(void *u, int k, uint64_t i), void *u);

/* C1-C4 between phases: 0, or -1 with a message naming the invariant
 * ("cores C1: ..."). */
int rt_cores_check(const rt_cores *c, rt_err *e);

#endif
