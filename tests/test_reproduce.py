"""`python -m research reproduce --quick` (research/, outside the wheel): the thesis' claims re-measured, written as a
report with plots."""

import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from agent.sph.reference import PerParticleDriver
from agent.sph.setups import spread_block
from research.reproduce.allpairs import AllPairsDriver

REPO = Path(__file__).resolve().parents[1]  # research/ is run from a checkout: `python -m research`


@pytest.mark.swarm
def test_quick_reproduction_writes_a_row_with_numbers_per_claim(tmp_path):
    r = subprocess.run(
        [sys.executable, "-m", "research", "reproduce", "--quick", "--out", str(tmp_path)],
        cwd=REPO,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert r.returncode == 0, r.stderr
    report = (tmp_path / "thesis-reproduction.md").read_text()
    rows = [line for line in report.splitlines() if line.startswith("| ") and not line.startswith("| where")]
    assert len(rows) >= 30
    for row in rows:
        cells = [c.strip() for c in re.split(r"(?<!\\)\|", row)[1:-1]]
        assert len(cells) == 7, row
        assert re.search(r"\d", cells[3]), f"no number in 'ours': {row}"
        assert cells[4] in ("**agree**", "**disagree**", "**not comparable**"), row
    # Every group's plots exist and are PNGs.
    pngs = re.findall(r"\]\((reproduction/[^)]+\.png)\)", report)
    assert len(pngs) >= 8
    for p in pngs:
        assert (tmp_path / p).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    counts = dict(line.split("=") for line in r.stdout.splitlines() if "=" in line)
    assert int(counts["agree"]) + int(counts["disagree"]) + int(counts["not_comparable"]) == len(rows)


@pytest.mark.swarm
def test_bad_out_is_one_line_error(tmp_path):
    f = tmp_path / "file.txt"
    f.write_text("x")
    r = subprocess.run(
        [sys.executable, "-m", "research", "reproduce", "--quick", "--out", str(f)],
        cwd=REPO,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert r.returncode == 1 and "Traceback" not in r.stderr and len(r.stderr.strip().splitlines()) == 1
    assert r.stderr.startswith(f"python -m research reproduce: error: --out {f}: not a folder"), r.stderr


def test_independent_all_pairs_equations_match_the_agent_step():
    """The per-particle step (what every agent runs) against the thesis' equations written again, all pairs."""
    s = spread_block(36)
    ref = PerParticleDriver(s.ids, s.states, s.controls, s.params)
    for k in range(20):
        before = ref.states.copy()
        ref.step()
        ap = AllPairsDriver(before, s.controls, s.params)
        ap.step_index = k
        ap.step()
        assert np.abs(ap.states - ref.states).max() < 1e-10
    # The thesis' two-exchange flow (Fig. 3.5) is a different scheme: it must not match.
    ap = AllPairsDriver(before, s.controls, s.params, lag="none")
    ap.step()
    assert np.abs(ap.states - ref.states).max() > 1e-6
