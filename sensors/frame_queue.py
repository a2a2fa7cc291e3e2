"""FrameQueue: the small bounded queue between a driver's reader thread and ``read(timeout)``.

When it is full the oldest frame is dropped (the newest is what the loop wants) and counted.
``get(timeout)`` waits at most ``timeout`` on a condition; ``until`` lets a driver end the wait
early on its own state (e.g. FAILED), and ``wake()`` makes waiters look at that state again.
"""

from __future__ import annotations

import threading
from collections import deque
from collections.abc import Callable

from sensors.base import Frame


class FrameQueue:
    def __init__(self, maxlen: int) -> None:
        if maxlen < 1:
            raise ValueError(f"maxlen: expected an integer >= 1, got {maxlen}")
        self.maxlen = maxlen
        self._arrived = threading.Condition(threading.Lock())
        self._frames: deque[Frame] = deque(maxlen=maxlen)
        self._dropped = 0

    @property
    def dropped(self) -> int:
        """Frames dropped because the queue was full (since construction or the last ``reset``)."""
        with self._arrived:
            return self._dropped

    def __len__(self) -> int:
        with self._arrived:
            return len(self._frames)

    def put(self, frame: Frame) -> bool:
        """Append ``frame`` and wake a waiting reader; False when the oldest frame was dropped for it."""
        with self._arrived:
            full = len(self._frames) == self.maxlen
            if full:
                self._dropped += 1
            self._frames.append(frame)
            self._arrived.notify_all()
            return not full

    def get(self, timeout: float, until: Callable[[], bool] | None = None) -> Frame | None:
        """The oldest frame, waiting at most ``timeout`` s for one; None if none came (or ``until()`` turned true)."""
        with self._arrived:
            if not self._frames and not (until is not None and until()):
                self._arrived.wait_for(lambda: bool(self._frames) or (until is not None and until()),
                                       timeout=max(timeout, 0.0))
            return self._frames.popleft() if self._frames else None

    def wake(self) -> None:
        """Make waiting readers check their ``until`` again (call after changing the state it reads)."""
        with self._arrived:
            self._arrived.notify_all()

    def clear(self) -> None:
        """Forget the waiting frames; the dropped count stays."""
        with self._arrived:
            self._frames.clear()

    def reset(self) -> None:
        """Forget the waiting frames and zero the dropped count (a fresh open)."""
        with self._arrived:
            self._frames.clear()
            self._dropped = 0
