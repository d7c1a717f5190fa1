"""A short property run of every Python decoder's fuzz target (fuzz/python_targets.py), in `make test`: random
bytes and mutations of the fuzz seeds (fuzz/seeds.py), a bounded number of examples each (seconds in all),
derandomised so a failure is reproducible. `make fuzz` runs the same targets coverage-guided for minutes
(docs/benchmarks/fuzz.md). And every input a decoder once failed on (tests/vectors/fuzz/python_<target>/, each
file one input, named for what went wrong) passes now."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "fuzz"))

import python_targets
import seeds

EXAMPLES = {"mcap": 40, "scenario": 100, "users": 100}  # file-backed targets cost more per input
FOUND = sorted((REPO / "tests" / "vectors" / "fuzz").glob("python_*/*"))


@st.composite
def mutated(draw, pool: list[bytes]) -> bytes:
    """A seed with a few bytes replaced, inserted or deleted: near-valid inputs reach past the first check."""
    data = bytearray(draw(st.sampled_from(pool)))
    for _ in range(draw(st.integers(0, 6))):
        at = draw(st.integers(0, len(data)))
        op = draw(st.sampled_from("rid"))
        if op == "r" and at < len(data):
            data[at] = draw(st.integers(0, 255))
        elif op == "i":
            data[at:at] = draw(st.binary(min_size=1, max_size=8))
        else:
            del data[at : at + draw(st.integers(1, 16))]
    return bytes(data)


@pytest.mark.parametrize("name", sorted(seeds.PYTHON))
def test_seeds_pass(name):
    """The seeds are valid inputs: each target accepts them without an invariant failing (and the target's
    checks are live: a seed the decoder refuses would show here as a refusal, not pass silently)."""
    target, pool = python_targets.TARGETS[name], seeds.PYTHON[name]()
    assert pool
    for s in pool:
        target(s)


@pytest.mark.parametrize("name", sorted(seeds.PYTHON))
def test_random_and_mutated_inputs(name):
    target, pool = python_targets.TARGETS[name], seeds.PYTHON[name]()

    @settings(
        max_examples=EXAMPLES.get(name, 150),
        deadline=None,
        derandomize=True,
        database=None,
        suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
    )
    @given(st.one_of(st.binary(max_size=300), mutated(pool)))
    def run(data):
        target(data)

    run()


@pytest.mark.parametrize("path", FOUND, ids=lambda p: f"{p.parent.name}/{p.name}")
def test_found_inputs_pass_now(path):
    python_targets.TARGETS[path.parent.name.removeprefix("python_")](path.read_bytes())


def teardown_module():
    python_targets.cleanup()
