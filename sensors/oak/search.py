"""Finding an OAK camera, bounded in time, and the errors that tell the user what to check.

depthai's own "connect to any device" waits its default search time (10 s, ~11 s in all) when
nothing is attached, and ``dai.Pipeline()`` does that implicitly. Here a search is
``Device.getAllAvailableDevices()`` run in a worker thread: the caller gets an answer (the devices,
or "none within the time") after at most ``timeout_s``, whatever depthai does. A search that
overruns keeps running in its (daemon) thread and is reused by the next call rather than started
again, so a hung USB stack never piles up threads.
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

from sensors.base import SensorUnavailable


@dataclass(frozen=True, slots=True)
class FoundDevice:
    """One camera a search found, as plain data (``info`` keeps depthai's DeviceInfo to connect)."""

    device_id: str
    name: str  # USB port name ("1.3") or IP address (PoE)
    state: str  # X_LINK_UNBOOTED, X_LINK_BOOTLOADER, X_LINK_BOOTED (in use), ...
    protocol: str
    info: Any = field(default=None, compare=False, repr=False)

    @property
    def in_use(self) -> bool:
        """Booted (running a pipeline): another program holds it, or it is still shutting down."""
        return self.state == "X_LINK_BOOTED"

    def describe(self) -> str:
        return f"{self.device_id or '?'} at {self.name or '?'} ({self.state.removeprefix('X_LINK_').lower()})"


Lister = Callable[[], Sequence[FoundDevice]]


def _enum_name(value: Any) -> str:
    return str(getattr(value, "name", value)).split(".")[-1]


def list_depthai_devices() -> list[FoundDevice]:
    """Every OAK depthai can see now (unbounded: call it through :class:`DeviceSearch`)."""
    import depthai as dai

    return [FoundDevice(device_id=str(d.getDeviceId()), name=str(d.name), state=_enum_name(d.state),
                        protocol=_enum_name(d.protocol), info=d)
            for d in dai.Device.getAllAvailableDevices()]


class SearchTimeout(SensorUnavailable):
    """The device search did not answer in time."""


class DeviceSearch:
    """Runs ``lister`` in a worker thread and waits for it at most ``timeout_s``."""

    def __init__(self, lister: Lister = list_depthai_devices) -> None:
        self._lister = lister
        self._lock = threading.Lock()
        self._pending: _Search | None = None

    def find(self, timeout_s: float) -> list[FoundDevice]:
        """The devices found; raises :class:`SearchTimeout` after ``timeout_s`` without an answer,
        or SensorUnavailable if the search itself failed (depthai missing, USB error)."""
        with self._lock:
            search = self._pending
            if search is None or search.done.is_set():
                search = _Search(self._lister)
                self._pending = search
        if not search.done.wait(max(timeout_s, 0.0)):
            raise SearchTimeout(f"the search for OAK cameras gave no answer within {timeout_s:g} s "
                                "(a USB or network stack that hangs: replug the camera, check `dmesg`)")
        with self._lock:
            if self._pending is search:
                self._pending = None
        if search.error is not None:
            raise SensorUnavailable(f"the search for OAK cameras failed: {search.error}") from search.error
        return list(search.result)


class _Search:
    def __init__(self, lister: Lister) -> None:
        self.done = threading.Event()
        self.result: Sequence[FoundDevice] = ()
        self.error: BaseException | None = None
        threading.Thread(target=self._run, args=(lister,), name="oak-search", daemon=True).start()

    def _run(self, lister: Lister) -> None:
        try:
            self.result = lister()
        except Exception as e:  # reported to the caller as SensorUnavailable
            self.error = e
        finally:
            self.done.set()


# ---------------------------------------------------------------- choosing and explaining

NOT_FOUND_HINT = ("check the USB3 cable is plugged into a USB3 port (or the PoE camera is on this network and "
                  "powered), that on Linux the udev rule is installed (docs/sensors.md), and `jostle doctor`")


def pick_device(found: Sequence[FoundDevice], wanted: str, sensor: str) -> FoundDevice:
    """The configured camera (by id, IP or port name), or the first free one when ``wanted`` is "".

    Raises SensorUnavailable naming the camera, listing what was found and what to check.
    """
    label = f"oak {sensor!r}"
    if wanted:
        for d in found:
            if wanted in (d.device_id, d.name):
                if d.in_use:
                    raise SensorUnavailable(f"{label}: OAK {wanted} is in use by another program "
                                            f"({d.describe()}); close it, or wait a few seconds if it is rebooting")
                return d
        others = "; ".join(d.describe() for d in found) or "none"
        raise SensorUnavailable(f"{label}: OAK {wanted} not found (found: {others}); check the device id in the "
                                f"config (`jostle doctor` lists cameras), and {NOT_FOUND_HINT}")
    free = [d for d in found if not d.in_use]
    if free:
        return free[0]
    if found:
        busy = "; ".join(d.describe() for d in found)
        raise SensorUnavailable(f"{label}: every OAK found is in use by another program ({busy}); close it, or "
                                "wait a few seconds if it is rebooting")
    raise SensorUnavailable(f"{label}: no OAK camera found; {NOT_FOUND_HINT}")


# depthai / XLink error texts → what the user should check (first match wins)
LINK_HINTS: tuple[tuple[str, str], ...] = (
    ("INSUFFICIENT_PERMISSIONS", "this user may not open the USB device: install the udev rule (docs/sensors.md) "
                                 "and replug"),
    ("DEVICE_NOT_FOUND", "the camera vanished while booting: replug it; on Linux install the udev rule "
                         "(docs/sensors.md); use a powered USB3 port or hub"),
    ("ALREADY_IN_USE", "another program holds the camera: close it"),
    ("X_LINK_ERROR", "the link dropped: check the cable and port (a shorter cable, no unpowered hub, or "
                     "usb_speed = \"high\"), the power supply, and vibration on the connector"),
    ("TIMEOUT", "the camera stopped answering: check power and the cable; it may be rebooting"),
    ("MessageQueue was closed", "the pipeline stopped (the device was lost for good)"),
)


def link_hint(error_text: str) -> str:
    for needle, hint in LINK_HINTS:
        if needle.lower() in error_text.lower():
            return hint
    return "check the cable, the port and the power; `jostle doctor` lists cameras"
