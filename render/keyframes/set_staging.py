"""Changes to a keyframe set's folder as one transaction: staged, checked, then committed.

An import (``jostle keyframes import``) reads the set's manifest and pose files through
``sensors.untrusted`` (bounded, regular files only), keeps every file it changes in memory
(``StagedSet.write``), and on ``commit`` first loads the whole changed set from a staging folder
inside the set's folder (so every check ``KeyframeSet.load`` makes runs before anything is touched),
then writes each new pose file with ``write_owned`` (atomic, regular files only) and the manifest
last. Any failure leaves the set's folder as it was: files and folders it made are removed.
"""

from __future__ import annotations

import re
import secrets
import shutil
from pathlib import Path

from render.keyframes.set_file import KeyframeError
from sensors.untrusted import (
    MissingInput,
    UntrustedInput,
    load_toml,
    parse_toml,
    read_text,
    shorten,
    write_owned,
)
from sensors.untrusted.limits import KEYFRAME_SET, POSE_FILE

MANIFEST = "keyframes.toml"
_NAME = re.compile(r"[A-Za-z0-9_-]{1,64}")


def checked_name(value: object, what: str) -> str:
    """``value`` if it is a name safe as a file stem and a bare TOML key (letters, digits, ``_``,
    ``-``; 1–64 characters), else KeyframeError naming ``what`` (an animation or pose name)."""
    if isinstance(value, str) and _NAME.fullmatch(value):
        return value
    raise KeyframeError(f"{what}: expected a name of letters, digits, '_' or '-' (at most 64), got {shorten(value)}")


class StagedSet:
    """The files of the keyframe set in ``set_dir`` (paths relative to it, e.g. ``poses/walk.toml``)
    as they will be after the import: read from disk until written here."""

    def __init__(self, set_dir: Path) -> None:
        self.set_dir = Path(set_dir)
        self.changed: dict[str, str] = {}  # relative path → new text, in the order written

    @property
    def manifest(self) -> Path:
        return self.set_dir / MANIFEST

    def text(self, rel: str) -> str | None:
        """The file's text as staged, or as on disk (bounded), or None if it does not exist."""
        if rel in self.changed:
            return self.changed[rel]
        limit = KEYFRAME_SET.max_bytes if rel == MANIFEST else POSE_FILE.max_bytes
        try:
            return read_text(self.set_dir / rel, limit, "keyframe file")
        except MissingInput:
            return None
        except UntrustedInput as e:
            raise KeyframeError(str(e)) from None

    def pose_names(self, rel: str) -> set[str]:
        """The pose names a pose file defines, as staged or on disk (empty when missing or unreadable)."""
        try:
            if rel in self.changed:
                return set(parse_toml(self.changed[rel], self.set_dir / rel, POSE_FILE))
            return set(load_toml(self.set_dir / rel, POSE_FILE, "pose file"))
        except UntrustedInput:
            return set()

    def write(self, rel: str, text: str) -> None:
        self.changed[rel] = text

    def commit(self) -> Path:
        """Check the staged set (``KeyframeSet.load``), then write it: pose files first, the manifest
        last. Returns the manifest; on any failure the folder is left as it was and the error raised."""
        missing = [d for d in (*reversed(self.set_dir.parents), self.set_dir, self.set_dir / "poses") if not d.exists()]
        made: list[Path] = []
        written: list[Path] = []
        try:
            for d in missing:  # outermost first; each removed again on failure
                d.mkdir()
                made.append(d)
            self._check()
            order = sorted(self.changed, key=lambda rel: rel == MANIFEST)  # the manifest last
            for rel in order:
                target = self.set_dir / rel
                existed = target.exists()
                write_owned(target, self.changed[rel])
                if not existed:
                    written.append(target)
        except BaseException:
            for f in written:
                f.unlink(missing_ok=True)
            for d in reversed(made):
                shutil.rmtree(d, ignore_errors=True)
            raise
        return self.manifest

    def _check(self) -> None:
        """Load the set as staged from a copy in ``.staging-…`` inside the set's folder."""
        from render.keyframes.keyframe_set import KeyframeSet

        manifest_text = self.changed.get(MANIFEST) or self.text(MANIFEST)
        if manifest_text is None:
            raise KeyframeError(f"{self.manifest}: no such keyframe manifest")
        staging = self.set_dir / f".staging-{secrets.token_hex(6)}"
        try:
            (staging / "poses").mkdir(parents=True)
            files = _listed(manifest_text)
            for rel in files:
                text = self.text(rel)
                if text is not None and _inside(rel):
                    (staging / rel).parent.mkdir(parents=True, exist_ok=True)
                    (staging / rel).write_text(text, encoding="utf-8")
            (staging / MANIFEST).write_text(manifest_text, encoding="utf-8")
            try:
                KeyframeSet.load(staging / MANIFEST)
            except (KeyframeError, UntrustedInput) as e:
                raise KeyframeError(str(e).replace(str(staging), str(self.set_dir))) from None
        finally:
            shutil.rmtree(staging, ignore_errors=True)


def commit(staged: StagedSet, source: Path) -> Path:
    """``staged.commit()``, a refusal naming the imported file ``source`` as well as the set."""
    try:
        return staged.commit()
    except KeyframeError as e:
        raise KeyframeError(f"{source}: not imported, the set would not load: {e}") from None


def _listed(manifest_text: str) -> list[str]:
    """The pose files a manifest lists (its ``poses``), [] when it lists none or is not TOML."""
    try:
        files = parse_toml(manifest_text, MANIFEST, KEYFRAME_SET).get("poses", [])
    except UntrustedInput:
        return []
    return [str(f) for f in files] if isinstance(files, list) else []


def _inside(rel: str) -> bool:
    """Whether ``rel`` stays inside the set's folder (no absolute path, no ``..``)."""
    p = Path(rel)
    return not p.is_absolute() and ".." not in p.parts
