#!/usr/bin/env bash
# Sanitizer builds (not run by CI: too slow for its budget; results and wall times in docs/TESTING.md).
#
#   scripts/sanitize.sh [ctest arguments]           AddressSanitizer + UBSan (+ LeakSanitizer) in build-asan/,
#                                                   then the whole suite, or what the arguments select (-L unit)
#   scripts/sanitize.sh --thread [ctest arguments]  ThreadSanitizer in build-tsan/: builds only the capture tests
#                                                   (the threaded part: Recorder's writer thread, the OpenNI2 and
#                                                   libfreenect sources) and runs them
#
# Every sanitizer finding fails its test (UBSan does not recover). LeakSanitizer suppressions for third-party
# code are in cmake/sanitizers/lsan.supp, each with its reason; the tests sanitizer_leak_check* prove they hide
# no leak of ours. The environment is set by CTest: run a single test binary of these builds through
# `ctest --test-dir build-asan -R <name>` (or copy LSAN_OPTIONS from `ctest -R <name> -V`).
# LIGHTSKIN_JOBS (default: nproc) sets the parallel compile and test jobs.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
jobs="${LIGHTSKIN_JOBS:-$(nproc)}"
mode=address
if [[ "${1:-}" == "--thread" ]]; then
  mode=thread
  shift
fi
"$root/scripts/install_dependencies.sh"
if [[ "$mode" == address ]]; then
  build="$root/build-asan"
  cmake -S "$root" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Debug -DLIGHTSKIN_SANITIZE=ON \
    -DLIGHTSKIN_BUILD_BENCHMARKS=OFF
  cmake --build "$build" --parallel "$jobs"
  ctest --test-dir "$build" --output-on-failure --no-tests=error --parallel "$jobs" "$@"
else
  build="$root/build-tsan"
  # Also for the build: gtest discovery runs the test binaries, and libOpenNI2 trips TSan while it loads.
  export TSAN_OPTIONS="suppressions=$root/cmake/sanitizers/tsan.supp:halt_on_error=1:second_deadlock_stack=1"
  cmake -S "$root" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Debug -DLIGHTSKIN_SANITIZE_THREAD=ON \
    -DLIGHTSKIN_BUILD_BENCHMARKS=OFF
  # The capture test binaries (tests/capture; the recorder test also builds the `lightskin` program it runs).
  cmake --build "$build" --parallel "$jobs" --target capture_bad_input_test capture_data_test \
    capture_depth_filter_test capture_fakenect_test capture_oni_test capture_recorder_test capture_recording_test \
    capture_tum_test
  suites='^(BadInputTest|DepthFilterTest|FakenectTest|OniSourceTest|RecordedDataTest|RecorderTest|RecordingTest|TumSourceTest)\.'
  ctest --test-dir "$build" --output-on-failure --no-tests=error --parallel "$jobs" -R "$suites" "$@"
fi
