#!/bin/sh
# The stream tracers from the command line: their options' usage errors
# (exit 2, naming the option or the grid's cell limit), a sweep of both
# tracers into a database and `report --figure purcell` printing the
# paper's bunny values and each run's statistics (v, t, s, passes) as
# stored, in Markdown and CSV.
set -u
bin=${RT_BIN:-./raytraffic}
tmp=$(mktemp -d /tmp/rt_stream_cli.XXXXXX) || exit 1
trap 'rm -rf "$tmp"' EXIT
fail=0
err() { echo "FAIL: $*"; fail=1; }
[ -x "$bin" ] || { echo "FAIL: $bin is not an executable"; exit 1; }

# usage errors: exit 2 and a message naming the option
usage_err() { # WANT-IN-MESSAGE ARGS...
    want=$1; shift
    "$bin" render cornell -W 8 -H 8 -o "$tmp/x.exr" "$@" > "$tmp/out" 2>&1
    rc=$?
    [ $rc -eq 2 ] || err "render $*: exit $rc, want 2"
    grep -q -- "$want" "$tmp/out" || err "render $*: message lacks '$want': $(cat "$tmp/out")"
}
usage_err "--grid-min" -t stream-branching --grid-min 0
usage_err "134217728" -t stream-branching --grid-min 999999999
usage_err "--oracle-fraction" -t stream-multipass --oracle-fraction 0
usage_err "--oracle-fraction" -t stream-multipass --oracle-fraction 1.5
usage_err "--oracle" -t stream-multipass --oracle best
usage_err "--unroll" -t stream-multipass --unroll 0,1
usage_err "--unroll" -t stream-multipass --unroll 4
# a grid within the option's range but over the cell limit: refused, naming the limit
"$bin" render cornell -t stream-branching --grid-min 1024 -W 8 -H 8 -o "$tmp/x.exr" > "$tmp/out" 2>&1
rc=$?
[ $rc -ne 0 ] || err "grid over the cell limit accepted"
grep -q "134217728" "$tmp/out" || err "over the limit: message lacks the limit: $(cat "$tmp/out")"

# sweep both tracers, then the report
"$bin" sweep --scenes knot --tracers stream-branching,stream-multipass -W 16 -H 16 --modes raycast \
    --db "$tmp/s.db" > /dev/null 2>&1 || err "sweep failed"
"$bin" report --db "$tmp/s.db" --figure purcell > "$tmp/r.md" 2>&1 || err "report failed: $(cat "$tmp/r.md")"
grep -q "| paper: bunny ray cast 1024x1024 | 93.93 | 13.88 | 0.82 | 1048576 |" "$tmp/r.md" || err "figure 6 paper row"
grep -q "| paper: bunny ray cast 1024x1024 | 1085 | 610 | 471 | 4 | 221 | 328 | 0.105 |" "$tmp/r.md" || err "table 2 paper row"
stats=$(sqlite3 "$tmp/s.db" "select stats from runs where tracer = 'stream-multipass'" 2>/dev/null)
if [ -n "$stats" ]; then
    v=$(echo "$stats" | tr ' ' '\n' | sed -n 's/^v=//p')
    p=$(echo "$stats" | tr ' ' '\n' | sed -n 's/^passes=//p')
    vr=$(printf '%.2f' "$v")
    grep -q "^| knot multipass 16x16 | $vr |" "$tmp/r.md" || err "figure 6 row lacks v=$vr"
    grep -q "^| knot multipass 16x16 | $p |" "$tmp/r.md" || err "table 2 row lacks passes=$p"
fi
"$bin" report --db "$tmp/s.db" --figure purcell --format csv > "$tmp/r.csv" 2>&1 || err "csv report failed"
grep -q '^"paper: bunny ray cast 1024x1024",1085,610,471,4,221,328,0.105$' "$tmp/r.csv" || err "csv table 2 paper row"
"$bin" report --db "$tmp/s.db" --figure purcell --scene cornell > "$tmp/out" 2>&1 && err "report on a scene without runs succeeded"
grep -q "no runs of the stream tracers" "$tmp/out" || err "no-runs message: $(cat "$tmp/out")"
exit $fail
