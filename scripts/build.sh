#!/usr/bin/env bash
# Configures and builds lightskin into ${LIGHTSKIN_BUILD_DIR:-build} (Ninja, RelWithDebInfo with
# assertions on). Extra arguments go to CMake's configure step (e.g. -DLIGHTSKIN_SANITIZE=ON).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build_dir="${LIGHTSKIN_BUILD_DIR:-$root/build}"
"$root/scripts/install_dependencies.sh"
cmake -S "$root" -B "$build_dir" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo "$@"
cmake --build "$build_dir" --parallel "$(nproc)"
