"""``jostle keyframes check``: every problem of a keyframe set at once, each naming its file and animation.

The loader (``render.keyframes.set_file``) stops at the first error; this reads the same files tolerantly
and reports all it finds, then — when the set loads — what only a loaded set shows:

- ``unknown-joint``: a pose rotates a joint the skeleton does not have;
- ``out-of-range``: a coordinate outside Q (Mitake eq. 10: Θx ∈ [−π, π], Θz ∈ [−π/2, π/2],
  Dx, Dz ∈ [0, 1); an added dimension's [min, max]);
- ``duplicate``: two keys of an animation at one coordinate, a pose or animation name used twice,
  two animations on the same line of Q;
- ``gap``: neighbouring keys (or parallel animations) too far apart, a behaviour with no pose
  upright, or the default behaviour not reaching lying (|Θ| = π/2) in some direction;
- ``invalid``: anything else the loader refuses (bad TOML, unknown pose, animations that meet with
  different poses, …).

Errors make the set unusable; warnings (gaps) are for the animator to judge.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, Literal

import numpy as np

from render.keyframes.interp import STANDARD_AXES
from render.keyframes.set_file import KeyframeError
from sensors.untrusted import InputLimits, MissingInput, UntrustedInput, load_toml
from sensors.untrusted.limits import KEYFRAME_SET, POSE_FILE
from sim.motion.mocap import JOINTS

THETA_GAP = 0.8  # radians between neighbouring keys along Θ
CYCLE_GAP = 0.35  # of a cycle between neighbouring keys along Dx/Dz
RANGES = {"theta_x": (-math.pi, math.pi), "theta_z": (-math.pi / 2, math.pi / 2), "dx": (0.0, 1.0), "dz": (0.0, 1.0)}


@dataclass(frozen=True)
class Problem:
    severity: Literal["error", "warning"]
    kind: str
    file: str
    animation: str | None
    key: int | None
    message: str

    def line(self) -> str:
        where = f"animation '{self.animation}'" if self.animation else ""
        if self.key is not None:
            where += f" key {self.key}"
        return f"{self.severity}: {self.file}: {where + ': ' if where else ''}{self.message} [{self.kind}]"


@dataclass
class CheckReport:
    set: str
    animations: int = 0
    keyframes: int = 0
    poses: int = 0
    behaviours: list[str] = field(default_factory=list)
    problems: list[Problem] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        return not any(p.severity == "error" for p in self.problems)

    def as_dict(self) -> dict[str, Any]:
        d = asdict(self)
        d["ok"] = self.ok
        return d


def _read(path: Path, report: CheckReport, limits: InputLimits = KEYFRAME_SET) -> dict[str, Any] | None:
    """The TOML file within ``limits`` (``sensors.untrusted``), or None with the problem reported."""
    try:
        return load_toml(path, limits, "keyframe file")
    except MissingInput:
        report.problems.append(Problem("error", "invalid", str(path), None, None, "no such file"))
    except UntrustedInput as e:
        report.problems.append(Problem("error", "invalid", str(path), None, None, e.problem))
    return None


def check_set(manifest: str | Path) -> CheckReport:
    """Check a keyframe set; never raises for a bad set (the problems are in the report)."""
    path = Path(manifest)
    if path.is_dir():
        path = path / "keyframes.toml"
    report = CheckReport(str(path))
    doc = _read(path, report)
    if doc is None:
        return report
    mfile = str(path)

    def problem(severity: Literal["error", "warning"], kind: str, file: str, anim: str | None, key: int | None,
                msg: str) -> None:
        report.problems.append(Problem(severity, kind, file, anim, key, msg))

    # ---- poses
    pose_file: dict[str, str] = {}
    files = doc.get("poses", [])
    for rel in files if isinstance(files, list) else []:
        ppath = path.parent / str(rel)
        pdoc = _read(ppath, report, POSE_FILE)
        for name, table in (pdoc or {}).items():
            if name in pose_file:
                problem("error", "duplicate", str(ppath), None, None, f"pose '{name}' defined twice (also in {pose_file[name]})")
                continue
            pose_file[name] = str(ppath)
            joints = table.get("joints", {}) if isinstance(table, dict) else {}
            for joint in joints if isinstance(joints, dict) else []:
                if joint not in JOINTS:
                    problem("error", "unknown-joint", str(ppath), None, None,
                            f"pose '{name}': joints.{joint}: unknown joint; expected one of {', '.join(JOINTS)}")
    report.poses = len(pose_file)

    # ---- animations
    dims = doc.get("dimensions", {})
    ranges = dict(RANGES)
    if isinstance(dims, dict):
        for name, d in dims.items():
            if isinstance(d, dict):
                ranges[name] = (0.0, 1.0) if d.get("periodic") else (d.get("min", -math.inf), d.get("max", math.inf))
    anims = doc.get("animation", [])
    anims = anims if isinstance(anims, list) else []
    report.animations = len(anims)
    names: set[str] = set()
    lines: dict[tuple[Any, ...], list[tuple[str, float, float]]] = {}
    families = {a.get("family", a.get("name")) for a in anims if isinstance(a, dict)}
    for i, a in enumerate(anims):
        if not isinstance(a, dict):
            continue
        name = str(a.get("name", f"#{i}"))
        if name in names:
            problem("error", "duplicate", mfile, name, None, "animation name used twice")
        names.add(name)
        axis = a.get("axis")
        at: dict[str, Any] = a["at"] if isinstance(a.get("at"), dict) else {}
        for coord, v in at.items():
            lo, hi = ranges.get(coord, (-math.inf, math.inf))
            if isinstance(v, int | float) and not (lo <= v <= hi):
                problem("error", "out-of-range", mfile, name, None, f"at.{coord} = {v}: outside [{lo:.4g}, {hi:.4g}]")
        keys: list[Any] = a["keys"] if isinstance(a.get("keys"), list) else []
        report.keyframes += len(keys)
        seen: dict[float, int] = {}
        lo, hi = ranges.get(str(axis), (-math.inf, math.inf))
        periodic = axis in ("dx", "dz") or (isinstance(dims, dict) and bool(dims.get(axis, {}).get("periodic")))
        for k, key in enumerate(keys):
            if not isinstance(key, dict):
                continue
            x = key.get("at")
            if isinstance(x, int | float):
                if not (lo <= x < hi if periodic else lo <= x <= hi):
                    problem("error", "out-of-range", mfile, name, k, f"at = {x}: {axis} must be in [{lo:.4g}, {hi:.4g}{')' if periodic else ']'}")
                if x in seen:
                    problem("error", "duplicate", mfile, name, k, f"at = {x}: key {seen[x]} is there too")
                seen[float(x)] = k
            if "pose" in key and key["pose"] not in pose_file:
                problem("error", "invalid", mfile, name, k, f"no pose named {key['pose']!r} in the pose files")
            if "family" in key and key["family"] not in families:
                problem("error", "invalid", mfile, name, k, f"refers to family {key['family']!r}, which the set does not have")
        coords = sorted(seen)
        _gaps(coords, str(axis), periodic, name, mfile, problem)
        line = (a.get("behaviour"), axis, tuple(sorted((k, str(v)) for k, v in at.items())))
        for other, olo, ohi in lines.get(line, []):
            if coords and (periodic or min(ohi, coords[-1]) > max(olo, coords[0])):
                problem("error", "duplicate", mfile, name, None,
                        f"overlaps animation '{other}' on the same line of Q (same behaviour, axis and coordinates)")
        if coords:
            lines.setdefault(line, []).append((name, coords[0], coords[-1]))

    if report.ok:
        _loaded_checks(path, report, problem)
    return report


def _gaps(coords: list[float], axis: str, periodic: bool, name: str, file: str, problem: Any) -> None:
    if len(coords) < 2:
        if periodic and coords:
            problem("warning", "gap", file, name, None, f"one key along periodic {axis}: the pose never changes there")
        return
    steps = np.diff(coords).tolist() + ([coords[0] + 1.0 - coords[-1]] if periodic else [])
    limit = CYCLE_GAP if periodic else THETA_GAP
    for i, step in enumerate(steps):
        if step > limit + 1e-9:
            j = (i + 1) % len(coords)
            problem("warning", "gap", file, name, i,
                    f"{step:.3g} from {axis}={coords[i]:.4g} to {axis}={coords[j]:.4g} (more than {limit:g})")


def _loaded_checks(path: Path, report: CheckReport, problem: Any) -> None:
    from render.keyframes.keyframe_set import KeyframeSet

    try:
        kset = KeyframeSet.load(path)
    except KeyframeError as e:
        msg = str(e)
        file, _, rest = msg.partition(": ")
        problem("error", "invalid", file or str(path), None, None, rest or msg)
        return
    report.behaviours = list(kset.behaviours)
    for fam in kset.families.values():
        if fam.loft is not None:
            values = [float(m.base[fam.loft] or 0.0) for m in fam.members]
            _gaps(values, kset.space.axes[fam.loft], kset.space.periodic[fam.loft], fam.name, str(path), problem)
    d = kset.space.dims
    for behaviour, table in kset.tables.items():
        upright = np.zeros((8, d))
        upright[:, 2] = upright[:, 3] = np.arange(8) / 8
        upright = kset.space.clamp(upright)
        if table.distances(upright).min(axis=1).max() > 1e-9:
            problem("warning", "gap", str(path), None, None, f"behaviour '{behaviour}': no animation passes upright (Θ = 0)")
    default = kset.default_behaviour
    for axis in (0, 1):
        for sign in (-1.0, 1.0):
            reach = [c.lo if sign < 0 else c.hi for c in kset.animations
                     if c.behaviour == default and c.axis == axis]
            far = max((sign * r for r in reach), default=0.0)
            if far < math.pi / 2 - 1e-6:
                problem("warning", "gap", str(path), None, None,
                        f"behaviour '{default}': nothing reaches {STANDARD_AXES[axis]} = {sign * math.pi / 2:+.3f} "
                        f"(lying); beyond {sign * far:+.3f} the end pose holds")
