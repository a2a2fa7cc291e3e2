"""``jostle synth shoe-model``: the depth observer's shoe model, made from virtual performers.

For each seed, the recordings ``jostle bench interaction`` makes for that seed (1 to 4 people crossing the
stage, walking and punching, 15 fps, 5 s; performer seeds seed + 1 … seed + 4) are made again; the depth
observer runs over each with the shoe rules alone (``shoe_model = false``), and every foot it finds
(:func:`interaction.depth.parts.find_feet`'s ``shoe_rows``) within ``MATCH_M`` of a true foot's middle
(:mod:`jostle.bench.truth`) gives one row: its features (:func:`interaction.depth.shoe_model.column_features`)
and the correction that would have put it there, along the camera's view, across it and up (metres).
The rows of all seeds, in seed order, are the model (:meth:`interaction.depth.shoe_model.ShoeModel.save`); the
same seeds make the same model (the same arrays). The shipped model was made with seeds 300, 400, … 5000;
the bench scores seeds 0, 100 and 200, never among them.

How the shipped model was made and what it gives, with the figures: docs/notes/shoe-model-fit.md.
"""

from __future__ import annotations

import tempfile
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np

MATCH_M = 0.25  # a foot found this near a true foot's middle is that foot (farther: no row)
BENCH_SEEDS = (0, 100, 200)  # what the bench scores: never made into the model


def seed_rows(seed: int, folder: Path, duration: float = 5.0, fps: float = 15.0,
              people: tuple[int, ...] = (1, 2, 3, 4)) -> tuple[np.ndarray, np.ndarray]:
    """(features (N, FEATURES), corrections (N, 3)) of the feet found in one seed's recordings."""
    from interaction.depth.shoe_model import FEATURES
    from jostle.bench.interaction import _record

    features: list[np.ndarray] = []
    corrections: list[np.ndarray] = []
    for n in people:
        path = folder / f"shoes-{n}-seed{seed}.mcap"
        _record(path, n, (640, 480), (640, 400), duration, seed + n, fps)
        f, c = recording_rows(path)
        features.extend(f)
        corrections.extend(c)
        path.unlink()
    return (np.array(features, dtype=np.float64).reshape(-1, FEATURES),
            np.array(corrections, dtype=np.float64).reshape(-1, 3))


def recording_rows(path: Path) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """The rows of one recording with truth (channels oak and truth)."""
    from interaction.depth import DepthObserver, DepthObserverConfig
    from interaction.depth.shoe_model import view_frame
    from jostle.bench.interaction import _depth_calibration
    from jostle.bench.truth import part_centres
    from jostle.performer.truth import read_cameras, read_truth
    from sensors.base import DepthImage, Frame
    from sensors.recording.source import iter_payloads

    cameras = read_cameras(path)
    truth = {round(f.t * 1000): f for f in read_truth(path)}
    frames = [(t_ns, seq, p) for t_ns, seq, p in iter_payloads(path, "oak") if isinstance(p, DepthImage)]
    observer = DepthObserver(DepthObserverConfig(shoe_model=False),
                             _depth_calibration([p for _, _, p in frames[:8]], cameras["oak"].position))
    camera = np.asarray(cameras["oak"].centre, dtype=np.float64)
    features: list[np.ndarray] = []
    corrections: list[np.ndarray] = []
    for t_ns, seq, payload in frames:
        observer.shoes_seen = []
        observer.observe(Frame("oak", t_ns / 1e9, seq, payload))
        frame_truth = truth.get(round(t_ns / 1e6))
        if observer.learning or frame_truth is None:
            continue
        centres = np.array([pos for _, pos, _ in part_centres(frame_truth, "foot")]).reshape(-1, 3)
        if not len(centres):
            continue
        for f, pos in observer.shoes_seen:
            d = np.linalg.norm(centres - pos, axis=1)
            k = int(np.argmin(d))
            if d[k] > MATCH_M or not np.isfinite(f).all():
                continue
            along, across = view_frame(pos, camera)
            off = centres[k] - pos
            features.append(f)
            corrections.append(np.array([float(off[:2] @ along), float(off[:2] @ across), float(off[2])]))
    return features, corrections


def fit(seeds: list[int], out: Path, k: int, jobs: int = 1,
        progress: Callable[[int, int, int], None] | None = None) -> dict[str, Any]:
    """Make the model from ``seeds`` into ``out``; ``progress(done, total, rows)`` after each seed. Returns
    a summary (seeds, rows, k, out)."""
    from interaction.depth.shoe_model import ShoeModel

    if not seeds:
        raise ValueError("seeds: expected at least one")
    # seed S records performers S + 1 … S + 4: a seed within 3 of the bench's shares performers with it
    clash = sorted(s for s in seeds if any(abs(s - b) <= 3 for b in BENCH_SEEDS))
    if clash:
        raise ValueError(f"seeds {clash}: the bench scores these (or their performers); a model made from them "
                         "would be scored on what it was made from")
    rows: dict[int, tuple[np.ndarray, np.ndarray]] = {}
    with tempfile.TemporaryDirectory(prefix="jostle-shoes-") as tmp:
        folder = Path(tmp)
        if jobs <= 1:
            for seed in seeds:
                rows[seed] = seed_rows(seed, folder)
                if progress is not None:
                    progress(len(rows), len(seeds), sum(len(f) for f, _ in rows.values()))
        else:
            with ProcessPoolExecutor(max_workers=jobs) as pool:
                futures = {seed: pool.submit(seed_rows, seed, folder) for seed in seeds}
                for seed in seeds:
                    rows[seed] = futures[seed].result()
                    if progress is not None:
                        progress(len(rows), len(seeds), sum(len(f) for f, _ in rows.values()))
    features = np.concatenate([rows[s][0] for s in seeds])
    corrections = np.concatenate([rows[s][1] for s in seeds])
    if len(features) < k:
        raise ValueError(f"{len(features)} feet found in seeds {seeds}: fewer than k={k}")
    ShoeModel.save(out, features, corrections, k, seeds)
    return {"seeds": seeds, "rows": int(len(features)), "k": k, "out": str(out),
            "correction_m_p95": round(float(np.percentile(np.linalg.norm(corrections, axis=1), 95)), 4)}


def parse_seeds(text: str) -> list[int]:
    """``300:5000:100`` (start:stop:step, stop included) or ``300,400,500``."""
    try:
        if ":" in text:
            start, stop, step = (int(v) for v in text.split(":"))
            if step <= 0 or stop < start:
                raise ValueError
            return list(range(start, stop + 1, step))
        return [int(v) for v in text.split(",") if v.strip()]
    except ValueError:
        raise ValueError(f"--seeds: expected start:stop:step or a comma list of whole numbers, got {text!r}") from None


def check_k(k: int) -> int:
    if not 1 <= k <= 1000:
        raise ValueError(f"--k: expected a whole number 1..1000, got {k}")
    return k
