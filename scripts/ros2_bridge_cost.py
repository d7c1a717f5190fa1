"""CPU of the ROS 2 bridge's work for one step of N agents: the four step messages built and serialised
(fluidswarm/recording/ros2_bridge.py `_publish`), puts captured, no session (docs/ros2.md "Cost").

    .venv/bin/python scripts/ros2_bridge_cost.py N [REPEATS]
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))


class _Discard:
    def put(self, cdr: bytes) -> None:
        pass


def main() -> int:
    from agent.sph.particle import SPEED
    from fluidswarm.recording import ros2_messages as m
    from fluidswarm.recording.ros2_bridge import Bridge

    n = int(sys.argv[1])
    repeats = int(sys.argv[2]) if len(sys.argv) > 2 else 100
    vals = np.random.default_rng(0).random((n, SPEED + 1))
    ids = np.arange(n)
    pubs = {t.name: _Discard() for t in m.TOPICS}
    bridge = Bridge("tcp/127.0.0.1:1", 0, False, print)
    for _ in range(5):  # the type store's first use builds its serialisers
        bridge._publish(pubs, ("states", 0, 0.1, ids, vals))
    t0 = time.process_time()
    for _ in range(repeats):
        bridge._publish(pubs, ("states", 0, 0.1, ids, vals))
    ms = (time.process_time() - t0) / repeats * 1e3
    print(f"n={n} bridge_ms_per_step={ms:.2f} us_per_agent_step={ms * 1e3 / n:.1f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
