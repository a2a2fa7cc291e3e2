"""Every shipped config loads; a configured sensor that is absent is reported, never silently replaced."""

from __future__ import annotations

from pathlib import Path

import pytest

from jostle.cli import main
from jostle.cli.bench import main_json
from jostle.config import load_config

ROOT = Path(__file__).resolve().parent.parent
CONFIGS = sorted((ROOT / "configs").glob("*.toml"))


@pytest.mark.parametrize("path", CONFIGS, ids=[p.name for p in CONFIGS])
def test_shipped_config_loads(path: Path) -> None:
    config = load_config(path)
    assert config.sensors and config.render.keyframes.exists()
    for observer in config.observers:
        assert observer.calibration is None or observer.calibration.exists()
        assert observer.sensor in {s.name for s in config.sensors}


def test_absent_camera_is_a_clear_error(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    text = (ROOT / "configs" / "webcam.toml").read_text().replace('source = "0"', 'source = "/dev/video97"')
    cfg = ROOT / "configs" / "_absent_camera_test.toml"
    cfg.write_text(text)
    try:
        code = main(["run", str(cfg), "--headless", "--out", str(tmp_path), "--duration", "1", "--quiet"])
    finally:
        cfg.unlink()
    err = capsys.readouterr().err
    assert code == 2, err
    line = [ln for ln in err.splitlines() if ln.startswith("jostle: error:")]
    assert len(line) == 1 and "/dev/video97" in line[0] and "Traceback" not in err


def test_bench_pipeline_reports_every_stage() -> None:
    figures = main_json("pipeline", ["--config", str(ROOT / "configs" / "demo.toml"), "--seconds", "1",
                                     "--width", "160", "--height", "90"])
    assert figures["frames"] == 30
    shares = [figures[f"{s}_share"] for s in ("sensors", "observe", "simulate", "draw", "encode")]
    assert all(0.0 <= s <= 1.0 for s in shares) and abs(sum(shares) - 1.0) < 0.01
    assert figures["realtime_factor"] > 0
