"""A small Foxglove WebSocket client for the tests: what the Foxglove app does when it connects to a run.

It speaks the protocol directly (the `websockets` package): serverInfo, advertise, subscribe, and the
binary message-data frames (opcode 1: u32 subscription id, u64 log time in ns, then the message bytes).
"""

from __future__ import annotations

import contextlib
import json
import struct
import time

from websockets.sync.client import connect

# What the Foxglove app offers: foxglove-sdk 0.30 servers pick the first, older servers the second.
SUBPROTOCOLS = ["foxglove.sdk.v1", "foxglove.websocket.v1"]
MESSAGE_DATA = 1
_HEADER = struct.Struct("<BIQ")


class FoxgloveClient:
    def __init__(self, url: str, timeout: float = 30.0, **options):
        """Connect to `url`, retrying until the server listens or `timeout` s pass."""
        deadline = time.monotonic() + timeout
        self._stack = contextlib.ExitStack()
        while True:
            try:
                self.ws = self._stack.enter_context(connect(url, subprotocols=SUBPROTOCOLS, open_timeout=2, **options))
                break
            except OSError:
                if time.monotonic() > deadline:
                    raise
                time.sleep(0.05)
        self.server_info: dict | None = None
        self.channels: dict[str, dict] = {}  # topic -> advertised channel

    def read_control(self, until, timeout: float = 10.0) -> None:
        """Read JSON control messages until `until(self)` holds."""
        deadline = time.monotonic() + timeout
        while not until(self):
            msg = self.ws.recv(timeout=max(0.01, deadline - time.monotonic()))
            if isinstance(msg, bytes):
                continue
            op = json.loads(msg)
            if op["op"] == "serverInfo":
                self.server_info = op
            elif op["op"] == "advertise":
                for ch in op["channels"]:
                    self.channels[ch["topic"]] = ch

    def channel(self, leaf: str) -> dict:
        """Wait for the advertised channel whose topic ends with `/leaf`."""
        self.read_control(lambda c: any(t.endswith("/" + leaf) for t in c.channels))
        return next(ch for t, ch in self.channels.items() if t.endswith("/" + leaf))

    def subscribe(self, channel_id: int, subscription_id: int = 1) -> None:
        self.ws.send(
            json.dumps({"op": "subscribe", "subscriptions": [{"id": subscription_id, "channelId": channel_id}]})
        )

    def message(self, timeout: float) -> tuple[int, int, bytes] | None:
        """The next message-data frame: (subscription id, log time ns, message bytes); None on a control message."""
        msg = self.ws.recv(timeout=timeout)
        if not isinstance(msg, bytes) or msg[0] != MESSAGE_DATA:
            return None
        _op, sub, log_time = _HEADER.unpack_from(msg)
        return sub, log_time, msg[_HEADER.size :]

    def close(self) -> None:
        self._stack.close()
