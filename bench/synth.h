/*
 * synth.h -- the synthetic ray-tracer trace both benchmarks replay
 * (module prefix rt_synth). Not part of the library.
 *
 * It imitates a k-d tree ray tracer with coherent rays (consecutive rays
 * are neighbours, as in Hilbert order): per ray, read the 32-byte ray
 * record, walk an 18-level path down a breadth-first array of 8-byte nodes
 * (the top levels change every few thousand rays, the deepest every ray),
 * then visit two leaves, each an index read (16 B) and four 36-byte
 * triangles (straddling lines) at a leaf-dependent place in a
 * 500K-triangle array, and write 16 bytes of hit record back into the ray:
 * 30 references per ray. The stream is a pure function of the position in
 * it (no seed, no clock), so every pass and every machine sees the same
 * references, and a benchmark can regenerate it in chunks instead of
 * holding it.
 */
#ifndef RT_SYNTH_H
#define RT_SYNTH_H

#include "memmodel.h"

#include <stddef.h>
#include <stdint.h>

typedef struct rt_synth {
    uint64_t ray;  /* current ray */
    int phase;     /* step within the current ray (0..29) */
    uint64_t node; /* current node index (breadth-first, root 1) */
    uint64_t leaf; /* current leaf's first triangle */
} rt_synth;

/* Starts g at the first reference of the stream. */
void rt_synth_init(rt_synth *g);
/* Writes the next n references of the stream to a[0..n-1]. */
void rt_synth_fill(rt_synth *g, rt_access *a, size_t n);

#endif
