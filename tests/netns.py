"""A test harness of "hosts" as Linux network namespaces joined by veth pairs (needs root and iproute2).

Only addresses inside these namespaces are used (10.77.x.y on veth links that exist only in them).
Faults on a link between two hosts (tests/test_netfaults.py): this kernel has no netem, so a partition and a
random packet drop are nftables rules on one host's end of the link (nft, package nftables), a bandwidth cap
a `tc tbf` qdisc on both ends.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import uuid


class NetnsUnavailable(RuntimeError):
    pass


_FAULTS = "fluidswarm_fault"  # the nft table of a host's injected faults


def _ip(*args: str) -> None:
    subprocess.run(["ip", *args], check=True, capture_output=True, text=True)


class Hosts:
    """Namespaces `a`, `b`, `c`; links a<->b (10.77.0.1 / .2) and a<->c (10.77.1.1 / .2)."""

    LINKS = (("a", "b", "10.77.0.1", "10.77.0.2"), ("a", "c", "10.77.1.1", "10.77.1.2"))

    def __init__(self):
        if os.geteuid() != 0 or shutil.which("ip") is None:
            raise NetnsUnavailable("network namespaces need root and iproute2 ('ip')")
        tag = uuid.uuid4().hex[:6]
        self.ns = {h: f"fs{tag}{h}" for h in "abc"}
        self.addr = {}
        self.dev = {}  # (host, peer) -> the host's end of the veth link to peer
        self.procs: list[subprocess.Popen] = []
        try:
            for name in self.ns.values():
                _ip("netns", "add", name)
                _ip("-n", name, "link", "set", "lo", "up")
            for k, (h1, h2, a1, a2) in enumerate(self.LINKS):
                v1, v2 = f"v{tag}{k}x", f"v{tag}{k}y"
                _ip("link", "add", v1, "type", "veth", "peer", "name", v2)
                _ip("link", "set", v1, "netns", self.ns[h1])
                _ip("link", "set", v2, "netns", self.ns[h2])
                _ip("-n", self.ns[h1], "addr", "add", f"{a1}/24", "dev", v1)
                _ip("-n", self.ns[h2], "addr", "add", f"{a2}/24", "dev", v2)
                _ip("-n", self.ns[h1], "link", "set", v1, "up")
                _ip("-n", self.ns[h2], "link", "set", v2, "up")
                self.addr[(h1, h2)], self.addr[(h2, h1)] = a1, a2
                self.dev[(h1, h2)], self.dev[(h2, h1)] = v1, v2
        except subprocess.CalledProcessError as exc:
            self.close()
            raise NetnsUnavailable(f"cannot create namespaces: {exc.stderr.strip()}") from None

    def popen(self, host: str, cmd: list[str], **kw) -> subprocess.Popen:
        proc = subprocess.Popen(["ip", "netns", "exec", self.ns[host], *cmd], **kw)
        self.procs.append(proc)
        return proc

    def _in(self, host: str, *cmd: str, stdin: str | None = None) -> None:
        done = subprocess.run(["ip", "netns", "exec", self.ns[host], *cmd], input=stdin, capture_output=True, text=True)
        if done.returncode != 0:
            raise NetnsUnavailable(f"{' '.join(cmd)} in host {host}: {done.stderr.strip()}")

    def _filter(self, host: str, peer: str, verdict: str) -> None:
        """Every packet in and out of host's link to peer meets `verdict` (an nft statement list), until heal."""
        if shutil.which("nft") is None:
            raise NetnsUnavailable("network faults need nftables ('nft'; apt-get install -y nftables)")
        dev = self.dev[(host, peer)]
        self._in(
            host,
            "nft",
            "-f",
            "-",
            stdin=f"""
            table inet {_FAULTS} {{
                chain out {{ type filter hook output priority 0; oifname "{dev}" {verdict}; }}
                chain in {{ type filter hook input priority 0; iifname "{dev}" {verdict}; }}
            }}""",
        )

    def partition(self, host: str, peer: str) -> None:
        """Cut the link host <-> peer both ways (packets dropped, not refused: as a pulled cable)."""
        self._filter(host, peer, "drop")

    def drop_randomly(self, host: str, peer: str, percent: int) -> None:
        """Drop `percent` % of the packets each way on the link host <-> peer, at random (nft numgen)."""
        self._filter(host, peer, f"numgen random mod 100 < {int(percent)} drop")

    def heal(self, host: str) -> None:
        """Remove the partition or drop rules of `host`."""
        self._in(host, "nft", "delete", "table", "inet", _FAULTS)

    def cap_bandwidth(self, host: str, peer: str, rate: str, burst: str = "16kbit", latency: str = "200ms") -> None:
        """At most `rate` (tc units, e.g. 256kbit) each way on the link host <-> peer: a token bucket on both ends."""
        for h, p in ((host, peer), (peer, host)):
            self._in(
                h,
                "tc",
                "qdisc",
                "replace",
                "dev",
                self.dev[(h, p)],
                "root",
                "tbf",
                "rate",
                rate,
                "burst",
                burst,
                "latency",
                latency,
            )

    def close(self) -> None:
        for p in self.procs:
            if p.poll() is None:
                p.terminate()
        for p in self.procs:
            try:
                p.wait(10)
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait(5)
        for name in self.ns.values():
            subprocess.run(["ip", "netns", "pids", name], capture_output=True)
            out = subprocess.run(["ip", "netns", "pids", name], capture_output=True, text=True).stdout.split()
            for pid in out:
                try:
                    os.kill(int(pid), 9)
                except (ProcessLookupError, ValueError):
                    pass
            subprocess.run(["ip", "netns", "del", name], capture_output=True)
