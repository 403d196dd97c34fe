/*
 * replay.c -- feed a trace file (.rtt through the trace reader, or din)
 * into any rt_sink: the one trace-replay loop (rt_sim_replay_threads, see
 * sim.h), used by the exact and the approximate simulators alike. Kept
 * apart from sim.c so programs that only stream in-process do not link the
 * trace reader.
 *
 * With two threads, decoding (inflate, record decoding or din parsing)
 * runs on a reader thread and the sink on the calling thread, through the
 * pipeline of pipe.c: a ring of PIPE_SLOTS buffers of PIPE_CHUNK records.
 * The consumer sees exactly the batches the single-threaded loop would
 * hand to the sink, in the same order, so every counter is the same; a
 * decode error reaches the caller after the records decoded before it,
 * as in the single-threaded loop. A repeat filter (sim.h, rt_repeats), if
 * the sink has one, runs on the reader thread after the decoder.
 */
#include "pipe.h"
#include "sim.h"
#include "sim_int.h"
#include "sindex.h"
#include "trace.h"

#include <errno.h>
#include <ctype.h>
#include <stdlib.h>
#include <string.h>

#define REPLAY_BUF 4096 /* 64 KB: small enough to stay in L2 beside the simulator */
#define PIPE_SLOTS 8    /* ring of 8 x 64 KB */
#define PIPE_CHUNK REPLAY_BUF

typedef long (*next_fn)(void *, rt_access *, size_t, rt_err *);

typedef struct pipe_ring {
    rt_access *slot[PIPE_SLOTS]; /* PIPE_CHUNK records each */
    long kept[PIPE_SLOTS];    /* records left in the slot after filtering */
    next_fn next;             /* decoder */
    void *src;                /* its state, touched only by the reader until the pipeline ends */
    /* repeat filter (rt_repeats), NULL if none; its state is the reader's */
    const rt_repeats *rp;
    uint64_t (*rep)[RT_SIM_NCG]; /* per slot: reads dropped, by (class, generation) */
    uint64_t last;            /* line the previous reference ended on */
    int have_last;            /* a reference has been seen */
    rt_sink *sink;            /* the consumer's */
    rt_sim_input *info;
} pipe_ring;

/* Drops from a[0..n) the one-line reads of the line the previous reference
 * ended on, counting them in rep; returns the records kept (compacted in
 * place, in order). The previous reference's end is its last line, or its
 * first when its end wraps past 2^64 (the simulators touch only that).
 * Branch-free (a third of the records are dropped, at random): the dropped
 * ones' indices are collected first and counted after the loop. */
static inline __attribute__((always_inline)) long drop_run(pipe_ring *q, rt_access *a, long n, uint64_t *rep,
                                                              const int sh)
{
    const uint64_t ls = q->rp->line;
    uint64_t last = q->last;
    unsigned have = (unsigned)q->have_last;
    uint8_t dcg[PIPE_CHUNK]; /* the dropped ones' (class, generation) indices, in turn */
    long k = 0, j = 0;
    for (long i = 0; i < n; i++) {
        const rt_access *r = &a[i];
        const uint64_t addr = r->addr, end = addr + (r->size ? r->size : 1) - 1;
        const uint64_t f = sh >= 0 ? addr >> sh : addr / ls, l = sh >= 0 ? end >> sh : end / ls;
        const unsigned drop = have & (r->write == 0) & (f == l) & (f == last);
        dcg[j] = (uint8_t)rt_sim_cg(r);
        j += drop;
        memcpy(&a[k], r, sizeof *r); /* k <= i: never ahead of the reads */
        k += 1 - (long)drop;
        last = l > f ? l : f; /* unchanged by a dropped one: f == l == last */
        have = 1;
    }
    /* four count rows in turn, so that neighbours, which mostly share an
     * index, do not wait on each other's increment */
    uint32_t cnt[4][RT_SIM_NCG];
    memset(cnt, 0, sizeof cnt);
    for (long i = 0; i < j; i++) cnt[i & 3][dcg[i]]++;
    for (int cg = 0; cg < RT_SIM_NCG; cg++) rep[cg] = (uint64_t)cnt[0][cg] + cnt[1][cg] + cnt[2][cg] + cnt[3][cg];
    q->last = last;
    q->have_last = (int)have;
    return k;
}

static long drop_repeats(pipe_ring *q, rt_access *a, long n, uint64_t *rep)
{
    const uint64_t ls = q->rp->line;
    if (ls == 64) return drop_run(q, a, n, rep, 6); /* the default, with a constant shift */
    if ((ls & (ls - 1)) == 0) return drop_run(q, a, n, rep, __builtin_ctzll(ls));
    return drop_run(q, a, n, rep, -1);
}

/* Reads the whole input through next() into sink, counting references. */
static long pump(next_fn next, void *src, rt_sink *sink, rt_access *buf,
                 rt_sim_input *info, rt_err *e)
{
    long n;
    while ((n = next(src, buf, REPLAY_BUF, e)) > 0) {
        if (sink->put(sink, buf, (size_t)n) < 0) return rt_errf(e, "the simulator rejected references");
        info->refs += (uint64_t)n;
    }
    return n;
}

static long ring_produce(void *ctx, unsigned i, rt_err *e)
{
    pipe_ring *q = ctx;
    long n = q->next(q->src, q->slot[i], PIPE_CHUNK, e);
    q->kept[i] = n > 0 && q->rp ? drop_repeats(q, q->slot[i], n, q->rep[i]) : n;
    return n;
}

static int ring_consume(void *ctx, unsigned i, long n, rt_err *e)
{
    pipe_ring *q = ctx;
    long k = q->kept[i];
    if (k < n) q->rp->add(q->rp->ctx, q->rep[i]);
    if (k > 0 && q->sink->put(q->sink, q->slot[i], (size_t)k) < 0)
        return rt_errf(e, "the simulator rejected references");
    q->info->refs += (uint64_t)n;
    q->info->repeats += (uint64_t)(n - k);
    return 0;
}

/* pump() with the decoder on a second thread. Falls back to pump() when
 * the thread cannot be started (nothing has been read then). */
static long pump2(next_fn next, void *src, rt_sink *sink, const rt_repeats *rp, rt_access *buf,
                  rt_sim_input *info, rt_err *e)
{
    pipe_ring *q = rt_calloc(1, sizeof *q, e);
    if (!q) return -1;
    rt_access *mem = rt_calloc((size_t)PIPE_SLOTS * PIPE_CHUNK, sizeof *mem, e);
    if (rp && rp->line && !(q->rep = rt_calloc(PIPE_SLOTS, sizeof *q->rep, e))) {
        free(mem);
        mem = NULL;
    }
    if (!mem) {
        free(q);
        return -1;
    }
    if (q->rep) q->rp = rp;
    for (int i = 0; i < PIPE_SLOTS; i++) q->slot[i] = mem + (size_t)i * PIPE_CHUNK;
    q->next = next;
    q->src = src;
    q->sink = sink;
    q->info = info;
    rt_pipe_ops ops = {ring_produce, ring_consume, q, PIPE_SLOTS};
    int rc = rt_pipe_run(&ops, e);
    free(q->rep);
    free(mem);
    free(q);
    if (rc > 0) return pump(next, src, sink, buf, info, e);
    return rc;
}

static long din_next(void *d, rt_access *b, size_t n, rt_err *e) { return rt_din_read(d, b, n, e); }
static long rtt_next(void *r, rt_access *b, size_t n, rt_err *e) { return rt_tr_read(r, b, n, e); }

int rt_sim_replay_sink(rt_sink *sink, const char *path, int fmt, int din_class, rt_tr_meta *meta,
                       rt_sim_input *info, rt_err *e)
{
    return rt_sim_replay_threads(sink, path, fmt, din_class, 1, meta, info, e);
}

int rt_sim_replay_threads(rt_sink *sink, const char *path, int fmt, int din_class, int nthreads, rt_tr_meta *meta,
                          rt_sim_input *info, rt_err *e)
{
    return rt_sim_replay_filtered(sink, NULL, path, fmt, din_class, nthreads, meta, info, e);
}

int rt_sim_replay_filtered(rt_sink *sink, const rt_repeats *rp, const char *path, int fmt, int din_class,
                           int nthreads, rt_tr_meta *meta, rt_sim_input *info, rt_err *e)
{
    if (nthreads < 1 || nthreads > RT_SIM_MAXTHREADS)
        return rt_errf(e, "%d replay threads: 1 to %d are supported", nthreads, RT_SIM_MAXTHREADS);

    rt_sim_input loc;
    if (!info) info = &loc;
    memset(info, 0, sizeof *info);
    if (fmt == RT_SIM_IN_AUTO) {
        fmt = rt_sim_sniff(path, e);
        if (fmt < 0) return -1;
    }
    rt_access *buf = rt_calloc(REPLAY_BUF, sizeof *buf, e);
    if (!buf) return -1;
    long n = -1;
    info->format = fmt;
    if (fmt == RT_SIM_IN_DIN) {
        rt_din *d = rt_din_open(path, din_class, e);
        if (d) {
            n = nthreads > 1 ? pump2(din_next, d, sink, rp, buf, info, e) : pump(din_next, d, sink, buf, info, e);
            info->file_bytes = rt_din_file_bytes(d);
            info->file_hash = rt_din_file_hash(d);
            rt_din_close(d);
        }
    } else {
        rt_tr_reader *r = rt_si_open(path, e);
        if (r) {
            rt_tr_set_side_check(r, 0); /* the records alone make the results: side chunks CRC-checked only */
            if (meta) *meta = *rt_tr_get_meta(r);
            info->has_meta = 1;
            n = nthreads > 1 ? pump2(rtt_next, r, sink, rp, buf, info, e) : pump(rtt_next, r, sink, buf, info, e);
            if (n == 0) {
                info->file_bytes = rt_tr_file_bytes(r);
                info->file_hash = rt_tr_file_hash(r);
            }
            rt_tr_close(r);
        }
    }
    free(buf);
    return n == 0 ? 0 : -1;
}

int rt_sim_replay(rt_sim *s, const char *path, int fmt, int din_class, rt_tr_meta *meta, rt_sim_input *info,
                  rt_err *e)
{
    return rt_sim_replay_sink(rt_sim_sink(s), path, fmt, din_class, meta, info, e);
}

int rt_sim_sniff(const char *path, rt_err *e)
{
    FILE *f = fopen(path, "rb");
    if (!f) return rt_errf(e, "%s: %s", path, strerror(errno));
    unsigned char b[4096];
    size_t n = fread(b, 1, sizeof b, f);
    int err = ferror(f);
    fclose(f);
    if (err) return rt_errf(e, "%s: read error", path);
    if (n == 0) return rt_errf(e, "%s: empty file", path);
    /* din: printable text whose first non-blank line is "digits space hex" */
    for (size_t i = 0; i < n; i++)
        if (!(isprint(b[i]) || b[i] == '\n' || b[i] == '\r' || b[i] == '\t')) return RT_SIM_IN_RTT;
    size_t i = 0;
    while (i < n && isspace(b[i])) i++;
    if (i < n && isdigit(b[i])) {
        while (i < n && isdigit(b[i])) i++;
        if (i < n && (b[i] == ' ' || b[i] == '\t')) {
            while (i < n && (b[i] == ' ' || b[i] == '\t')) i++;
            if (i < n && isxdigit(b[i])) return RT_SIM_IN_DIN;
        }
    }
    return rt_errf(e, "%s: neither a raytraffic trace nor a din file", path);
}
