/*
 * replay.c -- feed a trace file (.rtt through the trace reader, or din)
 * into any rt_sink: the one trace-replay loop (rt_sim_replay_sink, see
 * sim.h), used by the exact and the approximate simulators alike. Kept
 * apart from sim.c so programs that only stream in-process do not link the
 * trace reader.
 */
#include "sim.h"
#include "trace.h"

#include <errno.h>
#include <ctype.h>
#include <stdlib.h>
#include <string.h>

#define REPLAY_BUF 4096 /* 64 KB: small enough to stay in L2 beside the simulator */

/* Reads the whole input through next() into sink, counting references. */
static long pump(long (*next)(void *, rt_access *, size_t, rt_err *), void *src, rt_sink *sink, rt_access *buf,
                 rt_sim_input *info, rt_err *e)
{
    long n;
    while ((n = next(src, buf, REPLAY_BUF, e)) > 0) {
        if (sink->put(sink, buf, (size_t)n) < 0) return rt_errf(e, "the simulator rejected references");
        info->refs += (uint64_t)n;
    }
    return n;
}

static long din_next(void *d, rt_access *b, size_t n, rt_err *e) { return rt_din_read(d, b, n, e); }
static long rtt_next(void *r, rt_access *b, size_t n, rt_err *e) { return rt_tr_read(r, b, n, e); }

int rt_sim_replay_sink(rt_sink *sink, const char *path, int fmt, int din_class, rt_tr_meta *meta,
                       rt_sim_input *info, rt_err *e)
{
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
            n = pump(din_next, d, sink, buf, info, e);
            info->file_bytes = rt_din_file_bytes(d);
            info->file_hash = rt_din_file_hash(d);
            rt_din_close(d);
        }
    } else {
        rt_tr_reader *r = rt_tr_open(path, e);
        if (r) {
            if (meta) *meta = *rt_tr_get_meta(r);
            info->has_meta = 1;
            n = pump(rtt_next, r, sink, buf, info, e);
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
