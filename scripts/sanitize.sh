#!/usr/bin/env bash
# Builds with AddressSanitizer + UndefinedBehaviorSanitizer into build-asan/ and runs the tests
# (extra arguments go to ctest, e.g. -L unit). LeakSanitizer suppressions for Mesa and the UBSan
# runtime are in cmake/sanitizers/lsan.supp and applied by CTest.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
"$root/scripts/install_dependencies.sh"
cmake -S "$root" -B "$root/build-asan" -G Ninja -DCMAKE_BUILD_TYPE=Debug -DLIGHTSKIN_SANITIZE=ON
cmake --build "$root/build-asan" --parallel "$(nproc)"
cd "$root/build-asan"
ctest --output-on-failure --no-tests=error --parallel "$(nproc)" "$@"
