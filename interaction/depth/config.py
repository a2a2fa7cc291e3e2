"""The depth observer's settings: how it finds people, their hands and feet. Distances in stage metres.

Read from an ``[observers.<name>]`` table of ``type = "depth"``; every value is checked on
construction (a :class:`ValueError` names the key and what was expected).
"""

from __future__ import annotations

from dataclasses import dataclass


def _check(name: str, value: object, lo: float, hi: float) -> None:
    if not isinstance(value, int | float) or isinstance(value, bool) or not lo <= value <= hi:
        raise ValueError(f"{name}: expected a number {lo}..{hi}, got {value!r}")


@dataclass(frozen=True)
class DepthObserverConfig:
    """How the depth observer finds people. Distances in stage metres."""

    work_width: int = 160  # depth pixels across the sampled image (the frame's width when smaller)
    stage_x: tuple[float, ...] = (-3.5, 3.5)  # the stage volume: x range
    stage_y: tuple[float, ...] = (-2.0, 2.2)  # y range
    max_height_m: float = 2.4  # top of the volume
    floor_clearance_m: float = 0.03  # points nearer the floor than this are floor
    body_clearance_m: float = 0.15  # only points higher than this find people (the rest: their feet)
    cell_m: float = 0.05  # the top-down grid's cell size
    min_height_m: float = 0.9  # a person reaches at least this high
    min_points: int = 60  # … and holds at least this many points (at the work size)
    max_people: int = 8
    side_by_side_m: float = 0.4  # a blob whose two halves' middles are this far apart is two people
    match_distance_m: float = 0.6  # a person moves less than this between frames
    track_memory_frames: int = 30
    hidden_memory_s: float = 1.0  # a person unseen this long, near someone seen, is still counted (hidden)
    hidden_near_m: float = 0.7
    learn_frames: int = 5  # first frames: what is on the stage then is furniture
    hand_band_low: float = 0.5  # hands are looked for above this fraction of the person's height
    min_arm_reach: float = 0.27  # … this far from the shoulders at least (a fraction of the height)
    min_hand_reach_m: float = 0.2  # a hand is this far out from the torso's axis (nearer: not told from it)
    alpha: float = 0.6  # the velocity filter's gains
    beta: float = 0.4
    limb_gate_m: float = 0.3  # a hand (foot) moves less than this from where its track predicts it
    limb_steady_m: float = 0.1  # … and its velocity is trusted after it stays this close for:
    limb_steady_frames: int = 3
    limb_consistent_deg: float = 20.0  # … and claimed when its last two steps turn less than this
    limb_min_speed: float = 0.5  # … and are faster than this (m/s)
    limb_confirm_frames: int = 2  # a hand is reported once found in this many frames in a row
    foot_confirm_frames: int = 1  # … a foot in this many (its first frame's error is no larger: no confirming)
    limb_memory_frames: int = 3  # a track not found for longer is forgotten
    shoe_model: bool = True  # feet corrected by the shipped shoe model (interaction.depth.shoe_model); false: rules only

    def __post_init__(self) -> None:
        if not isinstance(self.work_width, int) or not 16 <= self.work_width <= 4096:
            raise ValueError(f"work_width: expected a whole number 16..4096, got {self.work_width!r}")
        for name in ("stage_x", "stage_y"):
            r = getattr(self, name)
            if not (isinstance(r, tuple) and len(r) == 2 and all(isinstance(v, int | float) for v in r) and r[0] < r[1]):
                raise ValueError(f"{name}: expected [low, high] with low < high, got {r!r}")
        _check("max_height_m", self.max_height_m, 0.5, 5.0)
        _check("floor_clearance_m", self.floor_clearance_m, 0.0, 0.5)
        _check("body_clearance_m", self.body_clearance_m, 0.0, 1.0)
        _check("cell_m", self.cell_m, 0.01, 0.5)
        _check("min_height_m", self.min_height_m, 0.1, 3.0)
        for name, hi in (("min_points", 100000), ("max_people", 64), ("track_memory_frames", 1000), ("learn_frames", 1000),
                         ("limb_steady_frames", 100), ("limb_confirm_frames", 100), ("foot_confirm_frames", 100),
                         ("limb_memory_frames", 1000)):
            v = getattr(self, name)
            if not isinstance(v, int) or isinstance(v, bool) or not 0 <= v <= hi:
                raise ValueError(f"{name}: expected a whole number 0..{hi}, got {v!r}")
        _check("side_by_side_m", self.side_by_side_m, 0.2, 3.0)
        _check("match_distance_m", self.match_distance_m, 0.01, 10.0)
        _check("hidden_memory_s", self.hidden_memory_s, 0.0, 60.0)
        _check("hidden_near_m", self.hidden_near_m, 0.0, 10.0)
        _check("hand_band_low", self.hand_band_low, 0.0, 0.9)
        _check("min_arm_reach", self.min_arm_reach, 0.0, 1.0)
        _check("min_hand_reach_m", self.min_hand_reach_m, 0.0, 1.0)
        _check("alpha", self.alpha, 0.01, 1.0)
        _check("beta", self.beta, 0.0, 2.0)
        _check("limb_gate_m", self.limb_gate_m, 0.01, 5.0)
        _check("limb_steady_m", self.limb_steady_m, 0.0, 5.0)
        _check("limb_consistent_deg", self.limb_consistent_deg, 0.0, 180.0)
        _check("limb_min_speed", self.limb_min_speed, 0.0, 10.0)
        if not isinstance(self.shoe_model, bool):
            raise ValueError(f"shoe_model: expected true or false, got {self.shoe_model!r}")
