#!/usr/bin/env bash
# The main job: installs what is missing, builds the programs (not the tests: scripts/test.sh
# builds those on top), and runs the headless demo (`sirupp demo`).
# Arguments go to `sirupp demo` (see `build/bin/sirupp help`).
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
build=$("$root/scripts/build.sh" --programs | tail -n 1)
cd "$root"
exec "$build/bin/sirupp" demo "$@"
