/* camera.c -- the shared pinhole camera (see camera.h). */
#include "camera.h"

double rt_cam_tan(double x)
{
    double s, c;
    rt_dsincos_deg(x * (180.0 / 3.14159265358979323846), &s, &c);
    return s / c;
}

double rt_cam_tan_deg(double deg)
{
    double s, c;
    rt_dsincos_deg(deg, &s, &c);
    return s / c;
}

void rt_cam_setup(rt_cam_frame *f, const rt_scene *sc, int W, int H)
{
    const rt_camera *c = &sc->cam;
    rt_vec3 dir = rt_norm(rt_sub(c->at, c->eye));
    rt_vec3 right = rt_norm(rt_cross(dir, c->up));
    rt_vec3 up = rt_cross(right, dir);
    if (c->mirror) right = rt_mul(right, -1.0f); /* pbrt's left-handed screen */
    double half_h = rt_cam_tan_deg(0.5 * (double)c->fovy_deg);
    double half_w = half_h * (double)W / (double)H;
    f->eye = c->eye;
    f->dir = dir;
    f->right = rt_mul(right, (float)half_w);
    f->up = rt_mul(up, (float)half_h);
    f->W = W;
    f->H = H;
}

void rt_cam_ray(const rt_cam_frame *f, int x, int y, rt_ray *r)
{
    float sx = (float)(2.0 * ((double)x + 0.5) / f->W - 1.0);
    float sy = (float)(1.0 - 2.0 * ((double)y + 0.5) / f->H);
    rt_vec3 d = rt_add(f->dir, rt_add(rt_mul(f->right, sx), rt_mul(f->up, sy)));
    rt_ray_init(r, f->eye, d);
}
