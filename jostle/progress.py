"""Progress of long work: a tqdm bar on a terminal, a plain line every few seconds otherwise (logs, CI)."""

from __future__ import annotations

import sys
import time
from types import TracebackType
from typing import Any


class Progress:
    def __init__(self, total: float | None, desc: str, unit: str, *, enabled: bool = True,
                 every_s: float = 5.0) -> None:
        self.total = total
        self.desc = desc
        self.unit = unit
        self.n = 0.0
        self._every = every_s
        self._last = time.perf_counter()
        self._start = self._last
        self._bar: Any = None
        self._enabled = enabled
        if enabled and sys.stderr.isatty():
            from tqdm import tqdm

            fmt = "{desc}: {percentage:3.0f}%|{bar}| {n:.1f}/{total:.1f} " + unit + " [{elapsed}<{remaining}]"
            self._bar = tqdm(total=total, desc=desc, leave=False, bar_format=fmt if total else None,
                             unit=unit, mininterval=0.25)

    def update_to(self, n: float) -> None:
        """Progress is now ``n`` (in ``unit``): for a count the work itself keeps, e.g. a world's time."""
        self.update(n - self.n)

    def update(self, n: float) -> None:
        self.n += n
        if self._bar is not None:
            self._bar.update(n)
            return
        if not self._enabled:
            return
        now = time.perf_counter()
        if now - self._last >= self._every:
            self._last = now
            of = f"/{self.total:.1f}" if self.total else ""
            print(f"{self.desc}: {self.n:.1f}{of} {self.unit} ({now - self._start:.0f} s)", file=sys.stderr)

    def close(self) -> None:
        if self._bar is not None:
            self._bar.close()
            self._bar = None

    def __enter__(self) -> Progress:
        return self

    def __exit__(self, t: type[BaseException] | None, e: BaseException | None, tb: TracebackType | None) -> None:
        self.close()
