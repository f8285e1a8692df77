#!/usr/bin/env bash
# Installs dependencies, builds, and runs every test; ends with CTest's summary.
set -euo pipefail
cd "$(dirname "$0")"
scripts/setup.sh
scripts/build.sh
cd build
ctest --output-on-failure -j "$(nproc)" --timeout 600
