"""Labs 05 and 06: a progress bar run without a browser saves its final count, not "0/N"."""

import tempfile

import nbformat
from nbclient import NotebookClient

from pendkit.grading.local_kernels import unix_socket_kernel_manager


def test_the_saved_bar_says_how_far_it_got():
    cell = nbformat.v4.new_code_cell("from pendkit.labs.progress import progress\n"
                                     "bar = progress(total=4, desc='episodes', unit='episode')\n"
                                     "for _ in range(4):\n    bar.update()\nbar.close()\n"
                                     "for _ in progress(range(3), desc='steps'):\n    pass")
    notebook = nbformat.v4.new_notebook(cells=[cell])
    with tempfile.TemporaryDirectory(prefix="pendkit-kernel-") as sockets:
        NotebookClient(notebook, timeout=60, kernel_name="python3", km=unix_socket_kernel_manager(sockets)).execute()
    saved = [o.get("data", {}).get("text/plain", "") for o in cell.outputs]
    assert any("4/4" in text for text in saved) and any("3/3" in text for text in saved), saved
    assert not any("0/4" in text or "0/3" in text for text in saved), saved
