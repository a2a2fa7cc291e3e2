"""The protocol every kind of character implements so that ``World`` can step them alike.

A population is all the characters of one kind (``sim.mitake``, ``sim.articulated``, ``sim.quadruped``).
``World`` calls each population, in a fixed order, at the points of a control tick (dm_control's
before-step / physics step / after-step split): ``before_tick`` → for each physics substep
``before_substep`` → ``stepSimulation`` → ``after_substep`` (people's contact forces) → ``after_tick``
→ ``notice`` (contact episodes that ended). Times in seconds, forces in newtons, positions in stage
metres. ``World`` never asks which kind a character is: it asks the population that holds the name.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol

from interaction.types import Contactor, Impulse
from sim.snapshot import CharacterSnapshot, ContactEvent, StateChange
from sim.terrain import TerrainGrid

__all__ = ["Footprint", "Population", "Tick"]

Footprint = tuple[str, float, float, float]  # name, stage x, y and radius (m) where no cube may go


@dataclass(slots=True)
class Tick:
    """One control tick as the populations see it; they append what happened to ``changes``/``events``."""

    t: float  # the tick's start
    dt: float  # its length (the control step)
    t_end: float  # the world's time once its physics has run (``World.t``; set before ``after_tick``)
    contactors: tuple[Contactor, ...]  # the people's contactors during it
    terrain: TerrainGrid | None  # the world's cube grid (read it; only the world changes it)
    forget: Callable[[str], None]  # drop a character's open contact episodes (it was put back)
    changes: list[StateChange] = field(default_factory=list)
    events: list[ContactEvent] = field(default_factory=list)


class Population(Protocol):
    """All the characters of one kind in one world."""

    def __contains__(self, name: object) -> bool: ...

    def __len__(self) -> int: ...

    @property
    def bodies(self) -> Mapping[int, str]:
        """pybullet body id → character name, for the people's contact forces (empty: not reported)."""
        ...

    def add(self, name: str, spec: Any, position: tuple[float, float], heading: float, t: float,
            **options: Any) -> None:
        """Stand a character of this kind (``spec``'s type) at ``position`` facing ``heading`` (radians);
        ``options`` (``intent``, ``waypoints``, ``goal``): it takes those it knows and ignores the rest."""
        ...

    def footprints(self) -> Iterable[Footprint]:
        """The characters whose floor cells refuse cubes (reserved by the world before each tick)."""
        ...

    def start_step(self) -> None:
        """A ``World.step`` begins: forget the previous step's peak contact forces."""
        ...

    def reach(self, position: tuple[float, float, float]) -> float | None:
        """Distance (m) to its nearest character a pad's impulse may act on; None: it takes none."""
        ...

    def impulse(self, impulse: Impulse, t: float) -> None:
        """A pad's impulse for the nearest of its characters (after ``reach`` said it is the nearest)."""
        ...

    def strike(self, name: str, force: tuple[float, float, float], duration: float,
               at: tuple[float, float, float], t: float) -> None:
        """Push ``name`` with ``force`` (N, world frame) for ``duration`` s at ``at`` (body frame from the CoM)."""
        ...

    def before_tick(self, tick: Tick) -> None: ...

    def substeps(self) -> tuple[int, bool]:
        """Physics steps per world physics step it needs now (1: the world's), and whether for a recovery."""
        ...

    def before_substep(self, dt: float, recovering: bool) -> None: ...

    def after_substep(self, t: float, dt: float, forces: Mapping[tuple[str, int], float]) -> None:
        """``forces``: (character, person) → N the people put on its characters during the substep."""
        ...

    def after_tick(self, tick: Tick) -> None: ...

    def notice(self, tick: Tick, ended: Sequence[ContactEvent]) -> None:
        """Contact episodes of its characters that ended in this tick (already in ``tick.events``)."""
        ...

    def push_threshold(self, name: str) -> float:
        """The impulse (N·s) from which a contact on ``name`` counts as a push."""
        ...

    def snapshots(self) -> tuple[CharacterSnapshot, ...]: ...

    def counts(self) -> Mapping[str, int]:
        """Repairs made (``WorldCounters`` fields) since the world was made."""
        ...
