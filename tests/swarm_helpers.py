"""Helpers shared by the tests: process inspection, the field names a command carries."""

from __future__ import annotations

import os


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
PER_PARTICLE = {"id", "ids", "agent", "agents", "agent_id", "particle", "particles", "position", "positions",
                "velocity", "velocities", "assignment", "assignments", "state", "states"}


def field_names(obj) -> set[str]:
    """Every key of a JSON value, at any depth (what a command carries, not what it says)."""
    if isinstance(obj, dict):
        return set(obj).union(*(field_names(v) for v in obj.values()))
    if isinstance(obj, list):
        return set().union(*(field_names(v) for v in obj))
    return set()
