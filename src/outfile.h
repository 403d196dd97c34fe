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

/* ---- the one rule for every file a command writes or reads as a database --
 *
 * rt_open_target classifies path before anything is opened, so no command
 * ever blocks on a FIFO, reads a device as a database, or creates a file
 * beside something that is not a regular file (SQLite's "-journal", "-wal"
 * and "-shm" beside /dev/null, rt_out's temporary beside a device):
 *
 *   - the name must be a file name: not empty; for the two database kinds
 *     not ":memory:" nor any name beginning with ':' (SQLite keeps those in
 *     memory or in a temporary file: results stored nowhere). These are
 *     usage errors (e->usage = 1; front ends exit 2);
 *   - symbolic links are followed (40 levels at most) and the rules apply
 *     to their target;
 *   - a directory is always an error;
 *   - RT_TARGET_OUTPUT (an -o file): regular, absent, or an existing device,
 *     FIFO or socket, which is written in place (rt_out_open's rule 3);
 *   - RT_TARGET_DB (a database that may be written): regular or absent, and
 *     when absent its folder must exist;
 *   - RT_TARGET_DB_READ (a database only read): an existing regular file.
 *
 * Returns what path is (RT_TARGET_ABSENT, RT_TARGET_REGULAR, or
 * RT_TARGET_STREAM for an in-place output), or -1 with "PATH: reason" in
 * e. The check is on the name; a file swapped for a FIFO between the check
 * and SQLite's open is not covered (nothing in raytraffic does that). */
enum { RT_TARGET_OUTPUT, RT_TARGET_DB, RT_TARGET_DB_READ };
enum { RT_TARGET_ABSENT, RT_TARGET_REGULAR, RT_TARGET_STREAM };
int rt_open_target(const char *path, int kind, rt_err *e);

/* Removes the temporaries rt_out_open left in folder dir when its process
 * died without cleaning up (kill -9, a power cut): the files named
 * ".NAME.XXXXXX" (six characters of mkstemp's alphabet) for which
 * match(NAME) is non-zero, that are regular files, and that no live
 * process holds: rt_out_open keeps an exclusive flock on each temporary
 * while it is open, so a temporary whose lock can be taken belongs to a
 * dead writer. Other files are never touched. The number removed (>= 0),
 * or -1 with e set when dir cannot be read. */
long rt_out_remove_stale(const char *dir, int (*match)(const char *name), rt_err *e);

/* Unlinks the temporaries of all outputs still open. Async-signal-safe:
 * for a handler of SIGINT/SIGTERM that then re-raises the signal. */
void rt_out_remove_temporaries(void);

/* Test hook: when >= 0, each output fails with ENOSPC after this many
 * bytes have been written to it (-1, the default, disables). */
extern long long rt_out_fail_after;

#endif
