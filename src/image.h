/*
 * image.h -- float images with cost channels, and OpenEXR I/O.
 *
 * An rt_image holds what a render produces: linear RGB plus per-pixel cost
 * channels (k-d nodes visited and triangles tested by all of the pixel's
 * rays) and the primary hit distance, so a tracer's work can be looked at
 * as a picture. EXR files are written and read through the OpenEXR C API
 * (OpenEXRCore) as 32-bit float scanline images with channels R, G, B,
 * nodes, tests, Z and string attributes for provenance.
 */
#ifndef RT_IMAGE_H
#define RT_IMAGE_H

#include "rt.h"

typedef struct rt_image {
    int W, H;
    float *rgb;    /* 3 floats per pixel, row-major, y down */
    float *nodes;  /* k-d nodes visited for this pixel (all its rays) */
    float *tests;  /* triangles tested for this pixel (all its rays) */
    float *depth;  /* primary hit distance, +inf on a miss */
} rt_image;

rt_image *rt_image_new(int W, int H, rt_err *e);
void rt_image_free(rt_image *im);
/* 1 if the RGB planes are bit-identical, else 0. */
int rt_image_rgb_equal(const rt_image *a, const rt_image *b);

/* A provenance attribute (name, value) stored in the EXR header. */
typedef struct rt_exr_attr {
    const char *name;
    const char *value;
} rt_exr_attr;

/* Writes im to path (ZIP-compressed float scanlines). 0 or -1. */
int rt_exr_write(const char *path, const rt_image *im, const rt_exr_attr *attrs, int nattrs, rt_err *e);
/* Reads an EXR written by rt_exr_write (any channel subset of R,G,B,nodes,
 * tests,Z; missing planes are zero). NULL on failure. */
rt_image *rt_exr_read(const char *path, rt_err *e);

/* Writes a tone-mapped 8-bit PNG-free preview as binary PPM (P6), gamma 2.2,
 * clamped; used for looking at renders and for the side-by-side plots. */
int rt_ppm_write(const char *path, const rt_image *im, rt_err *e);

/* Writes the image as an 8-bit gamma-2.2 PNG (zlib, no external library). */
int rt_png_write(const char *path, const rt_image *im, rt_err *e);
/* Writes raw 8-bit RGB rows (W*H*3 bytes) as PNG. */
int rt_png_write_rgb8(const char *path, int W, int H, const unsigned char *rgb, rt_err *e);
/* Tone-maps to 8-bit RGB (gamma 2.2, clamped). out holds W*H*3 bytes. */
void rt_image_to_rgb8(const rt_image *im, unsigned char *out);

#endif
/* Bytes of one pixel (colour, depth, node and test counts: 6 floats);
 * rt_image_new refuses an image larger than the machine's memory before
 * allocating it (rt_mem_fits). */
#define RT_IMAGE_PIXEL_BYTES (6 * sizeof(float))

