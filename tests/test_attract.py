"""Attract mode: the pure state machine on time sequences, the world's switch of every character's
intent, and the whole loop on the demo recording (nobody at first, then the walking person)."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest

from jostle.app import App, RunOptions
from jostle.attract import Attract, Phase, Transition
from jostle.config import JostleConfig, load_config
from sim.config import CharacterSpec, WorldConfig
from sim.world import World

ROOT = Path(__file__).resolve().parent.parent
FPS = 30.0


def _feed(attract: Attract, people: list[int], t0: float = 0.0) -> list[tuple[float, Phase, Transition | None]]:
    out = []
    for k, n in enumerate(people):
        t = t0 + k / FPS
        change = attract.update(t, n)
        out.append((t, attract.phase, change))
    return out


def test_nobody_for_after_s_starts_attract_mode_and_a_person_ends_it_at_once() -> None:
    a = Attract(after_s=2.0)
    trace = _feed(a, [0] * 90 + [1] + [0] * 10)
    changes = [(t, c) for t, _, c in trace if c is not None]
    assert len(changes) == 2
    (t1, c1), (t2, c2) = changes
    assert (c1.before, c1.after) == (Phase.PLAY, Phase.ATTRACT)
    assert t1 == pytest.approx(2.0)  # frame 60: exactly after_s after the first update
    assert all(p is Phase.PLAY for t, p, _ in trace if t < 2.0 - 1e-9)
    assert (c2.before, c2.after) == (Phase.ATTRACT, Phase.PLAY)
    assert t2 == pytest.approx(90 / FPS)  # the very frame the person appears
    assert trace[-1][1] is Phase.PLAY  # then 10 empty frames (0.33 s < after_s): still play
    assert a.idle_for(trace[-1][0]) == pytest.approx(10 / FPS)


def test_every_sighting_restarts_the_wait() -> None:
    a = Attract(after_s=1.0)
    people = ([0] * 25 + [2]) * 4 + [0] * 40  # someone every 26 frames (< 30 = 1 s): never attract
    trace = _feed(a, people)
    first = next(t for t, p, _ in trace if p is Phase.ATTRACT)
    last_seen = (26 * 4 - 1) / FPS
    assert first == pytest.approx(last_seen + 1.0)
    assert all(p is Phase.PLAY for t, p, _ in trace if t < last_seen + 1.0 - 1e-9)


def test_zero_turns_it_off_and_bad_arguments_are_refused() -> None:
    a = Attract(after_s=0.0)
    assert not a.enabled
    assert all(p is Phase.PLAY and c is None for _, p, c in _feed(a, [0] * 600))
    assert a.strength(100.0) == 0.0
    for kwargs, field in (({"after_s": -1.0}, "after_s"), ({"after_s": math.nan}, "after_s"),
                          ({"after_s": 1.0, "period_s": 0.0}, "period_s"),
                          ({"after_s": 1.0, "fade_s": -0.1}, "fade_s")):
        with pytest.raises(ValueError, match=f"^{field}: "):
            Attract(**kwargs)


def test_time_running_backwards_or_nan_changes_nothing() -> None:
    a = Attract(after_s=1.0)
    a.update(5.0, 0)
    assert a.update(math.nan, 0) is None
    assert a.update(3.0, 0) is None  # taken as 5.0
    change = a.update(6.0, 0)
    assert change is not None and change.after is Phase.ATTRACT and change.t == 6.0


def test_the_call_to_action_fades_in_then_pulses_within_bounds() -> None:
    a = Attract(after_s=1.0, period_s=2.0, fade_s=0.5)
    _feed(a, [0] * 31)
    assert a.phase is Phase.ATTRACT
    start = a.since
    assert a.strength(start) == 0.0  # faded in from nothing
    ts = start + np.arange(0.0, 8.0, 1 / FPS)
    s = np.array([a.strength(float(t)) for t in ts])
    settled = s[ts - start >= 0.5]
    assert settled.min() == pytest.approx(0.35, abs=0.01) and settled.max() == pytest.approx(1.0, abs=0.01)
    assert np.all(np.diff(s[ts - start <= 0.5]) > 0)  # rises during the fade
    late = ts - start >= 0.5
    period = np.array([a.strength(float(t) + 2.0) for t in ts[late]])
    assert np.allclose(period, settled)  # periodic
    a.update(ts[-1] + 0.1, 1)
    assert a.strength(ts[-1] + 0.2) == 0.0


# ------------------------------------------------------------------ the world's intent switch


def test_intent_all_makes_idle_characters_wander_and_gives_their_own_back() -> None:
    world = World(WorldConfig(), np.random.default_rng(3))
    names = [world.add_character(CharacterSpec(), (x, 0.0), 0.0, intent="idle") for x in (-1.5, 1.5)]
    try:
        def travelled(seconds: float) -> float:
            start = {c.name: np.array(c.position[:2]) for c in world.snapshot().characters}
            for _ in range(int(seconds * 60)):
                snap = world.step(None, 1 / 60)
            return max(float(np.linalg.norm(np.array(c.position[:2]) - start[c.name])) for c in snap.characters)

        idle = travelled(3.0)
        world.step(None, 0.0, intent_all="wander")
        wandered = travelled(4.0)
        world.step(None, 0.0, intent_all=None)
        travelled(1.5)  # slow down and stop
        back = travelled(3.0)
        assert idle < 0.1 and back < 0.1
        assert wandered > 1.0
        assert [world.crowd.base_intent[world.crowd.index[n]] for n in names] == [0, 0]  # idle again
        with pytest.raises(ValueError, match="^intent: "):
            world.step(None, 0.0, intent_all="dance")
    finally:
        world.close()


# ------------------------------------------------------------------ the whole loop


def _demo(**kiosk: object) -> JostleConfig:
    cfg = load_config(ROOT / "configs" / "demo.toml")
    return dataclasses.replace(cfg, render=dataclasses.replace(cfg.render, width=320, height=180),
                               kiosk=dataclasses.replace(cfg.kiosk, **kiosk))  # type: ignore[arg-type]


def _run(cfg: JostleConfig, seconds: float) -> list[tuple[float, int, Phase, np.ndarray]]:
    app = App(cfg, RunOptions(out_dir=None, seed=7, duration_s=seconds, video=False, progress=False))
    frames = []

    def on_frame(snap, obs, image) -> None:  # type: ignore[no-untyped-def]
        frames.append((snap.t, obs.people, app.operations.attract.phase, image.copy()))

    app.on_frame = on_frame
    app.run()
    return frames


def test_the_loop_attracts_while_the_stage_is_empty_and_plays_when_the_person_walks_in() -> None:
    frames = _run(_demo(attract_after_s=0.5, attract_modes=("headless",)), 3.0)
    first_person = next(i for i, f in enumerate(frames) if f[1] > 0)
    attract = [i for i, f in enumerate(frames) if f[2] is Phase.ATTRACT]
    assert attract, "the recording's empty stage lasts longer than attract_after_s"
    assert frames[attract[0]][0] == pytest.approx(frames[0][0] + 0.5, abs=1.5 / FPS)
    assert attract == list(range(attract[0], first_person))  # attract until the person, then play
    assert frames[first_person][2] is Phase.PLAY
    # the call to action is drawn (lower third) in attract mode only: compare with a run without text
    plain = _run(_demo(attract_after_s=0.5, attract_modes=("headless",), call_to_action=""), 3.0)
    band = slice(int(180 * 0.65), int(180 * 0.9))
    diff = [float(np.abs(f[3][band].astype(int) - p[3][band].astype(int)).mean()) for f, p in zip(frames, plain, strict=True)]
    settled = [d for i, d in enumerate(diff) if i in attract and frames[i][0] - frames[attract[0]][0] > 0.5]
    # white letters over the floor; 0 where none are drawn. The text pulses: its faintest frames here differ by
    # 2.05 with OpenCV 5.0's putText and 1.83 with 5.1's (the same scene; the letters' edges are drawn apart)
    assert settled and min(settled) > 1.0
    assert all(d == 0.0 for i, d in enumerate(diff) if i < attract[0])  # identical before attract
    assert all(d == 0.0 for i, d in enumerate(diff) if i >= first_person)  # gone once the person is there


def test_attract_mode_is_off_in_modes_not_listed() -> None:
    frames = _run(_demo(attract_after_s=0.5), 1.2)  # attract_modes = ("kiosk",) by default; this is headless
    assert all(f[2] is Phase.PLAY for f in frames)
