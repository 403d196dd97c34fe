#!/bin/sh
# Scenes at scale (bench/scale_bench.c, docs/performance.md "Scale"):
# 1. `bench --what scale-quick` writes the torus mesh and the instanced
#    forest at their tiny sizes, renders each in a child process and
#    reports the triangle counts computed by hand below; its folder under
#    --tmpdir is gone afterwards;
# 2. `render --instances bvh` keeps the instances unflattened: 400
#    instances of a 972-triangle sphere (388,800 triangles) load under
#    maxtri=2000, which the flattened scene exceeds (refused naming maxtri),
#    and the image equals the flattened scene's (PNG bytes) when maxtri
#    allows both, with --lights all; `render --json` counts the flattened
#    triangles either way.
set -u
bin=${RT_BIN:-./raytraffic}
tmp=$(mktemp -d /tmp/rt-scale-cli-XXXXXX) || exit 1
trap 'rm -rf "$tmp"' EXIT
fail=0
die() { echo "FAIL: $*"; fail=1; }

# ---- 1. the quick bench ------------------------------------------------------
# torus: 60 x 61 quads, two triangles each = 7320; a tree: 8 crown bands x 16
# quads + 15 trunk bands x 64 quads, two triangles each = 2176; 2 trees
# = 4352 unique, 6 x 6 instances = 78336 instanced.
"$bin" bench --what scale-quick --tmpdir "$tmp" > "$tmp/out" 2>&1 || { cat "$tmp/out"; die "bench --what scale-quick"; }
grep -q '^| torus mesh (bvh8) | 7320 | 64x64 | ' "$tmp/out" || die "torus row: $(grep torus "$tmp/out")"
grep -q '^| forest, 36 instances of 2 trees (--instances bvh --lights all) | 78336 instanced, 4352 unique | 64x64 | ' "$tmp/out" ||
    die "forest row: $(grep forest "$tmp/out")"
left=$(ls "$tmp" | grep -c '^rt-scale-')
[ "$left" -eq 0 ] || die "bench left $left folder(s) under --tmpdir"

# ---- 2. kept instances --------------------------------------------------------
sc="$tmp/balls.pbrt"
{
    echo 'LookAt 0 30 -40  0 0 0  0 1 0'
    echo 'Camera "perspective" "float fov" 50'
    echo 'WorldBegin'
    echo 'LightSource "point" "point3 from" [10 40 -20] "rgb I" [50 50 50]'
    echo 'Shape "trianglemesh" "point3 P" [-30 -1 -30  30 -1 -30  30 -1 30  -30 -1 30] "integer indices" [0 1 2 0 2 3]'
    echo 'ObjectBegin "ball"'
    echo 'Shape "sphere" "float radius" 1'
    echo 'ObjectEnd'
    i=0
    while [ $i -lt 20 ]; do
        j=0
        while [ $j -lt 20 ]; do
            echo "AttributeBegin Translate $((i * 3 - 28)) 0 $((j * 3 - 28)) Rotate $((i * 7 + j)) 0 1 0 Scale 1 1.$j 1 ObjectInstance \"ball\" AttributeEnd"
            j=$((j + 1))
        done
        i=$((i + 1))
    done
} > "$sc"
"$bin" render "$sc:tess=9,maxtri=2000" -W 40 -H 30 -o "$tmp/f.exr" >/dev/null 2>"$tmp/err" &&
    die "the flattened scene loaded under maxtri=2000"
grep -q 'more than maxtri=2000' "$tmp/err" || die "flattened under maxtri=2000: '$(cat "$tmp/err")'"
"$bin" render "$sc:tess=9,maxtri=2000" --instances bvh --lights all -W 40 -H 30 -o "$tmp/k.exr" --png "$tmp/k.png" \
    --json >"$tmp/kj" 2>"$tmp/err" || die "kept instances under maxtri=2000: '$(cat "$tmp/err")'"
"$bin" render "$sc:tess=9" --lights all -W 40 -H 30 -o "$tmp/f.exr" --png "$tmp/f.png" --json >"$tmp/fj" 2>"$tmp/err" ||
    die "flattened: '$(cat "$tmp/err")'"
cmp -s "$tmp/k.png" "$tmp/f.png" || die "kept instances: the image differs from the flattened scene's"
for f in kj fj; do
    grep -q '"triangles": 388802,' "$tmp/$f" || die "$f: $(grep -o '"triangles": [0-9]*' "$tmp/$f")"
done

exit $fail
