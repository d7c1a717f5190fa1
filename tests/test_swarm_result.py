"""SwarmResult's figures from the agents' final reports (swarmhost/launcher.py)."""

from agent.protocol.report import FinalReport, Status
from swarmhost.launcher import SwarmResult


def result(steps_made: list[int], cap: int) -> SwarmResult:
    """Agents that each made `steps_made[i]` steps between Unix times 100 + i and 110 + i, in a run capped at `cap`."""
    finals = {
        i: FinalReport(i, Status.DONE, s, (0.0,) * 12, t_start=100.0 + i, t_end=110.0 + i)
        for i, s in enumerate(steps_made)
    }
    return SwarmResult(list(finals), finals, [], {}, wall_seconds=12.0, startup_seconds=1.0, steps=cap)


def test_steps_per_second_counts_the_steps_made_not_the_cap():
    # an imitation that settled: told to end at step 455 of its 700 (ctl/end), over 100..112 s
    assert result([455, 455, 455], cap=700).steps_per_second() == 455 / 12.0


def test_steps_per_second_of_a_run_to_its_cap():
    assert result([300, 300], cap=300).steps_per_second() == 300 / 11.0


def test_steps_per_second_is_the_furthest_agents():
    # one agent stopped early (killed, or fell behind): the swarm's rate is its furthest agent's
    assert result([120, 300, 300], cap=300).steps_per_second() == 300 / 12.0


def test_steps_per_second_without_times_is_zero():
    finals = {0: FinalReport(0, Status.STOPPED, 0, (0.0,) * 12)}
    assert SwarmResult([0], finals, [], {}, 0.0, 0.0, 300).steps_per_second() == 0.0
