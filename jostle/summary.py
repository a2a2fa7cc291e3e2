"""What a run really did, counted from the snapshots' events as they happen."""

from __future__ import annotations

import hashlib
import json
from dataclasses import asdict, dataclass, field
from pathlib import Path

from sensors.untrusted import write_owned
from sim.snapshot import CharacterState, WorldSnapshot


@dataclass
class RunSummary:
    characters: int = 0
    sim_steps: int = 0
    sim_seconds: float = 0.0
    wall_seconds: float = 0.0
    frames_rendered: int = 0
    sensor_frames: int = 0
    observed_frames_with_people: int = 0
    contacts: int = 0
    pushes: int = 0
    falls: int = 0
    getups: int = 0
    max_contact_force_n: float = 0.0
    dropped_sim_seconds: float = 0.0
    state_changes: dict[str, int] = field(default_factory=dict)
    recording: str | None = None
    video: str | None = None
    seed: int = 0
    trace_sha256: str = ""
    stopped_because: str = ""

    def to_json(self) -> str:
        return json.dumps(asdict(self), indent=2, sort_keys=False)

    def write(self, path: Path) -> None:
        write_owned(path, self.to_json() + "\n")  # a regular file or none: never a device or FIFO


class SnapshotTally:
    """Counts events from every snapshot and hashes the whole trace (for determinism checks)."""

    def __init__(self, summary: RunSummary) -> None:
        self.summary = summary
        self._hash = hashlib.sha256()

    def add(self, snap: WorldSnapshot) -> None:
        s = self.summary
        s.sim_steps = snap.steps
        s.sim_seconds = snap.t
        s.dropped_sim_seconds += snap.dropped_time
        for c in snap.contacts:
            s.contacts += 1
            s.pushes += int(c.push)
            s.max_contact_force_n = max(s.max_contact_force_n, c.peak_force_n)
        for ch in snap.characters:
            s.max_contact_force_n = max(s.max_contact_force_n, ch.contact_force_n)
        for change in snap.changes:
            key = f"{change.before.value}->{change.after.value}"
            s.state_changes[key] = s.state_changes.get(key, 0) + 1
            if change.after is CharacterState.FALL:
                s.falls += 1
            if change.before is CharacterState.STAND_UP and change.after is CharacterState.WALK:
                s.getups += 1
        self._hash.update(repr(snap).encode())

    @property
    def digest(self) -> str:
        return self._hash.hexdigest()
