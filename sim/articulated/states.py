"""The articulated character's state machine as one pure function (see ``sim.articulated.character``)."""

from __future__ import annotations

from dataclasses import dataclass

from sim.articulated.spec import ArticulatedSpec
from sim.snapshot import CharacterState

S = CharacterState
GETUP_SETTLE_S = 0.3  # s after the get-up clip's last frame before judging whether it stands


@dataclass(frozen=True)
class Readings:
    """What the state machine looks at, once per control update."""

    tilt_deg: float  # pelvis from upright
    root_z: float  # root joint height, m
    load: float  # balance load (0 balanced, 1 at the edge of recovery)
    pushed: bool  # a push is acting now
    speed: float  # root speed, m/s
    state_s: float  # seconds in the current state
    clip_s: float  # clip time
    clip_duration: float


def next_state(state: CharacterState, r: Readings, spec: ArticulatedSpec, hold_s: float,
               dt: float) -> tuple[CharacterState, float]:
    """(the state to be in, the new hold timer) — ``hold_s`` counts how long a leaving condition has held."""
    s = spec
    if state in (S.WALK, S.STAGGER):
        if r.tilt_deg >= s.fall_tilt_deg or r.root_z < s.fall_height or (s.fall_load > 0 and r.load >= s.fall_load):
            return S.FALL, 0.0
        if state == S.WALK:
            return (S.STAGGER, 0.0) if r.load >= s.stagger_load else (state, 0.0)
        hold_s = hold_s + dt if r.load < s.recover_load and not r.pushed else 0.0
        return (S.WALK, 0.0) if hold_s >= s.recover_hold_s else (state, hold_s)
    if state == S.FALL:
        still = r.speed < s.still_speed and r.root_z < s.fall_height + 0.1
        hold_s = hold_s + dt if still else 0.0
        return (S.LIE, 0.0) if hold_s >= s.still_hold_s else (state, hold_s)
    if state == S.LIE:
        return (S.STAND_UP, 0.0) if r.state_s >= s.lie_duration_s else (state, 0.0)
    if state == S.STAND_UP:
        if r.clip_s >= r.clip_duration + GETUP_SETTLE_S:
            if r.tilt_deg <= s.upright_tilt_deg and r.root_z >= s.upright_height:
                return S.WALK, 0.0
            if r.clip_s >= r.clip_duration + s.getup_grace_s or r.tilt_deg >= s.fall_tilt_deg:
                return S.FALL, 0.0
        return (S.FALL, 0.0) if r.state_s >= s.getup_timeout_s else (state, 0.0)
    return state, hold_s
