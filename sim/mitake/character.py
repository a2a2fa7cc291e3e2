"""Reading characters out of the crowd: frozen snapshots for render/, and a live view for inspection."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from sim.config import INTENTS, CharacterSpec
from sim.mitake.ai import BEHAVIOUR_STAND_UP, BEHAVIOUR_WALK
from sim.mitake.crowd import STAND_UP, STATES, Crowd
from sim.snapshot import CharacterSnapshot, CharacterState


@dataclass(frozen=True, slots=True)
class CharacterView:
    """One character's controller record at the last control tick (for tests, benches and tools).

    ``peak_*_ratio`` are the largest |applied| / bound seen since the character was made (≤ 1 when
    the bounds held); ``tau_*`` the last tick's balance torques, ``friction`` the legs' horizontal
    force and ``friction_limit`` its bound min(μ f_N, leg_force_max).
    """

    name: str
    spec: CharacterSpec
    state: CharacterState
    load: float
    normal_force: float
    tau_front: float
    tau_side: float
    tau_yaw: float
    friction: float
    friction_limit: float
    peak_torque_ratio: float
    peak_friction_ratio: float
    non_finite_controls: int


def view(crowd: Crowd, row: int) -> CharacterView:
    return CharacterView(
        name=crowd.names[row], spec=crowd.specs[row], state=STATES[int(crowd.state[row])],
        load=float(crowd.load[row]), normal_force=float(crowd.normal[row]),
        tau_front=float(crowd.tau_front[row]), tau_side=float(crowd.tau_side[row]),
        tau_yaw=float(crowd.tau_yaw[row]), friction=float(crowd.friction[row]),
        friction_limit=float(crowd.friction_limit[row]),
        peak_torque_ratio=float(crowd.peak_torque_ratio[row]),
        peak_friction_ratio=float(crowd.peak_friction_ratio[row]),
        non_finite_controls=int(crowd.non_finite[row]),
    )


def _rows(a: NDArray[np.float64]) -> list[tuple[float, ...]]:
    return list(zip(*a.T.tolist(), strict=True))


def snapshots(crowd: Crowd) -> tuple[CharacterSnapshot, ...]:
    """Every character as a frozen ``CharacterSnapshot`` (columns converted once, rows built by ``map``)."""
    n = len(crowd)
    if not n:
        return ()
    f = crowd.frames
    states = crowd.state.tolist()
    return tuple(map(
        CharacterSnapshot,
        crowd.names, _rows(crowd.pos), _rows(crowd.quat), _rows(crowd.vel), _rows(crowd.ang),
        f.heading.tolist(), zip(f.tilt_x.tolist(), f.tilt_z.tolist(), strict=True),
        crowd.d_front.tolist(), crowd.d_side.tolist(), [STATES[s] for s in states],
        [BEHAVIOUR_STAND_UP if s == STAND_UP else BEHAVIOUR_WALK for s in states],
        [INTENTS[i] for i in crowd.intent.tolist()],
        [None if v < 0 else bool(v) for v in crowd.face_up.tolist()],
        crowd.contact_force.tolist(), [s.height for s in crowd.specs], [s.name for s in crowd.specs],
        np.minimum(crowd.load, 10.0).tolist(), [() for _ in range(n)], [s.com_height for s in crowd.specs],
    ))
