#!/usr/bin/env bash
# Installs what is missing, builds and runs every test with CTest.
#   scripts/test.sh            the normal build (warnings shown, not errors)
#   scripts/test.sh --werror   warnings are errors (CI; or SIRUPP_WERROR=1)
#   scripts/test.sh --asan     the same tests under AddressSanitizer + UBSan (build-asan/)
#   scripts/test.sh --tsan     under ThreadSanitizer (build-tsan/)
#   scripts/test.sh --long     also the long tests (label "long": the demo idle and under load)
#                              (--asan also leaves out label "not-asan": the Python tests)
# Options may be combined (--asan --werror). Further arguments go to ctest (e.g. -R Bus to run
# only matching tests).
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
build_args=()
long=0
while [[ $# -gt 0 ]]; do
  case "$1" in
    --asan|--tsan|--werror) build_args+=("$1"); shift ;;
    --long) long=1; shift ;;
    *) break ;;
  esac
done
# The tests start services of their own (Slurm, Apache: scripts/install-deps.sh --services installs
# them with no daemon started); the build installs the rest.
"$root/scripts/install-deps.sh" --services >&2
build=$("$root/scripts/build.sh" "${build_args[@]}" | tail -n 1)
export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1:abort_on_error=0}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}
cd "$build"
# Excluded labels: "long" unless --long; under --asan also "not-asan" (multi-process tests whose
# code the unit tests already cover under ASan: the Python tests, tests/CMakeLists.txt says why).
exclude=()
[[ $long -eq 1 ]] || exclude+=(long)
[[ " ${build_args[*]:-} " == *" --asan "* ]] && exclude+=(not-asan)
select=()
[[ ${#exclude[@]} -eq 0 ]] || select=(-LE "$(IFS='|'; echo "${exclude[*]}")")
exec ctest --output-on-failure --timeout 900 -j "$(nproc)" "${select[@]}" "$@"
