"""The fill controller on the shared hand photos: one real imitation (native agent processes) per photo.

    .venv/bin/python scripts/fill_table.py [--per-class 5] [--agents 60] [--controller fill] > docs/benchmarks/fill_table.txt

For the first `--per-class` photos (sorted by name) of every class 0-9 of
../shared/datasets/sign-language-digits, runs `fluidswarm imitate` in-process and prints one row per photo
(fidelity_iou, fidelity_inside, nn_cv, simulated and wall time to settle), then the mean and the extremes.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from coordinator.imitate import imitate  # noqa: E402

DATA = ROOT.parent / "shared" / "datasets" / "sign-language-digits"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--per-class", type=int, default=5)
    ap.add_argument("--agents", type=int, default=60)
    ap.add_argument("--controller", default="fill")
    ap.add_argument("--data", type=Path, default=DATA)
    args = ap.parse_args()
    if not args.data.is_dir():
        print(f"fill_table: --data {args.data}: not a directory", file=sys.stderr)
        return 2
    rows = []
    print(f"# {args.controller} controller, {args.agents} agent processes, first {args.per_class} photos per class "
          f"({time.strftime('%Y-%m-%d')})")
    print(f"{'class':>5} {'photo':<14} {'iou':>6} {'inside':>6} {'nn_cv':>6} {'form_s':>6} {'wall_s':>6} settled")
    for cls in sorted(p.name for p in args.data.iterdir() if p.is_dir()):
        for photo in sorted((args.data / cls).glob("*.JPG"))[: args.per_class]:
            with tempfile.TemporaryDirectory() as out:
                t = time.perf_counter()
                res = imitate(str(photo), agents=args.agents, out=out, controller=args.controller, name="photo")
                wall = time.perf_counter() - t
            f = res.fidelity
            rows.append((f.iou, f.inside, f.nn_cv, res.formation_seconds, wall))
            print(f"{cls:>5} {photo.name:<14} {f.iou:6.3f} {f.inside:6.3f} {f.nn_cv:6.3f} "
                  f"{res.formation_seconds:6.2f} {wall:6.1f} {'yes' if res.settled else 'no'}", flush=True)
    r = np.array(rows)
    print(f"photos={len(r)}")
    print(f"mean_fidelity_iou={r[:, 0].mean():.4f}")
    print(f"min_fidelity_iou={r[:, 0].min():.4f}")
    print(f"min_fidelity_inside={r[:, 1].min():.4f}")
    print(f"mean_nn_cv={r[:, 2].mean():.4f}")
    print(f"max_nn_cv={r[:, 2].max():.4f}")
    print(f"mean_formation_seconds={r[:, 3].mean():.2f}")
    print(f"max_wall_seconds={r[:, 4].max():.1f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
