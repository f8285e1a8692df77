#!/usr/bin/env bash
# Installs dependencies, builds, and runs Mimic on its embedded default.
set -euo pipefail
cd "$(dirname "$0")"
scripts/setup.sh
scripts/build.sh
echo "run.sh: watch the avatar from another terminal: build/bin/mimic view --connect 127.0.0.1:7777 (needs a display; mimic run prints the address it serves on)" >&2
exec build/bin/mimic run "$@"
