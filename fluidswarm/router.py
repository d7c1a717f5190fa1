"""`fluidswarm router`: a Zenoh router for one host (docs/multi-host.md, docs/security.md).

In-process router mode of zenoh-python, so nothing else needs installing. With `--auth-file` (a users file,
agent/protocol/access.py) every session must authenticate, and each user gets its role's rights only
(Zenoh access control, default deny); its own credentials towards the routers it connects to are the file's
`router` line. With `--tls-ca/--tls-cert/--tls-key`, `tls/` endpoints use mutual TLS: only nodes holding a
certificate signed by that CA open a link.
"""

from __future__ import annotations

import zenoh

from agent.protocol.access import AuthFileError, acl_config, read_users_file
from agent.protocol.errors import UserError
from agent.protocol.session import TlsFiles, router_config
from agent.protocol.stopping import stop_on_signals


def register(sub) -> None:
    p = sub.add_parser("router", help="run a Zenoh router for this host (agents of other hosts connect through it)")
    p.add_argument(
        "--listen", action="append", default=None, help="endpoint to listen on, e.g. tcp/0.0.0.0:7447 (repeatable)"
    )
    p.add_argument(
        "--connect", action="append", default=[], help="another host's router, e.g. tls/10.0.0.2:7448 (repeatable)"
    )
    p.add_argument(
        "--auth-file",
        help="users file (user:password lines, users are roles: agent-<id>, launcher, "
        "coordinator, recorder, router); every session must then authenticate and "
        "gets its role's rights only (docs/security.md)",
    )
    p.add_argument("--tls-ca", help="PEM of the CA that signed every router's certificate (tls/ endpoints, mutual TLS)")
    p.add_argument("--tls-cert", help="PEM certificate of this router")
    p.add_argument("--tls-key", help="PEM private key of this router")
    p.set_defaults(func=run)


def _check_endpoint(name: str, ep: str) -> None:
    proto, sep, addr = ep.partition("/")
    if not sep or proto not in ("tcp", "udp", "tls", "quic") or ":" not in addr:
        raise UserError(f"{name} {ep!r}: expected PROTO/HOST:PORT, e.g. tcp/127.0.0.1:7447")


def _tls(args) -> TlsFiles | None:
    given = [args.tls_ca, args.tls_cert, args.tls_key]
    if not any(given):
        return None
    if not all(given):
        raise UserError("--tls-ca, --tls-cert and --tls-key go together")
    try:
        return TlsFiles(args.tls_ca, args.tls_cert, args.tls_key)
    except ValueError as exc:
        raise UserError(str(exc)) from None


def run(args) -> int:
    listen = args.listen or ["tcp/127.0.0.1:7447"]
    for ep in listen:
        _check_endpoint("--listen", ep)
    for ep in args.connect:
        _check_endpoint("--connect", ep)
    tls = _tls(args)
    if tls is None and any(ep.startswith("tls/") for ep in listen + args.connect):
        raise UserError("tls/ endpoints need --tls-ca, --tls-cert and --tls-key")
    user = password = ""
    acl = None
    if args.auth_file:
        try:
            users = read_users_file(args.auth_file)
        except AuthFileError as exc:
            raise UserError(f"--auth-file {exc}") from None
        own = next((c for c in users if c.user == "router"), None)
        if own is None and args.connect:
            raise UserError(
                f"--auth-file {args.auth_file}: no 'router' line (this router's credentials "
                "towards the routers it connects to)"
            )
        user, password = (own.user, own.password) if own else ("", "")
        acl = acl_config([c.user for c in users])
    conf = router_config(
        listen, args.connect, dictionary_file=args.auth_file or "", user=user, password=password, acl=acl, tls=tls
    )
    try:
        session = zenoh.open(conf)
    except zenoh.ZError as exc:
        raise UserError(f"cannot start the router on {listen}: {str(exc).splitlines()[0]}") from None
    stop = stop_on_signals()
    print(f"router={','.join(listen)} zid={session.zid()}", flush=True)
    try:
        while not stop.wait(0.5):
            pass
    finally:
        session.close()
    return 0
