/*
 * ply_read.c -- the Stanford PLY reader (ascii, binary_little_endian,
 * binary_big_endian) that every user of PLY data shares: the PLY loader
 * (scene_ply.c), the built-in bunny (scene_builtin.c) and pbrt's
 * "plymesh" (scene_pbrt.c). It parses into vertices and triangle corner
 * indices (ply_read.h) and knows nothing of scenes, so no loader calls
 * another.
 *
 * From the header we need an element `vertex` with scalar properties x, y
 * and z (any of the eight PLY scalar types, under either their old names
 * char/uchar/short/ushort/int/uint/float/double or the sized ones
 * int8...float64) and an element `face` with a list property
 * `vertex_indices` or `vertex_index` (any integer count and index types).
 * Every other element and property, list properties included, is parsed and
 * skipped. Elements may come in any order: faces are collected as index
 * triples (fan triangulation) and resolved once all data is read.
 *
 * Errors are one line: header problems and ascii data as "FILE:LINE: what",
 * binary data as "FILE: byte OFFSET: what" (offset of the value that could
 * not be read). Every read is bounds-checked against the file buffer;
 * element counts are checked against the bytes remaining before anything is
 * allocated, so a lying header cannot make us allocate gigabytes.
 * Invariants of a parsed mesh (rt_ply_mesh): (P1) every index is below nv;
 * (P2) nidx is a multiple of 3; (P3) every coordinate is finite and within
 * RT_COORD_MAX.
 */
#include "config.h"
#include "ply_read.h"
#include "scene_file.h"

#include <errno.h>
#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

enum { T_I8, T_U8, T_I16, T_U16, T_I32, T_U32, T_F32, T_F64, T_NTYPES };

static const struct {
    const char *name, *alias;
    int size;
} ply_types[T_NTYPES] = {
    {"char", "int8", 1},     {"uchar", "uint8", 1}, {"short", "int16", 2},   {"ushort", "uint16", 2},
    {"int", "int32", 4},     {"uint", "uint32", 4}, {"float", "float32", 4}, {"double", "float64", 8},
};

static int type_of(const char *s)
{
    for (int i = 0; i < T_NTYPES; i++)
        if (!strcmp(s, ply_types[i].name) || !strcmp(s, ply_types[i].alias)) return i;
    return -1;
}

static int is_int_type(int t) { return t != T_F32 && t != T_F64; }

#define MAXELEM 32
#define MAXPROP 64

typedef struct plyprop {
    char name[40]; /* property name (truncated) */
    int type;      /* scalar type, or item type of a list */
    int is_list;   /* 1 for list properties */
    int ctype;     /* list count type */
} plyprop;

typedef struct plyelem {
    char name[40];     /* element name (truncated) */
    uint32_t count;    /* instances */
    unsigned long line; /* header line declaring it */
    int nprop;         /* properties */
    plyprop prop[MAXPROP];
} plyelem;

enum { F_ASCII, F_LE, F_BE };

typedef struct plyload {
    const char *path;
    const unsigned char *buf; /* whole file, NUL-terminated */
    size_t n;                 /* file size */
    size_t pos;               /* read position in the data section */
    unsigned long line;       /* ascii: current line */
    int fmt;                  /* F_ASCII, F_LE, F_BE */
    rt_err *e;
} plyload;


/* ------------------------------------------------------------------------ */
/* Header                                                                    */

/* Splits a header line (modified in place) into at most 8 tokens. */
static int split(char *s, char **tok, int max)
{
    int n = 0;
    for (;;) {
        while (*s == ' ' || *s == '\t' || *s == '\r') s++;
        if (!*s) break;
        if (n == max) return max + 1;
        tok[n++] = s;
        while (*s && *s != ' ' && *s != '\t' && *s != '\r') s++;
        if (*s) *s++ = 0;
    }
    return n;
}

/* An element with instances but no properties takes no bytes, so the file
 * size cannot bound its count (4294967295 of them would spin): refused. */
#define CHECK_PROPS(E)                                                                                           \
    do {                                                                                                         \
        if ((E)->count > 0 && (E)->nprop == 0)                                                                   \
            return rt_errf(L->e, "%s:%lu: element '%s' has %u instances but no properties", L->path, (E)->line,   \
                           rt_esc(q, sizeof q, (E)->name, 40), (E)->count);                                      \
    } while (0)

static int parse_header(plyload *L, plyelem *el, int *nel)
{
    const char *b = (const char *)L->buf;
    size_t n = L->n, p = 0;
    char line[512], q[64];
    int nelem = 0, have_format = 0;
    L->line = 0;
    for (;;) {
        if (p >= n) return rt_errf(L->e, "%s:%lu: header has no end_header line", L->path, L->line + 1);
        const char *nl = memchr(b + p, '\n', n - p);
        if (!nl) return rt_errf(L->e, "%s:%lu: header has no end_header line", L->path, L->line + 1);
        size_t len = (size_t)(nl - (b + p));
        L->line++;
        if (memchr(b + p, 0, len)) return rt_errf(L->e, "%s:%lu: NUL byte in header", L->path, L->line);
        if (len >= sizeof line) return rt_errf(L->e, "%s:%lu: header line too long", L->path, L->line);
        memcpy(line, b + p, len);
        line[len] = 0;
        p += len + 1;
        char *tok[8];
        int nt = split(line, tok, 8);
        if (L->line == 1) {
            if (nt != 1 || strcmp(tok[0], "ply"))
                return rt_errf(L->e, "%s:1: not a PLY file (no 'ply' magic line)", L->path);
            continue;
        }
        if (nt == 0) continue;
        if (!strcmp(tok[0], "comment") || !strcmp(tok[0], "obj_info")) continue;
        if (nt > 8) return rt_errf(L->e, "%s:%lu: too many words in header line", L->path, L->line);
        if (strcmp(tok[0], "format") && !have_format)
            return rt_errf(L->e, "%s:%lu: expected a format line before '%s'", L->path, L->line,
                           rt_esc(q, sizeof q, tok[0], 40));
        if (!strcmp(tok[0], "format")) {
            if (have_format) return rt_errf(L->e, "%s:%lu: second format line", L->path, L->line);
            have_format = 1;
            if (nt != 3) return rt_errf(L->e, "%s:%lu: format line needs a format and a version", L->path, L->line);
            if (!strcmp(tok[1], "ascii")) L->fmt = F_ASCII;
            else if (!strcmp(tok[1], "binary_little_endian")) L->fmt = F_LE;
            else if (!strcmp(tok[1], "binary_big_endian")) L->fmt = F_BE;
            else return rt_errf(L->e, "%s:%lu: unknown format '%s'", L->path, L->line, rt_esc(q, sizeof q, tok[1], 40));
            if (strcmp(tok[2], "1.0") && strcmp(tok[2], "1"))
                return rt_errf(L->e, "%s:%lu: unsupported PLY version '%s'", L->path, L->line,
                               rt_esc(q, sizeof q, tok[2], 40));
            if (L->line != 2) return rt_errf(L->e, "%s:%lu: format line must follow 'ply'", L->path, L->line);
        } else if (!strcmp(tok[0], "element")) {
            if (nt != 3) return rt_errf(L->e, "%s:%lu: element line needs a name and a count", L->path, L->line);
            if (nelem == MAXELEM) return rt_errf(L->e, "%s:%lu: too many elements", L->path, L->line);
            char *end;
            errno = 0;
            unsigned long long c = strtoull(tok[2], &end, 10);
            if (*end || end == tok[2] || tok[2][0] < '0' || tok[2][0] > '9' || errno || c > UINT32_MAX)
                return rt_errf(L->e, "%s:%lu: bad element count '%s'", L->path, L->line, rt_esc(q, sizeof q, tok[2], 40));
            if (nelem > 0) CHECK_PROPS(&el[nelem - 1]);
            plyelem *E = &el[nelem++];
            memset(E, 0, sizeof *E);
            rt_esc(E->name, sizeof E->name, tok[1], 39); /* names reach messages */
            E->count = (uint32_t)c;
            E->line = L->line;
        } else if (!strcmp(tok[0], "property")) {
            if (nelem == 0) return rt_errf(L->e, "%s:%lu: property before any element", L->path, L->line);
            plyelem *E = &el[nelem - 1];
            if (E->nprop == MAXPROP) return rt_errf(L->e, "%s:%lu: too many properties", L->path, L->line);
            plyprop *P = &E->prop[E->nprop];
            if (nt >= 2 && !strcmp(tok[1], "list")) {
                if (nt != 5) return rt_errf(L->e, "%s:%lu: bad list property line", L->path, L->line);
                P->is_list = 1;
                P->ctype = type_of(tok[2]);
                P->type = type_of(tok[3]);
                if (P->ctype < 0 || P->type < 0)
                    return rt_errf(L->e, "%s:%lu: unknown property type '%s'", L->path, L->line,
                                   rt_esc(q, sizeof q, P->ctype < 0 ? tok[2] : tok[3], 40));
                if (!is_int_type(P->ctype))
                    return rt_errf(L->e, "%s:%lu: list count type '%s' is not an integer type", L->path, L->line,
                                   rt_esc(q, sizeof q, tok[2], 40));
                rt_esc(P->name, sizeof P->name, tok[4], 39);
            } else {
                if (nt != 3) return rt_errf(L->e, "%s:%lu: bad property line", L->path, L->line);
                P->type = type_of(tok[1]);
                if (P->type < 0)
                    return rt_errf(L->e, "%s:%lu: unknown property type '%s'", L->path, L->line,
                                   rt_esc(q, sizeof q, tok[1], 40));
                rt_esc(P->name, sizeof P->name, tok[2], 39);
            }
            for (int k = 0; k < E->nprop; k++)
                if (!strcmp(E->prop[k].name, P->name))
                    return rt_errf(L->e, "%s:%lu: property '%s' given twice in element '%s'", L->path, L->line,
                                   P->name, E->name);
            E->nprop++;
        } else if (!strcmp(tok[0], "end_header")) {
            if (nt != 1) return rt_errf(L->e, "%s:%lu: bad end_header line", L->path, L->line);
            if (nelem > 0) CHECK_PROPS(&el[nelem - 1]);
            break;
        } else {
            return rt_errf(L->e, "%s:%lu: unknown header keyword '%s'", L->path, L->line,
                           rt_esc(q, sizeof q, tok[0], 40));
        }
    }
    if (L->line < 3) return rt_errf(L->e, "%s:%lu: header lacks a format line", L->path, L->line);
    L->pos = p;
    L->line++; /* ascii data starts on the line after end_header */
    *nel = nelem;
    return 0;
}

/* ------------------------------------------------------------------------ */
/* Data                                                                      */

typedef struct val {
    double d;    /* value as double (exact for every PLY integer type) */
    long long i; /* value as integer, for integer types */
} val;

static int read_ascii(plyload *L, int type, const char *what, val *v)
{
    const char *b = (const char *)L->buf;
    while (L->pos < L->n) {
        char c = b[L->pos];
        if (c == '\n') L->line++;
        else if (c != ' ' && c != '\t' && c != '\r' && c != '\f' && c != '\v') break;
        L->pos++;
    }
    if (L->pos >= L->n) return rt_errf(L->e, "%s:%lu: truncated %s data", L->path, L->line, what);
    const char *tok = b + L->pos;
    if (*tok == 0) return rt_errf(L->e, "%s:%lu: NUL byte in %s data", L->path, L->line, what);
    int tl = 0;
    while (L->pos + (size_t)tl < L->n && tok[tl] && !strchr(" \t\r\n\f\v", tok[tl])) tl++;
    char buf[64];
    if (tl >= (int)sizeof buf) return rt_errf(L->e, "%s:%lu: bad number '%.20s...'", L->path, L->line, tok);
    memcpy(buf, tok, (size_t)tl);
    buf[tl] = 0;
    char *end;
    errno = 0;
    if (is_int_type(type)) {
        long long x = strtoll(buf, &end, 10);
        if (*end || end == buf || errno)
            return rt_errf(L->e, "%s:%lu: bad integer '%s' in %s data", L->path, L->line, buf, what);
        static const long long lo[] = {-128, 0, -32768, 0, -2147483648LL, 0};
        static const long long hi[] = {127, 255, 32767, 65535, 2147483647LL, 4294967295LL};
        if (x < lo[type] || x > hi[type])
            return rt_errf(L->e, "%s:%lu: %s value %lld out of range in %s data", L->path, L->line,
                           ply_types[type].name, x, what);
        v->i = x;
        v->d = (double)x;
    } else {
        double x = strtod(buf, &end);
        if (*end || end == buf || strchr(buf, 'x') || strchr(buf, 'X')) /* no hex floats */
            return rt_errf(L->e, "%s:%lu: bad number '%s' in %s data", L->path, L->line, buf, what);
        v->d = x;
        v->i = 0;
    }
    L->pos += (size_t)tl;
    return 0;
}

static int read_binary(plyload *L, int type, const char *what, val *v)
{
    int sz = ply_types[type].size;
    if (L->n - L->pos < (size_t)sz)
        return rt_errf(L->e, "%s: byte %zu: truncated %s data", L->path, L->pos, what);
    const unsigned char *p = L->buf + L->pos;
    uint64_t u = 0;
    for (int k = 0; k < sz; k++) {
        int idx = L->fmt == F_LE ? sz - 1 - k : k;
        u = (u << 8) | p[idx];
    }
    L->pos += (size_t)sz;
    switch (type) {
    case T_I8: v->i = (int8_t)(uint8_t)u; break;
    case T_U8: v->i = (uint8_t)u; break;
    case T_I16: v->i = (int16_t)(uint16_t)u; break;
    case T_U16: v->i = (uint16_t)u; break;
    case T_I32: v->i = (int32_t)(uint32_t)u; break;
    case T_U32: v->i = (uint32_t)u; break;
    case T_F32: {
        uint32_t w = (uint32_t)u;
        float f;
        memcpy(&f, &w, 4);
        v->d = f;
        v->i = 0;
        return 0;
    }
    default: {
        double d;
        memcpy(&d, &u, 8);
        v->d = d;
        v->i = 0;
        return 0;
    }
    }
    v->d = (double)v->i;
    return 0;
}

static int read_val(plyload *L, int type, const char *what, val *v)
{
    return L->fmt == F_ASCII ? read_ascii(L, type, what, v) : read_binary(L, type, what, v);
}

/* Where the last value started, for messages. */
static void where(const plyload *L, size_t at, char *buf, size_t n)
{
    if (L->fmt == F_ASCII) snprintf(buf, n, "%s:%lu", L->path, L->line);
    else snprintf(buf, n, "%s: byte %zu", L->path, at);
}


typedef struct idxbuf {
    uint32_t *v; /* triangle corner indices, 3 per triangle */
    size_t n, cap;
} idxbuf;

static int push3(idxbuf *B, uint32_t a, uint32_t b, uint32_t c, rt_err *e)
{
    if (B->n + 3 > B->cap) {
        size_t nc = B->cap ? 2 * B->cap : 3 * 1024;
        uint32_t *nv = rt_reallocarray(B->v, nc, sizeof *nv, e);
        if (!nv) return -1;
        B->v = nv;
        B->cap = nc;
    }
    B->v[B->n++] = a;
    B->v[B->n++] = b;
    B->v[B->n++] = c;
    return 0;
}

/* Bytes one record of E needs at least in binary (lists: their count). */
static uint64_t min_record_size(const plyelem *E)
{
    uint64_t s = 0;
    for (int i = 0; i < E->nprop; i++)
        s += (uint64_t)ply_types[E->prop[i].is_list ? E->prop[i].ctype : E->prop[i].type].size;
    return s;
}

/* What the mesh needs from the header: element and property indices. */
typedef struct plyneed {
    int vi, fi;     /* vertex and face elements */
    int px, py, pz; /* x, y, z properties of vertex */
    int pl;         /* vertex_indices list of face */
    uint32_t nvert; /* vertices */
} plyneed;

static int locate(const plyload *L, const plyelem *el, int nel, plyneed *N)
{
    N->vi = N->fi = N->px = N->py = N->pz = N->pl = -1;
    for (int i = 0; i < nel; i++) {
        if (!strcmp(el[i].name, "vertex") && N->vi < 0) {
            N->vi = i;
            for (int k = 0; k < el[i].nprop; k++) {
                const plyprop *P = &el[i].prop[k];
                int *slot = !strcmp(P->name, "x") ? &N->px : !strcmp(P->name, "y") ? &N->py
                          : !strcmp(P->name, "z") ? &N->pz : NULL;
                if (slot && !P->is_list) *slot = k;
            }
        } else if (!strcmp(el[i].name, "face") && N->fi < 0) {
            N->fi = i;
            for (int k = 0; k < el[i].nprop; k++) {
                const plyprop *P = &el[i].prop[k];
                if (P->is_list && (!strcmp(P->name, "vertex_indices") || !strcmp(P->name, "vertex_index"))) N->pl = k;
            }
        }
    }
    if (N->vi < 0) return rt_errf(L->e, "%s: no 'vertex' element in header", L->path);
    if (N->px < 0 || N->py < 0 || N->pz < 0)
        return rt_errf(L->e, "%s: vertex element lacks scalar x, y and z properties", L->path);
    if (N->fi < 0 || N->pl < 0)
        return rt_errf(L->e, "%s: no 'face' element with a vertex_indices list (point clouds are not supported)",
                       L->path);
    const plyprop *P = &el[N->fi].prop[N->pl];
    if (!is_int_type(P->type))
        return rt_errf(L->e, "%s: face index type '%s' is not an integer type", L->path, ply_types[P->type].name);
    N->nvert = el[N->vi].count;
    if (N->nvert == 0 || el[N->fi].count == 0)
        return rt_errf(L->e, "%s: empty mesh (%u vertices, %u faces)", L->path, N->nvert, el[N->fi].count);
    return 0;
}

/* The header's counts must fit in the bytes left before anything is
 * allocated or looped over: in ascii every value (a scalar or a list's
 * count) takes a digit and a separator, so V values need 2V-1 bytes; in
 * binary each record takes at least its fixed-size part. Elements without
 * properties occupy no bytes, so their count is unchecked by the file:
 * parse_header refuses them. */
static int check_counts(const plyload *L, const plyelem *el, int nel)
{
    uint64_t left = L->n - L->pos, need = 0;
    for (int i = 0; i < nel; i++) {
        need += (uint64_t)el[i].count * (L->fmt == F_ASCII ? (uint64_t)el[i].nprop : min_record_size(&el[i]));
        if (L->fmt == F_ASCII ? need <= (left + 1) / 2 : need <= left) continue;
        if (L->fmt == F_ASCII)
            return rt_errf(L->e, "%s:%lu: truncated %s data (%u declared; the elements so far need %llu values, "
                                 "the %llu bytes of data hold at most %llu)", L->path, L->line, el[i].name,
                           el[i].count, (unsigned long long)need, (unsigned long long)left,
                           (unsigned long long)((left + 1) / 2));
        return rt_errf(L->e, "%s: byte %zu: truncated %s data (%u declared; the elements so far need %llu bytes, "
                             "the file has %llu)", L->path, L->n, el[i].name, el[i].count, (unsigned long long)need,
                       (unsigned long long)left);
    }
    return 0;
}

/* Reads one scalar property; stores it if it is a vertex coordinate. */
static int read_scalar(plyload *L, const plyelem *el, const plyneed *N, int i, int k, uint32_t r, rt_vec3 *verts)
{
    const plyprop *P = &el[i].prop[k];
    size_t at = L->pos;
    val v;
    if (read_val(L, P->type, el[i].name, &v) < 0) return -1;
    if (i != N->vi || (k != N->px && k != N->py && k != N->pz)) return 0;
    if (!isfinite(v.d) || fabs(v.d) > RT_COORD_MAX) {
        char w[300];
        where(L, at, w, sizeof w);
        if (!isfinite(v.d)) return rt_errf(L->e, "%s: vertex %u: coordinate is not a finite number", w, r);
        return rt_errf(L->e, "%s: vertex %u: coordinate %.9g out of range (|c| <= %g, docs/scenes.md)", w, r, v.d,
                       RT_COORD_MAX);
    }
    float f = (float)v.d;
    if (k == N->px) verts[r].x = f;
    else if (k == N->py) verts[r].y = f;
    else verts[r].z = f;
    return 0;
}

/* Reads one list property; the face list becomes fan triangles. */
static int read_list(plyload *L, const plyelem *el, const plyneed *N, int i, int k, uint32_t r, idxbuf *tris)
{
    const plyprop *P = &el[i].prop[k];
    size_t at = L->pos;
    val v;
    if (read_val(L, P->ctype, el[i].name, &v) < 0) return -1;
    long long cnt = v.i;
    int want = i == N->fi && k == N->pl;
    char w[300];
    if (cnt < 0 || (want && cnt < 3)) {
        where(L, at, w, sizeof w);
        if (cnt < 0) return rt_errf(L->e, "%s: negative list length %lld", w, cnt);
        return rt_errf(L->e, "%s: face %u has %lld vertices (need at least 3)", w, r, cnt);
    }
    size_t left = L->n - L->pos;
    if (L->fmt == F_ASCII ? (size_t)cnt > (left + 1) / 2 : (size_t)cnt > left / (size_t)ply_types[P->type].size) {
        where(L, at, w, sizeof w);
        return rt_errf(L->e, "%s: truncated %s data (list of %lld)", w, el[i].name, cnt);
    }
    uint32_t first = 0, prev = 0;
    for (long long j = 0; j < cnt; j++) {
        size_t vat = L->pos;
        if (read_val(L, P->type, el[i].name, &v) < 0) return -1;
        if (!want) continue;
        if (v.i < 0 || v.i >= (long long)N->nvert) {
            where(L, vat, w, sizeof w);
            return rt_errf(L->e, "%s: face %u: vertex index %lld out of range (%u vertices)", w, r, v.i, N->nvert);
        }
        uint32_t x = (uint32_t)v.i;
        if (j == 0) first = x;
        else if (j >= 2 && push3(tris, first, prev, x, L->e) < 0) return -1;
        prev = x;
    }
    return 0;
}

static int read_data(plyload *L, const plyelem *el, int nel, const plyneed *N, rt_vec3 *verts, idxbuf *tris)
{
    for (int i = 0; i < nel; i++)
        for (uint32_t r = 0; r < el[i].count; r++)
            for (int k = 0; k < el[i].nprop; k++) {
                int rc = el[i].prop[k].is_list ? read_list(L, el, N, i, k, r, tris)
                                               : read_scalar(L, el, N, i, k, r, verts);
                if (rc < 0) return -1;
            }
    /* The header's counts must account for the whole body: data after the
     * last element means a count that is too small, and dropping it would
     * silently lose geometry. ASCII may end in white space. */
    if (L->fmt == F_ASCII) {
        while (L->pos < L->n && strchr(" \t\r\n\f\v", L->buf[L->pos]) && L->buf[L->pos]) {
            if (L->buf[L->pos] == '\n') L->line++;
            L->pos++;
        }
        if (L->pos < L->n)
            return rt_errf(L->e, "%s:%lu: data after the last element (the header's counts are too small)", L->path,
                           L->line);
    } else if (L->pos < L->n) {
        return rt_errf(L->e, "%s: byte %zu: %zu bytes after the last element (the header's counts are too small)",
                       L->path, L->pos, L->n - L->pos);
    }
    return 0;
}

/* Parses the PLY in buf into vertices (*pverts, caller frees) and triangle
 * corner indices (tris). 0 or -1. */
static int ply_read(const char *path, const char *buf, size_t n, rt_vec3 **pverts, uint32_t *pnv, idxbuf *tris, rt_err *e)
{
    plyload L = {path, (const unsigned char *)buf, n, 0, 0, F_ASCII, e};
    plyelem *el = rt_calloc(MAXELEM, sizeof *el, e);
    rt_vec3 *verts = NULL;
    plyneed N;
    int nel = 0, rc = -1;
    if (el && parse_header(&L, el, &nel) == 0 && locate(&L, el, nel, &N) == 0 && check_counts(&L, el, nel) == 0 &&
        (verts = rt_calloc(N.nvert, sizeof *verts, e)) && read_data(&L, el, nel, &N, verts, tris) == 0)
        rc = 0;
    free(el);
    if (rc < 0) free(verts);
    else {
        *pverts = verts;
        *pnv = N.nvert;
    }
    return rc;
}

int rt_ply_parse(const char *path, const char *buf, size_t n, rt_ply_mesh *m, rt_err *e)
{
    memset(m, 0, sizeof *m);
    idxbuf tris = {NULL, 0, 0};
    rt_vec3 *verts = NULL;
    uint32_t nv = 0;
    if (ply_read(path, buf, n, &verts, &nv, &tris, e) < 0) {
        free(tris.v);
        return -1;
    }
    m->v = verts;
    m->nv = nv;
    m->idx = tris.v;
    m->nidx = tris.n;
    return 0;
}

int rt_ply_read_file(const char *path, rt_ply_mesh *m, rt_err *e)
{
    char *buf = NULL;
    size_t n = 0;
    memset(m, 0, sizeof *m);
    if (rt_sfile_slurp(path, rt_scene_max_bytes, &buf, &n, e) < 0) return -1;
    int rc = rt_ply_parse(path, buf, n, m, e);
    free(buf);
    return rc;
}

void rt_ply_mesh_free(rt_ply_mesh *m)
{
    if (!m) return;
    free(m->v);
    free(m->idx);
    memset(m, 0, sizeof *m);
}

int rt_ply_check(const rt_ply_mesh *m, rt_err *e)
{
    if (m->nidx % 3) return rt_errf(e, "PLY mesh: %zu corner indices, not a multiple of 3 (P2)", m->nidx);
    for (size_t i = 0; i < m->nidx; i++)
        if (m->idx[i] >= m->nv)
            return rt_errf(e, "PLY mesh: index %zu is %u, not below %u vertices (P1)", i, (unsigned)m->idx[i], (unsigned)m->nv);
    for (uint32_t i = 0; i < m->nv; i++) {
        const rt_vec3 p = m->v[i];
        if (!(fabs(p.x) <= RT_COORD_MAX && fabs(p.y) <= RT_COORD_MAX && fabs(p.z) <= RT_COORD_MAX))
            return rt_errf(e, "PLY mesh: vertex %u not finite or beyond %g (P3)", (unsigned)i, RT_COORD_MAX);
    }
    return 0;
}
