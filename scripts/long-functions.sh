#!/usr/bin/env bash
# Lists the functions longer than N lines (default 80) in the tracked C++ sources outside tests/,
# longest first, as "LINES FILE:LINE NAME", then their count. Lines are counted from the line
# that names the function to its closing brace (Universal Ctags' end field), so a lambda counts
# with the function it is written in.
#   scripts/long-functions.sh [N]
set -euo pipefail
limit=${1:-80}
cd "$(dirname "${BASH_SOURCE[0]}")/.."
command -v ctags >/dev/null || { echo "long-functions.sh: needs universal-ctags" >&2; exit 2; }
git ls-files '*.cpp' '*.hpp' ':!tests/' |
  ctags --language-force=c++ --kinds-c++=f --fields=+ne -x --_xformat='%{end} %n %N %F' -L - |
  awk -v limit="$limit" '$1 != "" && $1 - $2 + 1 > limit { print $1 - $2 + 1, $4 ":" $2, $3 }' |
  sort -k1,1nr -k2 |
  awk '{ print } END { print NR " functions over '"$limit"' lines" }'
