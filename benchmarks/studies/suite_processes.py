"""Study: where the README's test command spends its CPU, process by process (docs/results/test-suite.md).

    python benchmarks/studies/suite_processes.py [-- extra pytest arguments, e.g. --ignore=tests/sweep]

Runs the suite once with a `sitecustomize` on PYTHONPATH that has every Python process it starts (pytest's
workers, notebook kernels, the graders' kernels, the CLI's subprocesses) write its own CPU seconds to a log
folder, every quarter second and at exit: a kernel is killed at its end, so its last quarter second is lost.
Then prints the CPU by kind of process, and for kernels by the test that started them (a grader's kernel,
started with a cleaned environment, does not know its test) and by what they imported.
"""

from __future__ import annotations

import argparse
import collections
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]

PROBE = '''
import os, sys, threading, time, resource
FOLDER = LOG_FOLDER
_test = os.environ.get("PYTEST_CURRENT_TEST", "-").split(" ")[0]
def _write(_folder=FOLDER):
    try:
        r, m = resource.getrusage(resource.RUSAGE_SELF), sys.modules
        with open(os.path.join(_folder, f"{os.getpid()}.tsv"), "w") as f:
            f.write("\\t".join([f"{r.ru_utime + r.ru_stime:.3f}", " ".join(sys.argv)[:200], _test,
                               str("torch" in m), str("control" in m)]) + "\\n")
    except Exception:
        pass
def _every_quarter_second():
    while True:
        time.sleep(0.25)
        _write()
threading.Thread(target=_every_quarter_second, daemon=True).start()
import atexit
atexit.register(_write)
'''


def kind(argv: str, test: str) -> str:
    if " -f " in argv or "ipykernel" in argv:
        return "kernel (grader's, environment cleaned)" if test == "-" else "kernel (nbval or a test's)"
    if argv.strip() == "-c" and test == "-":  # execnet starts xdist's workers with `python -c`
        return "pytest worker"
    return "other (CLI subprocesses, brokers, pytest itself)"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("pytest_args", nargs="*")
    args = parser.parse_args()
    # the log under the home folder: a grader's kernel has a /tmp of its own (a sandboxed one cannot write at all)
    Path.home().mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory() as site, tempfile.TemporaryDirectory(dir=Path.home()) as log:
        Path(site, "sitecustomize.py").write_text(PROBE.replace("LOG_FOLDER", repr(log)))
        env = {**os.environ,
               "PYTHONPATH": os.pathsep.join([site, *filter(None, [os.environ.get("PYTHONPATH")])])}
        started = time.perf_counter()
        done = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", *args.pytest_args],
                              cwd=ROOT, env=env, capture_output=True, text=True)
        wall_s = time.perf_counter() - started
        rows = []
        for path in Path(log).glob("*.tsv"):
            fields = path.read_text().rstrip("\n").split("\t")
            if len(fields) == 5:
                rows.append((float(fields[0]), fields[1], fields[2], fields[3] == "True", fields[4] == "True"))
    print(f"wall_s={wall_s:.0f} exit={done.returncode} {done.stdout.strip().splitlines()[-1] if done.stdout else ''}")
    by_kind = collections.defaultdict(lambda: [0, 0.0])
    for cpu_s, argv, test, _, _ in rows:
        by_kind[kind(argv, test)][0] += 1
        by_kind[kind(argv, test)][1] += cpu_s
    for name, (count, cpu_s) in sorted(by_kind.items(), key=lambda item: -item[1][1]):
        print(f"kind={name!r} processes={count} cpu_s={cpu_s:.0f}")
    kernels = [r for r in rows if kind(r[1], r[2]).startswith("kernel")]
    for label, chosen in (("torch", [r for r in kernels if r[3]]), ("control", [r for r in kernels if r[4]]),
                          ("neither", [r for r in kernels if not r[3] and not r[4]])):
        print(f"kernels_importing={label} processes={len(chosen)} cpu_s={sum(r[0] for r in chosen):.0f}")
    by_test = collections.defaultdict(lambda: [0, 0.0])
    for cpu_s, _, test, _, _ in kernels:
        by_test[test.split("::")[0]][0] += 1
        by_test[test.split("::")[0]][1] += cpu_s
    for test, (count, cpu_s) in sorted(by_test.items(), key=lambda item: -item[1][1])[:12]:
        print(f"kernels_of={test} processes={count} cpu_s={cpu_s:.1f}")


if __name__ == "__main__":
    import os
    import runpy  # the header line every benchmark prints first (benchmarks/provenance.py)

    runpy.run_path(os.path.join(os.path.dirname(os.path.abspath(__file__)), os.pardir, "provenance.py"),
                   run_name="__main__")
    main()
