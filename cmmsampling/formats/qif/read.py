"""Points out of a QIF 3.0 document: the measured points of a results file (ours or another
program's), else the planned points of a plan.

Measured points, in this order of preference:

- ``MeasuredPointSet``\\ s: ours pair each point with its planned ``MeasurePoint``
  (``MeasurePointNominalIds``) and so with its label (the feature item's ``pointLabels``); of
  the sets that hold the same planned points (ours: as read and as aligned) the one as read is
  taken. Another program's sets are labelled by the feature that lists them
  (``<feature>_P<i>``, or the feature's name for a set of one point), which pair by order;
- the ``DefiningPoints`` of feature measurements;
- the ``Location`` of point and edge point feature measurements (labelled by the feature's name).

Points a CMM left uncompensated (``Compensated`` false, with a ``ProbeRadius``) are ball
centres: the metadata states the radius (``probe_radius_mm``). A document that does not parse,
is not QIF 3.0 or that the QIF 3.0 schemas refuse (where lxml can check) is refused in one line.
"""
from __future__ import annotations

import json
import xml.etree.ElementTree as ET

import numpy as np

from ...geometry.validation import InputError
from ..pointset import PointSet
from .schema import SchemaUnavailable, schema_errors
from .xml import tag


def parsed(text, path):
    """The root of a QIF 3.0 document's text, checked by the schemas where lxml is present;
    InputError naming the file and the first problem."""
    try:
        root = ET.fromstring(text.encode("utf-8"))
    except ET.ParseError as exc:
        raise InputError(f"{path}: not well-formed XML ({exc}); give a QIF 3.0 file") from None
    if root.tag != tag("QIFDocument"):
        raise InputError(f"{path}: not a QIF 3.0 document (its root element is {root.tag.split('}')[-1]!r} "
                         f"in {root.tag.split('}')[0].lstrip('{') or 'no namespace'}); give a QIF 3.0 file")
    try:
        errors = schema_errors(text)
    except SchemaUnavailable:
        errors = []
    if errors:
        raise InputError(f"{path}: the QIF 3.0 schemas refuse it ({errors[0]}; {len(errors)} errors in all); "
                         "correct the file or export it again")
    return root


def read(text, path="<text>"):
    """PointSet of a QIF document's text: its measured points (metadata ``qif``: 'results') or,
    without any, its planned contact points (``qif``: 'plan'); InputError for a document with
    neither."""
    root = parsed(text, path)
    document = QIFDocument(root)
    point_set = document.measured()
    if point_set is None:
        point_set = document.planned()
    if point_set is None:
        raise InputError(f"{path}: a QIF document with neither measured nor planned points (a results file of "
                         "statuses only?); give the QIF results file that holds the measured points")
    return point_set


def _floats(element, width=3):
    """The numbers of an element's text as an (M, width) array."""
    return np.array((element.text or "").split(), dtype=float).reshape(-1, width)


class QIFDocument:
    """A parsed QIF document: its elements by id, and the labels of planned points."""

    def __init__(self, root):
        self.root = root
        self.by_id = {element.get("id"): element for element in root.iter() if element.get("id")}
        self.labels = self._planned_labels()

    def find_all(self, path):
        """Elements at a path of QIF names ('Features/FeatureItems/*')."""
        return self.root.findall("/".join(part if part == "*" else tag(part) for part in path.split("/")))

    def _planned_labels(self):
        """{MeasurePoint or DefiningPoint id: (label, face)} from the feature items' point lists
        and the nominals' defining points, labels from ``pointLabels`` where written."""
        labels = {}
        for item in self.find_all("Features/FeatureItems/*"):
            name = item.findtext(tag("FeatureName"), "")
            written = self._point_labels(item)
            nominal = self.by_id.get(item.findtext(tag("FeatureNominalId"), ""))
            sets = [self.by_id.get(e.text) for e in item.iter(tag("WholePointSetId"))]
            for element in [s for s in sets if s is not None] + ([] if nominal is None else [nominal]):
                points = [p for p in element.iter() if p.tag in (tag("MeasurePoint"), tag("DefiningPoint"))]
                for index, point in enumerate(points):
                    label = written[index] if len(written) == len(points) else f"{name}_P{index + 1}"
                    labels[point.get("id")] = (label, name)
        return labels

    @staticmethod
    def _point_labels(item):
        """The labels we wrote on a feature item (its attribute ``pointLabels``), or []."""
        for attribute in item.iter(tag("AttributeStr")):
            if attribute.get("name") == "pointLabels":
                return [str(label) for label in json.loads(attribute.get("value", "[]"))]
        return []

    def measured(self):
        """The measured points as a PointSet (None where the document has none)."""
        sets = self.find_all("Results/MeasurementResultsSet/MeasurementResults/MeasuredPointSets/MeasuredPointSet")
        if sets:
            return self._from_sets(sets)
        defining = self.find_all("Results/MeasurementResultsSet/MeasurementResults/MeasuredFeatures/*")
        rows = [(p, m) for m in defining for p in m.iter(tag("DefiningPoint"))]
        if rows:
            return self._from_defining(rows)
        locations = [m for m in defining if m.tag in (tag("PointFeatureMeasurement"), tag("EdgePointFeatureMeasurement"))
                     and m.find(tag("Location")) is not None]
        if locations:
            names = [self._feature_name(m) or f"PT{index}" for index, m in enumerate(locations, start=1)]
            points = np.concatenate([_floats(m.find(tag("Location"))) for m in locations])
            return PointSet(names, points, np.full_like(points, np.nan), metadata={"qif": "results"})
        return None

    def _feature_name(self, measurement):
        """The FeatureName of a feature measurement's item ('' where none)."""
        item = self.by_id.get(measurement.findtext(tag("FeatureItemId"), ""))
        return "" if item is None else item.findtext(tag("FeatureName"), "")

    def _from_sets(self, sets):
        """PointSet of MeasuredPointSets: of sets holding the same planned points the first as
        read (with a TranformId), the others labelled by the feature that lists them."""
        chosen, seen = [], set()
        for element in sorted(sets, key=lambda s: s.find(tag("TranformId")) is None):
            ids = tuple(element.findtext(f"{tag('MeasurePointNominalIds')}/{tag('Ids')}", "").split())
            if ids and ids in seen:
                continue
            seen.add(ids)
            chosen.append((element, ids))
        chosen.sort(key=lambda pair: sets.index(pair[0]))
        listed = self._set_features()
        labels, faces, blocks, normals, deviations, radii = [], [], [], [], [], []
        for element, ids in chosen:
            if element.find(tag("Points")) is None:
                raise InputError("a QIF point set is stored in binary (BinaryPoints), which this reader does not take; "
                                 "export the points as text")
            points = _floats(element.find(tag("Points")))
            named = [self.labels.get(i) for i in ids] if len(ids) == len(points) else []
            if named and all(named):
                labels += [label for label, _ in named]
                faces += [face for _, face in named]
            else:
                name = listed.get(element.get("id"), f"SET{element.get('id')}")
                labels += [name] if len(points) == 1 else [f"{name}_P{i}" for i in range(1, len(points) + 1)]
                faces += [name] * len(points)
            blocks.append(points)
            given = element.find(tag("Normals"))
            normals.append(_floats(given) if given is not None else np.full_like(points, np.nan))
            deviation = element.find(tag("Deviations"))
            deviations.append(_floats(deviation, 1)[:, 0] if deviation is not None else np.full(len(points), np.nan))
            radii.append(0.0 if element.findtext(tag("Compensated"), "true").strip() in ("true", "1")
                         else float(element.findtext(tag("ProbeRadius"), "0") or 0.0))
        return self._point_set(labels, faces, blocks, normals, deviations, radii)

    def _set_features(self):
        """{MeasuredPointSet id: the name of the feature whose measurement lists it}."""
        listed = {}
        for measurement in self.find_all("Results/MeasurementResultsSet/MeasurementResults/MeasuredFeatures/*"):
            name = self._feature_name(measurement) or measurement.tag.split("}")[-1].replace("FeatureMeasurement", "")
            for reference in measurement.iter():
                if reference.tag.endswith("PointSetId") and reference.text:
                    listed.setdefault(reference.text.strip(), f"{name}{measurement.get('id')}")
        return listed

    def _point_set(self, labels, faces, blocks, normals, deviations, radii):
        """One PointSet of the blocks read; ball centres' radius in the metadata (one radius)."""
        metadata = {"qif": "results"}
        stated = {radius for radius in radii if radius > 0}
        if len(stated) > 1:
            raise InputError(f"the QIF point sets hold ball centres of {len(stated)} probe radii "
                             f"({', '.join(f'{r:g}' for r in sorted(stated))} mm); inspect each probe's points alone")
        if stated:
            if len(set(radii)) > 1:
                raise InputError("the QIF point sets mix compensated contact points and ball centres; inspect each "
                                 "kind alone")
            metadata["probe_radius_mm"] = stated.pop()
        if len(set(label.casefold() for label in labels)) < len(labels):
            labels = [f"P{i}" for i in range(1, len(labels) + 1)]
            metadata["labels"] = "by order"
        deviation = np.concatenate(deviations)
        return PointSet(labels, np.concatenate(blocks), np.concatenate(normals),
                        deviation=None if np.isnan(deviation).any() else deviation, metadata=metadata,
                        faces=faces)

    def _from_defining(self, rows):
        """PointSet of the DefiningPoints of feature measurements, labelled as their nominals."""
        labels, faces, points = [], [], []
        for point, measurement in rows:
            item = self.by_id.get(measurement.findtext(tag("FeatureItemId"), ""))
            nominal = None if item is None else self.by_id.get(item.findtext(tag("FeatureNominalId"), ""))
            sequence = int(point.findtext(tag("SequenceNumber"), "0"))
            planned = [] if nominal is None else list(nominal.iter(tag("DefiningPoint")))
            match = next((p for p in planned if int(p.findtext(tag("SequenceNumber"), "0")) == sequence), None)
            name = self._feature_name(measurement) or f"F{measurement.get('id')}"
            label, face = self.labels.get(None if match is None else match.get("id"), (f"{name}_P{sequence}", name))
            labels.append(label)
            faces.append(face)
            points.append(_floats(point.find(tag("Point"))))
        block = np.concatenate(points)
        return self._point_set(labels, faces, [block], [np.full_like(block, np.nan)], [np.full(len(block), np.nan)],
                               [0.0])

    def planned(self):
        """The planned contact points of the feature nominals' DefiningPoints with their vectors
        (None where there are none); the probe's ball radius where the plan names a spherical tip."""
        labels, faces, points, normals = [], [], [], []
        for nominal in self.find_all("Features/FeatureNominals/*"):
            name = nominal.findtext(tag("Name"), "") or f"F{nominal.get('id')}"
            for point in nominal.iter(tag("DefiningPoint")):
                label, face = self.labels.get(point.get("id"), (f"{name}_P{len(labels) + 1}", name))
                labels.append(label)
                faces.append(face)
                points.append(_floats(point.find(tag("Point"))))
                given = point.find(tag("Normal"))
                normals.append(_floats(given) if given is not None else np.full((1, 3), np.nan))
        if not labels:
            return None
        metadata = {"qif": "plan"}
        diameter = self.root.findtext(f".//{tag('SimpleTactileProbeSensor')}/{tag('TipEndDiameter')}")
        if diameter:
            metadata["ball_radius_mm"] = float(diameter) / 2.0
        return PointSet(labels, np.concatenate(points), np.concatenate(normals), metadata=metadata,
                        faces=faces if len(set(faces)) > 1 else None)
