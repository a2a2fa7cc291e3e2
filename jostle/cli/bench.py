"""``jostle bench …``: every benchmark an issue names, as a command that prints its figures.

Each benchmark lives in the package it measures, as a module with two functions::

    def add_arguments(parser: argparse.ArgumentParser) -> None   # its own flags (--characters, …)
    def run(args: argparse.Namespace) -> dict[str, object]        # measures, returns the figures

Timings are ratios measured in one run against a baseline in the same process. ``--json`` prints
the figures for machines; without it they are printed one per line for people.
"""

from __future__ import annotations

import argparse
import importlib
import json
from typing import Any

RAW = argparse.RawDescriptionHelpFormatter

# name → (module, one-line description). A module that does not exist yet is listed as unavailable.
BENCHES: dict[str, tuple[str, str]] = {
    "pipeline": ("jostle.bench.pipeline", "the demo's cost per stage: decode, observe, simulate, draw"),
    "sim": ("jostle.bench.sim", "N characters with controller and AI against N bare bodies, same run"),
    "identify": ("jostle.bench.identify", "the paper's observer experiment (§6.2) done by machine, on the drawn figure"),
    "render": ("jostle.bench.render", "headless frame rate and pose evaluation cost for N characters"),
    "sensors": ("jostle.bench.sensors", "pad parser fuzz and rate, recording replay speed"),
    "interaction": ("jostle.bench.interaction", "observers against virtual-performer ground truth"),
    "synth": ("jostle.bench.performer", "virtual performer: ms per frame of webcam, OAK depth (+colour) and pads"),
    "soak": ("jostle.bench.soak", "the demo looped headless for minutes: memory and frame-rate drift"),
    "ragdoll": ("jostle.bench.ragdoll", "articulated characters: cost vs DeepMimic stable PD, tracking, pushes, get-ups"),
    "quadruped": ("jostle.bench.quadruped", "quadruped on generated cube terrains: goals, feet, replan time, fps"),
}


def _module(name: str) -> Any | None:
    try:
        return importlib.import_module(BENCHES[name][0])
    except ModuleNotFoundError as e:
        if e.name == BENCHES[name][0]:
            return None
        raise


def add(sub: Any) -> None:
    p = sub.add_parser(
        "bench",
        help="run a benchmark and print its figures (--json for machines)",
        formatter_class=RAW,
        description="Benchmarks of jostle. Each prints its figures; add --json for a machine-readable\n"
        "object. Timings are ratios against a baseline measured in the same run.",
        epilog="examples:\n  jostle bench pipeline --json\n  jostle bench sensors --fuzz-bytes 1000000 --json",
    )
    benches = p.add_subparsers(dest="bench", metavar="BENCH", required=True)
    for name, (_, description) in BENCHES.items():
        module = _module(name)
        b = benches.add_parser(name, help=description + ("" if module else " (not built yet)"),
                               description=description, formatter_class=RAW)
        b.add_argument("--json", action="store_true", help="print the figures as one JSON object")
        if module is not None:
            module.add_arguments(b)
        b.set_defaults(func=_runner(name))


def _runner(name: str) -> Any:
    def run(args: argparse.Namespace) -> int:
        module = _module(name)
        if module is None:
            from jostle.cli.main import UsageError

            raise UsageError(f"bench {name}: not built yet ({BENCHES[name][0]} is missing)")
        try:
            figures: dict[str, Any] = module.run(args)
        except ValueError as e:  # a bad flag value: one line, like every other user error
            from jostle.cli.main import UsageError

            raise UsageError(f"bench {name}: {e}") from None
        if args.json:
            print(json.dumps(figures, indent=2, default=str))
        else:
            width = max(len(k) for k in figures) if figures else 0
            for k, v in figures.items():
                shown = f"{v:.4g}" if isinstance(v, float) else v
                print(f"{k:<{width}}  {shown}")
        return 0

    return run


def main_json(name: str, argv: list[str]) -> dict[str, Any]:
    """Run a benchmark in-process and return its figures (for tests)."""
    parser = argparse.ArgumentParser()
    module = _module(name)
    if module is None:
        raise RuntimeError(f"bench {name} is not built")
    module.add_arguments(parser)
    result: dict[str, Any] = module.run(parser.parse_args(argv))
    return result

