#!/bin/sh
# pbrt scene files end to end: `scene info` reports instancing and the
# Film; render, trace and sweep take the Film's resolution as the image
# size when -W/-H are not given (one of them given: the Film's aspect
# ratio sets the other); warnings reach stderr, bad input exits 1 with
# one line naming FILE:LINE:COL.
set -u
bin=${RT_BIN:-./raytraffic}
src=${RT_SRCDIR:-.}
tmp=$(mktemp -d /tmp/rt_pbrt_cli.XXXXXX) || exit 1
trap 'rm -rf "$tmp"' EXIT
fail=0
err() { echo "FAIL: $*"; fail=1; }
main="$src/tests/data/pbrt/main.pbrt"
box="$src/data/pbrt/cornell.pbrt"

# scene info
"$bin" scene info "$box" --no-tree > "$tmp/info" || err "scene info cornell.pbrt"
grep -q '^triangles    36$' "$tmp/info" || err "cornell.pbrt: $(grep triangles "$tmp/info")"
grep -q '^instancing   24 unique triangles; 2 instances give 24 of the total$' "$tmp/info" || err "instancing line"
grep -q '^film         256x256' "$tmp/info" || err "film line"
"$bin" scene info "$box" --no-tree --json > "$tmp/json" || err "scene info --json"
grep -q '"instances": 2,' "$tmp/json" && grep -q '"film": \[256, 256\],' "$tmp/json" || err "json: $(cat "$tmp/json")"
"$bin" scene info cornell:glass=0 --no-tree > "$tmp/info2" || err "scene info cornell"
grep -q 'instancing\|film' "$tmp/info2" && err "a built-in scene got instancing or film lines"

# render / trace: the Film's 40x30, or what -W/-H say
size() { # render MAIN with the options given; prints "W H"
    "$bin" render "$main" -o "$tmp/o.exr" --json "$@" 2>/dev/null |
        sed -n 's/.*"width": \([0-9]*\), "height": \([0-9]*\).*/\1 \2/p'
}
[ "$(size)" = "40 30" ] || err "render without -W/-H: $(size)"
[ "$(size -W 20)" = "20 15" ] || err "render -W 20: $(size -W 20)"
[ "$(size -H 60)" = "80 60" ] || err "render -H 60: $(size -H 60)"
[ "$(size -W 8 -H 8)" = "8 8" ] || err "render -W 8 -H 8: $(size -W 8 -H 8)"
"$bin" trace "$main" -o "$tmp/t.rtt" 2> "$tmp/tlog" || err "trace main.pbrt"
grep -q 'tracer recursive, 40x30,' "$tmp/tlog" || err "trace size: $(cat "$tmp/tlog")"
"$bin" trace-info "$tmp/t.rtt" > "$tmp/tinfo" 2>&1 || err "trace-info"
grep -q '^tracer: *recursive, 40x30, lights none$' "$tmp/tinfo" || err "trace-info: $(cat "$tmp/tinfo")"

# -W and -H on a film of another aspect: the horizontal extent kept, with a warning
"$bin" render "$main" -o "$tmp/o.exr" -W 8 -H 8 2> "$tmp/alog" || err "render -W 8 -H 8"
grep -q "warning: main.pbrt: image 8x8 has not the Film's aspect (40x30): its horizontal extent is kept, vertical field of view 57.82 degrees$" "$tmp/alog" ||
    err "aspect warning: $(cat "$tmp/alog")"
"$bin" render "$main" -o "$tmp/o.exr" -W 25 2> "$tmp/alog2" || err "render -W 25"
grep -q "warning" "$tmp/alog2" && err "-W alone warned: $(cat "$tmp/alog2")"

# the features scene: a gzipped top file, a gzipped PLY in ../assets,
# disk, cylinder, sphere, curve, interface, alpha 0 and an alpha texture
feat="$src/tests/data/pbrt/features/scene/top.pbrt.gz"
"$bin" scene info "$feat" --no-tree > "$tmp/finfo" 2> "$tmp/flog" || err "scene info features: $(cat "$tmp/flog")"
grep -q '^triangles    201$' "$tmp/finfo" || err "features: $(grep triangles "$tmp/finfo") (24 + 48 + 108 + 16 + 4 + 1 = 201)"
for k in 'Shape "curve" (type "flat") made as camera-facing ribbons' 'Material "interface" left out' \
         '"float alpha" 0 left out' 'alpha texture ignored'; do
    grep -qF "$k" "$tmp/flog" || err "features: no warning '$k': $(cat "$tmp/flog")"
done
[ "$(grep -c warning: "$tmp/flog")" = 4 ] || err "features: $(grep -c warning: "$tmp/flog") warnings, expected 4"
for t in recursive packet dynamic treelet; do
    "$bin" render "$feat" -t $t -o "$tmp/f.exr" --ppm "$tmp/f-$t.ppm" 2> /dev/null || err "features: render -t $t"
done
for t in packet dynamic treelet; do
    cmp -s "$tmp/f-recursive.ppm" "$tmp/f-$t.ppm" || err "features: $t image differs from recursive"
done

# sweep: per scene, the Film or the preset
"$bin" sweep --scenes "$main",cornell:glass=0 --tracers recursive --lights primary --sizes 1K \
    --db "$tmp/s.db" 2> "$tmp/slog" || { err "sweep"; cat "$tmp/slog"; }
got=$(sqlite3 "$tmp/s.db" "SELECT s.name, r.W, r.H FROM runs r JOIN scenes s ON s.id = r.scene_id ORDER BY s.name" |
      tr '\n' ' ')
[ "$got" = "cornell|256|256 main.pbrt|40|30 " ] || err "sweep sizes: $got"
"$bin" sweep --scenes "$main" --tracers recursive --lights primary --sizes 1K -W 16 \
    --db "$tmp/s2.db" 2> "$tmp/slog2" || { err "sweep -W 16"; cat "$tmp/slog2"; }
got=$(sqlite3 "$tmp/s2.db" "SELECT W, H FROM runs")
[ "$got" = "16|12" ] || err "sweep -W 16: $got"

# warnings and errors
printf 'Sampler "halton"\nWorldBegin\nShape "trianglemesh" "point3 P" [ 0 0 0 1 0 0 0 1 0 ]\n' > "$tmp/w.pbrt"
"$bin" render "$tmp/w.pbrt" -o "$tmp/w.exr" -W 4 -H 4 2> "$tmp/wlog" || err "render w.pbrt"
grep -q "^raytraffic render: warning: $tmp/w.pbrt:1: Sampler skipped$" "$tmp/wlog" || err "warning: $(cat "$tmp/wlog")"
# every kind on its own line with its count; all of them in --json; --strict refuses
printf 'Sampler "halton"\nWorldBegin\nShape "k1"\nShape "k2"\nShape "k2"\nShape "trianglemesh" "point3 P" [ 0 0 0 1 0 0 0 1 0 ]\n' \
    > "$tmp/w2.pbrt"
"$bin" scene info "$tmp/w2.pbrt" --no-tree > /dev/null 2> "$tmp/w2log" || err "scene info w2.pbrt"
[ "$(grep -c 'warning:' "$tmp/w2log")" = 3 ] || err "three warning lines: $(cat "$tmp/w2log")"
grep -q "^raytraffic scene: warning: $tmp/w2.pbrt:4: Shape \"k2\" skipped (2 times)$" "$tmp/w2log" ||
    err "counted warning: $(cat "$tmp/w2log")"
"$bin" scene info "$tmp/w2.pbrt" --no-tree --json > "$tmp/w2json" 2> "$tmp/w2jlog" || err "scene info --json"
[ -s "$tmp/w2jlog" ] && err "scene info --json printed warnings to stderr: $(cat "$tmp/w2jlog")"
grep -qF '"warnings": [{"kind": "Sampler", "count": 1, "first": "'"$tmp"'/w2.pbrt:1", "message": "Sampler skipped"}, {"kind": "Shape \"k1\"", "count": 1,' "$tmp/w2json" ||
    err "json warnings: $(grep warnings "$tmp/w2json")"
grep -qF '{"kind": "Shape \"k2\"", "count": 2, "first": "'"$tmp"'/w2.pbrt:4", "message": "Shape \"k2\" skipped"}]' "$tmp/w2json" ||
    err "json warnings k2: $(grep warnings "$tmp/w2json")"
"$bin" render "$tmp/w2.pbrt" -o "$tmp/w2.exr" -W 4 -H 4 --json > "$tmp/w2rjson" 2>/dev/null || err "render --json"
grep -qF '"warnings": [{"kind": "Sampler"' "$tmp/w2rjson" || err "render --json warnings: $(cat "$tmp/w2rjson")"
for c in "scene info" render trace; do
    # shellcheck disable=SC2086
    "$bin" $c "$tmp/w2.pbrt" -o "$tmp/w2.out" -W 4 -H 4 --strict > /dev/null 2> "$tmp/slog3"
    rc=$?
    [ "$c" = "scene info" ] && { "$bin" scene info "$tmp/w2.pbrt" --no-tree --strict > /dev/null 2> "$tmp/slog3"; rc=$?; }
    [ $rc = 1 ] || err "$c --strict: exit $rc"
    grep -q "w2.pbrt:1: Sampler skipped (--strict: 3 kinds of warnings are errors)$" "$tmp/slog3" ||
        err "$c --strict: $(cat "$tmp/slog3")"
    [ -e "$tmp/w2.out" ] && err "$c --strict left an output"
done
"$bin" render "$box" -o "$tmp/c.exr" -W 4 -H 4 --strict 2> /dev/null || err "--strict refused a file without warnings"

printf 'WorldBegin\nAttributeEnd\n' > "$tmp/b.pbrt"
"$bin" render "$tmp/b.pbrt" -o "$tmp/b.exr" 2> "$tmp/blog"
[ $? = 1 ] || err "bad file: exit status"
[ "$(cat "$tmp/blog")" = "raytraffic render: $tmp/b.pbrt:2:1: AttributeEnd without a matching AttributeBegin" ] ||
    err "bad file: $(cat "$tmp/blog")"
[ -e "$tmp/b.exr" ] && err "bad file left an image"
exit $fail
