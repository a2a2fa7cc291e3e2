"""``jostle keyframes preview``: a contact sheet of every keyframe and a video sweeping each axis of Q.

``contact_sheet.png``: one tile per key of every animation, drawn as the renderer draws it (in its
rigid body's frame, tilted by the key's Θ, standing on the floor), labelled with the animation and
the key's point of Q. A key that refers to a family is drawn as that family gives it at the
animation's base (an "any" coordinate taken as 0).

``sweep.mp4`` (and ``sweep.gif``, smaller): for each behaviour, each axis swept over its range with
the other coordinates at 0 — Θ from −π/2 to π/2, Dx and Dz over two cycles.
"""

from __future__ import annotations

import math
from pathlib import Path

import cv2
import numpy as np

from render.gl.renderer import Renderer
from render.gl.scene import body_rotations, posed_capsules
from render.gl.style import Camera, RenderStyle
from render.gl.video import VideoOut, save_gif
from render.keyframes import KeyframeSet
from render.keyframes.skeletons import figure_for
from sim.motion import quaternion as quat
from sim.snapshot import CharacterSnapshot, CharacterState, WorldSnapshot

TILE = 220
CAMERA = Camera(eye=(3.2, -2.6, 1.35), target=(0.0, 0.0, 0.6), fov_y_deg=34.0)


def body_orientation(theta_x: float, theta_z: float) -> tuple[float, float, float, float]:
    """The sim body's orientation (x y z w) facing +x, leaning forward by θx and right by θz."""
    pitch = quat.from_axis_angle(np.array([0.0, 1.0, 0.0]), theta_x)
    roll = quat.from_axis_angle(np.array([1.0, 0.0, 0.0]), theta_z)
    q = quat.multiply(pitch, roll)
    return (float(q[0]), float(q[1]), float(q[2]), float(q[3]))


def posed_snapshot(kset: KeyframeSet, q: np.ndarray, behaviour: str, height: float = 1.5) -> WorldSnapshot:
    """One character at point q of Q (array of the set's dimensions), resting on the floor at x = y = 0."""
    orientation = body_orientation(float(q[0]), float(q[1]))
    pose = kset.evaluate(q[None, :], [behaviour])
    figure = figure_for(kset.skeleton)
    scale = np.array([height / kset.height])
    a, b, r = posed_capsules(figure, pose, np.zeros((1, 3)), body_rotations(np.array([orientation])), scale,
                             np.zeros(1))
    lowest = float((np.minimum(a[..., 2], b[..., 2]) - r).min())
    c = CharacterSnapshot(
        name="preview", position=(0.0, 0.0, -lowest), orientation=orientation, velocity=(0.0, 0.0, 0.0),
        angular_velocity=(0.0, 0.0, 0.0), heading=0.0, tilt=(float(q[0]), float(q[1])), d_front=float(q[3]),
        d_side=float(q[2]), state=CharacterState.WALK, behaviour=behaviour, intent="idle", face_up=None,
        contact_force_n=0.0, height=height,
    )
    return WorldSnapshot(t=0.0, steps=0, characters=(c,))


def _label(img: np.ndarray, lines: list[str]) -> None:
    for i, text in enumerate(lines):
        y = 14 + 14 * i
        cv2.putText(img, text, (5, y), cv2.FONT_HERSHEY_SIMPLEX, 0.36, (0, 0, 0), 3, cv2.LINE_AA)
        cv2.putText(img, text, (5, y), cv2.FONT_HERSHEY_SIMPLEX, 0.36, (255, 255, 255), 1, cv2.LINE_AA)


def _fmt(kset: KeyframeSet, q: np.ndarray) -> str:
    short = {"theta_x": "Tx", "theta_z": "Tz", "dx": "Dx", "dz": "Dz"}
    return " ".join(f"{short.get(n, n)}={v:.2f}" for n, v in zip(kset.space.axes, q, strict=True))


def contact_sheet(kset: KeyframeSet, path: Path, columns: int = 8) -> int:
    """Write the contact sheet PNG; returns the number of tiles."""
    tiles = []
    with Renderer(TILE, TILE, camera=CAMERA, style=RenderStyle(camera=CAMERA), stage_x=(-0.6, 0.6)) as r:
        for curve in kset.animations:
            for k, x in enumerate(curve.coords):
                q = np.array([0.0 if b is None else b for b in curve.base])
                q[curve.axis] = x
                img = r.draw(posed_snapshot(kset, q, curve.behaviour), None, kset).copy()
                key = curve.keys[k]
                what = kset.key_names[key] if isinstance(key, int) else f"family {key}"
                _label(img, [curve.name, f"key {k}: {what}"[:34], _fmt(kset, q), f"B={curve.behaviour}"])
                tiles.append(img)
    rows = math.ceil(len(tiles) / columns)
    sheet = np.full((rows * TILE, columns * TILE, 3), 30, np.uint8)
    for i, tile in enumerate(tiles):
        y, x = divmod(i, columns)
        sheet[y * TILE : (y + 1) * TILE, x * TILE : (x + 1) * TILE] = tile
    path.parent.mkdir(parents=True, exist_ok=True)
    cv2.imwrite(str(path), sheet)
    return len(tiles)


def sweep(kset: KeyframeSet, path: Path, frames_per_axis: int = 60, size: tuple[int, int] = (480, 360)) -> int:
    """Write the sweep video (MP4, and a GIF beside it); returns the number of frames."""
    w, h = size
    cam = Camera(eye=(3.6, -3.0, 1.5), target=(0.0, 0.0, 0.6), fov_y_deg=34.0)
    frames = []
    with Renderer(w, h, camera=cam, stage_x=(-0.8, 0.8)) as r:
        for behaviour in kset.behaviours:
            for axis, name in enumerate(kset.space.axes):
                if not any(c.axis == axis and c.behaviour == behaviour for c in kset.animations):
                    continue
                if kset.space.periodic[axis]:
                    values = np.linspace(0.0, 2.0, frames_per_axis, endpoint=False) % 1.0
                else:
                    lo = max(kset.space.lo[axis], -math.pi / 2)
                    hi = min(kset.space.hi[axis], math.pi / 2)
                    values = np.concatenate([np.linspace(0, hi, frames_per_axis // 4),
                                             np.linspace(hi, lo, frames_per_axis // 2),
                                             np.linspace(lo, 0, frames_per_axis // 4)])
                for v in values:
                    q = np.zeros(kset.space.dims)
                    q[axis] = v
                    img = r.draw(posed_snapshot(kset, q, behaviour), None, kset).copy()
                    _label(img, [f"sweep {name}  B={behaviour}", _fmt(kset, q)])
                    frames.append(img)
    path.parent.mkdir(parents=True, exist_ok=True)
    with VideoOut(path, 30.0, (w, h)) as video:
        for f in frames:
            video.write(f)
    small = [cv2.resize(f, (w // 2, h // 2), interpolation=cv2.INTER_AREA) for f in frames[::2]]
    save_gif(small, path.with_suffix(".gif"), fps=15.0)
    return len(frames)
