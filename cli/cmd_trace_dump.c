/* cmd_trace_dump.c -- `raytraffic trace-dump`: print a trace's records as
 * text or as Dinero IV din, verifying the file as it goes. */
#include "cmd.h"
#include "sindex.h"
#include "trace.h"

#include <errno.h>
#include <inttypes.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static void usage(FILE *f)
{
    fprintf(f,
            "Usage: raytraffic trace-dump FILE [--din] [--line N] [--limit N] [--core K]\n\n"
            "Print the records of a trace, one per line:\n"
            "  text (default)  'R 0x10001000 8 node': R/W, address, size in bytes, class\n"
            "  --din           Dinero IV din: 'LABEL ADDRESS' with LABEL 0 read, 1 write and\n"
            "                  ADDRESS in hexadecimal. A reference of size s is split into\n"
            "                  one din line per cache line of --line bytes it touches, each\n"
            "                  giving the address of the reference's first byte within that\n"
            "                  line, so replaying the din output with that line size (any\n"
            "                  cache organisation) counts exactly what the trace would.\n\n"
            "Options:\n"
            "  --din              Dinero IV din output\n"
            "  --line N           line size for --din in bytes (default 64)\n"
            "  --limit N          stop after N trace records (default: all)\n"
            "  --core K           only core K's references (a version-4 trace of several\n"
            "                     simulated cores: one din per core; earlier traces are\n"
            "                     core 0). Without it the text lines of such a trace end\n"
            "                     with ' core K'; --din then writes all cores' references\n"
            "                     in their interleaved order\n"
            "  -h, --help         this help\n\n"
            "The whole file is verified unless --limit stops early; an error after some\n"
            "records were printed still exits 1 with the byte offset.\n");
}

static int parse_u64(const char *s, uint64_t lo, uint64_t *out)
{
    char *end;
    errno = 0;
    if (!s || *s < '0' || *s > '9') return -1; /* no space, sign or empty string */
    unsigned long long v = strtoull(s, &end, 10);
    if (errno || *end || v < lo) return -1;
    *out = v;
    return 0;
}

/* Writes "L hex\n" without printf. */
static inline void din_line(FILE *f, int label, uint64_t a)
{
    static const char hx[] = "0123456789abcdef";
    char b[24];
    int k = 23;
    b[k--] = '\n';
    do {
        b[k--] = hx[a & 15];
        a >>= 4;
    } while (a);
    b[k--] = ' ';
    b[k] = (char)('0' + label);
    fwrite(b + k, 1, (size_t)(24 - k), f);
}

int main_trace_dump(int argc, char **argv)
{
    static const struct option lo[] = {
        {"din", no_argument, NULL, 'd'},
        {"line", required_argument, NULL, 'l'},
        {"limit", required_argument, NULL, 'n'},
        {"core", required_argument, NULL, 'k'},
        {"help", no_argument, NULL, 'h'},
        {NULL, 0, NULL, 0},
    };
    int din = 0, c;
    uint32_t line = 64;
    uint64_t limit = UINT64_MAX, only = UINT64_MAX;
    optind = 1;
    while ((c = getopt_long(argc, argv, "h", lo, NULL)) != -1) {
        switch (c) {
        case 'd': din = 1; break;
        case 'l':
            if (rt_cmd_parse_line("trace-dump", optarg, &line) < 0) return RT_EXIT_USAGE;
            break;
        case 'n':
            if (parse_u64(optarg, 0, &limit) < 0) {
                rt_cmd_error("trace-dump", "--limit: '%s' is not a record count", optarg);
                return RT_EXIT_USAGE;
            }
            break;
        case 'k':
            if (parse_u64(optarg, 0, &only) < 0 || only >= RT_TR_MAX_CORES) {
                rt_cmd_error("trace-dump", "--core: '%s' is not a core in 0..%d", optarg, RT_TR_MAX_CORES - 1);
                return RT_EXIT_USAGE;
            }
            break;
        case 'h': usage(stdout); return RT_EXIT_OK;
        default: return RT_EXIT_USAGE;
        }
    }
    if (optind != argc - 1) {
        if (argc == 1) {
            usage(stdout);
            return RT_EXIT_OK;
        }
        rt_cmd_error("trace-dump", "expected exactly one FILE (see --help)");
        return RT_EXIT_USAGE;
    }
    const char *path = argv[optind];
    rt_err e = {0};
    rt_tr_reader *r = rt_si_open(path, &e);
    if (!r) {
        rt_cmd_error("trace-dump", "%s", e.msg);
        return RT_EXIT_FAIL;
    }
    const uint32_t ncores = rt_tr_get_meta(r)->cores;
    if (only != UINT64_MAX && only >= ncores) {
        rt_cmd_error("trace-dump", "--core %" PRIu64 ": %s holds %" PRIu32 " core%s", only, path, ncores,
                     ncores == 1 ? " (0)" : "s");
        rt_tr_close(r);
        return RT_EXIT_USAGE;
    }
    enum { CAP = 16384 };
    rt_access *buf = rt_calloc(CAP, sizeof *buf, &e);
    uint8_t *cores = buf ? rt_calloc(CAP, 1, &e) : NULL;
    long n = cores ? 1 : -1;
    uint64_t done = 0;
    while (cores && done < limit && (n = rt_tr_read_cores(r, buf, cores, CAP, &e)) > 0) {
        uint64_t k = (uint64_t)n;
        if (k > limit - done) k = limit - done;
        for (uint64_t i = 0; i < k; i++) {
            const rt_access *a = &buf[i];
            if (only != UINT64_MAX && cores[i] != only) continue;
            if (!din) {
                if (ncores > 1 && only == UINT64_MAX)
                    printf("%c 0x%" PRIx64 " %" PRIu32 " %s core %u\n", a->write ? 'W' : 'R', a->addr, a->size,
                           rt_class_name(a->cls), cores[i]);
                else
                    printf("%c 0x%" PRIx64 " %" PRIu32 " %s\n", a->write ? 'W' : 'R', a->addr, a->size,
                           rt_class_name(a->cls));
                continue;
            }
            /* last byte, clipped at the top of the address space */
            uint64_t last = a->addr + (a->size - 1);
            if (last < a->addr) last = UINT64_MAX;
            uint64_t l0 = a->addr / line, l1 = last / line;
            din_line(stdout, a->write ? 1 : 0, a->addr);
            for (uint64_t l = l0 + 1; l <= l1 && l != 0; l++) din_line(stdout, a->write ? 1 : 0, l * line);
        }
        done += k;
    }
    free(buf);
    free(cores);
    int rc = RT_EXIT_OK;
    if (n < 0) {
        fflush(stdout);
        rt_cmd_error("trace-dump", "%s", e.msg);
        rc = RT_EXIT_FAIL;
    }
    rt_tr_close(r);
    if (fflush(stdout) != 0 || ferror(stdout)) {
        rt_cmd_error("trace-dump", "write error on standard output");
        rc = RT_EXIT_FAIL;
    }
    return rc;
}
