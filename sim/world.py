"""The simulated world: pybullet (DIRECT), the floor, the characters and the people's contactors.

``World.step(observation, dt)`` accumulates ``dt`` and runs whole control ticks. Each tick, for all
characters at once (``sim.mitake.crowd``): AI (``sim.mitake.ai``) → state machine (``sim.mitake.states``) → control law
(``sim.mitake.control``), whose impulse is written into each body's velocities with one pybullet call; the
contactors are placed once (kinematic, with the people's velocity); then ``n_substeps`` calls of
``stepSimulation`` of ``physics_dt`` each (pads and strikes re-applied before each: pybullet clears
external forces after every call; contact impulses are read per substep, since ``getContactPoints``
only reports the last one); then one batched read of every body. Catch-up is capped at
``max_catchup_ticks``; the skipped time is reported.

Input: the contactors of the latest observation stand (moved along their velocity) for
``contactor_hold_s``; ``None`` means no new observation. Each pad ``Impulse`` is applied once, as a
force for its duration on the body axis of the nearest character; an identical impulse reported again
while the first one is still acting is taken as the same report. ``strike`` applies a force at a chosen
point of a chosen character (benchmarks, tests, scripted shows).
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import pybullet as p

from interaction.types import BodyObservation
from sim.articulated.spec import ArticulatedSpec
from sim.articulated.troupe import ArticulatedCharacters
from sim.config import INTENTS, CharacterSpec, WorldConfig
from sim.contactors import ContactEpisodes, ContactorPool
from sim.frames import Vec3, yaw_quaternion
from sim.inputs import SafeContactor, SafeImpulse, clean_observation, clean_push, contactors_at
from sim.mitake.ai import Neighbours, Stage, decide, impose_intent, notice_push, separation_velocities
from sim.mitake.balance import BalanceDesign
from sim.mitake.body import create_body, create_shape, read_states, write_velocities
from sim.mitake.character import CharacterView, snapshots, view
from sim.mitake.control import control
from sim.mitake.crowd import STATES, WALK, Crowd
from sim.mitake.pushes import PAD_PERSON, Push, axis_offset, finished, tick_forces
from sim.mitake.repair import free_spot, lost_characters, slow_down, stand_again
from sim.mitake.states import advance, enter_state, quiet, readings
from sim.physics import open_client
from sim.quadruped.herd import Quadrupeds, TerrainConfig
from sim.snapshot import ContactEvent, StateChange, WorldSnapshot

__all__ = ["PAD_PERSON", "World", "WorldCounters"]

_REACH_M = 5.0  # a strike's point of application lies within this distance of the centre of mass
_SHAPE_FIELDS = ("height", "com_height", "widest_height", "half_depth", "half_width", "bottom_exponent",
                 "top_exponent")
_DESIGN_FIELDS = ("mass", "inertia", "com_height", "tau_max", "tau_max_side", "leg_force_max", "yaw_frequency",
                  "lqr_tilt_scale_deg", "lqr_rate_scale", "lqr_speed_scale")


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
        self._rng = rng
        self._n_sub = config.n_substeps
        client, self._floor = open_client(config)
        self._client: int | None = client
        self._stage = Stage(config.x_min, config.x_max, config.y_min, config.y_max)
        self._pool = ContactorPool(client, config.contactor_friction, config.contactor_stiffness,
                                   config.contactor_damping)
        self._episodes = ContactEpisodes(config.contact_episode_gap_s)
        self._crowd = Crowd()
        self._by_body: dict[int, str] = {}
        self._shapes: dict[tuple[float, ...], int] = {}  # by the spec's body figures
        self._designs: dict[tuple[float, ...], BalanceDesign] = {}  # by its balance figures
        self._ticks = 0
        self._pending = 0.0
        self._contactors: tuple[SafeContactor, ...] = ()
        self._contactors_t = 0.0
        self._seen: dict[SafeImpulse, float] = {}  # impulses applied, until when a repeat is the same one
        self._pushes: list[Push] = []
        self._counts = {f: 0 for f in WorldCounters.__dataclass_fields__}
        self.physics_wall_s = 0.0  # wall seconds spent in the physics substeps (for benchmarks)
        self._neighbours = Neighbours()
        self._own_intents: np.ndarray | None = None  # each character's own intent while set_intent_all rules
        self.quadrupeds: Quadrupeds | None = None  # the cube terrain and the quadrupeds on it (terrain())
        self.articulated = ArticulatedCharacters(  # PD-tracked multibody characters (issue 9)
            client, (config.x_min, config.x_max, config.y_min, config.y_max))

    # ------------------------------------------------------------------ public surface
    @property
    def t(self) -> float:
        return self._ticks * self.config.control_dt

    @property
    def counters(self) -> WorldCounters:
        return WorldCounters(**{**self._counts, "non_finite_controls": int(self._crowd.non_finite.sum())})

    @property
    def crowd(self) -> Crowd:
        """The characters' arrays (read them; the world owns and writes them)."""
        return self._crowd

    def character(self, name: str) -> CharacterView:
        """One character's controller record (bounds, state, load); KeyError if unknown."""
        return view(self._crowd, self._crowd.index[name])

    def add_character(self, spec: CharacterSpec | ArticulatedSpec, position: tuple[float, float], heading: float,
                      intent: str = "wander", waypoints: Sequence[tuple[float, float]] | None = None) -> str:
        """Stand a new character upright at stage ``position`` facing ``heading``; returns its unique name.

        ``waypoints`` (stage x, y) replaces the spec's loop for the intent ``follow``. An ``ArticulatedSpec``
        makes an articulated character (``sim.articulated``; it walks its clip: no intent, no waypoints).
        """
        client = self._require_open()
        if len(position) != 2 or not all(math.isfinite(v) for v in (*position, heading)):
            raise ValueError(f"position: expected finite (x, y) and heading, got {position!r}, {heading!r}")
        if isinstance(spec, ArticulatedSpec):
            return self.articulated.add(self._unique_name(spec.name), spec, (float(position[0]), float(position[1])),
                                        float(heading))
        if intent not in INTENTS:
            raise ValueError(f"intent: expected one of {', '.join(INTENTS)}, got {intent!r}")
        path = np.asarray(spec.waypoints if waypoints is None else waypoints, dtype=np.float64).reshape(-1, 2)
        if not np.isfinite(path).all():
            raise ValueError(f"waypoints: expected finite (x, y) pairs, got {waypoints!r}")
        name = self._unique_name(spec.name)
        shape_key = tuple(getattr(spec, f) for f in _SHAPE_FIELDS)
        if shape_key not in self._shapes:
            self._shapes[shape_key] = create_shape(client, spec)
        design_key = tuple(getattr(spec, f) for f in _DESIGN_FIELDS)
        if design_key not in self._designs:
            self._designs[design_key] = BalanceDesign.for_spec(spec, self.config.floor_friction, self.config.gravity,
                                                               self.config.control_dt)
        pos = (float(position[0]), float(position[1]), spec.com_height + 0.002)
        orn = yaw_quaternion(heading)
        body = create_body(client, spec, self._shapes[shape_key], pos, orn)
        row = self._crowd.add(name, body, spec, self._designs[design_key], intent, path, self.t)
        self._place_row(row, pos, orn)
        self._crowd.heading_goal[row] = heading
        self._by_body[body] = name
        return name

    def set_intent_all(self, intent: str | None) -> None:
        """Every character follows ``intent`` instead of its own (pushes and falls still come first);
        ``None``: each follows the intent it was added with again."""
        self._own_intents = impose_intent(self._crowd, intent, self._own_intents)

    def _unique_name(self, base: str) -> str:
        name, k = base, 1
        while name in self._crowd.index or name in self.articulated:
            k += 1
            name = f"{base}-{k}"
        return name

    def terrain(self, config: TerrainConfig) -> Quadrupeds:
        """The cube terrain (made on first call, with its pybullet twin) and its quadrupeds (``add``)."""
        if self.quadrupeds is None:
            self.quadrupeds = Quadrupeds(self._require_open(), config)
        return self.quadrupeds

    def strike(self, name: str, force: Vec3, duration: float, at: Vec3) -> None:
        """Push character ``name`` with the world-frame ``force`` (N) for ``duration`` s at the point ``at``
        (its body frame, metres from the centre of mass: x forward, y left, z up; ``sim.mitake.body.figure_point``).

        Reported as a ``ContactEvent`` of person ``PAD_PERSON`` when it ends, like a pad's (not for an
        articulated character: its push acts on the link nearest ``at``, and makes it stagger).
        """
        push = clean_push(force, duration, self.config)
        if push is None or len(at) != 3 or not all(math.isfinite(v) and abs(v) <= _REACH_M for v in at):
            self._counts["rejected_inputs"] += 1
            return
        force, duration, cut = push
        self._counts["clamped_inputs"] += cut
        if name in self.articulated:
            self.articulated.strike(name, force, duration, at)
            return
        self._pushes.append(Push(self._crowd.index[name], force, at, duration, duration, self.t))

    def step(self, observation: BodyObservation | None, dt: float) -> WorldSnapshot:
        """Advance by ``dt`` seconds of loop time (whole control ticks; the remainder waits)."""
        self._require_open()
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
        self._crowd.contact_force[:] = 0.0
        self.articulated.clear_forces()
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
        now = self.t
        self._seen = {imp: until for imp, until in self._seen.items() if until > now}
        crowd = self._crowd
        for imp in cleaned.impulses:
            if imp in self._seen or not len(crowd):  # the same report again (a re-sent observation): once
                continue
            self._seen[imp] = now + imp.duration + self.config.control_dt
            row = int(np.argmin(np.hypot(crowd.pos[:, 0] - imp.position[0], crowd.pos[:, 1] - imp.position[1])))
            self._pushes.append(Push(row, imp.force, axis_offset(crowd, row, imp.position[2]), imp.duration,
                                     imp.duration, now))

    def _physics_step(self, pad_forces: list[tuple[int, Vec3, Vec3]], fine: tuple[int, bool], t_sub: float,
                      touched: set[int]) -> None:
        """One ``stepSimulation`` of physics_dt / n, pads re-applied, then contacts (``fine``: n, recovering)."""
        client, crowd, dt = self._require_open(), self._crowd, self.config.physics_dt / fine[0]
        for body, force, at in pad_forces:
            p.applyExternalForce(body, -1, force, at, p.WORLD_FRAME, physicsClientId=client)
        if self.articulated.characters:
            self.articulated.before_physics_step(dt, fine[1])
        p.stepSimulation(physicsClientId=client)
        if not self._pool.active:
            return
        for (name, person), f in self._pool.read_forces(self._by_body).items():
            self._episodes.add(t_sub, name, person, f, dt)
            row = crowd.index[name]
            crowd.contact_force[row] = max(crowd.contact_force[row], f)
            touched.add(row)
        if self.articulated.characters:
            for (name, person), f in self._pool.read_forces(self.articulated.bodies).items():
                self._episodes.add(t_sub, name, person, f, dt)
                self.articulated.contact_force(name, f)

    # ------------------------------------------------------------------ one control tick
    def _tick(self, events: list[ContactEvent], changes: list[StateChange]) -> None:
        client = self._require_open()
        cfg, crowd = self.config, self._crowd
        t0 = self.t
        contactors = contactors_at(self._contactors, t0 - self._contactors_t, self.config.contactor_hold_s)
        if len(crowd):
            self._think(t0, contactors, changes)
        self._pool.place(contactors)
        if self.quadrupeds is not None:  # procedural legs, kinematic bodies: posed before the physics
            self.quadrupeds.tick(t0, cfg.control_dt, contactors, crowd.pos[:, :2], crowd.names)
        touched = {push.row for push in self._pushes}  # every queued push acts in this tick
        pad_forces = tick_forces(self._pushes, crowd, cfg.control_dt, cfg.max_impulse_force_n)
        start = time.perf_counter()
        for k in range(self._n_sub):
            fine = self.articulated.substeps()  # finer while one recovers (sim.articulated.recovery): all bodies
            n = fine[0]
            if n > 1:
                p.setPhysicsEngineParameter(fixedTimeStep=cfg.physics_dt / n, physicsClientId=client)
            for j in range(n):
                self._physics_step(pad_forces, fine, t0 + (k + (j + 1) / n) * cfg.physics_dt, touched)
            if n > 1:
                p.setPhysicsEngineParameter(fixedTimeStep=cfg.physics_dt, physicsClientId=client)
        self.physics_wall_s += time.perf_counter() - start
        self._ticks += 1
        if self.articulated.characters:
            self.articulated.after_tick(self.t, cfg.control_dt, changes)
        if touched:  # pushed during this tick (a person's contact, a pad, a strike): it may pivot
            crowd.pushed_at[list(touched)] = t0
        crowd.sense(*read_states(client, crowd.bodies), cfg.control_dt, cfg.gravity)
        self._limit_speeds()
        self._recover(changes)
        fr = crowd.frames
        crowd.d_front += (crowd.vel[:, 0] * fr.cos_h + crowd.vel[:, 1] * fr.sin_h) * cfg.control_dt
        crowd.d_side += (crowd.vel[:, 0] * fr.sin_h - crowd.vel[:, 1] * fr.cos_h) * cfg.control_dt
        for ev in self._episodes.close(self.t, self._push_threshold):
            events.append(ev)
            self._notice(ev, contactors)
            if ev.character in self.articulated:
                self.articulated.notice(ev)
        self._pushes, done = finished(self._pushes, crowd)
        for push, ev in done:
            events.append(ev)
            if ev.push:
                notice_push(crowd, push.row, self.t, (push.force[0], push.force[1]))

    def _push_threshold(self, name: str) -> float:
        if name in self.articulated:
            return self.articulated.threshold(name)
        return float(self._crowd.cols.push_threshold_ns[self._crowd.index[name]])

    def _think(self, t0: float, contactors: tuple[SafeContactor, ...], changes: list[StateChange]) -> None:
        """AI, state machine and control of every character; writes the control impulses."""
        cfg, crowd, client = self.config, self._crowd, self._require_open()
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

    def _notice(self, ev: ContactEvent, contactors: tuple[SafeContactor, ...]) -> None:
        if not ev.push or ev.character not in self._crowd.index:
            return
        crowd = self._crowd
        row = crowd.index[ev.character]
        x, y = float(crowd.pos[row, 0]), float(crowd.pos[row, 1])
        mine = [c for c in contactors if c.person == ev.person]
        if mine:
            near = min(mine, key=lambda c: math.hypot(c.position[0] - x, c.position[1] - y))
            notice_push(crowd, row, self.t, (x - near.position[0], y - near.position[1]))
        else:
            notice_push(crowd, row, self.t, (float(crowd.vel[row, 0]), float(crowd.vel[row, 1])))

    # ------------------------------------------------------------------ repair
    def _place_row(self, row: int, pos: Vec3, orn: tuple[float, float, float, float]) -> None:
        """A body was just put at ``pos``/``orn``, still: set its row without reading pybullet."""
        self._crowd.place(row, pos, orn, self._crowd.specs[row].mass, self.config.gravity)

    def _limit_speeds(self) -> None:
        """Slow any body beyond the speed or spin limits (and count it): nothing runs away for ever."""
        self._counts["slowed_characters"] += slow_down(self._require_open(), self._crowd, self.config)

    def _recover(self, changes: list[StateChange]) -> None:
        """Stand up, on the stage, every character that is lost, non-finite or stuck on the ground."""
        crowd, t = self._crowd, self.t
        for row, lost in lost_characters(crowd, self.config, t):
            self._counts["recovered_characters"] += 1
            self._episodes.forget(crowd.names[row])
            near = None if lost else (float(crowd.pos[row, 0]), float(crowd.pos[row, 1]))
            spot = free_spot(crowd, row, self._stage, self._rng, near)
            before = stand_again(self._require_open(), crowd, row, spot, t, self.config.gravity)
            if before != WALK:
                changes.append(StateChange(t=t, character=crowd.names[row], before=STATES[before],
                                           after=STATES[WALK]))

    def _snapshot(self, events: tuple[ContactEvent, ...], changes: tuple[StateChange, ...],
                  dropped: float) -> WorldSnapshot:
        extra = self.quadrupeds.snapshots() if self.quadrupeds is not None else ()
        extra += self.articulated.snapshots()
        return WorldSnapshot(t=self.t, steps=self._ticks * self._n_sub, characters=snapshots(self._crowd) + extra,
                             contacts=events, changes=changes, dropped_time=dropped)
