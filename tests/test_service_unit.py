"""``jostle service install|uninstall``: the unit's content (checked by systemd-analyze when present),
files written and removed; and journal logging (priority prefixes, JOURNAL_STREAM detection)."""

from __future__ import annotations

import logging
import os
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from jostle.cli import main
from jostle.cli.journal import JournalFormatter, priority, under_journal
from jostle.cli.service_unit import OPERATOR_EXIT, UnitSpec, unit_name, unit_text

ROOT = Path(__file__).resolve().parent.parent
JOSTLE = Path(os.path.abspath(sys.executable)).parent / "jostle"


def _config(tmp_path: Path, health: str = "") -> Path:
    """The demo config in tmp_path (its content paths made absolute), with a [health] table of our own."""
    text = (ROOT / "configs" / "demo.toml").read_text()
    for folder in ("recordings", "characters", "keyframes"):
        text = text.replace(f'"{folder}/', f'"{ROOT}/configs/{folder}/')
    path = tmp_path / "show.toml"
    path.write_text(text + ("\n[health]\n" + health if health else ""))
    return path


def _fields(text: str) -> dict[str, list[str]]:
    out: dict[str, list[str]] = {}
    for line in text.splitlines():
        if "=" in line and not line.startswith("#"):
            k, v = line.split("=", 1)
            out.setdefault(k, []).append(v)
    return out


def test_install_writes_a_notify_unit_with_the_configs_watchdog(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = _config(tmp_path, "watchdog_s = 45.0\nrestart_s = 7.0\nstall_s = 4.0")
    units = tmp_path / "units"
    assert main(["service", "install", str(path), "--user", "--unit-dir", str(units), "--display", ":3"]) == 0
    out = capsys.readouterr().out
    name = unit_name(path)
    unit = (units / name).read_text()
    f = _fields(unit)
    assert f["Type"] == ["notify"] and f["Restart"] == ["always"] and f["NotifyAccess"] == ["main"]
    assert f["WatchdogSec"] == ["45"] and f["RestartSec"] == ["7"]
    assert f["StartLimitIntervalSec"] == ["0"]  # never gives up restarting
    assert f["RestartPreventExitStatus"] == [str(OPERATOR_EXIT)]
    exec_start = f["ExecStart"][0].split()
    assert exec_start[:3] == [str(JOSTLE), "run", str(path.resolve())]
    assert Path(exec_start[0]).is_absolute() and os.access(exec_start[0], os.X_OK)
    assert "--kiosk" in exec_start and "--no-video" in exec_start  # weeks of video would fill the disk
    assert '"DISPLAY=:3"' in f["Environment"]  # quoted by systemd's rules
    assert f["WantedBy"] == ["default.target"]
    short = name.removesuffix(".service")
    assert f"systemctl --user daemon-reload && systemctl --user enable --now {short}" in out
    assert f"journalctl --user -u {short}" in out


def test_headless_system_units_have_no_display_and_run_as_a_user(tmp_path: Path) -> None:
    spec = UnitSpec(name="jostle-x.service", jostle=JOSTLE, config=ROOT / "configs" / "demo.toml",
                    out_dir=Path("/var/lib/jostle/x"), mode="headless", user_unit=False, run_as="kiosk")
    f = _fields(unit_text(spec))
    assert "Environment" in f and not [e for e in f["Environment"] if e.startswith("DISPLAY")]
    assert f["User"] == ["kiosk"] and f["StateDirectory"] == ["jostle/x"]
    assert f["WantedBy"] == ["multi-user.target"]
    with pytest.raises(ValueError, match="^config: expected an absolute path"):
        UnitSpec(name="jostle-x.service", jostle=JOSTLE, config=Path("configs/demo.toml"), out_dir=Path("/tmp/x"))
    assert unit_name(Path("a b%c.toml")) == "jostle-a-b-c.service"
    spaced = UnitSpec(name="jostle-x.service", jostle=JOSTLE, config=Path("/srv/my shows/100%.toml"),
                      out_dir=Path("/tmp/x"), mode="headless")
    assert '"/srv/my shows/100%%.toml"' in unit_text(spaced)  # quoted; % is systemd's specifier escape


@pytest.mark.skipif(shutil.which("systemd-analyze") is None, reason="systemd-analyze is not installed")
def test_systemd_accepts_the_unit(tmp_path: Path) -> None:
    units = tmp_path / "units"
    path = _config(tmp_path)
    assert main(["service", "install", str(path), "--unit-dir", str(units), "--run-as", "root"]) == 0
    unit = units / unit_name(path)
    r = subprocess.run(["systemd-analyze", "verify", str(unit)], capture_output=True, text=True, timeout=60)
    if "Failed to initialize manager" in r.stderr:
        pytest.skip("systemd-analyze cannot run here")
    assert r.returncode == 0 and r.stderr.strip() == "", r.stderr  # systemd warns of any line it ignores


def test_dry_run_changes_nothing_and_uninstall_removes_the_unit_and_its_links(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    units = tmp_path / "units"
    path = _config(tmp_path)
    name = unit_name(path)
    assert main(["service", "install", str(path), "--user", "--unit-dir", str(units), "--dry-run"]) == 0
    assert "Type=notify" in capsys.readouterr().out and not units.exists()
    assert main(["service", "install", str(path), "--user", "--unit-dir", str(units)]) == 0
    (units / "default.target.wants").mkdir()
    (units / "default.target.wants" / name).symlink_to(units / name)  # what `systemctl enable` makes
    assert main(["service", "install", str(path), "--user", "--unit-dir", str(units), "--mode", "headless"]) == 2
    assert "exists; use --force" in capsys.readouterr().err
    assert main(["service", "uninstall", str(path), "--user", "--unit-dir", str(units), "--dry-run"]) == 0
    assert (units / name).exists()
    assert main(["service", "uninstall", name.removesuffix(".service"), "--user", "--unit-dir", str(units)]) == 0
    assert not (units / name).exists() and not (units / "default.target.wants" / name).is_symlink()
    assert f"systemctl --user stop {name.removesuffix('.service')}" in capsys.readouterr().out
    assert main(["service", "uninstall", str(path), "--user", "--unit-dir", str(units)]) == 2


def test_a_config_that_does_not_load_gets_no_unit(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    bad = tmp_path / "bad.toml"
    bad.write_text("[health]\nwatchdog_s = -1\n[sensors.x]\ntype = 'replay'\npath = 'nope.mcap'\n")
    assert main(["service", "install", str(bad), "--user", "--unit-dir", str(tmp_path / "u")]) == 2
    assert f"{bad}:" in capsys.readouterr().err and not (tmp_path / "u").exists()


# ------------------------------------------------------------------ the journal


def test_journal_lines_carry_the_priority_and_one_record_stays_one_line() -> None:
    fmt = JournalFormatter()
    rec = logging.LogRecord("jostle.app", logging.WARNING, __file__, 1, 'sensor "webcam"\nreconnecting', (), None)
    assert fmt.format(rec) == '<4>level=warning logger=jostle.app msg="sensor \\"webcam\\"\\nreconnecting"'
    try:
        raise ValueError("bad frame")
    except ValueError:
        rec = logging.LogRecord("jostle.x", logging.ERROR, __file__, 1, "observer crashed", (), sys.exc_info())
    line = fmt.format(rec)
    assert line.startswith("<3>level=error logger=jostle.x msg=\"observer crashed\" exc=\"Traceback")
    assert "\n" not in line and "ValueError: bad frame" in line
    assert [priority(v) for v in (50, 40, 30, 20, 10)] == [2, 3, 4, 6, 7]


def test_journal_format_only_when_stderr_is_the_stream_systemd_named(tmp_path: Path) -> None:
    log = tmp_path / "stderr.log"
    log.write_text("")
    st = log.stat()
    script = textwrap.dedent("""
        import logging, sys
        from jostle.cli.journal import adopt_journal
        logging.basicConfig(format="plain: %(message)s")
        print(adopt_journal(), file=sys.stdout)
        logging.getLogger("jostle.t").warning("hello")
    """)
    for stream, expect in ((f"{st.st_dev}:{st.st_ino}", "<4>level=warning logger=jostle.t msg=hello"),
                           ("1:2", "plain: hello")):
        with log.open("w") as err:
            r = subprocess.run([sys.executable, "-c", script], stderr=err, stdout=subprocess.PIPE, text=True,
                               env={**os.environ, "JOURNAL_STREAM": stream}, cwd=ROOT, timeout=60)
        assert r.returncode == 0
        assert log.read_text().strip() == expect
        assert r.stdout.strip() == str(expect.startswith("<4>"))
    assert not under_journal({})


def test_command_line_errors_carry_the_error_priority_under_the_journal(tmp_path: Path) -> None:
    log = tmp_path / "stderr.log"
    log.write_text("")
    st = log.stat()
    with log.open("w") as err:
        r = subprocess.run([str(JOSTLE), "info", str(tmp_path / "missing.mcap")], stderr=err, timeout=60,
                           env={**os.environ, "JOURNAL_STREAM": f"{st.st_dev}:{st.st_ino}"})
    assert r.returncode == 2
    assert log.read_text().startswith(f"<3>jostle: error: {tmp_path / 'missing.mcap'}")
