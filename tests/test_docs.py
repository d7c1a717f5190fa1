"""Docs that cannot drift: the README's benchmark figures are written from docs/benchmarks/results.json
(fluidswarm/orchestration/bench_record.py `readme_section`, `fluidswarm bench --readme`), and this fails when they
differ."""

from __future__ import annotations

import copy
import json
from pathlib import Path

import pytest

from agent.protocol.errors import UserError
from fluidswarm.bench import FIT_MAX_N, write_readme
from fluidswarm.orchestration.bench_record import (
    README_BEGIN,
    README_END,
    BenchRecord,
    readme_section,
    with_readme_section,
)

REPO = Path(__file__).resolve().parents[1]
README = REPO / "README.md"
RESULTS = REPO / "docs" / "benchmarks" / "results.json"


def test_the_readme_benchmark_figures_are_the_results_json_ones():
    readme = README.read_text()
    assert readme.count(README_BEGIN) == 1 and readme.count(README_END) == 1
    assert with_readme_section(readme, BenchRecord.load(RESULTS), FIT_MAX_N) == readme, (
        "README.md's benchmark figures differ from docs/benchmarks/results.json: run `fluidswarm bench --readme`"
    )


def test_the_section_says_what_the_record_says():
    d = json.loads(RESULTS.read_text())
    n300 = next(r for r in d["runs"] if r["n"] == 300)
    text = readme_section(BenchRecord.from_dict(d), FIT_MAX_N)
    assert f"| 300 | {n300['steps_per_second']:.1f} | {n300['startup_seconds']:.2f} |" in text
    assert f"start-up of 300 agents ≤ 5 s ({n300['startup_seconds']:.2f}, met)" in text
    slow = copy.deepcopy(d)
    next(r for r in slow["runs"] if r["n"] == 300).update(startup_seconds=7.25, steps_per_second=4.0)
    slow["runs"][-1] = {"n": 1000, "steps": 300, "error": "1000 agents not ready after 180 s"}
    slow["gesture_imitation_seconds"]["cylindrical"] = None
    text = readme_section(BenchRecord.from_dict(slow), FIT_MAX_N)
    assert "| 300 | 4.0 | 7.25 |" in text and "(7.25, **missed**)" in text and "(4.0, **missed**)" in text
    assert "| 1000 | did not finish: 1000 agents not ready after 180 s |" in text
    assert "N = 1000 completes (**it did not**)" in text and "cylindrical failed" in text


def test_bench_readme_rewrites_only_its_section(tmp_path):
    readme = tmp_path / "README.md"
    readme.write_text(f"# title\n\nbefore\n\n{README_BEGIN}\nold figures\n{README_END}\n\nafter\n")
    write_readme(readme, RESULTS)
    text = readme.read_text()
    assert text.startswith("# title\n\nbefore\n\n") and text.endswith(f"{README_END}\n\nafter\n")
    assert "old figures" not in text and readme_section(BenchRecord.load(RESULTS), FIT_MAX_N) in text
    write_readme(readme, RESULTS)
    assert readme.read_text() == text  # written once, the same again


def test_bench_readme_bad_input_is_one_line(tmp_path):
    readme = tmp_path / "README.md"
    readme.write_text("no markers\n")
    with pytest.raises(UserError, match="no benchmark section"):
        write_readme(readme, RESULTS)
    bad = tmp_path / "results.json"
    bad.write_text('{"runs": 3}')
    with pytest.raises(UserError, match="key 'runs'"):
        write_readme(readme, bad)
    with pytest.raises(UserError, match="cannot read"):
        write_readme(readme, tmp_path / "none.json")
    assert readme.read_text() == "no markers\n"
