"""Recording and analysis of runs: the MCAP writer and reader, what `fluidswarm replay` renders (its command and
its work are the command line's: fluidswarm/replay_command.py, fluidswarm/replay.py; the imitation-fidelity score it
reports is coordinator/control/fidelity.py, the Zhang-Suen thinning behind it perception/skeleton.py).

Modules, one job each:
- `schemas`   — the Foxglove well-known JSON schemas and the packed per-particle layout.
- `messages`  — the Foxglove message of each topic, built and validated from plain arrays.
- `writer`    — `RunWriter`, the one thin MCAP writer the recorder process calls.
- `recorder`  — the recorder process; `steps` — what it does with each message (states grouped by step).
- `ros2_messages`, `ros2_bridge` — the run as standard ROS 2 messages, published live by the recorder (`--ros2`).
- `live`      — `LiveServer`, the Foxglove WebSocket server that shows a run as it happens (`--live`).
- `reader`    — `load_run` and the completeness `check`.
- `analysis`  — the per-step series the thesis plots (velocity per class, pressure, spacing).
- `render`    — PNG snapshots, the GIF and the plots.
"""
