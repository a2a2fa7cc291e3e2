"""The Mitake characters of one world as a ``sim.population.Population``.

Each tick, for all of them at once (``sim.mitake.crowd``): AI (``sim.mitake.ai``) → state machine
(``sim.mitake.states``) → control law (``sim.mitake.control``), whose impulse is written into each
body's velocities with one pybullet call; pads and strikes (``sim.mitake.pushes``) are re-applied before
every physics substep (pybullet clears external forces after each ``stepSimulation``); after the
substeps one batched read of every body, speed limits and repairs (``sim.mitake.repair``).
A pad's impulse acts on the body axis of the nearest character.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

import numpy as np
import pybullet as p

from interaction.types import Contactor, Impulse, Vec3
from sim.config import INTENTS, CharacterSpec, WorldConfig
from sim.frames import yaw_quaternion
from sim.mitake.ai import Neighbours, Stage, decide, impose_intent, notice_push, separation_velocities
from sim.mitake.balance import BalanceDesign
from sim.mitake.body import create_body, create_shape, read_states, write_velocities
from sim.mitake.character import CharacterView, snapshots, view
from sim.mitake.control import control
from sim.mitake.crowd import STATES, WALK, Crowd
from sim.mitake.pushes import Push, axis_offset, finished, tick_forces
from sim.mitake.repair import free_spot, lost_characters, slow_down, stand_again
from sim.mitake.states import advance, enter_state, quiet, readings
from sim.population import Footprint, Tick
from sim.snapshot import CharacterSnapshot, ContactEvent, StateChange

__all__ = ["MitakeCharacters"]

_RESERVE_M = 0.25  # around a character's centre: no cube there
_SHAPE_FIELDS = ("height", "com_height", "widest_height", "half_depth", "half_width", "bottom_exponent",
                 "top_exponent")
_DESIGN_FIELDS = ("mass", "inertia", "com_height", "tau_max", "tau_max_side", "leg_force_max", "yaw_frequency",
                  "lqr_tilt_scale_deg", "lqr_rate_scale", "lqr_speed_scale")


class MitakeCharacters:
    def __init__(self, client: int, config: WorldConfig, rng: np.random.Generator) -> None:
        self._client = client
        self._config = config
        self._rng = rng
        self._stage = Stage(config.x_min, config.x_max, config.y_min, config.y_max)
        self.crowd = Crowd()  # the characters' arrays (others read them; only this population writes them)
        self._by_body: dict[int, str] = {}
        self._shapes: dict[tuple[float, ...], int] = {}  # by the spec's body figures
        self._designs: dict[tuple[float, ...], BalanceDesign] = {}  # by its balance figures
        self._pushes: list[Push] = []
        self._neighbours = Neighbours()
        self._own_intents: np.ndarray | None = None  # each character's own intent while set_intent_all rules
        self._touched: set[int] = set()  # rows pushed during this tick
        self._pad_forces: list[tuple[int, Vec3, Vec3]] = []  # this tick's (body, force, world point)
        self._counts = {"recovered_characters": 0, "slowed_characters": 0}

    def __contains__(self, name: object) -> bool:
        return name in self.crowd.index

    def __len__(self) -> int:
        return len(self.crowd)

    @property
    def bodies(self) -> Mapping[int, str]:
        return self._by_body

    def view(self, name: str) -> CharacterView:
        return view(self.crowd, self.crowd.index[name])

    def add(self, name: str, spec: Any, position: tuple[float, float], heading: float, t: float,
            **options: Any) -> None:
        """Options: ``intent`` (one of ``INTENTS``), ``waypoints`` (stage x, y; replaces the spec's loop)."""
        assert isinstance(spec, CharacterSpec)
        intent = options.get("intent", "wander")
        waypoints = options.get("waypoints")
        if intent not in INTENTS:
            raise ValueError(f"intent: expected one of {', '.join(INTENTS)}, got {intent!r}")
        path = np.asarray(spec.waypoints if waypoints is None else waypoints, dtype=np.float64).reshape(-1, 2)
        if not np.isfinite(path).all():
            raise ValueError(f"waypoints: expected finite (x, y) pairs, got {waypoints!r}")
        cfg, client = self._config, self._client
        shape_key = tuple(getattr(spec, f) for f in _SHAPE_FIELDS)
        if shape_key not in self._shapes:
            self._shapes[shape_key] = create_shape(client, spec)
        design_key = tuple(getattr(spec, f) for f in _DESIGN_FIELDS)
        if design_key not in self._designs:
            self._designs[design_key] = BalanceDesign.for_spec(spec, cfg.floor_friction, cfg.gravity, cfg.control_dt)
        pos = (position[0], position[1], spec.com_height + 0.002)
        orn = yaw_quaternion(heading)
        body = create_body(client, spec, self._shapes[shape_key], pos, orn)
        row = self.crowd.add(name, body, spec, self._designs[design_key], intent, path, t)
        self.crowd.place(row, pos, orn, spec.mass, cfg.gravity)  # just put there, still: no pybullet read
        self.crowd.heading_goal[row] = heading
        self._by_body[body] = name

    def set_intent_all(self, intent: str | None) -> None:
        """Every character follows ``intent`` instead of its own; ``None``: its own again."""
        self._own_intents = impose_intent(self.crowd, intent, self._own_intents)

    def footprints(self) -> Iterable[Footprint]:
        crowd = self.crowd
        return [(name, float(xy[0]), float(xy[1]), _RESERVE_M) for name, xy in zip(crowd.names, crowd.pos[:, :2],
                                                                                     strict=True)]

    def start_step(self) -> None:
        self.crowd.contact_force[:] = 0.0

    def reach(self, position: tuple[float, float, float]) -> float | None:
        crowd = self.crowd
        if not len(crowd):
            return None
        return float(np.min(np.hypot(crowd.pos[:, 0] - position[0], crowd.pos[:, 1] - position[1])))

    def impulse(self, impulse: Impulse, t: float) -> None:
        crowd = self.crowd
        row = int(np.argmin(np.hypot(crowd.pos[:, 0] - impulse.position[0], crowd.pos[:, 1] - impulse.position[1])))
        self._pushes.append(Push(row, impulse.force, axis_offset(crowd, row, impulse.position[2]), impulse.duration,
                                 impulse.duration, t))

    def strike(self, name: str, force: Vec3, duration: float, at: Vec3, t: float) -> None:
        """Reported as a ``ContactEvent`` of person ``PAD_PERSON`` when it ends, like a pad's."""
        self._pushes.append(Push(self.crowd.index[name], force, at, duration, duration, t))

    # ------------------------------------------------------------------ one control tick
    def before_tick(self, tick: Tick) -> None:
        cfg = self._config
        if len(self.crowd):
            self._think(tick.t, tick.contactors, tick.changes)
        self._touched = {push.row for push in self._pushes}  # every queued push acts in this tick
        self._pad_forces = tick_forces(self._pushes, self.crowd, cfg.control_dt, cfg.max_impulse_force_n)

    def substeps(self) -> tuple[int, bool]:
        return 1, False

    def before_substep(self, dt: float, recovering: bool) -> None:
        for body, force, at in self._pad_forces:
            p.applyExternalForce(body, -1, force, at, p.WORLD_FRAME, physicsClientId=self._client)

    def after_substep(self, t: float, dt: float, forces: Mapping[tuple[str, int], float]) -> None:
        crowd = self.crowd
        for (name, _), f in forces.items():
            row = crowd.index[name]
            crowd.contact_force[row] = max(crowd.contact_force[row], f)
            self._touched.add(row)

    def after_tick(self, tick: Tick) -> None:
        cfg, crowd = self._config, self.crowd
        if self._touched:  # pushed during this tick (a person's contact, a pad, a strike): it may pivot
            crowd.pushed_at[list(self._touched)] = tick.t
        crowd.sense(*read_states(self._client, crowd.bodies), cfg.control_dt, cfg.gravity)
        self._counts["slowed_characters"] += slow_down(self._client, crowd, cfg)
        self._recover(tick)
        fr = crowd.frames
        crowd.d_front += (crowd.vel[:, 0] * fr.cos_h + crowd.vel[:, 1] * fr.sin_h) * cfg.control_dt
        crowd.d_side += (crowd.vel[:, 0] * fr.sin_h - crowd.vel[:, 1] * fr.cos_h) * cfg.control_dt

    def notice(self, tick: Tick, ended: Sequence[ContactEvent]) -> None:
        """A push turns a character away from whoever pushed it; then its own pads' and strikes' ends."""
        t = tick.t_end
        for ev in ended:
            self._notice(ev, tick.contactors, t)
        self._pushes, done = finished(self._pushes, self.crowd)
        for push, ev in done:
            tick.events.append(ev)
            if ev.push:
                notice_push(self.crowd, push.row, t, (push.force[0], push.force[1]))

    def push_threshold(self, name: str) -> float:
        return float(self.crowd.cols.push_threshold_ns[self.crowd.index[name]])

    def snapshots(self) -> tuple[CharacterSnapshot, ...]:
        return snapshots(self.crowd)

    def counts(self) -> Mapping[str, int]:
        return {**self._counts, "non_finite_controls": int(self.crowd.non_finite.sum())}

    # ------------------------------------------------------------------ inside a tick
    def _think(self, t0: float, contactors: tuple[Contactor, ...], changes: list[StateChange]) -> None:
        """AI, state machine and control of every character; writes the control impulses."""
        cfg, crowd, client = self._config, self.crowd, self._client
        c = crowd.cols
        xy = crowd.pos[:, :2]
        upright = crowd.upright()
        sep = separation_velocities(xy, c.personal_space, 2.0 * c.walk_speed, self._neighbours) * upright[:, None]
        person = np.full((len(crowd), 2), math.nan)
        if contactors:
            people = np.array([cc.position[:2] for cc in contactors])
            d = np.hypot(xy[:, 0, None] - people[None, :, 0], xy[:, 1, None] - people[None, :, 1])
            person = people[np.argmin(d, axis=1)]
        decide(crowd, t0, self._stage, sep, person, self._rng)
        load = crowd.load = crowd.balance_load()
        if not quiet(crowd, load):
            for row, before, after in advance(crowd, readings(crowd, t0, load), t0):
                enter_state(client, crowd, row, before, after, t0, cfg.floor_friction)
                changes.append(StateChange(t=t0, character=crowd.names[row], before=STATES[before],
                                           after=STATES[after]))
            up = crowd.upright()
            crowd.not_upright_since = np.where(up, math.nan, np.where(np.isnan(crowd.not_upright_since), t0,
                                                                      crowd.not_upright_since))
        elif not np.isnan(crowd.not_upright_since).all():
            crowd.not_upright_since[:] = math.nan
        imp = control(crowd, t0, cfg.floor_friction, cfg.gravity, cfg.control_dt)
        if imp.active.all():
            write_velocities(client, crowd.bodies, crowd.vel + imp.dv, crowd.ang + imp.dw)
        else:
            rows = np.flatnonzero(imp.active)
            bodies = [crowd.bodies[i] for i in rows.tolist()]
            write_velocities(client, bodies, crowd.vel[rows] + imp.dv[rows], crowd.ang[rows] + imp.dw[rows])
        crowd.vz_after = crowd.vel[:, 2] + imp.dv[:, 2]

    def _notice(self, ev: ContactEvent, contactors: tuple[Contactor, ...], t: float) -> None:
        if not ev.push:
            return
        crowd = self.crowd
        row = crowd.index[ev.character]
        x, y = float(crowd.pos[row, 0]), float(crowd.pos[row, 1])
        mine = [c for c in contactors if c.person == ev.person]
        if mine:
            near = min(mine, key=lambda c: math.hypot(c.position[0] - x, c.position[1] - y))
            notice_push(crowd, row, t, (x - near.position[0], y - near.position[1]))
        else:
            notice_push(crowd, row, t, (float(crowd.vel[row, 0]), float(crowd.vel[row, 1])))

    def _recover(self, tick: Tick) -> None:
        """Stand up, on the stage, every character that is lost, non-finite or stuck on the ground."""
        crowd, t = self.crowd, tick.t_end
        for row, lost in lost_characters(crowd, self._config, t):
            self._counts["recovered_characters"] += 1
            tick.forget(crowd.names[row])
            near = None if lost else (float(crowd.pos[row, 0]), float(crowd.pos[row, 1]))
            spot = free_spot(crowd, row, self._stage, self._rng, near)
            before = stand_again(self._client, crowd, row, spot, t, self._config.gravity)
            if before != WALK:
                tick.changes.append(StateChange(t=t, character=crowd.names[row], before=STATES[before],
                                                after=STATES[WALK]))
