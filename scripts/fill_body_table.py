"""The fill controller on Weizmann body poses: one real imitation (native agent processes) per frame.

    .venv/bin/python scripts/fill_body_table.py [--agents 60] [--frames-per-clip 2] > docs/benchmarks/fill_body_table.txt

For every clip of wave1, wave2 and jack (persons 0-6 of ../shared/datasets/weizmann-actions-64), runs
`fluidswarm imitate CLIP --frame F` at `--frames-per-clip` frames spread over the clip (at 1/(k+1), ...,
k/(k+1) of its length, so neither the first nor the last, often a resting pose) and prints one row per
frame (fidelity_iou, fidelity_inside, nn_cv, simulated time to settle, wall time), then the mean and the
extremes. The command line is what a user types; the figures are read from its `key=value` lines.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from perception.io import load_frames  # noqa: E402

DATA = ROOT.parent / "shared" / "datasets" / "weizmann-actions-64"
ACTIONS = ("wave1", "wave2", "jack")


def imitate(clip: Path, frame: int, agents: int) -> tuple[dict[str, str], float]:
    with tempfile.TemporaryDirectory() as out:
        t = time.perf_counter()
        r = subprocess.run([sys.executable, "-m", "fluidswarm", "imitate", str(clip), "--frame", str(frame),
                            "--agents", str(agents), "--out", out], capture_output=True, text=True, cwd=ROOT)
        wall = time.perf_counter() - t
    if r.returncode != 0:
        raise SystemExit(f"fill_body_table: {clip} --frame {frame}: {r.stderr.strip().splitlines()[-1:]}")
    return dict(line.split("=", 1) for line in r.stdout.split() if "=" in line), wall


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--agents", type=int, default=60)
    ap.add_argument("--frames-per-clip", type=int, default=2)
    ap.add_argument("--data", type=Path, default=DATA)
    args = ap.parse_args()
    if not args.data.is_dir():
        print(f"fill_body_table: --data {args.data}: not a directory", file=sys.stderr)
        return 2
    k = args.frames_per_clip
    print(f"# fill controller, {args.agents} agent processes, {k} frames per clip of {', '.join(ACTIONS)} "
          f"({time.strftime('%Y-%m-%d')})")
    print(f"{'clip':<16} {'frame':>5} {'iou':>6} {'inside':>6} {'nn_cv':>6} {'form_s':>6} {'wall_s':>6} settled")
    rows = []
    for action in ACTIONS:
        for clip in sorted((args.data / action).glob("person*.png")):
            n = len(load_frames(clip))
            for frame in (round(n * (i + 1) / (k + 1)) for i in range(k)):
                f, wall = imitate(clip, frame, args.agents)
                row = (float(f["fidelity_iou"]), float(f["fidelity_inside"]), float(f["nn_cv"]),
                       float(f["formation_seconds"]), wall)
                rows.append(row)
                print(f"{action + '/' + clip.stem:<16} {frame:>5} {row[0]:6.3f} {row[1]:6.3f} {row[2]:6.3f} "
                      f"{row[3]:6.2f} {wall:6.1f} {f.get('formation_settled', '?')}", flush=True)
    r = np.array(rows)
    print(f"frames={len(r)}")
    print(f"mean_fidelity_iou={r[:, 0].mean():.4f}")
    print(f"min_fidelity_iou={r[:, 0].min():.4f}")
    print(f"frames_below_0.7={int(np.sum(r[:, 0] < 0.7))}")
    print(f"min_fidelity_inside={r[:, 1].min():.4f}")
    print(f"mean_nn_cv={r[:, 2].mean():.4f}")
    print(f"max_nn_cv={r[:, 2].max():.4f}")
    print(f"max_wall_seconds={r[:, 4].max():.1f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
