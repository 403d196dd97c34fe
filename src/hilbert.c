/* hilbert.c -- Hilbert-curve pixel order (see hilbert.h). */
#include "hilbert.h"

/* The curve's levels from side b up to n (t: the digits of d above b's),
 * applied to a point (x, y) of the b x b block; from b = 1 and (0, 0),
 * the point of d itself. */
static void upper_levels(uint32_t n, uint32_t b, uint64_t t, uint32_t *xo, uint32_t *yo)
{
    uint32_t x = *xo, y = *yo;
    for (uint32_t s = b; s < n; s *= 2) {
        uint32_t rx = 1u & (uint32_t)(t / 2);
        uint32_t ry = 1u & (uint32_t)(t ^ rx);
        if (ry == 0) {
            if (rx == 1) {
                x = s - 1 - x;
                y = s - 1 - y;
            }
            uint32_t tmp = x;
            x = y;
            y = tmp;
        }
        x += s * rx;
        y += s * ry;
        t /= 4;
    }
    *xo = x;
    *yo = y;
}

void rt_hilbert_d2xy(uint32_t n, uint64_t d, uint32_t *xo, uint32_t *yo)
{
    *xo = *yo = 0; /* every level from side 1: the whole curve */
    upper_levels(n, 1, d, xo, yo);
}

/*
 * The curve in blocks of B x B pixels (B = 16, or n when smaller): every
 * level of rt_hilbert_d2xy maps the point built by the levels below it by
 * a reflection or swap plus an offset -- an affine map with integer
 * coefficients -- so the levels above a block compose to one such map,
 * found from the images of three points of the block, and applied to the
 * block's own curve (a table of B x B points). Exact integer arithmetic:
 * the same points as rt_hilbert_d2xy of every d, at a few operations per
 * pixel instead of a loop over all levels.
 */
void rt_hilbert_order(int W, int H, uint32_t *order)
{
    enum { B = 16 };
    uint32_t n = 1;
    while (n < (uint32_t)W || n < (uint32_t)H) n *= 2;
    const uint64_t total = (uint64_t)W * (uint64_t)H;
    if (n == 1) {
        if (total) order[0] = 0;
        return;
    }
    const uint32_t b = n < B ? n : B, bb = b * b;
    uint8_t tx[B * B], ty[B * B];
    for (uint32_t j = 0; j < bb; j++) {
        uint32_t x, y;
        rt_hilbert_d2xy(b, j, &x, &y);
        tx[j] = (uint8_t)x;
        ty[j] = (uint8_t)y;
    }
    uint64_t k = 0;
    const uint64_t nblocks = (uint64_t)n * n / bb;
    for (uint64_t blk = 0; blk < nblocks && k < total; blk++) {
        uint32_t cx = 0, cy = 0, ux = 1, uy = 0, vx = 0, vy = 1;
        upper_levels(n, b, blk, &cx, &cy); /* image of (0, 0) */
        upper_levels(n, b, blk, &ux, &uy); /* of (1, 0) */
        upper_levels(n, b, blk, &vx, &vy); /* of (0, 1) */
        const int64_t ax = (int64_t)ux - cx, ay = (int64_t)uy - cy, bx = (int64_t)vx - cx, by = (int64_t)vy - cy;
        for (uint32_t j = 0; j < bb && k < total; j++) {
            const int64_t x = cx + ax * tx[j] + bx * ty[j], y = cy + ay * tx[j] + by * ty[j];
            if (x < W && y < H) order[k++] = (uint32_t)y * (uint32_t)W + (uint32_t)x;
        }
    }
}
