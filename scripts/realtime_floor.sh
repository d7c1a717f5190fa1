#!/usr/bin/env bash
# The floor of docs/benchmarks/realtime.md (issue 32 item 1): the machine's primitives, then the bare lockstep
# exchange (no physics) at N = 100 and 300 through the production router, at three subscription radii, at both
# access levels, and with the Zenoh settings compared there, each setting between two default runs.
#   flock /tmp/fluidswarm-cpu.lock scripts/realtime_floor.sh [ROUNDS] > floor.txt     (~10 min at 300 rounds)
# Builds the two examples first (cargo, --locked; $CARGO_TARGET_DIR is honoured, as the router binary's
# $FLUIDSWARM_ROUTER_BIN). Figures taken while anything else runs are void: check `uptime` first.
set -eu
cd "$(dirname "$0")/.."
rounds=${1:-300}
PY=${PY:-./.venv/bin/python}
target=${CARGO_TARGET_DIR:-$PWD/agent/native/target}
cargo build --release --locked --quiet --manifest-path agent/native/Cargo.toml --bins --examples
export FLUIDSWARM_ROUTER_BIN=${FLUIDSWARM_ROUTER_BIN:-$target/release/fluidswarm-router}
export PYTHONPATH=$PWD${PYTHONPATH:+:$PYTHONPATH}
bare() {
  echo "$(date -u +%H:%M:%S) ${FLUIDSWARM_ACCESS:+FLUIDSWARM_ACCESS=$FLUIDSWARM_ACCESS }${BARE_RUNTIME:+BARE_RUNTIME=$BARE_RUNTIME }$*"
  "$PY" scripts/bare_exchange_launch.py "$@"
}
echo "# $(date -u +%Y-%m-%dT%H:%MZ) $(nproc) cores; git $(git rev-parse --short HEAD); $(uptime)"

echo "## primitives"
"$target/release/examples/primitives" 200000

echo "## bare exchange, default access level (acl), R = 2.5 h (the agents' R_sub at h = 1, v_max dt = 0.05)"
bare 100 "$rounds" 2.5
bare 300 "$rounds" 2.5
echo "## per delivery: radius 1 and 4 (acl), and level none (one routing per state)"
bare 300 "$rounds" 1.0
bare 300 "$rounds" 4.0
FLUIDSWARM_ACCESS=none bare 300 "$rounds" 2.5
FLUIDSWARM_ACCESS=none bare 300 "$rounds" 1.0

echo "## Zenoh settings at N = 300, each between two default runs"
ll_agent='transport/unicast/lowlatency=true;transport/unicast/qos/enabled=false'
ll_router='{"transport/unicast/lowlatency": true, "transport/unicast/qos/enabled": false}'
bare 300 "$rounds" 2.5 --agent-set "$ll_agent" --router-set "$ll_router"
bare 300 "$rounds" 2.5
bare 300 "$rounds" 2.5 --router-set '{"transport/link/tx/queue/batching/time_limit": 5}'
bare 300 "$rounds" 2.5
bare 300 "$rounds" 2.5 --router-runtime '(rx:(worker_threads:1),tx:(handover:rx),app:(handover:rx))'
bare 300 "$rounds" 2.5
BARE_RUNTIME='(rx:(worker_threads:1),app:(worker_threads:1),tx:(handover:app),acc:(handover:app),net:(handover:app))' \
  bare 300 "$rounds" 2.5
bare 300 "$rounds" 2.5 --router-set '{"transport/link/tx/queue/batching/enabled": false}' \
  --agent-set 'transport/link/tx/queue/batching/enabled=false'
bare 300 "$rounds" 2.5
