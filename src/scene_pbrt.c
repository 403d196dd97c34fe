/*
 * scene_pbrt.c -- pbrt-v4 scene files, the geometry-and-view subset.
 *
 * A pbrt file is a stream of directives (`Shape "trianglemesh" "point3 P"
 * [...]`), each a bare word followed by positional arguments and a
 * parameter list of `"type name" value` pairs, where a value is one token
 * or a bracketed list. The loader reads it in one pass:
 *
 *   lexer     one token at a time from the file on top of an include
 *             stack (comments, quoted strings with escapes, numbers,
 *             brackets, bare words), with line and column; a file's end
 *             is a token of its own, so no directive spans two files and a
 *             file's buffer is freed when it is popped;
 *   state     the graphics state of pbrt (current transformation matrix,
 *             material, area light) with its AttributeBegin/TransformBegin/
 *             ObjectBegin stack, named materials, named coordinate
 *             systems and object definitions (name tables: open hashing);
 *   output    triangles go straight into the rt_scene with the colour and
 *             material table entry of the state (disks, cylinders, spheres
 *             and curves tessellated, PLY files through the shared reader
 *             ply_read.c). An object's triangles are appended like any
 *             others and cut out into the object store at ObjectEnd;
 *             ObjectInstance records the object and its matrix, and once
 *             the file is read every instance is expanded in file order
 *             (instances are flattened, the counts kept); an
 *             ObjectInstance inside an ObjectBegin block (nested
 *             instancing) is expanded at once into the object being
 *             defined.
 *
 * What is mapped and what is skipped is listed in docs/scenes.md ("pbrt
 * scene files"). Invariants: (I1) every triangle in the scene was made
 * under the state current when its Shape was read (world vertices =
 * CTM x object vertices, instances: CTM_instance x CTM_definition x
 * vertices); (I2) the state stack returns to empty at the end of the top
 * file, and every *End pops a frame of its own kind; (I3) memory is bounded
 * by the bytes read (every value held comes from at least two bytes of
 * input, files are capped one by one and in total) and by `maxtri`
 * (checked before any shape, subdivision or instance is generated; a
 * loopsubdiv shape also by maxsubdiv); (I4) every file read is a regular
 * file, opened once and checked on its descriptor, named by a path
 * relative to the file naming it, and no file is read while it is already
 * open on the include stack; (I5) every matrix of the state is finite and
 * every vertex, light and eye it makes is finite and within RT_COORD_MAX.
 *
 * Errors are one line "FILE:LINE:COL: what was expected"; directives of
 * pbrt outside the subset are skipped, and approximations made, with a
 * warning per kind counted and naming the first FILE:LINE, collected in
 * s->warn (rt_sfile_warn; the library never prints).
 * Arithmetic is in double with + - * / and sqrt only (angles through
 * rt_dsincos_deg), so the triangles are the same on every machine.
 */
#include "config.h"
#include "alpha.h"
#include "scene.h"
#include "scene_load.h"
#include "scene_file.h"
#include "ply_read.h"

#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#define MAX_FILE_BYTES ((uint64_t)1 << 30)  /* one scene or PLY file */
#define MAX_TOTAL_BYTES ((uint64_t)1 << 32) /* all files one load reads */
#define MAX_FILES 4096                      /* files one load opens */
#define MAX_DEPTH 32                        /* include nesting */
#define MAX_NEST 4096                       /* AttributeBegin nesting */
#define DEFAULT_MAXTRI (1u << 26)
#define DEFAULT_MAXSUBDIV (1u << 22)        /* triangles one loopsubdiv shape may make */
#define MAX_PARAMS 256                      /* parameters of one directive */

typedef struct mat4 {
    double m[4][4]; /* row-major, applied to column vectors */
} mat4;

/* ------------------------------------------------------------------------ */
/* Lexer                                                                     */

enum { TK_EOF, TK_WORD, TK_STRING, TK_NUMBER, TK_LBRACK, TK_RBRACK };

typedef struct token {
    int kind;          /* TK_* */
    const char *p;     /* text (strings: between the quotes, escapes raw) */
    size_t n;          /* its bytes */
    double num;        /* TK_NUMBER: the value */
    uint32_t line, col; /* 1-based position of the first byte */
} token;

typedef struct srcfile {
    char *path;        /* as shown in messages */
    char *rel;         /* its folder relative to the top folder ("" = the top) */
    char *buf;         /* whole file, NUL-terminated */
    size_t n, pos;     /* size, read position */
    uint32_t line, col; /* position of buf[pos] */
    dev_t dev;         /* identity, for include cycles */
    ino_t ino;
    int pid;           /* its index in pbrt.paths */
    int has_peek;      /* peek holds the next token */
    token peek;
} srcfile;

typedef struct matdef {
    char name[32];          /* named material's name, or the type */
    float rgb[3];           /* diffuse colour of the triangles */
    float ks[3], kt[3], ior; /* the table terms (ke comes from the area light) */
    long tab;               /* its table index without emission, -1 = not looked up yet */
    int invisible;          /* "interface": its shapes are not made (rays pass, as in pbrt) */
} matdef;

typedef struct gstate {
    mat4 ctm;     /* current transformation matrix */
    int mat;      /* index into P->mats */
    int area;     /* 1: shapes emit ke */
    float ke[3];  /* their emitted radiance */
} gstate;

typedef struct frame {
    gstate g;      /* state to restore */
    char kind;     /* 'a' AttributeBegin, 't' TransformBegin, 'o' ObjectBegin */
    char at[200];  /* "FILE:LINE:COL" of the directive that opened it */
} frame;

typedef struct namemap {
    char **key;    /* slot keys (NULL = empty) */
    int *val;      /* slot values */
    size_t n, cap; /* keys held, slots (a power of two, > 2 n) */
} namemap;

typedef struct object {
    uint32_t start, count; /* range in the object store */
    int used;              /* instanced at least once */
} object;

/* An ObjectInstance, expanded once the whole file is read (so a file
 * whose instances exceed maxtri is refused before their triangles are
 * made): the object, the CTM and where the instance goes in the triangle
 * order (the scene's triangle count when it was read). */
typedef struct instrec {
    uint32_t at;    /* triangles made before it (outside instances) */
    int obj;        /* index into objs */
    mat4 ctm;       /* the instance's transformation */
    uint32_t file, line, col; /* where its name stands (file: index into paths), for messages */
} instrec;

typedef struct arealight {
    double c[3], nsum[3]; /* area-weighted centroid sum, sum of edge cross products */
    double area2;         /* sum of |cross| (twice the area) */
    char at[200];         /* "FILE:LINE" of its Shape */
} arealight;

/* A named texture (Texture "name" "float" "imagemap" ...): the image is
 * read at the directive; map is its index among the alpha maps, -1 for a
 * texture of another type or class (an alpha naming it is drawn opaque). */
typedef struct texdef {
    int map;
} texdef;

/* The triangles of one shape with an alpha texture: [first, first +
 * count) in the order the shapes were made (instances not yet expanded),
 * the map and each triangle's three uv (6 floats, owned). */
typedef struct aspan {
    uint32_t first, count, map;
    float *uv;
} aspan;

typedef struct pbrt {
    rt_scene *s;
    rt_err *e;
    int tess;           /* sphere tessellation */
    uint32_t maxtri;    /* triangle limit */
    uint32_t maxsubdiv; /* triangles one loopsubdiv shape may make */
    int keep;           /* RT_LOAD_KEEP_INSTANCES: instances recorded, not flattened */
    srcfile *f[MAX_DEPTH];
    int depth;          /* files on the include stack */
    uint64_t total;     /* bytes read so far */
    int nfiles;         /* files opened so far */
    char **paths;       /* every file pushed, as shown (for instance messages), npaths <= MAX_FILES + 1 */
    int npaths;
    gstate g;           /* current graphics state */
    frame *stack;       /* AttributeBegin/TransformBegin/ObjectBegin frames */
    int nstack, cstack;
    int world;          /* WorldBegin seen */
    int have_camera;
    mat4 cam_ctm;       /* CTM at Camera: camera-from-world */
    double eye[3];      /* the camera's position in the world (have_camera) */
    double fov;         /* perspective fov (degrees), pbrt's shorter image axis */
    double sw[4];       /* screenwindow when have_sw */
    int have_sw;
    double frame_aspect; /* frameaspectratio, 0 = from the film */
    int film_w, film_h; /* Film resolution (0 = no Film) */
    matdef *mats;       /* material definitions; 0 is pbrt's default diffuse 0.5 */
    int nmats, cmats;
    namemap named_mat, named_cs, named_obj;
    mat4 *cs;           /* named coordinate systems */
    int ncs, ccs;
    object *objs;       /* object definitions */
    int nobjs, cobjs;
    rt_tri *otri;       /* object store: triangles and their shading */
    rt_shade *oshade;
    uint32_t on, ocap;
    instrec *inst;      /* ObjectInstances in file order, expanded at the end */
    int ninst, cinst;
    uint64_t pend;      /* their triangles (not yet in s) */
    int in_obj;         /* index of the object being defined, -1 if none */
    uint32_t obj_start; /* its first triangle in the scene */
    uint32_t nonobj;    /* triangles made outside objects and instances */
    rt_vec3 plight[RT_NLIGHTS]; /* point and spot lights */
    int nplight;        /* of them kept (<= RT_NLIGHTS) */
    int nlights_all;    /* lights seen, area lights included */
    arealight *al;      /* area-light shapes outside objects */
    int nal, cal;
    texdef *tex;        /* named textures */
    int ntex, ctex;
    namemap named_tex;
    rt_alpha_map *amap; /* alpha maps read (float imagemap textures) */
    uint32_t namap, camap;
    float *texel;       /* their texels, map after map */
    uint64_t ntexel, ctexel;
    aspan *span;        /* shapes with an alpha texture */
    int alpha_off;      /* spec parameter alpha=0: alpha textures drawn opaque */
    int nspan, cspan;
    const float *cur_rgb; /* colour and table index of the shape being made */
    uint32_t cur_mat;
    token shape_tok;    /* its type string, for messages */
    uint32_t *mslot;    /* material table entries by their terms: open hashing, 0 = empty, else index */
    size_t nmslot;      /* slots (a power of two, > 2 x entries), 0 = none yet */
} pbrt;

static srcfile *cur(pbrt *P) { return P->f[P->depth - 1]; }

static int perr(pbrt *P, const token *t, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;

/* "FILE:LINE:COL: message" at token t of the current file. */
static int perr(pbrt *P, const token *t, const char *fmt, ...)
{
    char m[RT_ERR_LEN];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(m, sizeof m, fmt, ap);
    va_end(ap);
    return rt_errf(P->e, "%s:%u:%u: %s", cur(P)->path, (unsigned)t->line, (unsigned)t->col, m);
}

static void pwarn(pbrt *P, const token *t, const char *key, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 4, 5)))
#endif
    ;

/* Records a warning of kind key at token t (s->warn: one entry per kind,
 * counted, with its first FILE:LINE; rt_sfile_warn). */
static void pwarn(pbrt *P, const token *t, const char *key, const char *fmt, ...)
{
    char m[200], first[256];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(m, sizeof m, fmt, ap);
    va_end(ap);
    snprintf(first, sizeof first, "%.230s:%u", cur(P)->path, (unsigned)t->line);
    rt_err e2;
    (void)rt_sfile_warn(P->s, key, first, &e2, "%s", m); /* out of memory: the warning is lost, not the scene */
}

/* A token quoted for a message (escaped, truncated). */
static const char *tq(char *buf, size_t n, const token *t)
{
    if (t->kind == TK_EOF) return snprintf(buf, n, "the end of the file"), buf;
    char q[64];
    rt_esc(q, sizeof q, t->p, t->n < 40 ? t->n : 40);
    snprintf(buf, n, t->kind == TK_STRING ? "\"%s\"" : "'%s'", q);
    return buf;
}

static int is_blank(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\f' || c == '\v'; }

static int lex(pbrt *P, token *t)
{
    srcfile *F = cur(P);
    if (F->has_peek) {
        *t = F->peek;
        F->has_peek = 0;
        return 0;
    }
    for (;;) {
        if (F->pos >= F->n) {
            t->kind = TK_EOF;
            t->p = "";
            t->n = 0;
            t->line = F->line;
            t->col = F->col;
            return 0;
        }
        char c = F->buf[F->pos];
        if (c == '\n') {
            F->pos++;
            F->line++;
            F->col = 1;
        } else if (is_blank(c)) {
            F->pos++;
            F->col++;
        } else if (c == '#') {
            while (F->pos < F->n && F->buf[F->pos] != '\n' && F->buf[F->pos]) F->pos++;
        } else
            break;
    }
    const char *b = F->buf + F->pos;
    size_t left = F->n - F->pos;
    t->line = F->line;
    t->col = F->col;
    t->p = b;
    t->num = 0;
    if (*b == 0) {
        t->n = 1;
        return perr(P, t, "NUL byte in the text");
    }
    if (*b == '[' || *b == ']') {
        t->kind = *b == '[' ? TK_LBRACK : TK_RBRACK;
        t->n = 1;
        F->pos++;
        F->col++;
        return 0;
    }
    if (*b == '"') {
        size_t i = 1;
        while (i < left && b[i] != '"') {
            if (b[i] == '\n' || b[i] == 0) break;
            if (b[i] == '\\' && i + 1 < left && b[i + 1] != '\n' && b[i + 1] != 0) i++;
            i++;
        }
        if (i >= left || b[i] != '"') {
            t->n = 1;
            return perr(P, t, "string without its closing '\"' on the same line");
        }
        t->kind = TK_STRING;
        t->p = b + 1;
        t->n = i - 1;
        F->pos += i + 1;
        F->col += (uint32_t)(i + 1);
        return 0;
    }
    size_t i = 0;
    while (i < left && b[i] && b[i] != '\n' && !is_blank(b[i]) && b[i] != '"' && b[i] != '[' && b[i] != ']' &&
           b[i] != '#')
        i++;
    t->n = i;
    F->pos += i;
    F->col += (uint32_t)i;
    char c = *b;
    t->kind = TK_WORD; /* for messages until it is known */
    if ((c >= '0' && c <= '9') || c == '-' || c == '+' || c == '.') {
        char tmp[64], q[80], *end;
        if (i >= sizeof tmp) return perr(P, t, "bad number %s", tq(q, sizeof q, t));
        memcpy(tmp, b, i);
        tmp[i] = 0;
        double v = strtod(tmp, &end);
        if (end != tmp + i || memchr(tmp, 'x', i) || memchr(tmp, 'X', i)) /* no hex floats, as the OBJ loader */
            return perr(P, t, "bad number %s", tq(q, sizeof q, t));
        if (!isfinite(v) || fabs(v) > 1e30) return perr(P, t, "number %s out of range (|x| <= 1e30)", tq(q, sizeof q, t));
        t->kind = TK_NUMBER;
        t->num = v;
    } else {
        t->kind = TK_WORD;
    }
    return 0;
}

static int peek(pbrt *P, const token **t)
{
    srcfile *F = cur(P);
    if (!F->has_peek) {
        if (lex(P, &F->peek) < 0) return -1;
        F->has_peek = 1;
    }
    *t = &F->peek;
    return 0;
}

static int word_is(const token *t, const char *w) { return t->kind == TK_WORD && strlen(w) == t->n && !memcmp(t->p, w, t->n); }

/* The string token decoded (escapes \b \f \n \r \t, others: the character
 * itself) into buf. 0, or -1 if longer than cap - 1 bytes. */
static int tok_str(pbrt *P, const token *t, char *buf, size_t cap)
{
    size_t k = 0;
    for (size_t i = 0; i < t->n; i++) {
        char c = t->p[i];
        if (c == '\\' && i + 1 < t->n) {
            c = t->p[++i];
            c = c == 'b' ? '\b' : c == 'f' ? '\f' : c == 'n' ? '\n' : c == 'r' ? '\r' : c == 't' ? '\t' : c;
        }
        if (k + 1 >= cap) return perr(P, t, "string longer than %zu bytes", cap - 1);
        buf[k++] = c;
    }
    buf[k] = 0;
    return 0;
}

/* ------------------------------------------------------------------------ */
/* Name tables                                                               */

static uint64_t str_hash(const char *s) { return rt_fnv1a(RT_FNV_INIT, s, strlen(s)); }

static int nm_find(const namemap *m, const char *k)
{
    if (!m->cap) return -1;
    for (size_t h = str_hash(k) & (m->cap - 1);; h = (h + 1) & (m->cap - 1)) {
        if (!m->key[h]) return -1;
        if (!strcmp(m->key[h], k)) return m->val[h];
    }
}

/* Adds k -> v (k not present). 0 or -1. */
static int nm_put(namemap *m, const char *k, int v, rt_err *e)
{
    if (2 * (m->n + 1) >= m->cap) {
        size_t nc = m->cap ? 2 * m->cap : 64;
        char **nk = rt_calloc(nc, sizeof *nk, e);
        int *nv = rt_calloc(nc, sizeof *nv, e);
        if (!nk || !nv) {
            free(nk);
            free(nv);
            return -1;
        }
        for (size_t i = 0; i < m->cap; i++)
            if (m->key[i]) {
                size_t h = str_hash(m->key[i]) & (nc - 1);
                while (nk[h]) h = (h + 1) & (nc - 1);
                nk[h] = m->key[i];
                nv[h] = m->val[i];
            }
        free(m->key);
        free(m->val);
        m->key = nk;
        m->val = nv;
        m->cap = nc;
    }
    size_t len = strlen(k);
    char *c = rt_calloc(len + 1, 1, e);
    if (!c) return -1;
    memcpy(c, k, len);
    size_t h = str_hash(k) & (m->cap - 1);
    while (m->key[h]) h = (h + 1) & (m->cap - 1);
    m->key[h] = c;
    m->val[h] = v;
    m->n++;
    return 0;
}

static void nm_free(namemap *m)
{
    for (size_t i = 0; i < m->cap; i++) free(m->key[i]);
    free(m->key);
    free(m->val);
}

/* ------------------------------------------------------------------------ */
/* Matrices                                                                  */

static mat4 m_ident(void)
{
    mat4 r;
    memset(&r, 0, sizeof r);
    for (int i = 0; i < 4; i++) r.m[i][i] = 1;
    return r;
}

static mat4 m_mul(const mat4 *a, const mat4 *b)
{
    mat4 r;
    for (int i = 0; i < 4; i++)
        for (int j = 0; j < 4; j++) {
            double s = 0;
            for (int k = 0; k < 4; k++) s += a->m[i][k] * b->m[k][j];
            r.m[i][j] = s;
        }
    return r;
}

/* Inverse by Gauss-Jordan elimination with partial pivoting; -1 when
 * singular. */
static int m_inverse(const mat4 *a, mat4 *out)
{
    double w[4][8];
    for (int i = 0; i < 4; i++)
        for (int j = 0; j < 8; j++) w[i][j] = j < 4 ? a->m[i][j] : (j - 4 == i);
    for (int c = 0; c < 4; c++) {
        int p = c;
        for (int r = c + 1; r < 4; r++)
            if (fabs(w[r][c]) > fabs(w[p][c])) p = r;
        if (!(fabs(w[p][c]) > 1e-300)) return -1;
        for (int j = 0; j < 8; j++) {
            double t = w[c][j];
            w[c][j] = w[p][j];
            w[p][j] = t;
        }
        double d = w[c][c];
        for (int j = 0; j < 8; j++) w[c][j] /= d;
        for (int r = 0; r < 4; r++)
            if (r != c && w[r][c] != 0) {
                double f = w[r][c];
                for (int j = 0; j < 8; j++) w[r][j] -= f * w[c][j];
            }
    }
    for (int i = 0; i < 4; i++)
        for (int j = 0; j < 4; j++) {
            out->m[i][j] = w[i][j + 4];
            if (!isfinite(out->m[i][j])) return -1;
        }
    return 0;
}

static void m_apply(const mat4 *m, const double p[3], double out[3])
{
    double r[4];
    for (int i = 0; i < 4; i++) r[i] = m->m[i][0] * p[0] + m->m[i][1] * p[1] + m->m[i][2] * p[2] + m->m[i][3];
    if (r[3] != 1.0) r[0] /= r[3], r[1] /= r[3], r[2] /= r[3];
    out[0] = r[0], out[1] = r[1], out[2] = r[2];
}

static rt_vec3 m_point(const mat4 *m, double x, double y, double z)
{
    double p[3] = {x, y, z}, q[3];
    m_apply(m, p, q);
    return rt_v3((float)q[0], (float)q[1], (float)q[2]);
}

static double det3(const mat4 *m)
{
    const double(*a)[4] = m->m;
    return a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1]) - a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0]) +
           a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0]);
}

/* ------------------------------------------------------------------------ */
/* Files                                                                     */

/* Opens a regular file without blocking (a FIFO or device is refused
 * before any read). 0 with *fd and *st, or -1 with "reason" in why. A
 * static equivalent of the shared rt_open_regular (src/rt.c), kept here
 * until the two are unified. */
static int open_regular(const char *path, int *fd, struct stat *st, char *why, size_t nwhy)
{
    int f = open(path, O_RDONLY | O_NONBLOCK | O_NOCTTY | O_CLOEXEC);
    if (f < 0 && errno == ENOENT) {
        /* the folder it was looked for in, as the file system names it */
        char dir[4096], q[300];
        const char *slash = strrchr(path, '/');
        size_t dl = slash ? (size_t)(slash - path) : 0;
        if (dl >= sizeof dir) dl = 0;
        memcpy(dir, slash ? path : ".", slash ? (dl ? dl : 1) : 1);
        dir[slash ? (dl ? dl : 1) : 1] = 0;
        char *real = realpath(dir, NULL);
        rt_esc(q, sizeof q, real ? real : dir, 256);
        snprintf(why, nwhy, "no such file in %.150s%s", q, real ? "" : " (no such folder)");
        free(real);
        return -1;
    }
    if (f < 0) return snprintf(why, nwhy, "%s", strerror(errno)), -1;
    if (fstat(f, st) < 0 || !S_ISREG(st->st_mode)) {
        snprintf(why, nwhy, "%s", S_ISDIR(st->st_mode) ? "a folder, not a file" : "not a regular file");
        close(f);
        return -1;
    }
    *fd = f;
    return 0;
}

/* Reads the open regular file (plain or gzip, rt_sfile_read: at most
 * MAX_FILE_BYTES after inflation, and within the load's total) into a
 * NUL-terminated buffer. Closes fd. 0 or -1 (why). */
static int read_fd(pbrt *P, int fd, const struct stat *st, char **pbuf, size_t *pn, char *why, size_t nwhy)
{
    if ((uint64_t)st->st_size > MAX_FILE_BYTES) {
        close(fd);
        return snprintf(why, nwhy, "larger than %llu bytes", (unsigned long long)MAX_FILE_BYTES), -1;
    }
    if (P->total + (uint64_t)st->st_size > MAX_TOTAL_BYTES || P->nfiles >= MAX_FILES) {
        close(fd);
        return snprintf(why, nwhy, "the files read exceed %llu bytes or %d files in all",
                        (unsigned long long)MAX_TOTAL_BYTES, MAX_FILES), -1;
    }
    uint64_t left = MAX_TOTAL_BYTES - P->total, lim = left < MAX_FILE_BYTES ? left : MAX_FILE_BYTES;
    if (lim > rt_scene_max_bytes) lim = rt_scene_max_bytes;
    char *buf;
    size_t n;
    int gz;
    int rc = rt_sfile_read_fd(fd, lim, &buf, &n, &gz, why, nwhy);
    close(fd);
    if (rc < 0) {
        if (strstr(why, "more than") && lim == left && left < MAX_FILE_BYTES && left < rt_scene_max_bytes)
            snprintf(why, nwhy, "the files read exceed %llu bytes or %d files in all",
                     (unsigned long long)MAX_TOTAL_BYTES, MAX_FILES);
        return -1;
    }
    P->total += n;
    P->nfiles++;
    *pbuf = buf;
    *pn = n;
    return 0;
}

static void file_free(srcfile *F)
{
    if (!F) return;
    free(F->path);
    free(F->rel);
    free(F->buf);
    free(F);
}

/* The path of a file a directive names (token t, decoded name), as pbrt
 * resolves it: relative to the folder of the file that names it, ".."
 * allowed (scene collections share asset folders: "../landscape/x.ply").
 * Absolute paths are refused, so a scene folder stays movable. The name
 * is never checked apart from its opening: the caller opens it once
 * (open_regular) and checks the opened descriptor, so a link swapped
 * between a check and the read cannot change what is read. *prel and
 * *pfull (malloc'd): the path to open, the first to become the folder of
 * an included file. 0 or -1. */
static int resolve(pbrt *P, const token *t, const char *what, const char *name, char **prel, char **pfull)
{
    char q[300];
    rt_esc(q, sizeof q, name, 256);
    if (name[0] == '/')
        return perr(P, t, "%s \"%s\": absolute paths are not allowed (name it relative to the folder of %s)", what, q,
                    cur(P)->path);
    const char *dir = cur(P)->rel;
    size_t n = strlen(dir) + strlen(name) + 2;
    char *full = rt_calloc(n, 1, P->e), *rel = rt_calloc(n, 1, P->e);
    if (!full || !rel) {
        free(full);
        free(rel);
        return -1;
    }
    snprintf(full, n, "%s%s%s", dir, dir[0] ? "/" : "", name);
    memcpy(rel, full, strlen(full) + 1);
    *prel = rel;
    *pfull = full;
    return 0;
}

/* Pushes a file; rel = its path as opened (taken over; cut to its folder,
 * "" when it has none). */
static int push_file(pbrt *P, char *shown, char *rel, char *buf, size_t n, const struct stat *st)
{
    srcfile *F = rt_calloc(1, sizeof *F, P->e);
    if (!F) {
        free(shown);
        free(rel);
        free(buf);
        return -1;
    }
    F->path = shown;
    if (P->npaths % 64 == 0) {
        char **np = rt_reallocarray(P->paths, (size_t)P->npaths + 64, sizeof *np, P->e);
        if (!np) {
            free(shown);
            free(rel);
            free(buf);
            free(F);
            return -1;
        }
        P->paths = np;
    }
    size_t pl = strlen(shown);
    if (!(P->paths[P->npaths] = rt_calloc(pl + 1, 1, P->e))) {
        free(shown);
        free(rel);
        free(buf);
        free(F);
        return -1;
    }
    memcpy(P->paths[P->npaths], shown, pl);
    F->pid = P->npaths++;
    /* the folder of rel */
    char *slash = strrchr(rel, '/');
    if (slash == rel) rel[1] = 0; /* "/x.pbrt": the root */
    else if (slash) *slash = 0;
    else rel[0] = 0;
    F->rel = rel;
    F->buf = buf;
    F->n = n;
    F->line = F->col = 1;
    F->dev = st->st_dev;
    F->ino = st->st_ino;
    P->f[P->depth++] = F;
    return 0;
}

/* Include/Import "name": textual inclusion. */
static int do_include(pbrt *P, const token *d)
{
    const token *t;
    char name[4096], q[300], why[200];
    if (peek(P, &t) < 0) return -1;
    if (t->kind != TK_STRING) return perr(P, t, "%.*s: expected a file name in quotes", (int)d->n, d->p);
    token nt = *t;
    lex(P, &nt);
    if (tok_str(P, &nt, name, sizeof name) < 0) return -1;
    char what[16];
    snprintf(what, sizeof what, "%.*s", (int)d->n, d->p);
    rt_esc(q, sizeof q, name, 256);
    if (P->depth >= MAX_DEPTH) return perr(P, &nt, "%s \"%s\": more than %d nested files", what, q, MAX_DEPTH);
    char *rel, *full;
    if (resolve(P, &nt, what, name, &rel, &full) < 0) return -1;
    int fd;
    struct stat st;
    char *buf = NULL;
    size_t n = 0;
    if (open_regular(full, &fd, &st, why, sizeof why) < 0) {
        free(rel);
        free(full);
        return perr(P, &nt, "%s \"%s\": %s", what, q, why);
    }
    for (int i = 0; i < P->depth; i++)
        if (P->f[i]->dev == st.st_dev && P->f[i]->ino == st.st_ino) {
            close(fd);
            free(rel);
            free(full);
            if (i == P->depth - 1)
                return perr(P, &nt, "%s \"%s\": a file cannot %s itself", what, q,
                            what[1] == 'm' ? "import" : "include");
            char q2[300];
            rt_esc(q2, sizeof q2, P->f[i]->path, 256);
            return perr(P, &nt, "%s \"%s\": include cycle (%s is already being read)", what, q, q2);
        }
    if (read_fd(P, fd, &st, &buf, &n, why, sizeof why) < 0) {
        free(rel);
        free(full);
        return perr(P, &nt, "%s \"%s\": %s", what, q, why);
    }
    return push_file(P, full, rel, buf, n, &st);
}

/* ------------------------------------------------------------------------ */
/* Parameter lists                                                           */

enum { PT_FLOAT, PT_INT, PT_BOOL, PT_STRING, PT_TEXTURE, PT_POINT2, PT_VECTOR2, PT_POINT3, PT_VECTOR3, PT_NORMAL3,
       PT_RGB, PT_SPECTRUM, PT_BLACKBODY };

static const struct {
    const char *name;
    int type;
} ptypes[] = {
    {"float", PT_FLOAT},     {"integer", PT_INT},     {"bool", PT_BOOL},       {"string", PT_STRING},
    {"texture", PT_TEXTURE}, {"point2", PT_POINT2},   {"vector2", PT_VECTOR2}, {"point3", PT_POINT3},
    {"point", PT_POINT3},    {"vector3", PT_VECTOR3}, {"vector", PT_VECTOR3},  {"normal3", PT_NORMAL3},
    {"normal", PT_NORMAL3},  {"rgb", PT_RGB},         {"color", PT_RGB},       {"spectrum", PT_SPECTRUM},
    {"blackbody", PT_BLACKBODY},
};

typedef struct param {
    token at;        /* the "type name" string */
    int type;        /* PT_* */
    char tname[16];  /* type as written */
    char name[64];   /* parameter name */
    double *v;       /* numbers (bools as 0/1) */
    size_t nv, cv;
    token *s;        /* strings */
    size_t ns, cs;
} param;

typedef struct plist {
    param *p;
    size_t n, cap;
} plist;

static void plist_free(plist *L)
{
    for (size_t i = 0; i < L->n; i++) {
        free(L->p[i].v);
        free(L->p[i].s);
    }
    free(L->p);
    memset(L, 0, sizeof *L);
}

static int pv_push(pbrt *P, param *q, double v)
{
    if (q->nv == q->cv) {
        size_t nc = q->cv ? 2 * q->cv : 16;
        double *nv = rt_reallocarray(q->v, nc, sizeof *nv, P->e);
        if (!nv) return -1;
        q->v = nv;
        q->cv = nc;
    }
    q->v[q->nv++] = v;
    return 0;
}

static int ps_push(pbrt *P, param *q, const token *t)
{
    if (q->ns == q->cs) {
        size_t nc = q->cs ? 2 * q->cs : 4;
        token *ns = rt_reallocarray(q->s, nc, sizeof *ns, P->e);
        if (!ns) return -1;
        q->s = ns;
        q->cs = nc;
    }
    q->s[q->ns++] = *t;
    return 0;
}

/* One value of parameter q. */
static int param_value(pbrt *P, param *q, const token *t)
{
    char b[80];
    int numeric = q->type != PT_BOOL && q->type != PT_STRING && q->type != PT_TEXTURE;
    if (t->kind == TK_NUMBER) {
        if (!numeric) return perr(P, t, "parameter \"%s %s\": expected a %s, got the number %s", q->tname, q->name,
                                  q->type == PT_BOOL ? "bool (true or false)" : "string in quotes", tq(b, sizeof b, t));
        if (q->type == PT_INT && (t->num != floor(t->num) || t->num < -2147483648.0 || t->num > 2147483647.0))
            return perr(P, t, "parameter \"%s %s\": %s is not an integer", q->tname, q->name, tq(b, sizeof b, t));
        if (q->ns) return perr(P, t, "parameter \"%s %s\": numbers mixed with strings", q->tname, q->name);
        return pv_push(P, q, t->num);
    }
    if (q->type == PT_BOOL && (t->kind == TK_WORD || t->kind == TK_STRING)) {
        int tr = t->n == 4 && !memcmp(t->p, "true", 4), fa = t->n == 5 && !memcmp(t->p, "false", 5);
        if (!tr && !fa) return perr(P, t, "parameter \"bool %s\": expected true or false, got %s", q->name,
                                    tq(b, sizeof b, t));
        return pv_push(P, q, tr);
    }
    if (t->kind == TK_STRING && (q->type == PT_STRING || q->type == PT_TEXTURE || q->type == PT_SPECTRUM)) {
        if (q->nv) return perr(P, t, "parameter \"%s %s\": strings mixed with numbers", q->tname, q->name);
        return ps_push(P, q, t);
    }
    return perr(P, t, "parameter \"%s %s\": expected %s, got %s", q->tname, q->name,
                numeric ? "a number" : "a string in quotes", tq(b, sizeof b, t));
}

/* Reads `"type name" value` pairs while the next token is a string. */
static int parse_params(pbrt *P, plist *L)
{
    for (;;) {
        const token *pt;
        if (peek(P, &pt) < 0) return -1;
        if (pt->kind != TK_STRING) return 0;
        token t;
        lex(P, &t);
        char decl[128], ty[32], nm[80], b[80];
        if (tok_str(P, &t, decl, sizeof decl) < 0) return -1;
        int k = 0;
        char extra[8];
        if (sscanf(decl, "%31s %79s %7s", ty, nm, extra) != 2 || strlen(ty) >= 16 || strlen(nm) >= 64)
            return perr(P, &t, "expected a parameter \"type name\", got %s", tq(b, sizeof b, &t));
        for (k = 0; k < (int)(sizeof ptypes / sizeof ptypes[0]); k++)
            if (!strcmp(ptypes[k].name, ty)) break;
        if (k == (int)(sizeof ptypes / sizeof ptypes[0]))
            return perr(P, &t, "unknown parameter type '%s' (float, integer, bool, string, texture, point2, vector2, "
                               "point3, vector3, normal3, rgb, spectrum, blackbody)", ty);
        if (L->n == MAX_PARAMS) return perr(P, &t, "more than %d parameters", MAX_PARAMS);
        for (size_t i = 0; i < L->n; i++)
            if (!strcmp(L->p[i].name, nm)) return perr(P, &t, "parameter \"%s\" given twice", nm);
        if (L->n == L->cap) {
            size_t nc = L->cap ? 2 * L->cap : 8;
            param *np = rt_reallocarray(L->p, nc, sizeof *np, P->e);
            if (!np) return -1;
            L->p = np;
            L->cap = nc;
        }
        param *q = &L->p[L->n++];
        memset(q, 0, sizeof *q);
        q->at = t;
        q->type = ptypes[k].type;
        snprintf(q->tname, sizeof q->tname, "%s", ty);
        snprintf(q->name, sizeof q->name, "%s", nm);
        token v;
        if (lex(P, &v) < 0) return -1;
        if (v.kind == TK_LBRACK) {
            for (;;) {
                if (lex(P, &v) < 0) return -1;
                if (v.kind == TK_RBRACK) break;
                if (v.kind == TK_EOF || v.kind == TK_LBRACK)
                    return perr(P, &v, "parameter \"%s %s\": expected a value or ']', got %s", q->tname, q->name,
                                tq(b, sizeof b, &v));
                if (param_value(P, q, &v) < 0) return -1;
            }
        } else if (v.kind == TK_NUMBER || v.kind == TK_STRING || v.kind == TK_WORD) {
            if (v.kind == TK_WORD && q->type != PT_BOOL)
                return perr(P, &v, "parameter \"%s %s\": expected a value, got %s", q->tname, q->name,
                            tq(b, sizeof b, &v));
            if (param_value(P, q, &v) < 0) return -1;
        } else {
            return perr(P, &v, "parameter \"%s %s\": expected a value, got %s", q->tname, q->name, tq(b, sizeof b, &v));
        }
    }
}

static param *pfind(plist *L, const char *name)
{
    for (size_t i = 0; i < L->n; i++)
        if (!strcmp(L->p[i].name, name)) return &L->p[i];
    return NULL;
}

/* Numbers of parameter `name` whose type is in `types` (PT_ bits), a
 * multiple of `mult` of them, at least `minn`. NULL with *n = 0 when
 * absent; -1 (message) on a mismatch. */
static int pnums(pbrt *P, plist *L, const char *name, unsigned types, const char *tnames, size_t mult, size_t minn,
                 const double **v, size_t *n)
{
    param *q = pfind(L, name);
    *v = NULL;
    *n = 0;
    if (!q) return 0;
    if (!(types & (1u << q->type)))
        return perr(P, &q->at, "parameter \"%s %s\": \"%s\" must be %s", q->tname, q->name, name, tnames);
    if (q->ns) return perr(P, &q->at, "parameter \"%s %s\": expected numbers, got strings", q->tname, q->name);
    if (q->nv % mult || q->nv < minn) {
        if (mult == 1 && minn == 1)
            return perr(P, &q->at, "parameter \"%s %s\": expected a value, got none", q->tname, q->name);
        return perr(P, &q->at, "parameter \"%s %s\": %zu values, expected %s%zu", q->tname, q->name, q->nv,
                    mult > 1 ? "a multiple of " : "at least ", mult > 1 ? mult : minn);
    }
    *v = q->v;
    *n = q->nv;
    return 1;
}

#define B(t) (1u << (t))

/* One float (float or integer type); def when absent. */
static int pfloat(pbrt *P, plist *L, const char *name, double def, double *out)
{
    const double *v;
    size_t n;
    int r = pnums(P, L, name, B(PT_FLOAT) | B(PT_INT), "float", 1, 1, &v, &n);
    if (r < 0) return -1;
    if (r && n != 1) return perr(P, &pfind(L, name)->at, "parameter \"%s\": %zu values, expected 1", name, n);
    *out = r ? v[0] : def;
    return 0;
}

static int pint(pbrt *P, plist *L, const char *name, long def, long *out)
{
    const double *v;
    size_t n;
    int r = pnums(P, L, name, B(PT_INT), "integer", 1, 1, &v, &n);
    if (r < 0) return -1;
    if (r && n != 1) return perr(P, &pfind(L, name)->at, "parameter \"%s\": %zu values, expected 1", name, n);
    *out = r ? (long)v[0] : def;
    return 0;
}

/* One string into buf; "" when absent. */
static int pstring(pbrt *P, plist *L, const char *name, char *buf, size_t cap)
{
    param *q = pfind(L, name);
    buf[0] = 0;
    if (!q) return 0;
    if (q->type != PT_STRING)
        return perr(P, &q->at, "parameter \"%s %s\": \"%s\" must be string", q->tname, q->name, name);
    if (q->ns != 1) return perr(P, &q->at, "parameter \"%s %s\": %zu strings, expected 1", q->tname, q->name, q->ns);
    return tok_str(P, &q->s[0], buf, cap);
}

/* A colour: rgb (3 values), float (grey), spectrum (numbers: wavelength,
 * value pairs -> the mean value as grey; a named spectrum -> def), blackbody
 * (-> white) or a texture (-> def). *approx is set when the value was not
 * taken as given. */
static int pcolour(pbrt *P, plist *L, const char *name, const float def[3], float out[3], int *approx)
{
    param *q = pfind(L, name);
    for (int k = 0; k < 3; k++) out[k] = def[k];
    if (!q) return 0;
    switch (q->type) {
    case PT_RGB:
        if (q->nv != 3) return perr(P, &q->at, "parameter \"rgb %s\": %zu values, expected 3", name, q->nv);
        for (int k = 0; k < 3; k++) out[k] = (float)q->v[k];
        break;
    case PT_FLOAT:
        if (q->nv != 1) return perr(P, &q->at, "parameter \"float %s\": %zu values, expected 1", name, q->nv);
        out[0] = out[1] = out[2] = (float)q->v[0];
        break;
    case PT_SPECTRUM:
        if (q->nv) {
            if (q->nv % 2) return perr(P, &q->at, "parameter \"spectrum %s\": %zu values, expected wavelength-value pairs", name, q->nv);
            double s = 0;
            for (size_t i = 1; i < q->nv; i += 2) s += q->v[i];
            out[0] = out[1] = out[2] = (float)(s / (double)(q->nv / 2));
        }
        *approx = 1;
        break;
    case PT_BLACKBODY:
        out[0] = out[1] = out[2] = 1;
        *approx = 1;
        break;
    case PT_TEXTURE:
        *approx = 1;
        break;
    default:
        return perr(P, &q->at, "parameter \"%s %s\": \"%s\" must be rgb, spectrum, blackbody, float or texture",
                    q->tname, q->name, name);
    }
    for (int k = 0; k < 3; k++)
        if (!(out[k] >= 0) || out[k] > 1e30f)
            return perr(P, &q->at, "parameter \"%s %s\": negative value", q->tname, q->name);
    return 0;
}

/* ------------------------------------------------------------------------ */
/* Directives: helpers                                                       */

static int need_number(pbrt *P, const token *d, double *out)
{
    token t;
    char b[80];
    if (lex(P, &t) < 0) return -1;
    if (t.kind != TK_NUMBER)
        return perr(P, &t, "%.*s: expected a number, got %s", (int)d->n, d->p, tq(b, sizeof b, &t));
    *out = t.num;
    return 0;
}

/* The next token as a decoded string. */
static int need_string(pbrt *P, const token *d, char *buf, size_t cap, token *at)
{
    token t;
    char b[80];
    if (lex(P, &t) < 0) return -1;
    if (t.kind != TK_STRING)
        return perr(P, &t, "%.*s: expected a string in quotes, got %s", (int)d->n, d->p, tq(b, sizeof b, &t));
    if (at) *at = t;
    return tok_str(P, &t, buf, cap);
}

/* n numbers, optionally in brackets (Transform, ConcatTransform). */
static int need_numbers(pbrt *P, const token *d, double *v, int n)
{
    const token *t;
    if (peek(P, &t) < 0) return -1;
    int br = t->kind == TK_LBRACK;
    token x;
    if (br) lex(P, &x);
    for (int i = 0; i < n; i++)
        if (need_number(P, d, &v[i]) < 0) return -1;
    if (br) {
        char b[80];
        if (lex(P, &x) < 0) return -1;
        if (x.kind != TK_RBRACK) return perr(P, &x, "%.*s: expected ']' after %d numbers, got %s", (int)d->n, d->p, n,
                                           tq(b, sizeof b, &x));
    }
    return 0;
}

/* Skips a directive's arguments: every token up to the next bare word that
 * is not true/false, or the end of the file. */
static int skip_args(pbrt *P)
{
    for (;;) {
        const token *t;
        if (peek(P, &t) < 0) return -1;
        if (t->kind == TK_EOF || (t->kind == TK_WORD && !word_is(t, "true") && !word_is(t, "false"))) return 0;
        token x;
        lex(P, &x);
    }
}

static int need_world(pbrt *P, const token *d, int inside)
{
    if (inside && !P->world)
        return perr(P, d, "%.*s before WorldBegin (shapes, lights and objects belong in the world block)", (int)d->n,
                    d->p);
    if (!inside && P->world)
        return perr(P, d, "%.*s inside the world block (it must come before WorldBegin)", (int)d->n, d->p);
    return 0;
}

static void where(pbrt *P, const token *t, char *buf, size_t n, int col)
{
    if (col) snprintf(buf, n, "%s:%u:%u", cur(P)->path, (unsigned)t->line, (unsigned)t->col);
    else snprintf(buf, n, "%s:%u", cur(P)->path, (unsigned)t->line);
}

static int push_frame(pbrt *P, const token *d, char kind)
{
    if (P->nstack >= MAX_NEST) return perr(P, d, "more than %d nested blocks", MAX_NEST);
    if (P->nstack == P->cstack) {
        int nc = P->cstack ? 2 * P->cstack : 16;
        frame *ns = rt_reallocarray(P->stack, (size_t)nc, sizeof *ns, P->e);
        if (!ns) return -1;
        P->stack = ns;
        P->cstack = nc;
    }
    frame *f = &P->stack[P->nstack++];
    f->g = P->g;
    f->kind = kind;
    where(P, d, f->at, sizeof f->at, 1);
    return 0;
}

static const char *frame_name(char k)
{
    return k == 'a' ? "AttributeBegin" : k == 't' ? "TransformBegin" : "ObjectBegin";
}

static int pop_frame(pbrt *P, const token *d, char kind)
{
    if (!P->nstack) return perr(P, d, "%.*s without a matching %s", (int)d->n, d->p, frame_name(kind));
    frame *f = &P->stack[P->nstack - 1];
    if (f->kind != kind)
        return perr(P, d, "%.*s closes the %s at %s (blocks must nest)", (int)d->n, d->p, frame_name(f->kind), f->at);
    if (kind == 't') P->g.ctm = f->g.ctm;
    else P->g = f->g;
    P->nstack--;
    return 0;
}

/* The CTM after directive d must be finite (a product may overflow). */
static int ctm_check(pbrt *P, const token *d)
{
    for (int i = 0; i < 4; i++)
        for (int j = 0; j < 4; j++)
            if (!isfinite(P->g.ctm.m[i][j]))
                return perr(P, d, "%.*s: the transformation is no longer finite (entry %d,%d overflows)", (int)d->n,
                            d->p, i, j);
    return 0;
}

/* CTM = CTM x m, checked finite. */
static int concat(pbrt *P, const token *d, const mat4 *m)
{
    P->g.ctm = m_mul(&P->g.ctm, m);
    return ctm_check(P, d);
}

/* ------------------------------------------------------------------------ */
/* Materials                                                                 */

static int add_matdef(pbrt *P, const matdef *m)
{
    if (P->nmats == P->cmats) {
        int nc = P->cmats ? 2 * P->cmats : 16;
        matdef *nm = rt_reallocarray(P->mats, (size_t)nc, sizeof *nm, P->e);
        if (!nm) return -1;
        P->mats = nm;
        P->cmats = nc;
    }
    P->mats[P->nmats] = *m;
    P->mats[P->nmats].tab = -1;
    return P->nmats++;
}

/* The normal-incidence reflectance of a conductor, ((n-1)^2+k^2)/((n+1)^2+k^2). */
static float f0_conductor(double n, double k) { return (float)(((n - 1) * (n - 1) + k * k) / ((n + 1) * (n + 1) + k * k)); }

/* A material from its type (tok: for messages) and parameters
 * (docs/scenes.md has the mapping). */
static int make_matdef(pbrt *P, const token *tt, const char *type, plist *L, matdef *m)
{
    static const float half[3] = {0.5f, 0.5f, 0.5f}, copper[3] = {0.955f, 0.638f, 0.538f},
                       glass_rgb[3] = {0.85f, 0.90f, 0.95f};
    memset(m, 0, sizeof *m);
    m->ior = 1;
    snprintf(m->name, sizeof m->name, "%.31s", type);
    int approx = 0;
    char key[48];
    if (!strcmp(type, "diffuse") || !strcmp(type, "coateddiffuse") || !strcmp(type, "diffusetransmission")) {
        static const float quarter[3] = {0.25f, 0.25f, 0.25f};
        if (pcolour(P, L, "reflectance", type[1] == 'i' && type[7] == 't' ? quarter : half, m->rgb, &approx) < 0)
            return -1;
        if (!strcmp(type, "coateddiffuse")) {
            double eta;
            const double *v;
            size_t n;
            int r = pnums(P, L, "eta", B(PT_FLOAT) | B(PT_SPECTRUM), "float or spectrum", 1, 1, &v, &n);
            if (r < 0) return -1;
            eta = r && n == 1 ? v[0] : 1.5;
            if (!(eta > 0)) return perr(P, tt, "coateddiffuse: eta must be positive");
            float f = (float)(((eta - 1) / (eta + 1)) * ((eta - 1) / (eta + 1)));
            m->ks[0] = m->ks[1] = m->ks[2] = f;
        }
    } else if (!strcmp(type, "conductor") || !strcmp(type, "coatedconductor")) {
        const char *pe = type[0] == 'c' && type[1] == 'o' && type[2] == 'a' ? "conductor.eta" : "eta";
        const char *pk = pe[0] == 'c' ? "conductor.k" : "k";
        param *refl = pfind(L, "reflectance");
        if (refl) {
            if (pcolour(P, L, "reflectance", copper, m->ks, &approx) < 0) return -1;
        } else {
            param *qe = pfind(L, pe), *qk = pfind(L, pk);
            float ev[3], kv[3];
            static const float one[3] = {1, 1, 1}, zero[3] = {0, 0, 0};
            int ae = 0, ak = 0;
            if (qe && qk && (qe->type == PT_RGB || qe->type == PT_FLOAT) && (qk->type == PT_RGB || qk->type == PT_FLOAT)) {
                if (pcolour(P, L, pe, one, ev, &ae) < 0 || pcolour(P, L, pk, zero, kv, &ak) < 0) return -1;
                for (int c = 0; c < 3; c++) m->ks[c] = f0_conductor(ev[c], kv[c]);
            } else {
                memcpy(m->ks, copper, sizeof m->ks);
                if (qe || qk) approx = 1;
            }
        }
        memcpy(m->rgb, m->ks, sizeof m->rgb);
    } else if (!strcmp(type, "dielectric") || !strcmp(type, "thindielectric")) {
        double eta = 1.5;
        param *q = pfind(L, "eta");
        if (q && q->type == PT_FLOAT) {
            if (pfloat(P, L, "eta", 1.5, &eta) < 0) return -1;
        } else if (q && q->type == PT_SPECTRUM && q->nv) {
            if (q->nv % 2) return perr(P, &q->at, "parameter \"spectrum eta\": expected wavelength-value pairs");
            double s = 0;
            for (size_t i = 1; i < q->nv; i += 2) s += q->v[i];
            eta = s / (double)(q->nv / 2);
        } else if (q && q->type == PT_RGB) {
            if (q->nv != 3) return perr(P, &q->at, "parameter \"rgb eta\": %zu values, expected 3", q->nv);
            eta = (q->v[0] + q->v[1] + q->v[2]) / 3; /* one index for the three channels */
            approx = 1;
        } else if (q) {
            approx = 1; /* a named spectrum: glass */
        }
        if (!(eta > 0) || eta > 100) return perr(P, q ? &q->at : tt, "%s: eta %g outside (0, 100]", type, eta);
        if (eta < 1) eta = 1 / eta; /* an interface seen from the denser side: same rays */
        m->kt[0] = m->kt[1] = m->kt[2] = 1;
        m->ior = (float)eta;
        memcpy(m->rgb, glass_rgb, sizeof m->rgb);
    } else if (!strcmp(type, "interface")) {
        /* pbrt: a boundary between media, invisible to rays */
        m->invisible = 1;
        memcpy(m->rgb, half, sizeof m->rgb);
        return 0;
    } else {
        snprintf(key, sizeof key, "Material \"%.30s\"", type);
        char q[64];
        rt_esc(q, sizeof q, type, 32);
        pwarn(P, tt, key, "Material \"%s\" not supported: plain diffuse 0.5", q);
        memcpy(m->rgb, half, sizeof m->rgb);
        return 0;
    }
    if (approx) {
        snprintf(key, sizeof key, "approx %.30s", type);
        pwarn(P, tt, key, "%s: a texture, named or spectral value was approximated (docs/scenes.md)", type);
    }
    return 0;
}

static int mat_same(const rt_material *a, const rt_material *b)
{
    return !memcmp(a->ks, b->ks, sizeof a->ks) && !memcmp(a->kt, b->kt, sizeof a->kt) && a->ior == b->ior &&
           !memcmp(a->ke, b->ke, sizeof a->ke) && !strcmp(a->name, b->name);
}

static uint64_t mat_hash(const rt_material *m)
{
    uint64_t h = rt_fnv1a(RT_FNV_INIT, m->ks, sizeof m->ks);
    h = rt_fnv1a(h, m->kt, sizeof m->kt);
    h = rt_fnv1a(h, &m->ior, sizeof m->ior);
    h = rt_fnv1a(h, m->ke, sizeof m->ke);
    return rt_fnv1a(h, m->name, strlen(m->name));
}

/* Puts table entry i into the slots (growing them). 0 or -1. */
static int mslot_put(pbrt *P, uint32_t i)
{
    rt_scene *s = P->s;
    if (2 * (size_t)s->nmat >= P->nmslot) {
        size_t nc = P->nmslot ? 2 * P->nmslot : 64;
        while (2 * (size_t)s->nmat >= nc) nc *= 2;
        uint32_t *ns = rt_calloc(nc, sizeof *ns, P->e);
        if (!ns) return -1;
        free(P->mslot);
        P->mslot = ns;
        P->nmslot = nc;
        for (uint32_t k = 1; k < s->nmat; k++)
            if (k != i) {
                size_t h = (size_t)mat_hash(&s->mat[k]) & (nc - 1);
                while (ns[h]) h = (h + 1) & (nc - 1);
                ns[h] = k;
            }
    }
    size_t h = (size_t)mat_hash(&s->mat[i]) & (P->nmslot - 1);
    while (P->mslot[h]) h = (h + 1) & (P->nmslot - 1);
    P->mslot[h] = i;
    return 0;
}

/* The table index for material md with emission ke (made on first use;
 * identical terms share an entry, found by hashing: a file of many
 * materials costs linear time). */
static int table_index(pbrt *P, matdef *md, const float ke[3], int emit, uint32_t *out)
{
    if (!emit && md->tab >= 0) return *out = (uint32_t)md->tab, 0;
    rt_material m;
    memset(&m, 0, sizeof m);
    memcpy(m.ks, md->ks, sizeof m.ks);
    memcpy(m.kt, md->kt, sizeof m.kt);
    m.ior = md->ior;
    int plain = 1;
    for (int k = 0; k < 3; k++) {
        if (emit) m.ke[k] = ke[k];
        if (m.ks[k] > 0 || m.kt[k] > 0 || m.ke[k] > 0) plain = 0;
    }
    if (plain) {
        if (!emit) md->tab = 0;
        return *out = 0, 0;
    }
    snprintf(m.name, sizeof m.name, "%s", md->name);
    if (emit && !strcmp(md->name, "diffuse")) snprintf(m.name, sizeof m.name, "light");
    rt_scene *s = P->s;
    /* the name as the table stores it (copied, truncated) */
    m.name[sizeof m.name - 1] = 0;
    for (size_t h = P->nmslot ? (size_t)mat_hash(&m) & (P->nmslot - 1) : 0; P->nmslot && P->mslot[h];
         h = (h + 1) & (P->nmslot - 1)) {
        uint32_t i = P->mslot[h];
        if (mat_same(&s->mat[i], &m)) {
            if (!emit) md->tab = i;
            return *out = i, 0;
        }
    }
    int r = rt_scene_add_material(s, &m, P->e);
    if (r < 0) {
        if (s->nmat >= 65536) return perr(P, &P->shape_tok, "more than 65536 distinct materials (the table's limit)");
        char msg[RT_ERR_LEN];
        snprintf(msg, sizeof msg, "%s", P->e->msg);
        return perr(P, &P->shape_tok, "%s", msg);
    }
    if (mslot_put(P, (uint32_t)r) < 0) return -1;
    if (!emit) md->tab = r;
    *out = (uint32_t)r;
    return 0;
}

/* ------------------------------------------------------------------------ */
/* Shapes                                                                    */

static int room_for(pbrt *P, const token *t, uint64_t more)
{
    /* kept instances hold no triangles of their own (do_object_instance
     * bounds their indices) */
    uint64_t n = (uint64_t)P->s->ntri + (P->keep ? 0 : P->pend) + more;
    if (n > P->maxtri)
        return perr(P, t, "the scene would have %llu triangles, more than maxtri=%u (raise it with the spec parameter "
                          "FILE.pbrt:maxtri=N)", (unsigned long long)n, (unsigned)P->maxtri);
    return 0;
}

static int finite3(rt_vec3 a) { return isfinite(a.x) && isfinite(a.y) && isfinite(a.z); }

/* Finite and within the coordinate range (RT_COORD_MAX). */
static int in_range3(rt_vec3 a)
{
    return finite3(a) && fabs(a.x) <= RT_COORD_MAX && fabs(a.y) <= RT_COORD_MAX && fabs(a.z) <= RT_COORD_MAX;
}

/* A triangle of the shape being made (at P->shape_tok), refused at its
 * line when the transformation left a vertex non-finite in float. */
static int emit(pbrt *P, rt_vec3 a, rt_vec3 b, rt_vec3 c)
{
    if (!in_range3(a) || !in_range3(b) || !in_range3(c)) {
        char q[80];
        rt_vec3 x = !in_range3(a) ? a : !in_range3(b) ? b : c;
        return perr(P, &P->shape_tok, "Shape %s: vertex (%g, %g, %g) is not finite or beyond %g after the transformation",
                    tq(q, sizeof q, &P->shape_tok), (double)x.x, (double)x.y, (double)x.z, RT_COORD_MAX);
    }
    return rt_scene_add_tri_mat(P->s, a, b, c, P->cur_rgb, P->cur_mat, P->e);
}

/* Triangles from world vertices w (nw) and corner indices idx (3 per
 * triangle, checked). */
static int emit_indexed(pbrt *P, const rt_vec3 *w, const long *idx, size_t nidx)
{
    for (size_t i = 0; i + 2 < nidx; i += 3)
        if (emit(P, w[idx[i]], w[idx[i + 1]], w[idx[i + 2]]) < 0) return -1;
    return 0;
}

/* Vertices "P" (point3) mapped by the CTM into a malloc'd array. */
static int get_points(pbrt *P, const token *d, const char *shape, plist *L, rt_vec3 **out, size_t *nout)
{
    const double *v;
    size_t n;
    int r = pnums(P, L, "P", B(PT_POINT3), "point3", 3, 3, &v, &n);
    if (r < 0) return -1;
    if (!r) return perr(P, d, "Shape \"%s\": missing the vertices \"point3 P\"", shape);
    rt_vec3 *w = rt_calloc(n / 3, sizeof *w, P->e);
    if (!w) return -1;
    for (size_t i = 0; i < n / 3; i++) w[i] = m_point(&P->g.ctm, v[3 * i], v[3 * i + 1], v[3 * i + 2]);
    *out = w;
    *nout = n / 3;
    return 0;
}

/* Corner indices "indices" (k per face) into a malloc'd array, each below
 * nv; when absent and nv == k, the one face 0..k-1. */
static int get_indices(pbrt *P, const token *d, const char *shape, plist *L, size_t k, size_t nv, long **out,
                       size_t *nout)
{
    const double *v;
    size_t n;
    int r = pnums(P, L, "indices", B(PT_INT), "integer", k, k, &v, &n);
    if (r < 0) return -1;
    if (!r && nv != k)
        return perr(P, d, "Shape \"%s\": \"integer indices\" missing (optional only with exactly %zu vertices)", shape,
                    k);
    size_t m = r ? n : k;
    long *idx = rt_calloc(m, sizeof *idx, P->e);
    if (!idx) return -1;
    for (size_t i = 0; i < m; i++) {
        double x = r ? v[i] : (double)i;
        if (x < 0 || x >= (double)nv) {
            free(idx);
            return perr(P, &pfind(L, "indices")->at, "Shape \"%s\": index %.0f (entry %zu) out of range (%zu vertices)",
                        shape, x, i, nv);
        }
        idx[i] = (long)x;
    }
    *out = idx;
    *nout = m;
    return 0;
}

/* Cube-sphere template as in scene_builtin.c (sphere_template): 6 faces x
 * t x t cells x 2 triangles of unit vectors, outward, watertight. */
static double *sphere_template(int t, rt_err *e)
{
    double *v = rt_calloc((size_t)108 * t * t, sizeof *v, e);
    if (!v) return NULL;
    double grid[65];
    for (int k = 0; k <= t; k++) grid[k] = 2 * k <= t ? -1.0 + 2.0 * k / t : 1.0 - 2.0 * (t - k) / t;
    size_t k = 0;
    for (int face = 0; face < 6; face++) {
        int ax = face >> 1;
        double sg = (face & 1) ? -1.0 : 1.0;
        int a1 = (ax + 1) % 3, a2 = (ax + 2) % 3;
        for (int i = 0; i < t; i++)
            for (int j = 0; j < t; j++) {
                double q[4][3];
                for (int c = 0; c < 4; c++) {
                    int ii = i + (c == 1 || c == 2), jj = j + (c >= 2);
                    double p[3];
                    p[ax] = sg;
                    p[a1] = grid[ii];
                    p[a2] = grid[jj] * sg;
                    double l = sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]);
                    for (int d = 0; d < 3; d++) q[c][d] = p[d] / l;
                }
                static const int order[6] = {0, 1, 2, 0, 2, 3};
                for (int o = 0; o < 6; o++)
                    for (int d = 0; d < 3; d++) v[k++] = q[order[o]][d];
            }
    }
    return v;
}

/* Loop subdivision (pbrt-v4's LoopSubdivide rules, our own code): `levels`
 * refinements of the triangle mesh (v: nv points, f: nf x 3 indices),
 * then every vertex moved to its limit position. Even vertices: interior
 * (1 - n beta) p + beta sum(ring), beta = 3/16 for valence 3 else 3/(8n);
 * boundary 3/4 p + 1/8 (its two boundary neighbours). Odd (edge) vertices:
 * interior 3/8 (a + b) + 1/8 (c + d), boundary (a + b) / 2. Limit:
 * interior (1 - n g) p + g sum(ring), g = 1 / (n + 3 / (8 beta));
 * boundary 3/5 p + 1/5 (its boundary neighbours). Faces split into four
 * in pbrt's child order (corner 0, 1, 2, then the middle). The mesh must
 * be an oriented manifold (each directed edge once, at most two faces per
 * edge, at most one boundary fan per vertex). Output: *pv (3 * *pnv
 * doubles) and *pf (3 * *pnf indices), malloc'd. 0, or -1 with why. */
typedef struct edgeent {
    int32_t a, b;   /* a < b */
    int32_t f[2];   /* faces on it (-1 none) */
    int32_t opp[2]; /* their third vertices */
    int32_t mid;    /* first use a < b (while counting), then the odd vertex's index */
} edgeent;

static int subdivide(const double *v0, long nv0, const long *f0, long nf0, int levels, double **pv, long *pnv,
                     long **pf, long *pnf, char *why, size_t nwhy, rt_err *e)
{
    double *v = rt_calloc((size_t)nv0 * 3, sizeof *v, e);
    long *f = rt_calloc((size_t)nf0 * 3, sizeof *f, e);
    long nv = nv0, nf = nf0;
    int rc = -1;
    edgeent *E = NULL;
    uint32_t *slot = NULL; /* 1 + index into E, 0 = empty */
    long *nb = NULL, *bcount = NULL;
    double *acc = NULL, *bacc = NULL;
    if (!v || !f) goto done;
    memcpy(v, v0, sizeof *v * 3 * (size_t)nv0);
    memcpy(f, f0, sizeof *f * 3 * (size_t)nf0);
    for (int level = 0;; level++) {
        /* edges: open hashing on the unordered pair */
        long ne = 0, nslot = 64;
        while (nslot < 2 * 3 * nf) nslot *= 2;
        free(E);
        free(slot);
        E = rt_calloc((size_t)(3 * nf), sizeof *E, e);
        slot = rt_calloc((size_t)nslot, sizeof *slot, e);
        if (!E || !slot) goto done;
        for (long i = 0; i < nf; i++)
            for (int k = 0; k < 3; k++) {
                long a = f[3 * i + k], b = f[3 * i + (k + 1) % 3], c = f[3 * i + (k + 2) % 3];
                if (a == b) {
                    snprintf(why, nwhy, "face %ld uses vertex %ld twice", i, a);
                    goto done;
                }
                long lo = a < b ? a : b, hi = a < b ? b : a;
                uint64_t h = rt_mix64((uint64_t)lo * 0x9e3779b97f4a7c15ULL ^ (uint64_t)hi) & (uint64_t)(nslot - 1);
                while (slot[h] && !(E[slot[h] - 1].a == lo && E[slot[h] - 1].b == hi)) h = (h + 1) & (uint64_t)(nslot - 1);
                if (!slot[h]) {
                    edgeent *x = &E[ne++];
                    x->a = (int32_t)lo, x->b = (int32_t)hi, x->f[0] = (int32_t)i, x->f[1] = -1;
                    x->opp[0] = (int32_t)c, x->opp[1] = -1;
                    x->mid = a < b; /* remember the direction of the first use */
                    slot[h] = (uint32_t)ne;
                } else {
                    edgeent *x = &E[slot[h] - 1];
                    if (x->f[1] >= 0) {
                        snprintf(why, nwhy, "edge %ld-%ld is shared by more than two faces", lo, hi);
                        goto done;
                    }
                    if (x->mid == (a < b)) {
                        snprintf(why, nwhy, "faces %ld and %ld run along edge %ld-%ld the same way (orientation)",
                                 (long)x->f[0], i, lo, hi);
                        goto done;
                    }
                    x->f[1] = (int32_t)i, x->opp[1] = (int32_t)c;
                }
            }
        /* per vertex: neighbour sums and counts, boundary neighbours */
        free(acc);
        free(bacc);
        free(nb);
        free(bcount);
        acc = rt_calloc((size_t)nv * 3, sizeof *acc, e);
        bacc = rt_calloc((size_t)nv * 3, sizeof *bacc, e);
        nb = rt_calloc((size_t)nv, sizeof *nb, e);
        bcount = rt_calloc((size_t)nv, sizeof *bcount, e);
        if (!acc || !bacc || !nb || !bcount) goto done;
        for (long i = 0; i < ne; i++) {
            const edgeent *x = &E[i];
            int bnd = x->f[1] < 0;
            for (int s2 = 0; s2 < 2; s2++) {
                long p = s2 ? x->b : x->a, q = s2 ? x->a : x->b;
                nb[p]++;
                for (int d = 0; d < 3; d++) acc[3 * p + d] += v[3 * q + d];
                if (bnd) {
                    bcount[p]++;
                    for (int d = 0; d < 3; d++) bacc[3 * p + d] += v[3 * q + d];
                }
            }
        }
        for (long i = 0; i < nv; i++)
            if (bcount[i] != 0 && bcount[i] != 2) {
                snprintf(why, nwhy, "vertex %ld joins %ld boundary edges (not a manifold)", i, bcount[i]);
                goto done;
            }
        if (level == levels) {
            /* push to the limit surface (vertices in no face stay) */
            for (long i = 0; i < nv; i++) {
                double *p = &v[3 * i];
                if (!nb[i]) continue;
                if (bcount[i]) {
                    for (int d = 0; d < 3; d++) p[d] = 0.6 * p[d] + 0.2 * bacc[3 * i + d];
                } else {
                    double n = (double)nb[i], beta = nb[i] == 3 ? 3.0 / 16.0 : 3.0 / (8.0 * n);
                    double g = 1.0 / (n + 3.0 / (8.0 * beta));
                    for (int d = 0; d < 3; d++) p[d] = (1 - n * g) * p[d] + g * acc[3 * i + d];
                }
            }
            break;
        }
        /* refine: even vertices keep their indices, odd ones follow */
        long nv2 = nv + ne, nf2 = 4 * nf;
        double *v2 = rt_calloc((size_t)nv2 * 3, sizeof *v2, e);
        long *f2 = rt_calloc((size_t)nf2 * 3, sizeof *f2, e);
        if (!v2 || !f2) {
            free(v2);
            free(f2);
            goto done;
        }
        for (long i = 0; i < nv; i++) {
            const double *p = &v[3 * i];
            double *o = &v2[3 * i];
            if (!nb[i]) {
                for (int d = 0; d < 3; d++) o[d] = p[d];
            } else if (bcount[i]) {
                for (int d = 0; d < 3; d++) o[d] = 0.75 * p[d] + 0.125 * bacc[3 * i + d];
            } else {
                double n = (double)nb[i], beta = nb[i] == 3 ? 3.0 / 16.0 : 3.0 / (8.0 * n);
                for (int d = 0; d < 3; d++) o[d] = (1 - n * beta) * p[d] + beta * acc[3 * i + d];
            }
        }
        for (long i = 0; i < ne; i++) {
            edgeent *x = &E[i];
            double *o = &v2[3 * (nv + i)];
            for (int d = 0; d < 3; d++) {
                if (x->f[1] < 0) o[d] = 0.5 * v[3 * x->a + d] + 0.5 * v[3 * x->b + d];
                else
                    o[d] = 0.375 * v[3 * x->a + d] + 0.375 * v[3 * x->b + d] + 0.125 * v[3 * x->opp[0] + d] +
                           0.125 * v[3 * x->opp[1] + d];
            }
            x->mid = (int32_t)(nv + i);
        }
        for (long i = 0; i < nf; i++) {
            long c[3], m[3];
            for (int k = 0; k < 3; k++) {
                long a = f[3 * i + k], b = f[3 * i + (k + 1) % 3];
                long lo = a < b ? a : b, hi = a < b ? b : a;
                uint64_t h = rt_mix64((uint64_t)lo * 0x9e3779b97f4a7c15ULL ^ (uint64_t)hi) & (uint64_t)(nslot - 1);
                while (!(E[slot[h] - 1].a == lo && E[slot[h] - 1].b == hi)) h = (h + 1) & (uint64_t)(nslot - 1);
                c[k] = a;
                m[k] = E[slot[h] - 1].mid; /* on edge k -> k+1 */
            }
            long *o = &f2[12 * i];
            long child[4][3] = {{c[0], m[0], m[2]}, {m[0], c[1], m[1]}, {m[2], m[1], c[2]}, {m[0], m[1], m[2]}};
            for (int ch = 0; ch < 4; ch++)
                for (int k = 0; k < 3; k++) o[3 * ch + k] = child[ch][k];
        }
        free(v);
        free(f);
        v = v2, f = f2, nv = nv2, nf = nf2;
    }
    *pv = v, *pnv = nv, *pf = f, *pnf = nf;
    v = NULL, f = NULL;
    rc = 0;
done:
    if (rc < 0 && !why[0]) snprintf(why, nwhy, "%.150s", e ? e->msg : "out of memory");
    free(v);
    free(f);
    free(E);
    free(slot);
    free(acc);
    free(bacc);
    free(nb);
    free(bcount);
    return rc;
}

/* Counts a light; the fourth one gets the warning. */
static void count_light(pbrt *P, const token *t)
{
    if (++P->nlights_all == RT_NLIGHTS + 1)
        pwarn(P, t, "lights",
              "more than %d lights: the point model keeps %d, point and spot lights first (--light-samples traces all)",
              RT_NLIGHTS, RT_NLIGHTS);
}

/* Records an area-light shape (triangles from `start` on) for the lights. */
static int note_area_light(pbrt *P, const token *d, uint32_t start)
{
    if (P->nal == P->cal) {
        int nc = P->cal ? 2 * P->cal : 8;
        arealight *na = rt_reallocarray(P->al, (size_t)nc, sizeof *na, P->e);
        if (!na) return -1;
        P->al = na;
        P->cal = nc;
    }
    arealight *a = &P->al[P->nal++];
    memset(a, 0, sizeof *a);
    where(P, d, a->at, sizeof a->at, 0);
    for (uint32_t i = start; i < P->s->ntri; i++) {
        const rt_vec3 *p = P->s->tri[i].p;
        double e1[3] = {(double)p[1].x - p[0].x, (double)p[1].y - p[0].y, (double)p[1].z - p[0].z};
        double e2[3] = {(double)p[2].x - p[0].x, (double)p[2].y - p[0].y, (double)p[2].z - p[0].z};
        double n[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]};
        double w = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
        a->area2 += w;
        a->nsum[0] += n[0], a->nsum[1] += n[1], a->nsum[2] += n[2];
        a->c[0] += w * ((double)p[0].x + p[1].x + p[2].x) / 3;
        a->c[1] += w * ((double)p[0].y + p[1].y + p[2].y) / 3;
        a->c[2] += w * ((double)p[0].z + p[1].z + p[2].z) / 3;
    }
    count_light(P, d);
    return 0;
}

/* Authored lights (scene.h "Lights as authored"): a record for the scene's
 * lights[] beside the point model above, named by the directive's line. */
static int add_light(pbrt *P, const token *t, rt_light *l)
{
    l->scale = 1.0f;
    where(P, t, l->at, sizeof l->at, 0);
    rt_err le;
    if (rt_scene_add_light(P->s, l, &le) < 0) return perr(P, t, "%s", le.msg);
    return 0;
}

/* The emitter of an AreaLightSource on this shape: sphere and disk as
 * analytic shapes (centre and radius from the transform, which is taken
 * as a similarity), other shapes by their triangles [start, ntri). */
static int note_authored_area(pbrt *P, const token *t, const char *type, plist *L, uint32_t start)
{
    rt_light l;
    memset(&l, 0, sizeof l);
    const mat4 *m = &P->g.ctm;
    if (!strcmp(type, "sphere") || !strcmp(type, "disk")) {
        double r, h = 0;
        if (pfloat(P, L, "radius", 1.0, &r) < 0) return -1;
        if (type[0] == 'd' && pfloat(P, L, "height", 0.0, &h) < 0) return -1;
        if (!(r > 0)) return perr(P, t, "Shape \"%s\": radius must be positive", type);
        rt_vec3 c = m_point(m, 0, 0, h), ex = m_point(m, r, 0, h), ey = m_point(m, 0, r, h), ez = m_point(m, 0, 0, h + 1);
        l.p = c;
        l.r = rt_len(rt_sub(ex, c));
        if (type[0] == 's') {
            l.kind = RT_LIGHT_SPHERE;
        } else {
            rt_vec3 n = rt_cross(rt_sub(ex, c), rt_sub(ey, c)); /* the disk's +z side */
            if (rt_dot(n, rt_sub(ez, c)) < 0) n = rt_mul(n, -1.0f);
            l.kind = RT_LIGHT_DISK;
            l.d = rt_norm(n);
        }
        if (!(l.r > 0) || !isfinite(l.r))
            return perr(P, t, "Shape \"%s\": emitter radius out of range after the transform", type);
        return add_light(P, t, &l);
    }
    if (P->s->ntri <= start) return 0;
    l.kind = RT_LIGHT_MESH;
    l.first = start;
    l.count = P->s->ntri - start;
    return add_light(P, t, &l);
}

/* Shape "curve" as flat ribbons: each cubic (or quadratic) Bezier segment
 * -- "bspline" control points are converted to Bezier ones first -- is
 * evaluated at 2^splitdepth + 1 points (splitdepth 3: 8 pieces, 16
 * triangles per segment), mapped by the CTM, and widened across its
 * tangent by the width (width0 to width1 along the whole curve, scaled by
 * the CTM's mean scale): type "ribbon" across its normals N, types "flat"
 * and "cylinder" facing the camera as pbrt's flat curves face the ray (a
 * tube drawn as the ribbon that is its silhouette from the eye). 0 or -1. */
static int make_curve(pbrt *P, const token *tt, plist *L)
{
    const double *cp, *nv = NULL;
    size_t ncp, nn = 0;
    char basis[32], ctype[32];
    long degree, split;
    double w0, w1, w;
    int r = pnums(P, L, "P", B(PT_POINT3), "point3", 3, 3, &cp, &ncp);
    if (r < 0) return -1;
    if (!r) return perr(P, tt, "Shape \"curve\": missing the control points \"point3 P\"");
    ncp /= 3;
    if (pstring(P, L, "basis", basis, sizeof basis) < 0 || pstring(P, L, "type", ctype, sizeof ctype) < 0 ||
        pint(P, L, "degree", 3, &degree) < 0 || pint(P, L, "splitdepth", 3, &split) < 0 ||
        pfloat(P, L, "width", 1, &w) < 0 || pfloat(P, L, "width0", w, &w0) < 0 || pfloat(P, L, "width1", w, &w1) < 0)
        return -1;
    if (!basis[0]) snprintf(basis, sizeof basis, "bezier");
    if (!ctype[0]) snprintf(ctype, sizeof ctype, "flat");
    int bspline = !strcmp(basis, "bspline");
    if (!bspline && strcmp(basis, "bezier")) return perr(P, tt, "Shape \"curve\": basis \"%.20s\" (bezier or bspline)", basis);
    if (degree != 2 && degree != 3) return perr(P, tt, "Shape \"curve\": degree %ld (2 or 3)", degree);
    int ribbon = !strcmp(ctype, "ribbon");
    if (!ribbon && strcmp(ctype, "flat") && strcmp(ctype, "cylinder"))
        return perr(P, tt, "Shape \"curve\": type \"%.20s\" (flat, ribbon or cylinder)", ctype);
    if (split < 0 || split > 6) return perr(P, tt, "Shape \"curve\": splitdepth %ld outside 0..6", split);
    if (!(w0 >= 0 && w1 >= 0)) return perr(P, tt, "Shape \"curve\": negative width");
    size_t nseg = bspline ? (ncp > (size_t)degree ? ncp - (size_t)degree : 0)
                          : (ncp > 1 && (ncp - 1) % (size_t)degree == 0 ? (ncp - 1) / (size_t)degree : 0);
    if (!nseg)
        return perr(P, tt, "Shape \"curve\": %zu control points do not make %s segments of degree %ld", ncp, basis,
                    degree);
    if (ribbon) {
        r = pnums(P, L, "N", B(PT_NORMAL3), "normal3", 3, 3, &nv, &nn);
        if (r < 0) return -1;
        if (nn / 3 != nseg + 1)
            return perr(P, tt, "Shape \"curve\": type \"ribbon\" needs %zu normals \"normal3 N\" (one per segment end), "
                        "got %zu", nseg + 1, nn / 3);
    }
    int pieces = 1 << split;
    if (room_for(P, tt, (uint64_t)nseg * 2 * (uint64_t)pieces) < 0) return -1;
    double sc = 0; /* the CTM's mean scale: its columns' mean length (sqrt only, as all arithmetic here) */
    for (int c = 0; c < 3; c++)
        sc += sqrt(P->g.ctm.m[0][c] * P->g.ctm.m[0][c] + P->g.ctm.m[1][c] * P->g.ctm.m[1][c] +
                   P->g.ctm.m[2][c] * P->g.ctm.m[2][c]) / 3;
    static const double z_up[3] = {0, 0, 1};
    for (size_t sg = 0; sg < nseg; sg++) {
        /* the segment's Bezier control points */
        double b[4][3];
        int nb = (int)degree + 1;
        for (int d = 0; d < 3; d++) {
            const double *p0 = cp + 3 * (bspline ? sg : sg * (size_t)degree) + d;
            if (!bspline) {
                for (int k = 0; k < nb; k++) b[k][d] = p0[3 * k];
            } else if (degree == 3) {
                b[0][d] = (p0[0] + 4 * p0[3] + p0[6]) / 6, b[1][d] = (2 * p0[3] + p0[6]) / 3;
                b[2][d] = (p0[3] + 2 * p0[6]) / 3, b[3][d] = (p0[3] + 4 * p0[6] + p0[9]) / 6;
            } else {
                b[0][d] = (p0[0] + p0[3]) / 2, b[1][d] = p0[3], b[2][d] = (p0[3] + p0[6]) / 2;
            }
        }
        rt_vec3 prevl = {0, 0, 0}, prevr = {0, 0, 0};
        for (int i = 0; i <= pieces; i++) {
            double u = (double)i / pieces, v = 1 - u, q[3], t[3], wq[3];
            for (int d = 0; d < 3; d++) {
                if (degree == 3) {
                    q[d] = v * v * v * b[0][d] + 3 * u * v * v * b[1][d] + 3 * u * u * v * b[2][d] + u * u * u * b[3][d];
                    t[d] = 3 * (v * v * (b[1][d] - b[0][d]) + 2 * u * v * (b[2][d] - b[1][d]) + u * u * (b[3][d] - b[2][d]));
                } else {
                    q[d] = v * v * b[0][d] + 2 * u * v * b[1][d] + u * u * b[2][d];
                    t[d] = 2 * (v * (b[1][d] - b[0][d]) + u * (b[2][d] - b[1][d]));
                }
            }
            m_apply(&P->g.ctm, q, wq);
            /* the tangent in the world: the linear part of the CTM */
            double wt[3], side[3], ref[3];
            for (int d = 0; d < 3; d++) wt[d] = P->g.ctm.m[d][0] * t[0] + P->g.ctm.m[d][1] * t[1] + P->g.ctm.m[d][2] * t[2];
            if (ribbon) {
                const double *n0 = nv + 3 * sg, *n1 = nv + 3 * (sg + 1);
                double n[3] = {v * n0[0] + u * n1[0], v * n0[1] + u * n1[1], v * n0[2] + u * n1[2]};
                for (int d = 0; d < 3; d++) ref[d] = P->g.ctm.m[d][0] * n[0] + P->g.ctm.m[d][1] * n[1] + P->g.ctm.m[d][2] * n[2];
            } else if (P->have_camera) {
                for (int d = 0; d < 3; d++) ref[d] = P->eye[d] - wq[d];
            } else {
                memcpy(ref, z_up, sizeof ref);
            }
            side[0] = wt[1] * ref[2] - wt[2] * ref[1];
            side[1] = wt[2] * ref[0] - wt[0] * ref[2];
            side[2] = wt[0] * ref[1] - wt[1] * ref[0];
            double sl = sqrt(side[0] * side[0] + side[1] * side[1] + side[2] * side[2]);
            if (!(sl > 0)) { /* tangent along the reference: any perpendicular */
                double alt[3] = {fabs(wt[0]) < fabs(wt[1]) ? 1 : 0, fabs(wt[0]) < fabs(wt[1]) ? 0 : 1, 0};
                side[0] = wt[1] * alt[2] - wt[2] * alt[1];
                side[1] = wt[2] * alt[0] - wt[0] * alt[2];
                side[2] = wt[0] * alt[1] - wt[1] * alt[0];
                sl = sqrt(side[0] * side[0] + side[1] * side[1] + side[2] * side[2]);
                if (!(sl > 0)) sl = 1, side[0] = 1, side[1] = side[2] = 0;
            }
            double gu = ((double)sg + u) / (double)nseg; /* along the whole curve */
            double half = 0.5 * ((1 - gu) * w0 + gu * w1) * sc / sl;
            rt_vec3 lft = rt_v3((float)(wq[0] - side[0] * half), (float)(wq[1] - side[1] * half), (float)(wq[2] - side[2] * half));
            rt_vec3 rgt = rt_v3((float)(wq[0] + side[0] * half), (float)(wq[1] + side[1] * half), (float)(wq[2] + side[2] * half));
            if (i > 0 && (emit(P, prevl, prevr, rgt) < 0 || emit(P, prevl, rgt, lft) < 0)) return -1;
            prevl = lft, prevr = rgt;
        }
    }
    char q[48];
    snprintf(q, sizeof q, "%.20s", ctype);
    pwarn(P, tt, "curve", "Shape \"curve\" (type \"%s\") made as %s ribbons, %d pieces (%d triangles) per segment", q,
          ribbon ? "normal-oriented" : "camera-facing", pieces, 2 * pieces);
    return 0;
}

/* ------------------------------------------------------------------------ */
/* Alpha textures                                                            */

/* 1 when name ends in ext (case-insensitive). */
static int has_ext(const char *name, const char *ext)
{
    size_t n = strlen(name), k = strlen(ext);
    if (n < k) return 0;
    for (size_t i = 0; i < k; i++) {
        char c = name[n - k + i];
        if (c >= 'A' && c <= 'Z') c = (char)(c - 'A' + 'a');
        if (c != ext[i]) return 0;
    }
    return 1;
}

/* Texture "name" "type" "class" params. A float imagemap is read here
 * (PNG through libpng, OpenEXR through OpenEXRCore; the file named as
 * pbrt resolves it, opened once like every file) into an alpha map, its
 * texels already scaled and inverted (src/alpha.h); every other texture
 * is skipped with a warning. A shape names the texture later by "texture
 * alpha". */
static int do_texture(pbrt *P, const token *d)
{
    char name[256], type[32], cls[32], q[300];
    token tn, tt, tc;
    plist L = {NULL, 0, 0};
    if (need_string(P, d, name, sizeof name, &tn) < 0 || need_string(P, d, type, sizeof type, &tt) < 0 ||
        need_string(P, d, cls, sizeof cls, &tc) < 0 || parse_params(P, &L) < 0)
        goto fail;
    rt_esc(q, sizeof q, name, 200);
    texdef td = {-1};
    if (strcmp(type, "float") || strcmp(cls, "imagemap")) {
        pwarn(P, d, "Texture", "Texture skipped (not a float imagemap)");
    } else {
        char fname[4096], enc[32], filt[32], wrap[32], why[200], q2[300];
        double scale;
        const double *bv;
        size_t nb;
        int inv = 0;
        if (pstring(P, &L, "filename", fname, sizeof fname) < 0 || pstring(P, &L, "encoding", enc, sizeof enc) < 0 ||
            pstring(P, &L, "filter", filt, sizeof filt) < 0 || pstring(P, &L, "wrap", wrap, sizeof wrap) < 0 ||
            pfloat(P, &L, "scale", 1.0, &scale) < 0)
            goto fail;
        int rb = pnums(P, &L, "invert", B(PT_BOOL), "bool", 1, 1, &bv, &nb);
        if (rb < 0) goto fail;
        if (rb) inv = bv[0] != 0;
        if (!fname[0]) {
            perr(P, &tc, "Texture \"%s\": missing \"string filename\"", q);
            goto fail;
        }
        rt_esc(q2, sizeof q2, fname, 256);
        if (!isfinite(scale)) {
            perr(P, &pfind(&L, "scale")->at, "Texture \"%s\": scale is not finite", q);
            goto fail;
        }
        int png = has_ext(fname, ".png"), exr = has_ext(fname, ".exr");
        if (!png && !exr) {
            perr(P, &pfind(&L, "filename")->at, "Texture \"%s\": \"%s\": only PNG (.png) and OpenEXR (.exr) images are read",
                 q, q2);
            goto fail;
        }
        int srgb = png; /* pbrt's default encoding: sRGB for PNG, linear otherwise */
        if (!strcmp(enc, "linear")) srgb = 0;
        else if (!strcmp(enc, "sRGB")) srgb = 1;
        else if (enc[0]) {
            char a[40];
            pwarn(P, d, "texture encoding", "Texture \"%s\": encoding \"%s\" read as %s", q, rt_esc(a, sizeof a, enc, 20),
                  srgb ? "sRGB" : "linear");
        }
        if (exr) srgb = 0;
        if (strcmp(filt, "point"))
            pwarn(P, d, "texture filter", "Texture \"%s\": looked up at the nearest texel (pbrt filters %s)", q,
                  filt[0] ? "as its \"filter\" says" : "bilinearly");
        if (wrap[0] && strcmp(wrap, "repeat")) {
            char a[40];
            pwarn(P, d, "texture wrap", "Texture \"%s\": wrap \"%s\" read as \"repeat\"", q, rt_esc(a, sizeof a, wrap, 20));
        }
        char *rel = NULL, *full = NULL, *buf = NULL;
        size_t n = 0;
        int fd;
        struct stat st;
        if (resolve(P, &pfind(&L, "filename")->at, "Texture", fname, &rel, &full) < 0) goto fail;
        free(rel);
        if (open_regular(full, &fd, &st, why, sizeof why) < 0 || read_fd(P, fd, &st, &buf, &n, why, sizeof why) < 0) {
            free(full);
            perr(P, &pfind(&L, "filename")->at, "Texture \"%s\": \"%s\": %s", q, q2, why);
            goto fail;
        }
        float *px = NULL;
        uint32_t w = 0, h = 0;
        rt_err ie;
        int r = png ? rt_alpha_decode_png((const unsigned char *)buf, n, full, srgb, &px, &w, &h, &ie)
                    : rt_alpha_decode_exr((const unsigned char *)buf, n, full, &px, &w, &h, &ie);
        free(buf);
        free(full);
        if (r < 0) {
            perr(P, &pfind(&L, "filename")->at, "Texture \"%s\": %s", q, ie.msg);
            goto fail;
        }
        uint64_t nt = (uint64_t)w * h;
        if (nt > RT_ALPHA_MAX_TEXELS - P->ntexel) {
            free(px);
            perr(P, d, "Texture \"%s\": the alpha textures would hold more than %llu texels", q,
                 (unsigned long long)RT_ALPHA_MAX_TEXELS);
            goto fail;
        }
        for (uint64_t i = 0; i < nt; i++) { /* pbrt: scale * v, then invert: max(0, 1 - v) */
            double v = scale * (double)px[i];
            if (inv) v = 1 - v > 0 ? 1 - v : 0;
            if (!(v >= 0)) v = 0; /* a negative alpha counts as 0 (pbrt: a <= 0 is cut) */
            px[i] = (float)v;
            if (!isfinite(px[i])) {
                free(px);
                perr(P, &pfind(&L, "filename")->at, "Texture \"%s\": texel %llu is not finite after the scale", q,
                     (unsigned long long)i);
                goto fail;
            }
        }
        if (P->namap == P->camap) {
            uint32_t nc = P->camap ? 2 * P->camap : 8;
            rt_alpha_map *nm = rt_reallocarray(P->amap, nc, sizeof *nm, P->e);
            if (!nm) {
                free(px);
                goto fail;
            }
            P->amap = nm;
            P->camap = nc;
        }
        if (P->ntexel + nt > P->ctexel) {
            uint64_t nc = P->ctexel ? P->ctexel : 4096;
            while (nc < P->ntexel + nt) nc *= 2;
            float *nx = rt_reallocarray(P->texel, (size_t)nc, sizeof *nx, P->e);
            if (!nx) {
                free(px);
                goto fail;
            }
            P->texel = nx;
            P->ctexel = nc;
        }
        memcpy(P->texel + P->ntexel, px, (size_t)nt * sizeof *px);
        free(px);
        rt_alpha_map *m = &P->amap[P->namap];
        memset(m, 0, sizeof *m);
        m->w = w;
        m->h = h;
        m->off = P->ntexel;
        snprintf(m->name, sizeof m->name, "%.63s", name);
        P->ntexel += nt;
        td.map = (int)P->namap++;
    }
    int k = nm_find(&P->named_tex, name);
    if (k >= 0) { /* pbrt: a redefinition replaces the texture */
        pwarn(P, &tn, "texture redefined", "Texture \"%s\" defined again: the later one is used", q);
        P->tex[k] = td;
    } else {
        if (P->ntex == P->ctex) {
            int nc = P->ctex ? 2 * P->ctex : 8;
            texdef *nt = rt_reallocarray(P->tex, (size_t)nc, sizeof *nt, P->e);
            if (!nt) goto fail;
            P->tex = nt;
            P->ctex = nc;
        }
        if (nm_put(&P->named_tex, name, P->ntex, P->e) < 0) goto fail;
        P->tex[P->ntex++] = td;
    }
    plist_free(&L);
    return 0;
fail:
    plist_free(&L);
    return -1;
}

/* The map a shape's "texture alpha" names, or -1 (drawn opaque, warned):
 * only a float imagemap defined before it, on a trianglemesh or
 * bilinearmesh outside an object definition. */
static int alpha_map_of(pbrt *P, const param *alpha, const char *type, const char *q, const token *tt)
{
    char tn[256], qt[300];
    if (alpha->ns != 1) return perr(P, &alpha->at, "parameter \"texture alpha\": expected one texture name"), -2;
    if (tok_str(P, &alpha->s[0], tn, sizeof tn) < 0) return -2;
    rt_esc(qt, sizeof qt, tn, 200);
    int k = nm_find(&P->named_tex, tn);
    if (k < 0 || P->tex[k].map < 0) {
        pwarn(P, tt, "alpha texture", "Shape \"%s\": alpha texture ignored, drawn opaque: \"%s\" is not a float imagemap "
              "Texture defined before it", q, qt);
        return -1;
    }
    if (strcmp(type, "trianglemesh") && strcmp(type, "bilinearmesh")) {
        pwarn(P, tt, "alpha texture shape", "Shape \"%s\": alpha texture \"%s\" ignored, drawn opaque (cutouts on "
              "trianglemesh and bilinearmesh only)", q, qt);
        return -1;
    }
    if (P->alpha_off) {
        pwarn(P, tt, "alpha off", "Shape \"%s\": alpha texture \"%s\" drawn opaque (the spec parameter alpha=0)", q, qt);
        return -1;
    }
    if (P->in_obj >= 0) {
        pwarn(P, tt, "alpha texture object", "Shape \"%s\": alpha texture \"%s\" inside ObjectBegin ignored, drawn opaque",
              q, qt);
        return -1;
    }
    return P->tex[k].map;
}

/* Records the uv of the triangles [start, s->ntri) just made from the
 * corner indices idx (3 per triangle, or 4 per bilinear patch: p00 p10
 * p01 p11, made as (p00 p10 p11) (p00 p11 p01)) with the mesh's "uv"
 * (point2 per vertex) or pbrt's defaults: (0,0) (1,0) (1,1) per triangle,
 * the patch's corners (0,0) (1,0) (0,1) (1,1). */
static int alpha_span(pbrt *P, plist *L, const token *tt, int map, uint32_t start, const long *idx, size_t ni, size_t nw,
                      int bil)
{
    const double *uv;
    size_t nuv;
    int r = pnums(P, L, "uv", B(PT_POINT2) | B(PT_FLOAT), "point2", 2, 2, &uv, &nuv);
    if (r < 0) return -1;
    if (r && nuv != 2 * nw)
        return perr(P, &pfind(L, "uv")->at, "parameter \"uv\": %zu values for %zu vertices, expected %zu", nuv, nw, 2 * nw);
    for (size_t i = 0; r && i < nuv; i++)
        if (!(fabs(uv[i]) < 1e30)) return perr(P, &pfind(L, "uv")->at, "parameter \"uv\": value %g is not finite", uv[i]);
    uint32_t count = P->s->ntri - start;
    if (!count) return 0;
    if (P->nspan == P->cspan) {
        int nc = P->cspan ? 2 * P->cspan : 8;
        aspan *ns = rt_reallocarray(P->span, (size_t)nc, sizeof *ns, P->e);
        if (!ns) return -1;
        P->span = ns;
        P->cspan = nc;
    }
    float *u = rt_reallocarray(NULL, (size_t)count, 6 * sizeof *u, P->e);
    if (!u) return -1;
    static const float dtri[6] = {0, 0, 1, 0, 1, 1};
    static const float dbil[2][6] = {{0, 0, 1, 0, 1, 1}, {0, 0, 1, 1, 0, 1}};
    static const int cbil[2][3] = {{0, 1, 3}, {0, 3, 2}};
    for (uint32_t t = 0; t < count; t++) {
        float *o = u + 6 * (size_t)t;
        for (int c = 0; c < 3; c++) {
            long v = bil ? idx[4 * (t / 2) + cbil[t & 1][c]] : idx[3 * (size_t)t + c];
            if (r) {
                o[2 * c] = (float)uv[2 * v];
                o[2 * c + 1] = (float)uv[2 * v + 1];
            } else {
                o[2 * c] = bil ? dbil[t & 1][2 * c] : dtri[2 * c];
                o[2 * c + 1] = bil ? dbil[t & 1][2 * c + 1] : dtri[2 * c + 1];
            }
        }
    }
    (void)ni;
    (void)tt;
    P->span[P->nspan++] = (aspan){start, count, (uint32_t)map, u};
    return 0;
}

/* The alpha spans' triangles once the instances are made (as
 * relocate_mesh_lights; called before expand_instances). */
static void relocate_alpha(pbrt *P)
{
    for (int i = 0; i < P->nspan; i++) {
        uint64_t shift = 0;
        for (int k = 0; k < P->ninst; k++)
            if (P->inst[k].at <= P->span[i].first) shift += P->objs[P->inst[k].obj].count;
        P->span[i].first += (uint32_t)shift;
    }
}

/* The scene's rt_scene_alpha from the spans (none: no alpha, and the maps
 * read are dropped). 0 or -1. */
static int make_alpha(pbrt *P)
{
    rt_scene *s = P->s;
    if (!P->nspan) return 0;
    rt_scene_alpha *A = rt_calloc(1, sizeof *A, P->e);
    if (!A) return -1;
    /* indices of the flattened order (instances kept or not: the spans
     * were relocated into it); the arrays end at the last textured one */
    A->ntri = rt_scene_nflat(s);
    for (int i = 0; i < P->nspan; i++)
        if (P->span[i].first + P->span[i].count > A->nrec) A->nrec = P->span[i].first + P->span[i].count;
    A->tmap = rt_calloc(A->nrec, sizeof *A->tmap, P->e);
    A->uv = rt_calloc((size_t)A->nrec * 6, sizeof *A->uv, P->e);
    if (!A->tmap || !A->uv) {
        rt_alpha_free(A);
        return -1;
    }
    for (int i = 0; i < P->nspan; i++) {
        const aspan *a = &P->span[i];
        for (uint32_t t = 0; t < a->count; t++) A->tmap[a->first + t] = a->map + 1;
        memcpy(A->uv + 6 * (size_t)a->first, a->uv, (size_t)a->count * 6 * sizeof *a->uv);
    }
    A->nmap = P->namap;
    A->map = P->amap;
    A->ntexel = P->ntexel;
    A->texel = P->texel;
    P->amap = NULL;
    P->texel = NULL;
    s->alpha = A;
    return rt_alpha_check(A, P->e);
}

static int do_shape(pbrt *P, const token *d)
{
    if (need_world(P, d, 1) < 0) return -1;
    char type[64], q[80];
    token tt;
    plist L = {NULL, 0, 0};
    if (need_string(P, d, type, sizeof type, &tt) < 0 || parse_params(P, &L) < 0) goto fail;
    rt_esc(q, sizeof q, type, 40);
    P->shape_tok = tt;
    /* colour and table entry of the state */
    matdef *md = &P->mats[P->g.mat];
    if (md->invisible) { /* Material "interface": rays pass through, as in pbrt */
        pwarn(P, &tt, "interface", "Shape \"%s\" with Material \"interface\" left out (invisible: rays pass, as in "
              "pbrt, but are not tested against it)", q);
        plist_free(&L);
        return 0;
    }
    param *alpha = pfind(&L, "alpha");
    int amap = -1; /* the alpha map of the shape, -1: opaque */
    if (alpha && (alpha->type == PT_FLOAT || alpha->type == PT_INT)) {
        double a;
        if (pfloat(P, &L, "alpha", 1, &a) < 0) goto fail;
        if (!(a >= 0 && a <= 1)) {
            perr(P, &alpha->at, "Shape \"%s\": alpha %g outside [0, 1]", q, a);
            goto fail;
        }
        if (a == 0) { /* pbrt: fully transparent, the shape is never hit */
            pwarn(P, &tt, "alpha 0", "Shape \"%s\" with \"float alpha\" 0 left out (never hit, as in pbrt)", q);
            plist_free(&L);
            return 0;
        }
        if (a < 1) pwarn(P, &tt, "alpha partial", "Shape \"%s\": \"float alpha\" %g drawn opaque (no stochastic "
                         "transparency)", q, a);
    } else if (alpha && alpha->type == PT_TEXTURE) {
        if ((amap = alpha_map_of(P, alpha, type, q, &tt)) == -2) goto fail;
    } else if (alpha) {
        perr(P, &alpha->at, "parameter \"%s alpha\": \"alpha\" must be float or texture", alpha->tname);
        goto fail;
    }
    P->cur_rgb = md->rgb;
    if (table_index(P, md, P->g.ke, P->g.area, &P->cur_mat) < 0) goto fail;
    uint32_t start = P->s->ntri;
    rt_vec3 *w = NULL;
    long *idx = NULL;
    size_t nw = 0, ni = 0;
    int rc = 0;
    if (!strcmp(type, "trianglemesh") || !strcmp(type, "bilinearmesh")) {
        int bil = type[0] == 'b';
        rc = get_points(P, &tt, type, &L, &w, &nw);
        if (rc == 0) rc = get_indices(P, &tt, type, &L, bil ? 4 : 3, nw, &idx, &ni);
        if (rc == 0) rc = room_for(P, &tt, bil ? ni / 2 : ni / 3);
        if (rc == 0 && !bil) rc = emit_indexed(P, w, idx, ni);
        for (size_t i = 0; rc == 0 && bil && i + 3 < ni; i += 4) /* p00 p10 p01 p11 */
            if (emit(P, w[idx[i]], w[idx[i + 1]], w[idx[i + 3]]) < 0 || emit(P, w[idx[i]], w[idx[i + 3]], w[idx[i + 2]]) < 0)
                rc = -1;
        if (rc == 0 && amap >= 0) rc = alpha_span(P, &L, &tt, amap, start, idx, ni, nw, bil);
    } else if (!strcmp(type, "sphere")) {
        double r;
        rc = pfloat(P, &L, "radius", 1.0, &r);
        if (rc == 0 && !(r > 0)) rc = perr(P, &pfind(&L, "radius")->at, "Shape \"sphere\": radius must be positive");
        if (rc == 0 && (pfind(&L, "zmin") || pfind(&L, "zmax") || pfind(&L, "phimax")))
            pwarn(P, &tt, "sphere partial", "Shape \"sphere\": zmin, zmax and phimax ignored (whole spheres)");
        if (rc == 0) rc = room_for(P, &tt, 12u * (uint64_t)P->tess * (uint64_t)P->tess);
        double *tm = rc == 0 ? sphere_template(P->tess, P->e) : NULL;
        if (rc == 0 && !tm) rc = -1;
        for (size_t k = 0; rc == 0 && k < (size_t)108 * P->tess * P->tess; k += 9) {
            rt_vec3 a = m_point(&P->g.ctm, r * tm[k], r * tm[k + 1], r * tm[k + 2]);
            rt_vec3 b = m_point(&P->g.ctm, r * tm[k + 3], r * tm[k + 4], r * tm[k + 5]);
            rt_vec3 c = m_point(&P->g.ctm, r * tm[k + 6], r * tm[k + 7], r * tm[k + 8]);
            rc = emit(P, a, b, c);
        }
        free(tm);
    } else if (!strcmp(type, "disk") || !strcmp(type, "cylinder")) {
        /* 8 x tess segments around (24 at tess=3) over phimax; a disk is a
         * fan (an annulus with innerradius), a cylinder one band of quads */
        int disk = type[0] == 'd';
        double r, h = 0, ri = 0, z0 = -1, z1 = 1, phimax;
        rc = pfloat(P, &L, "radius", 1.0, &r);
        if (rc == 0) rc = pfloat(P, &L, "phimax", 360, &phimax);
        if (rc == 0 && disk) rc = pfloat(P, &L, "height", 0, &h);
        if (rc == 0 && disk) rc = pfloat(P, &L, "innerradius", 0, &ri);
        if (rc == 0 && !disk) rc = pfloat(P, &L, "zmin", -1, &z0);
        if (rc == 0 && !disk) rc = pfloat(P, &L, "zmax", 1, &z1);
        if (rc == 0 && !(r > 0)) rc = perr(P, &tt, "Shape \"%s\": radius must be positive", q);
        if (rc == 0 && !(ri >= 0 && ri < r)) rc = perr(P, &tt, "Shape \"disk\": innerradius must be in [0, radius)");
        if (rc == 0 && !(z0 != z1)) rc = perr(P, &tt, "Shape \"cylinder\": zmin and zmax coincide");
        if (rc == 0 && !(phimax > 0 && phimax <= 360)) rc = perr(P, &tt, "Shape \"%s\": phimax outside (0, 360]", q);
        int nseg = 8 * P->tess;
        if (rc == 0) rc = room_for(P, &tt, (uint64_t)nseg * (disk && ri == 0 ? 1 : 2));
        for (int i = 0; rc == 0 && i < nseg; i++) {
            double s0, c0, s1, c1;
            rt_dsincos_deg(phimax * i / nseg, &s0, &c0);
            rt_dsincos_deg(phimax * (i + 1) / nseg, &s1, &c1);
            if (disk) {
                rt_vec3 a = m_point(&P->g.ctm, r * c0, r * s0, h), b = m_point(&P->g.ctm, r * c1, r * s1, h);
                if (ri == 0) {
                    rc = emit(P, m_point(&P->g.ctm, 0, 0, h), a, b);
                } else {
                    rt_vec3 ia = m_point(&P->g.ctm, ri * c0, ri * s0, h), ib = m_point(&P->g.ctm, ri * c1, ri * s1, h);
                    rc = emit(P, ia, a, b);
                    if (rc == 0) rc = emit(P, ia, b, ib);
                }
            } else {
                rt_vec3 a0 = m_point(&P->g.ctm, r * c0, r * s0, z0), a1 = m_point(&P->g.ctm, r * c1, r * s1, z0);
                rt_vec3 b0 = m_point(&P->g.ctm, r * c0, r * s0, z1), b1 = m_point(&P->g.ctm, r * c1, r * s1, z1);
                rc = emit(P, a0, a1, b1);
                if (rc == 0) rc = emit(P, a0, b1, b0);
            }
        }
    } else if (!strcmp(type, "curve")) {
        rc = make_curve(P, &tt, &L);
    } else if (!strcmp(type, "loopsubdiv")) {
        long levels;
        const double *pv;
        size_t npv;
        rc = pint(P, &L, "levels", 3, &levels);
        if (rc == 0 && levels < 0) rc = perr(P, &pfind(&L, "levels")->at, "Shape \"loopsubdiv\": levels %ld is negative", levels);
        if (rc == 0) {
            int r = pnums(P, &L, "P", B(PT_POINT3), "point3", 3, 3, &pv, &npv);
            rc = r < 0 ? -1 : r == 0 ? perr(P, &tt, "Shape \"loopsubdiv\": missing the vertices \"point3 P\"") : 0;
        }
        if (rc == 0) rc = get_indices(P, &tt, type, &L, 3, npv / 3, &idx, &ni);
        /* the output size before any allocation: 4^levels x the faces
         * (subdivide's working memory is about 200 bytes per output
         * face, hence a limit of its own below maxtri) */
        uint64_t nt = ni / 3;
        long lv = 0;
        for (; rc == 0 && lv < levels && nt <= P->maxsubdiv; lv++) nt *= 4;
        if (rc == 0 && nt > P->maxsubdiv)
            rc = perr(P, &pfind(&L, "levels")->at,
                      "Shape \"loopsubdiv\": %llu faces at levels %ld make %s%llu triangles, more than maxsubdiv=%u "
                      "(raise it with the spec parameter FILE.pbrt:maxsubdiv=N)", (unsigned long long)(ni / 3), levels,
                      lv < levels ? "over " : "", (unsigned long long)nt, (unsigned)P->maxsubdiv);
        if (rc == 0) rc = room_for(P, &tt, nt);
        if (rc == 0) {
            double *ov = NULL;
            long *of = NULL, onv = 0, onf = 0;
            char why[160] = "";
            if (subdivide(pv, (long)(npv / 3), idx, (long)(ni / 3), (int)levels, &ov, &onv, &of, &onf, why, sizeof why,
                          P->e) < 0)
                rc = perr(P, &tt, "Shape \"loopsubdiv\": %s", why);
            for (long i = 0; rc == 0 && i < onf; i++) {
                rt_vec3 c[3];
                for (int k = 0; k < 3; k++) {
                    const double *p = &ov[3 * of[3 * i + k]];
                    c[k] = m_point(&P->g.ctm, p[0], p[1], p[2]);
                }
                rc = emit(P, c[0], c[1], c[2]);
            }
            free(ov);
            free(of);
        }
    } else if (!strcmp(type, "plymesh")) {
        char name[4096], why[200];
        rc = pstring(P, &L, "filename", name, sizeof name);
        if (rc == 0 && !name[0]) rc = perr(P, &tt, "Shape \"plymesh\": missing \"string filename\"");
        char *rel = NULL, *full = NULL, *buf = NULL;
        size_t n = 0;
        int fd;
        struct stat st;
        if (rc == 0) rc = resolve(P, &pfind(&L, "filename")->at, "plymesh", name, &rel, &full);
        if (rc == 0 && (open_regular(full, &fd, &st, why, sizeof why) < 0 || read_fd(P, fd, &st, &buf, &n, why, sizeof why) < 0)) {
            char q2[300];
            rc = perr(P, &pfind(&L, "filename")->at, "plymesh \"%s\": %s", rt_esc(q2, sizeof q2, name, 256), why);
        }
        if (rc == 0) { /* the shared reader (ply_read.c), then the triangles under the CTM */
            rt_ply_mesh pm;
            rt_err pe;
            if (rt_ply_parse(full, buf, n, &pm, &pe) < 0) rc = perr(P, &tt, "plymesh: %s", pe.msg);
            else {
                free(buf); /* the text is no longer needed */
                buf = NULL;
                rc = room_for(P, &tt, pm.nidx / 3);
                for (size_t k = 0; rc == 0 && k < pm.nidx; k += 3) {
                    const rt_vec3 *a = &pm.v[pm.idx[k]], *b = &pm.v[pm.idx[k + 1]], *c = &pm.v[pm.idx[k + 2]];
                    rc = emit(P, m_point(&P->g.ctm, a->x, a->y, a->z), m_point(&P->g.ctm, b->x, b->y, b->z),
                              m_point(&P->g.ctm, c->x, c->y, c->z));
                }
                rt_ply_mesh_free(&pm);
            }
        }
        if (rc == 0 && pfind(&L, "displacement"))
            pwarn(P, &tt, "displacement", "Shape \"plymesh\": displacement ignored");
        free(rel);
        free(full);
        free(buf);
    } else {
        char key[48];
        snprintf(key, sizeof key, "Shape \"%.30s\"", type);
        pwarn(P, &tt, key, "Shape \"%s\" skipped", q);
    }
    if (rc == 0 && P->g.area && P->in_obj < 0 && P->s->ntri > start) rc = note_area_light(P, &tt, start);
    if (rc == 0 && P->g.area && P->in_obj < 0) rc = note_authored_area(P, &tt, type, &L, start);
    if (rc == 0 && P->g.area && P->in_obj >= 0)
        pwarn(P, &tt, "instanced area light", "area light inside an object: not one of the authored lights");
    if (rc == 0 && P->in_obj < 0) P->nonobj += P->s->ntri - start;
    free(w);
    free(idx);
    plist_free(&L);
    return rc;
fail:
    plist_free(&L);
    return -1;
}

/* Names the coordinate system m (a new name, or a redefinition). */
static int name_cs(pbrt *P, const char *name, const mat4 *m)
{
    int k = nm_find(&P->named_cs, name);
    if (k >= 0) {
        P->cs[k] = *m;
        return 0;
    }
    if (P->ncs == P->ccs) {
        int nc = P->ccs ? 2 * P->ccs : 8;
        mat4 *ns = rt_reallocarray(P->cs, (size_t)nc, sizeof *ns, P->e);
        if (!ns) return -1;
        P->cs = ns;
        P->ccs = nc;
    }
    P->cs[P->ncs] = *m;
    if (nm_put(&P->named_cs, name, P->ncs, P->e) < 0) return -1;
    P->ncs++;
    return 0;
}

/* ------------------------------------------------------------------------ */
/* Other directives                                                          */

static int do_camera(pbrt *P, const token *d)
{
    char type[64], q[80];
    token tt;
    plist L = {NULL, 0, 0};
    int rc = -1;
    if (need_world(P, d, 0) < 0 || need_string(P, d, type, sizeof type, &tt) < 0 || parse_params(P, &L) < 0)
        goto done;
    mat4 inv;
    if (m_inverse(&P->g.ctm, &inv) < 0) {
        perr(P, d, "Camera: the current transformation is singular");
        goto done;
    }
    rt_vec3 eye = m_point(&inv, 0, 0, 0);
    if (!in_range3(eye)) {
        perr(P, d, "Camera: the eye (%g, %g, %g) is not finite or beyond %g", (double)eye.x, (double)eye.y,
             (double)eye.z, RT_COORD_MAX);
        goto done;
    }
    if (strcmp(type, "perspective")) {
        char key[48];
        snprintf(key, sizeof key, "Camera \"%.30s\"", type);
        pwarn(P, &tt, key, "Camera \"%s\" rendered as a perspective camera", rt_esc(q, sizeof q, type, 40));
    }
    if (pfloat(P, &L, "fov", 90, &P->fov) < 0) goto done;
    if (!(P->fov > 0 && P->fov < 180)) {
        perr(P, &pfind(&L, "fov")->at, "Camera: fov %g outside (0, 180) degrees", P->fov);
        goto done;
    }
    if (pfloat(P, &L, "frameaspectratio", 0, &P->frame_aspect) < 0) goto done;
    if (P->frame_aspect < 0 || (pfind(&L, "frameaspectratio") && !(P->frame_aspect > 0))) {
        perr(P, &pfind(&L, "frameaspectratio")->at, "Camera: frameaspectratio must be positive");
        goto done;
    }
    const double *sw;
    size_t n;
    int r = pnums(P, &L, "screenwindow", B(PT_FLOAT), "float", 4, 4, &sw, &n);
    if (r < 0) goto done;
    P->have_sw = r > 0;
    if (r) {
        if (n != 4 || !(sw[1] > sw[0]) || !(sw[3] > sw[2])) {
            perr(P, &pfind(&L, "screenwindow")->at, "Camera: screenwindow needs 4 values xmin < xmax, ymin < ymax");
            goto done;
        }
        memcpy(P->sw, sw, sizeof P->sw);
        if (sw[0] != -sw[1] || sw[2] != -sw[3])
            pwarn(P, &tt, "screenwindow", "Camera: an off-centre screenwindow is rendered centred");
    }
    P->have_camera = 1;
    P->cam_ctm = P->g.ctm;
    P->eye[0] = eye.x, P->eye[1] = eye.y, P->eye[2] = eye.z;
    if (name_cs(P, "camera", &inv) < 0) goto done;
    rc = 0;
done:
    plist_free(&L);
    return rc;
}

static int do_film(pbrt *P, const token *d)
{
    char type[64];
    plist L = {NULL, 0, 0};
    int rc = -1;
    long w, h;
    if (need_world(P, d, 0) < 0 || need_string(P, d, type, sizeof type, NULL) < 0 || parse_params(P, &L) < 0 ||
        pint(P, &L, "xresolution", 1280, &w) < 0 || pint(P, &L, "yresolution", 720, &h) < 0)
        goto done;
    if (w < 1 || w > 65536 || h < 1 || h > 65536) {
        perr(P, &pfind(&L, w < 1 || w > 65536 ? "xresolution" : "yresolution")->at,
             "Film: resolution %ldx%ld outside 1..65536", w, h);
        goto done;
    }
    P->film_w = (int)w;
    P->film_h = (int)h;
    if (pfind(&L, "cropwindow") || pfind(&L, "pixelbounds"))
        pwarn(P, d, "Film cropwindow", "Film: %s ignored (the whole image is rendered)",
              pfind(&L, "cropwindow") ? "cropwindow" : "pixelbounds");
    rc = 0;
done:
    plist_free(&L);
    return rc;
}

static int do_light(pbrt *P, const token *d)
{
    char type[64], q[80];
    token tt;
    plist L = {NULL, 0, 0};
    int rc = -1;
    if (need_world(P, d, 1) < 0 || need_string(P, d, type, sizeof type, &tt) < 0 || parse_params(P, &L) < 0)
        goto done;
    if (!strcmp(type, "point") || !strcmp(type, "spot")) {
        const double *v;
        size_t n;
        double o[3] = {0, 0, 0};
        int r = pnums(P, &L, "from", B(PT_POINT3), "point3", 3, 3, &v, &n);
        if (r < 0) goto done;
        if (r && n != 3) {
            perr(P, &pfind(&L, "from")->at, "LightSource: \"from\" has %zu values, expected 3", n);
            goto done;
        }
        if (r) memcpy(o, v, sizeof o);
        rt_vec3 lp = m_point(&P->g.ctm, o[0], o[1], o[2]);
        if (!in_range3(lp)) {
            perr(P, &tt, "LightSource: the light's position (%g, %g, %g) is not finite or beyond %g", (double)lp.x,
                 (double)lp.y, (double)lp.z, RT_COORD_MAX);
            goto done;
        }
        if (P->nplight < RT_NLIGHTS) P->plight[P->nplight++] = lp;
        count_light(P, &tt);
        rt_light al;
        memset(&al, 0, sizeof al);
        al.kind = RT_LIGHT_POINT;
        al.p = m_point(&P->g.ctm, o[0], o[1], o[2]);
        if (add_light(P, &tt, &al) < 0) goto done;
    } else if (!strcmp(type, "distant")) {
        const double *v;
        size_t n;
        double ft[6] = {0, 0, 0, 0, 0, 1};
        for (int k = 0; k < 2; k++) {
            const char *key = k ? "to" : "from";
            int r = pnums(P, &L, key, B(PT_POINT3), "point3", 3, 3, &v, &n);
            if (r < 0) goto done;
            if (r && n != 3) {
                perr(P, &pfind(&L, key)->at, "LightSource: \"%s\" has %zu values, expected 3", key, n);
                goto done;
            }
            if (r) memcpy(ft + 3 * k, v, 3 * sizeof *v);
        }
        rt_vec3 f = m_point(&P->g.ctm, ft[0], ft[1], ft[2]), t = m_point(&P->g.ctm, ft[3], ft[4], ft[5]);
        rt_vec3 dir = rt_sub(f, t);
        if (!(rt_len(dir) > 0) || !isfinite(rt_len(dir))) {
            perr(P, &tt, "LightSource \"distant\": \"from\" and \"to\" coincide");
            goto done;
        }
        rt_light al;
        memset(&al, 0, sizeof al);
        al.kind = RT_LIGHT_DISTANT;
        al.d = rt_norm(dir);
        if (add_light(P, &tt, &al) < 0) goto done;
        pwarn(P, &tt, "LightSource \"distant\"",
              "LightSource \"distant\" skipped by the point lights (traced with --light-samples)");
    } else if (!strcmp(type, "infinite")) {
        rt_light al;
        memset(&al, 0, sizeof al);
        al.kind = RT_LIGHT_INFINITE;
        if (add_light(P, &tt, &al) < 0) goto done;
        if (pfind(&L, "filename"))
            pwarn(P, &tt, "infinite image", "LightSource \"infinite\": image ignored (a uniform sky)");
        pwarn(P, &tt, "LightSource \"infinite\"",
              "LightSource \"infinite\" skipped by the point lights (traced with --light-samples)");
    } else {
        char key[48];
        snprintf(key, sizeof key, "LightSource \"%.30s\"", type);
        pwarn(P, &tt, key, "LightSource \"%s\" skipped", rt_esc(q, sizeof q, type, 40));
    }
    rc = 0;
done:
    plist_free(&L);
    return rc;
}

static int do_area_light(pbrt *P, const token *d)
{
    char type[64], q[80];
    token tt;
    plist L = {NULL, 0, 0};
    int rc = -1;
    if (need_world(P, d, 1) < 0 || need_string(P, d, type, sizeof type, &tt) < 0 || parse_params(P, &L) < 0)
        goto done;
    if (!strcmp(type, "diffuse")) {
        static const float one[3] = {1, 1, 1};
        float l[3];
        double sc;
        int approx = 0;
        if (pcolour(P, &L, "L", one, l, &approx) < 0 || pfloat(P, &L, "scale", 1, &sc) < 0) goto done;
        if (!(sc >= 0)) {
            perr(P, &pfind(&L, "scale")->at, "AreaLightSource: negative scale");
            goto done;
        }
        if (approx) pwarn(P, &tt, "approx L", "AreaLightSource: a spectral L was taken as white");
        if (pfind(&L, "filename")) pwarn(P, &tt, "arealight image", "AreaLightSource: image ignored");
        P->g.area = 1;
        for (int k = 0; k < 3; k++) P->g.ke[k] = (float)(l[k] * sc);
        if (!(P->g.ke[0] <= 1e30f && P->g.ke[1] <= 1e30f && P->g.ke[2] <= 1e30f)) {
            perr(P, &tt, "AreaLightSource: L x scale out of range");
            goto done;
        }
    } else {
        char key[48];
        snprintf(key, sizeof key, "AreaLightSource \"%.24s\"", type);
        pwarn(P, &tt, key, "AreaLightSource \"%s\" skipped", rt_esc(q, sizeof q, type, 40));
        P->g.area = 0;
    }
    rc = 0;
done:
    plist_free(&L);
    return rc;
}

/* Material "type" params, or MakeNamedMaterial "name" params. */
static int do_material(pbrt *P, const token *d, int named)
{
    char first[256], type[64], q[300];
    token tt;
    plist L = {NULL, 0, 0};
    int rc = -1;
    if (need_string(P, d, first, sizeof first, &tt) < 0 || parse_params(P, &L) < 0) goto done;
    if (named) {
        if (pstring(P, &L, "type", type, sizeof type) < 0) goto done;
        if (!type[0]) {
            perr(P, &tt, "MakeNamedMaterial \"%s\": missing \"string type\"", rt_esc(q, sizeof q, first, 200));
            goto done;
        }
        if (nm_find(&P->named_mat, first) >= 0) {
            perr(P, &tt, "MakeNamedMaterial \"%s\": defined twice", rt_esc(q, sizeof q, first, 200));
            goto done;
        }
    } else {
        snprintf(type, sizeof type, "%.63s", first);
    }
    matdef m;
    if (make_matdef(P, &tt, type, &L, &m) < 0) goto done;
    if (named) snprintf(m.name, sizeof m.name, "%.31s", first);
    int k = add_matdef(P, &m);
    if (k < 0) goto done;
    if (named) {
        if (nm_put(&P->named_mat, first, k, P->e) < 0) goto done;
    } else {
        P->g.mat = k;
    }
    rc = 0;
done:
    plist_free(&L);
    return rc;
}

static int do_named_material(pbrt *P, const token *d)
{
    char name[256], q[300];
    token tt;
    if (need_string(P, d, name, sizeof name, &tt) < 0) return -1;
    int k = nm_find(&P->named_mat, name);
    if (k < 0)
        return perr(P, &tt, "NamedMaterial \"%s\": no such material (MakeNamedMaterial must define it first)",
                    rt_esc(q, sizeof q, name, 200));
    P->g.mat = k;
    return 0;
}

static int do_coordsys(pbrt *P, const token *d, int set)
{
    char name[256], q[300];
    token tt;
    if (need_string(P, d, name, sizeof name, &tt) < 0) return -1;
    if (set) return name_cs(P, name, &P->g.ctm);
    int k = nm_find(&P->named_cs, name);
    if (k < 0) return perr(P, &tt, "CoordSysTransform \"%s\": no such coordinate system", rt_esc(q, sizeof q, name, 200));
    P->g.ctm = P->cs[k];
    return 0;
}

static int do_object_begin(pbrt *P, const token *d)
{
    char name[256], q[300];
    token tt;
    if (need_world(P, d, 1) < 0 || need_string(P, d, name, sizeof name, &tt) < 0) return -1;
    rt_esc(q, sizeof q, name, 200);
    if (P->in_obj >= 0) return perr(P, d, "ObjectBegin \"%s\" inside another ObjectBegin", q);
    if (nm_find(&P->named_obj, name) >= 0) return perr(P, &tt, "ObjectBegin \"%s\": object defined twice", q);
    if (P->nobjs == P->cobjs) {
        int nc = P->cobjs ? 2 * P->cobjs : 8;
        object *no = rt_reallocarray(P->objs, (size_t)nc, sizeof *no, P->e);
        if (!no) return -1;
        P->objs = no;
        P->cobjs = nc;
    }
    if (nm_put(&P->named_obj, name, P->nobjs, P->e) < 0) return -1;
    memset(&P->objs[P->nobjs], 0, sizeof P->objs[0]);
    if (push_frame(P, d, 'o') < 0) return -1;
    P->in_obj = P->nobjs++;
    P->obj_start = P->s->ntri;
    return 0;
}

static int do_object_end(pbrt *P, const token *d)
{
    if (P->in_obj < 0) return perr(P, d, "ObjectEnd without ObjectBegin");
    if (pop_frame(P, d, 'o') < 0) return -1;
    object *o = &P->objs[P->in_obj];
    uint32_t n = P->s->ntri - P->obj_start;
    if ((uint64_t)P->on + n > P->maxtri) return room_for(P, d, (uint64_t)P->on + n);
    if (P->on + n > P->ocap) {
        uint32_t nc = P->ocap ? P->ocap : 64;
        while (nc < P->on + n) nc *= 2;
        rt_tri *nt = rt_reallocarray(P->otri, nc, sizeof *nt, P->e);
        if (!nt) return -1;
        P->otri = nt;
        rt_shade *ns = rt_reallocarray(P->oshade, nc, sizeof *ns, P->e);
        if (!ns) return -1;
        P->oshade = ns;
        P->ocap = nc;
    }
    if (n) {
        memcpy(P->otri + P->on, P->s->tri + P->obj_start, n * sizeof *P->otri);
        memcpy(P->oshade + P->on, P->s->shade + P->obj_start, n * sizeof *P->oshade);
    }
    o->start = P->on;
    o->count = n;
    P->on += n;
    P->s->ntri = P->obj_start; /* the definition itself is not rendered */
    P->in_obj = -1;
    return 0;
}

static int do_object_instance(pbrt *P, const token *d)
{
    char name[256], q[300];
    token tt;
    if (need_world(P, d, 1) < 0 || need_string(P, d, name, sizeof name, &tt) < 0) return -1;
    rt_esc(q, sizeof q, name, 200);
    int k = nm_find(&P->named_obj, name);
    if (k < 0) return perr(P, &tt, "ObjectInstance \"%s\": no such object", q);
    object *o = &P->objs[k];
    /* Nested instancing: an ObjectInstance inside an ObjectBegin block is
     * flattened into the object being defined (its triangles under the
     * current transformation join the outer object's, which ObjectEnd cuts
     * out), so the two-level structure builds one bottom-level tree over
     * the outer object with the inner copies in it; an object defined so
     * can itself be instanced inside a further ObjectBegin (any depth).
     * The inner instance is not a scene instance: it counts through the
     * outer object's triangles. Its triangles are made at once, so the
     * triangle limit applies as to any shape. */
    const int nested = P->in_obj >= 0;
    if (nested && k == P->in_obj) return perr(P, &tt, "ObjectInstance \"%s\" inside its own definition", q);
    if (P->keep && !nested) {
        /* checked before anything is made: the instances' triangles are
         * not held, but each has an index of the flattened scene */
        uint64_t n = (uint64_t)P->s->ntri + P->pend + o->count;
        if (n > RT_SCENE_MAX_FLAT)
            return perr(P, &tt, "the instances would make %llu triangles, more than the %llu triangle indices a scene "
                                "has (kept instances: the limit is the index, not memory)",
                        (unsigned long long)n, (unsigned long long)RT_SCENE_MAX_FLAT);
        if (o->count * (uint64_t)(sizeof(rt_tri) + sizeof(rt_shade)) <= sizeof(instrec) &&
            room_for(P, &tt, o->count) < 0)
            return -1;
    } else if (room_for(P, &tt, o->count) < 0)
        return -1;
    /* an instance is recorded (148 bytes) only when its triangles would
     * take more (52 bytes each): the records never hold more memory than
     * the flattened scene they stand for (maxtri bounds both) */
    if (nested || o->count * (uint64_t)(sizeof(rt_tri) + sizeof(rt_shade)) <= sizeof(instrec)) {
        for (uint32_t i = 0; i < o->count; i++) {
            const rt_tri *t = &P->otri[o->start + i];
            const rt_shade *h = &P->oshade[o->start + i];
            rt_vec3 c[3];
            for (int j = 0; j < 3; j++) {
                c[j] = m_point(&P->g.ctm, t->p[j].x, t->p[j].y, t->p[j].z);
                if (!in_range3(c[j]))
                    return perr(P, &tt, "ObjectInstance: vertex (%g, %g, %g) is not finite or beyond %g after the "
                                "transformation", (double)c[j].x, (double)c[j].y, (double)c[j].z, RT_COORD_MAX);
            }
            if (rt_scene_add_tri_mat(P->s, c[0], c[1], c[2], h->rgb, h->mat, P->e) < 0) return -1;
        }
        if (nested) return 0;
        goto count;
    }
    if (P->ninst == P->cinst) {
        int nc = P->cinst ? 2 * P->cinst : 16;
        instrec *ni = rt_reallocarray(P->inst, (size_t)nc, sizeof *ni, P->e);
        if (!ni) return -1;
        P->inst = ni;
        P->cinst = nc;
    }
    instrec *r = &P->inst[P->ninst++];
    r->at = P->s->ntri;
    r->obj = k;
    r->ctm = P->g.ctm;
    r->file = (uint32_t)cur(P)->pid;
    r->line = tt.line;
    r->col = tt.col;
    P->pend += o->count;
count:
    if (!o->used) P->s->ntri_unique += o->count;
    o->used = 1;
    P->s->ninst++;
    P->s->ntri_inst += o->count;
    return 0;
}

/* The mesh lights' triangles once the instances are made: an instance
 * recorded at or before a light's first triangle moves it up by the
 * object's triangles (expand_instances below; a shape is never split by
 * an instance). Called before it, while the records are there. */
static void relocate_mesh_lights(pbrt *P)
{
    rt_scene *s = P->s;
    for (uint32_t i = 0; i < s->nlight; i++) {
        rt_light *l = &s->lights[i];
        if (l->kind != RT_LIGHT_MESH) continue;
        uint64_t shift = 0;
        for (int k = 0; k < P->ninst; k++)
            if (P->inst[k].at <= l->first) shift += P->objs[P->inst[k].obj].count;
        l->first += (uint32_t)shift;
    }
}

/* Makes the triangles of every ObjectInstance, in file order: the scene
 * grows once to its final size (maxtri was checked at each instance) and,
 * from the last instance back, the triangles made after an instance move
 * up to make room for its copy. 0 or -1. */
static int invertible_affine(const mat4 *m)
{
    return m->m[3][0] == 0 && m->m[3][1] == 0 && m->m[3][2] == 0 && m->m[3][3] == 1 && fabs(det3(m)) > 1e-30;
}

/* Kept instances (scene.h): the invertible affine instances become records
 * at their flattened positions and make no triangles; the others are
 * flattened into tri like expand_instances does, as loose triangles; the
 * objects' shading records follow the loose ones in shade. 0 or -1. */
static int keep_instances(pbrt *P)
{
    rt_scene *s = P->s;
    uint64_t flat = (uint64_t)s->ntri + P->pend, loose = s->ntri;
    for (int i = 0; i < P->ninst; i++)
        if (!invertible_affine(&P->inst[i].ctm)) loose += P->objs[P->inst[i].obj].count;
    if (loose > P->maxtri)
        return rt_errf(P->e, "%s: %llu triangles, more than maxtri=%u", cur(P)->path, (unsigned long long)loose,
                       (unsigned)P->maxtri);
    if (flat > RT_SCENE_MAX_FLAT)
        return rt_errf(P->e, "%s: %llu triangles, more than %llu triangle indices", cur(P)->path,
                       (unsigned long long)flat, (unsigned long long)RT_SCENE_MAX_FLAT);
    if (rt_scene_reserve(s, (uint32_t)loose, P->e) < 0) return -1;
    if (P->ninst && !(s->irec = rt_reallocarray(NULL, (size_t)P->ninst, sizeof *s->irec, P->e))) return -1;
    /* forward: flattened positions and loose counts */
    uint64_t before = 0, nonrec = 0; /* triangles of earlier instances, of earlier flattened ones */
    for (int i = 0; i < P->ninst; i++) {
        const instrec *r = &P->inst[i];
        const uint32_t n = P->objs[r->obj].count;
        if (invertible_affine(&r->ctm)) {
            rt_scene_inst *q = &s->irec[s->nirec++];
            q->obj = (uint32_t)r->obj;
            q->first = (uint32_t)(r->at + before);
            q->loose = (uint32_t)(r->at + nonrec);
            for (int a = 0; a < 3; a++)
                for (int b = 0; b < 4; b++) q->m[a][b] = r->ctm.m[a][b];
            s->nirec_tri += n;
        } else nonrec += n;
        before += n;
    }
    /* backward: the flattened instances' copies among the loose triangles */
    uint32_t src = s->ntri, dst = (uint32_t)loose;
    for (int i = P->ninst - 1; i >= 0; i--) {
        const instrec *r = &P->inst[i];
        if (invertible_affine(&r->ctm)) continue;
        const object *o = &P->objs[r->obj];
        uint32_t tail = src - r->at;
        if (tail && dst != src) {
            memmove(s->tri + dst - tail, s->tri + r->at, tail * sizeof *s->tri);
            memmove(s->shade + dst - tail, s->shade + r->at, tail * sizeof *s->shade);
        }
        dst -= tail;
        src = r->at;
        dst -= o->count;
        for (uint32_t j = 0; j < o->count; j++) {
            const rt_tri *t = &P->otri[o->start + j];
            rt_tri *w = &s->tri[dst + j];
            for (int c = 0; c < 3; c++) {
                w->p[c] = m_point(&r->ctm, t->p[c].x, t->p[c].y, t->p[c].z);
                if (!in_range3(w->p[c]))
                    return rt_errf(P->e, "%s:%u:%u: ObjectInstance: vertex (%g, %g, %g) is not finite or beyond %g "
                                         "after the transformation", P->paths[r->file], (unsigned)r->line,
                                   (unsigned)r->col, (double)w->p[c].x, (double)w->p[c].y, (double)w->p[c].z,
                                   RT_COORD_MAX);
            }
            s->shade[dst + j] = P->oshade[o->start + j];
        }
    }
    /* the objects' shading records after the loose ones */
    rt_shade *ns = rt_reallocarray(s->shade, (size_t)loose + P->on + 1, sizeof *ns, P->e);
    if (!ns) return -1;
    s->shade = ns;
    if (P->on) memcpy(s->shade + loose, P->oshade, P->on * sizeof *s->shade);
    if (!(s->obj = rt_reallocarray(NULL, (size_t)P->nobjs + 1, sizeof *s->obj, P->e))) return -1;
    for (int k = 0; k < P->nobjs; k++) s->obj[k].start = P->objs[k].start, s->obj[k].count = P->objs[k].count;
    s->nobj = (uint32_t)P->nobjs;
    s->otri = P->otri;
    s->notri = P->on;
    P->otri = NULL;
    s->ntri = (uint32_t)loose;
    s->kept = 1;
    s->nflat = (uint32_t)flat;
    P->pend = 0;
    return 0;
}

static int expand_instances(pbrt *P)
{
    rt_scene *s = P->s;
    if (P->keep) return keep_instances(P);
    if (!P->ninst) return 0;
    uint64_t total = (uint64_t)s->ntri + P->pend;
    if (total > P->maxtri) return rt_errf(P->e, "%s: %llu triangles, more than maxtri=%u", cur(P)->path,
                                          (unsigned long long)total, (unsigned)P->maxtri);
    if (rt_scene_reserve(s, (uint32_t)total, P->e) < 0) return -1;
    /* the instance records of the two-level structure (rt_scene_inst):
     * invertible affine instances only (a projective or singular one
     * stays flattened, loose) */
    if (!(s->irec = rt_reallocarray(NULL, (size_t)P->ninst, sizeof *s->irec, P->e))) return -1;
    uint32_t src = s->ntri, dst = (uint32_t)total;
    for (int i = P->ninst - 1; i >= 0; i--) {
        const instrec *r = &P->inst[i];
        const object *o = &P->objs[r->obj];
        uint32_t tail = src - r->at;
        if (tail && dst != src) {
            memmove(s->tri + dst - tail, s->tri + r->at, tail * sizeof *s->tri);
            memmove(s->shade + dst - tail, s->shade + r->at, tail * sizeof *s->shade);
        }
        dst -= tail;
        src = r->at;
        dst -= o->count;
        for (uint32_t j = 0; j < o->count; j++) {
            const rt_tri *t = &P->otri[o->start + j];
            rt_tri *w = &s->tri[dst + j];
            for (int c = 0; c < 3; c++) {
                w->p[c] = m_point(&r->ctm, t->p[c].x, t->p[c].y, t->p[c].z);
                if (!in_range3(w->p[c]))
                    return rt_errf(P->e, "%s:%u:%u: ObjectInstance: vertex (%g, %g, %g) is not finite or beyond %g "
                                         "after the transformation", P->paths[r->file], (unsigned)r->line,
                                   (unsigned)r->col, (double)w->p[c].x, (double)w->p[c].y, (double)w->p[c].z,
                                   RT_COORD_MAX);
            }
            s->shade[dst + j] = P->oshade[o->start + j];
        }
        const mat4 *m = &r->ctm;
        if (invertible_affine(m)) {
            rt_scene_inst *q = &s->irec[s->nirec++];
            q->obj = (uint32_t)r->obj;
            q->first = dst;
            for (int a = 0; a < 3; a++)
                for (int b = 0; b < 4; b++) q->m[a][b] = m->m[a][b];
        }
    }
    /* records were made from the last instance back: file order */
    for (uint32_t i = 0, j = s->nirec ? s->nirec - 1 : 0; i < j; i++, j--) {
        rt_scene_inst t = s->irec[i];
        s->irec[i] = s->irec[j];
        s->irec[j] = t;
    }
    uint64_t inst = 0; /* the records' triangles before each */
    for (uint32_t i = 0; i < s->nirec; i++) {
        s->irec[i].loose = (uint32_t)(s->irec[i].first - inst);
        inst += P->objs[s->irec[i].obj].count;
    }
    s->nirec_tri = (uint32_t)inst;
    if (!(s->obj = rt_reallocarray(NULL, (size_t)P->nobjs, sizeof *s->obj, P->e))) return -1;
    for (int k = 0; k < P->nobjs; k++) s->obj[k].start = P->objs[k].start, s->obj[k].count = P->objs[k].count;
    s->nobj = (uint32_t)P->nobjs;
    s->otri = P->otri; /* handed over: the objects' triangles stay for the two-level structure */
    s->notri = P->on;
    P->otri = NULL;
    s->ntri = (uint32_t)total;
    P->pend = 0;
    return 0;
}

/* ------------------------------------------------------------------------ */
/* The directive loop                                                        */

/* pbrt directives this loader skips with a warning. */
static const char *const skipped[] = {"Accelerator", "Attribute", "ColorSpace", "Integrator", "MakeNamedMedium",
                                      "MediumInterface", "Option", "PixelFilter", "ReverseOrientation", "Sampler",
                                      "TransformTimes", NULL};

static int directive(pbrt *P, const token *d)
{
    char dn[32], b[80];
    if (d->n >= sizeof dn) return perr(P, d, "unknown directive %s (not a pbrt directive)", tq(b, sizeof b, d));
    memcpy(dn, d->p, d->n);
    dn[d->n] = 0;
    double v[16];
    mat4 m;
    if (!strcmp(dn, "Include") || !strcmp(dn, "Import")) return do_include(P, d);
    if (!strcmp(dn, "Shape")) return do_shape(P, d);
    if (!strcmp(dn, "Texture")) return do_texture(P, d);
    if (!strcmp(dn, "LookAt")) {
        if (need_numbers(P, d, v, 9) < 0) return -1;
        double dir[3] = {v[3] - v[0], v[4] - v[1], v[5] - v[2]}, up[3] = {v[6], v[7], v[8]};
        double dl = sqrt(dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2]);
        double ul = sqrt(up[0] * up[0] + up[1] * up[1] + up[2] * up[2]);
        if (!(dl > 0)) return perr(P, d, "LookAt: the eye and the point looked at coincide");
        if (!(ul > 0)) return perr(P, d, "LookAt: the up vector is zero");
        for (int k = 0; k < 3; k++) dir[k] /= dl, up[k] /= ul;
        double r[3] = {up[1] * dir[2] - up[2] * dir[1], up[2] * dir[0] - up[0] * dir[2], up[0] * dir[1] - up[1] * dir[0]};
        double rl = sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2]);
        if (!(rl > 0)) return perr(P, d, "LookAt: the up vector is parallel to the viewing direction");
        for (int k = 0; k < 3; k++) r[k] /= rl;
        double nu[3] = {dir[1] * r[2] - dir[2] * r[1], dir[2] * r[0] - dir[0] * r[2], dir[0] * r[1] - dir[1] * r[0]};
        /* camera-from-world: rows right, up, dir; translation -R eye */
        const double *rows[3] = {r, nu, dir};
        m = m_ident();
        for (int i = 0; i < 3; i++) {
            for (int j = 0; j < 3; j++) m.m[i][j] = rows[i][j];
            m.m[i][3] = -(rows[i][0] * v[0] + rows[i][1] * v[1] + rows[i][2] * v[2]);
        }
        return concat(P, d, &m);
    }
    if (!strcmp(dn, "Translate") || !strcmp(dn, "Scale")) {
        if (need_numbers(P, d, v, 3) < 0) return -1;
        m = m_ident();
        for (int k = 0; k < 3; k++) {
            if (dn[0] == 'T') m.m[k][3] = v[k];
            else m.m[k][k] = v[k];
        }
        return concat(P, d, &m);
    }
    if (!strcmp(dn, "Rotate")) {
        if (need_numbers(P, d, v, 4) < 0) return -1;
        double l = sqrt(v[1] * v[1] + v[2] * v[2] + v[3] * v[3]);
        if (!(l > 0)) return perr(P, d, "Rotate: the axis is zero");
        double x = v[1] / l, y = v[2] / l, z = v[3] / l, s, c;
        rt_dsincos_deg(v[0], &s, &c);
        m = m_ident();
        m.m[0][0] = x * x + (1 - x * x) * c;
        m.m[0][1] = x * y * (1 - c) - z * s;
        m.m[0][2] = x * z * (1 - c) + y * s;
        m.m[1][0] = x * y * (1 - c) + z * s;
        m.m[1][1] = y * y + (1 - y * y) * c;
        m.m[1][2] = y * z * (1 - c) - x * s;
        m.m[2][0] = x * z * (1 - c) - y * s;
        m.m[2][1] = y * z * (1 - c) + x * s;
        m.m[2][2] = z * z + (1 - z * z) * c;
        return concat(P, d, &m);
    }
    if (!strcmp(dn, "Transform") || !strcmp(dn, "ConcatTransform")) {
        if (need_numbers(P, d, v, 16) < 0) return -1;
        for (int i = 0; i < 4; i++)
            for (int j = 0; j < 4; j++) m.m[i][j] = v[4 * j + i]; /* the file holds the transpose */
        if (dn[0] == 'T') {
            P->g.ctm = m;
            return ctm_check(P, d);
        }
        return concat(P, d, &m);
    }
    if (!strcmp(dn, "Identity")) {
        P->g.ctm = m_ident();
        return 0;
    }
    if (!strcmp(dn, "CoordinateSystem")) return do_coordsys(P, d, 1);
    if (!strcmp(dn, "CoordSysTransform")) return do_coordsys(P, d, 0);
    if (!strcmp(dn, "Camera")) return do_camera(P, d);
    if (!strcmp(dn, "Film")) return do_film(P, d);
    if (!strcmp(dn, "WorldBegin")) {
        if (P->world) return perr(P, d, "WorldBegin given twice");
        P->world = 1;
        P->g.ctm = m_ident();
        return name_cs(P, "world", &P->g.ctm);
    }
    if (!strcmp(dn, "WorldEnd")) return 0; /* pbrt-v3: the end of the world block */
    if (!strcmp(dn, "AttributeBegin")) return push_frame(P, d, 'a');
    if (!strcmp(dn, "AttributeEnd")) return pop_frame(P, d, 'a');
    if (!strcmp(dn, "TransformBegin")) return push_frame(P, d, 't');
    if (!strcmp(dn, "TransformEnd")) return pop_frame(P, d, 't');
    if (!strcmp(dn, "ObjectBegin")) return do_object_begin(P, d);
    if (!strcmp(dn, "ObjectEnd")) return do_object_end(P, d);
    if (!strcmp(dn, "ObjectInstance")) return do_object_instance(P, d);
    if (!strcmp(dn, "Material")) return do_material(P, d, 0);
    if (!strcmp(dn, "MakeNamedMaterial")) return do_material(P, d, 1);
    if (!strcmp(dn, "NamedMaterial")) return do_named_material(P, d);
    if (!strcmp(dn, "LightSource")) return do_light(P, d);
    if (!strcmp(dn, "AreaLightSource")) return do_area_light(P, d);
    if (!strcmp(dn, "ActiveTransform")) {
        token x;
        if (lex(P, &x) < 0) return -1;
        if (!word_is(&x, "StartTime") && !word_is(&x, "EndTime") && !word_is(&x, "All"))
            return perr(P, &x, "ActiveTransform: expected StartTime, EndTime or All, got %s", tq(b, sizeof b, &x));
        pwarn(P, d, "ActiveTransform", "ActiveTransform skipped");
        return 0;
    }
    for (int i = 0; skipped[i]; i++)
        if (!strcmp(dn, skipped[i])) {
            pwarn(P, d, dn, "%s skipped", dn);
            return skip_args(P);
        }
    return perr(P, d, "unknown directive %s (not a pbrt directive)", tq(b, sizeof b, d));
}

static int parse_all(pbrt *P)
{
    for (;;) {
        token t;
        char b[80];
        if (lex(P, &t) < 0) return -1;
        if (t.kind == TK_EOF) {
            if (P->depth == 1) {
                if (P->nstack) {
                    const frame *f = &P->stack[P->nstack - 1];
                    return perr(P, &t, "the %s at %s has no %s", frame_name(f->kind), f->at,
                                f->kind == 'a' ? "AttributeEnd" : f->kind == 't' ? "TransformEnd" : "ObjectEnd");
                }
                return 0;
            }
            file_free(P->f[--P->depth]);
            P->f[P->depth] = NULL;
            continue;
        }
        if (t.kind != TK_WORD) return perr(P, &t, "expected a directive, got %s", tq(b, sizeof b, &t));
        if (directive(P, &t) < 0) return -1;
    }
}

/* ------------------------------------------------------------------------ */
/* Finishing: camera, lights, warnings                                       */

static double tan_half(double fov)
{
    double s, c;
    rt_dsincos_deg(0.5 * fov, &s, &c);
    return s / c;
}

/* 2 atan(t) in degrees, by bisection on tan_half (only + - * /). */
static double fov_of(double t)
{
    double lo = 0, hi = 180;
    for (int i = 0; i < 200 && hi - lo > 0; i++) {
        double mid = 0.5 * (lo + hi);
        if (mid == lo || mid == hi) break;
        if (tan_half(mid) < t) lo = mid;
        else hi = mid;
    }
    return 0.5 * (lo + hi);
}

static void set_camera(pbrt *P)
{
    rt_scene *s = P->s;
    mat4 M;
    m_inverse(&P->cam_ctm, &M); /* checked at Camera */
    double o[3] = {0, 0, 0}, e[3];
    m_apply(&M, o, e);
    double f[3], u[3];
    for (int k = 0; k < 3; k++) f[k] = M.m[k][2], u[k] = M.m[k][1];
    double fl = sqrt(f[0] * f[0] + f[1] * f[1] + f[2] * f[2]);
    double ul = sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]);
    for (int k = 0; k < 3; k++) e[k] += 0.0, f[k] += 0.0, u[k] += 0.0; /* -0 -> +0 */
    s->cam.eye = rt_v3((float)e[0], (float)e[1], (float)e[2]);
    s->cam.at = rt_v3((float)(e[0] + f[0] / fl), (float)(e[1] + f[1] / fl), (float)(e[2] + f[2] / fl));
    s->cam.up = rt_v3((float)(u[0] / ul), (float)(u[1] / ul), (float)(u[2] / ul));
    s->cam.mirror = det3(&M) > 0;
    /* pbrt's fov spans the shorter image axis; ours is vertical */
    double W = P->film_w ? P->film_w : 1280, H = P->film_h ? P->film_h : 720;
    double fa = P->frame_aspect > 0 ? P->frame_aspect : W / H;
    double half = P->have_sw ? 0.5 * (P->sw[3] - P->sw[2]) : fa > 1 ? 1.0 : 1.0 / fa;
    s->cam.fovy_deg = half == 1.0 ? (float)P->fov : (float)fov_of(tan_half(P->fov) * half);
}

static void set_lights(pbrt *P)
{
    rt_scene *s = P->s;
    rt_bounds b = s->bounds;
    double dx = (double)b.hi.x - b.lo.x, dy = (double)b.hi.y - b.lo.y, dz = (double)b.hi.z - b.lo.z;
    double diag = sqrt(dx * dx + dy * dy + dz * dz);
    int n = 0;
    for (int i = 0; i < P->nplight && n < RT_NLIGHTS; i++) s->light[n++] = P->plight[i];
    for (int i = 0; i < P->nal && n < RT_NLIGHTS; i++) {
        const arealight *a = &P->al[i];
        double nl = sqrt(a->nsum[0] * a->nsum[0] + a->nsum[1] * a->nsum[1] + a->nsum[2] * a->nsum[2]);
        if (!(a->area2 > 0) || !(nl > 1e-6 * a->area2)) {
            rt_err e2;
            (void)rt_sfile_warn(s, "closed area light", a->at, &e2,
                                "area light without a facing side (closed or degenerate): no point light for it");
            continue;
        }
        double off = 0.025 * diag / nl;
        s->light[n++] = rt_v3((float)(a->c[0] / a->area2 + a->nsum[0] * off),
                              (float)(a->c[1] / a->area2 + a->nsum[1] * off),
                              (float)(a->c[2] / a->area2 + a->nsum[2] * off));
    }
    if (P->have_camera)
        for (; n < RT_NLIGHTS; n++) s->light[n] = s->cam.eye;
    /* auto-framed: the remaining lights stay where rt_scene_autoframe put them */
}

int rt_scene_fit_film(rt_scene *s, int W, int H, rt_err *e)
{
    if (s->film_w <= 0 || s->film_h <= 0 || W <= 0 || H <= 0) return 0;
    if ((int64_t)W * s->film_h == (int64_t)H * s->film_w) return 0;
    /* tan of the new half angle: the film's horizontal half-extent
     * (tan(fovy/2) x film aspect) over the image's aspect */
    double t = tan_half(s->cam.fovy_deg) * ((double)s->film_w / s->film_h) * ((double)H / W);
    double fovy = fov_of(t);
    if (!(fovy > 0 && fovy < 180)) return 0;
    s->cam.fovy_deg = (float)fovy;
    char first[300];
    snprintf(first, sizeof first, "%.250s", s->name);
    if (rt_sfile_warn(s, "image aspect", first, e,
                      "image %dx%d does not have the Film's aspect (%dx%d): its horizontal extent is kept, vertical field "
                      "of view %.4g degrees", W, H, s->film_w, s->film_h, fovy) < 0)
        return -1;
    rt_sfile_warn_summary(s);
    return 1;
}

/* tess=N,maxtri=N,maxsubdiv=N */
static int parse_spec(const char *path, const char *params, int *tess, uint32_t *maxtri, uint32_t *maxsubdiv,
                      int *alpha, rt_err *e)
{
    *tess = 3;
    *alpha = 1;
    *maxtri = DEFAULT_MAXTRI;
    *maxsubdiv = DEFAULT_MAXSUBDIV;
    int seen_t = 0, seen_m = 0, seen_s = 0, seen_a = 0;
    const char *p = params ? params : "";
    while (*p) {
        const char *end = strchr(p, ',');
        size_t len = end ? (size_t)(end - p) : strlen(p);
        char item[64], *q;
        if (len == 0 || len >= sizeof item)
            return rt_errf(e, "%s: bad parameter list '%.60s' (known: tess, maxtri, maxsubdiv, alpha)", path, params);
        memcpy(item, p, len);
        item[len] = 0;
        char *eq = strchr(item, '=');
        if (!eq) return rt_errf(e, "%s: parameter '%s' is not key=value", path, item);
        *eq = 0;
        errno = 0;
        long long v = strtoll(eq + 1, &q, 10);
        int ok = *q == 0 && q != eq + 1 && eq[1] != ' ' && !errno;
        if (!strcmp(item, "tess")) {
            if (seen_t++) return rt_errf(e, "%s: parameter 'tess' given twice", path);
            if (!ok || v < 1 || v > 64) return rt_errf(e, "%s: tess=%s out of range 1..64", path, eq + 1);
            *tess = (int)v;
        } else if (!strcmp(item, "maxtri")) {
            if (seen_m++) return rt_errf(e, "%s: parameter 'maxtri' given twice", path);
            if (!ok || v < 1 || v > (long long)(UINT32_MAX / 2))
                return rt_errf(e, "%s: maxtri=%s out of range 1..%u", path, eq + 1, (unsigned)(UINT32_MAX / 2));
            *maxtri = (uint32_t)v;
        } else if (!strcmp(item, "maxsubdiv")) {
            if (seen_s++) return rt_errf(e, "%s: parameter 'maxsubdiv' given twice", path);
            if (!ok || v < 1 || v > (long long)(UINT32_MAX / 2))
                return rt_errf(e, "%s: maxsubdiv=%s out of range 1..%u", path, eq + 1, (unsigned)(UINT32_MAX / 2));
            *maxsubdiv = (uint32_t)v;
        } else if (!strcmp(item, "alpha")) {
            if (seen_a++) return rt_errf(e, "%s: parameter 'alpha' given twice", path);
            if (!ok || v < 0 || v > 1) return rt_errf(e, "%s: alpha=%s is not 0 or 1", path, eq + 1);
            *alpha = (int)v;
        } else {
            char q2[80];
            return rt_errf(e, "%s: unknown parameter '%s' (known for .pbrt files: tess, maxtri, maxsubdiv, alpha, material)", path,
                           rt_esc(q2, sizeof q2, item, 40));
        }
        p = end ? end + 1 : p + len;
        if (end && !*p) return rt_errf(e, "%s: empty parameter in '%.60s'", path, params);
    }
    return 0;
}

rt_scene *rt_scene_load_pbrt(const char *path, const char *params, rt_err *e)
{
    return rt_scene_load_pbrt_flags(path, params, 0, e);
}

rt_scene *rt_scene_load_pbrt_flags(const char *path, const char *params, unsigned flags, rt_err *e)
{
    pbrt *P = rt_calloc(1, sizeof *P, e);
    if (!P) return NULL;
    P->keep = (flags & RT_LOAD_KEEP_INSTANCES) != 0;
    int rc = -1, tess, alpha_on;
    uint32_t maxtri, maxsubdiv;
    P->e = e;
    P->in_obj = -1;
    P->fov = 90;
    if (parse_spec(path, params, &tess, &maxtri, &maxsubdiv, &alpha_on, e) < 0) goto done;
    P->alpha_off = !alpha_on;
    P->tess = tess;
    P->maxtri = maxtri;
    P->maxsubdiv = maxsubdiv;
    if (!(P->s = rt_scene_new(0, e))) goto done;
    const char *base = strrchr(path, '/');
    snprintf(P->s->name, sizeof P->s->name, "%s", base ? base + 1 : path);
    snprintf(P->s->params, sizeof P->s->params, "tess=%d%s", tess, alpha_on ? "" : ",alpha=0");
    /* the top file */
    int fd;
    struct stat st;
    char why[200], *buf = NULL;
    size_t n = 0;
    if (open_regular(path, &fd, &st, why, sizeof why) < 0 || read_fd(P, fd, &st, &buf, &n, why, sizeof why) < 0) {
        rt_errf(e, "%s: %s", path, why);
        goto done;
    }
    size_t pl = strlen(path);
    char *shown = rt_calloc(pl + 1, 1, e), *rel = rt_calloc(pl + 1, 1, e);
    if (!shown || !rel) {
        free(shown);
        free(rel);
        free(buf);
        goto done;
    }
    memcpy(shown, path, pl);
    memcpy(rel, path, pl); /* its folder after push_file */
    if (push_file(P, shown, rel, buf, n, &st) < 0) goto done;
    /* the default material and state */
    matdef m0;
    memset(&m0, 0, sizeof m0);
    snprintf(m0.name, sizeof m0.name, "diffuse");
    m0.rgb[0] = m0.rgb[1] = m0.rgb[2] = 0.5f;
    m0.ior = 1;
    if (add_matdef(P, &m0) < 0) goto done;
    P->g.ctm = m_ident();
    if (parse_all(P) < 0) goto done;
    relocate_mesh_lights(P);
    relocate_alpha(P);
    if (expand_instances(P) < 0) goto done;
    if (make_alpha(P) < 0) goto done;
    rt_scene *s = P->s;
    s->ntri_unique += P->nonobj;
    if (!s->ninst) s->ntri_unique = 0;
    rt_err fe;
    if (rt_scene_finish(s, &fe) < 0) {
        rt_errf(e, "%s: %s", path, rt_scene_nflat(s) ? fe.msg : "no triangles (no supported Shape in the world block)");
        goto done;
    }
    if (rt_scene_check_kept(s, e) < 0) goto done;
    if (rt_scene_check_range(s, path, e) < 0) goto done;
    if (P->have_camera) set_camera(P);
    else rt_scene_autoframe(s);
    set_lights(P);
    s->film_w = P->film_w;
    s->film_h = P->film_h;
    rt_sfile_warn_summary(s);
    rc = 0;
done:
    for (int i = 0; i < P->depth; i++) file_free(P->f[i]);
    free(P->stack);
    free(P->mats);
    nm_free(&P->named_mat);
    nm_free(&P->named_cs);
    nm_free(&P->named_obj);
    free(P->cs);
    free(P->objs);
    free(P->otri);
    free(P->oshade);
    free(P->al);
    free(P->inst);
    free(P->mslot);
    free(P->tex);
    nm_free(&P->named_tex);
    free(P->amap);
    free(P->texel);
    for (int i = 0; i < P->nspan; i++) free(P->span[i].uv);
    free(P->span);
    for (int i = 0; i < P->npaths; i++) free(P->paths[i]);
    free(P->paths);
    rt_scene *out = P->s;
    if (rc < 0) {
        rt_scene_free(out);
        out = NULL;
    }
    free(P);
    return out;
}
