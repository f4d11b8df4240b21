#!/usr/bin/env bash
# The README's main-job command: installs what is missing, builds, and runs lightskin on the
# bundled sample, writing its outputs to ${1:-out/}.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build_dir="${LIGHTSKIN_BUILD_DIR:-$root/build}"
out_dir="${1:-$root/out}"
"$root/scripts/build.sh"
mkdir -p "$out_dir"
"$build_dir/apps/lightskin" doctor --out "$out_dir/doctor.png"
echo "main job: outputs in $out_dir"
