/*
 * sindex_int.h -- the state of the sample index's maker (sindex.c), for
 * sindex.c and the tests that check rt_si_check on corrupted copies.
 * Private to cachesim/ and the tests; the public API is sindex.h. The
 * invariants I1-I7 are stated at the top of sindex.c.
 */
#ifndef RT_SINDEX_INT_H
#define RT_SINDEX_INT_H

#include "sindex.h"
#include "trace_rec.h"

#include <stddef.h>
#include <stdint.h>

/* A growable byte buffer. */
typedef struct rt_si_buf {
    unsigned char *b; /* bytes */
    size_t n, cap;    /* used, allocated */
} rt_si_buf;

/* The maker: rt_si_payload.open returns one. */
typedef struct rt_si_maker {
    rt_tr_sample_params p;          /* parameters */
    int shift;                      /* log2(p.line) */
    uint64_t T64, goff;             /* sampled iff L * RT_SAMPLE_GOLD + goff < T64 (T64 0: every line) */
    unsigned maxgen;                /* header generations (0: none) */
    uint64_t pos, next;             /* records seen; start of the window in progress or to come (I3, I4) */
    uint64_t cpos;                  /* pos at the start of the current chunk (I6) */
    rt_access *hist;                /* ring of p.hist records */
    uint64_t hn, hhead;             /* records kept, next slot */
    uint64_t wn;                    /* records of the current window */
    uint64_t wscanned;              /* its warm-up: records scanned */
    uint32_t wnwarm;                /*   lines found */
    int wshort;                     /*   short warm-up */
    uint64_t *set;                  /* distinct-line set of the scan (L + 1; 0 empty) */
    uint32_t *setidx;               /* index in stk of each set entry */
    uint64_t setmask;               /* set size - 1 */
    int setshift;                   /* 64 - log2(set size) */
    rt_access *stk;                 /* lines found, most recent first */
    uint64_t touch[RT_NCLASS][2];   /* chunk: line touches by class, write */
    uint64_t refs[RT_NCLASS], bytes[RT_NCLASS], writes[RT_NCLASS]; /* chunk: totals */
    rt_si_buf samp;                      /* chunk: sampled records, encoded */
    uint64_t ns;                    /* their count */
    rt_trc_coder cs;                /* their coder */
    rt_si_buf wcur;                      /* current window: warm-up then records, encoded */
    rt_trc_coder cw;                /* its coder */
    rt_si_buf wins;                      /* windows ended in this chunk (header + wcur each), then nothing */
    uint64_t nw;                    /* their count */
    rt_si_buf out;                       /* the last payload made */
    uint64_t setfill;               /* size of set and setidx as allocated (I7) */
} rt_si_maker;

#endif
