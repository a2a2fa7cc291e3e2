"""The live link to a real OAK camera (depthai 3.x). Thin on purpose: it cannot run without a
device, so it only builds the pipeline, reads the queue and forwards depthai's state callbacks;
everything it hands on is handled by code that is tested on host pipelines.

The pipeline (depthai 3 API, names checked against the installed package by
``tests/test_oak_device_api.py``)::

    device   = dai.Device(device_info, dai.UsbSpeed.SUPER | HIGH)
    device.setMaxReconnectionAttempts(n, on_reconnection)      # depthai's built-in reconnection
    pipeline = dai.Pipeline(device)
    pipeline.setDeviceStateCallback(on_device_state)           # RUNNING / DISCONNECTED / RECONNECTING / FAILED
    stereo   = pipeline.create(dai.node.StereoDepth).build(autoCreateCameras=True, presetMode=…, size=(640, 400), fps=…)
    stereo.setLeftRightCheck(True); stereo.setDepthAlign(CAM_A); stereo.setOutputSize(w, h)
    colour   = pipeline.create(dai.node.Camera).build(CAM_A, sensorFps=fps).requestOutput(size=(w, h), type=NV12, fps=fps)
    sync     = pipeline.create(dai.node.Sync)  → inputs["depth"], inputs["color"] → sync.out.createOutputQueue()
    pipeline.start()
"""

from __future__ import annotations

import threading
from datetime import timedelta
from typing import Any

from sensors.oak.config import OakConfig
from sensors.oak.frames import Intrinsics
from sensors.oak.link import LinkHealth, LinkMessage, health_of_event
from sensors.oak.search import FoundDevice

QUEUE_SIZE = 4  # messages depthai keeps for us (non-blocking: the oldest is dropped on the device side)

# Every depthai name this module uses, so a test can check them against the installed depthai.
DEPTHAI_NAMES: tuple[str, ...] = (
    "Device", "Device.setMaxReconnectionAttempts", "Device.readCalibration", "Device.close",
    "Device.ReconnectionStatus", "DeviceInfo", "UsbSpeed.SUPER", "UsbSpeed.HIGH", "Pipeline",
    "Pipeline.setDeviceStateCallback", "Pipeline.create", "Pipeline.start", "Pipeline.stop", "Pipeline.wait",
    "DeviceState", "CameraBoardSocket.CAM_A", "CalibrationHandler.getCameraIntrinsics",
    "node.StereoDepth", "node.StereoDepth.build", "node.StereoDepth.PresetMode", "node.StereoDepth.setLeftRightCheck",
    "node.StereoDepth.setDepthAlign", "node.StereoDepth.setOutputSize", "node.StereoDepth.depth",
    "node.Camera", "node.Camera.build", "node.Camera.requestOutput", "ImgFrame.Type.NV12",
    "node.Sync", "node.Sync.setSyncThreshold", "node.Sync.inputs", "node.Sync.out",
    "Node.Output.createOutputQueue", "MessageQueue.get", "Clock.now",
)


def _calibration(dai: Any, device: Any, size: tuple[int, int]) -> Intrinsics | None:
    try:
        k = device.readCalibration().getCameraIntrinsics(dai.CameraBoardSocket.CAM_A, size[0], size[1])
        found = Intrinsics.from_matrix(k, size)
    except (RuntimeError, ValueError):  # an uncalibrated device: frames may still carry intrinsics
        return None
    return found if found.plausible else None


def build_graph(dai: Any, pipeline: Any, config: OakConfig) -> Any:
    """Stereo depth aligned to CAM_A at the output size, with the colour output paired by a Sync
    node when ``config.color``; returns the output queue."""
    preset = getattr(dai.node.StereoDepth.PresetMode, config.preset.upper())
    stereo = pipeline.create(dai.node.StereoDepth).build(autoCreateCameras=True, presetMode=preset, size=(640, 400),
                                                         fps=config.fps)
    stereo.setLeftRightCheck(True)  # depth alignment requires the left-right check
    stereo.setDepthAlign(dai.CameraBoardSocket.CAM_A)
    stereo.setOutputSize(config.width, config.height)
    if not config.color:
        return stereo.depth.createOutputQueue(maxSize=QUEUE_SIZE, blocking=False)
    camera = pipeline.create(dai.node.Camera).build(dai.CameraBoardSocket.CAM_A, sensorFps=config.fps)
    color = camera.requestOutput(size=config.size, type=dai.ImgFrame.Type.NV12, fps=config.fps)
    sync = pipeline.create(dai.node.Sync)
    sync.setSyncThreshold(timedelta(seconds=0.5 / config.fps))
    stereo.depth.link(sync.inputs["depth"])
    color.link(sync.inputs["color"])
    return sync.out.createOutputQueue(maxSize=QUEUE_SIZE, blocking=False)


class DeviceLink:
    """A started pipeline on one OAK. Construct it to connect (raises depthai's errors)."""

    def __init__(self, found: FoundDevice, config: OakConfig) -> None:
        import depthai as dai

        self._dai: Any = dai
        self._lock = threading.Lock()
        self._health = (LinkHealth.RUNNING, "")
        self._device_id = found.device_id or found.name
        info = found.info if found.info is not None else dai.DeviceInfo(found.device_id or found.name)
        speed = dai.UsbSpeed.SUPER if config.usb_speed == "super" else dai.UsbSpeed.HIGH
        self._device = dai.Device(info, speed)
        self._pipeline: Any = None
        try:
            self._device.setMaxReconnectionAttempts(config.reconnect_attempts, self._on_event)
            self._calibration = _calibration(dai, self._device, config.size)
            self._pipeline = dai.Pipeline(self._device)
            if hasattr(self._pipeline, "setDeviceStateCallback"):  # depthai >= 3.12
                self._pipeline.setDeviceStateCallback(lambda _device, state: self._on_event(state))
            self._queue = build_graph(dai, self._pipeline, config)
            self._pipeline.start()
        except BaseException:
            self.close()
            raise

    @property
    def device_id(self) -> str:
        return self._device_id

    @property
    def calibration(self) -> Intrinsics | None:
        return self._calibration

    def _on_event(self, event: Any) -> None:
        """depthai's callbacks (its monitor thread): record, never block."""
        health = health_of_event(event)
        if health is not None:
            with self._lock:
                self._health = (health, str(getattr(event, "name", event)))

    def health(self) -> tuple[LinkHealth, str]:
        with self._lock:
            return self._health

    def read(self, timeout_s: float) -> LinkMessage | None:
        msg = self._queue.get(timedelta(seconds=max(timeout_s, 0.0)))
        if msg is None:
            return None
        age = (self._dai.Clock.now() - msg.getTimestamp()).total_seconds()
        return LinkMessage(msg, age)

    def close(self) -> None:
        """Stop the pipeline and close the device; a dead device may refuse both (ignored: the
        link is being dropped either way, and the device reboots on its own)."""
        pipeline, self._pipeline = self._pipeline, None
        if pipeline is not None:
            try:
                pipeline.stop()
                pipeline.wait()
            except Exception:  # see the docstring
                pass
        try:
            self._device.close()
        except Exception:  # see the docstring
            pass


def connect_device(found: FoundDevice, config: OakConfig) -> DeviceLink:
    """The default connector of :class:`sensors.oak.driver.OakSensor`."""
    return DeviceLink(found, config)
