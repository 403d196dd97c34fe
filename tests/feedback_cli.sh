#!/bin/sh
# The feedback tracer end to end: usage errors (exit 2) for an unknown
# --accel, the path mode and a vertex buffer too small (the message gives
# the size needed); a run prints its passes, S_VB and stage shares in the
# --json statistics; --heatmap writes a PNG. A tiny sweep of the tracer
# (knot 32x32, whitted depth 2, one light): one run per option set, the
# feedback options in the run key only when not the default (record stores:
# write-allocate adds a fetch per record written), the same run
# through --list-jobs, and no run added on a rerun.
set -u
bin=${RT_BIN:-./raytraffic}
tmp=$(mktemp -d /tmp/rt_feedback_cli.XXXXXX) || exit 1
trap 'rm -rf "$tmp"' EXIT
fail=0
err() { echo "FAIL: $*"; fail=1; }
[ -x "$bin" ] || { echo "FAIL: $bin is not an executable"; exit 1; }

"$bin" render cornell -t feedback --accel bvh -W 8 -H 8 -o "$tmp/a.exr" 2>"$tmp/e1"
[ $? -eq 2 ] || err "--accel bvh: want exit 2"
grep -q "accel" "$tmp/e1" || err "--accel bvh: message '$(cat "$tmp/e1")'"

"$bin" render cornell -t feedback --record-stores none -W 8 -H 8 -o "$tmp/a.exr" 2>"$tmp/e4"
[ $? -eq 2 ] || err "--record-stores none: want exit 2"
grep -q "record-stores" "$tmp/e4" || err "--record-stores: message '$(cat "$tmp/e4")'"

"$bin" render cornell -t feedback --mode path -W 8 -H 8 -o "$tmp/a.exr" 2>"$tmp/e2"
[ $? -eq 2 ] || err "--mode path: want exit 2"
grep -q "path" "$tmp/e2" || err "--mode path: message '$(cat "$tmp/e2")'"

# 16 x 16, shadows and one bounce: 16 * 16 * (2 + 1) * 64 = 49152 bytes
"$bin" render cornell:material=mirror -t feedback --mode whitted --depth 2 --lights 0 -W 16 -H 16 \
    --vb-size 49151 -o "$tmp/a.exr" 2>"$tmp/e3"
[ $? -eq 2 ] || err "--vb-size too small: want exit 2"
grep -q "49152 bytes" "$tmp/e3" || err "--vb-size: message '$(cat "$tmp/e3")'"

"$bin" render cornell:material=mirror -t feedback --mode whitted --depth 2 --lights 0 -W 16 -H 16 \
    --vb-size 49152 --json --heatmap "$tmp/h.png" -o "$tmp/a.exr" >"$tmp/j" 2>/dev/null
[ $? -eq 0 ] || err "--vb-size 49152: want exit 0"
grep -q '"tracer": "feedback"' "$tmp/j" || err "json: $(cat "$tmp/j")"
grep -q 'passes=3 composite=eq1 svb=49152 G=2 G2=1' "$tmp/j" || err "json extra: $(cat "$tmp/j")"
grep -q 'modeled_share_vs=' "$tmp/j" || err "no modeled stage shares"
[ "$(head -c 8 "$tmp/h.png" | od -An -c | tr -d ' ')" = "211PNG\r\n032\n" ] || err "heat map is not a PNG"

# sweep: one run per accel/grid-min choice, keys as rt_job_params writes them
sw="--scenes knot --tracers feedback --modes whitted --depth 2 --lights 0 -W 32 -H 32 --sizes 4K,64K"
"$bin" sweep $sw --db "$tmp/s.db" 2>"$tmp/s1" || err "sweep: $(cat "$tmp/s1")"
grep -q "1 run(s) (1 scenes x 1 lightings x 1 tracers, 2 sizes)" "$tmp/s1" || err "sweep matrix: $(cat "$tmp/s1")"
"$bin" sweep $sw --accel naive --db "$tmp/s.db" 2>/dev/null || err "sweep --accel naive"
"$bin" sweep $sw --grid-min 16 --db "$tmp/s.db" 2>/dev/null || err "sweep --grid-min 16"
"$bin" sweep $sw --grid-min 16 --db "$tmp/s.db" 2>"$tmp/s2" || err "sweep rerun"
"$bin" sweep $sw --record-stores write-allocate --db "$tmp/s.db" 2>/dev/null || err "sweep --record-stores"
"$bin" sweep $sw --grid-density 4 --db "$tmp/s.db" 2>/dev/null || err "sweep --grid-density"
grep -q "(1 already in the database)" "$tmp/s2" || err "rerun did not skip: $(cat "$tmp/s2")"
keys=$(sqlite3 "$tmp/s.db" "SELECT params FROM runs WHERE tracer = 'feedback' ORDER BY id" | tr '\n' '|')
[ "$keys" = "mode=whitted depth=2|accel=naive mode=whitted depth=2|grid_min=16 mode=whitted depth=2|record_stores=write-allocate mode=whitted depth=2|grid_density=4 mode=whitted depth=2|" ] ||
    err "sweep run keys: '$keys'"
# the records' stores: write-allocate fetches a line per record written (64 B x writes more traffic),
# non-temporal fetches none; same records, same statistics
d=$(sqlite3 "$tmp/s.db" "SELECT (SELECT t.traffic_bytes FROM traffic t JOIN runs r ON r.id = t.run_id JOIN cache_configs c ON c.id = t.config_id WHERE r.params = 'record_stores=write-allocate mode=whitted depth=2' AND t.class = 'stream' AND c.size = 4096 AND c.assoc = 0) - (SELECT t.traffic_bytes FROM traffic t JOIN runs r ON r.id = t.run_id JOIN cache_configs c ON c.id = t.config_id WHERE r.params = 'mode=whitted depth=2' AND t.class = 'stream' AND c.size = 4096 AND c.assoc = 0)")
w=$(sqlite3 "$tmp/s.db" "SELECT stats FROM runs WHERE params = 'mode=whitted depth=2'" | sed -n 's/.*gs_emitted=\([0-9]*\).*/\1/p')
[ -n "$w" ] && [ "$d" = "$((64 * (w + 1024)))" ] || err "record stores: write-allocate adds $d bytes, want 64 x ($w + 1024)"
[ "$(sqlite3 "$tmp/s.db" "SELECT stats FROM runs WHERE params IN ('mode=whitted depth=2', 'record_stores=write-allocate mode=whitted depth=2')" |
      sed -E 's/[a-z_]*seconds=[0-9.e+-]*//g' | sort -u | wc -l)" = 1 ] || err "record stores changed the statistics"
# 32 x 32 pixels, E = 1, 2, 1: S_VB = 1024 * 3 * 64; passes and records as the render prints them
n=$(sqlite3 "$tmp/s.db" "SELECT COUNT(*) FROM runs WHERE stats LIKE '%passes=3 composite=eq1 svb=196608 G=2 G2=1 E=1,2,1 %'")
[ "$n" = 5 ] || err "sweep stats: $n of 5 runs with passes=3 svb=196608"
"$bin" render knot -t feedback --mode whitted --depth 2 --lights 0 -W 32 -H 32 --grid-min 16 --json \
    -o "$tmp/k.exr" >"$tmp/kj" 2>/dev/null || err "render knot"
rin=$(sed -n 's/.*\(records_in=[0-9,]* records_out=[0-9,]*\).*/\1/p' "$tmp/kj")
[ -n "$rin" ] && [ "$(sqlite3 "$tmp/s.db" "SELECT COUNT(*) FROM runs WHERE params LIKE 'grid_min=16%' AND stats LIKE '%$rin %'")" = 1 ] ||
    err "sweep and render disagree on records ($rin)"
# the naive run tests every triangle: more tests than the grid's
t=$(sqlite3 "$tmp/s.db" "SELECT (SELECT refs FROM runs WHERE params LIKE 'accel=naive%') > 10 * (SELECT refs FROM runs WHERE params = 'mode=whitted depth=2')")
[ "$t" = 1 ] || err "naive run not heavier than the grid run"
# every class of the tracer at both sizes, traffic of the 64-byte records in class stream
c=$(sqlite3 "$tmp/s.db" "SELECT group_concat(class) FROM (SELECT DISTINCT t.class FROM traffic t JOIN runs r ON r.id = t.run_id WHERE r.params = 'mode=whitted depth=2' ORDER BY t.class)")
[ "$c" = "fb,index,node,shade,stream,tri" ] || err "sweep classes: '$c'"
# --list-jobs: one command carrying the feedback options; it stores the same run
"$bin" sweep $sw --grid-min 16 --accel naive --db "$tmp/l.db" --list-jobs >"$tmp/jobs" || err "list-jobs"
[ "$(wc -l <"$tmp/jobs")" = 1 ] || err "list-jobs: $(cat "$tmp/jobs")"
grep -q "'--grid-min' '16' '--accel' 'naive'" "$tmp/jobs" || err "list-jobs lost the options: $(cat "$tmp/jobs")"
sh "$tmp/jobs" 2>/dev/null || err "running the listed job" # names the binary by its absolute path
k=$(sqlite3 "$tmp/l.job0000.db" "SELECT params FROM runs" 2>/dev/null)
[ "$k" = "accel=naive grid_min=16 mode=whitted depth=2" ] || err "listed job's key: '$k'"
exit $fail
