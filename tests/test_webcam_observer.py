"""The webcam observer on real frames drawn with OpenCV.

Each scene: a textured, noisy background (gradients, rectangles, blurred noise), person-like figures
(ellipse head, polygon torso, thick-line arms and legs, textured like clothing) moved a known number
of pixels per frame, camera noise on every frame, a slow global light change, and soft shadows
(darkened, same colour). The truth — each figure's mask and motion — is known exactly, so the
silhouettes, outlines and velocities are checked against it.
"""

from __future__ import annotations

import time
from collections.abc import Iterator
from dataclasses import dataclass

import cv2
import numpy as np
import pytest

from interaction.types import BodyObservation
from interaction.webcam import WebcamObserver, WebcamObserverConfig
from interaction.webcam.calibration import Calibration
from sensors.base import ColorImage, DepthImage, Frame

FPS = 30.0
LEARN = 10


# ---------------------------------------------------------------- scene drawing


def calibration_for(w: int, h: int) -> Calibration:
    """The image spans 4 m of stage at the top and 3.4 m at the floor, 3 m high."""
    uv = np.array([[0, 0], [w, 0], [w, h], [0, h]], dtype=np.float64)
    xz = np.array([[-2.0, 3.0], [2.0, 3.0], [1.7, 0.0], [-1.7, 0.0]])
    return Calibration.from_correspondences(uv, xz, plane_y=0.5, half_depth=0.8, image_size=(w, h))


def background(w: int, h: int, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    u = np.linspace(0, 1, w, dtype=np.float32)[None, :]
    v = np.linspace(0, 1, h, dtype=np.float32)[:, None]
    img = np.empty((h, w, 3), np.float32)
    img[..., 0] = 70 + 60 * u + 20 * v
    img[..., 1] = 100 + 50 * v
    img[..., 2] = 130 - 40 * u + 30 * v
    for _ in range(14):
        x0, y0 = int(rng.integers(0, w)), int(rng.integers(0, h))
        x1, y1 = x0 + int(rng.integers(10, w // 3)), y0 + int(rng.integers(10, h // 3))
        cv2.rectangle(img, (x0, y0), (x1, y1), [float(c) for c in rng.uniform(40, 220, 3)], -1)
    tex = rng.normal(0, 14, (h, w, 3)).astype(np.float32)
    img += cv2.GaussianBlur(tex, (3, 3), 0)
    return np.clip(img, 0, 255)


@dataclass
class Figure:
    colour: np.ndarray  # float32 (fh, fw, 3)
    mask: np.ndarray  # uint8 (fh, fw)


def figure(scale: float, seed: int, shirt: tuple[int, int, int]) -> Figure:
    """A person about 155 × scale px tall, arms out; clothes with a blotchy texture."""
    fh, fw = int(160 * scale), int(110 * scale)
    mask = np.zeros((fh, fw), np.uint8)
    colour = np.zeros((fh, fw, 3), np.float32)

    def p(x: float, y: float) -> tuple[int, int]:
        return int(round(x * scale)), int(round(y * scale))

    def part(draw: object, bgr: tuple[int, int, int]) -> None:
        m = np.zeros_like(mask)
        draw(m)  # type: ignore[operator]
        colour[m > 0] = bgr
        mask[m > 0] = 255

    trousers, torso = (120, 60, 30), np.array([p(38, 34), p(72, 34), p(68, 92), p(42, 92)], np.int32)
    part(lambda m: cv2.ellipse(m, p(55, 18), p(11, 14), 0, 0, 360, 255, -1), (90, 120, 200))
    part(lambda m: cv2.fillPoly(m, [torso], 255), shirt)
    part(lambda m: cv2.line(m, p(40, 38), p(8, 66), 255, max(2, int(9 * scale))), shirt)
    part(lambda m: cv2.line(m, p(70, 38), p(102, 66), 255, max(2, int(9 * scale))), shirt)
    part(lambda m: cv2.line(m, p(47, 90), p(35, 152), 255, max(2, int(12 * scale))), trousers)
    part(lambda m: cv2.line(m, p(63, 90), p(75, 152), 255, max(2, int(12 * scale))), trousers)
    tex = np.random.default_rng(seed).normal(0, 40, colour.shape).astype(np.float32)
    colour = np.clip(colour + 3 * cv2.GaussianBlur(tex, (0, 0), 1.5 * scale), 0, 255)
    return Figure(colour, mask)


@dataclass
class Shadow:
    centre: tuple[float, float]
    axes: tuple[float, float]
    depth: float  # 0.4: the floor gets 40 % darker in the core


def draw_frame(
    bg: np.ndarray,
    figures: list[tuple[Figure, int, int]],
    shadows: list[Shadow],
    gain: tuple[float, float, float],
    rng: np.random.Generator,
) -> tuple[np.ndarray, list[np.ndarray], np.ndarray]:
    """(uint8 BGR frame, each figure's true mask, where the shadows darken the floor by > 5 %)."""
    h, w = bg.shape[:2]
    img = bg.copy()
    shade = np.zeros((h, w), np.float32)
    for s in shadows:
        m = np.zeros((h, w), np.float32)
        cv2.ellipse(m, (int(s.centre[0]), int(s.centre[1])), (int(s.axes[0]), int(s.axes[1])), 0, 0, 360, 1.0, -1)
        shade = np.maximum(shade, s.depth * cv2.GaussianBlur(m, (0, 0), 5))
    img *= (1.0 - shade)[..., None]
    truths = []
    for fig, x, y in figures:
        truth = np.zeros((h, w), np.uint8)
        fh, fw = fig.mask.shape
        x0, y0, x1, y1 = max(0, x), max(0, y), min(w, x + fw), min(h, y + fh)
        on = fig.mask[y0 - y : y1 - y, x0 - x : x1 - x] > 0
        img[y0:y1, x0:x1][on] = fig.colour[y0 - y : y1 - y, x0 - x : x1 - x][on]
        truth[y0:y1, x0:x1][on] = 255
        truths.append(truth)
    img = img * np.asarray(gain, np.float32) + rng.normal(0, 3.0, img.shape).astype(np.float32)
    return np.clip(img + 0.5, 0, 255).astype(np.uint8), truths, (shade > 0.05).astype(np.uint8) * 255


def frame(k: int, img: np.ndarray) -> Frame:
    return Frame("webcam", k / FPS, k, ColorImage(img))


def drift(k: int, total: int, amount: float = 0.15) -> tuple[float, float, float]:
    """Slow global light change: darker and slightly warmer over the sequence."""
    f = k / max(total - 1, 1)
    return (1.0 - amount * f, 1.0 - 0.9 * amount * f, 1.0 - 0.8 * amount * f)


# ---------------------------------------------------------------- measures


def iou(a: np.ndarray, b: np.ndarray) -> float:
    return float(((a > 0) & (b > 0)).sum() / max(((a > 0) | (b > 0)).sum(), 1))


def outline_distance(truth: np.ndarray, uv: np.ndarray) -> np.ndarray:
    """Pixels from each point to the true mask's boundary."""
    boundary = truth - cv2.erode(truth, np.ones((3, 3), np.uint8))
    dist = cv2.distanceTransform(np.where(boundary > 0, 0, 255).astype(np.uint8), cv2.DIST_L2, 5)
    h, w = truth.shape
    u = np.clip(np.round(uv[:, 0]).astype(int), 0, w - 1)
    v = np.clip(np.round(uv[:, 1]).astype(int), 0, h - 1)
    return np.asarray(dist[v, u])


def velocity_errors(obs: BodyObservation, cal: Calibration, motion_px: tuple[float, float]) -> np.ndarray:
    """|v − v_true| / |v_true| per contactor; v_true from the figure's known pixel motion per frame."""
    pos = np.array([c.position for c in obs.contactors])
    vel = np.array([c.velocity for c in obs.contactors])
    uv = cal.stage_to_image(pos)
    true = (cal.image_to_stage(uv) - cal.image_to_stage(uv - np.asarray(motion_px))) * FPS
    return np.asarray(np.linalg.norm(vel - true, axis=1) / np.linalg.norm(true, axis=1))


# ---------------------------------------------------------------- configuration and input checks


@pytest.mark.parametrize(
    ("field", "value"),
    [
        ("learn_frames", 0),
        ("diff_threshold", -1.0),
        ("shadow_min_ratio", 1.5),
        ("min_blob_area", 0.0),
        ("contour_spacing_px", 0.5),
        ("flow_preset", "slowest"),
        ("work_width", 16),
        ("max_people", 0),
    ],
)
def test_config_rejects_bad_values_naming_the_field(field: str, value: object) -> None:
    with pytest.raises(ValueError, match=rf"^{field}: expected"):
        WebcamObserverConfig(**{field: value})  # type: ignore[arg-type]


def test_frames_other_than_colour_images_are_refused() -> None:
    obs = WebcamObserver(WebcamObserverConfig(), calibration_for(320, 240))
    depth = Frame("oak", 0.0, 3, DepthImage(np.zeros((240, 320), np.uint16), 300.0, 300.0, 160.0, 120.0))
    with pytest.raises(ValueError, match=r"frame 3 from sensor 'oak' carries a depth payload; expected a colour"):
        obs.observe(depth)
    with pytest.raises(ValueError, match=r"640×480, but the calibration was made for 320×240"):
        obs.observe(frame(0, np.zeros((480, 640, 3), np.uint8)))


# ---------------------------------------------------------------- empty stage


@pytest.mark.parametrize("refresh", [False, True], ids=["frozen", "refreshed"])
def test_learning_then_nothing_on_an_empty_stage_under_drifting_light(refresh: bool) -> None:
    w, h = 320, 240
    cal = calibration_for(w, h)
    config = WebcamObserverConfig(learn_frames=LEARN, refresh_after_empty_frames=20 if refresh else 10_000,
                                  adapt_rate=0.01 if refresh else 0.0)
    observer = WebcamObserver(config, cal)
    bg = background(w, h)
    rng = np.random.default_rng(1)
    total = LEARN + 60
    for k in range(total):
        img, _, _ = draw_frame(bg, [], [], drift(k, total, amount=0.25), rng)
        assert observer.learning == (k < LEARN)
        obs = observer.observe(frame(k, img))
        assert obs.t == k / FPS
        assert obs.contactors == () and obs.people == 0, f"frame {k}: {obs.people} people on an empty stage"
        if k >= LEARN:
            sil = observer.silhouette
            assert sil is not None and not sil.any()
    learned = observer.background
    assert learned is not None
    if refresh:  # the background followed the light down while no one was in view
        assert observer.light_gain[0] > 0.8 and learned.mean() < 0.95 * bg.mean()
    else:  # frozen: the 25 % drop was undone by the light gain alone
        assert observer.light_gain[0] == pytest.approx(0.75, abs=0.02)
        assert learned.mean() == pytest.approx(bg.mean(), rel=0.03)  # learned while the drift began
    observer.relearn()
    assert observer.learning and observer.silhouette is None


def test_a_shadow_alone_is_not_a_person_but_would_be_without_suppression() -> None:
    w, h = 320, 240
    cal = calibration_for(w, h)
    bg = background(w, h)
    with_suppression = WebcamObserver(WebcamObserverConfig(), cal)
    without = WebcamObserver(WebcamObserverConfig(shadow_min_ratio=1.0), cal)  # only α = 1 counts as shadow
    rng = np.random.default_rng(2)
    seen_without = 0
    for k in range(LEARN + 20):
        # shadows down to 60 % of the floor's light are suppressed (shadow_min_ratio); darker is taken for
        # dark clothes (dark trousers on a brown floor are α ≈ 0.4–0.55 and must stay people)
        shadows = [Shadow((60 + 6 * k, 200), (45, 14), 0.38), Shadow((250, 120 + k), (20, 50), 0.33)]
        img, _, _ = draw_frame(bg, [], shadows if k >= LEARN else [], (1.0, 1.0, 1.0), rng)
        a = with_suppression.observe(frame(k, img))
        b = without.observe(frame(k, img))
        assert a.people == 0 and a.contactors == (), f"frame {k}: a shadow became {a.people} people"
        seen_without += b.people > 0
    assert seen_without >= 15  # the shadows are strong enough to matter


# ---------------------------------------------------------------- one moving person


def _walk(
    w: int, h: int, scale: float, motion: tuple[int, int], frames: int, seed: int = 5
) -> Iterator[tuple[int, np.ndarray, np.ndarray | None, np.ndarray]]:
    """Frames of one figure walking with a soft shadow at its feet under drifting light."""
    bg = background(w, h)
    fig = figure(scale, seed=11, shirt=(40, 40, 170))
    rng = np.random.default_rng(seed)
    total = LEARN + frames
    for k in range(total):
        if k < LEARN:
            img, _, shade = draw_frame(bg, [], [], drift(k, total), rng)
            yield k, img, None, shade
            continue
        i = k - LEARN
        y0 = 30 if motion[1] >= 0 else 72  # stays whole in the frame
        x, y = int(40 * scale) + motion[0] * i, int(y0 * scale) + motion[1] * i
        feet = (x + 105 * scale, y + 153 * scale)
        shadow = Shadow(feet, (45 * scale, 9 * scale), 0.38)  # as dark as shadow_min_ratio suppresses
        img, truths, shade = draw_frame(bg, [(fig, x, y)], [shadow], drift(k, total), rng)
        yield k, img, truths[0], shade


@pytest.mark.parametrize(
    ("size", "scale", "motion"),
    [((320, 240), 1.0, (3, 1)), ((320, 240), 1.0, (1, -3)), ((640, 480), 2.0, (6, 2))],
    ids=["320-right", "320-up", "640-right"],
)
def test_one_walking_person(size: tuple[int, int], scale: float, motion: tuple[int, int]) -> None:
    w, h = size
    cal = calibration_for(w, h)
    observer = WebcamObserver(WebcamObserverConfig(), cal)
    ious, dists, errs, ids = [], [], [], set()
    for k, img, truth, shade in _walk(w, h, scale, motion, frames=24):
        obs = observer.observe(frame(k, img))
        if truth is None:
            assert obs.contactors == ()
            continue
        assert obs.people == 1
        ids |= {c.person for c in obs.contactors}
        sil = observer.silhouette
        assert sil is not None and sil.shape == (h, w)
        ious.append(iou(sil, truth))
        pos = np.array([c.position for c in obs.contactors])
        uv = cal.stage_to_image(pos)
        dists.append(outline_distance(truth, uv))
        # shadows never become contactors: none lies in the shadow away from the figure
        away = (shade > 0) & (cv2.dilate(truth, np.ones((7, 7), np.uint8)) == 0)
        assert not away[np.clip(uv[:, 1].round().astype(int), 0, h - 1), np.clip(uv[:, 0].round().astype(int), 0, w - 1)].any()
        # capsules on the calibrated plane, moving in it
        assert all(c.position[1] == 0.5 and c.velocity[1] == 0.0 and c.half_depth == 0.8 for c in obs.contactors)
        assert all(0.01 < c.radius < 0.2 for c in obs.contactors)
        parts = [c.part for c in obs.contactors]
        assert parts.count("head") == 1 and parts.count("hand") == 2 and 1 <= parts.count("foot") <= 2
        _check_extremities(obs, cal, truth)
        if k == LEARN:
            assert all(c.velocity == (0.0, 0.0, 0.0) for c in obs.contactors)  # first sight: no motion yet
        else:
            errs.append(velocity_errors(obs, cal, motion))
    d, e = np.concatenate(dists), np.concatenate(errs)
    print(
        f"\n{w}x{h} motion {motion} px/frame: IoU min {min(ious):.3f}; outline distance p50 {np.median(d):.2f} "
        f"p95 {np.percentile(d, 95):.2f} px; velocity error p50 {np.median(e):.1%} p80 {np.percentile(e, 80):.1%} "
        f"within 25 %: {np.mean(e < 0.25):.1%}"
    )
    assert ids == {0}
    assert min(ious) > 0.8
    tol = 2.0 * w / 320  # one work pixel is 2 input pixels at 640 wide
    assert np.percentile(d, 95) <= tol
    assert np.median(e) < 0.15
    assert np.mean(e < 0.25) > 0.7


def _check_extremities(obs: BodyObservation, cal: Calibration, truth: np.ndarray) -> None:
    ys, xs = np.nonzero(truth)
    tol = 3.0 * truth.shape[1] / 320
    for c in obs.contactors:
        u, v = cal.stage_to_image(np.array([c.position]))[0]
        if c.part == "head":
            assert abs(v - ys.min()) <= tol
        elif c.part == "hand":
            assert min(abs(u - xs.min()), abs(u - xs.max())) <= tol
        elif c.part == "foot":  # the middle of the shoe-high band at the bottom (5 % of the height)
            assert ys.max() - 0.05 * (ys.max() - ys.min()) - tol <= v <= ys.max() + tol


def test_where_the_frame_cuts_a_person_there_are_no_contactors() -> None:
    w, h = 320, 240
    cal = calibration_for(w, h)
    observer = WebcamObserver(WebcamObserverConfig(), cal)
    bg = background(w, h)
    fig = figure(1.0, seed=11, shirt=(40, 40, 170))
    rng = np.random.default_rng(3)
    for k in range(LEARN + 8):
        figs = [(fig, -40 + 3 * (k - LEARN), 100)] if k >= LEARN else []  # entering from the left, feet cut off
        img, truths, _ = draw_frame(bg, figs, [], (1.0, 1.0, 1.0), rng)
        obs = observer.observe(frame(k, img))
        if k < LEARN:
            continue
        assert obs.people == 1
        uv = cal.stage_to_image(np.array([c.position for c in obs.contactors]))
        assert uv[:, 0].min() > 0.5 and uv[:, 1].max() < h - 1.5
        assert "foot" not in {c.part for c in obs.contactors}
        assert np.percentile(outline_distance(truths[0], uv), 95) <= 2.0


# ---------------------------------------------------------------- two people


def test_two_people_keep_their_ids() -> None:
    w, h = 320, 240
    cal = calibration_for(w, h)
    observer = WebcamObserver(WebcamObserverConfig(), cal)
    bg = background(w, h, seed=4)
    left, right = figure(0.8, seed=21, shirt=(40, 40, 170)), figure(0.8, seed=22, shirt=(40, 150, 40))
    rng = np.random.default_rng(9)
    owner: dict[int, int] = {}  # person id → which figure (0 left, 1 right)
    for k in range(LEARN + 24):
        i = max(0, k - LEARN)
        figs = [(left, 10 + 2 * i, 60), (right, 220 - 2 * i, 50 + i)] if k >= LEARN else []  # 30 px apart at the end
        img, truths, _ = draw_frame(bg, figs, [], drift(k, LEARN + 24), rng)
        obs = observer.observe(frame(k, img))
        if k < LEARN:
            continue
        assert obs.people == 2
        for pid in {c.person for c in obs.contactors}:
            uv = cal.stage_to_image(np.array([c.position for c in obs.contactors if c.person == pid]))
            near = [float(np.median(outline_distance(t, uv))) for t in truths]
            fig = int(np.argmin(near))
            assert near[fig] < 2.0
            assert owner.setdefault(pid, fig) == fig, f"frame {k}: person {pid} jumped to the other figure"
    assert sorted(owner) == [0, 1] and sorted(owner.values()) == [0, 1]


# ---------------------------------------------------------------- determinism and cost


def test_same_frames_give_the_same_observations() -> None:
    frames = [frame(k, img) for k, img, _, _ in _walk(320, 240, 1.0, (2, 1), frames=6)]
    a = WebcamObserver(WebcamObserverConfig(), calibration_for(320, 240))
    b = WebcamObserver(WebcamObserverConfig(), calibration_for(320, 240))
    assert [a.observe(f) for f in frames] == [b.observe(f) for f in frames]


@pytest.mark.slow
@pytest.mark.parametrize(("size", "scale"), [((320, 240), 1.0), ((640, 480), 2.0)])
def test_cost_per_frame(size: tuple[int, int], scale: float) -> None:
    w, h = size
    frames = [frame(k, img) for k, img, _, _ in _walk(w, h, scale, (2, 1), frames=60)]
    observer = WebcamObserver(WebcamObserverConfig(), calibration_for(w, h))
    for f in frames[: LEARN + 2]:
        observer.observe(f)
    times = []
    for f in frames[LEARN + 2 :]:
        t0 = time.perf_counter()
        observer.observe(f)
        times.append(time.perf_counter() - t0)
    ms = 1000 * np.array(times)
    print(f"\n{w}x{h}: {np.median(ms):.2f} ms per frame (p90 {np.percentile(ms, 90):.2f}) with one person")
    assert np.median(ms) < 40.0
