/*
 * trace_rec.h -- the record coding of the trace format (trace.c,
 * docs/trace-format.md "Record encoding"), shared by the trace's chunks and
 * by whoever makes a version-3 side payload whose record groups are coded
 * the same way (cachesim/sindex.c). Prefix rt_trc_.
 *
 * A record is a tag byte (bits 0-3 class, bit 4 write, bit 5 size equals
 * the class's previous size, bit 6 address is the previous address plus
 * its size, bit 7 the generation changes and a generation byte follows),
 * then the zigzag LEB128 address delta unless bit 6, then the LEB128 size
 * unless bit 5. A group of records (a chunk, or one record group of a side
 * payload) starts from a zeroed rt_trc_coder. The functions are inline:
 * they are the inner loops of the writer, the reader and the sample-index
 * builder.
 */
#ifndef RT_TRACE_REC_H
#define RT_TRACE_REC_H

#include "rt.h"

#include <stdint.h>

#define RT_TRC_MAX_REC_V1 16u /* largest record: tag + 10-byte address varint + 5-byte size varint */
#define RT_TRC_MAX_REC 17u    /* with generations (version >= 2): + generation byte */

#define RT_TRC_TAG_CLASS 0x0fu
#define RT_TRC_TAG_WRITE 0x10u
#define RT_TRC_TAG_SAMESIZE 0x20u
#define RT_TRC_TAG_SEQ 0x40u
#define RT_TRC_TAG_GEN 0x80u /* version >= 2; reserved (zero) in version 1 */
/* Version 4: the core-switch record, a tag byte of exactly 0x0f (class 15,
 * no other bit) and the core id byte: the references after it, up to the
 * next switch or the chunk's end, are that core's. Not a reference (a
 * chunk's n counts references only); it always precedes a reference. */
#define RT_TRC_SWITCH 0x0fu
#define RT_TRC_MAX_REC_V4 (RT_TRC_MAX_REC + 2u) /* a reference with its core switch */

/* Per-class coder state: previous address and size per class and the
 * current generation, all 0 at the start of a chunk (and of every record
 * group of a side chunk). */
typedef struct rt_trc_coder {
    uint64_t addr[16]; /* previous address per class */
    uint32_t size[16]; /* previous size per class */
    unsigned gen;      /* current generation */
    unsigned core;     /* current core (version 4; 0 at a chunk's start, and always before) */
} rt_trc_coder;

/* Writes v as LEB128 at p (at most 10 bytes); returns the end. */
static inline unsigned char *rt_trc_put_varint(unsigned char *p, uint64_t v)
{
    while (v >= 0x80) {
        *p++ = (unsigned char)(v | 0x80);
        v >>= 7;
    }
    *p++ = (unsigned char)v;
    return p;
}

/* Encodes one valid record (class < RT_NCLASS, size >= 1, generation
 * allowed by the header) at p; returns the end (at most RT_TRC_MAX_REC). */
static inline unsigned char *rt_trc_enc(rt_trc_coder *c, unsigned char *p, const rt_access *a)
{
    unsigned cls = a->cls, gen = a->gen;
    unsigned char *tag = p++;
    unsigned t = cls | (a->write ? RT_TRC_TAG_WRITE : 0);
    if (gen != c->gen) { /* only possible with generations (version >= 2) */
        t |= RT_TRC_TAG_GEN;
        *p++ = (unsigned char)gen;
        c->gen = gen;
    }
    uint64_t pa = c->addr[cls];
    uint32_t ps = c->size[cls];
    if (a->addr == pa + ps) t |= RT_TRC_TAG_SEQ;
    else {
        uint64_t d = a->addr - pa;
        p = rt_trc_put_varint(p, (d << 1) ^ (0 - (d >> 63)));
    }
    if (a->size == ps) t |= RT_TRC_TAG_SAMESIZE;
    else p = rt_trc_put_varint(p, a->size);
    *tag = (unsigned char)t;
    c->addr[cls] = a->addr;
    c->size[cls] = a->size;
    return p;
}

/* Decoding errors (RT_TRC_OK: none), in the words of the chunk decoder in
 * rt_tr_read; rt_trc_msg gives the message of each. */
enum { RT_TRC_OK = 0, RT_TRC_TAG, RT_TRC_CLASS, RT_TRC_SAMEGEN, RT_TRC_GEN, RT_TRC_SHORT, RT_TRC_OVERFLOW, RT_TRC_SIZE0,
       RT_TRC_SAMECORE, RT_TRC_CORE, RT_TRC_SWITCH2 };
static inline const char *rt_trc_msg(int err)
{
    switch (err) {
    case RT_TRC_TAG: return "reserved tag bit set";
    case RT_TRC_CLASS: return "class out of range";
    case RT_TRC_SAMEGEN: return "generation byte repeats the current generation";
    case RT_TRC_GEN: return "generation above the header's";
    case RT_TRC_SHORT: return "record runs past the end of the chunk";
    case RT_TRC_OVERFLOW: return "varint overflow";
    case RT_TRC_SIZE0: return "size 0";
    case RT_TRC_SAMECORE: return "core switch to the current core";
    case RT_TRC_CORE: return "core switch above the header's cores";
    case RT_TRC_SWITCH2: return "core switch not followed by a reference";
    default: return "";
    }
}

/* Decodes one record from *pp (< end) with every check a reader makes
 * (rt_tr_read, and the side payloads' record groups alike) and advances
 * *pp past it; maxgen 0 = no generations (bit 7 reserved). RT_TRC_OK or
 * the error (*pp, *c and *out then unchanged). */
static inline __attribute__((always_inline)) int rt_trc_dec(const unsigned char **pp, const unsigned char *end,
                                                         rt_trc_coder *restrict c, unsigned maxgen,
                                                         rt_access *restrict out)
{
    const unsigned char *p = *pp;
    if (p == end) return RT_TRC_SHORT;
    unsigned t = *p++;
    unsigned cls = t & RT_TRC_TAG_CLASS, gen = c->gen;
    if (t & RT_TRC_TAG_GEN) {
        if (!maxgen) return RT_TRC_TAG;
        if (p == end) return RT_TRC_SHORT;
        gen = *p++;
        if (gen == c->gen) return RT_TRC_SAMEGEN;
        if (gen > maxgen) return RT_TRC_GEN;
    }
    if (cls >= RT_NCLASS) return RT_TRC_CLASS;
    uint64_t addr = c->addr[cls];
    uint32_t size = c->size[cls];
    if (t & RT_TRC_TAG_SEQ) addr += size;
    else {
        uint64_t z = 0;
        for (int sh = 0;; sh += 7) {
            if (p == end) return RT_TRC_SHORT;
            unsigned b = *p++;
            if (sh == 63 && b > 1) return RT_TRC_OVERFLOW;
            z |= (uint64_t)(b & 0x7f) << sh;
            if (!(b & 0x80)) break;
        }
        addr += (z >> 1) ^ (0 - (z & 1));
    }
    if (!(t & RT_TRC_TAG_SAMESIZE)) {
        uint64_t v = 0;
        for (int sh = 0;; sh += 7) {
            if (p == end) return RT_TRC_SHORT;
            unsigned b = *p++;
            if (sh == 28 && b > 0x0f) return RT_TRC_OVERFLOW;
            v |= (uint64_t)(b & 0x7f) << sh;
            if (!(b & 0x80)) break;
        }
        size = (uint32_t)v;
    }
    if (size == 0) return RT_TRC_SIZE0;
    c->addr[cls] = addr;
    c->size[cls] = size;
    c->gen = gen;
    out->addr = addr;
    out->size = size;
    out->write = (t & RT_TRC_TAG_WRITE) != 0;
    out->cls = (uint8_t)cls;
    out->gen = (uint8_t)gen;
    *pp = p;
    return RT_TRC_OK;
}

/* Version 4: one reference, after its core switch if one comes first
 * (ncores: the header's cores, 2..256); its core is c->core after the call. The errors of rt_trc_dec, and a
 * switch to the current core, to a core >= ncores, or followed by another
 * switch or by the chunk's end. */
static inline int rt_trc_dec4(const unsigned char **pp, const unsigned char *end, rt_trc_coder *restrict c,
                              unsigned maxgen, unsigned ncores, rt_access *restrict out)
{
    const unsigned char *p = *pp;
    if (p == end || *p != RT_TRC_SWITCH) return rt_trc_dec(pp, end, c, maxgen, out);
    if (end - p < 2) return RT_TRC_SHORT;
    const unsigned core = p[1], saved = c->core;
    if (core == saved) return RT_TRC_SAMECORE;
    if (core >= ncores) return RT_TRC_CORE;
    p += 2;
    if (p == end || *p == RT_TRC_SWITCH) return RT_TRC_SWITCH2;
    c->core = core;
    const int r = rt_trc_dec(&p, end, c, maxgen, out);
    if (r != RT_TRC_OK) {
        c->core = saved;
        return r;
    }
    *pp = p;
    return RT_TRC_OK;
}

/* A LEB128 varint of at most 10 bytes (the last holding one bit) from *pp;
 * -1 if it runs past end or overflows. */
static inline int rt_trc_get_varint(const unsigned char **pp, const unsigned char *end, uint64_t *v)
{
    const unsigned char *p = *pp;
    uint64_t z = 0;
    for (int sh = 0;; sh += 7) {
        if (p == end) return -1;
        unsigned b = *p++;
        if (sh == 63 && b > 1) return -1;
        z |= (uint64_t)(b & 0x7f) << sh;
        if (!(b & 0x80)) break;
    }
    *v = z;
    *pp = p;
    return 0;
}

#endif
