/*
 * options.h -- render options shared by every tracer (prefix rt_render_).
 *
 * One struct carries what a run is asked to do: image size, lights, and the
 * per-tracer knobs (packet edge, the dynamic scheduler's cache budget and
 * queue order, pixel subsampling). A tracer reads only the fields it needs;
 * the job records the ones that shaped its run (run.c, rt_job_meta).
 */
#ifndef RT_OPTIONS_H
#define RT_OPTIONS_H

#include "accel.h"
#include "rt.h"

#include <stdint.h>

typedef enum rt_qorder {
    RT_QORDER_FULLEST = 0, /* dynamic: process the fullest queue next */
    RT_QORDER_TREE = 1     /* dynamic: queue points in tree (depth-first) order */
} rt_qorder;

/* How triangles are stored in the modeled memory (docs/memory-model.md,
 * "Geometry layouts"). Only what is recorded differs: images are the same. */
typedef enum rt_geom_layout {
    RT_GEOM_COMPACT = 0, /* 36-byte triangle records (three vertices), 16-byte shading records */
    RT_GEOM_MESH = 1,    /* pbrt-style mesh: 12-byte vertex indices, shared positions and normals */
    RT_GEOM_PBRT = 2,    /* pbrt-v1's objects on a 32-bit machine: the mesh plus mailboxes, primitives,
                          * shapes and leaf pointer lists (pbrtlayout.h) */
    RT_GEOM_PBRT64 = 3   /* the same with 64-bit pointers */
} rt_geom_layout;
/* 1 for the layouts built on the mesh's vertex index (mesh, pbrt, pbrt64). */
static inline int rt_geom_uses_mesh(int geom) { return geom == RT_GEOM_MESH || geom == RT_GEOM_PBRT || geom == RT_GEOM_PBRT64; }
/* 1 for pbrt-v1's object layouts (pbrt, pbrt64). */
static inline int rt_geom_is_pbrt(int geom) { return geom == RT_GEOM_PBRT || geom == RT_GEOM_PBRT64; }

/* What the dynamic tracer does with a hit found in a subtree that lies
 * beyond the subtree's exit (docs/results.md, "Why rays visit N queue
 * points"). */
typedef enum rt_hit_rule {
    RT_HIT_EXACT = 0, /* keep it as a candidate and settle it in later queue points: the closest hit */
    RT_HIT_FIRST = 1  /* take it: the ray ends in the subtree where it found a hit (section 2.1.1 read
                       * literally; a closer hit in a later cell is missed, images may differ) */
} rt_hit_rule;

/* How the dynamic tracer measures a subtree against the budget g_max when it
 * selects queue points. */
typedef enum rt_qp_measure {
    RT_QPM_ALL = 0,      /* nodes (8 B) + index entries (4 B) + distinct triangles (36 B) */
    RT_QPM_TRIANGLES = 1 /* distinct triangles only (36 B): the nodes are resident (section 2.2) */
} rt_qp_measure;

/* How the dynamic tracer writes ray-queue records (docs/memory-model.md). */
typedef enum rt_qstores {
    RT_QSTORES_WRITE_ALLOCATE = 0, /* ordinary stores: a missing line is fetched first */
    RT_QSTORES_STREAM = 1          /* non-temporal stores (RT_WRITE_STREAM): queue lines are not fetched */
} rt_qstores;

/* How the tracers whose ray records the GPU writes whole (the feedback
 * tracer's vertex buffers, the stream tracers' render-target ray state)
 * store them (docs/feedback.md, docs/purcell.md). */
typedef enum rt_rstores {
    RT_RSTORES_NON_TEMPORAL = 0,  /* full-line stores (RT_WRITE_STREAM): a missing line is not fetched */
    RT_RSTORES_WRITE_ALLOCATE = 1 /* ordinary stores: a missing line is fetched first (the former model) */
} rt_rstores;
/*
 * Render options that only some tracers read, each in one group; a tracer's
 * traits (tracer.h, rt_tracer.opts) list the groups it reads, and an option
 * given on the command line for a tracer that does not read it is refused
 * (rt_tracer_check_given).
 */
enum {
    RT_OPTG_PACKET = 1u << 0,   /* --packet */
    RT_OPTG_SCHED = 1u << 1,    /* --cache-size, --gmax, --qorder, --hit-rule, --qp-measure:
                                 * scheduled tracers */
    RT_OPTG_QUEUES = 1u << 2,   /* --queue-stores: tracers that keep ray queues */
    RT_OPTG_GRID = 1u << 3,     /* --grid-min, --grid-density: tracers on the uniform grid */
    RT_OPTG_VB = 1u << 4,       /* --vb-size: ping-pong vertex buffers */
    RT_OPTG_ORACLE = 1u << 5,   /* --oracle, --oracle-fraction, --unroll, --unroll-suppress */
    RT_OPTG_RECORDS = 1u << 6,  /* --record-stores: tracers whose ray records the GPU writes whole */
    RT_OPTG_TREELET = 1u << 7,  /* --treelet-tris, --ray-window: the treelet scheduler */
    RT_OPTG_THREADS = 1u << 8,  /* --threads: tracers whose work splits over host threads
                                 * (parallel by construction: rt_job_run, run.h) */
    RT_OPTG_CORES = 1u << 9     /* --cores: simulated cores (the tracers of RT_OPTG_THREADS:
                                 * their work shares; dynamic: its modeled threads) */
};

/*
 * The render option table: every option of render, trace, bench and sweep
 * that sets a field of rt_render_opts is declared once here, in the order
 * --help lists them. Everything else derives from the entry:
 *
 *   1. the front end's getopt tables (cli/cmd_common.c, rt_cmd_longopts)
 *      take each entry whose .cmds names the command: the option's code is
 *      RT_OPT_CODE_BASE + its index;
 *   2. parsing: .parse reads the value into rt_render_opts (a message in e
 *      on a bad value); every numeric value goes through the strict parsers
 *      below (no white space, '+', hex, inf, nan or overflow);
 *   3. --help: rt_cmd_render_help prints .label (default "--NAME ARG") and
 *      .help for every entry of the command; sweep lists .sweep_help where
 *      its usage places it, and any entry without one after its own options;
 *   4. the refusal: a value given sets bit (index) of rt_render_opts.given;
 *      rt_tracer_check_given refuses a given option whose .group the tracer
 *      does not read ("--packet does not apply to the dynamic tracer");
 *   5. .key is the spelling of the run-key parameter the option writes
 *      (written by the tracer's .params, or by rt_job_params for the
 *      options every tracer reads); tests/test_options.c checks that the
 *      .example value puts "KEY=" in the run key.
 *
 * Invariants (rt_render_optdefs_check): (1) names are unique and start with
 * "--"; (2) short names are unique; (3) every entry has a parser except
 * --tracer (the front end's: it names the tracer, not an option value);
 * (4) at most 64 entries (the .given mask); (5) every entry but those listed
 * with the entry before (.help NULL) has help text and an example value.
 *
 * Adding an option: a field in rt_render_opts (and its default in
 * rt_render_default_opts), a parser, one entry here. Nothing in cli/ changes.
 * The table holds what a run renders with; the simulator's options
 * (--sizes, --line, ...) stay sweep's and sim's own.
 */
#define RT_OC_RENDER 1u /* render */
#define RT_OC_TRACE 2u  /* trace */
#define RT_OC_BENCH 4u  /* bench (takes every option of a run; its help lists its own) */
#define RT_OC_SWEEP 8u  /* sweep */
#define RT_OC_RUN (RT_OC_RENDER | RT_OC_TRACE | RT_OC_BENCH) /* the commands that run one job */
#define RT_OPT_CODE_BASE 1000 /* getopt code of entry i: RT_OPT_CODE_BASE + i */

struct rt_render_opts;
typedef struct rt_render_optdef {
    const char *name;       /* "--packet"; the long option is name + 2 */
    int short_name;         /* 'W', or 0 */
    const char *arg;        /* the value's name in --help ("N"); NULL: a switch without a value */
    unsigned group;         /* RT_OPTG_* of the tracers that read it; 0: every tracer */
    unsigned cmds;          /* RT_OC_* commands that take it */
    const char *key;        /* run-key parameter it writes ("qorder"), NULL: none (a column, or no key) */
    /* Reads arg (NULL for a switch) into o: 0, 1 (done, with a note in e->msg
     * to show), or -1 with "--NAME: ..." in e. NULL only for --tracer. */
    int (*parse)(struct rt_render_opts *o, const char *arg, rt_err *e);
    const char *label;      /* --help column; NULL: "NAME ARG" */
    const char *help;       /* --help text, "\n" between lines; NULL: listed with the entry before */
    const char *sweep_help; /* sweep --help: the whole line(s) naming it with others; "": listed on
                             * another entry's line; NULL: label and help as in render */
    const char *example;    /* a value the parser takes (tests); NULL for a switch */
} rt_render_optdef;

extern const rt_render_optdef rt_render_optdefs[];
extern const int rt_render_noptdefs;
/* Index of the entry named "--NAME" (or "NAME"), or -1. */
int rt_render_opt_find(const char *name);
/* "--packet" ... for an index, and its group. */
const char *rt_render_opt_name(int id);
unsigned rt_render_opt_group(int id);
/* Checks the table's invariants: 0, or -1 naming the entry and the
 * invariant's number in e. The _table form checks any table (tests). */
int rt_render_optdefs_check(rt_err *e);
int rt_render_optdefs_check_table(const rt_render_optdef *t, int n, rt_err *e);

/* The strict parsers every numeric option value goes through. A decimal
 * integer in lo..hi: a digit first (or '-' and a digit), nothing after it.
 * A finite decimal [-]D[.D][e[+-]D] (or [-].D...). No white space, no '+'
 * in front, no hex, nan or inf, no overflow. 0 or -1. */
int rt_opt_parse_long(const char *s, long lo, long hi, long *out);
int rt_opt_parse_double(const char *s, double *out);

/* What a run traces (docs/tracers.md, "Modes"). */
typedef enum rt_mode {
    RT_MODE_DEFAULT = 0, /* SHADOW when lights are enabled, else RAYCAST */
    RT_MODE_RAYCAST = 1, /* primary rays only, headlight shading */
    RT_MODE_SHADOW = 2,  /* primary rays and shadow rays to the enabled lights */
    RT_MODE_WHITTED = 3, /* plus mirror reflection and refraction, depth generations */
    RT_MODE_PATH = 4     /* spp paths per pixel, one continuation per bounce */
} rt_mode;

#define RT_DEPTH_MAX 64    /* largest --depth */
#define RT_BOUNCES_MAX 1000 /* largest --bounces (path records count depth in 16 bits) */
#define RT_SPP_MAX 65536    /* largest --spp */

/* A camera and lights given on the command line, replacing the scene's
 * (every scene: built-in and file). Part of the run key when set. */
typedef struct rt_render_view {
    int look;            /* 1: eye/at (and up, when up_set) replace the scene's camera */
    int up_set;          /* 1: up given; else the scene's up vector stays */
    float eye[3], at[3], up[3];
    float fov;           /* vertical field of view in degrees; 0 = the scene's */
    int nlights;         /* lights given (0 = the scene's); lights >= nlights do not exist */
    float light[RT_NLIGHTS][4]; /* x, y, z, power (0 = the scene's light power) */
} rt_render_view;

typedef struct rt_render_opts {
    int W, H;            /* image size */
    unsigned lights;     /* bit i set: light i enabled */
    int packet;          /* packet edge in pixels (packet tracer), 8 */
    uint64_t sched_size; /* dynamic: cache size the schedule targets (bytes) */
    uint64_t gmax;       /* dynamic: explicit geometry budget, 0 = derive */
    int qorder;          /* dynamic: rt_qorder */
    int threads;         /* dynamic: modeled cores, --cores (ray buffer = 2 rays each; the run
                          * key keeps its version-1 spelling "threads=N") */
    int cores;           /* --cores for the tracers of RT_OPTG_THREADS: simulated cores, one work
                          * share each, interleaved by the modeled clock (run.h); 1 = today's
                          * single stream (the run key's cores: rt_tr_meta.cores, the database column) */
    int host_threads;    /* --threads: real host threads of an untraced run (1; never in a run key:
                          * the images and statistics are those of one thread, run.h) */
    uint32_t subsample;  /* reduced experiment: trace 1 in K tiles (1 = all) */
    int subtile;         /* subsampling tile edge in pixels (default 8) */
    int mode;            /* rt_mode; RT_MODE_DEFAULT resolves by lights (rt_render_mode) */
    int depth;           /* whitted: ray generations along a path, primary included (1..64, 5) */
    int spp;             /* path: samples per pixel (1) */
    int bounces;         /* path: bounces after the primary hit (>= 0, 4) */
    int geom;            /* rt_geom_layout (compact) */
    int qstores;         /* dynamic: rt_qstores (write-allocate) */
    int hit_rule;        /* dynamic: rt_hit_rule (exact) */
    int qp_measure;      /* dynamic: rt_qp_measure (all) */
    int queue_stats;     /* dynamic, test/bench only: append the per-cause queue counters to the
                          * statistics (off, so existing statistics stay as they were) */
    int accel;           /* rt_accel_kind the tracer runs on; RT_ACCEL_DEFAULT = the tracer's default */
    int instances;       /* --instances: 0 flatten (object instances copied into the triangle array), 1 bvh
                          * (the two-level structure, accel kind inst; sets accel) */
    uint64_t vb_size;    /* feedback: limit of one vertex buffer in bytes, 0 = 2 GiB */
    uint32_t grid_min;   /* grid tracers: cells along the smallest axis; 0 = the tracer's default */
    double grid_density; /* grid tracers: cells ~ grid_density x triangles (accel/grid.c); 0 = by grid_min */
    int rstores;         /* feedback, stream tracers: rt_rstores (non-temporal) */
    int oracle;          /* stream-multipass: rt_oracle */
    double oracle_frac;  /* stream-multipass: threshold oracle's fraction, (0, 1] (0.2) */
    int unroll_t;        /* stream-multipass: traversal steps per pass (>= 1, 1) */
    int unroll_i;        /* stream-multipass: intersection tests per pass (>= 1, 1) */
    int unroll_suppress; /* stream-multipass: no texel reads for rays that finish mid-pass */
    int treelet_tris;    /* treelet: the leaves' triangles count against the treelet budget (0: nodes only) */
    uint32_t ray_window; /* treelet: rays in flight per generation, 0 = all rays of the frame */
    uint64_t given;      /* front end: bit i set when rt_render_optdefs[i] was given (never in a run key) */
    unsigned lights_named; /* the light indices --lights named (not "all"): each must exist */
    rt_render_view view; /* camera and lights the user set (--look-at, --fov, --light); none by default */
    uint32_t light_samples; /* --light-samples N: 0 = the point model (the scene's three point lights);
                             * N >= 1 = the authored lights, N shadow rays per hit to each area or
                             * infinite light (docs/scenes.md "Lights"); part of the run key when set */
    int lights_all;      /* --lights all: every light, also those past index 31 (authored model) */
    unsigned film;       /* RT_FILM_W | RT_FILM_H: that size may come from the scene's default
                          * image size (a pbrt Film); front ends set the bits of -W/-H not given (0) */
} rt_render_opts;

/* 1 when the option of table index id was given (o->given). */
static inline int rt_render_opt_given(const rt_render_opts *o, int id)
{
    return id >= 0 && id < 64 && (o->given >> id & 1);
}

#define RT_MAX_CORES 1024 /* largest --cores (the dynamic tracer's modeled threads; a multi-core
                           * trace holds at most 256: RT_TR_MAX_CORES) */

#define RT_FILM_W 1u
#define RT_FILM_H 2u

/* Applies a scene's default image size film_w x film_h (0 = none) to the
 * sizes o->film marks: both marked, the film's size; one marked, it
 * follows the film's aspect ratio from the other (rounded, 1..65536).
 * Clears o->film, so applying twice changes nothing. */
void rt_render_apply_film(rt_render_opts *o, int film_w, int film_h);

typedef enum rt_oracle {
    RT_ORACLE_THRESHOLD = 0, /* intersect once oracle_frac of the active rays need it */
    RT_ORACLE_NAIVE = 1      /* intersect as soon as any ray needs it */
} rt_oracle;

/* Fills o with the defaults: 512 x 512, no lights, packet 8, a 64 KiB
 * schedule, fullest-first queues, 4 threads, no subsampling (tile 8), the
 * default mode, depth 5, 1 sample, 4 bounces, the compact geometry
 * layout, write-allocate queue stores, no queue statistics; grid_min 0
 * (the tracer's default), no grid density, non-temporal record stores,
 * the threshold oracle at 0.2, no unrolling. */
void rt_render_default_opts(rt_render_opts *o);

/* The mode a run traces: o->mode, or for RT_MODE_DEFAULT SHADOW when a
 * light is enabled and RAYCAST otherwise (today's behaviour). */
int rt_render_mode(const rt_render_opts *o);
/* Mode name ("raycast", "shadow", "whitted", "path"), or NULL. */
const char *rt_render_mode_name(int mode);
/* Mode from its name, or -1. */
int rt_render_mode_from_name(const char *name);
/* 1 when the mode follows secondary rays (whitted, path). */
static inline int rt_render_secondary(const rt_render_opts *o)
{
    int m = o->mode;
    return m == RT_MODE_WHITTED || m == RT_MODE_PATH;
}
/* Checks mode, depth, spp, bounces, layout, queue and record stores,
 * accel, grid_min and grid_density (not both). 0, or -1 naming the option
 * in e. */
int rt_render_check_mode(const rt_render_opts *o, rt_err *e);

/* Layout name ("compact", "mesh", "pbrt", "pbrt64") or NULL; from its name, or -1. */
const char *rt_render_geom_name(int geom);
int rt_render_geom_from_name(const char *name);
/* Record-store name ("non-temporal", "write-allocate") or NULL; from its
 * name, or -1. */
const char *rt_render_rstores_name(int rs);
int rt_render_rstores_from_name(const char *name);
/* Hit-rule name ("exact", "first") and queue-point measure name ("all",
 * "triangles") or NULL; from the name, or -1. */
const char *rt_render_hit_rule_name(int r);
int rt_render_hit_rule_from_name(const char *name);
const char *rt_render_qp_measure_name(int m);
int rt_render_qp_measure_from_name(const char *name);
/* Queue-store name ("write-allocate", "non-temporal") or NULL; from its
 * name ("stream" is the former name of non-temporal), or -1. */
const char *rt_render_qstores_name(int qs);
int rt_render_qstores_from_name(const char *name);


/* Puts the view of o into sc: the camera (rt_scene_set_camera) and the
 * lights (positions, and a power as a factor on the scene's light power).
 * 0, or -1 (a usage-class error naming the option). */
int rt_render_apply_view(const rt_render_opts *o, rt_scene *sc, rt_err *e);
/* The light mask o asks for, limited to the lights that exist (with
 * --light given, only that many). */
unsigned rt_render_lights(const rt_render_opts *o);
/* Refuses a light index --lights named that --light did not define (with
 * --light given N times, only lights 0..N-1 exist). 0, or -1 (usage). */
int rt_render_check_lights(const rt_render_opts *o, rt_err *e);
/* Appends the view's run-key parameters (" look_at=... fov=... light0=...")
 * to buf (nothing when no view was given). */
void rt_render_view_params(const rt_render_opts *o, char *buf, size_t n);

/* Parses "all", "none" (or ""), or a list of light indices joined by ','
 * or '+' ("0,2", or "0+2" as rt_exp_lights_name prints it) into a light
 * mask ("all": lights 0..2, the point model's; with a file's own lights
 * the front end also sets lights_all). Indices 0..31; whether the light
 * exists is checked when the scene is known (rt_render_check_scene_lights).
 * 0, or -1 on a malformed list (*mask untouched). */
int rt_render_parse_lights(const char *s, unsigned *mask);
#define RT_LIGHT_SAMPLES_MAX 4096 /* largest --light-samples */
/* The number of lights the run can enable: the scene's authored lights
 * when o->light_samples > 0 and it has some, else the RT_NLIGHTS point lights. */
uint32_t rt_render_nlights(const rt_render_opts *o, const struct rt_scene *sc);
/* 1 when light i is enabled (bit i of the mask; every light with lights_all). */
int rt_render_light_on(const rt_render_opts *o, uint32_t i);
/* Every enabled light exists in sc and --light-samples is in range: 0, or -1
 * naming the light. */
int rt_render_check_scene_lights(const rt_render_opts *o, const struct rt_scene *sc, rt_err *e);

/* Former name, kept for the front end and its tests. */
static inline int rt_parse_lights(const char *s, unsigned *mask) { return rt_render_parse_lights(s, mask); }

#endif
