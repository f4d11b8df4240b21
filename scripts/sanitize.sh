#!/usr/bin/env bash
# Sanitizer builds; scripts/build_and_test.sh (CI) runs both after the normal suite. Wall times in
# docs/TESTING.md ("Build and CI times").
#
#   scripts/sanitize.sh [ctest arguments]           AddressSanitizer + UBSan (+ LeakSanitizer) in build-asan/,
#                                                   then the whole suite, or what the arguments select (-L unit)
#   scripts/sanitize.sh --thread [ctest arguments]  ThreadSanitizer in build-tsan/: builds only the tests of the
#                                                   threaded code (tests/capture: Recorder's writer thread, the
#                                                   OpenNI2 and libfreenect sources; gi_ground_truth_test: the
#                                                   Embree reference's worker threads; the CPU GI backend's
#                                                   oneTBB loops; tests/sanitizer's deliberate race, which
#                                                   the suppressions must not hide) and runs them
#
# Both are Debug builds (-O0: every access instrumented, nothing inlined away) with line tables only (-g1):
# reports keep function names and file:line, while full debug info would make these builds (the longest
# part of CI) slower to compile and link.
#
# Every sanitizer finding fails its test (UBSan does not recover). LeakSanitizer suppressions for third-party
# code are in cmake/sanitizers/lsan.supp, each with its reason; the tests sanitizer_leak_check* prove they hide
# no leak of ours, and sanitizer_race_check that cmake/sanitizers/tsan.supp hides no race of ours. The environment
# is set by CTest: run a single test binary of these builds through `ctest --test-dir build-asan -R <binary>`
# (in the ASan build a test binary is one CTest test, named after it: tests/CMakeLists.txt), or copy
# LSAN_OPTIONS from `ctest -R <name> -V`.
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
debug_flags=(-DCMAKE_BUILD_TYPE=Debug -DCMAKE_C_FLAGS_DEBUG=-g1 -DCMAKE_CXX_FLAGS_DEBUG=-g1 -DLIGHTSKIN_BUILD_BENCHMARKS=OFF)
if [[ "$mode" == address ]]; then
  build="$root/build-asan"
  cmake -S "$root" -B "$build" -G Ninja "${debug_flags[@]}" -DLIGHTSKIN_SANITIZE=ON
  cmake --build "$build" --parallel "$jobs"
  # No rerun of failed tests: the LeakSanitizer tracer crash that needed one (GCC 12's libasan guessing a
  # dynamic TLS block's range) is kept from GL programs at its cause (cmake/LightskinAsanDriverTls.cmake).
  ctest --test-dir "$build" --output-on-failure --no-tests=error --parallel "$jobs" --timeout 900 "$@"
else
  build="$root/build-tsan"
  # Also for the build: gtest discovery runs the test binaries, and libOpenNI2 trips TSan while it loads.
  export TSAN_OPTIONS="suppressions=$root/cmake/sanitizers/tsan.supp:halt_on_error=1:second_deadlock_stack=1:history_size=7"
  cmake -S "$root" -B "$build" -G Ninja "${debug_flags[@]}" -DLIGHTSKIN_SANITIZE_THREAD=ON
  # The threaded code's test binaries: every capture test (the recorder tests also build the `lightskin`
  # program they run), the Embree reference's worker threads, read from the CMake and test files so that
  # new capture tests are included, and the CPU GI backend's oneTBB loops (gi::CpuLightSkin, its
  # thread-count and extremes tests; gi::CpuValGenerator). Debian's libtbb is not instrumented: the fork
  # and join of those loops are declared to TSan (gi/common/src/TsanParallelRegion.h) and the reports on oneTBB's
  # own objects suppressed by their top frame (cmake/sanitizers/tsan.supp). Not the backend's
  # CpuLightSkinSetupGLTest: its double references take minutes at -O0 under TSan and add no thread count
  # the thread-count test does not run, and its GL-path comparisons exercise only Mesa's threads.
  mapfile -t targets < <(grep -ho 'lightskin_add_test(capture_[a-z_]*' "$root/tests/capture/CMakeLists.txt" | sed 's/.*(//')
  # mr::Session's prefetch and GI-ahead workers: their sessions' tests only, not the whole suite (with moving
  # content too: the GI ahead places animated objects on the caller's thread while the worker computes).
  targets+=(gi_ground_truth_test gi_cpu_lightskin_gl_test gi_cpu_val_generator_gl_test mr_session_gl_test
            mr_moving_content_gl_test)
  # The deliberate race that the suppressions must not hide (tests/sanitizer).
  targets+=(sanitizer_race_check_program)
  cmake --build "$build" --parallel "$jobs" --target "${targets[@]}"
  suites="$(grep -ho '^TEST\(_F\|_P\)\?([A-Za-z0-9_]*' "$root"/tests/capture/*.cpp \
    "$root/tests/gi/reference/RayTracedGroundTruthTest.cpp" "$root/tests/gi/common/CpuValGeneratorGLTest.cpp" \
    | sed 's/.*(//' | sort -u | paste -sd'|')|CpuLightSkinGLTest|CpuLightSkinExtremeGLTest"
  ctest --test-dir "$build" --output-on-failure --no-tests=error --parallel "$jobs" --timeout 900 \
    -R "(^|/)(($suites)\.|(SessionGLTest|MovingContentGLTest)\.(Prefetch|GiAhead))|^sanitizer_race_check" "$@"
fi
