#!/usr/bin/env bash
# The documentation set holds together: README.md at most 12 KiB, every docs/*.md linked
# from README.md, every file under bench/results/ linked from docs/benchmarks.md, and every
# relative link of README.md and docs/*.md pointing at a file that exists. Run by CTest.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
fail=0
size=$(wc -c < README.md)
if ((size > 12288)); then echo "README.md is $size bytes (at most 12288)"; fail=1; fi
for doc in docs/*.md; do
  grep -q "($doc)" README.md || { echo "README.md does not link $doc"; fail=1; }
done
while IFS= read -r f; do
  grep -q "(../$f)" docs/benchmarks.md || { echo "docs/benchmarks.md does not link $f"; fail=1; }
done < <(find bench/results -type f | sort)
for md in README.md docs/*.md; do
  dir=$(dirname "$md")
  # markdown links and images: ](target) or ](target#anchor), not URLs
  while IFS= read -r target; do
    path="${target%%#*}"
    [[ -z "$path" || "$path" == *://* ]] && continue
    [[ -e "$dir/$path" ]] || { echo "$md links $target, which does not exist"; fail=1; }
  done < <(grep -oE '\]\([^) ]+\)' "$md" | sed -E 's/^\]\((.*)\)$/\1/')
done
((fail == 0)) && echo "check_docs.sh: README $size bytes; $(ls docs/*.md | wc -l) docs linked; $(find bench/results -type f | wc -l) results files linked; links resolve"
exit "$fail"
