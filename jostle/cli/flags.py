"""Numbers on the command line, checked once after parsing and before any command runs.

Every float flag (``--duration``, ``--fps``, ``--range LO HI`` …) must be finite (argparse's
``float`` takes ``nan``, ``inf`` and ``1e999``); the flags in :data:`RANGES` must also lie in their
range. A refusal is one ``UntrustedInput`` naming the flag (``--duration: expected a number from …``).
"""

from __future__ import annotations

import argparse

from sensors.untrusted import UntrustedInput, finite, whole
from sensors.untrusted.limits import DURATION_MAX_S, SEED_MAX

# dest → (low, high, whether the low end is excluded): seconds > 0 (0 would "reach" it at once)
RANGES: dict[str, tuple[float, float, bool]] = {
    "duration": (0.0, DURATION_MAX_S, True),
    "seconds": (0.0, DURATION_MAX_S, True),
    "empty": (0.0, DURATION_MAX_S, False),
    "fps": (0.0, 1000.0, True),
    "depth_fps": (0.0, 1000.0, True),
}
SEEDS = ("seed",)  # whole numbers 0 … 2^32 − 1


def flag_name(dest: str) -> str:
    """The flag as the user typed it: ``depth_fps`` → ``--depth-fps``."""
    return "--" + dest.replace("_", "-")


def check_flags(args: argparse.Namespace) -> None:
    """Refuse (``UntrustedInput``, one line naming the flag) a non-finite float flag, a flag of
    :data:`RANGES` out of its range, or a seed outside 0 … 2^32 − 1."""
    for dest, value in vars(args).items():
        values = value if isinstance(value, list | tuple) else [value]
        for v in values:
            if isinstance(v, float):
                finite(v, flag_name(dest))
        if dest in SEEDS and value is not None:
            whole(value, flag_name(dest), 0, SEED_MAX)
        if dest in RANGES and isinstance(value, int | float) and not isinstance(value, bool):
            lo, hi, open_low = RANGES[dest]
            finite(value, flag_name(dest), lo, hi)
            if open_low and value <= lo:
                raise UntrustedInput(flag_name(dest), f"expected a number > {lo:g}, got {value!r}")
