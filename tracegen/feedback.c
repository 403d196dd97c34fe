/*
 * feedback.c -- the feedback tracer (Ralovich and Magdics 2009, "Recursive
 * ray tracing in geometry shader"; see feedback.h for the record and the
 * buffer size, docs/feedback.md for every modeling choice).
 *
 * Rays are point primitives in one of two ping-pong vertex buffers. The
 * primary rays fill buffer 0 in rasterisation order (row by row). A pass
 * runs the three stages over the input buffer in its order:
 *   vertex stage    reads the 64-byte record, tests the scene's bounding
 *                   box and intersects through the uniform grid (3D-DDA,
 *                   the paper's Figure 4 textures) or every triangle
 *                   (--accel naive), and hands the hit record on;
 *   geometry stage  drops records already written to the framebuffer and
 *                   finished rays, and appends to the other buffer, in the
 *                   fixed order input ray (passed through to be shaded),
 *                   shadow rays (light order), reflected ray, refracted ray
 *                   (stream-out: sequential writes of whole 64-byte
 *                   records, recorded as streaming stores, RT_WRITE_STREAM,
 *                   unless --record-stores write-allocate);
 *   fragment stage  shades the passed-through rays with the one shading
 *                   model (shade.h) and blends them into the framebuffer in
 *                   buffer order.
 * Then the buffers swap. A pass runs while the input holds a ray to trace,
 * so the number of passes is the recursion depth (plus one for the last
 * generation's shadow rays).
 *
 * Compositing. The paper's Equation 1, out = src + alpha dst, with alpha 1
 * for eye and reflected rays and 0 for an occluded shadow ray, whose src
 * is then the hit's colour without that light (the paper writes black: its
 * shading has no ambient term). That replacement is right only while the
 * eye ray's colour is all the pixel holds, i.e. for one light; the shadow
 * rays of reflected hits come after the reflection was added, so they use
 * the paper's other option (float blending without clamping, its footnote):
 * alpha 1 and src = minus the light's term. Equation 1 therefore serves
 * one light and depth <= 2 (composite=eq1). Otherwise ray generations go
 * to separate render targets, blended additively and summed by a final
 * blending pass: in shadow mode one float target for the ambient colour
 * and one per light, summed in light order (the recursive tracer's float
 * order, so bit-identical); in whitted mode one 32.32 fixed-point target
 * per generation (rt_acc: order-independent, bit-identical).
 *
 * Invariants (checked every pass; ctx->check adds the per-pixel one):
 *   F1 a buffer never holds more than its capacity W H (G + G') records;
 *   F2 a pass appends at most E[k-1] + E[k] records per pixel;
 *   F3 every record read is either traced or dropped, none twice;
 *   F4 simulated cores (ctx->cores, test mode, at every barrier): record i
 *      of a pass's n is read by the core whose chunk holds it (cores.h C4:
 *      records floor(k n / N) .. floor((k + 1) n / N) - 1 on core k), and
 *      nothing of a pass is left buffered past its barrier (C1-C3).
 */
#include "feedback.h"

#include "camera.h"
#include "cores.h"
#include "grid.h"
#include "shade.h"

#include <inttypes.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ---- records ---------------------------------------------------------------- */

static void put_u(float *lane, uint32_t u) { memcpy(lane, &u, 4); }
static uint32_t get_u(const float *lane)
{
    uint32_t u;
    memcpy(&u, lane, 4);
    return u;
}

void rt_fb_pack(const rt_fb_ray *r, rt_fb_rec *out)
{
    memset(out, 0, sizeof *out);
    put_u(&out->pos[0], r->pix);
    for (int k = 0; k < 3; k++) out->pos[1 + k] = r->w[k];
    out->orig_t[0] = r->o.x, out->orig_t[1] = r->o.y, out->orig_t[2] = r->o.z, out->orig_t[3] = r->t;
    out->dir_idx[0] = r->d.x, out->dir_idx[1] = r->d.y, out->dir_idx[2] = r->d.z;
    put_u(&out->dir_idx[3], r->tri);
    if (r->type == RT_FB_SHADOW) {
        put_u(&out->uv_state[0], r->light);
    } else {
        out->uv_state[0] = r->u;
        out->uv_state[1] = r->v;
    }
    uint32_t s = (uint32_t)(r->state & 3u) | (uint32_t)(r->type & 3u) << 2 | (uint32_t)(r->gen & 127u) << 4 |
                 (uint32_t)(r->nmed & 7u) << 11;
    put_u(&out->uv_state[2], s);
    put_u(&out->uv_state[3], (uint32_t)r->med[0] | (uint32_t)r->med[1] << 8 | (uint32_t)r->med[2] << 16 |
                                 (uint32_t)r->med[3] << 24);
}

void rt_fb_unpack(const rt_fb_rec *in, rt_fb_ray *r)
{
    memset(r, 0, sizeof *r);
    r->pix = get_u(&in->pos[0]);
    for (int k = 0; k < 3; k++) r->w[k] = in->pos[1 + k];
    r->o = rt_v3(in->orig_t[0], in->orig_t[1], in->orig_t[2]);
    r->t = in->orig_t[3];
    r->d = rt_v3(in->dir_idx[0], in->dir_idx[1], in->dir_idx[2]);
    r->tri = get_u(&in->dir_idx[3]);
    uint32_t s = get_u(&in->uv_state[2]), m = get_u(&in->uv_state[3]);
    r->state = (uint8_t)(s & 3u);
    r->type = (uint8_t)(s >> 2 & 3u);
    r->gen = (uint8_t)(s >> 4 & 127u);
    r->nmed = (uint8_t)(s >> 11 & 7u);
    for (int k = 0; k < 4; k++) r->med[k] = (uint8_t)(m >> (8 * k));
    if (r->type == RT_FB_SHADOW) {
        r->light = get_u(&in->uv_state[0]);
    } else {
        r->u = in->uv_state[0];
        r->v = in->uv_state[1];
    }
}

/* ---- buffer size -------------------------------------------------------------- */

static int nlights(const rt_render_opts *o)
{
    if (rt_render_mode(o) == RT_MODE_RAYCAST) return 0;
    int n = 0;
    for (int i = 0; i < RT_NLIGHTS; i++) n += (o->lights >> i) & 1u;
    return n;
}

/* A file's own lights (--light-samples, shadow mode; shade.h): one target
 * per enabled light, which sums its unoccluded samples' weights. */
static int authored(const rt_scene *sc, const rt_render_opts *o)
{
    return rt_shade_authored(sc, o) && o->lights && rt_render_mode(o) == RT_MODE_SHADOW;
}

/* Shadow rays one hit casts at most: a record per enabled light, or with a
 * file's own lights per enabled light and sample. */
static int nshadow(const rt_scene *sc, const rt_render_opts *o)
{
    if (!authored(sc, o)) return nlights(o);
    int n = 0;
    for (uint32_t i = 0; i < sc->nlight; i++)
        if (rt_render_light_on(o, i)) n += (int)rt_shade_light_nsamples(sc, o, i);
    return n;
}

/* Enabled lights of a file's own (their targets). */
static int nlit(const rt_scene *sc, const rt_render_opts *o)
{
    int n = 0;
    for (uint32_t i = 0; i < sc->nlight; i++) n += rt_render_light_on(o, i);
    return n;
}

/* Most children one hit spawns: 2 for a material with mirror and
 * transmission terms, 1 for one of them (a total internal reflection
 * replaces the refraction), over the materials triangles use. */
static int branching(const rt_scene *sc)
{
    int b = 0;
    for (uint32_t i = 0; i < sc->ntri && b < 2; i++) {
        uint32_t m = sc->shade[i].mat;
        if (m >= sc->nmat) continue;
        int nb = (sc->mat[m].flags & RT_MAT_SPECULAR ? 1 : 0) + (sc->mat[m].flags & RT_MAT_TRANSMIT ? 1 : 0);
        if (nb > b) b = nb;
    }
    return b;
}

#define REFUSED "S_VB: "

int rt_fb_size(const rt_scene *sc, const rt_render_opts *o, rt_fb_sizes *z, rt_err *e)
{
    memset(z, 0, sizeof *z);
    const int mode = rt_render_mode(o), L = nshadow(sc, o), D = mode == RT_MODE_WHITTED ? o->depth : 1;
    z->branching = mode == RT_MODE_WHITTED ? branching(sc) : 0;
    const double b = z->branching;
    double s = 1.0; /* secondary rays per pixel in generation k-1 */
    z->E[0] = 1.0;
    for (int k = 1; k <= D; k++) {
        z->E[k] = L * s + (k < D ? s * b : 0.0);
        s *= b;
    }
    z->ndepth = D + 1;
    while (z->ndepth > 1 && z->E[z->ndepth - 1] == 0.0) z->ndepth--;
    z->passes = z->ndepth;
    for (int k = 0; k < z->ndepth; k++) {
        if (z->E[k] > z->G) {
            z->G2 = z->G;
            z->G = z->E[k];
        } else if (z->E[k] > z->G2) {
            z->G2 = z->E[k];
        }
    }
    z->svb = (double)o->W * (double)o->H * (z->G + z->G2) * RT_FB_REC_SIZE;
    z->limit = o->vb_size ? o->vb_size : RT_FB_VB_DEFAULT;
    if (z->svb > (double)z->limit)
        return rt_errf_usage(e,
                       REFUSED "a vertex buffer would need %.0f bytes (%d x %d pixels x (G %.0f + G' %.0f) x 64 B, "
                               "depth %d, %d light(s), branching %d), more than the limit of %" PRIu64
                               " bytes (--vb-size)",
                       z->svb, o->W, o->H, z->G, z->G2, D, L, z->branching, z->limit);
    return 0;
}

int rt_fb_refused(const rt_err *e) { return e && e->usage && !strncmp(e->msg, REFUSED, strlen(REFUSED)); }

/* ---- heat map ------------------------------------------------------------------ */

void rt_fb_heatmap(const rt_image *img, uint32_t ntri, unsigned char *rgb)
{
    static const float ramp[4][3] = {{0, 0, 255}, {0, 200, 0}, {255, 230, 0}, {230, 0, 0}};
    const double top = log1p(4.0 * (double)(ntri ? ntri : 1));
    const size_t n = (size_t)img->W * (size_t)img->H;
    for (size_t i = 0; i < n; i++) {
        double t = log1p(fmax(0.0, (double)img->tests[i])) / top;
        t = t < 0 ? 0 : t > 1 ? 1 : t;
        double x = t * 3.0;
        int a = x >= 3.0 ? 2 : (int)x;
        double f = x - a;
        for (int k = 0; k < 3; k++)
            rgb[3 * i + k] = (unsigned char)lrint(ramp[a][k] + f * (ramp[a + 1][k] - ramp[a][k]));
    }
}

/* ---- plan and layout ------------------------------------------------------------- */

enum { COMP_EQ1 = 0, COMP_LIGHTS = 1, COMP_GENS = 2 };
static const char *const comp_names[] = {"eq1", "mrt-lights", "mrt-generations"};

typedef struct fb_plan {
    const rt_grid *grid; /* the job's grid; NULL with --accel naive */
    rt_bounds box;   /* scene bounds, enlarged: the vertex stage's box test */
    rt_fb_sizes z;   /* buffer sizes */
    uint64_t cap;    /* records per buffer = W H (G + G') */
    int comp;        /* COMP_* */
    int ntarget;     /* render targets */
    uint32_t texel;  /* bytes per framebuffer texel: 12 (float RGB) or 24 (fixed point) */
} fb_plan;

static void fb_plan_free(void *p)
{
    fb_plan *pl = p;
    if (!pl) return;
    free(pl);
}

static int fb_plan_make(const rt_tracer_ctx *ctx, void **out, rt_err *e)
{
    const rt_scene *sc = ctx->sc;
    const rt_render_opts *o = ctx->opt;
    *out = NULL;
    fb_plan *pl = rt_calloc(1, sizeof *pl, e);
    if (!pl) return -1;
    if (rt_fb_size(sc, o, &pl->z, e) < 0) goto fail;
    if (pl->z.branching == 2 && sc->nmat > 256) {
        rt_errf(e, "feedback: %u materials: a record holds dielectric media as 8-bit indices (at most 256)", sc->nmat);
        goto fail;
    }
    pl->cap = (uint64_t)o->W * (uint64_t)o->H * (uint64_t)(pl->z.G + pl->z.G2);
    const int mode = rt_render_mode(o), L = nlights(o);
    if (mode == RT_MODE_WHITTED) {
        pl->comp = L <= 1 && o->depth <= 2 ? COMP_EQ1 : COMP_GENS;
        pl->ntarget = pl->comp == COMP_EQ1 ? 1 : o->depth;
    } else if (authored(sc, o)) { /* a target per light of the file, summing its samples' weights */
        pl->comp = COMP_LIGHTS;
        pl->ntarget = 1 + nlit(sc, o);
    } else {
        pl->comp = L <= 1 ? COMP_EQ1 : COMP_LIGHTS;
        pl->ntarget = pl->comp == COMP_EQ1 ? 1 : 1 + L;
    }
    pl->texel = pl->comp == COMP_GENS ? 24 : 12;
    /* the box test is conservative: enlarged by 1e-4 of the extent plus
     * an absolute 1e-30, so rounding never rejects a ray that hits */
    rt_bounds b = sc->bounds;
    float ext = fmaxf(b.hi.x - b.lo.x, fmaxf(b.hi.y - b.lo.y, b.hi.z - b.lo.z));
    float pad = 1e-4f * ext + 1e-4f * fmaxf(fmaxf(fabsf(b.lo.x), fabsf(b.hi.x)),
                                            fmaxf(fmaxf(fabsf(b.lo.y), fabsf(b.hi.y)),
                                                  fmaxf(fabsf(b.lo.z), fabsf(b.hi.z)))) + 1e-30f;
    pl->box.lo = rt_sub(b.lo, rt_v3(pad, pad, pad));
    pl->box.hi = rt_add(b.hi, rt_v3(pad, pad, pad));
    if (ctx->acc->kind == RT_ACCEL_GRID) pl->grid = ctx->acc->as;
    *out = pl;
    return 0;
fail:
    fb_plan_free(pl);
    return -1;
}

/* Regions: the scene textures, the two vertex buffers, the framebuffer.
 * grid, list, tri reuse the node, index and tri classes; the buffers are
 * stream class; vb.read is the buffer the primary rays fill (read in odd
 * passes), vb.write the first pass's stream-out target. */
static int fb_layout(const rt_tracer_ctx *ctx, rt_layout *L, rt_err *e)
{
    const fb_plan *pl = ctx->plan;
    const uint64_t npix = (uint64_t)ctx->opt->W * (uint64_t)ctx->opt->H, ntri = ctx->sc->ntri ? ctx->sc->ntri : 1;
    if (!pl) return rt_errf(e, "feedback: no plan");
    if (pl->grid) {
        if (rt_mm_add(L, "grid", RT_CLS_NODE, RT_GRID_WORD, pl->grid->ncells, e) < 0) return -1;
        if (rt_mm_add(L, "list", RT_CLS_INDEX, RT_GRID_WORD, pl->grid->nlist ? pl->grid->nlist : 1, e) < 0) return -1;
    }
    if (rt_mm_add(L, "tri", RT_CLS_TRI, 16, 8 * ntri, e) < 0) return -1;
    if (rt_alpha_regions(L, ctx->sc->alpha, e) < 0) return -1;
    if (rt_mm_add(L, "vb.read", RT_CLS_STREAM, RT_FB_REC_SIZE, pl->cap, e) < 0) return -1;
    if (rt_mm_add(L, "vb.write", RT_CLS_STREAM, RT_FB_REC_SIZE, pl->cap, e) < 0) return -1;
    if (rt_mm_add(L, "fb", RT_CLS_FB, pl->texel, npix * (uint64_t)pl->ntarget, e) < 0) return -1;
    return 0;
}

/* ---- a run ------------------------------------------------------------------------ */

/* Per-operation costs, in GPU instructions counted as Purcell et al.'s
 * Table 1 counts them (one vector instruction = 1, one texture fetch = 1,
 * fixed-function blending = 0) over the paper's shaders (Listings 3-5,
 * docs/feedback.md "The stage shares" shows every count). They give the
 * modeled_share_* statistics: a model, not a measurement.
 * Vertex stage (Listing 3): */
#define COST_VS_RECORD 15 /* inVS: 4 attribute moves, 2 float->int; 2 state branches; outVS: 7 moves */
#define COST_VS_BOX 16    /* slab test: 3 RCP, 2 x (ADD, MUL), 2 MIN/MAX, 2 x 2 component max/min, 1 compare */
#define COST_VS_STEP 14   /* DDA step: 3 compares, 3 selects, 2 index, 2 tMax, 1 grid fetch, 1 empty test, 2 bounds */
#define COST_VS_LIST 1    /* one list texel fetch */
#define COST_VS_TEST 28   /* 3 vertex fetches; Moller-Trumbore: 2 edges, 2 crosses (2 each), 4 DP3, 1 RCP, 3 MUL, 1 SUB; 5 range compares, 3 hit-update selects, 2 loop */
/* Geometry stage (Listing 4): */
#define COST_GS_RECORD 8  /* inGS: 6 unpack; the state and the hit tests */
#define COST_GS_EMIT 8    /* one EmitVertex: 7 output moves and the emit */
#define COST_GS_RAY 14    /* one child ray: normal fetch and index (4), hit point (2 MAD), to-light or reflect, length (DP3, RSQ, MUL), normalise, state and type (2) */
/* Fragment stage (Listing 5): every record the geometry stage emits is a
 * point the rasteriser turns into one fragment, which unpacks and tests
 * its state (most are discarded); a shaded one adds the Phong term. */
#define COST_FS_FRAGMENT 10 /* 6 unpack, 2 state and 2 type branches */
#define COST_FS_SHADE 16    /* hit point (MAD), light vector, normal fetch (4), normalise (3), N.L and MAX, colour fetch (3), MUL, output */
#define COST_FS_BLEND 0     /* blending is fixed-function (Equation 1): no shader instruction */
#define COST_FS_FINAL 2     /* the final blending pass: one target fetch and one ADD per term */

typedef struct fb_stats {
    uint64_t vs_records, vs_box, vs_box_out, vs_steps, vs_list, vs_tests;
    uint64_t gs_records, gs_emitted, gs_drop_written, gs_drop_done, gs_rays;
    uint64_t fs_shaded, fs_blends, fs_final; /* fs_final: the final pass's terms (in fs_blends too) */
    uint64_t eye, shadow, secondary;
    uint64_t in[RT_DEPTH_MAX + 2], out[RT_DEPTH_MAX + 2];
    int passes;
} fb_stats;

typedef struct fb_run {
    const rt_tracer_ctx *ctx;
    const rt_scene *sc;
    const rt_render_opts *o;
    const fb_plan *pl;
    rt_rec *rec;
    const rt_layout *L;
    int reg_grid, reg_list, reg_tri, reg_vb[2], reg_fb;
    int mode, light[RT_NLIGHTS], nl;
    int authored;        /* a file's own lights: targets 1.. hold each enabled light's summed sample weights */
    int *arank;          /* authored: target - 1 of light i (-1: off) */
    uint32_t *htri;      /* authored: each pixel's primary hit triangle (RT_NO_HIT: none) */
    int mats;            /* whitted on a scene with materials: the tex1 material slices are read */
    size_t npix;
    float *ft;           /* float targets, ntarget x npix x 3 */
    rt_acc *at;          /* fixed-point targets, ntarget x npix */
    rt_image *img;
    uint8_t *mark;       /* triangles tested: bit 1 by eye rays, 2 by others */
    rt_fb_rec *vb[2];    /* the two buffers (grown on demand up to cap) */
    uint64_t n[2], alloc[2];
    uint32_t *perpix;    /* check mode: records appended per pixel this pass */
    rt_alpha_at aat;     /* the alpha filter's regions */
    fb_stats s;
    /* simulated cores (ctx->cores; NULL: one processor, today's run): a
     * pass's input records in contiguous chunks (cores.h), a barrier per
     * pass; the stream-out keeps the input order, so core k's records go
     * where one processor puts them */
    rt_cores *cores;
    int ncores;
    int core;            /* the core whose recorder is current */
} fb_run;

/* Item i of n (a record of the pass's input, a pixel): its chunk's core
 * records (simulated cores). */
static inline void fb_item(fb_run *R, uint64_t i, uint64_t n)
{
    if (!R->cores) return;
    R->core = rt_cores_owner(i, n, R->ncores);
    R->rec = rt_cores_rec(R->cores, R->core);
}

/* The end of a pass: the barrier; in test mode F4 (the cores' C1-C4:
 * every record read by its chunk's core, nothing buffered past the
 * barrier). 0, or -1 with e (the trace sink failed, F4 broken). */
static int fb_pass_end(fb_run *R, rt_err *e)
{
    if (!R->cores) return 0;
    if (rt_cores_barrier(R->cores) < 0) return rt_errf(e, "trace sink failed");
    rt_err ce = {0};
    if (R->ctx->check && rt_cores_check(R->cores, &ce) < 0) return rt_errf(e, "feedback: F4: %s", ce.msg);
    return 0;
}

/* Modeled address of texel (texture tex, slice z) of triangle tri: a 3D
 * texture stores slice after slice, so a triangle's texels share (x, y)
 * but lie ntri texels apart. */
static uint64_t texel(const fb_run *R, int tex, int z, uint32_t tri)
{
    return rt_mm_addr(R->L, R->reg_tri, (uint64_t)(tex * 4 + z) * R->sc->ntri + tri);
}

static void rec_verts(fb_run *R, uint32_t tri)
{
    if (!R->rec) return;
    for (int z = 0; z < 3; z++) RT_REC(R->rec, texel(R, 0, z, tri), 16, 0, RT_CLS_TRI);
}

/* Shading reads: the normal, the albedo and, with materials, ks, kt, ke. */
static void rec_shading(fb_run *R, uint32_t tri, int children)
{
    if (!R->rec) return;
    RT_REC(R->rec, texel(R, 0, 3, tri), 16, 0, RT_CLS_TRI);
    if (!children) {
        RT_REC(R->rec, texel(R, 1, 0, tri), 16, 0, RT_CLS_SHADE);
        if (R->mats) RT_REC(R->rec, texel(R, 1, 3, tri), 16, 0, RT_CLS_SHADE);
    } else if (R->mats) {
        RT_REC(R->rec, texel(R, 1, 1, tri), 16, 0, RT_CLS_SHADE);
        RT_REC(R->rec, texel(R, 1, 2, tri), 16, 0, RT_CLS_SHADE);
    }
}

static void count_test(fb_run *R, uint32_t tri, int eye)
{
    R->s.vs_tests++;
    R->mark[tri] |= (uint8_t)(eye ? 1 : 2);
    rec_verts(R, tri);
}

/* Slab test against the enlarged scene box. */
static int box_hit(const rt_bounds *b, const rt_ray *r)
{
    const float o[3] = {r->o.x, r->o.y, r->o.z}, d[3] = {r->d.x, r->d.y, r->d.z};
    const float lo[3] = {b->lo.x, b->lo.y, b->lo.z}, hi[3] = {b->hi.x, b->hi.y, b->hi.z};
    float t0 = r->tmin, t1 = r->tmax;
    for (int k = 0; k < 3; k++) {
        if (d[k] == 0.0f) {
            if (!(o[k] >= lo[k] && o[k] <= hi[k])) return 0;
            continue;
        }
        float a = (lo[k] - o[k]) / d[k], c = (hi[k] - o[k]) / d[k];
        if (a > c) {
            float x = a;
            a = c;
            c = x;
        }
        t0 = fmaxf(t0, a);
        t1 = fminf(t1, c);
    }
    return t0 <= t1;
}

/* The vertex stage's intersection: closest hit (any = 0) or any hit in
 * (tmin, tmax), through the grid or over every triangle; exactly the hits
 * of rt_grid_closest / rt_grid_any / rt_brute_closest (all equal to the
 * k-d tree's). Records the texel reads. Returns 1 on a hit. */
static int intersect(fb_run *R, const rt_ray *r, rt_hit *h, int any, int eye, uint32_t pix)
{
    const rt_scene *sc = R->sc;
    const rt_grid *g = R->pl->grid;
    uint64_t steps0 = R->s.vs_steps, tests0 = R->s.vs_tests;
    int found = 0;
    rt_hit_none(h);
    R->s.vs_box++;
    if (g) {
        rt_grid_iter it;
        rt_grid_cell c;
        if (!rt_grid_iter_init(&it, g, r, r->tmin, r->tmax)) { /* the box test */
            R->s.vs_box_out++;
            return 0;
        }
        const float tol = rt_grid_ttol(g, r);
        while (rt_grid_iter_next(&it, &c)) {
            R->s.vs_steps++;
            RT_REC(R->rec, rt_mm_addr(R->L, R->reg_grid, c.id), RT_GRID_WORD, 0, RT_CLS_NODE);
            const uint32_t w = g->cells[c.id];
            if (w == RT_GRID_NULL) continue;
            if (any) {
                const uint32_t *p = g->list + w;
                for (; *p != RT_GRID_NULL && !found; p++) {
                    float t, u, v;
                    R->s.vs_list++;
                    RT_REC(R->rec, rt_mm_addr(R->L, R->reg_list, (uint64_t)(p - g->list)), RT_GRID_WORD, 0,
                           RT_CLS_INDEX);
                    count_test(R, *p, eye);
                    if (rt_isect_core(r, &sc->tri[*p], &t, &u, &v) && t > r->tmin && t < r->tmax &&
                        !rt_alpha_cut(sc->alpha, &R->aat, R->rec, r, *p, u, v)) {
                        found = 1;
                        h->tri = *p;
                        h->t = t;
                    }
                }
                if (found) break;
                R->s.vs_list++; /* the terminator */
                RT_REC(R->rec, rt_mm_addr(R->L, R->reg_list, (uint64_t)(p - g->list)), RT_GRID_WORD, 0, RT_CLS_INDEX);
                continue;
            }
            const uint32_t *p = g->list + w;
            for (; *p != RT_GRID_NULL; p++) {
                R->s.vs_list++;
                RT_REC(R->rec, rt_mm_addr(R->L, R->reg_list, (uint64_t)(p - g->list)), RT_GRID_WORD, 0, RT_CLS_INDEX);
                R->s.vs_tests--; /* rt_grid_cell_closest counts them below */
                count_test(R, *p, eye);
            }
            R->s.vs_list++;
            RT_REC(R->rec, rt_mm_addr(R->L, R->reg_list, (uint64_t)(p - g->list)), RT_GRID_WORD, 0, RT_CLS_INDEX);
            found = rt_grid_cell_closest_at(g, sc, r, &c, tol, h, &R->s.vs_tests, &R->aat, R->rec);
            if (found && h->t < c.t1 - tol) break;
        }
    } else if (!box_hit(&R->pl->box, r)) {
        R->s.vs_box_out++;
    } else if (any) {
        for (uint32_t i = 0; i < sc->ntri && !found; i++) {
            float t, u, v;
            count_test(R, i, eye);
            if (rt_isect_core(r, &sc->tri[i], &t, &u, &v) && t > r->tmin && t < r->tmax &&
                !rt_alpha_cut(sc->alpha, &R->aat, R->rec, r, i, u, v)) {
                found = 1;
                h->tri = i;
                h->t = t;
            }
        }
    } else { /* rt_brute_closest's loop */
        float best = r->tmax;
        for (uint32_t i = 0; i < sc->ntri; i++) {
            float t, u, v;
            count_test(R, i, eye);
            if (!rt_isect_core(r, &sc->tri[i], &t, &u, &v)) continue;
            if (t > r->tmin && t < best && !rt_alpha_cut(sc->alpha, &R->aat, R->rec, r, i, u, v)) {
                best = t;
                h->t = t;
                h->tri = i;
                h->u = u;
                h->v = v;
            }
        }
        found = h->tri != RT_NO_HIT;
    }
    R->img->nodes[pix] += (float)(R->s.vs_steps - steps0);
    R->img->tests[pix] += (float)(R->s.vs_tests - tests0);
    return found;
}

/* Appends a record to the output buffer (stream-out: the next slot). */
static int emit(fb_run *R, int out, const rt_fb_ray *ray, rt_err *e)
{
    if (R->n[out] >= R->pl->cap)
        return rt_errf(e, "feedback: F1: vertex buffer overflow (%" PRIu64 " records)", R->pl->cap);
    if (R->n[out] == R->alloc[out]) {
        uint64_t na = R->alloc[out] ? 2 * R->alloc[out] : 4096;
        if (na > R->pl->cap) na = R->pl->cap;
        rt_fb_rec *nb = rt_reallocarray(R->vb[out], (size_t)na, sizeof *nb, e);
        if (!nb) return -1;
        R->vb[out] = nb;
        R->alloc[out] = na;
    }
    rt_rec_set_gen(R->rec, ray->gen);
    RT_REC(R->rec, rt_mm_addr(R->L, R->reg_vb[out], R->n[out]), RT_FB_REC_SIZE,
           R->o->rstores == RT_RSTORES_WRITE_ALLOCATE ? 1 : RT_WRITE_STREAM, RT_CLS_STREAM);
    rt_fb_pack(ray, &R->vb[out][R->n[out]++]);
    R->s.gs_emitted++;
    if (R->perpix) R->perpix[ray->pix]++;
    return 0;
}

/* Equation 1 on float target tg: dst = src + alpha dst (alpha 0 or 1). */
static void blend(fb_run *R, int tg, uint32_t pix, const float src[3], int alpha)
{
    const uint64_t t = (uint64_t)tg * R->npix + pix;
    R->s.fs_blends++;
    if (R->rec) {
        uint64_t a = rt_mm_addr(R->L, R->reg_fb, t);
        RT_REC(R->rec, a, R->pl->texel, 0, RT_CLS_FB);
        RT_REC(R->rec, a, R->pl->texel, 1, RT_CLS_FB);
    }
    if (R->at) {
        rt_acc_add(&R->at[t], src);
        return;
    }
    float *d = &R->ft[3 * t];
    for (int k = 0; k < 3; k++) d[k] = alpha ? src[k] + d[k] : src[k];
}

/* Unit geometric normal facing the ray and the hit point from the
 * barycentrics: the expressions of shade.c, so a light's term below is the
 * float rt_shade_hit adds. */
static rt_vec3 facing_normal(const rt_scene *sc, const rt_ray *r, const rt_hit *h)
{
    rt_vec3 n = rt_norm(rt_tri_normal(&sc->tri[h->tri]));
    if (rt_dot(n, r->d) > 0) n = rt_mul(n, -1.0f);
    return n;
}

/* Light i's term alb * (n.l) * power of a primary hit (0 when n.l <= 0). */
static void light_term(const rt_scene *sc, const rt_ray *r, const rt_hit *h, int i, float out[3])
{
    const float *alb = sc->shade[h->tri].rgb;
    rt_vec3 n = facing_normal(sc, r, h), p = rt_tri_point(&sc->tri[h->tri], h->u, h->v);
    float ndl = rt_dot(n, rt_norm(rt_sub(sc->light[i], p)));
    out[0] = out[1] = out[2] = 0.0f;
    if (!(ndl > 0)) return;
    float s = ndl * (sc->light_power * sc->light_scale[i]);
    for (int k = 0; k < 3; k++) out[k] = alb[k] * s;
}

static int nonzero3(const float c[3]) { return c[0] != 0.0f || c[1] != 0.0f || c[2] != 0.0f; }

/* The passed-through input ray: streamed out (dropped next pass) and
 * shaded now. */
static int pass_through(fb_run *R, int out, rt_fb_ray *ray, rt_err *e)
{
    ray->state = RT_FB_WRITTEN;
    return emit(R, out, ray, e);
}

static rt_fb_ray shadow_rec(const rt_fb_ray *parent, const rt_ray *sr, int light, const float payload[3])
{
    rt_fb_ray s;
    memset(&s, 0, sizeof s);
    s.pix = parent->pix;
    for (int k = 0; k < 3; k++) s.w[k] = payload[k];
    s.o = sr->o;
    s.d = sr->d;
    s.t = sr->tmax;
    s.tri = RT_NO_HIT;
    s.light = (uint32_t)light;
    s.state = RT_FB_TRACE;
    s.type = RT_FB_SHADOW;
    s.gen = parent->gen;
    return s;
}

/* Geometry and fragment stages of an eye ray in raycast and shadow modes. */
static int gs_primary(fb_run *R, int out, rt_fb_ray *ray, const rt_ray *r, const rt_hit *h, rt_err *e)
{
    const rt_scene *sc = R->sc;
    const unsigned lights = R->o->lights;
    float src[3];
    rt_fb_ray in = *ray;
    if (h->tri == RT_NO_HIT) {
        src[0] = sc->background.x, src[1] = sc->background.y, src[2] = sc->background.z;
        R->img->depth[ray->pix] = INFINITY;
        if (!nonzero3(src)) {
            R->s.gs_drop_done++;
            return 0;
        }
        if (pass_through(R, out, ray, e) < 0) return -1;
        R->s.fs_shaded++;
        blend(R, 0, in.pix, src, 1);
        return 0;
    }
    if (R->authored) { /* every sample of every enabled light, payload its weight */
        rec_shading(R, h->tri, 1);
        if (pass_through(R, out, ray, e) < 0) return -1;
        R->img->depth[in.pix] = h->t * rt_len(r->d);
        R->htri[in.pix] = h->tri;
        for (uint32_t i = 0; i < sc->nlight; i++) {
            if (!rt_render_light_on(R->o, i)) continue;
            for (uint32_t k = 0, ns = rt_shade_light_nsamples(sc, R->o, i); k < ns; k++) {
                rt_ray sr;
                float w;
                uint32_t tri;
                if (!rt_shade_sample_ray(sc, R->o, r, h, i, k, &sr, &w, &tri)) continue;
                if (tri != RT_NO_HIT) rec_verts(R, tri); /* a mesh light's sampled triangle; light records are constants */
                const float pay[3] = {w, w, w};
                rt_fb_ray s = shadow_rec(&in, &sr, (int)i, pay);
                R->s.gs_rays++;
                if (emit(R, out, &s, e) < 0) return -1;
            }
        }
        R->s.fs_shaded++;
        rec_shading(R, h->tri, 0);
        int none[RT_NLIGHTS] = {0};
        rt_shade_hit(sc, r, h, none, lights, src); /* ambient only: target 0 */
        blend(R, 0, in.pix, src, 1);
        return 0;
    }
    int vis[RT_NLIGHTS] = {0}, want[RT_NLIGHTS] = {0};
    rt_ray sr[RT_NLIGHTS];
    if (lights) rec_shading(R, h->tri, 1);
    for (int j = 0; j < R->nl; j++) {
        int i = R->light[j];
        want[i] = vis[i] = rt_shade_ray(sc, r, h, i, &sr[i]);
    }
    if (pass_through(R, out, ray, e) < 0) return -1;
    R->img->depth[in.pix] = h->t * rt_len(r->d);
    for (int j = 0; j < R->nl; j++) {
        int i = R->light[j];
        if (!want[i]) continue;
        float pay[3];
        if (R->pl->comp == COMP_EQ1) {
            int none[RT_NLIGHTS] = {0};
            rt_shade_hit(sc, r, h, none, lights, pay); /* the colour when occluded */
        } else {
            light_term(sc, r, h, i, pay);
        }
        rt_fb_ray s = shadow_rec(&in, &sr[i], i, pay);
        R->s.gs_rays++;
        if (emit(R, out, &s, e) < 0) return -1;
    }
    /* fragment stage of the passed-through eye ray */
    R->s.fs_shaded++;
    rec_shading(R, h->tri, 0);
    if (R->pl->comp == COMP_EQ1) {
        rt_shade_hit(sc, r, h, vis, lights, src); /* every light assumed visible */
    } else {
        int none[RT_NLIGHTS] = {0};
        rt_shade_hit(sc, r, h, none, lights, src); /* ambient only: target 0 */
    }
    blend(R, 0, in.pix, src, 1);
    return 0;
}

/* Geometry and fragment stages of an eye or secondary ray in whitted mode. */
static int gs_whitted(fb_run *R, int out, rt_fb_ray *ray, const rt_ray *r, const rt_hit *h, rt_err *e)
{
    const rt_scene *sc = R->sc;
    rt_path p;
    rt_shade_out so;
    memset(&p, 0, sizeof p);
    p.o = ray->o;
    p.d = ray->d;
    for (int k = 0; k < 3; k++) p.w[k] = ray->w[k];
    p.pix = ray->pix;
    p.depth = ray->gen;
    p.nmed = ray->nmed;
    p.kind = ray->type == RT_FB_REFR ? RT_PATH_REFRACT : 0;
    for (int k = 0; k < RT_PATH_MEDIA; k++) p.med[k] = ray->med[k];
    p.from_tri = RT_NO_HIT;
    const int hit = h->tri != RT_NO_HIT;
    rt_shade_step(sc, R->o, &p, r, hit ? h : NULL, &so);
    rt_fb_ray in = *ray;
    const int eq1 = R->pl->comp == COMP_EQ1, tg = eq1 ? 0 : in.gen;
    if (in.gen == 0) R->img->depth[in.pix] = hit ? h->t * rt_len(r->d) : INFINITY;
    if (!hit && !nonzero3(so.c)) {
        R->s.gs_drop_done++;
        return 0;
    }
    if (pass_through(R, out, ray, e) < 0) return -1;
    if (hit && (R->nl || so.nchild)) rec_shading(R, h->tri, 1);
    for (int j = 0; j < R->nl; j++) {
        int i = R->light[j];
        if (!so.want[i]) continue;
        float pay[3];
        for (int k = 0; k < 3; k++)
            pay[k] = !eq1 ? so.lc[i][k] : in.gen == 0 ? so.c[k] : -so.lc[i][k];
        rt_fb_ray s = shadow_rec(&in, &so.sray[i], i, pay);
        R->s.gs_rays++;
        if (emit(R, out, &s, e) < 0) return -1;
    }
    for (int c = 0; c < so.nchild; c++) {
        const rt_path *ch = &so.child[c];
        rt_fb_ray cr;
        memset(&cr, 0, sizeof cr);
        cr.pix = ch->pix;
        for (int k = 0; k < 3; k++) cr.w[k] = ch->w[k];
        cr.o = ch->o;
        cr.d = ch->d;
        cr.t = INFINITY;
        cr.tri = RT_NO_HIT;
        cr.state = RT_FB_TRACE;
        cr.type = ch->kind == RT_PATH_REFRACT ? RT_FB_REFR : RT_FB_REFL;
        cr.gen = (uint8_t)ch->depth;
        cr.nmed = ch->nmed;
        for (int k = 0; k < ch->nmed; k++) {
            if (ch->med[k] > 255) return rt_errf(e, "feedback: material %u does not fit a record", ch->med[k]);
            cr.med[k] = (uint8_t)ch->med[k];
        }
        R->s.gs_rays++;
        if (emit(R, out, &cr, e) < 0) return -1;
    }
    /* fragment stage of the passed-through ray: Equation 1 with alpha 1,
     * src = w (colour), the light assumed visible (eq1) */
    float src[3] = {so.c[0], so.c[1], so.c[2]};
    if (eq1)
        for (int j = 0; j < R->nl; j++)
            if (so.want[R->light[j]])
                for (int k = 0; k < 3; k++) src[k] = src[k] + so.lc[R->light[j]][k];
    R->s.fs_shaded++;
    if (hit) rec_shading(R, h->tri, 0);
    blend(R, tg, in.pix, src, 1);
    return 0;
}

/* Shadow rays: the geometry stage passes through the ones whose outcome
 * changes the pixel (occluded under eq1, unoccluded in the targets). */
static int gs_shadow(fb_run *R, int out, rt_fb_ray *ray, rt_err *e)
{
    const int occluded = ray->tri != RT_NO_HIT, eq1 = R->pl->comp == COMP_EQ1;
    if (eq1 ? !occluded : occluded) {
        R->s.gs_drop_done++;
        return 0;
    }
    rt_fb_ray in = *ray;
    if (pass_through(R, out, ray, e) < 0) return -1;
    int tg, alpha = 1;
    if (eq1) {
        tg = 0;
        /* primary hits: replace (alpha 0); deeper ones: subtract (alpha 1,
         * the payload is minus the light's term) */
        alpha = in.gen == 0 ? 0 : 1;
    } else if (R->pl->comp == COMP_LIGHTS && R->authored) {
        tg = 1 + R->arank[in.light];
    } else if (R->pl->comp == COMP_LIGHTS) {
        tg = 1;
        while (R->light[tg - 1] != (int)in.light) tg++;
    } else {
        tg = in.gen;
    }
    blend(R, tg, in.pix, in.w, alpha);
    return 0;
}

/* One record through the three stages. */
static int stage(fb_run *R, int cur, uint64_t i, rt_err *e)
{
    const int out = !cur;
    rt_fb_ray ray;
    R->s.vs_records++;
    rt_fb_unpack(&R->vb[cur][i], &ray);
    if (R->cores) rt_cores_claim(R->cores, R->core, i, R->n[cur]); /* F4 */
    rt_rec_set_gen(R->rec, ray.gen);
    RT_REC(R->rec, rt_mm_addr(R->L, R->reg_vb[cur], i), RT_FB_REC_SIZE, 0, RT_CLS_STREAM);
    R->s.gs_records++;
    if (ray.state == RT_FB_WRITTEN) {
        R->s.gs_drop_written++;
        return 0;
    }
    if (ray.state != RT_FB_TRACE) return rt_errf(e, "feedback: F3: record %" PRIu64 " in state %d", i, ray.state);
    rt_ray r;
    rt_hit h;
    rt_ray_init(&r, ray.o, ray.d);
    r.tmax = ray.t;
    const int shadow = ray.type == RT_FB_SHADOW;
    if (shadow) R->s.shadow++;
    else if (ray.type == RT_FB_EYE) R->s.eye++;
    else R->s.secondary++;
    intersect(R, &r, &h, shadow, ray.type == RT_FB_EYE, ray.pix);
    ray.tri = h.tri;
    ray.state = RT_FB_SHADE;
    if (!shadow) {
        ray.t = h.t;
        ray.u = h.u;
        ray.v = h.v;
    }
    if (shadow) return gs_shadow(R, out, &ray, e);
    if (R->mode == RT_MODE_WHITTED) return gs_whitted(R, out, &ray, &r, &h, e);
    return gs_primary(R, out, &ray, &r, &h, e);
}

/* The final blending pass over the render targets (none under eq1). */
static void composite(fb_run *R, const uint8_t *kept)
{
    const int nt = R->pl->ntarget;
    for (size_t pix = 0; pix < R->npix; pix++) {
        if (!kept[pix]) continue;
        fb_item(R, pix, R->npix);
        float *rgb = &R->img->rgb[3 * pix];
        if (R->rec && R->pl->comp != COMP_EQ1) {
            for (int t = 0; t < nt; t++)
                RT_REC(R->rec, rt_mm_addr(R->L, R->reg_fb, (uint64_t)t * R->npix + pix), R->pl->texel, 0, RT_CLS_FB);
            RT_REC(R->rec, rt_mm_addr(R->L, R->reg_fb, pix), R->pl->texel, 1, RT_CLS_FB);
        }
        if (R->pl->comp != COMP_EQ1) {
            R->s.fs_blends += (uint64_t)nt;
            R->s.fs_final += (uint64_t)nt;
        }
        if (R->at) {
            rt_acc sum = R->at[pix];
            for (int t = 1; t < nt; t++)
                for (int k = 0; k < 3; k++) sum.v[k] += R->at[(size_t)t * R->npix + pix].v[k];
            float depth = R->img->depth[pix];
            rt_acc_pixel(&sum, 1, NULL, NULL, R->img, pix);
            R->img->depth[pix] = depth;
            continue;
        }
        for (int k = 0; k < 3; k++) rgb[k] = R->ft[3 * pix + k];
        if (R->authored) { /* target 1 + rank: light i's unoccluded weights; shade.h's rule in light order */
            if (R->htri[pix] == RT_NO_HIT) continue;
            const float *alb = R->sc->shade[R->htri[pix]].rgb;
            for (uint32_t i = 0; i < R->sc->nlight; i++) {
                if (R->arank[i] < 0) continue;
                float W = R->ft[3 * ((size_t)(1 + R->arank[i]) * R->npix + pix)];
                if (!(W > 0)) continue;
                float sw = (W / (float)rt_shade_light_nsamples(R->sc, R->o, i)) *
                           (R->sc->light_power * R->sc->lights[i].scale);
                for (int k = 0; k < 3; k++) rgb[k] += alb[k] * sw;
            }
            continue;
        }
        for (int t = 1; t < nt; t++)
            for (int k = 0; k < 3; k++) rgb[k] += R->ft[3 * ((size_t)t * R->npix + pix) + k];
    }
}

static void list_u64(char *buf, size_t n, const uint64_t *v, int cnt)
{
    size_t l = 0;
    buf[0] = 0;
    for (int i = 0; i < cnt && l + 24 < n; i++) {
        if (i == 8 && cnt > 9) {
            snprintf(buf + l, n - l, ",...,%" PRIu64, v[cnt - 1]);
            return;
        }
        snprintf(buf + l, n - l, "%s%" PRIu64, i ? "," : "", v[i]);
        l = strlen(buf);
    }
}

static void list_dbl(char *buf, size_t n, const double *v, int cnt)
{
    size_t l = 0;
    buf[0] = 0;
    for (int i = 0; i < cnt && l + 24 < n; i++) {
        if (i == 8 && cnt > 9) {
            snprintf(buf + l, n - l, ",...,%.0f", v[cnt - 1]);
            return;
        }
        snprintf(buf + l, n - l, "%s%.0f", i ? "," : "", v[i]);
        l = strlen(buf);
    }
}

static void finish_stats(fb_run *R, rt_run_stats *st)
{
    const fb_stats *s = &R->s;
    const fb_plan *pl = R->pl;
    st->rays_primary = s->eye;
    st->rays_shadow = s->shadow;
    st->nodes = s->vs_steps;
    st->tests = s->vs_tests;
    for (uint32_t i = 0; i < R->sc->ntri; i++) {
        st->pv_primary += R->mark[i] & 1;
        st->pv_all += R->mark[i] != 0;
    }
    double vs = (double)s->vs_records * COST_VS_RECORD + (double)s->vs_box * COST_VS_BOX +
                (double)s->vs_steps * COST_VS_STEP + (double)s->vs_list * COST_VS_LIST +
                (double)s->vs_tests * COST_VS_TEST;
    double gs = (double)s->gs_records * COST_GS_RECORD + (double)s->gs_emitted * COST_GS_EMIT +
                (double)s->gs_rays * COST_GS_RAY;
    double fs = (double)s->gs_emitted * COST_FS_FRAGMENT + (double)s->fs_shaded * COST_FS_SHADE +
                (double)(s->fs_blends - s->fs_final) * COST_FS_BLEND + (double)s->fs_final * COST_FS_FINAL;
    double tot = vs + gs + fs > 0 ? vs + gs + fs : 1;
    uint64_t maxout = 0;
    for (int p = 0; p < s->passes; p++) maxout = s->out[p] > maxout ? s->out[p] : maxout;
    char rin[96], rout[96], E[96];
    list_u64(rin, sizeof rin, s->in, s->passes);
    list_u64(rout, sizeof rout, s->out, s->passes);
    list_dbl(E, sizeof E, pl->z.E, pl->z.ndepth);
    snprintf(st->extra, sizeof st->extra,
             "passes=%d composite=%s svb=%.0f G=%.0f G2=%.0f E=%s records_in=%s records_out=%s occupancy=%.4f "
             "rays_secondary=%" PRIu64 " vs_records=%" PRIu64 " vs_box_out=%" PRIu64 " vs_steps=%" PRIu64
             " vs_tests=%" PRIu64 " gs_read=%" PRIu64 " gs_emitted=%" PRIu64 " gs_dropped=%" PRIu64
             " fs_shaded=%" PRIu64 " fs_blended=%" PRIu64 " modeled_share_vs=%.2f modeled_share_gs=%.2f modeled_share_fs=%.2f",
             s->passes, comp_names[pl->comp], pl->z.svb, pl->z.G, pl->z.G2, E, rin, rout,
             pl->cap ? (double)maxout / (double)pl->cap : 0.0, s->secondary, s->vs_records, s->vs_box_out,
             s->vs_steps, s->vs_tests, s->gs_records, s->gs_emitted, s->gs_drop_written + s->gs_drop_done,
             s->fs_shaded, s->fs_blends, 100 * vs / tot, 100 * gs / tot, 100 * fs / tot);
}

static int fb_run_tracer(const rt_tracer_ctx *ctx, rt_image *img, rt_run_stats *st, rt_err *e)
{
    const rt_render_opts *o = ctx->opt;
    const fb_plan *pl = ctx->plan;
    fb_run R;
    int rc = -1;
    memset(&R, 0, sizeof R);
    if (!pl) return rt_errf(e, "feedback: no plan");
    R.ctx = ctx;
    R.sc = ctx->sc;
    R.o = o;
    R.pl = pl;
    R.rec = ctx->rec;
    R.L = ctx->L;
    if (ctx->cores) {
        R.cores = ctx->cores;
        R.ncores = ctx->cores->n;
        R.rec = rt_cores_rec(R.cores, 0);
    }
    R.img = img;
    R.mode = rt_render_mode(o);
    R.npix = (size_t)o->W * (size_t)o->H;
    R.reg_grid = rt_mm_find(R.L, "grid");
    R.reg_list = rt_mm_find(R.L, "list");
    R.reg_tri = rt_mm_find(R.L, "tri");
    R.reg_vb[0] = rt_mm_find(R.L, "vb.read");
    R.reg_vb[1] = rt_mm_find(R.L, "vb.write");
    R.reg_fb = rt_mm_find(R.L, "fb");
    rt_alpha_at_init(&R.aat, R.L);
    R.mats = R.mode == RT_MODE_WHITTED && rt_scene_material_flags(R.sc) != 0;
    if (R.mode != RT_MODE_RAYCAST)
        for (int i = 0; i < RT_NLIGHTS; i++)
            if (o->lights & (1u << i)) R.light[R.nl++] = i;
    uint8_t *kept = rt_calloc(R.npix, 1, e);
    R.authored = authored(R.sc, o);
    if (R.authored) {
        if (!(R.arank = rt_calloc(R.sc->nlight, sizeof *R.arank, e)) || !(R.htri = rt_calloc(R.npix, sizeof *R.htri, e)))
            goto done;
        for (uint32_t i = 0, j = 0; i < R.sc->nlight; i++) R.arank[i] = rt_render_light_on(o, i) ? (int)j++ : -1;
        for (size_t p = 0; p < R.npix; p++) R.htri[p] = RT_NO_HIT;
    }
    R.mark = rt_calloc(R.sc->ntri ? R.sc->ntri : 1, 1, e);
    if (pl->comp == COMP_GENS) R.at = rt_calloc(R.npix * (size_t)pl->ntarget, sizeof *R.at, e);
    else R.ft = rt_calloc(R.npix * (size_t)pl->ntarget * 3, sizeof *R.ft, e);
    if (ctx->check) R.perpix = rt_calloc(R.npix, sizeof *R.perpix, e);
    if (!kept || !R.mark || !(R.at || R.ft) || (ctx->check && !R.perpix)) goto done;

    /* primary rays: a W x H grid of points, row by row */
    rt_cam_frame cam;
    rt_cam_setup(&cam, R.sc, o->W, o->H);
    uint64_t nkept = 0; /* on cores, the fill's records in chunks too */
    for (int y = 0; R.cores && y < o->H; y++)
        for (int x = 0; x < o->W; x++) nkept += rt_pixel_kept(o, x, y) != 0;
    for (int y = 0; y < o->H; y++)
        for (int x = 0; x < o->W; x++) {
            if (!rt_pixel_kept(o, x, y)) continue;
            fb_item(&R, R.n[0], nkept);
            rt_ray er;
            rt_fb_ray ray;
            rt_cam_ray(&cam, x, y, &er);
            memset(&ray, 0, sizeof ray);
            ray.pix = (uint32_t)y * (uint32_t)o->W + (uint32_t)x;
            kept[ray.pix] = 1;
            ray.w[0] = ray.w[1] = ray.w[2] = 1.0f;
            ray.o = er.o;
            ray.d = er.d;
            ray.t = er.tmax;
            ray.tri = RT_NO_HIT;
            if (emit(&R, 0, &ray, e) < 0) goto done;
        }
    R.s.gs_emitted = 0; /* the fill is not geometry-stage work */
    if (fb_pass_end(&R, e) < 0) goto done;
    int cur = 0;
    uint64_t live = R.n[0];
    while (live) {
        if (R.s.passes > RT_DEPTH_MAX) {
            rt_errf(e, "feedback: more passes than the recursion allows");
            goto done;
        }
        const int out = !cur;
        R.n[out] = 0;
        R.s.in[R.s.passes] = R.n[cur];
        if (R.perpix) memset(R.perpix, 0, R.npix * sizeof *R.perpix);
        for (uint64_t i = 0; i < R.n[cur]; i++) {
            fb_item(&R, i, R.n[cur]);
            if (stage(&R, cur, i, e) < 0) goto done;
        }
        if (fb_pass_end(&R, e) < 0) goto done;
        R.s.out[R.s.passes] = R.n[out];
        /* live records of the output: those not already written */
        live = 0;
        for (uint64_t i = 0; i < R.n[out]; i++) live += get_u(&R.vb[out][i].uv_state[2]) % 4u == RT_FB_TRACE;
        if (R.perpix) {
            const int p = R.s.passes;
            double lim = pl->z.E[p] + (p + 1 < pl->z.ndepth ? pl->z.E[p + 1] : 0.0);
            for (size_t q = 0; q < R.npix; q++)
                if ((double)R.perpix[q] > lim) {
                    rt_errf(e, "feedback: F2: pass %d appended %u records for pixel %zu (bound %.0f)", p + 1,
                            R.perpix[q], q, lim);
                    goto done;
                }
        }
        R.s.passes++;
        cur = out;
    }
    composite(&R, kept);
    if (fb_pass_end(&R, e) < 0) goto done;
    finish_stats(&R, st);
    if (R.ncores > 1) {
        size_t l = strlen(st->extra);
        snprintf(st->extra + l, sizeof st->extra - l, " cores=%d barriers=%" PRIu64, R.ncores, R.cores->phases);
    }
    rc = 0;
done:
    free(kept);
    free(R.arank);
    free(R.htri);
    free(R.mark);
    free(R.at);
    free(R.ft);
    free(R.perpix);
    free(R.vb[0]);
    free(R.vb[1]);
    return rc;
}

/* The options that differ from the defaults ("grid_min=N vb-size=B"; the
 * job puts "accel=naive" before them), so a default run's key is empty. */
static void fb_params(const rt_render_opts *o, char *buf, size_t n)
{
    size_t l = 0;
    buf[0] = 0;
    if (o->grid_min && o->grid_min != 64) l += (size_t)snprintf(buf, n, "grid_min=%u", (unsigned)o->grid_min);
    if (o->grid_density > 0 && l < n) l += (size_t)snprintf(buf + l, n - l, "%sgrid_density=%g", l ? " " : "", o->grid_density);
    if (o->vb_size && l < n) l += (size_t)snprintf(buf + l, n - l, "%svb-size=%" PRIu64, l ? " " : "", o->vb_size);
    if (o->rstores != RT_RSTORES_NON_TEMPORAL && l < n)
        snprintf(buf + l, n - l, "%srecord_stores=%s", l ? " " : "", rt_render_rstores_name(o->rstores));
}

const rt_tracer rt_tracer_feedback = {
    .name = "feedback",
    .desc = "rays as points in ping-pong vertex buffers, one generation per pass, blend compositing",
    .modes = (1u << RT_MODE_RAYCAST) | (1u << RT_MODE_SHADOW) | (1u << RT_MODE_WHITTED),
    .accels = RT_ACCEL_BIT(RT_ACCEL_GRID) | RT_ACCEL_BIT(RT_ACCEL_NAIVE),
    .accel_default = RT_ACCEL_GRID,
    .opts = RT_OPTG_GRID | RT_OPTG_VB | RT_OPTG_RECORDS | RT_OPTG_CORES,
    .traits = RT_TR_TEXCACHE | RT_TR_LIGHTS | RT_TR_CORE_PHASES,
    .figures = RT_FIG_FEEDBACK,
    .params = fb_params,
    .layout = fb_layout,
    .run = fb_run_tracer,
    .plan = fb_plan_make,
    .plan_free = fb_plan_free,
};
