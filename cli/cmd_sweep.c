/*
 * cmd_sweep.c -- `raytraffic sweep`: the paper's experiment as one command.
 *
 * The matrix is scene x mode x lighting x tracer (x scheduled cache size
 * for the dynamic tracer). --modes shadow (the default) is the paper's
 * matrix: the lighting list decides, `primary` being the raycast run;
 * raycast adds the runs without lights (unless `primary` is swept anyway);
 * whitted and path run every lighting with lights and skip `primary`
 * (rt_exp_matrix). Each job renders in-process with its accesses streamed
 * straight into the cache simulator (optionally also into a trace file) and
 * stores one run in the database in one transaction:
 *   - recursive, packet: one run simulated at every size in one pass;
 *   - dynamic: one run per cache size S, scheduled for S and simulated at S
 *     (or at every size with --dynamic-all-sizes, which shows what a
 *     mis-tuned schedule costs).
 * Jobs whose run key is already in the database are skipped, so an
 * interrupted sweep rerun with the same arguments finishes the rest and
 * loses nothing. --jobs N runs the worker pool (results/pool.c): N forked
 * workers claim jobs in order from a shared counter; each keeps the current
 * scene and its k-d tree. This file parses, calls and prints.
 * --approx runs sampled estimators on the same stream and stores each as a
 * run of its own; a hybrid one also stores its standard errors (table
 * traffic_se, " errors=1" in its sim_params) unless --no-error.
 * --list-jobs prints one self-contained command per job, each writing its
 * own database, for GNU parallel or a Slurm array; `raytraffic db merge`
 * joins the shards. Each line names the running binary and every file by
 * its absolute path and quotes every word for a POSIX shell, so it runs
 * from any folder under sh -c.
 *
 * --model lean|paper (results/experiment.h, docs/results.md "Models") sets
 * the defaults of --layout, --queue-stores, --flush and --write-fullline;
 * those given explicitly override it. The model and any non-default
 * accounting go into the exact runs' sim_params ("model=paper
 * policy=wb-wa+flush+fullline"), the layout and queue stores into the
 * tracer parameters, so runs of different models never share a key.
 *
 * Workers never outlive the sweep (pool.h): SIGTERM, SIGINT or SIGHUP to the parent
 * is forwarded to every worker and waited for (the sweep then exits 1; a
 * killed worker's open transaction leaves no row, and a rerun resumes), and
 * a worker whose parent dies without forwarding (SIGKILL) gets SIGTERM from
 * the kernel (PR_SET_PDEATHSIG, Linux).
 */
#include "scene_load.h"
#include "cmd.h"
#include "experiment.h"
#include "hier.h"
#include "mcore.h"
#include "outfile.h"
#include "pool.h"

#include <errno.h>
#include <inttypes.h>
#include <sqlite3.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#define MAX_LIST RT_EXP_MAXLIST

/* The command's options: the experiment (shared with the library) and how
 * to run it. */
typedef struct sweep_opts {
    rt_exp_config x;  /* the experiment */
    const char *preset;
    const char *db;
    int jobs;         /* worker processes */
    int list;         /* --list-jobs */
    long only;        /* --job K, -1 = all */
    long stop_after;  /* RT_SWEEP_STOP_AFTER (tests only), 0 = never */
    long fail_job;    /* RT_SWEEP_FAIL_JOB=K:MARKER (tests only): job K fails once, -1 = never */
    const char *fail_marker; /* file whose creation marks that failure as done */
    int W, H;         /* -W/-H, 0 = from the preset */
    char *lists[7];   /* own copies of --scenes, --tracers, --lights, --approx, --proxy, --modes, --accels */
    const char *sizes_arg;
    const char *mode_opt[2]; /* --depth (whitted only), --spp/--bounces (path only) given: the option's name */
    int geom_given, qs_given; /* --layout / --queue-stores given (they override the model) */
    int flush, fullline;      /* --flush / --write-fullline: -1 = the model's, else 0/1 */
    int no_error;             /* --no-error: hybrid estimators store no standard errors */
    const char *repl_arg, *hier_arg; /* --repl, --hierarchy */
    int line_given;           /* --line given (refused with --hierarchy) */
    rt_hier_config hc;        /* parsed --hierarchy (x.hier points here) */
    rt_mc_config mcc;         /* the multi-core machine (x.mc points here): --hierarchy with --cores or scopes */
    int cores_given;          /* --cores LIST */
    const char *scenes_file;  /* --scenes-file: one spec per line (names may hold commas) */
    char *owned[MAX_LIST];    /* specs made absolute from --scenes-file */
    int strict;               /* --strict: a scene whose loading warned is refused */
} sweep_opts;


static void usage(FILE *f)
{
    fprintf(f,
            "Usage: raytraffic sweep [options]\n\n"
            "Runs scene x lighting x tracer x cache size into a results database.\n\n"
            "Options:\n"
            "  --preset P         quick (default; 256x256) or paper (1024x1024): room, grove,\n"
            "                     sphereflake; lighting primary,0,1,2,all; recursive, packet,\n"
            "                     dynamic; sizes 1K-4M; cpu or gpu: quick behind a hierarchy,\n"
            "                     L1=32K/8/64/lru,L2=1M/16/64/lru,LLC=1K-4M/full/64/lru or\n"
            "                     L1=128K/4/128/lru,L2=1M+2M+4M+6M/16/128/lru\n"
            "  --scenes LIST      comma list of scene specs (overrides the preset)\n"
            "  --scenes-file FILE  the scene specs one per line instead (a name may hold\n"
            "                     commas; blank lines and lines starting with # skipped; a\n"
            "                     relative mesh path is relative to FILE's folder)\n"
            "  --scene SPEC       the same as --scenes with one spec\n"
            "  --strict           refuse a scene whose loading warned (every scene's\n"
            "                     warnings are printed once, before the first job)\n"
            "  --tracers LIST     comma list of tracers\n"
            "  --lights LIST      comma list of lightings: primary, 0, 1, 2, all (with\n"
            "                     --light-samples N: the file's lights 0..31, all = every one)\n"
            "  --light-samples N  the scene files' own lights, N shadow rays per hit to area and\n"
            "                     infinite lights (see render --help)\n"
            "  --modes LIST       comma list of render modes: raycast, shadow (default: the\n"
            "                     lighting list as it is, primary = raycast), whitted, path\n"
            "                     (these two run the lightings with lights, primary skipped)\n");
    rt_cmd_render_help_line(f, "--depth");
    fprintf(f,
            "  --sizes LIST       cache sizes: 1K-4M (powers of two) or 1K,64K,...\n"
            "  --line N           line size in bytes (default 64)\n"
            "  --repl P           replacement policy (default lru; docs/cachesim.md)\n"
            "  --hierarchy SPEC   simulate through cache levels, e.g.\n"
            "                     L1=32K/8/64/lru,LLC=1K-4M/full/64/lru (instead of\n"
            "                     --sizes/--line/--repl; no --approx); runs keep the spec\n");
    rt_cmd_render_help_line(f, "--width");
    fprintf(f,
            "  --db FILE          results database (default raytraffic.db)\n"
            "  --jobs N           worker processes (default 1)\n"
            "  --cores LIST       simulated core counts swept, e.g. 1,2,4,8,16,32,64 (tracers\n"
            "                     that split their work); with --hierarchy (or --preset\n"
            "                     cpu/gpu): the multi-core machine, each core with the\n"
            "                     private levels above the shared ones (a level ending\n"
            "                     /private or /shared; without: the last shared, the first\n"
            "                     private, a middle one as the one above); without: the\n"
            "                     cores' interleaved stream in the one cache\n"
            "  --keep-traces DIR  also write every job's trace to DIR\n"
            "  --dynamic-all-sizes  simulate each dynamic schedule at every size\n"
            "  --approx LIST      also run approximate simulators on the same access stream\n"
            "                     and store them beside the exact runs: comma list of\n"
            "                     shards:RATE[:EXACT_BELOW], shards-fixed:SMAX[:EXACT_BELOW],\n"
            "                     statstack:RATE[:EXACT_BELOW], hybrid[:RATE[:WINDOW_BELOW[:PERIOD]]]\n"
            "                     (rates as 0.01 or 1/64; see report --speed-error); hybrid\n"
            "                     runs also store each size's standard error (traffic_se)\n"
            "  --no-error         hybrid: no standard errors (about 2.4x less CPU in the\n"
            "                     estimator; a separate run key, sim_params without errors=1)\n"
            "  --proxy LIST       also run reduced experiments of every job (exact simulation,\n"
            "                     compared with the full run by report --speed-error): comma\n"
            "                     list of res:N (N pixels wide, same aspect) and sub:K[:T]\n"
            "                     (trace 1 in K tiles of TxT pixels, T default 8)\n");
    rt_cmd_render_help_line(f, "--qorder");
    rt_cmd_render_help_line(f, "--treelet-tris");
    fprintf(f,
            "  --model M          lean (default: compact layout, write-allocate queue stores,\n"
            "                     no flush, no full-line rule) or paper (pbrt layout; Dinero\n"
            "                     IV's printed accounting: flush + full-line writes); sets the\n"
            "                     defaults of:\n");
    rt_cmd_render_help_line(f, "--layout");
    rt_cmd_render_help_line(f, "--queue-stores");
    fprintf(f,
            "  --flush, --no-flush  write back the dirty lines at the end (Dinero IV)\n"
            "  --write-fullline, --no-write-fullline  a write miss covering its line fetches\n"
            "                     nothing (Dinero IV)\n");
    rt_cmd_render_help_line(f, "--look-at");
    rt_cmd_render_help_line(f, "--accel");
    fprintf(f,
            "  --accels LIST      sweep structures too: comma list of kd, bvh2, bvh4, bvh8,\n"
            "                     grid, naive; each tracer runs on those of the list it can\n"
            "                     (its default structure keeps the run key of a plain run)\n"
            "  --list-jobs        print one self-contained command per job and exit\n"
            "  --job K            run only job K (0-based) of the matrix\n");
    rt_cmd_render_help_rest(f, RT_OC_SWEEP); /* table options without a place above */
    fprintf(f,
            "  -h, --help         this help\n\n"
            "Jobs of the stream and feedback tracers also simulate the texture cache of\n"
            "Purcell et al. 2002 (65520 B, 48-byte lines, direct-mapped; report --figure purcell).\n"
            "Rerunning with the same arguments skips finished runs. A progress bar with ETA\n"
            "is drawn on stderr when it is a terminal, else one line per finished run.\n");
}

static int split_list(char *s, char **out, int max)
{
    int n = 0;
    char *save = NULL;
    for (char *t = strtok_r(s, ",", &save); t; t = strtok_r(NULL, ",", &save)) {
        if (n == max) return -1;
        out[n++] = t;
    }
    return n;
}

static int parse_lightings(char *s, sweep_opts *o)
{
    char *items[MAX_LIST];
    int n = split_list(s, items, MAX_LIST);
    if (n <= 0) return -1;
    for (int i = 0; i < n; i++) {
        rt_exp_lighting *l = &o->x.lightings[i];
        if (!strcmp(items[i], "primary") || !strcmp(items[i], "none")) {
            l->label = "primary";
            l->mask = 0;
        } else if (!strcmp(items[i], "all")) {
            l->label = "all";
            l->mask = 7;
        } else if (!strchr(items[i], ',') && rt_parse_lights(items[i], &l->mask) == 0 && l->mask) {
            l->label = items[i]; /* one light, "0", or several, "0+1" (rt_exp_lights_name) */
        } else {
            return -1;
        }
    }
    o->x.nlightings = n;
    return 0;
}

/* --modes into x.modes (default: shadow alone, the paper's matrix); the
 * mode options must have a mode they apply to. 0 or -1 (printed). */
static int parse_modes(sweep_opts *o)
{
    char *items[MAX_LIST];
    int n = o->lists[5] ? split_list(o->lists[5], items, MAX_LIST) : 0, has[RT_MODE_PATH + 1] = {0};
    if (o->lists[5] && (n <= 0 || n > RT_EXP_MAXMODES)) {
        rt_cmd_error("sweep", "--modes: expected a comma list of raycast, shadow, whitted, path");
        return -1;
    }
    for (int i = 0; i < n; i++) {
        int m = rt_render_mode_from_name(items[i]);
        if (m < 0) {
            rt_cmd_error("sweep", "--modes: '%s' is not raycast, shadow, whitted or path", items[i]);
            return -1;
        }
        if (has[m]++) {
            rt_cmd_error("sweep", "--modes: '%s' given twice", items[i]);
            return -1;
        }
        o->x.modes[i] = m;
    }
    o->x.nmodes = n;
    if (!n) has[RT_MODE_SHADOW] = 1;
    int whitted = has[RT_MODE_WHITTED], path = has[RT_MODE_PATH];
    if ((o->mode_opt[0] && !whitted) || (o->mode_opt[1] && !path)) {
        const char *opt = o->mode_opt[0] && !whitted ? o->mode_opt[0] : o->mode_opt[1];
        rt_cmd_error("sweep", "%s does not apply: --modes has no %s mode", opt, opt == o->mode_opt[0] ? "whitted" : "path");
        return -1;
    }
    if (whitted || path) {
        int lit = 0;
        for (int l = 0; l < o->x.nlightings; l++) lit |= o->x.lightings[l].mask != 0;
        if (!lit) {
            rt_cmd_error("sweep", "--modes %s: --lights has only primary; whitted and path need a lighting with lights",
                         whitted ? "whitted" : "path");
            return -1;
        }
    }
    return 0;
}

static int parse_approx(char *s, sweep_opts *o, rt_err *e)
{
    char *items[MAX_LIST];
    int n = split_list(s, items, MAX_LIST);
    if (n <= 0 || n > RT_EXP_MAXAPPROX) return rt_errf(e, "--approx: expected 1 to 8 comma-separated methods");
    for (int i = 0; i < n; i++) {
        rt_approx_config *ac = &o->x.approx[i];
        rt_approx_config_default(ac);
        char *save = NULL, *m = strtok_r(items[i], ":", &save), *p = strtok_r(NULL, ":", &save),
             *x = strtok_r(NULL, ":", &save), *y = strtok_r(NULL, ":", &save);
        int method = m ? rt_approx_method_from_name(m) : -1;
        if (method <= 0 || (!p && method != RT_APPROX_HYBRID))
            return rt_errf(e, "--approx: '%s' is not shards:RATE, shards-fixed:SMAX, statstack:RATE or hybrid[:RATE]",
                           m ? m : "");
        ac->method = method;
        ac->rate = rt_approx_default_rate(method);
        if (method == RT_APPROX_SHARDS_FIXED) {
            uint64_t v;
            if (rt_parse_size(p, &v) < 0) return rt_errf(e, "--approx: bad sample size '%s'", p);
            ac->smax = v;
        } else if (p && rt_cmd_parse_rate(p, &ac->rate) < 0) {
            return rt_errf(e, "--approx: bad rate '%s' (a number in (0, 1] or 1/N)", p);
        }
        /* third field: exact-below, or for hybrid the window-below size */
        uint64_t *third = method == RT_APPROX_HYBRID ? &ac->window_below : &ac->exact_below;
        if (x && rt_parse_size(x, third) < 0) return rt_errf(e, "--approx: bad size '%s'", x);
        /* fourth field, hybrid only: the window period */
        if (y && (method != RT_APPROX_HYBRID || rt_parse_size(y, &ac->period) < 0))
            return rt_errf(e, "--approx: bad fourth field '%s' (hybrid:RATE:WINDOW_BELOW:PERIOD)", y);
        rt_sim_config dc;
        rt_sim_config_default(&dc);
        if (rt_approx_config_check(&dc, ac, e) < 0) return -1;
    }
    o->x.napprox = n;
    return 0;
}

static int parse_proxies(char *s, sweep_opts *o, rt_err *e)
{
    char *items[RT_EXP_MAXPROXY];
    int n = split_list(s, items, RT_EXP_MAXPROXY);
    if (n <= 0) return rt_errf(e, "--proxy: expected 1 to 8 comma-separated items res:N or sub:K[:T]");
    for (int i = 0; i < n; i++) {
        rt_exp_proxy *p = &o->x.proxies[i];
        memset(p, 0, sizeof *p);
        p->subsample = 1;
        p->subtile = 8;
        if (!strncmp(items[i], "res:", 4)) {
            long v;
            if (rt_cmd_parse_long(items[i] + 4, 8, 65536, &v) < 0)
                return rt_errf(e, "--proxy: '%s': res:N needs N in 8..65536", items[i]);
            p->W = (int)v;
        } else if (!strncmp(items[i], "sub:", 4)) {
            char num[32], *colon;
            long k, t = 8;
            snprintf(num, sizeof num, "%s", items[i] + 4);
            if ((colon = strchr(num, ':'))) *colon = 0;
            if (strlen(items[i] + 4) >= sizeof num || rt_cmd_parse_long(num, 2, 1L << 20, &k) < 0 ||
                (colon && rt_cmd_parse_long(colon + 1, 1, 4096, &t) < 0))
                return rt_errf(e, "--proxy: '%s': sub:K[:T] needs K in 2..1048576 and T in 1..4096", items[i]);
            p->subsample = (uint32_t)k;
            p->subtile = (int)t;
        } else {
            return rt_errf(e, "--proxy: '%s' is not res:N or sub:K[:T]", items[i]);
        }
    }
    o->x.nproxies = n;
    return 0;
}

/* The pool's reports (results/pool.h): a line per job when stderr is not
 * a terminal, a progress bar when it is, a failed job's message. */
static void on_job_done(void *ctx, long d, long total, const char *label, int stored, double sec)
{
    (void)ctx;
    fprintf(stderr, "[%ld/%ld] %s: %s (%.1f s)\n", d, total, label, stored ? "done" : "already in database", sec);
}

/* --accels into x.accels: known names, none twice, each run by some
 * tracer of the sweep; not with --accel. 0 or -1 (printed). */
static int parse_accels(sweep_opts *o, const rt_tracer *const *trs)
{
    rt_exp_config *x = &o->x;
    char *items[MAX_LIST];
    if (!o->lists[6]) return 0;
    if (rt_render_opt_given(&x->ro, rt_render_opt_find("--accel"))) {
        rt_cmd_error("sweep", "--accel and --accels together: give the structures in --accels");
        return -1;
    }
    int n = split_list(o->lists[6], items, MAX_LIST);
    if (n <= 0 || n > RT_ACCEL_NKINDS) {
        rt_cmd_error("sweep", "--accels: expected a comma list of %s", rt_accel_names());
        return -1;
    }
    for (int i = 0; i < n; i++) {
        int k = rt_accel_from_name(items[i]), used = 0;
        if (k <= 0) {
            rt_cmd_error("sweep", "--accels: unknown structure '%s' (%s)", items[i], rt_accel_names());
            return -1;
        }
        for (int j = 0; j < i; j++)
            if (x->accels[j] == k) {
                rt_cmd_error("sweep", "--accels: '%s' given twice", items[i]);
                return -1;
            }
        for (int t = 0; t < x->ntracers; t++) used |= (trs[t]->accels & RT_ACCEL_BIT(k)) != 0;
        if (!used) {
            rt_cmd_error("sweep", "--accels: no tracer of the sweep runs on %s", items[i]);
            return -1;
        }
        x->accels[i] = k;
    }
    x->naccels = n;
    return 0;
}

static void on_job_failed(void *ctx, long i, const char *label, const rt_err *e)
{
    (void)ctx;
    if (i >= 0) rt_cmd_error("sweep", "job %ld (%s): %s", i, label, e->msg);
    else rt_cmd_error("sweep", "%s", e->msg);
}

static void on_progress(void *ctx, long d, long s, long nj, double t0)
{
    (void)ctx;
    double el = rt_now() - t0;
    double rate = d > s ? el / (double)(d - s) : 0;
    double eta = rate * (double)(nj - d);
    int width = 30, fill = nj ? (int)(width * d / nj) : width;
    fprintf(stderr, "\r[%.*s%*s] %ld/%ld runs, %.0f s elapsed, ETA %.0f s ", fill,
            "##############################", width - fill, "", d, nj, el, d > s ? eta : 0.0);
}

enum { O_PRESET = 1, O_SCENES, O_TRACERS, O_LIGHTS, O_SIZES, O_LINE, O_DB, O_JOBS, O_KEEP, O_DYNALL, O_LIST, O_JOB,
       O_APPROX, O_PROXY, O_MODES, O_MODEL, O_FLUSH, O_NOFLUSH, O_FULLLINE, O_NOFULLLINE, O_ACCELS, O_NOERR,
       O_SCENES_FILE, O_REPL, O_HIER, O_STRICT, O_CORES };

/* The command's own options; the table's render options for sweep follow
 * them in sweep_longopts (--lights is its own, a list of lightings). */
static const struct option sweep_own[] = {
    {"preset", required_argument, NULL, O_PRESET},
    {"scenes", required_argument, NULL, O_SCENES},
    {"scene", required_argument, NULL, O_SCENES}, /* one scene: the same list */
    {"strict", no_argument, NULL, O_STRICT},
    {"scenes-file", required_argument, NULL, O_SCENES_FILE},
    {"tracers", required_argument, NULL, O_TRACERS},
    {"lights", required_argument, NULL, O_LIGHTS},
    {"sizes", required_argument, NULL, O_SIZES},
    {"line", required_argument, NULL, O_LINE},
    {"repl", required_argument, NULL, O_REPL},
    {"hierarchy", required_argument, NULL, O_HIER},
    {"cores", required_argument, NULL, O_CORES}, /* a list here (render's --cores is one count) */
    {"db", required_argument, NULL, O_DB},
    {"jobs", required_argument, NULL, O_JOBS},
    {"keep-traces", required_argument, NULL, O_KEEP},
    {"dynamic-all-sizes", no_argument, NULL, O_DYNALL},
    {"list-jobs", no_argument, NULL, O_LIST},
    {"job", required_argument, NULL, O_JOB},
    {"approx", required_argument, NULL, O_APPROX},
    {"no-error", no_argument, NULL, O_NOERR},
    {"proxy", required_argument, NULL, O_PROXY},
    {"modes", required_argument, NULL, O_MODES},
    {"accels", required_argument, NULL, O_ACCELS},
    {"model", required_argument, NULL, O_MODEL},
    {"flush", no_argument, NULL, O_FLUSH},
    {"no-flush", no_argument, NULL, O_NOFLUSH},
    {"write-fullline", no_argument, NULL, O_FULLLINE},
    {"no-write-fullline", no_argument, NULL, O_NOFULLLINE},
    {"help", no_argument, NULL, 'h'},
    {NULL, 0, NULL, 0},
};

/* sweep_own and the table's entries for sweep, built once. */
static struct option *sweep_longopts;

/* The first word sh_quote met with a control character (a newline there
 * would end a job line early), or NULL. */
static const char *bad_word;
static char bad_buf[256];

/* Writes s as one word for a POSIX shell: in single quotes, a quote as '\''.
 * A control character cannot be quoted this way (a newline ends the line
 * when the list is run line by line): noted in bad_word, and print_jobs
 * then prints nothing. */
static void sh_quote(FILE *f, const char *s)
{
    fputc('\'', f);
    for (const char *p = s; *p; p++) {
        if ((unsigned char)*p < 0x20 || *p == 0x7f) {
            if (!bad_word) bad_word = rt_esc(bad_buf, sizeof bad_buf, s, 4096);
        }
        if (*p == '\'') fputs("'\\''", f);
        else fputc(*p, f);
    }
    fputc('\'', f);
}

/* An absolute form of path: itself if absolute, its realpath if it exists,
 * else the current folder joined to it. Into buf (n bytes). */
static const char *absolute(const char *path, char *buf, size_t n)
{
    char cwd[4096], *r;
    if (path[0] == '/') snprintf(buf, n, "%s", path);
    else if ((r = realpath(path, NULL))) {
        snprintf(buf, n, "%s", r);
        free(r);
    } else if (getcwd(cwd, sizeof cwd)) snprintf(buf, n, "%s/%s", cwd, path);
    else snprintf(buf, n, "%s", path);
    return buf;
}

/* A scene spec that names a mesh file (as rt_scene_load decides). */
static int is_mesh(const char *s)
{
    size_t n = strlen(s);
    return (n >= 4 && (!strcasecmp(s + n - 4, ".obj") || !strcasecmp(s + n - 4, ".ply"))) ||
           (n >= 5 && !strcasecmp(s + n - 5, ".pbrt"));
}

/* The options of this sweep as words of a command line, each quoted, with
 * every file absolute; --db, --jobs, --job and --list-jobs left out. argv
 * is parsed again (getopt_long) so abbreviations and --opt=value forms are
 * all caught. Written to f with a leading space per word. */
static void print_words(FILE *f, int argc, char **argv)
{
    char buf[8192];
    int c, idx;
    optind = 1;
    opterr = 0;
    while ((c = getopt_long(argc, argv, "hW:H:", sweep_longopts, &idx)) != -1) {
        if (c == O_DB || c == O_JOBS || c == O_JOB || c == O_LIST || c == '?') continue;
        const char *name = NULL;
        for (int k = 0; sweep_longopts[k].name; k++)
            if (sweep_longopts[k].val == c) {
                name = sweep_longopts[k].name;
                break;
            }
        if (c == 'W' || c == 'H') {
            fprintf(f, " -%c", c);
        } else {
            snprintf(buf, sizeof buf, "--%s", name ? name : "?");
            fputc(' ', f);
            sh_quote(f, buf);
        }
        if (!optarg) continue;
        fputc(' ', f);
        if (c == O_KEEP || c == O_SCENES_FILE) {
            sh_quote(f, absolute(optarg, buf, sizeof buf));
        } else if (c == O_SCENES) { /* each mesh of the list made absolute */
            char *list = strdup(optarg), *save = NULL, out[8192] = "", one[4096];
            for (char *t = list ? strtok_r(list, ",", &save) : NULL; t; t = strtok_r(NULL, ",", &save)) {
                size_t l = strlen(out);
                snprintf(out + l, sizeof out - l, "%s%s", l ? "," : "", is_mesh(t) ? absolute(t, one, sizeof one) : t);
            }
            sh_quote(f, list ? out : optarg);
            free(list);
        } else {
            sh_quote(f, optarg);
        }
    }
}

/* Prints the job lines, all or nothing: 0, or -1 (printed) when a word
 * (the binary's path, the working folder in a made-absolute path) holds a
 * control character. */
static int print_jobs(const sweep_opts *o, long nj, int argc, char **argv)
{
    char exe[4096], base[4096], word[4200];
    char *mem = NULL;
    size_t memlen = 0;
    FILE *out = open_memstream(&mem, &memlen);
    if (!out) {
        rt_cmd_error("sweep", "--list-jobs: %s", strerror(errno));
        return -1;
    }
    bad_word = NULL;
    ssize_t n = readlink("/proc/self/exe", exe, sizeof exe - 1);
    if (n > 0) exe[n] = 0;
    else snprintf(exe, sizeof exe, "raytraffic"); /* no /proc: PATH decides */
    absolute(o->db, base, sizeof base);
    size_t bl = strlen(base);
    if (bl > 3 && !strcmp(base + bl - 3, ".db")) base[bl - 3] = 0;
    for (long i = 0; i < nj; i++) {
        sh_quote(out, exe);
        fputs(" sweep", out);
        print_words(out, argc, argv);
        snprintf(word, sizeof word, "%s.job%04ld.db", base, i);
        fprintf(out, " --job %ld --db ", i);
        sh_quote(out, word);
        fputc('\n', out);
    }
    int bad = fclose(out) != 0;
    if (!bad && bad_word)
        rt_cmd_error("sweep", "--list-jobs: '%s' contains a control character; a job line cannot hold it", bad_word);
    else if (bad)
        rt_cmd_error("sweep", "--list-jobs: out of memory");
    else /* line by line, so a failing stdout keeps its reason for close_stdout */
        for (char *p = mem, *q; p < mem + memlen; p = q + 1) {
            q = memchr(p, '\n', (size_t)(mem + memlen - p));
            if (!q) q = mem + memlen;
            fwrite(p, 1, (size_t)(q - p) + (q < mem + memlen), stdout);
        }
    free(mem);
    return bad || bad_word ? -1 : 0;
}


/* Keeps a copy of a list argument (lists are split in place, and argv is
 * reprinted by --list-jobs). */
static char *keep_copy(sweep_opts *o, int k, const char *arg)
{
    free(o->lists[k]);
    return o->lists[k] = strdup(arg);
}

/* Handles one option. 0 ok, 1 = --help, -1 usage error (printed). */
static int parse_opt(sweep_opts *o, int c, const char *arg)
{
    rt_err e = {0};
    const char *dummy = NULL;
    long v;
    int id = rt_cmd_opt_index(c);
    const char *name = id >= 0 ? rt_render_opt_name(id) : "";
    if (!strcmp(name, "--width") || !strcmp(name, "--height")) {
        rt_render_opts tmp = o->x.ro;
        if (rt_cmd_render_opt("sweep", c, arg, &tmp, &dummy) < 0) return -1;
        if (name[2] == 'w') o->W = tmp.W; else o->H = tmp.H;
        return 0;
    }
    if (!strcmp(name, "--depth")) o->mode_opt[0] = "--depth";
    if (!strcmp(name, "--spp") || !strcmp(name, "--bounces")) o->mode_opt[1] = name;
    if (!strcmp(name, "--layout")) o->geom_given = 1;
    if (!strcmp(name, "--queue-stores")) o->qs_given = 1;
    int r = rt_cmd_render_opt("sweep", c, arg, &o->x.ro, &dummy);
    if (r != 0) return r < 0 ? -1 : 0;
    switch (c) {
    case O_PRESET:
        if (strcmp(arg, "quick") && strcmp(arg, "paper") && strcmp(arg, "cpu") && strcmp(arg, "gpu")) {
            rt_cmd_error("sweep", "--preset: '%s' is not quick, paper, cpu or gpu", arg);
            return -1;
        }
        o->preset = arg;
        return 0;
    case O_SCENES:
        if (rt_cmd_check_text("sweep", "--scenes", arg) < 0) return -1;
        return keep_copy(o, 0, arg) ? 0 : -1;
    case O_STRICT: o->strict = 1; return 0;
    case O_SCENES_FILE:
        if (rt_cmd_check_text("sweep", "--scenes-file", arg) < 0) return -1;
        o->scenes_file = arg;
        return 0;
    case O_TRACERS: return keep_copy(o, 1, arg) ? 0 : -1;
    case O_LIGHTS: return keep_copy(o, 2, arg) ? 0 : -1;
    case O_MODES: return keep_copy(o, 5, arg) ? 0 : -1;
    case O_ACCELS: return keep_copy(o, 6, arg) ? 0 : -1;
    case O_SIZES: o->sizes_arg = arg; return 0;
    case O_MODEL:
        if ((o->x.model = rt_exp_model_find(arg)) < 0) {
            rt_cmd_error("sweep", "--model: '%s' is not lean or paper", arg);
            return -1;
        }
        return 0;
    case O_FLUSH:
    case O_NOFLUSH: o->flush = c == O_FLUSH; return 0;
    case O_FULLLINE:
    case O_NOFULLLINE: o->fullline = c == O_FULLLINE; return 0;
    case O_LINE: o->line_given = 1; return rt_cmd_parse_line("sweep", arg, &o->x.sim.line);
    case O_REPL: o->repl_arg = arg; return 0;
    case O_HIER: o->hier_arg = arg; return 0;
    case O_CORES: {
        char buf[512];
        int n = 0;
        snprintf(buf, sizeof buf, "%s", arg);
        for (char *save = NULL, *t = strtok_r(buf, ",", &save); t; t = strtok_r(NULL, ",", &save)) {
            if (n == RT_EXP_MAXLIST || rt_cmd_parse_long(t, 1, RT_TR_MAX_CORES, &v) < 0) {
                rt_cmd_error("sweep", "--cores: '%s' is not a comma list of at most %d counts in 1..%d", arg,
                             RT_EXP_MAXLIST, RT_TR_MAX_CORES);
                return -1;
            }
            for (int k = 0; k < n; k++)
                if (o->x.cores[k] == v) {
                    rt_cmd_error("sweep", "--cores: %ld repeats", v);
                    return -1;
                }
            o->x.cores[n++] = (int)v;
        }
        if (!n || strlen(arg) >= sizeof buf) {
            rt_cmd_error("sweep", "--cores: '%s' is not a comma list of counts", arg);
            return -1;
        }
        o->x.ncores = n;
        o->cores_given = 1;
        return 0;
    }
    case O_DB: {
        rt_err ne = {0};
        if (rt_cmd_check_text("sweep", "--db", arg) < 0) return -1;
        if (rt_open_target(arg, RT_TARGET_DB, &ne) < 0 && ne.usage) { /* the name; the file is checked at the start */
            rt_cmd_error("sweep", "--db: %s", ne.msg);
            return -1;
        }
        o->db = arg;
        return 0;
    }
    case O_JOBS:
        if (rt_cmd_parse_long(arg, 1, 256, &v) < 0) {
            rt_cmd_error("sweep", "--jobs: '%s' is not in 1..256", arg);
            return -1;
        }
        o->jobs = (int)v;
        return 0;
    case O_KEEP:
        if (rt_cmd_check_text("sweep", "--keep-traces", arg) < 0) return -1;
        o->x.keep = arg;
        return 0;
    case O_DYNALL: o->x.dyn_all = 1; return 0;
    case O_NOERR: o->no_error = 1; return 0;
    case O_LIST: o->list = 1; return 0;
    case O_JOB:
        if (rt_cmd_parse_long(arg, 0, 1L << 30, &o->only) < 0) {
            rt_cmd_error("sweep", "--job: '%s' is not a job index", arg);
            return -1;
        }
        return 0;
    case O_APPROX:
    case O_PROXY:
        if (!keep_copy(o, c == O_APPROX ? 3 : 4, arg)) return -1;
        if ((c == O_APPROX ? parse_approx(o->lists[3], o, &e) : parse_proxies(o->lists[4], o, &e)) < 0) {
            rt_cmd_error("sweep", "%s", e.msg);
            return -1;
        }
        return 0;
    case 'h': usage(stdout); return 1;
    default: return -1;
    }
}

/* --scenes-file: the file (a regular one, at most 1 MiB) into lists[0],
 * one spec per line into x.scenes; a relative mesh path is made relative
 * to the file's folder. 0 or -1 (printed, FILE:LINE). */
static int read_scenes_file(sweep_opts *o)
{
    rt_exp_config *x = &o->x;
    const char *path = o->scenes_file;
    struct stat sb;
    FILE *f = fopen(path, "r");
    if (!f || fstat(fileno(f), &sb) < 0 || !S_ISREG(sb.st_mode) || sb.st_size > (1 << 20)) {
        rt_cmd_error("sweep", "--scenes-file: %s: %s", path,
                     !f ? strerror(errno) : !S_ISREG(sb.st_mode) ? "not a regular file" : "larger than 1 MiB");
        if (f) fclose(f);
        return -1;
    }
    char *buf = calloc((size_t)sb.st_size + 1, 1);
    size_t n = buf ? fread(buf, 1, (size_t)sb.st_size, f) : 0;
    int bad = !buf || ferror(f);
    fclose(f);
    free(o->lists[0]);
    o->lists[0] = buf;
    if (bad) {
        rt_cmd_error("sweep", "--scenes-file: %s: read error", path);
        return -1;
    }
    buf[n] = 0;
    if (memchr(buf, 0, n)) {
        rt_cmd_error("sweep", "--scenes-file: %s: a NUL byte (not a text file)", path);
        return -1;
    }
    const char *slash = strrchr(path, '/');
    int dirlen = slash ? (int)(slash - path) : 0;
    x->nscenes = 0;
    long line = 0;
    for (char *p = buf, *next; p && *p; p = next) {
        line++;
        char *nl = strchr(p, '\n');
        next = nl ? nl + 1 : NULL;
        if (nl) *nl = 0;
        if (nl > p && nl[-1] == '\r') nl[-1] = 0;
        if (!*p || *p == '#') continue;
        char where[64];
        snprintf(where, sizeof where, "%s:%ld", slash ? slash + 1 : path, line);
        if (rt_cmd_check_text("sweep", where, p) < 0) return -1;
        if (x->nscenes == MAX_LIST) {
            rt_cmd_error("sweep", "--scenes-file: %s:%ld: more than %d scenes", path, line, MAX_LIST);
            return -1;
        }
        if (is_mesh(p) && p[0] != '/' && slash) { /* relative to the file's folder */
            size_t l = (size_t)dirlen + 1 + strlen(p) + 1;
            char *abs = malloc(l);
            if (!abs) {
                rt_cmd_error("sweep", "out of memory");
                return -1;
            }
            snprintf(abs, l, "%.*s/%s", dirlen, path, p);
            o->owned[x->nscenes] = abs;
            p = abs;
        }
        x->scenes[x->nscenes++] = p;
    }
    if (!x->nscenes) {
        rt_cmd_error("sweep", "--scenes-file: %s: no scene", path);
        return -1;
    }
    return 0;
}

/* Fills in what the options left to the preset and checks the lists.
 * 0 or -1 (usage error, printed). */
static int finish_opts(sweep_opts *o)
{
    rt_exp_config *x = &o->x;
    rt_err e = {0};
    static char defscenes[] = "room,grove,sphereflake", deftracers[] = "recursive,packet,dynamic",
                deflights[] = "primary,0,1,2,all";
    int paper = !strcmp(o->preset, "paper");
    x->ro.W = o->W ? o->W : (paper ? 1024 : 256);
    x->ro.H = o->H ? o->H : (paper ? 1024 : 256);
    x->ro.film = (o->W ? 0 : RT_FILM_W) | (o->H ? 0 : RT_FILM_H); /* a .pbrt scene's Film */
    /* the defaults are split in place: copies, so a second sweep in one
     * process (tests) sees them whole */
    if (o->scenes_file && o->lists[0]) {
        rt_cmd_error("sweep", "--scenes and --scenes-file: give one");
        return -1;
    }
    if (o->scenes_file && read_scenes_file(o) < 0) return -1;
    char *sc = o->lists[0] ? o->lists[0] : keep_copy(o, 0, defscenes);
    char *tr = o->lists[1] ? o->lists[1] : keep_copy(o, 1, deftracers);
    char *li = o->lists[2] ? o->lists[2] : keep_copy(o, 2, deflights);
    if (!sc || !tr || !li) {
        rt_cmd_error("sweep", "out of memory");
        return -1;
    }
    if (!o->scenes_file && (x->nscenes = split_list(sc, x->scenes, MAX_LIST)) <= 0) {
        rt_cmd_error("sweep", "--scenes: empty or too long list");
        return -1;
    }
    if ((x->ntracers = split_list(tr, x->tracers, MAX_LIST)) <= 0) {
        rt_cmd_error("sweep", "--tracers: empty or too long list");
        return -1;
    }
    for (int t = 0; t < x->ntracers; t++)
        if (!rt_tracer_find(x->tracers[t])) {
            rt_cmd_error("sweep", "--tracers: unknown tracer '%s' (%s)", x->tracers[t], rt_tracer_names());
            return -1;
        }
    /* options of one tracer are an error when no tracer swept reads them */
    const rt_tracer *trs[MAX_LIST];
    int has_sched = 0, has_all = 0;
    for (int t = 0; t < x->ntracers; t++) {
        trs[t] = rt_tracer_find(x->tracers[t]);
        has_sched |= rt_tracer_is(trs[t], RT_TR_SCHEDULED);
        has_all |= !rt_tracer_is(trs[t], RT_TR_SCHEDULED);
    }
    if (parse_accels(o, trs) < 0) return -1;
    if (rt_tracer_check_given_any(trs, x->ntracers, &x->ro, &e) < 0) {
        rt_cmd_error("sweep", "%s", e.msg);
        return -1;
    }
    if (!has_sched && x->dyn_all) {
        rt_cmd_error("sweep", "--dynamic-all-sizes does not apply: --tracers has no scheduled tracer");
        return -1;
    }
    /* the model's defaults, then the options given explicitly */
    rt_render_opts given = x->ro;
    rt_exp_model_apply(rt_exp_model_get(x->model), &x->ro, &x->sim);
    if (o->geom_given) x->ro.geom = given.geom;
    if (o->qs_given) x->ro.qstores = given.qstores;
    if (o->flush >= 0) x->sim.flush = o->flush;
    if (o->fullline >= 0) x->sim.write_miss_fullline = o->fullline;
    if (x->napprox && (x->model != RT_EXP_MODEL_LEAN || x->sim.flush || x->sim.write_miss_fullline)) {
        rt_cmd_error("sweep", "--approx does not apply: the sampled methods support neither --model paper nor the "
                              "flush or full-line rule");
        return -1;
    }
    /* the hybrid's standard errors: stored unless --no-error */
    int hybrid = 0;
    for (int a = 0; a < x->napprox; a++)
        if (x->approx[a].method == RT_APPROX_HYBRID) {
            x->approx[a].errors = !o->no_error;
            hybrid = 1;
        }
    if (o->no_error && !hybrid) {
        rt_cmd_error("sweep", "--no-error does not apply: --approx has no hybrid method (the only one with errors)");
        return -1;
    }
    if (x->napprox && !has_all && !x->dyn_all) {
        rt_cmd_error("sweep", "--approx does not apply: it runs on jobs simulated at every size (unscheduled "
                              "tracers, or scheduled ones with --dynamic-all-sizes)");
        return -1;
    }
    for (int p = 0; p < x->nproxies; p++)
        for (int t = 0; t < x->ntracers; t++) {
            rt_render_opts ro = x->ro;
            ro.subsample = x->proxies[p].subsample;
            ro.subtile = x->proxies[p].subtile;
            if (!(trs[t]->accels & RT_ACCEL_BIT(rt_tracer_accel(trs[t], &ro)))) ro.accel = RT_ACCEL_DEFAULT, ro.instances = 0;
            if (rt_tracer_check_opts(trs[t], &ro, &e) < 0) {
                rt_cmd_error("sweep", "--proxy: %s", e.msg);
                return -1;
            }
        }
    if (parse_lightings(li, o) < 0) {
        rt_cmd_error("sweep", "--lights: expected a comma list of primary, 0, 1, 2, all");
        return -1;
    }
    for (int l = 0; l < x->nlightings; l++) { /* with --light, only the lights given exist */
        rt_render_opts t = x->ro;
        t.lights_named = strcmp(x->lightings[l].label, "all") ? x->lightings[l].mask : 0;
        if (rt_render_check_lights(&t, &e) < 0) {
            rt_cmd_error("sweep", "%s", e.msg);
            return -1;
        }
    }
    if (parse_modes(o) < 0) return -1;
    if (o->sizes_arg && rt_sim_parse_sizes(o->sizes_arg, &x->sim, &e) < 0) {
        rt_cmd_error("sweep", "--sizes: %s", e.msg);
        return -1;
    }
    if (o->repl_arg && rt_sim_repl_parse(o->repl_arg, &x->sim.repl, &e) < 0) {
        rt_cmd_error("sweep", "--repl: %s", e.msg);
        return -1;
    }
    /* the hierarchy presets (docs/cachesim.md, "Presets"): the quick sweep
     * behind a CPU-like or a GPU-like hierarchy */
    if (!o->hier_arg && !strcmp(o->preset, "cpu")) o->hier_arg = "L1=32K/8/64/lru,L2=1M/16/64/lru,LLC=1K-4M/full/64/lru";
    if (!o->hier_arg && !strcmp(o->preset, "gpu")) o->hier_arg = "L1=128K/4/128/lru,L2=1M+2M+4M+6M/16/128/lru";
    if (o->hier_arg) { /* the levels give sizes, lines and policies; the last level is the run's sim */
        const char *clash = o->sizes_arg ? "--sizes" : o->line_given ? "--line" : o->repl_arg ? "--repl" : NULL;
        if (clash) {
            rt_cmd_error("sweep", "%s does not apply with --hierarchy (each level gives its own)", clash);
            return -1;
        }
        /* with --cores, or a level marked private or shared: the multi-core
         * machine (cachesim/mcore.h), each job's simulated cores with their
         * private levels above the shared ones */
        if (o->cores_given || strstr(o->hier_arg, "/private") || strstr(o->hier_arg, "/shared")) {
            if (rt_mc_parse_base(o->hier_arg, &x->sim, &o->mcc, &e) < 0) {
                rt_cmd_error("sweep", "%s", e.msg);
                return -1;
            }
            x->sim = o->mcc.h.level[o->mcc.h.nlevels - 1];
            x->mc = &o->mcc;
        } else if (rt_hier_parse(o->hier_arg, &x->sim, &o->hc, &e) < 0) {
            rt_cmd_error("sweep", "--hierarchy: %s", e.msg);
            return -1;
        }
        if (!x->mc) {
            x->sim = o->hc.level[o->hc.nlevels - 1];
            x->hier = &o->hc;
        }
    }
    /* simulated cores: only tracers that split their work (their traits) */
    for (int k = 0; k < x->ncores; k++)
        for (int t = 0; t < x->ntracers && x->cores[k] > 1 && x->mc; t++) {
            const rt_tracer *ct = rt_tracer_find(x->tracers[t]);
            if (ct && !rt_tracer_simulates_cores(ct) && !rt_tracer_is(ct, RT_TR_CORES)) {
                rt_cmd_error("sweep", "--cores %d: the %s tracer's work is not split over cores yet (run it with --cores 1)",
                             x->cores[k], ct->name);
                return -1;
            }
        }
    if ((x->sim.repl || x->hier || x->mc) && x->napprox) {
        rt_cmd_error("sweep", "--approx does not apply with %s (the sampled methods model one LRU level)",
                     x->hier || x->mc ? "--hierarchy" : "--repl");
        return -1;
    }
    if (rt_sim_config_check(&x->sim, &e) < 0) {
        rt_cmd_error("sweep", "%s", e.msg);
        return -1;
    }
    return 0;
}

/* Parses argv into o. 0 ok, 1 = help printed, -1 usage error. */
static int parse_args(int argc, char **argv, sweep_opts *o)
{
    memset(o, 0, sizeof *o);
    o->preset = "quick";
    o->db = "raytraffic.db";
    o->jobs = 1;
    o->only = -1;
    rt_render_default_opts(&o->x.ro);
    rt_sim_config_default(&o->x.sim);
    o->x.command = rt_cmd_line();
    const char *stop = getenv("RT_SWEEP_STOP_AFTER");
    if (stop && *stop && rt_cmd_parse_long(stop, 0, 1L << 30, &o->stop_after) < 0) {
        rt_cmd_error("sweep", "RT_SWEEP_STOP_AFTER: '%s' is not a count", stop);
        return -1;
    }
    o->fail_job = -1;
    o->flush = o->fullline = -1;
    const char *fj = getenv("RT_SWEEP_FAIL_JOB"), *colon = fj ? strchr(fj, ':') : NULL;
    if (fj && *fj) {
        char num[32];
        snprintf(num, sizeof num, "%.*s", colon ? (int)(colon - fj) : 0, fj);
        if (!colon || !colon[1] || rt_cmd_parse_long(num, 0, 1L << 30, &o->fail_job) < 0) {
            rt_cmd_error("sweep", "RT_SWEEP_FAIL_JOB: '%s' is not K:MARKER-FILE", fj);
            return -1;
        }
        o->fail_marker = colon + 1;
    }
    int c;
    optind = 1;
    if (!sweep_longopts && !(sweep_longopts = rt_cmd_longopts(RT_OC_SWEEP, sweep_own))) {
        rt_cmd_error("sweep", "out of memory");
        return -1;
    }
    while ((c = getopt_long(argc, argv, "hW:H:", sweep_longopts, NULL)) != -1) {
        int r = parse_opt(o, c, optarg);
        if (r) return r;
    }
    if (optind != argc) {
        rt_cmd_error("sweep", "unexpected argument '%s'", argv[optind]);
        return -1;
    }
    return finish_opts(o);
}

/* Runs the workers (this process alone, or forked ones) until every job is
 * claimed; draws the progress bar on a terminal. 0 or -1. */
/* Creates the schema once before workers start, and the trace folder. */
static int prepare_outputs(const sweep_opts *o)
{
    rt_err e = {0};
    if (o->x.keep && mkdir(o->x.keep, 0777) < 0 && errno != EEXIST) {
        rt_cmd_error("sweep", "%s: %s", o->x.keep, strerror(errno));
        return -1;
    }
    rt_db *db = rt_db_open(o->db, &e);
    if (!db) {
        rt_cmd_error("sweep", "%s", e.msg);
        return e.usage ? -2 : -1;
    }
    rt_db_close(db);
    return 0;
}

/* Every scene of the sweep (with --job K, only that job's) loads, with the
 * camera and lights of the options applied: before --list-jobs prints a
 * line or a sweep creates its database. Its load warnings are printed here,
 * once per scene (not by each job), and --strict refuses a scene that
 * warned. 0, -1 (a scene that does not load: the loader's FILE:LINE
 * message printed; or warned under --strict) or -2 (the view does not fit
 * the scene: a usage error). */
static int check_scenes(const sweep_opts *o, const rt_exp_job *J)
{
    for (int i = 0; i < o->x.nscenes; i++) {
        if (o->only >= 0 && J[o->only].scene != i) continue;
        rt_err e = {0};
        rt_scene *sc = rt_scene_load(o->x.scenes[i], &e);
        if (sc && rt_render_apply_view(&o->x.ro, sc, &e) < 0) {
            rt_cmd_error("sweep", "%s: %s", o->x.scenes[i], e.msg);
            rt_scene_free(sc);
            return -2;
        }
        if (!sc) {
            /* "a,b.obj" in --scenes is two specs: say where such a name goes */
            int split = !o->scenes_file && o->x.nscenes > 1 && !is_mesh(o->x.scenes[i]);
            rt_cmd_error("sweep", "--scenes: %s%s", e.msg,
                         split ? "; --scenes splits at commas: list a name holding one in --scenes-file" : "");
            return -1;
        }
        rt_cmd_print_warnings("sweep", sc);
        int refused = o->strict && rt_cmd_strict("sweep", sc) < 0;
        rt_scene_free(sc);
        if (refused) return -1;
    }
    return 0;
}

/* The database a failed sweep created and stored nothing in (no run, as
 * SQLite says) is removed with its journal, so a failure leaves no empty
 * results file behind; one that existed before is left as it was. */
static void remove_if_empty(const char *path)
{
    rt_err e = {0};
    rt_db *db = rt_db_open(path, &e);
    sqlite3_stmt *st = NULL;
    int empty = 0;
    if (db && sqlite3_prepare_v2(rt_db_handle(db), "SELECT count(*) FROM runs", -1, &st, NULL) == SQLITE_OK &&
        sqlite3_step(st) == SQLITE_ROW)
        empty = sqlite3_column_int64(st, 0) == 0;
    sqlite3_finalize(st);
    rt_db_close(db);
    if (!empty) return;
    static const char *const suffix[] = {"", "-journal", "-wal", "-shm"};
    char buf[4200];
    for (int k = 0; k < 4; k++) {
        snprintf(buf, sizeof buf, "%s%s", path, suffix[k]);
        unlink(buf);
    }
    fprintf(stderr, "sweep: no run stored: removed the empty %s\n", path);
}

static int sweep_run(sweep_opts *o, const rt_exp_job *J, long nj)
{
    struct stat sb;
    int cs = check_scenes(o, J);
    if (cs < 0) return cs == -2 ? RT_EXIT_USAGE : RT_EXIT_FAIL;
    int existed = lstat(o->db, &sb) == 0;
    int pr = prepare_outputs(o);
    if (pr < 0) return pr == -2 ? RT_EXIT_USAGE : RT_EXIT_FAIL;
    const rt_exp_config *x = &o->x;
    long total = o->only >= 0 ? 1 : nj;
    rt_pool_opts po = {o->db, o->jobs, o->only, isatty(2), o->stop_after, o->fail_job, o->fail_marker,
                       on_job_done, on_job_failed, on_progress, NULL};
    rt_pool_result r;
    rt_err e = {0};
    double t0 = rt_now();
    char nacc[48] = "";
    if (x->naccels) snprintf(nacc, sizeof nacc, " x %d structures", x->naccels);
    fprintf(stderr, "sweep: %ld run(s) (%d scenes x %d lightings x %d tracers%s, %d sizes) at %dx%d into %s, %d worker(s)\n",
            total, x->nscenes, x->nlightings, x->ntracers, nacc, x->sim.nsizes, x->ro.W, x->ro.H, o->db, o->jobs);
    int rc = rt_pool_run(&o->x, J, nj, &po, &r, &e);
    if (po.tty) fputc('\n', stderr);
    if (e.msg[0]) rt_cmd_error("sweep", "%s", e.msg);
    if (r.stop_signal)
        rt_cmd_error("sweep", "stopped by signal %d: workers stopped; rerun the same command to resume", r.stop_signal);
    fprintf(stderr,
            "sweep: %ld run(s) finished (%ld already in the database) in %.1f s wall; results in %s; stages: scene %.1f s, "
            "tracing %.1f s, simulation %.1f s, database %.1f s (summed over workers)\n",
            r.done, r.skipped, rt_now() - t0, o->db, r.stage_sec[0], r.stage_sec[1], r.stage_sec[2], r.stage_sec[3]);
    if ((r.usage || rc < 0) && !existed && r.done == 0) remove_if_empty(o->db);
    if (r.usage) return RT_EXIT_USAGE; /* as render and trace: the options ask too much */
    return rc < 0 ? RT_EXIT_FAIL : RT_EXIT_OK;
}

int main_sweep(int argc, char **argv)
{
    sweep_opts o;
    rt_err e = {0};
    rt_exp_job *J = NULL;
    int rc = parse_args(argc, argv, &o);
    long nj = 0;
    if (rc) {
        rc = rc > 0 ? RT_EXIT_OK : RT_EXIT_USAGE;
    } else if ((nj = rt_exp_matrix(&o.x, &J, &e)) < 0) {
        rt_cmd_error("sweep", "%s", e.msg);
        rc = RT_EXIT_FAIL;
    } else if (o.only >= nj) {
        rt_cmd_error("sweep", "--job %ld: the matrix has %ld jobs (0..%ld)", o.only, nj, nj - 1);
        rc = RT_EXIT_USAGE;
    } else if (o.list) {
        int cs = check_scenes(&o, J);
        rc = cs < 0 ? (cs == -2 ? RT_EXIT_USAGE : RT_EXIT_FAIL) : print_jobs(&o, nj, argc, argv) < 0 ? RT_EXIT_FAIL : RT_EXIT_OK;
    } else {
        rc = sweep_run(&o, J, nj);
    }
    free(J);
    for (int i = 0; i < 7; i++) free(o.lists[i]);
    for (int i = 0; i < MAX_LIST; i++) free(o.owned[i]);
    return rc;
}
