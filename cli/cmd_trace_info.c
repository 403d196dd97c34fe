/* cmd_trace_info.c -- `raytraffic trace-info`: describe a trace file (header,
 * region table, per-class totals) after verifying all of it. */
#include "cmd.h"
#include "experiment.h"
#include "sindex.h"
#include "trace.h"

#include <inttypes.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static void usage(FILE *f)
{
    fprintf(f,
            "Usage: raytraffic trace-info FILE [--json]\n\n"
            "Print a trace's provenance (tool version, git revision, command line), scene and\n"
            "tracer parameters, region table, and per-class reference counts. The whole file\n"
            "is read and verified (CRCs, footer totals); a truncated or corrupt file is an\n"
            "error (exit 1) naming the byte offset.\n\n"
            "Options:\n"
            "  --json             one JSON object on stdout\n"
            "  -h, --help         this help\n");
}

static void json_str(FILE *f, const char *s) { rt_cmd_json_str(f, s); }

static void lights_str(uint32_t mask, char *buf, size_t cap) { rt_exp_lights_name(mask, buf, cap); }

static void print_text(const char *path, const rt_tr_reader *r)
{
    const rt_tr_meta *m = rt_tr_get_meta(r);
    const rt_tr_totals *t = rt_tr_get_totals(r);
    uint64_t fb = rt_tr_file_bytes(r);
    char lights[128];
    lights_str(m->lights, lights, sizeof lights);
    printf("file:          %s\n", path);
    printf("format:        rtt version %" PRIu32 ", %" PRIu32 " records per chunk\n", rt_tr_get_version(r),
           rt_tr_get_chunk_records(r));
    printf("size:          %" PRIu64 " bytes, %.3f bytes/reference\n", fb,
           t->nrefs ? (double)fb / (double)t->nrefs : 0.0);
    printf("file hash:     %016" PRIx64 "\n", rt_tr_file_hash(r));
    if (m->cores > 1) /* version 4 only: earlier traces print as they did */
        printf("cores:         %" PRIu32 " simulated cores, interleaved (a 2-byte core-switch record per change)\n",
               m->cores);
    printf("written by:    raytraffic %s (git %s)\n", m->tool_version, m->git_rev);
    printf("command:       %s\n", m->command);
    printf("scene:         %s%s%s%s, %" PRIu32 " triangles, hash %016" PRIx64 "\n", m->scene,
           m->scene_params[0] ? " (" : "", m->scene_params, m->scene_params[0] ? ")" : "", m->ntri, m->scene_hash);
    printf("tracer:        %s, %dx%d, lights %s", m->tracer, (int)m->W, (int)m->H, lights);
    if (m->sched_size) printf(", scheduled for cache size %" PRIu64, m->sched_size);
    if (m->gmax) printf(", gmax %" PRIu64, m->gmax);
    if (m->params[0]) printf(", %s", m->params);
    /* the structure: accel=X in the key, else the tracer's default */
    const char *acc = strstr(m->params, "accel=");
    const rt_tracer *tr = rt_tracer_find(m->tracer);
    char aname[16] = "?";
    if (strstr(m->params, "instances=bvh")) snprintf(aname, sizeof aname, "%s", rt_accel_name(RT_ACCEL_INST));
    else if (acc) sscanf(acc + 6, "%15[a-z0-9]", aname);
    else if (tr && rt_accel_name(tr->accel_default)) snprintf(aname, sizeof aname, "%s", rt_accel_name(tr->accel_default));
    printf("\nstructure:     %s", aname);
    printf("\n\nregions (%d):\n", m->layout.n);
    printf("  %-20s %-7s %18s %8s %12s %14s\n", "name", "class", "base", "recsize", "count", "bytes");
    for (int i = 0; i < m->layout.n; i++) {
        const rt_region *g = &m->layout.r[i];
        const char *cn = rt_class_name(g->cls);
        printf("  %-20s %-7s 0x%016" PRIx64 " %8" PRIu32 " %12" PRIu64 " %14" PRIu64 "\n", g->name, cn ? cn : "?",
               g->base, g->recsize, g->count, (uint64_t)g->recsize * g->count);
    }
    printf("\nreferences by class:\n");
    printf("  %-7s %-8s %14s %16s %14s\n", "class", "group", "refs", "bytes", "writes");
    for (int c = 0; c < RT_NCLASS; c++) {
        if (!t->refs[c]) continue;
        printf("  %-7s %-8s %14" PRIu64 " %16" PRIu64 " %14" PRIu64 "\n", rt_class_name(c),
               rt_group_name(rt_class_group(c)), t->refs[c], t->bytes[c], t->writes[c]);
    }
    uint64_t bytes = 0, writes = 0;
    for (int c = 0; c < RT_NCLASS; c++) bytes += t->bytes[c], writes += t->writes[c];
    printf("  %-7s %-8s %14" PRIu64 " %16" PRIu64 " %14" PRIu64 "\n", "total", "", t->nrefs, bytes, writes);
    rt_tr_sample_params sp;
    if (rt_tr_get_sample_params(r, &sp)) {
        printf("\nsample index: %" PRIu32 "-byte lines at rate 1/%llu (seed %" PRIu64 "); a window of %" PRIu64
               " records every %" PRIu64 ", warmed for %" PRIu64 " lines from at most %" PRIu64 " records\n",
               sp.line, 1ULL << sp.shift, sp.seed, sp.window, sp.period, sp.cmax, sp.hist);
        printf("\n%" PRIu64 " chunks; verified: CRCs, footer totals and sample index match\n", t->nchunks);
    } else {
        printf("\n%" PRIu64 " chunks; verified: CRCs and footer totals match\n", t->nchunks);
    }
}

static void print_json(const char *path, const rt_tr_reader *r)
{
    const rt_tr_meta *m = rt_tr_get_meta(r);
    const rt_tr_totals *t = rt_tr_get_totals(r);
    uint64_t fb = rt_tr_file_bytes(r);
    printf("{\"file\": ");
    json_str(stdout, path);
    printf(", \"format_version\": %" PRIu32 ", \"chunk_records\": %" PRIu32 ", \"file_bytes\": %" PRIu64
           ", \"file_hash\": \"%016" PRIx64 "\", \"bytes_per_ref\": %.4f",
           rt_tr_get_version(r), rt_tr_get_chunk_records(r), fb, rt_tr_file_hash(r),
           t->nrefs ? (double)fb / (double)t->nrefs : 0.0);
    if (m->cores > 1) printf(", \"cores\": %" PRIu32, m->cores);
    printf(", \"tool_version\": ");
    json_str(stdout, m->tool_version);
    printf(", \"git_rev\": ");
    json_str(stdout, m->git_rev);
    printf(", \"command\": ");
    json_str(stdout, m->command);
    printf(", \"scene\": ");
    json_str(stdout, m->scene);
    printf(", \"scene_params\": ");
    json_str(stdout, m->scene_params);
    printf(", \"scene_hash\": \"%016" PRIx64 "\", \"triangles\": %" PRIu32 ", \"tracer\": ", m->scene_hash, m->ntri);
    json_str(stdout, m->tracer);
    printf(", \"width\": %d, \"height\": %d, \"lights\": %" PRIu32 ", \"sched_size\": %" PRIu64
           ", \"gmax\": %" PRIu64 ", \"params\": ",
           (int)m->W, (int)m->H, m->lights, m->sched_size, m->gmax);
    json_str(stdout, m->params);
    printf(", \"regions\": [");
    for (int i = 0; i < m->layout.n; i++) {
        const rt_region *g = &m->layout.r[i];
        printf("%s{\"name\": ", i ? ", " : "");
        json_str(stdout, g->name);
        printf(", \"class\": \"%s\", \"base\": \"0x%016" PRIx64 "\", \"recsize\": %" PRIu32 ", \"count\": %" PRIu64
               ", \"bytes\": %" PRIu64 "}",
               rt_class_name(g->cls), g->base, g->recsize, g->count, (uint64_t)g->recsize * g->count);
    }
    printf("], \"classes\": {");
    int first = 1;
    for (int c = 0; c < RT_NCLASS; c++) {
        if (!t->refs[c]) continue;
        printf("%s\"%s\": {\"group\": \"%s\", \"refs\": %" PRIu64 ", \"bytes\": %" PRIu64 ", \"writes\": %" PRIu64
               "}",
               first ? "" : ", ", rt_class_name(c), rt_group_name(rt_class_group(c)), t->refs[c], t->bytes[c],
               t->writes[c]);
        first = 0;
    }
    printf("}, \"refs\": %" PRIu64 ", \"chunks\": %" PRIu64, t->nrefs, t->nchunks);
    rt_tr_sample_params sp;
    /* "sample_index"; "sample_stream" repeats it under its former name
     * for one release, for scripts written before */
    for (int k = 0; k < 2 && rt_tr_get_sample_params(r, &sp); k++)
        printf(", \"%s\": {\"line\": %" PRIu32 ", \"rate\": %.10g, \"seed\": %" PRIu64
               ", \"period\": %" PRIu64 ", \"window\": %" PRIu64 ", \"warm_lines\": %" PRIu64
               ", \"history\": %" PRIu64 "}",
               k ? "sample_stream" : "sample_index", sp.line, 1.0 / (double)(1ULL << sp.shift), sp.seed, sp.period,
               sp.window, sp.cmax, sp.hist);
    printf("}\n");
}

int main_trace_info(int argc, char **argv)
{
    static const struct option lo[] = {
        {"json", no_argument, NULL, 'j'},
        {"help", no_argument, NULL, 'h'},
        {NULL, 0, NULL, 0},
    };
    int json = 0, c;
    optind = 1;
    while ((c = getopt_long(argc, argv, "h", lo, NULL)) != -1) {
        switch (c) {
        case 'j': json = 1; break;
        case 'h': usage(stdout); return RT_EXIT_OK;
        default: return RT_EXIT_USAGE;
        }
    }
    if (optind != argc - 1) {
        if (optind == argc && argc == 1) {
            usage(stdout);
            return RT_EXIT_OK;
        }
        rt_cmd_error("trace-info", "expected exactly one FILE (see --help)");
        return RT_EXIT_USAGE;
    }
    const char *path = argv[optind];
    rt_err e = {0};
    rt_tr_reader *r = rt_si_open(path, &e);
    if (!r) {
        rt_cmd_error("trace-info", "%s", e.msg);
        return RT_EXIT_FAIL;
    }
    enum { CAP = 16384 };
    rt_access *buf = rt_calloc(CAP, sizeof *buf, &e);
    long n = buf ? 1 : -1;
    while (buf && (n = rt_tr_read(r, buf, CAP, &e)) > 0) {}
    free(buf);
    if (n < 0) {
        rt_cmd_error("trace-info", "%s", e.msg);
        rt_tr_close(r);
        return RT_EXIT_FAIL;
    }
    if (json) print_json(path, r);
    else print_text(path, r);
    rt_tr_close(r);
    if (fflush(stdout) != 0) {
        rt_cmd_error("trace-info", "write error on standard output");
        return RT_EXIT_FAIL;
    }
    return RT_EXIT_OK;
}
