"""``jostle bench …``: every benchmark an issue names, as a command that prints its figures.

Every benchmark is a module of :mod:`jostle.bench`, named in its table (:mod:`jostle.bench.table`).
Timings are ratios measured in one run against a baseline in the same process. ``--json`` prints
the figures for machines; without it they are printed one per line for people.
"""

from __future__ import annotations

import argparse
import json
from typing import Any

from jostle.bench.table import BENCHES

RAW = argparse.RawDescriptionHelpFormatter


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
    for name, (module, description) in BENCHES.items():
        b = benches.add_parser(name, help=description, description=description, formatter_class=RAW)
        b.add_argument("--json", action="store_true", help="print the figures as one JSON object")
        module.add_arguments(b)
        b.set_defaults(func=_runner(name))


def _runner(name: str) -> Any:
    def run(args: argparse.Namespace) -> int:
        module = BENCHES[name][0]
        try:
            figures: dict[str, Any] = module.run(args)
        except ValueError as e:  # a bad flag value: one line, like every other user error
            from jostle.errors import UsageError

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
    module = BENCHES[name][0]
    module.add_arguments(parser)
    result: dict[str, Any] = module.run(parser.parse_args(argv))
    return result

