/*
 * sindex.c -- the sample index: the side payload a version-3 trace stores
 * after every data chunk (sindex.h), made from the records by the writer,
 * re-made by the verifying reader, decoded by the sampled replay.
 *
 * WHAT IT IS. The hybrid method (approx.c, window.c, shards.c) needs of a
 * trace only the line-touch counts, the records that touch a golden-ratio
 * line sample, and a few exact windows with their warm-up. A trace that
 * stores those per chunk can be simulated without inflating or decoding a
 * single record: the side payloads are ~10% of the file. The trace format
 * (src/trace.c) stores the payloads as opaque bytes; this file is the only
 * place that knows what they hold.
 *
 * PAYLOAD of data chunk k (docs/trace-format.md has the table): u8 flags
 * (bit 0: the last chunk; the one byte the format reads; bits 1-2: the
 * classes stored beyond the first 10, so 10 + v classes follow, v > 0 only
 * when the chunk has a record of class 10 or later, the highest stored
 * being one); per stored class 5 varints (line touches by reads and by writes, refs, bytes, writes of
 * chunk k); varint ns and the ns records of chunk k that touch a sampled
 * line; varint nw and per window ending in chunk k (plus, in the last
 * chunk, the one the trace ends in): varints nwarm, scanned, u8 short,
 * varint nrecs, then nwarm warm-up records and nrecs window records. Each
 * record group is coded as a chunk is (src/trace_rec.h), from a reset
 * coder.
 *
 * THE MAKER (rt_si_maker, sindex_int.h) sees every record in order (the writer as it encodes
 * them, the verifying reader as it decodes them) and makes each chunk's
 * payload, so writer and reader produce the same bytes from the same
 * records and the reader checks a payload with one memcmp. The sampling
 * rules are cachesim/sample.h's. Its window logic is that of window.c at its
 * default placement (seed 1: window j measures records [s_j, s_j + M),
 * s_j = (j + 1) P - M - o), with the same backward scan, so a window
 * replayed from the payload gives the counters the hybrid method computes
 * from the whole stream. Memory: the history ring (hist records, 512 KiB
 * at the defaults), the scan's set, and one chunk's payload.
 *
 * INVARIANTS (rt_si_check; P = period, M = window, H = hist):
 *   I1  the parameters are the format's (line a power of two, 1 <= M <=
 *       P / 2, H <= P - M, 1 <= cmax) and shift = log2(line);
 *   I2  0 <= wn < M: a window closes as its M-th record arrives;
 *   I3  next = s_0 + j P for some j >= 0 (s_0 = rt_sample_first_window);
 *   I4  a window runs (wn > 0) iff pos > next, and then pos = next + wn;
 *   I5  with lo = max(next - H, 0) and q = min(pos, next): hn = q - lo if
 *       q > lo, else 0 -- the ring holds exactly the records of [lo, q),
 *       the history the next (or running) window's scan walks back over;
 *       hhead < H (or 0 when H = 0);
 *   I6  the chunk's tallies describe its pos - cpos records: the refs sum
 *       to pos - cpos, per class writes <= refs <= bytes and refs <=
 *       touches, and ns <= pos - cpos;
 *   I7  the encoded buffers fit their allocation (samp, wcur, wins, out),
 *       the window warm-up holds wnwarm <= cmax lines, the scan's set has
 *       a power-of-two size >= 4 cmax, and nw windows are in wins.
 *
 * THE DECODER (rt_si_read) parses a payload with every bound checked
 * (counts against the chunk's records and the parameters, each record as
 * the chunk decoder checks it, nothing left over), reports the class
 * totals to the trace reader for its footer check, and fails through
 * rt_tr_payload_fail so its messages name the file and the byte offset.
 */
#include "sindex_int.h"
#include "sample.h"

#include <stdlib.h>
#include <string.h>

/* ---- growable byte buffer ---------------------------------------------------- */

/* Room for `more` bytes at b->b + b->n; 0 or -1 (out of memory). */
static int bb_room(rt_si_buf *b, size_t more)
{
    if (more <= b->cap - b->n) return 0;
    size_t nc = b->cap ? b->cap : 4096;
    while (nc - b->n < more) nc *= 2;
    unsigned char *x = realloc(b->b, nc);
    if (!x) return -1;
    b->b = x;
    b->cap = nc;
    return 0;
}

/* ---- the maker ------------------------------------------------------------ */

#define GOLD RT_SAMPLE_GOLD

static void sb_free(rt_si_maker *b)
{
    if (!b) return;
    free(b->hist);
    free(b->set);
    free(b->setidx);
    free(b->stk);
    free(b->samp.b);
    free(b->wcur.b);
    free(b->wins.b);
    free(b->out.b);
    free(b);
}

/* The first window's start, by the rule window.c follows (sample.h). */
static uint64_t first_window(const rt_tr_sample_params *p)
{
    return rt_sample_first_window(p->period, p->window, p->seed);
}

static rt_si_maker *sb_new(const rt_tr_sample_params *p, unsigned maxgen, rt_err *e)
{
    rt_si_maker *b = rt_calloc(1, sizeof *b, e);
    if (!b) return NULL;
    b->p = *p;
    while ((1u << b->shift) != p->line) b->shift++;
    b->T64 = p->shift == 0 ? 0 : 1ULL << (64 - p->shift);
    b->goff = rt_sample_golden_offset(p->seed);
    b->maxgen = maxgen;
    b->next = first_window(p);
    uint64_t ss = 16;
    while (ss < 4 * p->cmax) ss <<= 1;
    b->setmask = ss - 1;
    b->setfill = ss;
    b->setshift = 64;
    for (uint64_t q = ss; q > 1; q >>= 1) b->setshift--;
    b->set = rt_calloc(ss, sizeof *b->set, e);
    b->setidx = b->set ? rt_calloc(ss, sizeof *b->setidx, e) : NULL;
    b->stk = b->setidx ? rt_calloc(p->cmax, sizeof *b->stk, e) : NULL;
    b->hist = b->stk && p->hist ? rt_calloc(p->hist, sizeof *b->hist, e) : NULL;
    if (!b->stk || (p->hist && !b->hist)) {
        sb_free(b);
        return NULL;
    }
    return b;
}

/* Window start: the backward scan of window.c's window_begin over the
 * ring; the lines found go to wcur, least recent first. */
static int sb_begin(rt_si_maker *b)
{
    memset(b->set, 0, (b->setmask + 1) * sizeof *b->set);
    const uint64_t cmax = b->p.cmax, mask = b->setmask;
    uint32_t seen = 0;
    uint64_t s = b->hn, prev = UINT64_MAX;
    while (s > 0 && seen < cmax) {
        --s;
        uint64_t at = b->hhead + (b->p.hist - b->hn) + s; /* < 2 hist: oldest kept is s = 0 */
        const rt_access *r = &b->hist[at >= b->p.hist ? at - b->p.hist : at];
        uint64_t f = r->addr >> b->shift, l = (r->addr + r->size - 1) >> b->shift;
        unsigned w = r->write ? 1 : 0, cls = r->cls;
        if (f == l && f == prev && !w) continue; /* a read of the line just met: nothing new */
        prev = f;
        for (uint64_t L = l + 1; L-- > f && seen < cmax;) {
            uint64_t i = (L * GOLD) >> b->setshift;
            while (b->set[i] && b->set[i] != L + 1) i = (i + 1) & mask;
            if (!b->set[i]) {
                b->set[i] = L + 1;
                b->setidx[i] = seen;
                b->stk[seen++] = (rt_access){L << b->shift, 1, (uint8_t)w, (uint8_t)cls, 0};
            } else if (w && !b->stk[b->setidx[i]].write) {
                b->stk[b->setidx[i]].write = 1;
                b->stk[b->setidx[i]].cls = (uint8_t)cls;
            }
        }
    }
    b->wscanned = b->hn - s;
    b->wnwarm = seen;
    b->wshort = seen < cmax && b->next - b->hn > 0;
    b->wcur.n = 0;
    if (bb_room(&b->wcur, (size_t)seen * RT_TRC_MAX_REC)) return -1;
    memset(&b->cw, 0, sizeof b->cw);
    unsigned char *q = b->wcur.b;
    for (uint32_t i = seen; i-- > 0;) q = rt_trc_enc(&b->cw, q, &b->stk[i]);
    b->wcur.n = (size_t)(q - b->wcur.b);
    memset(&b->cw, 0, sizeof b->cw); /* the window's records: a group of their own */
    return 0;
}

/* Appends the current window (complete, or the partial one at the end of
 * the trace) to wins. */
static int sb_close_window(rt_si_maker *b)
{
    if (bb_room(&b->wins, 4 * 10 + 1 + b->wcur.n)) return -1;
    unsigned char *q = b->wins.b + b->wins.n;
    q = rt_trc_put_varint(q, b->wnwarm);
    q = rt_trc_put_varint(q, b->wscanned);
    *q++ = (unsigned char)b->wshort;
    q = rt_trc_put_varint(q, b->wn);
    if (b->wcur.n) memcpy(q, b->wcur.b, b->wcur.n);
    b->wins.n = (size_t)(q - b->wins.b) + b->wcur.n;
    b->nw++;
    return 0;
}

/* Feeds n valid records. 0 or -1 (out of memory). The hot loop keeps its
 * state in locals (the history stores would otherwise make the compiler
 * reload it) and counts into four interleaved tables, so consecutive
 * records of one class do not wait on each other's store. */
static int sb_put(rt_si_maker *b, const rt_access *a, size_t n)
{
    const int sh = b->shift;
    const uint64_t T = b->T64, off = b->goff, H = b->p.hist;
    if (n == 0) return 0;
    if (bb_room(&b->samp, n * RT_TRC_MAX_REC)) return -1;
    unsigned char *sq = b->samp.b + b->samp.n;
    uint64_t cnt[4][RT_NCLASS][2], tch[4][RT_NCLASS][2], byt[4][RT_NCLASS];
    memset(cnt, 0, sizeof cnt);
    memset(tch, 0, sizeof tch);
    memset(byt, 0, sizeof byt);
    rt_access *restrict hist = b->hist;
    uint64_t pos = b->pos, next = b->next, hhead = b->hhead, hn = b->hn;
    int rc = 0;
    for (size_t i = 0; i < n; i++) {
        const rt_access *r = &a[i];
        unsigned cls = r->cls, w = r->write ? 1 : 0, k = i & 3;
        uint64_t f = r->addr >> sh, l = (r->addr + r->size - 1) >> sh;
        cnt[k][cls][w]++;
        tch[k][cls][w] += l - f + 1;
        byt[k][cls] += r->size;
        int hit = f <= l && (!T || f * GOLD + off < T || l * GOLD + off < T);
        for (uint64_t L = f + 1; !hit && L < l; L++) hit = L * GOLD + off < T; /* wider than two lines */
        if (hit) {
            sq = rt_trc_enc(&b->cs, sq, r);
            b->ns++;
        }
        if (pos < next) { /* before a window: keep the last hist records */
            if (pos + H >= next && H) {
                hist[hhead] = *r;
                hhead = hhead + 1 == H ? 0 : hhead + 1;
                hn += hn < H;
            }
        } else {
            b->hhead = hhead;
            b->hn = hn;
            if (b->wn == 0 && sb_begin(b)) rc = -1;
            if (!rc && bb_room(&b->wcur, RT_TRC_MAX_REC)) rc = -1;
            if (rc) break;
            b->wcur.n = (size_t)(rt_trc_enc(&b->cw, b->wcur.b + b->wcur.n, r) - b->wcur.b);
            if (++b->wn == b->p.window) {
                if (sb_close_window(b)) {
                    rc = -1;
                    break;
                }
                b->wn = 0;
                hn = 0;
                next = b->next += b->p.period;
            }
        }
        pos++;
    }
    b->pos = pos;
    b->hhead = hhead;
    b->hn = hn;
    b->samp.n = (size_t)(sq - b->samp.b);
    for (int k = 0; k < 4; k++)
        for (int c = 0; c < RT_NCLASS; c++) {
            for (int w = 0; w < 2; w++) {
                b->touch[c][w] += tch[k][c][w];
                b->refs[c] += cnt[k][c][w];
            }
            b->writes[c] += cnt[k][c][1];
            b->bytes[c] += byt[k][c];
        }
    return rc;
}

/* Makes the side payload of the chunk just ended into b->out and starts
 * the next chunk; last: the trace ends here (a window in progress is
 * stored as it is). 0 or -1 (out of memory). */
static int sb_chunk(rt_si_maker *b, int last)
{
    if (last && b->wn && sb_close_window(b)) return -1;
    b->out.n = 0;
    if (bb_room(&b->out, 1 + RT_NCLASS * 5 * 10 + 2 * 10 + b->samp.n + b->wins.n)) return -1;
    unsigned char *q = b->out.b;
    int nc = RT_NCLASS_V1; /* classes stored: 10, or up to the highest with a reference (flags bits 1-2) */
    for (int c = RT_NCLASS_V1; c < RT_NCLASS; c++)
        if (b->refs[c]) nc = c + 1;
    *q++ = (unsigned char)((last ? 1 : 0) | (nc - RT_NCLASS_V1) << 1);
    for (int c = 0; c < nc; c++) {
        q = rt_trc_put_varint(q, b->touch[c][0]);
        q = rt_trc_put_varint(q, b->touch[c][1]);
        q = rt_trc_put_varint(q, b->refs[c]);
        q = rt_trc_put_varint(q, b->bytes[c]);
        q = rt_trc_put_varint(q, b->writes[c]);
    }
    q = rt_trc_put_varint(q, b->ns);
    if (b->samp.n) memcpy(q, b->samp.b, b->samp.n); /* (a buffer never grown is NULL) */
    q += b->samp.n;
    q = rt_trc_put_varint(q, b->nw);
    if (b->wins.n) memcpy(q, b->wins.b, b->wins.n);
    q += b->wins.n;
    b->out.n = (size_t)(q - b->out.b);
    memset(b->touch, 0, sizeof b->touch);
    memset(b->refs, 0, sizeof b->refs);
    memset(b->bytes, 0, sizeof b->bytes);
    memset(b->writes, 0, sizeof b->writes);
    memset(&b->cs, 0, sizeof b->cs);
    b->cpos = b->pos;
    b->samp.n = 0;
    b->ns = 0;
    b->wins.n = 0;
    b->nw = 0;
    return 0;
}

/* ---- the maker as the trace format's payload maker ------------------------- */

/* The trace format hands over only parameters in its ranges; the
 * maker's own needs (I1) are checked again for any other caller. */
static void *si_open(const rt_tr_sample_params *p, unsigned generations, rt_err *e)
{
    if (p->line < 2 || p->line > (1u << 30) || (p->line & (p->line - 1)) || p->shift > 32 || p->window < 1 ||
        p->window > p->period / 2 || p->hist > p->period - p->window || p->cmax < 1 || p->cmax > (1u << 20))
        return rt_errf(e, "sample index: impossible parameters (line %u, rate 2^-%u, period %llu, window %llu, "
                       "%llu lines, history %llu)", p->line, p->shift, (unsigned long long)p->period,
                       (unsigned long long)p->window, (unsigned long long)p->cmax, (unsigned long long)p->hist),
               NULL;
    return sb_new(p, generations, e);
}
static int si_put(void *ctx, const rt_access *a, size_t n) { return sb_put(ctx, a, n); }
static int si_chunk(void *ctx, int last, const unsigned char **bytes, size_t *len)
{
    rt_si_maker *b = ctx;
    if (sb_chunk(b, last) < 0) return -1;
    *bytes = b->out.b;
    *len = b->out.n;
    return 0;
}
static void si_close(void *ctx) { sb_free(ctx); }

const rt_tr_payload_ops rt_si_payload = {
    {RT_SI_LINE, RT_SI_SHIFT, RT_SI_SEED, RT_SI_PERIOD, RT_SI_WINDOW, RT_SI_CMAX, RT_SI_HIST},
    si_open,
    si_put,
    si_chunk,
    si_close,
};

void rt_si_wopts(rt_tr_wopts *o)
{
    rt_tr_default_wopts(o);
    o->payload = &rt_si_payload;
}

rt_tr_reader *rt_si_open(const char *path, rt_err *e)
{
    rt_tr_reader *r = rt_tr_open(path, e);
    if (r) rt_tr_set_payload_check(r, &rt_si_payload);
    return r;
}

/* ---- the checker ------------------------------------------------------------- */

int rt_si_check(const void *maker, rt_err *e)
{
    const rt_si_maker *b = maker;
    const rt_tr_sample_params *p = &b->p;
    const uint64_t P = p->period, M = p->window, H = p->hist;
    if (p->line < 2 || (p->line & (p->line - 1)) || (1u << b->shift) != p->line || M < 1 || M > P / 2 ||
        H > P - M || p->cmax < 1)
        return rt_errf(e, "sample index maker: I1: parameters (line %u, shift %d, period %llu, window %llu, "
                       "history %llu)", p->line, b->shift, (unsigned long long)P, (unsigned long long)M,
                       (unsigned long long)H);
    if (b->wn >= M) return rt_errf(e, "sample index maker: I2: window of %llu records open", (unsigned long long)b->wn);
    uint64_t s0 = rt_sample_first_window(P, M, p->seed);
    if (b->next < s0 || (b->next - s0) % P)
        return rt_errf(e, "sample index maker: I3: next window at %llu, not %llu + j %llu", (unsigned long long)b->next,
                       (unsigned long long)s0, (unsigned long long)P);
    if ((b->wn > 0) != (b->pos > b->next) || (b->wn > 0 && b->pos != b->next + b->wn))
        return rt_errf(e, "sample index maker: I4: %llu records seen, window at %llu has %llu",
                       (unsigned long long)b->pos, (unsigned long long)b->next, (unsigned long long)b->wn);
    uint64_t lo = b->next > H ? b->next - H : 0, q = b->pos < b->next ? b->pos : b->next;
    if (b->hn != (q > lo ? q - lo : 0) || (H ? b->hhead >= H : b->hhead != 0))
        return rt_errf(e, "sample index maker: I5: %llu history records kept (head %llu), expected %llu",
                       (unsigned long long)b->hn, (unsigned long long)b->hhead,
                       (unsigned long long)(q > lo ? q - lo : 0));
    uint64_t n = b->pos - b->cpos, sum = 0;
    for (int c = 0; c < RT_NCLASS; c++) {
        if (b->writes[c] > b->refs[c] || b->refs[c] > b->bytes[c] || b->refs[c] > b->touch[c][0] + b->touch[c][1])
            return rt_errf(e, "sample index maker: I6: class %d tallies (refs %llu, bytes %llu, writes %llu)", c,
                           (unsigned long long)b->refs[c], (unsigned long long)b->bytes[c],
                           (unsigned long long)b->writes[c]);
        sum += b->refs[c];
    }
    if (b->cpos > b->pos || sum != n || b->ns > n)
        return rt_errf(e, "sample index maker: I6: %llu records in the chunk, %llu tallied, %llu sampled",
                       (unsigned long long)n, (unsigned long long)sum, (unsigned long long)b->ns);
    uint64_t ss = b->setmask + 1;
    if (b->samp.n > b->samp.cap || b->wcur.n > b->wcur.cap || b->wins.n > b->wins.cap || b->out.n > b->out.cap ||
        b->wnwarm > p->cmax || (ss & (ss - 1)) || ss < 4 * p->cmax || ss != b->setfill || (b->nw > 0) != (b->wins.n > 0))
        return rt_errf(e, "sample index maker: I7: buffers (sampled %zu/%zu, window %zu/%zu, windows %zu/%zu for %llu, "
                       "%u warm-up lines, set of %llu)", b->samp.n, b->samp.cap, b->wcur.n, b->wcur.cap, b->wins.n,
                       b->wins.cap, (unsigned long long)b->nw, b->wnwarm, (unsigned long long)ss);
    return 0;
}

/* ---- the decoder --------------------------------------------------------------- */

struct rt_si_reader {
    rt_tr_reader *r;        /* the trace (borrowed) */
    rt_tr_sample_params sp; /* its parameters */
    unsigned maxgen;        /* its generations */
    rt_access *srec;        /* decoded records: sampled, then each window's warm-up and records */
    size_t sreccap;         /* capacity */
    rt_si_window *swin;     /* windows */
    uint32_t swincap;       /* capacity */
};

rt_si_reader *rt_si_reader_new(rt_tr_reader *r, rt_err *e)
{
    rt_si_reader *d = rt_calloc(1, sizeof *d, e);
    if (!d) return NULL;
    d->r = r;
    rt_tr_get_sample_params(r, &d->sp); /* none: rt_si_read fails as rt_tr_read_payload does */
    d->maxgen = rt_tr_get_meta(r)->generations;
    return d;
}

void rt_si_reader_free(rt_si_reader *d)
{
    if (!d) return;
    free(d->srec);
    free(d->swin);
    free(d);
}

/* Parses the payload pl into s, checking its structure and its totals
 * against its chunk; 0, or -1 through rt_tr_payload_fail. */
static int parse_side(rt_si_reader *d, const rt_tr_payload *pl, rt_si_side *s, rt_err *e)
{
    const unsigned char *p = pl->bytes + 1, *end = pl->bytes + pl->len;
    uint64_t n = pl->nrefs;
    const rt_tr_sample_params *sp = &d->sp;
    rt_tr_totals tot;
    memset(&tot, 0, sizeof tot);
    memset(s, 0, sizeof *s);
    s->nrefs = n;
    uint64_t sum = 0, v[5];
    const char *bad = NULL;
    const int nc = RT_NCLASS_V1 + ((pl->bytes[0] & RT_TR_SIDE_MAKER) >> 1); /* classes stored (10..13) */
    for (int c = 0; c < nc && !bad; c++) {
        for (int k = 0; k < 5 && !bad; k++)
            if (rt_trc_get_varint(&p, end, &v[k]) < 0) bad = "bad class totals";
        if (bad) break;
        if (v[2] > n || v[4] > v[2] || v[3] < v[2]) {
            bad = "impossible class totals";
            break;
        }
        s->touches[c][0] = v[0];
        s->touches[c][1] = v[1];
        tot.refs[c] = v[2];
        tot.bytes[c] = v[3];
        tot.writes[c] = v[4];
        sum += v[2];
    }
    if (!bad && sum != n) bad = "class totals do not add up to the chunk's records";
    uint64_t ns = 0, nw = 0, nwmax = n / sp->period + 2;
    if (!bad && (rt_trc_get_varint(&p, end, &ns) < 0 || ns > n)) bad = "bad sampled record count";
    /* the records: ns sampled, then per window up to cmax + window */
    uint64_t need = ns + nwmax * (sp->cmax + sp->window);
    if (!bad && need > d->sreccap) {
        rt_access *x = realloc(d->srec, (size_t)need * sizeof *x);
        if (!x) return rt_tr_payload_fail(d->r, e, "out of memory");
        d->srec = x;
        d->sreccap = (size_t)need;
    }
    if (!bad && nwmax > d->swincap) {
        rt_si_window *x = realloc(d->swin, (size_t)nwmax * sizeof *x);
        if (!x) return rt_tr_payload_fail(d->r, e, "out of memory");
        d->swin = x;
        d->swincap = (uint32_t)nwmax;
    }
    rt_access *q = d->srec;
    rt_trc_coder cd;
    int dr = RT_TRC_OK;
    if (!bad) {
        memset(&cd, 0, sizeof cd);
        for (uint64_t i = 0; i < ns && !dr; i++) dr = rt_trc_dec(&p, end, &cd, d->maxgen, q++);
    }
    if (!bad && !dr && (rt_trc_get_varint(&p, end, &nw) < 0 || nw > nwmax)) bad = "bad window count";
    for (uint64_t j = 0; j < nw && !bad && !dr; j++) {
        rt_si_window *w = &d->swin[j];
        uint64_t nwarm, scanned, nrecs;
        if (rt_trc_get_varint(&p, end, &nwarm) < 0 || nwarm > sp->cmax || rt_trc_get_varint(&p, end, &scanned) < 0 ||
            scanned > sp->hist || p == end || *p > 1) {
            bad = "bad window warm-up";
            break;
        }
        w->short_warmup = *p++;
        if (rt_trc_get_varint(&p, end, &nrecs) < 0 || nrecs < 1 || nrecs > sp->window ||
            (nrecs < sp->window && !pl->last)) {
            bad = "bad window length";
            break;
        }
        w->nwarm = (uint32_t)nwarm;
        w->scanned = scanned;
        w->nrecs = (uint32_t)nrecs;
        w->warm = q;
        memset(&cd, 0, sizeof cd);
        for (uint64_t i = 0; i < nwarm && !dr; i++) dr = rt_trc_dec(&p, end, &cd, d->maxgen, q++);
        w->recs = q;
        memset(&cd, 0, sizeof cd);
        for (uint64_t i = 0; i < nrecs && !dr; i++) dr = rt_trc_dec(&p, end, &cd, d->maxgen, q++);
    }
    if (!bad && dr) bad = rt_trc_msg(dr);
    if (!bad && p != end) bad = "bytes left over after the last window";
    if (bad) return rt_tr_payload_fail(d->r, e, "%s", bad);
    rt_tr_payload_tally(d->r, &tot);
    s->sampled = d->srec;
    s->nsampled = ns;
    s->win = d->swin;
    s->nwin = (uint32_t)nw;
    return 0;
}

int rt_si_read(rt_si_reader *d, rt_si_side *s, rt_err *e)
{
    memset(s, 0, sizeof *s);
    rt_tr_payload pl;
    int k = rt_tr_read_payload(d->r, &pl, e);
    if (k <= 0) return k;
    return parse_side(d, &pl, s, e) < 0 ? -1 : 1;
}
