"""``jostle bench sim``: N characters with controller and AI against N bare bodies, in the same run.

The jostle world runs N wandering characters (AI, state machine, balance controller, contacts) the
way the app drives it: ``World.step`` once per 30 Hz frame, snapshots included. The baselines are
pybullet clients set up identically (``sim.physics.open_client``), each holding N bodies of the same
shape, mass, inertia and friction, upright where the characters start, stepped with nothing but
``stepSimulation``: in one they glide at walking speed, all the same way, in the other they stand
still. The three alternate in blocks of simulated time so that a shared machine slows them alike.

Figures: ``bare_step_us`` / ``jostle_step_us`` (wall µs per physics step of the whole world),
``overhead_ratio`` (``_still``: against still bodies), ``realtime_factor`` (simulated s per wall s),
``jostle_physics_us`` / ``jostle_control_us``. In full: docs/benches.md; why two baselines:
docs/notes/bench-timing.md.
"""

from __future__ import annotations

import argparse
import math
import time
from typing import Any

FRAME_HZ = 30.0  # the app steps the world once per rendered frame


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--characters", type=int, default=1000, help="how many characters (default 1000)")
    parser.add_argument("--seconds", type=float, default=4.0, help="simulated seconds of each side (default 4)")
    parser.add_argument("--physics-hz", type=float, default=240.0, help="physics rate (default 240)")
    parser.add_argument("--control-hz", type=float, default=0.0,
                        help="controller and AI rate (default: sim.config.WorldConfig's)")
    parser.add_argument("--people", type=int, default=0,
                        help="people walking through the crowd, pushing with hands, feet and body (default 0)")
    parser.add_argument("--seed", type=int, default=0)


def run(args: argparse.Namespace) -> dict[str, Any]:
    try:
        return measure(args.characters, args.seconds, args.physics_hz, args.control_hz or None, args.seed,
                       args.people)
    except ValueError as e:  # a bad flag: one line, not a traceback
        raise SystemExit(f"jostle bench sim: {e}") from None


def _layout(n: int) -> tuple[float, float, list[tuple[float, float]]]:
    """A stage of about 2.5 m² per character and a grid of start spots on it."""
    half_x = max(3.0, math.sqrt(2.5 * n))
    half_y = max(1.0, half_x / 2.0)
    cols = max(1, math.ceil(math.sqrt(n * half_x / half_y)))
    rows = max(1, math.ceil(n / cols))
    spots = []
    for i in range(n):
        x = -half_x + (i % cols + 0.5) * 2.0 * half_x / cols
        y = -half_y + (i // cols + 0.5) * 2.0 * half_y / rows
        spots.append((x, y))
    return half_x, half_y, spots


def people_at(people: int, t: float, half_x: float, half_y: float) -> tuple[Any, ...]:
    """``people`` walkers crossing the stage at 1.2 m/s, each a body capsule, two swinging hands and two
    feet (the contactors an observer reports), spread over its depth; stage metres, seconds."""
    from interaction.types import Contactor

    out = []
    for k in range(people):
        vx = 1.2 if k % 2 == 0 else -1.2
        x = ((k * 1.7 + vx * t + half_x) % (2.0 * half_x)) - half_x
        y = -half_y + (k + 0.5) * 2.0 * half_y / people
        swing, rate = 0.35 * math.sin(2.0 * math.pi * t + k), 0.7 * math.pi * math.cos(2.0 * math.pi * t + k)
        out.append(Contactor(person=k, part="torso", position=(x, y, 1.1), velocity=(vx, 0.0, 0.0),
                             radius=0.18, half_depth=0.1))
        for side, sign in (("left", 1.0), ("right", -1.0)):
            out.append(Contactor(person=k, part=f"{side}_hand", position=(x + sign * swing, y + 0.25 * sign, 1.0),
                                 velocity=(vx + sign * rate, 0.0, 0.0), radius=0.06))
            out.append(Contactor(person=k, part=f"{side}_foot", position=(x - sign * swing, y + 0.12 * sign, 0.08),
                                 velocity=(vx - sign * rate, 0.0, 0.0), radius=0.07))
    return tuple(out)


def measure(n: int, seconds: float, physics_hz: float = 240.0, control_hz: float | None = None,
            seed: int = 0, people: int = 0) -> dict[str, Any]:
    import numpy as np
    import pybullet as p

    from interaction.types import BodyObservation
    from sim.config import CharacterSpec, WorldConfig
    from sim.mitake.body import create_body, create_shape, write_velocities
    from sim.physics import open_client
    from sim.world import World

    if n < 1 or not seconds > 0 or not physics_hz > 0 or people < 0:
        raise ValueError("bench sim: expected --characters ≥ 1, --seconds > 0, --physics-hz > 0, --people ≥ 0")
    half_x, half_y, spots = _layout(n)
    base = WorldConfig()
    control_dt = 1.0 / control_hz if control_hz else base.control_dt
    cfg = WorldConfig(physics_dt=1.0 / physics_hz, control_dt=control_dt, x_min=-half_x, x_max=half_x,
                      y_min=-half_y, y_max=half_y, max_catchup_ticks=1000)
    spec = CharacterSpec()
    rng = np.random.default_rng(seed)
    world = World(cfg, rng)
    still, _ = open_client(cfg)
    gliding, _ = open_client(cfg)
    try:
        headings = rng.uniform(-math.pi, math.pi, size=n)
        for (x, y), h in zip(spots, headings.tolist(), strict=True):
            world.add_character(spec, (x, y), h, intent="wander")
        bare: dict[int, list[int]] = {}
        for client in (still, gliding):
            shape = create_shape(client, spec)
            bare[client] = [create_body(client, spec, shape, (x, y, spec.com_height + 0.002), (0.0, 0.0, 0.0, 1.0))
                            for x, y in spots]
        # all in one direction at walking speed: they move like walkers and never meet
        write_velocities(gliding, bare[gliding], np.tile([spec.walk_speed, 0.0, 0.0], (n, 1)), np.zeros((n, 3)))
        frame_dt = 1.0 / FRAME_HZ
        steps_per_frame = round(frame_dt / cfg.physics_dt)
        step_sim = p.stepSimulation
        for _ in range(3):  # settle all three (contacts made, caches warm)
            world.step(None, frame_dt)
            for client in bare:
                for _ in range(steps_per_frame):
                    step_sim(client)
        frames = max(1, round(seconds / frame_dt))
        block = max(1, round(0.5 / frame_dt))
        wall = {still: 0.0, gliding: 0.0}
        wall_jostle = 0.0
        physics_before = world.physics_wall_s
        states: dict[str, int] = {}
        contacts, peak = 0, 0.0
        done = 0
        while done < frames:
            k = min(block, frames - done)
            for client in bare:
                start = time.perf_counter()
                for _ in range(k * steps_per_frame):
                    step_sim(client)
                wall[client] += time.perf_counter() - start
            seen = [BodyObservation(t=t, contactors=people_at(people, t, half_x, half_y), people=people) if people
                    else None for t in (world.t + i * frame_dt for i in range(k))]  # made outside the timing
            start = time.perf_counter()
            for obs in seen:
                snap = world.step(obs, frame_dt)
                contacts += len(snap.contacts)
                peak = max([peak, *(c.peak_force_n for c in snap.contacts)])
                for ch in snap.changes:
                    states[ch.after.value] = states.get(ch.after.value, 0) + 1
            wall_jostle += time.perf_counter() - start
            done += k
        steps = frames * steps_per_frame
        sim_seconds = steps * cfg.physics_dt

        def upright(client: int) -> int:
            return sum(1 for b in bare[client]
                       if p.getBasePositionAndOrientation(b, physicsClientId=client)[0][2] > 0.9 * spec.com_height)

        up_now = sum(1 for c in snap.characters if c.state.value in ("walk", "stagger"))
        bare_us = wall[gliding] / steps * 1e6
        still_us = wall[still] / steps * 1e6
        jostle_us = wall_jostle / steps * 1e6
        physics_us = (world.physics_wall_s - physics_before) / steps * 1e6
        return {
            "characters": n,
            "people": people,
            "contacts": contacts,
            "max_contact_force_n": round(peak, 2),
            "physics_hz": physics_hz,
            "control_hz": round(1.0 / cfg.control_dt, 6),
            "sim_seconds": round(sim_seconds, 6),
            "wall_seconds": round(wall_jostle, 4),
            "realtime_factor": round(sim_seconds / wall_jostle, 4),
            "bare_step_us": round(bare_us, 2),
            "jostle_step_us": round(jostle_us, 2),
            "overhead_ratio": round(jostle_us / bare_us, 4),
            # the same figures against bodies that stand still (cheaper for pybullet than moving ones)
            "bare_still_step_us": round(still_us, 2),
            "overhead_ratio_still": round(jostle_us / still_us, 4),
            "bare_realtime_factor": round(sim_seconds / wall[gliding], 4),
            # where the jostle step goes: pybullet stepping its walking characters, and everything else
            # (reads, controller, AI, state machine, writes, snapshots), per physics step
            "jostle_physics_us": round(physics_us, 2),
            "jostle_control_us": round(jostle_us - physics_us, 2),
            "bare_upright": upright(gliding),
            "bare_still_upright": upright(still),
            "characters_upright_at_end": up_now,
            "state_changes": states,
            "recovered_characters": world.counters.recovered_characters,
        }
    finally:
        world.close()
        p.disconnect(physicsClientId=still)
        p.disconnect(physicsClientId=gliding)
