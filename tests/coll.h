/*
 * coll.h -- a sink that collects a run's references with the core that
 * made each (the multi-core tests compare streams reference by reference).
 */
#ifndef RT_TEST_COLL_H
#define RT_TEST_COLL_H

#include "trace.h"

#include <stdlib.h>
#include <string.h>

typedef struct coll {
    rt_access *a;
    uint8_t *core;
    size_t n, cap;
} coll;

static inline void coll_add(coll *c, unsigned core, const rt_access *a, size_t n)
{
    if (c->n + n > c->cap) {
        c->cap = 2 * (c->n + n);
        c->a = realloc(c->a, c->cap * sizeof *c->a);
        c->core = realloc(c->core, c->cap);
    }
    memcpy(c->a + c->n, a, n * sizeof *a);
    memset(c->core + c->n, (int)core, n);
    c->n += n;
}

static inline void coll_free(coll *c)
{
    free(c->a);
    free(c->core);
    memset(c, 0, sizeof *c);
}

/* rt_sink: everything on core 0 */
static inline int coll_put(rt_sink *s, const rt_access *a, size_t n)
{
    coll_add(s->ctx, 0, a, n);
    return 0;
}

/* rt_csink: each reference with its core */
static inline int coll_cput(rt_csink *s, unsigned core, const rt_access *a, size_t n)
{
    coll_add(s->ctx, core, a, n);
    return 0;
}

static inline int same_access(const rt_access *x, const rt_access *y)
{
    return x->addr == y->addr && x->size == y->size && x->write == y->write && x->cls == y->cls && x->gen == y->gen;
}

#endif
