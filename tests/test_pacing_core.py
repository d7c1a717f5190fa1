"""The launcher's pacing core (swarmhost/pacing_core.py) fed message sequences with made-up times: the clock
follows the slowest live agent, moves only when it must, holds a frozen agent out until it catches up, believes
no forged or far-ahead state, says ctl/end with every clock; a split run's share clocks, a silent host dropped
and named, a silent owner replaced. No session, no thread, no sleep: milliseconds."""

from __future__ import annotations

from agent.protocol import keys
from agent.protocol.ctl import Clock, End
from agent.protocol.pace import Pace, pace_key
from agent.protocol.wire import encode_state
from swarmhost.pacing_core import (
    AHEAD,
    CLOCK_LEAD,
    CLOCK_REPEAT,
    PACE_SILENCE,
    HostLost,
    Note,
    PaceCore,
    Say,
    SayPace,
    Share,
)

RUN = "r"
CELL = "fluidswarm/r/state/0/0"  # an exact cell key vouches for any id (no per-process rights)


def state(core: PaceCore, agent: int, step: int, now: float, key: str = CELL) -> None:
    core.sample(key, encode_state(agent, step, [0.0] * 12), now)


def clocks(actions) -> list[int]:
    return [a.message.step for a in actions if isinstance(a, Say) and isinstance(a.message, Clock)]


def test_the_clock_is_the_slowest_live_agents_step_said_when_it_moves_and_every_clock_repeat():
    core = PaceCore(RUN, agent_timeout=2.0)
    assert core.tick(0.0, {0, 1}) == []  # nothing heard: no clock
    state(core, 0, 5, 0.01)
    state(core, 1, 3, 0.01)
    assert core.tick(0.02, {0, 1}) == [Say(Clock(3))]
    assert core.tick(0.04, {0, 1}) == []  # unchanged: not said again
    state(core, 1, 6, 0.05)
    assert clocks(core.tick(0.06, {0, 1})) == [5]
    assert clocks(core.tick(0.06 + CLOCK_REPEAT, {0, 1})) == [5]  # said again, so a lost tick costs a second
    state(core, 0, 7, 0.07)
    assert clocks(core.tick(0.08 + CLOCK_REPEAT, {1})) == [6]  # agent 0's token went: it no longer holds it


def test_the_steps_seen_their_first_times_and_each_agents_newest_record():
    core = PaceCore(RUN, agent_timeout=2.0)
    state(core, 0, 0, 1.0)
    state(core, 1, 0, 1.5)
    state(core, 0, 1, 2.0)
    state(core, 0, 0, 3.0)  # an older state arriving late changes nothing
    assert core.step_times == {0: 1.0, 1: 2.0} and core.max_step == 1
    assert core.agent_steps == {0: (1, 2.0), 1: (0, 1.5)}
    assert core.newest[0] == encode_state(0, 1, [0.0] * 12)


def test_a_forged_state_a_far_ahead_one_and_bad_bytes_are_not_believed():
    core = PaceCore(RUN, agent_timeout=2.0)
    state(core, 0, 2, 0.0, key=keys.state_key(RUN, 0))
    state(core, 3, 1, 0.0, key=keys.state_key(RUN, 4))  # agent 3's record on agent 4's key
    state(core, 5, 1, 0.0, key="fluidswarm/r/state/*")  # a wildcard key vouches for nobody
    state(core, 0, 2 + AHEAD + 1, 0.0)  # further ahead of the newest step than anyone could be
    core.sample(CELL, b"\x00" * 7, 0.0)
    assert core.agent_steps == {0: (2, 0.0)} and core.max_step == 2


def test_a_batch_of_states_counts_each_record_and_a_torn_batch_none():
    core = PaceCore(RUN, agent_timeout=2.0)
    batch = encode_state(7, 3, [0.0] * 12) + encode_state(8, 4, [0.0] * 12)
    core.sample("fluidswarm/r/batch/abc", batch, 1.0)
    core.sample("fluidswarm/r/batch/abc", batch[:-1] + encode_state(9, 9, [0.0] * 12)[:1], 1.0)
    assert core.agent_steps == {7: (3, 1.0), 8: (4, 1.0)}


def test_a_frozen_agent_does_not_hold_the_clock_and_counts_again_once_it_reached_the_clock():
    core = PaceCore(RUN, agent_timeout=1.0)
    state(core, 0, 10, 0.0)
    state(core, 1, 10, 0.0)
    assert clocks(core.tick(0.02, {0, 1})) == [10]
    for k in range(1, 21):  # agent 1 freezes at 10, agent 0 steps on
        state(core, 0, 10 + k, 0.1 * k)
    assert clocks(core.tick(2.0, {0, 1})) == [30]  # agent 1 silent for 2 s > 1 s: held out
    state(core, 1, 11, 2.1)  # it resumes, heard again far behind the clock while it rejoins
    state(core, 0, 35, 2.1)
    assert clocks(core.tick(2.12, {0, 1})) == [35]  # not counted: it would pull the swarm back to step 11
    state(core, 1, 36, 2.2)
    state(core, 0, 40, 2.2)
    assert clocks(core.tick(2.22, {0, 1})) == [36]  # at the clock's step: it counts again
    assert 1 not in core.held_out


def test_when_every_agent_is_silent_the_slowest_alive_one_paces():
    core = PaceCore(RUN, agent_timeout=1.0)
    state(core, 0, 4, 0.0)
    state(core, 1, 6, 0.0)
    assert clocks(core.tick(5.0, {0, 1})) == [4]  # both silent beyond the timeout: not no clock at all
    assert clocks(core.tick(5.0, set())) == []


def test_end_is_said_with_every_clock():
    core = PaceCore(RUN, agent_timeout=2.0)
    assert core.end_at(40) == [Say(End(40))]
    state(core, 0, 2, 0.0)
    assert core.tick(0.02, {0}) == [Say(Clock(2)), Say(End(40))]


def test_realtime_holds_the_clock_below_the_wall_clocks_step():
    core = PaceCore(RUN, agent_timeout=2.0)
    core.mark_start(0.1, 100.0)
    assert core.pace_realtime() == [Say(Clock(0))]
    state(core, 0, 50, 100.5)
    assert clocks(core.tick(101.0, {0})) == [10 - CLOCK_LEAD - 1]  # 1 s of 0.1 s steps
    assert core.realtime_factor() == 50 * 0.1 / 0.5


def test_a_share_says_its_clock_to_the_owner_and_done_when_its_agents_are_gone():
    core = PaceCore(RUN, agent_timeout=2.0, share=Share(own=(3, 4), swarm=6, owner=False))
    state(core, 3, 2, 0.0, key=keys.state_key(RUN, 3))
    state(core, 4, 1, 0.0, key=keys.state_key(RUN, 4))
    core.owner_heard(0.0)
    assert core.tick(0.02, {3, 4}) == [SayPace(Pace(3, 2, 1, False))]  # no ctl/clock of its own
    assert core.tick(0.04, {3, 4}) == []
    assert core.tick(0.06, set()) == [SayPace(Pace(3, 2, 1, True))]
    assert core.farewell() == [SayPace(Pace(3, 2, 0, True))]


def test_a_share_whose_owner_went_silent_paces_itself_said_once():
    core = PaceCore(RUN, agent_timeout=100.0, share=Share(own=(3, 4), swarm=6, owner=False))
    state(core, 3, 2, 0.0, key=keys.state_key(RUN, 3))
    state(core, 4, 2, 0.0, key=keys.state_key(RUN, 4))
    core.owner_heard(0.0)
    assert clocks(core.tick(PACE_SILENCE - 0.1, {3, 4})) == []
    actions = core.tick(PACE_SILENCE, {3, 4})
    assert clocks(actions) == [2] and [a for a in actions if isinstance(a, Note)] == [Note(core.notes[0])]
    assert "this host paces its own share" in core.notes[0]
    assert [a for a in core.tick(PACE_SILENCE + 0.1, {3, 4}) if isinstance(a, Note)] == []


def owner_with_hosts() -> PaceCore:
    share = Share(own=(0, 1), swarm=6, owner=True, others=((2, 3), (4, 5)))
    core = PaceCore(RUN, agent_timeout=100.0, share=share)
    state(core, 0, 9, 0.0, key=keys.state_key(RUN, 0))
    state(core, 1, 9, 0.0, key=keys.state_key(RUN, 1))
    return core


def test_the_owner_waits_for_the_swarm_to_be_covered_then_says_the_minimum_share_clock():
    core = owner_with_hosts()
    assert core.tick(0.02, {0, 1}) == []  # hosts heard cover 2 of 6 agents: no clock yet
    core.pace(pace_key(RUN, 2), Pace(2, 2, 7).encode(), 0.1)
    core.pace(pace_key(RUN, 0), Pace(0, 2, 1).encode(), 0.1)  # claims this host's own share: ignored
    core.pace(pace_key(RUN, 4), b"\x01" * 3, 0.1)  # malformed: ignored
    assert core.tick(0.12, {0, 1}) == []
    core.pace(pace_key(RUN, 4), Pace(4, 2, 8).encode(), 0.2)
    assert clocks(core.tick(0.22, {0, 1})) == [7]
    assert not core.hosts_done()
    core.pace(pace_key(RUN, 2), Pace(2, 2, 7, True).encode(), 0.3)
    core.pace(pace_key(RUN, 4), Pace(4, 2, 12, True).encode(), 0.3)
    assert clocks(core.tick(0.32, {0, 1})) == [9] and core.hosts_done()


def test_the_owner_drops_a_host_silent_for_pace_silence_and_names_its_agents_once():
    core = owner_with_hosts()
    core.pace(pace_key(RUN, 2), Pace(2, 2, 7).encode(), 0.0)
    core.pace(pace_key(RUN, 4), Pace(4, 2, 8).encode(), 0.0)
    assert clocks(core.tick(0.02, {0, 1})) == [7]
    core.pace(pace_key(RUN, 4), Pace(4, 2, 8).encode(), PACE_SILENCE - 1.0)
    actions = core.tick(PACE_SILENCE, {0, 1})
    lost = {"first": 2, "agents": 2, "step": 7, "ids": [2, 3]}
    text = f"the host of agents 2-3 was lost: its share clock stopped at step 7, silent for {PACE_SILENCE:.0f} s"
    assert [a for a in actions if isinstance(a, HostLost)] == [HostLost(lost, core.notes[0])]
    assert core.notes[0].startswith(text) and core.lost_hosts == [lost]
    assert clocks(actions) == [8]  # paced without it
    assert [a for a in core.tick(PACE_SILENCE + 0.1, {0, 1}) if isinstance(a, HostLost)] == []


def test_the_owner_paces_without_hosts_that_never_spoke_after_pace_silence():
    core = owner_with_hosts()
    core.pace(pace_key(RUN, 2), Pace(2, 2, 7).encode(), 0.0)
    assert core.tick(0.02, {0, 1}) == []  # 4 of 6 covered
    core.pace(pace_key(RUN, 2), Pace(2, 2, 7).encode(), PACE_SILENCE)
    actions = core.tick(0.02 + PACE_SILENCE, {0, 1})
    assert clocks(actions) == [7] and core.notes == [
        f"2 of 6 agents' hosts never said their share clock in {PACE_SILENCE:.0f} s: the run is paced without them"
    ]
