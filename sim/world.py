"""The simulated world: pybullet (DIRECT), the floor, the terrain, the people's contactors and the characters.

``World.step(observation, dt)`` accumulates ``dt`` and runs whole control ticks. The characters are
populations, one per kind (``sim.population``: ``sim.mitake``, ``sim.quadruped``, ``sim.articulated``),
each called at the same points of a tick: ``before_tick``; the contactors placed (``sim.contactors``);
``n_substeps`` physics steps of ``physics_dt`` (finer while a population asks for it), each between
``before_substep`` and ``after_substep``, with the people's contact forces computed, bounded per person
and applied before each step (``sim.person_contact``); ``after_tick``; contact episodes closed and
``notice``d. Catch-up is capped at ``max_catchup_ticks``; the skipped time is reported.

Input: the contactors of the latest observation stand (moved along their velocity) for
``contactor_hold_s``; ``None`` means no new observation. Each pad ``Impulse`` acts once, on the nearest
character that takes pads; an identical impulse reported again while the first one is still acting is
taken as the same report. ``strike`` pushes a chosen point of a chosen character.
"""

from __future__ import annotations

import math
import time
from collections import Counter
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from types import EllipsisType

import numpy as np
import pybullet as p

from interaction.types import BodyObservation, Contactor, Impulse, Vec3
from sim.articulated.spec import ArticulatedSpec
from sim.articulated.troupe import ArticulatedCharacters
from sim.config import CharacterSpec, WorldConfig
from sim.contactors import ContactEpisodes, ContactorPool
from sim.inputs import clean_observation, clean_push, contactors_at
from sim.mitake.character import CharacterView
from sim.mitake.crowd import Crowd
from sim.mitake.population import MitakeCharacters
from sim.person_contact import PersonContact
from sim.physics import open_client
from sim.population import Population, Tick
from sim.quadruped.config import QuadrupedSpec
from sim.quadruped.herd import Quadrupeds
from sim.snapshot import ContactEvent, StateChange, WorldSnapshot
from sim.terrain import TerrainBody, TerrainConfig, TerrainGrid
from sim.terrain_edits import TerrainEdits

__all__ = ["World", "WorldCounters"]

_REACH_M = 5.0  # a strike's point of application lies within this distance of the centre of mass
_KINDS = ("mitake", "quadruped", "articulated")  # the populations' order: snapshots, ticks, contact reads


@dataclass(frozen=True, slots=True)
class WorldCounters:
    """What the world had to repair since it was made (all should stay 0 in a healthy installation)."""

    rejected_inputs: int = 0  # contactors/impulses dropped: non-finite or absurd positions/forces
    clamped_inputs: int = 0  # values clamped: speeds, radii, forces, durations, bad dt
    non_finite_controls: int = 0  # controller outputs replaced by zero before reaching pybullet
    recovered_characters: int = 0  # characters put back upright: off stage, stuck, non-finite
    dropped_ticks: int = 0  # control ticks skipped by the catch-up cap
    slowed_characters: int = 0  # bodies found beyond max_character_speed / max_character_spin, slowed to it


class World:
    def __init__(self, config: WorldConfig, rng: np.random.Generator) -> None:
        self.config = config
        self._n_sub = config.n_substeps
        client, self._floor = open_client(config)
        self._client: int | None = client
        self._pool = ContactorPool(client)
        self._law = PersonContact(client, config.contactor_stiffness, config.contactor_damping,
                                  config.contactor_friction, config.max_person_force_n)
        self._episodes = ContactEpisodes(config.contact_episode_gap_s)
        self._ticks = 0
        self._pending = 0.0
        self._contactors: tuple[Contactor, ...] = ()
        self._contactors_t = 0.0
        self._placed_t = 0.0  # when the contactors' bodies were last placed
        self._seen: dict[Impulse, float] = {}  # impulses applied, until when a repeat is the same one
        self._counts = {f: 0 for f in WorldCounters.__dataclass_fields__}
        self.physics_wall_s = 0.0  # wall seconds spent in the physics substeps (for benchmarks)
        self._terrain: TerrainGrid | None = None
        self._terrain_edits: TerrainEdits | None = None
        self._intent_all: str | None = None  # imposed on every Mitake character (attract mode), None: their own
        self._mitake = MitakeCharacters(client, config, rng)
        stage = (config.x_min, config.x_max, config.y_min, config.y_max)
        self._populations: dict[str, Population] = {
            "mitake": self._mitake, "articulated": ArticulatedCharacters(client, stage)}
        self._kind_of_spec: dict[type, str] = {CharacterSpec: "mitake", ArticulatedSpec: "articulated",
                                               QuadrupedSpec: "quadruped"}

    # ------------------------------------------------------------------ public surface
    @property
    def t(self) -> float:
        return self._ticks * self.config.control_dt

    @property
    def counters(self) -> WorldCounters:
        counts = dict(self._counts)
        for population in self._ordered():
            for key, n in population.counts().items():
                counts[key] += n
        return WorldCounters(**counts)

    @property
    def crowd(self) -> Crowd:
        """The Mitake characters' arrays (read them; the world owns and writes them)."""
        return self._mitake.crowd

    def character(self, name: str) -> CharacterView:
        """One Mitake character's controller record (bounds, state, load); KeyError if unknown."""
        return self._mitake.view(name)

    def population(self, kind: str) -> Population:
        """The characters of one kind (``mitake``, ``articulated``, ``quadruped``), to read; KeyError if none."""
        return self._populations[kind]

    @property
    def terrain(self) -> TerrainGrid | None:
        """The cube grid every character collides with (None until ``add_terrain``); read it."""
        return self._terrain

    @property
    def terrain_counts(self) -> Counter[str]:
        """What became of the terrain's layout and the people's changes (``sim.terrain_edits``)."""
        return Counter() if self._terrain_edits is None else Counter(self._terrain_edits.counts)

    def add_terrain(self, config: TerrainConfig, layout: Iterable[tuple[int, int, int]] = ()) -> TerrainGrid:
        """Lay the cube grid (with its pybullet twin) on the floor and build ``layout`` ((ix, iy, cubes) per
        column) on it, bar the cells under the characters already standing (no cube goes there).
        Quadrupeds walk on it: add them after it. Afterwards it changes through ``step``'s observations."""
        client = self._require_open()
        if self._terrain is not None:
            raise ValueError("terrain: the world has one already")
        grid = self._terrain = TerrainGrid(config)
        TerrainBody(client, grid)
        self._populations["quadruped"] = Quadrupeds(client, grid)
        self._reserve(grid)
        self._terrain_edits = TerrainEdits(grid)
        self._terrain_edits.layout(layout)
        return grid

    def add_character(self, spec: CharacterSpec | ArticulatedSpec | QuadrupedSpec, position: tuple[float, float],
                      heading: float, intent: str = "wander", waypoints: Sequence[tuple[float, float]] | None = None,
                      goal: tuple[float, float] | None = None) -> str:
        """Stand a new character upright at stage ``position`` facing ``heading``; returns its unique name.

        The spec's type says the kind: ``CharacterSpec`` (``intent``; ``waypoints`` replaces the spec's loop
        for the intent ``follow``), ``ArticulatedSpec`` (it walks its clip), ``QuadrupedSpec`` (needs
        ``add_terrain`` first; ``goal`` or ``waypoints``).
        """
        self._require_open()
        if len(position) != 2 or not all(math.isfinite(v) for v in (*position, heading)):
            raise ValueError(f"position: expected finite (x, y) and heading, got {position!r}, {heading!r}")
        kind = self._kind_of_spec[type(spec)]
        if kind not in self._populations:  # (the quadrupeds come with the terrain)
            raise ValueError(f"{spec.name}: a {kind} needs the terrain (World.add_terrain) first")
        name = self._unique_name(spec.name)  # each kind takes the options it knows
        self._populations[kind].add(name, spec, (float(position[0]), float(position[1])), float(heading), self.t,
                                    intent=intent, waypoints=waypoints, goal=goal)
        if self._terrain is not None:  # no cube goes under it from now on
            self._reserve(self._terrain)
        return name

    def strike(self, name: str, force: Vec3, duration: float, at: Vec3) -> None:
        """Push character ``name`` with the world-frame ``force`` (N) for ``duration`` s at the point ``at``
        (its body frame, metres from the centre of mass: x forward, y left, z up; ``sim.mitake.body.figure_point``).

        On a Mitake character it is reported as a ``ContactEvent`` of person ``PAD_PERSON`` when it ends,
        like a pad's; on an articulated character it acts on the link nearest ``at`` and makes it stagger.
        """
        push = clean_push(force, duration, self.config)
        if push is None or len(at) != 3 or not all(math.isfinite(v) and abs(v) <= _REACH_M for v in at):
            self._counts["rejected_inputs"] += 1
            return
        force, duration, cut = push
        self._counts["clamped_inputs"] += cut
        self._owner(name).strike(name, force, duration, at, self.t)

    def step(self, observation: BodyObservation | None, dt: float, *,
             intent_all: str | None | EllipsisType = ...) -> WorldSnapshot:
        """Advance by ``dt`` seconds of loop time (whole control ticks; the remainder waits).

        ``intent_all``: from now on every Mitake character follows this intent instead of its own (attract
        mode; pushes and falls still come first); ``None``: each its own again; ``...``: as before.
        """
        self._require_open()
        if intent_all is not ... and intent_all != self._intent_all:
            self._mitake.set_intent_all(intent_all)
            self._intent_all = intent_all
        if not (isinstance(dt, int | float) and math.isfinite(dt) and dt >= 0.0):
            self._counts["clamped_inputs"] += 1
            dt = 0.0
        if observation is not None:
            self._take(observation)
        cdt = self.config.control_dt
        self._pending += dt
        n = int(math.floor(self._pending / cdt + 1e-9))
        dropped = 0.0
        if n > self.config.max_catchup_ticks:
            skipped = n - self.config.max_catchup_ticks
            dropped = skipped * cdt
            self._counts["dropped_ticks"] += skipped
            n = self.config.max_catchup_ticks
            self._pending -= dropped
        for population in self._ordered():
            population.start_step()
        events: list[ContactEvent] = []
        changes: list[StateChange] = []
        for _ in range(n):
            self._tick(events, changes)
            self._pending -= cdt
        self._pending = max(0.0, self._pending)
        return self._snapshot(tuple(events), tuple(changes), dropped)

    def snapshot(self) -> WorldSnapshot:
        """The world as it is now (no events: those belong to the step that produced them)."""
        self._require_open()
        return self._snapshot((), (), 0.0)

    def close(self) -> None:
        if self._client is not None:
            p.disconnect(physicsClientId=self._client)
            self._client = None

    def __enter__(self) -> World:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # ------------------------------------------------------------------ populations
    def _ordered(self) -> list[Population]:
        return [self._populations[k] for k in _KINDS if k in self._populations]

    def _owner(self, name: str) -> Population:
        for population in self._ordered():
            if name in population:
                return population
        raise KeyError(name)

    def _unique_name(self, base: str) -> str:
        name, k = base, 1
        while any(name in population for population in self._ordered()):
            k += 1
            name = f"{base}-{k}"
        return name

    def _reserve(self, grid: TerrainGrid) -> None:
        """No cube under a character: the cells around each one's centre are kept free."""
        for population in self._ordered():
            for name, x, y, radius in population.footprints():
                grid.reserve(name, grid.cells_within(x, y, radius))

    # ------------------------------------------------------------------ input
    def _require_open(self) -> int:
        if self._client is None:
            raise RuntimeError("World: already closed")
        return self._client

    def _take(self, obs: BodyObservation) -> None:
        cleaned = clean_observation(obs, self.config)
        self._counts["rejected_inputs"] += cleaned.rejected
        self._counts["clamped_inputs"] += cleaned.clamped
        self._contactors = cleaned.contactors
        self._contactors_t = self.t
        if cleaned.terrain is not None and self._terrain_edits is not None:
            self._terrain_edits.apply(cleaned.terrain)
        now = self.t
        self._seen = {imp: until for imp, until in self._seen.items() if until > now}
        for imp in cleaned.impulses:
            if imp in self._seen:  # the same report again (a re-sent observation): once
                continue
            reaches = [(d, population) for population in self._ordered()
                       if (d := population.reach(imp.position)) is not None]
            if not reaches:
                continue
            self._seen[imp] = now + imp.duration + self.config.control_dt
            min(reaches, key=lambda r: r[0])[1].impulse(imp, now)

    # ------------------------------------------------------------------ one control tick
    def _tick(self, events: list[ContactEvent], changes: list[StateChange]) -> None:
        client = self._require_open()
        cfg = self.config
        t0 = self.t
        contactors = contactors_at(self._contactors, t0 - self._contactors_t, self.config.contactor_hold_s)
        tick = Tick(t0, cfg.control_dt, t0, contactors, self._terrain, self._episodes.forget, changes, events)
        populations = self._ordered()
        if self._terrain is not None:
            self._reserve(self._terrain)
        for population in populations:
            population.before_tick(tick)
        self._pool.place(contactors)
        self._placed_t = t0
        if self._pool.active:
            bodies = {body: name for population in populations for body, name in population.bodies.items()}
            self._law.prepare(self._pool.active, bodies, cfg.control_dt)
        start = time.perf_counter()
        for k in range(self._n_sub):
            fine = max(population.substeps() for population in populations)  # finer while one recovers
            n = fine[0]
            if n > 1:
                p.setPhysicsEngineParameter(fixedTimeStep=cfg.physics_dt / n, physicsClientId=client)
            for j in range(n):
                self._physics_step(populations, cfg.physics_dt / n, fine[1],
                                   t0 + (k + (j + 1) / n) * cfg.physics_dt)
            if n > 1:
                p.setPhysicsEngineParameter(fixedTimeStep=cfg.physics_dt, physicsClientId=client)
        self.physics_wall_s += time.perf_counter() - start
        self._ticks += 1
        tick.t_end = self.t
        for population in populations:
            population.after_tick(tick)
        ended = self._episodes.close(self.t, lambda name: self._owner(name).push_threshold(name))
        events.extend(ended)
        for population in populations:
            population.notice(tick, [ev for ev in ended if ev.character in population])

    def _physics_step(self, populations: list[Population], dt: float, recovering: bool, t_sub: float) -> None:
        """One ``stepSimulation`` of ``dt`` with the people's contact forces (``sim.person_contact``: bounded
        per person, applied before the step, reported to each population after it)."""
        for population in populations:
            population.before_substep(dt, recovering)
        forces = self._law.apply(self._pool.active, dt, t_sub - dt - self._placed_t) if self._pool.active else {}
        p.stepSimulation(physicsClientId=self._require_open())
        if not forces:
            return
        for (name, person), f in forces.items():
            self._episodes.add(t_sub, name, person, f, dt)
        for population in populations:
            if population.bodies:
                population.after_substep(t_sub, dt, {key: f for key, f in forces.items() if key[0] in population})

    def _snapshot(self, events: tuple[ContactEvent, ...], changes: tuple[StateChange, ...],
                  dropped: float) -> WorldSnapshot:
        characters = tuple(c for population in self._ordered() for c in population.snapshots())
        return WorldSnapshot(t=self.t, steps=self._ticks * self._n_sub, characters=characters,
                             contacts=events, changes=changes, dropped_time=dropped)
