/*
 * shade.h -- the shading rule and shadow rays every tracer shares (prefix
 * rt_shade_).
 *
 * Shading, in this exact operation order so results are bit-identical:
 * c = albedo * ambient; for each enabled light i in increasing order, if
 * visible: c += albedo * (max(0, n.l) * light_power); n is the geometric
 * normal facing the eye ray, l the unit vector to the light. With no light
 * enabled (primary rays only) a headlight stands in so the image still
 * shows shape: c = albedo * (ambient + |n.d| * light_power), d the unit eye
 * direction. Rays that miss get the scene background.
 *
 * Tracers differ only in the order they trace rays: each finds a pixel's
 * closest hit and per-light visibility and hands them to rt_shade_pixel.
 */
#ifndef RT_SHADE_H
#define RT_SHADE_H

#include "image.h"
#include "kdtrav.h"
#include "scene.h"

/* Shades one primary hit exactly as documented above. vis[i] != 0 when light
 * i is enabled and visible. Writes rgb[3]. */
void rt_shade_hit(const rt_scene *sc, const rt_ray *eye, const rt_hit *h, const int vis[RT_NLIGHTS],
                  unsigned lights, float rgb[3]);

/* Writes pixel pix of img (RGB and depth; not the cost channels): the
 * shaded hit h of the eye ray, or the background when h is NULL. */
void rt_shade_pixel(const rt_scene *sc, const rt_ray *eye, const rt_hit *h, const int vis[RT_NLIGHTS],
                    unsigned lights, rt_image *img, size_t pix);

/* Shadow ray from a primary hit toward light i: origin offset off the
 * surface toward the eye side, direction = light - origin, interval
 * (0, 1). Returns 0 when the light is behind the surface (no ray needed:
 * not lit), else 1. */
int rt_shade_ray(const rt_scene *sc, const rt_ray *eye, const rt_hit *h, int light, rt_ray *sr);

#endif
