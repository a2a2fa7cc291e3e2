"""The ``jostle`` command: its table of subcommands and ``main``. Every subcommand's ``--help`` says
what it does and shows an example."""

from __future__ import annotations

import argparse
import logging
import sys
import traceback
import warnings
from collections.abc import Callable
from typing import Any, TextIO

from jostle import __version__
from jostle.cli import bench, calibrate, keyframes, observe, ragdoll, run, service, synth, terrain, tools

DESCRIPTION = """\
jostle: people in front of sensors push, hit and shove on-screen characters, and the characters
react physically, in the style their animators designed.

Start with the embedded demo (a shipped recording, replayed headless into a video):
  jostle run configs/demo.toml --headless --out out/demo
"""

EPILOG = """\
examples:
  jostle run configs/demo.toml --headless --out out/demo     replay the demo into out/demo/demo.mp4
  jostle info configs/recordings/demo.mcap                   what a recording holds
  jostle record configs/webcam.toml --out session.mcap       record live sensors
  jostle replay session.mcap --config configs/webcam.toml    run a recorded session again
  jostle synth performer --clip walk --out demo.mcap         make a recording of a virtual person
  jostle observe street.mp4 --no-pose --json                 people found in a video, before calibrating
  jostle doctor                                              check OpenGL, cameras, serial, DepthAI
  jostle service install configs/webcam.toml --user          start it at boot under systemd (kiosk)
Run 'jostle COMMAND --help' for each command's options.
"""


# The one table of subcommands, in the order ``jostle --help`` lists them. Each adds its parser and
# names the function that runs it.
COMMANDS: tuple[Callable[[Any], None], ...] = (
    run.add_run,
    run.add_record,
    run.add_replay,
    run.add_info,
    synth.add,
    keyframes.add,
    calibrate.add,
    observe.add,  # jostle observe (people in a video, uncalibrated)
    tools.add,
    bench.add,
    service.add,
    ragdoll.add,  # jostle ragdoll (articulated characters)
    terrain.add,  # jostle terrain (cube layouts)
)


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="jostle",
        description=DESCRIPTION,
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("--version", action="version", version=f"jostle {__version__}")
    p.add_argument("--debug", action="store_true", help="show full tracebacks and debug logging")
    sub = p.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for add in COMMANDS:
        add(sub)
    return p


def main(argv: list[str] | None = None) -> int:
    """Runs one command; its exit status. A reader that closes the pipe early ends it quietly
    (:mod:`jostle.cli.terminal`: status 141, as for other tools stopped by a closed pipe)."""
    from jostle.cli.terminal import end_on_closed_pipe, flush_output

    try:
        try:
            status = _command(argv)
        except SystemExit:  # argparse: --help, --version or a usage error, already printed
            flush_output()
            raise
        flush_output()
        return status
    except BrokenPipeError:
        return end_on_closed_pipe()


def _command(argv: list[str] | None) -> int:
    parser = _parser()
    args = parser.parse_args(argv)
    terse = "jostle: %(levelname)s: %(message)s"
    logging.basicConfig(
        level=logging.DEBUG if args.debug else logging.INFO,
        format=terse if not args.debug else "%(asctime)s %(name)s %(levelname)s %(message)s",
    )
    from jostle.cli.journal import adopt_journal, prefix
    from jostle.cli.terminal import one_line_records

    if not args.debug:
        one_line_records(terse)  # a crash logged by an observer: its line; the traceback with --debug
    adopt_journal()  # under systemd: one `<priority>key=value` line per record, for the journal
    from jostle.errors import RunFailed, user_facing
    from jostle.quiet import import_pybullet_quietly

    if args.command in ("run", "replay", "bench", "synth", "keyframes"):
        import_pybullet_quietly()

    previous_showwarning = warnings.showwarning
    warnings.showwarning = _one_line_warning
    try:
        from jostle.cli.flags import check_flags

        check_flags(args)
        result = args.func(args)
        return int(result or 0)
    except KeyboardInterrupt:
        print("jostle: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:  # the reader closed the pipe: main ends quietly
        raise
    except RunFailed as e:  # the run went to its end without doing its job (the summary says why too)
        print(f"{prefix(logging.ERROR)}jostle: error: {e}", file=sys.stderr)  # (--debug: the crash logged it)
        return 1
    except Exception as e:  # one line for what the user can fix; a traceback only for real bugs
        message = user_facing(e)
        if message is not None:
            print(f"{prefix(logging.ERROR)}jostle: error: {message}", file=sys.stderr)
            if args.debug:
                traceback.print_exc()
            return 2
        if args.debug:
            raise
        print(f"{prefix(logging.ERROR)}jostle: internal error: {type(e).__name__}: {e} (run with --debug for the "
              "traceback)", file=sys.stderr)
        return 1
    finally:
        warnings.showwarning = previous_showwarning


def _one_line_warning(
    message: Warning | str,
    category: type[Warning],
    filename: str,
    lineno: int,
    file: TextIO | None = None,
    line: str | None = None,
) -> None:
    """Warnings (a damaged recording, a missing keyframe behaviour) as one line for the user."""
    from jostle.cli.journal import prefix

    print(f"{prefix(logging.WARNING)}jostle: warning: {message}", file=sys.stderr)


if __name__ == "__main__":
    sys.exit(main())
