"""The coordinator hands the imitation it perceived to the process that launched it: through a pipe.

The coordinator process is the one owner of perception (docs/architecture.md, "One imitation run"): for a
file and for a camera alike it observes, builds the imitation (coordinator/control/imitation_setup.py
`imitation_for`: set-up and commands) and broadcasts the commands. The launching process needs the same
imitation to place the swarm, start the recorder and score the formation, so the coordinator writes it once,
whole, on a pipe the launcher made for it (`--handover FD`), and closes its end:

    b"fluidswarm-imitation <length>\\n" + an .npz of <length> bytes (arrays, and one JSON entry for the rest)

The launcher waits for it with a deadline (`receive`): an imitation, or `CoordinatorFailed` naming why not —
the coordinator's own one-line error if it exited, or the deadline. Nothing is polled or left on disk.
"""

from __future__ import annotations

import io
import json
import os
import select
import subprocess
import time
from collections.abc import Callable
from dataclasses import asdict

import numpy as np

from agent.protocol.command import parse_body
from agent.protocol.errors import UserError
from agent.sph.params import SPHParams
from agent.sph.particle import Control
from agent.sph.robot import RobotModel
from agent.sph.setups import Setup
from coordinator.control.geometry import ImageToDomain
from coordinator.control.imitation_setup import Imitation
from coordinator.control.observe import Observation

MAGIC = b"fluidswarm-imitation "
MAX_BYTES = 1 << 30  # a 20000 x 20000 picture is refused by perception long before this
ERROR_PREFIX = "fluidswarm coordinator: error: "


class HandoverFailed(UserError):
    """The coordinator could not write its imitation on the hand-over pipe; the message names the pipe."""


class CoordinatorFailed(UserError):
    """The coordinator process did not hand over an imitation; the message says why (its own error line)."""


def encode(im: Imitation) -> bytes:
    """The imitation as one framed .npz (no pickles: every array numeric or bool, the rest JSON)."""
    obs, setup = im.observation, im.setup
    arrays = {
        "mask": im.mask,
        "obs_mask": obs.mask,
        "states": setup.states,
        "classes": setup.classes,
        "ids": setup.ids,
    }
    if obs.frame is not None:
        arrays["frame"] = obs.frame
    arrays.update({f"part_{k}": v for k, v in obs.parts.items()})
    rest = {
        "transform": im.transform.as_dict(),
        "commands": [[int(first), c.body()] for first, c in im.commands],
        "controls": [asdict(c) for c in setup.controls],
        "class_names": list(setup.class_names),
        "params": setup.params.as_dict(),
        "robot": setup.robot.as_dict(),
        "observation": {"kind": obs.kind, "label": obs.label, "index": obs.index},
    }
    arrays["rest"] = np.frombuffer(json.dumps(rest).encode(), np.uint8)
    buf = io.BytesIO()
    np.savez(buf, allow_pickle=False, **arrays)
    data = buf.getvalue()
    return MAGIC + str(len(data)).encode() + b"\n" + data


def decode(data: bytes) -> Imitation:
    """The imitation `encode` wrote (the .npz part); ValueError/KeyError on anything else."""
    with np.load(io.BytesIO(data), allow_pickle=False) as z:
        rest = json.loads(z["rest"].tobytes())
        parts = {k.removeprefix("part_"): z[k].astype(bool) for k in z.files if k.startswith("part_")}
        frame = z["frame"] if "frame" in z.files else None
        o = rest["observation"]
        obs = Observation(str(o["kind"]), z["obs_mask"].astype(bool), str(o["label"]), frame, parts, int(o["index"]))
        p = dict(rest["params"], domain=tuple(rest["params"]["domain"]))
        setup = Setup(
            z["ids"],
            z["states"],
            [Control(**c) for c in rest["controls"]],
            z["classes"],
            tuple(rest["class_names"]),
            SPHParams(**p),
            RobotModel(**rest["robot"]),
        )
        commands = [(int(first), parse_body(body)) for first, body in rest["commands"]]
        return Imitation(z["mask"].astype(bool), ImageToDomain(**rest["transform"]), commands, setup, obs)


def send(fd: int, im: Imitation) -> None:
    """Write `im` on the hand-over pipe `fd` and close it (the launcher reads to its end). HandoverFailed if
    the pipe cannot take it (not a pipe of ours, or the launcher gone)."""
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(encode(im))
    except OSError as exc:
        raise HandoverFailed(f"--handover {fd}: {exc.strerror or exc}") from None


def error_line(proc: subprocess.Popen) -> str:
    """The coordinator's last one-line error (without its program prefix), or '' (read once it has ended)."""
    try:
        err = proc.stderr.read().decode("utf-8", "replace") if proc.stderr else ""
    except (OSError, ValueError):
        err = ""
    # Its own error line, not whatever a library logged after it (FFmpeg does, closing a network stream).
    lines = [line for line in err.splitlines() if line.startswith(ERROR_PREFIX)]
    return lines[-1][len(ERROR_PREFIX) :] if lines else ""


def receive(
    fd: int, proc: subprocess.Popen, timeout: float, timed_out: Callable[[], str], what: str = "the coordinator"
) -> Imitation:
    """The imitation the coordinator `proc` writes on the pipe `fd` (read end; closed here) within `timeout` s.

    If the pipe ends first (the coordinator exited, or closed it without a whole imitation), CoordinatorFailed
    with its error line; at the deadline, CoordinatorFailed with `timed_out()` (which says what was awaited)."""
    data = bytearray()
    deadline = time.monotonic() + timeout
    try:
        while True:
            left = deadline - time.monotonic()
            if left <= 0:
                raise CoordinatorFailed(timed_out())
            ready, _, _ = select.select([fd], [], [], left)
            if not ready:
                continue
            chunk = os.read(fd, 1 << 20)
            if not chunk:
                break
            data += chunk
            if len(data) > MAX_BYTES + 64:
                raise CoordinatorFailed(f"{what} handed over more than {MAX_BYTES} bytes")
    finally:
        os.close(fd)
    header, _, body = bytes(data).partition(b"\n")
    if header.startswith(MAGIC) and header[len(MAGIC) :].isdigit() and len(body) == int(header[len(MAGIC) :]):
        try:
            return decode(body)
        except (ValueError, KeyError, TypeError) as exc:
            raise CoordinatorFailed(f"{what} handed over a malformed imitation: {exc}") from None
    try:  # the pipe ended without a whole imitation: the coordinator is ending (its error line says why)
        code = proc.wait(10)
    except subprocess.TimeoutExpired:  # it closed the pipe and lives on: its stderr has no end to read to
        raise CoordinatorFailed(f"{what} closed its hand-over pipe without an imitation") from None
    line = error_line(proc)
    raise CoordinatorFailed(line or f"{what} ended without handing over an imitation (exit code {code})")
