"""Every untouched lab template graded as a class is graded: 0 on every task, and no raw exception."""

from pathlib import Path

import pytest

from pendkit.grading.runner import grade_notebook

ROOT = Path(__file__).resolve().parents[2]
HIDDEN = ROOT / "solutions" / "tests"


@pytest.mark.expensive  # lab 09 alone runs 40 s on its real-time rig
@pytest.mark.parametrize("lab_file", sorted((ROOT / "labs").glob("*.ipynb")), ids=lambda p: p.name)
def test_invert_untouched_labs_score_zero_on_every_task(lab_file):
    lab = lab_file.name[:2]
    grade = grade_notebook(lab_file, "nobody", lab, sorted(HIDDEN.glob(f"lab{lab}_*.py")), 60, 180)
    assert grade.tasks and grade.max_score > 0
    for task in grade.tasks:
        assert task.score == 0, f"{task.task} scored {task.score} on the untouched lab"
    assert not any("raised" in note for note in grade.notes), grade.notes
