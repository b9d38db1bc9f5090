"""What a lab tells students about itself agrees with the grader and the syllabus: every task's points in
the header and in its heading are the grader's total (public and hidden tests), the time is the
syllabus's, and the syllabus's points are the lab's."""

import re
from pathlib import Path

import nbformat
import pytest

from pendkit.grading import TASKS
from pendkit.labs.build import lab_files

ROOT = Path(__file__).resolve().parents[2]
LABS = {lab.number: lab.source for lab in lab_files(ROOT / "solutions", ROOT / "labs")}
MENTION = re.compile(r"`(\d\d\.[a-z_0-9]+)`(?: \(|, )(\d+)(?: points?)?")


def syllabus_rows() -> dict[str, list[str]]:
    rows = {}
    for line in (ROOT / "docs" / "syllabus.md").read_text().splitlines():
        cells = [c.strip() for c in line.strip("|").split("|")]
        if len(cells) == 6 and re.fullmatch(r"\d\d", cells[0]):
            rows[cells[0]] = cells
    return rows


def totals() -> dict[str, int]:
    return {task_id: sum(t.points for t in task.tests) for task_id, task in TASKS.items()}


@pytest.mark.parametrize("lab", sorted(LABS))
def test_every_points_mention_is_the_graders_total(all_tests_loaded, lab):
    points = totals()
    for cell in nbformat.read(LABS[lab], as_version=4).cells:
        if cell.cell_type == "markdown":
            for task_id, said in MENTION.findall(cell.source):
                if task_id not in points:  # a written question: its own test holds it to its metadata
                    continue
                assert int(said) == points[task_id], f"{lab}: {task_id} said {said}, graded {points[task_id]}"


@pytest.mark.parametrize("lab", sorted(LABS))
def test_every_task_mention_reads_as_points(lab):
    """A task's points are written "(N points)" (a header once said "(3None)")."""
    for cell in nbformat.read(LABS[lab], as_version=4).cells:
        if cell.cell_type == "markdown":
            for said in re.findall(r"`\d\d\.[a-z_0-9]+` \(([^)]*)\)", cell.source):
                assert re.fullmatch(r"\d+ points?", said), f"lab {lab}: a task's points read ({said})"


@pytest.mark.parametrize("lab", sorted(LABS))
def test_time_and_points_agree_with_the_syllabus(all_tests_loaded, lab):
    notebook = nbformat.read(LABS[lab], as_version=4)
    row = syllabus_rows()[lab]
    said = re.search(r"about (\d+) minutes", notebook.cells[0].source).group(1)
    assert row[2].startswith(f"{said} min"), f"lab {lab} says {said} minutes, the syllabus {row[2]}"
    automatic = sum(points for task_id, points in totals().items() if task_id.startswith(f"{lab}."))
    written = sum(c.metadata["pendkit"]["points"] for c in notebook.cells
                  if "question" in c.metadata.get("pendkit", {}))
    assert (int(row[4]), int(row[5])) == (automatic, written), f"lab {lab}: syllabus {row[4]}/{row[5]}"
