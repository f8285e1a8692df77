#!/usr/bin/env bash
# Installs dependencies, builds, and runs Mimic on its embedded default.
set -euo pipefail
cd "$(dirname "$0")"
scripts/setup.sh
scripts/build.sh
# mimic run says where it serves and how to watch it.
exec build/bin/mimic run "$@"
