#!/usr/bin/env bash
# The README's test command and CI's (.ci/run). Three stages, each named in its banner and, if it fails,
# in the last line printed:
#   1. the normal build (RelWithDebInfo, build/) and every test (labels unit, gl, data, replay);
#   2. AddressSanitizer + UBSan + LeakSanitizer (scripts/sanitize.sh, build-asan/): the whole suite again;
#   3. ThreadSanitizer (scripts/sanitize.sh --thread, build-tsan/): the tests of the threaded code.
# Fails if a stage ran no test. Extra arguments go to ctest in stages 1 and 2 (e.g. -L unit).
# All three run by default (CI). LIGHTSKIN_SANITIZERS=0 runs stage 1 only (a quick local check; CI never sets it).
# Stage times are printed at the end; the measured totals are in docs/TESTING.md ("Build and CI times").
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build_dir="${LIGHTSKIN_BUILD_DIR:-$root/build}"

stage_names=()
stage_seconds=()
tests_run=0
stage_log="$(mktemp)"
trap 'rm -f "$stage_log"' EXIT
run_stage() {
  local name="$1"
  shift
  echo "==== build_and_test: ${name} ===="
  local start=$SECONDS
  if ! "$@" 2>&1 | tee "$stage_log"; then
    echo "build_and_test: FAILED in stage: ${name}" >&2
    exit 1
  fi
  stage_names+=("$name")
  stage_seconds+=($((SECONDS - start)))
  # ctest's own count ("100% tests passed, 0 tests failed out of N"), for the closing line.
  local count
  count="$(sed -n 's/.*tests passed, 0 tests failed out of \([0-9]*\).*/\1/p' "$stage_log" | tail -n 1)"
  tests_run=$((tests_run + ${count:-0}))
}
normal_suite() {
  "$root/scripts/build.sh"
  ctest --test-dir "$build_dir" --output-on-failure --no-tests=error --parallel "$(nproc)" --timeout 900 "$@"
}

run_stage "1/3 normal build and the whole suite ($build_dir)" normal_suite "$@"
if [[ "${LIGHTSKIN_SANITIZERS:-1}" != 0 ]]; then
  run_stage "2/3 AddressSanitizer+UBSan build and the whole suite (build-asan/)" "$root/scripts/sanitize.sh" "$@"
  run_stage "3/3 ThreadSanitizer build and the threaded code's tests (build-tsan/)" "$root/scripts/sanitize.sh" --thread
fi
echo "==== build_and_test: all stages passed ===="
for i in "${!stage_names[@]}"; do
  printf '  %5d s  %s\n' "${stage_seconds[$i]}" "${stage_names[$i]}"
done
echo "tests: ${tests_run} passed, 0 failed"
