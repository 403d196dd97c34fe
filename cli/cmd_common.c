/* cmd_common.c -- option parsing and output helpers shared by the
 * subcommands, so the same option is spelled and checked the same way
 * everywhere and JSON strings are escaped one way. */
#include "cmd.h"
#include "feedback.h"
#include "grid.h"
#include "scene.h"

#include <errno.h>
#include <ctype.h>
#include <limits.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

struct option *rt_cmd_longopts(unsigned cmd, const struct option *own)
{
    size_t a = 0, b = 0;
    while (own[a].name) a++;
    struct option *t = calloc(a + (size_t)rt_render_noptdefs + 1, sizeof *t);
    if (!t) return NULL;
    memcpy(t, own, a * sizeof *t);
    for (int i = 0; i < rt_render_noptdefs; i++) {
        const rt_render_optdef *d = &rt_render_optdefs[i];
        if (!(d->cmds & cmd)) continue;
        t[a + b].name = d->name + 2;
        t[a + b].has_arg = d->arg ? required_argument : no_argument;
        t[a + b].val = d->short_name ? d->short_name : RT_OPT_CODE_BASE + i;
        b++;
    }
    return t;
}

const char *rt_cmd_shortopts(unsigned cmd, const char *own, char *buf, size_t n)
{
    size_t l = (size_t)snprintf(buf, n, "%s", own);
    for (int i = 0; i < rt_render_noptdefs && l + 3 < n; i++) {
        const rt_render_optdef *d = &rt_render_optdefs[i];
        if (!(d->cmds & cmd) || !d->short_name) continue;
        buf[l++] = (char)d->short_name;
        if (d->arg) buf[l++] = ':';
        buf[l] = 0;
    }
    return buf;
}

int rt_cmd_opt_index(int c)
{
    if (c >= RT_OPT_CODE_BASE && c < RT_OPT_CODE_BASE + rt_render_noptdefs) return c - RT_OPT_CODE_BASE;
    for (int i = 0; c > 0 && c < 128 && i < rt_render_noptdefs; i++)
        if (rt_render_optdefs[i].short_name == c) return i;
    return -1;
}

int rt_cmd_parse_long(const char *s, long lo, long hi, long *out) { return rt_opt_parse_long(s, lo, hi, out); }

int rt_cmd_parse_double(const char *s, double *out) { return rt_opt_parse_double(s, out); }

int rt_cmd_check_text(const char *cmd, const char *opt, const char *arg)
{
    for (const unsigned char *p = (const unsigned char *)arg; *p; p++)
        if (*p < 0x20 || *p == 0x7f) {
            char q[128];
            rt_cmd_error(cmd, "%s: '%s' contains a control character (\\x%02x); not allowed in scene names and "
                              "file names", opt, rt_esc(q, sizeof q, arg, 4096), *p);
            return -1;
        }
    return 0;
}

/* The tracer and the mode must agree, whichever came first. */
static int check_mode(const char *cmd, const rt_render_opts *o, const char *tracer)
{
    const rt_tracer *tr = tracer ? rt_tracer_find(tracer) : rt_tracer_reference();
    if (o->mode != RT_MODE_DEFAULT && tr && !(tr->modes & (1u << o->mode))) {
        rt_cmd_error(cmd, "--mode: the %s tracer cannot run mode %s", tr->name, rt_render_mode_name(o->mode));
        return -1;
    }
    return 0;
}

/* Entry i with its value: 1, or -1 (printed). */
static int render_opt(const char *cmd, int i, const char *arg, rt_render_opts *o, const char **tracer)
{
    const rt_render_optdef *d = &rt_render_optdefs[i];
    rt_err e = {0};
    if (!d->parse) { /* --tracer: the front end's */
        if (!rt_tracer_find(arg)) {
            rt_cmd_error(cmd, "unknown tracer '%s' (%s)", arg, rt_tracer_names());
            return -1;
        }
        if (check_mode(cmd, o, arg) < 0) return -1;
        *tracer = arg;
        return 1;
    }
    if (!strcmp(d->name, "--threads") && strcmp(cmd, "render") && strcmp(cmd, "bench")) {
        /* traced runs are one ordered stream; the former --threads is --cores */
        rt_cmd_error(cmd, "--threads: %s records one ordered stream on one host thread; the dynamic tracer's modeled "
                          "threads are now --cores N", cmd);
        return -1;
    }
    rt_render_opts t = *o; /* a refusal leaves o as it was */
    int r = d->parse(&t, arg, &e);
    if (r < 0) {
        rt_cmd_error(cmd, "%s", e.msg);
        return -1;
    }
    if (!strcmp(d->name, "--mode") && check_mode(cmd, &t, tracer ? *tracer : NULL) < 0) return -1;
    if (r > 0 && e.msg[0]) rt_cmd_error(cmd, "%s", e.msg); /* a note */
    t.given |= (uint64_t)1 << i;
    *o = t;
    return 1;
}

int rt_cmd_render_opt(const char *cmd, int c, const char *arg, rt_render_opts *o, const char **tracer)
{
    int i = rt_cmd_opt_index(c);
    return i < 0 ? 0 : render_opt(cmd, i, arg, o, tracer);
}

int rt_cmd_render_opt_named(const char *cmd, const char *name, const char *arg, rt_render_opts *o)
{
    const char *tracer = NULL;
    int i = rt_render_opt_find(name);
    return i < 0 ? 0 : render_opt(cmd, i, arg, o, &tracer);
}

/* --tracer's help: the registered tracers (rt_tracer_all), " | " between
 * them, and the default, wrapped at 80 columns. */
static void tracer_help(char *buf, size_t n)
{
    char words[40][64];
    int nw = 0;
    for (int i = 0; rt_tracer_all[i] && nw < 37; i++)
        snprintf(words[nw++], sizeof words[0], "%s%s", rt_tracer_all[i]->name, rt_tracer_all[i + 1] ? " |" : "");
    snprintf(words[nw++], sizeof words[0], "(default");
    snprintf(words[nw++], sizeof words[0], "%s)", rt_tracer_reference()->name);
    size_t l = 0, col = 21;
    buf[0] = 0;
    for (int k = 0; k < nw && l < n; k++) {
        size_t wl = strlen(words[k]);
        const char *sep = "";
        if (k == 0) col += wl;
        else if (col + 1 + wl > 80) sep = "\n", col = 21 + wl;
        else sep = " ", col += 1 + wl;
        l += (size_t)snprintf(buf + l, n - l, "%s%s", sep, words[k]);
    }
}

/* "  LABEL" padded to the help column (21), or two spaces after a longer
 * one, then the help lines, the later ones indented to the column. */
static void print_entry(FILE *f, const rt_render_optdef *d)
{
    char gen[512];
    const char *help = d->help;
    if (!d->parse) { /* --tracer: the list comes from the tracers' table */
        tracer_help(gen, sizeof gen);
        help = gen;
    }
    char label[128];
    if (d->label) snprintf(label, sizeof label, "%s", d->label);
    else if (d->short_name) snprintf(label, sizeof label, "-%c %s", d->short_name, d->arg ? d->arg : "");
    else snprintf(label, sizeof label, "%s%s%s", d->name, d->arg ? " " : "", d->arg ? d->arg : "");
    int w = fprintf(f, "  %s", label);
    fprintf(f, "%*s", w < 21 ? 21 - w : 2, "");
    for (const char *p = help; *p; p++) {
        fputc(*p, f);
        if (*p == '\n') fprintf(f, "%21s", "");
    }
    fputc('\n', f);
}

void rt_cmd_render_help(FILE *f, unsigned cmd)
{
    for (int i = 0; i < rt_render_noptdefs; i++)
        if ((rt_render_optdefs[i].cmds & cmd) && rt_render_optdefs[i].help) print_entry(f, &rt_render_optdefs[i]);
}

void rt_cmd_render_help_line(FILE *f, const char *name)
{
    int i = rt_render_opt_find(name);
    if (i >= 0 && rt_render_optdefs[i].sweep_help) fputs(rt_render_optdefs[i].sweep_help, f);
}

void rt_cmd_render_help_rest(FILE *f, unsigned cmd)
{
    for (int i = 0; i < rt_render_noptdefs; i++) {
        const rt_render_optdef *d = &rt_render_optdefs[i];
        if ((d->cmds & cmd) && d->help && !d->sweep_help) print_entry(f, d);
    }
}

int rt_cmd_check_tracer_opts(const char *cmd, const char *tracer, const rt_render_opts *o)
{
    rt_err e = {0};
    const rt_tracer *tr = tracer ? rt_tracer_find(tracer) : rt_tracer_reference();
    if (!tr) {
        rt_cmd_error(cmd, "unknown tracer '%s' (%s)", tracer, rt_tracer_names());
        return -1;
    }
    const int th = rt_render_opt_find("--threads");
    if (th >= 0 && (o->given & ((uint64_t)1 << th)) && !(tr->opts & RT_OPTG_THREADS) && (tr->opts & RT_OPTG_SCHED) &&
        !rt_tracer_is(tr, RT_TR_CORES)) {
        /* the former spelling of the scheduler's modeled threads */
        rt_cmd_error(cmd, "--threads: host threads do not apply to the %s tracer (one serial schedule); its modeled "
                          "threads are now --cores N", tr->name);
        return -1;
    }
    if (th >= 0 && (o->given & ((uint64_t)1 << th)) && o->host_threads > 1 && rt_tracer_is(tr, RT_TR_CORES) &&
        rt_render_secondary(o)) {
        rt_cmd_error(cmd, "--threads %d: the %s tracer runs the whitted and path modes on one thread", o->host_threads,
                     tr->name);
        return -1;
    }
    if (rt_tracer_check_given(tr, o, &e) < 0 || rt_tracer_check_opts(tr, o, &e) < 0 ||
        rt_render_check_lights(o, &e) < 0) {
        rt_cmd_error(cmd, "%s", e.msg);
        return -1;
    }
    return 0;
}

int rt_cmd_parse_rate(const char *s, double *out)
{
    char buf[64];
    double v, q = 1;
    if (!s || strlen(s) >= sizeof buf) return -1;
    snprintf(buf, sizeof buf, "%s", s);
    char *slash = strchr(buf, '/');
    if (slash) {
        *slash = 0;
        if (rt_cmd_parse_double(slash + 1, &q) < 0 || !(q >= 1)) return -1;
    }
    if (rt_cmd_parse_double(buf, &v) < 0) return -1;
    v /= q;
    if (!(v > 0) || v > 1) return -1;
    *out = v;
    return 0;
}

int rt_cmd_parse_line(const char *cmd, const char *arg, uint32_t *line)
{
    uint64_t v;
    if (rt_parse_size(arg, &v) < 0 || v == 0 || v > (1u << 20)) {
        rt_cmd_error(cmd, "--line: '%s' is not a line size in 1..1M bytes", arg);
        return -1;
    }
    *line = (uint32_t)v;
    return 0;
}

void rt_cmd_json_str(FILE *f, const char *s)
{
    fputc('"', f);
    for (; *s; s++) {
        unsigned char c = (unsigned char)*s;
        if (c == '"' || c == '\\') fprintf(f, "\\%c", c);
        else if (c < 0x20) fprintf(f, "\\u%04x", c);
        else fputc(c, f);
    }
    fputc('"', f);
}

void rt_cmd_print_warnings(const char *cmd, const rt_scene *s)
{
    for (uint32_t i = 0; i < s->nwarn; i++) {
        const rt_scene_warn *w = &s->warn[i];
        if (w->count > 1) rt_cmd_error(cmd, "warning: %s: %s (%u times)", w->first, w->msg, (unsigned)w->count);
        else rt_cmd_error(cmd, "warning: %s: %s", w->first, w->msg);
    }
}

void rt_cmd_json_warnings(FILE *f, const rt_scene *s)
{
    fputs("\"warnings\": [", f);
    for (uint32_t i = 0; i < s->nwarn; i++) {
        const rt_scene_warn *w = &s->warn[i];
        fputs(i ? ", {\"kind\": " : "{\"kind\": ", f);
        rt_cmd_json_str(f, w->kind);
        fprintf(f, ", \"count\": %u, \"first\": ", (unsigned)w->count);
        rt_cmd_json_str(f, w->first);
        fputs(", \"message\": ", f);
        rt_cmd_json_str(f, w->msg);
        fputc('}', f);
    }
    fputc(']', f);
}

int rt_cmd_strict(const char *cmd, const rt_scene *s)
{
    if (!s->nwarn) return 0;
    const rt_scene_warn *w = &s->warn[0];
    rt_cmd_error(cmd, "%s: %s (--strict: %u kind%s of warnings are errors)", w->first, w->msg, (unsigned)s->nwarn,
                 s->nwarn > 1 ? "s" : "");
    return -1;
}

const char *rt_cmd_scene_material(const char *cmd, const char *spec, const char *name, char *buf, size_t n)
{
    if (!name) return spec;
    int known = 0;
    for (int i = 0; rt_material_preset_names[i]; i++) known |= !strcmp(name, rt_material_preset_names[i]);
    if (!known) {
        rt_cmd_error(cmd, "--material: unknown preset '%s' (diffuse, mirror, glass)", name);
        return NULL;
    }
    /* a built-in name or a mesh path, then ':' and k=v parameters */
    const char *colon = strrchr(spec, ':');
    const char *slash = strrchr(spec, '/');
    int has_params = colon && (!slash || colon > slash) && strchr(colon, '=');
    if ((size_t)snprintf(buf, n, "%s%smaterial=%s", spec, has_params ? "," : ":", name) >= n) {
        rt_cmd_error(cmd, "--material: scene spec too long");
        return NULL;
    }
    return buf;
}
