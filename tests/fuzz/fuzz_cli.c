/*
 * fuzz_cli.c -- fuzz target for the command line's shared option parsers
 * (cli/cmd_common.c): rt_cmd_longopts, rt_cmd_render_opt,
 * rt_cmd_parse_long, rt_cmd_parse_rate, rt_cmd_parse_line,
 * rt_cmd_json_str, and the library parsers under them (rt_parse_size,
 * rt_parse_lights, rt_tracer_find).
 *
 * The input is an argv: arguments separated by newlines (so the seeds are
 * readable text), at most 64. getopt_long walks it with the shared table
 * merged into a command's own ({"line"}, {"rate"}, {"help"}, as sim and
 * sweep do), and each option goes to the parser a subcommand would call.
 * No subcommand's main_* runs: they render, simulate and write files. The
 * parsers report bad values through rt_cmd_error, which cli/main.c defines
 * to print; this harness defines it to keep the message instead, so a run
 * prints nothing and can check that every refusal has a message.
 *
 * Contracts checked: a value accepted is in its documented range (-W/-H
 * 1..65536, --packet 1..256, --cores 1..1024, --cache-size >= 64,
 * --gmax >= 1, --subsample 1..2^20 with tile 1..4096, --lights a subset
 * of 0..2, --line 1..1M, a rate in (0, 1]); a refusal leaves the options
 * unchanged and has a message; rt_parse_size agrees with a naive parser;
 * rt_cmd_json_str output is a quoted string without control bytes that
 * unescapes to its input. An argv is "accepted" when no parser refused
 * anything in it.
 */
#include "cmd.h"
#include "fuzz.h"

#include <stdarg.h>

static char last_error[512];
static int nerrors;

void rt_cmd_error(const char *cmd, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(last_error, sizeof last_error, fmt, ap);
    va_end(ap);
    nerrors++;
}

/* Naive rt_parse_size: digits, an optional K/M/G with an optional B. */
static int ref_size(const char *s, uint64_t *out)
{
    uint64_t v = 0;
    const char *p = s;
    if (*p < '0' || *p > '9') return -1;
    for (; *p >= '0' && *p <= '9'; p++) {
        if (v > (UINT64_MAX - (uint64_t)(*p - '0')) / 10) return -1;
        v = v * 10 + (uint64_t)(*p - '0');
    }
    int shift = 0;
    if (*p) {
        const char *u = strchr("kKmMgG", *p);
        if (!u) return -1;
        shift = 10 * (1 + (int)(u - "kKmMgG") / 2);
        p++;
        if (*p == 'b' || *p == 'B') p++;
        if (*p) return -1;
    }
    for (int i = 0; i < shift; i++) {
        if (v > UINT64_MAX / 2) return -1;
        v *= 2;
    }
    *out = v;
    return 0;
}

static void check_json(const char *s)
{
    char *out = NULL;
    size_t n = 0;
    FILE *f = open_memstream(&out, &n);
    if (!f) return;
    rt_cmd_json_str(f, s);
    fclose(f);
    if (n < 2 || out[0] != '"' || out[n - 1] != '"') rt_fuzz_fail("json string not quoted");
    size_t k = 0;
    for (size_t i = 1; i + 1 < n; i++) {
        unsigned char c = (unsigned char)out[i];
        if (c < 0x20) rt_fuzz_fail("raw control byte in a json string");
        if (c == '"') rt_fuzz_fail("unescaped quote in a json string");
        if (c == '\\') {
            if (i + 2 < n && (out[i + 1] == '"' || out[i + 1] == '\\')) c = (unsigned char)out[++i];
            else {
                unsigned u;
                if (i + 6 >= n || out[i + 1] != 'u' || sscanf(out + i + 2, "%4x", &u) != 1 || u >= 0x20)
                    rt_fuzz_fail("bad escape in a json string");
                c = (unsigned char)u;
                i += 5;
            }
        }
        if ((unsigned char)s[k++] != c) rt_fuzz_fail("json string does not unescape to its input");
    }
    if (s[k]) rt_fuzz_fail("json string too short");
    free(out);
}

static void check_opts(const rt_render_opts *o, const char *tracer)
{
    if (o->W < 1 || o->W > 65536 || o->H < 1 || o->H > 65536) rt_fuzz_fail("image size %dx%d", o->W, o->H);
    if (o->packet < 1 || o->packet > 256) rt_fuzz_fail("packet %d", o->packet);
    if (o->threads < 1 || o->threads > 1024) rt_fuzz_fail("threads %d", o->threads);
    if (o->cores < 1 || o->cores > 1024) rt_fuzz_fail("cores %d", o->cores);
    if (o->host_threads < 1 || o->host_threads > 1024) rt_fuzz_fail("host threads %d", o->host_threads);
    if (o->sched_size < 64) rt_fuzz_fail("sched size %llu", (unsigned long long)o->sched_size);
    if (o->subsample < 1 || o->subsample > (1u << 20) || o->subtile < 1 || o->subtile > 4096)
        rt_fuzz_fail("subsample %u:%d", o->subsample, o->subtile);
    /* the lights mask may name any of lights 0..31 (whether they exist is checked at job setup) */
    if (o->light_samples > RT_LIGHT_SAMPLES_MAX) rt_fuzz_fail("light samples %u", (unsigned)o->light_samples);
    if (o->lights_all && o->lights != 7) rt_fuzz_fail("lights all with mask %u", o->lights);
    if (o->qorder != RT_QORDER_FULLEST && o->qorder != RT_QORDER_TREE) rt_fuzz_fail("qorder %d", o->qorder);
    if (!rt_tracer_find(tracer)) rt_fuzz_fail("tracer '%s'", tracer);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    enum { MAXARG = 64 };
    char *text = malloc(size + 1), *argv[MAXARG + 2];
    if (!text) return 0;
    memcpy(text, data, size);
    text[size] = 0;
    int argc = 0;
    argv[argc++] = "fuzz";
    for (char *p = text; argc < MAXARG + 1;) {
        argv[argc++] = p;
        char *nl = strchr(p, '\n');
        if (!nl) break;
        *nl = 0;
        p = nl + 1;
    }
    argv[argc] = NULL;
    /* Each argument alone through the value parsers and the JSON escaper. */
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        uint64_t u = 0, v = 0;
        int rc = rt_parse_size(a, &u), rr = ref_size(a, &v);
        if (rc != rr || (rc == 0 && u != v)) rt_fuzz_fail("rt_parse_size('%s') = %d %llu, naive %d %llu", a, rc,
                                                          (unsigned long long)u, rr, (unsigned long long)v);
        long l;
        if (rt_cmd_parse_long(a, -5, 1000, &l) == 0 && (l < -5 || l > 1000)) rt_fuzz_fail("parse_long %ld", l);
        check_json(a);
    }
    static const struct option own[] = {
        {"line", required_argument, NULL, 'l'},
        {"rate", required_argument, NULL, 'r'},
        {"help", no_argument, NULL, 'h'},
        {NULL, 0, NULL, 0},
    };
    struct option *lo = rt_cmd_longopts(RT_OC_RENDER, own);
    if (!lo) rt_fuzz_fail("rt_cmd_longopts failed");
    size_t nlo = 0, nshared = 0;
    char so[32];
    while (lo[nlo].name) nlo++;
    for (int i = 0; i < rt_render_noptdefs; i++) nshared += (rt_render_optdefs[i].cmds & RT_OC_RENDER) != 0;
    if (nlo != 3 + nshared || strcmp(lo[0].name, "line") || strcmp(lo[3].name, rt_render_optdefs[0].name + 2))
        rt_fuzz_fail("merged table has %zu entries", nlo);
    rt_render_opts o;
    rt_render_default_opts(&o);
    const char *tracer = "recursive";
    int c;
    optind = 0; /* glibc: full re-initialisation for each input */
    opterr = 0;
    while ((c = getopt_long(argc, argv, rt_cmd_shortopts(RT_OC_RENDER, "l:r:h", so, sizeof so), lo, NULL)) != -1) {
        if (c == 'l') {
            uint32_t line = 0;
            int before = nerrors;
            if (rt_cmd_parse_line("fuzz", optarg, &line) == 0) {
                if (line < 1 || line > (1u << 20)) rt_fuzz_fail("--line %u", line);
            } else if (nerrors == before) rt_fuzz_fail("--line refused without a message");
        } else if (c == 'r') {
            double rate = 0;
            if (rt_cmd_parse_rate(optarg, &rate) == 0 && !(rate > 0 && rate <= 1)) rt_fuzz_fail("rate %g", rate);
        } else if (c != 'h' && c != '?' && c != ':') {
            rt_render_opts before = o;
            const char *tbefore = tracer;
            int nbefore = nerrors;
            int rc = rt_cmd_render_opt("fuzz", c, optarg, &o, &tracer);
            if (rc == 0) rt_fuzz_fail("shared option %d not handled", c);
            if (rc < 0 && (nerrors == nbefore || memcmp(&before, &o, sizeof o) || tracer != tbefore))
                rt_fuzz_fail("option %d refused with changes or without a message", c);
            check_opts(&o, tracer);
        }
    }
    rt_fuzz_accepted = nerrors == 0;
    nerrors = 0;
    free(lo);
    free(text);
    return 0;
}
