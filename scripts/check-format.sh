#!/usr/bin/env bash
# Fails when a C++ file (tracked, or new and not ignored) differs from clang-format's output
# (VTK style, .clang-format).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
if ! git rev-parse --is-inside-work-tree > /dev/null 2>&1; then
  echo "check-format: not a git checkout, nothing to check"
  exit 0
fi
status=0
while IFS= read -r file; do
  if ! clang-format --dry-run --Werror "$file" > /dev/null 2>&1; then
    echo "check-format: $file is not clang-formatted (run: clang-format -i $file)"
    status=1
  fi
done < <(git ls-files --cached --others --exclude-standard '*.h' '*.cxx')
[ "$status" -eq 0 ] && echo "check-format: all C++ files are formatted"
exit "$status"
