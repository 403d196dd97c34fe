#!/bin/sh
# `raytraffic render`, `scene info` and `bench` end to end.
#
# render: cornell at 16x16 to EXR, PNG and PPM. Pixels that look straight
# at a diffuse wall are computed here independently (camera ray of the
# pixel, albedo * (ambient + cos * light_power) with lights none, plus
# n.l * light_power for a light that sees the point) and compared with the
# EXR's R, G, B and Z; the PPM is the EXR's colour through gamma 2.2; the
# PNG decodes (perl, zlib) to the PPM's bytes; a background pixel of knot
# is its background colour at infinite depth; the nodes and tests channels
# sum to the --json counters; the packet and dynamic tracers give the
# recursive tracer's image. scene info: triangle counts and bounds of the
# built-ins. bench: its smallest settings print every table and exit 0;
# the render-mode items at 8x8 and 16x16 (path-error's RMSE recomputed from
# render's EXRs, modes' ray counts from render --json, identical's OK lines).
set -u
bin=${RT_BIN:-./raytraffic}
build=${RT_BUILDDIR:-.}
exr="$build/tests/test_core" # --exr-pixel / --exr-sums: the shell reads no EXR
tmp=$(mktemp -d /tmp/rt_render_cli.XXXXXX) || exit 1
trap 'rm -rf "$tmp"' EXIT
fail=0
err() { echo "FAIL: $*"; fail=1; }
[ -x "$bin" ] || { echo "FAIL: $bin is not an executable"; exit 1; }
[ -x "$exr" ] || { echo "FAIL: $exr is not built"; exit 1; }

# near GOT WANT: |GOT - WANT| <= 1e-5 * max(1, |WANT|) ("inf" equals only "inf")
near() {
    awk -v g="$1" -v w="$2" 'BEGIN {
        if (g == "inf" || w == "inf") exit !(g == w)
        d = g - w; if (d < 0) d = -d; a = w < 0 ? -w : w; exit !(d <= 1e-5 * (a > 1 ? a : 1)) }'
}

# wall X Y AXIS PLANE ALB_R ALB_G ALB_B [LIGHT_X LIGHT_Y LIGHT_Z]
# Prints "R G B Z" of cornell's 16x16 pixel (X, Y) that looks at the wall
# AXIS = PLANE (axis 0 = x, 1 = y): the camera at (0.5, -1.35, 0.5) looks
# along +y with +z up and fovy 40, so the ray is (sx h, 1, sy h) with
# h = tan(20 deg), sx = 2 (X + 0.5) / 16 - 1, sy = 1 - 2 (Y + 0.5) / 16.
wall() {
    awk -v X="$1" -v Y="$2" -v axis="$3" -v plane="$4" -v r="$5" -v g="$6" -v b="$7" \
        -v lx="${8:-}" -v ly="${9:-}" -v lz="${10:-}" 'BEGIN {
        pi = atan2(0, -1); h = sin(20 * pi / 180) / cos(20 * pi / 180)
        sx = 2 * (X + 0.5) / 16 - 1; sy = 1 - 2 * (Y + 0.5) / 16
        ex = 0.5; ey = -1.35; ez = 0.5; dx = sx * h; dy = 1; dz = sy * h
        len = sqrt(dx * dx + dy * dy + dz * dz)
        t = axis == 0 ? (plane - ex) / dx : (plane - ey) / dy
        c = (axis == 0 ? dx : dy) / len; if (c < 0) c = -c
        ambient = 0.12; power = 0.45
        if (lx == "") k = ambient + c * power
        else { # one light that sees the point: n.l with n facing the eye
            px = ex + t * dx; py = ey + t * dy; pz = ez + t * dz
            Lx = lx - px; Ly = ly - py; Lz = lz - pz
            ndl = (axis == 0 ? Lx * (dx < 0 ? 1 : -1) : Ly * (dy < 0 ? 1 : -1)) / sqrt(Lx * Lx + Ly * Ly + Lz * Lz)
            k = ambient + (ndl > 0 ? ndl * power : 0)
        }
        printf "%.9g %.9g %.9g %.9g\n", r * k, g * k, b * k, t * len }'
}

# expect_px FILE X Y "R G B Z" what
expect_px() {
    got=$("$exr" --exr-pixel "$1" "$2" "$3") || { err "$5: cannot read pixel ($2, $3) of $1"; return; }
    set -- "$got" "$4" "$5"
    i=1
    for w in $2; do
        g=$(echo "$1" | cut -d' ' -f$i)
        near "$g" "$w" || err "$3: channel $i is $g, want $w (pixel: $1)"
        i=$((i + 1))
    done
}

# --- render cornell:glass=0 16x16, lights none ---------------------------------------
"$bin" render cornell:glass=0 -W 16 -H 16 -o "$tmp/c.exr" --png "$tmp/c.png" --ppm "$tmp/c.ppm" --json \
    > "$tmp/c.json" 2> "$tmp/c.err" || err "render cornell:glass=0 exited $?: $(cat "$tmp/c.err")"
for f in '"width": 16, "height": 16, "lights": 0, "triangles": 36, "rays_primary": 256, "rays_shadow": 0'; do
    grep -q "$f" "$tmp/c.json" || err "render --json lacks $f: $(cat "$tmp/c.json")"
done
# the centre pixel sees the grey back wall (y = 1), pixel (0, 7) the red left wall (x = 0)
expect_px "$tmp/c.exr" 8 8 "$(wall 8 8 1 1 0.73 0.73 0.73)" "cornell back wall"
expect_px "$tmp/c.exr" 0 7 "$(wall 0 7 0 0 0.63 0.065 0.05)" "cornell red wall"
# every pixel's k-d nodes and triangle tests add up to the run's counters
nodes=$(sed -n 's/.*"nodes": \([0-9]*\),.*/\1/p' "$tmp/c.json")
tests=$(sed -n 's/.*"tests": \([0-9]*\),.*/\1/p' "$tmp/c.json")
[ -n "$nodes" ] && [ "$("$exr" --exr-sums "$tmp/c.exr")" = "$nodes $tests" ] \
    || err "EXR nodes/tests sums $("$exr" --exr-sums "$tmp/c.exr") differ from --json $nodes $tests"

# --- PPM = EXR through gamma 2.2; PNG decodes to the PPM's bytes -------------
[ "$(head -c 13 "$tmp/c.ppm" | tr '\n' ' ')" = "P6 16 16 255 " ] || err "PPM header"
[ "$(wc -c < "$tmp/c.ppm")" -eq $((13 + 16 * 16 * 3)) ] || err "PPM size"
for p in "8 8" "0 7" "15 15" "3 12"; do
    set -- $p
    want=$("$exr" --exr-pixel "$tmp/c.exr" "$1" "$2" | awk '{
        for (i = 1; i <= 3; i++) { v = $i; b = v <= 0 ? 0 : v >= 1 ? 255 : int(255 * exp(log(v) / 2.2) + 0.5); printf "%d ", b } }')
    got=$(od -An -tu1 -j $((13 + 3 * ($2 * 16 + $1))) -N 3 "$tmp/c.ppm" | awk '{ printf "%d %d %d ", $1, $2, $3 }')
    [ "$got" = "$want" ] || err "PPM pixel ($1, $2) is $got, want $want"
done
if perl -MCompress::Zlib -e 1 2>/dev/null; then
    perl -MCompress::Zlib -e '
        local $/; open my $f, "<:raw", $ARGV[0] or die "png: $!\n"; my $png = <$f>;
        open my $g, "<:raw", $ARGV[1] or die "ppm: $!\n"; my $ppm = <$g>;
        substr($png, 0, 8) eq "\x89PNG\r\n\x1a\n" or die "png signature\n";
        my ($pos, $idat, $ihdr) = (8, "", undef);
        while ($pos < length $png) {
            my ($n, $type) = unpack("N a4", substr($png, $pos, 8));
            my $data = substr($png, $pos + 8, $n);
            unpack("N", substr($png, $pos + 8 + $n, 4)) == crc32($type . $data) or die "png: $type CRC\n";
            $ihdr = $data if $type eq "IHDR";
            $idat .= $data if $type eq "IDAT";
            $pos += 12 + $n;
        }
        my ($w, $h, $depth, $ctype) = unpack("N N C C", $ihdr);
        "$w $h $depth $ctype" eq "16 16 8 2" or die "png IHDR $w $h $depth $ctype\n";
        my $raw = uncompress($idat); defined $raw or die "png: IDAT does not inflate\n";
        my $rgb = "";
        for my $y (0 .. $h - 1) {
            my $row = substr($raw, $y * (3 * $w + 1), 3 * $w + 1);
            substr($row, 0, 1) eq "\0" or die "png: row $y filter is not 0\n";
            $rgb .= substr($row, 1);
        }
        $rgb eq substr($ppm, 13) or die "png pixels differ from the ppm\n";
    ' "$tmp/c.png" "$tmp/c.ppm" 2> "$tmp/png.err" || err "PNG: $(cat "$tmp/png.err")"
else
    echo "SKIP: PNG decode (perl's Compress::Zlib is missing)"
fi

# --- the other tracers render the same image; one light ----------------------
for t in packet dynamic; do
    "$bin" render cornell:glass=0 -t $t -W 16 -H 16 -o "$tmp/$t.exr" --ppm "$tmp/$t.ppm" 2>/dev/null || err "render -t $t"
    cmp -s "$tmp/c.ppm" "$tmp/$t.ppm" || err "-t $t renders a different image from -t recursive"
done
# light 1, under the ceiling lamp, sees the centre of the back wall
"$bin" render cornell:glass=0 -W 16 -H 16 --lights 1 -o "$tmp/l1.exr" --json > "$tmp/l1.json" 2>/dev/null \
    || err "render --lights 1"
grep -q '"rays_shadow": [1-9]' "$tmp/l1.json" || err "--lights 1 traced no shadow rays: $(cat "$tmp/l1.json")"
expect_px "$tmp/l1.exr" 8 8 "$(wall 8 8 1 1 0.73 0.73 0.73 0.5 0.5 0.95)" "cornell back wall, light 1"

# --- background: knot's corner pixel misses everything -----------------------
"$bin" render knot -W 16 -H 16 -o "$tmp/k.exr" 2>/dev/null || err "render knot"
expect_px "$tmp/k.exr" 0 0 "0.1 0.1 0.12 inf" "knot background"
"$exr" --exr-pixel "$tmp/k.exr" 0 0 | grep -q ' inf 0 0$' || err "a background pixel visits k-d nodes"

# --- usage and failure exits ---------------------------------------------------
"$bin" render cornell:glass=0 > /dev/null 2>&1; [ $? -eq 2 ] || err "render without -o should exit 2"
"$bin" render no-such-scene -o "$tmp/x.exr" > /dev/null 2>&1; [ $? -eq 1 ] || err "render of a bad scene should exit 1"
[ ! -e "$tmp/x.exr" ] || err "a failed render left its EXR"

# --- scene info: counts and bounds of the built-ins -----------------------------
# sphereflake: 7381 spheres (level 4) of 108 triangles and a 2-triangle floor;
# cornell is the unit box
info() { "$bin" scene info "$1" --no-tree 2>&1 || echo "exit $?"; }
check_info() { # SCENE TRIANGLES BOUNDS
    out=$(info "$1")
    echo "$out" | grep -q "^triangles  *$2\$" || err "scene info $1: triangles, want $2: $out"
    echo "$out" | grep -qF "bounds       $3" || err "scene info $1: bounds, want $3: $out"
}
check_info sphereflake $((7381 * 108 + 2)) "(-12, -12, -0.5) - (12, 12, 0.829978)"
check_info grove 163722 "(-50, -50, 0) - (50, 50, 3.11465)"
check_info grove:v=1 168302 "(-50, -50, 0) - (50, 50, 3.06208)"
check_info room 46588 "(-0.06, -0.06, 0) - (15.06, 8.06, 2.6)"
check_info room:v=1 46588 "(-0.06, -0.06, 0) - (15.06, 8.06, 2.6)"
check_info cornell:glass=0 36 "(0, 0, 0) - (1, 1, 1)"
check_info cornell 228 "(0, 0, 0) - (1, 1, 1)"
check_info knot 1024 "(-1.24557, -1.44274, -0.52) - (1.52, 1.44274, 0.52)"
check_info "knot:segs=10,sides=4" 80 ""
"$bin" scene info cornell:glass=0 --json > "$tmp/info.json" || err "scene info --json"
grep -q '"triangles": 36,' "$tmp/info.json" && grep -q '"bounds_lo": \[0, 0, 0\],' "$tmp/info.json" \
    && grep -q '"bounds_hi": \[1, 1, 1\],' "$tmp/info.json" || err "scene info --json: $(cat "$tmp/info.json")"
grep -q '"kd": {"nodes": 75, "leaves": 38, "empty_leaves": 1, "depth": 10, "index_entries": 222,' "$tmp/info.json" \
    || err "scene info --json: cornell's k-d tree"
# the structures' footprints: kd = 8 B x 75 nodes + 4 B x 222 index entries;
# a BVH's bytes are its nodes x 32, 128 or 80; a binary tree of L leaves has
# 2L - 1 nodes (odd); --accel shows one structure, an unknown one exits 2
grep -q '{"name": "kd", "build_sec": [0-9.]*, "nodes": 75, "bytes": 1488, "depth": 10}' "$tmp/info.json" \
    || err "scene info --json: kd footprint: $(cat "$tmp/info.json")"
"$bin" scene info cornell:glass=0 --accel kd,bvh2,bvh4,bvh8 > "$tmp/info.txt" || err "scene info cornell"
awk '$1 == "bvh2" && $3 % 2 == 1 && $4 == 32 * $3 { n++ } $1 == "bvh4" && $4 == 128 * $3 { n++ }
     $1 == "bvh8" && $4 == 80 * $3 && $3 > 1 { n++ } $1 == "kd" && $3 == 75 && $4 == 1488 { n++ }
     END { exit n != 4 }' "$tmp/info.txt" || err "scene info: structure table: $(cat "$tmp/info.txt")"
"$bin" scene info cornell:glass=0 --accel bvh4 > "$tmp/info4.txt" || err "scene info --accel bvh4"
[ "$(grep -c '^  bvh' "$tmp/info4.txt")" = 1 ] && grep -q '^  bvh4 ' "$tmp/info4.txt" && ! grep -q '^kd nodes' "$tmp/info4.txt" \
    || err "scene info --accel bvh4: $(cat "$tmp/info4.txt")"
"$bin" scene info cornell:glass=0 --accel nope > /dev/null 2>&1; [ $? -eq 2 ] || err "scene info --accel nope should exit 2"
# by default only the default structure (kd) is built; all: every member of the table
"$bin" scene info cornell:glass=0 > "$tmp/info0.txt" || err "scene info, default structures"
[ "$(grep -c '^  [a-z0-9]* *[0-9.]* *[0-9]* *[0-9]* *[0-9]*$' "$tmp/info0.txt")" = 1 ] && grep -q '^  kd ' "$tmp/info0.txt" \
    && grep -q '^kd nodes     75$' "$tmp/info0.txt" || err "scene info builds more than kd by default: $(cat "$tmp/info0.txt")"
"$bin" scene info cornell:glass=0 --accel all > "$tmp/infoa.txt" || err "scene info --accel all"
for a in kd grid naive bvh2 bvh4 bvh8; do grep -q "^  $a " "$tmp/infoa.txt" || err "scene info --accel all lacks $a"; done
"$bin" scene info cornell:glass=0 --accel none > "$tmp/infon.txt" || err "scene info --accel none"
grep -q '^structure\|^kd nodes' "$tmp/infon.txt" && err "scene info --accel none built a structure"
"$bin" scene info cornell:glass=0 --accel bvh4,nope > /dev/null 2>&1; [ $? -eq 2 ] || err "scene info --accel bvh4,nope should exit 2"
"$bin" scene list > "$tmp/list" || err "scene list"
for s in sphereflake grove room cornell knot; do grep -q "$s" "$tmp/list" || err "scene list lacks $s"; done
"$bin" scene info no-such-scene > /dev/null 2>&1; [ $? -eq 1 ] || err "scene info of a bad scene should exit 1"

# --- bench, smallest settings -----------------------------------------------------
"$bin" bench --scene cornell:glass=0 -W 8 -H 8 --what tracers,trace,sim,approx --sim-refs 100000 --tmpdir "$tmp" \
    > "$tmp/bench" 2> "$tmp/bench.err" || err "bench exited $?: $(cat "$tmp/bench.err")"
for t in recursive packet dynamic; do
    for m in "untraced" "recording (null sink)" "trace file" "in-process 13-size simulation"; do
        grep -qF "| $t | $m" "$tmp/bench" || err "bench lacks the row $t / $m"
    done
done
grep -q "^k-d tree: 36 triangles, 75 nodes, 38 leaves, depth 10" "$tmp/bench" || err "bench k-d tree line"
grep -q "^cachesim: 100000 synthetic references, 13 sizes" "$tmp/bench" || err "bench cachesim header"
grep -q "^cachesim: one pass, 13 sizes: .* M refs/s" "$tmp/bench" || err "bench one-pass line"
# the synthetic trace is deterministic: the same misses every run
grep -q "^cachesim: (check) tri read misses 1K 21203, 4M 15727" "$tmp/bench" || err "bench synthetic-trace misses"
grep -q "^| exact | | [0-9.]* | 1.0 | 13 | 0 | 0 | 0 | 0 | 0 |" "$tmp/bench" || err "bench approx exact row"
for m in shards shards-fixed statstack hybrid; do grep -q "^| $m | " "$tmp/bench" || err "bench lacks $m rows"; done
ls "$tmp"/rt-bench-* > /dev/null 2>&1 && err "bench left trace files in --tmpdir"
# replay of a trace file: one and two threads, the same counters, ratios to the naive LRU and to one thread
"$bin" trace cornell:glass=0 -W 16 -H 16 --lights all -o "$tmp/rb.rtt" > /dev/null 2>&1 || err "trace for bench replay"
"$bin" bench --what replay --trace "$tmp/rb.rtt" --reps 1 > "$tmp/rbench" 2> "$tmp/rbench.err" ||
    err "bench --what replay exited $?: $(cat "$tmp/rbench.err")"
grep -q "^replay: .*rb.rtt, [0-9]* references, exact 13 sizes" "$tmp/rbench" || err "bench replay header"
grep -q "^replay: --threads 1: .* M refs/s .*x naive LRU  1.00$" "$tmp/rbench" || err "bench replay one-thread row"
grep -q "^replay: --threads 2: .*x --threads 1 (counters agree)$" "$tmp/rbench" || err "bench replay two-thread row"
"$bin" bench --what replay > /dev/null 2> "$tmp/rbench.err"; rc=$?
[ $rc -eq 2 ] && grep -qx "raytraffic bench: --what replay needs --trace FILE" "$tmp/rbench.err" ||
    err "bench --what replay without --trace: exit $rc, $(cat "$tmp/rbench.err")"
"$bin" bench --what replay --trace "$tmp/rb.rtt" --reps 0 > /dev/null 2>&1; [ $? -eq 2 ] || err "bench --reps 0 should be a usage error"
head -c 300 "$tmp/rb.rtt" > "$tmp/rbcut.rtt"
"$bin" bench --what replay --trace "$tmp/rbcut.rtt" > /dev/null 2> "$tmp/rbench.err"; rc=$?
[ $rc -eq 1 ] && grep -q "rbcut.rtt" "$tmp/rbench.err" || err "bench replay of a cut trace: exit $rc, $(cat "$tmp/rbench.err")"
# --what bvh: every width beside the k-d tree, every hit the k-d tree's (differ 0)
"$bin" bench --scene cornell:glass=0 -W 8 -H 8 --what bvh --reps 1 > "$tmp/bbench" 2> "$tmp/bbench.err" ||
    err "bench --what bvh exited $?: $(cat "$tmp/bbench.err")"
for t in "k-d tree" bvh2 bvh4 bvh8; do
    # columns: build s, build CPU s, over k-d, nodes, MB, seconds, CPU s, Mrays/s, nodes/ray, tests/ray, differ
    grep -Eq "^\| $t( \| [0-9.]+){10} \| 0 \| " "$tmp/bbench" ||
        err "bench --what bvh lacks the row $t (or its hits differ)"
done
# provenance header: the machine's CPU model and online CPUs, the revision, today's date
grep -q "^raytraffic [0-9][^ ]* ([^)]*) bench: scene cornell:glass=0, 8x8" "$tmp/bench" || err "bench title line"
cpu=$(sed -n 's/^model name[^:]*: *//p' /proc/cpuinfo 2>/dev/null | head -n 1)
ncpu=$(getconf _NPROCESSORS_ONLN)
grep -qxF "machine: ${cpu:-unknown}, $ncpu online CPUs" "$tmp/bench" || err "bench machine line: $(grep '^machine' "$tmp/bench")"
grep -q "^date: $(date -u +%Y-%m-%d) [0-9:]* UTC$" "$tmp/bench" || err "bench date line: $(grep '^date' "$tmp/bench")"
# ratio column: every tracer row ends with its rays/s over the untraced recursive tracer's, which is 1.00 itself
grep -q "^| tracer | mode | seconds | Mrays/s | refs/ray | time vs untraced | rays/s vs recursive untraced |$" "$tmp/bench" ||
    err "bench tracer table header"
grep -q "^| recursive | untraced | [0-9.]* | [0-9.]* | | 1.00 | 1.00 |$" "$tmp/bench" || err "bench reference row"
[ "$(grep -cE '^\| (recursive|packet|dynamic) \| .* \| [0-9]+\.[0-9]+ \| [0-9]+\.[0-9]{2} \|$' "$tmp/bench")" = 12 ] ||
    err "bench: not every tracer row has both ratio columns"
# simulator rows: against the naive per-size LRU, which agrees on the misses of the same prefix
grep -q "^cachesim: naive per-size LRU: .* M refs/s on the first 100000 refs, 13 sizes (the reference)$" "$tmp/bench" ||
    err "bench naive LRU line"
grep -q "^cachesim: one pass, same refs: .* M refs/s  *[0-9.]*x naive LRU (misses agree)$" "$tmp/bench" ||
    err "bench: naive LRU and simulator disagree, or no ratio: $(grep 'same refs' "$tmp/bench")"
grep -q "^cachesim: one pass, 13 sizes: .* M refs/s  *[0-9.]*x naive LRU$" "$tmp/bench" || err "bench one-pass ratio"
grep -q "^cachesim: 13 sizes one by one: .* M refs/s  *[0-9.]*x naive LRU (" "$tmp/bench" || err "bench one-by-one ratio"
# without the recursive tracer first, its untraced run is measured as the reference
"$bin" bench --scene cornell:glass=0 -W 8 -H 8 --what tracers --tracers packet > "$tmp/bench2" 2>&1 ||
    err "bench --tracers packet exited $?"
[ "$(grep -c '^| ' "$tmp/bench2")" = 4 ] && grep -q "^| recursive | untraced (reference) | [0-9.]* | [0-9.]* | | 1.00 | 1.00 |$" \
    "$tmp/bench2" && grep -q "^| packet | recording (null sink) |" "$tmp/bench2" || err "bench reference run: $(cat "$tmp/bench2")"
"$bin" bench --sim-refs 0 > /dev/null 2>&1; [ $? -eq 2 ] || err "bench --sim-refs 0 should exit 2"
# Embree (optional): either the build says it lacks it, or both rows come out of the same
# run on the same rays, and every primary ray in the closed Cornell box hits
"$bin" bench --what embree --scene cornell:glass=0 -W 8 -H 8 > "$tmp/emb" 2> "$tmp/emb.err" ||
    err "bench --what embree exited $?: $(cat "$tmp/emb.err")"
if ! grep -qx "embree: not built (libembree-dev missing)" "$tmp/emb"; then
    grep -q "^Embree [0-9.]*, rtcIntersect1, one thread, the same 8x8 primary rays in Hilbert order" "$tmp/emb" &&
        grep -q "^| recursive (untraced) | [0-9.]* | [0-9.]* | | 1.00 |$" "$tmp/emb" &&
        grep -q "^| embree rtcIntersect1 | [0-9.]* | [0-9.]* | 64 | [0-9]*\.[0-9][0-9] |$" "$tmp/emb" ||
        err "bench --what embree: $(cat "$tmp/emb")"
fi

# --- bench, the render modes at tiny sizes -------------------------------------------
# path-error: the RMSE of the 8x8 spp-1 and spp-4 images against the spp-16
# reference, computed here from the EXRs of `render`; spp 16 draws the
# reference's own samples, so its error is exactly 0
"$bin" bench --what path-error -W 8 -H 8 --ref-spp 16 --plot "$tmp/plot" > "$tmp/perr" 2> "$tmp/perr.err" \
    || err "bench --what path-error exited $?: $(cat "$tmp/perr.err")"
for s in 1 4 16; do
    "$bin" render cornell --mode path --spp $s --lights all -W 8 -H 8 -o "$tmp/p$s.exr" 2>/dev/null \
        || err "render --mode path --spp $s"
done
pix() { # every pixel's R G B, one line each
    for y in 0 1 2 3 4 5 6 7; do for x in 0 1 2 3 4 5 6 7; do "$exr" --exr-pixel "$1" $x $y | cut -d' ' -f1-3; done; done
}
pix "$tmp/p16.exr" > "$tmp/p16.px"
for s in 1 4; do
    pix "$tmp/p$s.exr" > "$tmp/p$s.px"
    want=$(paste -d' ' "$tmp/p$s.px" "$tmp/p16.px" | awk '{ for (i = 1; i <= 3; i++) { d = $i - $(i + 3); t += d * d } }
        END { printf "%.5f", sqrt(t / (NR * 3)) }')
    got=$(sed -n "s/^| $s | [0-9.]* | \([0-9.]*\) | .*/\1/p" "$tmp/perr")
    near "${got:-x}" "$want" || err "bench path-error: RMSE at spp $s is '$got', want $want"
done
grep -q "^| 1 | [0-9.]* | [0-9.]* | 1.00 | 1.000 | 1.000 |$" "$tmp/perr" || err "bench path-error spp 1 row"
grep -q "^| 4 | [0-9.]* | [0-9.]* | [0-9.]* | [0-9.]* | 0.500 |$" "$tmp/perr" || err "bench path-error spp 4 row"
grep -q "^| 16 | [0-9.]* | 0.00000 | [0-9.]* | 0.000 | 0.250 |$" "$tmp/perr" || err "bench path-error spp 16 row"
grep -q "^| 64 | [0-9.]* | [0-9.]* | [0-9.]* | [0-9.]* | 0.125 |$" "$tmp/perr" || err "bench path-error spp 64 row"
[ "$(grep -cv '^#' "$tmp/plot/path-error-cornell.dat" 2>/dev/null)" = 4 ] || err "bench --plot: path-error-cornell.dat"
if command -v gnuplot > /dev/null 2>&1; then
    [ -s "$tmp/plot/path-error-cornell.png" ] || err "bench --plot wrote no path-error-cornell.png"
fi
# modes: every tracer traces the rays `render --json` counts (primary +
# secondary + shadow), and the ratio line divides the table's figures
"$bin" bench --what modes --scenes cornell -W 16 -H 16 > "$tmp/modes" 2> "$tmp/modes.err" \
    || err "bench --what modes exited $?: $(cat "$tmp/modes.err")"
for m in "shadow" "whitted depth 5" "path spp 4 bounces 4"; do
    case $m in
    shadow) args="--mode shadow" ;;
    whitted*) args="--mode whitted --depth 5" ;;
    *) args="--mode path --spp 4 --bounces 4" ;;
    esac
    want=$("$bin" render cornell $args --lights all -W 16 -H 16 -o "$tmp/m.exr" --json | awk '{
        n = 0; for (i = 1; i <= NF; i++) if ($i ~ /"rays_(primary|shadow)":/ || $i ~ /rays_secondary=/) {
            v = $($i ~ /=/ ? i : i + 1); sub(/.*=/, "", v); gsub(/[^0-9]/, "", v); n += v } print n }')
    for t in recursive packet dynamic; do
        grep -q "^| cornell | $m | $t | $want | [0-9.]* | [0-9.]* | [0-9.]* | [0-9.]* | [0-9.]* | [0-9.]*[1-9][0-9.]* | [0-9.]* |$" \
            "$tmp/modes" || err "bench modes: no row cornell / $m / $t with $want rays"
    done
done
# (the ratio is of the unrounded figures: equal within the rounding of the table's)
awk -F' *[|] *' '$2 == "cornell" && $4 == "recursive" { r[$3] = $7; tr[$3] = $10 }
    function chk(a, b, q) { return q != "" && (q - a / b) ^ 2 <= (0.02 * q + 0.006) ^ 2 }
    /^whitted\/shadow cornell:/ { n = split($0, f, /[ ,=\/]+/)
        # f: whitted shadow cornell: untraced A B Q traced A B Q (...)
        ok = f[5] == r["whitted depth 5"] && f[6] == r["shadow"] && chk(f[5], f[6], f[7]) &&
             f[9] == tr["whitted depth 5"] && f[10] == tr["shadow"] && chk(f[9], f[10], f[11]) }
    END { exit !ok }' "$tmp/modes" || err "bench modes: whitted/shadow ratio line: $(grep '^whitted' "$tmp/modes")"
# identical: the two other tracers give the recursive tracer's image in every mode
"$bin" bench --what identical --scenes cornell,knot -W 16 -H 16 > "$tmp/ident" 2> "$tmp/ident.err" \
    || err "bench --what identical exited $?: $(cat "$tmp/ident.err")"
for s in cornell knot; do for m in raycast shadow whitted path; do for t in packet dynamic; do
    grep -q "^| $s | $m | $t | OK | " "$tmp/ident" || err "bench identical: no OK line for $s / $m / $t"
done; done; done
[ "$(grep -c '| OK |' "$tmp/ident")" = 16 ] && grep -q "^0 cases differ" "$tmp/ident" \
    || err "bench identical: $(grep -c '| OK |' "$tmp/ident") OK lines, want 16 and no DIFF"
"$bin" bench --what path-error --ref-spp 0 > /dev/null 2>&1; [ $? -eq 2 ] || err "bench --ref-spp 0 should exit 2"
"$bin" bench --what nothing > /dev/null 2>&1; [ $? -eq 2 ] || err "bench --what nothing should exit 2"

# tracer traits: an option of another tracer, or a structure the tracer
# cannot run on, is a usage error naming both, before any output
for args in "-t packet --accel naive" "-t recursive --qorder tree" "-t packet --grid-min 32" \
            "-t dynamic --oracle naive" "-t stream-branching --accel kd" "-t recursive --accel nonesuch"; do
    rm -f "$tmp/t.exr"
    # shellcheck disable=SC2086
    "$bin" render knot -W 8 -H 8 $args -o "$tmp/t.exr" 2>"$tmp/t.err"
    [ $? -eq 2 ] || err "render $args: want exit 2"
    [ -e "$tmp/t.exr" ] && err "render $args wrote its output"
    grep -q -- "--" "$tmp/t.err" || err "render $args: message '$(cat "$tmp/t.err")' names no option"
done
"$bin" render knot -W 8 -H 8 -t packet --accel naive -o "$tmp/t.exr" 2>&1 | grep -q "packet tracer runs on kd" \
    || err "--accel naive: the message names the tracer and its structures"
"$bin" render knot -W 8 -H 8 -t feedback --accel naive -o "$tmp/t.exr" 2>/dev/null || err "feedback --accel naive: want exit 0"
# a job builds only the structure its tracer runs on
"$bin" render knot -W 8 -H 8 -t stream-branching --json -o "$tmp/t.exr" > "$tmp/t.json" 2>/dev/null || err "stream-branching render"
grep -q '"grid_build_seconds"' "$tmp/t.json" && ! grep -q '"kd_build_seconds"' "$tmp/t.json" \
    || err "stream-branching --json: $(cat "$tmp/t.json")"
"$bin" render knot -W 8 -H 8 --json -o "$tmp/t.exr" 2>/dev/null | grep -q '"kd_build_seconds"' || err "recursive --json: no k-d build"
# an unwritable output fails before any output is written
rm -f "$tmp/t.exr" "$tmp/t.png"
"$bin" render knot -W 8 -H 8 -o "$tmp/t.exr" --png "$tmp/t.png" --heatmap "$tmp/nonesuch/h.png" 2>/dev/null
[ $? -eq 1 ] || err "--heatmap into a missing folder: want exit 1"
[ -e "$tmp/t.exr" ] || [ -e "$tmp/t.png" ] && err "--heatmap into a missing folder: the EXR or PNG was written first"
# an S_VB overflow is a usage error in render, trace and sweep alike
for c in render trace; do
    "$bin" $c knot -t feedback -W 64 -H 64 --lights all --mode whitted --vb-size 49151 -o "$tmp/vb.$c" 2>/dev/null
    [ $? -eq 2 ] || err "$c S_VB overflow: want exit 2"
done
"$bin" sweep --scenes knot --tracers feedback --lights all --modes whitted -W 64 -H 64 --vb-size 49151 \
    --sizes 64K --db "$tmp/vb.db" 2>/dev/null
[ $? -eq 2 ] || err "sweep S_VB overflow: want exit 2"
exit $fail
