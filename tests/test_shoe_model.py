"""The depth observer's shoe model (interaction.depth.shoe_model) and how it is made (jostle.bench.shoe_model_fit)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from interaction.depth import DepthObserver, DepthObserverConfig
from interaction.depth.shoe_model import (
    FEATURES,
    ShoeModel,
    column_features,
    default_model_path,
    shipped_shoe_model,
)
from jostle.bench.interaction import _depth_calibration
from jostle.bench.shoe_model_fit import BENCH_SEEDS, MATCH_M, parse_seeds, recording_rows
from jostle.bench.truth import part_centres
from jostle.performer.truth import read_cameras, read_truth
from sensors.base import DepthImage, Frame
from sensors.recording.source import iter_payloads

CAMERA = np.array([0.0, -4.0, 2.4])


def _box_column(pitch_deg: float, lift: float, rng: np.random.Generator) -> np.ndarray:
    """Points on the top of a 26 × 10 cm shoe pitched toe-down by ``pitch_deg`` (its heel ``lift`` m up),
    and a shin over its heel: what a column over a foot holds."""
    t = math.radians(pitch_deg)
    s = rng.uniform(0.0, 0.26, 300)
    w = rng.uniform(-0.05, 0.05, 300)
    top = np.stack([s * math.cos(t), w, lift + 0.08 - s * math.sin(t)], axis=1)
    h = rng.uniform(0.12, 0.3, 150)
    shin = np.stack([np.full_like(h, 0.02), rng.uniform(-0.04, 0.04, 150), lift + h], axis=1)
    return np.concatenate([top, shin]) + rng.normal(0.0, 0.005, (450, 3))


def test_features_are_finite_and_tell_a_flat_shoe_from_a_hanging_one() -> None:
    rng = np.random.default_rng(0)
    flat = column_features(_box_column(0.0, 0.0, rng), CAMERA, 0.04, 0.1)
    hanging = column_features(_box_column(60.0, 0.25, rng), CAMERA, None, 0.2)
    assert flat.shape == hanging.shape == (FEATURES,)
    assert np.isfinite(flat).all() and np.isfinite(hanging).all()
    assert flat[-3:-1].tolist() == [1.0, 0.0] and hanging[-3:-1].tolist() == [0.0, 0.0]  # the rules' say
    assert hanging[0] > flat[0] + 0.02  # its lowest points: the toe, in the air
    assert hanging[3] > flat[3] + 0.03  # the median height over them: a pitched top spreads up


def _model(k: int = 2) -> ShoeModel:
    features = np.zeros((4, FEATURES))
    features[2:, 0] = 1.0  # two feet at 0, two at 1 on the first feature
    corrections = np.array([[0.1, 0.0, 0.0], [0.1, 0.0, 0.02], [0.0, -0.05, 0.0], [0.0, -0.05, 0.04]])
    return ShoeModel(features, corrections, np.zeros(FEATURES), np.ones(FEATURES), k)


def test_a_foot_takes_the_mean_correction_of_its_nearest_feet_in_the_view_frame() -> None:
    model = _model()
    query = np.zeros(FEATURES)
    assert model.correction(query) == pytest.approx([0.1, 0.0, 0.01])
    query[0] = 0.9
    assert model.correction(query) == pytest.approx([0.0, -0.05, 0.02])
    # along the view: from the camera (0, -4) to a foot at (0, 0) is +y; across it is -x
    foot = np.array([0.0, 0.0, 0.05])
    assert model.corrected(foot, np.zeros(FEATURES), CAMERA) == pytest.approx([0.0, 0.1, 0.06])
    assert model.corrected(foot, query, CAMERA) == pytest.approx([0.05, 0.0, 0.07])
    bad = np.zeros(FEATURES)
    bad[3] = math.nan
    assert model.correction(bad) is None and model.corrected(foot, bad, CAMERA) is foot


def test_bad_models_are_refused_with_what_is_wrong(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="at least k=5"):
        ShoeModel(np.zeros((4, FEATURES)), np.zeros((4, 3)), np.zeros(FEATURES), np.ones(FEATURES), 5)
    with pytest.raises(ValueError, match="corrections: up to 1.00 m"):
        ShoeModel(np.zeros((4, FEATURES)), np.ones((4, 3)), np.zeros(FEATURES), np.ones(FEATURES), 2)
    with pytest.raises(ValueError, match="scale"):
        ShoeModel(np.zeros((4, FEATURES)), np.zeros((4, 3)), np.zeros(FEATURES), np.zeros(FEATURES), 2)
    junk = tmp_path / "junk.npz"
    junk.write_bytes(b"not a model")
    with pytest.raises(ValueError, match="junk.npz: not a shoe model"):
        ShoeModel.load(junk)
    pickled = tmp_path / "pickled.npz"  # object arrays would need unpickling: never read
    with pickled.open("wb") as f:
        np.savez(f, features=np.array([{"x": 1}], dtype=object), corrections=np.zeros((1, 3)),
                 mean=np.zeros(FEATURES), scale=np.ones(FEATURES), k=np.array(1))
    with pytest.raises(ValueError, match="pickled.npz"):
        ShoeModel.load(pickled)


def test_save_then_load_gives_the_same_corrections(tmp_path: Path) -> None:
    rng = np.random.default_rng(1)
    features, corrections = rng.normal(size=(50, FEATURES)), rng.uniform(-0.05, 0.05, (50, 3))
    ShoeModel.save(tmp_path / "m.npz", features, corrections, 3, [300])
    assert sorted(p.name for p in tmp_path.iterdir()) == ["m.npz"]  # no part file left behind
    model = ShoeModel.load(tmp_path / "m.npz")
    assert len(model) == 50 and model.k == 3
    q = features[7]
    d = np.linalg.norm((features - q) / features.std(axis=0), axis=1)
    assert model.correction(q) == pytest.approx(corrections[np.argsort(d)[:3]].mean(axis=0), abs=1e-6)


def test_the_shipped_model_is_made_from_other_seeds_than_the_benchs() -> None:
    model = shipped_shoe_model()
    assert model is not None and len(model) > 10000 and model.k == 10
    with np.load(default_model_path(), allow_pickle=False) as f:
        seeds = set(f["seeds"].tolist())
    assert seeds and all(abs(s - b) > 3 for s in seeds for b in BENCH_SEEDS)  # no performer shared either


def test_seeds_parse_and_the_benchs_seeds_are_refused(tmp_path: Path) -> None:
    from jostle.bench.shoe_model_fit import fit

    assert parse_seeds("300:600:100") == [300, 400, 500, 600] and parse_seeds("300, 700") == [300, 700]
    with pytest.raises(ValueError, match="--seeds: expected"):
        parse_seeds("300:200:100")
    with pytest.raises(ValueError, match=r"seeds \[100\]: the bench scores these"):
        fit([100, 300], tmp_path / "m.npz", 10)
    with pytest.raises(ValueError, match=r"seeds \[3, 197\]: the bench scores these \(or their performers\)"):
        fit([3, 4, 197, 196], tmp_path / "m.npz", 10)  # 3 records performers 4–7, 197 records 198–201
    with pytest.raises(ValueError, match="shoe_model: expected true or false"):
        DepthObserverConfig(shoe_model="yes")  # type: ignore[arg-type]


@pytest.fixture(scope="module")
def crossing(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """One person walking and kicking across the stage: performer seed 7, and a clip (kick), that the
    shipped model's recordings (walk, punch; seeds 301–5004) never had."""
    from jostle.performer.config import DepthCameraConfig, PerformerConfig
    from jostle.performer.session import SynthSensors, record_performance

    path = tmp_path_factory.mktemp("shoes") / "crossing.mcap"
    config = PerformerConfig(clips=("walk", "kick"), width=160, height=120, fps=15.0, duration_s=5.0, seed=7,
                             empty_s=1.0, people=1, route="crossing")
    oak = DepthCameraConfig(width=640, height=400, fps=15.0, color=False)
    record_performance(config, SynthSensors(webcam=False, oak=oak, truth=True), path)
    return path


def _foot_errors(path: Path, shoe_model: bool) -> np.ndarray:
    frames = [Frame("oak", t / 1e9, seq, p) for t, seq, p in iter_payloads(path, "oak") if isinstance(p, DepthImage)]
    observer = DepthObserver(DepthObserverConfig(shoe_model=shoe_model),
                             _depth_calibration([f.payload for f in frames[:8]], read_cameras(path)["oak"].position))
    truth = {round(f.t * 1000): f for f in read_truth(path)}
    out = []
    for frame in frames:
        obs = observer.observe(frame)
        centres = np.array([pos for _, pos, _ in part_centres(truth[round(frame.t * 1000)], "foot")]).reshape(-1, 3)
        for c in obs.contactors:
            if c.part == "foot" and len(centres):
                out.append(float(np.min(np.linalg.norm(centres - np.array(c.position), axis=1))))
    return np.array(out)


def test_the_shipped_model_brings_feet_nearer_their_true_middles(crossing: Path) -> None:
    rules, model = _foot_errors(crossing, False), _foot_errors(crossing, True)
    assert len(rules) > 40 and len(model) == len(rules)  # the same feet, moved (none added or lost)
    assert float(np.mean(model)) < float(np.mean(rules)) - 0.002
    assert np.count_nonzero(model > 0.05) < np.count_nonzero(rules > 0.05)


def test_rows_are_the_feet_found_with_their_corrections_and_the_same_each_time(crossing: Path) -> None:
    features, corrections = recording_rows(crossing)
    assert len(features) > 40 and len(features) == len(corrections)
    f, c = np.array(features), np.array(corrections)
    assert f.shape[1] == FEATURES and np.isfinite(f).all()
    assert np.linalg.norm(c, axis=1).max() <= MATCH_M + 1e-9
    again_f, again_c = recording_rows(crossing)
    assert np.array_equal(f, np.array(again_f)) and np.array_equal(c, np.array(again_c))


def test_without_its_file_the_observer_says_so_and_places_feet_by_the_rules(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture) -> None:
    import interaction.depth.shoe_model as shoe_model

    monkeypatch.setattr(shoe_model, "default_model_path", lambda: tmp_path / "missing.npz")
    shoe_model.shipped_shoe_model.cache_clear()
    try:
        with caplog.at_level("WARNING", logger="jostle.depth"):
            assert shoe_model.shipped_shoe_model() is None
        assert "no shoe model at" in caplog.text and "shoe rules alone" in caplog.text
        (tmp_path / "missing.npz").write_bytes(b"broken")
        shoe_model.shipped_shoe_model.cache_clear()
        caplog.clear()
        with caplog.at_level("WARNING", logger="jostle.depth"):
            assert shoe_model.shipped_shoe_model() is None
        assert "missing.npz: not a shoe model" in caplog.text
    finally:
        shoe_model.shipped_shoe_model.cache_clear()


def test_the_command_refuses_an_out_it_cannot_write_before_recording_anything(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from jostle.cli import main

    assert main(["synth", "shoe-model", "--seeds", "300", "--out", str(tmp_path)]) == 2
    assert f"--out {tmp_path}: cannot be written here" in capsys.readouterr().err
    assert main(["synth", "shoe-model", "--seeds", "100"]) == 2
    assert "seeds [100]: the bench scores these" in capsys.readouterr().err
