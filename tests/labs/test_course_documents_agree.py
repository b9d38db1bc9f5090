"""The course documents agree with the grader (issue 68): each lab's points in the syllabus, in its notebook's
first cell (labs/ and solutions/) and wherever a notebook names a task or a question; the course's totals
and lab 09's share; the number of labs; what students hand in, as `pendkit grade` finds it.

Every expected number is read from the grader (the suites, the kit's hidden tests, `written(...)`)."""

import functools
import re
import shutil
from dataclasses import dataclass
from pathlib import Path

import nbformat
import pytest

from pendkit.grading.core import TASKS, kit_hidden_tests, known_labs, lab_of, load_hidden, load_lab
from pendkit.grading.submissions import find_submissions
from pendkit.grading.written import questions_of
from pendkit.labs.build import lab_files

ROOT = Path(__file__).resolve().parents[2]
SYLLABUS = ROOT / "docs" / "syllabus.md"
GUIDES = sorted((ROOT / "docs").rglob("*.md")) + [ROOT / "README.md", ROOT / "CONTRIBUTING.md"]
LABS = known_labs()
NOTEBOOKS = {(lab.number, folder): path for lab in lab_files(ROOT / "solutions", ROOT / "labs")
             for folder, path in (("solutions", lab.source), ("labs", lab.target))}
NUMBER_WORDS = ("zero one two three four five six seven eight nine ten eleven twelve thirteen fourteen fifteen "
                "sixteen seventeen eighteen nineteen twenty").split()
POINTS_MENTION = re.compile(r"`(\d\d\.[a-z_0-9]+)`(?: \(|, )(\d+) points?")
POINTS_LINE = re.compile(r"\*\*Points:\*\* (\d+) automatic \+ (\d+) written = (\d+)")


@dataclass(frozen=True)
class LabPoints:
    tasks: dict[str, float]  # task id -> its public and hidden tests' points
    written: dict[str, float]  # question id -> points, marked by hand
    titles: dict[str, str]  # question id -> its title, lower case

    @property
    def automatic(self) -> float:
        return sum(self.tasks.values())

    @property
    def total(self) -> float:
        return self.automatic + sum(self.written.values())


@functools.cache
def graded() -> dict[str, LabPoints]:
    """Each lab's points as `pendkit grade` awards them, with the kit's hidden tests."""
    hidden = kit_hidden_tests()
    assert hidden is not None, "no solutions/tests beside the package: the hidden tests' points are unknown"
    for lab in LABS:
        load_lab(lab)
        for path in sorted(hidden.glob(f"lab{lab}_*.py")):
            load_hidden(path)
    return {lab: LabPoints({t.id: t.max_points(hidden=True) for t in TASKS.values() if lab_of(t.id) == lab},
                           {q.id: q.points for q in questions_of(lab)},
                           {q.id: q.title.lower() for q in questions_of(lab)}) for lab in LABS}


def table_rows(text: str, columns: int) -> dict[str, list[str]]:
    """The rows of the markdown tables in `text` with `columns` cells whose first cell is a lab ("07")."""
    rows = {}
    for line in text.splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if line.startswith("|") and len(cells) == columns and re.fullmatch(r"\d\d", cells[0]):
            rows[cells[0]] = cells
    return rows


def section(text: str, heading: str) -> str:
    return text.split(f"## {heading}\n", 1)[1].split("\n## ", 1)[0]


def test_the_syllabus_has_each_labs_points():
    rows = table_rows(section(SYLLABUS.read_text(), "Labs and points"), 6)
    assert sorted(rows) == LABS, f"syllabus rows {sorted(rows)}, graded labs {LABS}"
    for lab, points in graded().items():
        said = (float(rows[lab][4]), float(rows[lab][5]))
        assert said == (points.automatic, sum(points.written.values())), \
            f"syllabus: lab {lab} {said[0]:g} automatic and {said[1]:g} written; the grader " \
            f"{points.automatic:g} and {sum(points.written.values()):g}"


@pytest.mark.parametrize("lab, folder", sorted(NOTEBOOKS))
def test_each_notebook_opens_with_the_graders_points(lab, folder):
    """The first cell names every task and written question with its points, and the lab's total."""
    header = nbformat.read(NOTEBOOKS[lab, folder], as_version=4).cells[0].source
    points = graded()[lab]
    said = {task_id: float(n) for task_id, n in POINTS_MENTION.findall(header)}
    assert said == {**points.tasks, **points.written}, f"{folder}/{NOTEBOOKS[lab, folder].name}'s first cell"
    line = POINTS_LINE.search(header)
    assert line, f"{folder}/{NOTEBOOKS[lab, folder].name}: no '**Points:** A automatic + W written = T' line"
    expected = (points.automatic, sum(points.written.values()), points.total)
    assert tuple(float(n) for n in line.groups()) == expected, f"{line.group(0)}; the grader: {expected}"


@pytest.mark.parametrize("lab, folder", sorted(NOTEBOOKS))
def test_every_points_mention_in_a_notebook_is_the_graders(lab, folder):
    """Task headings, question headings, rubrics: "`NN.id` (N points" or "`NN.id`, N points"."""
    points = graded()[lab]
    known = {**points.tasks, **points.written}
    for cell in nbformat.read(NOTEBOOKS[lab, folder], as_version=4).cells:
        if cell.cell_type != "markdown":
            continue
        for task_id, said in POINTS_MENTION.findall(cell.source):
            assert task_id in known, f"{folder} lab {lab} names {task_id}, which the grader does not have"
            assert float(said) == known[task_id], f"{folder} lab {lab}: {task_id} said {said}, graded {known[task_id]}"
        question = (cell.metadata.get("pendkit") or {}).get("question")
        if question:
            assert cell.metadata["pendkit"]["points"] == points.written[question], f"{question}'s metadata"
            graded_as = re.search(r"How it is graded \((\d+) points?\)", cell.source)
            assert graded_as is None or float(graded_as.group(1)) == points.written[question], question


def test_the_syllabus_totals_and_lab_09s_share():
    text = section(SYLLABUS.read_text(), "Assessment")
    labs = graded()
    totals = re.search(r"the course has (\d+) points over the six-week plan \(without lab (\d\d)\), (\d+) with "
                       r"lab \2 \((\d+) automatic, (\d+) written\)", " ".join(text.split()))
    assert totals, "the syllabus's Assessment no longer states the course's totals in the words this test reads"
    without, left_out, everything, automatic, written = totals.groups()
    assert float(everything) == sum(p.total for p in labs.values())
    assert float(without) == sum(p.total for lab, p in labs.items() if lab != left_out)
    assert float(automatic) == sum(p.automatic for p in labs.values())
    assert float(written) == sum(sum(p.written.values()) for p in labs.values())
    share = re.search(r"Lab (\d\d): (\d+) points, of which its (.+?) carries (\d+) and its (.+?) (\d+), the most "
                      r"written points of any lab\.", " ".join(text.split()))
    assert share, "the syllabus's Assessment no longer states lab 09's share in the words this test reads"
    lab, total, first, first_points, second, second_points = share.groups()
    assert float(total) == labs[lab].total
    assert sum(labs[lab].written.values()) == max(sum(p.written.values()) for p in labs.values())
    by_title = {labs[lab].titles[q]: p for q, p in labs[lab].written.items()}
    assert {first: float(first_points), second: float(second_points)} == by_title
    assert not re.search(r"counts? double", SYLLABUS.read_text()), "the grader weighs no lab: each point counts once"


def test_the_docs_count_every_lab():
    first, last, count = LABS[0], LABS[-1], len(LABS)
    syllabus, guide = SYLLABUS.read_text(), (ROOT / "docs" / "instructor-guide.md").read_text()
    assert re.search(r"course in (\w+) labs", syllabus).group(1) == NUMBER_WORDS[count]
    assert re.search(r"Labs (\d\d)-(\d\d)\s+are in `labs/`", guide).groups() == (first, last)
    assert re.search(r"every lab's written answers\) \| (\d\d)-(\d\d) \|", syllabus).groups() == (first, last)
    one_short = re.compile(rf"\b{first}[-–]{int(last) - 1:02d}\b|\b{NUMBER_WORDS[count - 1]} labs\b", re.I)
    for path in GUIDES:  # a lab added and a guide left behind
        for number, line in enumerate(path.read_text().splitlines(), start=1):
            assert not one_short.search(line), f"{path.relative_to(ROOT)}:{number}: {line.strip()}"


def test_the_syllabus_says_what_each_lab_hands_in():
    text = section(SYLLABUS.read_text(), "What students hand in")
    rows = table_rows(text, 3)
    assert sorted(rows) == LABS, f"hand-in rows {sorted(rows)}, graded labs {LABS}"
    for lab, points in graded().items():
        assert rows[lab][1] == f"`{NOTEBOOKS[lab, 'labs'].name}`", f"lab {lab} hands in {rows[lab][1]}"
        for title in points.titles.values():
            assert title in rows[lab][2].lower(), f"lab {lab}'s hand-in row does not name its {title}"


def test_a_pairs_folder_is_one_row_named_for_the_folder(tmp_path):
    """What the syllabus and the grading guide say about a pair's folder, a flat notebook and a PDF is what
    `pendkit grade` finds."""
    pair_example = re.search(r"`([\w-]+)/(\d\d_\w+\.ipynb)`", section(SYLLABUS.read_text(), "What students hand in"))
    flat_example = re.search(r"`submissions/([\w-]+)\.ipynb`", (ROOT / "docs" / "labs-and-grading.md").read_text())
    assert pair_example and flat_example, "the docs no longer show a pair's folder and a flat notebook"
    (pair, handed_in), flat = pair_example.groups(), flat_example.group(1)
    lab = handed_in[:2]
    (tmp_path / pair).mkdir()
    shutil.copy(NOTEBOOKS[lab, "labs"], tmp_path / pair / handed_in)
    shutil.copy(NOTEBOOKS[lab, "labs"], tmp_path / f"{flat}-flat.ipynb")
    (tmp_path / "cat.pdf").write_bytes(b"%PDF-1.4")
    found = {s.student: s for s in find_submissions(tmp_path, lab)}
    assert sorted(found) == sorted([pair, f"{flat}-flat", "cat"])
    assert found[pair].lab == lab and found[pair].problem is None
    assert found[f"{flat}-flat"].problem is None
    assert found["cat"].problem.startswith("0 points")
