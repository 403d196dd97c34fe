/* memmodel.c -- region table and access recorder (see memmodel.h). */
#include "memmodel.h"

#include <stdlib.h>
#include <string.h>

static const char *const class_names[RT_NCLASS] = {
    "node", "index", "tri", "shade", "ray", "queue", "qtable", "hit", "stream", "fb", "tlas", "inst", "alpha",
};

const char *rt_class_name(int cls)
{
    return cls >= 0 && cls < RT_NCLASS ? class_names[cls] : NULL;
}

int rt_class_from_name(const char *name)
{
    for (int i = 0; i < RT_NCLASS; i++)
        if (strcmp(name, class_names[i]) == 0) return i;
    return -1;
}

rt_group rt_class_group(int cls)
{
    switch (cls) {
    case RT_CLS_NODE: case RT_CLS_INDEX: case RT_CLS_TRI: case RT_CLS_SHADE:
    case RT_CLS_TLAS: case RT_CLS_INST: case RT_CLS_ALPHA:
        return RT_GROUP_GEOMETRY;
    case RT_CLS_RAY: case RT_CLS_QUEUE: case RT_CLS_QTABLE: case RT_CLS_HIT: case RT_CLS_STREAM:
        return RT_GROUP_RAY;
    default:
        return RT_GROUP_OTHER;
    }
}

const char *rt_group_name(int group)
{
    static const char *const g[RT_NGROUP] = {"geometry", "ray", "other"};
    return group >= 0 && group < RT_NGROUP ? g[group] : NULL;
}

void rt_mm_init(rt_layout *L)
{
    memset(L, 0, sizeof *L);
    L->next = RT_MM_BASE;
}

int rt_mm_add(rt_layout *L, const char *name, rt_class cls, uint32_t recsize, uint64_t count, rt_err *e)
{
    if (L->n >= RT_MM_MAX_REGIONS) return rt_errf(e, "memory model: more than %d regions", RT_MM_MAX_REGIONS);
    if (recsize == 0) return rt_errf(e, "memory model: region %s has zero record size", name);
    if (count > (UINT64_MAX / 4) / recsize || L->next > UINT64_MAX / 2)
        return rt_errf(e, "memory model: region %s overflows the address space", name);
    rt_region *r = &L->r[L->n];
    memset(r, 0, sizeof *r);
    strncpy(r->name, name, RT_MM_NAME_LEN - 1);
    r->cls = (uint8_t)cls;
    r->recsize = recsize;
    r->count = count;
    r->base = L->next;
    uint64_t end = r->base + recsize * (count ? count : 1);
    L->next = (end + RT_MM_ALIGN - 1) / RT_MM_ALIGN * RT_MM_ALIGN;
    return L->n++;
}

int rt_mm_check(const rt_layout *L, rt_err *e)
{
    if (L->n < 0 || L->n > RT_MM_MAX_REGIONS) return rt_errf(e, "memory model: %d regions", L->n);
    uint64_t end = RT_MM_BASE;
    for (int i = 0; i < L->n; i++) {
        const rt_region *r = &L->r[i];
        if (!r->name[0] || memchr(r->name, 0, RT_MM_NAME_LEN) == NULL)
            return rt_errf(e, "memory model: region %d has no terminated name", i);
        for (int j = 0; j < i; j++)
            if (!strcmp(L->r[j].name, r->name)) return rt_errf(e, "memory model: region %s named twice", r->name);
        if (r->cls >= RT_NCLASS) return rt_errf(e, "memory model: region %s has class %u", r->name, r->cls);
        if (!r->recsize) return rt_errf(e, "memory model: region %s has zero record size", r->name);
        if (i == 0 && r->base != RT_MM_BASE)
            return rt_errf(e, "memory model: first region %s does not start at the base", r->name);
        if (r->base % RT_MM_ALIGN) return rt_errf(e, "memory model: region %s is not aligned", r->name);
        if (r->base < end) return rt_errf(e, "memory model: region %s overlaps the one before it", r->name);
        if (r->count > (UINT64_MAX / 4) / r->recsize || r->base > UINT64_MAX / 2)
            return rt_errf(e, "memory model: region %s overflows the address space", r->name);
        end = r->base + (uint64_t)r->recsize * (r->count ? r->count : 1);
    }
    if (L->n && L->next < end) return rt_errf(e, "memory model: next free address inside the last region");
    return 0;
}

int rt_mm_find(const rt_layout *L, const char *name)
{
    for (int i = 0; i < L->n; i++)
        if (strcmp(L->r[i].name, name) == 0) return i;
    return -1;
}

rt_rec *rt_rec_new(rt_sink *sink, rt_err *e)
{
    rt_rec *r = rt_calloc(1, sizeof *r, e);
    if (!r) return NULL;
    r->sink = sink;
    return r;
}

int rt_rec_flush(rt_rec *r)
{
    if (r->n) {
        if (!r->failed && r->sink->put(r->sink, r->buf, r->n) < 0) r->failed = 1;
        r->total += r->n;
        r->n = 0;
    }
    return r->failed ? -1 : 0;
}

void rt_rec_free(rt_rec *r) { free(r); }
