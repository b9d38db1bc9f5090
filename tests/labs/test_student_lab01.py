"""Lab 01: a wrong shift is scored where the position is (once public, once hidden), and the reflection's
figures are the rig's."""

from pathlib import Path

import nbformat

from pendkit.grading import run_task
from pendkit.rig import RigParams
from tests.grading.test_wrong_answers import KEYS

ROOT = Path(__file__).resolve().parents[2]


def test_lab01_an_off_by_one_shift_fails_the_position_tests_only():
    results = run_task("01.decode_frame", KEYS["01"].decode_off_by_one_shift, include_hidden=True)
    failed = {r.name for r in results if not r.passed}
    assert failed == {"positions_of_clean_frames", "every_position_round_trips"}, failed
    assert sum(r.max_points - r.points for r in results) == 4
    assert all("frame >> 6" in r.message for r in results if not r.passed)


def test_lab01_the_reflections_figures_are_the_rigs():
    params = RigParams()
    notebook = nbformat.read(ROOT / "solutions" / "01_encoder.ipynb", as_version=4)
    text = " ".join(" ".join(cell.source for cell in notebook.cells).split())
    half_turn_rev_s = (params.encoder_counts / 2) / params.encoder_counts / (params.streaming_period_ms / 1000)
    assert params.streaming_period_ms == 25.0 and half_turn_rev_s == 20.0 and params.overspin_limit_rev_s == 2.0
    assert "512 counts per 25 ms = 20 rev/s. The over-spin stop (2 rev/s)" in text
    assert "a velocity spike of up to 20 rev/s" in text  # the largest wrap-aware step, 512 counts, in one period
    assert "`frame` is an `int` from 0 to 0xFFFF" in text  # what arrives, answered in the task
    assert round(360 / params.encoder_counts, 2) == 0.35 and "**1024 positions** per turn (0.35° each)" in text
