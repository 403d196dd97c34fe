/*
 * hilbert.h -- Hilbert-curve pixel order for images of any size.
 *
 * The curve is drawn on the smallest power-of-two square that covers the
 * image and pixels outside the image are skipped, so every pixel is visited
 * exactly once for any width and height (odd, non-square), and consecutive
 * pixels stay neighbours except where the curve leaves and re-enters the
 * image.
 */
#ifndef RT_HILBERT_H
#define RT_HILBERT_H

#include <stdint.h>

/* (x, y) of distance d along the Hilbert curve of side n (power of two). */
void rt_hilbert_d2xy(uint32_t n, uint64_t d, uint32_t *x, uint32_t *y);
/* Fills order[0 .. W*H) with pixel indices y*W + x in curve order. */
void rt_hilbert_order(int W, int H, uint32_t *order);

#endif
