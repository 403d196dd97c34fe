/*
 * stream.h -- the streaming ray tracer of Purcell et al. (2002): its
 * kernels, their Table 1 costs and the paper's cost model (prefix
 * rt_stream_).
 *
 * Two tracers (stream.c) run the same kernels over the uniform grid
 * (src/grid.h): stream-branching runs one ray at a time from generation to
 * shading; stream-multipass runs one kernel over every ray of a
 * screen-sized stream per rendering pass, under the control of a stencil
 * buffer. Both find the same hits and count the same voxels, tests and
 * shading calculations per ray; they differ in passes and traffic
 * (docs/purcell.md).
 */
#ifndef RT_STREAM_H
#define RT_STREAM_H

#include <stdint.h>

/* The kernels, in Table 1's order. */
typedef enum rt_stream_kernel {
    RT_SK_EYE = 0,    /* generate eye ray */
    RT_SK_SETUP = 1,  /* traverse: setup */
    RT_SK_STEP = 2,   /* traverse: step */
    RT_SK_ISECT = 3,  /* intersect */
    RT_SK_COLOR = 4,  /* shade: color */
    RT_SK_SHADOW = 5, /* shade: shadow */
    RT_SK_REFL = 6,   /* shade: reflected */
    RT_SK_PATH = 7,   /* shade: path */
    RT_SK_N = 8
} rt_stream_kernel;

/* One row of Table 1 for one architecture. Words are 32 bits; stencil
 * values 8 bits. The branching architecture has no stencil (RS = WS = 0). */
typedef struct rt_stream_cost_row {
    const char *name; /* "eye", "setup", "step", "intersect", "color", "shadow", "reflected", "path" */
    int instr;        /* instructions per invocation */
    int R, W;         /* state words read and written between passes */
    int M;            /* words read from random-access textures */
    int RS, WS;       /* stencil reads and writes (multipass) */
} rt_stream_cost_row;

/* Table 1: multipass != 0 gives the multipass columns, else branching.
 * Returns RT_SK_N rows in rt_stream_kernel order. */
const rt_stream_cost_row *rt_stream_table(int multipass);

/* Data types of Figure 8, in the order of the "dbytes" statistic. */
enum { RT_SD_STENCIL, RT_SD_STATE, RT_SD_GRID, RT_SD_LIST, RT_SD_TRI, RT_SD_SHADE, RT_SD_FB, RT_SD_N };

/* The paper's cost model (section 3.2):
 *   C = R (C_r + v C_v + t C_t + s C_s) + R P C_stencil
 * with C_r = eye + setup, C_v = step, C_t = intersect, C_s = color from
 * Table 1 (multipass or branching columns). Fills *instr with the
 * instruction cost and *bytes with the bandwidth cost (4 bytes per state
 * or texel word, 1 per stencil access: C_stencil = 1 byte, 0 for
 * branching). */
void rt_stream_cost(int multipass, double R, double v, double t, double s, double P, double *instr, double *bytes);

#endif
