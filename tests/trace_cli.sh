#!/bin/sh
# The trace commands end to end: din and text export of a tiny synthetic
# trace against golden files, trace-info on good and damaged files, usage
# errors, and `raytraffic trace` determinism.
# Regenerate the golden files with: RT_REDO_GOLDEN=1 make check
set -u
bin=${RT_BIN:-./raytraffic}
src=${RT_SRCDIR:-.}
build=${RT_BUILDDIR:-.}
gold=$src/tests/golden
tmp=$(mktemp -d /tmp/rt_trace_cli.XXXXXX) || exit 1
trap 'rm -rf "$tmp"' EXIT
fail=0
err() { echo "FAIL: $*"; fail=1; }
[ -x "$bin" ] || { echo "FAIL: $bin is not an executable"; exit 1; }
[ -x "$build/tests/test_trace" ] || { echo "FAIL: $build/tests/test_trace is not built"; exit 1; }

# --- golden files from a synthetic trace -----------------------------------
"$build/tests/test_trace" --synthetic "$tmp/syn.rtt" || err "writing the synthetic trace"
for v in "din64:--din" "din32:--din --line 32" "text:"; do
    name=${v%%:*}; opts=${v#*:}
    # shellcheck disable=SC2086
    "$bin" trace-dump "$tmp/syn.rtt" $opts > "$tmp/syn.$name" || err "trace-dump $opts exited $?"
    if [ "${RT_REDO_GOLDEN:-0}" = 1 ]; then
        cp "$tmp/syn.$name" "$gold/synthetic.$name"; echo "regenerated $gold/synthetic.$name"
    elif ! cmp -s "$tmp/syn.$name" "$gold/synthetic.$name"; then
        err "trace-dump $opts differs from $gold/synthetic.$name"
        diff "$gold/synthetic.$name" "$tmp/syn.$name" | head -20
    fi
done
"$bin" trace-dump "$tmp/syn.rtt" --limit 3 | wc -l | grep -q '^ *3$' || err "--limit 3"

# --- trace-info on good, truncated and corrupt files ------------------------
"$bin" trace-info "$tmp/syn.rtt" > "$tmp/info" || err "trace-info on a good file"
grep -q '^  total  *15 ' "$tmp/info" || err "trace-info total of the synthetic trace"
"$bin" trace-info --json "$tmp/syn.rtt" | grep -q '"refs": 15, "chunks": 4}' || err "trace-info --json"
size=$(wc -c < "$tmp/syn.rtt")
head -c $((size - 7)) "$tmp/syn.rtt" > "$tmp/short.rtt"
"$bin" trace-info "$tmp/short.rtt" > /dev/null 2> "$tmp/msg"; st=$?
[ $st -eq 1 ] || err "trace-info on a truncated file exited $st, want 1"
grep -q "short.rtt: byte [0-9]*: .*truncated" "$tmp/msg" || err "truncation message: $(cat "$tmp/msg")"
[ "$(wc -l < "$tmp/msg")" -eq 1 ] || err "truncation message is not one line"
"$bin" trace-dump "$tmp/short.rtt" > /dev/null 2>&1; st=$?
[ $st -eq 1 ] || err "trace-dump on a truncated file exited $st, want 1"
printf 'not a trace at all\n' > "$tmp/junk.rtt"
"$bin" trace-info "$tmp/junk.rtt" 2>&1 >/dev/null | grep -q "junk.rtt: byte 0: not a raytraffic trace" \
    || err "bad magic message"
"$bin" trace-info "$tmp/missing.rtt" > /dev/null 2>&1; [ $? -eq 1 ] || err "missing file should exit 1"

# --- usage errors ---------------------------------------------------------------
"$bin" trace-info a b > /dev/null 2>&1; [ $? -eq 2 ] || err "trace-info with two files should exit 2"
"$bin" trace-dump "$tmp/syn.rtt" --line 0 > /dev/null 2>&1; [ $? -eq 2 ] || err "--line 0 should exit 2"
"$bin" trace-dump "$tmp/syn.rtt" --bogus > /dev/null 2>&1; [ $? -eq 2 ] || err "unknown option should exit 2"
"$bin" trace cornell > /dev/null 2>&1; [ $? -eq 2 ] || err "trace without -o should exit 2"
"$bin" trace cornell -W 0 -o "$tmp/x.rtt" > /dev/null 2>&1; [ $? -eq 2 ] || err "trace -W 0 should exit 2"

# --- raytraffic trace ------------------------------------------------------------
# (no probe-and-skip: every command here is built with the binary, so a
# failure is a failure)
{
    "$bin" trace cornell -W 32 -H 32 --lights all -o "$tmp/c1.rtt" 2> "$tmp/c1.err" || err "trace cornell"
    grep -q "wrote .*c1.rtt: [0-9]* references" "$tmp/c1.err" || err "trace summary: $(cat "$tmp/c1.err")"
    "$bin" trace cornell -W 32 -H 32 --lights all -o "$tmp/c2.rtt" 2> /dev/null || err "trace cornell again"
    # the command line (and so the header) differs only in the output name
    "$bin" trace-dump "$tmp/c1.rtt" > "$tmp/c1.txt" && "$bin" trace-dump "$tmp/c2.rtt" > "$tmp/c2.txt" \
        && cmp -s "$tmp/c1.txt" "$tmp/c2.txt" || err "two traces of cornell have different records"
    (cd "$tmp" && "$bin" trace cornell -W 32 -H 32 --lights all -o same.rtt 2>/dev/null && mv same.rtt a.rtt \
        && "$bin" trace cornell -W 32 -H 32 --lights all -o same.rtt 2>/dev/null) || err "trace same.rtt"
    cmp -s "$tmp/a.rtt" "$tmp/same.rtt" || err "tracing cornell twice gives different files"
    [ ! -e "$tmp/same.rtt.tmp" ] || err "trace left its tmp file"
    "$bin" trace-info --json "$tmp/c1.rtt" > "$tmp/c1.json" || err "trace-info on cornell"
    grep -q '"scene": "cornell"' "$tmp/c1.json" || err "trace-info scene"
    grep -q '"width": 32, "height": 32, "lights": 7' "$tmp/c1.json" || err "trace-info size/lights"
    grep -q '"ray": {"group": "ray", "refs": [1-9]' "$tmp/c1.json" || err "trace-info ray references"
    grep -q '"node": {"group": "geometry", "refs": [1-9]' "$tmp/c1.json" || err "trace-info node references"
    grep -q '"fb": {"group": "other", "refs": 1024, "bytes": [0-9]*, "writes": 1024}' "$tmp/c1.json" \
        || err "one framebuffer write per pixel"
    size=$(wc -c < "$tmp/c1.rtt")
    head -c $((size / 2)) "$tmp/c1.rtt" > "$tmp/c1short.rtt"
    "$bin" trace-info "$tmp/c1short.rtt" > /dev/null 2> "$tmp/msg"; st=$?
    [ $st -eq 1 ] || err "trace-info on truncated cornell exited $st"
    grep -q "c1short.rtt: byte [0-9][0-9]*:" "$tmp/msg" || err "truncated cornell message: $(cat "$tmp/msg")"
    # din export is exact at its line size: the simulator sees the same traffic
    # per cache size from the .rtt and from its din dump (total over classes)
    "$bin" trace-dump --din "$tmp/c1.rtt" > "$tmp/c1.din" || err "din dump of cornell"
    sum() { awk '$1 ~ /^[0-9]+$/ {t[$1] += $NF} END {for (s in t) print s, t[s]}' "$1" | sort -n; }
    if "$bin" sim "$tmp/c1.rtt" > "$tmp/sim.rtt.txt" 2>/dev/null && "$bin" sim "$tmp/c1.din" > "$tmp/sim.din.txt" 2>/dev/null
    then
        sum "$tmp/sim.rtt.txt" > "$tmp/s1"; sum "$tmp/sim.din.txt" > "$tmp/s2"
        [ -s "$tmp/s1" ] && cmp -s "$tmp/s1" "$tmp/s2" || err "sim traffic differs between .rtt and its din dump"
    else
        err "raytraffic sim on cornell's .rtt or din dump failed"
    fi
    "$bin" trace no-such-scene -o "$tmp/bad.rtt" > /dev/null 2>&1; [ $? -eq 1 ] || err "bad scene should exit 1"
    [ ! -e "$tmp/bad.rtt" ] && [ ! -e "$tmp/bad.rtt.tmp" ] || err "failed trace left a file"
}
# "lights" has one meaning: the trace's summary, trace-info, sweep's
# progress lines and --lights itself spell a set of lights the same way
# (none, 0, 0+1, all); the older "0,1" is still read
"$bin" trace cornell:glass=0 --lights 0 -W 8 -H 8 -o "$tmp/l0.rtt" 2> "$tmp/l0.log" || err "trace --lights 0"
grep -q "lights 0;" "$tmp/l0.log" || err "trace --lights 0 summary: $(cat "$tmp/l0.log")"
"$bin" trace-info "$tmp/l0.rtt" | grep -q "lights 0$" || err "trace-info of --lights 0: $("$bin" trace-info "$tmp/l0.rtt" | grep lights)"
for l in "0+2" "0,2"; do
    "$bin" trace cornell:glass=0 --lights "$l" -W 8 -H 8 -o "$tmp/l02.rtt" 2> "$tmp/l02.log" || err "trace --lights $l"
    grep -q "lights 0+2;" "$tmp/l02.log" || err "trace --lights $l summary: $(cat "$tmp/l02.log")"
    "$bin" trace-info "$tmp/l02.rtt" | grep -q "lights 0+2$" || err "trace-info of --lights $l"
done
"$bin" trace cornell:glass=0 --lights all -W 8 -H 8 -o "$tmp/la.rtt" 2> "$tmp/la.log" && grep -q "lights all;" "$tmp/la.log" ||
    err "trace --lights all summary: $(cat "$tmp/la.log")"
"$bin" trace cornell:glass=0 --lights none -W 8 -H 8 -o "$tmp/ln.rtt" 2> "$tmp/ln.log" && grep -q "lights none;" "$tmp/ln.log" &&
    "$bin" trace-info "$tmp/ln.rtt" | grep -q "lights none$" || err "trace --lights none: $(cat "$tmp/ln.log")"
"$bin" sweep --scenes cornell:glass=0 --tracers recursive --lights primary,1,0+2 --sizes 1K -W 8 -H 8 --db "$tmp/l.db" \
    2> "$tmp/ls.log" >/dev/null || err "sweep --lights primary,1,0+2: $(cat "$tmp/ls.log")"
for l in none 1 0+2; do
    grep -q "cornell:glass=0 lights $l recursive" "$tmp/ls.log" || err "sweep progress lacks 'lights $l': $(cat "$tmp/ls.log")"
done
[ "$(sqlite3 "$tmp/l.db" "SELECT group_concat(lights) FROM (SELECT lights FROM runs ORDER BY lights)")" = "0,2,5" ] ||
    err "sweep stored masks $(sqlite3 "$tmp/l.db" "SELECT lights FROM runs")"
exit $fail
