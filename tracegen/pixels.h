/*
 * pixels.h -- which pixels a run traces, and in what order (prefix
 * rt_pixel_).
 *
 * Pixel subsampling, a reduced experiment: the image is cut into square
 * tiles of o->subtile pixels and a tile is traced iff a fixed hash of its
 * coordinates is 0 mod o->subsample, so about 1/K of the tiles are traced,
 * the same ones on every machine and for every tracer. Tiles keep the
 * locality of neighbouring rays (a tile of 8 is one packet, and two rays
 * per ray-record line); tile 1 samples single pixels. Untraced pixels
 * keep the image's initial zeros and are never referenced, so their ray
 * records and framebuffer lines never enter the cache. Traffic of the
 * full image is estimated as traffic x (pixels / traced pixels).
 */
#ifndef RT_PIXELS_H
#define RT_PIXELS_H

#include "options.h"

#include <stddef.h>

/* 1 when pixel (x, y) is traced under o's subsampling, else 0. */
int rt_pixel_kept(const rt_render_opts *o, int x, int y);
/* Writes the traced pixels (y * W + x) in Hilbert-curve order to order[]
 * (room for W * H) and returns how many there are. */
size_t rt_pixel_order(const rt_render_opts *o, uint32_t *order);
/*
 * Work shares. The work of a frame splits into parts that can run at the
 * same time (host threads: rt_job_run), by a static interleave:
 *   - pixel tracers (recursive, treelet): the traced pixels in Hilbert order
 *     (rt_pixel_order) are cut into share tiles of RT_SHARE_TILE consecutive
 *     pixels; share tile t belongs to part t mod nparts;
 *   - packet tracer: the kept packets, counted in the tracer's row-major
 *     order, packet q belonging to part q mod nparts.
 * Every pixel belongs to exactly one part, and part p traces its pixels in
 * the order one part would (nparts <= 1: everything, today's order). With a
 * 512 x 512 image a share tile is an 8 x 8 block of the Hilbert curve.
 */
#define RT_SHARE_TILE 64
/* Part `part` of `nparts` of rt_pixel_order's pixels, in order, into order[]
 * (room for W * H); returns how many. */
size_t rt_pixel_order_part(const rt_render_opts *o, int part, int nparts, uint32_t *order);
/* 1 when the packet with row-major index q belongs to part `part` of `nparts`. */
static inline int rt_pixel_packet_part(uint64_t q, int part, int nparts)
{
    return nparts <= 1 || q % (uint64_t)nparts == (uint64_t)part;
}

/* Number of subsampling tiles of the image (partial tiles at the right and
 * bottom edges count). */
uint64_t rt_pixel_tiles(const rt_render_opts *o);
/* Checks subsample/subtile: K >= 1, tile >= 1, K no larger than the tile
 * count and at least one tile kept (else the run would trace nothing).
 * Tracer-specific rules (whole packets per tile) are the tracer's
 * check_opts. 0, or -1 with the reason in e. */
int rt_pixel_check(const rt_render_opts *o, rt_err *e);
/* Writes " subsample=K tile=T" (nothing when K = 1) to buf for the run
 * parameters. */
void rt_pixel_params(const rt_render_opts *o, char *buf, size_t n);

/* Former names, kept for the front end. */
static inline void rt_subsample_params(const rt_render_opts *o, char *buf, size_t n) { rt_pixel_params(o, buf, n); }

#endif
