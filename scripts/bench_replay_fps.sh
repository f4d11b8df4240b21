#!/usr/bin/env bash
# Frames per second and CPU ms per frame of whole replays (issue 18): the .oni (640x480, fixed pose) and
# synth-orbit (320x240, AprilTag tracking), GL and CPU backends, side by side in one run, alternated per round.
# Per frame without the setup: (all frames - 1 frame) / (N - 1), for wall clock and for the process's CPU time
# (user + system, every thread: llvmpipe's, oneTBB's and the prefetch worker's). Outputs: no video, no
# comparison, one PNG (--write-frames 0): the pipeline, not the PNG encoder. Differential off (its Embree
# gather dominates otherwise; docs/BENCHMARKS.md).
#
#   scripts/bench_replay_fps.sh ROUNDS VARIANT=BINARY[:EXTRA_ARGS] ...
#   e.g. scripts/bench_replay_fps.sh 3 before=/tmp/lightskin-main:--sequential after=build/apps/lightskin
# Prints one line per variant, recording and backend: medians over the rounds.
set -euo pipefail
rounds=${1:?rounds}
shift
repo=$(cd "$(dirname "$0")/.." && pwd)
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
declare -A recs=(
  [oni]="$repo/tests/data/oni-kinect-v1/3dj_test.oni --scene $repo/recordings/scenes/oni_room.json --pose fixed"
  [orbit]="$repo/recordings/synth-orbit --scene $repo/recordings/scenes/orbit.json --pose tracking"
)
declare -A frames=([oni]=12 [orbit]=40)
# one timed run: prints "wall_seconds cpu_seconds"
run() {
  local binary=$1 extra=$2 rec=$3 backend=$4 n=$5 out="$work/out"
  rm -rf "$out"
  # shellcheck disable=SC2086
  /usr/bin/time -f "%e %U %S" -o "$work/time" "$binary" -q replay ${recs[$rec]} --out "$out" --no-video --no-compare \
    --write-frames 0 --differential off --backend "$backend" --max-frames "$n" $extra >/dev/null 2>&1
  awk '{print $1, $2 + $3}' "$work/time"
}
for ((r = 0; r < rounds; ++r)); do
  for rec in oni orbit; do
    for backend in gl cpu; do
      for variant in "$@"; do
        name=${variant%%=*}
        spec=${variant#*=}
        binary=${spec%%:*}
        extra=""
        [[ $spec == *:* ]] && extra=${spec#*:}
        n=${frames[$rec]}
        read -r wallN cpuN < <(run "$binary" "$extra" "$rec" "$backend" "$n")
        read -r wall1 cpu1 < <(run "$binary" "$extra" "$rec" "$backend" 1)
        awk -v id="$name $rec $backend" -v n="$n" -v wN="$wallN" -v w1="$wall1" -v cN="$cpuN" -v c1="$cpu1" \
          'BEGIN { print id, (wN - w1) * 1000 / (n - 1), (cN - c1) * 1000 / (n - 1) }' >>"$work/samples"
      done
    done
  done
done
echo "variant recording backend wall_ms_per_frame fps cpu_ms_per_frame fps_bound_2_cores (medians of $rounds; load $(cut -d' ' -f1-3 /proc/loadavg))"
python3 - "$work/samples" <<'EOF'
import statistics, sys
rows = {}
for line in open(sys.argv[1]):
    name, rec, backend, wall, cpu = line.split()
    rows.setdefault((name, rec, backend), []).append((float(wall), float(cpu)))
for (name, rec, backend), samples in rows.items():
    wall = statistics.median(s[0] for s in samples)
    cpu = statistics.median(s[1] for s in samples)
    print(f"{name} {rec} {backend} {wall:.1f} {1000 / wall:.1f} {cpu:.1f} {2000 / cpu:.1f}")
EOF
