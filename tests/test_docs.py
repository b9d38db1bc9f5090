"""The guides: the BOM adds up, the wiring diagram follows the firmware's pin map, the docs build with
no broken links, and every command they show is exercised or says why it cannot be here."""

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

