"""The pose worker on real people: two signers of the ASL clips (fixtures/signers, CC BY 4.0; cut
out by the segmentation model) side by side, and one on the empty room of another real clip. The
worker attaches keypoints to the right people with their frame's time, drops frames it had no time
for instead of queueing them, stops when the observer closes, and inline (``pose_sync``) gives the
keypoints the tracker gives when called directly. Skipped only if the model files cannot be had."""

from __future__ import annotations

import threading
from functools import cache
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import pytest
from pose_fixtures import model_dir, pose_model

from interaction.webcam import WebcamObserver, WebcamObserverConfig
from interaction.webcam.calibration import Calibration
from interaction.webcam.pose import PoseModel, PoseTracker
from interaction.webcam.pose_worker import PosePerson, PoseResult, PoseWorker
from sensors.base import ColorImage, Frame

SIGNERS = Path(__file__).parent / "fixtures" / "signers"
FRAMES = (0, 5, 10, 15, 20, 25, 30, 35)  # the fixture's frames of each clip, 30 fps
W, H = 320, 240


def image(name: str) -> np.ndarray:
    img = cv2.imread(str(SIGNERS / f"{name}.jpg"), cv2.IMREAD_COLOR)
    assert img is not None, f"missing fixture {name}.jpg"
    return img


@cache
def signer(clip: str, k: int) -> tuple[np.ndarray, np.ndarray]:
    """Frame ``k`` of a clip and its person's outline (N, 2) pixels, from the segmentation model."""
    img = image(f"{clip}-{k:02d}")
    mask = (pose_model().person_mask(img) > 0.5).astype(np.uint8)
    contours, _ = cv2.findContours(mask, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
    outline = max(contours, key=cv2.contourArea).reshape(-1, 2).astype(np.float64)
    return img, outline


def side_by_side(k: int) -> tuple[np.ndarray, list[PosePerson]]:
    """Signer of walk.mkv on the left (person 1), of help.mkv on the right (person 2)."""
    (left, lo), (right, ro) = signer("walk", k), signer("help", k)
    return np.hstack([left, right]), [PosePerson(1, lo), PosePerson(2, ro + [W, 0])]


def worker(threaded: bool) -> PoseWorker:
    return PoseWorker(PoseTracker(PoseModel.from_dir(model_dir())), threaded=threaded)


def by_person(results: list[PoseResult]) -> dict[int, PoseResult]:
    return {r.person: r for r in results}


def test_the_worker_attaches_keypoints_to_the_right_people_with_their_frame_time() -> None:
    img, people = side_by_side(0)
    live, inline = worker(threaded=True), worker(threaded=False)
    try:
        live.submit(0.5, img, people)
        assert live.wait_idle(20.0)
        got = by_person(live.take())
    finally:
        live.close()
    inline.submit(0.5, img, people)
    want = by_person(inline.take())
    assert set(got) == set(want) == {1, 2}
    for pid, side in ((1, (0, W)), (2, (W, 2 * W))):
        kp = got[pid].keypoints
        assert kp is not None and kp.score > 0.5 and kp.t == got[pid].t == 0.5
        for name in ("nose", "left_shoulder", "right_shoulder"):
            u, v = kp.point(name)
            assert side[0] <= u < side[1] and 0 <= v < H, (pid, name, u, v)
        # the same model on the same crop in another thread: the same numbers (one process, one machine)
        other = want[pid].keypoints
        assert other is not None and np.array_equal(kp.uv, other.uv)


def test_frames_it_has_no_time_for_are_dropped_not_queued() -> None:
    live = worker(threaded=True)
    try:
        submitted = 30
        for i in range(submitted):  # far faster than two people a frame can be looked at
            img, people = side_by_side(FRAMES[i % len(FRAMES)])
            live.submit(i / 30, img, people)
        assert live.wait_idle(30.0)
        results = live.take()
    finally:
        live.close()
    assert live.frames_started + live.frames_dropped == submitted
    assert live.frames_dropped >= submitted // 2
    times = [r.t for r in results]
    assert times == sorted(times)
    assert times[-1] == (submitted - 1) / 30  # the newest frame is always looked at
    assert live.runs == len(results) < 2 * submitted


def test_inline_gives_the_keypoints_of_the_tracker_called_directly() -> None:
    inline, direct = worker(threaded=False), PoseTracker(PoseModel.from_dir(model_dir()))
    for i, k in enumerate(FRAMES[:4]):
        img, people = side_by_side(k)
        inline.submit(i / 6, img, people)
        got = by_person(inline.take())
        for p in people:
            want = direct.track(img, p.person, p.outline)
            kp = got[p.person].keypoints
            assert want is not None and kp is not None
            assert np.array_equal(kp.uv, want.uv) and kp.score == want.score and kp.t == i / 6


def observer(sync: bool) -> WebcamObserver:
    uv = np.array([[0, 0], [W, 0], [W, H], [0, H]], dtype=np.float64)
    xz = np.array([[-1.0, 1.5], [1.0, 1.5], [1.0, 0.0], [-1.0, 0.0]])
    cal = Calibration.from_correspondences(uv, xz, plane_y=0.0, half_depth=0.5, image_size=(W, H))
    cfg = WebcamObserverConfig(learn_frames=2, pose=True, pose_sync=sync, pose_model_dir=str(model_dir()))
    return WebcamObserver(cfg, cal)


def on_the_room(k: int) -> np.ndarray:
    """The signer of walk.mkv, cut out, standing in the empty room of one-by-one-person-detection.mp4."""
    img = image(f"walk-{k:02d}")
    mask = pose_model().person_mask(img) > 0.5
    out = image("room")
    out[mask] = img[mask]
    return out


def feed(obs: WebcamObserver, rounds: int = 2) -> list[tuple[float, object]]:
    out: list[tuple[float, object]] = []
    for i in range(2):
        obs.observe(Frame("webcam", i / 30, i, ColorImage(image("room"))))
    for i in range(rounds * len(FRAMES)):
        t, k = (i + 2) / 6, FRAMES[i % len(FRAMES)]  # every 5th frame of a 30 fps clip
        out.append((t, obs.observe(Frame("webcam", t, i + 2, ColorImage(on_the_room(k))))))
        kps = obs.keypoints
        assert all(kp.t is not None and kp.t <= t for kp in kps.values())
        if obs.pose_worker is not None and obs.pose_worker.threaded:
            assert obs.pose_worker.wait_idle(20.0)  # this test is about attaching, not about speed
    return out


def test_the_observer_attaches_the_workers_keypoints_and_stops_it_on_close() -> None:
    obs = observer(sync=False)
    worker_thread = [t for t in threading.enumerate() if t.name == "jostle-pose" and t.is_alive()]
    assert obs.pose_worker is not None and obs.pose_worker.running and worker_thread
    try:
        seen = feed(obs)
    finally:
        obs.close()
    assert not obs.pose_worker.running
    assert not any(t.is_alive() for t in worker_thread)
    updates = obs.pose_updates
    assert len(updates) == 1 and next(iter(updates.values())) >= len(seen) - 2
    (pid,) = updates
    # keypoints looked at in frame i arrive at frame i + 1: their limbs are there from then on
    hands = [ob for _, ob in seen if any(c.part.endswith("hand") for c in ob.contactors)]  # type: ignore[attr-defined]
    assert len(hands) >= len(seen) // 2
    assert obs.keypoints[pid].t == seen[-2][0]


def test_inline_observers_give_the_same_contactors_twice() -> None:
    first, second = observer(sync=True), observer(sync=True)
    a, b = feed(first, rounds=1), feed(second, rounds=1)
    assert first.pose_worker is not None and not first.pose_worker.threaded
    assert [ob for _, ob in a] == [ob for _, ob in b]
    assert any(c.part.endswith("hand") for _, ob in a for c in ob.contactors)  # type: ignore[attr-defined]
    pid = next(iter(first.pose_updates))
    assert first.pose_updates[pid] == len(a) and first.keypoints[pid].t == a[-1][0]


def test_the_app_guard_closes_a_crashed_webcam_observer_and_its_own_at_the_end() -> None:
    from jostle.observer_guard import ObserverGuard
    from sensors.base import DepthImage
    from sensors.clock import SimClock

    built: list[WebcamObserver] = []

    def build() -> WebcamObserver:
        built.append(observer(sync=False))
        return built[-1]

    clock = SimClock()
    guard = ObserverGuard("webcam", build, clock, first_backoff_s=1.0)
    depth = DepthImage(np.zeros((4, 4), np.uint16), 1.0, 1.0, 2.0, 2.0)
    guard.observe(Frame("webcam", 0.0, 0, depth))  # not a colour image: the observer raises, the guard drops it
    first = built[0].pose_worker
    assert first is not None and not first.running
    clock.advance(2.0)
    guard.observe(Frame("webcam", 2.0, 1, ColorImage(image("room"))))  # rebuilt after its back-off
    assert len(built) == 2
    second = built[1].pose_worker
    assert second is not None and second.running
    guard.close()  # the app does this when the run ends
    assert not second.running and guard.health().state == "running"


def test_on_simulated_time_the_app_runs_pose_inline(tmp_path: Path) -> None:
    from jostle.config import ObserverEntry
    from jostle.run_setup import observer_builder

    cal = tmp_path / "webcam.calibration.toml"
    observer(sync=True).calibration.save(cal)
    cfg = WebcamObserverConfig(pose=True, pose_model_dir=str(model_dir()))
    entry = ObserverEntry("webcam", "webcam", "webcam", cal, cfg)
    built = [observer_builder(entry, entry.calibration, inline)() for inline in (True, False)]
    try:
        workers = [b.pose_worker for b in built if isinstance(b, WebcamObserver)]
        assert len(workers) == 2 and workers[0] is not None and workers[1] is not None
        assert not workers[0].threaded and workers[1].threaded  # replays inline; live beside the loop
    finally:
        for b in built:
            if isinstance(b, WebcamObserver):
                b.close()


def test_limb_velocities_are_over_the_keypoints_own_frame_times() -> None:
    """The signer slid right 4 px a frame at 30 fps (120 px/s); the worker's keypoints arrive one or
    two frames late, some frames never looked at: the hands' velocity is still 120 px/s."""
    from interaction.webcam.pose_limbs import PoseLimbs

    img = image("walk-00")
    mask = pose_model().person_mask(img) > 0.5
    room = image("room")
    model = PoseModel.from_dir(model_dir())
    limbs = PoseLimbs(PoseWorker(PoseTracker(model), threaded=True), PoseTracker(model), max_age_s=1.0)
    velocities: list[tuple[float, float]] = []
    held: Any = None
    try:
        for k in range(24):
            shift = 4 * k
            frame = room.copy()
            frame[:, shift:][mask[:, : W - shift]] = img[:, : W - shift][mask[:, : W - shift]]
            contours, _ = cv2.findContours(np.roll(mask, shift, axis=1).astype(np.uint8) * 255, cv2.RETR_EXTERNAL,
                                           cv2.CHAIN_APPROX_NONE)
            outline = max(contours, key=cv2.contourArea).reshape(-1, 2).astype(np.float64)
            if k % 3 == 2:  # every third frame the next one comes before the worker starts it: the
                held = limbs.worker._wake  # worker is held out (its lock, re-entrant here) until it has
                held.acquire()
            limbs.update(k / 30, frame, [7], [outline])
            if held is not None and k % 3 == 0:
                held.release()  # frame k - 1 was replaced by frame k: dropped, whatever this machine's speed
                held = None
            if k % 3 != 2:
                assert limbs.worker.wait_idle(20.0)
            if k >= 10:
                accept = np.full((H, W), 255, np.uint8)
                velocities += [p.velocity for p in limbs.limbs(7, k / 30, accept) if p.part.endswith("hand")]
    finally:
        if held is not None:
            held.release()
        limbs.worker.close()
    assert limbs.worker.frames_dropped >= 1 and len(velocities) >= 10
    vu, vv = np.median(np.array(velocities), axis=0)
    assert abs(vu - 120.0) < 30.0 and abs(vv) < 30.0, (vu, vv)  # keypoints jitter a few px a frame


def test_who_is_looked_at_first() -> None:
    from interaction.webcam.pose_limbs import PoseLimbs
    from interaction.webcam.pose_worker import looking_order

    box = np.array([[0.0, 0.0], [10.0, 0.0], [10.0, 40.0], [0.0, 40.0]])
    near, far, new = PosePerson(1, box, rank=0.5), PosePerson(2, box, rank=3.0), PosePerson(3, box, rank=9.0)
    assert [p.person for p in looking_order([far, near, new], {})] == [1, 2, 3]  # by rank
    # the one never looked at, then the one looked at longest ago, whatever their rank
    assert [p.person for p in looking_order([far, near, new], {1: 0.2, 2: 0.1})] == [3, 2, 1]
    # the observer's ranks: without characters the larger outline first; with them the nearer
    limbs = PoseLimbs(PoseWorker(PoseTracker(pose_model()), threaded=False), PoseTracker(pose_model()), 0.3)
    small, big = box, np.array([[100.0, 0.0], [130.0, 0.0], [130.0, 90.0], [100.0, 90.0]])
    assert [p.rank for p in limbs.people([1, 2], [small, big])] == [-400.0, -2700.0]
    to_stage = lambda uv: np.column_stack([uv[:, 0] / 100.0, np.zeros(len(uv)), np.zeros(len(uv))])  # noqa: E731
    limbs.focus_on(np.array([[0.0, 0.0, 0.0], [2.0, 0.0, 0.0]]))  # characters at x = 0 and 2 m
    ranked = limbs.people([2, 1], [big, small], to_stage)  # given in any order: by id
    assert [p.person for p in ranked] == [1, 2]
    assert [p.rank for p in ranked] == pytest.approx([0.05, 0.85])  # box middles at x = 0.05 and 1.15 m
    limbs.focus_on(None)
    assert [p.rank for p in limbs.people([1, 2], [small, big], to_stage)] == [-400.0, -2700.0]
