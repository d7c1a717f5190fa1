"""Historical (needs commit 7b7d7b7, the last with agent/process.py, and /tmp/pyagent: a shell script running
`exec .venv/bin/python -m agent "$@"`). Side by side, one run: the Python agent vs the native agent, the same
lockstep set-up (`spread_block`, all SPH terms), alternating per N. Figures as fluidswarm bench's lockstep()."""

import json
import os
import sys
import time

sys.path.insert(0, "/work/main")
import swarmhost.launcher as L
from fluidswarm import bench

out = []
steps = int(sys.argv[2])
for n in [int(v) for v in sys.argv[1].split(",")]:
    for kind in ("python", "native"):
        if kind == "python":
            os.environ["FLUIDSWARM_AGENT_BIN"] = "/tmp/pyagent"
            L.CLOCK_PERIOD = 0.1
        else:
            os.environ.pop("FLUIDSWARM_AGENT_BIN", None)
            L.CLOCK_PERIOD = 0.02
        t = time.time()
        try:
            r = bench.lockstep(n, steps)
        except Exception as exc:  # noqa: BLE001  # a failed size is recorded as such; the others still run
            r = {"n": n, "error": str(exc)}
        r["agent"] = kind
        r["wall_total_s"] = round(time.time() - t, 1)
        print(json.dumps(r), flush=True)
        out.append(r)
with open(sys.argv[3], "w") as f:
    json.dump(out, f, indent=1)
