"""The temporary folder the hostile cases live in, and the special files they are made of.

Everything is written under ``root``: a copy of ``configs/`` (the demo's recording linked, not
copied), one output folder per case, FIFOs, and twins of ``/dev/zero`` and ``/dev/full`` made with
``mknod`` in ``root`` (the real device nodes are never named). Making a device twin needs root
(CAP_MKNOD); where that fails the case that needs it is left out and listed in ``skipped``.
"""

from __future__ import annotations

import os
import shutil
import stat
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]


class Workspace:
    """``root``: the folder; ``configs``: the copy of the shipped configs; ``skipped``: cases left out."""

    def __init__(self, root: Path) -> None:
        self.root = Path(root)
        self.configs = self.root / "configs"
        self.skipped: list[str] = []
        if not self.configs.exists():
            shutil.copytree(REPO / "configs", self.configs, ignore=shutil.ignore_patterns("*.mcap"))
            (self.configs / "recordings" / "demo.mcap").symlink_to(REPO / "configs" / "recordings" / "demo.mcap")

    def out(self, name: str) -> Path:
        """A fresh output folder for one case."""
        path = self.root / "out" / name
        path.mkdir(parents=True, exist_ok=True)
        return path

    def file(self, name: str, data: bytes | str) -> Path:
        path = self.root / "in" / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(data.encode() if isinstance(data, str) else data)
        return path

    def fifo(self, name: str) -> Path:
        path = self.root / "in" / name
        path.parent.mkdir(parents=True, exist_ok=True)
        if path.is_symlink() or (path.exists() and not stat.S_ISFIFO(path.lstat().st_mode)):
            path.unlink()  # a run replaced it: make it again
        if not path.exists():
            os.mkfifo(path)
        return path

    def device_twin(self, name: str, minor: int) -> Path | None:
        """A character device 1:minor (5 = zero, 7 = full) at ``in/name``, or None if mknod fails."""
        path = self.root / "in" / name
        path.parent.mkdir(parents=True, exist_ok=True)
        if path.is_symlink() or (path.exists() and not stat.S_ISCHR(path.lstat().st_mode)):
            path.unlink()
        if not path.exists():
            try:
                os.mknod(path, stat.S_IFCHR | 0o666, os.makedev(1, minor))
            except OSError:
                return None
        return path

    def config(self, name: str, text: str) -> Path:
        """A config beside the shipped ones (so their relative paths resolve) holding ``text``."""
        path = self.configs / f"{name}.toml"
        path.write_text(text)
        return path

    def demo_with(self, name: str, old: str, new: str) -> Path:
        """The demo config with ``old`` replaced by ``new`` (which must occur)."""
        text = (self.configs / "demo.toml").read_text()
        if old not in text:
            raise ValueError(f"demo.toml has no {old!r} to replace")
        return self.config(name, text.replace(old, new, 1))

    def run_argv(self, config: Path, name: str, *extra: str) -> tuple[str, ...]:
        """``jostle run CONFIG`` headless, without video, for half a second of simulated time."""
        return ("run", str(config), "--headless", "--no-video", "--quiet", "--duration", "0.5",
                "--out", str(self.out(name)), *extra)


def is_char_device(path: Path) -> str | None:
    """A check: the problem if ``path`` is no longer a character device (it was replaced)."""
    try:
        mode = path.lstat().st_mode
    except OSError:
        return f"{path} was removed"
    return None if stat.S_ISCHR(mode) else f"{path} was replaced by a {'file' if stat.S_ISREG(mode) else 'node'}"


def is_fifo(path: Path) -> str | None:
    try:
        mode = path.lstat().st_mode
    except OSError:
        return f"{path} was removed"
    return None if stat.S_ISFIFO(mode) else f"{path} (a FIFO) was replaced"
