#!/bin/sh
# The hybrid's standard errors in a sweep database: the sweep stores, per
# estimated size, the errors `sim --method hybrid` prints for the kept trace
# of the same job (and the same estimates); errors=1 is in the run key, so
# --no-error is another run, with no error rows (NULL in v_traffic_se) and
# the same estimates; a rerun stores nothing; --list-jobs carries
# --no-error; report --speed-error counts the estimates within 1, 2, 3
# standard errors of the exact traffic as a direct query does (Markdown and
# CSV); a version-4 database (no error table) reports and is upgraded;
# shards of --list-jobs merge to the same errors; bad input is a one-line
# error.
set -u
bin=${RT_BIN:-./raytraffic}
tmp=$(mktemp -d /tmp/rt-sweepse-XXXXXX)
trap 'chmod -R u+w "$tmp" 2>/dev/null; rm -rf "$tmp"' EXIT
fail=0
die() { echo "FAIL: $*"; fail=1; }
command -v sqlite3 >/dev/null 2>&1 || { echo "SKIP: sqlite3 not installed"; exit 77; }
q() { sqlite3 "$tmp/a.db" "$1"; }

# 64x64 cornell: about 85K references, 41 windows of period 2048, so the
# windowed sizes (1K, 2K) have estimates and errors too
sizes=1K,2K,4K,16K,64K
args="--scenes cornell:glass=0 --lights primary --tracers recursive -W 64 -H 64 --sizes $sizes"
"$bin" sweep $args --approx hybrid:1/4:4K:2048 --db "$tmp/a.db" --keep-traces "$tmp/tr" 2>"$tmp/log" ||
    { echo "FAIL: sweep"; cat "$tmp/log"; exit 1; }
hid=$(q "SELECT id FROM runs WHERE sim_method = 'hybrid'")
xid=$(q "SELECT id FROM runs WHERE sim_method = 'exact'")
[ -n "$hid" ] && [ -n "$xid" ] || { echo "FAIL: runs: $(q 'SELECT id, sim_method FROM runs')"; exit 1; }
[ "$(q "SELECT sim_params FROM runs WHERE id = $hid")" = \
  "rate=0.25 seed=1 window_below=4096 period=2048 window=1024 exact_below=0 errors=1" ] ||
    die "hybrid key: $(q "SELECT sim_params FROM runs WHERE id = $hid")"
[ "$(q "SELECT count(*) FROM traffic_se WHERE run_id = $hid")" = 5 ] || die "want 5 error rows (one per size)"
[ "$(q "SELECT count(*) FROM traffic_se WHERE run_id <> $hid")" = 0 ] || die "the exact run has error rows"
q "SELECT wall_time > 0 FROM runs WHERE id = $hid" | grep -qx 1 || die "hybrid run without a time"

# 1. the stored errors and estimates equal what sim prints for the kept trace
tr=$(ls "$tmp"/tr/*.rtt 2>/dev/null | head -n 1)
[ -n "$tr" ] || { echo "FAIL: no trace kept"; exit 1; }
"$bin" sim --method hybrid --rate 1/4 --window-below 4K --period 2048 --sizes $sizes "$tr" > "$tmp/sim.txt" 2>/dev/null ||
    die "sim of the kept trace"
# "SIZE GROUP TRAFFIC SE" per group row, "SIZE total SE" per error line
# (a group row follows its size's class rows, one of which is called ray)
awk '$4 == "geometry" { g = 1 } $4 != "geometry" && $4 != "ray" && $4 != "other" { g = 0 }
     g && NF == 11 { print $1, $4, $(NF - 1), $NF }
     /^# [0-9]+: traffic [0-9]+ bytes, standard error/ { s = $2; sub(":", "", s); print s, "total", $8 }' \
    "$tmp/sim.txt" | sort > "$tmp/want.txt"
q "SELECT c.size, k.grp, SUM(t.traffic_bytes),
       COALESCE(printf('%.0f', CASE k.grp WHEN 'geometry' THEN e.geometry_se WHEN 'ray' THEN e.ray_se
                                 ELSE e.other_se END), '-')
   FROM traffic t JOIN cache_configs c ON c.id = t.config_id JOIN classes k ON k.name = t.class
   JOIN traffic_se e ON e.run_id = t.run_id AND e.config_id = t.config_id
   WHERE t.run_id = $hid GROUP BY c.size, k.grp;
   SELECT c.size, 'total', printf('%.0f', e.total_se) FROM traffic_se e
   JOIN cache_configs c ON c.id = e.config_id WHERE e.run_id = $hid AND e.total_se IS NOT NULL" |
    tr '|' ' ' | sort > "$tmp/got.txt"
[ "$(wc -l < "$tmp/want.txt")" -ge 15 ] || die "sim printed too few group rows: $(cat "$tmp/sim.txt")"
grep -q '^1024 total ' "$tmp/want.txt" || die "no windowed size with an error: $(cat "$tmp/sim.txt")"
cmp -s "$tmp/want.txt" "$tmp/got.txt" ||
    { die "stored estimates/errors differ from sim's"; diff "$tmp/want.txt" "$tmp/got.txt"; }

# 2. a rerun stores nothing; --no-error is another run with the same
# estimates and no errors
n1=$(q "SELECT count(*) FROM runs; SELECT count(*) FROM traffic; SELECT count(*) FROM traffic_se" | tr '\n' ' ')
"$bin" sweep $args --approx hybrid:1/4:4K:2048 --db "$tmp/a.db" 2>"$tmp/log2" || die "rerun"
grep -q "(1 already in the database)" "$tmp/log2" || die "rerun did not skip: $(cat "$tmp/log2")"
n2=$(q "SELECT count(*) FROM runs; SELECT count(*) FROM traffic; SELECT count(*) FROM traffic_se" | tr '\n' ' ')
[ "$n1" = "$n2" ] || die "rerun changed row counts: $n1 -> $n2"
"$bin" sweep $args --approx hybrid:1/4:4K:2048 --no-error --db "$tmp/a.db" 2>"$tmp/log3" || die "--no-error sweep"
nid=$(q "SELECT id FROM runs WHERE sim_method = 'hybrid' AND sim_params NOT LIKE '%errors=1%'")
[ -n "$nid" ] && [ "$(q "SELECT count(*) FROM runs")" = 3 ] || die "--no-error: runs $(q 'SELECT id, sim_params FROM runs')"
[ "$(q "SELECT count(*) FROM traffic_se WHERE run_id = '$nid'")" = 0 ] || die "--no-error stored errors"
[ "$(q "SELECT count(*) FROM v_traffic_se WHERE run_id = '$nid' AND total_se_mb IS NULL AND geometry_se_mb IS NULL")" = 5 ] ||
    die "--no-error: v_traffic_se not NULL"
[ "$(q "SELECT count(*) FROM v_traffic_se WHERE run_id = $xid AND total_se_mb IS NULL")" = 5 ] ||
    die "exact run: v_traffic_se not NULL"
same=$(q "SELECT count(*) FROM traffic a JOIN traffic b ON b.config_id = a.config_id AND b.class = a.class
          WHERE a.run_id = $hid AND b.run_id = '$nid' AND a.traffic_bytes = b.traffic_bytes
          AND a.accesses = b.accesses AND a.writebacks = b.writebacks")
[ "$same" = "$(q "SELECT count(*) FROM traffic WHERE run_id = $hid")" ] || die "--no-error changed the estimates"
"$bin" sweep $args --approx hybrid:1/4:4K:2048 --no-error --db "$tmp/a.db" --list-jobs | grep -q "'--no-error'" ||
    die "--list-jobs dropped --no-error"
"$bin" sweep $args --no-error --db "$tmp/u.db" >/dev/null 2>&1; [ $? = 2 ] || die "--no-error without --approx accepted"
"$bin" sweep $args --approx shards:0.1 --no-error --db "$tmp/u.db" >/dev/null 2>&1; [ $? = 2 ] ||
    die "--no-error without a hybrid method accepted"

# 3. report --speed-error: within 1, 2, 3 standard errors, as a direct query
"$bin" report --db "$tmp/a.db" --speed-error > "$tmp/se.md" 2>"$tmp/log4" || die "report --speed-error"
within() { # group column, k -> "within of n" over the sizes of run $hid
    q "SELECT SUM(ABS(v.$1_mb - x.$1_mb) <= $2 * v.$1_se_mb), COUNT(*) FROM v_traffic_se v
       JOIN v_traffic_group x ON x.run_id = $xid AND x.config_id = v.config_id
       WHERE v.run_id = $hid AND v.$1_se_mb IS NOT NULL"
}
cells=""
for g in geometry ray total; do
    set -- $(within $g 1 | tr '|' ' ') $(within $g 2 | tr '|' ' ') $(within $g 3 | tr '|' ' ')
    [ "$2" = 5 ] || die "$g: $2 sizes compared, want 5"
    cells="$cells | $1 / $3 / $5 of $2"
done
row=$(grep "^| cornell | recursive | 0 | 0 | hybrid | .* errors=1 | $hid ($xid) |" "$tmp/se.md" | grep " SE\| of ")
echo "$row" | grep -qF "$hid ($xid)$cells |" || die "within-SE row: '$row', want '...$cells |'"
grep -q "^## Standard errors" "$tmp/se.md" || die "no standard-error section"
grep -Eq "^\| $hid \($xid\) \| 1024 \| [0-9.]+ ± [0-9.]+ \| [0-9.]+ \|" "$tmp/se.md" || die "no per-size row of 1K"
[ "$(grep -c "^| $hid ($xid) | [0-9]* | " "$tmp/se.md")" = 5 ] || die "want 5 per-size rows"
grep -q "^| $nid (" "$tmp/se.md" && die "the --no-error run is in the standard-error tables"
"$bin" report --db "$tmp/a.db" --speed-error --format csv > "$tmp/se.csv" || die "report csv"
head -n 1 "$tmp/se.csv" | grep -q ',sizes,se_sizes,within_1se,within_2se,within_3se$' || die "csv header"
set -- $(within total 1 | tr '|' ' ') $(within total 2 | tr '|' ' ') $(within total 3 | tr '|' ' ')
grep -q ",$hid,$xid,.*,5,$2,$1,$3,$5\$" "$tmp/se.csv" || die "csv row: $(grep ",$hid,$xid," "$tmp/se.csv")"
grep -q ",$nid,$xid,.*,5,,,,\$" "$tmp/se.csv" || die "csv row without errors: $(grep ",$nid,$xid," "$tmp/se.csv")"

# shards of --list-jobs merged: the same errors, to the bit
"$bin" sweep $args --approx hybrid:1/4:4K:2048 --db "$tmp/sh.db" --list-jobs > "$tmp/jobs" || die "list-jobs"
(cd "$tmp" && sh jobs 2>/dev/null) || die "running the shard commands"
"$bin" db merge "$tmp/m.db" "$tmp"/sh.job*.db 2>/dev/null || die "db merge"
errs() { sqlite3 "$1" "SELECT c.size, quote(e.geometry_se), quote(e.ray_se), quote(e.other_se), quote(e.total_se)
    FROM traffic_se e JOIN cache_configs c ON c.id = e.config_id ORDER BY c.size"; }
[ -n "$(errs "$tmp/m.db")" ] && [ "$(errs "$tmp/m.db")" = "$(errs "$tmp/a.db")" ] ||
    die "merged errors differ: $(errs "$tmp/m.db")"

# 4. a version-4 database (as this one without the error table): read by
# report as it is, upgraded in place by the next sweep, rows intact
cp "$tmp/a.db" "$tmp/v4.db"
sqlite3 "$tmp/v4.db" "DROP VIEW v_traffic_se; DROP TABLE traffic_se; PRAGMA user_version = 4"
"$bin" report --db "$tmp/v4.db" --speed-error > "$tmp/v4.md" 2>"$tmp/log5" || die "report of a v4 file: $(cat "$tmp/log5")"
grep -q "Standard errors" "$tmp/v4.md" && die "v4 report has a standard-error section"
t4=$(sqlite3 "$tmp/v4.db" "SELECT count(*), sum(traffic_bytes) FROM traffic")
"$bin" sweep $args --approx hybrid:1/4:4K:2048 --no-error --db "$tmp/v4.db" 2>/dev/null || die "sweep into a v4 file"
[ "$(sqlite3 "$tmp/v4.db" "PRAGMA user_version; SELECT count(*) FROM traffic_se; SELECT count(*), sum(traffic_bytes) FROM traffic")" = \
  "$(printf '8\n0\n%s' "$t4")" ] || die "v4 upgrade: $(sqlite3 "$tmp/v4.db" "PRAGMA user_version; SELECT count(*) FROM traffic")"

# 5. bad input: an unwritable database, a newer schema
"$bin" sweep $args --approx hybrid --db "$tmp/no/such/dir/x.db" >/dev/null 2>"$tmp/e1"; st=$?
[ $st = 1 ] && [ "$(wc -l < "$tmp/e1")" -le 2 ] && grep -q "$tmp/no/such/dir/x.db" "$tmp/e1" ||
    die "unwritable: exit $st $(cat "$tmp/e1")"
cp "$tmp/a.db" "$tmp/new.db"
sqlite3 "$tmp/new.db" "PRAGMA user_version = 9"
"$bin" sweep $args --approx hybrid --db "$tmp/new.db" >/dev/null 2>"$tmp/e2"; st=$?
[ $st = 1 ] && grep -q "new.db: database schema version 9 is newer" "$tmp/e2" || die "newer: exit $st $(cat "$tmp/e2")"

[ $fail -eq 0 ] && echo "sweep_se tests passed"
exit $fail
