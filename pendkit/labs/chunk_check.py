"""Lab 10: a student's upload chunks read as the rig reads them, and the first thing wrong said in words a
student can act on (before the rig sees them: the rig itself only reports a blob that does not add up). The
reading is the grader's own (`pendkit.grading.suites.lab10`), so the cell and the check name the same cause."""

from pendkit.grading.suites.lab10 import chunk_problem

__all__ = ["chunk_problem"]
