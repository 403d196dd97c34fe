#!/bin/sh
# Secondary rays end to end on a tiny sweep: --modes in the run keys,
# generation rows summing to the traffic rows, sim --db of a kept whitted
# trace storing the same generation rows, db merge copying them, and
# report --figure secondary printing a table and the finding per scene.
set -u
bin=${RT_BIN:-./raytraffic}
d=$(mktemp -d /tmp/rt_secondary_XXXXXX)
trap 'rm -rf "$d"' EXIT
fail=0
err() { echo "FAIL: $*"; fail=1; }
q() { sqlite3 "$1" "$2"; }
"$bin" sweep --scenes cornell --modes shadow,whitted,path --tracers recursive,dynamic --lights primary,all \
    -W 16 -H 16 --sizes 4K,64K --depth 3 --bounces 2 --keep-traces "$d/tr" --db "$d/s.db" >/dev/null 2>&1 ||
    err "sweep failed"
# shadow: primary,all x (recursive + dynamic at 2 sizes) = 6; whitted, path: all only = 3 each
[ "$(q "$d/s.db" 'select count(*) from runs')" = 12 ] || err "want 12 runs"
[ "$(q "$d/s.db" "select count(*) from runs where params like '%mode=whitted depth=3'")" = 3 ] || err "whitted keys"
[ "$(q "$d/s.db" "select count(*) from runs where params like '%mode=path spp=1 bounces=2'")" = 3 ] || err "path keys"
[ "$(q "$d/s.db" 'select max(gen) from traffic_gen')" = 2 ] || err "max generation is not 2"
sums="select count(*) from traffic t join (select run_id, config_id, class, sum(traffic_bytes) b, sum(accesses) a
  from traffic_gen group by 1, 2, 3) g using (run_id, config_id, class) where g.b = t.traffic_bytes and g.a = t.accesses"
want=$(q "$d/s.db" "select count(*) from traffic where run_id in (select run_id from traffic_gen)")
[ "$(q "$d/s.db" "$sums")" = "$want" ] && [ "$want" -gt 0 ] || err "generation rows do not sum to traffic rows"
# sim --db of the kept recursive whitted trace: the same generation rows
t=$(ls "$d"/tr/*whitted-recursive*.rtt 2>/dev/null | head -1)
[ -n "$t" ] || err "no kept whitted trace"
"$bin" sim "$t" --sizes 4K,64K --db "$d/r.db" >/dev/null 2>&1 || err "sim --db failed"
a=$(q "$d/s.db" "select group_concat(x, ' ') from (select c.size || ':' || g.class || ':' || g.gen || ':' || g.traffic_bytes x
  from traffic_gen g join runs r on r.id = g.run_id join cache_configs c on c.id = g.config_id
  where r.tracer = 'recursive' and r.params like '%whitted%' order by 1)")
b=$(q "$d/r.db" "select group_concat(x, ' ') from (select c.size || ':' || g.class || ':' || g.gen || ':' || g.traffic_bytes x
  from traffic_gen g join cache_configs c on c.id = g.config_id order by 1)")
[ -n "$a" ] && [ "$a" = "$b" ] || err "sim --db generation rows differ from the sweep's"
# merge copies them
"$bin" db merge "$d/m.db" "$d/s.db" >/dev/null 2>&1 || err "merge failed"
[ "$(q "$d/m.db" 'select count(*) from traffic_gen')" = "$(q "$d/s.db" 'select count(*) from traffic_gen')" ] ||
    err "merge lost generation rows"
# the report
"$bin" report --db "$d/s.db" --figure secondary --plot "$d/pl" >"$d/rep.md" 2>"$d/rep.err" || err "report failed: $(cat "$d/rep.err")"
grep -q '^### cornell, whitted (mode=whitted depth=3), lights all, 16x16' "$d/rep.md" || err "no whitted table"
grep -q '^### cornell, path (mode=path spp=1 bounces=2), lights all, 16x16' "$d/rep.md" || err "no path table"
grep -q '^| 64K |' "$d/rep.md" || err "no 64K row"
grep -q '^- \*\*cornell\*\*: dynamic moves less geometry than recursive in generations >= 1 at [0-4] of 4 ' "$d/rep.md" ||
    err "no finding sentence"
[ -f "$d/pl/secondary-cornell-whitted-l7-16x16.dat" ] || err "no plot data"
"$bin" report --db "$d/s.db" --figure secondary --format csv | grep -q '^cornell,path,"mode=path spp=1 bounces=2",7,16,16,4096,' ||
    err "csv row"
# a database without generations: error, exit 1
"$bin" sweep --scenes cornell --tracers recursive,dynamic --lights all -W 8 -H 8 --sizes 4K --db "$d/p.db" >/dev/null 2>&1
"$bin" report --db "$d/p.db" --figure secondary >/dev/null 2>&1
[ $? -eq 1 ] || err "report of a database without generations should fail"
# options that do not apply
"$bin" sweep --scenes cornell --lights all --depth 3 --db "$d/x.db" >/dev/null 2>&1
[ $? -eq 2 ] || err "--depth without whitted should be a usage error"
"$bin" sweep --scenes cornell --modes whitted --lights primary --db "$d/x.db" >/dev/null 2>&1
[ $? -eq 2 ] || err "whitted with only the primary lighting should be a usage error"
exit $fail
