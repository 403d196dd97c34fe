#!/bin/sh
# Scenes at scale (bench/scale_bench.c, docs/performance.md "Scale"):
# 1. `bench --what scale-quick` writes the torus mesh and the instanced
#    forest at their tiny sizes, renders each in a child process and
#    reports the triangle counts computed by hand below; its folder under
#    --tmpdir is gone afterwards.
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
grep -q '^| forest, 36 instances of 2 trees (--instances bvh) | 78336 instanced, 4352 unique | 64x64 | ' "$tmp/out" ||
    die "forest row: $(grep forest "$tmp/out")"
left=$(ls "$tmp" | grep -c '^rt-scale-')
[ "$left" -eq 0 ] || die "bench left $left folder(s) under --tmpdir"

exit $fail
