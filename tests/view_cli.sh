#!/bin/sh
# Cameras and lights that users set (--look-at, --fov, --light): the scene's
# own camera and lights given explicitly render the same image; a new view
# changes the image and the run key (trace-info shows it, a sweep stores it
# and --list-jobs repeats it); every tracer honours it (same image); scene
# export writes the camera line; bad values are usage errors.
set -u
bin=${RT_BIN:-./raytraffic}
tmp=$(mktemp -d /tmp/rt_view_cli.XXXXXX) || exit 1
trap 'rm -rf "$tmp"' EXIT
fail=0
err() { echo "FAIL: $*"; fail=1; }
[ -x "$bin" ] || { echo "FAIL: $bin is not an executable"; exit 1; }

# cornell's own view (scene info prints it), given explicitly: same pixels
own="--look-at 0.5,-1.35,0.5,0.5,0.5,0.5,0,0,1 --fov 40 --light 0.5,-0.9,0.55 --light 0.5,0.5,0.95 --light 0.85,0.15,0.8,0.45"
"$bin" scene info cornell --no-tree | grep -q "eye (0.5, -1.35, 0.5) at (0.5, 0.5, 0.5) up (0, 0, 1) fovy 40" \
    || err "cornell's camera is not the one this test assumes"
"$bin" render cornell -W 24 -H 24 --lights all -o "$tmp/a.exr" --png "$tmp/a.png" 2>/dev/null || err "render"
# shellcheck disable=SC2086
"$bin" render cornell -W 24 -H 24 --lights all $own -o "$tmp/b.exr" --png "$tmp/b.png" 2>/dev/null || err "render own view"
cmp -s "$tmp/a.png" "$tmp/b.png" || err "the scene's own camera and lights given explicitly change the image"

# a new view: another image, in every tracer the same
view="--look-at 0.9,-0.5,0.8,0.4,0.5,0.3 --fov 60 --light 0.5,0.5,0.9,1.2"
for t in recursive packet dynamic stream-branching stream-multipass feedback; do
    # shellcheck disable=SC2086
    "$bin" render cornell -W 24 -H 24 --lights all -t $t $view -o "$tmp/v.exr" --png "$tmp/v_$t.png" 2>/dev/null \
        || err "render -t $t with a view"
    [ "$t" = recursive ] || cmp -s "$tmp/v_recursive.png" "$tmp/v_$t.png" || err "$t: image differs from recursive's"
done
cmp -s "$tmp/a.png" "$tmp/v_recursive.png" && err "a new view left the image unchanged"

# the run key: trace-info, a sweep's row, --list-jobs
# shellcheck disable=SC2086
"$bin" trace cornell -W 16 -H 16 --lights all $view -o "$tmp/v.rtt" >/dev/null 2>&1 || err "trace with a view"
"$bin" trace-info "$tmp/v.rtt" | grep -q "lights 0, look_at=0.9,-0.5,0.8,0.4,0.5,0.3 fov=60 light0=0.5,0.5,0.9,1.2" \
    || err "trace-info: $("$bin" trace-info "$tmp/v.rtt" | grep tracer:)"
# shellcheck disable=SC2086
"$bin" sweep --scenes cornell --tracers recursive --lights all -W 16 -H 16 --sizes 64K $view --db "$tmp/s.db" \
    >/dev/null 2>&1 || err "sweep with a view"
"$bin" sweep --scenes cornell --tracers recursive --lights all -W 16 -H 16 --sizes 64K --db "$tmp/s.db" \
    >/dev/null 2>&1 || err "sweep without"
n=$(sqlite3 "$tmp/s.db" "SELECT count(*) FROM runs WHERE params LIKE '%look_at=0.9,-0.5,0.8,0.4,0.5,0.3 fov=60 light0=%'")
[ "$n" = 1 ] || err "sweep: $n runs carry the view in their key, want 1"
n=$(sqlite3 "$tmp/s.db" "SELECT count(*) FROM runs")
[ "$n" = 2 ] || err "sweep: $n runs, want 2 (the default view keeps its own key)"
# shellcheck disable=SC2086
"$bin" sweep --scenes cornell --tracers recursive --lights all -W 16 -H 16 --sizes 64K $view --db "$tmp/j.db" \
    --list-jobs > "$tmp/jobs" 2>/dev/null || err "--list-jobs"
grep -q "'--look-at' '0.9,-0.5,0.8,0.4,0.5,0.3'" "$tmp/jobs" || grep -q -- "--look-at" "$tmp/jobs" \
    || err "--list-jobs drops the view: $(cat "$tmp/jobs")"

# scene export's camera line
# shellcheck disable=SC2086
"$bin" scene export cornell $view -o "$tmp/e.obj" || err "export with a view"
# (full float precision, so the file reads back to the same camera)
grep -q "^# camera eye 0.899999976 -0.5 0.800000012 at 0.400000006 0.5 0.300000012 up 0 0 1 fovy 60" "$tmp/e.obj" \
    || err "export: $(grep camera "$tmp/e.obj")"

# bad values: usage errors naming the option
for bad in "--look-at 1,1,1,1,1,1" "--look-at 1,2,3" "--look-at 0,0,0,1,0,0,1,0,0" "--fov 0" "--fov 180" \
           "--fov nan" "--light 1,2" "--light 1,2,3,-1" "--light 1,2,3,0x10" "--look-at 1e31,0,0,0,0,0"; do
    # shellcheck disable=SC2086
    "$bin" render cornell -W 8 -H 8 $bad -o "$tmp/x.exr" 2>"$tmp/x.err"
    [ $? -eq 2 ] || err "render $bad: want exit 2"
    grep -q -- "${bad%% *}" "$tmp/x.err" || err "render $bad: message '$(cat "$tmp/x.err")'"
done
"$bin" render cornell -W 8 -H 8 --light 1,1,1 --light 1,1,2 --light 1,1,3 --light 1,1,4 -o "$tmp/x.exr" 2>/dev/null
[ $? -eq 2 ] || err "a fourth --light: want exit 2"

# a pbrt file's LookAt/Camera and the same camera given by --look-at/--fov
# (to another file with the same geometry) render the same image
for f in a b; do
    if [ $f = a ]; then cam="LookAt 0.5 -1.35 0.5  0.5 0.5 0.5  0 0 1
Camera \"perspective\" \"float fov\" [ 40 ]"; else cam="LookAt 3 3 3  0 0 0  0 0 1
Camera \"perspective\" \"float fov\" [ 70 ]"; fi
    printf '%s\n%s\n%s\n' "$cam" 'Film "rgb" "integer xresolution" [ 24 ] "integer yresolution" [ 24 ]' 'WorldBegin' \
        > "$tmp/$f.pbrt"
    printf '%s\n' 'Shape "trianglemesh" "point3 P" [ 0 0 0  1 0 0  1 1 0  0 1 0  0 0 1  1 0 1 ]' \
        '  "integer indices" [ 0 1 2  0 2 3  0 1 5  0 5 4 ]' >> "$tmp/$f.pbrt"
done
"$bin" render "$tmp/a.pbrt" -o "$tmp/pa.exr" --png "$tmp/pa.png" 2>/dev/null || err "render a.pbrt"
"$bin" render "$tmp/b.pbrt" --look-at 0.5,-1.35,0.5,0.5,0.5,0.5,0,0,1 --fov 40 -o "$tmp/pb.exr" --png "$tmp/pb.png" \
    2>/dev/null || err "render b.pbrt with a.pbrt's camera"
cmp -s "$tmp/pa.png" "$tmp/pb.png" || err "a pbrt camera and the same camera on the command line give different images"
"$bin" render "$tmp/b.pbrt" -o "$tmp/pc.exr" --png "$tmp/pc.png" 2>/dev/null || err "render b.pbrt"
cmp -s "$tmp/pa.png" "$tmp/pc.png" && err "two different pbrt cameras give the same image"
exit $fail
