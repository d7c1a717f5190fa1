"""The launcher's ctl/gone relay (swarmhost/pacing.py): a lost agent is relayed to the swarm, a finished one is not —
its token's deletion overtakes its final report, and a neighbour told it is gone could stop waiting for its
last state still on the way (docs/protocol.md, "A neighbour's last states")."""

from __future__ import annotations

import time

from agent.protocol.ctl import Gone, decode_ctl
from agent.protocol.report import FinalReport, Status
from swarmhost import pacing
from swarmhost.supervisor import Swarm
from tests.swarm_helpers import wait_until


class NoStates:
    def try_recv(self):
        return None

    def undeclare(self):
        pass


class RecordingSession:
    """What the pacer puts, instead of a Zenoh session (a unit test opens none)."""

    def __init__(self):
        self.puts: list[tuple[str, bytes]] = []

    def declare_subscriber(self, *args, **kwargs):
        return NoStates()

    def put(self, key, payload, **kwargs):
        self.puts.append((key, payload))


def relayed(session: RecordingSession) -> list[int]:
    out = []
    for key, payload in session.puts:
        msg = decode_ctl(key.rsplit("/", 1)[-1], payload)
        if isinstance(msg, Gone):
            out.append(msg.agent)
    return out


def test_a_lost_agent_is_relayed_after_the_grace_and_a_finished_one_never():
    session = RecordingSession()
    swarm = Swarm(run="r", endpoint="tcp/127.0.0.1:1", session=session)  # type: ignore[arg-type]
    pacer = pacing.Pacer(swarm, agent_timeout=2.0, id_keys=False, clock_period=0.01)
    lost_at = time.monotonic()
    with swarm.changed:
        swarm.gone += [(5, lost_at), (6, lost_at)]
    pacer.start()
    try:
        time.sleep(pacing.GONE_GRACE / 3)
        assert relayed(session) == []  # within the grace: its report may still come
        with swarm.changed:  # agent 6's report arrives after its token's deletion: it finished
            swarm.finals[6] = FinalReport(id=6, status=Status.DONE, steps=10, state=(0.0,) * 10)
        wait_until(lambda: relayed(session), timeout=10.0)  # the clock thread, once the grace has passed
        assert relayed(session) == [5]
    finally:
        pacer.stop()
