/*
 * stream.c -- the streaming ray tracer of Purcell et al. (2002) on the
 * uniform grid: `stream-branching` and `stream-multipass`.
 *
 * A ray is a small state machine driven by the paper's kernels (Table 1):
 * the eye-ray generator tests the ray against the grid bounds; traversal
 * setup clips it and finds its first cell; a traversal step reads the cell's
 * grid word and either hands a non-empty cell to intersection or moves on;
 * an intersection tests one listed triangle (list word + 9 vertex words),
 * accepting a hit only inside the current cell (src/grid.h) and, at the end
 * of the list, either ends the ray or hands it back to traversal; shading
 * runs on hits. The walk is exactly rt_grid_closest / rt_grid_any cut into
 * single steps, so hits equal the k-d tree's and images equal every other
 * tracer's (raycast/shadow through rt_shade_pixel, whitted/path through
 * rt_shade_step and rt_acc).
 *
 * stream-branching: one ray at a time from generation to shading (then its
 * shadow rays, then its children depth first), all of its memory operations
 * before the next ray's: the paper's branching architecture.
 *
 * stream-multipass: rays live in screen-sized streams (at most W x H rays,
 * a larger wave is cut into several). Every rendering pass runs one kernel
 * over the whole stream; it reads every ray's 8-bit stencil (the paper's
 * R P C_stencil term) and, with early pixel-kill, only the rays in the
 * kernel's state do anything else. The pass loop is
 *   eye (first wave) | setup (2 passes) |
 *   while (any active) { oracle ? traverse : intersect } |
 *   color | one shadow pass per light | reflected (2) or path (1)
 * and a stream of shadow rays ends with one accumulation pass. The oracle
 * is naive (intersect when any ray needs it) or the threshold oracle
 * (intersect once a fraction F of the active rays need it). --unroll T,I
 * runs up to T steps or I tests per pass with one state read and write;
 * rays that stop mid-pass keep issuing their texel reads unless
 * --unroll-suppress.
 *
 * Memory (docs/purcell.md): grid.cells (one word per cell, class node),
 * grid.lists (one word per list entry, class index), tri.verts (36 B per
 * triangle, class tri), grid.shade (21 words per triangle, class shade:
 * Table 1's color kernel reads 21), mat (whitted/path with materials),
 * stream.state (16 words per stream slot, class stream: a kernel reads its
 * R state words and writes its W as one access each; the writes go to
 * render targets, which the GPU writes without reading, so they are
 * streaming stores, RT_WRITE_STREAM, unless --record-stores
 * write-allocate), stream.stencil (one
 * byte per slot, multipass only, class fb: the stencil plane of the
 * framebuffer), fb (12 B RGB per pixel). Every access is also counted per
 * kernel and per data type, so the statistics need no recorder.
 *
 * Representation. A ray (st_ray) carries the traced rt_ray, its path
 * record (secondary modes), the closest hit so far, the grid iterator and
 * its current cell, the list position while it intersects, its counters
 * and its state. The branching tracer keeps one ray in flight and a stack
 * of the pixel's children (st_vec); the multipass tracer keeps a wave of
 * closest rays in a vector, cut into streams of at most W x H rays whose
 * slot i is record i of stream.state and stream.stencil, the spawned
 * shadow rays and children in two more vectors (the next wave).
 *
 * Invariants (RT_ASSERT where a kernel relies on one; S1-S3 hold for every
 * ray between kernel invocations, S4-S5 between passes, S6 at the end):
 *   S1  state: a ray is in ST_TRAV (its cell c is the iterator's current
 *       cell, c.id < ncells), ST_ISECT (lpos is a list word of c's list,
 *       list[lpos] != RT_GRID_NULL) or ST_DONE, and nothing else; a ray is
 *       finished only when done, except a branching eye ray that missed
 *       the grid's box (finished at once: no step taken, no hit);
 *   S2  closest rays: h is the best hit (the hit rule of accel/hit.h) of
 *       the triangles tested so far whose t lies in the cell they were
 *       tested in (widened by tol); a ray is done with a hit only when no
 *       later cell can hold a closer one (h.t < c.t1 - tol) or the
 *       iterator is exhausted; so the hit is rt_grid_closest's;
 *   S3  shadow rays: occluded implies done; a shadow ray never holds a hit;
 *   S4  streams (multipass): a stream holds n <= W x H rays in slots
 *       0..n-1 (its slots are records of stream.state and stream.stencil);
 *       every pass reads all n stencils and only rays in the kernel's state
 *       work; the traversal loop ends exactly when every ray is done;
 *   S5  generations: a wave's rays share one generation (the recorder's);
 *       the next wave holds only the children of this one; a pixel's
 *       children in the branching tracer are traced depth first,
 *       reflection before refraction, each ray with its shadow rays before
 *       the next ray;
 *   S6  accounting: every byte is charged once to a kernel and once to a
 *       data type, so the sums of kbytes[] and dbytes[] are equal;
 *   S7  simulated cores (ctx->cores, test mode, at every barrier): a pass's
 *       kernel work on slot i of a stream of n is charged by the core
 *       whose chunk holds i (cores.h C4), and nothing of a pass is left
 *       buffered past its barrier (C1-C3).
 *
 * Simulated cores (--cores N, ctx->cores; cores.h): multipass, every
 * pass's n rays in N contiguous chunks of the stream's slots, core k's
 * kernel work on its own, a barrier per pass; branching, the Hilbert
 * order's pixels in N contiguous chunks, the cores stepped a pixel each in
 * turn, the frame one phase. One core is the one-core run exactly.
 */
#include "stream.h"

#include "camera.h"
#include "cores.h"
#include "grid.h"
#include "regions.h"
#include "rt_assert.h"
#include "shade.h"
#include "stats.h"
#include "tracer.h"

#include <inttypes.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ---- Table 1 ------------------------------------------------------------- */

static const rt_stream_cost_row table_mp[RT_SK_N] = {
    {"eye", 28, 0, 5, 0, 0, 1},        {"setup", 38, 11, 12, 0, 1, 0},   {"step", 20, 14, 9, 1, 1, 1},
    {"intersect", 41, 14, 5, 10, 1, 1}, {"color", 36, 10, 3, 21, 1, 0},   {"shadow", 16, 11, 8, 0, 1, 1},
    {"reflected", 26, 11, 9, 9, 1, 1},  {"path", 17, 14, 9, 9, 1, 1},
};
static const rt_stream_cost_row table_br[RT_SK_N] = {
    {"eye", 26, 0, 4, 0, 0, 0},        {"setup", 22, 7, 0, 0, 0, 0},   {"step", 12, 0, 0, 1, 0, 0},
    {"intersect", 36, 0, 0, 10, 0, 0}, {"color", 25, 0, 3, 21, 0, 0},  {"shadow", 10, 0, 0, 0, 0, 0},
    {"reflected", 12, 0, 0, 0, 0, 0},  {"path", 11, 3, 0, 0, 0, 0},
};

const rt_stream_cost_row *rt_stream_table(int multipass) { return multipass ? table_mp : table_br; }

void rt_stream_cost(int multipass, double R, double v, double t, double s, double P, double *instr, double *bytes)
{
    const rt_stream_cost_row *k = rt_stream_table(multipass);
#define KB(i) (4.0 * (k[i].R + k[i].W + k[i].M) + k[i].WS)
    double cr = k[RT_SK_EYE].instr + k[RT_SK_SETUP].instr, br = KB(RT_SK_EYE) + KB(RT_SK_SETUP);
    *instr = R * (cr + v * k[RT_SK_STEP].instr + t * k[RT_SK_ISECT].instr + s * k[RT_SK_COLOR].instr);
    *bytes = R * (br + v * KB(RT_SK_STEP) + t * KB(RT_SK_ISECT) + s * KB(RT_SK_COLOR)) + (multipass ? R * P : 0);
#undef KB
}

/* ---- plan: the option checks; the grid is the job's (accel.h) ---------- */

typedef struct st_plan {
    const rt_grid *g; /* the job's structure */
} st_plan;

static void st_plan_free(void *p) { free(p); }

static int st_plan_make(const rt_tracer_ctx *ctx, void **plan, rt_err *e)
{
    const rt_render_opts *o = ctx->opt;
    *plan = NULL;
    if (o->oracle != RT_ORACLE_NAIVE && o->oracle != RT_ORACLE_THRESHOLD)
        return rt_errf(e, "--oracle: unknown oracle %d", o->oracle);
    if (!(o->oracle_frac > 0) || o->oracle_frac > 1)
        return rt_errf(e, "--oracle-fraction: %g is not in (0, 1]", o->oracle_frac);
    if (o->unroll_t < 1 || o->unroll_i < 1)
        return rt_errf(e, "--unroll: %d,%d: both must be at least 1", o->unroll_t, o->unroll_i);
    if (ctx->acc->kind != RT_ACCEL_GRID || !ctx->acc->as) return rt_errf(e, "stream tracers run on the grid only");
    st_plan *pl = rt_calloc(1, sizeof *pl, e);
    if (!pl) return -1;
    pl->g = ctx->acc->as;
    *plan = pl;
    return 0;
}

/* ---- layout ---------------------------------------------------------------- */

#define ST_STATE_WORDS 16 /* a ray's state record: the largest R or W of Table 1 fits */

static uint64_t st_npix(const rt_render_opts *o) { return (uint64_t)o->W * (uint64_t)o->H; }

static int st_layout(const rt_tracer_ctx *ctx, rt_layout *L, int multipass, rt_err *e)
{
    const st_plan *pl = ctx->plan;
    const rt_grid *g = pl->g;
    uint64_t npix = st_npix(ctx->opt);
    (void)g;
    if (rt_reg_geometry(ctx, L, 0, e) < 0) return -1; /* grid.cells, grid.lists, tri.verts */
    if (rt_mm_add(L, "grid.shade", RT_CLS_SHADE, 4u * (uint32_t)table_mp[RT_SK_COLOR].M, ctx->sc->ntri, e) < 0)
        return -1;
    if (rt_reg_wants_mat(ctx) && rt_mm_add(L, "mat", RT_CLS_SHADE, RT_MAT_RECSIZE, ctx->sc->nmat, e) < 0) return -1;
    if (rt_mm_add(L, "stream.state", RT_CLS_STREAM, 4 * ST_STATE_WORDS, npix, e) < 0) return -1;
    if (multipass && rt_mm_add(L, "stream.stencil", RT_CLS_FB, 1, npix, e) < 0) return -1;
    if (rt_mm_add(L, "fb", RT_CLS_FB, 12, npix, e) < 0) return -1;
    return 0;
}

static int st_layout_br(const rt_tracer_ctx *ctx, rt_layout *L, rt_err *e) { return st_layout(ctx, L, 0, e); }
static int st_layout_mp(const rt_tracer_ctx *ctx, rt_layout *L, rt_err *e) { return st_layout(ctx, L, 1, e); }

/* ---- rays and run state ------------------------------------------------------ */

enum { ST_TRAV, ST_ISECT, ST_DONE };                /* a ray's traversal state */
enum { ST_CLOSEST, ST_SHADOW };                     /* what a ray asks */
enum { ST_PASS_TRAV, ST_PASS_ISECT, ST_PASS_OTHER }; /* Table 2's pass kinds */

typedef struct st_ray {
    rt_ray r;          /* the ray as traced */
    rt_path p;         /* whitted/path: the ray's path record */
    rt_hit h;          /* closest hit so far */
    rt_grid_iter it;   /* DDA state */
    rt_grid_cell c;    /* current cell */
    float tol;         /* in-cell acceptance window (rt_grid_ttol) */
    float lc[3];       /* shadow ray, whitted/path: contribution when unoccluded */
    uint32_t pix;      /* pixel */
    uint32_t lpos;     /* intersecting: list word of the next triangle */
    uint32_t last_tri; /* last triangle tested (unrolled re-reads) */
    uint32_t nstep;    /* traversal steps so far */
    uint32_t ntest;    /* intersection tests so far */
    uint8_t kind;      /* ST_CLOSEST or ST_SHADOW */
    uint8_t state;     /* ST_TRAV, ST_ISECT or ST_DONE */
    uint8_t light;     /* shadow ray: its light (point lights) */
    uint8_t occluded;  /* shadow ray: a blocker was found */
    uint8_t gen;       /* generation (mark bit and recorder) */
    uint8_t primary;   /* eye ray of sample 0 (sets the pixel's depth) */
    uint8_t cidx;      /* multipass child: 0 reflection / path, 1 refraction */
    uint8_t ready;     /* it already holds rt_grid_iter_init of r (the eye kernel's bounds test) */
    uint32_t parent;   /* multipass: stream slot of the ray that spawned it */
    uint32_t alight;   /* shadow ray, a file's own lights: its light */
    uint32_t lslot;    /* ... and its sample's slot among the pixel's (loff[alight] + sample) */
} st_ray;

typedef struct st_vec {
    st_ray *a;
    size_t n, cap;
} st_vec;

typedef struct st_run {
    const rt_tracer_ctx *ctx;
    const rt_grid *g;
    const rt_scene *sc;
    const rt_render_opts *o;
    rt_rec *rec;
    const rt_layout *L;
    int multipass, secondary;
    int wstate;          /* how state words are written: RT_WRITE_STREAM (render targets, default) or 1 */
    int reg_cells, reg_lists, reg_verts, reg_shade, reg_mat, reg_state, reg_stencil, reg_fb;
    rt_image *img;
    rt_cam_frame cam;
    rt_hit *h0;          /* raycast/shadow: each pixel's primary hit */
    uint8_t *vis;        /* raycast/shadow: pixel x light visibility (a file's lights: pixel x sample slot) */
    int authored;        /* the file's own lights (--light-samples; shade.h) */
    uint32_t nslot, *loff; /* authored: sample slots per pixel; light i's first slot */
    float *lw;           /* authored: a pixel's per-light weights while shading */
    rt_acc *acc;         /* whitted/path: each pixel's sum */
    uint8_t *mark;       /* triangles tested (bit 1 primary, 2 shadow, 4 secondary) */
    rt_alpha_at aat;     /* the alpha filter's regions */
    int err;             /* 1: out of memory while spawning; 2: the trace sink failed (simulated cores) */
    /* statistics */
    uint64_t rays[2];    /* closest, shadow rays traced */
    uint64_t rays_eye, rays_sec;
    uint64_t steps, tests, shades;
    uint32_t max_step, max_test;
    uint64_t passes[3];  /* by ST_PASS_* */
    double simd_sum;     /* sum over passes of working / stream rays */
    uint64_t kexec[RT_SK_N];  /* kernel bodies executed (unrolled iterations included) */
    uint64_t kbytes[RT_SK_N]; /* bytes moved per kernel (stencil included) */
    uint64_t dbytes[RT_SD_N]; /* bytes moved per data type */
    uint64_t acc_bytes;  /* shadow accumulation passes' fb traffic (in dbytes fb too) */
    /* simulated cores (ctx->cores; NULL: one processor, today's run): the
     * stream processors, each with a contiguous chunk of a stream's slots
     * (cores.h), a barrier per pass; branching: chunks of the pixels */
    rt_cores *cores;
    int ncores;
    int core;            /* the core whose recorder is current */
    size_t sn;           /* multipass: the rays of the stream whose pass runs (the chunks' n) */
    rt_err cerr;         /* test mode: S7 broken (err 3) */
} st_run;

/* Slot i of a stream of n: its chunk's core records (simulated cores). */
static inline void st_slot(st_run *S, size_t i, size_t n)
{
    if (!S->cores) return;
    S->core = rt_cores_owner(i, n, S->ncores);
    S->sn = n;
    S->rec = rt_cores_rec(S->cores, S->core);
}

/* The generation stamped on every core's references. */
static void st_gen(st_run *S, int g)
{
    if (!S->cores) {
        rt_rec_set_gen(S->rec, g);
        return;
    }
    for (int k = 0; k < S->ncores; k++) rt_rec_set_gen(rt_cores_rec(S->cores, k), g);
}

/* The end of a pass: the stream processors' barrier; in test mode S7,
 * the interleave's C1-C4 (cores.h: every slot's kernel work charged to its
 * chunk's core, nothing buffered past the barrier). */
static void st_pass_end(st_run *S)
{
    if (!S->cores) return;
    if (rt_cores_barrier(S->cores) < 0) S->err = 2;
    if (S->ctx->check && !S->err && rt_cores_check(S->cores, &S->cerr) < 0) S->err = 3;
}

static int vec_push(st_run *S, st_vec *v, const st_ray *r)
{
    if (v->n == v->cap) {
        size_t nc = v->cap ? 2 * v->cap : 1024;
        st_ray *na = realloc(v->a, nc * sizeof *na);
        if (!na) {
            S->err = 1;
            return -1;
        }
        v->a = na;
        v->cap = nc;
    }
    v->a[v->n++] = *r;
    return 0;
}

/* ---- accounting: every access is counted and, when recording, recorded ---- */

static void acc_rd(st_run *S, int kern, int dtype, int reg, uint64_t rec, uint64_t off, uint32_t bytes, int cls, int w)
{
    S->kbytes[kern] += bytes;
    S->dbytes[dtype] += bytes;
    if (S->rec) RT_REC(S->rec, rt_mm_addr(S->L, reg, rec) + off, bytes, w, cls);
}

/* State words of one kernel invocation on slot: R read, W written. The
 * color kernel's W words are the pixel's colour (fb). */
static void charge_state(st_run *S, int kern, uint32_t slot, int R, int W)
{
    if (R) acc_rd(S, kern, RT_SD_STATE, S->reg_state, slot, 0, 4u * (uint32_t)R, RT_CLS_STREAM, 0);
    if (W && kern != RT_SK_COLOR)
        acc_rd(S, kern, RT_SD_STATE, S->reg_state, slot, 0, 4u * (uint32_t)W, RT_CLS_STREAM, S->wstate);
}

/* One kernel invocation on a ray in slot: its state words, its stencil
 * write (multipass) and its instruction count. Texel reads are charged by
 * the kernels themselves. */
static void charge(st_run *S, int kern, uint32_t slot)
{
    const rt_stream_cost_row *k = rt_stream_table(S->multipass) + kern;
    if (S->cores && S->multipass) rt_cores_claim(S->cores, S->core, slot, S->sn); /* S7 */
    S->kexec[kern]++;
    charge_state(S, kern, slot, k->R, k->W);
    if (S->multipass && k->WS) acc_rd(S, kern, RT_SD_STENCIL, S->reg_stencil, slot, 0, 1, RT_CLS_FB, 1);
}

/* ---- the per-ray kernels ------------------------------------------------------ */

static void ray_advance(st_ray *r)
{
    r->state = rt_grid_iter_next(&r->it, &r->c) ? ST_TRAV : ST_DONE;
}

/* Traversal setup: clip to the grid, first cell. An eye ray's iterator
 * was already initialised by the eye kernel's bounds test with the same
 * arguments (rt_grid_iter_init is a pure function of them), so it is not
 * computed twice. */
static void k_setup(st_run *S, st_ray *r)
{
    rt_hit_none(&r->h);
    r->state = ST_DONE;
    if (!r->ready && !rt_grid_iter_init(&r->it, S->g, &r->r, r->r.tmin, r->r.tmax)) return;
    r->ready = 0;
    r->tol = rt_grid_ttol(S->g, &r->r);
    ray_advance(r);
}

/* One traversal step without its texel accounting (k_step charges it). */
static RT_ALWAYS_INLINE void k_step_body(st_run *S, st_ray *r)
{
    RT_ASSERT(r->state == ST_TRAV && r->c.id < S->g->ncells); /* S1 */
    const uint32_t w = S->g->cells[r->c.id];
    r->nstep++;
    S->steps++;
    if (w != RT_GRID_NULL) {
        r->state = ST_ISECT;
        r->lpos = w;
        return;
    }
    if (r->kind == ST_CLOSEST && r->h.tri != RT_NO_HIT && r->h.t < r->c.t1 - r->tol) {
        r->state = ST_DONE;
        return;
    }
    ray_advance(r);
}

/* One traversal step: the grid word of the current cell. */
static void k_step(st_run *S, st_ray *r)
{
    acc_rd(S, RT_SK_STEP, RT_SD_GRID, S->reg_cells, r->c.id, 0, RT_GRID_WORD, RT_CLS_NODE, 0);
    k_step_body(S, r);
}

/* One intersection test without its texel accounting (k_isect charges it). */
static RT_ALWAYS_INLINE void k_isect_body(st_run *S, st_ray *r)
{
    const rt_grid *g = S->g;
    RT_ASSERT(r->state == ST_ISECT && r->lpos < g->nlist && g->list[r->lpos] != RT_GRID_NULL); /* S1 */
    const uint32_t tri = g->list[r->lpos];
    r->ntest++;
    r->last_tri = tri;
    S->tests++;
    S->mark[tri] |= (uint8_t)(r->kind == ST_SHADOW ? 2 : r->gen ? 4 : 1);
    float t, u, v;
    int hit = rt_isect_core(&r->r, &S->sc->tri[tri], &t, &u, &v) && t > r->r.tmin && t < r->r.tmax;
    if (r->kind == ST_SHADOW) {
        if (hit && !rt_alpha_cut(S->sc->alpha, &S->aat, S->rec, &r->r, tri, u, v)) {
            r->occluded = 1;
            r->state = ST_DONE;
            return;
        }
    } else if (hit && t >= r->c.t0 - r->tol && t <= r->c.t1 + r->tol &&
               (t < r->h.t || (t == r->h.t && tri < r->h.tri)) && !rt_alpha_cut(S->sc->alpha, &S->aat, S->rec, &r->r, tri, u, v)) {
        r->h.t = t;
        r->h.tri = tri;
        r->h.u = u;
        r->h.v = v;
    }
    r->lpos++;
    if (g->list[r->lpos] != RT_GRID_NULL) return;
    if (r->kind == ST_CLOSEST && r->h.tri != RT_NO_HIT && r->h.t < r->c.t1 - r->tol) r->state = ST_DONE;
    else ray_advance(r);
}

/* One intersection test: list word, then the triangle's 9 vertex words. */
static void k_isect(st_run *S, st_ray *r)
{
    const uint32_t tri = S->g->list[r->lpos];
    acc_rd(S, RT_SK_ISECT, RT_SD_LIST, S->reg_lists, r->lpos, 0, RT_GRID_WORD, RT_CLS_INDEX, 0);
    acc_rd(S, RT_SK_ISECT, RT_SD_TRI, S->reg_verts, tri, 0, RT_GRID_VERT_BYTES, RT_CLS_TRI, 0);
    k_isect_body(S, r);
}

/* ---- rays in, results out ------------------------------------------------------ */

static void ray_new_closest(st_ray *r, const rt_path *p, uint32_t pix, int primary)
{
    memset(r, 0, sizeof *r);
    r->p = *p;
    rt_shade_path_ray(p, &r->r);
    r->pix = pix;
    r->kind = ST_CLOSEST;
    r->gen = (uint8_t)(p->depth > 255 ? 255 : p->depth);
    r->primary = (uint8_t)primary;
}

static void ray_new_shadow(st_ray *r, const rt_ray *sr, uint32_t pix, int light, int gen, const float *lc)
{
    memset(r, 0, sizeof *r);
    r->r = *sr;
    r->pix = pix;
    r->kind = ST_SHADOW;
    r->light = (uint8_t)light;
    r->gen = (uint8_t)gen;
    if (lc) memcpy(r->lc, lc, sizeof r->lc);
}

static void ray_stats(st_run *S, const st_ray *r)
{
    if (r->nstep > S->max_step) S->max_step = r->nstep;
    if (r->ntest > S->max_test) S->max_test = r->ntest;
    S->img->nodes[r->pix] += (float)r->nstep;
    S->img->tests[r->pix] += (float)r->ntest;
    S->rays[r->kind]++;
}

/* A finished closest ray: the color kernel on a hit, then the shadow rays
 * (shadow kernel) and children (reflected / path kernels) it spawns into
 * shadows and children. slot: the ray's stream slot. In the multipass
 * tracer the kernels are charged by the passes (charge_kernels = 0). */
static void finish_closest(st_run *S, st_ray *r, uint32_t slot, st_vec *shadows, st_vec *children, int charge_kernels)
{
    RT_ASSERT(r->kind == ST_CLOSEST && (r->state == ST_DONE || (r->nstep == 0 && r->h.tri == RT_NO_HIT))); /* S1 */
    const rt_render_opts *o = S->o;
    const int hit = r->h.tri != RT_NO_HIT;
    ray_stats(S, r);
    if (hit) {
        S->shades++;
        if (charge_kernels) charge(S, RT_SK_COLOR, slot);
        acc_rd(S, RT_SK_COLOR, RT_SD_SHADE, S->reg_shade, r->h.tri, 0, 4u * (uint32_t)table_mp[RT_SK_COLOR].M,
               RT_CLS_SHADE, 0);
        if (S->reg_mat >= 0)
            acc_rd(S, RT_SK_COLOR, RT_SD_SHADE, S->reg_mat, S->sc->shade[r->h.tri].mat, 0, RT_MAT_RECSIZE,
                   RT_CLS_SHADE, 0);
        if (S->secondary && !r->primary) /* a later contribution to the pixel: read-modify-write */
            acc_rd(S, RT_SK_COLOR, RT_SD_FB, S->reg_fb, r->pix, 0, 12, RT_CLS_FB, 0);
        acc_rd(S, RT_SK_COLOR, RT_SD_FB, S->reg_fb, r->pix, 0, 12, RT_CLS_FB, 1);
    }
    st_ray n;
    if (!S->secondary) {
        S->h0[r->pix] = r->h;
        if (!hit) return;
        for (uint32_t i = 0; S->authored && i < S->sc->nlight; i++) { /* the file's lights, sample by sample */
            if (!rt_render_light_on(o, i)) continue;
            for (uint32_t k = 0, ns = rt_shade_light_nsamples(S->sc, o, i); k < ns; k++) {
                rt_ray sr;
                float w;
                uint32_t tri;
                if (!rt_shade_sample_ray(S->sc, o, &r->r, &r->h, i, k, &sr, &w, &tri)) continue;
                rt_reg_light(S->ctx, S->rec, i, tri);
                if (charge_kernels) charge(S, RT_SK_SHADOW, slot);
                ray_new_shadow(&n, &sr, r->pix, 0, 0, NULL);
                n.alight = i;
                n.lslot = S->loff[i] + k;
                if (vec_push(S, shadows, &n) < 0) return;
            }
        }
        for (int i = 0; i < RT_NLIGHTS && !S->authored; i++) {
            rt_ray sr;
            if (!(o->lights & (1u << i)) || !rt_shade_ray(S->sc, &r->r, &r->h, i, &sr)) continue;
            if (charge_kernels) charge(S, RT_SK_SHADOW, slot);
            ray_new_shadow(&n, &sr, r->pix, i, 0, NULL);
            if (vec_push(S, shadows, &n) < 0) return;
        }
        return;
    }
    rt_shade_out out;
    if (r->primary) S->h0[r->pix] = r->h;
    rt_shade_step(S->sc, o, &r->p, &r->r, hit ? &r->h : NULL, &out);
    rt_acc_add(&S->acc[r->pix], out.c);
    for (int i = 0; i < RT_NLIGHTS; i++) {
        if (!out.want[i]) continue;
        if (charge_kernels) charge(S, RT_SK_SHADOW, slot);
        ray_new_shadow(&n, &out.sray[i], r->pix, i, r->gen, out.lc[i]);
        if (vec_push(S, shadows, &n) < 0) return;
    }
    for (int c = 0; c < out.nchild; c++) {
        if (charge_kernels) {
            int k = o->mode == RT_MODE_PATH ? RT_SK_PATH : RT_SK_REFL;
            charge(S, k, slot);
            acc_rd(S, k, RT_SD_TRI, S->reg_verts, r->h.tri, 0, RT_GRID_VERT_BYTES, RT_CLS_TRI, 0);
        }
        ray_new_closest(&n, &out.child[c], r->pix, 0);
        if (vec_push(S, children, &n) < 0) return;
    }
}

/* A finished shadow ray: unoccluded, its light counts (the accumulation
 * reads and writes the pixel, charged to the shadow kernel). */
static void finish_shadow(st_run *S, st_ray *r)
{
    RT_ASSERT(r->kind == ST_SHADOW && r->state == ST_DONE && r->h.tri == RT_NO_HIT); /* S1, S3 */
    ray_stats(S, r);
    if (r->occluded) return;
    acc_rd(S, RT_SK_SHADOW, RT_SD_FB, S->reg_fb, r->pix, 0, 12, RT_CLS_FB, 0);
    acc_rd(S, RT_SK_SHADOW, RT_SD_FB, S->reg_fb, r->pix, 0, 12, RT_CLS_FB, 1);
    S->acc_bytes += 24;
    if (S->secondary) rt_acc_add(&S->acc[r->pix], r->lc);
    else if (S->authored) S->vis[(size_t)r->pix * S->nslot + r->lslot] = 1;
    else S->vis[(size_t)r->pix * RT_NLIGHTS + r->light] = 1;
}

/* ---- branching: one ray at a time ----------------------------------------------- */

/* Untraced: the step and intersection kernels' counts are gathered in
 * locals and turned into bytes once per ray. charge() and the kernels'
 * acc_rd add the same fixed amounts per invocation (branching has no
 * stencil), so the totals are the same integers. */
static void br_trace_counted(st_run *S, st_ray *r)
{
    const rt_stream_cost_row *ks = &table_br[RT_SK_STEP], *ki = &table_br[RT_SK_ISECT];
    const uint64_t sb = 4u * (uint64_t)(ks->R + ks->W), ib = 4u * (uint64_t)(ki->R + ki->W);
    uint64_t ns = 0, ni = 0;
    while (r->state != ST_DONE) {
        if (r->state == ST_TRAV) {
            ns++;
            k_step_body(S, r);
        } else {
            ni++;
            k_isect_body(S, r);
        }
    }
    S->kexec[RT_SK_STEP] += ns;
    S->kexec[RT_SK_ISECT] += ni;
    S->kbytes[RT_SK_STEP] += ns * (sb + RT_GRID_WORD);
    S->kbytes[RT_SK_ISECT] += ni * (ib + RT_GRID_WORD + RT_GRID_VERT_BYTES);
    S->dbytes[RT_SD_STATE] += ns * sb + ni * ib;
    S->dbytes[RT_SD_GRID] += ns * RT_GRID_WORD;
    S->dbytes[RT_SD_LIST] += ni * RT_GRID_WORD;
    S->dbytes[RT_SD_TRI] += ni * RT_GRID_VERT_BYTES;
}

static void br_trace(st_run *S, st_ray *r, uint32_t slot)
{
    rt_rec_set_gen(S->rec, r->gen);
    charge(S, RT_SK_SETUP, slot);
    k_setup(S, r);
    if (!S->rec) {
        br_trace_counted(S, r);
        return;
    }
    while (r->state != ST_DONE) {
        if (r->state == ST_TRAV) {
            charge(S, RT_SK_STEP, slot);
            k_step(S, r);
        } else {
            charge(S, RT_SK_ISECT, slot);
            k_isect(S, r);
        }
    }
}

/* Everything of one eye ray: the ray, its shadow rays, its children (depth
 * first, reflection before refraction), each to the end before the next. */
static void br_pixel(st_run *S, uint32_t pix, uint32_t sample, st_vec *stack, st_vec *shadows)
{
    const int W = S->o->W;
    rt_ray eye;
    rt_path p;
    st_ray r;
    rt_cam_ray(&S->cam, (int)(pix % (uint32_t)W), (int)(pix / (uint32_t)W), &eye);
    rt_shade_path_start(&p, &eye, pix, sample);
    ray_new_closest(&r, &p, pix, sample == 0);
    S->rays_eye++;
    rt_rec_set_gen(S->rec, 0);
    charge(S, RT_SK_EYE, pix);
    if (!rt_grid_iter_init(&r.it, S->g, &r.r, r.r.tmin, r.r.tmax)) { /* outside the scene box: done */
        rt_hit_none(&r.h);
        finish_closest(S, &r, pix, shadows, stack, 1);
    } else {
        r.ready = 1; /* the setup kernel reuses the iterator */
        stack->n = 0;
        vec_push(S, stack, &r);
        while (stack->n && !S->err) {
            st_ray cur = stack->a[--stack->n];
            size_t base = stack->n;
            br_trace(S, &cur, pix);
            if (cur.gen) S->rays_sec++;
            shadows->n = 0;
            finish_closest(S, &cur, pix, shadows, stack, 1);
            for (size_t i = 0; i < shadows->n; i++) {
                br_trace(S, &shadows->a[i], pix);
                finish_shadow(S, &shadows->a[i]);
            }
            /* children were pushed reflection first: pop reflection first */
            for (size_t a = base, b = stack->n ? stack->n - 1 : 0; a < b; a++, b--) {
                st_ray t = stack->a[a];
                stack->a[a] = stack->a[b];
                stack->a[b] = t;
            }
        }
    }
    shadows->n = 0;
    rt_rec_set_gen(S->rec, 0);
}

/* ---- multipass: one kernel over the stream per pass -------------------------------- */

/* One pass of kernel kern over n rays: every stencil is read (one access
 * per ray, charged to the pass's kernel); work rays did something. */
static void mp_pass(st_run *S, int kern, int kind, size_t n, size_t work)
{
    S->passes[kind]++;
    S->simd_sum += n ? (double)work / (double)n : 0;
    S->kbytes[kern] += n;
    S->dbytes[RT_SD_STENCIL] += n;
    if (S->rec || S->cores)
        for (size_t i = 0; i < n; i++) {
            st_slot(S, i, n);
            if (S->rec) RT_REC(S->rec, rt_mm_addr(S->L, S->reg_stencil, i), 1, 0, RT_CLS_FB);
        }
}

static int mp_oracle(const st_run *S, size_t ntrav, size_t nisect)
{
    if (!nisect) return 0;
    if (!ntrav) return 1;
    if (S->o->oracle == RT_ORACLE_NAIVE) return 1;
    return (double)nisect >= S->o->oracle_frac * (double)(ntrav + nisect);
}

/* Traverses and intersects one stream (rays in slots 0..n-1) to the end. */
static void mp_loop(st_run *S, st_ray *a, size_t n)
{
    const int T = S->o->unroll_t, I = S->o->unroll_i, sup = S->o->unroll_suppress;
    RT_ASSERT(n <= st_npix(S->o)); /* S4: slots are stream.state records */
    size_t active = 0;
    for (size_t i = 0; i < n; i++)
        if (a[i].state != ST_DONE) active++;
    /* setup: two passes; Table 1's setup words charged on the first */
    mp_pass(S, RT_SK_SETUP, ST_PASS_OTHER, n, active);
    for (size_t i = 0; i < n; i++)
        if (a[i].state != ST_DONE) {
            st_slot(S, i, n);
            charge(S, RT_SK_SETUP, (uint32_t)i);
            k_setup(S, &a[i]);
        }
    st_pass_end(S);
    mp_pass(S, RT_SK_SETUP, ST_PASS_OTHER, n, active);
    st_pass_end(S);
    for (;;) {
        size_t ntrav = 0, nisect = 0;
        for (size_t i = 0; i < n; i++) {
            ntrav += a[i].state == ST_TRAV;
            nisect += a[i].state == ST_ISECT;
        }
        if (!ntrav && !nisect) break; /* S4: every ray done */
        int isect = mp_oracle(S, ntrav, nisect);
        int want = isect ? ST_ISECT : ST_TRAV, kern = isect ? RT_SK_ISECT : RT_SK_STEP, U = isect ? I : T;
        mp_pass(S, kern, isect ? ST_PASS_ISECT : ST_PASS_TRAV, n, isect ? nisect : ntrav);
        for (size_t i = 0; i < n; i++) {
            st_ray *r = &a[i];
            if (r->state != want) continue;
            st_slot(S, i, n);
            /* one state read and write per pass, the body U times */
            charge(S, kern, (uint32_t)i);
            S->kexec[kern] += (uint64_t)(U - 1);
            int u = 0;
            uint32_t last_cell = r->c.id;
            for (; u < U && r->state == want; u++) {
                last_cell = r->c.id;
                if (isect) k_isect(S, r);
                else k_step(S, r);
            }
            if (sup) continue;
            for (; u < U; u++) { /* the unrolled body still reads its texels */
                if (isect) {
                    acc_rd(S, kern, RT_SD_LIST, S->reg_lists, r->lpos ? r->lpos - 1 : 0, 0, RT_GRID_WORD, RT_CLS_INDEX, 0);
                    acc_rd(S, kern, RT_SD_TRI, S->reg_verts, r->last_tri, 0, RT_GRID_VERT_BYTES, RT_CLS_TRI, 0);
                } else {
                    acc_rd(S, kern, RT_SD_GRID, S->reg_cells, last_cell, 0, RT_GRID_WORD, RT_CLS_NODE, 0);
                }
            }
        }
        st_pass_end(S);
    }
}

/* Runs one stream of closest rays (first: it starts with the eye pass),
 * then its shading passes; spawned rays go to shadows and children. */
static void mp_closest(st_run *S, st_ray *a, size_t n, int first, st_vec *shadows, st_vec *children)
{
    const rt_render_opts *o = S->o;
    if (first) {
        mp_pass(S, RT_SK_EYE, ST_PASS_OTHER, n, n);
        for (size_t i = 0; i < n; i++) {
            st_slot(S, i, n);
            charge(S, RT_SK_EYE, (uint32_t)i);
            a[i].state = rt_grid_iter_init(&a[i].it, S->g, &a[i].r, a[i].r.tmin, a[i].r.tmax) ? ST_TRAV : ST_DONE;
            a[i].ready = a[i].state == ST_TRAV; /* the setup kernel reuses the iterator */
            if (a[i].state == ST_DONE) rt_hit_none(&a[i].h);
        }
        st_pass_end(S);
    }
    mp_loop(S, a, n);
    /* shading, pass by pass: color on hits (spawning), then one shadow pass
     * per light, then the children (two reflected passes in whitted, one
     * path pass) */
    size_t nhit = 0, s0 = shadows->n, c0 = children->n;
    for (size_t i = 0; i < n; i++) {
        st_ray *r = &a[i];
        size_t sk = shadows->n, ck = children->n;
        st_slot(S, i, n);
        if (r->gen) S->rays_sec++;
        if (r->h.tri != RT_NO_HIT) charge(S, RT_SK_COLOR, (uint32_t)i);
        finish_closest(S, r, (uint32_t)i, shadows, children, 0);
        nhit += r->h.tri != RT_NO_HIT;
        for (size_t k = sk; k < shadows->n; k++) shadows->a[k].parent = (uint32_t)i;
        for (size_t k = ck; k < children->n; k++) {
            children->a[k].parent = (uint32_t)i;
            children->a[k].cidx = (uint8_t)(k - ck);
        }
    }
    mp_pass(S, RT_SK_COLOR, ST_PASS_OTHER, n, nhit);
    st_pass_end(S);
    for (uint32_t l = 0; S->authored && l < S->sc->nlight; l++) { /* one shadow pass per light of the file */
        if (!rt_render_light_on(o, l)) continue;
        size_t w = 0;
        for (size_t k = s0; k < shadows->n; k++)
            if (shadows->a[k].alight == l) {
                st_slot(S, shadows->a[k].parent, n);
                charge(S, RT_SK_SHADOW, shadows->a[k].parent);
                w++;
            }
        mp_pass(S, RT_SK_SHADOW, ST_PASS_OTHER, n, w);
        st_pass_end(S);
    }
    for (int l = 0; l < RT_NLIGHTS && !S->authored; l++) {
        if (!(o->lights & (1u << l))) continue;
        size_t w = 0;
        for (size_t k = s0; k < shadows->n; k++)
            if (shadows->a[k].light == l) {
                st_slot(S, shadows->a[k].parent, n);
                charge(S, RT_SK_SHADOW, shadows->a[k].parent);
                w++;
            }
        mp_pass(S, RT_SK_SHADOW, ST_PASS_OTHER, n, w);
        st_pass_end(S);
    }
    const int kern = o->mode == RT_MODE_PATH ? RT_SK_PATH : RT_SK_REFL;
    for (int c = 0; c < (o->mode == RT_MODE_WHITTED ? 2 : o->mode == RT_MODE_PATH ? 1 : 0); c++) {
        size_t w = 0;
        for (size_t k = c0; k < children->n; k++) {
            const st_ray *ch = &children->a[k];
            if (ch->cidx != c) continue;
            st_slot(S, ch->parent, n);
            charge(S, kern, ch->parent);
            acc_rd(S, kern, RT_SD_TRI, S->reg_verts, a[ch->parent].h.tri, 0, RT_GRID_VERT_BYTES, RT_CLS_TRI, 0);
            w++;
        }
        mp_pass(S, kern, ST_PASS_OTHER, n, w);
        st_pass_end(S);
    }
}

static void mp_shadow(st_run *S, st_ray *a, size_t n)
{
    size_t nvis = 0;
    for (size_t i = 0; i < n; i++) a[i].state = ST_TRAV;
    mp_loop(S, a, n);
    for (size_t i = 0; i < n; i++) {
        nvis += !a[i].occluded;
        st_slot(S, i, n);
        finish_shadow(S, &a[i]);
    }
    mp_pass(S, RT_SK_SHADOW, ST_PASS_OTHER, n, nvis); /* accumulation */
    st_pass_end(S);
}

/* Waves of closest rays, each followed by its shadow rays, in screen-sized
 * streams. */
static void mp_run(st_run *S, st_vec *wave, size_t cap)
{
    st_vec next = {0}, shadows = {0};
    int first = 1;
    while (wave->n && !S->err) {
        next.n = 0;
        for (size_t b = 0; b < wave->n && !S->err; b += cap) {
            size_t n = wave->n - b < cap ? wave->n - b : cap;
            shadows.n = 0;
            st_gen(S, wave->a[b].gen);
            mp_closest(S, wave->a + b, n, first, &shadows, &next);
            for (size_t c = 0; c < shadows.n; c += cap)
                mp_shadow(S, shadows.a + c, shadows.n - c < cap ? shadows.n - c : cap);
        }
        first = 0;
        st_vec t = *wave;
        *wave = next;
        next = t;
    }
    free(next.a);
    free(shadows.a);
    st_gen(S, 0);
}

/* Branching on cores: core k's chunk of the pixels, one pixel of each core
 * in turn (rt_cores_steps). */
typedef struct br_cores {
    st_run *S;
    const uint32_t *order;
    int spp;
    st_vec *stack, *shadows;
} br_cores;

static int br_core_pixel(void *u, int k, uint64_t i)
{
    br_cores *b = u;
    b->S->core = k;
    b->S->rec = rt_cores_rec(b->S->cores, k);
    for (int s = 0; s < b->spp && !b->S->err; s++) br_pixel(b->S, b->order[i], (uint32_t)s, b->stack, b->shadows);
    return b->S->err;
}

/* ---- the run ---------------------------------------------------------------------- */

static int st_run_common(const rt_tracer_ctx *ctx, rt_image *img, rt_run_stats *st, int multipass, rt_err *e)
{
    const st_plan *pl = ctx->plan;
    const rt_render_opts *o = ctx->opt;
    const rt_scene *sc = ctx->sc;
    const int W = o->W, H = o->H, spp = o->mode == RT_MODE_PATH ? o->spp : 1;
    const size_t npix = (size_t)W * (size_t)H;
    st_run S;
    memset(&S, 0, sizeof S);
    S.ctx = ctx;
    S.g = pl->g;
    S.sc = sc;
    S.o = o;
    S.rec = ctx->rec;
    S.L = ctx->L;
    rt_alpha_at_init(&S.aat, S.L);
    if (ctx->cores) {
        S.cores = ctx->cores;
        S.ncores = ctx->cores->n;
        S.rec = rt_cores_rec(S.cores, 0);
    }
    S.img = img;
    S.multipass = multipass;
    S.secondary = rt_render_secondary(o);
    S.wstate = o->rstores == RT_RSTORES_WRITE_ALLOCATE ? 1 : RT_WRITE_STREAM;
    S.reg_cells = rt_mm_find(S.L, "grid.cells");
    S.reg_lists = rt_mm_find(S.L, "grid.lists");
    S.reg_verts = rt_mm_find(S.L, "tri.verts");
    S.reg_shade = rt_mm_find(S.L, "grid.shade");
    S.reg_mat = rt_mm_find(S.L, "mat");
    S.reg_state = rt_mm_find(S.L, "stream.state");
    S.reg_stencil = rt_mm_find(S.L, "stream.stencil");
    S.reg_fb = rt_mm_find(S.L, "fb");
    rt_cam_setup(&S.cam, sc, W, H);
    uint32_t *order = rt_calloc(npix, sizeof *order, e);
    S.h0 = rt_calloc(npix, sizeof *S.h0, e);
    S.authored = rt_shade_authored(sc, o) && o->lights && !S.secondary;
    if (S.authored && (S.loff = rt_calloc(sc->nlight, sizeof *S.loff, e)))
        for (uint32_t i = 0; i < sc->nlight; i++) {
            S.loff[i] = S.nslot;
            S.nslot += rt_shade_light_nsamples(sc, o, i);
        }
    S.vis = S.authored && !S.loff ? NULL : rt_calloc(npix * (S.authored ? S.nslot : RT_NLIGHTS), 1, e);
    S.acc = S.secondary ? rt_calloc(npix, sizeof *S.acc, e) : NULL;
    S.mark = rt_calloc(sc->ntri ? sc->ntri : 1, 1, e);
    st_vec wave = {0}, stack = {0}, shadows = {0};
    int rc = -1;
    S.lw = S.authored ? rt_calloc(sc->nlight, sizeof *S.lw, e) : NULL;
    if (!order || !S.h0 || !S.vis || (S.secondary && !S.acc) || !S.mark || (S.authored && !S.lw)) goto out;
    size_t nk = rt_pixel_order(o, order);
    for (size_t i = 0; i < npix; i++) rt_hit_none(&S.h0[i]);
    if (!multipass && S.cores) {
        br_cores b = {&S, order, spp, &stack, &shadows};
        if (rt_cores_steps(S.cores, nk, br_core_pixel, &b) && !S.err) S.err = 2;
    } else if (!multipass) {
        for (size_t k = 0; k < nk && !S.err; k++)
            for (int s = 0; s < spp; s++) br_pixel(&S, order[k], (uint32_t)s, &stack, &shadows);
    } else {
        /* the stream is in scanline order (a screen-sized rectangle) */
        uint8_t *kept = rt_calloc(npix, 1, e);
        if (!kept) goto out;
        for (size_t k = 0; k < nk; k++) kept[order[k]] = 1;
        for (int s = 0; s < spp && !S.err; s++)
            for (size_t pix = 0; pix < npix && !S.err; pix++) {
                if (!kept[pix]) continue;
                rt_ray eye;
                rt_path p;
                st_ray r;
                rt_cam_ray(&S.cam, (int)(pix % (size_t)W), (int)(pix / (size_t)W), &eye);
                rt_shade_path_start(&p, &eye, (uint32_t)pix, (uint32_t)s);
                ray_new_closest(&r, &p, (uint32_t)pix, s == 0);
                vec_push(&S, &wave, &r);
                S.rays_eye++;
            }
        free(kept);
        if (!S.err) mp_run(&S, &wave, npix);
    }
    if (S.err) {
        if (S.err == 3) rt_errf(e, "%s S7: %s", multipass ? "stream-multipass" : "stream-branching", S.cerr.msg);
        else rt_errf(e, S.err == 2 ? "trace sink failed" : "out of memory");
        goto out;
    }
    /* the pixels */
    for (size_t k = 0; k < nk; k++) {
        uint32_t pix = order[k];
        rt_ray eye;
        rt_cam_ray(&S.cam, (int)(pix % (uint32_t)W), (int)(pix / (uint32_t)W), &eye);
        const rt_hit *h = S.h0[pix].tri != RT_NO_HIT ? &S.h0[pix] : NULL;
        if (S.secondary) {
            rt_acc_pixel(&S.acc[pix], spp, &eye, h, img, pix);
        } else if (S.authored) { /* the unoccluded samples' weights, summed in light and sample order */
            float *lw = S.lw;
            for (uint32_t i = 0; i < sc->nlight; i++) {
                lw[i] = 0.0f;
                for (uint32_t smp = 0, ns = rt_shade_light_nsamples(sc, o, i); h && smp < ns; smp++) {
                    rt_ray sr;
                    float w;
                    uint32_t tri;
                    if (S.vis[(size_t)pix * S.nslot + S.loff[i] + smp] &&
                        rt_shade_sample_ray(sc, o, &eye, h, i, smp, &sr, &w, &tri))
                        lw[i] += w;
                }
            }
            rt_shade_pixel_lw(sc, o, &eye, h, lw, img, pix);
        } else {
            int vis[RT_NLIGHTS];
            for (int i = 0; i < RT_NLIGHTS; i++) vis[i] = S.vis[(size_t)pix * RT_NLIGHTS + i];
            rt_shade_pixel(sc, &eye, h, vis, o->lights, img, pix);
        }
    }
#if RT_ASSERTS_ON
    {
        uint64_t ksum = 0, dsum = 0;
        for (int k = 0; k < RT_SK_N; k++) ksum += S.kbytes[k];
        for (int d = 0; d < RT_SD_N; d++) dsum += S.dbytes[d];
        RT_ASSERT(ksum == dsum); /* S6 */
    }
#endif
    rt_trav tv;
    memset(&tv, 0, sizeof tv);
    tv.nodes = S.steps;
    tv.tests = S.tests;
    st->rays_primary = S.rays_eye;
    st->rays_shadow = S.rays[ST_SHADOW];
    rt_stats_finish(st, &tv, S.mark, sc->ntri);
    {
        const double R = (double)(S.rays[0] + S.rays[1]);
        const uint64_t P = S.passes[0] + S.passes[1] + S.passes[2];
        uint64_t instr = 0;
        for (int k = 0; k < RT_SK_N; k++) instr += S.kexec[k] * (uint64_t)rt_stream_table(multipass)[k].instr;
        char *x = st->extra;
        size_t n = sizeof st->extra, l = 0;
#define PUT(...) (l += (l < n ? (size_t)snprintf(x + l, n - l, __VA_ARGS__) : 0))
        PUT("grid=%ux%ux%u rays=%.0f v=%.4f t=%.4f s=%.4f", (unsigned)S.g->n[0], (unsigned)S.g->n[1],
            (unsigned)S.g->n[2], R, R ? (double)S.steps / R : 0, R ? (double)S.tests / R : 0,
            R ? (double)S.shades / R : 0);
        if (multipass)
            PUT(" passes=%" PRIu64 " pass_trav=%" PRIu64 " pass_isect=%" PRIu64 " pass_other=%" PRIu64 " simd=%.4f", P,
                S.passes[ST_PASS_TRAV], S.passes[ST_PASS_ISECT], S.passes[ST_PASS_OTHER],
                P ? S.simd_sum / (double)P : 0);
        PUT(" max_trav=%u max_isect=%u instr=%" PRIu64 " kexec=", S.max_step, S.max_test, instr);
        for (int k = 0; k < RT_SK_N; k++) PUT("%s%" PRIu64, k ? "," : "", S.kexec[k]);
        PUT(" kbytes=");
        for (int k = 0; k < RT_SK_N; k++) PUT("%s%" PRIu64, k ? "," : "", S.kbytes[k]);
        PUT(" dbytes=");
        for (int d = 0; d < RT_SD_N; d++) PUT("%s%" PRIu64, d ? "," : "", S.dbytes[d]);
        if (S.secondary) PUT(" rays_secondary=%" PRIu64, S.rays_sec);
        if (S.ncores > 1) PUT(" cores=%d barriers=%" PRIu64, S.ncores, S.cores->phases);
#undef PUT
    }
    rc = 0;
out:
    free(order);
    free(S.h0);
    free(S.vis);
    free(S.loff);
    free(S.lw);
    free(S.acc);
    free(S.mark);
    free(wave.a);
    free(stack.a);
    free(shadows.a);
    return rc;
}

static int st_run_br(const rt_tracer_ctx *ctx, rt_image *img, rt_run_stats *st, rt_err *e)
{
    return st_run_common(ctx, img, st, 0, e);
}
static int st_run_mp(const rt_tracer_ctx *ctx, rt_image *img, rt_run_stats *st, rt_err *e)
{
    return st_run_common(ctx, img, st, 1, e);
}

/* The parameters that differ from their defaults, so a default run's key is
 * just the tracer name; the multipass tracer adds its oracle and unrolling. */
static void st_params(const rt_render_opts *o, char *buf, size_t n, int multipass)
{
    size_t l = 0;
    buf[0] = 0;
    if (o->grid_min) l += (size_t)snprintf(buf + l, n - l, " grid_min=%u", (unsigned)o->grid_min);
    if (o->grid_density > 0 && l < n) l += (size_t)snprintf(buf + l, n - l, " grid_density=%g", o->grid_density);
    if (o->rstores != RT_RSTORES_NON_TEMPORAL && l < n)
        l += (size_t)snprintf(buf + l, n - l, " record_stores=%s", rt_render_rstores_name(o->rstores));
    if (multipass && l < n) {
        if (o->oracle == RT_ORACLE_NAIVE && l < n) l += (size_t)snprintf(buf + l, n - l, " oracle=naive");
        if (o->oracle != RT_ORACLE_NAIVE && o->oracle_frac != 0.2 && l < n)
            l += (size_t)snprintf(buf + l, n - l, " oracle_fraction=%g", o->oracle_frac);
        if ((o->unroll_t != 1 || o->unroll_i != 1) && l < n)
            l += (size_t)snprintf(buf + l, n - l, " unroll=%d,%d", o->unroll_t, o->unroll_i);
        if (o->unroll_suppress && l < n) l += (size_t)snprintf(buf + l, n - l, " unroll_suppress=1");
    }
    if (buf[0]) memmove(buf, buf + 1, strlen(buf));
}
static void st_params_br(const rt_render_opts *o, char *buf, size_t n) { st_params(o, buf, n, 0); }
static void st_params_mp(const rt_render_opts *o, char *buf, size_t n) { st_params(o, buf, n, 1); }

const rt_tracer rt_tracer_stream_branching = {
    .name = "stream-branching",
    .desc = "Purcell et al. 2002, branching architecture: one ray at a time over the uniform grid",
    .modes = RT_TRACER_ALL_MODES,
    .accels = RT_ACCEL_BIT(RT_ACCEL_GRID),
    .accel_default = RT_ACCEL_GRID,
    .opts = RT_OPTG_GRID | RT_OPTG_RECORDS | RT_OPTG_CORES,
    .traits = RT_TR_TEXCACHE | RT_TR_LIGHTS | RT_TR_CORE_PHASES,
    .figures = RT_FIG_PURCELL,
    .params = st_params_br,
    .layout = st_layout_br,
    .run = st_run_br,
    .plan = st_plan_make,
    .plan_free = st_plan_free,
};

const rt_tracer rt_tracer_stream_multipass = {
    .name = "stream-multipass",
    .desc = "Purcell et al. 2002, multipass architecture: one kernel over all rays per pass",
    .modes = RT_TRACER_ALL_MODES,
    .accels = RT_ACCEL_BIT(RT_ACCEL_GRID),
    .accel_default = RT_ACCEL_GRID,
    .opts = RT_OPTG_GRID | RT_OPTG_ORACLE | RT_OPTG_RECORDS | RT_OPTG_CORES,
    .traits = RT_TR_TEXCACHE | RT_TR_MULTIPASS | RT_TR_LIGHTS | RT_TR_CORE_PHASES,
    .figures = RT_FIG_PURCELL | RT_FIG_FEEDBACK,
    .params = st_params_mp,
    .layout = st_layout_mp,
    .run = st_run_mp,
    .plan = st_plan_make,
    .plan_free = st_plan_free,
};
