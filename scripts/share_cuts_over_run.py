#!/usr/bin/env python3
"""Neighbour pairs that a cut between hosts separates over a whole recorded imitation, for several ways of
cutting the same swarm into shares (issue 37 item 2, docs/multi-host.md): id ranges, regions of the start
layout (what `--workers` gives), and regions of where the swarm is later (its mean, middle and final positions:
what a plan could aim at if it knew the formation ahead). Pure: reads an MCAP of the imitation of PICTURE with N
agents (e.g. tests/test_workers_netns.py's whole run), no swarm.

    python scripts/share_cuts_over_run.py RUN.mcap PICTURE N [HOSTS]
"""

from __future__ import annotations

import sys

import numpy as np
from scipy.spatial import cKDTree

from agent.sph.regions import part_labels, regions
from coordinator.control.imitation_setup import prepare
from fluidswarm.recording.reader import load_run
from perception.io import load_image


def main(argv: list[str]) -> int:
    path, picture, n = argv[0], argv[1], int(argv[2])
    hosts = int(argv[3]) if len(argv) > 3 else 3
    setup = prepare(load_image(picture), n).setup
    support = float(setup.params.support)
    order = np.argsort(setup.ids)
    start = setup.states[order, :2]
    frames = [f for f in load_run(path, images=False).frames if len(f.ids) == n]
    track = np.array([np.asarray(f.positions)[np.argsort(f.ids), :2] for f in frames])  # (steps, n, 2), by id
    cuts = {
        "id ranges": part_labels(np.array_split(np.arange(n), hosts), n),
        "regions of the start layout": part_labels(regions(start, hosts), n),
        "regions of the mean position": part_labels(regions(track.mean(axis=0), hosts), n),
        "regions of the middle step": part_labels(regions(track[len(track) // 2], hosts), n),
        "regions of the final positions": part_labels(regions(track[-1], hosts), n),
    }
    crossing = dict.fromkeys(cuts, 0)
    pairs_seen = 0
    for positions in track[::5]:  # every 5th recorded step
        pairs = cKDTree(positions).query_pairs(support, output_type="ndarray")
        pairs_seen += len(pairs)
        for name, label in cuts.items():
            crossing[name] += int((label[pairs[:, 0]] != label[pairs[:, 1]]).sum())
    print(f"{path}: {n} agents, {hosts} hosts, {len(track)} steps, neighbour pairs within {support:g} m")
    print("| cut | pairs across hosts (every 5th step, summed) | × id ranges | share of all pairs |")
    print("| --- | --- | --- | --- |")
    for name, count in crossing.items():
        print(f"| {name} | {count} | {count / crossing['id ranges']:.2f} | {count / pairs_seen:.2f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
