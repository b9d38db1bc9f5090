"""nbformat for the grader, without a slow import it does not need.

nbformat validates notebooks with jsonschema, whose format checkers import rfc3987-syntax when it is
installed (Jupyter installs it): that builds some 35 IRI parsers and costs 2-3 s of CPU in every grading
process (python-jsonschema/jsonschema#1428). No notebook schema uses an IRI format, so the grader hides
that package before nbformat is first imported; the formats it checks are unaffected.
"""

from __future__ import annotations

import sys

if "jsonschema" not in sys.modules:
    sys.modules.setdefault("rfc3987_syntax", None)  # a None entry makes `import rfc3987_syntax` fail fast

import os  # noqa: E402

import nbformat  # noqa: E402

__all__ = ["nbformat", "read_submitted"]


def read_submitted(path: str | os.PathLike):
    """A submitted notebook, never read through a symbolic link (a submission's link could name any file)."""
    handle = os.open(path, os.O_RDONLY | getattr(os, "O_NOFOLLOW", 0))
    with os.fdopen(handle, encoding="utf-8") as file:
        return nbformat.read(file, as_version=4)
