"""The spreadsheets of the document: a result's deviation report and a plan's report, as text
a CMM programmer reads (coordinates to 0.1 um) with aliases for expressions."""
import json
from xml.etree import ElementTree

import numpy as np

from ..fitting.deviation import mm_text

REPORT_COLUMNS = "ABCDEFGHIJ"
REPORT_WIDTHS = {"A": 190, "B": 110, "C": 110, **{c: 95 for c in "DEFGHIJ"}}
PARAMETER_NAMES = {
    "fit_degree": "Fit degree (u x v)", "fit_poles": "Fit poles (u x v)", "smoothing": "Fit smoothing",
    "grid": "Evaluation grid (u x v)", "seed": "Seed", "workers": "Processes",
    "edge_offset": "Edge offset (mm)", "min_spacing": "Minimum spacing (mm)",
    "population": "PSO population", "iterations": "PSO iterations", "w1": "PSO inertia w1",
    "w2": "PSO inertia w2", "c1": "PSO c1", "c2": "PSO c2", "velocity_limit": "PSO velocity limit",
    "start_from_uniform": "PSO starts from uniform", "start": "Descent start",
    "time_limit": "Time limit (s)", "max_evaluations": "Most evaluations", "closest": "Closest points (mm)",
}


def write_deviation_report(sheet, points):
    """Fill the spreadsheet with the probe points' summary, run parameters, notes and per-point
    table, in readable columns.

    The summary figures are numbers in column B with aliases (strategy, n, max_mm, mean_mm,
    rms_mm, std_mm, occ_max_mm, time_s) for expressions such as ``=DeviationReport.max_mm``;
    column C repeats them readably, with their unit (the spreadsheet shows numbers with two
    decimals, which hides micrometres). The per-point table is text at the CMM's resolution.
    """
    clear_cells(sheet)
    summary = summary_rows(points)
    rows = ([row[:2] + _readable(row) for row in summary] + parameter_rows(points)
            + note_rows(points) + [()] + table_rows(points))
    for row, values in enumerate(rows, start=1):
        for column, value in zip(REPORT_COLUMNS, values):
            sheet.set(f"{column}{row}", _cell_text(value))
    for row, entry in enumerate(summary, start=1):
        if len(entry) == 3:
            sheet.setAlias(f"B{row}", entry[2])
    header = len(rows) - len(points.Labels)
    sheet.setStyle("A1", "bold")
    sheet.setStyle(f"A{header}:J{header}", "bold")
    sheet.setAlignment(f"B{header}:J{len(rows)}", "right")
    for column, width in REPORT_WIDTHS.items():
        sheet.setColumnWidth(column, width)


def clear_cells(sheet):
    """Empty every used cell of a spreadsheet (content, alias, style), undoably.

    FreeCAD 0.20's ``Sheet.clearAll()`` is not undoable: an Undo after it restores an empty sheet.
    Clearing cell by cell is. The used cells are read from the sheet's saved form.
    """
    for cell in ElementTree.fromstring(sheet.cells.Content).iter("Cell"):
        sheet.clear(cell.get("address"))


def summary_rows(points):
    """The report's summary: rows (name, value[, alias])."""
    return [
        ("CMM sampling report",),
        ("Source", points.SourceName or "(none)"),
        ("Strategy", points.Strategy, "strategy"),
        ("Points", len(points.Labels), "n"),
        ("Max deviation (mm)", points.MaxDeviation.Value, "max_mm"),
        ("Mean deviation (mm)", points.MeanDeviation.Value, "mean_mm"),
        ("RMS deviation (mm)", points.RmsDeviation.Value, "rms_mm"),
        ("Std deviation (mm)", points.StdDeviation.Value, "std_mm"),
        ("OCC max deviation (mm)", points.OccMaxDeviation.Value, "occ_max_mm"),
        ("Sampling time (s)", points.RunTime, "time_s"),
        ("Cancelled", "yes" if points.Cancelled else "no"),
    ] + reach_rows(points)


def reach_rows(points):
    """The report's rows on the probe's reach, for points sampled with the part: the points
    reached with the stylus tilted, those it cannot reach, and the face's area out of reach."""
    if not getattr(points, "Probe", ""):
        return []
    reached = np.isfinite(np.array([tuple(a) for a in points.Axes], dtype=float)).all(axis=1)
    return [
        ("Probe", probe_text(json.loads(points.Probe))),
        ("Points reached tilted", int(sum(points.Tilted)), "tilted"),
        ("Points the probe cannot reach", int(np.count_nonzero(~reached)), "unreached"),
        ("Area out of reach (mm^2)", points.UnreachedArea.Value, "unreached_mm2"),
    ]


def probe_text(probe):
    """A probe's settings (dict of cmmsampling.Probe's fields) in words: 'ball 2 mm, stylus 20 x
    1.5 mm, ...'."""
    return (f"ball {probe.get('ball_diameter', 0):g} mm, stylus {probe.get('stylus_length', 0):g} x "
            f"{probe.get('stylus_diameter', 0):g} mm, tilt up to {probe.get('max_tilt', 0):g} deg")


def parameter_rows(points):
    """The run's parameters other than strategy, N and the probe (:func:`reach_rows` says it):
    rows (name with its unit, value)."""
    settings = json.loads(points.Parameters)
    return [(PARAMETER_NAMES.get(key, key.replace("_", " ").capitalize()), _parameter_text(value))
            for key, value in settings.items() if key not in ("strategy", "n", "probe")]


def note_rows(points):
    """The run's notes: rows ("Note", sentence)."""
    return [("Note", note) for note in getattr(points, "Notes", [])]


def table_rows(points):
    """The per-point table: a header and rows (label, x, y, z, i, j, k, u, v, deviation), the
    values as text: coordinates to 0.1 um, approach vectors to 6 decimals, parameters and
    deviations to 6 significant digits."""
    header = ("Label", "X (mm)", "Y (mm)", "Z (mm)", "I", "J", "K", "U", "V", "Deviation (mm)")
    return [header] + [
        (label, *(f"{c:.4f}" for c in p), *(f"{c:.6f}" for c in n), f"{u:.6g}", f"{v:.6g}", f"{d:.6g}")
        for label, p, n, u, v, d in zip(points.Labels, points.Points, points.Normals,
                                        points.U, points.V, points.Deviation)
    ]


def _readable(row):
    """(text,) for a summary row (name, number[, alias]) whose name ends in its unit, 'Max
    deviation (mm)': the number to four significant digits with the unit, so that micrometres
    show; () for other rows."""
    if len(row) < 2 or isinstance(row[1], (str, bool)) or not row[0].endswith(")"):
        return ()
    unit = row[0][row[0].rindex("(") + 1:-1]
    return (mm_text(row[1]),) if unit == "mm" else (f"{row[1]:.4g} {unit}",)


PLAN_COLUMNS = ("Face", "Area (mm^2)", "N", "Max deviation (mm)", "Bound (mm)", "Tolerance met", "Notes")


def write_plan_report(sheet, plan, moves=None):
    """The per-part table of a plan in a spreadsheet: a title, the goal, one row per face and a
    row for the part (points in all, the worst face's deviation); below, for a plan made with a
    probe, the probe and, given its path (moves: a ProbeMoves), the path's length (mm) and the
    measuring time (s) as numbers."""
    goal = (f"tolerance {plan.tolerance:g} mm" if plan.tolerance is not None else f"{plan.budget} points")
    rows = [("CMM sampling plan",), ("Goal", goal), ("Strategy", plan.strategy), (), PLAN_COLUMNS]
    for face in plan.faces:
        rows.append((face.name, f"{face.area:.2f}", face.n, _figure(face.maximum), _figure(face.bound),
                     face.met_text, face.notes))
    rows.append(("Part", f"{plan.area:.2f}", plan.n_total, _figure(plan.worst), "",
                 "", f"{len(plan.refused)} faces without points" if plan.refused else ""))
    rows += _probe_rows(plan.probe, moves)
    for row, values in enumerate(rows, start=1):
        for column, value in zip(REPORT_COLUMNS, values):
            sheet.set(f"{column}{row}", _cell_text(value))
    sheet.setStyle("A1", "bold")
    sheet.setStyle("A5:G5", "bold")
    sheet.setColumnWidth("A", 110)
    sheet.setColumnWidth("G", 400)


def _probe_rows(probe, moves):
    """The plan report's rows on its probe (none without one) and its path (when given)."""
    if probe is None:
        return []
    rows = [(), ("Probe", f"{probe.ball_diameter:g} mm ball, {probe.stylus_length:g} mm stylus "
                          f"({probe.stylus_diameter:g} mm), {probe.body_diameter:g} mm body")]
    if moves is not None:
        rows += [("Probe path", float(moves.travel), "mm of moves between the points, "
                  f"{moves.detours} over the clearance plane"),
                 ("Measuring time", float(moves.seconds), "s, estimated from the CMM's speeds")]
    return rows


def _figure(value):
    """A deviation in mm as text at the CMM's resolution ('' for NaN)."""
    return "" if not np.isfinite(value) else f"{value:.6f}"


def _parameter_text(value):
    """A run parameter as report text: (u, v) pairs as 'a x b', other lists as JSON."""
    if isinstance(value, (list, tuple)):
        if len(value) == 2 and all(isinstance(v, (int, float)) for v in value):
            return f"{value[0]} x {value[1]}"
        return json.dumps(value)
    return value


def _cell_text(value):
    """Spreadsheet cell content: numbers in full precision, text always as text (never a
    formula or a number, e.g. the table's '12.3456')."""
    if isinstance(value, bool):
        return "'yes" if value else "'no"
    if isinstance(value, (int, float, np.floating, np.integer)):
        return format(float(value), ".10g")
    return "'" + str(value)
