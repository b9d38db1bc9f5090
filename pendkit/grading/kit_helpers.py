"""One slip costs one task: while a task's function is tested, the earlier tasks' functions it may call are
the kit's own (`Task.kit_helpers`), so a mistake in Task 1 is graded in Task 1 and not again in every task built
on it. Runs in the grader (`check`, `run_task`) and in the student's kernel (`pendkit.grading.kernel`)."""

from __future__ import annotations

import contextlib
import importlib
from collections.abc import Iterator

KIT_PACKAGE = "pendkit."  # the only modules a helper may come from (the kernel imports what the grader names)


def kit_function(where: str):
    """The kit's function at `where` ("pendkit.module:name")."""
    module, _, name = where.partition(":")
    if not module.startswith(KIT_PACKAGE) or not name:
        raise ValueError(f"a kit helper is 'pendkit.module:name', got {where!r}")
    return getattr(importlib.import_module(module), name)


@contextlib.contextmanager
def kits_helpers_in(namespace: dict | None, helpers: dict[str, str] | None) -> Iterator[None]:
    """Within the block, each of `helpers`' names that `namespace` (the student's globals) defines is the kit's
    function instead; the student's own are back afterwards, whatever happened."""
    saved = {}
    if namespace is not None and helpers:
        for name, where in helpers.items():
            if name in namespace:
                saved[name] = namespace[name]
                namespace[name] = kit_function(where)
    try:
        yield
    finally:
        if namespace is not None:
            namespace.update(saved)
