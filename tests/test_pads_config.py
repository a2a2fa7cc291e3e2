"""PadsConfig validation, the registry row, the calibration arithmetic, and no backend on import."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from jostle.configtree import ConfigError, build
from sensors.pads.calibration import STANDARD_GRAVITY, PadCalibration, scale_from_known_load
from sensors.pads.config import PadsConfig
from sensors.registry import SENSOR_TYPES


@pytest.mark.parametrize(
    ("changes", "message"),
    [
        ({"port": 42}, "port: expected a path like /dev/ttyUSB0 or a pyserial URL, got 42"),
        ({"port": "ttyUSB0"}, "port: expected a path like /dev/ttyUSB0 or a pyserial URL, got 'ttyUSB0'"),
        ({"port": ""}, "port: expected a path"),
        ({"baudrate": 0}, "baudrate: expected a whole number of bits per second > 0"),
        ({"baudrate": 9600.0}, "baudrate:"),
        ({"framing": "json"}, "framing: expected 'binary' or 'csv', got 'json'"),
        ({"pads": 0}, "pads: expected a whole number of pads 1..255, got 0"),
        ({"pads": True}, "pads:"),
        ({"pads": 3, "newtons_per_count": (1.0, 2.0)}, r"newtons_per_count: expected one number, or one per pad \(3\)"),
        ({"newtons_per_count": (0.0,)}, "newtons_per_count: expected non-zero numbers"),
        ({"newtons_per_count": (float("nan"),)}, "newtons_per_count: expected non-zero numbers"),
        ({"tare_samples": -1}, "tare_samples: expected a whole number >= 0, got -1"),
        ({"max_bad_per_s": 0}, "max_bad_per_s: expected a whole number >= 1, got 0"),
        ({"deadband_n": -0.1}, "deadband_n: expected newtons >= 0, got -0.1"),
        ({"reconnect_s": 0}, "reconnect_s: expected a number > 0, got 0"),
        ({"rate_hz": float("inf")}, "rate_hz: expected a number > 0, got inf"),
    ],
)
def test_config_errors_start_with_the_field(changes: dict[str, object], message: str) -> None:
    fields: dict[str, object] = {"port": "/dev/ttyUSB0", **changes}
    with pytest.raises(ValueError, match=f"^{message}"):
        PadsConfig(**fields)  # type: ignore[arg-type]


@pytest.mark.parametrize("port", ["/dev/ttyUSB0", "/dev/serial/by-id/usb-1a86_USB_Serial-if00-port0", "loop://",
                                  "socket://localhost:7777", "rfc2217://board.local:4000", "COM3", "./ports/pads"])
def test_ports_accepted(port: str) -> None:
    assert PadsConfig(port=port).port == port


def test_scales_repeat_a_single_value() -> None:
    assert PadsConfig(port="loop://", pads=3, newtons_per_count=(0.5,)).scales == (0.5, 0.5, 0.5)
    assert PadsConfig(port="loop://", pads=2, newtons_per_count=(0.5, -2)).scales == (0.5, -2.0)


def test_registry_builds_pads_from_toml_like_tables(tmp_path: Path) -> None:
    row = SENSOR_TYPES["pads"]
    table = {"port": "/dev/ttyACM0", "pads": 2, "framing": "csv", "newtons_per_count": [0.01, 0.02]}
    config: PadsConfig = build(row.config, table, source="arcade.toml", key="sensors.pads", base_dir=tmp_path)
    assert config == PadsConfig(port="/dev/ttyACM0", pads=2, framing="csv", newtons_per_count=(0.01, 0.02))
    with pytest.raises(ConfigError, match=r"^arcade.toml: sensors.pads.pads: expected a whole number of pads"):
        build(row.config, {"port": "/dev/ttyACM0", "pads": 0}, source="arcade.toml", key="sensors.pads",
              base_dir=tmp_path)
    with pytest.raises(ConfigError, match=r"sensors.pads.baud: unknown key"):
        build(row.config, {"port": "/dev/ttyACM0", "baud": 9600}, source="arcade.toml", key="sensors.pads",
              base_dir=tmp_path)
    sensor = row.loader(config, "floor", _Clock())
    assert sensor.spec.name == "floor" and sensor.spec.kind == "pads" and sensor.spec.pads == 2


class _Clock:
    def now(self) -> float:
        return 0.0

    def sleep_until(self, t: float) -> None:
        return None


def test_importing_the_package_pulls_in_no_serial_backend() -> None:
    code = ("import sys, sensors, sensors.registry, sensors.pads, sensors.pads.config, sensors.pads.protocol, "
            "sensors.pads.calibration, jostle.bench.pad_fuzz; print('serial' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                         cwd=Path(__file__).resolve().parents[1])
    assert out.stdout.strip() == "False"


def test_tare_averages_the_first_samples() -> None:
    cal = PadCalibration((0.5, -2.0), tare_samples=3)
    assert cal.taring and cal.tare_progress == (0, 3)
    assert not cal.add_tare((100, 10))
    assert not cal.add_tare((102, 11))
    assert cal.add_tare((107, 15))
    assert cal.zero == (103.0, 12.0)
    assert cal.newtons((113, 2)) == ((113 - 103) * 0.5, (2 - 12) * -2.0)
    cal.reset()
    assert cal.taring
    with pytest.raises(ValueError, match="tare: 0 of 3 samples"):
        cal.newtons((1, 1))


def test_no_tare_means_a_zero_of_zero_and_the_deadband_clips_small_forces() -> None:
    cal = PadCalibration((0.1,) * 5, tare_samples=0, deadband_n=0.5)
    assert not cal.taring
    assert cal.newtons((4, 5, -4, -5, 100)) == (0.0, 5 * 0.1, 0.0, -5 * 0.1, 100 * 0.1)


def test_scale_from_a_known_load() -> None:
    load = 20 * STANDARD_GRAVITY
    scales = scale_from_known_load((8_000, -200), (8_000 + 392_266, -200 - 39_226), load)
    assert scales == (load / 392_266, load / -39_226)
    cal = PadCalibration(scales, tare_samples=1)
    cal.add_tare((8_000, -200))
    assert cal.newtons((8_000 + 392_266, -200 - 39_226)) == pytest.approx((load, load))
    with pytest.raises(ValueError, match="pad 1 reads 5 counts with and without the load"):
        scale_from_known_load((1, 5), (9, 5), load)
