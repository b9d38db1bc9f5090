"""Which file a pytest-xdist worker takes next: compute-bound files keep the cores busy while a few files that
wait on real time (virtual rigs, brokers, timeouts) run beside them.

The suite's files either compute (identification, training, grading in sandboxes) or mostly wait on real
time (lab 09's rigs, the rig link: a fifth of a core for minutes). Run in collection order, two waiting files
met by chance and left the machine half idle for a minute and a half (docs/results/test-suite.md). Here a
free worker takes the first waiting file while fewer than `lanes` are running, else the first computing file,
so that the waiting files overlap the computing ones instead of each other. Files are still whole work
units, in collection order within each kind (conftest.py puts the slowest first).
"""

from __future__ import annotations

from collections.abc import Iterable

# Files whose tests spend most of their time waiting on real time (their CPU a third of their wall time or
# less when run alone; lab 09's and lab 10's student checks about half). A file missing here only loses
# overlap; tests/test_scheduling.py checks that every path exists.
WAITS_ON_REAL_TIME = (
    "solutions/09_deploy.ipynb",
    "labs/09_deploy.ipynb",
    "tests/labs/test_student_lab09.py",
    "tests/labs/test_student_lab10.py",
    "tests/link/test_rig_link.py",
    "tests/link/test_classroom_teams.py",
    "tests/control/test_trajopt.py",
    "tests/device/test_onboard.py",
    "tests/device/test_deploy_checks.py",
    "tests/agents/test_resume.py",
    "tests/link/test_tls_and_settle.py",
    "tests/queue/test_runner_rigs.py",
    "tests/queue/test_runner_process.py",
    "tests/deploy/test_classical_from_the_laptop.py",
    "docs/acceptance.ipynb",
)


def next_file(queue: Iterable[str], waiting_running: int, lanes: int,
              waits: Iterable[str] = WAITS_ON_REAL_TIME) -> str:
    """The file to start from `queue` (in order), given how many waiting files are running now: the first
    waiting one while fewer than `lanes` run, else the first that computes (the first of all when only
    waiting ones are left)."""
    queue, waits = list(queue), set(waits)
    waiting = [f for f in queue if f in waits]
    computing = [f for f in queue if f not in waits]
    if waiting and (waiting_running < lanes or not computing):
        return waiting[0]
    return computing[0]


def lanes_for(workers: int, cores: int) -> int:
    """Waiting files to run at once: the workers beyond the cores, at least one."""
    return max(1, workers - cores)


def make_scheduler(config, log):
    """xdist's file-by-file scheduling with `next_file` choosing each worker's next file."""
    import os

    from xdist.scheduler import LoadFileScheduling

    class RealTimeAwareScheduling(LoadFileScheduling):
        def __init__(self, config, log=None) -> None:
            super().__init__(config, log)
            self.lanes = lanes_for(self.numnodes, os.cpu_count() or 1)

        def _waiting_running(self, node) -> int:
            """Waiting files under way on the other workers (`node` asks for its next file as its current
            one ends: xdist hands out the next when two tests are left)."""
            return sum(1 for other, work in self.assigned_work.items() if other is not node
                       for scope, tests in work.items()
                       if scope in WAITS_ON_REAL_TIME and not all(tests.values()))

        def _assign_work_unit(self, node) -> None:
            try:
                chosen = next_file(self.workqueue, self._waiting_running(node), self.lanes)
                self.workqueue.move_to_end(chosen, last=False)
            except (AttributeError, TypeError):  # an xdist whose scheduler keeps its work otherwise: its order
                pass
            super()._assign_work_unit(node)

    return RealTimeAwareScheduling(config, log)
