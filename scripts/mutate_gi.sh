#!/usr/bin/env bash
# Mutation check of the GI core's tests: applies one plausible formula error
# at a time to the GI math (gi/lightskin/shaders/lightskin_math.glsl, shared by the shaders and the double
# reference gi::reference, and the GPU-only shaders), rebuilds only the GI tests, runs them and
# records which test binaries fail. Every mutation must be caught by at least one test; the
# independent ones are gi_paper_reference_test (PaperReference, closed forms), gi_gather_gl_test
# (GPU against PaperReference) and gi_truth_gl_test (GPU against the Embree ray tracer).
#
#   scripts/mutate_gi.sh
#   MUTATE_ONLY=7,8,10 MUTATE_TESTS=gi_truth_gl_test scripts/mutate_gi.sh   # a subset (numbers as
#                       in the table; a subset run cannot prove that every mutation is caught)
#
# Works on a scratch copy of the source tree, build-mutate/src/ (build dir build-mutate/src/build,
# RelWithDebInfo; the checkout itself is never edited), so the rest of the checkout can be built
# meanwhile. The copy's first build is mostly ccache hits when ccache has the checkout's objects
# (with CCACHE_BASEDIR and CCACHE_NOHASHDIR set); each mutation then rebuilds only the
# shader embedding, the gi library and the four test binaries. Prints a Markdown table (also
# written to build-mutate/mutate_gi.md) and exits non-zero if a mutation survived or the unmutated
# tests fail. ~1 min per mutation on 2 cores (incremental rebuild + ~30 s of tests).
set -euo pipefail
checkout="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
root="$checkout/build-mutate/src"
build="$root/build"
mkdir -p "$root"
# Sync the copy: write only files whose bytes differ (fresh mtime), so that ninja rebuilds exactly
# what changed since the last run (restoring old mtimes, as tar would, can hide a change).
python3 - "$checkout" "$root" <<'EOF_SYNC'
import os, shutil, sys
src, dst = sys.argv[1], sys.argv[2]
for folder, dirs, files in os.walk(src):
    rel = os.path.relpath(folder, src)
    if rel == '.':
        dirs[:] = [d for d in dirs if not (d.startswith('build') or d in ('.git', 'out'))]
    os.makedirs(os.path.join(dst, rel), exist_ok=True)
    for name in files:
        a, b = os.path.join(folder, name), os.path.join(dst, rel, name)
        if os.path.islink(a):
            continue
        if not os.path.exists(b) or open(a, 'rb').read() != open(b, 'rb').read():
            shutil.copyfile(a, b)
            shutil.copymode(a, b)
EOF_SYNC
cmake -S "$root" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo >/dev/null
tests=(gi_paper_reference_test gi_gather_reference_test gi_gather_gl_test gi_truth_gl_test)
if [[ -n "${MUTATE_TESTS:-}" ]]; then read -r -a tests <<<"$MUTATE_TESTS"; fi
only=",${MUTATE_ONLY:-},"
declare -A binary=(
  [gi_paper_reference_test]=tests/gi/reference/gi_paper_reference_test
  [gi_gather_reference_test]=tests/gi/reference/gi_gather_reference_test
  [gi_gather_gl_test]=tests/gi/lightskin/gi_gather_gl_test
  [gi_truth_gl_test]=tests/gi/lightskin/gi_truth_gl_test
)
math=gi/lightskin/shaders/lightskin_math.glsl

# name | equation | file | exact text | replacement (literal strings, each must occur exactly once)
mutations=(
  "w without r^2|eq. 3/4|$math|const real w = t.r2 * t.g;|const real w = t.g;"
  "c_k = c, (k + 1) dropped|eq. 5|$math|s.glossy = valid ? mw * (ck * lobe)|s.glossy = valid ? mw * (ck / (k + 1.0) * lobe)"
  "GPU c_k = c k|eq. 5 (GPU only)|gi/lightskin/shaders/gather_sparse.frag|const float ck = uC * (k + 1.0);|const float ck = uC * k;"
  "mirror without the factor 2|eq. 5|$math|const rvec3 mirror = 2.0 * dot(n, toLight) * n - toLight;|const rvec3 mirror = dot(n, toLight) * n - toLight;"
  "cos^(k+1) in the gather|eq. 5|$math|ls_cosPow(ls_cosGamma(n, t.toLight, toEye), k)|ls_cosPow(ls_cosGamma(n, t.toLight, toEye), k + 1.0)"
  "W_d without cos(theta_i)|eq. 7|$math|s.weightD = valid ? epsL + w * t.cosI : 0.0;|s.weightD = valid ? epsL + w : 0.0;"
  "W_s with the diffuse weight|eq. 7|$math|s.weightS = valid ? epsL + w * lobe : 0.0;|s.weightS = valid ? epsL + w * t.cosI : 0.0;"
  "rbar^2 not divided by W|eq. 7|$math|v.r2 = max(sumR2 * invW, 0.0);\n    v.position = x + mean;\n    const rvec3 variance|v.r2 = max(sumR2, 0.0);\n    v.position = x + mean;\n    const rvec3 variance"
  "L''_d multiplied by cos|eq. 11|$math|v.radiance = sumL * (max(d2 + v.r2, kTinyLength2) / max(cosT, kMinRenormCos));|v.radiance = sumL * (max(d2 + v.r2, kTinyLength2) * max(cosT, kMinRenormCos));"
  "L''_s without rbar^2 in D|eq. 11|$math|v.radiance = sumL * (max(d2 + v.r2, kTinyLength2) / max(lobe, kMinRenormCos));|v.radiance = sumL * (max(d2, kTinyLength2) / max(lobe, kMinRenormCos));"
  "eq. 10 diffuse D without rbar^2|eq. 10|$math|return v.radiance * (cosT / max(d2 + v.r2, kTinyLength2));|return v.radiance * (cosT / max(d2, kTinyLength2));"
  "distance term squared|eq. 12|$math|max(1.0 - dist[j] / dMax, 0.0)|max(1.0 - dist[j] * dist[j] / (dMax * dMax), 0.0)"
  "normal term dropped|eq. 12|$math|r.w[j] = unique[j] ? distanceTerm * clamp(cosN[j], 0.0, 1.0) : 0.0;|r.w[j] = unique[j] ? distanceTerm : 0.0;"
  "weights not normalised (1/W_v)|eq. 13|$math|for (int j = 0; j < kNeighbours; ++j) r.w[j] = r.w[j] / total;|for (int j = 0; j < kNeighbours; ++j) r.w[j] = r.w[j] / (total + 1.0);"
  "occluder centre t/b swapped|eq. 14|$math|const rvec2 centre = rvec2(dot(u, t), dot(u, b));|const rvec2 centre = rvec2(dot(u, b), dot(u, t));"
  "occluder quad side = area|eq. 14|$math|const real side = sqrt(area);|const real side = area;"
  "occluder area without cos(theta_i)|eq. 14|$math|* r2 / max(r2 + d2, kTinyLength2) * cosI; // pi F_disk, eq. 3|* r2 / max(r2 + d2, kTinyLength2); // pi F_disk, eq. 3"
  "S_o area with cos(theta_i) twice|eq. 14|$math|o.area = kPi * cosI * r2 / max(r2 + d2, kTinyLength2);|o.area = kPi * cosI * cosI * r2 / max(r2 + d2, kTinyLength2);"
  "S_o radius = variance, not sigma|3.3|$math|v.sphereRadius = sqrt(max(max(variance.x, variance.y), variance.z));|v.sphereRadius = max(max(variance.x, variance.y), variance.z);"
  "GPU interpolation: normals not transformed|eq. 12 (GPU only)|gi/lightskin/shaders/gather_interpolate.comp|const vec3 nv = normalize(uNormalFromModel * vin.normal.xyz);|const vec3 nv = normalize(vin.normal.xyz);"
)

targets=()
for t in "${tests[@]}"; do
  if grep -qs "lightskin_add_test($t " "$root"/tests/gi/*/CMakeLists.txt; then
    targets+=("$t")
  fi
done

scratch="$(mktemp -d)"
restore() {
  for f in "$scratch"/*.orig; do
    [[ -e "$f" ]] || continue
    local rel
    rel="$(cat "${f%.orig}.path")"
    cp "$f" "$root/$rel"
  done
}
cleanup() {
  restore
  rm -rf "$scratch"
}
trap cleanup EXIT INT TERM

build_targets() { cmake --build "$build" --parallel 2 --target "${targets[@]}" >"$scratch/build.log" 2>&1; }

# Runs every test binary; prints "name(failed count)" for each failing one.
run_tests() {
  local caught=()
  for t in "${targets[@]}"; do
    local out="$scratch/$t.log"
    if ! (cd "$build" && timeout 600 "./${binary[$t]}" >"$out" 2>&1); then
      local n
      n="$(grep -c '^\[  FAILED  \] .*)$' "$out" || true)"
      caught+=("$t ($n)")
    fi
  done
  local IFS=';'
  echo "${caught[*]:-}"
}

replace() { # file, old, new: literal, exactly one occurrence
  python3 - "$@" <<'EOF'
import sys
path, old, new = sys.argv[1], sys.argv[2].replace('\\n', '\n'), sys.argv[3].replace('\\n', '\n')
text = open(path).read()
if text.count(old) != 1:
    sys.exit(f"mutate_gi.sh: {path}: expected exactly one '{old[:60]}', found {text.count(old)}")
open(path, 'w').write(text.replace(old, new))
EOF
}

echo "building ${targets[*]} (unmutated)"
build_targets || { cat "$scratch/build.log"; exit 1; }
baseline="$(run_tests)"
if [[ -n "$baseline" ]]; then
  echo "mutate_gi.sh: the unmutated tests fail: $baseline" >&2
  exit 1
fi

table="| # | mutation | equation | file | failing test binaries (failed tests) |\n|---|---|---|---|---|\n"
survivors=0
i=0
for m in "${mutations[@]}"; do
  i=$((i + 1))
  if [[ -n "${MUTATE_ONLY:-}" && "$only" != *",$i,"* ]]; then continue; fi
  IFS='|' read -r name equation file old new <<<"$m"
  key="$scratch/$i"
  cp "$root/$file" "$key.orig"
  echo "$file" >"$key.path"
  replace "$root/$file" "$old" "$new"
  if build_targets; then
    caught="$(run_tests)"
  else
    caught="build failed"
  fi
  cp "$key.orig" "$root/$file"
  rm -f "$key.orig" "$key.path"
  [[ -z "$caught" ]] && { caught="**SURVIVED**"; survivors=$((survivors + 1)); }
  echo "[$i/${#mutations[@]}] $name ($equation): $caught"
  table+="| $i | $name | $equation | \`$(basename "$file")\` | ${caught//;/, } |\n"
done

printf "%b" "$table" | tee "$checkout/build-mutate/mutate_gi.md"
echo "survivors: $survivors of ${#mutations[@]}"
[[ $survivors -eq 0 ]]
