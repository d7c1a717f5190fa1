"""Fill shapes for the command and fill vectors: squares, polygons, the digit-2 photo's command, zones."""

from __future__ import annotations

import dataclasses
import math

import cv2

from agent.protocol.command import Fill, Zone, _canonical
from coordinator.control.imitation_setup import prepare

from .common import PHOTO, body, sign_raw


def fill_list(fill: Fill) -> dict:
    return {
        "rings": [[list(v) for v in ring] for ring in fill.rings],
        "alpha": fill.alpha,
        "s": fill.s,
        "zones": [zone_list(z) for z in fill.zones],
    }


def zone_list(z: Zone) -> list:
    return [z.x, z.y, z.ux, z.uy, z.a, z.b, z.beta, z.mu]


ZONE = {"x": 1.0, "y": 2.0, "ux": 0.6, "uy": 0.8, "a": 3.0, "b": 1.5, "beta": 20.0, "mu": 1.0}


def square(x0, y0, side) -> list:
    return [[x0, y0], [x0 + side, y0], [x0 + side, y0 + side], [x0, y0 + side]]


def polygon(n: int, cx=0.0, cy=0.0, radius=10.0) -> list:
    """A regular n-gon, vertices rounded to 0.1 mm as the coordinator writes them."""
    return [
        [round(cx + radius * math.cos(2 * math.pi * k / n), 4), round(cy + radius * math.sin(2 * math.pi * k / n), 4)]
        for k in range(n)
    ]


def photo_command(n_agents: int = 16):
    """The fill command the coordinator makes for the digit-2 photo, its zones rounded to 1e-9.

    The zones are ellipse fits (numpy's linear algebra): their last digits follow the BLAS kernel the CPU
    picks, so unrounded they made the vectors differ from machine to machine. The vectors test the codec and
    the follower, not the fit's last bit."""
    command = prepare(cv2.imread(str(PHOTO)), n_agents).command
    assert command.fill is not None
    zones = tuple(Zone(*(round(v, 9) for v in zone_list(z))) for z in command.fill.zones)
    return dataclasses.replace(command, fill=dataclasses.replace(command.fill, zones=zones))


def fill(**changes) -> dict:
    f = {"rings": [square(0.0, 0.0, 10.0)], "alpha": 80.0, "s": 0.2}
    f.update(changes)
    return f


def raw_fill(text: bytes) -> bytes:
    """The standard body with a fill whose first vertex's x is `text` verbatim, signed over those bytes."""
    b = _canonical(body(fill=fill(rings=[[["@@", 0.0], [10.0, 0.0], [10.0, 10.0]]])))
    assert b.count(b'"@@"') == 1
    return sign_raw(b.replace(b'"@@"', text))
