#!/bin/sh
# The treelet tracer from the command line: usage errors (exit 2, the
# option named) for a budget smaller than one node (from --cache-size or
# --gmax), a structure it cannot run on, a ray window of 0 and its options
# given to another tracer; render --json reports the treelets; a sweep
# lists one job per scheduled size with the run key's parameters.
set -u
bin=${RT_BIN:-./raytraffic}
tmp=$(mktemp -d /tmp/rt_treelet_cli.XXXXXX) || exit 1
trap 'rm -rf "$tmp"' EXIT
fail=0
err() { echo "FAIL: $*"; fail=1; }
[ -x "$bin" ] || { echo "FAIL: $bin is not an executable"; exit 1; }

usage() { # name, option the message must name, arguments...
    name=$1 opt=$2
    shift 2
    "$bin" render cornell -W 8 -H 8 -o "$tmp/a.exr" "$@" 2>"$tmp/e"
    rc=$?
    [ $rc -eq 2 ] || err "$name: exit $rc, want 2 ($(cat "$tmp/e"))"
    grep -q -- "$opt" "$tmp/e" || err "$name: message does not name $opt: '$(cat "$tmp/e")'"
    [ "$(wc -l <"$tmp/e")" -le 2 ] || err "$name: more than a line or two: $(cat "$tmp/e")"
}
usage "budget below a bvh4 node" --cache-size -t treelet --cache-size 200
usage "budget below a bvh2 node" --gmax -t treelet --accel bvh2 --gmax 31
usage "k-d tree" --accel -t treelet --accel kd
usage "grid" --accel -t treelet --accel grid
usage "window of 0" --ray-window -t treelet --ray-window 0
usage "window not a number" --ray-window -t treelet --ray-window many
usage "window for recursive" --ray-window --ray-window 64K
usage "treelet-tris for dynamic" --treelet-tris -t dynamic --treelet-tris

# the smallest budgets that hold a node run
"$bin" render cornell -t treelet --accel bvh2 --gmax 32 -W 8 -H 8 -o "$tmp/a.exr" 2>"$tmp/e" ||
    err "--gmax 32 on bvh2: $(cat "$tmp/e")"
"$bin" render cornell -t treelet --cache-size 256 -W 8 -H 8 -o "$tmp/a.exr" 2>"$tmp/e" ||
    err "--cache-size 256 on bvh4: $(cat "$tmp/e")"

# render --json: the treelets in the statistics; a bounded window
"$bin" render knot -t treelet --mode path --lights 0 --bounces 2 --ray-window 100 --cache-size 16K -W 16 -H 16 \
    --json -o "$tmp/a.exr" >"$tmp/j" 2>"$tmp/e" || err "render --json: $(cat "$tmp/e")"
for k in budget=8192 treelets= treelet_bytes_mean= treelet_bytes_max= treelet_depth= ray_window=100 \
    '"accel": "bvh4"' enqueues= stack_writes=; do
    grep -q -- "$k" "$tmp/j" || err "json lacks $k: $(cat "$tmp/j")"
done

# sweep: one job per size, the run key's parameters
"$bin" sweep --scenes knot --tracers treelet,recursive --accel bvh4 --modes path --lights 0 --bounces 1 --sizes 4K,64K \
    -W 16 -H 16 --ray-window 64K --db "$tmp/s.db" --list-jobs >"$tmp/l" 2>"$tmp/e" || err "list-jobs: $(cat "$tmp/e")"
# the recursive run and one treelet run per size, each carrying the window
[ "$(grep -c -- "--ray-window' '64K' --job" "$tmp/l")" -eq 3 ] || err "jobs: $(cat "$tmp/l")"
"$bin" sweep --scenes knot --tracers treelet,recursive --accel bvh4 --modes path --lights 0 --bounces 1 --sizes 4K,64K \
    -W 16 -H 16 --ray-window 64K --db "$tmp/s.db" >/dev/null 2>"$tmp/e" || err "sweep: $(cat "$tmp/e")"
n=$(sqlite3 "$tmp/s.db" "select count(*) from runs where tracer='treelet' and params like 'qorder=fullest ray_window=65536 mode=path%'" 2>/dev/null)
[ "$n" = 2 ] || err "treelet runs with their key: $n ($(sqlite3 "$tmp/s.db" 'select tracer, sched_size, params from runs'))"
s=$(sqlite3 "$tmp/s.db" "select count(*) from traffic t join runs r on r.id = t.run_id where r.tracer='treelet' and t.class = 'stream'")
[ "$s" -gt 0 ] || err "no stack traffic (class stream) in the database"

# the listed jobs run as shards and merged: the same runs and traffic as the sweep
while IFS= read -r line; do
    eval "$line" >/dev/null 2>"$tmp/e" || err "job: $line: $(cat "$tmp/e")"
done <"$tmp/l"
"$bin" db merge "$tmp/m.db" "$tmp"/s.job*.db 2>"$tmp/e" || err "merge: $(cat "$tmp/e")"
q="select r.tracer, r.sched_size, r.params, t.class, c.size, t.traffic_bytes from traffic t join runs r on r.id = t.run_id
    join cache_configs c on c.id = t.config_id order by 1, 2, 3, 4, 5"
[ -n "$(sqlite3 "$tmp/m.db" "$q")" ] || err "merged database is empty"
[ "$(sqlite3 "$tmp/m.db" "$q")" = "$(sqlite3 "$tmp/s.db" "$q")" ] || err "merged shards differ from the sweep"

# report --figure treelet: one table row per size, values from the database
"$bin" report --db "$tmp/s.db" --figure treelet >"$tmp/r" 2>"$tmp/e" || err "report: $(cat "$tmp/e")"
[ "$(grep -c '^| [0-9]*K |' "$tmp/r")" -eq 2 ] || err "report rows: $(cat "$tmp/r")"
grep -q "^### knot, mode=path spp=1 bounces=1, lights 0, 16x16, bvh4, qorder=fullest ray_window=65536" "$tmp/r" ||
    err "report group: $(cat "$tmp/r")"
grep -q "^Largest treelet saving: " "$tmp/r" || err "report summary: $(cat "$tmp/r")"
base=$(sqlite3 "$tmp/s.db" "select round(sum(t.traffic_bytes) / 1048576.0, 1) from traffic t join runs r on r.id = t.run_id
    join cache_configs c on c.id = t.config_id where r.tracer = 'recursive' and c.size = 4096 and c.line = 64 and c.assoc = 0
    and c.policy = 'wb-wa'")
grep -q "^| 4K | $base |" "$tmp/r" || err "report baseline at 4K is not $base: $(cat "$tmp/r")"
"$bin" report --db "$tmp/s.db" --figure treelet --format csv >"$tmp/c" 2>"$tmp/e" || err "report csv: $(cat "$tmp/e")"
[ "$(wc -l <"$tmp/c")" -eq 3 ] || err "report csv lines: $(cat "$tmp/c")"
"$bin" report --db "$tmp/s.db" --figure treelet --plot "$tmp/plots" >/dev/null 2>"$tmp/e" || err "report --plot: $(cat "$tmp/e")"
ls "$tmp/plots"/treelet-knot-path-l1-16x16-bvh4-*.dat >/dev/null 2>&1 || err "no plot data: $(ls "$tmp/plots")"
sqlite3 "$tmp/s.db" "delete from traffic where run_id in (select id from runs where tracer = 'treelet');
    delete from runs where tracer = 'treelet'"
"$bin" report --db "$tmp/s.db" --figure treelet >/dev/null 2>"$tmp/e"
[ $? -eq 1 ] || err "report without treelet runs: want exit 1"
grep -q "no treelet runs" "$tmp/e" || err "report without treelet runs: '$(cat "$tmp/e")'"

# bench --what treelet, smallest settings: per structure three ways a
# repetition, then their medians; the references per ray of both tracers
# are the counts a recording run of each gives; no trace file left behind
"$bin" bench --what treelet --scene knot -W 12 -H 10 --reps 2 --tmpdir "$tmp" >"$tmp/b" 2>"$tmp/e" ||
    err "bench --what treelet: $(cat "$tmp/e")"
[ "$(grep -cE '^\| bvh[48] \| (untraced|null sink|trace file) \| [12] \|' "$tmp/b")" -eq 12 ] ||
    err "bench --what treelet rows: $(cat "$tmp/b")"
[ "$(grep -cE '^\| bvh[48] \| (untraced|null sink|trace file) \| median \|' "$tmp/b")" -eq 6 ] ||
    err "bench --what treelet medians: $(cat "$tmp/b")"
for acc in bvh4 bvh8; do
    "$bin" trace knot -W 12 -H 10 --accel $acc -o "$tmp/br.rtt" >/dev/null 2>&1 || err "trace recursive $acc"
    "$bin" trace knot -W 12 -H 10 --accel $acc -t treelet -o "$tmp/bt.rtt" >/dev/null 2>&1 || err "trace treelet $acc"
    nr=$("$bin" trace-dump "$tmp/br.rtt" | wc -l)
    nt=$("$bin" trace-dump "$tmp/bt.rtt" | wc -l)
    want=$(awk -v r="$nr" -v t="$nt" 'BEGIN { printf "%.1f | %.1f", r / 120, t / 120 }')
    grep -qE "^\| $acc \| null sink \| 1 \| .* \| $want \|\$" "$tmp/b" ||
        err "bench --what treelet $acc refs/ray not $want: $(grep "$acc | null sink | 1" "$tmp/b")"
done
ls "$tmp"/rt-bench-treelet-* >/dev/null 2>&1 && err "bench --what treelet left a trace file in --tmpdir"
"$bin" bench --what treelet --scene knot -W 12 -H 10 --reps 1 --accel kd >/dev/null 2>"$tmp/e"
[ $? -eq 1 ] && grep -q "runs on a BVH" "$tmp/e" || err "bench --what treelet --accel kd: '$(cat "$tmp/e")'"
"$bin" bench --what treelet --scene knot -W 12 -H 10 --reps 1 --accel bvh2 >"$tmp/b" 2>"$tmp/e" ||
    err "bench --what treelet --accel bvh2: $(cat "$tmp/e")"
[ "$(grep -cE '^\| bvh2 \|' "$tmp/b")" -eq 6 ] && ! grep -qE '^\| bvh[48] \|' "$tmp/b" ||
    err "bench --what treelet --accel bvh2 rows: $(cat "$tmp/b")"

exit $fail
