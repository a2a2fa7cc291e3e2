"""The smaller commands: record, info, doctor, synth, and --help everywhere."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from jostle.cli import main
from sensors.recording.info import describe_recording
from sensors.recording.source import iter_frames

ROOT = Path(__file__).resolve().parent.parent
DEMO = ROOT / "configs" / "demo.toml"


def test_record_a_replay_keeps_every_frame_and_time(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "again.mcap"
    assert main(["record", str(DEMO), "--out", str(out), "--duration", "2"]) == 0
    info = describe_recording(out)
    (channel,) = info.channels
    assert channel.topic == "webcam" and channel.message_count == 31 and info.complete
    original = [(f.t, f.seq, f.payload.size) for f in iter_frames(ROOT / "configs/recordings/demo.mcap")][:31]
    again = [(f.t, f.seq, f.payload.size) for f in iter_frames(out)]
    assert again == original
    # never overwrite by accident
    assert main(["record", str(DEMO), "--out", str(out), "--duration", "1"]) == 2
    assert "exists already" in capsys.readouterr().err


def test_info_json(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["info", str(ROOT / "configs/recordings/demo.mcap"), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["channels"][0]["topic"] == "webcam" and doc["channels"][0]["message_count"] == 240


def test_doctor_answers_for_every_device_kind(capsys: pytest.CaptureFixture[str]) -> None:
    code = main(["doctor", "--json", "--timeout", "20"])
    checks = {c["name"]: c for c in json.loads(capsys.readouterr().out)}
    assert code in (0, 1)
    for name in ("python", "headless OpenGL (EGL)", "serial ports", "DepthAI devices", "disk space here"):
        assert name in checks, name
    assert checks["headless OpenGL (EGL)"]["status"] == "ok", checks["headless OpenGL (EGL)"]
    assert any(n.startswith("camera") for n in checks)


def test_synth_performer_writes_recording_and_calibration(tmp_path: Path) -> None:
    out = tmp_path / "p.mcap"
    assert main(["synth", "performer", "--clip", "walk", "--duration", "1", "--size", "160x120",
                 "--out", str(out)]) == 0
    assert describe_recording(out).channels[0].message_count == 15
    from interaction.webcam.calibration import Calibration

    calibration = Calibration.load(out.with_suffix(".calibration.toml"))
    assert calibration.plane_y == 0.0


@pytest.mark.parametrize(
    "argv",
    [[], ["run"], ["replay"], ["record"], ["info"], ["synth", "performer"], ["doctor"], ["bench"],
     ["keyframes", "build-default"]],
)
def test_every_command_has_help(argv: list[str], capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as done:
        main([*argv, "--help"])
    assert done.value.code == 0
    text = capsys.readouterr().out
    assert "usage: jostle" in text and len(text) > 200
