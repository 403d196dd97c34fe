/* image.c -- float images with cost channels, and a PPM preview writer. */
#include "image.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

rt_image *rt_image_new(int W, int H, rt_err *e)
{
    if (W <= 0 || H <= 0 || W > 65536 || H > 65536) {
        rt_errf(e, "image size %dx%d out of range (1..65536)", W, H);
        return NULL;
    }
    size_t n = (size_t)W * (size_t)H;
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
    FILE *f = fopen(path, "wb");
    if (!f) return rt_errf(e, "%s: %s", path, strerror(errno));
    fprintf(f, "P6\n%d %d\n255\n", im->W, im->H);
    size_t n = (size_t)im->W * (size_t)im->H;
    for (size_t i = 0; i < n; i++) {
        unsigned char px[3] = {to8(im->rgb[3 * i]), to8(im->rgb[3 * i + 1]), to8(im->rgb[3 * i + 2])};
        fwrite(px, 1, 3, f);
    }
    if (fclose(f) != 0) return rt_errf(e, "%s: write failed: %s", path, strerror(errno));
    return 0;
}
