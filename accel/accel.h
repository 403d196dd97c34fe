/*
 * accel.h -- the acceleration-structure layer (prefix rt_accel_): the
 * structures rays are traced through, behind one small interface.
 *
 * A structure is built from a scene, declares the regions its walks read in
 * the memory model (memmodel.h), walks one ray at a time for the closest hit
 * or any hit with every node and triangle access counted (rt_trav) and,
 * when a recorder is attached, recorded at its modeled address, and has a
 * checker for its invariants. Hits follow the one rule of hit.h, so every
 * structure gives the same image.
 *
 * Members (rt_accel_table, indexed by rt_accel_kind):
 *   kd     SAH k-d tree with 8-byte nodes (kdtree.h, kdtrav.h; Navratil et al.)
 *   grid   uniform grid walked by 3D-DDA (grid.h; Purcell et al.)
 *   naive  no structure: every triangle against every ray (Purcell's Fig. 1d)
 *   bvh2, bvh4, bvh8  bounding volume hierarchies: binary (pbrt's 32-byte
 *          nodes), 4-wide (Embree's 128-byte nodes), 8-wide compressed
 *          (Ylitie et al.'s 80-byte nodes); triangles in leaf order (bvh.h)
 *   inst   true instancing: a top-level BVH over instances, one shared BVH
 *          per object (inst.h); chosen with --instances bvh, not by name
 * A tracer's traits (tracer.h) say which members it runs on and which is its
 * default; a job builds only that one.
 *
 * Adding a structure: write accel/NAME.c defining `const rt_accel_ops
 * rt_accel_NAME` (build, free, regions, trav_init, closest, occluded,
 * check, info), add its kind to rt_accel_kind and one line to
 * rt_accel_table (accel.c), and list the file in accel/local.am.
 *
 * Library rule: return -1 (or NULL) with rt_errf(e, ...); never print.
 */
#ifndef RT_ACCEL_H
#define RT_ACCEL_H

#include "hit.h"
#include "memmodel.h"
#include "rt.h"
#include "scene.h"

#include <stdint.h>

typedef enum rt_accel_kind {
    RT_ACCEL_DEFAULT = 0, /* the tracer's default structure (tracer.h, accel_default) */
    RT_ACCEL_KD = 1,      /* SAH k-d tree */
    RT_ACCEL_GRID = 2,    /* uniform grid */
    RT_ACCEL_NAIVE = 3,   /* every triangle */
    RT_ACCEL_BVH2 = 4,    /* binary BVH, 32-byte nodes (pbrt) */
    RT_ACCEL_BVH4 = 5,    /* 4-wide BVH, 128-byte nodes (Embree) */
    RT_ACCEL_BVH8 = 6,    /* 8-wide compressed BVH, 80-byte nodes (Ylitie et al.) */
    RT_ACCEL_INST = 7,    /* two-level BVH over object instances (inst.h; --instances bvh) */
    RT_ACCEL_NKINDS = 8
} rt_accel_kind;

#define RT_ACCEL_BVH_BITS (RT_ACCEL_BIT(RT_ACCEL_BVH2) | RT_ACCEL_BIT(RT_ACCEL_BVH4) | RT_ACCEL_BIT(RT_ACCEL_BVH8))

/* rt_accel_ops.flags */
enum {
    RT_ACCEL_OWN_TRIS = 1u << 0 /* stores the triangle records itself, in its own order (its regions
                                 * include them; tracers add no tri.verts and walks record into its
                                 * region): compact 36-byte records only */
};

#define RT_ACCEL_BIT(k) (1u << (k))

/* How to build: the knobs a structure reads (others ignore them). */
typedef struct rt_accel_params {
    uint32_t grid_min; /* grid: cells along the smallest axis; 0 = 64, halved until the grid fits */
    int max_leaf;      /* BVH: most triangles per leaf; 0 = the default (4) */
    double grid_density; /* grid: > 0: cells ~ grid_density x triangles instead (rt_grid_density_min) */
} rt_accel_params;

/* Footprint of a built structure, for `scene info` and `render --json`. */
typedef struct rt_accel_info {
    uint64_t nodes;    /* node (or cell) records */
    uint64_t bytes;    /* modeled bytes of the structure (nodes and index lists, not triangles) */
    uint32_t depth;    /* deepest node (0 when it has no depth) */
} rt_accel_info;

typedef struct rt_accel_ops {
    const char *name; /* "kd", "grid", "naive", "bvh2", "bvh4", "bvh8" */
    const char *desc; /* one line */
    unsigned flags;   /* RT_ACCEL_OWN_TRIS */
    /* Builds the structure over sc; NULL with e set on failure. NULL
     * member: nothing to build (the structure is the triangle array). */
    void *(*build)(const rt_scene *sc, const rt_accel_params *p, rt_err *e);
    void (*free)(void *as); /* accepts NULL */
    /* Declares the structure's own regions in L, in a fixed order. 0 or -1. */
    int (*regions)(const void *as, const rt_scene *sc, rt_layout *L, rt_err *e);
    /* Points tv at the structure and its regions in L (tv->sc, rec, L set). */
    void (*trav_init)(rt_trav *tv, const void *as, const rt_layout *L);
    /* Closest hit in (r->tmin, r->tmax): 1 and *h, or 0 with rt_hit_none. */
    int (*closest)(rt_trav *tv, const rt_ray *r, rt_hit *h);
    /* Any hit in (r->tmin, r->tmax): 1 if occluded. */
    int (*occluded)(rt_trav *tv, const rt_ray *r);
    /* Verifies the structure's invariants against sc. 0, or -1 naming the broken one. */
    int (*check)(const void *as, const rt_scene *sc, rt_err *e);
    void (*info)(const void *as, rt_accel_info *inf);
} rt_accel_ops;

/* A built structure of a job. */
typedef struct rt_accel {
    int kind;                 /* rt_accel_kind, never RT_ACCEL_DEFAULT once built */
    const rt_accel_ops *ops;  /* rt_accel_table[kind] */
    void *as;                 /* the structure (rt_kdtree *, rt_grid *, ...), NULL for naive */
    double build_sec;         /* wall time of the build */
} rt_accel;

/* The members, indexed by kind (entry 0, RT_ACCEL_DEFAULT, is NULL). */
extern const rt_accel_ops *const rt_accel_table[RT_ACCEL_NKINDS];

/* Name of a kind ("kd", "grid", ...) or NULL; kind of a name, or -1. */
const char *rt_accel_name(int kind);
int rt_accel_from_name(const char *name);
/* The known names, comma separated ("kd, grid, naive"), for messages. */
const char *rt_accel_names(void);

/* The branching factor of a BVH kind (2, 4, 8), or 0 for the structures
 * that are not BVHs: the one place that knows which kinds are which width. */
int rt_accel_bvh_width(int kind);

/* Builds kind over sc into *a (a->kind, ops, as, build_sec). 0, or -1 with
 * *a zeroed. */
int rt_accel_build(rt_accel *a, int kind, const rt_scene *sc, const rt_accel_params *p, rt_err *e);
/* Wraps a structure built elsewhere (not owned: do not rt_accel_free it
 * unless ownership is handed over). */
void rt_accel_wrap(rt_accel *a, int kind, void *as, double build_sec);
/* Frees what *a holds and zeroes it; accepts NULL and empty. */
void rt_accel_free(rt_accel *a);

/* Shorthands over a->ops. */
int rt_accel_regions(const rt_accel *a, const rt_scene *sc, rt_layout *L, rt_err *e);
void rt_accel_trav(const rt_accel *a, rt_trav *tv, const rt_scene *sc, rt_rec *rec, const rt_layout *L);
int rt_accel_check(const rt_accel *a, const rt_scene *sc, rt_err *e);
void rt_accel_info_of(const rt_accel *a, rt_accel_info *inf);

/* ---- surveys (`scene info`): which structures, built one at a time ---- */

/* A comma list of structure names ("kd,bvh4"), "all" (every member) or
 * "none" into a mask of RT_ACCEL_BIT(kind). 0, or -1 naming the unknown
 * name in e. */
int rt_accel_parse_mask(const char *list, unsigned *mask, rt_err *e);

/* What a survey reports of one structure. */
typedef struct rt_accel_survey_row {
    int kind;            /* rt_accel_kind */
    double build_sec;    /* wall time of its build */
    rt_accel_info info;  /* footprint */
    int has_kd;          /* 1: a k-d tree, the kd_ fields are set */
    uint32_t kd_leaves, kd_empty, kd_entries, kd_max_leaf;
    double kd_mean_leaf; /* mean triangles per non-empty leaf */
} rt_accel_survey_row;

/* Builds each structure of mask over sc, in kind order, one at a time (built,
 * measured and freed before the next: the peak memory is the largest one,
 * not their sum), into rows[0..RT_ACCEL_NKINDS). How many rows, or -1 with
 * "NAME: message" in e. */
int rt_accel_survey(const rt_scene *sc, unsigned mask, const rt_accel_params *p, rt_accel_survey_row *rows, rt_err *e);

#endif
