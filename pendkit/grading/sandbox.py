"""Where a student's kernel runs while `pendkit grade` runs their notebook: a bubblewrap sandbox.

Why bubblewrap: it is a small, well-kept Debian/Ubuntu/Fedora package (the sandbox behind Flatpak) that
builds Linux namespaces without a daemon or root. Inside, the kernel sees a read-only system and Python,
only the kit's own package of this checkout, and a scratch folder with a copy of the submission: no hidden
tests, solutions, other submissions or grades folder exist there. It has no network, its own process tree
(everything it started, detached or not, dies with it) and limits on CPU time, memory, file size and
processes. Where the grader runs as root (a container, Gradescope) the kernel drops to an unprivileged user
of its own before it starts, so the process cap holds there too. The kernel talks to the grader over Unix
sockets in the scratch folder. Where bubblewrap is missing (macOS, Windows, WSL without it) `pendkit grade`
says that isolation is off and grades anyway: docs/labs-and-grading.md.
"""

from __future__ import annotations

import functools
import json
import os
import platform
import shutil
import site
import subprocess
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path

from pendkit.errors import ConfigError
from pendkit.grading.local_kernels import unix_socket_kernel_manager

KERNEL_NAME = "pendkit-sandbox"
MAX_SOCKET_PATH = 100  # Linux allows 108 bytes, macOS 104
KERNEL_WRITES = ("work", "home", "ipc")  # the scratch folder's subfolders the kernel may write
GRADER_ONLY = ("specs", "run")  # read-only to the kernel: the grader writes and deletes here
SANDBOX_UID_BASE = 61000
SYSTEM_DIRS = ("/usr", "/etc", "/lib", "/lib64", "/lib32", "/bin", "/sbin", "/opt/conda")


@dataclass(frozen=True)
class Limits:
    cpu_s: int = 1200
    memory_mb: int = 8192  # address space: torch and MuJoCo reserve far more than they use
    file_mb: int = 512
    processes: int = 256  # threads count too; beyond the user's own where the grader is not root


SANDBOX_VARIABLE = "PENDKIT_GRADE_SANDBOX"  # "off": grade as on a machine without bubblewrap (CI tests that path)


def isolation_problem() -> str | None:
    """Why a sandbox cannot be used here, or None when it can."""
    if os.environ.get(SANDBOX_VARIABLE, "").lower() == "off":
        return f"turned off by {SANDBOX_VARIABLE}=off"
    return _bubblewrap_problem()


@functools.cache
def _bubblewrap_problem() -> str | None:
    if platform.system() != "Linux":
        return f"bubblewrap needs Linux (this is {platform.system()})"
    if shutil.which("bwrap") is None:
        return "bubblewrap is not installed (sudo apt-get install bubblewrap)"
    probe = subprocess.run(["bwrap", *_namespace_args(), "--ro-bind", "/", "/", "true"], capture_output=True,
                           text=True, timeout=30)
    if probe.returncode != 0:
        return f"bubblewrap cannot create namespaces here ({probe.stderr.strip()[:120]})"
    return None


def _namespace_args() -> list[str]:
    # As root: no user namespace, and only what the launcher needs to hand the scratch folder to the kernel's
    # own user and become it (every capability is gone once it has).
    kept = ("CAP_SETUID", "CAP_SETGID", "CAP_CHOWN", "CAP_DAC_OVERRIDE")
    user = [arg for cap in kept for arg in ("--cap-add", cap)] if os.geteuid() == 0 else ["--unshare-user"]
    return ["--unshare-pid", "--unshare-net", "--unshare-ipc", "--unshare-uts", "--die-with-parent",
            "--new-session", "--cap-drop", "ALL", *user]


def _kernel_uid() -> int:
    """The user a root grader's kernels run as: one per grading process (a worker grades one notebook at
    a time), outside the range distributions give to people and services."""
    return SANDBOX_UID_BASE + os.getpid() % 4000


def _python_dirs() -> list[str]:
    import pendkit

    dirs = {sys.prefix, sys.base_prefix, sys.exec_prefix, str(Path(pendkit.__file__).resolve().parent),
            str(Path(sys.executable).resolve().parent.parent), *site.getsitepackages()}
    return sorted(d for d in dirs if Path(d).exists())


def _process_cap(extra: int) -> int:
    """RLIMIT_NPROC counts all of a user's processes: theirs now plus `extra` (a root grader's kernel has a
    user of its own, so `extra` alone)."""
    if os.geteuid() == 0:
        return extra
    uid = os.geteuid()
    mine = 0
    for entry in Path("/proc").iterdir():
        try:
            mine += entry.name.isdigit() and entry.stat().st_uid == uid
        except OSError:
            continue
    return mine + extra


@functools.cache
def _font_cache_files() -> tuple[Path, ...]:
    """matplotlib's font list as the grader's own matplotlib built it (the same font paths exist in the
    sandbox); none where matplotlib is missing."""
    try:
        import matplotlib
        import matplotlib.font_manager  # noqa: F401 - builds the list if this user has none yet
    except ImportError:
        return ()
    return tuple(Path(matplotlib.get_cachedir()).glob("fontlist-*.json"))


def _kill_user_processes(uid: int) -> None:
    """SIGKILL every process of `uid` (a root grader's kernel user: nothing else runs as it)."""
    import signal

    for entry in Path("/proc").iterdir():
        try:
            if entry.name.isdigit() and entry.stat().st_uid == uid:
                os.kill(int(entry.name), signal.SIGKILL)
        except (OSError, ValueError):
            continue


def _readable_parents(paths: list[str]) -> list[str]:
    """bwrap arguments that create the folders above `paths` world-readable (as root it would make them
    private to root, and the kernel's own user could not reach its Python or its scratch folder)."""
    parents = sorted({str(parent) for path in paths for parent in Path(path).parents if str(parent) != "/"},
                     key=lambda p: p.count("/"))
    return [arg for parent in parents for arg in ("--perms", "0755", "--dir", parent)]


class Sandbox:
    """A scratch folder holding a copy of the submission's folder, and a kernel spec that starts the kernel
    inside bubblewrap. `kernel_manager()` for nbclient; `close()` removes the scratch folder."""

    def __init__(self, submission_dir: Path, limits: Limits | None = None, kernel_starts: int = 5) -> None:
        self.limits = limits or Limits()
        self.root = Path(tempfile.mkdtemp(prefix="pendkit-grade-"))
        if len(str(self._sockets(kernel_starts - 1) / "kernel-65535")) > MAX_SOCKET_PATH:
            shutil.rmtree(self.root)
            raise ConfigError(f"the scratch folder {self.root.parent} is too deep for the kernel's sockets (a socket's "
                              f"path may not pass {MAX_SOCKET_PATH} bytes): grade with TMPDIR=/tmp")
        os.chmod(self.root, 0o755)  # the kernel's own user passes through it, and writes nothing in it
        self.work = self.root / "work"
        shutil.copytree(submission_dir, self.work, symlinks=True)  # staged: regular files only
        for name in (*KERNEL_WRITES, *GRADER_ONLY):
            (self.root / name).mkdir(exist_ok=True)
        for start in range(kernel_starts):  # made now, so that a root grader hands them to the kernel's user
            self._sockets(start).mkdir()
        for font_list in _font_cache_files():  # else matplotlib rebuilds it in every sandbox (~0.4 s)
            shutil.copy2(font_list, self.root / "home")
        self.uid = _kernel_uid() if os.geteuid() == 0 else None
        if self.uid is not None:
            for path in [path for name in KERNEL_WRITES for path in [self.root / name, *(self.root / name).rglob("*")]]:
                os.chown(path, self.uid, self.uid, follow_symlinks=False)
        self._write_spec()

    def _write_spec(self) -> None:
        binds = _readable_parents([*_python_dirs(), str(self.root)])
        for path in SYSTEM_DIRS:
            binds += ["--ro-bind-try", path, path]
        for path in _python_dirs():
            binds += ["--ro-bind", path, path]
        home = str(self.root / "home")
        argv = ["bwrap", *_namespace_args(), "--dev", "/dev", "--proc", "/proc", "--perms", "1777", "--tmpfs", "/tmp",
                *binds,
                # the scratch folder read-only but for the kernel's own folders, so it can never swap a folder
                # the grader later writes in (run/: the connection file and the call socket) for a link
                "--ro-bind", str(self.root), str(self.root),
                *[arg for name in KERNEL_WRITES for arg in ("--bind", str(self.root / name), str(self.root / name))],
                "--chdir", str(self.work),
                "--setenv", "HOME", home, "--setenv", "MPLCONFIGDIR", home, "--setenv", "IPYTHONDIR", home,
                "--unsetenv", "JPY_PARENT_PID",  # its parent is the sandbox's init (pid 1): no parent polling
                sys.executable, "-m", "pendkit.grading.sandbox_launch", "--cpu-s", str(self.limits.cpu_s),
                "--memory-mb", str(self.limits.memory_mb), "--file-mb", str(self.limits.file_mb),
                "--nproc", str(_process_cap(self.limits.processes)), "--uid", str(self.uid or -1),
                "--", "-f", "{connection_file}"]
        spec = {"argv": argv, "display_name": "pendkit sandbox", "language": "python",
                "interrupt_mode": "message",  # a signal would reach bwrap, not the kernel inside it
                "env": {"PYTHONNOUSERSITE": "1"}}
        folder = self.root / "specs" / KERNEL_NAME
        folder.mkdir()
        (folder / "kernel.json").write_text(json.dumps(spec, indent=1))

    def _sockets(self, start: int) -> Path:
        return self.root / "ipc" / f"s{start}"

    def kernel_manager(self, start: int = 0):
        """A kernel manager for start `start` of the notebook: each start binds its sockets in a folder of its
        own, so a new kernel never takes the socket paths an earlier one's client may still hold."""
        from jupyter_client.kernelspec import KernelSpecManager

        specs = KernelSpecManager(kernel_dirs=[str(self.root / "specs")], ensure_native_kernel=False)
        return unix_socket_kernel_manager(self._sockets(start), KERNEL_NAME,  # the kernel binds these sockets
                                          kernel_spec_manager=specs,
                                          connection_file=str(self.root / "run" / "connection.json"))

    def close(self) -> None:
        """Kill whatever still runs as the sandbox's own user, then remove the scratch folder."""
        if self.uid is not None:
            _kill_user_processes(self.uid)
        shutil.rmtree(self.root, ignore_errors=True)
