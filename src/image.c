/* image.c -- float images with cost channels, and PPM and PNG preview
 * writers (through outfile.c: complete or absent). */
#include "image.h"
#include "outfile.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <zlib.h>

rt_image *rt_image_new(int W, int H, rt_err *e)
{
    if (W <= 0 || H <= 0 || W > 65536 || H > 65536) {
        rt_errf(e, "image size %dx%d out of range (1..65536)", W, H);
        return NULL;
    }
    size_t n = (size_t)W * (size_t)H;
    char what[64];
    snprintf(what, sizeof what, "an image of %dx%d pixels", W, H);
    if (rt_mem_fits((uint64_t)n * RT_IMAGE_PIXEL_BYTES, what, e) < 0) return NULL;
    rt_image *im = rt_calloc(1, sizeof *im, e);
    if (!im) return NULL;
    im->W = W;
    im->H = H;
    im->rgb = rt_calloc(3 * n, sizeof(float), e);
    im->nodes = im->rgb ? rt_calloc(n, sizeof(float), e) : NULL;
    im->tests = im->nodes ? rt_calloc(n, sizeof(float), e) : NULL;
    im->depth = im->tests ? rt_calloc(n, sizeof(float), e) : NULL;
    if (!im->depth) {
        rt_image_free(im);
        return NULL;
    }
    return im;
}

void rt_image_free(rt_image *im)
{
    if (!im) return;
    free(im->rgb);
    free(im->nodes);
    free(im->tests);
    free(im->depth);
    free(im);
}

int rt_image_rgb_equal(const rt_image *a, const rt_image *b)
{
    if (a->W != b->W || a->H != b->H) return 0;
    return memcmp(a->rgb, b->rgb, sizeof(float) * 3 * (size_t)a->W * (size_t)a->H) == 0;
}

static unsigned char to8(float v)
{
    if (!(v > 0)) return 0;
    if (v >= 1) return 255;
    return (unsigned char)(255.0 * pow(v, 1.0 / 2.2) + 0.5);
}

int rt_ppm_write(const char *path, const rt_image *im, rt_err *e)
{
    rt_out *o = rt_out_open(path, e);
    if (!o) return -1;
    FILE *f = rt_out_stream(o);
    fprintf(f, "P6\n%d %d\n255\n", im->W, im->H);
    size_t n = (size_t)im->W * (size_t)im->H;
    for (size_t i = 0; i < n; i++) {
        unsigned char px[3] = {to8(im->rgb[3 * i]), to8(im->rgb[3 * i + 1]), to8(im->rgb[3 * i + 2])};
        fwrite(px, 1, 3, f);
    }
    return rt_out_commit(o, e); /* checks the stream's error flag */
}

/* ---- PNG (8-bit RGB, one IDAT, zlib) --------------------------------- */

static void put32(unsigned char *p, uint32_t v)
{
    p[0] = (unsigned char)(v >> 24);
    p[1] = (unsigned char)(v >> 16);
    p[2] = (unsigned char)(v >> 8);
    p[3] = (unsigned char)v;
}

static int png_chunk(FILE *f, const char *type, const unsigned char *data, size_t n)
{
    unsigned char hdr[8];
    put32(hdr, (uint32_t)n);
    memcpy(hdr + 4, type, 4);
    uLong crc = crc32(0L, (const Bytef *)type, 4);
    if (n) crc = crc32(crc, data, (uInt)n);
    unsigned char c[4];
    put32(c, (uint32_t)crc);
    return fwrite(hdr, 1, 8, f) == 8 && (n == 0 || fwrite(data, 1, n, f) == n) && fwrite(c, 1, 4, f) == 4 ? 0 : -1;
}

int rt_png_write_rgb8(const char *path, int W, int H, const unsigned char *rgb, rt_err *e)
{
    size_t row = (size_t)W * 3 + 1, raw_n = row * (size_t)H;
    unsigned char *raw = rt_calloc(raw_n, 1, e);
    if (!raw) return -1;
    for (int y = 0; y < H; y++) {
        raw[(size_t)y * row] = 0; /* filter: none */
        memcpy(raw + (size_t)y * row + 1, rgb + (size_t)y * W * 3, (size_t)W * 3);
    }
    uLongf zn = compressBound((uLong)raw_n);
    unsigned char *z = rt_calloc(zn, 1, e);
    if (!z || compress2(z, &zn, raw, (uLong)raw_n, 6) != Z_OK) {
        free(raw);
        free(z);
        return z ? rt_errf(e, "%s: compression failed", path) : -1;
    }
    free(raw);
    rt_out *o = rt_out_open(path, e);
    if (!o) {
        free(z);
        return -1;
    }
    FILE *f = rt_out_stream(o);
    static const unsigned char sig[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
    unsigned char ihdr[13];
    put32(ihdr, (uint32_t)W);
    put32(ihdr + 4, (uint32_t)H);
    ihdr[8] = 8;  /* bit depth */
    ihdr[9] = 2;  /* colour type: RGB */
    ihdr[10] = ihdr[11] = ihdr[12] = 0;
    int ok = fwrite(sig, 1, 8, f) == 8 && png_chunk(f, "IHDR", ihdr, 13) == 0 && png_chunk(f, "IDAT", z, zn) == 0 &&
             png_chunk(f, "IEND", NULL, 0) == 0;
    free(z);
    if (!ok) {
        int err = errno ? errno : EIO;
        rt_out_abort(o);
        return rt_errf(e, "%s: write failed: %s", path, strerror(err));
    }
    return rt_out_commit(o, e);
}

void rt_image_to_rgb8(const rt_image *im, unsigned char *out)
{
    size_t n = (size_t)im->W * (size_t)im->H;
    for (size_t i = 0; i < 3 * n; i++) out[i] = to8(im->rgb[i]);
}

int rt_png_write(const char *path, const rt_image *im, rt_err *e)
{
    unsigned char *rgb = rt_calloc((size_t)im->W * im->H, 3, e);
    if (!rgb) return -1;
    rt_image_to_rgb8(im, rgb);
    int rc = rt_png_write_rgb8(path, im->W, im->H, rgb, e);
    free(rgb);
    return rc;
}
