#!/usr/bin/env bash
# Exactness under load (issue 14): 20 consecutive `fluidswarm verify --agents 36 --steps 120` while two busy
# loops keep both cores loaded. Every run must print max_position_error <= 1e-9.
#   scripts/exactness_under_load.sh [RUNS] > docs/benchmarks/exactness_under_load.txt
set -u
cd "$(dirname "$0")/.."
runs=${1:-20}
FS=./.venv/bin/fluidswarm
burners=()
for _ in 1 2; do (while :; do :; done) & burners+=($!); done
trap 'kill "${burners[@]}" 2>/dev/null' EXIT INT TERM
echo "# $(date -u +%Y-%m-%dT%H:%MZ) $(nproc) cores, 2 busy loops running; git $(git rev-parse --short HEAD)"
fails=0
for i in $(seq 1 "$runs"); do
  out=$("$FS" verify --agents 36 --steps 120 2>&1)
  err=$(sed -n 's/^max_position_error=//p' <<<"$out")
  sps=$(sed -n 's/^steps_per_second=//p' <<<"$out")
  ok=$(awk -v e="$err" 'BEGIN{print (e!="" && e+0<=1e-9) ? "ok" : "FAIL"}')
  [ "$ok" = ok ] || fails=$((fails+1))
  echo "run $i: max_position_error=$err steps_per_second=$sps $ok"
done
echo "failed=$fails of $runs"
exit $((fails > 0))
