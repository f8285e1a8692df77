#!/usr/bin/env bash
# The test suite under AddressSanitizer + UndefinedBehaviorSanitizer, then every libFuzzer target
# for a bounded time. One Clang build (build-asan/) serves both: with MIMIC_FUZZ=ON every library
# and test is compiled with -fsanitize=fuzzer-no-link,address,undefined, so the same objects run
# the tests and feed the fuzzers with coverage from inside the libraries. Benchmarks are off.
#
#   scripts/sanitize_and_fuzz.sh            # build, ctest, fuzz each target for 20 s
#   MIMIC_FUZZ_SECONDS=60 scripts/sanitize_and_fuzz.sh
#   MIMIC_FUZZ_SEED=N                      # libFuzzer's seed (default 1)
#   MIMIC_SKIP_TESTS=1 / MIMIC_SKIP_FUZZ=1  # one half only
#
# Fuzzing works on a copy of fuzz/corpus (the committed seeds stay small); a crash leaves its
# input in build-asan/fuzz-artifacts/ and fails the script.
set -euo pipefail
cd "$(dirname "$0")/.."
dir=${MIMIC_ASAN_DIR:-build-asan}
seconds=${MIMIC_FUZZ_SECONDS:-20}
# One seed, printed with the results: a finding reproduces with the same seed and corpus.
seed=${MIMIC_FUZZ_SEED:-1}
jobs=$(nproc)

launcher=()
if command -v ccache >/dev/null; then
  launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
fi
gen=()
command -v ninja >/dev/null && gen=(-G Ninja)
if [ ! -f "$dir/CMakeCache.txt" ]; then
  # -O1, as the sanitizers' authors advise: a quarter less build time than -O3 for the same
  # findings, and the suite (mostly waiting on processes and sockets) runs as fast.
  cmake -S . -B "$dir" "${gen[@]}" "${launcher[@]}" -DCMAKE_BUILD_TYPE=Release "-DCMAKE_CXX_FLAGS_RELEASE=-O1 -DNDEBUG" \
    -DCMAKE_CXX_COMPILER=clang++ -DMIMIC_FUZZ=ON -DMIMIC_SANITIZE=ON -DMIMIC_BUILD_BENCH=OFF
fi
start=$(date +%s)
cmake --build "$dir" -j "$jobs"
echo "sanitize_and_fuzz: build $(( $(date +%s) - start )) s"

if [ -z "${MIMIC_SKIP_TESTS:-}" ]; then
  start=$(date +%s)
  scripts/seed_test_costs.sh "$dir"
  # The statistical sweeps run in the Release suite only (tests/sanitizer_skip.txt says why).
  skip=$(grep -v '^#' tests/sanitizer_skip.txt | awk 'NF{printf "%s^%s$", sep, $1; sep="|"}')
  echo "sanitize_and_fuzz: left to the Release suite: $(grep -v '^#' tests/sanitizer_skip.txt | awk 'NF{printf "%s%s", sep, $1; sep=", "}')"
  # halt_on_error: the first report fails the test; leaks are reported too.
  ( cd "$dir" && ASAN_OPTIONS=detect_leaks=1:halt_on_error=1:abort_on_error=1 \
      UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
      ctest --output-on-failure -j "$(( 2 * jobs ))" --timeout 900 -E "$skip" )  # two per core, as test.sh
  echo "sanitize_and_fuzz: tests under ASan+UBSan $(( $(date +%s) - start )) s"
fi

if [ -z "${MIMIC_SKIP_FUZZ:-}" ]; then
  start=$(date +%s)
  work="$dir/fuzz-work"
  artifacts="$dir/fuzz-artifacts"
  rm -rf "$work"
  mkdir -p "$work" "$artifacts"
  # One target per core at a time; each reports its executions and coverage.
  fuzz_one() {
    local bin=$1 name
    name=$(basename "$bin" _fuzz)
    mkdir -p "$work/$name"
    [ -d "fuzz/corpus/$name" ] && cp -r "fuzz/corpus/$name/." "$work/$name/"
    local log="$work/$name.log"
    if ! ASAN_OPTIONS=detect_leaks=1 "$bin" "$work/$name" -seed="$seed" -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 \
        -artifact_prefix="$artifacts/${name}-" -print_final_stats=1 >"$log" 2>&1; then
      echo "sanitize_and_fuzz: $name FAILED (see $log and $artifacts)"
      tail -40 "$log"
      return 1
    fi
    local execs cov
    execs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$log" | grep -o '[0-9]*$' || echo '?')
    cov=$(grep -o 'cov: [0-9]*' "$log" | tail -1 | grep -o '[0-9]*' || echo '?')
    echo "sanitize_and_fuzz: $name ok: $execs runs, coverage $cov, corpus $(ls "$work/$name" | wc -l) inputs"
  }
  failed=0
  running=0
  for bin in "$dir"/bin/*_fuzz; do
    fuzz_one "$bin" &
    running=$((running + 1))
    if [ "$running" -ge "$jobs" ]; then
      wait -n || failed=1
      running=$((running - 1))
    fi
  done
  while [ "$running" -gt 0 ]; do
    wait -n || failed=1
    running=$((running - 1))
  done
  echo "sanitize_and_fuzz: fuzzing $(( $(date +%s) - start )) s (seed $seed)"
  [ "$failed" -eq 0 ]
fi
