"""Kernels started without a sandbox talk over Unix sockets in a folder of their own: two processes starting
kernels at once (`pendkit grade --jobs`, the suite's workers) can be handed the same TCP port, and one
grader then reads another kernel's messages (seen as "Invalid Signature" and a correct notebook short of
full marks)."""

import os
import shutil
from pathlib import Path

import pytest

from pendkit.grading.local_kernels import unix_socket_kernel_manager

ROOT = Path(__file__).resolve().parents[2]
pytestmark = pytest.mark.skipif(os.name != "posix", reason="Unix sockets: elsewhere the kernels keep TCP")


def test_a_kernel_on_unix_sockets_runs_code_and_its_sockets_are_files_in_its_folder(tmp_path):
    from jupyter_core.utils import run_sync

    km = unix_socket_kernel_manager(tmp_path)
    run_sync(km.start_kernel)()
    try:
        client = km.blocking_client()
        client.start_channels()
        client.wait_for_ready(timeout=60)
        reply = client.execute_interactive("x = 6 * 7", timeout=60)
        assert reply["content"]["status"] == "ok"
        assert km.transport == "ipc"
        assert {p.name for p in tmp_path.iterdir()} >= {f"kernel-{km.shell_port}", f"kernel-{km.iopub_port}"}
        client.stop_channels()
    finally:
        run_sync(km.shutdown_kernel)(now=True)


def test_the_grader_without_a_sandbox_uses_them_and_removes_their_folder(tmp_path, monkeypatch):
    import pendkit.grading.runner as runner

    made, real = [], runner.unix_socket_kernel_manager

    def recording(folder, **kwargs):
        made.append((Path(folder), real(folder, **kwargs)))
        return made[-1][1]

    monkeypatch.setattr(runner, "unix_socket_kernel_manager", recording)
    (tmp_path / "ann").mkdir()
    shutil.copy(ROOT / "solutions" / "00_tour.ipynb", tmp_path / "ann")
    grade = runner.grade_notebook(tmp_path / "ann" / "00_tour.ipynb", "ann", "00", [], 60.0, 240.0, isolate=False)
    assert grade.score == grade.max_score > 0, grade.notes
    assert made and all(km.transport == "ipc" for _, km in made)
    assert not any(folder.exists() for folder, _ in made)
