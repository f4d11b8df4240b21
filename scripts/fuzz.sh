#!/usr/bin/env bash
# Builds the libFuzzer targets (fuzz/, clang-15 + ASan + UBSan, in build-fuzz/) and runs each for
# SECONDS (default 60). Usage: scripts/fuzz.sh [SECONDS] [TARGET...]   (targets: fuzz/CMakeLists.txt;
# default all). Each target starts from a working copy of its committed corpus (build-fuzz/corpus/
# <target>, seeded from fuzz/corpus/<target>, kept between runs) so that new inputs never land in the
# repository by themselves; findings go to build-fuzz/findings/<target>/ and fail the script.
# Prints one line per target with the executions done (libFuzzer's final stats).
# Installs clang-15, libfuzzer-15-dev and libomp-15-dev (clang's OpenMP, which the gi module's CPU
# backend needs) when missing (not in scripts/debian-packages.txt: the normal build and CI replay the
# corpora with gcc and need none of them).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build_dir="${LIGHTSKIN_FUZZ_BUILD_DIR:-$root/build-fuzz}"
seconds="${1:-60}"
shift || true
all_targets=(recording_header recording_index tum image_header scene_json mesh tag_world detector_settings
  golden_sidecar)
targets=("$@")
[[ ${#targets[@]} -gt 0 ]] || targets=("${all_targets[@]}")

installed() { dpkg-query -W -f='${Status}' "$1" 2>/dev/null | grep -q "ok installed"; }
if ! command -v clang++-15 >/dev/null || ! installed libfuzzer-15-dev || ! installed libomp-15-dev; then
  as_root=()
  [[ $(id -u) -eq 0 ]] || as_root=(sudo)
  "${as_root[@]}" apt-get update -qq
  DEBIAN_FRONTEND=noninteractive "${as_root[@]}" apt-get install -y -qq --no-install-recommends clang-15 libfuzzer-15-dev libomp-15-dev
fi
# Warnings are errors in the gcc build (CI); clang's warning set differs, so not here.
CC=clang-15 CXX=clang++-15 cmake -S "$root" -B "$build_dir" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DLIGHTSKIN_FUZZ=ON -DLIGHTSKIN_BUILD_TESTS=OFF -DLIGHTSKIN_BUILD_BENCHMARKS=OFF \
  -DLIGHTSKIN_WARNINGS_AS_ERRORS=OFF >/dev/null
cmake --build "$build_dir" --parallel "${LIGHTSKIN_FUZZ_JOBS:-2}" --target "${targets[@]/#/lightskin_fuzz_}"

failed=0
export ASAN_OPTIONS="${ASAN_OPTIONS:-detect_leaks=1}"
export LSAN_OPTIONS="${LSAN_OPTIONS:-suppressions=$root/fuzz/lsan.supp:print_suppressions=0}"
export UBSAN_OPTIONS="${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}"
for target in "${targets[@]}"; do
  corpus="$build_dir/corpus/$target"
  findings="$build_dir/findings/$target"
  mkdir -p "$corpus" "$findings"
  cp -n "$root/fuzz/corpus/$target/"* "$corpus/"
  log="$build_dir/fuzz-$target.log"
  # LIGHTSKIN_FUZZ_WORKERS=N > 1: N libFuzzer processes on the one corpus (-jobs/-workers; each
  # logs to fuzz-<job>.log in $build_dir/logs-<target>/ and stops at its first finding); the counts
  # below are summed over them. Default 1: one process, a deliberate choice on a shared machine.
  workers="${LIGHTSKIN_FUZZ_WORKERS:-1}"
  parallel=()
  workdir="$build_dir"
  if [[ $workers -gt 1 ]]; then
    workdir="$build_dir/logs-$target"
    rm -rf "$workdir" && mkdir -p "$workdir"
    parallel=(-jobs="$workers" -workers="$workers")
  fi
  # -max_len 64 KiB (LIGHTSKIN_FUZZ_MAX_LEN): larger than every seed; a smaller one makes slow targets
  # (mesh: assimp) run many more inputs per second. -timeout 10 s per input is a hang; -rss_limit_mb 2048
  # is libFuzzer's default, named here because an input that makes us allocate that much is a finding.
  started=$(date +%s)
  # libFuzzer's slow-unit-* files are no findings: at nice 19 on a busy machine a 40 ms input can take
  # 10 s of wall time (rerun them alone to check).
  countFindings() { find "$findings" -maxdepth 1 -type f ! -name 'slow-unit-*' | wc -l; }
  findingsBefore=$(countFindings)
  (cd "$workdir"
    "$build_dir/fuzz/lightskin_fuzz_$target" "$corpus" "${parallel[@]}" -max_total_time="$seconds" \
      -max_len="${LIGHTSKIN_FUZZ_MAX_LEN:-65536}" -timeout=10 -rss_limit_mb=2048 -print_final_stats=1 \
      -artifact_prefix="$findings/" >"$log" 2>&1) || true
  logs=("$log")
  [[ $workers -gt 1 ]] && logs=("$workdir"/fuzz-*.log)
  # A finding is a new input in findings/ (a crash, leak, timeout or out-of-memory), in either mode.
  runs=$(cat "${logs[@]}" | grep -ao 'stat::number_of_executed_units: *[0-9]*' | grep -o '[0-9]*$' |
    awk '{ s += $1 } END { print (NR ? s : "?") }')
  if [[ $runs == "?" ]]; then
    status="FAILED to run (see ${logs[*]})"
    failed=1
  elif [[ $(countFindings) -eq $findingsBefore ]]; then
    status=ok
  else
    status="FINDING (see ${logs[*]} and $findings/)"
    failed=1
  fi
  echo "$target: $runs executions in $(($(date +%s) - started)) s, corpus $(ls "$corpus" | wc -l) inputs: $status"
done
exit "$failed"
