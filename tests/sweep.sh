#!/bin/sh
# The sweep and report: a tiny sweep matches a golden report; rerunning adds
# no rows; a sweep stopped after 5 runs and rerun ends with the same contents as an
# uninterrupted one; db merge of shards equals a one-process sweep; --jobs 2
# equals --jobs 1. Set RT_REDO_GOLDEN=1 to regenerate the golden report.
set -u
bin=${RT_BIN:-./raytraffic}
src=${RT_SRCDIR:-.}
golden="$src/tests/golden/sweep_report.md"
tmp=$(mktemp -d /tmp/rt-sweep-XXXXXX)
trap 'rm -rf "$tmp"' EXIT
fail=0
args="--scenes cornell:glass=0,knot --lights primary,0,all -W 24 -H 20 --sizes 1K,4K,64K"
contents() { # the database's results, without volatile provenance
    sqlite3 "$1" "SELECT s.name, s.hash, r.tracer, r.W, r.H, r.lights, r.sched_size, r.params, r.refs, r.stats,
        c.size, t.class, t.accesses, t.read_misses, t.write_misses, t.writebacks, t.traffic_bytes
        FROM traffic t JOIN runs r ON r.id = t.run_id JOIN scenes s ON s.id = r.scene_id
        JOIN cache_configs c ON c.id = t.config_id
        ORDER BY s.name, r.tracer, r.lights, r.sched_size, c.size, t.class" |
        sed -e 's/render_seconds=[0-9.]*//' -e 's/sim_seconds=[0-9.]*//'
}
# 1. golden report
"$bin" sweep $args --db "$tmp/a.db" 2>"$tmp/log" || { echo "FAIL: sweep"; cat "$tmp/log"; exit 1; }
# the summary's revision, date and command are the run's own: masked
"$bin" report --db "$tmp/a.db" | sed -e "s#$tmp/a.db#DB#g" -e 's/^- Revision: .*/- Revision: REV/' \
    -e 's/^- Date: .*/- Date: DATE/' -e 's/^- Command: `[^ ]* /- Command: `BIN /' > "$tmp/report.md" ||
    { echo "FAIL: report"; fail=1; }
if [ "${RT_REDO_GOLDEN:-0}" = 1 ]; then cp "$tmp/report.md" "$golden"; echo "regenerated $golden"; fi
diff -u "$golden" "$tmp/report.md" || { echo "FAIL: report differs from $golden"; fail=1; }
"$bin" report --db "$tmp/a.db" --format csv --out "$tmp/csv" 2>/dev/null || { echo "FAIL: csv report"; fail=1; }
"$bin" report --db "$tmp/a.db" --compare-paper >/dev/null || { echo "FAIL: compare-paper"; fail=1; }
# 2. rerun adds nothing
n1=$(sqlite3 "$tmp/a.db" "SELECT COUNT(*) FROM runs; SELECT COUNT(*) FROM traffic" | tr '\n' ' ')
"$bin" sweep $args --db "$tmp/a.db" 2>"$tmp/log2" || { echo "FAIL: rerun"; fail=1; }
n2=$(sqlite3 "$tmp/a.db" "SELECT COUNT(*) FROM runs; SELECT COUNT(*) FROM traffic" | tr '\n' ' ')
[ "$n1" = "$n2" ] || { echo "FAIL: rerun changed row counts: $n1 -> $n2"; fail=1; }
grep -q "already in the database" "$tmp/log2" || { echo "FAIL: rerun did not skip"; fail=1; }
# the last line: wall time and the per-stage split, summed over workers; the
# stages of one worker fit in its wall time (of two, in twice), and a rerun
# that skips every job neither traces nor simulates
stages() { # prints "wall scene tracing simulation database" of the sweep's last line
    sed -n 's/^sweep: [0-9]* run(s) finished ([0-9]* already in the database) in \([0-9.]*\) s wall; results in .*; stages: scene \([0-9.]*\) s, tracing \([0-9.]*\) s, simulation \([0-9.]*\) s, database \([0-9.]*\) s (summed over workers)$/\1 \2 \3 \4 \5/p' "$1"
}
set -- $(stages "$tmp/log")
[ $# = 5 ] && awk -v w="$1" -v a="$2" -v b="$3" -v c="$4" -v d="$5" 'BEGIN { exit !(a + b + c + d <= w + 0.25) }' ||
    { echo "FAIL: sweep's stage line: $(tail -n 1 "$tmp/log")"; fail=1; }
set -- $(stages "$tmp/log2")
[ $# = 5 ] && [ "$3 $4" = "0.0 0.0" ] || { echo "FAIL: rerun's stage line: $(tail -n 1 "$tmp/log2")"; fail=1; }
contents "$tmp/a.db" > "$tmp/a.txt"
# 3. interrupted for certain, then rerun: RT_SWEEP_STOP_AFTER (a test-only
# hook) kills the sweep with SIGKILL after 5 stored runs, as a kill would
total=$(sqlite3 "$tmp/a.db" "SELECT COUNT(*) FROM runs")
RT_SWEEP_STOP_AFTER=5 "$bin" sweep $args --db "$tmp/k.db" 2>/dev/null
st=$?
[ "$st" -ne 0 ] || { echo "FAIL: stopped sweep exited 0"; fail=1; }
c=$(sqlite3 "$tmp/k.db" "SELECT COUNT(*) FROM runs")
[ "$c" = 5 ] && [ "$c" -lt "$total" ] || { echo "FAIL: interrupted sweep stored $c runs, want 5 of $total"; fail=1; }
"$bin" sweep $args --db "$tmp/k.db" 2>"$tmp/log3" || { echo "FAIL: resume after kill"; fail=1; }
grep -q "(5 already in the database)" "$tmp/log3" || { echo "FAIL: resume did not skip the 5 stored runs"; cat "$tmp/log3"; fail=1; }
contents "$tmp/k.db" > "$tmp/k.txt"
cmp -s "$tmp/a.txt" "$tmp/k.txt" || { echo "FAIL: killed+resumed sweep differs from an uninterrupted one"; fail=1; }
# 4. shards + merge
"$bin" sweep $args --db "$tmp/s.db" --list-jobs > "$tmp/jobs" || { echo "FAIL: list-jobs"; fail=1; }
njobs=$(wc -l < "$tmp/jobs")
[ "$njobs" -gt 10 ] || { echo "FAIL: list-jobs printed $njobs commands"; fail=1; }
(cd "$tmp" && sed "s#^raytraffic #'$bin' #" jobs | sh 2>/dev/null) || { echo "FAIL: running shard commands"; fail=1; }
"$bin" db merge "$tmp/m.db" "$tmp"/s.job*.db 2>/dev/null || { echo "FAIL: db merge"; fail=1; }
"$bin" db merge "$tmp/m.db" "$tmp"/s.job*.db 2>/dev/null || { echo "FAIL: db merge twice"; fail=1; }
contents "$tmp/m.db" > "$tmp/m.txt"
cmp -s "$tmp/a.txt" "$tmp/m.txt" || { echo "FAIL: merged shards differ from a one-process sweep"; fail=1; }
# 5. --jobs 2
"$bin" sweep $args --db "$tmp/j.db" --jobs 2 2>"$tmp/log5" || { echo "FAIL: --jobs 2"; fail=1; }
set -- $(stages "$tmp/log5")
[ $# = 5 ] && awk -v w="$1" -v a="$2" -v b="$3" -v c="$4" -v d="$5" 'BEGIN { exit !(a + b + c + d <= 2 * w + 0.25) }' ||
    { echo "FAIL: --jobs 2 stage line: $(tail -n 1 "$tmp/log5")"; fail=1; }
contents "$tmp/j.db" > "$tmp/j.txt"
cmp -s "$tmp/a.txt" "$tmp/j.txt" || { echo "FAIL: --jobs 2 differs from --jobs 1"; fail=1; }
# 6. --keep-traces gives the same numbers as streaming
"$bin" sweep --scenes cornell:glass=0 --lights all --tracers dynamic -W 16 -H 16 --sizes 4K --db "$tmp/t.db" --keep-traces "$tmp/tr" 2>/dev/null || { echo "FAIL: keep-traces"; fail=1; }
tr=$(ls "$tmp"/tr/*.rtt 2>/dev/null | head -n1)
if [ -n "$tr" ]; then
    "$bin" sim "$tr" --sizes 4K --format csv > "$tmp/sim.csv" || { echo "FAIL: sim on kept trace"; fail=1; }
    want=$(sqlite3 "$tmp/t.db" "SELECT SUM(traffic_bytes) FROM traffic")
    # per-class rows come first, then the group rows (geometry, ray, other)
    got=$(awk -F, 'NR == 1 { for (i = 1; i <= NF; i++) { if ($i == "traffic_bytes") c = i; if ($i == "class") k = i }; next }
        $k == "geometry" { done = 1 } !done { s += $c } END { print s }' "$tmp/sim.csv")
    [ "$want" = "$got" ] || { echo "FAIL: kept trace simulates to $got bytes, streamed run stored $want"; fail=1; }
else
    echo "FAIL: no trace kept"; fail=1
fi
# 8. reduced experiments: --proxy runs res:16 and sub:4 of every job; the
# report pairs each with its full run and its figures match a direct query
"$bin" sweep --scenes cornell:glass=0 --lights primary --tracers recursive,dynamic -W 32 -H 32 --sizes 4K,64K \
    --proxy res:16,sub:4:2 --db "$tmp/p.db" 2>/dev/null || { echo "FAIL: sweep --proxy"; fail=1; }
n=$(sqlite3 "$tmp/p.db" "SELECT COUNT(*) FROM runs")
[ "$n" = 9 ] || { echo "FAIL: --proxy stored $n runs, want 3 full + 6 reduced"; fail=1; }
"$bin" report --db "$tmp/p.db" --speed-error --format csv > "$tmp/p.csv" || { echo "FAIL: report --speed-error on proxies"; fail=1; }
nr=$(grep -c ',resolution,"16x16 (x4.00)"' "$tmp/p.csv"); ns=$(grep -c ',subsample,"32x32 subsample=4 tile=2' "$tmp/p.csv")
[ "$nr" = 3 ] && [ "$ns" = 3 ] || { echo "FAIL: want 3 resolution and 3 subsample rows, got $nr and $ns"; cat "$tmp/p.csv"; fail=1; }
# geometry traffic error (max over sizes, %) of the recursive res:16 proxy, from the tables
want=$(sqlite3 "$tmp/p.db" "WITH g AS (SELECT r.W, c.size, SUM(t.traffic_bytes) AS b FROM traffic t
    JOIN runs r ON r.id = t.run_id JOIN cache_configs c ON c.id = t.config_id JOIN classes k ON k.name = t.class
    WHERE r.tracer = 'recursive' AND r.params = '' AND k.grp = 'geometry' GROUP BY r.W, c.size)
    SELECT printf('%.3f', MAX(ABS(4.0 * a.b - x.b) * 100.0 / x.b)) FROM g a JOIN g x ON x.size = a.size AND x.W = 32 WHERE a.W = 16")
got=$(awk -F, '$2 == "recursive" && $7 == "resolution" { print $17 }' "$tmp/p.csv")
[ -n "$want" ] && [ "$want" = "$got" ] || { echo "FAIL: res:16 geometry traffic error $got%, direct query $want%"; fail=1; }
"$bin" report --db "$tmp/p.db" --speed-error | grep -q "rays per queue event" || { echo "FAIL: no ray-density table"; fail=1; }
"$bin" sweep --proxy sub:4:3 --tracers packet --db "$tmp/p.db" >/dev/null 2>&1; [ $? -eq 2 ] || { echo "FAIL: packet tile 3 not a usage error"; fail=1; }
"$bin" sweep --proxy bogus --db "$tmp/p.db" >/dev/null 2>&1; [ $? -eq 2 ] || { echo "FAIL: bad --proxy not a usage error"; fail=1; }
# 7. bad input
"$bin" sweep --preset nope >/dev/null 2>&1; [ $? -eq 2 ] || { echo "FAIL: bad preset not a usage error"; fail=1; }
"$bin" report --db "$tmp/none.db" >/dev/null 2>&1; [ $? -eq 1 ] || { echo "FAIL: missing db not an error"; fail=1; }
[ $fail -eq 0 ] && echo "sweep tests passed"
exit $fail
