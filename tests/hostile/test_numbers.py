"""Numbers at the config and command-line boundary: nan, inf, 1e308 and negative seeds give one line
naming the key or flag and exit status 2, at once (they used to hang or end a run at once)."""

from __future__ import annotations

import os
import re
import shutil
import threading
from pathlib import Path

import pytest

from jostle.cli import main

ROOT = Path(__file__).resolve().parent.parent.parent


def _config(tmp_path: Path, run_table: str) -> Path:
    """The demo config in a copy of configs/ (the recording linked, not copied), [run] replaced."""
    dst = tmp_path / "configs"
    shutil.copytree(ROOT / "configs", dst, ignore=shutil.ignore_patterns("*.mcap"))
    (dst / "recordings" / "demo.mcap").symlink_to(ROOT / "configs" / "recordings" / "demo.mcap")
    text = (dst / "demo.toml").read_text(encoding="utf-8")
    text = re.sub(r"^\[run\]\n(?:[^\[\n].*\n|\n)*", "", text, flags=re.M)
    (dst / "demo.toml").write_text(f"[run]\n{run_table}\n\n" + text, encoding="utf-8")
    return dst / "demo.toml"


def _one_line(args: list[str], capsys: pytest.CaptureFixture[str]) -> str:
    code = main(args)
    err = capsys.readouterr().err
    lines = err.strip().splitlines()
    assert code == 2 and len(lines) == 1 and "Traceback" not in err, err
    assert lines[0].startswith("jostle: error: "), err
    return lines[0]


@pytest.mark.parametrize(("table", "key"), [
    ("tail_s = nan", "run.tail_s: expected a finite number"),
    ("tail_s = inf", "run.tail_s: expected a finite number"),
    ("duration_s = nan", "run.duration_s: expected a finite number"),
    ("duration_s = 1e308", "run.duration_s: expected a number from 0 to"),
    ("duration_s = -1", "run.duration_s: expected a number from 0 to"),
    ("seed = -1", "run.seed: expected a whole number from 0 to 4294967295, got -1"),
    ("seed = 4294967296", "run.seed: expected a whole number from 0 to 4294967295"),
])
def test_run_table_numbers(table: str, key: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    config = _config(tmp_path, table)
    line = _one_line(["run", str(config), "--no-video", "--quiet", "--out", str(tmp_path / "out")], capsys)
    assert f"{config}: {key}" in line, line


@pytest.mark.parametrize(("flags", "said"), [
    (["--duration", "nan"], "--duration: expected a finite number, got nan"),
    (["--duration", "inf"], "--duration: expected a finite number, got inf"),
    (["--duration", "-1"], "--duration: expected a number from 0 to"),
    (["--duration", "0"], "--duration: expected a number > 0"),
    (["--duration", "1e308"], "--duration: expected a number from 0 to"),
    (["--seed", "-1"], "--seed: expected a whole number from 0 to 4294967295, got -1"),
])
def test_run_flags(flags: list[str], said: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    line = _one_line(["run", str(ROOT / "configs" / "demo.toml"), "--out", str(tmp_path), *flags], capsys)
    assert said in line, line
    assert not any(tmp_path.iterdir())  # refused before anything ran


def test_every_float_flag_must_be_finite(capsys: pytest.CaptureFixture[str]) -> None:
    line = _one_line(["keyframes", "import", "x.bvh", "--into", "s", "--axis", "theta_x", "--range", "0", "nan"], capsys)
    assert "--range: expected a finite number, got nan" in line, line


def test_a_fifo_as_the_config_is_refused_at_once(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    fifo = tmp_path / "config.toml"
    os.mkfifo(fifo)
    box: dict[str, str] = {}
    worker = threading.Thread(target=lambda: box.update(line=_one_line(["run", str(fifo)], capsys)), daemon=True)
    worker.start()
    worker.join(20)
    assert not worker.is_alive(), "hung on a FIFO"
    assert f"{fifo}: is a FIFO, expected a regular file" in box["line"], box


@pytest.mark.parametrize(("line", "said"), [
    ("contactor_stiffness = " + "9" * 400, "world.contactor_stiffness: expected a number"),
    ("contactor_stiffness = nan", "world.contactor_stiffness: expected a finite number, got nan"),
    ('keyframes = "~no_such_user_here/set"', "keyframes: expected a path (string), got '~no_such_user_here/set'"),
    ("".join(f'[sensors.s{i}]\ntype = "replay"\n' for i in range(70)), "sensors: 71 sensors, more than the 64 allowed"),
    ("".join(f'[sensors.s{i}]\ntype = "replay"\npath = "x"\n' for i in range(10_000)), "more than the 10000 allowed"),
])
def test_config_values_out_of_bounds(line: str, said: str, tmp_path: Path) -> None:
    from jostle.config import load_config
    from jostle.errors import user_facing

    config = _config(tmp_path, "seed = 1")
    text = config.read_text(encoding="utf-8")
    if line.startswith("[sensors."):
        text += "\n" + line
    else:  # the shipped key's line replaced
        key = line.split(" = ")[0]
        text, n = re.subn(rf"^{key} = .*$", lambda _: line, text, count=1, flags=re.M)
        assert n == 1
    config.write_text(text, encoding="utf-8")
    with pytest.raises(Exception) as caught:
        load_config(config)
    message = user_facing(caught.value)
    assert message is not None and "\n" not in message and said in message, message
