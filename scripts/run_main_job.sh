#!/usr/bin/env bash
# The README's main-job command: installs what is missing, builds, and replays the bundled
# synthetic recording (recordings/synth-orbit, 40 frames) with its scene (a bunny and a cube on a
# tag board, lit by the room through LightSkin), writing to ${1:-out/}: frames/ (composited PNGs),
# compare/ (with GI | without GI), replay.mp4, report.json and report.md.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build_dir="${LIGHTSKIN_BUILD_DIR:-$root/build}"
out_dir="${1:-$root/out}"
"$root/scripts/build.sh"
mkdir -p "$out_dir"
"$build_dir/apps/lightskin" doctor --out "$out_dir/doctor.png"
"$build_dir/apps/lightskin" replay "$root/recordings/synth-orbit" --scene "$root/recordings/scenes/orbit.json" \
  --out "$out_dir"
echo "main job: outputs in $out_dir (open report.md)"
