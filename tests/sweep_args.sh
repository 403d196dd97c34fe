#!/bin/sh
# sweep's scene list and its failures:
#  1. --scenes-file names meshes whose names hold commas (which --scenes,
#     a comma list, cannot), relative to the file's folder; comments and
#     blank lines skipped; --list-jobs reprints it as an absolute path;
#  2. --list-jobs loads every scene first: an unknown built-in, a missing
#     file and an unloadable .pbrt exit 1 with the loader's message and
#     print no job line; the unknown-scene message names .pbrt;
#  3. a sweep that fails before storing a run leaves no database behind
#     (a bad scene; a job failing in the database), and one that existed
#     before stays;
#  4. --scene is --scenes with one spec (not an ambiguous abbreviation); a
#     scene's load warnings are printed once per sweep, and --strict refuses
#     it before a database is created.
set -u
bin=${RT_BIN:-./raytraffic}
tmp=$(mktemp -d /tmp/rt-sweepargs-XXXXXX)
trap 'rm -rf "$tmp"' EXIT
fail=0
die() { echo "FAIL: $*"; fail=1; }
want() {
    st=$1; shift; what=$1; shift
    "$@" >"$tmp/out" 2>"$tmp/err"; got=$?
    [ "$got" -eq "$st" ] || die "$what: exit $got, want $st ($(head -c 300 "$tmp/err"))"
}
mkdir "$tmp/m"
printf 'v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\nf 1 2 4\nf 1 3 4\nf 2 3 4\n' > "$tmp/m/a,b.obj" # a tetrahedron
printf '# scenes\n\na,b.obj\ncornell\n' > "$tmp/m/list"

# ---- 1. --scenes-file ------------------------------------------------------
want 0 "sweep --scenes-file" "$bin" sweep --scenes-file "$tmp/m/list" --tracers recursive --lights primary -W 8 -H 8 \
    --sizes 1K,2K --db "$tmp/f.db"
n=$(sqlite3 "$tmp/f.db" "select count(*) from runs")
[ "$n" = 2 ] || die "--scenes-file: $n runs, want 2"
sqlite3 "$tmp/f.db" "select path from scenes" | grep -q "m/a,b.obj$" || die "the comma mesh is not stored: $(sqlite3 "$tmp/f.db" "select * from scenes")"
want 1 "--scenes a,b.obj splits at the comma" "$bin" sweep --scenes "$tmp/m/a,b.obj" --tracers recursive --list-jobs
grep -q "list a name holding one in --scenes-file" "$tmp/err" || die "no hint at --scenes-file: $(cat "$tmp/err")"
(cd "$tmp" && "$bin" sweep --scenes-file m/list --tracers recursive --lights primary --list-jobs) > "$tmp/jobs" 2>"$tmp/err" \
    || die "--list-jobs with --scenes-file: $(cat "$tmp/err")"
[ "$(wc -l < "$tmp/jobs")" -eq 2 ] || die "--list-jobs: $(wc -l < "$tmp/jobs") lines, want 2"
grep -q "'--scenes-file' '/" "$tmp/jobs" || die "--list-jobs: the list file is not absolute: $(head -1 "$tmp/jobs")"
want 2 "--scenes and --scenes-file" "$bin" sweep --scenes cornell --scenes-file "$tmp/m/list" --list-jobs
printf 'cornell\n\tknot\n' > "$tmp/bad"
want 2 "a control character in the file" "$bin" sweep --scenes-file "$tmp/bad" --list-jobs
grep -q "bad:2" "$tmp/err" || die "control character: no FILE:LINE: $(cat "$tmp/err")"
printf '# nothing\n' > "$tmp/none"
want 2 "an empty list" "$bin" sweep --scenes-file "$tmp/none" --list-jobs
want 2 "a folder as the list" "$bin" sweep --scenes-file "$tmp/m" --list-jobs

# ---- 2. --list-jobs validates the scenes -----------------------------------
want 1 "--list-jobs, unknown built-in" "$bin" sweep --scenes cornell,nosuch --list-jobs
grep -q "unknown scene 'nosuch' (not .obj/.ply/.pbrt" "$tmp/err" || die "unknown scene message: $(cat "$tmp/err")"
[ -s "$tmp/out" ] && die "--list-jobs printed jobs for an unknown scene"
want 1 "--list-jobs, missing file" "$bin" sweep --scenes "$tmp/missing.obj" --list-jobs
printf 'Shape "nosuchshape"\n' > "$tmp/bad.pbrt"
want 1 "--list-jobs, unloadable .pbrt" "$bin" sweep --scenes "$tmp/bad.pbrt" --list-jobs
grep -q "bad.pbrt:1" "$tmp/err" || die "pbrt message lacks FILE:LINE: $(cat "$tmp/err")"
want 0 "--list-jobs, good scenes" "$bin" sweep --scenes cornell,knot --tracers recursive --list-jobs
want 2 "--list-jobs, a view along knot's up" "$bin" sweep --scenes cornell,knot --tracers recursive \
    --look-at 0,0,12,0,0,0 --list-jobs
grep -q "^raytraffic sweep: cornell: --look-at: the scene.s up vector" "$tmp/err" || die "view message: $(cat "$tmp/err")"

# ---- 3. no empty database ---------------------------------------------------
want 1 "sweep, unknown scene" "$bin" sweep --scenes nosuch --tracers recursive -W 8 -H 8 --db "$tmp/e.db"
[ -e "$tmp/e.db" ] && die "a failed sweep left $tmp/e.db"
want 1 "sweep, a job failing in the database" env RT_SWEEP_FAIL_JOB=0:"$tmp/marker" "$bin" sweep --scenes cornell \
    --tracers recursive --lights primary -W 8 -H 8 --db "$tmp/j.db"
ls "$tmp"/j.db* >/dev/null 2>&1 && die "a failed sweep left $(ls "$tmp"/j.db*)"
grep -q "removed the empty" "$tmp/err" || die "no word of the removed database: $(cat "$tmp/err")"
want 0 "--job 0 loads only its own scene" "$bin" sweep --scenes cornell,nosuch --tracers recursive --lights primary \
    -W 8 -H 8 --sizes 1K --job 0 --db "$tmp/j0.db"
want 1 "--job 1 loads its bad scene" "$bin" sweep --scenes cornell,nosuch --tracers recursive --lights primary \
    -W 8 -H 8 --sizes 1K --job 1 --db "$tmp/j1.db"
[ -e "$tmp/j1.db" ] && die "--job 1 of a bad scene left its database"
cp "$tmp/f.db" "$tmp/keep.db"
want 1 "sweep into an existing database, unknown scene" "$bin" sweep --scenes nosuch --db "$tmp/keep.db"
cmp -s "$tmp/f.db" "$tmp/keep.db" || die "the existing database changed"

# ---- 4. --scene, warnings, --strict -----------------------------------------
want 0 "sweep --scene" "$bin" sweep --scene cornell --tracers recursive --lights primary -W 8 -H 8 --sizes 1K \
    --db "$tmp/s1.db"
[ "$(sqlite3 "$tmp/s1.db" "select count(*) from runs")" = 1 ] || die "--scene: not one run"
printf 'Sampler "halton"\nWorldBegin\nShape "trianglemesh" "point3 P" [ 0 0 0 1 0 0 0 1 0 ]\n' > "$tmp/w.pbrt"
want 0 "sweep of a scene that warns" "$bin" sweep --scene "$tmp/w.pbrt" --tracers recursive,packet --lights primary \
    -W 8 -H 8 --sizes 1K --jobs 2 --db "$tmp/w.db"
[ "$(grep -c "^raytraffic sweep: warning: $tmp/w.pbrt:1: Sampler skipped$" "$tmp/err")" = 1 ] ||
    die "the warning once: $(cat "$tmp/err")"
want 1 "sweep --strict" "$bin" sweep --scene "$tmp/w.pbrt" --strict --tracers recursive --lights primary -W 8 -H 8 \
    --db "$tmp/ws.db"
grep -q "w.pbrt:1: Sampler skipped (--strict: 1 kind of warnings are errors)$" "$tmp/err" || die "--strict: $(cat "$tmp/err")"
[ -e "$tmp/ws.db" ] && die "sweep --strict left a database"
exit $fail
