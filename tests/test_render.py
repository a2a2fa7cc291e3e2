"""The headless renderer makes real pixels (EGL, llvmpipe here), and video files come out readable."""

from __future__ import annotations

import dataclasses
import math
import os
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import cv2
import numpy as np
import pytest
from PIL import Image, ImageSequence

from interaction.types import BodyObservation, Contactor
from render.gl.renderer import Renderer
from render.gl.style import Camera
from render.gl.video import VideoError, VideoOut, save_gif
from render.keyframes import KeyframeSet
from sim.snapshot import CharacterSnapshot, CharacterState, WorldSnapshot

SHIPPED = Path(__file__).resolve().parent.parent / "configs" / "keyframes" / "humanoid" / "keyframes.toml"
W, H = 320, 180


@pytest.fixture(scope="module")
def kset() -> KeyframeSet:
    return KeyframeSet.load(SHIPPED)


@pytest.fixture(scope="module")
def renderer() -> Iterator[Renderer]:
    r = Renderer(W, H, samples=4)
    yield r
    r.close()


def character(
    name: str = "ann",
    x: float = 0.0,
    y: float = 0.0,
    *,
    heading: float = 0.0,
    force: float = 0.0,
    d_front: float = 0.3,
) -> CharacterSnapshot:
    """An upright character facing ``heading`` (body frame x forward, y left, z up; mass centre 0.75 m up)."""
    return CharacterSnapshot(
        name=name,
        position=(x, y, 0.75),
        orientation=(0.0, 0.0, math.sin(heading / 2), math.cos(heading / 2)),
        velocity=(0.0, 0.0, 0.0),
        angular_velocity=(0.0, 0.0, 0.0),
        heading=heading,
        tilt=(0.0, 0.0),
        d_front=d_front,
        d_side=0.0,
        state=CharacterState.WALK,
        behaviour="walk",
        intent="wander",
        face_up=None,
        contact_force_n=force,
        height=1.5,
    )


def world(*chars: CharacterSnapshot) -> WorldSnapshot:
    return WorldSnapshot(t=0.0, steps=0, characters=tuple(chars))


def pixel_box(
    lo: tuple[float, float, float], hi: tuple[float, float, float], margin: int
) -> tuple[int, int, int, int]:
    """(row0, row1, col0, col1) bounding the projection of a stage-frame box, grown by ``margin`` pixels.

    Independent of the renderer's drawing: only the camera's documented matrix."""
    corners = np.array(
        [(x, y, z, 1.0) for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])]
    )
    clip = corners @ Camera().view_projection(W, H).T
    ndc = clip[:, :2] / clip[:, 3:4]
    cols = (ndc[:, 0] + 1) / 2 * W
    rows = (ndc[:, 1] + 1) / 2 * H
    return (
        int(rows.min()) - margin,
        int(math.ceil(rows.max())) + margin,
        int(cols.min()) - margin,
        int(math.ceil(cols.max())) + margin,
    )


def changed(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.abs(a.astype(int) - b.astype(int)).max(axis=2) > 8


def outside(mask: np.ndarray, box: tuple[int, int, int, int]) -> int:
    r0, r1, c0, c1 = box
    m = mask.copy()
    m[max(r0, 0) : max(r1, 0), max(c0, 0) : max(c1, 0)] = False
    return int(m.sum())


def test_frame_is_bgr_of_the_requested_size(renderer: Renderer, kset: KeyframeSet) -> None:
    frame = renderer.draw(world(character()), None, kset)
    assert frame.shape == (H, W, 3) and frame.dtype == np.uint8 and frame.flags["C_CONTIGUOUS"]


def test_default_size_is_1280_by_720(kset: KeyframeSet) -> None:
    with Renderer() as r:
        frame = r.draw(world(character()), None, kset)
    assert frame.shape == (720, 1280, 3) and frame.dtype == np.uint8


def test_character_is_drawn_where_it_stands(renderer: Renderer, kset: KeyframeSet) -> None:
    empty = renderer.draw(world(), None, kset)
    for x, y in ((0.0, 0.0), (-2.0, 1.0), (2.2, -0.5)):
        frame = renderer.draw(world(character(x=x, y=y)), None, kset)
        diff = changed(frame, empty)
        r0, r1, c0, c1 = pixel_box((x - 0.6, y - 0.6, 0.0), (x + 0.6, y + 0.6, 1.6), margin=0)
        inside = diff[max(r0, 0) : r1, max(c0, 0) : c1]
        assert inside.mean() > 0.08, f"character at {x, y}: only {inside.mean():.0%} of its box changed"
        assert outside(diff, pixel_box((x - 0.6, y - 0.6, 0.0), (x + 0.6, y + 0.6, 1.6), margin=3)) == 0


def test_same_snapshot_same_pixels(renderer: Renderer, kset: KeyframeSet) -> None:
    snap = world(character("ann", -1.0), character("bob", 1.0, heading=2.0, force=80.0))
    obs = BodyObservation(t=0.0, contactors=(Contactor(0, "hand", (0.5, 0.0, 1.0), (0.0, 0.0, 0.0), 0.15),))
    first = renderer.draw(snap, obs, kset)
    second = renderer.draw(snap, obs, kset)
    assert np.array_equal(first, second)


def test_a_push_flashes_red(renderer: Renderer, kset: KeyframeSet) -> None:
    empty = renderer.draw(world(), None, kset)
    calm = renderer.draw(world(character(force=0.0)), None, kset)
    pushed = renderer.draw(world(character(force=300.0)), None, kset)
    body = changed(calm, empty)
    redness = [float((f[..., 2].astype(int) - f[..., 1].astype(int))[body].mean()) for f in (calm, pushed)]
    assert redness[1] > redness[0] + 30, redness


def test_contactors_are_drawn_where_they_are(renderer: Renderer, kset: KeyframeSet) -> None:
    empty = renderer.draw(world(), None, kset)
    p = (1.5, 0.0, 1.0)
    obs = BodyObservation(
        t=0.0,
        contactors=(Contactor(person=1, part="hand", position=p, velocity=(0.0, 0.0, 0.0), radius=0.2),),
    )
    diff = changed(renderer.draw(world(), obs, kset), empty)
    box = pixel_box((p[0] - 0.2, p[1] - 0.2, p[2] - 0.2), (p[0] + 0.2, p[1] + 0.2, p[2] + 0.2), margin=0)
    assert diff[box[0] : box[1], box[2] : box[3]].mean() > 0.3
    assert (
        outside(
            diff, pixel_box((p[0] - 0.2, p[1] - 0.2, p[2] - 0.2), (p[0] + 0.2, p[1] + 0.2, p[2] + 0.2), 2)
        )
        == 0
    )


def test_silhouette_is_blended_over_its_half_of_the_frame(renderer: Renderer, kset: KeyframeSet) -> None:
    plain = renderer.draw(world(), None, kset)
    mask = np.zeros((90, 160), np.uint8)
    mask[:, :80] = 255
    frame = renderer.draw(world(), None, kset, silhouette=mask)
    diff = changed(frame, plain)
    assert diff[:, : W // 2 - 2].mean() > 0.95 and not diff[:, W // 2 + 2 :].any()
    tinted = frame[:, : W // 2 - 2].astype(int) - plain[:, : W // 2 - 2].astype(int)
    assert tinted[..., 0].mean() > tinted[..., 2].mean()  # towards blue (BGR channel 0)


def test_a_set_per_character_and_a_clear_error_for_a_missing_one(
    renderer: Renderer, kset: KeyframeSet
) -> None:
    renderer.draw(world(character("ann")), None, {"ann": kset})
    renderer.draw(world(character("bob")), None, {"*": kset})
    with pytest.raises(KeyError, match="no keyframe set for character 'bob'"):
        renderer.draw(world(character("bob")), None, {"ann": kset})


def test_close_twice_and_draw_after_close(kset: KeyframeSet) -> None:
    r = Renderer(64, 36, samples=0)
    r.draw(world(character()), None, kset)
    r.close()
    r.close()
    with pytest.raises(RuntimeError, match="after close"):
        r.draw(world(), None, kset)


def test_window_mode_without_a_display_says_so() -> None:
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    code = "from render.gl.renderer import Renderer\nRenderer(headless=False)"
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=60)
    assert out.returncode != 0
    assert "RendererUnavailable: render: no display for a window (DISPLAY is not set)" in out.stderr


# ------------------------------------------------------------------------------ video


def test_video_round_trip(tmp_path: Path) -> None:
    path = tmp_path / "out.mp4"
    frames = [np.full((48, 64, 3), (40 * i, 100, 200 - 40 * i), np.uint8) for i in range(5)]
    with VideoOut(path, 25.0, (64, 48)) as video:
        for f in frames:
            video.write(f)
        with pytest.raises(ValueError, match=r"^frame: expected \(48, 64, 3\) uint8"):
            video.write(np.zeros((64, 48, 3), np.uint8))
    cap = cv2.VideoCapture(str(path))
    got: list[np.ndarray] = []
    while True:
        ok, img = cap.read()
        if not ok:
            break
        got.append(np.asarray(img))
    cap.release()
    assert len(got) == 5 and got[0].shape == (48, 64, 3)
    assert np.abs(got[2].astype(int) - frames[2].astype(int)).mean() < 12


def test_video_in_a_missing_folder_is_a_clear_error(tmp_path: Path) -> None:
    with pytest.raises(VideoError, match="nowhere/out.mp4: cannot write a video there"):
        VideoOut(tmp_path / "nowhere" / "out.mp4", 25.0, (64, 48))


def test_gif(tmp_path: Path) -> None:
    frames = [np.full((20, 30, 3), (0, 0, 255 * (i % 2)), np.uint8) for i in range(3)]
    path = save_gif(frames, tmp_path / "a.gif", fps=10)
    with Image.open(path) as im:
        pictures = [np.asarray(f.convert("RGB")) for f in ImageSequence.Iterator(im)]
    assert len(pictures) == 3 and pictures[0].shape == (20, 30, 3)
    assert pictures[0][5, 5].tolist() == [0, 0, 0]
    assert pictures[1][5, 5, 0] > 200 and pictures[1][5, 5, 2] < 50  # red: BGR in, RGB in the file


# ------------------------------------------------------------------------------ people, flashes, HUD, critter


def test_silhouette_is_drawn_on_the_stage_where_the_calibration_puts_it(renderer: Renderer, kset: KeyframeSet) -> None:
    from interaction.webcam.calibration import Calibration

    # a 160×120 camera image covering stage x ∈ [−1, 1], z ∈ [2, 0] (rows top to bottom) on the plane y = 0.5
    calib = Calibration.from_correspondences(
        np.array([(0, 0), (160, 0), (160, 120), (0, 120)], dtype=float),
        np.array([(-1.0, 2.0), (1.0, 2.0), (1.0, 0.0), (-1.0, 0.0)]),
        plane_y=0.5,
    )
    mask = np.zeros((120, 160), np.uint8)
    mask[:, :80] = 255  # the person fills the image's left half: stage x ∈ [−1, 0]
    plain = renderer.draw(world(), None, kset)
    frame = renderer.draw(world(), None, kset, silhouette=mask, silhouette_calibration=calib)
    diff = changed(frame, plain)
    r0, r1, c0, c1 = pixel_box((-1.0, 0.5, 0.0), (0.0, 0.5, 2.0), margin=0)
    assert diff[r0 + 2 : r1 - 2, c0 + 2 : c1 - 2].mean() > 0.95
    assert outside(diff, pixel_box((-1.0, 0.5, 0.0), (0.0, 0.5, 2.0), margin=2)) == 0
    # a character standing in front of the plane hides it; one behind it is tinted by it
    front = renderer.draw(world(character(x=-0.5, y=-0.5)), None, kset, silhouette=mask, silhouette_calibration=calib)
    front_plain = renderer.draw(world(character(x=-0.5, y=-0.5)), None, kset)
    body = changed(front_plain, plain)
    assert changed(front, front_plain)[body].mean() < 0.05


def test_a_flash_where_a_contact_lands_then_fades(kset: KeyframeSet) -> None:
    from render.gl.style import Look, RenderStyle

    hand = BodyObservation(t=0.0, contactors=(Contactor(0, "hand", (0.45, 0.0, 1.1), (0.0, 0.0, 0.0), 0.12),))
    with Renderer(W, H, style=RenderStyle(look=Look(flash_s=0.3))) as r:
        calm = r.draw(world(character(force=0.0)), hand, kset)
        hit = r.draw(dataclasses.replace(world(character(force=40.0)), t=0.05), hand, kset)
        later = r.draw(dataclasses.replace(world(character(force=40.0)), t=0.5), hand, kset)
    glow = (hit.astype(int) - calm.astype(int)).clip(0).sum(axis=2)
    r0, r1, c0, c1 = pixel_box((0.1, -0.3, 0.8), (0.8, 0.3, 1.4), margin=2)
    near = glow[r0:r1, c0:c1]
    assert (near > 120).sum() > 20  # a bright flash around the contact
    lit_then = (hit.astype(int) - later.astype(int)).clip(0).sum(axis=2)[r0:r1, c0:c1]
    assert (lit_then > 120).sum() > 20  # gone 0.45 s later (the red tint of the push stays)


def test_hud_shows_the_figures(kset: KeyframeSet) -> None:
    from render.gl.style import Look, RenderStyle

    with Renderer(W, H, style=RenderStyle(look=Look(hud=True))) as r:
        with_hud = r.draw(world(character()), None, kset)
    with Renderer(W, H) as r:
        without = r.draw(world(character()), None, kset)
    diff = changed(with_hud, without)
    assert diff[:40, :150].mean() > 0.3 and not diff[80:, :].any()


def test_the_critter_is_drawn_small_with_its_own_set(renderer: Renderer, kset: KeyframeSet) -> None:
    critter = KeyframeSet.load(SHIPPED.parent.parent / "critter" / "keyframes.toml")
    empty = renderer.draw(world(), None, kset)
    tall = changed(renderer.draw(world(character()), None, kset), empty)
    small = dataclasses.replace(character(), height=0.8, position=(0.0, 0.0, 0.4))
    short = changed(renderer.draw(world(small), None, {"*": critter}), empty)
    rows_tall, rows_short = np.nonzero(tall.any(axis=1))[0], np.nonzero(short.any(axis=1))[0]
    span_tall, span_short = rows_tall.max() - rows_tall.min(), rows_short.max() - rows_short.min()
    assert 0.4 < span_short / span_tall < 0.7  # 0.8 m against 1.5 m, shadows included
    assert abs(int(rows_short.max()) - int(rows_tall.max())) <= 4  # both stand on the floor


def test_bench_render_reports_its_figures() -> None:
    from jostle.cli.bench import main_json

    figures = main_json("render", ["--characters", "6", "--width", "160", "--height", "90", "--frames", "4"])
    for key in ("characters", "width", "height", "fps", "frame_ms_p50", "frame_ms_p99", "pose_eval_us_per_character"):
        assert key in figures
    assert figures["characters"] == 6 and figures["fps"] > 0 and figures["pose_eval_us_per_character"] > 0


def test_a_smaller_render_scale_draws_the_same_picture_softer(kset: KeyframeSet) -> None:
    from render.gl.style import Look, RenderStyle

    snap = world(character(x=-1.0), character("bob", x=1.2, y=0.5, heading=2.5))
    with Renderer(W, H, style=RenderStyle(look=Look(render_scale=0.5))) as r:
        half = r.draw(snap, None, kset)
        empty_half = r.draw(world(), None, kset)
    with Renderer(W, H) as r:
        full = r.draw(snap, None, kset)
        empty_full = r.draw(world(), None, kset)
    assert half.shape == full.shape == (H, W, 3)
    a, b = changed(half, empty_half), changed(full, empty_full)
    overlap = (a & b).sum() / max(1, (a | b).sum())
    assert overlap > 0.75  # the same figures in the same places, edges softer


def test_style_errors_name_the_field() -> None:
    from render.gl.style import Colours, Look

    with pytest.raises(ValueError, match=r"^eye: expected 3 finite numbers"):
        Camera(eye=(0.0, 1.0))
    with pytest.raises(ValueError, match=r"^floor: expected a colour like"):
        Colours(floor="red")
    with pytest.raises(ValueError, match=r"^people\[1\]: expected a colour like"):
        Colours(people=("#ffffff", "#12345"))
    with pytest.raises(ValueError, match=r"^render_scale: expected 0.25 to 1"):
        Look(render_scale=2.0)


def test_sets_are_chosen_by_name_then_kind(renderer: Renderer, kset: KeyframeSet) -> None:
    critter = KeyframeSet.load(SHIPPED.parent.parent / "critter" / "keyframes.toml")
    small = dataclasses.replace(character("tiny"), height=0.8, position=(0.0, 0.0, 0.4), kind="critter")
    by_kind = renderer.draw(world(small), None, {"critter": critter, "*": kset})
    explicit = renderer.draw(world(small), None, {"tiny": critter})
    default = renderer.draw(world(small), None, {"*": kset})
    assert np.array_equal(by_kind, explicit) and not np.array_equal(by_kind, default)
