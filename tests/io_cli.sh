#!/bin/sh
# The commands' outputs under hostile conditions (docs/reliability.md):
# -o naming a directory, a symlink, a device; two writers racing for one
# trace; full disks (/dev/full, a tiny tmpfs when we may mount one, the
# RT_OUT_FAIL_AFTER fault hook); standard output on /dev/full; framing of
# tall images; a signed --cache-size. Every failure must exit non-zero and
# leave no partial file and no temporary behind.
set -u
bin=${RT_BIN:-./raytraffic}
src=${RT_SRCDIR:-.}
tmp=$(mktemp -d /tmp/rt_io_cli.XXXXXX) || exit 1
mnt=
cleanup() { [ -n "$mnt" ] && umount "$mnt" 2>/dev/null; rm -rf "$tmp"; }
trap cleanup EXIT
fail=0
err() { echo "FAIL: $*"; fail=1; }
[ -x "$bin" ] || { echo "FAIL: $bin is not an executable"; exit 1; }
cube=$src/data/meshes/cube.obj
small="-W 16 -H 16"

# Entries in a folder, hidden ones included (temporaries are hidden).
entries() { ls -A "$1" | wc -l | tr -d ' '; }

# --- 1. directories, symlinks, devices ---------------------------------------
mkdir "$tmp/dir"
"$bin" render "$cube" $small -o "$tmp/dir" 2> "$tmp/err"; rc=$?
[ $rc = 1 ] || err "render -o DIR exited $rc"
grep -q "is a directory" "$tmp/err" || err "render -o DIR: message '$(cat "$tmp/err")'"
grep -q "Success" "$tmp/err" && err "render -o DIR reports 'Success'"
[ "$(entries "$tmp/dir")" = 0 ] || err "render -o DIR left $(ls -A "$tmp/dir")"
"$bin" trace "$cube" $small -o "$tmp/dir" 2> "$tmp/err" && err "trace -o DIR succeeded"
"$bin" scene export "$cube" -o "$tmp/dir" 2> "$tmp/err" && err "scene export -o DIR succeeded"
[ "$(entries "$tmp/dir")" = 0 ] || err "-o DIR left $(ls -A "$tmp/dir")"

ln -s /dev/null "$tmp/null.exr"
ln -s /dev/null "$tmp/null.rtt"
ln -s real.obj "$tmp/link.obj"
"$bin" render "$cube" $small -o "$tmp/null.exr" 2>/dev/null || err "render -o link-to-/dev/null failed"
"$bin" trace "$cube" $small -o "$tmp/null.rtt" 2>/dev/null || err "trace -o link-to-/dev/null failed"
"$bin" scene export "$cube" -o "$tmp/link.obj" || err "scene export through a link failed"
for f in null.exr null.rtt link.obj; do
    [ -L "$tmp/$f" ] || err "$f: the symlink was replaced by a file"
done
[ -c /dev/null ] || err "/dev/null is no longer a device"
grep -q "^f " "$tmp/real.obj" 2>/dev/null || err "export through a link did not write its target"

# --- 2. two writers to one trace -----------------------------------------------
i=0
while [ $i -lt 6 ]; do
    "$bin" trace "$cube" -W 24 -H 24 -o "$tmp/same.rtt" 2>/dev/null &
    p1=$!
    "$bin" trace knot:segs=16,sides=4 -W 20 -H 20 -o "$tmp/same.rtt" 2>/dev/null &
    p2=$!
    wait $p1 || err "round $i: writer 1 failed"
    wait $p2 || err "round $i: writer 2 failed"
    "$bin" trace-info "$tmp/same.rtt" > /dev/null 2>&1 || err "round $i: same.rtt does not verify"
    i=$((i + 1))
done
ls -A "$tmp" | grep -q '^\.same\.rtt\.' && err "racing writers left temporaries"

# --- 3. full disks ------------------------------------------------------------------
if [ -c /dev/full ]; then
    ln -s /dev/full "$tmp/full.obj"
    ln -s /dev/full "$tmp/full.png"
    "$bin" scene export "$cube" -o "$tmp/full.obj" 2> "$tmp/err"; rc=$?
    [ $rc = 1 ] || err "scene export to /dev/full exited $rc"
    grep -q "No space left" "$tmp/err" || err "export to /dev/full: message '$(cat "$tmp/err")'"
    "$bin" render "$cube" $small -o "$tmp/ok.exr" --png "$tmp/full.png" 2>/dev/null; rc=$?
    [ $rc = 1 ] || err "render --png to /dev/full exited $rc"
fi
for n in 0 100 500; do
    RT_OUT_FAIL_AFTER=$n "$bin" scene export "$cube" -o "$tmp/h.obj" 2> "$tmp/err"; rc=$?
    [ $rc = 1 ] || err "export failing after $n bytes exited $rc"
    [ -e "$tmp/h.obj" ] && err "export failing after $n bytes left h.obj"
    RT_OUT_FAIL_AFTER=$n "$bin" render "$cube" $small -o "$tmp/h.exr" --png "$tmp/h.png" 2>/dev/null; rc=$?
    [ $rc = 1 ] || err "render failing after $n bytes exited $rc"
    [ -e "$tmp/h.png" ] && err "render failing after $n bytes left h.png"
    RT_OUT_FAIL_AFTER=$n "$bin" trace "$cube" $small -o "$tmp/h.rtt" 2>/dev/null; rc=$?
    [ $rc = 1 ] || err "trace failing after $n bytes exited $rc"
    [ -e "$tmp/h.rtt" ] && err "trace failing after $n bytes left h.rtt"
done
ls -A "$tmp" | grep -q '^\.h\.' && err "failed writes left temporaries: $(ls -A "$tmp" | grep '^\.h\.')"
# A tiny tmpfs, when we may mount one (root); skipped otherwise.
mkdir "$tmp/small"
if [ "$(id -u)" = 0 ] && mount -t tmpfs -o size=64k tmpfs "$tmp/small" 2>/dev/null; then
    mnt=$tmp/small
    "$bin" scene export knot -o "$mnt/knot.obj" 2> "$tmp/err"; rc=$?
    [ $rc = 1 ] || err "export to a full tmpfs exited $rc"
    [ "$(entries "$mnt")" = 0 ] || err "full tmpfs keeps $(ls -A "$mnt")"
    "$bin" render knot -W 128 -H 128 -o "$mnt/k.exr" --png "$mnt/k.png" 2>/dev/null
    [ -e "$mnt/k.png" ] && [ ! -s "$mnt/k.png" ] && err "render left an empty k.png on a full tmpfs"
    umount "$mnt"; mnt=
else
    echo "skip: cannot mount a tmpfs (not root or no permission)"
fi

# --- 4. standard output on /dev/full --------------------------------------------------
if [ -c /dev/full ]; then
    for c in "version" "--help" "scene list" "scene info $cube --no-tree" "trace-info --help" \
             "sweep --scenes cornell --list-jobs" "render $cube $small -o $tmp/j.exr --json"; do
        # shellcheck disable=SC2086
        "$bin" $c > /dev/full 2> "$tmp/err"; rc=$?
        [ $rc = 1 ] || err "'$c > /dev/full' exited $rc"
        grep -q "raytraffic: write error: No space left on device" "$tmp/err" ||
            err "'$c > /dev/full': message '$(cat "$tmp/err")'"
    done
fi

# --- 7. framing of tall images; signed sizes ------------------------------------------
# The cube's whole bounding sphere must be in view: the left and right
# columns of a tall render are background, like its top-left pixel.
"$bin" render "$cube" -W 32 -H 64 -o "$tmp/tall.exr" --ppm "$tmp/tall.ppm" 2>/dev/null || err "tall render failed"
if [ -s "$tmp/tall.ppm" ]; then
    # P6 header "P6\n32 64\n255\n" is 13 bytes; 3 bytes per pixel.
    od -An -v -tu1 -j13 "$tmp/tall.ppm" | tr -s ' \n' '\n\n' | grep -v '^$' |
        awk -v W=32 '{ v[NR-1] = $1 } END {
            bg = v[0] " " v[1] " " v[2]; bad = 0
            for (y = 0; y < NR / (3 * W); y++) for (s = 0; s < 2; s++) {
                x = s ? W - 1 : 0; i = 3 * (y * W + x)
                if (v[i] " " v[i+1] " " v[i+2] != bg) bad++
            }
            exit bad ? 1 : 0 }' || err "tall render crops the mesh at the sides"
fi
"$bin" render "$cube" -W 32 -H 32 -o "$tmp/sq.exr" --ppm "$tmp/sq1.ppm" 2>/dev/null
"$bin" render "$cube" -W 32 -H 32 -o "$tmp/sq.exr" --ppm "$tmp/sq2.ppm" 2>/dev/null
cmp -s "$tmp/sq1.ppm" "$tmp/sq2.ppm" || err "square render not deterministic"
for v in " -64" "-64" "+64K" " 64"; do
    "$bin" trace "$cube" $small -t dynamic --cache-size "$v" -o "$tmp/c.rtt" 2>/dev/null && err "--cache-size '$v' accepted"
done

# --- defects the reliability probes found (docs/reliability.md) -------------
# a PLY header whose counts are too small, or data after the last element
for f in face-count-short trailing-data; do
    out=$("$bin" scene info "$src/tests/probes/$f.ply" 2>&1 >/dev/null); rc=$?
    [ $rc -eq 1 ] || err "$f.ply: exit $rc, expected 1"
    case $out in *"after the last element"*) ;; *) err "$f.ply: message '$out'" ;; esac
done
# subsampling that traces nothing is a usage error, before any work
"$bin" trace cornell --subsample 4:16 -W 8 -H 8 -o "$tmp/s.rtt" > /dev/null 2>&1; rc=$?
[ $rc -eq 2 ] || err "trace --subsample 4:16 -W 8 -H 8: exit $rc, expected 2"
[ ! -e "$tmp/s.rtt" ] || err "refused trace left a file"

exit $fail
