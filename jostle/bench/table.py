"""The benches of ``jostle bench``: name → (module, one-line description), imported normally.

Each bench module has two functions::

    def add_arguments(parser: argparse.ArgumentParser) -> None   # its own flags (--characters, …)
    def run(args: argparse.Namespace) -> dict[str, object]        # measures, returns the figures

A bench that cannot be imported fails here, loudly, when the ``jostle`` command is built.
"""

from __future__ import annotations

from types import ModuleType

from jostle.bench import (
    hostile,
    identify,
    interaction,
    performer,
    pipeline,
    pose,
    quadruped,
    ragdoll,
    render,
    sensors,
    sim,
    soak,
)

BENCHES: dict[str, tuple[ModuleType, str]] = {
    "pipeline": (pipeline, "the demo's cost per stage: decode, observe, simulate, draw"),
    "sim": (sim, "N characters with controller and AI against N bare bodies, same run"),
    "identify": (identify, "the paper's observer experiment (§6.2) done by machine, on the drawn figure"),
    "render": (render, "headless frame rate and pose evaluation cost for N characters"),
    "sensors": (sensors, "pad parser fuzz and rate, recording replay speed"),
    "interaction": (interaction, "observers against virtual-performer ground truth"),
    "pose": (pose, "webcam observer fps with pose on vs off, keypoint refreshes per person, on real people"),
    "synth": (performer, "virtual performer: ms per frame of webcam, OAK depth (+colour) and pads"),
    "soak": (soak, "the demo looped headless for minutes: memory and frame-rate drift"),
    "ragdoll": (ragdoll, "articulated characters: cost vs DeepMimic stable PD, tracking, pushes, get-ups"),
    "hostile": (hostile, "a few hundred bad inputs over every surface: one line each, no tracebacks, hangs or bombs"),
    "quadruped": (quadruped, "quadruped on generated cube terrains: goals, feet, replan time, fps"),
}
