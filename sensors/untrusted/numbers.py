"""Numbers and timestamps at a boundary (config, CLI flag, recording, serial line): finite, in range."""

from __future__ import annotations

import math
import numbers
from typing import overload

from sensors.untrusted.errors import UntrustedInput, shorten
from sensors.untrusted.limits import TIMESTAMP_MAX_GAP_NS, TIMESTAMP_MAX_NS


@overload
def finite(value: int, what: str, lo: float | None = None, hi: float | None = None) -> int: ...
@overload
def finite(value: float, what: str, lo: float | None = None, hi: float | None = None) -> float: ...
@overload
def finite(value: object, what: str, lo: float | None = None, hi: float | None = None) -> int | float: ...
def finite(value: object, what: str, lo: float | None = None, hi: float | None = None) -> int | float:
    """``value`` if it is a real number (int or float, not bool, not a string), finite, and within
    [``lo``, ``hi``] (either bound optional, inclusive); else one line naming ``what``, e.g.
    ``[run] duration_s: expected a finite number, got nan``. Units are the caller's (say them in
    ``what``). An int comes back an int, a float a float (numpy scalars as Python ones)."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise UntrustedInput(what, f"expected a number, got {shorten(value)}")
    number: int | float = int(value) if isinstance(value, numbers.Integral) else float(value)
    if isinstance(number, float) and not math.isfinite(number):
        raise UntrustedInput(what, f"expected a finite number, got {number!r}")
    if (lo is not None and number < lo) or (hi is not None and number > hi):
        raise UntrustedInput(what, f"expected a number {_range(lo, hi)}, got {shorten(number)}")
    return number


def whole(value: object, what: str, lo: int | None = None, hi: int | None = None) -> int:
    """``value`` if it is an integer (not bool, not a float such as 1.5 or 1e20) within [``lo``,
    ``hi``]: counts, seeds (lo=0), ports, sizes; one line naming ``what`` otherwise."""
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise UntrustedInput(what, f"expected a whole number, got {shorten(value)}")
    number = int(value)
    if (lo is not None and number < lo) or (hi is not None and number > hi):
        raise UntrustedInput(what, f"expected a whole number {_range(lo, hi)}, got {shorten(number)}")
    return number


def _range(lo: float | None, hi: float | None) -> str:
    if lo is not None and hi is not None:
        return f"from {_bound(lo)} to {_bound(hi)}"
    return f"≥ {_bound(lo)}" if lo is not None else f"≤ {_bound(hi)}"


def _bound(x: float | None) -> str:
    return str(x) if isinstance(x, int) else f"{x:g}"


class Timeline:
    """The timestamps of one stream (integer ns), which must not go back nor jump ahead by more than
    ``max_gap_ns``, and lie in 0 … ``TIMESTAMP_MAX_NS``. ``flag(t)`` says what is wrong with the next
    stamp (None if fine, and then it becomes the last); ``check(t)`` raises that as UntrustedInput.
    A refused stamp is not taken: the stream goes on from the last good one."""

    def __init__(self, what: str, max_gap_ns: int = TIMESTAMP_MAX_GAP_NS) -> None:
        self.what = what
        self.max_gap_ns = max_gap_ns
        self.last_ns: int | None = None
        self.refused = 0

    def flag(self, t_ns: object) -> str | None:
        """None if ``t_ns`` may follow the last stamp taken (it is taken), else why not (one line)."""
        problem = self._problem(t_ns)
        if problem is None:
            assert isinstance(t_ns, numbers.Integral)
            self.last_ns = int(t_ns)
        else:
            self.refused += 1
        return problem

    def check(self, t_ns: object) -> int:
        """``t_ns`` as an int if ``flag`` takes it; else ``UntrustedInput`` naming ``what``."""
        problem = self.flag(t_ns)
        if problem is not None:
            raise UntrustedInput(self.what, problem)
        assert isinstance(t_ns, numbers.Integral)
        return int(t_ns)

    def _problem(self, value: object) -> str | None:
        if isinstance(value, bool) or not isinstance(value, numbers.Integral):
            return f"a timestamp must be whole nanoseconds, got {shorten(value)}"
        t = int(value)
        if not 0 <= t <= TIMESTAMP_MAX_NS:
            return f"timestamp {shorten(t)} ns is outside 0 … {TIMESTAMP_MAX_NS} ns"
        if self.last_ns is None:
            return None
        if t < self.last_ns:
            return f"timestamp {t} ns goes back {self.last_ns - t} ns from the one before ({self.last_ns} ns)"
        if t - self.last_ns > self.max_gap_ns:
            return (f"timestamp {t} ns is {(t - self.last_ns) / 1e9:.6g} s after the one before "
                    f"({self.last_ns} ns), more than the {self.max_gap_ns / 1e9:g} s allowed")
        return None
