/*
 * pipe.h -- the two-thread pipeline of the trace replays (private to
 * cachesim/): a reader thread fills slots, the calling thread consumes them
 * in order. Used by the record replay (replay.c) and the sample-index
 * replay (approx.c). See the essay in pipe.c.
 */
#ifndef RT_PIPE_H
#define RT_PIPE_H

#include "rt.h"

#define RT_PIPE_MAXSLOTS 16

typedef struct rt_pipe_ops {
    /* Reader thread: fills slot s (0..nslots-1). > 0: a slot to consume;
     * 0: the end of the input; -1: an error, message in *e. Called again
     * only after a result > 0. */
    long (*produce)(void *ctx, unsigned s, rt_err *e);
    /* Calling thread: consumes slot s, whose produce result was n > 0.
     * 0, or -1 with *e to stop the pipeline. */
    int (*consume)(void *ctx, unsigned s, long n, rt_err *e);
    void *ctx;
    unsigned nslots; /* 2..RT_PIPE_MAXSLOTS */
} rt_pipe_ops;

/* Runs the pipeline to its end: 0 after produce returned 0 and every slot
 * before it was consumed; -1 with the first error in order (the reader's
 * error reaches the caller after every slot produced before it). 1 when
 * the reader thread could not be started: nothing was produced, and the
 * caller should run the work on its own thread. */
int rt_pipe_run(const rt_pipe_ops *ops, rt_err *e);

#endif
