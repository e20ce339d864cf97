"""QIF 3.0 results of an inspection (:class:`cmmsampling.inspection.judge.Inspection`): what
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
"""
from __future__ import annotations

import numpy as np

from ..pointset import PointSet
from .plan import characteristics, face_groups, features, header, product, resources
from .xml import QIFWriter, decimal, numbers

MACHINE_FRAME = "CMM"
CAD_FRAME = "CAD"


def nominal_point_set(inspection):
    """The planned side as a PointSet: the nominal points where planned, else each point's foot
    on the face, with the face's outward normals there, the labels and the faces."""
    nominal = np.array(inspection.nominal, dtype=float)
    missing = ~np.isfinite(nominal).all(axis=1)
    nominal[missing] = inspection.feet[missing]
    return PointSet(list(inspection.labels), nominal, np.asarray(inspection.normals, dtype=float),
                    faces=list(inspection.faces))


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


def status_of(passed):
    """PASS, FAIL, or (without a verdict: no tolerance) NOT_CALCULATED."""
    return {True: "PASS", False: "FAIL", None: "NOT_CALCULATED"}[passed]


def measured_sets(doc, parent, inspection, groups, found, transform_id, cad_id):
    """Per face the MeasuredPointSets as read and as aligned; returns {face: aligned set id}."""
    holder = doc.add(parent, "MeasuredPointSets", n=2 * len(groups))
    aligned_ids = {}
    for name, rows in groups:
        for points, frame in ((inspection.measured, ("TranformId", transform_id)),
                              (inspection.points, ("CoordinateSystemId", cad_id))):
            element, identifier = doc.with_id(holder, "MeasuredPointSet", count=len(rows))
            doc.add(element, frame[0], frame[1])
            doc.add(element, "Points", numbers(points[rows]))
            doc.add(element, "Compensated", "true")
            doc.add(doc.add(element, "MeasurePointNominalIds", n=len(rows)), "Ids", " ".join(found[name][2]))
            doc.add(element, "Deviations", numbers(inspection.deviations[rows]))
        aligned_ids[name] = identifier
    return aligned_ids


def feature_measurements(doc, holder, inspection, groups, found, set_ids):
    """Per face a point-defined surface measurement: its aligned points numbered as their nominals
    and the face's form profile; returns {face: measurement id}."""
    profiles, measured = inspection.face_profiles, {}
    for name, rows in groups:
        element, measured[name] = doc.with_id(holder, "PointDefinedSurfaceFeatureMeasurement")
        doc.add(element, "FeatureItemId", found[name][1])
        doc.add(doc.add(element, "PointList", n=1), "WholePointSetId", set_ids[name])
        defining = doc.add(element, "DefiningPoints", n=len(rows))
        for sequence, row in enumerate(rows, start=1):
            point = doc.with_id(defining, "DefiningPoint")[0]
            doc.add(point, "Point", numbers(inspection.points[row]))
            doc.add(point, "SequenceNumber", sequence)
        form = inspection.face_forms.get(name)
        doc.add(element, "Form", decimal(float(profiles[name] if form is None else form)))
    return measured


def characteristic_measurements(doc, parent, inspection, groups, items, measured):
    """With a tolerance, per face its profile (mm), worst deviations and verdict."""
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


def inspection_facts(inspection):
    """The document's attributes: the alignment, the zone's offset, the profile, the file read."""
    entries = [("Str", "alignment", inspection.alignment.method), ("D1", "zoneOffset_mm", decimal(inspection.zone_offset)),
               ("D1", "profile_mm", decimal(inspection.profile))]
    if inspection.measured_file:
        entries.append(("Str", "measuredFile", inspection.measured_file))
    entries.append(("Str", "profileIs", inspection.profile_kind))
    entries += [("Str", f"datum{datum.label}", datum.text()) for datum in inspection.datums]
    if inspection.uncertainty is not None:
        entries += [("D1", "expandedUncertainty_mm", decimal(inspection.uncertainty.expanded)),
                    ("D1", "coverageFactor", decimal(inspection.uncertainty.coverage)),
                    ("D1", "probingUncertainty_mm", decimal(inspection.uncertainty.probing)),
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
    transform_id, cad_id = transforms(doc, np.asarray(inspection.transform, dtype=float))
    resource_ids = resources(doc, 0.0, None)
    part_element = product(doc, part)
    nominal = nominal_point_set(inspection)
    groups = face_groups(nominal)
    found = features(doc, nominal, groups, resource_ids)
    doc.id_list(part_element, "FeatureNominalIds", [found[face][0] for face, _ in groups])
    items = {} if standard is None else characteristics(doc, groups, found, inspection.tolerance, standard,
                                                          resource_ids[0])
    top = doc.add(doc.root, "Results")
    results = doc.with_id(doc.add(top, "MeasurementResultsSet", n=1), "MeasurementResults")[0]
    features_holder = doc.add(results, "MeasuredFeatures", n=len(groups))
    set_ids = measured_sets(doc, results, inspection, groups, found, transform_id, cad_id)
    measured = feature_measurements(doc, features_holder, inspection, groups, found, set_ids)
    if items:
        characteristic_measurements(doc, results, inspection, groups, items, measured)
    actual = doc.add(results, "ActualTransforms", n=1)
    association = doc.add(doc.add(results, "CoordinateSystemActualTransformAssociations", n=1),
                          "CoordinateSystemActualTransformAssociation")
    doc.add(association, "ActualTransformId", add_transform(doc, actual, np.asarray(inspection.transform, float)))
    doc.add(association, "CoordinateSystemId", cad_id)
    status = status_of(inspection.passed)
    if inspection.decision is not None:
        status = {**DECISION_STATUS, "undecided": "UNKNOWN"}[inspection.decision]
    doc.add(doc.add(results, "InspectionStatus"), "InspectionStatusEnum", status)
    component_set = doc.add(doc.add(top, "ActualComponentSets", n=1), "ActualComponentSet", n=1)
    component, component_id = doc.with_id(component_set, "ActualComponent")
    doc.add(doc.add(component, "Status"), "InspectionStatusEnum", status)
    doc.id_list(results, "ActualComponentIds", [component_id])
    return doc.text()
