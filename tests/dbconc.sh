#!/bin/sh
# Concurrent writers on a fresh database: W `sim --db` processes start at
# once on a file that does not exist yet, each storing one run (its own din
# file), for R rounds (a fresh file each round). Every process must exit 0
# and every round must end with exactly W runs and W x rows traffic rows:
# none lost ("database is locked" while creating the schema or switching to
# WAL), none duplicated. Quick tier 4 x 2, long tier 8 x 5; RT_DBCONC="W R"
# overrides (docs/reliability.md quotes an 8 x 50 measurement).
set -u
bin=${RT_BIN:-./raytraffic}
tmp=$(mktemp -d /tmp/rt-dbconc-XXXXXX)
trap 'rm -rf "$tmp"' EXIT
if [ "${RT_TEST_LONG:-0}" != 0 ]; then set -- 8 5; else set -- 4 2; fi
[ -n "${RT_DBCONC:-}" ] && set -- $RT_DBCONC
W=$1 R=$2
"$bin" trace cornell -W 8 -H 8 -o "$tmp/t.rtt" 2>/dev/null || { echo "FAIL: trace"; exit 1; }
"$bin" trace-dump "$tmp/t.rtt" --din > "$tmp/t.din" || { echo "FAIL: trace-dump"; exit 1; }
i=1
while [ $i -le "$W" ]; do cp "$tmp/t.din" "$tmp/w$i.din"; i=$((i + 1)); done
fails=0 lost=0 r=1
while [ $r -le "$R" ]; do
    db="$tmp/r$r.db" pids="" i=1
    while [ $i -le "$W" ]; do
        "$bin" sim --db "$db" --sizes 1K,4K "$tmp/w$i.din" 2>"$tmp/err$i" &
        pids="$pids $!"
        i=$((i + 1))
    done
    i=1
    for p in $pids; do
        wait "$p" || { fails=$((fails + 1)); echo "round $r writer $i: $(cat "$tmp/err$i")"; }
        i=$((i + 1))
    done
    runs=$(sqlite3 "$db" "SELECT COUNT(*) FROM runs")
    rows=$(sqlite3 "$db" "SELECT COUNT(*) FROM traffic")
    dup=$(sqlite3 "$db" "SELECT COUNT(*) FROM (SELECT scene_id FROM runs GROUP BY scene_id HAVING COUNT(*) > 1)")
    # 2 sizes x 1 class (fb) per run
    if [ "$runs" != "$W" ] || [ "$rows" != $((2 * W)) ] || [ "$dup" != 0 ]; then
        echo "round $r: $runs runs, $rows traffic rows, $dup duplicated scenes; want $W, $((2 * W)), 0"
        lost=$((lost + 1))
    fi
    rm -f "$db" "$db-wal" "$db-shm"
    r=$((r + 1))
done
echo "$W writers x $R rounds: $fails failed processes, $lost bad rounds"
[ "$fails" = 0 ] && [ "$lost" = 0 ] || { echo "FAIL"; exit 1; }
