#!/usr/bin/env bash
# The 10,000-frame soak: the replay pipeline with GI on over a looping synthetic
# source, RSS, open descriptors and GL objects sampled and asserted flat within 5 % after warm-up
# (tests/mr/SoakGLTest.cpp). The default suite runs the same test for 500 frames; this one is
# registered only with -DLIGHTSKIN_SOAK=ON (ctest label `soak`), so no default run starts it.
#   scripts/soak.sh [FRAMES=10000] [BUILD_DIR=build]
set -euo pipefail
frames="${1:-10000}"
build="${2:-build}"
cd "$(dirname "$0")/.."
cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DLIGHTSKIN_SOAK=ON >/dev/null
cmake --build "$build" --target mr_soak_gl_test
start=$(date +%s)
LIGHTSKIN_SOAK_FRAMES="$frames" ctest --test-dir "$build" -L soak --output-on-failure -V | grep -E "soak:|frame +[0-9]+:|Passed|Failed|tests passed"
echo "soak: $frames frames in $(( $(date +%s) - start )) s"
