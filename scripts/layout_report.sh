#!/bin/bash
# The house in numbers (issue 34): lines per src/ folder, files over 500 lines, functions over 100
# lines (Universal Ctags), the tests and the README. Usage: scripts/layout_report.sh [repo root]
cd "${1:-.}"
echo "== lines per src/ folder (cpp+hpp+h)"
for d in src/*/; do printf "%-20s %6d\n" "$d" "$(find "$d" -name '*.cpp' -o -name '*.hpp' -o -name '*.h' | xargs cat | wc -l)"; done
printf "%-20s %6d\n" total "$(find src -name '*.cpp' -o -name '*.hpp' -o -name '*.h' | xargs cat | wc -l)"
echo "== files over 500 lines"
find src -name '*.cpp' -o -name '*.hpp' | xargs wc -l | sort -rn | awk '$2!="total" && $1>500'
echo "== functions over 100 lines"
ctags -R --fields=+ne --c++-kinds=f -x --_xformat='%N %F %n %e' src 2>/dev/null | awk '{len=$4-$3+1; if (len>100) print len, $1, $2":"$3}' | sort -rn
echo "== tests: $(ls tests | wc -l) entries at top level; $(find tests -name '*.cpp' -o -name '*.hpp' | xargs cat | wc -l) lines"
echo "== README: $(wc -l < README.md) lines"
