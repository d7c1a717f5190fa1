"""`fluidswarm imitate` end to end (perception -> coordinator process -> agent processes -> MCAP) on real
pictures: a V sign splits into two branches, one finger gives one elongated branch, a Weizmann two-hand
wave with the arms sideways gives arm-class particles on both sides of the torso."""

from __future__ import annotations

import json
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pytest

from coordinator.control.imitation_setup import imitation_of_input
from coordinator.control.route import class_of
from fluidswarm.recording.reader import load_run

pytestmark = pytest.mark.swarm  # starts agents, routers or the CLI (tests/conftest.py)

REPO = Path(__file__).resolve().parent.parent
WAVE2 = REPO / "scenarios" / "inputs" / "weizmann_wave2_person0.png"  # = shared weizmann-actions-64/wave2/person0.png
WAVE2_SIDEWAYS = 14  # perception/data/weizmann_wave2_labels.json: person0 frames 14, 16 have the arms sideways


def imitate(path: Path, out: Path, agents: int, steps: int, *extra: str):
    r = subprocess.run(
        [
            sys.executable,
            "-m",
            "fluidswarm",
            "imitate",
            str(path),
            "--agents",
            str(agents),
            "--steps",
            str(steps),
            "--out",
            str(out),
            "--json",
            *extra,
        ],
        capture_output=True,
        text=True,
        timeout=300,
        cwd=REPO,
    )
    assert r.returncode == 0, r.stderr[-3000:]
    record = json.loads(r.stdout)  # the whole of stdout: one JSON object
    assert record["kind"] == "imitation" and record["finished"] == agents
    run = load_run(record["mcap"], images=False)
    last = run.frames[-1]
    assert len(last.ids) == agents
    # The file keeps its own score (metadata `fidelity`): the same figures the command gave.
    for key, field in (("fidelity_iou", "iou"), ("nn_cv", "nn_cv")):
        assert abs(run.fidelity[key] - record["fidelity"][field]) <= 1e-4, (key, run.fidelity, record["fidelity"])
    order = np.argsort(last.ids)
    return last.ids[order], last.positions[order], record["fidelity"]


def branches(positions: np.ndarray, split_y: float, gap: float = 1.5) -> tuple[int, float]:
    """Groups of the particles above split_y along x (a gap wider than `gap` m separates two): (count, widest gap)."""
    xs = np.sort(positions[positions[:, 1] > split_y, 0])
    if len(xs) < 2:
        return len(xs), 0.0
    gaps = np.diff(xs)
    return 1 + int(np.sum(gaps > gap)), float(gaps.max())


@pytest.fixture(scope="module")
def imitations(request, tmp_path_factory, shared_image):
    """The `imitate` runs of the module's selected tests, side by side (they count steps, not seconds; each
    keeps about one of the two cores busy): name -> future of imitate()'s (ids, positions, fidelity)."""
    out = tmp_path_factory.mktemp("imitate")
    runs = {
        "v": (shared_image(2), out / "v", 60, 500),
        "one": (shared_image(1), out / "one", 40, 450),
        "wave": (WAVE2, out / "wave", 48, 450, "--frame", str(WAVE2_SIDEWAYS), "--controller", "region"),
    }
    needs = {
        "test_v_sign_two_branches_and_one_finger_one_elongated_branch": ("v", "one"),
        "test_wave2_arms_sideways_arm_classes_left_and_right_of_the_torso": ("wave",),
    }
    selected = {
        name
        for item in request.session.items
        if item.module is request.module
        for name in needs.get(item.originalname, ())
    }
    with ThreadPoolExecutor(len(runs)) as pool:
        yield {name: pool.submit(imitate, *args) for name, args in runs.items() if name in selected}


def top_third_y(image, agents: int) -> float:
    """The domain y of the hand's top third (image rows), where a V's fingers have separated, mapped with the
    transform of the run's own input."""
    im = imitation_of_input(image, agents)
    rows = np.nonzero(im.mask.any(axis=1))[0]
    return float(im.transform.to_domain(np.array([0.0, rows.min() + 0.3 * (rows.max() - rows.min())]))[1])


def test_v_sign_two_branches_and_one_finger_one_elongated_branch(imitations, shared_image):
    _ids, pos2, fig2 = imitations["v"].result()
    top_y = top_third_y(shared_image(2), 60)
    n2, gap2 = branches(pos2, top_y)
    _ids, pos1, fig1 = imitations["one"].result()
    top1 = top_third_y(shared_image(1), 40)
    n1, _gap1 = branches(pos1, top1)
    extent = np.ptp(pos1, axis=0)
    print(
        f"V: {n2} branches above y={top_y:.1f} m, widest gap {gap2:.2f} m, iou {fig2['iou']}; "
        f"one finger: {n1} branch above y={top1:.1f} m, extent x {extent[0]:.1f} m, y {extent[1]:.1f} m, "
        f"iou {fig1['iou']}"
    )
    assert n2 == 2 and gap2 > 1.5
    assert n1 == 1 and extent[1] > 1.5 * extent[0]  # one elongated (upright) branch over the palm
    assert fig2["iou"] >= 0.7 and fig1["iou"] >= 0.7


def test_wave2_arms_sideways_arm_classes_left_and_right_of_the_torso(imitations):
    # The region controller (thesis ch. 6): torso and arm classes with routes through the shoulders.
    ids, pos, fig = imitations["wave"].result()
    im = imitation_of_input(WAVE2, 48, "region", WAVE2_SIDEWAYS)
    assert im.observation.kind == "body" and im.observation.label == "left_side-right_side"
    shares = [c.share for c in im.command.classes]
    names = [im.command.classes[class_of(int(i), 48, shares)].name for i in ids]
    part = np.array([n.rstrip("0123456789") for n in names])
    torso = pos[part == "torso"]
    left, right = pos[part == "left_arm"], pos[part == "right_arm"]
    assert len(left) >= 2 and len(right) >= 2 and len(torso) >= 10
    # the torso column: its particles' x extent around the torso centre
    t_lo, t_hi = np.percentile(torso[:, 0], [10, 90])
    ty = np.median(torso[:, 1])
    print(
        f"torso x [{t_lo:.1f}, {t_hi:.1f}] m; left arm x {np.round(left[:, 0], 1)}; "
        f"right arm x {np.round(right[:, 0], 1)}; "
        f"arm heights {np.median(left[:, 1]):.1f}/{np.median(right[:, 1]):.1f} m vs torso {ty:.1f} m; iou {fig['iou']}"
    )
    assert np.all(left[:, 0] < t_lo) and np.all(right[:, 0] > t_hi)
    # sideways: the arms reach out at least as far as the torso is wide, above the torso's middle
    width = t_hi - t_lo
    assert t_lo - left[:, 0].min() > 0.5 * width and right[:, 0].max() - t_hi > 0.5 * width
    assert np.median(left[:, 1]) > ty and np.median(right[:, 1]) > ty
    assert fig["iou"] >= 0.45
