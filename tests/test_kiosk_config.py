"""The [kiosk] and [health] tables: defaults, canonical key combinations, and one-line errors that
name the file and the key."""

from __future__ import annotations

from pathlib import Path

import pytest

from jostle.config import ConfigError, load_config
from jostle.operations_config import HealthConfig, KioskConfig, parse_combo

ROOT = Path(__file__).resolve().parent.parent


def _config(tmp_path: Path, extra: str) -> Path:
    text = (ROOT / "configs" / "demo.toml").read_text()
    for folder in ("recordings", "characters", "keyframes"):
        text = text.replace(f'"{folder}/', f'"{ROOT}/configs/{folder}/')
    path = tmp_path / "show.toml"
    path.write_text(text + "\n" + extra)
    return path


def test_defaults_and_a_full_table_load(tmp_path: Path) -> None:
    cfg = load_config(ROOT / "configs" / "demo.toml")
    assert cfg.kiosk == KioskConfig() and cfg.health == HealthConfig()
    assert cfg.kiosk.exit_keys == "ctrl+shift+q" and cfg.kiosk.attract_after_s == 20.0
    assert cfg.health.json_file is None and cfg.health.http_port == 0
    path = _config(tmp_path, '[kiosk]\nexit_keys = "Shift+Ctrl+X"\ndiagnostics_key = "d"\nattract_after_s = 0\n'
                   'attract_modes = ["kiosk", "window"]\ncall_to_action = "Shove!"\n'
                   '[health]\njson_path = "state/health.json"\nhttp_port = 8089\nwatchdog_s = 20\n')
    cfg = load_config(path)
    assert cfg.kiosk.exit_keys == "ctrl+shift+x" and cfg.kiosk.diagnostics_key == "d"
    assert cfg.kiosk.attract_modes == ("kiosk", "window") and cfg.kiosk.call_to_action == "Shove!"
    assert cfg.health.json_file == tmp_path / "state" / "health.json"  # relative to the config file
    assert cfg.health.http_port == 8089 and cfg.health.watchdog_s == 20.0


@pytest.mark.parametrize("table, message", [
    ('[kiosk]\nexit_keys = "escape"', r"kiosk\.exit_keys: expected a combination a visitor cannot press by chance"),
    ('[kiosk]\nexit_keys = "ctrl+hyper+q"', r"kiosk\.exit_keys: expected modifiers from ctrl, shift, alt, super"),
    ('[kiosk]\ndiagnostics_key = "f99"', r"kiosk\.diagnostics_key: expected a letter, digit, f1\.\.f24"),
    ('[kiosk]\ndiagnostics_key = "ctrl+shift+q"', r"kiosk\.diagnostics_key: expected a key other than exit_keys"),
    ("[kiosk]\nattract_after_s = -5", r"kiosk\.attract_after_s: expected seconds ≥ 0"),
    ('[kiosk]\nattract_intent = "dance"', r"kiosk\.attract_intent: "),
    ('[kiosk]\nattract_modes = ["arcade"]', r"kiosk\.attract_modes: "),
    ('[kiosk]\ncall_to_action = "Schubs sie – los!"', r"kiosk\.call_to_action: expected up to 60 printable ASCII"),
    ("[kiosk]\nexit_key = 'ctrl+q'", r"kiosk\.exit_key: unknown key"),
    ("[health]\nhttp_port = 70000", r"health\.http_port: expected 0 \(off\) or a port 1\.\.65535"),
    ("[health]\nstall_s = 0", r"health\.stall_s: expected seconds > 0"),
    ("[health]\nwatchdog_s = -1", r"health\.watchdog_s: expected seconds > 0"),
])
def test_mistakes_are_one_line_naming_file_and_key(tmp_path: Path, table: str, message: str) -> None:
    path = _config(tmp_path, table)
    with pytest.raises(ConfigError, match=f"^{path}: {message}") as e:
        load_config(path)
    assert "\n" not in str(e.value)


def test_key_combinations_are_canonical() -> None:
    assert parse_combo("Q") == "q"
    assert parse_combo(" alt + CTRL + F12 ") == "ctrl+alt+f12"
    assert parse_combo("super+shift+esc") == "shift+super+escape"
    for bad in ("", "ctrl+", "ctrl+ctrl+q", "ctrl+shift"):
        with pytest.raises(ValueError):
            parse_combo(bad)


def test_the_diagnostics_key_toggles_the_panel_and_the_exit_keys_are_noted() -> None:
    from jostle.operations import Operations

    cfg = load_config(ROOT / "configs" / "demo.toml")
    ops = Operations(cfg, "kiosk", live=True, env={})
    assert ops.captions(0.0) is None  # nothing to draw: no panel, not attracting yet
    ops.keys(("escape", "f1"))
    shown = ops.captions(0.0)
    assert shown is not None and shown.diagnostics[0].startswith("jostle STARTING")
    assert not ops.exit_requested
    ops.keys(("f1", "ctrl+shift+q"))
    assert ops.captions(0.0) is None and ops.exit_requested
