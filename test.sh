#!/usr/bin/env bash
# Installs dependencies, builds, and runs every test; ends with CTest's summary.
set -euo pipefail
cd "$(dirname "$0")"
scripts/setup.sh
scripts/build.sh
scripts/seed_test_costs.sh build
cd build
# Two tests per core: most of them wait on child processes, sockets and timers (a CPU is busy
# about half the time at one per core), and they are written to pass on a loaded machine.
ctest --output-on-failure -j "$(( 2 * $(nproc) ))" --timeout 600
