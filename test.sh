#!/usr/bin/env bash
# Installs missing dependencies, builds raytraffic out of tree and runs
# `make check`.
#   RT_BUILD_DIR  build directory (default: build)
#   RT_SANITIZE=1 configure with --enable-sanitizers (ASan + UBSan)
set -euo pipefail
top="$(cd "$(dirname "$0")" && pwd)"
cd "$top"
"$top/scripts/deps.sh"
[ -x configure ] || autoreconf -fi
bdir="${RT_BUILD_DIR:-build}"
mkdir -p "$bdir"
cd "$bdir"
flags=""
[ "${RT_SANITIZE:-0}" = 1 ] && flags="--enable-sanitizers"
if [ ! -f Makefile ] || [ "$top/configure" -nt config.status ]; then
    "$top/configure" -q $flags CFLAGS="${CFLAGS:--O2 -g}"
fi
make -j"$(nproc)" >/dev/null
if ! make -j"$(nproc)" check; then
    cat tests/*.log 2>/dev/null | tail -n 80
    exit 1
fi
