#!/usr/bin/env bash
# The docs index is complete and true: every page under docs/ is linked from docs/README.md and from
# the README's docs row, and every relative link in those two indexes names a file that exists.
# Run by CTest from the source root.
set -u
fail=0
index=docs/README.md
# The README's row of the "What is here" table for docs/.
row=$(grep '^| \[docs/\]' README.md)
[[ -n $row ]] || { echo "FAIL README.md has no docs/ row"; fail=1; }
pages=0
while IFS= read -r page; do
  rel=${page#docs/}
  pages=$((pages + 1))
  [[ $rel == README.md ]] && continue
  grep -qF "]($rel)" "$index" || { echo "FAIL $index does not link $rel"; fail=1; }
  grep -qF "](docs/$rel)" <<<"$row" || { echo "FAIL README.md's docs row does not link docs/$rel"; fail=1; }
done < <(find docs -name '*.md' | sort)
# Links in the two indexes point at files that exist.
for link in $(grep -o '](\([^)#]*\)' "$index" | sed 's/^](//'); do
  [[ $link == http* ]] && continue
  [[ -e docs/$link ]] || { echo "FAIL $index links $link, which does not exist"; fail=1; }
done
for link in $(grep -o '](\([^)#]*\)' <<<"$row" | sed 's/^](//'); do
  [[ -e $link ]] || { echo "FAIL README.md's docs row links $link, which does not exist"; fail=1; }
done
if [[ $fail -ne 0 ]]; then echo "docs_index: FAILED"; exit 1; fi
echo "docs_index: all checks passed ($pages pages under docs/ all linked from $index and README.md)"
