/*
 * memmodel.h -- the modeled address space and the memory-access stream.
 *
 * Traffic is measured on a *modeled* address space, not on the addresses
 * malloc happens to return, so that every trace is deterministic and every
 * layout decision is explicit and documented (docs/memory-model.md).
 *
 * A layout is an ordered list of regions. Each region is one data structure
 * a tracer touches: a name, a class, a record size, a record count and a
 * base address. Invariants:
 *   - bases are assigned in the order regions are added, starting at
 *     RT_MM_BASE, each aligned to RT_MM_ALIGN (4 KiB), with regions never
 *     overlapping: base[i+1] >= base[i] + recsize[i] * count[i];
 *   - the same sequence of rt_mm_add calls yields the same addresses on any
 *     machine (no pointers, no hashing of memory);
 *   - a region exists only if the scene and tracer use it: tracers add
 *     regions lazily (shading data only when shading happens, queues only
 *     for the dynamic tracer), so a trace's region table lists only what the
 *     run needed;
 *   - the address of record i of region r is base[r] + i * recsize[r];
 *     sub-record accesses add a byte offset within the record.
 *
 * An access is (address, size, read|write, class, ray generation). Tracers
 * report accesses in program order through an rt_rec recorder. The recorder buffers
 * accesses and hands full buffers to a sink (trace file writer, in-process
 * cache simulator, counter, ...). When recording is off the tracer holds a
 * NULL recorder and every RT_REC() is a single predictable branch, so the
 * untraced path costs (almost) nothing.
 *
 * Classes group into the paper's two columns: geometry (nodes, index lists,
 * triangles, shading data) and ray (ray records, queues, queue table, hit
 * records, stream buffers); the framebuffer is "other". The two-level
 * structure's classes (tlas, inst) and alpha texels are geometry: the
 * bottom-level trees (blas) keep the classes node and tri.
 */
#ifndef RT_MEMMODEL_H
#define RT_MEMMODEL_H

#include "rt.h"
#include "rt_assert.h"

#include <stdint.h>

typedef enum rt_class {
    RT_CLS_NODE = 0,   /* k-d tree nodes, 8 B */
    RT_CLS_INDEX = 1,  /* leaf triangle-index lists, 4 B per entry */
    RT_CLS_TRI = 2,    /* triangle vertex data, 36 B per triangle */
    RT_CLS_SHADE = 3,  /* shading data, read only when a hit is shaded */
    RT_CLS_RAY = 4,    /* 32-byte ray records */
    RT_CLS_QUEUE = 5,  /* ray queue buffers (dynamic scheduler) */
    RT_CLS_QTABLE = 6, /* queue table, 8 B per queue point */
    RT_CLS_HIT = 7,    /* hit records */
    RT_CLS_STREAM = 8, /* stream / ping-pong buffers of later tracers */
    RT_CLS_FB = 9,     /* framebuffer */
    RT_CLS_TLAS = 10,  /* top-level BVH nodes of the two-level structure (--instances bvh), 32 B */
    RT_CLS_INST = 11,  /* instance records (world-to-object matrix, tree, first triangle), 64 B */
    RT_CLS_ALPHA = 12, /* alpha-texture texels (reserved: any-hit cutouts) */
    RT_NCLASS = 13
} rt_class;

/* Classes below this one are those of every trace written before the
 * two-level structure existed: a trace footer and a sample-index side
 * payload store at least RT_NCLASS_V1 classes, and more only when a
 * record of a later class exists (docs/trace-format.md), so traces that
 * use none of them are byte for byte what they were. */
#define RT_NCLASS_V1 10

typedef enum rt_group {
    RT_GROUP_GEOMETRY = 0,
    RT_GROUP_RAY = 1,
    RT_GROUP_OTHER = 2,
    RT_NGROUP = 3
} rt_group;

/* Short lowercase class name ("node", "tri", ...); NULL if out of range. */
const char *rt_class_name(int cls);
/* Class from its name, or -1. */
int rt_class_from_name(const char *name);
/* Paper column of a class. */
rt_group rt_class_group(int cls);
const char *rt_group_name(int group);

#define RT_MM_BASE 0x10000000ULL /* first region base; 0 is never a valid address */
#define RT_MM_ALIGN 4096ULL
#define RT_MM_MAX_REGIONS 32
#define RT_MM_NAME_LEN 24

typedef struct rt_region {
    char name[RT_MM_NAME_LEN]; /* e.g. "kd.nodes" */
    uint8_t cls;               /* rt_class */
    uint32_t recsize;          /* bytes per record */
    uint64_t count;            /* records */
    uint64_t base;             /* modeled address of record 0 */
} rt_region;

typedef struct rt_layout {
    int n;                              /* regions in use */
    rt_region r[RT_MM_MAX_REGIONS];     /* in order of addition */
    uint64_t next;                      /* first free modeled address */
} rt_layout;

void rt_mm_init(rt_layout *L);
/* Adds a region and returns its index (>= 0), or -1 if the table is full or
 * the region would overflow the 64-bit address space. */
int rt_mm_add(rt_layout *L, const char *name, rt_class cls, uint32_t recsize, uint64_t count, rt_err *e);
/* Checks the invariants above on a layout (one read from a trace header
 * too): region count in range; region 0 at RT_MM_BASE; every base aligned
 * to RT_MM_ALIGN and at or after the end of the previous region (bases in
 * order, no overlap); record sizes non-zero; classes known; names non-empty,
 * terminated and unique; next at or after the last region's end. 0, or -1
 * naming the first violation. */
int rt_mm_check(const rt_layout *L, rt_err *e);
/* Index of the region with this name, or -1. */
int rt_mm_find(const rt_layout *L, const char *name);
static inline uint64_t rt_mm_addr(const rt_layout *L, int reg, uint64_t rec)
{
    return L->r[reg].base + rec * L->r[reg].recsize;
}

/*
 * Ray generations: 0 = primary rays (and their shadow rays), 1 = the first
 * bounce, and so on. An access carries the generation of the ray the tracer
 * was working on (0..255, as stored in traces). Per-generation counters
 * (the exact simulators) keep RT_MAXGEN buckets: generations 0..RT_MAXGEN-2
 * each have their own, every generation >= RT_MAXGEN-1 is counted in the
 * last bucket (rt_gen_bucket).
 */
#define RT_MAXGEN 8

static inline unsigned rt_gen_bucket(unsigned gen) { return gen < RT_MAXGEN - 1 ? gen : RT_MAXGEN - 1; }

/* A streaming store (rt_access.write): a write to lines the program fills
 * whole before it reads them again (the dynamic tracer's queue blocks with
 * --queue-stores stream), so a miss allocates the line without fetching it;
 * it still becomes dirty and is written back. Simulators that know only
 * read/write treat it as a write (any non-zero value is a write). */
#define RT_WRITE_STREAM 2

/* One memory reference. 16 bytes: gen lives in what was padding, so
 * buffers of accesses keep their size. C zeroes the members a positional
 * initializer {addr, size, write, cls} omits, so such literals mean
 * generation 0 (gcc -Wextra asks for the fifth value: {..., cls, 0}). */
typedef struct rt_access {
    uint64_t addr;  /* modeled byte address */
    uint32_t size;  /* bytes, >= 1 */
    uint8_t write;  /* 0 read, 1 write, RT_WRITE_STREAM streaming store */
    uint8_t cls;    /* rt_class */
    uint8_t gen;    /* ray generation (0 = primary), see RT_MAXGEN */
} rt_access;
_Static_assert(sizeof(rt_access) == 16, "rt_access must stay 16 bytes");

/*
 * A sink consumes batches of accesses. put() returns 0 or -1 (with the
 * message in the sink's own error, retrievable by the owner). The sink does
 * not keep the pointer past the call.
 */
typedef struct rt_sink rt_sink;
struct rt_sink {
    int (*put)(rt_sink *s, const rt_access *a, size_t n);
    void *ctx; /* owner's state */
};

/*
 * A core sink consumes the references of several simulated cores, each
 * batch one core's (core < the stream's cores), in the order of the
 * modeled clock (tracegen/run.h: rt_job_run_cores). Same contract as put.
 */
typedef struct rt_csink rt_csink;
struct rt_csink {
    int (*put)(rt_csink *s, unsigned core, const rt_access *a, size_t n);
    void *ctx; /* owner's state */
};

#define RT_REC_BUF 4096

/* The recorder. Invariant (RT_ASSERT in rt_rec_push and the writer
 * below): 0 <= n < RT_REC_BUF between calls; a push that fills the
 * buffer hands it to the sink at once, so the sink always receives
 * batches of RT_REC_BUF accesses but the last. */
typedef struct rt_rec {
    rt_access buf[RT_REC_BUF]; /* pending accesses */
    size_t n;                  /* entries in buf, < RT_REC_BUF between calls */
    rt_sink *sink;             /* receives full buffers; never NULL */
    uint64_t total;            /* accesses recorded so far */
    int failed;                /* a put() failed; later accesses are dropped */
    uint8_t gen;               /* generation stamped on each access (rt_rec_set_gen) */
} rt_rec;

/* Creates a recorder feeding sink, at generation 0; NULL on out of memory. */
rt_rec *rt_rec_new(rt_sink *sink, rt_err *e);
/* Hands the pending buffer to the sink. Returns 0, or -1 if any put failed. */
int rt_rec_flush(rt_rec *r);
void rt_rec_free(rt_rec *r);

/* Sets the generation stamped on every later access: a tracer calls it
 * when it starts on rays of another generation (the recursive tracer per
 * ray, a breadth-first tracer per wave). Pending accesses keep the
 * generation they were recorded with. gen is clamped to 0..255. Like
 * RT_REC, a NULL recorder (recording off) is fine. */
static inline void rt_rec_set_gen(rt_rec *r, int gen)
{
    if (r) r->gen = (uint8_t)(gen < 0 ? 0 : gen > 255 ? 255 : gen);
}

static inline void rt_rec_push(rt_rec *r, uint64_t addr, uint32_t size, int write, int cls)
{
    RT_ASSERT(r->n < RT_REC_BUF);
    rt_access *a = &r->buf[r->n++];
    a->addr = addr;
    a->size = size;
    a->write = (uint8_t)write;
    a->cls = (uint8_t)cls;
    a->gen = r->gen;
    if (r->n == RT_REC_BUF) rt_rec_flush(r);
}

/*
 * A local writer for a walk's inner loop (the k-d walk's leaves and
 * nodes): reads that rt_rec_push would do through the recorder after
 * every store (its count and generation, which the compiler must assume
 * the stores into buf may change) are held in this struct, which the
 * walk keeps in registers. It writes the same accesses, fields and order
 * as rt_rec_push and hands the buffer to the sink at the same fill level,
 * so the sink sees the very batches rt_rec_push would give it.
 *
 *   rt_rec_w w;
 *   rt_rec_wbegin(&w, rec);          rec non-NULL
 *   rt_rec_wput(&w, addr, size, cls) reads only, any number of times
 *   rt_rec_wend(&w);                 writes the count back
 *
 * Between wbegin and wend the recorder's own count is stale: nothing else
 * may record into rec (RT_ASSERT at wend checks that the count is the one
 * the writer last left there), and the generation stays as it was.
 */
#if defined(__GNUC__)
#define RT_REC_INLINE inline __attribute__((always_inline))
#else
#define RT_REC_INLINE inline
#endif

typedef struct rt_rec_w {
    rt_rec *rec;    /* the recorder */
    rt_access *buf; /* rec->buf */
    size_t n;       /* entries in buf (rec->n is stale until rt_rec_wend) */
    size_t synced;  /* rec->n as the writer last left it */
    uint8_t gen;    /* rec->gen, constant between wbegin and wend */
} rt_rec_w;

static RT_REC_INLINE void rt_rec_wbegin(rt_rec_w *w, rt_rec *rec)
{
    w->rec = rec;
    w->buf = rec->buf;
    w->n = w->synced = rec->n;
    w->gen = rec->gen;
}

static RT_REC_INLINE void rt_rec_wput(rt_rec_w *w, uint64_t addr, uint32_t size, uint8_t cls)
{
    RT_ASSERT(w->n < RT_REC_BUF);
    rt_access *a = &w->buf[w->n++];
    a->addr = addr;
    a->size = size;
    a->write = 0;
    a->cls = cls;
    a->gen = w->gen;
    if (w->n == RT_REC_BUF) {
        RT_ASSERT(w->rec->n == w->synced); /* nothing else recorded meanwhile */
        w->rec->n = w->n;
        rt_rec_flush(w->rec);
        w->n = w->synced = w->rec->n;
    }
}

static RT_REC_INLINE void rt_rec_wend(rt_rec_w *w)
{
    RT_ASSERT(w->rec->n == w->synced && w->rec->gen == w->gen); /* nothing else recorded meanwhile */
    w->rec->n = w->synced = w->n;
}

/* The tracers' hook: free when recording is off (rec == NULL). */
#define RT_REC(rec, addr, size, write, cls)                              \
    do {                                                                 \
        if (rec) rt_rec_push((rec), (addr), (uint32_t)(size), (write), (cls)); \
    } while (0)

#endif
