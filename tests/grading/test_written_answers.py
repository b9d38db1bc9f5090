"""Written answers reach the instructor: `pendkit grade` puts each answer's text in results.json and leaves
a column in grades.csv; a blank answer says so; no point is given automatically."""

import csv
import json
import shutil
from pathlib import Path

import nbformat

from pendkit.grading.report import grade_folder
from pendkit.grading.written import ANSWER_PROMPT, collect_answers, questions_of
from pendkit.labs.build import lab_files
from tests.system_needs import class_isolation

ROOT = Path(__file__).resolve().parents[2]


def test_every_lab_asks_for_a_written_answer_and_its_student_copy_has_the_prompt():
    from pendkit.grading.core import load_lab

    for lab in [lab.number for lab in lab_files(ROOT / "solutions", ROOT / "labs")]:
        load_lab(lab)
        questions = questions_of(lab)
        assert questions, lab
        student = nbformat.read(next((ROOT / "labs").glob(f"{lab}_*.ipynb")), as_version=4)
        assert [a.text for a in collect_answers(student, lab)] == [""] * len(questions), lab
        prompts = [c for c in student.cells if (c.metadata.get("pendkit") or {}).get("answer")]
        assert prompts and all(c.source == ANSWER_PROMPT for c in prompts)


def test_an_answer_is_collected_for_the_instructor_and_scores_nothing_by_itself(tmp_path):
    notebook = nbformat.read(ROOT / "labs" / "00_tour.ipynb", as_version=4)
    answer = next(c for c in notebook.cells if (c.metadata.get("pendkit") or {}).get("answer") == "00.reflection")
    answer.source = "1. The reward is highest upright because ...\n2. Ten steps is 0.6 s."
    for student, nb in (("ann", notebook), ("bob", nbformat.read(ROOT / "labs" / "00_tour.ipynb", as_version=4))):
        (tmp_path / "class" / student).mkdir(parents=True)
        nbformat.write(nb, tmp_path / "class" / student / "00_tour.ipynb")
    shutil.copy(ROOT / "solutions" / "tests" / "lab00_hidden.py", tmp_path / "lab00_hidden.py")
    grades = grade_folder(tmp_path / "class", tmp_path / "out", "00", tmp_path, 60.0, 300.0, progress=False,
                          isolate=class_isolation())
    assert [g.score for g in grades] == [0, 0]  # untouched code, and a written answer is not auto-scored
    results = json.loads((tmp_path / "out" / "ann" / "results.json").read_text())
    written = [t for t in results["tests"] if "graded by hand" in t["name"]]
    assert len(written) == 1 and written[0]["max_score"] == 0 and "highest upright" in written[0]["output"]
    rows = {r["student"]: r for r in csv.DictReader((tmp_path / "out" / "grades.csv").open())}
    column = next(k for k in rows["ann"] if k.startswith("00.reflection"))
    assert column == "00.reflection (by hand, /2)"
    assert rows["ann"][column] == "" and rows["bob"][column] == "0 (no answer)"


def test_every_questions_points_agree_with_its_heading():
    """A heading that says 3 points where the grader counts 2 (lab 05's, once) misleads students."""
    import re

    for path in sorted((ROOT / "solutions").glob("*.ipynb")):
        for cell in nbformat.read(path, as_version=4).cells:
            meta = cell.metadata.get("pendkit", {})
            if "question" in meta:
                heading = cell.source.splitlines()[0]
                said = re.search(r"(\d+) points?", heading)
                assert said and int(said.group(1)) == meta["points"], f"{path.name}: {heading!r} vs {meta['points']}"


def test_students_see_how_every_written_answer_is_graded():
    for path in sorted((ROOT / "labs").glob("*.ipynb")):
        for cell in nbformat.read(path, as_version=4).cells:
            if "question" in cell.metadata.get("pendkit", {}):
                shown = "How it is graded" in cell.source or "**Criteria" in cell.source
                assert shown, f"{path.name}: {cell.source[:60]}"
