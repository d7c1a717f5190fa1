"""Lockstep steps/s with and without credentials and access control, side by side (docs/benchmarks/security.md).

    .venv/bin/python scripts/security_side_by_side.py N[,N...] STEPS ROUNDS OUT.json [BASE_DIR BASE_AGENT_BINARY]

Per N and round, alternating, one swarm each (`run_swarm(spread_block(N), STEPS)`, as scripts/probe_swarm.py):
  acl       fresh credentials, per-process access control on the router, agents put on their id keys and the
            compiled router's relay puts them on the cell keys (FLUIDSWARM_ACCESS=acl)
  acl-keys  the same run without the router's access control: credentials, id keys, the compiled router and its
            relay, no rules
            (measures the rules' own cost; a measurement only, no FLUIDSWARM_ACCESS level)
  auth      credentials only, one exact state key per cell (FLUIDSWARM_ACCESS=auth)
  open      no credentials (FLUIDSWARM_ACCESS=none), same agent binary
  base  the code before issue 18 (an open router, one exact state key per cell): its launcher from BASE_DIR
        (e.g. `git archive 353a79b | tar -x -C BASE_DIR`) and its agent build BASE_AGENT_BINARY
Each swarm runs in its own process (its environment picks the setting). Run it under the CPU lock.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time


def one(n: int, steps: int) -> dict:
    import numpy as np

    from agent.protocol.access import LaunchAccess
    from agent.sph.setups import spread_block
    from swarmhost.launcher import Launcher, run_swarm

    if os.environ.get("FLUIDSWARM_SBS_NO_RULES"):  # acl-keys: the acl level's key layout, no rules on the router
        embedded = LaunchAccess.embedded

        def without_rules():
            access = embedded()
            access.acl = None  # state_key_ids stays as the acl level set it
            return access

        LaunchAccess.embedded = staticmethod(without_rules)

    with Launcher() as la:
        res = run_swarm(spread_block(n), steps, launcher=la)
    f = list(res.finals.values())
    field = lambda r, k: getattr(r, k) if hasattr(r, k) else r[k]  # a FinalReport or a dict
    cpu = np.mean([(field(r, "cpu_seconds") - field(r, "cpu_seconds_at_start")) / max(field(r, "steps"), 1) for r in f])
    rejected: dict[str, int] = {}
    for r in f:
        for k, v in field(r, "rejected").items():
            rejected[k] = rejected.get(k, 0) + v
    return {
        "n": n,
        "done": sum(str(getattr(field(r, "status"), "value", field(r, "status"))) == "done" for r in f),
        "steps_per_second": round(res.steps_per_second(), 2),
        "agent_cpu_us_per_step": round(float(cpu) * 1e6),
        "startup_s": round(res.startup_seconds, 2),
        "msgs": round(res.msgs_per_agent_step(), 1),
        "rejected": rejected,
    }


def main() -> None:
    if sys.argv[1] == "--one":
        print(json.dumps(one(int(sys.argv[2]), int(sys.argv[3]))))
        return
    ns = [int(v) for v in sys.argv[1].split(",")]
    steps, rounds, out = int(sys.argv[2]), int(sys.argv[3]), sys.argv[4]
    base_dir, base = (sys.argv[5], sys.argv[6]) if len(sys.argv) > 6 else ("", "")
    settings = {
        "acl": {"FLUIDSWARM_ACCESS": "acl"},
        "acl-keys": {"FLUIDSWARM_ACCESS": "acl", "FLUIDSWARM_SBS_NO_RULES": "1"},
        "auth": {"FLUIDSWARM_ACCESS": "auth"},
        "open": {"FLUIDSWARM_ACCESS": "none"},
    }
    only = os.environ.get("FLUIDSWARM_SBS_SETTINGS")  # e.g. acl,acl-keys,auth
    if only:
        settings = {k: v for k, v in settings.items() if k in only.split(",")}
    if base:
        settings["base"] = {"FLUIDSWARM_ACCESS": "none", "FLUIDSWARM_AGENT_BIN": base, "PYTHONPATH": base_dir}
    rows = []
    for n in ns:
        for k in range(rounds):
            order = list(settings) if k % 2 == 0 else list(reversed(settings))
            for name in order:
                env = {**os.environ, **settings[name]}
                t = time.time()
                p = subprocess.run(
                    [sys.executable, __file__, "--one", str(n), str(steps)],
                    env=env,
                    capture_output=True,
                    text=True,
                    timeout=1800,
                )
                row = (
                    json.loads(p.stdout.strip().splitlines()[-1])
                    if p.returncode == 0
                    else {"n": n, "error": p.stderr[-300:]}
                )
                row.update(setting=name, round=k, wall_s=round(time.time() - t, 1))
                print(json.dumps(row), flush=True)
                rows.append(row)
    with open(out, "w") as f:
        json.dump({"steps": steps, "rows": rows}, f, indent=1)
    summarise(rows, ns, rounds)


def summarise(rows: list[dict], ns: list[int], rounds: int) -> None:
    """Per N: each setting's steps/s by round, and against `open` in the same round (the issue's figure)."""
    rate = {(r["n"], r["setting"], r["round"]): r.get("steps_per_second") for r in rows}
    for n in ns:
        for name in sorted({r["setting"] for r in rows if r["n"] == n}):
            values = [rate.get((n, name, k)) for k in range(rounds)]
            ratios = [v / o for v, o in zip(values, (rate.get((n, "open", k)) for k in range(rounds))) if v and o]
            against = (
                f"  vs open: {', '.join(f'{r:.0%}' for r in ratios)} (mean {sum(ratios) / len(ratios):.0%})"
                if ratios and name != "open"
                else ""
            )
            print(f"N={n} {name}: steps/s {', '.join('-' if v is None else f'{v:.2f}' for v in values)}{against}")


if __name__ == "__main__":
    main()
