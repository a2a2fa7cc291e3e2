"""Run one hostile case as a real ``jostle …`` process, capped, timed, and classify what it did.

The child gets ``RLIMIT_AS`` = ``mem_cap_mb`` (set in ``preexec_fn``) and is killed after
``timeout_s`` (a hang). Its peak resident memory is ``VmHWM`` from ``/proc/PID/status``, polled
every 20 ms: ``ru_maxrss`` would carry the forking parent's peak across ``exec``. Outcomes, first
match wins: ``hang``, ``traceback`` (``Traceback`` on stderr), ``internal_error`` (exit 1 with
``internal error``, or killed by a signal), ``clean_error`` (exit 2, exactly one ``jostle: error:``
line), ``warning`` (exit 0, exactly one ``jostle: warning:`` line), ``ok`` (exit 0, no such line),
``other`` (anything else, e.g. several lines). :func:`passes` says whether that meets the case's
expectation and the case's own checks (a device node left alone, a unit without injected lines).
"""

from __future__ import annotations

import json
import os
import pty
import resource
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, Literal

Expect = Literal["error", "warning", "line", "ok", "any"]
BAD = ("hang", "traceback", "internal_error")


@dataclass(frozen=True)
class Case:
    """One bad input: where it enters (``surface``), its name, the ``jostle`` arguments that feed it,
    the one line expected, the input's size in bytes, and optional extras: ``intact`` frames of a
    damaged recording (``kept`` read from ``summary``), bytes fed to a serial pty (the config's
    ``{pty}`` filled in), what to do to the process while it runs (``during``, in a thread: hostile
    network clients), and ``checks`` run after the process on its exit code (each returns a
    problem or None)."""

    surface: str
    name: str
    argv: tuple[str, ...]
    expect: Expect
    input_bytes: int = 0
    intact: int | None = None
    summary: Path | None = None
    pty_config: tuple[Path, str] | None = None
    pty_feed: bytes = b""
    checks: tuple[Callable[[int | None], str | None], ...] = ()
    during: Callable[[], None] | None = None
    max_line_chars: int = 2000

    @property
    def id(self) -> str:
        return f"{self.surface}-{self.name}"


@dataclass
class Outcome:
    case: str
    surface: str
    kind: str
    exit_code: int | None
    peak_rss_mb: float
    seconds: float
    line: str
    kept: int | None = None
    problems: list[str] = field(default_factory=list)


def jostle_command() -> list[str]:
    """The ``jostle`` console script beside this Python, or ``python -c`` calling its main."""
    script = Path(sys.executable).parent / "jostle"
    if script.exists():
        return [str(script)]
    return [sys.executable, "-c", "import sys; from jostle.cli import main; sys.exit(main())"]


def _peak_kb(pid: int) -> int:
    try:
        with open(f"/proc/{pid}/status") as f:
            for line in f:
                if line.startswith("VmHWM:"):
                    return int(line.split()[1])
    except (OSError, ValueError):
        pass
    return 0


def _feed(master: int, data: bytes, stop: threading.Event) -> None:
    """Write ``data`` to the pty line by line, slowly and repeatedly, until told to stop."""
    lines = data.splitlines(keepends=True) or [b""]
    while not stop.is_set():
        for line in lines:
            try:
                os.write(master, line)
            except OSError:
                return
            if stop.wait(0.01):
                return


def run_case(case: Case, *, timeout_s: float, mem_cap_mb: int, cwd: Path) -> Outcome:
    """Run ``case`` once and classify it (see the module docstring)."""
    cap = mem_cap_mb * 1024 * 1024
    argv = list(case.argv)
    master = slave = -1
    stop = threading.Event()
    if case.pty_config is not None:
        master, slave = pty.openpty()
        path, text = case.pty_config
        path.write_text(text.replace("{pty}", os.ttyname(slave)))

    def limit() -> None:  # in the child, between fork and exec: one system call, no locks
        resource.setrlimit(resource.RLIMIT_AS, (cap, cap))

    start = time.monotonic()
    proc = subprocess.Popen(jostle_command() + argv, cwd=cwd, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, preexec_fn=limit, start_new_session=True)
    feeder = None
    if case.during is not None:
        threading.Thread(target=case.during, daemon=True).start()
    if master >= 0:
        feeder = threading.Thread(target=_feed, args=(master, case.pty_feed, stop), daemon=True)
        feeder.start()
    peak_kb, hung = 0, False
    out_chunks: dict[str, bytes] = {}

    def drain(name: str, stream: IO[bytes] | None) -> None:
        out_chunks[name] = stream.read() if stream is not None else b""

    readers = [threading.Thread(target=drain, args=(n, s), daemon=True)
               for n, s in (("out", proc.stdout), ("err", proc.stderr))]
    for r in readers:
        r.start()
    try:
        while proc.poll() is None:
            peak_kb = max(peak_kb, _peak_kb(proc.pid))
            if time.monotonic() - start > timeout_s:
                hung = True
                break
            time.sleep(0.02)
    finally:  # a hang, or the bench itself interrupted: the child's whole process group goes
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
    seconds = time.monotonic() - start
    for r in readers:
        r.join(timeout=5)
    stop.set()
    if feeder is not None:
        feeder.join(timeout=2)
    for fd in (master, slave):
        if fd >= 0:
            os.close(fd)
    err = out_chunks.get("err", b"").decode(errors="replace")
    code = proc.returncode
    kind, line = _classify(err, code, hung)
    if "MemoryError" in err or "cannot allocate" in err.lower() or "bad_alloc" in err:
        peak_kb = max(peak_kb, cap // 1024)
    outcome = Outcome(case.id, case.surface, kind, None if hung else code, round(peak_kb / 1024, 1),
                      round(seconds, 2), line[:300])
    if case.summary is not None:
        outcome.kept = _kept(case.summary)
    if len(line) > case.max_line_chars:
        outcome.problems.append(f"its line is {len(line)} characters long")
    for check in case.checks:
        problem = check(outcome.exit_code)
        if problem:
            outcome.problems.append(problem)
    return outcome


def _classify(err: str, code: int | None, hung: bool) -> tuple[str, str]:
    errors = [ln for ln in err.splitlines() if "jostle: error:" in ln]
    warns = [ln for ln in err.splitlines() if "jostle: warning:" in ln]
    internal = [ln for ln in err.splitlines() if "internal error" in ln]
    first = (errors or warns or internal or [ln for ln in err.splitlines() if ln.strip()] or [""])[0]
    if hung:
        return "hang", first
    if "Traceback" in err:
        lines = err.splitlines()
        after = lines[max(i for i, ln in enumerate(lines) if "Traceback" in ln):]
        raised = [ln for ln in after[1:] if ln and not ln.startswith(" ")]
        return "traceback", raised[0] if raised else first
    if (code == 1 and internal) or (code is not None and code < 0):
        return "internal_error", first or f"killed by signal {-code if code else 0}"
    if code == 2 and len(errors) == 1:
        return "clean_error", errors[0]
    if code == 0 and len(warns) == 1 and not errors:
        return "warning", warns[0]
    if code == 0 and not warns and not errors:
        return "ok", first
    return "other", first


def _kept(summary: Path) -> int:
    """Frames a replay delivered (its summary's ``sensor_frames``); 0 when it wrote none."""
    try:
        value = json.loads(summary.read_text()).get("sensor_frames", 0)
    except (OSError, ValueError):
        return 0
    return int(value) if isinstance(value, int) else 0


def passes(case: Case, outcome: Outcome, *, mem_target_mb: float = 512.0) -> list[str]:
    """What is wrong with ``outcome`` for ``case`` (empty: it passed)."""
    wrong = list(outcome.problems)
    if outcome.kind in BAD:
        wrong.append(f"{outcome.kind}: {outcome.line}")
    elif case.expect == "error" and outcome.kind != "clean_error":
        wrong.append(f"expected one 'jostle: error:' line and exit 2, got {outcome.kind} "
                     f"(exit {outcome.exit_code}): {outcome.line}")
    elif case.expect == "warning" and outcome.kind != "warning":
        wrong.append(f"expected one 'jostle: warning:' line, got {outcome.kind} (exit {outcome.exit_code}): "
                     f"{outcome.line}")
    elif case.expect == "line" and outcome.kind not in ("clean_error", "warning"):
        wrong.append(f"expected one error or warning line, got {outcome.kind} (exit {outcome.exit_code}): "
                     f"{outcome.line}")
    elif case.expect == "ok" and outcome.kind not in ("ok", "warning"):
        wrong.append(f"expected it to be accepted, got {outcome.kind} (exit {outcome.exit_code}): {outcome.line}")
    if case.intact and (outcome.kept or 0) < 0.99 * case.intact:
        wrong.append(f"kept {outcome.kept} of the {case.intact} intact frames")
    if case.input_bytes < 10 * 1024 * 1024 and outcome.peak_rss_mb >= mem_target_mb:
        wrong.append(f"peak memory {outcome.peak_rss_mb:.0f} MB for an input of {case.input_bytes} bytes")
    return wrong
