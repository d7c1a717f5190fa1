"""The launcher's ctl/gone relay (swarmhost/pacing_core.py): a lost agent is relayed to the swarm, a finished one is
not — its token's deletion overtakes its final report, and a neighbour told it is gone could stop waiting for its
last state still on the way (docs/protocol.md, "A neighbour's last states"). The core with made-up times: no
session, no thread, no sleep."""

from __future__ import annotations

from agent.protocol.ctl import Clock, Gone
from swarmhost.pacing_core import GONE_GRACE, PaceCore, Say


def gone(actions) -> list[int]:
    return [a.message.agent for a in actions if isinstance(a, Say) and isinstance(a.message, Gone)]


def test_a_lost_agent_is_relayed_after_the_grace_and_a_finished_one_never():
    core = PaceCore("r", agent_timeout=2.0)
    lost_at = 100.0
    core.lose(5, lost_at)
    core.lose(6, lost_at)
    assert gone(core.tick(lost_at + GONE_GRACE / 3, set())) == []  # within the grace: its report may still come
    core.finished({6: "agent 6's report"})  # it arrives after its token's deletion: agent 6 finished
    assert gone(core.tick(lost_at + GONE_GRACE / 2, set())) == []
    assert gone(core.tick(lost_at + GONE_GRACE, set())) == [5]
    assert gone(core.tick(lost_at + 10 * GONE_GRACE, set())) == []  # relayed once


def test_gone_comes_before_the_clock_of_the_same_tick():
    from agent.protocol.wire import encode_state

    core = PaceCore("r", agent_timeout=2.0)
    core.state(encode_state(1, 4, [0.0] * 12), "fluidswarm/r/state/0/0", 0.0)
    core.lose(2, 0.0)
    assert core.tick(GONE_GRACE, {1}) == [Say(Gone(2)), Say(Clock(4))]
