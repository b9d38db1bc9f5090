"""Submissions that attack the grader: none scores more than the empty template, and none disturbs the
others. Run in the bubblewrap sandbox where it is available (CI installs it); the checks that need the
sandbox are skipped without it, the rest hold either way because the tests run in the grader's process."""

import shutil
import subprocess
import time
from pathlib import Path

import nbformat
import pytest

from pendkit.grading.report import grade_folder
from pendkit.grading.sandbox import Limits, isolation_problem
from tests.system_needs import class_isolation, needs

pytestmark = pytest.mark.expensive  # the full tier (`pytest --full`): a class of attacks graded

ROOT = Path(__file__).resolve().parents[2]
TEMPLATE = ROOT / "labs" / "01_encoder.ipynb"
SOLUTION = ROOT / "solutions" / "01_encoder.ipynb"
MARKER = "pendkit-attack-marker-7f3a"
ISOLATED = isolation_problem() is None
needs_sandbox = needs("bubblewrap")


def with_cell(source: str, base: Path = TEMPLATE, at_end: bool = False):
    """The notebook with an extra cell after its imports (or at the end, to replace a function)."""
    notebook = nbformat.read(base, as_version=4)
    index = next(i for i, c in enumerate(notebook.cells) if c.cell_type == "code" and "import" in c.source)
    notebook.cells.insert(len(notebook.cells) if at_end else index + 1, nbformat.v4.new_code_cell(source))
    return notebook


FORGED = "import json\nprint('PENDKIT-GRADE-RESULT:0:' + json.dumps({'task': '01.decode_frame', 'results': []}))"
PATCH_GRADER = """
import pendkit.grading.core as core, pendkit.grading.kernel as kernel
core.run_test = lambda test, fn, **k: core.TestResult(test.name, test.points, test.points, True)
kernel.serve_call = lambda request: '{"found": true, "close": null, "outcomes": []}'
"""
READ_HIDDEN = f"""
import os, pendkit
found = []
for top in (os.path.dirname(os.path.dirname(pendkit.__file__)), "/", os.path.expanduser("~")):
    for folder, dirs, files in os.walk(top):
        if folder.startswith(("/proc", "/sys", "/usr")):
            dirs[:] = []
        found += [os.path.join(folder, f) for f in files if f.startswith("lab01_hidden")]
        if len(found) > 3:
            break
def decode_frame(frame):
    raise ValueError("{MARKER} found " + repr(found[:3]))
"""
EDIT_HIDDEN = f"""
import pendkit, pathlib
root = pathlib.Path(pendkit.__file__).resolve().parents[1]
for path in list(root.glob("solutions/tests/lab01_*.py")) + list(root.glob("**/lab01_hidden.py"))[:5]:
    try:
        path.write_text(path.read_text() + "\\n\\n# {MARKER}\\n@decode.test(points=1, hidden=True)\\ndef "
                        "random_frames_match_the_reference(fn, rng):\\n    pass\\n")
    except OSError:
        pass
"""
DETACHED = f"""
import subprocess, sys
subprocess.Popen([sys.executable, "-c", "import time; time.sleep(600)  # {MARKER}"], start_new_session=True)
"""
FORK_BOMB = f"""
import os
children = 0
for _ in range(2000):
    try:
        if os.fork() == 0:
            os.execvp("sleep", ["sleep {MARKER}", "600"])  # the marker shows in ps
        children += 1
    except OSError:
        break
def decode_frame(frame):
    raise ValueError("{MARKER} children=" + str(children))
"""
HUGE_OUTPUT = "print('x' * 20_000_000)"
RECURSION = "def decode_frame(frame):\n    return decode_frame(frame)"


def marked_processes() -> list[str]:
    listing = subprocess.run(["ps", "-eo", "pid,args"], capture_output=True, text=True).stdout
    return [line for line in listing.splitlines() if MARKER in line and "ps -eo" not in line]


@pytest.fixture(scope="module")
def attacked(tmp_path_factory):
    work = tmp_path_factory.mktemp("attacks")
    hidden = work / "hidden"
    shutil.copytree(ROOT / "solutions" / "tests", hidden)
    before = {p.name: p.read_bytes() for p in hidden.iterdir() if p.is_file()}
    submissions = work / "class"
    attacks = {"a-empty": nbformat.read(TEMPLATE, as_version=4), "b-forged": with_cell(FORGED),
               "c-patched": with_cell(PATCH_GRADER), "d-reads-hidden": with_cell(READ_HIDDEN, at_end=True),
               "h-huge-output": with_cell(HUGE_OUTPUT), "i-recursion": with_cell(RECURSION, at_end=True),
               "z-honest": nbformat.read(SOLUTION, as_version=4)}
    if ISOLATED:  # outside the sandbox these would really edit this checkout and leave processes behind
        attacks |= {"e-edits-hidden": with_cell(EDIT_HIDDEN), "f-detached": with_cell(DETACHED),
                    "g-forks": with_cell(FORK_BOMB, at_end=True)}
    for student, notebook in attacks.items():
        (submissions / student).mkdir(parents=True)
        nbformat.write(notebook, submissions / student / "01_encoder.ipynb")
    grades = grade_folder(submissions, work / "out", "01", hidden, 60.0, 300.0, progress=False, jobs=2,
                          isolate=class_isolation())
    time.sleep(1.0)
    return {g.student: g for g in grades}, before, hidden, work / "out"


def test_no_attack_beats_the_empty_template(attacked):
    grades, *_ = attacked
    empty = grades["a-empty"].score
    for student, grade in grades.items():
        if student != "z-honest":
            assert grade.score <= empty, f"{student} scored {grade.score} > {empty}"


def test_an_honest_submission_graded_after_the_attacks_gets_full_marks(attacked):
    grades, *_ = attacked
    honest = grades["z-honest"]
    assert honest.score == honest.max_score == 29, honest.notes


def test_hidden_files_are_unchanged_and_were_loaded_once(attacked):
    _, before, hidden, _ = attacked
    assert {p.name: p.read_bytes() for p in hidden.iterdir() if p.is_file()} == before


@needs_sandbox
def test_the_kernel_cannot_see_hidden_tests_or_solutions(attacked):
    grades, *_ = attacked
    messages = " ".join(r.message for t in grades["d-reads-hidden"].tasks for r in t.results)
    assert MARKER in messages and "found []" in messages  # the function ran, and found nothing


@needs_sandbox
def test_a_fork_bomb_stops_at_the_process_cap(attacked):
    grades, *_ = attacked
    messages = " ".join(r.message for t in grades["g-forks"].tasks for r in t.results)
    children = int(messages.split(f"{MARKER} children=")[1].split()[0].rstrip(".:"))
    assert 0 < children < Limits().processes  # the kernel's own threads count against the cap too


@needs_sandbox
def test_nothing_a_notebook_started_outlives_it(attacked):
    assert marked_processes() == []


def test_every_report_is_written_whole(attacked):
    grades, _, _, out = attacked
    rows = (out / "grades.csv").read_text().splitlines()
    assert len(rows) == 1 + len(grades)
    assert not list(out.rglob("*.tmp"))


def test_a_broken_hidden_file_is_skipped_not_fatal(tmp_path, capsys):
    hidden = tmp_path / "hidden"
    hidden.mkdir()
    shutil.copy(ROOT / "solutions" / "tests" / "lab00_hidden.py", hidden / "lab00_hidden.py")
    backup = (hidden / "lab00_hidden.py").read_text() + "\n# edited copy\n"
    (hidden / "lab00_zz_backup.py").write_text(backup)  # an instructor's edited backup: the same test names
    (hidden / "lab00_broken.py").write_text("def oops(:\n")
    (tmp_path / "class" / "ann").mkdir(parents=True)
    shutil.copy(ROOT / "solutions" / "00_tour.ipynb", tmp_path / "class" / "ann")
    grades = grade_folder(tmp_path / "class", tmp_path / "out", "00", hidden, 60.0, 300.0, progress=False)
    assert grades[0].score == grades[0].max_score > 0
    problems = capsys.readouterr().err
    assert "lab00_broken.py" in problems and "SyntaxError" in problems
    assert "lab00_zz_backup.py" in problems and "already has a test named" in problems
