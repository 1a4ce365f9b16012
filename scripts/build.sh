#!/usr/bin/env bash
# Installs what is missing, then configures and builds SIRUPP-LCM.
#   scripts/build.sh                 build/        (warnings are errors, as in CI)
#   scripts/build.sh --asan          build-asan/   AddressSanitizer + UndefinedBehaviorSanitizer
#   scripts/build.sh --tsan          build-tsan/   ThreadSanitizer
# Extra arguments after the option go to cmake (e.g. -DCMAKE_BUILD_TYPE=Debug).
# Prints the build directory on its last line.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
sanitizer=""
case "${1:-}" in
  --asan) sanitizer=asan; shift ;;
  --tsan) sanitizer=tsan; shift ;;
esac
build="$root/build${sanitizer:+-$sanitizer}"

"$root/scripts/install-deps.sh" >&2

generator=()
if [[ ! -f "$build/CMakeCache.txt" ]] && command -v ninja >/dev/null; then generator=(-G Ninja); fi
cmake -S "$root" -B "$build" "${generator[@]}" -DSIRUPP_WERROR=ON -DSIRUPP_SANITIZER="$sanitizer" "$@" >&2
cmake --build "$build" -j "$(nproc)" >&2
echo "$build"
