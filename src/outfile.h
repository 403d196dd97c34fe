/*
 * outfile.h -- every output file raytraffic writes goes through here.
 *
 * An output is opened with rt_out_open, written through the stdio stream
 * rt_out_stream returns, and ended with rt_out_commit (keep it) or
 * rt_out_abort (throw it away). Whatever happens, the target path holds
 * either its previous content or one complete new output, never a partial
 * one; the rules are in outfile.c.
 */
#ifndef RT_OUTFILE_H
#define RT_OUTFILE_H

#include <stdio.h>

#include "rt.h"

typedef struct rt_out rt_out;

/* Opens an output for path. Returns NULL and sets e when path is a
 * directory, a symlink loop, or the temporary cannot be created. */
rt_out *rt_out_open(const char *path, rt_err *e);

/* The stream to write to (owned by o; do not fclose it). */
FILE *rt_out_stream(rt_out *o);

/* fwrite of n bytes to the output's stream that remembers why a short
 * write failed (errno, e.g. ENOSPC), so rt_out_commit reports that reason
 * rather than a generic I/O error when stdio has already dropped the
 * buffer. 0, or -1 (the commit will fail too). */
int rt_out_write(rt_out *o, const void *p, size_t n);

/* The path given to rt_out_open, for messages. */
const char *rt_out_path(const rt_out *o);

/* Flushes, syncs and closes the output and renames the temporary over the
 * target. Always frees o. 0, or -1 with "path: reason" (any write error
 * since rt_out_open counts) and the temporary removed. */
int rt_out_commit(rt_out *o, rt_err *e);

/* Closes o and removes its temporary; the target is untouched (an
 * in-place device or FIFO keeps what was written). Accepts NULL. */
void rt_out_abort(rt_out *o);

/* Checks, before any work, that path could be written as rt_out_open
 * would (its folder takes a temporary; it is not a directory): opens and
 * aborts one. 0, or -1 with e set. */
int rt_out_probe(const char *path, rt_err *e);

/* Unlinks the temporaries of all outputs still open. Async-signal-safe:
 * for a handler of SIGINT/SIGTERM that then re-raises the signal. */
void rt_out_remove_temporaries(void);

/* Test hook: when >= 0, each output fails with ENOSPC after this many
 * bytes have been written to it (-1, the default, disables). */
extern long long rt_out_fail_after;

#endif
