/* stats.c -- end-of-run statistics shared by the tracers (see stats.h). */
#include "stats.h"

#include <string.h>

void rt_stats_finish(rt_run_stats *st, const rt_trav *tv, const uint8_t *mark, uint32_t ntri)
{
    if (st->mark_keep && ntri) memcpy(st->mark_keep, mark, ntri);
    st->nodes = tv->nodes;
    st->tests = tv->tests;
    /* eight marks at a time: bit 0 of every byte counted for pv_primary,
     * and of every byte with its eight bits or-ed into bit 0 for pv_all;
     * (x * low) >> 56 sums the bytes of x (each 0 or 1 here) */
    const uint64_t low = 0x0101010101010101ull;
    uint64_t prim = 0, all = 0;
    uint32_t i = 0;
    for (; i + 8 <= ntri; i += 8) {
        uint64_t w;
        memcpy(&w, mark + i, sizeof w);
        uint64_t nz = w | w >> 4; /* bit 8k + j of the shifts comes from byte k for j < 4, 2, 1 */
        nz |= nz >> 2;
        nz |= nz >> 1;
        prim += ((w & low) * low) >> 56;
        all += ((nz & low) * low) >> 56;
    }
    for (; i < ntri; i++) {
        prim += mark[i] & 1;
        all += mark[i] != 0;
    }
    st->pv_primary += prim;
    st->pv_all += all;
}

int rt_stats_is_number(const char *v, size_t len)
{
    size_t i = 0;
    if (i < len && v[i] == '-') i++;
    if (i >= len || v[i] < '0' || v[i] > '9') return 0;
    if (v[i] == '0') i++;
    else
        while (i < len && v[i] >= '0' && v[i] <= '9') i++;
    if (i < len && v[i] == '.') {
        i++;
        if (i >= len || v[i] < '0' || v[i] > '9') return 0;
        while (i < len && v[i] >= '0' && v[i] <= '9') i++;
    }
    if (i < len && (v[i] == 'e' || v[i] == 'E')) {
        i++;
        if (i < len && (v[i] == '+' || v[i] == '-')) i++;
        if (i >= len || v[i] < '0' || v[i] > '9') return 0;
        while (i < len && v[i] >= '0' && v[i] <= '9') i++;
    }
    return i == len;
}

static int key_char(char c)
{
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_';
}

int rt_stats_json(const char *s, char *out, size_t n, rt_err *e)
{
    size_t l = 0, tok = 0;
    const char *p = s;
    if (n < 3) return rt_errf(e, "statistics: output buffer too small");
    out[l++] = '{';
    while (*p) {
        const char *k = p, *eq = k;
        while (key_char(*eq)) eq++;
        if (eq == k || *eq != '=')
            goto bad;
        const char *v = eq + 1, *end = v;
        while (*end && *end != ' ') {
            unsigned char c = (unsigned char)*end;
            if (c < 0x21 || c == 0x7f || c == '"' || c == '\\') goto bad;
            end++;
        }
        if (end == v) goto bad;
        /* a key twice: look for ` key=` or a leading `key=` before this token */
        for (const char *q = s; q < k;) {
            const char *qe = q;
            while (*qe != '=') qe++;
            if ((size_t)(qe - q) == (size_t)(eq - k) && !memcmp(q, k, (size_t)(eq - k))) {
                out[0] = '{', out[1] = '}', out[2] = 0;
                return rt_errf(e, "statistics: key '%.*s' appears twice (token %zu)", (int)(eq - k), k, tok + 1);
            }
            q = strchr(q, ' ') + 1;
        }
        const int num = rt_stats_is_number(v, (size_t)(end - v));
        const size_t need = (size_t)(end - k) + 8; /* , "": "" */
        if (l + need + 2 > n) {
            out[0] = '{', out[1] = '}', out[2] = 0;
            return rt_errf(e, "statistics: output buffer too small at token %zu", tok + 1);
        }
        if (tok) out[l++] = ',', out[l++] = ' ';
        out[l++] = '"';
        memcpy(out + l, k, (size_t)(eq - k)), l += (size_t)(eq - k);
        out[l++] = '"', out[l++] = ':', out[l++] = ' ';
        if (!num) out[l++] = '"';
        memcpy(out + l, v, (size_t)(end - v)), l += (size_t)(end - v);
        if (!num) out[l++] = '"';
        tok++;
        if (!*end) break;
        p = end + 1;
        if (!*p || *p == ' ') goto bad; /* a trailing or a double space */
        continue;
    bad:
        out[0] = '{', out[1] = '}', out[2] = 0;
        return rt_errf(e, "statistics: token %zu ('%.20s') is not key=value with a one-word value", tok + 1, p);
    }
    out[l++] = '}';
    out[l] = 0;
    return 0;
}
