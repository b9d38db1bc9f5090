"""Run a solution notebook up to the cell a student watches, as solved or with one function answered
wrongly, and read what the cell printed (the invert checks in tests/labs/test_student_labNN.py: a wrong
answer must change what the student sees). Each lab has its own file, so the labs run side by side on the
suite's workers."""

import functools
import os
import tempfile
from pathlib import Path

import nbformat
from nbclient import NotebookClient

from pendkit.grading.local_kernels import unix_socket_kernel_manager
from pendkit.grading.runner import DEMO_TAG

ROOT = Path(__file__).resolve().parents[2]


def printed_by_lab(notebook_name: str, stop_at: str, replace: dict[str, str] | None = None,
                   then: str | None = None) -> str:
    """Run the solution's code cells up to the one containing `stop_at`, with the cells defining the named
    functions replaced, and then the code `then` if given; return what that cell (and `then`) printed. The demo cells
    before it are left out, as the grader leaves them out: nothing later needs them. The same run asked for
    twice in one worker is run once."""
    return _printed(notebook_name, stop_at, tuple(sorted((replace or {}).items())), then)


@functools.cache
def _printed(notebook_name: str, stop_at: str, replace: tuple[tuple[str, str], ...], then: str | None) -> str:
    notebook = nbformat.read(ROOT / "solutions" / notebook_name, as_version=4)
    kept = []
    for cell in notebook.cells:
        if cell.cell_type != "code" or (DEMO_TAG in cell.metadata.get("tags", []) and stop_at not in cell.source):
            continue
        for name, source in replace:
            if f"def {name}(" in cell.source:
                cell.source = source
        kept.append(cell)
        if stop_at in cell.source:
            break
    if then is not None:
        kept.append(nbformat.v4.new_code_cell(then))
    notebook.cells = kept
    saved = os.environ.get("PENDKIT_MODE")
    os.environ["PENDKIT_MODE"] = "ci"  # the kernel inherits it: the notebooks' short horizons
    try:
        with tempfile.TemporaryDirectory(prefix="pendkit-kernel-") as sockets:  # no port race with other workers
            NotebookClient(notebook, timeout=300, kernel_name="python3", km=unix_socket_kernel_manager(sockets),
                           resources={"metadata": {"path": str(ROOT / "solutions")}}).execute()
    finally:
        if saved is None:
            os.environ.pop("PENDKIT_MODE", None)
        else:
            os.environ["PENDKIT_MODE"] = saved
    printing = kept[-2:] if then is not None else kept[-1:]
    return "".join(o.get("text", "") for cell in printing for o in cell.outputs if o.get("output_type") == "stream")
