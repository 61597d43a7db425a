#!/usr/bin/env bash
# The project speaks of itself, not of the history of its making: no tracked file's name or
# text may say "session", "issue N", "seed 0NN" (a numbered source document), "DESIGN" (a
# design document's sections) or "Review mend". Cite the paper or name the thing instead.
# Checks every file git tracks (binary files' contents are skipped) but this one, which
# has to spell the words. Exits 1 listing the hits.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
git rev-parse --is-inside-work-tree > /dev/null 2>&1 || { echo "check_history_words: not a git checkout" >&2; exit 2; }
self=scripts/check_history_words.sh
# any case: session(s), issue N, seed 0NN, review mend; upper case only: DESIGN (the word
# "design" itself is fine)
words='\bsessions?\b|\bissues? #?[0-9]+|\bseeds? 0[0-9]{2}\b|\breview mend'
design='\bDESIGN\b'

hits="$( { git grep -I -n -i -E "$words" -- . ":!$self" || true
           git grep -I -n -E "$design" -- . ":!$self" || true
           git ls-files | grep -v -x "$self" |
             grep -i -E '(^|[^a-z])sessions?([^a-z]|$)|(^|[^a-z])issues?[ _-]?[0-9]+|seeds?[ _-]?0[0-9]{2}|review[ _-]?mend' |
             sed 's/$/ (file name)/' || true
           git ls-files | grep -v -x "$self" | grep -E 'DESIGN' | sed 's/$/ (file name)/' || true; } | sort -u)"
if [ -n "$hits" ]; then
  echo "$hits"
  echo "check_history_words: $(echo "$hits" | wc -l) lines speak of the project's history (above)" >&2
  exit 1
fi
echo "$(git ls-files | grep -v -c -x "$self") files checked, no history words"
