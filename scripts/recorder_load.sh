#!/usr/bin/env bash
# Recorder under load, the long version: 10 minutes of paced 30 fps 640x480 RGB-D
# into the recorder while one thread saturates a core. Usage: scripts/recorder_load.sh [SECONDS=600]
# [BUSY_THREADS=1]. Needs the build (cmake --build build --target lightskin_bench_recorder_load).
# Writes ~1.5 GB per 10 minutes into build/recorder-load/ (removed first). Fails when a frame was lost.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build_dir="${LIGHTSKIN_BUILD_DIR:-$root/build}"
out="$build_dir/recorder-load"
rm -rf "$out"
"$build_dir/capture/lightskin_bench_recorder_load" "$out/rec" "${1:-600}" "${2:-1}"
