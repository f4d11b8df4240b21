#!/bin/sh
# Blender Cycles reference for `lightskin bench` (issue 8; documented in docs/BENCHMARKS.md, not in CI).
# Needs Debian's `blender` (apt-get install blender; 3.4.1, CPU only).
# Usage: scripts/blender_reference.sh [BUILD_DIR] [OUT_DIR] [SAMPLES] [extra lightskin bench options...]
# Run from the source folder (the bench finds tests/data/stanford-bunny there).
set -eu
build=${1:-build}
out=${2:-blender-reference}
samples=${3:-256}
shift 3 2>/dev/null || shift $#
"$build/apps/lightskin" -q bench --export-blender "$out" --default-width 320 --default-height 240 --default-stride 4 "$@"
blender -b -noaudio --factory-startup -P "$(dirname "$0")/blender_reference.py" -- "$out" "$samples"
