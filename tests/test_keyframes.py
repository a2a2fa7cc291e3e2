"""Keyframe sets: the shipped humanoid set, its interpolation (exact, convex, periodic, continuous), and
the loader's one-line errors."""

from __future__ import annotations

import math
import tomllib
import warnings
from pathlib import Path

import numpy as np
import pytest

from render.keyframes import KeyframeError, KeyframeQuery, KeyframeSet, Pose, query_from_snapshot
from render.keyframes.default_set import build_default_sets
from render.keyframes.interp import STANDARD_AXES as AXES
from render.keyframes.interp import Curve
from sim.snapshot import CharacterSnapshot, CharacterState

SHIPPED = Path(__file__).resolve().parent.parent / "configs" / "keyframes" / "humanoid" / "keyframes.toml"
PERIODIC = (False, False, True, True)


@pytest.fixture(scope="module", params=["humanoid", "critter"])
def kset(request: pytest.FixtureRequest) -> KeyframeSet:
    return KeyframeSet.load(SHIPPED.parent.parent / request.param / "keyframes.toml")


def angles(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Rotation angle between unit quaternions (..., 4), sign-blind; precise near 0 (arccos is not)."""
    chord = np.minimum(np.linalg.norm(a - b, axis=-1), np.linalg.norm(a + b, axis=-1))
    return 4.0 * np.arcsin(np.clip(chord / 2.0, 0.0, 1.0))


def pose_change(p: Pose, q: Pose) -> tuple[np.ndarray, np.ndarray]:
    """Per query: largest joint/root rotation change (rad) and root offset change (m)."""
    return angles(p.rotations(), q.rotations()).max(axis=-1), np.linalg.norm(
        p.root_offset - q.root_offset, axis=-1
    )


def on_curve(curve: Curve, coord: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Queries (N, 4) on an animation's curve at the given coordinates; "any" coordinates drawn at random."""
    q = np.zeros((len(coord), 4))
    for c in range(4):
        if c == curve.axis:
            q[:, c] = coord
        elif curve.base[c] is None:
            q[:, c] = rng.uniform(0.0, 1.0, len(coord)) if PERIODIC[c] else rng.uniform(-0.5, 0.5, len(coord))
        else:
            q[:, c] = curve.base[c]
    return q


def key_pose(kset: KeyframeSet, curve: Curve, slot: int, q: np.ndarray) -> Pose:
    """What key ``slot`` of an animation stores at queries q: its pose, or the referenced family's pose."""
    key = curve.keys[slot]
    if isinstance(key, str):
        weights = kset.family_weights(key, q)
    else:
        weights = np.zeros((len(q), len(kset.key_names)))
        weights[:, key] = 1.0
    return kset.pose_from_weights(weights)


# ------------------------------------------------------------------------------ the shipped set


def test_shipped_sets_are_what_the_builder_makes(tmp_path: Path) -> None:
    manifests = build_default_sets(tmp_path)
    shipped = SHIPPED.parent.parent
    made = sorted(p.relative_to(tmp_path) for p in tmp_path.rglob("*.toml"))
    assert made == sorted(p.relative_to(shipped) for p in shipped.rglob("*.toml"))
    for rel in made:  # floats rounded to 4–6 decimals: another CPU may round a last digit the other way
        built, ours = tomllib.loads((tmp_path / rel).read_text()), tomllib.loads((shipped / rel).read_text())
        assert _same_written_numbers(built, ours), f"{rel} is stale: rerun `jostle keyframes build-default`"
    assert manifests == [tmp_path / "humanoid" / "keyframes.toml", tmp_path / "critter" / "keyframes.toml"]


def _same_written_numbers(a: object, b: object) -> bool:
    """Two parsed TOML trees equal in shape and text, their floats within one unit of the coarsest
    written digit (1e-4): a tolerance, not bit for bit, for files made on another machine."""
    if isinstance(a, dict) and isinstance(b, dict):
        return a.keys() == b.keys() and all(_same_written_numbers(a[k], b[k]) for k in a)
    if isinstance(a, list) and isinstance(b, list):
        return len(a) == len(b) and all(_same_written_numbers(x, y) for x, y in zip(a, b, strict=True))
    if isinstance(a, float) or isinstance(b, float):
        return isinstance(a, int | float) and isinstance(b, int | float) and abs(a - b) <= 1.5e-4
    return a == b


def test_shipped_set_has_walk_staggers_falls_and_get_ups(kset: KeyframeSet) -> None:
    names = {a.name for a in kset.animations}
    assert {"walk_dx000", "fall_forward", "fall_backward", "fall_right", "fall_left"} <= names
    assert {"stagger_forward", "stagger_backward", "stagger_right", "stagger_left"} <= names
    assert {"stand_up_faceup", "stand_up_facedown"} <= names
    # at least the paper's set: 12 one-dimensional animations, 57 keyframes
    assert len(kset.animations) >= 12 and sum(len(a.coords) for a in kset.animations) >= 57
    assert kset.behaviours == ("stand_up", "walk") and kset.default_behaviour == "walk"
    walk = kset.families["walk"]
    assert walk.loft == AXES.index("dx") and all(len(m.coords) == 8 for m in walk.members)


# ------------------------------------------------------------------------------ interpolation


def test_exact_at_every_key(kset: KeyframeSet) -> None:
    rng = np.random.default_rng(1)
    for curve in kset.animations:
        for slot, x in enumerate(curve.coords):
            q = on_curve(curve, np.full(5, x), rng)
            got = kset.evaluate(q, [curve.behaviour] * len(q))
            want = key_pose(kset, curve, slot, q)
            rot, off = pose_change(got, want)
            assert rot.max() < 1e-7 and off.max() < 1e-9, f"{curve.name} key {slot} ({AXES[curve.axis]}={x})"


def test_weights_are_convex_everywhere(kset: KeyframeSet) -> None:
    rng = np.random.default_rng(2)
    n = 3000
    q = np.column_stack(
        [rng.uniform(-3.2, 3.2, n), rng.uniform(-3.2, 3.2, n), rng.uniform(-2, 3, n), rng.uniform(-2, 3, n)]
    )
    q[:500, :2] = 0.0  # on the walk surface, where five families meet
    behaviours = rng.choice(["walk", "stand_up"], n).tolist()
    w = kset.weights_array(q, behaviours)
    assert w.min() >= 0.0
    np.testing.assert_allclose(w.sum(axis=1), 1.0, atol=1e-12)


def test_no_overshoot_between_neighbouring_keys(kset: KeyframeSet) -> None:
    """Between two keys of an animation every rotation lies on the arc between theirs and the root
    offset on the segment between theirs: its distance to each end never exceeds the ends' distance."""
    rng = np.random.default_rng(3)
    for curve in kset.animations:
        m = len(curve.coords)
        pairs = [(i, i + 1) for i in range(m - 1)] + ([(m - 1, 0)] if PERIODIC[curve.axis] else [])
        for i, j in pairs:
            x0, x1 = curve.coords[i], curve.coords[j] + (1.0 if j < i else 0.0)
            u = rng.uniform(0.0, 1.0, 40)
            q = on_curve(curve, x0 + u * (x1 - x0), rng)
            got = kset.pose_from_weights(kset.weights_array(q, [curve.behaviour] * len(q)))
            a, b = key_pose(kset, curve, i, q), key_pose(kset, curve, j, q)
            mutual = angles(a.rotations(), b.rotations())
            assert np.all(angles(got.rotations(), a.rotations()) <= mutual + 1e-9), f"{curve.name} {i}-{j}"
            assert np.all(angles(got.rotations(), b.rotations()) <= mutual + 1e-9), f"{curve.name} {i}-{j}"
            span = np.linalg.norm(a.root_offset - b.root_offset, axis=-1)
            assert np.all(np.linalg.norm(got.root_offset - a.root_offset, axis=-1) <= span + 1e-12)


def test_blends_stay_within_the_keys_they_blend(kset: KeyframeSet) -> None:
    """Anywhere in Q a rotation is no farther from any key it blends than those keys are from each other,
    measured on the unit quaternions as blended: signed to agree with the heaviest key (distances on the
    sign-blind rotation angle can be shorter for rotations near a half turn apart)."""
    rng = np.random.default_rng(4)
    n = 400
    q = np.column_stack(
        [rng.uniform(-2, 2, n), rng.uniform(-2, 2, n), rng.uniform(0, 1, n), rng.uniform(0, 1, n)]
    )

    def arc(a: np.ndarray, b: np.ndarray) -> np.ndarray:
        return 2.0 * np.arcsin(np.clip(np.linalg.norm(a - b, axis=-1) / 2.0, 0.0, 1.0))

    for behaviour in kset.behaviours:
        w = kset.weights_array(q, [behaviour] * n)
        got = kset.pose_from_weights(w).rotations()
        for k in range(n):
            used = np.nonzero(w[k] > 0)[0]
            ref = kset.key_rotations[np.argmax(w[k])]
            keys = kset.key_rotations[used]  # (U, 1 + J, 4)
            keys = np.where(np.sum(keys * ref, axis=-1, keepdims=True) < 0, -keys, keys)
            blended = np.where(np.sum(got[k] * ref, axis=-1, keepdims=True) < 0, -got[k], got[k])
            diameter = arc(keys[:, None], keys[None, :]).max(axis=(0, 1))  # per joint
            assert np.all(arc(blended[None], keys) <= diameter[None] + 1e-9)


def test_periodic_in_dx_and_dz(kset: KeyframeSet) -> None:
    for tx in (0.0, 0.4, -0.9):
        for dx in (0.0, 0.3):
            at0 = kset.pose(KeyframeQuery(tx, 0.0, dx, 0.0, "walk"))
            at1 = kset.pose(KeyframeQuery(tx, 0.0, dx, 1.0, "walk"))
            almost = kset.pose(KeyframeQuery(tx, 0.0, dx, 1.0 - 1e-9, "walk"))
            for other in (at1, almost):
                rot, off = pose_change(at0, other)
                assert rot < 1e-6 and off < 1e-9
        side0 = kset.pose(KeyframeQuery(0.0, 0.0, 0.0, 0.3, "walk"))
        side1 = kset.pose(KeyframeQuery(0.0, 0.0, 1.0, 0.3, "walk"))
        assert pose_change(side0, side1)[0] < 1e-9


def test_continuous_small_steps_give_small_changes(kset: KeyframeSet) -> None:
    """Random points (half of them near Θ = 0 where families meet, some at the Dz seam), random steps.

    Measured here: at most ~15 rad (joint rotation) and ~1 m (root offset) per unit of step, the same
    for steps of 1e-3 and 1e-4 (so no jumps). A jump anywhere would show at the 1e-6 step.
    """
    rng = np.random.default_rng(5)
    n = 4000
    q = np.column_stack(
        [rng.uniform(-1.8, 1.8, n), rng.uniform(-1.8, 1.8, n), rng.uniform(0, 1, n), rng.uniform(0, 1, n)]
    )
    q[: n // 2, :2] *= 0.02
    q[: n // 8, 3] = rng.choice([0.0, 1.0], n // 8) + rng.uniform(-1e-6, 1e-6, n // 8)
    for behaviour in kset.behaviours:
        base = kset.pose_from_weights(kset.weights_array(q, [behaviour] * n))
        for h, max_rad, max_m in ((1e-3, 0.03, 2e-3), (1e-6, 3e-5, 2e-6)):
            step = rng.normal(size=(n, 4))
            step *= h / np.linalg.norm(step, axis=1, keepdims=True)
            moved = kset.pose_from_weights(kset.weights_array(q + step, [behaviour] * n))
            rot, off = pose_change(base, moved)
            assert rot.max() < max_rad and off.max() < max_m, (behaviour, h, rot.max(), off.max())


def test_get_up_ends_in_the_walk(kset: KeyframeSet) -> None:
    """Upright, standing up and walking give the same pose: switching B there does not pop."""
    for dx, dz in ((0.0, 0.0), (0.3, 0.7), (0.9, 0.2)):
        walk = kset.pose(KeyframeQuery(0.0, 0.0, dx, dz, "walk"))
        up = kset.pose(KeyframeQuery(0.0, 0.0, dx, dz, "stand_up"))
        assert max(pose_change(walk, up)) < 1e-9


def test_lying_pose_is_shared_by_the_fall_and_the_get_up(kset: KeyframeSet) -> None:
    for tx in (math.pi / 2, -math.pi / 2):
        fallen = kset.pose(KeyframeQuery(tx, 0.0, 0.4, 0.6, "walk"))
        rising = kset.pose(KeyframeQuery(tx, 0.0, 0.4, 0.6, "stand_up"))
        assert max(pose_change(fallen, rising)) < 1e-9


def test_one_query_and_a_batch_agree(kset: KeyframeSet) -> None:
    qs = [KeyframeQuery(0.3, -0.2, 0.1, 0.9, "walk"), KeyframeQuery(-1.0, 0.0, 0.5, 0.5, "stand_up")]
    batch = kset.poses(qs)
    for i, q in enumerate(qs):
        one = kset.pose(q)
        np.testing.assert_array_equal(one.joint_rotations, batch.joint_rotations[i])
        np.testing.assert_array_equal(one.root_offset, batch.root_offset[i])


def test_unknown_behaviour_falls_back_to_the_default_once(kset: KeyframeSet) -> None:
    fresh = KeyframeSet.load(kset.source or SHIPPED)
    q = KeyframeQuery(0.2, 0.0, 0.0, 0.3, "juggle")
    with pytest.warns(UserWarning, match="juggle"):
        got = fresh.pose(q)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        fresh.pose(q)
    want = kset.pose(KeyframeQuery(0.2, 0.0, 0.0, 0.3, "walk"))
    assert max(pose_change(got, want)) < 1e-12


def test_query_from_snapshot_maps_tilt_and_travel() -> None:
    c = CharacterSnapshot(
        name="ann",
        position=(0.0, 0.0, 0.75),
        orientation=(0.0, 0.0, 0.0, 1.0),
        velocity=(0.0, 0.0, 0.0),
        angular_velocity=(0.0, 0.0, 0.0),
        heading=0.0,
        tilt=(0.25, -0.5),
        d_front=3.75,
        d_side=-0.25,
        state=CharacterState.STAGGER,
        behaviour="walk",
        intent="wander",
        face_up=None,
        contact_force_n=0.0,
        height=1.5,
    )
    q = query_from_snapshot(c)
    assert (q.theta_x, q.theta_z, q.dx, q.dz, q.behaviour) == (0.25, -0.5, 0.75, 0.75, "walk")


def test_query_rejects_non_finite_values() -> None:
    with pytest.raises(ValueError, match="^theta_x: expected a finite number"):
        KeyframeQuery(float("nan"), 0.0, 0.0, 0.0, "walk")
    with pytest.raises(ValueError, match="^behaviour:"):
        KeyframeQuery(0.0, 0.0, 0.0, 0.0, "")


# ------------------------------------------------------------------------------ load errors


def write_set(folder: Path, *, pose_extra: str = "", anim_extra: str = "", keys: str = "") -> Path:
    """A small valid set (a 2-key walk and a fall that starts from it), with text spliced in."""
    (folder / "poses.toml").write_text(
        "[a]\nroot_offset = [0.0, 0.0, 0.0]\n[a.joints]\nright_knee = -20.0\n"
        "[b]\n[b.joints]\nleft_knee = -20.0\n"
        "[down]\nroot_rotation = { axis = [0, 0, 1], degrees = -80 }\n" + pose_extra,
        encoding="utf-8",
    )
    keys = keys or '{ at = 0.0, pose = "a" }, { at = 0.5, pose = "b" }'
    (folder / "keyframes.toml").write_text(
        'format = 1\nskeleton = "humanoid"\nheight = 1.6\ndefault_behaviour = "walk"\nposes = ["poses.toml"]\n'
        '[[animation]]\nname = "walk"\nbehaviour = "walk"\naxis = "dz"\n'
        "at = { theta_x = 0.0, theta_z = 0.0, dx = 0.0 }\n"
        f"keys = [{keys}]\n"
        '[[animation]]\nname = "fall"\nbehaviour = "walk"\naxis = "theta_x"\n'
        'at = { theta_z = 0.0, dx = "any", dz = "any" }\n'
        'keys = [{ at = 0.0, family = "walk" }, { at = 1.5, pose = "down" }]\n' + anim_extra,
        encoding="utf-8",
    )
    return folder / "keyframes.toml"


def load_error(path: Path) -> str:
    with pytest.raises(KeyframeError) as info:
        KeyframeSet.load(path)
    msg = str(info.value)
    assert "\n" not in msg
    return msg


def test_the_small_set_loads(tmp_path: Path) -> None:
    s = KeyframeSet.load(write_set(tmp_path))
    assert len(s.key_names) == 3 and s.behaviours == ("walk",)


def test_error_unknown_joint_names_file_pose_animation_and_key(tmp_path: Path) -> None:
    path = write_set(
        tmp_path,
        pose_extra="[c]\n[c.joints]\nrigt_knee = 10.0\n",
        keys='{ at = 0.0, pose = "a" }, { at = 0.5, pose = "c" }',
    )
    msg = load_error(path)
    assert (
        "poses.toml" in msg
        and "pose 'c'" in msg
        and "animation 'walk' key 1" in msg
        and "rigt_knee: unknown joint" in msg
    )


def test_error_wrong_length(tmp_path: Path) -> None:
    path = write_set(tmp_path, pose_extra="[c]\nroot_offset = [0.0, 1.0]\n", keys='{ at = 0.0, pose = "c" }')
    msg = load_error(path)
    assert (
        "poses.toml" in msg
        and "animation 'walk' key 0" in msg
        and "root_offset: expected 3 finite numbers" in msg
    )


def test_error_non_finite(tmp_path: Path) -> None:
    path = write_set(
        tmp_path, pose_extra="[c]\n[c.joints]\nneck = [0.0, 0.0, nan, 1.0]\n", keys='{ at = 0.0, pose = "c" }'
    )
    msg = load_error(path)
    assert "pose 'c'" in msg and "joints.neck: expected 4 finite numbers" in msg


def test_error_duplicate_coordinate(tmp_path: Path) -> None:
    path = write_set(tmp_path, keys='{ at = 0.25, pose = "a" }, { at = 0.25, pose = "b" }')
    msg = load_error(path)
    assert "keyframes.toml" in msg and "animation 'walk' key 1 at dz=0.25: duplicate coordinate" in msg


def test_error_unknown_pose_and_unknown_family(tmp_path: Path) -> None:
    msg = load_error(write_set(tmp_path, keys='{ at = 0.0, pose = "nope" }'))
    assert "animation 'walk' key 0" in msg and "no pose named 'nope'" in msg
    extra = (
        '[[animation]]\nname = "x"\nbehaviour = "walk"\naxis = "theta_z"\n'
        'at = { theta_x = 0.0, dx = 0.0, dz = 0.0 }\nkeys = [{ at = 0.0, family = "run" }]\n'
    )
    assert "refers to family 'run'" in load_error(write_set(tmp_path, anim_extra=extra))


def test_error_animations_that_meet_with_different_poses(tmp_path: Path) -> None:
    extra = (
        '[[animation]]\nname = "lean"\nbehaviour = "walk"\naxis = "theta_z"\n'
        "at = { theta_x = 0.0, dx = 0.0, dz = 0.0 }\n"
        'keys = [{ at = 0.0, pose = "b" }, { at = 1.0, pose = "down" }]\n'
    )
    msg = load_error(write_set(tmp_path, anim_extra=extra))
    assert "keyframes.toml: animations 'walk' and 'lean' meet at (theta_x=0, theta_z=0, dx=0, dz=0)" in msg
    assert "with different poses (right_knee differs by 20.00°" in msg


def test_error_missing_file_and_bad_toml(tmp_path: Path) -> None:
    assert "no such keyframe manifest" in load_error(tmp_path / "missing.toml")
    bad = tmp_path / "bad.toml"
    bad.write_text("format = [", encoding="utf-8")
    assert "bad.toml: not valid TOML" in load_error(bad)
