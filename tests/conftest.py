"""Shared fixtures, and the line between unit tests and swarm tests.

A test that starts processes (the fluidswarm CLI, agents, routers, recorders) or opens a Zenoh session is
marked `swarm` (registered in pyproject.toml); `make test` runs the unit tests first (`-m "not swarm"`, in
seconds) and the swarm tests after. A unit test that starts such a process or session anyway fails here,
naming the marker, so the split cannot drift.

The shared data sets live next to the repository (../shared/datasets); a test that needs one fails (not
skips) when it is missing.
"""

from __future__ import annotations

import signal
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path

import pytest
import zenoh

REPO = Path(__file__).resolve().parents[1]

# A test run started as a background job of a non-interactive shell (`make test &`) inherits SIGINT ignored,
# and so would every process it starts: the tests that stop a launcher or a recorder with SIGINT then waited
# for it forever (an ignored signal stays ignored across exec, and Python installs no KeyboardInterrupt for
# it). Handled here, the children start with SIGINT at its default, as from a terminal.
if signal.getsignal(signal.SIGINT) == signal.SIG_IGN:
    signal.signal(signal.SIGINT, signal.default_int_handler)
DATASETS = REPO.parent / "shared" / "datasets"
# Programs a unit test may not start: Python (the CLI, a coordinator, a recorder) and the compiled agent.
# Other programs (fc-list, started by matplotlib when it builds its font cache) are not the swarm's.
_SWARM_PROGRAMS = (Path(sys.executable).name, "python", "python3", "fluidswarm-agent", "zenohd")


# Swarm tests that run alone (marker `alone`): `make test` runs these first, one after the other (only the idle
# build beside them), then every other test two at a time (pytest-xdist, -n 2). Each here measures wall seconds
# or CPU (stalls, recovery and detection times, the realtime factor, wake-ups, a bench), injects a fault whose
# effect depends on timing (a freeze, a kill, a partition, a lost router or recorder, a late joiner). A key is a
# test file, a test function (all its parameters) or one parametrized test; the reason says why.
# test_scenarios.py's timed scenario runs (its timed(); the untimed ones count steps and share the machine)
_SCENARIO = "tests/test_scenarios.py::test_scenario_runs_end_to_end_and_passes"
_ASYNC_FAILURES = "async agents keep their own clocks while failures are injected"
ALONE: dict[str, str] = {
    "tests/test_agents.py::test_launch_with_default_options_every_agent_finishes_without_republishing_storms": (
        "counts republished states, which a late neighbour causes"
    ),
    "tests/test_agents.py::test_sigkill_20_percent_at_step_100_the_rest_complete_and_recover": "recovery by timeouts",
    "tests/test_agents.py::test_sigstop_one_agent_swarm_keeps_stepping_and_it_leaves_cleanly": "the longest stall",
    "tests/test_agents.py::test_rogue_state_messages_are_dropped_counted_and_change_nothing": "no neighbour timeout",
    "tests/test_bench.py": "a benchmark",
    "tests/test_camera.py::test_camera_clip_switches_commands_as_the_arms_move_and_the_formation_follows": (
        "a clip played as a live camera, the realtime factor"
    ),
    "tests/test_camera_hand.py": "videos played as a live camera, the realtime factor",
    "tests/test_camera_hand_leaving.py": "a video played as a live camera: when the leaving is said",
    "tests/test_coordinator_swarm.py::test_late_joiner_gets_the_command_within_one_second": "a latency",
    "tests/test_coordinator_swarm.py::test_coordinator_publishes_a_new_command_when_the_gesture_changes": (
        "a clip played at its frame rate"
    ),
    "tests/test_faults.py": "killed, frozen and lost processes, detected in wall seconds",
    "tests/test_live.py::test_live_client_sees_the_steps_as_they_happen_and_the_mcap_is_complete": "as they happen",
    "tests/test_multihost.py::test_losing_one_hosts_router_the_other_host_completes_and_logs_the_loss": "a lost host",
    "tests/test_netfaults.py": "partitions against zenoh's lease, packet loss, a bandwidth cap",
    "tests/test_one_wakeup.py": "wake-ups per step; busy loops on both cores",
    "tests/test_perception_room_live.py": "formed in real time",
    "tests/test_realtime.py": "the realtime factor",
    "tests/test_recorder_swarm.py::test_recorder_complete_after_20_percent_killed": "killed agents",
    "tests/test_ros2_out.py::test_a_ros2_router_lost_mid_run_is_one_line_and_the_mcap_is_complete": "a lost router",
    "tests/test_relay.py::test_the_compiled_router_says_why_it_cannot_start_in_one_line_and_keeps_no_configuration": (
        "no router's configuration in the shared temporary folder, where another test's router keeps one"
    ),
    _SCENARIO + "[branching_failures]": "the longest stall",
    _SCENARIO + "[branching_failures_async]": _ASYNC_FAILURES,
    _SCENARIO + "[hand_failures_freeze_drop]": "the longest stall",
    _SCENARIO + "[hand_failures_freeze_drop_async]": _ASYNC_FAILURES,
    _SCENARIO + "[hand_failures_kill20_async]": _ASYNC_FAILURES,
    "tests/test_scenarios.py::test_run_options_inject_failures_in_async_mode": _ASYNC_FAILURES,
    "tests/test_split_run.py::test_the_launcher_that_finishes_first_stops_none_of_the_other_hosts_agents": (
        "two launchers' ends, in time"
    ),
    "tests/test_workers_netns.py": "a host lost against zenoh's lease",
    "tests/test_workers.py::test_an_imitation_with_one_worker_finishes_every_agent_and_refuses_bad_workers": (
        "a late worker races the run's end: beside another test the run can end before it asks, and it then waits"
        " for a main host as long as the test waits for it (a fresh clone's CI, 71f05d9)"
    ),
}


def _alone_reason(nodeid: str) -> str | None:
    for key, reason in ALONE.items():
        if nodeid == key or nodeid.startswith((key + "::", key + "[")):
            return reason
    return None


@pytest.hookimpl(tryfirst=True)  # before `-m` selects: the marker it selects on must be there
def pytest_collection_modifyitems(config, items):
    seen: dict[Path, object] = {}
    for item in items:
        if item.get_closest_marker("swarm") and _alone_reason(item.nodeid) is not None:
            item.add_marker(pytest.mark.alone)
        seen.setdefault(Path(str(item.fspath)), item.module)
    # A key that names a test function no longer there would quietly let its test share the machine: refuse it.
    for key in ALONE:
        path, _, rest = key.partition("::")
        if not (REPO / path).is_file():
            raise pytest.UsageError(f"tests/conftest.py ALONE names {path}, which does not exist")
        module = seen.get(REPO / path)
        name = rest.partition("[")[0]
        if module is not None and name and not hasattr(module, name):
            raise pytest.UsageError(f"tests/conftest.py ALONE names {key}, which is not a test of {path}")


def _dataset(name: str) -> Path:
    path = DATASETS / name
    if not path.is_dir():
        pytest.fail(f"this test needs the shared data set {name} at {path} (../shared next to the repository)")
    return path


@pytest.fixture(scope="session")
def weizmann() -> Path:
    """The Weizmann action clips (one PNG strip a person and action: wave2/person0.png, ...)."""
    return _dataset("weizmann-actions-64")


@pytest.fixture(scope="session")
def shared_hands() -> Path:
    """The Sign Language Digits hand set (one folder a class, 0..9)."""
    return _dataset("sign-language-digits")


@pytest.fixture(scope="session")
def shared_image(shared_hands: Path) -> Callable[[int], Path]:
    """The last image of a class of the shared hand set (a fixed, documented pick)."""
    return lambda cls: max((shared_hands / str(cls)).iterdir())


@pytest.fixture(autouse=True)
def _unit_tests_start_no_swarm(request, monkeypatch):
    """Fail a test not marked `swarm` that starts a swarm process or a Zenoh session."""
    if request.node.get_closest_marker("swarm"):
        return
    name = request.node.nodeid

    def no_session(*args, **kwargs):
        raise AssertionError(f"{name} opens a Zenoh session: mark it @pytest.mark.swarm")

    spawn = subprocess.Popen._execute_child

    def no_process(self, args, *rest, **kwargs):
        program = Path(str(args[0] if isinstance(args, (list, tuple)) else str(args).split()[0])).name
        if program in _SWARM_PROGRAMS:
            raise AssertionError(f"{name} starts {program}: mark it @pytest.mark.swarm")
        return spawn(self, args, *rest, **kwargs)

    monkeypatch.setattr(zenoh, "open", no_session)
    monkeypatch.setattr(subprocess.Popen, "_execute_child", no_process)
