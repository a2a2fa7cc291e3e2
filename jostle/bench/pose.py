"""``jostle bench pose``: the webcam observer's frame rate with pose on against off, on real people.

Scenes, from the real clips in ``--media`` (its ``video/``): ``1``, ``4``, ``8`` people: the signers
of the ASL clips (walk, help, please; cut out by the selfie segmentation model) on the empty room
of one-by-one-person-detection.mp4, one at 640×480, or 4 (2×2) and 8 (4×2) tiles of 320×240 side by
side, each tile another clip or time; ``sports2d`` and ``walking`` (face-demographics-walking.gif)
as they are, their background the clip's median. Each scene is run as fast as it goes for
``--seconds``, pose off, on (the worker) and inline (``pose_sync``), off and on twice interleaved.
Figures per scene: ``people`` (mean per frame), ``fps_off``, ``fps_on``, ``ratio_on_off`` (target
≥ 0.9), ``ratio_sync_off`` (the inline cost before the worker), ``refresh_per_person_s`` (keypoint
sets per tracked person per wall second, flat out; its minimum over people ``…_min``) and
``refresh_per_person_s_live`` (the same with frames paced at the clip's rate, as from a camera;
target ≥ 5 up to 4 people), ``loop_cpu_ms_off``/``_on`` (the loop thread's own CPU per frame: what
the worker adds to the loop itself, whatever else runs), ``cpus``, ``load_average``. Notes:
docs/notes/pose-worker.md.
"""

from __future__ import annotations

import argparse
import os
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import cv2
import numpy as np

SCENES = ("1", "4", "8", "sports2d", "walking")
TARGETS = {"ratio_on_off": 0.9, "refresh_per_person_s_live": 5.0}
_SIGNERS = ("walk.mkv", "help.mkv", "please.mkv")
_ROOM = "one-by-one-person-detection.mp4"
_TILE = (320, 240)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--media", type=Path, default=None, metavar="DIR",
                        help="the shared media folder (default: $JOSTLE_MEDIA, else ../shared/media beside the checkout)")
    parser.add_argument("--scenes", default=",".join(SCENES), help=f"comma-separated, of {', '.join(SCENES)}")
    parser.add_argument("--seconds", type=float, default=3.0, help="wall seconds per run (default 3)")
    parser.add_argument("--cpu-share", type=float, default=None, help="the worker's share of one core (default: config's)")


def read_clip(path: Path, limit: int = 90) -> tuple[list[np.ndarray], float]:
    """Up to ``limit`` BGR frames of a video (or GIF) and its frame rate (30 if it does not say)."""
    cap = cv2.VideoCapture(str(path))
    fps = cap.get(cv2.CAP_PROP_FPS)
    frames: list[np.ndarray] = []
    while len(frames) < limit:
        ok, f = cap.read()
        if not ok:
            break
        frames.append(f)
    cap.release()
    if not frames:
        raise ValueError(f"--media: cannot read {path}")
    return frames, fps if 1.0 <= fps <= 240.0 else 30.0


def cut_out(frames: list[np.ndarray], person_mask: Callable[[np.ndarray], np.ndarray]) -> list[np.ndarray]:
    """Each frame's person as a uint8 mask (255 = the person), from a segmentation (0 … 1 per pixel)."""
    return [np.where(person_mask(f) > 0.5, 255, 0).astype(np.uint8) for f in frames]


def crowd(room: np.ndarray, people: list[tuple[list[np.ndarray], list[np.ndarray]]], n: int,
          length: int) -> list[np.ndarray]:
    """``length`` frames of ``n`` people on the room: one person on the whole room, else tiles of
    320×240 in rows of up to 4, tile k showing person k mod len(people) started k × 7 frames later."""
    cols = 1 if n == 1 else min(n, 4) if n > 2 else n
    rows = -(-n // cols)
    tw, th = (room.shape[1], room.shape[0]) if n == 1 else _TILE
    back = cv2.resize(room, (tw, th), interpolation=cv2.INTER_AREA)
    out: list[np.ndarray] = []
    for i in range(length):
        img = np.empty((rows * th, cols * tw, 3), np.uint8)
        for k in range(rows * cols):
            tile = back.copy()
            if k < n:
                frames, masks = people[k % len(people)]
                j = (i + 7 * k) % len(frames)
                colour = cv2.resize(frames[j], (tw, th), interpolation=cv2.INTER_AREA)
                on = cv2.resize(masks[j], (tw, th), interpolation=cv2.INTER_NEAREST) > 0
                tile[on] = colour[on]
            r, c = divmod(k, cols)
            img[r * th:(r + 1) * th, c * tw:(c + 1) * tw] = tile
        out.append(img)
    return out


def measure(frames: list[np.ndarray], background: np.ndarray, fps: float, seconds: float, *, pose: bool,
            sync: bool = False, paced: bool = False, cpu_share: float | None = None) -> dict[str, float]:
    """One run of the webcam observer over ``frames`` (looped), after learning ``background``:
    frames per wall second, people per frame, keypoint refreshes per tracked person per second."""
    from interaction.webcam import WebcamObserver, WebcamObserverConfig
    from interaction.webcam.calibration import Calibration
    from sensors.base import ColorImage, Frame

    h, w = background.shape[:2]
    uv = np.array([[0, 0], [w, 0], [w, h], [0, h]], dtype=np.float64)
    xz = np.array([[-2.0, 2.4], [2.0, 2.4], [2.0, 0.0], [-2.0, 0.0]])
    cal = Calibration.from_correspondences(uv, xz, plane_y=0.0, half_depth=0.5, image_size=(w, h))
    extra: dict[str, Any] = {} if cpu_share is None else {"pose_cpu_share": cpu_share}
    cfg = WebcamObserverConfig(learn_frames=3, max_people=12, pose=pose, pose_sync=sync, **extra)
    obs = WebcamObserver(cfg, cal)
    try:
        for k in range(3):
            obs.observe(Frame("webcam", k / fps, k, ColorImage(background)))
        seen: dict[int, int] = {}
        people = n = 0
        start, cpu0 = time.perf_counter(), time.thread_time()
        while (elapsed := time.perf_counter() - start) < seconds:
            if paced and (wait := n / fps - elapsed) > 0:
                time.sleep(wait)
            k = n + 3
            ob = obs.observe(Frame("webcam", k / fps, k, ColorImage(frames[n % len(frames)])))
            for pid in {c.person for c in ob.contactors}:
                seen[pid] = seen.get(pid, 0) + 1
            people += ob.people
            n += 1
        wall, cpu = time.perf_counter() - start, time.thread_time() - cpu0
        updates = obs.pose_updates
    finally:
        obs.close()
    per_frame = wall / max(n, 1)
    rates = [updates.get(p, 0) / (f * per_frame) for p, f in seen.items() if f * per_frame >= 0.5]
    return {"fps": n / wall, "people": people / max(n, 1), "loop_cpu_ms": 1000.0 * cpu / max(n, 1),
            "refresh": float(np.mean(rates)) if rates else 0.0, "refresh_min": float(min(rates, default=0.0))}


def _media(args: argparse.Namespace) -> Path:
    env = os.environ.get("JOSTLE_MEDIA", "").strip()
    beside = Path(__file__).resolve().parents[2].parent / "shared" / "media"
    media = args.media if args.media is not None else Path(env) if env else beside
    if not (media / "video").is_dir():
        raise ValueError(f"--media: {media} has no video/ folder (give the shared media folder)")
    return media


def scene(name: str, media: Path, cache: dict[str, Any]) -> tuple[list[np.ndarray], np.ndarray, float]:
    """The frames, empty background and frame rate of one scene."""
    video = media / "video"
    if name in ("sports2d", "walking"):
        frames, fps = read_clip(video / ("sports2d-demo.mp4" if name == "sports2d" else "face-demographics-walking.gif"))
        return frames, np.median(np.stack(frames[:: max(1, len(frames) // 40)]), axis=0).astype(np.uint8), fps
    if "people" not in cache:
        from interaction.webcam.pose import PoseModel
        from interaction.webcam.pose_models import default_model_dir

        model = PoseModel.from_dir(default_model_dir())
        signers = [read_clip(video / s)[0] for s in _SIGNERS]
        cache["people"] = [(f, cut_out(f, model.person_mask)) for f in signers]
        cache["room"] = cv2.resize(read_clip(video / _ROOM, limit=1)[0][0], (640, 480), interpolation=cv2.INTER_AREA)
    frames = crowd(cache["room"], cache["people"], int(name), 90)
    room = crowd(cache["room"], [([cache["room"]], [np.zeros((480, 640), np.uint8)])], int(name), 1)[0]
    return frames, room, 30.0


def run(args: argparse.Namespace) -> dict[str, object]:
    names = [s.strip() for s in str(args.scenes).split(",") if s.strip()]
    bad = [s for s in names if s not in SCENES]
    if bad or not names:
        raise ValueError(f"--scenes: {','.join(bad) or 'nothing'} is not one of {', '.join(SCENES)}")
    if not (0.2 <= args.seconds <= 600):
        raise ValueError(f"--seconds: expected 0.2 to 600, got {args.seconds}")
    media, cache = _media(args), dict[str, Any]()
    out: dict[str, object] = {}
    for name in names:
        frames, room, fps = scene(name, media, cache)
        share = args.cpu_share
        off = [measure(frames, room, fps, args.seconds, pose=False) for _ in range(2)]
        on = [measure(frames, room, fps, args.seconds, pose=True, cpu_share=share)]
        off.append(measure(frames, room, fps, args.seconds, pose=False))
        on.append(measure(frames, room, fps, args.seconds, pose=True, cpu_share=share))
        sync = measure(frames, room, fps, args.seconds, pose=True, sync=True)
        live = measure(frames, room, fps, args.seconds, pose=True, paced=True, cpu_share=share)
        fps_off, fps_on = float(np.mean([r["fps"] for r in off[1:]])), float(np.mean([r["fps"] for r in on]))
        out[f"{name}.people"] = round(float(np.mean([r["people"] for r in on])), 2)
        out[f"{name}.fps_off"] = round(fps_off, 1)
        out[f"{name}.fps_on"] = round(fps_on, 1)
        out[f"{name}.ratio_on_off"] = round(fps_on / fps_off, 3)
        out[f"{name}.ratio_sync_off"] = round(sync["fps"] / fps_off, 3)
        cpu_off, cpu_on = (float(np.mean([r["loop_cpu_ms"] for r in rs])) for rs in (off[1:], on))
        out[f"{name}.loop_cpu_ms_off"] = round(cpu_off, 2)
        out[f"{name}.loop_cpu_ms_on"] = round(cpu_on, 2)
        out[f"{name}.refresh_per_person_s"] = round(float(np.mean([r["refresh"] for r in on])), 2)
        out[f"{name}.refresh_per_person_s_min"] = round(min(r["refresh_min"] for r in on), 2)
        out[f"{name}.refresh_per_person_s_live"] = round(live["refresh"], 2)
        out[f"{name}.refresh_per_person_s_live_min"] = round(live["refresh_min"], 2)
    out["cpus"] = os.cpu_count() or 0
    out["load_average"] = round(os.getloadavg()[0], 2)
    return out
