/*
 * ply_read.h -- the shared Stanford PLY reader (prefix rt_ply): a PLY
 * file's bytes into vertices and triangle corner indices, for the PLY
 * loader, the built-in bunny and pbrt's plymesh alike (ply_read.c has the
 * format subset and the error rules). It knows nothing of scenes.
 */
#ifndef RT_PLY_READ_H
#define RT_PLY_READ_H

#include "rt.h"
#include "rt_math.h"

#include <stddef.h>
#include <stdint.h>

typedef struct rt_ply_mesh {
    rt_vec3 *v;    /* nv vertices (finite, within RT_COORD_MAX) */
    uint32_t nv;
    uint32_t *idx; /* triangle corners, 3 per triangle, each < nv (faces fanned in file order) */
    size_t nidx;
} rt_ply_mesh;

/* Parses the PLY held in buf (n bytes, buf[n] = 0; path names it in
 * messages) into m (free with rt_ply_mesh_free). 0, or -1 with a one-line
 * "FILE:LINE: what" / "FILE: byte N: what" in e (m empty). */
int rt_ply_parse(const char *path, const char *buf, size_t n, rt_ply_mesh *m, rt_err *e);
/* The file at path (plain or gzip, regular, at most rt_scene_max_bytes;
 * scene_file.h) through rt_ply_parse. */
int rt_ply_read_file(const char *path, rt_ply_mesh *m, rt_err *e);
void rt_ply_mesh_free(rt_ply_mesh *m);
/* Checks invariants P1-P3 of ply_read.c. 0, or -1 naming the broken one. */
int rt_ply_check(const rt_ply_mesh *m, rt_err *e);

#endif
