#!/usr/bin/env bash
# Installs dependencies, builds, and runs Mimic on its embedded default.
set -euo pipefail
cd "$(dirname "$0")"
scripts/setup.sh
scripts/build.sh
exec build/bin/mimic run "$@"
