#!/bin/sh
# The SQL of docs/database.md and of the README runs against a database of
# run.sh's kind, small: a full run and a lower-resolution proxy of the same
# scene (room at 16x16 and 8x8), a second structure (bvh4) beside the k-d
# tree, so a query that forgets a dimension shows each size twice. Every
# query must run; the figure queries must give exactly one row per tracer
# and size (one setup), with the dynamic run scheduled for each size. The
# tidy CSV and JSON tables of `report --format` load with Python's csv and
# json modules, one table per figure, the database's bytes.
set -u
bin=${RT_BIN:-./raytraffic}
src=${RT_SRCDIR:-.}
tmp=$(mktemp -d /tmp/rt-dbq-XXXXXX)
trap 'rm -rf "$tmp"' EXIT
fail=0
db="$tmp/raytraffic.db"
common="--scenes room --tracers recursive,dynamic --lights primary --sizes 1K,4K,16K"
"$bin" sweep $common -W 16 -H 16 --accels kd,bvh4 --db "$db" >/dev/null 2>"$tmp/log" &&
    "$bin" sweep $common -W 8 -H 8 --db "$db" >/dev/null 2>>"$tmp/log" ||
    { echo "FAIL: sweep"; cat "$tmp/log"; exit 1; }
# the ```sql blocks of the doc, one file each (sqlite3 dot-commands kept)
awk -v dir="$tmp" '/^```sql$/ { n++; f = dir "/q" n ".sql"; on = 1; next } /^```$/ { on = 0; next } on { print > f }' \
    "$src/docs/database.md"
nq=$(ls "$tmp"/q*.sql 2>/dev/null | wc -l)
[ "$nq" -ge 5 ] || { echo "FAIL: only $nq queries found in docs/database.md"; fail=1; }
for q in "$tmp"/q*.sql; do
    sqlite3 "$db" < "$q" > "$q.out" 2> "$q.err" && [ ! -s "$q.err" ] ||
        { echo "FAIL: $(head -1 "$q") ...: $(cat "$q.err")"; fail=1; }
done
# the statistics through json_extract: the dynamic runs' queue points as
# their stats text says, and one run's keys as many as its text's tokens
want=$(sqlite3 "$db" "SELECT id, tracer, W, substr(stats, instr(stats, ' queue_points=') + 14,
    instr(substr(stats, instr(stats, ' queue_points=') + 14), ' ') - 1) FROM runs WHERE tracer = 'dynamic' ORDER BY id")
got=$(cut -d'|' -f1-4 "$tmp/q4.sql.out" | head -n "$(echo "$want" | wc -l)")
[ -n "$want" ] && [ "$got" = "$want" ] || { echo "FAIL: json_extract queue_points: $got, want $want"; fail=1; }
ntok=$(sqlite3 "$db" "SELECT stats FROM runs WHERE id = 1" | wc -w)
nkey=$(($(wc -l < "$tmp/q4.sql.out") - $(echo "$want" | wc -l)))
[ "$nkey" = "$ntok" ] || { echo "FAIL: json_each gives $nkey keys for run 1's $ntok tokens"; fail=1; }
# Figure 4: 2 tracers x 3 sizes, one row each (header lines of .mode column: 2)
rows=$(($(wc -l < "$tmp/q1.sql.out") - 2))
[ "$rows" = 6 ] || { echo "FAIL: Figure 4 query gives $rows rows, not 6:"; cat "$tmp/q1.sql.out"; fail=1; }
dup=$(tail -n +3 "$tmp/q1.sql.out" | awk '{ print $1, $2 }' | sort | uniq -d)
[ -z "$dup" ] || { echo "FAIL: Figure 4 query repeats: $dup"; fail=1; }
# the reduction: one row per size
[ "$(wc -l < "$tmp/q2.sql.out")" = 3 ] && [ -z "$(cut -d'|' -f1 "$tmp/q2.sql.out" | sort | uniq -d)" ] ||
    { echo "FAIL: reduction query:"; cat "$tmp/q2.sql.out"; fail=1; }
# its values are the report's: 100 (recursive / dynamic - 1) of v_paper's
# 16x16 k-d rows, computed here the obvious way
want=$(sqlite3 "$db" "SELECT printf('%.1f%%', 100.0 * (b.geometry_mb / d.geometry_mb - 1)) FROM v_paper b, v_paper d
  WHERE b.tracer = 'recursive' AND d.tracer = 'dynamic' AND b.W = 16 AND d.W = 16 AND b.accel = '' AND d.accel = ''
  AND b.cache_size = 4096 AND d.cache_size = 4096 AND d.sched_size = 4096")
[ "$(sed -n 2p "$tmp/q2.sql.out" | cut -d'|' -f2)" = "$want" ] ||
    { echo "FAIL: reduction at 4K: $(sed -n 2p "$tmp/q2.sql.out"), want $want"; fail=1; }
# v_runs: both structures, both resolutions, names of the light mask
[ "$(sqlite3 "$db" "SELECT COUNT(DISTINCT accel), COUNT(DISTINCT W), MIN(light_names) FROM v_runs")" = "2|2|none" ] ||
    { echo "FAIL: v_runs: $(sqlite3 "$db" "SELECT DISTINCT accel, W, light_names FROM v_runs")"; fail=1; }
# the README's query (on this database's scene): one row per tracer and size
readme=$(sed -n '/^sqlite3 out\/raytraffic.db "SELECT/,/ORDER BY cache_size, tracer"$/p' "$src/README.md" |
    sed -e 's/^sqlite3 out\/raytraffic.db "//' -e 's/"$//' -e "s/sphereflake/room/g")
[ -n "$readme" ] || { echo "FAIL: README query not found"; fail=1; }
out=$(sqlite3 "$db" "$readme" 2>&1)
[ "$(printf '%s\n' "$out" | wc -l)" = 6 ] && [ -z "$(printf '%s\n' "$out" | cut -d'|' -f2,4 | sort | uniq -d)" ] ||
    { echo "FAIL: README query:"; printf '%s\n' "$out"; fail=1; }
# the tidy tables load with Python's csv and json modules, one table per
# figure, every row of the figure's one setup (16x16, the k-d tree, lean;
# dynamic rows at their scheduled size), bytes as the database holds them
"$bin" report --db "$db" --format csv --out "$tmp/csv" 2>/dev/null || { echo "FAIL: report --format csv --out"; fail=1; }
"$bin" report --db "$db" --format json > "$tmp/all.json" 2>"$tmp/log" || { echo "FAIL: report --format json"; fail=1; }
"$bin" report --db "$db" --format csv --figure 4 > "$tmp/f4.csv" 2>"$tmp/log" || { echo "FAIL: --figure 4 csv"; fail=1; }
want=$(sqlite3 "$db" "SELECT COUNT(*), SUM(t.traffic_bytes) FROM traffic t JOIN runs r ON r.id = t.run_id
  JOIN cache_configs c ON c.id = t.config_id WHERE r.W = 16 AND r.params NOT LIKE '%accel=%' AND r.lights = 0
  AND (r.sched_size = 0 OR r.sched_size = c.size)")
got=$(python3 - "$tmp" <<'PY'
import csv, json, sys
d = sys.argv[1]
rows = list(csv.DictReader(open(d + "/csv/figure4-room.csv")))
js = json.load(open(d + "/all.json"))
figs = [f for f in js["figures"] if f["figure"] == 4]
assert len(figs) == 1, figs
cols = figs[0]["columns"]
jrows = [dict(zip(cols, r)) for r in figs[0]["rows"]]
one = list(csv.DictReader(open(d + "/f4.csv")))
assert rows == one, "stdout table differs from the folder's"
assert len(jrows) == len(rows) and all(int(a["traffic_bytes"]) == b["traffic_bytes"] for a, b in zip(rows, jrows))
assert {r["W"] for r in rows} == {"16"} and {r["accel"] for r in rows} == {""}, "another setup in the figure"
print(len(rows), sum(int(r["traffic_bytes"]) for r in rows), sep="|")
PY
) || { echo "FAIL: the tidy tables do not load with csv/json"; fail=1; }
[ "$got" = "$want" ] || { echo "FAIL: tidy figure 4: $got rows|bytes, the database $want"; fail=1; }

# --figure N --compare-paper compares that figure's scene only (and a
# figure whose scene the database lacks has nothing to show)
"$bin" report --db "$db" --figure 4 --compare-paper > "$tmp/c4.md" 2>"$tmp/log" && grep -q '^### `room`, primary rays' "$tmp/c4.md" ||
    { echo "FAIL: --figure 4 --compare-paper: $(cat "$tmp/log")"; fail=1; }
"$bin" report --db "$db" --figure 6 --compare-paper > "$tmp/c6.md" 2>"$tmp/log"
[ $? = 1 ] && [ ! -s "$tmp/c6.md" ] || { echo "FAIL: --figure 6 --compare-paper without sphereflake"; fail=1; }

[ "$fail" = 0 ] && echo "db_queries: ok"
exit $fail
