/* hilbert.c -- Hilbert-curve pixel order (see hilbert.h). */
#include "hilbert.h"

void rt_hilbert_d2xy(uint32_t n, uint64_t d, uint32_t *xo, uint32_t *yo)
{
    uint32_t x = 0, y = 0;
    uint64_t t = d;
    for (uint32_t s = 1; s < n; s *= 2) {
        uint32_t rx = 1u & (uint32_t)(t / 2);
        uint32_t ry = 1u & (uint32_t)(t ^ rx);
        if (ry == 0) { /* rotate the quadrant */
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

void rt_hilbert_order(int W, int H, uint32_t *order)
{
    uint32_t n = 1;
    while (n < (uint32_t)W || n < (uint32_t)H) n *= 2;
    uint64_t k = 0, total = (uint64_t)W * (uint64_t)H;
    for (uint64_t d = 0; k < total && d < (uint64_t)n * n; d++) {
        uint32_t x, y;
        rt_hilbert_d2xy(n, d, &x, &y);
        if (x < (uint32_t)W && y < (uint32_t)H) order[k++] = y * (uint32_t)W + x;
    }
}
