#!/bin/sh
# Sweeps and the database under a hostile or careless user:
# 1. SIGTERM to a `sweep --jobs 2` stops its workers (none left, no run
#    stored after), and a rerun completes the matrix with no duplicates;
# 2. two different meshes both named mesh.obj stay two scenes in the report,
#    labelled by their paths, and --plot re-renders them from another folder;
#    a mesh gone from its place is a reported error;
# 3. options that do not apply are usage errors (exit 2) naming the option,
#    and `sim --db` of an empty trace stores nothing and fails;
# 4. --list-jobs lines name the binary and files absolutely, quote every
#    word, and run from another folder.
set -u
bin=${RT_BIN:-./raytraffic}
tmp=$(mktemp -d /tmp/rt-jobs-XXXXXX)
trap 'rm -rf "$tmp"' EXIT
fail=0
die() { echo "FAIL: $*"; fail=1; }
runs() { sqlite3 "$1" "SELECT COUNT(*) FROM runs" 2>/dev/null || echo 0; }

# ---- 1. SIGTERM reaches the workers ----------------------------------------
db="$tmp/term.db"
args="--scenes knot,cornell --lights primary,all --tracers recursive,dynamic -W 160 -H 160 --sizes 1K-1M"
"$bin" sweep $args --jobs 2 --db "$db" 2>"$tmp/term.log" &
parent=$!
i=0
while [ "$(runs "$db")" -lt 1 ] && [ $i -lt 300 ]; do sleep 0.1; i=$((i + 1)); done
kids=$(pgrep -P "$parent" | tr '\n' ' ')
[ -n "$kids" ] || die "no worker processes seen under the sweep"
kill -TERM "$parent"
wait "$parent"
st=$?
[ "$st" -ne 0 ] || die "a sweep stopped by SIGTERM exited 0"
sleep 0.5
left=""
for k in $kids; do kill -0 "$k" 2>/dev/null && left="$left $k"; done
[ -z "$left" ] || die "workers still running after SIGTERM to the sweep:$left"
[ -z "$(pgrep -f "$db" | tr -d '\n')" ] || die "a process with $db in its command line is still running"
n1=$(runs "$db"); sleep 1; n2=$(runs "$db")
[ "$n1" = "$n2" ] || die "runs still being stored after the sweep stopped: $n1 -> $n2"
total=$("$bin" sweep $args --list-jobs | wc -l)
[ "$n1" -lt "$total" ] || die "the matrix finished before SIGTERM ($n1 of $total): the test proves nothing"
grep -q "rerun the same command to resume" "$tmp/term.log" || die "no resume message: $(cat "$tmp/term.log")"
for k in $kids; do kill -KILL "$k" 2>/dev/null; done # never leave them behind
"$bin" sweep $args --jobs 2 --db "$db" 2>"$tmp/resume.log" || die "rerun after SIGTERM failed"
n=$(runs "$db")
keys=$(sqlite3 "$db" "SELECT COUNT(*) FROM (SELECT DISTINCT scene_id, tracer, W, H, lights, sched_size, params, sim_method FROM runs)")
[ "$n" = "$total" ] && [ "$keys" = "$total" ] || die "after the rerun: $n runs, $keys distinct, want $total"
grep -q "($n1 already in the database)" "$tmp/resume.log" || die "rerun did not skip the $n1 stored runs"

# ---- 2. two meshes of one file name ---------------------------------------
mkdir -p "$tmp/m/a" "$tmp/m/b" "$tmp/elsewhere"
"$bin" scene export cornell:glass=0 -o "$tmp/m/a/mesh.obj" 2>/dev/null || die "export cornell"
"$bin" scene export knot -o "$tmp/m/b/mesh.obj" 2>/dev/null || die "export knot"
(cd "$tmp/m" && "$bin" sweep --scenes a/mesh.obj,b/mesh.obj --lights primary --tracers recursive -W 16 -H 16 \
    --sizes 1K,64K --db mesh.db 2>/dev/null) || die "sweep of two meshes"
got=$(sqlite3 "$tmp/m/mesh.db" "SELECT name, path, abspath, triangles FROM scenes ORDER BY path")
want="mesh.obj|a/mesh.obj|$tmp/m/a/mesh.obj|36
mesh.obj|b/mesh.obj|$tmp/m/b/mesh.obj|1024"
[ "$got" = "$want" ] || die "scene rows: $got"
"$bin" report --db "$tmp/m/mesh.db" --format csv --figure scenes > "$tmp/mesh.csv" 2>&1 || die "report of two meshes"
grep -q '^mesh.obj (a/mesh.obj),36,' "$tmp/mesh.csv" && grep -q '^mesh.obj (b/mesh.obj),1024,' "$tmp/mesh.csv" ||
    die "report does not tell the two meshes apart: $(grep '^mesh' "$tmp/mesh.csv")"
# each scene's figure rows are its own run's traffic (1K, recursive)
for p in a b; do
    want=$(sqlite3 "$tmp/m/mesh.db" "SELECT printf('%.2f', geometry_mb) FROM v_traffic_group g JOIN runs r ON r.id = g.run_id
        JOIN scenes s ON s.id = r.scene_id WHERE s.path = '$p/mesh.obj' AND g.cache_size = 1024")
    [ -d "$tmp/mcsv" ] || "$bin" report --db "$tmp/m/mesh.db" --format csv --out "$tmp/mcsv" 2>/dev/null ||
        die "tidy tables of two meshes"
    got=$(awk -F, -v sc="mesh.obj ($p/mesh.obj)" 'NR == 1 { for (i = 1; i <= NF; i++) h[$i] = i; next }
        $h["cache_size"] == 1024 && $h["class_group"] == "geometry" && $h["tracer"] == "recursive" { s += $h["traffic_bytes"] }
        END { printf "%.2f", s / 1048576 }' "$tmp/mcsv/primary-mesh.obj (${p}_mesh.obj).csv" 2>/dev/null)
    [ "$got" = "$want" ] || die "figure rows of $p/mesh.obj: $got, not $want MB ($(ls "$tmp/mcsv"))"
done
(cd "$tmp/elsewhere" && "$bin" report --db ../m/mesh.db --plot plots >/dev/null 2>"$tmp/plot.log") ||
    die "report --plot from another folder: $(cat "$tmp/plot.log")"
[ -s "$tmp/elsewhere/plots/scenes.png" ] || die "no scene thumbnails"
mv "$tmp/m/b" "$tmp/m/gone"
(cd "$tmp/elsewhere" && "$bin" report --db ../m/mesh.db --plot plots2 >/dev/null 2>"$tmp/plot2.log")
st=$?
[ "$st" -ne 0 ] && grep -q "$tmp/m/b/mesh.obj" "$tmp/plot2.log" || die "a missing mesh is not a reported error (exit $st): $(cat "$tmp/plot2.log")"

# ---- 3. options that do not apply ------------------------------------------
"$bin" trace cornell -W 8 -H 8 -o "$tmp/t.rtt" 2>/dev/null || die "trace"
usage() { # expected-option command...
    opt=$1; shift
    "$@" >/dev/null 2>"$tmp/u.log"
    st=$?
    [ "$st" = 2 ] && grep -q -- "$opt" "$tmp/u.log" || die "'$*' exited $st, want 2 naming $opt: $(cat "$tmp/u.log")"
}
usage --rate "$bin" sim --rate 0.1 "$tmp/t.rtt"
usage --rate "$bin" sim --method exact --rate 1/64 "$tmp/t.rtt"
usage --seed "$bin" sim --seed 3 "$tmp/t.rtt"
usage --exact-below "$bin" sim --exact-below 4K "$tmp/t.rtt"
usage --smax "$bin" sim --method shards --smax 9000 "$tmp/t.rtt"
usage --rate "$bin" sim --method shards-fixed --rate 0.1 "$tmp/t.rtt"
usage --window "$bin" sim --method statstack --window 64 "$tmp/t.rtt"
usage --period "$bin" sim --method shards --period 64 "$tmp/t.rtt"
usage --window-below "$bin" sim --method shards --window-below 8K "$tmp/t.rtt"
usage --format "$bin" sim --db "$tmp/u.db" --format csv "$tmp/t.rtt"
usage --din-class "$bin" sim --input-format rtt --din-class tri "$tmp/t.rtt"
usage --qorder "$bin" sweep --tracers recursive,packet --qorder tree --db "$tmp/u.db"
usage --threads "$bin" sweep --tracers recursive --threads 8 --db "$tmp/u.db"
usage --packet "$bin" sweep --tracers recursive,dynamic --packet 4 --db "$tmp/u.db"
usage --dynamic-all-sizes "$bin" sweep --tracers packet --dynamic-all-sizes --db "$tmp/u.db"
usage --approx "$bin" sweep --tracers dynamic --approx shards:0.1 --db "$tmp/u.db"
[ ! -e "$tmp/u.db" ] || die "a usage error created the database"
# the applicable ones still work
"$bin" sim --method hybrid --rate 1/4 --seed 2 --period 64 --window 16 --sizes 1K,64K "$tmp/t.rtt" >/dev/null 2>&1 ||
    die "hybrid options refused"
"$bin" sim --method shards-fixed --smax 8192 --exact-below 2K --sizes 1K,64K "$tmp/t.rtt" >/dev/null 2>&1 ||
    die "shards-fixed options refused"
# an empty trace stores nothing
: > "$tmp/empty.din"
"$bin" sim --db "$tmp/e.db" --input-format din "$tmp/empty.din" 2>"$tmp/e.log"
st=$?
[ "$st" = 1 ] && grep -q "no references" "$tmp/e.log" || die "sim --db of an empty trace exited $st: $(cat "$tmp/e.log")"
[ "$(runs "$tmp/e.db")" = 0 ] || die "an empty run was stored"

# ---- 4. --list-jobs runs from anywhere ------------------------------------
mkdir -p "$tmp/lj/sub dir" "$tmp/far"
cp "$tmp/m/a/mesh.obj" "$tmp/lj/sub dir/it's.obj"
(cd "$tmp/lj" && "$bin" sweep --scenes "sub dir/it's.obj,cornell" --lights primary --tracers recursive -W 16 -H 16 \
    --sizes 1K,64K --keep-traces traces --db "shard's.db" --list-jobs > "$tmp/jobs.txt") || die "--list-jobs"
[ "$(wc -l < "$tmp/jobs.txt")" = 2 ] || die "want 2 jobs: $(cat "$tmp/jobs.txt")"
line=$(head -n 1 "$tmp/jobs.txt")
case "$line" in "'$bin' sweep "*) ;; *) die "job line does not start with the quoted absolute binary: $line" ;; esac
(cd "$tmp/far" && PATH=/nonexistent /bin/sh -c "$line" 2>"$tmp/lj.log") || die "job 0 from another folder: $(cat "$tmp/lj.log")"
(cd / && sh -c "$(sed -n 2p "$tmp/jobs.txt")" 2>>"$tmp/lj.log") || die "job 1 from /: $(cat "$tmp/lj.log")"
[ "$(runs "$tmp/lj/shard's.job0000.db")" = 1 ] && [ "$(runs "$tmp/lj/shard's.job0001.db")" = 1 ] ||
    die "shards not written beside the database named: $(ls "$tmp/lj" "$tmp/far")"
[ "$(ls "$tmp/lj/traces" | wc -l)" = 2 ] || die "kept traces not in the folder named"
[ -z "$(ls "$tmp/far")" ] || die "a job wrote into the folder it ran from: $(ls "$tmp/far")"
sqlite3 "$tmp/lj/shard's.job0000.db" "SELECT abspath FROM scenes" | grep -qx "$tmp/lj/sub dir/it's.obj" ||
    die "mesh path of the job"

# ---- 5. models: --list-jobs passes them through; the job stores its model --
"$bin" sweep --model paper --layout mesh --no-write-fullline --scenes cornell --lights primary --tracers recursive \
    -W 16 -H 16 --sizes 1K,64K --db "$tmp/md.db" --list-jobs > "$tmp/mjobs.txt" || die "--list-jobs with --model"
for w in "'--model' 'paper'" "'--layout' 'mesh'" "'--no-write-fullline'"; do
    grep -qF -- "$w" "$tmp/mjobs.txt" || die "--list-jobs dropped $w: $(cat "$tmp/mjobs.txt")"
done
sh -c "$(head -n 1 "$tmp/mjobs.txt")" 2>/dev/null || die "model job failed"
got=$(sqlite3 "$tmp/md.job0000.db" "SELECT r.params || '|' || r.sim_params || '|' || c.policy FROM runs r
    JOIN traffic t ON t.run_id = r.id JOIN cache_configs c ON c.id = t.config_id GROUP BY c.policy")
[ "$got" = "layout=mesh|model=paper policy=wb-wa+flush|wb-wa+flush" ] || die "model run stored as: $got"
# the same job under the lean model is a new run, and a rerun of either skips
"$bin" sweep --scenes cornell --lights primary --tracers recursive -W 16 -H 16 --sizes 1K,64K --layout mesh \
    --db "$tmp/md.job0000.db" 2>/dev/null || die "lean sweep"
[ "$(runs "$tmp/md.job0000.db")" = 2 ] || die "lean and paper runs share a key"
"$bin" sweep --model paper --layout mesh --no-write-fullline --scenes cornell --lights primary --tracers recursive \
    -W 16 -H 16 --sizes 1K,64K --db "$tmp/md.job0000.db" 2>&1 | grep -q "1 already in the database" ||
    die "paper rerun not skipped"
"$bin" sweep --model nonsense 2>/dev/null; [ $? = 2 ] || die "--model nonsense accepted"
"$bin" sweep --model paper --approx hybrid 2>/dev/null; [ $? = 2 ] || die "--model paper --approx accepted"
"$bin" sweep --queue-stores stream --tracers recursive 2>/dev/null; [ $? = 2 ] ||
    die "--queue-stores without the dynamic tracer accepted"

[ $fail = 0 ] && echo "jobs_cli: ok"
exit $fail
