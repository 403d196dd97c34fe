/*
 * approx.c -- the rt_approx front door (approx.h): configuration, method
 * names and canonical parameters, the split of sizes between the exact
 * simulator (sizes below exact_below) and a sampling estimator (shards.c,
 * statstack.c), replay, availability rules, rounding of estimates, and
 * database rows.
 *
 * Size split: sizes[0..nexact-1] (those < exact_below, or all of them for
 * RT_APPROX_EXACT) go to an rt_sim that sees every reference; the rest,
 * converted to lines, go to the estimator, which also counts every touch
 * (so accesses are exact for every size). Estimates are doubles in full-
 * trace units; rt_approx_get clamps misses to the exact accesses of their
 * kind, rounds to the nearest integer and recomputes traffic as the exact
 * simulator does, so (rm + wm + wb) * line == traffic_bytes holds here too.
 *
 * Sample index: a version-3 trace stores, per chunk, the exact touch
 * counts, the records touching its golden-ratio line sample and the
 * hybrid's windows with their warm-up (sindex.h). rt_approx_replay_file
 * feeds those instead of the records when rt_approx_sample_fits says they
 * give the same estimates (hybrid, no exact sizes, the stream's line, seed
 * and windows, a rate at most the stream's), on a second thread that
 * reads and decodes; otherwise it replays every record and says why.
 *
 * Availability: a size has no estimate if the sample is smaller than
 * RT_APPROX_MIN_SAMPLES (too few sampled lines or references: the trace is
 * too short for the rate; not checked at rate 1, where nothing is left
 * out), or, for SHARDS, if the cache holds fewer than
 * one sampled line (R x lines < 1; its hit threshold would be below one
 * sampled line, so only immediate re-touches could hit).
 */
#include "approx.h"
#include "approx_int.h"
#include "pipe.h"
#include "sim_int.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>


struct rt_approx {
    rt_sim_config cfg;          /* as created */
    rt_approx_config ac;        /* as created (rate as given) */
    rt_sink sink;               /* put() -> rt_approx_put */
    uint64_t refs;              /* references seen */
    rt_sim *exact;              /* sizes 0..nexact-1, or NULL */
    int nexact;                 /* sizes simulated exactly */
    rt_shards *sh;              /* SHARDS estimator, or NULL */
    rt_sstack *ss;              /* StatStack estimator, or NULL */
    rt_window *tw;                /* hybrid: windowed sizes nexact..nexact+nwin-1, or NULL */
    int nwin;                   /* sizes on windows */
    uint64_t acc[RT_NCLASS][2]; /* exact touches by class, write */
    rt_approx_est est;          /* estimates of the last finish */
    int finished;               /* est is valid */
    uint64_t fin_refs;          /* refs at the last finish */
};

static const char *const method_names[RT_APPROX_NMETHODS] = {"exact", "shards", "shards-fixed", "statstack",
                                                              "hybrid"};

void rt_approx_config_default(rt_approx_config *ac)
{
    memset(ac, 0, sizeof *ac);
    ac->method = RT_APPROX_SHARDS_RATE;
    ac->rate = rt_approx_default_rate(ac->method);
    ac->smax = 8192;
    ac->seed = 1;
    ac->exact_below = 0;
    ac->window_below = RT_APPROX_HYBRID_WINDOW_BELOW;
    ac->period = RT_APPROX_HYBRID_PERIOD;
    ac->window = RT_APPROX_HYBRID_WINDOW;
}

double rt_approx_default_rate(int method) { return method == RT_APPROX_HYBRID ? RT_APPROX_HYBRID_RATE : 0.01; }

const char *rt_approx_method_name(int method)
{
    return method >= 0 && method < RT_APPROX_NMETHODS ? method_names[method] : NULL;
}

int rt_approx_method_from_name(const char *name)
{
    for (int i = 0; name && i < RT_APPROX_NMETHODS; i++)
        if (!strcmp(name, method_names[i])) return i;
    return -1;
}

const char *rt_approx_params(const rt_approx_config *ac, char *buf, size_t n)
{
    if (!n) return buf;
    switch (ac->method) {
    case RT_APPROX_SHARDS_RATE:
    case RT_APPROX_STATSTACK:
        snprintf(buf, n, "rate=%.6g seed=%llu exact_below=%llu", ac->rate, (unsigned long long)ac->seed,
                 (unsigned long long)ac->exact_below);
        break;
    case RT_APPROX_HYBRID:
        snprintf(buf, n, "rate=%.6g seed=%llu window_below=%llu period=%llu window=%llu exact_below=%llu", ac->rate,
                 (unsigned long long)ac->seed, (unsigned long long)ac->window_below, (unsigned long long)ac->period,
                 (unsigned long long)ac->window, (unsigned long long)ac->exact_below);
        break;
    case RT_APPROX_SHARDS_FIXED:
        snprintf(buf, n, "smax=%llu seed=%llu exact_below=%llu", (unsigned long long)ac->smax,
                 (unsigned long long)ac->seed, (unsigned long long)ac->exact_below);
        break;
    default:
        buf[0] = 0;
    }
    return buf;
}

int rt_approx_config_check(const rt_sim_config *c, const rt_approx_config *ac, rt_err *e)
{
    if (rt_sim_config_check(c, e)) return -1;
    if (!rt_approx_method_name(ac->method)) return rt_errf(e, "unknown approximation method %d", ac->method);
    if (ac->method == RT_APPROX_EXACT) return 0;
    if (c->repl)
        return rt_errf(e, "sampled simulation (%s) models LRU only, not replacement policy %s: use the exact method",
                       rt_approx_method_name(ac->method), rt_sim_repl_name(c->repl));
    if (c->flush || c->write_miss_fullline)
        return rt_errf(e, "sampled simulation (%s) does not model %s: use the exact method",
                       rt_approx_method_name(ac->method), rt_sim_policy_name(c));
    if (c->assoc || c->write_through || c->no_write_allocate)
        return rt_errf(e, "sampled simulation (%s) supports only fully associative write-back write-allocate "
                          "caches, not %s assoc %u",
                       rt_approx_method_name(ac->method), rt_sim_policy_name(c), c->assoc);
    if (ac->method == RT_APPROX_SHARDS_FIXED) {
        if (ac->smax < RT_APPROX_MIN_SAMPLES || ac->smax > (1ULL << 30))
            return rt_errf(e, "smax %llu out of range (%d..%llu)", (unsigned long long)ac->smax,
                           RT_APPROX_MIN_SAMPLES, 1ULL << 30);
    } else if (!(ac->rate >= 0x1p-32 && ac->rate <= 1)) {
        return rt_errf(e, "sampling rate %g out of range (2^-32 .. 1)", ac->rate);
    }
    if (ac->method == RT_APPROX_HYBRID) {
        if (ac->window < 1 || ac->period < 2 * ac->window)
            return rt_errf(e, "hybrid: window %llu must be at least 1 and at most half the period %llu",
                           (unsigned long long)ac->window, (unsigned long long)ac->period);
        if (ac->period > (1ULL << 40))
            return rt_errf(e, "hybrid: period %llu too large", (unsigned long long)ac->period);
    }
    return 0;
}

static int sink_put(rt_sink *sk, const rt_access *a, size_t n) { return rt_approx_put(sk->ctx, a, n); }

rt_approx *rt_approx_new(const rt_sim_config *c, const rt_approx_config *ac, rt_err *e)
{
    if (rt_approx_config_check(c, ac, e)) return NULL;
    rt_approx *a = rt_calloc(1, sizeof *a, e);
    if (!a) return NULL;
    a->cfg = *c;
    a->ac = *ac;
    a->sink.put = sink_put;
    a->sink.ctx = a;
    if (ac->method == RT_APPROX_EXACT) a->nexact = c->nsizes;
    else
        while (a->nexact < c->nsizes && c->sizes[a->nexact] < ac->exact_below) a->nexact++;
    if (a->nexact) {
        rt_sim_config ce = *c;
        ce.nsizes = a->nexact;
        a->exact = rt_sim_new(&ce, e);
        if (!a->exact) goto fail;
    }
    if (ac->method == RT_APPROX_HYBRID) {
        while (a->nexact + a->nwin < c->nsizes && c->sizes[a->nexact + a->nwin] < ac->window_below) a->nwin++;
        if (a->nwin) {
            a->tw = rt_window_new(c->sizes + a->nexact, a->nwin, c->line, ac->period, ac->window, ac->seed, e);
            if (!a->tw) goto fail;
        }
    }
    int first = a->nexact + a->nwin, ns = c->nsizes - first;
    if (ns > 0) {
        uint64_t lines[RT_SIM_MAXSIZES];
        for (int i = 0; i < ns; i++) lines[i] = c->sizes[first + i] / c->line;
        if (ac->method == RT_APPROX_STATSTACK) a->ss = rt_sstack_new(lines, ns, c->line, ac->rate, ac->seed, e);
        else
            a->sh = rt_shards_new(lines, ns, c->line, ac->rate, ac->method == RT_APPROX_SHARDS_FIXED ? ac->smax : 0,
                                  ac->seed, ac->method == RT_APPROX_HYBRID, e);
        if (!a->ss && !a->sh) goto fail;
        /* the hybrid's error: replicates of its golden sample (below rate 1,
         * where the sample is not everything) */
        if (a->sh && ac->method == RT_APPROX_HYBRID && ac->errors && ac->rate < 1 &&
            rt_shards_split(a->sh, lines, RT_APPROX_SE_PARTS, e))
            goto fail;
    }
    return a;
fail:
    rt_approx_free(a);
    return NULL;
}

void rt_approx_free(rt_approx *a)
{
    if (!a) return;
    rt_sim_free(a->exact);
    rt_shards_free(a->sh);
    rt_sstack_free(a->ss);
    rt_window_free(a->tw);
    free(a);
}

const rt_sim_config *rt_approx_get_config(const rt_approx *a) { return &a->cfg; }
const rt_approx_config *rt_approx_get_approx_config(const rt_approx *a) { return &a->ac; }
rt_sink *rt_approx_sink(rt_approx *a) { return &a->sink; }
uint64_t rt_approx_refs(const rt_approx *a) { return a->refs; }

/* Exact touch counts when no sampling estimator runs beside the windows. */
static void count_touches(rt_approx *a, const rt_access *r, size_t n)
{
    rt_approx_lines ln;
    rt_approx_lines_init(&ln, a->cfg.line);
    for (size_t i = 0; i < n; i++) {
        rt_approx_touch t = rt_approx_touch_of(&ln, &r[i]);
        a->acc[t.cls][t.w] += t.last - t.first + 1;
    }
}

int rt_approx_put(rt_approx *a, const rt_access *acc, size_t n)
{
    a->refs += n;
    if (a->exact) rt_sim_put(a->exact, acc, n);
    if (a->tw) rt_window_put(a->tw, acc, n);
    if (a->sh) rt_shards_put(a->sh, acc, n, a->acc);
    else if (a->tw) count_touches(a, acc, n); /* no estimator counts them */
    if (a->ss) rt_sstack_put(a->ss, acc, n, a->acc);
    return 0;
}

int rt_approx_replay(rt_approx *a, const char *path, int fmt, int din_class, rt_tr_meta *meta,
                     rt_sim_input *info, rt_err *e)
{
    return rt_sim_replay_sink(&a->sink, path, fmt, din_class, meta, info, e);
}

static void approx_add_repeats(void *ctx, const uint64_t *cnt)
{
    rt_approx *a = ctx;
    rt_repeats r;
    rt_sim_repeats(a->exact, &r);
    for (int cg = 0; cg < RT_NCLASS * RT_MAXGEN; cg++) a->refs += cnt[cg];
    r.add(r.ctx, cnt);
}

void rt_approx_repeats(rt_approx *a, rt_repeats *out)
{
    memset(out, 0, sizeof *out);
    /* only the exact method, whose one engine may count them */
    if (a->ac.method != RT_APPROX_EXACT || !a->exact || a->tw || a->sh || a->ss) return;
    rt_sim_repeats(a->exact, out);
    if (!out->line) return;
    out->add = approx_add_repeats;
    out->ctx = a;
}

int rt_approx_sample_fits(const rt_approx *a, const rt_tr_sample_params *sp, char *why, size_t n)
{
    const rt_approx_config *ac = &a->ac;
    if (ac->method != RT_APPROX_HYBRID)
        return snprintf(why, n, "the sample index serves the hybrid method, not %s", method_names[ac->method]), 0;
    if (a->refs) return snprintf(why, n, "references were already fed"), 0;
    if (a->nexact) return snprintf(why, n, "sizes below exact_below need every reference"), 0;
    if (a->cfg.line != sp->line)
        return snprintf(why, n, "the sample index has %u-byte lines, not %u", sp->line, a->cfg.line), 0;
    if (ac->seed != sp->seed)
        return snprintf(why, n, "the sample index has seed %llu, not %llu", (unsigned long long)sp->seed,
                        (unsigned long long)ac->seed), 0;
    if (a->sh && sp->shift > 0) { /* golden samples: the lines under T64 (shards.c), nested in T64 */
        double T = floor(ac->rate * 0x1p64 + 0.5);
        if (T >= 0x1p64 || T > ldexp(1, 64 - (int)sp->shift))
            return snprintf(why, n, "rate %g is above the sample index's 1/%llu", ac->rate,
                            1ULL << sp->shift), 0;
    }
    if (a->tw) {
        uint64_t cmax = a->cfg.sizes[a->nexact + a->nwin - 1] / a->cfg.line;
        if (ac->period != sp->period || ac->window != sp->window || cmax != sp->cmax ||
            rt_window_hist(a->tw) != sp->hist)
            return snprintf(why, n, "windows of %llu every %llu warmed for %llu lines are not the sample index's "
                            "(%llu every %llu for %llu lines)",
                            (unsigned long long)ac->window, (unsigned long long)ac->period, (unsigned long long)cmax,
                            (unsigned long long)sp->window, (unsigned long long)sp->period,
                            (unsigned long long)sp->cmax), 0;
    }
    if (n) why[0] = 0;
    return 1;
}

int rt_approx_put_side(rt_approx *a, const rt_si_side *s)
{
    a->refs += s->nrefs;
    for (int c = 0; c < RT_NCLASS; c++)
        for (int w = 0; w < 2; w++) a->acc[c][w] += s->touches[c][w];
    if (a->sh) { /* the touches were counted by the writer; these are the sampled ones again */
        uint64_t scratch[RT_NCLASS][2];
        rt_shards_put(a->sh, s->sampled, (size_t)s->nsampled, scratch);
    }
    for (uint32_t j = 0; a->tw && j < s->nwin; j++) {
        const rt_si_window *w = &s->win[j];
        rt_window_put_warm(a->tw, w->warm, w->nwarm, w->scanned, w->short_warmup, w->recs, w->nrecs);
    }
    return 0;
}

/* ---- sample-index replay on two threads ----
 * The reader thread reads, hashes, CRC-checks, inflates and decodes side
 * chunks (rt_si_read) and copies each into a slot of the pipeline
 * (pipe.c); the calling thread feeds the slots to the estimator in order. */
#define SIDE_SLOTS 4

typedef struct side_slot {
    rt_si_side s;       /* the copy, pointing into rec and win */
    rt_access *rec;     /* sampled records, then each window's warm-up and records */
    size_t reccap;      /* capacity */
    rt_si_window *win;  /* windows */
    uint32_t wincap;    /* capacity */
} side_slot;

typedef struct side_ring {
    side_slot slot[SIDE_SLOTS];
    rt_si_reader *r;    /* the reader thread's until the pipeline ends */
    rt_approx *a;       /* the consumer's */
    uint64_t *refs;
} side_ring;

/* Deep copy of s into x; 0 or -1 (out of memory). */
static int side_copy(side_slot *x, const rt_si_side *s)
{
    size_t need = (size_t)s->nsampled;
    for (uint32_t j = 0; j < s->nwin; j++) need += s->win[j].nwarm + (size_t)s->win[j].nrecs;
    if (need > x->reccap) {
        rt_access *p = realloc(x->rec, need * sizeof *p);
        if (!p) return -1;
        x->rec = p;
        x->reccap = need;
    }
    if (s->nwin > x->wincap) {
        rt_si_window *p = realloc(x->win, s->nwin * sizeof *p);
        if (!p) return -1;
        x->win = p;
        x->wincap = s->nwin;
    }
    x->s = *s;
    rt_access *q = x->rec;
    if (s->nsampled) memcpy(q, s->sampled, (size_t)s->nsampled * sizeof *q);
    x->s.sampled = q;
    q += s->nsampled;
    for (uint32_t j = 0; j < s->nwin; j++) {
        x->win[j] = s->win[j];
        if (s->win[j].nwarm) memcpy(q, s->win[j].warm, s->win[j].nwarm * sizeof *q);
        x->win[j].warm = q;
        q += s->win[j].nwarm;
        memcpy(q, s->win[j].recs, s->win[j].nrecs * sizeof *q);
        x->win[j].recs = q;
        q += s->win[j].nrecs;
    }
    x->s.win = x->win;
    return 0;
}

static long side_produce(void *ctx, unsigned i, rt_err *e)
{
    side_ring *q = ctx;
    rt_si_side sd;
    int k = rt_si_read(q->r, &sd, e);
    if (k > 0 && side_copy(&q->slot[i], &sd) < 0) return rt_errf(e, "out of memory");
    return k;
}

static int side_consume(void *ctx, unsigned i, long n, rt_err *e)
{
    side_ring *q = ctx;
    (void)n;
    (void)e;
    rt_approx_put_side(q->a, &q->slot[i].s);
    *q->refs += q->slot[i].s.nrefs;
    return 0;
}

/* Feeds every side chunk of r to a: 0 at the verified end, -1 (e). */
static int side_pump(rt_approx *a, rt_tr_reader *tr, int nthreads, uint64_t *refs, rt_err *e)
{
    rt_si_reader *r = rt_si_reader_new(tr, e);
    if (!r) return -1;
    int rc = 1;
    if (nthreads > 1) {
        side_ring *q = calloc(1, sizeof *q);
        if (q) {
            q->r = r;
            q->a = a;
            q->refs = refs;
            rt_pipe_ops ops = {side_produce, side_consume, q, SIDE_SLOTS};
            rc = rt_pipe_run(&ops, e);
            for (int i = 0; i < SIDE_SLOTS; i++) {
                free(q->slot[i].rec);
                free(q->slot[i].win);
            }
            free(q);
        }
    }
    if (rc <= 0) {
        rt_si_reader_free(r);
        return rc;
    }
    /* one thread: read and feed in turn */
    rt_si_side sd;
    int k;
    while ((k = rt_si_read(r, &sd, e)) > 0) {
        rt_approx_put_side(a, &sd);
        *refs += sd.nrefs;
    }
    rt_si_reader_free(r);
    return k;
}

int rt_approx_replay_file(rt_approx *a, const char *path, int fmt, int din_class, int nthreads, rt_tr_meta *meta,
                          rt_sim_input *info, char *note, size_t n, rt_err *e)
{
    if (n) note[0] = 0;
    if (nthreads < 1 || nthreads > RT_SIM_MAXTHREADS)
        return rt_errf(e, "%d replay threads: 1 to %d are supported", nthreads, RT_SIM_MAXTHREADS);
    if (a->ac.method == RT_APPROX_HYBRID) {
        if (fmt == RT_SIM_IN_AUTO && (fmt = rt_sim_sniff(path, e)) < 0) return -1;
        rt_tr_reader *r = fmt == RT_SIM_IN_RTT ? rt_tr_open(path, e) : NULL;
        if (fmt == RT_SIM_IN_RTT && !r) return -1;
        rt_tr_sample_params sp;
        char why[200];
        if (r && !rt_tr_get_sample_params(r, &sp))
            snprintf(note, n, "%s: format version %u has no sample index; decoding every record", path,
                     rt_tr_get_version(r));
        else if (r && !rt_approx_sample_fits(a, &sp, why, sizeof why))
            snprintf(note, n, "%s: %s; decoding every record", path, why);
        else if (r) {
            rt_sim_input loc;
            if (!info) info = &loc;
            memset(info, 0, sizeof *info);
            info->format = RT_SIM_IN_RTT;
            info->has_meta = 1;
            if (meta) *meta = *rt_tr_get_meta(r);
            int k = side_pump(a, r, nthreads, &info->refs, e);
            if (k == 0) {
                info->file_bytes = rt_tr_file_bytes(r);
                info->file_hash = rt_tr_file_hash(r);
            }
            rt_tr_close(r);
            return k == 0 ? 0 : -1;
        }
        rt_tr_close(r);
    }
    rt_repeats rp;
    rt_approx_repeats(a, &rp);
    return rt_sim_replay_filtered(&a->sink, &rp, path, fmt, din_class, nthreads, meta, info, e);
}

const char *rt_approx_engine(const rt_approx *a)
{
    return a->ac.method == RT_APPROX_EXACT ? rt_sim_engine(a->exact) : method_names[a->ac.method];
}

/* Standard errors of the SHARDS sizes from the spread of the replicates'
 * estimates (shards.c, REPLICATES): sqrt(sample variance / K). */
static int shards_se(rt_approx *a, rt_err *e)
{
    int K = rt_shards_nparts(a->sh), first = a->nexact + a->nwin, ns = a->cfg.nsizes - first;
    if (K == 0) { /* rate 1: the estimate is exact */
        for (int i = 0; i < ns; i++)
            for (int g = 0; g <= RT_NGROUP; g++) a->est.se[a->nwin + i][g] = a->est.rate >= 1 ? 0 : -1;
        return 0;
    }
    rt_approx_est *pe = rt_calloc(1, sizeof *pe, e);
    double (*x)[RT_SIM_MAXSIZES][RT_NGROUP + 1] = rt_calloc((size_t)K, sizeof *x, e);
    if (!pe || !x) {
        free(pe);
        free(x);
        return -1;
    }
    double prate = 0;
    for (int p = 0; p < K; p++) {
        memset(pe, 0, sizeof *pe);
        if (rt_shards_estimate_part(a->sh, p, pe, 0, e)) {
            free(pe);
            free(x);
            return -1;
        }
        prate = pe->rate;
        for (int i = 0; i < ns; i++)
            for (int c = 0; c < RT_NCLASS; c++) {
                double t = pe->rm[i][c] + pe->wm[i][c] + pe->wb[i][c];
                x[p][i][rt_class_group(c)] += t;
                x[p][i][RT_NGROUP] += t;
            }
    }
    for (int i = 0; i < ns; i++)
        for (int g = 0; g <= RT_NGROUP; g++) {
            double m = 0, v = 0;
            for (int p = 0; p < K; p++) m += x[p][i][g];
            m /= K;
            for (int p = 0; p < K; p++) v += (x[p][i][g] - m) * (x[p][i][g] - m);
            /* a part holding less than one sampled line of this cache says nothing */
            int seen = prate * (double)(a->cfg.sizes[first + i] / a->cfg.line) >= 1;
            a->est.se[a->nwin + i][g] = seen ? sqrt(v / (K - 1) / K) : -1;
        }
    free(pe);
    free(x);
    return 0;
}

int rt_approx_finish(rt_approx *a, rt_err *e)
{
    a->finished = 0;
    memset(&a->est, 0, sizeof a->est);
    for (int i = 0; i < RT_SIM_MAXSIZES; i++)
        for (int g = 0; g <= RT_NGROUP; g++) a->est.se[i][g] = -1;
    if (a->exact) rt_sim_finish(a->exact); /* the end-of-run flush, if configured */
    /* est index j is size nexact + j: SHARDS' sizes follow the windowed ones */
    if (a->sh && rt_shards_estimate(a->sh, &a->est, a->nwin, e)) return -1;
    if (a->ss && rt_sstack_estimate(a->ss, (const uint64_t(*)[2])a->acc, &a->est, e)) return -1;
    if (a->tw && rt_window_estimate(a->tw, (const uint64_t(*)[2])a->acc, &a->est, 0, e)) return -1;
    if (a->sh && a->ac.method == RT_APPROX_HYBRID && a->ac.errors && shards_se(a, e)) return -1;
    a->finished = 1;
    a->fin_refs = a->refs;
    return 0;
}

/* "1K", "64K", "4M", or bytes. */
static void fmt_size(char *buf, size_t n, uint64_t v)
{
    if (v >= (1ULL << 20) && v % (1ULL << 20) == 0) snprintf(buf, n, "%lluM", (unsigned long long)(v >> 20));
    else if (v >= 1024 && v % 1024 == 0) snprintf(buf, n, "%lluK", (unsigned long long)(v >> 10));
    else snprintf(buf, n, "%llu", (unsigned long long)v);
}

int rt_approx_available(const rt_approx *a, int i, rt_err *e)
{
    if (i < 0 || i >= a->cfg.nsizes) return rt_errf(e, "size index %d out of range", i), 0;
    if (i < a->nexact) return 1;
    if (!a->finished || a->fin_refs != a->refs)
        return rt_errf(e, "rt_approx_finish was not called after the last references"), 0;
    if (i < a->nexact + a->nwin) {
        uint64_t nw, ns, fed;
        rt_window_stats(a->tw, &nw, &ns, &fed);
        if (nw < RT_APPROX_MIN_SAMPLES) {
            rt_errf(e, "trace too short for windows every %llu references: %llu windows (need %d)",
                    (unsigned long long)a->ac.period, (unsigned long long)nw, RT_APPROX_MIN_SAMPLES);
            return 0;
        }
        return 1;
    }
    const char *unit = a->ss ? "sampled references" : "sampled lines";
    if (a->est.sampled_lines < RT_APPROX_MIN_SAMPLES && a->est.rate < 1) {
        if (a->ac.method == RT_APPROX_SHARDS_FIXED)
            rt_errf(e, "trace too short for sampling: %llu %s (need %d)", (unsigned long long)a->est.sampled_lines,
                    unit, RT_APPROX_MIN_SAMPLES);
        else
            rt_errf(e, "trace too short for rate %g: %llu %s (need %d)", a->ac.rate,
                    (unsigned long long)a->est.sampled_lines, unit, RT_APPROX_MIN_SAMPLES);
        return 0;
    }
    if (a->sh) {
        double sl = a->est.rate * (double)(a->cfg.sizes[i] / a->cfg.line);
        if (sl < 1) {
            char sz[32];
            fmt_size(sz, sizeof sz, a->cfg.sizes[i]);
            rt_errf(e, "size %s is below the sampling resolution at rate %g (%.3g sampled lines, need >= 1); "
                       "simulate it exactly with exact_below",
                    sz, a->est.rate, sl);
            return 0;
        }
    }
    return 1;
}

static uint64_t rnd(double x, uint64_t hi)
{
    if (!(x > 0)) return 0;
    if (x >= (double)hi) return hi;
    return (uint64_t)(x + 0.5);
}

int rt_approx_get(const rt_approx *a, int i, int cls, rt_sim_counts *out, rt_err *e)
{
    memset(out, 0, sizeof *out);
    if (cls < 0 || cls >= RT_NCLASS) return rt_errf(e, "class %d out of range", cls);
    if (!rt_approx_available(a, i, e)) return -1;
    if (i < a->nexact) {
        rt_sim_get(a->exact, i, cls, out);
        return 0;
    }
    int j = i - a->nexact;
    out->accesses = a->acc[cls][0] + a->acc[cls][1];
    out->read_misses = rnd(a->est.rm[j][cls], a->acc[cls][0]);
    out->write_misses = rnd(a->est.wm[j][cls], a->acc[cls][1]);
    out->writebacks = rnd(a->est.wb[j][cls], UINT64_MAX / 2);
    out->traffic_bytes = (out->read_misses + out->write_misses + out->writebacks) * a->cfg.line;
    return 0;
}

int rt_approx_traffic_se(const rt_approx *a, int i, int group, double *se, rt_err *e)
{
    *se = -1;
    if (group < 0 || group > RT_NGROUP) return rt_errf(e, "group %d out of range", group);
    if (!rt_approx_available(a, i, e)) return -1;
    if (i < a->nexact) return *se = 0, 0;
    if (a->ac.method != RT_APPROX_HYBRID)
        return rt_errf(e, "the %s method has no error estimate (the hybrid method has)", method_names[a->ac.method]);
    if (!a->ac.errors) return rt_errf(e, "standard errors were not asked for (rt_approx_config.errors)");
    double v = a->est.se[i - a->nexact][group];
    if (v < 0) {
        char sz[32];
        fmt_size(sz, sizeof sz, a->cfg.sizes[i]);
        return rt_errf(e, "size %s: no error estimate (%s)", sz,
                       i < a->nexact + a->nwin ? "fewer than two windows"
                                               : "a replicate holds less than one sampled line of it");
    }
    *se = v * a->cfg.line;
    return 0;
}

int rt_approx_get_gen(const rt_approx *a, int i, int cls, int gen, rt_sim_counts *out, rt_err *e)
{
    memset(out, 0, sizeof *out);
    if (i < 0 || i >= a->nexact) return rt_errf(e, "size index %d is not simulated exactly: no generations", i);
    rt_sim_get_gen(a->exact, i, cls, gen, out);
    return 0;
}

int rt_approx_get_group(const rt_approx *a, int i, int group, rt_sim_counts *out, rt_err *e)
{
    memset(out, 0, sizeof *out);
    for (int c = 0; c < RT_NCLASS; c++) {
        if ((int)rt_class_group(c) != group) continue;
        rt_sim_counts t;
        if (rt_approx_get(a, i, c, &t, e)) return -1;
        out->accesses += t.accesses;
        out->read_misses += t.read_misses;
        out->write_misses += t.write_misses;
        out->writebacks += t.writebacks;
        out->wt_bytes += t.wt_bytes;
        out->traffic_bytes += t.traffic_bytes;
        out->nofetch += t.nofetch;
    }
    return 0;
}

void rt_approx_get_stats(const rt_approx *a, rt_approx_stats *st)
{
    memset(st, 0, sizeof *st);
    st->refs = a->refs;
    for (int c = 0; c < RT_NCLASS; c++) st->touches += a->acc[c][0] + a->acc[c][1];
    if (a->ac.method == RT_APPROX_EXACT) {
        st->touches = 0;
        for (int c = 0; c < RT_NCLASS; c++) {
            rt_sim_counts t;
            rt_sim_get(a->exact, 0, c, &t);
            st->touches += t.accesses;
        }
        st->sampled_touches = st->touches;
        st->rate = 1;
        return;
    }
    st->sampled_touches = a->est.sampled_touches;
    st->sampled_lines = a->est.sampled_lines;
    st->rate = a->est.rate;
    if (a->tw) rt_window_stats(a->tw, &st->windows, &st->short_warmups, &st->window_refs);
}

