"""Cost of the simulation per character per control tick: ``python -m sim.benchmark [N ...]``.

Characters wander on a stage sized for them (about 2.5 m² each); one person's hand sweeps through the
crowd so contact handling is part of the cost. Prints µs per character per control tick (wall time
of ``World.step`` with dt = control_dt, snapshots included). Short on purpose: this machine is shared.
"""

from __future__ import annotations

import math
import sys
import time

import numpy as np

from interaction.types import BodyObservation, Contactor
from sim.config import CharacterSpec, WorldConfig
from sim.world import World


def measure(n: int, seconds: float = 4.0, seed: int = 0) -> float:
    """µs of wall time per character per control tick for ``n`` wandering characters."""
    half_x = max(3.0, math.sqrt(2.5 * n))
    half_y = max(1.0, half_x / 2.0)
    cfg = WorldConfig(x_min=-half_x, x_max=half_x, y_min=-half_y, y_max=half_y)
    rng = np.random.default_rng(seed)
    with World(cfg, rng) as world:
        spec = CharacterSpec()
        cols = max(1, math.ceil(math.sqrt(n * 2)))
        for i in range(n):
            x = -half_x + 0.5 + (i % cols) * (2 * half_x - 1.0) / max(1, cols - 1)
            y = -half_y + 0.5 + (i // cols) * 1.2
            world.add_character(spec, (x, min(y, half_y - 0.5)), 0.0, intent="wander")
        ticks = round(seconds / cfg.control_dt)
        for _ in range(30):  # settle
            world.step(None, cfg.control_dt)
        start = time.perf_counter()
        for k in range(ticks):
            t = k * cfg.control_dt
            hand = Contactor(person=1, part="hand", position=(-half_x + 0.5 * t, 0.0, 1.1),
                             velocity=(0.5, 0.0, 0.0), radius=0.08)
            world.step(BodyObservation(t=t, contactors=(hand,)), cfg.control_dt)
        wall = time.perf_counter() - start
    return wall / ticks / n * 1e6


def main(argv: list[str]) -> int:
    sizes = [int(a) for a in argv] or [1, 10, 50]
    for n in sizes:
        print(f"N={n:4d}: {measure(n):8.1f} µs per character per control tick")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
