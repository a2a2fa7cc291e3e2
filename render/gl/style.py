"""How the stage looks: camera, colours and what is drawn — frozen config dataclasses (TOML-shaped).

In an installation config these sit under ``[render]``::

    [render.camera]
    eye = [0.0, -8.2, 2.1]        # stage metres (x right, y into the screen, z up)
    target = [0.0, 0.0, 0.85]
    fov_y_deg = 30.0

    [render.colours]
    floor = "#807d77"             # "#rrggbb"
    people = ["#59d9ff", "#ffd959"]

    [render.look]
    hud = true                    # fps, people, characters, states in the top-left corner
    silhouette_opacity = 0.45

Every ``__post_init__`` raises ValueError starting with the field name.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np


def _vec3(name: str, v: tuple[float, ...]) -> None:
    if len(v) != 3 or not all(isinstance(x, int | float) and math.isfinite(x) for x in v):
        raise ValueError(f"{name}: expected 3 finite numbers (stage metres), got {v!r}")


def rgb(name: str, text: str) -> tuple[float, float, float]:
    """'#rrggbb' → (r, g, b) in 0..1; ValueError naming the field otherwise."""
    s = text.strip() if isinstance(text, str) else ""
    if len(s) != 7 or s[0] != "#" or any(c not in "0123456789abcdefABCDEF" for c in s[1:]):
        raise ValueError(f"{name}: expected a colour like \"#3a7bd5\", got {text!r}")
    return (int(s[1:3], 16) / 255.0, int(s[3:5], 16) / 255.0, int(s[5:7], 16) / 255.0)


@dataclass(frozen=True)
class Camera:
    """A perspective camera on the audience side looking at the stage (z up)."""

    eye: tuple[float, ...] = (0.0, -8.2, 2.1)
    target: tuple[float, ...] = (0.0, 0.0, 0.85)
    fov_y_deg: float = 30.0
    near: float = 0.1
    far: float = 60.0

    def __post_init__(self) -> None:
        _vec3("eye", self.eye)
        _vec3("target", self.target)
        if math.dist(self.eye, self.target) < 1e-3:
            raise ValueError(f"target: expected a point away from the eye, got {self.target!r}")
        d = np.subtract(self.target, self.eye)
        if np.linalg.norm(d[:2]) < 1e-6 * np.linalg.norm(d):
            raise ValueError("target: the camera cannot look straight up or down (z is up)")
        if not 1.0 <= self.fov_y_deg <= 150.0:
            raise ValueError(f"fov_y_deg: expected 1 to 150 degrees, got {self.fov_y_deg}")
        if not 0.0 < self.near < self.far:
            raise ValueError(f"near: expected 0 < near < far={self.far}, got {self.near}")

    def view_projection(self, width: int, height: int, *, flip_y: bool = True) -> np.ndarray:
        """Row-major 4×4; ``flip_y`` puts the first image row at the top when read back with glReadPixels."""
        eye, target = np.array(self.eye, dtype=float), np.array(self.target, dtype=float)
        f = target - eye
        f /= np.linalg.norm(f)
        s = np.cross(f, [0.0, 0.0, 1.0])
        s /= np.linalg.norm(s)
        u = np.cross(s, f)
        view = np.eye(4)
        view[0, :3], view[1, :3], view[2, :3] = s, u, -f
        view[:3, 3] = -view[:3, :3] @ eye
        t = 1.0 / math.tan(math.radians(self.fov_y_deg) / 2.0)
        n, fa = self.near, self.far
        proj = np.zeros((4, 4))
        proj[0, 0] = t * height / width
        proj[1, 1] = -t if flip_y else t
        proj[2, 2] = (fa + n) / (n - fa)
        proj[2, 3] = 2.0 * fa * n / (n - fa)
        proj[3, 2] = -1.0
        return proj @ view


@dataclass(frozen=True)
class Colours:
    """Colours as "#rrggbb". Shirts get a hue per character; ``people`` cycles over people ids."""

    background: str = "#1e2126"
    floor: str = "#807d77"
    stage: str = "#9e9990"
    grid: str = "#59564f"
    stage_edge: str = "#d98c40"
    wall_low: str = "#c7ccd1"
    wall_high: str = "#7394bd"
    trousers: str = "#383d52"
    skin: str = "#edc29e"
    shoes: str = "#292421"
    flash: str = "#ffe08a"
    silhouette: str = "#73d1ff"
    people: tuple[str, ...] = ("#59d9ff", "#ffd959", "#b3ff80", "#ff8cd9")
    hud_text: str = "#f2f2f2"

    def __post_init__(self) -> None:
        for f in ("background", "floor", "stage", "grid", "stage_edge", "wall_low", "wall_high", "trousers",
                  "skin", "shoes", "flash", "silhouette", "hud_text"):
            rgb(f, getattr(self, f))
        if not self.people:
            raise ValueError("people: expected at least one colour")
        for i, c in enumerate(self.people):
            rgb(f"people[{i}]", c)


@dataclass(frozen=True)
class Look:
    """What is drawn besides the characters."""

    hud: bool = False  # fps, people, characters and their states, top left
    shadows: bool = True  # soft contact shadows under every limb near the floor
    flash_s: float = 0.35  # how long the flash where a contact lands lasts
    flash_newtons: float = 150.0  # a push of this force tints a character fully red
    silhouette_opacity: float = 0.45
    contactor_opacity: float = 0.35
    samples: int = -1  # multisampling: 0, 2, 4 or 8; -1: 0 headless (llvmpipe pays 2.5× for it), 4 in a window
    render_scale: float = 1.0  # draw the scene at this fraction of the size and scale it up (crowds, slow GL)

    def __post_init__(self) -> None:
        if not 0.0 <= self.flash_s <= 5.0:
            raise ValueError(f"flash_s: expected 0 to 5 seconds, got {self.flash_s}")
        if not self.flash_newtons > 0:
            raise ValueError(f"flash_newtons: expected a number > 0, got {self.flash_newtons}")
        for f in ("silhouette_opacity", "contactor_opacity"):
            if not 0.0 <= getattr(self, f) <= 1.0:
                raise ValueError(f"{f}: expected 0 to 1, got {getattr(self, f)}")
        if not 0.25 <= self.render_scale <= 1.0:
            raise ValueError(f"render_scale: expected 0.25 to 1, got {self.render_scale}")
        if self.samples not in (-1, 0, 2, 4, 8):
            raise ValueError(f"samples: expected -1 (auto), 0, 2, 4 or 8, got {self.samples}")


@dataclass(frozen=True)
class RenderStyle:
    """Everything about the look, for ``Renderer(style=…)``."""

    camera: Camera = field(default_factory=Camera)
    colours: Colours = field(default_factory=Colours)
    look: Look = field(default_factory=Look)
