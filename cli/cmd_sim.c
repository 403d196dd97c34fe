/* cmd_sim.c -- `raytraffic sim`: replay traces through cache models, print
 * the counters or store them in the results database.
 *
 * One path for every method: each trace is replayed into an rt_approx
 * (RT_APPROX_EXACT wraps the exact simulator, so its output and rows are
 * those of rt_sim), counters are printed from it or turned into rows by
 * rows.c and stored under the key experiment.c builds. */
#include "approx.h"
#include "cmd.h"
#include "experiment.h"
#include "outfile.h"
#include "rows.h"
#include "sim.h"
#include "hier.h"
#include "trace.h"

#include <errno.h>
#include <getopt.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

enum { FMT_TEXT, FMT_CSV, FMT_JSON };

typedef struct sim_opts {
    rt_sim_config cfg;  /* cache configurations */
    int infmt;          /* RT_SIM_IN_* */
    int din_class;      /* class of din records */
    const char *db;     /* database path or NULL */
    int outfmt;         /* FMT_* */
    rt_approx_config ac;/* --method etc.; RT_APPROX_EXACT = the exact simulator */
    int rate_given;     /* --rate seen */
    int threads;        /* replay threads: 1, or 2 to decode beside the simulator */
    unsigned given;     /* bit (1 << O_x) for every option seen, to refuse those that do not apply */
    const char *hier;   /* --hierarchy spec, or NULL */
    rt_hier_config hc;  /* parsed from it */
} sim_opts;

static void usage(FILE *f)
{
    fprintf(f,
            "Usage: raytraffic sim [options] TRACE...\n\n"
            "Replays each trace (raytraffic .rtt or Dinero IV din text) once through a\n"
            "set of caches (LRU unless --repl) and reports per-class accesses, misses, write-backs and\n"
            "DRAM traffic for every cache size.\n\n"
            "Options:\n"
            "  --sizes LIST           1K-4M (powers of two) or 1K,2K,64K (default 1K-4M)\n"
            "  --line N               line size in bytes, any value (default 64)\n"
            "  --assoc full|N         fully associative (default) or N ways; 1 = direct-mapped\n"
            "  --repl P               replacement policy (default lru), one of\n"
            "                         %s; --seed seeds random choices\n"
            "  --hierarchy SPEC       caches in levels, from the core outward, instead of\n"
            "                         --sizes/--line/--assoc/--repl and the write options:\n"
            "                         NAME=SIZE[S]/WAYS|full/LINE/POLICY[/wt][/nwa],...\n"
            "                         e.g. L1=32K/8/64/lru,L2=1M/16/64/srrip,LLC=1K-4M/full/64/lru\n"
            "                         (only the last level may have several sizes: A-B or\n"
            "                         A+B+C); rows per level, DRAM = the last level;\n"
            "                         a last item nine (default), inclusive or exclusive\n"
            "                         sets the inclusion (any policy but opt, one line size;\n"
            "                         one chain per last-level size; back-invalidations\n"
            "                         shown, and stored with --db)\n"
            "  --write-through        write-through instead of write-back\n"
            "  --no-write-allocate    write misses do not allocate (write around)\n"
            "  --flush                write back the lines still dirty at the end, as\n"
            "                         Dinero IV does (policy label +flush)\n"
            "  --write-fullline       a write miss covering its whole line fetches nothing,\n"
            "                         as in Dinero IV (policy label +fullline)\n"
            "  --input-format F       auto | rtt | din (default auto: sniff the content)\n"
            "  --din-class C          class of din records (default fb, group 'other')\n"
            "  --db FILE              store one run per trace in this SQLite database and\n"
            "                         print a one-line summary per trace to stderr\n"
            "  --format F             text | csv | json output when --db is not given\n"
            "  --method M             exact (default) | shards | shards-fixed | statstack |\n"
            "                         hybrid: sampled estimates (docs/approx.md); fully\n"
            "                         associative write-back write-allocate caches only.\n"
            "                         hybrid reads only the sample index of a trace\n"
            "                         written by `raytraffic trace` (format version 3) when\n"
            "                         it fits the settings (same results, ~15x faster);\n"
            "                         otherwise every record, with a note on stderr\n"
            "  --rate R               sampling rate, a number or 1/N (default 0.01; hybrid:\n"
            "                         1/64, golden-ratio line sampling)\n"
            "  --window-below SIZE    hybrid: sizes below SIZE on exact windows (default 32K)\n"
            "  --period N             hybrid: one window every N references (default 65536)\n"
            "  --window N             hybrid: references per window (default 1024)\n"
            "  --no-error             hybrid: no standard errors (column traffic_se; they\n"
            "                         cost about as much again as the sampled part)\n"
            "  --smax N               sampled lines kept by shards-fixed (default 8192)\n"
            "  --seed S               sampling seed (default 1)\n"
            "  --threads N            1, or 2 to decode the trace on a second thread beside\n"
            "                         the simulator (same results; default 2 on a machine\n"
            "                         with 2 or more CPUs, else 1)\n"
            "  --exact-below SIZE     simulate sizes below SIZE exactly (default 0 = none);\n"
            "                         sizes without an estimate are left out (text: a\n"
            "                         '#' line gives the reason)\n"
            "  --hierarchy P,S        with levels ending /private and /shared: the simulated\n"
            "                         cores of a version-4 trace on private caches above a\n"
            "                         shared level (sim --hierarchy L1=32K/8/64/lru/private,\n"
            "                         LLC=1K-4M/full/64/lru/shared --help)\n"
            "  -h, --help             this help\n\n"
            "Output columns: size_bytes line assoc class accesses read_misses write_misses\n"
            "writebacks wt_bytes traffic_bytes; one row per size and class, then group rows\n"
            "(geometry, ray, other). accesses counts line touches (a reference spanning k\n"
            "lines is k accesses), not references. assoc 0 = fully associative. Accounting\n"
            "and units: docs/cachesim.md. Exit status 0 ok, 1 a trace failed, 2 usage error.\n",
            rt_sim_repl_list());
}

/* Whether the output has the traffic_se column: the hybrid method, errors
 * asked for (the default; --no-error). */
static int has_se(const rt_approx_config *ac) { return ac->method == RT_APPROX_HYBRID && ac->errors; }

/* se: the row's estimated standard error of traffic_bytes (hybrid, group
 * rows), -1 where there is none; with_se: the format has that column. */
static void print_row(FILE *f, int fmt, const char *trace, const rt_sim_config *c, int i, const char *name,
                      const rt_sim_counts *t, int with_se, double se, int *first)
{
    unsigned long long v[6] = {t->accesses, t->read_misses, t->write_misses, t->writebacks, t->wt_bytes,
                               t->traffic_bytes};
    char sec[32] = "";
    if (with_se) {
        if (se >= 0) snprintf(sec, sizeof sec, "%.0f", se);
        else snprintf(sec, sizeof sec, "%s", fmt == FMT_TEXT ? "-" : fmt == FMT_JSON ? "null" : "");
    }
    if (fmt == FMT_TEXT) {
        char assoc[16];
        if (c->assoc) snprintf(assoc, sizeof assoc, "%u", c->assoc);
        else strcpy(assoc, "full");
        fprintf(f, "%12llu %5u %5s %-9s %14llu %12llu %12llu %12llu %12llu %16llu%s%*s\n",
                (unsigned long long)c->sizes[i], c->line, assoc, name, v[0], v[1], v[2], v[3], v[4], v[5],
                with_se ? " " : "", with_se ? 16 : 0, sec);
    } else if (fmt == FMT_CSV) {
        fprintf(f, "%s,%llu,%u,%u,%s,%llu,%llu,%llu,%llu,%llu,%llu%s%s\n", trace, (unsigned long long)c->sizes[i],
                c->line, c->assoc, name, v[0], v[1], v[2], v[3], v[4], v[5], with_se ? "," : "", sec);
    } else {
        fprintf(f,
                "%s\n  {\"trace\": \"%s\", \"size_bytes\": %llu, \"line\": %u, \"assoc\": %u, \"policy\": \"%s\", %s%s%s"
                "\"class\": \"%s\", \"accesses\": %llu, \"read_misses\": %llu, \"write_misses\": %llu, "
                "\"writebacks\": %llu, \"wt_bytes\": %llu, \"traffic_bytes\": %llu%s%s}",
                *first ? "" : ",", trace, (unsigned long long)c->sizes[i], c->line, c->assoc,
                rt_sim_policy_name(c), c->repl ? "\"repl\": \"" : "", c->repl ? rt_sim_repl_name(c->repl) : "",
                c->repl ? "\", " : "", name, v[0], v[1], v[2], v[3], v[4], v[5],
                with_se ? ", \"traffic_se_bytes\": " : "", sec);
        *first = 0;
    }
}

/* The header lines of the text format. */
static void print_header(FILE *f, const char *trace, const rt_approx *ap)
{
    const rt_sim_config *c = rt_approx_get_config(ap);
    const rt_approx_config *ac = rt_approx_get_approx_config(ap);
    char params[160];
    rt_approx_params(ac, params, sizeof params);
    char repl[48] = ""; /* LRU keeps the line it always had */
    if (c->repl) snprintf(repl, sizeof repl, ", replacement %s", rt_sim_repl_name(c->repl));
    fprintf(f, "# %s: %llu references (accesses below are line touches), policy %s%s, engine %s%s%s\n", trace,
            (unsigned long long)rt_approx_refs(ap), rt_sim_policy_name(c), repl, rt_approx_engine(ap),
            ac->method == RT_APPROX_EXACT ? "" : " ", params);
    if (ac->method != RT_APPROX_EXACT) {
        rt_approx_stats st;
        rt_approx_get_stats(ap, &st);
        fprintf(f, "# sample: %llu of %llu line touches (%llu lines, rate %.6g)", (unsigned long long)st.sampled_touches,
                (unsigned long long)st.touches, (unsigned long long)st.sampled_lines, st.rate);
        if (ac->method == RT_APPROX_HYBRID)
            fprintf(f, "; %llu windows, %llu with a short warm-up, %llu references scanned or simulated for them",
                    (unsigned long long)st.windows, (unsigned long long)st.short_warmups,
                    (unsigned long long)st.window_refs);
        fputc('\n', f);
    }
    int with_se = has_se(ac);
    fprintf(f, "%12s %5s %5s %-9s %14s %12s %12s %12s %12s %16s%s%*s\n", "size_bytes", "line", "assoc", "class",
            "accesses", "read_misses", "write_misses", "writebacks", "wt_bytes", "traffic_bytes", with_se ? " " : "",
            with_se ? 16 : 0, with_se ? "traffic_se" : "");
}

/* Traffic of size i over all classes (the sum of the group rows). */
static uint64_t total_traffic(const rt_approx *ap, int i)
{
    rt_sim_counts t;
    uint64_t all = 0;
    for (int g = 0; g < RT_NGROUP; g++)
        if (!rt_approx_get_group(ap, i, g, &t, NULL)) all += t.traffic_bytes;
    return all;
}

/* Per-class rows (those with accesses), then group rows, for every size;
 * sizes without an estimate are left out (text: a '#' line says why). */
static void print_results(FILE *f, int fmt, const char *trace, const rt_approx *ap, int *first)
{
    const rt_sim_config *c = rt_approx_get_config(ap);
    const rt_approx_config *ac = rt_approx_get_approx_config(ap);
    int with_se = has_se(ac);
    if (fmt == FMT_TEXT) print_header(f, trace, ap);
    for (int i = 0; i < c->nsizes; i++) {
        rt_sim_counts t;
        rt_err e = {0};
        if (!rt_approx_available(ap, i, &e)) {
            if (fmt == FMT_TEXT) fprintf(f, "# %llu: %s\n", (unsigned long long)c->sizes[i], e.msg);
            continue;
        }
        double se;
        for (int k = 0; k < RT_NCLASS; k++)
            if (!rt_approx_get(ap, i, k, &t, NULL) && t.accesses)
                print_row(f, fmt, trace, c, i, rt_class_name(k), &t, with_se, -1, first);
        for (int g = 0; g < RT_NGROUP; g++)
            if (!rt_approx_get_group(ap, i, g, &t, NULL)) {
                if (rt_approx_traffic_se(ap, i, g, &se, NULL)) se = -1;
                print_row(f, fmt, trace, c, i, rt_group_name(g), &t, with_se, se, first);
            }
        /* the whole traffic and its error, in words */
        if (fmt == FMT_TEXT && with_se) {
            uint64_t all = total_traffic(ap, i);
            if (rt_approx_traffic_se(ap, i, RT_NGROUP, &se, &e) == 0)
                fprintf(f, "# %llu: traffic %llu bytes, standard error %.0f bytes (%.2f%%)\n",
                        (unsigned long long)c->sizes[i], (unsigned long long)all, se,
                        all ? 100 * se / (double)all : 0.0);
            else
                fprintf(f, "# %llu: %s\n", (unsigned long long)c->sizes[i], e.msg);
        }
    }
}

/* The largest relative standard error of the whole traffic over the sizes
 * that have one (hybrid), for the one-line summary; -1 if none. */
static double worst_se(const rt_approx *ap, int *at)
{
    const rt_sim_config *c = rt_approx_get_config(ap);
    double worst = -1;
    for (int i = 0; i < c->nsizes; i++) {
        double se;
        if (rt_approx_traffic_se(ap, i, RT_NGROUP, &se, NULL)) continue;
        uint64_t all = total_traffic(ap, i);
        double r = all ? se / (double)all : 0;
        if (r > worst) {
            worst = r;
            *at = i;
        }
    }
    return worst;
}

/* Stores one replayed trace as a run; prints a summary line to stderr. */
static int store(rt_db *db, const char *path, const rt_approx *ap, const rt_tr_meta *m, const rt_sim_input *in,
                 double secs, int din_class, rt_err *e)
{
    const rt_sim_config *c = rt_approx_get_config(ap);
    rt_db_traffic *rows = calloc((size_t)c->nsizes * RT_NCLASS, sizeof *rows);
    if (!rows) return rt_errf(e, "out of memory");
    size_t n = rt_approx_db_rows(ap, rows);
    rt_exp_key k;
    if (in->has_meta) {
        memset(&k, 0, sizeof k);
        rt_exp_run_from_meta(m, &k.run);
    } else {
        rt_exp_run_from_din(path, din_class, in->file_hash, &k);
    }
    rt_exp_key_method(&k, rt_approx_get_approx_config(ap));
    rt_db_run r = k.run;
    r.trace_hash = in->file_hash;
    r.refs = in->refs;
    r.command = rt_cmd_line();
    r.wall_time = secs;
    r.repl = c->repl ? rt_sim_repl_name(c->repl) : NULL; /* the run key's replacement policy */
    int64_t id = 0;
    /* an empty trace measured nothing: storing it would look like a result */
    if (in->refs == 0) {
        free(rows);
        return rt_errf(e, "%s: no references in the trace; nothing stored", path);
    }
    /* a trace with generations, simulated exactly: per-generation rows too */
    rt_db_gen *grows = NULL;
    size_t ng = 0;
    if (in->has_meta && m->generations > 0 && rt_approx_get_approx_config(ap)->method == RT_APPROX_EXACT) {
        if (!(grows = calloc((size_t)c->nsizes * RT_NCLASS * RT_MAXGEN, sizeof *grows))) {
            free(rows);
            return rt_errf(e, "out of memory");
        }
        ng = rt_approx_db_gen_rows(ap, grows);
    }
    /* the hybrid's standard errors (sim_params says errors=1) */
    rt_db_se *se = calloc((size_t)c->nsizes, sizeof *se);
    int rc = -1;
    size_t nse = 0;
    if (!se) rt_errf(e, "out of memory");
    else {
        nse = rt_approx_db_se_rows(ap, se);
        rt_db_rows R = {.traffic = rows, .ntraffic = n, .gen = grows, .ngen = ng, .se = se, .nse = nse};
        rc = rt_db_store(db, &r, &R, &id, e);
    }
    free(rows);
    free(grows);
    free(se);
    if (rc == 0) {
        char err[96] = "";
        int at = 0;
        double w = worst_se(ap, &at);
        if (w >= 0 && nse > 0) /* an exact run has no standard error to report */
            snprintf(err, sizeof err, ", largest standard error %.2f%% of traffic (%llu bytes)", 100 * w,
                     (unsigned long long)c->sizes[at]);
        fprintf(stderr, "raytraffic sim: %s: %llu refs in %.2f s (%.1f M refs/s), %zu rows, run %lld%s\n", path,
                (unsigned long long)in->refs, secs, secs > 0 ? (double)in->refs / secs / 1e6 : 0.0, n,
                (long long)id, err);
    }
    return rc;
}

enum { O_SIZES = 1, O_LINE, O_ASSOC, O_WT, O_NWA, O_INFMT, O_DINCLS, O_DB, O_FMT, O_METHOD, O_RATE, O_SMAX,
       O_SEED, O_EXACT_BELOW, O_WINDOW_BELOW, O_PERIOD, O_WINDOW, O_FLUSH, O_FULLLINE, O_THREADS, O_NOERR,
       O_REPL, O_HIER };
static const struct option longopts[] = {
    {"sizes", required_argument, NULL, O_SIZES},
    {"line", required_argument, NULL, O_LINE},
    {"assoc", required_argument, NULL, O_ASSOC},
    {"write-through", no_argument, NULL, O_WT},
    {"no-write-allocate", no_argument, NULL, O_NWA},
    {"input-format", required_argument, NULL, O_INFMT},
    {"din-class", required_argument, NULL, O_DINCLS},
    {"db", required_argument, NULL, O_DB},
    {"format", required_argument, NULL, O_FMT},
    {"method", required_argument, NULL, O_METHOD},
    {"rate", required_argument, NULL, O_RATE},
    {"smax", required_argument, NULL, O_SMAX},
    {"seed", required_argument, NULL, O_SEED},
    {"exact-below", required_argument, NULL, O_EXACT_BELOW},
    {"window-below", required_argument, NULL, O_WINDOW_BELOW},
    {"period", required_argument, NULL, O_PERIOD},
    {"window", required_argument, NULL, O_WINDOW},
    {"flush", no_argument, NULL, O_FLUSH},
    {"write-fullline", no_argument, NULL, O_FULLLINE},
    {"threads", required_argument, NULL, O_THREADS},
    {"no-error", no_argument, NULL, O_NOERR},
    {"repl", required_argument, NULL, O_REPL},
    {"hierarchy", required_argument, NULL, O_HIER},
    {"help", no_argument, NULL, 'h'},
    {NULL, 0, NULL, 0},
};

/* Index of arg in names (NULL-terminated), or -1 with a usage message. */
static int pick(const char *opt, const char *arg, const char *const *names, const char *expect)
{
    for (int i = 0; names[i]; i++)
        if (!strcmp(arg, names[i])) return i;
    rt_cmd_error("sim", "--%s: '%s' is not %s", opt, arg, expect);
    return -1;
}

/* Handles one option. 0 ok, -1 usage error (printed). */
static int parse_opt(sim_opts *o, int ch, const char *arg, const char *argv_opt)
{
    static const char *const infmts[] = {"auto", "rtt", "din", NULL}, *const outfmts[] = {"text", "csv", "json", NULL};
    rt_err err = {0};
    uint64_t v;
    switch (ch) {
    case O_SIZES:
        if (rt_sim_parse_sizes(arg, &o->cfg, &err)) {
            rt_cmd_error("sim", "--sizes: %s", err.msg);
            return -1;
        }
        return 0;
    case O_LINE: return rt_cmd_parse_line("sim", arg, &o->cfg.line);
    case O_ASSOC:
        if (!strcmp(arg, "full")) o->cfg.assoc = 0;
        else if (rt_parse_size(arg, &v) || v == 0 || v > (1u << 30)) {
            rt_cmd_error("sim", "--assoc: '%s' is not 'full' or a positive number of ways", arg);
            return -1;
        } else o->cfg.assoc = (uint32_t)v;
        return 0;
    case O_REPL:
        if (rt_sim_repl_parse(arg, &o->cfg.repl, &err)) {
            rt_cmd_error("sim", "--repl: %s", err.msg);
            return -1;
        }
        return 0;
    case O_HIER: o->hier = arg; return 0;
    case O_WT: o->cfg.write_through = 1; return 0;
    case O_NWA: o->cfg.no_write_allocate = 1; return 0;
    case O_FLUSH: o->cfg.flush = 1; return 0;
    case O_NOERR: o->ac.errors = 0; return 0;
    case O_FULLLINE: o->cfg.write_miss_fullline = 1; return 0;
    case O_THREADS:
        if (rt_parse_size(arg, &v) || v < 1 || v > RT_SIM_MAXTHREADS) {
            rt_cmd_error("sim", "--threads: '%s' is not 1 or %d", arg, RT_SIM_MAXTHREADS);
            return -1;
        }
        o->threads = (int)v;
        return 0;
    case O_INFMT: /* RT_SIM_IN_AUTO, _RTT, _DIN are 0, 1, 2 */
        return (o->infmt = pick("input-format", arg, infmts, "auto, rtt or din")) < 0 ? -1 : 0;
    case O_DINCLS:
        if ((o->din_class = rt_class_from_name(arg)) < 0) {
            rt_cmd_error("sim", "--din-class: unknown class '%s'", arg);
            return -1;
        }
        return 0;
    case O_DB: {
        rt_err ne = {0};
        if (rt_open_target(arg, RT_TARGET_DB, &ne) < 0 && ne.usage) { /* the name; the file is checked when opened */
            rt_cmd_error("sim", "--db: %s", ne.msg);
            return -1;
        }
        o->db = arg;
        return 0;
    }
    case O_FMT: return (o->outfmt = pick("format", arg, outfmts, "text, csv or json")) < 0 ? -1 : 0;
    case O_METHOD:
        if ((o->ac.method = rt_approx_method_from_name(arg)) < 0) {
            rt_cmd_error("sim", "--method: '%s' is not exact, shards, shards-fixed, statstack or hybrid", arg);
            return -1;
        }
        return 0;
    case O_RATE:
        if (rt_cmd_parse_rate(arg, &o->ac.rate)) {
            rt_cmd_error("sim", "--rate: '%s' is not a rate in (0, 1] or 1/N", arg);
            return -1;
        }
        o->rate_given = 1;
        return 0;
    case O_SMAX: case O_SEED: case O_EXACT_BELOW: case O_WINDOW_BELOW: case O_PERIOD: case O_WINDOW: {
        uint64_t *dst[] = {&o->ac.smax, &o->ac.seed, &o->ac.exact_below, &o->ac.window_below, &o->ac.period,
                           &o->ac.window};
        if (rt_parse_size(arg, &v)) {
            rt_cmd_error("sim", "--%s: '%s' is not a count", longopts[ch - O_SIZES].name, arg);
            return -1;
        }
        *dst[ch - O_SMAX] = v;
        return 0;
    }
    default:
        rt_cmd_error("sim", "unknown or incomplete option '%s' (see --help)", argv_opt);
        return -1;
    }
}

/* Options that apply only to some methods, and which. */
static const struct {
    int opt;
    unsigned methods; /* bit (1 << RT_APPROX_x) */
    const char *which;
} method_opts[] = {
    {O_RATE, 1u << RT_APPROX_SHARDS_RATE | 1u << RT_APPROX_STATSTACK | 1u << RT_APPROX_HYBRID,
     "shards, statstack and hybrid"},
    {O_SMAX, 1u << RT_APPROX_SHARDS_FIXED, "shards-fixed"},
    {O_SEED, ~0u, "the sampled methods and --repl random|brrip"},
    {O_EXACT_BELOW, ~(1u << RT_APPROX_EXACT), "the sampled methods"},
    {O_WINDOW_BELOW, 1u << RT_APPROX_HYBRID, "hybrid"},
    {O_PERIOD, 1u << RT_APPROX_HYBRID, "hybrid"},
    {O_WINDOW, 1u << RT_APPROX_HYBRID, "hybrid"},
    {O_NOERR, 1u << RT_APPROX_HYBRID, "hybrid"},
    {O_FLUSH, 1u << RT_APPROX_EXACT, "exact"},
    {O_FULLLINE, 1u << RT_APPROX_EXACT, "exact"},
};

/* An option given that the run would ignore is a usage error naming it.
 * 0 or -1 (printed). */
static int check_applies(const sim_opts *o)
{
    for (size_t i = 0; i < sizeof method_opts / sizeof method_opts[0]; i++)
        if ((o->given >> method_opts[i].opt & 1) && !(method_opts[i].methods >> o->ac.method & 1)) {
            rt_cmd_error("sim", "--%s does not apply to --method %s (only to %s)",
                         longopts[method_opts[i].opt - O_SIZES].name, rt_approx_method_name(o->ac.method),
                         method_opts[i].which);
            return -1;
        }
    if ((o->given >> O_SEED & 1) && o->ac.method == RT_APPROX_EXACT && !rt_sim_repl_random(o->cfg.repl)) {
        rt_cmd_error("sim", "--seed does not apply to --method exact with --repl %s (only to the sampled methods "
                            "and to --repl random|brrip)", rt_sim_repl_name(o->cfg.repl));
        return -1;
    }
    if (o->hier) {
        static const int in_spec[] = {O_SIZES, O_LINE, O_ASSOC, O_REPL, O_WT, O_NWA};
        for (size_t i = 0; i < sizeof in_spec / sizeof in_spec[0]; i++)
            if (o->given >> in_spec[i] & 1) {
                rt_cmd_error("sim", "--%s does not apply with --hierarchy (each level gives its own)",
                             longopts[in_spec[i] - O_SIZES].name);
                return -1;
            }
        if (o->ac.method != RT_APPROX_EXACT) {
            rt_cmd_error("sim", "--hierarchy needs --method exact");
            return -1;
        }
    }
    if (o->db && (o->given >> O_FMT & 1)) {
        rt_cmd_error("sim", "--format applies to printed output, not to --db (which stores runs)");
        return -1;
    }
    if (o->infmt == 1 && (o->given >> O_DINCLS & 1)) { /* RT_SIM_IN_RTT */
        rt_cmd_error("sim", "--din-class does not apply to --input-format rtt");
        return -1;
    }
    return 0;
}

/* Parses argv; optind is left at the first trace. 0 ok, -1 usage error. */
static int parse_args(int argc, char **argv, sim_opts *o)
{
    memset(o, 0, sizeof *o);
    rt_sim_config_default(&o->cfg);
    o->din_class = RT_CLS_FB;
    o->threads = sysconf(_SC_NPROCESSORS_ONLN) >= 2 ? 2 : 1;
    rt_approx_config_default(&o->ac);
    o->ac.method = RT_APPROX_EXACT;
    o->ac.errors = 1; /* sim prints them (hybrid) unless --no-error */
    rt_err err = {0};
    optind = 1;
    opterr = 0;
    int ch;
    while ((ch = getopt_long(argc, argv, "h", longopts, NULL)) != -1) {
        if (parse_opt(o, ch, optarg, argv[optind - 1]) < 0) return -1;
        if (ch > 0 && ch < 32) o->given |= 1u << ch;
    }
    o->cfg.seed = o->ac.seed;
    if (check_applies(o) < 0) return -1;
    if (!o->rate_given) o->ac.rate = rt_approx_default_rate(o->ac.method);
    if (optind >= argc) {
        rt_cmd_error("sim", "no trace given (see --help)");
        return -1;
    }
    if (o->hier) {
        if (rt_hier_parse(o->hier, &o->cfg, &o->hc, &err)) {
            rt_cmd_error("sim", "--hierarchy: %s", err.msg);
            return -1;
        }
        return 0;
    }
    if (rt_sim_config_check(&o->cfg, &err) || rt_approx_config_check(&o->cfg, &o->ac, &err)) {
        rt_cmd_error("sim", "%s", err.msg);
        return -1;
    }
    return 0;
}

/* The rows of one hierarchy: per level, size, class (those with accesses)
 * and group, with the level's name first. An inclusive or exclusive one
 * prints class rows only, with two more columns: backinvals and
 * bi_writebacks (incl.h). */
static void print_hier(FILE *f, int fmt, const char *trace, const rt_hier *h, int *first)
{
    const rt_hier_config *hc = rt_hier_get_config(h);
    int inc = hc->inclusion != RT_INCL_NINE;
    char spec[1024];
    if (fmt == FMT_TEXT) {
        fprintf(f, "# %s: %llu references (accesses below are line touches), hierarchy %s, policy %s, %s\n",
                trace, (unsigned long long)rt_hier_refs(h), rt_hier_spec(hc, spec, sizeof spec),
                rt_sim_policy_name(&hc->level[0]),
                inc ? rt_hier_inclusion_name(hc->inclusion) : "non-inclusive");
        fprintf(f, "%-6s ", "level");
        if (inc) fprintf(f, "%12s ", "last_size");
        fprintf(f, "%12s %5s %5s %-6s %-9s %14s %12s %12s %12s %12s %16s", "size_bytes", "line", "assoc",
                "repl", "class", "accesses", "read_misses", "write_misses", "writebacks", "wt_bytes", "traffic_bytes");
        if (inc) fprintf(f, " %12s %13s", "backinvals", "bi_writebacks");
        fputc('\n', f);
    }
    for (int k = 0; k < hc->nlevels; k++) {
        const rt_sim *s = rt_hier_level(h, k);
        const rt_sim_config *c = &hc->level[k];
        const rt_sim_config *lc = &hc->level[hc->nlevels - 1];
        int nrows = inc ? lc->nsizes : c->nsizes; /* inclusive: level k in the chain of each last-level size */
        for (int i = 0; i < nrows; i++)
            for (int r = 0; r < RT_NCLASS + (inc ? 0 : RT_NGROUP); r++) {
                rt_sim_counts t;
                rt_hier_counts hcnt;
                memset(&hcnt, 0, sizeof hcnt);
                const char *name;
                if (inc) {
                    rt_hier_get(h, k, i, r, &hcnt);
                    t = hcnt.c;
                    if (!t.accesses && !hcnt.backinvals) continue;
                    name = rt_class_name(r);
                } else if (r < RT_NCLASS) {
                    rt_sim_get(s, i, r, &t);
                    if (!t.accesses) continue;
                    name = rt_class_name(r);
                } else {
                    rt_sim_get_group(s, i, r - RT_NCLASS, &t);
                    name = rt_group_name(r - RT_NCLASS);
                }
                unsigned long long v[6] = {t.accesses, t.read_misses, t.write_misses, t.writebacks, t.wt_bytes,
                                           t.traffic_bytes};
                unsigned long long size = inc && k + 1 < hc->nlevels ? c->sizes[0] : c->sizes[i];
                char assoc[16];
                if (c->assoc) snprintf(assoc, sizeof assoc, "%u", c->assoc);
                else strcpy(assoc, fmt == FMT_TEXT ? "full" : "0");
                const char *rp = rt_sim_repl_name(c->repl);
                if (fmt == FMT_TEXT) {
                    fprintf(f, "%-6s ", hc->name[k]);
                    if (inc) fprintf(f, "%12llu ", (unsigned long long)lc->sizes[i]);
                    fprintf(f, "%12llu %5u %5s %-6s %-9s %14llu %12llu %12llu %12llu %12llu %16llu", size, c->line, assoc, rp, name, v[0], v[1], v[2], v[3], v[4], v[5]);
                    if (inc)
                        fprintf(f, " %12llu %13llu", (unsigned long long)hcnt.backinvals,
                                (unsigned long long)hcnt.bi_writebacks);
                    fputc('\n', f);
                } else if (fmt == FMT_CSV) {
                    fprintf(f, "%s,%s,", trace, hc->name[k]);
                    if (inc) fprintf(f, "%llu,", (unsigned long long)lc->sizes[i]);
                    fprintf(f, "%llu,%u,%s,%s,%s,%llu,%llu,%llu,%llu,%llu,%llu", size, c->line,
                            assoc, rp, name, v[0], v[1], v[2], v[3], v[4], v[5]);
                    if (inc)
                        fprintf(f, ",%llu,%llu", (unsigned long long)hcnt.backinvals,
                                (unsigned long long)hcnt.bi_writebacks);
                    fputc('\n', f);
                } else {
                    fprintf(f,
                            "%s\n  {\"trace\": \"%s\", \"level\": \"%s\", \"size_bytes\": %llu, \"line\": %u, \"assoc\": %s, "
                            "\"repl\": \"%s\", \"policy\": \"%s\", \"class\": \"%s\", \"accesses\": %llu, \"read_misses\": %llu, "
                            "\"write_misses\": %llu, \"writebacks\": %llu, \"wt_bytes\": %llu, \"traffic_bytes\": %llu",
                            *first ? "" : ",", trace, hc->name[k], size, c->line, assoc, rp, rt_sim_policy_name(c), name,
                            v[0], v[1], v[2], v[3], v[4], v[5]);
                    if (inc)
                        fprintf(f, ", \"inclusion\": \"%s\", \"last_level_size\": %llu, \"backinvals\": %llu, \"bi_writebacks\": %llu",
                                rt_hier_inclusion_name(hc->inclusion), (unsigned long long)lc->sizes[i],
                                (unsigned long long)hcnt.backinvals, (unsigned long long)hcnt.bi_writebacks);
                    fputc('}', f);
                    *first = 0;
                }
            }
    }
}

/* Stores one hierarchy run: the run keyed by its canonical spec (and the
 * last level's replacement policy), the last level's rows as its traffic
 * (what reaches memory; per generation too when the trace has them) and
 * per-level rows. */
static int store_hier(rt_db *db, const char *path, const rt_hier *h, const rt_tr_meta *m, const rt_sim_input *in,
                      double secs, int din_class, rt_err *e)
{
    const rt_hier_config *hc = rt_hier_get_config(h);
    const rt_sim *last = rt_hier_level(h, hc->nlevels - 1); /* NULL when inclusive or exclusive */
    const rt_sim_config *lc = &hc->level[hc->nlevels - 1];
    if (in->refs == 0) return rt_errf(e, "%s: no references in the trace; nothing stored", path);
    rt_exp_key k;
    if (in->has_meta) {
        memset(&k, 0, sizeof k);
        rt_exp_run_from_meta(m, &k.run);
    } else {
        rt_exp_run_from_din(path, din_class, in->file_hash, &k);
    }
    rt_approx_config ac;
    rt_approx_config_default(&ac);
    ac.method = RT_APPROX_EXACT;
    rt_exp_key_method(&k, &ac);
    char spec[1024];
    rt_db_run r = k.run;
    r.trace_hash = in->file_hash;
    r.refs = in->refs;
    r.command = rt_cmd_line();
    r.wall_time = secs;
    r.repl = lc->repl ? rt_sim_repl_name(lc->repl) : NULL;
    r.hierarchy = rt_hier_spec(hc, spec, sizeof spec);
    rt_db_traffic *rows = calloc((size_t)lc->nsizes * RT_NCLASS, sizeof *rows);
    rt_db_level *lv = calloc(rt_hier_db_level_max(h), sizeof *lv);
    rt_db_gen *grows = NULL;
    size_t ng = 0;
    int rc = -1;
    int gens = last && in->has_meta && m->generations > 0; /* inclusion pools the generations */
    if (gens && (grows = calloc((size_t)lc->nsizes * RT_NCLASS * RT_MAXGEN, sizeof *grows)))
        ng = rt_sim_db_gen_rows(last, grows);
    if (!rows || !lv || (gens && !grows)) rt_errf(e, "out of memory");
    else {
        size_t n = rt_hier_db_rows(h, rows), nl = rt_hier_db_level_rows(h, gens, lv);
        rt_db_rows R = {rows, n, grows, ng, NULL, 0, lv, nl};
        int64_t id = 0;
        rc = rt_db_store(db, &r, &R, &id, e);
        if (rc == 0)
            fprintf(stderr, "raytraffic sim: %s: %llu refs in %.2f s, hierarchy %s, %zu rows, %zu level rows, run %lld\n",
                    path, (unsigned long long)in->refs, secs, spec, n, nl, (long long)id);
    }
    free(rows);
    free(lv);
    free(grows);
    return rc;
}

/* Replays one trace through the hierarchy and prints it. 0 or -1 (printed). */
static int sim_hier(const sim_opts *o, rt_db *db, const char *path, rt_tr_meta *meta, int *first)
{
    rt_err err = {0};
    double t0 = rt_now();
    rt_hier *h = rt_hier_new(&o->hc, &err);
    rt_sim_input in;
    int rc = -1;
    memset(meta, 0, sizeof *meta);
    if (h) {
        rt_repeats rp;
        rt_hier_repeats(h, &rp);
        if (rt_sim_replay_filtered(rt_hier_sink(h), &rp, path, o->infmt, o->din_class, o->threads, meta, &in, &err) == 0) {
            rt_hier_finish(h);
            if (db) rc = store_hier(db, path, h, meta, &in, rt_now() - t0, o->din_class, &err);
            else {
                print_hier(stdout, o->outfmt, path, h, first);
                rc = 0;
            }
        }
    }
    if (rc < 0) rt_cmd_error("sim", "%s", err.msg);
    rt_hier_free(h);
    return rc;
}

/* Replays one trace and prints or stores its counters. 0 or -1 (printed). */
static int sim_one(const sim_opts *o, rt_db *db, const char *path, rt_tr_meta *meta, int *first)
{
    rt_err err = {0};
    rt_approx *ap = rt_approx_new(&o->cfg, &o->ac, &err);
    rt_sim_input in;
    double t0 = rt_now();
    int rc = -1;
    char note[RT_ERR_LEN];
    memset(meta, 0, sizeof *meta);
    int replayed = ap ? rt_approx_replay_file(ap, path, o->infmt, o->din_class, o->threads, meta, &in, note,
                                              sizeof note, &err)
                      : -1;
    if (ap && note[0]) fprintf(stderr, "raytraffic sim: note: %s\n", note);
    if (ap && !replayed && !rt_approx_finish(ap, &err)) {
        if (!db) print_results(stdout, o->outfmt, path, ap, first);
        rc = db ? store(db, path, ap, meta, &in, rt_now() - t0, o->din_class, &err) : 0;
    }
    if (rc < 0) rt_cmd_error("sim", "%s", err.msg);
    rt_approx_free(ap);
    return rc;
}

int rt_cmd_sim_check_args(int argc, char **argv)
{
    if (rt_cmd_wants_cores(argc, argv)) return 0;
    sim_opts o;
    return parse_args(argc, argv, &o);
}

int main_sim(int argc, char **argv)
{
    /* levels marked private/shared: the multi-core model, cmd_sim_cores.c */
    if (rt_cmd_wants_cores(argc, argv)) return rt_cmd_sim_cores(argc, argv);
    if (rt_cmd_wants_help(argc, argv)) {
        usage(stdout);
        return RT_EXIT_OK;
    }
    sim_opts o;
    if (parse_args(argc, argv, &o) < 0) return RT_EXIT_USAGE;
    rt_err err = {0};
    rt_db *db = NULL;
    if (o.db && !(db = rt_db_open(o.db, &err))) {
        rt_cmd_error("sim", "%s", err.msg);
        return err.usage ? RT_EXIT_USAGE : RT_EXIT_FAIL;
    }
    rt_tr_meta *meta = malloc(sizeof *meta);
    if (!meta) {
        rt_cmd_error("sim", "out of memory");
        rt_db_close(db);
        return RT_EXIT_FAIL;
    }
    int status = RT_EXIT_OK, first = 1;
    if (!db && o.hier && o.outfmt == FMT_CSV && o.hc.inclusion != RT_INCL_NINE)
        printf("trace,level,last_level_size,size_bytes,line,assoc,repl,class,accesses,read_misses,write_misses,writebacks,"
               "wt_bytes,traffic_bytes,backinvals,bi_writebacks\n");
    else if (!db && o.hier && o.outfmt == FMT_CSV)
        printf("trace,level,size_bytes,line,assoc,repl,class,accesses,read_misses,write_misses,writebacks,wt_bytes,"
               "traffic_bytes\n");
    else if (!db && o.outfmt == FMT_CSV)
        printf("trace,size_bytes,line,assoc,class,accesses,read_misses,write_misses,writebacks,wt_bytes,"
               "traffic_bytes%s\n", has_se(&o.ac) ? ",traffic_se_bytes" : "");
    if (!db && o.outfmt == FMT_JSON) printf("[");
    for (int a = optind; a < argc; a++)
        if ((o.hier ? sim_hier(&o, db, argv[a], meta, &first) : sim_one(&o, db, argv[a], meta, &first)) < 0)
            status = RT_EXIT_FAIL;
    if (!db && o.outfmt == FMT_JSON) printf("\n]\n");
    free(meta);
    rt_db_close(db);
    if (fflush(stdout) != 0) {
        rt_cmd_error("sim", "writing output: %s", strerror(errno));
        status = RT_EXIT_FAIL;
    }
    return status;
}
