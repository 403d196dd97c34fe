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
    float near;                  /* camera rays start this far from the eye (0: at it) */
} rt_cam_frame;

/* Sets up the frame of sc's camera for a W x H image.
 *
 * Camera on a surface: an eye closer to a triangle than the
 * self-intersection rule's reach (rt_offset_reach: the distance a spawned
 * ray's origin is moved off its surface, doubled) would see that triangle
 * at t of rounding size -- in every structure, and in the k-d tree only
 * when the triangle is listed on the side the ray points to
 * (docs/kdtree.md cause 4). For such an eye the frame gets a near
 * distance equal to that reach, and every camera ray starts that far from
 * the eye along its direction: the eye's own surface is behind it, as a
 * spawned ray's is, and all structures agree. Any other eye (every
 * built-in scene's) gets near = 0 and the rays are those of before bit for
 * bit. The test is one pass over the triangles, skipped when the eye lies
 * outside the scene's bounds. */
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
