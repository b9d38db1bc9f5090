"""The guides: the BOM adds up, the wiring diagram follows the firmware's pin map, the docs build with
no broken links, and every command they show is exercised or says why it cannot be here."""

import datetime
import re
import shutil
import subprocess
import sys
from pathlib import Path

import click
import pytest
from click.testing import CliRunner

from pendkit.bom import COLUMNS, cost_summary, read_bom
from pendkit.cli import main
from pendkit.errors import ConfigError
from pendkit.wiring import connections, draw_wiring, read_pins
from tests.readme_row import ROW_START, command_row, rewrite

ROOT = Path(__file__).resolve().parents[1]
BOM = ROOT / "hardware_bom" / "bom.csv"
PINS = ROOT / "firmware" / "include" / "pins.h"
# Commands that cannot run here, by the reason their line gives.
NOT_HERE = ("# hardware-only", "# windows-only", "# online-only", "# classroom-only", "# interactive",
            "# long-running", "# cluster-only")
# long-running servers are exercised as processes by tests/cli/test_link_commands.py


def test_bom_columns_and_totals():
    lines = read_bom(BOM)
    assert len(lines) >= 12
    total = sum(line.quantity * line.unit_price for line in lines if line.scope == "rig")
    shared = sum(line.quantity * line.unit_price for line in lines if line.scope == "class")
    summary = cost_summary(lines, rigs=10)
    assert f"**{total:.2f}**" in summary and f"**{shared:.2f}**" in summary
    assert f"**{10 * total + shared:.2f}**" in summary
    assert 100 < total < 300  # a low-cost rig, as the paper promises
    parts = {line.part for line in lines}
    assert {"Kill switch", "Wi-Fi access point", "Broker computer"} <= parts
    assert {line.scope for line in lines if line.part in ("Wi-Fi access point", "Broker computer")} == {"class"}
    assert (ROOT / "hardware_bom" / "README.md").read_text().count(summary) == 1, \
        "hardware_bom/README.md is stale: paste `pendkit bom` into it"


@pytest.mark.parametrize("change, words", [
    (lambda text: text.replace("part,part_number", "part,number"), "columns must be"),
    (lambda text: text.replace("2026-11-21", "21/11/2026", 1), "YYYY-MM-DD"),
    (lambda text: text.replace(",USD,", ",EUR,", 1), "one currency"),
    (lambda text: text.replace(",rig,", ",lab,", 1), "scope must be one of"),
    (lambda text: text.replace(",44.99,", ",free,", 1), "must be numbers"),
])
def test_bad_bom_files_are_refused(tmp_path, change, words):
    bad = tmp_path / "bom.csv"
    bad.write_text(change(BOM.read_text()))
    with pytest.raises(ConfigError, match=words):
        read_bom(bad)
    assert list(COLUMNS)[0] == "part"


def test_wiring_follows_the_pin_map(tmp_path):
    pins = read_pins(PINS)
    text = PINS.read_text()
    for name, value in pins.items():
        assert re.search(rf"{name}\s*=\s*{value:#x}|{name}\s*=\s*{value}\b", text)
    labels = " ".join(label for _, _, label, _ in connections(pins))
    for name in ("kEncoderClock", "kEncoderData", "kEncoderChipSelect", "kI2cSda", "kI2cScl"):
        assert f"GPIO {pins[name]}" in labels
    image = draw_wiring(PINS, tmp_path / "wiring.png")
    assert image.read_bytes()[:4] == b"\x89PNG"
    other = tmp_path / "pins.h"
    other.write_text(text.replace("kEncoderClock = 10", "kEncoderClock = 33"))
    assert "CLK  GPIO 33" in " ".join(label for _, _, label, _ in connections(read_pins(other)))


def test_docs_build_with_no_broken_links(tmp_path):
    pytest.importorskip("mkdocs")
    result = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(tmp_path)],
                            cwd=ROOT, capture_output=True, text=True)
    assert result.returncode == 0, result.stderr[-2000:]


def test_strict_docs_build_catches_a_broken_link(tmp_path):
    pytest.importorskip("mkdocs")
    shutil.copytree(ROOT / "docs", tmp_path / "docs")
    shutil.copy(ROOT / "mkdocs.yml", tmp_path)
    (tmp_path / "docs" / "index.md").write_text("[gone](no-such-page.md)\n")
    result = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict"], cwd=tmp_path,
                            capture_output=True, text=True)
    assert result.returncode != 0 and "no-such-page.md" in result.stderr


def doc_commands():
    for page in sorted((ROOT / "docs").glob("*.md")):
        if page.name == "first-day.md":
            continue  # run in order, with its broker and virtual rigs, by tests/test_first_day.py
        for block in re.findall(r"```(?:bash|powershell|sh)\n(.*?)```", page.read_text(), re.S):
            for line in block.splitlines():
                if line.strip() and not line.strip().startswith("#"):
                    yield page.name, line.strip()


@pytest.fixture(scope="module")
def workspace(tmp_path_factory):
    """A copy of what the commands touch, so running them changes nothing in the repository."""
    root = tmp_path_factory.mktemp("docs-commands")
    for folder in ("solutions", "labs", "hardware_bom", "firmware/include"):
        shutil.copytree(ROOT / folder, root / folder)
    (root / "submissions" / "ana").mkdir(parents=True)
    shutil.copy(ROOT / "solutions" / "01_encoder.ipynb", root / "submissions" / "ana")
    return root


def test_every_command_in_the_docs_is_exercised_or_marked(workspace, monkeypatch):
    ci = (ROOT / ".ci" / "run").read_text()
    monkeypatch.chdir(workspace)
    ran = []
    for page, line in doc_commands():
        command = line.split("  #")[0].strip()
        if any(marker in line for marker in NOT_HERE) or command in ci:
            continue
        assert command.startswith("pendkit "), f"{page}: `{line}` is neither exercised here nor marked"
        args = command.split()[1:]
        if args[:1] == ["demo"]:
            args += ["--quiet", "--no-animation", "--out", str(workspace / "out")]
        result = CliRunner().invoke(main, [a.strip('"') for a in args], catch_exceptions=False)
        assert result.exit_code == 0, f"{page}: `{command}` failed:\n{result.output}"
        ran.append(command)
    assert {"pendkit bom", "pendkit wiring", "pendkit labs build"} <= set(ran)
    assert any(c.startswith("pendkit grade") for c in ran)


def test_the_readmes_command_list_is_the_clis():
    row = next(line for line in (ROOT / "README.md").read_text().splitlines() if line.startswith(ROW_START))
    listed = set(re.findall(r"`(?:pendkit )?([a-z][a-z-]*)(?: [a-z/]+)?`", row.split("|")[3]))
    assert listed == set(main.commands), (f"README lists {sorted(listed)}; the CLI has {sorted(main.commands)}: "
                                          "`python -m tests.readme_row` rewrites the row")
    assert row == command_row(main), "README's command row is stale: `python -m tests.readme_row` rewrites it"


def test_the_readme_row_writer_adds_a_new_command(tmp_path):
    @click.command("new-thing")
    def new_thing():
        """A command added in one module."""

    group = click.Group(commands={**main.commands, "new-thing": new_thing})
    readme = tmp_path / "README.md"
    readme.write_text((ROOT / "README.md").read_text())
    assert rewrite(readme, group)
    assert "`new-thing`" in readme.read_text()
    assert not rewrite(readme, group)



# --- Research apart from the product: results pages are tables with their provenance; guides carry no dated
# or stale figures (issue 70, part 4). What was tried, in order, lives in research/ (not held to these rules).
RESULTS = ROOT / "docs" / "results"
GUIDES = sorted(p for p in (ROOT / "docs").glob("*.md")) + [ROOT / "README.md", ROOT / "CONTRIBUTING.md"]
PROVENANCE = re.compile(r"^commit=([0-9a-f]{7,40}) date=(\d{4}-\d\d-\d\d) machine=\S.*$", re.M)
ISO_DATE = re.compile(r"\b(?:19|20)\d\d-[01]\d-[0-3]\d\b")
DIARY = re.compile(r"\b(?:yesterday|tonight|last night|this (?:morning|afternoon|evening|week)|last (?:week|session)"
                   r"|this session|(?:third|fourth|fifth|sixth|seventh|eighth|ninth|tenth) session)\b"
                   r"|, (?:morning|afternoon|evening|night)\)", re.I)
NUMBER = r"\d{1,3}(?: \d{3})+|\d+"  # 10 000 as the docs write it
SCORE = re.compile(rf"(?<![\w./=-])({NUMBER}) ?(?:/|of) ?({NUMBER})(?![\w\"./%-]|\.\d)")


def _defined_scores() -> set[tuple[int, int]]:
    """Fractions that are definitions, not measurements: the kit's rule, the shipped bar, the solved tail and
    the encoder's seam, read from the code that defines them."""
    from pendkit.agents.policy_rule import RULE_MIN_HELD, RULE_STARTS, SHIPPED_RANDOM, SHIPPED_REST
    from pendkit.encoder import ENCODER_COUNTS
    from pendkit.env_name import EPISODE_STEPS
    from pendkit.features import SOLVED_TAIL_STEPS

    return {(RULE_MIN_HELD, len(RULE_STARTS)), SHIPPED_RANDOM, SHIPPED_REST, (SOLVED_TAIL_STEPS, EPISODE_STEPS),
            (0, ENCODER_COUNTS - 1)}


def _prose(text: str) -> str:
    """The text without fenced blocks and inline code (quoted commands and their output)."""
    text = re.sub(r"^(```|~~~).*?^\1", "", text, flags=re.S | re.M)
    text = re.sub(r"^(?: {4}|\t).*$", "", text, flags=re.M)  # indented code
    return re.sub(r"`[^`\n]*`", "", text)


def _scores(text: str) -> set[tuple[int, int]]:
    found = set()
    for m in SCORE.finditer(text):
        n, d = (int(g.replace(" ", "")) for g in m.groups())
        if 2 <= d and n <= d:
            found.add((n, d))
    return found


def stale_figures(page: Path, text: str) -> list[str]:
    """A guide's problems: any ISO date (code included), a diary's words, and a score (k/n or k of n) outside
    code that is not a definition and whose paragraph does not link a results page that carries it."""
    problems = [f"{page.name}: a date ({m.group(0)}): dated figures go in docs/results/"
                for m in ISO_DATE.finditer(text)]
    prose = _prose(text)
    problems += [f"{page.name}: a diary's word ({m.group(0)!r}): the route to a result goes in research/"
                 for m in DIARY.finditer(prose)]
    defined = _defined_scores()
    for paragraph in re.split(r"\n\s*\n", prose):
        scores = _scores(paragraph) - defined
        if not scores:
            continue
        linked = [RESULTS / name for name in re.findall(r"\]\((?:\.\./)?(?:docs/)?results/([\w-]+\.md)", paragraph)]
        carried = set().union(*(_scores(p.read_text()) for p in linked if p.exists()))
        for n, d in sorted(scores - carried):
            where = "links no results page" if not linked else "is not carried by the results page it links"
            problems.append(f"{page.name}: the figure {n}/{d} {where}: {' '.join(paragraph.split())[:120]}")
    return problems


def results_problems(page: Path, text: str) -> list[str]:
    """A results page's problems: a table without, since the table before it, a fenced block holding its
    command (`$ ...`) and the `commit=... date=... machine=...` line the benchmarks print; a page without a table."""
    problems, blocks = [], []
    lines = text.splitlines()
    tables = 0
    fence, fence_lines = None, []
    for k, line in enumerate(lines):
        stripped = line.strip()
        if fence is not None:
            if stripped.startswith(fence):
                blocks.append("\n".join(fence_lines))
                fence = None
            else:
                fence_lines.append(stripped)
            continue
        if stripped.startswith(("```", "~~~")):
            fence = stripped[:3]
            fence_lines = []
            continue
        starts_table = (stripped.startswith("|") and k + 1 < len(lines) and re.match(r"\|\s*:?-", lines[k + 1].strip())
                        and not (k and lines[k - 1].strip().startswith("|")))
        if starts_table:
            tables += 1
            if not any(PROVENANCE.search(b) and re.search(r"^\$ \S", b, re.M) for b in blocks):
                problems.append(f"{page.name}:{k + 1}: a table without its command and commit=/date=/machine= block")
            blocks = []
    if not tables:
        problems.append(f"{page.name}: no table (a results page is tables, each with its provenance)")
    problems += [f"{page.name}: a diary's word ({m.group(0)!r}): the route to a result goes in research/"
                 for m in DIARY.finditer(_prose(text))]
    for commit, date in PROVENANCE.findall(text):
        datetime.date.fromisoformat(date)
        if _git("cat-file", "-e", f"{commit}^{{commit}}") is False:
            problems.append(f"{page.name}: commit {commit} is not in this repository's history")
    return problems


def _git(*args: str) -> bool | None:
    """True/False for a git command's success; None where there is no full history to ask."""
    git = shutil.which("git")
    if not git or not (ROOT / ".git").exists():
        return None
    shallow = subprocess.run([git, "rev-parse", "--is-shallow-repository"], cwd=ROOT, capture_output=True, text=True)
    if shallow.returncode or shallow.stdout.strip() != "false":
        return None
    return subprocess.run([git, *args], cwd=ROOT, capture_output=True).returncode == 0


@pytest.mark.parametrize("page", GUIDES, ids=lambda p: p.name)
def test_guides_carry_no_dated_or_stale_figures(page):
    problems = stale_figures(page, page.read_text())
    assert not problems, "\n".join(problems)


RESULTS_PAGES = [pytest.param(p, marks=pytest.mark.xfail(strict=True, reason="the labs' owner adds its tables' "
                                                          "provenance blocks (issue 70, part 4)"))
                 if p.name == "labs.md" else p for p in sorted(RESULTS.glob("*.md"))]


@pytest.mark.parametrize("page", RESULTS_PAGES, ids=lambda p: p.name)
def test_every_results_table_says_its_command_commit_date_and_machine(page):
    problems = results_problems(page, page.read_text())
    assert not problems, "\n".join(problems)


def test_the_figure_rules_catch_what_they_are_for(tmp_path):
    results = RESULTS / "robust.md"
    guide = tmp_path / "guide.md"
    assert stale_figures(guide, "Measured 2026-11-28: fine.")  # a date
    assert stale_figures(guide, "Then, in the fourth session, it held.")  # a diary
    assert stale_figures(guide, "It holds 71 of 90 unseen rigs.")  # a figure with no link
    assert stale_figures(guide, "It holds 70/90 ([results](results/robust.md)).")  # linked, not carried there
    assert not stale_figures(guide, "It holds 75/90 on the device ([results](results/robust.md)).")
    assert "75/90" in results.read_text()
    assert not stale_figures(guide, "Solved when 9 of 10 hold; `solved=10/10` is printed.")  # the rule; output
    good = ("```text\n$ python benchmarks/bench_sim.py\ncommit=0fb89c2 date=2026-11-29 machine=x86_64, 2 cores\n```\n\n"
            "| a | b |\n|---|---|\n| 1 | 2 |\n")
    assert not results_problems(guide, good)
    assert results_problems(guide, good.replace("$ python", "python"))  # no command
    assert results_problems(guide, good.replace("commit=0fb89c2 ", ""))  # no commit
    assert results_problems(guide, good + "\n| c |\n|---|\n| 3 |\n")  # a second table shares the first's block
    assert results_problems(guide, "Prose only, 2026-11-29.\n")  # no table
    assert results_problems(guide, good + "\nMeasured in the fourth session.\n")  # a diary
    if _git("rev-parse", "HEAD") is not None:
        assert results_problems(guide, good.replace("0fb89c2", "0000000"))  # a commit the history lacks


def test_every_study_is_a_results_tables_command():
    """A study (benchmarks/studies/) stays while a results table reproduces with it; the route to a result, and
    the studies it alone used, are in research/ and the history."""
    pages = "\n".join(p.read_text() for p in RESULTS.glob("*.md"))
    commands = "\n".join(re.findall(r"^```\w*\n(.*?)^```", pages, re.S | re.M))  # the pages' fenced commands
    for study in sorted((ROOT / "benchmarks" / "studies").glob("*.py")):
        assert f"benchmarks/studies/{study.name}" in commands, f"no results table runs {study.name}: move it out"


def test_the_controllers_table_lists_every_registered_controller():
    """docs/control.md's table of `--controller` names is the registry's (pendkit.deploy.controllers)."""
    import re

    from pendkit.deploy.controllers import CONTROLLER_NAMES

    text = (ROOT / "docs" / "control.md").read_text()
    table = text.split("## The classical controllers", 1)[1].split("\n## ", 1)[0]
    assert sorted(re.findall(r"^\| `([a-z][a-z-]*)` \|", table, flags=re.M)) == sorted(CONTROLLER_NAMES)
