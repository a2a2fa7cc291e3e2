"""`jostle bench pose`, run small on one real clip: the figures are there and mean what they say.
Needs the shared media folder (``$JOSTLE_MEDIA`` or ../shared/media beside the checkout, as CI has it)."""

from __future__ import annotations

import math
import os
from pathlib import Path

import pytest

from jostle.cli.bench import main_json

MEDIA = Path(os.environ.get("JOSTLE_MEDIA", "") or Path(__file__).resolve().parents[1].parent / "shared" / "media")


@pytest.mark.skipif(not (MEDIA / "video" / "face-demographics-walking.gif").is_file(),
                    reason=f"the shared media folder is not at {MEDIA} (set JOSTLE_MEDIA)")
def test_the_bench_reports_every_figure_and_the_worker_beats_inline() -> None:
    figures = main_json("pose", ["--media", str(MEDIA), "--scenes", "walking", "--seconds", "0.4"])
    for key in ("people", "fps_off", "fps_on", "ratio_on_off", "ratio_sync_off", "loop_cpu_ms_off", "loop_cpu_ms_on",
                "refresh_per_person_s", "refresh_per_person_s_min", "refresh_per_person_s_live"):
        value = figures[f"walking.{key}"]
        assert isinstance(value, float) and math.isfinite(value) and value >= 0, (key, value)
    assert figures["walking.people"] >= 1.0  # two or three people walk toward the camera
    assert figures["walking.ratio_on_off"] > 0 and figures["walking.ratio_sync_off"] > 0
    # the model inline costs ~25 ms a person a frame; beside the loop, the loop does not pay it
    assert figures["walking.ratio_sync_off"] < figures["walking.ratio_on_off"]
    assert figures["cpus"] >= 1
    with pytest.raises(ValueError, match="--scenes: nowhere is not one of"):
        main_json("pose", ["--media", str(MEDIA), "--scenes", "nowhere"])
