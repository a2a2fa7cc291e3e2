"""``jostle bench ragdoll`` runs in one process and reports exactly the issue's keys (quick settings)."""

from __future__ import annotations

import math
from collections.abc import Generator

import pytest

from jostle.bench.ragdoll import EXTRA_KEYS, KEYS
from jostle.bench.ragdoll_baseline import baseline_slices
from jostle.bench.ragdoll_pushes import EXCESS_WHEN
from jostle.bench.ragdoll_walk import interleaved, walking_slices
from jostle.bench.table import BENCHES
from jostle.cli.bench import main_json
from sim.articulated.spec import ArticulatedSpec


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
    spec = ArticulatedSpec()  # the walking assist turns the pelvis: reported, and within its bounds
    bound = max(spec.assist_torque_max_nm * spec.walk_in_assist, spec.getup_assist_torque_max_nm)
    assert isinstance(figures["external_assist_nm"], float) and 0 < figures["external_assist_nm"] <= bound + 0.05
    assert figures["walkoff_success"] is None  # quick: nothing stands again in 0.5 s
    excess = figures["joint_limit_excess_deg"]
    assert isinstance(excess, float) and 0 <= excess < 180
    by_when = {when: figures[f"joint_limit_excess_deg_{when}"] for when in EXCESS_WHEN}
    assert max(by_when.values()) == excess  # the split covers every step the overall figure read
    assert by_when["walkoff"] == 0.0  # quick: nothing walks off
    if survived == (600.0, 600.0):
        assert by_when["down"] == by_when["felled"] == 0.0  # nothing fell
    if survived == (0.0, 0.0):
        assert by_when["survived"] == 0.0  # no push was survived
    assert "ragdoll" in BENCHES


def test_bad_flags_are_one_line_errors() -> None:
    with pytest.raises(ValueError, match="--phases: expected a whole number >= 1, got 0"):
        main_json("ragdoll", ["--phases", "0"])
    with pytest.raises(ValueError, match=r"--push-start: expected 0 <= start <= --push-max=100.0, got 200.0"):
        main_json("ragdoll", ["--push-start", "200", "--push-max", "100"])
    with pytest.raises(ValueError, match="--recovery-substeps: expected a whole number from 1 to 32, got 0"):
        main_json("ragdoll", ["--recovery-substeps", "0"])


def test_quick_bench_recovering_at_finer_steps() -> None:
    """The characters' recovery settings reach the bench and its figures (``sim.articulated.recovery``)."""
    plain = main_json("ragdoll", ["--quick", "--recovery-substeps", "1"])
    fine = main_json("ragdoll", ["--quick"])  # the character's default: 8
    assert (plain["recovery_substeps"], fine["recovery_substeps"]) == (1, 8)
    assert plain["recovery_cost_ratio"] is None
    cost = fine["recovery_cost_ratio"]  # one walker kept recovering: a ratio of wall times, reported, not judged
    assert isinstance(cost, float) and cost > 0.0 and math.isfinite(cost)
    assert fine["joint_limit_excess_deg_unpushed"] == plain["joint_limit_excess_deg_unpushed"] == 0.0
    # one 600 N push each way: measured 10.9° past a limit at the world's step, 2.5° at 8 substeps
    assert fine["joint_limit_excess_deg"] < plain["joint_limit_excess_deg"]


def test_runs_take_turns_one_slice_each_until_all_are_done() -> None:
    order: list[str] = []

    def run(name: str, slices: int) -> Generator[float, None, str]:
        for k in range(slices):
            order.append(f"{name}{k}")
            yield 0.5
        return f"{name} done"

    result = interleaved([run("a", 3), run("b", 2)])
    assert order == ["a0", "b0", "a1", "b1", "a2"]
    assert result == [(1.5, "a done"), (1.0, "b done")]


def test_walking_in_slices_is_the_same_walk_and_the_baseline_yields_each_slice() -> None:
    whole = interleaved([walking_slices(1, 0.25, 1)])[0][1]
    parts = walking_slices(1, 0.25, 3)
    (wall, sliced), = interleaved([parts])
    assert sliced[1:] == whole[1:]  # simulated time, tracking error, assist: the same trace
    assert sliced[1] == pytest.approx(0.25) and wall == pytest.approx(sliced[0])
    times = list(baseline_slices(1, 0.25, 3))
    assert len(times) == 3 and all(t > 0 for t in times)


class _Seen:
    """What ``_Worst.see`` reads of a character: its state and its excess now."""

    def __init__(self, state: str, excess: float) -> None:
        self.state, self.excess = state, excess

    def limit_excess(self) -> float:
        return self.excess


def test_the_excess_is_split_by_when_it_happened() -> None:
    from jostle.bench.ragdoll_pushes import Worst as _Worst

    worst = _Worst()
    worst.see([_Seen("walk", 0.01)])  # walking up to a push
    worst.when = "pushed"
    worst.see([_Seen("stagger", 0.1)])
    worst.end_push(felled=False)
    worst.see([_Seen("stagger", 0.2), _Seen("walk", 0.05)])
    worst.see([_Seen("fall", 0.3)])
    worst.end_push(felled=True)
    worst.see([_Seen("walk", 0.25)])  # standing again: still down until the walk-off starts
    worst.when = "walkoff"
    worst.see([_Seen("walk", 0.04)])
    assert worst.by_when == {"unpushed": 0.01, "survived": 0.1, "felled": 0.2, "down": 0.3, "walkoff": 0.04}
    assert worst.rad == 0.3
