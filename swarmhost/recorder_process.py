"""The run's passive MCAP recorder as a process (fluidswarm/recording/recorder.py): start it, stop it."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from typing import IO

from agent.protocol import keys
from agent.protocol.errors import SwarmFailed, SwarmTimeout, UserError
from swarmhost.supervisor import die_with_parent, stop_process


@dataclass(frozen=True)
class RecorderInputs:
    """What a recording holds besides the run's messages, and where else the run goes: `target` (.npz mask +
    transform) and `image` (.jpg) written into the file; `live` (HOST:PORT) also serves the run over Foxglove
    WebSocket; `coordinator_notes`: follow a camera coordinator's notes on the bus (the missing notes said before
    it started: written at t = 0); `ros2`: the ROS 2 router's endpoint, the run also published there
    (fluidswarm/recording/ros2_bridge.py)."""

    target: str = ""
    image: str = ""
    live: str = ""
    coordinator_notes: tuple[str, ...] | None = None
    ros2: str = ""


class RecorderProcess:
    """The recorder of run `run`, connected to `endpoint` with the credentials in `env` (docs/security.md);
    `quiet`: its output goes nowhere."""

    def __init__(self, run: str, endpoint: str, session, env: dict, quiet: bool = True, id_keys: bool = False):
        self.run, self.endpoint, self.session, self.env, self.quiet = run, endpoint, session, env, quiet
        self.id_keys = id_keys  # the agents put states on their id keys (per-process rights)
        self.proc: subprocess.Popen | None = None
        self._stderr: IO[str] | None = None  # its error output (a file, never a pipe it could fill), for last_words()
        self.words = ""  # its last line on stderr, kept when stop() closes that file

    def start(
        self,
        path: str,
        metadata: dict,
        dt: float,
        inputs: RecorderInputs = RecorderInputs(),
        launcher_events: str = "",
        timeout: float = 30.0,
    ) -> subprocess.Popen:
        """Start recording to `path` and wait until the recorder's subscribers are declared (it then shows a
        liveliness token), so it misses no step. `inputs`: what else it writes and follows (RecorderInputs);
        `launcher_events`: the launcher's events folder, followed (recording/coordinator_events.py)."""
        check_writable(Path(path))
        meta = dict(metadata)
        meta.setdefault("run", self.run)
        out = subprocess.DEVNULL if self.quiet else None
        self._stderr = tempfile.TemporaryFile("w+")  # noqa: SIM115  # lives as long as the recorder: closed in close()
        cmd = [
            sys.executable,
            "-m",
            "fluidswarm.recording.recorder",
            "--connect",
            self.endpoint,
            "--run",
            self.run,
            "--out",
            str(path),
            "--dt",
            repr(float(dt)),
            "--metadata",
            json.dumps(meta),
            "--state-keys",
            "id" if self.id_keys else "cell",
        ]
        if inputs.target:
            cmd += ["--target", inputs.target]
        if inputs.image:
            cmd += ["--image", inputs.image]
        if inputs.live:  # HOST:PORT of its Foxglove WebSocket server (fluidswarm/recording/live.py)
            cmd += ["--live", inputs.live]
        if inputs.coordinator_notes is not None:
            cmd += ["--coordinator-notes", json.dumps(list(inputs.coordinator_notes))]
        if launcher_events:
            cmd += ["--launcher-events", launcher_events]
        if inputs.ros2:
            cmd += ["--ros2", inputs.ros2]
        self.proc = subprocess.Popen(
            cmd,
            stdout=out,
            stderr=self._stderr,
            stdin=subprocess.DEVNULL,
            preexec_fn=die_with_parent,  # noqa: PLW1509  # only prctl(PR_SET_PDEATHSIG): no locks, no allocation
            env=dict(os.environ, **self.env),
        )
        deadline = time.monotonic() + timeout
        key = f"{keys.PREFIX}/{self.run}/recorder"
        while time.monotonic() < deadline:
            if self.proc.poll() is not None:
                why = self.last_words()
                raise SwarmFailed(
                    f"recorder exited at start-up (code {self.proc.returncode})" + (f": {why}" if why else "")
                )
            # its own token's key: a token on a wildcard key (`fluidswarm/**`) answers this query too
            if any(
                r.ok is not None and str(r.ok.key_expr) == key for r in self.session.liveliness().get(key, timeout=1.0)
            ):
                return self.proc
            time.sleep(0.1)
        raise SwarmTimeout(f"recorder not ready after {timeout:.0f} s")

    def stop(self, timeout: float = 60.0) -> int | None:
        """SIGTERM the recorder: it writes the pending steps and the MCAP footer, then exits."""
        if self.proc is None:
            return None
        stop_process(self.proc, timeout)
        if self._stderr is not None:
            self.words = self.last_words()
            self._stderr.seek(0)
            for line in self._stderr.read().splitlines():
                if line.startswith("ros2: "):  # the ROS 2 bridge's notes (an absent or lost router) are the user's
                    print(line[:300], file=sys.stderr, flush=True)
            self._stderr.close()
            self._stderr = None
        return self.proc.returncode

    def last_words(self) -> str:
        """The last line the recorder wrote on its stderr ("" if none)."""
        if self._stderr is None:
            return ""
        self._stderr.seek(0)
        lines = [line.strip() for line in self._stderr.read().splitlines() if line.strip()]
        return lines[-1][:300] if lines else ""


def check_writable(path: Path) -> None:
    """The recording's folder exists and takes a new file: else one line naming the path, before anything."""
    folder = path.parent if str(path.parent) else Path(".")
    if path.is_dir():
        raise UserError(f"cannot record to {path}: it is a directory")
    if not folder.is_dir():
        raise UserError(f"cannot record to {path}: no such directory {folder}")
    if not os.access(folder, os.W_OK | os.X_OK) or (path.exists() and not os.access(path, os.W_OK)):
        raise UserError(f"cannot record to {path}: permission denied")
