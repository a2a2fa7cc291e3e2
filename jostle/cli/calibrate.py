"""``jostle calibrate``: the webcam → stage homography from an ArUco/ChArUco board, and the board to print.

``jostle calibrate webcam`` finds the board in a recording (headless) or in a live camera's frames,
fits the homography (see :mod:`interaction.webcam.calibrate`), reports the reprojection error,
refuses a fit above ``--max-error`` with what to do, and writes the calibration TOML — by default
next to the config given with ``--config`` — plus, if asked, a preview image of the fit.
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    import numpy as np

RAW = argparse.RawDescriptionHelpFormatter
DEFAULT_NAME = "webcam.calibration.toml"
DEFAULT_DEPTH_NAME = "depth.calibration.toml"


def add(sub: Any) -> None:
    p = sub.add_parser(
        "calibrate",
        help="calibrate a webcam onto the stage with an ArUco/ChArUco board",
        formatter_class=RAW,
        description="Calibrate a sensor onto the stage.\n\n"
        "  jostle calibrate board   write the board image to print (or to show on the screen)\n"
        "  jostle calibrate webcam  find the board in a recording or a live camera → calibration TOML\n"
        "  jostle calibrate depth   find the floor in an empty-stage depth recording → calibration TOML",
    )
    what = p.add_subparsers(dest="target", metavar="TARGET", required=True)

    w = what.add_parser(
        "webcam",
        help="the image → stage homography from a board in view",
        formatter_class=RAW,
        description="Find the board in the frames, fit the image → stage homography, report the reprojection\n"
        "error, and write the calibration TOML. A fit whose error exceeds --max-error is refused.\n\n"
        "Placement: --plane screen (the board upright in the stage plane, e.g. shown on the\n"
        "projection screen or hung where people stand; --origin X,Z is the stage position of its\n"
        "top-left corner) or --plane floor (flat on the floor, top edge toward the screen; --origin X,Y).\n"
        "Without a board: --points, four or more floor points (pixel = stage x,y metres) → a floor calibration.",
        epilog="examples:\n"
        "  jostle calibrate board --out board.png --square-m 0.12 --marker-m 0.09\n"
        "  jostle record configs/webcam.toml --out board.mcap --duration 3\n"
        "  jostle calibrate webcam --from board.mcap --square-m 0.12 --marker-m 0.09 --origin=-0.3,1.8 \\\n"
        "      --config configs/webcam.toml --preview board-fit.png\n"
        '  jostle calibrate webcam --size 640x480 --points "102,410=-2,0 540,405=2,0 470,250=1.5,3 170,252=-1.5,3"\n'
        "      --out calibration/webcam.toml\n"
        "  jostle calibrate webcam --camera 0 --plane floor --origin=-0.5,1.0 --out calibration/webcam.toml",
    )
    src = w.add_mutually_exclusive_group()
    src.add_argument("--from", dest="recording", type=Path, metavar="REC.mcap", help="a recording (headless)")
    src.add_argument("--camera", metavar="SOURCE", help='a live camera ("0"), a video file or a stream URL')
    w.add_argument("--points", default=None, metavar='"U,V=X,Y ..."',
                   help="no board: floor points, each a pixel and the stage x,y metres it lies at (4 or more)")
    w.add_argument("--size", default=None, metavar="WxH", help="--points: the image size (default: --from/--camera's)")
    w.add_argument("--hfov", type=float, default=None, metavar="DEG",
                   help="--points: the camera's horizontal field of view, if known (default: found from the points)")
    w.add_argument("--channel", default="", help="the recording's colour channel (default: the only one)")
    w.add_argument("--frames", type=int, default=30, metavar="N", help="use up to N frames (default 30)")
    w.add_argument("--seconds", type=float, default=5.0, metavar="S", help="--camera: watch for S seconds")
    _board_flags(w)
    w.add_argument("--plane", choices=("screen", "floor"), default="screen", help="where the board is")
    w.add_argument("--origin", default="0,0", metavar="A,B",
                   help="stage metres of the board's top-left corner: X,Z (screen) or X,Y (floor); "
                   "write --origin=-0.5,1.2 when it starts with a minus")
    w.add_argument("--plane-y", type=float, default=0.0, metavar="M", help="the stage plane people stand in (y)")
    w.add_argument("--half-depth", type=float, default=None, metavar="M",
                   help="how far a webcam contactor reaches either side of that plane (default 1; --points: "
                   "of the person's own, default 0.25)")
    w.add_argument("--max-error", type=float, default=2.0, metavar="PX",
                   help="refuse a fit whose RMS reprojection error exceeds PX pixels (default 2)")
    w.add_argument("--out", type=Path, default=None, metavar="FILE.toml",
                   help=f"where to write it (default: {DEFAULT_NAME} next to --config)")
    w.add_argument("--config", type=Path, default=None, help="the installation config it is for")
    w.add_argument("--preview", type=Path, default=None, metavar="PNG", help="also draw the fit on a frame")
    w.add_argument("--force", action="store_true", help="overwrite --out if it exists")
    w.set_defaults(func=cmd_calibrate_webcam)

    _add_depth(what)

    b = what.add_parser("board", help="write the board image", formatter_class=RAW,
                        description="Write the board as an image (print it at the scale given, or show it full screen).")
    _board_flags(b)
    b.add_argument("--out", type=Path, required=True, metavar="PNG")
    b.add_argument("--px-per-m", type=float, default=2500.0, help="pixels per metre (default 2500 ≈ 64 dpi)")
    b.set_defaults(func=cmd_calibrate_board)


def _board_flags(p: argparse.ArgumentParser) -> None:
    p.add_argument("--board", choices=("charuco", "grid"), default="charuco", help="board kind (default charuco)")
    p.add_argument("--squares", default="5x7", metavar="CxR", help="columns x rows (default 5x7)")
    p.add_argument("--square-m", type=float, default=0.04, metavar="M", help="square (grid: marker) side, metres")
    p.add_argument("--marker-m", type=float, default=0.03, metavar="M", help="marker side (grid: gap), metres")
    p.add_argument("--dictionary", default="DICT_4X4_50", help="ArUco dictionary (default DICT_4X4_50)")


def _usage(message: str) -> Exception:
    from jostle.errors import UsageError

    return UsageError(message)


def _pair(text: str, flag: str) -> tuple[float, float]:
    try:
        a, b = (float(x) for x in text.replace(" ", "").split(","))
    except ValueError:
        raise _usage(f"{flag}: expected two numbers like 0.5,1.2, got {text!r}") from None
    return a, b


def _board_spec(args: argparse.Namespace) -> Any:
    from interaction.webcam.calibrate import BoardSpec

    try:
        cols, rows = (int(x) for x in args.squares.lower().split("x"))
    except ValueError:
        raise _usage(f"--squares: expected columns x rows like 5x7, got {args.squares!r}") from None
    try:
        return BoardSpec(args.board, cols, rows, args.square_m, args.marker_m, args.dictionary)
    except ValueError as e:
        raise _usage(f"--board: {e}") from None


def cmd_calibrate_board(args: argparse.Namespace) -> int:
    import cv2

    from interaction.webcam.calibrate import board_image

    spec = _board_spec(args)
    img = board_image(spec, args.px_per_m)
    if not cv2.imwrite(str(args.out), img):
        raise _usage(f"{args.out}: cannot write the image (is the folder there, and the suffix .png?)")
    w, h = spec.size_m
    print(f"jostle: board {spec.kind} {spec.columns}x{spec.rows} ({w:.3f} × {h:.3f} m) → {args.out} "
          f"({img.shape[1]}×{img.shape[0]} px); print it so a square measures {spec.square_m * 1000:g} mm")
    return 0


def cmd_calibrate_webcam(args: argparse.Namespace) -> int:
    from interaction.webcam.calibrate import BoardPlacement, CalibrationRefused, detect_board, fit_calibration
    from jostle.cli.calibrate_points import calibrate_from_points

    if args.points is not None:
        return calibrate_from_points(args, _out_path(args), _frames)
    if args.recording is None and args.camera is None:
        raise _usage("calibrate webcam: give --from REC.mcap or --camera SOURCE (a board in view), or --points")
    spec = _board_spec(args)
    try:
        placement = BoardPlacement(args.plane, _pair(args.origin, "--origin"), args.plane_y,
                                   1.0 if args.half_depth is None else args.half_depth)
    except ValueError as e:
        raise _usage(f"--{str(e).split(':')[0].replace('_', '-')}: {str(e).split(': ', 1)[-1]}") from None
    out = _out_path(args)
    if args.frames < 1:
        raise _usage(f"--frames: expected a whole number ≥ 1, got {args.frames}")

    views, last, size, seen = [], None, None, 0
    for k, bgr in enumerate(_frames(args)):
        seen += 1
        h, w = bgr.shape[:2]
        if size is None:
            size = (w, h)
        elif size != (w, h):
            raise _usage(f"frame {k} is {w}×{h}, the first was {size[0]}×{size[1]}")
        view = detect_board(bgr, spec, k)
        if view is not None:
            views.append(view)
            last = bgr
        if len(views) >= args.frames:
            break
    if size is None:
        raise _usage(f"{args.recording or args.camera}: no colour frames")
    print(f"jostle: board found in {len(views)} of {seen} frames", file=sys.stderr)
    try:
        fit = fit_calibration(views, placement, size, max_rms_px=args.max_error)
    except CalibrationRefused as e:
        raise _usage(f"calibration refused: {e}") from None
    print(f"jostle: {fit.describe()}")
    fit.calibration.save(out)
    print(f"jostle: calibration: {out}")
    if args.preview is not None and last is not None:
        _write_preview(args.preview, last, views[-1], fit, placement)
        print(f"jostle: preview:     {args.preview}")
    return 0


def _out_path(args: argparse.Namespace, default_name: str = DEFAULT_NAME) -> Path:
    out: Path | None = args.out
    if out is None:
        if args.config is None:
            raise _usage("--out: say where to write the calibration (or give --config to put it next to it)")
        out = args.config.parent / default_name
    if out.exists() and not args.force:
        raise _usage(f"{out}: exists; pass --force to overwrite it")
    if not out.parent.is_dir():
        raise _usage(f"{out}: the folder {out.parent} does not exist")
    return out


def _frames(args: argparse.Namespace) -> Iterator[np.ndarray]:
    """BGR frames from the recording or the live camera."""
    from sensors.base import ColorImage, DepthImage

    if args.recording is not None:
        from sensors.recording.info import describe_recording, select_channel
        from sensors.recording.source import iter_payloads

        info = describe_recording(args.recording)
        channel = select_channel(info, args.channel or None)
        if channel.kind not in ("color", "depth"):
            raise _usage(f"{args.recording}: channel {channel.topic!r} holds {channel.kind}, expected colour frames")
        for _, _, payload in iter_payloads(args.recording, channel.topic):
            if isinstance(payload, ColorImage):
                yield payload.bgr
            elif isinstance(payload, DepthImage) and payload.color is not None:
                yield payload.color
        return
    from sensors.clock import WallClock
    from sensors.webcam.config import WebcamConfig
    from sensors.webcam.driver import WebcamSensor

    sensor = WebcamSensor(WebcamConfig(source=args.camera), WallClock(), "webcam")
    with sensor:
        end = time.monotonic() + args.seconds
        print(f"jostle: watching {args.camera} for {args.seconds:g} s: hold the board still in view", file=sys.stderr)
        while time.monotonic() < end:
            frame = sensor.read(0.2)
            if frame is not None and isinstance(frame.payload, ColorImage):
                yield frame.payload.bgr


def _write_preview(path: Path, bgr: np.ndarray, view: Any, fit: Any, placement: Any) -> None:
    """The last frame with the detected corners (green) and where the fit puts them (red)."""
    import cv2
    import numpy as np

    img = bgr.copy()
    stage = placement.board_to_stage(view.board_xy)
    if placement.plane == "screen":
        xyz = np.column_stack([stage[:, 0], np.full(len(stage), placement.plane_y), stage[:, 1]])
        back = fit.calibration.stage_to_image(xyz)
    else:
        back = view.image_uv  # the fit is to the upright plane; the floor corners are drawn as found
    for (u, v), (bu, bv) in zip(view.image_uv, back, strict=True):
        cv2.circle(img, (round(u), round(v)), 4, (0, 200, 0), 1)
        cv2.drawMarker(img, (round(bu), round(bv)), (0, 0, 255), cv2.MARKER_CROSS, 6, 1)
    cv2.putText(img, fit.describe()[:90], (8, 20), cv2.FONT_HERSHEY_SIMPLEX, 0.45, (0, 0, 255), 1)
    if not cv2.imwrite(str(path), img):
        raise _usage(f"{path}: cannot write the preview image")


# ---------------------------------------------------------------- depth


def _add_depth(what: Any) -> None:
    d = what.add_parser(
        "depth",
        help="the depth camera → stage transform from the floor",
        formatter_class=RAW,
        description="Find the floor (RANSAC) in depth frames of the EMPTY stage, put the stage origin where\n"
        "--origin says the camera stands (the stage x,y of the floor point straight below it) and the\n"
        "stage's y axis along the camera's view laid flat (turned by --heading degrees toward the\n"
        "audience's left), report the reprojection error (RMS distance of the floor's points to the\n"
        "fitted floor), refuse it above --max-error, and write the calibration TOML.\n"
        "With --show the fit is drawn in a window: Enter or space accepts it, Esc refuses.",
        epilog="examples:\n"
        "  jostle record configs/oak.toml --out empty.mcap --duration 2\n"
        "  jostle calibrate depth --from empty.mcap --origin=0,-4 --config configs/oak.toml\n"
        "  jostle calibrate depth --from empty.mcap --origin=0.5,-3.8 --heading 5 --show --out depth.toml",
    )
    d.add_argument("--from", dest="recording", type=Path, required=True, metavar="REC.mcap",
                   help="a recording of the empty stage holding depth frames")
    d.add_argument("--channel", default="", help="the recording's depth channel (default: the only one)")
    d.add_argument("--frames", type=int, default=10, metavar="N", help="median of the first N frames (default 10)")
    d.add_argument("--origin", default="0,0", metavar="X,Y",
                   help="stage metres of the floor point below the camera; write --origin=-0.5,-4 for a minus")
    d.add_argument("--heading", type=float, default=0.0, metavar="DEG", help="the stage's y axis from the view's")
    d.add_argument("--max-error", type=float, default=0.05, metavar="M",
                   help="refuse a floor whose RMS reprojection error exceeds M metres (default 0.05)")
    d.add_argument("--out", type=Path, default=None, metavar="FILE.toml",
                   help=f"where to write it (default: {DEFAULT_DEPTH_NAME} next to --config)")
    d.add_argument("--config", type=Path, default=None, help="the installation config it is for")
    d.add_argument("--show", action="store_true", help="show the fit in a window and ask to accept it")
    d.add_argument("--force", action="store_true", help="overwrite --out if it exists")
    d.set_defaults(func=cmd_calibrate_depth)


def cmd_calibrate_depth(args: argparse.Namespace) -> int:
    import warnings

    import numpy as np

    from interaction.depth.calibration import DepthCalibrationError, calibrate_depth, fit_floor
    from sensors.base import DepthImage
    from sensors.recording.info import describe_recording, select_channel
    from sensors.recording.source import iter_payloads

    out = _out_path(args, DEFAULT_DEPTH_NAME)
    if args.frames < 1:
        raise _usage(f"--frames: expected a whole number ≥ 1, got {args.frames}")
    if not args.max_error > 0:
        raise _usage(f"--max-error: expected metres > 0, got {args.max_error}")
    origin = _pair(args.origin, "--origin")
    info = describe_recording(args.recording)
    depth_channels = [c for c in info.sensor_channels if c.kind == "depth"]
    if not args.channel and len(depth_channels) == 1:
        channel = depth_channels[0]
    else:
        channel = select_channel(info, args.channel or None)
    if channel.kind != "depth":
        raise _usage(f"{args.recording}: channel {channel.topic!r} holds {channel.kind}, expected depth frames")
    images: list[DepthImage] = []
    for _, _, payload in iter_payloads(args.recording, channel.topic):
        if isinstance(payload, DepthImage):
            if images and payload.depth_mm.shape != images[0].depth_mm.shape:
                raise _usage(f"{args.recording}: the depth frames change size")
            images.append(payload)
        if len(images) >= args.frames:
            break
    if not images:
        raise _usage(f"{args.recording}: no depth frames in channel {channel.topic!r}")
    stack = np.stack([im.depth_mm for im in images]).astype(np.float32)
    stack[stack == 0] = np.nan
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN pixels: no data in any frame
        median = np.nan_to_num(np.nanmedian(stack, axis=0)).astype(np.uint16)
    first = images[0]
    intrinsics = (first.fx, first.fy, first.cx, first.cy)
    try:
        fit = fit_floor(median, intrinsics)
    except DepthCalibrationError as e:
        raise _usage(f"{args.recording}: {e}") from None
    print(f"jostle: {fit.describe()} (median of {len(images)} frames)")
    if fit.rms_m > args.max_error:
        raise _usage(f"calibration refused: the floor's reprojection error {fit.rms_m:.3f} m exceeds --max-error "
                     f"{args.max_error:g} m; record the stage empty (nobody, nothing moved onto it), with more floor "
                     "in view (tilt the camera down), or raise --max-error if the camera is far from the stage")
    if fit.inliers < 0.2 * fit.valid:
        raise _usage(f"calibration refused: only {fit.inliers} of {fit.valid} pixels lie on the floor; tilt the camera "
                     "so the floor fills at least a fifth of the view, and record the stage empty")
    calibration = calibrate_depth(fit, origin, args.heading, first.size)
    if args.show and not _accept_in_window(median, intrinsics, fit):
        raise _usage("calibration refused in the window; nothing written")
    calibration.save(out)
    print(f"jostle: camera at stage ({', '.join(f'{v:.3f}' for v in calibration.translation)}) m")
    print(f"jostle: calibration: {out}")
    return 0


def _accept_in_window(depth_mm: np.ndarray, intrinsics: tuple[float, float, float, float], fit: Any) -> bool:
    """Show the depth with the floor's pixels tinted green; True on Enter/space, False on Esc."""
    import cv2
    import numpy as np

    from interaction.depth.calibration import camera_points

    pts, vu = camera_points(depth_mm, intrinsics)
    grey = cv2.normalize(depth_mm, None, 0, 255, cv2.NORM_MINMAX).astype(np.uint8)  # type: ignore[call-overload, unused-ignore]  # OpenCV 5.0 stubs reject None; 5.1 takes it
    img = cv2.cvtColor(grey, cv2.COLOR_GRAY2BGR)
    on = np.abs(pts @ np.array(fit.plane[:3]) + fit.plane[3]) < 0.05
    img[vu[on, 0], vu[on, 1]] = (img[vu[on, 0], vu[on, 1]] // 2 + np.array([0, 127, 0], np.uint8))
    cv2.putText(img, "floor: Enter accepts, Esc refuses", (8, 20), cv2.FONT_HERSHEY_SIMPLEX, 0.5, (0, 0, 255), 1)
    title = "jostle calibrate depth"
    try:
        cv2.imshow(title, img)
        while True:
            key = cv2.waitKey(100) & 0xFF
            if key in (13, 10, 32):
                return True
            if key == 27 or cv2.getWindowProperty(title, cv2.WND_PROP_VISIBLE) < 1:
                return False
    finally:
        cv2.destroyAllWindows()
