/* pixels.c -- pixel subsampling and the traced-pixel order (see pixels.h). */
#include "pixels.h"
#include "image.h"
#include "hilbert.h"

#include <inttypes.h>
#include <stdio.h>
#include <string.h>

int rt_pixel_kept(const rt_render_opts *o, int x, int y)
{
    if (o->subsample <= 1) return 1;
    uint64_t t = ((uint64_t)(uint32_t)(x / o->subtile) << 32) | (uint32_t)(y / o->subtile);
    /* splitmix64 finalizer: tiles are chosen independently of position */
    t += 0x9e3779b97f4a7c15ULL;
    t = (t ^ (t >> 30)) * 0xbf58476d1ce4e5b9ULL;
    t = (t ^ (t >> 27)) * 0x94d049bb133111ebULL;
    t ^= t >> 31;
    return t % o->subsample == 0;
}

size_t rt_pixel_order(const rt_render_opts *o, uint32_t *order)
{
    size_t npix = (size_t)o->W * (size_t)o->H, n = 0;
    rt_hilbert_order(o->W, o->H, order);
    if (o->subsample <= 1) return npix;
    for (size_t k = 0; k < npix; k++) {
        uint32_t p = order[k];
        if (rt_pixel_kept(o, (int)(p % (uint32_t)o->W), (int)(p / (uint32_t)o->W))) order[n++] = p;
    }
    return n;
}

uint64_t rt_pixel_tiles(const rt_render_opts *o)
{
    if (o->subtile < 1 || o->W < 1 || o->H < 1) return 0;
    uint64_t tx = ((uint64_t)o->W + (uint64_t)o->subtile - 1) / (uint64_t)o->subtile;
    uint64_t ty = ((uint64_t)o->H + (uint64_t)o->subtile - 1) / (uint64_t)o->subtile;
    return tx * ty;
}

int rt_pixel_check(const rt_render_opts *o, rt_err *e)
{
    /* the image must fit in memory: refused here, before any work */
    if (o->W >= 1 && o->H >= 1) {
        char what[80];
        snprintf(what, sizeof what, "-W %d -H %d: an image of %dx%d pixels", o->W, o->H, o->W, o->H);
        if (rt_mem_fits((uint64_t)o->W * (uint64_t)o->H * RT_IMAGE_PIXEL_BYTES, what, e) < 0) return -1;
    }
    if (o->subsample < 1 || o->subtile < 1) return rt_errf(e, "subsampling needs K >= 1 and a tile of >= 1 pixel");
    if (o->subsample <= 1 || o->W < 1 || o->H < 1) return 0; /* image size is checked by the job */
    uint64_t tiles = rt_pixel_tiles(o);
    if (o->subsample > tiles)
        return rt_errf(e, "--subsample %u exceeds the %" PRIu64 " tiles of %dx%d pixels (tile %d): no pixel would be "
                          "traced", (unsigned)o->subsample, tiles, o->W, o->H, o->subtile);
    for (int y = 0; y < o->H; y += o->subtile)
        for (int x = 0; x < o->W; x += o->subtile)
            if (rt_pixel_kept(o, x, y)) return 0;
    return rt_errf(e, "--subsample %u keeps none of the %" PRIu64 " tiles of %dx%d pixels (tile %d): no pixel would "
                      "be traced", (unsigned)o->subsample, tiles, o->W, o->H, o->subtile);
}

void rt_pixel_params(const rt_render_opts *o, char *buf, size_t n)
{
    if (n) buf[0] = 0;
    if (o->subsample > 1) snprintf(buf, n, " subsample=%u tile=%d", (unsigned)o->subsample, o->subtile);
}

size_t rt_pixel_order_part(const rt_render_opts *o, int part, int nparts, uint32_t *order)
{
    size_t n = rt_pixel_order(o, order);
    if (nparts <= 1) return n;
    size_t m = 0;
    for (size_t k = 0; k < n; k++)
        if ((k / RT_SHARE_TILE) % (size_t)nparts == (size_t)part) order[m++] = order[k];
    return m;
}
