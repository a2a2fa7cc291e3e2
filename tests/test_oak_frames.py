"""OAK host-side frame assembly on real depthai messages (no device): intrinsics, sizes, numbering."""

from __future__ import annotations

import cv2
import depthai as dai
import numpy as np
import pytest

from sensors.oak.frames import (
    BadMessage,
    FrameNumbering,
    Intrinsics,
    assemble_depth,
    crop_to_aspect,
    fit_intrinsics,
    intrinsics_of,
    make_frame,
)

K_SRC = Intrinsics(fx=1030.0, fy=1027.5, cx=951.3, cy=547.8, width=1920, height=1080)


def _blob_image(k: Intrinsics, point: np.ndarray, sigma: float = 7.0) -> np.ndarray:
    """A float image of a Gaussian blob centred where ``k`` projects the 3D ``point``."""
    u = k.fx * point[0] / point[2] + k.cx
    v = k.fy * point[1] / point[2] + k.cy
    y, x = np.mgrid[0 : k.height, 0 : k.width].astype(np.float64)
    return np.exp(-((x - u) ** 2 + (y - v) ** 2) / (2 * sigma**2)).astype(np.float32)


def _centroid(image: np.ndarray) -> tuple[float, float]:
    w = image.astype(np.float64)
    w = np.where(w > 0.02 * w.max(), w, 0.0)
    y, x = np.mgrid[0 : image.shape[0], 0 : image.shape[1]]
    return float((w * x).sum() / w.sum()), float((w * y).sum() / w.sum())


def _project(k: Intrinsics, point: np.ndarray) -> tuple[float, float]:
    return k.fx * point[0] / point[2] + k.cx, k.fy * point[1] / point[2] + k.cy


@pytest.mark.parametrize("point", [np.array([0.31, -0.12, 2.5]), np.array([-0.6, 0.25, 3.1])])
def test_crop_fit_matches_what_opencv_does_to_the_pixels(point: np.ndarray) -> None:
    # 16:9 sensor image → 640x400 (16:10): crop the sides to the aspect, then downscale (depthai's CROP)
    big = _blob_image(K_SRC, point)
    small = cv2.resize(crop_to_aspect(big, (640, 400)), (640, 400), interpolation=cv2.INTER_AREA)
    k = fit_intrinsics(K_SRC, (640, 400), "crop")
    assert k.size == (640, 400)
    found = _centroid(small)
    expected = _project(k, point)
    assert found == pytest.approx(expected, abs=0.05)
    # multiplying cx by the scale (depthai's addScale convention) misses by (s - 1) / 2 px in x
    s = 400 / 1080
    assert abs(found[0] - (expected[0] - 0.5 * s + 0.5)) > 0.25


def test_stretch_fit_matches_cv2_resize_on_each_axis() -> None:
    point = np.array([0.2, 0.1, 2.0])
    k_src = Intrinsics(600.0, 605.0, 321.2, 238.9, 640, 480)
    big = _blob_image(k_src, point, sigma=5.0)
    small = cv2.resize(big, (320, 200), interpolation=cv2.INTER_AREA)
    k = fit_intrinsics(k_src, (320, 200), "stretch")
    assert _centroid(small) == pytest.approx(_project(k, point), abs=0.05)
    assert k.fx == pytest.approx(300.0) and k.fy == pytest.approx(605.0 * 200 / 480)


def test_fit_to_the_same_size_is_the_identity() -> None:
    assert fit_intrinsics(K_SRC, K_SRC.size) == K_SRC
    with pytest.raises(ValueError, match="size"):
        fit_intrinsics(K_SRC, (0, 10))


def _depth_msg(depth: np.ndarray, seq: int = 0, k: Intrinsics | None = None) -> dai.ImgFrame:
    msg = dai.ImgFrame()
    msg.setFrame(depth)
    msg.setType(dai.ImgFrame.Type.RAW16)
    msg.setWidth(depth.shape[1])
    msg.setHeight(depth.shape[0])
    msg.setSequenceNum(seq)
    if k is not None:
        msg.setTransformation(dai.ImgTransformation(k.width, k.height, [[k.fx, 0, k.cx], [0, k.fy, k.cy], [0, 0, 1]]))
    return msg


def _color_msg(color: np.ndarray, seq: int = 0) -> dai.ImgFrame:
    msg = dai.ImgFrame()
    msg.setCvFrame(color, dai.ImgFrame.Type.BGR888i)
    msg.setSequenceNum(seq)
    return msg


def _group(depth: dai.ImgFrame | None, color: dai.ImgFrame | None) -> dai.MessageGroup:
    g = dai.MessageGroup()
    if depth is not None:
        g["depth"] = depth
    if color is not None:
        g["color"] = color
    return g


RNG = np.random.default_rng(4)
DEPTH = RNG.integers(0, 9000, (40, 64), dtype=np.uint16)
COLOR = RNG.integers(0, 256, (40, 64, 3), dtype=np.uint8)
K_SMALL = Intrinsics(50.5, 51.25, 31.75, 19.5, 64, 40)


def test_intrinsics_ride_in_every_frame() -> None:
    assert intrinsics_of(_depth_msg(DEPTH, k=K_SMALL)) == K_SMALL
    assert intrinsics_of(_depth_msg(DEPTH)) is None  # no transformation set
    identity = Intrinsics(1.0, 1.0, 0.0, 0.0, 64, 40)
    assert intrinsics_of(_depth_msg(DEPTH, k=identity)) is None  # set, but not a calibration


def test_a_group_becomes_a_depth_image_bit_for_bit() -> None:
    image, source = assemble_depth(_group(_depth_msg(DEPTH, k=K_SMALL), _color_msg(COLOR)), (64, 40), None)
    assert source == "frame"
    assert image.depth_mm.dtype == np.uint16 and np.array_equal(image.depth_mm, DEPTH)
    assert image.color is not None and np.array_equal(image.color, COLOR)
    assert (image.fx, image.fy, image.cx, image.cy) == (K_SMALL.fx, K_SMALL.fy, K_SMALL.cx, K_SMALL.cy)


def test_calibration_is_the_fallback_and_zero_means_uncalibrated() -> None:
    calib = Intrinsics(101.0, 102.5, 63.5, 39.5, 128, 80)  # the device's calibration at twice the size
    image, source = assemble_depth(_depth_msg(DEPTH), (64, 40), calib)
    assert source == "calibration"
    assert (image.fx, image.cx) == pytest.approx((50.5, 31.5))
    image, source = assemble_depth(_depth_msg(DEPTH), (64, 40), None)
    assert source == "none" and (image.fx, image.fy, image.cx, image.cy) == (0.0, 0.0, 0.0, 0.0)
    assert image.color is None  # a lone depth ImgFrame: colour is off


def test_other_sizes_are_brought_to_the_configured_one() -> None:
    big_depth = np.kron(DEPTH, np.ones((2, 2), np.uint16))  # each value in a 2x2 block
    big_color = cv2.resize(COLOR, (100, 70))
    k_big = Intrinsics(101.0, 102.5, 63.5, 39.5, 128, 80)
    image, _ = assemble_depth(_group(_depth_msg(big_depth, k=k_big), _color_msg(big_color)), (64, 40), None)
    assert np.array_equal(image.depth_mm, DEPTH)  # nearest neighbour: no depth is invented
    assert image.color is not None and image.color.shape == (40, 64, 3)
    assert (image.fx, image.cx) == pytest.approx((50.5, 31.5))


def test_bad_messages_are_refused_with_what_was_wrong() -> None:
    with pytest.raises(BadMessage, match="without depth"):
        assemble_depth(_group(None, _color_msg(COLOR)), (64, 40), None)
    with pytest.raises(BadMessage, match="RAW16"):
        assemble_depth(_color_msg(COLOR), (64, 40), None)  # colour where depth belongs


def test_numbering_shows_gaps_survives_restarts_and_maps_latency() -> None:
    n = FrameNumbering()
    assert n.next(10.0, 0.030, device_seq=5) == pytest.approx((9.97, 0))
    assert n.next(10.1, 0.030, device_seq=6)[1] == 1
    assert n.next(10.2, 0.030, device_seq=9)[1] == 4  # two frames lost on the way
    assert n.skipped == 2
    n.restart_device_numbering()  # the camera reconnected and counts from 0 again
    assert n.next(10.3, 0.030, device_seq=0)[1] == 5
    t, _ = n.next(10.31, 5.0, device_seq=1)  # an age beyond MAX_AGE_S is clock skew: ignored
    assert t == pytest.approx(10.31)
    t2, _ = n.next(10.2, 0.0, device_seq=2)  # an earlier arrival time never takes t back
    assert t2 == t


def test_make_frame_numbers_from_the_device_sequence() -> None:
    n = FrameNumbering()
    group = _group(_depth_msg(DEPTH, seq=40, k=K_SMALL), _color_msg(COLOR, seq=40))
    frame, source = make_frame("oak", group, n, now=3.0, age_s=0.02, size=(64, 40), fallback=None)
    assert (frame.sensor, frame.seq, source) == ("oak", 0, "frame")
    assert frame.t == pytest.approx(2.98)
    frame, _ = make_frame("oak", _group(_depth_msg(DEPTH, seq=43, k=K_SMALL), None), n, now=3.1, age_s=0.0,
                          size=(64, 40), fallback=None)
    assert frame.seq == 3
