"""The second round of attacks on the grader (lab 00, the shortest lab): submissions that try to stall the
run, starve it of memory, or read what they must not, and a careless instructor's names and options. Every
one gets its own row; none reads a marker it must not; an honest notebook graded after them gets full marks."""

import os
import shutil
import stat
import tempfile
from pathlib import Path

import nbformat
import pytest

from pendkit.grading.report import GradingInterrupted, grade_folder
from pendkit.grading.sandbox import isolation_problem
from tests.system_needs import class_isolation, needs

pytestmark = pytest.mark.expensive  # the full tier (`pytest --full`): a class of attacks graded

ROOT = Path(__file__).resolve().parents[2]
TEMPLATE = ROOT / "labs" / "00_tour.ipynb"
SOLUTION = ROOT / "solutions" / "00_tour.ipynb"
SECRET = "pendkit-secret-3b9e"  # in hidden tests, other students' files, the grader's environment
ISOLATED = isolation_problem() is None
needs_sandbox = needs("bubblewrap")


def solution_with(source: str, at_end: bool = True):
    """The solved notebook with one more cell (at the end: it replaces a function, or patches modules after
    the notebook's own cells ran)."""
    notebook = nbformat.read(SOLUTION, as_version=4)
    notebook.cells.insert(len(notebook.cells) if at_end else 1, nbformat.v4.new_code_cell(source))
    notebook.metadata["pendkit"] = {"lab": "00"}  # as `pendkit labs build` writes it: named anything, still lab 00
    return notebook


TRICKLE = """
import time, pendkit.grading.channel as channel
plain = channel.send
def send(sock, text):  # the first answer a byte a second, then as usual: the grader must read those in full
    channel.send = plain
    data = channel.HEADER.pack(len(text.encode())) + text.encode()
    for k in range(len(data)):
        sock.sendall(data[k:k + 1])
        time.sleep(1.0)
channel.send = send
"""
HUGE_BYTES = """
import pendkit.grading.kernel as kernel
kernel.serve_call = lambda request: '{"list": [' + '{"list": []}, ' * 3_000_000 + '{"list": []}]}'
"""
MANY_VALUES = """
import pendkit.grading.kernel as kernel
kernel.serve_call = lambda request: '{"list": [' + '{"list": []},' * 250_000 + '{"list": []}]}'
"""
PRINTS_ENVIRONMENT = """
import os
def reward(angle_from_upright_rad, velocity_rad_s):
    # short, so that no truncation of the feedback can hide it: what this kernel can see of the grader's
    leaked = [k for k, v in os.environ.items() if "TOKEN" in k or "pendkit-secret" in v]
    raise ValueError("PENDKIT_MODE=" + os.environ.get("PENDKIT_MODE", "-") + " leaked=" + repr(leaked))
"""
LISTS_FILES = """
import os
def reward(angle_from_upright_rad, velocity_rad_s):
    seen = []
    for top, dirs, files in os.walk("."):
        for name in files:
            try:
                seen.append(name + ":" + open(os.path.join(top, name), errors="replace").read(200))
            except OSError as error:
                seen.append(name + ":" + type(error).__name__)
    raise ValueError(" | ".join(seen))
"""
PATCHES_JSON = """
import json
json.dumps = lambda *args, **kwargs: "{}"
"""
SWAPS_RUN_FOLDER = """
import os
run = os.path.join(os.path.dirname(os.getcwd()), "run")
try:
    os.rename(run, run + ".old")
    os.symlink({decoy!r}, run)
except OSError as error:
    print("refused:", error)
os._exit(1)
"""
KILLS_ITS_WORKER = """
import os, signal
os.kill(os.getppid(), signal.SIGKILL)  # without a sandbox, the kernel's parent is the grading worker
"""


def feedback(grade) -> str:
    return " ".join([*grade.notes, *(r.message for t in grade.tasks for r in t.results)])


def write(folder: Path, notebook) -> None:
    folder.parent.mkdir(parents=True, exist_ok=True)
    nbformat.write(notebook, folder)


@pytest.fixture(scope="module")
def graded(tmp_path_factory):
    work = tmp_path_factory.mktemp("round2")
    outside = work / "outside"  # what no student may read: hidden tests, a root-only file
    outside.mkdir()
    (outside / "lab00_hidden.py").write_text(f"# {SECRET} hidden\n")
    (outside / "private").write_text(f"{SECRET} private\n")
    os.chmod(outside / "private", 0o600)
    decoy = work / "decoy"
    decoy.mkdir()
    (decoy / "connection.json").write_text("keep me")
    os.chmod(decoy, 0o700)
    cls = work / "class"
    write(cls / "a-trickle" / "00_tour.ipynb", solution_with(TRICKLE))
    write(cls / "b-huge-bytes" / "00_tour.ipynb", solution_with(HUGE_BYTES))
    write(cls / "c-many-values" / "00_tour.ipynb", solution_with(MANY_VALUES))
    write(cls / "d-environment" / "00_tour.ipynb", solution_with(PRINTS_ENVIRONMENT))
    write(cls / "e-links" / "00_tour.ipynb", solution_with(LISTS_FILES))
    os.symlink(outside, cls / "e-links" / "hidden")
    os.symlink(outside / "private", cls / "e-links" / "private")
    os.symlink(cls / "z-honest" / "00_tour.ipynb", cls / "e-links" / "neighbour.ipynb")
    os.symlink(outside / "private", cls / "e-links" / "data.txt")
    nbformat.write(solution_with(LISTS_FILES), cls / "f-flat.ipynb")  # flat, next to the student folders
    write(cls / "g-json" / "00_tour.ipynb", solution_with(PATCHES_JSON))
    write(cls / "h-run-folder" / "00_tour.ipynb", solution_with(SWAPS_RUN_FOLDER.format(decoy=str(decoy))))
    nbformat.write(nbformat.read(TEMPLATE, as_version=4), cls / "grades.csv.ipynb")
    lab99 = nbformat.read(SOLUTION, as_version=4)
    lab99.metadata["pendkit"] = {"lab": "99"}
    write(cls / "i-lab99" / "notebook.ipynb", lab99)
    os.symlink(outside / "private", cls / "j-linked-notebook.ipynb")
    write(cls / "z-honest" / "00_tour.ipynb", nbformat.read(SOLUTION, as_version=4))
    (cls / "z-honest" / "notes.txt").write_text(f"{SECRET} z-honest's own notes\n")
    os.environ["PENDKIT_TEST_INSTRUCTOR_TOKEN"] = SECRET
    run_tmp = Path(tempfile.mkdtemp(prefix="pk-"))  # this run's scratch apart from others' (short: sockets)
    saved_tmp, tempfile.tempdir = tempfile.tempdir, str(run_tmp)
    try:
        grades = grade_folder(cls, work / "out", None, outside, 60.0, 240.0, check_timeout_s=3.0,
                              progress=False, jobs=2, isolate=class_isolation())
    finally:
        del os.environ["PENDKIT_TEST_INSTRUCTOR_TOKEN"]
        tempfile.tempdir = saved_tmp
    yield {g.student: g for g in grades}, run_tmp, decoy
    shutil.rmtree(run_tmp, ignore_errors=True)


def test_every_notebook_gets_a_row_and_the_csv_is_written(graded):
    grades, *_ = graded
    work = Path(grades["z-honest"].notebook).parents[2]
    assert set(grades) == {"a-trickle", "b-huge-bytes", "c-many-values", "d-environment", "e-links/00_tour",
                           "e-links/neighbour", "f-flat",
                           "g-json", "h-run-folder", "grades.csv", "i-lab99", "j-linked-notebook", "z-honest"}
    rows = (work / "out" / "grades.csv").read_text().splitlines()
    assert len(rows) == 1 + len(grades)
    assert (work / "out" / "student-grades.csv" / "results.json").exists()


def test_an_honest_notebook_graded_after_the_attacks_gets_full_marks(graded):
    grades, *_ = graded
    assert grades["z-honest"].score == grades["z-honest"].max_score > 0, grades["z-honest"].notes


def test_a_trickling_reply_is_cut_off_at_the_checks_time_limit_and_the_next_is_read_whole(graded):
    grades, *_ = graded
    first, *rest = grades["a-trickle"].tasks  # one trickled reply shows the cut: each costs a wall backstop
    assert first.results[0].points == 0 and "took longer than 3 s" in first.results[0].message
    assert all(result.passed for task in rest for result in task.results), feedback(grades["a-trickle"])
    assert grades["a-trickle"].score == grades["a-trickle"].max_score - first.results[0].max_points > 0


def test_oversized_replies_are_refused_before_they_are_decoded(graded):
    grades, *_ = graded
    assert "more than the 4194304 the grader reads" in feedback(grades["b-huge-bytes"])
    assert "more than the grader reads" in feedback(grades["c-many-values"])


def test_the_graders_environment_does_not_reach_student_code(graded):
    grades, *_ = graded
    text = feedback(grades["d-environment"])
    assert "PENDKIT_MODE=" in text and "leaked=[]" in text, text  # it ran, and saw nothing of the grader's
    assert SECRET not in text


def test_links_in_a_submission_are_left_out_and_named(graded):
    grades, *_ = graded
    text = feedback(grades["e-links/00_tour"])
    assert "00_tour.ipynb" in text and SECRET not in text
    for link in ("hidden", "private", "data.txt"):
        assert f"left out `{link}` (a symbolic link" in text
    for linked in ("j-linked-notebook", "e-links/neighbour"):  # a notebook that is a link: its own row, refused
        assert "is a symbolic link" in feedback(grades[linked]) and SECRET not in feedback(grades[linked])


def test_a_flat_notebook_sees_nothing_of_the_student_folders_beside_it(graded):
    grades, *_ = graded
    text = feedback(grades["f-flat"])
    assert "f-flat.ipynb" in text and SECRET not in text and "z-honest" not in text


def test_patching_json_in_the_kernel_is_reported_as_tampering(graded):
    grades, *_ = graded
    text = feedback(grades["g-json"])
    assert "patch json" in text and "the grader failed" not in text


@needs_sandbox
def test_a_kernel_cannot_swap_the_graders_folder_for_a_link(graded):
    grades, _, decoy = graded
    assert (decoy / "connection.json").read_text() == "keep me"
    assert stat.S_IMODE(decoy.stat().st_mode) == 0o700
    assert "killed the kernel" in feedback(grades["h-run-folder"])


def test_names_and_labs_a_careless_instructor_gives(graded):
    grades, *_ = graded
    assert grades["grades.csv"].lab == "00" and grades["grades.csv"].score == 0
    assert "metadata says lab '99'" in feedback(grades["i-lab99"])
    assert "cannot tell" in feedback(grades["i-lab99"]) or "not graded" in feedback(grades["i-lab99"])


def test_with_a_lab_given_a_notebook_of_unknown_lab_is_graded_as_that_lab(graded, tmp_path):
    lab99 = nbformat.read(SOLUTION, as_version=4)
    lab99.metadata["pendkit"] = {"lab": "99"}
    write(tmp_path / "class" / "ann" / "notebook.ipynb", lab99)
    write(tmp_path / "class" / "bob" / "01_encoder.ipynb", nbformat.read(ROOT / "labs" / "01_encoder.ipynb",
                                                                         as_version=4))
    grades = {g.student: g for g in grade_folder(tmp_path / "class", tmp_path / "out", "00", None, 60.0, 240.0,
                                                   progress=False)}
    assert grades["ann"].score == grades["ann"].max_score > 0
    assert "graded as lab 00" in feedback(grades["ann"])
    assert "this is lab 01's notebook, and this run grades lab 00" in feedback(grades["bob"])


def test_scratch_folders_are_gone_after_the_run(graded):
    _, run_tmp, _ = graded
    assert list(run_tmp.iterdir()) == []  # sandboxes, staged copies and killed workers' folders alike


def test_a_killed_worker_costs_only_the_notebook_that_killed_it(tmp_path):
    cls = tmp_path / "class"
    write(cls / "a-killer" / "00_tour.ipynb", solution_with(KILLS_ITS_WORKER, at_end=False))
    for name in ("b-honest", "c-honest", "d-honest"):
        write(cls / name / "00_tour.ipynb", nbformat.read(SOLUTION, as_version=4))
    grades = {g.student: g for g in grade_folder(cls, tmp_path / "out", None, None, 60.0, 240.0, progress=False,
                                                   jobs=2, isolate=False)}
    assert "was killed, twice" in feedback(grades["a-killer"])
    for name in ("b-honest", "c-honest", "d-honest"):
        assert grades[name].score == grades[name].max_score > 0, grades[name].notes


def test_an_interrupted_run_writes_what_it_graded(tmp_path, monkeypatch):
    import pendkit.grading.report as report

    cls = tmp_path / "class"
    for name in ("ann", "bob", "cat"):
        write(cls / name / "00_tour.ipynb", nbformat.read(SOLUTION, as_version=4))
    real = report._grade_one

    def interrupted_at_bob(submission, settings):
        if submission.student == "bob":
            raise KeyboardInterrupt  # Ctrl-C while bob's notebook is graded (as Python delivers SIGINT)
        return real(submission, settings)

    monkeypatch.setattr(report, "_grade_one", interrupted_at_bob)
    run_tmp = Path(tempfile.mkdtemp(prefix="pk-"))
    monkeypatch.setattr(tempfile, "tempdir", str(run_tmp))
    with pytest.raises(GradingInterrupted, match="1 of 3 notebooks graded"):
        grade_folder(cls, tmp_path / "out", None, None, 60.0, 240.0, progress=False, isolate=class_isolation())
    rows = (tmp_path / "out" / "grades.csv").read_text().splitlines()
    assert len(rows) == 4 and "interrupted" in rows[2] and "interrupted" in rows[3]
    assert list(run_tmp.iterdir()) == []
    run_tmp.rmdir()


def test_fractional_limits_work_and_bad_ones_are_refused(tmp_path):
    write(tmp_path / "class" / "ann" / "00_tour.ipynb", nbformat.read(SOLUTION, as_version=4))
    grades = grade_folder(tmp_path / "class", tmp_path / "out", None, None, 30.5, 240.5, check_timeout_s=2.5,
                          progress=False)
    assert grades[0].score == grades[0].max_score > 0, grades[0].notes
    from pendkit.errors import ConfigError
    from pendkit.grading.runner import grade_notebook

    with pytest.raises(ConfigError):
        grade_notebook(tmp_path / "class" / "ann" / "00_tour.ipynb", "ann", "00", [], float("nan"))
    shutil.rmtree(tmp_path / "out")


def test_a_kernel_that_does_not_start_is_started_again_at_no_cost_to_the_student(tmp_path, monkeypatch):
    """Another kernel on the machine can take a new kernel's port before it binds it (seen in CI as
    "Kernel died before replying to kernel_info"): the grader starts it again rather than failing the
    submission."""
    from nbclient import NotebookClient

    from pendkit.grading.runner import grade_notebook

    start_client, failures = NotebookClient.start_new_kernel_client, []

    def first_start_fails(self):
        if not failures:
            failures.append(True)
            raise RuntimeError("Kernel died before replying to kernel_info")
        return start_client(self)

    monkeypatch.setattr(NotebookClient, "start_new_kernel_client", first_start_fails)
    write(tmp_path / "ann" / "00_tour.ipynb", nbformat.read(SOLUTION, as_version=4))
    grade = grade_notebook(tmp_path / "ann" / "00_tour.ipynb", "ann", "00", [], 60.0, 240.0, isolate=False)
    assert failures and grade.score == grade.max_score > 0
    assert any("did not start" in note for note in grade.notes)
