#!/bin/sh
# Alpha cutouts end to end: a .pbrt with two cards, one masked by a PNG
# and one by an OpenEXR image (both written here by test_alpha), over a
# wall. scene info reports the textures; every tracer and structure makes
# the same image, and it is not the opaque one (the spec parameter
# alpha=0); a trace holds the alpha class and its regions, the opaque one
# neither; a malformed image is one line naming the file, exit 1.
set -u
bin=${RT_BIN:-./raytraffic}
mk=${RT_BUILDDIR:-.}/tests/test_alpha
tmp=$(mktemp -d /tmp/rt_alpha_cli.XXXXXX) || exit 1
trap 'rm -rf "$tmp"' EXIT
fail=0
err() { echo "FAIL: $*"; fail=1; }

# a 4x4 mask, row 0 on top: 1 1 0 1 / 0 1 1 0 / 1 0 0 0 / 1 1 1 1 (PNG); the EXR with
# partial values (pbrt's hashed test: every tracer must agree ray by ray)
"$mk" --png "$tmp/m.png" 4 4 255 255 0 255 0 255 255 0 255 0 0 0 255 255 255 255 || err "writing m.png"
"$mk" --exr "$tmp/m.exr" 4 4 1 0.5 0 1 0 1 0.7 0 0.3 0 0 0 1 1 0.5 1 || err "writing m.exr"
cat > "$tmp/a.pbrt" <<'EOF'
LookAt 0 0 -3  0 0 0  0 1 0
Camera "perspective" "float fov" 40
Film "rgb" "integer xresolution" 32 "integer yresolution" 32
WorldBegin
LightSource "point" "point3 from" [0 2 -3] "rgb I" [10 10 10]
Texture "png" "float" "imagemap" "string filename" "m.png" "string filter" "point"
Texture "exr" "float" "imagemap" "string filename" "m.exr" "string filter" "point"
Material "diffuse" "rgb reflectance" [0.8 0.1 0.1]
Shape "trianglemesh" "point3 P" [-1 -1 0  0 -1 0  0 1 0  -1 1 0] "integer indices" [0 1 2 0 2 3]
  "point2 uv" [0 0 1 0 1 1 0 1] "texture alpha" "png"
Shape "bilinearmesh" "point3 P" [0 -1 0  1 -1 0  0 1 0  1 1 0] "texture alpha" "exr"
Material "diffuse" "rgb reflectance" [0.5 0.5 0.5]
Shape "trianglemesh" "point3 P" [-3 -3 2  3 -3 2  3 3 2  -3 3 2] "integer indices" [0 1 2 0 2 3]
EOF
"$bin" scene info "$tmp/a.pbrt" --no-tree > "$tmp/info" 2> "$tmp/ilog" || err "scene info: $(cat "$tmp/ilog")"
grep -q '^alpha        2 textures (32 texels), 4 triangles with a cutout$' "$tmp/info" || err "info: $(cat "$tmp/info")"
[ -s "$tmp/ilog" ] && err "warnings: $(cat "$tmp/ilog")"
"$bin" scene info "$tmp/a.pbrt" --no-tree --json > "$tmp/json" || err "scene info --json"
grep -q '"alpha_textures": 2,' "$tmp/json" && grep -q '"alpha_triangles": 4,' "$tmp/json" || err "json: $(cat "$tmp/json")"

# every tracer (shadow rays on) and every structure: one image
for t in recursive packet dynamic treelet stream-branching stream-multipass feedback; do
    "$bin" render "$tmp/a.pbrt" -t $t --lights 0 -o "$tmp/r.exr" --ppm "$tmp/t-$t.ppm" 2> /dev/null || err "render -t $t"
done
for a in bvh2 bvh4 bvh8 naive; do
    "$bin" render "$tmp/a.pbrt" --accel $a --lights 0 -o "$tmp/r.exr" --ppm "$tmp/a-$a.ppm" 2> /dev/null || err "render --accel $a"
done
for f in "$tmp"/t-*.ppm "$tmp"/a-*.ppm; do
    cmp -s "$tmp/t-recursive.ppm" "$f" || err "$(basename "$f") differs from the recursive tracer's image"
done
"$bin" render "$tmp/a.pbrt:alpha=0" --lights 0 -o "$tmp/r.exr" --ppm "$tmp/opaque.ppm" 2> "$tmp/olog" || err "alpha=0"
cmp -s "$tmp/t-recursive.ppm" "$tmp/opaque.ppm" && err "the cutout image equals the opaque one"
grep -q 'alpha texture "png" drawn opaque (the spec parameter alpha=0) (x2)\|alpha texture "png" drawn opaque' "$tmp/olog" ||
    err "alpha=0 warning: $(cat "$tmp/olog")"

# traces: the alpha class and its two regions only with the cutout
"$bin" trace "$tmp/a.pbrt" --lights 0 -o "$tmp/c.rtt" 2> /dev/null || err "trace"
"$bin" trace "$tmp/a.pbrt:alpha=0" --lights 0 -o "$tmp/o.rtt" 2> /dev/null || err "trace alpha=0"
"$bin" trace-info "$tmp/c.rtt" > "$tmp/ci" 2>&1 || err "trace-info: $(cat "$tmp/ci")"
"$bin" trace-info "$tmp/o.rtt" > "$tmp/oi" 2>&1 || err "trace-info alpha=0"
grep -q '^  alpha\.tri  *alpha .* 28  *6 ' "$tmp/ci" && grep -q '^  alpha\.texel  *alpha .* 4  *32 ' "$tmp/ci" ||
    err "regions: $(cat "$tmp/ci")"
grep -q '^  alpha  *geometry  *[1-9]' "$tmp/ci" || err "no alpha references: $(cat "$tmp/ci")"
grep -Eq '^  alpha[ .]' "$tmp/oi" && err "the opaque trace has alpha: $(cat "$tmp/oi")"
# on simulated cores each core's recorder gets the alpha reads of its rays
for t in recursive treelet stream-branching; do
    "$bin" trace "$tmp/a.pbrt" -t $t --lights 0 --cores 2 -o "$tmp/k.rtt" 2> /dev/null || err "trace -t $t --cores 2"
    "$bin" trace-info "$tmp/k.rtt" > "$tmp/ki" 2>&1 || err "trace-info -t $t --cores 2: $(cat "$tmp/ki")"
    grep -q '^  alpha  *geometry  *[1-9]' "$tmp/ki" || err "$t --cores 2: no alpha references: $(cat "$tmp/ki")"
done

# instances before the cards (their triangles come first in the flattened
# order) and after: flattened and kept (--instances bvh) give one image
{
    sed -n '1,7p' "$tmp/a.pbrt"
    echo 'ObjectBegin "box"'
    echo 'Shape "trianglemesh" "point3 P" [-0.2 -0.2 -0.2 0.2 -0.2 -0.2 0.2 0.2 -0.2 -0.2 0.2 -0.2 -0.2 -0.2 0.2 0.2 -0.2 0.2 0.2 0.2 0.2 -0.2 0.2 0.2]'
    echo '  "integer indices" [0 1 2 0 2 3 4 6 5 4 7 6 0 4 5 0 5 1 3 2 6 3 6 7 0 3 7 0 7 4 1 5 6 1 6 2]'
    echo 'ObjectEnd'
    echo 'AttributeBegin Translate -0.6 0.6 -0.5 ObjectInstance "box" AttributeEnd'
    echo 'AttributeBegin Translate 0.6 -0.6 1 ObjectInstance "box" AttributeEnd'
    sed -n '8,12p' "$tmp/a.pbrt"
    echo 'AttributeBegin Translate 0.6 0.6 1.5 ObjectInstance "box" AttributeEnd'
    sed -n '13,$p' "$tmp/a.pbrt"
} > "$tmp/k.pbrt"
"$bin" scene info "$tmp/k.pbrt" --no-tree > "$tmp/kinfo" 2>&1 || err "scene info k.pbrt: $(cat "$tmp/kinfo")"
grep -q '^alpha        2 textures (32 texels), 4 triangles with a cutout$' "$tmp/kinfo" &&
    grep -q '^two-level    3 instance records' "$tmp/kinfo" || err "k.pbrt: $(cat "$tmp/kinfo")"
"$bin" render "$tmp/k.pbrt" --lights 0 -o "$tmp/r.exr" --ppm "$tmp/k-flat.ppm" 2> /dev/null || err "render k.pbrt"
"$bin" render "$tmp/k.pbrt" --instances bvh --lights 0 -o "$tmp/r.exr" --ppm "$tmp/k-kept.ppm" 2> /dev/null ||
    err "render k.pbrt --instances bvh"
"$bin" render "$tmp/k.pbrt:alpha=0" --lights 0 -o "$tmp/r.exr" --ppm "$tmp/k-opaque.ppm" 2> /dev/null || err "k alpha=0"
cmp -s "$tmp/k-flat.ppm" "$tmp/k-kept.ppm" || err "kept instances: the image differs from the flattened scene's"
cmp -s "$tmp/k-flat.ppm" "$tmp/k-opaque.ppm" && err "k.pbrt: the cutout image equals the opaque one"

# malformed images: one line naming the file, exit 1
head -c 60 "$tmp/m.png" > "$tmp/cut.png"
sed 's/m\.png/cut.png/' "$tmp/a.pbrt" > "$tmp/b.pbrt"
"$bin" scene info "$tmp/b.pbrt" --no-tree > /dev/null 2> "$tmp/blog"
rc=$?
[ $rc = 1 ] || err "truncated PNG: exit $rc"
[ "$(wc -l < "$tmp/blog")" = 1 ] && grep -q 'b\.pbrt:6:.*cut\.png.*PNG' "$tmp/blog" || err "truncated PNG: $(cat "$tmp/blog")"
printf 'v/1\001garbage' > "$tmp/bad.exr"
sed 's/m\.exr/bad.exr/' "$tmp/a.pbrt" > "$tmp/c.pbrt"
"$bin" scene info "$tmp/c.pbrt" --no-tree > /dev/null 2> "$tmp/clog"
rc=$?
[ $rc = 1 ] || err "bad EXR: exit $rc"
[ "$(wc -l < "$tmp/clog")" = 1 ] && grep -q 'c\.pbrt:7:.*bad\.exr.*OpenEXR' "$tmp/clog" || err "bad EXR: $(cat "$tmp/clog")"
sed 's/m\.exr/none.exr/' "$tmp/a.pbrt" > "$tmp/d.pbrt"
"$bin" scene info "$tmp/d.pbrt" --no-tree > /dev/null 2> "$tmp/dlog" && err "missing EXR accepted"
grep -q 'd\.pbrt:7:.*none\.exr' "$tmp/dlog" || err "missing EXR: $(cat "$tmp/dlog")"
exit $fail
