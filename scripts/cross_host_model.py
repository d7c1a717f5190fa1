#!/usr/bin/env python3
"""A model of the state messages that cross router links in an imitation split over hosts, and what the best
cut of the swarm could save (issue 37 item 2, docs/multi-host.md "What a cut can save").

What crosses, as the agents and routers do it (agent/native/src/agent.rs, keys.rs, relay.rs): every step an
agent's state is put on the key of its cell (side h); an agent subscribes to the cells that meet the disc of
radius r_sub = 2h + 10 v_max dt around it (and lets a cell go only beyond r_sub + h/2); a router forwards a
state once over each link towards a router whose clients subscribe to its cell. The hosts are a star: the
workers' routers connect to the main host's (share 0), so a state from one worker to another crosses two
links. Per step, summed over the directed links:

    messages = sum_i sum_{links l leaving the route of i} [some host behind l subscribes cell(i)]

The swarm's positions come from the numpy oracle following the imitation's command (agent/sph/reference.py,
as fluidswarm/orchestration/share_layout.py), every step of a run of the routers' measured length. The model is checked
against the counts of scripts/imitation_traffic.py and then asked what other cuts would send: regions of the
start layout and of the formation (what `--shares start|formation` do), ranges of ids (`--shares ids`), and,
for comparison only, the best of some 300 balanced straight cuts of the formation (chosen on every 25th step
of the same track, so it is an optimistic bound) and the ids shuffled (what the issue took id ranges to be).

    python scripts/cross_host_model.py [--agents 180] [--hosts 3] [--steps 470]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from agent.sph.reference import VectorisedDriver
from agent.sph.regions import central_first, part_labels, regions
from coordinator.control.imitation_setup import prepare
from coordinator.control.route import followers_for
from perception.io import load_image

PHOTO = Path(__file__).resolve().parents[1] / "scenarios" / "inputs" / "digit2_IMG_1140.JPG"


def track(setup, command, steps: int) -> np.ndarray:
    """(steps + 1, n, 2) positions of the oracle following `command`, in `setup`'s order."""
    driver = VectorisedDriver(setup.ids, setup.states, followers_for(command, setup.ids), setup.params, setup.robot)
    back = np.empty(len(setup.ids), dtype=int)
    back[np.argsort(np.asarray(setup.ids), kind="stable")] = np.arange(len(setup.ids))
    out = [driver.states[back, :2].copy()]
    for _ in range(steps):
        driver.step()
        out.append(driver.states[back, :2].copy())
    return np.array(out)


def subscribed_cells(pos: np.ndarray, radius: float, cell: float) -> set[tuple[int, int]]:
    """The cells of side `cell` meeting a disc of `radius` around any of `pos` (n, 2) (keys.rs covering_cells)."""
    out: set[tuple[int, int]] = set()
    k = int(np.ceil(radius / cell)) + 1
    for x, y in pos:
        cx, cy = int(np.floor(x / cell)), int(np.floor(y / cell))
        for ix in range(cx - k, cx + k + 1):
            dx = max(ix * cell - x, 0.0, x - (ix + 1) * cell)
            for iy in range(cy - k, cy + k + 1):
                dy = max(iy * cell - y, 0.0, y - (iy + 1) * cell)
                if dx * dx + dy * dy <= radius * radius:
                    out.add((ix, iy))
    return out


def messages_per_step(pos: np.ndarray, label: np.ndarray, hosts: int, radius: float, cell: float) -> int:
    """State messages crossing the star's links in one step: host 0 the hub, `label[i]` agent i's host."""
    subs = [subscribed_cells(pos[label == h], radius, cell) for h in range(hosts)]
    count = 0
    for (x, y), h in zip(pos, label, strict=True):
        c = (int(np.floor(x / cell)), int(np.floor(y / cell)))
        wanted = [g != h and c in subs[g] for g in range(hosts)]
        if h == 0:
            count += sum(wanted)  # hub -> each worker that subscribes
        else:
            others = [g for g in range(1, hosts) if g != h and wanted[g]]
            count += int(wanted[0] or bool(others))  # worker -> hub, once, if anyone beyond wants it
            count += len(others)  # hub -> each other worker that subscribes
    return count


def straight_cuts(at: np.ndarray, m: int) -> list[list[np.ndarray]]:
    """Balanced cuts of `at` (n, 2) by straight lines: m bands across every 10 degrees, and, for three hosts, a
    third cut off across every 15 degrees with the rest halved across every 15 degrees (both ends)."""
    n = len(at)
    out = []
    for th in np.radians(np.arange(0, 180, 10)):
        proj = at @ np.array([np.cos(th), np.sin(th)])
        out.append([np.sort(x) for x in np.array_split(np.argsort(proj, kind="stable"), m)])
    if m == 3:
        for th1 in np.radians(np.arange(0, 180, 15)):
            o = np.argsort(at @ np.array([np.cos(th1), np.sin(th1)]), kind="stable")
            for one, rest in ((o[: n // 3], o[n // 3 :]), (o[-(n // 3) :], o[: -(n // 3)])):
                for th2 in np.radians(np.arange(0, 180, 15)):
                    o2 = rest[np.argsort(at[rest] @ np.array([np.cos(th2), np.sin(th2)]), kind="stable")]
                    out.append([np.sort(one), np.sort(o2[: len(o2) // 2]), np.sort(o2[len(o2) // 2 :])])
    return out


def main(argv: list[str]) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--agents", type=int, default=180)
    ap.add_argument("--hosts", type=int, default=3)
    ap.add_argument("--steps", type=int, default=470, help="steps of the run (the routers' runs: ~470)")
    ap.add_argument("--every", type=int, default=5, help="model every k-th step")
    ap.add_argument("--photo", type=Path, default=PHOTO)
    args = ap.parse_args(argv)
    im = prepare(load_image(args.photo), args.agents)
    setup = im.setup
    p = setup.params
    d = p.max_step_displacement
    r_sub = p.support + 10.0 * d
    n, m = len(setup.ids), args.hosts
    path = track(setup, im.command, args.steps)
    ahead = path[min(300, args.steps)]
    by_id = np.argsort(np.asarray(setup.ids), kind="stable")
    rng = np.random.default_rng(0)
    cuts = {
        "id ranges (--shares ids)": np.array_split(by_id, m),
        "regions of the start layout (--shares start)": regions(path[0], m),
        "regions of the formation ahead (default)": regions(ahead, m),
        "shuffled ids in ranges (the issue's picture)": np.array_split(rng.permutation(n), m),
    }
    rough = path[:: 25 * max(1, args.every // 5)]
    r_mid = r_sub + 0.25 * p.h

    def rough_cost(parts: list[np.ndarray]) -> float:
        label = part_labels(central_first(ahead, parts, float(p.support)), n)
        return float(np.mean([messages_per_step(q, label, m, r_mid, p.h) for q in rough]))

    cuts[f"best of {len(straight_cuts(ahead, m))} straight cuts of the formation ahead"] = min(
        straight_cuts(ahead, m), key=rough_cost
    )
    print(
        f"{n} agents, {m} hosts (a star), {args.steps} steps, h={p.h:g} r_sub={r_sub:g} "
        f"(cells kept to {r_sub + 0.5 * p.h:g})"
    )
    print("| cut | messages per step, r_sub | r_sub + h/2 | × id ranges |")
    print("| --- | --- | --- | --- |")
    base = None
    for name, parts in cuts.items():
        at = ahead if "formation" in name else path[0]  # what fluidswarm/orchestration/run.py hands central_first
        label = part_labels(central_first(at, parts, float(p.support)), n)
        lo = np.mean([messages_per_step(path[s], label, m, r_sub, p.h) for s in range(0, len(path), args.every)])
        hi = np.mean(
            [messages_per_step(path[s], label, m, r_sub + 0.5 * p.h, p.h) for s in range(0, len(path), args.every)]
        )
        base = base or (lo + hi) / 2
        print(f"| {name} | {lo:.1f} | {hi:.1f} | {(lo + hi) / 2 / base:.2f} |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
