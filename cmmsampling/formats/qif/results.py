"""QIF 3.0 results of an inspection (:class:`cmmsampling.inspection.result.Inspection`): what
``cmmsampling.export(inspection, "results.qif")`` writes.

The planned side is written as a plan's (:mod:`.plan`: the part, a point-defined surface
feature per face with its nominal points in the measured order, a surface profile
characteristic per face where a tolerance was given); then the alignment as a ``Transform``
(measured -> CAD, the common coordinate system ``CAD``, the machine's ``CMM``), and
``Results/MeasurementResultsSet/MeasurementResults`` with, per face:

- a ``PointDefinedSurfaceFeatureMeasurement``: the aligned points as its ``DefiningPoints``
  (numbered as their nominals), its form profile as ``Form``;
- two ``MeasuredPointSet``\\ s: the points as read (``TranformId``: the alignment takes them to the
  CAD frame) and as aligned (in ``CAD``), each point's nominal ``MeasurePoint`` id
  (``MeasurePointNominalIds``) and its signed deviation (``Deviations``, mm, + out of the
  material);
- with a tolerance, a ``SurfaceProfileCharacteristicMeasurement``: the profile (``Value``, mm),
  the worst deviations and PASS or FAIL;

and the part's status (PASS, FAIL, or NOT_CALCULATED without a tolerance), with the actual part.

With datums (``inspect(..., datums=...)``) the document is the whole record of the verdict:
each datum face is a feature like the toleranced ones (its nominal, its item, its measurement
with the datum's points as read and as aligned, their deviations and its form, no profile
characteristic), ``DatumDefinitions`` give each datum's label and its face's feature (the
attributes ``label``, ``face`` and ``points``: 'planned', its points taken from the measured
file, or 'own', brought with the datum), and one ``DatumReferenceFrame`` lists them in
precedence order with their criterion as the substitute feature algorithm (tangent: ONESIDED,
least squares: LEASTSQUARES); the profile characteristic's definition references it
(``DatumReferenceFrameId``) and states the zone offset as ISO's ``UnequallyDisposedZone``.
The document's attributes carry what the inspection was asked besides (``alignment``,
``lockedMotions``, ``zoneOffset_mm``, ``probingUncertainty_mm``, ``seed``) and the order the
measured file's points were judged in (``pointOrder``): :mod:`.record` reads them back, so that
the part can be judged again as it was.
"""
from __future__ import annotations

import json
from typing import NamedTuple

import numpy as np

from ..pointset import PointSet
from .datum_frame import datum_definitions, framed_profile, reference_frame
from .plan import characteristics, face_groups, features, header, product, resources
from .xml import QIFWriter, decimal, numbers

MACHINE_FRAME = "CMM"
CAD_FRAME = "CAD"


class Written(NamedTuple):
    """The points a results document holds, each datum's that kept them (primary first), then the
    toleranced ones: nominal, a PointSet of the N labels, the nominal points (N, 3) mm, the outward
    normals (N, 3) and each point's feature name (faces); measured (N, 3) mm as read, aligned
    (N, 3) mm in the CAD frame, deviations (N,) mm; groups [(feature name, rows)] in that order;
    forms {feature name: its form profile, mm}; datum_features {datum label: its feature name}."""

    nominal: PointSet
    measured: np.ndarray
    aligned: np.ndarray
    deviations: np.ndarray
    groups: list
    forms: dict
    datum_features: dict


def with_feet(nominal, aligned, deviations, normals):
    """Nominal points (N, 3) mm with the unplanned ones (NaN rows) replaced by their feet on the
    face, aligned (N, 3) mm less deviations (N,) mm along the outward normals (N, 3)."""
    nominal = np.array(nominal, dtype=float)
    missing = ~np.isfinite(nominal).all(axis=1)
    nominal[missing] = (aligned - deviations[:, None] * normals)[missing]
    return nominal


def nominal_point_set(inspection):
    """The planned side of the toleranced points as a PointSet: the nominal points where planned,
    else each point's foot on the face, with the face's outward normals there, the labels and
    the faces."""
    normals = np.asarray(inspection.normals, dtype=float)
    return PointSet(list(inspection.labels), with_feet(inspection.nominal, inspection.points, inspection.deviations,
                                                       normals), normals, faces=list(inspection.faces))


def datum_feature_names(inspection):
    """{datum label: the name of its feature}: its face's name, or 'Face1 (datum A)' where the
    name is already a toleranced face's or an earlier datum's (a datum that brought its own
    points to a toleranced face), for the datums that kept their points."""
    taken, names = set(inspection.faces), {}
    for fit in inspection.datums:
        if fit.measurement is not None:
            names[fit.label] = fit.face if fit.face not in taken else f"{fit.face} (datum {fit.label})"
            taken.add(names[fit.label])
    return names


def written_points(inspection):
    """The Written of an Inspection: its datums' points (those it kept) and its toleranced ones."""
    names = datum_feature_names(inspection)
    fits = [fit for fit in inspection.datums if fit.label in names]
    taken = [fit.measurement for fit in fits]
    matrix = np.asarray(inspection.transform, dtype=float)
    aligned = [measurement.measured @ matrix[:3, :3].T + matrix[:3, 3] for measurement in taken]
    toleranced = nominal_point_set(inspection)
    nominal = PointSet(
        [label for measurement in taken for label in measurement.labels] + toleranced.labels,
        np.vstack([with_feet(m.nominal, points, fit.deviations, m.normals)
                   for m, points, fit in zip(taken, aligned, fits)] + [toleranced.points]),
        np.vstack([measurement.normals for measurement in taken] + [toleranced.normals]),
        faces=[names[fit.label] for fit, m in zip(fits, taken) for _ in m.labels] + list(toleranced.faces))
    forms = {names[fit.label]: fit.form for fit in fits}
    forms.update({name: profile if inspection.face_forms.get(name) is None else inspection.face_forms[name]
                  for name, profile in inspection.face_profiles.items()})
    return Written(nominal, np.vstack([m.measured for m in taken] + [inspection.measured]),
                   np.vstack(aligned + [inspection.points]),
                   np.concatenate([fit.deviations for fit in fits] + [inspection.deviations]),
                   face_groups(nominal), forms, names)


def transforms(doc, matrix):
    """The alignment measured -> CAD as a top-level Transform, and the coordinate systems CMM (the
    machine's) and CAD (the common one). Returns (transform id, CAD id)."""
    transform_id = add_transform(doc, doc.add(doc.root, "Transforms", n=1), matrix)
    systems = doc.add(doc.root, "CoordinateSystems")
    definitions = doc.add(systems, "CoordinateSystemDefinitions", n=2)
    machine = doc.with_id(definitions, "CoordinateSystem")
    doc.add(machine[0], "Name", MACHINE_FRAME)
    cad = doc.with_id(definitions, "CoordinateSystem")
    doc.add(cad[0], "Name", CAD_FRAME)
    doc.add(systems, "CommonCoordinateSystemId", cad[1])
    doc.add(doc.add(systems, "MachineCoordinateSystem"), "CoordinateSystemId", machine[1])
    return transform_id, cad[1]


def add_transform(doc, parent, matrix):
    """A Transform of a (4, 4) rigid motion: X = XDirection x + YDirection y + ZDirection z +
    Origin (the rotation's columns); returns its id."""
    element, identifier = doc.with_id(parent, "Transform")
    rotation = doc.add(element, "Rotation")
    for column, name in enumerate(("XDirection", "YDirection", "ZDirection")):
        doc.add(rotation, name, numbers(matrix[:3, column]))
    doc.add(element, "Origin", numbers(matrix[:3, 3]))
    doc.add(element, "Name", "measured to CAD")
    return identifier


# A characteristic's status from ISO 14253-1's decision (cmmsampling.inspection.uncertainty).
DECISION_STATUS = {"conforms": "PASS", "does not conform": "FAIL", "undecided": "INDETERMINATE"}
# The part's status from the decision (InspectionStatusEnum has no INDETERMINATE).
PART_DECISION_STATUS = {**DECISION_STATUS, "undecided": "UNKNOWN"}


def status_of(passed):
    """PASS, FAIL, or (without a verdict: no tolerance) NOT_CALCULATED."""
    return {True: "PASS", False: "FAIL", None: "NOT_CALCULATED"}[passed]


def datum_features(doc, datums, defined, written, found):
    """Each datum definition's feature: the nominal of its face's feature (where it kept its points)."""
    for fit, (element, _) in zip(datums, defined):
        if fit.label in written.datum_features:
            doc.id_list(element, "FeatureNominalIds", [found[written.datum_features[fit.label]][0]])


def measured_sets(doc, parent, written, found, transform_id, cad_id):
    """Per feature the MeasuredPointSets as read and as aligned; returns {feature: aligned set id}."""
    holder = doc.add(parent, "MeasuredPointSets", n=2 * len(written.groups))
    aligned_ids = {}
    for name, rows in written.groups:
        for points, frame in ((written.measured, ("TranformId", transform_id)),
                              (written.aligned, ("CoordinateSystemId", cad_id))):
            element, identifier = doc.with_id(holder, "MeasuredPointSet", count=len(rows))
            doc.add(element, frame[0], frame[1])
            doc.add(element, "Points", numbers(points[rows]))
            doc.add(element, "Compensated", "true")
            doc.add(doc.add(element, "MeasurePointNominalIds", n=len(rows)), "Ids", " ".join(found[name][2]))
            doc.add(element, "Deviations", numbers(written.deviations[rows]))
        aligned_ids[name] = identifier
    return aligned_ids


def feature_measurements(doc, holder, written, found, set_ids):
    """Per feature a point-defined surface measurement: its aligned points numbered as their
    nominals and its form profile; returns {feature: measurement id}."""
    measured = {}
    for name, rows in written.groups:
        element, measured[name] = doc.with_id(holder, "PointDefinedSurfaceFeatureMeasurement")
        doc.add(element, "FeatureItemId", found[name][1])
        doc.add(doc.add(element, "PointList", n=1), "WholePointSetId", set_ids[name])
        defining = doc.add(element, "DefiningPoints", n=len(rows))
        for sequence, row in enumerate(rows, start=1):
            point = doc.with_id(defining, "DefiningPoint")[0]
            doc.add(point, "Point", numbers(written.aligned[row]))
            doc.add(point, "SequenceNumber", sequence)
        doc.add(element, "Form", decimal(float(written.forms[name])))
    return measured


def characteristic_measurements(doc, parent, inspection, groups, items, measured):
    """With a tolerance, per toleranced face (groups: [(face, rows of the inspection's points)])
    its profile (mm), worst deviations and verdict."""
    holder = doc.add(doc.add(parent, "MeasuredCharacteristics"), "CharacteristicMeasurements", n=len(groups))
    profiles = inspection.face_profiles
    for name, rows in groups:
        element = doc.with_id(holder, "SurfaceProfileCharacteristicMeasurement")[0]
        status = status_of(inspection.face_passed(profiles[name]))
        if inspection.face_decision(name) is not None:
            status = DECISION_STATUS[inspection.face_decision(name)]
        doc.add(doc.add(element, "Status"), "CharacteristicStatusEnum", status)
        doc.add(element, "CharacteristicItemId", items[name])
        doc.id_list(element, "FeatureMeasurementIds", [measured[name]])
        value = doc.add(element, "Value", decimal(profiles[name]))
        if inspection.uncertainty is not None:
            value.set("combinedUncertainty", decimal(inspection.uncertainty.faces[name] / inspection.uncertainty.coverage))
            value.set("meanError", decimal(abs(inspection.uncertainty.mean_shift)))
        doc.add(element, "WorstPositiveDeviation", decimal(float(inspection.deviations[rows].max())))
        doc.add(element, "WorstNegativeDeviation", decimal(float(inspection.deviations[rows].min())))


def point_order(inspection):
    """The labels of the measured file's points in the order the inspection judged them: each
    datum's that came from the file (primary first), then the toleranced ones."""
    return [label for fit in inspection.datums if fit.measurement is not None and not fit.measurement.own
            for label in fit.measurement.labels] + list(inspection.labels)


def inspection_facts(inspection):
    """The document's attributes: what the inspection was asked (alignment, locked motions, zone
    offset, probing uncertainty and seed), what it found (profile, datums, uncertainty, decision),
    the file read and the order its points were judged in."""
    entries = [("Str", "alignment", inspection.alignment.method),
               ("Str", "lockedMotions", json.dumps(list(inspection.alignment.locked))),
               ("D1", "zoneOffset_mm", decimal(inspection.zone_offset)),
               ("D1", "profile_mm", decimal(inspection.profile))]
    if inspection.measured_file:
        entries.append(("Str", "measuredFile", inspection.measured_file))
    entries.append(("Str", "pointOrder", json.dumps(point_order(inspection))))
    entries.append(("Str", "profileIs", inspection.profile_kind))
    entries += [("Str", f"datum{datum.label}", datum.text()) for datum in inspection.datums]
    if inspection.uncertainty is not None:
        entries += [("D1", "expandedUncertainty_mm", decimal(inspection.uncertainty.expanded)),
                    ("D1", "coverageFactor", decimal(inspection.uncertainty.coverage)),
                    ("D1", "probingUncertainty_mm", decimal(inspection.uncertainty.probing)),
                    ("I1", "seed", int(inspection.uncertainty.seed)),
                    ("Str", "uncertaintyMethod", inspection.uncertainty.text())]
    entries.append(("Str", "decision", inspection.decision_text()))
    entries += [("Str", f"note{index}", note) for index, note in enumerate(inspection.notes, start=1)]
    return entries


def write_results(inspection, part="part"):
    """The QIF 3.0 results document (text) of an Inspection; part: the part's name."""
    doc = QIFWriter()
    doc.attributes(doc.root, inspection_facts(inspection))
    header(doc, f"Inspection results: {len(inspection.labels)} measured points on {part}")
    standard = None if inspection.tolerance is None else doc.standard()
    doc.units()
    datums = list(inspection.datums)
    defined = datum_definitions(doc, datums) if datums else []
    transform_id, cad_id = transforms(doc, np.asarray(inspection.transform, dtype=float))
    frame_id = reference_frame(doc, datums, defined, cad_id) if datums else None
    resource_ids = resources(doc, 0.0, None)
    part_element = product(doc, part)
    written = written_points(inspection)
    found = features(doc, written.nominal, written.groups, resource_ids)
    datum_features(doc, datums, defined, written, found)
    doc.id_list(part_element, "FeatureNominalIds", [found[face][0] for face, _ in written.groups])
    toleranced = face_groups(nominal_point_set(inspection))
    items = {}
    if standard is not None:
        items = characteristics(doc, toleranced, found, inspection.tolerance, standard, resource_ids[0])
        framed_profile(doc, inspection.zone_offset, frame_id)
    top = doc.add(doc.root, "Results")
    results = doc.with_id(doc.add(top, "MeasurementResultsSet", n=1), "MeasurementResults")[0]
    features_holder = doc.add(results, "MeasuredFeatures", n=len(written.groups))
    set_ids = measured_sets(doc, results, written, found, transform_id, cad_id)
    measured = feature_measurements(doc, features_holder, written, found, set_ids)
    if items:
        characteristic_measurements(doc, results, inspection, toleranced, items, measured)
    actual = doc.add(results, "ActualTransforms", n=1)
    association = doc.add(doc.add(results, "CoordinateSystemActualTransformAssociations", n=1),
                          "CoordinateSystemActualTransformAssociation")
    doc.add(association, "ActualTransformId", add_transform(doc, actual, np.asarray(inspection.transform, float)))
    doc.add(association, "CoordinateSystemId", cad_id)
    status = status_of(inspection.passed)
    if inspection.decision is not None:
        status = PART_DECISION_STATUS[inspection.decision]
    doc.add(doc.add(results, "InspectionStatus"), "InspectionStatusEnum", status)
    component_set = doc.add(doc.add(top, "ActualComponentSets", n=1), "ActualComponentSet", n=1)
    component, component_id = doc.with_id(component_set, "ActualComponent")
    doc.add(doc.add(component, "Status"), "InspectionStatusEnum", status)
    doc.id_list(results, "ActualComponentIds", [component_id])
    return doc.text()
