#!/usr/bin/env bash
# Configures and builds Mimic into build/ (program at build/bin/mimic).
set -euo pipefail
cd "$(dirname "$0")/.."
type=${MIMIC_BUILD_TYPE:-Release}
gen=()
command -v ninja >/dev/null && gen=(-G Ninja)
# ccache, when installed, makes rebuilds from a clean checkout cheap (not a dependency). Its own
# configuration decides the base directory (tests find their data by absolute paths from CMake,
# so relative paths in the compile commands are harmless).
if command -v ccache >/dev/null; then
  gen+=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
fi
if [ ! -f build/CMakeCache.txt ]; then
  cmake -S . -B build "${gen[@]}" -DCMAKE_BUILD_TYPE="$type" "$@"
else
  cmake -S . -B build "$@" >/dev/null
fi
cmake --build build -j "$(nproc)"
