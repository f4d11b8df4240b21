#!/usr/bin/env bash
# Frames per second and CPU ms per frame of the main job's whole replays: the .oni (640x480, fixed pose, the room's
# estimated light) and synth-orbit (320x240, AprilTag tracking), GL and CPU backends, side by side in one run,
# alternated per round.
# Per frame without the setup: wall clock from the end of the first frame to the end of the last (the replay
# report's steadyMsPerFrame, measured in the process), and the process's CPU time (user + system, every thread:
# llvmpipe's, oneTBB's, the prefetch and GI-ahead workers') as (all frames - 1 frame) / (N - 1). Outputs: no video, no
# comparison, one PNG (--write-frames 0): the pipeline, not the PNG encoder. Differential off unless
# BENCH_DIFFERENTIAL=scene (the scenes' setting: on). A second table gives every stage's mean (report.json cpuMs).
# Recording orbit-moving is
# synth-orbit with orbit_moving.json (the cube animated): the cost of moving content beside orbit's.
#
#   scripts/bench_replay_fps.sh ROUNDS VARIANT=BINARY[:EXTRA_ARGS] ...
#   e.g. scripts/bench_replay_fps.sh 3 before=../main/build/apps/lightskin:--sequential after=build/apps/lightskin
# Prints one line per variant, recording and backend: medians over the rounds, and the fastest round's wall
# time (the round least disturbed by other jobs on a shared machine). BENCH_RECORDINGS="oni orbit" and
# BENCH_BACKENDS="gl cpu" (the defaults) choose what runs.
set -euo pipefail
rounds=${1:?rounds}
shift
repo=$(cd "$(dirname "$0")/.." && pwd)
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
declare -A recs=(
  [oni]="$repo/tests/data/oni-kinect-v1/3dj_test.oni --scene $repo/recordings/scenes/oni_room_estimated.json --pose fixed"
  [orbit]="$repo/recordings/synth-orbit --scene $repo/recordings/scenes/orbit.json --pose tracking"
  [orbit-moving]="$repo/recordings/synth-orbit --scene $repo/recordings/scenes/orbit_moving.json --pose tracking"
)
declare -A frames=([oni]=12 [orbit]=40 [orbit-moving]=40)
# one timed run: prints "wall_seconds cpu_seconds steady_ms_per_frame differential_ms" (the stage's mean wall ms over
# the frames after the first, -1 when it did not run); given an id, appends "id stage=ms ..." (every stage's mean
# over the frames after the first) to $work/stages
run() {
  local binary=$1 extra=$2 rec=$3 backend=$4 n=$5 out="$work/out" id=${6:-}
  rm -rf "$out"
  # shellcheck disable=SC2086
  /usr/bin/time -f "%e %U %S" -o "$work/time" "$binary" -q replay ${recs[$rec]} --out "$out" --no-video --no-compare \
    --write-frames 0 --differential "${BENCH_DIFFERENTIAL:-off}" --backend "$backend" --max-frames "$n" $extra >/dev/null 2>&1
  # binaries from before the key: -1 (the steady column then shows the N - 1 frames' difference instead)
  read -r steady differential < <(python3 -c '
import json, sys
report = json.load(open(sys.argv[1]))
frames = report["frames"][1:]
stages = {}
for f in frames:
    for name, ms in f.get("cpuMs", {}).items():
        stages.setdefault(name, []).append(ms)
if sys.argv[2]:
    with open(sys.argv[3], "a") as out:
        out.write(sys.argv[2] + " " + " ".join(f"{k.replace(chr(32), chr(95))}={sum(v) / len(frames):.2f}"
                                               for k, v in stages.items()) + "\n")
stage = stages.get("differential", [])
print(report.get("steadyMsPerFrame", -1), sum(stage) / len(stage) if stage else -1)' "$out/report.json" "$id" "$work/stages")
  awk -v steady="$steady" -v differential="$differential" '{print $1, $2 + $3, steady, differential}' "$work/time"
}
for ((r = 0; r < rounds; ++r)); do
  for rec in ${BENCH_RECORDINGS:-oni orbit}; do
    for backend in ${BENCH_BACKENDS:-gl cpu}; do
      for variant in "$@"; do
        name=${variant%%=*}
        spec=${variant#*=}
        binary=${spec%%:*}
        extra=""
        [[ $spec == *:* ]] && extra=${spec#*:}
        n=${frames[$rec]}
        read -r wallN cpuN steady differential < <(run "$binary" "$extra" "$rec" "$backend" "$n" "$name,$rec,$backend")
        read -r wall1 cpu1 _ _ < <(run "$binary" "$extra" "$rec" "$backend" 1)
        awk -v id="$name $rec $backend" -v n="$n" -v steady="$steady" -v wN="$wallN" -v w1="$wall1" -v cN="$cpuN" \
          -v c1="$cpu1" -v differential="$differential" \
          'BEGIN { d = (wN - w1) * 1000 / (n - 1); print id, (steady > 0 ? steady : d), (cN - c1) * 1000 / (n - 1), d, differential }' \
          >>"$work/samples"
      done
    done
  done
done
echo "variant recording backend steady_wall_ms_per_frame fps cpu_ms_per_frame fps_bound_2_cores min_steady_wall_ms difference_wall_ms differential_stage_ms (medians of $rounds, min; load $(cut -d' ' -f1-3 /proc/loadavg))"
python3 - "$work/samples" <<'EOF'
import statistics, sys
rows = {}
for line in open(sys.argv[1]):
    name, rec, backend, wall, cpu, difference, differential = line.split()
    rows.setdefault((name, rec, backend), []).append((float(wall), float(cpu), float(difference), float(differential)))
for (name, rec, backend), samples in rows.items():
    wall = statistics.median(s[0] for s in samples)
    cpu = statistics.median(s[1] for s in samples)
    fastest = min(s[0] for s in samples)
    difference = statistics.median(s[2] for s in samples)
    differential = statistics.median(s[3] for s in samples)
    print(f"{name} {rec} {backend} {wall:.1f} {1000 / wall:.1f} {cpu:.1f} {2000 / cpu:.1f} {fastest:.1f} {difference:.1f}"
          f" {differential:.1f}")
EOF
echo
echo "per stage: mean CPU-wall ms per frame over the frames after the first (report.json cpuMs), median of $rounds rounds"
python3 - "$work/stages" <<'EOF'
import statistics, sys
rows = {}
for line in open(sys.argv[1]):
    key, *pairs = line.split()
    for pair in pairs:
        name, ms = pair.split("=")
        rows.setdefault(key, {}).setdefault(name, []).append(float(ms))
for key, stages in rows.items():
    print(key.replace(",", " "), " ".join(f"{name}={statistics.median(v):.1f}" for name, v in stages.items()))
EOF
