"""Session recording in the real App: rotating files under a quota, oldest deleted, and a full disk
(a real small tmpfs, filled up mid-show) stopping the recording with one error while the show goes on."""

from __future__ import annotations

import dataclasses
import errno
import logging
import os
import shutil
import subprocess
from collections.abc import Iterator
from pathlib import Path

import pytest

from jostle.app import App, RunOptions
from jostle.config import ConfigError, JostleConfig, load_config
from jostle.session_recording import SessionRecordConfig, session_files
from sensors.clock import SimClock
from sensors.recording.info import describe_recording
from sensors.recording.replay import Replay

ROOT = Path(__file__).resolve().parent.parent


def demo(record: SessionRecordConfig, seconds: float = 8.0) -> tuple[JostleConfig, RunOptions]:
    cfg = load_config(ROOT / "configs" / "demo.toml")
    cfg = dataclasses.replace(cfg, render=dataclasses.replace(cfg.render, width=160, height=90), record=record)
    return cfg, RunOptions(out_dir=None, seed=7, duration_s=seconds, video=False, progress=False)


def frames_of(path: Path) -> list[tuple[float, int]]:
    clock = SimClock()
    replay = Replay(path, clock, channel="webcam")
    replay.open()
    out = []
    clock.advance(10_000.0)
    while (f := replay.read(0.0)) is not None:
        out.append((f.t, f.seq))
    replay.close()
    return out


def test_files_rotate_and_the_oldest_go_to_stay_under_the_quota(tmp_path: Path) -> None:
    folder = tmp_path / "sessions"
    folder.mkdir()
    (folder / "notes.txt").write_text("the operator's own file: never deleted\n")
    quota = 0.6
    cfg, options = demo(SessionRecordConfig(dir=folder, quota_mb=quota, file_minutes=10.0, min_free_mb=0.0),
                        seconds=5.0)
    app = App(cfg, options)
    totals: list[int] = []
    app.on_frame = lambda snap, obs, image: totals.append(sum(p.stat().st_size for _, p in session_files(folder)))
    summary = app.run()
    recorder = app.session_recorder
    assert recorder is not None
    health = recorder.health()
    assert health.state == "recording" and health.error == ""
    assert health.frames_written == summary.sensor_frames > 60
    assert max(totals) <= quota * 1e6 and health.bytes <= quota * 1e6  # under the quota at every frame …
    assert health.deleted_files >= 3  # … because the oldest files went
    files = session_files(folder)
    assert [n for n, _ in files] == list(range(files[0][0], files[-1][0] + 1)) and files[0][0] > 1
    assert (folder / "notes.txt").exists()
    # what is left is playable and is the end of the session, without a gap between files
    kept: list[tuple[float, int]] = []
    for _, path in files:
        info = describe_recording(path)
        assert not info.truncated
        kept += frames_of(path)
    seqs = [s for _, s in kept]
    assert seqs == list(range(seqs[0], seqs[0] + len(seqs)))
    assert 0 < len(seqs) < summary.sensor_frames


def test_files_rotate_after_file_minutes_of_loop_time(tmp_path: Path) -> None:
    cfg, options = demo(SessionRecordConfig(dir=tmp_path / "s", quota_mb=200.0, file_minutes=0.03, min_free_mb=0.0),
                        seconds=4.0)
    app = App(cfg, options)
    app.run()
    files = session_files(tmp_path / "s")
    assert [n for n, _ in files] == [1, 2, 3]  # 0-1.8 s, 1.8-3.6 s, 3.6-4 s
    spans = [frames_of(p) for _, p in files]
    for frames in spans:
        assert frames[-1][0] - frames[0][0] < 1.8
    assert sum(len(f) for f in spans) == app.session_recorder.health().frames_written  # type: ignore[union-attr]


def test_a_folder_that_cannot_be_made_stops_recording_with_one_error(tmp_path: Path,
                                                                        caplog: pytest.LogCaptureFixture) -> None:
    blocker = tmp_path / "not-a-folder"
    blocker.write_text("a file where the session folder should be")
    cfg, options = demo(SessionRecordConfig(dir=blocker / "sessions", min_free_mb=0.0), seconds=2.0)
    app = App(cfg, options)
    with caplog.at_level(logging.INFO, logger="jostle.record"):
        summary = app.run()
    assert summary.stopped_because == "duration 2 s reached" and summary.frames_rendered == 60
    health = app.session_recorder.health()  # type: ignore[union-attr]
    assert health.state == "stopped" and health.frames_written == 0
    assert health.error.startswith(("NotADirectoryError", "FileExistsError"))
    errors = [r for r in caplog.records if r.levelno >= logging.ERROR]
    assert len(errors) == 1 and "session recording stopped (the show goes on)" in errors[0].getMessage()


@pytest.fixture
def small_disk(tmp_path: Path) -> Iterator[Path]:
    """A real 2 MB filesystem (tmpfs; mounting needs root, as in CI: skipped otherwise)."""
    mount_point = tmp_path / "disk"
    mount_point.mkdir()
    if os.geteuid() != 0:
        pytest.skip("mounting a small tmpfs needs root")
    done = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=2m", "tmpfs", str(mount_point)],
                          capture_output=True, text=True, check=False)
    if done.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs here: {done.stderr.strip()}")
    try:
        yield mount_point
    finally:
        subprocess.run(["umount", "-l", str(mount_point)], check=False)


def fill(path: Path) -> int:
    """Write until the disk is full (ENOSPC); the bytes written."""
    written = 0
    with path.open("wb", buffering=0) as f:
        block = b"\xa5" * 4096
        while True:
            try:
                written += f.write(block) or 0
            except OSError as e:
                assert e.errno == errno.ENOSPC
                return written


def test_a_full_disk_stops_recording_with_one_error_and_the_show_goes_on(
        small_disk: Path, caplog: pytest.LogCaptureFixture) -> None:
    folder = small_disk / "sessions"
    cfg, options = demo(SessionRecordConfig(dir=folder, quota_mb=1.6, file_minutes=0.03, min_free_mb=0.0),
                        seconds=6.0)
    app = App(cfg, options)
    filled: list[int] = []

    def on_frame(snap: object, obs: object, image: object) -> None:
        if app.clock.now() >= 3.0 and not filled:  # another program fills the disk mid-show
            filled.append(fill(small_disk / "filler.bin"))

    app.on_frame = on_frame
    with caplog.at_level(logging.INFO, logger="jostle.record"):
        summary = app.run()
    assert summary.stopped_because == "duration 6 s reached" and summary.frames_rendered == 180
    health = app.session_recorder.health()  # type: ignore[union-attr]
    assert health.state == "stopped" and "No space left on device" in health.error
    errors = [r for r in caplog.records if r.levelno >= logging.ERROR]
    assert len(errors) == 1
    assert 0 < health.frames_written < summary.sensor_frames
    # the file being written when the disk filled was deleted (the disk needs the room); the ones
    # closed before are whole and playable
    files = session_files(folder)
    assert files and health.current == ""
    for _, path in files:
        assert not describe_recording(path).truncated
    assert sum(len(frames_of(p)) for _, p in files) < health.frames_written


def test_on_a_short_disk_the_files_shrink_to_keep_min_free_mb_free(small_disk: Path) -> None:
    folder = small_disk / "sessions"
    cfg, options = demo(SessionRecordConfig(dir=folder, quota_mb=100.0, file_minutes=10.0, min_free_mb=0.5),
                        seconds=5.0)
    app = App(cfg, options)
    free: list[int] = []
    app.on_frame = lambda snap, obs, image: free.append(shutil.disk_usage(small_disk).free)
    app.run()
    health = app.session_recorder.health()  # type: ignore[union-attr]
    assert health.state == "recording" and health.deleted_files >= 1
    assert health.budget_bytes <= 2 * 1024 * 1024 - 0.5e6  # the 2 MiB disk less 0.5 MB, not the 100 MB quota
    assert min(free) >= 0.5e6 - 64 * 1024  # at most a chunk in flight beyond the budget


def test_the_record_table_of_a_config(tmp_path: Path) -> None:
    text = (ROOT / "configs" / "demo.toml").read_text()
    for folder in ("recordings/", "characters/", "keyframes/"):
        text = text.replace(f'"{folder}', f'"{ROOT}/configs/{folder}')
    path = tmp_path / "kiosk.toml"
    path.write_text(text + '\n[record]\ndir = "sessions"\nquota_mb = 500\nfile_minutes = 5\n')
    cfg = load_config(path)
    assert cfg.record == SessionRecordConfig(dir=tmp_path / "sessions", quota_mb=500.0, file_minutes=5.0)
    assert cfg.record.enabled and not load_config(ROOT / "configs" / "demo.toml").record.enabled
    path.write_text(text + "\n[record]\ndir = \"s\"\nquota_mb = -1\n")
    with pytest.raises(ConfigError, match=r"record.*quota_mb: expected MB ≥ 0.1, got -1"):
        load_config(path)
    path.write_text(text + "\n[record]\ndir = \"s\"\nquota = 10\n")
    with pytest.raises(ConfigError, match="quota"):
        load_config(path)
