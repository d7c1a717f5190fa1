#!/bin/sh
# issue 34: `sh scripts/count_boundary_lines.sh [tree]`; for a commit: `git archive COMMIT | tar -x -C DIR`, then count DIR
# Lines of Python + Rust under agent/ and coordinator/control/, outside tests: no target/, fuzz/ or tests/, and a Rust
# file's lines from its `#[cfg(test)]` on are tests (this crate's layout: the test module last).
cd "${1:-.}"
py=$(find agent coordinator/control -name '*.py' -not -path '*/target/*' -not -path '*/fuzz/*' -not -path '*/tests/*' | xargs cat | wc -l)
rs_all=$(find agent coordinator/control -name '*.rs' -not -path '*/target/*' -not -path '*/fuzz/*' -not -path '*/tests/*' | xargs cat | wc -l)
rs=$(for f in $(find agent coordinator/control -name '*.rs' -not -path '*/target/*' -not -path '*/fuzz/*' -not -path '*/tests/*'); do awk '/^#\[cfg\(test\)\]/{exit} {print}' "$f"; done | wc -l)
echo "python $py  rust $rs (with inline tests $rs_all)  total $((py + rs))"
