"""Bad input never gives a traceback: one line naming what is wrong, exit status 2."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from jostle.cli import main

ROOT = Path(__file__).resolve().parent.parent
DEMO = ROOT / "configs" / "demo.toml"


def _copy_demo(tmp_path: Path, text: str | None = None) -> Path:
    """A copy of the configs folder, so relative paths keep working, with demo.toml replaced."""
    dst = tmp_path / "configs"
    shutil.copytree(ROOT / "configs", dst, ignore=shutil.ignore_patterns("*.mcap"))
    rec = ROOT / "configs" / "recordings" / "demo.mcap"
    (dst / "recordings" / "demo.mcap").symlink_to(rec)
    if text is not None:
        (dst / "demo.toml").write_text(text)
    return dst / "demo.toml"


def _run(args: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str]:
    code = main(args)
    err = capsys.readouterr().err.strip()
    return code, err


def _one_line_error(err: str) -> str:
    lines = [ln for ln in err.splitlines() if ln.startswith("jostle: error:")]
    assert len(lines) == 1, err
    assert "Traceback" not in err
    return lines[0]


def test_wrong_type_names_file_and_key(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    text = DEMO.read_text().replace("fps = 30", 'fps = "fast"', 1)
    assert text != DEMO.read_text(), "demo.toml must have a render fps to mutate"
    cfg = _copy_demo(tmp_path, text)
    code, err = _run(["run", str(cfg), "--out", str(tmp_path / "out")], capsys)
    line = _one_line_error(err)
    assert code == 2
    assert f"{cfg}: render.fps: expected a number, got 'fast'" in line


def test_unknown_key_is_rejected(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    cfg = _copy_demo(tmp_path, DEMO.read_text().replace("[render]", "[render]\nfsp = 30", 1))
    code, err = _run(["run", str(cfg), "--out", str(tmp_path / "out")], capsys)
    line = _one_line_error(err)
    assert code == 2 and "render.fsp: unknown key" in line and str(cfg) in line


def test_unknown_sensor_type_lists_known(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    cfg = _copy_demo(tmp_path, DEMO.read_text().replace('type = "replay"', 'type = "kinect"', 1))
    code, err = _run(["run", str(cfg)], capsys)
    line = _one_line_error(err)
    assert code == 2 and "unknown type 'kinect'" in line and "replay" in line and "webcam" in line


def test_missing_config_file(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    missing = tmp_path / "nope.toml"
    code, err = _run(["run", str(missing)], capsys)
    assert code == 2 and f"{missing}: no such config file" in _one_line_error(err)


def test_config_that_is_not_toml(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    bad = tmp_path / "bad.toml"
    bad.write_text("[sensors\nthis is not toml")
    code, err = _run(["run", str(bad)], capsys)
    assert code == 2 and f"{bad}: not valid TOML" in _one_line_error(err)


def test_missing_recording_named_in_config(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    cfg = _copy_demo(tmp_path)
    (cfg.parent / "recordings" / "demo.mcap").unlink()
    code, err = _run(["run", str(cfg), "--out", str(tmp_path / "out")], capsys)
    line = _one_line_error(err)
    assert code == 2 and "demo.mcap" in line


def test_recording_that_is_not_mcap(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    junk = tmp_path / "junk.mcap"
    junk.write_bytes(b"this is not a recording at all\n" * 10)
    code, err = _run(["info", str(junk)], capsys)
    line = _one_line_error(err)
    assert code == 2 and str(junk) in line and "not an MCAP recording" in line
    code, err = _run(["replay", str(junk), "--config", str(DEMO), "--out", str(tmp_path / "o")], capsys)
    assert code == 2 and str(junk) in _one_line_error(err)


def test_truncated_recording_replays_what_it_has(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    data = (ROOT / "configs" / "recordings" / "demo.mcap").read_bytes()
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(data[: len(data) // 3])
    code, err = _run(["info", str(cut)], capsys)
    assert code == 0, err
    out_dir = tmp_path / "out"
    code, err = main(["replay", str(cut), "--config", str(DEMO), "--out", str(out_dir), "--no-video",
                      "--quiet"]), capsys.readouterr().err
    assert code == 0, err
    assert str(cut) in err and "Traceback" not in err  # the warning names the file
    assert (out_dir / "summary.json").exists()


def test_missing_recording_on_command_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code, err = _run(["info", str(tmp_path / "absent.mcap")], capsys)
    assert code == 2 and "absent.mcap" in _one_line_error(err)
