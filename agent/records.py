"""The compiled boundary records, agent._native (agent/native/python, PyO3): the one implementation of every
record that crosses a process boundary, shared with the agent program (the agent crate, agent/native/src).

The protocol modules (agent/protocol/*, agent/fill.py, coordinator/control/route.py) are typed wrappers of it.
A source tree that was not built has no agent._native: importing it is then one line saying how to build it,
not a traceback (the build: `make install`, or `pip install .`, setuptools-rust).
"""

from __future__ import annotations

try:
    from agent import _native as native
except ImportError as exc:
    raise SystemExit(
        f"fluidswarm: the compiled records module agent._native is not built here ({exc}): "
        "run `make install` (or `pip install .`) in the source tree"
    ) from None

__all__ = ["native"]
