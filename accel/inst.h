/*
 * inst.h -- true instancing: the two-level BVH (accel kind "inst"; inst.c
 * states the layout and its invariants).
 */
#ifndef RT_INST_H
#define RT_INST_H

#include "bvh.h" /* rt_bvh2_node */
#include "hit.h"
#include "rt.h"
#include "scene.h"

#include <stdint.h>

#define RT_INST_RECSIZE 64 /* modeled instance record: world-to-object 3x4 floats, tree, first triangle */

/* One bottom-level tree: its nodes and records in the shared arrays. */
typedef struct rt_inst_blas {
    uint32_t node0, nnode; /* nodes bnode[node0 .. node0 + nnode), root node0 */
    uint32_t tri0, ntri;   /* records btri[tri0 .. tri0 + ntri) */
    int used;              /* built (an object no instance record names is not) */
} rt_inst_blas;

/* One instance (host copy; modeled as RT_INST_RECSIZE bytes). */
typedef struct rt_inst_rec {
    uint32_t blas;      /* its bottom-level tree */
    uint32_t first;     /* its first scene triangle (the loose tree: 0, through covered[]) */
    int identity;       /* the loose triangles' instance: no transformation */
    double o2w[3][4];   /* object-to-world */
    double w2o[3][4];   /* world-to-object (the inverse) */
} rt_inst_rec;

typedef struct rt_inst {
    rt_bvh2_node *tnode; /* top level, depth-first; leaves index torder */
    uint32_t ntnode;
    uint32_t *torder;    /* top-level leaf entries: instance indices */
    rt_inst_rec *inst;
    uint32_t ninst;
    rt_inst_blas *blas;  /* one per scene object, then the loose tree (index sc->nobj) */
    uint32_t nblas;
    rt_bvh2_node *bnode; /* all bottom-level nodes; leaves index btri */
    uint32_t nbnode;
    rt_tri *btri;        /* shared triangle records in leaf order (object space) */
    uint32_t *bref;      /* per record: its triangle's index within its object (loose: into covered) */
    uint32_t nbtri;
    uint32_t *covered;   /* the loose triangles' scene indices, ascending */
    uint32_t nloose;
} rt_inst;

/* Builds the structure from the scene's instance records (a scene without
 * any is one loose tree under one identity instance). NULL with e set. */
rt_inst *rt_inst_build(const rt_scene *sc, rt_err *e);
void rt_inst_free(rt_inst *I); /* accepts NULL */
/* Verifies (I1)..(I6) of inst.c against sc: 0, or -1 naming the broken one. */
int rt_inst_check(const rt_inst *I, const rt_scene *sc, rt_err *e);

/* One step of the single-ray walk (inst_closest / inst_occluded) at
 * top-level node cur, for tracers that keep the top-level stack
 * themselves (the treelet tracer): the node is visited (counted in
 * tv->nodes, recorded as tlas); if the world ray r meets its box within
 * best->t, an interior node gives its children in walk order (kid[0]
 * next, kid[1] below it on the stack: returns 2), a leaf enters each of
 * its instances (record read, ray transformed, the shared tree walked to
 * completion, as the single walk does) improving *best, or (any) stopping
 * at the first occluder; *found is set when a hit was taken. Returns 0
 * for a leaf or a missed box. The tv must be the structure's (tv->as). */
int rt_inst_visit(rt_trav *tv, const rt_ray *r, uint32_t cur, rt_hit *best, int any, int *found, uint32_t kid[2]);

/* Packets (the packet tracer; inst.c states the discipline): a walker for
 * packets of at most np rays; NULL with e set. */
typedef struct rt_inst_pk rt_inst_pk;
rt_inst_pk *rt_inst_pk_new(const rt_inst *I, int np, rt_err *e);
void rt_inst_pk_free(rt_inst_pk *k); /* accepts NULL */
/* Traces the rays ray[idx[0..n)] (slots < np, world space) through both
 * levels: closest hits into hit[] (slots start with tri RT_NO_HIT or a
 * hit to beat), or (shadow) done[slot] = 1 for occluded rays (slots
 * already done are skipped). Counts visits and tests in tv (recording
 * through tv->rec, marking tv->mark) and per slot in pnodes/ptests
 * (NULL: not kept). */
void rt_inst_pk_trace(rt_inst_pk *k, rt_trav *tv, const rt_ray *ray, rt_hit *hit, uint8_t *done, int shadow,
                      float *pnodes, float *ptests, const uint16_t *idx, int n);

#endif
