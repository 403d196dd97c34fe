/* alpha.c -- alpha textures and the any-hit cutout (see alpha.h). */
#include "alpha.h"
#include "isect.h"

#include <math.h>
#include <openexr.h>
#include <png.h>
#include <setjmp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ---- the cutout ------------------------------------------------------------ */

void rt_alpha_at_init(rt_alpha_at *at, const rt_layout *L)
{
    int a = L ? rt_mm_find(L, "alpha.tri") : -1, b = L ? rt_mm_find(L, "alpha.texel") : -1;
    at->on = a >= 0 && b >= 0;
    at->tri_base = a >= 0 ? L->r[a].base : 0;
    at->tex_base = b >= 0 ? L->r[b].base : 0;
}

int rt_alpha_regions(rt_layout *L, const rt_scene_alpha *A, rt_err *e)
{
    if (!A) return 0;
    if (rt_mm_add(L, "alpha.tri", RT_CLS_ALPHA, RT_ALPHA_TRI_RECSIZE, A->ntri, e) < 0 ||
        rt_mm_add(L, "alpha.texel", RT_CLS_ALPHA, RT_ALPHA_TEXEL_RECSIZE, A->ntexel, e) < 0)
        return -1;
    return 0;
}

/* x mod n for any x (repeat wrap). */
static int64_t wrap(int64_t x, uint32_t n)
{
    int64_t m = x % (int64_t)n;
    return m < 0 ? m + n : m;
}

float rt_alpha_value(const rt_scene_alpha *A, const rt_alpha_at *at, rt_rec *rec, uint32_t tri, float u, float v)
{
    if (!at || !at->on) rec = NULL;
    uint32_t k = tri < A->nrec ? A->tmap[tri] : 0;
    RT_REC(rec, at->tri_base + (uint64_t)RT_ALPHA_TRI_RECSIZE * tri, k ? RT_ALPHA_TRI_RECSIZE : 4, 0, RT_CLS_ALPHA);
    if (!k) return 1.0f;
    const rt_alpha_map *m = &A->map[k - 1];
    const float *uv = A->uv + 6 * (size_t)tri;
    const float w0 = 1.0f - u - v;
    const float s = w0 * uv[0] + u * uv[2] + v * uv[4];
    const float t = w0 * uv[1] + u * uv[3] + v * uv[5];
    /* nearest texel, pbrt's t flipped (v = 1 is the top row), repeat */
    const double fx = floor((double)s * m->w), fy = floor((1.0 - (double)t) * m->h);
    if (!(fabs(fx) < 9e15 && fabs(fy) < 9e15)) return 1.0f; /* uv not finite: opaque (the loader refuses such uv) */
    const uint64_t idx = m->off + (uint64_t)wrap((int64_t)fy, m->h) * m->w + (uint64_t)wrap((int64_t)fx, m->w);
    RT_REC(rec, at->tex_base + (uint64_t)RT_ALPHA_TEXEL_RECSIZE * idx, RT_ALPHA_TEXEL_RECSIZE, 0, RT_CLS_ALPHA);
    return A->texel[idx];
}

static uint64_t le64(const unsigned char *p)
{
    uint64_t v = 0;
    for (int i = 0; i < 8; i++) v |= (uint64_t)p[i] << (8 * i);
    return v;
}

/* pbrt-v4's MurmurHash64A (util/hash.h), little-endian words. */
static uint64_t murmur64a(const unsigned char *key, size_t len, uint64_t seed)
{
    const uint64_t m = 0xc6a4a7935bd1e995ull;
    const int r = 47;
    uint64_t h = seed ^ (len * m);
    size_t nw = len / 8;
    for (size_t i = 0; i < nw; i++) {
        uint64_t k = le64(key + 8 * i);
        k *= m;
        k ^= k >> r;
        k *= m;
        h ^= k;
        h *= m;
    }
    const unsigned char *t = key + 8 * nw;
    switch (len & 7) {
    case 7: h ^= (uint64_t)t[6] << 48; /* fall through */
    case 6: h ^= (uint64_t)t[5] << 40; /* fall through */
    case 5: h ^= (uint64_t)t[4] << 32; /* fall through */
    case 4: h ^= (uint64_t)t[3] << 24; /* fall through */
    case 3: h ^= (uint64_t)t[2] << 16; /* fall through */
    case 2: h ^= (uint64_t)t[1] << 8;  /* fall through */
    case 1:
        h ^= (uint64_t)t[0];
        h *= m;
    }
    h ^= h >> r;
    h *= m;
    h ^= h >> r;
    return h;
}

static void put_f(unsigned char *p, float f)
{
    uint32_t b;
    memcpy(&b, &f, 4);
    for (int i = 0; i < 4; i++) p[i] = (unsigned char)(b >> (8 * i));
}

float rt_alpha_hash(const rt_ray *r)
{
    unsigned char b[24];
    put_f(b, r->o.x), put_f(b + 4, r->o.y), put_f(b + 8, r->o.z);
    put_f(b + 12, r->d.x), put_f(b + 16, r->d.y), put_f(b + 20, r->d.z);
    return (float)(uint32_t)murmur64a(b, sizeof b, 0) * 0x1p-32f;
}

int rt_alpha_cut_slow(const rt_scene_alpha *A, const rt_alpha_at *at, rt_rec *rec, const rt_ray *r, uint32_t tri,
                      float u, float v)
{
    const float a = rt_alpha_value(A, at, rec, tri, u, v);
    if (a >= 1.0f) return 0;
    if (a <= 0.0f) return 1;
    return rt_alpha_hash(r) > a;
}

/* ---- the structure ------------------------------------------------------------ */

int rt_alpha_check(const rt_scene_alpha *A, rt_err *e)
{
    if (!A) return 0;
    if (A->nmap < 1 || !A->map || !A->texel || !A->tmap || !A->uv) return rt_errf(e, "alpha: no textures or arrays");
    uint64_t next = 0;
    for (uint32_t k = 0; k < A->nmap; k++) {
        const rt_alpha_map *m = &A->map[k];
        if (m->w < 1 || m->h < 1 || m->off != next || (uint64_t)m->w * m->h > A->ntexel - m->off)
            return rt_errf(e, "alpha: texture %u (%ux%u at %llu) outside the texels or out of order", k, m->w, m->h,
                           (unsigned long long)m->off);
        next = m->off + (uint64_t)m->w * m->h;
    }
    if (next != A->ntexel) return rt_errf(e, "alpha: %llu texels, the textures hold %llu", (unsigned long long)A->ntexel,
                                          (unsigned long long)next);
    for (uint64_t i = 0; i < A->ntexel; i++)
        if (!(A->texel[i] >= 0 && isfinite(A->texel[i])))
            return rt_errf(e, "alpha: texel %llu is %g", (unsigned long long)i, (double)A->texel[i]);
    if (A->nrec < 1 || A->nrec > A->ntri)
        return rt_errf(e, "alpha: %u triangle records for %u triangles", A->nrec, A->ntri);
    uint32_t mapped = 0;
    for (uint32_t t = 0; t < A->nrec; t++) {
        if (A->tmap[t] > A->nmap) return rt_errf(e, "alpha: triangle %u names texture %u of %u", t, A->tmap[t], A->nmap);
        mapped += A->tmap[t] != 0;
        for (int j = 0; j < 6; j++)
            if (!isfinite(A->uv[6 * (size_t)t + j])) return rt_errf(e, "alpha: triangle %u has a uv not finite", t);
    }
    if (!mapped) return rt_errf(e, "alpha: no triangle has a texture");
    return 0;
}

void rt_alpha_free(rt_scene_alpha *A)
{
    if (!A) return;
    free(A->map);
    free(A->texel);
    free(A->tmap);
    free(A->uv);
    free(A);
}

/* ---- PNG (libpng, from memory) ------------------------------------------------ */

typedef struct pngsrc {
    const unsigned char *p;
    size_t n, pos;
    char msg[160]; /* libpng's message */
    jmp_buf jb;
} pngsrc;

static void png_rd(png_structp ps, png_bytep out, size_t len)
{
    pngsrc *s = png_get_io_ptr(ps);
    if (len > s->n - s->pos) png_error(ps, "file ends inside the image (truncated)");
    memcpy(out, s->p + s->pos, len);
    s->pos += len;
}

static void png_err(png_structp ps, png_const_charp msg)
{
    pngsrc *s = png_get_error_ptr(ps);
    snprintf(s->msg, sizeof s->msg, "%s", msg);
    longjmp(s->jb, 1);
}

static void png_warn(png_structp ps, png_const_charp msg)
{
    (void)ps;
    (void)msg; /* the library never prints */
}

static double srgb_to_linear(double v) { return v <= 0.04045 ? v / 12.92 : pow((v + 0.055) / 1.055, 2.4); }

int rt_alpha_decode_png(const unsigned char *buf, size_t n, const char *name, int srgb, float **px, uint32_t *pw,
                        uint32_t *ph, rt_err *e)
{
    *px = NULL;
    if (n < 8 || png_sig_cmp(buf, 0, 8)) return rt_errf(e, "%s: not a PNG file (no PNG signature)", name);
    /* volatile: they change between setjmp and a longjmp back to it */
    pngsrc *volatile src = calloc(1, sizeof *src);
    float *volatile out = NULL;
    png_bytep *volatile rows = NULL;
    png_structp ps = NULL;
    png_infop pi = NULL;
    if (!src) return rt_errf(e, "%s: out of memory", name);
    src->p = buf;
    src->n = n;
    ps = png_create_read_struct(PNG_LIBPNG_VER_STRING, src, png_err, png_warn);
    if (ps) pi = png_create_info_struct(ps);
    if (!ps || !pi) {
        png_destroy_read_struct(ps ? &ps : NULL, NULL, NULL);
        free(src);
        return rt_errf(e, "%s: out of memory", name);
    }
    if (setjmp(src->jb)) {
        rt_errf(e, "%s: PNG: %s", name, src->msg);
        goto fail;
    }
    png_set_read_fn(ps, src, png_rd);
    png_set_user_limits(ps, 1u << 20, 1u << 20);
    png_read_info(ps, pi);
    png_uint_32 w = png_get_image_width(ps, pi), h = png_get_image_height(ps, pi);
    if ((uint64_t)w * h > RT_ALPHA_MAX_TEXELS) {
        rt_errf(e, "%s: PNG image of %lux%lu texels, more than %llu", name, (unsigned long)w, (unsigned long)h,
                (unsigned long long)RT_ALPHA_MAX_TEXELS);
        goto fail;
    }
    png_set_expand(ps); /* palette to RGB, gray below 8 bits to 8, tRNS to alpha */
    png_set_interlace_handling(ps);
    png_read_update_info(ps, pi);
    const int depth = png_get_bit_depth(ps, pi), ch = png_get_channels(ps, pi);
    const size_t rb = png_get_rowbytes(ps, pi);
    if ((depth != 8 && depth != 16) || ch < 1) {
        rt_errf(e, "%s: PNG with %d-bit samples after expansion", name, depth);
        goto fail;
    }
    out = malloc((size_t)w * h * sizeof(float));
    rows = calloc(h, sizeof *rows);
    if (!out || !rows) {
        rt_errf(e, "%s: out of memory for a %lux%lu texture", name, (unsigned long)w, (unsigned long)h);
        goto fail;
    }
    for (png_uint_32 y = 0; y < h; y++)
        if (!(rows[y] = malloc(rb))) {
            rt_errf(e, "%s: out of memory for a %lux%lu texture", name, (unsigned long)w, (unsigned long)h);
            goto fail;
        }
    png_read_image(ps, rows);
    png_read_end(ps, NULL);
    const double maxv = depth == 16 ? 65535.0 : 255.0;
    for (png_uint_32 y = 0; y < h; y++)
        for (png_uint_32 x = 0; x < w; x++) {
            const png_bytep q = rows[y] + (size_t)x * ch * (depth / 8);
            unsigned v = depth == 16 ? (unsigned)q[0] << 8 | q[1] : q[0];
            double f = v / maxv;
            out[(size_t)y * w + x] = (float)(srgb ? srgb_to_linear(f) : f);
        }
    for (png_uint_32 y = 0; y < h; y++) free(rows[y]);
    free(rows);
    png_destroy_read_struct(&ps, &pi, NULL);
    free(src);
    *px = out;
    *pw = w;
    *ph = h;
    return 0;
fail:
    if (rows) {
        png_uint_32 hh = png_get_image_height(ps, pi);
        for (png_uint_32 y = 0; y < hh; y++) free(rows[y]);
        free(rows);
    }
    free(out);
    png_destroy_read_struct(&ps, &pi, NULL);
    free(src);
    return -1;
}

/* ---- OpenEXR (OpenEXRCore, from memory) --------------------------------------- */

typedef struct exrsrc {
    const unsigned char *p;
    size_t n;
    char msg[200];
} exrsrc;

static int64_t exr_mem_read(exr_const_context_t ctxt, void *ud, void *buf, uint64_t sz, uint64_t off,
                            exr_stream_error_func_ptr_t error_cb)
{
    (void)ctxt;
    (void)error_cb;
    exrsrc *s = ud;
    if (off >= s->n) return 0;
    uint64_t k = s->n - off < sz ? s->n - off : sz;
    memcpy(buf, s->p + off, (size_t)k);
    return (int64_t)k;
}

static int64_t exr_mem_size(exr_const_context_t ctxt, void *ud)
{
    (void)ctxt;
    return (int64_t)((exrsrc *)ud)->n;
}

static _Thread_local char exr_msg[200];

static void exr_quiet(exr_const_context_t ctxt, exr_result_t code, const char *msg)
{
    (void)ctxt;
    snprintf(exr_msg, sizeof exr_msg, "%s", msg ? msg : exr_get_error_code_as_string(code));
}

static int exr_bad(rt_err *e, const char *name, const char *what, exr_result_t rv)
{
    return rt_errf(e, "%s: OpenEXR %s: %s", name, what, exr_msg[0] ? exr_msg : exr_get_error_code_as_string(rv));
}

int rt_alpha_decode_exr(const unsigned char *buf, size_t n, const char *name, float **px, uint32_t *pw, uint32_t *ph,
                        rt_err *e)
{
    *px = NULL;
    exrsrc src = {buf, n, {0}};
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    init.error_handler_fn = exr_quiet;
    init.read_fn = exr_mem_read;
    init.size_fn = exr_mem_size;
    init.user_data = &src;
    exr_context_t f = NULL;
    exr_decode_pipeline_t dec;
    int have_dec = 0;
    float *out = NULL;
    exr_result_t rv;
    exr_msg[0] = 0;
    if (n < 4 || buf[0] != 0x76 || buf[1] != 0x2f || buf[2] != 0x31 || buf[3] != 0x01)
        return rt_errf(e, "%s: not an OpenEXR file (no OpenEXR magic)", name);
    if ((rv = exr_start_read(&f, name, &init))) return exr_bad(e, name, "header", rv);
    exr_storage_t st;
    exr_attr_box2i_t dw;
    int32_t spc = 1;
    const exr_attr_chlist_t *chl = NULL;
    if ((rv = exr_get_storage(f, 0, &st)) || (rv = exr_get_data_window(f, 0, &dw)) ||
        (rv = exr_get_scanlines_per_chunk(f, 0, &spc)) || (rv = exr_get_channels(f, 0, &chl))) {
        exr_bad(e, name, "header", rv);
        goto fail;
    }
    if (st != EXR_STORAGE_SCANLINE) {
        rt_errf(e, "%s: OpenEXR: only scanline images are read (this one is tiled or deep)", name);
        goto fail;
    }
    int64_t W = (int64_t)dw.max.x - dw.min.x + 1, H = (int64_t)dw.max.y - dw.min.y + 1;
    if (W < 1 || H < 1 || (uint64_t)W * (uint64_t)H > RT_ALPHA_MAX_TEXELS) {
        rt_errf(e, "%s: OpenEXR data window of %lldx%lld texels (1..%llu)", name, (long long)W, (long long)H,
                (unsigned long long)RT_ALPHA_MAX_TEXELS);
        goto fail;
    }
    /* the channel: R, else Y, else A, else the first */
    const char *want = NULL;
    static const char *const pref[3] = {"R", "Y", "A"};
    for (int k = 0; k < 3 && !want; k++)
        for (int c = 0; c < chl->num_channels && !want; c++)
            if (!strcmp(chl->entries[c].name.str, pref[k])) want = pref[k];
    if (!want && chl->num_channels > 0) want = chl->entries[0].name.str;
    if (!want) {
        rt_errf(e, "%s: OpenEXR image without channels", name);
        goto fail;
    }
    if (!(out = calloc((size_t)W * (size_t)H, sizeof *out))) {
        rt_errf(e, "%s: out of memory for a %lldx%lld texture", name, (long long)W, (long long)H);
        goto fail;
    }
    for (int64_t y = 0; y < H; y += spc) {
        exr_chunk_info_t ci;
        if ((rv = exr_read_scanline_chunk_info(f, 0, (int)(y + dw.min.y), &ci))) {
            exr_bad(e, name, "chunk", rv);
            goto fail;
        }
        rv = have_dec ? exr_decoding_update(f, 0, &ci, &dec) : exr_decoding_initialize(f, 0, &ci, &dec);
        if (rv) {
            exr_bad(e, name, "decoder", rv);
            goto fail;
        }
        if (!have_dec) have_dec = 1;
        int found = 0;
        for (int c = 0; c < dec.channel_count; c++) {
            exr_coding_channel_info_t *q = &dec.channels[c];
            if (strcmp(q->channel_name, want) || q->x_samples != 1 || q->y_samples != 1) {
                q->decode_to_ptr = NULL;
                continue;
            }
            found = 1;
            q->user_pixel_stride = (int32_t)sizeof(float);
            q->user_line_stride = (int32_t)(sizeof(float) * (size_t)W);
            q->user_bytes_per_element = sizeof(float);
            q->user_data_type = EXR_PIXEL_FLOAT;
            q->decode_to_ptr = (uint8_t *)(out + (size_t)(ci.start_y - dw.min.y) * (size_t)W);
        }
        if (!found) {
            rt_errf(e, "%s: OpenEXR channel %s is subsampled", name, want);
            goto fail;
        }
        if ((rv = exr_decoding_choose_default_routines(f, 0, &dec)) || (rv = exr_decoding_run(f, 0, &dec))) {
            exr_bad(e, name, "decode", rv);
            goto fail;
        }
    }
    exr_decoding_destroy(f, &dec);
    exr_finish(&f);
    *px = out;
    *pw = (uint32_t)W;
    *ph = (uint32_t)H;
    return 0;
fail:
    if (have_dec) exr_decoding_destroy(f, &dec);
    exr_finish(&f);
    free(out);
    return -1;
}
