"""The live view: a Foxglove WebSocket server inside the recorder process (`--live [HOST:PORT]`).

The recorder hands every message it writes to the MCAP to `LiveServer.publish` as well: the same topic,
schema and JSON bytes, so Foxglove shows a running swarm exactly as it later shows its recording. The
protocol is served by the `foxglove-sdk` package (subprotocol `foxglove.sdk.v1`, and
`foxglove.websocket.v1` for older clients).

A viewer never slows the swarm: agents do not wait for the recorder at all, and the recorder only
queues each message for each client (`BACKLOG` messages per client; when a slow or stuck viewer lets the
queue fill, the SDK drops that client's oldest messages). A viewer loses frames, the swarm loses no step.

What is written once at the start (the target's outline, the perception picture) is kept and sent again
whenever a viewer subscribes, so a viewer that connects mid-run sees it too.
"""

from __future__ import annotations

import errno
import socket
import threading
from dataclasses import dataclass

from agent.protocol.errors import UserError
from fluidswarm.recording import schemas as sc

DEFAULT_ADDRESS = "127.0.0.1:8765"  # the Foxglove app's default WebSocket connection
BACKLOG = 64  # messages queued per viewer; older ones are dropped when a viewer falls behind
SERVER_NAME = "fluidswarm"


@dataclass(frozen=True)
class LiveAddress:
    """Where the live server listens. Loopback unless the user names another address."""

    host: str
    port: int

    def __str__(self) -> str:
        return f"{self.host}:{self.port}"

    @property
    def url(self) -> str:
        host = f"[{self.host}]" if ":" in self.host else self.host
        return f"ws://{host}:{self.port}"


def parse_address(text: str) -> LiveAddress:
    """'HOST:PORT' (or ':PORT', or 'PORT': loopback) -> LiveAddress. Raises UserError naming the flag."""
    raw = str(text).strip()
    host, sep, port_text = raw.rpartition(":")
    if not sep:
        host, port_text = "", raw
    host = host.strip("[]") or "127.0.0.1"
    try:
        port = int(port_text)
    except ValueError:
        raise UserError(f"--live {text}: expected HOST:PORT, e.g. {DEFAULT_ADDRESS}") from None
    if not 1 <= port <= 65535:
        raise UserError(f"--live {text}: port must be in 1..65535")
    return LiveAddress(host, port)


def check_free(address: LiveAddress) -> None:
    """Fail before anything starts if the address cannot be listened on (port in use, unknown host)."""
    try:
        infos = socket.getaddrinfo(address.host, address.port, type=socket.SOCK_STREAM)
    except socket.gaierror as exc:
        raise UserError(f"--live {address}: unknown host ({exc.strerror})") from None
    family, kind, proto, _name, sockaddr = infos[0]
    with socket.socket(family, kind, proto) as s:
        # As the server binds (SO_REUSEADDR): a port left in TIME_WAIT by the last run is free, a listener is not.
        s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            s.bind(sockaddr)
        except OSError as exc:
            what = "port in use" if exc.errno == errno.EADDRINUSE else exc.strerror
            raise UserError(f"--live {address}: {what}") from None


def add_live_argument(parser) -> None:
    """`--live [HOST:PORT]` on a command that starts the recorder."""
    parser.add_argument(
        "--live",
        nargs="?",
        const=DEFAULT_ADDRESS,
        default=None,
        metavar="HOST:PORT",
        help=f"stream the run to Foxglove as it happens (WebSocket server; default {DEFAULT_ADDRESS})",
    )


def live_from_args(args) -> str:
    """The validated `--live` address as the recorder's argument ('' without the flag); says where to connect."""
    if getattr(args, "live", None) is None:
        return ""
    address = parse_address(args.live)
    check_free(address)
    import sys

    print(f"live: {address.url} (Foxglove: Open connection -> Foxglove WebSocket)", file=sys.stderr, flush=True)
    return str(address)


class LiveServer:
    """A Foxglove WebSocket server publishing one run's channels (topics and schemas as in the MCAP).

    Every channel is advertised when the server starts, so a viewer can subscribe before the first step."""

    def __init__(self, address: LiveAddress, run: str):
        import foxglove

        self._context = foxglove.Context()
        self._latched: dict[str, tuple[str, bytes, int]] = {}  # key -> (leaf, data, log time)
        self._subscribed = threading.Event()
        self._closed = threading.Event()
        # Raises RuntimeError ("Failed to bind port ...") if the address is taken.
        self.server = foxglove.start_server(
            name=f"{SERVER_NAME} {run}",
            host=address.host,
            port=address.port,
            context=self._context,
            message_backlog_size=BACKLOG,
            # the two callbacks it needs; the Protocol's others have no-op defaults that the SDK does without
            server_listener=_Listener(self._subscribed),  # type: ignore[arg-type]
        )
        self._channels = {}
        for leaf, name in sc.TOPIC_SCHEMAS.items():
            schema = foxglove.Schema(name=name, encoding=sc.SCHEMA_ENCODING, data=sc.schema_bytes(name))
            self._channels[leaf] = foxglove.Channel(
                sc.topic(run, leaf), schema=schema, message_encoding=sc.MESSAGE_ENCODING, context=self._context
            )
        self.dropped = 0  # messages the SDK refused (never raised into the recorder)
        threading.Thread(target=self._resend, name="live-latched", daemon=True).start()

    @property
    def port(self) -> int:
        return self.server.port

    def publish(self, leaf: str, data: bytes, log_time_ns: int, latch: str | None = None) -> None:
        """Queue `data` (the MCAP message's bytes) for every subscribed viewer; never blocks. With `latch`,
        it is also kept under that key and sent again to each viewer that subscribes later."""
        if latch is not None:
            self._latched[latch] = (leaf, data, log_time_ns)
        try:
            self._channels[leaf].log(data, log_time=log_time_ns)
        except Exception:  # noqa: BLE001  # a live view must never stop the recording
            self.dropped += 1

    def _resend(self) -> None:
        # Not from the listener itself: it runs on the server's own thread, which must not wait on a send.
        while not self._closed.is_set():
            if not self._subscribed.wait(0.5):
                continue
            self._subscribed.clear()
            self._closed.wait(0.1)  # let the subscription take effect
            for leaf, data, log_time in list(self._latched.values()):
                self.publish(leaf, data, log_time)

    def close(self, timeout: float = 1.0) -> bool:
        """Stop the server; False if it had not stopped after `timeout` s. Its stop waits for every viewer to
        take its queued messages, which a stuck viewer never does (measured: the recorder hung until the
        launcher's 60 s SIGKILL), so it runs on a daemon thread and the caller may exit without it."""
        self._closed.set()

        def stop() -> None:
            try:
                self.server.stop()
            except Exception:  # noqa: BLE001, S110  # a live view must never stop the recording, nor its end
                pass

        t = threading.Thread(target=stop, name="live-stop", daemon=True)
        t.start()
        t.join(timeout)
        return not t.is_alive()


class _Listener:
    """foxglove.websocket.ServerListener: says when a viewer subscribes."""

    def __init__(self, subscribed: threading.Event):
        self.subscribed = subscribed

    def on_subscribe(self, client, channel) -> None:
        self.subscribed.set()

    def on_unsubscribe(self, client, channel) -> None:  # the SDK calls it on every disconnect
        pass
