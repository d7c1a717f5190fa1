"""CPU seconds of every process a command starts, by program (comm), e.g.
    .venv/bin/python scripts/cpu_by_process.py .venv/bin/fluidswarm launch -n 300 --steps 300 --record r.mcap

Polls /proc every 0.2 s for the command's process tree and keeps each process's last user + system CPU, so
processes that end are counted up to their last sample (< 0.2 s of CPU lost each). Prints the command's
finished / steps_per_second / msgs_per_agent_step lines and `comm:<processes>p=<seconds>s` per program
(fluidswarm-agen: the agents, fluidswarm-rout: the router, python: the recorder, fluidswarm: the launcher).
Used for docs/scale.md and issue 34's side-by-side runs."""

import collections
import os
import subprocess
import sys
import time

TCK = os.sysconf("SC_CLK_TCK")


def stat(pid: int) -> tuple[str, int, float] | None:
    """comm, parent pid and user + system CPU seconds of `pid` (/proc/PID/stat), or None once it is gone."""
    try:
        with open(f"/proc/{pid}/stat") as f:
            s = f.read()
    except OSError:
        return None
    comm = s[s.index("(") + 1 : s.rindex(")")]
    fl = s.rsplit(")", 1)[1].split()
    return comm, int(fl[1]), (int(fl[11]) + int(fl[12])) / TCK


def tree_of(root: int, stats: dict[int, tuple[str, int, float]]) -> set[int]:
    """`root` and its descendants among `stats` (pid -> comm, parent, CPU)."""
    tree, changed = {root}, True
    while changed:
        changed = False
        for pid, (_, parent, _) in stats.items():
            if parent in tree and pid not in tree:
                tree.add(pid)
                changed = True
    return tree


def main() -> None:
    p = subprocess.Popen(sys.argv[1:], stdout=subprocess.PIPE, text=True)
    last: dict[int, tuple[str, float]] = {}  # pid -> comm, CPU at its last sample
    try:
        while p.poll() is None:
            stats = {int(d): r for d in os.listdir("/proc") if d.isdigit() and (r := stat(int(d)))}
            for pid in tree_of(p.pid, stats) & stats.keys():
                last[pid] = (stats[pid][0], stats[pid][2])
            time.sleep(0.2)
    finally:
        if p.poll() is None:
            p.terminate()
            p.wait()
    out = p.stdout.read() if p.stdout else ""
    by_comm: dict[str, float] = collections.defaultdict(float)
    count: collections.Counter[str] = collections.Counter()
    for comm, cpu in last.values():
        by_comm[comm] += cpu
        count[comm] += 1
    keep = ("finished", "steps_per_second", "msgs_per_agent_step")
    print(" ".join(w for w in out.split() if w.split("=")[0] in keep))
    print(" ".join(f"{c}:{count[c]}p={v:.1f}s" for c, v in sorted(by_comm.items(), key=lambda x: -x[1])))


if __name__ == "__main__":
    main()
