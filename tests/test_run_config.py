"""One run configuration (fluidswarm/orchestration/run_config.py): built once from the flags, each value checked
once at the edge with the same words whichever command or file received it."""

from __future__ import annotations

from pathlib import Path

import pytest

from agent.sph.robot import POINT
from coordinator.control.imitation_setup import DEFAULT_CONTROLLER, DEFAULT_STEPS
from fluidswarm.cli import build_parser, main
from fluidswarm.imitate_commands import run_config
from fluidswarm.orchestration.run_config import AGENTS, Access, Recording, RunConfig


def config_of(*argv: str) -> RunConfig:
    return run_config(build_parser().parse_args(["imitate", *argv]))


def test_an_imitation_with_no_options_is_the_declared_defaults():
    config = config_of("photo.jpg")
    assert config == RunConfig(recording=Recording(name="photo"))
    assert (config.agents, config.steps, config.controller, config.robot) == (
        AGENTS,
        DEFAULT_STEPS,
        DEFAULT_CONTROLLER,
        POINT,
    )
    assert config.access == Access() and not config.realtime


def test_the_flags_land_in_the_one_configuration():
    config = config_of(
        "photo.jpg", "--agents", "12", "--steps", "40", "--controller", "pca", "--out", "o", "--realtime"
    )
    assert config == RunConfig(12, 40, "pca", realtime=True, recording=Recording(Path("o"), "photo"))
    camera = config_of("--camera", "0", "--agents", "9")
    assert camera.realtime and camera.recording.name == "camera" and camera.agents == 9


@pytest.mark.parametrize(
    "argv",
    [
        ["imitate", "photo.jpg", "--agents", "0"],
        ["launch", "--agents", "0"],
        ["verify", "--agents", "0"],
        ["run", "demo_v_sign", "--agents", "0"],
    ],
)
def test_a_bad_swarm_size_is_the_same_line_whichever_command_got_it(argv, capsys):
    assert main(argv) == 1
    err = capsys.readouterr().err.strip()
    assert err == f"fluidswarm {argv[0]}: error: --agents: must be in 1..8192, got 0"


@pytest.mark.parametrize("command", [["imitate", "photo.jpg"], ["launch"], ["verify"], ["run", "demo_v_sign"]])
def test_a_swarm_beyond_the_embedded_routers_ids_is_the_same_line_whichever_command_got_it(command, capsys):
    from agent.protocol.access import AGENT_CAPACITY

    assert main([*command, "--agents", "9000"]) == 1
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"fluidswarm {command[0]}: error: --agents 9000: an embedded router knows agent ids")
    assert f"0..{AGENT_CAPACITY - 1} only" in err


def test_a_scenario_files_swarm_size_is_checked_with_the_same_words(tmp_path, capsys):
    bad = tmp_path / "bad.toml"
    bad.write_text('name = "x"\nexperiment = "branching"\nagents = 0\n')
    assert main(["run", str(bad)]) == 1
    assert capsys.readouterr().err.strip().endswith(f"{bad}: key 'agents': must be in 1..8192, got 0")


def test_launch_takes_sync_and_its_old_name_mode():
    parser = build_parser()
    assert parser.parse_args(["launch", "--sync", "async"]).sync == "async"
    assert parser.parse_args(["launch", "--mode", "async"]).sync == "async"
    assert parser.parse_args(["run", "demo_v_sign", "--sync", "async"]).sync == "async"


def test_an_imitations_router_provisions_its_swarm_and_late_joiners_ids_only(monkeypatch):
    # The embedded router's rules grow with its users (1280: ~0.3 s of every start): a run that knows its
    # swarm provisions its ids, and the late joiners' its failures will start, no more.
    from agent.protocol.access import AGENT_CAPACITY, LaunchAccess
    from fluidswarm.orchestration.imitate import FileImitation, run_options
    from fluidswarm.orchestration.run import RunOptions
    from fluidswarm.scenario import Failure

    monkeypatch.setenv("FLUIDSWARM_ACCESS", "acl")
    # Run gives capacity its kind's swarm size (RunKind.agents: Block's, an experiment's, an imitation's config's)
    assert FileImitation("x.png", RunConfig(agents=300)).agents == 300
    assert run_options(RunConfig(agents=300)).capacity(300) == 300
    joining = RunOptions(Recording(None, "x"), failures=(Failure("late_join", 10, count=4), Failure("kill", 5)))
    assert joining.capacity(20) == 24 < AGENT_CAPACITY
    access = LaunchAccess.embedded(24)
    assert access.capacity == 24 and len(access.acl["policies"]) == 24 + 3
    access.env_for_agent(23)
    with pytest.raises(ValueError, match=r"ids 0\.\.23 only"):
        access.env_for_agent(24)
