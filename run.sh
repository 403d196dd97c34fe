#!/usr/bin/env bash
# The main job: installs what is missing, builds raytraffic, renders the
# default scene and runs the default sweep and report on the built-in scenes.
#   RT_BUILD_DIR  build directory (default: build)
#   RT_OUT        output directory (default: out)
set -euo pipefail
top="$(cd "$(dirname "$0")" && pwd)"
cd "$top"
"$top/scripts/deps.sh"
[ -x configure ] || autoreconf -fi
bdir="${RT_BUILD_DIR:-build}"
out="${RT_OUT:-out}"
mkdir -p "$bdir" "$out"
( cd "$bdir"
  if [ ! -f Makefile ] || [ "$top/configure" -nt config.status ]; then
      "$top/configure" -q CFLAGS="${CFLAGS:--O2 -g}"
  fi
  make -j"$(nproc)" >/dev/null )
rt="$bdir/raytraffic"
"$rt" render sphereflake -W 1024 -H 1024 --lights all -o "$out/sphereflake.exr" --png "$out/sphereflake.png"
echo "rendered: $out/sphereflake.exr (preview $out/sphereflake.png)"
