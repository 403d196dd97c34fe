/*
 * camera.h -- the pinhole camera every tracer shares (prefix rt_cam_).
 *
 * All tracers build their primary rays here, so the same pixel gets the same
 * ray bit for bit whichever order it is traced in. The basis is computed
 * once per render with double-precision series instead of libm
 * trigonometry, whose last bit differs between machines.
 */
#ifndef RT_CAMERA_H
#define RT_CAMERA_H

#include "isect.h"
#include "scene.h"

typedef struct rt_cam_frame {
    rt_vec3 eye, dir, right, up; /* dir/right/up scaled to the image plane */
    int W, H;                    /* image size the frame was set up for */
} rt_cam_frame;

/* Sets up the frame of sc's camera for a W x H image. */
void rt_cam_setup(rt_cam_frame *f, const rt_scene *sc, int W, int H);
/* Primary ray through the centre of pixel (x, y), y down. */
void rt_cam_ray(const rt_cam_frame *f, int x, int y, rt_ray *r);
/* Deterministic double-precision tangent for |x| < pi/2 (series; no libm). */
double rt_cam_tan(double x);
/* The same for an angle in degrees (no conversion rounding). */
double rt_cam_tan_deg(double deg);

/* Former name, kept for the core tests. */
static inline double rt_dtan(double x) { return rt_cam_tan(x); }

#endif
