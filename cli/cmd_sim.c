/* cmd_sim.c -- `raytraffic sim`: replay traces through cache models, print
 * the counters or store them in the results database. */
#include "approx.h"
#include "cmd.h"
#include "rows.h"
#include "sim.h"
#include "trace.h"

#include <errno.h>
#include <getopt.h>
#include <stdlib.h>
#include <string.h>

enum { FMT_TEXT, FMT_CSV, FMT_JSON };

typedef struct sim_opts {
    rt_sim_config cfg;  /* cache configurations */
    int infmt;          /* RT_SIM_IN_* */
    int din_class;      /* class of din records */
    const char *db;     /* database path or NULL */
    int outfmt;         /* FMT_* */
    rt_approx_config ac;/* --method etc.; RT_APPROX_EXACT = the exact simulator */
} sim_opts;

static void usage(FILE *f)
{
    fprintf(f,
            "Usage: raytraffic sim [options] TRACE...\n\n"
            "Replays each trace (raytraffic .rtt or Dinero IV din text) once through a\n"
            "set of LRU caches and reports per-class accesses, misses, write-backs and\n"
            "DRAM traffic for every cache size.\n\n"
            "Options:\n"
            "  --sizes LIST           1K-4M (powers of two) or 1K,2K,64K (default 1K-4M)\n"
            "  --line N               line size in bytes, any value (default 64)\n"
            "  --assoc full|N         fully associative (default) or N ways; 1 = direct-mapped\n"
            "  --write-through        write-through instead of write-back\n"
            "  --no-write-allocate    write misses do not allocate (write around)\n"
            "  --input-format F       auto | rtt | din (default auto: sniff the content)\n"
            "  --din-class C          class of din records (default fb, group 'other')\n"
            "  --db FILE              store one run per trace in this SQLite database and\n"
            "                         print a one-line summary per trace to stderr\n"
            "  --format F             text | csv | json output when --db is not given\n"
            "  --method M             exact (default) | shards | shards-fixed | statstack |\n"
            "                         hybrid: sampled estimates (docs/approx.md); fully\n"
            "                         associative write-back write-allocate caches only\n"
            "  --rate R               sampling rate, a number or 1/N (default 0.01; hybrid:\n"
            "                         1/64, golden-ratio line sampling)\n"
            "  --window-below SIZE    hybrid: sizes below SIZE on exact windows (default 32K)\n"
            "  --period N             hybrid: one window every N references (default 65536)\n"
            "  --window N             hybrid: references per window (default 1024)\n"
            "  --smax N               sampled lines kept by shards-fixed (default 8192)\n"
            "  --seed S               sampling seed (default 1)\n"
            "  --exact-below SIZE     simulate sizes below SIZE exactly (default 0 = none);\n"
            "                         sizes without an estimate are left out (text: a\n"
            "                         '#' line gives the reason)\n"
            "  -h, --help             this help\n\n"
            "Output columns: size_bytes line assoc class accesses read_misses write_misses\n"
            "writebacks wt_bytes traffic_bytes; one row per size and class, then group rows\n"
            "(geometry, ray, other). assoc 0 = fully associative. Accounting and units:\n"
            "docs/cachesim.md. Exit status 0 ok, 1 a trace failed, 2 usage error.\n");
}

static const char *basename_of(const char *p)
{
    const char *s = strrchr(p, '/');
    return s ? s + 1 : p;
}

static void print_row(FILE *f, int fmt, const char *trace, const rt_sim_config *c, int i, const char *name,
                      const rt_sim_counts *t, int *first)
{
    unsigned long long v[6] = {t->accesses, t->read_misses, t->write_misses, t->writebacks, t->wt_bytes,
                               t->traffic_bytes};
    if (fmt == FMT_TEXT) {
        char assoc[16];
        if (c->assoc) snprintf(assoc, sizeof assoc, "%u", c->assoc);
        else strcpy(assoc, "full");
        fprintf(f, "%12llu %5u %5s %-9s %14llu %12llu %12llu %12llu %12llu %16llu\n",
                (unsigned long long)c->sizes[i], c->line, assoc, name, v[0], v[1], v[2], v[3], v[4], v[5]);
    } else if (fmt == FMT_CSV) {
        fprintf(f, "%s,%llu,%u,%u,%s,%llu,%llu,%llu,%llu,%llu,%llu\n", trace, (unsigned long long)c->sizes[i],
                c->line, c->assoc, name, v[0], v[1], v[2], v[3], v[4], v[5]);
    } else {
        fprintf(f,
                "%s\n  {\"trace\": \"%s\", \"size_bytes\": %llu, \"line\": %u, \"assoc\": %u, \"policy\": \"%s\", "
                "\"class\": \"%s\", \"accesses\": %llu, \"read_misses\": %llu, \"write_misses\": %llu, "
                "\"writebacks\": %llu, \"wt_bytes\": %llu, \"traffic_bytes\": %llu}",
                *first ? "" : ",", trace, (unsigned long long)c->sizes[i], c->line, c->assoc,
                rt_sim_policy_name(c), name, v[0], v[1], v[2], v[3], v[4], v[5]);
        *first = 0;
    }
}

static void print_results(FILE *f, int fmt, const char *trace, const rt_sim *s, int *first)
{
    const rt_sim_config *c = rt_sim_get_config(s);
    if (fmt == FMT_TEXT) {
        fprintf(f, "# %s: %llu references, policy %s, engine %s\n", trace, (unsigned long long)rt_sim_refs(s),
                rt_sim_policy_name(c), rt_sim_engine(s));
        fprintf(f, "%12s %5s %5s %-9s %14s %12s %12s %12s %12s %16s\n", "size_bytes", "line", "assoc", "class",
                "accesses", "read_misses", "write_misses", "writebacks", "wt_bytes", "traffic_bytes");
    }
    for (int i = 0; i < c->nsizes; i++) {
        rt_sim_counts t;
        for (int k = 0; k < RT_NCLASS; k++) {
            rt_sim_get(s, i, k, &t);
            if (t.accesses) print_row(f, fmt, trace, c, i, rt_class_name(k), &t, first);
        }
        for (int g = 0; g < RT_NGROUP; g++) {
            rt_sim_get_group(s, i, g, &t);
            print_row(f, fmt, trace, c, i, rt_group_name(g), &t, first);
        }
    }
}

/* print_results for a sampled estimate: sizes without one are left out. */
static void print_results_approx(FILE *f, int fmt, const char *trace, const rt_approx *ap, int *first)
{
    const rt_sim_config *c = rt_approx_get_config(ap);
    char params[160];
    rt_approx_params(rt_approx_get_approx_config(ap), params, sizeof params);
    if (fmt == FMT_TEXT) {
        fprintf(f, "# %s: %llu references, policy %s, engine %s %s\n", trace,
                (unsigned long long)rt_approx_refs(ap), rt_sim_policy_name(c),
                rt_approx_method_name(rt_approx_get_approx_config(ap)->method), params);
        rt_approx_stats st;
        rt_approx_get_stats(ap, &st);
        fprintf(f, "# sample: %llu of %llu line touches (%llu lines, rate %.6g)", (unsigned long long)st.sampled_touches,
                (unsigned long long)st.touches, (unsigned long long)st.sampled_lines, st.rate);
        if (rt_approx_get_approx_config(ap)->method == RT_APPROX_HYBRID)
            fprintf(f, "; %llu windows, %llu with a short warm-up, %llu references scanned or simulated for them",
                    (unsigned long long)st.windows, (unsigned long long)st.short_warmups,
                    (unsigned long long)st.window_refs);
        fputc('\n', f);
        fprintf(f, "%12s %5s %5s %-9s %14s %12s %12s %12s %12s %16s\n", "size_bytes", "line", "assoc", "class",
                "accesses", "read_misses", "write_misses", "writebacks", "wt_bytes", "traffic_bytes");
    }
    for (int i = 0; i < c->nsizes; i++) {
        rt_sim_counts t;
        rt_err e = {{0}};
        if (!rt_approx_available(ap, i, &e)) {
            if (fmt == FMT_TEXT) fprintf(f, "# %llu: %s\n", (unsigned long long)c->sizes[i], e.msg);
            continue;
        }
        for (int k = 0; k < RT_NCLASS; k++)
            if (!rt_approx_get(ap, i, k, &t, NULL) && t.accesses) print_row(f, fmt, trace, c, i, rt_class_name(k), &t, first);
        for (int g = 0; g < RT_NGROUP; g++)
            if (!rt_approx_get_group(ap, i, g, &t, NULL)) print_row(f, fmt, trace, c, i, rt_group_name(g), &t, first);
    }
}

static int store(rt_db *db, const char *path, const rt_sim *s, const rt_approx *ap, const rt_tr_meta *m,
                 const rt_sim_input *in, double secs, int din_class, rt_err *e)
{
    const rt_sim_config *c = s ? rt_sim_get_config(s) : rt_approx_get_config(ap);
    rt_db_traffic *rows = calloc((size_t)c->nsizes * RT_NCLASS, sizeof *rows);
    if (!rows) return rt_errf(e, "out of memory");
    size_t n = s ? rt_sim_db_rows(s, rows) : rt_approx_db_rows(ap, rows);
    char sim_params[160] = "";
    if (ap) rt_approx_params(rt_approx_get_approx_config(ap), sim_params, sizeof sim_params);
    rt_db_run r;
    memset(&r, 0, sizeof r);
    char scene[300], params[64];
    if (in->has_meta) {
        r.scene = m->scene;
        r.scene_params = m->scene_params;
        r.scene_hash = m->scene_hash;
        r.ntri = m->ntri;
        r.tracer = m->tracer;
        r.W = m->W;
        r.H = m->H;
        r.lights = m->lights;
        r.cache_size = m->cache_size;
        r.gmax = m->gmax;
        r.params = m->params;
    } else { /* din: identified by file name and content */
        snprintf(scene, sizeof scene, "din:%s", basename_of(path));
        snprintf(params, sizeof params, "din_class=%s", rt_class_name(din_class));
        r.scene = scene;
        r.scene_hash = in->file_hash;
        r.tracer = "din";
        r.params = params;
    }
    r.sim_method = ap ? rt_approx_method_name(rt_approx_get_approx_config(ap)->method) : "exact";
    r.sim_params = sim_params;
    r.trace_hash = in->file_hash;
    r.refs = in->refs;
    r.command = rt_cmd_line();
    r.wall_time = secs;
    int64_t id = 0;
    int rc = rt_db_store_run(db, &r, rows, n, &id, e);
    free(rows);
    if (rc == 0)
        fprintf(stderr, "raytraffic sim: %s: %llu refs in %.2f s (%.1f M refs/s), %zu rows, run %lld\n", path,
                (unsigned long long)in->refs, secs, secs > 0 ? (double)in->refs / secs / 1e6 : 0.0, n,
                (long long)id);
    return rc;
}

int main_sim(int argc, char **argv)
{
    if (rt_cmd_wants_help(argc, argv)) {
        usage(stdout);
        return RT_EXIT_OK;
    }
    sim_opts o;
    memset(&o, 0, sizeof o);
    rt_sim_config_default(&o.cfg);
    o.din_class = RT_CLS_FB;
    rt_approx_config_default(&o.ac);
    o.ac.method = RT_APPROX_EXACT;
    int rate_given = 0;
    enum { O_SIZES = 1, O_LINE, O_ASSOC, O_WT, O_NWA, O_INFMT, O_DINCLS, O_DB, O_FMT, O_METHOD, O_RATE, O_SMAX,
           O_SEED, O_EXACT_BELOW, O_WINDOW_BELOW, O_PERIOD, O_WINDOW };
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
        {"help", no_argument, NULL, 'h'},
        {NULL, 0, NULL, 0},
    };
    rt_err err = {{0}};
    optind = 1;
    opterr = 0;
    int ch;
    while ((ch = getopt_long(argc, argv, "h", longopts, NULL)) != -1) {
        uint64_t v;
        switch (ch) {
        case O_SIZES:
            if (rt_sim_parse_sizes(optarg, &o.cfg, &err)) {
                rt_cmd_error("sim", "--sizes: %s", err.msg);
                return RT_EXIT_USAGE;
            }
            break;
        case O_LINE:
            if (rt_parse_size(optarg, &v) || v == 0 || v > (1u << 20)) {
                rt_cmd_error("sim", "--line: '%s' is not a line size in 1..1M bytes", optarg);
                return RT_EXIT_USAGE;
            }
            o.cfg.line = (uint32_t)v;
            break;
        case O_ASSOC:
            if (!strcmp(optarg, "full")) o.cfg.assoc = 0;
            else if (rt_parse_size(optarg, &v) || v == 0 || v > (1u << 30)) {
                rt_cmd_error("sim", "--assoc: '%s' is not 'full' or a positive number of ways", optarg);
                return RT_EXIT_USAGE;
            } else o.cfg.assoc = (uint32_t)v;
            break;
        case O_WT: o.cfg.write_through = 1; break;
        case O_NWA: o.cfg.no_write_allocate = 1; break;
        case O_INFMT:
            if (!strcmp(optarg, "auto")) o.infmt = RT_SIM_IN_AUTO;
            else if (!strcmp(optarg, "rtt")) o.infmt = RT_SIM_IN_RTT;
            else if (!strcmp(optarg, "din")) o.infmt = RT_SIM_IN_DIN;
            else {
                rt_cmd_error("sim", "--input-format: '%s' is not auto, rtt or din", optarg);
                return RT_EXIT_USAGE;
            }
            break;
        case O_DINCLS:
            o.din_class = rt_class_from_name(optarg);
            if (o.din_class < 0) {
                rt_cmd_error("sim", "--din-class: unknown class '%s'", optarg);
                return RT_EXIT_USAGE;
            }
            break;
        case O_DB: o.db = optarg; break;
        case O_FMT:
            if (!strcmp(optarg, "text")) o.outfmt = FMT_TEXT;
            else if (!strcmp(optarg, "csv")) o.outfmt = FMT_CSV;
            else if (!strcmp(optarg, "json")) o.outfmt = FMT_JSON;
            else {
                rt_cmd_error("sim", "--format: '%s' is not text, csv or json", optarg);
                return RT_EXIT_USAGE;
            }
            break;
        case O_METHOD:
            o.ac.method = rt_approx_method_from_name(optarg);
            if (o.ac.method < 0) {
                rt_cmd_error("sim", "--method: '%s' is not exact, shards, shards-fixed, statstack or hybrid", optarg);
                return RT_EXIT_USAGE;
            }
            break;
        case O_RATE:
            if (rt_cmd_parse_rate(optarg, &o.ac.rate)) {
                rt_cmd_error("sim", "--rate: '%s' is not a rate in (0, 1] or 1/N", optarg);
                return RT_EXIT_USAGE;
            }
            rate_given = 1;
            break;
        case O_SMAX:
        case O_SEED:
        case O_EXACT_BELOW:
        case O_WINDOW_BELOW:
        case O_PERIOD:
        case O_WINDOW:
            if (rt_parse_size(optarg, &v)) {
                rt_cmd_error("sim", "--%s: '%s' is not a count", longopts[ch - O_SIZES].name, optarg);
                return RT_EXIT_USAGE;
            }
            if (ch == O_SMAX) o.ac.smax = v;
            else if (ch == O_SEED) o.ac.seed = v;
            else if (ch == O_EXACT_BELOW) o.ac.exact_below = v;
            else if (ch == O_WINDOW_BELOW) o.ac.window_below = v;
            else if (ch == O_PERIOD) o.ac.period = v;
            else o.ac.window = v;
            break;
        case 'h': usage(stdout); return RT_EXIT_OK;
        default:
            rt_cmd_error("sim", "unknown or incomplete option '%s' (see --help)", argv[optind - 1]);
            return RT_EXIT_USAGE;
        }
    }
    if (!rate_given) o.ac.rate = rt_approx_default_rate(o.ac.method);
    if (optind >= argc) {
        rt_cmd_error("sim", "no trace given (see --help)");
        return RT_EXIT_USAGE;
    }
    if (rt_sim_config_check(&o.cfg, &err) || rt_approx_config_check(&o.cfg, &o.ac, &err)) {
        rt_cmd_error("sim", "%s", err.msg);
        return RT_EXIT_USAGE;
    }
    rt_db *db = NULL;
    if (o.db && !(db = rt_db_open(o.db, &err))) {
        rt_cmd_error("sim", "%s", err.msg);
        return RT_EXIT_FAIL;
    }
    int status = RT_EXIT_OK, first = 1;
    if (!db && o.outfmt == FMT_CSV)
        printf("trace,size_bytes,line,assoc,class,accesses,read_misses,write_misses,writebacks,wt_bytes,"
               "traffic_bytes\n");
    if (!db && o.outfmt == FMT_JSON) printf("[");
    rt_tr_meta *meta = malloc(sizeof *meta);
    if (!meta) {
        rt_cmd_error("sim", "out of memory");
        rt_db_close(db);
        return RT_EXIT_FAIL;
    }
    for (int a = optind; a < argc; a++) {
        const char *path = argv[a];
        if (o.ac.method != RT_APPROX_EXACT) { /* sampled estimate */
            rt_approx *ap = rt_approx_new(&o.cfg, &o.ac, &err);
            if (!ap) {
                rt_cmd_error("sim", "%s", err.msg);
                status = RT_EXIT_FAIL;
                break;
            }
            rt_sim_input in;
            double t0 = rt_now();
            memset(meta, 0, sizeof *meta);
            if (rt_approx_replay(ap, path, o.infmt, o.din_class, meta, &in, &err) || rt_approx_finish(ap, &err)) {
                rt_cmd_error("sim", "%s", err.msg);
                status = RT_EXIT_FAIL;
            } else if (db) {
                if (store(db, path, NULL, ap, meta, &in, rt_now() - t0, o.din_class, &err)) {
                    rt_cmd_error("sim", "%s", err.msg);
                    status = RT_EXIT_FAIL;
                }
            } else {
                print_results_approx(stdout, o.outfmt, path, ap, &first);
            }
            rt_approx_free(ap);
            continue;
        }
        rt_sim *s = rt_sim_new(&o.cfg, &err);
        if (!s) {
            rt_cmd_error("sim", "%s", err.msg);
            status = RT_EXIT_FAIL;
            break;
        }
        rt_sim_input in;
        double t0 = rt_now();
        memset(meta, 0, sizeof *meta);
        if (rt_sim_replay(s, path, o.infmt, o.din_class, meta, &in, &err)) {
            rt_cmd_error("sim", "%s", err.msg);
            status = RT_EXIT_FAIL;
        } else if (db) {
            if (store(db, path, s, NULL, meta, &in, rt_now() - t0, o.din_class, &err)) {
                rt_cmd_error("sim", "%s", err.msg);
                status = RT_EXIT_FAIL;
            }
        } else {
            print_results(stdout, o.outfmt, path, s, &first);
        }
        rt_sim_free(s);
    }
    if (!db && o.outfmt == FMT_JSON) printf("\n]\n");
    free(meta);
    rt_db_close(db);
    if (fflush(stdout) != 0) {
        rt_cmd_error("sim", "writing output: %s", strerror(errno));
        status = RT_EXIT_FAIL;
    }
    return status;
}
