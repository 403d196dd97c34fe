/*
 * scene.h -- triangles, shading attributes, camera and lights.
 *
 * A scene is a flat array of triangles (three vertices each, 36 bytes, the
 * record the tracers read), a parallel array of per-triangle shading records
 * (diffuse colour; kept apart because it is read only when a hit is shaded),
 * a pinhole camera and exactly three point lights (the paper's experiments
 * use lights 0, 1, 2). Scenes come from deterministic built-in generators
 * (scene_builtin.c) or from OBJ/PLY files (scene_obj.c, scene_ply.c) and
 * pbrt-v4 scene files (scene_pbrt.c, a geometry-and-view subset); the
 * same spec always yields bit-identical triangles on any machine, which the
 * scene hash (rt_scene_hash) certifies in every trace and result row.
 *
 * Scene specs: a built-in name with optional parameters, e.g.
 *   "sphereflake", "sphereflake:level=2,tess=3", "grove:trees=4",
 * or a path ending in .obj, .ply or .pbrt (a .pbrt file takes the
 * parameters tess and maxtri, "scene.pbrt:tess=4"). Any spec may end in material=PRESET
 * ("knot:material=diffuse", "bun_zipper.ply:material=mirror"), which gives
 * every triangle that preset (rt_scene_set_material).
 */
#ifndef RT_SCENE_H
#define RT_SCENE_H

#include "rt.h"
#include "rt_math.h"

#include <stdint.h>
#include <stdio.h>

typedef struct rt_tri {
    rt_vec3 p[3]; /* vertices; 36 bytes, the modeled triangle record */
} rt_tri;

/* The smallest and largest of three floats (plain compares: scenes reject
 * NaN), and the bounds of a triangle from them. */
static inline float rt_min3f(float a, float b, float c)
{
    float m = a < b ? a : b;
    return m < c ? m : c;
}
static inline float rt_max3f(float a, float b, float c)
{
    float m = a > b ? a : b;
    return m > c ? m : c;
}
static inline rt_bounds rt_tri_bounds(const rt_tri *t)
{
    const rt_vec3 *p = t->p;
    rt_bounds b = {{rt_min3f(p[0].x, p[1].x, p[2].x), rt_min3f(p[0].y, p[1].y, p[2].y), rt_min3f(p[0].z, p[1].z, p[2].z)},
                   {rt_max3f(p[0].x, p[1].x, p[2].x), rt_max3f(p[0].y, p[1].y, p[2].y), rt_max3f(p[0].z, p[1].z, p[2].z)}};
    return b;
}

typedef struct rt_shade {
    float rgb[3];   /* diffuse albedo, linear */
    uint32_t mat;   /* index into rt_scene.mat (0 = plain diffuse); record is 16 bytes */
} rt_shade;

/*
 * Materials. The diffuse colour stays per triangle (rt_shade.rgb, the
 * record every shaded hit reads); what only secondary rays need lives in a
 * small table indexed by rt_shade.mat, modeled as its own region and read
 * once per shaded hit only when the mode follows secondary rays, so a scene
 * or a mode that needs no more than diffuse shading pays nothing for it.
 * Entry 0 is the plain diffuse material (all terms zero, ior 1).
 */
enum {
    RT_MAT_SPECULAR = 1u << 0, /* ks non-zero: mirror reflection */
    RT_MAT_TRANSMIT = 1u << 1, /* kt non-zero: refraction with ior */
    RT_MAT_EMIT = 1u << 2      /* ke non-zero: emits light */
};

typedef struct rt_material {
    char name[32];  /* from the MTL file or the generator ("" for entry 0) */
    float ks[3];    /* mirror reflectance rho (linear) */
    float kt[3];    /* transmittance of a dielectric (linear) */
    float ior;      /* index of refraction (1 = none) */
    float ke[3];    /* emitted radiance */
    uint32_t flags; /* RT_MAT_* bits, derived from the terms by rt_scene_add_material */
} rt_material;

/* Bytes of one material record in the modeled memory (ks, kt, ior, ke,
 * flags, padding to 48). */
#define RT_MAT_RECSIZE 48

typedef struct rt_camera {
    rt_vec3 eye, at, up; /* look-at frame */
    float fovy_deg;      /* vertical field of view, degrees */
    int mirror;          /* 0: image x runs along dir x up (right-handed); 1: along
                          * up x dir, pbrt's left-handed screen (pbrt files only;
                          * hashed only when set) */
} rt_camera;

#define RT_NLIGHTS 3

/*
 * Lights as authored. A scene always has the three point lights above
 * (light[], the paper's lights 0..2; for a pbrt file they stand in for the
 * file's lights: its point and spot lights, then a point near each area
 * light, the "point model"). A pbrt file also keeps the lights it declares,
 * in file order, as rt_light records (lights[], nlight of them), which the
 * tracers use when a run asks for them (--light-samples N, the "authored
 * model"; docs/scenes.md "Lights").
 *
 * Invariants (rt_scene_check_lights tests them):
 *  1. nlight == 0 exactly when lights == NULL.
 *  2. Every kind is one of rt_light_kind; every position, direction and
 *     radius is finite.
 *  3. DISTANT and DISK directions (d) have unit length (within 1e-3);
 *     SPHERE and DISK radii are > 0.
 *  4. A MESH light names triangles [first, first + count) of the scene,
 *     count >= 1 and first + count <= ntri, and its cdf holds count
 *     non-decreasing values ending in exactly 1 (area fractions), so a
 *     sample picks triangle i with probability area_i / area.
 *  5. scale >= 0 and finite.
 */
typedef enum rt_light_kind {
    RT_LIGHT_POINT = 0,   /* p: position (LightSource "point", "spot") */
    RT_LIGHT_MESH = 1,    /* triangles first..first+count-1 emit (AreaLightSource on a triangle shape) */
    RT_LIGHT_SPHERE = 2,  /* p: centre, r: radius (AreaLightSource on Shape "sphere") */
    RT_LIGHT_DISK = 3,    /* p: centre, d: unit normal, r: radius (AreaLightSource on Shape "disk") */
    RT_LIGHT_DISTANT = 4, /* d: unit direction toward the light (LightSource "distant": from - to) */
    RT_LIGHT_INFINITE = 5 /* the sky: every direction (LightSource "infinite") */
} rt_light_kind;
#define RT_LIGHT_KINDS 6

typedef struct rt_light {
    int kind;               /* rt_light_kind */
    rt_vec3 p, d;           /* see the kinds */
    float r;                /* sphere, disk: radius */
    float scale;            /* factor on the scene's light_power (1) */
    uint32_t first, count;  /* mesh: the emitting triangles */
    float *cdf;             /* mesh: count cumulative area fractions (owned) */
    char at[256];           /* "FILE:LINE" of its declaration ("" if none; a long path truncated) */
} rt_light;

/* Bytes of one light record in the modeled memory (kind, p, d, r, scale,
 * first, count, cdf offset: 48, padded to 64). */
#define RT_LIGHT_RECSIZE 64

/* The kind's name ("point", "mesh", "sphere", "disk", "distant", "infinite"). */
const char *rt_light_kind_name(int kind);

/* One kind of load warning (a skipped or approximated feature): its key
 * ("Shape \"disk\"", "Sampler"), how often it occurred and where first. */
typedef struct rt_scene_warn {
    char kind[48];   /* the kind, one per entry */
    char first[256]; /* "FILE:LINE" of its first occurrence */
    char msg[200];   /* what was done ("Shape \"curve\" skipped") */
    uint32_t count;  /* occurrences */
} rt_scene_warn;

/* Instancing kept beside the flattened triangles (pbrt ObjectInstance; see
 * accel/inst.c, the two-level structure that reads them). An object is a
 * range of otri, its triangles in the object's own space (the CTM of its
 * definition applied); an instance record says which object, where its
 * flattened copy starts in tri (first .. first + count) and the
 * object-to-world matrix whose application, in double, made that copy. */
typedef struct rt_scene_obj {
    uint32_t start, count; /* range of otri */
} rt_scene_obj;

typedef struct rt_scene_inst {
    uint32_t obj;     /* index into obj */
    uint32_t first;   /* its first triangle in the flattened order (in tri unless the instances are kept) */
    uint32_t loose;   /* triangles outside instance records before it in that order */
    double m[3][4];   /* object-to-world, row-major (affine; pbrt's projective rows are refused at load) */
} rt_scene_inst;

/*
 * Kept instances (rt_scene.kept, a .pbrt loaded with RT_LOAD_KEEP_INSTANCES,
 * which `--instances bvh` asks for). The flattened copy is not made: tri
 * and the first ntri records of shade hold only the loose triangles (those
 * outside instance records, singular or projective instances included), in
 * the flattened order, and shade continues with the objects' shading
 * records (shade[ntri + obj.start + j], notri of them). Triangle indices --
 * hits, lights, ties -- still number the flattened scene, 0 .. nflat - 1:
 * irec[] is sorted by first, and index i is
 *   instance k's triangle j   when first_k <= i < first_k + count (j = i - first_k),
 *   loose triangle i - (triangles of the records before it)  otherwise;
 * an instanced triangle's world vertices are (float)(m x object vertex)
 * evaluated in double as the loader's flattening evaluates them, so the
 * triangle is the flattened copy's bit for bit (rt_scene_tri_of). Invariants
 * (rt_scene_check_kept): records sorted by first, their ranges disjoint and
 * inside 0 .. nflat - 1, loose counts consistent (loose_k = first_k minus the
 * earlier records' triangles), ntri + the records' triangles = nflat, every
 * record's object inside otri.
 */
#define RT_LOAD_KEEP_INSTANCES 1u
#define RT_SCENE_MAX_FLAT 0xfffffffeu /* triangle indices of a kept scene (RT_NO_HIT excluded) */

/* The world triangle of an instance record's object triangle ot (the
 * flattening's arithmetic, bit for bit). */
static inline void rt_scene_inst_tri(const double m[3][4], const rt_tri *ot, rt_tri *w)
{
    for (int c = 0; c < 3; c++) {
        const double x = ot->p[c].x, y = ot->p[c].y, z = ot->p[c].z;
        w->p[c].x = (float)(m[0][0] * x + m[0][1] * y + m[0][2] * z + m[0][3]);
        w->p[c].y = (float)(m[1][0] * x + m[1][1] * y + m[1][2] * z + m[1][3]);
        w->p[c].z = (float)(m[2][0] * x + m[2][1] * y + m[2][2] * z + m[2][3]);
    }
}

typedef struct rt_scene {
    char name[256];         /* spec it was made from: built-in name or mesh file name, whole (NAME_MAX) */
    char params[128];       /* canonical parameter string, "" if none */
    uint32_t ntri;          /* triangles */
    rt_tri *tri;            /* ntri triangles */
    rt_shade *shade;        /* ntri shading records */
    uint32_t nmat;          /* materials in mat (>= 1) */
    rt_material *mat;       /* material table; mat[0] is plain diffuse */
    rt_camera cam;          /* default view */
    rt_vec3 light[RT_NLIGHTS]; /* point lights 0..2 */
    float light_power;      /* radiance scale of each light */
    float light_scale[RT_NLIGHTS]; /* per-light factor on light_power (1; a --light POWER sets it) */
    float ambient;          /* ambient term */
    rt_vec3 background;     /* colour of rays that leave the scene */
    rt_bounds bounds;       /* of all vertices */
    char warning[512];      /* first load warning(s) ("" if none; the library never prints it) */
    int film_w, film_h;     /* default image size from the file (pbrt Film), 0 = none */
    uint32_t ninst;         /* object instances flattened into tri (pbrt ObjectInstance), 0 = none */
    uint32_t ntri_unique;   /* with instances: triangles outside objects + each instanced object once */
    uint32_t ntri_inst;     /* with instances: triangles that came from instances */
    uint32_t nlight;        /* authored lights (pbrt files), 0 = none */
    rt_light *lights;       /* nlight records (see "Lights as authored") */
    rt_scene_warn *warn;    /* every load warning, one entry per kind in order of first occurrence (NULL if none; owned) */
    uint32_t nwarn;         /* entries in warn */
    uint32_t nobj;          /* instanced objects kept in obj (0: none) */
    rt_scene_obj *obj;      /* their ranges of otri (owned) */
    uint32_t notri;         /* triangles in otri */
    rt_tri *otri;           /* the objects' triangles in object space (owned) */
    uint32_t nirec;         /* instance records (objects of 3 or more triangles; smaller ones are copied at once) */
    rt_scene_inst *irec;    /* in file order (owned) */
    int kept;               /* 1: instances kept, not flattened ("Kept instances" above) */
    uint32_t nflat;         /* kept: triangles of the flattened scene (indices 0 .. nflat - 1); else ntri */
    uint32_t nirec_tri;     /* triangles of the instance records (their objects' counts summed) */
    struct rt_scene_alpha *alpha; /* alpha textures and their triangles (src/alpha.h; owned), NULL = every hit counts */
} rt_scene;

/* Triangles of the flattened scene: the range of triangle indices. */
static inline uint32_t rt_scene_nflat(const rt_scene *s) { return s->kept ? s->nflat : s->ntri; }
/* Shading records (and per-triangle marks): ntri, kept: ntri + notri. */
static inline uint32_t rt_scene_nshade(const rt_scene *s) { return s->kept ? s->ntri + s->notri : s->ntri; }
/* Kept scenes: the record holding index i (-1: a loose triangle) and the
 * loose triangle's index in tri (or the object triangle's j). */
int rt_scene_kept_find(const rt_scene *s, uint32_t i, uint32_t *j);
/* Triangle i of the flattened order: in tri, or made in *tmp (kept). */
static inline const rt_tri *rt_scene_tri_of(const rt_scene *s, uint32_t i, rt_tri *tmp)
{
    if (!s->kept) return &s->tri[i];
    uint32_t j;
    const int k = rt_scene_kept_find(s, i, &j);
    if (k < 0) return &s->tri[j];
    rt_scene_inst_tri(s->irec[k].m, &s->otri[s->obj[s->irec[k].obj].start + j], tmp);
    return tmp;
}
/* Index of triangle i's shading record in shade (and of its mark). */
static inline uint32_t rt_scene_slot(const rt_scene *s, uint32_t i)
{
    if (!s->kept) return i;
    uint32_t j;
    const int k = rt_scene_kept_find(s, i, &j);
    return k < 0 ? j : s->ntri + s->obj[s->irec[k].obj].start + j;
}
static inline const rt_shade *rt_scene_shade_of(const rt_scene *s, uint32_t i) { return &s->shade[rt_scene_slot(s, i)]; }
/* The instancing model's shading slots (what `--instances bvh` records and
 * marks, kept or flattened alike): with instance records, the loose
 * triangles 0 .. L - 1 in the flattened order (L = nflat - nirec_tri),
 * then each object's triangles once (L + obj.start + j), shared by all its
 * instances; without records (or inst 0) the triangle index itself. For a
 * kept scene the slot is where its shading record is (rt_scene_slot). */
static inline uint32_t rt_scene_model_nslot(const rt_scene *s, int inst)
{
    return inst && s->nirec ? rt_scene_nflat(s) - s->nirec_tri + s->notri : rt_scene_nshade(s);
}
static inline uint32_t rt_scene_model_slot(const rt_scene *s, uint32_t i, int inst)
{
    if (!inst || !s->nirec) return i;
    uint32_t j;
    const int k = rt_scene_kept_find(s, i, &j);
    return k < 0 ? j : rt_scene_nflat(s) - s->nirec_tri + s->obj[s->irec[k].obj].start + j;
}
/* Into box[k] (nirec of them) the exact bounds of record k's world
 * triangles -- the flattened copy's, kept or not -- without transforming
 * every triangle (scene.c, kept_bounds). 0, or -1 (out of memory, or a
 * record whose triangles are not finite). */
int rt_scene_inst_boxes(const rt_scene *s, rt_bounds *box, rt_err *e);
/* The invariants of "Kept instances": 0, or -1 naming the broken one
 * (a scene that is not kept passes). */
int rt_scene_check_kept(const rt_scene *s, rt_err *e);

void rt_scene_free(rt_scene *s);

/* Allocates an empty scene with room for ntri triangles (ntri may grow via
 * rt_scene_reserve). */
rt_scene *rt_scene_new(uint32_t ntri, rt_err *e);
int rt_scene_reserve(rt_scene *s, uint32_t ntri, rt_err *e);
/* Appends a triangle with a colour; returns 0 or -1. */
int rt_scene_add_tri(rt_scene *s, rt_vec3 a, rt_vec3 b, rt_vec3 c, const float rgb[3], rt_err *e);
/* Appends a material (flags are derived from its terms; name copied,
 * truncated). Returns its index, or -1 (bad value: NaN, infinite or
 * negative terms, ior < 1; too many materials). */
int rt_scene_add_material(rt_scene *s, const rt_material *m, rt_err *e);
/* Appends a triangle with a colour and a material index (< nmat). */
int rt_scene_add_tri_mat(rt_scene *s, rt_vec3 a, rt_vec3 b, rt_vec3 c, const float rgb[3], uint32_t mat, rt_err *e);
/* The union of the RT_MAT_* flags of the materials triangles use: 0 when
 * diffuse shading is all the scene needs. */
uint32_t rt_scene_material_flags(const rt_scene *s);
/* Material presets for the spec parameter material=NAME, NULL-terminated:
 * "diffuse" (the plain material), "mirror" (ks 0.8), "glass" (kt 1,
 * ior 1.5). */
extern const char *const rt_material_preset_names[];
/* Gives every triangle the preset `name` (colours unchanged): the table
 * becomes entry 0 plus the preset ("diffuse": entry 0 alone, so a scene
 * without materials keeps its hash). 0, or -1 for an unknown name. */
int rt_scene_set_material(rt_scene *s, const char *name, rt_err *e);
/* Writes the material table, one line per material (index, name,
 * triangles using it, RT_MAT_* flags, ks, kt, ior, ke), after a header
 * line. Returns 0, or -1 if the stream reports a write error. */
int rt_scene_describe_materials(const rt_scene *s, FILE *f);
/* Appends a copy of the light l (a MESH light's cdf is computed here from
 * its triangles; l->cdf is ignored). 0, or -1 when l breaks an invariant
 * of "Lights as authored" (message names l->at) or on allocation failure. */
int rt_scene_add_light(rt_scene *s, const rt_light *l, rt_err *e);
/* Checks the invariants of "Lights as authored": 0, or -1 naming the
 * first light and invariant broken. */
int rt_scene_check_lights(const rt_scene *s, rt_err *e);
/* 1 when some authored light is not a point light. */
int rt_scene_nonpoint_lights(const rt_scene *s);

/* Recomputes bounds; rejects NaN/Inf coordinates. Returns 0 or -1. */
int rt_scene_finish(rt_scene *s, rt_err *e);
/* Frames the camera on the bounds and places three default lights. The
 * bounding sphere fits the vertical field of view, which is enough for
 * images at least as wide as tall. */
void rt_scene_autoframe(rt_scene *s);
/* For an image W x H with W < H, moves an auto-framed camera (and light 0,
 * which sits at the camera) back so the bounding sphere also fits the
 * narrower horizontal field. Does nothing for W >= H or a scene whose
 * camera was not auto-framed, so those stay bit-identical. */
void rt_scene_fit_aspect(rt_scene *s, int W, int H);
/* Sets the camera a user gave (it is then no longer auto-framed, so
 * rt_scene_fit_aspect leaves it alone). eye != at, up not along at - eye,
 * 0 < fovy < 180: 0, else -1 naming what is wrong. */
int rt_scene_set_camera(rt_scene *s, rt_vec3 eye, rt_vec3 at, rt_vec3 up, float fovy_deg, rt_err *e);

/* The coordinates the single-precision pipeline resolves (derivation in
 * docs/scenes.md): every |coordinate| <= RT_COORD_MAX, the bounding-box
 * diagonal RT_EXTENT_MIN <= D <= RT_EXTENT_MAX (normals are cross
 * products of edges, and their squared length ~D^4 must stay below
 * FLT_MAX and above FLT_MIN: a smaller scene's normals underflow and its
 * shadow rays vanish), and D >= RT_EXTENT_MIN_REL * the largest
 * |coordinate| (at least 2^10 float steps across the scene, so vertices do
 * not collapse onto each other). */
#define RT_COORD_MAX 1e13
#define RT_EXTENT_MAX 1e9
#define RT_EXTENT_MIN 1e-9
#define RT_EXTENT_MIN_REL (1.0 / 8192.0)
/* The length scale of the self-intersection rule (src/isect.h,
 * rt_offset_origin_scaled): 16 times the bounding-box diagonal, at most 1.
 * The fixed offset near the origin (2^-16) is then at most 2^-12 of the
 * diagonal: it shrinks with scenes whose diagonal is below 1/16 and stays
 * the unit cube's for larger ones (every built-in scene, and the bunny,
 * diagonal 0.25, keep their offsets bit for bit). 1 for an empty scene. */
float rt_scene_offset_scale(const rt_scene *s);
/* Checks a finished scene (bounds computed) against that range. 0, or -1
 * with "WHERE: what (value)". Loaders call it with the file name. */
int rt_scene_check_range(const rt_scene *s, const char *where, rt_err *e);
/* Identity hash over triangles, shading, camera and lights. */
uint64_t rt_scene_hash(const rt_scene *s);
/* Writes the scene as OBJ with a colour comment per group. A scene with
 * materials (nmat > 1) also gets an MTL file beside it (path with .obj
 * replaced by .mtl, or .mtl appended), one MTL material per run of equal
 * colour and material, named by `mtllib` and `usemtl`; on failure neither
 * file is left. Both files are renamed into place under an exclusive
 * flock of the target's folder, so concurrent exports to one name leave
 * the OBJ and the MTL of one writer. */
int rt_scene_export_obj(const rt_scene *s, const char *path, rt_err *e);

/* Parameters a built-in scene accepts, as one human-readable line
 * ("key=default (min..max): help; ..."), into buf. 0, or -1 if unknown. */
int rt_scene_builtin_params(const char *name, char *buf, size_t n);

#endif
