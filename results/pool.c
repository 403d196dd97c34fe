/* pool.c -- the sweep's worker pool (see pool.h). */
#include "pool.h"
#include "db.h"
#include "outfile.h"

#include <errno.h>
#include <inttypes.h>
#include <signal.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <sys/wait.h>
#include <unistd.h>
#ifdef __linux__
#include <sys/prctl.h>
#endif

/* State the workers share (an anonymous shared mapping). */
typedef struct shared {
    atomic_long next;     /* next job to claim */
    atomic_long done;     /* jobs finished (run or skipped) */
    atomic_long skipped;  /* of which skipped */
    atomic_long stored;   /* of which run and stored */
    atomic_int failed;    /* a worker failed */
    atomic_int usage;     /* a job failed because its options ask too much */
    atomic_llong stage_us[4]; /* rt_exp_stages summed over workers, microseconds */
} shared;

void rt_pool_job_label(const rt_exp_config *o, const rt_exp_job *jb, char *buf, size_t n)
{
    char px[64] = "";
    if (jb->proxy >= 0) {
        const rt_exp_proxy *p = &o->proxies[jb->proxy];
        if (p->W) snprintf(px, sizeof px, " [res:%d]", p->W);
        else snprintf(px, sizeof px, " [sub:%u:%d]", (unsigned)p->subsample, p->subtile);
    }
    char li[96], ln[48];
    /* the lights as names (rt_exp_lights_name), the one spelling */
    rt_exp_lights_name(jb->lighting >= 0 ? o->lightings[jb->lighting].mask : 0, ln, sizeof ln);
    if (jb->mode == RT_MODE_WHITTED || jb->mode == RT_MODE_PATH)
        snprintf(li, sizeof li, "%s lights %s", rt_render_mode_name(jb->mode), ln);
    else
        snprintf(li, sizeof li, "lights %s", ln);
    char tr[96];
    snprintf(tr, sizeof tr, "%s%s%s", jb->tracer, jb->accel != RT_ACCEL_DEFAULT ? "/" : "",
             jb->accel != RT_ACCEL_DEFAULT ? rt_accel_name(jb->accel) : "");
    if (jb->sched_size)
        snprintf(buf, n, "%s %s %s @%" PRIu64 "K%s", o->scenes[jb->scene], li, tr, jb->sched_size / 1024, px);
    else
        snprintf(buf, n, "%s %s %s%s", o->scenes[jb->scene], li, tr, px);
}

/* Test hook: stop_after stored runs, die as a kill from outside would. */
static void maybe_stop(const rt_pool_opts *o, shared *sh)
{
    if (o->stop_after > 0 && atomic_load(&sh->stored) >= o->stop_after) raise(SIGKILL);
}

/* Test hook: job fail_job fails in the middle of storing its run the first
 * time (fail_marker created exclusively: once, even across processes). */
static void maybe_fail(const rt_pool_opts *o, long i)
{
    if (o->fail_job != i || !o->fail_marker) return;
    FILE *f = fopen(o->fail_marker, "wx");
    if (!f) return;
    fclose(f);
    rt_db_fail_row_after = 2;
}

/* rt_exp_config.on_stored: a job's exact run is in the database. Runs with
 * the stop signals blocked, so the result's count is the database's. */
static void on_job_stored(void *arg)
{
    shared *sh = arg;
    atomic_fetch_add(&sh->stored, 1);
    atomic_fetch_add(&sh->done, 1);
}

/* pre: a worker made and preloaded before the fork (its scene and tree
 * shared by all workers), or NULL: each worker loads its own. */
static int worker_loop(const rt_exp_config *c, const rt_exp_job *J, long nj, const rt_pool_opts *o, shared *sh,
                       rt_exp_worker *pre, rt_err *e)
{
    rt_db *db = rt_db_open(o->db, e);
    rt_exp_worker *w = !db ? NULL : pre ? pre : rt_exp_worker_new(c, db, e);
    if (!w) {
        atomic_store(&sh->failed, 1);
        rt_db_close(db);
        return -1;
    }
    if (pre) rt_exp_worker_set_db(w, db);
    int rc = 0;
    const long total = o->only >= 0 ? 1 : nj;
    for (;;) {
        if (atomic_load(&sh->failed)) break;
        maybe_stop(o, sh);
        long i = o->only >= 0 ? (atomic_fetch_add(&sh->next, 1) == 0 ? o->only : nj) : atomic_fetch_add(&sh->next, 1);
        if (i >= nj) break;
        double t0 = rt_now();
        maybe_fail(o, i);
        rt_err je = {0};
        int r = rt_exp_run_job(w, &J[i], i, &je);
        char label[256];
        rt_pool_job_label(c, &J[i], label, sizeof label);
        if (r < 0) {
            if (o->job_failed) o->job_failed(o->ctx, i, label, &je);
            if (je.usage) atomic_store(&sh->usage, 1);
            atomic_store(&sh->failed, 1);
            rc = -1;
            break;
        }
        /* a run job was counted by on_job_stored when its run was committed */
        long d = r ? atomic_load(&sh->done) : (atomic_fetch_add(&sh->skipped, 1), atomic_fetch_add(&sh->done, 1) + 1);
        if (!o->tty && o->job_done) o->job_done(o->ctx, d, total, label, r != 0, rt_now() - t0);
        if (o->only >= 0) break;
    }
    maybe_stop(o, sh);
    rt_exp_stages t;
    rt_exp_worker_stages(w, &t);
    double sec[4] = {t.scene, t.tracing, t.simulation, t.database};
    for (int k = 0; k < 4; k++) atomic_fetch_add(&sh->stage_us[k], (long long)(sec[k] * 1e6));
    if (!pre) rt_exp_worker_free(w); /* the shared one is the parent's to free */
    rt_db_close(db);
    return rc;
}

/* The signal that asked the pool to stop (0 = none); set by the handler
 * the parent installs while it has workers. */
static volatile sig_atomic_t stop_signal;

static void on_stop_signal(int sig) { stop_signal = sig; }

static const int stop_signals[] = {SIGTERM, SIGINT, SIGHUP};

/* Installs (on = 1) or restores (on = 0) the parent's handlers for the
 * stop signals. No SA_RESTART: waitpid returns EINTR so the parent acts. */
static void catch_stop_signals(int on, struct sigaction *saved)
{
    for (int i = 0; i < 3; i++) {
        if (on) {
            struct sigaction sa;
            memset(&sa, 0, sizeof sa);
            sa.sa_handler = on_stop_signal;
            sigemptyset(&sa.sa_mask);
            sigaction(stop_signals[i], &sa, &saved[i]);
        } else {
            sigaction(stop_signals[i], &saved[i], NULL);
        }
    }
}

/* In a new worker: default signal handling, and death with the parent. */
static void worker_init(pid_t parent, const struct sigaction *saved)
{
    for (int i = 0; i < 3; i++) sigaction(stop_signals[i], &saved[i], NULL);
#ifdef __linux__
    prctl(PR_SET_PDEATHSIG, SIGTERM);
#endif
    if (getppid() != parent) _exit(1); /* the parent died before prctl took effect */
}

static int run_workers(const rt_exp_config *c, const rt_exp_job *J, long nj, const rt_pool_opts *o, shared *sh,
                       long total, double t0, rt_err *e)
{
    int tty = o->tty, rc = 0;
    int nw = o->jobs < total ? o->jobs : (int)total;
    if (nw <= 1 && !tty) return worker_loop(c, J, nj, o, sh, NULL, e);
    /* a terminal: even one worker is a child, so progress is reported here */
    if (nw < 1) nw = 1;
    if (nw > 256) nw = 256;
    /* one scene for every job: load it and its tree once, here, so the
     * workers share their pages instead of each building a copy */
    rt_exp_worker *pre = NULL;
    if (nw > 1 && o->only < 0) {
        double ts = rt_now();
        pre = rt_exp_worker_new(c, NULL, e);
        int pr = pre ? rt_exp_worker_preload(pre, J, nj, e) : -1;
        if (pr <= 0) {
            rt_exp_worker_free(pre);
            pre = NULL;
            if (pr < 0) {
                atomic_store(&sh->failed, 1);
                return -1;
            }
        } else {
            atomic_fetch_add(&sh->stage_us[0], (long long)((rt_now() - ts) * 1e6));
        }
    }
    pid_t pids[256], parent = getpid();
    struct sigaction saved[3];
    stop_signal = 0;
    catch_stop_signals(1, saved);
    for (int k = 0; k < nw; k++) {
        pids[k] = fork();
        if (pids[k] == 0) {
            worker_init(parent, saved);
            rt_err we = {0};
            int wr = worker_loop(c, J, nj, o, sh, pre, &we);
            if (wr < 0 && we.msg[0] && o->job_failed) o->job_failed(o->ctx, -1, "", &we);
            _exit(wr < 0 ? 1 : 0);
        }
        if (pids[k] < 0) {
            rt_errf(e, "fork: %s", strerror(errno));
            atomic_store(&sh->failed, 1);
            nw = k;
            rc = -1;
            break;
        }
    }
    int alive = nw, forwarded = 0;
    while (alive > 0) {
        int status;
        if (stop_signal && !forwarded) {
            /* stop: no new job is claimed, running ones are killed (their
             * open transaction leaves nothing); wait for every worker */
            atomic_store(&sh->failed, 1);
            for (int k = 0; k < nw; k++)
                if (pids[k] > 0) kill(pids[k], SIGTERM);
            forwarded = 1;
            rc = -1;
        }
        pid_t p = tty ? waitpid(-1, &status, WNOHANG) : waitpid(-1, &status, 0);
        if (p > 0) {
            alive--;
            for (int k = 0; k < nw; k++)
                if (pids[k] == p) pids[k] = 0;
            if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) rc = -1;
        } else if (p == 0) {
            if (o->progress) o->progress(o->ctx, atomic_load(&sh->done), atomic_load(&sh->skipped), total, t0);
            usleep(250000);
        } else if (errno != EINTR) {
            break;
        }
    }
    catch_stop_signals(0, saved);
    rt_exp_worker_free(pre);
    if (tty && o->progress) o->progress(o->ctx, atomic_load(&sh->done), atomic_load(&sh->skipped), total, t0);
    return rc;
}

/* 1 if name is a kept trace's file name as experiment.c's open_trace
 * makes it: "job", at least four digits, '-', anything, ".rtt". */
static int kept_trace_name(const char *name)
{
    size_t n = strlen(name), d = 0;
    if (strncmp(name, "job", 3) != 0) return 0;
    while (name[3 + d] >= '0' && name[3 + d] <= '9') d++;
    return d >= 4 && name[3 + d] == '-' && n > 3 + d + 1 + 4 && strcmp(name + n - 4, ".rtt") == 0;
}

int rt_pool_run(rt_exp_config *c, const rt_exp_job *J, long nj, const rt_pool_opts *po, rt_pool_result *r, rt_err *e)
{
    memset(r, 0, sizeof *r);
    /* a sweep killed with SIGKILL (no handler runs) left the temporaries of
     * the traces it was writing: remove those of dead writers, of the kept
     * traces' naming only, in that folder only (live writers hold a lock) */
    if (c->keep && rt_out_remove_stale(c->keep, kept_trace_name, e) < 0) return -1;
    shared *sh = mmap(NULL, sizeof *sh, PROT_READ | PROT_WRITE, MAP_SHARED | MAP_ANONYMOUS, -1, 0);
    if (sh == MAP_FAILED) return rt_errf(e, "mmap: %s", strerror(errno));
    atomic_init(&sh->next, 0);
    atomic_init(&sh->done, 0);
    atomic_init(&sh->skipped, 0);
    atomic_init(&sh->stored, 0);
    atomic_init(&sh->failed, 0);
    atomic_init(&sh->usage, 0);
    for (int k = 0; k < 4; k++) atomic_init(&sh->stage_us[k], 0);
    c->on_stored = on_job_stored;
    c->on_stored_arg = sh;
    long total = po->only >= 0 ? 1 : nj;
    int rc = run_workers(c, J, nj, po, sh, total, rt_now(), e);
    r->done = atomic_load(&sh->done);
    r->skipped = atomic_load(&sh->skipped);
    r->failed = atomic_load(&sh->failed) || rc < 0;
    r->usage = atomic_load(&sh->usage);
    r->stop_signal = (int)stop_signal;
    for (int k = 0; k < 4; k++) r->stage_sec[k] = (double)atomic_load(&sh->stage_us[k]) * 1e-6;
    c->on_stored = NULL;
    c->on_stored_arg = NULL;
    munmap(sh, sizeof *sh);
    return rc < 0 || r->done < total ? -1 : 0;
}
