/*
 * pool.h -- the sweep's worker pool (prefix rt_pool_): runs the jobs of an
 * experiment matrix in this process or in forked worker processes that
 * claim jobs from a shared counter, each with its own database connection
 * (rt_exp_worker), until every job is claimed, one fails, or a stop signal
 * (SIGTERM, SIGINT, SIGHUP) arrives.
 *
 * Guarantees: a job is claimed by exactly one worker; a run is stored in
 * one transaction (experiment.c), so a worker killed mid-job leaves no
 * partial row and a rerun of the same matrix resumes where it stopped; the
 * counts of the result agree with the database even after a stop signal
 * (a run is counted with the stop signals blocked from its commit:
 * rt_exp_config.on_stored); a stop signal reaching the parent stops every
 * worker (they die with the parent, PR_SET_PDEATHSIG on Linux).
 *
 * The library prints nothing: what a front end shows (a line per job, a
 * progress bar, a failed job's message) goes through the callbacks.
 */
#ifndef RT_POOL_H
#define RT_POOL_H

#include "experiment.h"

typedef struct rt_pool_opts {
    const char *db;   /* database path */
    int jobs;         /* worker processes (>= 1) */
    long only;        /* run only job K of the matrix, -1 = all */
    int tty;          /* 1: workers are children even when one, and progress() is called a few times a second */
    /* Test hooks (tests only): stop_after > 0 kills the pool (SIGKILL, as a
     * kill from outside would) once that many runs are stored; fail_job = K
     * makes job K fail in the middle of storing its run the first time,
     * i.e. when fail_marker can be created. -1 / 0: off. */
    long stop_after;
    long fail_job;
    const char *fail_marker;
    /* Reports, called in the worker or parent that sees the event (NULL:
     * none). job_done: a job finished, d of total, stored or already in the
     * database; job_failed: job i failed with e; progress: done/skipped of
     * total since t0 (tty only). */
    void (*job_done)(void *ctx, long d, long total, const char *label, int stored, double sec);
    void (*job_failed)(void *ctx, long i, const char *label, const rt_err *e);
    void (*progress)(void *ctx, long done, long skipped, long total, double t0);
    void *ctx;
} rt_pool_opts;

typedef struct rt_pool_result {
    long done;          /* jobs finished (run or skipped) */
    long skipped;       /* of which already in the database */
    int failed;         /* a job or worker failed */
    int usage;          /* a job failed because its options ask too much (rt_err.usage) */
    int stop_signal;    /* the stop signal that ended the pool, 0 = none */
    double stage_sec[4];/* scene, tracing, simulation, database seconds summed over workers */
} rt_pool_result;

/* Runs the matrix J[0..nj) of c (c->on_stored is set here). 0 when every
 * job ran or was found stored; -1 otherwise (r says why; e holds a failure
 * of the pool itself: mmap, fork, the first worker's database). */
int rt_pool_run(rt_exp_config *c, const rt_exp_job *J, long nj, const rt_pool_opts *po, rt_pool_result *r, rt_err *e);

/* A job's label for messages: "knot whitted all dynamic @64K [res:64]". */
void rt_pool_job_label(const rt_exp_config *c, const rt_exp_job *jb, char *buf, size_t n);

#endif
