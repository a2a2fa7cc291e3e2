"""The main loop: sensors → observers → world → renderer → video, on one injected clock.

Replays and headless runs use simulated time (a ``SimClock`` that the loop moves one render frame at
a time), so a recording plus a seed always gives the same trace, as fast as the CPU allows. Live runs
use the wall clock and pace the loop to the render rate.
"""

from __future__ import annotations

import dataclasses
import logging
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Literal

import numpy as np

from interaction.fusion import SensorFusion
from interaction.observers import Observer, observer_types
from interaction.types import BodyObservation
from jostle.config import JostleConfig, ObserverEntry
from jostle.observer_guard import ObserverGuard
from jostle.operations import Operations
from jostle.progress import Progress
from jostle.session_recording import SessionRecorder
from jostle.summary import RunSummary, SnapshotTally
from jostle.terrain_wiring import TerrainWiring, attach_terrain
from sensors.base import Sensor, SensorState
from sensors.clock import Clock, SimClock, WallClock
from sensors.registry import SENSOR_TYPES
from sim.snapshot import WorldSnapshot
from sim.world import World

if TYPE_CHECKING:
    from render.gl.renderer import Renderer
    from render.gl.video import VideoOut
    from render.keyframes import KeyframeSet

log = logging.getLogger("jostle")

Mode = Literal["headless", "window", "kiosk"]
Speed = Literal["realtime", "max"]


@dataclass(frozen=True)
class RunOptions:
    mode: Mode = "headless"
    out_dir: Path | None = None
    seed: int | None = None
    speed: Speed = "max"
    duration_s: float | None = None  # overrides the config's [run] duration_s
    video: bool = True
    progress: bool = True


def place_characters(config: JostleConfig, world: World, seed: int) -> int:
    """Spread the configured characters over the stage, deterministically from the seed."""
    rng = np.random.default_rng([seed, 7])
    w = config.world
    total = sum(g.count for g in config.characters)
    n = 0
    for group in config.characters:
        for _ in range(group.count):
            frac = (n + 0.5) / max(total, 1)
            x = w.x_min + 0.5 + frac * (w.x_max - w.x_min - 1.0) + rng.uniform(-0.2, 0.2)
            y = rng.uniform(w.y_min * 0.5, w.y_max * 0.5)
            heading = float(rng.uniform(-np.pi, np.pi))
            world.add_character(group.spec, (float(x), float(y)), heading, intent=group.intent)
            n += 1
    return n


def expected_duration(config: JostleConfig, options: RunOptions) -> float | None:
    """Seconds of simulated time the run will cover, when it can be known in advance."""
    if options.duration_s:
        return options.duration_s
    if config.run.duration_s:
        return config.run.duration_s
    from sensors.recording.info import describe_recording
    from sensors.recording.replay import ReplayConfig

    longest = 0.0
    for entry in config.sensors:
        if not isinstance(entry.config, ReplayConfig):
            return None  # a live sensor: runs until stopped
        longest = max(longest, describe_recording(entry.config.path).duration)
    return longest + config.run.tail_s


class App:
    """Owns every part of one run; ``run()`` drives them and returns what happened."""

    def __init__(self, config: JostleConfig, options: RunOptions, *, clock: Clock | None = None) -> None:
        self.config = config
        self.options = options
        self.seed = config.run.seed if options.seed is None else options.seed
        live = any(not _is_replay(e.config) for e in config.sensors)
        if clock is None:
            clock = WallClock() if (live or options.speed == "realtime") else SimClock()
        self.clock = clock
        # attract mode, health report, diagnostics, systemd supervision (jostle.operations)
        self.operations = Operations(config, options.mode, live=not isinstance(clock, SimClock))
        self.summary = RunSummary(seed=self.seed)
        self.tally = SnapshotTally(self.summary)
        # wall seconds spent in each stage of the loop (for `jostle bench pipeline`)
        self.stage_seconds: dict[str, float] = dict.fromkeys(("sensors", "observe", "simulate", "draw", "encode"), 0.0)
        self.on_frame: Callable[[WorldSnapshot, BodyObservation, np.ndarray | None], None] | None = None
        # faults survived (jostle.observer_guard, jostle.session_recording): read by tests and the health report
        self.observer_guards: dict[str, ObserverGuard] = {}
        self.session_recorder: SessionRecorder | None = None
        self.sensors: dict[str, Sensor] = {}  # this run's sensors (filled by run())
        self.terrain: TerrainWiring | None = None  # [terrain]: the cubes people build (filled by run())

    def run(self) -> RunSummary:
        from render.gl.renderer import Renderer
        from render.gl.video import VideoOut
        from render.keyframes import KeyframeSet

        cfg = self.config
        opts = self.options
        wall0 = time.perf_counter()
        sensors: dict[str, Sensor] = self.sensors
        observers: dict[str, tuple[str, Observer]] = {}  # observer name -> (sensor name, observer)
        for entry in cfg.sensors:
            sensors[entry.name] = SENSOR_TYPES[entry.type].load(entry.config, entry.name, self.clock)
        for ob in cfg.observers:
            inline = isinstance(self.clock, SimClock)  # simulated time: pose inline, the same trace every time
            guard = ObserverGuard(ob.name, _observer_builder(ob, inline), self.clock)  # a crash: logged, rebuilt later
            self.observer_guards[ob.name] = guard
            observers[ob.name] = (ob.sensor, guard)
        if cfg.record.enabled:
            self.session_recorder = SessionRecorder(cfg.record, metadata={"config": str(cfg.path)})
        recordings = [str(e.config.path) for e in cfg.sensors if _is_replay(e.config)]
        self.summary.recording = ", ".join(recordings) if recordings else None

        keyframes = self._keyframe_sets(KeyframeSet)
        world = World(cfg.world, np.random.default_rng(self.seed))
        renderer = None
        video = None
        out_dir = opts.out_dir
        try:
            self.summary.characters = place_characters(cfg, world, self.seed)
            self.terrain = attach_terrain(cfg, world)  # the layout built; None without [terrain]
            self.summary.characters += len(cfg.quadrupeds)  # (they need [terrain]: stood on it just above)
            from render.gl.style import RenderStyle

            renderer = Renderer(
                cfg.render.width,
                cfg.render.height,
                headless=(opts.mode == "headless"),
                fullscreen=(opts.mode == "kiosk"),
                style=RenderStyle(camera=cfg.render.camera, colours=cfg.render.colours, look=cfg.render.look),
                stage_x=(cfg.world.x_min, cfg.world.x_max),
                com_fraction={g.spec.name: g.spec.com_height / g.spec.height for g in cfg.characters} or 0.5,
                exit_keys=cfg.kiosk.exit_keys,
            )
            if out_dir is not None:
                out_dir.mkdir(parents=True, exist_ok=True)
                if opts.video:
                    video_path = out_dir / f"{cfg.path.stem}.mp4"
                    video = VideoOut(video_path, cfg.render.fps, (cfg.render.width, cfg.render.height))
                    self.summary.video = str(video_path)
            for s in sensors.values():
                s.open()
            self.operations.start()
            self._loop(sensors, observers, world, renderer, keyframes, video)
        finally:
            self.operations.close(self.summary.stopped_because)
            for guard in self.observer_guards.values():
                guard.close()
            for s in sensors.values():
                s.close()
            if self.session_recorder is not None:
                self.session_recorder.close()
            if video is not None:
                video.close()
            if renderer is not None:
                renderer.close()
            world.close()
            self.summary.wall_seconds = round(time.perf_counter() - wall0, 3)
            self.summary.trace_sha256 = self.tally.digest
            if out_dir is not None:
                self.summary.write(out_dir / "summary.json")
        return self.summary

    def _keyframe_sets(self, loader: type[KeyframeSet]) -> dict[str, KeyframeSet]:
        """One keyframe set per character kind (the spec's name), "*" for the default; each file read once."""
        cfg = self.config
        loaded: dict[Path, KeyframeSet] = {}

        def load(path: Path) -> KeyframeSet:
            if path not in loaded:
                loaded[path] = loader.load(path)
            return loaded[path]

        sets = {"*": load(cfg.render.keyframes)}
        for group in cfg.characters:
            if group.keyframes is not None:
                sets[group.spec.name] = load(group.keyframes)
        return sets

    def _loop(
        self,
        sensors: dict[str, Sensor],
        observers: dict[str, tuple[str, Observer]],
        world: World,
        renderer: Renderer,
        keyframes: dict[str, KeyframeSet],
        video: VideoOut | None,
    ) -> None:
        cfg = self.config
        opts = self.options
        dt = 1.0 / cfg.render.fps
        duration = opts.duration_s or cfg.run.duration_s or 0.0
        total = expected_duration(cfg, opts)
        latest: dict[str, BodyObservation] = {}
        silhouettes: dict[str, np.ndarray] = {}
        ended_at: float | None = None
        bar = Progress(total, "jostle run", "sim s", enabled=opts.progress)
        spent = self.stage_seconds
        terrain = self.terrain
        fusion = SensorFusion()  # a person seen by two sensors is pushed once
        silhouette_calibration = None
        for _, observer in observers.values():
            calibration = getattr(observer, "calibration", None)
            if calibration is not None and hasattr(observer, "silhouette"):
                silhouette_calibration = calibration
                break
        t = self.clock.now()
        t0 = t
        stepped_to = t  # the world has been stepped up to this clock time
        try:
            while True:
                t = max(t + dt, self.clock.now())  # late (live, slow display): draw now, never catch up frames
                self.clock.sleep_until(t)
                now = self.clock.now()
                clock = time.perf_counter
                for sensor_name, sensor in sensors.items():
                    mark = clock()
                    while (frame := sensor.read(0.0)) is not None:
                        self.summary.sensor_frames += 1
                        if self.session_recorder is not None:
                            self.session_recorder.write(frame)
                        spent["sensors"] += clock() - mark
                        for ob_name, (src, observer) in observers.items():
                            if src != sensor_name:
                                continue
                            mark = clock()
                            obs = observer.observe(frame)
                            if terrain is not None and ob_name == terrain.section.boxes:  # boxes on the floor
                                obs = terrain.observe_depth(frame, obs)  # (a stack as tall as a person is no one)
                            spent["observe"] += clock() - mark
                            pending = latest.get(ob_name)
                            if pending is not None and pending.impulses:  # several pad samples per frame:
                                obs = dataclasses.replace(obs, impulses=pending.impulses + obs.impulses)  # keep all hits
                            latest[ob_name] = obs
                            sil = getattr(observer, "silhouette", None)
                            if isinstance(sil, np.ndarray):
                                silhouettes[ob_name] = sil
                            if obs.people:
                                self.summary.observed_frames_with_people += 1
                        mark = clock()
                    spent["sensors"] += clock() - mark
                    if sensor.status.state in _SENSOR_DOWN:  # unplugged: the people it saw are not there now
                        _forget_sensor(sensor_name, observers, latest, silhouettes)
                observation = fusion.merge(now, list(latest.values()))
                if terrain is not None:  # a hand held still over a floor cell places a cube
                    terrain.observe_hands(observation)
                mark = clock()
                # on simulated time this is exactly dt; live, a slow frame hands the world all the
                # time that really passed (the world caps catch-up and reports what it dropped)
                snap = world.step(observation, now - stepped_to)
                stepped_to = now
                spent["simulate"] += clock() - mark
                for ob_name, obs in latest.items():  # an impulse acts once; contactors stay until replaced
                    if obs.impulses:
                        latest[ob_name] = dataclasses.replace(obs, impulses=())
                self.tally.add(snap)
                self.operations.frame(now, snap, observation, sensors, world, self.observer_guards)
                silhouette = next(iter(silhouettes.values()), None) if cfg.render.show_silhouette else None
                mark = clock()
                image = renderer.draw(snap, observation if cfg.render.show_contactors else None, keyframes,
                                      silhouette=silhouette, silhouette_calibration=silhouette_calibration,
                                      captions=self.operations.captions(now),
                                      terrain=None if terrain is None else terrain.view())
                spent["draw"] += clock() - mark
                self.operations.keys(renderer.take_keys())  # pressed while the frame was shown
                self.summary.frames_rendered += 1
                if video is not None:
                    mark = clock()
                    video.write(image)
                    spent["encode"] += clock() - mark
                if self.on_frame is not None:
                    self.on_frame(snap, observation, image)
                bar.update(dt)
                if renderer.should_close:
                    self.summary.stopped_because = "window closed"
                    break
                elapsed = now - t0
                if duration and elapsed >= duration - 1e-9:
                    self.summary.stopped_because = f"duration {duration:g} s reached"
                    break
                if not duration and all(s.status.state is SensorState.ENDED for s in sensors.values()):
                    ended_at = now if ended_at is None else ended_at
                    if now - ended_at >= cfg.run.tail_s - 1e-9:
                        self.summary.stopped_because = "all recordings ended"
                        break
                failed = [n for n, s in sensors.items() if s.status.state is SensorState.FAILED]
                if failed:
                    name = failed[0]
                    raise RuntimeError(f"sensor {name!r} failed: {sensors[name].status.reason}")
        except KeyboardInterrupt:
            self.summary.stopped_because = "interrupted"
        finally:
            bar.close()


_SENSOR_DOWN = (SensorState.RECONNECTING, SensorState.FAILED)


def _forget_sensor(name: str, observers: dict[str, tuple[str, Observer]], latest: dict[str, BodyObservation],
                   silhouettes: dict[str, np.ndarray]) -> None:
    """Drop what the observers of sensor ``name`` last saw (its contactors would push on, stale)."""
    for ob_name, (src, _) in observers.items():
        if src == name:
            latest.pop(ob_name, None)
            silhouettes.pop(ob_name, None)


def _observer_builder(ob: ObserverEntry, inline: bool = False) -> Callable[[], Observer]:
    """Builds the observer of ``ob`` afresh from its config (at start, and after a crash); ``inline``
    runs work an observer would do beside the loop in it (the webcam's ``pose_sync``): deterministic."""
    config = ob.config
    if inline and dataclasses.is_dataclass(config) and not isinstance(config, type) \
            and any(f.name == "pose_sync" for f in dataclasses.fields(config)):
        config = dataclasses.replace(config, pose_sync=True)
    return lambda: observer_types()[ob.type].build(config, ob.calibration, ob.sensor)


def _is_replay(config: object) -> bool:
    from sensors.recording.replay import ReplayConfig

    return isinstance(config, ReplayConfig)
