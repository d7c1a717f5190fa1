#!/usr/bin/env python3
"""Neighbour pairs that cross hosts at the start of an imitation: region shares (agent/sph/regions.py, what
`--workers` gives) against id-range shares, for a picture and swarm sizes (issue 37 item 2, docs/multi-host.md).

A pair within the SPH support 2h of each other at the start exchanges states every step; one whose agents are on
two hosts crosses a router-to-router link. Pure computation on the coordinator's own start layout, no swarm.

    python scripts/share_boundaries.py [PICTURE] [N ...]
"""

from __future__ import annotations

import sys

import numpy as np
from scipy.spatial import cKDTree

from agent.sph.regions import regions
from coordinator.control.imitation_setup import prepare
from perception.io import load_image


def crossing(labels: np.ndarray, pairs: np.ndarray) -> int:
    return int((labels[pairs[:, 0]] != labels[pairs[:, 1]]).sum())


def main(argv: list[str]) -> None:
    picture = argv[0] if argv else "scenarios/inputs/digit2_IMG_1140.JPG"
    sizes = [int(a) for a in argv[1:]] or [90, 180]
    image = load_image(picture)
    print("| agents | hosts | neighbour pairs | across regions | across id ranges | ratio |")
    print("| --- | --- | --- | --- | --- | --- |")
    for n in sizes:
        setup = prepare(image, n).setup
        pos, ids = setup.states[:, :2], np.asarray(setup.ids)
        pairs = cKDTree(pos).query_pairs(float(setup.params.support), output_type="ndarray")
        for m in (2, 3, 4):
            region, by_id = np.empty(n, int), np.empty(n, int)
            for k, part in enumerate(regions(pos, m)):
                region[part] = k
            for k, part in enumerate(np.array_split(np.argsort(ids), m)):
                by_id[part] = k
            r, i = crossing(region, pairs), crossing(by_id, pairs)
            print(f"| {n} | {m} | {len(pairs)} | {r} | {i} | {r / i:.2f} |")


if __name__ == "__main__":
    main(sys.argv[1:])
