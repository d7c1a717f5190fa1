"""`fluidswarm router`: a Zenoh router for one host (docs/multi-host.md).

In-process router mode of zenoh-python, so nothing else needs installing; the upstream `zenohd` daemon,
where installed, is an equivalent alternative (same endpoints, same auth settings).
"""

from __future__ import annotations

import os
import signal
import threading

import zenoh

from agent.protocol.session import router_config
from agent.protocol.errors import UserError


def register(sub) -> None:
    p = sub.add_parser("router", help="run a Zenoh router for this host (agents of other hosts connect through it)")
    p.add_argument("--listen", action="append", default=None, help="endpoint to listen on, e.g. tcp/0.0.0.0:7447 (repeatable)")
    p.add_argument("--connect", action="append", default=[], help="another host's router, e.g. tcp/10.0.0.2:7447 (repeatable)")
    p.add_argument("--auth-file", help="user:password lines; clients and routers must then authenticate (usrpwd)")
    p.add_argument("--user", default="", help="this router's own credentials towards the routers it connects to")
    p.add_argument("--password", default="")
    p.set_defaults(func=run)


def _check_endpoint(name: str, ep: str) -> None:
    proto, sep, addr = ep.partition("/")
    if not sep or proto not in ("tcp", "udp", "tls", "quic") or ":" not in addr:
        raise UserError(f"{name} {ep!r}: expected PROTO/HOST:PORT, e.g. tcp/127.0.0.1:7447")


def run(args) -> int:
    listen = args.listen or ["tcp/127.0.0.1:7447"]
    for ep in listen:
        _check_endpoint("--listen", ep)
    for ep in args.connect:
        _check_endpoint("--connect", ep)
    if args.auth_file and not os.path.isfile(args.auth_file):
        raise UserError(f"--auth-file {args.auth_file}: no such file")
    conf = router_config(listen, args.connect, dictionary_file=args.auth_file or "", user=args.user, password=args.password)
    try:
        session = zenoh.open(conf)
    except zenoh.ZError as exc:
        raise UserError(f"cannot start the router on {listen}: {str(exc).splitlines()[0]}") from None
    stop = threading.Event()
    signal.signal(signal.SIGTERM, lambda *a: stop.set())
    signal.signal(signal.SIGINT, lambda *a: stop.set())
    print(f"router={','.join(listen)} zid={session.zid()}", flush=True)
    try:
        while not stop.wait(0.5):
            pass
    finally:
        session.close()
    return 0
