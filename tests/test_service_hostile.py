"""``jostle service install`` with hostile values: every value quoted by systemd's rules (checked by
``systemd-analyze verify``), a newline or control character anywhere refused with one line and no
unit written, special files at the unit's path never replaced."""

from __future__ import annotations

import os
import shutil
import subprocess
from pathlib import Path

import pytest

from jostle.cli import main
from jostle.cli.service_unit import unit_name

ROOT = Path(__file__).resolve().parent.parent
INJECTED = "ExecStartPre=/bin/touch /tmp/jostle-injected"


def _config(folder: Path, stem: str = "show") -> Path:
    """The demo config (content paths absolute) in ``folder``, named ``stem``.toml."""
    text = (ROOT / "configs" / "demo.toml").read_text()
    for sub in ("recordings", "characters", "keyframes"):
        text = text.replace(f'"{sub}/', f'"{ROOT}/configs/{sub}/')
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / f"{stem}.toml"
    path.write_text(text)
    return path


def _one_error(capsys: pytest.CaptureFixture[str]) -> str:
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("jostle: error: "), err
    return err[0]


def _verify(unit: Path) -> None:
    r = subprocess.run(["systemd-analyze", "verify", str(unit)], capture_output=True, text=True, timeout=60)
    if "Failed to initialize manager" in r.stderr:
        pytest.skip("systemd-analyze cannot run here")
    assert r.returncode == 0 and r.stderr.strip() == "", r.stderr  # systemd warns of any line it ignores


FOLDERS = ["my show", "it's \"quoted\"", "cost$HOME", "a;b", "back\\slash", "Zürich", "100%", "end "]


@pytest.mark.skipif(shutil.which("systemd-analyze") is None, reason="systemd-analyze is not installed")
@pytest.mark.parametrize("folder", FOLDERS)
def test_systemd_accepts_a_unit_for_a_config_in_any_folder(tmp_path: Path, folder: str) -> None:
    path = _config(tmp_path / folder)
    units = tmp_path / "units"
    out = tmp_path / folder / "out dir $x"
    assert main(["service", "install", str(path), "--unit-dir", str(units), "--run-as", "root",
                 "--mode", "window", "--display", 'host:0 "$x%', "--out", str(out)]) == 0
    unit = units / unit_name(path)
    text = unit.read_text()
    work = next(line for line in text.splitlines() if line.startswith("WorkingDirectory="))
    # systemd takes WorkingDirectory= verbatim (no quotes); % is its specifier escape
    assert work.removeprefix("WorkingDirectory=").replace("%%", "%").rstrip("/") == str(path.parent).rstrip("/")
    _verify(unit)


@pytest.mark.parametrize("flag", ["--display", "--run-as", "--out", "--name"])
def test_a_newline_in_any_flag_is_refused_with_one_line_and_no_unit(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], flag: str
) -> None:
    path = _config(tmp_path)
    units = tmp_path / "units"
    value = f"/tmp/x\n{INJECTED}" if flag == "--out" else f":0\n{INJECTED}"
    assert main(["service", "install", str(path), "--unit-dir", str(units), "--run-as", "root", flag, value]) == 2
    line = _one_error(capsys)
    assert "newline" in line and flag in line
    assert not units.exists()


def test_display_from_the_environment_and_control_characters_are_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    path = _config(tmp_path)
    units = tmp_path / "units"
    monkeypatch.setenv("DISPLAY", f":0\n{INJECTED}")
    assert main(["service", "install", str(path), "--user", "--unit-dir", str(units)]) == 2
    assert "$DISPLAY" in _one_error(capsys)
    monkeypatch.setenv("DISPLAY", ":0\x1b[2J")
    assert main(["service", "install", str(path), "--user", "--unit-dir", str(units)]) == 2
    assert "U+001B" in _one_error(capsys)
    monkeypatch.delenv("DISPLAY")
    assert main(["service", "install", str(path), "--user", "--unit-dir", str(units)]) == 0
    assert '"DISPLAY=:0"' in (units / unit_name(path)).read_text()


def test_a_newline_in_the_config_path_is_refused(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = _config(tmp_path / f"x\n{INJECTED}")
    units = tmp_path / "units"
    assert main(["service", "install", str(path), "--user", "--unit-dir", str(units)]) == 2
    assert "config: holds a newline" in _one_error(capsys) and not units.exists()


def test_names_without_letters_are_a_user_error(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = _config(tmp_path)
    units = tmp_path / "units"
    assert main(["service", "install", str(path), "--user", "--unit-dir", str(units), "--name", "!!!"]) == 2
    assert "--name: '!!!' leaves no letters" in _one_error(capsys)
    bang = _config(tmp_path / "b", "!!!")
    assert main(["service", "install", str(bang), "--user", "--unit-dir", str(units)]) == 2
    assert "give one with --name" in _one_error(capsys)
    assert main(["service", "uninstall", "!!!", "--user", "--unit-dir", str(units)]) == 2
    _one_error(capsys)
    assert not units.exists()
    assert main(["service", "install", str(path), "--user", "--unit-dir", str(units), "--name", "a b!c"]) == 0
    assert (units / "jostle-a-b-c.service").is_file()


def test_a_fifo_where_the_unit_goes_is_refused_and_left(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = _config(tmp_path)
    units = tmp_path / "units"
    units.mkdir()
    fifo = units / unit_name(path)
    os.mkfifo(fifo)
    assert main(["service", "install", str(path), "--user", "--unit-dir", str(units), "--force"]) == 2
    assert "is a FIFO" in _one_error(capsys)
    assert fifo.is_fifo()
    assert main(["service", "install", str(path), "--user", "--unit-dir", str(units)]) == 2  # without --force
    assert "is a FIFO" in _one_error(capsys) and fifo.is_fifo()


def test_a_unit_dir_that_is_a_file_is_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = _config(tmp_path)
    blocker = tmp_path / "a-file"
    blocker.write_text("")
    assert main(["service", "install", str(path), "--user", "--unit-dir", str(blocker / "units")]) == 2
    assert "cannot make the folder for the unit" in _one_error(capsys)
