/*
 * scene_obj.c -- Wavefront OBJ loader.
 *
 * Reads `v x y z [w]` vertices and `f` faces whose corners are written
 * `v`, `v/vt`, `v//vn` or `v/vt/vn`, with positive (1-based) or negative
 * (relative to the vertices read so far) indices. Triangles, quads and
 * n-gons are fan-triangulated from the first corner: (0,1,2), (0,2,3), ...
 * Every other statement (vt, vn, g, o, s, usemtl, mtllib, l, p, ...) and
 * comments are ignored; CRLF line ends are accepted. Faces must refer to
 * vertices defined above them.
 *
 * Malformed input never crashes and never reads outside the file buffer:
 * the first problem ends the load with one line "FILE:LINE: what", e.g.
 * "mesh.obj:12: face index 9 out of range (8 vertices)". A file without
 * faces, with a NaN/Inf coordinate, or outside the coordinate range the
 * float pipeline resolves (rt_scene_check_range) is rejected; input quoted
 * in a message is escaped (rt_esc).
 * Loaded meshes get a default grey, an auto-framed camera and default
 * lights (rt_scene_autoframe).
 */
#include "config.h"
#include "scene.h"

#include <errno.h>
#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>


static int is_space(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\f' || c == '\v'; }

static const char *skip_space(const char *p)
{
    while (is_space(*p)) p++;
    return p;
}

/* Parses one float coordinate at *pp (a whole whitespace-delimited token).
 * 0 on success, else 1 = not a number, 2 = NaN or infinite, 3 = beyond
 * RT_COORD_MAX (docs/scenes.md: coordinate range). */
static int parse_coord(const char **pp, float *out)
{
    const char *p = *pp;
    char *end;
    errno = 0;
    double v = strtod(p, &end);
    if (end == p || (*end && !is_space(*end))) return 1;
    *pp = end;
    if (!isfinite(v)) return 2;
    if (fabs(v) > RT_COORD_MAX) return 3;
    *out = (float)v;
    return 0;
}

static int token_len(const char *p)
{
    int n = 0;
    while (p[n] && !is_space(p[n]) && n < 40) n++;
    return n;
}

typedef struct objload {
    const char *path;
    unsigned long line;
    rt_vec3 *v;   /* vertices so far */
    size_t nv, cv;
    uint32_t *face; /* corner indices of the current face */
    size_t cf;
    rt_err *e;
} objload;

static int vertex_line(objload *L, const char *p)
{
    float c[3];
    for (int k = 0; k < 4; k++) {
        p = skip_space(p);
        if (!*p) {
            if (k < 3) return rt_errf(L->e, "%s:%lu: vertex has %d coordinates (need 3)", L->path, L->line, k);
            break;
        }
        float x;
        const char *tok = p;
        int r = parse_coord(&p, &x);
        char q[64];
        if (r) rt_esc(q, sizeof q, tok, (size_t)token_len(tok));
        if (r == 1) return rt_errf(L->e, "%s:%lu: bad number '%s'", L->path, L->line, q);
        if (r == 2) return rt_errf(L->e, "%s:%lu: coordinate is not a finite number ('%s')", L->path, L->line, q);
        if (r == 3)
            return rt_errf(L->e, "%s:%lu: coordinate %s out of range (|c| <= %g, docs/scenes.md)", L->path, L->line,
                           q, RT_COORD_MAX);
        if (k < 3) c[k] = x;
    }
    /* Further tokens (vertex colours) are ignored. */
    if (L->nv == L->cv) {
        size_t nc = L->cv ? 2 * L->cv : 1024;
        rt_vec3 *nvv = rt_reallocarray(L->v, nc, sizeof *nvv, L->e);
        if (!nvv) return -1;
        L->v = nvv;
        L->cv = nc;
    }
    if (L->nv >= UINT32_MAX) return rt_errf(L->e, "%s:%lu: too many vertices", L->path, L->line);
    L->v[L->nv++] = rt_v3(c[0], c[1], c[2]);
    return 0;
}

/* Parses an optionally signed decimal integer; 0 or -1. */
static int parse_int(const char **pp, long long *out)
{
    const char *p = *pp;
    int neg = 0;
    if (*p == '-' || *p == '+') neg = *p++ == '-';
    if (*p < '0' || *p > '9') return -1;
    long long v = 0;
    while (*p >= '0' && *p <= '9') {
        if (v > (1LL << 40)) return -1; /* absurd; rejected as out of range by caller */
        v = v * 10 + (*p++ - '0');
    }
    *out = neg ? -v : v;
    *pp = p;
    return 0;
}

static int face_line(objload *L, rt_scene *s, const char *p)
{
    size_t n = 0;
    for (;;) {
        p = skip_space(p);
        if (!*p) break;
        const char *tok = p;
        long long idx;
        char q[64];
        if (parse_int(&p, &idx) < 0)
            return rt_errf(L->e, "%s:%lu: bad face index '%s'", L->path, L->line,
                           rt_esc(q, sizeof q, tok, (size_t)token_len(tok)));
        /* Optional /vt, //vn, /vt/vn: validated, then ignored. */
        for (int k = 0; k < 2 && *p == '/'; k++) {
            p++;
            long long dummy;
            if (*p != '/' && *p && !is_space(*p) && parse_int(&p, &dummy) < 0)
                return rt_errf(L->e, "%s:%lu: bad face index '%s'", L->path, L->line,
                               rt_esc(q, sizeof q, tok, (size_t)token_len(tok)));
        }
        if (*p && !is_space(*p))
            return rt_errf(L->e, "%s:%lu: bad face index '%s'", L->path, L->line,
                           rt_esc(q, sizeof q, tok, (size_t)token_len(tok)));
        if (idx == 0) return rt_errf(L->e, "%s:%lu: face index 0 (OBJ indices start at 1)", L->path, L->line);
        long long abs_i = idx > 0 ? idx - 1 : (long long)L->nv + idx;
        if (abs_i < 0 || abs_i >= (long long)L->nv)
            return rt_errf(L->e, "%s:%lu: face index %lld out of range (%zu vertices)", L->path, L->line, idx,
                           L->nv);
        if (n == L->cf) {
            size_t nc = L->cf ? 2 * L->cf : 16;
            uint32_t *nf = rt_reallocarray(L->face, nc, sizeof *nf, L->e);
            if (!nf) return -1;
            L->face = nf;
            L->cf = nc;
        }
        L->face[n++] = (uint32_t)abs_i;
    }
    if (n < 3) return rt_errf(L->e, "%s:%lu: face has %zu vertices (need at least 3)", L->path, L->line, n);
    for (size_t k = 1; k + 1 < n; k++) {
        if (rt_scene_add_tri(s, L->v[L->face[0]], L->v[L->face[k]], L->v[L->face[k + 1]], NULL, L->e) < 0) {
            /* Put the position in front of the allocator's message. */
            char m[RT_ERR_LEN];
            snprintf(m, sizeof m, "%s", L->e ? L->e->msg : "");
            return rt_errf(L->e, "%s:%lu: %s", L->path, L->line, m);
        }
    }
    return 0;
}

rt_scene *rt_scene_load_obj(const char *path, rt_err *e)
{
    char *buf = NULL;
    size_t n = 0;
    if (rt_slurp(path, &buf, &n, e) < 0) return NULL;
    rt_scene *s = rt_scene_new(0, e);
    if (!s) {
        free(buf);
        return NULL;
    }
    const char *base = strrchr(path, '/');
    snprintf(s->name, sizeof s->name, "%s", base ? base + 1 : path);
    objload L = {path, 0, NULL, 0, 0, NULL, 0, e};
    int rc = 0;
    char *p = buf, *end = buf + n;
    while (p < end && rc == 0) {
        char *nl = memchr(p, '\n', (size_t)(end - p));
        char *le = nl ? nl : end;
        L.line++;
        if (memchr(p, 0, (size_t)(le - p))) {
            rc = rt_errf(e, "%s:%lu: NUL byte in text", path, L.line);
            break;
        }
        *le = 0;
        const char *q = skip_space(p);
        if (q[0] == 'v' && is_space(q[1]))
            rc = vertex_line(&L, q + 2);
        else if (q[0] == 'f' && is_space(q[1]))
            rc = face_line(&L, s, q + 2);
        else if ((q[0] == 'v' || q[0] == 'f') && q[1] == 0)
            rc = rt_errf(e, "%s:%lu: '%c' without data", path, L.line, q[0]);
        /* Anything else (comments, vt, vn, g, o, s, usemtl, ...) is ignored. */
        p = le + 1;
    }
    if (rc == 0 && s->ntri == 0)
        rc = rt_errf(e, "%s:%lu: no faces (empty mesh)", path, L.line);
    free(buf);
    free(L.v);
    free(L.face);
    if (rc == 0) {
        rt_err fe;
        if (rt_scene_finish(s, &fe) < 0) rc = rt_errf(e, "%s: %s", path, fe.msg);
        else rc = rt_scene_check_range(s, path, e);
    }
    if (rc < 0) {
        rt_scene_free(s);
        return NULL;
    }
    rt_scene_autoframe(s);
    return s;
}
