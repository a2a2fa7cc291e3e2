"""``jostle bench interaction --quick`` (jostle.bench.interaction): records, observes, scores; figures sane."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import pytest

from jostle.bench import interaction as bench_interaction


def main_json(name: str, argv: list[str]) -> dict[str, Any]:
    """As jostle.cli.bench.main_json, on the module directly (the table names jostle.bench.interaction)."""
    import argparse

    assert name == "interaction"
    parser = argparse.ArgumentParser()
    bench_interaction.add_arguments(parser)
    return bench_interaction.run(parser.parse_args(argv))

FIGURES = ("webcam_fps", "depth_fps", "latency_ms_p99", "depth_extremity_error_m_p95",
           "webcam_extremity_error_m_p95", "velocity_direction_error_deg_p95", "person_count_accuracy")


def test_quick_bench_scores_one_person_against_the_truth(tmp_path: Path) -> None:
    figures = main_json("interaction", ["--quick", "--people", "1", "--duration", "3.5", "--keep", str(tmp_path)])
    kept = sorted(path.name for path in tmp_path.iterdir())
    assert kept == ["crossing1-seed0-15fps-3.5s-320x240.mcap"]  # the name says what made it: reused only then
    assert figures["frames_per_s"] == 15.0
    for name in FIGURES:
        value = figures[name]
        assert isinstance(value, float) and math.isfinite(value) and value >= 0, f"{name}: {value!r}"
    assert figures["person_count_frames"] > 10
    assert figures["person_count_accuracy"] >= 0.9  # one person, fully in view for most of it
    assert figures["depth_extremity_error_m_p95"] < 1.0  # hands and feet are found near real ones
    assert 0 <= figures["velocity_direction_error_deg_p95"] <= 180
    assert set(figures["targets_met"]) == set(FIGURES)


def test_bad_people_list_is_refused() -> None:
    with pytest.raises(ValueError, match="--people"):
        main_json("interaction", ["--quick", "--people", "7"])


@pytest.mark.parametrize("fps", ["0", "500", "nan"])
def test_bad_frame_rate_is_refused(fps: str) -> None:
    with pytest.raises(ValueError, match=r"^--fps: expected a frame rate from 1 to 120, got "):
        main_json("interaction", ["--quick", "--fps", fps])
