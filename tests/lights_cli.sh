#!/bin/sh
# --light-samples from the command line: a floor under an area light casts
# 64 hits x N shadow rays (8 x 8 pixels, all on the floor), the same image
# from every tracer; the run key names the light model;
# scene info lists the file's lights; a built-in scene renders the same
# with and without the option; bad values, missing lights and secondary
# modes are usage errors (exit 2) with a one-line reason.
set -u
bin=${RT_BIN:-./raytraffic}
tmp=$(mktemp -d /tmp/rt_lights_cli.XXXXXX) || exit 1
trap 'rm -rf "$tmp"' EXIT
fail=0
err() { echo "FAIL: $*"; fail=1; }
[ -x "$bin" ] || { echo "FAIL: $bin is not an executable"; exit 1; }

cat > "$tmp/lamp.pbrt" <<'PBRT'
LookAt 0 0 5  0 0 0  0 1 0
Camera "perspective" "float fov" 40
Film "rgb" "integer xresolution" 8 "integer yresolution" 8
WorldBegin
Shape "trianglemesh" "point3 P" [-50 -50 0  50 -50 0  0 50 0] "integer indices" [0 1 2]
AttributeBegin
AreaLightSource "diffuse" "rgb L" [4 4 4]
Shape "trianglemesh" "point3 P" [-1 -1 10  1 -1 10  0 1 10] "integer indices" [0 1 2]
AttributeEnd
PBRT

for t in recursive packet dynamic treelet stream-branching stream-multipass feedback; do
    "$bin" render "$tmp/lamp.pbrt" -t $t --lights 0 --light-samples 16 --json -o "$tmp/a.exr" --png "$tmp/$t.png" \
        > "$tmp/$t.json" 2>/dev/null || err "render -t $t --light-samples 16"
    grep -q '"rays_shadow": 1024,' "$tmp/$t.json" || err "$t: 64 hits x 16 samples: $(cat "$tmp/$t.json")"
done
for t in packet dynamic treelet stream-branching stream-multipass feedback; do
    cmp -s "$tmp/recursive.png" "$tmp/$t.png" || err "$t image differs from recursive's"
done
"$bin" render "$tmp/lamp.pbrt" --lights all --light-samples 4 --json -o "$tmp/a.exr" 2>/dev/null \
    | grep -q '"rays_shadow": 256,' || err "--lights all, 4 samples: not 256 shadow rays"
"$bin" render "$tmp/lamp.pbrt" --lights 0 --json -o "$tmp/a.exr" --png "$tmp/point.png" 2>/dev/null \
    | grep -q '"rays_shadow": 64,' || err "point model: not 64 shadow rays"
cmp -s "$tmp/point.png" "$tmp/recursive.png" && err "16 lamp samples left the point model's image unchanged"

"$bin" trace "$tmp/lamp.pbrt" --lights 0 --light-samples 4 -o "$tmp/t.rtt" >/dev/null 2>&1 || err "trace --light-samples"
"$bin" trace-info "$tmp/t.rtt" | grep -q "light_model=authored light_samples=4" \
    || err "trace-info: $("$bin" trace-info "$tmp/t.rtt" | grep tracer:)"
"$bin" scene info "$tmp/lamp.pbrt" --no-tree 2>/dev/null | grep -q "^file light 0  mesh     triangles 1..1" \
    || err "scene info does not list the lamp"

# the database: light_model authored beside the point model's run
"$bin" sweep --scenes "$tmp/lamp.pbrt" --tracers recursive --lights 0,all -W 8 -H 8 --sizes 64K --light-samples 4 \
    --db "$tmp/s.db" >/dev/null 2>&1 || err "sweep --light-samples"
"$bin" sweep --scenes "$tmp/lamp.pbrt" --tracers recursive --lights 0 -W 8 -H 8 --sizes 64K --db "$tmp/s.db" \
    >/dev/null 2>&1 || err "sweep, point model"
sqlite3 "$tmp/s.db" "SELECT lights, light_model, params FROM runs ORDER BY id" > "$tmp/rows" || err "sqlite3"
printf '%s\n' "1|authored|light_model=authored light_samples=4" "7|authored|light_model=authored light_samples=4 lights=all" \
    "1|point|" | cmp -s - "$tmp/rows" || err "runs rows: $(cat "$tmp/rows")"
"$bin" sim --db "$tmp/t.db" --sizes 64K "$tmp/t.rtt" >/dev/null 2>&1 || err "sim --db"
[ "$(sqlite3 "$tmp/t.db" "SELECT light_model FROM runs")" = authored ] || err "sim --db: light_model not authored"

# a built-in scene has no light records: the option changes nothing
"$bin" render cornell -W 16 -H 16 --lights all -o "$tmp/a.exr" --png "$tmp/c0.png" 2>/dev/null || err "render cornell"
"$bin" render cornell -W 16 -H 16 --lights all --light-samples 16 -o "$tmp/a.exr" --png "$tmp/c1.png" 2>/dev/null \
    || err "render cornell --light-samples"
cmp -s "$tmp/c0.png" "$tmp/c1.png" || err "--light-samples changed a built-in scene's image"

# golden traffic: the Cornell box's lamp sampled 4 times per hit, 32 x 32,
# simulated at 4K and 64K (the sample points decide every address the
# shadow rays touch, so this pins the sampling on every machine);
# RT_REDO_GOLDEN=1 rewrites tests/golden/lights_cornell.csv
golden=${RT_SRCDIR:-.}/tests/golden/lights_cornell.csv
"$bin" trace "${RT_SRCDIR:-.}/data/pbrt/cornell.pbrt" -W 32 -H 32 --lights all --light-samples 4 -o "$tmp/c.rtt" \
    >/dev/null 2>&1 || err "trace cornell.pbrt --light-samples 4"
"$bin" sim --sizes 4K,64K --format csv "$tmp/c.rtt" 2>/dev/null | cut -d, -f2- > "$tmp/c.csv" || err "sim"
if [ "${RT_REDO_GOLDEN:-0}" = 1 ]; then cp "$tmp/c.csv" "$golden"; echo "regenerated $golden"; fi
diff -u "$golden" "$tmp/c.csv" || err "traffic differs from $golden"

# usage errors: exit 2, one line naming the problem
usage() { # want-text, then the command's arguments
    want=$1
    shift
    "$bin" "$@" > /dev/null 2> "$tmp/err"
    rc=$?
    [ $rc -eq 2 ] || err "$*: exit $rc, expected 2"
    grep -q -- "$want" "$tmp/err" || err "$*: message '$(cat "$tmp/err")' lacks '$want'"
    [ "$(grep -c . "$tmp/err")" -eq 1 ] || err "$*: more than one line: $(cat "$tmp/err")"
}
usage "--light-samples: '0' is not a sample count" render "$tmp/lamp.pbrt" --light-samples 0 -o "$tmp/a.exr"
usage "--light-samples: 'x' is not a sample count" render "$tmp/lamp.pbrt" --light-samples x -o "$tmp/a.exr"
usage "light 1 does not exist" render "$tmp/lamp.pbrt" --lights 1 --light-samples 4 -o "$tmp/a.exr"
usage "light 3 does not exist" render cornell --lights 3 -W 8 -H 8 -o "$tmp/a.exr"
usage "--lights: '32' is not" render cornell --lights 32 -o "$tmp/a.exr"
usage "give one of them" render "$tmp/lamp.pbrt" --lights 0 --light 1,2,3 --light-samples 4 -o "$tmp/a.exr"
usage "mode whitted follows the three point lights only" render "$tmp/lamp.pbrt" --mode whitted --lights 0 \
    --light-samples 4 -o "$tmp/a.exr"
[ $fail -eq 0 ] && echo "lights_cli: all passed"
exit $fail
