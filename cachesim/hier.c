/*
 * hier.c -- cache hierarchies as engines chained (see hier.h).
 *
 * INVARIANTS (rt_hier_check):
 *   H1 every level is a consistent simulator (rt_sim_check);
 *   H2 every level but the last has one size and feeds the next;
 *   H3 the references level k+1 saw are those level k sent: with
 *      write-back write-allocate, exactly its fetches (read misses plus
 *      allocating write misses that fetched) plus its write-backs; with
 *      write-through or no-write-allocate at least those (the written
 *      bytes are references too).
 */
#include "hier.h"

#include "engine.h"
#include "incl.h"

#include <stdlib.h>
#include <string.h>

#define RT_INCL_POLICIES "lru, fifo, random, plru, srrip, brrip"

struct rt_hier {
    rt_hier_config cfg;
    rt_sim *lv[RT_HIER_MAXLEVELS]; /* non-inclusive */
    rt_incl *incl;                 /* inclusive or exclusive */
    rt_sink sink;
};

/* ---- the spec ---- */

static int parse_level(char *tok, int last, const rt_sim_config *base, rt_hier_config *h, rt_err *e)
{
    int k = h->nlevels;
    char *eq = strchr(tok, '=');
    if (!eq || eq == tok || eq - tok >= (long)sizeof h->name[0])
        return rt_errf(e, "hierarchy level %d '%s': want NAME=SIZE/WAYS/LINE/POLICY", k + 1, tok);
    *eq = 0;
    snprintf(h->name[k], sizeof h->name[k], "%s", tok);
    for (int j = 0; j < k; j++)
        if (!strcmp(h->name[j], h->name[k])) return rt_errf(e, "hierarchy: level name %s repeats", tok);
    char *f[8];
    int nf = 0;
    for (char *p = eq + 1, *s; nf < 8 && (s = strsep(&p, "/")); ) f[nf++] = s;
    if (nf < 4) return rt_errf(e, "hierarchy level %s: want SIZE/WAYS/LINE/POLICY, got %d fields", tok, nf);
    rt_sim_config *c = &h->level[k];
    *c = *base;
    c->repl = 0;
    c->assoc = 0;
    c->write_through = c->no_write_allocate = 0;
    /* sizes: one, a range, or '+'-joined */
    char sz[256];
    snprintf(sz, sizeof sz, "%s", f[0]);
    for (char *p = sz; *p; p++)
        if (*p == '+') *p = ',';
    rt_err se = {0};
    if (rt_sim_parse_sizes(sz, c, &se)) return rt_errf(e, "hierarchy level %s: size: %s", tok, se.msg);
    if (!last && c->nsizes != 1)
        return rt_errf(e, "hierarchy level %s: only the last level may have several sizes", tok);
    uint64_t v;
    if (!strcmp(f[1], "full")) c->assoc = 0;
    else if (rt_parse_size(f[1], &v) || v == 0 || v > (1u << 30))
        return rt_errf(e, "hierarchy level %s: ways '%s' is not 'full' or a positive number", tok, f[1]);
    else c->assoc = (uint32_t)v;
    if (rt_parse_size(f[2], &v) || v == 0 || v > (1u << 20))
        return rt_errf(e, "hierarchy level %s: line '%s' is not a size in bytes", tok, f[2]);
    c->line = (uint32_t)v;
    if (rt_sim_repl_parse(f[3], &c->repl, &se)) return rt_errf(e, "hierarchy level %s: %s", tok, se.msg);
    for (int i = 4; i < nf; i++) {
        if (!strcmp(f[i], "wt")) c->write_through = 1;
        else if (!strcmp(f[i], "nwa")) c->no_write_allocate = 1;
        else return rt_errf(e, "hierarchy level %s: unknown flag '%s' (wt, nwa)", tok, f[i]);
    }
    c->feeds_below = !last;
    if (rt_sim_config_check(c, &se)) return rt_errf(e, "hierarchy level %s: %s", tok, se.msg);
    h->nlevels++;
    return 0;
}

int rt_hier_parse(const char *spec, const rt_sim_config *base, rt_hier_config *h, rt_err *e)
{
    memset(h, 0, sizeof *h);
    char buf[1024];
    if (!spec || !*spec || strlen(spec) >= sizeof buf) return rt_errf(e, "bad hierarchy spec '%s'", spec ? spec : "");
    snprintf(buf, sizeof buf, "%s", spec);
    char *tok[RT_HIER_MAXLEVELS + 2];
    int n = 0;
    for (char *p = buf, *s; (s = strsep(&p, ","));) {
        if (n == RT_HIER_MAXLEVELS + 1) return rt_errf(e, "hierarchy '%s': more than %d levels", spec, RT_HIER_MAXLEVELS);
        tok[n++] = s;
    }
    h->inclusion = RT_INCL_NINE;
    if (n > 1 && !strchr(tok[n - 1], '=')) { /* the inclusion */
        const char *t = tok[--n];
        if (!strcmp(t, "nine")) h->inclusion = RT_INCL_NINE;
        else if (!strcmp(t, "inclusive")) h->inclusion = RT_INCL_INCLUSIVE;
        else if (!strcmp(t, "exclusive")) h->inclusion = RT_INCL_EXCLUSIVE;
        else return rt_errf(e, "hierarchy '%s': last item '%s' is not a level (NAME=...) nor nine, inclusive, exclusive", spec, t);
    }
    if (n > RT_HIER_MAXLEVELS) return rt_errf(e, "hierarchy '%s': more than %d levels", spec, RT_HIER_MAXLEVELS);
    for (int k = 0; k < n; k++)
        if (parse_level(tok[k], k == n - 1, base, h, e)) return -1;
    if (h->inclusion != RT_INCL_NINE) {
        const char *in = rt_hier_inclusion_name(h->inclusion);
        if (base->flush || base->write_miss_fullline)
            return rt_errf(e, "hierarchy '%s': %s: flush and full-line write misses are modeled only non-inclusive", spec, in);
        for (int k = 0; k < n; k++) {
            const rt_sim_config *c = &h->level[k];
            if ((c->repl != 0 && !rt_repl_ops_for(c->repl)) || c->write_through || c->no_write_allocate)
                return rt_errf(e, "hierarchy level %s: %s needs a per-size policy (%s, not opt), write-back, "
                                  "write-allocate at every level", h->name[k], in, RT_INCL_POLICIES);
            if (c->line != h->level[0].line)
                return rt_errf(e, "hierarchy level %s: %s needs one line size at every level (%u, not %u)", h->name[k], in,
                               h->level[0].line, c->line);
        }
    }
    return 0;
}

static void put_size(char *b, size_t n, uint64_t v)
{
    if (v >= (1u << 20) && v % (1u << 20) == 0) snprintf(b, n, "%lluM", (unsigned long long)(v >> 20));
    else if (v >= 1024 && v % 1024 == 0) snprintf(b, n, "%lluK", (unsigned long long)(v >> 10));
    else snprintf(b, n, "%llu", (unsigned long long)v);
}

const char *rt_hier_spec(const rt_hier_config *h, char *buf, size_t n)
{
    size_t at = 0;
    buf[0] = 0;
    for (int k = 0; k < h->nlevels && at < n; k++) {
        const rt_sim_config *c = &h->level[k];
        char sizes[512] = "", one[32];
        int range = c->nsizes > 2;
        for (int i = 1; i < c->nsizes; i++) range = range && c->sizes[i] == 2 * c->sizes[i - 1];
        if (range) {
            put_size(one, sizeof one, c->sizes[0]);
            strcat(sizes, one);
            strcat(sizes, "-");
            put_size(one, sizeof one, c->sizes[c->nsizes - 1]);
            strcat(sizes, one);
        } else
            for (int i = 0; i < c->nsizes; i++) {
                put_size(one, sizeof one, c->sizes[i]);
                if (i) strcat(sizes, "+");
                strcat(sizes, one);
            }
        char ways[16];
        if (c->assoc) snprintf(ways, sizeof ways, "%u", c->assoc);
        else strcpy(ways, "full");
        at += (size_t)snprintf(buf + at, n - at, "%s%s=%s/%s/%u/%s%s%s", k ? "," : "", h->name[k], sizes, ways, c->line,
                               rt_sim_repl_name(c->repl), c->write_through ? "/wt" : "",
                               c->no_write_allocate ? "/nwa" : "");
    }
    if (h->inclusion != RT_INCL_NINE && at < n)
        snprintf(buf + at, n - at, ",%s", rt_hier_inclusion_name(h->inclusion));
    return buf;
}

const char *rt_hier_inclusion_name(int inclusion)
{
    return inclusion == RT_INCL_INCLUSIVE ? "inclusive" : inclusion == RT_INCL_EXCLUSIVE ? "exclusive" : "nine";
}

/* ---- the chain ---- */

static int sink_put(rt_sink *s, const rt_access *a, size_t n) { return rt_hier_put(s->ctx, a, n); }

rt_hier *rt_hier_new(const rt_hier_config *hc, rt_err *e)
{
    if (hc->nlevels < 1 || hc->nlevels > RT_HIER_MAXLEVELS)
        return rt_errf(e, "a hierarchy has 1..%d levels, not %d", RT_HIER_MAXLEVELS, hc->nlevels), NULL;
    rt_hier *h = rt_calloc(1, sizeof *h, e);
    if (!h) return NULL;
    h->cfg = *hc;
    h->sink.put = sink_put;
    h->sink.ctx = h;
    if (hc->inclusion != RT_INCL_NINE) {
        if (!(h->incl = rt_incl_new(hc, e))) goto fail;
        return h;
    }
    for (int k = 0; k < hc->nlevels; k++) {
        rt_sim_config c = hc->level[k];
        c.feeds_below = k < hc->nlevels - 1;
        if (c.feeds_below && c.nsizes != 1) {
            rt_errf(e, "hierarchy level %s: only the last level may have several sizes", hc->name[k]);
            goto fail;
        }
        h->cfg.level[k] = c;
        if (!(h->lv[k] = rt_sim_new(&c, e))) goto fail;
    }
    for (int k = 0; k + 1 < hc->nlevels; k++)
        if (rt_sim_set_below(h->lv[k], rt_sim_sink(h->lv[k + 1]), e)) goto fail;
    return h;
fail:
    rt_hier_free(h);
    return NULL;
}

void rt_hier_free(rt_hier *h)
{
    if (!h) return;
    for (int k = 0; k < RT_HIER_MAXLEVELS; k++) rt_sim_free(h->lv[k]);
    rt_incl_free(h->incl);
    free(h);
}

const rt_hier_config *rt_hier_get_config(const rt_hier *h) { return &h->cfg; }
int rt_hier_put(rt_hier *h, const rt_access *a, size_t n)
{
    return h->incl ? rt_incl_put(h->incl, a, n) : rt_sim_put(h->lv[0], a, n);
}
rt_sink *rt_hier_sink(rt_hier *h) { return &h->sink; }
const rt_sim *rt_hier_level(const rt_hier *h, int k) { return k >= 0 && k < h->cfg.nlevels ? h->lv[k] : NULL; }

uint64_t rt_hier_refs(const rt_hier *h) { return h->incl ? rt_incl_refs(h->incl) : rt_sim_refs(h->lv[0]); }

void rt_hier_get(const rt_hier *h, int k, int i, int cls, rt_hier_counts *out)
{
    memset(out, 0, sizeof *out);
    if (h->incl) rt_incl_get(h->incl, k, i, cls, out);
    else if (k >= 0 && k < h->cfg.nlevels) rt_sim_get(h->lv[k], k + 1 == h->cfg.nlevels ? i : 0, cls, &out->c);
}

int rt_hier_finish(rt_hier *h)
{
    for (int k = 0; k < h->cfg.nlevels && !h->incl; k++) rt_sim_finish(h->lv[k]);
    return 0;
}

void rt_hier_repeats(rt_hier *h, rt_repeats *out)
{
    if (h->incl) memset(out, 0, sizeof *out); /* every read reaches the chains */
    else rt_sim_repeats(h->lv[0], out);
}

int rt_hier_check(const rt_hier *h, rt_err *e)
{
    if (h->incl) return rt_incl_check(h->incl, e);
    for (int k = 0; k < h->cfg.nlevels; k++) {
        if (rt_sim_check(h->lv[k], e)) return -1; /* H1 */
        const rt_sim_config *c = &h->cfg.level[k];
        if (k + 1 == h->cfg.nlevels) break;
        if (c->nsizes != 1 || !c->feeds_below) /* H2 */
            return rt_errf(e, "hierarchy: level %s does not feed the next", h->cfg.name[k]);
        uint64_t sent = 0; /* H3 */
        for (int cls = 0; cls < RT_NCLASS; cls++) {
            rt_sim_counts t;
            rt_sim_get(h->lv[k], 0, cls, &t);
            sent += t.read_misses + (c->no_write_allocate ? 0 : t.write_misses - t.nofetch) + t.writebacks;
        }
        uint64_t got = rt_sim_refs(h->lv[k + 1]);
        int plain = !c->write_through && !c->no_write_allocate;
        if (plain ? got != sent : got < sent)
            return rt_errf(e, "hierarchy: level %s saw %llu references, level %s sent %llu", h->cfg.name[k + 1],
                           (unsigned long long)got, h->cfg.name[k], (unsigned long long)sent);
    }
    return 0;
}
