#!/usr/bin/env bash
# CPU time of the differential stage per frame, by part, from perf samples of a replay (docs/BENCHMARKS.md,
# "Differential rendering"). perf counts CPU time, not wall clock, so other load on the machine inflates
# it far less than the report's stage times; compare two binaries by running this for both, one after the
# other. Usage: scripts/differential_cost.sh LIGHTSKIN_BINARY orbit|oni [FRAMES] [OUT_DIR]
#   orbit: recordings/synth-orbit, recordings/scenes/orbit.json, ground-truth poses (default 20 frames)
#   oni:   tests/data/oni-kinect-v1/3dj_test.oni, recordings/scenes/oni_room.json, fixed pose (all 12 frames)
# Needs perf (Debian: linux-perf) and python3. Parts (symbols): embree (libembree3, TriangleRayScene: the
# shadow rays), simd (the SIMD gather kernel GatherGroup; gatherDiscs in older binaries), receivers
# (computeReceiver / placeReceiver / gatherReceiver and the file's helpers they call: geometry, region,
# pair tests, the lights, the adaptive cells), really (reallyOccluded: the depth-frame shadow test), pixels
# (the interpolation and each pixel's light shadow), composite (applyDifferentialInto), other (the rest of
# DifferentialIrradiance).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
binary="${1:?usage: $0 LIGHTSKIN_BINARY orbit|oni [FRAMES] [OUT_DIR]}"
dataset="${2:?usage: $0 LIGHTSKIN_BINARY orbit|oni [FRAMES] [OUT_DIR]}"
command -v perf > /dev/null || { echo "differential_cost.sh: perf not found (apt-get install linux-perf)" >&2; exit 2; }
[[ -x "$binary" ]] || { echo "differential_cost.sh: $binary: not an executable" >&2; exit 2; }
case "$dataset" in
orbit) frames="${3:-20}"; args=("$root/recordings/synth-orbit" --scene "$root/recordings/scenes/orbit.json" --pose ground-truth) ;;
oni) frames="${3:-12}"; args=("$root/tests/data/oni-kinect-v1/3dj_test.oni" --scene "$root/recordings/scenes/oni_room.json" --pose fixed) ;;
*) echo "differential_cost.sh: dataset '$dataset': expected orbit or oni" >&2; exit 2 ;;
esac
out="${4:-$(mktemp -d)}"
mkdir -p "$out"
frequency=4999
perf record -q -o "$out/perf.data" -F "$frequency" "$binary" replay "${args[@]}" --out "$out/replay" --overwrite \
  --no-video --write-frames 0 --sequential --max-frames "$frames" > "$out/replay.log" 2>&1 ||
  { echo "differential_cost.sh: the replay failed (log: $out/replay.log)" >&2; exit 1; }
perf report -i "$out/perf.data" --no-children --sort dso,symbol -F overhead,sample,dso,symbol --percent-limit 0 \
  2> /dev/null | grep -v '^#' | grep -v '^$' > "$out/symbols.txt"
python3 - "$out/symbols.txt" "$frames" "$frequency" "$dataset" "$binary" << 'PY'
import sys
path, frames, frequency, dataset, binary = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), sys.argv[4], sys.argv[5]
parts = {"embree": 0, "simd": 0, "receivers": 0, "really": 0, "pixels": 0, "composite": 0, "other": 0}
total = 0
for line in open(path):
    fields = line.split()
    if len(fields) < 4 or not fields[1].isdigit():
        continue
    samples = int(fields[1])
    total += samples
    if "libembree" in line or "TriangleRayScene" in line:
        parts["embree"] += samples
    elif "GatherGroup" in line or "gatherDiscs" in line:
        parts["simd"] += samples
    elif "reallyOccluded" in line:
        parts["really"] += samples
    elif "Differential" in line and ("interpolate" in line or "lightsAtPixel" in line):
        parts["pixels"] += samples
    elif "applyDifferentialInto" in line:
        parts["composite"] += samples
    elif any(name in line for name in ("computeReceiver", "placeReceiver", "gatherReceiver", "testBlock",
                                       "discWeight", "discNearSphere", "segmentDistance2", "segmentNearSphere",
                                       "lightIrradiance", "sortVals", "spreadBits10", "validDisc", "lightReceiver",
                                       "interpolable", "fillCells", "negligibleAt", "dropHiddenReceivers")):
        parts["receivers"] += samples
    elif "Differential" in line:
        parts["other"] += samples
ms = {k: v / frequency * 1000.0 / frames for k, v in parts.items()}
print(f"{dataset} {binary}: differential {sum(ms.values()):.1f} CPU-ms/frame = "
      + " + ".join(f"{k} {v:.1f}" for k, v in ms.items())
      + f"; whole replay {total / frequency * 1000.0 / frames:.0f} CPU-ms/frame ({frames} frames)")
PY
