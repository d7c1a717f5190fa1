"""`fluidswarm auth-file --agents N --out FILE`: the users file of a multi-host run (docs/multi-host.md).

One `user:password` line per role (launcher, coordinator, recorder, router) and per agent id 0..N-1, fresh
passwords (agent/protocol/access.py RunKey), the format `fluidswarm router --auth-file` and the launchers
read. Written with mode 0600 from the start (never readable by others, not even for a moment); an existing
file is kept unless `--force`, which replaces it whole (a new file, renamed over the old one).
"""

from __future__ import annotations

import os
import tempfile

from agent.protocol import keys
from agent.protocol.access import RunKey, users_text, write_users_file
from agent.protocol.errors import UserError


def register(sub) -> None:
    p = sub.add_parser(
        "auth-file", help="write a multi-host run's users file (user:password per role and agent id, mode 0600)"
    )
    p.add_argument("--agents", type=int, required=True, metavar="N", help="agent ids 0..N-1 get a line")
    p.add_argument("--out", required=True, metavar="FILE", help="the users file to write (copy it to every host)")
    p.add_argument("--force", action="store_true", help="replace FILE if it exists (its old passwords stop working)")
    p.set_defaults(func=run)


def check_agents(n: int) -> None:
    if not 1 <= n <= keys.MAX_AGENTS:
        raise UserError(f"--agents: must be 1..{keys.MAX_AGENTS} (the ids an agent's keys hold), got {n}")


def write(path: str, agents: int, force: bool = False) -> None:
    """Fresh credentials for `agents` agents and the roles into `path` (mode 0600); UserError in one line if
    `path` exists (without `force`) or cannot be written."""
    check_agents(agents)
    creds = RunKey().users(agents)
    if os.path.isdir(path):
        raise UserError(f"--out {path}: is a directory")
    try:
        if not force:
            write_users_file(path, creds)  # O_EXCL: refuses an existing file, even one made a moment ago
            return
        # beside the target (mode 0600 from mkstemp), so the rename stays on one file system and replaces the
        # old file whole
        fd, tmp = tempfile.mkstemp(prefix=".users-", dir=os.path.dirname(os.path.abspath(path)))
        try:
            with os.fdopen(fd, "w") as f:
                f.write(users_text(creds))
            os.replace(tmp, path)
        except BaseException:
            if os.path.exists(tmp):
                os.unlink(tmp)
            raise
    except FileExistsError:
        raise UserError(f"--out {path}: exists (--force replaces it; its old passwords then stop working)") from None
    except OSError as exc:
        raise UserError(f"--out {path}: cannot write ({exc.strerror or exc})") from None


def run(args) -> int:
    write(args.out, args.agents, args.force)
    print(f"users_file={args.out} agents={args.agents} mode=0600")
    return 0
