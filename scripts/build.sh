#!/usr/bin/env bash
# What run.sh and test.sh share: installs missing dependencies, configures
# raytraffic out of tree (once, and again when configure is newer than the
# build) and builds it.
#   scripts/build.sh [BUILD_DIR]   (relative to the source tree; default build)
#   RT_SANITIZE=1  configure with --enable-sanitizers (ASan + UBSan, and
#                  float-cast-overflow where the compiler has it; with
#                  CC=clang: the clang sanitizer configuration)
#   CFLAGS         default -O2 -g
set -euo pipefail
top="$(cd "$(dirname "$0")/.." && pwd)"
cd "$top"
"$top/scripts/deps.sh"
# configure and Makefile.in together: an interrupted autoreconf can leave
# one without the other.
{ [ -x configure ] && [ -f Makefile.in ]; } || autoreconf -fi
bdir="${1:-build}"
mkdir -p "$bdir"
cd "$bdir"
flags=""
[ "${RT_SANITIZE:-0}" = 1 ] && flags="--enable-sanitizers"
if [ ! -f Makefile ] || [ "$top/configure" -nt config.status ]; then
    # shellcheck disable=SC2086
    "$top/configure" -q $flags CFLAGS="${CFLAGS:--O2 -g}"
fi
make -j"$(nproc)" >/dev/null
