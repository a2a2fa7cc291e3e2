"""The live OAK path cannot run without a camera; what it relies on in depthai is checked here."""

from __future__ import annotations

import subprocess
import sys

import depthai as dai
import pytest

from sensors.oak.config import STEREO_PRESETS
from sensors.oak.device import DEPTHAI_NAMES
from sensors.oak.link import LinkHealth, health_of_event


@pytest.mark.parametrize("dotted", DEPTHAI_NAMES)
def test_every_depthai_name_the_live_link_uses_exists(dotted: str) -> None:
    obj: object = dai
    for part in dotted.split("."):
        assert hasattr(obj, part), f"depthai {dai.__version__} has no {dotted} (missing {part!r})"
        obj = getattr(obj, part)


def test_every_configurable_preset_is_a_depthai_preset() -> None:
    members = dai.node.StereoDepth.PresetMode.__members__
    assert {p.upper() for p in STEREO_PRESETS} <= set(members)


def test_depthais_state_events_map_to_health() -> None:
    assert health_of_event(dai.Device.ReconnectionStatus.RECONNECTING) is LinkHealth.RECONNECTING
    assert health_of_event(dai.Device.ReconnectionStatus.RECONNECTED) is LinkHealth.RUNNING
    assert health_of_event(dai.Device.ReconnectionStatus.RECONNECT_FAILED) is LinkHealth.FAILED
    for state in dai.DeviceState.__members__.values():  # RUNNING, DISCONNECTED, RECONNECTING, FAILED
        assert health_of_event(state) is not None, state
    assert health_of_event(dai.DeviceState.FAILED) is LinkHealth.FAILED
    assert health_of_event("SOMETHING_NEW") is None


def test_importing_the_sensors_never_imports_depthai() -> None:
    code = ("import sys, sensors, sensors.registry, sensors.oak, sensors.oak.config, sensors.oak.frames, "
            "sensors.oak.search, sensors.oak.link, sensors.oak.driver, sensors.faults, jostle.bench.sensors; "
            "print(sorted(m for m in ('depthai', 'cv2', 'serial') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60, check=True)
    assert out.stdout.strip() == "[]"
