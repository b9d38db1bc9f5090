"""`pendkit grade` on one student's folder (its lab files lying flat) names the grades.csv row after the
folder, the student, not after the lab's notebook; a class folder's flat notebooks keep their own names."""

import shutil
from pathlib import Path

from pendkit.grading.submissions import find_submissions

LABS = Path(__file__).resolve().parents[2] / "labs"


def test_one_students_folder_names_the_row_after_the_student(tmp_path):
    (tmp_path / "ana").mkdir()
    shutil.copy(LABS / "04_lqr.ipynb", tmp_path / "ana" / "04_lqr.ipynb")
    (row,) = find_submissions(tmp_path / "ana", lab="04")
    assert (row.student, row.lab, row.problem) == ("ana", "04", None)


def test_several_labs_in_one_students_folder_name_the_student_and_each_notebook(tmp_path):
    (tmp_path / "ana").mkdir()
    for name in ("04_lqr.ipynb", "05_swingup.ipynb"):
        shutil.copy(LABS / name, tmp_path / "ana" / name)
    assert {s.student for s in find_submissions(tmp_path / "ana")} == {"ana/04_lqr", "ana/05_swingup"}


def test_a_class_folders_flat_notebooks_keep_their_names(tmp_path):
    for name in ("ben.ipynb", "04_lqr.ipynb"):
        shutil.copy(LABS / "04_lqr.ipynb", tmp_path / name)
    (tmp_path / "cat").mkdir()
    shutil.copy(LABS / "04_lqr.ipynb", tmp_path / "cat" / "04_lqr.ipynb")
    assert {s.student for s in find_submissions(tmp_path, lab="04")} == {"ben", "04_lqr", "cat"}
