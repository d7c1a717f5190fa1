"""The compiled router (`fluidswarm-router`, agent/native/src/router_program.rs: the agent's program, which
`fluidswarm-router` execs under its own name, agent/native/src/router_main.rs), with the state relay on the
router's own session (agent/native/src/relay.rs): every launcher's embedded router (`RouterProcess(run, …)`),
and a host's router of a multi-host swarm (`RouterProcess(None, …)`: `fluidswarm router`, whose relay the
launchers of its host ask over Zenoh, swarmhost/host_relay.py).

Why a process of its own: under per-process rights every state passes the relay (its sender's id key in, its
cell's key out). On the launcher's zenoh-python session that cost a Python hand-over per state (~3 s of launcher
CPU per 200 steps at N = 300); inside a compiled router it is a table look-up on zenoh's receiving thread
(docs/benchmarks/security.md). The launcher is then a client of its router, like every other process.

The router's configuration (listen endpoints, users file, access-control rules) travels in a private file
(0600 in a 0700 directory, removed once the router has read it), never on the command line; the launcher talks
to it over its stdin and stdout (`add`, `rejected`); closing its stdin, or the launcher's death, closes it.
"""

from __future__ import annotations

import json
import os
import select
import shutil
import subprocess
import tempfile
import threading
from typing import IO

from agent.protocol.errors import SwarmFailed
from swarmhost.executable import router_executable, router_traffic_executable

CONFIG_ENV = "FLUIDSWARM_ROUTER_CONFIG"
CLOSE_TIMEOUT = 10.0  # s; the router ends itself 5 s after its stdin closed (router_program.rs)
START_TIMEOUT = 60.0  # s until it listens (with the rules of 1280 users it opens in ~1 s here)


class RouterFailed(SwarmFailed):
    """The compiled router did not start or stopped answering (the message says why, in one line)."""


def rejected_counts(answer: str, who: str) -> dict[str, int]:
    """Reason -> count from a relay's answer `rejected length=<n> …` (relay.rs answer); `who` names the router
    in the error of any other answer."""
    words = answer.split()
    if not words or words[0] != "rejected":
        raise RouterFailed(f"{who}: unexpected answer {answer!r}")
    return {k: int(v) for k, v in (w.split("=", 1) for w in words[1:])}


class RouterProcess:
    """`run`: the run's name (the relay's keys), None for a host's router (any run, asked over Zenoh);
    `settings`: the router's Zenoh configuration as a nested dict (agent/protocol/session.py:
    router_config_dict). `zid`: the router's Zenoh id, once it has started."""

    def __init__(self, run: str | None, settings: dict, count_traffic: bool = False):
        private = tempfile.mkdtemp(prefix="fluidswarm-router-")  # mode 0700
        errors = None
        try:
            path = os.path.join(private, "router.json")
            fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
            with os.fdopen(fd, "w") as f:
                json.dump(settings, f)
            errors = open(os.path.join(private, "stderr"), "w+")  # noqa: SIM115  # closed on failure below, else by close()
            self.proc = subprocess.Popen(
                [router_traffic_executable() if count_traffic else router_executable()]
                + [run if run is not None else "--host"],
                env=dict(os.environ, **{CONFIG_ENV: path}),
                stdin=subprocess.PIPE,
                stdout=subprocess.PIPE,
                stderr=errors,
                text=True,
                bufsize=1,
            )
            try:
                # Bounded: a router stuck opening reads no stdin, so the launcher's end would not end it.
                ready, _, _ = select.select([self._stdout], [], [], START_TIMEOUT)
                first = self._stdout.readline().strip() if ready else ""
                said, _, zid = first.partition(" zid=")
                if said != "ready" or not zid:
                    self._kill()
                    errors.seek(0)
                    why = errors.read().strip().splitlines()
                    raise RouterFailed(
                        why[-1]
                        if why
                        else f"fluidswarm-router did not say ready within {START_TIMEOUT:g} s "
                        f"(exit code {self.proc.returncode})"
                    )
            except BaseException:  # also Ctrl-C while it opens: never left behind
                self._kill()
                raise
        except BaseException:
            if errors is not None:
                errors.close()
            raise
        finally:
            shutil.rmtree(private, ignore_errors=True)  # the router has read its configuration (or failed)
        # Kept open (its name is gone with the directory): what the router says after `ready` is read when it is
        # lost (`last_words`), so a router that dies mid-run is named with its reason, not only its exit code.
        assert errors is not None  # opened before the router started, which it did
        self._errors: IO[str] = errors
        self.zid = zid
        self._lock = threading.Lock()  # one request and its answer at a time (late joiners spawn from threads)
        self._last_rejected: dict[str, int] = {}  # the relay's counts when the router closed
        self.relay = CompiledRelay(self)

    # Popen(stdin=PIPE, stdout=PIPE): both pipes exist as long as the process object does.
    @property
    def _stdin(self) -> IO[str]:
        assert self.proc.stdin is not None
        return self.proc.stdin

    @property
    def _stdout(self) -> IO[str]:
        assert self.proc.stdout is not None
        return self.proc.stdout

    def _kill(self) -> None:
        """End the router now (it failed to start, or to close), and let go of its pipes."""
        if self.proc.poll() is None:
            self.proc.kill()
        self.proc.wait()
        self._stdin.close()
        self._stdout.close()

    def last_words(self) -> str:
        """The last line the router wrote to its stderr since it started (its reason when it ends itself), or ''."""
        if self._errors.closed:
            return ""
        self._errors.seek(0)
        lines = [line.strip() for line in self._errors.read().splitlines() if line.strip()]
        return lines[-1] if lines else ""

    def ask(self, request: str) -> str:
        """Send one request line, return the router's answer line."""
        with self._lock:
            try:
                self._stdin.write(request + "\n")
                self._stdin.flush()
                answer = self._stdout.readline()
            except (BrokenPipeError, ValueError):
                answer = ""
        if not answer:
            raise RouterFailed(f"fluidswarm-router stopped (exit code {self.proc.poll()})")
        return answer.strip()

    def rejected(self) -> dict[str, int]:
        """Reason -> states the relay dropped so far; once the router is closed, its last counts."""
        if self._stdin.closed:
            return dict(self._last_rejected)
        return rejected_counts(self.ask("rejected"), "fluidswarm-router")

    def traffic(self) -> dict[str, int]:
        """State messages this router sent to and received from other routers, and how many routers
        (`sent`, `received`, `links`); RouterFailed unless it was started with count_traffic (router_program.rs)."""
        answer = self.ask("traffic")
        words = answer.split()
        if not words or words[0] != "traffic":
            raise RouterFailed(f"fluidswarm-router: traffic: {answer.removeprefix('error ')}")
        return {k: int(v) for k, v in (w.split("=", 1) for w in words[1:])}

    def close(self) -> None:
        """Close the router (its stdin); kill it if it has not ended after CLOSE_TIMEOUT s. Idempotent. The
        relay's last counts stay readable (`rejected`)."""
        if self.proc.poll() is None and not self._stdin.closed:
            try:
                self._last_rejected = self.rejected()
            except RouterFailed:
                pass
        with self._lock:
            try:
                self._stdin.close()
            except (BrokenPipeError, OSError):
                pass
        try:
            self.proc.wait(CLOSE_TIMEOUT)
        except subprocess.TimeoutExpired:
            pass
        self._kill()
        self._errors.close()


class CompiledRelay:
    """The relay inside the launcher's embedded router, asked over its stdin: `add`, `rejected`, `close` (as
    swarmhost/host_relay.py's HostRelay, the relay of another host's router)."""

    def __init__(self, router: RouterProcess):
        self._router = router

    def add(self, agent_id: int, cell: float) -> None:
        """Relay agent `agent_id`'s states from now on (the router answers once its table holds it, so call
        this before the agent starts: none of its states is missed)."""
        answer = self._router.ask(f"add {int(agent_id)} {float(cell)!r}")
        if answer != "ok":
            raise ValueError(answer.removeprefix("error "))

    @property
    def rejected(self) -> dict[str, int]:
        """Reason -> states the relay dropped so far (relay.rs REASONS); after the router closed,
        its last counts."""
        return self._router.rejected()

    def close(self) -> None:
        pass  # the relay ends with its router
