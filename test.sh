#!/usr/bin/env bash
# Installs missing dependencies, builds raytraffic out of tree and runs
# `make check` (the quick tier; `make check-long` in the build directory
# runs the long one).
#   RT_BUILD_DIR  build directory (default: build)
#   RT_SANITIZE=1 configure with --enable-sanitizers (ASan + UBSan)
set -euo pipefail
top="$(cd "$(dirname "$0")" && pwd)"
cd "$top"
bdir="${RT_BUILD_DIR:-build}"
"$top/scripts/build.sh" "$bdir"
cd "$bdir"
if ! make -j"$(nproc)" check; then
    cat tests/*.log 2>/dev/null | tail -n 80
    exit 1
fi
