"""The installation config: one TOML file → frozen dataclasses, checked before anything opens.

Layout (all tables optional but ``sensors``)::

    [run]                 seed, duration_s, tail_s
    [sensors.<name>]      type = "webcam" | "replay" | ...  + that driver's keys
    [observers.<name>]    type = "webcam", sensor = "<sensor name>", calibration = "file.toml" + observer keys
    [world]               sim.WorldConfig keys
    [[characters]]        spec = "characters/x.toml", count, intent
    [render]              width, height, fps, keyframes, ...
    [record]              dir, quota_mb, file_minutes, min_free_mb: session recording (jostle.session_recording)

Paths are relative to the config file. Every error names the file, the key and what was expected.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

from interaction.observers import observer_types
from jostle.configtree import ConfigError, build
from jostle.operations_config import HealthConfig, KioskConfig
from jostle.session_recording import SessionRecordConfig
from jostle.terrain_layout import QuadrupedGroup, QuadrupedTable, TerrainSection
from render.gl.style import Camera, Colours, Look
from sensors.registry import SENSOR_TYPES
from sensors.untrusted import InputLimits, MissingInput, UntrustedInput, finite, whole
from sensors.untrusted import load_toml as load_untrusted_toml
from sensors.untrusted.limits import CHARACTER_SPEC, CONFIG_TOML, DURATION_MAX_S, SEED_MAX, SENSORS_MAX
from sim.articulated.spec import ArticulatedSpec
from sim.config import CharacterSpec, WorldConfig
from sim.quadruped.config import QuadrupedSpec

__all__ = ["ConfigError", "JostleConfig", "load_config", "load_toml"]

TAIL_MAX_S = 3600.0  # [run] tail_s: the seconds run on after the recordings end


@dataclass(frozen=True)
class RunConfig:
    seed: int = 0  # 0 … 2^32 − 1 (numpy's seeding)
    duration_s: float = 0.0  # seconds, 0 … DURATION_MAX_S; 0: until every sensor has ended, then tail_s more
    tail_s: float = 2.0  # seconds, 0 … TAIL_MAX_S

    def __post_init__(self) -> None:
        finite(self.duration_s, "duration_s", 0, DURATION_MAX_S)  # an UntrustedInput: a ValueError
        finite(self.tail_s, "tail_s", 0, TAIL_MAX_S)
        whole(self.seed, "seed", 0, SEED_MAX)


@dataclass(frozen=True)
class RenderConfig:
    keyframes: Path  # the default keyframe set; a [[characters]] group may name its own
    width: int = 1280
    height: int = 720
    fps: float = 30.0
    show_silhouette: bool = True
    show_contactors: bool = True
    camera: Camera = field(default_factory=Camera)  # [render.camera]: eye, target, fov_y_deg, …
    colours: Colours = field(default_factory=Colours)  # [render.colours]: "#rrggbb" per part of the scene
    look: Look = field(default_factory=Look)  # [render.look]: hud, shadows, flash, opacity, samples

    def __post_init__(self) -> None:
        if not (16 <= self.width <= 7680 and 16 <= self.height <= 4320):
            raise ValueError(f"width: expected a size from 16×16 to 7680×4320, got {self.width}×{self.height}")
        if not 1 <= self.fps <= 240:
            raise ValueError(f"fps: expected 1 to 240, got {self.fps}")
        if not self.keyframes.exists():
            raise ValueError(f"keyframes: no such file {self.keyframes}")


@dataclass(frozen=True)
class SensorEntry:
    name: str
    type: str
    config: Any


@dataclass(frozen=True)
class ObserverEntry:
    name: str
    type: str
    sensor: str
    calibration: Path | None
    config: Any


@dataclass(frozen=True)
class CharacterGroup:
    spec: CharacterSpec | ArticulatedSpec  # body = "articulated" in the spec file: an ArticulatedSpec
    count: int
    intent: str
    source: Path
    keyframes: Path | None = None  # this group's keyframe set; None: [render] keyframes


@dataclass(frozen=True)
class JostleConfig:
    path: Path
    run: RunConfig
    sensors: tuple[SensorEntry, ...]
    observers: tuple[ObserverEntry, ...]
    world: WorldConfig
    characters: tuple[CharacterGroup, ...]
    render: RenderConfig
    raw: Mapping[str, Any] = field(default_factory=dict, repr=False, compare=False)
    kiosk: KioskConfig = field(default_factory=KioskConfig)  # [kiosk]: exit keys, attract mode, diagnostics
    health: HealthConfig = field(default_factory=HealthConfig)  # [health]: health report, systemd watchdog
    record: SessionRecordConfig = field(default_factory=SessionRecordConfig)  # [record]: session files, quota
    terrain: TerrainSection | None = None  # [terrain]: the cube grid people build (jostle.terrain_layout)
    quadrupeds: tuple[QuadrupedGroup, ...] = ()  # [[quadrupeds]]: four-legged characters on the terrain


TOP_KEYS = ("run", "sensors", "observers", "world", "characters", "render", "kiosk", "health", "record", "terrain",
            "quadrupeds")


def load_toml(path: Path, limits: InputLimits = CONFIG_TOML, what: str = "config") -> dict[str, Any]:
    """Read a TOML file within ``limits`` (a regular file, bounded in size, nesting and keys: see
    ``sensors.untrusted``), turning every failure into a one-line ConfigError naming the file."""
    try:
        return load_untrusted_toml(path, limits, what)
    except MissingInput:
        raise ConfigError(f"{path}: no such {what} file") from None
    except UntrustedInput as e:
        raise ConfigError(str(e)) from None


def _table(doc: Mapping[str, Any], key: str, source: str) -> Mapping[str, Any]:
    value = doc.get(key, {})
    if not isinstance(value, Mapping):
        raise ConfigError(f"{source}: {key}: expected a table, got {type(value).__name__}")
    return value


def _typed_entry(
    name: str, table: Mapping[str, Any], section: str, known: Mapping[str, Any], source: str
) -> tuple[str, dict[str, Any]]:
    if not isinstance(table, Mapping):
        raise ConfigError(f"{source}: {section}.{name}: expected a table")
    kind = table.get("type")
    if not isinstance(kind, str):
        raise ConfigError(
            f"{source}: {section}.{name}.type: missing; expected one of: {', '.join(sorted(known))}"
        )
    if kind not in known:
        raise ConfigError(
            f"{source}: {section}.{name}.type: unknown type {kind!r}; known: {', '.join(sorted(known))}"
        )
    rest = {k: v for k, v in table.items() if k != "type"}
    return kind, rest


def load_config(path: str | Path) -> JostleConfig:
    """Load and check a whole installation config. Raises ConfigError (one line) on anything wrong."""
    path = Path(path)
    doc = load_toml(path)
    source = str(path)
    base = path.parent.resolve()
    for k in doc:
        if k not in TOP_KEYS:
            raise ConfigError(f"{source}: {k}: unknown key; expected one of: {', '.join(TOP_KEYS)}")

    run = build(RunConfig, _table(doc, "run", source), source=source, key="run", base_dir=base)
    if len(_table(doc, "sensors", source)) > SENSORS_MAX:
        raise ConfigError(f"{source}: sensors: {len(doc['sensors'])} sensors, more than the {SENSORS_MAX} allowed")

    sensors: list[SensorEntry] = []
    sensor_tables = _table(doc, "sensors", source)
    if not sensor_tables:
        raise ConfigError(f"{source}: sensors: missing; at least one [sensors.<name>] table is needed")
    for name, table in sensor_tables.items():
        kind, rest = _typed_entry(name, table, "sensors", SENSOR_TYPES, source)
        sensor_cfg: Any = build(SENSOR_TYPES[kind].config, rest, source=source, key=f"sensors.{name}", base_dir=base)
        sensors.append(SensorEntry(name, kind, sensor_cfg))

    observers: list[ObserverEntry] = []
    known_observers = observer_types()
    for name, table in _table(doc, "observers", source).items():
        kind, rest = _typed_entry(name, table, "observers", known_observers, source)
        sensor = rest.pop("sensor", None)
        if sensor not in sensor_tables:
            raise ConfigError(
                f"{source}: observers.{name}.sensor: expected the name of a [sensors.*] table "
                f"({', '.join(sensor_tables)}), got {sensor!r}"
            )
        calib_value = rest.pop("calibration", None)
        calibration: Path | None = None
        if known_observers[kind].needs_calibration or calib_value is not None:
            if not isinstance(calib_value, str):
                raise ConfigError(
                    f"{source}: observers.{name}.calibration: missing; expected a path to a calibration TOML"
                )
            calibration = Path(calib_value) if Path(calib_value).is_absolute() else base / calib_value
            if not calibration.exists():
                raise ConfigError(f"{source}: observers.{name}.calibration: no such file {calibration}")
        cfg: Any = build(known_observers[kind].config, rest, source=source, key=f"observers.{name}", base_dir=base)
        observers.append(ObserverEntry(name, kind, str(sensor), calibration, cfg))

    world = build(WorldConfig, _table(doc, "world", source), source=source, key="world", base_dir=base)

    groups: list[CharacterGroup] = []
    char_list = doc.get("characters", [])
    if not isinstance(char_list, list):
        raise ConfigError(f"{source}: characters: expected [[characters]] tables")
    for i, entry in enumerate(char_list):
        key = f"characters[{i}]"
        if not isinstance(entry, Mapping):
            raise ConfigError(f"{source}: {key}: expected a table")
        group = build(_GroupTable, entry, source=source, key=key, base_dir=base)
        spec_doc = load_toml(group.spec, CHARACTER_SPEC, "character spec")
        spec: CharacterSpec | ArticulatedSpec
        if spec_doc.get("body") == "articulated":
            spec = _with_clip_files(build(ArticulatedSpec, spec_doc, source=str(group.spec), key="",
                                          base_dir=group.spec.parent), group.spec)
        else:
            spec = build(CharacterSpec, spec_doc, source=str(group.spec), key="", base_dir=group.spec.parent)
        groups.append(CharacterGroup(spec, group.count, group.intent, group.spec,
                                     None if group.keyframes == Path() else group.keyframes))

    render = build(RenderConfig, _table(doc, "render", source), source=source, key="render", base_dir=base)
    kiosk = build(KioskConfig, _table(doc, "kiosk", source), source=source, key="kiosk", base_dir=base)
    health = build(HealthConfig, _table(doc, "health", source), source=source, key="health", base_dir=base)
    record = build(SessionRecordConfig, _table(doc, "record", source), source=source, key="record", base_dir=base)
    terrain, quadrupeds = _terrain(doc, observers, source, base)
    return JostleConfig(path, run, tuple(sensors), tuple(observers), world, tuple(groups), render, doc,
                        kiosk=kiosk, health=health, record=record, terrain=terrain,
                        quadrupeds=quadrupeds)


def _with_clip_files(spec: ArticulatedSpec, source: Path) -> ArticulatedSpec:
    """Clip keys that name files (a BVH, DeepMimic JSON) made relative to the spec file and loaded once
    here, so a bad file is a config error naming the spec file, the key and the clip file."""
    from dataclasses import replace

    from sim.motion.clips import is_motion_file, load_motion
    from sim.motion.mocap import MotionFileError

    resolved: dict[str, Any] = {}
    for key in ("walk_clip", "getup_faceup_clip", "getup_facedown_clip"):
        ref = getattr(spec, key)
        if not is_motion_file(ref):
            continue
        path = str(Path(ref) if Path(ref).is_absolute() else source.parent / ref)
        try:
            load_motion(path, key, cycle=key == "walk_clip")
        except MotionFileError as e:
            raise ConfigError(f"{source}: {e}") from None
        resolved[key] = path
    if spec.skeleton != "deepmimic_humanoid":  # a BVH file: its body is built when the world starts
        path = str(Path(spec.skeleton) if Path(spec.skeleton).is_absolute() else source.parent / spec.skeleton)
        try:
            from sim.articulated.bvh_body import bvh_character

            bvh_character(path)
        except MotionFileError as e:
            raise ConfigError(f"{source}: {e}") from None
        resolved["skeleton"] = path
    return replace(spec, **resolved)


@dataclass(frozen=True)
class _GroupTable:
    spec: Path
    count: int = 1
    intent: Literal["idle", "wander", "approach", "flee", "follow"] = "wander"
    keyframes: Path = Path()  # this group's keyframe set (default: [render] keyframes)

    def __post_init__(self) -> None:
        if not 0 <= self.count <= 1000:
            raise ValueError(f"count: expected 0 to 1000, got {self.count}")
        if not self.spec.exists():
            raise ValueError(f"spec: no such character file {self.spec}")
        if self.keyframes != Path() and not self.keyframes.exists():
            raise ValueError(f"keyframes: no such keyframe set {self.keyframes}")


def _terrain(doc: Mapping[str, Any], observers: list[ObserverEntry], source: str, base: Path
             ) -> tuple[TerrainSection | None, tuple[QuadrupedGroup, ...]]:
    """``[terrain]`` (None when absent; its ``boxes`` must name a depth observer) and ``[[quadrupeds]]``."""
    tables = doc.get("quadrupeds", [])
    if not isinstance(tables, list) or not all(isinstance(t, Mapping) for t in tables):
        raise ConfigError(f"{source}: quadrupeds: expected [[quadrupeds]] tables")
    if "terrain" not in doc:
        if tables:
            raise ConfigError(f"{source}: quadrupeds: a quadruped walks on the cube terrain: add a [terrain] table")
        return None, ()
    terrain = build(TerrainSection, _table(doc, "terrain", source), source=source, key="terrain", base_dir=base)
    depth = [o.name for o in observers if o.type == "depth"]
    if terrain.boxes and terrain.boxes not in depth:
        raise ConfigError(f"{source}: terrain.boxes: expected the name of a depth observer "
                          f"({', '.join(depth) or 'none configured'}), got {terrain.boxes!r}")
    groups = []
    for i, t in enumerate(tables):
        table = build(QuadrupedTable, t, source=source, key=f"quadrupeds[{i}]", base_dir=base)
        spec = QuadrupedSpec() if table.spec == Path() else build(
            QuadrupedSpec, load_toml(table.spec, CHARACTER_SPEC, "quadruped spec"), source=str(table.spec), key="", base_dir=table.spec.parent)
        groups.append(QuadrupedGroup(spec, table))
    return terrain, tuple(groups)
