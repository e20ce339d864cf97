"""A QIF 3.0 measurement plan from probe points (a face's SamplingResult or a PartPlan, as the
PointSet :func:`cmmsampling.export` writes).

What goes where (docs/qif.md tells why):

- the part's name: ``Product/PartSet/Part/Header/Name``; the CMM and its probe (a spherical tip
  of the ball's diameter): ``MeasurementResources``;
- per face a point-defined surface feature: the nominal's ``DefiningPoints`` (each point and
  its vector out of the material, numbered in probe order) and, for the CMM, the item's
  ``NominalPointSet`` of ``MeasurePoint`` targets in probe order; the point labels, which QIF
  points cannot carry, as the item's attribute ``pointLabels`` (a JSON list);
- per face a surface profile characteristic where a tolerance is given (QIF requires its
  ``ToleranceValue``; without a tolerance there is none);
- the plan: one ``CoordinateMeasureFeatureMethod`` per face (N, the strategy and the
  substitute's expected maximum deviation as attributes), an ``OrderedPlanRoot`` measuring the
  faces in probe order and then evaluating the characteristics; a collision-free probe path,
  which QIF 3 plans have no element for, as the attribute ``probePath`` (our namespace);
- the sampling rule: ``Rules`` with a point-defined surface rule (N, the strategy as a
  user-defined strategy, least-squares fitting).
"""
from __future__ import annotations

import json
from dataclasses import dataclass

import numpy as np

from .datum_frame import datum_definitions, framed_profile, reference_frame
from .xml import QIFWriter, decimal, extension, extension_child, new_qpid, numbers

APPLICATION = "cmmsampling"
# The source a PartPlan's points state unless the caller names the part (cmmsampling.formats.exporting).
PLAN_SOURCE = "part plan"
DEFAULT_FACE = "face"


def face_groups(point_set):
    """[(face name, rows (k,) int)] in the order of each face's first point: a plan's faces, or
    the one face of a result (named by its source, e.g. 'Body:Face3' -> 'Face3')."""
    if point_set.faces is None:
        source = str(point_set.metadata.get("source", "")) or DEFAULT_FACE
        return [(source.rsplit(":", 1)[-1] or DEFAULT_FACE, np.arange(len(point_set)))]
    names = list(dict.fromkeys(point_set.faces))
    faces = np.array(point_set.faces, dtype=object)
    return [(name, np.flatnonzero(faces == name)) for name in names]


def part_name(metadata):
    """The part's name: the source before its face ('bracket.step:Face3' -> 'bracket.step'), a
    part plan's source as given (its file, e.g. 'bracket.step'), else 'part'."""
    source = str(metadata.get("source", ""))
    if ":" in source:
        return source.rsplit(":", 1)[0]
    return source if source and source != PLAN_SOURCE else "part"


def header(doc, description):
    """Header/Application naming the program, and a Description."""
    element = doc.add(doc.root, "Header")
    doc.add(doc.add(element, "Application"), "Name", APPLICATION)
    doc.add(element, "Description", description)


def resources(doc, ball_radius, probe):
    """MeasurementResources: a CMM and, for a stated ball radius (mm), its probe with a
    spherical tip of twice the radius (probe: the run's Probe as a dict, its sizes as attributes).
    Returns [CMM id] or [CMM id, probe id]."""
    holder = doc.add(doc.root, "MeasurementResources")
    devices = doc.add(holder, "MeasurementDevices", n=1)
    cmm, device = doc.with_id(devices, "CartesianCMM")
    doc.add(cmm, "Name", "CMM")
    if ball_radius <= 0:
        return [device]
    sensors = doc.add(holder, "DetachableSensors", n=1)
    sensor_element, sensor = doc.with_id(sensors, "SimpleTactileProbeSensor")
    doc.add(sensor_element, "Name", f"ball {2 * ball_radius:g} mm")
    if probe:
        doc.attributes(sensor_element, [("D1", f"{key}_mm" if key != "max_tilt" else f"{key}_deg", decimal(float(value)))
                                        for key, value in probe.items() if isinstance(value, (int, float))])
    doc.add(doc.add(sensor_element, "TipEndGeometry"), "TipEndGeometryEnum", "SPHERE")
    doc.add(sensor_element, "TipEndDiameter", decimal(2.0 * ball_radius))
    doc.id_list(cmm, "SensorIds", [sensor])
    return [device, sensor]


def features(doc, point_set, groups, resource_ids, labels_by_face=True):
    """Features: one point-defined surface definition, per face a nominal (DefiningPoints in probe
    order), an item and its NominalPointSet of MeasurePoint targets. Returns {face: (nominal id,
    item id, [MeasurePoint ids])}."""
    holder = doc.add(doc.root, "Features")
    definition = doc.with_id(doc.add(holder, "FeatureDefinitions", n=1), "PointDefinedSurfaceFeatureDefinition")[1]
    nominals = doc.add(holder, "FeatureNominals", n=len(groups))
    items = doc.add(holder, "FeatureItems", n=len(groups))
    sets = doc.add(holder, "NominalPointSets", n=len(groups))
    found = {}
    for name, rows in groups:
        nominal_element, nominal = doc.with_id(nominals, "PointDefinedSurfaceFeatureNominal")
        doc.add(nominal_element, "Name", name)
        doc.add(nominal_element, "FeatureDefinitionId", definition)
        defining = doc.add(nominal_element, "DefiningPoints", n=len(rows))
        for sequence, row in enumerate(rows, start=1):
            point = doc.with_id(defining, "DefiningPoint")[0]
            doc.add(point, "Point", numbers(point_set.points[row]))
            doc.add(point, "Normal", numbers(point_set.normals[row]))
            doc.add(point, "SequenceNumber", sequence)
        item_element, item = doc.with_id(items, "PointDefinedSurfaceFeatureItem")
        if labels_by_face:
            doc.attributes(item_element, [("Str", "pointLabels", json.dumps([point_set.labels[r] for r in rows]))])
        doc.add(item_element, "FeatureNominalId", nominal)
        doc.add(item_element, "FeatureName", name)
        target_element, target = doc.with_id(sets, "NominalPointSet", n=len(rows))
        doc.add(doc.add(item_element, "PointList", n=1), "WholePointSetId", target)
        checked = doc.add(doc.add(item_element, "DeterminationMode"), "Checked")
        doc.add(doc.add(checked, "CheckDetails"), "Measured")
        targets = []
        for row in rows:
            point, identifier = doc.with_id(target_element, "MeasurePoint")
            doc.add(point, "Point", numbers(point_set.points[row]))
            doc.add(point, "Normal", numbers(point_set.normals[row]))
            doc.add(point, "MeasurementDeviceId", resource_ids[0])
            if len(resource_ids) > 1:
                doc.add(point, "SensorId", resource_ids[1])
            targets.append(identifier)
        found[name] = (nominal, item, targets)
    return found


def characteristics(doc, groups, found, tolerance, standard, device):
    """Characteristics: a surface profile definition of the tolerance (mm), per face a nominal and
    an item on its feature. Returns {face: characteristic item id}."""
    holder = doc.add(doc.root, "Characteristics")
    doc.add(holder, "FormalStandardId", standard)
    definitions = doc.add(holder, "CharacteristicDefinitions", n=1)
    definition_element, definition = doc.with_id(definitions, "SurfaceProfileCharacteristicDefinition")
    doc.add(definition_element, "ToleranceValue", decimal(float(tolerance)))
    nominals = doc.add(holder, "CharacteristicNominals", n=len(groups))
    items = doc.add(holder, "CharacteristicItems", n=len(groups))
    chosen = {}
    for name, _ in groups:
        nominal_element, nominal = doc.with_id(nominals, "SurfaceProfileCharacteristicNominal")
        doc.add(nominal_element, "CharacteristicDefinitionId", definition)
        doc.id_list(nominal_element, "FeatureNominalIds", [found[name][0]])
        item_element, item = doc.with_id(items, "SurfaceProfileCharacteristicItem")
        doc.add(item_element, "Name", f"{name} profile")
        doc.id_list(item_element, "FeatureItemIds", [found[name][1]])
        doc.id_list(item_element, "MeasurementDeviceIds", [device])
        doc.add(item_element, "CharacteristicNominalId", nominal)
        chosen[name] = item
    return chosen


def sampling_facts(metadata, name, count):
    """The attributes of a face's measuring method: the strategy, N and the substitute's expected
    maximum deviation (mm) where known."""
    entries = [("Str", "samplingStrategy", str(metadata.get("strategy", "given points"))),
               ("I1", "numberOfPoints", str(count))]
    maximum = metadata.get("max_deviation_mm", {}).get(name, metadata.get("max_mm"))
    if maximum is not None and np.isfinite(maximum):
        entries.append(("D1", "expectedMaxDeviation_mm", decimal(float(maximum))))
    return entries


def probe_path(point_set, order):
    """Our element for a probe path: per point (MeasurePoint id, in visiting order) the moves
    before it, leaving the last point and arriving at this one (ball centres, mm), and the
    probe's axis; then the move out of the last point."""
    path = extension("ProbePath", points=len(order))
    for index, (leaving, arriving) in enumerate(point_set.travel):
        move = extension_child(path, "Move", **({"to": order[index]} if index < len(order) else {"after": order[-1]}))
        if index < len(order) and point_set.axes is not None:
            move.set("axis", numbers(point_set.axes[index]))
        extension_child(move, "Leave", numbers(leaving)) if len(leaving) else None
        extension_child(move, "Arrive", numbers(arriving)) if len(arriving) else None
    return path


def plan(doc, point_set, groups, found, characteristic_items, resource_ids, rules_id, facts):
    """Plan: a measuring method per face, the ordered steps (each face, then the evaluation of
    the characteristics), the probe path where the points have one (an attribute of the ordered
    plan root: QIF 3 plans have no motion actions)."""
    holder = doc.add(doc.root, "Plan")
    doc.add(doc.add(holder, "RulesUsedQPId"), "ItemQPId", rules_id)
    methods = doc.add(holder, "ActionMethods", n=len(groups))
    method_ids = {}
    for name, rows in groups:
        method, method_ids[name] = doc.with_id(methods, "CoordinateMeasureFeatureMethod")
        doc.id_list(method, "ChosenResourceIds", resource_ids)
        doc.attributes(method, sampling_facts(point_set.metadata, name, len(rows)))
        doc.add(method, "NumberOfMeasurementPoints", len(rows))
    root = doc.add(holder, "OrderedPlanRoot")
    if point_set.travel is not None:
        visiting = [None] * len(point_set)
        for name, rows in groups:
            for row, target in zip(rows, found[name][2]):
                visiting[row] = target
        path = probe_path(point_set, visiting)
        path.set("travel_mm", decimal(float(facts.get("path_length_mm", 0.0))))
        doc.attributes(root, [("User", "probePath", path)])
    steps = doc.add(root, "Steps", n=len(groups) + bool(characteristic_items))
    for sequence, (name, _) in enumerate(groups, start=1):
        step = doc.add(steps, "NumberedPlanElement")
        doc.add(step, "SequenceNumber", sequence)
        measure = doc.add(step, "MeasureSpecifiedFeatures")
        doc.add(measure, "PreferredActionMethodId", method_ids[name])
        doc.id_list(measure, "PreferredResourceIds", resource_ids)
        doc.id_list(measure, "FeatureItemIds", [found[name][1]])
    if characteristic_items:
        step = doc.add(steps, "NumberedPlanElement")
        doc.add(step, "SequenceNumber", len(groups) + 1)
        doc.id_list(doc.add(step, "EvaluateSpecifiedCharacteristics"), "CharacteristicItemIds",
                    list(characteristic_items.values()))


def rules(doc, point_set, groups, rules_id):
    """Rules: the sampling rule for point-defined surfaces: N (each face's, or at least the fewest
    a face has where they differ), the strategy, a least-squares substitute and its expected
    maximum deviation (the worst face's)."""
    holder = doc.add(doc.root, "Rules")
    doc.add(doc.add(holder, "Version"), "ThisInstanceQPId", rules_id)
    feature_rules = doc.add(doc.add(holder, "FeatureRules"), "IfThenElseFeatureRules", n=1)
    metadata = point_set.metadata
    strategy = str(metadata.get("strategy", "given points")).replace(" ", "_")
    rule = doc.add(feature_rules, "IfThenPointDefinedSurfaceRule", name=f"cmmsampling {strategy}")
    counts = {len(rows) for _, rows in groups}
    doc.add(doc.add(rule, "ThenPoints"), "NumberOfPoints" if len(counts) == 1 else "MinPoints", min(counts))
    doc.add(doc.add(rule, "ThenPointStrategy"), "UserDefinedStrategy", strategy)
    fitting = doc.add(rule, "ThenFittingAlgorithm")
    worst = metadata.get("worst_max_mm", metadata.get("max_mm"))
    if worst is not None and np.isfinite(worst):
        doc.attributes(fitting, [("D1", "expectedMaxDeviation_mm", decimal(float(worst)))])
    doc.add(fitting, "SubstituteFeatureAlgorithmEnum", "LEASTSQUARES")


def document_facts(point_set, facts):
    """The document's own attributes: what the numbers mean (frame, contact points, order)."""
    entries = [("Str", "points", str(facts.get("points", "contact points on the face"))),
               ("Str", "frame", str(facts.get("frame", "global"))), ("Str", "order", str(facts.get("order", "")))]
    if "frame_origin_mm" in facts:
        entries.append(("D3", "frame_origin_mm", numbers(facts["frame_origin_mm"])))
    source = point_set.metadata.get("source")
    if source:
        entries.append(("Str", "source", str(source)))
    return entries


def product(doc, name):
    """Product with the part (its name in the part's Header); returns the Part element, which
    gets its FeatureNominalIds once the features exist."""
    part = doc.with_id(doc.add(doc.add(doc.root, "Product"), "PartSet", n=1), "Part")[0]
    doc.add(doc.add(part, "Header"), "Name", name)
    return part


@dataclass(frozen=True)
class PlannedDatum:
    """A datum of a plan: label ('A'), faces (('Face1',); a bore's halves ('Face43', 'Face44')),
    criterion (the inspection's default, tangent); measurement None (its points are the measured
    file's, planned on its faces)."""

    label: str
    faces: tuple
    criterion: str = "tangent"
    measurement: None = None

    @property
    def face(self) -> str:
        """Its faces' names, space-separated ('Face43 Face44')."""
        return " ".join(self.faces)


def planned_datums(point_set):
    """The PlannedDatums a point set's metadata states (``datums``: {label: face or faces},
    primary first) whose faces hold points; [] for none."""
    stated = point_set.datum_faces()
    return [PlannedDatum(label, stated[label]) for label in point_set.datum_rows()]


def write(point_set, facts, options):
    """The QIF 3.0 plan document (text) of a written PointSet (contact points in probe order),
    its facts (frame, the ball's radius, order) and the WriteOptions (the probe of a path)."""
    doc = QIFWriter()
    doc.attributes(doc.root, document_facts(point_set, facts))
    name = part_name(point_set.metadata)
    header(doc, f"Measurement plan: probe points on {name}")
    tolerance = point_set.metadata.get("tolerance_mm")
    standard = None if tolerance is None else doc.standard()
    doc.units()
    datums = planned_datums(point_set)
    defined = datum_definitions(doc, datums) if datums else []
    frame_id = reference_frame(doc, datums, defined, None) if datums else None
    resource_ids = resources(doc, float(facts.get("ball_radius_mm", 0.0)), options.probe)
    part = product(doc, name)
    groups = face_groups(point_set)
    found = features(doc, point_set, groups, resource_ids)
    doc.id_list(part, "FeatureNominalIds", [found[face][0] for face, _ in groups])
    for datum, (element, _) in zip(datums, defined):
        doc.id_list(element, "FeatureNominalIds", [found[name][0] for name in datum.faces if name in found])
    toleranced = [(face, rows) for face, rows in groups if face not in {name for datum in datums for name in datum.faces}]
    items = {} if tolerance is None else characteristics(doc, toleranced, found, tolerance, standard, resource_ids[0])
    if items and frame_id is not None:
        framed_profile(doc, 0.0, frame_id)
    rules_id = new_qpid()
    plan(doc, point_set, groups, found, items, resource_ids, rules_id, facts)
    rules(doc, point_set, groups, rules_id)
    return doc.text()
