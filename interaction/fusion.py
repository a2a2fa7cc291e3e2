"""One observation from several observers, without counting a person twice.

A depth camera's contactors are spheres (``half_depth == 0``) at the person's place in 3-D; a
webcam's are capsules sweeping the stage's y band (``half_depth > 0``). When both see the same
person, the webcam person's contactors are dropped and the depth person's kept: a webcam person
is "the same" as a depth person when that depth person's centre (x) lies within the webcam
person's x extent widened by ``margin_m``, and within the webcam's y band. People only one sensor
sees are kept. Person ids are made distinct per observer: ``1000 · k + id`` for the k-th
observation passed in (so keep the order of the observers fixed). Impulses (pads) pass through.

Use :meth:`SensorFusion.merge` in place of :meth:`BodyObservation.merge`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

from interaction.types import BodyObservation, Contactor, TerrainReport

__all__ = ["FusionConfig", "SensorFusion", "ID_STRIDE"]

ID_STRIDE = 1000


@dataclass(frozen=True)
class FusionConfig:
    margin_m: float = 0.15  # widening of a webcam person's x extent when matching depth people

    def __post_init__(self) -> None:
        if not isinstance(self.margin_m, int | float) or isinstance(self.margin_m, bool) or not 0 <= self.margin_m <= 2:
            raise ValueError(f"margin_m: expected a number 0..2 (metres), got {self.margin_m!r}")


class SensorFusion:
    """Merges the observers' latest observations; :attr:`dropped` says whom it left out last time."""

    def __init__(self, config: FusionConfig | None = None) -> None:
        self._cfg = config or FusionConfig()
        self.dropped: frozenset[int] = frozenset()  # fused ids of the webcam people seen by depth too

    def merge(self, t: float, parts: Sequence[BodyObservation]) -> BodyObservation:
        renamed = [[replace(c, person=ID_STRIDE * k + c.person) for c in o.contactors] for k, o in enumerate(parts)]
        spheres = [c for cs in renamed for c in cs if c.half_depth == 0]
        depth_people: dict[int, list[Contactor]] = {}
        for c in spheres:
            depth_people.setdefault(c.person, []).append(c)
        centres = [_centre(cs) for cs in depth_people.values()]
        dropped: set[int] = set()
        people = 0
        for o, cs in zip(parts, renamed, strict=True):
            bands: dict[int, list[Contactor]] = {}
            for c in cs:
                if c.half_depth > 0:
                    bands.setdefault(c.person, []).append(c)
            for pid, band in bands.items():
                lo = min(c.position[0] - c.radius for c in band) - self._cfg.margin_m
                hi = max(c.position[0] + c.radius for c in band) + self._cfg.margin_m
                y0, half = band[0].position[1], band[0].half_depth
                if any(lo <= x <= hi and abs(y - y0) <= half for x, y in centres):
                    dropped.add(pid)
            seen_by_depth = sum(1 for pid in bands if pid in dropped)
            people += max(0, o.people - seen_by_depth)
        self.dropped = frozenset(dropped)
        contactors = tuple(c for cs in renamed for c in cs if c.person not in dropped)
        return BodyObservation(t=t, contactors=contactors, impulses=tuple(i for o in parts for i in o.impulses),
                               people=people,
                               silhouette=next((o.silhouette for o in parts if o.silhouette is not None), None),
                               terrain=TerrainReport.merge([o.terrain for o in parts]))


def _centre(cs: list[Contactor]) -> tuple[float, float]:
    """A depth person's (x, y): its body spheres' mean, or all its contactors' when it has none."""
    body = [c for c in cs if c.part == "body"] or cs
    return (sum(c.position[0] for c in body) / len(body), sum(c.position[1] for c in body) / len(body))
