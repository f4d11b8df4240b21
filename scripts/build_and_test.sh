#!/usr/bin/env bash
# The README's test command: installs what is missing, builds, runs every test (labels unit, gl,
# data, replay). Fails if no test ran. Extra arguments are passed to ctest (e.g. -L unit).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build_dir="${LIGHTSKIN_BUILD_DIR:-$root/build}"
"$root/scripts/build.sh"
cd "$build_dir"
ctest --output-on-failure --no-tests=error --parallel "$(nproc)" --timeout 900 "$@"
