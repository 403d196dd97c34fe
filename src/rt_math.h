/*
 * rt_math.h -- small vector math, all inline. Single precision, as the
 * modeled records store floats; callers that need more widen locally.
 */
#ifndef RT_MATH_H
#define RT_MATH_H

#include <math.h>
#include <stdint.h>

typedef struct rt_vec3 {
    float x, y, z;
} rt_vec3;

typedef struct rt_bounds {
    rt_vec3 lo, hi; /* empty when lo > hi on any axis */
} rt_bounds;

static inline rt_vec3 rt_v3(float x, float y, float z) { rt_vec3 v = {x, y, z}; return v; }
static inline rt_vec3 rt_add(rt_vec3 a, rt_vec3 b) { return rt_v3(a.x + b.x, a.y + b.y, a.z + b.z); }
static inline rt_vec3 rt_sub(rt_vec3 a, rt_vec3 b) { return rt_v3(a.x - b.x, a.y - b.y, a.z - b.z); }
static inline rt_vec3 rt_mul(rt_vec3 a, float s) { return rt_v3(a.x * s, a.y * s, a.z * s); }
static inline rt_vec3 rt_hadamard(rt_vec3 a, rt_vec3 b) { return rt_v3(a.x * b.x, a.y * b.y, a.z * b.z); }
static inline float rt_dot(rt_vec3 a, rt_vec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
static inline rt_vec3 rt_cross(rt_vec3 a, rt_vec3 b)
{
    return rt_v3(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
}
static inline float rt_len(rt_vec3 a) { return sqrtf(rt_dot(a, a)); }
static inline rt_vec3 rt_norm(rt_vec3 a)
{
    float l = rt_len(a);
    return l > 0 ? rt_mul(a, 1.0f / l) : a;
}
static inline float rt_axis(rt_vec3 a, int k) { return k == 0 ? a.x : (k == 1 ? a.y : a.z); }
static inline void rt_set_axis(rt_vec3 *a, int k, float v)
{
    if (k == 0) a->x = v; else if (k == 1) a->y = v; else a->z = v;
}
static inline rt_vec3 rt_vmin(rt_vec3 a, rt_vec3 b)
{
    return rt_v3(fminf(a.x, b.x), fminf(a.y, b.y), fminf(a.z, b.z));
}
static inline rt_vec3 rt_vmax(rt_vec3 a, rt_vec3 b)
{
    return rt_v3(fmaxf(a.x, b.x), fmaxf(a.y, b.y), fmaxf(a.z, b.z));
}
static inline rt_bounds rt_bounds_empty(void)
{
    rt_bounds b = {{INFINITY, INFINITY, INFINITY}, {-INFINITY, -INFINITY, -INFINITY}};
    return b;
}
static inline void rt_bounds_grow(rt_bounds *b, rt_vec3 p)
{
    b->lo = rt_vmin(b->lo, p);
    b->hi = rt_vmax(b->hi, p);
}

/* a grown to hold b (plain compares: boxes hold no NaN). */
static inline void rt_bounds_union(rt_bounds *a, const rt_bounds *b)
{
    if (b->lo.x < a->lo.x) a->lo.x = b->lo.x;
    if (b->lo.y < a->lo.y) a->lo.y = b->lo.y;
    if (b->lo.z < a->lo.z) a->lo.z = b->lo.z;
    if (b->hi.x > a->hi.x) a->hi.x = b->hi.x;
    if (b->hi.y > a->hi.y) a->hi.y = b->hi.y;
    if (b->hi.z > a->hi.z) a->hi.z = b->hi.z;
}

/* The murmur3 64-bit finalizer: a cheap, well-mixed hash of a 64-bit key,
 * shared by the samplers and the synthetic benchmark trace. */
static inline uint64_t rt_mix64(uint64_t x)
{
    x ^= x >> 33;
    x *= 0xff51afd7ed558ccdULL;
    x ^= x >> 33;
    x *= 0xc4ceb9fe1a85ec53ULL;
    return x ^ (x >> 33);
}

#endif
