"""Nothing people do makes the world explode: thousands of random, broken and absurd pushes; the small creature."""

from __future__ import annotations

import math
import tomllib
from pathlib import Path

import numpy as np

from interaction.types import BodyObservation, Contactor, Impulse
from sim.config import CharacterSpec, WorldConfig
from sim.mitake.body import figure_point
from sim.snapshot import CharacterState
from sim.world import World

ROOT = Path(__file__).resolve().parent.parent
S = CharacterState


def _critter() -> CharacterSpec:
    with (ROOT / "configs" / "characters" / "critter.toml").open("rb") as f:
        return CharacterSpec(**tomllib.load(f))


def test_thousands_of_random_pushes_never_make_it_explode() -> None:
    cfg = WorldConfig()  # rigid contactors: the hardest case
    rng = np.random.default_rng(1)
    walker, critter = CharacterSpec(), _critter()
    w = World(cfg, np.random.default_rng(2))
    names = [w.add_character(walker if i % 3 else critter, (-2.4 + 0.96 * i, 0.4 * (i % 2) - 0.2), 0.5 * i)
             for i in range(6)]
    pushes = garbage = 0
    worst_speed = 0.0
    with w:
        for tick in range(1000):  # 33 s
            for _ in range(3):  # 3000 strikes in all
                name = names[int(rng.integers(len(names)))]
                size = 10.0 ** rng.uniform(0.0, 7.0)  # 1 N … 10 MN
                direction = rng.normal(size=3)
                force = tuple(size * direction / np.linalg.norm(direction))
                at = tuple(rng.uniform(-1.0, 1.0, size=3))
                duration = float(10.0 ** rng.uniform(-3.0, 1.0))
                if rng.random() < 0.05:  # broken input
                    force, duration = (math.nan, 0.0, 1.0), -1.0
                    garbage += 1
                w.strike(name, force, duration, at)
                pushes += 1
            obs = None
            if tick % 5 == 0:  # people's hands appearing anywhere, even inside bodies, and pads
                hands = tuple(Contactor(person=int(k), part="hand", position=tuple(rng.uniform(-3.0, 3.0, 3) * (1, 0.4, 0.5) + (0, 0, 1)),
                                        velocity=tuple(rng.normal(size=3) * 5.0), radius=float(rng.uniform(0.02, 0.4)))
                              for k in range(3))
                pad = Impulse(position=(float(rng.uniform(-3, 3)), 0.0, 1.0), force=(float(rng.normal() * 1e4), 0.0, 0.0),
                              duration=0.1, source="pad")
                obs = BodyObservation(t=w.t, contactors=hands, impulses=(pad,))
            s = w.step(obs, cfg.control_dt)
            for ch in s.characters:
                assert all(math.isfinite(v) for v in (*ch.position, *ch.velocity, *ch.orientation,
                                                      *ch.angular_velocity)), (tick, ch)
                x, y, _ = ch.position
                assert cfg.x_min - 2.0 < x < cfg.x_max + 2.0 and cfg.y_min - 2.0 < y < cfg.y_max + 2.0
                worst_speed = max(worst_speed, math.hypot(*ch.velocity))
        assert pushes >= 3000
        counters = w.counters
        assert counters.rejected_inputs >= garbage and counters.clamped_inputs > 100
        assert counters.non_finite_controls == 0
        # pushes stack, but nobody is ever faster than the world's limit
        assert worst_speed <= cfg.max_character_speed + 1e-9
        for name in names:  # the controller kept its bounds through all of it
            view = w.character(name)
            assert view.peak_torque_ratio <= 1.0 + 1e-9 and view.peak_friction_ratio <= 1.0 + 1e-9
        for _ in range(round(25.0 / cfg.control_dt)):  # left alone, everyone is back on their feet
            s = w.step(None, cfg.control_dt)
        assert all(ch.state is S.WALK for ch in s.characters), [ch.state for ch in s.characters]


def test_the_small_creature_balances_falls_and_stands_up_on_its_own_scale() -> None:
    critter = _critter()
    assert (critter.height, critter.mass) == (0.8, 12.0)
    cfg = WorldConfig()
    with World(cfg, np.random.default_rng(0)) as w:
        name = w.add_character(critter, (0.0, 0.0), 0.0, intent="idle")
        snaps = [w.step(None, cfg.control_dt) for _ in range(30)]
        assert abs(snaps[-1].characters[0].position[2] - critter.com_height) < 0.01
        assert snaps[-1].characters[0].kind == "critter" and snaps[-1].characters[0].height == 0.8
        # a 3 N·s push at its chest staggers it at most; 30 N·s from behind fells it on its face
        w.strike(name, (30.0, 0.0, 0.0), 0.1, figure_point(critter, math.pi, 0.6))
        snaps = [w.step(None, cfg.control_dt) for _ in range(60)]
        assert not any(c.after is S.FALL for s in snaps for c in s.changes)
        w.strike(name, (300.0, 0.0, 0.0), 0.1, figure_point(critter, math.pi, 0.6))
        snaps = [w.step(None, cfg.control_dt) for _ in range(round(10.0 / cfg.control_dt))]
        after = [c.after for s in snaps for c in s.changes]
        assert after[after.index(S.FALL):][:5] == [S.FALL, S.BRAKE, S.LIE, S.STAND_UP, S.WALK]
        lying = next(s.characters[0] for s in snaps if s.characters[0].state is S.LIE)
        assert lying.face_up is False and lying.position[2] < 0.2
        assert snaps[-1].characters[0].intent in ("flee", "idle")  # after_fall_intent: flee (nobody near)
        view = w.character(name)
        assert view.peak_torque_ratio <= 1.0 + 1e-9 and view.peak_friction_ratio <= 1.0 + 1e-9
