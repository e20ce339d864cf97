"""A QIF MBD model's characteristics judged (an MbdInspection) as a first-article table in the
document: a spreadsheet with one row per characteristic of the model (id, name, type, tolerance,
datums, faces, points, measured value, U, decision, conforms), the ones this tool does not judge
listed with the reason, under a line with the model, the measured file and the verdict.
"""
from __future__ import annotations

import os
from typing import Any

from ..geometry.validation import InputTypeError
from .sheets import fit_columns, write_rows
from .transaction import recompute, transaction

VERDICTS = {True: "conforms", False: "does not conform", None: "no verdict"}
# The table's columns that hold figures (numbers in the sheet, text elsewhere).
FIGURES = ("tolerance", "points", "value", "uncertainty")


def add_first_article_to_document(found: Any, doc: Any) -> Any:
    """Add the first-article table of ``found`` (cmmsampling.inspect of a model's plan: an
    MbdInspection) to ``doc`` as a spreadsheet, in one transaction; returns the sheet."""
    from ..inspection.characteristics import COLUMNS, MbdInspection

    if not isinstance(found, MbdInspection):
        raise InputTypeError(f"a first-article table is made of a model's characteristics judged "
                             f"(cmmsampling.inspect(plan(read_mbd(path)), measured)), got a {type(found).__name__}")
    name = os.path.basename(found.plan.model.path)
    rows: list[tuple] = [(f"{name}: {found.table().splitlines()[-1]}; measured: "
                          f"{found.measured_file or 'points given in hand'}",),
                         tuple(heading for heading, _ in COLUMNS)]
    rows += [tuple(_cell(key, row[key]) for _, key in COLUMNS) for row in found.rows()]
    with transaction(doc, "Add first-article table"):
        sheet = doc.addObject("Spreadsheet::Sheet", "FirstArticle")
        sheet.Label = f"First article {os.path.splitext(name)[0]} ({VERDICTS[found.passed]})"
        write_rows(sheet, rows)
        fit_columns(sheet, rows)
        recompute(doc, [sheet])
    return sheet


def _cell(key: str, text: str) -> str | float:
    """A table cell as the sheet holds it: a figure's column as a number (where it has one)."""
    if key not in FIGURES or not text:
        return text
    try:
        return float(text)
    except ValueError:   # a figure with its words, e.g. '0.5000 (UZ +0.1000)'
        return text
