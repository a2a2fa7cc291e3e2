"""The split of a control tick into physics substeps (dm_control's control step vs physics step)."""

from __future__ import annotations

import math

_RELATIVE_TOLERANCE = 1e-9


def compute_n_substeps(control_dt: float, physics_dt: float) -> int:
    """How many physics steps of ``physics_dt`` make one control tick of ``control_dt``.

    Raises ``ValueError`` unless both are finite and > 0 and ``control_dt`` is a whole multiple of
    ``physics_dt`` (within a relative tolerance of 1e-9).
    """
    if not (math.isfinite(physics_dt) and physics_dt > 0.0):
        raise ValueError(f"physics_dt: expected a number > 0, got {physics_dt!r}")
    if not (math.isfinite(control_dt) and control_dt > 0.0):
        raise ValueError(f"control_dt: expected a number > 0, got {control_dt!r}")
    ratio = control_dt / physics_dt
    n = round(ratio)
    if n < 1 or abs(ratio - n) > _RELATIVE_TOLERANCE * ratio:
        raise ValueError(
            f"control_dt: expected a whole multiple of physics_dt={physics_dt!r}, "
            f"got {control_dt!r} (ratio {ratio:.12g})"
        )
    return n
