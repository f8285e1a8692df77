#!/usr/bin/env bash
# The size rules of docs/structure.md: no product source file over 600 lines, no function over
# 120 lines. Tests and fuzz targets are outside the rule. Prints every breach
# and exits 1 when there is one. Needs universal-ctags (function extents).
set -euo pipefail
cd "$(dirname "$0")/.."
max_file=${MIMIC_MAX_FILE_LINES:-600}
max_function=${MIMIC_MAX_FUNCTION_LINES:-120}
if git rev-parse --is-inside-work-tree > /dev/null 2>&1; then
  mapfile -t files < <(git ls-files -- '*.cpp' '*.h' | grep -vE '^(tests|fuzz)/')
else  # an exported tree: every source below the product's folders
  mapfile -t files < <(find . -path ./build -prune -o -path './build-*' -prune -o \( -name '*.cpp' -o -name '*.h' \) -print |
    sed 's|^\./||' | grep -vE '^(tests|fuzz|examples)/' | sort)
fi
breaches=0
for f in "${files[@]}"; do
  [[ -f $f ]] || continue
  n=$(wc -l < "$f")
  if (( n > max_file )); then echo "$f: $n lines (over $max_file)"; breaches=$((breaches + 1)); fi
done
while IFS=$'\t' read -r lines name file line; do
  echo "$file:$line: $name is $lines lines (over $max_function)"; breaches=$((breaches + 1))
done < <(ctags --fields=+ne --kinds-C++=f --extras=-q -o - --language-force=C++ "${files[@]}" |
  awk -F'\t' -v max="$max_function" '{
    l = 0; e = 0
    for (i = 4; i <= NF; i++) { if ($i ~ /^line:/) l = substr($i, 6); if ($i ~ /^end:/) e = substr($i, 5) }
    if (l > 0 && e - l + 1 > max) printf "%d\t%s\t%s\t%d\n", e - l + 1, $1, $2, l }' | sort -rn)
if (( breaches > 0 )); then echo "$breaches breach(es) of the size rules"; exit 1; fi
echo "size rules hold: ${#files[@]} files, none over $max_file lines, no function over $max_function lines"
