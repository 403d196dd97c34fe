/* cmd_sim_cores.c -- `raytraffic sim --hierarchy SPEC`: replay traces
 * through the multi-core hierarchy (cachesim/mcore.h): a version-4 trace
 * of N simulated cores on N private caches above a shared last level, a
 * trace of versions 1-3 on one core; print per-core and per-level rows or
 * store them with the run (cores, hierarchy) in the database. */
#include "cmd.h"
#include "experiment.h"
#include "mcore.h"
#include "mcore_rows.h"
#include "rows.h"
#include "trace.h"

#include <getopt.h>
#include <inttypes.h>
#include <stdlib.h>
#include <string.h>

static void usage(FILE *f)
{
    fprintf(f,
            "Usage: raytraffic sim --hierarchy SPEC [--db FILE] [--format text|csv] TRACE...\n\n"
            "Replays each .rtt trace through N cores with private caches above one shared\n"
            "level (N = the trace's simulated cores: `trace --cores N`, format version 4;\n"
            "earlier traces are one core). SPEC is 1-4 levels as for sim --hierarchy, each\n"
            "NAME=SIZE/WAYS/LINE/POLICY[/private|/shared], e.g.\n"
            "  L1=32K/8/64/lru/private,LLC=1K-4M/full/64/lru/shared\n"
            "(without the suffix the last level is shared, the first private, a middle\n"
            "one as the level above it; the last level may give several sizes, a range\n"
            "1K-4M or a list 256K+1M). Writes invalidate the\n"
            "other cores' copies; coherence misses are counted apart (docs/cachesim.md,\n"
            "\"Many cores\").\n\n"
            "Options:\n"
            "  --hierarchy SPEC   the hierarchy (required for this form)\n"
            "  --db FILE          store the run (cores, hierarchy) with its memory traffic\n"
            "                     rows and per-level rows (one per core for the private level)\n"
            "  --format F         text (default) | csv\n"
            "  -h, --help         this help\n");
}

static int one(const rt_mc_config *cfg0, rt_db *db, int csv, const char *path, rt_err *e)
{
    rt_tr_reader *r = rt_tr_open(path, e);
    if (!r) return -1;
    const rt_tr_meta *m = rt_tr_get_meta(r);
    rt_mc_config cfg = *cfg0;
    cfg.ncores = m->cores > 1 ? (int)m->cores : 1;
    rt_mc *mc = rt_mc_new(&cfg, e);
    enum { CAP = 16384 };
    rt_access *buf = mc ? rt_calloc(CAP, sizeof *buf, e) : NULL;
    uint8_t *cores = buf ? rt_calloc(CAP, 1, e) : NULL;
    int rc = -1;
    long n = 0;
    double t0 = rt_now();
    while (cores && (n = rt_tr_read_cores(r, buf, cores, CAP, e)) > 0) {
        for (long i = 0; i < n;) {
            long j = i + 1;
            while (j < n && cores[j] == cores[i]) j++;
            if (rt_mc_put(mc, cores[i], buf + i, (size_t)(j - i)) < 0) {
                rt_errf(e, "%s: %s", path, rt_mc_error(mc));
                n = -1;
                break;
            }
            i = j;
        }
        if (n < 0) break;
    }
    if (cores && n == 0 && rt_mc_finish(mc) == 0) rc = 0;
    char spec[200];
    rt_mc_spec(&cfg, spec, sizeof spec);
    if (rc == 0 && !db) {
        if (!csv) printf("# %s: %d core%s, %s, %" PRIu64 " references\n", path, cfg.ncores, cfg.ncores == 1 ? "" : "s",
                         spec, rt_mc_refs(mc));
        if (!csv) printf("level core size_bytes line assoc class accesses misses coherence_misses writebacks traffic_bytes\n");
        for (int p = 0; p < cfg.nprivate; p++)
            for (int k = 0; k < cfg.ncores; k++)
                for (int cls = -1; cls < RT_NCLASS; cls++) {
                    rt_mc_counts x;
                    rt_mc_get_level(mc, p, k, cls, -1, &x);
                    if (!x.accesses) continue;
                    printf(csv ? "%s,%s,%d,%" PRIu64 ",%u,%u,%s,%" PRIu64 ",%" PRIu64 ",%" PRIu64 ",%" PRIu64 ",%" PRIu64 "\n"
                               : "%s%.0s %d %" PRIu64 " %u %u %s %" PRIu64 " %" PRIu64 " %" PRIu64 " %" PRIu64 " %" PRIu64 "\n",
                           csv ? path : cfg.h.name[p], csv ? cfg.h.name[p] : "", k, cfg.h.level[p].sizes[0],
                           cfg.h.level[p].line, cfg.h.level[p].assoc, cls < 0 ? "all" : rt_class_name(cls), x.accesses,
                           x.misses, x.coherence_misses, x.writebacks, x.traffic_bytes);
                }
        for (int q = cfg.nprivate; q < cfg.h.nlevels; q++) {
            const rt_sim_config *l = &cfg.h.level[q];
            for (int z = 0; z < l->nsizes; z++)
                for (int cls = -1; cls < RT_NCLASS; cls++) {
                    rt_sim_counts x;
                    memset(&x, 0, sizeof x);
                    for (int c = cls < 0 ? 0 : cls; c < (cls < 0 ? RT_NCLASS : cls + 1); c++) {
                        rt_hier_counts s;
                        rt_hier_get(rt_mc_shared_hier(mc), q - cfg.nprivate, z, c, &s);
                        x.accesses += s.c.accesses;
                        x.read_misses += s.c.read_misses + s.c.write_misses;
                        x.writebacks += s.c.writebacks;
                        x.traffic_bytes += s.c.traffic_bytes;
                    }
                    if (!x.accesses) continue;
                    printf(csv ? "%s,%s,-1,%" PRIu64 ",%u,%u,%s,%" PRIu64 ",%" PRIu64 ",0,%" PRIu64 ",%" PRIu64 "\n"
                               : "%s%.0s - %" PRIu64 " %u %u %s %" PRIu64 " %" PRIu64 " 0 %" PRIu64 " %" PRIu64 "\n",
                           csv ? path : cfg.h.name[q], csv ? cfg.h.name[q] : "", l->sizes[z], l->line, l->assoc,
                           cls < 0 ? "all" : rt_class_name(cls), x.accesses, x.read_misses, x.writebacks, x.traffic_bytes);
                }
        }
    }
    if (rc == 0 && db) {
        rt_db_run run;
        rt_exp_run_from_meta(m, &run);
        run.hierarchy = spec;
        run.cores = cfg.ncores;
        run.trace_hash = rt_tr_file_hash(r);
        run.refs = rt_mc_refs(mc);
        run.command = rt_cmd_line();
        run.wall_time = rt_now() - t0;
        rt_db_traffic *tr = rt_calloc((size_t)cfg.h.level[cfg.h.nlevels - 1].nsizes * RT_NCLASS, sizeof *tr, e);
        rt_db_level *lv = tr ? rt_calloc(rt_mc_db_level_cap(mc), sizeof *lv, e) : NULL;
        int64_t id = 0;
        if (!lv || !run.refs) {
            if (lv) rt_errf(e, "%s: no references in the trace; nothing stored", path);
            rc = -1;
        } else {
            rt_db_rows R = {.traffic = tr, .ntraffic = rt_mc_db_traffic_rows(mc, tr), .level = lv,
                            .nlevel = rt_mc_db_level_rows(mc, lv)};
            rc = rt_db_store(db, &run, &R, &id, e);
            if (rc == 0)
                fprintf(stderr, "raytraffic sim: %s: run %lld, %d cores, %s, %" PRIu64 " references\n", path,
                        (long long)id, cfg.ncores, spec, run.refs);
        }
        free(tr);
        free(lv);
    }
    free(cores);
    free(buf);
    rt_mc_free(mc);
    rt_tr_close(r);
    return rc;
}

int rt_cmd_sim_cores(int argc, char **argv)
{
    static const struct option lo[] = {
        {"hierarchy", required_argument, NULL, 'y'},
        {"db", required_argument, NULL, 'd'},
        {"format", required_argument, NULL, 'f'},
        {"help", no_argument, NULL, 'h'},
        {NULL, 0, NULL, 0},
    };
    const char *spec = NULL, *dbpath = NULL;
    int csv = 0, c;
    optind = 1;
    while ((c = getopt_long(argc, argv, "h", lo, NULL)) != -1) {
        switch (c) {
        case 'y': spec = optarg; break;
        case 'd': dbpath = optarg; break;
        case 'f':
            if (!strcmp(optarg, "csv")) csv = 1;
            else if (strcmp(optarg, "text")) {
                rt_cmd_error("sim", "--format: '%s' is not text or csv (with --hierarchy)", optarg);
                return RT_EXIT_USAGE;
            }
            break;
        case 'h': usage(stdout); return RT_EXIT_OK;
        default:
            rt_cmd_error("sim", "with --hierarchy: only --db and --format apply (see sim --hierarchy X --help)");
            return RT_EXIT_USAGE;
        }
    }
    rt_err e = {0};
    rt_mc_config cfg;
    if (!spec || rt_mc_parse(spec, &cfg, &e) < 0) {
        rt_cmd_error("sim", "%s", spec ? e.msg : "--hierarchy needs SPEC");
        return RT_EXIT_USAGE;
    }
    if (optind >= argc) {
        rt_cmd_error("sim", "expected one or more TRACE files");
        return RT_EXIT_USAGE;
    }
    rt_db *db = NULL;
    if (dbpath && !(db = rt_db_open(dbpath, &e))) {
        rt_cmd_error("sim", "%s", e.msg);
        return RT_EXIT_FAIL;
    }
    if (csv && !db)
        printf("trace,level,core,size_bytes,line,assoc,class,accesses,misses,coherence_misses,writebacks,traffic_bytes\n");
    int status = RT_EXIT_OK;
    for (int a = optind; a < argc; a++) {
        memset(&e, 0, sizeof e);
        if (one(&cfg, db, csv, argv[a], &e) < 0) {
            rt_cmd_error("sim", "%s", e.msg);
            status = RT_EXIT_FAIL;
        }
    }
    rt_db_close(db);
    if (fflush(stdout) != 0) status = RT_EXIT_FAIL;
    return status;
}
