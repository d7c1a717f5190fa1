"""Helpers shared by the tests: process inspection, the live view of a run, the field names a command carries."""

from __future__ import annotations

import json
import os
import time

from tests.foxglove_client import FoxgloveClient


def children_of(pid: int) -> set[int]:
    """Direct children of a process (Linux /proc)."""
    out: set[int] = set()
    try:
        for tid in os.listdir(f"/proc/{pid}/task"):
            with open(f"/proc/{pid}/task/{tid}/children") as f:
                out.update(int(c) for c in f.read().split())
    except FileNotFoundError:
        pass
    return out


def is_running(pid: int) -> bool:
    """True if the pid exists and is not a zombie."""
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().rsplit(")", 1)[1].split()[0] != "Z"
    except (FileNotFoundError, ProcessLookupError):
        return False


# Field names that would mean a command addresses particles one by one (the coordinator sends parameters only).
PER_PARTICLE = {
    "id",
    "ids",
    "agent",
    "agents",
    "agent_id",
    "particle",
    "particles",
    "position",
    "positions",
    "velocity",
    "velocities",
    "assignment",
    "assignments",
    "state",
    "states",
}


def field_names(obj) -> set[str]:
    """Every key of a JSON value, at any depth (what a command carries, not what it says)."""
    if isinstance(obj, dict):
        return set(obj).union(*(field_names(v) for v in obj.values()))
    if isinstance(obj, list):
        return set().union(*(field_names(v) for v in obj))
    return set()


def wait_until(condition, timeout: float, every: float = 0.02) -> bool:
    """Poll `condition()` until it holds (True) or `timeout` s pass (False): for a state that has no callback."""
    deadline = time.monotonic() + timeout
    while not condition():
        if time.monotonic() >= deadline:
            return False
        time.sleep(every)
    return True


def wait_for_live_step(port: int, step: int, timeout: float = 60.0) -> int:
    """Wait until the recorder's live view (Foxglove WebSocket on 127.0.0.1:`port`, `--live`) streams the
    swarm's state at `step` or later, and return the step seen: the event "the run is stepping and being
    recorded", instead of a fixed sleep."""
    deadline = time.monotonic() + timeout
    client = FoxgloveClient(f"ws://127.0.0.1:{port}", timeout=timeout)
    try:
        client.subscribe(client.channel("state")["id"])
        while True:
            left = deadline - time.monotonic()
            if left <= 0:
                raise TimeoutError(f"no live state at step {step} or later within {timeout:.0f} s")
            got = client.message(timeout=left)
            if got is not None and (seen := json.loads(got[2])["fluidswarm"]["step"]) >= step:
                return seen
    finally:
        client.close()


def wait_recorded_steps(mcap, steps: int, proc, timeout: float) -> None:
    """Until the MCAP being written at `mcap` (a Path, or a callable returning it or None) holds `steps` steps
    (the recorder flushes every 0.5 s; read while it is written); fails if `proc` (the run writing it) ends or
    `timeout` s pass first."""
    from fluidswarm.recording.reader import load_run

    def recorded() -> bool:
        path = mcap() if callable(mcap) else mcap
        try:
            return path is not None and path.exists() and len(load_run(path, images=False).frames) >= steps
        except Exception:  # noqa: BLE001  # a file still being written: only its header yet
            return False

    deadline = time.monotonic() + timeout
    while not recorded():
        assert time.monotonic() < deadline and proc.poll() is None, f"the run never recorded {steps} steps"
        time.sleep(0.5)
