"""``jostle calibrate webcam --points``: a floor calibration without a board, from floor points typed in.

The installer marks four or more points on the floor (tape, tile corners, the stage's corners),
measures their stage (x, y) metres, reads their pixels off a frame, and types them as
``--points "u,v=x,y u,v=x,y ..."``. The image size comes from ``--size`` or the first frame of
``--from``/``--camera``. The fit (:mod:`interaction.webcam.floor_points`) reports the reprojection
error in pixels and metres and refuses bad points with one line each; the calibration file is
written with ``kind = "floor"``. No click-to-mark window yet: the pixels are typed.
"""

from __future__ import annotations

import argparse
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

from jostle.errors import UsageError


def calibrate_from_points(args: argparse.Namespace, out: Path, frames: Callable[[argparse.Namespace], Iterator[Any]]) -> int:
    """Fit, report and write the floor calibration from ``args.points``; ``frames(args)`` gives the
    source's frames when the size is to be read from them. Every refusal is a UsageError."""
    from interaction.webcam.calibration import CalibrationError
    from interaction.webcam.floor_points import fit_floor_points, parse_points

    size = _image_size(args, frames)
    if not args.max_error > 0:
        raise UsageError(f"--max-error: expected pixels > 0, got {args.max_error}")
    half_depth = 0.25 if args.half_depth is None else args.half_depth
    if not 0 <= half_depth <= 100:
        raise UsageError(f"--half-depth: expected metres from 0 to 100, got {half_depth}")
    try:
        uv, xy = parse_points(args.points)
        fit = fit_floor_points(uv, xy, size, hfov_deg=args.hfov, half_depth=half_depth,
                               max_rms_px=args.max_error)
    except CalibrationError as e:
        raise UsageError(f"calibration refused: {e}") from None
    print(f"jostle: {fit.describe()}")
    fit.calibration.save(out)
    print(f"jostle: floor calibration: {out}")
    return 0


def _image_size(args: argparse.Namespace, frames: Callable[[argparse.Namespace], Iterator[Any]]) -> tuple[int, int]:
    if args.size is not None:
        try:
            w, h = (int(v) for v in args.size.lower().split("x"))
        except ValueError:
            raise UsageError(f"--size: expected WIDTHxHEIGHT like 640x480, got {args.size!r}") from None
        if not (16 <= w <= 16384 and 16 <= h <= 16384):
            raise UsageError(f"--size: expected 16..16384 pixels each way, got {args.size!r}")
        return w, h
    if args.recording is None and args.camera is None:
        raise UsageError("--points: give the image size with --size WxH (or --from/--camera to read it from a frame)")
    for bgr in frames(args):
        h, w = bgr.shape[:2]
        return int(w), int(h)
    raise UsageError(f"{args.recording or args.camera}: no colour frames to read the image size from")
