#!/usr/bin/env bash
# Seeds CTest's cost data in a build tree that has none, so that a fresh checkout (CI) starts the
# longest tests first: without it CTest runs them in declaration order and the last ones (the fit
# and fold sweeps, minutes under the sanitizers) run alone on an otherwise idle machine at the end.
# Once a tree has run its tests, CTest keeps its own measured costs and this does nothing.
#
#   scripts/seed_test_costs.sh <build dir>
set -euo pipefail
cd "$(dirname "$0")/.."
dir=${1:?build directory}
data="$dir/Testing/Temporary/CTestCostData.txt"
[ -f "$data" ] && exit 0
mkdir -p "$(dirname "$data")"
# CTestCostData.txt: "<test> <previous runs> <cost>" per line; one run, so CTest's own averages
# replace these figures as soon as the tree has run its tests.
grep -v '^#' tests/ctest_costs.txt | awk '{print $1, 1, $2}' >"$data"
