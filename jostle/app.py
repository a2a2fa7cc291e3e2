"""The main loop: sensors → observers → world → renderer → video, on one injected clock.

Replays and headless runs use simulated time (a ``SimClock`` that the loop moves one render frame at
a time), so a recording or a video file plus a seed always gives the same trace, as fast as the CPU
allows. Live runs use the wall clock and pace the loop to the render rate.
"""

from __future__ import annotations

import dataclasses
import logging
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from interaction.fusion import SensorFusion
from interaction.observers import Observer
from interaction.types import BodyObservation, Impulse
from jostle.calibration_check import calibration_for
from jostle.config import JostleConfig
from jostle.errors import RunFailed
from jostle.observer_guard import ObserverGuard
from jostle.operations import Operations
from jostle.progress import Progress
from jostle.run_setup import (
    RunOptions,
    expected_duration,
    observer_builder,
    place_characters,
    played_file,
    plays_a_file,
)
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

class App:
    """Owns every part of one run; ``run()`` drives them and returns what happened."""

    def __init__(self, config: JostleConfig, options: RunOptions, *, clock: Clock | None = None) -> None:
        self.config = config
        self.options = options
        self.seed = config.run.seed if options.seed is None else options.seed
        live = any(not plays_a_file(e.config) for e in config.sensors)  # recordings and video files: sim time
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
        self.progress: Progress | None = None  # the progress line of the last run (its ``n``: simulated seconds)

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
        if cfg.record.enabled:
            self.session_recorder = SessionRecorder(cfg.record, metadata={"config": str(cfg.path)})
        recordings = [str(played_file(e.config)) for e in cfg.sensors if plays_a_file(e.config)]
        self.summary.recording = ", ".join(recordings) if recordings else None

        keyframes = self._keyframe_sets(KeyframeSet)
        world = World(cfg.world, np.random.default_rng(self.seed))
        renderer = None
        video = None
        out_dir = opts.out_dir
        try:
            for s in sensors.values():  # open first: a calibration is checked against the size they give
                s.open()
            for ob in cfg.observers:  # a crash: logged, the observer rebuilt later (jostle.observer_guard)
                calibration = calibration_for(ob, sensors[ob.sensor])
                inline = isinstance(self.clock, SimClock)  # simulated time: pose inline, the same trace every time
                guard = ObserverGuard(ob.name, observer_builder(ob, calibration, inline), self.clock)
                self.observer_guards[ob.name] = guard
                observers[ob.name] = (ob.sensor, guard)
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
                com_fraction=None,  # each character's from its snapshot
                exit_keys=cfg.kiosk.exit_keys,
            )
            if out_dir is not None:
                out_dir.mkdir(parents=True, exist_ok=True)
                if opts.video:
                    video_path = out_dir / f"{cfg.path.stem}.mp4"
                    video = VideoOut(video_path, cfg.render.fps, (cfg.render.width, cfg.render.height))
                    self.summary.video = str(video_path)
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
            self.summary.failed = "; ".join(filter(None, (g.never_observed() for g in self.observer_guards.values())))
            self.summary.wall_seconds = round(time.perf_counter() - wall0, 3)
            self.summary.trace_sha256 = self.tally.digest
            if out_dir is not None and out_dir.is_dir():  # (not made when the run stopped before it began)
                self.summary.write(out_dir / "summary.json")
        if self.summary.failed:
            raise RunFailed(f"{self.summary.failed}; run with --debug for the traceback")
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
        """One render frame at a time: read → observe → merge → step → draw, until a stop condition."""
        dt = 1.0 / self.config.render.fps
        frames = _Frames(SensorFusion(), t0=self.clock.now())
        bar = self.progress = Progress(expected_duration(self.config, self.options), "jostle run", "sim s",
                                       enabled=self.options.progress)
        try:
            while True:
                frames.t = max(frames.t + dt, self.clock.now())  # late (live, slow display): draw now, never catch up
                self.clock.sleep_until(frames.t)
                now = self.clock.now()
                self._read_and_observe(sensors, observers, frames)
                observation = self._merge(now, frames)
                snap = self._step(world, observation, now - frames.stepped_to)
                frames.stepped_to = now
                self.operations.frame(now, snap, observation, sensors, world, self.observer_guards)
                image = self._draw(renderer, snap, observation, keyframes, now, video)
                if self.on_frame is not None:
                    self.on_frame(snap, observation, image)
                bar.update_to(snap.t)  # the world's time, as the summary counts it (a late frame steps more than dt)
                if self._should_stop(renderer, sensors, frames, now):
                    break
        except KeyboardInterrupt:
            self.summary.stopped_because = "interrupted"
        finally:
            bar.close()

    def _read_and_observe(self, sensors: dict[str, Sensor], observers: dict[str, tuple[str, Observer]],
                          frames: _Frames) -> None:
        """Every frame each sensor has ready → its observers; each observer's latest observation kept
        (its impulses, a pad's hits, collected apart: they are handed to the world once)."""
        spent, clock, terrain = self.stage_seconds, time.perf_counter, self.terrain
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
                    frames.hits[ob_name] = frames.hits.get(ob_name, ()) + obs.impulses  # several pad samples a frame
                    frames.latest[ob_name] = dataclasses.replace(obs, impulses=()) if obs.impulses else obs
                    if obs.people:
                        self.summary.observed_frames_with_people += 1
                mark = clock()
            spent["sensors"] += clock() - mark
            if sensor.status.state in _SENSOR_DOWN:  # unplugged: the people it saw are not there now
                _forget_sensor(sensor_name, observers, frames.latest)

    def _merge(self, now: float, frames: _Frames) -> BodyObservation:
        """The observers' latest observations as one (a person seen by two sensors pushes once), with this
        frame's hits and the cubes held hands ask for."""
        observation = frames.fusion.merge(now, list(frames.latest.values()))
        hits = tuple(i for name in frames.latest for i in frames.hits.get(name, ()))
        frames.hits.clear()
        if hits:
            observation = dataclasses.replace(observation, impulses=hits)
        if self.terrain is not None:  # a hand held still over a floor cell asks for a cube
            observation = self.terrain.with_hands(observation)
        return observation

    def _step(self, world: World, observation: BodyObservation, dt: float) -> WorldSnapshot:
        """On simulated time ``dt`` is exactly one frame; live, a slow frame hands the world all the time that
        really passed (the world caps catch-up and reports what it dropped)."""
        mark = time.perf_counter()
        snap = world.step(observation, dt, intent_all=self.operations.intent_all)
        self.stage_seconds["simulate"] += time.perf_counter() - mark
        self.tally.add(snap)
        return snap

    def _draw(self, renderer: Renderer, snap: WorldSnapshot, observation: BodyObservation,
              keyframes: dict[str, KeyframeSet], now: float, video: VideoOut | None) -> np.ndarray | None:
        cfg, spent, clock = self.config, self.stage_seconds, time.perf_counter
        silhouette = observation.silhouette if cfg.render.show_silhouette else None
        mark = clock()
        image = renderer.draw(snap, observation if cfg.render.show_contactors else None, keyframes,
                              silhouette=None if silhouette is None else silhouette.mask,
                              silhouette_calibration=None if silhouette is None else silhouette.calibration,
                              captions=self.operations.captions(now),
                              terrain=None if self.terrain is None else self.terrain.view())
        spent["draw"] += clock() - mark
        self.operations.keys(renderer.take_keys())  # pressed while the frame was shown
        self.summary.frames_rendered += 1
        if video is not None:
            mark = clock()
            video.write(image)
            spent["encode"] += clock() - mark
        return image

    def _should_stop(self, renderer: Renderer, sensors: dict[str, Sensor], frames: _Frames, now: float) -> bool:
        """The window closed, the duration reached, every recording over (plus the tail); a failed sensor raises."""
        cfg = self.config
        duration = self.options.duration_s or cfg.run.duration_s or 0.0
        if renderer.should_close:
            self.summary.stopped_because = "window closed"
            return True
        if duration and now - frames.t0 >= duration - 1e-9:
            self.summary.stopped_because = f"duration {duration:g} s reached"
            return True
        if not duration and all(s.status.state is SensorState.ENDED for s in sensors.values()):
            frames.ended_at = now if frames.ended_at is None else frames.ended_at
            if now - frames.ended_at >= cfg.run.tail_s - 1e-9:
                self.summary.stopped_because = "all recordings ended"
                return True
        failed = [n for n, s in sensors.items() if s.status.state is SensorState.FAILED]
        if failed:
            raise RuntimeError(f"sensor {failed[0]!r} failed: {sensors[failed[0]].status.reason}")
        return False


@dataclass
class _Frames:
    """What the loop carries from one render frame to the next."""

    fusion: SensorFusion
    t0: float  # the clock when the loop began
    t: float = 0.0  # this frame's time
    stepped_to: float = 0.0  # the world has been stepped up to this clock time
    ended_at: float | None = None  # when every recording had ended
    latest: dict[str, BodyObservation] = field(default_factory=dict)  # each observer's last (no impulses)
    hits: dict[str, tuple[Impulse, ...]] = field(default_factory=dict)  # impulses not yet handed to the world

    def __post_init__(self) -> None:
        self.t = self.stepped_to = self.t0


_SENSOR_DOWN = (SensorState.RECONNECTING, SensorState.FAILED)


def _forget_sensor(name: str, observers: dict[str, tuple[str, Observer]], latest: dict[str, BodyObservation]) -> None:
    """Drop what the observers of sensor ``name`` last saw (its contactors would push on, stale)."""
    for ob_name, (src, _) in observers.items():
        if src == name:
            latest.pop(ob_name, None)
