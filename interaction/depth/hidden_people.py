"""People the depth camera does not see this frame but who are still on the stage: behind (or merged with)
someone it does see.

Someone seen in ``HIDDEN_AFTER_FRAMES`` frames or more who vanished less than ``memory_s`` ago, whose
predicted place is within ``near_m`` of someone still seen or in the camera's shadow of someone nearer to it
(``SHADOW_HALF_WIDTH_M``: the camera, on the stage's floor plan, given), is counted — unless a track that
appeared (new, or back after going unseen) after their last sighting — or split off beside them from
``REBORN_S`` before it — is there instead (within ``near_m`` of where they were last seen or are
predicted): then the tracker has lost them and found them again under another id (a lunging arm cut off as a blob of
its own took the body's track, or a blob split in two), and counting both would count one person twice.
Someone first seen beside a person already there is counted from their ``CONFIRM_FRAMES``-th frame
(``unconfirmed``).
Figures (frames with the wrong count, before and after): docs/notes/depth.md.
"""

from __future__ import annotations

import math

HIDDEN_AFTER_FRAMES = 5  # only a person seen in this many frames is counted when hidden
REBORN_S = 0.15  # a piece split off someone this long before their last sighting may be them found again
CONFIRM_FRAMES = 3  # someone first seen beside another person is counted from their third frame on
SHADOW_HALF_WIDTH_M = 0.5  # someone this near the line from the camera through a nearer person is hidden by them


class HiddenPeople:
    """Remembers who was seen when; counts the hidden (see the module docstring)."""

    def __init__(self, memory_s: float, near_m: float, camera_xy: tuple[float, float] | None = None) -> None:
        self._memory_s = memory_s
        self._near_m = near_m
        self._camera = camera_xy
        self._seen_at: dict[int, float] = {}  # person → when last seen
        self._first_seen: dict[int, float] = {}  # person → when first seen
        self._seen_frames: dict[int, int] = {}  # person → in how many frames
        self._seen_place: dict[int, tuple[float, float]] = {}  # person → where last seen
        self._born_beside: set[int] = set()  # people first seen beside someone already there
        self._back_since: dict[int, float] = {}  # person → when seen again after a frame or more unseen (or first)
        self._explained: dict[int, int] = {}  # person lost → the track that took them over
        self._last_t = -math.inf

    def clear(self) -> None:
        self._seen_at.clear()
        self._first_seen.clear()
        self._seen_frames.clear()
        self._seen_place.clear()
        self._born_beside.clear()
        self._back_since.clear()
        self._explained.clear()
        self._last_t = -math.inf

    def unconfirmed(self, ids: list[int]) -> int:
        """How many of the people seen now (``ids``, after ``count``) are not counted yet: first seen beside
        someone already there less than ``CONFIRM_FRAMES`` frames ago — a body cut in two for a frame or
        two (a lunge with an arm thrown forward) more likely than a person stepping out from behind."""
        return sum(1 for pid in ids if pid in self._born_beside and self._seen_frames.get(pid, 0) < CONFIRM_FRAMES)

    def _behind(self, place: tuple[float, float], other: tuple[float, float]) -> bool:
        """Whether ``place`` is in the camera's shadow of someone standing at ``other`` (seen from above:
        farther from the camera, within the body's half width of the line from the camera through them)."""
        if self._camera is None:
            return False
        cx, cy = self._camera
        ox, oy, px, py = other[0] - cx, other[1] - cy, place[0] - cx, place[1] - cy
        near = math.hypot(ox, oy)
        if near < 1e-6 or math.hypot(px, py) <= near:
            return False
        along = (px * ox + py * oy) / near
        return along > 0.0 and abs(px * oy - py * ox) / near <= SHADOW_HALF_WIDTH_M

    def count(self, ids: list[int], centres: list[tuple[float, float]],
              predicted: dict[int, tuple[tuple[float, float], int]], t: float) -> int:
        """How many people are hidden at time ``t``: ``ids`` are seen at ``centres``; ``predicted`` is
        every track's predicted place and how many frames it has gone unseen."""
        self._note_seen(ids, centres, t)
        seen = dict(zip(ids, centres, strict=True))
        # tracks that appeared lately and have not yet been taken for someone lost: (appeared, where, id)
        pool = [(self._back_since[pid], c, pid) for pid, c in seen.items() if pid not in self._explained.values()]
        count = 0
        for pid in sorted(self._hidden_now(centres, predicted, t), key=lambda h: -self._seen_at[h]):
            if self._explained.get(pid) in self._seen_at:
                continue  # taken over earlier by a track still remembered: that track is this person
            place = predicted[pid][0]
            last_seen, last_place = self._seen_at[pid], self._seen_place[pid]

            def off(c: tuple[float, float], last: tuple[float, float] = last_place,
                    ahead: tuple[float, float] = place) -> float:  # from where last seen or where predicted
                return min(math.dist(last, c), math.dist(ahead, c))
            found = [k for k, (back, c, taker) in enumerate(pool)
                     if off(c) <= self._near_m and (back > last_seen or (  # appeared after they were last seen,
                         taker in self._born_beside and back >= last_seen - REBORN_S))]  # or split off them
            if found:  # found again under another id: that one is this person (and counted at once)
                taker = pool.pop(min(found, key=lambda k: off(pool[k][1])))[2]
                self._explained[pid] = taker
                self._born_beside.discard(taker)
                # the taker is this person, seen as long as they were (so it counts if it is lost in turn)
                self._seen_frames[taker] = self._seen_frames.get(taker, 0) + self._seen_frames.get(pid, 0)
            else:
                count += 1
        self._forget(t)
        return count

    def _note_seen(self, ids: list[int], centres: list[tuple[float, float]], t: float) -> None:
        known = [c for pid, c in zip(ids, centres, strict=True) if pid in self._first_seen]
        for pid, c in zip(ids, centres, strict=True):
            if pid not in self._first_seen and any(math.dist(c, k) <= self._near_m for k in known):
                self._born_beside.add(pid)
            if self._seen_at.get(pid) != self._last_t:
                self._back_since[pid] = t
                self._explained.pop(pid, None)  # seen again itself
            self._seen_at[pid] = t
            self._seen_place[pid] = c
            self._first_seen.setdefault(pid, t)
            self._seen_frames[pid] = self._seen_frames.get(pid, 0) + 1
        self._last_t = t

    def _hidden_now(self, centres: list[tuple[float, float]], predicted: dict[int, tuple[tuple[float, float], int]],
                    t: float) -> list[int]:
        """The tracks unseen now that may be hidden: seen long enough, lately, and near or behind someone."""
        out = []
        for pid, (place, unseen) in predicted.items():
            if unseen == 0 or t - self._seen_at.get(pid, -math.inf) > self._memory_s:
                continue
            if self._seen_frames.get(pid, 0) < HIDDEN_AFTER_FRAMES:
                continue  # seen for a moment only: more likely a blob split in two than a person
            last = self._seen_place[pid]  # where predicted, or (a jump thrown the prediction off) last seen
            if any(min(math.dist(place, c), math.dist(last, c)) <= self._near_m or self._behind(place, c)
                   or self._behind(last, c) for c in centres):
                out.append(pid)
        return out

    def _forget(self, t: float) -> None:
        for pid in [p for p, seen in self._seen_at.items() if t - seen > self._memory_s + 1.0]:
            del self._seen_at[pid]
            for table in (self._first_seen, self._seen_frames, self._seen_place, self._back_since, self._explained):
                table.pop(pid, None)
            self._born_beside.discard(pid)
