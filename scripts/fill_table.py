"""The fill controller on shared pictures: one real imitation (native agent processes) per picture.

    .venv/bin/python scripts/fill_table.py hands [--per-class 5] > docs/benchmarks/fill_table.txt
    .venv/bin/python scripts/fill_table.py bodies [--frames-per-clip 2] > docs/benchmarks/fill_body_table.txt

hands: the first `--per-class` photos (sorted by name) of every class 0-9 of
../shared/datasets/sign-language-digits. bodies: every clip of wave1, wave2 and jack (persons 0-6 of
../shared/datasets/weizmann-actions-64) at `--frames-per-clip` frames spread over the clip (at 1/(k+1), ...,
k/(k+1) of its length, so neither the first nor the last, often a resting pose).
Runs `fluidswarm imitate ... --json` as a user would and prints one row per picture (fidelity_iou,
fidelity_inside, nn_cv, simulated time to settle, wall time), then the mean and the extremes.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from fluidswarm.orchestration.run_config import AGENTS
from perception.io import load_frames

SHARED = ROOT.parent / "shared" / "datasets"
ACTIONS = ("wave1", "wave2", "jack")


def hand_inputs(per_class: int) -> list[tuple[str, Path, list[str]]]:
    digits = SHARED / "sign-language-digits"
    return [
        (f"{cls}/{photo.name}", photo, [])
        for cls in sorted(p.name for p in digits.iterdir() if p.is_dir())
        for photo in sorted((digits / cls).glob("*.JPG"))[:per_class]
    ]


def body_inputs(k: int) -> list[tuple[str, Path, list[str]]]:
    out = []
    for action in ACTIONS:
        for clip in sorted((SHARED / "weizmann-actions-64" / action).glob("person*.png")):
            n = len(load_frames(clip))
            out += [
                (f"{action}/{clip.stem} f{f}", clip, ["--frame", str(f)])
                for f in (round(n * (i + 1) / (k + 1)) for i in range(k))
            ]
    return out


def imitate(path: Path, extra: list[str], agents: int) -> tuple[dict, float]:
    with tempfile.TemporaryDirectory() as out:
        t = time.perf_counter()
        r = subprocess.run(
            [
                sys.executable,
                "-m",
                "fluidswarm",
                "imitate",
                str(path),
                *extra,
                "--agents",
                str(agents),
                "--out",
                out,
                "--json",
            ],
            capture_output=True,
            text=True,
            cwd=ROOT,
        )
        wall = time.perf_counter() - t
    if r.returncode != 0:
        raise SystemExit(f"fill_table: {path} {' '.join(extra)}: {r.stderr.strip().splitlines()[-1:]}")
    return json.loads(r.stdout), wall


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("kind", choices=("hands", "bodies"))
    ap.add_argument("--per-class", type=int, default=5)
    ap.add_argument("--frames-per-clip", type=int, default=2)
    ap.add_argument("--agents", type=int, default=AGENTS)
    args = ap.parse_args()
    if not SHARED.is_dir():
        print(f"fill_table: {SHARED}: not a directory (the shared data sets)", file=sys.stderr)
        return 2
    inputs = hand_inputs(args.per_class) if args.kind == "hands" else body_inputs(args.frames_per_clip)
    print(
        f"# fill controller, {args.agents} agent processes, {args.kind}: {len(inputs)} pictures "
        f"({time.strftime('%Y-%m-%d')})"
    )
    print(f"{'picture':<22} {'iou':>6} {'inside':>6} {'nn_cv':>6} {'form_s':>6} {'wall_s':>6} settled")
    rows = []
    for name, path, extra in inputs:
        rec, wall = imitate(path, extra, args.agents)
        f = rec["fidelity"]
        rows.append((f["iou"], f["inside"], f["nn_cv"], rec["formation_seconds"], wall))
        print(
            f"{name:<22} {f['iou']:6.3f} {f['inside']:6.3f} {f['nn_cv']:6.3f} {rec['formation_seconds']:6.2f} "
            f"{wall:6.1f} {'yes' if rec['formation_settled'] else 'no'}",
            flush=True,
        )
    r = np.array(rows)
    print(f"pictures={len(r)}")
    print(f"mean_fidelity_iou={r[:, 0].mean():.4f}")
    print(f"min_fidelity_iou={r[:, 0].min():.4f}")
    print(f"below_0.7={int(np.sum(r[:, 0] < 0.7))}")
    print(f"min_fidelity_inside={r[:, 1].min():.4f}")
    print(f"mean_nn_cv={r[:, 2].mean():.4f}")
    print(f"max_nn_cv={r[:, 2].max():.4f}")
    print(f"mean_formation_seconds={r[:, 3].mean():.2f}")
    print(f"max_wall_seconds={r[:, 4].max():.1f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
