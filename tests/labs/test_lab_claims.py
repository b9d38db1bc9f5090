"""What labs 07-09 tell a student to expect is what the kit measured: each claim in a notebook's text is
held to its source (the results page's claims table, the cell's own code)."""

import re
from pathlib import Path

import nbformat

ROOT = Path(__file__).resolve().parents[2]


def text_of(notebook_name: str) -> str:
    notebook = nbformat.read(ROOT / "solutions" / notebook_name, as_version=4)
    return "\n".join(cell.source for cell in notebook.cells)


def claims_row(lab: str) -> list[str]:
    """The cells of lab `lab`'s row in docs/results/labs.md's table of claims (its first cell `lab07-claim`)."""
    for line in (ROOT / "docs" / "results" / "labs.md").read_text().splitlines():
        if line.startswith(f"| lab{lab}-claim "):
            return [cell.strip() for cell in line.strip("|").split("|")]
    raise AssertionError(f"no lab{lab}-claim row in docs/results/labs.md")


def deployed_policies() -> tuple[str, ...]:
    """The policies lab 09's policy cell deploys (its DEPLOYED line)."""
    import ast

    notebook = nbformat.read(ROOT / "solutions" / "09_deploy.ipynb", as_version=4)
    line = next(line for cell in notebook.cells for line in cell.source.splitlines() if line.startswith("DEPLOYED ="))
    return tuple(ast.literal_eval(line.split("=", 1)[1].split("#")[0].strip()))


def test_lab07_quotes_its_five_seeds_as_measured():
    _, _, reached, episodes, held_out = claims_row("07")[:5]
    counts = [int(n) for n in re.findall(r"\d+", episodes)]
    text = " ".join(text_of("07_dqn.ipynb").split())
    assert reached == "5/5" and "every seed reached a policy that holds" in text
    assert f"after {min(counts)} to {max(counts)} episodes" in text, (counts, text)
    lowest = min(int(n) for n in re.findall(r"\d+", held_out))
    held = "10 of 10" if lowest == 10 else f"{lowest} or 10 of 10"
    assert f"held {held} starts it had never been judged on" in text, held_out


def test_lab08_quotes_its_five_seeds_as_measured():
    text = " ".join(text_of("08_gru_rdqn.ipynb").split())
    for name, said in (("dqn", "plain DQN reached a policy that holds in {k} of 5"),
                       ("dqn+actions", "the delay-aware DQN in {k} of 5")):
        row = claims_row("08-" + name.replace("+", "-"))
        assert said.format(k=row[2].split("/")[0]) in text, (row, said)


def test_lab09_names_the_policies_its_cell_deploys_and_says_two():
    deployed = deployed_policies()
    text = text_of("09_deploy.ipynb")
    assert len(deployed) == 2 and "two policies" in text  # the report asks about "both policies"
    for name in deployed:
        assert f"`{name}`" in text, name
