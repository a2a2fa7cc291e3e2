"""``jostle bench ragdoll`` runs in one process and reports exactly the issue's keys (quick settings)."""

from __future__ import annotations

import math

import pytest

from jostle.bench_cli import BENCHES, main_json
from jostle.bench_ragdoll import EXTRA_KEYS, KEYS


def test_quick_bench_reports_the_issues_keys() -> None:
    figures = main_json("ragdoll", ["--quick"])
    assert tuple(figures) == KEYS + EXTRA_KEYS
    assert figures["characters"] == 1 and figures["physics_hz"] == pytest.approx(240.0)
    rt, ratio = figures["realtime_factor"], figures["cost_ratio_vs_baseline"]
    assert isinstance(rt, float) and rt > 0 and isinstance(ratio, float) and ratio > 0
    err = figures["tracking_error_deg"]
    assert err is None or (isinstance(err, float) and 0 <= err < 180)
    # quick: one 600 N push per direction, watched for 0.5 s: survived (600) or felled (0) — and a get-up
    # figure exactly when something fell (0.5 s is too short to stand again)
    survived = (figures["max_survived_forward_n"], figures["max_survived_side_n"])
    assert set(survived) <= {0.0, 600.0}
    assert figures["getup_success"] == (None if survived == (600.0, 600.0) else 0.0)
    assist = figures["external_assist_n"]
    assert isinstance(assist, float) and assist >= 0 and math.isfinite(assist)
    assert figures["walkoff_success"] is None  # quick: nothing stands again in 0.5 s
    excess = figures["joint_limit_excess_deg"]
    assert isinstance(excess, float) and 0 <= excess < 180
    assert "ragdoll" in BENCHES


def test_bad_flags_are_one_line_errors() -> None:
    with pytest.raises(ValueError, match="--phases: expected a whole number >= 1, got 0"):
        main_json("ragdoll", ["--phases", "0"])
    with pytest.raises(ValueError, match=r"--push-start: expected 0 <= start <= --push-max=100.0, got 200.0"):
        main_json("ragdoll", ["--push-start", "200", "--push-max", "100"])
