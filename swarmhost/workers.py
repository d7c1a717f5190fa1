"""Hosts of one run joined by workers (docs/multi-host.md "Workers"): the main host serves the run's plan
(`PlanServer`, a queryable on `plan`), each `fluidswarm worker` fetches its share (`fetch_share`) and runs
it (`run_share`) on its own router. The plan record and its signature: agent/protocol/plan.py.
"""

from __future__ import annotations

import secrets
import threading
import time
from dataclasses import replace

from agent.protocol.errors import SwarmFailed, SwarmTimeout, UserError
from agent.protocol.plan import (
    NONCE_SIZE,
    Plan,
    PlanError,
    check_nonce,
    open_reply,
    plan_key,
    sign_reply,
    signing_key,
)
from agent.protocol.spec import AgentSpec
from swarmhost.launcher import Launcher

FETCH_SECONDS = 60.0  # s a worker waits for a main host to serve the run's plan (it may still be perceiving)
RETRY_SECONDS = 0.5  # s between a worker's queries while no main host answers


def launcher_password(launcher: Launcher) -> str:
    """The `launcher` password of the run's users file (what the plan's and the command's keys derive from)."""
    own = launcher.access.own
    if own is None or not launcher.access.state_key_ids:
        raise UserError("workers need the run's users file (--auth-file FILE or $FLUIDSWARM_AUTH_FILE) and --connect")
    return own.password


class PlanServer:
    """The main host's queryable on the run's plan: each query gets the next share not yet handed out (or
    "started" once the run has begun, "full" when every share has its worker), signed for its nonce."""

    def __init__(self, launcher: Launcher, shares: list[Plan]):
        self.run, self.shares = launcher.run, shares
        self.key = signing_key(launcher_password(launcher), self.run)
        self.handed = 0
        self.started = False
        self.lock = threading.Condition()
        self._q = launcher.session.declare_queryable(plan_key(self.run), self._on_query)

    def _on_query(self, query) -> None:
        nonce = check_nonce(query.payload.to_bytes() if query.payload is not None else None)
        if nonce is None or str(query.key_expr) != plan_key(self.run):
            return  # not a worker's query of this run's plan: no answer
        with self.lock:
            if self.started:
                plan = Plan(self.run, "started")
            elif self.handed >= len(self.shares):
                plan = Plan(self.run, "full")
            else:
                plan = self.shares[self.handed]
                self.handed += 1
                self.lock.notify_all()
        try:
            query.reply(plan_key(self.run), sign_reply(self.key, nonce, plan.body()))
        except Exception:  # noqa: BLE001, S110  # the session is closing; the worker hears nothing and says so
            pass

    def wait_workers(self, timeout: float) -> None:
        """Until every share is handed out; SwarmTimeout naming how many workers came after `timeout` s."""
        deadline = time.monotonic() + timeout
        with self.lock:
            while self.handed < len(self.shares):
                left = deadline - time.monotonic()
                if left <= 0:
                    raise SwarmTimeout(
                        f"{self.handed} of {len(self.shares)} workers came in {timeout:.0f} s "
                        f"(fluidswarm worker --connect ROUTER --run {self.run}); nothing was started"
                    )
                self.lock.wait(min(left, 0.2))

    def mark_started(self) -> None:
        with self.lock:
            self.started = True

    def close(self) -> None:
        try:
            self._q.undeclare()
        except Exception:  # noqa: BLE001, S110  # undeclaring on a session that is closing may fail
            pass


def fetch_share(launcher: Launcher, timeout: float = FETCH_SECONDS) -> Plan:
    """This worker's share of the run's plan, verified: UserError in one line when no main host answers, the
    answer does not verify, or it is not a share (the run started, or every share has its worker)."""
    run = launcher.run
    key = signing_key(launcher_password(launcher), run)
    deadline = time.monotonic() + timeout
    why = None
    while True:
        nonce = secrets.token_bytes(NONCE_SIZE)
        left = max(0.5, min(10.0, deadline - time.monotonic()))
        for reply in launcher.session.get(plan_key(run), payload=nonce, timeout=left):
            if reply.ok is None:
                continue
            try:
                plan = open_reply(key, nonce, reply.ok.payload.to_bytes(), run)
            except PlanError as exc:
                why = str(exc)
                continue
            if plan.answer == "started":
                raise UserError(f"run {run}: the main host has already started it; nothing was started")
            if plan.answer == "full":
                raise UserError(f"run {run}: every share already has its worker; nothing was started")
            return plan
        if why is not None:
            raise UserError(f"run {run}: the main host's plan was refused: {why}; nothing was started")
        if time.monotonic() >= deadline:
            raise UserError(
                f"run {run}: no main host served its plan on {launcher.endpoint} in {timeout:.0f} s (no such "
                f"run, or its main host is not waiting for workers); nothing was started"
            )
        time.sleep(RETRY_SECONDS)


def run_share(launcher: Launcher, plan: Plan, startup_timeout: float, run_timeout: float) -> dict:
    """Start and supervise this worker's share of `plan` until its agents have reported (the main host gives
    the start signal and ends the run): {id: FinalReport} of the share."""
    la = launcher
    specs = [
        replace(s, connect=[la.agent_endpoint], state_key_ids=la.access.state_key_ids, secret="") for s in plan.specs
    ]
    ids = [s.id for s in specs]
    la.check_ids(ids)
    la.pace_split(ids, range(plan.swarm), owner=False)
    for spec in specs:
        la.spawn(spec)
    la.track_progress()
    la.wait_alive(ids, startup_timeout)
    la.wait_finals(ids, startup_timeout + run_timeout)
    with la.swarm.changed:
        return {i: la.swarm.finals[i] for i in ids if i in la.swarm.finals}


def share_plans(run: str, swarm: int, salt: str, shares: list[list[AgentSpec]]) -> list[Plan]:
    """The replies of shares 2..M of M (region 1 is the main host's own)."""
    m = len(shares) + 1
    if any(not specs for specs in shares):
        raise SwarmFailed(f"{m} shares of {swarm} agents: a share without agents")
    return [Plan(run, "share", (k + 2, m), swarm, salt, tuple(specs)) for k, specs in enumerate(shares)]
