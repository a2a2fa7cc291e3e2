"""The health report outside the process: a JSON file rewritten atomically every few seconds, and a
small HTTP endpoint on 127.0.0.1 (``GET /health`` → the JSON; 200 when ok, 503 otherwise). Both
serve :meth:`jostle.health.Health.report`, the figures the diagnostics overlay shows.

The file is written with ``write_owned``: a FIFO, device (``/dev/full``) or symlink at its path is
refused by name (one warning line) and never replaced. The endpoint takes a backlog of
``LISTEN_BACKLOG`` connections, gives each ``CLIENT_TIMEOUT_S`` to send its request, says only
``jostle-health`` in its ``Server:`` header, and treats a client that resets or closes early as
nothing worse than a debug line (no traceback).
"""

from __future__ import annotations

import json
import logging
import sys
import threading
from collections.abc import Callable
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path
from typing import Any

from sensors.untrusted import UntrustedInput, write_owned

log = logging.getLogger("jostle.health")

Report = Callable[[], dict[str, Any]]
LISTEN_BACKLOG = 128  # connections waiting to be accepted (socketserver's default is 5)
CLIENT_TIMEOUT_S = 5.0  # a client that sends no request within this is dropped


class HealthFile:
    """Rewrites ``path`` with the report every ``interval_s`` seconds of the wall clock given to
    ``due``. A failing write (disk full, folder gone) is logged once per kind and retried next time;
    it never stops the installation."""

    def __init__(self, path: Path, interval_s: float, report: Report) -> None:
        self.path, self.interval_s, self.report = path, interval_s, report
        self._last: float | None = None
        self.writes = 0
        self._failure: str | None = None

    def due(self, wall: float) -> bool:
        """Write the report if ``interval_s`` passed since the last write; True when written."""
        if self._last is not None and wall - self._last < self.interval_s:
            return False
        self._last = wall
        return self.write()

    def write(self) -> bool:
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            write_owned(self.path, json.dumps(self.report(), indent=1) + "\n")  # never over a special file
        except (OSError, UntrustedInput) as e:
            kind = e.problem if isinstance(e, UntrustedInput) else type(e).__name__
            if self._failure != kind:
                log.warning("health report %s: cannot write: %s", self.path,
                            e.problem if isinstance(e, UntrustedInput) else e)
            self._failure = kind
            return False
        self._failure = None
        self.writes += 1
        return True


class HealthServer:
    """``GET /health`` (or ``/``) on ``host:port`` (port 0: any free one; see ``port`` once started)
    in a daemon thread. Serves the report as JSON; 200 when its status is "ok", else 503."""

    def __init__(self, report: Report, port: int, host: str = "127.0.0.1") -> None:
        self.report = report
        handler = _handler(report)
        self._server = _QuietServer((host, port), handler)
        self._thread = threading.Thread(target=self._server.serve_forever, kwargs={"poll_interval": 0.2},
                                        name="jostle-health-http", daemon=True)
        self._started = False

    @property
    def port(self) -> int:
        return int(self._server.server_address[1])

    @property
    def url(self) -> str:
        host = self._server.server_address[0]
        return f"http://{host!s}:{self.port}/health"

    def start(self) -> HealthServer:
        self._thread.start()
        self._started = True
        return self

    def close(self) -> None:
        if self._started:
            self._server.shutdown()
            self._thread.join(timeout=5)
            self._started = False
        self._server.server_close()

    def __enter__(self) -> HealthServer:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.close()


class _QuietServer(ThreadingHTTPServer):
    """A threading HTTP server with a real backlog, whose per-connection errors are one log line."""

    request_queue_size = LISTEN_BACKLOG
    daemon_threads = True

    def handle_error(self, request: Any, client_address: Any) -> None:
        e = sys.exc_info()[1]
        if isinstance(e, ConnectionError | TimeoutError):  # the client reset, closed or went quiet
            log.debug("health http: %s from %s", type(e).__name__, client_address)
        else:
            log.warning("health http: %s: %s (from %s)", type(e).__name__, e, client_address)


def _handler(report: Report) -> type[BaseHTTPRequestHandler]:
    class HealthHandler(BaseHTTPRequestHandler):
        server_version = "jostle-health"
        sys_version = ""  # the Server: header names no Python version
        timeout = CLIENT_TIMEOUT_S

        def version_string(self) -> str:
            return self.server_version

        def do_GET(self) -> None:  # noqa: N802 (http.server's name)
            if self.path.split("?")[0] not in ("/health", "/"):
                self._send(404, {"error": f"no such page {self.path}; try /health"})
                return
            try:
                body = report()
            except Exception as e:  # a report that cannot be made is itself a health problem
                self._send(500, {"status": "error", "error": f"{type(e).__name__}: {e}"})
                return
            self._send(200 if body.get("status") == "ok" else 503, body)

        def _send(self, code: int, body: dict[str, Any]) -> None:
            data = (json.dumps(body, indent=1) + "\n").encode()
            self.send_response(code)
            self.send_header("Content-Type", "application/json")
            self.send_header("Content-Length", str(len(data)))
            self.send_header("Cache-Control", "no-store")
            self.end_headers()
            self.wfile.write(data)

        def log_message(self, format: str, *args: Any) -> None:  # noqa: A002 (http.server's name)
            log.debug("health http: " + format, *args)

    return HealthHandler
