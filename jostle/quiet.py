"""pybullet prints its build time on the C-level stderr when first imported: import it once with
file descriptor 2 pointed at /dev/null, so the user sees only jostle's own lines."""

from __future__ import annotations

import os
import sys


def import_pybullet_quietly() -> None:
    if "pybullet" in sys.modules:
        return
    sys.stderr.flush()
    saved = os.dup(2)
    try:
        with open(os.devnull, "wb") as null:
            os.dup2(null.fileno(), 2)
            import pybullet  # noqa: F401
    finally:
        os.dup2(saved, 2)
        os.close(saved)
