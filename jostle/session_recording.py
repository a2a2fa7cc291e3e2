"""Session recording: the live sensor frames into rotating MCAP files that stay under a quota.

``[record] dir = "sessions", quota_mb = 2000, file_minutes = 10`` records every frame the sensors
deliver while the show runs (:class:`sensors.recording.writer.RecordingWriter`, one channel per sensor; a file
replays with ``jostle replay``) into ``dir/session-000001.mcap``, … (numbering goes on after the files
already there; larger numbers are newer).

- A file is closed and the next one begun after ``file_minutes`` of loop time, or when it reaches
  a quarter of the quota (so at least four files share the quota and deleting one frees room).
- Before each new file the budget is worked out: ``quota_mb``, or less if the disk is short (the
  session files plus the free space, less ``min_free_mb``); a file may grow to a quarter of it, and the
  oldest session files are deleted until the closed ones plus one full file fit: they never pass the
  quota nor take the disk's last ``min_free_mb``. Only ``session-NNNNNN.mcap`` in ``dir`` are deleted.
- If the budget is too small for any file (the disk filled by something else), or a write fails
  (ENOSPC, EIO, a folder made read-only, …), recording stops with ONE error in the log and the
  show goes on. A file cut by ENOSPC is deleted (the disk needs the room); another failed file is
  kept as written (a replay plays it up to the damage).

All decisions are made on the loop's clock (frame times), so on a SimClock they repeat exactly.
"""

from __future__ import annotations

import errno
import logging
import math
import re
import shutil
import stat
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

from sensors.base import Frame
from sensors.recording.writer import RecordingWriter
from sensors.untrusted import check_owned

log = logging.getLogger("jostle.record")

_NAME = re.compile(r"session-(\d{6,})\.mcap")
_MB = 1_000_000
_CHUNK_MAX = 512 * 1024
_SUMMARY_ROOM = 64 * 1024  # the index and summary a file gets when it is closed, with room to spare
_MIN_BUDGET = 4 * (64 * 1024 + _SUMMARY_ROOM)  # four files of at least a small chunk each

RecordingState = Literal["off", "recording", "stopped"]


@dataclass(frozen=True)
class SessionRecordConfig:
    """``[record]``: record the live sensors while the show runs (off unless ``dir`` is set).

    ``dir``: the folder of the session files (relative to the config file). ``quota_mb``: the most
    the session files may take together, in MB (10⁶ bytes). ``file_minutes``: loop minutes per
    file. ``min_free_mb``: room always left free on the disk. ``jpeg_quality``: colour frames'.
    """

    dir: Path = Path()
    quota_mb: float = 2000.0
    file_minutes: float = 10.0
    min_free_mb: float = 500.0
    jpeg_quality: int = 85

    def __post_init__(self) -> None:
        if not _number(self.quota_mb) or self.quota_mb < 0.1:
            raise ValueError(f"quota_mb: expected MB ≥ 0.1, got {self.quota_mb!r}")
        if not _number(self.file_minutes) or self.file_minutes <= 0:
            raise ValueError(f"file_minutes: expected minutes > 0, got {self.file_minutes!r}")
        if not _number(self.min_free_mb) or self.min_free_mb < 0:
            raise ValueError(f"min_free_mb: expected MB ≥ 0, got {self.min_free_mb!r}")
        if isinstance(self.jpeg_quality, bool) or not isinstance(self.jpeg_quality, int) \
                or not 1 <= self.jpeg_quality <= 100:
            raise ValueError(f"jpeg_quality: expected a whole number from 1 to 100, got {self.jpeg_quality!r}")

    @property
    def enabled(self) -> bool:
        return self.dir != Path()


def _number(value: object) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)


@dataclass(frozen=True, slots=True)
class RecordingHealth:
    """What session recording is doing (for the health report)."""

    state: RecordingState  # "off": not configured; "stopped": gave up after an error (see error)
    dir: str
    files: int  # session files in dir now
    bytes: int  # their size together (the one being written as far as it is on disk)
    quota_bytes: int
    budget_bytes: int  # what the session files may take now: the quota, less if the disk is short
    current: str  # the file being written ("" if none)
    frames_written: int  # frames recorded this run
    deleted_files: int  # old session files deleted this run to stay under quota / keep the disk free
    error: str  # why recording stopped ("" while fine)


def session_files(folder: Path) -> list[tuple[int, Path]]:
    """(number, path) of the session files in ``folder``, oldest (lowest number) first."""
    try:
        entries = list(folder.iterdir())
    except OSError:
        return []
    found = [(int(m.group(1)), p) for p in entries if (m := _NAME.fullmatch(p.name))]
    return sorted(found)


def _regular(path: Path) -> bool:
    """A regular file, not a symlink: a FIFO, device or link named like a session file is not ours."""
    try:
        return stat.S_ISREG(path.lstat().st_mode)
    except OSError:
        return False


def _size(path: Path) -> int:
    try:
        return path.stat().st_size
    except OSError:
        return 0


class SessionRecorder:
    """Writes frames to rotating session files (see the module docstring). ``write`` never raises."""

    def __init__(self, config: SessionRecordConfig, metadata: dict[str, str] | None = None) -> None:
        if not config.enabled:
            raise ValueError("dir: session recording needs a folder ([record] dir = \"...\")")
        self.config = config
        self.folder = config.dir
        self.quota_bytes = int(config.quota_mb * _MB)
        self.budget_bytes = self.quota_bytes  # what the session files may take now (less on a short disk)
        self.file_max_bytes = self.quota_bytes // 4
        self._chunk = max(16 * 1024, min(_CHUNK_MAX, self.file_max_bytes // 16))
        self._metadata = dict(metadata or {})
        self._writer: RecordingWriter | None = None
        self._file_t0 = 0.0
        self._number = 0
        self._state: RecordingState = "recording"
        self._error = ""
        self.frames_written = 0
        self.deleted_files = 0

    # ------------------------------------------------------------------ the loop's calls

    def write(self, frame: Frame) -> None:
        """Record one frame (rotating files as needed). After an error: does nothing."""
        if self._state != "recording":
            return
        try:
            writer = self._writer
            if writer is None or self._due(frame.t, writer):
                writer = self._next_file(frame.t)
                if writer is None:
                    return
            writer.write(frame)
            self.frames_written += 1
        except Exception as e:  # a recording must never take the show down
            self._stop(e)

    def close(self) -> None:
        """Finish the file being written (the show is over)."""
        if self._writer is not None:
            writer, self._writer = self._writer, None
            try:
                writer.close()
            except Exception as e:
                self._stop(e, writer)

    def health(self) -> RecordingHealth:
        files = session_files(self.folder)
        return RecordingHealth(
            state=self._state, dir=str(self.folder), files=len(files), bytes=sum(_size(p) for _, p in files),
            quota_bytes=self.quota_bytes, budget_bytes=self.budget_bytes, current=str(self._writer.path) if self._writer is not None else "",
            frames_written=self.frames_written, deleted_files=self.deleted_files, error=self._error,
        )

    @property
    def state(self) -> RecordingState:
        return self._state

    # ------------------------------------------------------------------ files

    def _due(self, t: float, writer: RecordingWriter) -> bool:
        if t - self._file_t0 >= self.config.file_minutes * 60.0:
            return True
        return _size(writer.path) + self._chunk + _SUMMARY_ROOM >= self.file_max_bytes

    def _next_file(self, t: float) -> RecordingWriter | None:
        if self._writer is not None:
            old, self._writer = self._writer, None
            old.close()
        self.folder.mkdir(parents=True, exist_ok=True)
        if not self._make_room():
            return None
        existing = session_files(self.folder)
        self._number = max([self._number, *(n for n, _ in existing)]) + 1
        path = check_owned(self.folder / f"session-{self._number:06d}.mcap")  # never into a FIFO or device
        self._writer = RecordingWriter(path, metadata={"session_file": str(self._number), **self._metadata},
                                       jpeg_quality=self.config.jpeg_quality, chunk_size=self._chunk)
        self._file_t0 = t
        log.info("recording the session to %s", path)
        return self._writer

    def _make_room(self) -> bool:
        """Size the next file and delete the oldest session files so that it fits: the budget is the
        quota, or less when the disk is short (what the session files hold plus the free space, less
        ``min_free_mb``); a file is a quarter of the budget. False (recording stopped) when the
        budget is too small for even a small file."""
        files = [(n, p) for n, p in session_files(self.folder) if _regular(p)]  # only ours are deleted
        used = sum(_size(p) for _, p in files)
        free = shutil.disk_usage(self.folder).free
        budget = min(self.quota_bytes, used + free - int(self.config.min_free_mb * _MB))
        if budget < _MIN_BUDGET:
            self._stop(OSError(errno.ENOSPC, f"the disk of {self.folder} is nearly full: {free / _MB:.1f} MB free, "
                                             f"min_free_mb = {self.config.min_free_mb:g}, session files "
                                             f"{used / _MB:.1f} MB; no room for a session file"))
            return False
        self.budget_bytes = budget
        self.file_max_bytes = budget // 4
        self._chunk = max(16 * 1024, min(_CHUNK_MAX, self.file_max_bytes // 16))
        while files and used + self.file_max_bytes > budget:
            _, oldest = files.pop(0)
            used -= _size(oldest)
            oldest.unlink(missing_ok=True)
            self.deleted_files += 1
            log.info("deleted the oldest session file %s (budget %.1f MB)", oldest, budget / _MB)
        return True

    def _stop(self, e: BaseException, writer: RecordingWriter | None = None) -> None:
        """Give up recording for the rest of the run, with one error."""
        writer = writer or self._writer
        self._writer = None
        if writer is not None:
            try:
                writer.close()
            except Exception:
                pass  # the error that matters is the first one
            if isinstance(e, OSError) and e.errno == errno.ENOSPC:
                writer.path.unlink(missing_ok=True)
        self._state = "stopped"
        self._error = f"{type(e).__name__}: {e}".splitlines()[0][:300]
        log.error("session recording stopped (the show goes on): %s", self._error)
