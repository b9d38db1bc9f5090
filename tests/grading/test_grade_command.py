"""`pendkit grade` on a class of one correct and many broken submissions, and the invert check."""

import csv
import json
import shutil
import subprocess
import sys
from pathlib import Path

import nbformat
import pytest
from click.testing import CliRunner

from pendkit.cli import main
from pendkit.grading.runner import DEMO_TAG, _where
from tests.system_needs import no_sandbox_args

pytestmark = pytest.mark.expensive  # the full tier (`pytest --full`): a class of broken submissions graded

ROOT = Path(__file__).resolve().parents[2]
SOLUTION = ROOT / "solutions" / "01_encoder.ipynb"
HIDDEN = ROOT / "solutions" / "tests"
FULL = 29  # lab 01: public + hidden points (pre-lab included)
# short enough that kim's endless loop costs little, long enough that a correct check on a busy 2-core worker
# (just after erin's kernel was restarted) stays inside it: 0.5 s once cost erin a point in CI
CHECK_S = "2"


def solution():
    return nbformat.read(SOLUTION, as_version=4)


def index_of(notebook, text):
    return next(i for i, c in enumerate(notebook.cells) if c.cell_type == "code" and text in c.source)


def insert_after_imports(notebook, source):
    notebook.cells.insert(index_of(notebook, "import math") + 1, nbformat.v4.new_code_cell(source))
    return notebook


def replace_in(notebook, marker, old, new):
    cell = notebook.cells[index_of(notebook, marker)]
    cell.source = cell.source.replace(old, new)
    return notebook


def broken_class(folder: Path) -> None:
    def save(student, notebook):
        (folder / student).mkdir(parents=True)
        nbformat.write(notebook, folder / student / "01_encoder.ipynb")

    save("alice", solution())
    (folder / "bob").mkdir()
    shutil.copy(ROOT / "labs" / "01_encoder.ipynb", folder / "bob")
    save("carol", insert_after_imports(solution(), "1 / 0"))
    save("dave", insert_after_imports(solution(), "while True:\n    pass"))
    save("erin", insert_after_imports(solution(), "import os\nos._exit(1)"))
    save("frank", replace_in(solution(), "def decode_frame", '"""Position', 'import os; os._exit(3)\n    """Position'))
    grace = solution()
    del grace.cells[index_of(grace, "def wrap_delta")]
    save("grace", grace)
    heidi = replace_in(solution(), "def decode_frame", "def decode_frame(", "def decode_frames(")
    save("heidi", replace_in(heidi, 'check("01.decode_frame"', "decode_frame)", "decode_frames)"))
    ivan = solution()
    ivan.cells = [nbformat.from_dict(dict(c)) for c in ivan.cells for _ in range(2)]
    for i, cell in enumerate(ivan.cells):
        cell["id"] = f"dup-{i}"
    save("ivan", ivan)
    (folder / "judy").mkdir()
    (folder / "judy" / "01_encoder.ipynb").write_text("this is not a notebook")
    save("kim", replace_in(solution(), "def decode_frame", '"""Position', 'while True:\n        pass\n    """Position'))
    leo = insert_after_imports(solution(), "import os\nos._exit(1)  # a demo the grader does not run")
    leo.cells[index_of(leo, "os._exit(1)  # a demo")].metadata["tags"] = [DEMO_TAG]
    save("leo", leo)
    mia = solution()
    mia.cells[index_of(mia, "def decode_frame")].metadata["tags"] = [DEMO_TAG]  # a tag can only cost points
    save("mia", mia)


@pytest.fixture(scope="module")
def graded(tmp_path_factory):
    folder, out = tmp_path_factory.mktemp("submissions"), tmp_path_factory.mktemp("grades")
    broken_class(folder)
    result = CliRunner().invoke(main, ["grade", str(folder), "--out", str(out), "--hidden", str(HIDDEN),
                                       "--cell-timeout", "4", "--notebook-timeout", "90", "--check-timeout", CHECK_S,
                                       "--quiet", *no_sandbox_args()])
    assert result.exit_code == 0, result.output
    rows = {row["student"]: row for row in csv.DictReader((out / "grades.csv").open())}
    results = {student: json.loads((out / student / "results.json").read_text()) for student in rows}
    return rows, results


def messages(results, student):
    return " ".join([results[student]["output"]] + [t["output"] for t in results[student]["tests"]])


def test_correct_submission_gets_full_marks(graded):
    rows, results = graded
    assert results["alice"]["score"] == FULL and rows["alice"]["max_score"] == str(FULL)
    assert results["alice"]["output"] == "Every cell ran."
    assert {t["visibility"] for t in results["alice"]["tests"]} == {"visible", "after_published"}


def test_every_score_in_results_json_is_one_number_type(graded):
    _, results = graded
    for student in results.values():  # once 11.0 in one file and 14 in another
        assert isinstance(student["score"], float)
        assert all(isinstance(t["score"], float) and isinstance(t["max_score"], float) for t in student["tests"])


def test_cells_tagged_demo_are_not_run_and_the_tag_gains_nothing(graded):
    rows, results = graded
    assert results["leo"]["score"] == FULL and "killed the kernel" not in messages(results, "leo")
    assert "1 demonstration cells (tagged `demo`) were not run" in results["leo"]["output"]
    decode = [t for t in results["mia"]["tests"] if "decode_frame" in t["name"]]
    assert decode and all(t["score"] == 0 for t in decode) and results["mia"]["score"] < FULL


def test_untouched_lab_scores_zero(graded):
    rows, results = graded
    assert results["bob"]["score"] == 0
    assert "not implemented yet" in messages(results, "bob")


@pytest.mark.parametrize("student, note", [
    ("carol", "raised ZeroDivisionError"),
    ("dave", "ran past its time limit"),
    ("erin", "killed the kernel"),
])
def test_a_broken_cell_outside_the_tasks_costs_nothing_but_is_reported(graded, student, note):
    rows, results = graded
    assert results[student]["score"] == FULL
    assert note in results[student]["output"]


def test_a_broken_cells_note_marks_a_cut_line_with_an_ellipsis():
    line = "from pendkit.labs.velocity_view import ALPHA, notes"  # 51 characters
    assert _where(16, nbformat.v4.new_code_cell(line + "\n\nraw = 1")) == f"cell 17 ({line[:50]}…)"
    assert _where(2, nbformat.v4.new_code_cell("\n1 / 0")) == "cell 3 (1 / 0)"


def test_a_function_that_kills_the_kernel_scores_zero_for_its_task_only(graded):
    rows, results = graded
    assert rows["frank"]["01.decode_frame"] == "0"
    assert results["frank"]["score"] == FULL - 11
    assert "killed the kernel" in messages(results, "frank")


def test_a_deleted_function_scores_zero_with_a_message(graded):
    rows, results = graded
    assert rows["grace"]["01.wrap_delta"] == "0" and results["grace"]["score"] == FULL - 7
    assert "function `wrap_delta` not found" in messages(results, "grace")


def test_a_renamed_function_is_named_in_the_feedback(graded):
    rows, results = graded
    assert rows["heidi"]["01.decode_frame"] == "0"
    assert "found `decode_frames`: keep the name `decode_frame`" in messages(results, "heidi")


def test_duplicated_cells_are_harmless(graded):
    rows, results = graded
    assert results["ivan"]["score"] == FULL


def test_an_unreadable_file_scores_zero_with_a_reason(graded):
    rows, results = graded
    assert results["judy"]["score"] == 0 and "could not read the notebook" in results["judy"]["output"]


def test_a_hanging_function_times_out(graded):
    rows, results = graded
    assert rows["kim"]["01.decode_frame"] == "0" and results["kim"]["score"] == FULL - 11
    decode_tests = [t for t in results["kim"]["tests"] if t["name"].startswith("01.decode_frame")]
    for test in decode_tests:  # each named for what it is, none blamed on a wrong exception (a test catching all)
        assert test["output"].startswith(f"took longer than {CHECK_S} s: is there an endless loop?"), test


def test_feedback_never_shows_hidden_test_code(graded):
    rows, results = graded
    hidden_source = (HIDDEN / "lab01_hidden.py").read_text()
    for student in results:
        for test in results[student]["tests"]:
            assert "rng.integers(0, 1 << 16, 400)" not in test["output"]
    assert "rng.integers(0, 1 << 16, 400)" in hidden_source  # the probe itself is real


def test_hidden_tests_are_found_from_the_kits_install_wherever_grade_runs(tmp_path, monkeypatch):
    (tmp_path / "class").mkdir()
    shutil.copy(SOLUTION, tmp_path / "class" / "zoe.ipynb")
    monkeypatch.chdir(tmp_path)  # outside the kit's folder: no solutions/tests here
    result = CliRunner().invoke(main, ["grade", "class", "--lab", "01", "--out", "out", "--quiet"])
    assert result.exit_code == 0, result.output
    assert "zoe" in result.output and f"{FULL}/{FULL}" in result.output, result.output
    # a process of its own: this one has loaded the hidden tests already
    public = subprocess.run([sys.executable, "-m", "pendkit.cli", "grade", "class", "--lab", "01", "--out", "out",
                             "--quiet", "--public-only"], capture_output=True, text=True, timeout=600)
    last = public.stderr.strip().splitlines()[-1]
    assert last.startswith("NOTE: graded with the public tests only") and "out of the public points" in last
    assert f"{FULL}/{FULL}" not in public.stdout and "zoe" in public.stdout


def test_an_install_without_hidden_tests_refuses_to_grade_or_build_silently(tmp_path, monkeypatch):
    import pendkit.cli.labs as labs_command

    monkeypatch.setattr(labs_command, "kit_hidden_tests", lambda: None)  # a wheel: no solutions/ beside the package
    monkeypatch.chdir(tmp_path)
    (tmp_path / "class").mkdir()
    for command in (["grade", "class", "--lab", "00"], ["grade", "--gradescope-autograder", "a.zip", "--lab", "00"]):
        result = CliRunner().invoke(main, command)
        assert result.exit_code != 0 and "has no hidden tests" in result.output and "--public-only" in result.output
    assert not (tmp_path / "a.zip").exists()
    built = CliRunner().invoke(main, ["grade", "--gradescope-autograder", "a.zip", "--lab", "00", "--public-only"])
    assert built.exit_code == 0 and "the public tests only" in built.output


def test_one_notebook_instead_of_a_folder_is_refused_saying_to_pass_the_folder(tmp_path):
    notebook = tmp_path / "00_tour.ipynb"
    shutil.copy(Path(__file__).resolve().parents[2] / "labs" / "00_tour.ipynb", notebook)
    result = CliRunner().invoke(main, ["grade", str(notebook), "--out", str(tmp_path / "grades")])
    assert result.exit_code != 0 and "is one notebook: pass the folder that holds it" in result.output, result.output
    assert not (tmp_path / "grades").exists()
