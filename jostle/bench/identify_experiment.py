"""The observer experiment of ``jostle bench identify`` (Mitake et al. 2009 §6.2) done by machine.

Forces (Figure 9 of the paper): a walking character is pushed once, for ``PUSH_S``, at the point of its
figure at azimuth θpos ∈ {−45°, 0°, 45°} from its front (positive toward its left) and height
h ∈ {0, 0.5, 1.0} m above the floor, in the direction pointing at its vertical axis turned by
θdir ∈ {−45°, 0°, 45°}, weak or strong. Every cell of that grid is repeated with a random walking speed,
heading and walking phase (time of the push). The pushes act on the figure's outline
(``sim.mitake.body.figure_point``): at h = 0 that is the feet, spread like the drawn legs.

What is recorded is only what a viewer sees, sampled at 30 Hz from ``BEFORE_S`` before the push to
``AFTER_S`` after, in the heading frame at the push: ``body_view`` gives the rigid body's position and
orientation; :mod:`jostle.bench.identify` passes the drawn figure's joint positions instead. The
viewer's eye adds Gaussian noise to every position (m) and angle (rad).

The observer: windowed channel means, standardised, and a shrunk linear discriminant fitted on the
joint label (θpos, θdir, h, strength) of half the repetitions and tested on the other half; each
factor's answer is read off the joint one, |θdir+θpos| scored as in the paper's Table 1. ``add_arguments``
holds the flags of ``jostle bench identify``; ``run`` scores the body view alone. In full: docs/benches.md.
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from sim.snapshot import CharacterSnapshot

if TYPE_CHECKING:
    from sim.config import CharacterSpec

Array = NDArray[np.float64]

THETA_POS = (-45, 0, 45)  # degrees
THETA_DIR = (-45, 0, 45)  # degrees
HEIGHTS = (0.0, 0.5, 1.0)  # m above the floor
PUSH_S = 0.1  # how long each push acts
BEFORE_S = 0.3  # the viewer sees this much walking before the push
AFTER_S = 2.5  # and this much after it
RATE_HZ = 30.0
WINDOW = 3  # samples averaged per feature (0.1 s)
SPEEDS = (0.4, 0.55, 0.7, 0.85, 1.0)  # m/s, walking speeds drawn from
CELL_M = 16.0  # each character walks alone in a square this wide
PAPER = {"theta_pos": 0.73, "theta_dir_plus_pos": 0.78, "h": 0.54, "magnitude": 0.88}


@dataclass(frozen=True)
class Trial:
    theta_pos: int
    theta_dir: int
    h: float
    strong: bool
    speed: float
    heading: float  # radians, stage frame, at the push
    origin: tuple[float, float, float]  # centre of mass at the push
    track: tuple[CharacterSnapshot, ...]  # one per sample, BEFORE_S before to AFTER_S after the push

    @property
    def label(self) -> tuple[int, int, float, bool]:
        return self.theta_pos, self.theta_dir, self.h, self.strong


# A view: what the viewer sees of one trial — (positions (T, P, 3) metres, angles (T, A) radians) in the
# heading frame at the push.
View = Callable[[Trial], tuple[Array, Array]]


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--repetitions", type=int, default=12,
                        help="repetitions of each of the 54 grid cells (default 12; half train, half test)")
    parser.add_argument("--weak", type=float, default=15.0, help="weak impulse, N·s (default 15)")
    parser.add_argument("--strong", type=float, default=45.0, help="strong impulse, N·s (default 45)")
    parser.add_argument("--noise-cm", type=float, default=2.0, help="viewer's position noise, cm (default 2)")
    parser.add_argument("--noise-deg", type=float, default=2.0, help="viewer's angle noise, degrees (default 2)")
    parser.add_argument("--character", type=str, default="",
                        help="a character TOML (keys of sim.config.CharacterSpec); default: the built-in walker")
    parser.add_argument("--seed", type=int, default=0)


def load_spec(path: str) -> CharacterSpec:
    """A character spec from a TOML file of ``CharacterSpec`` keys (one clear line when it is wrong)."""
    from dataclasses import fields

    from sensors.untrusted import UntrustedInput, load_toml, one_line
    from sensors.untrusted.limits import CHARACTER_SPEC
    from sim.config import CharacterSpec

    if not path:
        return CharacterSpec()
    doc = load_toml(path, CHARACTER_SPEC, "character spec")
    known = {f.name for f in fields(CharacterSpec)}
    unknown = sorted(set(doc) - known)
    if unknown:
        raise UntrustedInput(path, f"{one_line(unknown[0], 60)}: unknown key; see sim.config.CharacterSpec")
    try:
        return CharacterSpec(**doc)
    except (TypeError, ValueError) as e:
        raise UntrustedInput(path, str(e)) from None


def run(args: argparse.Namespace) -> dict[str, Any]:
    try:
        trials = run_trials(args.repetitions, args.weak, args.strong, args.seed, load_spec(args.character))
    except ValueError as e:  # a bad flag or character file: one line, not a traceback
        raise SystemExit(f"jostle bench identify: {e}") from None
    return score(trials, body_view, args.noise_cm / 100.0, math.radians(args.noise_deg), args.seed,
                 weak=args.weak, strong=args.strong, view_name="body position and orientation")


def _grid() -> list[tuple[int, int, float, bool]]:
    return [(tp, td, h, s) for tp in THETA_POS for td in THETA_DIR for h in HEIGHTS for s in (False, True)]


def run_trials(repetitions: int, weak: float, strong: float, seed: int = 0,
               spec: CharacterSpec | None = None) -> list[Trial]:
    """Every grid cell ``repetitions`` times; one world per repetition, one character per cell."""
    from sim.config import CharacterSpec

    if repetitions < 4 or not 0 < weak < strong:
        raise ValueError("bench identify: expected --repetitions ≥ 4 and 0 < --weak < --strong")
    rng = np.random.default_rng(seed)
    base = spec or CharacterSpec()
    trials: list[Trial] = []
    for rep in range(repetitions):
        trials += _one_world(_grid(), weak, strong, rng, seed * 1000 + rep, base)
    return trials


def _one_world(cells: list[tuple[int, int, float, bool]], weak: float, strong: float, rng: np.random.Generator,
               world_seed: int, base: CharacterSpec) -> list[Trial]:
    import dataclasses

    from sim.config import WorldConfig
    from sim.mitake.body import figure_point
    from sim.world import World

    cols = math.ceil(math.sqrt(len(cells)))
    half = 0.5 * CELL_M * cols
    cfg = WorldConfig(x_min=-half, x_max=half, y_min=-half, y_max=half, control_dt=1.0 / RATE_HZ)
    world = World(cfg, np.random.default_rng(world_seed))
    specs = {v: dataclasses.replace(base, walk_speed=v) for v in SPEEDS}
    plan = []
    try:
        for k, cell in enumerate(cells):
            centre = (-half + CELL_M * (k % cols + 0.5), -half + CELL_M * (k // cols + 0.5))
            speed = float(rng.choice(SPEEDS))
            heading = float(rng.uniform(-math.pi, math.pi))
            t_push = round(float(rng.uniform(1.5, 2.5)) * RATE_HZ) / RATE_HZ  # the walking phase
            f = (math.cos(heading), math.sin(heading))
            start = (centre[0] - 3.0 * f[0], centre[1] - 3.0 * f[1])
            far = (centre[0] + 60.0 * f[0], centre[1] + 60.0 * f[1])  # straight on, well past the window
            name = world.add_character(specs[speed], start, heading, intent="follow", waypoints=(far, start))
            plan.append((name, cell, speed, t_push))
        before = round(BEFORE_S * RATE_HZ)
        after = round(AFTER_S * RATE_HZ)
        pushes: dict[int, list[int]] = {round(t * RATE_HZ): [] for *_, t in plan}  # tick → rows pushed then
        for row, (*_, t) in enumerate(plan):
            pushes[round(t * RATE_HZ)].append(row)
        end_tick = max(pushes) + after
        tracks: list[list[CharacterSnapshot]] = [[] for _ in plan]
        frames_at_push: dict[int, tuple[float, tuple[float, float, float]]] = {}
        for tick in range(end_tick + 1):
            snap = world.snapshot() if tick == 0 else world.step(None, cfg.control_dt)
            for row in pushes.get(tick, []):
                name, (tp, td, h, strong_push), _, _ = plan[row]
                ch = snap.characters[row]
                frames_at_push[row] = (ch.heading, ch.position)
                a = ch.heading + math.radians(tp + td) + math.pi  # toward the axis, turned by θdir
                size = (strong if strong_push else weak) / PUSH_S
                world.strike(name, (size * math.cos(a), size * math.sin(a), 0.0), PUSH_S,
                             figure_point(world.character(name).spec, math.radians(tp), h))
            for row, (*_, t) in enumerate(plan):
                push_tick = round(t * RATE_HZ)
                if push_tick - before <= tick <= push_tick + after:
                    tracks[row].append(snap.characters[row])
    finally:
        world.close()
    out = []
    for row, (_, cell, speed, _) in enumerate(plan):
        heading, origin = frames_at_push[row]
        out.append(Trial(*cell, speed=speed, heading=heading, origin=origin, track=tuple(tracks[row])))
    return out


def body_view(trial: Trial) -> tuple[Array, Array]:
    """The rigid body as drawn: centre-of-mass position (T, 1, 3) and (yaw, θx, θz) (T, 3), heading frame
    at the push (x forward, y left, z up; yaw from the heading at the push)."""
    c, s = math.cos(trial.heading), math.sin(trial.heading)
    p = np.array([ch.position for ch in trial.track]) - np.asarray(trial.origin)
    pos = np.stack([c * p[:, 0] + s * p[:, 1], -s * p[:, 0] + c * p[:, 1], p[:, 2]], axis=1)[:, None, :]
    yaw = np.unwrap(np.array([ch.heading for ch in trial.track]) - trial.heading)
    yaw = (yaw + math.pi) % (2 * math.pi) - math.pi
    tilts = np.array([ch.tilt for ch in trial.track])
    return pos, np.column_stack([yaw, tilts])


def features(trials: Sequence[Trial], view: View, noise_m: float, noise_rad: float,
             rng: np.random.Generator) -> Array:
    """The observer's features: every channel, noised per sample, averaged over windows of WINDOW samples."""
    rows = []
    for trial in trials:
        pos, ang = view(trial)
        pos = pos + rng.normal(0.0, noise_m, size=pos.shape) if noise_m > 0 else pos
        ang = ang + rng.normal(0.0, noise_rad, size=ang.shape) if noise_rad > 0 else ang
        x = np.concatenate([pos.reshape(pos.shape[0], -1), ang], axis=1)
        n = x.shape[0] // WINDOW * WINDOW
        rows.append(x[:n].reshape(-1, WINDOW, x.shape[1]).mean(axis=1).ravel())
    return np.array(rows)


class Discriminant:
    """Nearest class mean under the pooled within-class covariance S, shrunk toward its diagonal:
    Σ = (1 − shrink)·S + shrink·diag(S) (standardised features).

    Features can outnumber the trials (joint positions × windows), so Σ⁻¹ is never formed: with
    S = RᵀR/(n − k) for the n × p within-class residuals R, the Woodbury identity needs only an
    n × n solve.
    """

    def __init__(self, shrink: float) -> None:
        if not 0.0 < shrink <= 1.0:
            raise ValueError(f"shrink: expected 0 < shrink ≤ 1, got {shrink}")
        self.shrink = shrink

    def fit(self, x: Array, y: NDArray[np.int64]) -> Discriminant:
        self.mu_x = x.mean(axis=0)
        self.sd_x = x.std(axis=0) + 1e-12
        z = (x - self.mu_x) / self.sd_x
        self.classes = np.unique(y)
        means = np.array([z[y == c].mean(axis=0) for c in self.classes])
        resid = z - means[np.searchsorted(self.classes, y)]
        dof = max(1, len(z) - len(self.classes))
        diag = np.sum(resid * resid, axis=0) / dof
        d_inv = 1.0 / (self.shrink * np.where(diag > 1e-12, diag, 1.0))
        u = resid.T * math.sqrt((1.0 - self.shrink) / dof)  # (p, n)
        du = d_inv[:, None] * u
        inner = np.eye(u.shape[1]) + u.T @ du
        dm = d_inv[:, None] * means.T  # (p, k)
        self.weights = dm - du @ np.linalg.solve(inner, u.T @ dm)  # Σ⁻¹ Mᵀ
        self.bias = -0.5 * np.sum(means.T * self.weights, axis=0)
        return self

    def predict(self, x: Array) -> NDArray[np.int64]:
        z = (x - self.mu_x) / self.sd_x
        out: NDArray[np.int64] = self.classes[np.argmax(z @ self.weights + self.bias, axis=1)]
        return out


def _fit(x: Array, y: NDArray[np.int64], groups: NDArray[np.int64]) -> Discriminant:
    """Pick the shrinkage by leave-one-group-out cross-validation on the training set, then fit all."""
    best, best_acc = 0.5, -1.0
    folds = np.unique(groups)
    for shrink in (0.05, 0.2, 0.5, 0.8, 0.95):
        hits = 0
        for g in folds:
            test = groups == g
            hits += int(np.sum(Discriminant(shrink).fit(x[~test], y[~test]).predict(x[test]) == y[test]))
        if hits / len(y) > best_acc:
            best, best_acc = shrink, hits / len(y)
    return Discriminant(best).fit(x, y)


def accuracies(trials: Sequence[Trial], view: View, noise_m: float, noise_rad: float,
               seed: int) -> dict[str, float]:
    """Train on the even repetitions, test on the odd ones; accuracy of each factor (Table 1)."""
    cells = _grid()
    y = np.array([cells.index(t.label) for t in trials])
    rep = np.arange(len(trials)) // len(cells)
    x = features(trials, view, noise_m, noise_rad, np.random.default_rng(seed + 17))
    train = rep % 2 == 0
    model = _fit(x[train], y[train], rep[train])
    guess = [cells[i] for i in model.predict(x[~train])]
    truth = [cells[i] for i in y[~train]]

    def rate(key: Callable[[tuple[int, int, float, bool]], object]) -> float:
        return round(float(np.mean([key(g) == key(t) for g, t in zip(guess, truth, strict=True)])), 4)

    return {
        "theta_pos": rate(lambda c: c[0]),
        "theta_dir_plus_pos": rate(lambda c: abs(c[0] + c[1])),
        "h": rate(lambda c: c[2]),
        "magnitude": rate(lambda c: c[3]),
    }


def cached(view: View) -> View:
    """``view`` computed once per trial (the noisy and the exact scoring look at the same samples)."""
    seen: dict[int, tuple[Array, Array]] = {}

    def once(trial: Trial) -> tuple[Array, Array]:
        key = id(trial)
        if key not in seen:
            seen[key] = view(trial)
        return seen[key]

    return once


def score(trials: Sequence[Trial], view: View, noise_m: float, noise_rad: float, seed: int, *, weak: float,
          strong: float, view_name: str) -> dict[str, Any]:
    """The benchmark's figures: per-factor accuracy with the viewer's noise, and without (``exact``)."""
    view = cached(view)
    noisy = accuracies(trials, view, noise_m, noise_rad, seed)
    exact = accuracies(trials, view, 0.0, 0.0, seed)
    falls = sum(1 for t in trials if any(ch.state.value == "fall" for ch in t.track))
    return {
        **noisy,
        "exact": exact,
        "trials": len(trials),
        "weak_impulse_ns": weak,
        "strong_impulse_ns": strong,
        "noise_cm": round(noise_m * 100.0, 3),
        "noise_deg": round(math.degrees(noise_rad), 3),
        "view": view_name,
        "falls": falls,
        "paper_observers": PAPER,
    }
