"""Forces that act on one body for a while: force-pad impulses and scripted strikes.

A push holds a world-frame force for its duration at a point fixed in the body (so it turns with the
body). It is applied before every physics substep (pybullet clears external forces after each
``stepSimulation``), scaled in its last control tick so that the whole push carries exactly
force × duration. When it ends it becomes a ``ContactEvent`` (person ``PAD_PERSON``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from interaction.types import Vec3
from sim.mitake.crowd import Crowd
from sim.snapshot import PAD_PERSON, ContactEvent


@dataclass(slots=True)
class Push:
    row: int
    force: Vec3  # world frame, N
    offset: Vec3  # point of application, body frame, from the centre of mass
    remaining: float
    duration: float
    t_start: float

    @property
    def impulse_ns(self) -> float:
        return math.sqrt(sum(v * v for v in self.force)) * self.duration


def axis_offset(crowd: Crowd, row: int, height: float) -> Vec3:
    """The body-frame point on the body's axis at ``height`` above its foot (clamped to the body)."""
    c = crowd.cols
    along = min(max(height - c.com_height[row], -c.com_height[row]), c.height[row] - c.com_height[row])
    return (0.0, 0.0, float(along))


def tick_forces(pushes: list[Push], crowd: Crowd, control_dt: float, max_force: float) -> list[tuple[int, Vec3, Vec3]]:
    """(body, force, world point) of every push for this control tick; counts the tick off each push.

    Pushes acting on one body at once share ``max_force``: their sizes are scaled down together when
    they add up to more.
    """
    out: list[tuple[int, Vec3, Vec3]] = []
    if not pushes:
        return out
    rotation = crowd.frames.rotation()
    total: dict[int, float] = {}
    for push in pushes:
        total[push.row] = total.get(push.row, 0.0) + math.sqrt(sum(v * v for v in push.force))
    for push in pushes:
        share = min(push.remaining, control_dt) / control_dt  # the whole push carries exactly F·duration
        share *= min(1.0, max_force / total[push.row]) if total[push.row] > 0.0 else 1.0
        f = (push.force[0] * share, push.force[1] * share, push.force[2] * share)
        at = crowd.pos[push.row] + rotation[push.row] @ np.asarray(push.offset)
        out.append((crowd.bodies[push.row], f, (float(at[0]), float(at[1]), float(at[2]))))
        crowd.contact_force[push.row] = max(crowd.contact_force[push.row], math.sqrt(sum(v * v for v in f)))
        push.remaining -= control_dt
    return out


def finished(pushes: list[Push], crowd: Crowd) -> tuple[list[Push], list[tuple[Push, ContactEvent]]]:
    """Split ``pushes`` into those still acting and the events of those that ended."""
    keep: list[Push] = []
    done: list[tuple[Push, ContactEvent]] = []
    for push in pushes:
        if push.remaining > 1e-12:
            keep.append(push)
            continue
        size = math.sqrt(sum(v * v for v in push.force))
        threshold = float(crowd.cols.push_threshold_ns[push.row])
        done.append((push, ContactEvent(
            t_start=push.t_start, t_end=push.t_start + push.duration, character=crowd.names[push.row],
            person=PAD_PERSON, impulse_ns=size * push.duration, peak_force_n=size,
            push=size * push.duration >= threshold)))
    return keep, done
