"""Articulated characters are drawn from their link transforms (render.gl.links), headless, real pixels.

The links come from a real pybullet body (the DeepMimic humanoid, lying on its back along stage x) while
the snapshot's position and orientation say "upright": a keyframe figure would stand, the links lie.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pybullet as p
import pytest

from render.gl.links import articulated_part, link_capsules, link_figure, link_figure_for
from render.gl.renderer import Renderer
from render.gl.style import Camera, Colours
from render.keyframes import KeyframeSet
from sim.articulated.build import build_multibody, source_to_stage
from sim.articulated.skeleton import deepmimic_humanoid
from sim.motion import quaternion as quat
from sim.snapshot import CharacterSnapshot, CharacterState, LinkPose, WorldSnapshot

SHIPPED = Path(__file__).resolve().parent.parent / "configs" / "keyframes" / "humanoid" / "keyframes.toml"
W, H = 320, 180

LYING = quat.from_axis_angle(np.array([0.0, 1.0, 0.0]), -math.pi / 2)  # head toward +x, face up


@pytest.fixture(scope="module")
def lying_links() -> tuple[LinkPose, ...]:
    sk = deepmimic_humanoid()
    client = p.connect(p.DIRECT)
    try:
        turn = quat.multiply(LYING, source_to_stage(sk))
        body = build_multibody(client, sk, (-0.4, 0.5, 0.15), tuple(turn))
        links = [LinkPose("root", (-0.4, 0.5, 0.15), tuple(turn))]
        for j in range(len(sk.links) - 1):
            s = p.getLinkState(body, j, computeForwardKinematics=True, physicsClientId=client)
            links.append(LinkPose(sk.links[j + 1].name, tuple(s[4]), tuple(s[5])))
        return tuple(links)
    finally:
        p.disconnect(client)


@pytest.fixture(scope="module")
def renderer() -> Iterator[Renderer]:
    r = Renderer(W, H, samples=4)
    yield r
    r.close()


def character(name: str, x: float = 0.0, y: float = 0.0, links: tuple[LinkPose, ...] = ()) -> CharacterSnapshot:
    """Upright at (x, y), centre of mass 0.75 m up, facing +x."""
    return CharacterSnapshot(name, (x, y, 0.75), (0.0, 0.0, 0.0, 1.0), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), 0.0,
                             (0.0, 0.0), 0.3, 0.0, CharacterState.WALK, "walk", "wander", None, 0.0, 1.5, links=links)


def changed(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.abs(a.astype(int) - b.astype(int)).max(axis=2) > 8


def ragdoll(links: tuple[LinkPose, ...]) -> CharacterSnapshot:
    return character("rag", -0.4, 0.5, links)


def to_pixel(point: np.ndarray) -> tuple[int, int]:
    clip = np.append(point, 1.0) @ Camera().view_projection(W, H).T
    ndc = clip[:2] / clip[3]
    return int((ndc[1] + 1) / 2 * H), int((ndc[0] + 1) / 2 * W)


def test_capsules_follow_the_links(lying_links: tuple[LinkPose, ...]) -> None:
    figure = link_figure(deepmimic_humanoid())
    assert link_figure_for(figure.names) is not None
    a, b, r, _ = link_capsules([ragdoll(lying_links)])
    assert a.shape == (1, len(figure.radii), 3) and len(figure.radii) > len(figure.names)  # shapes + bridges
    assert list(figure.link[: len(figure.names)]) == list(range(len(figure.names)))
    ends = np.concatenate([a[0], b[0]])
    assert ends[:, 2].max() < 0.45  # lying: nothing higher than a body's depth
    span = ends[:, 0].max() - ends[:, 0].min()
    assert 1.2 < span < 1.8  # head to feet along stage x
    # links of no known skeleton are left to render.gl.link_figures (a stick figure): still drawn
    assert link_figure_for(("a", "b")) is None
    other = character("odd", links=(LinkPose("a", (0, 0, 0.5), (0, 0, 0, 1)), LinkPose("b", (0, 0, 1), (0, 0, 0, 1))))
    sel, a2, _, _, _ = articulated_part([other, ragdoll(lying_links)], np.array([3, 1]), Colours(), 300.0)
    assert list(sel) == [1, 3] and a2.shape[1] == len(figure.radii)


def test_headless_render_shows_the_character_where_its_links_are(
    renderer: Renderer, lying_links: tuple[LinkPose, ...]
) -> None:
    kset = KeyframeSet.load(SHIPPED)
    empty = renderer.draw(WorldSnapshot(0.0, 0, ()), None, kset)
    frame = renderer.draw(WorldSnapshot(0.0, 0, (ragdoll(lying_links),)), None, kset)
    diff = changed(frame, empty)
    a, b, _, _ = link_capsules([ragdoll(lying_links)])
    centres = (a[0] + b[0]) / 2.0
    hits = 0
    for c in centres:  # every link's centre is drawn over
        row, col = to_pixel(c)
        hits += bool(diff[max(row - 1, 0) : row + 2, max(col - 1, 0) : col + 2].any())
    assert hits == len(centres)
    # where a keyframe figure standing at the snapshot's position would have its chest: nothing
    row, col = to_pixel(np.array([-0.4, 0.5, 1.3]))
    assert not diff[row - 2 : row + 3, col - 2 : col + 3].any()
    # and a keyframe character next to it is still drawn from its pose (both kinds in one frame)
    both = renderer.draw(WorldSnapshot(0.0, 0, (ragdoll(lying_links), character("ann", x=1.5))), None, kset)
    row, col = to_pixel(np.array([1.5, 0.0, 1.1]))
    assert changed(both, empty)[row - 2 : row + 3, col - 2 : col + 3].any()


def test_a_registered_bvh_body_is_drawn_along_its_bones(tmp_path: Path) -> None:
    from test_bvh_body import bvh_from_clip

    from render.gl.links import register_link_skeleton
    from sim.articulated.bvh_body import bvh_body
    from sim.motion.bvh import read_bvh

    bvh_from_clip(tmp_path / "walk.bvh", frames=3)
    sk = bvh_body(read_bvh(tmp_path / "walk.bvh")).skeleton
    register_link_skeleton(sk)
    turn = source_to_stage(sk)  # the rest pose, standing on the stage: every link frame turned alike
    joint = {0: np.array([0.0, 0.0, 1.0])}
    for i, link in enumerate(sk.links[1:], start=1):
        joint[i] = joint[link.parent] + quat.rotate(turn, np.array(link.joint_offset))
    links = tuple(LinkPose(link.name, tuple(joint[i]), tuple(turn)) for i, link in enumerate(sk.links))
    a, b, r, _ = link_capsules([character("bvh", links=links)])
    thigh, knee = sk.index("RightUpLeg"), sk.index("RightLeg")
    bone = joint[knee] - joint[thigh]
    for end in (a[0, thigh], b[0, thigh]):  # the thigh's capsule lies on the bone from hip to knee
        t = np.dot(end - joint[thigh], bone) / np.dot(bone, bone)
        assert 0.0 < t < 1.0 and np.linalg.norm(joint[thigh] + t * bone - end) < 1e-9
    assert r[0, thigh] == pytest.approx(sk.links[thigh].size[0])
