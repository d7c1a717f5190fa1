"""A long run (issue 36 item 7): N agents for tens of thousands of lockstep steps with --record, watched.

    python scripts/soak.py [--agents 300] [--steps 33000] [--out DIR] [--every 10]

Starts `fluidswarm launch -n N --steps S --record DIR/soak.mcap --progress` and, every `--every` s, reads
/proc for each process the launcher started (the agents, the router, the recorder): resident memory, open
files, threads. Steps/s per minute come from the launcher's progress lines (a new line every 5 s into a
pipe). At the end: the figures after 1 minute against the last ones, and `fluidswarm replay --check` of the
file. Exit 0 when every criterion holds (RSS within +10 % of its 1-minute value, no growth in open files or
threads, steps/s steady (each minute's rate within 25 % of the median minute; a run of under 5 minutes:
by fifths of it), the MCAP complete with every step), 1 otherwise. Ctrl-C stops the launcher (which
stops its processes) and reports what was seen.
"""

from __future__ import annotations

import argparse
import os
import re
import signal
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path

PAGE = os.sysconf("SC_PAGE_SIZE")
PROGRESS = re.compile(r"(\d+)/(\d+)\s+[\d.]+ steps/s(?:\s+alive (\d+))?")
RSS_GROWTH = 0.10  # the bound: +10 % of the value after 1 minute
RATE_SPREAD = 0.25  # a minute's steps/s within 25 % of the median minute: "steady" on a noisy 2-core machine


@dataclass
class Sample:
    t: float
    rss: dict[int, int]  # pid -> bytes
    fds: dict[int, int]
    threads: dict[int, int]


@dataclass
class Watch:
    kinds: dict[int, str] = field(default_factory=dict)  # pid -> agent | router | recorder
    samples: list[Sample] = field(default_factory=list)
    progress: list[tuple[float, int, int]] = field(default_factory=list)  # (t, step, alive)


def children(root: int) -> list[int]:
    """Every descendant of `root` (from /proc's parent links)."""
    parent: dict[int, int] = {}
    for d in os.listdir("/proc"):
        if d.isdigit():
            try:
                with open(f"/proc/{d}/stat", "rb") as f:
                    stat = f.read()
            except OSError:
                continue
            parent[int(d)] = int(stat[stat.rindex(b")") + 2 :].split()[1])
    out, todo = [], [root]
    while todo:
        p = todo.pop()
        kids = [c for c, pp in parent.items() if pp == p]
        out += kids
        todo += kids
    return out


def kind_of(pid: int) -> str | None:
    try:
        cmd = Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ")
    except OSError:
        return None
    if b"fluidswarm-agent" in cmd:
        return "agent"
    if b"fluidswarm-router" in cmd:
        return "router"
    if b"fluidswarm.recording.recorder" in cmd:
        return "recorder"
    return None


def sample(watch: Watch, root: int, t: float) -> None:
    s = Sample(t, {}, {}, {})
    for pid in children(root):
        kind = watch.kinds.get(pid) or kind_of(pid)
        if kind is None:
            continue
        watch.kinds[pid] = kind
        try:
            with open(f"/proc/{pid}/statm") as f:
                s.rss[pid] = int(f.read().split()[1]) * PAGE
            s.fds[pid] = len(os.listdir(f"/proc/{pid}/fd"))
            s.threads[pid] = len(os.listdir(f"/proc/{pid}/task"))
        except OSError:  # ended between the listing and the read
            for d in (s.rss, s.fds, s.threads):
                d.pop(pid, None)
    watch.samples.append(s)


def read_progress(stream, watch: Watch, t0: float, log) -> None:
    for line in iter(stream.readline, ""):
        m = PROGRESS.search(line)
        if m:
            watch.progress.append((time.monotonic() - t0, int(m.group(1)), int(m.group(3) or -1)))
        else:
            log.write(line)


def window_rates(progress: list[tuple[float, int, int]], window: float) -> list[float]:
    """Steps/s of each whole `window` s of the stepping (from the progress lines' step counts at their times)."""
    stepping = [p for p in progress if p[1] > 0]
    if len(stepping) < 2:
        return []
    t0, rates = stepping[0][0], []
    for k in range(1, int((stepping[-1][0] - t0) // window) + 1):
        start = [p for p in stepping if p[0] <= t0 + (k - 1) * window][-1]
        end = [p for p in stepping if p[0] <= t0 + k * window][-1]
        if end[0] > start[0]:
            rates.append((end[1] - start[1]) / (end[0] - start[0]))
    return rates


def at(watch: Watch, t: float) -> Sample:
    """The first sample taken at or after `t` s (the last one if the run was shorter)."""
    return next((s for s in watch.samples if s.t >= t), watch.samples[-1])


def report(watch: Watch, mcap: Path, code: int, wall: float) -> bool:
    ok = True

    def verdict(name: str, good: bool, text: str) -> None:
        nonlocal ok
        ok &= good
        print(f"{'PASS' if good else 'FAIL'} {name}: {text}")

    # "after 1 minute" of stepping: the start-up (300 processes coming up) is not part of the run's memory
    started = next((t for t, step, _ in watch.progress if step > 0), 0.0)
    first, last = at(watch, started + 60.0), watch.samples[-1]
    print(f"launch exit={code} wall_s={wall:.0f} samples={len(watch.samples)} stepping_from_s={started:.0f}")
    for kind in ("agent", "router", "recorder"):
        pids = [p for p in first.rss if watch.kinds[p] == kind and p in last.rss]
        if not pids:
            print(f"{kind}: none alive at both samples")
            continue
        growth = [last.rss[p] / first.rss[p] - 1.0 for p in pids]
        mb = [first.rss[p] / 2**20 for p in pids], [last.rss[p] / 2**20 for p in pids]
        print(
            f"{kind}: processes={len(pids)} rss_mib_after_1min mean={statistics.mean(mb[0]):.1f} "
            f"max={max(mb[0]):.1f}  at_end mean={statistics.mean(mb[1]):.1f} max={max(mb[1]):.1f}  "
            f"growth max={max(growth):+.1%} mean={statistics.mean(growth):+.1%}"
        )
        fd_grew = [p for p in pids if last.fds[p] > first.fds[p]]
        th_grew = [p for p in pids if last.threads[p] > first.threads[p]]
        print(
            f"{kind}: open_files {sum(first.fds[p] for p in pids)} -> {sum(last.fds[p] for p in pids)}, "
            f"threads {sum(first.threads[p] for p in pids)} -> {sum(last.threads[p] for p in pids)}"
        )
        if kind != "recorder":  # the bound is on the agents and the router; the recorder is reported
            verdict(f"{kind} rss", max(growth) <= RSS_GROWTH, f"largest growth {max(growth):+.1%} (bound +10 %)")
        verdict(f"{kind} files", not fd_grew, f"{len(fd_grew)} processes with more open files")
        verdict(f"{kind} threads", not th_grew, f"{len(th_grew)} processes with more threads")
    # by minute; a short try (under 5 minutes of stepping) by fifths of it
    span = watch.progress[-1][0] - started if watch.progress else 0.0
    window = 60.0 if span >= 300 else max(span / 5, 1.0)
    rates = window_rates(watch.progress, window)
    if rates:
        med = statistics.median(rates)
        spread = max(abs(r / med - 1.0) for r in rates)
        print(f"steps_per_s_by_{window:.0f}s " + " ".join(f"{r:.1f}" for r in rates))
        verdict("steps/s steady", spread <= RATE_SPREAD, f"median {med:.1f}, largest departure {spread:.0%}")
        print(f"steps={watch.progress[-1][1]} alive_at_last_line={watch.progress[-1][2]}")
    else:
        verdict("steps/s steady", False, f"{len(watch.progress)} progress lines: too few to tell")
    check = subprocess.run(
        [sys.executable, "-m", "fluidswarm", "replay", str(mcap), "--check"], capture_output=True, text=True
    )
    lines = dict(x.split("=", 1) for x in check.stdout.split() if "=" in x)
    print("replay --check: " + " ".join(check.stdout.split()) + (f" ({check.stderr.strip()})" if check.stderr else ""))
    verdict(
        "mcap complete",
        check.returncode == 0 and lines.get("complete") == "true" and lines.get("missing_states") == "0",
        f"complete={lines.get('complete')} steps={lines.get('steps')} missing_states={lines.get('missing_states')}",
    )
    verdict("launch exit", code == 0, f"exit code {code}")
    return ok


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--agents", type=int, default=300)
    ap.add_argument("--steps", type=int, default=33000)
    ap.add_argument("--every", type=float, default=10.0, help="s between /proc samples")
    ap.add_argument("--out", type=Path, help="directory of soak.mcap (default: a temporary one, removed)")
    a = ap.parse_args()
    tmp = None if a.out else tempfile.TemporaryDirectory(prefix="soak-")
    out = a.out or Path(tmp.name)
    out.mkdir(parents=True, exist_ok=True)
    mcap = out / "soak.mcap"
    cmd = [sys.executable, "-m", "fluidswarm", "launch", "-n", str(a.agents), "--steps", str(a.steps)]
    cmd += ["--record", str(mcap), "--progress"]
    print("command: " + " ".join(["fluidswarm", *cmd[3:]]), flush=True)
    watch, t0 = Watch(), time.monotonic()
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    reader = threading.Thread(target=read_progress, args=(proc.stderr, watch, t0, sys.stderr), daemon=True)
    reader.start()
    try:
        while proc.poll() is None:
            sample(watch, proc.pid, time.monotonic() - t0)
            try:
                proc.wait(timeout=a.every)
            except subprocess.TimeoutExpired:
                pass
    except KeyboardInterrupt:
        proc.send_signal(signal.SIGINT)  # the launcher stops its agents, router and recorder
        proc.wait()
    wall = time.monotonic() - t0
    reader.join(timeout=5)
    sys.stdout.write(proc.stdout.read() if proc.stdout else "")
    if not watch.samples:
        print("no sample taken: the launcher ended at once")
        return 1
    ok = report(watch, mcap, proc.returncode, wall)
    if tmp is not None:
        tmp.cleanup()
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
