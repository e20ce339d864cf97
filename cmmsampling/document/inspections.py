"""Inspections in the document: the measured points, aligned to the CAD model and coloured by
their deviation's band in the tolerance zone, and the inspection report, added in one
transaction (one Undo removes them; a fault adds nothing).

The part is never moved: the alignment (measured -> CAD) is applied to the measured points and
shown as a placement. Lengths in mm.
"""
from __future__ import annotations

import json

import numpy as np

from ..geometry.freecad_env import import_part
from ..geometry.validation import InputError, InputTypeError
from ..inspection.align import Alignment
from ..inspection.datums import DatumFit
from ..formats.exporting import is_mbd_inspection
from ..inspection.result import Inspection, verdict_text, verdict_word
from ..inspection.uncertainty import NO_UNCERTAINTY, ProfileUncertainty
from .object_types import MEASURED_POINTS, in_document, is_measured_points
from .objects import TypedProxy
from .first_article import add_first_article_to_document
from .sheets import write_inspection_report
from .transaction import hide_results, recompute, transaction

Part = import_part()
import FreeCAD  # noqa: E402  (importable once import_part() has set the path)

NO_TOLERANCE = "no tolerance"


def add_inspection_to_document(inspection: Inspection, doc: FreeCAD.Document,
                               source: FreeCAD.DocumentObject | None = None) -> FreeCAD.DocumentObject:
    """Add an Inspection (cmmsampling.inspect) to ``doc`` in one transaction.

    source: the probe points or part plan's group the points were planned as (linked from the
    measured points), or None. Creates a group "Inspection <source> (<verdict>)" (ISO 14253-1's
    decision where an uncertainty was given, else PASS or FAIL) holding the
    "Measured points" (the aligned points as vertices, with their deviations, bands and the
    alignment) and the "Inspection report" spreadsheet; hides the earlier results' points,
    substitutes and measured points (Undo shows them again). Returns the group. A QIF MBD model's
    characteristics judged (an MbdInspection) become its first-article table instead
    (:func:`cmmsampling.document.first_article.add_first_article_to_document`: the sheet).
    """
    if is_mbd_inspection(inspection):
        return add_first_article_to_document(inspection, doc)
    if not isinstance(inspection, Inspection):
        raise InputTypeError(f"add_inspection_to_document takes an Inspection (cmmsampling.inspect), got a "
                             f"{type(inspection).__name__}")
    if source is not None and not in_document(source, doc):
        raise InputError("source must be the probe points or part plan in this document the points were planned "
                         "as, or None")
    with transaction(doc, "Add inspection"):
        group = doc.addObject("App::DocumentObjectGroup", "Inspection")
        hide_results(doc)
        for other in doc.Objects:
            if is_measured_points(other) and other.Visibility:
                other.Visibility = False
        points = make_measured_points(doc)
        report = doc.addObject("Spreadsheet::Sheet", "InspectionReport")
        report.Label = "Inspection report"
        group.addObjects([points, report])
        points.Source, points.Report = source, report
        write_inspection(points, inspection)
        group.Label = f"Inspection {source.Label if source is not None else 'face'} ({verdict_word(inspection)})"
        write_inspection_report(report, points)
        recompute(doc, [points, report])
    return group


def make_measured_points(doc):
    """A measured-points object (Part::FeaturePython), empty until :func:`write_inspection`."""
    obj = doc.addObject("Part::FeaturePython", "MeasuredPoints")
    MeasuredPoints(obj)
    obj.Label = "Measured points"
    if FreeCAD.GuiUp:
        from ..gui import inspection_view

        inspection_view.ViewProviderMeasuredPoints(obj.ViewObject)
    return obj


def write_inspection(points, inspection):
    """Copy an Inspection into a measured-points object."""
    vectors = lambda rows: [FreeCAD.Vector(*map(float, row)) for row in rows]  # noqa: E731
    points.Labels = list(inspection.labels)
    points.Faces = list(inspection.faces)
    points.Nominal = vectors(np.nan_to_num(inspection.nominal))
    points.Measured = vectors(inspection.measured)
    points.Points = vectors(inspection.points)
    points.Deviation = [float(d) for d in inspection.deviations]
    points.Bands = [int(b) for b in inspection.bands]
    points.Tolerance = 0.0 if inspection.tolerance is None else inspection.tolerance
    points.ZoneOffset = inspection.zone_offset
    points.Profile = inspection.profile
    points.FaceProfiles = face_lines(inspection)
    points.Verdict = verdict(inspection)
    points.Alignment = inspection.alignment.method
    points.Locked = list(inspection.alignment.locked)
    points.AlignmentPlacement = inspection.placement
    points.MovedBy = inspection.alignment.moved_mm
    points.FreeMotions = list(inspection.free_motions)
    points.MeasuredFile = inspection.measured_file
    points.Notes = list(inspection.notes)
    points.Normals = vectors(inspection.normals)
    points.FaceForms = {name: repr(form) for name, form in inspection.face_forms.items() if form is not None}
    points.ProfileKind = inspection.profile_kind
    points.Datums = [datum.text() for datum in inspection.datums]
    points.Uncertainty = inspection.profile_uncertainty or 0.0
    points.Decision = decision(inspection)
    points.Records = json.dumps({"datums": [datum.as_record() for datum in inspection.datums],
                                 "uncertainty": None if inspection.uncertainty is None
                                 else inspection.uncertainty.as_record(),
                                 "beyond_edges": list(inspection.beyond_edges)})


def face_lines(inspection):
    """'Face3: 0.0123 mm PASS' for each face judged (the verdict left out without a tolerance), with
    ', form 0.0101 mm aligned alone' where the face has a form profile of its own."""
    forms = inspection.face_forms
    spread = {} if inspection.uncertainty is None else inspection.uncertainty.faces
    return [f"{name}: {value:.4f} mm" + ("" if inspection.tolerance is None else
                                          f" {verdict_text(inspection.face_passed(value))}")
            + ("" if name not in spread else f", U {spread[name]:.4f} mm" + (
                "" if inspection.tolerance is None else f" {inspection.face_decision(name)}"))
            + ("" if forms.get(name) is None else f", form {forms[name]:.4f} mm aligned alone")
            for name, value in inspection.face_profiles.items()]


def decision(inspection):
    """ISO 14253-1's decision ('conforms', 'does not conform', 'undecided'), 'no tolerance', or
    that no uncertainty was given."""
    if inspection.uncertainty is None:
        return NO_UNCERTAINTY
    return NO_TOLERANCE if inspection.decision is None else inspection.decision


def verdict(inspection):
    """'PASS', 'FAIL' or NO_TOLERANCE."""
    return NO_TOLERANCE if inspection.passed is None else verdict_text(inspection.passed)


class MeasuredPoints(TypedProxy):
    """Proxy of the measured points of an inspection: N points measured on the part, aligned to
    the CAD model, with their signed deviations (+ out of the material) and bands in the
    tolerance zone (cmmsampling.inspection.result.BANDS).

    Properties: Labels, Faces (the face each was judged on); Points (aligned, mm), Measured (as
    read, mm), Nominal (planned, mm; 0 where none was planned); Deviation (mm); Bands (-2 .. 2);
    Tolerance (mm, 0 without one), ZoneOffset (mm), Profile (mm, 2 max |d - offset|), Verdict,
    FaceProfiles, FaceForms (each face aligned alone, mm); Alignment, Locked,
    AlignmentPlacement (measured -> CAD), MovedBy (mm), FreeMotions; MeasuredFile, Notes; Normals
    (the face's outward normal at each aligned point's foot); Source (the probe points or plan)
    and Report.
    """

    Type = MEASURED_POINTS
    PROPERTIES = (
        ("App::PropertyStringList", "Labels", "Measured", "Point labels, as in the measured file"),
        ("App::PropertyStringList", "Faces", "Measured", "The face each point was judged on"),
        ("App::PropertyVectorList", "Points", "Measured", "Measured points aligned to the CAD model (mm)"),
        ("App::PropertyVectorList", "Measured", "Measured", "Measured points as read from the file (mm)"),
        ("App::PropertyVectorList", "Nominal", "Measured", "Planned points (mm); 0 where none was planned"),
        ("App::PropertyFloatList", "Deviation", "Measured",
         "Signed distance from the CAD face along its normal (mm), + out of the material"),
        ("App::PropertyIntegerList", "Bands", "Measured",
         "Band in the tolerance zone: 0 in, +-1 near the limit, +-2 out (+ above the nominal)"),
        ("App::PropertyLength", "Tolerance", "Verdict", "Profile tolerance t (mm), 0 without one"),
        ("App::PropertyDistance", "ZoneOffset", "Verdict",
         "The tolerance zone's centre from the nominal (mm, + out of the material; ISO 1101 UZ)"),
        ("App::PropertyLength", "Profile", "Verdict", "Profile of the surface, form only: 2 max |d - offset| (mm)"),
        ("App::PropertyStringList", "FaceProfiles", "Verdict", "Each face's profile (mm) and verdict"),
        ("App::PropertyString", "Verdict", "Verdict", "PASS, FAIL or no tolerance"),
        ("App::PropertyString", "Alignment", "Alignment", "none, best_fit or min_max"),
        ("App::PropertyStringList", "Locked", "Alignment", "Degrees of freedom held fixed"),
        ("App::PropertyPlacement", "AlignmentPlacement", "Alignment",
         "The alignment, measured -> CAD, applied to the measured points (the part is not moved)"),
        ("App::PropertyLength", "MovedBy", "Alignment", "How far the alignment moved the points at most (mm)"),
        ("App::PropertyStringList", "FreeMotions", "Alignment",
         "The motions the points do not hold, kept where their labels put them (rx .. z about the points' centre)"),
        ("App::PropertyString", "MeasuredFile", "Measured", "The file the points were read from"),
        ("App::PropertyStringList", "Notes", "Measured", "What the pairing of the points found"),
        ("App::PropertyVectorList", "Normals", "Measured",
         "The face's outward normal at each aligned point's closest point on it"),
        ("App::PropertyMap", "FaceForms", "Verdict", "Each face's form profile aligned alone (mm), for several faces"),
        ("App::PropertyString", "ProfileKind", "Verdict",
         "What the profile is: the form, floated, or location and form relative to datums"),
        ("App::PropertyStringList", "Datums", "Alignment",
         "The datum reference frame, primary first: face, criterion, motions fixed, points, form"),
        ("App::PropertyLength", "Uncertainty", "Verdict",
         "The profile's expanded uncertainty U (k = 2, mm, Monte Carlo), 0 without one"),
        ("App::PropertyString", "Decision", "Verdict",
         "ISO 14253-1's decision with U as guard band: conforms, does not conform or undecided"),
        ("App::PropertyString", "Records", "Verdict", "The datums' fits and the uncertainty's figures (JSON)"),
    )

    def __init__(self, obj):
        obj.Proxy = self
        self.add_missing_properties(obj)
        obj.addProperty("App::PropertyLink", "Source", "Measured", "The probe points or part plan measured")
        obj.addProperty("App::PropertyLink", "Report", "Verdict", "The inspection report sheet")

    @classmethod
    def add_missing_properties(cls, obj):
        """The PROPERTIES an object lacks (one saved before they existed), added read-only."""
        for kind, name, group, doc in cls.PROPERTIES:
            if not hasattr(obj, name):
                obj.addProperty(kind, name, group, doc)
                obj.setEditorMode(name, 1)

    def inspection(self, obj):
        """The Inspection these properties hold (its results for :func:`cmmsampling.export`).
        InputError for an inspection saved before the normals were kept whose points were not
        all planned (their nominal is their foot on the face, which needs the normals)."""
        count = len(obj.Labels)
        array = lambda values: np.array([tuple(v) for v in values], dtype=float).reshape(-1, 3)  # noqa: E731
        nominal = array(obj.Nominal) if obj.Source is not None else np.full((count, 3), np.nan)
        normals = array(obj.Normals) if len(obj.Normals) == count else None
        if normals is None and obj.Source is None:
            raise InputError(f"{obj.Label} was saved before the inspection kept its normals; inspect the points "
                             "again to export its results")
        deviations = np.array(obj.Deviation, dtype=float)
        matrix = np.array(obj.AlignmentPlacement.toMatrix().A, dtype=float).reshape(4, 4)
        alignment = Alignment(matrix, obj.Alignment, tuple(obj.Locked), 0, float(obj.MovedBy.Value), deviations,
                              tuple(obj.FreeMotions))
        records = json.loads(obj.Records or "{}")
        spread = records.get("uncertainty")
        return Inspection(list(obj.Labels), nominal, array(obj.Measured), array(obj.Points), deviations, matrix,
                          alignment, obj.Tolerance.Value or None, list(obj.Faces), list(obj.Notes),
                          measured_file=obj.MeasuredFile, zone_offset=float(obj.ZoneOffset.Value),
                          face_forms={name: float(value) for name, value in obj.FaceForms.items()},
                          normals=normals, datums=[DatumFit.from_record(item) for item in records.get("datums", [])],
                          uncertainty=None if spread is None else ProfileUncertainty.from_record(spread),
                          beyond_edges=list(records.get("beyond_edges", [])))

    def execute(self, obj):
        """Shape: a compound of the aligned points as vertices."""
        obj.Shape = Part.makeCompound([Part.Vertex(p) for p in obj.Points])

    def onDocumentRestored(self, obj):
        self.add_missing_properties(obj)
        if FreeCAD.GuiUp:
            from ..gui import inspection_view

            inspection_view.attach_when_missing(obj)
