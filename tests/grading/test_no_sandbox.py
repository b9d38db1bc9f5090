"""Grading where no sandbox holds a student's kernel (macOS, Windows, Linux without bubblewrap): a class is
refused unless the instructor says so; whatever a notebook leaves running is ended before the next one runs
and before any grade is written; nothing of a kernel (its client, its sockets, its output) outlives it; and
a test's time limit is charged in the kernel's CPU time, not the machine's business."""

import os
import shutil
import signal
import sys
import threading
import time
from pathlib import Path

import nbformat
import psutil
import pytest
from click.testing import CliRunner

from pendkit.cli import main
from pendkit.grading.report import SandboxRequired, grade_folder
from pendkit.grading.sandbox import SANDBOX_VARIABLE, isolation_problem

ROOT = Path(__file__).resolve().parents[2]
SOLUTION = ROOT / "solutions" / "00_tour.ipynb"
pytestmark = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="the attacks read Linux's /proc")

# Started by a cell in a session of its own, orphaned at once (the shell exits): for a minute it kills every
# kernel of the same grading run but its own, and appends a row to grades.csv once the file exists.
DAEMON = '''
import os, time
mine = os.getcwd()
run_folder = os.path.dirname(mine)
open({pid_file!r}, "w").write(str(os.getpid()))
end = time.time() + 60
while time.time() < end:
    for pid in [p for p in os.listdir("/proc") if p.isdigit()]:
        try:
            where = os.readlink(f"/proc/{{pid}}/cwd")
            if where.startswith(run_folder) and not where.startswith(mine):
                os.kill(int(pid), 9)
        except OSError:
            pass
    if os.path.exists({grades!r}):
        with open({grades!r}, "a") as grades:
            grades.write("mallory,00,999,10\\n")
    time.sleep(0.05)
'''
STARTS_DAEMON = '''
import subprocess, sys
open("daemon.py", "w").write({daemon!r})
subprocess.Popen(["/bin/sh", "-c", f"'{{sys.executable}}' daemon.py </dev/null >/dev/null 2>&1 &"],
                 start_new_session=True)
'''


def solution_with(source: str):
    notebook = nbformat.read(SOLUTION, as_version=4)
    notebook.cells.insert(1, nbformat.v4.new_code_cell(source))
    return notebook


def write(path: Path, notebook) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    nbformat.write(notebook, path)


@pytest.fixture
def short_tmp(monkeypatch):
    """Kernels' socket paths must stay short: a scratch folder under /tmp for this test's runs."""
    import tempfile

    folder = Path(tempfile.mkdtemp(prefix="pk-"))
    monkeypatch.setattr(tempfile, "tempdir", str(folder))
    yield folder
    shutil.rmtree(folder, ignore_errors=True)


@pytest.mark.parametrize("isolate", [False, None], ids=["no-sandbox", "sandbox"])
@pytest.mark.expensive  # the full tier: a class graded
def test_a_daemon_a_notebook_starts_cannot_touch_later_grades_or_grades_csv(tmp_path, short_tmp, isolate):
    if isolate is None and isolation_problem() is not None:
        pytest.skip(f"no sandbox here: {isolation_problem()}")
    cls, out, pid_file = tmp_path / "class", tmp_path / "out", tmp_path / "daemon.pid"
    daemon = DAEMON.format(pid_file=str(pid_file), grades=str(out / "grades.csv"))
    write(cls / "a-mallory" / "00_tour.ipynb", solution_with(STARTS_DAEMON.format(daemon=daemon)))
    for honest in ("b-ann", "c-ben"):
        write(cls / honest / "00_tour.ipynb", nbformat.read(SOLUTION, as_version=4))
    grades = {g.student: g for g in grade_folder(cls, out, None, None, 60.0, 240.0, progress=False,
                                                 isolate=isolate)}
    for honest in ("b-ann", "c-ben"):
        assert grades[honest].score == grades[honest].max_score > 0, grades[honest].notes
    if isolate is False:  # outside a sandbox the daemon really ran, and was stopped with its notebook
        assert pid_file.exists()
        assert any("were still running after it and were stopped" in n for n in grades["a-mallory"].notes)
        pid = int(pid_file.read_text())
        assert not psutil.pid_exists(pid) or psutil.Process(pid).status() == psutil.STATUS_ZOMBIE
    time.sleep(1.0)
    assert "999" not in (out / "grades.csv").read_text()


def test_a_class_without_a_sandbox_is_refused_unless_the_instructor_says_so(tmp_path, monkeypatch):
    monkeypatch.setenv(SANDBOX_VARIABLE, "off")
    for student in ("ann", "ben"):
        write(tmp_path / "class" / student / "00_tour.ipynb", nbformat.read(SOLUTION, as_version=4))
    with pytest.raises(SandboxRequired, match="other 1 students"):
        grade_folder(tmp_path / "class", tmp_path / "out", None, None, 60.0, 240.0, progress=False)
    assert not (tmp_path / "out").exists()
    result = CliRunner().invoke(main, ["grade", str(tmp_path / "class"), "--out", str(tmp_path / "out"),
                                       "--public-only", "--quiet"])
    assert result.exit_code != 0
    message = result.output.strip().splitlines()[-1]
    assert "no sandbox here" in message and "--no-sandbox" in message and "grades" in message


def test_one_students_folder_is_graded_without_a_sandbox(tmp_path, monkeypatch, short_tmp):
    """A student grading their own work (or one folder at a time) is not refused."""
    monkeypatch.setenv(SANDBOX_VARIABLE, "off")
    write(tmp_path / "class" / "ann" / "00_tour.ipynb", nbformat.read(SOLUTION, as_version=4))
    (grade,) = grade_folder(tmp_path / "class", tmp_path / "out", None, None, 60.0, 240.0, progress=False)
    assert grade.score == grade.max_score > 0 and not grade.isolated


@pytest.mark.expensive  # the full tier: four notebooks graded
def test_no_kernel_client_or_socket_outlives_its_notebook(tmp_path, short_tmp):
    """Every graded notebook used to leave a connected client behind (14 descriptors and a thread): a class
    then ran out of descriptors, and a restarted kernel's client read the old one's messages."""
    from pendkit.grading.runner import grade_notebook

    write(tmp_path / "ann" / "00_tour.ipynb", nbformat.read(SOLUTION, as_version=4))
    me = psutil.Process()

    def grade():
        result = grade_notebook(tmp_path / "ann" / "00_tour.ipynb", "ann", "00", [], 60.0, 240.0, isolate=False)
        assert result.score == result.max_score > 0, result.notes

    grade()  # the first one loads what stays loaded
    fds, threads = me.num_fds(), me.num_threads()
    for _ in range(3):
        grade()
    assert me.num_fds() <= fds + 2 and me.num_threads() <= threads + 1, (fds, me.num_fds(), threads,
                                                                          me.num_threads())


def test_each_kernel_start_binds_its_sockets_in_a_folder_of_its_own(tmp_path, monkeypatch, short_tmp):
    import pendkit.grading.runner as runner

    folders, real = [], runner.unix_socket_kernel_manager

    def recording(folder, **kwargs):
        folders.append(Path(folder))
        return real(folder, **kwargs)

    monkeypatch.setattr(runner, "unix_socket_kernel_manager", recording)
    notebook = nbformat.read(SOLUTION, as_version=4)
    notebook.cells.insert(2, nbformat.v4.new_code_cell("import os\nos._exit(1)"))  # the first start dies here
    write(tmp_path / "ann" / "00_tour.ipynb", notebook)
    grade = runner.grade_notebook(tmp_path / "ann" / "00_tour.ipynb", "ann", "00", [], 60.0, 240.0, isolate=False)
    assert grade.score == grade.max_score > 0, grade.notes
    assert len(folders) == 2 and len(set(folders)) == 2


def test_a_notebooks_output_is_capped_in_the_graders_memory(tmp_path, short_tmp):
    from pendkit.grading.notebook_client import MAX_KEPT_OUTPUT_BYTES
    from pendkit.grading.runner import grade_notebook

    flood = f"for _ in range(6):\n    print('x' * {MAX_KEPT_OUTPUT_BYTES // 4})"
    write(tmp_path / "ann" / "00_tour.ipynb", solution_with(flood))
    grade = grade_notebook(tmp_path / "ann" / "00_tour.ipynb", "ann", "00", [], 60.0, 240.0, isolate=False)
    assert grade.score == grade.max_score > 0, grade.notes
    assert any(f"more than the {MAX_KEPT_OUTPUT_BYTES >> 20} MB of output" in n for n in grade.notes), grade.notes


@pytest.fixture
def kernel_session(tmp_path):
    """A kernel (no sandbox) with `add_one` and `spin` defined, and a grader's session on it."""
    from nbclient import NotebookClient

    from pendkit.grading.local_kernels import unix_socket_kernel_manager
    from pendkit.grading.notebook_client import end_kernel
    from pendkit.grading.process_guard import kernel_pid, tree_cpu_s
    from pendkit.grading.remote import KernelSession

    notebook = nbformat.v4.new_notebook(cells=[nbformat.v4.new_code_cell(
        "def add_one(x):\n    return x + 1\n\ndef spin(x):\n    while True:\n        pass")])
    km = unix_socket_kernel_manager(tmp_path / "k")
    client = NotebookClient(notebook, km=km, timeout=60, kernel_name="python3")
    with client.setup_kernel():
        client.execute_cell(notebook.cells[0], 0)
        pid = kernel_pid(client.km)
        session = KernelSession(client, tmp_path, cpu_s=lambda: tree_cpu_s(pid))
        try:
            yield session, pid
        finally:
            session.close()
            end_kernel(client, km)


def test_a_kernel_starved_of_the_cpu_is_not_charged_for_the_wait(kernel_session):
    """The kernel stopped for 3 s during a 1 s check (as a busy machine starves it): the answer still counts."""
    from pendkit.grading.remote import RemoteFunction

    session, pid = kernel_session
    session.start_test(1.0)
    os.kill(pid, signal.SIGSTOP)
    threading.Timer(3.0, os.kill, (pid, signal.SIGCONT)).start()
    assert RemoteFunction(session, "add_one")(41) == 42


def test_an_endless_loop_is_still_stopped_at_its_limit(kernel_session):
    from pendkit.grading.remote import RemoteFunction
    from pendkit.grading.timeouts import CheckTimeout

    session, _ = kernel_session
    session.start_test(1.0)
    with pytest.raises(CheckTimeout, match="took longer than 1 s"):
        RemoteFunction(session, "spin")(0)
    session.start_test(5.0)
    assert RemoteFunction(session, "add_one")(1) == 2  # the kernel was interrupted, not lost
