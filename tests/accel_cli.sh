#!/bin/sh
# Structures as a sweep dimension and `report --figure accel`:
# 1. `sweep --accels kd,bvh2,bvh4,bvh8` runs each tracer on the listed
#    structures its traits allow (dynamic: the k-d tree only), the runs on a
#    tracer's default structure keep the key of a plain sweep (a plain sweep
#    afterwards stores nothing new), and every --list-jobs line reproduces
#    its job's rows;
# 2. the report on that sweep matches a golden file; its plot data hold one
#    column per structure;
# 3. `bench --what bvh` runs (walks agree with the k-d tree, the tracer on
#    every structure); bad lists are usage errors (exit 2); a database
#    without a structure sweep is a reported error.
# Set RT_REDO_GOLDEN=1 to regenerate the golden report.
set -u
bin=${RT_BIN:-./raytraffic}
src=${RT_SRCDIR:-.}
golden="$src/tests/golden/accel_report.md"
tmp=$(mktemp -d /tmp/rt-accel-XXXXXX)
trap 'rm -rf "$tmp"' EXIT
fail=0
die() { echo "FAIL: $*"; fail=1; }
q() { sqlite3 "$1" "$2" 2>/dev/null || echo "sqlite error"; }
args="--scenes cornell:glass=0,knot --tracers recursive,packet,dynamic --lights primary,all -W 24 -H 20 --sizes 1K,4K,64K"
contents() { # the database's results, without volatile provenance
    sqlite3 "$1" "SELECT s.name, s.hash, r.tracer, r.W, r.H, r.lights, r.sched_size, r.params, r.refs, r.stats,
        c.size, t.class, t.accesses, t.read_misses, t.write_misses, t.writebacks, t.traffic_bytes
        FROM traffic t JOIN runs r ON r.id = t.run_id JOIN scenes s ON s.id = r.scene_id
        JOIN cache_configs c ON c.id = t.config_id" |
        sed -e 's/render_seconds=[0-9.]*//' -e 's/sim_seconds=[0-9.]*//' -e 's/accel_build_seconds=[0-9.]*//' | sort
}

# ---- 1. the matrix ------------------------------------------------------------
db="$tmp/a.db"
"$bin" sweep $args --accels kd,bvh2,bvh4,bvh8 --db "$db" 2>"$tmp/log" || { cat "$tmp/log"; die "sweep --accels"; }
# per scene and lighting: recursive and packet on 4 structures, dynamic on kd at 3 sizes
[ "$(q "$db" "SELECT COUNT(*) FROM runs")" = 44 ] || die "runs: want 44, got $(q "$db" "SELECT COUNT(*) FROM runs")"
for t in recursive packet; do
    got=$(q "$db" "SELECT group_concat(k, ',') FROM (SELECT DISTINCT CASE WHEN params LIKE '%accel=%'
        THEN substr(params, instr(params, 'accel=') + 6, 4) ELSE 'kd' END AS k FROM runs WHERE tracer = '$t' ORDER BY k)")
    [ "$got" = "bvh2,bvh4,bvh8,kd" ] || die "$t ran on $got, want bvh2,bvh4,bvh8,kd"
done
[ "$(q "$db" "SELECT COUNT(*) FROM runs WHERE tracer = 'dynamic' AND params LIKE '%accel=%'")" = 0 ] \
    || die "dynamic ran on a structure it does not list"
[ "$(q "$db" "SELECT COUNT(*) FROM runs WHERE stats NOT LIKE '%accel_nodes=%'")" = 0 ] \
    || die "a structure sweep's run lacks the footprint"
# the default structure keeps its key: a plain sweep finds every run stored
n1=$(q "$db" "SELECT COUNT(*) FROM runs")
"$bin" sweep $args --db "$db" 2>"$tmp/log2" || die "plain sweep"
[ "$(q "$db" "SELECT COUNT(*) FROM runs")" = "$n1" ] || die "a plain sweep stored new runs: the kd keys changed"
grep -q "0 run(s) finished (20 already in the database)" "$tmp/log2" || die "plain sweep: $(tail -1 "$tmp/log2")"
# --list-jobs: one line per job; every 7th line run alone reproduces its rows
"$bin" sweep $args --accels kd,bvh2,bvh4,bvh8 --db "$tmp/l.db" --list-jobs > "$tmp/jobs" || die "--list-jobs"
[ "$(wc -l < "$tmp/jobs")" = 44 ] || die "--list-jobs: $(wc -l < "$tmp/jobs") lines, want 44"
contents "$db" > "$tmp/all"
i=0
while IFS= read -r line; do
    if [ $((i % 7)) = 3 ]; then
        (cd "$tmp" && eval "$line") 2>/dev/null || die "job $i: $line"
        f=$(printf '%s/l.job%04d.db' "$tmp" $i)
        contents "$f" > "$tmp/one"
        [ -s "$tmp/one" ] || die "job $i stored nothing"
        [ -z "$(comm -23 "$tmp/one" "$tmp/all")" ] || die "job $i: rows differ from the sweep's"
    fi
    i=$((i + 1))
done < "$tmp/jobs"

# ---- 2. the report ----------------------------------------------------------------
"$bin" report --db "$db" --figure accel > "$tmp/report.md" || die "report --figure accel"
if [ "${RT_REDO_GOLDEN:-0}" = 1 ]; then cp "$tmp/report.md" "$golden"; echo "regenerated $golden"; fi
diff -u "$golden" "$tmp/report.md" || die "report differs from $golden"
"$bin" report --db "$db" --figure accel --format csv > "$tmp/report.csv" || die "report --figure accel --format csv"
# 8 groups x 4 structures x 3 sizes, and the header
[ "$(wc -l < "$tmp/report.csv")" = 97 ] || die "csv: $(wc -l < "$tmp/report.csv") lines, want 97"
RT_GNUPLOT=/bin/true "$bin" report --db "$db" --figure accel --scene knot --plot "$tmp/plots" \
    > /dev/null 2>"$tmp/plot.err" || die "report --figure accel --plot: $(cat "$tmp/plot.err")"
dat="$tmp/plots/accel-knot_24x20_lights_all__recursive.dat"
[ -f "$dat" ] && [ -f "${dat%.dat}.gp" ] || die "plot files missing: $(ls "$tmp/plots" 2>&1)"
awk '!/^#/ && NF == 5 { n++ } END { exit n != 3 }' "$dat" 2>/dev/null || die "plot data: $(cat "$dat" 2>&1)"

# ---- bench --what bvh, smallest settings: the walks agree with the k-d tree,
# and the tracer runs on every structure
"$bin" bench --what bvh --scene knot -W 12 -H 10 --reps 1 > "$tmp/bench" 2>&1 || die "bench --what bvh: $(cat "$tmp/bench")"
[ "$(grep -cE '^\| bvh[248] \|' "$tmp/bench")" = 6 ] || die "bench --what bvh: rows: $(cat "$tmp/bench")"
awk -F'|' '/^\| bvh[248] \|/ && NF == 16 && $13 + 0 != 0 { bad = 1 } END { exit bad }' "$tmp/bench" \
    || die "bench --what bvh: hits differ: $(cat "$tmp/bench")"

# ---- 3. errors ------------------------------------------------------------------
for bad in "--accels bvh4 --accel kd" "--accels nope" "--accels kd,kd" "--accels grid"; do
    "$bin" sweep $args $bad --db "$tmp/x.db" > /dev/null 2>&1
    [ $? = 2 ] || die "sweep $bad should exit 2"
done
"$bin" sweep --scenes knot --tracers dynamic --accels bvh4 --db "$tmp/x.db" > /dev/null 2>&1
[ $? = 2 ] || die "sweep --tracers dynamic --accels bvh4 should exit 2"
"$bin" sweep --scenes knot --tracers recursive --lights primary -W 8 -H 8 --sizes 1K --db "$tmp/p.db" 2>/dev/null || die "plain sweep"
out=$("$bin" report --db "$tmp/p.db" --figure accel 2>&1); rc=$?
[ $rc = 1 ] && echo "$out" | grep -q "sweep --accels" || die "report --figure accel without structures: exit $rc: $out"
exit $fail
