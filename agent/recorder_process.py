"""The run's passive MCAP recorder as a process (fluidswarm/recording/recorder.py): start it, stop it."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time

from agent.protocol import keys
from agent.supervisor import die_with_parent, stop_process


class RecorderProcess:
    """The recorder of run `run`, connected to `endpoint` with the credentials in `env` (docs/security.md);
    `quiet`: its output goes nowhere."""

    def __init__(self, run: str, endpoint: str, session, env: dict, quiet: bool = True, id_keys: bool = False):
        self.run, self.endpoint, self.session, self.env, self.quiet = run, endpoint, session, env, quiet
        self.id_keys = id_keys  # the agents put states on their id keys (per-process rights)
        self.proc: subprocess.Popen | None = None

    def start(self, path: str, metadata: dict, dt: float, timeout: float = 30.0, target: str = "", image: str = "",
              live: str = "") -> subprocess.Popen:
        """Start recording to `path` and wait until the recorder's subscribers are declared (it then shows a
        liveliness token), so it misses no step. `target` (.npz mask + transform) and `image` (.jpg) are
        written into the file; `live` (HOST:PORT) also serves the run over Foxglove WebSocket."""
        meta = dict(metadata)
        meta.setdefault("run", self.run)
        out = subprocess.DEVNULL if self.quiet else None
        cmd = [sys.executable, "-m", "fluidswarm.recording.recorder", "--connect", self.endpoint, "--run", self.run,
               "--out", str(path), "--dt", repr(float(dt)), "--metadata", json.dumps(meta),
               "--state-keys", "id" if self.id_keys else "cell"]
        if target:
            cmd += ["--target", target]
        if image:
            cmd += ["--image", image]
        if live:  # HOST:PORT of its Foxglove WebSocket server (fluidswarm/recording/live.py)
            cmd += ["--live", live]
        self.proc = subprocess.Popen(cmd, stdout=out, stderr=out, stdin=subprocess.DEVNULL, preexec_fn=die_with_parent,
                                     env=dict(os.environ, **self.env))
        deadline = time.monotonic() + timeout
        key = f"{keys.PREFIX}/{self.run}/recorder"
        while time.monotonic() < deadline:
            if self.proc.poll() is not None:
                raise RuntimeError(f"recorder exited at start-up (code {self.proc.returncode})")
            # its own token's key: a token on a wildcard key (`fluidswarm/**`) answers this query too
            if any(r.ok is not None and str(r.ok.key_expr) == key for r in self.session.liveliness().get(key, timeout=1.0)):
                return self.proc
            time.sleep(0.1)
        raise TimeoutError(f"recorder not ready after {timeout:.0f} s")

    def stop(self, timeout: float = 60.0) -> int | None:
        """SIGTERM the recorder: it writes the pending steps and the MCAP footer, then exits."""
        if self.proc is None:
            return None
        stop_process(self.proc, timeout)
        return self.proc.returncode
