"""Nothing a student hands in is silently left out of grades.csv: a PDF, a zip, an empty folder get a row
with 0 and the reason; two notebooks of one lab from one student are both graded and flagged."""

import csv
import shutil
from pathlib import Path

from click.testing import CliRunner

from pendkit.cli import main
from pendkit.grading.submissions import find_submissions
from tests.system_needs import no_sandbox_args

ROOT = Path(__file__).resolve().parents[2]
TEMPLATE = ROOT / "labs" / "00_tour.ipynb"


def a_class(folder: Path) -> Path:
    (folder / "ann").mkdir(parents=True)
    shutil.copy(TEMPLATE, folder / "ann" / "00_tour.ipynb")
    (folder / "bob").mkdir()
    (folder / "bob" / "00_tour.pdf").write_bytes(b"%PDF-1.7 exported from Jupyter")
    (folder / "cat.zip").write_bytes(b"PK\x03\x04 a zipped notebook")
    (folder / "dan").mkdir()
    (folder / "eve").mkdir()
    shutil.copy(TEMPLATE, folder / "eve" / "00_tour.ipynb")
    shutil.copy(TEMPLATE, folder / "eve" / "00_tour (1).ipynb")
    (folder / "fay.pdf").write_bytes(b"%PDF-1.7")
    (folder / ".DS_Store").write_bytes(b"\0")  # the file browser's, not a student's
    return folder


def test_every_entry_of_the_class_folder_is_found_with_its_reason(tmp_path):
    found = {s.student: s for s in find_submissions(a_class(tmp_path / "class"), lab="00")}
    assert set(found) == {"ann", "bob", "cat", "dan", "eve/00_tour", "eve/00_tour (1)", "fay"}
    assert "no notebook in bob/ (00_tour.pdf)" in found["bob"].problem
    assert "cat.zip is a zip archive: unpack it" in found["cat"].problem
    assert "the folder is empty" in found["dan"].problem
    assert "fay.pdf is a PDF" in found["fay"].problem
    assert found["ann"].problem is None and found["ann"].note is None
    for copy in ("eve/00_tour", "eve/00_tour (1)"):
        assert found[copy].problem is None and "CHECK: eve handed in 2 notebooks for lab 00" in found[copy].note


def test_one_students_folder_without_a_notebook_gets_a_zero_row(tmp_path):
    (tmp_path / "report.pdf").write_bytes(b"%PDF")
    (row,) = find_submissions(tmp_path, lab="00", one_student=True)
    assert "no notebook was handed in (found: report.pdf)" in row.problem


def test_grades_csv_has_a_row_for_each_with_zero_on_every_task(tmp_path):
    out = tmp_path / "out"
    result = CliRunner().invoke(main, ["grade", str(a_class(tmp_path / "class")), "--lab", "00", "--out", str(out),
                                       "--quiet", *no_sandbox_args()])
    assert result.exit_code == 0, result.output
    rows = {row["student"]: row for row in csv.DictReader((out / "grades.csv").open())}
    assert set(rows) == {"ann", "bob", "cat", "dan", "eve/00_tour", "eve/00_tour (1)", "fay"}
    task_columns = [name for name in rows["ann"] if name.startswith("00.") and "by hand" not in name]
    assert task_columns
    for student in ("bob", "cat", "dan", "fay"):
        assert rows[student]["score"] == "0" and rows[student]["max_score"] == rows["ann"]["max_score"]
        assert all(rows[student][column] == "0" for column in task_columns), rows[student]
        assert rows[student]["notes"].startswith("0 points:")
    assert "CHECK: eve handed in 2 notebooks" in result.output


def test_grades_are_never_written_inside_the_submissions_folder(tmp_path):
    result = CliRunner().invoke(main, ["grade", str(a_class(tmp_path / "class")), "--lab", "00", "--out",
                                       str(tmp_path / "class" / "grades"), "--quiet", *no_sandbox_args()])
    assert result.exit_code != 0 and "inside the submissions' folder" in result.output
    assert not (tmp_path / "class" / "grades").exists()
