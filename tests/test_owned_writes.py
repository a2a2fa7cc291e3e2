"""Files the run writes go only where a regular file is or nothing is: the summary and session
recordings refuse a FIFO, a device or a symlink by name and leave it as it is; session
files named like ours that are not regular files are never deleted."""

from __future__ import annotations

import dataclasses
import os
import stat
from pathlib import Path

import pytest

from jostle.session_recording import SessionRecordConfig, SessionRecorder
from jostle.summary import RunSummary
from sensors.base import Frame
from sensors.clock import SimClock
from sensors.recording.replay import Replay
from sensors.untrusted import UntrustedInput, check_owned

ROOT = Path(__file__).resolve().parent.parent
FIXTURE = ROOT / "tests" / "fixtures" / "crossing2.mcap"


def _kind(path: Path) -> int:
    return stat.S_IFMT(os.lstat(path).st_mode)


def _specials(tmp_path: Path) -> list[Path]:
    fifo = tmp_path / "fifo"
    os.mkfifo(fifo)
    link = tmp_path / "link"
    (tmp_path / "theirs.txt").write_text("theirs\n")
    link.symlink_to(tmp_path / "theirs.txt")
    return [fifo, link, Path("/dev/full")]


def test_the_summary_refuses_special_files(tmp_path: Path) -> None:
    for path in _specials(tmp_path):
        before = _kind(path)
        with pytest.raises(UntrustedInput, match=f"^{path}: is a ") as e:
            RunSummary().write(path)
        assert "\n" not in str(e.value)
        with pytest.raises(UntrustedInput, match=f"^{path}: is a "):
            check_owned(path)
        assert _kind(path) == before
    assert (tmp_path / "theirs.txt").read_text() == "theirs\n"
    RunSummary().write(tmp_path / "summary.json")  # a regular file (or none) is fine
    assert check_owned(tmp_path / "summary.json") == tmp_path / "summary.json"


def _frames(n: int) -> list[Frame]:
    clock = SimClock()
    replay = Replay(FIXTURE, clock, channel="webcam")
    replay.open()
    clock.advance(10_000.0)
    out: list[Frame] = []
    while len(out) < n and (f := replay.read(0.0)) is not None:
        out.append(f)
    replay.close()
    return out


def test_session_files_that_are_not_ours_are_never_deleted_nor_written(tmp_path: Path) -> None:
    folder = tmp_path / "sessions"
    folder.mkdir()
    os.mkfifo(folder / "session-000001.mcap")
    (tmp_path / "theirs.mcap").write_bytes(b"theirs")
    (folder / "session-000002.mcap").symlink_to(tmp_path / "theirs.mcap")
    recorder = SessionRecorder(SessionRecordConfig(dir=folder, quota_mb=0.6, file_minutes=0.01, min_free_mb=0.0))
    clip = _frames(1000)
    span = clip[-1].t - clip[0].t + 1 / 30
    frames = [dataclasses.replace(f, t=f.t + k * span, seq=f.seq + k * len(clip)) for k in range(6) for f in clip]
    for f in frames:
        recorder.write(f)
    recorder.close()
    health = recorder.health()
    assert health.state == "recording" and health.frames_written == len(frames)
    assert health.deleted_files >= 1  # the quota made it delete: only its own files
    assert stat.S_ISFIFO(os.lstat(folder / "session-000001.mcap").st_mode)
    assert (folder / "session-000002.mcap").is_symlink() and (tmp_path / "theirs.mcap").read_bytes() == b"theirs"
    ours = sorted(p.name for p in folder.iterdir() if p.is_file() and not p.is_symlink())
    assert ours and all(name > "session-000002.mcap" for name in ours)
