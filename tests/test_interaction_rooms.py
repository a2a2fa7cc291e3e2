"""interaction/'s rooms: the observer table and the packages import no OpenCV until an observer is built."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def test_the_rooms_and_the_observer_table_import_no_opencv() -> None:
    code = (
        "import sys, interaction, interaction.observers, interaction.webcam, interaction.depth, interaction.pads\n"
        "from interaction.webcam import WebcamObserverConfig\n"
        "from interaction.depth import DepthObserverConfig\n"
        "print('cv2' in sys.modules)\n"
    )
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, check=True)
    assert r.stdout.strip() == "False"


def test_the_observer_table_names_each_kind_once_with_its_config() -> None:
    from interaction.depth.config import DepthObserverConfig
    from interaction.observers import OBSERVER_TYPES, observer_types
    from interaction.pads import PadsObserverConfig
    from interaction.webcam.config import WebcamObserverConfig

    table = observer_types()
    assert table == OBSERVER_TYPES and table is not OBSERVER_TYPES
    assert {k: t.config for k, t in table.items()} == {
        "webcam": WebcamObserverConfig, "depth": DepthObserverConfig, "pads": PadsObserverConfig}
    assert all(t.description for t in table.values())


def test_the_observers_are_found_through_their_rooms() -> None:
    from interaction.depth import DepthObserver
    from interaction.depth.observer import DepthObserver as InRoom
    from interaction.webcam import WebcamObserver
    from interaction.webcam.observer import WebcamObserver as WebcamInRoom

    assert DepthObserver is InRoom and WebcamObserver is WebcamInRoom
