#!/bin/sh
# The long run of issue 36 item 7: 300 agents, ~33,000 lockstep steps (about 30 minutes here), --record,
# watched every 10 s (scripts/soak.py says what and the criteria). Its output is docs/benchmarks/soak.txt:
#     scripts/soak.sh | tee docs/benchmarks/soak.txt
# Options pass through, e.g. scripts/soak.sh --agents 50 --steps 3000 for a short try.
set -e
cd "$(dirname "$0")/.."
exec .venv/bin/python scripts/soak.py "$@"
