"""The pads observer: calibrated pad forces → one impulse per hit (:mod:`interaction.pads.observer`)."""

from __future__ import annotations

from interaction.pads.observer import PadsObserver, PadsObserverConfig

__all__ = ["PadsObserver", "PadsObserverConfig"]
