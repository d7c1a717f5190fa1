"""The record of one re-measured thesis claim, and of a group of them."""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import Enum
from pathlib import Path


class Verdict(str, Enum):
    """How our measurement compares with the thesis' claim."""

    AGREE = "agree"
    DISAGREE = "disagree"
    NOT_COMPARABLE = "not comparable"


@dataclass(frozen=True)
class Claim:
    """One row of the report.

    where     thesis section / figure / table, e.g. "§4.7, Fig. 4.12"
    claim     what the thesis states, in a few words
    thesis    the thesis' figure (number or relation as printed)
    ours      our measurement, with numbers
    verdict   agree / disagree / not comparable
    why       one sentence: the reason, from the equations or the set-up
    setup     which set-up measured it: "thesis-faithful", "measurable" (a set-up that exposes a relation
              ours hides), or a reading of an ambiguous passage
    """

    where: str
    claim: str
    thesis: str
    ours: str
    verdict: Verdict
    why: str
    setup: str = "thesis-faithful"


@dataclass
class Group:
    """Claims measured together, the notes that explain their set-ups, and their plots (PNG paths)."""

    title: str
    claims: list[Claim] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    plots: list[tuple[Path, str]] = field(default_factory=list)  # (path, caption)


@dataclass(frozen=True)
class Context:
    """What every group needs: the reduced set or the full one, and where plots go.

    quick      CI mode: fewer particles and steps, the slow groups reduced (under a minute in all)
    image_dir  folder for the comparison PNGs (created on demand)
    """

    quick: bool
    image_dir: Path

    def steps(self, full: int, quick: int) -> int:
        return quick if self.quick else full
