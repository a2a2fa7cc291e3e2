"""[terrain]: the layout reader, the config, and the wiring of layout, hands and depth boxes into the
world's cube grid (sim.terrain.TerrainGrid, changed by sim.terrain_edits), up to a headless run that draws the cubes."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest
from test_terrain_cells import calibration, cube_column, depth_frame

from interaction.depth import DepthObserver, DepthObserverConfig
from interaction.depth.terrain_cells import TerrainObserverConfig
from interaction.types import BodyObservation, Contactor, TerrainReport
from jostle.app import App, RunOptions
from jostle.config import ConfigError, load_config
from jostle.terrain_layout import LayoutError, TerrainSection, parse_rows, read_layout
from jostle.terrain_wiring import TerrainWiring, grid_config
from sensors.recording.writer import RecordingWriter
from sim.snapshot import WorldSnapshot
from sim.terrain import TerrainGrid
from sim.terrain_edits import TerrainEdits

ROOT = Path(__file__).resolve().parent.parent
STEPS = ROOT / "configs" / "terrain" / "steps.toml"
QUADRUPED = ROOT / "configs" / "quadruped.toml"
SMALL = TerrainSection(size=(16.0, 10.0), origin=(-2.4, -1.2))  # the grid of test_terrain_cells


# ------------------------------------------------------------------ layouts


def test_the_shipped_layout_reads_as_drawn() -> None:
    layout = read_layout(STEPS, (64, 64), 3)
    cols = {(ix, iy): h for ix, iy, h in layout.columns}
    assert cols[(27, 39)] == 1  # the single cube, on the row 4th from the bottom (at = [23, 36])
    assert [cols[(x, 39)] for x in (31, 32, 33)] == [1, 2, 1]  # the staircase
    assert [cols[(37, y)] for y in range(38, 43)] == [3] * 5  # the wall
    assert len(cols) == 9


@pytest.mark.parametrize(("rows", "at", "message"), [
    (["..1", ".x."], [0, 0], r"^f\.toml: row 2, column 2: expected '\.' or a digit 0\.\.3 .*got 'x'$"),
    (["..1", ".4."], [0, 0], r"^f\.toml: row 2, column 2: .*max_height is 3.*got '4'$"),
    (["..1", "..."], [15, 0], r"^f\.toml: row 1, column 3: cell \(17, 1\) is off the 16×10 grid"),
    (["..1", "...."], [0, 0], r"^f\.toml: row 2: 4 cells, but row 1 has 3"),
    ([], [0, 0], r"^f\.toml: rows: expected a list of strings"),
    (["1"], [0.5, 0], r"^f\.toml: at: expected \[ix, iy\]"),
])
def test_layout_errors_name_the_row_and_column(rows: list[str], at: list[float], message: str) -> None:
    with pytest.raises(LayoutError, match=message):
        parse_rows(rows, at, "f.toml", (16, 10), 3)


def test_layout_file_errors(tmp_path: Path) -> None:
    with pytest.raises(LayoutError, match=r"nope\.toml: no such layout file"):
        read_layout(tmp_path / "nope.toml", (8, 8), 3)
    bad = tmp_path / "bad.toml"
    bad.write_text('at = [0, 0]\nrows = ["1"]\nheight = 3\n')
    with pytest.raises(LayoutError, match=r"bad\.toml: height: unknown key; expected at, rows"):
        read_layout(bad, (8, 8), 3)
    bad.write_text("rows = [")
    with pytest.raises(LayoutError, match=r"bad\.toml: not valid TOML"):
        read_layout(bad, (8, 8), 3)


def _config(tmp_path: Path, terrain: str, observers: str = "") -> Path:
    """A config like configs/quadruped.toml with its own [terrain] table."""
    text = QUADRUPED.read_text().split("\n[terrain]\n")[0].split("\n[[characters]]\n")[0]
    text = text.replace('"recordings/', f'"{ROOT}/configs/recordings/')
    text += f'{observers}\n[terrain]\n{terrain}\n[render]\nkeyframes = "{ROOT}/configs/keyframes/humanoid/keyframes.toml"\n'
    path = tmp_path / "c.toml"
    path.write_text(text)
    return path


def test_config_errors_are_one_line_naming_the_key(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match=r"c\.toml: terrain\.rows: row 1, column 2: expected '\.' or a digit"):
        load_config(_config(tmp_path, 'rows = [".x"]'))
    with pytest.raises(ConfigError, match=r"c\.toml: terrain\.layout: .*steps\.toml: row 1, column 15: cell \(37, 42\) "
                                          r"is off the 4×4 grid"):
        load_config(_config(tmp_path, f'size = [4, 4]\nlayout = "{STEPS}"'))
    with pytest.raises(ConfigError, match=r"c\.toml: terrain\.size: expected \[nx, ny\]"):
        load_config(_config(tmp_path, "size = [64.5, 3]"))
    with pytest.raises(ConfigError, match=r"c\.toml: terrain\.boxes: expected the name of a depth observer \(none "
                                          r"configured\), got 'oak'"):
        load_config(_config(tmp_path, 'boxes = "oak"'))
    with pytest.raises(ConfigError, match=r"c\.toml: terrain\.observe\.hold_s: expected a number"):
        load_config(_config(tmp_path, "[terrain.observe]\nhold_s = -1"))
    with pytest.raises(ConfigError, match=r"c\.toml: quadrupeds\[0\]\.waypoints: expected x0, y0, x1, y1"):
        load_config(_config(tmp_path, "[[quadrupeds]]\nwaypoints = [1, 2, 3]"))
    with pytest.raises(ConfigError, match=r"c\.toml: quadrupeds: a quadruped walks on the cube terrain: add a "
                                          r"\[terrain\] table"):
        path = _config(tmp_path, "")
        path.write_text(path.read_text().replace("[terrain]\n", "[[quadrupeds]]\n"))
        load_config(path)
    cfg = load_config(_config(tmp_path, 'rows = ["12", "3."]\nat = [5, 6]'))
    assert cfg.terrain is not None
    assert cfg.terrain.initial_layout().columns == ((5, 7, 1), (6, 7, 2), (5, 6, 3))
    assert cfg.terrain.floor_grid.origin == (-9.6, -9.6)  # centred by default


# ------------------------------------------------------------------ wiring


def wiring(section: TerrainSection = SMALL) -> TerrainWiring:
    """The wiring of a grid laid out as ``section`` says (the world's part: ``sim.terrain_edits``)."""
    grid = TerrainGrid(grid_config(section))
    TerrainEdits(grid).layout(section.initial_layout().columns)
    return TerrainWiring.build(section, grid, calibration())


def edits(w: TerrainWiring) -> TerrainEdits:
    """What the world does with the wiring's reports (``World.step`` applies them so)."""
    return TerrainEdits(w.grid)


def test_the_layout_is_built_and_drawn_from_the_grid() -> None:
    w = wiring(dataclasses.replace(SMALL, rows=("2.", ".1"), at=(3.0, 4.0)))
    assert w.grid.height(3, 5) == 2 and w.grid.height(4, 4) == 1 and int(w.grid.heights.sum()) == 3
    view = w.view()
    assert view.cell == 0.3 and view.origin == (-2.4, -1.2)
    assert view.heights[3, 5] == 2 and view.heights.shape == (16, 10)


def test_boxes_come_and_go_and_keep_the_cubes_placed_on_them() -> None:
    w = wiring()
    e = edits(w)
    e.apply(TerrainReport(boxes=((5, 4, 1), (7, 2, 2))))
    assert (w.grid.height(5, 4), w.grid.height(7, 2)) == (1, 2)
    assert w.grid.place(5, 4).changed  # a cube placed on the real box
    e.apply(TerrainReport(boxes=((7, 2, 2),)))  # the box under it lifted away
    assert (w.grid.height(5, 4), w.grid.height(7, 2)) == (1, 2)
    e.apply(TerrainReport(boxes=()))
    assert int(w.grid.heights.sum()) == 1
    assert e.counts["box_added"] == 2 and e.counts["box_removed"] == 2


def test_a_box_under_a_character_waits_until_it_leaves() -> None:
    w = wiring()
    e = edits(w)
    w.grid.reserve("dog", [(5, 4)])
    e.apply(TerrainReport(boxes=((5, 4, 1),)))
    assert w.grid.height(5, 4) == 0 and e.counts["box_under_character"] == 1
    w.grid.release("dog")
    e.apply(TerrainReport(boxes=((5, 4, 1),)))
    assert w.grid.height(5, 4) == 1


def test_depth_frames_of_boxes_build_the_grid() -> None:
    w = wiring()
    e = edits(w)
    boxes = [cube_column(3, 4, 1), cube_column(8, 5, 2)]
    rng = np.random.default_rng(4)
    for i in range(20):
        report = w.observe_depth(depth_frame(boxes, i / 15, i, rng), BodyObservation(i / 15)).terrain
        assert report is not None
        e.apply(report)
    assert {(int(i), int(j)) for i, j in zip(*np.nonzero(w.grid.heights), strict=True)} == {(3, 4), (8, 5)}
    assert (w.grid.height(3, 4), w.grid.height(8, 5)) == (1, 2)


def test_a_held_hand_places_one_cube_and_a_refused_one_is_counted() -> None:
    w = wiring(dataclasses.replace(SMALL, observe=TerrainObserverConfig(hold_s=0.5)))
    e = edits(w)
    x, y = w.observer.grid.centre(10, 6)
    for i in range(40):
        people = (Contactor(1, "head", (0.0, 0.0, 1.6), (0.0, 0.0, 0.0), 0.12),
                  Contactor(1, "hand", (x, y, 1.0), (0.0, 0.0, 0.0), 0.07),
                  Contactor(1, "hand", (-0.6, 0.0, 1.0), (0.0, 0.0, 0.0), 0.07))  # both hands held out
        report = w.with_hands(BodyObservation(i / 30, people, people=1)).terrain
        if report is not None:
            e.apply(report)
    other = w.observer.grid.cell_at(-0.6, 0.0)
    assert other is not None
    assert w.grid.height(10, 6) == 1 and w.grid.height(*other) == 1
    assert e.counts["hand_placed"] == 2
    off = wiring(dataclasses.replace(SMALL, hands=False))
    assert off.observe_hands(BodyObservation(0.0, people)) == ()


def test_a_grid_of_another_geometry_is_refused() -> None:
    with pytest.raises(ValueError, match=r"^terrain: the world's grid \(64×64"):
        TerrainWiring.build(SMALL, TerrainGrid(grid_config(TerrainSection())))


# ------------------------------------------------------------------ a run


def test_a_run_builds_the_layout_and_draws_its_cubes() -> None:
    cfg = load_config(QUADRUPED)
    cfg = dataclasses.replace(cfg, render=dataclasses.replace(cfg.render, width=320, height=180))
    frames: list[np.ndarray] = []
    app = App(cfg, RunOptions(duration_s=0.2, video=False, progress=False))

    snaps: list[WorldSnapshot] = []

    def keep(snap: WorldSnapshot, obs: BodyObservation, image: np.ndarray | None) -> None:
        assert image is not None
        frames.append(image.copy())
        snaps.append(snap)

    app.on_frame = keep
    app.run()
    assert app.terrain is not None
    dogs = [c for c in snaps[-1].characters if c.kind == "quadruped"]  # [[quadrupeds]]: one, where it was put
    assert len(dogs) == 1 and len(dogs[0].links) >= 16
    assert np.hypot(dogs[0].position[0] + 2.4, dogs[0].position[1] - 2.25) < 0.3
    expected = {(ix, iy): h for ix, iy, h in read_layout(STEPS, (64, 64), 3).columns}
    built = {(int(i), int(j)): int(app.terrain.grid.height(int(i), int(j)))
             for i, j in zip(*np.nonzero(app.terrain.grid.heights), strict=True)}
    assert built == expected
    # the columns' front faces are drawn (cardboard), bar the few a walker may stand in front of
    g = cfg.terrain.floor_grid if cfg.terrain else None
    assert g is not None
    vp = cfg.render.camera.view_projection(320, 180)
    warm = []
    for (ix, iy), h in expected.items():
        if (ix, iy - 1) in expected:
            continue  # hidden behind the column in front of it
        x, y = g.centre(ix, iy)
        clip = np.array([x, y - 0.5 * g.cell, 0.5 * h * g.cell, 1.0]) @ vp.T
        col, row = ((clip[:2] / clip[3]) + 1) / 2 * np.array([320, 180])
        b, _, r = frames[-1][int(row), int(col)].astype(int)
        warm.append(r > b + 40)
    assert len(warm) == 5 and sum(warm) >= 4, warm


def test_a_run_with_a_depth_camera_turns_real_boxes_into_cubes(tmp_path: Path) -> None:
    """A depth recording of two boxes on the floor, replayed through [observers.oak] and [terrain] boxes."""
    rng = np.random.default_rng(9)
    boxes = [cube_column(3, 4, 1), cube_column(8, 5, 2)]
    with RecordingWriter(tmp_path / "boxes.mcap") as rec:
        for i in range(30):  # 2 s at 15 fps
            rec.write(depth_frame(boxes, i / 15, i, rng))
    calibration().save(tmp_path / "oak.calibration.toml")
    (tmp_path / "c.toml").write_text(f"""
[sensors.oak]
type = "replay"
path = "boxes.mcap"
[observers.oak]
type = "depth"
sensor = "oak"
calibration = "oak.calibration.toml"
[terrain]
size = [16, 10]
origin = [-2.4, -1.2]
boxes = "oak"
[render]
keyframes = "{ROOT}/configs/keyframes/humanoid/keyframes.toml"
width = 160
height = 90
""")
    app = App(load_config(tmp_path / "c.toml"), RunOptions(duration_s=2.2, video=False, progress=False))
    app.run()
    assert app.terrain is not None
    heights = app.terrain.grid.heights
    assert {(int(i), int(j)) for i, j in zip(*np.nonzero(heights), strict=True)} == {(3, 4), (8, 5)}
    assert (int(heights[3, 4]), int(heights[8, 5])) == (1, 2)


def test_a_stack_as_tall_as_a_person_is_a_stack_not_a_person() -> None:
    """The depth observer takes a 0.9 m stack of boxes for a person (it reaches its min_height_m); the
    terrain takes it for boxes, and the observation handed on has no one in it."""
    w = wiring()
    e = edits(w)
    people = DepthObserver(DepthObserverConfig(), calibration())
    rng = np.random.default_rng(6)
    for i in range(6):  # the depth observer learns the empty stage
        people.observe(depth_frame([], i / 15, i, rng))
    seen, handed_on = 0, 0
    for i in range(6, 30):
        frame = depth_frame([cube_column(5, 4, 3)], i / 15, i, rng)
        obs = people.observe(frame)
        seen += obs.people
        handed = w.observe_depth(frame, obs)
        handed_on += handed.people
        assert handed.terrain is not None
        e.apply(handed.terrain)
    assert seen > 20  # the depth observer's "person"
    assert handed_on == 0
    assert w.grid.height(5, 4) == 3 and int(w.grid.heights.sum()) == 3


def test_a_person_beside_a_box_is_still_a_person() -> None:
    w = wiring()
    e = edits(w)
    x, y = w.observer.grid.centre(6, 4)
    person = BodyObservation(0.0, (Contactor(2, "head", (x + 0.5, y, 1.6), (0.0, 0.0, 0.0), 0.12),
                                   Contactor(2, "hand", (x, y, 0.9), (0.0, 0.0, 0.0), 0.07)), people=1)
    rng = np.random.default_rng(1)
    for i in range(20):
        handed_on = w.observe_depth(depth_frame([cube_column(6, 4, 1)], i / 15, i, rng), person)
        assert handed_on.people == 1 and len(handed_on.contactors) == 2
        assert handed_on.terrain is not None
        e.apply(handed_on.terrain)
    assert w.grid.height(6, 4) == 0  # a person's hand over it: not judged while they are there


def test_the_view_shows_a_hold_under_way() -> None:
    w = wiring()
    x, y = w.observer.grid.centre(10, 6)
    people = (Contactor(1, "head", (0.0, 0.0, 1.6), (0.0, 0.0, 0.0), 0.12),
              Contactor(1, "hand", (x, y, 1.0), (0.0, 0.0, 0.0), 0.07))
    for i in range(16):
        w.observe_hands(BodyObservation(i / 30, people, people=1))
    assert w.view().pending == ((10, 6, pytest.approx(0.5)),)
    assert dataclasses.replace(w, section=dataclasses.replace(SMALL, hands=False)).view().pending == ()


def test_terrain_show_prints_the_map_and_draws_it(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from jostle.cli import main

    assert main(["terrain", "show", str(QUADRUPED), "--out", str(tmp_path / "t.png")]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0].startswith("cells x 26..38 ") and "9 columns, 20 cubes" in out[0]
    assert "  39  .1...121...3." in out  # the row of the cube and the stairs, under the wall's column
    assert (tmp_path / "t.png").stat().st_size > 1000
    assert main(["terrain", "show", str(ROOT / "configs" / "demo.toml")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == ["jostle: error: " + str(ROOT / "configs" / "demo.toml") + ": terrain: missing; this config has no "
                   "[terrain] table"]
