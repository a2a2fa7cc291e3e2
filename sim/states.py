"""The control state machine (Mitake et al. 2009, Figure 3), pure of pybullet.

    WALK ──load ≥ stagger──▶ STAGGER ──load < recover for recover_hold_s──▶ WALK
      │                         │
      └──────load ≥ fall────────┴──▶ FALL ──tilt ≥ ground_tilt──▶ BRAKE ──still for still_hold_s──▶ LIE
                                                                    ▲                                │
                                                                    └──────── moved again ───────────┤
    WALK ◀──upright and balanced── STAND_UP ◀──────────── lie_duration_s ───────────────────────────┘
                                      │ knocked over (tilt far above its reference) or too slow
                                      └──▶ FALL

"load" is ``BalanceDesign.balance_load``: whether the *bounded* controller can still bring the body
back (capture-point criterion), not a fixed angle.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from sim.config import CharacterSpec
from sim.snapshot import CharacterState

FALL_TIMEOUT_S = 3.0  # a fall that never reaches the ground (leaning on someone) brakes anyway
STAND_UP_ABORT_RAD = math.radians(30.0)  # tilt this far above the stand-up reference: knocked over
STAND_UP_GRACE_S = 0.3
STAND_UP_SLACK_S = 3.0  # stand-up may take this much longer than getup_duration_s before giving up


@dataclass(frozen=True, slots=True)
class BalanceReading:
    """What the state machine looks at, once per control tick."""

    load: float  # balance load, 0 upright and still, ≥ 1 beyond the bounded controller
    tilt: float  # radians between the body axis and vertical
    speed: float  # m/s of the centre of mass
    spin: float  # rad/s
    face_up: bool  # the body's face axis points up
    stand_up_error: float = 0.0  # radians of tilt above the stand-up reference (STAND_UP only)


class StateMachine:
    def __init__(self, spec: CharacterSpec, t: float = 0.0) -> None:
        self._spec = spec
        self.state = CharacterState.WALK
        self.entered = t
        self.face_up: bool | None = None
        self._since: float | None = None  # start of the calm/still stretch being timed

    def force(self, state: CharacterState, t: float) -> None:
        """Put the machine in ``state`` (recovery after a reset), without reporting a change."""
        self.state, self.entered, self._since = state, t, None
        if state not in (CharacterState.LIE, CharacterState.STAND_UP):
            self.face_up = None

    def _held(self, condition: bool, t: float, hold: float) -> bool:
        if not condition:
            self._since = None
            return False
        if self._since is None:
            self._since = t
        return t - self._since >= hold - 1e-9

    def update(self, t: float, r: BalanceReading) -> tuple[CharacterState, CharacterState] | None:
        """Advance one tick; returns (before, after) when the state changed."""
        s, spec = self.state, self._spec
        S = CharacterState
        nxt = s
        in_state = t - self.entered
        if s in (S.WALK, S.STAGGER):
            if r.load >= spec.fall_ratio:
                nxt = S.FALL
            elif s is S.WALK and r.load >= spec.stagger_ratio:
                nxt = S.STAGGER
            elif s is S.STAGGER and self._held(r.load < spec.recover_ratio, t, spec.recover_hold_s):
                nxt = S.WALK
        elif s is S.FALL:
            if r.tilt >= math.radians(spec.ground_tilt_deg) or in_state >= FALL_TIMEOUT_S:
                nxt = S.BRAKE
        elif s is S.BRAKE:
            still = r.speed < spec.still_speed and r.spin < spec.still_rate
            if self._held(still, t, spec.still_hold_s):
                nxt = S.LIE
        elif s is S.LIE:
            if r.speed > 3.0 * spec.still_speed or r.spin > 3.0 * spec.still_rate:
                nxt = S.BRAKE
            elif in_state >= spec.lie_duration_s:
                nxt = S.STAND_UP
        elif s is S.STAND_UP:
            if r.tilt < math.radians(spec.upright_tilt_deg) and r.load < spec.stagger_ratio:
                nxt = S.WALK
            elif (in_state > STAND_UP_GRACE_S and r.stand_up_error > STAND_UP_ABORT_RAD) or \
                    in_state > spec.getup_duration_s + STAND_UP_SLACK_S:
                nxt = S.FALL
        if nxt is s:
            return None
        self.state, self.entered, self._since = nxt, t, None
        if nxt is S.LIE:
            self.face_up = r.face_up
        elif nxt is not S.STAND_UP:
            self.face_up = None
        return s, nxt
