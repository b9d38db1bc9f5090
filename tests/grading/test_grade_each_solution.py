"""Every solution notebook graded one by one as a class is graded: full automatic marks on every task."""

from pathlib import Path

import nbformat
import pytest

from pendkit.grading.runner import DEMO_TAG, grade_notebook

ROOT = Path(__file__).resolve().parents[2]
HIDDEN = ROOT / "solutions" / "tests"

pytestmark = pytest.mark.expensive  # a minute or two in all: scheduled first (conftest.py)


@pytest.mark.parametrize("solution_file", sorted((ROOT / "solutions").glob("*.ipynb")), ids=lambda p: p.name)
def test_every_solution_graded_as_a_class_is_gets_full_marks(solution_file):
    """The class's path (the student's kernel, every argument sent as data, hidden tests included): a
    correct notebook must score every automatic point (lab 10's bytes once arrived as an opaque value)."""
    lab = solution_file.name[:2]
    grade = grade_notebook(solution_file, "solution", lab, sorted(HIDDEN.glob(f"lab{lab}_*.py")), 60, 180)
    assert grade.tasks and grade.score == grade.max_score, [(t.task, t.score, t.max_score) for t in grade.tasks]
    if any(DEMO_TAG in c.metadata.get("tags", []) for c in nbformat.read(solution_file, as_version=4).cells):
        assert any("demonstration cells" in note for note in grade.notes)
