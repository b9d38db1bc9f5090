"""Graded tasks: tests declared in Python with points, a time limit and feedback; running and reporting.

A lab's suite module declares its tasks:

    decode = task("01.decode_frame", function="decode_frame", title="Decode an SSI frame")

    @decode.test(points=2, hint="Position is in bits 15..6, most significant bit first.")
    def clean_frames(fn, rng):
        got = fn(0x8020)
        expect(got == 512, f"decode_frame(0x8020) should be 512, got {got!r}")

Hidden tests (instructor material) attach to the same tasks with `hidden=True`.
"""

from __future__ import annotations

import hashlib
import importlib
import importlib.util
import numbers
import os
import zlib
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from pendkit.errors import ConfigError, PendkitError
from pendkit.grading.kit_helpers import kits_helpers_in
from pendkit.grading.timeouts import CheckTimeout, call_with_timeout

DEFAULT_TIMEOUT_S = 10.0
TIMEOUT_CAP_VARIABLE = "PENDKIT_CHECK_TIMEOUT_S"  # `pendkit grade --check-timeout` caps every test with it


class Diagnosis(str):
    """Feedback that names the mistake's cause (a suite's diagnosis helpers return one): a failure with it
    carries no hint, since the test's hint may point at a different cause. Adding text to it, on either side,
    keeps it a diagnosis: `message + note` names the cause when the note does."""

    def __add__(self, other: str) -> Diagnosis:
        return Diagnosis(str(self) + str(other))

    def __radd__(self, other: str) -> Diagnosis:
        return Diagnosis(str(other) + str(self))


class Failed(AssertionError):
    """A test's specific feedback for the student. `hint=False` (or a `Diagnosis` message): the message names
    the cause, so the test's hint (what it checks) is left off."""

    def __init__(self, message: str = "", hint: bool | None = None) -> None:
        super().__init__(message)
        self.with_hint = not isinstance(message, Diagnosis) if hint is None else hint


class NotGradable(Exception):
    """The function could not be tested at all (e.g. it is missing): the message is shown as it is."""


class GradingError(PendkitError):
    """Strict mode: a check scored less than full marks."""


class Pending(Exception):
    """A test whose outcome comes later, from outside the grader (a rig's verdict through the class's queue:
    `pendkit.grading.on_rigs`): 0 points until then. `payload`: what is to be judged."""

    def __init__(self, message: str, payload: bytes) -> None:
        super().__init__(message)
        self.payload = payload


def shown(value) -> str:
    """A student's value as feedback shows it: numbers to 6 significant digits whatever their type
    (`np.float64(0.24)` reads 0.24), anything else as Python writes it."""
    import numbers

    if isinstance(value, numbers.Real) and not isinstance(value, bool):
        return f"{float(value):.6g}"
    return repr(value)


def as_number(got, call: str) -> float:
    """A student's return value as a float, or a failure saying what came back instead."""
    try:
        return float(got)
    except (TypeError, ValueError):
        raise Failed(f"{call} should return a number, got {type(got).__name__}") from None


@dataclass(frozen=True)
class Outcome:
    """One call's result: its return value, or the exception it raised."""

    value: Any = None
    error: Exception | None = None


def outcomes(fn: Callable, calls: list[tuple]) -> list[Outcome]:
    """Call `fn(*args)` for every argument tuple and keep each outcome; in one round trip when `fn` runs in
    a student's kernel (tests with hundreds of calls). NotImplementedError is not an outcome: it ends the test."""
    if hasattr(fn, "many"):
        return fn.many(calls)
    results = []
    for args in calls:
        try:
            results.append(Outcome(fn(*args)))
        except NotImplementedError:
            raise
        except Exception as error:
            results.append(Outcome(error=error))
    return results


def raised_name(error: BaseException) -> str:
    """The name a student knows an exception by: their own class's, also when it came back from their kernel."""
    return getattr(error, "shown_as", type(error).__name__)


def is_real(value) -> bool:
    """Any real number a student may return: int, float, numpy scalars (not bool)."""
    return isinstance(value, numbers.Real) and not isinstance(value, (bool, np.bool_))


def is_sequence_of(value, length: int) -> bool:
    """A tuple, list or 1-D array of `length` items: what "return a pair" accepts."""
    if isinstance(value, np.ndarray):
        return value.ndim >= 1 and len(value) == length
    return isinstance(value, (tuple, list)) and len(value) == length


def expect(condition: bool, message: str, hint: bool | None = None) -> None:
    """Fail the current test with `message` unless `condition` holds (`hint`: as `Failed`'s)."""
    if not condition:
        raise Failed(message, hint)


@dataclass
class TestCase:
    name: str
    points: float
    run: Callable[[Callable, np.random.Generator], None]
    hint: str = ""
    timeout_s: float = DEFAULT_TIMEOUT_S
    hidden: bool = False

    @property
    def seed(self) -> int:
        return zlib.crc32(self.name.encode())  # fixed per test, so a score never depends on luck


@dataclass
class TestResult:
    name: str
    points: float
    max_points: float
    passed: bool
    message: str = ""
    hidden: bool = False
    pending: bytes | None = None  # what a rig is still to judge (`Pending`)


@dataclass
class Task:
    id: str
    function: str
    title: str
    tests: list[TestCase] = field(default_factory=list)
    hidden_points: float | None = None  # what the hidden tests add, as the public suite states it to `check`
    # earlier tasks' functions this one may call, by name: the kit's own while it is tested
    # (`pendkit.grading.kit_helpers`), so one slip costs one task
    kit_helpers: dict[str, str] = field(default_factory=dict)

    def test(self, points: float, hint: str = "", timeout_s: float = DEFAULT_TIMEOUT_S, hidden: bool = False):
        """Decorator declaring a test of this task."""
        if points < 0 or timeout_s <= 0:
            raise ConfigError(f"test points must be >= 0 and timeout_s > 0, got {points}, {timeout_s}")

        def register(run: Callable) -> Callable:
            if any(t.name == run.__name__ for t in self.tests):
                raise ConfigError(f"task {self.id} already has a test named {run.__name__}")
            self.tests.append(TestCase(run.__name__, points, run, hint, timeout_s, hidden))
            return run

        return register

    def max_points(self, hidden: bool = False) -> float:
        return sum(t.points for t in self.tests if hidden or not t.hidden)


TASKS: dict[str, Task] = {}


def task(task_id: str, function: str, title: str, hidden_points: float | None = None,
         kit_helpers: dict[str, str] | None = None) -> Task:
    """Declare (or fetch) a graded task. Ids are "NN.name": NN is the lab. `hidden_points`: the points its
    hidden tests add, which `check` names beside the public score; `kit_helpers`: the earlier tasks' functions
    it may call ({name: "pendkit.module:name"}), the kit's own while it is tested."""
    if task_id not in TASKS:
        TASKS[task_id] = Task(task_id, function, title, kit_helpers=dict(kit_helpers or {}))
    if hidden_points is not None:
        TASKS[task_id].hidden_points = hidden_points
    return TASKS[task_id]


def lab_of(task_id: str) -> str:
    return task_id.split(".", 1)[0]


def known_labs() -> list[str]:
    """The labs the kit grades ("00", "01", ...): one public suite each."""
    suites = Path(__file__).resolve().parent / "suites"
    return sorted(path.stem[3:] for path in suites.glob("lab[0-9][0-9].py"))


def load_lab(lab: str) -> list[Task]:
    """Import the public suite of lab `lab` ("01") and return its tasks in declaration order."""
    if lab not in known_labs():
        raise ConfigError(f"the kit has no lab {lab!r}: its labs are {', '.join(known_labs())}")
    importlib.import_module(f"pendkit.grading.suites.lab{lab}")
    return [t for t in TASKS.values() if lab_of(t.id) == lab]


_LOADED_HIDDEN: dict[str, object] = {}  # content digest -> the module it made
def kit_hidden_tests() -> Path | None:
    """The hidden tests of the kit this command runs from (`solutions/tests` beside its package, as in a
    clone installed with `pip install -e`), or None where this install has none (a wheel)."""
    import pendkit

    folder = Path(pendkit.__file__).resolve().parents[1] / "solutions" / "tests"
    return folder if any(folder.glob("lab??_*.py")) else None


HIDDEN_MODULES: dict[str, object] = {}  # each loaded hidden-test module by its file's stem (its answer key too)


def load_hidden(path: str | Path) -> None:
    """Import an instructor's hidden-test module (it attaches tests with hidden=True); once per content,
    so the same tests copied elsewhere (a grading folder, a course archive) load only once. A file that
    fails (a syntax error, a test name twice) adds nothing and raises ConfigError saying why."""
    path = Path(path).resolve()
    try:
        source = path.read_bytes()
    except OSError as error:
        raise ConfigError(f"cannot read hidden tests {path.name}: {error}") from None
    load_hidden_source(path, source)


def load_hidden_source(path: Path, source: bytes) -> None:
    """`load_hidden` from bytes read earlier (the grader reads every hidden file before any student code runs)."""
    digest = hashlib.sha256(source).hexdigest()
    if digest in _LOADED_HIDDEN:
        HIDDEN_MODULES.setdefault(path.stem, _LOADED_HIDDEN[digest])
        return
    before = {task_id: len(t.tests) for task_id, t in TASKS.items()}
    try:
        module = importlib.util.module_from_spec(importlib.util.spec_from_loader(f"pendkit_hidden_{path.stem}",
                                                                                 loader=None))
        module.__file__ = str(path)
        exec(compile(source, str(path), "exec"), module.__dict__)  # noqa: S102 - the instructor's own file
    except BaseException as error:  # noqa: BLE001 - any failure: undo what it registered, report it
        for task_id in list(TASKS):
            if task_id not in before:
                del TASKS[task_id]
            else:
                del TASKS[task_id].tests[before[task_id]:]
        raise ConfigError(f"hidden tests {path.name} were not loaded ({type(error).__name__}: {error})") from None
    _LOADED_HIDDEN[digest] = HIDDEN_MODULES[path.stem] = module


def hidden_module(path: str | Path):
    """The module loaded from the hidden-test file at `path`, as its content is now (loaded if it was not): unlike
    `HIDDEN_MODULES`, never another file of the same name loaded later (a copy edited in a grading folder)."""
    path = Path(path).resolve()
    load_hidden(path)
    return _LOADED_HIDDEN[hashlib.sha256(path.read_bytes()).hexdigest()]


def run_test(test: TestCase, fn: Callable, time_limit: bool = True) -> TestResult:
    """Run one test; every outcome becomes a result, never an exception. `time_limit=False` when `fn` keeps
    its own deadline (the grader's remote calls). A test that returns text passes with it as its feedback."""
    rng = np.random.default_rng(test.seed)
    timeout_s = test.timeout_s
    if os.environ.get(TIMEOUT_CAP_VARIABLE):
        timeout_s = min(timeout_s, float(os.environ[TIMEOUT_CAP_VARIABLE]))
    try:
        if time_limit:
            said = call_with_timeout(lambda: test.run(fn, rng), timeout_s)
        else:
            said = test.run(fn, rng)
    except Pending as waiting:
        return TestResult(test.name, 0.0, test.points, False, str(waiting), test.hidden, pending=waiting.payload)
    except Failed as failure:
        return _failed(test, str(failure) or "wrong result", with_hint=getattr(failure, "with_hint", True))
    except CheckTimeout as timeout:
        return _failed(test, f"{timeout}: is there an endless loop?")
    except NotImplementedError:
        return _failed(test, "not implemented yet", with_hint=False)
    except NotGradable as error:
        return _failed(test, str(error), with_hint=False)
    except Exception as error:
        return _failed(test, f"raised {raised_name(error)}: {error}")
    return TestResult(test.name, test.points, test.points, True, said if isinstance(said, str) else "", test.hidden)


def run_task(task_id: str, fn: Any, include_hidden: bool = False) -> list[TestResult]:
    """Run the task's tests (public, or public and hidden) on `fn`."""
    current = TASKS.get(task_id) or _task_after_loading(task_id)
    tests = [t for t in current.tests if include_hidden or not t.hidden]
    if not callable(fn):
        message = f"expected the function {current.function}, got {type(fn).__name__}"
        return [_failed(t, message, with_hint=False) for t in tests]
    with kits_helpers_in(getattr(fn, "__globals__", None), current.kit_helpers):
        return [run_test(t, fn) for t in tests]


def _task_after_loading(task_id: str) -> Task:
    load_lab(lab_of(task_id))
    if task_id not in TASKS:
        raise ConfigError(f"unknown task {task_id!r}; known: {sorted(TASKS)}")
    return TASKS[task_id]


COVERS = "This test checks: "  # what stands before a test's hint in its feedback


def _failed(test: TestCase, message: str, with_hint: bool = True) -> TestResult:
    """A failure's result. A message that names no cause gets the test's hint, shown as what the test checks
    (a scope, never a cause): a hint read as "the cause" misled whenever the mistake was another one."""
    if with_hint and test.hint:
        message = f"{message}{'' if message.endswith(('.', '?', '!')) else '.'} {COVERS}{_sentence(test.hint)}"
    return TestResult(test.name, 0.0, test.points, False, message, test.hidden)


def _sentence(hint: str) -> str:
    """The hint continuing a sentence: "Any alpha" reads "any alpha"; "MagINC" and "OCF" stay as they are."""
    first = hint.split(" ", 1)[0]
    return hint[0].lower() + hint[1:] if first.isalpha() and first[1:].islower() else hint


def format_report(task_id: str, results: list[TestResult]) -> str:
    """A short plain-text table (test, pass/fail, points, feedback)."""
    score = sum(r.points for r in results)
    total = sum(r.max_points for r in results)
    title = TASKS[task_id].title if task_id in TASKS else task_id
    lines = [f"{task_id} {title}: {score:g}/{total:g} points"]
    width = max((len(r.name) for r in results), default=4)
    for r in results:
        mark = "PASS" if r.passed else "FAIL"
        line = f"  {mark}  {r.name:<{width}}  {r.points:g}/{r.max_points:g}"
        lines.append(f"{line}  {r.message}" if r.message else line)
    return "\n".join(lines)
