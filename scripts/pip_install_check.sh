#!/usr/bin/env bash
# `pip install .` as a new user does it (issue 34): a clean clone of the committed HEAD installed
# non-editable in a fresh venv, the clone removed, `fluidswarm demo` run from another folder; the wheel of
# `pip wheel` installed in a second fresh venv and its demo; then the bad inputs: the agent program missing at
# run time, and a build without a Rust toolchain, each one line. Slow (the pip build compiles the whole Rust
# dependency tree cold), so not part of `make test`; tests/test_packaging.py is its cheap part.
#   scripts/pip_install_check.sh                 # LOCK=/tmp/fluidswarm-cpu.lock: each demo under that flock
set -euo pipefail
repo=$(cd "$(dirname "$0")/.." && pwd)
PY=${PY:-python3}
tmp=$(mktemp -d /tmp/fluidswarm-pipcheck.XXXXXX)
trap 'rm -rf "$tmp"' EXIT
locked() { if [ -n "${LOCK:-}" ]; then flock "$LOCK" "$@"; else "$@"; fi; }
fig() { sed -n "s/^$1=\([^ ]*\).*/\1/p" "$2" | tail -n 1; }
fails=0
check() { if eval "$2"; then echo "PASS $1"; else echo "FAIL $1"; fails=$((fails + 1)); fi; }
demo() {  # demo VENV NAME: fluidswarm demo from $tmp, fidelity and MCAP checked
  ( cd "$tmp" && locked timeout 300 "$1/bin/fluidswarm" demo --out "$tmp/$2" >"$tmp/$2.log" 2>&1 ) || true
  local iou; iou=$(fig fidelity_iou "$tmp/$2.log")
  check "$2: fidelity_iou=${iou:-none} >= 0.7, MCAP written" \
    "awk -v i='$iou' 'BEGIN{exit !(i!=\"\" && i+0>=0.7)}' && [ -n \"\$(find '$tmp/$2' -name '*.mcap' -size +1k)\" ]"
  [ -n "$iou" ] || tail -n 3 "$tmp/$2.log"
}

echo "# $(date -u +%Y-%m-%dT%H:%MZ) $(nproc) cores; git $(git -C "$repo" rev-parse --short HEAD); $($PY --version)"
git clone -q "$repo" "$tmp/src"
"$PY" -m venv "$tmp/v"
SECONDS=0
"$tmp/v/bin/python" -m pip install -q "$tmp/src" >"$tmp/pip.log" 2>&1 || { tail -n 20 "$tmp/pip.log"; exit 1; }
echo "pip install <clean clone>: ${SECONDS} s (cold cargo build included)"
SECONDS=0
"$tmp/v/bin/python" -m pip wheel -q --no-deps -w "$tmp/wheels" "$tmp/src" >"$tmp/wheel.log" 2>&1 \
  || { tail -n 20 "$tmp/wheel.log"; exit 1; }
echo "pip wheel <the same clone>: ${SECONDS} s; $(cd "$tmp/wheels" && ls) $(du -h "$tmp"/wheels/*.whl | cut -f1)"
rm -rf "$tmp/src"
check "programs installed in the venv's bin/" "[ -x '$tmp/v/bin/fluidswarm-agent' ] && [ -x '$tmp/v/bin/fluidswarm-router' ]"
demo "$tmp/v" pd

"$PY" -m venv "$tmp/w"
"$tmp/w/bin/python" -m pip install -q "$tmp"/wheels/*.whl >"$tmp/pipw.log" 2>&1 || { tail -n 20 "$tmp/pipw.log"; exit 1; }
demo "$tmp/w" wd

# Bad input 1: the agent program missing at run time: one line naming it and how to get it, exit 1
rm "$tmp/w/bin/fluidswarm-agent"
rc=0; ( cd "$tmp" && "$tmp/w/bin/fluidswarm" demo --out "$tmp/gone" >"$tmp/gone.out" 2>"$tmp/gone.err" ) || rc=$?
echo "  $(cat "$tmp/gone.err")"
check "agent program missing: exit 1, one line, no traceback" \
  "[ $rc -eq 1 ] && [ \$(wc -l <'$tmp/gone.err') -eq 1 ] && grep -q 'fluidswarm-agent is not installed' '$tmp/gone.err'"
check "no process of that venv left behind" "! pgrep -f '$tmp/w/' >/dev/null"

# Bad input 2: building without a Rust toolchain (no cargo on PATH, none in ~/.cargo/bin)
git clone -q "$repo" "$tmp/src2"
mkdir "$tmp/home"
rc=0; env PATH=/usr/bin:/bin HOME="$tmp/home" "$tmp/w/bin/python" -m pip wheel -q --no-deps -w "$tmp/nowheel" \
  "$tmp/src2" >"$tmp/norust.log" 2>&1 || rc=$?
grep 'fluidswarm: ' "$tmp/norust.log" | sed 's/^/  /' || true
check "no Rust toolchain: the build stops with our one line" \
  "[ $rc -ne 0 ] && grep -q 'needs a Rust toolchain' '$tmp/norust.log' && ! grep -q Traceback '$tmp/norust.log'"
echo "failures=$fails"
exit $((fails > 0))
