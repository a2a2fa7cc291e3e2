"""The articulated characters of one world as a ``sim.population.Population``.

Their control runs before every physics step (``before_substep``), finer while one recovers
(``substeps``, ``sim.articulated.recovery``); after a tick's substeps, state changes and travelled
distances (``after_tick``). People's contactors hit the links physically (the contactor pool's bodies
collide with every character link); their contact forces come back through ``bodies`` (body id → name)
like the Mitake characters', and a contact episode that is a push makes the character stagger.
Pads' impulses do not act on them; a strike pushes the link nearest its point.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

import numpy as np
import pybullet as p

from interaction.types import Impulse
from sim.articulated import balance as bal
from sim.articulated.bvh_body import bvh_character
from sim.articulated.character import ArticulatedCharacter
from sim.articulated.recovery import any_recovering, substeps_of
from sim.articulated.skeleton import ArticulatedSkeleton, deepmimic_humanoid
from sim.articulated.spec import ArticulatedSpec
from sim.motion.mocap import MotionClip
from sim.population import Footprint, Tick
from sim.snapshot import CharacterSnapshot, CharacterState, ContactEvent, StateChange

_DOWN = (CharacterState.FALL, CharacterState.LIE, CharacterState.BRAKE)


EDGE_M = 0.6  # nearer than this to the stage's edge, walking outward: it turns back toward the centre


class ArticulatedCharacters:
    def __init__(self, client: int, stage: tuple[float, float, float, float] = (-3.0, 3.0, -1.0, 1.0)) -> None:
        """``stage``: (x_min, x_max, y_min, y_max), the floor rectangle they keep to (by turning)."""
        self._client = client
        self._stage = stage
        self._skeletons: dict[str, ArticulatedSkeleton] = {}
        self._clips: dict[str, MotionClip] = {}  # the walk of a skeleton made from a BVH file
        self.characters: dict[str, ArticulatedCharacter] = {}
        self.bodies: dict[int, str] = {}  # pybullet body id → name (for the contactor pool's forces)
        self._states: dict[str, CharacterState] = {}
        self._travel: dict[str, list[float]] = {}  # d_front, d_side
        self._force: dict[str, float] = {}

    def __contains__(self, name: object) -> bool:
        return name in self.characters

    def __len__(self) -> int:
        return len(self.characters)

    def add(self, name: str, spec: Any, position: tuple[float, float], heading: float, t: float,
            **options: Any) -> None:
        """It walks its clip: it takes no options."""
        assert isinstance(spec, ArticulatedSpec)
        if spec.skeleton not in self._skeletons:
            if spec.skeleton == "deepmimic_humanoid":
                self._skeletons[spec.skeleton] = deepmimic_humanoid()
            else:  # a BVH file: its own body, walking its own motion
                self._skeletons[spec.skeleton], self._clips[spec.skeleton] = bvh_character(spec.skeleton)
        ch = ArticulatedCharacter(self._client, self._skeletons[spec.skeleton], spec, self._clips.get(spec.skeleton),
                                  position, heading)
        self.characters[name] = ch
        self.bodies[ch.body] = name
        self._states[name] = ch.state
        self._travel[name] = [0.0, 0.0]
        self._force[name] = 0.0

    def footprints(self) -> Iterable[Footprint]:
        return ()

    def reach(self, position: tuple[float, float, float]) -> float | None:
        return None

    def impulse(self, impulse: Impulse, t: float) -> None:
        raise ValueError("articulated characters take no pad impulses")

    def before_tick(self, tick: Tick) -> None:
        pass

    def counts(self) -> Mapping[str, int]:
        return {}

    def strike(self, name: str, force: tuple[float, float, float], duration: float,
               at: tuple[float, float, float], t: float) -> None:
        """Push the link nearest ``at`` — body frame from the centre of mass (x forward, y left, z up)."""
        ch = self.characters[name]
        com, _ = ch.com_state()
        _, orn = ch.root()
        h = bal.heading_of(orn)
        c, s = math.cos(h), math.sin(h)
        point = (float(com[0] + c * at[0] - s * at[1]), float(com[1] + s * at[0] + c * at[1]), float(com[2] + at[2]))
        ch.push(ch.nearest_link(point), force, duration)

    def before_substep(self, dt: float, recovering: bool = False) -> None:
        """Every character's control for a physics step of ``dt`` (``recovering``: finer than the world's step
        for a character's recovery, ``sim.articulated.recovery.any_recovering``)."""
        for name, ch in self.characters.items():
            ch.stepped_finely = recovering
            ch.step_control(dt)
            self._force[name] = max(self._force[name], ch.last_push_force_n)

    def after_substep(self, t: float, dt: float, forces: Mapping[tuple[str, int], float]) -> None:
        """People's contact forces (for the snapshot's contact_force_n); a touch starts a recovery (finer
        steps, ``sim.articulated.recovery``)."""
        for (name, _), force in forces.items():
            self._force[name] = max(self._force[name], force)
            if force > 0.0:
                self.characters[name].touched()

    def substeps(self) -> tuple[int, bool]:
        """Physics steps per world step the characters need now, and whether for a recovery (not only a
        hand-over) (``sim.articulated.recovery``)."""
        n = substeps_of(self.characters.values())
        return n, n > 1 and any_recovering(self.characters.values())

    def notice(self, tick: Tick, ended: Sequence[ContactEvent]) -> None:
        """Contact episodes that ended: a push makes the character stagger."""
        for event in ended:
            if event.push:
                self.characters[event.character].staggered()

    def push_threshold(self, name: str) -> float:
        return self.characters[name].spec.push_threshold_ns

    def after_tick(self, tick: Tick) -> None:
        t, control_dt, changes = tick.t_end, tick.dt, tick.changes
        for name, ch in self.characters.items():
            before, after = self._states[name], ch.state
            if before != after:
                changes.append(StateChange(t=t, character=name, before=before, after=after))
                self._states[name] = after
            com, v = ch.com_state()
            _, orn = ch.root()
            h = bal.heading_of(orn)
            self._keep_on_stage(ch, float(com[0]), float(com[1]), h)
            self._travel[name][0] += (v[0] * math.cos(h) + v[1] * math.sin(h)) * control_dt
            self._travel[name][1] += (v[0] * math.sin(h) - v[1] * math.cos(h)) * control_dt

    def _keep_on_stage(self, ch: ArticulatedCharacter, x: float, y: float, heading: float) -> None:
        x0, x1, y0, y1 = self._stage
        out_x = (x > x1 - EDGE_M and math.cos(heading) > 0) or (x < x0 + EDGE_M and math.cos(heading) < 0)
        out_y = (y > y1 - EDGE_M and math.sin(heading) > 0) or (y < y0 + EDGE_M and math.sin(heading) < 0)
        if out_x or out_y:
            ch.steer(math.atan2((y0 + y1) / 2 - y, (x0 + x1) / 2 - x))
        elif ch.heading_goal is not None and abs(math.remainder(ch.heading_goal - heading, math.tau)) < 0.2:
            ch.steer(None)  # turned: walk on

    def start_step(self) -> None:
        for name in self._force:
            self._force[name] = 0.0

    def snapshots(self) -> tuple[CharacterSnapshot, ...]:
        out = []
        for name, ch in self.characters.items():
            com, v = ch.com_state()
            _, orn = ch.root()
            _, w = p.getBaseVelocity(ch.body, physicsClientId=self._client)
            state = ch.state
            lying = state in (CharacterState.LIE, CharacterState.STAND_UP) or state == CharacterState.FALL
            out.append(CharacterSnapshot(
                name=name,
                position=(float(com[0]), float(com[1]), float(com[2])),
                orientation=(float(orn[0]), float(orn[1]), float(orn[2]), float(orn[3])),
                velocity=(float(v[0]), float(v[1]), float(v[2])),
                angular_velocity=(float(w[0]), float(w[1]), float(w[2])),
                heading=bal.heading_of(orn),
                tilt=bal.tilt_components(orn),
                d_front=self._travel[name][0],
                d_side=self._travel[name][1],
                state=state,
                behaviour="stand_up" if state == CharacterState.STAND_UP else ("fall" if state in _DOWN else "walk"),
                intent="walk",
                face_up=bal.face_up(orn) if lying and state != CharacterState.STAND_UP else None,
                contact_force_n=self._force[name],
                height=ch.spec.height,
                kind=ch.spec.name,
                balance_load=10.0 if state in _DOWN else float(np.clip(ch.load, 0.0, 10.0)),
                links=ch.link_poses(),
            ))
        return tuple(out)
