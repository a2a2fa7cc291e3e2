"""The shipped demo pushes with a person's strength: its contact peak stays within the person's budget."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest

from jostle.app import App, RunOptions
from jostle.config import load_config
from jostle.summary import RunSummary

DEMO = Path(__file__).resolve().parent.parent / "configs" / "demo.toml"
DEMO_PEAK_N = 1500.0  # issue K's target for the demo's max_contact_force_n


def _run(duration: float | None) -> RunSummary:
    cfg = load_config(DEMO)
    small = dataclasses.replace(cfg, render=dataclasses.replace(cfg.render, width=160, height=90))
    return App(small, RunOptions(out_dir=None, seed=7, duration_s=duration, video=False, progress=False)).run()


def test_the_demo_first_shoves_stay_within_the_budget() -> None:
    """The first 5 s (the person comes in at about 1.9 s and shoves): fast."""
    budget = load_config(DEMO).world.max_person_force_n
    s = _run(5.0)
    assert s.pushes >= 1
    assert 0.0 < s.max_contact_force_n <= budget * (1 + 1e-9) <= DEMO_PEAK_N


@pytest.mark.slow
def test_the_whole_demo_peaks_below_1_5_kn_and_still_pushes_people_over() -> None:
    s = _run(None)
    assert s.max_contact_force_n <= DEMO_PEAK_N
    assert s.pushes >= 10 and s.falls >= 3, (s.pushes, s.falls)


@pytest.mark.slow
@pytest.mark.xfail(strict=True, reason="issue K asks for 3 get-ups; the demo gives 2 under the 800 N budget "
                                       "(docs/notes/contact-law.md)")
def test_the_whole_demo_shows_three_get_ups() -> None:
    assert _run(None).getups >= 3
