"""``jostle terrain show``: the cube layout of a config, as a map and (``--out``) as a picture."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

import numpy as np

RAW = argparse.RawDescriptionHelpFormatter


def add(sub: Any) -> None:
    t = sub.add_parser("terrain", help="the cube terrain of a config: show its layout", formatter_class=RAW,
                       description="Cube terrains ([terrain] in a config; issue 10).")
    tsub = t.add_subparsers(dest="terrain_command", metavar="SUBCOMMAND", required=True)
    s = tsub.add_parser(
        "show",
        help="print the layout as a map (and draw it with --out)",
        formatter_class=RAW,
        description="Build the [terrain] layout of CONFIG and print it as a map seen from above, the audience\n"
        "at the bottom ('.' floor, digits: cubes), with the grid cells and stage metres of its corners.\n"
        "With --out, also draw it from the config's camera into an image (PNG or JPEG).",
        epilog="example:\n  jostle terrain show configs/quadruped.toml --out out/terrain.png",
    )
    s.add_argument("config", type=Path, help="installation config with a [terrain] table")
    s.add_argument("--out", type=Path, default=None, metavar="IMAGE", help="also draw it into this image")
    s.set_defaults(func=cmd_show)


def layout_map(heights: np.ndarray, origin: tuple[float, float], cell: float) -> list[str]:
    """Lines of the occupied part of ``heights`` (nx, ny) and a cell around it, back row first."""
    nz = np.argwhere(heights > 0)
    if not len(nz):
        return ["(no cubes)"]
    nx, ny = heights.shape
    x0, y0 = (max(int(v) - 1, 0) for v in nz.min(axis=0))
    x1, y1 = (min(int(v) + 1, n - 1) for v, n in zip(nz.max(axis=0), (nx, ny), strict=True))
    lines = [f"cells x {x0}..{x1} (stage x {origin[0] + x0 * cell:.2f}..{origin[0] + (x1 + 1) * cell:.2f} m), "
             f"y {y0}..{y1} (stage y {origin[1] + y0 * cell:.2f}..{origin[1] + (y1 + 1) * cell:.2f} m); "
             f"{int((heights > 0).sum())} columns, {int(heights.sum())} cubes"]
    for iy in range(y1, y0 - 1, -1):
        row = "".join("." if heights[ix, iy] == 0 else str(int(heights[ix, iy])) for ix in range(x0, x1 + 1))
        lines.append(f"{iy:4d}  {row}")
    lines.append("      (audience)")
    return lines


def cmd_show(args: argparse.Namespace) -> int:
    from jostle.quiet import import_pybullet_quietly

    import_pybullet_quietly()  # (its banner)
    from jostle.config import ConfigError, load_config
    from jostle.terrain_wiring import grid_config
    from sim.terrain import TerrainGrid

    cfg = load_config(args.config)
    if cfg.terrain is None:
        raise ConfigError(f"{args.config}: terrain: missing; this config has no [terrain] table")
    section = cfg.terrain
    grid = TerrainGrid(grid_config(section))
    for ix, iy, cubes in section.initial_layout().columns:
        grid.set_height(ix, iy, cubes)
    g = section.floor_grid
    heights = np.array(grid.heights)
    print("\n".join(layout_map(heights, (g.origin[0], g.origin[1]), g.cell)))
    if args.out is not None:
        _draw(cfg, heights, args.out)
        print(f"jostle: image: {args.out}")
    return 0


def _draw(cfg: Any, heights: np.ndarray, out: Path) -> None:
    import cv2

    from jostle.config import ConfigError
    from render.gl.renderer import Renderer
    from render.gl.style import RenderStyle
    from render.gl.terrain import TerrainView
    from render.keyframes import KeyframeSet
    from sim.snapshot import WorldSnapshot

    g = cfg.terrain.floor_grid
    style = RenderStyle(camera=cfg.render.camera, colours=cfg.render.colours, look=cfg.render.look)
    with Renderer(cfg.render.width, cfg.render.height, style=style, stage_x=(cfg.world.x_min, cfg.world.x_max)) as r:
        image = r.draw(WorldSnapshot(t=0.0, steps=0, characters=()), None, KeyframeSet.load(cfg.render.keyframes),
                       terrain=TerrainView(heights, g.cell, (g.origin[0], g.origin[1])))
    if not out.parent.exists() or not cv2.imwrite(str(out), image):
        raise ConfigError(f"{out}: cannot write the image (is the folder there, and the name .png or .jpg?)")
