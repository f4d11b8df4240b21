#!/usr/bin/env bash
# Promotes named actual images written by golden-image tests to goldens, after showing what changes.
#   scripts/promote_goldens.sh [--accept] [--actual DIR] [--goldens DIR] [--lightskin PROGRAM] NAME...
# NAME is a golden's name (e.g. synth_orbit_final_0). For each, NAME.actual.png is looked up in a
# `golden` folder under DIR (default build/test-scratch: replay_<case>/golden/), and the old golden
# (DIR --goldens, default tests/replay/goldens) is compared with it by `lightskin golden-diff`:
# both renderers, old and new means over the covered pixels, the metrics, and NAME.promote-diff.png
# (|new - old| x 8) beside the actual image. Without --accept nothing is copied (exit 3): look at
# the numbers and the diffs first, then run again with --accept. Names are required: there is no
# "promote everything". Exit 2: usage; 1: an actual image is missing or ambiguous, or a tool failed.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
actual_root="$root/build/test-scratch"
golden_dir="$root/tests/replay/goldens"
program="$root/build/apps/lightskin"
accept=0
names=()
usage() { sed -n '2,10p' "$0" | sed 's/^# \{0,1\}//' >&2; exit 2; }
while [[ $# -gt 0 ]]; do
  case "$1" in
    --accept) accept=1; shift ;;
    --actual) [[ $# -ge 2 ]] || usage; actual_root="$2"; shift 2 ;;
    --goldens) [[ $# -ge 2 ]] || usage; golden_dir="$2"; shift 2 ;;
    --lightskin) [[ $# -ge 2 ]] || usage; program="$2"; shift 2 ;;
    -h|--help) usage ;;
    -*) echo "promote_goldens: unknown option '$1'" >&2; usage ;;
    *) names+=("$1"); shift ;;
  esac
done
if [[ ${#names[@]} -eq 0 ]]; then
  echo "promote_goldens: name the goldens to promote (e.g. synth_orbit_final_0); there is no 'all'" >&2
  usage
fi
[[ -x "$program" ]] || { echo "promote_goldens: $program is not built (cmake --build build --target lightskin)" >&2; exit 1; }

actuals=()
for name in "${names[@]}"; do
  mapfile -t found < <(find "$actual_root" -path "*/golden/$name.actual.png" 2>/dev/null | sort)
  if [[ ${#found[@]} -ne 1 ]]; then
    echo "promote_goldens: $name: expected one golden/$name.actual.png under $actual_root, found ${#found[@]}" \
         "(run the test first: ctest --test-dir build -L replay)" >&2
    exit 1
  fi
  actual="${found[0]}"
  [[ -f "${actual%.png}.json" ]] || { echo "promote_goldens: $name: ${actual%.png}.json (renderer sidecar) is missing" >&2; exit 1; }
  echo "$name:"
  "$program" -q golden-diff "$actual" "$golden_dir/$name.png" --diff "${actual%.actual.png}.promote-diff.png"
  actuals+=("$actual")
done

if [[ $accept -ne 1 ]]; then
  echo "promote_goldens: nothing promoted. Review the metrics and diffs above, then run again with --accept" \
       "and say in the commit why the images changed." >&2
  exit 3
fi
mkdir -p "$golden_dir"
for i in "${!names[@]}"; do
  name="${names[$i]}"; actual="${actuals[$i]}"
  cp "$actual" "$golden_dir/$name.png"
  cp "${actual%.png}.json" "$golden_dir/$name.json"
  echo "promoted $name ($(grep -o '"renderer": "[^"]*"' "$golden_dir/$name.json"))"
done
