/*
 * din.h -- Dinero IV "din" text traces (module prefix rt_din_).
 *
 * The reader turns each "LABEL ADDRESS" line into a 1-byte rt_access of the
 * class given at open; the simulators replay din files through it and
 * `trace-dump --din` writes the format.
 */
#ifndef RT_DIN_H
#define RT_DIN_H

#include "memmodel.h"
#include "rt.h"

#include <stddef.h>
#include <stdint.h>

/* Din reader (din.c): opens a Dinero IV "label hexaddress" text file. */
typedef struct rt_din rt_din;
rt_din *rt_din_open(const char *path, int cls, rt_err *e);
/* Fills buf; returns records (> 0), 0 at end of file, -1 on a bad line
 * ("file:line: message"). Labels: 0 read, 1 write, 2 instruction fetch
 * (read); any other label is an error. Each record is a 1-byte reference. */
long rt_din_read(rt_din *d, rt_access *buf, size_t cap, rt_err *e);
uint64_t rt_din_file_hash(const rt_din *d); /* FNV-1a of the bytes read so far */
uint64_t rt_din_file_bytes(const rt_din *d);
void rt_din_close(rt_din *d);

#endif
