"""The bill of materials: read `hardware_bom/bom.csv`, check its columns, total it per rig and per class.

`scope` says whether a line is bought for every rig ("rig") or once for the room ("class": the Wi-Fi access
point, the broker computer)."""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass
from pathlib import Path

from pendkit.errors import ConfigError

COLUMNS = ("part", "part_number", "quantity", "unit_price", "currency", "price_date", "supplier", "scope",
           "alternatives", "notes")
SCOPES = ("rig", "class")


@dataclass(frozen=True)
class BomLine:
    part: str
    part_number: str
    quantity: float
    unit_price: float
    currency: str
    price_date: str
    supplier: str
    scope: str = "rig"

    @property
    def cost(self) -> float:
        return self.quantity * self.unit_price


def read_bom(path: str | Path) -> list[BomLine]:
    """Parse and check the CSV: exact columns, positive numbers, one currency, ISO dates."""
    with Path(path).open(newline="") as handle:
        reader = csv.DictReader(handle)
        if tuple(reader.fieldnames or ()) != COLUMNS:
            raise ConfigError(f"{path}: columns must be {', '.join(COLUMNS)}; got {reader.fieldnames}")
        lines = []
        for row_number, row in enumerate(reader, start=2):
            try:
                quantity, price = float(row["quantity"]), float(row["unit_price"])
            except ValueError:
                raise ConfigError(f"{path}:{row_number}: quantity and unit_price must be numbers") from None
            if not (quantity > 0 and price >= 0 and math.isfinite(quantity * price)):
                raise ConfigError(f"{path}:{row_number}: quantity must be > 0 and unit_price >= 0")
            date = row["price_date"]
            if len(date) != 10 or date[4] != "-" or date[7] != "-" or not date.replace("-", "").isdigit():
                raise ConfigError(f"{path}:{row_number}: price_date must be YYYY-MM-DD, got {date!r}")
            if not row["part"] or not row["part_number"] or not row["supplier"]:
                raise ConfigError(f"{path}:{row_number}: part, part_number and supplier are required")
            if row["scope"] not in SCOPES:
                raise ConfigError(f"{path}:{row_number}: scope must be one of {SCOPES}, got {row['scope']!r}")
            lines.append(BomLine(row["part"], row["part_number"], quantity, price, row["currency"], date,
                                 row["supplier"], row["scope"]))
    currencies = {line.currency for line in lines}
    if len(currencies) != 1:
        raise ConfigError(f"{path}: one currency please, found {sorted(currencies)}")
    return lines


def totals(lines: list[BomLine], rigs: int = 10) -> tuple[float, float, float]:
    """(one rig, the class-wide items, a class of `rigs` rigs with its class-wide items)."""
    per_rig = sum(line.cost for line in lines if line.scope == "rig")
    per_class = sum(line.cost for line in lines if line.scope == "class")
    return per_rig, per_class, per_rig * rigs + per_class


def cost_summary(lines: list[BomLine], rigs: int = 10) -> str:
    """A Markdown table of costs: every rig's parts, the class-wide items, and the totals."""
    currency = lines[0].currency
    per_rig, per_class, class_total = totals(lines, rigs)
    rows = [f"| {line.part} | {line.part_number} | {line.scope} | {line.quantity:g} | {line.unit_price:.2f} | "
            f"{line.cost:.2f} |" for line in sorted(lines, key=lambda line: SCOPES.index(line.scope))]
    return "\n".join([
        f"| part | part number | per | quantity | unit price ({currency}) | cost ({currency}) |",
        "|---|---|---|---|---|---|", *rows,
        f"| **one rig** | | | | | **{per_rig:.2f}** |",
        f"| **once per class** (network, broker) | | | | | **{per_class:.2f}** |",
        f"| **a class of {rigs} rigs** | | | | | **{class_total:.2f}** |",
    ])
