#!/usr/bin/env bash
# Builds the Debian package sirupp_VERSION_amd64.deb (CPack, cmake/SiruppPackage.cmake) and prints
# its path on the last line. docs/install.md.
#   scripts/package.sh                  scripts/build.sh first (installs what is missing, builds
#                                       build/), then the package from build/
#   scripts/package.sh --build-dir DIR  the package from DIR as it is (already built; no
#                                       sanitizer build)
#   --lintian                           also run lintian on it: its report is printed, and an
#                                       error (E:) fails the script
#   --out DIR                           where the .deb goes (default: BUILD_DIR/packages)
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
build=""
out=""
lint=0
while [[ $# -gt 0 ]]; do
  case "$1" in
    --build-dir) [[ $# -ge 2 ]] || { echo "package.sh: --build-dir needs a folder" >&2; exit 2; }
                 build=$(cd "$2" && pwd); shift 2 ;;
    --out) [[ $# -ge 2 ]] || { echo "package.sh: --out needs a folder" >&2; exit 2; }
           mkdir -p "$2"; out=$(cd "$2" && pwd); shift 2 ;;
    --lintian) lint=1; shift ;;
    *) echo "package.sh: unknown option '$1'; allowed: --build-dir DIR, --out DIR, --lintian" >&2; exit 2 ;;
  esac
done

if [[ -z "$build" ]]; then
  build=$("$root/scripts/build.sh" | tail -n 1)
fi
cache="$build/CMakeCache.txt"
[[ -f "$cache" ]] || { echo "package.sh: $build is not a configured build folder (no CMakeCache.txt)" >&2; exit 2; }
sanitizer=$(sed -n 's/^SIRUPP_SANITIZER:STRING=//p' "$cache")
[[ -z "$sanitizer" ]] || { echo "package.sh: $build is a '$sanitizer' build; package an ordinary one (build/)" >&2; exit 2; }
[[ -f "$build/CPackConfig.cmake" ]] || { echo "package.sh: $build has no CPackConfig.cmake; configure it again (scripts/build.sh)" >&2; exit 2; }
[[ -x "$build/bin/sirupp" ]] || { echo "package.sh: $build/bin/sirupp is missing; build first (scripts/build.sh)" >&2; exit 2; }
command -v dpkg-shlibdeps >/dev/null || { echo "package.sh: dpkg-shlibdeps missing (apt-get install dpkg-dev)" >&2; exit 2; }

out=${out:-$build/packages}
mkdir -p "$out"
# The version the package gets is the project's (CMakeLists.txt); a stale .deb of it goes first.
version=$(sed -n 's/^CMAKE_PROJECT_VERSION:STATIC=//p' "$cache")
deb="$out/sirupp_${version}_$(dpkg --print-architecture).deb"
rm -f "$deb"
(cd "$build" && cpack -G DEB -B "$out" >"$out/cpack.log" 2>&1) ||
  { echo "package.sh: cpack failed; its output:" >&2; cat "$out/cpack.log" >&2; exit 1; }
[[ -f "$deb" ]] || { echo "package.sh: cpack wrote no $deb; its output:" >&2; cat "$out/cpack.log" >&2; exit 1; }
rm -rf "$out/_CPack_Packages"

if [[ $lint -eq 1 ]]; then
  command -v lintian >/dev/null || { echo "package.sh: lintian missing (apt-get install lintian)" >&2; exit 2; }
  # lintian says it should not run as root; it reads the package only.
  report=$(lintian --tag-display-limit 0 "$deb" 2>&1 | grep -v "running with root privileges" || true)
  echo "lintian:" >&2
  if [[ -n "$report" ]]; then printf '%s\n' "$report" >&2; else echo "  (nothing)" >&2; fi
  if grep -q '^E: ' <<<"$report"; then
    echo "package.sh: lintian reports errors" >&2
    exit 1
  fi
fi
echo "$deb"
