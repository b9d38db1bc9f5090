"""Copy a submission into a scratch folder before any of it runs: regular files only.

A submission folder is untrusted: a symbolic link in it could point at the hidden tests, a root-only file
or another student's notebook, and a grader running as root would copy what it points at. Here nothing is
followed: links and special files are left out and named in the student's feedback, files are opened with
O_NOFOLLOW, and only the student's own folder is copied (a notebook lying flat in the class folder gets
nothing beside it: the folders next to it are other students').
"""

from __future__ import annotations

import os
import stat
from pathlib import Path

SKIPPED_FOLDERS = {".ipynb_checkpoints", "__pycache__", ".git"}
MAX_STAGED_BYTES = 256 << 20  # a submission's data files; beyond, the rest is left out and said so
_NOFOLLOW = getattr(os, "O_NOFOLLOW", 0)


def stage_submission(notebook: Path, folder: Path | None, into: Path) -> list[str]:
    """Copy `notebook` into `into` (an existing, empty folder), with, when `folder` is the student's own
    folder, its regular files and subfolders except other notebooks. Returns what was left out and why."""
    left_out: list[str] = []
    _copy_file(notebook, into / notebook.name)
    if folder is not None:
        budget = [MAX_STAGED_BYTES]
        _copy_folder(folder, into, Path(), notebook.resolve(), left_out, budget)
    return left_out


def _copy_folder(source: Path, target: Path, relative: Path, notebook: Path, left_out: list[str],
                 budget: list[int]) -> None:
    with os.scandir(source) as entries:
        for entry in sorted(entries, key=lambda e: e.name):
            name = relative / entry.name
            if entry.is_symlink():
                left_out.append(f"`{name}` (a symbolic link: submissions are copied as regular files only)")
                continue
            if entry.is_dir(follow_symlinks=False):
                if entry.name not in SKIPPED_FOLDERS:
                    (target / entry.name).mkdir()
                    _copy_folder(Path(entry.path), target / entry.name, name, notebook, left_out, budget)
                continue
            if not entry.is_file(follow_symlinks=False):
                left_out.append(f"`{name}` (not a regular file)")
                continue
            if Path(entry.path).resolve() == notebook:
                continue  # copied already
            if entry.name.endswith(".ipynb"):
                continue  # another lab's notebook: graded on its own
            size = entry.stat(follow_symlinks=False).st_size
            if size > budget[0]:
                left_out.append(f"`{name}` (the submission's files are over {MAX_STAGED_BYTES >> 20} MB)")
                continue
            budget[0] -= size
            _copy_file(Path(entry.path), target / entry.name)


def _copy_file(source: Path, target: Path) -> None:
    """A regular file's bytes, never through a link (OSError if `source` is a link or not a regular file)."""
    handle = os.open(source, os.O_RDONLY | _NOFOLLOW)
    try:
        if not stat.S_ISREG(os.fstat(handle).st_mode):
            raise OSError(f"{source.name} is not a regular file")
        with open(target, "xb") as out:
            while chunk := os.read(handle, 1 << 20):
                out.write(chunk)
    finally:
        os.close(handle)
