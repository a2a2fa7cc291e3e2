"""What the renderer remembers between frames, all of it cosmetic: the flashes where contacts land,
the fade between behaviours, and the HUD's text image. Nothing here feeds back into the sim.
"""

from __future__ import annotations

import time
from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass

import cv2
import numpy as np

from interaction.types import BodyObservation
from sim.snapshot import CharacterSnapshot

FLASH_FLOATS = 5  # centre(3) radius(1) strength(1)


@dataclass
class _Flash:
    position: np.ndarray
    born: float
    size: float


class Flashes:
    """A short flash where a contact lands: when a character starts being pushed (its contact force
    goes from 0 to > 0) and where a pad impulse hits; each lasts ``duration`` seconds of snapshot time,
    growing and fading."""

    def __init__(self, duration: float) -> None:
        self.duration = duration
        self._pushed: dict[str, bool] = {}
        self._flashes: list[_Flash] = []

    def update(
        self,
        t: float,
        characters: Sequence[CharacterSnapshot],
        contact_points: dict[int, np.ndarray],
        observation: BodyObservation | None,
    ) -> None:
        """``contact_points``: per character index, where the people touch it (for the pushed ones)."""
        self._flashes = [f for f in self._flashes if 0.0 <= t - f.born < self.duration]
        for i, c in enumerate(characters):
            pushed = c.contact_force_n > 0
            if pushed and not self._pushed.get(c.name, False) and i in contact_points:
                self._flashes.append(_Flash(contact_points[i], t, 0.18 * c.height))
            self._pushed[c.name] = pushed
        if observation is not None:
            for imp in observation.impulses:
                self._flashes.append(_Flash(np.array(imp.position, dtype=float), t, 0.3))

    def instances(self, t: float) -> np.ndarray:
        """(M, FLASH_FLOATS) for the flashes alive at t."""
        rows = []
        for f in self._flashes:
            age = (t - f.born) / self.duration if self.duration > 0 else 1.0
            if 0.0 <= age < 1.0:
                rows.append([*f.position, f.size * (0.6 + 0.8 * age), (1.0 - age) ** 1.5])
        return np.array(rows, dtype=float).reshape(-1, FLASH_FLOATS)


class BehaviourFade:
    """Blends B from a character's previous behaviour to its new one over ``duration`` seconds of
    snapshot time (all values of B are adjacent), so a switch never pops."""

    def __init__(self, duration: float = 0.25) -> None:
        self.duration = duration
        self._last: dict[str, tuple[str, str, float]] = {}  # name → (from, to, switched at)

    def behaviours(self, t: float, characters: Sequence[CharacterSnapshot]) -> list[str | dict[str, float]]:
        out: list[str | dict[str, float]] = []
        for c in characters:
            prev = self._last.get(c.name)
            if prev is None or (prev[1] != c.behaviour and t < prev[2]):
                self._last[c.name] = (c.behaviour, c.behaviour, t)
            elif prev[1] != c.behaviour:
                self._last[c.name] = (prev[1], c.behaviour, t)
            old, new, at = self._last[c.name]
            u = (t - at) / self.duration if self.duration > 0 else 1.0
            out.append(new if old == new or u >= 1.0 or u < 0 else {old: 1.0 - u, new: u})
        return out


class Hud:
    """The HUD: fps, people, characters and their states, as an RGBA image redrawn at most 4× a second."""

    def __init__(self, colour: tuple[float, float, float]) -> None:
        self.colour = tuple(int(255 * c) for c in colour)
        self._last_draw = time.perf_counter()
        self._fps = 0.0
        self._text = ""
        self._stamp = 0.0
        self.image: np.ndarray | None = None
        self.changed = False

    def update(self, characters: Sequence[CharacterSnapshot], observation: BodyObservation | None) -> None:
        now = time.perf_counter()
        dt = now - self._last_draw
        self._last_draw = now
        if dt > 0:
            self._fps = 1.0 / dt if self._fps == 0 else 0.9 * self._fps + 0.1 / dt
        if now - self._stamp < 0.25 and self.image is not None:
            self.changed = False
            return
        self._stamp = now
        states = Counter(str(c.state) for c in characters)
        people = observation.people if observation is not None else 0
        lines = [
            f"{self._fps:5.1f} fps   people {people}   characters {len(characters)}",
            "   ".join(f"{k} {v}" for k, v in sorted(states.items())) or "no characters",
        ]
        text = "\n".join(lines)
        self.changed = text != self._text or self.image is None
        if self.changed:
            self._text = text
            self.image = _text_image(lines, self.colour)


def _text_image(lines: list[str], colour: tuple[int, ...]) -> np.ndarray:
    """RGBA text on a translucent dark panel, row 0 at the top."""
    font, scale, thick = cv2.FONT_HERSHEY_SIMPLEX, 0.5, 1
    sizes = [cv2.getTextSize(line, font, scale, thick)[0] for line in lines]
    w = max(s[0] for s in sizes) + 16
    line_h = max(s[1] for s in sizes) + 10
    img = np.zeros((line_h * len(lines) + 8, w, 4), np.uint8)
    img[..., 3] = 150
    for i, line in enumerate(lines):
        cv2.putText(img, line, (8, 4 + line_h * (i + 1) - 6), font, scale, (*colour, 255), thick, cv2.LINE_AA)
    return img
