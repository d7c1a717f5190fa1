"""Sweep the fill zones' material (beta, mu) with the reference solver (no processes; docs/fill.md).

    .venv/bin/python scripts/fill_materials.py hand 2,0.2 5,1.0 50,0.2
    .venv/bin/python scripts/fill_materials.py body 2,0.2 20,1.0

hand: photos 1 and 4 (sorted by name) of every class 0-9 of ../shared/datasets/sign-language-digits, the
fingers' zones; body: six Weizmann frames (wave1, wave2, jack), the arms' zones. 60 particles, 500 steps of
the vectorised reference driver; prints mean / min IoU and mean / max nn_cv per material.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import coordinator.control.imitation_setup as setup_module
from agent.sph.particle import X, Y
from agent.sph.reference import VectorisedDriver
from coordinator.control.fidelity import fidelity
from coordinator.control.route import followers_for

SHARED = ROOT.parent / "shared" / "datasets"
BODY_FRAMES = (("wave1", 0, 20), ("wave2", 0, 14), ("wave2", 2, 20), ("jack", 0, 10), ("jack", 2, 15), ("wave1", 3, 18))


def inputs(kind: str) -> list[tuple[Path, int]]:
    if kind == "hand":
        digits = SHARED / "sign-language-digits"
        return [(sorted((digits / str(c)).iterdir())[k], 0) for c in range(10) for k in (0, 3)]
    return [(SHARED / "weizmann-actions-64" / a / f"person{p}.png", f) for a, p, f in BODY_FRAMES]


def main() -> int:
    if len(sys.argv) < 3 or sys.argv[1] not in ("hand", "body"):
        print("usage: fill_materials.py hand|body BETA,MU [BETA,MU ...]", file=sys.stderr)
        return 2
    for text in sys.argv[2:]:
        beta, mu = map(float, text.split(","))
        # the zones' material is a module constant of the fill controller: set it for this sweep only
        setup_module.FINGER_BETA = setup_module.ARM_BETA = beta
        setup_module.FINGER_MU = setup_module.ARM_MU = mu
        ious, cvs, t = [], [], time.perf_counter()
        for path, frame in inputs(sys.argv[1]):
            im = setup_module.imitation_of_input(path, 60, frame=frame)
            s = im.setup
            out = VectorisedDriver(s.ids, s.states, followers_for(im.command, s.ids), s.params).run(500)
            f = fidelity(im.mask, im.transform, out[:, [X, Y]])
            ious.append(f.iou)
            cvs.append(f.nn_cv)
        print(
            f"{sys.argv[1]} beta={beta} mu={mu}: mean iou {np.mean(ious):.4f} min {np.min(ious):.4f} "
            f"mean nn_cv {np.mean(cvs):.3f} max {np.max(cvs):.3f} ({time.perf_counter() - t:.0f} s)",
            flush=True,
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
