"""A short property run of every Python decoder's fuzz target (fuzz/python_targets.py), in `make test`: random
bytes and mutations of the fuzz seeds (fuzz/seeds.py), a bounded number of examples each (seconds in all),
derandomised so a failure is reproducible. `make fuzz` runs the same targets coverage-guided for minutes
(docs/benchmarks/fuzz.md). And every input a decoder once failed on (tests/vectors/fuzz/python_<target>/, each
file one input, named for what went wrong) passes now."""

from __future__ import annotations

import io
import sys
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "fuzz"))

import python_targets
import seeds

from agent.protocol.access import AuthFileError, parse_users, read_users_file
from agent.protocol.errors import UserError
from fluidswarm.recording.reader import completeness, load_run, read_run
from fluidswarm.scenario import load_scenario, parse_scenario

EXAMPLES = {"mcap": 40, "scenario": 100, "users": 100}  # the costlier targets per input


def bounded(examples: int):
    """Hypothesis settings of these tests: `examples` inputs, the same ones every run, no deadline or database."""
    return settings(
        max_examples=examples,
        deadline=None,
        derandomize=True,
        database=None,
        suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
    )


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

    @bounded(EXAMPLES.get(name, 150))
    @given(st.one_of(st.binary(max_size=300), mutated(pool)))
    def run(data):
        target(data)

    run()


@pytest.mark.parametrize("path", FOUND, ids=lambda p: f"{p.parent.name}/{p.name}")
def test_found_inputs_pass_now(path):
    python_targets.TARGETS[path.parent.name.removeprefix("python_")](path.read_bytes())


def _outcome(name: str, path: Path, data: bytes | None):
    """What the decoder of a file-reading target makes of the file at `path` (data None: `load_run`,
    `load_scenario`, `read_users_file`), or of its bytes `data` in memory (what the fuzz target calls): the
    accepted record (for a run, its completeness and what it holds), or the refusal's type."""
    try:
        if name == "mcap":
            run = load_run(path, images=False) if data is None else read_run(io.BytesIO(data), path, images=False)
            return completeness(run), run.steps.tolist(), len(run.events), run.metadata, run.truncated
        if name == "scenario":
            return load_scenario(path) if data is None else parse_scenario(data, path)
        return read_users_file(str(path)) if data is None else parse_users(data, str(path))
    except (UserError, AuthFileError) as exc:
        return type(exc), str(exc).startswith(f"{path}")


@pytest.mark.parametrize("name", ["mcap", "scenario", "users"])
def test_in_memory_decoders_read_as_the_files_do(name, tmp_path):
    """The fuzz targets of the file decoders hand them the bytes in memory (read_run on an io.BytesIO,
    parse_scenario, parse_users: what load_run, load_scenario and read_users_file do after opening the file);
    on the seeds, the inputs once found and mutations of them, the file and its bytes give the same outcome."""
    path = tmp_path / f"input.{name}"
    found = [p.read_bytes() for p in FOUND if p.parent.name == f"python_{name}"]
    pool = seeds.PYTHON[name]() + found
    for data in pool:
        path.write_bytes(data)
        assert _outcome(name, path, None) == _outcome(name, path, data)

    @bounded(EXAMPLES[name])
    @given(st.one_of(st.binary(max_size=300), mutated(pool)))
    def run(data):
        path.write_bytes(data)
        assert _outcome(name, path, None) == _outcome(name, path, data)

    run()
