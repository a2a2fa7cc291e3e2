"""systemd's notify protocol (sd_notify(3)) in a few lines: datagrams "KEY=value\\n…" to the AF_UNIX
socket named by $NOTIFY_SOCKET (a path, or "@name" in the abstract namespace). Without
$NOTIFY_SOCKET (not started by systemd with Type=notify) every call does nothing.

:class:`Heartbeat` decides when ``WATCHDOG=1`` may be sent: only while the loop advances and sensor
frames really arrive, at most every half watchdog period, so a hung or starved process is restarted.
"""

from __future__ import annotations

import logging
import os
import socket
import time
from collections.abc import Callable, Mapping

log = logging.getLogger("jostle.sdnotify")


def socket_address(value: str) -> str | bytes:
    """The address to send to for a $NOTIFY_SOCKET value ("@x" → b"\\0x", the abstract namespace)."""
    if value.startswith("@"):
        return b"\0" + value[1:].encode()
    return value


def watchdog_interval(env: Mapping[str, str]) -> float | None:
    """Seconds between watchdog pings that systemd asks for: half of $WATCHDOG_USEC, when it is set
    and meant for this process ($WATCHDOG_PID absent or ours); None otherwise."""
    usec = env.get("WATCHDOG_USEC", "")
    pid = env.get("WATCHDOG_PID", "")
    if not usec.isdigit() or int(usec) <= 0:
        return None
    if pid and (not pid.isdigit() or int(pid) != os.getpid()):
        return None
    return int(usec) / 2e6


class Notifier:
    """Sends notify messages to ``address`` (from $NOTIFY_SOCKET by default). Never raises: a
    supervisor that went away must not stop the installation; failures are logged once."""

    def __init__(self, address: str | None = None) -> None:
        if address is None:
            address = os.environ.get("NOTIFY_SOCKET") or None
        self.address = address
        self._sock: socket.socket | None = None
        self._failed = False
        self.sent = 0

    @property
    def enabled(self) -> bool:
        return bool(self.address)

    def send(self, **fields: str | int) -> bool:
        """``send(READY=1, STATUS="…")`` → one datagram ``READY=1\\nSTATUS=…``. True when sent."""
        if not self.address:
            return False
        body = "\n".join(f"{k}={str(v).replace(chr(10), ' ')}" for k, v in fields.items())
        try:
            if self._sock is None:
                self._sock = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM | socket.SOCK_CLOEXEC)
            self._sock.sendto(body.encode("utf-8", "replace"), socket_address(self.address))
        except OSError as e:
            if not self._failed:
                log.warning("systemd notify socket %s: %s (further failures not logged)", self.address, e)
            self._failed = True
            return False
        self.sent += 1
        return True

    def close(self) -> None:
        if self._sock is not None:
            self._sock.close()
            self._sock = None


class Heartbeat:
    """Sends ``WATCHDOG=1`` through ``notifier`` every ``interval_s`` wall seconds, but only while
    the loop clock advances and some sensor delivered a frame within ``stall_s`` seconds of loop time.

    ``beat(now, newest_frame_t)`` is called once per loop frame; ``wall`` is the wall clock for the
    interval (injectable for tests). ``interval_s`` None: no pings (systemd asked for none).
    """

    def __init__(self, notifier: Notifier, interval_s: float | None, stall_s: float,
                 wall: Callable[[], float] = time.monotonic) -> None:
        self.notifier, self.interval_s, self.stall_s, self.wall = notifier, interval_s, stall_s, wall
        self._last_ping: float | None = None
        self._last_now: float | None = None
        self.pings = 0
        self.flowing = False

    def beat(self, now: float, newest_frame_t: float | None) -> bool:
        """True when a ping was sent for this frame."""
        advancing = self._last_now is None or now > self._last_now
        self._last_now = now if self._last_now is None else max(now, self._last_now)
        self.flowing = advancing and newest_frame_t is not None and now - newest_frame_t <= self.stall_s + 1e-9
        if not self.flowing or self.interval_s is None or not self.notifier.enabled:
            return False
        wall = self.wall()
        if self._last_ping is not None and wall - self._last_ping < self.interval_s:
            return False
        if self.notifier.send(WATCHDOG=1):
            self._last_ping = wall
            self.pings += 1
            return True
        return False
