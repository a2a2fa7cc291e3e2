"""WebcamSensor: OpenCV capture of a camera, a stream URL or a video file.

Two ways of running, chosen by the source:

- **Live** (device index, device path, URL): a reader thread captures frames into a small bounded
  queue (the oldest frame is dropped when it is full, and counted); ``t`` is ``clock.now()`` at
  capture; ``read(timeout)`` waits at most ``timeout``. When the camera or stream vanishes the
  status turns RECONNECTING with the reason, the thread retries every ``reconnect_s``, and the
  status returns to CONNECTED once frames flow again. ``seq`` counts captured frames, so drops
  show as gaps. The thread is :class:`sensors.threaded.ThreadedDriver`'s; if it crashes (a bug),
  the status turns FAILED and ``read`` raises.
- **File**: frames follow the file's own timeline, ``t = t_open + index / file fps``, and each is
  returned only once it is due on the clock (like a replay): no thread, no waiting, deterministic
  on a SimClock; ENDED after the last frame.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from sensors.base import ColorImage, Frame, SensorSpec, SensorState, SensorUnavailable
from sensors.clock import Clock
from sensors.threaded import Backoff, LinkLost, ThreadedDriver
from sensors.webcam.config import WebcamConfig

QUEUE_SIZE = 2  # live frames waiting for read(); older ones are dropped
_DUE_TOLERANCE_S = 1e-9
_JOIN_S = 2.0


def _as_bgr(image: np.ndarray) -> np.ndarray:
    if image.ndim == 2:
        return np.asarray(cv2.cvtColor(image, cv2.COLOR_GRAY2BGR))
    if image.shape[2] == 4:
        return np.asarray(cv2.cvtColor(image, cv2.COLOR_BGRA2BGR))
    return image


def video_duration(path: str) -> float | None:
    """Seconds from the first frame of the video file ``path`` to its last (frame count and fps from the
    container, so approximate for some files), or None when OpenCV cannot tell."""
    cap = cv2.VideoCapture(path)
    try:
        frames, fps = float(cap.get(cv2.CAP_PROP_FRAME_COUNT)), float(cap.get(cv2.CAP_PROP_FPS))
    finally:
        cap.release()
    if not (math.isfinite(frames) and math.isfinite(fps) and frames >= 1 and fps > 0):
        return None
    return (frames - 1) / fps


class WebcamSensor(ThreadedDriver[Any]):  # the link is a cv2.VideoCapture (live mode only)
    driver = "webcam"

    def __init__(self, config: WebcamConfig, clock: Clock, name: str = "webcam") -> None:
        super().__init__(SensorSpec(name=name, kind="color", rate_hz=float(config.fps), width=config.width,
                                    height=config.height), clock, QUEUE_SIZE, _JOIN_S)
        self.config = config
        # file mode
        self._cap: Any = None
        self._next_image: np.ndarray | None = None
        self._index = 0
        self._file_fps = 0.0
        self._t_open = 0.0
        # live mode
        self._seq = 0  # frames captured since open: drops show as gaps

    # -------------------------------------------------------------- opening

    def _unavailable(self, what: str) -> SensorUnavailable:
        return SensorUnavailable(f"webcam {self.name!r} (source {self.config.source!r}): {what}")

    def _capture(self) -> Any:
        """Open the live source and ask for the configured size and rate; None if it will not open."""
        source = self.config.source
        cap = cv2.VideoCapture(int(source)) if source.isdigit() else cv2.VideoCapture(source)
        if not cap.isOpened():
            cap.release()
            return None
        if self.config.kind == "device":
            cap.set(cv2.CAP_PROP_FRAME_WIDTH, self.config.width)
            cap.set(cv2.CAP_PROP_FRAME_HEIGHT, self.config.height)
            cap.set(cv2.CAP_PROP_FPS, self.config.fps)
        return cap

    def open(self) -> None:
        if self._open:
            return
        if self.config.kind == "file":
            self._open_file()
            self._open = True
        else:
            self._open_live()

    def _open_file(self) -> None:
        path = Path(self.config.source)
        if not path.is_file():
            raise self._unavailable(f"video file {path} not found (a source is a device index like \"0\", "
                                    "a video file or a stream URL)")
        cap = cv2.VideoCapture(str(path))
        if not cap.isOpened():
            cap.release()
            raise self._unavailable(f"OpenCV cannot read {path} as a video (check it is a video file, "
                                    "e.g. MP4 written with mp4v, or MJPG AVI)")
        ok, image = cap.read()
        if not ok or image is None:
            cap.release()
            raise self._unavailable(f"video file {path} has no frames OpenCV can decode")
        fps = float(cap.get(cv2.CAP_PROP_FPS))
        self._file_fps = fps if math.isfinite(fps) and fps > 0 else float(self.config.fps)
        self._cap = cap
        self._next_image = _as_bgr(image)
        h, w = self._next_image.shape[:2]
        self._spec = SensorSpec(name=self.name, kind="color", rate_hz=self._file_fps, width=w, height=h)
        self._index = 0
        self._t_open = self._clock.now()
        with self._lock:
            self._frames = 0
            self._state, self._reason = SensorState.CONNECTED, ""

    def _open_live(self) -> None:
        cap = self._capture()
        if cap is None:
            if self.config.kind == "device":
                raise self._unavailable("cannot open the camera; check it is plugged in, not used by another "
                                        "program, and that this user may read /dev/video*")
            raise self._unavailable("cannot open the stream; check the URL and that the stream is running")
        fps = float(cap.get(cv2.CAP_PROP_FPS))
        w, h = int(cap.get(cv2.CAP_PROP_FRAME_WIDTH)), int(cap.get(cv2.CAP_PROP_FRAME_HEIGHT))
        self._spec = SensorSpec(
            name=self.name, kind="color", rate_hz=fps if math.isfinite(fps) and fps > 0 else float(self.config.fps),
            width=w if w > 0 else self.config.width, height=h if h > 0 else self.config.height,
        )
        self._queue.reset()
        with self._lock:
            self._frames = self._reconnects = 0
        self._seq = 0
        self._start_reader(lambda: cap)

    # -------------------------------------------------------------- live capture thread

    def _backoff(self) -> Backoff:
        return Backoff(self.config.reconnect_s, self.config.reconnect_s)

    def _crash_reason(self, error: Exception) -> str:
        return f"the capture thread of {self.config.source!r} stopped: {error!r}"

    def _read_one(self, cap: Any) -> bool:
        ok, image = cap.read()
        t = self._clock.now()
        if not ok or image is None:
            raise LinkLost(f"no frame from {self.config.source!r} (unplugged, or the stream ended)")
        self._queue.put(Frame(sensor=self.name, t=t, seq=self._seq, payload=ColorImage(_as_bgr(image))))
        self._seq += 1
        return True

    def _reconnect(self) -> tuple[Any, str]:
        cap = self._capture()
        return (None, f"cannot reopen {self.config.source!r}") if cap is None else (cap, "")

    def _close_link(self, cap: Any) -> None:
        cap.release()

    # -------------------------------------------------------------- reading

    def read(self, timeout: float) -> Frame | None:
        if self.config.kind != "file":
            return super().read(timeout)
        self._check_open()
        return self._read_file()

    def _read_file(self) -> Frame | None:
        image = self._next_image
        if image is None:
            return None
        t = self._t_open + self._index / self._file_fps
        if t > self._clock.now() + _DUE_TOLERANCE_S:
            return None
        frame = Frame(sensor=self.name, t=t, seq=self._index, payload=ColorImage(image))
        self._index += 1
        ok, nxt = self._cap.read()
        with self._lock:
            self._frames += 1
            if ok and nxt is not None:
                self._next_image = _as_bgr(nxt)
            else:
                self._next_image = None
                self._state, self._reason = SensorState.ENDED, "end of the video file"
        if self._next_image is None:
            self._cap.release()
            self._cap = None
        return frame

    # -------------------------------------------------------------- closing

    def close(self) -> None:
        super().close()  # stops the live thread; a capture stuck in read() releases itself when it returns
        if self._cap is not None:
            self._cap.release()
            self._cap = None
        self._next_image = None
