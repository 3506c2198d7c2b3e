#!/usr/bin/env bash
# The 150-line function rule in core/, with the named exceptions of tests/apps/core_long_functions.txt (each at
# most as long as listed there). Exits 1 naming every function over its limit, and every listed exception that
# no longer exists or is now within 150 lines (the list stays current).
# Usage: core_function_lengths.sh REPO
set -euo pipefail
repo=$1
cd "$repo"
list=tests/apps/core_long_functions.txt
mapfile -t files < <(find core -name '*.cpp' -o -name '*.hpp' | sort)
long=$(bash tests/apps/function_lengths.sh 150 "${files[@]}" || true)
bad=0
while read -r where name lines _; do
  [ -n "$where" ] || continue
  file=${where%%:*}
  allowed=$(awk -v f="$file" -v n="$name" '$1 == f && $2 == n { print $3 }' "$list")
  if [ -z "$allowed" ]; then
    echo "core_function_lengths: $where $name is $lines lines (at most 150; not an exception in $list)"
    bad=1
  elif [ "$lines" -gt "$allowed" ]; then
    echo "core_function_lengths: $where $name grew to $lines lines (its exception allows $allowed)"
    bad=1
  fi
done <<< "$long"
while read -r file name allowed _; do
  case "$file" in ''|'#'*) continue ;; esac
  if ! grep -q "^$file:[0-9]* $name " <<< "$long"; then
    echo "core_function_lengths: $file $name is listed in $list but is no longer over 150 lines (or gone): drop it"
    bad=1
  fi
done < "$list"
[ "$bad" = 0 ] && echo "core_function_lengths: every core function within 150 lines but the $(grep -cv '^#' "$list") listed"
exit "$bad"
