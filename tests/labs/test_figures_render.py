"""Every figure of labs 00-06 and the demo notebooks shows as an image in the kit's own Jupyter stack
(ipykernel's default inline backend, no MPLBACKEND), never as the text `<Figure size ...>`."""

import os
import re
from pathlib import Path

import nbformat
import pytest
from nbclient import NotebookClient

ROOT = Path(__file__).resolve().parents[2]
NOTEBOOKS = sorted(ROOT.glob("solutions/0[0-6]_*.ipynb")) + sorted((ROOT / "docs" / "demos").glob("*.ipynb"))
FIGURE_TEXT = re.compile(r"<(matplotlib\.figure\.)?Figure size [^>]*>")
DRAWS = re.compile(r"plt\.show\(\)|plot_\w+\(|\.imshow\(")  # a cell meant to show a figure


@pytest.fixture
def jupyter_backend(monkeypatch):
    monkeypatch.delenv("MPLBACKEND", raising=False)  # conftest sets Agg for nbval; a student's kernel has none
    monkeypatch.setenv("PENDKIT_GRADER_STRICT", "0")


@pytest.mark.expensive
@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.name for p in NOTEBOOKS])
def test_every_figure_is_an_image(jupyter_backend, path):
    notebook = nbformat.read(path, as_version=4)
    NotebookClient(notebook, timeout=300, kernel_name="python3",
                   resources={"metadata": {"path": str(path.parent)}}, env=dict(os.environ)).execute()
    for index, cell in enumerate(notebook.cells):
        if cell.cell_type != "code":
            continue
        outputs = cell.get("outputs", [])
        texts = [o.get("data", {}).get("text/plain", "") for o in outputs if "image/png" not in o.get("data", {})]
        assert not any(FIGURE_TEXT.search(text) for text in texts), f"{path.name} cell {index}: a figure as text"
        if DRAWS.search(cell.source) and "widget" not in cell.source:
            images = [o for o in outputs if "image/png" in o.get("data", {})]
            assert images, f"{path.name} cell {index} draws a figure but shows no image"
