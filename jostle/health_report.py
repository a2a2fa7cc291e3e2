"""The health report outside the process: a JSON file rewritten atomically every few seconds, and a
small HTTP endpoint on 127.0.0.1 (``GET /health`` → the JSON; 200 when ok, 503 otherwise). Both
serve :meth:`jostle.health.Health.report`, the figures the diagnostics overlay shows.
"""

from __future__ import annotations

import json
import logging
import os
import threading
from collections.abc import Callable
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path
from typing import Any

log = logging.getLogger("jostle.health")

Report = Callable[[], dict[str, Any]]


def write_atomically(path: Path, text: str) -> None:
    """Write ``text`` to ``path`` so that a reader sees the old file or the new one, never half of one
    (a temporary file beside it, flushed, then ``os.replace``)."""
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        with tmp.open("w", encoding="utf-8") as f:
            f.write(text)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


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
            write_atomically(self.path, json.dumps(self.report(), indent=1) + "\n")
        except OSError as e:
            if self._failure != type(e).__name__:
                log.warning("health report %s: cannot write: %s", self.path, e)
            self._failure = type(e).__name__
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
        self._server = ThreadingHTTPServer((host, port), handler)
        self._server.daemon_threads = True
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


def _handler(report: Report) -> type[BaseHTTPRequestHandler]:
    class HealthHandler(BaseHTTPRequestHandler):
        server_version = "jostle-health"

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
