"""A depthai pipeline that runs on the host alone, standing in for a camera.

``dai.Pipeline(False)`` needs no device: a threaded host node sends depth (RAW16, with intrinsics
in its ``ImgTransformation``) and colour (BGR888i) ``ImgFrame`` messages, a Sync node running on the
host pairs them into ``MessageGroup`` s, and :class:`HostPipelineLink` reads them from a depthai
``MessageQueue`` — the same message types, queue calls and failure modes (``QueueException`` once
the pipeline stops) as a device link. The OAK driver is tested on it, and it can replay any
depth source (a recording, the virtual performer) through the driver.

Always ``close()`` a link: a host pipeline still running when Python exits takes the process down
(depthai's node thread outlives the interpreter).
"""

from __future__ import annotations

import functools
import threading
import time
from collections.abc import Callable
from datetime import timedelta
from typing import Any

import numpy as np

from sensors.oak.frames import Intrinsics
from sensors.oak.link import LinkHealth, LinkMessage, health_of_event

# index → (depth uint16 (H, W), colour uint8 BGR (H, W, 3) or None), or None: nothing to send now
FrameSource = Callable[[int], tuple[np.ndarray, np.ndarray | None] | None]
_IDLE_S = 0.01


@functools.cache
def _generator_class(dai: Any) -> type:
    class FrameGenerator(dai.node.ThreadedHostNode):
        def __init__(self) -> None:
            super().__init__()
            self.depth = self.createOutput()
            self.color = self.createOutput()
            self.source: FrameSource | None = None
            self.period_s = 1 / 30
            self.matrix: list[list[float]] | None = None
            self.sent = 0
            self.error: BaseException | None = None

        def run(self) -> None:
            next_t = time.monotonic()
            while self.isRunning() and self.source is not None:
                try:
                    item = self.source(self.sent)
                except Exception as e:  # kept for the test to see; the stream goes quiet like a hung camera
                    self.error = e
                    return
                if item is None:
                    time.sleep(_IDLE_S)
                    continue
                self._send(*item)
                next_t += self.period_s
                time.sleep(max(0.0, next_t - time.monotonic()))

        def _send(self, depth: np.ndarray, color: np.ndarray | None) -> None:
            stamp = dai.Clock.now()
            h, w = depth.shape
            msg = dai.ImgFrame()
            msg.setFrame(np.ascontiguousarray(depth, dtype=np.uint16))
            msg.setType(dai.ImgFrame.Type.RAW16)
            msg.setWidth(w)
            msg.setHeight(h)
            msg.setSequenceNum(self.sent)
            msg.setTimestamp(stamp)
            if self.matrix is not None:
                msg.setTransformation(dai.ImgTransformation(w, h, self.matrix))
            self.depth.send(msg)
            if color is not None:
                c = dai.ImgFrame()
                c.setCvFrame(np.ascontiguousarray(color, dtype=np.uint8), dai.ImgFrame.Type.BGR888i)
                c.setSequenceNum(self.sent)
                c.setTimestamp(stamp)
                self.color.send(c)
            self.sent += 1

    return FrameGenerator


class HostPipelineLink:
    """An :class:`sensors.oak.link.OakLink` over a host-only depthai pipeline.

    ``intrinsics`` go into every depth message (None: frames carry none); ``calibration`` is what
    the link reports as the device's calibration (the driver's fallback). ``color`` pairs colour
    with depth through a Sync node, as on a device.
    """

    def __init__(self, source: FrameSource, *, fps: float, intrinsics: Intrinsics | None = None,
                 calibration: Intrinsics | None = None, color: bool = True, device_id: str = "host-pipeline") -> None:
        import depthai as dai

        self._dai: Any = dai
        self._device_id = device_id
        self._calibration = calibration
        self._lock = threading.Lock()
        self._health = (LinkHealth.RUNNING, "")
        self._broken = ""
        self._pipeline: Any = dai.Pipeline(False)
        generator: Any = self._pipeline.create(_generator_class(dai))
        generator.source = source
        generator.period_s = 1.0 / fps
        if intrinsics is not None:
            k = intrinsics
            generator.matrix = [[k.fx, 0.0, k.cx], [0.0, k.fy, k.cy], [0.0, 0.0, 1.0]]
        self.generator = generator
        self._queue: Any
        if color:
            sync = self._pipeline.create(dai.node.Sync)
            sync.setRunOnHost(True)
            sync.setSyncThreshold(timedelta(seconds=0.5 / fps))
            self.generator.depth.link(sync.inputs["depth"])
            self.generator.color.link(sync.inputs["color"])
            self._queue = sync.out.createOutputQueue(maxSize=4, blocking=False)
        else:
            self._queue = self.generator.depth.createOutputQueue(maxSize=4, blocking=False)
        self._pipeline.start()

    @property
    def device_id(self) -> str:
        return self._device_id

    @property
    def calibration(self) -> Intrinsics | None:
        return self._calibration

    def read(self, timeout_s: float) -> LinkMessage | None:
        if self._broken:
            raise self._dai.XLinkReadError(self._broken)
        msg = self._queue.get(timedelta(seconds=max(timeout_s, 0.0)))
        if msg is None:
            return None
        return LinkMessage(msg, (self._dai.Clock.now() - msg.getTimestamp()).total_seconds())

    def health(self) -> tuple[LinkHealth, str]:
        with self._lock:
            return self._health

    # -------------------------------------------------------------- faults, as a device shows them

    def report(self, event: str) -> None:
        """Deliver a device-state event (``"RECONNECTING"``, ``"RECONNECTED"``, ``"FAILED"``, ...)
        exactly as a device link's depthai callbacks do."""
        health = health_of_event(event)
        if health is None:
            raise ValueError(f"event: expected one of depthai's state names, got {event!r}")
        with self._lock:
            self._health = (health, event)

    def break_link(self, text: str = "Couldn't read data from stream: 'sync' (X_LINK_ERROR)") -> None:
        """From now on ``read`` raises ``dai.XLinkReadError(text)``, as after a cable glitch."""
        self._broken = text

    def unplug(self) -> None:
        """Stop the pipeline: the next ``read`` raises depthai's ``MessageQueue.QueueException``."""
        self._pipeline.stop()

    def close(self) -> None:
        if self._pipeline.isRunning():
            self._pipeline.stop()
        self._pipeline.wait()
