"""The spreadsheets of the document: a result's deviation report and a plan's report, as a CMM
programmer reads them (coordinates to 0.1 um), the figures numbers with aliases for expressions.

FreeCAD shows a number with the user's number of decimals (two by default), which would show a
deviation of 0.0084 mm as 0.01. Deviation cells therefore hold the number in mm (what an
expression such as ``=DeviationReport.max_mm`` gets) and display it in micrometres
(DEVIATION_DISPLAY_UNIT: '8.41 µm', 10 nm at two decimals).
"""
import json
from types import SimpleNamespace
from xml.etree import ElementTree

import numpy as np

REPORT_COLUMNS = "ABCDEFGHIJKLM"
DEVIATION_DISPLAY_UNIT = "µm"
DEVIATION_ALIASES = ("max_mm", "mean_mm", "rms_mm", "std_mm", "occ_max_mm")
# Column widths (pixels) from the longest entry: CHARACTER_PIXELS a character plus COLUMN_PADDING,
# between the bounds; the notes' column keeps NOTES_WIDTH.
CHARACTER_PIXELS = 7
COLUMN_PADDING = 16
COLUMN_WIDTHS = (60, 260)
NOTES_WIDTH = 400
PARAMETER_NAMES = {
    "fit_degree": "Fit degree (u x v)", "fit_poles": "Fit poles (u x v)", "smoothing": "Fit smoothing",
    "grid": "Evaluation grid (u x v)", "seed": "Seed", "workers": "Processes asked",
    "processes": "Processes the swarm used",
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
    rms_mm, std_mm, occ_max_mm, normal_angle_deg, time_s) for expressions such as ``=DeviationReport.max_mm``, the
    deviations in mm shown in micrometres (see the module's docstring). The per-point table is
    text at the CMM's resolution, but for its deviations: numbers in mm shown in micrometres.
    """
    clear_cells(sheet)
    summary = summary_rows(points)
    notes = note_rows(points)
    rows = [row[:2] for row in summary] + parameter_rows(points) + notes + [()] + table_rows(points)
    write_rows(sheet, rows)
    name_figures(sheet, summary, DEVIATION_ALIASES)
    header = len(rows) - len(points.Labels)
    sheet.setStyle("A1", "bold")
    sheet.setStyle(f"A{header}:J{header}", "bold")
    sheet.setAlignment(f"B{header}:J{len(rows)}", "right")
    in_micrometres(sheet, "J", range(header + 1, len(rows) + 1))
    fit_columns(sheet, [row for row in rows if row not in notes])


def write_rows(sheet, rows):
    """Write rows (tuples of cell values, from column A) into the sheet from row 1 (see
    :func:`_cell_text`)."""
    for row, values in enumerate(rows, start=1):
        for column, value in zip(REPORT_COLUMNS, values):
            sheet.set(f"{column}{row}", _cell_text(value))


def name_figures(sheet, summary, in_micrometres):
    """Give the summary's figures (rows (name, value, alias) from row 1) their aliases in column
    B, those named in in_micrometres shown in DEVIATION_DISPLAY_UNIT."""
    for row, entry in enumerate(summary, start=1):
        if len(entry) == 3:
            sheet.setAlias(f"B{row}", entry[2])
            if entry[2] in in_micrometres:
                sheet.setDisplayUnit(f"B{row}", DEVIATION_DISPLAY_UNIT)


def in_micrometres(sheet, columns, rows):
    """Show the cells of ``columns`` (letters, e.g. "DE") in ``rows`` (numbers), deviations in mm,
    in DEVIATION_DISPLAY_UNIT."""
    for row in rows:
        for column in columns:
            sheet.setDisplayUnit(f"{column}{row}", DEVIATION_DISPLAY_UNIT)


def clear_cells(sheet):
    """Empty every used cell of a spreadsheet (content, alias, style), undoably.

    FreeCAD 0.20's ``Sheet.clearAll()`` is not undoable: an Undo after it restores an empty sheet.
    Clearing cell by cell is. The used cells are read from the sheet's saved form.
    """
    for cell in ElementTree.fromstring(sheet.cells.Content).iter("Cell"):
        sheet.clear(cell.get("address"))


# The normal angle of probe points made before it was reported.
ZERO_ANGLE = SimpleNamespace(Value=0.0)


def summary_rows(points):
    """The report's summary: rows (name, value[, alias])."""
    return [
        ("CMM sampling report",),
        ("Source", points.SourceName or "(none)"),
        ("Strategy", points.Strategy, "strategy"),
        ("Points", len(points.Labels), "n"),
        ("Max deviation", points.MaxDeviation.Value, "max_mm"),
        ("Mean deviation", points.MeanDeviation.Value, "mean_mm"),
        ("RMS deviation", points.RmsDeviation.Value, "rms_mm"),
        ("Std deviation", points.StdDeviation.Value, "std_mm"),
        ("OCC max deviation", points.OccMaxDeviation.Value, "occ_max_mm"),
        ("Largest normal angle (deg)", getattr(points, "MaxNormalAngle", ZERO_ANGLE).Value, "normal_angle_deg"),
        ("Sampling time (s)", points.RunTime, "time_s"),
        ("Cancelled", "yes" if points.Cancelled else "no"),
    ] + reach_rows(points)


def reach_rows(points):
    """The report's rows on the probe's reach, for points sampled with the part: the points
    reached with the stylus tilted, those it cannot reach, the face's area out of reach and, where
    there is some, that the deviations are judged over the rest."""
    if not getattr(points, "Probe", ""):
        return []
    reached = np.isfinite(np.array([tuple(a) for a in points.Axes], dtype=float)).all(axis=1)
    return [
        ("Probe", probe_text(json.loads(points.Probe))),
        ("Points reached tilted", int(sum(points.Tilted)), "tilted"),
        ("Points the probe cannot reach", int(np.count_nonzero(~reached)), "unreached"),
        ("Area out of reach (mm^2)", points.UnreachedArea.Value, "unreached_mm2"),
    ] + ([("Deviations judged over", "the part of the face the probe reaches")] if points.UnreachedArea.Value > 0 else [])


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
    coordinates as text to 0.1 um, approach vectors to 6 decimals, parameters to 6 significant
    digits; the deviation a number in mm (shown in micrometres by write_deviation_report)."""
    header = ("Label", "X (mm)", "Y (mm)", "Z (mm)", "I", "J", "K", "U", "V", "Deviation")
    return [header] + [
        (label, *(f"{c:.4f}" for c in p), *(f"{c:.6f}" for c in n), f"{u:.6g}", f"{v:.6g}", _figure(d))
        for label, p, n, u, v, d in zip(points.Labels, points.Points, points.Normals,
                                        points.U, points.V, points.Deviation)
    ]


PLAN_COLUMNS = ("Face", "Area (mm^2)", "N", "Max deviation", "Local bound", "Tolerance met", "Notes")


def write_plan_report(sheet, plan, moves=None):
    """The per-part table of a plan in a spreadsheet: a title, the goal, one row per face and a
    row for the part (points in all, the worst face's deviation); below, for a plan made with a
    probe, the probe and, given its path (moves: a ProbeMoves), the path's length (mm), the
    measuring time (s), the head orientations and the tip changes as numbers. Area, N, maximum and bound are numbers (the deviations in mm,
    shown in micrometres; empty where there is none)."""
    goal = (f"tolerance {plan.tolerance:g} mm" if plan.tolerance is not None else f"{plan.budget} points")
    head = [("CMM sampling plan",), ("Goal", goal), ("Strategy", plan.strategy), (), PLAN_COLUMNS]
    rows = list(head)
    for face in plan.faces:
        rows.append((face.name, float(face.area), face.n, _figure(face.maximum), _figure(face.bound),
                     face.met_text, face.notes))
    rows.append(("Part", float(plan.area), plan.n_total, _figure(plan.worst), "",
                 "", f"{len(plan.refused)} faces without points" if plan.refused else ""))
    table = range(len(head) + 1, len(rows) + 1)
    rows += _probe_rows(plan.probe, moves)
    write_rows(sheet, rows)
    in_micrometres(sheet, "DE", table)
    sheet.setStyle("A1", "bold")
    sheet.setStyle("A5:G5", "bold")
    fit_columns(sheet, [row[:6] for row in rows])
    sheet.setColumnWidth("G", NOTES_WIDTH)


INSPECTION_COLUMNS = ("Label", "Face", "Nominal X (mm)", "Nominal Y (mm)", "Nominal Z (mm)", "Measured X (mm)",
                      "Measured Y (mm)", "Measured Z (mm)", "Aligned X (mm)", "Aligned Y (mm)", "Aligned Z (mm)",
                      "Deviation", "Band")
BAND_TEXTS = {-2: "OUT below", -1: "near below", 0: "in", 1: "near above", 2: "OUT above"}


def write_inspection_report(sheet, points):
    """The inspection report of measured points (cmmsampling.document.inspections): the summary
    (profile and what it is, tolerance, zone offset, verdict, the expanded uncertainty and ISO
    14253-1's decision, points outside the zone, alignment, its 4 x 4 matrix measured -> CAD) with
    aliases (n, profile_mm, tolerance_mm, zone_offset_mm, verdict, uncertainty_mm, decision,
    outside, moved_mm), the motions the points do not hold, the datums, each face's profile where
    there are several,
    then one row per point: label, face, nominal, measured (as read from the file), aligned, the
    signed deviation, and its band. The figures in mm (the deviations included) are numbers shown
    in micrometres, as in the deviation report."""
    clear_cells(sheet)
    bands = np.array(points.Bands, dtype=int)
    matrix = points.AlignmentPlacement.toMatrix()
    summary = [
        ("Inspection report",),
        ("Measured file", points.MeasuredFile or "(points given in the console)"),
        ("Points", len(points.Labels), "n"),
        ("Profile", points.Profile.Value, "profile_mm"),
        ("Profile is", getattr(points, "ProfileKind", "") or "the form (floated)"),
        ("Tolerance", points.Tolerance.Value if points.Tolerance.Value > 0 else "none", "tolerance_mm"),
        ("Zone offset (UZ)", points.ZoneOffset.Value, "zone_offset_mm"),
        ("Verdict", points.Verdict, "verdict"),
        ("Expanded uncertainty U (k = 2)", points.Uncertainty.Value if getattr(points, "Uncertainty", 0) else "none",
         "uncertainty_mm"),
        ("Decision (ISO 14253-1)", getattr(points, "Decision", ""), "decision"),
        ("Points outside the zone", int(np.count_nonzero(np.abs(bands) == 2)), "outside"),
        ("Alignment", points.Alignment + (f", locked {', '.join(points.Locked)}" if points.Locked else "")),
        ("Moved the points by up to", points.MovedBy.Value, "moved_mm"),
        ("Motions the points do not hold", ", ".join(getattr(points, "FreeMotions", [])) or "none"),
    ] + [("Transform (measured -> CAD)" if row == 0 else "", *(f"{matrix.A[4 * row + column]:.9g}"
                                                               for column in range(4))) for row in range(4)]
    notes = [("Datum" if index == 0 else "", line) for index, line in enumerate(getattr(points, "Datums", []))]
    notes += [("Face profile", line) for line in points.FaceProfiles if len(points.FaceProfiles) > 1]
    notes += [("Note", note) for note in points.Notes]
    table = [INSPECTION_COLUMNS] + [
        (label, face, *(f"{c:.4f}" for c in nominal), *(f"{c:.4f}" for c in measured),
         *(f"{c:.4f}" for c in aligned), _figure(d), BAND_TEXTS[band])
        for label, face, nominal, measured, aligned, d, band in zip(
            points.Labels, points.Faces, points.Nominal, points.Measured, points.Points, points.Deviation, bands)]
    rows = [row[:5] if len(row) == 5 else row[:2] for row in summary] + notes + [()] + table
    write_rows(sheet, rows)
    name_figures(sheet, summary, [entry[2] for entry in summary
                                  if len(entry) == 3 and entry[2].endswith("_mm") and not isinstance(entry[1], str)])
    header = len(rows) - len(points.Labels)
    sheet.setStyle("A1", "bold")
    sheet.setStyle(f"A{header}:M{header}", "bold")
    sheet.setAlignment(f"C{header}:L{len(rows)}", "right")
    in_micrometres(sheet, "L", range(header + 1, len(rows) + 1))
    fit_columns(sheet, [row for row in rows if row not in notes])


def fit_columns(sheet, rows):
    """Widen each column of a spreadsheet to its longest entry among rows (tuples of cell
    values, from column A), so that no header is cut; widths within COLUMN_WIDTHS."""
    longest = {}
    for values in rows:
        for column, value in zip(REPORT_COLUMNS, values):
            longest[column] = max(longest.get(column, 0), len(_shown_text(value)))
    for column, characters in longest.items():
        width = CHARACTER_PIXELS * characters + COLUMN_PADDING
        sheet.setColumnWidth(column, int(min(max(width, COLUMN_WIDTHS[0]), COLUMN_WIDTHS[1])))


def _shown_text(value):
    """About the text a cell shows for a value: a number with two decimals and room for a unit."""
    if isinstance(value, (float, np.floating)):
        return f"{value:.2f} mm^2"
    return str(value)


def _probe_rows(probe, moves):
    """The plan report's rows on its probe (none without one) and its path (when given)."""
    if probe is None:
        return []
    rows = [(), ("Probe", f"{probe.ball_diameter:g} mm ball, {probe.stylus_length:g} mm stylus "
                          f"({probe.stylus_diameter:g} mm), {probe.body_diameter:g} mm body")]
    if moves is not None:
        rows += [("Probe path", float(moves.travel), "mm of moves between the points, "
                  f"{moves.detours} over the clearance plane"),
                 ("Measuring time", float(moves.seconds), "s, estimated from the CMM's speeds and the head's "
                  "index moves"),
                 ("Orientations", moves.orientations, "head orientations the points are measured with"),
                 ("Tip changes", moves.tip_changes, "changes of orientation along the path (index moves)")]
    return rows


def _figure(value):
    """A deviation in mm as a number ('' for NaN)."""
    return "" if not np.isfinite(value) else float(value)


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
