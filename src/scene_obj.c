/*
 * scene_obj.c -- Wavefront OBJ loader.
 *
 * Reads `v x y z [w]` vertices and `f` faces whose corners are written
 * `v`, `v/vt`, `v//vn` or `v/vt/vn`, with positive (1-based) or negative
 * (relative to the vertices read so far) indices. Triangles, quads and
 * n-gons are fan-triangulated from the first corner: (0,1,2), (0,2,3), ...
 * `mtllib` reads MTL material libraries (several names per line, relative
 * to the OBJ's folder and inside it: rt_path_within) and `usemtl` gives the faces after it that
 * material: its Kd becomes the triangles' colour, and Ks, Ke, Ni, d/Tr, Tf
 * and illum become a material table entry (mapping in docs/scenes.md).
 * Faces before any usemtl get the default grey and material 0. Every other
 * statement (vt, vn, g, o, s, l, p, ...) and comments are ignored; lines
 * may end in LF, CRLF or CR alone. Numbers are decimal (hex floats, which
 * strtod would take, are refused). Faces must refer to vertices defined above them,
 * and usemtl to a library named above it.
 *
 * A library that does not exist does not stop the load (meshes are often
 * shared without theirs): its faces get the default material and the scene
 * records a warning in s->warning, which the front end prints. A usemtl
 * naming a material no library defines is an error -- unless a library is
 * missing or none was named, when it is the same warning.
 *
 * Malformed input never crashes and never reads outside the file buffer:
 * the first problem ends the load with one line "FILE:LINE: what", e.g.
 * "mesh.obj:12: face index 9 out of range (8 vertices)". A file without
 * faces, with a NaN/Inf coordinate, or outside the coordinate range the
 * float pipeline resolves (rt_scene_check_range) is rejected; input quoted
 * in a message is escaped (rt_esc).
 * MTL files get the same treatment: "lib.mtl:LINE: what" for bad or
 * NaN/Inf/negative numbers, Ni < 1, d, Tr or Tf outside [0, 1], unknown illum
 * models; keywords we do not use (Ka, Ns, map_Kd, ...) are ignored.
 * Loaded meshes get an auto-framed camera and default lights
 * (rt_scene_autoframe).
 */
#include "config.h"
#include "scene.h"
#include "scene_load.h"
#include "scene_file.h"

#include <errno.h>
#include <float.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>


static int is_space(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\f' || c == '\v'; }

static const char *skip_space(const char *p)
{
    while (is_space(*p)) p++;
    return p;
}

/* The end of the line that starts at p (before end): its first '\n' or
 * '\r' (LF, CRLF and CR-only files all work), or end. *next gets where the
 * next line starts ("\r\n" is one line end). */
static char *line_end(char *p, char *end, char **next)
{
    char *q = p;
    while (q < end && *q != '\n' && *q != '\r') q++;
    *next = q < end ? q + 1 + (*q == '\r' && q + 1 < end && q[1] == '\n') : end;
    return q;
}

/* A hex float ("0x1p3"): strtod takes it, the formats do not. */
static int is_hex_number(const char *p, size_t n)
{
    for (size_t i = 0; i < n && p[i]; i++)
        if (p[i] == 'x' || p[i] == 'X') return 1;
    return 0;
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
    if (end == p || (*end && !is_space(*end)) || is_hex_number(p, (size_t)(end - p))) return 1;
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

/* A material read from an MTL file, with the illum mapping applied. */
typedef struct mtldef {
    char name[256];  /* as written after newmtl */
    float kd[3];     /* diffuse colour for the triangles' rgb */
    rt_material m;   /* ks, kt, ior, ke for the scene's table */
    long table;      /* index in s->mat once a usemtl used it, else -1 */
} mtldef;

typedef struct objload {
    const char *path;
    unsigned long line;
    rt_vec3 *v;   /* vertices so far */
    size_t nv, cv;
    uint32_t *face; /* corner indices of the current face */
    size_t cf;
    rt_err *e;
    rt_scene *s;        /* the scene being built (for warnings) */
    mtldef *mtl;        /* materials of all libraries read, in file order */
    size_t nmtl, cmtl;  /* used, allocated */
    int nlib;           /* mtllib names seen */
    int libmissing;     /* one of them did not exist */
    unsigned nwarn;     /* warnings (the first is kept in s->warning) */
    uint32_t cur_mat;   /* material of the faces that follow */
    const float *cur_rgb; /* their colour (NULL: default grey) */
    float cur_kd[3];    /* storage for cur_rgb */
} objload;

static void warn(objload *L, const char *kind, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;

/* A warning of `kind` at the current line (s->warn, rt_sfile_warn). */
static void warn(objload *L, const char *kind, const char *fmt, ...)
{
    char m[200], first[256];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(m, sizeof m, fmt, ap);
    va_end(ap);
    snprintf(first, sizeof first, "%.230s:%lu", L->path, L->line);
    L->nwarn++;
    rt_err e2;
    (void)rt_sfile_warn(L->s, kind, first, &e2, "%s", m); /* out of memory: the warning is lost, not the scene */
}

/* ------------------------------------------------------------------------ */
/* MTL                                                                       */

static int kw_is(const char *p, size_t n, const char *kw)
{
    if (strlen(kw) != n) return 0;
    for (size_t i = 0; i < n; i++) {
        char a = p[i], b = kw[i];
        if (a >= 'A' && a <= 'Z') a = (char)(a - 'A' + 'a');
        if (b >= 'A' && b <= 'Z') b = (char)(b - 'A' + 'a');
        if (a != b) return 0;
    }
    return 1;
}

/* Terms of the material being read, before the illum mapping. */
typedef struct mtlraw {
    float kd[3], ks[3], ke[3], tf[3];
    float ni;        /* Ni, default 1 */
    float t;         /* transmittance from d (1 - d) or Tr; < 0 = not given */
    int illum;       /* default 2 */
} mtlraw;

static void raw_init(mtlraw *r)
{
    for (int k = 0; k < 3; k++) {
        r->kd[k] = 0.7f; /* the loaders' default grey */
        r->ks[k] = r->ke[k] = 0;
        r->tf[k] = 1;
    }
    r->ni = 1;
    r->t = -1;
    r->illum = 2;
}

/* The illum mapping (docs/scenes.md: Materials): 0-2 and 10 diffuse (Ks
 * ignored), 3, 5, 8 mirror with Ks, 4, 6, 7, 9 glass: Ks reflection and
 * transmittance t*Tf (t = 1 when neither d nor Tr is given) with index Ni. */
static void raw_finish(const mtlraw *r, mtldef *d)
{
    rt_material *m = &d->m;
    memset(m, 0, sizeof *m);
    size_t nl = strlen(d->name);
    if (nl >= sizeof m->name) nl = sizeof m->name - 1; /* the table keeps a prefix */
    memcpy(m->name, d->name, nl);
    m->ior = 1;
    int mirror = r->illum == 3 || r->illum == 5 || r->illum == 8;
    int glass = r->illum == 4 || r->illum == 6 || r->illum == 7 || r->illum == 9;
    float t = r->t < 0 ? 1.0f : r->t;
    int clear = 0;
    for (int k = 0; k < 3; k++) {
        d->kd[k] = r->kd[k];
        m->ke[k] = r->ke[k];
        if (mirror || glass) m->ks[k] = r->ks[k];
        if (glass) m->kt[k] = t * r->tf[k];
        if (m->kt[k] > 0) clear = 1;
    }
    if (clear) m->ior = r->ni;
    d->table = -1;
}

typedef struct mtlread {
    objload *L;
    const char *path;    /* of the MTL file, for messages */
    unsigned long line;
} mtlread;

/* Parses the numbers after a keyword into v (at most nmax); 0 or -1 with
 * a message naming the MTL file and line. */
static int mtl_numbers(mtlread *R, const char *kw, const char *p, float *v, int nmax, int *nout)
{
    int n = 0;
    for (;;) {
        p = skip_space(p);
        if (!*p) break;
        const char *tok = p;
        char *end;
        double x = strtod(p, &end);
        char q[64];
        if (end == p || (*end && !is_space(*end)) || is_hex_number(p, (size_t)(end - p)))
            return rt_errf(R->L->e, "%s:%lu: %s: bad number '%s'", R->path, R->line, kw,
                           rt_esc(q, sizeof q, tok, (size_t)token_len(tok)));
        if (!isfinite(x) || fabs(x) > 1e30)
            return rt_errf(R->L->e, "%s:%lu: %s: '%s' is not a finite number", R->path, R->line, kw,
                           rt_esc(q, sizeof q, tok, (size_t)token_len(tok)));
        if (x < 0)
            return rt_errf(R->L->e, "%s:%lu: %s: negative value '%s'", R->path, R->line, kw,
                           rt_esc(q, sizeof q, tok, (size_t)token_len(tok)));
        if (n == nmax) return rt_errf(R->L->e, "%s:%lu: %s: more than %d numbers", R->path, R->line, kw, nmax);
        v[n++] = (float)x;
        p = end;
    }
    if (n == 0) return rt_errf(R->L->e, "%s:%lu: %s without a value", R->path, R->line, kw);
    *nout = n;
    return 0;
}

/* "K? r [g b]": one number stands for grey. */
static int mtl_colour(mtlread *R, const char *kw, const char *p, float out[3])
{
    float v[3];
    int n;
    if (mtl_numbers(R, kw, p, v, 3, &n) < 0) return -1;
    if (n == 2) return rt_errf(R->L->e, "%s:%lu: %s: 2 numbers (need 1 or 3)", R->path, R->line, kw);
    for (int k = 0; k < 3; k++) out[k] = v[n == 1 ? 0 : k];
    return 0;
}

static int mtl_scalar(mtlread *R, const char *kw, const char *p, float *out)
{
    int n;
    return mtl_numbers(R, kw, p, out, 1, &n);
}

static int mtl_add(objload *L, const char *name, size_t len)
{
    if (L->nmtl == L->cmtl) {
        size_t nc = L->cmtl ? 2 * L->cmtl : 16;
        mtldef *nm = rt_reallocarray(L->mtl, nc, sizeof *nm, L->e);
        if (!nm) return -1;
        L->mtl = nm;
        L->cmtl = nc;
    }
    mtldef *d = &L->mtl[L->nmtl++];
    memset(d, 0, sizeof *d);
    memcpy(d->name, name, len);
    d->name[len] = 0;
    d->table = -1;
    return 0;
}

/* Trims a statement's argument: leading and trailing blanks. */
static size_t rest_len(const char *p)
{
    size_t n = strlen(p);
    while (n && is_space(p[n - 1])) n--;
    return n;
}

/* Reads the material library at mpath. 0, -1 with a message, or -2 (no
 * message) when the file does not exist. */
static int load_mtl(objload *L, const char *mpath)
{
    char *buf = NULL;
    size_t n = 0;
    if (rt_sfile_slurp(mpath, rt_scene_max_bytes, &buf, &n, L->e) < 0) {
        if (errno == ENOENT) return -2;
        char m[RT_ERR_LEN];
        snprintf(m, sizeof m, "%s", L->e ? L->e->msg : "");
        return rt_errf(L->e, "%s:%lu: material library %s", L->path, L->line, m);
    }
    mtlread R = {L, mpath, 0};
    mtlraw raw;
    raw_init(&raw);
    int open = 0, rc = 0;
    char *p = buf, *end = buf + n;
    while (p < end && rc == 0) {
        char *next, *le = line_end(p, end, &next);
        R.line++;
        if (memchr(p, 0, (size_t)(le - p))) {
            rc = rt_errf(L->e, "%s:%lu: NUL byte in text", mpath, R.line);
            break;
        }
        *le = 0;
        char *hash = strchr(p, '#');
        if (hash) *hash = 0;
        const char *q = skip_space(p);
        size_t kl = 0;
        while (q[kl] && !is_space(q[kl])) kl++;
        const char *arg = skip_space(q + kl);
        char kw[16];
        snprintf(kw, sizeof kw, "%.*s", (int)(kl < 15 ? kl : 15), q);
        if (kl == 0) {
            /* blank or comment */
        } else if (kw_is(q, kl, "newmtl")) {
            size_t len = rest_len(arg);
            if (len == 0) rc = rt_errf(L->e, "%s:%lu: newmtl without a name", mpath, R.line);
            else if (len >= sizeof L->mtl[0].name)
                rc = rt_errf(L->e, "%s:%lu: material name longer than %zu bytes", mpath, R.line,
                             sizeof L->mtl[0].name - 1);
            else {
                if (open) raw_finish(&raw, &L->mtl[L->nmtl - 1]);
                raw_init(&raw);
                rc = mtl_add(L, arg, len);
                open = 1;
            }
        } else if (kw_is(q, kl, "Kd") || kw_is(q, kl, "Ks") || kw_is(q, kl, "Ke") || kw_is(q, kl, "Tf") ||
                   kw_is(q, kl, "Ni") || kw_is(q, kl, "d") || kw_is(q, kl, "Tr") || kw_is(q, kl, "illum")) {
            float v;
            if (!open) rc = rt_errf(L->e, "%s:%lu: %s before any newmtl", mpath, R.line, kw);
            else if (kw_is(q, kl, "Kd")) rc = mtl_colour(&R, kw, arg, raw.kd);
            else if (kw_is(q, kl, "Ks")) rc = mtl_colour(&R, kw, arg, raw.ks);
            else if (kw_is(q, kl, "Ke")) rc = mtl_colour(&R, kw, arg, raw.ke);
            else if (kw_is(q, kl, "Tf")) {
                /* A filter: more than 1 would make glass amplify light. */
                rc = mtl_colour(&R, kw, arg, raw.tf);
                for (int k = 0; k < 3 && rc == 0; k++)
                    if (raw.tf[k] > 1)
                        rc = rt_errf(L->e, "%s:%lu: Tf %g outside [0, 1]", mpath, R.line, (double)raw.tf[k]);
            }
            else if ((rc = mtl_scalar(&R, kw, arg, &v)) == 0) {
                if (kw_is(q, kl, "Ni")) {
                    if (!(v >= 1.0f && v <= 100.0f))
                        rc = rt_errf(L->e, "%s:%lu: Ni %g outside [1, 100] (index of refraction)", mpath, R.line,
                                     (double)v);
                    raw.ni = v;
                } else if (kw_is(q, kl, "illum")) {
                    if (v > 10 || v != (float)(int)v)
                        rc = rt_errf(L->e, "%s:%lu: illum %g is not an illumination model 0..10", mpath, R.line,
                                     (double)v);
                    raw.illum = (int)v;
                } else {
                    if (v > 1) rc = rt_errf(L->e, "%s:%lu: %s %g outside [0, 1]", mpath, R.line, kw, (double)v);
                    raw.t = kw_is(q, kl, "d") ? 1.0f - v : v;
                }
            }
        }
        /* Other keywords (Ka, Ns, map_Kd, bump, ...) do not affect the
         * rays; ignored. */
        p = next;
    }
    if (rc == 0 && open) raw_finish(&raw, &L->mtl[L->nmtl - 1]);
    free(buf);
    return rc;
}

/* mtllib NAME...: each relative to the OBJ's folder, and inside it
 * (rt_path_within: no absolute path, no '..' above the folder). */
static int mtllib_line(objload *L, const char *p)
{
    size_t pl = strlen(L->path);
    char *dir = rt_calloc(pl + 1, 1, L->e);
    if (!dir) return -1;
    rt_path_dir(L->path, dir, pl + 1);
    int any = 0, rc = 0;
    for (;;) {
        p = skip_space(p);
        if (!*p) break;
        size_t tl = 0;
        while (p[tl] && !is_space(p[tl])) tl++;
        any = 1;
        L->nlib++;
        size_t mn = pl + tl + 2;
        char *name = rt_calloc(tl + 1, 1, L->e), *mp = name ? rt_calloc(mn, 1, L->e) : NULL;
        if (!mp) {
            free(name);
            rc = -1;
            break;
        }
        memcpy(name, p, tl);
        rt_err pe;
        char q[160];
        if (rt_path_within(dir, name, mp, mn, &pe) < 0) {
            rc = rt_errf(L->e, "%s:%lu: material library %s (docs/scenes.md: files a scene names)", L->path, L->line,
                         pe.msg);
        } else if ((rc = load_mtl(L, mp)) == -2) {
            L->libmissing = 1;
            warn(L, "mtllib missing", "material library %s not found; its materials are the default",
                 rt_esc(q, sizeof q, mp, 4096));
            rc = 0;
        }
        free(name);
        free(mp);
        if (rc < 0) break;
        p += tl;
    }
    free(dir);
    if (rc < 0) return -1;
    if (!any) return rt_errf(L->e, "%s:%lu: mtllib without a file name", L->path, L->line);
    return 0;
}

static int usemtl_line(objload *L, const char *p)
{
    p = skip_space(p);
    size_t len = rest_len(p);
    char q[64];
    if (len == 0) return rt_errf(L->e, "%s:%lu: usemtl without a name", L->path, L->line);
    for (size_t i = 0; i < L->nmtl; i++) {
        mtldef *d = &L->mtl[i];
        if (strlen(d->name) != len || memcmp(d->name, p, len) != 0) continue;
        if (d->table < 0) {
            int r = rt_scene_add_material(L->s, &d->m, L->e);
            if (r < 0) {
                char m[RT_ERR_LEN];
                snprintf(m, sizeof m, "%s", L->e ? L->e->msg : "");
                return rt_errf(L->e, "%s:%lu: %s", L->path, L->line, m);
            }
            d->table = r;
        }
        L->cur_mat = (uint32_t)d->table;
        memcpy(L->cur_kd, d->kd, sizeof L->cur_kd);
        L->cur_rgb = L->cur_kd;
        return 0;
    }
    rt_esc(q, sizeof q, p, len);
    if (L->nlib == 0 || L->libmissing) {
        warn(L, "usemtl unknown", "usemtl %s: %s; default material", q,
             L->nlib ? "not in the libraries found" : "no mtllib names a library");
        L->cur_mat = 0;
        L->cur_rgb = NULL;
        return 0;
    }
    return rt_errf(L->e, "%s:%lu: usemtl %s: no such material in the libraries named above", L->path, L->line, q);
}

/* ------------------------------------------------------------------------ */
/* OBJ                                                                       */

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
        if (rt_scene_add_tri_mat(s, L->v[L->face[0]], L->v[L->face[k]], L->v[L->face[k + 1]], L->cur_rgb,
                                 L->cur_mat, L->e) < 0) {
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
    if (rt_sfile_slurp(path, rt_scene_max_bytes, &buf, &n, e) < 0) return NULL;
    rt_scene *s = rt_scene_new(0, e);
    if (!s) {
        free(buf);
        return NULL;
    }
    const char *base = strrchr(path, '/');
    snprintf(s->name, sizeof s->name, "%s", base ? base + 1 : path);
    objload L;
    memset(&L, 0, sizeof L);
    L.path = path;
    L.e = e;
    L.s = s;
    int rc = 0;
    char *p = buf, *end = buf + n;
    while (p < end && rc == 0) {
        char *next, *le = line_end(p, end, &next);
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
        else if (!strncmp(q, "mtllib", 6) && (is_space(q[6]) || !q[6]))
            rc = mtllib_line(&L, q + 6);
        else if (!strncmp(q, "usemtl", 6) && (is_space(q[6]) || !q[6]))
            rc = usemtl_line(&L, q + 6);
        /* Anything else (comments, vt, vn, g, o, s, usemtl, ...) is ignored. */
        p = next;
    }
    if (rc == 0 && s->ntri == 0)
        rc = rt_errf(e, "%s:%lu: no faces (empty mesh)", path, L.line);
    free(buf);
    free(L.v);
    free(L.face);
    free(L.mtl);
    if (rc == 0 && L.nwarn) rt_sfile_warn_summary(s); /* the counts as they ended */
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
