"""``jostle bench hostile``: a few hundred bad inputs over every surface, each a capped ``jostle`` run.

:func:`build_cases` makes the inputs in a folder (``sample=True``: one case per kind per surface,
for the tests); :func:`measure` runs them one at a time (:func:`jostle.bench.hostile_run.run_case`)
and :func:`figures` totals the outcomes, overall and per surface. ``recovered_share`` is the frames
replays kept from damaged recordings over the frames intact in them (counted from each file before
it was damaged). Targets (issue N): 0 tracebacks, hangs and internal errors; ``peak_rss_mb_max``
< 512; ``recovered_share`` ≥ 0.99. ``failures`` lists every case that missed its expectation.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

from jostle.bench.hostile_content import bvh_cases, depth_calibration_cases, gltf_cases, referenced_cases
from jostle.bench.hostile_inputs import cli_cases, config_cases, observer_cases, recording_cases
from jostle.bench.hostile_operations import endpoint_cases, health_cases, pads_cases, service_cases
from jostle.bench.hostile_run import Case, Outcome, passes, run_case
from jostle.bench.hostile_workspace import Workspace

BUILDERS: tuple[Callable[[Workspace, bool], list[tuple[Case, bool]]], ...] = (
    recording_cases, observer_cases, config_cases, cli_cases, referenced_cases, depth_calibration_cases, bvh_cases,
    gltf_cases, service_cases, health_cases, endpoint_cases, pads_cases)

SURFACES = ("recording", "observers", "config", "cli", "keyframes", "character_spec", "calibration", "pose_file", "terrain",
            "depth_calibration", "bvh", "gltf", "service", "health", "pads")

EPILOG = """\
Every case runs as its own `jostle …` process under a memory cap (RLIMIT_AS) and a timeout, in a
temporary folder; nothing outside it is written and no real device node is opened (/dev/zero and
/dev/full are twins made with mknod). Outcomes: clean_errors (exit 2, one 'jostle: error:' line),
warnings (one 'jostle: warning:' line), tracebacks, hangs (killed at --timeout), internal_errors
(exit 1 'internal error' or a signal); peak_rss_mb is the child's VmHWM. A case fails when it is
bad, misses the one line it should give, keeps < 99 % of a damaged recording's intact frames, or
peaks at 512 MB or more on an input under 10 MB. Progress goes to stderr, one line per case.

examples:
  jostle bench hostile --json                      every case (~20 min while many hang; minutes once fixed)
  jostle bench hostile --sample --surface gltf     one case per kind, glTF imports only
  jostle bench hostile --keep out/hostile --json   keep the inputs to replay a case by hand
"""


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.epilog = EPILOG
    parser.add_argument("--sample", action="store_true", help="one case per kind per surface (what the tests run)")
    parser.add_argument("--surface", action="append", default=[], metavar="NAME",
                        help="only this surface (repeatable): " + ", ".join(SURFACES))
    parser.add_argument("--timeout", type=float, default=20.0, metavar="S", help="seconds before a case is a hang")
    parser.add_argument("--mem-cap-mb", type=int, default=4096, metavar="MB",
                        help="RLIMIT_AS of each child (address space; the RSS target is 512 MB)")
    parser.add_argument("--keep", type=Path, default=None, metavar="DIR", help="build the inputs in DIR and keep them")


def build_cases(ws: Workspace, *, sample: bool, surfaces: tuple[str, ...] = ()) -> list[Case]:
    """Every case (or the sample), optionally only those of ``surfaces``."""
    cases = [case for build in BUILDERS for case, in_sample in build(ws, sample) if in_sample or not sample]
    return [c for c in cases if not surfaces or c.surface in surfaces]


def _totals(cases: list[Case], outcomes: list[Outcome]) -> dict[str, Any]:
    kinds = [o.kind for o in outcomes]
    intact = sum(c.intact or 0 for c in cases)
    kept = sum(min(o.kept or 0, c.intact or 0) for c, o in zip(cases, outcomes, strict=True) if c.intact)
    return {"inputs": len(outcomes), "clean_errors": kinds.count("clean_error"), "warnings": kinds.count("warning"),
            "tracebacks": kinds.count("traceback"), "hangs": kinds.count("hang"),
            "internal_errors": kinds.count("internal_error"), "accepted": kinds.count("ok"),
            "other": kinds.count("other"),
            "peak_rss_mb_max": max((o.peak_rss_mb for o in outcomes), default=0.0),
            "recovered_share": round(kept / intact, 4) if intact else None,
            "failed": sum(1 for c, o in zip(cases, outcomes, strict=True) if passes(c, o))}


def figures(cases: list[Case], outcomes: list[Outcome], skipped: list[str]) -> dict[str, Any]:
    """Totals, the same per surface, the failures (case id → what is wrong) and the skipped cases."""
    result = _totals(cases, outcomes)
    surfaces: dict[str, Any] = {}
    for name in dict.fromkeys(c.surface for c in cases):
        pairs = [(c, o) for c, o in zip(cases, outcomes, strict=True) if c.surface == name]
        surfaces[name] = _totals([c for c, _ in pairs], [o for _, o in pairs])
    result["surfaces"] = surfaces
    result["failures"] = {c.id: "; ".join(passes(c, o)) for c, o in zip(cases, outcomes, strict=True) if passes(c, o)}
    result["skipped"] = skipped
    return result


def measure(cases: list[Case], ws: Workspace, *, timeout_s: float, mem_cap_mb: int) -> list[Outcome]:
    outcomes = []
    for i, case in enumerate(cases, 1):
        o = run_case(case, timeout_s=timeout_s, mem_cap_mb=mem_cap_mb, cwd=ws.root)
        outcomes.append(o)
        print(f"jostle: hostile {i}/{len(cases)} {case.id}: {o.kind} ({o.seconds:.1f} s, {o.peak_rss_mb:.0f} MB)",
              file=sys.stderr, flush=True)
    return outcomes


def run(args: argparse.Namespace) -> dict[str, Any]:
    if args.timeout <= 0 or args.mem_cap_mb < 256:
        raise ValueError(f"--timeout must be > 0 and --mem-cap-mb ≥ 256, got {args.timeout} and {args.mem_cap_mb}")
    unknown = [s for s in args.surface if s not in SURFACES]
    if unknown:
        raise ValueError(f"--surface: unknown {unknown[0]!r} (known: {', '.join(SURFACES)})")
    with tempfile.TemporaryDirectory(prefix="jostle-hostile-") as tmp:
        root = args.keep if args.keep is not None else Path(tmp)
        root.mkdir(parents=True, exist_ok=True)
        ws = Workspace(root)
        cases = build_cases(ws, sample=args.sample, surfaces=tuple(args.surface))
        outcomes = measure(cases, ws, timeout_s=args.timeout, mem_cap_mb=args.mem_cap_mb)
        return figures(cases, outcomes, ws.skipped)
