/*
 * tracer.c -- the tracer registry. What the tracers share lives beside it,
 * one job per file: options.c, pixels.c (subsampling and order), camera.c,
 * shade.c (shading rule and shadow rays), regions.c (geometry regions and
 * the recording traversal), stats.c.
 */
#include "tracer.h"

#include <stdio.h>
#include <string.h>

extern const rt_tracer rt_tracer_recursive;
extern const rt_tracer rt_tracer_packet;
extern const rt_tracer rt_tracer_dynamic;
extern const rt_tracer rt_tracer_stream_branching;
extern const rt_tracer rt_tracer_stream_multipass;
extern const rt_tracer rt_tracer_feedback;
extern const rt_tracer rt_tracer_treelet;

const rt_tracer *const rt_tracer_all[] = {
    &rt_tracer_recursive,
    &rt_tracer_packet,
    &rt_tracer_dynamic,
    &rt_tracer_stream_branching,
    &rt_tracer_stream_multipass,
    &rt_tracer_feedback,
    &rt_tracer_treelet,
    NULL,
};

const rt_tracer *rt_tracer_find(const char *name)
{
    for (int i = 0; rt_tracer_all[i]; i++)
        if (!strcmp(rt_tracer_all[i]->name, name)) return rt_tracer_all[i];
    return NULL;
}

const char *rt_tracer_names(void)
{
    static char buf[256];
    if (!buf[0]) {
        size_t l = 0;
        for (int i = 0; rt_tracer_all[i] && l < sizeof buf; i++)
            l += (size_t)snprintf(buf + l, sizeof buf - l, "%s%s", i ? ", " : "", rt_tracer_all[i]->name);
    }
    return buf;
}

const rt_tracer *rt_tracer_reference(void)
{
    for (int i = 0; rt_tracer_all[i]; i++)
        if (rt_tracer_all[i]->traits & RT_TR_REFERENCE) return rt_tracer_all[i];
    return rt_tracer_all[0];
}

/* The names of the registered tracers that read group g (or run on
 * structure kind k when g is 0), for the refusal's hint. */
static void readers(unsigned g, int k, char *buf, size_t n)
{
    size_t l = 0;
    buf[0] = 0;
    for (int i = 0; rt_tracer_all[i] && l < n; i++) {
        const rt_tracer *t = rt_tracer_all[i];
        if (g ? (t->opts & g) != 0 : (t->accels & RT_ACCEL_BIT(k)) != 0)
            l += (size_t)snprintf(buf + l, n - l, "%s%s", l ? ", " : "", t->name);
    }
}

/* The structures tr runs on, "kd" or "grid, naive". */
static void accels_of(const rt_tracer *tr, char *buf, size_t n)
{
    size_t l = 0;
    buf[0] = 0;
    for (int k = 1; k < RT_ACCEL_NKINDS && l < n; k++)
        if (tr->accels & RT_ACCEL_BIT(k)) l += (size_t)snprintf(buf + l, n - l, "%s%s", l ? ", " : "", rt_accel_name(k));
}

/* Why a tracer does not trace the two-level structure (docs/bvh.md,
 * "Instancing"). */
static const char *inst_why(const rt_tracer *tr)
{
    if (!strcmp(tr->name, "dynamic"))
        return "schedules rays on the cells of one k-d tree over world space, which cannot sit under a top-level BVH "
               "(a cell of a shared object's tree is a different region of space in every instance)";
    return "walks its own structure, not the two-level one";
}

int rt_tracer_check_given_any(const rt_tracer *const *trs, int ntr, const rt_render_opts *o, rt_err *e)
{
    unsigned opts = 0, accels = 0;
    for (int i = 0; i < ntr; i++) {
        opts |= trs[i]->opts;
        /* --threads also runs a tracer's own cores on host threads (the dynamic scheduler's rounds) */
        if (rt_tracer_is(trs[i], RT_TR_CORES)) opts |= RT_OPTG_THREADS;
        accels |= trs[i]->accels;
    }
    const char *who = ntr == 1 ? trs[0]->name : NULL;
    char hint[256];
    for (int id = 0; id < rt_render_noptdefs; id++) {
        if (!rt_render_opt_given(o, id)) continue;
        unsigned g = rt_render_opt_group(id);
        if (!g || (opts & g)) continue;
        readers(g, 0, hint, sizeof hint);
        if (who) return rt_errf(e, "%s does not apply to the %s tracer (only to %s)", rt_render_opt_name(id), who, hint);
        return rt_errf(e, "%s does not apply: no tracer given reads it (only %s)", rt_render_opt_name(id), hint);
    }
    if (o->accel == RT_ACCEL_INST && !(accels & RT_ACCEL_BIT(o->accel))) {
        readers(0, o->accel, hint, sizeof hint);
        if (who) return rt_errf(e, "--instances bvh: the %s tracer %s (only %s)", who, inst_why(trs[0]), hint);
        return rt_errf(e, "--instances bvh: no tracer given traces the two-level structure (only %s)", hint);
    }
    if (o->accel != RT_ACCEL_DEFAULT && !(accels & RT_ACCEL_BIT(o->accel))) {
        if (who) {
            accels_of(trs[0], hint, sizeof hint);
            return rt_errf(e, "--accel: the %s tracer runs on %s, not %s", who, hint, rt_accel_name(o->accel));
        }
        readers(0, o->accel, hint, sizeof hint);
        return rt_errf(e, "--accel: no tracer given runs on %s (only %s)", rt_accel_name(o->accel), hint);
    }
    return 0;
}

int rt_tracer_check_opts(const rt_tracer *tr, const rt_render_opts *o, rt_err *e)
{
    if (rt_pixel_check(o, e) < 0) return -1;
    int k = rt_tracer_accel(tr, o);
    if (k == RT_ACCEL_INST && !(tr->accels & RT_ACCEL_BIT(k))) {
        char hint[128];
        readers(0, k, hint, sizeof hint);
        return rt_errf(e, "--instances bvh: the %s tracer %s (only %s)", tr->name, inst_why(tr), hint);
    }
    if (!(tr->accels & RT_ACCEL_BIT(k))) {
        char hint[128];
        accels_of(tr, hint, sizeof hint);
        return rt_errf(e, "--accel: the %s tracer runs on %s, not %s", tr->name, hint,
                       rt_accel_name(k) ? rt_accel_name(k) : "?");
    }
    if ((rt_accel_table[k]->flags & RT_ACCEL_OWN_TRIS) && o->geom != RT_GEOM_COMPACT)
        return rt_errf(e, "--layout %s: the %s structure stores its triangles in leaf order as compact records",
                       rt_render_geom_name(o->geom), rt_accel_name(k));
    return tr->check_opts ? tr->check_opts(o, e) : 0;
}

int rt_tracer_check_given(const rt_tracer *tr, const rt_render_opts *o, rt_err *e)
{
    return rt_tracer_check_given_any(&tr, 1, o, e);
}
