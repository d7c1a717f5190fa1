"""`fluidswarm router`: a Zenoh router for one host (docs/multi-host.md, docs/security.md).

The compiled router (`fluidswarm-router --host`, swarmhost/router_process.py), as every launcher's embedded one:
it relays the states of the agents its host's launchers add (agent/native/src/relay.rs HostRelays), for any
run. This command watches it: a router that exits is named, with its exit code. With `--auth-file` (a users
file, agent/protocol/access.py) every session must authenticate, and each user gets its role's rights only
(Zenoh access control: agent/protocol/acl.py); its own credentials towards the routers it connects to are the
file's `router` line. With `--tls-ca/--tls-cert/--tls-key`, `quic/` endpoints use mutual TLS (TLS 1.3 over
QUIC): only nodes holding a certificate signed by that CA open a link. `tls/` is refused (TLS_REFUSED).
"""

from __future__ import annotations

import sys

from agent.protocol.access import AuthFileError, acl_config, read_users_file
from agent.protocol.errors import UserError
from agent.protocol.session import TlsFiles, router_config_dict
from agent.protocol.stopping import stop_on_signals
from swarmhost.helpers import describe_exit
from swarmhost.router_process import RouterFailed, RouterProcess

POLL = 0.5  # s between looks at the router: its loss is said within this


def register(sub) -> None:
    p = sub.add_parser("router", help="run a Zenoh router for this host (agents of other hosts connect through it)")
    p.add_argument(
        "--listen", action="append", default=None, help="endpoint to listen on, e.g. tcp/0.0.0.0:7447 (repeatable)"
    )
    p.add_argument(
        "--connect", action="append", default=[], help="another host's router, e.g. quic/10.0.0.2:7448 (repeatable)"
    )
    p.add_argument(
        "--auth-file",
        help="users file (user:password lines, users are roles: agent-<id>, launcher, "
        "coordinator, recorder, router); every session must then authenticate and "
        "gets its role's rights only (docs/security.md)",
    )
    p.add_argument(
        "--tls-ca", help="PEM of the CA that signed every router's certificate (quic/ endpoints, mutual TLS)"
    )
    p.add_argument("--tls-cert", help="PEM certificate of this router")
    p.add_argument("--tls-key", help="PEM private key of this router")
    p.add_argument(
        "--count-traffic",
        action="store_true",
        help="count the state messages this router sends to and receives from other routers (what crosses "
        "between hosts) and print them when it stops: router_traffic sent=N received=N links=N",
    )
    p.set_defaults(func=run)


# zenoh 1.10's tls/ link reads and writes one rustls stream from two threads at once, which rustls does not
# support (eclipse-zenoh/zenoh#2557): between two of our routers it crashed one ("memory allocation of
# 139855342500400 bytes failed" in rustls) and lost states in most split runs (verify: errors of 1e-3 to 1.6 m;
# the same runs over quic/ or tcp/ exact). quic/ carries the same mutual TLS (TLS 1.3, the same certificates).
TLS_REFUSED = (
    "tls/ links are refused: zenoh 1.10's TLS link is unsound under load (eclipse-zenoh/zenoh#2557); "
    "use quic/HOST:PORT, the same certificates and mutual TLS"
)


def _check_endpoint(name: str, ep: str) -> None:
    if ep.startswith("tls/"):
        raise UserError(f"{name} {ep!r}: {TLS_REFUSED}")
    proto, sep, addr = ep.partition("/")
    # the compiled router's transports (agent/native/Cargo.toml: zenoh's tcp and quic links)
    if not sep or proto not in ("tcp", "quic") or ":" not in addr:
        raise UserError(f"{name} {ep!r}: expected tcp/HOST:PORT or quic/HOST:PORT, e.g. tcp/127.0.0.1:7447")


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
    if tls is None and any(ep.startswith("quic/") for ep in listen + args.connect):
        raise UserError("quic/ endpoints need --tls-ca, --tls-cert and --tls-key")
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
    settings = router_config_dict(
        listen, args.connect, dictionary_file=args.auth_file or "", user=user, password=password, acl=acl, tls=tls
    )
    stop = stop_on_signals()
    try:
        router = RouterProcess(None, settings, count_traffic=args.count_traffic)
    except RouterFailed as exc:
        why = str(exc).removeprefix("fluidswarm router: error: ")
        raise UserError(f"cannot start the router on {','.join(listen)}: {why}") from None
    print(f"router={','.join(listen)} zid={router.zid}", flush=True)
    try:
        while not stop.wait(POLL):
            if router.proc.poll() is not None:
                why = router.last_words().removeprefix("fluidswarm router: error: ")
                raise UserError(
                    f"the router (fluidswarm-router, pid {router.proc.pid}) "
                    f"{describe_exit(router.proc.returncode)}" + (f": {why}" if why else "")
                )
    finally:
        if args.count_traffic and router.proc.poll() is None:
            _say_traffic(router)
        router.close()
    return 0


def _say_traffic(router: RouterProcess) -> None:
    """The router's count of state messages over its links to other routers, one line on stdout."""
    try:
        t = router.traffic()
    except RouterFailed as exc:
        print(f"fluidswarm router: {exc}", file=sys.stderr, flush=True)
        return
    print(f"router_traffic sent={t['sent']} received={t['received']} links={t['links']}", flush=True)
