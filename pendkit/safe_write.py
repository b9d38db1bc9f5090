"""Files the kit writes (sweep tables, grades, adaptation outputs) written without following a symbolic link
the kit did not make: a link planted where an output goes (`ln -s ~/notes.txt studentdir/table.csv`), or in
place of a folder the kit writes into below the one it was given, is refused in one line that names it.

`base` is the folder the user named (followed as given: it is their choice); every folder below it and the
file itself must be what they look like. Without `base`, only the file itself is checked. On POSIX the walk
holds each folder open (`dir_fd`, O_NOFOLLOW), so a link swapped in between the check and the write is
refused too; Windows, which has neither, checks each level with `lstat` first. A file is written to a
temporary file beside it, then renamed over it (`os.replace` replaces a link itself, never what it points
at), so a reader sees the old file or the new one, never half of one.
"""

from __future__ import annotations

import contextlib
import errno
import io
import os
import secrets
import stat
from collections.abc import Iterator
from pathlib import Path

from pendkit.errors import ConfigError

_NOFOLLOW = getattr(os, "O_NOFOLLOW", 0)
_DIRECTORY = getattr(os, "O_DIRECTORY", 0)
_AT_CALLS = {os.open, os.mkdir, os.stat, os.rename, os.unlink}  # os.replace is os.rename's renameat
_HELD_FOLDERS = bool(_NOFOLLOW and _DIRECTORY) and _AT_CALLS <= os.supports_dir_fd


class LinkRefused(ConfigError):
    """A file the kit was to write, or a folder it writes into, is a symbolic link it did not make."""


def refusal(path: Path, link: Path) -> LinkRefused:
    """The one line a refusal says: the file, and the link in its way."""
    which = "it" if link == path else str(link)
    return LinkRefused(f"refused to write {path}: {which} is a symbolic link the kit did not make (it could point "
                       "at any file): remove the link or choose another folder")


def _levels(path: Path, base: Path | None) -> tuple[Path, list[str]]:
    """(the base folder, the names of the folders below it down to the file's, the file's name last)."""
    base = path.parent if base is None else Path(base)
    parts = path.relative_to(base).parts  # a path outside its base is the caller's bug: ValueError
    if not parts or any(part in ("", ".", "..") for part in parts):
        raise ValueError(f"{path} is not a file below {base}")
    return base, list(parts)


def _is_link(name: str, folder_fd: int | None, folder: Path) -> bool:
    try:
        if folder_fd is None:
            return stat.S_ISLNK(os.lstat(folder / name).st_mode)
        return stat.S_ISLNK(os.stat(name, dir_fd=folder_fd, follow_symlinks=False).st_mode)
    except FileNotFoundError:
        return False


@contextlib.contextmanager
def _held_folder(path: Path, base: Path | None, names: list[str], create: bool) -> Iterator[int | None]:
    """The folder `base/names...` open (None where folders cannot be held open), each level checked."""
    base = Path(base)
    if create:
        base.mkdir(parents=True, exist_ok=True)
    if not _HELD_FOLDERS:
        folder = base
        for name in names:
            if _is_link(name, None, folder):
                raise refusal(path, folder / name)
            folder = folder / name
            if create:
                folder.mkdir(exist_ok=True)
        yield None
        return
    fd = os.open(base, os.O_RDONLY | _DIRECTORY)
    folder = base
    try:
        for name in names:
            if create:
                with contextlib.suppress(FileExistsError):
                    os.mkdir(name, dir_fd=fd)
            try:
                inner = os.open(name, os.O_RDONLY | _DIRECTORY | _NOFOLLOW, dir_fd=fd)
            except OSError as error:
                if error.errno in (errno.ELOOP, errno.ENOTDIR) and _is_link(name, fd, folder):
                    raise refusal(path, folder / name) from None
                raise
            os.close(fd)
            fd, folder = inner, folder / name
        yield fd
    finally:
        os.close(fd)


def check_no_links(path: str | Path, base: str | Path | None = None) -> Path:
    """Refuse now (LinkRefused) what writing `path` would refuse later: for checks before a long run."""
    path = Path(path)
    base, names = _levels(path, None if base is None else Path(base))
    folder = base
    for name in names:
        if _is_link(name, None, folder):
            raise refusal(path, folder / name)
        folder = folder / name
    return path


def make_folder(path: str | Path, base: str | Path | None = None) -> Path:
    """Create `path` and the folders between it and `base`, refusing any of them that is a link."""
    path = Path(path)
    base, names = _levels(path, None if base is None else Path(base))
    with _held_folder(path, base, names, create=True):
        return path


@contextlib.contextmanager
def replacing(path: str | Path, base: str | Path | None = None, binary: bool = False,
              newline: str | None = None, mode: int = 0o666) -> Iterator[io.IOBase]:
    """A file to write `path`'s new contents into, put in its place when the block ends without an error
    (its folders made as `make_folder` does); `mode` as os.open's (the umask applies)."""
    path = Path(path)
    base, names = _levels(path, None if base is None else Path(base))
    *folders, name = names
    with _held_folder(path, base, folders, create=True) as fd:
        where = path.parent
        if _is_link(name, fd, where):
            raise refusal(path, path)
        temporary = f".{name}.{secrets.token_hex(4)}.tmp"
        flags = os.O_WRONLY | os.O_CREAT | os.O_EXCL | _NOFOLLOW | getattr(os, "O_BINARY", 0)
        handle = os.open(temporary if fd is not None else where / temporary, flags, mode,
                         **({"dir_fd": fd} if fd is not None else {}))
        try:
            with (os.fdopen(handle, "wb") if binary else
                  os.fdopen(handle, "w", encoding="utf-8", newline=newline)) as file:
                yield file
            if _is_link(name, fd, where):  # planted while we wrote: still refused, said so
                raise refusal(path, path)
            if fd is not None:
                os.replace(temporary, name, src_dir_fd=fd, dst_dir_fd=fd)
            else:
                os.replace(where / temporary, path)
        except BaseException:
            with contextlib.suppress(OSError):
                os.unlink(temporary, dir_fd=fd) if fd is not None else os.unlink(where / temporary)
            raise


def write_text(path: str | Path, text: str, base: str | Path | None = None, newline: str | None = None,
               mode: int = 0o666) -> Path:
    with replacing(path, base, newline=newline, mode=mode) as file:
        file.write(text)
    return Path(path)


def write_bytes(path: str | Path, data: bytes, base: str | Path | None = None) -> Path:
    with replacing(path, base, binary=True) as file:
        file.write(data)
    return Path(path)


def open_new(path: str | Path, base: str | Path | None = None):
    """`path` opened for writing text from its start (a log written as it goes, not replaced whole), refused
    if it or a folder below `base` is a link."""
    path = Path(path)
    base, names = _levels(path, None if base is None else Path(base))
    *folders, name = names
    with _held_folder(path, base, folders, create=True) as fd:
        flags = os.O_WRONLY | os.O_CREAT | os.O_TRUNC | _NOFOLLOW
        if fd is None and _is_link(name, None, path.parent):  # no O_NOFOLLOW here: checked first
            raise refusal(path, path)
        try:
            handle = (os.open(name, flags, 0o666, dir_fd=fd) if fd is not None
                      else os.open(path, flags, 0o666))
        except OSError as error:
            if error.errno == errno.ELOOP or _is_link(name, fd, path.parent):
                raise refusal(path, path) from None
            raise
    return os.fdopen(handle, "w", encoding="utf-8")
