#!/bin/sh
# Blender Cycles reference for `lightskin bench` (documented in docs/BENCHMARKS.md).
# An offline reference tool, not a build or CI dependency (so not in scripts/debian-packages.txt):
# needs Debian's `blender` (3.4.1, CPU only, no OSL) and, for the glossy model bound, python3-numpy:
#   apt-get install -y blender python3-numpy
# Usage: scripts/blender_reference.sh [BUILD_DIR] [OUT_DIR] [SAMPLES] [extra lightskin bench options...]
# SAMPLES per seed; Cycles renders seeds 0 and 1 (their difference states its noise).
# Run from the source folder (the bench finds tests/data/stanford-bunny there).
set -eu
build=${1:-build}
out=${2:-blender-reference}
samples=${3:-256}
shift 3 2>/dev/null || shift $#
"$build/apps/lightskin" -q bench --export-blender "$out" --default-width 320 --default-height 240 --default-stride 4 "$@"
blender -b -noaudio --factory-startup -P "$(dirname "$0")/blender_reference.py" -- "$out" "$samples"
