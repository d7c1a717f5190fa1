"""Recording and analysis of runs: the MCAP writer and reader, the imitation-fidelity score, `replay`.

Modules, one job each:
- `fidelity`  — the imitation-fidelity score (IoU, inside, coverage) of a formation against a silhouette.
- `skeleton`  — Zhang-Suen thinning, used by the coverage term of the score.
- `schemas`   — the Foxglove well-known JSON schemas and the packed per-particle layout.
- `writer`    — `RunWriter`, the one thin MCAP writer the recorder process calls.
- `live`      — `LiveServer`, the Foxglove WebSocket server that shows a run as it happens (`--live`).
- `reader`    — `load_run` and the completeness `check`.
- `analysis`  — the per-step series the thesis plots (velocity per class, pressure, spacing).
- `render`    — PNG snapshots, the GIF and the plots.
- `replay`    — the `fluidswarm replay` command's work; `commands` registers it.
"""
