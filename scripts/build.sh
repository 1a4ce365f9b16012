#!/usr/bin/env bash
# Installs what is missing, then configures and builds SIRUPP-LCM.
#   scripts/build.sh                 build/        (warnings are shown, not errors)
#   scripts/build.sh --werror        build/        warnings are errors (CI; or SIRUPP_WERROR=1)
#   scripts/build.sh --asan          build-asan/   AddressSanitizer + UndefinedBehaviorSanitizer
#   scripts/build.sh --tsan          build-tsan/   ThreadSanitizer
#   scripts/build.sh --programs      build/        only the programs (sirupp, sirupp-sim, ...: what
#                                    scripts/demo.sh runs), not the tests, benchmarks, examples or
#                                    the Python module; a later full build reuses what it built
#                                    (sanitizer builds leave out the Python module and the
#                                    benchmarks, which no test runs there; -DSIRUPP_BUILD_PYTHON=ON
#                                    or -DSIRUPP_BUILD_BENCH=ON after the option puts them back)
# Options may be combined (--asan --werror). Arguments after them go to cmake (e.g.
# -DCMAKE_BUILD_TYPE=Debug). Prints the build directory on its last line.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
sanitizer=""
werror=OFF
target=()
case "${SIRUPP_WERROR:-}" in
  1|ON|on|yes|true) werror=ON ;;
  ""|0|OFF|off|no|false) ;;
  *) echo "build.sh: SIRUPP_WERROR='$SIRUPP_WERROR': expected 1 or 0" >&2; exit 2 ;;
esac
while [[ $# -gt 0 ]]; do
  case "$1" in
    --asan) sanitizer=asan; shift ;;
    --tsan) sanitizer=tsan; shift ;;
    --werror) werror=ON; shift ;;
    --programs) target=(--target sirupp_programs); shift ;;
    *) break ;;
  esac
done
build="$root/build${sanitizer:+-$sanitizer}"

"$root/scripts/install-deps.sh" >&2

generator=()
if [[ ! -f "$build/CMakeCache.txt" ]] && command -v ninja >/dev/null; then generator=(-G Ninja); fi
# SIRUPP_WERROR is passed every time, so a build directory configured with --werror once does not
# keep it.
parts=ON
[[ -z "$sanitizer" ]] || parts=OFF
cmake -S "$root" -B "$build" "${generator[@]}" -DSIRUPP_WERROR="$werror" -DSIRUPP_SANITIZER="$sanitizer" \
  -DSIRUPP_BUILD_PYTHON="$parts" -DSIRUPP_BUILD_BENCH="$parts" "$@" >&2
cmake --build "$build" -j "$(nproc)" "${target[@]}" >&2
echo "$build"
