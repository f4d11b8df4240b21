#!/usr/bin/env bash
# Promotes actual images written by golden-image tests to goldens.
#   scripts/promote_goldens.sh <folder with NAME.actual.png> <golden folder> [NAME ...]
# Without names, every NAME.actual.png in the folder is promoted. Each golden keeps the sidecar
# (NAME.json) that records the renderer that produced it. Review the images before committing.
set -euo pipefail
if [[ $# -lt 2 ]]; then
  sed -n '2,6p' "$0" >&2
  exit 2
fi
actual_dir="$1"; golden_dir="$2"; shift 2
mkdir -p "$golden_dir"
if [[ $# -eq 0 ]]; then
  mapfile -t names < <(find "$actual_dir" -maxdepth 1 -name '*.actual.png' -printf '%f\n' | sed 's/\.actual\.png$//' | sort)
else
  names=("$@")
fi
[[ ${#names[@]} -gt 0 ]] || { echo "promote_goldens: no *.actual.png in $actual_dir" >&2; exit 1; }
for name in "${names[@]}"; do
  cp "$actual_dir/$name.actual.png" "$golden_dir/$name.png"
  cp "$actual_dir/$name.actual.json" "$golden_dir/$name.json"
  echo "promoted $name ($(grep -o '"renderer": "[^"]*"' "$golden_dir/$name.json"))"
done
