"""Finding an OAK: bounded in time (never depthai's ~11 s wait), clear errors, the config."""

from __future__ import annotations

import threading
import time

import pytest

from sensors.base import SensorUnavailable
from sensors.clock import SimClock
from sensors.oak.config import OakConfig
from sensors.oak.driver import OakSensor
from sensors.oak.search import DeviceSearch, FoundDevice, SearchTimeout, link_hint, pick_device

FREE = FoundDevice("14442C10D13EABCE00", "1.3", "X_LINK_UNBOOTED", "X_LINK_USB_VSC")
BUSY = FoundDevice("18443010C1B1E01300", "1.4", "X_LINK_BOOTED", "X_LINK_USB_VSC")
POE = FoundDevice("1844301011F4C41200", "192.168.1.44", "X_LINK_BOOTLOADER", "X_LINK_TCP_IP")


def test_a_search_that_hangs_is_cut_off_and_not_started_twice() -> None:
    started = []
    release = threading.Event()

    def hanging() -> list[FoundDevice]:
        started.append(time.monotonic())
        release.wait(10.0)  # a USB stack that does not answer
        return [FREE]

    search = DeviceSearch(hanging)
    t0 = time.monotonic()
    with pytest.raises(SearchTimeout, match=r"no answer within 0\.2 s"):
        search.find(0.2)
    with pytest.raises(SearchTimeout):
        search.find(0.2)
    assert time.monotonic() - t0 < 1.5
    assert len(started) == 1  # the second call waited on the same search instead of piling up threads
    release.set()  # the search finally answers: the next call gets that answer
    assert search.find(2.0) == [FREE]


def test_a_failing_search_says_so() -> None:
    def broken() -> list[FoundDevice]:
        raise RuntimeError("libusb: LIBUSB_ERROR_ACCESS")

    with pytest.raises(SensorUnavailable, match="search for OAK cameras failed: libusb"):
        DeviceSearch(broken).find(1.0)


def test_the_real_depthai_search_is_bounded_here() -> None:
    """With the installed depthai and no camera attached: an answer (no devices) well within the bound."""
    t0 = time.monotonic()
    try:
        found = DeviceSearch().find(3.0)
    except SearchTimeout:
        found = None  # a slow machine: the bound held, which is the point
    took = time.monotonic() - t0
    assert took < 3.5
    if found:
        pytest.skip(f"an OAK is attached here: {found[0].describe()}")


def test_open_with_no_camera_fails_fast_and_names_what_to_check() -> None:
    sensor = OakSensor(OakConfig(device="14442C10D13EABCE00", search_timeout_s=3.0), SimClock(), "depth")
    t0 = time.monotonic()
    with pytest.raises(SensorUnavailable) as info:
        sensor.open()
    assert time.monotonic() - t0 < 4.0  # never the ~11 s of an implicit dai.Device()
    text = str(info.value)
    assert text.startswith("oak 'depth': ")
    assert "14442C10D13EABCE00" in text or "no answer" in text
    assert "\n" not in text
    sensor.close()


def test_pick_by_id_by_port_or_the_first_free_one() -> None:
    assert pick_device([BUSY, FREE, POE], "", "cam") is FREE
    assert pick_device([BUSY, FREE, POE], "1844301011F4C41200", "cam") is POE
    assert pick_device([BUSY, FREE, POE], "192.168.1.44", "cam") is POE
    assert pick_device([FREE], "1.3", "cam") is FREE


@pytest.mark.parametrize(
    ("found", "wanted", "message"),
    [
        ([], "", r"oak 'cam': no OAK camera found; check the USB3 cable .* udev rule"),
        ([FREE], "NOPE", r"OAK NOPE not found \(found: 14442C10D13EABCE00 at 1\.3 \(unbooted\)\); check the device id"),
        ([BUSY], BUSY.device_id, r"OAK 18443010C1B1E01300 is in use by another program"),
        ([BUSY], "", r"every OAK found is in use"),
    ],
)
def test_pick_errors_name_the_camera_and_what_to_check(found: list[FoundDevice], wanted: str, message: str) -> None:
    with pytest.raises(SensorUnavailable, match=message):
        pick_device(found, wanted, "cam")


def test_link_hints_know_depthais_failures() -> None:
    assert "cable" in link_hint("Couldn't read data from stream: 'depth' (X_LINK_ERROR)")
    assert "udev" in link_hint("Failed to connect to device, error message: X_LINK_DEVICE_NOT_FOUND")
    assert "udev" in link_hint("X_LINK_INSUFFICIENT_PERMISSIONS")
    assert "stopped" in link_hint("MessageQueue was closed")
    assert link_hint("something new")  # never empty


@pytest.mark.parametrize(
    ("field", "value", "message"),
    [
        ("width", 641, "width: expected an even whole number"),
        ("height", 0, "height: expected an even whole number"),
        ("fps", -3, "fps: expected a number > 0, got -3"),
        ("preset", "fastest", "preset: expected one of default, robotics"),
        ("usb_speed", "usb2", "usb_speed: expected 'super'"),
        ("device", " 1.3", "device: expected a device id"),
        ("give_up_after", -1, "give_up_after: expected a whole number >= 0"),
        ("reconnect_max_s", 0.5, r"reconnect_max_s: expected >= reconnect_s \(2\)"),
        ("color", 1, "color: expected true or false"),
    ],
)
def test_config_errors_start_with_the_field(field: str, value: object, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        OakConfig(**{field: value})  # type: ignore[arg-type]
