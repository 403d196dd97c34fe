#!/bin/sh
# Many cores from the command line: sim --hierarchy on a version-4 trace of
# 4 simulated cores prints a private row set per core and the shared
# sizes, stores the run with cores 4, its hierarchy and per-level rows
# (one per core for the private level); a one-core trace is one core; bad
# hierarchies are usage errors naming the part; bench --what cores prints
# its ratio.
set -u
bin=${RT_BIN:-./raytraffic}
tmp=$(mktemp -d /tmp/rt_cores_cli.XXXXXX) || exit 1
trap 'rm -rf "$tmp"' EXIT
fail=0
err() { echo "FAIL: $*"; fail=1; }
[ -x "$bin" ] || { echo "FAIL: $bin is not an executable"; exit 1; }
H=L1=32K/8/64/lru/private,LLC=1K-4M/full/64/lru/shared

"$bin" trace cornell -W 24 -H 24 --lights all --cores 4 -o "$tmp/c4.rtt" 2>/dev/null || err "trace --cores 4"
"$bin" trace cornell -W 24 -H 24 --lights all -o "$tmp/c1.rtt" 2>/dev/null || err "trace"
"$bin" sim --hierarchy "$H" "$tmp/c4.rtt" >"$tmp/s4.txt" || err "sim --hierarchy: $(cat "$tmp/s4.txt")"
grep -q "^# .*c4.rtt: 4 cores, $H, " "$tmp/s4.txt" || err "sim header: $(head -1 "$tmp/s4.txt")"
[ "$(grep -c '^L1 [0-3] 32768 64 8 all ' "$tmp/s4.txt")" -eq 4 ] || err "not 4 private rows: $(cat "$tmp/s4.txt")"
[ "$(grep -c '^LLC - [0-9]* 64 0 all ' "$tmp/s4.txt")" -eq 13 ] || err "not 13 shared sizes"
# the private levels' accesses add up to the line touches of the one-core run's private level
a4=$(awk '$1 == "L1" && $6 == "all" { s += $7 } END { print s }' "$tmp/s4.txt")
"$bin" sim --hierarchy "$H" "$tmp/c1.rtt" >"$tmp/s1.txt" || err "sim --hierarchy of a one-core trace"
grep -q ": 1 core, " "$tmp/s1.txt" || err "a version-3 trace is not one core: $(head -1 "$tmp/s1.txt")"
a1=$(awk '$1 == "L1" && $6 == "all" { s += $7 } END { print s }' "$tmp/s1.txt")
[ "$a4" = "$a1" ] && [ "$a4" -gt 0 ] || err "line touches: $a4 on 4 cores, $a1 on one"
# the shared level sees only what the private ones send down
"$bin" sim --hierarchy "$H" --format csv "$tmp/c4.rtt" >"$tmp/s4.csv" || err "csv"
head -1 "$tmp/s4.csv" | grep -q "^trace,level,core,size_bytes" || err "csv header"
# the database
"$bin" sim --hierarchy "$H" --db "$tmp/r.db" "$tmp/c4.rtt" 2>"$tmp/db.log" || err "sim --db: $(cat "$tmp/db.log")"
[ "$(sqlite3 "$tmp/r.db" "SELECT cores || ' ' || hierarchy FROM runs")" = "4 $H" ] || err "run: $(sqlite3 "$tmp/r.db" 'SELECT * FROM runs')"
[ "$(sqlite3 "$tmp/r.db" "SELECT COUNT(DISTINCT core) FROM level_traffic WHERE level = 1")" = 4 ] || err "private rows"
[ "$(sqlite3 "$tmp/r.db" "SELECT COUNT(DISTINCT cache_size) FROM level_traffic WHERE level = 2 AND core = -1")" = 13 ] \
    || err "shared rows"
[ "$(sqlite3 "$tmp/r.db" "SELECT COUNT(DISTINCT config_id) FROM traffic")" = 13 ] || err "memory traffic rows"
# report --figure cores: one row per core count, the DRAM MB of the traffic rows
"$bin" sim --hierarchy "$H" --db "$tmp/r.db" "$tmp/c1.rtt" 2>/dev/null || err "sim --db of the one-core trace"
"$bin" trace cornell -W 24 -H 24 --lights all -t treelet --cores 4 -o "$tmp/t4.rtt" 2>/dev/null || err "trace -t treelet --cores 4"
"$bin" sim --hierarchy "$H" --db "$tmp/r.db" "$tmp/t4.rtt" 2>/dev/null || err "sim --db of the treelet trace"
"$bin" report --db "$tmp/r.db" --figure cores >"$tmp/rep.md" 2>&1 || err "report --figure cores: $(cat "$tmp/rep.md")"
want=$(sqlite3 "$tmp/r.db" "SELECT printf('%.2f', SUM(t.traffic_bytes) / 1048576.0) FROM traffic t JOIN runs r ON r.id = t.run_id
    JOIN cache_configs c ON c.id = t.config_id WHERE r.cores = 4 AND r.tracer = 'recursive' AND c.size = 4194304")
grep "shared 4096K" -A5 "$tmp/rep.md" | grep -q "^| 4 | $want | [0-9.]*% | [0-9.]* | [0-9.]*% |$" \
    || err "report: want recursive $want MB on 4 cores: $(cat "$tmp/rep.md")"
grep "shared 4096K" -A5 "$tmp/rep.md" | grep -q "^| 1 | [0-9.]* | [0-9.]*% | - | - |$" || err "report: the one-core row"
# the treelet tracer is compared with the recursive tracer on its structure (bvh4)
"$bin" trace cornell -W 24 -H 24 --lights all --accel bvh4 --cores 4 -o "$tmp/b4.rtt" 2>/dev/null || err "trace --accel bvh4"
"$bin" sim --hierarchy "$H" --db "$tmp/r.db" "$tmp/b4.rtt" 2>/dev/null || err "sim --db of the bvh4 trace"
"$bin" report --db "$tmp/r.db" --figure cores >"$tmp/rep.md" 2>&1 || err "report --figure cores (bvh4)"
grep -q "| treelet vs recursive/bvh4 |" "$tmp/rep.md" || err "no treelet vs recursive/bvh4 column: $(cat "$tmp/rep.md")"
grep "shared 4096K" -A6 "$tmp/rep.md" | grep -q "^| 4 | [0-9.]* | [0-9.]*% | [0-9.]* | [0-9.]*% | [0-9.]* | [0-9.]*% | -*[0-9.]*% |$" \
    || err "report: the reduction on 4 cores: $(cat "$tmp/rep.md")"
"$bin" report --db "$tmp/r.db" --figure cores --format csv | grep -q "^cornell,24,24,7,.*,4194304,4,treelet," || err "report csv"
# sweep --hierarchy --cores: in process, the same runs and rows as sim --hierarchy of the traces
"$bin" sweep --scenes cornell -W 24 -H 24 --lights all --tracers recursive --cores 1,4 --hierarchy "$H" \
    --db "$tmp/s.db" 2>"$tmp/sw.log" || err "sweep --hierarchy: $(cat "$tmp/sw.log")"
"$bin" sweep --scenes cornell -W 24 -H 24 --lights all --tracers treelet --cores 4 --hierarchy "$H" \
    --db "$tmp/s.db" 2>"$tmp/sw.log" || err "sweep --hierarchy -t treelet: $(cat "$tmp/sw.log")"
# (the treelet tracer is scheduled: the sweep's run scheduled for the trace's 64K, at that size)
q="SELECT r.tracer, r.cores, r.hierarchy, l.level, l.core, l.cache_size, l.class, l.gen, l.accesses, l.misses, l.writebacks,
   l.traffic_bytes FROM level_traffic l JOIN runs r ON r.id = l.run_id WHERE r.params NOT LIKE '%accel=%'
   AND r.sched_size IN (0, 65536) AND (r.sched_size = 0 OR l.level = 1 OR l.cache_size = r.sched_size)
   ORDER BY 1, 2, 4, 5, 6, 7, 8"
sqlite3 "$tmp/r.db" "$q" >"$tmp/lv_sim.txt"; sqlite3 "$tmp/s.db" "$q" >"$tmp/lv_sweep.txt"
[ -s "$tmp/lv_sim.txt" ] && cmp -s "$tmp/lv_sim.txt" "$tmp/lv_sweep.txt" || err "sweep and sim --hierarchy rows differ"
# the dynamic scheduler's queues dealt to cores: the sweep of the three schedulers at 1, 8 and 64 cores
# (the scheduled tracers once per shared size, scheduled for it: two sizes here)
H2=L1=32K/8/64/lru/private,LLC=256K+4M/full/64/lru/shared
"$bin" sweep --scenes sphereflake --lights all --cores 1,8,64 --hierarchy "$H2" --tracers recursive,dynamic,treelet -W 16 -H 16 \
    --db "$tmp/d.db" 2>"$tmp/d.log" || err "sweep -t recursive,dynamic,treelet --cores 1,8,64: $(cat "$tmp/d.log")"
[ "$(sqlite3 "$tmp/d.db" "SELECT GROUP_CONCAT(tc, ' ') FROM (SELECT DISTINCT tracer || ':' || cores AS tc, tracer, cores
    FROM runs ORDER BY tracer, cores)")" = "dynamic:1 dynamic:8 dynamic:64 recursive:1 recursive:8 recursive:64 treelet:1 treelet:8 treelet:64" ] \
    || err "dynamic sweep runs: $(sqlite3 "$tmp/d.db" 'SELECT tracer, cores FROM runs')"
[ "$(sqlite3 "$tmp/d.db" "SELECT r.cores || ':' || COUNT(DISTINCT l.core) FROM level_traffic l JOIN runs r ON r.id = l.run_id
    WHERE r.tracer = 'dynamic' AND l.level = 1 GROUP BY r.cores ORDER BY r.cores" | tr '\n' ' ')" = "1:1 8:8 64:64 " ] \
    || err "dynamic private rows per core"
[ "$(sqlite3 "$tmp/d.db" "SELECT COUNT(DISTINCT l.cache_size) FROM level_traffic l JOIN runs r ON r.id = l.run_id
    WHERE r.tracer = 'dynamic' AND r.cores = 64 AND l.level = 2 AND l.core = -1")" = 2 ] || err "dynamic shared rows"
sqlite3 "$tmp/d.db" "SELECT stats FROM runs WHERE tracer = 'dynamic' AND cores = 8" | grep -q " cores=8 rounds=[1-9][0-9]* rays_moved=[1-9]" \
    || err "dynamic 8-core statistics: $(sqlite3 "$tmp/d.db" "SELECT stats FROM runs WHERE tracer = 'dynamic'")"
sqlite3 "$tmp/d.db" "SELECT stats FROM runs WHERE tracer = 'dynamic' AND cores = 1" | grep -q "rays_moved" \
    && err "one core's statistics name moved rays"
"$bin" report --db "$tmp/d.db" --figure cores >"$tmp/d.md" 2>&1 || err "report --figure cores (dynamic): $(cat "$tmp/d.md")"
for n in 1 8 64; do
    grep "shared 4096K" -A7 "$tmp/d.md" | grep -q "^| $n | [0-9.]* | [0-9.]*% | [0-9.]* | [0-9.]*% | [0-9.]* | [0-9.]*% | -*[0-9.]*% |$" \
        || err "report: dynamic vs recursive on $n cores: $(cat "$tmp/d.md")"
done
"$bin" sweep --scenes cornell -W 8 -H 8 --tracers dynamic --modes whitted --cores 2 --hierarchy "$H2" --db "$tmp/s.db" 2>"$tmp/u.log"
[ $? = 2 ] && grep -q "whitted and path modes on one core" "$tmp/u.log" || err "sweep -t dynamic --modes whitted --cores 2: $(cat "$tmp/u.log")"
# a one-cache sweep with --cores: the interleaved stream in the one cache, its own run key (cores 4)
"$bin" sweep --scenes cornell --tracers recursive -W 16 -H 16 --sizes 64K --db "$tmp/o.db" 2>/dev/null || err "sweep"
"$bin" sweep --scenes cornell --tracers recursive --cores 4 -W 16 -H 16 --sizes 64K --db "$tmp/o.db" 2>/dev/null \
    || err "sweep --cores 4"
[ "$(sqlite3 "$tmp/o.db" "SELECT GROUP_CONCAT(DISTINCT cores) FROM (SELECT cores FROM runs ORDER BY cores)")" = "1,4" ] \
    || err "one-cache sweep cores: $(sqlite3 "$tmp/o.db" 'SELECT tracer, cores FROM runs')"
# the multi-core sweep through the job machinery: the CPU preset (L1, L2 private, LLC shared) with --cores,
# two workers, resumed after a kill, --list-jobs and --job; per-core rows of both private levels
A="--preset cpu --scenes cornell -W 16 -H 16 --lights all --tracers recursive,packet --cores 1,3"
CPU=L1=32K/8/64/lru/private,L2=1M/16/64/lru/private,LLC=1K-4M/full/64/lru/shared
RT_SWEEP_STOP_AFTER=2 "$bin" sweep $A --db "$tmp/j.db" 2>/dev/null
[ "$(sqlite3 "$tmp/j.db" "SELECT COUNT(*) FROM runs")" = 2 ] || err "the killed sweep: $(sqlite3 "$tmp/j.db" 'SELECT tracer, cores FROM runs')"
"$bin" sweep $A --jobs 2 --db "$tmp/j.db" 2>"$tmp/j.log" || err "sweep --preset cpu --cores --jobs 2: $(cat "$tmp/j.log")"
grep -q "4 run(s) finished (2 already in the database)" "$tmp/j.log" || err "resume: $(cat "$tmp/j.log")"
[ "$(sqlite3 "$tmp/j.db" "SELECT GROUP_CONCAT(x, ' ') FROM (SELECT tracer || ':' || cores || ':' || hierarchy AS x FROM runs
    ORDER BY tracer, cores)")" = "packet:1:$CPU packet:3:$CPU recursive:1:$CPU recursive:3:$CPU" ] \
    || err "cpu runs: $(sqlite3 "$tmp/j.db" 'SELECT tracer, cores, hierarchy FROM runs')"
[ "$(sqlite3 "$tmp/j.db" "SELECT GROUP_CONCAT(x, ' ') FROM (SELECT DISTINCT l.level || ':' || l.core AS x FROM level_traffic l
    JOIN runs r ON r.id = l.run_id WHERE r.cores = 3 AND r.tracer = 'packet' ORDER BY l.level, l.core)")" = "1:0 1:1 1:2 2:0 2:1 2:2 3:-1" ] \
    || err "cpu level rows"
"$bin" sweep $A --list-jobs --db "$tmp/j.db" >"$tmp/jobs.txt" || err "--list-jobs"
[ "$(wc -l <"$tmp/jobs.txt")" = 4 ] && grep -q -- "'--cores' '1,3' --job 3 --db " "$tmp/jobs.txt" || err "job lines: $(cat "$tmp/jobs.txt")"
(cd "$tmp" && sh -c "$(sed -n 4p "$tmp/jobs.txt")") 2>/dev/null || err "job line 4"
lv="SELECT r.tracer, r.cores, l.level, l.core, l.cache_size, l.class, l.gen, l.accesses, l.misses, l.writebacks, l.traffic_bytes
    FROM level_traffic l JOIN runs r ON r.id = l.run_id WHERE r.tracer = 'packet' AND r.cores = 3 ORDER BY 1, 2, 3, 4, 5, 6, 7"
[ -n "$(sqlite3 "$tmp/j.job0003.db" "$lv")" ] && [ "$(sqlite3 "$tmp/j.job0003.db" "$lv")" = "$(sqlite3 "$tmp/j.db" "$lv")" ] \
    || err "--job 3 differs from the sweep's run"
# one core on the machine is the one-core hierarchy: the same memory traffic and level rows (private ones: core 0)
"$bin" sweep --preset cpu --scenes cornell -W 16 -H 16 --lights all --tracers recursive --db "$tmp/one.db" 2>/dev/null || err "sweep --preset cpu"
tq="SELECT c.size, t.class, t.accesses, t.read_misses, t.write_misses, t.writebacks, t.traffic_bytes FROM traffic t
    JOIN runs r ON r.id = t.run_id JOIN cache_configs c ON c.id = t.config_id WHERE r.tracer = 'recursive' AND r.cores = 1 ORDER BY 1, 2"
lq="SELECT l.level, l.cache_size, l.class, l.gen, l.accesses, l.misses, l.writebacks, l.traffic_bytes FROM level_traffic l
    JOIN runs r ON r.id = l.run_id WHERE r.tracer = 'recursive' AND r.cores = 1 ORDER BY 1, 2, 3, 4"
[ -n "$(sqlite3 "$tmp/one.db" "$tq")" ] && [ "$(sqlite3 "$tmp/one.db" "$tq")" = "$(sqlite3 "$tmp/j.db" "$tq")" ] \
    || err "one core: memory traffic differs from the one-core hierarchy"
[ "$(sqlite3 "$tmp/one.db" "$lq")" = "$(sqlite3 "$tmp/j.db" "$lq")" ] || err "one core: level rows differ from the one-core hierarchy"
[ "$(sqlite3 "$tmp/j.db" "SELECT DISTINCT l.core FROM level_traffic l JOIN runs r ON r.id = l.run_id WHERE r.cores = 1
    AND l.level < 3")" = 0 ] || err "one core: private rows are core 0's"
"$bin" report --db "$tmp/j.db" --figure cores >"$tmp/jr.md" 2>&1 || err "report --figure cores (cpu): $(cat "$tmp/jr.md")"
grep "shared 4096K" -A5 "$tmp/jr.md" | grep -q "^| 3 | [0-9.]* | [0-9.]*% | [0-9.]* | [0-9.]*% | -*[0-9.]*% |$" \
    || err "report (cpu): $(cat "$tmp/jr.md")"
# bad hierarchies
for bad in "L1=32K/8/64/lru/private" "L1=32K/8/64/lru/wt/private,LLC=1M/full/64/lru/shared" \
    "L1=32K/8/64/lru/shared,LLC=1M/full/64/lru/private" "L1=32K/8/64/lru/private,LLC=1M/full/64/lru/shared,inclusive" \
    "L1=32K/8/64/opt/private,LLC=1M/full/64/lru/shared" "L1=32K/8/64/lru/private,L2=1M/8/128/lru/private,LLC=4M/full/128/lru/shared"; do
    "$bin" sim --hierarchy "$bad" "$tmp/c4.rtt" >/dev/null 2>"$tmp/u.log"
    [ $? = 2 ] && grep -q -- "--hierarchy" "$tmp/u.log" || err "--hierarchy $bad: $(cat "$tmp/u.log")"
done
"$bin" bench --what cores --scene cornell -W 24 -H 24 --cores 3 --reps 1 >"$tmp/b.txt" 2>&1 || err "bench --what cores: $(cat "$tmp/b.txt")"
grep -q "^| median | [0-9.]* | | [0-9.]* | [0-9.]* |" "$tmp/b.txt" || err "bench: $(cat "$tmp/b.txt")"

[ $fail = 0 ] && echo "PASS: cores_cli"
exit $fail
