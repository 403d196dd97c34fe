#!/bin/sh
# The job list on real engines (long tier only): `sweep --list-jobs` run by
# GNU parallel and as a Slurm array job on a private single-node Slurm
# (scripts/slurm-local.sh), then `db merge` of the shards, must equal a
# one-machine sweep row for row (timing and command columns aside). Job 3
# fails once in the middle of storing its run (RT_SWEEP_FAIL_JOB, a
# test-only hook): it leaves no shard (a sweep that stored nothing
# removes the database it made), the engine must report the failure, and
# resubmitting the same list must complete the matrix.
# The Slurm part is skipped, with a message, when Slurm cannot start here.
set -u
if [ "${RT_TEST_LONG:-0}" = 0 ]; then echo "SKIP: engines.sh runs in the long tier only (make check-long)"; exit 77; fi
bin=${RT_BIN:-./raytraffic}
src=${RT_SRCDIR:-.}
tmp=$(mktemp -d /tmp/rt-engines-XXXXXX)
slurm_dir="$tmp/slurm"
cleanup() {
    [ -d "$slurm_dir" ] && RT_SLURM_DIR="$slurm_dir" sh "$src/scripts/slurm-local.sh" stop >/dev/null 2>&1
    rm -rf "$tmp"
}
trap cleanup EXIT
trap 'exit 1' INT TERM HUP
fail=0
die() { echo "FAIL: $*"; fail=1; }
args="--scenes cornell,knot --lights primary,all --tracers recursive,dynamic -W 24 -H 20 --sizes 1K,4K,64K"
contents() { # every stored value but timings, the command line and dates
    sqlite3 "$1" "SELECT s.name, s.params, s.hash, s.triangles, s.path, s.abspath, r.tracer, r.W, r.H, r.lights,
        r.sched_size, r.gmax, r.params, r.sim_method, r.sim_params, r.trace_hash, r.refs, r.tool_version, r.git_rev,
        r.stats, c.size, c.line, c.assoc, c.policy, t.class, t.accesses, t.read_misses, t.write_misses, t.writebacks,
        t.wt_bytes, t.traffic_bytes
        FROM traffic t JOIN runs r ON r.id = t.run_id JOIN scenes s ON s.id = r.scene_id
        JOIN cache_configs c ON c.id = t.config_id ORDER BY 1, 2, 3, 7, 8, 9, 10, 11, 13, 14, 15, 21, 22, 23, 24, 25" |
        sed -E 's/[a-z_]*seconds=[0-9.e+-]*//g'
}
runs() { sqlite3 "$1" "SELECT COUNT(*) FROM runs" 2>/dev/null || echo missing; }
rows() { sqlite3 "$1" "SELECT COUNT(*) FROM traffic" 2>/dev/null || echo missing; }

"$bin" sweep $args --db "$tmp/one.db" 2>/dev/null || { echo "FAIL: one-machine sweep"; exit 1; }
contents "$tmp/one.db" > "$tmp/one.txt"
[ -s "$tmp/one.txt" ] || { echo "FAIL: empty reference"; exit 1; }

# check_engine NAME: shards NAME/s.job*.db merged equal the one-machine sweep
check_merge() {
    "$bin" db merge "$tmp/$1.db" "$tmp/$1"/s.job*.db 2>"$tmp/$1-merge.log" || die "$1: db merge: $(cat "$tmp/$1-merge.log")"
    contents "$tmp/$1.db" > "$tmp/$1.txt"
    cmp -s "$tmp/one.txt" "$tmp/$1.txt" || { die "$1: merged shards differ from the one-machine sweep"; diff "$tmp/one.txt" "$tmp/$1.txt" | head -5; }
}

# ---- GNU parallel ----------------------------------------------------------
if command -v parallel >/dev/null 2>&1; then
    mkdir -p "$tmp/par"
    (cd "$tmp/par" && "$bin" sweep $args --db s.db --list-jobs > jobs.txt) || die "parallel: --list-jobs"
    n=$(wc -l < "$tmp/par/jobs.txt")
    # run from another folder: the lines name every file absolutely
    (cd / && RT_SWEEP_FAIL_JOB="3:$tmp/par/failed-once" parallel --will-cite -j 2 < "$tmp/par/jobs.txt" \
        >/dev/null 2>"$tmp/par/run1.log")
    st=$?
    [ "$st" = 1 ] || die "parallel: want exit 1 (one job failed), got $st"
    [ -e "$tmp/par/failed-once" ] || die "parallel: job 3 was not made to fail"
    [ ! -e "$tmp/par/s.job0003.db" ] ||
        die "parallel: the failed job left a database: $(runs "$tmp/par/s.job0003.db") runs"
    [ "$(runs "$tmp/par/s.job0004.db")" = 1 ] || die "parallel: the other jobs did not run"
    (cd / && RT_SWEEP_FAIL_JOB="3:$tmp/par/failed-once" parallel --will-cite -j 2 < "$tmp/par/jobs.txt" \
        >/dev/null 2>"$tmp/par/run2.log") || die "parallel: resubmitted list failed: $(tail -n 3 "$tmp/par/run2.log")"
    [ "$(ls "$tmp/par"/s.job*.db | wc -l)" = "$n" ] || die "parallel: want $n shards"
    check_merge par
    echo "parallel: $n jobs, one failed and was rerun, merged = one machine"
else
    die "GNU parallel is not installed (apt-get install parallel; scripts/deps.sh --engines)"
fi

# ---- Slurm -----------------------------------------------------------------
if ! RT_SLURM_DIR="$slurm_dir" RT_SLURM_PORT=$((7100 + $$ % 500 * 2)) sh "$src/scripts/slurm-local.sh" start \
        >"$tmp/slurm-start.log" 2>&1; then
    echo "SKIP Slurm part: a private Slurm could not start here: $(tail -n 1 "$tmp/slurm-start.log")"
else
    export SLURM_CONF="$slurm_dir/slurm.conf"
    mkdir -p "$tmp/sl"
    (cd "$tmp/sl" && "$bin" sweep $args --db s.db --list-jobs > jobs.txt) || die "slurm: --list-jobs"
    n=$(wc -l < "$tmp/sl/jobs.txt")
    submit() { # the whole list as one array job; waits; sbatch's status
        (cd / && RT_SWEEP_FAIL_JOB="3:$tmp/sl/failed-once" sbatch --wait --array=1-"$n" -o "$tmp/sl/out-%a.txt" \
            --wrap "sh -c \"\$(sed -n \${SLURM_ARRAY_TASK_ID}p '$tmp/sl/jobs.txt')\"" >/dev/null 2>"$tmp/sl/sbatch.log")
    }
    submit
    st=$?
    [ "$st" != 0 ] || die "slurm: an array with a failing task reported success"
    [ -e "$tmp/sl/failed-once" ] || die "slurm: job 3 was not made to fail"
    [ ! -e "$tmp/sl/s.job0003.db" ] ||
        die "slurm: the failed job left a database: $(runs "$tmp/sl/s.job0003.db") runs"
    submit || die "slurm: resubmitted array failed: $(cat "$tmp/sl/sbatch.log")"
    [ "$(ls "$tmp/sl"/s.job*.db | wc -l)" = "$n" ] || die "slurm: want $n shards"
    check_merge sl
    echo "slurm: $n array tasks, one failed and was rerun, merged = one machine"
fi
[ $fail = 0 ] && echo "engines: ok"
exit $fail
