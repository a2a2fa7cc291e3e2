"""The simulated world: pybullet (DIRECT), the floor, the characters and the people's contactors.

``World.step(observation, dt)`` accumulates ``dt`` and runs whole control ticks. Each tick:
AI → state machine and controller per character → contactors placed once (kinematic, with the
people's velocity) → ``n_substeps`` physics steps of ``physics_dt``. The controller's force and torque
are held over the tick (zero-order hold) but *re-applied before every substep*: the world calls
``stepSimulation`` once per substep (no ``numSubSteps``), because pybullet clears external forces after
each call and because contact impulses are read per substep (``getContactPoints`` only reports the
last substep's manifold). Catch-up is capped at ``max_catchup_ticks``; the skipped time is reported.

Input: the contactors of the latest observation stand (moved along their velocity) for
``contactor_hold_s``; ``None`` means no new observation. Each pad ``Impulse`` is applied once, as a
force for its duration at the nearest character; an identical impulse reported again while the first
one is still acting is taken as the same report.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pybullet as p

from interaction.types import BodyObservation
from sim.ai import CharacterAI, Stage, separation_velocities
from sim.balance import BalanceDesign
from sim.body import GROUP_FLOOR, MASK_FLOOR, CharacterBody, Kinematics
from sim.character import UPRIGHT_STATES, Character
from sim.config import CharacterSpec, WorldConfig
from sim.contactors import ContactEpisodes, ContactorPool
from sim.frames import Vec3, yaw_quaternion
from sim.inputs import SafeContactor, SafeImpulse, clean_observation
from sim.snapshot import CharacterSnapshot, ContactEvent, StateChange, WorldSnapshot

PAD_PERSON = -1  # ContactEvent.person for force-pad impulses (they carry no person id)


@dataclass(frozen=True, slots=True)
class WorldCounters:
    """What the world had to repair since it was made (all should stay 0 in a healthy installation)."""

    rejected_inputs: int = 0  # contactors/impulses dropped: non-finite or absurd positions/forces
    clamped_inputs: int = 0  # values clamped: speeds, radii, forces, durations, bad dt
    non_finite_controls: int = 0  # controller outputs replaced by zero before reaching pybullet
    recovered_characters: int = 0  # characters put back upright: off stage, stuck, non-finite
    dropped_ticks: int = 0  # control ticks skipped by the catch-up cap


@dataclass(slots=True)
class _PadPush:
    character: str
    force: Vec3
    height: float  # above floor, where it hits
    remaining: float
    duration: float
    t_start: float


class World:
    def __init__(self, config: WorldConfig, rng: np.random.Generator) -> None:
        self.config = config
        self._rng = rng
        self._n_sub = config.n_substeps
        self._client: int | None = p.connect(p.DIRECT)
        c = self._client
        p.setGravity(0.0, 0.0, -config.gravity, physicsClientId=c)
        p.setPhysicsEngineParameter(fixedTimeStep=config.physics_dt, numSubSteps=0,
                                    deterministicOverlappingPairs=1, physicsClientId=c)
        self._floor: int = p.createMultiBody(0.0, p.createCollisionShape(p.GEOM_PLANE, physicsClientId=c),
                                             physicsClientId=c)
        p.changeDynamics(self._floor, -1, lateralFriction=1.0, restitution=0.0, physicsClientId=c)
        p.setCollisionFilterGroupMask(self._floor, -1, GROUP_FLOOR, MASK_FLOOR, physicsClientId=c)
        self._stage = Stage(config.x_min, config.x_max, config.y_min, config.y_max)
        self._pool = ContactorPool(c, config.contactor_friction, config.contactor_stiffness,
                                   config.contactor_damping)
        self._episodes = ContactEpisodes(config.contact_episode_gap_s)
        self._characters: dict[str, Character] = {}
        self._by_body: dict[int, str] = {}
        self._shapes: dict[CharacterSpec, int] = {}
        self._designs: dict[CharacterSpec, BalanceDesign] = {}
        self._ticks = 0
        self._pending = 0.0
        self._contactors: tuple[SafeContactor, ...] = ()
        self._contactors_t = 0.0
        self._seen: dict[SafeImpulse, float] = {}  # impulses applied, until when a repeat is the same one
        self._pads: list[_PadPush] = []
        self._counts = {f: 0 for f in WorldCounters.__dataclass_fields__}

    # ------------------------------------------------------------------ public surface
    @property
    def t(self) -> float:
        return self._ticks * self.config.control_dt

    @property
    def counters(self) -> WorldCounters:
        non_finite = sum(ch.non_finite_controls for ch in self._characters.values())
        return WorldCounters(**{**self._counts, "non_finite_controls": non_finite})

    def character(self, name: str) -> Character:
        """The live character (for inspection: bounds records, state machine); KeyError if unknown."""
        return self._characters[name]

    def add_character(self, spec: CharacterSpec, position: tuple[float, float], heading: float,
                      intent: str = "wander") -> str:
        """Stand a new character upright at stage ``position`` facing ``heading``; returns its unique name."""
        client = self._require_open()
        if not all(math.isfinite(v) for v in (*position, heading)) or len(position) != 2:
            raise ValueError(f"position: expected finite (x, y) and heading, got {position!r}, {heading!r}")
        name, k = spec.name, 1
        while name in self._characters:
            k += 1
            name = f"{spec.name}-{k}"
        if spec not in self._shapes:
            self._shapes[spec] = CharacterBody.create_shape(client, spec)
            self._designs[spec] = BalanceDesign.for_spec(spec, self.config.floor_friction, self.config.gravity,
                                                         self.config.control_dt)
        ai = CharacterAI(spec, intent, self._stage, self._rng, heading)
        body = CharacterBody(client, spec, (position[0], position[1], spec.com_height + 0.002),
                             yaw_quaternion(heading), self._shapes[spec])
        ch = Character(name, spec, body, self._designs[spec], ai, self.config.floor_friction,
                       self.config.gravity, self.t)
        self._characters[name] = ch
        self._by_body[body.body_id] = name
        return name

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
        for ch in self._characters.values():
            ch.contact_force = 0.0
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

    # ------------------------------------------------------------------ internals
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
        for imp in cleaned.impulses:
            if imp in self._seen:  # the same report again (a re-sent observation): apply it once
                continue
            self._seen[imp] = now + imp.duration + self.config.control_dt
            self._queue_pad(imp)

    def _queue_pad(self, imp: SafeImpulse) -> None:
        best, best_d = None, math.inf
        for ch in self._characters.values():
            pos = ch.kin.position
            d = math.hypot(pos[0] - imp.position[0], pos[1] - imp.position[1])
            if d < best_d:
                best, best_d = ch, d
        if best is None:
            return
        self._pads.append(_PadPush(best.name, imp.force, imp.position[2], imp.duration, imp.duration, self.t))

    def _contactors_now(self, t: float) -> tuple[SafeContactor, ...]:
        age = t - self._contactors_t
        if not self._contactors or age > self.config.contactor_hold_s + 1e-9:
            return ()
        if age <= 0.0:
            return self._contactors
        return tuple(
            SafeContactor(c.person, (c.position[0] + c.velocity[0] * age, c.position[1] + c.velocity[1] * age,
                                     c.position[2] + c.velocity[2] * age), c.velocity, c.radius, c.half_depth)
            for c in self._contactors
        )

    def _tick(self, events: list[ContactEvent], changes: list[StateChange]) -> None:
        client = self._require_open()
        cfg = self.config
        t0 = self.t
        chars = list(self._characters.values())
        contactors = self._contactors_now(t0)
        # AI and control
        sep = np.zeros((len(chars), 2))
        if chars:
            xy = np.array([[ch.kin.position[0], ch.kin.position[1]] for ch in chars])
            space = np.array([ch.spec.personal_space for ch in chars])
            speed = np.array([2.0 * ch.spec.walk_speed for ch in chars])  # personal space beats goals
            upright = np.array([ch.state in UPRIGHT_STATES for ch in chars])
            sep = separation_velocities(xy, space, speed) * upright[:, None]
        for i, ch in enumerate(chars):
            pos = ch.kin.position
            nearest = None
            best = math.inf
            for c in contactors:
                d = math.hypot(c.position[0] - pos[0], c.position[1] - pos[1])
                if d < best:
                    best, nearest = d, (c.position[0], c.position[1])
            goal = ch.ai.decide(t0, pos[0], pos[1], ch.state, (float(sep[i, 0]), float(sep[i, 1])), nearest)
            change = ch.think(t0, goal)
            if change is not None:
                changes.append(StateChange(t=t0, character=ch.name, before=change[0], after=change[1]))
        self._pool.place(contactors)
        pad_forces = self._pad_forces()
        dt = cfg.physics_dt
        for k in range(self._n_sub):
            for ch in chars:
                ch.apply()
            for body_id, force, at in pad_forces:
                p.applyExternalForce(body_id, -1, force, at, p.WORLD_FRAME, physicsClientId=client)
            p.stepSimulation(physicsClientId=client)
            if self._pool.active:
                t_sub = t0 + (k + 1) * dt
                for (name, person), f in self._pool.read_forces(self._by_body).items():
                    self._episodes.add(t_sub, name, person, f, dt)
                    ch = self._characters[name]
                    ch.contact_force = max(ch.contact_force, f)
        self._ticks += 1
        self._sense_all()
        self._recover(changes)
        t1 = self.t
        for ch in chars:
            ch.integrate(cfg.control_dt)
        for ev in self._episodes.close(t1, lambda n: self._characters[n].spec.push_threshold_ns):
            events.append(ev)
            self._notice(ev, contactors)
        self._finish_pads(events)

    def _pad_forces(self) -> list[tuple[int, Vec3, Vec3]]:
        cdt = self.config.control_dt
        out: list[tuple[int, Vec3, Vec3]] = []
        for pad in self._pads:
            ch = self._characters.get(pad.character)
            if ch is None:
                continue
            share = min(pad.remaining, cdt) / cdt  # so that the whole tick carries exactly F·duration
            f = (pad.force[0] * share, pad.force[1] * share, pad.force[2] * share)
            spec, pos, up = ch.spec, ch.kin.position, ch.frame.up
            along = max(-spec.com_height, min(spec.height - spec.com_height, pad.height - spec.com_height))
            at = (pos[0] + along * up[0], pos[1] + along * up[1], pos[2] + along * up[2])
            out.append((ch.body.body_id, f, at))
            ch.contact_force = max(ch.contact_force, math.sqrt(f[0] ** 2 + f[1] ** 2 + f[2] ** 2))
            pad.remaining -= cdt
        return out

    def _finish_pads(self, events: list[ContactEvent]) -> None:
        keep: list[_PadPush] = []
        for pad in self._pads:
            if pad.remaining > 1e-12:
                keep.append(pad)
                continue
            ch = self._characters.get(pad.character)
            if ch is None:
                continue
            size = math.sqrt(sum(v * v for v in pad.force))
            ev = ContactEvent(t_start=pad.t_start, t_end=pad.t_start + pad.duration, character=pad.character,
                              person=PAD_PERSON, impulse_ns=size * pad.duration, peak_force_n=size,
                              push=size * pad.duration >= ch.spec.push_threshold_ns)
            events.append(ev)
            if ev.push:
                ch.ai.notice_push(self.t, (pad.force[0], pad.force[1]))
        self._pads = keep

    def _notice(self, ev: ContactEvent, contactors: tuple[SafeContactor, ...]) -> None:
        if not ev.push:
            return
        ch = self._characters.get(ev.character)
        if ch is None:
            return
        pos = ch.kin.position
        mine = [c for c in contactors if c.person == ev.person]
        if mine:
            near = min(mine, key=lambda c: math.hypot(c.position[0] - pos[0], c.position[1] - pos[1]))
            ch.ai.notice_push(self.t, (pos[0] - near.position[0], pos[1] - near.position[1]))
        else:
            ch.ai.notice_push(self.t, (ch.kin.velocity[0], ch.kin.velocity[1]))

    def _sense_all(self) -> None:
        client = self._require_open()
        normal: dict[int, float] = {}
        for cp in p.getContactPoints(bodyA=self._floor, physicsClientId=client):
            other = cp[2] if cp[1] == self._floor else cp[1]
            normal[other] = normal.get(other, 0.0) + cp[9]
        for ch in self._characters.values():
            ch.sense(ch.body.read(), normal.get(ch.body.body_id, 0.0))

    def _recover(self, changes: list[StateChange]) -> None:
        cfg = self.config
        t = self.t
        for ch in self._characters.values():
            k: Kinematics = ch.kin
            x, y, z = k.position
            bad = not k.is_finite()
            off = not bad and (x < cfg.x_min - cfg.stage_escape_margin
                               or x > cfg.x_max + cfg.stage_escape_margin
                               or y < cfg.y_min - cfg.stage_escape_margin
                               or y > cfg.y_max + cfg.stage_escape_margin or z < -1.0 or z > 20.0)
            stuck = ch.not_upright_since is not None and t - ch.not_upright_since > cfg.stuck_timeout_s
            if not (bad or off or stuck):
                continue
            self._counts["recovered_characters"] += 1
            self._episodes.forget(ch.name)
            before = ch.state
            spot = self._free_spot(ch, None if (bad or off) else (x, y))
            heading = ch.frame.heading if math.isfinite(ch.frame.heading) else 0.0
            ch.put_upright((spot[0], spot[1], ch.spec.com_height + 0.002), heading, t)
            if before is not ch.state:
                changes.append(StateChange(t=t, character=ch.name, before=before, after=ch.state))

    def _free_spot(self, ch: Character, near: tuple[float, float] | None) -> tuple[float, float]:
        st = self._stage.shrunk(ch.spec.stage_margin)
        others = [o.kin.position for o in self._characters.values() if o is not ch]

        def free(px: float, py: float) -> bool:
            return all(math.hypot(px - o[0], py - o[1]) > 2.0 * ch.spec.half_width + 0.1 for o in others)

        if near is not None:
            px = min(max(near[0], st.x_min), st.x_max)
            py = min(max(near[1], st.y_min), st.y_max)
            if free(px, py):
                return px, py
        for _ in range(32):
            px, py = float(self._rng.uniform(st.x_min, st.x_max)), float(self._rng.uniform(st.y_min, st.y_max))
            if free(px, py):
                return px, py
        return 0.5 * (st.x_min + st.x_max), 0.5 * (st.y_min + st.y_max)

    def _snapshot(self, events: tuple[ContactEvent, ...], changes: tuple[StateChange, ...],
                  dropped: float) -> WorldSnapshot:
        chars: tuple[CharacterSnapshot, ...] = tuple(ch.snapshot() for ch in self._characters.values())
        return WorldSnapshot(t=self.t, steps=self._ticks * self._n_sub, characters=chars, contacts=events,
                             changes=changes, dropped_time=dropped)
