#!/usr/bin/env bash
# The README's main job: installs what is missing, builds the `lightskin` program only (the tests
# are built by scripts/build_and_test.sh), and runs the whole design twice, writing to ${1:-out/}:
#
# 1. recordings/synth-orbit (40 synthetic frames with exact ground truth) with recordings/scenes/orbit_moving.json
#    (orbit.json with the cube sliding and turning on the table):
#    capture -> bilateral depth filter -> AprilTag tracking (the pose source; the scene's tag world
#    and detector settings) -> VALs from depth -> LightSkin GI -> composite. Outputs in out/:
#    frames/, compare/ (with GI | without GI), replay.mp4, report.md / report.json with the tracking
#    states, the pose error against the recording's ground truth (per frame and summary) and whether
#    GI was active in every frame.
# 2. The real Kinect v1 recording tests/data/oni-kinect-v1/3dj_test.oni (unregistered depth, registered
#    to colour in software) with recordings/scenes/oni_room_estimated.json (a bunny and a cube on its floor,
#    --pose fixed: the world is the camera's frame), lit by the room's own light as estimated from each frame
#    (oni_room.json is the same scene with a hand-placed light). Outputs in out/oni-kinect-v1/, the same files.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build_dir="${LIGHTSKIN_BUILD_DIR:-$root/build}"
out_dir="${1:-$root/out}"
"$root/scripts/install_dependencies.sh"
cmake -S "$root" -B "$build_dir" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo
cmake --build "$build_dir" --parallel "$(nproc)" --target lightskin
program="$build_dir/apps/lightskin"
# --overwrite: a re-run replaces the previous run's outputs (the replay clears the folder first, so
# the second replay's folder and doctor.png come after it).
"$program" replay "$root/recordings/synth-orbit" --scene "$root/recordings/scenes/orbit_moving.json" --pose tracking \
  --out "$out_dir" --overwrite --save-room-model "$out_dir/room-model.lsroom"
"$program" replay "$root/tests/data/oni-kinect-v1/3dj_test.oni" --scene "$root/recordings/scenes/oni_room_estimated.json" \
  --pose fixed --out "$out_dir/oni-kinect-v1"
"$program" doctor --out "$out_dir/doctor.png"
echo "main job: outputs in $out_dir (open report.md) and $out_dir/oni-kinect-v1 (real Kinect v1 data)"
