#!/usr/bin/env bash
# The main job: installs what is missing, builds raytraffic, runs the
# default sweep (quick preset) and report on the built-in scenes, and
# renders sphereflake to an EXR.
#   RT_BUILD_DIR  build directory (default: build)
#   RT_OUT        output directory (default: out)
set -euo pipefail
top="$(cd "$(dirname "$0")" && pwd)"
cd "$top"
bdir="${RT_BUILD_DIR:-build}"
out="${RT_OUT:-out}"
"$top/scripts/build.sh" "$bdir"
mkdir -p "$out"
rt="$bdir/raytraffic"
db="$out/raytraffic.db"
# The paper's experiment at the quick preset's resolution (about 2 minutes
# on 2 cores; rerunning skips finished runs) with approximate simulators
# beside the exact one, its tables, the speed-vs-error table and plots.
"$rt" sweep --preset quick --jobs "$(nproc)" --db "$db" \
    --approx hybrid,hybrid:1/64:32K:16384,hybrid:1/64:8K,shards:0.01:16K,shards-fixed:16K,statstack:0.01,statstack:0.001
# Reduced experiments of the primary-ray runs (half resolution, 1 in 4 tiles
# of 8x8 pixels), compared with the full runs by report --speed-error.
"$rt" sweep --preset quick --lights primary --jobs "$(nproc)" --db "$db" --proxy res:128,sub:4
# The other two papers' tracers, small and quick: Purcell et al.'s streaming
# tracers ray-cast the bunny; the knot with a mirror finish and one light,
# Whitted depth 2 (Ralovich & Magdics' Figure 1c), through the recursive,
# dynamic, feedback and multipass tracers for the ray-state comparison.
"$rt" sweep --scenes bunny --tracers stream-branching,stream-multipass --lights primary -W 256 -H 256 \
    --jobs "$(nproc)" --db "$db"
"$rt" sweep --scenes knot --tracers recursive,dynamic,feedback,stream-multipass --modes whitted --depth 2 \
    --lights 0 -W 256 -H 256 --jobs "$(nproc)" --db "$db"
plots="no plots (gnuplot missing)"
plotarg=()
if command -v gnuplot >/dev/null 2>&1; then
    "$rt" report --db "$db" --figure scenes --plot "$out/plots" > /dev/null && plots="$out/plots/"
    plotarg=(--plot "$out/plots")
fi
# The report opens with its summary and findings; the diagnostics (speed
# against error, standard errors, reduced experiments) go to appendix.md.
"$rt" report --db "$db" --appendix "${plotarg[@]}" > "$out/appendix.md"
{ "$rt" report --db "$db" --compare-paper
  echo; "$rt" report --db "$db" --figure purcell --compare-paper "${plotarg[@]}"
  echo; "$rt" report --db "$db" --figure feedback "${plotarg[@]}"
  echo; "$rt" report --db "$db" --figure secondary "${plotarg[@]}"; } > "$out/report.md"
"$rt" render sphereflake -W 1024 -H 1024 --lights all -o "$out/sphereflake.exr" --png "$out/sphereflake.png" 2>/dev/null
cat <<EOT

raytraffic main job done:
  database  $db   (sqlite3 $db 'SELECT * FROM v_paper LIMIT 5')
  report    $out/report.md   (summary and findings, Figures 3-9 and the comparison with the
            paper; Purcell's figures on the bunny; feedback records and secondary rays on the knot)
  appendix  $out/appendix.md (speed against error, standard errors, reduced experiments)
  plots     $plots
  image     $out/sphereflake.exr (preview $out/sphereflake.png)
EOT
