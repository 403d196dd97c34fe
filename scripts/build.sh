#!/usr/bin/env bash
# What run.sh and test.sh share: installs missing dependencies, configures
# raytraffic out of tree (once, and again when configure is newer than the
# build) and builds it.
#   scripts/build.sh BUILD_DIR   (relative to the source tree)
#   RT_SANITIZE=1  configure with --enable-sanitizers (ASan + UBSan)
#   CFLAGS         default -O2 -g
set -euo pipefail
top="$(cd "$(dirname "$0")/.." && pwd)"
cd "$top"
"$top/scripts/deps.sh"
[ -x configure ] || autoreconf -fi
bdir="${1:?usage: scripts/build.sh BUILD_DIR}"
mkdir -p "$bdir"
cd "$bdir"
flags=""
[ "${RT_SANITIZE:-0}" = 1 ] && flags="--enable-sanitizers"
if [ ! -f Makefile ] || [ "$top/configure" -nt config.status ]; then
    # shellcheck disable=SC2086
    "$top/configure" -q $flags CFLAGS="${CFLAGS:--O2 -g}"
fi
make -j"$(nproc)" >/dev/null
